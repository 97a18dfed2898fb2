"""The bootstrap particle filter: against the Kalman filter, the EKF, a sensor the EKF cannot use, and its contract.

What this file guarantees
-------------------------
* On a linear-Gaussian plant the posterior is Gaussian and the Kalman filter (written out here in NumPy)
  computes it exactly: with many particles the PF's weighted mean, weighted variance and NIS follow the
  Kalman filter's to within a Monte Carlo tolerance stated at the test.
* On the pendulum (continuous plant, angle sampled at 10 Hz) the PF converges like the EKF, with posterior
  standard deviations close to the EKF's steady state.
* With the sensor ``y = x²`` and a prior symmetric about 0 the cloud becomes bimodal at ``±|x|`` and the PF
  tracks ``|x|``, where the EKF (``∂h/∂x = 0`` at its mean 0) never moves; with the bound ``x ≥ 0`` the PF
  tracks ``x`` itself.
* The process noise has the documented scale (``Q h`` per step in continuous time, ``Q`` in discrete time).
* Systematic resampling equals the textbook search of the positions ``(u + j)/N`` in the cumulative weights.
* Contract: reproducible (same seed, same bits; another seed, other numbers; the documented generator),
  batch axes (shapes, each run converges, run 0 of a batch is the run alone), missing samples (a NaN row is
  exactly a row not sampled), bounds (every particle inside them after every call), typed errors, and
  ``SimulationDiverged`` when no particle can explain a sample.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import nlobs
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError, NotSymmetricError, SimulationDiverged
from nlobs.observers.base import CorrectingObserver, Diagnosing, Observer, SelfStepping
from nlobs.observers.particle import ParticleFilter, ParticleState, systematic_resample
from nlobs.simulate import MeasurementGroup, run_observer, simulate
from nlobs.systems.modelfile import parse_model

# ----------------------------------------------------------------------------- plants
A = np.array([[0.9, 0.2], [-0.1, 0.95]])
B = np.array([[0.0], [0.1]])
C = np.array([[1.0, 0.0]])
Q_LIN, R_LIN, P0_LIN = np.diag([0.01, 0.02]), np.array([[0.05]]), np.eye(2)

SQUARE = """
name = "square-sensor"
time = "discrete"
dt = 1.0
states = ["x"]
outputs = ["y"]

