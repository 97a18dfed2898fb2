r"""A piecewise-constant attitude gain ``Γ(t)`` for the GNSS/INS observer (24) of Grip, Saberi & Johansen.

The attitude gain ``Γ`` of (22)/(24c, d) trades two things against each other: a large ``Γ``
converges fast from a large attitude error, a small one filters the magnetometer and accelerometer
noise better in steady state (``docs/noise_optimal.md`` measures both). An EKF resolves the trade
by its covariance: its gain is large while the covariance is large and shrinks as the filter
converges. :class:`ScheduledGnssInsObserver` does the same with a schedule known in advance::

    Γ(t) = Γ_k   for   τ_k ≤ t < τ_{k+1},   k = 0 … N−1,   τ_0 = −∞,  τ_N = +∞,

on the run's clock (the time stamps of the data); ``K`` and everything else stay as they are.

Why the guarantees of (24) survive the switching
------------------------------------------------
Every mode is observer (24) with a constant symmetric positive-definite ``Γ_k``, and the proofs of
Lemma 1 and Theorem 1 use one Lyapunov function for all of them:

* **Lemma 1.** ``V(R̃) = ½‖R̃‖²`` does not involve ``Γ``, and along (23) in mode ``k``
  ``V̇ ≤ −λmin(Γ_k) c² ‖R̃‖²``. So Assumption 1 holds for the switched attitude error
  ``dR̃/dt = R̃ S(ω^b) − Γ(t) J`` with the *same* ``V``, ``α₁ = α₂ = ½``, ``α₄ = 1`` and
  ``α₃ = c² min_k λmin(Γ_k)`` (the paper's standing assumption allows a right-hand side that is
  piecewise continuous in ``t``).
* **Assumption 2** holds with ``L₁`` of the largest gain: ``‖g(u, x̂, z) − g(u, x̂, ẑ)‖ ≤
  max_k λmax(Γ_k) · ‖[0, mⁿ × z̃, mⁿ × (mⁿ × z̃)] A_bᵀ‖`` (proof of Lemma 2). **Assumption 3** and
  LMI (14) do not involve ``Γ`` (``K`` and ``P`` are the same in every mode).
* **Theorem 1.** ``W = γ V + w̃ᵀ P w̃`` is then a common Lyapunov function of every mode, and the
  proof's bound ``Ẇ ≤ −γα₃‖x̃‖² + γα₄L₁‖x̃‖‖w̃‖ − ‖w̃‖² + γ²L₂²‖x̃‖²`` holds at every ``t`` with
  those worst-case constants. The error is globally exponentially stable under
  ``γ < 4α₃ / (4L₂² + α₄²L₁²)`` with them, for *any* switching signal: no dwell time is needed,
  because ``W`` is common.

So a schedule keeps exactly the claim that nlobs (and the paper) make for a constant ``Γ``: ``K``
satisfies LMI (14) at ``γ`` and every ``Γ_k`` is symmetric positive definite. What it changes is
the constant of Theorem 1 a user would compute: ``α₃`` from the *smallest* mode, ``L₁`` from the
*largest*. (With finitely many switches there is a second, cruder argument: after the last switch
the observer *is* (24) with ``Γ_{N−1}``, and before it the error grows at most exponentially over a
finite time; so the guarantee of the last mode alone suffices for convergence, with a transient
constant that grows with ``τ_{N−1}``.)
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray
from nlobs._validate import as_symmetric, as_vector, positive, readonly
from nlobs.errors import InvalidArgumentError, NonFiniteError
from nlobs.navigation.gnss_ins import GnssInsObserver, GnssInsState
from nlobs.navigation.gains import kron_gain
from nlobs.navigation.sensors import SensorNoise
from nlobs.navigation.translation_schedule import TranslationGainSchedule, switch_times
from nlobs.systems.timebase import CONTINUOUS, TimeBase
from nlobs.observers.base import ToControl

__all__ = ["AttitudeGainSchedule", "ScheduledGnssInsObserver", "heading_rate_per_gain", "noise_scheduled_gain",
           "steady_attitude_gain"]

#: Scale ``t₁`` of the ``1/t`` decay of :func:`noise_scheduled_gain` [s]: ``Γ(t) = Γ₀ t₁ / t`` after ``t₁``.
#: Chosen by measurement (``docs/noise_optimal.md``): on the demo's flight and sensors, six seeds,
#: the mean attitude RMS after convergence is 0.443°, 0.299°, 0.292°, 0.295°, 0.301° for
#: ``t₁`` = 1, 2, 3, 4, 5 s (constant ``0.5 I``: 0.504°; the EKF: 0.208°).
DECAY_SCALE_S = 3.0

#: Switch times are compared with the loop's time stamps to this many seconds (the IMU grid is
#: built as ``k / rate``, so ``t = 10 s`` may arrive as ``9.999999999998``).
_TIME_TOL_S = 1e-9


@dataclass(frozen=True)
class AttitudeGainSchedule:
    """A piecewise-constant attitude gain: ``Γ(t) = gains[k]`` for ``times[k-1] ≤ t < times[k]``.

    Parameters
    ----------
    gains : sequence of array_like, each (3, 3), or of positive floats
        ``Γ_0, …, Γ_{N−1}``, each symmetric positive definite; a number ``γ`` means ``γ I``.
    times : sequence of float
        The ``N − 1`` switch times ``τ_1 < … < τ_{N−1}`` in seconds, on the run's clock.

    Raises
    ------
    InvalidArgumentError
        No gain, a gain that is not positive definite, ``len(times) != len(gains) − 1``, switch
        times not strictly increasing.
    NonFiniteError
        A non-finite gain entry or switch time.
    DimensionError, NotSymmetricError
        A gain of the wrong shape or not symmetric.

    Examples
    --------
    The paper's ``Γ = diag(20, 0.2, 0.2)`` for the first 5 s, then ``0.5 I``, then ``0.05 I`` from 10 s. A
    switch time reached to within 1 ns counts as reached (the IMU grid's ``k / rate`` rounding); the
    constants of Lemma 1 and Assumption 2 come from the smallest and the largest mode:

    >>> import numpy as np
    >>> schedule = AttitudeGainSchedule((np.diag([20.0, 0.2, 0.2]), 0.5, 0.05), (5.0, 10.0))
    >>> schedule.describe()
    'Γ = diag(20, 0.2, 0.2); 0.5 I from 5 s; 0.05 I from 10 s'
    >>> [schedule.index(t) for t in (0.0, 4.999, 5.0, 9.9999999999, 60.0)]
    [0, 0, 1, 2, 2]
    >>> np.diag(schedule.gain_at(7.0)).tolist(), schedule.smallest_eigenvalue, schedule.largest_eigenvalue
    ([0.5, 0.5, 0.5], 0.05, 20.0)
    >>> AttitudeGainSchedule.constant(0.5).to_dict()["times_s"]
    []
    >>> try:
    ...     AttitudeGainSchedule((0.5, -0.1), (5.0,))
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError gains[1]: must be positive definite (smallest eigenvalue -0.1)
    """

    gains: tuple[Array, ...]
    times: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        raw = tuple(self.gains)
        if not raw:
            raise InvalidArgumentError("gains: a schedule needs at least one attitude gain")
        gains = []
        for k, G in enumerate(raw):
            if np.ndim(G) == 0:
                g = float(G)
                if not math.isfinite(g):
                    raise NonFiniteError(f"gains[{k}]: must be finite, got {g!r}")
                G = g * np.eye(3)
            M = as_symmetric(f"gains[{k}]", G, 3)
            lam = float(np.linalg.eigvalsh(M)[0])
            if lam <= 0.0:
                raise InvalidArgumentError(f"gains[{k}]: must be positive definite (smallest eigenvalue {lam:.3g})")
            gains.append(readonly(M))
        object.__setattr__(self, "gains", tuple(gains))
        object.__setattr__(self, "times", switch_times(self.times, len(gains)))

    @classmethod
    def constant(cls, gain: ArrayLike | float) -> AttitudeGainSchedule:
        """One mode: ``Γ(t) = gain`` at all times."""
        return cls((gain,))  # type: ignore[arg-type]

    def index(self, t: float) -> int:
        """The mode in force at ``t``: the number of switch times ``≤ t`` (to 1 ns)."""
        return bisect_right(self.times, float(t) + _TIME_TOL_S)

    def gain_at(self, t: float) -> Array:
        """``Γ(t)``, read-only (3, 3)."""
        return self.gains[self.index(t)]

    @property
    def smallest_eigenvalue(self) -> float:
        """``min_k λmin(Γ_k)``: the ``α₃ / c²`` of Lemma 1 for the switched error (module docstring)."""
        return min(float(np.linalg.eigvalsh(G)[0]) for G in self.gains)

    @property
    def largest_eigenvalue(self) -> float:
        """``max_k λmax(Γ_k)``: the factor of ``L₁`` in Assumption 2 for the switched error."""
        return max(float(np.linalg.eigvalsh(G)[-1]) for G in self.gains)

    def describe(self) -> str:
        """A one-line account, e.g. ``"Γ = 0.5 I; 0.05 I from 10 s"``."""
        parts = []
        for k, G in enumerate(self.gains):
            d = np.diag(G)
            iso = np.allclose(G, d[0] * np.eye(3), rtol=0, atol=1e-15 * abs(d[0]))
            g = f"{d[0]:g} I" if iso else ("diag(" + ", ".join(f"{x:g}" for x in d) + ")"
                                           if np.count_nonzero(G - np.diag(d)) == 0 else "a full 3×3 matrix")
            parts.append(f"Γ = {g}" if k == 0 else f"{g} from {self.times[k - 1]:g} s")
        return "; ".join(parts)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready form: ``{"gains": [[3×3], ...], "times_s": [...]}``."""
        return {"gains": [np.asarray(G).tolist() for G in self.gains], "times_s": list(self.times)}


@dataclass(frozen=True)
class ScheduledGnssInsObserver(ToControl):
    """Observer (24) with the attitude gain ``Γ(t)`` of an :class:`AttitudeGainSchedule` (module docstring).

    A correcting observer on the protocol of :mod:`nlobs.observers.base`, with the state of
    :class:`~nlobs.navigation.gnss_ins.GnssInsObserver`. Every mode is ``base`` with its ``Γ``
    replaced (the kernels, the integrator and the measurement handling are the base's). Over one
    step ``[t, t + h]`` the mode in force at ``t`` is used: a switch time between two IMU instants
    takes effect at the next one.

    Parameters
    ----------
    base : GnssInsObserver
        ``K``, ``mⁿ``, ``gⁿ`` and the options; its own ``Gamma`` is ignored (and its ``K`` too when
        ``gain_schedule`` is given).
    schedule : AttitudeGainSchedule
        ``Γ(t)``.
    name : str
        Label of the results (default ``"observer"``).
    gain_schedule : TranslationGainSchedule or None
        ``K(t)`` of (24a)–(24c) (:mod:`nlobs.navigation.translation_schedule`); ``None``: ``base.K``
        throughout. The modes are then the intervals between the switch times of both schedules.

    Raises
    ------
    InvalidArgumentError
        ``base`` is not a :class:`~nlobs.navigation.gnss_ins.GnssInsObserver` or ``schedule`` not
        an :class:`AttitudeGainSchedule`, ``gain_schedule`` not a
        :class:`~nlobs.navigation.translation_schedule.TranslationGainSchedule`, or its gains do not
        fit the receiver.

    Examples
    --------
    The take-off of the traffic pattern of Grip, Saberi & Johansen (Sec. 5.2) with exact sensors (IMU at
    100 Hz, GNSS at 5 Hz), the estimate started 30° off in yaw and 3.7 m off in position. With the paper's
    ``Γ`` switched to ``0.5 I`` at 5 s the attitude error ends smaller than with the paper's ``Γ`` throughout:

    >>> import math
    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.navigation import metrics, nav_vector, traffic_pattern
    >>> from nlobs.navigation.so3 import rot_z
    >>> traj = traffic_pattern(duration=10.0).sample(100.0)  # the first 10 s of the flight of Sec. 5.2, 100 Hz
    >>> u = np.hstack([traj.omega_b, traj.a_b, traj.m_b])  # exact IMU samples [ω^b, a^b, m^b]
    >>> fixes = slice(None, None, 20)  # exact GNSS fixes [p, v] at 5 Hz
    >>> y, truth = np.hstack([traj.p, traj.v])[fixes], nav_vector(traj.p, traj.v, traj.R)
    >>> x_hat0 = nav_vector(traj.p[0] + [3.0, -2.0, 1.0], traj.v[0], rot_z(math.radians(30.0)) @ traj.R[0])
    >>> from nlobs.navigation import AttitudeGainSchedule
    >>> base = nlobs.GnssInsObserver.paper(traj.m_n, traj.g_n)
    >>> schedule = AttitudeGainSchedule((base.Gamma, 0.5), (5.0,))
    >>> schedule.describe()
    'Γ = diag(20, 0.2, 0.2); 0.5 I from 5 s'
    >>> def final_attitude_error(observer):
    ...     res = nlobs.run_observer(observer, traj.t, x_hat0=x_hat0, u=u, y=y, y_times=traj.t[fixes], truth=truth)
    ...     return float(metrics.attitude_error_deg(res)[-1])
    >>> scheduled = nlobs.ScheduledGnssInsObserver(base, schedule)
    >>> round(final_attitude_error(base), 2), round(final_attitude_error(scheduled), 2)  # degrees
    (0.67, 0.16)
    """

    base: GnssInsObserver
    schedule: AttitudeGainSchedule
    name: str = "observer"
    gain_schedule: TranslationGainSchedule | None = None
    time: TimeBase = field(default=CONTINUOUS, init=False)
    modes: tuple[GnssInsObserver, ...] = field(init=False, repr=False, compare=False)
    switch_times: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.base, GnssInsObserver):
            raise InvalidArgumentError(f"base: expected a GnssInsObserver, got {type(self.base).__name__}")
        if not isinstance(self.schedule, AttitudeGainSchedule):
            raise InvalidArgumentError(
                f"schedule: expected an AttitudeGainSchedule, got {type(self.schedule).__name__}")
        ks = self.gain_schedule
        if ks is None:
            object.__setattr__(self, "modes", tuple(replace(self.base, Gamma=G, name=self.name)
                                                    for G in self.schedule.gains))
            object.__setattr__(self, "switch_times", self.schedule.times)
            return
        if not isinstance(ks, TranslationGainSchedule):
            raise InvalidArgumentError(
                f"gain_schedule: expected a TranslationGainSchedule, got {type(ks).__name__}")
        if ks.final.shape[1] != (1 if self.base.position_only else 2):
            raise InvalidArgumentError(
                f"gain_schedule: per-axis gains of shape {ks.final.shape} do not fit a "
                f"{'position-only' if self.base.position_only else 'position and velocity'} receiver")
        times = tuple(sorted(set(self.schedule.times) | set(ks.times)))
        starts = (-math.inf,) + times
        gains = tuple(kron_gain(K) for K in ks.gains)
        object.__setattr__(self, "modes", tuple(
            replace(self.base, K=gains[ks.index(t)], Gamma=self.schedule.gains[self.schedule.index(t)], name=self.name)
            for t in starts))
        object.__setattr__(self, "switch_times", times)

    # ---------------------------------------------------------------- protocol
    @property
    def n_x(self) -> int:
        """15, as :class:`~nlobs.navigation.gnss_ins.GnssInsObserver`."""
        return 15

    @property
    def K(self) -> Array:
        """The gain of (24a)–(24c) that holds for good (the last mode's; ``base.K`` without a gain schedule)."""
        return self.modes[-1].K

    @property
    def position_only(self) -> bool:
        """Whether the observer uses position fixes only."""
        return self.base.position_only

    def mode(self, t: float) -> GnssInsObserver:
        """The constant-gain observer in force at ``t`` (the number of switch times ``≤ t``, to 1 ns)."""
        return self.modes[bisect_right(self.switch_times, float(t) + _TIME_TOL_S)]

    def init(self, x_hat0: ArrayLike) -> GnssInsState:
        """See :meth:`GnssInsObserver.init <nlobs.navigation.gnss_ins.GnssInsObserver.init>`."""
        return self.modes[0].init(x_hat0)

    def init_state(self, p0: ArrayLike, v0: ArrayLike, R0: ArrayLike, xi0: ArrayLike | None = None) -> GnssInsState:
        """See :meth:`GnssInsObserver.init_state <nlobs.navigation.gnss_ins.GnssInsObserver.init_state>`."""
        return self.modes[0].init_state(p0, v0, R0, xi0)

    def rhs(self, t: float, z: GnssInsState, u: Array, y: Array) -> GnssInsState:
        """(24a)–(24d) with ``Γ = Γ(t)``: the mode's right-hand side."""
        return self.mode(t).rhs(t, z, u, y)

    def step(self, t: float, z: GnssInsState, u: Array, y: Array, h: float) -> GnssInsState:
        """One IMU period ``[t, t + h]`` in the mode in force at ``t`` (its split step or RK4)."""
        return self.mode(t).step(t, z, u, y, h)

    def correct(self, t: float, z: GnssInsState, u: Array, y: Array, fresh: BoolArray) -> GnssInsState:
        """Take a GNSS fix (independent of ``Γ`` and ``K``: the fix is held, the gains act in :meth:`rhs`)."""
        return self.modes[0].correct(t, z, u, y, fresh)

    def estimate(self, z: GnssInsState) -> Array:
        """``[p̂, v̂, R̂ projected onto SO(3)]``."""
        return self.modes[0].estimate(z)

    def raw_estimate(self, z: GnssInsState) -> Array:
        """``[p̂, v̂, R̂]`` with the raw ``R̂`` (the loop projects the record once)."""
        return self.modes[0].raw_estimate(z)

    def finish_estimates(self, raw: Array) -> tuple[Array, dict[str, Array]]:
        """The recorded raw estimates with ``R̂`` projected onto SO(3) (as the base observer)."""
        return self.modes[0].finish_estimates(raw)

    def diagnostics(self, z: GnssInsState, u: Array) -> dict[str, Array]:
        """``{"z_hat": ẑ}`` (as the base observer)."""
        return self.modes[0].diagnostics(z, u)


