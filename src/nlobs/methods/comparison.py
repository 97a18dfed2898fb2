r"""Every applicable observer on the same noisy, multi-rate Monte Carlo runs (the engine of ``nlobs simulate MODEL``).

A user's own plant, measured by real sensors: :func:`compare_observers` designs each chosen observer with its
method's defaults (or the options given), runs all of them on the same runs — the same truth, the
same initial estimates, the same sensor and process noise — and reports, per observer, what an
engineer compares: RMS error per state (after a settling time, and overall), final error,
convergence time, runs that blew up (named), cost per step, and for a certified design whether the
run stayed inside what its certificate covers.

The observers (``OBSERVERS``):

* ``drift`` — (3.1) of Dalla Mora, Germani & Manes with the gain of Remark 2.11 on the region
  (:data:`nlobs.methods.drift.DRIFT`), ``α = 1`` and the input bound ``μ`` of
  (2.17) the largest ``‖u(t)‖`` of the run's known input; skipped when drift-observability fails on
  the region or the design is not usable;
* ``pinv`` — Röbenack's Moore–Penrose observer (7), (17) with the high-gain placement of (10)
  (:data:`nlobs.methods.pinv.PINV`); skipped when A1 or A5 fails;
* ``luenberger`` — a copy of the plant with constant output injection
  (:class:`~nlobs.observers.luenberger.ConstantGainObserver`; for a linear model the Luenberger
  observer) with the gain of LMIs (14), (15) of Grip, Saberi & Johansen for the linearisation at
  ``x0``: poles left of ``−α``, the analytic centre at ``γ = γn =`` :data:`LUENBERGER_GAMMA`;
* ``cascade`` — the observer (9)–(10) (or (17)–(18)) of Grip, Saberi & Johansen, for a model file with a
  ``[cascade]`` table (a nonlinear Σ₁ whose unmeasured output drives a linear Σ₂,
  :mod:`nlobs.systems.cascade_file`), with the gain of
  :data:`nlobs.methods.cascade.CASCADE` (the file's ``method`` and ``gamma``);
  skipped with the reason for a model without one;
* ``ekf``, ``ukf`` — the continuous-discrete (discrete for discrete models) extended and unscented
  Kalman filters (:class:`~nlobs.observers.EKF`, :class:`~nlobs.observers.UKF`), tuned from the
  sensor and process noise tables: ``R`` from the sensors, ``Q`` the process noise (or
  :data:`DEFAULT_FILTER_Q` per second without one), ``P0 = diag(initial_error_std²)``.

How the runs are made: the truth starts at ``x0`` in every run; run ``i`` starts the observers at
``x̂0 = x0 + e_i``, ``e_i ~ N(0, diag(initial_error_std²))`` (or at the given ``x_hat0``). Each
observer is simulated with its plant by :func:`nlobs.simulate.simulate` (RK4, one batch of all
runs, ``divergence="keep"``) with the same seed, so the truth and every noise sample are the same
for every observer (the loop draws them from the plant alone).

Metrics (over the runs that did not diverge): ``rms_error[i] = √mean(e_i²)`` over runs and saved
times ``t ≥ settle``; ``rms_error_norm = √mean(‖e‖²)`` likewise; ``final_error_norm`` the RMS over
runs of ``‖e(T)‖``; ``convergence_time`` the median over runs of the first time at which ``‖e‖``
(averaged over a moving window of 1 % of the run) reaches ``max(5 % of ‖e(0)‖, 2 ×`` its final level``)``,
the final level being the median of that average over the last quarter of the run; ``inf`` (JSON
``null``) for a run that never does, or whose threshold is not below half of ``‖e(0)‖`` (the error never
fell well below where it started). Later bursts (an outage, a disturbance) do not move it: the plots do. A run *diverged* when its estimate became
non-finite or its error exceeded :data:`BLOWUP` times ``1 + max‖x‖`` of its truth.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike


from nlobs._typing import Array
from nlobs._validate import as_count, positive
from nlobs.errors import (
    AssumptionViolated,
    DesignError,
    DimensionError,
    InvalidArgumentError,
    ModelError,
    NlobsError,
    SimulationDiverged,
    StudyFailed,
    UnknownNameError,
)
from nlobs._schema import BOOLEAN, INTEGER, NUMBER, STRING, Node, Record, array, mapping, nullable, one_of
from nlobs.methods.base import DESIGN_JSON, Design
from nlobs.methods.closed_loop import (
    CLOSED_LOOP_JSON,
    CLOSED_LOOP_SETUP_JSON,
    CONSTRAINTS_JSON,
    ESTIMATE_BOUNDS_JSON,
    bounds_report,
    closed_loop_metrics,
    estimate_bounds,
    loop_setup,
    warnings_of,
)
from nlobs.methods.kalman import DEFAULT_FILTER_Q, noise_matrix
from nlobs.methods.problem import Problem, problem
from nlobs.methods.registry import get as get_method
from nlobs.methods.registry import names
from nlobs.simulate.consistency import CONSISTENCY_JSON, Consistency, filter_consistency
from nlobs.simulate.coverage import VIOLATION_JSON, monitor
from nlobs.simulate.loop import PlantRun, observe, simulate, simulate_plant
from nlobs.simulate.result import SimulationResult, with_run_axis
from nlobs.systems.linear import LinearSystem
from nlobs.systems.controller import control_period_steps
from nlobs.systems.modelfile import load_scenario
from nlobs.systems.scenario import Scenario
from nlobs.systems.sensors import MeasurementGroup
from nlobs.systems.symbolic import SymbolicModel
from nlobs.checks import Verdict
from nlobs.methods.problem import MAX_SIMULATION_STEPS, as_region, model_label

__all__ = [
    "BLOWUP",
    "DEFAULT_FILTER_Q",
    "OBSERVERS",
    "STOCHASTIC",
    "ComparisonReport",
    "DivergedRun",
    "ObserverOutcome",
    "compare_observers",
    "design_observer",
    "method_options",
]

#: The observers ``nlobs simulate MODEL`` knows, in the order they are reported (:mod:`nlobs.methods.registry`).
OBSERVERS: tuple[str, ...] = names(simulated=True)
#: Those it runs when none are named (the particle filter and moving-horizon estimation only when named).
DEFAULT_OBSERVERS: tuple[str, ...] = names(simulated=True, default=True)
#: Where the observers' steps run: NumPy, or their generated C (``--backend c``).
BACKENDS: tuple[str, ...] = ("python", "c")
#: A run diverged when its error exceeds this many times ``1 + max‖x‖`` of its truth (or is not finite).
BLOWUP = 1e6
#: Most values (runs × saved times × states, per array) one comparison keeps.
MAX_SAVED_VALUES = 50_000_000
#: Saved instants per run (the step grid is thinned to about this many).
SAVED_POINTS = 2000


#: One run that diverged (``diverged_runs`` of ``nlobs simulate MODEL``).
DIVERGED_RUN_JSON = Record("DivergedRun", {
    "run": INTEGER,
    "time": NUMBER.about("first time the error was non-finite or too large"),
    "reason": STRING,
    "causes": array(STRING, "what the run showed before"),
})

#: An observer's certificate checked along the runs (``certificate`` of ``nlobs simulate MODEL``).
RUN_CERTIFICATE_JSON = Record("RunCertificate", {
    "verified": BOOLEAN.about("re-checked without the solver"),
    "covers_run": BOOLEAN.about("every run inside every hypothesis"),
    "covered_fraction": NUMBER,
    "reasons": array(STRING, "why runs are not covered"),
    "violations": array(VIOLATION_JSON, "per run not covered, the first"),
    "hypotheses": array(STRING, "what the certificate rests on, each checked along every run"),
    "region": STRING.about("drift: the region of the certificate"),
    "mu": NUMBER.about("drift: the bound on the input"),
    "hinf_H": NUMBER.about("cascade: the H-infinity norm of H, the error dynamics (13) of Grip, Saberi & Johansen"),
    "theorem1_gamma": NUMBER.about("cascade: the gamma that Theorem 1 requires of it (null: no Lyapunov constants)"),
    "rms_bound": NUMBER.about("the certified RMS of the error after the settling time (null: not verified)"),
    "sampling": Record("SamplingBudget", {
        "budget": NUMBER,
        "iss_gain": NUMBER,
        "groups": array(Record("SamplingGroup", {"name": STRING, "period": NUMBER, "T_max": NUMBER})),
    }),
}, optional={"region", "mu", "hinf_H", "theorem1_gamma", "rms_bound", "sampling"})

#: An observer that did not run, and why.
SKIPPED_OBSERVER_JSON = Record("SkippedObserver", {
    "skipped": STRING.about("why it does not apply: the assumption or design that failed"),
    "description": STRING,
})

#: An observer's results over the Monte Carlo runs (an entry of ``observers`` of ``nlobs simulate MODEL``).
OBSERVER_OUTCOME_JSON = Record("ObserverOutcome", {
    "skipped": Node({"type": "null"}),
    "description": STRING,
    "design": nullable(DESIGN_JSON),
    "rms_error": array(NUMBER, "per state, after the settling time, over the runs that did not diverge"),
    "rms_error_all": array(NUMBER, "per state, over the whole run"),
    "rms_error_norm": NUMBER,
    "rms_error_norm_all": NUMBER,
    "final_error_norm": NUMBER,
    "convergence_time": NUMBER,
    "diverged_runs": array(DIVERGED_RUN_JSON),
    "cost_per_step_us": NUMBER.about("wall time inside the observer per step and run"),
    "certificate": nullable(RUN_CERTIFICATE_JSON),
    "consistency": nullable(CONSISTENCY_JSON),
    "closed_loop": CLOSED_LOOP_JSON.about("with a [controller]: the loop around this observer against the reference"),
    "constraints": ESTIMATE_BOUNDS_JSON.about("with [constraints]: how often the estimate left them"),
}, optional={"closed_loop", "constraints"})

#: How the runs were made, as text.
SETUP_JSON = Record("Setup", {
    "sensors": STRING, "inputs": STRING, "process_noise": STRING, "initial estimate": STRING, "region": STRING})

#: ``nlobs simulate MODEL``.
COMPARISON_JSON = Record("Comparison", {
    "model": STRING,
    "states": array(STRING),
    "units": array(STRING, "per state, empty when none"),
    "runs": INTEGER,
    "seed": INTEGER,
    "duration": NUMBER,
    "dt": NUMBER,
    "settle": NUMBER,
    "time_unit": STRING,
    "x0": array(NUMBER),
    "setup": SETUP_JSON,
    "observers": mapping(one_of(OBSERVER_OUTCOME_JSON, SKIPPED_OBSERVER_JSON), "per observer, in the order asked for"),
    "unobservable": array(STRING, "the directions the outputs cannot see"),
    "files": array(STRING),
    "closed_loop": CLOSED_LOOP_SETUP_JSON.about("with a [controller]: the law and the loop around the true state"),
    "constraints": CONSTRAINTS_JSON.about("with [constraints]: the bounds and how often the truth left them"),
}, description="Observers compared on the same noisy Monte Carlo runs.", optional={"closed_loop", "constraints"})


@dataclass(frozen=True)
class DivergedRun:
    """A Monte Carlo run whose estimate blew up: its index, when, and how.

    Attributes
    ----------
    run : int
        Index of the run.
    time : float
        First time the error was non-finite or too large (``nan`` when the batch stopped with an error).
    reason : str
        What happened, e.g. ``"non-finite estimate"``.
    causes : tuple of str
        What the run shows before (:func:`divergence_causes`): the estimate leaving the region, a sampling period
        above ``T_max``, a step outside RK4's stability region for a pole of the gain, ``Q_s(x̂)`` near singular.
    """

    run: int
    time: float
    reason: str
    causes: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        return DIVERGED_RUN_JSON.emit({"run": self.run, "time": self.time, "reason": self.reason,
                                       "causes": list(self.causes)})


@dataclass(frozen=True, eq=False)
class ObserverOutcome:
    """One observer's part of a comparison (``skipped`` set, or the metrics of its runs).

    Attributes
    ----------
    name : str
        ``"drift"``, ``"pinv"``, ``"luenberger"``, ``"cascade"``, ``"ekf"`` or ``"ukf"``.
    skipped : str or None
        Why the observer was not run (an assumption that failed, a design that failed), else ``None``.
    description : str
        What was run: the method and its design (gain, tuning).
    rms_error, rms_error_all : tuple of float
        RMS error per state after the settling time / over the whole run (runs that did not diverge).
    rms_error_norm, rms_error_norm_all, final_error_norm, convergence_time : float
    diverged_runs : tuple of DivergedRun
    cost_per_step_us : float
        Wall time inside the observer per step and run (µs).
    certificate : dict or None
        For a certified design, ``None`` for a method without a certificate: ``verified``,
        ``covers_run`` (every run inside every hypothesis, :mod:`nlobs.simulate.coverage`),
        ``covered_fraction``, ``violations`` (the first per run: ``run``, ``hypothesis``, ``time``,
        ``detail``), ``reasons`` (why runs are not covered), ``hypotheses`` (what was checked), for
        ``drift`` the ``region`` and ``mu``, and for a design with a bound under the sensors ``rms_bound``
        (the certified RMS of ``‖e‖`` after the settling time, for these runs' initial errors; ``None`` when
        the bound is not verified) and ``sampling`` (``budget`` Σ T/T_max and per group ``name``, ``period``,
        ``T_max``).
    run_rms : ndarray, shape (runs,)
        RMS of ``‖e‖`` after the settling time, per run (NaN for a diverged run): the box plot.
    result : SimulationResult or None
        The trajectories (not part of :meth:`to_dict`).
    observer : Observer or None
        The observer that was run, with its gains (not part of :meth:`to_dict`).
    design : Design or None
        The method's design (:class:`nlobs.methods.base.Design`; ``to_dict()`` is the ``design`` key).
    consistency : Consistency or None
        A Kalman filter's NEES and NIS over the runs against their 95 % χ² bands
        (:func:`nlobs.simulate.consistency.filter_consistency`; ``to_dict()`` is the ``consistency`` key).
    closed_loop : Mapping or None
        With a ``[controller]``: the loop around this observer against the reference loop
        (:func:`nlobs.methods.closed_loop.closed_loop_metrics`).
    bounds : Mapping or None
        With ``[constraints]``: how often the estimate left them (:func:`nlobs.methods.closed_loop.estimate_bounds`;
        the ``constraints`` key).
    """

    name: str
    skipped: str | None
    description: str = ""
    rms_error: tuple[float, ...] = ()
    rms_error_all: tuple[float, ...] = ()
    rms_error_norm: float = math.nan
    rms_error_norm_all: float = math.nan
    final_error_norm: float = math.nan
    convergence_time: float = math.nan
    diverged_runs: tuple[DivergedRun, ...] = ()
    cost_per_step_us: float = math.nan
    certificate: Mapping[str, Any] | None = None
    run_rms: Array = field(default_factory=lambda: np.zeros(0))
    result: SimulationResult | None = None
    observer: Any = None
    design: Design | None = None
    consistency: Consistency | None = None
    closed_loop: Mapping[str, Any] | None = None
    bounds: Mapping[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        if self.skipped is not None:
            return SKIPPED_OBSERVER_JSON.emit({"skipped": self.skipped, "description": self.description})
        return OBSERVER_OUTCOME_JSON.emit({
            "skipped": None,
            "description": self.description,
            "design": None if self.design is None else self.design.to_dict(),
            "rms_error": list(self.rms_error),
            "rms_error_all": list(self.rms_error_all),
            "rms_error_norm": self.rms_error_norm,
            "rms_error_norm_all": self.rms_error_norm_all,
            "final_error_norm": self.final_error_norm,
            "convergence_time": self.convergence_time,
            "diverged_runs": [d.to_dict() for d in self.diverged_runs],
            "cost_per_step_us": self.cost_per_step_us,
            "certificate": None if self.certificate is None else RUN_CERTIFICATE_JSON.emit(self.certificate),
            "consistency": None if self.consistency is None else self.consistency.to_dict(),
            **({} if self.closed_loop is None else {"closed_loop": dict(self.closed_loop)}),
            **({} if self.bounds is None else {"constraints": dict(self.bounds)}),
        })


@dataclass(frozen=True, eq=False)
class ComparisonReport:
    """What ``nlobs simulate MODEL`` reports (``to_dict()`` is its ``--json``; keys in the README).

    Attributes
    ----------
    model : str
    states, units : tuple of str
        State names and their units (``""`` where the file gives none).
    runs, seed : int
    duration, dt, settle : float
        In :attr:`time_unit`.
    time_unit : str
        ``units.t`` of the model file (``"s"`` by default).
    x0 : tuple of float
    setup : dict
        Sensors, inputs, process noise and initial errors, as described to the user.
    observers : dict of str to ObserverOutcome
    files : tuple of Path
    verdict : Verdict
        ``OK`` when at least one observer ran with at least one run that did not diverge;
        ``NO_OBSERVER`` when every observer was skipped; ``FAILED`` when every run of every
        observer that ran diverged.
    message : str
    scenario : Scenario or None
        The model file's tables the runs were made from (not part of :meth:`to_dict`).
    plant : Any
        The compiled plant that was simulated (not part of :meth:`to_dict`).
    unobservable : tuple of str
        The directions the outputs cannot see (:func:`nlobs.geometry.unobservable.unobservable_directions`:
        a state's name, or a combination of states); empty for an observable model.
    closed_loop : Mapping or None
        With a ``[controller]``: the law and the reference loop around the true state
        (:func:`nlobs.methods.closed_loop.loop_setup`).
    constraints : Mapping or None
        With ``[constraints]``: the bounds and how often the truth left them
        (:func:`nlobs.methods.closed_loop.bounds_report`).
    reference : SimulationResult or None
        With a ``[controller]``: the reference loop's runs (the law fed the true state; not part of :meth:`to_dict`).
    """

    model: str
    states: tuple[str, ...]
    units: tuple[str, ...]
    runs: int
    seed: int
    duration: float
    dt: float
    settle: float
    time_unit: str
    x0: tuple[float, ...]
    setup: Mapping[str, Any]
    observers: Mapping[str, ObserverOutcome]
    files: tuple[Path, ...]
    verdict: Verdict
    message: str
    scenario: Scenario | None = None
    plant: Any = None
    unobservable: tuple[str, ...] = ()
    closed_loop: Mapping[str, Any] | None = None
    constraints: Mapping[str, Any] | None = None
    reference: SimulationResult | None = None

    def to_dict(self) -> dict[str, Any]:
        return COMPARISON_JSON.emit({
            "model": self.model, "states": list(self.states), "units": list(self.units), "runs": self.runs,
            "seed": self.seed, "duration": self.duration, "dt": self.dt, "settle": self.settle,
            "time_unit": self.time_unit, "x0": list(self.x0),
            "setup": SETUP_JSON.emit(self.setup), "observers": {k: v.to_dict() for k, v in self.observers.items()},
            "unobservable": list(self.unobservable),
            "files": [str(f) for f in self.files],
            **({} if self.closed_loop is None else {"closed_loop": dict(self.closed_loop)}),
            **({} if self.constraints is None else {"constraints": dict(self.constraints)}),
        })

    def table(self) -> tuple[str, list[str], list[list[str]]]:
        """Title, column heads and rows of the comparison table the CLI prints."""
        heads = ["observer", *(f"RMS {s}" + (f" [{u}]" if u else "") for s, u in zip(self.states, self.units)),
                 "RMS ‖e‖", "certified ≤", "final ‖e‖", f"t_conv [{self.time_unit}]", "diverged", "µs/step",
                 "certificate"]
        rows = []
        for name, o in self.observers.items():
            if o.skipped is not None:
                rows.append([name, *(["—"] * (len(self.states) + 6)), "skipped"])
                continue
            cert = "—" if o.certificate is None else (
                "covers run" if o.certificate.get("covers_run") else
                ("verified, not covering the run" if o.certificate.get("verified") else "failed"))
            bound = None if o.certificate is None else o.certificate.get("rms_bound")
            rows.append([name, *(_num(v) for v in o.rms_error), _num(o.rms_error_norm),
                         "—" if bound is None else _num(float(bound)), _num(o.final_error_norm),
                         _num(o.convergence_time), f"{len(o.diverged_runs)}/{self.runs}", _num(o.cost_per_step_us),
                         cert])
        tu = self.time_unit
        title = (f"{self.model}: {self.runs} runs of {self.duration:g} {tu} (dt = {self.dt:g} {tu}, seed {self.seed}); "
                 f"RMS after t = {self.settle:g} {tu}")
        return title, heads, rows

    def summary(self) -> str:
        """The setup, the table as text, why observers were skipped, diverged runs, files."""
        title, heads, rows = self.table()
        lines = [title]
        for k, v in self.setup.items():
            lines.append(f"  {k}: {v}")
        widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(heads)]
        lines.append("  " + "  ".join(h.ljust(w) for h, w in zip(heads, widths)))
        for r in rows:
            lines.append("  " + "  ".join(c.ljust(w) for c, w in zip(r, widths)))
        for name, o in self.observers.items():
            if o.skipped is not None:
                lines.append(f"  {name}: skipped: {o.skipped}")
                continue
            lines.append(f"  {name}: {o.description}")
            if o.design is not None and o.design.defaults_text():
                lines.append(f"    from the model file: {o.design.defaults_text()}")
            lines += [f"    warning: {w}" for w in (o.design.warnings if o.design is not None else ())]
            if o.diverged_runs:
                shown = ", ".join(f"run {d.run} at t = {d.time:.4g} {self.time_unit} ({d.reason})"
                                  for d in o.diverged_runs[:5])
                more = f" and {len(o.diverged_runs) - 5} more" if len(o.diverged_runs) > 5 else ""
                lines.append(f"    diverged: {shown}{more}")
                first = o.diverged_runs[0]
                if first.causes:
                    lines.append(f"    seen before run {first.run} diverged: " + "; ".join(first.causes))
            if o.certificate is not None and o.certificate.get("reasons"):
                lines.append("    certificate: " + "; ".join(o.certificate["reasons"]))
        lines += self._loop_lines()
        lines += [f"warning: {w}" for w in warnings_of(self.constraints, self.runs)]
        lines += [f"wrote {f}" for f in self.files]
        return "\n".join(lines)

    def _loop_lines(self) -> list[str]:
        """The closed loop's table (each observer's loop against the reference) and the estimates' bounds."""
        lines = []
        if self.closed_loop is not None:
            ref = self.closed_loop["reference"]
            ins = self.closed_loop["inputs"]
            lines.append("closed loop: " + ", ".join(f"{i} = {e}" for i, e in zip(ins, self.closed_loop["law"]))
                         + f"; reference (true state fed back): RMS x after t = {self.settle:g} "
                         + str([float(f"{v:.3g}") for v in ref["rms_state"]]) + ", peak |u| "
                         + str([float(f"{v:.3g}") for v in ref["peak_input"]]))
            for name, o in self.observers.items():
                if o.closed_loop is not None:
                    c = o.closed_loop
                    lines.append(f"  {name}: RMS ‖x − x_ref‖ {_num(c['rms_deviation'])}, peak |u| "
                                 f"{[float(f'{v:.3g}') for v in c['peak_input']]}, diverged {c['diverged_runs']}/"
                                 f"{self.runs}")
        if self.constraints is not None:
            for name, o in self.observers.items():
                if o.bounds is not None and o.bounds["runs_outside"]:
                    lines.append(f"  {name}: estimate outside the [constraints] at "
                                 f"{100 * o.bounds['outside_fraction']:.3g} % of the instants "
                                 f"({o.bounds['runs_outside']}/{self.runs} runs)")
        return lines


