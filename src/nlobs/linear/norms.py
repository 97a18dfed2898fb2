"""System norms of ``G(s) = C (sI − A)⁻¹ B + D`` (or ``G(z)`` in discrete time).

* :func:`hinf_norm` — the H∞ norm ``sup_ω σ_max(G(jω))`` computed with the
  quadratically convergent two-step algorithm of Bruinsma & Steinbuch (1990),
  which alternates between imaginary-axis eigenvalues of a Hamiltonian matrix
  and singular-value evaluations (Boyd, Balakrishnan & Kabamba 1989 for the
  Hamiltonian characterisation). Discrete-time systems are mapped to continuous
  time by the norm-preserving bilinear (Cayley) transform ``z = (1 + s)/(1 − s)``.
* :func:`hinf_grid_peak` — the H∞ grid safeguard: the largest ``σ_max(G(jω))`` on a
  log-frequency grid spanning the poles, refined locally (a lower bound of ``‖G‖∞``);
  ``hinf_norm(..., grid=True)`` returns the larger of the two.
* :func:`h2_norm` — the H2 norm from a Gramian (Lyapunov equation).

References
----------
N. A. Bruinsma and M. Steinbuch, "A fast algorithm to compute the H∞-norm of
a transfer function matrix", Systems & Control Letters 14 (1990) 287–293.

S. Boyd, V. Balakrishnan and P. Kabamba, "A bisection method for computing the
H∞ norm of a transfer matrix and related problems", Math. Control Signals
Systems 2 (1989) 207–219.

K. Zhou, J. C. Doyle and K. Glover, *Robust and Optimal Control*, Prentice
Hall 1996, §4.3 (H2 norm via Gramians) and §21 (bilinear transformation).
"""

from __future__ import annotations

import cmath
import math
import os
from typing import Any

import numpy as np
import scipy.linalg
import scipy
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_matrix, as_square, in_range
from nlobs.errors import DimensionError, InvalidArgumentError, NumericalError
from nlobs.systems.linear import takes_system

__all__ = ["h2_norm", "hinf_grid_peak", "hinf_norm"]

_EPS = float(np.finfo(float).eps)


