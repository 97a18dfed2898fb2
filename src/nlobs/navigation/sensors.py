"""Sampled, noisy sensor streams of a generated flight (IMU + magnetometer, GNSS).

Rates are required arguments, never defaulted (a silent default sample rate is
a known source of wrong results in navigation libraries). The GNSS rate must
divide the IMU rate so that every fix falls on an IMU instant.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from nlobs._validate import as_finite_array, as_vector, positive
from nlobs.errors import InvalidArgumentError, NonFiniteError
from nlobs.navigation.base import Array, SensorData
from nlobs.navigation.trajectory import Trajectory


@dataclass(frozen=True)
class SensorNoise:
    """Sensor error model: white-noise standard deviations and constant biases.

    Attributes
    ----------
    gyro_std : float
        Gyro white noise per sample [rad/s].
    accel_std : float
        Accelerometer white noise per sample [m/s²].
    mag_std : float
        Magnetometer white noise per sample [units of the (unit) field].
    gnss_p_std, gnss_v_std : float
        GNSS position [m] and velocity [m/s] noise per fix.
    gyro_bias, accel_bias : (3,) array_like
        Constant biases added to every sample (zero by default).

    Examples
    --------
    A typical small-aircraft sensor set with a gyro bias about the body x axis; the defaults are exact sensors,
    and a negative standard deviation is refused:

    >>> noise = SensorNoise(gyro_std=0.002, accel_std=0.05, mag_std=0.01, gnss_p_std=1.5, gnss_v_std=0.1,
    ...                     gyro_bias=[0.01, 0.0, 0.0])
    >>> noise.gyro_bias, noise.accel_bias
    ((0.01, 0.0, 0.0), (0.0, 0.0, 0.0))
    >>> SensorNoise() == SensorNoise(gyro_std=0.0, gnss_p_std=0.0)
    True
    >>> try:
    ...     SensorNoise(gyro_std=-0.1)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError gyro_std: must be non-negative, got -0.1
    """

    gyro_std: float = 0.0
    accel_std: float = 0.0
    mag_std: float = 0.0
    gnss_p_std: float = 0.0
    gnss_v_std: float = 0.0
    gyro_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    accel_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for name in ("gyro_std", "accel_std", "mag_std", "gnss_p_std", "gnss_v_std"):
            positive(name, getattr(self, name), allow_zero=True)
        for name in ("gyro_bias", "accel_bias"):
            object.__setattr__(self, name, tuple(float(v) for v in as_vector(name, getattr(self, name), 3)))


def generate_sensors(
    traj: Trajectory,
    *,
    imu_rate_hz: float,
    gnss_rate_hz: float,
    noise: SensorNoise,
    seed: int | np.random.Generator,
    batch: int | None = None,
    position_only: bool = False,
) -> SensorData:
    """Sample a flight's IMU, magnetometer and GNSS with noise.

    Parameters
    ----------
    traj : Trajectory
        The flight sampled on the IMU grid ``t_k = t_0 + k / imu_rate_hz``
        (e.g. ``flight.sample(imu_rate_hz)``).
    imu_rate_hz, gnss_rate_hz : float
        Sensor rates (required). ``imu_rate_hz / gnss_rate_hz`` must be an integer.
    noise : SensorNoise
        Error model.
    seed : int or numpy.random.Generator
        Seed of the noise (deterministic given the seed).
    batch : int, optional
        Number of independent noise realisations of the same flight (a leading
        batch axis on every measured array); ``None`` for a single one.
    position_only : bool
        GNSS position only (``v_gnss`` is ``None``; Grip, Saberi & Johansen, Sec. 5.2).

    Returns
    -------
    SensorData
        GNSS fixes at ``t_gnss = t_imu[::imu_rate_hz / gnss_rate_hz]``. The three IMU streams are
        views of one ``(..., K, 9)`` buffer (and ``p_gnss``, ``v_gnss`` of one ``(..., G, 6)``), so
        :meth:`~nlobs.navigation.base.SensorData.imu_input` needs no copy.

    Examples
    --------
    200 noise realisations of the first 10 s of the traffic pattern (IMU at 100 Hz, GNSS at 5 Hz): the gyro
    error has the bias as its mean and ``gyro_std`` as its spread, the GNSS position error ``gnss_p_std``:

    >>> import numpy as np
    >>> from nlobs.navigation.trajectory import traffic_pattern
    >>> traj = traffic_pattern(seed=0, duration=10.0).sample(100.0)
    >>> noise = SensorNoise(gyro_std=0.002, accel_std=0.05, gnss_p_std=1.5, gnss_v_std=0.1, gyro_bias=(0.01, 0.0, 0.0))
    >>> data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=noise, seed=0, batch=200)
    >>> data.omega_b.shape, data.p_gnss.shape, data.t_gnss[:3].tolist()
    ((200, 1001, 3), (200, 51, 3), [0.0, 0.2, 0.4])
    >>> gyro_error = data.omega_b - traj.omega_b
    >>> round(float(gyro_error[..., 0].mean()), 4), round(float(gyro_error[..., 1].std()), 4)
    (0.01, 0.002)
    >>> round(float((data.p_gnss - traj.p[::20]).std()), 1)
    1.5
    >>> bool(np.shares_memory(data.imu_input(), data.omega_b))  # the IMU input is a view, not a copy
    True
    >>> try:
    ...     generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=3.0, noise=noise, seed=0)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError gnss_rate_hz=3 must divide imu_rate_hz=100 (fixes must fall on IMU samples)
    """
    imu = positive("imu_rate_hz", imu_rate_hz)
    gnss = positive("gnss_rate_hz", gnss_rate_hz)
    ratio = imu / gnss
    step = int(round(ratio))
    if step < 1 or abs(ratio - step) > 1e-9 * ratio:
        raise InvalidArgumentError(
            f"gnss_rate_hz={gnss:g} must divide imu_rate_hz={imu:g} (fixes must fall on IMU samples)")
    t = as_vector("traj.t", traj.t)
    if t.size < 2:
        raise InvalidArgumentError("traj: needs at least two samples")
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0))
        raise InvalidArgumentError(f"traj.t: times must increase (t[{k + 1}] = {t[k + 1]:g} ≤ t[{k}] = {t[k]:g})")
    if np.max(np.abs(dt - 1.0 / imu)) > 1e-9 * max(1.0, float(t[-1])):
        raise InvalidArgumentError(
            f"traj: sampled every {float(np.median(dt)):g} s but imu_rate_hz={imu:g} needs {1 / imu:g} s "
            "(use flight.sample(imu_rate_hz))")
    for name in ("p", "v", "R", "omega_b", "a_b", "m_b", "m_n", "g_n"):
        arr = np.asarray(getattr(traj, name))
        if not np.all(np.isfinite(arr)):
            raise NonFiniteError(f"traj.{name} has non-finite entries")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    shape: tuple[int, ...] = () if batch is None else (int(batch),)
    if batch is not None and batch < 1:
        raise InvalidArgumentError(f"batch: must be a positive integer, got {batch!r}")
    K = t.size
    idx = np.arange(0, K, step)

    def noisy(out: Array, x: Array, std: float, bias: Sequence[float] = (0.0, 0.0, 0.0)) -> Array:
        out[...] = x + np.asarray(bias)
        if std > 0:
            out += std * rng.standard_normal(out.shape)
        return out

    # the streams lie side by side in one buffer each: SensorData.imu_input() and gnss_output() are views
    imu_buf = np.empty((*shape, K, 9))
    gnss_buf = np.empty((*shape, idx.size, 3 if position_only else 6))
    return SensorData(
        t_imu=t.copy(),
        omega_b=noisy(imu_buf[..., 0:3], traj.omega_b, noise.gyro_std, noise.gyro_bias),
        a_b=noisy(imu_buf[..., 3:6], traj.a_b, noise.accel_std, noise.accel_bias),
        m_b=noisy(imu_buf[..., 6:9], traj.m_b, noise.mag_std),
        t_gnss=t[idx].copy(),
        p_gnss=noisy(gnss_buf[..., 0:3], traj.p[idx], noise.gnss_p_std),
        v_gnss=None if position_only else noisy(gnss_buf[..., 3:6], traj.v[idx], noise.gnss_v_std),
        m_n=np.array(traj.m_n, dtype=float),
        g_n=np.array(traj.g_n, dtype=float),
        p=traj.p.copy(),
        v=traj.v.copy(),
        R=traj.R.copy(),
        imu_rate_hz=imu,
        gnss_rate_hz=gnss,
    )


def drop_fixes(data: SensorData, fixes: ArrayLike, *, batch_index: int | None = None) -> SensorData:
    """Mark GNSS fixes as missing (NaN), e.g. to test outage handling.

    Parameters
    ----------
    fixes : array_like of int
        Indices into ``data.t_gnss``.
    batch_index : int, optional
        Only this batch member loses the fixes (default: all members).

    Examples
    --------
    Two flights of 10 s with fixes at 5 Hz; the second loses fixes 3 and 4 (a 0.4 s outage), the first
    keeps all of them, and the data given is not changed:

    >>> import numpy as np
    >>> from nlobs.navigation.trajectory import traffic_pattern
    >>> traj = traffic_pattern(seed=0, duration=10.0).sample(100.0)
    >>> data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=SensorNoise(gnss_p_std=1.5),
    ...                         seed=0, batch=2)
    >>> outage = drop_fixes(data, [3, 4], batch_index=1)
    >>> missing = np.isnan(outage.gnss_output()).any(axis=-1)  # (flights, fixes)
    >>> missing.sum(axis=-1).tolist(), np.flatnonzero(missing[1]).tolist(), outage.t_gnss[[3, 4]].tolist()
    ([0, 2], [3, 4], [0.6, 0.8])
    >>> bool(np.isnan(data.p_gnss).any())
    False
    """
    idx = np.asarray(as_finite_array("fixes", fixes), dtype=int).ravel()
    if idx.size and (idx.min() < 0 or idx.max() >= data.t_gnss.size):
        raise InvalidArgumentError(f"fixes: indices must lie in [0, {data.t_gnss.size - 1}]")
    sel = (Ellipsis,) if batch_index is None else (batch_index,)

    def blank(a: Array | None) -> Array | None:
        if a is None:
            return None
        out = a.copy()
        out[sel + (idx, slice(None))] = np.nan
        return out

    return replace(data, p_gnss=blank(data.p_gnss), v_gnss=blank(data.v_gnss))
