r"""The EKF baseline for GNSS/INS: what a navigation engineer would use instead of observer (24).

Same states (p, v, R) and measurements (IMU and magnetometer at the IMU rate,
GNSS p, v or p only at the GNSS rate) as observer (24) of Grip, Saberi & Johansen (Sec. 5),
and the same observer protocol (:mod:`nlobs.observers.base`): a correcting observer with its
own step, the IMU as input ``u = [ω^b, a^b, m^b]``, a GNSS fix as the sampled measurement
``y = [p, v]`` (channel layouts of :mod:`nlobs.navigation.base`), the estimate ``[p̂, v̂, R̂]``.

Error state and model
---------------------
Nominal state ``(p̂, v̂, R̂)`` with ``R̂ ∈ SO(3)``; 9-dimensional error state
``δx = [δp, δv, δθ]`` with the attitude error in **body** axes,
``R = R̂ exp(S(δθ))``. With the IMU sample ``(ω, a)`` held over ``dt``:

* nominal: ``R̂⁺ = R̂ exp(S(ω dt))``, ``v̂⁺ = v̂ + (R̂a + gⁿ) dt``,
  ``p̂⁺ = p̂ + v̂ dt + ½(R̂a + gⁿ) dt²``;
* error: ``δṗ = δv``, ``δv̇ = −R̂ S(a) δθ − R̂ n_a``, ``δθ̇ = −S(ω) δθ − n_g``;
  ``Φ = I + F dt + ½ (F dt)²``, ``Q = G diag(σ_a² I, σ_g² I) Gᵀ dt²``,
  ``G = [[0, 0], [−R̂, 0], [0, −I]]``: the sensors' white noise is given **per
  sample** (std ``σ``, as :class:`~nlobs.navigation.sensors.SensorNoise`), and a
  sample held over ``dt`` moves the velocity / angle by ``σ dt`` (variance
  ``σ² dt²``); a spectral density ``N`` would correspond to ``σ² = N / dt``.

Measurements: GNSS ``y = [p; v]`` with ``H = [[I, 0, 0], [0, I, 0]]``;
magnetometer ``m^b = exp(−S(δθ)) R̂ᵀ mⁿ ≈ R̂ᵀmⁿ + S(R̂ᵀmⁿ) δθ``,
``H = [0, 0, S(R̂ᵀmⁿ)]``.

Update in **Joseph form**, ``P⁺ = (I − KH) P (I − KH)ᵀ + K R Kᵀ``, then
``P⁺ ← (P⁺ + P⁺ᵀ)/2``: it keeps P symmetric positive semi-definite under rounding
and for any (even suboptimal) gain, unlike ``(I − KH) P``. After each update the
error is injected into the nominal state and reset to zero.

Continuous time
---------------
:meth:`ExtendedKalmanFilter.rhs` is the continuous-time mean and covariance propagation that
:meth:`~ExtendedKalmanFilter.step` discretises (with the IMU sample held)::

    ṗ = v̂,   v̇ = R̂ a + gⁿ,   Ṙ = R̂ S(ω),   Ṗ = F P + P Fᵀ + Q̇,   Q̇ = G diag(σ_a² I, σ_g² I) Gᵀ T

with ``T`` = :attr:`EkfConfig.sample_period_s`: a per-sample std ``σ`` held over a sample of
period ``T`` is white noise of spectral density ``σ² T``, so that ``Q̇ dt = Q`` for ``dt = T``.
The step agrees with the flow of ``rhs`` to first order in ``dt`` (the nominal velocity uses
``R̂`` at the start of the period, ``Φ`` is second order). The magnetometer is fused in
``step`` only (a discrete update at every IMU sample); ``rhs`` leaves it out.

Everything is vectorised over a leading batch axis: ``P`` has shape ``(..., 9, 9)``.

Cost of one flight
------------------
For a single flight (``P`` of shape ``(9, 9)``) NumPy's fixed cost per call (about 1 µs)
dominates the arithmetic of 9 × 9 matrices, so under ``kernel="auto"`` the step and the GNSS update
evaluate the same equations with as few NumPy calls as the structure allows
(:meth:`ExtendedKalmanFilter._step_one`): the nominal state, ``R̂ exp(S(ω dt))`` (Rodrigues' formula
on floats, :func:`~nlobs.navigation.split_kernel.exp_so3_scalar`), the blocks of ``Φ`` and the
magnetometer's ``H``, ``S⁻¹`` (3 × 3, by its adjugate) and the injection on Python floats; the
products of the 9 × 9 covariance with ``ndarray.dot``. The structure used:

* ``Φ = I + F dt + ½ (F dt)²`` is the identity except for ``Φ₀₁ = I dt`` and its last block column
  ``[½ A dt²; A dt + ½ A W dt²; I + W dt + ½ W² dt²]`` with ``A = −R̂ S(a)``, ``W = −S(ω)``
  (``F`` is nilpotent on the position/velocity blocks, ``F² = [[0, 0, A], [0, 0, AW], [0, 0, W²]]``);
* ``Q = G diag(σ_a² I, σ_g² I) Gᵀ dt² = diag(0, σ_a² R̂R̂ᵀ, σ_g² I) dt²`` with ``R̂R̂ᵀ = I``
  (``R̂`` is a rotation by construction: a product of Rodrigues exponentials, orthogonal to rounding),
  a constant diagonal per ``dt``;
* the magnetometer's ``K R Kᵀ = σ_m² K Kᵀ``.

The covariance update stays in Joseph form and is symmetrised as above. The results equal the
batched path's to rounding (``tests/test_ekf.py`` checks 1e-12 along a noisy flight);
``kernel="batched"`` takes the batched path for one flight too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray
from nlobs._validate import as_batch, as_vector, positive, readonly
from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.navigation.base import (
    GNSS_P,
    GNSS_V,
    IMU_ACCEL,
    IMU_MAG,
    IMU_OMEGA,
    GnssSample,
    ImuSample,
    nav_vector,
    split_nav,
)
from nlobs.navigation.sensors import SensorNoise
from nlobs.navigation.so3 import exp_so3, skew
from nlobs.navigation.split_kernel import _mm, exp_so3_scalar
from nlobs.observers.kalman import joseph_update  # the one implementation (re-exported here)
from nlobs.systems.timebase import CONTINUOUS, TimeBase
from nlobs.observers.base import ToControl

_I3 = np.eye(3)


def _check_dt(dt: float) -> float:
    dt = float(dt)
    if not 0.0 < dt < math.inf:
        raise InvalidArgumentError(f"dt: must be positive and finite, got {dt!r}")
    return dt


@dataclass(frozen=True)
class EkfConfig:
    """Tuning of the EKF: initial standard deviations and noise densities.

    Attributes
    ----------
    p0_std, v0_std : float
        Initial position [m] and velocity [m/s] standard deviations.
    tilt0_std_deg, yaw0_std_deg : float
        Initial roll/pitch and yaw standard deviations [deg].
    gyro_std, accel_std : float
        IMU white noise per sample [rad/s], [m/s²] (the process noise).
    mag_std : float
        Magnetometer noise per sample.
    gnss_p_std, gnss_v_std : float
        GNSS noise per fix.
    sample_period_s : float
        IMU sample period ``T`` [s] behind the per-sample noise std's, used by the continuous-time
        :meth:`ExtendedKalmanFilter.rhs` only (``Q̇ = G diag(σ²) Gᵀ T``, module docstring); the
        discrete :meth:`~ExtendedKalmanFilter.step` uses the actual step. Default 0.01 s (the
        demo's 100 Hz IMU).

    Examples
    --------
    The default tuning, one matched to a sensor model (a noise-free sensor's std floored at ``1e-4``), and
    the initial covariance it gives the filter (standard deviations of ``δp``, ``δv``, ``δθ``; the angles in
    radians):

    >>> import numpy as np
    >>> from nlobs.navigation.trajectory import M_N_DEFAULT
    >>> EkfConfig().yaw0_std_deg, EkfConfig().gnss_p_std
    (60.0, 1.5)
    >>> tuned = EkfConfig.for_noise(SensorNoise(gyro_std=0.002, accel_std=0.05, gnss_p_std=1.5), yaw_std_deg=30.0)
    >>> tuned.gyro_std, tuned.gnss_p_std, tuned.mag_std, tuned.yaw0_std_deg
    (0.002, 1.5, 0.0001, 30.0)
    >>> ekf = ExtendedKalmanFilter(tuned, M_N_DEFAULT, [0.0, 0.0, 9.80665])
    >>> state = ekf.init(nav_vector(np.zeros(3), np.zeros(3), np.eye(3)))
    >>> np.round(np.sqrt(np.diag(state.P)), 4).tolist()
    [5.0, 5.0, 5.0, 1.0, 1.0, 1.0, 0.1745, 0.1745, 0.5236]
    >>> try:
    ...     EkfConfig(gnss_p_std=0.0)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError gnss_p_std: must be positive, got 0.0
    """

    p0_std: float = 5.0
    v0_std: float = 1.0
    tilt0_std_deg: float = 10.0
    yaw0_std_deg: float = 60.0
    gyro_std: float = 0.002
    accel_std: float = 0.05
    mag_std: float = 0.01
    gnss_p_std: float = 1.5
    gnss_v_std: float = 0.1
    sample_period_s: float = 0.01

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            positive(name, getattr(self, name))

    @classmethod
    def for_noise(cls, noise: SensorNoise, *, yaw_std_deg: float = 60.0, floor: float = 1e-4,
                  sample_period_s: float = 0.01) -> EkfConfig:
        """A configuration matched to a sensor error model (zero std's are floored to ``floor``)."""
        f = max(floor, 0.0)
        return cls(
            yaw0_std_deg=yaw_std_deg,
            sample_period_s=sample_period_s,
            gyro_std=max(noise.gyro_std, f),
            accel_std=max(noise.accel_std, f),
            mag_std=max(noise.mag_std, f),
            gnss_p_std=max(noise.gnss_p_std, f),
            gnss_v_std=max(noise.gnss_v_std, f),
        )


@dataclass(frozen=True)
class _OneFlight:
    """Constants of the single-flight path (:meth:`ExtendedKalmanFilter._step_one`), made once per filter.

    ``m_n``, ``g_n`` as floats; the variances ``σ_a²``, ``σ_g²``, ``σ_m²``; the identity ``I9``; the
    GNSS ``H`` and ``R`` for a fix of ``p`` (3 channels) and of ``p, v`` (6 channels).
    """

    m_n: tuple[float, float, float]
    g_n: tuple[float, float, float]
    var_a: float
    var_g: float
    var_m: float
    I9: Array
    gnss: dict[int, tuple[Array, Array]]

    @classmethod
    def build(cls, c: EkfConfig, m_n: Array, g_n: Array) -> _OneFlight:
        gnss = {}
        for q in (3, 6):
            H = np.zeros((q, 9))
            H[:, 0:q] = np.eye(q)
            Rm = np.diag(np.r_[np.full(3, c.gnss_p_std**2), np.full(3, c.gnss_v_std**2)][:q])
            gnss[q] = (readonly(H, owned=True), readonly(Rm, owned=True))
        m0, m1, m2 = (float(x) for x in m_n)
        g0, g1, g2 = (float(x) for x in g_n)
        return cls(m_n=(m0, m1, m2), g_n=(g0, g1, g2), var_a=c.accel_std**2, var_g=c.gyro_std**2,
                   var_m=c.mag_std**2, I9=readonly(np.eye(9), owned=True), gnss=gnss)


@dataclass(frozen=True)
class EkfState:
    """EKF state: nominal ``p``, ``v`` ``(..., 3)``, ``R`` ``(..., 3, 3)``, covariance ``P`` ``(..., 9, 9)``;
    ``skipped`` counts invalid GNSS fixes per batch member; ``nis`` ``(...)`` is the normalised innovation squared
    ``νᵀ S⁻¹ ν`` of the last GNSS fix (``None`` where a state is rebuilt without it, e.g. from generated C).

    Attributes
    ----------
    p, v : ndarray, shape (..., 3)
        Nominal position [m] and velocity [m/s] in NED.
    R : ndarray, shape (..., 3, 3)
        Nominal attitude (a rotation matrix).
    P : ndarray, shape (..., 9, 9)
        Covariance of the error state ``[δp, δv, δθ]``.
    skipped : ndarray of int, shape (...)
        Invalid GNSS fixes skipped so far.
    nis : ndarray, shape (...), or None
        NIS of the last GNSS fix.

    Examples
    --------
    Two flights at the origin, 5 m of position uncertainty per axis. A GNSS fix 1 m north (std 1.5 m) reaches
    the first, a non-finite fix the second: the first moves by the scalar Kalman gain ``25 / (25 + 2.25)``, its
    north variance becomes ``25 · 2.25 / 27.25`` and its NIS ``1 / 27.25``; the second skips its fix:

    >>> import numpy as np
    >>> from nlobs.navigation.trajectory import M_N_DEFAULT
    >>> ekf = ExtendedKalmanFilter(EkfConfig(), M_N_DEFAULT, [0.0, 0.0, 9.80665])
    >>> state = ekf.init(nav_vector(np.zeros((2, 3)), np.zeros(3), np.eye(3)))
    >>> type(state).__name__, state.p.shape, state.R.shape, state.P.shape, state.skipped.tolist()
    ('EkfState', (2, 3), (2, 3, 3), (2, 9, 9), [0, 0])
    >>> fixes = np.array([[1.0, 0.0, 0.0, 0.0, 0.0, 0.0], [np.nan, 0.0, 0.0, 0.0, 0.0, 0.0]])
    >>> after = ekf.correct(0.0, state, np.zeros(9), fixes, np.ones(6, dtype=bool))
    >>> round(float(after.p[0, 0]), 4), round(25 / 27.25, 4), round(float(np.sqrt(after.P[0, 0, 0])), 4)
    (0.9174, 0.9174, 1.4367)
    >>> round(float(after.nis[0]), 4), round(1 / 27.25, 4), after.skipped.tolist(), float(after.P[1, 0, 0])
    (0.0367, 0.0367, [0, 1], 25.0)
    """

    p: Array
    v: Array
    R: Array
    P: Array
    skipped: Array
    nis: Array | None = None


@dataclass(frozen=True)
class ExtendedKalmanFilter(ToControl):
    """Error-state EKF with multiplicative attitude (module docstring), a correcting observer.

    ``time = Continuous()``, ``n_x = 15`` (the estimate ``[p̂, v̂, R̂]``); ``step`` is the EKF
    prediction with the magnetometer update, ``correct`` the GNSS update.

    Parameters
    ----------
    config : EkfConfig
    m_n, g_n : (3,) array_like
        Earth magnetic field and gravity in NED.
    position_only : bool
        GNSS position only (``GnssSample.v`` is None).
    use_magnetometer : bool
        Fuse the magnetometer at every IMU sample (default True, as the observer uses it).
    kernel : {"auto", "batched"}
        ``"auto"`` (default): a single flight (``P`` of shape ``(9, 9)``) takes the fused
        single-flight path (module docstring, *Cost of one flight*), anything else the batched
        NumPy path; ``"batched"``: always the batched path (the same results to rounding).
    name : str
        Label of the results (default ``"ekf"``).
    record_covariance : bool
        :meth:`diagnostics` also returns the whole error-state covariance ``P`` (for the NEES,
        :func:`~nlobs.navigation.metrics.navigation_consistency`); its diagonal ``P_diag`` and the GNSS fixes'
        ``nis`` are always returned.

    Raises
    ------
    InvalidArgumentError
        Unknown ``kernel``.

    Examples
    --------
    The take-off of the traffic pattern of Grip, Saberi & Johansen (Sec. 5.2) with exact sensors (IMU at
    100 Hz, GNSS at 5 Hz) and a filter tuned for a typical sensor set, the estimate started 30° off in yaw and
    3.7 m off in position:

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
    >>> from nlobs.navigation import EkfConfig, SensorNoise
    >>> tuning = SensorNoise(gyro_std=0.002, accel_std=0.05, mag_std=0.01, gnss_p_std=1.5, gnss_v_std=0.1)
    >>> ekf = nlobs.ExtendedKalmanFilter(EkfConfig.for_noise(tuning, yaw_std_deg=60.0), traj.m_n, traj.g_n)
    >>> res = nlobs.run_observer(ekf, traj.t, x_hat0=x_hat0, u=u, y=y, y_times=traj.t[fixes], truth=truth)
    >>> attitude, position = metrics.attitude_error_deg(res), metrics.position_error_m(res)
    >>> round(float(attitude[0]), 3), bool(attitude[-1] < 0.1), bool(position[-1] < 0.05)
    (30.0, True, True)
    """

    config: EkfConfig
    m_n: Array
    g_n: Array
    position_only: bool = False
    use_magnetometer: bool = True
    kernel: Literal["auto", "batched"] = "auto"
    name: str = "ekf"
    record_covariance: bool = False
    time: TimeBase = field(default=CONTINUOUS, init=False)
    _k: _OneFlight = field(init=False, repr=False, compare=False)
    _q_cache: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "m_n", as_vector("m_n", self.m_n, 3))
        object.__setattr__(self, "g_n", as_vector("g_n", self.g_n, 3))
        if self.kernel not in ("auto", "batched"):
            raise InvalidArgumentError(f"kernel: expected 'auto' or 'batched', got {self.kernel!r}")
        object.__setattr__(self, "_k", _OneFlight.build(self.config, self.m_n, self.g_n))
        object.__setattr__(self, "_q_cache", {})

    # ------------------------------------------------------------------ protocol
    @property
    def n_x(self) -> int:
        """15: the estimate is the navigation vector ``[p̂, v̂, R̂]``."""
        return 15

    def init(self, x_hat0: ArrayLike) -> EkfState:
        """Initial state from a navigation vector ``x̂0 = [p̂, v̂, R̂]`` of shape ``(..., 15)`` (:meth:`init_state`)."""
        p, v, R = split_nav(x_hat0)
        return self.init_state(p, v, R)

    def rhs(self, t: float, z: EkfState, u: Array, y: Array) -> EkfState:
        """The continuous-time mean and covariance propagation of the module docstring, ``u`` held.

        ``ṗ = v̂``, ``v̇ = R̂ a + gⁿ``, ``Ṙ = R̂ S(ω)``, ``Ṗ = F P + P Fᵀ + Q̇`` with
        ``Q̇ = G diag(σ_a² I, σ_g² I) Gᵀ T`` (``T`` = :attr:`EkfConfig.sample_period_s`). No
        magnetometer (it is fused by :meth:`step` only); the skipped-fix counter's derivative is 0; ``t`` and
        ``y`` are unused.
        """
        u_ = np.asarray(u, dtype=float)
        w, a = u_[..., IMU_OMEGA], u_[..., IMU_ACCEL]
        c = self.config
        F, G = self._jacobians(z.R, w, a, z.P.shape[:-2])
        Qc = np.diag(np.r_[np.full(3, c.accel_std**2), np.full(3, c.gyro_std**2)]) * c.sample_period_s
        FP = F @ z.P
        Pdot = FP + np.swapaxes(FP, -1, -2) + G @ Qc @ np.swapaxes(G, -1, -2)
        return EkfState(p=z.v, v=np.einsum("...ij,...j->...i", z.R, a) + self.g_n, R=z.R @ skew(w), P=Pdot,
                        skipped=np.zeros_like(z.skipped),  # a counter: constant between fixes
                        nis=None if z.nis is None else np.zeros_like(z.nis))

    def step(self, t: float, z: EkfState, u: Array, y: Array, h: float) -> EkfState:
        """Predict over ``h`` with ``u = [ω^b, a^b, m^b]`` held, then fuse the magnetometer (:meth:`propagate`)."""
        u_ = np.asarray(u, dtype=float)
        if u_.shape == (9,) and z.P.ndim == 2 and self.kernel == "auto":
            return self._step_one(z, u_.tolist(), _check_dt(h))
        return self.propagate(z, ImuSample(u_[..., IMU_OMEGA], u_[..., IMU_ACCEL], u_[..., IMU_MAG]), h)

    def correct(self, t: float, z: EkfState, u: Array, y: Array, fresh: BoolArray) -> EkfState:
        """GNSS update with the fix ``y = [p, v]`` (or ``p``); a fix with a non-finite entry is skipped for
        that batch member (:meth:`update`).

        Raises
        ------
        DimensionError
            ``y`` has neither 3 nor 6 channels.
        """
        y_ = np.asarray(y, dtype=float)
        if y_.ndim == 0 or y_.shape[-1] not in (3, 6):
            raise DimensionError(f"y: expected a GNSS fix of shape (..., 6) or (..., 3), got {y_.shape}")
        if y_.ndim == 1 and z.P.ndim == 2 and self.kernel == "auto":
            yl = y_.tolist()
            return self._update_one(z, yl, all(map(math.isfinite, yl)))
        valid = np.isfinite(y_).all(axis=-1)
        return self.update(z, GnssSample(y_[..., GNSS_P], y_[..., GNSS_V] if y_.shape[-1] == 6 else None, valid))

    def estimate(self, state: EkfState) -> Array:
        """The nominal state ``[p̂, v̂, R̂]`` (``R̂`` is a rotation matrix by construction), shape ``(..., 15)``."""
        return nav_vector(state.p, state.v, state.R)

    @property
    def compiled_diagnostics(self) -> bool:
        """Its generated C records :meth:`diagnostics` (the covariance, for the NEES) only with
        :attr:`record_covariance`: the C state carries no NIS, and without diagnostics the compiled filter runs
        a whole record in one call."""
        return self.record_covariance

    def diagnostics(self, z: EkfState, u: Array) -> dict[str, Array]:
        """What the loops record: ``P_diag`` (the error-state variances ``(..., 9)``: position, velocity,
        attitude), ``nis`` ``(...)`` of the last GNSS fix (when the state carries it) and, with
        :attr:`record_covariance`, ``P`` ``(..., 9, 9)``.

        Parameters
        ----------
        z : EkfState
            The filter's state.
        u : ndarray
            The IMU sample (unused).

        Returns
        -------
        dict
        """
        out = {"P_diag": np.diagonal(z.P, 0, -2, -1)}
        if z.nis is not None:
            out["nis"] = np.asarray(z.nis, dtype=float)
        if self.record_covariance:
            out["P"] = z.P
        return out

    # ------------------------------------------------------ functional form (domain types)
    def init_state(self, p0: ArrayLike, v0: ArrayLike, R0: ArrayLike) -> EkfState:
        """Initial state; the covariance is diagonal from :class:`EkfConfig`.

        Raises :class:`~nlobs.errors.NonFiniteError` / :class:`~nlobs.errors.DimensionError` for a
        non-finite entry or shapes other than ``(..., 3)``, ``(..., 3)``, ``(..., 3, 3)`` that broadcast.
        """
        p = as_batch("p0", p0, 3)
        v = as_batch("v0", v0, 3)
        R = as_batch("R0", R0, 3)
        if R.ndim < 2 or R.shape[-2] != 3:
            raise DimensionError(f"R0: expected shape (..., 3, 3), got {R.shape}")
        try:
            batch = np.broadcast_shapes(p.shape[:-1], v.shape[:-1], R.shape[:-2])
        except ValueError:
            raise DimensionError(f"p0, v0, R0: batch shapes {p.shape[:-1]}, {v.shape[:-1]}, {R.shape[:-2]} "
                                 "do not broadcast") from None
        c = self.config
        d = np.r_[np.full(3, c.p0_std**2), np.full(3, c.v0_std**2),
                  np.deg2rad([c.tilt0_std_deg, c.tilt0_std_deg, c.yaw0_std_deg]) ** 2]
        P = np.broadcast_to(np.diag(d), batch + (9, 9)).copy()
        return EkfState(
            p=np.broadcast_to(p, batch + (3,)).copy(),
            v=np.broadcast_to(v, batch + (3,)).copy(),
            R=np.broadcast_to(R, batch + (3, 3)).copy(),
            P=P,
            skipped=np.zeros(batch, dtype=int),
            nis=np.zeros(batch),
        )

    def propagate(self, state: EkfState, imu: ImuSample, dt: float) -> EkfState:
        """Predict over ``dt`` with the IMU sample held, then fuse the magnetometer.

        Raises :class:`~nlobs.errors.InvalidArgumentError` when ``dt`` is not positive and finite. The IMU
        sample is not checked per step: the loops check the record once up front
        (:func:`~nlobs.navigation.run.run_navigation`, :func:`~nlobs.simulate.run_observer`).
        """
        dt = _check_dt(dt)
        if state.P.ndim == 2 and self.kernel == "auto" and np.shape(imu.omega_b) == (3,) \
                and np.shape(imu.a_b) == (3,) and (not self.use_magnetometer or np.shape(imu.m_b) == (3,)):
            m = np.asarray(imu.m_b, dtype=float).tolist() if self.use_magnetometer else [0.0, 0.0, 0.0]
            return self._step_one(state, np.asarray(imu.omega_b, dtype=float).tolist()
                                  + np.asarray(imu.a_b, dtype=float).tolist() + m, dt)
        c = self.config
        w, a = imu.omega_b, imu.a_b
        R = state.R
        acc_n = np.einsum("...ij,...j->...i", R, a) + self.g_n
        p = state.p + state.v * dt + 0.5 * acc_n * dt**2
        v = state.v + acc_n * dt
        R_new = R @ exp_so3(w * dt)
        F, G = self._jacobians(R, w, a, state.P.shape[:-2])
        Fdt = F * dt
        Phi = np.eye(9) + Fdt + 0.5 * Fdt @ Fdt
        # per-sample white noise of std σ on a held sample over dt: velocity/angle random walk σ·dt per step
        Qc = np.diag(np.r_[np.full(3, c.accel_std**2), np.full(3, c.gyro_std**2)]) * dt**2
        Q = G @ Qc @ np.swapaxes(G, -1, -2)
        P = Phi @ state.P @ np.swapaxes(Phi, -1, -2) + Q
        P = 0.5 * (P + np.swapaxes(P, -1, -2))
        st = replace(state, p=p, v=v, R=R_new, P=P)
        if self.use_magnetometer:
            st = self._magnetometer(st, imu.m_b)
        return st

    def update(self, state: EkfState, gnss: GnssSample) -> EkfState:
        """GNSS update (Joseph form); batch members with ``valid == False`` are left unchanged.

        A member whose fix has a non-finite entry (of ``p``, or of ``v`` when fused) is invalid even when
        ``gnss.valid`` says otherwise: a missing fix for that flight, skipped and counted (it would
        otherwise be fused as a zero innovation and shrink the covariance).
        """
        if state.P.ndim == 2 and self.kernel == "auto" and np.shape(gnss.p) == (3,) \
                and (gnss.v is None or np.shape(gnss.v) == (3,)) and np.ndim(gnss.valid) == 0:
            yl = np.asarray(gnss.p, dtype=float).tolist()
            if not (self.position_only or gnss.v is None):
                yl += np.asarray(gnss.v, dtype=float).tolist()
            return self._update_one(state, yl, bool(gnss.valid) and all(map(math.isfinite, yl)))
        c = self.config
        finite = np.isfinite(gnss.p).all(axis=-1)
        if not (self.position_only or gnss.v is None):
            finite = finite & np.isfinite(gnss.v).all(axis=-1)
        valid = np.broadcast_to(np.asarray(gnss.valid, dtype=bool) & finite, state.P.shape[:-2])
        if self.position_only or gnss.v is None:
            y, yhat = gnss.p, state.p
            H = np.zeros((3, 9))
            H[:, 0:3] = _I3
            Rm = np.eye(3) * c.gnss_p_std**2
        else:
            y = np.concatenate([gnss.p, gnss.v], axis=-1)
            yhat = np.concatenate([state.p, state.v], axis=-1)
            H = np.zeros((6, 9))
            H[0:3, 0:3] = _I3
            H[3:6, 3:6] = _I3
            Rm = np.diag(np.r_[np.full(3, c.gnss_p_std**2), np.full(3, c.gnss_v_std**2)])
        nu = np.where(valid[..., None], np.nan_to_num(y - yhat), 0.0)
        Hb = np.broadcast_to(H, state.P.shape[:-2] + H.shape)
        dx, P_new, nis = joseph_update(state.P, Hb, Rm, nu, nis=True)
        new = self._inject(state, dx, P_new)
        keep = valid
        return EkfState(
            p=np.where(keep[..., None], new.p, state.p),
            v=np.where(keep[..., None], new.v, state.v),
            R=np.where(keep[..., None, None], new.R, state.R),
            P=np.where(keep[..., None, None], new.P, state.P),
            skipped=state.skipped + (~valid).astype(int),
            nis=None if state.nis is None else np.where(valid, nis, 0.0),
        )

    # ------------------------------------------------------------------ pieces
    @staticmethod
    def _jacobians(R: Array, w: Array, a: Array, batch: tuple[int, ...]) -> tuple[Array, Array]:
        """``F`` of ``δẋ = F δx + G n`` and the noise input ``G`` (module docstring), batched."""
        F = np.zeros(batch + (9, 9))
        F[..., 0:3, 3:6] = _I3
        F[..., 3:6, 6:9] = -R @ skew(a)
        F[..., 6:9, 6:9] = -skew(w)
        G = np.zeros(batch + (9, 6))
        G[..., 3:6, 0:3] = -R
        G[..., 6:9, 3:6] = -_I3
        return F, G

    def _magnetometer(self, state: EkfState, m_b: Array) -> EkfState:
        m_pred = np.einsum("...ji,j->...i", state.R, self.m_n)  # R̂ᵀ mⁿ
        H = np.zeros(state.P.shape[:-2] + (3, 9))
        H[..., 6:9] = skew(m_pred)
        Rm = np.eye(3) * self.config.mag_std**2
        dx, P_new = joseph_update(state.P, H, Rm, m_b - m_pred)
        return self._inject(state, dx, P_new)

    @staticmethod
    def _inject(state: EkfState, dx: Array, P: Array) -> EkfState:
        return replace(state, p=state.p + dx[..., 0:3], v=state.v + dx[..., 3:6],
                       R=state.R @ exp_so3(dx[..., 6:9]), P=P)

    # ------------------------------------------------------------ one flight (module docstring)
    def _q_one(self, dt: float) -> Array:
        """``Q = diag(0, σ_a² I, σ_g² I) dt²`` (``R̂R̂ᵀ = I``), ``(9, 9)``, cached by ``dt``."""
        Q = self._q_cache.get(dt)
        if Q is None:
            k = self._k
            Q = readonly(np.diag([0.0] * 3 + [k.var_a * dt**2] * 3 + [k.var_g * dt**2] * 3), owned=True)
            if len(self._q_cache) > 64:
                self._q_cache.clear()
            self._q_cache[dt] = Q
        return Q

    def _step_one(self, state: EkfState, u: list[float], dt: float) -> EkfState:
        """:meth:`propagate` of one flight: the same prediction and magnetometer update (module docstring,
        *Cost of one flight*); ``u = [ω^b, a^b, m^b]`` as 9 floats, ``dt`` checked."""
        w0, w1, w2, a0, a1, a2 = u[0:6]
        p0, p1, p2 = state.p.tolist()
        v0, v1, v2 = state.v.tolist()
        R = state.R.ravel().tolist()
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = R
        g0, g1, g2 = self._k.g_n
        # nominal: acceleration R̂a + gⁿ, position, velocity, attitude R̂ exp(S(ω dt))
        f0 = r0 * a0 + r1 * a1 + r2 * a2 + g0
        f1 = r3 * a0 + r4 * a1 + r5 * a2 + g1
        f2 = r6 * a0 + r7 * a1 + r8 * a2 + g2
        h2 = 0.5 * dt * dt
        p0, p1, p2 = p0 + v0 * dt + f0 * h2, p1 + v1 * dt + f1 * h2, p2 + v2 * dt + f2 * h2
        v0, v1, v2 = v0 + f0 * dt, v1 + f1 * dt, v2 + f2 * dt
        R_new = _mm(R, exp_so3_scalar(w0 * dt, w1 * dt, w2 * dt))
        # Φ's last block column: A = −R̂ S(a) (row i: a × r_i), W = −S(ω), AW, W² = ωωᵀ − |ω|² I
        A = (r2 * a1 - r1 * a2, r0 * a2 - r2 * a0, r1 * a0 - r0 * a1,
             r5 * a1 - r4 * a2, r3 * a2 - r5 * a0, r4 * a0 - r3 * a1,
             r8 * a1 - r7 * a2, r6 * a2 - r8 * a0, r7 * a0 - r6 * a1)
        ww = w0 * w0 + w1 * w1 + w2 * w2
        col = [h2 * x for x in A]
        for i in range(0, 9, 3):
            x0, x1, x2 = A[i], A[i + 1], A[i + 2]
            col += (dt * x0 + h2 * (x2 * w1 - x1 * w2), dt * x1 + h2 * (x0 * w2 - x2 * w0),
                    dt * x2 + h2 * (x1 * w0 - x0 * w1))
        col += (1.0 + h2 * (w0 * w0 - ww), dt * w2 + h2 * w0 * w1, -dt * w1 + h2 * w0 * w2,
                -dt * w2 + h2 * w1 * w0, 1.0 + h2 * (w1 * w1 - ww), dt * w0 + h2 * w1 * w2,
                dt * w1 + h2 * w2 * w0, -dt * w0 + h2 * w2 * w1, 1.0 + h2 * (w2 * w2 - ww))
        Phi = self._k.I9.copy()
        Phi[0, 3] = Phi[1, 4] = Phi[2, 5] = dt
        Phi[:, 6:9] = np.array(col).reshape(9, 3)
        P = Phi.dot(state.P).dot(Phi.T)
        P += self._q_one(dt)
        P += P.T.copy()
        P *= 0.5
        if self.use_magnetometer:
            return self._magnetometer_one(state, [p0, p1, p2, v0, v1, v2], R_new, P, u[6:9])
        return EkfState(p=np.array([p0, p1, p2]), v=np.array([v0, v1, v2]), R=np.array(R_new).reshape(3, 3),
                        P=P, skipped=state.skipped, nis=state.nis)

    def _magnetometer_one(self, state: EkfState, pv: list[float], R: tuple[float, ...], P: Array,
                          m_b: list[float]) -> EkfState:
        """The magnetometer update of one flight, ``H = [0, 0, S(R̂ᵀmⁿ)]`` (Joseph form, ``S⁻¹`` by its adjugate)."""
        n0, n1, n2 = self._k.m_n
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = R
        q0 = r0 * n0 + r3 * n1 + r6 * n2  # R̂ᵀ mⁿ
        q1 = r1 * n0 + r4 * n1 + r7 * n2
        q2 = r2 * n0 + r5 * n1 + r8 * n2
        H = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -q2, q1,
                      0.0, 0.0, 0.0, 0.0, 0.0, 0.0, q2, 0.0, -q0,
                      0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -q1, q0, 0.0]).reshape(3, 9)
        var = self._k.var_m
        PHt = P.dot(H.T)
        Sinv = _inv3(H.dot(PHt).ravel().tolist(), var)
        K = PHt.dot(Sinv)
        return self._joseph_inject_one(state, pv, R, P, H, K, var, [m_b[0] - q0, m_b[1] - q1, m_b[2] - q2])

    def _joseph_inject_one(self, state: EkfState, pv: list[float], R: tuple[float, ...] | list[float], P: Array,
                           H: Array, K: Array, var: float | Array, nu: list[float],
                           nis: float | None = None) -> EkfState:
        """Joseph form ``(I − KH) P (I − KH)ᵀ + K R Kᵀ`` (``R = var·I`` for a float ``var``), symmetrised,
        and the injection of ``δx = K ν``, for one flight (``nis``: that of a GNSS fix, else the state's)."""
        IKH = self._k.I9 - K.dot(H)
        KRKt = K.dot(K.T) * var if isinstance(var, float) else K.dot(var).dot(K.T)
        P_new = IKH.dot(P).dot(IKH.T)
        P_new += KRKt
        P_new += P_new.T.copy()
        P_new *= 0.5
        dx = K.dot(nu).tolist()
        E = exp_so3_scalar(dx[6], dx[7], dx[8])
        return EkfState(p=np.array([pv[0] + dx[0], pv[1] + dx[1], pv[2] + dx[2]]),
                        v=np.array([pv[3] + dx[3], pv[4] + dx[4], pv[5] + dx[5]]),
                        R=np.array(_mm(R, E)).reshape(3, 3), P=P_new, skipped=state.skipped,
                        nis=state.nis if nis is None or state.nis is None else np.asarray(nis))

    def _update_one(self, state: EkfState, y: list[float], valid: bool) -> EkfState:
        """:meth:`update` of one flight with the fix ``y = [p, (v)]`` as floats; an invalid fix is counted."""
        if not valid:
            return replace(state, skipped=state.skipped + 1)
        pv = state.p.tolist() + state.v.tolist()
        q = 3 if self.position_only or len(y) == 3 else 6
        H, Rm = self._k.gnss[q]
        P = state.P
        PHt = P.dot(H.T)
        S = H.dot(PHt)
        S += Rm
        Sinv = np.linalg.inv(S)
        K = PHt.dot(Sinv)
        nu = [y[i] - pv[i] for i in range(q)]
        return self._joseph_inject_one(state, pv, state.R.ravel().tolist(), P, H, K, Rm, nu,
                                       nis=float(np.dot(nu, Sinv.dot(nu))))


def _inv3(s: list[float], var: float) -> Array:
    """``(S + var·I)⁻¹`` of a 3 × 3 ``S`` given row-major as 9 floats, by the adjugate."""
    a, b, c, d, e, f, g, h, i = s
    a += var
    e += var
    i += var
    A, B, C = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * A + b * B + c * C
    if det == 0.0 or not math.isfinite(det):
        raise np.linalg.LinAlgError("Singular matrix")
    r = 1.0 / det
    return np.array([A * r, (c * h - b * i) * r, (b * f - c * e) * r,
                     B * r, (a * i - c * g) * r, (c * d - a * f) * r,
                     C * r, (b * g - a * h) * r, (a * e - b * d) * r]).reshape(3, 3)
