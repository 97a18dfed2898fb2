r"""``nlobs design pinv``: design, check and simulate Röbenack's Moore–Penrose observer (7), (17).

For a continuous-time input-affine model with observation relative degree ``r`` (A1) the observer
is ``x̂̇ = f(x̂) + g(x̂) u + Q⁺(x̂) K (y − h(x̂))`` (7) with the gain field (17)
(:class:`nlobs.observers.pinv.PinvObserver`) and ``K`` from a high-gain placement of the roots of
(10) (:class:`nlobs.synthesis.pinv_gain.HighGain`).

* :func:`design_pinv_report` — builds the observer once (checking A1 and A5 on the region) and
  reports its structure, ``Q⁺`` (25), the gain field and ``k``; the :class:`PinvDesignReport`
  keeps that observer (:attr:`PinvDesignReport.observer`);
* :func:`simulate_pinv` — simulates a model with that observer (or builds one the same way);
* :func:`design_pinv_observer` — the command ``nlobs design pinv``: one call, one frozen
  :class:`PinvWorkflowReport` whose ``to_dict()`` is what ``--json`` prints and ``summary()``
  what the text output prints; the simulation uses the report's own observer.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from nlobs.checks import Check
from nlobs.errors import InvalidArgumentError
from nlobs.geometry.checks import observability_rank
from nlobs.geometry.lie import lie_derivative
from nlobs.geometry.region import Box
from nlobs.observers.pinv import AssumptionWarning, PinvObserver
from nlobs.simulate.coverage import Coverage, InRegion, Premise, monitor
from nlobs.simulate.loop import simulate
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.sampling import MeasurementGroup
from nlobs.simulate.signals import InputLike
from nlobs.synthesis.pinv_gain import DEFAULT_THETA, PLACEMENTS, HighGain, Placement
from nlobs.systems.symbolic import SymbolicModel
from nlobs.workflows._results import checked_request, error_line, error_summary, run_study, write_result
from nlobs.workflows.inputs import SimulationRequest, as_region, model_units, symbolic_model
from nlobs.workflows.verdict import Verdict

__all__ = [
    "PLACEMENTS",
    "PinvDesignReport",
    "PinvWorkflowReport",
    "design_pinv_observer",
    "design_pinv_report",
    "simulate_pinv",
]


def _build_observer(
    model: SymbolicModel,
    k: ArrayLike | None,
    theta: float,
    placement: Placement,
    region: Box | None,
    parameters: Mapping[str, float] | None,
    pinv: Literal["symbolic", "numeric"],
) -> PinvObserver:
    """Observer (7)/(17) with ``k`` or ``HighGain(theta, placement)``; A5 failing only warns (silenced here)."""
    gain: ArrayLike | HighGain = HighGain(theta, placement) if k is None else k
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AssumptionWarning)
        return PinvObserver.from_model(model, parameters=parameters, k=gain, region=region, require_a5=False,
                                       pinv=pinv)


# ----------------------------------------------------------------------------- the design
def _strings(M: sp.MatrixBase) -> tuple[tuple[str, ...], ...]:
    return tuple(tuple(str(M[i, j]) for j in range(M.shape[1])) for i in range(M.shape[0]))


@dataclass(frozen=True)
class PinvDesignReport:
    """What ``nlobs design pinv`` prints: relative degree, checks, ``Q⁺``, the gain field and ``k``.

    Attributes
    ----------
    model : str
    states, outputs : tuple of str
    relative_degree : tuple of int
    input_gains : tuple of str
        Per output, ``L_g L_f^{r_j−1} h_j`` (where it vanishes the relative degree
        is not uniform, but the observation relative degree still is ``r_j``).
    observability_rank : int or None
        Generic rank of the codistribution spanned by the ``dL_f^k h`` (``None``: undecided, see
        :func:`nlobs.geometry.checks.observability_rank_evidence`).
    checks : tuple of Check
        A1 and A5.
    Q, pinv : tuple of tuple of str
        ``Q`` (13) and ``Q⁺`` (25), row by row.
    gain_field : tuple of tuple of str
        ``l(x) = Q⁺(x) K`` with the symbols ``k1, k2, …`` (n rows, q columns).
    gain_numeric : tuple of tuple of str
        The same with the numeric ``k``.
    k : tuple of float
    roots : tuple of float
        Eigenvalues of every ``A − k cᵀ`` (the roots of (10)).
    theta : float or None
    placement : str or None
    usable : bool
        A1 and A5 hold on the region — a *local* verdict (:attr:`usable_scope`): Corollary 4.1 also
        needs A3, A4 (global Lipschitz and output-to-state stability conditions in the coordinates (2))
        and A6 (the ``τ_i`` complete), which are not checked (:attr:`hypotheses`).
    region : str
        The region A1 and A5 were checked on.
    observer : PinvObserver
        The observer this report describes (built once; :func:`simulate_pinv` with
        ``report=`` runs this very object). Not part of :meth:`to_dict` nor of equality.
    """

    model: str
    states: tuple[str, ...]
    outputs: tuple[str, ...]
    relative_degree: tuple[int, ...]
    input_gains: tuple[str, ...]
    observability_rank: int | None
    checks: tuple[Check, ...]
    Q: tuple[tuple[str, ...], ...]
    pinv: tuple[tuple[str, ...], ...]
    gain_field: tuple[tuple[str, ...], ...]
    gain_numeric: tuple[tuple[str, ...], ...]
    k: tuple[float, ...]
    roots: tuple[float, ...]
    theta: float | None
    placement: str | None
    usable: bool
    region: str = ""
    observer: PinvObserver = field(default=None, repr=False, compare=False)  # type: ignore[assignment]

    @property
    def hypotheses(self) -> tuple[dict[str, str], ...]:
        """Every hypothesis of Röbenack's Corollary 4.1 (A1, A3–A6; A2 through Theorem 4.1), each with its status.

        ``status`` is ``"verified on the region"`` / ``"fails on the region"`` (A1, A5: sampled rank and
        involutivity tests with their evidence) or ``"not checked"`` (the global conditions).
        """
        out = []
        for c in self.checks:
            key = "A1" if c.name.startswith("A1") else "A5" if c.name.startswith("A5") else c.name
            out.append({"name": key, "status": "verified on the region" if c.passed else "fails on the region",
                        "evidence": c.evidence})
        out += [
            {"name": "A2", "status": "not checked",
             "evidence": "Φ (2) a global diffeomorphism: given by Theorem 4.1 only when A1, A5 and A6 hold globally"},
            {"name": "A3", "status": "not checked",
             "evidence": "α, β globally Lipschitz (11) in the coordinates (2) on all of Ω, not only the region"},
            {"name": "A4", "status": "not checked",
             "evidence": "an exponential-decay OSS Lyapunov function V₂ of the zero dynamics (12)"},
            {"name": "A6", "status": "not checked", "evidence": "the vector fields τ_1, …, τ_r complete"},
        ]
        return tuple(out)

    @property
    def missing(self) -> tuple[str, ...]:
        """The hypotheses of Corollary 4.1 that are not verified (failed or not checked)."""
        return tuple(h["name"] for h in self.hypotheses if h["status"] != "verified on the region")

    @property
    def usable_scope(self) -> str:
        """``"local, on the region …"`` when A1 and A5 hold there (the global A2–A4, A6 unchecked), else ``"none"``."""
        return f"local, on the region {self.region}" if self.usable else "none"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (stable keys)."""
        return {
            "model": self.model, "states": list(self.states), "outputs": list(self.outputs),
            "observation_relative_degree": list(self.relative_degree), "input_gains": list(self.input_gains),
            "observability_rank": self.observability_rank, "checks": [c.to_dict() for c in self.checks],
            "involutive": next(c.passed for c in self.checks if c.name.startswith("A5")),
            "Q": [list(r) for r in self.Q], "pinv": [list(r) for r in self.pinv],
            "pinv_gain": [list(r) for r in self.gain_field], "pinv_gain_numeric": [list(r) for r in self.gain_numeric],
            "k": list(self.k), "roots": list(self.roots), "theta": self.theta, "placement": self.placement,
            "usable": self.usable, "usable_scope": self.usable_scope, "hypotheses": list(self.hypotheses),
            "missing_hypotheses": list(self.missing),
        }

    def summary(self) -> str:
        """A plain-text report."""
        lines = [f"Moore–Penrose observer (Röbenack 2008, (7) with (17)) for {self.model}"]
        for o, rj, lg in zip(self.outputs, self.relative_degree, self.input_gains):
            lines.append(f"  output {o}: observation relative degree r = {rj}, L_g L_f^{rj - 1} h = {lg}")
        if self.observability_rank is None:
            lines.append("  generic rank of the observability codistribution: undecided (a scaled singular value "
                         "lies within the rounding error; see nlobs analyze)")
        else:
            lines.append(f"  generic rank of the observability codistribution: {self.observability_rank} "
                         f"(n = {len(self.states)}; {len(self.states) - self.observability_rank} unobservable "
                         "direction(s))")
        for c in self.checks:
            lines.append(f"  {'ok  ' if c.passed else 'FAIL'} {c.name}: {c.evidence}")
        lines.append("  Q⁺(x) (columns τ_i, (18)):")
        lines += [f"    [{', '.join(r)}]" for r in self.pinv]
        lines.append("  gain field l(x) = Q⁺(x) k (17):")
        for s, g, gn in zip(self.states, self.gain_field, self.gain_numeric):
            lines.append(f"    {s}: {', '.join(g)}    = {', '.join(gn)}")
        design = f" (θ = {self.theta:g}, placement {self.placement})" if self.theta is not None else ""
        lines.append(f"  k = [{', '.join(f'{v:.6g}' for v in self.k)}]{design}; roots of (10): "
                     f"[{', '.join(f'{v:.6g}' for v in self.roots)}]")
        for h in self.hypotheses[len(self.checks):]:
            lines.append(f"  ?    {h['name']} {h['status']}: {h['evidence']}")
        if self.usable:
            lines.append(f"  usable: local only, on the region {self.region} (A1, A5 verified there by sampling); "
                         f"Corollary 4.1's convergence also needs {', '.join(self.missing)}, not checked")
        else:
            lines.append("  usable: no: A5 fails, Theorem 4.1 does not apply")
        return "\n".join(lines)