[dynamics]
f = ["x"]
h = ["x**2"]
"""


def _linear() -> nlobs.LinearSystem:
    return nlobs.LinearSystem(A, B, C, time=nlobs.Discrete(1.0))


def _u_sine(t: float) -> np.ndarray:
    return np.array([math.sin(0.3 * t)])


def _pendulum() -> object:
    return nlobs.load_model("pendulum").compile()


ENCODER = MeasurementGroup("encoder", ["y"], rate=10.0)


def _pendulum_pf(**kw: object) -> ParticleFilter:
    return ParticleFilter(_pendulum(), Q=1e-4 * np.eye(2), R=[[1e-4]], P0=np.eye(2), **kw)  # type: ignore[arg-type]


def _run_pendulum(pf: ParticleFilter, x0: object = (1.0, 0.0)) -> nlobs.SimulationResult:
    return simulate(pf.plant, pf, x0, [0.0, 1.0], duration=3.0, dt=1e-2, u=0.0, measurements=ENCODER)


def _kalman(ys: np.ndarray, us: np.ndarray, x0: np.ndarray, P0: np.ndarray) -> tuple[np.ndarray, ...]:
    """Posterior means and covariances ``x_{k|k}, P_{k|k}`` and the NIS of each sample, in plain NumPy."""
    x, P = np.array(x0, dtype=float), P0.copy()
    xs, Ps, nis = [], [], []
    for y, u in zip(ys, us):
        S = C @ P @ C.T + R_LIN
        nu = y - C @ x
        K = P @ C.T @ np.linalg.inv(S)
        x, P = x + K @ nu, (np.eye(2) - K @ C) @ P
        xs.append(x)
        Ps.append(P)
        nis.append(float(nu @ np.linalg.solve(S, nu)))
        x, P = A @ x + B @ u, A @ P @ A.T + Q_LIN
    return np.array(xs), np.array(Ps), np.array(nis)


# ----------------------------------------------------------------------------- against independent filters
def test_protocol_membership() -> None:
    pf = _pendulum_pf(particles=10)
    assert isinstance(pf, Observer) and isinstance(pf, CorrectingObserver)
    assert isinstance(pf, SelfStepping) and isinstance(pf, Diagnosing)
    assert pf.n_x == 2 and pf.time == pf.plant.time and pf.name == "PF"  # type: ignore[attr-defined]


def test_linear_gaussian_plant_follows_the_kalman_filter() -> None:
    """Mean, variance and NIS of the PF against the exact Kalman filter on the same noisy data.

    Tolerance: the weighted mean of ``N`` particles has a Monte Carlo standard error of about
    ``σ √(κ/N)``, ``σ`` the posterior standard deviation and ``κ`` the variance inflation of the
    reweighting and resampling history (measured ``√κ ≈ 2``: RMS of ``|m_PF − m_KF| / σ`` ≈ 0.014 for
    ``N = 20000`` over five seeds, largest of 82 values 0.03–0.05). The bound 0.1 is 7 such standard errors;
    the variance's relative error ``≈ √(2κ/N) ≈ 0.02`` is held to 0.15, ``√NIS = |ν|/√S`` (the same moments
    of the predicted output) to 0.05 + 5 %. A filter off by a bias of 0.1 σ, a wrong ``R`` or ``Q`` fails these.
    """
    N = 20000
    plant = _linear()
    pf = ParticleFilter(plant, Q_LIN, R_LIN, P0_LIN, particles=N, seed=0)
    res = simulate(plant, pf, [1.0, -1.0], [0.0, 0.0], duration=40.0, u=_u_sine, process_noise=Q_LIN,
                   measurements=MeasurementGroup("y", [0], rate=1.0, noise_std=math.sqrt(0.05)), seed=7)
    us = np.array([_u_sine(t) for t in res.t])
    x_kf, P_kf, nis_kf = _kalman(res.y, us, np.zeros(2), P0_LIN)
    sd = np.sqrt(np.diagonal(P_kf, 0, 1, 2))
    dist = np.abs(res.x_hat - x_kf) / sd
    var_ratio = res.extras["P_diag"] / sd**2
    assert dist.max() < 0.1, dist.max()  # measured 0.044
    assert np.sqrt(np.mean(dist**2)) < 0.03  # measured 0.015
    assert np.all(np.abs(var_ratio - 1.0) < 0.15), (var_ratio.min(), var_ratio.max())  # measured 0.96–1.02
    # √NIS = |ν| / √S: ν is off by the predicted output's Monte Carlo error (a few hundredths of √S), S by ~2 %
    np.testing.assert_allclose(np.sqrt(res.extras["nis"]), np.sqrt(nis_kf), rtol=0.05, atol=0.05)
    ess = res.extras["ess"]
    assert np.all((ess > 1.0) & (ess <= N * (1 + 1e-12)))
    # the KF itself tracks the truth here (a sanity check of the written-out filter, not of the PF)
    assert np.sqrt(np.mean(((res.x - x_kf)[10:] / sd[10:]) ** 2)) < 2.0


def _settle(res: nlobs.SimulationResult, tol: float = 0.05) -> np.ndarray:
    """First time after which the velocity error stays below ``tol`` (per run)."""
    bad = np.abs(res.error[..., 1]) >= tol
    last = np.where(bad.any(axis=-1), bad.shape[-1] - 1 - np.argmax(bad[..., ::-1], axis=-1), -1)
    return np.asarray(res.t[np.minimum(last + 1, res.t.size - 1)])


def test_pendulum_converges_like_the_ekf() -> None:
    """The EKF's docstring example, with the PF: both fix the angle at the first sample and the velocity follows.

    Measured over 20 seeds (1000 particles): the velocity error settles below 0.05 rad/s after 0.1–1.7 s (the EKF:
    0.1 s), the final error is ≤ 0.008 and the posterior standard deviations are within 6 % of the EKF's steady
    state (0.0051 rad, 0.0170 rad/s). The velocity right after the first sample is the mean of the few particles
    whose angle fits it (an effective sample size of 3–10), so it is not tested. With 500 particles 2 seeds of
    20 fail (ends 0.05 off, or no particle near a sample); with 300, 3 of 20.
    """
    plant = _pendulum()
    ekf = nlobs.EKF(plant, Q=1e-4 * np.eye(2), R=[[1e-4]], P0=np.eye(2))
    r_ekf = simulate(plant, ekf, [1.0, 0.0], [0.0, 1.0], duration=3.0, dt=1e-2, u=0.0, measurements=ENCODER)
    r_pf = _run_pendulum(_pendulum_pf(particles=1000, seed=0))
    assert abs(r_pf.error[0, 0]) < 0.03  # the first sample fixes the angle (measured 0.002)
    assert float(_settle(r_ekf)) <= 0.1 and float(_settle(r_pf)) < 2.0  # measured 0.1 and 0.65
    assert np.abs(r_pf.error[r_pf.t >= 2.0]).max() < 0.05
    assert r_pf.error_norm[-1] < 0.02  # measured 0.002; the EKF: < 1e-4 (noise-free samples)
    np.testing.assert_allclose(np.sqrt(r_pf.extras["P_diag"][-1]), np.sqrt(r_ekf.extras["P_diag"][-1]), rtol=0.1)


@pytest.mark.slow
def test_pendulum_twenty_runs_converge() -> None:
    """20 runs of the same experiment in one batch (each its own draws): measured over 3 seeds × 20 runs, the median
    settling time is 0.55 s (the EKF: 0.1 s), the slowest 2.8 s, the largest final error 0.029."""
    res = _run_pendulum(_pendulum_pf(particles=1000, seed=0), np.tile([1.0, 0.0], (20, 1)))
    settle = _settle(res)
    assert np.median(settle) < 1.0 and settle.max() < 3.0, np.sort(settle)
    assert res.error_norm[:, -1].max() < 0.05


def _square_data(seed: int = 5, steps: int = 20) -> tuple[object, nlobs.SimulationResult]:
    plant = parse_model(SQUARE).compile()
    ekf = nlobs.EKF(plant, Q=[[1e-4]], R=[[0.01]], P0=[[1.0]])
    res = simulate(plant, ekf, [1.0], [0.0], duration=float(steps), process_noise=[[1e-4]],
                   measurements=MeasurementGroup("y", [0], rate=1.0, noise_std=0.1), seed=seed)
    return plant, res


def _run_by_hand(pf: ParticleFilter, ys: np.ndarray, x_hat0: list[float]) -> list[ParticleState]:
    """The loop's order for a discrete filter: correct with ``y_k``, record, predict (every state kept)."""
    z = pf.init(x_hat0)
    states, no_u, fresh = [], np.zeros(0), np.ones(pf.p, dtype=bool)
    for k, y in enumerate(ys):
        z = pf.correct(float(k), z, no_u, y, fresh)
        states.append(z)
        z = pf.rhs(float(k), z, no_u, y)
    return states


