"""Monte Carlo containment of the truth in the balls of Algorithm 1 (Khajenejad & Yong), sound vs printed bounds.

Every study draws 1000 seeded runs with noises in their balls, half of them exactly at the bound.
The sound radii must contain the true state and unknown input at every step in 100 % of runs;
the rates of the printed Theorem 5.13 bounds are printed (run with ``-s``), not asserted.
"""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError
from nlobs.observers.setvalued import GivenGain
from nlobs.papers.khajenejad_yong import PaperExample, containment_study, example_61, example_62
from nlobs.papers.khajenejad_yong_printed import printed_radii
from nlobs.simulate.setvalued import input_containment, radii_of, run_setvalued, state_containment
from nlobs.synthesis.setvalued import design_setvalued
from nlobs.systems.discrete_ui import DiscreteUISystem, Lipschitz
from nlobs.systems.timebase import Discrete

RUNS = 1000


@pytest.fixture(scope="module")
def ex61() -> tuple[PaperExample, object]:
    ex = example_61("II")
    return ex, design_setvalued(ex.system)


def test_example_61_sound_balls_contain_state_and_input(ex61) -> None:  # type: ignore[no-untyped-def]
    ex, design = ex61
    res = containment_study(ex, design, runs=RUNS, steps=300, seed=0)
    print(f"\n6.1 class II sound: {res}")
    assert res.rate_state == 1.0 and res.rate_input == 1.0
    assert res.first_violation_step is None
    # not vacuous: the initial states on the sphere touch the initial ball, later errors are a visible fraction
    assert res.max_error_over_radius == pytest.approx(1.0, abs=1e-9)
    assert np.max(res.errors[:, 1:] / res.radii.state[1:]) > 0.1
    assert np.isfinite(res.final_radius_state) and res.final_radius_state <= design.steady_radius * (1 + 1e-9)


def test_example_61_printed_gains_and_bounds_are_reported(ex61) -> None:  # type: ignore[no-untyped-def]
    ex, design = ex61
    for cls in ("0", "I", "II"):
        e = example_61(cls)
        pr = e.printed
        gain = GivenGain.for_system(e.system, pr["L_tilde"])
        Acl, _, _ = design.dynamics.split(gain.gain)
        srad = float(np.max(np.abs(np.linalg.eigvals(Acl))))
        kw = {"L_f": pr["L_f"]} if "L_f" in pr else {"A_aux": e.system.A}
        with np.errstate(over="ignore"):
            rad = printed_radii(e.system, pr["L_tilde"], pr["P"], pr["rho"], 300, **kw)
            res = containment_study(e, gain, runs=RUNS, steps=300, seed=0, radii=rad, label="printed")
        print(f"\n6.1 class {cls} printed gain: spectral radius {srad:.4g}; printed-bound containment "
              f"{res.rate_state:.3f} (state) {res.rate_input:.3f} (input); final printed radius {res.final_radius_state:.3g}")
        assert srad > 1  # measured independently: the printed L~ destabilise the error dynamics (16)


def test_unbounded_unknown_input_does_not_break_containment(ex61) -> None:  # type: ignore[no-untyped-def]
    ex, design = ex61
    res = containment_study(ex, design, runs=RUNS, steps=300, seed=5,
                            unknown_input=lambda t: (50.0 * t**2 + 20.0 * np.exp(t))[:, None])
    assert res.rate_state == 1.0 and res.rate_input == 1.0
    assert res.errors[:, -1].max() <= res.final_radius_state


def _w_dominated() -> PaperExample:
    """H = 0 (so Ψ = 0) and an unmeasured state: the printed η = ‖ℜ‖η_v + ‖ΨΦW‖η_w drops the process noise."""
    A = np.array([[0.2, 0.1, 0.0], [0.0, 0.3, 0.1], [0.1, 0.0, 0.2]])
    s = DiscreteUISystem(A, np.array([[1.0], [0.0], [0.5]]), np.array([[1.0, 0, 0], [0, 1.0, 0]]),
                         phi=lambda x: 0.1 * np.sin(x), function_class=Lipschitz(0.1, 3), eta_w=0.5, eta_v=0.01,
                         delta0=0.2, time=Discrete(1.0))
    return PaperExample(s, {}, lambda t: (10 * np.sin(t) + t)[:, None], "w-dominated")


