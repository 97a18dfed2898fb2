r"""The Riccati path of the observer-gain synthesis: LMIs (14) and (15) of Grip, Saberi & Johansen without an SDP.

With ``Q = P⁻¹`` and ``W = N Nᵀ ≻ 0``, the sum of the Schur complements of LMIs (14) and (15),

.. math:: (A − K C) Q + Q (A − K C)ᵀ + Q² + γ^{-2} B_d B_dᵀ + γ_n^{-2} K W Kᵀ ≺ 0,

is the bounded-real lemma of the stacked error channel ``[H/γ, G/γn]`` (input ``(d, n)``, output the
error): it says ``‖[H/γ  G/γn]‖∞ < 1``, and it implies both (14) and (15) with the common ``P`` (each
block drops one positive semidefinite term of the sum). Completing the square in ``K`` gives the
minimiser ``K = γn² Q Cᵀ W⁻¹`` and leaves the H∞ filter Riccati inequality of Doyle, Glover,
Khargonekar & Francis (1989; their ``Y∞`` equation ``AY + YAᵀ + Y(γ⁻²C₁ᵀC₁ − C₂ᵀC₂)Y + B₁B₁ᵀ = 0`` with
their level 1 after scaling: the error as output, ``C₁ = I``, ``C₂ = γn W^{-1/2} C``, ``B₁ = B_d/γ``):

.. math:: A Y + Y Aᵀ + Y ((1 + σ) I − γ_n^2 Cᵀ W^{-1} C) Y + γ^{-2} B_d B_dᵀ + δ I = 0,

whose stabilising solution ``Y ≻ 0`` (``A + Y (I − γn² Cᵀ W⁻¹ C)`` Hurwitz) exists iff some gain
achieves ``‖[H/γ  G/γn]‖∞ < 1`` (for ``σ, δ → 0``); then ``K = γn² Y Cᵀ W⁻¹`` and ``P = Y⁻¹`` satisfy
(14) and (15) strictly: the sum of their Schur complements is ``−σ I − δ P²``. The small ``σ ≥ 0``
(an output weight ``1 + σ``) is the strictness margin, the small ``δ > 0`` keeps ``Y`` positive
definite. The solution is the stable invariant subspace of the Hamiltonian

.. math:: \mathcal H = \begin{bmatrix} Aᵀ & (1 + σ) I − γ_n^2 Cᵀ W^{-1} C \\ −(γ^{-2} B_d B_dᵀ + δ I) & −A \end{bmatrix},

``Y = U₂ U₁⁻¹`` from an ordered real Schur form (stable eigenvalues first); it exists iff ``𝓗`` has no
eigenvalue on the imaginary axis and ``U₁`` is invertible.

The condition is sufficient for (14)–(15) with a common ``P`` — the two blocks separately allow up to
``√2`` more in each bound — so where it fails the exact LMIs may still hold (``method="auto"`` of
:func:`nlobs.synthesis.design_observer_gain` then solves the SDP when its estimated size fits).

Costs: one real Schur form of a ``2n × 2n`` matrix (``O(n³)``, milliseconds at ``n = 100``), instead
of an interior-point method whose memory grows with ``n⁴``.

References
----------
J. C. Doyle, K. Glover, P. P. Khargonekar and B. A. Francis, "State-space solutions to standard H2
and H∞ control problems", IEEE Trans. Automatic Control 34 (1989) 831–847.

K. Zhou, J. C. Doyle and K. Glover, *Robust and Optimal Control*, Prentice Hall 1996, §13
(Hamiltonian matrices and the stabilising solution), §16.8 (bounded-real lemma).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

__all__ = ["FilterRiccati", "filter_riccati", "smallest_riccati_scale", "riccati_delta"]

_EPS = float(np.finfo(float).eps)
_AXIS_TOL = 1e-9  # Hamiltonian eigenvalues with |Re λ| below this × ‖𝓗‖₁ count as on the imaginary axis


@dataclass(frozen=True)
class FilterRiccati:
    """The stabilising solution of the H∞ filter Riccati equation and the gain it gives.

    Attributes
    ----------
    Y : ndarray, shape (n, n)
        Stabilising solution (symmetric positive definite).
    K : ndarray, shape (n, p)
        ``γn² Y Cᵀ W⁻¹``.
    P : ndarray, shape (n, n)
        ``Y⁻¹``, the Lyapunov matrix of LMIs (14), (15).
    delta : float
        The term ``δ`` of the equation (keeps ``Y`` positive definite).
    sigma : float
        The output weight ``1 + σ`` of the equation (the strictness of (14), (15)).
    residual : float
        ``‖A Y + Y Aᵀ + Y R Y + Q‖_F / (‖A Y‖_F + ‖Y R Y‖_F + ‖Q‖_F)`` (relative).
    axis_gap : float
        ``min |Re λ(𝓗)| / ‖𝓗‖₁`` — how far the Hamiltonian is from an eigenvalue on the imaginary axis.
    """

    Y: NDArray[np.float64]
    K: NDArray[np.float64]
    P: NDArray[np.float64]
    delta: float
    sigma: float
    residual: float
    axis_gap: float


def riccati_delta(Bd: NDArray[np.float64], gamma: float, margin: float) -> float:
    """The strictness term ``δ = ε · max(1, ‖B_d‖₂² / γ²)`` (``ε`` the design's margin).

    Parameters
    ----------
    Bd : ndarray, shape (n, m)
        Disturbance input matrix ``B_d``.
    gamma : float
        ``γ`` of LMI (14).
    margin : float
        The design's strictness margin ``ε``.

    Returns
    -------
    float
    """
    return float(margin * max(1.0, float(np.linalg.norm(Bd, 2)) ** 2 / gamma**2))


def _parts(A: NDArray[np.float64], C: NDArray[np.float64], Bd: NDArray[np.float64], W: NDArray[np.float64],
           gamma: float, gamma_n: float, delta: float, sigma: float) -> tuple[NDArray[np.float64],
                                                                             NDArray[np.float64], NDArray[np.float64]]:
    n = A.shape[0]
    WiC = np.linalg.solve(W, C)  # W⁻¹ C
    R = (1.0 + sigma) * np.eye(n) - gamma_n**2 * (C.T @ WiC)
    R = 0.5 * (R + R.T)
    Q = (Bd @ Bd.T) / gamma**2 + delta * np.eye(n)
    Q = 0.5 * (Q + Q.T)
    return R, Q, WiC


def filter_riccati(A: NDArray[np.float64], C: NDArray[np.float64], Bd: NDArray[np.float64], W: NDArray[np.float64],
                   gamma: float, gamma_n: float, delta: float, sigma: float = 0.0) -> FilterRiccati | str:
    """Solve the H∞ filter Riccati equation (module docstring) at ``(γ, γn, δ)``.

    ``sigma ≥ 0`` weights the error output by ``1 + σ`` (the ``I`` of (14), (15) becomes ``(1 + σ) I``):
    the blocks of (14) and (15) then hold with their Schur complements ``⪯ −σ I``, a margin that
    survives rounding. Returns the solution, or a one-sentence reason why no stabilising positive
    definite solution exists.

    Parameters
    ----------
    A, C, Bd : ndarray
        ``(n, n)``, ``(p, n)``, ``(n, m)``: the error dynamics of LMIs (14), (15).
    W : ndarray, shape (p, p)
        ``N Nᵀ ≻ 0``.
    gamma, gamma_n : float
        ``γ`` of (14) and ``γn`` of (15).
    delta : float
        The term ``δ > 0`` (see :func:`riccati_delta`).
    sigma : float
        The output weight ``σ ≥ 0``.

    Returns
    -------
    FilterRiccati or str
    """
    n = A.shape[0]
    R, Q, WiC = _parts(A, C, Bd, W, gamma, gamma_n, delta, sigma)
    H = np.block([[A.T, R], [-Q, -A]])
    scale = float(np.linalg.norm(H, 1))
    eig = np.linalg.eigvals(H)
    gap = float(np.min(np.abs(eig.real))) / scale
    if gap <= _AXIS_TOL:
        return (f"the Hamiltonian has an eigenvalue on the imaginary axis (|Re λ| / ‖𝓗‖ = {gap:.2g}): "
                "no stabilising solution")
    tol = _AXIS_TOL * scale
    try:
        _, Z, sdim = scipy.linalg.schur(H, output="real", sort=lambda re, im: re < -tol)
    except (np.linalg.LinAlgError, ValueError) as exc:
        return f"the ordered Schur form failed ({exc})"
    if sdim != n:
        return f"the Hamiltonian has {sdim} stable eigenvalues instead of n = {n}"
    U1, U2 = Z[:n, :n], Z[n:, :n]
    if np.linalg.cond(U1) > 1.0 / (1e3 * _EPS):
        return "the stable invariant subspace is not a graph (U₁ singular): no stabilising solution"
    Y = np.linalg.solve(U1.T, U2.T).T
    Y = 0.5 * (Y + Y.T)
    if not np.all(np.isfinite(Y)):
        return "the stabilising solution is not finite"
    ev = np.linalg.eigvalsh(Y)
    if ev[0] <= 0.0:
        return (f"the stabilising solution is not positive definite (λ_min(Y) = {ev[0]:.3g}): "
                "the bounds (γ, γn) are below what the joint H∞ condition achieves")
    AY = A @ Y
    YRY = Y @ R @ Y
    res = AY + AY.T + YRY + Q
    denom = 2 * float(np.linalg.norm(AY)) + float(np.linalg.norm(YRY)) + float(np.linalg.norm(Q))
    residual = float(np.linalg.norm(res)) / max(denom, 1e-300)
    K = gamma_n**2 * (Y @ WiC.T)
    P = np.linalg.inv(Y)
    P = 0.5 * (P + P.T)
    return FilterRiccati(Y, K, P, float(delta), float(sigma), residual, gap)


def smallest_riccati_scale(A: NDArray[np.float64], C: NDArray[np.float64], Bd: NDArray[np.float64],
                           W: NDArray[np.float64], gamma: float, gamma_n: float, margin: float,
                           *, sigma: float = 0.0, steps: int = 30) -> float | None:
    """Smallest ``τ ≥ 1`` (to about 0.1 %) with a solution at ``(τγ, τγn)``; ``None`` when none up to ``τ = 10⁶``.

    Parameters
    ----------
    A, C, Bd, W : ndarray
        As in :func:`filter_riccati`.
    gamma, gamma_n : float
        The bounds ``γ``, ``γn`` that ``τ`` scales.
    margin : float
        Strictness margin ``ε``; ``δ`` is :func:`riccati_delta` at each ``τγ``.
    sigma : float
        The output weight ``σ ≥ 0``.
    steps : int
        Most bisection steps (in ``log τ``) after the decade bracket.

    Returns
    -------
    float or None
    """

    def ok(t: float) -> bool:
        g = t * gamma
        return not isinstance(filter_riccati(A, C, Bd, W, g, t * gamma_n, riccati_delta(Bd, g, margin), sigma), str)

    if ok(1.0):
        return 1.0
    hi = 10.0
    while not ok(hi):
        hi *= 10.0
        if hi > 1e6:
            return None
    lo = hi / 10.0
    for _ in range(steps):
        if hi / lo < 1.001:
            break
        mid = math.sqrt(lo * hi)
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return hi
