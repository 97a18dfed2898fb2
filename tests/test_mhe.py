"""Moving-horizon estimation: against the Kalman filter, the EKF, bounds, missing samples and bad arguments.

What this file guarantees
-------------------------
* Linear-Gaussian discrete plant, no bounds: with its EKF arrival cost the moving-horizon estimate is the
  Kalman filter's posterior at every sample (the full-information equivalence), to 1e-6, for windows shorter
  and longer than the run, with a missing sample of one output or of all of them (the Kalman filter written
  out here with filterpy skips the same rows); so are the covariance and the NIS.
* A batch of runs gives each run's own estimate (one solve per run).
* The shipped pendulum (continuous time, angle sampled at 10 Hz) converges with an error like the EKF's.
* Bounds: on an SIR epidemic with fractions in [0, 1] the EKF's estimate leaves the box and the MHE's does not;
  a scalar problem whose unconstrained optimum is negative is solved at the bound (not merely clipped).
* A failed IPOPT solve raises SimulationDiverged naming the time; bad arguments raise typed errors; a
  missing CasADi is one typed line naming the extra; the estimator pickles.
* The SymPy → CasADi translation agrees with the compiled NumPy plant on shipped models and refuses
  functions it has no form for.
"""

from __future__ import annotations

import pickle
import sys
import time

import numpy as np
import pytest
import sympy as sp

pytest.importorskip("casadi")

import nlobs  # noqa: E402
from nlobs.errors import (  # noqa: E402
    DimensionError,
    InvalidArgumentError,
    ModelError,
    NonFiniteError,
    NotSymmetricError,
    SimulationDiverged,
)
from nlobs.observers.mhe import MHE, MHEState  # noqa: E402
from nlobs.simulate import MeasurementGroup, run_observer  # noqa: E402
from nlobs.systems.casadi_expr import casadi_model  # noqa: E402
from nlobs.systems.symbolic import SymbolicModel  # noqa: E402

# ------------------------------------------------------------------ a linear-Gaussian plant and its Kalman filter
A = np.array([[1.0, 0.1], [-0.2, 0.95]])
B = np.array([[0.0], [0.1]])
C = np.array([[1.0, 0.0], [0.5, 1.0]])
QD = np.array([[0.01, 0.002], [0.002, 0.02]])
RD = np.array([[0.04, 0.01], [0.01, 0.09]])
P0D = np.diag([1.0, 2.0])
K_STEPS = 30


