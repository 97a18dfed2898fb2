r"""Saturations that make local Lipschitz conditions global (Grip, Saberi & Johansen, Appendix A).

If the signals ``u, u̇, x, z`` are known to stay in compact sets, the global
Lipschitz-type Assumptions 2 and 3 of Grip, Saberi & Johansen can be obtained from
*local* smoothness by saturating arguments (Appendix A):

* :class:`Saturation` — the component-wise hard saturation ``sat(z)`` used in
  ``g(u, x̂, sat(z))``: ``sat(z) = z`` on the box ``Z = [lower, upper]``, Lipschitz
  with constant 1, so ``‖g(·, sat z) − g(·, sat ẑ)‖ ≤ L₁‖sat z − sat ẑ‖ ≤ L₁‖z − ẑ‖``.
* :class:`SmoothSaturation` — the smooth ``sat*(x)`` used in the design model
  ``f_s(u, x) = f(u, sat*(x))``, ``h_s(u, x) = h(u, sat*(x))``; Appendix A needs
  ``∂sat*/∂x`` bounded **and** Lipschitz, which a hard saturation does not offer.

Construction of ``sat*`` (per component, identity box ``[l, h]``, transition
width ``δ > 0``). With ``S(τ) = 3τ² − 2τ³`` (the cubic smoothstep) and
``τ = (x − h)/δ`` above the box:

.. math::

    \mathrm{sat}^*(x) = \begin{cases}
        x, & l \le x \le h, \\
        h + δ\,(τ − τ^3 + τ^4/2), & 0 < τ < 1, \\
        h + δ/2, & τ \ge 1,
    \end{cases}
    \qquad
    \frac{d\,\mathrm{sat}^*}{dx} = 1 − S(\min(τ, 1)),

and symmetrically below ``l`` (``τ = (l − x)/δ``, value ``l − δ(τ − τ³ + τ⁴/2)``).
Hence ``sat*`` is C² (``d²sat*/dx² = −6τ(1 − τ)/δ`` vanishes at both ends of the
transition), equals ``x`` on ``[l, h]``, is bounded by ``[l − δ/2, h + δ/2]``, has
derivative in ``[0, 1]`` (so ``sat*`` is 1-Lipschitz) and the derivative is
Lipschitz with constant ``max |sat*''| = 1.5/δ``.

All functions are vectorised over a leading batch axis: ``x`` of shape ``(..., n)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._typing import Array
from nlobs._validate import as_batch, as_vector, readonly
from nlobs.errors import DimensionError, InvalidArgumentError


__all__ = ["Saturation", "SmoothSaturation"]


def _box(lower: ArrayLike, upper: ArrayLike) -> tuple[Array, Array]:
    lo = np.atleast_1d(np.asarray(lower, dtype=float))
    hi = np.atleast_1d(np.asarray(upper, dtype=float))
    try:
        lo, hi = np.broadcast_arrays(lo, hi)
    except ValueError:
        raise DimensionError(f"lower/upper: shapes {lo.shape} and {hi.shape} do not match") from None
    lo = as_vector("lower", lo)
    hi = as_vector("upper", hi)
    if np.any(lo > hi):
        i = int(np.flatnonzero(lo > hi)[0])
        raise InvalidArgumentError(f"lower/upper: component {i} has lower {float(lo[i])!r} > upper {float(hi[i])!r}")
    return readonly(lo), readonly(hi)


@dataclass(frozen=True, init=False)
class Saturation:
    """Component-wise hard saturation ``sat(z) = min(max(z, lower), upper)`` (Appendix A).

    Parameters
    ----------
    lower, upper : array_like, shape (n,) or scalars
        The box ``Z`` on which ``sat`` is the identity (``lower ≤ upper``).

    Notes
    -----
    ``sat`` is Lipschitz with constant 1 in the Euclidean norm (component-wise
    projection onto a box), which is what turns a local Lipschitz constant of
    ``g`` in ``z`` into the global ``L₁`` of Assumption 2.
    """

    lower: Array
    upper: Array

    def __init__(self, lower: ArrayLike, upper: ArrayLike) -> None:
        lo, hi = _box(lower, upper)
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    @property
    def n(self) -> int:
        """Number of components."""
        return int(self.lower.shape[0])

    def __call__(self, z: ArrayLike) -> Array:
        """``sat(z)`` for ``z`` of shape ``(..., n)``."""
        z_ = as_batch("z", z, self.n)
        return np.clip(z_, self.lower, self.upper)

    def contains(self, z: ArrayLike) -> NDArray[np.bool_]:
        """Whether ``z`` lies in the box (where ``sat`` is the identity), shape ``(...)``."""
        z_ = as_batch("z", z, self.n)
        return np.all((z_ >= self.lower) & (z_ <= self.upper), axis=-1)


@dataclass(frozen=True, init=False)
class SmoothSaturation:
    """Smooth (C²) component-wise saturation ``sat*`` of Appendix A; see the module docstring.

    Parameters
    ----------
    lower, upper : array_like, shape (n,) or scalars
        The box ``X`` on which ``sat*(x) = x``.
    width : array_like, shape (n,) or scalar
        Transition width ``δ > 0`` outside the box; ``sat*`` saturates at
        ``lower − δ/2`` and ``upper + δ/2``.

    Attributes
    ----------
    derivative_bound : float
        ``sup |d sat*/dx| = 1``.
    derivative_lipschitz : ndarray, shape (n,)
        Lipschitz constant of each component's derivative, ``1.5/δ``.
    """

    lower: Array
    upper: Array
    width: Array

    def __init__(self, lower: ArrayLike, upper: ArrayLike, width: ArrayLike) -> None:
        lo, hi = _box(lower, upper)
        w = np.atleast_1d(np.asarray(width, dtype=float))
        try:
            w = np.broadcast_to(w, lo.shape)
        except ValueError:
            raise DimensionError(f"width: shape {w.shape} does not match the box, {lo.shape}") from None
        w = as_vector("width", w)
        if np.any(w <= 0):
            raise InvalidArgumentError(f"width: every transition width must be positive, got {w.tolist()}")
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)
        object.__setattr__(self, "width", readonly(w))

    @property
    def n(self) -> int:
        """Number of components."""
        return int(self.lower.shape[0])

    @property
    def derivative_bound(self) -> float:
        """``sup |d sat*/dx| = 1``."""
        return 1.0

    @property
    def derivative_lipschitz(self) -> Array:
        """Lipschitz constant of ``d sat*/dx`` per component: ``max |sat*''| = 1.5/δ``."""
        return readonly(1.5 / self.width)

    @property
    def limits(self) -> tuple[Array, Array]:
        """The saturation levels ``(lower − δ/2, upper + δ/2)``."""
        return readonly(self.lower - self.width / 2), readonly(self.upper + self.width / 2)

    def _tau(self, x: Array) -> tuple[Array, Array, Array]:
        above = x > self.upper
        below = x < self.lower
        excess = np.where(above, x - self.upper, np.where(below, self.lower - x, 0.0))
        tau = np.minimum(excess / self.width, 1.0)
        sign = np.where(below, -1.0, 1.0)
        return tau, sign, above | below

    def __call__(self, x: ArrayLike) -> Array:
        """``sat*(x)`` for ``x`` of shape ``(..., n)``."""
        x_ = as_batch("x", x, self.n)
        tau, sign, out = self._tau(x_)
        edge = np.where(sign > 0, self.upper, self.lower)
        bent = edge + sign * self.width * (tau - tau**3 + 0.5 * tau**4)
        return np.where(out, bent, x_)

    def derivative(self, x: ArrayLike) -> Array:
        """Diagonal of the Jacobian, ``d sat*ᵢ/dxᵢ = 1 − S(τ)``, shape ``(..., n)``."""
        x_ = as_batch("x", x, self.n)
        tau, _, _ = self._tau(x_)
        return 1.0 - (3.0 * tau**2 - 2.0 * tau**3)

    def second_derivative(self, x: ArrayLike) -> Array:
        """``d² sat*ᵢ/dxᵢ² = ∓6τ(1 − τ)/δ`` (``−`` above the box, ``+`` below), shape ``(..., n)``."""
        x_ = as_batch("x", x, self.n)
        tau, sign, _ = self._tau(x_)
        return -sign * 6.0 * tau * (1.0 - tau) / self.width

    def jacobian(self, x: ArrayLike) -> Array:
        """``∂sat*/∂x`` (diagonal), shape ``(..., n, n)``."""
        d = self.derivative(x)
        return d[..., :, None] * np.eye(self.n)

    def contains(self, x: ArrayLike) -> NDArray[np.bool_]:
        """Whether ``x`` lies in the identity box, shape ``(...)``."""
        x_ = as_batch("x", x, self.n)
        return np.all((x_ >= self.lower) & (x_ <= self.upper), axis=-1)

