"""Observer methods: how each kind of observer is chosen, checked and designed for a model file.

* :mod:`nlobs.methods.problem` — :class:`Problem`, what every design reads from a model file, by
  one rule, each value with its source (region, ``x0``, horizon, known input, input bound ``μ``);
* :mod:`nlobs.methods.base` — :class:`Method` (``applies``, ``design``) and :class:`Design` (the
  observer, its certificate, its premises, the parameters used, a description; ``to_dict()`` is the
  ``design`` object of every command's JSON);
* :mod:`nlobs.methods.registry` — the one list of methods every command reads;
* one module per method: :mod:`~nlobs.methods.drift`, :mod:`~nlobs.methods.pinv`,
  :mod:`~nlobs.methods.luenberger`, :mod:`~nlobs.methods.cascade`, :mod:`~nlobs.methods.kalman`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from nlobs._lazy import lazy_exports

if TYPE_CHECKING:
    from nlobs.methods.base import Design, Method
    from nlobs.methods.problem import Problem, problem
    from nlobs.methods.registry import REGISTRY, get, names

_LAZY: dict[str, str] = {
    **dict.fromkeys(("Design", "Method"), "nlobs.methods.base"),
    **dict.fromkeys(("Problem", "problem"), "nlobs.methods.problem"),
    **dict.fromkeys(("REGISTRY", "get", "names"), "nlobs.methods.registry"),
}

__all__ = ["REGISTRY", "Design", "Method", "Problem", "get", "names", "problem"]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