def design_pinv_report(
    model: SymbolicModel,
    k: ArrayLike | None = None,
    theta: float = DEFAULT_THETA,
    placement: Placement = "powers",
    region: Box | None = None,
    *,
    parameters: Mapping[str, float] | None = None,
    pinv: Literal["symbolic", "numeric"] = "symbolic",
) -> PinvDesignReport:
    """Design the Moore–Penrose observer of ``model`` and report it (for ``nlobs design pinv``).

    ``k`` (stacked, ``Σ r_j`` entries) overrides the high-gain design ``(theta, placement)``.
    A5 failing is reported (``usable`` false), not raised; A1 failing raises
    :class:`~nlobs.errors.AssumptionViolated` (no ``Q⁺`` exists). The observer is built once and
    kept in the report (:attr:`PinvDesignReport.observer`).

    Parameters
    ----------
    model : SymbolicModel
        Continuous-time, input-affine model.
    k : array_like, optional
        Stacked gain vector (``Σ r_j`` entries); default: the high-gain design.
    theta : float
        ``θ > 0`` of :class:`~nlobs.synthesis.pinv_gain.HighGain`.
    placement : {"powers", "multiple"}
        Root placement of the high-gain design.
    region : Box, optional
        Where A1 and A5 are checked (default ``[−1, 1]ⁿ``).
    parameters : mapping of str to float, optional
        Override values of the model's named parameters.
    pinv : {"symbolic", "numeric"}
        ``Q⁺`` from its simplified closed form, or ``np.linalg.pinv`` of ``Q`` at each evaluation.

    Returns
    -------
    PinvDesignReport

    Raises
    ------
    AssumptionViolated
        A1 fails on the region.
    """
    obs = _build_observer(model, k, theta, placement, region, parameters, pinv)
    F = obs.fields
    lg = []
    for j, rj in enumerate(obs.r):
        phi = F.lie_chain(j, rj)[-1]
        row = ", ".join(str(sp.factor(lie_derivative(phi, F.g[:, c], F.x))) for c in range(F.m))
        lg.append(row if F.m == 1 else f"[{row}]")
    roots = np.concatenate([np.sort(np.linalg.eigvals(M).real) for M in obs.error_matrices])
    return PinvDesignReport(
        model=F.name, states=F.states, outputs=F.outputs, relative_degree=obs.r, input_gains=tuple(lg),
        observability_rank=observability_rank(F, obs.region), checks=obs.checks, Q=_strings(obs.Q),
        pinv=_strings(obs.Qp), gain_field=_strings(obs.gain_symbolic), gain_numeric=_strings(obs.gain),
        k=tuple(float(v) for v in obs.k_vector), roots=tuple(float(v) for v in roots),
        theta=None if obs.high_gain is None else obs.high_gain.theta,
        placement=None if obs.high_gain is None else obs.high_gain.placement,
        usable=all(c.passed for c in obs.checks), region=obs.region.describe(), observer=obs,
    )


