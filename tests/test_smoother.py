"""The Rauch–Tung–Striebel smoother of the EKF and the UKF (``nlobs.observers.smoother``), against independent sources.

* a discrete linear-Gaussian plant: the smoothed means and covariances are the batch Gaussian posterior of
  ``x_0 .. x_{K−1}`` (the dense joint information matrix of the prior, the dynamics and the samples, solved
  directly here), and filterpy's ``KalmanFilter.rts_smoother`` run on filterpy's own filter of the same data;
* on a linear plant the unscented smoother (Särkkä 2008) is the extended one, and the EKF's gain is
  ``P Φᵀ (P⁻)⁻¹`` with ``Φ`` the RK4 stability polynomial of ``h A``;
* the shipped pendulum with process noise and noisy samples: the smoothed error is measured against the truth;
* the re-made prediction is the filter's own record where there was no sample; a batch smooths as its members;
* the typed errors for bad input.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import nlobs
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.observers.smoother import Smoothed, rts_smooth, smooth_run
from nlobs.simulate import MeasurementGroup, run_observer, simulate

# ---------------------------------------------------------------------------------------------- a discrete plant
A = np.array([[0.9, 0.3], [-0.2, 0.95]])
B = np.array([[0.0], [1.0]])
C = np.array([[1.0, 0.0]])
Q = np.array([[0.02, 0.005], [0.005, 0.04]])
R = np.array([[0.25]])
P0 = np.diag([1.0, 2.0])
XH0 = np.array([0.5, -0.3])
K = 60


def _discrete_data(u: np.ndarray, seed: int = 7) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]:
    """Truth, samples at the kept instants (every 4th one dropped, one NaN: missing) and the instants used."""
    rng = np.random.default_rng(seed)
    x = np.empty((K, 2))
    x[0] = XH0 + rng.multivariate_normal(np.zeros(2), P0)
    for k in range(K - 1):
        x[k + 1] = A @ x[k] + B @ u[k] + rng.multivariate_normal(np.zeros(2), Q)
    y = x @ C.T + rng.normal(0.0, math.sqrt(R[0, 0]), (K, 1))
    kept = np.flatnonzero(np.arange(K) % 4 != 3)
    ys = y[kept].copy()
    ys[5] = np.nan  # a missing sample: the filter skips it
    used = [int(k) for g, k in enumerate(kept) if g != 5]
    return x, ys, kept, used


def _discrete_run(cls: type, u: np.ndarray) -> tuple[object, object, np.ndarray, list[int]]:
    plant = nlobs.LinearSystem(A, B, C, time=nlobs.Discrete(1.0))
    filt = cls(plant, Q=Q, R=R, P0=P0, record_covariance=True)
    x, ys, kept, used = _discrete_data(u)
    t = np.arange(K, dtype=float)
    res = run_observer(filt, t, x_hat0=XH0, u=u, y=ys, y_times=t[kept])
    return filt, res, x, used


def _batch_posterior(u: np.ndarray, y: np.ndarray, used: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The Gaussian posterior of ``x_0 .. x_{K−1}`` given the samples at ``used``: the joint information matrix of
    the prior ``N(XH0, P0)``, the dynamics ``x⁺ = A x + B u + w`` and the samples ``y = C x + v``, solved densely."""
    n = 2
    N = n * K
    L = np.zeros((N, N))
    b = np.zeros(N)
    Qi, Ri, P0i = np.linalg.inv(Q), np.linalg.inv(R), np.linalg.inv(P0)
    L[:n, :n] += P0i
    b[:n] += P0i @ XH0
    for k in range(K - 1):
        i, j = slice(n * k, n * k + n), slice(n * k + n, n * k + 2 * n)
        L[i, i] += A.T @ Qi @ A
        L[i, j] -= A.T @ Qi
        L[j, i] -= Qi @ A
        L[j, j] += Qi
        bu = B @ u[k]
        b[i] -= A.T @ Qi @ bu
        b[j] += Qi @ bu
    for k in used:
        i = slice(n * k, n * k + n)
        L[i, i] += C.T @ Ri @ C
        b[i] += C.T @ Ri @ y[k]
    mean = np.linalg.solve(L, b).reshape(K, n)
    cov = np.linalg.inv(L)
    return mean, np.stack([cov[n * k:n * k + n, n * k:n * k + n] for k in range(K)])