def _linear_data(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Inputs (K, 1), noisy outputs (K, 2) and true states (K, 2) of the plant above, drawn here with NumPy."""
    rng = np.random.default_rng(seed)
    u = np.sin(0.3 * np.arange(K_STEPS))[:, None]
    x = np.array([1.0, -0.5])
    xs, ys = [], []
    lw, lv = np.linalg.cholesky(QD), np.linalg.cholesky(RD)
    for k in range(K_STEPS):
        xs.append(x)
        ys.append(C @ x + lv @ rng.standard_normal(2))
        x = A @ x + B @ u[k] + lw @ rng.standard_normal(2)
    return u, np.array(ys), np.array(xs)


def _kalman(u: np.ndarray, y: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """filterpy's Kalman filter: posterior means, covariances and NIS at every step (NaN rows skipped)."""
    from filterpy.kalman import KalmanFilter

    kf = KalmanFilter(dim_x=2, dim_z=2, dim_u=1)
    kf.F, kf.B, kf.H, kf.Q, kf.R = A, B, C, QD, RD
    kf.x, kf.P = x0.reshape(2, 1).astype(float), P0D.copy()
    means, covs, nis = [], [], []
    last = 0.0
    for k in range(len(u)):
        rows = np.flatnonzero(np.isfinite(y[k]))
        if rows.size:
            H, R = C[rows], RD[np.ix_(rows, rows)]
            kf.update(y[k, rows].reshape(-1, 1), R=R, H=H)
            last = (kf.y.T @ np.linalg.solve(kf.S, kf.y)).item()
        else:
            kf.update(None)
        means.append(kf.x.ravel().copy())
        covs.append(kf.P.copy())
        nis.append(last)
        kf.predict(u=u[k].reshape(1, 1))
    return np.array(means), np.array(covs), np.array(nis)


def _linear_plant() -> nlobs.LinearSystem:
    return nlobs.LinearSystem(A, B, C, time=nlobs.Discrete(1.0))


@pytest.mark.parametrize("horizon", [1, 4, 40])
def test_linear_gaussian_mhe_is_the_kalman_filter(horizon: int) -> None:
    u, y, _ = _linear_data(0)
    x0 = np.array([0.0, 0.0])
    res = run_observer(MHE(_linear_plant(), QD, RD, P0D, horizon=horizon), np.arange(K_STEPS, dtype=float),
                       x_hat0=x0, u=u, y=y)
    means, covs, nis = _kalman(u, y, x0)
    # measured: 2.2e-16 for every horizon (IPOPT takes one Newton step on this quadratic problem)
    assert np.max(np.abs(res.x_hat - means)) < 1e-6
    np.testing.assert_allclose(res.extras["P_diag"], np.diagonal(covs, axis1=1, axis2=2), rtol=1e-9)
    np.testing.assert_allclose(res.extras["nis"], nis, rtol=1e-8, atol=1e-12)
    assert np.max(np.abs(means - _kalman(u, y, x0 + 1.0)[0])) > 1e-2  # the comparison can fail: x̂0 matters


@pytest.mark.parametrize("horizon", [4, 40])
def test_the_window_is_the_rauch_tung_striebel_smoother(horizon: int) -> None:
    """The window's states are the smoothed ones given all data so far (the arrival cost is the exact prior)."""
    u, y, _ = _linear_data(0)
    x0 = np.zeros(2)
    means, covs, _ = _kalman(u, y, x0)
    smoothed = means.copy()  # Rauch, Tung & Striebel (1965), written out with the inputs
    for k in range(K_STEPS - 2, -1, -1):
        gain = covs[k] @ A.T @ np.linalg.inv(A @ covs[k] @ A.T + QD)
        smoothed[k] = means[k] + gain @ (smoothed[k + 1] - (A @ means[k] + B @ u[k]))
    mhe = MHE(_linear_plant(), QD, RD, P0D, horizon=horizon)
    z = mhe.init(x0)
    for k in range(K_STEPS):
        z = mhe.correct(float(k), z, u[k], y[k], np.array([True, True]))
        z = mhe.rhs(float(k), z, u[k], y[k])
    W = min(horizon, K_STEPS)
    assert int(z.count) == W and z.times[:W].tolist() == list(range(K_STEPS - W, K_STEPS))
    # measured 6e-17 (4) and 1e-16 (40); the smoothed states differ from the filtered ones by 0.13 and 0.23
    assert np.max(np.abs(z.X[:W] - smoothed[-W:])) < 1e-6
    assert np.max(np.abs(smoothed[-W:] - means[-W:])) > 0.1


def test_a_random_walk_sampled_every_other_step_is_the_kalman_filter() -> None:
    """Discrete plant, samples two steps apart: ``F = f∘f`` and ``Q_j = 2 Q``, exact for a random walk."""
    Q, R = np.diag([0.01, 0.04]), np.diag([0.1, 0.2])
    walk = nlobs.LinearSystem(np.eye(2), np.zeros((2, 0)), np.eye(2), time=nlobs.Discrete(0.5))
    sensor = MeasurementGroup("s", [0, 1], rate=1.0, noise_std=np.sqrt(np.diag(R)))
    res = nlobs.simulate(walk, MHE(walk, Q, R, np.eye(2), horizon=3), [1.0, -1.0], [0.0, 0.0], duration=15.0,
                         process_noise=Q, measurements=sensor, seed=3)
    assert res.sampled[:4, 0].tolist() == [True, False, True, False]
    x, P, kf = np.zeros(2), np.eye(2), []
    for k in range(res.t.size):
        if res.sampled[k, 0]:
            gain = P @ np.linalg.inv(P + R)
            x, P = x + gain @ (res.y[k] - x), (np.eye(2) - gain) @ P
        kf.append(x.copy())  # the posterior at a sample, the prediction between samples
        P = P + Q
    assert np.max(np.abs(res.x_hat - np.array(kf))) < 1e-6  # measured 4e-16


@pytest.mark.parametrize("substeps", [1, 3])
def test_a_continuous_linear_plant_uses_rk4_over_the_interval_and_q_dt(substeps: int) -> None:
    """Continuous plant: the estimate at the samples is the Kalman filter of ``x⁺ = Φ x + w``, ``Φ`` the RK4
    transition over the sampling interval (``substeps`` steps), ``cov w = Q Δt`` (a singular ``Q`` here)."""
    Ac, Cc = np.array([[0.0, 1.0], [-2.0, -0.3]]), np.array([[1.0, 0.0]])
    Qc, Rc, T = np.diag([0.0, 0.05]), np.array([[0.01]]), 0.2
    osc = nlobs.LinearSystem(Ac, np.zeros((2, 0)), Cc)
    res = nlobs.simulate(osc, MHE(osc, Qc, Rc, np.eye(2), horizon=4, substeps=substeps), [1.0, 0.0], [0.0, 0.0],
                         duration=6.0, dt=0.01, process_noise=Qc, seed=4,
                         measurements=MeasurementGroup("pos", [0], rate=1 / T, noise_std=0.1))
    M = (T / substeps) * Ac
    Phi = np.linalg.matrix_power(np.eye(2) + M + M @ M / 2 + M @ M @ M / 6 + M @ M @ M @ M / 24, substeps)
    x, P, kf = np.zeros(2), np.eye(2), []
    at = np.flatnonzero(res.sampled[:, 0])
    for i, k in enumerate(at):
        if i:
            x, P = Phi @ x, Phi @ P @ Phi.T + Qc * T
        gain = P @ Cc.T @ np.linalg.inv(Cc @ P @ Cc.T + Rc)
        x, P = x + gain @ (res.y[k] - Cc @ x), (np.eye(2) - gain @ Cc) @ P
        kf.append(x.copy())
    assert at.size == 31
    assert np.max(np.abs(res.x_hat[at] - np.array(kf))) < 1e-6  # measured 7e-16 (1 step), 1e-15 (3 steps)


def test_missing_samples_and_a_batch_match_the_kalman_filter_that_skips_them() -> None:
    u0, y0, _ = _linear_data(1)
    u1, y1, _ = _linear_data(2)
    y1 = y1.copy()
    y1[3, 0] = np.nan  # one output missing
    y1[7:9, :] = np.nan  # both outputs missing at two samples (inside the window, then dropped from it)
    y1[12, 1] = np.inf
    x0 = np.array([[0.0, 0.0], [0.5, 0.5]])
    mhe = MHE(_linear_plant(), QD, RD, P0D, horizon=5)
    res = run_observer(mhe, np.arange(K_STEPS, dtype=float), x_hat0=x0, u=np.stack([u0, u1]), y=np.stack([y0, y1]))
    assert res.x_hat.shape == (2, K_STEPS, 2)
    assert res.info["missing"].tolist() == [0, 4]
    for i, (u, y) in enumerate(((u0, y0), (u1, y1))):
        means, covs, _ = _kalman(u, np.where(np.isfinite(y), y, np.nan), x0[i])
        assert np.max(np.abs(res.x_hat[i] - means)) < 1e-6
        np.testing.assert_allclose(res.extras["P_diag"][i], np.diagonal(covs, axis1=1, axis2=2), rtol=1e-9)
    # the missing samples changed the second run's estimates (what is compared is not vacuous)
    filled = _kalman(u1, np.where(np.isfinite(y1), y1, 0.0), x0[1])[0]
    assert np.max(np.abs(res.x_hat[1] - filled)) > 1e-2


def test_one_batched_correction_equals_each_run_alone() -> None:
    plant = nlobs.load_model("pendulum").compile()
    mhe = MHE(plant, 1e-3 * np.eye(2), [[1e-2]], np.eye(2), horizon=3)
    x0 = np.array([[0.1, 0.0], [0.5, -1.0], [-0.3, 2.0]])
    ys = np.array([[0.2], [np.nan], [-0.1]])
    u, fresh = np.zeros(1), np.array([True])
    together = mhe.init(x0)
    alone = [mhe.init(x0[i]) for i in range(3)]
    for k in range(4):
        t = 0.1 * k
        together = mhe.correct(t, together, u, ys + 0.05 * k, fresh)
        alone = [mhe.correct(t, z, u, ys[i] + 0.05 * k, fresh) for i, z in enumerate(alone)]
        for i, z in enumerate(alone):
            np.testing.assert_allclose(together.x[i], z.x, rtol=1e-12, atol=1e-14)
            np.testing.assert_allclose(together.P[i], z.P, rtol=1e-12, atol=1e-14)
    assert int(together.count) == 3 and together.X.shape == (3, 3, 2)
    assert not np.allclose(together.x[0], together.x[2])


# ------------------------------------------------------------------ continuous time: the pendulum
def test_pendulum_converges_like_the_ekf() -> None:
    plant = nlobs.load_model("pendulum").compile()
    Q, R, P0 = 1e-4 * np.eye(2), [[1e-4]], np.eye(2)
    enc = MeasurementGroup("encoder", ["y"], rate=10.0, noise_std=0.01)
    args = dict(duration=6.0, dt=1e-2, u=0.0, measurements=enc, seed=1)
    tic = time.perf_counter()
    mhe = nlobs.simulate(plant, MHE(plant, Q, R, P0, horizon=10), [1.0, 0.0], [0.0, 1.0], **args)
    wall = time.perf_counter() - tic
    ekf = nlobs.simulate(plant, nlobs.EKF(plant, Q, R, P0), [1.0, 0.0], [0.0, 1.0], **args)
    after = mhe.t >= 2.0
    rms_mhe = np.sqrt((mhe.error[after] ** 2).mean(axis=0))
    rms_ekf = np.sqrt((ekf.error[after] ** 2).mean(axis=0))
    # measured: MHE rms (0.0040, 0.0091), EKF (0.0040, 0.0090); final errors (0.0025, 0.0021) both
    assert abs(mhe.error[0, 0]) < 0.02 and abs(mhe.error[0, 1]) == 1.0  # the first sample corrects the angle
    assert np.all(rms_mhe < 0.02) and np.all(rms_mhe < 1.5 * rms_ekf)
    assert np.abs(mhe.error[-1]).max() < 0.02
    # the covariance diagnostic agrees with the EKF's (measured σ = (0.0051, 0.016) for both)
    np.testing.assert_allclose(np.sqrt(mhe.extras["P_diag"][-1]), np.sqrt(ekf.extras["P_diag"][-1]), rtol=0.2)
    sampled = mhe.sampled[:, 0]
    assert mhe.extras["iterations"][sampled].max() <= 10 and np.all(mhe.extras["cost"][sampled] >= 0.0)
    assert wall < 10.0  # measured ≈ 0.5 s (61 solves of horizon 10)


def test_pendulum_between_samples_follows_the_model() -> None:
    plant = nlobs.load_model("pendulum").compile()
    mhe = MHE(plant, 1e-4 * np.eye(2), [[1e-4]], np.eye(2), horizon=10)
    z = mhe.correct(0.0, mhe.init([0.2, 0.0]), np.zeros(1), np.array([0.3]), np.array([True]))
    rate = mhe.rhs(0.0, z, np.zeros(1), np.array([0.3]))
    np.testing.assert_allclose(rate.x, plant.rhs(0.0, z.x, np.zeros(1)), rtol=1e-14)
    F = plant.rhs_jacobian_x(0.0, z.x, np.zeros(1))
    np.testing.assert_allclose(rate.P, F @ z.P + z.P @ F.T + 1e-4 * np.eye(2), rtol=1e-12)
    assert float(rate.nis) == 0.0 and float(np.max(np.abs(rate.X))) == 0.0 and rate.count == z.count


# ------------------------------------------------------------------ bounds
def _sir() -> nlobs.systems.symbolic.CompiledModel:
    return SymbolicModel.general(["S", "I", "R"], [], ["cases"],
                                 rhs=["-beta*S*I", "beta*S*I - gamma*I", "gamma*I"], h=["I"],
                                 parameters={"beta": 0.25, "gamma": 0.1}, name="sir").compile()


def test_sir_estimate_stays_in_the_unit_box_where_the_ekf_leaves_it() -> None:
    sir = _sir()
    Q, R, P0 = 1e-6 * np.eye(3), [[1e-4]], 1e-4 * np.eye(3)
    args = dict(duration=60.0, dt=0.25, measurements=MeasurementGroup("daily", ["cases"], rate=1.0, noise_std=0.01),
                seed=2)
    x0, xh0 = [0.998, 0.002, 0.0], [0.99, 0.01, 0.0]
    mhe = nlobs.simulate(sir, MHE(sir, Q, R, P0, horizon=10, lower=np.zeros(3), upper=np.ones(3)), x0, xh0, **args)
    ekf = nlobs.simulate(sir, nlobs.EKF(sir, Q, R, P0), x0, xh0, **args)
    # measured: the EKF's I reaches −0.0060 and R −0.0017, its S 0.994; the MHE's stay in [0, 1]
    assert ekf.x_hat[:, 1].min() < -0.003 and ekf.x_hat[:, 2].min() < 0.0
    assert mhe.x_hat.min() >= 0.0 and mhe.x_hat.max() <= 1.0
    # and it tracks at least as well (measured rms of I: 0.0022 MHE, 0.0024 EKF)
    rms = lambda r: float(np.sqrt((r.error[:, 1] ** 2).mean()))  # noqa: E731
    assert rms(mhe) <= 1.05 * rms(ekf) and rms(mhe) < 0.01


def test_an_active_bound_is_met_by_the_optimiser_not_only_by_clipping() -> None:
    walk = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
    u, fresh = np.zeros(0), np.array([True])
    free = MHE(walk, [[1.0]], [[1.0]], [[1.0]], horizon=2)
    boxed = MHE(walk, [[1.0]], [[1.0]], [[1.0]], horizon=2, lower=[0.0])
    z_free = free.correct(0.0, free.init([0.1]), u, np.array([-1.0]), fresh)
    z_box = boxed.correct(0.0, boxed.init([0.1]), u, np.array([-1.0]), fresh)
    # min (x − 0.1)² + (−1 − x)²: −0.45 free, 0 with x ≥ 0 (convex, so the bound is where the optimum is)
    assert float(z_free.x[0]) == pytest.approx(-0.45, abs=1e-8)
    assert abs(float(z_box.x[0])) < 1e-7 and float(boxed.estimate(z_box)[0]) >= 0.0
    assert float(z_box.cost) == pytest.approx(0.1**2 + 1.0, abs=1e-6)
    # a second sample: both window states are bounded; the free solution has a negative first state
    z_free = free.correct(1.0, free.rhs(0.0, z_free, u, None), u, np.array([-0.5]), fresh)
    z_box = boxed.correct(1.0, boxed.rhs(0.0, z_box, u, None), u, np.array([-0.5]), fresh)
    assert z_free.X[:2, 0].min() < -0.1 and z_box.X[:2, 0].min() > -1e-7


# ------------------------------------------------------------------ failures and arguments
def test_a_failed_solve_raises_simulation_diverged_naming_the_time() -> None:
    plant = nlobs.load_model("pendulum").compile()
    mhe = MHE(plant, 1e-4 * np.eye(2), [[1e-4]], np.eye(2), ipopt_options={"ipopt.max_iter": 0})
    with pytest.raises(SimulationDiverged, match=r"MHE failed at t = 0\.3: IPOPT returned Maximum_Iterations"):
        mhe.correct(0.3, mhe.init([0.0, 0.0]), np.zeros(1), np.array([2.0]), np.array([True]))


def test_no_fresh_output_leaves_the_state_and_time_must_not_go_back() -> None:
    mhe = MHE(_linear_plant(), QD, RD, P0D, horizon=3)
    z = mhe.init([0.0, 0.0])
    assert mhe.correct(0.0, z, np.zeros(1), np.zeros(2), np.array([False, False])) is z
    z = mhe.correct(1.0, z, np.zeros(1), np.zeros(2), np.array([True, True]))
    with pytest.raises(InvalidArgumentError, match="before the window's newest"):
        mhe.correct(0.5, z, np.zeros(1), np.zeros(2), np.array([True, True]))
    with pytest.raises(DimensionError, match="fresh"):
        mhe.correct(2.0, z, np.zeros(1), np.zeros(2), np.array([True]))


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"horizon": 0}, InvalidArgumentError, "horizon"),
    ({"horizon": 2.5}, InvalidArgumentError, "horizon"),
    ({"horizon": True}, InvalidArgumentError, "horizon"),
    ({"substeps": 0}, InvalidArgumentError, "substeps"),
    ({"lower": [0.0]}, DimensionError, "lower"),
    ({"upper": [[1.0, 1.0]]}, DimensionError, "upper"),
    ({"lower": [0.0, np.nan]}, NonFiniteError, "lower"),
    ({"lower": [0.0, 1.0], "upper": [1.0, 1.0]}, InvalidArgumentError, r"lower\[1\] = 1.0 is not below upper\[1\]"),
    ({"lower": [np.inf, 0.0]}, InvalidArgumentError, "not below"),
    ({"name": 3}, InvalidArgumentError, "name"),
    ({"ipopt_options": [("ipopt.max_iter", 3)]}, InvalidArgumentError, "ipopt_options"),
    ({"ipopt_options": {"ipopt.max_iter": [3]}}, InvalidArgumentError, "ipopt_options"),
    ({"ipopt_options": {"no_such_option": 1}}, InvalidArgumentError, "ipopt_options"),
    ({"Q": -np.eye(2)}, InvalidArgumentError, "Q"),
    ({"R": np.zeros((2, 2))}, InvalidArgumentError, "R"),
    ({"P0": [[1.0, 0.5], [0.0, 1.0]]}, NotSymmetricError, "P0"),
    ({"Q": np.eye(3)}, DimensionError, "Q"),
])
def test_invalid_arguments_raise_typed_errors(kwargs: dict, error: type, match: str) -> None:
    args = {"Q": QD, "R": RD, "P0": P0D, **kwargs}
    with pytest.raises(error, match=match):
        MHE(_linear_plant(), args.pop("Q"), args.pop("R"), args.pop("P0"), **args)


