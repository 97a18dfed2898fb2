r"""A piecewise-constant translational gain ``K(t)`` for the GNSS/INS observer (24) of Grip, Saberi & Johansen.

The noise-optimal gain of :func:`~nlobs.navigation.gains.noise_optimal_gains` is the best *constant*
``K`` for the sensors in steady state. At the start of a flight it is slow: the observer starts at
the first GNSS fix, whose error (``σ_p`` per axis) its position gain ``K_pp ≈ √(V_v / V_p)``
(0.067 s⁻¹ for the demo's receiver) removes with a time constant of about 15 s, while an EKF started
from the same fix averages the fixes as they come (its gain falls like ``1/t``). Measured on the
demo's 300 s flight, ten seeds, the first 30 s carried most of the observer's position error.

:func:`kalman_scheduled_gain` gives ``K`` the shape of the Kalman–Bucy gain of the per-axis linear
model (Σ2 of (21), states ``p, v, z``, the white-noise model of
:func:`~nlobs.navigation.gains.axis_noise_model`) started from the initial uncertainty
``P(0) = diag(σ_p², σ_v², σ_z²)``:

    Ṗ = 𝔄 P + P 𝔄ᵀ + B_w W B_wᵀ − P ℭᵀ V⁻¹ ℭ P,    K_kb(t) = P(t) ℭᵀ V⁻¹,

made piecewise constant: level ``k`` holds ``K_kb(τ_k)`` from ``τ_k`` until ``K_pp`` has fallen by
``factor`` (a level is taken only where ``𝔄 − K ℭ`` is Hurwitz with ``‖H‖∞ < γ``, the necessary
part of LMI (14): at ``t = 0`` the gain of ``z`` is still zero); once it is within ``√factor`` of the final gain's ``K_pp``, the final gain (the
noise-optimal one) holds for good. ``P(t)`` is propagated exactly on a fixed grid by the
Hamiltonian transition (Radon's lemma): ``[X; Y](t + h) = expm(H h) [X; Y](t)``,
``H = [[𝔄, B_w W B_wᵀ], [ℭᵀ V⁻¹ ℭ, −𝔄ᵀ]]``, ``P = X Y⁻¹`` (no ODE solver, no clock).

Why the guarantee survives the switching
----------------------------------------
Every mode is observer (24) with a constant gain ``K_k`` that satisfies LMI (14) at ``γ`` with its
own Lyapunov matrix ``P_k`` (re-verified without the solver, :func:`certify_gain_schedule`), so
Theorem 1 holds in each mode with ``W_k = γ_s V + w̃ᵀ P_k w̃`` (``V`` the attitude function of
Lemma 1, the same in every mode). The ``P_k`` differ (measured: no common ``P`` satisfies LMI (14)
for all the demo's levels), so the argument is the finite-switching one: in mode ``k`` ``W_k`` does
not grow; at the switch ``k → k+1`` ``W_{k+1} ≤ max(1, μ_k) W_k`` with
``μ_k = λmax(P_k⁻¹ P_{k+1})``; after the last switch the final gain's certificate holds. The
error therefore converges exponentially as with the final gain alone, with its ``W`` at the last
switch at most ``∏ max(1, μ_k)`` (the certificate's ``growth``) times its value at the start.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_matrix, positive, readonly
from nlobs.checks import Check, CheckKind
from nlobs.errors import InvalidArgumentError, NonFiniteError
from nlobs.linear.norms import hinf_norm
from nlobs.navigation.gains import PAPER_GAMMA_HINF, axis_noise_model, axis_system, kron_gain
from nlobs.navigation.sensors import SensorNoise
from nlobs.synthesis.certificate import CertificateMixin, ObserverGainCertificate, checks_dict
from nlobs.synthesis.lmi import Solver
from nlobs.synthesis.observer_gain import verify_observer_gain

__all__ = ["GainScheduleCertificate", "TranslationGainSchedule", "certify_gain_schedule",
           "kalman_bucy_covariance", "kalman_scheduled_gain", "switch_times"]

#: Step [s] of the exact covariance propagation of :func:`kalman_bucy_covariance`.
RICCATI_STEP_S = 0.01
#: Longest time [s] the Kalman–Bucy levels are followed; the final gain holds from there at the latest.
HORIZON_S = 600.0
#: Switch times are compared with the loop's time stamps to this many seconds (as the attitude schedule).
_TIME_TOL_S = 1e-9


def switch_times(times: Any, modes: int) -> tuple[float, ...]:
    """The ``modes − 1`` switch times of a piecewise-constant schedule, checked: finite, strictly increasing.

    Parameters
    ----------
    times : sequence of float
        The switch times [s].
    modes : int
        The number of modes (gains).

    Returns
    -------
    tuple of float

    Raises
    ------
    InvalidArgumentError
        Not ``modes − 1`` times, or not strictly increasing.
    NonFiniteError
        A time that is not finite.
    """
    out = tuple(float(t) for t in times)
    if len(out) != modes - 1:
        raise InvalidArgumentError(f"times: {modes} gains need {modes - 1} switch times, got {len(out)}")
    for k, t in enumerate(out):
        if not math.isfinite(t):
            raise NonFiniteError(f"times[{k}]: must be finite, got {t!r}")
        if k and t <= out[k - 1]:
            raise InvalidArgumentError(
                f"times: switch times must increase strictly (times[{k}] = {t:g} s after {out[k - 1]:g} s)")
    return out


@dataclass(frozen=True)
class TranslationGainSchedule:
    """A piecewise-constant per-axis gain: ``K3(t) = gains[k]`` for ``times[k-1] ≤ t < times[k]``.

    The 9-state gain of (24a)–(24c) in mode ``k`` is ``kron(gains[k], I3)``
    (:func:`~nlobs.navigation.gains.kron_gain`).

    Parameters
    ----------
    gains : sequence of array_like, each (3, p)
        ``K3`` of each mode (rows ``p, v, z``; ``p`` = 2 outputs, or 1 for a position-only receiver).
    times : sequence of float
        The ``N − 1`` switch times on the run's clock [s], strictly increasing.

    Raises
    ------
    InvalidArgumentError
        No gain, gains of different shapes, ``len(times) != len(gains) − 1``, times not increasing.
    NonFiniteError
        A non-finite gain entry or switch time.
    DimensionError
        A gain that is not 3×1 or 3×2.
    """

    gains: tuple[Array, ...]
    times: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        raw = tuple(self.gains)
        if not raw:
            raise InvalidArgumentError("gains: a schedule needs at least one gain")
        first = np.asarray(raw[0], dtype=float)
        p = first.shape[1] if first.ndim == 2 else 0
        if p not in (1, 2):
            raise InvalidArgumentError(f"gains[0]: expected a 3×2 or 3×1 per-axis gain, got shape {first.shape}")
        gains = tuple(readonly(as_matrix(f"gains[{k}]", G, (3, p))) for k, G in enumerate(raw))
        object.__setattr__(self, "gains", gains)
        object.__setattr__(self, "times", switch_times(self.times, len(gains)))

    @classmethod
    def constant(cls, gain: ArrayLike) -> TranslationGainSchedule:
        """One mode: ``K3(t) = gain`` at all times."""
        return cls((np.asarray(gain, dtype=float),))

    @property
    def final(self) -> Array:
        """The gain of the last mode (the one that holds for good)."""
        return self.gains[-1]

    def index(self, t: float) -> int:
        """The mode in force at ``t``: the number of switch times ``≤ t`` (to 1 ns)."""
        return bisect_right(self.times, float(t) + _TIME_TOL_S)

    def gain_at(self, t: float) -> Array:
        """The 9-state gain ``kron(K3(t), I3)`` in force at ``t``."""
        return kron_gain(self.gains[self.index(t)])

    def describe(self) -> str:
        """A one-line account, e.g. ``"K_pp = 5 s⁻¹; 2.5 from 0.3 s; …; 0.0665 from 15.5 s"``."""
        parts = [f"K_pp = {self.gains[0][0, 0]:.3g} s⁻¹"]
        parts += [f"{G[0, 0]:.3g} from {t:.3g} s" for G, t in zip(self.gains[1:], self.times)]
        return "; ".join(parts)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready form: ``{"gains_per_axis": [[3×p], ...], "times_s": [...]}``."""
        return {"gains_per_axis": [np.asarray(G).tolist() for G in self.gains], "times_s": list(self.times)}


