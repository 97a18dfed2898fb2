"""Khajenejad & Yong Propositions 5.6 and 5.16 as printed: closed-form tiny cases, branch selection, verification.

Every expectation is derived here, by hand or from quantities recomputed in the test, not copied from
the functions' output (see docs/setvalued.md, "Propositions 5.6 and 5.16 as printed").
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from nlobs.errors import DesignInfeasible, InvalidArgumentError
from nlobs.linear.transform_ui import structural_check, ui_transform
from nlobs.papers.khajenejad_yong import TS, example_61, example_62
from nlobs.papers.khajenejad_yong_printed import (
    Prop56Verdict,
    Prop516Branch,
    design_printed,
    design_prop516,
    exact_condition_a16,
    necessary_condition_printed,
    printed_radii,
    theta1_printed,
)
from nlobs.synthesis.setvalued import design_setvalued
from nlobs.systems.discrete_ui import DiscreteUISystem
from nlobs.systems.timebase import Discrete


def _scalar(a: float, g: float, c1: float, c2: float, w: float = 1.0) -> DiscreteUISystem:
    """``x⁺ = a x + g d + w w``, ``y = [c1 x + d; c2 x]``: p_H = p = 1, so Φ = 1, Ψ = g c1, C₂ = ±c2.

    For ``f(x) = a x`` the error dynamics (16) is ``x̃⁺ = (1 − L̃C₂)(a − g c1) x̃``: a stable gain exists
    iff ``c2 ≠ 0`` or ``|a − g c1| < 1``.
    """
    return DiscreteUISystem(np.array([[a]]), np.array([[g]]), np.array([[c1], [c2]]), np.array([[1.0], [0.0]]),
                            W=np.array([[w]]), eta_w=0.1, eta_v=0.1, time=Discrete(1.0))


def _class_II(K: np.ndarray) -> np.ndarray:
    """(21) on the whole f: ``[[−I, K], [Kᵀ, −KᵀK]]`` (exact for ``f = K x``, γ = 0)."""
    n = K.shape[0]
    return np.block([[-np.eye(n), K], [K.T, -K.T @ K]])


def _lipschitz(L: float, n: int) -> np.ndarray:
    return np.block([[-np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), L**2 * np.eye(n)]])


def _error_factor(s: DiscreteUISystem, a: float, L: float) -> float:
    """|(1 − L C₂)(a − Ψ)| for the scalar system, from the transform (Φ = 1 checked)."""
    tr = ui_transform(s.G, s.C, s.H)
    assert tr.Phi.shape == (1, 1) and tr.Phi[0, 0] == pytest.approx(1.0)
    return abs((1 - L * tr.C2[0, 0]) * (a - tr.Psi[0, 0]))


# --------------------------------------------------------------------------- Proposition 5.6


def test_prop56_feasible_although_a_stable_gain_exists() -> None:
    # x⁺ = 0.5x + d, y = [d; x]: Ψ = 0, error factor |1 − L̃|·0.5, stable for L̃ ∈ (−1, 3) (L̃ = 0 included)
    a = 0.5
    s = _scalar(a, 1.0, 0.0, 1.0)
    r = necessary_condition_printed(s, _class_II(np.array([[a]])))
    assert r.verdict is Prop56Verdict.GAIN_UNSTABLE and r.feasible and not r.gain_given
    L = float(r.L_tilde[0, 0])
    assert _error_factor(s, a, L) > 1.0  # the one gain the feasible point is about is unstable ...
    assert _error_factor(s, a, 0.0) < 1.0  # ... but L̃ = 0 is stable: "no stable observer exists" is false
    assert r.members[0].key == "A" and r.members[0].passed
    assert r.members[0].values["min_modulus"] == pytest.approx(_error_factor(s, a, L), rel=1e-9)
    assert r.exact_min_eig >= r.pi_tilde_min_eig > 0  # Π̃ is a lower bound of ΔṼ − δ_f (A.26)
    # the reading the proof supports: Ỹ = P̃L̃ for a given stable gain is (necessarily) infeasible
    for stable in (0.0, 1.0, 2.5):
        assert _error_factor(s, a, stable) < 1.0
        rg = necessary_condition_printed(s, _class_II(np.array([[a]])), gain=[[stable]])
        assert rg.verdict is Prop56Verdict.INCONCLUSIVE and rg.gain_given and rg.margin < 0
    # and for a given unstable gain it can fire
    ru = necessary_condition_printed(s, _class_II(np.array([[a]])), gain=[[-6.0]])
    assert _error_factor(s, a, -6.0) > 1.0
    assert ru.verdict is Prop56Verdict.GAIN_UNSTABLE


def _max_min_eig_c2_zero(a: float, psi: float, margin: float) -> float:
    """``C₂ = 0``: ``S̃ = P̃``, ``Π̃ = [[P̃ + 1, −P̃ψ − a], [−P̃ψ − a, ψ²P̃ − P̃ + a²]]`` (24), whatever Ỹ, η̃.

    Its determinant is ``P̃((a − ψ)² − 1 − P̃)``: feasible iff ``|a − ψ| > 1``. The solver's ``t*`` is
    ``min(1, max_P λ_min(Π̃(P)))``, evaluated here on a grid.
    """
    P = np.geomspace(margin, 50.0, 40001)
    m11, m12, m22 = P + 1, -P * psi - a, psi**2 * P - P + a**2
    lmin = 0.5 * (m11 + m22) - np.sqrt(0.25 * (m11 - m22) ** 2 + m12**2)
    return float(min(1.0, lmin.max()))


@pytest.mark.parametrize("a, g, c1, feasible", [(3.0, 1.0, 1.0, True), (1.5, 1.0, 1.0, False), (0.4, 2.0, 1.0, True),
                                                (2.0, 1.0, 0.0, True), (0.9, 1.0, 0.0, False)])
def test_prop56_scalar_without_update_matches_the_closed_form(a: float, g: float, c1: float, feasible: bool) -> None:
    s = _scalar(a, g, c1, 0.0)  # z₂ = v only: every gain leaves x̃⁺ = (a − g c1) x̃
    psi = g * c1
    assert feasible == (abs(a - psi) > 1.0)
    r = necessary_condition_printed(s, _class_II(np.array([[a]])))
    assert r.feasible is feasible
    assert r.verdict is (Prop56Verdict.GAIN_UNSTABLE if feasible else Prop56Verdict.INCONCLUSIVE)
    assert r.margin == pytest.approx(_max_min_eig_c2_zero(a, psi, 1e-6), abs=2e-4)
    assert r.members[0].passed is (abs(a - psi) < 1.0)  # no gain acts: stabilisable iff already stable


def test_prop56_on_the_examples_as_printed() -> None:
    ex = example_61("II")
    A = ex.system.A
    M = _class_II(A)
    r = necessary_condition_printed(ex.system, M)
    assert r.verdict is Prop56Verdict.GAIN_UNSTABLE
    tr = ui_transform(ex.system.G, ex.system.C, ex.system.H)
    E = (np.eye(4) - r.L_tilde @ tr.C2) @ tr.Phi @ (A - tr.Psi)
    assert np.min(np.abs(np.linalg.eigvals(E))) > 1.0  # ΔṼ > 0 for f = Ax: every mode of that gain grows
    # ... yet a stable gain exists for f = Ax: nlobs's sound design certifies one (spectral radius < 1)
    sound = design_setvalued(ex.system)
    Es = (np.eye(4) - sound.gain @ tr.C2) @ tr.Phi @ (A - tr.Psi)
    assert np.max(np.abs(np.linalg.eigvals(Es))) < 1.0
    # the per-gain test misses the printed L̃*, although its error dynamics diverge
    Lp = np.asarray(ex.printed["L_tilde"], dtype=float)[:, None]
    Ep = (np.eye(4) - Lp @ tr.C2) @ tr.Phi @ (A - tr.Psi)
    assert np.max(np.abs(np.linalg.eigvals(Ep))) > 1.0
    assert necessary_condition_printed(ex.system, M, gain=Lp).verdict is Prop56Verdict.INCONCLUSIVE
    # 6.2: H = 0 so Ψ = 0 and Π̃₂₂ = −P̃ − L_f² I ≺ 0 for every P̃: the test can never fire,
    # although no stable observer exists (invariant zero −1.3431 of (A, G, C))
    s = example_62().system
    tr2 = ui_transform(s.G, s.C, s.H)
    assert np.all(tr2.Psi == 0)
    r2 = necessary_condition_printed(s, _lipschitz(1.1171, 2))
    assert r2.verdict is Prop56Verdict.INCONCLUSIVE and r2.margin < 0
    assert not structural_check(s.A, s.G, s.C, s.H).exists


def test_prop56_bad_input() -> None:
    s = _scalar(0.5, 1.0, 0.0, 1.0)
    with pytest.raises(InvalidArgumentError, match="gamma"):
        necessary_condition_printed(s, _class_II(np.array([[0.5]])), gamma=-0.1)
    with pytest.raises(InvalidArgumentError, match="not in the class"):
        necessary_condition_printed(s, _lipschitz(0.1, 1), members=[("K", [[0.5]])])


# --------------------------------------------------------------------------- Proposition 5.16

_GRID = {"alphas": [0.5, 0.95], "eps_grid": (0.1, 1.0), "refine": 0}


def _in_branch(P: np.ndarray, branch: Prop516Branch) -> float:
    """θ₁ of (32) from P alone, after checking that P is on ``branch``'s side of (A.43) (proof A.19)."""
    ev = np.linalg.eigvalsh(P)
    if branch is Prop516Branch.A:  # κ₁ ≥ 1, κ₂ − κ₁ ≤ 1 − 1e-5
        assert ev[0] >= 1.0 - 1e-7 and ev[-1] - ev[0] <= 1.0 - 1e-5 + 1e-7
    else:  # κ₂ ≤ 1, κ₁ ≥ 0.5 + 1e-5
        assert ev[-1] <= 1.0 + 1e-7 and ev[0] >= 0.5 + 1e-5 - 1e-7
    th1 = abs(ev[-1] - 1) / ev[0]
    assert th1 < 1.0
    return float(th1)