def test_discrete_linear_smoother_is_the_batch_posterior() -> None:
    u = np.sin(0.3 * np.arange(K))[:, None]
    ekf, res, _, used = _discrete_run(nlobs.EKF, u)
    s = smooth_run(ekf, res, u)
    y_all = np.full((K, 1), np.nan)  # the samples on the grid (only the instants in ``used`` are read)
    _, ys, kept, _ = _discrete_data(u)
    y_all[kept] = ys
    mean, cov = _batch_posterior(u, y_all, used)
    # measured: 1.7e-14 (means of size up to 10), 2.8e-16 (covariances of size 0.2)
    assert np.abs(s.x - mean).max() < 1e-9
    assert np.abs(s.P - cov).max() < 1e-9
    # the last smoothed estimate is the filter's, and the smoother is not the filter elsewhere
    assert np.array_equal(s.x[-1], res.x_hat[-1])
    assert np.abs(s.x - res.x_hat).max() > 0.1
    # smoothing never adds uncertainty: P^s ≤ P (the filter's) at every time
    assert np.linalg.eigvalsh(res.extras["P"] - s.P).min() > -1e-12


def test_discrete_linear_smoother_equals_filterpy() -> None:
    from filterpy.kalman import KalmanFilter

    u = np.zeros((K, 1))  # filterpy's rts_smoother predicts with F x alone (no input term)
    ekf, res, _, _ = _discrete_run(nlobs.EKF, u)
    _, ys, kept, _ = _discrete_data(u)
    y_at = dict(zip(kept.tolist(), ys[:, 0].tolist()))
    kf = KalmanFilter(dim_x=2, dim_z=1)
    kf.x, kf.P, kf.F, kf.H, kf.Q, kf.R = XH0.copy(), P0.copy(), A, C, Q, R
    xs, Ps = [], []
    for k in range(K):  # nlobs' order: the correction at t_k, then the prediction to t_{k+1}
        yk = y_at.get(k, math.nan)
        if math.isfinite(yk):
            kf.update(np.array([yk]))
        xs.append(kf.x.copy())
        Ps.append(kf.P.copy())
        kf.predict()
    Xf, Pf = np.array(xs), np.array(Ps)
    assert np.abs(Xf - res.x_hat).max() < 1e-12  # the two filters agree (measured 2e-16)
    xs_fp, Ps_fp, G_fp, _ = kf.rts_smoother(Xf, Pf, [A] * K, [Q] * K)
    s = smooth_run(ekf, res, u)
    # measured: 4e-16, 1.1e-15, 1.4e-15
    assert np.abs(s.x - xs_fp).max() < 1e-9
    assert np.abs(s.P - Ps_fp).max() < 1e-9
    assert np.abs(s.gains - G_fp[:-1]).max() < 1e-9


def test_unscented_smoother_is_the_extended_one_on_a_linear_plant() -> None:
    u = np.sin(0.3 * np.arange(K))[:, None]
    ekf, re, _, _ = _discrete_run(nlobs.EKF, u)
    ukf, ru, _, _ = _discrete_run(nlobs.UKF, u)
    se, su = smooth_run(ekf, re, u), smooth_run(ukf, ru, u)
    assert (se.method, su.method) == ("extended", "unscented")
    # measured: 4.4e-15 and 1.8e-15
    assert np.abs(su.x - se.x).max() < 1e-10
    assert np.abs(su.P - se.P).max() < 1e-10
    assert np.abs(su.gains - se.gains).max() < 1e-10


def test_continuous_linear_smoothers_agree_and_the_gain_is_the_rk4_transition() -> None:
    plant = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    Qc = np.diag([0.0, 0.3])
    meas = MeasurementGroup("y", ["y1"], rate=10.0, noise_std=0.1)
    runs = {}
    for cls in (nlobs.EKF, nlobs.UKF):
        filt = cls(plant, Q=Qc, R=[[0.01]], P0=np.eye(2), record_covariance=True)
        run = simulate(plant, filt, [1.0, 0.0], [0.0, 0.0], duration=3.0, dt=0.02, u=0.4, measurements=meas,
                       process_noise=Qc, seed=4)
        runs[cls] = (filt, run, smooth_run(filt, run, 0.4))
    (_, _, se), (_, _, su) = runs[nlobs.EKF], runs[nlobs.UKF]
    assert np.abs(su.x - se.x).max() < 1e-10  # measured 3.7e-15 (and 2.3e-15 for P)
    assert np.abs(su.P - se.P).max() < 1e-10
    # the EKF's gain: P_k Φᵀ (P⁻)⁻¹ with Φ = Σ_{j ≤ 4} (h A)^j / j! (one RK4 step of a linear system)
    _, run, _ = runs[nlobs.EKF]
    hA = 0.02 * plant.A
    Phi = sum(np.linalg.matrix_power(hA, j) / math.factorial(j) for j in range(5))
    P = np.asarray(run.extras["P"])
    G = P[:-1] @ Phi.T @ np.linalg.inv(se.P_pred)
    assert np.abs(se.gains - G).max() < 1e-9  # measured 1.4e-14