# ----------------------------------------------------------------------------- simulation
def simulate_pinv(
    model: SymbolicModel,
    x0: ArrayLike,
    x_hat0: ArrayLike,
    duration: float,
    *,
    dt: float = 1e-3,
    u: InputLike = None,
    k: ArrayLike | None = None,
    theta: float = DEFAULT_THETA,
    placement: Placement = "powers",
    region: Box | None = None,
    pinv: Literal["symbolic", "numeric"] = "symbolic",
    parameters: Mapping[str, float] | None = None,
    measurements: MeasurementGroup | Sequence[MeasurementGroup] | None = None,
    seed: int | None = None,
    report: PinvDesignReport | None = None,
    saturation: bool = False,
) -> SimulationResult:
    """Simulate ``model`` with its Moore–Penrose observer (7)/(17).

    With ``report`` the simulation uses :attr:`PinvDesignReport.observer` (the observer the
    report describes; ``k``, ``theta``, ``placement``, ``region`` and ``pinv`` are then not used).
    Without it the observer is built as :func:`design_pinv_report` builds it (``k`` overrides
    ``(theta, placement)``; A5 failing only warns). The plant is ``model.compile(parameters)``;
    ``u``, ``measurements``, ``seed`` are passed to :func:`nlobs.simulate.simulate`
    (``u=None``: zero input). ``saturation``: the observer saturated on its region outside it
    (:meth:`~nlobs.observers.pinv.PinvObserver.with_saturation`, Khalil's form of
    :mod:`nlobs.observers.pinv`; the same as (7) while the estimate is in the region); ``False``
    (default here): (7) as printed.

    Parameters
    ----------
    model : SymbolicModel
        The plant, and the model the observer is built for.
    x0 : array_like, shape (n,) or (*batch, n)
        Initial plant state(s).
    x_hat0 : array_like, shape (n,) or (*batch, n)
        Initial estimate(s).
    duration : float
        Simulated time span (seconds).
    dt : float
        Integration step.
    u : None, array_like, callable or SampledSignal
        Known input (``None``: zero input).
    k, theta, placement, region, pinv : optional
        As in :func:`design_pinv_report` (not used with ``report``).
    parameters : mapping of str to float, optional
        Override values of the model's named parameters (plant, and observer without ``report``).
    measurements : MeasurementGroup or sequence of them, optional
        Sampled sensors (``None``: exact outputs).
    seed : int, optional
        State of the random generator of the measurement noise.
    report : PinvDesignReport, optional
        A design whose observer is used.
    saturation : bool
        Saturate the observer on its region outside it.

    Returns
    -------
    SimulationResult
    """
    obs = report.observer if report is not None else _build_observer(model, k, theta, placement, region, parameters,
                                                                      pinv)
    if saturation:
        obs = obs.with_saturation(obs.region)
    return simulate(model.compile(parameters), obs, x0, x_hat0, duration=duration, dt=dt, u=u,
                    measurements=measurements, seed=seed)


