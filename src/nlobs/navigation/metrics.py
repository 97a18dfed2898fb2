"""Navigation metrics: functions of the :class:`~nlobs.simulate.SimulationResult` of a navigation run.

A navigation run (:func:`nlobs.navigation.run.run_navigation`, or
:func:`nlobs.simulate.run_observer` with the channel layouts of :mod:`nlobs.navigation.base`)
records the estimate ``x̂ = [p̂, v̂, R̂]`` (15 components, ``R̂`` row-major) and the truth
``x = [p, v, R]`` on the IMU grid, the raw ``R̂`` of observer (24) (extra ``R_raw``) and its ``ẑ``
(extra ``z_hat``), and in ``info`` the GNSS bookkeeping (``skipped_fixes`` per flight, ``n_fixes``,
``imu_rate_hz``, ``gnss_rate_hz``) and the cost (``cost_per_step_us``). This module reads them:

* accessors: :func:`p_hat`, :func:`v_hat`, :func:`R_hat` (estimates), :func:`p`, :func:`v`,
  :func:`R` (truth), :func:`R_raw`, :func:`z_hat` (extras, ``None`` when not recorded);
* errors along the flight: :func:`position_error_m`, :func:`velocity_error_mps`,
  :func:`attitude_error_deg` (geodesic angle between ``R̂`` and ``R``);
* convergence and accuracy: :func:`converge_s`, :func:`position_rms_m`, :func:`velocity_rms_mps`,
  :func:`attitude_rms_deg`, and :func:`summary_dict` (the demo's JSON row).

Every function is batched: a result of a batch of flights gives arrays with that batch shape.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nlobs._typing import Array, BoolArray
from nlobs._validate import in_range, positive
from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.navigation.base import NAV_P, NAV_R, NAV_V
from nlobs.navigation.so3 import angle_between
from nlobs.simulate.result import SimulationResult

__all__ = [
    "DEFAULT_CONVERGE_DEG", "R", "R_hat", "R_raw", "attitude_error_deg", "attitude_rms_deg", "converge_s", "p",
    "navigation_consistency", "navigation_error_state", "p_hat", "position_error_m", "position_rms_m",
    "summary_dict", "v", "v_hat", "velocity_error_mps", "velocity_rms_mps", "z_hat",
]

#: Attitude-error threshold [deg] defining :func:`converge_s` by default.
DEFAULT_CONVERGE_DEG = 2.0


def _nav(arr: Array, what: str) -> Array:
    if arr.shape[-1] != 15:
        raise DimensionError(f"{what}: a navigation run has 15 components [p, v, R], got {arr.shape[-1]}")
    return arr


def _est(res: SimulationResult) -> Array:
    return _nav(res.x_hat, "x_hat")


def _truth(res: SimulationResult) -> Array:
    if res.x is None:
        raise InvalidArgumentError("this result has no truth (x is None): navigation errors are undefined")
    return _nav(res.x, "x")


def _matrix(a: Array) -> Array:
    return a[..., NAV_R].reshape(*a.shape[:-1], 3, 3)


# ------------------------------------------------------------------ accessors
def p_hat(res: SimulationResult) -> Array:
    """Estimated position ``p̂`` [m] (NED), shape ``(..., K, 3)``.

    Parameters
    ----------
    res : SimulationResult
        A navigation run.
    """
    return _est(res)[..., NAV_P]


def v_hat(res: SimulationResult) -> Array:
    """Estimated velocity ``v̂`` [m/s] (NED), shape ``(..., K, 3)``.

    Parameters
    ----------
    res : SimulationResult
        A navigation run.
    """
    return _est(res)[..., NAV_V]


def R_hat(res: SimulationResult) -> Array:
    """Estimated attitude (body → NED), shape ``(..., K, 3, 3)``: a rotation (observer (24): ``R̂`` projected).

    Parameters
    ----------
    res : SimulationResult
        A navigation run.
    """
    return _matrix(_est(res))


def p(res: SimulationResult) -> Array:
    """True position [m], shape ``(K, 3)`` (or with the truth's batch shape).

    Parameters
    ----------
    res : SimulationResult
        A navigation run.

    Raises
    ------
    InvalidArgumentError
        The result has no truth (``res.x`` is None).
    """
    return _truth(res)[..., NAV_P]


def v(res: SimulationResult) -> Array:
    """True velocity [m/s], shape ``(K, 3)`` (or with the truth's batch shape).

    Parameters
    ----------
    res : SimulationResult
        A navigation run.

    Raises
    ------
    InvalidArgumentError
        The result has no truth (``res.x`` is None).
    """
    return _truth(res)[..., NAV_V]


def R(res: SimulationResult) -> Array:
    """True attitude, shape ``(K, 3, 3)`` (or with the truth's batch shape).

    Parameters
    ----------
    res : SimulationResult
        A navigation run.

    Raises
    ------
    InvalidArgumentError
        The result has no truth (``res.x`` is None).
    """
    return _matrix(_truth(res))


def R_raw(res: SimulationResult) -> Array | None:
    """The raw ``R̂`` of observer (24d) (not a rotation in general), ``(..., K, 3, 3)``; ``None`` if not recorded.

    Parameters
    ----------
    res : SimulationResult
        A navigation run.
    """
    return res.extras.get("R_raw")


def z_hat(res: SimulationResult) -> Array | None:
    """Observer (24)'s ``ẑ = R̂ a^b + ξ`` (estimate of ``aⁿ``) [m/s²], ``(..., K, 3)``; ``None`` if not recorded.

    Parameters
    ----------
    res : SimulationResult
        A navigation run.
    """
    return res.extras.get("z_hat")


# --------------------------------------------------------------------- errors
def position_error_m(res: SimulationResult) -> Array:
    """``‖p̂ − p‖`` [m], shape ``(..., K)``.

    Parameters
    ----------
    res : SimulationResult
        A navigation run.

    Raises
    ------
    InvalidArgumentError
        The result has no truth (``res.x`` is None).
    """
    return np.linalg.norm(p_hat(res) - p(res), axis=-1)


def velocity_error_mps(res: SimulationResult) -> Array:
    """``‖v̂ − v‖`` [m/s], shape ``(..., K)``.

    Parameters
    ----------
    res : SimulationResult
        A navigation run.

    Raises
    ------
    InvalidArgumentError
        The result has no truth (``res.x`` is None).
    """
    return np.linalg.norm(v_hat(res) - v(res), axis=-1)


def attitude_error_deg(res: SimulationResult) -> Array:
    """Geodesic angle between ``R̂`` (projected) and ``R`` [deg], shape ``(..., K)``.

    Parameters
    ----------
    res : SimulationResult
        A navigation run.

    Raises
    ------
    InvalidArgumentError
        The result has no truth (``res.x`` is None).
    """
    return np.degrees(angle_between(R_hat(res), R(res)))


def converge_s(res: SimulationResult, threshold_deg: float = DEFAULT_CONVERGE_DEG) -> Array:
    """First time after which the attitude error stays below ``threshold_deg`` for good.

    ``t[k*]`` with ``k*`` the smallest index such that the error is ``< threshold_deg`` at every
    ``t[k] ≥ t[k*]``; ``t[0]`` if it always is, NaN if it is not below at the last sample.
    Shape ``(...)``.

    Parameters
    ----------
    res : SimulationResult
        A navigation run (with its truth).
    threshold_deg : float, optional
        Attitude-error threshold [deg] (default :data:`DEFAULT_CONVERGE_DEG`, 2°).

    Raises
    ------
    InvalidArgumentError
        ``threshold_deg`` is not positive.
    """
    thr = positive("threshold_deg", threshold_deg)
    bad = attitude_error_deg(res) >= thr
    K = res.t.shape[0]
    # index of the last bad sample (−1 if none)
    last_bad = np.where(bad.any(axis=-1), K - 1 - np.argmax(bad[..., ::-1], axis=-1), -1)
    idx = last_bad + 1
    out = np.where(idx < K, res.t[np.minimum(idx, K - 1)], np.nan)
    return np.asarray(out, dtype=float)


def _window(res: SimulationResult, after: float | None, threshold_deg: float) -> BoolArray:
    if after is None:
        start = converge_s(res, threshold_deg)
    else:
        start = np.full(res.batch_shape, in_range("after", after, -np.inf, np.inf, hi_open=True))
    return res.t >= np.asarray(start)[..., None]  # NaN start → empty window


def _rms(err: Array, mask: BoolArray) -> Array:
    n = mask.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, np.sqrt(np.sum(np.where(mask, err**2, 0.0), axis=-1) / np.maximum(n, 1)), np.nan)


def position_rms_m(res: SimulationResult, after: float | None = None,
                   threshold_deg: float = DEFAULT_CONVERGE_DEG) -> Array:
    """RMS of ``‖p̂ − p‖`` [m] over ``t ≥ after`` (default: ``t ≥ converge_s(res, threshold_deg)``), shape ``(...)``.

    NaN when the window is empty (never converged).

    Parameters
    ----------
    res : SimulationResult
        A navigation run (with its truth).
    after : float or None, optional
        Start of the window [s] on the run's clock; ``None``: each flight's :func:`converge_s`.
    threshold_deg : float, optional
        Attitude-error threshold [deg] of :func:`converge_s` when ``after`` is None.
    """
    return _rms(position_error_m(res), _window(res, after, threshold_deg))


def velocity_rms_mps(res: SimulationResult, after: float | None = None,
                     threshold_deg: float = DEFAULT_CONVERGE_DEG) -> Array:
    """RMS of ``‖v̂ − v‖`` [m/s] over the same window as :func:`position_rms_m`.

    Parameters
    ----------
    res : SimulationResult
        A navigation run (with its truth).
    after : float or None, optional
        Start of the window [s] on the run's clock; ``None``: each flight's :func:`converge_s`.
    threshold_deg : float, optional
        Attitude-error threshold [deg] of :func:`converge_s` when ``after`` is None.
    """
    return _rms(velocity_error_mps(res), _window(res, after, threshold_deg))


def attitude_rms_deg(res: SimulationResult, after: float | None = None,
                     threshold_deg: float = DEFAULT_CONVERGE_DEG) -> Array:
    """RMS of the geodesic attitude error [deg] over the same window as :func:`position_rms_m`.

    Parameters
    ----------
    res : SimulationResult
        A navigation run (with its truth).
    after : float or None, optional
        Start of the window [s] on the run's clock; ``None``: each flight's :func:`converge_s`.
    threshold_deg : float, optional
        Attitude-error threshold [deg] of :func:`converge_s` when ``after`` is None.
    """
    return _rms(attitude_error_deg(res), _window(res, after, threshold_deg))


def summary_dict(res: SimulationResult, after: float | None = None,
                 threshold_deg: float = DEFAULT_CONVERGE_DEG) -> dict[str, Any]:
    """The metrics of a run: ``filter``, ``position_rms_m``, ``velocity_rms_mps``, ``attitude_rms_deg``,
    ``converge_s``, ``cost_per_step_us``, ``skipped_fixes``, ``n_fixes``, ``after``, ``threshold_deg``.

    Per-flight metrics are floats for a single flight and (nested) lists for a batch. ``filter``
    is the observer's name; ``cost_per_step_us``, ``skipped_fixes`` and ``n_fixes`` come from
    ``res.info`` (:func:`~nlobs.navigation.run.run_navigation` puts them there).

    Parameters
    ----------
    res : SimulationResult
        A navigation run (with its truth).
    after : float or None, optional
        Start of the window [s] on the run's clock; ``None``: each flight's :func:`converge_s`.
    threshold_deg : float, optional
        Attitude-error threshold [deg] of :func:`converge_s` (and of the window when ``after`` is None).

    Returns
    -------
    dict
        The metrics by name (the demo's JSON row).

    Raises
    ------
    InvalidArgumentError
        The result has no truth, or its ``info`` lacks the GNSS bookkeeping.

    Examples
    --------
    The navigation EKF on the first 10 s of the traffic pattern with noisy sensors (three GNSS fixes lost),
    started 30° off in yaw: its attitude error stays below 2° from 1 s on, and the RMS errors are taken from
    there (``cost_per_step_us`` is a measured time, so it is left out here):

    >>> import math
    >>> import nlobs
    >>> from nlobs.navigation import EkfConfig, SensorNoise, drop_fixes, generate_sensors, traffic_pattern
    >>> from nlobs.navigation.so3 import rot_z
    >>> traj = traffic_pattern(seed=0, duration=10.0).sample(100.0)
    >>> noise = SensorNoise(gyro_std=0.002, accel_std=0.05, mag_std=0.01, gnss_p_std=1.5, gnss_v_std=0.1)
    >>> data = drop_fixes(generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=noise, seed=1),
    ...                   [10, 11, 12])
    >>> ekf = nlobs.ExtendedKalmanFilter(EkfConfig.for_noise(noise), data.m_n, data.g_n)
    >>> res = nlobs.navigation.run_navigation(ekf, data, data.p_gnss[0], data.v_gnss[0],
    ...                                       rot_z(math.radians(30.0)) @ data.R[0])
    >>> row = summary_dict(res)
    >>> sorted(row)
    ['after', 'attitude_rms_deg', 'converge_s', 'cost_per_step_us', 'filter', 'n_fixes', 'position_rms_m',
     'skipped_fixes', 'threshold_deg', 'velocity_rms_mps']
    >>> row["filter"], row["converge_s"], row["threshold_deg"], row["skipped_fixes"], row["n_fixes"]
    ('ekf', 1.0, 2.0, 3, 51)
    >>> round(row["position_rms_m"], 2), round(row["velocity_rms_mps"], 3), round(row["attitude_rms_deg"], 2)
    (0.47, 0.068, 0.3)
    """

    def py(a: Any) -> Any:
        a = np.asarray(a)
        return float(a) if a.ndim == 0 and a.dtype.kind == "f" else a.tolist()

    missing = [k for k in ("cost_per_step_us", "skipped_fixes", "n_fixes") if k not in res.info]
    if missing:
        raise InvalidArgumentError(f"summary_dict: res.info lacks {missing} (run it with run_navigation)")
    return {
        "filter": res.observer,
        "position_rms_m": py(position_rms_m(res, after, threshold_deg)),
        "velocity_rms_mps": py(velocity_rms_mps(res, after, threshold_deg)),
        "attitude_rms_deg": py(attitude_rms_deg(res, after, threshold_deg)),
        "converge_s": py(converge_s(res, threshold_deg)),
        "cost_per_step_us": float(res.info["cost_per_step_us"]),
        "skipped_fixes": py(res.info["skipped_fixes"]),
        "n_fixes": int(res.info["n_fixes"]),
        "after": after,
        "threshold_deg": float(threshold_deg),
    }


def navigation_error_state(res: SimulationResult) -> Array:
    """The error in the navigation EKF's error-state coordinates: ``[p − p̂, v − v̂, log(R̂ᵀ R)]``, shape
    ``(..., K, 9)`` (the filter's attitude error ``δθ`` is defined by ``R = R̂ exp(S(δθ))``, as it injects it).

    Parameters
    ----------
    res : SimulationResult
        A navigation run with its truth.

    Returns
    -------
    ndarray
    """
    from nlobs.navigation.so3 import log_so3

    Rh, Rt = R_hat(res), R(res)
    dtheta = log_so3(np.swapaxes(Rh, -1, -2) @ Rt)
    return np.concatenate([p(res) - p_hat(res), v(res) - v_hat(res), dtheta], axis=-1)


def navigation_consistency(res: SimulationResult, data: Any, *, level: float = 0.95) -> Any:
    """NEES of the navigation EKF's 9-dimensional error state and NIS of its GNSS fixes against the χ² band
    (:func:`nlobs.simulate.consistency.error_consistency`); ``None`` for a run that recorded neither.

    The NEES needs the whole covariance (``ExtendedKalmanFilter(record_covariance=True)``); without it only the
    NIS is reported. A run of generated C records no NIS (its state does not carry it): the NEES alone.

    Parameters
    ----------
    res : SimulationResult
        A run of :func:`~nlobs.navigation.run.run_navigation` with the EKF's diagnostics (every IMU step saved).
    data : SensorData
        The sensor record it ran on: its GNSS fixes are the instants of the NIS (a missing fix is not counted).
    level : float
        Probability inside the band.

    Returns
    -------
    Consistency or None
    """
    from nlobs.simulate.consistency import error_consistency

    has_nis = "nis" in res.extras
    if res.x is None or not (has_nis or "P" in res.extras):
        return None
    e = navigation_error_state(res)
    fixes = np.asarray(data.gnss_output(), dtype=float)  # (..., G, q)
    K = res.t.shape[0]
    rows = np.rint((np.asarray(data.t_gnss, dtype=float) - res.t[0]) * float(data.imu_rate_hz)).astype(np.intp)
    if rows.size and (rows.min() < 0 or rows.max() >= K):
        raise InvalidArgumentError("data: its GNSS fixes are not on the run's saved instants")
    y = np.full((*fixes.shape[:-2], K, fixes.shape[-1]), np.nan)
    y[..., rows, :] = fixes
    sampled = np.zeros((K, fixes.shape[-1]), dtype=bool)
    sampled[rows] = True
    if not has_nis:  # generated C: the NEES alone
        return error_consistency(res.t, e, res.extras["P"], np.zeros(e.shape[:-1]), None, None, level=level)
    return error_consistency(res.t, e, res.extras.get("P"), res.extras["nis"], sampled, y, level=level)
