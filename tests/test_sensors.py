"""Sensor streams: exact when noise-free, statistics of the noise, rates, faults, validation."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError, NonFiniteError
from nlobs.navigation.sensors import SensorNoise, drop_fixes, generate_sensors
from nlobs.navigation.trajectory import traffic_pattern


@pytest.fixture(scope="module")
def traj():  # type: ignore[no-untyped-def]
    return traffic_pattern(seed=3, duration=40.0).sample(50.0)


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
    from dataclasses import replace

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
