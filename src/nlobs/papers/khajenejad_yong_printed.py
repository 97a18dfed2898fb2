r"""Khajenejad & Yong's Theorems 5.4, 5.10 and 5.13, Propositions 5.6 and 5.16 **as printed**, for comparison.

This module is part of the reading room (``nlobs.papers``): the paper's formulations as printed, used by
:mod:`nlobs.papers.khajenejad_yong` (``nlobs reproduce khajenejad-yong``) to show where they fail. The
library's sound design is :mod:`nlobs.synthesis.setvalued`; its observer takes any radius table
(:class:`~nlobs.observers.setvalued.Radii`), e.g. the one :func:`printed_radii` returns.

These LMIs are *not* a sound design (measured in ``docs/setvalued.md``): a gain they
accept can give unstable error dynamics. :func:`design_printed` solves the SDP of Theorem 5.10,

.. math:: (\rho^\star)^2 = \min \rho^2 \ \text{s.t. (18), (26)-(28)},

with a line search over ``α`` and a coarse-to-fine search over ``(ε₁, ε₂)``, on one problem compiled
with ``cp.Parameter``. Its answer is *reported* with the exact S-procedure condition (A.16) evaluated
at the returned ``(P, L̃, κ, α)`` and the spectral radius of ``(I − L̃C₂)Φ(A − Ψ)`` — never used by
the observer unless the caller decides to.

:func:`design_prop516` adds Proposition 5.16's constraints ``κ₁I ⪯ P ⪯ κ₂I`` and the disjunction
``(κ₁ ≥ 1, κ₂ − κ₁ < 1) ∨ (κ₂ ≤ 1, κ₁ > 0.5)`` (A.42)-(A.43) to the same builder, solves the two
branches as two SDPs (each compiled once, same search) and keeps the smaller ``ρ**``; it verifies
``θ₁ = |λ_max(P) − 1|/λ_min(P) < 1`` (32) from the returned ``P`` alone.

:func:`necessary_condition_printed` is Proposition 5.6's LMI test (23)-(24). What its answer proves
(proof A.13): a feasible point ``(P̃, Ỹ, Γ̃, η̃)`` shows that the error dynamics with the **one**
gain ``L̃ = P̃⁻¹Ỹ`` is unstable — ``Ỹ`` is a free variable, so it says nothing about other gains,
and "no stable observer exists" does not follow (a scalar counterexample is in ``docs/setvalued.md``
and ``tests/test_setvalued_printed_props.py``). Infeasibility proves nothing.

:func:`printed_radii` evaluates the radii of Theorem 5.13 exactly as printed (31)-(35); it is not safe
(measured in ``docs/setvalued.md``).

Transcription notes (each is where the printed text cannot be used literally):

* ``Γ`` in (26)-(27) must be ``(l − p_H) × (l − p_H)`` (it multiplies ``Ω``), not ``n × n``;
* ``2RᵀYΩ`` in ``N11`` is not symmetric: it enters symmetrised, ``RᵀYΩ + ΩᵀYᵀR``;
* the block ``Z̆ + M̃₄Ψ`` of (18) is not symmetric for a general ``Z̆``: CVXPY constrains the symmetric
  part, which is what is solved here;
* the multiplier ``M = [[M11, M12], [M12ᵀ, M22]]`` describes the **whole** ``f`` (as in the paper);
* ``Q = [0, 0, −√2T₂]`` has a middle block of width ``n_w``;
* strict inequalities (``P ≻ 0``, ``N ≻ 0``, ``Π̃ ≻ 0``, ``κ₂ − κ₁ < 1``, ``κ₁ > 0.5``, ``0 < η̃ < 1``)
  are imposed with explicit margins (arguments ``margin``, ``strict_margin``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import cvxpy as cp
import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_matrix, as_square, as_symmetric, positive, readonly
from nlobs.checks import Check, CheckKind
from nlobs.errors import CertificateError, DesignInfeasible, DimensionError, InvalidArgumentError
from nlobs.linear.transform_ui import UITransform, structural_check, ui_transform
from nlobs.observers.setvalued import Radii
from nlobs.synthesis.certificate import CertificateMixin, checks_dict
from nlobs.synthesis.lmi import Solver, as_solver, require_lmi_size, solve
from nlobs.systems.discrete_ui import DiscreteUISystem, qc_member_min_eig, qc_member_tolerance

__all__ = [
    "PrintedDesign",
    "design_printed",
    "exact_condition_a16",
    "theta1_printed",
    "Prop516Branch",
    "BranchOutcome",
    "Prop516Design",
    "design_prop516",
    "Prop56Verdict",
    "NecessaryConditionPrinted",
    "necessary_condition_printed",
    "printed_radii",
]


def _sym(X: Any) -> Any:
    return (X + X.T) / 2


def _split_M(M: ArrayLike, n: int) -> tuple[Array, Array, Array, Array]:
    M_ = as_symmetric("M", M, 2 * n)
    return M_, M_[:n, :n], M_[:n, n:], M_[n:, n:]


@dataclass(frozen=True)
class PrintedDesign(CertificateMixin):
    """The answer of Theorem 5.10's SDP as printed, with what it really guarantees.

    A :class:`~nlobs.synthesis.certificate.Certificate` whose checks are the exact condition (A.16) and the
    spectral radius: ``verified`` is ``False`` when the printed LMIs accepted a gain their own sufficient
    condition does not support (never use it as a certified observer).

    Attributes
    ----------
    P, Y : ndarray
    gain : ndarray
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
    solver : Solver or None
    """

    P: Array
    Y: Array
    gain: Array
    rho: float
    alpha: float
    eps1: float
    eps2: float
    kappa: float
    exact_min_eig: float
    spectral_radius: float
    solves: int
    seconds: float
    solver: Solver | None = None
    checks: tuple[Check, ...] = field(init=False, repr=False, compare=False)
    """Whether the answer is certified at all: exact (A.16) ``min eig ≥ 0`` and spectral radius ``< 1``."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "checks", _printed_checks(self.exact_min_eig, self.spectral_radius))

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view: the printed answer, its exact (A.16) and spectral radius, the checks."""
        return {"rho": self.rho, "alpha": self.alpha, "eps1": self.eps1, "eps2": self.eps2, "kappa": self.kappa,
                "P": self.P.tolist(), "Y": np.asarray(self.Y).tolist(), "gain": self.gain.tolist(),
                "exact_min_eig": self.exact_min_eig, "spectral_radius": self.spectral_radius,
                "verified": self.verified, "checks": checks_dict(self.checks), "solves": self.solves,
                "seconds": self.seconds, "solver": None if self.solver is None else self.solver.value}

    def summary(self) -> str:
        """One line per quantity, with the verdict of :attr:`verified`."""
        return (f"Thm 5.10 as printed: rho* = {self.rho:.6g}, alpha = {self.alpha:.4g}, eps1 = {self.eps1:.4g}, "
                f"eps2 = {self.eps2:.4g}, kappa = {self.kappa:.4g}\n"
                f"  (A.16) min eig = {self.exact_min_eig:.4g} (>= 0 needed), spectral radius = "
                f"{self.spectral_radius:.4g} (< 1 needed): " + _verdict(self.verified)
                + "".join("\n  " + c.summary() for c in self.checks))


def exact_condition_a16(M: Array, Phi: Array, Psi: Array, C2: Array, L_tilde: Array, P: Array, kappa: float,
                        alpha: float) -> float:
    r"""Minimum eigenvalue of ``κ[[−M11, −M12], [−M12ᵀ, −M22]] − [[B̆ᵀPB̆, B̆ᵀPĂ], [ĂᵀPB̆, ĂᵀPĂ + (α−1)P]]``.

    (A.16) without its ``γ`` row; ``Ă = −(I − L̃C₂)ΦΨ``, ``B̆ = (I − L̃C₂)Φ`` (A.12). It must be
    ``≥ 0`` for the Lyapunov decrease (17).

    Parameters
    ----------
    M : ndarray, shape (2n, 2n)
        The multiplier ``[[M11, M12], [M12ᵀ, M22]]`` of **f**.
    Phi, Psi, C2 : ndarray
        ``Φ``, ``Ψ`` and ``C₂`` of the transformation of Appendix A.1.
    L_tilde : ndarray
        The gain ``L̃``.
    P : ndarray, shape (n, n)
        The Lyapunov matrix.
    kappa : float
        The S-procedure multiplier weight ``κ``.
    alpha : float
        The ``α`` of the decrease condition.

    Returns
    -------
    float
        The minimum eigenvalue of the symmetric part.
    """
    n = P.shape[0]
    Bb = (np.eye(n) - L_tilde @ C2) @ Phi
    Ab = -Bb @ Psi
    lhs = -kappa * M
    rhs = np.block([[Bb.T @ P @ Bb, Bb.T @ P @ Ab], [Ab.T @ P @ Bb, Ab.T @ P @ Ab + (alpha - 1) * P]])
    D = lhs - rhs
    return float(np.linalg.eigvalsh(0.5 * (D + D.T))[0])


def theta1_printed(P: ArrayLike) -> float:
    r"""``θ₁ = |λ_max(P) − 1| / λ_min(P)`` of Theorem 5.13, (32), from the eigenvalues of ``P`` alone.

    Parameters
    ----------
    P : array_like, shape (n, n)
        The Lyapunov matrix; its symmetric part is used.

    Returns
    -------
    float

    Raises
    ------
    InvalidArgumentError
        The symmetric part of ``P`` is not positive definite.
    """
    P_ = as_square("P", P)
    ev = np.linalg.eigvalsh(0.5 * (P_ + P_.T))  # the symmetric part (a printed P* need not be symmetric)
    if ev[0] <= 0:
        raise InvalidArgumentError(f"P: must be positive definite, smallest eigenvalue {ev[0]:.3g}")
    return float(abs(ev[-1] - 1.0) / ev[0])


# --------------------------------------------------------------------------- Theorem 5.10's builder


class Prop516Branch(str, Enum):
    """The two sides of Proposition 5.16's disjunction (A.43), each with ``κ₁I ⪯ P ⪯ κ₂I`` (A.42)."""

    A = "A"
    """``κ₁ ≥ 1, κ₂ − κ₁ < 1`` (proof A.19, Case A)."""
    B = "B"
    """``κ₂ ≤ 1, κ₁ > 0.5`` (proof A.19, Case B)."""