def test_square_sensor_bimodal_cloud_tracks_the_magnitude() -> None:
    """``y = x² + v`` from a prior N(0, 1): the sign of ``x`` is not observable.

    The EKF linearises at its mean 0, where ``∂h/∂x = 2x̂ = 0``: its gain is zero, so it never moves from 0 and
    its variance only grows by ``Q`` per step. The posterior is symmetric with modes at ``±1``: the PF's cloud
    holds both, its mean stays near 0 (the right posterior mean) and its weighted ``E|x|`` tracks ``|x| ≈ 1``.
    """
    plant, res = _square_data()
    assert np.array_equal(res.x_hat, np.zeros_like(res.x_hat))  # the EKF is stuck at its prior mean
    np.testing.assert_allclose(res.extras["P_diag"][:, 0], 1.0 + 1e-4 * np.arange(res.t.size), rtol=1e-12)
    pf = ParticleFilter(plant, Q=[[1e-4]], R=[[0.01]], P0=[[1.0]], particles=2000, seed=0)
    states = _run_by_hand(pf, res.y, [0.0])
    last = states[-1]
    w, x = np.exp(last.log_weights), last.particles[:, 0]
    truth = abs(float(res.x[-1, 0]))
    plus = float(w[x > 0].sum())
    assert 0.2 < plus < 0.8, plus  # both modes kept (measured 0.47)
    assert float(w @ np.abs(x)) == pytest.approx(truth, abs=0.03)
    assert float(w[x > 0] @ x[x > 0]) / plus == pytest.approx(truth, abs=0.03)
    assert float(w[x < 0] @ x[x < 0]) / (1 - plus) == pytest.approx(-truth, abs=0.03)
    assert abs(float(pf.estimate(last)[0])) < 0.6  # the mean of a bimodal posterior: between the modes
    assert float(pf.diagnostics(last, np.zeros(0))["P_diag"][0]) > 0.5  # ≈ |x|² − mean²: the modes' spread