def _check_abcd(
    A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike | None, *, names: str = "ABCD"
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Validate a state-space quadruple; ``D=None`` means a zero feedthrough."""
    nA, nB, nC, nD = names
    A_ = as_square(nA, A)
    n = A_.shape[0]
    B_ = as_matrix(nB, B, (n, None))
    C_ = as_matrix(nC, C, (None, n))
    m, p = B_.shape[1], C_.shape[0]
    D_ = np.zeros((p, m)) if D is None else as_matrix(nD, D, (p, m))
    return A_, B_, C_, D_


def _is_strictly_stable(A: NDArray, discrete: bool) -> bool:
    if A.shape[0] == 0:
        return True
    lam = scipy.linalg.eigvals(A)
    if discrete:
        return bool(np.max(np.abs(lam)) < 1.0)
    return bool(np.max(lam.real) < 0.0)


def _balance(A: NDArray, B: NDArray, C: NDArray, scaling: list[NDArray] | None = None) -> tuple[NDArray, NDArray,
                                                                                                  NDArray]:
    """Diagonal state similarity ``(T⁻¹AT, T⁻¹B, CT)`` balancing ``[A B; C 0]``.

    Osborne/Parlett–Reinsch iteration (as in LAPACK ``xGEBAL`` and SLICOT
    ``TB01ID``) restricted to the state coordinates: for each state ``i`` the
    off-diagonal 1-norm of column ``i`` of ``[A; C]`` and of row ``i`` of
    ``[A B]`` are equalised by a power-of-2 factor, so the transformation is
    exact in floating point and leaves the transfer function unchanged.
    Without it, a system whose entries span many orders of magnitude (e.g. an
    observer ``A − KC`` with ``‖K‖ ~ 1e10``) gives a Hamiltonian pencil whose QZ
    backward error, relative to its largest entries, swamps its small ones: the
    computed spectrum loses its Hamiltonian symmetry and imaginary-axis
    eigenvalues (level crossings) are missed, so ``‖G‖∞`` is under-estimated. ``scaling``, when given,
    receives ``t`` (``T = diag(t)``).
    """
    n = A.shape[0]
    A = A.copy()
    B = B.copy()
    C = C.copy()
    t = np.ones(n)
    if scaling is not None:
        scaling.append(t)
    if n == 0:
        return A, B, C
    radix = 2.0
    for _ in range(200):
        converged = True
        for i in range(n):
            c = float(np.sum(np.abs(A[:, i])) - abs(A[i, i]) + np.sum(np.abs(C[:, i])))
            r = float(np.sum(np.abs(A[i, :])) - abs(A[i, i]) + np.sum(np.abs(B[i, :])))
            if c == 0.0 or r == 0.0 or not (math.isfinite(c) and math.isfinite(r)):
                continue
            # f = power of 2 closest to sqrt(r / c) (balances f·c against r/f)
            f = radix ** round(0.5 * math.log2(r / c))
            if f != 1.0 and c * f + r / f < 0.95 * (c + r):
                converged = False
                t[i] *= f
                A[:, i] *= f
                C[:, i] *= f
                A[i, :] /= f
                B[i, :] /= f
        if converged:
            break
    return A, B, C


def _balance_gebal(A: NDArray, B: NDArray, C: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """The state similarity of :func:`_balance` computed by LAPACK ``xGEBAL`` (no permutation).

    ``xGEBAL`` is applied to the square matrix ``[[A, B, 0], [0, 0, 0], [C, 0, 0]]``: the input
    coordinates have a zero row and the output coordinates a zero column, which ``xGEBAL``
    leaves unscaled, so the scaling ``T = diag(t)`` it finds is a power-of-2 state similarity
    balancing the off-diagonal part of column ``i`` of ``[A; C]`` against row ``i`` of
    ``[A B]`` — the quantities :func:`_balance` equalises, in the 2-norm instead of the 1-norm
    (LAPACK ≥ 3.5) and in compiled code instead of a Python loop. Exact in floating point: the
    transfer function is unchanged.
    """
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    if n == 0 or not (np.all(np.isfinite(A)) and np.all(np.isfinite(B)) and np.all(np.isfinite(C))):
        return _balance(A, B, C)
    S = np.zeros((n + m + p, n + m + p), dtype=np.result_type(A, B, C, float))
    S[:n, :n] = A
    S[:n, n:n + m] = B
    S[n + m:, :n] = C
    t = scipy.linalg.matrix_balance(S, permute=False, separate=True, overwrite_a=True)[1][0]
    t = t[:n]
    return (A / t[:, None]) * t[None, :], B / t[:, None], C * t[None, :]


def _rsf2csf(T: NDArray, Z: NDArray) -> tuple[NDArray, NDArray]:
    """Complex Schur form from a real one (as :func:`scipy.linalg.rsf2csf`).

    The same Givens rotations as SciPy's, with the eigenvalue of each ``2 × 2`` diagonal block
    in closed form instead of a call to ``eigvals`` per block (the dominant cost of
    :func:`scipy.linalg.rsf2csf` for small and medium ``n``).
    """
    N = T.shape[0]
    T = np.array(T, dtype=complex)
    Z = np.array(Z, dtype=complex)
    for m in range(N - 1, 0, -1):
        sub = T[m, m - 1]
        if abs(sub) > _EPS * (abs(T[m - 1, m - 1]) + abs(T[m, m])):
            a, b, d = complex(T[m - 1, m - 1]), complex(T[m - 1, m]), complex(T[m, m])
            c_ = complex(sub)
            h = 0.5 * (a - d)
            mu = h + cmath.sqrt(h * h + b * c_)  # (an eigenvalue of the block) − T[m, m]
            r = math.hypot(abs(mu), abs(c_))
            c, s = mu / r, c_ / r
            G = np.array([[c.conjugate(), s], [-s, c]])
            T[m - 1:m + 1, m - 1:] = G @ T[m - 1:m + 1, m - 1:]
            Gh = G.conj().T
            T[:m + 1, m - 1:m + 1] = T[:m + 1, m - 1:m + 1] @ Gh
            Z[:, m - 1:m + 1] = Z[:, m - 1:m + 1] @ Gh
        T[m, m - 1] = 0.0
    return T, Z


def _sigma_max(A: NDArray, B: NDArray, C: NDArray, D: NDArray, omega: float) -> float:
    """Largest singular value of ``D + C (jω I − A)⁻¹ B`` (``inf`` if singular)."""
    n = A.shape[0]
    if n == 0:
        G = D
    else:
        try:
            X = np.linalg.solve(1j * omega * np.eye(n) - A, B)
        except np.linalg.LinAlgError:
            return math.inf
        G = D + C @ X
    if not np.all(np.isfinite(G)):
        return math.inf
    if G.size == 0:
        return 0.0
    return float(np.linalg.norm(G, 2))


def _pencil_scaling(M: NDArray, k: int) -> tuple[NDArray, NDArray]:
    """Row/column power-of-2 scalings ``l, r`` equilibrating the pencil ``M``.

    Ward's (1981) least-squares balancing, as in LAPACK ``xGGBAL``: minimise
    ``Σ (log₂|M_ij| + ρ_i + c_j)²`` over the nonzero entries, with
    ``ρ_i = −c_i`` for the first ``k`` coordinates (a similarity there, so the
    ``N = diag(I_k, 0)`` part of the pencil is unchanged); ``l = 2^ρ``,
    ``r = 2^c`` rounded to integer exponents (exact in floating point). The
    remaining rows and columns (the ``u``/``v`` constraint blocks, whose
    entries ``γ``, ``B``, ``C`` can differ from ``A`` by many orders of
    magnitude) are scaled freely.
    """
    N = M.shape[0]
    # variable layout: c_0..c_{k-1} (states), then ρ_k..ρ_{N-1}, then c_k..c_{N-1}
    nv = k + 2 * (N - k)
    ii, jj = np.nonzero(M)
    if ii.size == 0:
        return np.ones(N), np.ones(N)
    target = -np.log2(np.abs(M[ii, jj]))
    # Each residual has two ±1 coefficients: one for row i (−c_i on a state, else ρ_i) and one
    # for column j. The minimum-norm least-squares solution is computed through the normal
    # equations GᵀG x = Gᵀ t (range(GᵀG) = range(Gᵀ): the same solution), with GᵀG (nv × nv)
    # assembled in O(nnz) — a dense least-squares solve of G itself costs O(nnz · nv²).
    st_i = ii < k
    ia = np.where(st_i, ii, k + (ii - k))
    sa = np.where(st_i, -1.0, 1.0)
    st_j = jj < k
    ib = np.where(st_j, jj, k + (N - k) + (jj - k))
    sb = np.ones(jj.size)
    GtG = np.zeros((nv, nv))
    np.add.at(GtG, (ia, ia), sa * sa)
    np.add.at(GtG, (ib, ib), sb * sb)
    np.add.at(GtG, (ia, ib), sa * sb)
    np.add.at(GtG, (ib, ia), sa * sb)
    Gt = np.zeros(nv)
    np.add.at(Gt, ia, sa * target)
    np.add.at(Gt, ib, sb * target)
    sol = np.linalg.lstsq(GtG, Gt, rcond=None)[0]
    if not np.all(np.isfinite(sol)):
        return np.ones(N), np.ones(N)
    e = np.round(sol)
    rho = np.concatenate([-e[:k], e[k:N]])
    col = np.concatenate([e[:k], e[N:]])
    return np.ldexp(1.0, rho.astype(int)), np.ldexp(1.0, col.astype(int))


def _crossing_frequencies(A: NDArray, B: NDArray, C: NDArray, D: NDArray, gamma: float) -> NDArray:
    """Frequencies ``ω`` at which ``γ`` is a singular value of ``G(jω)``.

    These are the imaginary generalised eigenvalues ``λ = jω`` of the extended
    Hamiltonian pencil (equivalent to the Hamiltonian matrix ``H(γ)`` of
    Bruinsma & Steinbuch 1990, eq. (3), after eliminating ``u`` and ``v``)::

        ⎡ A    0     B    0  ⎤       ⎡ I 0 0 0 ⎤
        ⎢ 0  −Aᴴ     0  −Cᴴ  ⎥ − λ   ⎢ 0 I 0 0 ⎥
        ⎢ C    0     D  −γI  ⎥       ⎢ 0 0 0 0 ⎥
        ⎣ 0   Bᴴ   −γI   Dᴴ  ⎦       ⎣ 0 0 0 0 ⎦

    (``s x = A x + B u``, ``s q = −Aᴴ q − Cᴴ v``, ``γ v = C x + D u``,
    ``γ u = Bᴴ q + Dᴴ v``). The pencil form avoids inverting
    ``DᴴD − γ²I``, which is ill conditioned when ``γ`` approaches ``σ_max(D)``
    (the peak is then near ``ω = ∞``). Conjugate transposes make it valid for
    the complex systems produced by the rotated bilinear transform.
    """
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    Z = np.zeros
    dt = np.result_type(A, B, C, D, float)
    M = np.block(
        [
            [A, Z((n, n)), B, Z((n, p))],
            [Z((n, n)), -A.conj().T, Z((n, m)), -C.conj().T],
            [C, Z((p, n)), D, -gamma * np.eye(p)],
            [Z((m, n)), B.conj().T, -gamma * np.eye(m), D.conj().T],
        ]
    ).astype(dt)
    # Two-sided diagonal scaling diag(l) M diag(r): same eigenvalues, and with
    # l·r = 1 on the state/costate coordinates N keeps its form.
    lsc, rsc = _pencil_scaling(M, 2 * n)
    M = (lsc[:, None] * M) * rsc[None, :]
    N = np.zeros_like(M)
    N[: 2 * n, : 2 * n] = np.eye(2 * n)
    ab = scipy.linalg.eigvals(M, N, homogeneous_eigvals=True)
    alpha, beta = ab[0], ab[1]
    scale = float(np.linalg.norm(M, 1))
    # Drop infinite eigenvalues (there are m + p of them, QZ returns β ≈ 0).
    finite = np.abs(beta) * 1e14 * max(scale, 1.0) > np.abs(alpha)
    ev = alpha[finite] / beta[finite]
    # Loose test for "on the imaginary axis": a false positive only costs
    # one extra evaluation (the lower bound is always a computed σ_max).
    tol = 1e-8 * np.maximum(np.abs(ev), 1.0) + 1e3 * _EPS * scale
    return np.sort(ev.imag[np.abs(ev.real) <= tol])


def _hinf_continuous_pencil(A: NDArray, B: NDArray, C: NDArray, D: NDArray, rtol: float) -> float:
    """Bruinsma–Steinbuch iteration for a strictly stable continuous system (reference implementation).

    Dense solves per frequency and a QZ of the extended pencil per level; kept as the reference the
    faster :func:`_hinf_continuous` is tested against.
    """
    n = A.shape[0]
    sD = float(np.linalg.norm(D, 2)) if D.size else 0.0
    if n == 0:
        return sD
    # Balance first: every quantity below (poles, σ_max evaluations, the
    # Hamiltonian pencil) is computed from the balanced realisation.
    A, B, C = _balance(A, B, C)
    # --- initial lower bound: ω = 0, ∞ and the frequencies of the poles -----
    lam = scipy.linalg.eigvals(A)
    cand = {0.0}
    for lv in lam:
        cand.update((float(lv.imag), float(abs(lv)), -float(abs(lv))))
    # A few fixed extra frequencies guard against a transfer function that
    # happens to vanish at all pole frequencies (only then matters γ_lb = 0).
    scale = max(float(np.max(np.abs(lam))), 1e-3)
    cand.update(scale * f for f in (0.137, 0.731, 2.19, 7.7, -0.53, -3.1))
    best_w = 0.0
    g_lb = sD
    for w in sorted(cand):
        s = _sigma_max(A, B, C, D, w)
        if s > g_lb:
            g_lb, best_w = s, w
    if g_lb == 0.0:
        return 0.0  # a nonzero rational G cannot vanish at all these points
    if not math.isfinite(g_lb):
        return math.inf
    # --- two-step iteration ---------------------------------------------------
    for _ in range(100):
        gamma = (1.0 + 2.0 * rtol) * g_lb
        w = _crossing_frequencies(A, B, C, D, gamma)
        if w.size == 0:
            break
        mids = 0.5 * (w[:-1] + w[1:]) if w.size > 1 else np.array([w[0]])
        improved = False
        for mw in mids:
            s = _sigma_max(A, B, C, D, float(mw))
            if not math.isfinite(s):
                return math.inf
            if s > g_lb:
                g_lb, best_w, improved = s, float(mw), True
        if not improved:
            break
    # Polish: a local maximisation of σ_max near the peak frequency can only
    # increase the (valid) lower bound.
    return _polish(A, B, C, D, g_lb, best_w)


class _FrequencyResponse:
    """``σ_max(G(jω))`` in ``O(n² m)`` per frequency from one complex Schur form ``A = Z T Zᴴ``.

    ``G(jω) = D + (C Z)(jω I − T)⁻¹(Zᴴ B)``: a triangular solve per frequency, backward stable
    since ``Z`` is unitary (the Hessenberg-once idea of Bruinsma & Steinbuch 1990 and Laub 1981,
    with the triangular Schur factor in place of the Hessenberg one because its eigenvalues, the
    poles, are needed anyway). :meth:`many` solves for a whole set of frequencies at once by a
    back substitution vectorised over the frequencies.
    """

    def __init__(self, A: NDArray, B: NDArray, C: NDArray, D: NDArray) -> None:
        if np.isrealobj(A):  # real Schur + conversion: about half the cost of a complex Schur
            T, Z = _rsf2csf(*scipy.linalg.schur(A, check_finite=False))
        else:
            T, Z = scipy.linalg.schur(A, output="complex")
        self.poles = np.diag(T).copy()
        self._T = T
        self._negT = np.asfortranarray(-T)
        self._negdiag = -self.poles
        self._B = np.asfortranarray(Z.conj().T @ B)
        self._C = C @ Z
        self._D = D
        self._diag = np.diag_indices(A.shape[0])
        self._trtrs = scipy.linalg.lapack.ztrtrs
        self.real = bool(np.isrealobj(A) and np.isrealobj(B) and np.isrealobj(C) and np.isrealobj(D))

    @staticmethod
    def _smax(G: NDArray) -> NDArray:
        if G.shape[-1] == 1 or G.shape[-2] == 1:
            return np.sqrt(np.sum(G.real**2 + G.imag**2, axis=(-2, -1)))
        if G.shape[-1] == 2 or G.shape[-2] == 2:
            # σ_max² = λ_max of the 2 × 2 Gram matrix [[a, b], [b̄, d]] (of the two columns, or
            # rows): (a + d)/2 + √(((a − d)/2)² + |b|²), a sum of nonnegative terms, so σ_max
            # has the relative accuracy of the Gram entries (a few ulps).
            g0, g1 = (G[..., 0], G[..., 1]) if G.shape[-1] == 2 else (G[..., 0, :], G[..., 1, :])
            a = np.sum(g0.real**2 + g0.imag**2, axis=-1)
            d = np.sum(g1.real**2 + g1.imag**2, axis=-1)
            b = np.sum(g0.conj() * g1, axis=-1)
            h = 0.5 * (a - d)
            return np.sqrt(0.5 * (a + d) + np.sqrt(h * h + (b.real**2 + b.imag**2)))
        return np.linalg.svd(G, compute_uv=False)[..., 0]

    def __call__(self, omega: float) -> float:
        M = self._negT  # ztrtrs reads it only: the diagonal is set in place per frequency
        M[self._diag] = self._negdiag + 1j * omega
        X, info = self._trtrs(M, self._B)
        if info != 0:
            return math.inf
        G = self._D + self._C @ X
        if not np.all(np.isfinite(G)):
            return math.inf
        if not G.size:
            return 0.0
        if G.shape == (2, 2):  # the Gram formula of _smax on Python scalars: no array overhead
            g00, g01, g10, g11 = G.ravel().tolist()
            a = g00.real * g00.real + g00.imag * g00.imag + g10.real * g10.real + g10.imag * g10.imag
            d = g01.real * g01.real + g01.imag * g01.imag + g11.real * g11.real + g11.imag * g11.imag
            b = g00.conjugate() * g01 + g10.conjugate() * g11
            h = 0.5 * (a - d)
            return math.sqrt(0.5 * (a + d) + math.sqrt(h * h + (b.real * b.real + b.imag * b.imag)))
        return float(self._smax(G))

    def many(self, omegas: NDArray) -> NDArray:
        """``σ_max(G(jω_k))`` for every ``ω_k`` (``inf`` where ``jω_k`` is a pole)."""
        T, Bt = self._T, self._B
        n, m = Bt.shape
        s = 1j * np.asarray(omegas, dtype=float)
        K = s.size
        X = np.zeros((n, K, m), dtype=complex)
        X2 = X.reshape(n, K * m)  # a view: row i holds x_i for every (frequency, input)
        den = s[None, :, None] - np.diag(T)[:, None, None]
        with np.errstate(all="ignore"):
            X[n - 1] = Bt[n - 1][None, :] / den[n - 1]
            for i in range(n - 2, -1, -1):
                X[i] = (Bt[i][None, :] + (T[i, i + 1:] @ X2[i + 1:]).reshape(K, m)) / den[i]
            G = self._D[None] + np.einsum("pn,nkm->kpm", self._C, X)
            out = self._smax(G) if G.size else np.zeros(K)
        return np.where(np.all(np.isfinite(G), axis=(1, 2)), out, math.inf)


def _hamiltonian_crossings(A: NDArray, B: NDArray, C: NDArray, D: NDArray, gamma: float) -> NDArray | None:
    """Imaginary eigenvalues ``jω`` of the Hamiltonian matrix ``H(γ)`` (eigenvalues only), or ``None``.

    ``H(γ) = diag(A, −Aᴴ) − [[B, 0], [0, −Cᴴ]] K⁻¹ [[C, 0], [0, Bᴴ]]`` with
    ``K = [[D, −γI], [−γI, Dᴴ]]`` is the extended pencil of :func:`_crossing_frequencies` with
    ``u`` and ``v`` eliminated (Bruinsma & Steinbuch 1990, eq. (3); Boyd, Balakrishnan & Kabamba
    1989): a ``2n × 2n`` standard eigenvalue problem instead of a ``(2n + m + p)`` QZ. ``None``
    when ``K`` is ill conditioned (``γ`` close to a singular value of ``D``, the peak near
    ``ω = ∞``): the caller then uses the pencil.
    """
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    dt = np.result_type(A, B, C, D, float)
    K = np.block([[D, -gamma * np.eye(p)], [-gamma * np.eye(m), D.conj().T]]).astype(dt)
    s = np.linalg.svd(K, compute_uv=False)
    if s[-1] <= 1e-3 * s[0]:
        return None
    left = np.zeros((2 * n, m + p), dtype=dt)
    left[:n, :m] = B
    left[n:, m:] = -C.conj().T
    right = np.zeros((p + m, 2 * n), dtype=dt)
    right[:p, :n] = C
    right[p:, n:] = B.conj().T
    H = np.zeros((2 * n, 2 * n), dtype=dt)
    H[:n, :n] = A
    H[n:, n:] = -A.conj().T
    H -= left @ np.linalg.solve(K, right)
    if not np.all(np.isfinite(H)):
        return None
    scale = float(np.linalg.norm(H, 1))
    ev = scipy.linalg.eigvals(H, check_finite=False, overwrite_a=True)
    tol = 1e-8 * np.maximum(np.abs(ev), 1.0) + 1e3 * _EPS * scale
    return np.sort(ev.imag[np.abs(ev.real) <= tol])


def _local_peak(sig: _FrequencyResponse, g: float, w: float, lo: float, hi: float) -> tuple[float, float]:
    """Bounded Brent search of ``σ_max`` on ``[lo, hi] ∋ w``; never returns less than ``(g, w)``."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return g, w
    # The level test that follows certifies the result (no crossing at (1 + 2 rtol) g), so the
    # search only has to land close enough that it usually passes at once: near a peak
    # σ_max loses about κ δω² (relative), so δω = 1e−7 of the bracket (itself narrow around a
    # sharp peak) is ample, and takes a third of the evaluations of a 1e−12 tolerance.
    xatol = max(1e-7 * (hi - lo), 1e-13 * max(abs(lo), abs(hi)), 1e-300)
    try:
        res = scipy.optimize.minimize_scalar(lambda x: -sig(x), bounds=(lo, hi), method="bounded",
                                             options={"xatol": xatol, "maxiter": 200})
    except (ValueError, RuntimeError):  # pragma: no cover - defensive
        return g, w
    val = -float(res.fun)
    if math.isfinite(val) and val > g:
        return val, float(res.x)
    return g, w


def _hinf_continuous(A: NDArray, B: NDArray, C: NDArray, D: NDArray, rtol: float) -> float:
    """Bruinsma–Steinbuch two-step iteration for a strictly stable continuous system.

    The same iteration as :func:`_hinf_continuous_pencil`, with the cost per step cut: one
    complex Schur form of ``A`` makes each ``σ_max(G(jω))`` an ``O(n² m)`` triangular solve,
    each level test is the eigenvalues (no vectors) of the ``2n × 2n`` Hamiltonian matrix (the
    extended pencil only when ``γ`` is close to a singular value of ``D``), and the best
    frequency of every step is polished by a bounded local search between its neighbouring
    crossings before the next level test, so that the test usually confirms the peak at once
    (Boyd & Balakrishnan 1990 for the quadratic convergence of the level iteration).
    """
    n = A.shape[0]
    sD = float(np.linalg.norm(D, 2)) if D.size else 0.0
    if n == 0:
        return sD
    A, B, C = _balance_gebal(A, B, C)
    sig = _FrequencyResponse(A, B, C, D)
    lam = sig.poles
    if not np.max(lam.real) < 0.0:
        return math.inf
    # --- initial lower bound: ω = 0, ∞ and the natural frequencies of the poles -----------
    cand = {0.0}
    for lv in lam:
        cand.update((float(lv.imag), float(abs(lv))))
        if not sig.real:
            cand.add(-float(abs(lv)))
    scale = max(float(np.max(np.abs(lam))), 1e-3)
    cand.update(scale * f for f in (0.137, 0.731, 2.19, 7.7, -0.53, -3.1))
    if sig.real:  # σ_max(G(−jω)) = σ_max(G(jω)) for real data
        cand = {abs(w) for w in cand}
    ws = np.array(sorted(cand))
    vals = sig.many(ws)
    if not np.all(np.isfinite(vals)):
        return math.inf
    g_lb, best_w = sD, math.inf
    i = int(np.argmax(vals))
    if vals[i] > g_lb:
        g_lb, best_w = float(vals[i]), float(ws[i])
        lo = float(ws[i - 1]) if i > 0 else (-float(ws[1]) if sig.real and ws.size > 1 else best_w)
        hi = float(ws[i + 1]) if i + 1 < ws.size else 2.0 * best_w + 1.0
        g_lb, best_w = _local_peak(sig, g_lb, best_w, lo, hi)
    if g_lb == 0.0:
        return 0.0  # a nonzero rational G cannot vanish at all these points
    # --- two-step iteration -----------------------------------------------------------------
    for _ in range(100):
        gamma = (1.0 + 2.0 * rtol) * g_lb
        w = _hamiltonian_crossings(A, B, C, D, gamma)
        if w is None:
            w = _crossing_frequencies(A, B, C, D, gamma)
        if w.size == 0:
            break
        mids = 0.5 * (w[:-1] + w[1:]) if w.size > 1 else np.array([w[0]])
        vals = sig.many(mids)
        if not np.all(np.isfinite(vals)):
            return math.inf
        j = int(np.argmax(vals))
        if vals[j] <= g_lb:
            break
        g_lb, best_w = _local_peak(sig, float(vals[j]), float(mids[j]), float(w[j]), float(w[min(j + 1, w.size - 1)]))
    return g_lb


def _polish(A: NDArray, B: NDArray, C: NDArray, D: NDArray, g: float, w0: float) -> float:
    if w0 == 0.0:
        h = 1e-4
    else:
        h = 1e-4 * abs(w0)
    f = lambda w: -_sigma_max(A, B, C, D, w)  # noqa: E731
    try:
        res = scipy.optimize.minimize_scalar(f, bracket=(w0 - h, w0, w0 + h), tol=1e-12)
    except (ValueError, RuntimeError):
        return g
    val = -float(res.fun)
    return max(g, val) if math.isfinite(val) else g


def _bilinear(A: NDArray, B: NDArray, C: NDArray, D: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Continuous system with ``G_c(s) = G_d(e^{iθ}(1 + s)/(1 − s))``.

    The map sends the imaginary axis onto the unit circle (``ω = ∞`` to the
    point ``−e^{iθ}``), so ``‖G_c‖∞ = ‖G_d‖∞`` exactly and Schur stability of
    ``A`` becomes Hurwitz stability of ``A_c``. ``θ = 0`` (real arithmetic)
    unless an eigenvalue of ``A`` is close to ``−1``; then the point ``−e^{iθ}``
    is rotated away from the spectrum to keep ``I + e^{−iθ} A`` well conditioned.
    """
    n = A.shape[0]
    lam = scipy.linalg.eigvals(A) if n else np.zeros(0)

    def dist(theta: float) -> float:
        return float(np.min(np.abs(lam + np.exp(1j * theta)), initial=np.inf))

    theta = 0.0
    if dist(0.0) < 0.25:
        grid = np.linspace(0.0, 2 * np.pi, 73)[:-1]
        theta = float(max(grid, key=dist))
    if theta != 0.0:
        rot = np.exp(-1j * theta)
        A, C = rot * A, rot * C
    I = np.eye(n)
    M = I + A
    Minv_B = np.linalg.solve(M, B)
    # C (I + A)^{-1} computed as ((I + A)^{-T} C^T)^T
    C_Minv = np.linalg.solve(M.T, C.T).T
    Ac = np.linalg.solve(M, A - I)
    Bc = math.sqrt(2.0) * Minv_B
    Cc = math.sqrt(2.0) * C_Minv
    Dc = D - C @ Minv_B
    return Ac, Bc, Cc, Dc


def _grid_peak(A: NDArray, B: NDArray, C: NDArray, D: NDArray, points: int) -> float:
    """Largest ``σ_max(G(jω))`` at ``ω = 0`` and on a log grid spanning the poles, refined around the maximum."""
    lam = np.abs(np.linalg.eigvals(A))
    lo = max(float(np.min(lam)), 1e-6) * 1e-3
    hi = max(float(np.max(lam)), 1e-6) * 1e3
    ws = np.concatenate([[0.0], np.logspace(np.log10(lo), np.log10(hi), points)])
    vals = np.array([_sigma_max(A, B, C, D, float(w)) for w in ws])
    i = int(np.argmax(vals))
    best = float(vals[i])
    if 0 < i < ws.size - 1:
        a, b = math.log(ws[max(i - 1, 1)]), math.log(ws[i + 1])
        res = scipy.optimize.minimize_scalar(lambda lw: -_sigma_max(A, B, C, D, math.exp(lw)), bounds=(a, b),
                                             method="bounded", options={"xatol": 1e-10})
        best = max(best, -float(res.fun))
    return best


def _grid_peak_discrete(A: NDArray, B: NDArray, C: NDArray, D: NDArray, points: int) -> float:
    """Largest ``σ_max(G(e^{jθ}))`` on a uniform grid of ``θ ∈ [0, π]`` (real systems), refined around the maximum."""
    n = A.shape[0]

    def sig(theta: float) -> float:
        try:
            G = D + C @ np.linalg.solve(np.exp(1j * theta) * np.eye(n) - A, B)
        except np.linalg.LinAlgError:
            return math.inf
        return float(np.linalg.norm(G, 2)) if np.all(np.isfinite(G)) else math.inf

    ts = np.linspace(0.0, math.pi, points)
    vals = np.array([sig(float(t)) for t in ts])
    i = int(np.argmax(vals))
    best = float(vals[i])
    a, b = float(ts[max(i - 1, 0)]), float(ts[min(i + 1, ts.size - 1)])
    res = scipy.optimize.minimize_scalar(lambda t: -sig(t), bounds=(a, b), method="bounded", options={"xatol": 1e-12})
    return max(best, -float(res.fun))


@takes_system(A="A", B="B", C="C", D="D")
def hinf_grid_peak(
    A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike, *, discrete: bool = False, points: int = 600
) -> float:
    r"""The H∞ grid safeguard: ``max σ_max(G(jω))`` over a refined frequency grid, a lower bound of ``‖G‖∞``.

    ``σ_max(G(jω))`` is evaluated at ``ω = 0`` and at ``points`` log-spaced frequencies from
    ``10⁻³ min|λ(A)|`` to ``10³ max|λ(A)|`` (discrete time: ``σ_max(G(e^{jθ}))`` at ``points``
    equally spaced ``θ ∈ [0, π]``); the best grid point is then refined by a bounded scalar
    search between its neighbours.

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices, shapes ``(n, n)``, ``(n, m)``, ``(p, n)``, ``(p, m)``.
    discrete : bool
        Discrete time (the grid is on the unit circle).
    points : int
        Number of grid frequencies (at least 2).

    Returns
    -------
    float
        An attained value ``σ_max(G(jω))``, hence ``≤ ‖G‖∞``; ``math.inf`` when ``A`` is not
        strictly stable; 0 when ``m = 0`` or ``p = 0``.

    Notes
    -----
    Why two routines. :func:`hinf_norm` (Bruinsma–Steinbuch) is the norm: it stops when the
    Hamiltonian pencil has no imaginary eigenvalue above ``(1 + 2 rtol)`` times its lower bound.
    That test relies on QZ finding the imaginary-axis eigenvalues; for observer error dynamics
    ``𝔄 − Kℭ`` with gains ``‖K‖ ~ 10⁷–10¹⁰`` (Grip–Saberi–Johansen, Example 1, pole placement at
    large scales) the unbalanced iteration was measured to miss a crossing and under-estimate the
    peak by 0.1 % (checked in 50-digit arithmetic and with ``control.linfnorm``). The balancing in
    :func:`hinf_norm` now removes that case (the two agree to ``10⁻¹⁵`` there, see
    ``tests/test_linear_norms.py``); the grid stays as an independent check that does not depend
    on eigenvalue locations at all, used where a missed peak would certify a gain that violates
    ``‖H‖∞ < γ`` (:func:`nlobs.synthesis.cascade_gain.place_cascade_gain`). The grid alone is
    not a norm: a narrow resonance between grid points is found only if the refinement lands
    on it.

    Examples
    --------
    A lightly damped mode ``G(s) = 1/(s² + 2ζs + 1)``, ``ζ = 0.1``: the grid peak, refined, reaches the
    resonance peak ``1/(2ζ√(1 − ζ²))`` and agrees with :func:`hinf_norm`:

    >>> import math
    >>> A, B, C, D = [[0, 1], [-1, -0.2]], [[0], [1]], [[1, 0]], [[0]]
    >>> peak = hinf_grid_peak(A, B, C, D)
    >>> round(peak, 6), round(1 / (2 * 0.1 * math.sqrt(1 - 0.1**2)), 6)
    (5.025189, 5.025189)
    >>> peak <= hinf_norm(A, B, C, D) * (1 + 1e-9)
    True
    >>> hinf_grid_peak([[1.0]], [[1.0]], [[1.0]], [[0.0]])  # not stable
    inf
    """
    A_, B_, C_, D_ = _check_abcd(A, B, C, D)
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 2:
        raise InvalidArgumentError(f"points: expected an integer ≥ 2, got {points!r}")
    if B_.shape[1] == 0 or C_.shape[0] == 0:
        return 0.0
    if not _is_strictly_stable(A_, discrete):
        return math.inf
    if A_.shape[0] == 0:
        return float(np.linalg.norm(D_, 2)) if D_.size else 0.0
    if discrete:
        return _grid_peak_discrete(A_, B_, C_, D_, int(points))
    return _grid_peak(A_, B_, C_, D_, int(points))


def _system_or_matrices(A: Any, B: Any, C: Any, D: Any, discrete: bool) -> tuple[Any, Any, Any, Any, bool]:
    """``(A, B, C, D, discrete)`` from four matrices, or from one system in ``A`` (its time base sets ``discrete``)."""
    if B is None and C is None and D is None:
        from nlobs.systems.linear import as_linear_system

        sys = as_linear_system(A, "A")
        return sys.A, sys.B, sys.C, sys.D, sys.is_discrete
    if B is None or C is None:
        raise InvalidArgumentError("give A, B, C (and D), or one system (LinearSystem or python-control) as A")
    return A, B, C, D, discrete


def hinf_norm(
    A: ArrayLike | Any, B: ArrayLike | None = None, C: ArrayLike | None = None, D: ArrayLike | None = None, *,
    discrete: bool = False, rtol: float = 1e-9, grid: bool = False, method: str = "auto",
) -> float:
    r"""H∞ norm of ``G = C (sI − A)⁻¹ B + D`` (``z`` instead of ``s`` when discrete).

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices, shapes ``(n, n)``, ``(n, m)``, ``(p, n)``, ``(p, m)``.
        ``m = 0`` or ``p = 0`` is allowed (the norm is then 0). Or ``A`` alone: a
        :class:`~nlobs.systems.linear.LinearSystem` or a python-control ``StateSpace`` /
        ``TransferFunction`` (its time base then sets ``discrete``).
    discrete : bool
        Discrete time: the supremum is over the unit circle ``z = e^{jθ}``.
    rtol : float
        Relative accuracy of the result, in ``(0, 0.5)``: the iteration stops with
        ``value ≤ ‖G‖∞ < (1 + 2 rtol) value``. Measured with the default ``1e−9``
        against ``control.linfnorm`` (SLICOT ``ab13dd``, tolerance ``1e−13``) on 206
        seeded random stable 30-state systems (``control.rss``/``drss``, shifted Gaussian
        matrices, and ``rss`` realisations scaled by ``diag(10^−k … 10^k)``, k ≤ 8): largest
        relative shortfall ``1.3e−9``, within the ``2 rtol`` bound.
    grid : bool
        Also evaluate the H∞ grid safeguard (:func:`hinf_grid_peak`) and return the larger of
        the two attained values (both are lower bounds of the supremum, so their maximum is
        never further from it than either).
    method : {"auto", "bruinsma-steinbuch", "slycot"}
        ``"bruinsma-steinbuch"``: nlobs's own iteration (below). ``"slycot"``: SLICOT ``AB13DD``
        through slycot (an optional dependency; :class:`~nlobs.errors.InvalidArgumentError` if
        it is not installed), its peak accepted only if nlobs's own evaluation of
        ``σ_max`` at the returned peak frequency reproduces it to ``rtol`` — the value returned
        is that evaluation, an attained ``σ_max`` — and nlobs's iteration used otherwise.
        ``"auto"`` (default): ``"slycot"`` when slycot can be imported and the environment
        variable ``NLOBS_NO_SLYCOT`` is not set, else ``"bruinsma-steinbuch"``.

    Returns
    -------
    float
        ``sup σ_max(G)`` over the stability boundary; ``math.inf`` when ``A`` is
        not strictly stable (``max Re λ < 0``, resp. ``max |λ| < 1``), since the
        H∞ norm is only defined for stable systems.

    Notes
    -----
    Bruinsma & Steinbuch (1990) two-step algorithm. A lower bound ``γ_lb`` is
    initialised from ``σ_max(D)``, ``σ_max(G(0))`` and ``σ_max(G)`` at the
    pole frequencies. Then, repeatedly, the imaginary eigenvalues ``jω_i`` of
    the Hamiltonian ``H((1 + 2 rtol) γ_lb)`` (the frequencies where some singular
    value equals that level) are found, ``σ_max`` is evaluated at the midpoints
    of consecutive ``ω_i`` and ``γ_lb`` is raised to the largest value. When no
    imaginary eigenvalue remains, ``γ_lb ≤ ‖G‖∞ < (1 + 2 rtol) γ_lb``.
    The returned value is always an attained ``σ_max(G(jω))`` (a certified
    lower bound), locally polished around the peak frequency.

    Cost: one complex Schur form ``A = Z T Zᴴ`` makes each ``σ_max(G(jω))`` a triangular solve
    (``O(n²)`` per frequency, as the Hessenberg form in Bruinsma & Steinbuch 1990); each level
    test is the eigenvalues only of the ``2n × 2n`` Hamiltonian matrix (the extended pencil
    below when ``γ`` is close to a singular value of ``D``, where the Hamiltonian needs an
    ill-conditioned inverse); the best frequency of each step is polished by a local search
    before the next test, so that with the quadratic convergence of the level iteration
    (Boyd & Balakrishnan 1990) two or three eigenvalue problems usually suffice.

    Badly scaled realisations (entries spanning many orders of magnitude, e.g.
    observer error dynamics ``A − KC`` with a large gain ``K``) are handled by
    (i) an exact power-of-2 diagonal state similarity balancing ``[A B; C 0]``
    (which does not change ``G``) before anything is computed, and (ii) an
    exact two-sided power-of-2 equilibration of the Hamiltonian pencil (Ward's
    balancing) before each QZ. Without them the QZ backward error can push the
    imaginary eigenvalues off the axis, crossings are missed and the norm is
    under-estimated.

    Discrete systems are first mapped by the bilinear transform
    ``z = (1 + s)/(1 − s)`` — ``A_c = (I + A)⁻¹(A − I)``,
    ``B_c = √2 (I + A)⁻¹ B``, ``C_c = √2 C (I + A)⁻¹``,
    ``D_c = D − C (I + A)⁻¹ B`` — which preserves the H∞ norm exactly.

    Examples
    --------
    ``G(s) = 1/(s² + 2ζs + 1)`` with ``ζ = 0.1`` peaks at ``1/(2ζ√(1 − ζ²))``; ``G(z) = 1/(z − 0.5)``
    peaks at ``z = 1`` with ``1/(1 − 0.5) = 2``; an unstable system has no finite norm:

    >>> import math
    >>> round(hinf_norm([[0, 1], [-1, -0.2]], [[0], [1]], [[1, 0]], [[0]]), 6)
    5.025189
    >>> round(1 / (2 * 0.1 * math.sqrt(1 - 0.1**2)), 6)
    5.025189
    >>> round(hinf_norm([[0.5]], [[1.0]], [[1.0]], [[0.0]], discrete=True), 6)
    2.0
    >>> hinf_norm([[1.0]], [[1.0]], [[1.0]], [[0.0]])
    inf
    """
    A, B, C, D, discrete = _system_or_matrices(A, B, C, D, discrete)
    A_, B_, C_, D_ = _check_abcd(A, B, C, D)
    r = max(in_range("rtol", rtol, 0.0, 0.5, lo_open=True), 10 * _EPS)
    use_slycot = _hinf_method(method)
    if B_.shape[1] == 0 or C_.shape[0] == 0:
        return 0.0
    if (discrete or grid or use_slycot) and not _is_strictly_stable(A_, discrete):
        return math.inf  # (the continuous iteration tests the poles of its own Schur form)
    safeguard = hinf_grid_peak(A_, B_, C_, D_, discrete=discrete) if grid else 0.0
    if use_slycot and A_.shape[0] > 0:
        fast = _hinf_slycot(A_, B_, C_, D_, discrete, r)
        if fast is not None:
            return max(fast, safeguard)
    if discrete:
        if A_.shape[0] == 0:
            return float(np.linalg.norm(D_, 2))
        A_, B_, C_ = _balance(A_, B_, C_)  # conditions I + A in the transform
        A_, B_, C_, D_ = _bilinear(A_, B_, C_, D_)
    try:
        value = float(_hinf_continuous(A_, B_, C_, D_, r))
    except np.linalg.LinAlgError as exc:  # pragma: no cover - defensive
        raise DimensionError(f"hinf_norm: linear algebra failure ({exc})") from None
    return max(value, safeguard)


_HINF_METHODS = ("auto", "bruinsma-steinbuch", "slycot")


def _slycot_module():  # noqa: ANN202 - optional dependency
    try:
        import slycot
    except ImportError:
        return None
    return slycot


def _hinf_method(method: object) -> bool:
    """Validate ``method`` of :func:`hinf_norm`; whether to try the slycot fast path."""
    if method not in _HINF_METHODS:
        raise InvalidArgumentError(f"method: expected one of {', '.join(map(repr, _HINF_METHODS))}, got {method!r}")
    if method == "bruinsma-steinbuch":
        return False
    available = _slycot_module() is not None
    if method == "slycot":
        if not available:
            raise InvalidArgumentError("method='slycot': slycot is not installed")
        return True
    return available and not os.environ.get("NLOBS_NO_SLYCOT")


def _hinf_slycot(A: NDArray, B: NDArray, C: NDArray, D: NDArray, discrete: bool, rtol: float) -> float | None:
    """SLICOT ``AB13DD`` (Bruinsma–Steinbuch with structure-preserving eigensolvers), checked.

    Returns nlobs's own ``σ_max`` at the peak frequency ``AB13DD`` reports, when it reproduces
    ``AB13DD``'s value to ``rtol``; ``None`` (use nlobs's iteration) otherwise or on any error.
    """
    slycot = _slycot_module()
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    # AB13DD's own equilibration was measured to be not enough: on a realisation scaled by
    # diag(10^k), |k| ≤ 6, it under-estimated a discrete norm by 0.3 %. It is given the
    # realisation balanced by nlobs (an exact similarity, G unchanged).
    A, B, C = _balance(A, B, C)
    try:
        gpeak, fpeak = slycot.ab13dd("D" if discrete else "C", "I", "S", "D", n, m, p, A.copy(), np.eye(n),
                                     B.copy(), C.copy(), D.copy(), tol=rtol)
    except Exception:  # noqa: BLE001 - any failure of the optional path falls back
        return None
    g, w = float(gpeak), float(fpeak)  # slycot returns inf for a zero denominator
    if not math.isfinite(g):
        return None
    if not math.isfinite(w):
        value = float(np.linalg.norm(D, 2)) if D.size else 0.0
    else:
        s = np.exp(1j * w) if discrete else 1j * w
        try:
            G = D + C @ np.linalg.solve(s * np.eye(n) - A, B)
        except np.linalg.LinAlgError:
            return None
        value = float(np.linalg.norm(G, 2)) if np.all(np.isfinite(G)) else math.nan
    if not (math.isfinite(value) and abs(value - g) <= rtol * g):
        return None
    return value


def _check_gramian(A: NDArray, R: NDArray, G: NDArray, val: float, discrete: bool) -> None:
    """Raise :class:`NumericalError` unless the Gramian ``G`` solves its Lyapunov equation to working accuracy.

    The residual ``A G + G Aᵀ + R`` (``A G Aᵀ − G + R``) is measured relative to the size of its
    terms; a trace ``val`` that is negative beyond rounding is a wrong Gramian, not a small norm.
    """
    if not (np.all(np.isfinite(G)) and math.isfinite(val)):
        return  # an overflowing Gramian is reported as an infinite norm by the caller
    if discrete:
        res = A @ G @ A.T - G + R
        size = float(np.linalg.norm(A, 2)) ** 2 * float(np.linalg.norm(G, 2)) + float(np.linalg.norm(G, 2))
    else:
        res = A @ G + G @ A.T + R
        size = 2.0 * float(np.linalg.norm(A, 2)) * float(np.linalg.norm(G, 2))
    size += float(np.linalg.norm(R, 2))
    rel = float(np.linalg.norm(res, 2)) / size if size > 0.0 else 0.0
    neg = val < -1e3 * _EPS * abs(float(np.trace(G))) * max(1.0, float(np.linalg.norm(R, 2)))
    if rel > 1e-8 or neg:
        raise NumericalError(
            f"h2_norm: the Gramian cannot be trusted (relative Lyapunov residual {rel:.1e}, "
            f"trace {val:.3e}); the realisation is too badly conditioned for double precision")


def h2_norm(A: ArrayLike | Any, B: ArrayLike | None = None, C: ArrayLike | None = None, D: ArrayLike | None = None,
            *, discrete: bool = False) -> float:
    r"""H2 norm of ``G = C (sI − A)⁻¹ B + D`` (or ``G(z)``).

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices, shapes ``(n, n)``, ``(n, m)``, ``(p, n)``, ``(p, m)``. Or ``A``
        alone: a :class:`~nlobs.systems.linear.LinearSystem` or a python-control system (as
        :func:`hinf_norm`).
    discrete : bool
        Discrete time.

    Returns
    -------
    float
        ``‖G‖₂``; ``math.inf`` when ``A`` is not strictly stable, and in
        continuous time when ``D ≠ 0`` (the impulse response then contains a
        Dirac). ``0`` when ``m = 0`` or ``p = 0``.

    Notes
    -----
    Continuous time: ``‖G‖₂² = trace(C P Cᵀ) = trace(Bᵀ Q B)`` with the Gramians
    ``A P + P Aᵀ + B Bᵀ = 0`` and ``Aᵀ Q + Q A + Cᵀ C = 0``. Discrete time:
    ``‖G‖₂² = trace(C P Cᵀ + D Dᵀ)`` with ``P = A P Aᵀ + B Bᵀ`` (Zhou, Doyle &
    Glover 1996, §4.3). The Gramian of the smaller of ``m`` and ``p`` is used.

    ``A`` is first balanced by an exact power-of-2 diagonal similarity
    (Parlett–Reinsch, :func:`scipy.linalg.matrix_balance`), which leaves ``G``
    unchanged, and the Gramian is accepted only if its Lyapunov residual is
    below ``1e−8`` relative to the equation's terms.

    Raises
    ------
    NumericalError
        The Gramian fails that check (or has a negative trace): the realisation is
        too badly conditioned for the result to be trusted.

    Examples
    --------
    ``G(s) = 1/(s + 1)``: ``‖G‖₂² = ∫₀^∞ e^{−2t} dt = 1/2``; ``G(z) = 1/(z − 0.5)``:
    ``‖G‖₂² = Σ 0.25ᵏ = 4/3``; a direct feed-through makes a continuous-time H2 norm infinite:

    >>> import math
    >>> round(h2_norm([[-1.0]], [[1.0]], [[1.0]], [[0.0]]), 9), round(1 / math.sqrt(2), 9)
    (0.707106781, 0.707106781)
    >>> round(h2_norm([[0.5]], [[1.0]], [[1.0]], [[0.0]], discrete=True), 9), round(math.sqrt(4 / 3), 9)
    (1.154700538, 1.154700538)
    >>> h2_norm([[-1.0]], [[1.0]], [[1.0]], [[1.0]])
    inf
    """
    A, B, C, D, discrete = _system_or_matrices(A, B, C, D, discrete)
    A_, B_, C_, D_ = _check_abcd(A, B, C, D)
    n, m, p = A_.shape[0], B_.shape[1], C_.shape[0]
    if m == 0 or p == 0:
        return 0.0
    if not _is_strictly_stable(A_, discrete):
        return math.inf
    if not discrete and np.any(D_ != 0.0):
        return math.inf
    dd = float(np.sum(D_**2)) if discrete else 0.0
    if n == 0:
        return math.sqrt(dd)
    # Diagonal similarity balancing A (Parlett–Reinsch, LAPACK xGEBAL, exact powers of 2):
    # G is unchanged, and the Lyapunov solver (Bartels–Stewart) then works on a realisation
    # whose entries no longer span many orders of magnitude. Unbalanced, e.g.
    # A = [[0, 1e12], [−1e−12, −1e−6]] gave a Gramian of the wrong sign, clipped to ‖G‖₂ = 0.
    _, (sc, _) = scipy.linalg.matrix_balance(A_, permute=False, separate=True)
    A_ = (A_ / sc[:, None]) * sc[None, :]
    B_ = B_ / sc[:, None]
    C_ = C_ * sc[None, :]
    # B and C each scaled by a power of 2 to a largest entry near 1 (G scales by the product, exactly): a
    # 1e−150-sized system's Gramian would underflow (its norm came out 0), a 1e+150 one overflow
    kb, kc = _pow2(B_), _pow2(C_)
    B_, C_ = np.ldexp(B_, -kb), np.ldexp(C_, -kc)
    if m <= p:
        # observability Gramian: trace(Bᵀ Q B)
        Acheck, R = A_.T, C_.T @ C_
        if discrete:
            Q = scipy.linalg.solve_discrete_lyapunov(Acheck, R)
        else:
            Q = scipy.linalg.solve_continuous_lyapunov(Acheck, -R)
        G, val = Q, float(np.trace(B_.T @ Q @ B_))
    else:
        Acheck, R = A_, B_ @ B_.T
        if discrete:
            P = scipy.linalg.solve_discrete_lyapunov(Acheck, R)
        else:
            P = scipy.linalg.solve_continuous_lyapunov(Acheck, -R)
        G, val = P, float(np.trace(C_ @ P @ C_.T))
    _check_gramian(Acheck, R, G, val, discrete)
    if dd == 0.0:
        out = math.ldexp(math.sqrt(max(val, 0.0)), kb + kc) if math.isfinite(val) else math.inf
        return out if math.isfinite(out) else math.inf
    try:
        total = math.ldexp(val, 2 * (kb + kc)) + dd
    except OverflowError:
        return math.inf
    if not math.isfinite(total):
        return math.inf
    return math.sqrt(total)


def _pow2(M: NDArray) -> int:
    """``k`` with the largest ``|M_ij|`` in ``[0.5, 1)·2^k`` (0 for an empty or zero matrix)."""
    big = float(np.abs(M).max()) if M.size else 0.0
    return math.frexp(big)[1] if big > 0.0 and math.isfinite(big) else 0
