"""Newton's polar iteration (navigation/polar.py) against the SVD projection onto SO(3)."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import DimensionError
from nlobs.navigation.polar import nearest_rotation
from nlobs.navigation.so3 import exp_so3, project_so3


@pytest.mark.parametrize("spread", [0.0, 1e-6, 1e-2, 0.3, 1.0, 3.0])
def test_equals_the_svd_projection(spread):
    rng = np.random.default_rng(int(spread * 1e6) + 1)
    Q = exp_so3(rng.normal(size=(20000, 3)))
    M = Q * rng.uniform(0.5, 2.0, size=(20000, 1, 1)) + spread * rng.normal(size=(20000, 3, 3))
    R = nearest_rotation(M)
    np.testing.assert_allclose(R, project_so3(M), rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-13)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-13)
    if spread == 0.0:  # a scaled rotation projects to the rotation
        np.testing.assert_allclose(R, Q, atol=1e-14)


def test_reflections_and_near_singular_matrices_go_to_the_svd():
    Q = exp_so3(np.array([[0.3, -1.0, 2.0], [0.0, 0.0, 0.1], [1.0, 1.0, 1.0]]))
    M = np.stack([Q[0] @ np.diag([1.0, 1.0, -0.5]),           # det < 0: a rotation with det(UVᵀ) flipped
                  Q[1] @ np.diag([1.0, 1e-9, 1e-9]),          # near-singular
                  Q[2] @ np.diag([2.0, 1.0, 0.0]),            # singular
                  Q[0]])
    np.testing.assert_array_equal(nearest_rotation(M)[:3], project_so3(M[:3]))
    np.testing.assert_allclose(nearest_rotation(M)[3], Q[0], atol=1e-15)


def test_shapes_and_bad_input():
    M = exp_so3(np.random.default_rng(0).normal(size=(2, 4, 3))) + 0.01
    out = nearest_rotation(M)
    assert out.shape == (2, 4, 3, 3) and out.flags.owndata
    np.testing.assert_allclose(nearest_rotation(M[0, 1]), project_so3(M[0, 1]), atol=1e-14)
    with pytest.raises(DimensionError, match="nearest_rotation"):
        nearest_rotation(np.zeros((3, 2)))
    with pytest.raises(np.linalg.LinAlgError):  # NaN: what the SVD projection does
        nearest_rotation(np.full((3, 3), np.nan))


def test_input_is_not_modified():
    for M in (np.full((3, 3), np.nan), np.diag([1.0, 1.0, -1.0]), np.eye(3) * 2.0):
        before = M.copy()
        try:
            nearest_rotation(M)
        except np.linalg.LinAlgError:
            pass
        np.testing.assert_array_equal(M, before)


def test_out_receives_the_result_in_place():
    M = exp_so3(np.random.default_rng(3).normal(size=(5, 7, 3))) * 1.3 + 0.01
    record = np.zeros((7, 5, 15))                              # matrices stored as row-major 9-blocks of a record
    dest = record[..., 6:].view()
    dest.shape = (7, 5, 3, 3)
    assert nearest_rotation(np.swapaxes(M, 0, 1), out=dest) is dest
    np.testing.assert_allclose(record[..., 6:].reshape(7, 5, 3, 3), project_so3(np.swapaxes(M, 0, 1)), atol=1e-14)
    assert np.all(record[..., :6] == 0.0)
    strided = np.empty((3, 3, 5, 7)).transpose(2, 3, 0, 1)     # not flattenable in place: written by index
    np.testing.assert_allclose(nearest_rotation(M, out=strided), project_so3(M), atol=1e-14)
    with pytest.raises(DimensionError, match="out"):
        nearest_rotation(M, out=np.empty((5, 3, 3)))
