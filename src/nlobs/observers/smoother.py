r"""The Rauch–Tung–Striebel smoother of the EKF and the UKF, run on a recorded filter output.

A filter's estimate at ``t_k`` uses the samples up to ``t_k``; the smoother's uses the whole record. It is
the backward recursion of Rauch, Tung & Striebel (1965, "Maximum likelihood estimates of linear dynamic
systems", AIAA Journal 3(8)) over the filter's posterior means and covariances ``(x_k, P_k)``, recorded at
every time of a grid ``t_0 < … < t_{K−1}`` (after the correction where there was a sample):

.. math:: G_k = C_{k+1} (P^-_{k+1})^{-1},\qquad
          x^s_k = x_k + G_k\,(x^s_{k+1} − x^-_{k+1}),\qquad
          P^s_k = P_k + G_k\,(P^s_{k+1} − P^-_{k+1})\,G_k^\top,

from ``x^s_{K−1} = x_{K−1}``, ``P^s_{K−1} = P_{K−1}``, where

* ``(x^-_{k+1}, P^-_{k+1})`` is the filter's own prediction from ``(x_k, P_k)`` over ``[t_k, t_{k+1})``,
  made again here exactly as the loops made it: the filter's ``rhs`` integrated by classical RK4 with the
  input ``u_k`` held over the step (a continuous plant; one step of ``t_{k+1} − t_k`` per interval as
  :func:`~nlobs.simulate.run_observer` takes, or whole steps of a given ``dt`` as
  :func:`~nlobs.simulate.simulate` takes with ``save_every > 1``), or ``rhs`` called once per step of the
  plant's ``dt`` (a discrete plant). Where no sample came at ``t_{k+1}`` this prediction *is* the recorded
  ``(x_{k+1}, P_{k+1})``, to rounding;
* ``C_{k+1}`` is the cross-covariance of ``x_k`` and ``x_{k+1}``. EKF: ``C = P_k Φ_kᵀ`` with ``Φ_k`` the
  transition matrix of the linearised flow over the interval, ``Φ̇ = F Φ`` (``F = ∂f/∂x`` at the mean)
  integrated alongside the mean with the same RK4 stages — so ``Φ_k`` is the exact Jacobian of the RK4 map of
  the mean —, or the product of the Jacobians ``∂f/∂x`` of the steps (discrete plant). UKF: the unscented
  RTS smoother of Särkkä (2008, "Unscented Rauch–Tung–Striebel smoother", IEEE TAC 53(3)),
  ``C = Σᵢ w^c_i (𝒳ᵢ − x_k)(φ(𝒳ᵢ) − x^-_{k+1})ᵀ``, with the UKF's sigma points of ``(x_k, P_k)``, its
  covariance weights ``w^c`` and ``φ`` the deterministic flow over the interval (the same RK4 steps applied to
  each sigma point; ``f`` itself for a discrete plant). For a continuous plant the noise entering over the
  interval is taken as independent of ``x_k``, as Särkkä's smoother takes the additive noise of a step.

For a linear plant the two smoothers coincide; for a linear discrete-time plant both are the Gaussian posterior
of the states given every sample (the batch least-squares solution). The gains are found with :func:`numpy.linalg.solve` from the
symmetrised ``P^-_{k+1}``, which must be positive definite; every array may carry leading batch axes (many
runs smoothed at once).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_finite_array, as_real_array, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.observers.ekf import EKF
from nlobs.observers.gaussian import FilterState, symmetrised
from nlobs.observers.ukf import UKF

__all__ = ["Smoothed", "rts_smooth", "smooth_run"]

#: Relative tolerance (of the step) within which an interval of ``t`` must be a whole number of steps.
STEP_RTOL = 1e-6


@dataclass(frozen=True, eq=False)
class Smoothed:
    r"""The smoothed means and covariances of a filter's record (:func:`rts_smooth`).

    Attributes
    ----------
    t : ndarray, shape (K,)
        The recorded times.
    x : ndarray, shape (..., K, n)
        Smoothed means ``x^s_k`` (the last one is the filter's).
    P : ndarray, shape (..., K, n, n)
        Smoothed covariances ``P^s_k``, symmetric.
    gains : ndarray, shape (..., K − 1, n, n)
        Smoother gains ``G_k``, ``k = 0 .. K − 2``.
    x_pred, P_pred : ndarray, shapes (..., K − 1, n) and (..., K − 1, n, n)
        The filter's prediction ``(x^-_{k+1}, P^-_{k+1})`` at ``t[1:]`` from its posterior at ``t[:-1]``, made
        again (``P_pred`` as integrated, not symmetrised): equal to the recorded posterior, to rounding, at the
        times without a sample.
    method : str
        ``"extended"`` (EKF: the linearised flow) or ``"unscented"`` (UKF: Särkkä 2008).

    All arrays are read-only.

    Examples
    --------
    A scalar random walk ``x⁺ = x + w`` (``Q = 1``) measured with ``R = 1`` from ``P0 = 1``, samples ``0`` and
    ``1``: the filter ends at ``0.6`` with variance ``0.6``; the smoother moves the first estimate from ``0`` to
    ``0.2`` and its variance from ``0.5`` to ``0.4`` (the batch posterior: the inverse of the information
    matrix ``[[3, −1], [−1, 2]]``), with the gain ``G = 0.5 / 1.5``:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import run_observer
    >>> walk = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
    >>> ekf = nlobs.EKF(walk, Q=[[1.0]], R=[[1.0]], P0=[[1.0]], record_covariance=True)
    >>> run = run_observer(ekf, [0.0, 1.0], x_hat0=[0.0], y=[[0.0], [1.0]])
    >>> s = smooth_run(ekf, run)
    >>> s.method, s.x.ravel().round(12).tolist(), s.P.ravel().round(12).tolist()
    ('extended', [0.2, 0.6], [0.4, 0.6])
    >>> s.gains.ravel().round(12).tolist(), s.P_pred.ravel().tolist(), s.std.ravel().round(4).tolist()
    ([0.333333333333], [1.5], [0.6325, 0.7746])
    """

    t: Array
    x: Array
    P: Array
    gains: Array
    x_pred: Array
    P_pred: Array
    method: str

    @property
    def std(self) -> Array:
        """Standard deviations of the states, ``√diag(P^s)``, shape ``(..., K, n)``."""
        return np.sqrt(np.maximum(self.P.diagonal(0, -2, -1), 0.0))


# ---------------------------------------------------------------------------------------------- validation
def _first_bad_time(arr: Array, axis_from_end: int) -> int | None:
    """Index of the first time whose entries are not all finite (the time axis ``axis_from_end`` from the end)."""
    ok = np.isfinite(np.moveaxis(arr, arr.ndim - axis_from_end, -1))
    ok = ok.all(axis=tuple(range(ok.ndim - 1)))
    return None if ok.all() else int(np.argmin(ok))


def _series(name: str, value: ArrayLike, K: int, tail: tuple[int, ...], grid: Array) -> Array:
    """``value`` as a float array ``(..., K, *tail)``, finite, checked."""
    arr = as_real_array(name, value)
    want = (K, *tail)
    if arr.ndim < len(want) or arr.shape[arr.ndim - len(want):] != want:
        dims = ", ".join(str(d) for d in want)
        raise DimensionError(f"{name}: expected shape (..., {dims}), got {arr.shape}")
    k = _first_bad_time(arr, len(want))
    if k is not None:
        raise NonFiniteError(f"{name}: not finite at t = {grid[k]:.9g} (index {k})")
    return arr


def _input(value: ArrayLike | None, K: int, m: int, grid: Array) -> Array:
    """The input as ``(..., K, m)``: a record, a constant ``(m,)`` or a scalar, or ``None`` without inputs."""
    if value is None:
        if m:
            raise DimensionError(f"u: the plant has {m} input{'s' if m > 1 else ''}; give u of shape (..., {K}, {m})")
        return np.zeros((K, 0))
    arr = as_real_array("u", value)
    if arr.ndim <= 1:  # a constant input
        if arr.ndim == 1 and arr.shape != (m,):
            raise DimensionError(f"u: expected shape ({m},) for a constant input or (..., {K}, {m}), got {arr.shape}")
        if not np.isfinite(arr).all():
            raise NonFiniteError("u: the constant input is not finite")
        return np.broadcast_to(arr, (K, m))
    return _series("u", arr, K, (m,), grid)


def _steps(filt: EKF | UKF, grid: Array, dt: float | None) -> tuple[list[int], list[float] | None]:
    """Per interval, the number of steps and (``None``: one step of the interval itself) the common step."""
    gaps = np.diff(grid)
    if filt.discrete:
        base = float(filt.time.dt)  # type: ignore[attr-defined]
        if dt is not None and abs(float(dt) - base) > STEP_RTOL * base:
            raise InvalidArgumentError(f"dt: the plant is discrete with dt = {base:g}, got {float(dt):g}")
        step: float | None = base
    elif dt is None:
        return [1] * gaps.size, None
    else:
        step = float(dt)
        if not (math.isfinite(step) and step > 0):
            raise InvalidArgumentError(f"dt: expected a positive finite step, got {dt!r}")
    parts = np.rint(gaps / step)
    off = (parts < 1) | (np.abs(gaps - parts * step) > STEP_RTOL * step)
    if off.any():
        k = int(np.argmax(off))
        raise InvalidArgumentError(f"t: the interval from t = {grid[k]:.9g} to {grid[k + 1]:.9g} is not a whole "
                                   f"number of steps of dt = {step:g}")
    return [int(v) for v in parts], [step] * gaps.size


# ---------------------------------------------------------------------------------------------- prediction
def _rk4(rate: Any, t: float, y: tuple[Array, ...], h: float) -> tuple[Array, ...]:
    """One classical RK4 step of a tuple of arrays, with the arithmetic of the loops' RK4 (so their rounding):
    stages ``a + c·b``, the update ``a + (h/6)(b1 + 2 b2 + 2 b3 + b4)``."""
    half = 0.5 * h
    k1 = rate(t, y)
    k2 = rate(t + half, tuple(a + half * b for a, b in zip(y, k1)))
    k3 = rate(t + half, tuple(a + half * b for a, b in zip(y, k2)))
    k4 = rate(t + h, tuple(a + h * b for a, b in zip(y, k3)))
    return tuple(a + (h / 6.0) * (b1 + 2.0 * b2 + 2.0 * b3 + b4) for a, b1, b2, b3, b4 in zip(y, k1, k2, k3, k4))


def _predict_ekf(filt: EKF, t0: float, x: Array, P: Array, nis: Array, u: Array, y: Array, n_steps: int,
                 h: float) -> tuple[Array, Array, Array]:
    """The EKF's prediction over one interval and ``Cᵀ = Φ P`` with ``Φ`` the transition matrix of its linearised
    flow."""
    jac = filt.plant.rhs_jacobian_x
    Phi = np.broadcast_to(np.eye(filt.n), P.shape).copy()
    if filt.discrete:
        z = FilterState(x, P, nis)
        for j in range(n_steps):
            tj = t0 + j * h
            Phi = np.asarray(jac(tj, z.x, u)) @ Phi
            z = filt.rhs(tj, z, u, y)
        return z.x, z.P, Phi @ P

    def rate(s: float, yy: tuple[Array, ...]) -> tuple[Array, ...]:
        xs, Ps, Phs = yy
        dz = filt.rhs(s, FilterState(xs, Ps, nis), u, y)
        return dz.x, dz.P, np.asarray(jac(s, xs, u)) @ Phs

    state = (x, P, Phi)
    for j in range(n_steps):
        state = _rk4(rate, t0 + j * h, state, h)
    xp, Pp, Phi = state
    return xp, Pp, Phi @ P  # Cᵀ = Φ P_k


def _predict_ukf(filt: UKF, t0: float, x: Array, P: Array, nis: Array, u: Array, y: Array, n_steps: int,
                 h: float) -> tuple[Array, Array, Array]:
    """The UKF's prediction over one interval and the transpose of the cross-covariance of Särkkä (2008)."""
    f = filt.plant.rhs
    X0 = filt.sigma_points(x, P)  # (..., L, n)
    uX = np.broadcast_to(u[..., None, :], X0.shape[:-1] + u.shape[-1:])
    X = X0
    if filt.discrete:
        z = FilterState(x, P, nis)
        for j in range(n_steps):
            tj = t0 + j * h
            X = f(tj, X, uX)
            z = filt.rhs(tj, z, u, y)
        xp, Pp = z.x, z.P
    else:
        def rate(s: float, yy: tuple[Array, ...]) -> tuple[Array, ...]:
            xs, Ps, Xs = yy
            dz = filt.rhs(s, FilterState(xs, Ps, nis), u, y)
            return dz.x, dz.P, f(s, Xs, uX)

        state = (x, P, X0)
        for j in range(n_steps):
            state = _rk4(rate, t0 + j * h, state, h)
        xp, Pp, X = state
    dX0 = (X0 - x[..., None, :]) * filt.wc[:, None]
    dX1 = X - xp[..., None, :]
    return xp, Pp, np.swapaxes(dX1, -1, -2) @ dX0  # Cᵀ = Σ w_c (φ(𝒳) − x⁻)(𝒳 − x)ᵀ


# ---------------------------------------------------------------------------------------------- smoother
def rts_smooth(filter: EKF | UKF, t: ArrayLike, x: ArrayLike, P: ArrayLike, u: ArrayLike | None, *,  # noqa: A002
               dt: float | None = None) -> Smoothed:
    r"""Rauch–Tung–Striebel smoothing of an EKF's or a UKF's recorded posterior (module docstring).

    Parameters
    ----------
    filter : EKF or UKF
        The filter that made the record (its plant, ``Q`` and, for the UKF, sigma-point weights).
    t : array_like, shape (K,)
        The recorded times, strictly increasing.
    x : array_like, shape (..., K, n)
        The filter's mean at each time (after the correction where there was a sample).
    P : array_like, shape (..., K, n, n)
        The filter's covariance at each time (as recorded with ``record_covariance=True``).
    u : array_like or None
        The input, shape ``(..., K, m)``, ``u[k]`` held over ``[t_k, t_{k+1})`` as
        :func:`~nlobs.simulate.run_observer` holds it (and :func:`~nlobs.simulate.simulate` for a constant or
        held input); a constant ``(m,)`` or a scalar; ``None`` for a plant without inputs.
    dt : float, optional
        Continuous plant: the RK4 step the filter was integrated with, each interval of ``t`` a whole number of
        them (a record kept every few steps); default one step per interval, of its own length. Discrete plant:
        the plant's ``dt`` (the default), each interval a whole number of its steps.

    Returns
    -------
    Smoothed
        Smoothed means and covariances on ``t``, the gains and the re-made predictions, with the leading
        batch axes of ``x``, ``P`` and ``u`` broadcast together.

    Raises
    ------
    InvalidArgumentError
        ``filter`` is not an :class:`~nlobs.observers.ekf.EKF` or a :class:`~nlobs.observers.ukf.UKF`; ``t`` is
        not strictly increasing; an interval is not a whole number of steps of ``dt``; a predicted covariance
        is singular or not positive definite (the message names its time).
    DimensionError
        ``t``, ``x``, ``P`` or ``u`` of the wrong shape, or batch shapes that do not broadcast.
    NonFiniteError
        A non-finite entry in ``t``, ``x``, ``P`` or ``u`` (the message names its time), or a prediction that
        is not finite.

    Notes
    -----
    Samples taken at times not in ``t`` are not seen: keep every instant with a sample in the record.
    An input that varies within a step (a function of time evaluated at RK4's stages by
    :func:`~nlobs.simulate.simulate`) is held here at its value at ``t_k``: the predictions then differ from
    the filter's by the change of the input over a step. Rauch, Tung & Striebel (1965); Särkkä (2008).

    Examples
    --------
    A double integrator ``ẋ₁ = x₂``, ``ẋ₂ = w`` whose position is sampled at 10 Hz with noise of standard
    deviation 0.1, the EKF integrated with RK4 steps of 10 ms and its covariance recorded at every step: the
    smoother, which also sees the samples that come later, tracks the velocity better than the filter over the
    run, and its predictions at the instants without a sample are the filter's own record:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup, simulate
    >>> plant = nlobs.LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> ekf = nlobs.EKF(plant, Q=np.diag([0.0, 0.5]), R=[[0.01]], P0=np.eye(2), record_covariance=True)
    >>> run = simulate(plant, ekf, [0.0, 1.0], [0.0, 0.0], duration=5.0, dt=0.01, u=0.0,
    ...                measurements=MeasurementGroup("position", ["y1"], rate=10.0, noise_std=0.1),
    ...                process_noise=[0.0, 0.5], seed=1)
    >>> s = rts_smooth(ekf, run.t, run.x_hat, run.extras["P"], np.zeros((run.t.size, 1)))
    >>> s.x.shape, s.P.shape, s.gains.shape
    ((501, 2), (501, 2, 2), (500, 2, 2))
    >>> rms = lambda e: float(np.sqrt(np.mean(e**2)))
    >>> bool(rms(s.x[:, 1] - run.x[:, 1]) < 0.8 * rms(run.x_hat[:, 1] - run.x[:, 1]))
    True
    >>> quiet = ~run.sampled[1:, 0]  # the instants without a sample: the record is the prediction
    >>> bool(np.allclose(s.x_pred[quiet], run.x_hat[1:][quiet], rtol=0.0, atol=1e-12))
    True
    """
    if not isinstance(filter, (EKF, UKF)):
        raise InvalidArgumentError(f"filter: expected an EKF or a UKF, got {type(filter).__name__}")
    filt = filter
    n, m, p = filt.n, int(filt.plant.m), filt.p
    grid = as_finite_array("t", t, ndim=1)
    K = grid.size
    if K < 1:
        raise DimensionError("t: at least one time is required")
    if K > 1 and np.any(np.diff(grid) <= 0):
        k = int(np.argmax(np.diff(grid) <= 0)) + 1
        raise InvalidArgumentError(f"t: not strictly increasing at index {k} (t = {grid[k]:.9g})")
    xa = _series("x", x, K, (n,), grid)
    Pa = _series("P", P, K, (n, n), grid)
    ua = _input(u, K, m, grid)
    try:
        batch = tuple(np.broadcast_shapes(xa.shape[:-2], Pa.shape[:-3], ua.shape[:-2]))
    except ValueError:
        raise DimensionError(f"batch shapes do not broadcast: x {xa.shape[:-2]}, P {Pa.shape[:-3]}, "
                             f"u {ua.shape[:-2]}") from None
    n_steps, steps = _steps(filt, grid, dt)
    method = "extended" if isinstance(filt, EKF) else "unscented"
    xb = np.broadcast_to(xa, (*batch, K, n))
    Pb = np.broadcast_to(Pa, (*batch, K, n, n))
    ub = np.broadcast_to(ua, (*batch, K, m))

    x_pred = np.empty((*batch, K - 1, n))
    P_pred = np.empty((*batch, K - 1, n, n))
    cross_t = np.empty((*batch, K - 1, n, n))  # C_{k+1}ᵀ
    y_none = np.zeros((*batch, p))  # the filters' rhs does not read the measurement
    nis = np.zeros(batch)
    predict: Callable[..., tuple[Array, Array, Array]] = _predict_ekf if isinstance(filt, EKF) else _predict_ukf
    gaps = np.diff(grid).tolist()
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for k in range(K - 1):
            xk = np.ascontiguousarray(xb[..., k, :])
            Pk = np.ascontiguousarray(Pb[..., k, :, :])
            uk = np.ascontiguousarray(ub[..., k, :])
            h = gaps[k] if steps is None else steps[k]
            xp, Pp, ct = predict(filt, float(grid[k]), xk, Pk, nis, uk, y_none, n_steps[k], h)
            x_pred[..., k, :] = xp
            P_pred[..., k, :, :] = Pp
            cross_t[..., k, :, :] = ct
    for name, arr, tail in (("mean", x_pred, 1), ("covariance", P_pred, 2), ("cross-covariance", cross_t, 2)):
        k = _first_bad_time(arr, tail + 1)
        if k is not None:
            raise NonFiniteError(f"the predicted {name} from t = {grid[k]:.9g} to {grid[k + 1]:.9g} is not finite")

    Pp_sym = symmetrised(P_pred)
    if K > 1:
        lam = np.linalg.eigvalsh(Pp_sym)  # (..., K − 1, n)
        lo, hi = lam[..., 0], lam[..., -1]
        bad = ~(lo > n * np.finfo(float).eps * np.maximum(hi, 0.0))
        if bad.any():
            lead = tuple(range(bad.ndim - 1))
            k = int(np.argmax(bad.any(axis=lead)))
            worst = float(np.min(lo[..., k]))
            raise InvalidArgumentError(f"the predicted covariance at t = {grid[k + 1]:.9g} (index {k + 1}) is singular "
                                       f"or not positive definite (smallest eigenvalue {worst:.3g}); the smoother "
                                       "needs it invertible (no process noise on a state?)")
    gains = np.swapaxes(np.linalg.solve(Pp_sym, cross_t), -1, -2)  # G = C (P⁻)⁻¹, P⁻ symmetric

    xs = np.empty((*batch, K, n))
    Ps = np.empty((*batch, K, n, n))
    xs[..., -1, :] = xb[..., -1, :]
    Ps[..., -1, :, :] = symmetrised(Pb[..., -1, :, :])
    for k in range(K - 2, -1, -1):
        G = gains[..., k, :, :]
        dx = xs[..., k + 1, :] - x_pred[..., k, :]
        xs[..., k, :] = xb[..., k, :] + (G @ dx[..., None])[..., 0]
        dP = Ps[..., k + 1, :, :] - Pp_sym[..., k, :, :]
        Ps[..., k, :, :] = symmetrised(Pb[..., k, :, :] + G @ dP @ np.swapaxes(G, -1, -2))
    return Smoothed(t=readonly(grid), x=readonly(xs, owned=True), P=readonly(Ps, owned=True),
                    gains=readonly(gains, owned=True), x_pred=readonly(x_pred, owned=True),
                    P_pred=readonly(P_pred, owned=True), method=method)


def smooth_run(filter: EKF | UKF, result: Any, u: ArrayLike | None = None) -> Smoothed:  # noqa: A002
    r"""Rauch–Tung–Striebel smoothing of a filter's run: :func:`rts_smooth` of its times, estimates and ``P``.

    Parameters
    ----------
    filter : EKF or UKF
        The filter of the run, made with ``record_covariance=True``.
    result : SimulationResult
        Its run (:func:`~nlobs.simulate.simulate` or :func:`~nlobs.simulate.run_observer`): ``t``, ``x_hat`` and
        the covariance ``extras["P"]``.
    u : array_like, optional
        The input as :func:`rts_smooth` takes it (``(..., K, m)`` on ``result.t``, or a constant). ``None``: the
        input the run recorded as ``extras["u"]`` (a closed loop's, held over each step) where there is one,
        else none (a plant without inputs).

    Returns
    -------
    Smoothed
        As :func:`rts_smooth`. The step: one per interval where the intervals of ``result.t`` are single steps
        of ``result.dt`` or not a whole number of them (a recorded grid); ``result.dt`` where the record was
        kept every few steps.

    Raises
    ------
    InvalidArgumentError
        ``result`` has no recorded covariance (the filter was made without ``record_covariance=True``), or as
        :func:`rts_smooth`.
    DimensionError, NonFiniteError
        As :func:`rts_smooth`.

    Examples
    --------
    The shipped pendulum, with process noise on its velocity and its angle sampled at 10 Hz with noise of
    standard deviation 0.05, the EKF's record kept every 5th RK4 step (each sample instant among them): the
    smoothed velocity error over the run is a fraction of the filtered one:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup, simulate
    >>> plant = nlobs.load_model("pendulum").compile()
    >>> Q = np.diag([1e-6, 0.05])
    >>> ekf = nlobs.EKF(plant, Q=Q, R=[[0.05**2]], P0=0.1 * np.eye(2), record_covariance=True)
    >>> run = simulate(plant, ekf, [0.5, 0.0], [0.3, 0.2], duration=5.0, dt=0.01, u=0.0, save_every=5,
    ...                measurements=MeasurementGroup("encoder", ["y"], rate=10.0, noise_std=0.05),
    ...                process_noise=Q, seed=3)
    >>> s = smooth_run(ekf, run, 0.0)
    >>> s.x.shape, s.method
    ((101, 2), 'extended')
    >>> rms = lambda e: float(np.sqrt(np.mean(e**2)))
    >>> bool(rms(s.x[:, 1] - run.x[:, 1]) < 0.8 * rms(run.x_hat[:, 1] - run.x[:, 1]))
    True
    """
    if not isinstance(filter, (EKF, UKF)):
        raise InvalidArgumentError(f"filter: expected an EKF or a UKF, got {type(filter).__name__}")
    extras = getattr(result, "extras", None)
    if extras is None or not hasattr(result, "t") or not hasattr(result, "x_hat"):
        raise InvalidArgumentError(f"result: expected a SimulationResult (t, x_hat, extras), got "
                                   f"{type(result).__name__}")
    if "P" not in extras:
        raise InvalidArgumentError("result: no covariance recorded (extras has no 'P'); make the filter with "
                                   "record_covariance=True")
    t = np.asarray(result.t, dtype=float)
    dt: float | None = None
    step = float(getattr(result, "dt", math.nan))
    if not filter.discrete and t.size > 1 and math.isfinite(step) and step > 0:
        gaps = np.diff(t)
        parts = np.rint(gaps / step)
        whole = bool(np.all((parts >= 1) & (np.abs(gaps - parts * step) <= STEP_RTOL * step)))
        if whole and parts.max() > 1:  # kept every few steps: whole steps of the run's dt
            dt = step
    if u is None and int(filter.plant.m) and "u" in extras:
        u = extras["u"]
    return rts_smooth(filter, t, result.x_hat, extras["P"], u, dt=dt)
