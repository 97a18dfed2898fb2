r"""Seed 004 (Khajenejad & Yong), Section 6: the two examples as printed, and Monte Carlo containment.

* :func:`example_61` — single-link flexible-joint robot (Sec. 6.1), ``n = 4``,
  ``T_s = 0.01``, Classes 0, I, II with the paper's constants and printed
  results (``P*``, ``Y*``, ``L̃*``, ``α*``, ``ρ*``).
* :func:`example_62` — the two-state benchmark (Sec. 6.2).
* :func:`containment_study` — Algorithm 1 over many runs (vectorised along the
  batch axis) with noises drawn in their balls, half of them *at* the bound,
  reporting the fraction of runs whose true state / unknown input stayed inside
  the balls at every step.

What the paper leaves open and we chose (documented, not tuned): the initial
ball (centre ``0``, radius ``δ₀ = 1`` for 6.1 and ``0.5`` for 6.2), the unknown
input of 6.1 (Fig. 2 is not given as data: ``d_k = 5 sin(2 t_k) + 2·1[t_k ≥ 1]``)
and the noise distribution (uniform direction; magnitude uniform in the ball or
at the bound, half each).

Findings (``docs/setvalued.md``): Example 6.2 as printed admits **no** stable
observer of the structure (10)-(15): ``(A, G, C)`` has the invariant zero
``−(0.42 + 0.6/0.65) ≈ −1.343`` outside the unit circle, and with the
nonlinearity the error obeys ``|x̃₁,k| ≥ 1.343 |x̃₁,k−1|`` for every gain.
Example 6.1 with the Lipschitz multiplier of Class I (``L_f = 3.33 T_s``) or the
printed Class 0 multiplier has no quadratic certificate (the LMI (⋆) is
infeasible for all ``λ < 1``); with Class II and Lemma 2.14's
``γ = −(2·3.33 T_s)²`` (the paper uses ``γ = 0``) a certified design exists.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._io import atomic_write
from nlobs._validate import positive
from nlobs.errors import InvalidArgumentError, NonFiniteError, SimulationDiverged
from nlobs.papers.reproduce import ReproRow, Value
from nlobs.observers.kalman import UnknownInputEKF
from nlobs.observers.lipschitz import DiscreteLipschitzObserver
from nlobs.observers.setvalued import GivenGain, Radii
from nlobs.simulate.replay import run_observer
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.setvalued import input_estimates, radii_of, run_setvalued, state_containment
from nlobs.synthesis.setvalued import SetValuedDesign
from nlobs.systems.discrete_ui import (
    DiscreteUISystem,
    Lipschitz,
    QuadraticConstraint,
    qcstar_from_bounded_split,
)
from nlobs.systems.timebase import Discrete

__all__ = [
    "PaperExample",
    "ContainmentResult",
    "example_61",
    "example_62",
    "ball_samples",
    "containment_study",
    "simulate_batch",
    "containment_of",
    "PointBaselines",
    "point_baselines",
    "run_baselines",
    "MonteCarloStudy",
    "monte_carlo",
    "plot_errors_vs_radii",
    "plot_study",
    "plot_trajectories",
    "save_figure",
    "adversarial_noise",
    "NaivePointObserver",
    "naive_point_observer",
    "reproduce",
]

Array = NDArray[np.float64]
TS = 0.01


@dataclass(frozen=True)
class PaperExample:
    """An example of Sec. 6 as printed.

    Attributes
    ----------
    system : DiscreteUISystem
        The model with the class of its nonlinear part.
    printed : mapping
        The paper's reported values (``P``, ``Y``, ``L_tilde``, ``alpha``, ``rho``, constants).
    unknown_input : callable
        ``d(t)`` used by the runners, ``t`` of shape ``(K + 1,)`` → ``(K + 1, p)``.
    note : str
        How the class was read from the paper.
    """

    system: DiscreteUISystem
    printed: Mapping[str, object]
    unknown_input: Callable[[Array], Array]
    note: str


def _A61() -> Array:
    return np.array([[1, TS, 0, 0], [-48.6 * TS, 1 - 1.25 * TS, 48.6 * TS, 0], [0, 0, 1, TS],
                     [19.5 * TS, 0, -19.5 * TS, 1]])


def _phi61(x: Array) -> Array:
    z = np.zeros(x.shape[:-1])
    return np.stack([z, np.full(x.shape[:-1], 2.16 * TS), z, -3.33 * TS * np.sin(x[..., 2])], axis=-1)


def _d61(t: Array) -> Array:
    return (5.0 * np.sin(2.0 * t) + 2.0 * (t >= 1.0))[:, None]


_PRINTED_61: dict[str, dict[str, object]] = {
    "0": {"P": [[1.4458, -1.5232, -0.3419, -0.2265], [-1.5232, 2.5753, -0.2546, -0.1828],
                [-0.3419, -0.2546, 1.2159, -0.1475], [-0.2265, -0.1828, -0.1475, 1.2605]],
          "Y": [0.4348, 0.3372, 0.1376, 0.1243], "alpha": 0.750, "rho": 1.1781,
          "L_tilde": [1.2471, 0.8705, 0.4783, 0.2947], "L_f": 3.33 * TS},
    "I": {"P": [[1.6684, -1.8242, -0.4606, -0.2268], [-1.8242, 2.8284, -0.2860, -0.0424],
                [-0.4606, -0.2860, 1.2086, -0.0628], [-0.2208, -0.0424, -0.0628, 1.2088]],
          "Y": [0.6464, 0.4422, 0.0420, 0.0264], "alpha": 0.825, "rho": 0.9436,
          "L_tilde": [1.2620, 0.4288, 0.4244, 0.2667], "L_f": 3.33 * TS},
    "II": {"P": [[2.2823, -2.7731, -1.0065, -0.5036], [-2.7731, 4.7225, -0.1605, -0.9806],
                 [-1.0065, -0.1605, 4.5760, -0.3148], [-0.5036, -0.9806, -0.3148, 4.4577]],
           "Y": [-0.9692, 1.0644, 0.0259, 0.0661], "alpha": 0.793, "rho": 0.9783,
           "L_tilde": [0.4605, 0.1837, 0.9321, 0.3519], "gamma": 0.0},
}


def example_61(function_class: str = "II", *, delta0: float = 1.0) -> PaperExample:
    """Sec. 6.1, flexible-joint robot, as printed (``η_w = η_v = 0.1``, ``W = I``).

    Parameters
    ----------
    function_class : {"0", "I", "II", "0-structured"}
        ``"I"``: Lipschitz with ``L_f = 3.33 T_s`` on the nonlinear part (the
        paper's constant); ``"II"``: ``(0, γ)``-QC* on the nonlinear part, i.e.
        ``(A, γ)``-QC* on ``f`` as in the paper, with Lemma 2.14's
        ``γ = −(2·3.33 T_s)²`` (printed: ``γ = 0``, which would make ``f`` affine);
        ``"0"``: the printed ``M = [[I, 0], [0, (3.333 T_s)² I]]``; ``"0-structured"``: nlobs's
        multiplier ``−‖Δφ‖² + (3.33 T_s)² Δx₃² ≥ 0`` (not in the paper; no printed values).
    delta0 : float
        Radius of the initial ball around ``0`` (not given in the paper).
    """
    n = 4
    if function_class == "I":
        fc = Lipschitz(3.33 * TS, n)
        note = "Class I: L_f = 3.33 Ts is the Lipschitz constant of the nonlinear part (as the paper uses it)"
    elif function_class == "II":
        fc = qcstar_from_bounded_split(np.zeros((n, n)), 3.33 * TS)
        note = ("Class II: f = A x + h + g(x), ‖g‖ ≤ 3.33 Ts, so (A, γ)-QC* with Lemma 2.14's γ = -(2·3.33 Ts)²; "
                "the paper prints γ = 0")
    elif function_class == "0-structured":
        Ms = np.zeros((2 * n, 2 * n))
        Ms[:n, :n] = -np.eye(n)
        Ms[n + 2, n + 2] = (3.33 * TS) ** 2
        fc = QuadraticConstraint(Ms, 0.0)
        note = ("Class 0 with nlobs's structured multiplier −‖Δφ‖² + (3.33 Ts)² Δx₃² ≥ 0 (φ depends on x₃ only); "
                "NOT in the paper")
    elif function_class == "0":
        fc = QuadraticConstraint(np.block([[np.eye(n), np.zeros((n, n))],
                                           [np.zeros((n, n)), (3.333 * TS) ** 2 * np.eye(n)]]), 0.0)
        note = "Class 0: the printed multiplier M = [[I, 0], [0, (3.333 Ts)² I]] (M11 = +I carries no information)"
    else:
        raise InvalidArgumentError(
            f"function_class: expected '0', 'I', 'II' or '0-structured', got {function_class!r}")
    system = DiscreteUISystem(
        _A61(), TS * np.array([[5.0, 5.0, 2.0, 1.0]]).T, np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]]),
        TS * np.array([[1.1, 2.0]]).T, phi=_phi61, function_class=fc, eta_w=0.1, eta_v=0.1,
        x0=np.zeros(n), delta0=positive("delta0", delta0, allow_zero=True), time=Discrete(TS),
        name=f"khajenejad-yong 6.1 class {function_class}",
    )
    return PaperExample(system, dict(_PRINTED_61.get(function_class, {})), _d61, note)


def _phi62(x: Array) -> Array:
    return np.stack([np.zeros(x.shape[:-1]), -1.25 * np.tanh(x[..., 0])], axis=-1)


def _d62(t: Array) -> Array:
    return (0.2 * np.sin(t))[:, None]


def example_62(*, delta0: float = 0.5) -> PaperExample:
    """Sec. 6.2 benchmark as printed: ``f(x) = [−0.42x₁ + x₂, −0.6x₁ − 1.25 tanh x₁]``, ``C = [0 1]``.

    ``f`` is split into ``A = [[−0.42, 1], [−0.6, 0]]`` and ``φ = [0, −1.25 tanh x₁]``
    (Lipschitz 1.25). The paper's ``L_f = 1.1171`` is ``‖A‖``; ``f``'s own
    constant is ≈ 1.914 (recorded in ``printed``).
    """
    system = DiscreteUISystem(
        np.array([[-0.42, 1.0], [-0.6, 0.0]]), np.array([[1.0], [-0.65]]), np.array([[0.0, 1.0]]),
        phi=_phi62, function_class=Lipschitz(1.25, 2), eta_w=0.2, eta_v=0.1, x0=np.zeros(2),
        delta0=positive("delta0", delta0, allow_zero=True), time=Discrete(1.0), name="khajenejad-yong 6.2",
    )
    printed = {"P": [[1.8086, 1.4022], [1.4022, 5.2068]], "Y": [-0.2282, 0.6664], "L_tilde": [-0.2604, 0.2064],
               "alpha": 0.8875, "rho": 1.7336, "L_f": 1.1171}
    return PaperExample(system, printed, _d62, "Class I on the nonlinear part; L_f = 1.1171 printed is ‖A‖")


# --------------------------------------------------------------------------- Monte Carlo


def ball_samples(rng: np.random.Generator, shape: tuple[int, ...], radius: float, dim: int,
                 at_bound: float = 0.5) -> Array:
    """Points in the ball of ``radius`` in ``R^dim``: uniform direction; a fraction ``at_bound`` exactly on the sphere,
    the rest uniform in the ball."""
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


def simulate_batch(system: DiscreteUISystem, gain: SetValuedDesign | GivenGain,
                   unknown_input: Callable[[Array], Array], *, runs: int, steps: int, seed: int = 0,
                   radii: Radii | None = None, at_bound: float = 0.5) -> SimulationResult:
    """Simulate the plant (8) and run Algorithm 1 for ``runs`` seeded runs (vectorised).

    Initial states are drawn in the initial ball and the noises in theirs, a fraction
    ``at_bound`` of each exactly on the bound (:func:`ball_samples`); ``unknown_input``
    maps ``t`` ``(K + 1,)`` to ``d`` ``(K + 1, p)``, the same in every run.

    Returns
    -------
    SimulationResult
        Of :func:`~nlobs.simulate.setvalued.run_setvalued`, with the truth ``x`` ``(B, K + 1, n)``, the
        measurements ``y`` ``(B, K + 1, l)`` and the extra ``d`` ``(B, K + 1, p)`` (the unknown input);
        ``info["seconds"]`` is the plant and observer time.
    """
    R, K = int(runs), int(steps)
    if R < 1 or K < 1:
        raise InvalidArgumentError(f"runs and steps must be >= 1, got {runs!r}, {steps!r}")
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
                             "the floating-point range; shorten the horizon (--steps) or bound the signal")
    d = np.broadcast_to(d1[None], (R, K + 1, system.p))
    w = ball_samples(rng, (R, K), system.eta_w, system.n_w, at_bound)
    v = ball_samples(rng, (R, K + 1), system.eta_v, system.l, at_bound)
    with np.errstate(over="ignore", invalid="ignore"):
        x, y = system.simulate(x0, d, w, v)
    bad_x = ~np.all(np.isfinite(x), axis=-1)  # (R, K + 1)
    if np.any(bad_x):
        k = int(np.argmax(bad_x.any(axis=0)))
        i = int(np.argmax((~np.isfinite(x[:, k])).any(axis=0)))
        exc = SimulationDiverged(float(t[k]), "plant", f"x{i + 1}")
        exc.args = (f"the plant overflowed at step {k} (t = {t[k]:g}): state x{i + 1} is not finite in "
                    f"{int(bad_x[:, k].sum())} of {R} runs (the model's f or the unknown input drives it past the "
                    "floating-point range)",)
        raise exc
    res = run_setvalued(system, gain, y, radii=radii, truth=x)
    return dataclasses.replace(res, y=y, extras={**res.extras, "d": np.array(d)},
                               info={**res.info, "seconds": time.perf_counter() - t0})


def containment_of(batch: SimulationResult, label: str = "sound", *, system: DiscreteUISystem | None = None,
                   gain: SetValuedDesign | GivenGain | None = None,
                   box: tuple[ArrayLike, ArrayLike] | None = None) -> ContainmentResult:
    """Containment of the truth in the balls of ``batch`` (every step of every run), with the conditions it rests on.

    ``batch`` is a :func:`simulate_batch` result. With its ``system`` and ``gain``, also evaluates on the
    pairs the runs visit: the class condition the certificate uses, whether the states left ``box`` (where
    the class was checked), and a floating-point round-off estimate against the radius (``ContainmentResult``).
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
    fc = gain.function_class if isinstance(gain, SetValuedDesign) else system.function_class
    if not isinstance(fc, LPV):  # a vertex design is run with the plant's weights: π is in the polytope by construction
        margin, rel = class_margins(system.nonlinear, fc, xh[:, :-1], x[:, :-1])
        out["class_violated_in_runs"] = int(np.sum((rel < 0).any(axis=1)))
        out["class_worst_margin"] = float(np.min(margin)) if margin.size else None
    if box is not None:
        lo, hi = np.asarray(box[0], dtype=float), np.asarray(box[1], dtype=float)
        with np.errstate(invalid="ignore"):
            outside = ((x < lo) | (x > hi)).any(axis=(1, 2)) | ~((xh >= lo) & (xh <= hi)).all(axis=(1, 2))
        out["left_box_runs"] = int(np.sum(outside))
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
    out["max_abs_input"] = float(np.max(np.abs(d))) if d.size else 0.0
    return out


def containment_study(example: PaperExample, gain: SetValuedDesign | GivenGain, *, runs: int = 1000,
                      steps: int = 200, seed: int = 0, radii: Radii | None = None,
                      unknown_input: Callable[[Array], Array] | None = None, label: str = "sound",
                      box: tuple[ArrayLike, ArrayLike] | None = None) -> ContainmentResult:
    """Run the plant and Algorithm 1 for ``runs`` seeded Monte Carlo runs (vectorised) and measure containment.

    Initial states are drawn in the initial ball and noises in theirs (half of
    each at the bound, see :func:`ball_samples`). The class condition is evaluated on the visited pairs,
    and, with ``box`` (where the class was checked), exits from it are counted (:func:`containment_of`).
    """
    dfun = example.unknown_input if unknown_input is None else unknown_input
    batch = simulate_batch(example.system, gain, dfun, runs=runs, steps=steps, seed=seed, radii=radii)
    return containment_of(batch, label, system=example.system, gain=gain, box=box)


# --------------------------------------------------------------------------- point-observer baselines


@dataclass(frozen=True)
class PointBaselines:
    """The two point observers of ``docs/baselines.md`` set up for a :class:`DiscreteUISystem`.

    Attributes
    ----------
    lipschitz : DiscreteLipschitzObserver or None
        Lipschitz LMI observer (ignores ``d``); ``None`` when its LMI is infeasible.
    lipschitz_note : str
        The constant and structure it was designed for, or why it could not be designed.
    ekf : UnknownInputEKF or None
        EKF modelling ``d`` as white noise of covariance ``Q_d`` (``None`` when it cannot be set up, e.g. a
        non-finite ``Q_d``; ``ekf_note`` says why).
    ekf_P0 : ndarray
        Its initial covariance.
    ekf_note : str
    """

    lipschitz: DiscreteLipschitzObserver | None
    lipschitz_note: str
    ekf: UnknownInputEKF | None
    ekf_P0: Array
    ekf_note: str


def _jacobian_fd(phi: Callable[[Array], Array], n: int) -> Callable[[Array], Array]:
    """Central-difference Jacobian of a batched map (used by the EKF baseline only)."""
    def jac(x: Array) -> Array:
        x = np.asarray(x, dtype=float)
        h = 1e-6 * np.maximum(1.0, np.abs(x))
        cols = []
        for j in range(n):
            e = np.zeros(n)
            e[j] = 1.0
            hj = h[..., j:j + 1]
            cols.append((np.asarray(phi(x + hj * e)) - np.asarray(phi(x - hj * e))) / (2 * hj))
        return np.stack(cols, axis=-1)
    return jac


def _sparsity(phi: Callable[[Array], Array], lo: Array, hi: Array, n: int, seed: int) -> tuple[Array, Array]:
    """``E``, ``F`` of ``φ = E ψ(F x) + const`` from sampled Jacobians (rows that vary, states it depends on)."""
    x = lo + (hi - lo) * np.random.default_rng(seed).random((256, n))
    J = np.abs(_jacobian_fd(phi, n)(x)).max(axis=0)
    tol = 1e-7 * max(1.0, float(J.max()))
    rows = np.flatnonzero(J.max(axis=1) > tol)
    cols = np.flatnonzero(J.max(axis=0) > tol)
    eye = np.eye(n)
    return eye[:, rows], eye[cols, :]


def point_baselines(system: DiscreteUISystem, *, q_d: float, box: tuple[ArrayLike, ArrayLike] | None = None,
                    seed: int = 0) -> PointBaselines:
    r"""Design the Lipschitz LMI observer and set up the EKF for ``system`` (``docs/baselines.md``).

    Lipschitz observer, designed by :func:`~nlobs.synthesis.discrete_lipschitz.design_discrete_lipschitz_gain`
    for ``f = A_b x + φ_b``: Class I ``(A, L)``; Class III ``(A, σ̃)``; Class 0 ``(A, k)`` with ``k`` the increment
    bound of (2) when ``M11 ≺ 0``; Class II ``(A + 𝒜, 0)``, the bounded remainder of Lemma 2.14 acting as a
    disturbance. When the constant is positive the structured bound ``φ = Eψ(Fx)`` is used, with the rows
    that vary and the states ``φ`` depends on read from Jacobians sampled in ``box`` (a sampled structure:
    evidence, not proof). EKF: ``Q_w = η_w²/(n_w + 2) I``, ``R_v = η_v²/(l + 2) I`` (covariances of the
    uniform distribution in the noise balls), ``Q_d = q_d I``, ``P₀ = δ₀²/(n + 2) I``, Jacobian of ``φ`` by
    central differences.
    """
    from nlobs.errors import DesignInfeasible
    from nlobs.synthesis.discrete_lipschitz import design_discrete_lipschitz_gain
    from nlobs.systems.discrete_ui import LPV, QCStar

    n, fc = system.n, system.function_class
    phi = system.nonlinear
    if box is None:
        half = max(10.0 * system.delta0, 1.0)
        lo, hi = system.x0 - half, system.x0 + half
    else:
        lo, hi = np.asarray(box[0], dtype=float), np.asarray(box[1], dtype=float)
    A_b, L_b = system.A, math.nan
    if isinstance(fc, Lipschitz):
        L_b = fc.L
    elif isinstance(fc, LPV):
        L_b = fc.sigma
    elif isinstance(fc, QCStar):
        A_b, L_b = system.A + fc.A_aux, 0.0
    else:
        L_b = fc.increment_bound(np.zeros((n, n)), np.eye(n))[0]
    lip: DiscreteLipschitzObserver | None = None
    if not math.isfinite(L_b):
        note = f"not designed: {fc.label} gives no Lipschitz bound (M11 is not negative definite)"
    else:
        E, F = (None, None) if L_b == 0 else _sparsity(phi, lo, hi, n, seed)
        try:
            cert = design_discrete_lipschitz_gain(A_b, system.C, lipschitz=L_b, E=E, F=F)
            lip = DiscreteLipschitzObserver(system.A, system.C, cert.gain, system.time, phi=system.nonlinear,
                                            B=system.B, D=system.D)
            note = (f"designed for γ = {L_b:.4g}" + ("" if E is None else f", φ = Eψ(Fx) with {E.shape[1]} rows "
                    f"and {F.shape[0]} states") + f": ρ = {cert.rho:.4g}, spectral radius {cert.spectral_radius:.4g}")
        except DesignInfeasible as exc:
            note = f"not designed: {exc}"
    from nlobs.errors import NlobsError

    ekf: UnknownInputEKF | None
    P0 = max(system.delta0, 1e-6) ** 2 / (n + 2) * np.eye(n)
    try:
        ekf = UnknownInputEKF(system.A, system.C, system.time,
                              Q_w=system.eta_w**2 / (system.n_w + 2) * np.eye(system.n_w),
                              R_v=max(system.eta_v, 1e-6) ** 2 / (system.l + 2) * np.eye(system.l),
                              Q_d=max(float(q_d), 1e-12) * np.eye(system.p), phi=phi,
                              phi_jacobian=_jacobian_fd(phi, n), B=system.B, D=system.D, G=system.G, H=system.H,
                              W=system.W, P0=P0)
        ekf_note = f"Q_d = {q_d:.4g} I (d modelled as white noise)"
    except NlobsError as exc:
        ekf, ekf_note = None, f"EKF diverged before its first step (not set up): {exc}"
    return PointBaselines(lip, note, ekf, P0, ekf_note)


def run_baselines(baselines: PointBaselines, system: DiscreteUISystem, y: Array) -> tuple[Array | None, Array]:
    """Run both point baselines on measurements ``y`` of shape ``(B, K + 1, l)``, from ``system.x0``.

    Parameters
    ----------
    baselines : PointBaselines
    system : DiscreteUISystem
    y : ndarray, shape (B, K + 1, l)

    Returns
    -------
    lipschitz : ndarray of shape (B, K + 1, n), or None
        Estimates ``x̂_k`` of the Lipschitz observer (a predictor: ``x̂_k`` uses ``y_0..y_{k−1}``);
        ``None`` when it could not be designed.
    ekf : ndarray of shape (B, K + 1, n), or None
        The EKF's priors ``x̂_{k|k−1}``; ``None`` when it was not set up.

    Raises
    ------
    SimulationDiverged
        The EKF diverged (its innovation covariance became singular or non-finite: ``LinAlgError``).
    """
    B, K1, _ = y.shape
    x0 = np.broadcast_to(system.x0, (B, system.n))
    t = np.arange(K1) * system.time.dt
    lip = None
    if baselines.lipschitz is not None:
        lip = run_observer(baselines.lipschitz, t, x_hat0=x0, y=y, divergence="keep").x_hat
    if baselines.ekf is None:
        return lip, None
    return lip, run_observer(baselines.ekf, t, x_hat0=x0, y=y, divergence="keep").x_hat


@dataclass(frozen=True)
class MonteCarloStudy:
    """Algorithm 1 and the point baselines on the same Monte Carlo runs.

    Attributes
    ----------
    containment : ContainmentResult
    batch : SimulationResult
        The runs themselves (of :func:`simulate_batch`, for plots).
    final_error_state : float
        ``max_runs ‖x_K − x̂_{K|K}‖`` of the set-valued observer.
    baseline_lipschitz_final_error, baseline_ekf_final_error : float or None
        ``max_runs ‖x_K − x̂_K‖`` of the baselines (``None`` when not designed / not run).
    baseline_lipschitz_errors, baseline_ekf_errors : ndarray or None, shape (B, K + 1)
    baselines : PointBaselines or None
    baseline_lipschitz_x_hat, baseline_ekf_x_hat : ndarray or None, shape (B, K + 1, n)
        The baselines' estimates (for plots).
    baseline_ekf_failure : str or None
        Why the EKF produced no estimates on these runs (e.g. "EKF diverged at step …").
    """

    containment: ContainmentResult
    batch: SimulationResult = field(repr=False)
    final_error_state: float
    baseline_lipschitz_final_error: float | None
    baseline_ekf_final_error: float | None
    baseline_lipschitz_errors: Array | None = field(repr=False)
    baseline_ekf_errors: Array | None = field(repr=False)
    baselines: PointBaselines | None = field(repr=False)
    baseline_lipschitz_x_hat: Array | None = field(default=None, repr=False)
    baseline_ekf_x_hat: Array | None = field(default=None, repr=False)
    baseline_ekf_failure: str | None = None


def monte_carlo(system: DiscreteUISystem, design: SetValuedDesign, unknown_input: Callable[[Array], Array], *,
                runs: int, steps: int, seed: int = 0, baselines: bool | PointBaselines = True,
                q_d: float | None = None, box: tuple[ArrayLike, ArrayLike] | None = None,
                label: str = "sound") -> MonteCarloStudy:
    """Containment of Algorithm 1 and, on the same runs, the errors of the point baselines.

    Parameters
    ----------
    system : DiscreteUISystem
    design : SetValuedDesign
        A verified design (its sound radii are used).
    unknown_input : callable
        ``t`` ``(K + 1,)`` → ``d`` ``(K + 1, p)``, the same in every run.
    runs, steps : int
    seed : int
        Seed of the initial states and noises (:func:`simulate_batch`).
    baselines : bool or PointBaselines
        ``True``: set them up with :func:`point_baselines`; ``False``: Algorithm 1 only.
    q_d : float, optional
        The EKF's ``Q_d = q_d I``; by default the mean square of ``unknown_input`` over the horizon (pass
        the bounded signal's to see how a filter tuned for a bounded ``d`` copes with a growing one).
    box : (lo, hi), optional
        Where the class was checked: the baselines' structure is sampled there, and runs whose states leave
        it are counted (``ContainmentResult.left_box_runs``).
    label : str

    Returns
    -------
    MonteCarloStudy
    """
    batch = simulate_batch(system, design, unknown_input, runs=runs, steps=steps, seed=seed)
    res = containment_of(batch, label, system=system, gain=design, box=box)
    fe = float(res.errors[:, -1].max())
    if baselines is False:
        return MonteCarloStudy(res, batch, fe, None, None, None, None, None)
    pb = baselines if isinstance(baselines, PointBaselines) else point_baselines(
        system, q_d=(float(np.mean(batch.extras["d"][0] ** 2)) if system.p else 0.0) if q_d is None else q_d, box=box,
        seed=seed)
    failure = None if pb.ekf is not None else pb.ekf_note
    with np.errstate(over="ignore", invalid="ignore"):
        try:
            lip, ekf = run_baselines(pb, system, batch.y)
        except SimulationDiverged as exc:  # the EKF's covariance broke down: report it, keep the other results
            failure = str(exc)
            lip, ekf = run_baselines(dataclasses.replace(pb, ekf=None), system, batch.y)
        el = None if lip is None else np.linalg.norm(batch.x - lip, axis=-1)
        ee = None if ekf is None else np.linalg.norm(batch.x - ekf, axis=-1)
    if ee is not None and not np.all(np.isfinite(ee[:, -1])) and failure is None:
        failure = "EKF diverged (non-finite estimates)"

    def final(e: Array | None) -> float | None:
        if e is None:
            return None
        v = float(np.max(e[:, -1]))
        return v if math.isfinite(v) else math.inf

    return MonteCarloStudy(res, batch, fe, final(el), final(ee), el, ee, pb, lip, ekf, failure)


# --------------------------------------------------------------------------- plots


def save_figure(fig: Any, path: str | Path) -> Path:
    """Save a matplotlib figure as PNG atomically (:func:`nlobs._io.atomic_write`); returns the path."""
    return atomic_write(path, lambda fh: fig.savefig(fh, format="png", dpi=120))


def plot_errors_vs_radii(results: tuple[ContainmentResult, ...], path: str | Path, *, title: str = "",
                         dt: float = 1.0, log: bool = False) -> Path:
    """Save a figure of the error norms over the runs (range, median) against each result's state radius.

    Uses matplotlib's object API (no pyplot). Returns ``path``.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    colours = ("C0", "C3", "C2", "C1")
    for res, col in zip(results, colours):
        t = np.arange(res.steps + 1) * dt
        ax.fill_between(t, np.min(res.errors, axis=0), np.max(res.errors, axis=0), color=col, alpha=0.2,
                        label=f"{res.label}: error range over {res.runs} runs")
        ax.plot(t, np.median(res.errors, axis=0), color=col, lw=1.0, label=f"{res.label}: median error")
        ax.plot(t, res.radii.state, color=col, lw=2.0, ls="--", label=f"{res.label}: radius δˣ_k")
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("t [s]" if dt != 1.0 else "step k")
    ax.set_ylabel("‖x_k − x̂_k|k‖")
    ax.set_title(title)
    ax.legend(fontsize=7)
    return save_figure(fig, path)


def plot_study(study: MonteCarloStudy, path: str | Path, *, title: str = "", dt: float = 1.0) -> Path:
    """Errors of Algorithm 1 against its radii, and the baselines' errors on the same runs (log scale)."""
    from matplotlib.figure import Figure

    res = study.containment
    t = np.arange(res.steps + 1) * dt
    fig = Figure(figsize=(8.0, 6.0), layout="constrained")
    ax, axd = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2)
    ax.fill_between(t, np.min(res.errors, axis=0), np.max(res.errors, axis=0), color="C0", alpha=0.25,
                    label=f"set-valued: error range ({res.runs} runs)")
    ax.plot(t, res.radii.state, "C0--", lw=2, label="set-valued: radius δˣ_k")
    for errs, col, name in ((study.baseline_lipschitz_errors, "C3", "Lipschitz LMI observer"),
                            (study.baseline_ekf_errors, "C2", "EKF, d as noise")):
        if errs is not None:
            ax.fill_between(t, np.min(errs, axis=0), np.max(errs, axis=0), color=col, alpha=0.2)
            ax.plot(t, np.median(errs, axis=0), color=col, lw=1.2, label=f"{name}: median error (band: range)")
    ax.set_yscale("log")
    ax.set_ylabel("‖x_k − x̂_k‖")
    ax.set_title(title)
    ax.legend(fontsize=7)
    b = study.batch
    de = np.linalg.norm(b.extras["d"][:, :-1] - input_estimates(b), axis=-1)
    axd.fill_between(t[:-1], de.min(axis=0), de.max(axis=0), color="C0", alpha=0.25, label="input error range")
    axd.plot(t[:-1], res.radii.input, "C0--", lw=2, label="input radius δᵈ_{k−1}")
    axd.set_yscale("log")
    axd.set_xlabel("t [s]" if dt != 1.0 else "step k")
    axd.set_ylabel("‖d_{k−1} − d̂_{k−1}‖")
    axd.legend(fontsize=7)
    return save_figure(fig, path)