def test_square_sensor_with_the_bound_x_nonnegative_tracks_x() -> None:
    plant, res = _square_data()
    pf = ParticleFilter(plant, Q=[[1e-4]], R=[[0.01]], P0=[[1.0]], particles=2000, seed=0, lower=[0.0])
    states = _run_by_hand(pf, res.y, [0.0])
    assert all(float(z.particles.min()) >= 0.0 for z in states)
    est = np.array([pf.estimate(z)[0] for z in states])
    np.testing.assert_allclose(est[5:], res.x[5:, 0], atol=0.05)


@pytest.mark.parametrize("discrete", [False, True])
def test_process_noise_has_the_documented_scale(discrete: bool) -> None:
    """``ẋ = 0`` with ``Q = 0.04``: after 1 s the particles' variance is ``P0 + Q t = 0.09 + 0.04`` (Euler–Maruyama
    is exact for a zero drift; 100 steps of 0.01 s), and ``x⁺ = x`` grows by ``Q`` per step (10 steps: 0.49).
    Relative sampling error of a variance of ``N = 20000`` Gaussian draws: ``√(2/N) = 0.01``; bound 0.05."""
    N = 20000
    time = nlobs.Discrete(1.0) if discrete else nlobs.Continuous()
    plant = nlobs.LinearSystem([[1.0 if discrete else 0.0]], np.zeros((1, 0)), [[1.0]], time=time)
    pf = ParticleFilter(plant, [[0.04]], [[1.0]], [[0.09]], particles=N, seed=3)
    z = pf.init([0.0])
    steps, h = (10, 1.0) if discrete else (100, 0.01)
    for k in range(steps):
        z = pf.rhs(k * h, z, np.zeros(0), np.zeros(1)) if discrete else pf.step(k * h, z, np.zeros(0), np.zeros(1), h)
    want = 0.09 + 0.04 * steps * h
    got = float(pf.diagnostics(z, np.zeros(0))["P_diag"][0])
    assert got == pytest.approx(want, rel=0.05)
    assert z.counter == steps + 1