def _num(v: float) -> str:
    if math.isnan(v):
        return "—"
    return "never" if math.isinf(v) else f"{v:.4g}"


# ----------------------------------------------------------------------------- set-up
@dataclass(frozen=True, eq=False)
class _Setup:
    scenario: Scenario
    label: str
    plant: Any
    x0: Array
    x_hat0: Array  # (runs, n)
    p0_std: Array  # (n,)
    duration: float
    dt: float
    settle: float
    runs: int
    seed: int
    u: Any
    u0: Array
    sensors: tuple[MeasurementGroup, ...]
    process_noise: Array | None
    box: Any
    save_every: int
    describe: dict[str, Any]
    problem: Problem
    controller: Any = None  # the file's [controller]: the loop is closed around each observer
    bounds: Any = None  # the file's [constraints]


def _vector(name: str, value: ArrayLike | None, n: int) -> Array | None:
    if value is None:
        return None
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.size == 1 and n > 1 and name == "`initial_error_std`":
        v = np.full(n, float(v[0]))
    if v.shape != (n,):
        raise DimensionError(f"{name}: expected {n} numbers (one per state), got {v.size}")
    if not np.all(np.isfinite(v)):
        raise InvalidArgumentError(f"{name}: values must be finite, got {v.tolist()}")
    return v