def plot_trajectories(batch: SimulationResult, path: str | Path, *, run: int = 0, title: str = "") -> Path:
    """States, unknown inputs, their estimates and the balls over time for one run (like seed 004, Figs. 2-5).

    The ball ``‖x − x̂‖ ≤ δˣ`` is drawn per component as the interval ``x̂ᵢ ± δˣ`` (a projection of the ball).
    """
    from matplotlib.figure import Figure

    x, xh, rad = batch.x[run], batch.x_hat[run], radii_of(batch)
    d_all, dh_all = batch.extras["d"], input_estimates(batch)
    n, p = x.shape[1], d_all.shape[2]
    t = batch.t
    fig = Figure(figsize=(9.0, 2.0 * (n + p) + 0.5), layout="constrained")
    for i in range(n):
        ax = fig.add_subplot(n + p, 1, i + 1)
        if rad is not None:
            ax.fill_between(t, xh[:, i] - rad.state, xh[:, i] + rad.state, color="C0", alpha=0.15,
                            label="x̂ᵢ ± δˣ_k")
        ax.plot(t, x[:, i], "k", lw=1.2, label=f"x{i + 1}")
        ax.plot(t, xh[:, i], "C0--", lw=1.0, label=f"x̂{i + 1}")
        if rad is not None:
            ax.set_ylim(*_limits(x[:, i], xh[:, i]))
        ax.legend(fontsize=7, loc="upper right")
        if i == 0:
            ax.set_title(title)
    for j in range(p):
        ax = fig.add_subplot(n + p, 1, n + j + 1)
        dh = dh_all[run, :, j]
        if rad is not None:
            ax.fill_between(t[:-1], dh - rad.input, dh + rad.input, color="C1", alpha=0.15, label="d̂ ± δᵈ")
        ax.plot(t[:-1], d_all[run, :-1, j], "k", lw=1.2, label=f"d{j + 1}")
        ax.plot(t[:-1], dh, "C1--", lw=1.0, label=f"d̂{j + 1}")
        ax.set_ylim(*_limits(d_all[run, :-1, j], dh))
        ax.legend(fontsize=7, loc="upper right")
    ax.set_xlabel("t [s]")
    return save_figure(fig, path)


