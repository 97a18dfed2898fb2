r"""Designs under the problem's sensors: the Jacobian box, the sensor groups of the bound, the gain chosen for them.

The pieces every method needs to state what its certificate still guarantees when the output is sampled
and noisy (:mod:`nlobs.synthesis.sampled_data`):

* :func:`error_box` — the entrywise bounds of ``(∂F/∂x, ∂h/∂x)`` on the region × the input range
  (:mod:`nlobs.geometry.jacobian_box`), whose vertices carry the Lyapunov inequality (1);
* :func:`output_rate_box` — those of the Jacobian of ``L_F h`` (``∂h/∂x · F``), the rate the inter-sample
  predictor integrates: its Lipschitz constants ``ℓ_j``;
* :func:`sensor_groups` — each measurement group as :class:`~nlobs.synthesis.sampled_data.GroupNoise`
  (period, noise covariance, bias, ``ℓ_j``, the process noise its outputs see between samples);
* :func:`sampling_hypotheses` — what a run must satisfy for the bound to cover it: the state and the
  estimate in the region, the input in its range, every group's longest gap between samples (its period, or
  an outage and one period) within the sampling budget;
* :func:`tune_thau` — the Thau/Luenberger gain chosen for the sensors: the decay rate ``α`` of the vertex
  LMIs (:mod:`nlobs.synthesis.thau_gain`) that makes the certified RMS bound after the settling time smallest
  (the trade-off of speed against noise amplification made explicit; Ahrens & Khalil, Automatica 45(4), 2009,
  for high-gain observers).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from nlobs._typing import Array
from nlobs._validate import one_of
from nlobs.errors import DesignInfeasible, InvalidArgumentError, NonFiniteError
from nlobs.geometry.jacobian_box import JacobianBox, jacobian_box
from nlobs.methods.problem import Problem
from nlobs.simulate.coverage import InputRange, InRegion, Premise
from nlobs.synthesis.lmi import psd_sqrt
from nlobs.synthesis.sampled_data import GroupNoise, SampledDataBound, SampledDesignCertificate, sampled_data_bound

__all__ = ["SensorTuning", "alpha_grid", "drift_process_noise", "rate_jacobian", "clock_sensor_groups", "drift_sampling_bound", "input_range", "on_samples", "sampling_form", "clock_triples", "error_box", "longest_gap", "output_indices", "output_rate_box", "sampling_hypotheses",
           "sensor_groups", "tune_thau"]

#: Vertex count above which a Lipschitz constant is bounded through the box's radius instead of its vertices.
MAX_NORM_VERTICES = 4096
#: Fractions of a gain's certified decay rate asked of its clock-dependent certificate, in turn.
CLOCK_DECAY_FRACTIONS = (0.5, 0.1)
#: Decay rates tried by :func:`tune_thau` (a geometric grid spanning the plant's rates).
ALPHA_GRID = 9
#: Geometric bisections of :func:`tune_thau` between the fastest feasible decay of the grid and the next.
FRONTIER_STEPS = 3
#: Relative step of the central differences of a nonlinear ``∂h/∂x`` (Hessians).
FD_STEP = 1e-6


#: The clock-dependent and impulsive certificates are tried with at most this many vertices of ``∂h/∂x``.
MAX_H_VERTICES = 64
#: The drift observer's sampling budget is not computed when ``cn(P)`` of (2.17) exceeds this (double precision).
MAX_DRIFT_CONDITION = 1e10

#: Relative widening of the input's sampled range (its instants may miss its extremes).
INPUT_MARGIN = 0.01


def input_range(problem: Problem) -> tuple[Array, Array]:
    """The problem's input range (:attr:`~nlobs.methods.problem.Problem.input_range`, sampled at instants that may
    miss an extreme) widened by :data:`INPUT_MARGIN` of its width on each side: where the Jacobian boxes are
    estimated and what the monitor checks.

    Parameters
    ----------
    problem : Problem
        Its known input and horizon.
    """
    lo, hi = problem.input_range
    width = np.maximum(hi - lo, 1e-9 * np.maximum(1.0, np.maximum(np.abs(lo), np.abs(hi))))
    return lo - INPUT_MARGIN * width, hi + INPUT_MARGIN * width


def _plant(problem: Problem) -> Any:
    model = problem.model
    return model if hasattr(model, "rhs_jacobian_x") else model.compile()


def error_box(problem: Problem, plant: Any | None = None) -> JacobianBox:
    """Entrywise bounds of ``[∂F/∂x; ∂h/∂x]`` (``(n + p) × n``) on the problem's region × input range.

    Parameters
    ----------
    problem : Problem
        The region and the input range.
    plant : PlantModel, optional
        The compiled model (default: compiled from the problem).

    Raises
    ------
    NonFiniteError
        A Jacobian is not finite on the region.
    """
    plant = _plant(problem) if plant is None else plant
    n, p = problem.model.n, problem.model.p

    def jac(x: Array, u: Array) -> Array:
        JF = np.broadcast_to(plant.rhs_jacobian_x(0.0, x, u), (x.shape[0], n, n))
        JH = np.broadcast_to(plant.output_jacobian_x(0.0, x, u), (x.shape[0], p, n))
        return np.concatenate([JF, JH], axis=1)

    lo, hi = input_range(problem)
    return jacobian_box(jac, problem.region, lo, hi)


def rate_jacobian(plant: Any, n: int, p: int, linear_h: bool) -> Any:
    """``x, u ↦ ∂(∂h/∂x · F)/∂x``: ``C ∂F/∂x`` for a linear output, central differences otherwise.

    Parameters
    ----------
    plant : PlantModel
        The compiled model (``rhs``, ``rhs_jacobian_x``, ``output_jacobian_x``).
    n, p : int
        States and outputs.
    linear_h : bool
        Whether ``∂h/∂x`` is constant (no Hessian term).

    Returns
    -------
    callable
        ``jac(x, u)`` for batches, shape ``(N, p, n)``.
    """

    def jac(x: Array, u: Array) -> Array:
        JF = np.broadcast_to(plant.rhs_jacobian_x(0.0, x, u), (x.shape[0], n, n))
        JH = np.broadcast_to(plant.output_jacobian_x(0.0, x, u), (x.shape[0], p, n))
        out = np.einsum("...ij,...jk->...ik", JH, JF)
        if linear_h:
            return out
        F = plant.rhs(0.0, x, u)
        for k in range(n):  # (∂/∂x_k of ∂h/∂x) · F: the Hessian term
            step = FD_STEP * np.maximum(1.0, np.abs(x[:, k]))
            xp, xm = x.copy(), x.copy()
            xp[:, k] += step
            xm[:, k] -= step
            dH = (np.broadcast_to(plant.output_jacobian_x(0.0, xp, u), JH.shape)
                  - np.broadcast_to(plant.output_jacobian_x(0.0, xm, u), JH.shape)) / (2 * step[:, None, None])
            out[:, :, k] += np.einsum("...ij,...j->...i", dH, F)
        return out

    return jac


def output_rate_box(problem: Problem, box: JacobianBox, plant: Any | None = None) -> JacobianBox:
    """Entrywise bounds of the Jacobian of ``L_F h = ∂h/∂x · F`` (``p × n``) on the region × input range.

    Parameters
    ----------
    problem : Problem
        The region and the input range.
    box : JacobianBox
        The problem's :func:`error_box` (its ``∂h/∂x`` rows say whether the output is linear).
    plant : PlantModel, optional
        The compiled model.
    """
    plant = _plant(problem) if plant is None else plant
    n, p = problem.model.n, problem.model.p
    linear_h = not np.any(box.upper[n:] > box.lower[n:])
    lo, hi = input_range(problem)
    return jacobian_box(rate_jacobian(plant, n, p, linear_h), problem.region, lo, hi)


def output_indices(problem: Problem, outputs: Sequence[int | str]) -> tuple[int, ...]:
    """The indices of a group's outputs (names or indices) in the model's outputs.

    Parameters
    ----------
    problem : Problem
        The model.
    outputs : sequence of int or str
        A measurement group's outputs.
    """
    names = list(problem.model.outputs)
    out = []
    for o in outputs:
        if isinstance(o, str):
            if o not in names:
                raise InvalidArgumentError(f"sensor output {o!r}: not an output of the model ({names})")
            out.append(names.index(o))
        else:
            out.append(int(o))
    return tuple(out)


def _largest_norm(box: JacobianBox, right: Array, left: Array | None = None, norm: Any = 2) -> float:
    """``max ‖left · G · right‖`` (spectral, or ``norm="fro"``) over the box: at its vertices (a norm is convex),
    or the centre's plus a bound of the radius when the vertices are too many."""
    L = np.eye(box.lower.shape[0]) if left is None else left
    if box.n_vertices <= MAX_NORM_VERTICES:
        return max(float(np.linalg.norm(L @ G @ right, norm)) for G in box.vertices())
    rad = (box.upper - box.lower) / 2
    return float(np.linalg.norm(L @ box.center @ right, norm)
                 + np.linalg.norm(L, 2) * np.linalg.norm(rad, "fro") * np.linalg.norm(right, 2))



