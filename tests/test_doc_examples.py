"""The Examples sections of the docstrings run: every module of ``src/nlobs`` with a ``>>>`` line is doctested
(examples marked ``# doctest: +SKIP`` excepted), so an example that stops working fails the suite."""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "nlobs"
MODULES = sorted(".".join(("nlobs", *p.relative_to(SRC).with_suffix("").parts)).removesuffix(".__init__")
                 for p in SRC.rglob("*.py") if ">>>" in p.read_text(encoding="utf-8"))


def test_the_examples_are_found() -> None:
    assert {"nlobs.simulate.loop", "nlobs.simulate.consistency", "nlobs.linear.frequency", "nlobs._frozen"} <= set(
        MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_the_examples_of_a_module_run(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False,
                             report=True)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"


def _public_names() -> list[tuple[str, object]]:
    """Every class and function the API reference renders (``docs/hooks.py``: the names ``import nlobs`` offers and
    each package's ``__all__``), ``sweep`` among them."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("nlobs_docs_hooks", SRC.parents[1] / "docs" / "hooks.py")
    assert spec is not None and spec.loader is not None
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    out = []
    for rows in hooks.api_objects().values():
        for module, path in rows:
            obj: object = importlib.import_module(module)
            for part in path[len(module) + 1:].split("."):
                obj = getattr(obj, part)
            out.append((path, obj))
    assert "nlobs.simulate.sweep.sweep" in dict(out) and "nlobs.simulate.loop.simulate" in dict(out)
    return out


@pytest.mark.parametrize(("name", "obj"), _public_names(), ids=lambda v: v if isinstance(v, str) else "")
def test_every_public_name_has_a_runnable_example(name: str, obj: object) -> None:
    """Every name of the API reference shows its use in an Examples section that this suite runs."""
    import inspect

    target = obj
    doc = inspect.getdoc(target) or ""
    assert "\nExamples\n--------\n" in doc, f"{name}: no Examples section"
    assert ">>> " in doc.split("\nExamples\n--------\n", 1)[1], f"{name}: its Examples section has no >>> line"
    assert "doctest: +SKIP" not in doc, f"{name}: a skipped example"
    module = inspect.getmodule(target)
    assert module is not None and module.__name__ in MODULES, f"{name}: its module is not doctested"