# ----------------------------------------------------------------------------- the command
@dataclass(frozen=True, eq=False)
class PinvWorkflowReport:
    """What ``nlobs design pinv`` reports: the design, its simulation if asked for, the files written.

    Attributes
    ----------
    design : PinvDesignReport
        With the observer it built (:attr:`PinvDesignReport.observer`).
    simulation : SimulationResult or None
        That observer simulated against the model (``None`` without a request).
    request : SimulationRequest or None
    files : tuple of Path
        The plot (``pinv.png``) and trajectories (``pinv.npz``) written to ``request.out``.
    coverage : Coverage or None
        The hypotheses of Corollary 4.1 checked along the run (:func:`nlobs.simulate.coverage.monitor`):
        the state and the estimate in the region where A1 and A5 were verified, and the premise that the
        global A2–A4, A6 hold — not checked, so no run is covered (``certificate_covers_run`` false) and
        ``certificate_violations`` says where a run left the region.
    verdict : Verdict
        ``OK`` whenever the observer was built (A1 failing raises instead): A5 failing
        (``design.usable`` false) loses the guarantee of Theorem 4.1 but not the observer, and is
        reported in the design, not as a failure.
    message : str
        Empty.
    """

    design: PinvDesignReport
    simulation: SimulationResult | None
    request: SimulationRequest | None
    files: tuple[Path, ...]
    verdict: Verdict = Verdict.OK
    message: str = ""
    coverage: Coverage | None = None

    def _simulation_dict(self) -> dict[str, Any]:
        assert self.simulation is not None
        out = error_summary(self.simulation, self.files)
        if self.coverage is not None:
            out.update(self.coverage.to_dict())
        return out

    def to_dict(self) -> dict[str, Any]:
        """``{"design": …, "simulation": …}``: what ``nlobs design pinv --json`` prints.

        ``simulation`` (present only when one ran) has ``final_error_norm``,
        ``initial_error_norm``, ``max_error_norm`` (largest over a batch), ``files`` and the monitor's
        ``certificate_covers_run``, ``certificate_covered_fraction``, ``certificate_violations`` (first per run:
        hypothesis, time, detail), ``certificate_failed_premises``, ``certificate_hypotheses``.
        """
        data: dict[str, Any] = {"design": self.design.to_dict()}
        if self.simulation is not None:
            data["simulation"] = self._simulation_dict()
        return data

    def summary(self) -> str:
        """The design report, then the simulation line and a ``wrote <file>`` line per file."""
        lines = [self.design.summary()]
        if self.simulation is not None and self.request is not None:
            line = error_line(error_summary(self.simulation, self.files), self.request.duration, self.request.dt)
            if self.coverage is not None:
                line += " (no theorem covers this run: " + "; ".join(self.coverage.reasons) + ")"
            lines.append(line)
            lines += [f"wrote {f}" for f in self.files]
        return "\n".join(lines)