@dataclass(frozen=True)
class GainScheduleCertificate(CertificateMixin):
    """Every mode of a :class:`TranslationGainSchedule` certified against LMI (14), and the switching growth.

    Attributes
    ----------
    gain : ndarray, shape (3, p)
        The final per-axis gain.
    P : ndarray, shape (3, 3) or None
        The final mode's Lyapunov matrix.
    modes : tuple of ObserverGainCertificate
        One per mode (:func:`~nlobs.synthesis.observer_gain.verify_observer_gain` at ``γ``).
    growth : float
        ``∏ max(1, λmax(P_k⁻¹ P_{k+1}))``: the most the final mode's ``W`` can exceed the first
        mode's over all the switches (module docstring); ``inf`` when a mode has no ``P``.
    gamma : float
        ``γ`` of LMI (14).
    checks : tuple of Check
        One per mode (its certificate's verdict) and one for the growth factor.
    solver : Solver or None
        The solver of the modes' analytic centres.
    """

    gain: Array
    P: Array | None
    modes: tuple[ObserverGainCertificate, ...]
    growth: float
    gamma: float
    checks: tuple[Check, ...]
    solver: Solver | None = None

    def summary(self) -> str:
        """The verdict, the growth factor and each mode's LMI (14) margin."""
        head = (f"translational gain schedule, {len(self.modes)} modes, LMI (14) at γ = {self.gamma:g}: "
                + ("verified" if self.verified else "NOT verified") + f"; switching growth of W ≤ {self.growth:.4g}")
        return "\n".join([head] + [f"  {c.summary()}" for c in self.checks])

    def to_dict(self) -> dict[str, Any]:
        """``{"verified", "gamma", "growth", "modes": [{"gain", "hinf_H", "verified"}], "checks"}``."""
        return {"verified": self.verified, "gamma": self.gamma,
                "growth": self.growth if math.isfinite(self.growth) else None,
                "modes": [{"gain": np.asarray(m.gain).tolist(), "hinf_H": m.hinf_H, "verified": m.verified}
                          for m in self.modes],
                "checks": checks_dict(self.checks)}


