r"""``nlobs design drift``: the observer (3.1) of Dalla Mora, Germani & Manes, its report and a simulation.

The design and its report are :data:`nlobs.methods.drift.DRIFT` and
:func:`nlobs.methods.drift.design_drift_report` (the method every command uses: the region, ``α`` and
``μ`` by the one rule of :mod:`nlobs.methods.problem`). This module adds :func:`simulate_drift` (that
design simulated against its plant, with the bound (3.2), as a :class:`DriftSimulation`) and
:func:`design_drift_observer`, the command ``nlobs design drift``: one call, one frozen
:class:`DriftWorkflowReport` whose ``to_dict()`` is the JSON report and ``summary()`` what the text
output prints, with its :class:`~nlobs.workflows.verdict.Verdict`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs.errors import (
    InvalidArgumentError,
    SimulationDiverged,
    StudyFailed,
)
from nlobs.geometry.region import Box
from nlobs.observers.drift import DriftObserver
from nlobs.simulate.coverage import COVERAGE_JSON, Coverage, InputBound, InRegion, Premise, monitor
from nlobs.simulate.loop import simulate
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.sampling import MeasurementGroup
from nlobs.synthesis.drift_bounds import ErrorBoundConstants, error_bound_constants
from nlobs.synthesis.drift_gain import (
    vandermonde_gain,
    riccati_constant,
    verify_drift_gain,
)
from nlobs.systems.brunovsky import brunovsky
from nlobs.systems.symbolic import SymbolicModel
from nlobs._schema import BOOLEAN, NUMBER, Record
from nlobs.methods.base import Design, joined_design_json
from nlobs.methods.drift import DRIFT, DRIFT_DESIGN_JSON, METHODS, DriftDesignReport, design_drift_report
from nlobs.methods.problem import problem
from nlobs.workflows._results import (
    ERROR_SUMMARY_JSON,
    checked_request,
    error_line,
    error_summary,
    explain_divergence,
    run_study,
    write_result,
)
from nlobs.workflows.inputs import SimulationRequest, model_label, model_units, symbolic_model
from nlobs.workflows.verdict import Verdict

__all__ = [
    "METHODS",
    "DriftDesignReport",
    "DriftSimulation",
    "DriftWorkflowReport",
    "design_drift_observer",
    "design_drift_report",
    "simulate_drift",
]



# --------------------------------------------------------------------------- the design


# --------------------------------------------------------------------------- simulate


@dataclass(frozen=True, eq=False)
class DriftSimulation:
    """A designed observer (3.1) simulated against its plant, with the bound (3.2).

    Attributes
    ----------
    report : DriftDesignReport
        Structure, checks, gain certificate, Lipschitz estimates and ``κ₁, κ₂``.
    w : float or None
        Vandermonde parameter of the simulated gain.
    result : SimulationResult
    bound : ndarray, shape (*batch, K)
        ``κ₁ e^{−αt} ‖e(0)‖`` (3.2) with ``b = 0`` (Lipschitz case, H1); NaN when the simulated
        gain is not certified (:attr:`gain_certified`).
    bound_ratio : float
        ``max_t ‖e(t)‖ / bound(t)`` (``≤ 1`` where the bound holds; NaN when the gain is not certified).
        Measured also for a run the certificate does not cover (then it is evidence, not a guarantee).
    decay_rate : float
        Fitted exponential rate of ``‖e‖`` (``floor`` 1e-9 relative, see
        :meth:`SimulationResult.decay_rate`), smallest over the batch.
    gain_certified : bool
        The simulated gain (with its ``P``) satisfies (2.17) for the report's constants, the model is
        drift-observable on the region, and ``γ`` is not below the sampled estimate there (report's
        ``warnings``).
    coverage : Coverage
        The hypotheses of Theorem 3.1 checked along the run (:func:`nlobs.simulate.coverage.monitor`):
        the state and the estimate in the region (where ``γ`` and the Lipschitz constants were
        sampled), ``‖u(t)‖ ≤ μ``, an exact output.
    constants : ErrorBoundConstants
        ``κ₁``, ``κ₂`` of the simulated gain's ``P``.

    Examples
    --------
    The Lipschitz oscillator of Dalla Mora, Germani & Manes (``Φ_s`` the identity, ``γ`` known exactly) under
    ``u = 0.8 sin 2t``, on a region its estimate never leaves: the error stays below the bound (3.2) at every
    saved instant, and the run is certified:

    >>> import math
    >>> import numpy as np
    >>> from nlobs.geometry.region import Box
    >>> from nlobs.papers import dallamora2000
    >>> model = dallamora2000.lipschitz_oscillator_model()
    >>> gamma = math.hypot(math.hypot(1.5, 1.0), 0.5)  # √(γ_L² + γ_H²), exact
    >>> sim = simulate_drift(model, [1.0, 0.0], [-1.0, 1.0], 1.0, dt=2e-3, gamma=gamma,
    ...                      region=Box([-12.0, -12.0], [12.0, 12.0]), u=lambda t: np.array([0.8 * math.sin(2 * t)]))
    >>> type(sim).__name__, sim.result.t.shape, sim.bound.shape
    ('DriftSimulation', (501,), (501,))
    >>> bool(np.all(sim.result.error_norm <= sim.bound)), round(sim.bound_ratio, 2), bool(sim.decay_rate > 1.0)
    (True, 0.1, True)
    >>> sim.gain_certified, sim.coverage.covers_run, sim.certified, round(sim.constants.kappa1, 1)
    (True, True, True, 47.4)
    >>> d = sim.to_dict()
    >>> d["design"]["s"], round(d["w"], 2), bool(d["final_error_norm"] < 1e-3)
    ([2], 9.44, True)
    """

    report: DriftDesignReport
    w: float | None
    result: SimulationResult
    bound: Array
    bound_ratio: float
    decay_rate: float
    gain_certified: bool
    constants: ErrorBoundConstants
    coverage: Coverage

    @property
    def certified(self) -> bool:
        """Theorem 3.1 covers this run: the gain is certified and the run stayed inside every hypothesis."""
        return self.gain_certified and self.coverage.covers_run

    def to_dict(self) -> dict[str, Any]:
        return {"design": self.report.to_dict(), "w": self.w, "certified": self.certified,
                "gain_certified": self.gain_certified, **self.coverage.to_dict(),
                "bound_constants": self.constants.to_dict(), "bound_ratio": self.bound_ratio,
                "decay_rate": self.decay_rate, "final_error_norm": float(np.max(self.result.error_norm[..., -1]))}


def simulate_drift(
    model: SymbolicModel,
    x0: ArrayLike,
    x_hat0: ArrayLike,
    duration: float,
    *,
    dt: float,
    u: Callable[[float], Array] | ArrayLike | None = None,
    s: Sequence[int] | None = None,
    alpha: float = 1.0,
    mu: float = 1.0,
    gamma: float | None = None,
    method: str = "vandermonde",
    w: float | None = None,
    region: Box | None = None,
    parameters: Mapping[str, float] | None = None,
    noise_std: float = 0.0,
    seed: int | None = None,
    regularization: float = 0.0,
    save_every: int = 1,
    report: DriftDesignReport | None = None,
    saturation: bool = True,
) -> DriftSimulation:
    """Design observer (3.1) with :func:`design_drift_report` (or take ``report``) and simulate it.

    ``w`` given: the gain ``K(w)`` of Remark 2.11 (checked against (2.17); if it fails,
    the report keeps the theory's smallest ``w`` and the simulation still uses ``w`` —
    the paper's "tuning by simulation"). The gain gets the bound (3.2) when the report's premises
    hold too (``gain_certified``); the run is ``certified`` only when, besides, it stays inside
    every hypothesis of Theorem 3.1 along the way (``coverage``, see :class:`DriftSimulation`). ``noise_std > 0`` samples every output at
    ``1/dt`` with that Gaussian noise (``seed`` required). ``report`` reuses a design.

    ``saturation`` (default on): the observer's nonlinear terms are saturated on the design's region
    outside it (Khalil's form, :mod:`nlobs.observers.drift`); while the estimate is in the region it is
    (3.1) itself, so every run the certificate covers is unchanged. ``False``: (3.1) as printed.

    Parameters
    ----------
    model : SymbolicModel
        The plant, and the model the observer is designed for.
    x0 : array_like, shape (n,) or (*batch, n)
        Initial plant state(s).
    x_hat0 : array_like, shape (n,) or (*batch, n)
        Initial estimate(s).
    duration : float
        Simulated time span (seconds).
    dt : float
        Integration step (and the sampling period of noisy outputs).
    u : None, array_like or callable, optional
        Known input: a constant or a callable ``u(t)``.
    s, alpha, mu, gamma, method, region : optional
        As in :func:`design_drift_report` (not used with ``report``).
    w : float, optional
        Vandermonde parameter of the simulated gain; default: the gain of the report's certificate.
    parameters : mapping of str to float, optional
        Override values of the model's named parameters (design and plant).
    noise_std : float
        Standard deviation of the Gaussian noise on every output (``0``: exact outputs).
    seed : int, optional
        State of the random generator of the measurement noise (required when ``noise_std > 0``).
    regularization : float
        Tikhonov ``ε`` of the observer's solve with ``Q_s`` (``0``: exact).
    save_every : int
        Keep every ``save_every``-th step (and always the last one).
    report : DriftDesignReport, optional
        A design to reuse instead of calling :func:`design_drift_report`.
    saturation : bool
        Saturate the observer's nonlinear terms outside the design's region.

    Returns
    -------
    DriftSimulation

    Examples
    --------
    The Lipschitz oscillator of Dalla Mora, Germani & Manes with its exact ``γ``: the design's gain (the
    smallest ``w`` of Remark 2.11 solving (2.17)) against the paper's "tuning by simulation" with ``w = 3``,
    which (2.17) does not certify (so no bound (3.2)), and which converges more slowly:

    >>> import math
    >>> import numpy as np
    >>> from nlobs.geometry.region import Box
    >>> from nlobs.papers import dallamora2000
    >>> model = dallamora2000.lipschitz_oscillator_model()
    >>> gamma = math.hypot(math.hypot(1.5, 1.0), 0.5)
    >>> report = design_drift_report(model, gamma=gamma, region=Box([-12.0, -12.0], [12.0, 12.0]))
    >>> u = lambda t: np.array([0.8 * math.sin(2.0 * t)])
    >>> designed = simulate_drift(model, [1.0, 0.0], [-1.0, 1.0], 1.0, dt=2e-3, u=u, report=report)
    >>> tuned = simulate_drift(model, [1.0, 0.0], [-1.0, 1.0], 1.0, dt=2e-3, u=u, report=report, w=3.0)
    >>> round(designed.w, 2), designed.certified, tuned.w, tuned.gain_certified, math.isnan(tuned.bound_ratio)
    (9.44, True, 3.0, False, True)
    >>> e_designed, e_tuned = designed.result.error_norm[-1], tuned.result.error_norm[-1]
    >>> round(float(designed.result.error_norm[0]), 4), bool(e_designed < 1e-3), bool(e_designed < e_tuned < 0.5)
    (2.2361, True, True)
    """
    rep = report or design_drift_report(model, s, alpha=alpha, mu=mu, gamma=gamma, method=method, region=region,
                                        parameters=parameters)
    bound_consts = rep.bound
    # Theorem 3.1's premises besides (2.17): drift-observable on the region, γ not below its sampled estimate there
    premises = rep.drift_check.passed and not rep.warnings
    certified = premises and rep.certificate.verified
    if w is None:
        K, w_used = rep.certificate.gain, rep.certificate.w
    else:  # the paper's tuning by simulation: K(w) is checked against (2.17), the bound applies only if it holds
        g = vandermonde_gain(rep.s, w)
        K, w_used = g.K, float(w)
        cw = verify_drift_gain(rep.certificate.constants, g.K, g.P, method="vandermonde", w=w_used)
        certified = premises and cw.verified
        bound_consts = error_bound_constants(cw, rep.lipschitz.gamma_phi, rep.lipschitz.gamma_phi_inv)
    obs = DriftObserver.from_fields(rep.fields, rep.s, K, regularization=regularization,
                                    saturation=rep.region if saturation else None)
    plant = model.compile(parameters)
    meas = None
    if noise_std > 0:
        meas = MeasurementGroup("y", list(model.outputs), rate=1.0 / dt, noise_std=noise_std)
    res = simulate(plant, obs, x0=x0, x_hat0=x_hat0, duration=duration, dt=dt, u=u, measurements=meas, seed=seed,
                   save_every=save_every)
    e = res.error_norm
    bnd = bound_consts.bound(res.t, e[..., 0])
    if not certified:
        bnd = np.full_like(bnd, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = float(np.nanmax(np.where(bnd > 0, e / bnd, np.nan))) if certified else math.nan
    rate = float(np.nanmin(res.decay_rate(floor=1e-9 * float(np.max(e[..., 0])))))
    box = rep.region
    where = box.describe()
    hyps: list[Any] = [InRegion(box.lower, box.upper, "state", where), InRegion(box.lower, box.upper, "estimate", where),
                       Premise("exact measurement", noise_std == 0, f"measurement noise of std {noise_std:g} "
                               "(Theorem 3.1 assumes an exact output)")]
    if model.m:
        hyps.append(InputBound(rep.certificate.constants.mu))
    coverage = monitor(res, hyps, u=u if callable(u) or u is None else np.asarray(u, dtype=float), verified=certified)
    return DriftSimulation(rep, w_used, res, bnd, ratio, rate, certified, bound_consts, coverage)


# --------------------------------------------------------------------------- the command


#: ``design`` of ``nlobs design drift``.
DRIFT_COMMAND_DESIGN_JSON = joined_design_json("DriftCommandDesign", DRIFT_DESIGN_JSON)
#: ``simulation`` of ``nlobs design drift`` with a simulation.
DRIFT_SIMULATION_JSON = ERROR_SUMMARY_JSON.extend("DriftSimulation", {
    "decay_rate": NUMBER,
    "bound_ratio": NUMBER.about("max |e| / the bound (3.2); null when the gain is not certified"),
    "certified": BOOLEAN.about("the gain is certified and the run stayed inside every hypothesis of Theorem 3.1"),
    "gain_certified": BOOLEAN,
    **COVERAGE_JSON.fields,
})
#: ``nlobs design drift``.
DESIGN_DRIFT_JSON = Record("DesignDrift", {
    "design": DRIFT_COMMAND_DESIGN_JSON,
    "simulation": DRIFT_SIMULATION_JSON,
}, optional={"simulation"}, description="The drift-observability observer (3.1) of Dalla Mora, Germani & Manes: "
                                        "design, verification and, when asked, a run checked against Theorem 3.1.")


@dataclass(frozen=True, eq=False)
class DriftWorkflowReport:
    """What ``nlobs design drift`` reports: the design, its simulation if asked for, the files written.

    Attributes
    ----------
    design : DriftDesignReport
    simulation : DriftSimulation or None
        ``None`` without a :class:`~nlobs.workflows.inputs.SimulationRequest`, and when the design
        is not usable (nothing is simulated then).
    request : SimulationRequest or None
        The simulation asked for.
    files : tuple of Path
        The plot (``drift.png``) and trajectories (``drift.npz``) written to ``request.out``.
    verdict : Verdict
        ``OK`` when the design is usable (:attr:`DriftDesignReport.usable`); ``NO_OBSERVER`` when
        drift-observability fails on the region (Def. 2.3: no observer (3.1) there); ``FAILED``
        when the design is not usable otherwise (a given ``γ`` below the sampled estimate, a failed
        certificate of (2.17)).
    message : str
        Empty when ``OK``; else ``"<model>: no usable observer: "`` and the reasons.
    method_design : Design or None
        The method's :class:`~nlobs.methods.base.Design` (its ``to_dict()`` keys join ``design`` in
        :meth:`to_dict`: the same ``method``, ``parameters``, ``sources``, ``gain``, ``certified``,
        ``premises`` as every other command reports).

    Examples
    --------
    The pendulum on ``[−1, 1] × [−3, 3]`` without a simulation: a usable design, nothing simulated or
    written. A model whose ``Q_s`` is singular on the region (``Φ_s = (x₁, x₂³)``, ``det Q_s = 3 x₂²``) has no
    observer (3.1) there, and the report says so instead of raising:

    >>> import sympy as sp
    >>> from nlobs.systems.symbolic import SymbolicModel
    >>> rep = design_drift_observer("pendulum", box=[-1, 1, -3, 3])
    >>> rep.verdict.value, rep.simulation, rep.files, list(rep.to_dict())
    ('ok', None, (), ['design'])
    >>> print(rep.summary().splitlines()[0])
    drift-observability observer (Dalla Mora–Germani–Manes) for pendulum
    >>> x1, x2 = sp.symbols("x1 x2")
    >>> sing = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2**3, -x1], g=[[0], [1]], h=[x1],
    ...                                   name="sing")
    >>> bad = design_drift_observer(sing, gamma=1.0)
    >>> bad.verdict.value, bad.simulation
    ('no observer', None)
    >>> bad.message
    'sing: no usable observer: drift-observability fails on the region (Q_s loses rank at x = ...'
    """

    design: DriftDesignReport
    simulation: DriftSimulation | None
    request: SimulationRequest | None
    files: tuple[Path, ...]
    verdict: Verdict
    message: str
    method_design: Design | None = None

    def _simulation_dict(self) -> dict[str, Any]:
        sim = self.simulation
        assert sim is not None
        out = error_summary(sim.result, self.files)
        out.update(decay_rate=sim.decay_rate, bound_ratio=sim.bound_ratio, certified=sim.certified,
                   gain_certified=sim.gain_certified, **sim.coverage.to_dict())
        return out

    def to_dict(self) -> dict[str, Any]:
        """``{"design": …, "simulation": …}``: the JSON report of ``nlobs design drift``.

        ``simulation`` (present only when one ran) has ``final_error_norm``,
        ``initial_error_norm``, ``max_error_norm`` (largest over a batch), ``files``,
        ``decay_rate``, ``bound_ratio`` (``max ‖e‖ / bound (3.2)``; NaN when the gain is not certified),
        ``certified`` (the gain is certified *and* the run stayed inside every hypothesis of Theorem 3.1),
        ``gain_certified``, and the monitor's ``certificate_covers_run``, ``certificate_covered_fraction``,
        ``certificate_violations`` (first per run: hypothesis, time, detail), ``certificate_failed_premises``,
        ``certificate_hypotheses``.
        """
        data: dict[str, Any] = {"design": DRIFT_COMMAND_DESIGN_JSON.emit({**self.design.to_dict(), **(
            {} if self.method_design is None else self.method_design.to_dict())})}
        if self.simulation is not None:
            data["simulation"] = DRIFT_SIMULATION_JSON.emit(self._simulation_dict())
        return DESIGN_DRIFT_JSON.emit(data)

    def summary(self) -> str:
        """The design report, where its defaults came from, then the simulation line and a ``wrote <file>`` line per file."""
        lines = [self.design.summary()]
        if self.method_design is not None:
            lines.append(f"  from the model file: {self.method_design.defaults_text() or 'nothing (every value given)'}; "
                         f"{self.method_design.status}")
            sampled = [d for d in self.method_design.details if d.startswith("sampling budget")]
            premise = next((h for h in self.method_design.hypotheses
                            if getattr(h, "name", "").startswith("sampled with period")), None)
            if sampled or premise is not None:  # the file's sensors: what the certificate says of their sampling
                how = self.method_design.parameters.get("sampling", "")
                lines.append(f"  under the file's sensors ({how}): " + "; ".join(
                    [*sampled, *([] if premise is None or premise.holds else [premise.reason])]))
        sim, req = self.simulation, self.request
        if sim is not None and req is not None:
            alpha = self.design.certificate.constants.alpha
            lines.append(error_line(self._simulation_dict(), req.duration, req.dt)
                         + f", fitted decay rate {sim.decay_rate:.4g} (α = {alpha:g}), max ‖e‖/bound(3.2) = "
                         f"{sim.bound_ratio:.3g}" + ("" if sim.certified else " (gain not certified)"
                                                     if not sim.gain_certified else
                                                     " (the certificate does not cover this run: "
                                                     + "; ".join(sim.coverage.reasons) + ")"))
            lines += [f"wrote {f}" for f in self.files]
        return "\n".join(lines)


def design_drift_observer(
    model: str | Path | SymbolicModel,
    *,
    s: Sequence[int] | None = None,
    alpha: float | None = None,
    mu: float | None = None,
    gamma: float | None = None,
    method: str = "vandermonde",
    w: float | None = None,
    box: Sequence[float] | Box | None = None,
    simulate: SimulationRequest | None = None,
    name: str | None = None,
    w_max: float = 1e5,
    saturation: bool = True,
) -> DriftWorkflowReport:
    """Design and verify observer (3.1) for a model, and simulate it if asked: ``nlobs design drift``.

    Parameters
    ----------
    model : str, Path or SymbolicModel
        A model file, a shipped model name (:func:`nlobs.systems.modelfile.load_model`) or a
        loaded continuous-time input-affine model.
    s : sequence of int, optional
        Multi-index (default: the observability indices on the region).
    alpha, mu : float, optional
        Decay rate ``α`` (default 1) and input bound ``μ`` of (2.17) (default: the largest
        ``‖u(t)‖`` of the file's ``[input_signals]`` over its ``[simulation]`` duration, by the rule
        of :mod:`nlobs.methods.problem`; 0 for a model given without a file).
    gamma : float, optional
        ``γ`` of (2.17) (default: estimated by sampling the region).
    method : {"vandermonde", "sdp"}
        Remark 2.11 (smallest ``w``, or ``w`` checked) or the LMI design.
    w : float, optional
        Use ``K(w)`` of Remark 2.11 instead of the smallest ``w`` solving (2.17); it is checked,
        and the simulation (if any) uses it.
    box : sequence of float, or Box, optional
        The region: ``lo, hi`` for every state or ``lo1, hi1, …``
        (:func:`~nlobs.workflows.inputs.box_from_numbers`); default: the file's ``[simulation] box``,
        else ``[−1, 1]ⁿ``.
    simulate : SimulationRequest, optional
        Simulate the design from these initial conditions (only when it is usable) and write
        the plot and trajectories to ``simulate.out``.
    name : str, optional
        How :attr:`DriftWorkflowReport.message` names the model (default: ``model`` as given, or
        the model's name).
    w_max : float
        Largest ``w`` the search of Remark 2.11's smallest ``w`` tries.
    saturation : bool
        Simulate the observer saturated on the region (``True``, the default; the same as (3.1)
        while the estimate is in the region) or (3.1) as printed (``False``).

    Returns
    -------
    DriftWorkflowReport
        Also when the design is not usable: then the verdict says why and nothing is simulated.

    Raises
    ------
    ModelFileError, ModelError
        The model cannot be loaded, is linear, or is not input-affine.
    InvalidArgumentError, NonFiniteError, DimensionError
        A bad option (``method``, ``s``, the sizes of the simulation's vectors).
    BoxError
        ``box`` does not make a box of the state space.
    AssumptionViolated
        A structural assumption fails before a design exists.
    DesignError
        No gain satisfies (2.17) (infeasible; a given ``w`` that does not solve it).
    OutputError
        ``simulate.out`` or a file in it cannot be written.
    SimulationDiverged
        The simulation diverged.
    StudyFailed
        The simulation stopped with another nlobs error (e.g. ``Q_s`` singular along the estimate);
        the cause is chained.

    Examples
    --------
    The pendulum on ``[−1, 1] × [−3, 3]``: the smallest ``w`` of Remark 2.11 solving (2.17) of Dalla Mora,
    Germani & Manes, then one second of observer (3.1) from a 0.01 rad initial error. The run stays inside
    the region, so Theorem 3.1 covers it, and its error stays below the bound (3.2):

    >>> from nlobs.workflows.inputs import SimulationRequest
    >>> req = SimulationRequest([0.5, 0.0], [0.49, 0.0], duration=1.0)
    >>> rep = design_drift_observer("pendulum", box=[-1, 1, -3, 3], simulate=req)
    >>> rep.verdict.value, rep.design.s, round(rep.design.certificate.w, 1)
    ('ok', (2,), 217.9)
    >>> sim = rep.to_dict()["simulation"]
    >>> bool(sim["final_error_norm"] < 1e-6), round(sim["bound_ratio"], 2), sim["certified"]
    (True, 0.1, True)
    """
    label = model_label(model) if name is None else str(name)
    if method not in METHODS:
        raise InvalidArgumentError(f"`method`: expected 'vandermonde' or 'sdp', got {method!r}")
    pb = problem(model, box=box, label=label)  # the model file is read once, here
    m = symbolic_model(pb.model)
    # α, μ, γ checked (and named as the parameters) before the Lipschitz sampling and the design
    if alpha is not None:
        riccati_constant("`alpha`", alpha)
    if mu is not None:
        riccati_constant("`mu`", mu, allow_zero=True)
    if gamma is not None:
        riccati_constant("`gamma`", gamma, allow_zero=True)
    # the simulation's vectors, size and output folder are checked before the design (which can take long)
    resolved = checked_request(simulate, m)
    w_max = riccati_constant("`w_max`", w_max)
    design = DRIFT.design(pb, s=s, alpha=alpha, mu=mu, gamma=gamma, gain_method=method, w=w, w_max=w_max)
    rep = design.report
    if not design.usable:
        verdict = Verdict.NO_OBSERVER if not rep.drift_check.passed else Verdict.FAILED
        return DriftWorkflowReport(rep, None, simulate, (), verdict,
                                   f"{label}: no usable observer: " + "; ".join(design.failed), design)
    if simulate is None:
        return DriftWorkflowReport(rep, None, None, (), Verdict.OK, "", design)
    assert resolved is not None
    x0, x_hat0, u = resolved
    try:
        sim = run_study(lambda: simulate_drift(m, x0, x_hat0, simulate.duration, dt=simulate.dt, u=u, w=w, report=rep,
                                               saturation=saturation))
    except (SimulationDiverged, StudyFailed) as exc:
        eig = rep.certificate.eigenvalues if w is None else np.linalg.eigvals(
            brunovsky(rep.s)[0] - vandermonde_gain(rep.s, w).K @ brunovsky(rep.s)[2])
        raise explain_divergence(exc, float(np.max(np.abs(eig))), simulate.dt, saturation) from exc
    files = write_result(sim.result, simulate.out, "drift", model_units(model))
    return DriftWorkflowReport(rep, sim, simulate, files, Verdict.OK, "", design)
