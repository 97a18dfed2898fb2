"""Sensor streams: exact when noise-free, statistics of the noise, rates, faults, validation."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.navigation.base import GNSS_OUTPUTS, IMU_INPUTS, NAV_STATES, nav_vector, split_nav
from nlobs.navigation.sensors import SensorNoise, drop_fixes, generate_sensors


@pytest.fixture(scope="module")
def traj(make_traj):  # type: ignore[no-untyped-def]
    return make_traj(3, 40.0, 50.0)


def test_noise_free_streams_equal_the_trajectory(traj) -> None:  # type: ignore[no-untyped-def]
    d = generate_sensors(traj, imu_rate_hz=50.0, gnss_rate_hz=5.0, noise=SensorNoise(), seed=0)
    np.testing.assert_array_equal(d.omega_b, traj.omega_b)
    np.testing.assert_array_equal(d.a_b, traj.a_b)
    np.testing.assert_array_equal(d.m_b, traj.m_b)
    np.testing.assert_array_equal(d.t_gnss, traj.t[::10])
    np.testing.assert_array_equal(d.p_gnss, traj.p[::10])
    np.testing.assert_array_equal(d.v_gnss, traj.v[::10])
    # conventions of navigation/base.py hold on the generated data: a^b = Rᵀ(v̇ − g), m^b = Rᵀ mⁿ
    np.testing.assert_allclose(np.einsum("kji,kj->ki", traj.R, traj.vdot - traj.g_n), d.a_b, atol=1e-12)
    np.testing.assert_allclose(np.einsum("kji,j->ki", traj.R, traj.m_n), d.m_b, atol=1e-12)


def test_noise_statistics_biases_batch_and_seed(traj) -> None:  # type: ignore[no-untyped-def]
    noise = SensorNoise(gyro_std=0.01, accel_std=0.2, gnss_p_std=2.0, accel_bias=(0.1, 0.0, -0.1))
    d = generate_sensors(traj, imu_rate_hz=50.0, gnss_rate_hz=5.0, noise=noise, seed=7, batch=20)
    assert d.a_b.shape == (20,) + traj.a_b.shape and d.p_gnss.shape == (20, traj.p[::10].shape[0], 3)
    e_gyro = d.omega_b - traj.omega_b
    e_acc = d.a_b - traj.a_b
    n = e_gyro.size
    assert np.std(e_gyro) == pytest.approx(0.01, rel=5 / np.sqrt(2 * n) * 3)
    np.testing.assert_allclose(e_acc.mean(axis=(0, 1)), [0.1, 0.0, -0.1], atol=5 * 0.2 / np.sqrt(e_acc[..., 0].size))
    assert np.std(d.p_gnss - traj.p[::10]) == pytest.approx(2.0, rel=0.05)
    again = generate_sensors(traj, imu_rate_hz=50.0, gnss_rate_hz=5.0, noise=noise, seed=7, batch=20)
    other = generate_sensors(traj, imu_rate_hz=50.0, gnss_rate_hz=5.0, noise=noise, seed=8, batch=20)
    np.testing.assert_array_equal(again.a_b, d.a_b)
    assert not np.array_equal(other.a_b, d.a_b)


def test_position_only_and_dropped_fixes(traj) -> None:  # type: ignore[no-untyped-def]
    d = generate_sensors(traj, imu_rate_hz=50.0, gnss_rate_hz=5.0, noise=SensorNoise(), seed=0, batch=3,
                         position_only=True)
    assert d.v_gnss is None
    dd = drop_fixes(d, [2, 5], batch_index=1)
    missing = np.isnan(dd.p_gnss).any(axis=-1)
    assert missing.sum() == 2 and missing[1, 2] and missing[1, 5]
    assert not np.isnan(d.p_gnss).any()  # the original is untouched


def test_validation(traj) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(InvalidArgumentError, match="gnss_rate_hz=3 must divide imu_rate_hz=50"):
        generate_sensors(traj, imu_rate_hz=50.0, gnss_rate_hz=3.0, noise=SensorNoise(), seed=0)
    with pytest.raises(InvalidArgumentError, match="imu_rate_hz=100 needs 0.01 s"):
        generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=SensorNoise(), seed=0)
    with pytest.raises(InvalidArgumentError, match="gyro_std: must be non-negative"):
        SensorNoise(gyro_std=-1.0)
    with pytest.raises(NonFiniteError, match="gnss_p_std: must be finite"):
        SensorNoise(gnss_p_std=float("nan"))
    with pytest.raises(InvalidArgumentError, match="fixes: indices must lie"):
        drop_fixes(generate_sensors(traj, imu_rate_hz=50.0, gnss_rate_hz=5.0, noise=SensorNoise(), seed=0), [10_000])


def test_bad_trajectories_raise_typed_errors(traj) -> None:  # type: ignore[no-untyped-def]
    kw = dict(imu_rate_hz=50.0, gnss_rate_hz=5.0, noise=SensorNoise(), seed=0)
    a_b = traj.a_b.copy()
    a_b[7, 1] = np.nan
    with pytest.raises(NonFiniteError, match="a_b"):
        generate_sensors(replace(traj, a_b=a_b), **kw)
    t = traj.t.copy()
    t[5] = t[4]
    with pytest.raises(InvalidArgumentError, match="times must increase"):
        generate_sensors(replace(traj, t=t), **kw)
    with pytest.raises(InvalidArgumentError, match="batch"):
        generate_sensors(traj, batch=0, **kw)


def test_fixes_fall_on_imu_instants_and_single_equals_batch_member_shapes(traj) -> None:  # type: ignore[no-untyped-def]
    d = generate_sensors(traj, imu_rate_hz=50.0, gnss_rate_hz=2.0, noise=SensorNoise(gnss_p_std=1.0),
                         seed=0)
    assert d.imu_rate_hz == 50.0 and d.gnss_rate_hz == 2.0
    k = np.rint(d.t_gnss * 50.0).astype(int)
    np.testing.assert_array_equal(d.t_imu[k], d.t_gnss)
    np.testing.assert_array_equal(np.diff(k), 25)
    assert d.omega_b.shape == traj.omega_b.shape and d.p_gnss.shape == (k.size, 3)


def test_channel_layouts_and_the_observer_inputs_without_copies(traj) -> None:  # type: ignore[no-untyped-def]
    assert len(IMU_INPUTS) == 9 and len(GNSS_OUTPUTS) == 6 and len(NAV_STATES) == 15
    assert NAV_STATES[6:9] == ("R11", "R12", "R13")  # R row-major
    d = generate_sensors(traj, imu_rate_hz=50.0, gnss_rate_hz=5.0, noise=SensorNoise(gyro_std=0.01, gnss_p_std=1.0),
                         seed=0, batch=4)
    u = d.imu_input()
    assert u.shape == (4, traj.t.size, 9) and not u.flags.writeable
    np.testing.assert_array_equal(u, np.concatenate([d.omega_b, d.a_b, d.m_b], axis=-1))
    assert np.shares_memory(u, d.omega_b) and np.shares_memory(u, d.m_b)  # a view of the one buffer: no copy
    one = replace(d, omega_b=d.omega_b[2], a_b=d.a_b[2], m_b=d.m_b[2], p_gnss=d.p_gnss[2], v_gnss=d.v_gnss[2])
    assert np.shares_memory(one.imu_input(), d.omega_b) and one.imu_input().shape == (traj.t.size, 9)
    np.testing.assert_array_equal(one.imu_input(), u[2])
    y = d.gnss_output()
    assert y.shape == (4, d.t_gnss.size, 6) and np.shares_memory(y, d.p_gnss)
    np.testing.assert_array_equal(y, np.concatenate([d.p_gnss, d.v_gnss], axis=-1))
    # streams that are not side by side (here: a broadcast single-flight rate gyro) are concatenated once
    mixed = replace(d, omega_b=traj.omega_b)
    np.testing.assert_array_equal(mixed.imu_input()[3, :, :3], traj.omega_b)
    np.testing.assert_array_equal(mixed.imu_input()[..., 3:], u[..., 3:])
    dropped = drop_fixes(d, [1], batch_index=0)
    assert np.isnan(dropped.gnss_output()[0, 1]).all() and np.isfinite(dropped.gnss_output()[1:]).all()
    po = generate_sensors(traj, imu_rate_hz=50.0, gnss_rate_hz=5.0, noise=SensorNoise(), seed=0, position_only=True)
    np.testing.assert_array_equal(po.gnss_output(), po.p_gnss)
    x = d.truth()
    assert x.shape == (traj.t.size, 15)
    p, v, R = split_nav(x)
    np.testing.assert_array_equal(p, traj.p)
    np.testing.assert_array_equal(v, traj.v)
    np.testing.assert_array_equal(R, traj.R)
    np.testing.assert_array_equal(R[5].reshape(9), x[5, 6:])
    np.testing.assert_array_equal(nav_vector(p, v, R), x)
    with pytest.raises(DimensionError, match="split_nav"):
        split_nav(np.zeros((3, 14)))
    with pytest.raises(DimensionError, match="nav_vector"):
        nav_vector(np.zeros(3), np.zeros(3), np.eye(2))