# ----------------------------------------------------------------------------- resampling
def test_systematic_resampling_is_the_textbook_search() -> None:
    rng = np.random.default_rng(0)
    w = rng.random((50, 200)) ** 4
    w[3, :150] = 0.0
    u = rng.random(50)
    got = systematic_resample(w, u)
    c = np.cumsum(w, axis=1) / w.sum(axis=1, keepdims=True)
    for r in range(50):
        positions = (u[r] + np.arange(200)) / 200
        np.testing.assert_array_equal(got[r], np.searchsorted(c[r], positions, side="right"))
    counts = np.stack([np.bincount(g, minlength=200) for g in got])
    Nw = 200 * w / w.sum(axis=1, keepdims=True)
    assert np.all((counts >= np.floor(Nw) - 1e-9) & (counts <= np.ceil(Nw) + 1e-9))
    assert np.all(counts[3, :150] == 0)
    with pytest.raises(InvalidArgumentError, match="offsets"):
        systematic_resample([0.5, 0.5], 1.0)
    with pytest.raises(InvalidArgumentError, match="sums to zero"):
        systematic_resample([0.0, 0.0], 0.5)
    with pytest.raises(DimensionError, match="offsets"):
        systematic_resample([[0.5, 0.5]], [0.1, 0.2])


def test_roughening_follows_gordon_salmond_smith() -> None:
    """After a resampling every particle is its ancestor plus ``N(0, σⱼ²)``, ``σⱼ = K Eⱼ N^(−1/n)``, ``Eⱼ`` the range
    of state ``j`` over the resampled particles. The same seed with ``K = 0`` and ``K = 1`` picks the same ancestors
    (the offsets are drawn alike), so the difference of the two clouds is the jitter: its standard deviation over
    ``σⱼ`` is 1 within the sampling error ``√(1/(2N)) ≈ 0.011`` of ``N = 4000`` draws (bound 0.05)."""
    plant = nlobs.LinearSystem(np.eye(2), np.zeros((2, 0)), [[1.0, 0.0]], time=nlobs.Discrete(1.0))
    clouds = {}
    for K in (0.0, 1.0):
        pf = ParticleFilter(plant, np.zeros((2, 2)), [[0.01]], np.diag([1.0, 4.0]), particles=4000, seed=2,
                            roughening=K, resample_threshold=1.0)
        z = pf.init([0.0, 0.0])
        z1 = pf.correct(0.0, z, np.zeros(0), np.array([0.3]), np.array([True]))
        assert np.allclose(z1.log_weights, -math.log(4000))  # resampled: equal weights again
        clouds[K] = z1.particles
    old = {tuple(r) for r in z.particles}
    assert all(tuple(r) in old for r in clouds[0.0])  # K = 0: copies of the old particles only
    assert len({tuple(r) for r in clouds[0.0]}) < 4000 / 2  # ... with repetitions (a sharp likelihood)
    sigma = np.ptp(clouds[0.0], axis=0) * 4000 ** (-1 / 2)
    jitter = (clouds[1.0] - clouds[0.0]) / sigma
    np.testing.assert_allclose(jitter.std(axis=0), 1.0, atol=0.05)
    np.testing.assert_allclose(jitter.mean(axis=0), 0.0, atol=0.1)


# ----------------------------------------------------------------------------- contract
def test_same_seed_same_numbers_other_seed_other_numbers() -> None:
    a = _run_pendulum(_pendulum_pf(particles=1000, seed=4))
    b = _run_pendulum(_pendulum_pf(particles=1000, seed=4))
    c = _run_pendulum(_pendulum_pf(particles=1000, seed=5))
    assert np.array_equal(a.x_hat, b.x_hat)
    for name in ("P_diag", "nis", "ess"):
        assert np.array_equal(a.extras[name], b.extras[name])
    assert not np.array_equal(a.x_hat, c.x_hat)
    assert np.abs(a.x_hat - c.x_hat)[a.t >= 2.0].max() < 0.1  # other numbers, the same filter once converged


