"""Workflows: one call per CLI command, each returning a frozen report with ``to_dict()`` and ``summary()``.

The command line parses its options, calls one workflow and prints the report; the same calls serve
scripts and notebooks. See :mod:`nlobs.workflows.verdict` for how a report says what it concluded.

* :func:`design_drift_report`, :func:`simulate_drift`: the observer (3.1) of Dalla Mora, Germani &
  Manes (:mod:`nlobs.workflows.design_drift`);
* :func:`design_pinv_report`, :func:`simulate_pinv`: Röbenack's Moore–Penrose observer (7), (17)
  (:mod:`nlobs.workflows.design_pinv`);
* :func:`gamma_sweep` → :class:`GammaSweep`: Sec. 3.2 of Grip, Saberi & Johansen, design and
  simulate for decreasing ``γ`` (:mod:`nlobs.workflows.gamma_sweep`).

Importing this package is cheap: the workflows themselves (and with them the observers, the
solvers and the simulation layer) are imported on first use of their names.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from nlobs.workflows.verdict import Verdict

if TYPE_CHECKING:
    from nlobs.workflows.design_drift import (
        DriftDesignReport,
        DriftSimulation,
        design_drift_report,
        simulate_drift,
    )
    from nlobs.workflows.design_pinv import (
        PinvDesignReport,
        design_pinv_report,
        simulate_pinv,
    )
    from nlobs.workflows.gamma_sweep import GammaSweep, GammaSweepRow, gamma_sweep

#: Names imported on first use, and the module that holds each.
_LAZY: dict[str, str] = {
    **dict.fromkeys(
        ("DriftDesignReport", "DriftSimulation", "design_drift_report", "simulate_drift"),
        "nlobs.workflows.design_drift"),
    **dict.fromkeys(
        ("PinvDesignReport", "design_pinv_report", "simulate_pinv"), "nlobs.workflows.design_pinv"),
    **dict.fromkeys(("GammaSweep", "GammaSweepRow", "gamma_sweep"), "nlobs.workflows.gamma_sweep"),
}

__all__ = [
    "DriftDesignReport",
    "DriftSimulation",
    "GammaSweep",
    "GammaSweepRow",
    "PinvDesignReport",
    "Verdict",
    "design_drift_report",
    "design_pinv_report",
    "gamma_sweep",
    "simulate_drift",
    "simulate_pinv",
]


def __getattr__(name: str) -> Any:
    """Import a workflow's module on first use of one of its names (PEP 562)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nlobs.workflows' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