def _ito_drift(problem: Problem, plant: Any, rows: Sequence[int], W2: Array) -> float:
    """``sup ‖½ tr(∇²h_j W Wᵀ)‖`` on sampled points of the region (0 for a linear output or no process noise)."""
    from nlobs.geometry.jacobian_box import sample_points

    if not np.any(W2):
        return 0.0
    n, p = problem.model.n, problem.model.p
    lo, hi = input_range(problem)
    x, u = sample_points(problem.region, lo, hi, 512, seed=1)
    acc = np.zeros((x.shape[0], len(rows)))
    for k in range(n):
        step = FD_STEP * np.maximum(1.0, np.abs(x[:, k]))
        xp, xm = x.copy(), x.copy()
        xp[:, k] += step
        xm[:, k] -= step
        dH = (np.broadcast_to(plant.output_jacobian_x(0.0, xp, u), (x.shape[0], p, n))
              - np.broadcast_to(plant.output_jacobian_x(0.0, xm, u), (x.shape[0], p, n))) / (2 * step[:, None, None])
        acc += 0.5 * np.einsum("sij,j->si", dH[:, list(rows), :], W2[:, k])  # Σ_l ∂²h/∂x_l∂x_k W2_lk
    return float(np.max(np.linalg.norm(acc, axis=-1)))