def test_the_documented_generator_draws_the_initial_cloud() -> None:
    """``init`` draws from ``np.random.default_rng([seed, 0, 0])``, centred, times a factor of ``P0``."""
    P0 = np.array([[2.0, 0.5], [0.5, 1.0]])
    pf = ParticleFilter(_linear(), Q_LIN, R_LIN, P0, particles=50, seed=11)
    xi = np.random.default_rng([11, 0, 0]).standard_normal((50, 2))
    xi -= xi.mean(axis=0)
    np.testing.assert_allclose(pf.init([1.0, 2.0]).particles, [1.0, 2.0] + xi @ np.linalg.cholesky(P0).T,
                               rtol=0, atol=1e-14)


def test_batch_of_three_runs() -> None:
    pf = _pendulum_pf(particles=1000, seed=0)
    x0 = np.array([[1.0, 0.0], [-0.5, 0.5], [0.3, -1.0]])
    res = _run_pendulum(pf, x0)
    K = res.t.size
    assert res.x_hat.shape == (3, K, 2)
    assert res.extras["P_diag"].shape == (3, K, 2)
    assert res.extras["nis"].shape == (3, K) and res.extras["ess"].shape == (3, K)
    assert np.all(res.error_norm[:, -1] < 0.05), res.error_norm[:, -1]
    z = pf.init(np.zeros((3, 2)))
    assert z.particles.shape == (3, 1000, 2) and z.log_weights.shape == (3, 1000)
    # run 0 of the batch is the run made alone (noise-free samples: the same data); the other runs drew
    # other numbers than run 0 (independent draws per run)
    alone = _run_pendulum(pf, x0[0])
    np.testing.assert_allclose(res.x_hat[0], alone.x_hat, rtol=0, atol=1e-12)
    u3 = np.zeros((3, 1))
    z1 = pf.step(0.0, z, u3, u3, 0.01)
    assert np.array_equal(z1.particles, pf.step(0.0, z, u3, u3, 0.01).particles)  # a pure function of the state
    assert not np.array_equal(z.particles[0], z.particles[1])


def test_missing_sample_is_a_row_not_sampled() -> None:
    """A NaN at a fresh row is exactly that row left out, for that run only; a run with no row left keeps its state."""
    plant = nlobs.LinearSystem(np.eye(2), np.zeros((2, 0)), np.eye(2), time=nlobs.Discrete(1.0))
    pf = ParticleFilter(plant, 0.01 * np.eye(2), np.diag([0.5, 0.2]), np.eye(2), particles=400, seed=1)
    z = pf.init(np.zeros((3, 2)))
    no_u, both = np.zeros((3, 0)), np.array([True, True])
    y = np.array([[1.0, -1.0], [1.0, np.nan], [np.nan, np.nan]])
    got = pf.correct(0.0, z, no_u, y, both)
    full = pf.correct(0.0, z, no_u, np.array([[1.0, -1.0]] * 3), both)
    first = pf.correct(0.0, z, no_u, np.array([[1.0, 99.0]] * 3), np.array([True, False]))
    for field in ("particles", "log_weights", "nis", "ess"):
        g, f, o, z0 = (getattr(s, field) for s in (got, full, first, z))
        np.testing.assert_array_equal(g[0], f[0])  # run 0: both rows
        np.testing.assert_array_equal(g[1], o[1])  # run 1: the first row only
        np.testing.assert_array_equal(g[2], z0[2])  # run 2: nothing
    assert not np.array_equal(got.log_weights[1], full.log_weights[1])