def _sensor_override(model: Any, rate: float | None, noise_std: float | Sequence[float] | None,
                     current: tuple[MeasurementGroup, ...]) -> tuple[MeasurementGroup, ...]:
    if rate is None and noise_std is None:
        return current
    if rate is None:
        if not current or len({g.rate for g in current}) != 1:
            raise InvalidArgumentError("`noise_std` without `rate`: the model's sensors do not have one common rate; "
                                       "give `rate` too")
        rate = current[0].rate
    return (MeasurementGroup("sensor", tuple(model.outputs), rate=rate,
                             noise_std=0.0 if noise_std is None else noise_std),)


def _setup(scenario: Scenario, label: str, *, runs: int | None, duration: float | None, dt: float | None,
           seed: int, x0: ArrayLike | None, x_hat0: ArrayLike | None, initial_error_std: ArrayLike | float | None,
           box: Any, settle: float | None, rate: float | None, noise_std: Any, inputs: Any,
           process_noise: ArrayLike | None) -> _Setup:
    model = scenario.model
    d = scenario.defaults
    n = model.n
    runs_ = as_count("`runs`", runs if runs is not None else (d.runs or 20), minimum=1)
    dur = positive("`duration`", duration if duration is not None else (d.duration or 10.0))
    if model.time.is_discrete:
        step = float(model.time.dt)  # type: ignore[attr-defined]
        if dt is not None and abs(dt - step) > 1e-9 * step:
            raise InvalidArgumentError(f"`dt`: the model is discrete with dt = {step:g} s; got `dt` {dt:g}")
    else:
        step = positive("`dt`", dt if dt is not None else (d.dt or 1e-3))
    if step > dur * (1 + 1e-12):  # one step past the end of the run: every number would be of the wrong time
        raise InvalidArgumentError(f"`dt` {step:g} is longer than `duration` {dur:g}: the one step would end past the "
                                   "run (take `dt` at most `duration`)")
    steps = math.ceil(dur / step - 1e-9)
    if steps > MAX_SIMULATION_STEPS:
        raise InvalidArgumentError(f"`duration` {dur:g} / `dt` {step:g} is {steps:.3g} steps; at most "
                                   f"{MAX_SIMULATION_STEPS:.0e} (raise `dt` or shorten `duration`)")
    save_every = max(1, steps // SAVED_POINTS)
    if runs_ * (steps // save_every + 1) * max(n, model.p) > MAX_SAVED_VALUES:
        raise InvalidArgumentError(f"`runs` {runs_}: {runs_} runs × {steps // save_every + 1} saved times × "
                                   f"{max(n, model.p)} values exceed {MAX_SAVED_VALUES:.0e}; use fewer runs")
    # ^ before anything is allocated per run (99999999999 runs: refused, not a MemoryError)
    settle_ = settle if settle is not None else (
        d.settle if d.settle is not None and d.settle < dur else 0.25 * dur)  # the file's, unless past a shorter run
    settle_ = positive("`settle`", settle_, allow_zero=True)
    if settle_ >= dur:
        raise InvalidArgumentError(f"`settle`: {settle_:g} s is not before the end of the run ({dur:g} s)")
    x0_ = _vector("`x0`", x0, n)
    if x0_ is None:
        x0_ = d.x0 if d.x0 is not None else np.zeros(n)
    std = _vector("`initial_error_std`", initial_error_std, n)
    xh = _vector("`x_hat0`", x_hat0, n)
    if std is None:
        std = d.initial_error_std if d.initial_error_std is not None else None
    if xh is not None:
        x_hat = np.broadcast_to(xh, (runs_, n)).copy()
        given = _vector("`initial_error_std`", initial_error_std, n) if initial_error_std is not None else None
        p0_std = given if given is not None else np.maximum(np.abs(xh - x0_), 1e-3 * np.maximum(1.0, np.abs(x0_)))
        init_text = f"x̂0 = {xh.tolist()} in every run" + (
            f" (filters' P0 = diag(std²), std = {given.tolist()})" if given is not None else "")
    else:
        if std is None:
            std = 0.1 * np.maximum(1.0, np.abs(x0_))
        rng = np.random.default_rng([int(seed), 7])  # its own stream: the sensor noise uses `seed`
        x_hat = x0_ + rng.standard_normal((runs_, n)) * std
        p0_std = np.maximum(std, 1e-3 * np.maximum(1.0, np.abs(x0_)))
        init_text = f"x̂0 = x0 + N(0, diag(std²)), std = {np.asarray(std).tolist()}"
    sensors = _sensor_override(model, rate, noise_std, scenario.sensors)
    q = scenario.process_noise if process_noise is None else noise_matrix("process_noise", process_noise, n)
    u, u_text = _input(scenario, inputs)
    u0 = np.asarray(u(0.0) if callable(u) else u, dtype=float).reshape(model.m) if model.m else np.zeros(0)
    region = as_region(box, n) if box is not None else (
        None if d.box is None else as_region([v for pair in zip(*d.box) for v in pair], n))
    pb = problem(scenario, box=region, x0=x0_, duration=dur, u=u if inputs else None,
                 u_source="the given inputs" if inputs else None, sensors=sensors, process_noise=q, label=label)
    pb = dataclasses.replace(pb, sources={**pb.sources, **_sources(d, box, x0, duration)})
    describe = {
        "sensors": "; ".join(_describe_sensor(g, scenario.time_unit) for g in sensors) if sensors else
                   "exact, continuous measurement of every output (no [sensors] table)",
        "inputs": u_text,
        "process_noise": "none" if q is None or not np.any(q) else
                         f"std {np.sqrt(np.clip(np.diag(q), 0, None)).tolist()} per √{scenario.time_unit}"
                         + (" (discrete: per step)" if model.time.is_discrete else ""),
        "initial estimate": init_text,
        "region": region.describe() if region is not None else "[-1, 1] per state (default)",
    }
    plant = model.compile() if isinstance(model, SymbolicModel) else model
    controller = scenario.controller
    if controller is not None:
        control_period_steps(controller.rate, step)  # a rate that does not fit dt: refused before any run
        describe["inputs"] = f"closed loop, {controller.describe()} (fed the estimate; [input_signals] not used)"
    return _Setup(scenario, label, plant, np.asarray(x0_, dtype=float), x_hat, np.asarray(p0_std, dtype=float), dur,
                  step, float(settle_), runs_, int(seed), u, u0, sensors, q, region, save_every, describe, pb,
                  controller, scenario.constraints)


def _sources(d: Any, box: Any, x0: Any, duration: Any) -> dict[str, str]:
    """Where the region, ``x0`` and the horizon of a comparison came from (options, ``[simulation]``, defaults)."""
    return {"region": "given" if box is not None else ("[simulation] box" if d.box is not None else
                                                      "default [-1, 1] per state"),
            "x0": "given" if x0 is not None else ("[simulation] x0" if d.x0 is not None else "default zeros"),
            "duration": "given" if duration is not None else ("[simulation] duration" if d.duration is not None
                                                              else "default 10")}


def _describe_sensor(g: MeasurementGroup, time_unit: str = "s") -> str:
    noise = ("noise cov " + str(np.asarray(g.noise_cov).tolist())) if g.noise_cov is not None else \
        f"noise std {np.asarray(g.noise_std).tolist()}"
    extra = ""
    if np.any(g.bias != 0):
        extra += f", bias {np.asarray(g.bias).tolist()}"
    if g.outages:
        extra += ", outages " + ", ".join(f"[{a:g}, {b:g}) {time_unit}" for a, b in g.outages)
    rate = f"{g.rate:g} Hz" if time_unit == "s" else f"{g.rate:g} per {time_unit}"
    return f"{g.name}: {', '.join(map(str, g.outputs))} at {rate}, {noise}{extra}"


def _input(scenario: Scenario, inputs: Any) -> tuple[Any, str]:
    model = scenario.model
    if model.m == 0:
        return None, "none (the model has no inputs)"
    sig = scenario.input_signals
    if inputs:
        from nlobs.systems.signals import Constant, InputSignals, parse_signal_spec

        base = Path(scenario.path).parent if scenario.path else None
        current = dict(zip(sig.names, sig.signals)) if sig is not None else {}
        for name, spec in dict(inputs).items():
            if name not in model.inputs:
                raise UnknownNameError(f"`inputs` {name}: not an input of the model (inputs: {', '.join(model.inputs)})")
            current[name] = spec if not isinstance(spec, str) else parse_signal_spec(spec, base_dir=base)
        sig = InputSignals(tuple(model.inputs), tuple(current.get(k, Constant(0.0)) for k in model.inputs))
    if sig is None:
        return np.zeros(model.m), "zero (no [input_signals] table)"
    return sig, "; ".join(sig.describe().splitlines())


# ----------------------------------------------------------------------------- designs
@dataclass(frozen=True)
class _Cert:
    """A certified design's verdict and the hypotheses a run must stay inside to be covered."""

    verified: bool
    hypotheses: tuple[Any, ...]
    extras: Mapping[str, Any]
    bound: Any = None


# ----------------------------------------------------------------------------- metrics
#: A drift observer's ``Q_s(x̂)`` counts as near singular above this condition number.
NEAR_SINGULAR = 1e8


def _poles(design: Design) -> Array | None:
    """The eigenvalues of the observer's error dynamics where its design states them (``A_s − K C_s``, the roots
    of (10)); ``None`` otherwise."""
    for holder, attr in ((design.certificate, "eigenvalues"), (design.report, "roots")):
        lam = getattr(holder, attr, None)
        if lam is not None and np.size(lam):
            return np.asarray(lam, dtype=complex).ravel()
    return None


def _rk4_growth(z: Array) -> Array:
    """``|R(z)|``, ``R(z) = 1 + z + z²/2 + z³/6 + z⁴/24``: RK4's amplification of the mode ``e^{λt}`` over one step
    ``z = dt·λ`` (above 1: the step is outside its stability region)."""
    return np.abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)


def _stable_step(lam: complex, dt: float) -> float:
    """The largest step below ``dt`` that keeps ``dt·λ`` in RK4's stability region (bisection)."""
    lo, hi = 0.0, float(dt)
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if _rk4_growth(np.asarray(mid * lam)) <= 1 else (lo, mid)
    return lo


def _q_s(observer: Any) -> Any:
    """The drift observer inside ``observer`` (the predictor wraps it), whose ``Q_s(x̂)`` can be evaluated."""
    for _ in range(3):
        if hasattr(observer, "jacobian_Q"):
            return observer
        observer = getattr(observer, "observer", None)
    return None


def divergence_causes(design: Design, dt: float, t: Array, x_hat: Array, states: Sequence[str]) -> tuple[str, ...]:
    """What a diverged run shows before its estimate blew up, as far as the design can see it.

    Parameters
    ----------
    design : Design
        The observer's design (its region, sampling premise, gain).
    dt : float
        The integration step.
    t : ndarray, shape (K,)
        The saved instants up to the divergence.
    x_hat : ndarray, shape (K, n)
        The run's estimate at them.
    states : sequence of str
        The state names.

    Returns
    -------
    tuple of str
        The estimate leaving the region (when and which component), the sampling premise that fails, ``dt·λ``
        outside RK4's stability region for a pole of the gain, ``Q_s(x̂)`` near singular at the last finite
        estimate.
    """
    from nlobs.simulate.coverage import InRegion, Premise
    from nlobs.simulate.integrators import RK4_REAL_LIMIT

    out = []
    finite = np.all(np.isfinite(x_hat), axis=-1)
    for h in design.hypotheses:
        if isinstance(h, InRegion) and h.which != "state":
            lo, hi = np.asarray(h.lower, dtype=float), np.asarray(h.upper, dtype=float)
            outside = finite & ~np.all((x_hat >= lo) & (x_hat <= hi), axis=-1)
            if outside.any():
                j = int(np.argmax(outside))
                c = int(np.argmax((x_hat[j] < lo) | (x_hat[j] > hi)))
                out.append(f"the estimate left the region {h.region} at t = {t[j]:.4g} "
                           f"({states[c]} = {x_hat[j, c]:.4g} outside [{lo[c]:.4g}, {hi[c]:.4g}])")
            break
    for h in design.hypotheses:
        if isinstance(h, Premise) and not h.holds and h.name.startswith("sampled with period"):
            out.append(f"the sampling period is above what the certificate survives ({h.reason})")
    poles = _poles(design)
    if poles is not None:
        growth = _rk4_growth(dt * poles)
        k = int(np.argmax(growth))
        if growth[k] > 1:
            lam = complex(poles[k])
            shown = f"{lam.real:.4g}" if abs(lam.imag) <= 1e-12 * abs(lam) else f"{lam:.4g}"
            out.append(f"dt·λ = {dt * lam.real:.3g}{'' if lam.imag == 0 else f' {dt * lam.imag:+.3g}j'} is outside RK4's "
                       f"stability region for the gain's pole λ = {shown} (|R(dt·λ)| = {growth[k]:.3g} > 1; for a "
                       f"real pole, dt·|λ| > {RK4_REAL_LIMIT}): `dt` below {_stable_step(lam, dt):.3g}")
    drift = _q_s(design.observer)
    if drift is not None and finite.any():
        last = x_hat[int(np.flatnonzero(finite)[-1])]
        try:
            with np.errstate(all="ignore"):
                cond = float(np.linalg.cond(np.asarray(drift.jacobian_Q(last), dtype=float)))
        except (NlobsError, ValueError, np.linalg.LinAlgError):
            cond = math.inf
        if not cond < NEAR_SINGULAR:
            out.append(f"Q_s(x̂) near singular at the last finite estimate (condition number {cond:.3g})")
    return tuple(out)


def _outcome(name: str, desc: str, res: SimulationResult, s: _Setup, cert: _Cert | None,
             design: Design | None = None) -> ObserverOutcome:
    x, xh, t = res.x, res.x_hat, res.t
    assert x is not None
    with np.errstate(all="ignore"):
        e = xh - x  # (runs, K, n)
        en = np.sqrt(np.sum(e * e, axis=-1))  # (runs, K)
        scale = 1.0 + np.max(np.sqrt(np.sum(x * x, axis=-1)), axis=-1)  # (runs,)
        bad_t = ~np.isfinite(en) | (en > BLOWUP * scale[:, None])
    diverged = []
    for i in np.flatnonzero(bad_t.any(axis=-1)):
        k = int(np.argmax(bad_t[i]))
        reason = "non-finite estimate" if not np.isfinite(en[i, k]) else f"‖e‖ > {BLOWUP:.0e} (1 + max‖x‖)"
        causes = divergence_causes(design, s.dt, t[: k + 1], xh[i, : k + 1], s.scenario.model.states) \
            if design is not None else ()
        diverged.append(DivergedRun(int(i), float(t[k]), reason, causes))
    ok = ~bad_t.any(axis=-1)
    after = t >= s.settle - 1e-12
    run_rms = np.full(s.runs, np.nan)
    if ok.any():
        eo, eno = e[ok], en[ok]
        rms = tuple(float(v) for v in np.sqrt(np.mean(eo[:, after] ** 2, axis=(0, 1))))
        rms_all = tuple(float(v) for v in np.sqrt(np.mean(eo**2, axis=(0, 1))))
        rms_norm = float(np.sqrt(np.mean(eno[:, after] ** 2)))
        rms_norm_all = float(np.sqrt(np.mean(eno**2)))
        final = float(np.sqrt(np.mean(eno[:, -1] ** 2)))
        run_rms[ok] = np.sqrt(np.mean(eno[:, after] ** 2, axis=-1))
        # a moving average over 1 % of the run, so that noise alone does not count as not converged
        width = max(1, t.size // 100)
        smooth = np.apply_along_axis(lambda v: np.convolve(v, np.ones(width) / width, mode="same"), -1, eno)
        final_level = np.median(smooth[:, t >= t[0] + 0.75 * (t[-1] - t[0])], axis=-1)
        tol = np.maximum(0.05 * eno[:, 0], 2.0 * final_level)
        below = smooth <= tol[:, None]
        conv = np.where(below.any(axis=-1), t[np.argmax(below, axis=-1)], np.inf)
        conv = np.where(tol < 0.5 * eno[:, 0], conv, np.inf)  # a final level above a quarter of the start: not converged
        conv_time = float(np.median(conv))
    else:
        nan = (math.nan,) * x.shape[-1]
        rms, rms_all, rms_norm, rms_norm_all, final, conv_time = nan, nan, math.nan, math.nan, math.nan, math.nan
    consistency = filter_consistency(res)
    if "P" in res.extras:  # recorded for the NEES only: the result keeps what a filter records by default
        res = dataclasses.replace(res, extras={k: v for k, v in res.extras.items() if k != "P"})
    certificate = None
    if cert is not None:
        applied = res.extras.get("u") if s.controller is not None else s.u  # a closed loop: the input applied
        cov = monitor(res, cert.hypotheses, u=applied, verified=cert.verified)
        certificate = {"verified": cert.verified, "covers_run": cov.covers_run,
                       "covered_fraction": cov.covered_fraction, "reasons": list(cov.reasons),
                       "violations": [v.to_dict() for v in cov.violations],
                       "hypotheses": list(cov.hypotheses), **cert.extras}
        if cert.bound is not None:
            certificate.update(_bound_entries(cert.bound, s))
    bounds = None if s.bounds is None else estimate_bounds(s.bounds, xh)
    return ObserverOutcome(name, None, desc, rms, rms_all, rms_norm, rms_norm_all, final, conv_time, tuple(diverged),
                           float(res.info.get("cost_per_step_us", math.nan)), certificate, run_rms, res,
                           consistency=consistency, bounds=bounds)


def _bound_entries(bound: Any, s: _Setup) -> dict[str, Any]:
    """``rms_bound`` (the certified RMS after the settling time for these runs' initial errors) and ``sampling``."""
    e0 = np.asarray(s.x_hat0, dtype=float) - np.asarray(s.x0, dtype=float)
    second = np.einsum("ri,rj->ij", e0, e0) / e0.shape[0]  # the runs' E[e0 e0ᵀ]: the bound is linear in it
    value = bound.rms_after(s.settle, second)
    iss = getattr(bound, "iss_gain", None) if bound.verified else None  # limsup |e| ≤ iss_gain · v̄, bounded noise
    return {"rms_bound": value if math.isfinite(value) else None,
            "sampling": {"budget": bound.budget, "iss_gain": iss if iss is not None and math.isfinite(iss) else None,
                         "groups": [{"name": g.name, "period": g.gap, "T_max": t}
                                    for g, t in zip(bound.groups, bound.t_max)]}}


# ----------------------------------------------------------------------------- the command
def compare_observers(
    model: str | Path | Scenario | SymbolicModel | LinearSystem,
    *,
    observers: Sequence[str] | None = None,
    runs: int | None = None,
    duration: float | None = None,
    dt: float | None = None,
    seed: int = 0,
    x0: ArrayLike | None = None,
    x_hat0: ArrayLike | None = None,
    initial_error_std: ArrayLike | float | None = None,
    box: Sequence[float] | None = None,
    settle: float | None = None,
    rate: float | None = None,
    noise_std: float | Sequence[float] | None = None,
    inputs: Mapping[str, Any] | None = None,
    process_noise: ArrayLike | None = None,
    filter_q: ArrayLike | None = None,
    alpha: float | None = None,
    design_options: Mapping[str, Mapping[str, Any]] | None = None,
    progress: bool | None = None,
    name: str | None = None,
    backend: str = "python",
    executor: Any = None,
    workers: int | None = None,
    scheduler: str | None = None,
) -> ComparisonReport:
    """Run the chosen observers on the same noisy, multi-rate Monte Carlo runs of a model (module docstring).

    Parameters
    ----------
    model : str, Path, Scenario, SymbolicModel or LinearSystem
        A model file (with its ``[sensors]``, ``[input_signals]``, ``[process_noise]``, ``units`` and
        ``[simulation]`` tables, :mod:`nlobs.systems.scenario`), a shipped model name, or a model.
    observers : sequence of str, optional
        Names from :data:`OBSERVERS` (default: all of them).
    runs, duration, dt, seed : optional
        Monte Carlo runs (default 20), simulated time (default 10 s), step (default 1e-3 s; a
        discrete model's own ``dt``) and seed (default 0); the file's ``[simulation]`` values
        come before the defaults.
    x0, x_hat0, initial_error_std : optional
        Initial plant state (default ``[simulation].x0``, else zeros); one initial estimate for
        every run, or the standard deviation of the initial error per state (default
        ``[simulation].initial_error_std``, else ``0.1 max(1, |x0|)``). The filters start with
        ``P0 = diag(std²)``; with ``x_hat0`` and no ``initial_error_std``, ``std = |x̂0 − x0|``
        (at least 10⁻³ max(1, |x0|)).
    box : sequence of float, optional
        The designs' region (``lo, hi`` or ``lo1, hi1, …``; default ``[simulation].box``, else
        ``[−1, 1]ⁿ``).
    settle : float, optional
        RMS errors are reported for ``t ≥ settle`` (default ``[simulation].settle``, else a quarter
        of the duration) and over the whole run.
    rate, noise_std : optional
        One sensor for all outputs at ``rate`` Hz with this noise, instead of the file's ``[sensors]``.
    inputs : mapping of str to str or signal, optional
        Known input signals by input name (the compact form of
        :func:`nlobs.systems.signals.parse_signal_spec`, e.g. ``"sine:0.5,0.2"``), replacing the file's.
    process_noise : array_like, optional
        Per-state standard deviations or an ``(n, n)`` covariance, replacing ``[process_noise]``.
    filter_q : array_like, optional
        The Kalman filters' ``Q`` (std per state or covariance), instead of the process noise.
    alpha : float, optional
        Decay rate of the Luenberger gain's region ``Re λ < −α`` (default: the method's, 1).
    design_options : mapping of str to mapping, optional
        Design options per method, by name (``{"drift": {"mu": 2.0}, "pinv": {"theta": 3.0}}``): each
        method's own options (:attr:`~nlobs.methods.base.Method.options`), over the comparison's defaults.
    progress : bool, optional
        A progress bar over observers and steps (``None``: on a terminal, for long runs).
    name : str, optional
        How messages name the model.
    backend : {"python", "c"}
        ``"c"``: every observer that has a C generator (drift, pinv, luenberger, cascade, ekf, ukf) runs as
        its generated, compiled C (:func:`nlobs.export.compile_observer`; the same estimates to rounding
        when the outputs are sampled; with exact outputs it holds ``y`` over each step), and the plant's ``f``
        is stepped by its generated C where the model has expressions or matrices
        (:func:`nlobs.export.plant.compile_plant`; outputs, sensors and noise as in Python).
    executor : optional
        Where the observers run, one task per observer (:mod:`nlobs.simulate.executors`: a Dask client,
        a scheduler address or a process pool; ``None``: here). Each task is the same call as here, so
        the numbers are the same; the runs of one observer stay one batch (its metrics, median
        convergence time and figures need whole records).
    workers : int, optional
        Run the observers on a Dask LocalCluster of this many worker processes.
    scheduler : str, optional
        Run the observers on the Dask scheduler at this address.

    Returns
    -------
    ComparisonReport

    Raises
    ------
    ModelFileError
        The model file (or a CSV input it names) is invalid.
    UnknownNameError
        An observer or input name that does not exist.
    InvalidArgumentError, DimensionError, NonFiniteError
        A bad option (runs, a vector of the wrong length, a rate that does not fit ``dt``...).
    OutputError
        ``out`` cannot be written.
    StudyFailed
        The plant itself diverged (the truth is not finite), or a simulation failed otherwise.
    """
    scenario = model if isinstance(model, Scenario) else (
        load_scenario(model) if isinstance(model, (str, Path)) else Scenario(model))
    label = name or model_label(model if not isinstance(model, Scenario) else scenario.model)
    chosen = tuple(DEFAULT_OBSERVERS if observers is None else observers)
    for o in chosen:
        if o not in OBSERVERS:
            raise UnknownNameError(f"`observers`: unknown observer {o!r} (known: {', '.join(OBSERVERS)})")
    if len(set(chosen)) != len(chosen):
        raise InvalidArgumentError(f"`observers`: {', '.join(chosen)} names an observer twice")
    alpha = None if alpha is None else positive("`alpha`", alpha)
    if backend not in BACKENDS:
        raise InvalidArgumentError(f"`backend`: expected one of {', '.join(BACKENDS)}, got {backend!r}")
    options = method_options(chosen, alpha, filter_q, design_options)
    s = _setup(scenario, label, runs=runs, duration=duration, dt=dt, seed=seed, x0=x0, x_hat0=x_hat0,
               initial_error_std=initial_error_std, box=box, settle=settle, rate=rate, noise_std=noise_std,
               inputs=inputs, process_noise=process_noise)
    if sum(v is not None for v in (executor, workers, scheduler)) > 1:
        raise InvalidArgumentError("`workers` and `scheduler` (or an `executor`): give one (workers start a local "
                                   "cluster, a scheduler address uses a running one)")
    outcomes: dict[str, ObserverOutcome] = {}
    if executor is None and workers is None and scheduler is None:
        shared = _SharedPlant(s, progress, backend)  # the plant integrated once, at the first observer that runs
        for name_ in chosen:
            outcomes[name_] = _run_one(name_, s, _with_p0(name_, options[name_], s), progress, backend, shared)
    else:
        from nlobs.simulate.executors import cluster, run_tasks

        got: dict[int, ObserverOutcome] = {}
        with cluster(workers, scheduler) as client:
            run_tasks(executor if executor is not None else client, _run_task, s,
                      [(n_, _with_p0(n_, options[n_], s), backend) for n_ in chosen], got.__setitem__)
        outcomes = {n_: got[i] for i, n_ in enumerate(chosen)}
    return _report(s, outcomes, (), progress, backend)


def _compiled(obs: Any, desc: str) -> tuple[Any, str]:
    """``obs`` as its generated C where it has a generator (``--backend c``), else itself."""
    from nlobs.export import compile_observer, supported

    if type(obs).__name__ not in supported():
        return obs, desc
    if getattr(obs, "bounds", None) is not None:  # the generated C has no projection onto the bounds
        return obs, desc + "; in Python (the generated C does not project onto the [constraints])"
    return compile_observer(obs), desc + "; generated C"


#: The options a comparison itself gives each method (the caller's design_options come on top).
#: The methods that start from the runs' initial error (``P0 = diag(p0_std²)``) and take the filters' ``filter_q``.
STOCHASTIC: tuple[str, ...] = ("ekf", "ukf", "pf", "mhe")
_DEFAULT_KEYS: dict[str, set[str]] = {"drift": {"on_singular"}, "luenberger": {"alpha"},
                                      **{k: {"filter_q", "p0_std"} for k in STOCHASTIC}}


def method_options(chosen: Sequence[str], alpha: float | None, filter_q: ArrayLike | None,
                   given: Mapping[str, Mapping[str, Any]] | None) -> dict[str, dict[str, Any]]:
    """The design options ``nlobs simulate`` (and ``nlobs estimate``) give each chosen method: their defaults, then
    the options given.

    Parameters
    ----------
    chosen : sequence of str
        The methods.
    alpha : float or None
        The Luenberger design's decay rate (``None``: its default).
    filter_q : array_like or None
        The Kalman filters' process noise (``None``: the file's, else their default).
    given : Mapping or None
        Per method, options that override (each checked against the method's options).

    Returns
    -------
    dict
        Per method, its options.

    Raises
    ------
    InvalidArgumentError
        A method not among ``chosen``, or an option the method does not take.

    Examples
    --------
    >>> method_options(["drift", "ekf"], None, None, {"drift": {"mu": 2.0}})
    {'drift': {'on_singular': 'nan', 'mu': 2.0}, 'ekf': {'filter_q': None}}
    """
    given = dict(given or {})
    unknown = sorted(set(given) - set(chosen))
    if unknown:
        raise InvalidArgumentError(f"`design_options`: {', '.join(map(repr, unknown))} is not among the observers "
                                   f"compared ({', '.join(chosen)})")
    out: dict[str, dict[str, Any]] = {}
    for name in chosen:
        base: dict[str, Any] = {"drift": {"on_singular": "nan"}, "luenberger": {} if alpha is None else {"alpha": alpha},
                                **{k: {"filter_q": filter_q} for k in STOCHASTIC}}.get(name, {})
        extra = dict(given.get(name, {}))
        method = get_method(name)
        bad = sorted(set(extra) - set(method.options))
        if bad:
            raise InvalidArgumentError(f"`design_options`: {', '.join(bad)} is not an option of {name} (it takes "
                                       f"{', '.join(sorted(method.options)) or 'none'})")
        out[name] = {**base, **extra}
    return out


def _with_p0(name: str, options: dict[str, Any], s: _Setup) -> dict[str, Any]:
    """A Kalman filter starts from the runs' initial error (``P0 = diag(p0_std²)``) unless given one."""
    if name in STOCHASTIC and "p0_std" not in options:
        return {**options, "p0_std": s.p0_std}
    return options


def design_observer(name: str, problem: Problem, options: Mapping[str, Any]) -> Design | str:
    """The method's design for a problem, or why the observer is skipped (one line): what ``nlobs simulate`` and
    ``nlobs estimate`` run, the same design for the same model file and options.

    Parameters
    ----------
    name : str
        A method of :func:`~nlobs.methods.registry.names` (``drift``, ``pinv``, ``luenberger``, ``cascade``,
        ``ekf``, ``ukf``).
    problem : Problem
        The model file's problem (:func:`~nlobs.methods.problem.problem`).
    options : Mapping
        The method's design options (:func:`method_options`, and ``p0_std`` for the Kalman filters).

    Returns
    -------
    Design or str
        The usable design, or why there is none (an assumption, a design that failed).

    Raises
    ------
    InvalidArgumentError
        A design option given by the caller is refused (named with its method).

    Examples
    --------
    >>> from nlobs.methods.problem import problem
    >>> d = design_observer("luenberger", problem("cartpole"), {})
    >>> d.method, d.usable
    ('luenberger', True)
    >>> design_observer("drift", problem("gnss-ins-axis"), {})
    '(3.1) of Dalla Mora, Germani & Manes is for nonlinear input-affine models; this one is linear'
    """
    method = get_method(name)
    why = method.applies(problem)
    if why is not None:
        return str(why)
    try:
        design = method.design(problem, **options)
    except (ModelError, AssumptionViolated, DesignError) as exc:
        return str(exc)
    except NlobsError as exc:  # a bad option (the design's own failures are caught above)
        given = set(options) - _DEFAULT_KEYS.get(name, set())
        text = str(exc).replace("`", "")
        if any(text.startswith((f"{k}:", f"{k.rpartition('_')[2]}:")) for k in given):  # a design option given
            raise InvalidArgumentError(f"`design_options` {name}: {text}") from exc
        if any(f"`{k}`" in str(exc) for k in given):  # a design option the caller gave: named with its method
            raise InvalidArgumentError(f"`design_options` {name}: {str(exc).replace('`', '')}") from exc
        raise
    except (TypeError, ValueError) as exc:  # a value the method could not even read (NumPy's conversions)
        given = set(options) - _DEFAULT_KEYS.get(name, set())
        if not given:
            raise
        raise InvalidArgumentError(f"`design_options` {name}: {', '.join(sorted(given))}: {exc}") from exc
    if not design.usable:
        return "; ".join(design.failed)
    return design


class _SharedPlant:
    """The comparison's plant run with its sensors (:func:`~nlobs.simulate.loop.simulate_plant`), made at the first
    call and replayed to every observer: the observers see the same samples, and the plant is integrated once."""

    def __init__(self, s: _Setup, progress: bool | None, backend: str = "python") -> None:
        self._s, self._progress, self._backend = s, progress, backend
        self._run: PlantRun | None = None
        self._plant: Any = None

    @property
    def plant(self) -> Any:
        """The plant as it runs: its generated C with ``backend="c"`` where it has a generator (made once)."""
        if self._plant is None:
            self._plant = _plant(self._s, self._backend)
        return self._plant

    def __call__(self) -> PlantRun:
        if self._run is None:
            s = self._s
            self._run = simulate_plant(self.plant, _initial(s), duration=s.duration, dt=s.dt, u=s.u,
                                       measurements=s.sensors, process_noise=s.process_noise, seed=s.seed,
                                       save_every=s.save_every, progress=self._progress)
        return self._run


def _plant(s: _Setup, backend: str) -> Any:
    """The comparison's plant, as its generated C with ``backend="c"`` where it has a generator (its ``f`` stepped
    in C; outputs, sensors and noise as in Python, so the same draws), else itself."""
    if backend != "c":
        return s.plant
    from nlobs.export.plant import compile_plant, has_plant_generator

    return compile_plant(s.plant) if has_plant_generator(s.plant) else s.plant


def _initial(s: _Setup) -> Array:
    """The runs' initial plant state: one vector for one run (no batch axis: the single-run paths), else a batch."""
    return s.x0 if s.runs == 1 else np.broadcast_to(s.x0, (s.runs, s.scenario.model.n))


def _run_one(name: str, s: _Setup, options: Mapping[str, Any], progress: bool | None,
             backend: str = "python", shared: _SharedPlant | None = None) -> ObserverOutcome:
    design = design_observer(name, s.problem, options)
    if isinstance(design, str):
        return ObserverOutcome(name, design)
    obs, desc = design.observer, design.description
    cert = None if design.certificate is None else _Cert(design.verified, design.hypotheses,
                                                           design.coverage_extras, design.bound)
    obs = _recording_covariance(obs, s)
    if backend == "c":
        obs, desc = _compiled(obs, desc)
    one = s.runs == 1  # one run without a batch axis: the single-run paths of the compiled code and the filters
    x_hat0 = s.x_hat0[0] if one else s.x_hat0
    try:
        if s.controller is not None:  # closed loop: the plant depends on the observer, integrated with each
            plant = shared.plant if shared is not None else _plant(s, backend)
            res = simulate(plant, obs, _initial(s), x_hat0, duration=s.duration, dt=s.dt, u=None,
                           measurements=s.sensors or None, process_noise=s.process_noise, seed=s.seed,
                           save_every=s.save_every, progress=progress, divergence="keep", controller=s.controller)
        elif shared is not None and s.sensors:  # sampled outputs: the observer replays the one plant run
            res = observe(shared(), obs, x_hat0, progress=progress, divergence="keep")
        else:  # exact outputs are read at every RK4 stage of the plant: integrated with each observer
            plant = shared.plant if shared is not None else _plant(s, backend)
            res = simulate(plant, obs, _initial(s), x_hat0, duration=s.duration, dt=s.dt, u=s.u,
                           measurements=s.sensors or None, process_noise=s.process_noise, seed=s.seed,
                           save_every=s.save_every, progress=progress, divergence="keep")
        if one:
            res = with_run_axis(res)
    except SimulationDiverged as exc:
        if exc.which == "plant":
            raise StudyFailed(f"the plant itself diverged ({exc}): check x0, the inputs and the process noise") from exc
        return dataclasses.replace(_failed(name, desc, s, f"stopped: {exc}"), design=design)
    except NlobsError as exc:
        if isinstance(exc, (InvalidArgumentError, DimensionError)) and "rate" in str(exc):
            raise
        return dataclasses.replace(_failed(name, desc, s, f"stopped: {exc}"), design=design)
    return dataclasses.replace(_outcome(name, desc, res, s, cert, design), observer=obs, design=design)


#: The most covariance values (runs × saved instants × n²) a comparison records for a filter's NEES.
MAX_COVARIANCE_VALUES = 20_000_000


def _recording_covariance(obs: Any, s: _Setup) -> Any:
    """A Kalman filter that also records its covariance at the saved instants (its NEES, :func:`_outcome`), where
    the runs' covariances fit :data:`MAX_COVARIANCE_VALUES`; any other observer as it is."""
    if getattr(obs, "record_covariance", True):
        return obs
    n = s.scenario.model.n
    saved = round(s.duration / s.dt) // s.save_every + 1
    if s.runs * saved * n * n > MAX_COVARIANCE_VALUES:
        return obs
    return dataclasses.replace(obs, record_covariance=True)


def _run_task(s: _Setup, name: str, options: Mapping[str, Any], backend: str) -> ObserverOutcome:
    """:func:`_run_one` on a worker (no progress bar there)."""
    return _run_one(name, s, options, False, backend)


def _failed(name: str, desc: str, s: _Setup, reason: str) -> ObserverOutcome:
    """An observer whose batch stopped with an error: every run counts as diverged, the reason kept."""
    return ObserverOutcome(name, None, desc, (math.nan,) * s.scenario.model.n, (math.nan,) * s.scenario.model.n,
                           diverged_runs=tuple(DivergedRun(i, math.nan, reason) for i in range(s.runs)),
                           run_rms=np.full(s.runs, np.nan))


def _unobservable(s: _Setup) -> tuple[str, ...]:
    """The unobservable directions of the comparison's model (computed once per problem; the designs ask it too)."""
    u = s.problem.observability
    return tuple(u.directions) if u is not None and u.rank is not None and not u.observable else ()


def _reference_loop(s: _Setup, progress: bool | None, backend: str) -> SimulationResult:
    """The law fed the true state, on the runs' noise (the same sensors and process noise draws, in order)."""
    res = simulate(_plant(s, backend), None, _initial(s), duration=s.duration, dt=s.dt, u=None,
                   measurements=s.sensors or None, process_noise=s.process_noise, seed=s.seed, save_every=s.save_every,
                   progress=progress, divergence="keep", controller=s.controller, feedback="state")
    return with_run_axis(res) if s.runs == 1 else res


def _loops_and_bounds(s: _Setup, outcomes: dict[str, ObserverOutcome], progress: bool | None,
                      backend: str) -> tuple[dict[str, ObserverOutcome], Any, Any, Any]:
    """Each outcome with its closed loop against the reference, the top-level ``closed_loop`` and ``constraints``,
    and the reference loop's runs."""
    loop = bounds = ref = None
    truth = next((o.result.x for o in outcomes.values() if o.result is not None and o.result.x is not None), None)
    if s.controller is not None:
        ref = _reference_loop(s, progress, backend)
        assert ref.x is not None
        loop = loop_setup(s.controller, ref.x, ref.extras["u"], ref.t, s.settle)
        outcomes = {k: o if o.result is None or o.result.x is None else dataclasses.replace(
            o, closed_loop=closed_loop_metrics(o.result.x, o.result.extras["u"], o.result.x_hat, ref.x, ref.t,
                                               s.settle)) for k, o in outcomes.items()}
        truth = ref.x if truth is None else truth
    if s.bounds is not None:
        if truth is None:  # every observer skipped: the plant's run alone
            truth = (_reference_loop(s, progress, backend) if s.controller is not None else
                     _SharedPlant(s, progress, backend)().result).x
            truth = truth if truth.ndim == 3 else truth[None]
        box = s.scenario.defaults.box
        bounds = bounds_report(s.bounds, truth, box)
    return outcomes, loop, bounds, ref


def _report(s: _Setup, outcomes: dict[str, ObserverOutcome], files: tuple[Path, ...], progress: bool | None = None,
            backend: str = "python") -> ComparisonReport:
    outcomes, loop, bounds, ref = _loops_and_bounds(s, outcomes, progress, backend)
    ran = [o for o in outcomes.values() if o.skipped is None]
    if not ran:
        verdict, msg = Verdict.NO_OBSERVER, f"{s.label}: none of the observers applies: " + "; ".join(
            f"{o.name}: {o.skipped}" for o in outcomes.values())
    elif all(len(o.diverged_runs) == s.runs for o in ran):
        verdict, msg = Verdict.FAILED, f"{s.label}: every run of every observer diverged"
    else:
        verdict, msg = Verdict.OK, ""
    model = s.scenario.model
    return ComparisonReport(
        model=model.name, states=tuple(model.states), units=tuple(s.scenario.unit(v) for v in model.states),
        runs=s.runs, seed=s.seed, duration=s.duration, dt=s.dt, settle=s.settle,
        time_unit=s.scenario.time_unit, x0=tuple(float(v) for v in s.x0),
        setup=s.describe, observers=outcomes, files=files, verdict=verdict, message=msg, scenario=s.scenario,
        plant=s.plant, unobservable=_unobservable(s), closed_loop=loop, constraints=bounds,
        reference=ref)

