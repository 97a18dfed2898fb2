"""Algorithm 1 of Khajenejad & Yong as generated C: the compiled observer equals the Python one (centres, input
estimates and radii) on noisy runs of the shipped models, the truth stays in its balls, the C compiles strictly."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError, SimulationDiverged
from nlobs.export import compile_observer, generate, render
from nlobs.export.compiler import compile_object
from nlobs.observers.setvalued import GivenGain, SetValuedObserver
from nlobs.papers.khajenejad_yong import example_61, example_62
from nlobs.papers.khajenejad_yong_printed import printed_radii
from nlobs.simulate import run_observer
from nlobs.simulate.setvalued import ball_samples, state_containment
from nlobs.systems.modelfile import load_discrete_ui_model
from nlobs.workflows.setvalued import design_setvalued_observer

RUNS = 5
RTOL = 1e-12


def _runs(model, steps: int, seed: int):  # type: ignore[no-untyped-def]
    """Noisy runs of the plant (8) as :func:`nlobs.simulate.setvalued.simulate_batch` draws them."""
    s = model.system
    rng = np.random.default_rng(seed)
    x0 = s.x0 + ball_samples(rng, (RUNS,), s.delta0, s.n)
    t = np.arange(steps + 1) * s.time.dt
    d = np.broadcast_to(model.signals["bounded"](t)[None], (RUNS, steps + 1, s.p))
    x, y = s.simulate(x0, d, ball_samples(rng, (RUNS, steps), s.eta_w, s.n_w),
                      ball_samples(rng, (RUNS, steps + 1), s.eta_v, s.l))
    return t, x, y


@pytest.fixture(scope="module")
def case61():  # type: ignore[no-untyped-def]
    """6.1 from the shipped file, designed as ``nlobs design setvalued`` does (the sound radius recursion)."""
    m = load_discrete_ui_model("khajenejad-6-1")
    design = design_setvalued_observer(m, samples=2000).design
    obs = SetValuedObserver(m.system, design)
    t, x, y = _runs(m, 300, 0)
    return m, obs, t, x, y


@pytest.fixture(scope="module")
def case62():  # type: ignore[no-untyped-def]
    """6.2 from the shipped file: no observer of the structure exists, so the paper's printed gain and bounds."""
    m = load_discrete_ui_model("khajenejad-6-2")
    s, pr = m.system, example_62().printed
    steps = 40
    gain = GivenGain.for_system(s, np.reshape(pr["L_tilde"], (2, 1)))
    radii = printed_radii(s, gain.gain, pr["P"], pr["rho"], steps, L_f=pr["L_f"])
    obs = SetValuedObserver(s, gain, radii=radii)
    t, x, y = _runs(m, steps, 1)
    return m, obs, t, x, y


def _close(a: np.ndarray, b: np.ndarray, what: str) -> None:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape, what
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=what)
    fa, fb = np.nan_to_num(a), np.nan_to_num(b)
    assert np.linalg.norm(fa - fb) <= RTOL * np.linalg.norm(fa), f"{what}: {np.linalg.norm(fa - fb):.3g}"


def _compare(obs, t, x, y):  # type: ignore[no-untyped-def]
    s = obs.system
    xh0 = np.broadcast_to(s.x0, (RUNS, s.n))
    py = run_observer(obs, t, x_hat0=xh0, y=y, truth=x)
    co = compile_observer(obs)
    cc = run_observer(co, t, x_hat0=xh0, y=y, truth=x)
    _close(cc.x_hat, py.x_hat, "centres")
    for key in ("d_hat", "radius_state", "radius_input"):
        _close(cc.extras[key], py.extras[key], key)
    one = co.run_record(t, s.x0, y=y[0])
    _close(one, py.x_hat[0], "run_record")
    return py, cc


@pytest.mark.parametrize("name", ["case61", "case62"])
def test_compiled_equals_python_along_noisy_runs(name: str, request: pytest.FixtureRequest) -> None:
    m, obs, t, x, y = request.getfixturevalue(name)
    py, cc = _compare(obs, t, x, y)
    assert np.isfinite(cc.extras["radius_state"]).all()
    assert np.isnan(cc.extras["radius_input"][0]) and np.isfinite(cc.extras["radius_input"][1:]).all()


def _inside(res, radius):  # type: ignore[no-untyped-def]
    e = np.linalg.norm(res.x - res.x_hat, axis=-1)
    return e <= radius * (1 + 1e-9) + 1e-9


def test_61_sound_balls_contain_the_truth_in_the_compiled_run(case61) -> None:  # type: ignore[no-untyped-def]
    m, obs, t, x, y = case61
    s = obs.system
    cc = run_observer(compile_observer(obs), t, x_hat0=np.broadcast_to(s.x0, (RUNS, s.n)), y=y, truth=x)
    inside = _inside(cc, cc.extras["radius_state"])
    assert inside.shape == (RUNS, t.size) and inside.all()
    # not vacuous: the errors reach a visible fraction of the radii
    assert np.max(np.linalg.norm(x - cc.x_hat, axis=-1)[:, 1:] / cc.extras["radius_state"][1:]) > 0.1