def _limits(*series: Array) -> tuple[float, float]:
    """y-limits showing the signals (the balls may be much wider early on)."""
    lo = min(float(np.min(s)) for s in series)
    hi = max(float(np.max(s)) for s in series)
    pad = 0.6 * max(hi - lo, 1e-3)
    return lo - pad, hi + pad


# --------------------------------------------------------------------------- adversarial noise


def adversarial_noise(system: DiscreteUISystem, design: SetValuedDesign, steps: int, *, seed: int = 0,
                      restarts: int = 20, iterations: int = 30) -> tuple[Array, Array, float]:
    r"""Noise sequences at their bounds that maximise ``‖x̃_K‖`` for the linear member of the class.

    For ``x̃_k = 𝒜_K x̃_{k−1} + ℰω_k`` (``𝒜_K = 𝒜 + ℬK₀``, ``K₀`` the first linear member, ``x̃_0 = 0``),
    ``x̃_K = Σ_j M_{w,j} w_{K−1−j} + Σ_i M_{v,i} v_{K−i}`` with ``M_{w,j} = 𝒜_K^jℰ_w`` and
    ``M_{v,i} = 𝒜_K^iℰ_{v,k} + 𝒜_K^{i−1}ℰ_{v,k−1}``. For a unit direction ``u`` the choice
    ``w = η_w M_{w,j}ᵀu/‖M_{w,j}ᵀu‖`` (and likewise ``v``) attains ``uᵀx̃_K = Σ_j ‖M_{w,j}ᵀu‖η_w + Σ_i ‖M_{v,i}ᵀu‖η_v``;
    ``u`` is improved by a fixed-point ascent from random starts.

    Returns
    -------
    w : ndarray, shape (K, n_w)
    v : ndarray, shape (K + 1, l)
    value : float
        ``uᵀx̃_K`` attained by these sequences on the linear member: a lower bound of the worst-case error.
    """
    design.certified_for.require(system)
    K = int(steps)
    Acl, Bcl, E = design.dynamics.split(design.gain)
    members = design.function_class.linear_members()
    AK = Acl + (Bcl @ members[0] if members else 0.0)
    l, nw, n = system.l, system.n_w, system.n
    E1, Ew, E2 = E[:, :l], E[:, l:l + nw], E[:, l + nw:]
    pw = [np.eye(n)]
    for _ in range(K):
        pw.append(AK @ pw[-1])
    Mw = [pw[j] @ Ew for j in range(K)]
    Mv = [E2] + [pw[i] @ E2 + pw[i - 1] @ E1 for i in range(1, K)] + [pw[K - 1] @ E1]

    def terms(u: Array) -> tuple[list[Array], list[Array]]:
        return [M.T @ u for M in Mw], [M.T @ u for M in Mv]

    def value(u: Array) -> float:
        tw, tv = terms(u)
        return sum(float(np.linalg.norm(t)) for t in tw) * system.eta_w + sum(
            float(np.linalg.norm(t)) for t in tv) * system.eta_v

    rng = np.random.default_rng(seed)
    best_u, best = np.eye(n)[0], -1.0
    for _ in range(int(restarts)):
        u = rng.standard_normal(n)
        u /= np.linalg.norm(u)
        for _ in range(int(iterations)):
            tw, tv = terms(u)
            g = sum((M @ t / max(float(np.linalg.norm(t)), 1e-300) for M, t in zip(Mw, tw)), np.zeros(n)) * system.eta_w
            g = g + sum((M @ t / max(float(np.linalg.norm(t)), 1e-300) for M, t in zip(Mv, tv)), np.zeros(n)) * system.eta_v
            if not np.linalg.norm(g) > 0:
                break
            u = g / np.linalg.norm(g)
        val = value(u)
        if val > best:
            best, best_u = val, u
    tw, tv = terms(best_u)

    def unit(t: Array, eta: float) -> Array:
        nt = float(np.linalg.norm(t))
        return eta * t / nt if nt > 0 else np.zeros_like(t)

    w = np.empty((K, nw))
    for j in range(K):
        w[K - 1 - j] = unit(tw[j], system.eta_w)
    v = np.empty((K + 1, l))
    for i in range(K + 1):
        v[K - i] = unit(tv[i], system.eta_v)
    return w, v, best


