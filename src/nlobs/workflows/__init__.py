"""Workflows: one call per CLI command, each returning a frozen report with ``to_dict()`` and ``summary()``.

The command line parses its options, calls one workflow and prints the report; the same calls serve
scripts and notebooks. See :mod:`nlobs.workflows.verdict` for how a report says what it concluded.

* :func:`design_drift_observer` (``nlobs design drift``) → :class:`DriftWorkflowReport`:
  the observer (3.1) of Dalla Mora, Germani & Manes (:mod:`nlobs.workflows.design_drift`);
* :func:`design_pinv_observer` (``nlobs design pinv``) → :class:`PinvWorkflowReport`:
  Röbenack's Moore–Penrose observer (7), (17) (:mod:`nlobs.workflows.design_pinv`);
* :func:`analyze_model` (``nlobs analyze``) → :class:`AnalysisReport`: the linear and nonlinear
  structural tests of a model (:mod:`nlobs.workflows.analyze`);
* :func:`design_setvalued_observer` (``nlobs design setvalued``) → :class:`SetValuedDesignReport` and
  :func:`simulate_setvalued_observer` (``nlobs simulate setvalued``) → :class:`SetValuedStudyReport`:
  the set-valued input-and-state observer of Khajenejad & Yong (:mod:`nlobs.workflows.setvalued`);
* :func:`gnss_ins_demo` (``nlobs demo gnss-ins``) → :class:`DemoReport`: the GNSS/INS example of
  Grip, Saberi & Johansen, Sec. 5, against an EKF (:mod:`nlobs.workflows.demo`);
* :func:`gnss_ins_monte_carlo` (``nlobs simulate gnss-ins``) → :class:`GnssInsStudyReport`: Monte Carlo
  flights of the same observer (24) from random initial errors, here or on Dask
  (:mod:`nlobs.workflows.gnss_ins_study`);
* :func:`gamma_sweep` → :class:`GammaSweep`: Sec. 3.2 of Grip, Saberi & Johansen, design and
  simulate for decreasing ``γ`` (:mod:`nlobs.workflows.gamma_sweep`);
* the inputs a caller hands over as plain values (:mod:`nlobs.workflows.inputs`):
  :class:`SimulationRequest`, :func:`box_from_numbers` (:class:`BoxError`), :func:`symbolic_model`,
  :func:`escape_unsafe` for text that reaches a terminal, and :func:`jsonable` (and :func:`with_schema`, the
  ``schema_version`` key) for what is printed as JSON, :func:`document_schema` (with :func:`one_of`) for the JSON
  Schema of a report, :func:`atomic_write_text` for the files a command writes.

Importing this package is cheap (the command line imports it when it starts): every name is
imported on first use, the workflows (and with them the observers, the solvers and the
simulation layer) only when a command runs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from nlobs._lazy import lazy_exports

if TYPE_CHECKING:
    from nlobs._io import atomic_write_text, jsonable, with_schema
    from nlobs._schema import document_schema, one_of
    from nlobs._validate import escape_unsafe
    from nlobs.workflows.analyze import AnalysisReport, analyze_model
    from nlobs.workflows.demo import DemoConfig, DemoReport, gnss_ins_demo
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
    from nlobs.workflows.gnss_ins_study import GnssInsStudyReport, gnss_ins_monte_carlo
    from nlobs.workflows.gamma_sweep import GammaSweep, GammaSweepRow, gamma_sweep
    from nlobs.workflows.inputs import BoxError, SimulationRequest, box_from_numbers, symbolic_model
    from nlobs.workflows.setvalued import (
        MonteCarloStudy,
        SetValuedDesignReport,
        SetValuedStudyReport,
        design_setvalued_observer,
        monte_carlo,
        simulate_setvalued_observer,
    )
    from nlobs.workflows.verdict import Verdict

#: Names imported on first use, and the module that holds each.
_LAZY: dict[str, str] = {
    **dict.fromkeys(("AnalysisReport", "analyze_model"), "nlobs.workflows.analyze"),
    **dict.fromkeys(("DemoConfig", "DemoReport", "gnss_ins_demo"), "nlobs.workflows.demo"),
    **dict.fromkeys(("MonteCarloStudy", "SetValuedDesignReport", "SetValuedStudyReport", "design_setvalued_observer",
                     "monte_carlo", "simulate_setvalued_observer"), "nlobs.workflows.setvalued"),
    **dict.fromkeys(
        ("DriftDesignReport", "DriftSimulation", "DriftWorkflowReport", "design_drift_observer", "design_drift_report",
         "simulate_drift"), "nlobs.workflows.design_drift"),
    **dict.fromkeys(
        ("PinvDesignReport", "PinvWorkflowReport", "design_pinv_observer", "design_pinv_report", "simulate_pinv"),
        "nlobs.workflows.design_pinv"),
    **dict.fromkeys(("GnssInsStudyReport", "gnss_ins_monte_carlo"), "nlobs.workflows.gnss_ins_study"),
    **dict.fromkeys(("GammaSweep", "GammaSweepRow", "gamma_sweep"), "nlobs.workflows.gamma_sweep"),
    **dict.fromkeys(("BoxError", "SimulationRequest", "box_from_numbers", "symbolic_model"), "nlobs.workflows.inputs"),
    "escape_unsafe": "nlobs._validate",
    "Verdict": "nlobs.workflows.verdict",
    "jsonable": "nlobs._io",
    "with_schema": "nlobs._io",
    "atomic_write_text": "nlobs._io",
    "document_schema": "nlobs._schema",
    "one_of": "nlobs._schema",
}

__all__ = [
    "AnalysisReport",
    "BoxError",
    "DemoConfig",
    "DemoReport",
    "DriftDesignReport",
    "DriftSimulation",
    "DriftWorkflowReport",
    "GammaSweep",
    "GammaSweepRow",
    "GnssInsStudyReport",
    "MonteCarloStudy",
    "PinvDesignReport",
    "PinvWorkflowReport",
    "SetValuedDesignReport",
    "SetValuedStudyReport",
    "SimulationRequest",
    "Verdict",
    "analyze_model",
    "box_from_numbers",
    "design_drift_observer",
    "design_drift_report",
    "design_pinv_observer",
    "design_pinv_report",
    "design_setvalued_observer",
    "escape_unsafe",
    "gamma_sweep",
    "gnss_ins_monte_carlo",
    "gnss_ins_demo",
    "atomic_write_text",
    "document_schema",
    "jsonable",
    "one_of",
    "with_schema",
    "monte_carlo",
    "simulate_drift",
    "simulate_pinv",
    "simulate_setvalued_observer",
    "symbolic_model",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