def sensor_groups(problem: Problem, P: Array, K: Array, box: JacobianBox, rate_box: JacobianBox,
                  plant: Any | None = None) -> tuple[GroupNoise, ...]:
    """The problem's measurement groups as the bound sees them, for a design's ``P`` and ``K``.

    Parameters
    ----------
    problem : Problem
        Its sensors and process noise.
    P : ndarray, shape (n, n)
        The Lyapunov matrix of the design's (1).
    K : ndarray, shape (n, p)
        The output-injection gain.
    box : JacobianBox
        :func:`error_box` (its ``∂h/∂x`` rows).
    rate_box : JacobianBox
        :func:`output_rate_box`.
    plant : PlantModel, optional
        The compiled model (for a nonlinear output's Itô term).
    """
    n = problem.model.n
    w, V = np.linalg.eigh((P + P.T) / 2)
    Si = (V / np.sqrt(w)) @ V.T
    S = (V * np.sqrt(w)) @ V.T
    W2 = np.zeros((n, n)) if problem.process_noise is None else np.asarray(problem.process_noise, dtype=float)
    Wh = psd_sqrt(W2)
    linear_h = not np.any(box.upper[n:] > box.lower[n:])
    out = []
    for g in problem.sensors:
        idx = output_indices(problem, g.outputs)
        ell = _largest_norm(rate_box.rows(idx), Si)
        H = box.rows([n + i for i in idx])
        Kj = K[:, list(idx)]
        q = _largest_norm(H, Wh, S @ Kj, "fro") ** 2 if np.any(W2) else 0.0
        bias = np.broadcast_to(np.asarray(g.bias, dtype=float), (len(idx),)).copy()
        if not linear_h and np.any(W2):
            drift = _ito_drift(problem, _plant(problem) if plant is None else plant, idx, W2) / g.rate
            bias = np.abs(bias) + drift / math.sqrt(len(idx))
        out.append(GroupNoise(g.name, idx, longest_gap(g), np.asarray(g.covariance, dtype=float), ell, q, bias))
    return tuple(out)


def longest_gap(group: Any) -> float:
    """The longest time between two samples of a measurement group: its period, or an outage and one period.

    The bound of :mod:`nlobs.synthesis.sampled_data` needs only ``t − t_k ≤ T_j`` (not periodic samples), so a
    group's ``T_j`` is its longest gap: a certificate for it covers the outages too.

    Parameters
    ----------
    group : MeasurementGroup
        Its ``rate`` and ``outages``.
    """
    period = 1.0 / float(group.rate)
    return max([period, *((b - a) + period for a, b in group.outages)])