@dataclass(frozen=True, eq=False)
class NaivePointObserver:
    """A point observer that ignores the unknown input: ``x̂⁺ = f(x̂)`` (``rhs``), ``x̂ ← x̂⁺ + L(y − Cx̂⁺)`` (``correct``).

    A baseline for Sec. 6.2's claim (an observer that treats ``d`` as absent or bounded); not the
    paper's benchmark observers [8], [10]. A discrete-time correcting observer whose state is the pair
    ``(x̂, predicted)``: the measurement at step 0 is not used (``x̂_0`` is the given estimate).
    """

    system: DiscreteUISystem
    L: Array
    name: str = "naive point observer"

    @property
    def time(self) -> Discrete:
        return self.system.time

    @property
    def n_x(self) -> int:
        return self.system.n

    def init(self, x_hat0: Array) -> tuple[Array, bool]:
        return np.array(x_hat0, dtype=float), False

    def rhs(self, t: float, z: tuple[Array, bool], u: Array, y: Array) -> tuple[Array, bool]:
        return self.system.f(z[0]), True

    def correct(self, t: float, z: tuple[Array, bool], u: Array, y: Array, fresh: NDArray[np.bool_]) -> tuple[Array, bool]:
        xp, predicted = z
        if not predicted:
            return z
        return xp + (y - xp @ self.system.C.T) @ np.asarray(self.L).T, False

    def estimate(self, z: tuple[Array, bool]) -> Array:
        return z[0]


