r"""Bounds of a Jacobian on a region: the matrix box (or parallelotope) of the differential mean value theorem.

For ``F`` differentiable on a convex region ``Ω`` and ``x, x̂ ∈ Ω``,
``F(x̂) − F(x) = J̄ (x̂ − x)`` with ``J̄ = ∫₀¹ ∂F/∂x(x + s(x̂ − x)) ds``, a mean of Jacobians on the segment, so
``J̄`` lies in the convex hull of the Jacobian's values on ``Ω`` and in any convex set that holds them: the box
``{M : lo ≤ M ≤ hi}`` of their entrywise bounds (Zemouche, Boutayeb & Bara, Systems & Control Letters 57, 2008,
Sec. 3). A condition affine in ``J̄`` (a Lyapunov inequality) then holds for every such ``J̄`` when it holds at
the ``2^k`` vertices of the box, ``k`` the number of entries with ``lo < hi``; the constant entries stay fixed.

The entries of a Jacobian are often combinations of fewer functions than there are varying entries (a mass
balance: ``∂Ẋ/∂X = μ(S) − D`` and ``∂Ṡ/∂X = −μ(S)/Y`` share ``μ(S)``). Then ``∂F/∂x(ξ) = M₀ + Σ_k c_k(ξ) E_k``
for ``r`` fixed matrices ``E_k`` (the principal directions of the sampled Jacobians, found by an SVD), and
``J̄`` lies in the parallelotope ``{M₀ + Σ c_k E_k : c_k ∈ [lo_k, hi_k]}`` of the coefficients' bounds: ``2^r``
vertices instead of ``2^k``, and the correlations between entries kept (a box lets ``μ − D`` be at its top
while ``−μ/Y`` is at its bottom; the parallelotope does not). :func:`jacobian_box` uses it when ``r < k`` and
the parallelotope, its coefficients widened by the margin (or by a half, a quarter of it, or not at all), stays
inside the widened entrywise box: never more conservative than the box.

:func:`jacobian_box` estimates the bounds from the Jacobian at sampled points of the region and of the
input range (every corner of the region when ``n ≤`` :data:`CORNER_LIMIT`, its centre, and seeded uniform
points), each varying entry's extremes then pushed further by a bounded local search (L-BFGS-B) from its best
samples, and its interval enlarged by :data:`MARGIN` of its width on both sides. A sampled bound is an
estimate, not a proof: a design that rests on it says so in its premises.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator, Sequence
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
    """Bounds of a Jacobian on a region: entrywise ``lo ≤ J ≤ hi``, or a parallelotope (module docstring).

    Attributes
    ----------
    lower, upper : ndarray, shape (r, c)
        The entrywise bounds (equal for a constant entry); with a ``basis``, those of the parallelotope.
    samples : int
        How many points they were estimated on.
    offset : ndarray, shape (r, c), optional
        ``M₀`` of the parallelotope ``{M₀ + Σ_k c_k E_k : coef_lower ≤ c ≤ coef_upper}``.
    basis : ndarray, shape (k, r, c), optional
        Its directions ``E_k``; ``None``: the plain box.
    coef_lower, coef_upper : ndarray, shape (k,), optional
        The bounds of the coefficients ``c_k``.
    """

    lower: Array
    upper: Array
    samples: int
    offset: Array | None = None
    basis: Array | None = None
    coef_lower: Array | None = None
    coef_upper: Array | None = None

    @property
    def varying(self) -> tuple[tuple[int, int], ...]:
        """The entries with ``lower < upper``."""
        return tuple((int(i), int(j)) for i, j in zip(*np.nonzero(self.upper > self.lower)))

    @property
    def n_vertices(self) -> int:
        """``2^k``, ``k`` the number of varying entries (of directions, for a parallelotope)."""
        return 2 ** (len(self.varying) if self.basis is None else self.basis.shape[0])

    @property
    def center(self) -> Array:
        """The midpoint matrix."""
        if self.basis is None:
            return (self.lower + self.upper) / 2
        return self.offset + np.tensordot((self.coef_lower + self.coef_upper) / 2, self.basis, axes=1)

    def vertices(self) -> Iterator[Array]:
        """Every vertex (each varying entry, or each coefficient, at its lower or upper bound)."""
        if self.basis is not None:
            for corner in itertools.product((0, 1), repeat=self.basis.shape[0]):
                c = np.where(np.asarray(corner, dtype=bool), self.coef_upper, self.coef_lower)
                yield self.offset + np.tensordot(c, self.basis, axes=1)
            return
        cells = self.varying
        for corner in itertools.product((0, 1), repeat=len(cells)):
            M = self.lower.copy()
            for (i, j), up in zip(cells, corner):
                if up:
                    M[i, j] = self.upper[i, j]
            yield M

    def rows(self, rows: Sequence[int]) -> JacobianBox:
        """The bounds of some rows of the Jacobian (a parallelotope keeps its directions' rows).

        Parameters
        ----------
        rows : sequence of int
            Which rows.
        """
        r = list(rows)
        if self.basis is None:
            return JacobianBox(self.lower[r], self.upper[r], self.samples)
        basis = self.basis[:, r]
        keep = np.any(basis != 0, axis=(1, 2))
        if not keep.any():
            return JacobianBox(self.lower[r], self.upper[r], self.samples)
        return JacobianBox(self.lower[r], self.upper[r], self.samples, self.offset[r], basis[keep],
                           self.coef_lower[keep], self.coef_upper[keep])


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


#: A Jacobian whose sampled values lie within this (relative to their spread) of an affine subspace of fewer
#: dimensions than its varying entries gets the parallelotope of that subspace (module docstring).
RANK_RTOL = 1e-9
#: The convex hull's facets are candidate directions of the parallelotope up to this many dimensions.
HULL_DIMENSIONS = 6
#: The thinnest this many candidate directions are combined into parallelotopes.
CANDIDATES = 24
#: A parallelotope is tried only with at most this many vertices and this many candidate sets of directions.
MAX_VERTICES = 1024
MAX_COMBINATIONS = 20000


def _refine(jac: Callable[[Array, Array], Array], features: Callable[[Array], Array], F: Array, x: Array, u: Array,
            region: Box, u_lower: ArrayLike, u_upper: ArrayLike) -> tuple[Array, Array]:
    """The sampled extremes of each feature of the Jacobian (an entry, or a coefficient of the parallelotope),
    pushed further by a bounded local search (L-BFGS-B) from its best samples; ``F`` holds the features at the
    samples, shape ``(N, K)``."""
    from scipy.optimize import minimize

    n = x.shape[1]
    lo_u = np.asarray(u_lower, dtype=float).reshape(-1)
    hi_u = np.asarray(u_upper, dtype=float).reshape(-1)
    bounds = [*zip(region.lower, region.upper), *zip(lo_u, hi_u)]
    lo, hi = F.min(axis=0), F.max(axis=0)
    for q in range(F.shape[1]):
        for sign, k in ((1.0, int(np.argmin(F[:, q]))), (-1.0, int(np.argmax(F[:, q])))):
            def value(v: Array, q: int = q, sign: float = sign) -> float:
                with np.errstate(all="ignore"):
                    J = np.asarray(jac(v[None, :n], v[None, n:]), dtype=float)
                    f = float(features(J.reshape(1, *J.shape[-2:]))[0, q])
                return sign * f if np.isfinite(f) else np.inf

            start = np.concatenate([x[k], u[k]])
            try:
                res = minimize(value, start, method="L-BFGS-B", bounds=bounds, options={"maxiter": REFINE_ITERATIONS})
            except (ValueError, FloatingPointError):
                continue
            if np.isfinite(res.fun):
                f = sign * float(res.fun)
                lo[q], hi[q] = min(lo[q], f), max(hi[q], f)
    return lo, hi


def _normals(C: Array, entries: Array, lo: Array, hi: Array) -> Array | None:
    """``r`` unit normals ``a_k`` (rows) of the slabs of a parallelotope that holds the points ``C`` (``(N, r)``),
    inside the entries' own box, with the smallest volume ``Π_k width_k / |det A|``; ``None`` when no candidate
    set stays inside that box.

    ``entries`` (``(K, r)``) maps coefficients to the varying entries (``entry = M₀ + entries · c``), and
    ``lo``, ``hi`` are those entries' sampled bounds less ``M₀``. Candidates: the entries' directions and the
    thinnest facet normals of the points' convex hull. A parallelotope inside the box is never more conservative
    than the box; the box alone lets a vertex take physically impossible combinations of entries, a
    parallelotope of equal volume may put one outside every sampled value (both seen on a chemostat)."""
    r = C.shape[1]
    units = entries / np.maximum(np.linalg.norm(entries, axis=1, keepdims=True), 1e-300)
    units = units[np.linalg.norm(entries, axis=1) > 1e-12]
    facets = np.zeros((0, r))
    if 2 <= r <= HULL_DIMENSIONS:
        from scipy.spatial import ConvexHull, QhullError

        try:
            facets = ConvexHull(C, qhull_options="QJ").equations[:, :r]
        except (QhullError, ValueError):
            pass
    if len(facets):  # the thinnest facets, after the entries' own directions
        proj = C @ facets.T
        facets = facets[np.argsort(proj.max(axis=0) - proj.min(axis=0))]
    A = np.concatenate([units, facets])
    A = A[np.sort(np.unique(np.round(np.where(A[:, :1] < 0, -A, A), 9), axis=0, return_index=True)[1])]
    A = A[:max(CANDIDATES, len(units))]
    proj = C @ A.T
    pmin, pmax = proj.min(axis=0), proj.max(axis=0)
    if 2**r > MAX_VERTICES or math.comb(len(A), r) > MAX_COMBINATIONS:
        return None  # too many vertices for the LMIs, or too many candidate sets to try: the box
    tol = 1e-9 * np.maximum(np.abs(lo) + np.abs(hi), 1e-300)
    best, chosen = np.inf, None
    for idx in itertools.combinations(range(len(A)), r):
        S = A[list(idx)]
        det = abs(float(np.linalg.det(S)))
        if det < 1e-9:
            continue
        vol = float(np.prod(pmax[list(idx)] - pmin[list(idx)])) / det
        if vol >= best:
            continue
        T = entries @ np.linalg.inv(S)  # entries as functions of the slab coordinates d = S c
        mid, rad = (pmax[list(idx)] + pmin[list(idx)]) / 2, (pmax[list(idx)] - pmin[list(idx)]) / 2
        centre, spread = T @ mid, np.abs(T) @ rad
        if np.all(centre - spread >= lo - tol) and np.all(centre + spread <= hi + tol):
            best, chosen = vol, S
    return chosen


def _directions(J: Array, varying: Array, lo: Array, hi: Array) -> tuple[Array, Array, Array] | None:
    """``(M₀, E, W)``: the mean of the sampled Jacobians, directions ``E`` (``(r, rows, cols)``) of the affine
    subspace that holds them, when ``r`` is below the number of varying entries, and the map ``W``
    (``(rows·cols, r)``) of an entry matrix to its coefficients, ``c = (M − M₀) W``; else ``None``. The directions
    make the coefficients' box small and keep the parallelotope inside the entries' box ``lo``, ``hi``
    (:func:`_normals`)."""
    N = J.shape[0]
    flat = J.reshape(N, -1)
    mean = flat.mean(axis=0)
    D = flat - mean
    scale = float(np.max(np.abs(D))) if D.size else 0.0
    if scale == 0.0:
        return None
    _, sv, Vt = np.linalg.svd(D / scale, full_matrices=False)
    r = int(np.sum(sv > RANK_RTOL * sv[0] * math.sqrt(N)))
    if r >= int(varying.sum()) or r == 0:
        return None
    V = Vt[:r]
    residual = D - (D @ V.T) @ V  # every sample of every entry within rounding of the subspace, or no parallelotope
    width = D.max(axis=0) - D.min(axis=0)
    if np.any(np.max(np.abs(residual), axis=0) > 1e-8 * np.maximum(width, 1e-300) + 1e-14 * scale):
        return None
    cells = np.flatnonzero(varying.reshape(-1))
    A = _normals(D @ V.T, V[:, cells].T, lo.reshape(-1)[cells] - mean[cells], hi.reshape(-1)[cells] - mean[cells])
    if A is None:
        return None  # coefficients d = A c of the orthonormal ones c = D Vᵀ
    E = np.linalg.solve(A.T, V)  # M = M₀ + c V = M₀ + d A⁻ᵀ V
    E[np.abs(E) < 1e-14 * np.max(np.abs(E))] = 0.0
    return mean.reshape(J.shape[1:]), E.reshape(r, *J.shape[1:]), V.T @ A.T


def jacobian_box(jac: Callable[[Array, Array], Array], region: Box, u_lower: ArrayLike, u_upper: ArrayLike, *,
                 samples: int = 4096, seed: int = 0, margin: float = MARGIN, refine: bool = True,
                 reduce: bool = True) -> JacobianBox:
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
    reduce : bool
        The parallelotope of the sampled Jacobians' affine span when it has fewer dimensions than the varying
        entries (module docstring); ``False``: always the entrywise box.

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
    varying = hi - lo > CONSTANT_RTOL * np.maximum(np.maximum(np.abs(lo), np.abs(hi)), 1e-300)
    if refine:
        cells = np.argwhere(varying)

        def entries(M: Array) -> Array:
            return M[:, cells[:, 0], cells[:, 1]]

        flo, fhi = _refine(jac, entries, entries(J), x, u, region, u_lower, u_upper)
        lo, hi = lo.copy(), hi.copy()
        lo[cells[:, 0], cells[:, 1]] = flo
        hi[cells[:, 0], cells[:, 1]] = fhi
    width = hi - lo
    scale = np.maximum(np.abs(lo), np.abs(hi))
    constant = width <= CONSTANT_RTOL * np.maximum(scale, 1e-300)
    mid = (lo + hi) / 2
    box = JacobianBox(np.where(constant, mid, lo - margin * width), np.where(constant, mid, hi + margin * width),
                      int(x.shape[0]))
    reduced = _directions(J, varying, box.lower, box.upper) if reduce else None
    if reduced is None:
        return box
    # the refined coefficients' parallelotope, widened by the margin or less, inside the widened box; else the box
    tight = _parallelotope(jac, J, x, u, region, u_lower, u_upper, reduced, 0.0, refine)
    slack = 1e-9 * np.maximum(scale, 1e-300)
    for fraction in (1.0, 0.5, 0.25, 0.0):
        shape = _widened(tight, fraction * margin)
        if np.all(shape.lower >= box.lower - slack) and np.all(shape.upper <= box.upper + slack):
            return shape
    return box


def _parallelotope(jac: Callable[[Array, Array], Array], J: Array, x: Array, u: Array, region: Box,
                   u_lower: ArrayLike, u_upper: ArrayLike, reduced: tuple[Array, Array, Array], margin: float,
                   refine: bool) -> JacobianBox:
    """The parallelotope of the coefficients' bounds (sampled, refined, widened by ``margin``) and its entrywise hull."""
    M0, E, W = reduced

    def coefficients(M: Array) -> Array:
        return (M.reshape(M.shape[0], -1) - M0.reshape(-1)) @ W

    C = coefficients(J)
    if refine:
        clo, chi = _refine(jac, coefficients, C, x, u, region, u_lower, u_upper)
    else:
        clo, chi = C.min(axis=0), C.max(axis=0)
    return _widened(JacobianBox(M0, M0, int(x.shape[0]), M0, E, clo, chi), margin)


def _widened(shape: JacobianBox, margin: float) -> JacobianBox:
    """A parallelotope with each coefficient's interval enlarged by ``margin`` of its width, and its entrywise hull."""
    M0, E = shape.offset, shape.basis
    width = shape.coef_upper - shape.coef_lower
    clo, chi = shape.coef_lower - margin * width, shape.coef_upper + margin * width
    mid, rad = (clo + chi) / 2, (chi - clo) / 2
    center = M0 + np.tensordot(mid, E, axes=1)
    spread = np.tensordot(rad, np.abs(E), axes=1)
    const = spread <= CONSTANT_RTOL * np.maximum(np.abs(center), 1e-300)
    lo = np.where(const, center, center - spread)
    hi = np.where(const, center, center + spread)
    return JacobianBox(lo, hi, shape.samples, M0, E, clo, chi)
