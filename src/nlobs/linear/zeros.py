r"""Invariant zeros, normal rank and related structural tests.

The Rosenbrock system matrix of ``(A, B, C, D)`` is

.. math::  R(s) = \begin{bmatrix} sI - A & -B \\ C & D \end{bmatrix},

an ``(n + p) × (n + m)`` pencil. Its *normal rank* is its rank for almost every
``s``; the finite *invariant zeros* are the ``z ∈ ℂ`` at which
``rank R(z)`` drops below the normal rank. They are computed with the
structure-preserving reduction of Emami-Naeini & Van Dooren (1982): orthogonal
transformations remove the infinite-zero and the left/right null structure
until an equivalent system with a square invertible feed-through ``D_f``
remains, whose zeros are the generalised eigenvalues of
``([[A_f, B_f], [C_f, D_f]], [[I, 0], [0, 0]])``.

References
----------
A. Emami-Naeini and P. Van Dooren, "Computation of zeros of linear
multivariable systems", Automatica 18(4) (1982) 415–430.

H. H. Rosenbrock, *State-space and Multivariable Theory*, Nelson 1970.

M. Khajenejad and S. Z. Yong, "Simultaneous input and state interval
observers for nonlinear systems with bounded-error outputs" (seed paper),
Definition 2.1 and Remark 2.2 (strong detectability).
"""

from __future__ import annotations


from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from nlobs.checks import Check, CheckKind
from nlobs.linear.norms import _balance, _check_abcd
from nlobs.linear.observability import _conjugate_symmetric
from nlobs.linear.stability import BOUNDARY_TOL, strictly_inside
from nlobs.systems.linear import takes_system

__all__ = [
    "InvariantZeros",
    "invariant_zeros",
    "is_left_invertible",
    "is_minimum_phase",
    "is_strongly_detectable",
    "minimum_phase",
]

_EPS = float(np.finfo(float).eps)


@dataclass(frozen=True)
class InvariantZeros:
    """Finite invariant zeros and normal rank of a Rosenbrock system matrix.

    Attributes
    ----------
    zeros : ndarray of complex
        The finite invariant zeros with multiplicity, sorted by real then
        imaginary part (read-only).
    normal_rank : int
        Normal rank of ``R(s) = [[sI − A, −B], [C, D]]``, at most
        ``min(n + p, n + m)``.
    n, m, p : int
        Dimensions of the system.

    Examples
    --------
    ``G(s) = (s + 2)/((s + 1)(s + 3))`` in companion form: one finite zero at ``−2``, normal rank
    ``n + 1 = 3``, and a square ``G`` with full normal rank is invertible from both sides:

    >>> import numpy as np
    >>> iz = invariant_zeros([[0, 1], [-3, -4]], [[0], [1]], [[2, 1]])
    >>> np.round(iz.zeros, 9).tolist(), iz.normal_rank, (iz.n, iz.m, iz.p)
    ([(-2+0j)], 3, (2, 1, 1))
    >>> iz.left_invertible, iz.right_invertible
    (True, True)
    """

    zeros: NDArray[np.complex128]
    normal_rank: int
    n: int = 0
    m: int = 0
    p: int = 0

    @property
    def left_invertible(self) -> bool:
        """Normal rank ``n + m`` (the transfer matrix has a left inverse)."""
        return self.normal_rank == self.n + self.m

    @property
    def right_invertible(self) -> bool:
        """Normal rank ``n + p``."""
        return self.normal_rank == self.n + self.p


def _exponent(M: NDArray) -> int:
    """``k`` with ``max |M_ij| = f · 2^k``, ``f ∈ [0.5, 1)`` (0 for an empty or zero matrix)."""
    big = float(np.max(np.abs(M))) if M.size else 0.0
    return int(np.frexp(big)[1]) if big > 0.0 else 0


def _row_compress(M: NDArray, tol: float) -> tuple[NDArray, int]:
    """Orthogonal ``U`` with ``Uᵀ M = [0; M̃]``, ``M̃`` of full row rank ``r`` (bottom rows)."""
    rows = M.shape[0]
    if M.size == 0:
        return np.eye(rows), 0
    U, s, _ = scipy.linalg.svd(M, full_matrices=True)
    r = int(np.sum(s > tol))
    return U[:, ::-1], r