def sampling_hypotheses(problem: Problem, bound: SampledDataBound | None, *, what: str = "the bound") -> tuple[Any, ...]:
    """What a run must satisfy for ``bound`` to cover it (module docstring).

    Parameters
    ----------
    problem : Problem
        The region, the input range, the sensors.
    bound : SampledDataBound or None
        The design's bound (``None``: the method states none under sampling, a failed premise when sampled).
    what : str
        How the premise names what rests on the sampling (``"Theorem 3.1"``).
    """
    region = problem.region
    lo, hi = input_range(problem)
    out: list[Any] = [InRegion(region.lower, region.upper, "state", region.describe()),
                      InRegion(region.lower, region.upper, "estimate", region.describe())]
    if problem.model.m:
        out.append(InputRange(lo, hi, tuple(problem.model.inputs)))
    if not problem.sensors:
        return tuple(out)
    if bound is None:
        out.append(Premise("sampled with period ≤ T_max", False,
                           f"the output is sampled and held; {what} states no sampling period it survives"))
        return tuple(out)
    parts = []
    for sensor, g, tm in zip(problem.sensors, bound.groups, bound.t_max):
        what = "T" if g.gap <= 1.0 / sensor.rate * (1 + 1e-12) else "longest gap (an outage)"
        parts.append(f"{g.name}: {what} = {g.gap:.4g} {'≤' if g.gap <= tm * (1 + 1e-12) else '>'} T_max = {tm:.4g}")
    holds = bool(bound.verified)
    how = f"; budget Σ T/T_max = {bound.budget:.3g}" if isinstance(bound, SampledDataBound) else \
        " (clock-dependent certificate for these gaps)"
    out.append(Premise(f"sampled with period ≤ T_max ({'; '.join(parts)}{how})", holds,
                       "" if holds else (bound.violation() or "")))
    return tuple(out)


def clock_sensor_groups(problem: Problem) -> tuple[Any, ...]:
    """The problem's measurement groups as :class:`~nlobs.synthesis.sampled_clock.ClockGroup` (gap, period, noise).

    Parameters
    ----------
    problem : Problem
        Its sensors.
    """
    from nlobs.synthesis.sampled_clock import ClockGroup

    return tuple(ClockGroup(g.name, output_indices(problem, g.outputs), longest_gap(g), 1.0 / g.rate,
                            np.asarray(g.covariance, dtype=float),
                            np.broadcast_to(np.asarray(g.bias, dtype=float), (len(g.outputs),)))
                 for g in problem.sensors)


def clock_triples(pairs: Sequence[tuple[Array, Array]], rate: JacobianBox, linear_h: bool,
                  limit: int = 256) -> list[tuple[Array, Array, Array]] | None:
    """The vertices ``(A, C, G)`` of the hybrid error system (:mod:`nlobs.synthesis.sampled_clock`): closed loop
    ``A − K C``, predictor error rate ``G``.

    A linear output: ``G = C A`` at the same vertex of the Jacobian box (one mean-value matrix drives both);
    otherwise every pair of a vertex of the box and one of the rate box (``None`` beyond ``limit`` pairs).

    Parameters
    ----------
    pairs : sequence of (A_v, C_v)
        The vertices of the Jacobian box.
    rate : JacobianBox
        The box of the Jacobian of ``L_F h``.
    linear_h : bool
        Whether ``∂h/∂x`` is constant.
    limit : int
        The most vertices.
    """
    if linear_h:
        return [(A, C, C @ A) for A, C in pairs]
    if len(pairs) * rate.n_vertices > limit:
        return None
    return [(A, C, G) for A, C in pairs for G in rate.vertices()]


def sampling_form(value: str | None, default: str = "predictor") -> str:
    """``"predictor"`` or ``"hold"``: how a method without a sampling certificate meets sampled outputs.

    Parameters
    ----------
    value : str or None
        The ``sampling`` option given.
    default : str
        The method's default (the drift observer holds: its high gains destabilise the predictor's loop).
    """
    return one_of("`sampling`", value, ("predictor", "hold"), default)


def on_samples(observer: Any, problem: Problem, sampling: str, theorem: str,
               bound: SampledDataBound | None = None, reason: str = "") -> tuple[Any, tuple[Any, ...]]:
    """A continuous observer for the problem's sensors, and the premise its certificate lacks under them.

    With sensors, the observer runs through the output predictor (``sampling="predictor"``) or on held samples
    (``"hold"``); its theorem assumes a continuous output and nlobs computes no sampling period it survives yet,
    so the premise "sampled with period ≤ T_max" fails with that reason. Without sensors: the observer itself,
    no premise.

    Parameters
    ----------
    observer : Observer
        The continuous observer of the design.
    problem : Problem
        Its sensors and model.
    sampling : {"predictor", "hold"}
        From :func:`sampling_form`.
    theorem : str
        What the certificate rests on (``"Theorem 3.1"``).
    bound : SampledDataBound, optional
        The method's sampling budget through the predictor (:func:`drift_sampling_bound`): the premise is then
        "sampled with period ≤ T_max" against it (failing for a held sample).
    reason : str, optional
        Without a bound: why none was computed for this design (else "not computed for this method").
    """
    from nlobs.observers.sampled import with_predictor

    if not problem.sensors:
        return observer, ()
    plant = _plant(problem)
    wrapped = with_predictor(observer, plant, sampling == "predictor")
    if bound is not None:
        if sampling == "predictor":
            return wrapped, tuple(h for h in sampling_hypotheses(problem, bound) if isinstance(h, Premise))
        there = bound.violation() or "it holds: sampling=predictor"
        return wrapped, (Premise("sampled with period ≤ T_max", False,
                                 f"the output is sampled and held; {theorem}'s sampling period is computed for the "
                                 f"output predictor ({there})"),)
    how = "through the output predictor" if sampling == "predictor" else "held"
    return wrapped, (Premise("sampled with period ≤ T_max", False,
                             f"the output is sampled ({how}); {theorem} assumes a continuous output and its "
                             + (f"certificate under the sensors fails: {reason}" if reason else
                                "sampling period is not computed for this method")),)


