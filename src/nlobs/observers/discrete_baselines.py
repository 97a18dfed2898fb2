r"""Point observers a user would compare the seed-004 set-valued observer against (its Sec. 6.2).

Plant (seed 004, (8), with ``f(x) = A x + φ(x)``):

.. math::

    x_{k+1} = A x_k + \varphi(x_k) + B u_k + G d_k + W w_k, \qquad
    y_k = C x_k + D u_k + H d_k + v_k .

Both baselines treat the unknown input ``d`` as something bounded or random, which is what
the set-valued observer does *not* assume (``docs/baselines.md``):

* :class:`DiscreteLipschitzObserver` — ``x̂_{k+1} = A x̂_k + φ(x̂_k) + B u_k + L (y_k − C x̂_k − D u_k)``
  with ``L`` from :func:`nlobs.synthesis.discrete_lipschitz.design_discrete_lipschitz_gain`;
  it ignores ``d``, so its error obeys
  ``e_{k+1} = (A − LC) e_k + Δφ_k + (G − LH) d_k + W w_k − L v_k``: bounded for bounded ``d``,
  growing with a growing ``d``.
* :class:`UnknownInputEKF` — an extended Kalman filter that models ``d`` as zero-mean white
  noise of covariance ``Q_d`` (so ``G d`` is process noise and ``H d`` measurement noise,
  correlated through ``S = G Q_d Hᵀ``), with a Joseph-form update.

Conventions: explicit state in and out; every array has a leading batch axis (Monte
Carlo), ``x`` of shape ``(..., n)``, ``u`` ``(..., m)``, ``y`` ``(..., l)``, covariances
``(..., n, n)``. The estimate after processing ``y_0 … y_{k−1}`` is the state at ``k``
(predictor form, like the set-valued observer's ``x̂_{k|k−1}``); the EKF also gives the
filtered ``x̂_{k|k}`` (:meth:`UnknownInputEKF.update`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_batch, as_matrix, as_square, as_symmetric, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.systems.timebase import Discrete

__all__ = ["DiscreteLipschitzObserver", "EkfState", "UnknownInputEKF", "joseph_update"]

Array = NDArray[np.float64]
BatchedMap = Callable[[Array], Array]



def _optional(name: str, value: ArrayLike | None, rows: int, cols: int | None) -> Array:
    if value is None:
        return np.zeros((rows, 0 if cols is None else cols))
    return as_matrix(name, value, (rows, cols))


def _finite_batch(name: str, value: ArrayLike | None, n: int) -> Array:
    if value is None:
        if n == 0:
            return np.zeros((0,))
        raise DimensionError(f"{name}: required (shape (..., {n}))")
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != n:
        raise DimensionError(f"{name}: expected shape (..., {n}), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        idx = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
        raise NonFiniteError(f"{name}: entry {idx} is {float(arr[idx])!r}; measurements and inputs must be finite "
                             "(drop or hold a missing sample before calling step)")
    return arr


def _phi_values(phi: BatchedMap | None, x: Array, n: int) -> Array:
    if phi is None:
        return np.zeros_like(x)
    out = np.asarray(phi(x), dtype=float)
    if out.shape != x.shape:
        raise DimensionError(f"phi: returned shape {out.shape} for x of shape {x.shape}; expected (..., {n})")
    return out


@dataclass(frozen=True, eq=False)
class DiscreteLipschitzObserver:
    r"""Lipschitz point observer ``x̂⁺ = A x̂ + φ(x̂) + B u + L (y − C x̂ − D u)`` (ignores ``d``).

    Parameters
    ----------
    A : array_like, shape (n, n)
        Linear part of ``f``.
    C : array_like, shape (l, n)
    L : array_like, shape (n, l)
        Gain, e.g. ``design_discrete_lipschitz_gain(A, C, lipschitz=γ).gain`` (its certificate
        gives ``‖e_k‖ ≤ √κ(P) ρᵏ ‖e_0‖`` for ``d = w = v = 0``).
    time : Discrete
        Sampling period of the model (required, never defaulted).
    phi : callable, optional
        Batched nonlinear part ``φ: (..., n) → (..., n)`` (``None``: linear plant).
    B : array_like, shape (n, m), optional
    D : array_like, shape (l, m), optional

    Notes
    -----
    Satisfies :class:`nlobs.observers.base.Observer` (``rhs`` is the discrete step).
    """

    A: Array
    C: Array
    L: Array
    time: Discrete
    phi: BatchedMap | None = None
    B: Array | None = None
    D: Array | None = None
    state_names: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        if not isinstance(self.time, Discrete):
            raise InvalidArgumentError(f"time: expected a Discrete time base, got {self.time!r}")
        A = as_square("A", self.A)
        n = A.shape[0]
        C = as_matrix("C", self.C, (None, n))
        L = as_matrix("L", self.L, (n, C.shape[0]))
        B = _optional("B", self.B, n, None)
        D = _optional("D", self.D, C.shape[0], B.shape[1])
        if self.phi is not None and not callable(self.phi):
            raise InvalidArgumentError("phi: expected a batched callable (..., n) -> (..., n) or None")
        for name, val in (("A", A), ("C", C), ("L", L), ("B", B), ("D", D)):
            object.__setattr__(self, name, readonly(val))
        object.__setattr__(self, "state_names", tuple(f"x{i + 1}_hat" for i in range(n)))

    @property
    def n_z(self) -> int:
        """Observer state dimension (``n``)."""
        return int(self.A.shape[0])

    @property
    def n_x(self) -> int:
        """Estimate dimension (``n``)."""
        return int(self.A.shape[0])

    @property
    def error_matrix(self) -> Array:
        """``A − L C``, the linear part of the error dynamics."""
        return self.A - self.L @ self.C

    def init(self, x_hat0: ArrayLike) -> Array:
        """Observer state from the initial estimate, shape ``(..., n)``."""
        return np.array(as_batch("x_hat0", x_hat0, self.n_z), dtype=float)

    def step(self, z: Array, u: ArrayLike | None, y: ArrayLike) -> Array:
        """``x̂_{k+1}`` from ``x̂_k``, ``u_k`` and ``y_k`` (batched)."""
        B, D = cast(Array, self.B), cast(Array, self.D)   # matrices after __post_init__
        uu = _finite_batch("u", u, B.shape[1])
        yy = _finite_batch("y", y, self.C.shape[0])
        innovation = yy - z @ self.C.T - uu @ D.T
        return z @ self.A.T + _phi_values(self.phi, z, self.n_z) + uu @ B.T + innovation @ self.L.T

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """:meth:`step` under the :class:`~nlobs.observers.base.Observer` protocol (``z⁺``)."""
        return self.step(z, u, y)

    def estimate(self, z: Array) -> Array:
        """The estimate is the observer state."""
        return z


@dataclass(frozen=True)
class EkfState:
    """EKF state at step ``k``: mean ``x`` ``(..., n)`` and covariance ``P`` ``(..., n, n)``.

    After :meth:`UnknownInputEKF.init` or :meth:`UnknownInputEKF.step` these are the
    prior ``x̂_{k|k−1}``, ``P_{k|k−1}``; after :meth:`UnknownInputEKF.update` the
    posterior ``x̂_{k|k}``, ``P_{k|k}``.
    """

    x: Array
    P: Array


def joseph_update(P: Array, H: Array, R: Array, innovation: Array) -> tuple[Array, Array]:
    """Kalman correction ``K ν`` and the Joseph-form covariance, batched (the one implementation in nlobs).

    Parameters
    ----------
    P : ndarray, shape (..., n, n)
        Prior covariance.
    H : ndarray, shape (q, n) or (..., q, n)
        Measurement matrix (may vary along the batch).
    R : ndarray, shape (q, q)
        Measurement covariance.
    innovation : ndarray, shape (..., q)

    Returns
    -------
    dx : ndarray, shape (..., n)
        ``K ν`` with ``K = P Hᵀ (H P Hᵀ + R)⁻¹``.
    P_new : ndarray, shape (..., n, n)
        ``(I − KH) P (I − KH)ᵀ + K R Kᵀ``, symmetrised: positive semi-definite for any
        gain under rounding, unlike ``(I − KH) P``.
    """
    PHt = P @ np.swapaxes(H, -1, -2)
    S = H @ PHt + R
    # K = P Hᵀ S⁻¹  ⇔  Kᵀ = S⁻¹ H P (S, P symmetric)
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)
    IKH = np.eye(P.shape[-1]) - K @ H
    P_new = IKH @ P @ np.swapaxes(IKH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    P_new = 0.5 * (P_new + np.swapaxes(P_new, -1, -2))
    return np.einsum("...ij,...j->...i", K, innovation), P_new


@dataclass(frozen=True, eq=False)
class UnknownInputEKF:
    r"""EKF that models the unknown input ``d`` as white noise of covariance ``Q_d``.

    Model: ``ω_k = G d_k + W w_k`` (covariance ``Q = W Q_w Wᵀ + G Q_d Gᵀ``),
    ``ν_k = H d_k + v_k`` (``R̃ = R_v + H Q_d Hᵀ``), correlated by ``S = G Q_d Hᵀ``.

    * update (Joseph form): ``K = P Cᵀ(C P Cᵀ + R̃)⁻¹``, ``x̂_{k|k} = x̂ + K(y − C x̂ − D u)``,
      ``P_{k|k} = (I − KC) P (I − KC)ᵀ + K R̃ Kᵀ``;
    * predict, with the correlation removed by ``J = S R̃⁻¹`` (``ω − Jν`` is uncorrelated
      with ``ν``): ``x̂_{k+1|k} = f(x̂_{k|k}) + B u + J (y − C x̂_{k|k} − D u)``,
      ``P_{k+1|k} = (F − JC) P_{k|k} (F − JC)ᵀ + Q − J Sᵀ``, ``F = A + ∂φ/∂x(x̂_{k|k})``.

    For a linear plant (``φ = 0``) this is the Kalman filter with correlated noises.

    Parameters
    ----------
    A, C : array_like
        ``(n, n)``, ``(l, n)``.
    time : Discrete
        Sampling period (required).
    Q_w, R_v : array_like
        Covariances of ``w`` (``(n_w, n_w)``, with ``W``) and ``v`` (``(l, l)``); for bounded
        noises a common choice is ``(η/3)² I`` or the uniform-ball covariance.
    Q_d : array_like, shape (p, p), optional
        Covariance assumed for ``d`` (with ``G``, ``H``); ``None``: ``d`` ignored.
    phi, phi_jacobian : callable, optional
        Batched ``φ: (..., n) → (..., n)`` and its Jacobian ``(..., n) → (..., n, n)`` (both
        or neither).
    B, D, G, H, W : array_like, optional
        ``(n, m)``, ``(l, m)``, ``(n, p)``, ``(l, p)``, ``(n, n_w)`` (``W`` default ``I``).
    """

    A: Array
    C: Array
    time: Discrete
    Q_w: Array
    R_v: Array
    Q_d: Array | None = None
    phi: BatchedMap | None = None
    phi_jacobian: BatchedMap | None = None
    B: Array | None = None
    D: Array | None = None
    G: Array | None = None
    H: Array | None = None
    W: Array | None = None
    Q: Array = field(init=False)
    R: Array = field(init=False)
    S: Array = field(init=False)
    J: Array = field(init=False)

    def __post_init__(self) -> None:
        if not isinstance(self.time, Discrete):
            raise InvalidArgumentError(f"time: expected a Discrete time base, got {self.time!r}")
        A = as_square("A", self.A)
        n = A.shape[0]
        C = as_matrix("C", self.C, (None, n))
        l = C.shape[0]
        B = _optional("B", self.B, n, None)
        D = _optional("D", self.D, l, B.shape[1])
        W = np.eye(n) if self.W is None else as_matrix("W", self.W, (n, None))
        Q_w = as_symmetric("Q_w", self.Q_w, W.shape[1])
        R_v = as_symmetric("R_v", self.R_v, l)
        if self.Q_d is None:
            G, H, Q_d = np.zeros((n, 0)), np.zeros((l, 0)), np.zeros((0, 0))
        else:
            Q_d = as_symmetric("Q_d", self.Q_d)
            p = Q_d.shape[0]
            G = np.zeros((n, p)) if self.G is None else as_matrix("G", self.G, (n, p))
            H = np.zeros((l, p)) if self.H is None else as_matrix("H", self.H, (l, p))
        for name, M in (("Q_w", Q_w), ("Q_d", Q_d)):
            if M.size and np.linalg.eigvalsh(M)[0] < -1e-12 * max(1.0, float(np.max(np.abs(M)))):
                raise InvalidArgumentError(f"{name}: must be positive semi-definite")
        if l and np.linalg.eigvalsh(R_v)[0] <= 0:
            raise InvalidArgumentError("R_v: must be positive definite")
        if (self.phi is None) != (self.phi_jacobian is None):
            raise InvalidArgumentError("phi, phi_jacobian: give both (a nonlinear plant) or neither (a linear one)")
        Q = W @ Q_w @ W.T + G @ Q_d @ G.T
        R = R_v + H @ Q_d @ H.T
        S = G @ Q_d @ H.T
        if l and not (np.all(np.isfinite(R)) and np.linalg.cond(R) < 1.0 / np.finfo(float).eps):
            raise InvalidArgumentError(
                f"R_v + H Q_d H^T: numerically singular (condition number {np.linalg.cond(R):.3g}): Q_d "
                f"(largest {float(np.max(np.abs(Q_d), initial=0.0)):.3g}) swamps the measurement noise R_v")
        J = np.linalg.solve(R, S.T).T if l else np.zeros((n, 0))
        for name, val in (("A", A), ("C", C), ("B", B), ("D", D), ("G", G), ("H", H), ("W", W), ("Q_w", Q_w),
                          ("R_v", R_v), ("Q_d", Q_d), ("Q", 0.5 * (Q + Q.T)), ("R", 0.5 * (R + R.T)), ("S", S),
                          ("J", J)):
            object.__setattr__(self, name, readonly(val))

    @property
    def n(self) -> int:
        """State dimension."""
        return int(self.A.shape[0])

    def init(self, x_hat0: ArrayLike, P0: ArrayLike) -> EkfState:
        """Prior at ``k = 0``: mean ``x_hat0`` ``(..., n)`` and covariance ``P0`` ``(n, n)`` or ``(..., n, n)``."""
        x = np.array(as_batch("x_hat0", x_hat0, self.n), dtype=float)
        P = np.asarray(P0, dtype=float)
        if P.ndim < 2 or P.shape[-2:] != (self.n, self.n):
            raise DimensionError(f"P0: expected shape (..., {self.n}, {self.n}), got {P.shape}")
        if P.ndim == 2:
            P = as_symmetric("P0", P, self.n)
        batch = np.broadcast_shapes(x.shape[:-1], P.shape[:-2])
        return EkfState(x=np.broadcast_to(x, batch + (self.n,)).copy(),
                        P=np.broadcast_to(P, batch + (self.n, self.n)).copy())

    def _innovation(self, x: Array, u: Array, y: Array) -> Array:
        return y - x @ self.C.T - u @ cast(Array, self.D).T

    def _inputs(self, u: ArrayLike | None, y: ArrayLike) -> tuple[Array, Array]:
        return (_finite_batch("u", u, cast(Array, self.B).shape[1]),
                _finite_batch("y", y, self.C.shape[0]))

    def update(self, state: EkfState, u: ArrayLike | None, y: ArrayLike) -> EkfState:
        """Measurement update with ``y_k`` (Joseph form): the posterior ``x̂_{k|k}``, ``P_{k|k}``."""
        uu, yy = self._inputs(u, y)
        dx, P = joseph_update(state.P, self.C, self.R, self._innovation(state.x, uu, yy))
        return EkfState(x=state.x + dx, P=P)

    def predict(self, posterior: EkfState, u: ArrayLike | None, y: ArrayLike) -> EkfState:
        """Time update from the posterior at ``k`` to the prior at ``k + 1`` (``y_k`` enters via ``J``)."""
        uu, yy = self._inputs(u, y)
        x = posterior.x
        x_next = x @ self.A.T + _phi_values(self.phi, x, self.n) + uu @ cast(Array, self.B).T
        F = np.broadcast_to(self.A, x.shape[:-1] + (self.n, self.n))
        if self.phi_jacobian is not None:
            Jphi = np.asarray(self.phi_jacobian(x), dtype=float)
            if Jphi.shape != x.shape[:-1] + (self.n, self.n):
                raise DimensionError(f"phi_jacobian: returned shape {Jphi.shape}; expected (..., {self.n}, {self.n})")
            F = F + Jphi
        if self.J.size:
            x_next = x_next + self._innovation(x, uu, yy) @ self.J.T
            F = F - self.J @ self.C
        P = F @ posterior.P @ np.swapaxes(F, -1, -2) + (self.Q - self.J @ self.S.T)
        return EkfState(x=x_next, P=0.5 * (P + np.swapaxes(P, -1, -2)))

    def step(self, state: EkfState, u: ArrayLike | None, y: ArrayLike) -> EkfState:
        """Update with ``y_k`` then predict: the prior at ``k + 1`` from the prior at ``k``."""
        return self.predict(self.update(state, u, y), u, y)

    def estimate(self, state: EkfState) -> Array:
        """The mean ``x`` of ``state``."""
        return state.x