def test_a_plant_without_expressions_is_refused() -> None:
    class Decay:
        time, states, inputs, outputs = nlobs.Continuous(), ("x",), (), ("y",)
        n, m, p = 1, 0, 1

        def rhs(self, t, x, u):  # type: ignore[no-untyped-def]
            return -x

        def output(self, t, x, u):  # type: ignore[no-untyped-def]
            return x

    with pytest.raises(InvalidArgumentError, match="plant: expected a SymbolicModel"):
        MHE(Decay(), [[1.0]], [[1.0]], [[1.0]])


def test_missing_casadi_is_one_typed_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "casadi", None)  # import casadi now raises ImportError
    with pytest.raises(InvalidArgumentError, match=r"MHE needs CasADi.*pip install 'nlobs\[mhe\]'") as info:
        MHE(_linear_plant(), QD, RD, P0D)
    assert "\n" not in str(info.value)


def test_the_estimator_pickles_and_computes_the_same() -> None:
    plant = nlobs.load_model("pendulum")  # the symbolic model itself is accepted too
    mhe = MHE(plant, 1e-4 * np.eye(2), [[1e-4]], np.eye(2), horizon=4, lower=[-4.0, -np.inf], upper=[4.0, np.inf],
              ipopt_options={"ipopt.tol": 1e-10})
    copy = pickle.loads(pickle.dumps(mhe))
    assert copy.horizon == 4 and copy.ipopt_options == {"ipopt.tol": 1e-10} and copy.lower.tolist() == [-4.0, -np.inf]
    za, zb = mhe.init([0.0, 0.5]), copy.init([0.0, 0.5])
    for k in range(6):
        y = np.array([0.1 * np.cos(k)])
        za = mhe.correct(0.1 * k, za, np.zeros(1), y, np.array([True]))
        zb = copy.correct(0.1 * k, zb, np.zeros(1), y, np.array([True]))
    np.testing.assert_allclose(za.x, zb.x, rtol=1e-12, atol=1e-14)
    assert int(za.count) == 4