@dataclass(frozen=True)
class SensorTuning:
    """The Thau/Luenberger gain chosen for the sensors (:func:`tune_thau`).

    Attributes
    ----------
    certificate : SampledDesignCertificate or ImpulsiveCertificate
        The chosen gain's certificate and its bound (the predictor), or the impulsive observer's.
    alpha : float
        The decay rate it was designed for.
    candidates : tuple of (float, str)
        Every ``α`` tried with its outcome (the RMS bound, or why not).
    box : JacobianBox
        The Jacobian box of the vertex LMIs.
    rms_bound : float
        The certified RMS bound after the settling time, for the problem's initial error.
    """

    certificate: SampledDesignCertificate
    alpha: float
    candidates: tuple[tuple[float, str], ...]
    box: JacobianBox
    rms_bound: float

    @property
    def sampling(self) -> str:
        """``"impulsive"`` when the impulsive observer won, else ``"predictor"``."""
        return "impulsive" if type(self.certificate).__name__ == "ImpulsiveCertificate" else "predictor"


def alpha_grid(box: JacobianBox, n: int, problem: Problem) -> tuple[float, ...]:
    """The decay rates tried for a certificate on ``box``: a geometric grid of :data:`ALPHA_GRID` rates from a
    thirtieth of the plant's rate scale up to ten times it, below half the fastest sensor's rate.

    Parameters
    ----------
    box : JacobianBox
        The error box (its centre's first ``n`` rows: ``∂F/∂x``).
    n : int
        The number of states.
    problem : Problem
        Its sensors.

    Returns
    -------
    tuple of float
        Increasing decay rates.
    """
    A = box.center[:n]
    rho = float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0
    rho = max(rho, float(np.linalg.norm(A, 2)) / 10, 1e-3)
    periods = [1.0 / g.rate for g in problem.sensors]
    top = 10 * rho if not periods else min(10 * rho, 0.5 / max(periods))
    bottom = min(rho / 30, top / 30)
    return tuple(float(a) for a in np.geomspace(bottom, top, ALPHA_GRID))