def _col_compress(M: NDArray, tol: float) -> tuple[NDArray, int]:
    """Orthogonal ``W`` with ``M W = [0, M̃]``, ``M̃`` of full column rank ``r`` (right columns)."""
    cols = M.shape[1]
    if M.size == 0:
        return np.eye(cols), 0
    _, s, Vt = scipy.linalg.svd(M, full_matrices=True)
    r = int(np.sum(s > tol))
    return Vt.T[:, ::-1], r


def _reduce(
    A: NDArray, B: NDArray, C: NDArray, D: NDArray, tol: float
) -> tuple[NDArray, NDArray, NDArray, NDArray, int]:
    """One pass of the Emami-Naeini–Van Dooren reduction.

    Returns an equivalent system (same finite zeros) whose ``D`` has full row
    rank, and the rank ``Σμ`` removed from the pencil (so that the normal
    rank is ``n_r + p_r + Σμ``).

    Each step: row-compress ``D`` (``Uᵀ[C D] = [[C₁, 0], [C₂, D̃]]``),
    drop the identically zero rows of ``C₁`` (left null structure), then
    column-compress the remaining full-row-rank ``C̃₁ W = [0, Ĉ]`` (``Ĉ``
    invertible, ``μ × μ``). The ``μ`` states ``x̄₂`` are then algebraically
    determined by the outputs; eliminating them with the invertible ``Ĉ``
    (a unimodular operation) leaves the system
    ``(A₁₁, B₁, [A₂₁; C₂₁], [B₂; D̃])`` with ``n − μ`` states.
    """
    removed = 0
    while True:
        n, p = A.shape[0], C.shape[0]
        if p == 0:
            return A, B, C, D, removed
        U, rho = _row_compress(D, tol)
        C_ = U.T @ C
        D_ = U.T @ D
        q = p - rho  # rows [C1, ~0]
        if q == 0:
            return A, B, C, D, removed
        C1, C2, Dt = C_[:q], C_[q:], D_[q:]
        if n == 0:
            # rows [C1, 0] are identically zero: drop them
            return A, B, C2, Dt, removed
        U2, mu = _row_compress(C1, tol)
        C1t = (U2.T @ C1)[q - mu :]
        if mu == 0:
            return A, B, C2, Dt, removed
        W, _ = _col_compress(C1t, tol)
        At = W.T @ A @ W
        Bt = W.T @ B
        C2t = C2 @ W
        k = n - mu
        A11, A21 = At[:k, :k], At[k:, :k]
        B1, B2 = Bt[:k], Bt[k:]
        A, B = A11, B1
        C = np.vstack([A21, C2t[:, :k]])
        D = np.vstack([B2, Dt])
        removed += mu


def _normal_rank_tol(A: NDArray, B: NDArray, C: NDArray, D: NDArray) -> tuple[float, float]:
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    M = np.block([[A, B], [C, D]]) if (n + p) and (n + m) else np.zeros((n + p, n + m))
    scale = float(np.linalg.norm(M)) if M.size else 0.0
    tol = max(n + p, n + m, 1) ** 2 * _EPS * scale * 10.0
    return tol, scale