# ------------------------------------------------------------------ the SymPy → CasADi translation
@pytest.mark.parametrize("name", ["pendulum", "cartpole", "rossler", "cstr", "ball-and-beam"])
def test_the_casadi_translation_agrees_with_the_compiled_plant(name: str) -> None:
    plant = nlobs.load_model(name).compile()
    cm = casadi_model(plant)
    rng = np.random.default_rng(0)
    x, u = rng.uniform(0.1, 1.0, (20, plant.n)), rng.uniform(-1.0, 1.0, (20, plant.m))
    f = np.array([np.asarray(cm.f(x[i], u[i])).ravel() for i in range(20)])
    h = np.array([np.asarray(cm.h(x[i], u[i])).ravel() for i in range(20)])
    np.testing.assert_allclose(f, plant.rhs(0.0, x, u), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(h, plant.output(0.0, x, u), rtol=1e-13, atol=1e-13)


def test_the_translation_covers_the_whitelist_and_refuses_the_rest() -> None:
    names = ["a", "b"]
    exprs = ["sin(a) + cos(b) + tan(a/3) + asin(a/2) + acos(b/3) + atan(a) + atan2(a, b)",
             "sinh(a) + cosh(b) + tanh(a) + exp(b) + log(b) + sqrt(b) + abs(a) + sign(a) + a**3 + b**(-1.5) + pi"]
    model = SymbolicModel.general(names, [], ["y"], rhs=exprs, h=["a*b"]).compile()
    cm = casadi_model(model)
    for x in ([0.3, 0.7], [-0.4, 1.9]):
        np.testing.assert_allclose(np.asarray(cm.f(x, [])).ravel(), model.rhs(0.0, np.array(x), np.zeros(0)),
                                   rtol=1e-14)
    a = sp.Symbol("a", real=True)
    odd = SymbolicModel.general(["a"], [], ["y"], rhs=[sp.gamma(a)], h=[a])
    with pytest.raises(ModelError, match="gamma .* has no CasADi form"):
        MHE(odd, [[1.0]], [[1.0]], [[1.0]])