def naive_point_observer(system: DiscreteUISystem, L: NDArray[np.float64], y: Array,
                         x0_hat: Array | None = None) -> Array:
    """Estimates ``(B, K + 1, n)`` of :class:`NaivePointObserver` on ``y`` ``(B, K + 1, l)`` (a run_observer call)."""
    B, K1, _ = y.shape
    xh = np.broadcast_to(system.x0 if x0_hat is None else x0_hat, (B, system.n)).copy()
    t = np.arange(K1) * system.time.dt
    return run_observer(NaivePointObserver(system, np.asarray(L, dtype=float)), t, x_hat0=xh, y=y,
                        divergence="keep").x_hat


# --------------------------------------------------------------------------- reproduction table


def _lst(a: ArrayLike, digits: int = 4) -> list[object]:
    arr = np.asarray(a, dtype=float)
    if arr.ndim == 2:
        return [[float(f"{x:.{digits}g}") for x in row] for row in arr]
    return [float(f"{x:.{digits}g}") for x in arr.ravel()]


def _prop516_rows(tag: str, system: DiscreteUISystem, M: Array) -> list[ReproRow]:
    """Proposition 5.16 as printed (two SDPs for its disjunction): ρ**, θ₁ at P**, and what L̃** does."""
    from nlobs.errors import DesignInfeasible
    from nlobs.synthesis.setvalued_printed import design_prop516

    try:
        d = design_prop516(system, M)
    except DesignInfeasible as exc:
        return [ReproRow(f"{tag}: ρ** (Prop. 5.16 as printed, two SDPs)", None, "infeasible",
                         f"{exc} (constraint {exc.constraint!r}, violation {exc.violation})")]
    other = {b.branch.value: b.rho for b in d.branches}
    return [
        ReproRow(f"{tag}: ρ** (Prop. 5.16 as printed, two SDPs)", None, d.rho,
                 f"the paper reports no ρ**; branch {d.branch.value} kept (A: {other['A']}, B: {other['B']}; "
                 "B is empty whenever the class contains a linear map: N ≻ 0 forces αP ≻ I)"),
        ReproRow(f"{tag}: θ₁ = |λmax(P**) − 1|/λmin(P**) (32) at Prop. 5.16's P**", None, d.theta1,
                 f"< 1 as Prop. 5.16 claims (eig(P**) in [{d.lambda_min_P:.4g}, {d.lambda_max_P:.4g}]); "
                 f"printed δx∞,1 = {d.theta1_steady:.4g}"),
        ReproRow(f"{tag}: L̃** (Prop. 5.16 as printed)", None, _lst(d.gain.ravel()),
                 f"(A.16) min eig {d.exact_min_eig:.3g} < 0, spectral radius {d.spectral_radius:.4g} > 1: "
                 "the printed bounds converge while the errors diverge"),
    ]