def _check_theta1(d, system: DiscreteUISystem) -> float:  # type: ignore[no-untyped-def]
    for b in d.branches:
        if b.rho is not None:
            assert b.theta1 == pytest.approx(_in_branch(b.P, b.branch), rel=1e-12)
    th1 = _in_branch(d.P, d.branch)
    ev = np.linalg.eigvalsh(d.P)
    assert d.theta1 == pytest.approx(th1, rel=1e-12) and theta1_printed(d.P) == pytest.approx(th1, rel=1e-12)
    noise2 = system.eta_w**2 + system.eta_v**2
    steady = d.rho * math.sqrt(noise2 / (ev[0] * (1 - th1)))
    assert d.theta1_steady == pytest.approx(steady, rel=1e-9)
    return steady


def test_prop516_class_I_only_branch_A_can_be_feasible() -> None:
    # N ≻ 0 with N33 ⪯ −M11 = I gives αP ≻ (1 + L²)I ⪰ I, so P ⪯ κ₂I ⪯ I (branch B) is impossible
    L = 0.1
    s = _scalar(0.5, 1.0, 0.0, 1.0)
    d = design_prop516(s, _lipschitz(L, 1), **_GRID)
    outcome = {b.branch: b.rho for b in d.branches}
    assert outcome[Prop516Branch.B] is None and outcome[Prop516Branch.A] == pytest.approx(d.rho)
    assert d.branch is Prop516Branch.A
    assert d.alpha * d.lambda_min_P > 1 + L**2
    steady = _check_theta1(d, s)
    # Theorem 5.13's printed constants in observers/setvalued.py agree: its steady state is min(δ∞,1, δ∞,2)
    rad = printed_radii(s, d.gain, d.P, d.rho, 10, L_f=L)
    assert rad.state_steady <= steady * (1 + 1e-12)
    tr = ui_transform(s.G, s.C, s.H)
    assert d.exact_min_eig == pytest.approx(
        exact_condition_a16(_lipschitz(L, 1), tr.Phi, tr.Psi, tr.C2, d.gain, d.P, d.kappa, d.alpha))
    assert d.spectral_radius == pytest.approx(_error_factor(s, 0.5, float(d.gain[0, 0])))


