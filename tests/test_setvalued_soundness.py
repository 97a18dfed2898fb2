"""Soundness conditions of the Khajenejad–Yong observer: each test fails on the code before its fix."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError
from nlobs.papers.khajenejad_yong import example_61
from nlobs.simulate.setvalued import ball_samples
from nlobs.observers.setvalued import sound_radii
from nlobs.simulate.setvalued import run_setvalued, state_containment
from nlobs.synthesis.setvalued import design_setvalued
from nlobs.systems.discrete_ui import LPV, DiscreteUISystem, Lipschitz, check_function_class
from nlobs.systems.timebase import Discrete

LO, HI = [-3.0, -3.0], [3.0, 3.0]
VERTS = (np.array([[0.0, 1.5], [0.0, 0.0]]), np.zeros((2, 2)))


def _hole(x: np.ndarray) -> np.ndarray:
    """φ = [0, 1.5 x₂]: 1.5-Lipschitz, but no difference quotient in conv{Aᵢ} (an LPV class with a hole)."""
    return np.stack([np.zeros(x.shape[:-1]), 1.5 * x[..., 1]], axis=-1)


def _member(x: np.ndarray) -> np.ndarray:
    """φ = [0.1 x₁, 0] = ½ diag(0.2, 0) x: every difference quotient lies in conv{diag(0.2, 0), 0}."""
    return np.stack([0.1 * x[..., 0], np.zeros(x.shape[:-1])], axis=-1)


def _lpv_system(phi=_member) -> DiscreteUISystem:  # type: ignore[no-untyped-def]
    return DiscreteUISystem(np.array([[0.5, 0.2], [0.0, 0.3]]), [[1.0], [0.0]], [[1.0, 0.0], [0.0, 0.0]],
                            [[0.0], [1.0]], phi=phi, function_class=LPV((np.diag([0.2, 0.0]), np.zeros((2, 2)))),
                            eta_w=0.01, eta_v=0.01, delta0=0.5, time=Discrete(1.0))


# --------------------------------------------------------------------------- 1. Class III


def test_lpv_class_check_tests_polytope_membership_not_only_the_lipschitz_bound() -> None:
    # the σ̃ = 1.5 Lipschitz bound holds for this φ ...
    assert check_function_class(_hole, Lipschitz(1.5, 2), LO, HI, n_pairs=2000).passed
    # ... but its difference quotients [0, 1.5 Δx₂] are not λ [1.5 Δx₂, 0]: the LPV class is violated
    chk = check_function_class(_hole, LPV(VERTS), LO, HI, n_pairs=2000)
    assert not chk.passed and chk.value < -1.0
    assert "distance of Δφ" in chk.evidence
    dx = chk.values["x2"] - chk.values["x1"]
    # (0, 1.5Δx₂) is orthogonal to the segment [0, (1.5Δx₂, 0)]: its distance is 1.5|Δx₂|
    assert np.sqrt(-chk.value) == pytest.approx(1.5 * abs(dx[1]), rel=1e-9)
    assert check_function_class(_member, LPV((np.diag([0.2, 0.0]), np.zeros((2, 2)))), LO, HI, n_pairs=2000).passed


def test_lpv_polytope_gap_with_three_vertices_matches_a_hand_projection() -> None:
    lpv = LPV((np.eye(2), -np.eye(2), np.diag([1.0, -1.0])))
    dx = np.array([[1.0, 1.0], [1.0, 1.0]])
    dphi = np.array([[0.5, 0.0], [2.0, 1.0]])  # first: ½(I) + ½(diag(1,-1)) → member; second: outside
    gap = lpv.polytope_gap(dphi, dx)
    assert gap[0] == pytest.approx(0.0, abs=1e-9)
    assert gap[1] == pytest.approx(1.0, abs=1e-6)  # nearest member I·dx = (1, 1)


def test_vertex_design_refuses_to_run_without_shared_weights() -> None:
    s = _lpv_system()
    vert = design_setvalued(s)  # default: vertices, the weights= path
    rng = np.random.default_rng(0)
    x, y = s.simulate(ball_samples(rng, (4,), 0.5, 2), np.zeros((4, 11, 1)), np.zeros((4, 10, 2)), np.zeros((4, 11, 2)))
    with pytest.raises(InvalidArgumentError, match="run-time weights"):
        run_setvalued(s, vert, y)
    lam = np.full((11, 2), 0.5)
    run_setvalued(s, vert, y, weights=lam)  # the library's weights= path is accepted


def test_lipschitz_mode_design_for_the_plants_own_phi_is_contained() -> None:
    s = _lpv_system()
    d = design_setvalued(s, lpv="lipschitz")
    assert d.certified_for.lpv is not None and d.certified_for.lpv.value == "lipschitz"
    assert d.function_class.label == "Class I (Lipschitz)" and d.kappa > 0
    rng = np.random.default_rng(1)
    B, K = 300, 60
    x, y = s.simulate(ball_samples(rng, (B,), 0.5, 2), np.broadcast_to(np.sin(np.arange(K + 1))[None, :, None],
                                                                       (B, K + 1, 1)),
                      ball_samples(rng, (B, K), 0.01, 2), ball_samples(rng, (B, K + 1), 0.01, 2))
    assert state_containment(run_setvalued(s, d, y), x).all()


# --------------------------------------------------------------------------- 2. design/system mismatch


def test_design_run_on_another_system_is_refused() -> None:
    s = example_61("II").system
    d = design_setvalued(s)
    other = dataclasses.replace(s, eta_w=1, eta_v=1)
    with pytest.raises(InvalidArgumentError, match="eta_w = 1 exceeds the certified 0.1"):
        sound_radii(other, d, 10)
    y = np.zeros((1, 11, s.l))
    with pytest.raises(InvalidArgumentError, match="certified for another system"):
        run_setvalued(other, d, y)
    with pytest.raises(InvalidArgumentError, match="A differs"):
        run_setvalued(dataclasses.replace(s, A=s.A * 1.01), d, y)
    with pytest.raises(InvalidArgumentError, match="function class"):
        sound_radii(example_61("I").system, d, 10)
    # smaller noise bounds are covered by the certified increment c
    assert sound_radii(dataclasses.replace(s, eta_w=0.05), d, 10).state.shape == (11,)


# --------------------------------------------------------------------------- 3./4. conditions along the runs


def _cubic() -> DiscreteUISystem:
    """φ = [0, 0.1x₁³]: 0.3-Lipschitz only on |x₁| ≤ 1."""
    return DiscreteUISystem(np.array([[0.5, 0.2], [0.0, 0.3]]), [[1.0], [0.0]], [[1.0, 0.0], [0.0, 0.0]],
                            [[0.0], [1.0]], phi=lambda x: np.stack([0 * x[..., 0], 0.1 * x[..., 0] ** 3], axis=-1),
                            function_class=Lipschitz(0.3, 2), eta_w=0.01, eta_v=0.01, delta0=0.5, time=Discrete(1.0))


def test_monte_carlo_evaluates_the_class_on_the_visited_pairs_and_the_box() -> None:
    from nlobs.workflows.setvalued import monte_carlo

    s = _cubic()
    d = design_setvalued(s)
    box = (np.array([-1.0, -1.0]), np.array([1.0, 1.0]))
    inside = monte_carlo(s, d, lambda t: (0.2 * np.sin(t))[:, None], runs=40, steps=60, baselines=False, box=box)
    r = inside.containment
    assert r.class_violated_in_runs == 0 and r.left_box_runs == 0 and r.roundoff_runs == 0 and r.guarantee_held
    assert r.likely_causes() == []
    out = monte_carlo(s, d, lambda t: (0.8 + 0.2 * np.sin(t))[:, None], runs=40, steps=60, baselines=False, box=box)
    r = out.containment
    assert r.class_violated_in_runs == 40 and r.class_worst_margin < 0 and r.left_box_runs == 40
    assert not r.guarantee_held and "violated along the trajectories" in r.likely_causes()[0]
    # one mechanism: the certificate monitor reports the same runs, each with its first violated pair
    assert inside.containment.coverage.covers_run and inside.containment.coverage.covered_fraction == 1.0
    cov = r.coverage
    assert not cov.covers_run and cov.covered_runs == 0 and len(cov.violations) == 40
    from nlobs.systems.discrete_ui import class_margins

    b = out.batch
    _, rel = class_margins(s.nonlinear, s.function_class, b.x_hat[:, :-1], b.x[:, :-1])
    first_k = np.argmax(rel < 0, axis=1)  # an independent first-violation step per run
    for v in cov.violations:
        assert v.hypothesis.startswith("function class Class I") and v.time == pytest.approx(b.t[first_k[v.run]])


def test_roundoff_is_flagged_only_when_it_reaches_the_radius() -> None:
    from nlobs.papers.khajenejad_yong import containment_study

    ex = example_61("II")
    d = design_setvalued(ex.system)
    grow = lambda t: (50 * t**2 + 20 * np.exp(t))[:, None]  # noqa: E731
    short = containment_study(ex, d, runs=5, steps=300, unknown_input=grow)
    assert short.roundoff_runs == 0 and short.roundoff_ratio < 1e-6 and short.guarantee_held
    long = containment_study(ex, d, runs=5, steps=4000, unknown_input=grow)
    assert long.roundoff_runs == 5 and long.max_abs_input > 1e18 and not long.guarantee_held
    assert long.class_violated_in_runs == 0
    assert short.coverage.covers_run and long.coverage.covered_runs == 0
    assert {v.hypothesis for v in long.coverage.violations} == {"floating-point round-off within 0.01 × the radius δˣ_k"}
    assert long.likely_causes() == [c for c in long.likely_causes() if "round-off" in c] != []


# --------------------------------------------------------------------------- 7. non-finite input


def test_estimate_lipschitz_refuses_a_nan_phi() -> None:
    from nlobs.errors import NonFiniteError
    from nlobs.systems.discrete_ui import estimate_lipschitz

    with pytest.raises(NonFiniteError, match="phi: not finite at x"):
        estimate_lipschitz(lambda x: np.sqrt(x), [-1.0, -1.0], [1.0, 1.0], n_pairs=100)


def test_plant_overflow_is_a_typed_error_naming_the_step() -> None:
    from nlobs.errors import SimulationDiverged
    from nlobs.simulate.setvalued import simulate_batch

    s = _cubic()
    with pytest.raises(SimulationDiverged, match="the plant overflowed at step 17"):
        simulate_batch(s, design_setvalued(s), lambda t: (3 + 0.1 * t)[:, None], runs=3, steps=40)


# --------------------------------------------------------------------------- 6. Class 0 linear members


def test_quadratic_constraint_with_positive_gamma_is_empty() -> None:
    from nlobs.systems.discrete_ui import QuadraticConstraint

    with pytest.raises(InvalidArgumentError, match="gamma > 0 is empty"):
        QuadraticConstraint(Lipschitz(1.0, 2).multiplier()[0], 0.1)


def _qcstar_M(K: np.ndarray) -> np.ndarray:
    """``−‖Δφ − KΔx‖² ≥ 0`` as a Class 0 multiplier: M22 = −KᵀK is not ⪰ 0, so K = 0 is not in the class."""
    return np.block([[-np.eye(2), K], [K.T, -K.T @ K]])


def test_class_0_member_k_star_is_found_and_used_by_the_structural_check() -> None:
    from nlobs.errors import AssumptionViolated
    from nlobs.systems.discrete_ui import QuadraticConstraint

    K = np.diag([1.0, 0.0])
    fc = QuadraticConstraint(_qcstar_M(K), 0.0)
    members = fc.linear_members()
    assert len(members) == 1 and np.allclose(members[0], K)  # found although M22 = -KᵀK is not ⪰ 0
    # Sec. 6.2's (A, G, C) has the invariant zero -1.343; with φ = K x the plant is (A + K) x, zero -0.343.
    # K = 0 is not in this class, so the zero of (A, G, C) says nothing (no "no stable observer" verdict)
    A = np.array([[-0.42, 1.0], [-0.6, 0.0]])
    s = DiscreteUISystem(A, [[1.0], [-0.65]], [[0.0, 1.0]], phi=lambda x: x @ K.T, function_class=fc, eta_w=0.2,
                         eta_v=0.1, delta0=0.5, time=Discrete(1.0))
    try:
        d = design_setvalued(s)
    except AssumptionViolated as exc:  # pragma: no cover - a false verdict from the zero of (A, G, C)
        pytest.fail(f"false 'no stable observer' verdict: {exc}")
    assert len(d.spectral_radii) == 1 and d.spectral_radii[0] < 1


def test_class_0_without_a_known_member_refuses_hinf_and_checks_no_member() -> None:
    from nlobs.linear.transform_ui import structural_check
    from nlobs.systems.discrete_ui import QuadraticConstraint

    M = np.zeros((4, 4))
    M[:2, :2] = np.eye(2)  # M11 = +I: no K* = -M11⁻¹M12
    M[2:, 2:] = np.diag([1.0, -1.0])  # M22 indefinite: K = 0 is not in the class
    fc = QuadraticConstraint(M, 0.0)
    assert fc.linear_members() == ()
    s = DiscreteUISystem(np.array([[0.5, 0.1], [0.0, 0.4]]), [[1.0], [0.0]], [[1.0, 0.0], [0.0, 1.0]],
                         function_class=fc, eta_w=0.01, eta_v=0.01, delta0=0.5, time=Discrete(1.0))
    st = structural_check(s.A, s.G, s.C, s.H, members=fc.linear_members())
    assert st.exists and st.strongly_detectable == () and "not checked" in st.summary()
    with pytest.raises(InvalidArgumentError, match="'hinf' needs a known linear member"):
        design_setvalued(s, objective="hinf")


# --------------------------------------------------------------------------- 8. the other λ candidates


def test_a_failed_verification_at_the_chosen_lambda_falls_back_to_the_next_candidate(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    import nlobs.synthesis.setvalued as sv
    from nlobs.synthesis.certificate import Check, CheckKind

    s = example_61("II").system
    first = design_setvalued(s)
    real = sv._verify

    def fails_at_first(system, dyn, P, L, kappa, lam, q, theta, rho):  # type: ignore[no-untyped-def]
        checks, *rest = real(system, dyn, P, L, kappa, lam, q, theta, rho)
        if lam == first.lam:  # pretend the solver's answer at the chosen λ misses (⋆)
            checks = [*checks, Check.compare("injected failure", 1.0, 0.0, kind=CheckKind.LMI, strict=False)]
        return (checks, *rest)

    monkeypatch.setattr(sv, "_verify", fails_at_first)
    second = design_setvalued(s)  # no CertificateError: the next solved λ is verified
    assert second.verified and second.lam != first.lam
    assert second.steady_radius >= first.steady_radius * (1 - 1e-3)  # the next in cost order


# --------------------------------------------------------------------------- 10. one read-only helper


def test_one_readonly_helper_for_the_setvalued_modules() -> None:
    import importlib

    from nlobs._validate import readonly

    a = [[1, 2], [3, 4]]
    r = readonly(a)
    assert r.dtype == np.float64 and not r.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        r[0, 0] = 5.0
    for mod in ("nlobs.systems.discrete_ui", "nlobs.linear.transform_ui", "nlobs.synthesis.setvalued",
                "nlobs.papers.khajenejad_yong_printed", "nlobs.observers.setvalued", "nlobs.observers.lipschitz", "nlobs.observers.kalman"):
        m = importlib.import_module(mod)
        assert not hasattr(m, "_ro") and m.readonly is readonly
