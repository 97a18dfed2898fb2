"""The GNSS/INS observer (22)–(24) of seed 001, Sec. 5, checked against independent references.

* truth: closed-form kinematics (``test_gnss_ins_synthetic.py``, checked there by
  finite differences) and the traffic-pattern flight of ``navigation.trajectory``;
* the linear part (24a)–(24c): the error of ``(p̂, v̂, ẑ)`` compared with
  ``scipy.linalg.expm`` of the linear error system written out by hand from (21),
  for motions with constant ``aⁿ`` (then ``d = ż = 0`` and the error system is
  exactly linear, whatever ``R̂`` does);
* convergence orders (RK4: 4; the held IMU sample: 1) instead of single numbers.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from test_gnss_ins_synthetic import G_N, M_N, turn_data

from nlobs.errors import DimensionError, InvalidArgumentError, NotSymmetricError
from nlobs.navigation.base import G0, GnssSample, ImuSample, SensorData
from nlobs.navigation.gains import PAPER_GAMMA, paper_gains
from nlobs.navigation.gnss_ins import GnssInsObserver, triad_J, triad_matrix
from nlobs.navigation.run import run_navigation
from nlobs.navigation.so3 import exp_so3, rot_x, rot_z

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
        errs[rate] = np.array([r.position_error_m().max(), r.velocity_error_mps().max(), r.attitude_error_deg().max()])
    # measured at 100 Hz: 1.0e-4 m, 8.2e-4 m/s, 0.016°; the held IMU sample (ZOH) makes it O(dt)
    assert np.all(errs[100.0] < [5e-4, 4e-3, 0.05])
    ratio = errs[50.0] / errs[100.0]
    assert np.all((ratio > 1.7) & (ratio < 2.5)), ratio


def test_zero_order_hold_of_the_fix_lags_the_aircraft():
    # the literal sample-and-hold: p̂ is pulled back to a fix up to v·T_gnss old (V = 50 m/s, 5 Hz → 10 m)
    d = turn_data(10.0)
    obs = GnssInsObserver.paper(d.m_n, d.g_n, intersample="hold")
    r = run_navigation(obs, d, d.p[0], d.v[0], d.R[0])
    lag = r.position_error_m()[200:].max()
    assert 0.8 * 10.0 < lag < 10.0  # measured 9.55 m
    assert r.attitude_error_deg().max() > 0.1  # ≈ 0.5° (vs 0.016° with the predictor)


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
    st = obs.init(d.p[0] - dp0, d.v[0] - dv0, d.R[0], xi0=xi0)
    K = len(d.t_imu)
    dt = 1.0 / d.imu_rate_hz
    fix = {round(tg * d.imu_rate_hz): i for i, tg in enumerate(d.t_gnss)}
    err = np.zeros((K, 9))
    for k in range(K):
        if k in fix:
            st = obs.update(st, GnssSample(d.p_gnss[fix[k]], d.v_gnss[fix[k]], np.array(True)))
        imu = ImuSample(d.omega_b[k], d.a_b[k], d.m_b[k])
        err[k] = np.concatenate([d.p[k] - st.p, d.v[k] - st.v, a_n - obs.diagnostics(st, imu)["z_hat"]])
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
    e = r.attitude_error_deg()
    np.testing.assert_allclose(e[:, 0], [60.0, 150.0], atol=1e-6)
    conv = r.converge_s(2.0)
    # measured 8.7 s and 45.9 s
    assert conv[0] < 15.0 and conv[1] < 60.0, conv
    assert np.all(e[:, -1] < 0.5)
    assert np.all(r.position_error_m()[:, -1] < 0.05) and np.all(r.velocity_error_mps()[:, -1] < 0.2)
    # R̂ itself is not a rotation during the transient; the estimate is (post-orthogonalised)
    Rr = r.R_raw[1, 500]
    assert np.linalg.norm(Rr.T @ Rr - I3) > 0.1
    Rp = r.R_hat[1, 500]
    np.testing.assert_allclose(Rp.T @ Rp, I3, atol=1e-12)
    assert np.linalg.det(Rp) == pytest.approx(1.0)


def test_position_only_observer_converges_on_the_flight():
    from nlobs.navigation.trajectory import traffic_pattern

    tr = traffic_pattern(seed=0, duration=90.0).sample(50.0)
    gi = np.arange(0, len(tr.t), 10)
    d = SensorData(tr.t, tr.omega_b, tr.a_b, tr.m_b, tr.t[gi], tr.p[gi], None, tr.m_n, tr.g_n, tr.p, tr.v, tr.R,
                   50.0, 5.0)
    obs = GnssInsObserver.paper(d.m_n, d.g_n, position_only=True)  # designed gain (the paper gives none)
    assert obs.K.shape == (9, 3)
    r = run_navigation(obs, d, d.p[0] + 5.0, d.v[0], rot_z(np.radians(60.0)) @ d.R[0])
    conv = float(r.converge_s(2.0))
    assert conv < 30.0, conv
    assert float(r.attitude_rms_deg(after=60.0)) < 0.2
    assert float(r.position_rms_m(after=60.0)) < 0.05


# ----------------------------------------------------- update, before the fix
def test_update_skips_invalid_fixes_per_member_and_counts_them():
    obs = GnssInsObserver.paper(M_N, G_N)
    st = obs.init(np.zeros((2, 3)), np.zeros(3), np.eye(3))
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
    st = obs.init(np.zeros(3), np.array([1.0, 2.0, 0.0]), np.eye(3))
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
    st = obs.init(np.zeros(3), np.zeros(3), np.eye(3))
    imu = ImuSample(np.zeros(3), -G_N, M_N)
    with pytest.raises(InvalidArgumentError, match="unstable"):
        obs.propagate(st, imu, 0.05)  # 0.05 · 131 > 2.785
    with pytest.raises(InvalidArgumentError, match="dt"):
        obs.propagate(st, imu, 0.0)
    with pytest.raises(InvalidArgumentError, match="velocity"):
        obs.update(st, GnssSample(np.zeros(3), None, np.array(True)))
