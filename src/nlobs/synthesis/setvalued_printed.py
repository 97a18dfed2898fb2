r"""Seed 004's Theorems 5.4 and 5.10 **as printed**, for comparison with the paper only.

These LMIs are *not* a sound design (``../shared/guide/facts.md``; ``docs/setvalued.md``): a gain they
accept can give unstable error dynamics. :func:`design_printed` solves the SDP of Theorem 5.10,

.. math:: (\rho^\star)^2 = \min \rho^2 \ \text{s.t. (18), (26)-(28)},

with a line search over ``α`` and a coarse-to-fine search over ``(ε₁, ε₂)``, on one problem compiled
with ``cp.Parameter``. Its answer is *reported* with the exact S-procedure condition (A.16) evaluated
at the returned ``(P, L̃, κ, α)`` and the spectral radius of ``(I − L̃C₂)Φ(A − Ψ)`` — never used by
the observer unless the caller decides to.

Transcription notes (each is where the printed text cannot be used literally):

* ``Γ`` in (26)-(27) must be ``(l − p_H) × (l − p_H)`` (it multiplies ``Ω``), not ``n × n``;
* ``2RᵀYΩ`` in ``N11`` is not symmetric: it enters symmetrised, ``RᵀYΩ + ΩᵀYᵀR``;
* the block ``Z̆ + M̃₄Ψ`` of (18) is not symmetric for a general ``Z̆``: CVXPY constrains the symmetric
  part, which is what is solved here;
* the multiplier ``M = [[M11, M12], [M12ᵀ, M22]]`` describes the **whole** ``f`` (as in the paper);
* ``Q = [0, 0, −√2T₂]`` has a middle block of width ``n_w``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import cvxpy as cp
import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_symmetric
from nlobs.errors import DesignInfeasible, DimensionError
from nlobs.linear.transform_ui import ui_transform
from nlobs.synthesis.lmi import Solver, as_solver, solve
from nlobs.systems.discrete_ui import DiscreteUISystem

__all__ = ["PrintedDesign", "design_printed", "exact_condition_a16"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class PrintedDesign:
    """The answer of Theorem 5.10's SDP as printed, with what it really guarantees.

    Attributes
    ----------
    P, Y, L_tilde : ndarray
        ``L̃ = P⁻¹Y``.
    rho : float
        The printed "H∞ bound" ``ρ*`` (not a certified bound).
    alpha, eps1, eps2, kappa : float
    exact_min_eig : float
        Minimum eigenvalue of the left side of (A.16) (``γ = 0`` part) at the returned point: the
        paper's own sufficient condition needs it ``≥ 0``.
    spectral_radius : float
        Of ``(I − L̃C₂)Φ(A − Ψ)`` (the linear part, ``Δf = A x̃``).
    solves : int
    seconds : float
    """

    P: Array
    Y: Array
    L_tilde: Array
    rho: float
    alpha: float
    eps1: float
    eps2: float
    kappa: float
    exact_min_eig: float
    spectral_radius: float
    solves: int
    seconds: float


def exact_condition_a16(M: Array, Phi: Array, Psi: Array, C2: Array, L_tilde: Array, P: Array, kappa: float,
                        alpha: float) -> float:
    r"""Minimum eigenvalue of ``κ[[−M11, −M12], [−M12ᵀ, −M22]] − [[B̆ᵀPB̆, B̆ᵀPĂ], [ĂᵀPB̆, ĂᵀPĂ + (α−1)P]]``.

    (A.16) without its ``γ`` row; ``Ă = −(I − L̃C₂)ΦΨ``, ``B̆ = (I − L̃C₂)Φ`` (A.12). It must be
    ``≥ 0`` for the Lyapunov decrease (17).
    """
    n = P.shape[0]
    Bb = (np.eye(n) - L_tilde @ C2) @ Phi
    Ab = -Bb @ Psi
    lhs = -kappa * M
    rhs = np.block([[Bb.T @ P @ Bb, Bb.T @ P @ Ab], [Ab.T @ P @ Bb, Ab.T @ P @ Ab + (alpha - 1) * P]])
    D = lhs - rhs
    return float(np.linalg.eigvalsh(0.5 * (D + D.T))[0])


def design_printed(system: DiscreteUISystem, M: ArrayLike, *, alphas: Sequence[float] | None = None,
                   eps_grid: Sequence[float] = (0.01, 0.1, 1.0, 10.0, 100.0), refine: int = 2,
                   solver: Solver | str = Solver.CLARABEL, margin: float = 1e-7) -> PrintedDesign:
    r"""Solve Theorem 5.10's SDP (with (18) of Theorem 5.4) as printed; see the module notes.

    Parameters
    ----------
    system : DiscreteUISystem
        Provides ``G, C, H, W``, ``A`` (only for the reported spectral radius) and the noise structure.
    M : array_like, shape (2n, 2n)
        The multiplier of **f** (paper's convention), e.g. ``[[−I, 0], [0, L_f² I]]`` for Class I.
    alphas : sequence of float, optional
        Values of ``α`` tried (default 0.05, 0.10, …, 0.95).
    eps_grid : sequence of float
        Coarse grid for ``ε₁ = ε₂``'s search; then ``refine`` rounds of a 3×3 grid around the best point.
    """
    t0 = time.perf_counter()
    n = system.n
    M_ = as_symmetric("M", M, 2 * n)
    M11, M12, M22 = M_[:n, :n], M_[:n, n:], M_[n:, n:]
    tr = ui_transform(system.G, system.C, system.H, system.D)
    q = tr.C2.shape[0]
    if q == 0:
        raise DimensionError("design_printed: no measurement is left for the update (l = p_H)")
    l, nw = system.l, system.n_w
    Phi, Psi, C2 = tr.Phi, tr.Psi, tr.C2
    s2 = math.sqrt(2.0)
    R = np.hstack([-s2 * Phi @ tr.G1 @ tr.M1 @ tr.T1, -Phi @ system.W, -s2 * tr.G2 @ tr.M2 @ tr.T2])
    Qm = np.hstack([np.zeros((q, l)), np.zeros((q, nw)), -s2 * tr.T2])
    Om = C2 @ R - Qm
    Nw = R.shape[1]
    I_n = np.eye(n)

    P = cp.Variable((n, n), symmetric=True)
    Y = cp.Variable((n, q))
    kap = cp.Variable(nonneg=True)
    Gt = cp.Variable((n, n), symmetric=True)
    Qb = cp.Variable((n, n), symmetric=True)
    Zb = cp.Variable((n, n))
    Gam = cp.Variable((q, q), symmetric=True)
    rho2 = cp.Variable(nonneg=True)
    alpha = cp.Parameter(nonneg=True, value=0.5)
    e1 = cp.Parameter(pos=True, value=1.0)
    e2 = cp.Parameter(pos=True, value=1.0)
    einv = cp.Parameter(nonneg=True, value=2.0)  # 1/ε1 + 1/ε2 (kept affine for DPP)

    def sym(X):  # type: ignore[no-untyped-def]
        return (X + X.T) / 2

    Y1 = (P - Y @ C2) @ Phi
    Y2 = -(P - Y @ C2) @ Phi @ Psi
    Mt1 = -kap * M11 - Qb
    Mt2 = -kap * M22 + (1 - alpha) * P - Gt  # (1 − α)P: α·P is parameter × variable (DPP)
    Mt3 = -kap * M11
    Mt4 = kap * M12.T
    cons = [P >> margin * I_n, Gt >> 0, Qb >> 0, Gam >> 0]
    cons += [sym(cp.bmat([[P, Y1], [Y1.T, Mt1]])) >> 0,
             sym(cp.bmat([[P, Y2], [Y2.T, Mt2]])) >> 0,
             sym(cp.bmat([[P, Y1], [Y1.T, Mt3]])) >> 0,
             sym(cp.bmat([[P, Y2], [Y2.T, Zb + Mt4 @ Psi]])) >> 0,
             sym(cp.bmat([[Gt, Zb], [Zb.T, Psi.T @ Qb @ Psi]])) >> 0]
    Pi = cp.bmat([[np.eye(q) - Gam, np.zeros((q, n)), np.zeros((q, q))],
                  [np.zeros((n, q)), P, Y],
                  [np.zeros((q, q)), Y.T, np.eye(q)]])
    cons.append(sym(Pi) >> 0)
    N11 = (rho2 * np.eye(Nw) + R.T @ Y @ Om + Om.T @ Y.T @ R - R.T @ P @ R - Om.T @ Gam @ Om
           - einv * (Om.T @ Om))
    PR_ = P @ R - Y @ Om - C2.T @ Y.T @ R
    N21 = Psi.T @ Phi.T @ PR_
    N31 = -Phi.T @ PR_
    CP = C2 @ Phi
    N22 = -I_n + alpha * P - e1 * (Psi.T @ CP.T @ CP @ Psi) - M22
    N32 = -M12
    N33 = -e2 * (CP.T @ CP) - M11
    N = cp.bmat([[N11, N21.T, N31.T], [N21, N22, N32.T], [N31, N32, N33]])
    cons.append(sym(N) >> margin * np.eye(Nw + 2 * n))
    prob = cp.Problem(cp.Minimize(rho2), cons)
    slv = as_solver(solver)
    solves = 0
    best: tuple[float, float, float, float, Array, Array, float] | None = None

    def run(a: float, x1: float, x2: float) -> float:
        nonlocal solves, best
        alpha.value, e1.value, e2.value, einv.value = a, x1, x2, 1 / x1 + 1 / x2
        solves += 1
        res = solve(prob, slv)
        if not res.status.has_solution or rho2.value is None:
            return math.inf
        val = float(rho2.value)
        if best is None or val < best[0]:
            best = (val, a, x1, x2, np.array(P.value), np.array(Y.value), float(kap.value))
        return val

    al = list(alphas) if alphas is not None else [0.05 * i for i in range(1, 20)]
    # coarse: α × ε (ε1 = ε2), then refine ε1, ε2 separately around the best point
    for a in al:
        for x in eps_grid:
            run(a, x, x)
    if best is None:
        raise DesignInfeasible("Theorem 5.10 as printed: (18), (26) infeasible on the whole (α, ε) grid",
                               constraint="(18), (26)")
    for _ in range(int(refine)):
        _, a, x1, x2, *_ = best
        for f1 in (0.5, 1.0, 2.0):
            for f2 in (0.5, 1.0, 2.0):
                run(a, x1 * f1, x2 * f2)
    val, a, x1, x2, Pv, Yv, kv = best
    Pv = 0.5 * (Pv + Pv.T)
    L = np.linalg.solve(Pv, Yv)
    emin = exact_condition_a16(M_, Phi, Psi, C2, L, Pv, kv, a)
    srad = float(np.max(np.abs(np.linalg.eigvals((np.eye(n) - L @ C2) @ Phi @ (system.A - Psi)))))
    return PrintedDesign(Pv, Yv, L, math.sqrt(val), a, x1, x2, kv, emin, srad, solves, time.perf_counter() - t0)