@pytest.mark.parametrize("c2, w", [(0.3, 1.0), (1.0, 1.0), (0.3, 3.0)])
def test_prop516_keeps_the_branch_that_holds_theorem_510s_optimum(c2: float, w: float) -> None:
    # A multiplier that no linear map satisfies ([k; 1]ᵀM[k; 1] = −k² − 3 < 0), so that branch B can
    # be feasible at all; the SDP is solved as printed. For n = 1 the branches are P ≥ 1 (A) and
    # 0.5 < P ≤ 1 (B): the one that contains Theorem 5.10's optimum P* (same grid) must attain ρ*.
    M = np.array([[-1.0, 0.0], [0.0, -3.0]])
    s = _scalar(0.5, 1.0, 0.0, c2, w)
    base = design_printed(s, M, **_GRID)
    P0 = float(base.P[0, 0])
    assert min(abs(P0 - 0.5), abs(P0 - 1.0)) > 1e-3  # the expectation below is then unambiguous
    d = design_prop516(s, M, **_GRID)
    rhos = {b.branch: b.rho for b in d.branches}
    assert all(r is not None and r >= base.rho * (1 - 1e-6) for r in rhos.values())  # restrictions of Thm 5.10
    assert d.rho == min(rhos.values()) and rhos[d.branch] == d.rho
    if P0 > 0.5:  # P* lies in one branch: that branch attains ρ* and is kept
        expected = Prop516Branch.B if P0 < 1 else Prop516Branch.A
        assert rhos[expected] == pytest.approx(base.rho, rel=1e-4)
        assert d.branch is expected
    else:  # P* < 0.5 lies in neither: both are strictly worse, B's P sits at its bound κ₁ > 0.5
        assert all(r > base.rho * (1 + 1e-6) for r in rhos.values())
    _check_theta1(d, s)


