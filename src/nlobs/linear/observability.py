"""Observability and detectability of the pair ``(A, C)``.

Numerically robust tests. The rank of the Kalman matrix
``[C; CA; …; CAⁿ⁻¹]`` is a poor test (its conditioning deteriorates like
``‖A‖ⁿ``), and so is a recursion over the whole state space (errors grow by
about ``‖A‖/σ`` per step along long observability chains). Instead the
Popov–Belevitch–Hautus (PBH) test — ``λ`` is an unobservable mode iff
``rank [λI − A; C] < n`` — is applied *per spectral cluster*: for each group
of numerically coinciding eigenvalues an ordered complex Schur form gives an
orthonormal basis ``X`` of its invariant subspace (``A X = X T``), and the
unobservable subspace of the small pair ``(T, C X)`` is computed by the
recursion ``N₀ = ker(C X)``, ``Nₖ₊₁ = {x ∈ Nₖ : T x ∈ Nₖ}`` with SVD rank
decisions. This yields the unobservable modes with their algebraic
multiplicities (Jordan chains inside the unobservable subspace included),
using unitary transformations only.

References
----------
P. M. Van Dooren, "The generalized eigenstructure problem in linear system
theory", IEEE Trans. Automat. Control 26 (1981) 111–129.

A. Varga, "Numerically stable algorithm for standard controllability form
determination", Electronics Letters 17 (1981) 74–75.

W. M. Wonham, *Linear Multivariable Control: a Geometric Approach*, 3rd ed.,
Springer 1985, §3.2 (unobservable subspace).

M. L. J. Hautus, "Controllability and observability conditions of linear
autonomous systems", Indag. Math. 31 (1969) 443–448.
"""

from __future__ import annotations


import numpy as np
import scipy.linalg
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_matrix, as_square, in_range
from nlobs.linear.norms import _balance
from nlobs.linear.stability import BOUNDARY_TOL, strictly_inside

__all__ = ["observability_matrix", "is_observable", "unobservable_modes", "is_detectable"]

_EPS = float(np.finfo(float).eps)

DEFAULT_RTOL = 1e-10
"""Default relative rank tolerance of the unobservable-subspace recursion (times ``‖[A; C]‖_F`` of the
scaled and balanced realisation, see :func:`unobservable_modes`)."""