@takes_system(A="A", B="B", C="C", D="D")
def invariant_zeros(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike | None = None) -> InvariantZeros:
    r"""Finite invariant zeros and normal rank of the Rosenbrock system matrix.

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices, shapes ``(n, n)``, ``(n, m)``, ``(p, n)``,
        ``(p, m)``; ``D = None`` means zero. Non-square systems and ``m = 0``
        or ``p = 0`` are allowed.

    Returns
    -------
    InvariantZeros
        ``zeros``: the finite ``z`` with ``rank R(z) < normal rank`` (with
        multiplicity); ``normal_rank``: rank of ``R(s)`` for generic ``s``.

    Notes
    -----
    Emami-Naeini & Van Dooren (1982): the reduction :func:`_reduce` is applied
    to the system and then to its dual ``(Aᵀ, Cᵀ, Bᵀ, Dᵀ)`` (the pencil is
    transposed, which preserves zeros and rank). The result has a square
    invertible ``D_f`` of size ``r``; the ``n_f`` finite zeros are the finite
    generalised eigenvalues of ``([[A_f, B_f], [C_f, D_f]], diag(I, 0))``
    (``rank R(z) = n_f + r`` iff ``z`` is not an eigenvalue of
    ``A_f − B_f D_f⁻¹ C_f``). The normal rank is ``n_f + r`` plus the ranks
    removed by the reduction. For ``m = 0`` the zeros are the unobservable
    modes of ``(A, C)``; for ``p = 0`` the uncontrollable modes of ``(A, B)``.
    Rank decisions use the tolerance ``10 max(n+p, n+m)² ε ‖[[A, B], [C, D]]‖_F``.

    Examples
    --------
    The zeros of ``G(s) = (s + 2)/(s² + 4s + 3)`` and ``(s − 2)/(s² + 4s + 3)`` are the roots of
    their numerators; ``s/(s + 1)`` (``D = 1``) has its zero at the origin:

    >>> import numpy as np
    >>> A, B = [[0, 1], [-3, -4]], [[0], [1]]
    >>> np.round(invariant_zeros(A, B, [[2, 1]]).zeros, 9).tolist()
    [(-2+0j)]
    >>> np.round(invariant_zeros(A, B, [[-2, 1]]).zeros, 9).tolist()
    [(2+0j)]
    >>> np.abs(invariant_zeros([[-1]], [[1]], [[-1]], [[1]]).zeros).round(9).tolist()
    [0.0]
    """
    A_, B_, C_, D_ = _check_abcd(A, B, C, D)
    n, m, p = A_.shape[0], B_.shape[1], C_.shape[0]
    z, normal_rank = _zeros(A_, B_, C_, D_)
    z.setflags(write=False)
    return InvariantZeros(zeros=z, normal_rank=normal_rank, n=n, m=m, p=p)


def _zeros(A_: NDArray, B_: NDArray, C_: NDArray, D_: NDArray) -> tuple[NDArray, int]:
    """The finite zeros (sorted) and the normal rank of one realisation (:func:`invariant_zeros`'s algorithm)."""
    # Exact power-of-2 equivalence diag(α I, β) R(z) diag(I, γ) and a diagonal state
    # similarity (Parlett–Reinsch balancing of [A B; C 0]) before any rank decision: the zeros
    # become α z and the normal rank is unchanged, while the tolerance below, relative to
    # ‖R‖, no longer lets one block's scale swamp another's. Unscaled, [[a, a], [−a, a]],
    # B = [0; 1], C = [1, 0] (no finite zero, normal rank 3) was given normal rank 2 and the
    # zeros a (1 ± j) for a ≥ 1e20.
    kA, kB, kC = _exponent(A_), _exponent(B_), _exponent(C_)
    A_, B_, C_ = np.ldexp(A_, -kA), np.ldexp(B_, -kB), np.ldexp(C_, -kC)
    D_ = np.ldexp(D_, kA - kB - kC)
    A_, B_, C_ = _balance(A_, B_, C_)
    tol, _ = _normal_rank_tol(A_, B_, C_, D_)
    A1, B1, C1, D1, r1 = _reduce(A_, B_, C_, D_, tol)
    A2, B2, C2, D2, r2 = _reduce(A1.T, C1.T, B1.T, D1.T, tol)
    Af, Bf, Cf, Df = A2.T, C2.T, B2.T, D2.T
    nf, q = Af.shape[0], Df.shape[0]
    normal_rank = int(nf + q + r1 + r2)
    if nf == 0:
        z = np.zeros(0, dtype=complex)
    elif q == 0:
        z = np.asarray(scipy.linalg.eigvals(Af), dtype=complex)
    else:
        M = np.block([[Af, Bf], [Cf, Df]])
        N = np.zeros_like(M)
        N[:nf, :nf] = np.eye(nf)
        ab = scipy.linalg.eigvals(M, N, homogeneous_eigvals=True)
        alpha, beta = ab[0], ab[1]
        # exactly q eigenvalues are infinite (D_f is invertible): keep the
        # n_f "most finite" ones.
        h = np.abs(beta) / np.maximum(np.hypot(np.abs(alpha), np.abs(beta)), np.finfo(float).tiny)
        keep = np.argsort(-h)[:nf]
        keep = keep[np.abs(beta[keep]) > 0]
        z = alpha[keep] / beta[keep]
    z = np.asarray(z, dtype=complex)
    z = np.ldexp(z.real, kA) + 1j * np.ldexp(z.imag, kA)
    # exact conjugate symmetry for real data: snap tiny imaginary parts
    small = np.abs(z.imag) <= 1e3 * _EPS * np.maximum(np.abs(z), 1.0)
    z = np.where(small, z.real + 0j, z)
    z = _conjugate_symmetric(z, 0.0)  # exact pairs: their order no longer flips with the last bit of the real parts
    z = z[np.lexsort((z.imag, z.real))] if z.size else z
    return z, normal_rank