def test_printed_eta_omits_the_process_noise_term() -> None:
    ex = _w_dominated()
    design = design_setvalued(ex.system, objective="hinf")
    sound = containment_study(ex, design, runs=RUNS, steps=60, seed=2)
    assert sound.rate_state == 1.0 and sound.rate_input == 1.0
    assert np.max(sound.errors[:, 1:] / sound.radii.state[1:]) > 0.8  # the sound radius is also tight here
    Lf = float(np.linalg.norm(ex.system.A, 2)) + 0.1  # the class on the whole f, as in the paper
    rad = printed_radii(ex.system, design.gain, design.P, design.rho, 60, L_f=Lf)
    printed = containment_study(ex, design, runs=RUNS, steps=60, seed=2, radii=rad, label="printed")
    print(f"\nw-dominated: sound {sound.rate_state:.3f}/{sound.rate_input:.3f} (final radius "
          f"{sound.final_radius_state:.3g}); printed {printed.rate_state:.3f}/{printed.rate_input:.3f} (final radius "
          f"{printed.final_radius_state:.3g}, first violation at step {printed.first_violation_step})")
    # the defect docs/setvalued.md Sec. 7 reports: the printed Theorem 5.13 bounds miss the truth (0.000 / 0.964)
    assert printed.rate_state < 1 and printed.rate_state == 0.0 and printed.first_violation_step == 1


def test_example_62_error_grows_for_every_gain() -> None:
    """Evidence that 6.2 as printed admits no stable observer: noise-free, |x̃₁,k| ≥ 1.343 |x̃₁,k−1| for any L̃."""
    ex = example_62()
    s = ex.system
    rng = np.random.default_rng(7)
    K, B = 12, 50
    x0 = rng.uniform(-0.5, 0.5, (B, 2))
    t = np.arange(K + 1.0)
    d = np.broadcast_to(ex.unknown_input(t)[None], (B, K + 1, 1))
    x, y = s.simulate(x0, d, np.zeros((B, K, 2)), np.zeros((B, K + 1, 1)))
    for Lt in (ex.printed["L_tilde"], [0.0, 0.0], rng.normal(size=2) * 3):
        run = run_setvalued(s, GivenGain.for_system(s, np.reshape(Lt, (2, 1))[:, :1] if np.size(Lt) == 2 else Lt), y)
        e1 = np.abs(x[..., 0] - run.x_hat[..., 0])
        grow = e1[:, 2:] / np.maximum(e1[:, 1:-1], 1e-300)
        assert np.all(grow[e1[:, 1:-1] > 1e-12] >= 0.42 + 0.6 / 0.65 - 1e-9)


def test_example_61_structured_class_0_multiplier() -> None:
    """A Class 0 multiplier that uses φ's structure (not the paper's) is valid and gives a certified design."""
    from nlobs.systems.discrete_ui import check_function_class

    ex = example_61("0-structured")
    assert check_function_class(ex.system.phi, ex.system.function_class, -5 * np.ones(4), 5 * np.ones(4)).passed
    design = design_setvalued(ex.system)
    res = containment_study(ex, design, runs=RUNS, steps=300, seed=3)
    print(f"\n6.1 structured class 0: λ = {design.lam:.5g}, κ = {design.kappa:.4g}, steady radius "
          f"{design.steady_radius:.4g}; {res}")
    assert res.rate_state == 1.0 and res.rate_input == 1.0


def test_adversarial_noise_at_the_bound_stays_inside(ex61) -> None:  # type: ignore[no-untyped-def]
    """Noise chosen at its bound to maximise the error at step K: the sound ball still contains it."""
    from nlobs.papers.khajenejad_yong import adversarial_noise
    from nlobs.observers.setvalued import sound_radii

    ex, design = ex61
    s = ex.system
    K = 300
    w, v, lower = adversarial_noise(s, design, K, restarts=5)
    assert np.all(np.linalg.norm(w, axis=-1) <= s.eta_w * (1 + 1e-12))
    assert np.all(np.linalg.norm(v, axis=-1) <= s.eta_v * (1 + 1e-12))
    rad = sound_radii(s, design, K)
    t = np.arange(K + 1) * s.time.dt
    x0 = s.x0[None] + np.zeros((1, 4))
    d = ex.unknown_input(t)[None]
    x, y = s.simulate(x0, d, w[None], v[None])
    run = run_setvalued(s, design, y)
    err = np.linalg.norm(x - run.x_hat, axis=-1)[0]
    print(f"\nadversarial noise: error at K = {err[-1]:.4g} (linear-member value {lower:.4g}), "
          f"sound radius {rad.state[-1]:.4g}")
    assert np.all(err <= rad.state * (1 + 1e-9))
    assert err[-1] > 0.5 * rad.state[-1]  # the radius is within a factor 2 of an attained error


