"""The generated C of the GNSS/INS observer (24) against the Python observer, along noisy flights.

The compiled observer runs through the same recorded-data loop (:func:`nlobs.navigation.run.run_navigation`)
and, for one flight, entirely in C (``run_record``); both equal the Python observer to 1e-12, relative
and norm-wise per quantity (position, velocity, projected and raw attitude), for the paper's gains,
the noise-optimal gains, the scheduled attitude gain, the scheduled attitude and translational gains, a full (non-diagonal) Γ and a position-only receiver.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError, NumericalError
from nlobs.export import compile_observer
from nlobs.export.compiler import compile_object
from nlobs.export.compiled import compile_gnss_ins
from nlobs.export.gnss_ins import generate_gnss_ins, gnss_ins_codec
from nlobs.export.program import render
from nlobs.navigation import metrics as M
from nlobs.navigation.gains import NOISE_OPTIMAL_GAMMA, PAPER_GAMMA, axis_gain, noise_optimal_gains, paper_gains
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation.run import run_navigation
from nlobs.navigation.schedule import ScheduledGnssInsObserver, noise_scheduled_gain
from nlobs.navigation.sensors import drop_fixes, generate_sensors
from nlobs.navigation.so3 import rot_z
from nlobs.navigation.translation_schedule import kalman_scheduled_gain
from nlobs.workflows.demo import DEMO_NOISE

RTOL = 1e-12
DURATION = 60.0
RATE = 100.0


@pytest.fixture(scope="module")
def noise_optimal_K():
    K, cert = noise_optimal_gains(DEMO_NOISE, imu_rate_hz=RATE, gnss_rate_hz=5.0)
    assert cert.verified
    return K


def _observer(kind: str, flight, K_opt):  # type: ignore[no-untyped-def]
    if kind == "paper":
        return GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n)
    if kind == "noise-optimal":
        return GnssInsObserver(K_opt, NOISE_OPTIMAL_GAMMA, flight.m_n, flight.g_n)
    if kind == "scheduled":
        base = GnssInsObserver(K_opt, NOISE_OPTIMAL_GAMMA, flight.m_n, flight.g_n)
        return ScheduledGnssInsObserver(base, noise_scheduled_gain(DEMO_NOISE, flight.m_n, flight.g_n,
                                                                   initial=float(NOISE_OPTIMAL_GAMMA[0, 0])))
    if kind == "k-scheduled":  # the demo's default: K(t) and Γ(t) scheduled, switch times interleaved
        base = GnssInsObserver(K_opt, NOISE_OPTIMAL_GAMMA, flight.m_n, flight.g_n)
        ks = kalman_scheduled_gain(DEMO_NOISE, axis_gain(K_opt), imu_rate_hz=RATE, gnss_rate_hz=5.0)
        assert len(ks.gains) > 3
        return ScheduledGnssInsObserver(base, noise_scheduled_gain(DEMO_NOISE, flight.m_n, flight.g_n,
                                                                   initial=float(NOISE_OPTIMAL_GAMMA[0, 0])),
                                        gain_schedule=ks)
    if kind == "full-gamma":  # a non-diagonal Γ: the eigenvector path of the injection
        Q = rot_z(0.3) @ np.array([[1.0, 0.0, 0.0], [0.0, np.cos(0.4), -np.sin(0.4)], [0.0, np.sin(0.4), np.cos(0.4)]])
        return GnssInsObserver(paper_gains(), Q @ np.diag([5.0, 0.3, 0.2]) @ Q.T, flight.m_n, flight.g_n)
    if kind == "hold":
        return GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n, intersample="hold")
    if kind == "position-only":
        return GnssInsObserver(paper_gains(position_only=True), PAPER_GAMMA, flight.m_n, flight.g_n,
                               position_only=True)
    raise AssertionError(kind)


KINDS = ("paper", "noise-optimal", "scheduled", "k-scheduled", "full-gamma", "hold", "position-only")


def _data(make_traj, position_only: bool, batch: int | None = None):  # type: ignore[no-untyped-def]
    traj = make_traj(0, DURATION, RATE)
    data = generate_sensors(traj, imu_rate_hz=RATE, gnss_rate_hz=5.0, noise=DEMO_NOISE, seed=7, batch=batch,
                            position_only=position_only)
    return traj, drop_fixes(data, [40, 41, 42, 150])  # an outage and a lone missing fix: skipped in C too


def _rel(a, b) -> float:  # type: ignore[no-untyped-def]
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(np.asarray(b)))


def _check_equal(res_c, res_py) -> None:  # type: ignore[no-untyped-def]
    for name, get in (("p", M.p_hat), ("v", M.v_hat), ("R", M.R_hat)):
        assert _rel(get(res_c), get(res_py)) < RTOL, name
    assert _rel(res_c.extras["R_raw"], res_py.extras["R_raw"]) < RTOL
    np.testing.assert_array_equal(res_c.info["skipped_fixes"], res_py.info["skipped_fixes"])


@pytest.mark.parametrize("kind", KINDS)
def test_compiled_observer_equals_python_along_a_noisy_flight(kind, flight, make_traj, noise_optimal_K):
    obs = _observer(kind, flight, noise_optimal_K)
    traj, data = _data(make_traj, obs.position_only)
    R0 = traj.R[0] @ rot_z(np.radians(60.0))
    p0 = traj.p[0] + np.array([5.0, -3.0, 2.0])
    cobs = compile_observer(obs)
    py = run_navigation(obs, data, p0, traj.v[0], R0)
    c = run_navigation(cobs, data, p0, traj.v[0], R0)
    _check_equal(c, py)
    assert np.all(py.info["skipped_fixes"] == 4)
    assert M.attitude_error_deg(c)[..., -1] < 5.0  # it converged from 60°: the comparison is not of a divergence


@pytest.mark.parametrize("kind", ("paper", "scheduled", "k-scheduled", "position-only"))
def test_compiled_observer_equals_python_on_a_batch_of_flights(kind, flight, make_traj, noise_optimal_K):
    obs = _observer(kind, flight, noise_optimal_K)
    traj, data = _data(make_traj, obs.position_only, batch=3)
    R0 = traj.R[0] @ rot_z(np.radians([60.0, -100.0, 150.0]))
    p0 = traj.p[0] + np.array([5.0, -3.0, 2.0])
    py = run_navigation(obs, data, p0, traj.v[0], R0)
    c = run_navigation(compile_observer(obs), data, p0, traj.v[0], R0)
    assert M.p_hat(c).shape[0] == 3
    for r in range(3):
        for get in (M.p_hat, M.v_hat, M.R_hat):
            assert _rel(get(c)[r], get(py)[r]) < RTOL
    _check_equal(c, py)


@pytest.mark.parametrize("kind", ("paper", "scheduled", "k-scheduled", "full-gamma", "position-only"))
def test_run_record_in_c_equals_the_python_run(kind, flight, make_traj, noise_optimal_K):
    obs = _observer(kind, flight, noise_optimal_K)
    traj, data = _data(make_traj, obs.position_only)
    R0 = traj.R[0] @ rot_z(np.radians(60.0))
    p0 = traj.p[0] + np.array([5.0, -3.0, 2.0])
    py = run_navigation(obs, data, p0, traj.v[0], R0)
    t, u, y, sampled = data.record()
    cobs = compile_observer(obs)
    x0 = np.concatenate([p0, traj.v[0], R0.ravel()])
    raw = cobs.run_record(t, x0, u=u, y=y, sampled=sampled)
    assert raw.shape == (t.size, 15)
    assert _rel(raw[:, 0:3], M.p_hat(py)) < RTOL
    assert _rel(raw[:, 3:6], M.v_hat(py)) < RTOL
    assert _rel(raw[:, 6:15].reshape(-1, 3, 3), py.extras["R_raw"]) < RTOL
    est, _ = cobs.finish_estimates(raw.copy())
    assert _rel(est[:, 6:15].reshape(-1, 3, 3), M.R_hat(py)) < RTOL


@pytest.mark.parametrize("kind", KINDS)
def test_generated_c_compiles_strictly(kind, flight, noise_optimal_K):
    program = generate_gnss_ins(_observer(kind, flight, noise_optimal_K), "gnss_ins")
    header, source = render(program, "test")
    compile_object(source, strict=True, headers={program.header_name: header})
    assert program.correcting and program.own_step and program.own_estimate
    assert program.n_z == (23 if kind == "position-only" else 26) and program.n_x == 15 and program.n_u == 9
    assert "IMU period" in header and "gain K" in header


def test_header_describes_the_schedule(flight, noise_optimal_K):
    obs = _observer("scheduled", flight, noise_optimal_K)
    header, _ = render(generate_gnss_ins(obs, "sched"), "test")
    assert "Gamma(t)" in header and "switch times" in header and "SCHED_H" in header
    for t in obs.schedule.times:
        assert f"{t:.17g}" in header


def test_rhs_in_c_equals_python(flight, make_traj, noise_optimal_K):
    traj, data = _data(make_traj, False)
    u = data.imu_input()[123]
    for kind in ("paper", "scheduled", "full-gamma", "hold", "position-only"):
        obs = _observer(kind, flight, noise_optimal_K)
        cobs = compile_observer(obs)
        z = obs.init_state(traj.p[0] + 1.0, traj.v[0] - 0.5, traj.R[0] @ rot_z(0.7), np.array([0.1, -0.2, 0.3]))
        fix = np.concatenate([traj.p[0], traj.v[0]])[: 3 if obs.position_only else 6]
        z = obs.correct(0.0, z, u, fix, np.ones(fix.shape, dtype=bool))
        codec = gnss_ins_codec(obs.position_only)
        for t in (0.0, 30.0):
            want = obs.rhs(t, z, u, fix)
            got = codec.unpack(cobs.rhs(t, codec.pack(z), u, fix))
            for name in ("p", "v", "xi", "R", "y_p") + (() if obs.position_only else ("y_v",)):
                np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-13, atol=1e-12,
                                           err_msg=f"{kind}: {name}")
        assert not got.has_fix and got.skipped == 0  # the flag and the counter are constant: derivative 0


def test_codec_round_trip_and_correction_skips_a_missing_fix(flight, noise_optimal_K):
    obs = _observer("paper", flight, noise_optimal_K)
    cobs = compile_observer(obs)
    z = obs.init_state(np.zeros((2, 3)), np.ones(3), np.eye(3))
    codec = cobs.program.codec
    back = codec.unpack(codec.pack(z))
    for f in dataclasses.fields(z):
        if f.init:
            np.testing.assert_array_equal(getattr(back, f.name), getattr(z, f.name))
    fix = np.array([[1.0, 2.0, 3.0, 0.1, 0.2, 0.3], [1.0, np.nan, 3.0, 0.1, 0.2, 0.3]])
    zc = codec.unpack(cobs.correct(0.0, codec.pack(z), np.zeros(9), fix, np.ones(6, dtype=bool)))
    zp = obs.correct(0.0, z, np.zeros(9), fix, np.ones(6, dtype=bool))
    for name in ("y_p", "y_v", "has_fix", "skipped"):
        np.testing.assert_array_equal(getattr(zc, name), getattr(zp, name))
    assert list(zc.has_fix) == [True, False] and list(zc.skipped) == [0, 1]


def test_another_imu_period_is_refused_by_the_step_and_compiled_for_on_request(flight, make_traj):
    obs = _observer("paper", flight, None)
    traj = make_traj(0, 10.0, 200.0)
    data = generate_sensors(traj, imu_rate_hz=200.0, gnss_rate_hz=5.0, noise=DEMO_NOISE, seed=2)
    R0 = traj.R[0] @ rot_z(np.radians(30.0))
    with pytest.raises(NumericalError, match="IMU period"):  # generated for 100 Hz: P_step returns status 1 at 200 Hz
        run_navigation(compile_observer(obs), data, traj.p[0], traj.v[0], R0)
    c = run_navigation(compile_gnss_ins(obs, imu_period=1.0 / 200.0), data, traj.p[0], traj.v[0], R0)
    _check_equal(c, run_navigation(obs, data, traj.p[0], traj.v[0], R0))


def test_unsupported_configurations_are_refused(flight):
    with pytest.raises(InvalidArgumentError, match="split"):
        generate_gnss_ins(GnssInsObserver.paper(flight.m_n, flight.g_n, integrator="rk4"), "x")
    K = np.array(paper_gains(), dtype=float)
    K[0, 1] = 0.5  # couples the x and y axes
    with pytest.raises(InvalidArgumentError, match="couples the three axes"):
        generate_gnss_ins(GnssInsObserver(K, PAPER_GAMMA, flight.m_n, flight.g_n), "x")
    with pytest.raises(InvalidArgumentError, match="imu_period"):
        generate_gnss_ins(GnssInsObserver.paper(flight.m_n, flight.g_n), "x", imu_period=-1.0)


@pytest.mark.parametrize("kind", ("paper", "position-only"))
def test_c_init_and_raw_estimate_match_the_python_observer(kind, flight, noise_optimal_K):
    import ctypes

    obs = _observer(kind, flight, noise_optimal_K)
    cobs = compile_observer(obs)
    P, lib = cobs.program.prefix, cobs.library
    x0 = np.concatenate([[1.0, -2.0, 3.0], [4.0, 5.0, -6.0], rot_z(0.4).ravel()])
    z = np.empty(cobs.n_z)
    ptr = ctypes.POINTER(ctypes.c_double)
    assert getattr(lib, f"{P}_init")(x0.ctypes.data_as(ptr), z.ctypes.data_as(ptr)) == 0
    np.testing.assert_array_equal(z, cobs.init(x0))
    est = np.empty(15)
    getattr(lib, f"{P}_estimate")(z.ctypes.data_as(ptr), est.ctypes.data_as(ptr))
    np.testing.assert_array_equal(est, obs.raw_estimate(obs.init(x0)))
    np.testing.assert_array_equal(cobs.raw_estimate(z), est)


def test_the_header_attributes_observer_24_to_its_authors(flight, noise_optimal_K) -> None:  # type: ignore[no-untyped-def]
    # before: "of Grip, Fossen, Johansen & Saberi" in every generated header; observer (24) is Grip, Saberi & Johansen's
    prog = generate_gnss_ins(_observer("paper", flight, noise_optimal_K), "gi")
    header, source = render(prog, "test")
    for text in (header, source):
        assert "Grip, Saberi & Johansen" in text and "Fossen" not in text