@takes_system(A="A", B="B", C="C", D="D")
def is_left_invertible(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike | None = None) -> bool:
    """Whether the system is left invertible: normal rank of ``R(s)`` equals ``n + m``.

    Equivalently, the transfer matrix ``G(s)`` has full column rank ``m`` (the
    input can be reconstructed from the output, given the initial state).

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices, shapes ``(n, n)``, ``(n, m)``, ``(p, n)``,
        ``(p, m)``; ``D = None`` means zero.

    Returns
    -------
    bool

    Examples
    --------
    Two inputs seen through one output cannot both be recovered (``y = x₁ + x₂`` mixes them); one
    input seen through one output with a nonzero transfer function can:

    >>> is_left_invertible([[-1, 0], [0, -2]], [[1, 0], [0, 1]], [[1, 1]])
    False
    >>> is_left_invertible([[0, 1], [-3, -4]], [[0], [1]], [[2, 1]])
    True
    """
    return invariant_zeros(A, B, C, D).left_invertible


@takes_system(A="A", B="B", C="C", D="D")
def minimum_phase(
    A: ArrayLike,
    B: ArrayLike,
    C: ArrayLike,
    D: ArrayLike | None = None,
    *,
    discrete: bool = False,
    tol: float = BOUNDARY_TOL,
) -> Check:
    """Minimum-phase test with the reason of a negative answer.

    See :func:`is_minimum_phase`.

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices (``D = None`` means zero).
    discrete : bool
        Stable region ``|z| < 1`` instead of ``Re z < 0``.
    tol : float, default 1e-9
        Margin from the stability boundary for the computed zeros, see
        :func:`~nlobs.linear.stability.strictly_inside`.

    Returns
    -------
    Check
        ``passed`` is the verdict; ``evidence`` the reason (the rank deficiency, or the offending
        zeros); ``values["unstable_zeros"]`` the finite invariant zeros outside the open stability
        region, as a tuple of complex (empty when minimum phase or not left invertible).

    Examples
    --------
    ``(s − 2)/(s² + 4s + 3)`` fails with its zero at ``s = 2`` named; two inputs through one output
    fail for lack of left invertibility:

    >>> chk = minimum_phase([[0, 1], [-3, -4]], [[0], [1]], [[-2, 1]])
    >>> chk.passed, chk.evidence
    (False, 'invariant zero(s) with Re z >= 0: 2+0j')
    >>> [round(z.real, 9) for z in chk.values["unstable_zeros"]]
    [2.0]
    >>> minimum_phase([[-1, 0], [0, -2]], [[1, 0], [0, 1]], [[1, 1]]).evidence
    'not left invertible: normal rank 3 < n + m = 4'
    """
    iz = invariant_zeros(A, B, C, D)

    def verdict(ok: bool, why: str, bad: tuple[complex, ...] = ()) -> Check:
        return Check.verdict("minimum phase", ok, why, kind=CheckKind.STRUCTURAL, method="numeric",
                             values={"unstable_zeros": bad})

    if not iz.left_invertible:
        return verdict(False, f"not left invertible: normal rank {iz.normal_rank} < n + m = {iz.n + iz.m}")
    bad = iz.zeros[~strictly_inside(iz.zeros, discrete=discrete, tol=tol)]
    if bad.size:
        where = "|z| >= 1" if discrete else "Re z >= 0"
        shown = ", ".join(f"{complex(v):.6g}" for v in bad)
        return verdict(False, f"invariant zero(s) with {where}: {shown}", tuple(complex(v) for v in bad))
    return verdict(True, "left invertible, all finite invariant zeros strictly stable")