def design_pinv_observer(
    model: str | Path | SymbolicModel,
    *,
    k: Sequence[float] | None = None,
    theta: float = DEFAULT_THETA,
    placement: Placement = "powers",
    box: Sequence[float] | Box | None = None,
    simulate: SimulationRequest | None = None,
    saturation: bool | None = None,
) -> PinvWorkflowReport:
    """Design the Moore–Penrose observer (7), (17), check A1 and A5, and simulate it if asked: ``nlobs design pinv``.

    Parameters
    ----------
    model : str, Path or SymbolicModel
        A model file, a shipped model name (:func:`nlobs.systems.modelfile.load_model`) or a
        loaded continuous-time input-affine model.
    k : sequence of float, optional
        The stacked gain vector (``Σ r_j`` numbers), instead of the high-gain design.
    theta, placement
        The high-gain design of the roots of (10) (:class:`~nlobs.synthesis.pinv_gain.HighGain`).
    box : sequence of float, or Box, optional
        Where A1 and A5 are checked: ``lo, hi`` for every state or ``lo1, hi1, …``; default
        ``[−1, 1]ⁿ``.
    simulate : SimulationRequest, optional
        Simulate the observer the design built (the same object, :attr:`PinvDesignReport.observer`)
        and write the plot and trajectories to ``simulate.out``.
    saturation : bool, optional
        Simulate the observer saturated on the region (``--saturation on``; the same as (7) while the
        estimate is in the region) or (7) as printed (``--saturation off``). Default: on when ``box`` is
        given, off on the default ``[−1, 1]ⁿ`` — the saturated form is right only while the *state* is in
        the region (Khalil's argument, :mod:`nlobs.observers.pinv`), which a region nobody chose need not
        hold: the README's ``isidori-146`` run leaves ``[−1, 1]⁴`` (``x4``) and ends with ‖e‖ = 13.8
        saturated against 0.31 as printed.

    Returns
    -------
    PinvWorkflowReport

    Raises
    ------
    ModelFileError, ModelError
        The model cannot be loaded, is linear, or is not input-affine.
    InvalidArgumentError, NonFiniteError, DimensionError
        A bad option (``placement``, ``k``, the sizes of the simulation's vectors).
    BoxError
        ``box`` does not make a box of the state space.
    AssumptionViolated
        A1 fails (no ``Q⁺`` exists on the region).
    OutputError
        ``simulate.out`` or a file in it cannot be written.
    SimulationDiverged
        The simulation diverged.
    StudyFailed
        The simulation stopped with another nlobs error; the cause is chained.
    """
    m = symbolic_model(model)
    if placement not in PLACEMENTS:
        raise InvalidArgumentError(f"placement: expected 'powers' or 'multiple', got {placement!r}")
    region = None if box is None else as_region(box, m.n)
    # the simulation's vectors, size and output folder are checked before the design (which can take long)
    resolved = checked_request(simulate, m)
    rep = design_pinv_report(m, None if k is None else [float(v) for v in k], theta, placement, region)
    if simulate is None:
        return PinvWorkflowReport(rep, None, None, ())
    assert resolved is not None
    x0, x_hat0, u = resolved
    res = run_study(lambda: simulate_pinv(m, x0, x_hat0, simulate.duration, dt=simulate.dt, u=u, report=rep,
                                          saturation=box is not None if saturation is None else saturation))
    files = write_result(res, simulate.out, "pinv", model_units(model))
    box = rep.observer.region
    assert box is not None
    where = box.describe()
    missing = [h["name"] for h in rep.hypotheses if h["status"] == "not checked"]
    hyps: list[Any] = [InRegion(box.lower, box.upper, "state", where), InRegion(box.lower, box.upper, "estimate", where),
                       Premise(f"{', '.join(missing)} of Corollary 4.1", False, "not checked (global conditions)")]
    coverage = monitor(res, hyps, u=np.asarray(u, dtype=float), verified=rep.usable)
    return PinvWorkflowReport(rep, res, simulate, files, coverage=coverage)