def test_prop516_example_61_class_II_theta1_below_one_but_unstable() -> None:
    ex = example_61("II")
    A = ex.system.A
    M = _class_II(A)
    grid = {"alphas": [0.95], "eps_grid": (0.05, 0.1), "refine": 0}
    d = design_prop516(ex.system, M, **grid)
    assert d.branch is Prop516Branch.A and {b.branch: b.rho for b in d.branches}[Prop516Branch.B] is None
    _check_theta1(d, ex.system)
    assert d.rho >= design_printed(ex.system, M, **grid).rho * (1 - 1e-6)
    tr = ui_transform(ex.system.G, ex.system.C, ex.system.H)
    E = (np.eye(4) - d.gain @ tr.C2) @ tr.Phi @ (A - tr.Psi)
    sr = float(np.max(np.abs(np.linalg.eigvals(E))))
    assert sr > 1.0 and d.spectral_radius == pytest.approx(sr)  # convergent printed bounds, divergent errors
    assert exact_condition_a16(M, tr.Phi, tr.Psi, tr.C2, d.gain, d.P, d.kappa, d.alpha) < 0
    assert d.verified is False and "NOT certified" in d.summary()


def test_prop516_infeasible_and_bad_input() -> None:
    s = example_61("0").system
    M0 = np.block([[np.eye(4), np.zeros((4, 4))], [np.zeros((4, 4)), (3.333 * TS) ** 2 * np.eye(4)]])
    with pytest.raises(DesignInfeasible, match="N33") as exc:
        design_prop516(s, M0, **_GRID)
    assert exc.value.violation == pytest.approx(1.0 + 1e-7)  # λ_max(M11) = λ_max(I) = 1, plus the margin
    assert exc.value.constraint.startswith("N33")
    with pytest.raises(InvalidArgumentError, match="gamma"):
        design_prop516(_scalar(0.5, 1.0, 0.0, 1.0), _lipschitz(0.1, 1), gamma=-1.0, **_GRID)


def test_infeasible_grids_name_the_failing_constraint() -> None:
    # 6.1 Class I (L_f = 3.33 T_s on f): (18) holds, N ⪰ margin·I of (26)-(28) falls short by a measured amount
    s = example_61("I").system
    with pytest.raises(DesignInfeasible, match="smallest shortfall found") as exc:
        design_printed(s, _lipschitz(3.33 * TS, 4), alphas=[0.5], eps_grid=(0.1, 1.0), refine=0)
    assert exc.value.constraint == "N of (26)-(28)" and exc.value.violation is not None and exc.value.violation > 0
    # 6.2 (Class I, L_f = 1.1171, Ψ = 0): (18) with Π ⪰ 0 is infeasible by itself
    s2 = example_62().system
    with pytest.raises(DesignInfeasible, match="infeasible by itself") as exc2:
        design_prop516(s2, _lipschitz(1.1171, 2), alphas=[0.5], eps_grid=(0.1, 1.0), refine=0)
    assert exc2.value.constraint.startswith("(18), Pi of (26)") and "A.43" in exc2.value.constraint
