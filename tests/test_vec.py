"""vec/unvec against the column-major definition and the Kronecker identity vec(AXB) = (Bᵀ ⊗ A) vec X."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import DimensionError
from nlobs.systems.vec import unvec, vec


def test_vec_is_column_major_and_unvec_inverts_it() -> None:
    M = np.arange(6.0).reshape(2, 3)
    np.testing.assert_array_equal(vec(M), M.flatten(order="F"))
    rng = np.random.default_rng(0)
    B = rng.normal(size=(5, 4, 3, 2))
    np.testing.assert_array_equal(unvec(vec(B), 3, 2), B)


def test_kronecker_identity() -> None:
    rng = np.random.default_rng(1)
    A, X, B = rng.normal(size=(3, 3)), rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    np.testing.assert_allclose(vec(A @ X @ B), np.kron(B.T, A) @ vec(X), rtol=1e-12)


def test_shape_errors() -> None:
    with pytest.raises(DimensionError, match="vec: expected a"):
        vec(np.ones(3))
    with pytest.raises(DimensionError, match=r"unvec: expected shape \(\.\.\., 9\)"):
        unvec(np.ones(8), 3)
