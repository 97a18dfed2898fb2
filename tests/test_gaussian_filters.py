"""The EKF and the UKF of nlobs against independent sources.

* discrete linear plant: both equal ``filterpy.kalman.KalmanFilter`` (update then predict) to 1e-10;
* continuous linear plant sampled every ``T``: both converge, at RK4's fourth order in the step, to
  filterpy's filter on the exact discretisation (``expm(A T)``, Van Loan's ``Q_d``);
* a nonlinear pendulum with process noise drawn here: NEES and NIS over 200 Monte Carlo runs stay in
  the two-sided 95 % chi-square band at most sample times;
* missing samples and multi-rate masks against a correction written out here; a batch against its
  members one by one; typed errors for bad arguments; the two loops.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from filterpy.kalman import KalmanFilter
from scipy.stats import chi2

from nlobs import EKF, UKF, Continuous, Discrete, LinearSystem
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError, NotSymmetricError, SimulationDiverged
from nlobs.observers.base import CorrectingObserver, Diagnosing
from nlobs.simulate import MeasurementGroup, rk4_step, run_observer, simulate
from nlobs.systems.symbolic import SymbolicModel

FILTERS = (EKF, UKF)


def _stable_system(rng: np.random.Generator, n: int = 3, m: int = 1, p: int = 2):  # type: ignore[no-untyped-def]
    A = rng.standard_normal((n, n))
    A *= 0.9 / np.max(np.abs(np.linalg.eigvals(A)))  # spectral radius 0.9
    return A, rng.standard_normal((n, m)), rng.standard_normal((p, n))


def _filterpy(A, B, C, Q, R, P0, x0, us, ys):  # type: ignore[no-untyped-def]
    """filterpy's posteriors: at each step ``update(y_k)`` (recorded), then ``predict(u_k)``."""
    kf = KalmanFilter(dim_x=A.shape[0], dim_z=C.shape[0], dim_u=B.shape[1])
    kf.F, kf.B, kf.H, kf.Q, kf.R, kf.P, kf.x = A, B, C, Q, R, P0.copy(), x0.copy()
    xs, Ps = [], []
    for u, y in zip(us, ys, strict=True):
        kf.update(y)
        xs.append(kf.x.copy())
        Ps.append(kf.P.copy())
        kf.predict(u=u)
    return np.array(xs), np.array(Ps)


# ----------------------------------------------------------------------------- 1. discrete linear
@pytest.mark.parametrize("cls", FILTERS, ids=lambda c: c.__name__)
def test_discrete_linear_equals_filterpy(cls: type) -> None:
    rng = np.random.default_rng(11)
    A, B, C = _stable_system(rng)
    Q = np.diag([0.02, 0.01, 0.03])
    R = np.array([[0.1, 0.02], [0.02, 0.2]])
    P0 = np.diag([1.0, 2.0, 0.5])
    K = 250
    us = rng.standard_normal((K, 1))
    x = rng.standard_normal(3)
    ys = np.empty((K, 2))
    for k in range(K):  # x_{k+1} = A x_k + B u_k + w_k, y_k = C x_k + v_k
        ys[k] = C @ x + rng.multivariate_normal(np.zeros(2), R)
        x = A @ x + B @ us[k] + rng.multivariate_normal(np.zeros(3), Q)
    x_hat0 = np.array([0.5, -0.5, 1.0])
    filt = cls(LinearSystem(A, B, C, time=Discrete(0.1)), Q, R, P0, record_covariance=True)
    res = run_observer(filt, 0.1 * np.arange(K), x_hat0=x_hat0, u=us, y=ys)
    want_x, want_P = _filterpy(A, B, C, Q, R, P0, x_hat0, us, ys)
    np.testing.assert_allclose(res.x_hat, want_x, rtol=0, atol=1e-10)  # measured 1.8e-15 (EKF), 2.7e-15 (UKF)
    np.testing.assert_allclose(res.extras["P"], want_P, rtol=0, atol=1e-10)  # 6.9e-17, 1.4e-15
    np.testing.assert_allclose(res.extras["P_diag"], np.diagonal(want_P, axis1=1, axis2=2), rtol=0, atol=1e-10)


