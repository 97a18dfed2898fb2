"""The navigation conventions of ``nlobs.navigation.base``, pinned by concrete cases.

NED Earth frame, ``R`` body→Earth, ``Ṙ = R S(ω^b)``, ``gⁿ = [0, 0, +g]``,
specific force ``a^b = Rᵀ(v̇ⁿ − gⁿ)``, ``m^b = Rᵀ mⁿ``, ZYX Euler angles, ``vec`` by columns.
"""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.navigation.base import G0
from nlobs.navigation.so3 import R_from_euler, euler_from_R, exp_so3, rot_x, rot_y, rot_z, skew
from nlobs.systems.vec import unvec, vec

G_N = np.array([0.0, 0.0, G0])
M_N = np.array([0.35, -0.02, 0.94])  # a NED field pointing north and down


def specific_force(R: np.ndarray, vdot_n: np.ndarray) -> np.ndarray:
    return R.T @ (vdot_n - G_N)


def test_level_aircraft_at_rest_reads_minus_g_on_z() -> None:
    R = R_from_euler([0.0, 0.0, 0.0])
    np.testing.assert_allclose(specific_force(R, np.zeros(3)), [0.0, 0.0, -G0])


def test_free_fall_reads_zero() -> None:
    R = R_from_euler([0.3, -0.4, 1.0])
    np.testing.assert_allclose(specific_force(R, G_N), 0.0, atol=1e-15)


def test_heading_north_level_reads_earth_field() -> None:
    R = R_from_euler([0.0, 0.0, 0.0])
    np.testing.assert_allclose(R.T @ M_N, M_N)


def test_yaw_90_maps_body_x_to_east() -> None:
    R = R_from_euler([0.0, 0.0, np.pi / 2])
    np.testing.assert_allclose(R @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)
    # and the magnetometer then sees north on its −y (left) axis
    np.testing.assert_allclose((R.T @ [1.0, 0.0, 0.0]), [0.0, -1.0, 0.0], atol=1e-15)


def test_positive_pitch_is_nose_up() -> None:
    R = R_from_euler([0.0, 0.2, 0.0])
    nose = R @ [1.0, 0.0, 0.0]
    assert nose[2] < 0  # NED: up is negative down
    # a nose-up level-held accelerometer sees gravity reaction tilted toward +x
    f = specific_force(R, np.zeros(3))
    assert f[0] > 0 and f[2] < 0


def test_positive_roll_is_right_wing_down() -> None:
    R = R_from_euler([0.2, 0.0, 0.0])
    right_wing = R @ [0.0, 1.0, 0.0]
    assert right_wing[2] > 0  # points down


def test_euler_is_zyx_product() -> None:
    rpy = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(R_from_euler(rpy), rot_z(0.3) @ rot_y(-0.2) @ rot_x(0.1), atol=0)
    np.testing.assert_allclose(euler_from_R(R_from_euler(rpy)), rpy, atol=1e-15)


def test_pure_roll_rate_integrates_to_rot_x() -> None:
    # Ṙ = R S(ω^b), ω^b = [w, 0, 0] from R(0) = I → R(t) = R_x(w t); RK4 at 1 kHz
    w, T, dt = 0.5, 2.0, 1e-3
    R = np.eye(3)
    Om = skew([w, 0.0, 0.0])
    for _ in range(int(round(T / dt))):
        k1 = R @ Om
        k2 = (R + 0.5 * dt * k1) @ Om
        k3 = (R + 0.5 * dt * k2) @ Om
        k4 = (R + dt * k3) @ Om
        R = R + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    np.testing.assert_allclose(R, rot_x(w * T), atol=1e-12)
    np.testing.assert_allclose(exp_so3([w * T, 0, 0]), rot_x(w * T), atol=1e-15)


def test_body_rate_is_in_body_axes() -> None:
    # yawed 90° then rolling about body x: the Earth-frame axis of rotation is east
    R0 = rot_z(np.pi / 2)
    dR = R0 @ exp_so3([1e-6, 0, 0]) - R0
    # dR R0ᵀ ≈ S(R0 ω^b dt) = S(east · 1e-6)
    np.testing.assert_allclose(dR @ R0.T, skew([0.0, 1e-6, 0.0]), atol=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_skew_is_cross(seed: int) -> None:
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(2, 3))
    np.testing.assert_allclose(skew(a) @ b, np.cross(a, b), atol=1e-14)


def test_vec_stacks_columns() -> None:
    R = R_from_euler([0.1, 0.2, 0.3])
    np.testing.assert_array_equal(vec(R)[:3], R[:, 0])
    np.testing.assert_array_equal(unvec(vec(R), 3), R)
