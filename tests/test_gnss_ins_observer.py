"""The GNSS/INS observer (22)–(24) of Grip, Saberi & Johansen, Sec. 5, checked against independent references.

* truth: closed-form kinematics (``test_gnss_ins_synthetic.py``, checked there by
  finite differences) and the traffic-pattern flight of ``navigation.trajectory``;
* the linear part (24a)–(24c): the error of ``(p̂, v̂, ẑ)`` compared with
  ``scipy.linalg.expm`` of the linear error system written out by hand from (21),
  for motions with constant ``aⁿ`` (then ``d = ż = 0`` and the error system is
  exactly linear, whatever ``R̂`` does);
* convergence orders (RK4: 4; the held IMU sample: 1; the split step against the flow of
  ``rhs``: 3 locally) instead of single numbers;
* the observer protocol: ``rhs``/``step``/``correct``/``estimate`` and the deferred projection.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from test_gnss_ins_synthetic import G_N, M_N, turn_data

from nlobs.errors import DimensionError, InvalidArgumentError, NotSymmetricError
from nlobs.navigation import metrics as M
from nlobs.navigation.base import G0, GnssSample, ImuSample, SensorData, nav_vector
from nlobs.navigation.gains import PAPER_GAMMA, paper_gains
from nlobs.navigation.gnss_ins import GnssInsObserver, GnssInsState, triad_J, triad_matrix
from nlobs.navigation.run import run_navigation
from nlobs.navigation.so3 import exp_so3, project_so3, rot_x, rot_z
from nlobs.observers.base import CorrectingObserver, DeferredEstimate, Diagnosing, SelfStepping
from nlobs.simulate.state import tree_map
from nlobs.systems.timebase import Continuous

I3, Z3 = np.eye(3), np.zeros((3, 3))
A9 = np.block([[Z3, I3, Z3], [Z3, Z3, I3], [Z3, Z3, Z3]])  # 𝔄 of (8c): ṗ = v, v̇ = z (+ gⁿ), ż = d
C9 = np.block([[I3, Z3, Z3], [Z3, I3, Z3]])                # ℭ: p and v measured


def _rand_rot(rng):
    return exp_so3(rng.normal(size=3))


# ------------------------------------------------------------------ J of (22)
def test_triad_J_vanishes_at_the_truth_and_is_linear_in_the_error():
    rng = np.random.default_rng(1)
    R = _rand_rot(rng)
    m_b, a_b = rng.normal(size=3), rng.normal(size=3)
    m_n, a_n = R @ m_b, R @ a_b
    np.testing.assert_allclose(triad_J(m_b, m_n, a_b, a_n, R), np.zeros((3, 3)), atol=1e-12)
    Ab = np.column_stack([m_b, np.cross(m_b, a_b), np.cross(m_b, np.cross(m_b, a_b))])  # numpy's cross
    np.testing.assert_allclose(triad_matrix(m_b, a_b), Ab)
    Rh = rng.normal(size=(3, 3))
    np.testing.assert_allclose(triad_J(m_b, m_n, a_b, a_n, Rh), (R - Rh) @ Ab @ Ab.T, atol=1e-12)
    # columns orthogonal: A_bᵀA_b diagonal
    G = Ab.T @ Ab
    np.testing.assert_allclose(G - np.diag(np.diag(G)), 0.0, atol=1e-12)


# --------------------------------------------------------- exact data, truth
def test_observer_started_at_the_truth_stays_there_first_order_in_the_imu_period():
    errs = {}
    for rate in (50.0, 100.0):
        d = turn_data(20.0, imu_rate_hz=rate)
        obs = GnssInsObserver.paper(d.m_n, d.g_n)  # intersample="predict"
        r = run_navigation(obs, d, d.p[0], d.v[0], d.R[0])
        errs[rate] = np.array([M.position_error_m(r).max(), M.velocity_error_mps(r).max(),
                               M.attitude_error_deg(r).max()])
    # measured at 100 Hz: 1.0e-4 m, 8.2e-4 m/s, 0.016°; the held IMU sample (ZOH) makes it O(dt)
    assert np.all(errs[100.0] < [5e-4, 4e-3, 0.05])
    ratio = errs[50.0] / errs[100.0]
    assert np.all((ratio > 1.7) & (ratio < 2.5)), ratio


def test_zero_order_hold_of_the_fix_lags_the_aircraft():
    # the literal sample-and-hold: p̂ is pulled back to a fix up to v·T_gnss old (V = 50 m/s, 5 Hz → 10 m)
    d = turn_data(10.0)
    obs = GnssInsObserver.paper(d.m_n, d.g_n, intersample="hold")
    r = run_navigation(obs, d, d.p[0], d.v[0], d.R[0])
    lag = M.position_error_m(r)[200:].max()
    assert 0.8 * 10.0 < lag < 10.0  # measured 9.55 m
    assert M.attitude_error_deg(r).max() > 0.1  # ≈ 0.5° (vs 0.016° with the predictor)


# ------------------------------------------------------- linear part (24a–c)
def _const_an_data(T, *, rate=100.0, grate=5.0, a_b=(0.0, 0.0, -(G0 + 1.5)), r=0.2, R0=None, v0=(30.0, 5.0, -1.0)):
    """Rotation about the a^b axis at a constant rate: aⁿ = R a^b constant, so d = ż = 0."""
    K = round(T * rate) + 1
    t = np.arange(K) / rate
    ab = np.asarray(a_b)
    w = r * ab / np.linalg.norm(ab)
    R0 = np.eye(3) if R0 is None else R0
    R = R0 @ exp_so3(t[:, None] * w)
    a_n = R0 @ ab
    alpha = a_n + G_N  # v̇ⁿ
    v = np.asarray(v0) + t[:, None] * alpha
    p = np.array([0.0, 0.0, -100.0]) + np.asarray(v0) * t[:, None] + 0.5 * t[:, None] ** 2 * alpha
    m_b = np.einsum("kji,j->ki", R, M_N)
    gi = np.arange(0, K, round(rate / grate))
    d = SensorData(t, np.tile(w, (K, 1)), np.tile(ab, (K, 1)), m_b, t[gi], p[gi], v[gi], M_N, G_N, p, v, R, rate, grate)
    return d, a_n


def _error_trajectory(obs, d, a_n, dp0, dv0, xi0):
    """Run the observer by hand (R̂(0) = R(0), ξ(0) = xi0) and return w̃ = [p − p̂, v − v̂, aⁿ − ẑ] at t_imu."""
    st = obs.init_state(d.p[0] - dp0, d.v[0] - dv0, d.R[0], xi0=xi0)
    K = len(d.t_imu)
    dt = 1.0 / d.imu_rate_hz
    fix = {round(tg * d.imu_rate_hz): i for i, tg in enumerate(d.t_gnss)}
    err = np.zeros((K, 9))
    for k in range(K):
        if k in fix:
            st = obs.update(st, GnssSample(d.p_gnss[fix[k]], d.v_gnss[fix[k]], np.array(True)))
        imu = ImuSample(d.omega_b[k], d.a_b[k], d.m_b[k])
        u = np.concatenate([imu.omega_b, imu.a_b, imu.m_b])
        err[k] = np.concatenate([d.p[k] - st.p, d.v[k] - st.v, a_n - obs.diagnostics(st, u)["z_hat"]])
        if k < K - 1:
            st = obs.propagate(st, imu, dt)
    return err, fix


def test_linear_part_with_predicted_measurement_matches_expm_of_the_error_system_at_rk4_order():
    # Independent reference (derived from (21), (24a–c) by hand): with η = y_pred − ℭw the
    # prediction error of the held fix, between fixes
    #   w̃' = (𝔄 − Kℭ) w̃ − K η,   η_p' = η_v,   η_v' = −z̃,   and η = 0 at each (exact) fix.
    d, a_n = _const_an_data(10.0, R0=rot_z(0.7) @ rot_x(0.3))
    K9 = paper_gains()
    F = np.block([[A9 - K9 @ C9, -K9], [np.block([[Z3, Z3, Z3], [Z3, Z3, -I3]]), np.block([[Z3, I3], [Z3, Z3]])]])
    Phi = sla.expm(F / d.imu_rate_hz)
    dp0, dv0, xi0 = np.array([5.0, -3.0, 2.0]), np.array([1.0, 0.5, -0.8]), np.array([0.3, -0.2, 0.4])
    dev = {}
    for n in (4, 8):
        obs = GnssInsObserver(K9, PAPER_GAMMA, M_N, G_N, intersample="predict", substeps=n, integrator="rk4")
        err, fix = _error_trajectory(obs, d, a_n, dp0, dv0, xi0)
        x = np.concatenate([err[0], np.zeros(6)])
        ref = np.zeros_like(err)
        for k in range(len(err)):
            if k in fix:
                x[9:] = 0.0
            ref[k] = x[:9]
            x = Phi @ x
        dev[n] = np.max(np.abs(err - ref))
    # the signs of (24a–c) are right (else O(1) deviations) and the error is RK4's: order 4
    assert dev[8] < 5e-5 * np.max(np.abs(err))  # measured 1.2e-5 for |w̃| ≤ 5
    assert dev[4] / dev[8] > 12.0  # measured 18 (2⁴ = 16)


def test_linear_part_with_held_fix_matches_expm_when_hovering():
    # a stationary hover spinning about the vertical: the held fix equals the truth, d = 0,
    # so w̃(t) = expm((𝔄 − Kℭ) t) w̃(0) exactly (up to RK4)
    d, a_n = _const_an_data(6.0, a_b=(0.0, 0.0, -G0), r=0.3, v0=(0.0, 0.0, 0.0))
    assert np.ptp(d.p, axis=0).max() == 0.0
    K9 = paper_gains()
    obs = GnssInsObserver(K9, PAPER_GAMMA, M_N, G_N, intersample="hold", substeps=4, integrator="rk4")
    err, _ = _error_trajectory(obs, d, a_n, np.array([4.0, -2.0, 1.0]), np.array([-1.0, 0.5, 0.2]),
                               np.array([0.2, 0.1, -0.3]))
    ref = sla.expm((A9 - K9 @ C9) * d.t_imu[:, None, None]) @ err[0]
    assert np.max(np.abs(err - ref)) < 1e-4 * np.max(np.abs(err))  # measured ~2e-5 relative


# ----------------------------------------------------------- global convergence
def test_global_convergence_from_large_attitude_errors():
    d = turn_data(70.0)
    R0 = np.stack([rot_z(np.radians(60.0)) @ d.R[0],
                   exp_so3(np.radians(150.0) * np.array([0.6, 0.0, 0.8])) @ d.R[0]])
    p0 = d.p[0] + np.array([10.0, -5.0, 3.0])
    v0 = d.v[0] + np.array([2.0, 1.0, -1.0])
    r = run_navigation(GnssInsObserver.paper(d.m_n, d.g_n), d, p0, v0, R0)
    e = M.attitude_error_deg(r)
    np.testing.assert_allclose(e[:, 0], [60.0, 150.0], atol=1e-6)
    conv = M.converge_s(r, 2.0)
    # measured 8.7 s and 45.9 s
    assert conv[0] < 15.0 and conv[1] < 60.0, conv
    assert np.all(e[:, -1] < 0.5)
    assert np.all(M.position_error_m(r)[:, -1] < 0.05) and np.all(M.velocity_error_mps(r)[:, -1] < 0.2)
    # R̂ itself is not a rotation during the transient; the estimate is (post-orthogonalised)
    Rr = M.R_raw(r)[1, 500]
    assert np.linalg.norm(Rr.T @ Rr - I3) > 0.1
    Rp = M.R_hat(r)[1, 500]
    np.testing.assert_allclose(Rp.T @ Rp, I3, atol=1e-12)
    assert np.linalg.det(Rp) == pytest.approx(1.0)


def test_position_only_observer_converges_on_the_flight(make_traj):
    tr = make_traj(0, 90.0, 50.0)
    gi = np.arange(0, len(tr.t), 10)
    d = SensorData(tr.t, tr.omega_b, tr.a_b, tr.m_b, tr.t[gi], tr.p[gi], None, tr.m_n, tr.g_n, tr.p, tr.v, tr.R,
                   50.0, 5.0)
    obs = GnssInsObserver.paper(d.m_n, d.g_n, position_only=True)  # designed gain (the paper gives none)
    assert obs.K.shape == (9, 3)
    r = run_navigation(obs, d, d.p[0] + 5.0, d.v[0], rot_z(np.radians(60.0)) @ d.R[0])
    conv = float(M.converge_s(r, 2.0))
    assert conv < 30.0, conv
    assert float(M.attitude_rms_deg(r, after=60.0)) < 0.2
    assert float(M.position_rms_m(r, after=60.0)) < 0.05


# ------------------------------------- update: invalid fixes, no injection before the first fix
def test_update_skips_invalid_fixes_per_member_and_counts_them():
    obs = GnssInsObserver.paper(M_N, G_N)
    st = obs.init_state(np.zeros((2, 3)), np.zeros(3), np.eye(3))
    assert st.batch_shape == (2,) and not st.has_fix.any()
    fix = GnssSample(np.array([[1.0, 2.0, 3.0], [np.nan] * 3]), np.array([[4.0, 5.0, 6.0], [np.nan] * 3]),
                     np.array([True, False]))
    st = obs.update(st, fix)
    np.testing.assert_array_equal(st.has_fix, [True, False])
    np.testing.assert_array_equal(st.skipped, [0, 1])
    np.testing.assert_array_equal(st.y_p, [[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]])
    assert np.all(np.isfinite(st.y_v))


def test_no_injection_before_the_first_fix():
    # open loop: p̂' = v̂, v̂' = R̂ a^b + ξ + gⁿ; with a^b = −gⁿ level and ξ = 0, v̂ stays, p̂ moves by v̂ t
    obs = GnssInsObserver.paper(M_N, G_N)
    st = obs.init_state(np.zeros(3), np.array([1.0, 2.0, 0.0]), np.eye(3))
    imu = ImuSample(np.zeros(3), -G_N, M_N)
    for _ in range(10):
        st = obs.propagate(st, imu, 0.01)
    np.testing.assert_allclose(st.p, [0.1, 0.2, 0.0], atol=1e-12)
    np.testing.assert_allclose(st.v, [1.0, 2.0, 0.0], atol=1e-12)


# ----------------------------------------------------------------- bad input
def test_constructor_rejects_bad_gains():
    with pytest.raises(DimensionError, match=r"K: expected shape \(9, 6\)"):
        GnssInsObserver(np.ones((9, 3)), PAPER_GAMMA, M_N, G_N)
    with pytest.raises(DimensionError, match=r"K: expected shape \(9, 3\)"):
        GnssInsObserver(paper_gains(), PAPER_GAMMA, M_N, G_N, position_only=True)
    with pytest.raises(NotSymmetricError, match="Gamma"):
        GnssInsObserver(paper_gains(), [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], M_N, G_N)
    with pytest.raises(InvalidArgumentError, match="Gamma: must be positive definite"):
        GnssInsObserver(paper_gains(), np.diag([1.0, 0.0, 1.0]), M_N, G_N)
    with pytest.raises(InvalidArgumentError, match="m_n"):
        GnssInsObserver(paper_gains(), PAPER_GAMMA, np.zeros(3), G_N)
    with pytest.raises(InvalidArgumentError, match="intersample"):
        GnssInsObserver(paper_gains(), PAPER_GAMMA, M_N, G_N, intersample="linear")  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="substeps"):
        GnssInsObserver(paper_gains(), PAPER_GAMMA, M_N, G_N, substeps=0)


def test_propagate_refuses_an_unstable_rk4_step_and_update_needs_velocity():
    obs = GnssInsObserver(paper_gains(), PAPER_GAMMA, M_N, G_N, substeps=1, integrator="rk4")
    st = obs.init_state(np.zeros(3), np.zeros(3), np.eye(3))
    imu = ImuSample(np.zeros(3), -G_N, M_N)
    with pytest.raises(InvalidArgumentError, match="unstable"):
        obs.propagate(st, imu, 0.05)  # 0.05 · 131 > 2.785
    with pytest.raises(InvalidArgumentError, match="dt"):
        obs.propagate(st, imu, 0.0)
    with pytest.raises(InvalidArgumentError, match="velocity"):
        obs.update(st, GnssSample(np.zeros(3), None, np.array(True)))


# ------------------------------------------------------------- the observer protocol
def _rk4(f, z, u, h, n):
    """``n`` classical RK4 steps of ``ż = f(z, u)`` over ``h`` on a dataclass state (the loop's arithmetic)."""
    s = h / n
    for _ in range(n):
        k1 = f(0.0, z, u, None)
        k2 = f(0.0, tree_map(lambda a, b: a + 0.5 * s * b, z, k1), u, None)
        k3 = f(0.0, tree_map(lambda a, b: a + 0.5 * s * b, z, k2), u, None)
        k4 = f(0.0, tree_map(lambda a, b: a + s * b, z, k3), u, None)
        z = tree_map(lambda a, b1, b2, b3, b4: a + (s / 6.0) * (b1 + 2.0 * b2 + 2.0 * b3 + b4), z, k1, k2, k3, k4)
    return z


def _moving_state(obs, batch=()):
    """A state away from the truth, with a held fix: every term of (24) is active."""
    rng = np.random.default_rng(11)
    st = obs.init_state(rng.normal(size=(*batch, 3)), rng.normal(size=(*batch, 3)) + [30.0, 5.0, -1.0],
                        exp_so3(rng.normal(size=(*batch, 3))) + 0.05 * rng.normal(size=(*batch, 3, 3)),
                        xi0=0.3 * rng.normal(size=(*batch, 3)))
    u = np.concatenate([[0.05, -0.1, 0.2], [0.4, -0.3, -G0 - 0.5], rot_x(0.2).T @ M_N])
    y = np.concatenate([rng.normal(size=(*batch, 3)), rng.normal(size=(*batch, 3)) + [29.0, 5.0, -1.0]], axis=-1)
    return obs.correct(0.0, st, u, y, np.ones(6, bool)), u


def _state_diff(a: GnssInsState, b: GnssInsState) -> float:
    return max(float(np.max(np.abs(getattr(a, f) - getattr(b, f)))) for f in ("p", "v", "xi", "R", "y_p", "y_v"))


def test_the_observer_implements_the_protocol_and_its_estimates():
    obs = GnssInsObserver.paper(M_N, G_N)
    for proto in (CorrectingObserver, SelfStepping, Diagnosing, DeferredEstimate):
        assert isinstance(obs, proto), proto
    assert obs.time == Continuous() and obs.n_x == 15
    x0 = nav_vector([1.0, 2.0, 3.0], [4.0, 5.0, 6.0], rot_z(0.3))
    st = obs.init(x0)
    np.testing.assert_array_equal(st.R, rot_z(0.3))
    assert not st.has_fix and np.all(st.xi == 0.0)
    np.testing.assert_array_equal(obs.raw_estimate(st), x0)
    st, u = _moving_state(obs, (4,))
    raw = np.stack([obs.raw_estimate(st), obs.raw_estimate(obs.step(0.0, st, u, None, 0.01))], axis=-2)  # (4, 2, 15)
    raw.setflags(write=False)
    est, extras = obs.finish_estimates(raw)                                  # read-only record: a new array
    np.testing.assert_array_equal(extras["R_raw"], raw[..., 6:].reshape(4, 2, 3, 3))
    np.testing.assert_allclose(est[:, 0], obs.estimate(st), rtol=0.0, atol=1e-13)   # Newton polar = SVD
    np.testing.assert_allclose(est[..., 6:].reshape(4, 2, 3, 3), project_so3(extras["R_raw"]), atol=1e-13)
    np.testing.assert_array_equal(est[..., :6], raw[..., :6])
    assert not est.flags.writeable and not np.shares_memory(est, raw)
    record = np.moveaxis(np.ascontiguousarray(np.moveaxis(raw, -2, 0)), 0, -2)  # the loop's time-major layout
    est2, extras2 = obs.finish_estimates(record)                             # writable: projected in place
    assert est2 is record and not extras2["R_raw"].flags.writeable
    np.testing.assert_array_equal(est2, est)
    np.testing.assert_array_equal(extras2["R_raw"], extras["R_raw"])
    z = obs.diagnostics(st, u)["z_hat"]
    np.testing.assert_allclose(z, st.R @ u[3:6] + st.xi, rtol=1e-14)


def test_one_rk4_step_of_rhs_is_the_rk4_integrator():
    obs = GnssInsObserver(paper_gains(), PAPER_GAMMA, M_N, G_N, integrator="rk4", substeps=1)
    st, u = _moving_state(obs, (3,))
    h = 1e-3  # inside RK4's stability interval for the attitude loop (λmax(Γ)·|m|²|m×a|² ≈ 2000 1/s)
    ref = obs.step(0.0, st, u, None, h)
    one = _rk4(obs.rhs, st, u, h, 1)
    assert _state_diff(one, ref) < 1e-12 * max(1.0, float(np.abs(st.v).max()))
    np.testing.assert_array_equal(one.has_fix, ref.has_fix)


@pytest.mark.parametrize("intersample", ["predict", "hold"])
def test_split_step_is_the_flow_of_rhs_to_third_order_locally(intersample):
    # Strang splitting of exactly solved sub-flows: local error O(h³) against the exact flow of (24)
    obs = GnssInsObserver.paper(M_N, G_N, intersample=intersample, kernel="batched")
    st, u = _moving_state(obs, (2,))
    errs = []
    for h in (1e-3, 5e-4, 2.5e-4):  # h·λmax(Γ)μ₃ ≤ 2: the asymptotic regime of the stiff attitude loop
        fine = _rk4(obs.rhs, st, u, h, 200)  # RK4 at h/200: error far below the splitting error
        errs.append(_state_diff(obs.step(0.0, st, u, None, h), fine))
    errs = np.array(errs)
    ratios = errs[:-1] / errs[1:]
    assert np.all((ratios > 6.5) & (ratios < 9.5)), (errs, ratios)  # 2³ = 8 (measured 7.2, 7.6)
    # the fused scalar kernel (one flight) takes the same step
    one = GnssInsState(p=st.p[0], v=st.v[0], xi=st.xi[0], R=st.R[0], y_p=st.y_p[0], y_v=st.y_v[0],
                       has_fix=st.has_fix[0], skipped=st.skipped[0])
    auto = GnssInsObserver.paper(M_N, G_N, intersample=intersample)
    bat = obs.step(0.0, st, u, None, 0.01)
    assert _state_diff(auto.step(0.0, one, u, None, 0.01),
                       GnssInsState(bat.p[0], bat.v[0], bat.xi[0], bat.R[0], bat.y_p[0], bat.y_v[0],
                                    bat.has_fix[0], bat.skipped[0])) < 1e-12


def test_correct_skips_invalid_members_and_checks_the_fix():
    obs = GnssInsObserver.paper(M_N, G_N)
    st = obs.init_state(np.zeros((3, 3)), np.zeros(3), np.eye(3))
    u = np.zeros(9)
    y = np.array([[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], [np.nan, 2.0, 3.0, 4.0, 5.0, 6.0], [1.0, 2.0, 3.0, 4.0, 5.0, np.inf]])
    new = obs.correct(0.2, st, u, y, np.ones(6, bool))
    np.testing.assert_array_equal(new.has_fix, [True, False, False])
    np.testing.assert_array_equal(new.skipped, [0, 1, 1])
    np.testing.assert_array_equal(new.y_p[0], [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(new.y_v[0], [4.0, 5.0, 6.0])
    np.testing.assert_array_equal(new.y_p[1:], st.y_p[1:])
    np.testing.assert_array_equal(new.y_v[1:], st.y_v[1:])
    with pytest.raises(InvalidArgumentError, match="velocity"):
        obs.correct(0.2, st, u, y[:, :3], np.ones(3, bool))
    with pytest.raises(InvalidArgumentError, match="all its channels"):
        obs.correct(0.2, st, u, y, np.array([True] * 3 + [False] * 3))
    with pytest.raises(DimensionError, match="GNSS fix"):
        obs.correct(0.2, st, u, y[:, :4], np.ones(4, bool))
    # a position-only observer takes p from a full fix (a non-finite v still invalidates it, as p and v are one fix)
    po = GnssInsObserver.paper(M_N, G_N, position_only=True)
    new = po.correct(0.2, po.init_state(np.zeros((3, 3)), np.zeros(3), np.eye(3)), u, y, np.ones(6, bool))
    np.testing.assert_array_equal(new.has_fix, [True, False, False])
    assert new.y_v is None