def test_62_printed_containment_is_the_python_one(case62) -> None:  # type: ignore[no-untyped-def]
    m, obs, t, x, y = case62
    s = obs.system
    xh0 = np.broadcast_to(s.x0, (RUNS, s.n))
    py = run_observer(obs, t, x_hat0=xh0, y=y, truth=x)
    cc = run_observer(compile_observer(obs), t, x_hat0=xh0, y=y, truth=x)
    np.testing.assert_array_equal(_inside(cc, cc.extras["radius_state"]), _inside(py, py.extras["radius_state"]))


def test_run_setvalued_containment_helper_reads_the_compiled_run(case61) -> None:  # type: ignore[no-untyped-def]
    import dataclasses

    m, obs, t, x, y = case61
    s = obs.system
    cc = run_observer(compile_observer(obs), t, x_hat0=np.broadcast_to(s.x0, (RUNS, s.n)), y=y, truth=x)
    assert state_containment(dataclasses.replace(cc, extras=dict(cc.extras))).all()


def test_given_gain_without_radii(case62) -> None:  # type: ignore[no-untyped-def]
    m, obs, t, x, y = case62
    bare = SetValuedObserver(obs.system, obs.design)
    py, cc = _compare(bare, t, x, y)
    assert np.isnan(cc.extras["radius_state"]).all() and np.isnan(cc.extras["radius_input"]).all()


def test_codec_round_trip(case61) -> None:  # type: ignore[no-untyped-def]
    m, obs, t, x, y = case61
    codec = generate(obs, "sv").codec
    z = obs.init(np.zeros((3, obs.n_x)))
    z = obs.correct(0.0, z, np.zeros((3, 0)), y[:3, 0], np.ones(2, bool))
    for _ in range(2):
        z = obs.rhs(0.0, z, np.zeros((3, 0)), y[:3, 0])
        z = obs.correct(0.0, z, np.zeros((3, 0)), y[:3, 1], np.ones(2, bool))
    for state in (obs.init(np.zeros((3, obs.n_x))), z):
        back = codec.unpack(codec.pack(state))
        for f in ("x", "d1", "d"):
            np.testing.assert_array_equal(getattr(back, f), getattr(state, f))
        for f in ("k", "corrected", "radius", "radius_input", "V"):
            a, b = getattr(back, f), getattr(state, f)
            assert a == b or (np.isnan(a) and np.isnan(b)), f


@pytest.mark.parametrize("name", ["case61", "case62"])
def test_strict_compilation(name: str, request: pytest.FixtureRequest) -> None:
    m, obs, t, x, y = request.getfixturevalue(name)
    for o in (obs, SetValuedObserver(obs.system, obs.design)):
        program = generate(o, "nlobs_sv")
        header, source = render(program, "test")
        compile_object(source, strict=True, headers={program.header_name: header})
        assert program.correcting and program.discrete and program.n_z == obs.n_x + \
            obs.design.transform.M1.shape[0] + obs.system.p + 9


def test_missing_sample_is_a_divergence_in_c(case61) -> None:  # type: ignore[no-untyped-def]
    m, obs, t, x, y = case61
    bad = np.array(y[:, :20])
    bad[1, 10, 0] = np.nan
    with pytest.raises(SimulationDiverged):
        run_observer(compile_observer(obs), t[:20], x_hat0=np.broadcast_to(obs.system.x0, (RUNS, obs.n_x)), y=bad)


def test_unexported_configurations_say_why() -> None:
    from nlobs.systems.discrete_ui import LPV, DiscreteUISystem
    from nlobs.systems.timebase import Discrete

    ex = example_61("II")  # the paper's system: phi is a Python function, no expressions to print
    with pytest.raises(InvalidArgumentError, match="phi"):
        generate(SetValuedObserver(ex.system, GivenGain.for_system(ex.system, np.zeros((4, 1)))), "sv")
    lpv = DiscreteUISystem(np.zeros((2, 2)), np.array([[1.0], [0.0]]), np.array([[0.0, 1.0], [1.0, 0.0]]),
                           function_class=LPV((0.1 * np.eye(2), -0.1 * np.eye(2))), time=Discrete(1.0))
    obs = SetValuedObserver(lpv, GivenGain.for_system(lpv, np.zeros((2, 2))), lpv_weights=True)
    with pytest.raises(InvalidArgumentError, match="LPV"):
        generate(obs, "sv")


def test_infinite_given_radii_are_values_not_overflow(case62) -> None:  # type: ignore[no-untyped-def]
    """A bound that does not converge (a printed one) is +inf: the C carries it, the run goes on."""
    from nlobs.observers.setvalued import Radii

    m, obs, t, x, y = case62
    K = t.size - 1
    state = np.where(np.arange(K + 1) > K // 2, np.inf, np.linspace(0.5, 3.0, K + 1))
    state[3] = np.nan
    radii = Radii(state, np.where(np.arange(K) > K // 3, np.inf, 1.0), np.inf, np.inf, "printed")
    o = SetValuedObserver(obs.system, obs.design, radii=radii)
    xh0 = np.broadcast_to(o.system.x0, (RUNS, o.n_x))
    py = run_observer(o, t, x_hat0=xh0, y=y)
    cc = run_observer(compile_observer(o), t, x_hat0=xh0, y=y)
    np.testing.assert_array_equal(cc.extras["radius_state"], py.extras["radius_state"])
    np.testing.assert_array_equal(cc.extras["radius_input"], py.extras["radius_input"])
    _close(cc.x_hat, py.x_hat, "centres")
