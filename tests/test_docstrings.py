"""The public API is documented in numpydoc form: every function and class ``import nlobs`` offers, and every one
in a module's ``__all__`` (the command line and the paper reproductions aside), that takes parameters has a
``Parameters`` (classes: or ``Attributes``) section naming each of them, and so do the methods of the one observer
protocol. Enumerations and exceptions are described in prose. (A missing section, or a parameter the section
forgets, fails here.)"""

from __future__ import annotations

import enum
import importlib
import inspect
import pkgutil
import re

import pytest

import nlobs
from nlobs.observers.base import CorrectingObserver, Observer


def _public() -> list[tuple[str, object]]:
    out, seen = [], set()
    for name, module in sorted(nlobs._LAZY.items()):
        obj = getattr(importlib.import_module(module), name)
        if callable(obj) and not inspect.ismodule(obj):
            out.append((f"{module}.{name}", obj))
            seen.add(id(obj))
    for info in pkgutil.walk_packages(nlobs.__path__, "nlobs."):
        if ".cli" in info.name or ".papers" in info.name:
            continue
        mod = importlib.import_module(info.name)
        for name in getattr(mod, "__all__", []):
            obj = getattr(mod, name, None)
            if callable(obj) and id(obj) not in seen and getattr(obj, "__module__", "") == info.name:
                out.append((f"{info.name}.{name}", obj))
                seen.add(id(obj))
    out = [(n, o) for n, o in out if _has_signature(o)]  # protocols and some builtins have none
    out += [(f"Observer.{m}", getattr(Observer, m)) for m in ("init", "rhs", "estimate")]
    out.append(("CorrectingObserver.correct", CorrectingObserver.correct))
    return out


def _has_signature(obj: object) -> bool:
    try:
        inspect.signature(obj)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return False
    return True


def _section(doc: str, title: str) -> str | None:
    m = re.search(rf"^{title}\n-+\n(.*?)(?:\n\n[A-Z][A-Za-z ]+\n-+\n|\Z)", doc, flags=re.S | re.M)
    return None if m is None else m.group(1)


@pytest.mark.parametrize(("name", "obj"), _public(), ids=lambda v: v if isinstance(v, str) else "")
def test_public_callable_documents_its_parameters(name: str, obj: object) -> None:
    sig = inspect.signature(obj)  # type: ignore[arg-type]
    params = [p for p in sig.parameters.values() if p.name not in ("self", "cls") and not p.name.startswith("_")
              and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    if inspect.isclass(obj) and issubclass(obj, (BaseException, enum.Enum)):
        params = []  # exceptions and enumerations: described in the class docstring's prose
    if not params:
        return
    doc = inspect.getdoc(obj) or ""
    sec = _section(doc, "Parameters") or (_section(doc, "Attributes") if inspect.isclass(obj) else None)
    assert sec is not None, f"{name}: no numpydoc Parameters section"
    documented = set()
    for line in sec.splitlines():
        m = re.match(r"^(\*{0,2}[A-Za-z_][\w, *]*?)\s*(?::|$)", line)
        if m and not line.startswith(" "):
            documented |= {s.strip().lstrip("*") for s in m.group(1).split(",")}
    missing = [p.name for p in params if p.name not in documented]
    assert not missing, f"{name}: parameters not in its Parameters section: {missing}"
