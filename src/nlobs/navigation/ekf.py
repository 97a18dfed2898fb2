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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray
from nlobs._validate import as_batch, as_vector, positive
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
from nlobs.observers.kalman import joseph_update  # the one implementation (re-exported here)
from nlobs.systems.timebase import CONTINUOUS, TimeBase

_I3 = np.eye(3)


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
class EkfState:
    """EKF state: nominal ``p``, ``v`` ``(..., 3)``, ``R`` ``(..., 3, 3)``, covariance ``P`` ``(..., 9, 9)``;
    ``skipped`` counts invalid GNSS fixes per batch member."""

    p: Array
    v: Array
    R: Array
    P: Array
    skipped: Array


@dataclass(frozen=True)
class ExtendedKalmanFilter:
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
    """

    config: EkfConfig
    m_n: Array
    g_n: Array
    position_only: bool = False
    use_magnetometer: bool = True
    name: str = "ekf"
    time: TimeBase = field(default=CONTINUOUS, init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "m_n", as_vector("m_n", self.m_n, 3))
        object.__setattr__(self, "g_n", as_vector("g_n", self.g_n, 3))

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
        magnetometer (it is fused by :meth:`step` only); ``t`` and ``y`` are unused.
        """
        u_ = np.asarray(u, dtype=float)
        w, a = u_[..., IMU_OMEGA], u_[..., IMU_ACCEL]
        c = self.config
        F, G = self._jacobians(z.R, w, a, z.P.shape[:-2])
        Qc = np.diag(np.r_[np.full(3, c.accel_std**2), np.full(3, c.gyro_std**2)]) * c.sample_period_s
        FP = F @ z.P
        Pdot = FP + np.swapaxes(FP, -1, -2) + G @ Qc @ np.swapaxes(G, -1, -2)
        return EkfState(p=z.v, v=np.einsum("...ij,...j->...i", z.R, a) + self.g_n, R=z.R @ skew(w), P=Pdot,
                        skipped=z.skipped)

    def step(self, t: float, z: EkfState, u: Array, y: Array, h: float) -> EkfState:
        """Predict over ``h`` with ``u = [ω^b, a^b, m^b]`` held, then fuse the magnetometer (:meth:`propagate`)."""
        u_ = np.asarray(u, dtype=float)
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
        valid = np.isfinite(y_).all(axis=-1)
        return self.update(z, GnssSample(y_[..., GNSS_P], y_[..., GNSS_V] if y_.shape[-1] == 6 else None, valid))

    def estimate(self, state: EkfState) -> Array:
        """The nominal state ``[p̂, v̂, R̂]`` (``R̂`` is a rotation matrix by construction), shape ``(..., 15)``."""
        return nav_vector(state.p, state.v, state.R)

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
        )

    def propagate(self, state: EkfState, imu: ImuSample, dt: float) -> EkfState:
        """Predict over ``dt`` with the IMU sample held, then fuse the magnetometer.

        Raises :class:`~nlobs.errors.InvalidArgumentError` when ``dt`` is not positive and finite. The IMU
        sample is not checked per step: the loops check the record once up front
        (:func:`~nlobs.navigation.run.run_navigation`, :func:`~nlobs.simulate.run_observer`).
        """
        dt = float(dt)
        if not 0.0 < dt < math.inf:
            raise InvalidArgumentError(f"dt: must be positive and finite, got {dt!r}")
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
        dx, P_new = joseph_update(state.P, Hb, Rm, nu)
        new = self._inject(state, dx, P_new)
        keep = valid
        return EkfState(
            p=np.where(keep[..., None], new.p, state.p),
            v=np.where(keep[..., None], new.v, state.v),
            R=np.where(keep[..., None, None], new.R, state.R),
            P=np.where(keep[..., None, None], new.P, state.P),
            skipped=state.skipped + (~valid).astype(int),
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
