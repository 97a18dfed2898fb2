"""Symbolic models and their compilation, checked against hand-written NumPy and finite differences."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from nlobs.errors import DimensionError, ModelError, NonFiniteError, UnknownNameError
from nlobs.systems.base import PlantModel
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.symbolic import SymbolicModel
from nlobs.systems.timebase import Discrete

x1, x2, x3, x4, u, k = sp.symbols("x1 x2 x3 x4 u k")


def isidori(k_value: float = 2.0) -> SymbolicModel:
    return SymbolicModel.input_affine(
        ["x1", "x2", "x3", "x4"], ["u"], ["y"],
        f=[x1 * x2 - x1**3, x1, -x3, x1**2 + x2],
        g=[[0], [k + 2 * x3], [1], [0]],
        h=[x4],
        parameters={"k": k_value},
        name="isidori",
    )


def isidori_numpy(x: np.ndarray, uu: np.ndarray, kv: float) -> np.ndarray:
    a, b, c, d = np.moveaxis(x, -1, 0)
    w = uu[..., 0]
    return np.stack([a * b - a**3, a + (kv + 2 * c) * w, -c + w, a**2 + b], axis=-1)


def test_compiled_rhs_matches_hand_written_numpy_on_a_batch() -> None:
    rng = np.random.default_rng(1)
    x = rng.normal(size=(7, 3, 4))
    w = rng.normal(size=(7, 3, 1))
    c = isidori().compile()
    np.testing.assert_allclose(c.rhs(0.0, x, w), isidori_numpy(x, w, 2.0), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(c.output(0.0, x, w), x[..., 3:4], rtol=0, atol=0)
    assert c.rhs(0.0, x[0, 0], w[0, 0]).shape == (4,)


def test_parameter_override_at_compile_time() -> None:
    rng = np.random.default_rng(2)
    x, w = rng.normal(size=(5, 4)), rng.normal(size=(5, 1))
    c = isidori().compile(parameters={"k": -1.5})
    np.testing.assert_allclose(c.rhs(0.0, x, w), isidori_numpy(x, w, -1.5), rtol=1e-13)
    with pytest.raises(UnknownNameError, match="no parameter named 'kk'"):
        isidori().compile(parameters={"kk": 1.0})


def test_jacobians_match_central_differences() -> None:
    rng = np.random.default_rng(3)
    c = isidori().compile()
    x, w = rng.normal(size=4), rng.normal(size=1)
    J = c.rhs_jacobian_x(0.0, x, w)
    h = 1e-6
    fd = np.stack([(c.rhs(0, x + h * e, w) - c.rhs(0, x - h * e, w)) / (2 * h) for e in np.eye(4)], axis=-1)
    np.testing.assert_allclose(J, fd, atol=1e-7)
    Ju = c.rhs_jacobian_u(0.0, x, w)
    fdu = (c.rhs(0, x, w + h) - c.rhs(0, x, w - h)) / (2 * h)
    np.testing.assert_allclose(Ju[:, 0], fdu, atol=1e-7)
    np.testing.assert_array_equal(c.output_jacobian_x(0.0, x, w), [[0, 0, 0, 1]])
    assert c.rhs_jacobian_x(0.0, rng.normal(size=(6, 4)), rng.normal(size=(6, 1))).shape == (6, 4, 4)


def test_constant_entries_broadcast_to_the_batch() -> None:
    fn = compile_matrix(sp.Matrix([[x1, 0], [3, 1]]), [(x1,)])
    out = fn(np.arange(5.0).reshape(5, 1))
    assert out.shape == (5, 2, 2)
    np.testing.assert_array_equal(out[:, 1, 0], 3.0)
    np.testing.assert_array_equal(out[:, 0, 0], np.arange(5.0))


def test_free_symbol_that_is_not_an_argument_is_an_error() -> None:
    with pytest.raises(ModelError, match="free symbols that are not arguments: k"):
        compile_matrix(sp.Matrix([x1 + k]), [(x1,)])
    with pytest.raises(ModelError, match=r"undeclared symbols \['q'\]"):
        SymbolicModel.general(["x1"], [], ["y"], [sp.Symbol("q") * x1], [x1])


def test_model_validation_errors() -> None:
    with pytest.raises(DimensionError, match="f: expected 2 entries"):
        SymbolicModel.input_affine(["x1", "x2"], [], ["y"], [x1], None, [x1])
    with pytest.raises(DimensionError, match=r"g: expected shape \(2, 1\)"):
        SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], [x1, x2], [[1, 0]], [x1])
    with pytest.raises(ModelError, match="must not depend on inputs"):
        SymbolicModel.input_affine(["x1"], ["u"], ["y"], [u * x1], [[1]], [x1])
    with pytest.raises(ModelError, match="duplicate state names: x1"):
        SymbolicModel.general(["x1", "x1"], [], ["y"], [x1, x1], [x1])
    with pytest.raises(ModelError, match="names used twice"):
        SymbolicModel.general(["x1"], ["x1"], ["y"], [x1], [x1])
    with pytest.raises(NonFiniteError, match="parameter 'k' is not finite"):
        SymbolicModel.general(["x1"], [], ["y"], [k * x1], [x1], parameters={"k": float("nan")})
    with pytest.raises(ModelError, match="not a valid identifier"):
        SymbolicModel.general(["x 1"], [], ["y"], [x1], [x1])


def test_compiled_model_is_a_plant_and_rejects_bad_shapes() -> None:
    c = isidori().compile()
    assert isinstance(c, PlantModel)
    assert (c.n, c.m, c.p) == (4, 1, 1)
    with pytest.raises(DimensionError, match=r"expected shape \(\.\.\., 4\)"):
        c.rhs(0.0, np.zeros(3), np.zeros(1))


def test_general_discrete_model_compiles() -> None:
    m = SymbolicModel.general(["x1", "x2"], ["u"], ["y"], [x2, -sp.sin(x1) + u], [x1 + u], time=Discrete(0.1))
    c = m.compile()
    out = c.rhs(0.0, np.array([[0.3, 0.1]]), np.array([[2.0]]))
    np.testing.assert_allclose(out, [[0.1, -np.sin(0.3) + 2.0]], rtol=1e-14)
    np.testing.assert_allclose(c.output_jacobian_u(0.0, np.zeros(2), np.zeros(1)), [[1.0]])
    assert not m.is_input_affine and c.time.dt == 0.1
