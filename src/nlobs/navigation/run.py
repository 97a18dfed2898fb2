"""Run a navigation filter on sampled sensor data: a thin call of :func:`nlobs.simulate.run_observer`.

:func:`run_navigation` checks a :class:`~nlobs.navigation.base.SensorData` record, lays it out in
the channels of :mod:`nlobs.navigation.base` (IMU input ``u`` of 9 channels at every IMU instant,
GNSS output ``y = [p, v]`` at the fix instants, truth ``[p, v, R]``) and runs the filter, a
:class:`~nlobs.observers.base.CorrectingObserver` (the GNSS/INS observer (24) of Grip, Saberi &
Johansen, the EKF baseline), through the one recorded-data loop of nlobs. At each IMU instant
``t_k``:

1. if a GNSS fix is time-stamped ``t_k``: ``z ← filt.correct(t_k, z, u_k, y, fresh)``;
2. the estimate at ``t_k`` is recorded (after the correction);
3. ``z ← filt.step(t_k, z, u_k, y, t_{k+1} − t_k)`` with the IMU sample at ``t_k`` held
   (not after the last sample).

Everything is batched: the sensor streams may carry leading batch axes (noise realisations) and
so may ``p0, v0, R0`` (e.g. a different initial attitude error per Monte Carlo flight); they are
broadcast to one batch shape.

Data rules (checked before the loop):

* IMU times strictly increasing and uniform at ``imu_rate_hz`` (to 10⁻⁶ of a period);
* every GNSS time on the IMU grid (to 10⁻⁶ of an IMU period) and strictly
  increasing, else :class:`~nlobs.errors.InvalidArgumentError` naming the fix;
* a non-finite IMU sample raises :class:`~nlobs.errors.NonFiniteError` naming its time;
* a GNSS fix with any non-finite entry (per batch member) is **skipped**: the filter keeps its
  previous information, and the fix is counted in ``info["skipped_fixes"]``.

The result is a :class:`~nlobs.simulate.SimulationResult` (estimates and truth as navigation
vectors, :data:`~nlobs.navigation.base.NAV_STATES`); its navigation metrics are the functions of
:mod:`nlobs.navigation.metrics`. ``info["cost_per_step_us"]`` is the wall time spent inside the
filter's ``correct`` and ``step`` (not ``estimate``, not recording) divided by the number of IMU
steps and by the number of flights in the batch: the cost of one IMU step of one flight,
amortised over the vectorised batch.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, IntArray
from nlobs._validate import as_batch, as_finite_array, as_real_array, positive
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.navigation.base import GNSS_OUTPUTS, GNSS_OUTPUTS_P, NAV_STATES, SensorData, nav_vector
from nlobs.observers.base import CorrectingObserver
from nlobs.simulate.replay import run_observer
from nlobs.simulate.result import SimulationResult

__all__ = ["run_navigation"]


# --------------------------------------------------------------------- checks
def _check_imu(data: SensorData) -> tuple[Array, tuple[int, ...]]:
    t = as_finite_array("data.t_imu", data.t_imu, ndim=1)
    K = t.shape[0]
    if K < 2:
        raise DimensionError(f"data.t_imu: need at least 2 IMU samples, got {K}")
    rate = positive("data.imu_rate_hz", data.imu_rate_hz)
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0)) + 1
        raise InvalidArgumentError(f"data.t_imu: not strictly increasing at sample {k} (t = {t[k]:.9g} s)")
    dev = np.abs(dt - 1.0 / rate)
    if np.any(dev > 1e-6 / rate):
        k = int(np.argmax(dev > 1e-6 / rate)) + 1
        raise InvalidArgumentError(
            f"data.t_imu: not uniform at {rate:g} Hz: step {dt[k - 1]:.9g} s before sample {k} (t = {t[k]:.9g} s)")
    batches: list[tuple[int, ...]] = []
    for name in ("omega_b", "a_b", "m_b"):
        arr = as_real_array(f"data.{name}", getattr(data, name))
        if arr.ndim < 2 or arr.shape[-2:] != (K, 3):
            raise DimensionError(f"data.{name}: expected shape (..., {K}, 3), got {arr.shape}")
        finite = np.isfinite(arr).all(axis=-1)  # (..., K)
        if not finite.all():
            k = int(np.argmax(~finite.reshape(-1, K).all(axis=0)))
            raise NonFiniteError(f"data.{name}: IMU sample at t = {t[k]:.6g} s (index {k}) is not finite")
        batches.append(arr.shape[:-2])
    try:
        return t, tuple(np.broadcast_shapes(*batches))
    except ValueError:
        raise DimensionError(f"data: IMU batch shapes {batches} do not broadcast") from None


def _check_gnss(data: SensorData, t: Array) -> tuple[IntArray, tuple[int, ...]]:
    tg = as_finite_array("data.t_gnss", data.t_gnss, ndim=1)
    G = tg.shape[0]
    rate = float(data.imu_rate_hz)
    positive("data.gnss_rate_hz", data.gnss_rate_hz)
    if G > 1 and np.any(np.diff(tg) <= 0):
        i = int(np.argmax(np.diff(tg) <= 0)) + 1
        raise InvalidArgumentError(
            f"data.t_gnss: fix {i} at t = {tg[i]:.9g} s is out of order (previous fix at {tg[i - 1]:.9g} s)")
    idx = np.rint((tg - t[0]) * rate).astype(np.intp)
    clipped = np.clip(idx, 0, t.shape[0] - 1)
    off = (idx != clipped) | (np.abs(t[clipped] - tg) > 1e-6 / rate)
    if np.any(off):
        i = int(np.argmax(off))
        raise InvalidArgumentError(
            f"data.t_gnss: fix {i} at t = {tg[i]:.9g} s is not on the IMU grid "
            f"(nearest IMU sample t = {t[clipped[i]]:.9g} s; fixes must coincide with IMU samples)")
    batches: list[tuple[int, ...]] = []
    for name in ("p_gnss", "v_gnss"):
        val = getattr(data, name)
        if val is None:
            continue
        arr = as_real_array(f"data.{name}", val)
        if arr.ndim < 2 or arr.shape[-2:] != (G, 3):
            raise DimensionError(f"data.{name}: expected shape (..., {G}, 3), got {arr.shape}")
        batches.append(arr.shape[:-2])
    try:
        return clipped, tuple(np.broadcast_shapes(*batches))
    except ValueError:
        raise DimensionError(f"data: GNSS batch shapes {batches} do not broadcast") from None


# ----------------------------------------------------------------------- loop
def run_navigation(filt: CorrectingObserver[object], data: SensorData, p0: ArrayLike, v0: ArrayLike, R0: ArrayLike,
                   *, progress: bool | None = False) -> SimulationResult:
    """Run ``filt`` on ``data`` from the initial estimates ``(p0, v0, R0)`` (module docstring).

    Parameters
    ----------
    filt : CorrectingObserver
        A navigation filter with ``n_x = 15``: e.g.
        :class:`~nlobs.navigation.gnss_ins.GnssInsObserver` or
        :class:`~nlobs.navigation.ekf.ExtendedKalmanFilter`.
    data : SensorData
        Sensor streams (possibly batched) and the truth.
    p0, v0 : array_like, shape (..., 3)
        Initial position and velocity estimates.
    R0 : array_like, shape (..., 3, 3)
        Initial attitude estimate.
    progress : bool or None
        Progress bar on stderr (``None``: automatically for long runs on a terminal).

    Returns
    -------
    SimulationResult
        ``x_hat`` and ``x`` are navigation vectors ``[p, v, R]`` on the IMU grid; ``extras`` hold
        the filter's diagnostics (observer (24): ``R_raw``, ``z_hat``); ``info`` adds to
        :func:`~nlobs.simulate.run_observer`'s ``skipped_fixes`` (per flight), ``n_fixes``,
        ``imu_rate_hz`` and ``gnss_rate_hz``.

    Raises
    ------
    InvalidArgumentError
        ``filt`` is not a correcting observer of 15 states; IMU times not uniform/increasing;
        GNSS times off the IMU grid or out of order.
    NonFiniteError
        A non-finite IMU sample (the message names its time) or initial estimate.
    DimensionError
        Inconsistent shapes.
    SimulationDiverged
        The estimate became non-finite (the time and component are named).

    Examples
    --------
    The first 10 s of the traffic pattern of Grip, Saberi & Johansen (Sec. 5.2) with noisy sensors (IMU at
    100 Hz, GNSS at 5 Hz, three fixes lost), observer (24) with the paper's gains started 30° off in yaw at
    the first fix: the lost fixes are skipped and counted, and the attitude error falls below 2°:

    >>> import math
    >>> import nlobs
    >>> from nlobs.navigation import SensorNoise, drop_fixes, generate_sensors, metrics, traffic_pattern
    >>> from nlobs.navigation.so3 import rot_z
    >>> traj = traffic_pattern(seed=0, duration=10.0).sample(100.0)
    >>> noise = SensorNoise(gyro_std=0.002, accel_std=0.05, mag_std=0.01, gnss_p_std=1.5, gnss_v_std=0.1)
    >>> data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=noise, seed=1)
    >>> data = drop_fixes(data, [10, 11, 12])
    >>> observer = nlobs.GnssInsObserver.paper(data.m_n, data.g_n)
    >>> R0 = rot_z(math.radians(30.0)) @ data.R[0]
    >>> res = run_navigation(observer, data, data.p_gnss[0], data.v_gnss[0], R0)
    >>> res.x_hat.shape, res.states[6], res.info["n_fixes"], int(res.info["skipped_fixes"])
    ((1001, 15), 'R11', 51, 3)
    >>> attitude = metrics.attitude_error_deg(res)
    >>> round(float(attitude[0]), 3), bool(attitude[-1] < 2.0)
    (30.0, True)
    """
    if not isinstance(filt, CorrectingObserver) or getattr(filt, "n_x", None) != len(NAV_STATES):
        raise InvalidArgumentError(f"filt: {type(filt).__name__} is not a navigation filter (a CorrectingObserver "
                                   f"with n_x = 15: time, n_x, init, rhs, correct, estimate)")
    t, imu_batch = _check_imu(data)
    gidx, gnss_batch = _check_gnss(data, t)
    p0_ = as_batch("p0", p0, 3)
    v0_ = as_batch("v0", v0, 3)
    R0_ = as_finite_array("R0", R0)
    if R0_.ndim < 2 or R0_.shape[-2:] != (3, 3):
        raise DimensionError(f"R0: expected shape (..., 3, 3), got {R0_.shape}")
    try:
        np.broadcast_shapes(imu_batch, gnss_batch, p0_.shape[:-1], v0_.shape[:-1], R0_.shape[:-2])
    except ValueError:
        raise DimensionError(
            f"batch shapes do not broadcast: IMU {imu_batch}, GNSS {gnss_batch}, p0 {p0_.shape[:-1]}, "
            f"v0 {v0_.shape[:-1]}, R0 {R0_.shape[:-2]}") from None
    K, G = t.shape[0], gidx.shape[0]
    for name, shape in (("p", (K, 3)), ("v", (K, 3)), ("R", (K, 3, 3))):
        if np.shape(getattr(data, name)) != shape:
            raise DimensionError(f"data.{name} (truth): expected shape {shape}, got {np.shape(getattr(data, name))}")
    res = run_observer(
        filt, t, x_hat0=nav_vector(p0_, v0_, R0_), u=data.imu_input(), y=data.gnss_output(), y_times=t[gidx],
        truth=data.truth(), states=NAV_STATES, estimates=NAV_STATES,
        outputs=GNSS_OUTPUTS_P if data.v_gnss is None else GNSS_OUTPUTS, progress=progress,
    )
    info = dict(res.info)
    info.update(skipped_fixes=np.asarray(info["missing"], dtype=np.int64), n_fixes=int(G),
                imu_rate_hz=float(data.imu_rate_hz), gnss_rate_hz=float(data.gnss_rate_hz))
    return replace(res, info=info)
