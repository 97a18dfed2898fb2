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