# ------------------------------------------------------------------ choosing a schedule from the noise
def _field_matrix(m_n: Array, g_n: Array) -> Array:
    """``M = A_n A_nᵀ`` of the reference vectors in level, unaccelerated flight (``aⁿ = −gⁿ``)."""
    a = -g_n
    An = np.stack([m_n, np.cross(m_n, a), np.cross(m_n, np.cross(m_n, a))], axis=1)
    return An @ An.T


def heading_rate_per_gain(m_n: ArrayLike, g_n: ArrayLike) -> float:
    """The rate [1/s] at which a small heading error decays per unit of ``Γ = γ I``, level flight.

    Linearising (22) about ``R̂ = R (I − S(δ))`` with ``aⁿ`` known gives
    ``dδ/dt = −(γ/2) (tr(M) I − M) δ`` in navigation axes, ``M = A_n A_nᵀ``; about the down axis
    ``d = gⁿ/|gⁿ|`` the rate is ``λ_d = ½ (tr M − dᵀ M d)`` (10.65 s⁻¹ for the demo's field and gravity).

    Parameters
    ----------
    m_n, g_n : array_like, shape (3,)
        Earth magnetic field and gravity (NED).

    Returns
    -------
    float
        ``λ_d`` [1/s].

    Raises
    ------
    InvalidArgumentError
        ``mⁿ`` or ``gⁿ`` is zero, or the field is vertical (no heading information).
    """
    m = as_vector("m_n", m_n, 3)
    g = as_vector("g_n", g_n, 3)
    if not np.any(m) or not np.any(g):
        raise InvalidArgumentError("m_n, g_n: the field and gravity must be non-zero")
    d = g / np.linalg.norm(g)
    M = _field_matrix(m, g)
    lam = 0.5 * float(np.trace(M) - d @ M @ d)
    if lam <= 1e-12 * float(np.trace(M)):
        raise InvalidArgumentError("m_n: the field is parallel to gravity; the heading is not observable")
    return lam


