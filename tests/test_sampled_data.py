"""Sampled outputs: the inter-sample output predictor, the sampling budget and the mean-square bound.

Independent sources: the exact one-period map of a linear error system with the predictor (a matrix
exponential, SciPy), closed forms of scalar systems, and Monte Carlo simulation.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sl

from nlobs.errors import InvalidArgumentError, NonFiniteError
from nlobs.geometry.jacobian_box import MARGIN, jacobian_box
from nlobs.geometry.region import Box
from nlobs.observers import LuenbergerObserver, OutputPredictor
from nlobs.simulate import simulate
from nlobs.simulate.sampling import MeasurementGroup
from nlobs.synthesis.sampled_data import GroupNoise, sampled_data_bound, verify_sampled_data_bound
from nlobs.synthesis.thau_gain import certified_decay, certify_thau_gain, design_thau_gain, verify_thau_gain
from nlobs.systems import LinearSystem

A = np.array([[0.0, 1.0], [-2.0, -0.3]])
B = np.array([[0.0], [1.0]])
C = np.array([[1.0, 0.0]])
L = np.array([[6.0], [20.0]])


def _one_period(A_: np.ndarray, C_: np.ndarray, L_: np.ndarray, T: float) -> np.ndarray:
    """``e(t_k + T) = M e(t_k)`` for the predictor: ``ė = (A − LC)e + Lδ``, ``δ̇ = CAe``, ``δ(t_k) = 0``."""
    n, p = A_.shape[0], C_.shape[0]
    big = np.block([[A_ - L_ @ C_, L_], [C_ @ A_, np.zeros((p, p))]])
    return sl.expm(big * T)[:n, :n]


def _exact_limit(A_: np.ndarray, C_: np.ndarray, L_: np.ndarray) -> float:
    """The first period at which the exact one-period map stops contracting (a fine scan)."""
    for T in np.linspace(1e-3, 5.0, 5000):
        if max(abs(np.linalg.eigvals(_one_period(A_, C_, L_, T)))) >= 1:
            return float(T)
    return math.inf


def _lyapunov_bound(A_: np.ndarray, C_: np.ndarray, L_: np.ndarray, T: float, R: float = 0.0,
                    process: np.ndarray | None = None, p0: np.ndarray | None = None):
    Acl = A_ - L_ @ C_
    P = sl.solve_continuous_lyapunov(Acl.T, -np.eye(A_.shape[0]))
    alpha = certified_decay(P, L_, [(A_, C_)])
    w, V = np.linalg.eigh(P)
    ell = float(np.linalg.norm(C_ @ A_ @ (V / np.sqrt(w)) @ V.T, 2))
    q = 0.0
    if process is not None:
        S = (V * np.sqrt(w)) @ V.T
        q = float(np.linalg.norm(S @ L_ @ C_ @ np.sqrt(process), "fro") ** 2)
    g = GroupNoise("s", (0,), T, np.array([[R]]), ell, q)
    return sampled_data_bound(P, L_, alpha, [g], process=process, p0=p0)


# ------------------------------------------------------------------ the predictor
def test_the_predictor_converges_where_the_held_sample_leaves_an_error_of_order_T() -> None:
    sys_ = LinearSystem(A, B, C)
    obs = LuenbergerObserver(sys_, L)
    u = lambda t: np.array([np.sin(t)])  # noqa: E731
    out = {}
    for T in (0.05, 0.2):
        group = MeasurementGroup("s", outputs=[0], rate=1 / T, noise_std=0.0)
        for name, o in (("hold", obs), ("predictor", OutputPredictor(obs, sys_))):
            r = simulate(sys_, o, np.array([1.0, 0.0]), np.zeros(2), duration=10.0, dt=0.005, u=u,
                         measurements=[group])
            out[name, T] = float(np.abs(r.x_hat - r.x)[-200:].max())
    assert out["predictor", 0.05] < 1e-8 and out["predictor", 0.2] < 1e-5
    assert out["hold", 0.05] > 1e-2 and out["hold", 0.2] > 3 * out["hold", 0.05]  # grows with T


def test_the_predictor_contracts_by_the_exact_one_period_map() -> None:
    """Noise-free, no input: the error at the samples follows e_{k+1} = M(T) e_k, M from a matrix exponential."""
    sys_ = LinearSystem(A, B, C)
    T, dt = 0.2, 0.001
    r = simulate(sys_, OutputPredictor(LuenbergerObserver(sys_, L), sys_), np.array([1.0, -0.5]), np.zeros(2),
                 duration=1.0, dt=dt, u=np.zeros(1), measurements=[MeasurementGroup("s", outputs=[0], rate=1 / T, noise_std=0.0)])
    e = r.x_hat - r.x
    k = int(round(T / dt))
    M = _one_period(A, C, L, T)
    for j in range(4):
        assert np.allclose(e[(j + 1) * k], M @ e[j * k], rtol=1e-7, atol=1e-10)


def test_a_missing_sample_keeps_the_prediction_running() -> None:
    sys_ = LinearSystem(A, B, C)
    pred = OutputPredictor(LuenbergerObserver(sys_, L), sys_)
    z = pred.init(np.array([[0.3, 0.1]]))
    z1 = pred.correct(0.0, z, np.zeros((1, 1)), np.array([[np.nan]]), np.array([True]))
    assert np.array_equal(z1, z)
    z2 = pred.correct(0.0, z, np.zeros((1, 1)), np.array([[0.7]]), np.array([True]))
    assert z2[0, -1] == 0.7 and np.array_equal(z2[0, :2], z[0, :2])


def test_the_predictor_refuses_a_filter_and_a_discrete_observer() -> None:
    from nlobs.observers import EKF

    sys_ = LinearSystem(A, B, C)
    with pytest.raises(InvalidArgumentError, match="corrects at samples"):
        OutputPredictor(EKF(sys_, Q=np.eye(2), R=np.eye(1), P0=np.eye(2)), sys_)
    from nlobs.systems import Discrete

    disc = LinearSystem(np.eye(2) * 0.5, B, C, time=Discrete(0.1))
    with pytest.raises(InvalidArgumentError, match="discrete"):
        OutputPredictor(LuenbergerObserver(disc, np.array([[0.1], [0.1]])), disc)


# ------------------------------------------------------------------ the sampling budget
@pytest.mark.parametrize("seed", range(6))
def test_t_max_is_below_the_exact_limit_of_the_one_period_map(seed: int) -> None:
    """The certificate is sufficient: at T_max the exact sampled error system still contracts."""
    rng = np.random.default_rng(seed)
    n = 3
    A_ = rng.normal(size=(n, n))
    C_ = rng.normal(size=(1, n))
    poles = -rng.uniform(0.5, 3.0, n)
    import scipy.signal as ss

    L_ = ss.place_poles(A_.T, C_.T, poles).gain_matrix.T
    b = _lyapunov_bound(A_, C_, L_, 0.0)
    t_max = b.t_max[0]
    assert 0 < t_max < _exact_limit(A_, C_, L_)
    assert max(abs(np.linalg.eigvals(_one_period(A_, C_, L_, t_max)))) < 1


def test_the_budget_decides_and_says_by_how_much() -> None:
    ok = _lyapunov_bound(A, C, L, 0.005)
    assert ok.verified and ok.budget == pytest.approx(0.005 / ok.t_max[0])
    bad = _lyapunov_bound(A, C, L, 0.05)
    assert not bad.verified and bad.budget > 1
    assert bad.violation() == f"s: T = 0.05 > T_max = {bad.t_max[0]:.4g}"
    assert math.isinf(bad.rms_bound())


def test_multi_rate_groups_share_the_budget() -> None:
    P, K = np.eye(2), np.eye(2)
    g1 = GroupNoise("fast", (0,), 0.01, np.zeros((1, 1)), 1.0)
    g2 = GroupNoise("slow", (1,), 0.2, np.zeros((1, 1)), 1.0)
    b = sampled_data_bound(P, K, 1.0, [g1, g2])
    assert b.t_max == (1.0, 1.0) and b.budget == pytest.approx(0.21) and b.verified
    b2 = sampled_data_bound(P, K, 1.0, [g1, GroupNoise("slow", (1,), 0.995, np.zeros((1, 1)), 1.0)])
    assert not b2.verified and "budget" in b2.violation() and "slow" in b2.violation()


def test_verify_recomputes_every_number_and_catches_a_tampered_matrix() -> None:
    b = _lyapunov_bound(A, C, L, 0.005, R=1e-4, process=np.diag([0.0, 1e-3]), p0=np.eye(2) * 0.01)
    v = verify_sampled_data_bound(b)
    for name in ("budget", "a", "sigma", "N", "lam_min", "v0"):
        assert getattr(v, name) == pytest.approx(getattr(b, name), rel=1e-12)
    import dataclasses

    tampered = verify_sampled_data_bound(dataclasses.replace(b, P=b.P * np.array([[1.0, 0.0], [0.0, -1.0]])))
    assert not tampered.verified and any(c.name == "P ≻ 0" for c in tampered.failed_checks)


def test_the_mean_square_bound_holds_in_simulation() -> None:
    """Noisy samples and process noise: the measured RMS after settling stays below the certified bound."""
    sys_ = LinearSystem(A, B, C)
    T, std, q = 0.005, 0.01, 1e-3
    proc = np.diag([0.0, q])
    p0 = np.diag([0.1, 0.1]) ** 2
    b = _lyapunov_bound(A, C, L, T, R=std**2, process=proc, p0=p0)
    assert b.verified
    runs = 40
    rng = np.random.default_rng(3)
    x0 = np.zeros((runs, 2))
    xh0 = x0 + rng.normal(size=(runs, 2)) * 0.1
    r = simulate(sys_, OutputPredictor(LuenbergerObserver(sys_, L), sys_), x0, xh0, duration=6.0, dt=0.001,
                 u=np.zeros(1), measurements=[MeasurementGroup("s", outputs=[0], rate=1 / T, noise_std=std)], process_noise=proc,
                 seed=1)
    e = r.x_hat - r.x
    after = r.t >= 2.0
    rms = math.sqrt(float(np.mean(np.sum(e[:, after] ** 2, axis=-1))))
    bound = b.rms_after(2.0, p0)
    assert 0 < rms < bound
    # and the bound is not vacuous here: within two orders of magnitude
    assert bound < 100 * rms


@pytest.mark.parametrize("bad", [dict(period=-0.1), dict(period=math.nan), dict(ell=math.inf), dict(q=-1.0)])
def test_bad_group_values_are_typed_errors(bad: dict) -> None:
    kw = dict(name="g", index=(0,), period=0.1, R=np.zeros((1, 1)), ell=1.0, q=0.0) | bad
    with pytest.raises(InvalidArgumentError):
        GroupNoise(**kw)


def test_bad_bound_inputs_are_typed_errors() -> None:
    g = GroupNoise("g", (0,), 0.1, np.zeros((1, 1)), 1.0)
    with pytest.raises(InvalidArgumentError, match="alpha"):
        sampled_data_bound(np.eye(1), np.ones((1, 1)), 0.0, [g])
    with pytest.raises(InvalidArgumentError, match="P"):
        sampled_data_bound(np.full((1, 1), np.nan), np.ones((1, 1)), 1.0, [g])
    with pytest.raises(InvalidArgumentError, match="two groups"):
        sampled_data_bound(np.eye(1), np.ones((1, 1)), 1.0, [g, g])


# ------------------------------------------------------------------ the Thau gain and the Jacobian box
def test_certified_decay_of_a_scalar_system_is_its_closed_form() -> None:
    # ė = (a − l c) e: decay l c − a for any P > 0
    assert certified_decay(np.array([[3.0]]), np.array([[5.0]]), [(np.array([[1.0]]), np.array([[2.0]]))]) == \
        pytest.approx(9.0)
    # two vertices: the worst one decides
    v = [(np.array([[1.0]]), np.array([[1.0]])), (np.array([[-1.0]]), np.array([[1.0]]))]
    assert certified_decay(np.eye(1), np.array([[2.0]]), v) == pytest.approx(1.0)


def test_the_vertex_design_is_reverified_and_a_tampered_gain_fails() -> None:
    verts = [(np.array([[0.0, 1.0], [a, -0.2]]), np.array([[1.0, 0.0]])) for a in (-3.0, 1.0)]
    cert = design_thau_gain(verts, 0.5, R=np.eye(1) * 1e-4)
    assert cert.verified and cert.decay >= 0.5 * (1 - 1e-6)
    for A_, C_ in verts:  # every vertex closed loop is Hurwitz with the certified margin
        assert np.max(np.linalg.eigvals(A_ - cert.gain @ C_).real) <= -cert.decay + 1e-9
    import dataclasses

    bad = verify_thau_gain(dataclasses.replace(cert, gain=np.zeros_like(cert.gain)))
    assert not bad.verified and bad.decay < 0
    given = certify_thau_gain(verts, cert.gain, 0.25)
    assert given.verified and given.decay >= 0.25 * (1 - 1e-6)
    with pytest.raises(Exception, match="decay"):
        certify_thau_gain(verts, np.zeros((2, 1)), 0.25)


def test_the_jacobian_box_of_a_sine_and_its_vertices() -> None:
    box = jacobian_box(lambda x, u: np.cos(x)[:, :, None], Box([0.0], [math.pi]), [], [], samples=2000)
    width = 2.0
    assert box.lower[0, 0] == pytest.approx(-1 - MARGIN * width, abs=1e-6)
    assert box.upper[0, 0] == pytest.approx(1 + MARGIN * width, abs=1e-6)
    assert box.varying == ((0, 0),) and box.n_vertices == 2
    assert sorted(float(v[0, 0]) for v in box.vertices()) == [box.lower[0, 0], box.upper[0, 0]]


def test_an_infinite_jacobian_on_the_region_is_a_typed_error() -> None:
    with pytest.raises(NonFiniteError, match="Lipschitz constant there is infinite"):
        jacobian_box(lambda x, u: (0.5 / np.sqrt(x))[:, :, None], Box([0.0], [1.0]), [], [])


# ------------------------------------------------------------------ the clock-dependent certificate
def _clock(T: float, alpha: float, R: float = 0.0, process: np.ndarray | None = None, segments: int = 4):
    from nlobs.synthesis.sampled_clock import ClockGroup, clock_certificate

    g = ClockGroup("s", (0,), T, T, np.array([[R]]), np.zeros(1))
    return clock_certificate([(A - L @ C, C @ A)], L, alpha, [g], process=process, H=[C],
                             p0=np.eye(2) * 0.01, settle=2.0, segments=segments)


def test_the_clock_certificate_reaches_far_longer_periods_than_the_small_gain_bound() -> None:
    small_gain = _lyapunov_bound(A, C, L, 0.0).t_max[0]
    cert = _clock(0.1, 0.5)
    assert cert.verified and cert.t_max == (0.1,)
    assert 0.1 > 5 * small_gain


@pytest.mark.parametrize("T", [0.05, 0.1, 0.2])
def test_a_clock_certificate_for_gaps_up_to_T_implies_every_periodic_sampling_below_T_contracts(T: float) -> None:
    """What it claims (decay for every gap ≤ T) forces ρ(M(T')) ≤ e^{−αT'} for the exact one-period map."""
    cert = _clock(T, 0.1)
    assert cert.verified
    for Tp in np.linspace(T / 20, T, 20):
        rho = max(abs(np.linalg.eigvals(_one_period(A, C, L, Tp))))
        # V decays like e^{-2αt}, |e|² ≤ V ≤ λ_max |e|²: the spectral radius of the map is at most e^{-αT'}
        assert rho <= math.exp(-cert.alpha * Tp) + 1e-9


def test_the_clock_certificate_is_infeasible_where_the_exact_map_expands() -> None:
    from nlobs.errors import DesignInfeasible

    T_bad = next(T for T in np.linspace(0.1, 3, 300) if max(abs(np.linalg.eigvals(_one_period(A, C, L, T)))) > 1)
    with pytest.raises(DesignInfeasible, match="clock-dependent"):
        _clock(float(T_bad), 0.01)


def test_the_clock_certificate_is_reverified_and_a_tampered_one_fails() -> None:
    import dataclasses

    from nlobs.synthesis.sampled_clock import verify_clock_certificate

    cert = _clock(0.1, 0.5, R=1e-4, process=np.diag([0.0, 1e-3]))
    again = verify_clock_certificate(cert)
    assert again.verified and again.c == pytest.approx(cert.c) and again.jumps == pytest.approx(cert.jumps)
    worse = verify_clock_certificate(dataclasses.replace(cert, alpha=cert.alpha * 20))
    assert not worse.verified and any("(F)" in c.name for c in worse.failed_checks)
    leak = cert.P0.copy()
    leak[0, 2] = leak[2, 0] = 0.5
    broken = verify_clock_certificate(dataclasses.replace(cert, P0=leak, nodes=(leak, *cert.nodes[1:])))
    assert not broken.verified and any("structure" in c.name for c in broken.failed_checks)


def test_the_clock_bound_holds_in_simulation() -> None:
    sys_ = LinearSystem(A, B, C)
    T, std, proc = 0.1, 0.01, np.diag([0.0, 1e-3])
    cert = _clock(T, 0.5, R=std**2, process=proc)
    runs = 40
    rng = np.random.default_rng(5)
    x0 = np.zeros((runs, 2))
    xh0 = x0 + rng.normal(size=(runs, 2)) * 0.1
    r = simulate(sys_, OutputPredictor(LuenbergerObserver(sys_, L), sys_), x0, xh0, duration=6.0, dt=0.001,
                 u=np.zeros(1), measurements=[MeasurementGroup("s", outputs=[0], rate=1 / T, noise_std=std)],
                 process_noise=proc, seed=2)
    e = r.x_hat - r.x
    after = r.t >= 2.0
    rms = math.sqrt(float(np.mean(np.sum(e[:, after] ** 2, axis=-1))))
    bound = cert.rms_after(2.0, np.eye(2) * 0.01)
    assert 0 < rms < bound < 100 * rms


# ------------------------------------------------------------------ the impulsive observer
def _impulsive(T: float, alpha: float, R: float = 0.0, process: np.ndarray | None = None, gap: float | None = None):
    from nlobs.synthesis.impulsive_gain import design_impulsive_gain
    from nlobs.synthesis.sampled_clock import ClockGroup

    g = ClockGroup("s", (0,), gap or T, T, np.array([[R]]), np.zeros(1))
    return design_impulsive_gain([A], [C], alpha, g, process=process, p0=np.eye(2) * 0.01, settle=2.0)


def test_the_impulsive_error_at_samples_follows_the_exact_jump_map() -> None:
    """e_{k+1} = (I − LC) e^{AT} e_k for a linear plant: the observer reproduces it (matrix exponential)."""
    from nlobs.observers import ImpulsiveObserver

    sys_ = LinearSystem(A, B, C)
    T, dt = 0.5, 0.001
    Lj = np.array([[0.8], [0.5]])
    r = simulate(sys_, ImpulsiveObserver(sys_, Lj), np.array([1.0, -0.5]), np.zeros(2), duration=2.0, dt=dt,
                 u=np.zeros(1), measurements=[MeasurementGroup("s", outputs=[0], rate=1 / T, noise_std=0.0)])
    e = r.x_hat - r.x
    k = int(round(T / dt))
    M = (np.eye(2) - Lj @ C) @ sl.expm(A * T)
    for j in range(1, 3):  # the estimate recorded at t_k is after the jump
        assert np.allclose(e[(j + 1) * k], M @ e[j * k], rtol=1e-7, atol=1e-10)


@pytest.mark.parametrize("T", [0.2, 0.5, 1.0])
def test_an_impulsive_certificate_implies_the_exact_jump_map_contracts(T: float) -> None:
    cert = _impulsive(T, 0.1)
    assert cert.verified
    M = (np.eye(2) - cert.gain @ C) @ sl.expm(A * T)
    # V(t_k⁺) decays by e^{-2αT} per period and |e|² ≤ V: the map's spectral radius is at most e^{-αT}
    assert max(abs(np.linalg.eigvals(M))) <= math.exp(-cert.alpha * T) + 1e-9


def test_the_impulsive_certificate_is_reverified_and_a_tampered_gain_fails() -> None:
    import dataclasses

    from nlobs.synthesis.impulsive_gain import verify_impulsive_gain

    cert = _impulsive(0.5, 0.1, R=1e-4, process=np.diag([0.0, 1e-3]))
    again = verify_impulsive_gain(cert)
    assert again.verified and again.jump == pytest.approx(cert.jump) and again.c == pytest.approx(cert.c)
    bad = verify_impulsive_gain(dataclasses.replace(cert, gain=np.zeros_like(cert.gain)))
    assert not bad.verified and any("jump" in c.name for c in bad.failed_checks)


def test_an_outage_is_a_longer_gap_the_certificate_must_bridge() -> None:
    short = _impulsive(0.5, 0.1)
    long_gap = _impulsive(0.5, 0.1, gap=3.0)
    assert short.verified and long_gap.verified and long_gap.t_max == (3.0,)
    M3 = (np.eye(2) - long_gap.gain @ C) @ sl.expm(A * 3.0)
    assert max(abs(np.linalg.eigvals(M3))) <= math.exp(-long_gap.alpha * 3.0) + 1e-9


def test_the_impulsive_bound_holds_in_simulation() -> None:
    from nlobs.observers import ImpulsiveObserver

    sys_ = LinearSystem(A, B, C)
    T, std, proc = 0.5, 0.01, np.diag([0.0, 1e-3])
    cert = _impulsive(T, 0.2, R=std**2, process=proc)
    runs = 40
    rng = np.random.default_rng(7)
    x0 = np.zeros((runs, 2))
    xh0 = x0 + rng.normal(size=(runs, 2)) * 0.1
    r = simulate(sys_, ImpulsiveObserver(sys_, cert.gain), x0, xh0, duration=8.0, dt=0.002, u=np.zeros(1),
                 measurements=[MeasurementGroup("s", outputs=[0], rate=1 / T, noise_std=std)], process_noise=proc,
                 seed=4)
    e = r.x_hat - r.x
    after = r.t >= 2.0
    rms = math.sqrt(float(np.mean(np.sum(e[:, after] ** 2, axis=-1))))
    bound = cert.rms_after(2.0, np.eye(2) * 0.01)
    assert 0 < rms < bound < 100 * rms


# ------------------------------------------------------------------ the design for the sensors, end to end
SQRT_TANK = '''name = "tank"
states = ["h"]
inputs = ["q"]
outputs = ["y"]
[dynamics]
f = ["-sqrt(h)"]
g = [["1"]]
h = ["h"]
[sensors.level]
outputs = ["y"]
rate = 10.0
noise_std = 0.01
[input_signals]
q = 1.0
[simulation]
x0 = [1.0]
box = [[0.0, 4.0]]
'''


def test_a_region_with_an_infinite_jacobian_is_a_design_failure_with_its_reason(tmp_path) -> None:
    from nlobs.methods.luenberger import LUENBERGER
    from nlobs.methods.problem import problem

    f = tmp_path / "tank.toml"
    f.write_text(SQRT_TANK)
    d = LUENBERGER.design(problem(str(f)))
    assert d.parameters["tuning"] == "decay"
    assert any("Lipschitz constant there is infinite" in w for w in d.warnings)
    ok = LUENBERGER.design(problem(str(f), box=[0.25, 4.0]))
    assert ok.parameters["tuning"] == "sensors" and ok.bound is not None and ok.bound.verified


def test_bad_design_options_are_one_line_errors(tmp_path) -> None:
    from typer.testing import CliRunner

    from nlobs.cli import app

    f = tmp_path / "tank.toml"
    f.write_text(SQRT_TANK)
    runner = CliRunner()
    for opt in ("luenberger.sampling=sideways", "luenberger.tuning=fast", "luenberger.alpha=-1",
                "luenberger.alpha=nan"):
        res = runner.invoke(app, ["simulate", "compare", str(f), "--observer", "luenberger", "--runs", "2",
                                  "--box", "0.25,4", "--duration", "1", "--option", opt])
        assert res.exit_code == 2, (opt, res.output)
        assert "Traceback" not in res.output and len(res.output.strip().splitlines()) == 1, res.output


@pytest.mark.slow
def test_on_the_cartpole_the_certificate_covers_the_runs_and_bounds_their_rms() -> None:
    """The shipped cart-pole and its 50 Hz encoders: the design for the sensors covers every run and the measured
    RMS after the settling time stays below the certified bound (a measured RMS above it is a bug)."""
    from nlobs.workflows.compare import compare_observers

    rep = compare_observers("cartpole", observers=["luenberger", "ekf"], runs=4, duration=7.0, progress=False)
    o = rep.observers["luenberger"]
    assert o.certificate["covers_run"] and o.certificate["covered_fraction"] == 1.0
    bound = o.certificate["rms_bound"]
    assert bound is not None and o.rms_error_norm < bound
    assert o.certificate["sampling"]["groups"][0]["T_max"] >= 0.02
    # and it is an observer worth running: within 2× the EKF on the same runs
    assert o.rms_error_norm < 2 * rep.observers["ekf"].rms_error_norm


def test_the_local_search_finds_an_extreme_the_samples_miss() -> None:
    """∂F/∂x = −(x−0.37)² − (y−0.61)² peaks at 0 inside the box: 64 samples stay below, the search reaches it."""
    def jac(x, u):
        return (-(x[:, 0] - 0.37) ** 2 - (x[:, 1] - 0.61) ** 2)[:, None, None]

    region = Box([0.0, 0.0], [1.0, 1.0])
    raw = jacobian_box(jac, region, [], [], samples=64, margin=0.0, refine=False)
    found = jacobian_box(jac, region, [], [], samples=64, margin=0.0)
    assert raw.upper[0, 0] < -1e-4
    assert found.upper[0, 0] == pytest.approx(0.0, abs=1e-8) and found.lower[0, 0] == raw.lower[0, 0]


# ------------------------------------------------------------------ the parallelotope of shared functions
def _chemostat_jacobian(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """∂F/∂x of the chemostat Ẋ = μ(S)X − DX, Ṡ = −μ(S)X/Y + D(4 − S), μ = 0.5 S/(0.2 + S), Y = 0.5 (closed form)."""
    X, S, D = x[:, 0], x[:, 1], u[:, 0]
    mu, dmu = 0.5 * S / (0.2 + S), 0.1 / (0.2 + S) ** 2
    return np.stack([np.stack([mu - D, X * dmu], -1), np.stack([-mu / 0.5, -D - X * dmu / 0.5], -1)], -2)


def _coefficients(box, M: np.ndarray) -> np.ndarray:
    E = box.basis.reshape(box.basis.shape[0], -1)
    c, res, *_ = np.linalg.lstsq(E.T, (M - box.offset).reshape(-1), rcond=None)
    assert np.allclose(E.T @ c, (M - box.offset).reshape(-1), atol=1e-9)  # M is in the parallelotope's plane
    return c


def test_shared_functions_give_a_parallelotope_that_keeps_the_mass_balance() -> None:
    """Four varying entries made of three functions (μ, Xμ', D): 8 vertices instead of 16, every one inside the
    entrywise box, and every one keeps the mass balance ∂(Ẋ + YṠ)/∂X = −D < 0 that
    the box's vertices break."""
    region = Box([0.05, 0.01], [4.0, 4.0])
    box = jacobian_box(_chemostat_jacobian, region, [0.2], [0.3])
    plain = jacobian_box(_chemostat_jacobian, region, [0.2], [0.3], reduce=False)
    assert box.basis is not None and box.n_vertices == 8 and plain.n_vertices == 16
    tol = 1e-9
    for V in box.vertices():
        assert np.all(V >= plain.lower - tol) and np.all(V <= plain.upper + tol)
        assert V[0, 0] + 0.5 * V[1, 0] < -0.19  # −D, D ≥ 0.2 less the margins
        assert V[1, 0] < 0  # ∂Ṡ/∂X = −μ/Y < 0
    assert max(V[0, 0] + 0.5 * V[1, 0] for V in plain.vertices()) > 0.25


def test_every_mean_value_matrix_lies_in_the_parallelotope() -> None:
    """F(x̂) − F(x) = J̄ (x̂ − x), J̄ = ∫₀¹ ∂F/∂x(x + s(x̂ − x)) ds (Gauss–Legendre, 20 nodes): on 500 random pairs
    of the region and inputs, J̄'s coefficients are within the parallelotope's bounds."""
    region = Box([0.05, 0.01], [4.0, 4.0])
    box = jacobian_box(_chemostat_jacobian, region, [0.2], [0.3])
    rng = np.random.default_rng(7)
    s, w = np.polynomial.legendre.leggauss(20)
    s, w = (s + 1) / 2, w / 2
    for _ in range(500):
        x, xh = region.sample(1, rng)[0], region.sample(1, rng)[0]
        u = np.array([0.2 + 0.1 * rng.random()])
        pts = x + s[:, None] * (xh - x)
        Jbar = np.tensordot(w, _chemostat_jacobian(pts, np.repeat(u[None], len(s), 0)), axes=1)
        c = _coefficients(box, Jbar)
        assert np.all(c >= box.coef_lower - 1e-9) and np.all(c <= box.coef_upper + 1e-9)


def test_independent_entries_keep_the_box() -> None:
    box = jacobian_box(lambda x, u: np.stack([np.cos(x[:, 0]), np.sin(x[:, 1])], -1)[:, None, :],
                       Box([0.0, 0.0], [1.0, 1.0]), [], [])
    assert box.basis is None and box.n_vertices == 4


def test_the_chemostat_design_for_its_analyser_is_certified() -> None:
    """With the parallelotope the shipped chemostat (substrate every 6 min, the file's whole region) gets a gain
    whose certificate is re-verified, at a decay rate below the smallest dilution rate (the mass balance's
    decay, which no output injection changes)."""
    from nlobs.methods.problem import problem
    from nlobs.methods.sensor_design import tune_thau

    tuned = tune_thau(problem("chemostat"))
    assert tuned.box.n_vertices == 8
    assert tuned.certificate.verified
    assert 0.15 < tuned.alpha < 0.2 * 1.01
    assert math.isfinite(tuned.rms_bound) and tuned.rms_bound < 0.1


@pytest.mark.parametrize("T", [0.2, 0.5])
def test_the_impulsive_iss_gain_is_above_the_worst_bounded_noise(T: float) -> None:
    """(I) against the exact worst case of |v_k| ≤ 1: e(t_k + τ) = e^{Aτ} Σ_i M^i L v_{k−i}, M = (I − LC)e^{AT}; for
    a direction d and τ the signs v = sign(dᵀ e^{Aτ} M^i L) reach Σ_i |dᵀ e^{Aτ} M^i L| (SciPy expm), which the gain
    must bound for every d and τ, and not by more than the Lyapunov function's conservatism (100×)."""
    cert = _impulsive(T, 0.2)
    gamma = cert.iss_gain
    L_ = cert.gain
    M = (np.eye(2) - L_ @ C) @ sl.expm(A * T)
    powers = [np.eye(2)]
    for _ in range(400):
        powers.append(M @ powers[-1])
    worst = 0.0
    for tau in np.linspace(0.0, T, 11):
        E = sl.expm(A * tau)
        terms = np.array([(E @ Mi @ L_)[:, 0] for Mi in powers])  # (i, n)
        for th in np.linspace(0, math.pi, 181):
            d = np.array([math.cos(th), math.sin(th)])
            worst = max(worst, float(np.sum(np.abs(terms @ d))))
    assert worst <= gamma < 100 * worst
    assert cert.ultimate_bound(0.01) == pytest.approx(0.01 * gamma)
    with pytest.raises(InvalidArgumentError):
        cert.ultimate_bound(-1.0)
    assert cert.to_dict()["iss_gain"] == pytest.approx(gamma)


@pytest.mark.parametrize("T", [0.05, 0.2])
def test_the_clock_iss_bound_is_above_the_worst_bounded_noise(T: float, predictor_worst_case) -> None:
    cert = _clock(T, 0.1)
    assert cert.verified
    worst = predictor_worst_case(A, C, L, T)
    assert worst <= cert.iss_gain < 100 * worst
    assert cert.ultimate_bound(0.5) == pytest.approx(0.5 * cert.iss_gain)
    assert cert.to_dict()["iss_gain"] == pytest.approx(cert.iss_gain)


def test_the_small_gain_iss_bound_is_above_the_worst_bounded_noise(predictor_worst_case) -> None:
    """:meth:`SampledDataBound.ultimate_bound` against the exact worst case of the predictor's error system."""
    T = 0.01
    bound = _lyapunov_bound(A, C, L, T)
    assert bound.verified
    worst = predictor_worst_case(A, C, L, T)
    gamma = bound.iss_gain
    assert worst <= gamma < 1000 * worst
    assert bound.ultimate_bound(0.5) == pytest.approx(0.5 * gamma, rel=1e-6)
    assert bound.to_dict()["iss_gain"] == pytest.approx(gamma)
    with pytest.raises(InvalidArgumentError):
        bound.ultimate_bound(float("nan"))