def tune_thau(problem: Problem, *, alpha: float | None = None, sampling: str | None = None) -> SensorTuning:
    """The Thau gain of the vertex LMIs whose certified RMS bound under the sensors is smallest.

    Parameters
    ----------
    problem : Problem
        The model, region, input range, sensors, process noise, initial error and settling time.
    alpha : float, optional
        Design at this decay rate only (default: the best of a grid spanning the plant's rates).
    sampling : {"predictor", "impulsive"}, optional
        Only the continuous gain run through the output predictor (its small-gain or clock-dependent bound), or
        only the impulsive observer (one sensor group); default: both, the smaller bound wins.

    Returns
    -------
    SensorTuning

    Raises
    ------
    DesignInfeasible
        No ``α`` gives a verified bound; the message says what fails and by how much (the vertex LMIs,
        the sampling budget with its ``T`` and ``T_max``, a Jacobian that is not finite on the region).
    """
    from nlobs.methods.kalman import measurement_covariance
    from nlobs.synthesis.sampled_clock import ClockSDP
    from nlobs.synthesis.thau_gain import VertexLMIs

    plant = _plant(problem)
    n = problem.model.n
    try:
        box = error_box(problem, plant)
    except NonFiniteError as exc:  # no certificate on this region: a design failure with its reason, not bad input
        raise DesignInfeasible(str(exc)) from exc
    if box.n_vertices > 1024:
        raise DesignInfeasible(f"the Jacobian of the model varies in {len(box.varying)} entries on the region "
                               f"{problem.region.describe()}: 2^{len(box.varying)} vertices exceed the vertex LMIs' "
                               "limit of 1024; give a smaller region (box)")
    rate = output_rate_box(problem, box, plant)
    pairs = [(V[:n], V[n:]) for V in box.vertices()]
    rate_vertices = list(rate.vertices()) if rate.n_vertices <= 256 else []
    R = measurement_covariance(problem.model, problem.sensors) if problem.sensors else None
    W2 = problem.process_noise
    p0, settle = problem.p0, problem.settle
    linear_h = not np.any(box.upper[n:] > box.lower[n:])
    clock_groups = clock_sensor_groups(problem) if problem.sensors and len(problem.sensors) <= 3 else ()
    h_box = box.rows(range(n, n + problem.model.p))
    # the clock-dependent and impulsive certificates take every vertex of ∂h/∂x, or are not tried
    h_vertices = list(h_box.vertices()) if h_box.n_vertices <= MAX_H_VERTICES else None
    tried: list[tuple[float, str]] = []
    best: tuple[float, float, Any] | None = None
    closest: tuple[float, str] | None = None
    grid = (float(alpha),) if alpha is not None else alpha_grid(box, n, problem)
    lmis = {o: VertexLMIs(pairs, R=R, process=W2, objective=o, rate_vertices=rate_vertices)
            for o in ("noise", "sampling")}
    # a nonlinear output sees the process noise's Itô drift ½ tr(∇²h W Wᵀ) between samples, which (B) leaves out:
    # the clock-dependent certificate is for a linear output or an exact model (the small-gain bound counts it)
    exact_model = W2 is None or not np.any(W2)
    triples = clock_triples(pairs, rate, linear_h) if clock_groups and (linear_h or exact_model) else None
    sdp = ClockSDP(triples, clock_groups, process=W2, H=h_vertices, p0=p0, settle=settle) \
        if triples and h_vertices is not None else None
    def consider(a: float, label: str, bound: Any, certificate: Any) -> None:
        """A verified candidate: its certified RMS bound after the settling time, kept if the smallest so far."""
        nonlocal best
        value = bound.rms_after(settle)
        tried.append((a, f"{label}: RMS bound {value:.4g}"))
        if best is None or value < best[0]:
            best = (value, a, certificate)

    def predictor(a: float) -> bool | None:
        """The continuous gains at ``α = a`` through the predictor; whether the vertex LMIs were feasible (``None``:
        the solver failed without claiming infeasibility)."""
        nonlocal closest
        feasible: bool | None = False
        for objective in ("noise", "sampling"):
            try:
                cert = lmis[objective].solve(a)
            except DesignInfeasible as exc:
                tried.append((a, f"{objective}: infeasible ({exc})"))
                if not exc.constraint and feasible is False:
                    feasible = None
                continue
            feasible = True
            if not cert.verified:
                tried.append((a, f"{objective}: the vertex LMIs failed their re-verification: "
                                 + "; ".join(c.evidence for c in cert.failed_checks)))
                continue
            groups = sensor_groups(problem, cert.P, cert.gain, box, rate, plant)
            bound = sampled_data_bound(cert.P, cert.gain, cert.decay, groups, process=W2, p0=p0)
            if bound.verified:
                consider(a, objective, bound, SampledDesignCertificate(cert, bound))
            else:
                why = bound.violation() or "the bound failed"
                tried.append((a, f"{objective}: {why}"))
                if closest is None or bound.budget < closest[0]:
                    closest = (bound.budget, why)
            if objective == "noise" and sdp is not None:
                clock = None
                for fraction in CLOCK_DECAY_FRACTIONS:  # the sampling costs decay: ask half of it, else a tenth
                    try:
                        clock = sdp.solve(cert.gain, fraction * cert.decay)
                        break
                    except DesignInfeasible as exc:
                        tried.append((a, f"clock: {exc}"))
                if clock is None:
                    continue
                if clock.verified:
                    consider(a, "clock", clock, SampledDesignCertificate(cert, clock))
                else:
                    tried.append((a, f"clock: {clock.violation()}"))
        return feasible

    imp = None
    if sampling in (None, "impulsive") and problem.sensors and len(clock_groups) == 1 and h_vertices is not None:
        from nlobs.synthesis.impulsive_gain import ImpulsiveSDP

        imp = ImpulsiveSDP([A for A, _ in pairs], h_vertices, clock_groups[0], process=W2, p0=p0, settle=settle)

    def impulsive(a: float) -> bool | None:
        """The impulsive observer at ``α = a``; whether its LMIs were feasible (``None``: the solver failed)."""
        try:
            icert = imp.solve(a)
        except DesignInfeasible as exc:
            tried.append((a, f"impulsive: {exc}"))
            return False if exc.constraint else None
        if not icert.verified:
            tried.append((a, f"impulsive: {icert.violation()}"))
            return True
        consider(a, "impulsive", icert, icert)
        return True

    forms = ([predictor] if sampling != "impulsive" else []) + ([impulsive] if imp is not None else [])
    for form in forms:  # the LMIs feasible at α are feasible below it: up the grid to the first infeasible α
        fastest = None
        for k, a in enumerate(grid):
            outcome = form(a)
            if outcome is False:  # the solver claims infeasibility; a solver failure goes on to the next α
                break
            if outcome:
                fastest = k
        if alpha is None and fastest is not None and fastest + 1 < len(grid):  # bisect up to the frontier
            lo_a, hi_a = grid[fastest], grid[fastest + 1]
            for _ in range(FRONTIER_STEPS):
                mid = math.sqrt(lo_a * hi_a)
                lo_a, hi_a = (mid, hi_a) if form(mid) else (lo_a, mid)
    if best is None:
        if closest is not None:
            raise DesignInfeasible(f"no gain of the vertex LMIs keeps its certificate under the sensors: at best "
                                   f"{closest[1]}")
        raise DesignInfeasible(f"the vertex LMIs on the region {problem.region.describe()} "
                               f"({len(pairs)} vertices) have no solution at any decay rate tried "
                               f"(α = {tried[0][0]:.3g} … {tried[-1][0]:.3g}); give a smaller region (box)")
    return SensorTuning(best[2], best[1], tuple(tried), box, best[0])