def steady_attitude_gain(noise: SensorNoise, m_n: ArrayLike, g_n: ArrayLike) -> float:
    """The steady-state ``γ∞`` of ``Γ = γ∞ I`` from the gyro and magnetometer noise.

    The heading error in steady state is a random walk driven by the gyro (white noise of
    intensity ``q = σ_gyro² / f``) corrected by a heading measured from the magnetometer's horizontal
    component (angle noise ``σ_mag / |m_h|``, intensity ``r = (σ_mag / |m_h|)² / f``). The
    steady-state Kalman gain of that scalar problem, ``k∞ = √(q/r) = σ_gyro |m_h| / σ_mag`` (the
    IMU rate cancels), is matched by the observer's heading rate ``γ λ_d``
    (:func:`heading_rate_per_gain`): ``γ∞ = k∞ / λ_d``. Demo sensors: ``k∞ = 0.068 s⁻¹``,
    ``γ∞ = 0.0064``.

    Parameters
    ----------
    noise : SensorNoise
        The sensors (``gyro_std`` [rad/s] and ``mag_std`` are used).
    m_n, g_n : array_like, shape (3,)
        Earth magnetic field and gravity (NED).

    Returns
    -------
    float
        ``γ∞``.

    Raises
    ------
    InvalidArgumentError
        A zero gyro or magnetometer noise (no finite optimum: give the gains by hand), or the
        geometry of :func:`heading_rate_per_gain`.
    """
    if not (noise.gyro_std > 0.0 and noise.mag_std > 0.0):
        raise InvalidArgumentError(
            f"noise: the steady attitude gain needs a positive gyro and magnetometer noise "
            f"(gyro_std = {noise.gyro_std:g}, mag_std = {noise.mag_std:g})")
    m = as_vector("m_n", m_n, 3)
    g = as_vector("g_n", g_n, 3)
    lam = heading_rate_per_gain(m, g)
    d = g / np.linalg.norm(g)
    m_h = float(np.linalg.norm(m - (m @ d) * d))
    return noise.gyro_std * m_h / noise.mag_std / lam