def _check_ac(A: ArrayLike, C: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    A_ = as_square("A", A)
    C_ = as_matrix("C", C, (None, A_.shape[0]))
    return A_, C_


def observability_matrix(A: ArrayLike, C: ArrayLike) -> NDArray[np.float64]:
    """Kalman observability matrix ``[C; C A; …; C Aⁿ⁻¹]``, shape ``(n p, n)``.

    Parameters
    ----------
    A : array_like, shape (n, n)
    C : array_like, shape (p, n)

    Returns
    -------
    ndarray, shape (n * p, n)

    Notes
    -----
    Provided for reference and teaching; its rank is a poor numerical test for
    large ``n``. Use :func:`is_observable` for decisions.
    """
    A_, C_ = _check_ac(A, C)
    n = A_.shape[0]
    blocks = []
    blk = C_
    for _ in range(n):
        blocks.append(blk)
        blk = blk @ A_
    if not blocks:
        return np.zeros((0, 0))
    return np.vstack(blocks)


def _unobservable_in_subspace(T: NDArray, Cx: NDArray, tol: float) -> NDArray:
    """Eigenvalues of ``T`` restricted to the unobservable subspace of ``(T, Cx)``.

    Subspace recursion (Wonham 1985, §3.2): ``N₀ = ker Cx``,
    ``Nₖ₊₁ = {x ∈ Nₖ : T x ∈ Nₖ}``; with an orthonormal basis ``Zₖ`` of ``Nₖ``,
    ``Nₖ₊₁`` is spanned by ``Zₖ Y`` where ``Y`` spans the numerical null space
    of ``(I − Zₖ Zₖᴴ) T Zₖ``. Works for complex data.
    """
    k = T.shape[0]
    Z = _null_space(Cx, tol, k)
    for _ in range(k + 1):
        if Z.shape[1] == 0:
            return np.zeros(0, dtype=complex)
        TZ = T @ Z
        Y = _null_space(TZ - Z @ (Z.conj().T @ TZ), tol, Z.shape[1])
        if Y.shape[1] == Z.shape[1]:
            break
        Z, _ = np.linalg.qr(Z @ Y)
    return np.asarray(scipy.linalg.eigvals(Z.conj().T @ T @ Z), dtype=complex)


def _null_space(M: NDArray, tol: float, cols: int) -> NDArray:
    """Orthonormal basis of the numerical null space of ``M`` (``cols`` columns)."""
    if M.shape[0] == 0 or M.size == 0:
        return np.eye(cols, dtype=M.dtype)
    _, s, Vh = scipy.linalg.svd(M, full_matrices=True)
    r = int(np.sum(s > tol))
    return Vh[r:].conj().T.copy()


def _clusters(lam: NDArray, ctol: float) -> list[list[int]]:
    """Single-linkage clusters of eigenvalues closer than ``ctol``."""
    n = lam.size
    parent = list(range(n))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(n):
        for j in range(i + 1, n):
            if abs(lam[i] - lam[j]) <= ctol:
                parent[find(i)] = find(j)
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(find(i), []).append(i)
    return list(groups.values())


def _unobservable_eigs(A: NDArray, C: NDArray, rtol: float) -> NDArray:
    """Unobservable modes with multiplicity, computed cluster by cluster.

    For each cluster of (numerically) coinciding eigenvalues of ``A`` an
    orthonormal basis ``X`` of its invariant subspace is obtained from an
    ordered complex Schur form, ``A X = X T``; the unobservable modes in that
    cluster are those of the small pair ``(T, C X)`` (the unobservable
    subspace is ``A``-invariant, hence the direct sum of its intersections
    with the spectral subspaces). Working per cluster keeps the rank
    decisions local: a recursion over the whole state space accumulates
    errors along long observability chains (≈ ``‖A‖/σ`` per step), while
    the per-mode (PBH-like) test does not.
    """
    n = A.shape[0]
    if n == 0:
        return np.zeros(0, dtype=complex)
    # Scale-aware rank decisions. The unobservable subspace does not change when C is scaled,
    # when A is scaled (the modes scale with it) or under a diagonal state similarity, so
    # (i) A and C are each scaled by a power of 2 to a largest entry in [0.5, 1) and (ii) an
    # exact power-of-2 diagonal similarity balances [A; C] (Parlett–Reinsch). The rank
    # decisions below are relative to ‖[A; C]‖ of that realisation. Without (i) and (ii) an
    # observable chain with couplings 1e−6 … 1e6 (residuals ~1e−6 against ‖A‖ ~ 1e6) was
    # called unobservable in every mode, and so was [[a, a], [−a, a]], C = [1, 0] for a = 1e100.
    kA = _exponent(A)
    A = np.ldexp(A, -kA)
    C = np.ldexp(C, -_exponent(C))
    A, _, C = _balance(A, np.zeros((n, 0)), C)
    scale = float(np.linalg.norm(np.vstack([A, C])))
    tol = max(rtol * scale, n * _EPS * scale)
    if C.shape[0] == 0 or scale == 0.0:
        lam0 = np.asarray(scipy.linalg.eigvals(A), dtype=complex)
        return np.ldexp(lam0.real, kA) + 1j * np.ldexp(lam0.imag, kA)
    T0, _ = scipy.linalg.schur(A, output="complex")
    lam = np.diag(T0).copy()
    ctol = 1e-4 * float(np.linalg.norm(A)) + _EPS * scale
    out: list[NDArray] = []
    for members in _clusters(lam, ctol):
        pts = lam[members]

        def select(x: complex, pts: NDArray = pts) -> bool:
            return bool(np.min(np.abs(pts - x)) <= 0.5 * ctol)

        T, Zs, sdim = scipy.linalg.schur(A, output="complex", sort=select)
        k = int(sdim)
        if k == 0:
            continue
        out.append(_unobservable_in_subspace(T[:k, :k], C @ Zs[:, :k], tol))
    z = np.concatenate(out) if out else np.zeros(0, dtype=complex)
    z = _conjugate_symmetric(z, 1e3 * _EPS * scale)
    return np.ldexp(z.real, kA) + 1j * np.ldexp(z.imag, kA)


def _exponent(M: NDArray) -> int:
    """``k`` with ``max |M_ij| = f · 2^k``, ``f ∈ [0.5, 1)`` (0 for an empty or zero matrix)."""
    big = float(np.max(np.abs(M))) if M.size else 0.0
    return int(np.frexp(big)[1]) if big > 0.0 else 0


def _conjugate_symmetric(z: NDArray, atol: float) -> NDArray:
    """Make modes of real data exactly closed under conjugation.

    Conjugate eigenvalues fall in different clusters and are computed
    separately in complex arithmetic; pair each ``Im > 0`` value with its
    nearest ``Im < 0`` partner and replace both by the exact conjugate pair of
    their mean. Imaginary parts below ``atol`` are set to zero.
    """
    z = np.asarray(z, dtype=complex).copy()
    small = np.abs(z.imag) <= atol
    z[small] = z[small].real
    up = np.flatnonzero(z.imag > 0)
    dn = np.flatnonzero(z.imag < 0)
    if up.size == 0 or up.size != dn.size:
        return z
    cost = np.abs(z[up][:, None] - np.conj(z[dn])[None, :])
    r, c = scipy.optimize.linear_sum_assignment(cost)
    for i, j in zip(up[r], dn[c]):
        mean = 0.5 * (z[i] + np.conj(z[j]))
        z[i], z[j] = mean, np.conj(mean)
    return z


def unobservable_modes(
    A: ArrayLike, C: ArrayLike, *, discrete: bool = False, rtol: float = DEFAULT_RTOL
) -> NDArray[np.complex128]:
    """Unobservable modes of ``(A, C)``: eigenvalues ``λ`` with ``rank [λI − A; C] < n``.

    Parameters
    ----------
    A : array_like, shape (n, n)
    C : array_like, shape (p, n)
        ``p = 0`` is allowed (every mode is then unobservable).
    discrete : bool
        Accepted for uniformity with the other tests; the set of unobservable
        modes does not depend on the time base.
    rtol : float
        Relative rank tolerance (times ``‖[A; C]‖_F``) of the SVD rank
        decisions: a direction is deemed unobservable when its residual is
        below it, i.e. when the pair is within about ``rtol`` (relative) of
        having that mode unobservable. The norm is that of the realisation
        actually tested: ``A`` and ``C`` each scaled by a power of 2 to a
        largest entry in ``[0.5, 1)`` and the states balanced by an exact
        power-of-2 diagonal similarity — none of which changes the
        unobservable subspace — so the verdict does not depend on units (an
        observable chain with couplings ``1e−6 … 1e6`` is observable).

    Returns
    -------
    ndarray of complex
        The unobservable modes with multiplicity, sorted by real then imaginary
        part; empty when the pair is observable.

    Notes
    -----
    Computed as the eigenvalues of ``Zᵀ A Z`` where ``Z`` is an orthonormal
    basis of the unobservable subspace (see the module docstring); this
    evaluates the PBH (Hautus) rank test at every eigenvalue at once, with the
    correct multiplicities, using orthogonal transformations only.
    """
    A_, C_ = _check_ac(A, C)
    r = in_range("rtol", rtol, 0.0, 1.0)
    lam = _unobservable_eigs(A_, C_, r)
    return lam[np.lexsort((lam.imag, lam.real))]


def is_observable(A: ArrayLike, C: ArrayLike, *, rtol: float = DEFAULT_RTOL) -> bool:
    """Whether ``(A, C)`` is observable (no unobservable mode).

    Parameters
    ----------
    A : array_like, shape (n, n)
    C : array_like, shape (p, n)
    rtol : float
        Relative rank tolerance, see :func:`unobservable_modes`.

    Returns
    -------
    bool
        ``True`` iff the unobservable subspace is ``{0}`` (equivalently, the PBH matrix ``[λI − A; C]`` has full column
        rank for every ``λ``; equivalently rank of the Kalman matrix is ``n``).
    """
    A_, C_ = _check_ac(A, C)
    return bool(_unobservable_eigs(A_, C_, in_range("rtol", rtol, 0.0, 1.0)).size == 0)


def is_detectable(
    A: ArrayLike,
    C: ArrayLike,
    *,
    discrete: bool = False,
    rtol: float = DEFAULT_RTOL,
    tol: float = BOUNDARY_TOL,
) -> bool:
    """Whether ``(A, C)`` is detectable: every unobservable mode is strictly stable.

    Parameters
    ----------
    A : array_like, shape (n, n)
    C : array_like, shape (p, n)
    discrete : bool
        Stability means ``|λ| < 1`` (discrete) instead of ``Re λ < 0``.
    rtol : float
        Relative rank tolerance, see :func:`unobservable_modes`.
    tol : float
        Stability margin for the computed modes, see
        :func:`~nlobs.linear.stability.strictly_inside` (a hidden mode on the
        boundary, e.g. an unobserved integrator, makes the pair undetectable).

    Returns
    -------
    bool
        Detectability is necessary and sufficient for the existence of an
        observer gain ``L`` making ``A − L C`` stable.
    """
    lam = unobservable_modes(A, C, discrete=discrete, rtol=rtol)
    return bool(np.all(strictly_inside(lam, discrete=discrete, tol=tol)))