def test_missing_sample_in_recorded_data() -> None:
    """``run_observer`` on recorded pendulum samples, run 1 missing the sample at t = 1 s: the runs agree before it,
    differ after it, and both still converge."""
    plant = _pendulum()
    truth = simulate(plant, None, [1.0, 0.0], duration=3.0, dt=1e-2, u=0.0, measurements=ENCODER)
    every = np.flatnonzero(truth.sampled[:, 0])
    t_y, y = truth.t[every], np.stack([truth.y[every], truth.y[every]])
    y[1, 10] = np.nan
    pf = _pendulum_pf(particles=1000, seed=0)
    res = run_observer(pf, truth.t, x_hat0=np.array([[0.0, 1.0], [0.0, 1.0]]), u=np.zeros((truth.t.size, 1)),
                       y=y, y_times=t_y, truth=np.stack([truth.x, truth.x]))
    np.testing.assert_array_equal(res.info["missing"], [0, 1])
    k = int(np.flatnonzero(np.isclose(truth.t, t_y[10]))[0])
    # run 1 drew other numbers than run 0 from the start (its own block of each draw): compare each run with
    # itself run alone instead: identical to the complete record up to the gap, different after
    alone = run_observer(pf, truth.t, x_hat0=[0.0, 1.0], u=np.zeros((truth.t.size, 1)), y=y[0], y_times=t_y)
    np.testing.assert_allclose(res.x_hat[0], alone.x_hat, rtol=0, atol=1e-12)
    assert np.array_equal(res.extras["nis"][1, k], res.extras["nis"][1, k - 1])  # the NIS kept at the gap
    assert np.all(res.error_norm[:, -1] < 0.05)


def test_bounds_hold_for_every_particle() -> None:
    """Bounds that the truth respects (|θ| ≤ 1 on this swing, |ω| ≤ 3.1) and the prior N((0, 1), I) does not: every
    particle stays inside them after every call, the initial cloud touches them, and the filter still converges."""
    lower, upper = np.array([-1.2, -3.5]), np.array([1.2, 3.5])
    pf = _pendulum_pf(particles=1000, seed=0, lower=lower, upper=upper)
    truth = simulate(pf.plant, None, [1.0, 0.0], duration=2.0, dt=1e-2, u=0.0, measurements=ENCODER)
    z = pf.init([0.0, 1.0])
    states, u = [z], np.zeros(1)
    for k, t in enumerate(truth.t[:-1]):
        if truth.sampled[k, 0]:
            z = pf.correct(t, z, u, truth.y[k], np.array([True]))
            states.append(z)
        z = pf.step(t, z, u, truth.y[k], 0.01)
        states.append(z)
    for s in states:
        assert np.all(s.particles >= lower) and np.all(s.particles <= upper)
    assert float(states[0].particles[:, 0].min()) == -1.2 and float(states[0].particles[:, 0].max()) == 1.2
    assert np.linalg.norm(pf.estimate(z) - truth.x[-1]) < 0.05


def test_a_sample_no_particle_explains_collapses_the_cloud_and_a_non_finite_one_raises() -> None:
    """A sample 10⁷ σ from every particle (a likelihood below the smallest double): the log weights still rank the
    particles, the nearest takes the weight (ESS 1) and the run goes on; a non-finite prediction raises."""
    plant = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
    pf = ParticleFilter(plant, [[0.0]], [[1e-4]], [[1e-6]], particles=100, name="my PF")
    z = pf.init(np.zeros((2, 1)))
    z1 = pf.correct(2.5, z, np.zeros((2, 0)), np.array([[0.0], [1e3]]), np.array([True]))
    assert np.isfinite(z1.log_weights).all() and np.isfinite(z1.particles).all()
    assert float(z1.ess[1]) == pytest.approx(1.0) and float(z1.ess[0]) > 50
    nearest = float(z.particles[1, np.argmax(z.particles[1, :, 0]), 0])
    assert float(pf.estimate(z1)[1, 0]) == pytest.approx(nearest, abs=1e-2)  # the cloud on its largest particle
    # through the loop: a sensor biased by 100 rad with R = 1e-4 runs to the end, every sample collapsing the cloud
    res = simulate(_pendulum(), _pendulum_pf(particles=100), [1.0, 0.0], [0.0, 1.0], duration=1.0, dt=1e-2, u=0.0,
                   measurements=MeasurementGroup("encoder", ["y"], rate=10.0, bias=100.0))
    assert np.isfinite(res.x_hat).all() and np.all(np.asarray(res.extras["ess"])[res.sampled[:, 0]] < 1.01)
    inf = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
    big = ParticleFilter(inf, [[0.0]], [[1e-4]], [[1e-6]], particles=10, name="my PF")
    zb = ParticleState(np.full((10, 1), 1e300), np.full(10, -math.log(10)), 0, np.zeros(()), np.full((), 10.0))
    with pytest.raises(SimulationDiverged, match=r"my PF diverged at t = 2\.5"):
        big.correct(2.5, zb, np.zeros(0), np.array([-1e300]), np.array([True]))


