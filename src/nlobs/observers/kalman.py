r"""Kalman filters: the Gaussian state, the one Joseph-form update, and the unknown-input EKF baseline.

:class:`UnknownInputEKF` is an extended Kalman filter for the plant (8) of Khajenejad & Yong that models
the unknown input ``d`` as zero-mean white noise of covariance ``Q_d`` (so ``G d`` is process noise and
``H d`` measurement noise, correlated through ``S = G Q_d Hᵀ``): what a user would compare the
set-valued observer against (``docs/baselines.md``). A discrete-time
:class:`~nlobs.observers.base.Observer` whose state is a :class:`GaussianState`; ``rhs`` is one
update with ``y_k`` followed by one prediction, so the estimate at ``k`` is the prior ``x̂_{k|k−1}``
(predictor form, like the Lipschitz baseline); :meth:`UnknownInputEKF.update` and
:meth:`UnknownInputEKF.predict` are the two halves, as functions of the state (filterpy's
procedural form).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_batch, as_matrix, as_square, as_symmetric, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, SimulationDiverged
from nlobs.observers.lipschitz import BatchedMap, _finite_batch, _optional, _phi_values
from nlobs.systems.timebase import Discrete
from nlobs.observers.base import ToControl

__all__ = ["GaussianState", "UnknownInputEKF", "joseph_update"]


@dataclass(frozen=True)
class GaussianState:
    """A Kalman filter's state: mean ``x`` ``(..., n)`` and covariance ``P`` ``(..., n, n)``.

    After :meth:`UnknownInputEKF.init` or :meth:`UnknownInputEKF.rhs` these are the
    prior ``x̂_{k|k−1}``, ``P_{k|k−1}``; after :meth:`UnknownInputEKF.update` the
    posterior ``x̂_{k|k}``, ``P_{k|k}``.

    Attributes
    ----------
    x : ndarray, shape (..., n)
        Mean (the estimate).
    P : ndarray, shape (..., n, n)
        Covariance.

    Examples
    --------
    A random walk ``x⁺ = x + w`` (``Q_w = 0.25``) measured as ``y = x + v`` (``R_v = 1``), from the prior
    ``x̂ = 0``, ``P = 1``: the update with ``y = 2`` (gain ``K = 1/2``) gives the posterior ``(1, 0.5)``, the
    prediction adds ``Q_w`` to the variance, and ``rhs`` is the two in one step:

    >>> import numpy as np
    >>> import nlobs
    >>> ekf = nlobs.UnknownInputEKF([[1.0]], [[1.0]], nlobs.Discrete(1.0), Q_w=[[0.25]], R_v=[[1.0]], P0=[[1.0]])
    >>> prior = ekf.init([0.0])
    >>> isinstance(prior, GaussianState), prior.x.tolist(), prior.P.tolist()
    (True, [0.0], [[1.0]])
    >>> posterior = ekf.update(prior, None, [2.0])
    >>> posterior.x.tolist(), posterior.P.tolist()
    ([1.0], [[0.5]])
    >>> nxt = ekf.predict(posterior, None, [2.0])
    >>> nxt.x.tolist(), nxt.P.tolist()
    ([1.0], [[0.75]])
    >>> step = ekf.rhs(0.0, prior, np.zeros(0), np.array([2.0]))
    >>> step.x.tolist(), step.P.tolist()
    ([1.0], [[0.75]])
    """

    x: Array
    P: Array


def joseph_update(P: Array, H: Array, R: Array, innovation: Array, *, nis: bool = False) -> tuple[Array, ...]:
    """Kalman correction ``K ν`` and the Joseph-form covariance, batched (the one implementation in nlobs).

    Parameters
    ----------
    P : ndarray, shape (..., n, n)
        Prior covariance.
    H : ndarray, shape (q, n) or (..., q, n)
        Measurement matrix (may vary along the batch).
    R : ndarray, shape (q, q) or (..., q, q)
        Measurement covariance (may vary along the batch: the unscented filter's effective one).
    innovation : ndarray, shape (..., q)
    nis : bool
        Also return the normalised innovation squared ``νᵀ S⁻¹ ν`` (from the same solve with ``S``).

    Returns
    -------
    dx : ndarray, shape (..., n)
        ``K ν`` with ``K = P Hᵀ S⁻¹``, ``S = H P Hᵀ + R``.
    P_new : ndarray, shape (..., n, n)
        ``(I − KH) P (I − KH)ᵀ + K R Kᵀ``, symmetrised: positive semi-definite for any
        gain under rounding, unlike ``(I − KH) P``.
    nis : ndarray, shape (...)
        Only with ``nis=True``: ``νᵀ S⁻¹ ν``.

    Raises
    ------
    numpy.linalg.LinAlgError
        ``S`` is singular (the caller names the time).

    Examples
    --------
    Two states with the correlated prior ``P = [[2, 1], [1, 2]]``, the first measured (``R = 1``) with the
    innovation ``ν = 3``: ``S = 3``, ``K = (2/3, 1/3)``, so ``K ν = (2, 1)``; without rounding the Joseph form
    equals the short form ``(I − K H) P``:

    >>> import numpy as np
    >>> P, H, R = np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([[1.0, 0.0]]), np.array([[1.0]])
    >>> dx, P_new, nis = joseph_update(P, H, R, np.array([3.0]), nis=True)
    >>> dx.round(6).tolist(), round(float(nis), 6)  # ν² / S = 9 / 3
    ([2.0, 1.0], 3.0)
    >>> K = P @ H.T / 3.0
    >>> bool(np.allclose(P_new, (np.eye(2) - K @ H) @ P)), (P_new * 3).round(6).tolist()
    (True, [[2.0, 1.0], [1.0, 5.0]])

    Batched: one update per leading index (here three priors ``k I``, each with ``ν = 1``):

    >>> Pb = np.arange(1.0, 4.0)[:, None, None] * np.eye(2)
    >>> dx, P_new, nis = joseph_update(Pb, H, R, np.ones((3, 1)), nis=True)
    >>> dx.shape, P_new.shape, nis.round(4).tolist()  # ν² / (k + 1)
    ((3, 2), (3, 2, 2), [0.5, 0.3333, 0.25])
    """
    if P.ndim == 2 and H.ndim == 2 and R.ndim == 2 and innovation.ndim == 1:
        return _joseph_one(P, H, R, innovation, nis)
    PHt = P @ H.mT
    S = H @ PHt + R
    # K = P Hᵀ S⁻¹  ⇔  Kᵀ = S⁻¹ H P (S, P symmetric); with nis, ν is one more right-hand side
    # of the same solve
    HP = PHt.mT
    if nis:
        batch = np.broadcast_shapes(HP.shape[:-2], innovation.shape[:-1], S.shape[:-2])
        rhs = np.concatenate([np.broadcast_to(HP, batch + HP.shape[-2:]),
                              np.broadcast_to(innovation, batch + innovation.shape[-1:])[..., None]], axis=-1)
        sol = np.linalg.solve(S, rhs)
        K = sol[..., :-1].mT
        value = np.einsum("...i,...i->...", innovation, sol[..., -1])
    else:
        K = np.linalg.solve(S, HP).mT
    IKH = _eye(P.shape[-1]) - K @ H
    P_new = IKH @ P @ IKH.mT + K @ R @ K.mT
    P_new = 0.5 * (P_new + P_new.mT)
    dx = (K @ innovation[..., None])[..., 0]
    return (dx, P_new, value) if nis else (dx, P_new)


@functools.lru_cache(maxsize=64)
def _eye(n: int) -> Array:
    """The identity of size ``n``, read-only (made once per size)."""
    return readonly(np.eye(n), owned=True)


def _inverse(S: Array) -> Array:
    """``S⁻¹`` of a small matrix: closed form for 1 × 1 and 2 × 2 (a fifth of ``np.linalg.inv``'s cost there)."""
    q = S.shape[0]
    if q == 1:
        s = float(S[0, 0])
        if s == 0.0:
            raise np.linalg.LinAlgError("Singular matrix")
        return np.array([[1.0 / s]])
    if q == 2:
        a, b, c, d = S.ravel().tolist()
        det = a * d - b * c
        if det == 0.0:
            raise np.linalg.LinAlgError("Singular matrix")
        return np.array([[d / det, -b / det], [-c / det, a / det]])
    return np.linalg.inv(S)


def _joseph_one(P: Array, H: Array, R: Array, innovation: Array, nis: bool) -> tuple[Array, ...]:
    """:func:`joseph_update` for one run (2-d matrices): the same formulas with ``ndarray.dot`` (a third of
    the cost of ``@`` on small matrices) and ``S⁻¹`` formed once."""
    PHt = P.dot(H.T)
    Sinv = _inverse(H.dot(PHt) + R)
    K = PHt.dot(Sinv)
    IKH = _eye(P.shape[0]) - K.dot(H)
    P_new = IKH.dot(P).dot(IKH.T) + K.dot(R).dot(K.T)
    P_new = P_new + P_new.T.copy()  # adding a contiguous copy is cheaper than adding the strided view
    P_new *= 0.5
    w = Sinv.dot(innovation)  # S⁻¹ ν: K ν = P Hᵀ S⁻¹ ν and the NIS νᵀ S⁻¹ ν
    dx = PHt.dot(w)
    if nis:
        return dx, P_new, innovation.dot(w)  # a NumPy float64 scalar (0-d)
    return dx, P_new


@dataclass(frozen=True, eq=False)
class UnknownInputEKF(ToControl):
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
    P0 : array_like, shape (n, n), optional
        Initial covariance used by :meth:`init` (the protocol's ``init(x_hat0)``); required there.
    name : str
        Label of the filter in results.

    Examples
    --------
    A sampled oscillator driven through ``G`` by an unknown input ``d`` (here a constant 1), recorded by
    :func:`~nlobs.simulate.simulate` with ``d`` as the plant's input; the filter that models ``d`` as white
    noise of covariance ``Q_d`` keeps a much smaller error than the one that ignores it (no ``Q_d``):

    >>> import numpy as np
    >>> import nlobs
    >>> T = 0.1
    >>> A, G, C = [[1.0, T], [-T, 1.0 - 0.1 * T]], [[0.0], [T]], [[1.0, 0.0]]
    >>> plant = nlobs.LinearSystem(A, G, C, time=nlobs.Discrete(T))  # its input is d, unknown to the filters
    >>> data = nlobs.simulate(plant, None, [0.0, 0.0], duration=6.0, u=1.0)
    >>> def final_error(**unknown_input):
    ...     filt = nlobs.UnknownInputEKF(A, C, nlobs.Discrete(T), Q_w=1e-6 * np.eye(2), R_v=[[1e-4]], P0=np.eye(2),
    ...                                  **unknown_input)
    ...     res = nlobs.run_observer(filt, data.t, x_hat0=[0.0, 0.0], y=data.y, truth=data.x)
    ...     return float(res.error_norm[-1])
    >>> round(final_error(Q_d=[[1.0]], G=G), 2), round(final_error(), 2)
    (0.26, 1.23)
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
    P0: Array | None = None
    name: str = "EKF (d as noise)"
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
        if self.P0 is not None:
            P0 = as_symmetric("P0", self.P0, n)
            if np.linalg.eigvalsh(P0)[0] < 0:
                raise InvalidArgumentError("P0: must be positive semi-definite")
            object.__setattr__(self, "P0", readonly(P0))

    @property
    def n_x(self) -> int:
        """Estimate dimension (``n``)."""
        return int(self.A.shape[0])

    @property
    def n(self) -> int:
        """State dimension."""
        return int(self.A.shape[0])

    def init(self, x_hat0: ArrayLike) -> GaussianState:
        """Prior at ``k = 0``: mean ``x_hat0`` ``(..., n)`` and the covariance :attr:`P0` (protocol form)."""
        if self.P0 is None:
            raise InvalidArgumentError("P0: this filter has no initial covariance; give P0= or use init_state")
        return self.init_state(x_hat0, self.P0)

    def init_state(self, x_hat0: ArrayLike, P0: ArrayLike) -> GaussianState:
        """Prior at ``k = 0``: mean ``x_hat0`` ``(..., n)`` and covariance ``P0`` ``(n, n)`` or ``(..., n, n)``."""
        x = np.array(as_batch("x_hat0", x_hat0, self.n), dtype=float)
        P = np.asarray(P0, dtype=float)
        if P.ndim < 2 or P.shape[-2:] != (self.n, self.n):
            raise DimensionError(f"P0: expected shape (..., {self.n}, {self.n}), got {P.shape}")
        if P.ndim == 2:
            P = as_symmetric("P0", P, self.n)
        batch = np.broadcast_shapes(x.shape[:-1], P.shape[:-2])
        return GaussianState(x=np.broadcast_to(x, batch + (self.n,)).copy(),
                             P=np.broadcast_to(P, batch + (self.n, self.n)).copy())

    def _innovation(self, x: Array, u: Array, y: Array) -> Array:
        return y - x @ self.C.T - u @ cast(Array, self.D).T

    def _inputs(self, u: ArrayLike | None, y: ArrayLike) -> tuple[Array, Array]:
        return (_finite_batch("u", u, cast(Array, self.B).shape[1]),
                _finite_batch("y", y, self.C.shape[0]))

    def update(self, state: GaussianState, u: ArrayLike | None, y: ArrayLike) -> GaussianState:
        """Measurement update with ``y_k`` (Joseph form): the posterior ``x̂_{k|k}``, ``P_{k|k}``."""
        uu, yy = self._inputs(u, y)
        dx, P = joseph_update(state.P, self.C, self.R, self._innovation(state.x, uu, yy))
        return GaussianState(x=state.x + dx, P=P)

    def predict(self, posterior: GaussianState, u: ArrayLike | None, y: ArrayLike) -> GaussianState:
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
        return GaussianState(x=x_next, P=0.5 * (P + np.swapaxes(P, -1, -2)))

    def rhs(self, t: float, state: GaussianState, u: ArrayLike | None, y: ArrayLike) -> GaussianState:
        """Update with ``y_k`` then predict: the prior at ``k + 1`` from the prior at ``k`` (``z⁺``).

        Raises
        ------
        SimulationDiverged
            The innovation covariance became singular or non-finite (``LinAlgError``): the time and the
            step are named.
        """
        try:
            return self.predict(self.update(state, u, y), u, y)
        except np.linalg.LinAlgError as exc:
            k = int(round(t / self.time.dt))
            err = SimulationDiverged(float(t), "observer", "EKF covariance")
            err.args = (f"EKF diverged at step {k} ({exc}: its covariance is no longer finite/invertible)",)
            raise err from None

    def estimate(self, state: GaussianState) -> Array:
        """The mean ``x`` of ``state``."""
        return state.x
