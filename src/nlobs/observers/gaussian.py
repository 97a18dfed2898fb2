r"""What the EKF and the UKF of nlobs share: their state, their checked covariances and the masked correction.

:class:`FilterState` is the state of both filters (mean, covariance and the last normalised innovation
squared). :class:`GaussianFilterBase` holds what they have in common — the plant, ``Q``, ``R``, ``P0``,
``init``/``estimate``/``diagnostics`` and :meth:`GaussianFilterBase.correct`, which selects the rows of
the fresh outputs, skips the missing samples of each batch member (a non-finite ``y`` at a fresh row)
and hands each group of members with the same rows to the filter's own ``_update`` (the EKF's
linearisation or the UKF's unscented transform, both ending in
:func:`~nlobs.observers.kalman.joseph_update`).

Noise conventions
-----------------
* continuous-time plant: ``ẋ = f(x, u) + w`` with ``w`` white of spectral density ``Q`` (the covariance
  grows as ``Q`` per second); the filters integrate the moment ODEs between samples (the loop's RK4);
* discrete-time plant: ``x⁺ = f(x, u) + w_k``, ``w_k`` of covariance ``Q``;
* ``y = h(x, u) + v``, ``v`` of covariance ``R`` (all outputs; a correction uses the rows and columns
  of the fresh ones).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray
from nlobs._validate import as_batch, as_symmetric, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, SimulationDiverged
from nlobs.systems.base import PlantModel
from nlobs.observers.base import ToControl
from nlobs.systems.timebase import Continuous, Discrete, TimeBase

__all__ = ["FilterState", "GaussianFilterBase", "checked_covariance", "checked_plant"]


@dataclass(frozen=True)
class FilterState:
    """State of :class:`~nlobs.observers.ekf.EKF` and :class:`~nlobs.observers.ukf.UKF`.

    Attributes
    ----------
    x : ndarray, shape (..., n)
        Mean (the estimate).
    P : ndarray, shape (..., n, n)
        Covariance.
    nis : ndarray, shape (...)
        Normalised innovation squared ``νᵀ S⁻¹ ν`` of the last correction of each member (0 before the
        first one; kept by a member that skipped a missing sample); a NumPy ``float64`` scalar for a
        single run after a correction. Constant between samples (its time derivative is zero).

    Examples
    --------
    The EKF of a double integrator whose position is measured with ``R = 1``, from ``P0 = I``: one sample
    ``y = 2`` gives the gain ``K = P Cᵀ/(C P Cᵀ + R) = (0.5, 0)``, the mean ``(1, 0)``, the variance of the
    position halved, and the NIS ``ν²/S = 4/2``; a missing sample (NaN) leaves the state as it was:

    >>> import numpy as np
    >>> import nlobs
    >>> plant = nlobs.LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> ekf = nlobs.EKF(plant, Q=np.zeros((2, 2)), R=[[1.0]], P0=np.eye(2))
    >>> z = ekf.init([0.0, 0.0])
    >>> z.x.tolist(), z.P.tolist(), float(z.nis)
    ([0.0, 0.0], [[1.0, 0.0], [0.0, 1.0]], 0.0)
    >>> z1 = ekf.correct(0.0, z, np.zeros(1), np.array([2.0]), np.array([True]))
    >>> z1.x.tolist(), z1.P.tolist(), float(z1.nis)
    ([1.0, 0.0], [[0.5, 0.0], [0.0, 1.0]], 2.0)
    >>> ekf.correct(0.0, z, np.zeros(1), np.array([np.nan]), np.array([True])).x.tolist()
    [0.0, 0.0]

    Between samples ``rhs`` returns the rates in the same form: ``ẋ = A x`` and ``Ṗ = A P + P Aᵀ + Q``, the NIS
    constant; a batch of runs carries its leading axes in every field:

    >>> rate = ekf.rhs(0.0, z1, np.zeros(1), np.array([2.0]))
    >>> rate.x.tolist(), rate.P.tolist(), float(rate.nis)
    ([0.0, 0.0], [[0.0, 1.0], [1.0, 0.0]], 0.0)
    >>> batch = ekf.init(np.zeros((3, 2)))
    >>> batch.x.shape, batch.P.shape, batch.nis.shape
    ((3, 2), (3, 2, 2), (3,))
    """

    x: Array
    P: Array
    nis: Array


def checked_covariance(name: str, value: ArrayLike, n: int, *, definite: bool) -> Array:
    """``value`` as a read-only symmetric ``(n, n)`` matrix, positive (semi-)definite.

    Parameters
    ----------
    name : str
        Name of the argument, used in error messages.
    value : array_like, shape (n, n)
        The candidate covariance.
    n : int
        Expected dimension.
    definite : bool
        Require positive definite (True) or only positive semi-definite (False).

    Returns
    -------
    ndarray, shape (n, n)
        ``value`` as a read-only float array.

    Raises
    ------
    DimensionError, NonFiniteError
        Wrong shape, non-finite entry.
    NotSymmetricError
        Not symmetric (relative tolerance ``1e-9``).
    InvalidArgumentError
        Not positive definite (``definite``) or semi-definite (beyond ``-1e-12`` of its scale); the
        message gives the smallest eigenvalue.
    """
    M = as_symmetric(name, value, n)
    if n:
        lo = float(np.linalg.eigvalsh(M)[0])
        scale = max(1.0, float(np.max(np.abs(M))))
        if (lo <= 0.0) if definite else (lo < -1e-12 * scale):
            kind = "definite" if definite else "semi-definite"
            raise InvalidArgumentError(f"{name}: not symmetric positive {kind} (smallest eigenvalue {lo:.3g})")
    return readonly(M)


def checked_plant(plant: Any) -> tuple[int, int]:
    """``(n, p)`` of a plant a stochastic estimator can run on: a :class:`~nlobs.systems.base.PlantModel` with a
    continuous or discrete time base.

    Parameters
    ----------
    plant : PlantModel

    Returns
    -------
    n, p : int
        States and outputs.

    Raises
    ------
    InvalidArgumentError
        Not a plant, or another time base.

    Examples
    --------
    >>> import nlobs
    >>> checked_plant(nlobs.load_model("pendulum").compile())
    (2, 1)
    """
    if not isinstance(plant, PlantModel):
        raise InvalidArgumentError(f"plant: expected a PlantModel (time, states, inputs, outputs, rhs, output), "
                                   f"got {type(plant).__name__}")
    if not isinstance(plant.time, (Continuous, Discrete)):
        raise InvalidArgumentError(f"plant.time: expected Continuous or Discrete, got {plant.time!r}")
    return int(plant.n), int(plant.p)


#: The NIS's rate between samples for one run: a shared read-only zero (the NIS only changes at a correction).
ZERO_RATE = np.zeros(())
ZERO_RATE.flags.writeable = False


def symmetrised(M: Array) -> Array:
    """``(M + Mᵀ) / 2`` over the last two axes."""
    return 0.5 * (M + np.swapaxes(M, -1, -2))


@dataclass(frozen=True, eq=False)
class GaussianFilterBase(ToControl):
    """Common part of the EKF and the UKF (module docstring); not an observer by itself (no ``rhs``).

    Parameters
    ----------
    plant : PlantModel
        The model, with a :class:`~nlobs.systems.timebase.Continuous` or
        :class:`~nlobs.systems.timebase.Discrete` time base.
    Q : array_like, shape (n, n)
        Symmetric positive semi-definite process noise (spectral density or covariance, module docstring).
    R : array_like, shape (p, p)
        Symmetric positive definite covariance of the noise on all outputs.
    P0 : array_like, shape (n, n)
        Symmetric positive semi-definite initial covariance (:meth:`init`).
    name : str
        Label in results.
    record_covariance : bool
        Also record the full ``P`` among the diagnostics.
    bounds : StateBounds, optional
        Bounds on the state (:class:`~nlobs.systems.constraints.StateBounds`): the mean is projected onto them after
        each correction (estimate projection, Simon 2010, with the weight ``I``: the clip); the covariance is kept.

    Raises
    ------
    InvalidArgumentError
        ``plant`` is not a :class:`~nlobs.systems.base.PlantModel` with a continuous or discrete time base,
        a covariance is not positive (semi-)definite, or ``name`` is not a string.
    DimensionError, NonFiniteError, NotSymmetricError
        For ``Q``, ``R``, ``P0`` of the wrong shape, with a non-finite entry, not symmetric.
    """

    plant: PlantModel
    Q: Array
    R: Array
    P0: Array
    name: str = field(default="Gaussian filter", kw_only=True)
    record_covariance: bool = field(default=False, kw_only=True)
    bounds: Any = field(default=None, kw_only=True)
    time: TimeBase = field(init=False)
    n: int = field(init=False)
    p: int = field(init=False)
    discrete: bool = field(init=False, repr=False)

    def __post_init__(self) -> None:
        plant = self.plant
        n, p = checked_plant(plant)
        object.__setattr__(self, "time", plant.time)
        object.__setattr__(self, "n", n)
        object.__setattr__(self, "p", p)
        object.__setattr__(self, "discrete", bool(plant.time.is_discrete))
        object.__setattr__(self, "Q", checked_covariance("Q", self.Q, n, definite=False))
        object.__setattr__(self, "R", checked_covariance("R", self.R, p, definite=True))
        object.__setattr__(self, "P0", checked_covariance("P0", self.P0, n, definite=False))
        if not isinstance(self.name, str):
            raise InvalidArgumentError(f"name: expected a string, got {type(self.name).__name__}")
        object.__setattr__(self, "record_covariance", bool(self.record_covariance))
        if self.bounds is not None:
            from nlobs.systems.constraints import StateBounds

            if not isinstance(self.bounds, StateBounds):
                raise InvalidArgumentError(f"bounds: expected a StateBounds, got {type(self.bounds).__name__}")
            self.bounds.check_size(n)

    @property
    def n_x(self) -> int:
        """Estimate dimension (the plant's ``n``)."""
        return self.n

    def init(self, x_hat0: ArrayLike) -> FilterState:
        """Mean ``x_hat0`` ``(..., n)``, covariance :attr:`P0` on every member, NIS 0."""
        x = np.array(as_batch("x_hat0", x_hat0, self.n), dtype=float)
        batch = x.shape[:-1]
        return FilterState(x=x, P=np.broadcast_to(self.P0, batch + (self.n, self.n)).copy(), nis=np.zeros(batch))

    def estimate(self, z: FilterState) -> Array:
        """The mean ``z.x``."""
        return z.x

    def diagnostics(self, z: FilterState, u: Array) -> dict[str, Array]:
        """``P_diag`` (the variances ``(..., n)``), ``nis`` ``(...)`` and, with ``record_covariance``, ``P``."""
        out = {"P_diag": z.P.diagonal(0, -2, -1), "nis": z.nis}
        if self.record_covariance:
            out["P"] = z.P
        return out

    # ------------------------------------------------------------------ correction
    def _update(self, t: float, x: Array, P: Array, u: Array, y: Array,
                rows: Any) -> tuple[Array, Array, Array]:  # pragma: no cover - each filter has its own
        raise NotImplementedError

    def _diverged(self, t: float, what: str, exc: Exception | None = None) -> SimulationDiverged:
        err = SimulationDiverged(float(t), "observer", f"{self.name} covariance")
        why = f" ({exc})" if exc is not None else ""
        err.args = (f"{self.name} diverged at t = {float(t):g}: {what}{why}",)
        return err

    def correct(self, t: float, z: FilterState, u: Array, y: Array, fresh: BoolArray) -> FilterState:
        """Measurement update with the outputs where ``fresh`` is True (multi-rate sensors).

        ``R`` is restricted to the rows and columns of those outputs. A non-finite ``y`` at a fresh row
        is a missing sample of that batch member: that row is skipped for that member only (members
        are grouped by the rows they keep, usually one group). The covariance update is in Joseph
        form (:func:`~nlobs.observers.kalman.joseph_update`).

        Raises
        ------
        DimensionError
            ``fresh`` is not of shape ``(p,)``.
        SimulationDiverged
            The innovation covariance is singular or not finite.
        """
        mask = fresh if type(fresh) is np.ndarray and fresh.dtype == np.bool_ else np.asarray(fresh, dtype=bool)
        if mask.shape != (self.p,):
            raise DimensionError(f"fresh: expected shape ({self.p},), got {mask.shape}")
        if type(y) is not np.ndarray or y.dtype != np.float64:
            y = np.asarray(y, dtype=float)
        if all(mask.tolist()):  # cheaper than mask.all() for the few outputs of a sensor set
            rows: Array | None = None
            ys = y
        else:
            rows = np.flatnonzero(mask)
            if rows.size == 0:
                return z
            ys = y[..., rows]
        # one run: Python's isfinite on the few values is cheaper than np.isfinite(...).all()
        finite = all(map(math.isfinite, ys.tolist())) if ys.ndim == 1 else bool(np.isfinite(ys).all())
        try:
            if finite:
                x, P, nis = self._update(t, z.x, z.P, u, ys, rows)
            else:
                x, P, nis = self._update_missing(t, z, u, ys, np.isfinite(ys),
                                                 np.arange(self.p) if rows is None else rows)
        except np.linalg.LinAlgError as exc:
            raise self._diverged(t, "the innovation covariance is singular", exc) from None
        if not (math.isfinite(nis) if nis.ndim == 0 else np.isfinite(nis).all()):
            raise self._diverged(t, "the innovation covariance or the innovation is not finite")
        if self.bounds is not None:
            x = self.bounds.project(x)
        return FilterState(x, P, nis)

    def _update_missing(self, t: float, z: FilterState, u: Array, ys: Array, ok: BoolArray,
                        rows: Array) -> tuple[Array, Array, Array]:
        """The update of each group of members that keep the same rows (the others unchanged)."""
        n = self.n
        u = np.asarray(u, dtype=float)
        batch = np.broadcast_shapes(z.x.shape[:-1], ys.shape[:-1], u.shape[:-1])
        q = rows.size
        X = np.broadcast_to(z.x, batch + (n,)).reshape(-1, n)
        PP = np.broadcast_to(z.P, batch + (n, n)).reshape(-1, n, n)
        U = np.broadcast_to(u, batch + u.shape[-1:]).reshape(-1, u.shape[-1])
        Y = np.broadcast_to(ys, batch + (q,)).reshape(-1, q)
        OK = np.broadcast_to(ok, batch + (q,)).reshape(-1, q)
        x_out, P_out = X.copy(), PP.copy()
        nis_out = np.broadcast_to(z.nis, batch).reshape(-1).copy()
        patterns, which = np.unique(OK, axis=0, return_inverse=True)
        which = np.asarray(which).reshape(-1)
        for j, keep in enumerate(patterns):
            if not keep.any():
                continue
            idx = np.flatnonzero(which == j)
            xj, Pj, nj = self._update(t, X[idx], PP[idx], U[idx], Y[idx][:, keep], rows[keep])
            x_out[idx], P_out[idx], nis_out[idx] = xj, Pj, nj
        return x_out.reshape(batch + (n,)), P_out.reshape(batch + (n, n)), nis_out.reshape(batch)

    def _R_rows(self, rows: Array | None) -> Array:
        return self.R if rows is None else self.R[np.ix_(rows, rows)]