# ---------------------------------------------------------------------------------------------- the pendulum
PEND_Q = np.diag([1e-6, 0.05])  # spectral density: the velocity is kicked
PEND_STD = 0.05  # encoder noise


def _pendulum_runs(cls: type, runs: int, duration: float) -> tuple[object, object]:
    plant = nlobs.load_model("pendulum").compile()
    P0 = np.diag([0.1, 0.3])
    rng = np.random.default_rng(11)
    x0 = np.array([0.8, 0.0]) + rng.normal(size=(runs, 2)) * np.sqrt(np.diag(P0))
    filt = cls(plant, Q=PEND_Q, R=[[PEND_STD**2]], P0=P0, record_covariance=True)
    run = simulate(plant, filt, x0, [0.8, 0.0], duration=duration, dt=0.01, u=0.0,
                   measurements=MeasurementGroup("encoder", ["y"], rate=10.0, noise_std=PEND_STD),
                   process_noise=PEND_Q, seed=5)
    return filt, run


def _pendulum_check(cls: type) -> None:
    filt, run = _pendulum_runs(cls, runs=20, duration=10.0)
    s = smooth_run(filt, run, 0.0)
    ef, es = run.x_hat - run.x, s.x - run.x
    rms_f = np.sqrt(np.mean(ef**2, axis=(0, 1)))
    rms_s = np.sqrt(np.mean(es**2, axis=(0, 1)))
    # measured (20 runs of 10 s, both filters): filtered RMS (0.0306 rad, 0.135 rad/s), smoothed (0.0209, 0.0866):
    # ratios 0.68 and 0.64
    ratio = rms_s / rms_f
    assert np.all(ratio < 0.8), ratio
    assert np.all(ratio > 0.4), ratio  # not too good to be true either
    # the smoothed ±3σ covers the error about as a Gaussian's does (measured 99.6 % per state; 99.73 % expected)
    cover = np.mean(np.abs(es) <= 3.0 * s.std, axis=(0, 1))
    assert np.all(cover > 0.98), cover
    # and the normalised error squared averages the state dimension (measured 2.19 for n = 2)
    nees = float(np.mean(np.einsum("...i,...ij,...j->...", es, np.linalg.inv(s.P), es)))
    assert 1.6 < nees < 2.6, nees


def test_pendulum_ekf_smoother_beats_the_filter() -> None:
    _pendulum_check(nlobs.EKF)


@pytest.mark.slow
def test_pendulum_ukf_smoother_beats_the_filter() -> None:
    _pendulum_check(nlobs.UKF)


def _pendulum_f(x: np.ndarray, tau: float) -> np.ndarray:
    """The shipped pendulum's ``f`` written out (g = 9.81, l = 1, c = 0.2, mass = 0.5)."""
    return np.stack([x[..., 1], -9.81 * np.sin(x[..., 0]) - 0.2 * x[..., 1] + tau / 0.5], axis=-1)


def _rk4_flow(x: np.ndarray, tau: float, h: float) -> np.ndarray:
    k1 = _pendulum_f(x, tau)
    k2 = _pendulum_f(x + 0.5 * h * k1, tau)
    k3 = _pendulum_f(x + 0.5 * h * k2, tau)
    k4 = _pendulum_f(x + h * k3, tau)
    return x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