def test_growing_unknown_input_breaks_a_naive_point_observer_but_not_the_set_observer(ex61) -> None:  # type: ignore[no-untyped-def]
    """Sec. 6.2's claim on Example 6.1: with d growing without bound the set-valued observer stays bounded."""
    from nlobs.papers.khajenejad_yong import naive_point_observer
    from nlobs.simulate.setvalued import ball_samples

    ex, design = ex61
    s = ex.system
    K, B = 300, 200
    rng = np.random.default_rng(11)
    t = np.arange(K + 1) * s.time.dt
    d = np.broadcast_to((50.0 * t**2)[None, :, None], (B, K + 1, 1))
    x0 = ball_samples(rng, (B,), s.delta0, 4)
    x, y = s.simulate(x0, d, ball_samples(rng, (B, K), s.eta_w, 4), ball_samples(rng, (B, K + 1), s.eta_v, 2))
    run = run_setvalued(s, design, y)
    assert state_containment(run, x).all() and input_containment(run, d[:, :-1]).all()
    # a stable gain for (A, C) (the d-free part), from the set design's L~ through z2 = U2ᵀ y
    L = design.gain @ design.transform.T2
    assert np.max(np.abs(np.linalg.eigvals((np.eye(4) - L @ s.C) @ s.A))) < 1
    xn = naive_point_observer(s, L, y)
    en = np.linalg.norm(x - xn, axis=-1)
    es = np.linalg.norm(x - run.x_hat, axis=-1)
    print(f"\ngrowing d: naive point observer max error at K {en[:, -1].max():.4g}, set observer {es[:, -1].max():.4g} "
          f"(radius {radii_of(run).state[-1]:.4g})")
    assert en[:, -1].min() > 3 * radii_of(run).state[-1]


def test_lpv_with_run_time_weights_is_contained() -> None:
    """Class III end to end: vertex design, plant and observer driven by the same random weights."""
    from nlobs.simulate.setvalued import ball_samples
    from nlobs.systems.discrete_ui import LPV

    A = np.array([[0.5, 0.2, 0.0], [0.0, 0.4, 0.3], [0.1, 0.0, 0.6]])
    Ai = (np.diag([0.3, 0.0, 0.0]), np.diag([0.0, 0.0, -0.3]), np.zeros((3, 3)))
    s = DiscreteUISystem(A, [[1.0], [0.0], [0.5]], [[1.0, 0, 0], [0, 0, 1.0]], [[0.0], [0.2]],
                         function_class=LPV(Ai), eta_w=0.05, eta_v=0.02, delta0=1.0, time=Discrete(1.0))
    design = design_setvalued(s)
    rng = np.random.default_rng(21)
    B, K = RUNS, 80
    lam = rng.dirichlet(np.ones(3), size=(B, K + 1))
    lam[: B // 2] = np.eye(3)[rng.integers(0, 3, size=(B // 2, K + 1))]  # half the runs switch between vertices
    d = np.broadcast_to((5 * np.sin(0.2 * np.arange(K + 1)) + 0.1 * np.arange(K + 1))[None, :, None], (B, K + 1, 1))
    x, y = s.simulate(ball_samples(rng, (B,), 1.0, 3), d, ball_samples(rng, (B, K), 0.05, 3),
                      ball_samples(rng, (B, K + 1), 0.02, 2), weights=lam)
    run = run_setvalued(s, design, y, weights=lam)
    assert state_containment(run, x).all() and input_containment(run, d[:, :-1]).all()
    with pytest.raises(InvalidArgumentError, match="sum to 1"):
        run_setvalued(s, design, y, weights=lam * 2)
