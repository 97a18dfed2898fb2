"""The split (exponential / Strang) integrator of the GNSS/INS observer against RK4.

Reference: the same observer (24) integrated by RK4 with many substeps per IMU period
(``integrator="rk4"``), on the same sampled data (IMU sample held over each period).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.navigation import metrics as M
from nlobs.navigation.base import GnssSample, ImuSample
from nlobs.navigation.gains import PAPER_GAMMA, paper_gains
from nlobs.navigation.gnss_ins import GnssInsObserver, GnssInsState
from nlobs.navigation.run import run_navigation
from nlobs.navigation.sensors import SensorNoise, drop_fixes, generate_sensors
from nlobs.navigation.so3 import angle_between, exp_so3, rot_z

pytestmark = pytest.mark.slow  # its module fixture alone takes seconds

NOISE = SensorNoise(gyro_std=1e-3, accel_std=0.05, mag_std=5e-3, gnss_p_std=1.0, gnss_v_std=0.1)


@pytest.fixture(scope="module")
def noisy_runs(flight, make_traj):
    """60 s noisy flight from 60° and 150° yaw errors (a batch of two), split / RK4-auto / RK4 reference."""
    traj = make_traj(0, 60.0, 100.0)
    data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=NOISE, seed=3)
    R0 = traj.R[0] @ rot_z(np.radians([60.0, 150.0]))
    p0 = traj.p[0] + np.array([5.0, -3.0, 2.0])
    out = {}
    for name, kw in (("split", {}), ("rk4", {"integrator": "rk4"}), ("ref", {"integrator": "rk4", "substeps": 6})):
        out[name] = run_navigation(GnssInsObserver.paper(flight.m_n, flight.g_n, **kw), data, p0, traj.v[0], R0)
    return out


def _diff(a, b, after):
    mask = a.t >= after
    dp = np.linalg.norm(M.p_hat(a) - M.p_hat(b), axis=-1)[..., mask].max()
    dv = np.linalg.norm(M.v_hat(a) - M.v_hat(b), axis=-1)[..., mask].max()
    dR = np.degrees(angle_between(M.R_hat(a), M.R_hat(b)))[..., mask].max()
    return dp, dv, dR


def test_default_is_split_and_bad_integrator_is_refused(flight):
    assert GnssInsObserver.paper(flight.m_n, flight.g_n).integrator == "split"
    with pytest.raises(InvalidArgumentError, match="integrator"):
        GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n, integrator="euler")


def test_split_tracks_the_rk4_reference_far_below_the_gnss_noise(noisy_runs):
    split, ref = noisy_runs["split"], noisy_runs["ref"]
    dp, dv, dR = _diff(split, ref, after=20.0)
    # measured: 1.4e-4 m, ~1e-3 m/s, 0.036° (GNSS noise 1 m / 0.1 m/s; attitude RMS vs truth ≈ 0.5°)
    assert dp < 0.01 and dv < 0.01 and dR < 0.05, (dp, dv, dR)
    # and it is not worse than RK4 with automatic substeps (measured 0.05 m, 0.23° there)
    dp4, _, dR4 = _diff(noisy_runs["rk4"], ref, after=20.0)
    assert dp <= dp4 and dR <= dR4
    # the error metrics vs truth agree
    np.testing.assert_allclose(M.position_rms_m(split, after=20.0), M.position_rms_m(ref, after=20.0), rtol=1e-3)
    np.testing.assert_allclose(M.attitude_rms_deg(split, after=20.0), M.attitude_rms_deg(ref, after=20.0), rtol=0.05)


def test_convergence_from_large_yaw_errors_is_kept(noisy_runs):
    cs = M.converge_s(noisy_runs["split"])
    assert np.all(np.isfinite(cs))
    np.testing.assert_allclose(cs, M.converge_s(noisy_runs["ref"]), atol=1.0)
    np.testing.assert_allclose(cs, M.converge_s(noisy_runs["rk4"]), atol=1.0)
    assert np.all(M.attitude_error_deg(noisy_runs["split"])[..., -1] < 3.0)


def test_split_converges_to_the_reference_at_least_first_order_in_the_imu_period(flight, make_flight):
    short = make_flight(0, 12.0)
    errs = []
    for rate in (50.0, 100.0, 200.0):
        traj = short.sample(rate)
        data = generate_sensors(traj, imu_rate_hz=rate, gnss_rate_hz=5.0, noise=SensorNoise(), seed=0)
        R0 = traj.R[0] @ rot_z(np.radians(40.0))
        p0 = traj.p[0] + 3.0
        n_ref = int(round(2000.0 / rate))  # the same fine RK4 step (0.5 ms) at every rate
        res = [run_navigation(GnssInsObserver.paper(short.m_n, short.g_n, **kw), data, p0, traj.v[0], R0)
               for kw in ({}, {"integrator": "rk4", "substeps": n_ref})]
        dp, dv, dR = _diff(res[0], res[1], after=0.0)
        errs.append((dp, dv, dR))
    errs = np.array(errs)
    # velocity and attitude (the position differences, ~3e-7 m, sit at the reference's floor)
    ratios = errs[:-1, 1:] / errs[1:, 1:]
    # halving the IMU period shrinks the splitting error (measured ratios 3.3, 3.7 (v); 1.7, 3.9 (R));
    # first order would give 2 per halving and 4 over both, Strang 4 per halving asymptotically
    assert np.all(ratios > 1.5) and np.all(errs[0, 1:] / errs[2, 1:] > 4.0), (errs, ratios)
    assert errs[1, 0] < 1e-3 and errs[1, 2] < 0.05


def test_stiffer_attitude_gain_split_stays_bounded_rk4_single_step_refuses(flight, make_traj):
    traj = make_traj(0, 15.0, 100.0)
    data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=NOISE, seed=5)
    R0 = traj.R[0] @ rot_z(np.radians(90.0))
    G10 = 10.0 * PAPER_GAMMA  # λmax(Γ)·|m × a|² ≈ 2000+ 1/s: h·ρ ≈ 20 at 100 Hz
    split = GnssInsObserver(paper_gains(), G10, flight.m_n, flight.g_n)
    res = run_navigation(split, data, traj.p[0], traj.v[0], R0)
    assert np.all(np.isfinite(M.R_raw(res))) and np.abs(M.R_raw(res)).max() < 10.0
    assert M.attitude_error_deg(res)[-1] < 3.0 and M.position_error_m(res)[-1] < 5.0
    rk1 = GnssInsObserver(paper_gains(), G10, flight.m_n, flight.g_n, integrator="rk4", substeps=1)
    st = rk1.init_state(traj.p[0], traj.v[0], R0)
    imu = ImuSample(data.omega_b[0], data.a_b[0], data.m_b[0])
    with pytest.raises(InvalidArgumentError, match="unstable"):
        rk1.propagate(st, imu, 0.01)


def test_batch_equals_single_runs_with_a_member_waiting_for_its_first_fix(flight, make_traj):
    traj = make_traj(1, 6.0, 100.0)
    data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=NOISE, seed=9, batch=3)
    data = drop_fixes(data, [0, 1, 2], batch_index=1)  # member 1 runs open loop for 0.6 s
    R0 = traj.R[0] @ exp_so3(np.array([[0.3, -0.2, 1.0], [0.0, 0.0, 2.5], [-0.4, 0.1, 0.0]]))
    obs = GnssInsObserver.paper(flight.m_n, flight.g_n)
    batch = run_navigation(obs, data, traj.p[0], traj.v[0], R0)
    import dataclasses

    for i in range(3):
        one = dataclasses.replace(data, omega_b=data.omega_b[i], a_b=data.a_b[i], m_b=data.m_b[i],
                                  p_gnss=data.p_gnss[i], v_gnss=data.v_gnss[i])
        single = run_navigation(obs, one, traj.p[0], traj.v[0], R0[i])
        np.testing.assert_allclose(M.p_hat(batch)[i], M.p_hat(single), rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(M.R_raw(batch)[i], M.R_raw(single), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(M.z_hat(batch)[i], M.z_hat(single), rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("kind", ["nondiagonal_gamma", "position_only_hold"])
def test_split_matches_rk4_for_general_gamma_and_other_modes(flight, make_traj, kind):
    traj = make_traj(0, 10.0, 100.0)
    po = kind == "position_only_hold"
    data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=SensorNoise(), seed=0, position_only=po)
    Q = exp_so3(np.array([0.4, -0.7, 0.2]))
    G = Q @ PAPER_GAMMA @ Q.T if kind == "nondiagonal_gamma" else PAPER_GAMMA
    kw = {"position_only": po, "intersample": "hold" if po else "predict"}
    R0 = traj.R[0] @ rot_z(np.radians(30.0))
    out = [run_navigation(GnssInsObserver(paper_gains(po), G, flight.m_n, flight.g_n, **kw, **extra),
                          data, traj.p[0] + 2.0, traj.v[0], R0)
           for extra in ({}, {"integrator": "rk4", "substeps": 10})]
    dp, dv, dR = _diff(out[0], out[1], after=0.0)
    assert dp < 0.01 and dR < 0.05, (dp, dv, dR)


def test_magnetometer_parallel_to_specific_force_is_handled():
    # TRIAD condition violated (m^b ∥ a^b): μ₂ = μ₃ = 0, the step stays finite and only rotates/injects along m
    obs = GnssInsObserver.paper([0.0, 0.0, 1.0], [0.0, 0.0, 9.8])
    st = obs.init_state(np.zeros(3), np.zeros(3), rot_z(0.3))
    st = obs.update(st, GnssSample(np.zeros(3), np.zeros(3), np.array(True)))
    imu = ImuSample(np.array([0.0, 0.0, 0.1]), np.array([0.0, 0.0, -9.8]), np.array([0.0, 0.0, 1.0]))
    nxt = obs.propagate(st, imu, 0.01)
    ref = GnssInsObserver.paper([0.0, 0.0, 1.0], [0.0, 0.0, 9.8], integrator="rk4", substeps=10).propagate(st, imu, 0.01)
    assert np.all(np.isfinite(nxt.R))
    np.testing.assert_allclose(nxt.R, ref.R, atol=1e-6)
    np.testing.assert_allclose(nxt.p, ref.p, atol=1e-9)
    # the single-flight state goes through the scalar kernel; the batched path handles the case alike
    bat = GnssInsObserver.paper([0.0, 0.0, 1.0], [0.0, 0.0, 9.8], kernel="batched").propagate(st, imu, 0.01)
    np.testing.assert_allclose(nxt.R, bat.R, rtol=0.0, atol=1e-15)
    np.testing.assert_allclose(nxt.xi, bat.xi, rtol=0.0, atol=1e-14)


# ------------------------------------------------------------ fused single-flight kernel
KERNEL_CASES = {
    "predict": {},
    "hold": {"intersample": "hold"},
    "position_only_predict": {"position_only": True},
    "position_only_hold": {"position_only": True, "intersample": "hold"},
    "nondiagonal_gamma": {"gamma": "rotated"},
    "coupled_K": {"K": "coupled"},  # Φ couples the axes: the kernel's dense fallback
}


@pytest.mark.parametrize("case", sorted(KERNEL_CASES))
def test_scalar_kernel_equals_the_batched_path_on_a_noisy_flight(flight, make_traj, case):
    kw = dict(KERNEL_CASES[case])
    po = kw.get("position_only", False)
    K = paper_gains(po).copy()
    if kw.pop("K", None) == "coupled":
        K[0, 1] += 0.3
        K[4, 2] -= 0.2
    G = PAPER_GAMMA
    if kw.pop("gamma", None) == "rotated":
        Q = exp_so3(np.array([0.4, -0.7, 0.2]))
        G = Q @ PAPER_GAMMA @ Q.T
    traj = make_traj(2, 20.0, 100.0)
    data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=NOISE, seed=4, position_only=po)
    data = drop_fixes(data, [0, 1, 7])  # open loop for 0.4 s, then a gap
    R0 = traj.R[0] @ exp_so3(np.array([0.1, -0.1, 1.0]))
    runs = {k: run_navigation(GnssInsObserver(K, G, flight.m_n, flight.g_n, kernel=k, **kw), data,
                              traj.p[0] + 4.0, traj.v[0] - 1.0, R0)
            for k in ("batched", "scalar", "auto")}
    b, s = runs["batched"], runs["scalar"]
    scale = np.abs(M.p_hat(b)).max()
    np.testing.assert_allclose(M.p_hat(s), M.p_hat(b), rtol=0.0, atol=1e-12 * scale)
    np.testing.assert_allclose(M.v_hat(s), M.v_hat(b), rtol=0.0, atol=1e-12 * scale)
    np.testing.assert_allclose(M.R_raw(s), M.R_raw(b), rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(M.z_hat(s), M.z_hat(b), rtol=0.0, atol=1e-12 * np.abs(M.z_hat(b)).max())
    np.testing.assert_allclose(M.R_hat(s), M.R_hat(b), rtol=0.0, atol=1e-12)
    assert M.attitude_error_deg(s)[-1] < 5.0  # a real segment: converged from 58°
    # "auto" takes the scalar kernel for one flight: identical arithmetic
    np.testing.assert_array_equal(M.R_raw(runs["auto"]), M.R_raw(s))
    np.testing.assert_array_equal(M.p_hat(runs["auto"]), M.p_hat(s))


def test_scalar_kernel_keeps_a_batch_axis_of_size_one_and_refuses_larger_batches(flight, make_traj):
    traj = make_traj(1, 2.0, 100.0)
    data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=NOISE, seed=9, batch=2)
    one = dataclasses.replace(data, omega_b=data.omega_b[:1], a_b=data.a_b[:1], m_b=data.m_b[:1],
                              p_gnss=data.p_gnss[:1], v_gnss=data.v_gnss[:1])
    R0 = traj.R[0] @ rot_z(0.5)
    b = run_navigation(GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n, kernel="batched"),
                       one, traj.p[0], traj.v[0], R0)
    s = run_navigation(GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n, kernel="scalar"),
                       one, traj.p[0], traj.v[0], R0)
    assert s.batch_shape == b.batch_shape == (1,)
    np.testing.assert_allclose(M.p_hat(s), M.p_hat(b), rtol=0.0, atol=1e-12 * np.abs(M.p_hat(b)).max())
    np.testing.assert_allclose(M.R_raw(s), M.R_raw(b), rtol=0.0, atol=1e-13)
    scalar = GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n, kernel="scalar")
    with pytest.raises(DimensionError, match="single flight"):
        run_navigation(scalar, data, traj.p[0], traj.v[0], R0)


def test_kernel_option_is_validated(flight):
    with pytest.raises(InvalidArgumentError, match="kernel"):
        GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n, kernel="numba")
    with pytest.raises(InvalidArgumentError, match="kernel"):
        GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n, integrator="rk4", kernel="scalar")
    assert GnssInsObserver.paper(flight.m_n, flight.g_n).kernel == "auto"


def test_batched_step_broadcasts_a_single_state_against_a_batch_of_imu_samples(flight):
    obs = GnssInsObserver.paper(flight.m_n, flight.g_n)
    st = obs.update(obs.init_state(np.zeros(3), np.ones(3), rot_z(0.4)),
                    GnssSample(np.full(3, 2.0), np.zeros(3), np.array(True)))
    w = np.array([[0.01, 0.02, 0.1], [0.0, -0.3, 0.05]])
    a = np.array([[0.3, -0.2, -9.7], [1.0, 0.5, -9.0]])
    m = np.array([[0.1, 0.5, 0.8], [0.4, 0.0, 0.9]])
    both = obs.propagate(st, ImuSample(w, a, m), 0.01)
    assert both.batch_shape == (2,) and both.has_fix.shape == (2,) and both.R.shape == (2, 3, 3)
    for i in range(2):
        one = obs.propagate(st, ImuSample(w[i], a[i], m[i]), 0.01)  # the scalar kernel
        np.testing.assert_allclose(both.R[i], one.R, rtol=0.0, atol=1e-15)
        np.testing.assert_allclose(both.p[i], one.p, rtol=0.0, atol=1e-14)
        np.testing.assert_allclose(both.xi[i], one.xi, rtol=0.0, atol=1e-13)
        np.testing.assert_allclose(both.y_v[i], one.y_v, rtol=0.0, atol=1e-14)


@pytest.mark.parametrize("case", ["predict", "nondiagonal_gamma", "position_only_hold"])
def test_batch_last_layout_equals_the_batch_first_layout(flight, make_traj, monkeypatch, case):
    from nlobs.navigation import gnss_ins

    po = case == "position_only_hold"
    n = gnss_ins.BATCH_LAST_MIN + 8
    traj = make_traj(1, 3.0, 100.0)
    data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=NOISE, seed=11, batch=n,
                            position_only=po)
    data = drop_fixes(data, [0, 1, 2], batch_index=1)  # member 1 runs open loop for 0.6 s
    R0 = traj.R[0] @ exp_so3(np.random.default_rng(5).normal(size=(n, 3)))
    Q = exp_so3(np.array([0.4, -0.7, 0.2]))
    G = Q @ PAPER_GAMMA @ Q.T if case == "nondiagonal_gamma" else PAPER_GAMMA
    obs = GnssInsObserver(paper_gains(po), G, flight.m_n, flight.g_n, position_only=po,
                          intersample="hold" if po else "predict")
    cols = run_navigation(obs, data, traj.p[0], traj.v[0], R0)
    monkeypatch.setattr(gnss_ins, "BATCH_LAST_MIN", 10**9)
    rows = run_navigation(obs, data, traj.p[0], traj.v[0], R0)
    scale = np.abs(M.p_hat(rows)).max()
    np.testing.assert_allclose(M.p_hat(cols), M.p_hat(rows), rtol=0.0, atol=1e-12 * scale)
    np.testing.assert_allclose(M.v_hat(cols), M.v_hat(rows), rtol=0.0, atol=1e-12 * scale)
    np.testing.assert_allclose(M.R_raw(cols), M.R_raw(rows), rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(M.z_hat(cols), M.z_hat(rows), rtol=0.0, atol=1e-12 * np.abs(M.z_hat(rows)).max())


def test_both_batched_layouts_handle_a_magnetometer_parallel_to_the_specific_force(monkeypatch):
    from nlobs.navigation import gnss_ins

    obs = GnssInsObserver.paper([0.0, 0.0, 1.0], [0.0, 0.0, 9.8])
    n = gnss_ins.BATCH_LAST_MIN
    rng = np.random.default_rng(2)
    st = obs.update(obs.init_state(np.zeros((n, 3)), np.zeros(3), exp_so3(rng.normal(size=(n, 3)))),
                    GnssSample(np.zeros(3), np.zeros(3), np.array(True)))
    m = np.tile([0.0, 0.0, 1.0], (n, 1))
    m[1] = [1.0, 0.0, 0.0]  # ∥ a for member 1, with |m₁| large: the other completion of U
    a = np.vstack([[0.0, 0.0, -9.8], [-9.8, 0.0, 0.0], rng.normal(size=(n - 2, 3)) + [0.0, 0.0, -9.8]])
    imu = ImuSample(rng.normal(scale=0.1, size=(n, 3)), a, m)
    cols = obs.propagate(st, imu, 0.01)
    monkeypatch.setattr(gnss_ins, "BATCH_LAST_MIN", 10**9)
    rows = obs.propagate(st, imu, 0.01)
    for i in range(3):
        one = obs.propagate(GnssInsState(p=st.p[i], v=st.v[i], xi=st.xi[i], R=st.R[i], y_p=st.y_p[i], y_v=st.y_v[i],
                                         has_fix=st.has_fix[i], skipped=st.skipped[i]),
                            ImuSample(imu.omega_b[i], a[i], m[i]), 0.01)
        for res in (cols, rows):
            assert np.all(np.isfinite(res.R[i]))
            np.testing.assert_allclose(res.R[i], one.R, rtol=0.0, atol=1e-14)
            np.testing.assert_allclose(res.xi[i], one.xi, rtol=0.0, atol=1e-12)
