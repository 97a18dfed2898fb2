"""Run a navigation filter on sampled sensor data: the multi-rate loop, its result and metrics.

The loop (:func:`run_navigation`) is the sampled-data scheme of the ``NavFilter``
protocol (:mod:`nlobs.navigation.base`): at each IMU instant ``t_k``

1. if a GNSS fix is time-stamped ``t_k``, ``state = filt.update(state, fix)``;
2. the estimate at ``t_k`` is recorded (after the update);
3. ``state = filt.propagate(state, imu_k, t_{k+1} − t_k)`` with the IMU sample at
   ``t_k`` held (not after the last sample).

Everything is batched: the sensor streams may carry leading batch axes (noise
realisations) and so may ``p0, v0, R0`` (e.g. a different initial attitude error
per Monte Carlo flight); they are broadcast to one batch shape.

Data rules (checked before the loop):

* IMU times strictly increasing and uniform at ``imu_rate_hz`` (to 10⁻⁶ of a period);
* every GNSS time on the IMU grid (to 10⁻⁶ of an IMU period) and strictly
  increasing, else :class:`~nlobs.errors.InvalidArgumentError` naming the fix;
* a non-finite IMU sample raises :class:`~nlobs.errors.NonFiniteError` naming its time;
* a GNSS fix with any non-finite entry (per batch member) is **skipped**: it is
  passed with ``valid = False`` (the filter keeps its previous information) and
  counted in :attr:`NavResult.skipped_fixes`.

Timing: :attr:`NavResult.cost_per_step_us` is the wall time spent inside
``filt.update`` and ``filt.propagate`` (not ``estimate``, not recording) divided by
the number of IMU steps and by the number of flights in the batch — the
cost of one IMU step of one flight, amortised over the vectorised batch.

Deferred projection: a filter whose estimate is a projection of a raw attitude
(the seed-001 observer: ``R̂`` onto SO(3)) may provide ``raw_estimate(state)``
(a :class:`~nlobs.navigation.base.NavEstimate` with the raw ``R``) and
``project_attitude(R_raw)`` (batched over any leading axes) such that
``estimate(state)`` equals ``raw_estimate(state)`` with ``project_attitude``
applied to ``R``. The loop then records the raw attitudes (they become
:attr:`NavResult.R_raw`) and projects the whole record in one call at the end,
instead of one projection per step: the per-step projection (an SVD per flight)
cost more than the observer itself in batched Monte Carlo runs.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._io import atomic_write
from nlobs._validate import as_batch, as_finite_array, in_range, positive
from nlobs.errors import (
    DimensionError,
    InvalidArgumentError,
    NonFiniteError,
    SimulationDiverged,
)
from nlobs.navigation.base import GnssSample, ImuSample, NavFilter, SensorData
from nlobs.navigation.so3 import angle_between

Array = NDArray[np.float64]

__all__ = ["DEFAULT_CONVERGE_DEG", "FORMAT_VERSION", "NavResult", "run_navigation"]

#: Attitude-error threshold [deg] defining :meth:`NavResult.converge_s` by default.
DEFAULT_CONVERGE_DEG = 2.0

#: Version of the ``.npz`` layout written by :meth:`NavResult.save`.
FORMAT_VERSION = 1

_OPTIONAL = ("R_raw", "z_hat")


def _ro(a: Any) -> Any:
    """A read-only array: ``a`` itself if it already is one that owns its memory (no copy), else a copy."""
    if a is None:
        return None
    if isinstance(a, np.ndarray) and a.flags.owndata and not a.flags.writeable:
        return a
    out = np.array(a)
    out.setflags(write=False)
    return out


def _frozen(a: Array | None) -> Array | None:
    """``a`` (an array this module allocated, or a new one from ``project_attitude``) made read-only when
    it owns its memory, so :class:`NavResult` keeps it without a copy."""
    if a is not None and a.flags.owndata:
        a.setflags(write=False)
    return a


@dataclass(frozen=True)
class NavResult:
    """Estimates of a navigation filter along a flight, with the truth and metrics.

    Attributes
    ----------
    t : (K,)
        IMU times [s]; estimates are recorded at ``t[k]`` after any GNSS update.
    p_hat, v_hat : (..., K, 3)
        Estimated position [m] and velocity [m/s] (NED).
    R_hat : (..., K, 3, 3)
        Estimated attitude, a rotation matrix (the observer's ``R̂`` projected onto SO(3)).
    p, v : (K, 3); R : (K, 3, 3)
        The truth.
    filter_name : str
    skipped_fixes : (...) int
        GNSS fixes skipped because non-finite (per flight).
    n_fixes : int
        GNSS fixes in the data.
    cost_per_step_us : float
        Filter wall time per IMU step per flight [µs] (see module docstring).
    wall_s : float
        Filter wall time of the whole run (all flights) [s].
    imu_rate_hz, gnss_rate_hz : float
    R_raw : (..., K, 3, 3) or None
        The observer's raw ``R̂`` (not a rotation in general), if the filter exposes it.
    z_hat : (..., K, 3) or None
        The observer's ``ẑ = R̂ a^b + ξ`` (estimate of ``aⁿ``), if exposed.

    All arrays are read-only.
    """

    t: Array
    p_hat: Array
    v_hat: Array
    R_hat: Array
    p: Array
    v: Array
    R: Array
    filter_name: str
    skipped_fixes: NDArray[np.int64]
    n_fixes: int
    cost_per_step_us: float
    wall_s: float
    imu_rate_hz: float
    gnss_rate_hz: float
    R_raw: Array | None = None
    z_hat: Array | None = None

    def __post_init__(self) -> None:
        for name in ("t", "p_hat", "v_hat", "R_hat", "p", "v", "R", "skipped_fixes", *_OPTIONAL):
            object.__setattr__(self, name, _ro(getattr(self, name)))
        K = self.t.shape[0]
        if self.p_hat.shape[-2:] != (K, 3) or self.R_hat.shape[-3:] != (K, 3, 3):
            raise DimensionError(f"NavResult: estimates {self.p_hat.shape}, {self.R_hat.shape} do not match t ({K},)")

    # ----------------------------------------------------------------- errors
    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading (batch) shape of the estimates."""
        return tuple(self.p_hat.shape[:-2])

    @property
    def n_flights(self) -> int:
        """Number of flights in the batch."""
        return int(np.prod(self.batch_shape, dtype=int))

    def position_error_m(self) -> Array:
        """``‖p̂ − p‖`` [m], shape ``(..., K)``."""
        return np.linalg.norm(self.p_hat - self.p, axis=-1)

    def velocity_error_mps(self) -> Array:
        """``‖v̂ − v‖`` [m/s], shape ``(..., K)``."""
        return np.linalg.norm(self.v_hat - self.v, axis=-1)

    def attitude_error_deg(self) -> Array:
        """Geodesic angle between ``R̂`` (projected) and ``R`` [deg], shape ``(..., K)``."""
        return np.degrees(angle_between(self.R_hat, self.R))

    def converge_s(self, threshold_deg: float = DEFAULT_CONVERGE_DEG) -> Array:
        """First time after which the attitude error stays below ``threshold_deg`` for good.

        ``t[k*]`` with ``k*`` the smallest index such that the error is
        ``< threshold_deg`` at every ``t[k] ≥ t[k*]``; ``t[0]`` if it always is,
        NaN if it is not below at the last sample. Shape ``(...)``.
        """
        thr = positive("threshold_deg", threshold_deg)
        bad = self.attitude_error_deg() >= thr
        K = self.t.shape[0]
        # index of the last bad sample (−1 if none)
        last_bad = np.where(bad.any(axis=-1), K - 1 - np.argmax(bad[..., ::-1], axis=-1), -1)
        idx = last_bad + 1
        out = np.where(idx < K, self.t[np.minimum(idx, K - 1)], np.nan)
        return np.asarray(out, dtype=float)

    def _window(self, after: float | None, threshold_deg: float) -> NDArray[np.bool_]:
        if after is None:
            start = self.converge_s(threshold_deg)
        else:
            start = np.full(self.batch_shape, in_range("after", after, -np.inf, np.inf, hi_open=True))
        return self.t >= np.asarray(start)[..., None]  # NaN start → empty window

    @staticmethod
    def _rms(err: Array, mask: NDArray[np.bool_]) -> Array:
        n = mask.sum(axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(n > 0, np.sqrt(np.sum(np.where(mask, err**2, 0.0), axis=-1) / np.maximum(n, 1)), np.nan)

    def position_rms_m(self, after: float | None = None, threshold_deg: float = DEFAULT_CONVERGE_DEG) -> Array:
        """RMS of ``‖p̂ − p‖`` over ``t ≥ after`` (default: ``t ≥ converge_s(threshold_deg)``), shape ``(...)``.

        NaN when the window is empty (never converged).
        """
        return self._rms(self.position_error_m(), self._window(after, threshold_deg))

    def velocity_rms_mps(self, after: float | None = None, threshold_deg: float = DEFAULT_CONVERGE_DEG) -> Array:
        """RMS of ``‖v̂ − v‖`` over the same window as :meth:`position_rms_m`."""
        return self._rms(self.velocity_error_mps(), self._window(after, threshold_deg))

    def attitude_rms_deg(self, after: float | None = None, threshold_deg: float = DEFAULT_CONVERGE_DEG) -> Array:
        """RMS of the geodesic attitude error [deg] over the same window as :meth:`position_rms_m`."""
        return self._rms(self.attitude_error_deg(), self._window(after, threshold_deg))

    def to_dict(self, after: float | None = None, threshold_deg: float = DEFAULT_CONVERGE_DEG) -> dict[str, Any]:
        """The metrics: ``position_rms_m``, ``velocity_rms_mps``, ``attitude_rms_deg``,
        ``converge_s``, ``cost_per_step_us`` (and ``filter``, ``skipped_fixes``,
        ``n_fixes``, ``after``, ``threshold_deg``).

        Per-flight metrics are floats for a single flight and (nested) lists for a batch.
        """

        def py(a: Array) -> Any:
            a = np.asarray(a)
            return float(a) if a.ndim == 0 and a.dtype.kind == "f" else a.tolist()

        return {
            "filter": self.filter_name,
            "position_rms_m": py(self.position_rms_m(after, threshold_deg)),
            "velocity_rms_mps": py(self.velocity_rms_mps(after, threshold_deg)),
            "attitude_rms_deg": py(self.attitude_rms_deg(after, threshold_deg)),
            "converge_s": py(self.converge_s(threshold_deg)),
            "cost_per_step_us": float(self.cost_per_step_us),
            "skipped_fixes": py(self.skipped_fixes),
            "n_fixes": int(self.n_fixes),
            "after": after,
            "threshold_deg": float(threshold_deg),
        }

    # -------------------------------------------------------------- save/load
    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the result to ``path`` (``.npz``) atomically (:func:`nlobs._io.atomic_write`)."""
        data: dict[str, Any] = {
            "format_version": np.array(FORMAT_VERSION),
            "filter_name": np.array(self.filter_name),
            "n_fixes": np.array(self.n_fixes),
            "cost_per_step_us": np.array(self.cost_per_step_us),
            "wall_s": np.array(self.wall_s),
            "imu_rate_hz": np.array(self.imu_rate_hz),
            "gnss_rate_hz": np.array(self.gnss_rate_hz),
        }
        for name in ("t", "p_hat", "v_hat", "R_hat", "p", "v", "R", "skipped_fixes", *_OPTIONAL):
            val = getattr(self, name)
            if val is not None:
                data[name] = val
        return atomic_write(path, lambda fh: np.savez(fh, **data))

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> NavResult:
        """Read a result written by :meth:`save`.

        Raises
        ------
        InvalidArgumentError
            Not a navigation result of a known format version.
        """
        with np.load(path, allow_pickle=False) as d:
            version = int(d["format_version"]) if "format_version" in d.files else None
            if version != FORMAT_VERSION or "R_hat" not in d.files:
                raise InvalidArgumentError(f"{path}: not an nlobs navigation result of format {FORMAT_VERSION}")
            return cls(
                t=d["t"], p_hat=d["p_hat"], v_hat=d["v_hat"], R_hat=d["R_hat"], p=d["p"], v=d["v"], R=d["R"],
                filter_name=str(d["filter_name"]), skipped_fixes=d["skipped_fixes"], n_fixes=int(d["n_fixes"]),
                cost_per_step_us=float(d["cost_per_step_us"]), wall_s=float(d["wall_s"]),
                imu_rate_hz=float(d["imu_rate_hz"]), gnss_rate_hz=float(d["gnss_rate_hz"]),
                R_raw=d["R_raw"] if "R_raw" in d.files else None,
                z_hat=d["z_hat"] if "z_hat" in d.files else None,
            )


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
    batches = []
    for name in ("omega_b", "a_b", "m_b"):
        arr = np.asarray(getattr(data, name), dtype=float)
        if arr.ndim < 2 or arr.shape[-2:] != (K, 3):
            raise DimensionError(f"data.{name}: expected shape (..., {K}, 3), got {arr.shape}")
        finite = np.isfinite(arr).all(axis=-1)  # (..., K)
        if not finite.all():
            k = int(np.argmax(~finite.reshape(-1, K).all(axis=0)))
            raise NonFiniteError(f"data.{name}: IMU sample at t = {t[k]:.6g} s (index {k}) is not finite")
        batches.append(arr.shape[:-2])
    try:
        batch = np.broadcast_shapes(*batches)
    except ValueError:
        raise DimensionError(f"data: IMU batch shapes {batches} do not broadcast") from None
    return t, batch


def _check_gnss(data: SensorData, t: Array) -> tuple[NDArray[np.intp], tuple[int, ...]]:
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
    batches = []
    for name in ("p_gnss", "v_gnss"):
        val = getattr(data, name)
        if val is None:
            continue
        arr = np.asarray(val, dtype=float)
        if arr.ndim < 2 or arr.shape[-2:] != (G, 3):
            raise DimensionError(f"data.{name}: expected shape (..., {G}, 3), got {arr.shape}")
        batches.append(arr.shape[:-2])
    return clipped, np.broadcast_shapes(*batches)


class _Bar:
    """A rich progress bar on stderr (only when asked)."""

    def __init__(self, total: int, on: bool, label: str) -> None:
        self.total, self.on, self.label = total, on, label
        self.every = max(1, total // 200)
        self.bar: Any = None
        self.task: Any = None

    def __enter__(self) -> Self:
        if self.on:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self.bar = Progress(TextColumn(self.label), BarColumn(), TextColumn("{task.percentage:>5.1f}%"),
                                TimeElapsedColumn(), TimeRemainingColumn(), console=Console(file=sys.stderr))
            self.bar.start()
            self.task = self.bar.add_task(self.label, total=self.total)
        return self

    def update(self, k: int) -> None:
        if self.bar is not None and k % self.every == 0:
            self.bar.update(self.task, completed=k)

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.update(self.task, completed=self.total)
            self.bar.stop()


# ----------------------------------------------------------------------- loop
def run_navigation(filt: NavFilter, data: SensorData, p0: ArrayLike, v0: ArrayLike, R0: ArrayLike, *,
                   progress: bool = False) -> NavResult:
    """Run ``filt`` on ``data`` from the initial estimates ``(p0, v0, R0)`` (the multi-rate loop above).

    Parameters
    ----------
    filt : NavFilter
        E.g. :class:`~nlobs.navigation.gnss_ins.GnssInsObserver` or the EKF.
        If it has a ``diagnostics(state, imu)`` method returning ``R_raw`` and
        ``z_hat``, those are recorded too. If it has ``raw_estimate`` and
        ``project_attitude`` (module docstring), the attitude is projected once, at
        the end, and ``R_raw`` is the recorded raw attitude.
    data : SensorData
        Sensor streams (possibly batched) and the truth.
    p0, v0 : array_like, shape (..., 3)
        Initial position and velocity estimates.
    R0 : array_like, shape (..., 3, 3)
        Initial attitude estimate.
    progress : bool
        Show a rich progress bar on stderr.

    Returns
    -------
    NavResult

    Raises
    ------
    InvalidArgumentError
        IMU times not uniform/increasing; GNSS times off the IMU grid or out of order.
    NonFiniteError
        A non-finite IMU sample (the message names its time) or initial estimate.
    DimensionError
        Inconsistent shapes.
    SimulationDiverged
        The estimate became non-finite (the time and quantity are named).
    """
    if not isinstance(filt, NavFilter):
        raise InvalidArgumentError(f"filt: {type(filt).__name__} does not implement the NavFilter protocol")
    t, imu_batch = _check_imu(data)
    gidx, gnss_batch = _check_gnss(data, t)
    p0_ = as_batch("p0", p0, 3)
    v0_ = as_batch("v0", v0, 3)
    R0_ = as_finite_array("R0", R0)
    if R0_.ndim < 2 or R0_.shape[-2:] != (3, 3):
        raise DimensionError(f"R0: expected shape (..., 3, 3), got {R0_.shape}")
    try:
        batch = np.broadcast_shapes(imu_batch, gnss_batch, p0_.shape[:-1], v0_.shape[:-1], R0_.shape[:-2])
    except ValueError:
        raise DimensionError(
            f"batch shapes do not broadcast: IMU {imu_batch}, GNSS {gnss_batch}, p0 {p0_.shape[:-1]}, "
            f"v0 {v0_.shape[:-1]}, R0 {R0_.shape[:-2]}") from None
    K, G = t.shape[0], gidx.shape[0]
    for name, shape in (("p", (K, 3)), ("v", (K, 3)), ("R", (K, 3, 3))):
        if np.shape(getattr(data, name)) != shape:
            raise DimensionError(f"data.{name} (truth): expected shape {shape}, got {np.shape(getattr(data, name))}")
    n_flights = int(np.prod(batch, dtype=int))

    b3 = (*batch, K, 3)
    om = np.broadcast_to(np.asarray(data.omega_b, dtype=float), b3)
    ab = np.broadcast_to(np.asarray(data.a_b, dtype=float), b3)
    mb = np.broadcast_to(np.asarray(data.m_b, dtype=float), b3)
    pg = np.broadcast_to(np.asarray(data.p_gnss, dtype=float), (*batch, G, 3))
    vg = None if data.v_gnss is None else np.broadcast_to(np.asarray(data.v_gnss, dtype=float), (*batch, G, 3))
    valid = np.isfinite(pg).all(axis=-1)
    if vg is not None:
        valid &= np.isfinite(vg).all(axis=-1)
    fix_at = np.full(K, -1, dtype=np.intp)
    fix_at[gidx] = np.arange(G)

    p_hat = np.empty(b3)
    v_hat = np.empty(b3)
    R_hat = np.empty((*batch, K, 3, 3))  # raw attitudes when the projection is deferred
    raw_estimate, project = getattr(filt, "raw_estimate", None), getattr(filt, "project_attitude", None)
    deferred = callable(raw_estimate) and callable(project)
    estimate = raw_estimate if deferred else filt.estimate
    diag = getattr(filt, "diagnostics", None)
    R_raw = np.empty((*batch, K, 3, 3)) if callable(diag) and not deferred else None
    z_hat: Array | None = np.empty(b3) if callable(diag) else None

    state = filt.init(np.broadcast_to(p0_, (*batch, 3)), np.broadcast_to(v0_, (*batch, 3)),
                      np.broadcast_to(R0_, (*batch, 3, 3)))
    busy = 0.0
    check_every = max(1, min(100, K // 20))
    k0 = 0
    with _Bar(K, progress, f"{filt.name}") as bar:
        for k in range(K):
            imu = ImuSample(om[..., k, :], ab[..., k, :], mb[..., k, :])
            g = fix_at[k]
            if g >= 0:
                fix = GnssSample(pg[..., g, :], None if vg is None else vg[..., g, :], valid[..., g])
                t0 = time.perf_counter()
                state = filt.update(state, fix)
                busy += time.perf_counter() - t0
            est = estimate(state)  # type: ignore[misc]
            p_hat[..., k, :] = est.p
            v_hat[..., k, :] = est.v
            R_hat[..., k, :, :] = est.R
            if z_hat is not None and callable(diag):
                extra = diag(state, imu)
                if "R_raw" in extra and "z_hat" in extra:
                    if R_raw is not None:
                        R_raw[..., k, :, :] = extra["R_raw"]
                    z_hat[..., k, :] = extra["z_hat"]
                else:
                    R_raw = z_hat = None
            if k % check_every == 0 or k == K - 1:
                _check_finite(t, k0, k, filt.name, p_hat, v_hat, R_hat)
                k0 = k
            if k < K - 1:
                t0 = time.perf_counter()
                state = filt.propagate(state, imu, float(t[k + 1] - t[k]))
                busy += time.perf_counter() - t0
            bar.update(k)

    if deferred:  # one projection of the whole record (module docstring)
        R_raw = R_hat
        R_hat = np.asarray(project(R_raw), dtype=float)  # type: ignore[misc]
        if R_hat is R_raw or R_hat.shape != R_raw.shape:
            raise DimensionError(f"{filt.name}.project_attitude: expected a new array of shape {R_raw.shape}, "
                                 f"got {R_hat.shape}")
    return NavResult(
        t=t, p_hat=_frozen(p_hat), v_hat=_frozen(v_hat), R_hat=_frozen(R_hat),
        p=np.asarray(data.p, dtype=float), v=np.asarray(data.v, dtype=float), R=np.asarray(data.R, dtype=float),
        filter_name=str(filt.name), skipped_fixes=(~valid).sum(axis=-1).astype(np.int64), n_fixes=G,
        cost_per_step_us=busy / K / n_flights * 1e6, wall_s=busy,
        imu_rate_hz=float(data.imu_rate_hz), gnss_rate_hz=float(data.gnss_rate_hz),
        R_raw=_frozen(R_raw), z_hat=_frozen(z_hat),
    )


def _check_finite(t: Array, k0: int, k1: int, name: str, p: Array, v: Array, R: Array) -> None:
    """Raise SimulationDiverged at the first sample in ``[k0, k1]`` with a non-finite estimate."""
    n = k1 - k0 + 1
    finite = {label: np.isfinite(arr[..., k0:k1 + 1, :].reshape(-1, n, size)).all(axis=(0, 2))  # per sample
              for label, arr, size in (("p", p, 3), ("v", v, 3), ("R", R.reshape(*R.shape[:-2], 9), 9))}
    ok = finite["p"] & finite["v"] & finite["R"]
    if ok.all():
        return
    k = int(np.argmin(ok))
    label = next(lbl for lbl in ("p", "v", "R") if not finite[lbl][k])
    raise SimulationDiverged(float(t[k0 + k]), name, label)
