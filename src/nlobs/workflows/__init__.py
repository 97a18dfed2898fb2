"""Workflows: one call per CLI command, each returning a frozen report with ``to_dict()`` and ``summary()``.

The command line parses its options, calls one workflow and prints the report; the same calls serve
scripts and notebooks. See :mod:`nlobs.workflows.verdict` for how a report says what it concluded.

* :func:`design_drift_observer` (``nlobs design drift``) → :class:`DriftWorkflowReport`:
  the observer (3.1) of Dalla Mora, Germani & Manes (:mod:`nlobs.workflows.design_drift`);
* :func:`design_pinv_observer` (``nlobs design pinv``) → :class:`PinvWorkflowReport`:
  Röbenack's Moore–Penrose observer (7), (17) (:mod:`nlobs.workflows.design_pinv`);
* :func:`gamma_sweep` → :class:`GammaSweep`: Sec. 3.2 of Grip, Saberi & Johansen, design and
  simulate for decreasing ``γ`` (:mod:`nlobs.workflows.gamma_sweep`);
* the inputs a caller hands over as plain values (:mod:`nlobs.workflows.inputs`):
  :class:`SimulationRequest`, :func:`box_from_numbers` (:class:`BoxError`), :func:`symbolic_model`,
  :func:`escape_unsafe` for text that reaches a terminal, and :func:`jsonable` for what is printed
  as JSON.

Importing this package is cheap (the command line imports it when it starts): every name is
imported on first use, the workflows (and with them the observers, the solvers and the
simulation layer) only when a command runs.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from nlobs._io import jsonable
    from nlobs.workflows.design_drift import (
        DriftDesignReport,
        DriftSimulation,
        DriftWorkflowReport,
        design_drift_observer,
        design_drift_report,
        simulate_drift,
    )
    from nlobs.workflows.design_pinv import (
        PinvDesignReport,
        PinvWorkflowReport,
        design_pinv_observer,
        design_pinv_report,
        simulate_pinv,
    )
    from nlobs.workflows.gamma_sweep import GammaSweep, GammaSweepRow, gamma_sweep
    from nlobs.workflows.inputs import BoxError, SimulationRequest, box_from_numbers, escape_unsafe, symbolic_model
    from nlobs.workflows.verdict import Verdict

#: Names imported on first use, and the module that holds each.
_LAZY: dict[str, str] = {
    **dict.fromkeys(
        ("DriftDesignReport", "DriftSimulation", "DriftWorkflowReport", "design_drift_observer", "design_drift_report",
         "simulate_drift"), "nlobs.workflows.design_drift"),
    **dict.fromkeys(
        ("PinvDesignReport", "PinvWorkflowReport", "design_pinv_observer", "design_pinv_report", "simulate_pinv"),
        "nlobs.workflows.design_pinv"),
    **dict.fromkeys(("GammaSweep", "GammaSweepRow", "gamma_sweep"), "nlobs.workflows.gamma_sweep"),
    **dict.fromkeys(("BoxError", "SimulationRequest", "box_from_numbers", "escape_unsafe", "symbolic_model"),
                    "nlobs.workflows.inputs"),
    "Verdict": "nlobs.workflows.verdict",
    "jsonable": "nlobs._io",
}

__all__ = [
    "BoxError",
    "DriftDesignReport",
    "DriftSimulation",
    "DriftWorkflowReport",
    "GammaSweep",
    "GammaSweepRow",
    "PinvDesignReport",
    "PinvWorkflowReport",
    "SimulationRequest",
    "Verdict",
    "box_from_numbers",
    "design_drift_observer",
    "design_drift_report",
    "design_pinv_observer",
    "design_pinv_report",
    "escape_unsafe",
    "gamma_sweep",
    "jsonable",
    "simulate_drift",
    "simulate_pinv",
    "symbolic_model",
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
