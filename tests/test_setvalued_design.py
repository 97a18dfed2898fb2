"""Sound design of the Khajenejad–Yong observer gain: error dynamics, certificate, failures."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import AssumptionViolated, CertificateError, DesignInfeasible, InvalidArgumentError, NonFiniteError
from nlobs.papers.khajenejad_yong import example_61, example_62
from nlobs.simulate.setvalued import radii_of, run_setvalued, state_containment, input_containment, input_estimates
from nlobs.synthesis.setvalued import design_setvalued, verify_setvalued
from nlobs.systems.discrete_ui import LPV, DiscreteUISystem, Lipschitz
from nlobs.systems.timebase import Discrete


def _lti(L: float = 0.0) -> DiscreteUISystem:
    """A small strongly detectable system with one unknown input and partial feed-through."""
    A = np.array([[0.9, 0.2, 0.0], [0.0, 0.8, 0.3], [0.1, 0.0, 1.05]])
    G = np.array([[1.0], [0.0], [0.5]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    H = np.array([[0.0], [0.2]])
    phi = (lambda x: L * np.sin(x[..., [1, 2, 0]])) if L else None
    return DiscreteUISystem(A, G, C, H, phi=phi, function_class=Lipschitz(L, 3), eta_w=0.05, eta_v=0.02,
                            delta0=1.0, time=Discrete(1.0))


@pytest.mark.parametrize("which", ["lti", "ex61"])
def test_error_dynamics_match_a_simulation(which: str) -> None:
    """x̃_k = Ξ(L̃)[ζ; π; ω] exactly, for any gain: checks the derivation of (16) independently."""
    if which == "lti":
        sysm = _lti(0.05)
    else:
        sysm = example_61("II").system
    design = design_setvalued(sysm)
    rng = np.random.default_rng(4)
    B, K = 4, 6
    x0 = sysm.x0 + rng.normal(size=(B, sysm.n))
    d = rng.normal(size=(B, K + 1, sysm.p)) * 3
    w = rng.normal(size=(B, K, sysm.n_w)) * 0.1
    v = rng.normal(size=(B, K + 1, sysm.l)) * 0.1
    x, y = sysm.simulate(x0, d, w, v)
    run = run_setvalued(sysm, design, y)
    e = x - run.x_hat
    Acl, Bcl, E = design.dynamics.split(design.gain)
    for k in range(1, K + 1):
        zeta = e[:, k - 1]
        pi = sysm.nonlinear(x[:, k - 1]) - sysm.nonlinear(run.x_hat[:, k - 1])
        om = np.concatenate([v[:, k - 1], w[:, k - 1], v[:, k]], axis=-1)
        pred = zeta @ Acl.T + pi @ Bcl.T + om @ E.T
        np.testing.assert_allclose(e[:, k], pred, atol=1e-9 * (1 + np.abs(e[:, k]).max()))


def test_radius_design_is_certified() -> None:
    design = design_setvalued(_lti(0.05))
    assert design.verified and design.objective.value == "radius"
    assert 0 < design.lam < 1 and design.spectral_radii[0] <= np.sqrt(design.lam) + 1e-9
    # recompute the exact condition (⋆) here from the returned numbers
    dyn = design.dynamics
    Xi = dyn.closed_loop(design.gain)
    n, l, nw = dyn.n, dyn.l, dyn.n_w
    N = Xi.shape[1]
    S = np.zeros((N, N))
    S[:n, :n] = -design.lam * design.P
    t1, tw, t2 = design.theta
    S[2 * n:, 2 * n:] = -np.diag(np.r_[np.full(l, t1), np.full(nw, tw), np.full(l, t2)])
    S[:n, :n] += design.kappa * 0.05**2 * np.eye(n)  # M22 = L² I
    S[n:2 * n, n:2 * n] += -design.kappa * np.eye(n)  # M11 = -I
    assert np.linalg.eigvalsh(Xi.T @ design.P @ Xi + S).max() <= 0.0  # exactly as production: no tolerance


def test_hinf_design_bound_matches_python_control() -> None:
    control = pytest.importorskip("control")
    sysm = _lti(0.0)
    design = design_setvalued(sysm, objective="hinf")
    assert design.rho is not None and design.verified
    Acl, _, E = design.dynamics.split(design.gain)
    s = np.r_[np.full(sysm.l, np.sqrt(2)), np.ones(sysm.n_w), np.full(sysm.l, np.sqrt(2))]
    ss = control.ss(Acl, E * s, np.eye(3), np.zeros((3, E.shape[1])), 1.0)
    w = np.linspace(0, np.pi, 4001)
    peak = max(np.linalg.norm(ss(np.exp(1j * wk)), 2) for wk in w)  # frequency sweep (lower bound of the norm)
    assert peak <= design.rho * (1 + 1e-6)
    assert design.hinf_linear[0] == pytest.approx(peak, rel=1e-3)
    # the Lyapunov matrix also proves contraction: V_k ≤ (1 - 1/λmax(P)) V_{k-1} + c
    assert design.lam_eff == pytest.approx(1 - 1 / np.linalg.eigvalsh(design.P)[-1])


def test_hinf_needs_nonnegative_gamma() -> None:
    with pytest.raises(InvalidArgumentError, match="'hinf' needs γ ≥ 0"):
        design_setvalued(example_61("II").system, objective="hinf")


def test_infeasible_design_raises() -> None:
    with pytest.raises(DesignInfeasible, match="infeasible for every λ < 1") as info:
        design_setvalued(_lti(5.0))
    assert info.value.constraint == "(⋆)"


def test_example_61_class_I_as_printed_has_no_quadratic_certificate() -> None:
    with pytest.raises(DesignInfeasible, match="infeasible"):
        design_setvalued(example_61("I").system)


def test_example_62_as_printed_is_refused_with_evidence() -> None:
    with pytest.raises(AssumptionViolated, match="no stable observer") as info:
        design_setvalued(example_62().system)
    assert info.value.item == "no_stable_observer"


def test_verify_rejects_a_bad_gain() -> None:
    sysm = _lti(0.0)
    good = design_setvalued(sysm)
    checks = verify_setvalued(sysm, good.gain, good.P, kappa=good.kappa, lam=good.lam, theta=good.theta)
    assert all(c.passed for c in checks)
    with pytest.raises(CertificateError, match="S-procedure condition"):
        verify_setvalued(sysm, np.zeros_like(good.gain), good.P, kappa=good.kappa, lam=good.lam,
                         theta=good.theta)


def test_nan_measurement_is_rejected() -> None:
    sysm = _lti(0.0)
    design = design_setvalued(sysm)
    y = np.zeros((2, 5, 2))
    y[1, 3, 0] = np.nan
    with pytest.raises(NonFiniteError, match="y: entry \\(1, 3, 0\\)"):
        run_setvalued(sysm, design, y)


def test_lpv_vertices_are_certified_and_contain_every_member() -> None:
    A = np.array([[0.5, 0.2, 0.0], [0.0, 0.4, 0.3], [0.1, 0.0, 0.6]])
    Ai = (np.diag([0.2, 0.0, 0.0]), np.diag([0.0, 0.0, -0.2]))
    sysm = DiscreteUISystem(A, [[1.0], [0.0], [0.5]], [[1.0, 0, 0], [0, 0, 1.0]], [[0.0], [0.2]],
                            function_class=LPV(Ai), eta_w=0.05, eta_v=0.02, delta0=1.0,
                            time=Discrete(1.0))
    design = design_setvalued(sysm)
    assert design.kappa == 0.0 and len(design.spectral_radii) == 2
    Acl, Bcl, _ = design.dynamics.split(design.gain)
    # every convex combination is contracted in the P-norm by at most λ (vertex LMIs imply the polytope)
    for s in np.linspace(0, 1, 11):
        Ak = Acl + Bcl @ (s * Ai[0] + (1 - s) * Ai[1])
        assert np.linalg.eigvals(np.linalg.solve(design.P, Ak.T @ design.P @ Ak)).real.max() <= design.lam + 1e-7


def test_example_61_printed_class_0_multiplier_is_infeasible() -> None:
    with pytest.raises(DesignInfeasible, match="infeasible"):
        design_setvalued(example_61("0").system)


@pytest.mark.parametrize("case", ["p_H = l", "p = 0"])
def test_edge_structures_design_and_contain(case: str) -> None:
    from nlobs.papers.khajenejad_yong import PaperExample, containment_study

    A = np.array([[0.5, 0.2], [0.1, 0.3]])
    C = np.array([[1.0, 0.5]])
    if case == "p_H = l":  # H invertible: all of y goes to d1, no gain left (L~ is n x 0)
        G, H, dfun = np.array([[1.0], [0.3]]), np.array([[2.0]]), (lambda t: (t**2)[:, None])
    else:  # no unknown input: a plain set-valued Luenberger observer
        G, H, dfun = np.zeros((2, 0)), None, (lambda t: np.zeros((t.size, 0)))
    s = DiscreteUISystem(A, G, C, H, function_class=Lipschitz(0.05, 2), phi=lambda x: 0.05 * np.sin(x),
                         eta_w=0.1, eta_v=0.1, delta0=1.0, time=Discrete(1.0))
    design = design_setvalued(s)
    assert design.gain.shape == ((2, 0) if case == "p_H = l" else (2, 1))
    res = containment_study(PaperExample(s, {}, dfun, case), design, runs=1000, steps=50, seed=9)
    assert res.rate_state == 1.0 and res.rate_input == 1.0