def reproduce() -> list[ReproRow]:
    """``nlobs reproduce khajenejad-yong``: Sec. 6's reported values beside nlobs's (printed and sound).

    Every ``nlobs`` value is recomputed here: the printed formulation by
    :func:`~nlobs.synthesis.setvalued_printed.design_printed` (Theorem 5.10 with (18)), the sound one by
    :func:`~nlobs.synthesis.setvalued.design_setvalued`. See ``docs/setvalued.md`` for the reasons.
    """
    from nlobs.errors import AssumptionViolated, DesignInfeasible
    from nlobs.linear.transform_ui import structural_check, ui_transform
    from nlobs.observers.setvalued import printed_radii
    from nlobs.synthesis.setvalued import design_setvalued
    from nlobs.synthesis.setvalued_printed import design_printed
    from nlobs.systems.discrete_ui import estimate_lipschitz

    rows: list[ReproRow] = []
    base = example_61("I").system
    A = base.A
    chk = structural_check(A, base.G, base.C, base.H)
    rows.append(ReproRow("6.1 strongly detectable (Def. 2.1, Cor. 5.8)", None, chk.exists, chk.reasons[0]))
    lip = np.block([[-np.eye(4), np.zeros((4, 4))], [np.zeros((4, 4)), (3.33 * TS) ** 2 * np.eye(4)]])
    printed_M = {"0": np.block([[np.eye(4), np.zeros((4, 4))], [np.zeros((4, 4)), (3.333 * TS) ** 2 * np.eye(4)]]),
                 "I": lip, "II": np.block([[-np.eye(4), A], [A.T, -A.T @ A]])}
    for cls in ("0", "I", "II"):
        ex = example_61(cls)
        pr = ex.printed
        P_, Y_, L_ = (np.asarray(pr[k], dtype=float) for k in ("P", "Y", "L_tilde"))
        tag = f"6.1 Class {cls}"
        rows.append(ReproRow(f"{tag}: P*⁻¹Y* (should equal L̃*)", _lst(L_), _lst(np.linalg.solve(P_, Y_)),
                             "the printed P*, Y*, L̃* are mutually inconsistent"))
        tr = ui_transform(ex.system.G, ex.system.C, ex.system.H)
        sr = float(np.max(np.abs(np.linalg.eigvals((np.eye(4) - L_[:, None] @ tr.C2) @ tr.Phi @ (A - tr.Psi)))))
        rows.append(ReproRow(f"{tag}: spectral radius of (I − L̃*C₂)(A − Ψ) with the printed L̃*", None, sr,
                             "> 1: the printed gain destabilises the error dynamics (16)"))
        try:
            dp = design_printed(ex.system, printed_M[cls])
            rows += [
                ReproRow(f"{tag}: ρ* (Thm 5.10 as printed)", pr["rho"], dp.rho,
                         f"(A.16) min eig {dp.exact_min_eig:.3g} < 0 and spectral radius {dp.spectral_radius:.4g}: "
                         "the printed LMIs accept a gain they do not certify"),
                ReproRow(f"{tag}: α* (Thm 5.10 as printed)", pr["alpha"], dp.alpha, "best α of the line search"),
                ReproRow(f"{tag}: L̃* (Thm 5.10 as printed)", _lst(L_), _lst(dp.gain.ravel()), ""),
                ReproRow(f"{tag}: P* (Thm 5.10 as printed)", _lst(P_), _lst(dp.P), ""),
                ReproRow(f"{tag}: Y* (Thm 5.10 as printed)", _lst(Y_), _lst(np.ravel(dp.Y)), "Y = P L̃"),
            ]
        except DesignInfeasible as exc:
            for q in ("ρ*", "α*", "L̃*", "P*", "Y*"):
                rows.append(ReproRow(f"{tag}: {q} (Thm 5.10 as printed)", _printed_value(pr, q), "infeasible",
                                     str(exc)))
        rows += _prop516_rows(tag, ex.system, printed_M[cls])
        try:
            ds = design_setvalued(ex.system)
            rows += [
                ReproRow(f"{tag}: sound design (radius objective), steady radius bound", None, ds.steady_radius,
                         f"λ = {ds.lam:.4g} (α = 1 − λ = {1 - ds.lam:.4g}), κ = {ds.kappa:.4g}; {ex.note}"),
                ReproRow(f"{tag}: L̃ (sound)", _lst(L_), _lst(ds.gain.ravel()),
                             "certified by (⋆) and the spectral radius"),
                ReproRow(f"{tag}: P (sound, scaled P ⪰ I)", _lst(P_), _lst(ds.P), ""),
                ReproRow(f"{tag}: Y = P L̃ (sound)", _lst(Y_), _lst((ds.P @ ds.gain).ravel()), ""),
                ReproRow(f"{tag}: α (sound: 1 − λ of (⋆))", pr["alpha"], 1.0 - ds.lam,
                         "the sound condition's decay per step; the printed α enters (26)-(28) differently"),
                ReproRow(f"{tag}: ρ (sound, ℓ2 gain)", pr["rho"], "n/a",
                         f"γ = {ex.system.function_class.gamma:.4g} < 0 leaves the constant −κγ in (V): no finite "
                         "ℓ2 gain follows (the radius bound above is the certified quantity)"
                         if ex.system.function_class.gamma < 0 else "the radius objective was used"),
            ]
            res = containment_study(ex, ds, runs=1000, steps=300, seed=0)
            rows.append(ReproRow(f"{tag}: containment state/input, 1000 runs (sound)", None,
                                 [res.rate_state, res.rate_input], "noises half at their bounds"))
        except DesignInfeasible as exc:
            rows.append(ReproRow(f"{tag}: sound design", None, "infeasible", f"{ex.note}; {exc}"))
            for q in ("ρ", "α", "L̃", "P", "Y"):
                rows.append(ReproRow(f"{tag}: {q} (sound)", _printed_value(pr, q + "*"), "infeasible",
                                     "(⋆) has no solution for any λ < 1 with this class (see 'sound design')"))
    PI = np.asarray(example_61("I").printed["P"], dtype=float)
    rows.append(ReproRow("6.1 Class I: max |P* − P*ᵀ| of the printed P*", 0.0, float(np.max(np.abs(PI - PI.T))),
                         "the printed P*_I is not symmetric (entries (1,4) −0.2268 and (4,1) −0.2208)"))
    Lf = 3.33 * TS
    aI = float(example_61("I").printed["alpha"])
    val = aI * float(np.linalg.eigvalsh(0.5 * (PI + PI.T))[0]) - (1 + Lf**2)
    rows.append(ReproRow("6.1 Class I: λ_min(α*P*) − (1 + L_f²), needed ≥ 0 by N22 ⪰ 0 of (26)-(28)", None, val,
                         "< 0: the printed (α*, P*) violate the paper's own constraint"))
    rows.append(ReproRow("6.1 Class I: lower bound √((1 + L_f²)/α*) on ρ implied by N11 ⪰ 0, N22 ⪰ 0", 0.9436,
                         float(np.sqrt((1 + Lf**2) / aI)),
                         "≥ 1 for every α ≤ 1, so the printed ρ*_I = 0.9436 is impossible under (26)-(28)"))
    exs = example_61("0-structured")
    dss = design_setvalued(exs.system)
    rows.append(ReproRow("6.1 Class 0 with nlobs's structured multiplier (not in the paper): steady radius bound",
                         None, dss.steady_radius, f"λ = {dss.lam:.4g}, κ = {dss.kappa:.4g}; {exs.note}"))
    rows.append(ReproRow("6.1 Class II γ", 0.0, example_61("II").system.function_class.gamma,
                         "Lemma 2.14 with ‖g‖ ≤ 3.33 Ts gives γ = −(2r)²; γ = 0 would make f affine"))
    ex = example_62()
    s = ex.system
    pr = ex.printed
    rows.append(ReproRow("6.2 L_f", pr["L_f"], float(np.linalg.norm(s.A, 2)), "‖A‖ of the linear part"))
    est = estimate_lipschitz(s.f, [-3, -3], [3, 3], n_pairs=20000, seed=0)
    rows.append(ReproRow("6.2 Lipschitz constant of f on [−3, 3]² (sampled estimate)", None, est.value,
                         "a lower estimate; f itself is not 1.1171-Lipschitz"))
    try:
        design_setvalued(s)
        rows.append(ReproRow("6.2 stable observer of this structure exists", True, True, ""))
    except AssumptionViolated as exc:
        rows.append(ReproRow("6.2 stable observer of this structure exists", True, False, exc.evidence))
    try:
        dp = design_printed(s, np.block([[-np.eye(2), np.zeros((2, 2))], [np.zeros((2, 2)), pr["L_f"] ** 2 * np.eye(2)]]))
        rows += [ReproRow("6.2 ρ* (Thm 5.10 as printed)", pr["rho"], dp.rho, ""),
                 ReproRow("6.2 α* (Thm 5.10 as printed)", pr["alpha"], dp.alpha, ""),
                 ReproRow("6.2 L̃* (Thm 5.10 as printed)", pr["L_tilde"], _lst(dp.gain.ravel()), ""),
                 ReproRow("6.2 P* (Thm 5.10 as printed)", pr["P"], _lst(dp.P), ""),
                 ReproRow("6.2 Y* (Thm 5.10 as printed)", pr["Y"], _lst(np.ravel(dp.Y)), "")]
    except DesignInfeasible as exc:
        for q in ("ρ*", "α*", "L̃*", "P*", "Y*"):
            rows.append(ReproRow(f"6.2 {q} (Thm 5.10 as printed)", _printed_value(pr, q), "infeasible", str(exc)))
    for q in ("ρ", "α", "L̃", "P", "Y"):
        rows.append(ReproRow(f"6.2 {q} (sound)", _printed_value(pr, q + "*"), "no stable observer",
                             "invariant zero −1.3431 of (A, G, C): every gain leaves |x̃₁,k| ≥ 1.343|x̃₁,k−1|"))
    P62, Y62, L62 = (np.asarray(pr[k], dtype=float) for k in ("P", "Y", "L_tilde"))
    L62y = np.linalg.solve(P62, Y62)
    rows.append(ReproRow("6.2 P*⁻¹Y* (should equal L̃*)", pr["L_tilde"], _lst(L62y),
                         f"differs by {float(np.max(np.abs(L62y - L62) / np.abs(L62))):.1%} (largest relative entry); "
                         f"cond(P*) = {float(np.linalg.cond(P62)):.3g}, so 4-digit rounding of P*, Y* cannot explain it"))
    tr62 = ui_transform(s.G, s.C, s.H)
    sr62 = float(np.max(np.abs(np.linalg.eigvals((np.eye(2) - L62[:, None] @ tr62.C2) @ tr62.Phi @ (s.A - tr62.Psi)))))
    rows.append(ReproRow("6.2 spectral radius of (I − L̃*C₂)Φ(A − Ψ) with the printed L̃*", None, sr62,
                         "≥ 1.343 for every gain (the invariant zero)"))
    gain = GivenGain.for_system(s, pr["L_tilde"])
    with np.errstate(over="ignore"):
        rad = printed_radii(s, pr["L_tilde"], pr["P"], pr["rho"], 50, L_f=pr["L_f"])
    res = containment_study(ex, gain, runs=1000, steps=50, seed=0, radii=rad, label="printed")
    rows.append(ReproRow("6.2 containment state/input, printed L̃* and Thm 5.13 bounds, 1000 runs", None,
                         [res.rate_state, res.rate_input], "the errors diverge for every gain (invariant zero −1.343)"))
    rows += _affine_rows()
    return rows


