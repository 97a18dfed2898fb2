r"""The discrete Lipschitz point observer (a baseline for the set-valued observer of Khajenejad & Yong).

Plant ((8) of Khajenejad & Yong, with ``f(x) = A x + φ(x)``):

.. math::

    x_{k+1} = A x_k + \varphi(x_k) + B u_k + G d_k + W w_k, \qquad
    y_k = C x_k + D u_k + H d_k + v_k .

:class:`DiscreteLipschitzObserver` — ``x̂_{k+1} = A x̂_k + φ(x̂_k) + B u_k + L (y_k − C x̂_k − D u_k)``
with ``L`` from :func:`nlobs.synthesis.discrete_lipschitz.design_discrete_lipschitz_gain`; it ignores ``d``,
so its error obeys ``e_{k+1} = (A − LC) e_k + Δφ_k + (G − LH) d_k + W w_k − L v_k``: bounded for bounded
``d``, growing with a growing ``d`` (``docs/baselines.md``). A discrete-time
:class:`~nlobs.observers.base.Observer` in predictor form: the estimate at ``k`` uses ``y_0 … y_{k−1}``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import cast

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_batch, as_matrix, as_square, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.systems.timebase import Discrete
from nlobs.observers.base import ToControl

__all__ = ["BatchedMap", "DiscreteLipschitzObserver"]

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
                             "(drop or hold a missing sample before the step)")
    return arr


def _phi_values(phi: BatchedMap | None, x: Array, n: int) -> Array:
    if phi is None:
        return np.zeros_like(x)
    out = np.asarray(phi(x), dtype=float)
    if out.shape != x.shape:
        raise DimensionError(f"phi: returned shape {out.shape} for x of shape {x.shape}; expected (..., {n})")
    return out


@dataclass(frozen=True, eq=False)
class DiscreteLipschitzObserver(ToControl):
    r"""Lipschitz point observer ``x̂⁺ = A x̂ + φ(x̂) + B u + L (y − C x̂ − D u)`` (ignores ``d``).

    Parameters
    ----------
    A : array_like, shape (n, n)
        Linear part of ``f``.
    C : array_like, shape (l, n)
    L : array_like, shape (n, l)
        Gain, e.g. ``design_discrete_lipschitz_gain(A, C, lipschitz=γ).L`` (its certificate
        gives ``‖e_k‖ ≤ √κ(P) ρᵏ ‖e_0‖`` for ``d = w = v = 0``).
    time : Discrete
        Sampling period of the model (required, never defaulted).
    phi : callable, optional
        Batched nonlinear part ``φ: (..., n) → (..., n)`` (``None``: linear plant).
    B : array_like, shape (n, m), optional
    D : array_like, shape (l, m), optional

    Notes
    -----
    Satisfies :class:`nlobs.observers.base.Observer` (``rhs`` is the discrete step ``z⁺``).

    Examples
    --------
    A sampled oscillator with the nonlinear part ``φ(x) = [0, 0.2 T sin x1]`` (Lipschitz with ``γ = 0.2 T``) and
    a gain certified for the contraction ``ρ = 0.9``: the certificate bounds the error by
    ``√κ(P) ρᵏ ‖e_0‖``, and a run (plant and observer stepped by hand) stays under that bound:

    >>> import numpy as np
    >>> import nlobs
    >>> T = 0.1
    >>> A, C = np.array([[1.0, T], [-T, 1.0]]), np.array([[1.0, 0.0]])
    >>> def phi(x):
    ...     return np.stack([0.0 * x[..., 0], 0.2 * T * np.sin(x[..., 0])], axis=-1)
    >>> cert = nlobs.design_discrete_lipschitz_gain(A, C, lipschitz=0.2 * T, rho=0.9)
    >>> observer = nlobs.DiscreteLipschitzObserver(A, C, cert.gain, nlobs.Discrete(T), phi=phi)
    >>> x, z = np.array([1.0, -1.0]), observer.init([0.0, 0.0])
    >>> errors = []
    >>> for k in range(40):
    ...     errors.append(np.linalg.norm(observer.estimate(z) - x))
    ...     x, z = A @ x + phi(x), observer.rhs(k * T, z, None, C @ x)
    >>> bound = cert.transient * cert.rho ** np.arange(40) * errors[0]
    >>> cert.verified, bool(np.all(errors <= bound)), bool(errors[-1] < 1e-2 * errors[0])
    (True, True, True)
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

    def rhs(self, t: float, z: Array, u: ArrayLike | None, y: ArrayLike) -> Array:
        """``x̂_{k+1}`` from ``x̂_k``, ``u_k`` and ``y_k`` (batched; ``u`` may be ``None`` when ``m = 0``)."""
        B, D = cast(Array, self.B), cast(Array, self.D)   # matrices after __post_init__
        uu = _finite_batch("u", u, B.shape[1])
        yy = _finite_batch("y", y, self.C.shape[0])
        innovation = yy - z @ self.C.T - uu @ D.T
        return z @ self.A.T + _phi_values(self.phi, z, self.n_z) + uu @ B.T + innovation @ self.L.T

    def estimate(self, z: Array) -> Array:
        """The estimate is the observer state."""
        return z