def certify_gain_schedule(schedule: TranslationGainSchedule, *, gamma: float = PAPER_GAMMA_HINF,
                          solver: Solver | str = Solver.CLARABEL) -> GainScheduleCertificate:
    """Certify every mode of ``schedule`` against LMI (14) at ``γ`` and bound the switching growth.

    Each mode's gain is certified by :func:`~nlobs.synthesis.observer_gain.verify_observer_gain`
    on the per-axis system of :func:`~nlobs.navigation.gains.axis_system` (the 9-state
    ``kron(K3, I3)`` has the same transfer functions); the growth factor is computed from the
    modes' re-verified ``P_k`` (module docstring).

    Parameters
    ----------
    schedule : TranslationGainSchedule
        The gains.
    gamma : float
        ``γ`` of LMI (14) (the paper's 50).
    solver : Solver or str
        For the analytic centres.

    Returns
    -------
    GainScheduleCertificate
        Verified when every mode is and the growth is finite.

    Raises
    ------
    InvalidArgumentError
        ``schedule`` is not a :class:`TranslationGainSchedule`, or ``gamma`` is not positive.
    """
    if not isinstance(schedule, TranslationGainSchedule):
        raise InvalidArgumentError(f"schedule: expected a TranslationGainSchedule, got {type(schedule).__name__}")
    g = positive("gamma", gamma)
    A, Bd, C = axis_system(schedule.final.shape[1] == 1)
    modes = tuple(verify_observer_gain(A, C, Bd, K, gamma=g, solver=solver, strict=False) for K in schedule.gains)
    checks = [Check.verdict(f"mode {k}: LMI (14) at γ = {g:g} (K_pp = {m.gain[0, 0]:.4g})", m.verified,
                            "verified" if m.verified else "; ".join(c.summary() for c in m.failed_checks),
                            kind=CheckKind.LMI) for k, m in enumerate(modes)]
    growth = 1.0
    for k in range(len(modes) - 1):
        P0, P1 = modes[k].P, modes[k + 1].P
        if P0 is None or P1 is None:
            growth = math.inf
            break
        mu = float(scipy.linalg.eigh(P1, P0, eigvals_only=True)[-1])
        growth *= max(1.0, mu)
    name = "switching growth of W (∏ max(1, λmax(P_k⁻¹ P_{k+1})))"
    if math.isfinite(growth):
        checks.append(Check.compare(name, growth, math.inf, kind=CheckKind.GAIN))
    else:
        checks.append(Check.verdict(name, False, "a mode has no Lyapunov matrix P", kind=CheckKind.GAIN))
    last = modes[-1]
    return GainScheduleCertificate(gain=last.gain, P=last.P, modes=modes, growth=growth, gamma=g,
                                   checks=tuple(checks), solver=last.solver)