def drift_sampling_bound(problem: Problem, report: Any) -> SampledDataBound | None:
    r"""The sampling budget (3) of the drift-observability observer (3.1) for the problem's sensors, or ``None``.

    In ``z = Φ_s(x)`` the observer (3.1) injects ``K (y − h(x̂))`` with a constant ``K``, and the proof of
    Theorem 3.1 (Dalla Mora, Germani & Manes) shows that ``V = e_zᵀ P⁻¹ e_z`` decays at ``2α`` for the pair
    ``(K, P)`` of (2.17): the inequality (1) of :mod:`nlobs.synthesis.sampled_data` with Lyapunov matrix ``P⁻¹``.
    Through the output predictor, group ``j``'s discrepancy grows at ``L_F h_j(x̂) − L_F h_j(x)``. For an output with
    ``s_j ≥ 2`` and relative degree ``r_j ≥ 2`` that is exactly ``z_{j,2}`` (``L_g h_j = 0``), so
    ``ℓ_j = ‖(C_s A_s)_j P^{1/2}‖₂`` in closed form; otherwise ``ℓ_j`` is bounded through the region:
    ``sup ‖∂L_F h_j/∂x‖ · γ_{Φ⁻¹} · ‖P^{1/2}‖`` (sampled). ``T_max,j = α/(κ_j ℓ_j)`` with ``κ_j = ‖P^{-1/2}K_j‖``.

    The process noise ``W`` of the file reaches ``z`` as ``Q_s(x) W Q_s(x)ᵀ`` (``Q_s = ∂Φ_s/∂x``) and an Itô drift
    ``d_i = ½ tr(∇²Φ_{s,i} W)`` (:func:`drift_process_noise`): the bound takes ``c I`` with ``c`` the largest
    eigenvalue of the first on the region, ``|d| ≤ β`` as its drift term, and for each group the process noise and
    the drift its outputs ``y_j = z_{j,1}`` see between samples (its ``q_j`` and a bias ``β_j T_j``), all sampled
    on the region and widened 5 %.

    Parameters
    ----------
    problem : Problem
        Its sensors and region.
    report : DriftReport
        The design (its certificate of (2.17), ``s``, ``r``, Lipschitz constants).

    Returns
    -------
    SampledDataBound or None
        ``None`` without sensors, when the certificate of (2.17) failed, when ``cn(P)`` exceeds
        :data:`MAX_DRIFT_CONDITION` (the inverse would carry no digits) or when the output's rate has no Lipschitz
        constant on the region.
    """
    from nlobs.systems.brunovsky import brunovsky

    cert = report.certificate
    if not problem.sensors or not cert.verified:
        return None
    P = (np.asarray(cert.P, dtype=float) + np.asarray(cert.P, dtype=float).T) / 2
    if not np.linalg.cond(P) < MAX_DRIFT_CONDITION:  # P⁻¹ and P^{1/2} would carry no digits (high gains)
        return None
    K = np.asarray(cert.gain, dtype=float)
    S = psd_sqrt(P)
    A_s, _, C_s = brunovsky(report.s)
    rows = C_s @ A_s
    s, r = tuple(report.s), tuple(report.r)
    plant, box, rate = None, None, None
    groups = []
    for g in problem.sensors:
        idx = output_indices(problem, g.outputs)
        exact = all(s[j] >= 2 and r[j] is not None and r[j] >= 2 for j in idx)
        if exact:
            ell = float(np.linalg.norm(rows[list(idx)] @ S, 2))
        else:
            if rate is None:
                plant = _plant(problem)
                try:
                    box = error_box(problem, plant)
                    rate = output_rate_box(problem, box, plant)
                except NonFiniteError:  # no Lipschitz constant of the output's rate on the region: no budget
                    return None
            sup = _largest_norm(rate.rows(idx), np.eye(problem.model.n))
            ell = sup * float(report.bound.gamma_phi_inv) * float(np.linalg.norm(S, 2))
        bias = np.broadcast_to(np.asarray(g.bias, dtype=float), (len(idx),)).copy()
        groups.append(GroupNoise(g.name, idx, longest_gap(g), np.asarray(g.covariance, dtype=float), ell, 0.0, bias))
    W = problem.process_noise
    if W is None or not np.any(W):
        return sampled_data_bound(np.linalg.inv(P), K, float(cert.constants.alpha), groups)
    try:
        c, beta, beta_y = drift_process_noise(problem, report)
    except NonFiniteError:
        return None
    Pb = np.linalg.inv(P)
    Sb = psd_sqrt(Pb)
    starts = np.cumsum((0, *s[:-1]))  # y_j = z_{j,1}: the first coordinate of block j
    noisy = []
    for g in groups:
        rows = [int(starts[j]) for j in g.index]
        Kj = K[:, list(g.index)]
        q = c * float(np.linalg.norm(Sb @ Kj @ np.eye(K.shape[0])[rows], "fro")) ** 2
        bias = np.abs(g.bias) + float(max(beta_y[r] for r in rows)) * g.period / math.sqrt(len(rows))
        noisy.append(GroupNoise(g.name, g.index, g.period, g.R, g.ell, q, bias))
    return sampled_data_bound(Pb, K, float(cert.constants.alpha), noisy, process=c * np.eye(K.shape[0]), drift=beta)


