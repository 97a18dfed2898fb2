"""SO(3) utilities: algebraic identities, round trips, stability near 0 and π, batching."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nlobs.errors import DimensionError
from nlobs.navigation.so3 import (
    R_from_euler,
    angle_between,
    euler_from_R,
    exp_so3,
    exp_so3_columns,
    log_so3,
    project_so3,
    quat_from_R,
    rot_x,
    rot_y,
    rot_z,
    skew,
    skew_columns,
    unskew,
)
from nlobs.navigation.split_kernel import exp_so3_scalar

vec3 = st.lists(st.floats(-10, 10, allow_nan=False), min_size=3, max_size=3).map(np.array)


def _random_rotvecs(rng: np.random.Generator, n: int, max_angle: float = np.pi) -> np.ndarray:
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    return u * rng.uniform(0, max_angle, (n, 1))


@given(vec3, vec3)
@settings(max_examples=50, deadline=None)
def test_skew_is_cross_product(a: np.ndarray, b: np.ndarray) -> None:
    np.testing.assert_allclose(skew(a) @ b, np.cross(a, b), atol=1e-12)
    np.testing.assert_allclose(unskew(skew(a)), a, atol=0)
    np.testing.assert_allclose(skew(a), -skew(a).T, atol=0)


def test_skew_batched_shapes() -> None:
    a = np.arange(24.0).reshape(2, 4, 3)
    assert skew(a).shape == (2, 4, 3, 3)
    np.testing.assert_array_equal(unskew(skew(a)), a)
    with pytest.raises(DimensionError):
        skew(np.zeros(4))
    with pytest.raises(DimensionError):
        unskew(np.zeros((3, 2)))


def test_exp_log_round_trip_all_angles() -> None:
    rng = np.random.default_rng(1)
    phi = _random_rotvecs(rng, 2000, np.pi * (1 - 1e-9))
    R = exp_so3(phi)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)
    np.testing.assert_allclose(log_so3(R), phi, atol=1e-12)


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-8, 1e-5, 1e-3 * (1 - 1e-9), 1e-3, 0.1])
def test_exp_log_near_zero(angle: float) -> None:
    u = np.array([0.48, -0.6, 0.64])
    phi = angle * u
    R = exp_so3(phi)
    # reference: exact Rodrigues with the series evaluated in extended form
    K = skew(u)
    R_ref = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    np.testing.assert_allclose(R, R_ref, atol=2e-16)
    np.testing.assert_allclose(log_so3(R), phi, atol=1e-15, rtol=1e-9)


@pytest.mark.parametrize("eps", [0.0, 1e-12, 1e-8, 1e-5, 1e-2])
def test_log_near_pi(eps: float) -> None:
    u = np.array([0.48, -0.6, 0.64])
    phi = (np.pi - eps) * u
    out = log_so3(exp_so3(phi))
    if eps == 0.0:  # both signs represent the same rotation
        assert min(np.abs(out - phi).max(), np.abs(out + phi).max()) < 1e-12
    else:
        np.testing.assert_allclose(out, phi, atol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(out), np.pi - eps, atol=1e-12)


def test_exp_is_rodrigues_of_matrix_exponential() -> None:
    from scipy.linalg import expm

    rng = np.random.default_rng(2)
    for phi in rng.normal(size=(20, 3)):
        np.testing.assert_allclose(exp_so3(phi), expm(skew(phi)), atol=1e-13)


def test_quaternion_is_unit_and_consistent() -> None:
    rng = np.random.default_rng(3)
    phi = _random_rotvecs(rng, 200)
    q = quat_from_R(exp_so3(phi))
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-15)
    ang = np.linalg.norm(phi, axis=-1)
    np.testing.assert_allclose(q[:, 0], np.cos(ang / 2), atol=1e-14)
    np.testing.assert_allclose(q[:, 1:], np.sin(ang / 2)[:, None] * phi / ang[:, None], atol=1e-14)


def test_project_so3_is_nearest_rotation() -> None:
    rng = np.random.default_rng(4)
    R = exp_so3(_random_rotvecs(rng, 100))
    np.testing.assert_allclose(project_so3(R), R, atol=1e-14)
    M = R + 0.05 * rng.normal(size=R.shape)
    P = project_so3(M)
    np.testing.assert_allclose(P @ np.swapaxes(P, -1, -2), np.broadcast_to(np.eye(3), P.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(P), 1.0, atol=1e-14)
    # nearer to M than any perturbed rotation
    for k in range(5):
        Q = P[k] @ exp_so3(1e-3 * rng.normal(size=3))
        assert np.linalg.norm(M[k] - P[k]) < np.linalg.norm(M[k] - Q)
    # a reflection-like input (det < 0) still yields det = +1
    assert np.linalg.det(project_so3(np.diag([1.0, 1.0, -1.0]))) == pytest.approx(1.0)


def test_euler_round_trip_and_formula() -> None:
    rng = np.random.default_rng(5)
    rpy = np.column_stack([rng.uniform(-np.pi, np.pi, 500), rng.uniform(-1.5, 1.5, 500), rng.uniform(-np.pi, np.pi, 500)])
    R = R_from_euler(rpy)
    np.testing.assert_allclose(euler_from_R(R), rpy, atol=1e-12)
    np.testing.assert_allclose(R, rot_z(rpy[:, 2]) @ rot_y(rpy[:, 1]) @ rot_x(rpy[:, 0]), atol=0)



def test_euler_of_random_rotations_round_trips() -> None:
    rng = np.random.default_rng(6)
    R = exp_so3(_random_rotvecs(rng, 500))
    np.testing.assert_allclose(R_from_euler(euler_from_R(R)), R, atol=1e-12)


def test_elementary_rotations_are_exponentials() -> None:
    for k, rot in enumerate((rot_x, rot_y, rot_z)):
        e = np.zeros(3)
        e[k] = 0.7
        np.testing.assert_allclose(rot(0.7), exp_so3(e), atol=1e-15)
    assert rot_x(np.zeros((2, 5))).shape == (2, 5, 3, 3)


def test_angle_between() -> None:
    rng = np.random.default_rng(7)
    R1 = exp_so3(_random_rotvecs(rng, 300))
    phi = _random_rotvecs(rng, 300)
    R2 = R1 @ exp_so3(phi)
    np.testing.assert_allclose(angle_between(R1, R2), np.linalg.norm(phi, axis=-1), atol=1e-12)
    np.testing.assert_allclose(angle_between(R2, R1), np.linalg.norm(phi, axis=-1), atol=1e-12)
    assert angle_between(R1[0], R1[0]) == pytest.approx(0.0, abs=1e-15)
    assert angle_between(np.eye(3), rot_z(np.pi)) == pytest.approx(np.pi)
    # broadcasting one matrix against a batch
    assert angle_between(np.eye(3), R1).shape == (300,)


@pytest.mark.parametrize("scale", [0.0, 1e-9, 1e-4, 9e-4, 1.2e-3, 2e-3, 0.3, 3.0])
def test_the_rodrigues_forms_agree(scale: float) -> None:
    """One formula per form: exp_so3 (NumPy, batch first), its batch-last layout, the fused scalar form."""
    rng = np.random.default_rng(int(scale * 1e9) % 2**32)
    phi = scale * rng.normal(size=(200, 3)) / np.sqrt(3.0)
    E = exp_so3(phi)
    # exactly the textbook evaluation I + A S + B S² (series below θ = 1e-3), with fewer NumPy calls
    th2 = np.sum(phi * phi, axis=-1)
    th = np.sqrt(th2)
    small = th < 1e-3
    ts = np.where(small, 1.0, th)
    A = np.where(small, 1.0 - th2 / 6.0 + th2 * th2 / 120.0, np.sin(ts) / ts)[:, None, None]
    B = np.where(small, 0.5 - th2 / 24.0 + th2 * th2 / 720.0, (1.0 - np.cos(ts)) / (ts * ts))[:, None, None]
    K = skew(phi)
    np.testing.assert_array_equal(E, np.eye(3) + A * K + B * (K @ K))
    np.testing.assert_allclose(exp_so3_columns(np.ascontiguousarray(phi.T)), E.transpose(1, 2, 0), rtol=0.0,
                               atol=1e-15)
    scalar = np.array([exp_so3_scalar(*map(float, f)) for f in phi]).reshape(-1, 3, 3)
    np.testing.assert_allclose(scalar, E, rtol=0.0, atol=1e-15)
    np.testing.assert_array_equal(skew_columns(np.ascontiguousarray(phi.T)), skew(phi).transpose(1, 2, 0))
    if scale == 0.0:
        np.testing.assert_array_equal(E, np.broadcast_to(np.eye(3), E.shape))
        np.testing.assert_array_equal(scalar, E)