def kalman_bucy_covariance(A: ArrayLike, Q: ArrayLike, S: ArrayLike, P0: ArrayLike, *, step: float,
                           n_steps: int) -> Array:
    r"""``P(k·step)``, ``k = 0 … n_steps``, of ``Ṗ = A P + P Aᵀ + Q − P S P`` (exact, Radon's lemma).

    ``[X; Y]`` with ``d/dt [X; Y] = [[A, Q], [S, −Aᵀ]] [X; Y]``, ``X(0) = P0``, ``Y(0) = I`` gives
    ``P = X Y⁻¹``; each step re-normalises (``X ← P``, ``Y ← I``) so nothing overflows.

    Parameters
    ----------
    A, Q, S : array_like, shape (n, n)
        Drift, process intensity ``B_w W B_wᵀ`` and ``ℭᵀ V⁻¹ ℭ``.
    P0 : array_like, shape (n, n)
        Initial covariance (symmetric positive semi-definite).
    step : float
        Grid step [s].
    n_steps : int
        Number of steps.

    Returns
    -------
    ndarray, shape (n_steps + 1, n, n)

    Raises
    ------
    InvalidArgumentError
        A non-positive step or a negative number of steps.
    NonFiniteError
        The propagation left the finite numbers.
    """
    A_ = np.asarray(A, dtype=float)
    n = A_.shape[0]
    h = positive("step", step)
    if int(n_steps) < 0:
        raise InvalidArgumentError(f"n_steps: must be non-negative, got {n_steps}")
    H = np.block([[A_, as_matrix("Q", Q, (n, n))], [as_matrix("S", S, (n, n)), -A_.T]])
    Phi = scipy.linalg.expm(H * h)
    out = np.empty((int(n_steps) + 1, n, n))
    P = as_matrix("P0", P0, (n, n))
    out[0] = P
    eye = np.eye(n)
    for k in range(1, int(n_steps) + 1):
        X = Phi[:n, :n] @ P + Phi[:n, n:]
        Y = Phi[n:, :n] @ P + Phi[n:, n:] @ eye
        P = np.linalg.solve(Y.T, X.T).T
        P = 0.5 * (P + P.T)
        out[k] = P
    if not np.all(np.isfinite(out)):
        raise NonFiniteError("kalman_bucy_covariance: the covariance left the finite numbers")
    return out