def drift_process_noise(problem: Problem, report: Any) -> tuple[float, float, Array]:
    """The process noise of the problem in the drift observer's coordinates ``z = Φ_s(x)``, on the region.

    Itô's formula gives ``dz = (…) dt + Q_s(x) W^{1/2} dβ + d(x) dt`` with ``d_i = ½ tr(∇²Φ_{s,i}(x) W)``.

    Parameters
    ----------
    problem : Problem
        Its region and process noise ``W``.
    report : DriftDesignReport
        Its ``fields`` and multi-index ``s``.

    Returns
    -------
    c : float
        The largest eigenvalue of ``Q_s W Q_sᵀ`` on the region (sampled, widened 5 %): ``c I`` bounds the intensity.
    beta : float
        The largest ``|d(x)|`` (sampled, widened 5 %).
    beta_coords : ndarray, shape (n,)
        The largest ``|d_i(x)|`` per coordinate (widened 5 %).

    Raises
    ------
    NonFiniteError
        ``Q_s`` or the Hessians are not finite on the region.
    """
    import sympy as sp

    from nlobs.geometry.jacobian_box import MARGIN, sample_points
    from nlobs.geometry.observability import observability_map
    from nlobs.systems.codegen import compile_matrix

    F = report.fields
    W = np.asarray(problem.process_noise, dtype=float)
    Phi = sp.Matrix(observability_map(F, report.s))
    x = sp.Matrix(F.x)
    J = Phi.jacobian(x)
    Wm = sp.Matrix(W.shape[0], W.shape[1], [sp.Float(float(v)) for v in W.ravel()])
    d = sp.Matrix([sp.Rational(1, 2) * (sp.hessian(Phi[i], x) * Wm).trace() for i in range(Phi.shape[0])])
    lo, hi = input_range(problem)
    pts, _ = sample_points(problem.region, lo, hi, 2048, seed=2)
    Jv = np.broadcast_to(compile_matrix(J, (tuple(F.x),))(pts), (pts.shape[0], *J.shape))
    dv = np.broadcast_to(compile_matrix(d, (tuple(F.x),), vector=True)(pts), (pts.shape[0], d.shape[0]))
    if not (np.all(np.isfinite(Jv)) and np.all(np.isfinite(dv))):
        raise NonFiniteError("Q_s or ∇²Φ_s is not finite on the region")
    c = float(np.max(np.linalg.eigvalsh(np.einsum("sij,jk,slk->sil", Jv, W, Jv)))) * (1 + MARGIN)
    beta = float(np.max(np.linalg.norm(dv, axis=-1))) * (1 + MARGIN)
    return c, beta, np.max(np.abs(dv), axis=0) * (1 + MARGIN)