# ----------------------------------------------------------------------------- 2. continuous linear
A_C = np.array([[0.0, 1.0, 0.0], [-4.0, -0.6, 1.0], [0.0, 0.0, -2.0]])
B_C = np.array([[0.0], [1.0], [0.5]])
C_C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
Q_C = np.diag([0.0, 0.5, 0.2])
R_C = np.diag([0.01, 0.02])
P0_C = np.eye(3)
T_SAMPLE = 0.1
N_SAMPLES = 40


def _exact_discretisation(A, B, Q, T):  # type: ignore[no-untyped-def]
    """``F = expm(A T)``, ``B_d = ∫₀ᵀ expm(A s) ds B`` (held input) and Van Loan's ``Q_d``."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = sla.expm(M * T)
    F, Bd = E[:n, :n], E[:n, n:]
    V = sla.expm(np.block([[-A, Q], [np.zeros((n, n)), A.T]]) * T)  # Van Loan (1978)
    Qd = V[n:, n:].T @ V[:n, n:]
    return F, Bd, 0.5 * (Qd + Qd.T)


def _continuous_difference(cls: type, dt: float) -> float:
    rng = np.random.default_rng(5)
    steps = round(T_SAMPLE / dt)
    us = rng.standard_normal((N_SAMPLES, 1))
    ys = rng.standard_normal((N_SAMPLES, 2))
    t = dt * np.arange(N_SAMPLES * steps)
    u_grid = np.repeat(us, steps, axis=0)  # held over each sample period
    filt = cls(LinearSystem(A_C, B_C, C_C), Q_C, R_C, P0_C, record_covariance=True)
    x_hat0 = np.array([1.0, 0.0, -1.0])
    res = run_observer(filt, t, x_hat0=x_hat0, u=u_grid, y=ys, y_times=T_SAMPLE * np.arange(N_SAMPLES))
    F, Bd, Qd = _exact_discretisation(A_C, B_C, Q_C, T_SAMPLE)
    want_x, want_P = _filterpy(F, Bd, C_C, Qd, R_C, P0_C, x_hat0, us, ys)
    at = np.arange(N_SAMPLES) * steps
    return max(float(np.max(np.abs(res.x_hat[at] - want_x))), float(np.max(np.abs(res.extras["P"][at] - want_P))))


@pytest.mark.parametrize("cls", FILTERS, ids=lambda c: c.__name__)
def test_continuous_linear_converges_at_fourth_order_to_the_exact_discretisation(cls: type) -> None:
    d1, d2, d3 = (_continuous_difference(cls, dt) for dt in (1e-2, 5e-3, 1e-3))
    assert d1 / d2 > 10.0  # RK4: 2⁴ = 16 per halving (measured 15.5 for both filters)
    assert d3 < 2e-10  # measured 1.9e-11 (EKF and UKF)
    assert d1 < 5e-7  # measured 1.9e-7 (at dt = 5e-3: 1.2e-8)


# ----------------------------------------------------------------------------- 3. NEES and NIS
PEND_DT = 0.05
PEND_Q = np.diag([1e-6, 4e-4])
PEND_R = np.diag([0.05**2, 0.1**2])
PEND_P0 = np.diag([0.1**2, 0.2**2])


def _pendulum():  # type: ignore[no-untyped-def]
    """Damped pendulum, explicit Euler at 50 ms: ``θ⁺ = θ + dt ω``, ``ω⁺ = ω + dt (−(g/l) sin θ − c ω + u)``.

    Outputs: ``sin θ`` (the horizontal position of the bob over ``l``) and ``ω`` (a rate gyro).
    """
    return SymbolicModel.general(["th", "om"], ["u"], ["s", "w"],
                                 ["th + dt*om", "om + dt*(-(g/l)*sin(th) - c*om + u)"], ["sin(th)", "om"],
                                 parameters={"dt": PEND_DT, "g": 9.81, "l": 1.0, "c": 0.3},
                                 time=Discrete(PEND_DT), name="pendulum").compile()


def _monte_carlo(cls: type, runs: int = 200, steps: int = 200):  # type: ignore[no-untyped-def]
    plant = _pendulum()
    rng = np.random.default_rng(0)
    x_hat0 = np.array([0.6, 0.0])
    x = x_hat0 + rng.multivariate_normal(np.zeros(2), PEND_P0, size=runs)  # the truth drawn from the prior
    u = np.zeros((runs, 1))
    xs, ys = np.empty((runs, steps, 2)), np.empty((runs, steps, 2))
    for k in range(steps):
        xs[:, k] = x
        ys[:, k] = plant.output(0.0, x, u) + rng.multivariate_normal(np.zeros(2), PEND_R, size=runs)
        x = plant.rhs(0.0, x, u) + rng.multivariate_normal(np.zeros(2), PEND_Q, size=runs)
    filt = cls(plant, PEND_Q, PEND_R, PEND_P0, record_covariance=True)
    res = run_observer(filt, PEND_DT * np.arange(steps), x_hat0=np.broadcast_to(x_hat0, (runs, 2)),
                       u=np.zeros((steps, 1)), y=ys, truth=xs)
    e = res.x - res.x_hat
    nees = np.einsum("rki,rki->rk", e, np.linalg.solve(res.extras["P"], e[..., None])[..., 0])
    return nees.mean(axis=0), res.extras["nis"].mean(axis=0)


def _inside(mean: np.ndarray, runs: int, dof: int) -> float:
    lo, hi = chi2.ppf([0.025, 0.975], runs * dof) / runs
    return float(np.mean((mean >= lo) & (mean <= hi)))


@pytest.mark.parametrize("cls", FILTERS, ids=lambda c: c.__name__)
def test_nees_and_nis_are_consistent_on_a_pendulum(cls: type) -> None:
    """Mean NEES (2 dof) and NIS (2 dof) over 200 runs inside the 95 % band at ≥ 85 % of the 200 sample times.

    For a consistent filter each sample time is inside with probability 0.95 (the times are correlated,
    so the fraction scatters more than a binomial one would); 85 % leaves room for that scatter and for
    the small linearisation error of a 50 ms step of a pendulum swinging ±0.6 rad. Measured: NEES 0.91,
    NIS 0.98 (EKF and UKF alike); over 20 other noise draws the smallest fraction was 0.905 and the
    mean 0.944 (NEES), 0.92 and 0.947 (NIS).
    """
    nees, nis = _monte_carlo(cls)
    assert _inside(nees, 200, 2) >= 0.85
    assert _inside(nis, 200, 2) >= 0.85


# ----------------------------------------------------------------------------- 4. missing and multi-rate
def _hand_update(x, P, C, R, y):  # type: ignore[no-untyped-def]
    """The textbook correction ``K = P Cᵀ (C P Cᵀ + R)⁻¹``, ``x + K (y − C x)``, ``(I − K C) P``."""
    K = P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    return x + K @ (y - C @ x), (np.eye(len(x)) - K @ C) @ P


@pytest.mark.parametrize("cls", FILTERS, ids=lambda c: c.__name__)
def test_missing_sample_skips_that_member_and_masks_select_rows(cls: type) -> None:
    rng = np.random.default_rng(3)
    A, B, C = _stable_system(rng)
    R = np.array([[0.1, 0.03], [0.03, 0.2]])
    P0 = np.array([[1.0, 0.2, 0.0], [0.2, 2.0, 0.1], [0.0, 0.1, 0.5]])
    filt = cls(LinearSystem(A, B, C, time=Discrete(0.1)), 0.01 * np.eye(3), R, P0)
    x_hat0 = np.array([[0.1, 0.2, 0.3], [-0.3, 0.0, 0.4], [0.5, 0.5, -0.5]])
    z = filt.init(x_hat0)
    u = np.zeros((3, 1))
    y = np.array([[1.0, -1.0], [np.nan, 0.5], [np.nan, np.nan]])
    out = filt.correct(0.0, z, u, y, np.ones(2, dtype=bool))
    x0, P0_0 = _hand_update(x_hat0[0], P0, C, R, y[0])
    x1, P0_1 = _hand_update(x_hat0[1], P0, C[1:], R[1:, 1:], y[1, 1:])
    np.testing.assert_allclose(out.x[0], x0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.P[0], P0_0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.x[1], x1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.P[1], P0_1, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(out.x[2], x_hat0[2])  # nothing left: unchanged
    np.testing.assert_array_equal(out.P[2], P0)
    assert out.nis[2] == 0.0 and np.all(out.nis[:2] > 0)
    # multi-rate: only output 1 is fresh (output 0's value is stale and must be ignored)
    fresh = np.array([False, True])
    out = filt.correct(0.0, z, u, np.array([[7.0, -1.0], [7.0, 0.5], [7.0, 0.25]]), fresh)
    for b, yb in enumerate((-1.0, 0.5, 0.25)):
        xb, Pb = _hand_update(x_hat0[b], P0, C[1:], R[1:, 1:], np.array([yb]))
        np.testing.assert_allclose(out.x[b], xb, rtol=0, atol=1e-12)
        np.testing.assert_allclose(out.P[b], Pb, rtol=0, atol=1e-12)
    # nothing fresh: the same state
    assert filt.correct(0.0, z, u, y, np.zeros(2, dtype=bool)) is z


@pytest.mark.parametrize("cls", FILTERS, ids=lambda c: c.__name__)
def test_a_missing_sample_in_run_observer_changes_that_run_only(cls: type) -> None:
    rng = np.random.default_rng(8)
    A, B, C = _stable_system(rng)
    filt = cls(LinearSystem(A, B, C, time=Discrete(0.1)), 0.01 * np.eye(3), 0.1 * np.eye(2), np.eye(3))
    y = np.broadcast_to(rng.standard_normal((30, 2)), (2, 30, 2)).copy()
    y[1, 10, 0] = np.nan
    res = run_observer(filt, 0.1 * np.arange(30), x_hat0=np.zeros(3), u=np.zeros((30, 1)), y=y)
    np.testing.assert_array_equal(res.info["missing"], [0, 1])
    np.testing.assert_array_equal(res.x_hat[0, :10], res.x_hat[1, :10])
    assert not np.allclose(res.x_hat[0, 10:], res.x_hat[1, 10:], rtol=0, atol=1e-9)
    assert np.isfinite(res.x_hat).all()


# ----------------------------------------------------------------------------- 5. batch = members
def _van_der_pol(discrete: bool = False):  # type: ignore[no-untyped-def]
    """Van der Pol, ``μ = 1``, output ``x1 + 0.1 x2²``; discrete: one explicit Euler step of 50 ms."""
    f = ["x2", "mu*(1 - x1**2)*x2 - x1"]
    if discrete:
        f = ["x1 + dt*x2", "x2 + dt*(mu*(1 - x1**2)*x2 - x1)"]
    return SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f, [[0], ["dt" if discrete else 1]],
                                      ["x1 + 0.1*x2**2"], parameters={"mu": 1.0, "dt": 0.05},
                                      time=Discrete(0.05) if discrete else Continuous(), name="van der Pol").compile()


@pytest.mark.parametrize("discrete", [False, True], ids=["continuous", "discrete"])
@pytest.mark.parametrize("cls", FILTERS, ids=lambda c: c.__name__)
def test_a_batch_of_five_equals_five_single_runs(cls: type, discrete: bool) -> None:
    plant = _van_der_pol(discrete)
    filt = cls(plant, np.diag([1e-3, 1e-2]), np.array([[0.05]]), np.diag([0.5, 0.3]))
    rng = np.random.default_rng(1)
    x_hat0 = rng.standard_normal((5, 2))
    us = 0.3 * rng.standard_normal((20, 5, 1))
    ys = rng.standard_normal((20, 5, 1))
    fresh = np.ones(1, dtype=bool)

    def run(x: np.ndarray, u: np.ndarray, y: np.ndarray):  # type: ignore[no-untyped-def]
        z = filt.init(x)
        for k in range(20):
            z = filt.correct(0.05 * k, z, u[k], y[k], fresh)
            if discrete:
                z = filt.rhs(0.05 * k, z, u[k], y[k])
            else:
                z = rk4_step(lambda t, zz: filt.rhs(t, zz, u[k], y[k]), 0.05 * k, z, 0.05)
        return z

    batch = run(x_hat0, us, ys)
    for b in range(5):
        one = run(x_hat0[b], us[:, b], ys[:, b])
        assert one.x.shape == (2,) and one.P.shape == (2, 2)
        np.testing.assert_allclose(batch.x[b], one.x, rtol=0, atol=1e-12)
        np.testing.assert_allclose(batch.P[b], one.P, rtol=0, atol=1e-12)
        np.testing.assert_allclose(batch.nis[b], one.nis, rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------- 6. bad input
def _linear() -> LinearSystem:
    return LinearSystem(np.eye(2), np.zeros((2, 1)), np.array([[1.0, 0.0]]), time=Discrete(0.1))


@pytest.mark.parametrize("cls", FILTERS, ids=lambda c: c.__name__)
@pytest.mark.parametrize(("Q", "R", "P0", "error", "match"), [
    ([[1.0, 0.5], [0.0, 1.0]], [[1.0]], np.eye(2), NotSymmetricError, "Q: not symmetric"),
    ([[1.0, 0.0], [0.0, -0.5]], [[1.0]], np.eye(2), InvalidArgumentError,
     r"Q: not symmetric positive semi-definite \(smallest eigenvalue -0.5\)"),
    (np.eye(2), [[0.0]], np.eye(2), InvalidArgumentError, r"R: not symmetric positive definite \(smallest eigenvalue 0\)"),
    (np.eye(2), [[-0.5]], np.eye(2), InvalidArgumentError, "R: not symmetric positive definite"),
    (np.eye(3), [[1.0]], np.eye(2), DimensionError, r"Q: expected shape \(2, 2\)"),
    (np.eye(2), np.eye(2), np.eye(2), DimensionError, r"R: expected shape \(1, 1\)"),
    (np.eye(2), [[1.0]], [1.0, 1.0], DimensionError, "P0: expected a 2-d matrix"),
    (np.eye(2), [[np.nan]], np.eye(2), NonFiniteError, "R: entry"),
    (np.eye(2), [[1.0]], [[1.0, 0.0], [0.0, np.inf]], NonFiniteError, "P0: entry"),
    (np.eye(2), [[1.0]], [[1.0, 2.0], [2.0, 1.0]], InvalidArgumentError, "P0: not symmetric positive semi-definite"),
])
def test_bad_covariances_are_typed_errors(cls: type, Q, R, P0, error: type, match: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(error, match=match):
        cls(_linear(), Q, R, P0)


class _NoJacobians:
    """A plant with ``rhs`` and ``output`` only."""

    time = Continuous()
    states, inputs, outputs = ("a", "b"), (), ("y",)
    n, m, p = 2, 0, 1

    def rhs(self, t, x, u):  # type: ignore[no-untyped-def]
        return np.stack([x[..., 1], -np.sin(x[..., 0])], axis=-1)

    def output(self, t, x, u):  # type: ignore[no-untyped-def]
        return x[..., :1]


def test_the_ekf_names_the_missing_jacobians_and_the_ukf_needs_none() -> None:
    with pytest.raises(InvalidArgumentError, match=r"rhs_jacobian_x\(t, x, u\), output_jacobian_x\(t, x, u\).*_NoJacobians"):
        EKF(_NoJacobians(), np.eye(2), [[1.0]], np.eye(2))
    ukf = UKF(_NoJacobians(), 1e-3 * np.eye(2), [[0.01]], np.eye(2))
    res = simulate(_NoJacobians(), ukf, [1.0, 0.0], [0.5, 0.3], duration=5.0, dt=0.01,
                   measurements=MeasurementGroup("angle", [0], rate=20.0, noise_std=0.1), seed=1)
    assert res.error_norm[-1] < 0.2 * res.error_norm[0]


def test_other_bad_arguments() -> None:
    with pytest.raises(InvalidArgumentError, match="plant: expected a PlantModel"):
        EKF(object(), np.eye(2), [[1.0]], np.eye(2))  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="alpha"):
        UKF(_linear(), np.eye(2), [[1.0]], np.eye(2), alpha=0.0)
    with pytest.raises(InvalidArgumentError, match="kappa"):
        UKF(_linear(), np.eye(2), [[1.0]], np.eye(2), kappa=-2.0)
    filt = EKF(_linear(), np.eye(2), [[1.0]], np.eye(2))
    with pytest.raises(DimensionError, match="x_hat0"):
        filt.init(np.zeros(3))
    with pytest.raises(NonFiniteError, match="x_hat0"):
        filt.init([np.nan, 0.0])
    with pytest.raises(DimensionError, match="fresh"):
        filt.correct(0.0, filt.init(np.zeros(2)), np.zeros(1), np.zeros(1), np.ones(2, dtype=bool))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # inf − inf on the way (the loops silence these)
@pytest.mark.parametrize("cls", FILTERS, ids=lambda c: c.__name__)
def test_a_non_finite_innovation_covariance_is_divergence(cls: type) -> None:
    filt = cls(_linear(), np.eye(2), [[1.0]], np.eye(2))
    z = filt.init(np.zeros(2))
    bad = type(z)(x=z.x, P=np.full((2, 2), np.inf), nis=z.nis)
    with pytest.raises(SimulationDiverged, match=f"{filt.name} diverged at t = 1.5"):
        filt.correct(1.5, bad, np.zeros(1), np.ones(1), np.ones(1, dtype=bool))


# ----------------------------------------------------------------------------- 7. the loops
@pytest.mark.parametrize("cls", FILTERS, ids=lambda c: c.__name__)
def test_simulate_and_run_observer(cls: type) -> None:
    """Van der Pol observed through a 20 Hz noisy sensor: the error falls by 10 in 8 s; the replay agrees."""
    plant = _van_der_pol()
    filt = cls(plant, np.diag([1e-4, 1e-3]), np.array([[0.05**2]]), np.diag([1.0, 1.0]))
    assert isinstance(filt, CorrectingObserver) and isinstance(filt, Diagnosing)
    x0 = np.array([[2.0, 0.0], [-1.0, 1.5], [0.5, -2.0]])
    x_hat0 = np.array([0.0, 0.5])
    group = MeasurementGroup("y", [0], rate=20.0, noise_std=0.05)
    res = simulate(plant, filt, x0, x_hat0, duration=8.0, dt=0.01, u=[0.0], measurements=group, seed=4)
    assert res.x_hat.shape == (3, 801, 2) and res.extras["P_diag"].shape == (3, 801, 2)
    assert res.extras["nis"].shape == (3, 801)
    tail = np.mean(res.error_norm[:, -100:], axis=1)
    assert np.all(tail < 0.1 * res.error_norm[:, 0])
    assert np.all(res.extras["P_diag"][:, -1] < 0.05)  # from 1.0
    rep = run_observer(filt, res.t, x_hat0=x_hat0, u=np.zeros((res.t.size, 1)), y=res.y, sampled=res.sampled,
                       truth=res.x)
    np.testing.assert_allclose(rep.x_hat, res.x_hat, rtol=0, atol=1e-10)


def test_ukf_with_a_singular_covariance_falls_back_to_the_eigen_square_root() -> None:
    """``P0`` with a zero variance (Cholesky fails): the UKF still equals filterpy's Kalman filter."""
    rng = np.random.default_rng(21)
    A, B, C = _stable_system(rng)
    Q, R, P0 = np.diag([0.0, 0.01, 0.02]), np.diag([0.1, 0.2]), np.diag([1.0, 0.0, 0.5])
    us, ys = rng.standard_normal((60, 1)), rng.standard_normal((60, 2))
    filt = UKF(LinearSystem(A, B, C, time=Discrete(0.1)), Q, R, P0, record_covariance=True)
    res = run_observer(filt, 0.1 * np.arange(60), x_hat0=np.zeros((2, 3)), u=us, y=ys)
    want_x, want_P = _filterpy(A, B, C, Q, R, P0, np.zeros(3), us, ys)
    for b in range(2):  # both members (their Cholesky factorisation fails at the first steps)
        np.testing.assert_allclose(res.x_hat[b], want_x, rtol=0, atol=1e-10)
        np.testing.assert_allclose(res.extras["P"][b], want_P, rtol=0, atol=1e-10)
