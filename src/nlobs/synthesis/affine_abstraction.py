r"""Affine abstraction of a nonlinear observation function on a box (Khajenejad & Yong, Prop. 2.18, (3), (5), (6)).

For a function :math:`q: \mathcal B \subset \mathbb R^{n} \to \mathbb R^{p}` on a box
:math:`\mathcal B = [\underline z, \overline z]` this module computes an upper and a lower
affine abstraction

.. math:: \underline A z + \underline e \;\le\; q(z) \;\le\; \overline A z + \overline e
          \qquad \forall z \in \mathcal B \qquad (5)

from the linear program (3) of Khajenejad & Yong, solved with SciPy's HiGHS, one program per
output component :math:`i`:

.. math::

    \min_{\theta, \overline a, \underline a, \overline b, \underline b} \theta \quad
    \text{s.t.}\quad
    \underline a^\top z_s + \underline b + \sigma_i \le q_i(z_s) \le
        \overline a^\top z_s + \overline b - \sigma_i \quad \forall z_s \in \mathcal G, \\
    (\overline a - \underline a)^\top v + \overline b - \underline b \le \theta
        \quad \forall v \in \mathcal V_{\mathcal B},

where :math:`\mathcal G` is a rectangular grid on the box (its corners
:math:`\mathcal V_{\mathcal B}` when ``points_per_axis = 2``, Prop. 2.18 as printed; finer
grids are the mesh of the paper's reference [43]) and :math:`\sigma_i` is the
*correction term* that makes constraints imposed at the grid points hold on the whole box.
The midpoint of the two abstractions gives the form (6),

.. math:: q(z) = C z + e + v^a, \qquad C = \tfrac12(\overline A + \underline A),\;
          e = \tfrac12(\overline e + \underline e),\; |v^a_i| \le \eta_i = \theta_i^\star / 2 .

The correction term (derived here; the paper defers it to [43, Proposition 1])
--------------------------------------------------------------------------------
Every ``z`` in a grid cell with corners :math:`z_j` and widths :math:`h` is the convex
combination :math:`z = \sum_j \lambda_j z_j` with the multilinear weights
:math:`\lambda_j = \prod_k (t_k \text{ or } 1 - t_k)`, :math:`t_k \in [0, 1]`, for which
:math:`\sum_j \lambda_j \|z - z_j\|^2 = \sum_k t_k(1 - t_k) h_k^2 \le \|h\|^2/4 = R^2`
(:math:`R` is the half-diagonal of a cell). Because the abstractions are affine,
:math:`\overline a^\top z + \overline b - q_i(z) = \sum_j \lambda_j(\overline a^\top z_j +
\overline b - q_i(z_j)) + (\sum_j \lambda_j q_i(z_j) - q_i(z)) \ge \sigma_i - |\sum_j
\lambda_j q_i(z_j) - q_i(z)|`, so (5) holds on the box as soon as :math:`\sigma_i` bounds
the interpolation error :math:`|\sum_j \lambda_j q_i(z_j) - q_i(z)|`:

* ``lipschitz`` (:math:`|q_i(z) - q_i(z')| \le L_i \|z - z'\|_2` on the box):
  the error is at most :math:`L_i \sum_j \lambda_j \|z - z_j\| \le L_i R`
  (Jensen), so :math:`\sigma_i = L_i \|h\|_2 / 2`;
* ``gradient_lipschitz`` (:math:`\|\nabla q_i(z) - \nabla q_i(z')\| \le \lambda_i \|z - z'\|`,
  e.g. :math:`\lambda_i \ge \max_{\mathcal B} \|\nabla^2 q_i\|_2`): a Taylor expansion at
  :math:`z` with :math:`\sum_j \lambda_j (z_j - z) = 0` gives at most
  :math:`\tfrac{\lambda_i}{2}\sum_j \lambda_j\|z_j - z\|^2 \le \lambda_i R^2/2`, so
  :math:`\sigma_i = \lambda_i \|h\|_2^2 / 8` (exact for :math:`q = z^2`).

**Guarantee.** If the stated constants are true bounds on the box, then (5) holds at every
point of the box (not only at the grid points), and so does :math:`|q_i(z) - C_i z - e_i|
\le \eta_i`. The solver's answer is not trusted: the slacks at the grid points are
recomputed in NumPy, the offsets are widened by any shortfall, and :math:`\eta` is
recomputed from the box vertices. The stated constants cannot be proved from samples,
but they are *tested*: grid differences that violate them, or a seeded random point where
the residual exceeds :math:`\eta`, raise :class:`~nlobs.errors.AssumptionViolated` with
the evidence.

Two differences with the printed text (see ``docs/affine_abstraction.md``): (3) as printed
subtracts :math:`2\sigma` inside the objective constraint, so that :math:`\eta_{v^a} =
\theta^\star/2` in (6) misses :math:`\sigma` (here :math:`\theta` is the full gap); and
(7) adds the :math:`\infty`-norm bound :math:`\eta_{v^a}` to the 2-norm bound
:math:`\eta_{\hat v}`, while :math:`\|v^a\|_2 \le \|\eta\|_2` is the sound 2-norm bound
(:meth:`AffineAbstraction.noise_bound`).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum

import numpy as np
import scipy
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_finite_array, as_vector, positive
from nlobs.errors import (
    AssumptionViolated,
    DesignInfeasible,
    DimensionError,
    InvalidArgumentError,
    NonFiniteError,
)

__all__ = ["AbstractionBound", "AffineAbstraction", "affine_abstraction"]


_MAX_GRID_POINTS = 200_000
_MAX_DIM = 12


class AbstractionBound(str, Enum):
    """Which regularity constant certifies the correction term ``σ`` (module docstring).

    Examples
    --------
    With both constants given, each component keeps the smaller ``σ_i``: on ``[−1, 1]`` with the
    corners only (``‖h‖₂ = 2``), ``q₁ = z²`` (``L = 2``, ``λ = 2``: ``σ = 2`` or ``1``) takes the
    gradient bound and ``q₂ = sin 3z`` (``L = 3``, ``λ = 9``: ``σ = 3`` or ``4.5``) the Lipschitz one:

    >>> import numpy as np
    >>> q = lambda z: np.stack([z[:, 0] ** 2, np.sin(3.0 * z[:, 0])], axis=-1)
    >>> r = affine_abstraction(q, [-1.0], [1.0], lipschitz=[2.0, 3.0], gradient_lipschitz=[2.0, 9.0])
    >>> [b.value for b in r.bound], r.sigma.tolist()
    (['gradient_lipschitz', 'lipschitz'], [1.0, 3.0])
    >>> AbstractionBound("lipschitz") is AbstractionBound.LIPSCHITZ
    True
    """

    LIPSCHITZ = "lipschitz"
    """``|q_i(z) − q_i(z')| ≤ L_i ‖z − z'‖₂`` on the box; ``σ_i = L_i ‖h‖₂ / 2``."""
    GRADIENT_LIPSCHITZ = "gradient_lipschitz"
    """``‖∇q_i(z) − ∇q_i(z')‖₂ ≤ λ_i ‖z − z'‖₂`` on the box; ``σ_i = λ_i ‖h‖₂² / 8``."""


@dataclass(frozen=True, eq=False)
class AffineAbstraction:
    r"""A certified affine abstraction (5) of ``q`` on a box and its midpoint form (6).

    Attributes
    ----------
    A : ndarray, shape (p, n)
        Midpoint slope ``(A̅ + A̲)/2`` (``C`` of (6), or ``[C, D̃]`` when ``z = (x, u)``).
    e : ndarray, shape (p,)
        Midpoint offset ``(e̅ + e̲)/2``.
    residual_bound : ndarray, shape (p,)
        ``η_i``: ``|q_i(z) − A_i z − e_i| ≤ η_i`` for every ``z`` in the box (certified
        given the constants); equals half the largest gap ``θ_i*`` between the abstractions.
    A_upper, e_upper, A_lower, e_lower : ndarray
        The upper and lower abstractions of (5) after the independent re-check.
    sigma : ndarray, shape (p,)
        Correction term ``σ_i`` (module docstring).
    bound : tuple of AbstractionBound
        Per component, which stated constant certified ``σ_i`` (the one giving the
        smaller ``σ_i`` when both were given).
    constants : ndarray, shape (p,)
        The constants ``L_i`` or ``λ_i`` behind ``σ_i``.
    lower, upper : ndarray, shape (n,)
        The box.
    cell_widths : ndarray, shape (n,)
        Grid spacing ``h``.
    points : ndarray, shape (N, n)
        The grid points where the LP (3) constraints are imposed.
    lp_theta : ndarray, shape (p,)
        The LP optimum per component as the solver returned it (before the re-check).
    shortfall : ndarray, shape (p,)
        How far the solver's abstraction missed its constraints at the grid points
        (recomputed; added to the offsets, so usually ~1e-10 or 0).
    sampled_max_residual : ndarray, shape (p,)
        ``max |q_i(z) − A_i z − e_i|`` over the grid and ``n_check`` seeded random points
        of the box (evidence: never above ``residual_bound``).
    n_check : int
        Number of random points checked.
    seconds : float
        Wall-clock time (LPs and checks).

    Examples
    --------
    ``μ(x, u) = x cos u`` on ``[0, 1] × [−0.5, 0.5]`` (``z = (x, u)`` as in Case 2 of Sec. 3), with
    the gradient-Lipschitz constant ``1.2 ≥ max ‖∇²μ‖₂ ≈ 1.09`` on a 5 × 5 grid: the form (6)
    ``μ = C x + D̃ u + e + v^a`` with ``|v^a| ≤ η``, never exceeded at the sampled points:

    >>> import numpy as np
    >>> mu = lambda z: (z[:, 0] * np.cos(z[:, 1]))[:, None]
    >>> r = affine_abstraction(mu, [0.0, -0.5], [1.0, 0.5], gradient_lipschitz=1.2, points_per_axis=5)
    >>> (r.p, r.n), r.points.shape, r.cell_widths.tolist()
    ((1, 2), (25, 2), [0.25, 0.25])
    >>> round(r.eta_inf, 3), bool(np.all(r.sampled_max_residual <= r.residual_bound))
    (0.08, True)
    >>> C, D = r.split(1)
    >>> C.shape, D.shape, bool(np.allclose(D, 0.0))  # even in u: no u-slope
    ((1, 1), (1, 1), True)
    >>> z = np.array([[0.5, 0.2], [1.0, -0.4]])
    >>> bool(np.all(np.abs(mu(z) - r(z)) <= r.residual_bound))
    True
    >>> r.noise_bound(0.1) == 0.1 + r.eta_2  # (7): η_v̂ + ‖η‖₂
    True
    """

    A: Array
    e: Array
    residual_bound: Array
    A_upper: Array
    e_upper: Array
    A_lower: Array
    e_lower: Array
    sigma: Array
    bound: tuple[AbstractionBound, ...]
    constants: Array
    lower: Array
    upper: Array
    cell_widths: Array
    points: Array
    lp_theta: Array
    shortfall: Array
    sampled_max_residual: Array
    n_check: int
    seconds: float

    @property
    def n(self) -> int:
        """Input dimension."""
        return int(self.A.shape[1])

    @property
    def p(self) -> int:
        """Output dimension."""
        return int(self.A.shape[0])

    @property
    def eta_inf(self) -> float:
        """``max_i η_i``: bound on ``‖v^a‖∞`` (the paper's ``η_{v^a}`` in (6))."""
        return float(np.max(self.residual_bound))

    @property
    def eta_2(self) -> float:
        """``‖η‖₂``: bound on ``‖v^a‖₂``, the norm the noise bounds of (7)–(8) use."""
        return float(np.linalg.norm(self.residual_bound))

    @property
    def eta_as_printed(self) -> Array:
        """``θ*/2`` per component with the objective constraint of (3) as printed (``… − 2σ ≤ θ``).

        Equals ``residual_bound − sigma``: it omits ``σ`` and is **not** a valid bound in
        general (for ``q = z²`` on ``[−1, 1]`` with the corners only it is 0, while the
        residual reaches 1). Reported for comparison with the paper only.
        """
        out = np.maximum(self.residual_bound - self.sigma, 0.0)
        out.setflags(write=False)
        return out

    def noise_bound(self, eta_v: float) -> float:
        """Measurement-noise bound of (7): ``η_v̂ + ‖η‖₂``, since ``‖v̂ + v^a‖₂ ≤ ‖v̂‖₂ + ‖v^a‖₂``.

        Parameters
        ----------
        eta_v : float
            Bound on ``‖v̂_k‖₂``, the measurement noise of (4).
        """
        return positive("eta_v", eta_v, allow_zero=True) + self.eta_2

    def split(self, n_x: int) -> tuple[Array, Array]:
        """``(C, D̃)``: the columns of :attr:`A` acting on ``x`` (the first ``n_x``) and on ``u``.

        For ``z = (x, û)`` as in Case 2 of Sec. 3, (6) reads ``μ(x, û) = C x + D̃ û + e + v^a``.
        """
        if not isinstance(n_x, int | np.integer) or not 0 < int(n_x) <= self.n:
            raise InvalidArgumentError(f"n_x: must be an integer in [1, {self.n}], got {n_x!r}")
        k = int(n_x)
        return self.A[:, :k].copy(), self.A[:, k:].copy()

    def __call__(self, z: ArrayLike) -> Array:
        """The midpoint affine map ``A z + e`` for a batch ``z`` of shape ``(..., n)``."""
        zz = as_finite_array("z", z)
        if zz.ndim == 0 or zz.shape[-1] != self.n:
            raise DimensionError(f"z: expected shape (..., {self.n}), got {zz.shape}")
        return zz @ self.A.T + self.e


def _box(lower: ArrayLike, upper: ArrayLike) -> tuple[Array, Array]:
    lo = as_vector("lower", lower)
    hi = as_vector("upper", upper, lo.shape[0])
    if lo.shape[0] == 0:
        raise DimensionError("lower: the box needs at least one coordinate")
    if lo.shape[0] > _MAX_DIM:
        raise InvalidArgumentError(f"lower: {lo.shape[0]} coordinates; at most {_MAX_DIM} (2^n box vertices)")
    if np.any(hi < lo):
        k = int(np.argmax(hi < lo))
        raise InvalidArgumentError(f"box is empty: upper[{k}] = {hi[k]:g} < lower[{k}] = {lo[k]:g}")
    if np.any(hi == lo):
        k = int(np.argmax(hi == lo))
        raise InvalidArgumentError(
            f"box is degenerate: upper[{k}] = lower[{k}] = {lo[k]:g}; fix that coordinate in q and drop it")
    return lo, hi


def _grid_sizes(points_per_axis: int | Sequence[int], n: int) -> tuple[int, ...]:
    raw = [points_per_axis] * n if isinstance(points_per_axis, int | np.integer) else list(points_per_axis)
    if len(raw) != n:
        raise DimensionError(f"points_per_axis: expected {n} entries, got {len(raw)}")
    sizes: list[int] = []
    for k, m in enumerate(raw):
        if isinstance(m, bool) or not isinstance(m, int | np.integer) or m < 2:
            raise InvalidArgumentError(f"points_per_axis[{k}]: must be an integer ≥ 2 (the box corners), got {m!r}")
        sizes.append(int(m))
    total = int(np.prod(sizes))
    if total > _MAX_GRID_POINTS:
        raise InvalidArgumentError(f"points_per_axis: {total} grid points; at most {_MAX_GRID_POINTS}")
    return tuple(sizes)


def _evaluate(q: Callable[[Array], ArrayLike], z: Array, p: int | None, what: str) -> Array:
    try:
        out = np.asarray(q(z), dtype=float)
    except (TypeError, ValueError) as exc:
        raise DimensionError(f"q: cannot be evaluated on {what} of shape {z.shape} ({exc})") from None
    if out.ndim != 2 or out.shape[0] != z.shape[0] or (p is not None and out.shape[1] != p):
        want = f"({z.shape[0]}, {'p' if p is None else p})"
        raise DimensionError(f"q: on {what} of shape {z.shape} it returned shape {out.shape}; expected {want} "
                             "(a batched callable (..., n) -> (..., p))")
    if not np.all(np.isfinite(out)):
        r, c = (int(i) for i in np.argwhere(~np.isfinite(out))[0])
        raise NonFiniteError(f"q: component {c} is {float(out[r, c])!r} at z = {np.array2string(z[r], precision=6)} "
                             f"({what}); q must be finite on the whole box")
    return out


def _constants(name: str, value: ArrayLike, p: int) -> Array:
    arr = as_finite_array(name, value)
    if arr.ndim == 0:
        arr = np.full(p, float(arr))
    if arr.shape != (p,):
        raise DimensionError(f"{name}: expected a number or shape ({p},), got {arr.shape}")
    if np.any(arr < 0):
        k = int(np.argmax(arr < 0))
        raise InvalidArgumentError(f"{name}[{k}]: must be non-negative, got {arr[k]:g}")
    return arr


def _check_constants(values: Array, sizes: tuple[int, ...], h: Array, bound: AbstractionBound, consts: Array,
                     points: Array) -> None:
    """Grid differences that contradict the stated constants (necessary conditions only)."""
    p = values.shape[1]
    grid = values.reshape(sizes + (p,))
    idx_grid = np.arange(points.shape[0]).reshape(sizes)
    scale = 8.0 * np.finfo(float).eps * max(1.0, float(np.max(np.abs(values))))   # rounding of q's values
    for k in range(len(sizes)):
        if bound is AbstractionBound.LIPSCHITZ:
            diff = np.abs(np.diff(grid, axis=k)) / h[k]              # |Δq| / ‖Δz‖ for neighbours along axis k
            idx = np.take(idx_grid, range(sizes[k] - 1), axis=k)
            what = "|q_i(z + h e_k) − q_i(z)| / h"
            tol = 2.0 * scale / h[k]
        else:
            if sizes[k] < 3:
                continue
            diff = np.abs(np.diff(grid, n=2, axis=k)) / h[k] ** 2   # second difference ≤ λ (mean-value theorem)
            idx = np.take(idx_grid, range(1, sizes[k] - 1), axis=k)
            what = "|q_i(z + h e_k) − 2 q_i(z) + q_i(z − h e_k)| / h²"
            tol = 4.0 * scale / h[k] ** 2
        excess = diff - consts * (1 + 1e-9) - tol
        if np.any(excess > 0):
            flat = excess.reshape(-1, p)
            r, c = np.unravel_index(int(np.argmax(flat)), flat.shape)
            z = points[idx.reshape(-1)[r]]
            value = float(diff.reshape(-1, p)[r, c])
            raise AssumptionViolated(
                f"q component {c} is not {bound.value} with constant {consts[c]:g} on the box: "
                f"{what} = {value:.6g} along axis {k} at z = {np.array2string(z, precision=6)}",
                item=f"{bound.value}_constant",
                evidence=f"component {c}, axis {k}, z = {z.tolist()}, value {value:.6g} > {consts[c]:g}",
            )


def _solve_component(qs: Array, points: Array, vertices: Array,
                     sigma: float) -> tuple[Array, float, Array, float, float]:
    """LP (3) for one component. Variables: ``[a_up (n), b_up, a_lo (n), b_lo, θ]``."""
    N, n = points.shape
    V = vertices.shape[0]
    ones_N = np.ones((N, 1))
    zeros_N = np.zeros((N, n + 1))
    # upper: −(a_up·z + b_up) ≤ −(q + σ);  lower: a_lo·z + b_lo ≤ q − σ
    up = np.hstack([-points, -ones_N, zeros_N, np.zeros((N, 1))])
    lo = np.hstack([zeros_N, points, ones_N, np.zeros((N, 1))])
    gap = np.hstack([vertices, np.ones((V, 1)), -vertices, -np.ones((V, 1)), -np.ones((V, 1))])
    A_ub = scipy.sparse.csr_matrix(np.vstack([up, lo, gap]))
    b_ub = np.concatenate([-(qs + sigma), qs - sigma, np.zeros(V)])
    c = np.zeros(2 * n + 3)
    c[-1] = 1.0
    res = scipy.optimize.linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * (2 * n + 3), method="highs")
    if res.status != 0 or res.x is None:
        raise DesignInfeasible(f"affine abstraction LP (3): HiGHS status {res.status} ({res.message})",
                               constraint="LP (3)")
    x = np.asarray(res.x, dtype=float)
    return x[:n], float(x[n]), x[n + 1:2 * n + 1], float(x[2 * n + 1]), float(x[-1])


def affine_abstraction(
    q: Callable[[Array], ArrayLike],
    lower: ArrayLike,
    upper: ArrayLike,
    *,
    lipschitz: ArrayLike | None = None,
    gradient_lipschitz: ArrayLike | None = None,
    points_per_axis: int | Sequence[int] = 2,
    n_check: int = 10_000,
    seed: int = 0,
) -> AffineAbstraction:
    r"""Affine abstraction of ``q`` on the box ``[lower, upper]`` (Khajenejad & Yong, Prop. 2.18, LP (3), form (6)).

    Parameters
    ----------
    q : callable
        Batched function, ``q(z)`` of shape ``(N, p)`` for ``z`` of shape ``(N, n)`` (e.g. a
        :class:`~nlobs.systems.codegen.BatchedFunction` compiled with ``vector=True``).
    lower, upper : array_like, shape (n,)
        The box; every ``lower[k] < upper[k]``.
    lipschitz : float or array_like of shape (p,), optional
        Lipschitz constants ``L_i`` of each component on the box (2-norm of ``z``).
    gradient_lipschitz : float or array_like of shape (p,), optional
        Lipschitz constants ``λ_i`` of each component's gradient (e.g. bounds on the
        spectral norm of its Hessian) on the box. At least one of the two is required;
        with both, the smaller ``σ_i`` is used.
    points_per_axis : int or sequence of int
        Grid resolution (≥ 2 per axis; 2 = the box corners only, Prop. 2.18 as printed).
        ``σ`` shrinks like ``h`` (Lipschitz) or ``h²`` (gradient-Lipschitz).
    n_check : int
        Number of seeded uniform random points on which the certified bound is tested.
    seed : int
        Seed of those points.

    Returns
    -------
    AffineAbstraction
        ``A``, ``e`` and ``residual_bound`` give (6): ``q(z) = A z + e + v^a`` with
        ``|v^a_i| ≤ η_i`` on the box.

    Raises
    ------
    InvalidArgumentError
        Empty or degenerate box, bad grid, missing or negative constants.
    DimensionError, NonFiniteError
        ``q`` returns the wrong shape, or a NaN/inf on the grid or the check points.
    AssumptionViolated
        The stated constants are contradicted by grid differences of ``q``, or the
        residual at a random check point exceeds the certified bound (evidence attached).
    DesignInfeasible
        HiGHS did not solve the LP (3).

    Examples
    --------
    ``q(z) = z²`` on ``[−1, 1]`` with ``λ = 2`` and a grid of 21 points (``h = 0.1``): the minimax
    line is the constant ``1/2`` (error ``1/2``, equioscillating at ``−1, 0, 1``), and the certified
    bound adds ``σ = λ h² / 8 = 0.0025``:

    >>> import numpy as np
    >>> square = lambda z: z[:, :1] ** 2
    >>> r = affine_abstraction(square, [-1.0], [1.0], gradient_lipschitz=2.0, points_per_axis=21)
    >>> bool(np.allclose(r.A, 0.0)), round(float(r.e[0]), 6), round(float(r.sigma[0]), 6)
    (True, 0.5, 0.0025)
    >>> round(float(r.residual_bound[0]), 6)  # 1/2 + σ
    0.5025
    >>> r.bound, round(float(r.sampled_max_residual[0]), 6)
    ((<AbstractionBound.GRADIENT_LIPSCHITZ: 'gradient_lipschitz'>,), 0.5)

    A constant that the grid contradicts is refused, with the evidence (the second difference of
    ``z²`` is 2):

    >>> try:
    ...     affine_abstraction(square, [-1.0], [1.0], gradient_lipschitz=0.5, points_per_axis=5)
    ... except AssumptionViolated as exc:
    ...     print(type(exc).__name__, exc)
    AssumptionViolated q component 0 is not gradient_lipschitz with constant 0.5 on the box: ... = 2 along axis 0 ...
    """
    t0 = time.perf_counter()
    lo, hi = _box(lower, upper)
    n = lo.shape[0]
    sizes = _grid_sizes(points_per_axis, n)
    if isinstance(n_check, bool) or not isinstance(n_check, int | np.integer) or n_check < 0:
        raise InvalidArgumentError(f"n_check: must be a non-negative integer, got {n_check!r}")
    if lipschitz is None and gradient_lipschitz is None:
        raise InvalidArgumentError(
            "lipschitz / gradient_lipschitz: give at least one constant; without one the LP (3) constraints "
            "hold at the grid points only and nothing is certified on the box")

    axes = [np.linspace(lo[k], hi[k], sizes[k]) for k in range(n)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, n)
    h = (hi - lo) / (np.array(sizes) - 1.0)
    vertices = np.array(list(itertools.product(*[(lo[k], hi[k]) for k in range(n)])), dtype=float)

    values = _evaluate(q, points, None, "the grid")
    p = values.shape[1]
    if p == 0:
        raise DimensionError("q: returns no components (shape (N, 0))")

    # σ per component, from the stated constants (module docstring)
    R = float(np.linalg.norm(h)) / 2.0
    candidates: list[tuple[AbstractionBound, Array, Array]] = []
    if lipschitz is not None:
        L = _constants("lipschitz", lipschitz, p)
        _check_constants(values, sizes, h, AbstractionBound.LIPSCHITZ, L, points)
        candidates.append((AbstractionBound.LIPSCHITZ, L, L * R))
    if gradient_lipschitz is not None:
        lam = _constants("gradient_lipschitz", gradient_lipschitz, p)
        _check_constants(values, sizes, h, AbstractionBound.GRADIENT_LIPSCHITZ, lam, points)
        candidates.append((AbstractionBound.GRADIENT_LIPSCHITZ, lam, lam * R**2 / 2.0))
    if len(candidates) == 2:
        use_lip = candidates[0][2] <= candidates[1][2]
        sigma = np.where(use_lip, candidates[0][2], candidates[1][2])
        consts = np.where(use_lip, candidates[0][1], candidates[1][1])
        kinds = tuple(AbstractionBound.LIPSCHITZ if u else AbstractionBound.GRADIENT_LIPSCHITZ for u in use_lip)
    else:
        kind, consts, sigma = candidates[0]
        kinds = (kind,) * p

    A_up = np.empty((p, n))
    A_lo = np.empty((p, n))
    e_up = np.empty(p)
    e_lo = np.empty(p)
    lp_theta = np.empty(p)
    shortfall = np.empty(p)
    for i in range(p):
        a_u, b_u, a_l, b_l, th = _solve_component(values[:, i], points, vertices, float(sigma[i]))
        # independent re-check of the grid constraints; widen the offsets by any shortfall
        short_u = max(0.0, float(np.max(values[:, i] + sigma[i] - (points @ a_u + b_u))))
        short_l = max(0.0, float(np.max((points @ a_l + b_l) - (values[:, i] - sigma[i]))))
        A_up[i], e_up[i] = a_u, b_u + short_u
        A_lo[i], e_lo[i] = a_l, b_l - short_l
        lp_theta[i] = th
        shortfall[i] = max(short_u, short_l)

    gaps = vertices @ (A_up - A_lo).T + (e_up - e_lo)       # (V, p): the gap is affine, its max is at a vertex
    eta = 0.5 * np.max(gaps, axis=0)
    A_mid = 0.5 * (A_up + A_lo)
    e_mid = 0.5 * (e_up + e_lo)

    # evidence: the certified bound on the grid and on seeded random points of the box
    resid = np.max(np.abs(values - (points @ A_mid.T + e_mid)), axis=0)
    if n_check > 0:
        rng = np.random.default_rng(seed)
        zc = lo + (hi - lo) * rng.random((int(n_check), n))
        vc = _evaluate(q, zc, p, "the random check points")
        rc = np.abs(vc - (zc @ A_mid.T + e_mid))
        resid = np.maximum(resid, np.max(rc, axis=0))
        # rounding allowance: q's values and A z + e evaluated in floating point
        magnitude = 1.0 + float(np.max(np.abs(vc))) + n * float(np.max(np.abs(zc))) * float(np.max(np.abs(A_mid)))
        scale = 8.0 * np.finfo(float).eps * magnitude
        over = rc - eta * (1 + 1e-9) - scale
        if np.any(over > 0):
            r, c = np.unravel_index(int(np.argmax(over)), over.shape)
            raise AssumptionViolated(
                f"affine abstraction: at z = {np.array2string(zc[r], precision=6)} component {c} has residual "
                f"{rc[r, c]:.6g} > certified {eta[c]:.6g}; the stated {kinds[c].value} constant {consts[c]:g} "
                "is too small for q on this box",
                item=f"{kinds[c].value}_constant",
                evidence=f"z = {zc[r].tolist()}, component {c}, residual {rc[r, c]:.6g}, bound {eta[c]:.6g}",
            )

    def ro(a: Array) -> Array:
        a = np.array(a, dtype=float)
        a.setflags(write=False)
        return a

    return AffineAbstraction(
        A=ro(A_mid), e=ro(e_mid), residual_bound=ro(eta),
        A_upper=ro(A_up), e_upper=ro(e_up), A_lower=ro(A_lo), e_lower=ro(e_lo),
        sigma=ro(sigma), bound=kinds, constants=ro(consts), lower=ro(lo), upper=ro(hi),
        cell_widths=ro(h), points=ro(points), lp_theta=ro(lp_theta), shortfall=ro(shortfall),
        sampled_max_residual=ro(resid), n_check=int(n_check), seconds=time.perf_counter() - t0,
    )
