"""Imports on first use: a package's names (PEP 562, the one ``__getattr__`` / ``__dir__`` pair) and whole modules.

A command imports only what it uses: CVXPY (with SciPy's statistics, a third of a second) is loaded by the
first LMI a command solves, not by ``import nlobs.synthesis``.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["LazyModule", "lazy_exports"]


def lazy_exports(package: str, names: Mapping[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package``, whose ``names`` live in the modules they map to.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    names : mapping of str to str
        Each public name and the dotted module that holds it; a name mapped to its own subpackage
        (``"simulate": "nlobs.simulate"`` in ``nlobs``) is that subpackage.

    Returns
    -------
    tuple of callables
        ``(__getattr__, __dir__)``: the first imports the module of a name on first use and keeps
        the value in the package's namespace; an unknown name is an ``AttributeError``.
    """
    namespace = sys.modules[package].__dict__

    def __getattr__(name: str) -> Any:
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        imported = importlib.import_module(module)
        value = imported if module == f"{package}.{name}" else getattr(imported, name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(names))

    return __getattr__, __dir__


class LazyModule:
    """A module imported on its first attribute access: ``cp = LazyModule("cvxpy")`` then ``cp.Variable(...)``.

    Parameters
    ----------
    name : str
        The module's dotted name.

    Examples
    --------
    >>> np_ = LazyModule("numpy")
    >>> float(np_.sqrt(4.0))
    2.0
    """

    __slots__ = ("_name",)

    def __init__(self, name: str) -> None:
        object.__setattr__(self, "_name", name)

    def __getattr__(self, attr: str) -> Any:
        return getattr(importlib.import_module(self._name), attr)

    def __setattr__(self, attr: str, value: Any) -> None:
        raise AttributeError(f"LazyModule({self._name!r}) is read-only")

    def __repr__(self) -> str:
        return f"LazyModule({self._name!r})"
