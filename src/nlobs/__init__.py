"""nlobs: design, certify and simulate nonlinear state observers.

The names a script needs, importable from the top (``from nlobs import load_model, simulate``);
each is imported on first use (PEP 562), so ``import nlobs`` loads neither NumPy nor SymPy.

Plants and models
    :func:`load_model` (a model file or a shipped name), :func:`shipped_models`,
    :class:`Continuous`, :class:`Discrete`, :class:`LinearSystem`, :class:`DiscreteUISystem`; a feedback law
    :class:`ControlLaw` (a model file's ``[controller]``) and state bounds :class:`StateBounds` (``[constraints]``).
The observer protocol and the observers
    :class:`Observer`, :class:`CorrectingObserver`; :class:`LuenbergerObserver`,
    :class:`CascadeObserver` (Grip, Saberi & Johansen, (3)), :class:`DriftObserver` (Dalla Mora,
    Germani & Manes, (3.1)), :class:`PinvObserver` and :class:`ByrnesIsidoriObserver` (Röbenack,
    (7), (17)), :class:`SetValuedObserver` (Khajenejad & Yong, (10)–(15)),
    :class:`DiscreteLipschitzObserver`, :class:`UnknownInputEKF`, :class:`EKF` and :class:`UKF` (any plant, and their
    smoother :func:`rts_smooth`), :class:`ParticleFilter` and :class:`MHE` (moving-horizon estimation),
    :class:`GnssInsObserver` (Grip, Saberi & Johansen, (22)/(24)), :class:`ScheduledGnssInsObserver` (the same
    with a scheduled attitude gain Γ(t)) and the navigation :class:`ExtendedKalmanFilter`; for sampled
    outputs :class:`OutputPredictor` (any continuous observer with the inter-sample output predictor of
    Karafyllis & Kravaris) and :class:`ImpulsiveObserver` (Raff & Allgöwer).
The loops and the result
    :func:`simulate` (plant and observer together: the simulation subpackage ``nlobs.simulate``,
    which called is its loop), :func:`run_observer` (an observer on recorded measurements),
    :func:`estimate` (every observer of a model file, designed as ``nlobs simulate`` designs it, on a logged run
    of the plant), :class:`SimulationResult`.
Gains and certificates
    ``design_*`` and ``verify_*`` for each method; every certificate satisfies :class:`Certificate`
    and reports its conditions as :class:`Check` values.
Workflows
    One call per command of the ``nlobs`` command line, each returning a frozen report:
    :func:`analyze_model`, :func:`design_drift_observer`, :func:`design_pinv_observer`,
    :func:`design_setvalued_observer`, :func:`simulate_setvalued_observer`, :func:`gnss_ins_demo`.
Errors
    :class:`NlobsError` and its typed subclasses (:mod:`nlobs.errors`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from nlobs._lazy import lazy_exports

if TYPE_CHECKING:
    __version__: str
    from nlobs.checks import Check
    from nlobs.errors import (
        AssumptionViolated,
        CertificateError,
        DesignError,
        DesignInfeasible,
        DimensionError,
        ModelError,
        ModelFileError,
        NlobsError,
        NonFiniteError,
        SimulationDiverged,
        UnknownNameError,
    )
    from nlobs.navigation.ekf import ExtendedKalmanFilter
    from nlobs.navigation.gnss_ins import GnssInsObserver
    from nlobs.navigation.schedule import ScheduledGnssInsObserver
    from nlobs.observers import (
        ByrnesIsidoriObserver,
        CascadeObserver,
        ConstantGainObserver,
        CorrectingObserver,
        DiscreteLipschitzObserver,
        DriftObserver,
        EKF,
        ImpulsiveObserver,
        LuenbergerObserver,
        MHE,
        Observer,
        OutputPredictor,
        ParticleFilter,
        PinvObserver,
        SetValuedObserver,
        UKF,
        UnknownInputEKF,
        rts_smooth,
    )
    from nlobs import simulate
    from nlobs.methods.estimation import estimate
    from nlobs.export import compile_observer, export_observer
    from nlobs.simulate import SimulationResult, monte_carlo, run_observer
    from nlobs.synthesis import (
        Certificate,
        design_cascade_gain,
        design_discrete_lipschitz_gain,
        design_drift_gain,
        design_observer_gain,
        design_setvalued,
        verify_discrete_lipschitz_gain,
        verify_drift_gain,
        verify_observer_gain,
        verify_setvalued,
    )
    from nlobs.systems import (
        Continuous,
        ControlLaw,
        Discrete,
        DiscreteUISystem,
        LinearSystem,
        StateBounds,
        load_model,
        shipped_models,
    )
    from nlobs.workflows import (
        analyze_model,
        design_drift_observer,
        design_pinv_observer,
        design_setvalued_observer,
        gnss_ins_demo,
        simulate_setvalued_observer,
    )

#: Every public name, and the module that holds it (imported on first use).
_LAZY: dict[str, str] = {
    "Check": "nlobs.checks",
    **dict.fromkeys(("AssumptionViolated", "CertificateError", "DesignError", "DesignInfeasible", "DimensionError",
                     "ModelError", "ModelFileError", "NlobsError", "NonFiniteError", "SimulationDiverged",
                     "UnknownNameError"), "nlobs.errors"),
    **dict.fromkeys(("compile_observer", "export_observer"), "nlobs.export"),
    "ExtendedKalmanFilter": "nlobs.navigation.ekf",
    "GnssInsObserver": "nlobs.navigation.gnss_ins",
    "ScheduledGnssInsObserver": "nlobs.navigation.schedule",
    **dict.fromkeys(("ByrnesIsidoriObserver", "CascadeObserver", "ConstantGainObserver", "CorrectingObserver",
                     "DiscreteLipschitzObserver", "DriftObserver", "EKF", "ImpulsiveObserver", "LuenbergerObserver", "MHE",
                     "Observer", "OutputPredictor", "ParticleFilter", "PinvObserver", "SetValuedObserver", "UKF",
                     "UnknownInputEKF", "rts_smooth"),
                    "nlobs.observers"),
    **dict.fromkeys(("SimulationResult", "run_observer", "monte_carlo"), "nlobs.simulate"),
    "simulate": "nlobs.simulate",
    "estimate": "nlobs.methods.estimation",
    **dict.fromkeys(("Certificate", "design_cascade_gain", "design_discrete_lipschitz_gain", "design_drift_gain",
                     "design_observer_gain", "design_setvalued", "verify_discrete_lipschitz_gain",
                     "verify_drift_gain", "verify_observer_gain", "verify_setvalued"), "nlobs.synthesis"),
    **dict.fromkeys(("Continuous", "ControlLaw", "Discrete", "DiscreteUISystem", "LinearSystem", "StateBounds",
                     "load_model", "shipped_models"), "nlobs.systems"),
    **dict.fromkeys(("analyze_model", "design_drift_observer", "design_pinv_observer", "design_setvalued_observer",
                     "gnss_ins_demo", "simulate_setvalued_observer"), "nlobs.workflows"),
}

__all__ = sorted([*_LAZY, "__version__"])


_lazy_getattr, _lazy_dir = lazy_exports(__name__, _LAZY)


def _version() -> str:
    """The installed distribution's version (``importlib.metadata`` is imported on first use: the command line's
    help needs none of it)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("nlobs")
    except PackageNotFoundError:  # pragma: no cover - a source tree that was never installed
        return "0+unknown"


def __getattr__(name: str) -> Any:
    if name == "__version__":
        globals()["__version__"] = value = _version()
        return value
    return _lazy_getattr(name)


def __dir__() -> list[str]:
    return sorted({*_lazy_dir(), "__version__"})