def test_the_discrete_filter_has_no_step_and_fresh_is_checked() -> None:
    pf = ParticleFilter(_linear(), Q_LIN, R_LIN, P0_LIN, particles=10)
    z = pf.init([0.0, 0.0])
    with pytest.raises(InvalidArgumentError, match="advanced by rhs"):
        pf.step(0.0, z, np.zeros(1), np.zeros(1), 1.0)
    with pytest.raises(DimensionError, match=r"fresh: expected shape \(1,\)"):
        pf.correct(0.0, z, np.zeros(1), np.zeros(1), np.array([True, True]))
    assert pf.correct(0.0, z, np.zeros(1), np.zeros(1), np.array([False])) is z


BAD_ARGUMENTS = [
    ({"particles": 1}, InvalidArgumentError, "particles: expected an integer ≥ 2"),
    ({"particles": 10.0}, InvalidArgumentError, "particles: expected an integer"),
    ({"particles": True}, InvalidArgumentError, "particles: expected an integer"),
    ({"seed": -1}, InvalidArgumentError, "seed: expected an integer ≥ 0"),
    ({"roughening": -0.1}, InvalidArgumentError, "roughening: must be non-negative"),
    ({"roughening": math.nan}, NonFiniteError, "roughening"),
    ({"resample_threshold": 0.0}, InvalidArgumentError, r"resample_threshold: must lie in \(0, 1\]"),
    ({"resample_threshold": 1.5}, InvalidArgumentError, "resample_threshold"),
    ({"lower": [0.0, 1.0], "upper": [1.0, 1.0]}, InvalidArgumentError, "state 1 has lower = 1.0 ≥ upper = 1.0"),
    ({"lower": [0.0]}, DimensionError, r"lower: expected shape \(2,\)"),
    ({"upper": [np.nan, 1.0]}, NonFiniteError, "upper: entry 0 is nan"),
    ({"Q": -np.eye(2)}, InvalidArgumentError, "Q: not symmetric positive semi-definite"),
    ({"R": [[0.0]]}, InvalidArgumentError, "R: not symmetric positive definite"),
    ({"P0": np.eye(3)}, DimensionError, "P0"),
    ({"P0": [[1.0, 1.0], [0.0, 1.0]]}, NotSymmetricError, "P0"),
    ({"name": 3}, InvalidArgumentError, "name: expected a string"),
    ({"plant": "pendulum"}, InvalidArgumentError, "plant: expected a PlantModel"),
]


@pytest.mark.parametrize(("change", "error", "message"), BAD_ARGUMENTS, ids=lambda v: str(v)[:40])
def test_invalid_arguments_raise_typed_errors(change: dict[str, object], error: type, message: str) -> None:
    args: dict[str, object] = {"plant": _linear(), "Q": Q_LIN, "R": R_LIN, "P0": P0_LIN, **change}
    with pytest.raises(error, match=message) as info:
        ParticleFilter(**args)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)


def test_initial_estimate_is_checked() -> None:
    pf = ParticleFilter(_linear(), Q_LIN, R_LIN, P0_LIN, particles=10)
    with pytest.raises(DimensionError, match="x_hat0"):
        pf.init([0.0, 0.0, 0.0])
    with pytest.raises(NonFiniteError, match="x_hat0"):
        pf.init([0.0, np.nan])