def _printed_value(printed: Mapping[str, object], q: str) -> Value:
    """The paper's value of ``ρ*``, ``α*``, ``L̃*``, ``P*`` or ``Y*`` from a ``printed`` mapping."""
    key = {"ρ*": "rho", "α*": "alpha", "L̃*": "L_tilde", "P*": "P", "Y*": "Y"}[q]
    v = printed.get(key)
    return v if isinstance(v, (float, int, list)) else None


def _affine_rows() -> list[ReproRow]:
    """Prop. 2.18 / LP (3): the printed η (which omits σ) against nlobs's certified η and sampled residuals."""
    from nlobs.synthesis.affine_abstraction import affine_abstraction

    def mu(z: Array) -> Array:
        return np.stack([np.sin(z[..., 0]), z[..., 0] * z[..., 1]], axis=-1)

    r = affine_abstraction(mu, [-1, -1], [1, 1], gradient_lipschitz=[np.sin(1.0), 1.0], points_per_axis=2)
    z = np.random.default_rng(1).uniform(-1, 1, (100_000, 2))
    resid = np.max(np.abs(mu(z) - r(z)), axis=0)
    bad = [i + 1 for i in range(2) if resid[i] > r.eta_as_printed[i] + 1e-12]
    note = (f"max sampled residual {_lst(resid)} on 1e5 points: the printed η (θ*/2, σ omitted) is exceeded in "
            f"component(s) {bad}; the certified η = θ*/2 + σ holds")
    return [
        ReproRow("Prop. 2.18 η_vᵃ of μ = [sin z₁, z₁z₂] on [−1, 1]², corners only: as printed (θ*/2)", None,
                 _lst(r.eta_as_printed), note),
        ReproRow("Prop. 2.18 η_vᵃ, same LP: certified by nlobs (θ*/2 + σ)", None, _lst(r.residual_bound),
                 "σ_i = λ_i‖h‖²/8 from the gradient-Lipschitz constants (docs/affine_abstraction.md)"),
        ReproRow("Prop. 2.18 η_vᵃ, same μ: certified on a 21-point grid", None,
                 _lst(affine_abstraction(mu, [-1, -1], [1, 1], gradient_lipschitz=[np.sin(1.0), 1.0],
                                         points_per_axis=21).residual_bound), "refining the mesh shrinks σ like h²"),
    ]

