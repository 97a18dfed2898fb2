"""The generated C of the navigation EKF against the Python filter (:mod:`nlobs.navigation.ekf`), along noisy flights.

The compiled filter runs through the recorded-data loop (:func:`nlobs.navigation.run.run_navigation`) and, for
one flight, entirely in C (``run_record``); its estimates equal the Python filter's to 1e-12 (relative, norm-wise
per quantity) with the magnetometer, without it, and for a position-only receiver; the C's dense products sum
in index order where NumPy calls BLAS, so the two agree to rounding, not bit for bit.
"""

from __future__ import annotations

import ctypes
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.errors import InvalidArgumentError
from nlobs.export import compile_observer, find_compiler
from nlobs.export.compiler import compile_object
from nlobs.export.nav_ekf import generate_nav_ekf, nav_ekf_codec
from nlobs.export.program import render
from nlobs.navigation import metrics as M
from nlobs.navigation.ekf import EkfConfig, ExtendedKalmanFilter
from nlobs.navigation.run import run_navigation
from nlobs.navigation.sensors import drop_fixes, generate_sensors
from nlobs.navigation.so3 import exp_so3, rot_z
from nlobs.workflows.demo import DEMO_NOISE

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler")

RTOL = 1e-12
RATE = 100.0
KINDS = ("demo", "no-magnetometer", "position-only")


def _ekf(kind: str, flight) -> ExtendedKalmanFilter:  # type: ignore[no-untyped-def]
    cfg = EkfConfig.for_noise(DEMO_NOISE, yaw_std_deg=60.0)
    return ExtendedKalmanFilter(cfg, flight.m_n, flight.g_n, position_only=kind == "position-only",
                                use_magnetometer=kind != "no-magnetometer")


def _data(make_traj, position_only: bool, batch: int | None = None):  # type: ignore[no-untyped-def]
    traj = make_traj(0, 60.0, RATE)
    data = generate_sensors(traj, imu_rate_hz=RATE, gnss_rate_hz=5.0, noise=DEMO_NOISE, seed=7, batch=batch,
                            position_only=position_only)
    return traj, drop_fixes(data, [40, 41, 42, 150])  # an outage and a lone missing fix: skipped in C too


def _rel(a, b) -> float:  # type: ignore[no-untyped-def]
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(np.asarray(b)))


@pytest.mark.parametrize("kind", KINDS)
def test_compiled_ekf_equals_python_along_a_noisy_flight(kind, flight, make_traj) -> None:  # type: ignore[no-untyped-def]
    ekf = _ekf(kind, flight)
    traj, data = _data(make_traj, ekf.position_only)
    R0 = traj.R[0] @ rot_z(np.radians(40.0))
    p0 = traj.p[0] + np.array([5.0, -3.0, 2.0])
    py = run_navigation(ekf, data, p0, traj.v[0], R0)
    c = run_navigation(compile_observer(ekf), data, p0, traj.v[0], R0)
    for get in (M.p_hat, M.v_hat, M.R_hat):
        assert _rel(get(c), get(py)) < RTOL
    np.testing.assert_array_equal(c.info["skipped_fixes"], py.info["skipped_fixes"])
    assert np.all(py.info["skipped_fixes"] == 4)
    assert M.attitude_error_deg(py)[..., -1] < 5.0  # it converged from 40°: the comparison is not of a divergence


def test_compiled_ekf_equals_python_on_a_batch_of_flights(flight, make_traj) -> None:  # type: ignore[no-untyped-def]
    ekf = _ekf("demo", flight)
    traj, data = _data(make_traj, False, batch=3)
    R0 = traj.R[0] @ rot_z(np.radians([20.0, -30.0, 45.0]))
    py = run_navigation(ekf, data, traj.p[0], traj.v[0], R0)
    c = run_navigation(compile_observer(ekf), data, traj.p[0], traj.v[0], R0)
    assert M.p_hat(c).shape[0] == 3
    for r in range(3):
        for get in (M.p_hat, M.v_hat, M.R_hat):
            assert _rel(get(c)[r], get(py)[r]) < RTOL


@pytest.mark.parametrize("kind", ("demo", "position-only"))
def test_run_record_in_c_equals_the_python_run(kind, flight, make_traj) -> None:  # type: ignore[no-untyped-def]
    ekf = _ekf(kind, flight)
    traj, data = _data(make_traj, ekf.position_only)
    R0 = traj.R[0] @ rot_z(np.radians(40.0))
    py = run_navigation(ekf, data, traj.p[0], traj.v[0], R0)
    t, u, y, sampled = data.record()
    raw = compile_observer(ekf).run_record(t, np.concatenate([traj.p[0], traj.v[0], R0.ravel()]), u=u, y=y,
                                           sampled=sampled)
    assert raw.shape == (t.size, 15)
    assert _rel(raw[:, 0:3], M.p_hat(py)) < RTOL
    assert _rel(raw[:, 3:6], M.v_hat(py)) < RTOL
    assert _rel(raw[:, 6:15].reshape(-1, 3, 3), M.R_hat(py)) < RTOL