def noise_scheduled_gain(noise: SensorNoise, m_n: ArrayLike, g_n: ArrayLike, *,
                         initial: float = 0.5, decay_scale_s: float = DECAY_SCALE_S, factor: float = 2.0,
                         start_s: float = 0.0) -> AttitudeGainSchedule:
    """The attitude-gain schedule ``Γ(t) = γ(t) I`` of the noise-optimal GNSS/INS observer.

    ``γ(t)`` follows the shape of a Kalman gain started from a diffuse prior: constant ``γ₀`` while
    the initial error is being removed, then ``γ₀ t₁ / (t − t_s)`` (the ``1/t`` of an estimate that
    averages more and more data), down to the steady-state :func:`steady_attitude_gain` ``γ∞``
    set by the gyro and magnetometer noise. It is made piecewise constant on the levels
    ``γ₀ / factor^k``: level ``γ`` starts at ``t_s + t₁ γ₀ / γ``. Every mode is ``γ I`` with
    ``γ ≥ γ∞ > 0``, so the switched observer keeps the guarantees of (24) (module docstring).

    Parameters
    ----------
    noise : SensorNoise
        The sensors (gyro and magnetometer noise set ``γ∞``).
    m_n, g_n : array_like, shape (3,)
        Earth field and gravity (NED).
    initial : float
        ``γ₀`` (default 0.5: the best constant ``Γ = γ I`` on the demo, :data:`~nlobs.navigation.gains.NOISE_OPTIMAL_GAMMA`).
    decay_scale_s : float
        ``t₁`` [s] (default :data:`DECAY_SCALE_S`, measured).
    factor : float
        Ratio of consecutive levels (> 1).
    start_s : float
        ``t_s``: the run's start on its clock (the first IMU time stamp).

    Returns
    -------
    AttitudeGainSchedule
        ``γ₀ I`` first; a single mode if ``γ∞ ≥ γ₀``.

    Raises
    ------
    InvalidArgumentError
        Non-positive ``initial``, ``decay_scale_s``, ``factor ≤ 1``, or the conditions of
        :func:`steady_attitude_gain`.

    Examples
    --------
    The demo's sensors: ``γ`` halves from 0.5 at ``t₁ γ₀ / γ`` (6 s, 12 s, 24 s, …) down to the steady-state
    ``γ∞`` of :func:`steady_attitude_gain`, reached at ``t₁ γ₀ / γ∞``:

    >>> import numpy as np
    >>> from nlobs.navigation.trajectory import M_N_DEFAULT
    >>> demo = SensorNoise(gyro_std=0.002, accel_std=0.05, mag_std=0.01, gnss_p_std=1.5, gnss_v_std=0.1)
    >>> g_n = [0.0, 0.0, 9.80665]
    >>> schedule = noise_scheduled_gain(demo, M_N_DEFAULT, g_n)
    >>> [round(float(G[0, 0]), 5) for G in schedule.gains]
    [0.5, 0.25, 0.125, 0.0625, 0.03125, 0.01562, 0.00781, 0.00642]
    >>> [round(t, 1) for t in schedule.times]
    [6.0, 12.0, 24.0, 48.0, 96.0, 192.0, 233.5]
    >>> g_inf = steady_attitude_gain(demo, M_N_DEFAULT, g_n)
    >>> bool(np.isclose(schedule.gains[-1][0, 0], g_inf)), bool(np.isclose(schedule.times[-1], 3.0 * 0.5 / g_inf))
    (True, True)
    """
    g0 = positive("initial", initial)
    t1 = positive("decay_scale_s", decay_scale_s)
    f = positive("factor", factor)
    if f <= 1.0:
        raise InvalidArgumentError(f"factor: must exceed 1, got {f:g}")
    ts = float(start_s)
    if not math.isfinite(ts):
        raise NonFiniteError(f"start_s: must be finite, got {start_s!r}")
    g_inf = steady_attitude_gain(noise, m_n, g_n)
    gains, times = [g0], []
    g = g0
    while g / f > g_inf * (1.0 + 1e-12):
        g /= f
        gains.append(g)
        times.append(ts + t1 * g0 / g)
    if gains[-1] > g_inf:
        gains.append(g_inf)
        times.append(ts + t1 * g0 / g_inf)
    return AttitudeGainSchedule(tuple(gains), tuple(times))