@pytest.mark.parametrize("cls", [nlobs.EKF, nlobs.UKF])
def test_the_gain_is_the_cross_covariance_of_the_rk4_flow(cls: type) -> None:
    """The gains, rebuilt here from an RK4 step of the pendulum written out: EKF ``G = P Φᵀ (P⁻)⁻¹`` with ``Φ`` the
    Jacobian of the step (central differences); UKF ``G = C (P⁻)⁻¹`` with ``C = Σ w_c (𝒳 − x)(φ(𝒳) − x⁻)ᵀ`` over
    the sigma points ``x ± √n S_i`` (``α = 1, β = 2, κ = 0``: ``w_c = 1/(2n)`` and the centre's term zero)."""
    plant = nlobs.load_model("pendulum").compile()
    h = 0.05
    t = np.arange(31) * h
    tau = 0.4 * np.sin(3.0 * t)
    y = (0.5 * np.cos(3.0 * t[::4]))[:, None]
    filt = cls(plant, Q=PEND_Q, R=[[PEND_STD**2]], P0=0.2 * np.eye(2), record_covariance=True)
    res = run_observer(filt, t, x_hat0=[0.4, 0.0], u=tau[:, None], y=y, y_times=t[::4])
    s = smooth_run(filt, res, tau[:, None])
    X, P = np.asarray(res.x_hat), np.asarray(res.extras["P"])
    for k in range(t.size - 1):
        if cls is nlobs.EKF:
            eps = 1e-6
            Phi = np.stack([(_rk4_flow(X[k] + eps * e, tau[k], h) - _rk4_flow(X[k] - eps * e, tau[k], h)) / (2 * eps)
                            for e in np.eye(2)], axis=-1)
            Ck = P[k] @ Phi.T
        else:
            D = math.sqrt(2.0) * np.linalg.cholesky(P[k]).T  # rows: the scaled columns of S
            pts = np.concatenate([X[k] + D, X[k] - D])
            Ck = (pts - X[k]).T @ (_rk4_flow(pts, tau[k], h) - s.x_pred[k]) / 4.0
        G = Ck @ np.linalg.inv(s.P_pred[k])
        assert np.abs(s.gains[k] - G).max() < 1e-7, k  # measured: 1.4e-9 (EKF: the differences), 4e-15 (UKF)


# ---------------------------------------------------------------------------------------------- re-propagation
@pytest.mark.parametrize("cls", [nlobs.EKF, nlobs.UKF])
def test_the_prediction_is_the_filters_prior_on_recorded_data(cls: type) -> None:
    """On :func:`run_observer` (a torque that changes at every step, held over it) the re-made prediction is the
    filter's own record, bit for bit, at every instant without a sample."""
    plant = nlobs.load_model("pendulum").compile()
    t = np.round(np.arange(0.0, 2.0 + 1e-9, 0.01), 10)
    tau = (0.3 * np.sin(2.0 * t) + 0.1 * np.cos(7.0 * t))[:, None]
    y_times = t[::10]
    rng = np.random.default_rng(2)
    y = (0.5 * np.cos(3.0 * y_times) + rng.normal(0.0, 0.05, y_times.size))[:, None]
    filt = cls(plant, Q=PEND_Q, R=[[PEND_STD**2]], P0=0.2 * np.eye(2), record_covariance=True)
    res = run_observer(filt, t, x_hat0=[0.4, 0.0], u=tau, y=y, y_times=y_times)
    s = smooth_run(filt, res, tau)
    quiet = np.ones(t.size - 1, dtype=bool)
    quiet[9::10] = False  # t[1:][k] is a sample instant when k + 1 is a multiple of 10
    assert quiet.sum() == 180
    assert np.array_equal(s.x_pred[quiet], res.x_hat[1:][quiet])  # measured: equal
    assert np.array_equal(s.P_pred[quiet], res.extras["P"][1:][quiet])
    # at a sample the filter's posterior differs from its prior: the correction is there
    assert np.abs(s.x_pred[~quiet] - res.x_hat[1:][~quiet]).max() > 1e-3
    # the smoother moves the estimates everywhere but at the end
    assert np.abs(s.x[:-1] - res.x_hat[:-1]).min(axis=-1).max() > 1e-3


def test_the_prediction_is_the_filters_prior_when_kept_every_few_steps() -> None:
    """:func:`simulate` with ``save_every=5`` (every sample instant kept): each interval is 5 RK4 steps of ``dt``."""
    plant = nlobs.load_model("pendulum").compile()
    ekf = nlobs.EKF(plant, Q=PEND_Q, R=[[PEND_STD**2]], P0=0.2 * np.eye(2), record_covariance=True)
    run = simulate(plant, ekf, [[0.6, 0.0], [0.2, 1.0]], [0.4, 0.0], duration=3.0, dt=0.01, u=0.0, save_every=5,
                   measurements=MeasurementGroup("encoder", ["y"], rate=10.0, noise_std=PEND_STD),
                   process_noise=PEND_Q, seed=8)
    assert run.t.size == 61 and run.sampled[::2, 0].all() and not run.sampled[1::2, 0].any()
    s = smooth_run(ekf, run, 0.0)
    quiet = ~run.sampled[1:, 0]
    # measured: 0 and 0 (the step is the run's dt, as the loop took it)
    assert np.abs(s.x_pred[:, quiet] - run.x_hat[:, 1:][:, quiet]).max() < 1e-12
    assert np.abs(s.P_pred[:, quiet] - run.extras["P"][:, 1:][:, quiet]).max() < 1e-12
    # one RK4 step of 0.05 s instead of five of 0.01 s is a different prediction (measured 1.1e-6): the step matters
    one = rts_smooth(ekf, run.t, run.x_hat, run.extras["P"], 0.0)
    assert np.abs(one.x_pred[:, quiet] - run.x_hat[:, 1:][:, quiet]).max() > 1e-9