@takes_system(A="A", B="B", C="C", D="D")
def is_minimum_phase(
    A: ArrayLike,
    B: ArrayLike,
    C: ArrayLike,
    D: ArrayLike | None = None,
    *,
    discrete: bool = False,
    tol: float = BOUNDARY_TOL,
) -> bool:
    """Whether the system is minimum phase.

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices (``D = None`` means zero).
    discrete : bool
        Stable region ``|z| < 1`` instead of ``Re z < 0``.
    tol : float
        Margin from the stability boundary for the computed zeros, see
        :func:`~nlobs.linear.stability.strictly_inside`.

    Returns
    -------
    bool
        ``True`` iff the system is left invertible (normal rank ``n + m``;
        otherwise ``R(z)`` is rank deficient *everywhere* and the notion of
        stable zero dynamics is void, so the answer is ``False``) and every
        finite invariant zero lies strictly inside the stability region.
        Zeros on the boundary (e.g. ``s = 0`` for ``s/(s + 1)``) fail the test.
        :func:`minimum_phase` returns the reason as well.

    Examples
    --------
    ``(s + 2)/(s² + 4s + 3)`` is minimum phase, ``(s − 2)/(s² + 4s + 3)`` and ``s/(s + 1)`` are not:

    >>> A, B = [[0, 1], [-3, -4]], [[0], [1]]
    >>> is_minimum_phase(A, B, [[2, 1]]), is_minimum_phase(A, B, [[-2, 1]])
    (True, False)
    >>> is_minimum_phase([[-1]], [[1]], [[-1]], [[1]])
    False
    """
    return minimum_phase(A, B, C, D, discrete=discrete, tol=tol).passed


@takes_system(A="A", G="B", C="C", H="D")
def is_strongly_detectable(
    A: ArrayLike,
    G: ArrayLike,
    C: ArrayLike,
    H: ArrayLike | None = None,
    *,
    discrete: bool = False,
    tol: float = BOUNDARY_TOL,
) -> bool:
    r"""Strong detectability of ``x⁺ = A x + G d``, ``y = C x + H d`` with unknown input ``d``.

    Parameters
    ----------
    A : array_like, shape (n, n)
    G : array_like, shape (n, p_d)
        Unknown-input matrix.
    C : array_like, shape (l, n)
    H : array_like, shape (l, p_d), optional
        Unknown-input feed-through (zero when omitted).
    discrete : bool
        Region ``|z| ≥ 1`` (discrete) or ``Re z ≥ 0`` (continuous).
    tol : float
        Margin from the stability boundary for the computed zeros, see
        :func:`~nlobs.linear.stability.strictly_inside`.

    Returns
    -------
    bool
        ``True`` iff ``rank [[zI − A, −G], [C, H]] = n + p_d`` for every ``z``
        in the closed unstable region (seed paper, Khajenejad & Yong,
        Definition 2.1 / Remark 2.2; Hautus 1983). Equivalently: the system is
        left invertible (normal rank ``n + p_d``) and it has no invariant zero
        with ``|z| ≥ 1`` (resp. ``Re z ≥ 0``); i.e. it is minimum phase.
        Strong detectability is the condition under which the state (and the
        unknown input) can be estimated without knowledge of ``d``.

    Examples
    --------
    ``x⁺ = A x + G d`` with ``A = [[0.5, 1], [0, 0.3]]``, ``G = [0; 1]``: measuring ``y = x₁`` gives no
    invariant zero, measuring ``y = −2.5 x₁ + x₂`` gives ``(z − 3)/((z − 0.5)(z − 0.3))``, whose zero
    ``z = 3`` lies outside the unit circle:

    >>> A, G = [[0.5, 1], [0, 0.3]], [[0], [1]]
    >>> is_strongly_detectable(A, G, [[1, 0]], discrete=True)
    True
    >>> is_strongly_detectable(A, G, [[-2.5, 1]], discrete=True)
    False
    """
    return minimum_phase(A, G, C, H, discrete=discrete, tol=tol).passed
