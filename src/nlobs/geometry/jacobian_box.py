r"""Entrywise bounds of a Jacobian on a region: the matrix box of the differential mean value theorem.

For ``F`` differentiable on a convex region ``Ω`` and ``x, x̂ ∈ Ω``, each row of
``F(x̂) − F(x)`` is ``∇F_i(ξ_i)ᵀ (x̂ − x)`` at some ``ξ_i`` of the segment, so ``F(x̂) − F(x) = J̄ (x̂ − x)``
with ``J̄`` in the box ``{M : lo ≤ M ≤ hi}`` of the entrywise bounds of ``∂F/∂x`` on ``Ω`` (Zemouche, Boutayeb
& Bara, Systems & Control Letters 57, 2008, Sec. 3). A condition affine in ``J̄`` (a Lyapunov inequality) then
holds for every such ``J̄`` when it holds at the ``2^k`` vertices of the box, ``k`` the number of entries with
``lo < hi``; the constant entries stay fixed.

:func:`jacobian_box` estimates the bounds from the Jacobian at sampled points of the region and of the
input range (every corner of the region when ``n ≤`` :data:`CORNER_LIMIT`, its centre, and seeded uniform
points), each varying entry's extremes then pushed further by a bounded local search (L-BFGS-B) from its best
samples, and its interval enlarged by :data:`MARGIN` of its width on both sides. A sampled bound is an
estimate, not a proof: a design that rests on it says so in its premises.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs.errors import InvalidArgumentError, NonFiniteError
from nlobs.geometry.region import Box

__all__ = ["CORNER_LIMIT", "JacobianBox", "MARGIN", "jacobian_box", "sample_points"]

#: Iterations of the local search that refines each varying entry's sampled extremes.
REFINE_ITERATIONS = 60
#: Relative enlargement of each varying entry's sampled interval (both sides).
MARGIN = 0.05
#: The corners of the region are sampled when ``n`` is at most this.
CORNER_LIMIT = 10
#: Entries whose sampled range is below this (relative to the entry's size) count as constant.
CONSTANT_RTOL = 1e-9


@dataclass(frozen=True)
class JacobianBox:
    """Entrywise bounds ``lo ≤ J ≤ hi`` of a Jacobian on a region (module docstring).

    Attributes
    ----------
    lower, upper : ndarray, shape (r, c)
        The bounds (equal for a constant entry).
    samples : int
        How many points they were estimated on.
    """

    lower: Array
    upper: Array
    samples: int

    @property
    def varying(self) -> tuple[tuple[int, int], ...]:
        """The entries with ``lower < upper``."""
        return tuple((int(i), int(j)) for i, j in zip(*np.nonzero(self.upper > self.lower)))

    @property
    def n_vertices(self) -> int:
        """``2^k``, ``k`` the number of varying entries."""
        return 2 ** len(self.varying)

    @property
    def center(self) -> Array:
        """The midpoint matrix."""
        return (self.lower + self.upper) / 2

    def vertices(self) -> Iterator[Array]:
        """Every vertex of the box (each varying entry at its lower or upper bound)."""
        cells = self.varying
        for corner in itertools.product((0, 1), repeat=len(cells)):
            M = self.lower.copy()
            for (i, j), up in zip(cells, corner):
                if up:
                    M[i, j] = self.upper[i, j]
            yield M


def sample_points(region: Box, u_lower: ArrayLike, u_upper: ArrayLike, samples: int,
                  seed: int = 0) -> tuple[Array, Array]:
    """Points ``(x, u)`` of region × input range: the corners (``n ≤`` :data:`CORNER_LIMIT`), the centre, uniform ones.

    Parameters
    ----------
    region : Box
        The state region.
    u_lower, u_upper : array_like, shape (m,)
        The input range (equal bounds: a constant input).
    samples : int
        How many uniform points.
    seed : int
        Seed of the uniform points.

    Returns
    -------
    x : ndarray, shape (N, n)
    u : ndarray, shape (N, m)
    """
    lo_u, hi_u = np.asarray(u_lower, dtype=float).reshape(-1), np.asarray(u_upper, dtype=float).reshape(-1)
    rng = np.random.default_rng(seed)
    parts = [region.sample(int(samples), rng), ((region.lower + region.upper) / 2)[None, :]]
    if region.n <= CORNER_LIMIT:
        parts.append(np.array(list(itertools.product(*zip(region.lower, region.upper))), dtype=float))
    x = np.concatenate(parts)
    u = lo_u + (hi_u - lo_u) * rng.random((x.shape[0], lo_u.size))
    if lo_u.size:  # the input's extremes at every corner too
        u[-len(parts[-1]):] = np.where(rng.random((len(parts[-1]), lo_u.size)) < 0.5, lo_u, hi_u)
    return x, u


def _refine(jac: Callable[[Array, Array], Array], J: Array, x: Array, u: Array, region: Box, u_lower: ArrayLike,
            u_upper: ArrayLike, lo: Array, hi: Array) -> tuple[Array, Array]:
    """Each varying entry's extremes pushed further by a bounded local search (L-BFGS-B) from its best samples."""
    from scipy.optimize import minimize

    n = x.shape[1]
    lo_u = np.asarray(u_lower, dtype=float).reshape(-1)
    hi_u = np.asarray(u_upper, dtype=float).reshape(-1)
    bounds = [*zip(region.lower, region.upper), *zip(lo_u, hi_u)]
    lo, hi = lo.copy(), hi.copy()
    varying = np.argwhere(hi - lo > CONSTANT_RTOL * np.maximum(np.maximum(np.abs(lo), np.abs(hi)), 1e-300))
    for i, j in varying:
        for sign, k in ((1.0, int(np.argmin(J[:, i, j]))), (-1.0, int(np.argmax(J[:, i, j])))):
            def entry(v: Array, i: int = int(i), j: int = int(j), sign: float = sign) -> float:
                with np.errstate(all="ignore"):
                    value = float(np.asarray(jac(v[None, :n], v[None, n:]), dtype=float).reshape(-1, *J.shape[1:])
                                  [0, i, j])
                return sign * value if np.isfinite(value) else np.inf

            start = np.concatenate([x[k], u[k]])
            try:
                res = minimize(entry, start, method="L-BFGS-B", bounds=bounds, options={"maxiter": REFINE_ITERATIONS})
            except (ValueError, FloatingPointError):
                continue
            if np.isfinite(res.fun):
                value = sign * float(res.fun)
                lo[i, j], hi[i, j] = min(lo[i, j], value), max(hi[i, j], value)
    return lo, hi


