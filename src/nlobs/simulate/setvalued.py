"""Algorithm 1 of Khajenejad & Yong on recorded measurements and in Monte Carlo, and the containment of the truth.

* :func:`run_setvalued` is a thin call of :func:`nlobs.simulate.run_observer` with
  :class:`~nlobs.observers.setvalued.SetValuedObserver`; :func:`radii_of`, :func:`input_estimates`,
  :func:`state_containment`, :func:`input_containment` read its result.
* :func:`simulate_batch` simulates the plant (8) over seeded runs (initial states and noises drawn in
  their balls, a fraction exactly at the bound, :func:`ball_samples`) and runs Algorithm 1 on them;
  :func:`containment_of` measures the containment of the truth in the balls at every step of every run,
  with the conditions the certificate rests on evaluated along the runs (:class:`ContainmentResult`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray
from nlobs._validate import as_finite_array, as_vector
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError, SimulationDiverged
from nlobs.observers.setvalued import GivenGain, Radii, SetValuedObserver
from nlobs.simulate.coverage import Condition, Coverage, Hypothesis, Premise, monitor
from nlobs.simulate.replay import run_observer
from nlobs.simulate.result import SimulationResult
from nlobs.synthesis.setvalued import SetValuedDesign
from nlobs.systems.discrete_ui import DiscreteUISystem

__all__ = [
    "ROUNDOFF_FRACTION",
    "ContainmentResult",
    "ball_samples",
    "containment_of",
    "input_containment",
    "input_estimates",
    "radii_of",
    "run_setvalued",
    "simulate_batch",
    "state_containment",
]


def run_setvalued(system: DiscreteUISystem, design: SetValuedDesign | GivenGain, y: ArrayLike, *,
                  u: ArrayLike | None = None, x0_hat: ArrayLike | None = None,
                  radii: Radii | None = None, weights: ArrayLike | None = None, truth: ArrayLike | None = None,
                  progress: bool | None = None) -> SimulationResult:
    """Run Algorithm 1 on measurements ``y`` of shape ``(B, K + 1, l)`` (``y_0..y_K``), batched over ``B``.

    A thin call of :func:`nlobs.simulate.run_observer` with :class:`SetValuedObserver`.

    Parameters
    ----------
    system : DiscreteUISystem
    design : SetValuedDesign or GivenGain
        Gains from :func:`nlobs.synthesis.setvalued.design_setvalued` (or a given ``L̃``).
    y : array_like, shape (B, K + 1, l)
        Measurements (finite; NaN raises :class:`~nlobs.errors.NonFiniteError`).
    u : array_like, shape (B, K + 1, m), optional
        Known inputs (zero when omitted).
    x0_hat : array_like, shape (n,) or (B, n), optional
        Initial centre (``system.x0`` when omitted).
    radii : Radii, optional
        Radii to report (default: the sound recursion for a design, none for a :class:`GivenGain`).
    weights : array_like, shape (B, K + 1, N) or (K + 1, N), optional
        Run-time LPV weights ``λ_{i,k}`` (Class III, Definition 2.4): (13) uses ``f_{k−1}``. Required
        for a design certified at the LPV vertices (``lpv="vertices"``).
    truth : array_like, shape (B, K + 1, n), optional
        The true states, kept as the result's ``x``.
    progress : bool, optional
        Progress bar (see :func:`~nlobs.simulate.run_observer`).

    Returns
    -------
    SimulationResult
        ``x_hat`` the centres ``x̂_{k|k}`` ``(B, K + 1, n)``; extras ``d_hat`` ``(B, K + 1, p)`` (row ``k``
        holds ``d̂_{k−1}``, NaN at ``k = 0``), ``radius_state`` ``(K + 1,)``, ``radius_input`` ``(K + 1,)``
        (NaN at ``k = 0``); info ``radius_state_steady``, ``radius_input_steady``, ``radii`` (the label).
        See :func:`state_containment`, :func:`input_containment`, :func:`input_estimates`, :func:`radii_of`.

    Raises
    ------
    InvalidArgumentError
        ``design`` was certified for another system (:class:`~nlobs.synthesis.setvalued.CertifiedFor`),
        or is a vertex design run without ``weights``.
    """
    if isinstance(design, SetValuedDesign):
        design.certified_for.require(system, weights_given=weights is not None)
    y_ = as_finite_array("y", y)
    if y_.ndim != 3 or y_.shape[-1] != system.l or y_.shape[1] < 1:
        raise DimensionError(f"y: expected shape (B, K + 1, {system.l}), got {y_.shape}")
    Bn, K1, _ = y_.shape
    if radii is not None and radii.state.shape != (K1,):
        raise DimensionError(f"radii: expected {K1} state radii, got {radii.state.shape}")
    if u is None:
        u_ = np.zeros((Bn, K1, system.m))
    else:
        u_ = as_finite_array("u", u)
        if u_.shape != (Bn, K1, system.m):
            raise DimensionError(f"u: expected shape {(Bn, K1, system.m)}, got {u_.shape}")
    if weights is not None:
        lw = system.lpv_weights(weights)
        u_ = np.concatenate([u_, np.broadcast_to(lw, (Bn, K1, lw.shape[-1]))], axis=-1)
    if x0_hat is None:
        xh = np.broadcast_to(system.x0, (Bn, system.n)).copy()
    else:
        x0a = as_finite_array("x0_hat", x0_hat)
        if x0a.ndim == 1:
            x0a = as_vector("x0_hat", x0a, system.n)
        xh = np.broadcast_to(x0a, (Bn, system.n)).copy()
    obs = SetValuedObserver(system, design, radii=radii, lpv_weights=weights is not None)
    t = np.arange(K1) * system.time.dt
    names = tuple(f"x{i + 1}" for i in range(system.n))
    res = run_observer(obs, t, x_hat0=xh, u=u_, y=y_, truth=truth, states=names, estimates=names,
                       outputs=tuple(f"y{i + 1}" for i in range(system.l)), progress=progress)
    rad = radii if radii is not None else (
        None if obs._rec is None else Radii(res.extras["radius_state"], res.extras["radius_input"][1:],
                                            *obs._rec.steady(), "sound"))
    info = dict(res.info)
    if rad is not None:
        info.update(radius_state_steady=rad.state_steady, radius_input_steady=rad.input_steady, radii=rad.label)
    extras = dict(res.extras)
    if rad is None:
        extras.pop("radius_state", None)
        extras.pop("radius_input", None)
    return dataclasses.replace(res, info=info, extras=extras)


def radii_of(result: SimulationResult) -> Radii | None:
    """The :class:`Radii` of a :func:`run_setvalued` result (``None`` when it has none).

    Parameters
    ----------
    result : SimulationResult
        A result of :func:`run_setvalued` or :func:`simulate_batch`.

    Returns
    -------
    Radii or None
        The state and input radii with their limits and label.
    """
    if "radius_state" not in result.extras:
        return None
    info = result.info
    return Radii(result.extras["radius_state"], result.extras["radius_input"][1:],
                 float(info.get("radius_state_steady", math.nan)), float(info.get("radius_input_steady", math.nan)),
                 str(info.get("radii", "")))


def input_estimates(result: SimulationResult) -> Array:
    """Centres ``d̂_{k−1}`` of the input balls, ``k = 1..K``, shape ``(B, K, p)`` (index ``j`` holds ``d̂_j``).

    Parameters
    ----------
    result : SimulationResult
        A result of :func:`run_setvalued` or :func:`simulate_batch` (its extra ``d_hat``).

    Returns
    -------
    ndarray, shape (B, K, p)
    """
    return result.extras["d_hat"][:, 1:]


def _radii_or_fail(result: SimulationResult, what: str) -> Radii:
    rad = radii_of(result)
    if rad is None:
        raise InvalidArgumentError(f"{what}: this run has no radii")
    return rad


def state_containment(result: SimulationResult, x_true: ArrayLike | None = None, rtol: float = 1e-9) -> BoolArray:
    """``(B, K + 1)``: ``‖x_k − x̂_{k|k}‖ ≤ δˣ_k`` (with a relative round-off allowance); truth default ``result.x``.

    Parameters
    ----------
    result : SimulationResult
        A result of :func:`run_setvalued` or :func:`simulate_batch`, with radii.
    x_true : array_like, shape (B, K + 1, n), optional
        The true states; default ``result.x``.
    rtol : float
        Round-off allowance: inside when the error is at most ``δˣ_k (1 + rtol) + rtol``.

    Returns
    -------
    ndarray of bool, shape (B, K + 1)

    Raises
    ------
    InvalidArgumentError
        The result has no radii, or no truth is given.
    """
    rad = _radii_or_fail(result, "state_containment")
    x = result.x if x_true is None else np.asarray(x_true)
    if x is None:
        raise InvalidArgumentError("state_containment: no truth given")
    e = np.linalg.norm(np.asarray(x) - result.x_hat, axis=-1)
    return e <= rad.state * (1 + rtol) + rtol


def input_containment(result: SimulationResult, d_true: ArrayLike, rtol: float = 1e-9) -> BoolArray:
    """``(B, K)``: ``‖d_{k−1} − d̂_{k−1}‖ ≤ δᵈ_{k−1}`` for ``d_true`` of shape ``(B, K, p)`` (``d_0..d_{K−1}``).

    Parameters
    ----------
    result : SimulationResult
        A result of :func:`run_setvalued` or :func:`simulate_batch`, with radii.
    d_true : array_like, shape (B, K, p)
        The true unknown inputs ``d_0..d_{K−1}``.
    rtol : float
        Round-off allowance: inside when the error is at most ``δᵈ_{k−1} (1 + rtol) + rtol``.

    Returns
    -------
    ndarray of bool, shape (B, K)

    Raises
    ------
    InvalidArgumentError
        The result has no radii.
    """
    rad = _radii_or_fail(result, "input_containment")
    e = np.linalg.norm(np.asarray(d_true) - input_estimates(result), axis=-1)
    return e <= rad.input * (1 + rtol) + rtol


def ball_samples(rng: np.random.Generator, shape: tuple[int, ...], radius: float, dim: int,
                 at_bound: float = 0.5) -> Array:
    """Points in the ball of ``radius`` in ``R^dim``: uniform direction; a fraction ``at_bound`` exactly on the sphere,
    the rest uniform in the ball.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the draws.
    shape : tuple of int
        Batch shape of the points.
    radius : float
        Radius of the ball.
    dim : int
        Dimension of the space (``0``: an empty last axis).
    at_bound : float
        Fraction of the points (in probability) drawn exactly on the sphere.

    Returns
    -------
    ndarray, shape (*shape, dim)
    """
    if dim == 0:
        return np.zeros(shape + (0,))
    g = rng.standard_normal(shape + (dim,))
    g /= np.linalg.norm(g, axis=-1, keepdims=True)
    mag = radius * rng.random(shape + (1,)) ** (1.0 / dim)
    on = rng.random(shape + (1,)) < at_bound
    return g * np.where(on, radius, mag)


@dataclass(frozen=True)
class ContainmentResult:
    """Monte Carlo containment of the truth in the balls of Algorithm 1.

    Attributes
    ----------
    runs, steps : int
    rate_state, rate_input : float
        Fraction of runs whose true state (unknown input) was inside its ball at *every* step.
    max_error_over_radius : float
        ``max ‖x_k − x̂_k‖ / δˣ_k`` over runs and steps.
    final_radius_state, final_radius_input : float
    first_violation_step : int or None
        Earliest step at which some run left the state ball.
    seconds : float
        Simulation + observer time.
    label : str
    errors : ndarray, shape (runs, steps + 1)
        ``‖x_k − x̂_k‖`` (for plots).
    radii : Radii
    class_violated_in_runs : int or None
        Runs in which a visited pair ``(x_k, x̂_k)`` violates the class condition the certificate uses
        (:func:`~nlobs.systems.discrete_ui.class_margins`; ``None`` when not evaluated).
    class_worst_margin : float or None
        The smallest margin ``QC − γ`` over those pairs (negative: violated).
    left_box_runs : int or None
        Runs in which ``x_k`` or ``x̂_k`` left the box where the class was checked (``None``: no box given).
    roundoff_runs : int or None
        Runs in which the floating-point round-off estimate ``ε·κ·(‖x_k‖ + ‖Gd_k‖ + ‖Hd_k‖ + ‖y_k‖)``
        (``κ`` from the observer's gains) exceeds :data:`ROUNDOFF_FRACTION` of the radius ``δˣ_k``,
        or the estimate is not finite.
    roundoff_ratio : float or None
        The largest ratio of that estimate to the radius.
    max_abs_input : float or None
        ``max |d|`` over the runs.
    per_run : dict of str to ndarray
        Per-run values of the conditions above, each ``(runs,)``: ``class_margin`` (smallest ``QC − γ``
        of the run), ``roundoff_ratio`` (largest round-off estimate over ``δˣ_k``), ``left_box`` (flags).
    coverage : Coverage or None
        The certificate monitor on these runs (:func:`nlobs.simulate.coverage.monitor`): the function
        class on the visited pairs and the round-off bound, the hypotheses above as one mechanism, with
        the first violation per run (``None`` when not evaluated).
    """

    runs: int
    steps: int
    rate_state: float
    rate_input: float
    max_error_over_radius: float
    final_radius_state: float
    final_radius_input: float
    first_violation_step: int | None
    seconds: float
    label: str
    errors: Array = field(repr=False)
    radii: Radii = field(repr=False)
    class_violated_in_runs: int | None = None
    class_worst_margin: float | None = None
    left_box_runs: int | None = None
    roundoff_runs: int | None = None
    roundoff_ratio: float | None = None
    max_abs_input: float | None = None
    per_run: dict[str, Array] = field(default_factory=dict, repr=False)
    coverage: Coverage | None = field(default=None, repr=False)

    @property
    def guarantee_held(self) -> bool:
        """The truth stayed inside both balls at every step of every run."""
        return self.rate_state == 1.0 and self.rate_input == 1.0

    def likely_causes(self) -> list[str]:
        """Measured reasons why a certified guarantee can fail on these runs (empty when none was found)."""
        out = []
        if self.class_violated_in_runs:
            out.append(f"the function class is violated along the trajectories in {self.class_violated_in_runs} "
                       f"of {self.runs} runs (worst QC − γ = {self.class_worst_margin:.4g})")
        if self.left_box_runs and self.class_violated_in_runs != 0:  # harmless where the class held on every pair
            out.append(f"the state or its estimate left the box where the class was checked in {self.left_box_runs} "
                       f"of {self.runs} runs")
        if self.roundoff_runs:
            out.append(f"containment lost to floating-point round-off in {self.roundoff_runs} of {self.runs} runs "
                       f"(|d| = {self.max_abs_input:.4g}; round-off estimate up to {self.roundoff_ratio:.3g} × the "
                       "radius)")
        return out


#: Round-off flag: the estimated floating-point error of one step exceeds this fraction of the radius.
ROUNDOFF_FRACTION = 0.01


def known_input_grid(known_input: Callable[[float], Any] | None, t: Array, m: int, runs: int) -> Array:
    """``u_k = u(t_k)`` on the grid, ``(runs, K + 1, m)`` (zeros without a known input), checked finite."""
    if known_input is None or m == 0:
        return np.zeros((runs, t.size, m))
    u1 = np.stack([np.asarray(known_input(float(tk)), dtype=float).reshape(m) for tk in t])
    bad = ~np.all(np.isfinite(u1), axis=-1)
    if np.any(bad):
        k = int(np.argmax(bad))
        raise NonFiniteError(f"known input: u(t) is not finite at step {k} (t = {t[k]:g})")
    return np.broadcast_to(u1[None], (runs, t.size, m)).copy()


def simulate_batch(system: DiscreteUISystem, gain: SetValuedDesign | GivenGain,
                   unknown_input: Callable[[Array], Array], *, runs: int, steps: int, seed: int = 0,
                   radii: Radii | None = None, at_bound: float = 0.5,
                   known_input: Callable[[float], Any] | None = None) -> SimulationResult:
    """Simulate the plant (8) and run Algorithm 1 for ``runs`` seeded runs (vectorised).

    Initial states are drawn in the initial ball and the noises in theirs, a fraction
    ``at_bound`` of each exactly on the bound (:func:`ball_samples`); ``unknown_input``
    maps ``t`` ``(K + 1,)`` to ``d`` ``(K + 1, p)``, the same in every run; ``known_input``
    ``t ↦ u(t)`` ``(m,)`` is the known input ``u_k = u(k dt)`` of ``B u`` and ``D u`` (zero when
    omitted), the same in every run and given to the observer.

    Parameters
    ----------
    system : DiscreteUISystem
        The plant (8), with its initial ball (``x0``, ``delta0``) and noise bounds ``eta_w``, ``eta_v``.
    gain : SetValuedDesign or GivenGain
        The observer's gains (a :class:`GivenGain` needs ``radii``).
    unknown_input : callable
        ``d(t)``: maps the times ``(K + 1,)`` to the unknown input ``(K + 1, p)``.
    runs : int
        Number of runs ``B`` (``>= 1``).
    steps : int
        Number of steps ``K`` (``>= 1``).
    seed : int
        Initial value of the random generator (:func:`numpy.random.default_rng`) of the draws.
    radii : Radii, optional
        Radii to report (default: the sound recursion for a design).
    at_bound : float
        Fraction of the initial states and noises drawn exactly on the bound (:func:`ball_samples`).
    known_input : callable, optional
        ``u(t)`` ``(m,)``, the known input; zero when omitted.

    Returns
    -------
    SimulationResult
        Of :func:`~nlobs.simulate.setvalued.run_setvalued`, with the truth ``x`` ``(B, K + 1, n)``, the
        measurements ``y`` ``(B, K + 1, l)`` and the extra ``d`` ``(B, K + 1, p)`` (the unknown input);
        ``info["seconds"]`` is the plant and observer time.

    Raises
    ------
    InvalidArgumentError
        ``runs`` or ``steps`` below 1, or a design certified for another system.
    NonFiniteError
        The unknown or the known input is not finite at some step.
    SimulationDiverged
        The plant's state overflows.
    """
    R, K = int(runs), int(steps)
    if R < 1 or K < 1:
        raise InvalidArgumentError(f"`runs` and `steps` must be >= 1, got {runs!r}, {steps!r}")
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    x0 = system.x0 + ball_samples(rng, (R,), system.delta0, system.n, at_bound)
    t = np.arange(K + 1) * system.time.dt
    with np.errstate(over="ignore", invalid="ignore"):
        d1 = np.asarray(unknown_input(t), dtype=float).reshape(K + 1, system.p)
    bad_d = ~np.all(np.isfinite(d1), axis=-1)
    if np.any(bad_d):
        k = int(np.argmax(bad_d))
        raise NonFiniteError(f"unknown input: d(t) is not finite at step {k} (t = {t[k]:g}): the signal overflows "
                             "the floating-point range; shorten the horizon (`steps`) or bound the signal")
    d = np.broadcast_to(d1[None], (R, K + 1, system.p))
    u = known_input_grid(known_input, t, system.m, R)
    w = ball_samples(rng, (R, K), system.eta_w, system.n_w, at_bound)
    v = ball_samples(rng, (R, K + 1), system.eta_v, system.l, at_bound)
    with np.errstate(over="ignore", invalid="ignore"):
        x, y = system.simulate(x0, d, w, v, u=u)
    bad_x = ~np.all(np.isfinite(x), axis=-1)  # (R, K + 1)
    if np.any(bad_x):
        k = int(np.argmax(bad_x.any(axis=0)))
        i = int(np.argmax((~np.isfinite(x[:, k])).any(axis=0)))
        exc = SimulationDiverged(float(t[k]), "plant", f"x{i + 1}")
        exc.args = (f"the plant overflowed at step {k} (t = {t[k]:g}): state x{i + 1} is not finite in "
                    f"{int(bad_x[:, k].sum())} of {R} runs (the model's f or the unknown input drives it past the "
                    "floating-point range)",)
        raise exc
    res = run_setvalued(system, gain, y, radii=radii, truth=x, u=u)
    return dataclasses.replace(res, y=y, extras={**res.extras, "d": np.array(d), "u": np.array(u)},
                               info={**res.info, "seconds": time.perf_counter() - t0})


def containment_of(batch: SimulationResult, label: str = "sound", *, system: DiscreteUISystem | None = None,
                   gain: SetValuedDesign | GivenGain | None = None,
                   box: tuple[ArrayLike, ArrayLike] | None = None) -> ContainmentResult:
    """Containment of the truth in the balls of ``batch`` (every step of every run), with the conditions it rests on.

    ``batch`` is a :func:`simulate_batch` result. With its ``system`` and ``gain``, also evaluates on the
    pairs the runs visit: the class condition the certificate uses, whether the states left ``box`` (where
    the class was checked), and a floating-point round-off estimate against the radius (``ContainmentResult``).

    Parameters
    ----------
    batch : SimulationResult
        A :func:`simulate_batch` result, with radii.
    label : str
        Label of the result.
    system : DiscreteUISystem, optional
        The plant of ``batch``; with ``gain``, enables the conditions along the runs.
    gain : SetValuedDesign or GivenGain, optional
        The gains ``batch`` was run with.
    box : tuple of (lower, upper) array_like, optional
        The box where the class was checked (only with ``system`` and ``gain``).

    Returns
    -------
    ContainmentResult

    Raises
    ------
    InvalidArgumentError
        ``batch`` has no radii.
    """
    rad = radii_of(batch)
    if rad is None:
        raise InvalidArgumentError("containment_study: a GivenGain needs radii")
    x, d = batch.x, batch.extras["d"]
    with np.errstate(over="ignore", invalid="ignore"):
        inside = state_containment(batch)
        inside_d = _input_inside(batch, d[:, :-1], rad)
        err = np.linalg.norm(x - batch.x_hat, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(rad.state > 0, err / rad.state, np.where(err > 0, np.inf, 0.0))
    ratio = np.where(np.isnan(ratio), np.inf, ratio)
    bad = np.flatnonzero(~inside.all(axis=0))
    R, K1 = err.shape
    extra = _trajectory_conditions(batch, system, gain, box) if system is not None and gain is not None else {}
    return ContainmentResult(
        runs=R, steps=K1 - 1, rate_state=float(inside.all(axis=1).mean()),
        rate_input=float(inside_d.all(axis=1).mean()), max_error_over_radius=float(np.max(ratio)),
        final_radius_state=float(rad.state[-1]), final_radius_input=float(rad.input[-1]),
        first_violation_step=int(bad[0]) if bad.size else None, seconds=float(batch.info.get("seconds", 0.0)),
        label=label, errors=err, radii=rad, **extra,
    )


def _input_inside(batch: SimulationResult, d_true: Array, rad: Radii, rtol: float = 1e-9) -> Array:
    e = np.linalg.norm(d_true - input_estimates(batch), axis=-1)
    return e <= rad.input * (1 + rtol) + rtol


def _trajectory_conditions(batch: SimulationResult, system: DiscreteUISystem, gain: SetValuedDesign | GivenGain,
                           box: tuple[ArrayLike, ArrayLike] | None) -> dict[str, Any]:
    """Class condition on the visited pairs, box exits and the round-off estimate (see :class:`ContainmentResult`)."""
    from nlobs.systems.discrete_ui import LPV, class_margins

    x, xh = batch.x, batch.x_hat
    d = batch.extras["d"]
    out: dict[str, Any] = {}
    per_run: dict[str, Array] = {}
    hypotheses: list[Hypothesis] = []
    fc = gain.function_class if isinstance(gain, SetValuedDesign) else system.function_class
    if not isinstance(fc, LPV):  # a vertex design is run with the plant's weights: π is in the polytope by construction
        margin, rel = class_margins(system.nonlinear, fc, xh[:, :-1], x[:, :-1])
        out["class_violated_in_runs"] = int(np.sum((rel < 0).any(axis=1)))
        out["class_worst_margin"] = float(np.min(margin)) if margin.size else None
        per_run["class_margin"] = margin.reshape(margin.shape[0], -1).min(axis=1) if margin.size else np.full(
            x.shape[0], np.inf)
        hypotheses.append(Condition(f"function class {fc.label} on the visited pairs (x_k, x̂_k)", rel,
                                    "QC − γ (tolerance-adjusted)"))
    if box is not None:
        lo, hi = np.asarray(box[0], dtype=float), np.asarray(box[1], dtype=float)
        with np.errstate(invalid="ignore"):
            outside = ((x < lo) | (x > hi)).any(axis=(1, 2)) | ~((xh >= lo) & (xh <= hi)).all(axis=(1, 2))
        out["left_box_runs"] = int(np.sum(outside))
        per_run["left_box"] = outside
    tr = gain.transform

    def nrm(M: Array) -> float:
        return float(np.linalg.norm(M, 2)) if M.size else 0.0

    kappa = ((1.0 + nrm(gain.gain) * nrm(tr.C2)) * (1.0 + nrm(tr.G1 @ tr.M1) + nrm(tr.G2 @ tr.M2))
             * (1.0 + nrm(system.C) + nrm(system.A)))
    with np.errstate(over="ignore", invalid="ignore"):
        scale = (np.linalg.norm(x, axis=-1) + np.linalg.norm(d @ system.G.T, axis=-1)
                 + np.linalg.norm(d @ system.H.T, axis=-1) + np.linalg.norm(batch.y, axis=-1))
        scale[:, 1:] = np.maximum(scale[:, 1:], scale[:, :-1])  # the error of step k carries that of step k - 1
        est = float(np.finfo(float).eps) * kappa * scale
        rad = np.asarray(batch.extras["radius_state"])
        rr = np.where(rad > 0, est / np.where(rad > 0, rad, 1.0), np.where(est > 0, np.inf, 0.0))
    rr = np.where(np.isfinite(rr) & np.isfinite(xh).all(axis=-1), rr, np.inf)
    out["roundoff_runs"] = int(np.sum((rr > ROUNDOFF_FRACTION).any(axis=1)))
    out["roundoff_ratio"] = float(np.max(rr))
    per_run["roundoff_ratio"] = rr.max(axis=1)
    out["max_abs_input"] = float(np.max(np.abs(d))) if d.size else 0.0
    with np.errstate(invalid="ignore"):
        hypotheses.append(Condition(f"floating-point round-off within {ROUNDOFF_FRACTION:g} × the radius δˣ_k",
                                    ROUNDOFF_FRACTION - rr, f"{ROUNDOFF_FRACTION:g} − round-off estimate / δˣ_k"))
    verified = bool(gain.verified) if isinstance(gain, SetValuedDesign) else False
    premises = [] if isinstance(gain, SetValuedDesign) else [
        Premise("a certificate for the gain", False, "a given gain (not designed by nlobs) has none")]
    out["coverage"] = monitor(batch, [*hypotheses, *premises], verified=verified)
    out["per_run"] = per_run
    return out




#: Bytes of a violation's detail kept per run in a Monte Carlo summary.
DETAIL_BYTES = 96


def run_summaries(batch: SimulationResult, system: DiscreteUISystem, gain: SetValuedDesign | GivenGain,
                  box: tuple[ArrayLike, ArrayLike] | None = None, *,
                  containment: ContainmentResult | None = None) -> dict[str, Array]:
    """Per-run values of a :func:`simulate_batch` result, for a Monte Carlo study (each ``(runs,)``).

    ``contained`` / ``input_contained``: the truth ``x_k`` (``d_k``) is in its ball at every step;
    ``first_violation_step`` (−1: none); ``final_error`` ``‖x_K − x̂_K‖``; ``max_error_over_radius`` over
    the steps and ``…_after_step_0``; ``covered``: the certificate covers the run
    (:class:`~nlobs.simulate.coverage.Coverage`: a verified design, the class on the visited pairs and
    the round-off bound), with the run's first violation (``violation_hypothesis``: its index in the
    coverage's ``hypotheses``, −1 when none; ``violation_time``, NaN when none; ``violation_detail``, UTF-8
    bytes, at most :data:`DETAIL_BYTES`); ``class_violated``, ``class_margin``, ``left_box``
    (``box`` given), ``roundoff`` and ``roundoff_ratio`` give the conditions one by one.
    ``containment`` is :func:`containment_of` of the same batch when already computed.
    """
    res = containment if containment is not None else containment_of(batch, system=system, gain=gain, box=box)
    rad = res.radii
    R = res.runs
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        inside_k = state_containment(batch)
        inside_d = _input_inside(batch, batch.extras["d"][:, :-1], rad).all(axis=1)
        ratio = np.where(rad.state > 0, res.errors / rad.state, np.where(res.errors > 0, np.inf, 0.0))
    ratio = np.where(np.isnan(ratio), np.inf, ratio)
    first = np.where(inside_k.all(axis=1), -1, np.argmax(~inside_k, axis=1))
    cov = res.coverage
    covered = np.zeros(R, bool) if cov is None or cov.failed_premises or not cov.verified else np.ones(R, bool)
    hyp = np.full(R, -1, dtype=np.int16)
    det = np.full(R, b"", dtype=object)
    when = np.full(R, np.nan)
    class_v = np.zeros(R, bool)
    names = list(cov.hypotheses) if cov is not None else []
    for v in () if cov is None else cov.violations:
        covered[v.run] = False
        hyp[v.run] = names.index(v.hypothesis) if v.hypothesis in names else len(names)
        det[v.run], when[v.run] = v.detail.encode("utf-8")[:DETAIL_BYTES], v.time
    pr = res.per_run
    if "class_margin" in pr:
        class_v = pr["class_margin"] < 0
        for v in () if cov is None else cov.violations:
            class_v[v.run] |= v.hypothesis.startswith("function class")
    out = {"contained": inside_k.all(axis=1), "input_contained": inside_d, "first_violation_step": first,
           "final_error": res.errors[:, -1].copy(), "max_error_over_radius": ratio.max(axis=1),
           "max_error_over_radius_after_step_0": (ratio[:, 1:].max(axis=1) if ratio.shape[1] > 1
                                                  else np.full(R, np.nan)),
           "covered": covered, "violation_hypothesis": hyp, "violation_time": when,
           "violation_detail": det.astype(bytes), "class_violated": class_v,
           "class_margin": pr.get("class_margin", np.full(R, np.nan)),
           "roundoff_ratio": pr.get("roundoff_ratio", np.full(R, np.nan))}
    out["roundoff"] = out["roundoff_ratio"] > ROUNDOFF_FRACTION
    if "left_box" in pr:
        out["left_box"] = pr["left_box"]
    return out


def _array_digest(*arrays: Any) -> str:
    import hashlib

    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(np.asarray(a, dtype=float)).tobytes())
    return h.hexdigest()[:16]


@dataclass(frozen=True, eq=False)
class SetValuedStudy:
    """Monte Carlo runs of the plant (8) and Algorithm 1 (Khajenejad & Yong), for :func:`~nlobs.simulate.monte_carlo`.

    Each batch draws its initial states and noises as :func:`simulate_batch` does, from the batch's own
    generator, and returns :func:`run_summaries` per run; with trajectories, the truth ``x`` and the centres
    ``x_hat`` (the radii are the same in every run: ``design``'s sound recursion).

    Parameters
    ----------
    system : DiscreteUISystem
    design : SetValuedDesign
        A verified design (its sound radii are used).
    unknown_input : callable
        ``t`` ``(K + 1,)`` → ``d`` ``(K + 1, p)``, the same in every run.
    steps : int
    input_label : str
        Names ``unknown_input`` in :meth:`key` (a function cannot be compared across processes).
    box : (lo, hi), optional
        Where the class was checked (runs leaving it are flagged ``left_box``).
    known_input : callable, optional
        ``t ↦ u(t)``, the known input (zero when omitted); named in ``input_label`` too.
    default_batch : int
        Runs per batch unless :func:`monte_carlo` is told otherwise.

    Examples
    --------
    Twenty runs of 50 steps of the flexible-joint robot of Khajenejad & Yong, Sec. 6.1 (a shipped model file, with
    its unknown input ``d(t) = 5 sin 2t + 1 + sign(t − 1)``), initial states and noises drawn in their balls: the
    truth stays in the state ball and the input in the input ball in every run, and the certificate covers
    every run:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.systems.modelfile import load_discrete_ui_model
    >>> model = load_discrete_ui_model("khajenejad-6-1")
    >>> system = model.system
    >>> study = SetValuedStudy(system, nlobs.design_setvalued(system, lam=0.98), model.signals["bounded"], steps=50,
    ...                        input_label="d = 5 sin 2t + 1 + sign(t - 1)")
    >>> study.name
    'set-valued khajenejad-6-1'
    >>> res = nlobs.monte_carlo(study, 20, batch=10)
    >>> res.runs, res.chunks, res.summaries["contained"].shape
    (20, 2, (20,))
    >>> bool(res.summaries["contained"].all()), bool(res.summaries["input_contained"].all())
    (True, True)
    >>> bool(res.summaries["covered"].all()), int(res.summaries["first_violation_step"].max())  # −1: none
    (True, -1)
    """

    system: DiscreteUISystem
    design: SetValuedDesign
    unknown_input: Callable[[Array], Array]
    steps: int
    input_label: str
    box: tuple[ArrayLike, ArrayLike] | None = None
    known_input: Callable[[float], Any] | None = None
    default_batch: int = 250

    @property
    def name(self) -> str:
        return f"set-valued {self.system.name}"

    def key(self) -> str:
        box = None if self.box is None else _array_digest(*self.box)
        s = self.system
        plant = _array_digest(s.A, s.C, s.G, s.H, [s.x0], [s.delta0, s.eta_w, s.eta_v])
        return f"setvalued|{s.name}|{plant}|{_array_digest(self.design.gain)}|{self.steps}|{self.input_label}|{box}"

    def prepare(self) -> None:
        return None

    def run(self, prepared: Any, rng: np.random.Generator, runs: int, trajectories: bool) -> Any:
        from nlobs.simulate.montecarlo import RunBatch

        batch = simulate_batch(self.system, self.design, self.unknown_input, runs=runs, steps=self.steps, seed=rng,
                               known_input=self.known_input)
        summ = run_summaries(batch, self.system, self.design, self.box)
        traj = {} if not trajectories else {"x": batch.x, "x_hat": batch.x_hat}
        return RunBatch(summ, traj)
