"""Estimation-error metrics on a time grid, vectorised over batches.

All functions take the error ``e = x̂ − x`` with shape ``(*batch, K, n)`` (or
its Euclidean norm, shape ``(*batch, K)``) and the times ``t`` of shape ``(K,)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nlobs._typing import Array
from nlobs._validate import positive
from nlobs.errors import DimensionError, InvalidArgumentError


@dataclass(frozen=True)
class ErrorMetrics:
    """Summary of an estimation error ``e = x̂ − x`` (one entry per trajectory of a batch).

    Attributes
    ----------
    rmse : ndarray, shape (*batch, n)
        Root-mean-square error of each state over the samples with ``t >= after``.
    final_error : ndarray, shape (*batch, n)
        Signed error at the final time.
    final_error_norm : ndarray, shape (*batch,)
        Euclidean norm of the final error.
    time_to_tolerance : ndarray, shape (*batch,)
        First time after which ``‖e‖ < tol`` holds until the end; NaN if never
        (or if no ``tol`` was given).
    decay_rate : ndarray, shape (*batch,)
        ``λ`` of the least-squares fit ``log ‖e(t)‖ ≈ c − λ t`` over the samples
        where ``‖e‖`` is above the floor; positive when the error decays; NaN
        when fewer than two samples qualify.
    after : float
        Start of the RMSE window.
    tol : float or None
        Tolerance used for ``time_to_tolerance``.

    Examples
    --------
    :meth:`SimulationResult.metrics <nlobs.simulate.result.SimulationResult.metrics>` of two runs of ``ẋ = −x``
    with a Luenberger observer of gain 3, so ``e(t) = e₀ e^{−4t}``, from ``e₀ = −1`` and ``−2`` over 2 s: the decay
    rate is 4, the final error ``e₀ e^{−8}``, the error stays below ``0.01`` from the first grid time after
    ``ln(100 |e₀|)/4`` and the RMS error over the run is about ``|e₀|/4``:

    >>> import numpy as np
    >>> import nlobs
    >>> plant = nlobs.LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
    >>> observer = nlobs.LuenbergerObserver(plant, [[3.0]])
    >>> res = nlobs.simulate(plant, observer, [[1.0], [2.0]], [0.0], duration=2.0, dt=1e-3)
    >>> m = res.metrics(tol=1e-2)
    >>> isinstance(m, ErrorMetrics), m.rmse.shape, m.final_error.shape, m.decay_rate.shape
    (True, (2, 1), (2, 1), (2,))
    >>> np.round(m.decay_rate, 3).tolist(), bool(np.allclose(m.final_error[:, 0], [-np.exp(-8), -2 * np.exp(-8)]))
    ([4.0, 4.0], True)
    >>> np.round(m.time_to_tolerance, 3).tolist(), np.round(np.log([100.0, 200.0]) / 4, 4).tolist()
    ([1.152, 1.325], [1.1513, 1.3246])
    >>> np.round(m.rmse[:, 0], 2).tolist(), m.tol
    ([0.25, 0.5], 0.01)
    """

    rmse: Array
    final_error: Array
    final_error_norm: Array
    time_to_tolerance: Array
    decay_rate: Array
    after: float
    tol: float | None


def _check(t: Array, enorm: Array) -> None:
    if t.ndim != 1 or enorm.shape[-1:] != t.shape:
        raise DimensionError(f"times of shape {t.shape} do not match an error-norm array of shape {enorm.shape}")


def rmse(t: Array, e: Array, after: float = -np.inf) -> Array:
    """RMS of each error component over the samples with ``t >= after``, shape ``(*batch, n)``."""
    _check(t, e[..., 0])
    sel = t >= after
    if not np.any(sel):
        raise InvalidArgumentError(f"after={after:g}: no sample at or after this time (last sample t={t[-1]:g})")
    return np.sqrt(np.mean(e[..., sel, :] ** 2, axis=-2))


def time_to_tolerance(t: Array, enorm: Array, tol: float) -> Array:
    """First time after which ``enorm < tol`` at every later sample; NaN if never, shape ``(*batch,)``."""
    _check(t, enorm)
    tol = positive("tol", tol)
    below = enorm < tol
    # stays[k] = below[k] and below[k+1] and ... and below[K-1]
    stays = np.flip(np.logical_and.accumulate(np.flip(below, axis=-1), axis=-1), axis=-1)
    first = np.argmax(stays, axis=-1)
    return np.where(stays.any(axis=-1), t[first], np.nan)


def decay_rate(
    t: Array, enorm: Array, *, floor: float | None = None, t_min: float = -np.inf, t_max: float = np.inf
) -> Array:
    """Exponential decay rate ``λ`` of ``‖e(t)‖ ≈ c exp(−λ t)`` by least squares on ``log ‖e‖``.

    Parameters
    ----------
    t : ndarray, shape (K,)
        Times.
    enorm : ndarray, shape (*batch, K)
        Error norms.
    floor : float, optional
        Samples with ``enorm <= floor`` are left out (round-off or noise level).
        Default: ``1e-9`` times the largest norm of each trajectory.
    t_min, t_max : float
        Fit window.

    Returns
    -------
    ndarray, shape (*batch,)
        ``λ`` (positive for a decaying error); NaN where fewer than two samples qualify.
    """
    _check(t, enorm)
    if floor is None:
        fl = 1e-9 * np.max(enorm, axis=-1, keepdims=True, initial=0.0)
    else:
        fl = np.asarray(positive("floor", floor, allow_zero=True))
    use = (enorm > fl) & np.isfinite(enorm) & (t >= t_min) & (t <= t_max)
    w = use.astype(float)
    cnt = w.sum(axis=-1)
    logn = np.log(np.where(use, enorm, 1.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        tbar = (w * t).sum(axis=-1) / cnt
        lbar = (w * logn).sum(axis=-1) / cnt
        dt_ = t - tbar[..., None]
        sxx = (w * dt_**2).sum(axis=-1)
        sxy = (w * dt_ * (logn - lbar[..., None])).sum(axis=-1)
        slope = sxy / sxx
    return np.where((cnt >= 2) & (sxx > 0), -slope, np.nan)