def jacobian_box(jac: Callable[[Array, Array], Array], region: Box, u_lower: ArrayLike, u_upper: ArrayLike, *,
                 samples: int = 4096, seed: int = 0, margin: float = MARGIN, refine: bool = True) -> JacobianBox:
    """Entrywise bounds of ``jac(x, u)`` on region × input range, from sampled points (module docstring).

    Parameters
    ----------
    jac : callable
        ``jac(x, u)`` for batches ``x`` of shape ``(N, n)`` and ``u`` of shape ``(N, m)``, returning ``(N, r, c)``.
    region : Box
        The state region.
    u_lower, u_upper : array_like, shape (m,)
        The input range.
    samples : int
        Number of uniform points.
    seed : int
        Seed of the uniform points.
    margin : float
        Relative enlargement of each varying entry's interval.
    refine : bool
        Push each varying entry's sampled extremes further by a bounded local search from its best sample.

    Returns
    -------
    JacobianBox

    Raises
    ------
    NonFiniteError
        The Jacobian is not finite somewhere on the region (a Lipschitz constant there is infinite).
    """
    if samples < 1:
        raise InvalidArgumentError(f"samples: expected a positive count, got {samples}")
    x, u = sample_points(region, u_lower, u_upper, samples, seed)
    with np.errstate(all="ignore"):
        J = np.asarray(jac(x, u), dtype=float)
    if J.ndim == 2:
        J = np.broadcast_to(J, (x.shape[0], *J.shape))
    bad = ~np.all(np.isfinite(J), axis=(-2, -1))
    if bad.any():
        k = int(np.argmax(bad))
        raise NonFiniteError(f"the Jacobian is not finite at x = {np.round(x[k], 6).tolist()} of the region "
                             f"{region.describe()}: a Lipschitz constant there is infinite; shrink the region (box)")
    lo, hi = J.min(axis=0), J.max(axis=0)
    if refine:
        lo, hi = _refine(jac, J, x, u, region, u_lower, u_upper, lo, hi)
    width = hi - lo
    scale = np.maximum(np.abs(lo), np.abs(hi))
    constant = width <= CONSTANT_RTOL * np.maximum(scale, 1e-300)
    mid = (lo + hi) / 2
    lo = np.where(constant, mid, lo - margin * width)
    hi = np.where(constant, mid, hi + margin * width)
    return JacobianBox(lo, hi, int(x.shape[0]))