@dataclass
class _Thm510:
    """Theorem 5.10's SDP (18), (26)-(28), compiled once; ``α, ε₁, ε₂`` are parameters."""

    prob: cp.Problem
    P: cp.Variable
    Y: cp.Variable
    kap: cp.Variable
    rho2: cp.Variable
    alpha: cp.Parameter
    e1: cp.Parameter
    e2: cp.Parameter
    einv: cp.Parameter
    extra: dict[str, cp.Variable] = field(default_factory=dict)


def thm510_size(system: DiscreteUISystem, tr: UITransform, branch: Prop516Branch | None = None,
                relax: bool = False) -> tuple[int, tuple[int, ...]]:
    """``(scalar decision variables, sizes of the semidefinite blocks)`` of the SDP :func:`_build_thm510` builds.

    ``P, Γ̃, Q̄`` (symmetric ``n × n``), ``Z̄`` (``n × n``), ``Y`` (``n × q``), ``Γ`` (``q × q``), ``κ``, ``ρ²``
    (and ``κ₁, κ₂`` / the shortfall); blocks ``P, Γ̃, Q̄`` (``n``), ``Γ`` (``q``), five of ``2n``, ``Π`` (``n + 2q``),
    ``N`` (``N_w + 2n``, ``N_w = 2l + n_w``) and with a branch ``κ₁I ⪯ P ⪯ κ₂I`` (two of ``n``).
    """
    n, q = system.n, tr.C2.shape[0]
    nw_cols = tr.T1.shape[1] + system.W.shape[1] + tr.T2.shape[1]
    nvar = 3 * (n * (n + 1) // 2) + n * n + n * q + q * (q + 1) // 2 + 2
    blocks = [n, n, n, q] + [2 * n] * 5 + [n + 2 * q, nw_cols + 2 * n]
    if relax:
        nvar += 1
    if branch is not None:
        nvar += 2
        blocks += [n, n]
    return nvar, tuple(blocks)


def _check_thm510_size(system: DiscreteUISystem, tr: UITransform, branch: Prop516Branch | None, who: str) -> None:
    nvar, blocks = thm510_size(system, tr, branch)
    require_lmi_size(f"{who}: the SDP of Theorem 5.10", f"n = {system.n} states, q = {tr.C2.shape[0]} transformed "
                     f"outputs", nvar, blocks, "reduce the model, or use the sound design design_setvalued "
                     "(about twice the states fit)")


def _build_thm510(system: DiscreteUISystem, M11: Array, M12: Array, M22: Array, tr: UITransform, margin: float,
                  branch: Prop516Branch | None = None, strict_margin: float = 0.0, relax: bool = False) -> _Thm510:
    """Build (18), (26)-(28) once; with ``branch``, add (A.42) and that side of (A.43) (Prop. 5.16).

    ``relax=True`` builds the diagnostic problem instead: ``N + sI ⪰ margin·I``, minimise ``s`` (the
    shortfall of (26)-(28) when everything else holds), kept in ``extra["shortfall"]``.
    """
    n = system.n
    q = tr.C2.shape[0]
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

    Y1 = (P - Y @ C2) @ Phi
    Y2 = -(P - Y @ C2) @ Phi @ Psi
    Mt1 = -kap * M11 - Qb
    Mt2 = -kap * M22 + (1 - alpha) * P - Gt  # (1 − α)P: α·P is parameter × variable (DPP)
    Mt3 = -kap * M11
    Mt4 = kap * M12.T
    cons = [P >> margin * I_n, Gt >> 0, Qb >> 0, Gam >> 0]
    cons += [_sym(cp.bmat([[P, Y1], [Y1.T, Mt1]])) >> 0,
             _sym(cp.bmat([[P, Y2], [Y2.T, Mt2]])) >> 0,
             _sym(cp.bmat([[P, Y1], [Y1.T, Mt3]])) >> 0,
             _sym(cp.bmat([[P, Y2], [Y2.T, Zb + Mt4 @ Psi]])) >> 0,
             _sym(cp.bmat([[Gt, Zb], [Zb.T, Psi.T @ Qb @ Psi]])) >> 0]
    Pi = cp.bmat([[np.eye(q) - Gam, np.zeros((q, n)), np.zeros((q, q))],
                  [np.zeros((n, q)), P, Y],
                  [np.zeros((q, q)), Y.T, np.eye(q)]])
    cons.append(_sym(Pi) >> 0)
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
    extra: dict[str, cp.Variable] = {}
    if relax:
        sh = cp.Variable(name="shortfall")
        extra["shortfall"] = sh
        cons.append(_sym(N) + sh * np.eye(Nw + 2 * n) >> margin * np.eye(Nw + 2 * n))
    else:
        cons.append(_sym(N) >> margin * np.eye(Nw + 2 * n))
    if branch is not None:
        k1 = cp.Variable(name="kappa1")
        k2 = cp.Variable(name="kappa2")
        extra.update(kappa1=k1, kappa2=k2)
        cons += [P >> k1 * I_n, P << k2 * I_n]  # (A.42)
        if branch is Prop516Branch.A:  # (A.43), Case A: κ₁ ≥ 1, κ₂ − κ₁ < 1
            cons += [k1 >= 1.0, k2 - k1 <= 1.0 - strict_margin]
        else:  # Case B: κ₂ ≤ 1, κ₁ > 0.5
            cons += [k2 <= 1.0, k1 >= 0.5 + strict_margin]
    obj = cp.Minimize(extra["shortfall"]) if relax else cp.Minimize(rho2)
    return _Thm510(cp.Problem(obj, cons), P, Y, kap, rho2, alpha, e1, e2, einv, extra)


@dataclass(frozen=True)
class _Best:
    rho2: float
    alpha: float
    eps1: float
    eps2: float
    P: Array
    Y: Array
    kappa: float
    extra: dict[str, float]


def _search(pb: _Thm510, solver: Solver, alphas: Sequence[float] | None, eps_grid: Sequence[float],
            refine: int) -> tuple[_Best | None, int]:
    """Search ``α`` and ``ε₁, ε₂`` on the problem compiled once.

    ``alphas`` given: those ``α`` on the coarse ``ε`` grid (``ε₁ = ε₂``). ``alphas`` ``None``: the line
    search of :func:`_alpha_line_search` (bisection for the smallest feasible ``α``, golden section of
    ``ρ*(α)``). At each ``α``, once a feasible ``ε`` is known only it and its two neighbours on the coarse
    grid are solved (the whole grid again if none of them is feasible). Then ``refine`` rounds of a 3×3 grid in ``(ε₁, ε₂)`` around the
    best point (coarse to fine).
    """
    solves = 0
    best: _Best | None = None

    def run(a: float, x1: float, x2: float) -> float:
        nonlocal solves, best
        pb.alpha.value, pb.e1.value, pb.e2.value, pb.einv.value = a, x1, x2, 1 / x1 + 1 / x2
        solves += 1
        res = solve(pb.prob, solver)
        if not res.status.has_solution or pb.rho2.value is None:
            return math.inf
        val = float(pb.rho2.value)
        if best is None or val < best.rho2:
            best = _Best(val, a, x1, x2, np.array(pb.P.value), np.array(pb.Y.value), float(pb.kap.value),
                         {k: float(v.value) for k, v in pb.extra.items()})
        return val

    eps = list(eps_grid)
    near: list[float] = []  # coarse to fine across α: once a feasible ε is known, only it and its grid neighbours

    def at_alpha(a: float) -> float:
        nonlocal near
        tried = near or eps
        vals = [run(a, x, x) for x in tried]
        if not math.isfinite(min(vals)) and near:  # the neighbours lost feasibility: the whole grid again
            vals, tried = [run(a, x, x) for x in eps], eps
        if math.isfinite(min(vals)):
            i = eps.index(tried[int(np.argmin(vals))])
            near = eps[max(i - 1, 0): i + 2]
        return min(vals)

    if alphas is None:
        _alpha_line_search(at_alpha)
    else:
        for a in alphas:
            at_alpha(a)
    if best is None:
        return None, solves
    for _ in range(int(refine)):
        b = best
        for f1 in (0.5, 1.0, 2.0):
            for f2 in (0.5, 1.0, 2.0):
                run(b.alpha, b.eps1 * f1, b.eps2 * f2)
    return best, solves


#: Line search of ``α ∈ [0, 1]`` (Theorem 5.4): bisection steps for the smallest feasible ``α``, most
#: golden-section steps for ``ρ*(α)``, and the relative agreement that ends the golden section early.
ALPHA_BISECTION_STEPS = 6
ALPHA_GOLDEN_STEPS = 10
ALPHA_RTOL = 1e-3


def _alpha_line_search(rho2_at: Callable[[float], float]) -> None:
    """Minimise ``ρ*(α)²`` over ``α ∈ [0, 1]`` (the caller keeps the best point).

    ``α = 1`` is tried first (the largest ``α`` relaxes ``αP`` in (18)); when it is infeasible, a coarse
    scan ``α = 0.1, …, 0.9`` looks for any feasible ``α`` (feasibility need not be monotone). From a
    feasible ``α_f`` a bisection on ``[0, α_f]`` finds the smallest feasible ``α`` it can reach, then a
    golden-section search of ``ρ*(α)`` runs on ``[α_min, α_f]`` (``ρ*`` is unimodal in the cases measured:
    on Example 6.1 it decreases monotonically towards ``α = 1``; docs/setvalued.md).
    """
    hi = 1.0
    if not math.isfinite(rho2_at(hi)):
        feas = [a for a in (0.9, 0.7, 0.5, 0.3, 0.1) if math.isfinite(rho2_at(a))]
        if not feas:
            return
        hi = feas[0]
    lo, top = 0.0, hi
    for _ in range(ALPHA_BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        if math.isfinite(rho2_at(mid)):
            hi = mid
        else:
            lo = mid
    a, b = hi, top
    gr = (math.sqrt(5.0) - 1) / 2
    x1, x2 = b - gr * (b - a), a + gr * (b - a)
    f1, f2 = rho2_at(x1), rho2_at(x2)
    for _ in range(ALPHA_GOLDEN_STEPS):
        if math.isfinite(f1) and math.isfinite(f2) and abs(f1 - f2) <= ALPHA_RTOL * min(f1, f2):
            break
        if f1 <= f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - gr * (b - a)
            f1 = rho2_at(x1)
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + gr * (b - a)
            f2 = rho2_at(x2)


def _n33_violation(M11: Array, margin: float) -> float | None:
    """By how much ``N33 = −ε₂ΦᵀC₂ᵀC₂Φ − M11 ⪰ margin·I`` (28) must fail for every ``ε₂ > 0`` (``None``: it need not)."""
    v = float(np.linalg.eigvalsh(M11)[-1]) + margin
    return v if v > 0 else None


def _n33_error(what: str, violation: float, margin: float) -> DesignInfeasible:
    return DesignInfeasible(
        f"{what}: N33 = -eps2 Phi^T C2^T C2 Phi - M11 >= {margin:g} I (28) fails for every eps2 > 0: "
        f"lambda_max(M11) + margin = {violation:.4g} > 0", constraint="N33 of (26)-(28)", violation=violation)


_DIAG_ALPHAS = (0.5, 0.95)


def _diagnosed(what: str, system: DiscreteUISystem, M11: Array, M12: Array, M22: Array, tr: UITransform,
               margin: float, branches: Sequence[Prop516Branch | None], strict_margin: float,
               eps_grid: Sequence[float], solver: Solver) -> DesignInfeasible:
    """The error for a grid with no feasible point, with the smallest shortfall of ``N ⪰ margin·I`` found.

    Relaxes (26)-(28) to ``N + sI ⪰ margin·I`` and minimises ``s`` (with (18), ``Π ⪰ 0`` and the
    branch's constraints kept) at ``α ∈ {0.5, 0.95}`` and the ``ε`` grid: ``violation`` is the smallest
    ``s`` found (a shortfall measured on those points, not a bound over all ``α, ε``); when the relaxed
    problem is infeasible too, (18) with ``Π ⪰ 0`` (and the branch) is what fails.
    """
    best = math.inf
    for br in branches:
        pb = _build_thm510(system, M11, M12, M22, tr, margin, br, strict_margin, relax=True)
        sh = pb.extra["shortfall"]
        for a in _DIAG_ALPHAS:
            for x in eps_grid:
                pb.alpha.value, pb.e1.value, pb.e2.value, pb.einv.value = a, x, x, 2 / x
                res = solve(pb.prob, solver)
                if res.status.has_solution and sh.value is not None:
                    best = min(best, float(sh.value))
    if math.isfinite(best):
        return DesignInfeasible(
            f"{what}: no feasible point on the whole (alpha, eps) grid; with (18) kept, N >= {margin:g} I of "
            f"(26)-(28) falls short: the smallest shortfall found is {best:.4g} (alpha in {_DIAG_ALPHAS}, eps in "
            f"{tuple(eps_grid)})", constraint="N of (26)-(28)", violation=best)
    extra = "" if all(b is None for b in branches) else " and (A.42)-(A.43) of each branch"
    return DesignInfeasible(f"{what}: (18) with Pi >= 0 of (26){extra} is infeasible by itself at alpha in "
                            f"{_DIAG_ALPHAS}", constraint=f"(18), Pi of (26){extra}")


def _alphas(alphas: Sequence[float] | None) -> list[float] | None:
    return None if alphas is None else list(alphas)


def _transform_for_printed(system: DiscreteUISystem, who: str) -> UITransform:
    tr = ui_transform(system.G, system.C, system.H, system.D)
    if tr.C2.shape[0] == 0:
        raise DimensionError(f"{who}: no measurement is left for the update (l = p_H)")
    return tr


def _spectral_radius(system: DiscreteUISystem, tr: UITransform, L: Array) -> float:
    n = system.n
    return float(np.max(np.abs(np.linalg.eigvals((np.eye(n) - L @ tr.C2) @ tr.Phi @ (system.A - tr.Psi)))))


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
        Values of ``α`` tried on a grid. Default: a line search of ``α ∈ [0, 1]`` (bisection for the
        smallest feasible ``α``, then golden section of ``ρ*(α)``; :func:`_alpha_line_search`).
    eps_grid : sequence of float
        Coarse grid for ``ε₁ = ε₂``'s search; then ``refine`` rounds of a 3×3 grid around the best point.
    refine : int
        Rounds of the 3×3 refinement of ``(ε₁, ε₂)`` around the best grid point.
    solver : Solver or str
    margin : float
        Margin of the strict ``P ≻ 0`` and ``N ≻ 0``.

    Returns
    -------
    PrintedDesign

    Raises
    ------
    DesignInfeasible
        When no grid point is feasible.
    """
    t0 = time.perf_counter()
    n = system.n
    M_, M11, M12, M22 = _split_M(M, n)
    tr = _transform_for_printed(system, "design_printed")
    v33 = _n33_violation(M11, margin)
    if v33 is not None:  # no ε₂ can help: fail before the search
        raise _n33_error("Theorem 5.10 as printed: (18), (26) infeasible", v33, margin)
    _check_thm510_size(system, tr, None, "design_printed")
    pb = _build_thm510(system, M11, M12, M22, tr, margin)
    slv = as_solver(solver)
    best, solves = _search(pb, slv, _alphas(alphas), eps_grid, refine)
    if best is None:
        raise _diagnosed("Theorem 5.10 as printed: (18), (26) infeasible", system, M11, M12, M22, tr, margin,
                         (None,), 0.0, eps_grid, slv)
    Pv = 0.5 * (best.P + best.P.T)
    L = np.linalg.solve(Pv, best.Y)
    emin = exact_condition_a16(M_, tr.Phi, tr.Psi, tr.C2, L, Pv, best.kappa, best.alpha)
    return PrintedDesign(Pv, best.Y, L, math.sqrt(best.rho2), best.alpha, best.eps1, best.eps2, best.kappa, emin,
                         _spectral_radius(system, tr, L), solves, time.perf_counter() - t0, slv)


# --------------------------------------------------------------------------- Proposition 5.16


@dataclass(frozen=True)
class BranchOutcome:
    """One side of Proposition 5.16's disjunction, solved as its own SDP.

    Attributes
    ----------
    branch : Prop516Branch
    rho : float or None
        The smallest ``ρ`` found on the search grid; ``None`` when every grid point was infeasible.
    solves : int
    P : ndarray or None
        The branch's ``P`` at its ``ρ``.
    theta1 : float or None
        ``|λ_max(P) − 1|/λ_min(P)`` (32) at that ``P``, recomputed in NumPy.
    """

    branch: Prop516Branch
    rho: float | None
    solves: int
    P: Array | None = None
    theta1: float | None = None


@dataclass(frozen=True)
class Prop516Design(CertificateMixin):
    r"""Proposition 5.16's mixed-integer SDP as two SDPs, and what its answer really guarantees.

    A :class:`~nlobs.synthesis.certificate.Certificate` whose checks are ``θ₁ < 1`` (32) (verified when
    the design returns), the exact condition (A.16) and the spectral radius (see :class:`PrintedDesign`).

    Attributes
    ----------
    rho : float
        ``ρ**``, the smaller of the two branches' ``ρ`` (not a certified H∞ bound: Theorem 5.10's
        LMIs are not sufficient).
    branch : Prop516Branch
        The branch that gave ``ρ**``.
    branches : tuple of BranchOutcome
        Both branches (A first).
    P, Y : ndarray
        At ``ρ**``.
    gain : ndarray
        ``L̃** = P**⁻¹Y**``.
    alpha, eps1, eps2, kappa, kappa1, kappa2 : float
        The search point and the solver's ``κ``, ``κ₁``, ``κ₂`` (A.42).
    lambda_min_P, lambda_max_P : float
        Eigenvalues of the returned ``P`` (NumPy).
    theta1 : float
        ``θ₁ = |λ_max(P) − 1|/λ_min(P)`` (32) recomputed from ``P`` alone: Proposition 5.16's
        guarantee is ``θ₁ < 1``.
    theta1_steady : float
        Theorem 5.13's printed ``δˣ_{∞,1} = ρ√((η_w² + η_v²)/(λ_min(P)(1 − θ₁)))`` (printed, not safe).
    exact_min_eig : float
        Minimum eigenvalue of (A.16) (``γ = 0`` part) at ``(P, L̃, κ, α)``; the Lyapunov decrease
        (17) needs it ``≥ 0``.
    spectral_radius : float
        Of ``(I − L̃C₂)Φ(A − Ψ)``.
    solves : int
    seconds : float
    solver : Solver or None
    """

    rho: float
    branch: Prop516Branch
    branches: tuple[BranchOutcome, ...]
    P: Array
    Y: Array
    gain: Array
    alpha: float
    eps1: float
    eps2: float
    kappa: float
    kappa1: float
    kappa2: float
    lambda_min_P: float
    lambda_max_P: float
    theta1: float
    theta1_steady: float
    exact_min_eig: float
    spectral_radius: float
    solves: int
    seconds: float
    solver: Solver | None = None
    checks: tuple[Check, ...] = field(init=False, repr=False, compare=False)
    """``θ₁ < 1`` (32) at ``P``, then exact (A.16) ``min eig ≥ 0`` and spectral radius ``< 1`` (:class:`PrintedDesign`)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "checks", (
            Check.compare("θ₁ = |λ_max(P) − 1|/λ_min(P) < 1 (32)", self.theta1, 1.0, kind=CheckKind.POSITIVITY),
            *_printed_checks(self.exact_min_eig, self.spectral_radius)))

    def summary(self) -> str:
        """One line per quantity."""
        br = ", ".join(f"{b.branch.value}: {'infeasible' if b.rho is None else f'{b.rho:.6g}'}" for b in self.branches)
        return (f"Prop. 5.16 as printed: rho** = {self.rho:.6g} (branch {self.branch.value}; {br})\n"
                f"  alpha = {self.alpha:.4g}, eps1 = {self.eps1:.4g}, eps2 = {self.eps2:.4g}, kappa = {self.kappa:.4g}, "
                f"kappa1 = {self.kappa1:.6g}, kappa2 = {self.kappa2:.6g}\n"
                f"  eig(P) in [{self.lambda_min_P:.6g}, {self.lambda_max_P:.6g}], theta1 = {self.theta1:.6g} (< 1 "
                f"required), printed steady radius delta_inf,1 = {self.theta1_steady:.4g}\n"
                f"  (A.16) min eig = {self.exact_min_eig:.4g} (>= 0 needed), spectral radius = "
                f"{self.spectral_radius:.4g} (< 1 needed): " + _verdict(self.verified)
                + "".join("\n  " + c.summary() for c in self.checks))

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view: ``ρ**``, both branches, the answer at ``ρ**``, ``θ₁``, (A.16), the checks."""
        return {"rho": self.rho, "branch": self.branch.value,
                "branches": [{"branch": b.branch.value, "rho": b.rho, "solves": b.solves, "theta1": b.theta1}
                             for b in self.branches],
                "P": self.P.tolist(), "Y": np.asarray(self.Y).tolist(), "gain": self.gain.tolist(),
                "alpha": self.alpha, "eps1": self.eps1, "eps2": self.eps2, "kappa": self.kappa,
                "kappa1": self.kappa1, "kappa2": self.kappa2, "lambda_min_P": self.lambda_min_P,
                "lambda_max_P": self.lambda_max_P, "theta1": self.theta1, "theta1_steady": self.theta1_steady,
                "exact_min_eig": self.exact_min_eig, "spectral_radius": self.spectral_radius,
                "verified": self.verified, "checks": checks_dict(self.checks), "solves": self.solves,
                "seconds": self.seconds, "solver": None if self.solver is None else self.solver.value}


def _printed_checks(exact_min_eig: float, spectral_radius: float) -> tuple[Check, Check]:
    """What a printed answer needs to be certified: (A.16) ``min eig ≥ 0`` (the decrease (17)) and a Schur error matrix."""
    return (Check.compare("exact condition (A.16): −min eig ≤ 0", -exact_min_eig, 0.0, kind=CheckKind.LMI,
                          strict=False),
            Check.compare("spectral radius of (I − L̃C₂)Φ(A − Ψ) < 1", spectral_radius, 1.0, kind=CheckKind.SPECTRUM))


def _verdict(verified: bool) -> str:
    return "certified" if verified else "NOT certified (verified = False: do not use this gain)"


def design_prop516(system: DiscreteUISystem, M: ArrayLike, *, gamma: float = 0.0,
                   alphas: Sequence[float] | None = None,
                   eps_grid: Sequence[float] = (0.01, 0.1, 1.0, 10.0, 100.0), refine: int = 2,
                   solver: Solver | str = Solver.CLARABEL, margin: float = 1e-7,
                   strict_margin: float = 1e-5) -> Prop516Design:
    r"""Proposition 5.16 as printed: Theorem 5.10's SDP with ``κ₁I ⪯ P ⪯ κ₂I`` and the disjunction (A.43).

    .. math::

        (\rho^{\star\star})^2 = \min \rho^2 \ \text{s.t. (18), (26) hold},\ \kappa_1 I \preceq P \preceq
        \kappa_2 I,\ (\kappa_1 \ge 1,\ \kappa_2 - \kappa_1 < 1) \vee (\kappa_2 \le 1,\ \kappa_1 > 0.5).

    The disjunction is split into two SDPs, as the paper suggests: branch A adds
    ``κ₁ ≥ 1, κ₂ − κ₁ ≤ 1 − strict_margin``, branch B adds ``κ₂ ≤ 1, κ₁ ≥ 0.5 + strict_margin``.
    Each is built once by Theorem 5.10's builder (the one :func:`design_printed` uses, with
    ``α, ε₁, ε₂`` as ``cp.Parameter``) and searched on the same grid; the smaller ``ρ`` is kept.

    Verified without the solver at the returned ``P``: ``θ₁ = |λ_max(P) − 1|/λ_min(P) < 1`` (32),
    which is what the proof A.19 derives from (A.42)-(A.43). Reported, not certified (the LMIs
    (18), (26) are not sufficient): the exact condition (A.16) and the spectral radius of
    ``(I − L̃C₂)Φ(A − Ψ)``.

    Parameters
    ----------
    system : DiscreteUISystem
    M : array_like, shape (2n, 2n)
        The multiplier of **f** (paper's convention).
    gamma : float
        ``γ`` of the class; must be ``≥ 0`` (Theorem 5.4: no quadratically stable estimator otherwise).
    alphas, eps_grid, refine, solver, margin
        As for :func:`design_printed`.
    strict_margin : float
        Margin of the strict ``κ₂ − κ₁ < 1`` and ``κ₁ > 0.5``.

    Returns
    -------
    Prop516Design

    Raises
    ------
    DesignInfeasible
        Neither branch is feasible on the grid (``constraint`` names both, ``violation`` is ``None``:
        no point to measure a margin at).
    CertificateError
        The returned ``P`` has ``θ₁ ≥ 1`` (the solver's answer does not meet (A.42)-(A.43)).
    """
    t0 = time.perf_counter()
    if gamma < 0:
        raise InvalidArgumentError(f"gamma: Theorem 5.4 / Proposition 5.16 need gamma >= 0, got {gamma!r}")
    sm = positive("strict_margin", strict_margin)
    n = system.n
    M_, M11, M12, M22 = _split_M(M, n)
    tr = _transform_for_printed(system, "design_prop516")
    what = ("Proposition 5.16 as printed: (18), (26) with kappa1 I <= P <= kappa2 I (A.42) infeasible in both branches "
            "of (A.43), A (kappa1 >= 1, kappa2 - kappa1 < 1) and B (kappa2 <= 1, kappa1 > 0.5)")
    v33 = _n33_violation(M11, margin)
    if v33 is not None:  # no ε₂ can help: fail before the search
        raise _n33_error(what, v33, margin)
    _check_thm510_size(system, tr, Prop516Branch.A, "design_prop516")
    slv = as_solver(solver)
    outcomes: list[BranchOutcome] = []
    bests: list[tuple[_Best, Prop516Branch]] = []
    solves = 0
    for br in (Prop516Branch.A, Prop516Branch.B):
        pb = _build_thm510(system, M11, M12, M22, tr, margin, br, sm)
        best, k = _search(pb, slv, _alphas(alphas), eps_grid, refine)
        solves += k
        if best is None:
            outcomes.append(BranchOutcome(br, None, k))
        else:
            Pb = 0.5 * (best.P + best.P.T)
            outcomes.append(BranchOutcome(br, math.sqrt(best.rho2), k, readonly(Pb), theta1_printed(Pb)))
            bests.append((best, br))
    if not bests:
        raise _diagnosed(what, system, M11, M12, M22, tr, margin, (Prop516Branch.A, Prop516Branch.B), sm,
                         eps_grid, slv)
    best, br = min(bests, key=lambda t: t[0].rho2)
    Pv = 0.5 * (best.P + best.P.T)
    ev = np.linalg.eigvalsh(Pv)
    th1 = float(abs(ev[-1] - 1.0) / ev[0])
    if not th1 < 1.0:
        raise CertificateError(
            f"Proposition 5.16: theta1 = |lambda_max(P) - 1|/lambda_min(P) = {th1:.6g} >= 1 at the returned P "
            f"(branch {br.value}, eig(P) in [{ev[0]:.6g}, {ev[-1]:.6g}]): the solver's answer misses (A.42)-(A.43) "
            f"by {th1 - 1.0:.3g}")
    L = np.linalg.solve(Pv, best.Y)
    emin = exact_condition_a16(M_, tr.Phi, tr.Psi, tr.C2, L, Pv, best.kappa, best.alpha)
    rho = math.sqrt(best.rho2)
    steady = rho * math.sqrt((system.eta_w**2 + system.eta_v**2) / (ev[0] * (1.0 - th1)))
    return Prop516Design(rho, br, tuple(outcomes), readonly(Pv), readonly(best.Y), readonly(L), best.alpha, best.eps1, best.eps2,
                         best.kappa, best.extra["kappa1"], best.extra["kappa2"], float(ev[0]), float(ev[-1]), th1,
                         steady, emin, _spectral_radius(system, tr, L), solves, time.perf_counter() - t0, slv)


# --------------------------------------------------------------------------- Proposition 5.6


class Prop56Verdict(str, Enum):
    """What an answer of Proposition 5.6's LMI test proves (proof A.13)."""

    GAIN_UNSTABLE = "gain_unstable"
    """(23) feasible: the error dynamics with the gain ``L̃ = P̃⁻¹Ỹ`` is unstable (``ΔṼ > δ_f ≥ 0``).
    Nothing follows for any other gain: it does **not** show that no stable observer exists."""
    INCONCLUSIVE = "inconclusive"
    """(23) infeasible: a necessary condition for stability is not violated; this proves nothing."""


def _member_check(name: str, K: Array, spectral_radius: float, min_modulus: float,
                  undetectable: tuple[complex, ...]) -> Check:
    r"""A linear member ``f(x) = Kx`` of the class (``[K; I]ᵀM[K; I] ⪰ 0``, so it satisfies (2) with ``γ = 0``).

    ``passed``: **some** gain makes this member's error dynamics Schur, i.e. ``(Φ(K − Ψ), C₂)`` has no
    unobservable mode with ``|λ| ≥ 1`` (:func:`~nlobs.linear.transform_ui.structural_check`); ``key``: the
    member's name (``"A"``, the system's linear part, ``"0"`` or the caller's); ``values``: ``K``,
    ``spectral_radius`` and ``min_modulus`` — the largest and smallest ``|λ|`` of ``(I − L̃C₂)Φ(K − Ψ)`` at
    the test's gain (``nan`` without one; if ``ΔṼ > δ_f`` holds every eigenvalue has ``|λ| > 1``, so
    ``min_modulus > 1``) — and ``undetectable_modes`` (the modes above, empty when it passes).
    """
    modes = ", ".join(f"{z:.6g}" for z in undetectable) or "none"
    ok = not undetectable
    return Check.verdict(
        f"member K = {name}: some gain stabilises it", ok,
        f"|eig| of (I - L~C2)Phi(K - Psi) in [{min_modulus:.4g}, {spectral_radius:.4g}]; some gain stabilises it: "
        f"{ok} (undetectable modes |lambda| >= 1: {modes})",
        kind=CheckKind.STRUCTURAL, method="numeric", key=name,
        values={"K": K, "spectral_radius": spectral_radius, "min_modulus": min_modulus,
                "undetectable_modes": undetectable})


@dataclass(frozen=True)
class NecessaryConditionPrinted:
    r"""Proposition 5.6's LMI test (23)-(24) as printed, its verdict and the evidence.

    Attributes
    ----------
    verdict : Prop56Verdict
    feasible : bool
        The solver found ``Π̃ ⪰ tI`` with ``t ≥ margin`` and the NumPy recheck confirms ``Π̃ ≻ 0``.
    gain_given : bool
        ``True`` when ``Ỹ = P̃L̃`` was imposed for a given ``L̃`` (the reading the proof supports).
    status : str
        The solver's status.
    margin : float
        ``t*``, the largest ``t`` (capped at 1) with ``Π̃ ⪰ tI`` found by the solver (``nan`` if none).
    P, Y, Gamma : ndarray or None
        ``P̃``, ``Ỹ``, ``Γ̃`` at the solver's point.
    eta : float or None
        ``η̃``.
    L_tilde : ndarray or None
        ``P̃⁻¹Ỹ`` (or the given gain).
    pi_tilde_min_eig, pi_hat_min_eig : float or None
        Minimum eigenvalues of ``Π̃`` (24) and ``Π̂`` (23), recomputed in NumPy.
    exact_min_eig : float or None
        Minimum eigenvalue of the exact form ``ΔṼ − δ_f`` (A.23), (A.28),
        ``[[B̆ᵀP̃B̆, B̆ᵀP̃Ă], [ĂᵀP̃B̆, ĂᵀP̃Ă − P̃]] − M`` with ``B̆ = (I − L̃C₂)Φ``, ``Ă = −B̆Ψ``; ``> 0``
        certifies the instability of that gain (``Π̃`` is a lower bound of it).
    members : tuple of Check
        One per linear member of the class (its ``key`` the member's name): does some gain stabilise
        it, with the spectrum at the test's gain as evidence.
    seconds : float
    """

    verdict: Prop56Verdict
    feasible: bool
    gain_given: bool
    status: str
    margin: float
    P: Array | None
    Y: Array | None
    Gamma: Array | None
    eta: float | None
    L_tilde: Array | None
    pi_tilde_min_eig: float | None
    pi_hat_min_eig: float | None
    exact_min_eig: float | None
    members: tuple[Check, ...]
    seconds: float

    def summary(self) -> str:
        """The numbers behind the verdict, and what they prove."""
        lines = [f"Proposition 5.6 (23)-(24) as printed, {'Y~ = P~ L~ for the given gain' if self.gain_given else 'Y~ free'}: "
                 f"{'feasible' if self.feasible else 'infeasible'} (solver {self.status}, t* = {self.margin:.4g})"]
        if self.L_tilde is not None:
            lines.append(f"  L~ = {np.round(self.L_tilde.ravel(), 6).tolist()}")
        if self.feasible:
            lines.append(f"  eta~ = {self.eta:.4g}, min eig Pi~ = {self.pi_tilde_min_eig:.4g}, min eig Pi^ = "
                         f"{self.pi_hat_min_eig:.4g}, min eig (DeltaV~ - delta_f) = {self.exact_min_eig:.4g}")
            lines.append("  proves: the error dynamics with THIS gain is unstable (A.13); nothing about other gains")
        else:
            lines.append("  proves: nothing (a necessary condition for stability is not violated)")
        lines += [f"  member K = {m.key}: {m.evidence}" for m in self.members]
        return "\n".join(lines)


def _members(system: DiscreteUISystem, M11: Array, M12: Array, M22: Array, gamma: float,
             members: Sequence[tuple[str, ArrayLike]] | None) -> list[tuple[str, Array]]:
    n = system.n
    M = np.block([[M11, M12], [M12.T, M22]])
    if members is None:
        if gamma > 0:  # σ(Kζ, ζ) = 0 < γ at ζ = 0: no linear map is in the class
            return []
        cands = [("A", np.asarray(system.A, dtype=float)), ("0", np.zeros((n, n)))]
        return [(nm, K) for nm, K in cands if qc_member_min_eig(M, K) >= -qc_member_tolerance(M, K)]
    out = []
    for i, (nm, K) in enumerate(members):
        K_ = as_matrix(f"members[{i}]", K, (n, n))
        v = qc_member_min_eig(M, K_)
        if gamma > 0 or v < -qc_member_tolerance(M, K_):
            raise InvalidArgumentError(
                f"members[{i}] ({nm!r}): f(x) = K x is not in the class: min eig of [K; I]^T M [K; I] = {v:.3g} "
                f"(gamma = {gamma:g})")
        out.append((str(nm), K_))
    return out


def _pi_tilde(P: Any, Y: Any, eta: Any, M11: Array, M12: Array, M22: Array, tr: UITransform) -> Any:
    """``Π̃`` of (23)-(24) for CVXPY expressions or NumPy arrays (same code: what is verified is what is solved)."""
    Phi, Psi, C2 = tr.Phi, tr.Psi, tr.C2
    cvx = isinstance(P, cp.Expression)
    blk = cp.bmat if cvx else np.block
    St = P - C2.T @ Y.T - Y @ C2
    Sh = St - (1 - eta) * (C2.T @ C2)
    P11 = Phi.T @ Sh @ Phi - M11
    P12 = -Phi.T @ St @ Phi @ Psi - M12
    P22 = Psi.T @ Phi.T @ Sh @ Phi @ Psi - P - M22
    return _sym(blk([[P11, P12], [P12.T, P22]]))


def necessary_condition_printed(system: DiscreteUISystem, M: ArrayLike, *, gamma: float = 0.0,
                                gain: ArrayLike | None = None,
                                members: Sequence[tuple[str, ArrayLike]] | None = None,
                                solver: Solver | str = Solver.CLARABEL, margin: float = 1e-6) -> NecessaryConditionPrinted:
    r"""Proposition 5.6's LMI test as printed: is there ``(P̃ ≻ 0, Ỹ, Γ̃ ≻ 0, 0 < η̃ < 1)`` with (23)?

    .. math::

        \hat\Pi = \begin{bmatrix} I - \tilde\Gamma & 0 & 0 \\ 0 & \tilde\Gamma & \tilde Y^\top \\
        0 & \tilde Y & \tilde P \end{bmatrix} \succeq 0, \quad
        \tilde\Pi = \begin{bmatrix} \tilde\Pi_{11} & \tilde\Pi_{12} \\ \tilde\Pi_{12}^\top & \tilde\Pi_{22}
        \end{bmatrix} \succ 0 \quad (23)

    with ``S̃ = P̃ − C₂ᵀỸᵀ − ỸC₂`` and (24): ``Π̃₁₁ = Φᵀ(S̃ − (1 − η̃)C₂ᵀC₂)Φ − M11``,
    ``Π̃₁₂ = −ΦᵀS̃ΦΨ − M12``, ``Π̃₂₂ = ΨᵀΦᵀ(S̃ − (1 − η̃)C₂ᵀC₂)ΦΨ − P̃ − M22``.

    Strictness: ``P̃ ⪰ margin·I``, ``Γ̃ ⪰ margin·I``, ``margin ≤ η̃ ≤ 1 − margin``, and the solver
    maximises ``t ≤ 1`` with ``Π̃ ⪰ tI``; (23) counts as feasible when ``t* ≥ margin`` and the NumPy
    recheck gives ``Π̃ ≻ 0``.

    What the answer proves (proof A.13, checked in ``docs/setvalued.md``): with ``L̃ = P̃⁻¹Ỹ``,
    ``ΔṼ ≥ ΔV̂ > δ_f ≥ γ ≥ 0`` for every admissible ``(Δf, x̃ ≠ 0)``, so the error dynamics **with that
    gain** is unstable. ``Ỹ`` is a free variable of (23), so a feasible point says nothing about other
    gains: it does not show that no stable observer exists (the paper's reading). Pass ``gain`` to
    impose ``Ỹ = P̃L̃`` — the test of one given gain that the proof supports. Infeasibility proves
    nothing in either case.

    Parameters
    ----------
    system : DiscreteUISystem
        Provides ``G, C, H`` (and ``A`` for the default linear members).
    M : array_like, shape (2n, 2n)
        The multiplier of **f** (paper's convention, ``Δf`` block first).
    gamma : float
        ``γ ≥ 0`` of the class (the proof uses ``δ_f ≥ γ ≥ 0``).
    gain : array_like, shape (n, l − p_H), optional
        Test this ``L̃`` (``Ỹ = P̃L̃``) instead of leaving ``Ỹ`` free.
    members : sequence of (str, array_like), optional
        Linear maps ``f(x) = Kx`` in the class, reported as evidence (default: those of ``A`` and ``0``
        that satisfy ``[K; I]ᵀM[K; I] ⪰ 0``).
    solver : Solver or str
    margin : float
        Margin of the strict inequalities.

    Returns
    -------
    NecessaryConditionPrinted

    Raises
    ------
    InvalidArgumentError
        ``gamma < 0``, or a given member is not in the class.
    CertificateError
        The solver reports ``t* ≥ margin`` but the recomputed ``ΔṼ − δ_f`` is not positive definite.
    """
    t0 = time.perf_counter()
    if gamma < 0:
        raise InvalidArgumentError(f"gamma: Proposition 5.6 needs gamma >= 0 (proof A.13 uses delta_f >= gamma >= 0), "
                                   f"got {gamma!r}")
    mg = positive("margin", margin)
    n = system.n
    M_, M11, M12, M22 = _split_M(M, n)
    tr = _transform_for_printed(system, "necessary_condition_printed")
    q = tr.C2.shape[0]
    Lg = None if gain is None else as_matrix("gain", np.asarray(gain, dtype=float).reshape(n, -1), (n, q))
    mem = _members(system, M11, M12, M22, gamma, members)

    P = cp.Variable((n, n), symmetric=True)
    Gam = cp.Variable((q, q), symmetric=True)
    eta = cp.Variable()
    t = cp.Variable()
    Y = P @ Lg if Lg is not None else cp.Variable((n, q))

    def pihat(Pv: Any, Yv: Any, Gv: Any) -> Any:
        blk = cp.bmat if isinstance(Pv, cp.Expression) else np.block
        return _sym(blk([[np.eye(q) - Gv, np.zeros((q, q)), np.zeros((q, n))],
                         [np.zeros((q, q)), Gv, Yv.T],
                         [np.zeros((n, q)), Yv, Pv]]))

    Pit = _pi_tilde(P, Y, eta, M11, M12, M22, tr)
    cons = [P >> mg * np.eye(n), Gam >> mg * np.eye(q), eta >= mg, eta <= 1 - mg, t <= 1.0,
            pihat(P, Y, Gam) >> 0, Pit >> t * np.eye(2 * n)]
    prob = cp.Problem(cp.Maximize(t), cons)
    res = solve(prob, as_solver(solver))
    ok = res.status.has_solution and t.value is not None and float(t.value) >= mg
    tv = float(t.value) if (res.status.has_solution and t.value is not None) else math.nan
    Pv = Yv = Gv = Lv = None
    ev = pit_min = pih_min = ex_min = None
    if res.status.has_solution and P.value is not None:
        Pv = 0.5 * (np.array(P.value) + np.array(P.value).T)
        Yv = np.array(Y.value).reshape(n, q)
        Gv = 0.5 * (np.array(Gam.value) + np.array(Gam.value).T)
        ev = float(eta.value)
        Lv = Lg if Lg is not None else np.linalg.solve(Pv, Yv)
        Pit_np = _pi_tilde(Pv, Yv, ev, M11, M12, M22, tr)
        pit_min = float(np.linalg.eigvalsh(Pit_np)[0])
        pih_min = float(np.linalg.eigvalsh(pihat(Pv, Yv, Gv))[0])
        Bb = (np.eye(n) - Lv @ tr.C2) @ tr.Phi
        Ab = -Bb @ tr.Psi
        E = np.block([[Bb.T @ Pv @ Bb, Bb.T @ Pv @ Ab], [Ab.T @ Pv @ Bb, Ab.T @ Pv @ Ab - Pv]]) - M_
        ex_min = float(np.linalg.eigvalsh(_sym(E))[0])
    feasible = bool(ok and pit_min is not None and pit_min > 0)
    if feasible and not (ex_min is not None and ex_min > 0):
        raise CertificateError(
            f"Proposition 5.6: the solver's point has t* = {tv:.3g} but DeltaV~ - delta_f has min eig {ex_min:.3g} <= 0")
    if Lg is not None:
        Lv = Lg
    evid = []
    for nm, K in mem:
        chk = structural_check(np.zeros((n, n)), system.G, system.C, system.H, members=(K,), transform=tr)
        bad = tuple(complex(z) for z in chk.unstable_error_modes[0])
        if Lv is not None and (feasible or Lg is not None):
            eig = np.abs(np.linalg.eigvals((np.eye(n) - Lv @ tr.C2) @ tr.Phi @ (K - tr.Psi)))
            sr, mm = float(eig.max()), float(eig.min())
        else:
            sr = mm = math.nan
        evid.append(_member_check(nm, readonly(K), sr, mm, bad))
    if not feasible:  # an infeasible test has no meaningful point: keep only a given gain
        Pv = Yv = Gv = None
        ev = pit_min = pih_min = ex_min = None
    verdict = Prop56Verdict.GAIN_UNSTABLE if feasible else Prop56Verdict.INCONCLUSIVE
    return NecessaryConditionPrinted(
        verdict, feasible, Lg is not None, res.raw_status, tv,
        None if Pv is None else readonly(Pv), None if Yv is None else readonly(Yv), None if Gv is None else readonly(Gv), ev,
        None if Lv is None or not (feasible or Lg is not None) else readonly(Lv), pit_min, pih_min, ex_min, tuple(evid),
        time.perf_counter() - t0)


# --------------------------------------------------------------------------- Theorem 5.13 as printed


def _nrm(M: Array) -> float:
    """Spectral norm, ``0`` for an empty matrix (as in :mod:`nlobs.observers.setvalued`)."""
    return float(np.linalg.norm(M, 2)) if M.size else 0.0


def printed_radii(system: DiscreteUISystem, L_tilde: ArrayLike, P: ArrayLike, rho: float, steps: int, *,
                  L_f: float | None = None, A_aux: ArrayLike | None = None, delta0: float | None = None) -> Radii:
    r"""Theorem 5.13 **as printed** (for comparison; not safe, see ``docs/setvalued.md``).

    ``δ_{k,1} = √(δ₀²θ₁ᵏ + ρ²/λ_min(P) (η_w² + η_v²) Σθ₁^{i−1})`` (31), ``θ₁ = |λ_max(P) − 1|/λ_min(P)`` (32),
    ``δ_{k,2} = δ₀θ₂ᵏ + η Σθ₂^{i−1}`` (33), ``η = ‖ℜ‖η_v + ‖ΨΦW‖η_w``,
    ``ℜ = −(ΨΦG₁M₁T₁ + ΨG₂M₂T₂ + L̃T₂)``; Class I (34): ``θ₂ = (L_f + ‖Ψ‖)‖(I − L̃C₂)Φ‖``,
    ``β = ‖V₁M₁C₁ − V₂M₂C₂Ψ‖ + L_f‖V₂M₂C₂‖``; Class II (35): ``λ_max(𝒜ᵀ𝒜)`` in place of ``L_f``;
    ``α = ‖V₂M₂C₂‖η_w + [‖(V₂M₂C₂G₁ − V₁)M₁T₁‖ + ‖V₂M₂T₂‖]η_v``; (29), (30).

    Exactly one of ``L_f`` (Class I) and ``A_aux`` (Class II) must be given; as
    in the paper they describe the whole ``f``.

    Parameters
    ----------
    system : DiscreteUISystem
        The plant (8).
    L_tilde : array_like
        The gain ``L̃``, reshaped to ``(n, l − p_H)``.
    P : array_like, shape (n, n)
        The symmetric positive definite matrix ``P`` of (31), (32) (symmetrised).
    rho : float
        ``ρ`` of (31).
    steps : int
        Number of steps ``K``.
    L_f : float, optional
        Lipschitz constant of ``f`` (Class I, (34)).
    A_aux : array_like, optional
        The matrix ``𝒜`` of Class II (35).
    delta0 : float, optional
        Initial state radius ``δ₀``; default ``system.delta0``.

    Returns
    -------
    Radii
        ``K + 1`` state radii, ``K`` input radii and their limits, labelled ``"printed"``.

    Raises
    ------
    InvalidArgumentError
        Neither or both of ``L_f`` and ``A_aux`` are given.
    """
    if (L_f is None) == (A_aux is None):
        raise InvalidArgumentError("printed_radii: give exactly one of L_f (Class I) and A_aux (Class II)")
    tr = ui_transform(system.G, system.C, system.H, system.D)
    n = system.n
    L = np.asarray(L_tilde, dtype=float).reshape(n, tr.C2.shape[0])
    P_ = np.asarray(P, dtype=float)
    ev = np.linalg.eigvalsh(0.5 * (P_ + P_.T))
    d0 = system.delta0 if delta0 is None else float(delta0)
    nrm = _nrm
    Phi, Psi = tr.Phi, tr.Psi
    theta1 = abs(ev[-1] - 1) / ev[0]
    Lc = L_f if L_f is not None else float(np.linalg.eigvalsh(np.asarray(A_aux).T @ np.asarray(A_aux))[-1])
    theta2 = (Lc + nrm(Psi)) * nrm((np.eye(n) - L @ tr.C2) @ Phi)
    Rm = -(Psi @ Phi @ tr.G1 @ tr.M1 @ tr.T1 + Psi @ tr.G2 @ tr.M2 @ tr.T2 + L @ tr.T2)
    eta = nrm(Rm) * system.eta_v + nrm(Psi @ Phi @ system.W) * system.eta_w
    V2M2C2 = tr.V2 @ tr.M2 @ tr.C2
    beta = nrm(tr.V1 @ tr.M1 @ tr.C1 - V2M2C2 @ Psi) + Lc * nrm(V2M2C2)
    alpha = nrm(V2M2C2) * system.eta_w + (nrm((V2M2C2 @ tr.G1 - tr.V1) @ tr.M1 @ tr.T1)
                                          + nrm(tr.V2 @ tr.M2 @ tr.T2)) * system.eta_v
    K = int(steps)
    k = np.arange(1, K + 1)
    geo1 = np.array([np.sum(theta1 ** np.arange(i)) for i in k])
    geo2 = np.array([np.sum(theta2 ** np.arange(i)) for i in k])
    noise2 = system.eta_w**2 + system.eta_v**2
    with np.errstate(over="ignore", invalid="ignore"):
        d1 = np.sqrt(d0**2 * theta1**k + rho**2 / ev[0] * noise2 * geo1)
        d2 = d0 * theta2**k + eta * geo2
    dx = np.concatenate([[d0], np.minimum(d1, d2)])
    dd = beta * dx[:-1] + alpha
    s1 = rho * math.sqrt(noise2 / (ev[0] * (1 - theta1))) if theta1 < 1 else math.inf
    s2 = eta / (1 - theta2) if theta2 < 1 else math.inf
    ss = min(s1, s2)
    return Radii(readonly(dx), readonly(dd), ss, beta * ss + alpha, "printed")