def test_a_batch_smooths_as_its_members() -> None:
    filt, run = _pendulum_runs(nlobs.EKF, runs=3, duration=2.0)
    s = smooth_run(filt, run, 0.0)
    assert s.x.shape == (3, 201, 2) and s.P.shape == (3, 201, 2, 2) and s.gains.shape == (3, 200, 2, 2)
    for i in range(3):
        one = rts_smooth(filt, run.t, run.x_hat[i], run.extras["P"][i], np.zeros((run.t.size, 1)))
        assert np.abs(one.x - s.x[i]).max() < 1e-12
        assert np.abs(one.P - s.P[i]).max() < 1e-12


def test_the_result_is_frozen_and_read_only() -> None:
    u = np.zeros((K, 1))
    ekf, res, _, _ = _discrete_run(nlobs.EKF, u)
    s = smooth_run(ekf, res, u)
    assert isinstance(s, Smoothed)
    for name in ("t", "x", "P", "gains", "x_pred", "P_pred"):
        assert not getattr(s, name).flags.writeable, name
    with pytest.raises(AttributeError):
        s.x = s.x  # type: ignore[misc]
    assert np.array_equal(s.P, np.swapaxes(s.P, -1, -2))
    assert np.allclose(s.std, np.sqrt(np.diagonal(s.P, 0, -2, -1)))


def test_one_time_is_the_filter_itself() -> None:
    ekf = nlobs.EKF(nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0)),
                    Q=[[1.0]], R=[[1.0]], P0=[[1.0]])
    s = rts_smooth(ekf, [0.0], [[0.5]], [[[2.0]]], None)
    assert s.x.tolist() == [[0.5]] and s.P.tolist() == [[[2.0]]] and s.gains.shape == (0, 1, 1)


# ---------------------------------------------------------------------------------------------- errors
def _two_state_ekf(Qd: np.ndarray | None = None) -> nlobs.EKF:
    plant = nlobs.LinearSystem(np.diag([1.0, 0.0]), np.zeros((2, 0)), [[1.0, 0.0]], time=nlobs.Discrete(0.5))
    return nlobs.EKF(plant, Q=np.eye(2) if Qd is None else Qd, R=[[1.0]], P0=np.eye(2))


GOOD = {"t": [0.0, 0.5, 1.0], "x": np.zeros((3, 2)), "P": np.broadcast_to(np.eye(2), (3, 2, 2)), "u": None}


@pytest.mark.parametrize(("change", "error", "text"), [
    ({"x": np.zeros((3, 3))}, DimensionError, "x: expected shape (..., 3, 2), got (3, 3)"),
    ({"P": np.zeros((3, 2))}, DimensionError, "P: expected shape (..., 3, 2, 2), got (3, 2)"),
    ({"x": np.zeros((2, 3, 2)), "P": np.broadcast_to(np.eye(2), (3, 3, 2, 2))}, DimensionError,
     "batch shapes do not broadcast"),
    ({"u": np.zeros((3, 1))}, DimensionError, "u: expected shape (..., 3, 0), got (3, 1)"),
    ({"x": np.array([[0.0, 0.0], [0.0, np.nan], [0.0, 0.0]])}, NonFiniteError, "x: not finite at t = 0.5 (index 1)"),
    ({"P": np.stack([np.eye(2), np.eye(2), np.full((2, 2), np.inf)])}, NonFiniteError,
     "P: not finite at t = 1 (index 2)"),
    ({"t": [0.0, 0.5, 0.5]}, InvalidArgumentError, "t: not strictly increasing at index 2"),
    ({"t": [0.0, 0.5, np.nan]}, NonFiniteError, "t: entry (2,)"),
    ({"t": [0.0, 0.5, 1.25]}, InvalidArgumentError, "not a whole number of steps of dt = 0.5"),
])
def test_bad_input_is_a_typed_one_line_error(change: dict, error: type, text: str) -> None:
    args = {**GOOD, **change}
    with pytest.raises(error) as exc:
        rts_smooth(_two_state_ekf(), args["t"], args["x"], args["P"], args["u"])
    assert text in str(exc.value) and "\n" not in str(exc.value)