def _moving(ekf: ExtendedKalmanFilter):  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(3)
    st = ekf.init_state(rng.normal(size=3), rng.normal(size=3) + [30.0, 5.0, -1.0], exp_so3(rng.normal(size=3)))
    A = rng.normal(size=(9, 9))
    return dataclasses.replace(st, P=A @ A.T / 9.0 + np.eye(9)), np.array([0.05, -0.1, 0.2, 0.4, -0.3, -9.3, 0.3, 0.05, 0.9])


@pytest.mark.parametrize("kind", KINDS)
def test_one_step_one_update_and_the_rhs_equal_python(kind, flight) -> None:  # type: ignore[no-untyped-def]
    ekf = _ekf(kind, flight)
    cobs = compile_observer(ekf)
    codec = nav_ekf_codec()
    st, u = _moving(ekf)
    z = codec.pack(st)
    pairs = [(codec.unpack(cobs.step(0.0, z, u, np.zeros(cobs.program.n_y), 0.01)), ekf.step(0.0, st, u, None, 0.01)),
             (codec.unpack(cobs.rhs(0.0, z, u, np.zeros(cobs.program.n_y))), ekf.rhs(0.0, st, u, None))]
    fix = np.r_[st.p + 2.0, st.v - 0.5][: cobs.program.n_y]
    fresh = np.ones(fix.shape, dtype=bool)
    pairs.append((codec.unpack(cobs.correct(0.0, z, u, fix, fresh)), ekf.correct(0.0, st, u, fix, fresh)))
    for got, want in pairs:
        for name in ("p", "v", "R", "P"):
            np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-12, atol=1e-12,
                                       err_msg=f"{kind}: {name}")
        np.testing.assert_array_equal(got.skipped, want.skipped)
    bad = fix.copy()
    bad[1] = np.nan
    skipped = codec.unpack(cobs.correct(0.0, z, u, bad, fresh))
    assert int(skipped.skipped) == 1 and np.array_equal(skipped.P, st.P)  # skipped and counted, P untouched
    assert int(ekf.correct(0.0, st, u, bad, fresh).skipped) == 1


def test_codec_round_trip_and_c_init(flight) -> None:  # type: ignore[no-untyped-def]
    ekf = _ekf("demo", flight)
    cobs = compile_observer(ekf)
    st = ekf.init_state(np.zeros((2, 3)), np.ones(3), np.eye(3))
    codec = nav_ekf_codec()
    back = codec.unpack(codec.pack(st))
    for f in dataclasses.fields(st):
        if f.name == "nis":  # the C state does not carry the GNSS fix's NIS: rebuilt without it (None)
            assert back.nis is None and ekf.diagnostics(back, np.zeros(9)).keys() == {"P_diag"}
            continue
        np.testing.assert_array_equal(getattr(back, f.name), getattr(st, f.name))
    x0 = np.concatenate([[1.0, -2.0, 3.0], [4.0, 5.0, -6.0], rot_z(0.4).ravel()])
    z = np.empty(cobs.n_z)
    ptr = ctypes.POINTER(ctypes.c_double)
    P = cobs.program.prefix
    assert getattr(cobs.library, f"{P}_init")(x0.ctypes.data_as(ptr), z.ctypes.data_as(ptr)) == 0
    np.testing.assert_array_equal(z, cobs.init(x0))  # the initial covariance printed into C is the filter's


@pytest.mark.parametrize("kind", KINDS)
def test_generated_c_compiles_strictly_and_says_what_it_is(kind, flight) -> None:  # type: ignore[no-untyped-def]
    program = generate_nav_ekf(_ekf(kind, flight), "nav")
    header, source = render(program, "test")
    compile_object(source, strict=True, headers={program.header_name: header})
    assert program.n_z == 97 and program.n_x == 15 and program.n_u == 9
    assert program.n_y == (3 if kind == "position-only" else 6)
    assert "Grip, Saberi & Johansen" in header and "Joseph form" in header
    assert ("magnetometer update" in header) == (kind != "no-magnetometer")


def test_a_step_that_is_not_positive_is_the_python_error(flight) -> None:  # type: ignore[no-untyped-def]
    ekf = _ekf("demo", flight)
    cobs = compile_observer(ekf)
    st, u = _moving(ekf)
    with pytest.raises(InvalidArgumentError, match="dt"):
        cobs.step(0.0, nav_ekf_codec().pack(st), u, np.zeros(6), 0.0)
    with pytest.raises(InvalidArgumentError, match="ExtendedKalmanFilter"):
        generate_nav_ekf(object(), "x")


def test_cli_exports_the_navigation_ekf_without_claiming_a_certificate(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["export", "gnss-ins", "--observer", "ekf", "--out", str(tmp_path), "--json"])
    assert res.exit_code == 0, res.output
    report = json.loads(res.stdout)
    assert report["observer"] == "ekf" and report["certified"] is False and report["verdict"] == "ok"
    header = (tmp_path / "gnss_ins_ekf.h").read_text(encoding="utf-8")
    assert "none: a Kalman filter carries no convergence guarantee" in header and "GNSS_INS_EKF_NZ 97" in header
    res = CliRunner().invoke(app, ["export", "gnss-ins", "--observer", "ekf", "--out", str(tmp_path), "--box", "0,1"])
    assert res.exit_code == 2 and "--box" in res.output and "Traceback" not in res.output