def kalman_scheduled_gain(noise: SensorNoise, final: ArrayLike, *, imu_rate_hz: float, gnss_rate_hz: float,
                          position_only: bool = False, z0_std: float = 1.0, factor: float = 2.0,
                          gamma: float = PAPER_GAMMA_HINF, start_s: float = 0.0) -> TranslationGainSchedule:
    """The translational gain schedule of the noise-optimal GNSS/INS observer (module docstring).

    Parameters
    ----------
    noise : SensorNoise
        The sensors: ``gnss_p_std``, ``gnss_v_std`` set ``P(0)`` (the observer starts at the first
        fix) and, with ``accel_std``, the noise model of :func:`~nlobs.navigation.gains.axis_noise_model`.
    final : array_like, shape (3, p)
        The per-axis gain that holds for good (the noise-optimal ``K3``).
    imu_rate_hz, gnss_rate_hz : float
        Sample rates [Hz].
    position_only : bool
        ``ℭ = [1, 0, 0]``.
    z0_std : float
        Initial standard deviation of ``z`` [m/s²] (default 1; measured on the demo, 0.3 and 3 give
        the same RMS ratios to 0.02).
    factor : float
        Ratio of consecutive levels of ``K_pp`` (> 1).
    gamma : float
        ``γ`` of LMI (14): a level is taken only where ``‖H‖∞ < γ`` (certify the result with
        :func:`certify_gain_schedule`).
    start_s : float
        The run's first time stamp (the schedule's clock starts there).

    Returns
    -------
    TranslationGainSchedule
        The Kalman–Bucy levels, then ``final``; ``final`` alone when the first level is not faster.

    Raises
    ------
    InvalidArgumentError
        ``noise`` is not a :class:`SensorNoise`, ``final`` has the wrong shape, a non-positive
        rate, ``z0_std``, ``gamma`` or ``factor ≤ 1``.
    NonFiniteError
        A non-finite ``start_s``.
    """
    if not isinstance(noise, SensorNoise):
        raise InvalidArgumentError(f"noise: expected a SensorNoise, got {type(noise).__name__}")
    p = 1 if position_only else 2
    K_end = as_matrix("final", final, (3, p))
    f = positive("factor", factor)
    g = positive("gamma", gamma)
    if f <= 1.0:
        raise InvalidArgumentError(f"factor: must exceed 1, got {f:g}")
    ts = float(start_s)
    if not math.isfinite(ts):
        raise NonFiniteError(f"start_s: must be finite, got {start_s!r}")
    model = axis_noise_model(noise, imu_rate_hz=imu_rate_hz, gnss_rate_hz=gnss_rate_hz, position_only=position_only)
    A, Bd, C = (np.asarray(x, dtype=float) for x in axis_system(position_only))

    def admissible(K: Array) -> bool:
        Acl = A - K @ C
        if float(np.max(np.linalg.eigvals(Acl).real)) >= 0.0:
            return False
        return hinf_norm(Acl, Bd, np.eye(3), np.zeros((3, Bd.shape[1]))) < g

    Vi = np.linalg.inv(model.measurement)
    Bw = np.asarray(model.process_input, dtype=float)
    Q = Bw @ np.asarray(model.process, dtype=float) @ Bw.T
    floor = 1e-4
    P0 = np.diag([max(floor, noise.gnss_p_std) ** 2, max(floor, noise.gnss_v_std) ** 2,
                  positive("z0_std", z0_std) ** 2])
    n_steps = int(round(HORIZON_S / RICCATI_STEP_S))
    Ps = kalman_bucy_covariance(A, Q, C.T @ Vi @ C, P0, step=RICCATI_STEP_S, n_steps=n_steps)
    Ks = Ps @ (C.T @ Vi)
    k_end = float(K_end[0, 0])
    gains: list[Array] = []
    times: list[float] = []
    ref = math.inf
    for k, K in enumerate(Ks):
        kpp = float(K[0, 0])
        if kpp <= math.sqrt(f) * k_end:
            if gains:
                times.append(ts + k * RICCATI_STEP_S)
            break
        if kpp <= ref / f and admissible(K):
            if gains:
                times.append(ts + k * RICCATI_STEP_S)
            gains.append(K)
            ref = kpp
    else:
        if gains:
            times.append(ts + n_steps * RICCATI_STEP_S)
    gains.append(K_end)
    return TranslationGainSchedule(tuple(gains), tuple(times))