def test_a_singular_prediction_names_its_time() -> None:
    # x₂⁺ = 0 with no process noise on it: P⁻ = diag(·, 0) from the first step on
    ekf = _two_state_ekf(np.diag([1.0, 0.0]))
    with pytest.raises(InvalidArgumentError, match=r"predicted covariance at t = 0\.5 \(index 1\) is singular"):
        rts_smooth(ekf, GOOD["t"], GOOD["x"], GOOD["P"], None)


def test_a_filter_that_is_not_an_ekf_or_a_ukf_is_refused() -> None:
    plant = nlobs.LinearSystem([[0.0]], [[1.0]], [[1.0]])
    with pytest.raises(InvalidArgumentError, match="filter: expected an EKF or a UKF, got LuenbergerObserver"):
        rts_smooth(nlobs.LuenbergerObserver(plant, [[1.0]]), [0.0], [[0.0]], [[[1.0]]], [0.0])


def test_the_input_is_checked() -> None:
    ekf = nlobs.EKF(nlobs.load_model("pendulum").compile(), Q=PEND_Q, R=[[1.0]], P0=np.eye(2))
    args = ([0.0, 0.01], np.zeros((2, 2)), np.broadcast_to(np.eye(2), (2, 2, 2)))
    with pytest.raises(DimensionError, match=r"u: the plant has 1 input; give u of shape \(\.\.\., 2, 1\)"):
        rts_smooth(ekf, *args, None)
    with pytest.raises(NonFiniteError, match=r"u: not finite at t = 0\.01 \(index 1\)"):
        rts_smooth(ekf, *args, [[0.0], [np.inf]])
    with pytest.raises(DimensionError, match=r"u: expected shape \(1,\) for a constant input"):
        rts_smooth(ekf, *args, [0.0, 1.0])
    with pytest.raises(InvalidArgumentError, match="dt: expected a positive finite step"):
        rts_smooth(ekf, *args, 0.0, dt=-1.0)
    # a constant and a scalar are the held record of that value
    a, b = rts_smooth(ekf, *args, 0.2), rts_smooth(ekf, *args, [[0.2], [0.2]])
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)


def test_a_run_without_covariance_is_refused() -> None:
    plant = nlobs.LinearSystem(A, B, C, time=nlobs.Discrete(1.0))
    ekf = nlobs.EKF(plant, Q=Q, R=R, P0=P0)  # record_covariance=False
    res = run_observer(ekf, np.arange(5.0), x_hat0=XH0, u=np.zeros((5, 1)), y=np.zeros((5, 1)))
    with pytest.raises(InvalidArgumentError, match="no covariance recorded.*record_covariance=True"):
        smooth_run(ekf, res, np.zeros((5, 1)))
    with pytest.raises(InvalidArgumentError, match="result: expected a SimulationResult"):
        smooth_run(ekf, object(), None)


def test_a_run_that_recorded_its_input_is_smoothed_with_it() -> None:
    """``smooth_run`` without ``u`` takes the run's recorded ``extras["u"]`` (a closed loop records the input it held)."""
    import types

    plant = nlobs.load_model("pendulum").compile()
    t = np.arange(41) * 0.05
    tau = 0.4 * np.sin(3.0 * t)[:, None]
    ekf = nlobs.EKF(plant, Q=PEND_Q, R=[[PEND_STD**2]], P0=0.2 * np.eye(2), record_covariance=True)
    res = run_observer(ekf, t, x_hat0=[0.4, 0.0], u=tau, y=(0.5 * np.cos(3.0 * t[::4]))[:, None], y_times=t[::4])
    logged = types.SimpleNamespace(t=res.t, x_hat=res.x_hat, dt=res.dt, extras={**res.extras, "u": tau})
    a, b = smooth_run(ekf, logged), smooth_run(ekf, res, tau)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.P, b.P)
    assert np.abs(smooth_run(ekf, res, 0.0).x - b.x).max() > 1e-3  # the input matters
    with pytest.raises(DimensionError, match="u: the plant has 1 input"):
        smooth_run(ekf, res)  # no input given and none recorded
