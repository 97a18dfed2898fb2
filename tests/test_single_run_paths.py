"""The single-run fast paths give the batched paths' numbers: compiled functions, RK4 of a filter's state, the UKF.

Everyday speed made one run of a filter cheaper (NumPy scalars into the generated code, a flat record's RK4 without
the tree walk, the EKF's ``f`` and ``∂f/∂x`` from one call); the answers must not move. Each check compares the fast
path with the general one on the same inputs, bit for bit where the operations are the same.
"""

from __future__ import annotations

import glob
from pathlib import Path

import numpy as np
import pytest

from nlobs import EKF, UKF
from nlobs.errors import ModelError
from nlobs.methods.problem import symbolic_model
from nlobs.observers.gaussian import FilterState
from nlobs.simulate import rk4_step
from nlobs.simulate.state import flat_fields, tree_map
from nlobs.systems.codegen import evaluate_together

MODELS = sorted(glob.glob(str(Path(__file__).resolve().parents[1] / "src" / "nlobs" / "data" / "models" / "*.toml")))


def _compiled(path: str):  # type: ignore[no-untyped-def]
    try:
        return symbolic_model(path).compile()
    except ModelError:
        return None  # a linear model: no generated code


@pytest.mark.parametrize("path", MODELS, ids=lambda p: Path(p).stem)
def test_one_run_of_generated_code_equals_the_batched_call_bit_for_bit(path: str) -> None:
    plant = _compiled(path)
    if plant is None:
        pytest.skip("linear model")
    rng = np.random.default_rng(1)
    X = rng.normal(size=(50, plant.n))
    U = rng.normal(size=(50, plant.m))
    with np.errstate(all="ignore"):
        for method in ("rhs", "output", "rhs_jacobian_x", "output_jacobian_x", "rhs_jacobian_u"):
            fn = getattr(plant, method)
            batched = fn(0.0, X, U)
            single = np.stack([fn(0.0, X[i], U[i]) for i in range(len(X))])
            np.testing.assert_array_equal(single, batched, err_msg=method)
        for i in range(len(X)):
            f, F = plant.rhs_and_jacobian_x(0.0, X[i], U[i])
            np.testing.assert_array_equal(f, plant.rhs(0.0, X[i], U[i]))
            np.testing.assert_array_equal(F, plant.rhs_jacobian_x(0.0, X[i], U[i]))
            h, H = plant.output_and_jacobian_x(0.0, X[i], U[i])
            np.testing.assert_array_equal(h, plant.output(0.0, X[i], U[i]))
            np.testing.assert_array_equal(H, plant.output_jacobian_x(0.0, X[i], U[i]))


def test_one_run_keeps_numpys_division_by_zero() -> None:
    """NumPy scalars, not Python floats: 1/x at 0 is inf (a Python float would raise ZeroDivisionError)."""
    import sympy as sp

    from nlobs.systems.codegen import compile_matrix

    x = sp.symbols("x1 x2")
    fn = compile_matrix([1 / x[0], sp.log(x[1])], (x,), vector=True)
    with np.errstate(all="ignore"):
        out = fn(np.array([0.0, 0.0]))
    assert out[0] == np.inf and out[1] == -np.inf
    with pytest.raises(Exception):  # noqa: B017 - any DimensionError subclass of the library
        evaluate_together((fn, fn), np.array([0.0]))


def _rk4_by_tree(f, t, y, h):  # type: ignore[no-untyped-def]
    k1 = f(t, y)
    k2 = f(t + 0.5 * h, tree_map(lambda a, b: a + (0.5 * h) * b, y, k1))
    k3 = f(t + 0.5 * h, tree_map(lambda a, b: a + (0.5 * h) * b, y, k2))
    k4 = f(t + h, tree_map(lambda a, b: a + h * b, y, k3))
    return tree_map(lambda a, b1, b2, b3, b4: a + (h / 6.0) * (b1 + 2.0 * b2 + 2.0 * b3 + b4), y, k1, k2, k3, k4)


@pytest.mark.parametrize("nis", [np.zeros(()), np.float64(2.5), np.zeros(7)], ids=["0-d", "scalar", "batch"])
def test_rk4_of_a_flat_record_equals_the_tree_walk(nis) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(3)
    batch = (7,) if np.ndim(nis) else ()
    z = FilterState(rng.normal(size=batch + (3,)), rng.normal(size=batch + (3, 3)), nis)
    assert flat_fields(z) is not None
    A = rng.normal(size=(3, 3))

    def f(t, s):  # type: ignore[no-untyped-def]
        return FilterState(np.sin(s.x) @ A.T + t, s.P @ A + A.T @ s.P, np.zeros(np.shape(s.nis)))

    fast, slow = rk4_step(f, 0.3, z, 1e-2), _rk4_by_tree(f, 0.3, z, 1e-2)
    for name in ("x", "P"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(slow, name))
    np.testing.assert_array_equal(fast.nis, slow.nis)
    assert type(fast.nis) is type(slow.nis)


def _flexible_joint():  # type: ignore[no-untyped-def]
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from kalman_baselines import flexible_joint

    return flexible_joint()


@pytest.mark.parametrize("kind", [EKF, UKF], ids=["EKF", "UKF"])
def test_one_run_of_a_filter_equals_its_batched_run(kind) -> None:  # type: ignore[no-untyped-def]
    """A batch of one run through the general (batched) code and the same run through the single-run path."""
    plant = _flexible_joint()
    Q, R, P0 = np.diag([1e-6, 1e-4, 1e-6, 1e-4]), np.diag([1e-6, 1e-4]), np.eye(4) * 0.1
    flt = kind(plant, Q, R, P0)
    rng = np.random.default_rng(5)
    z1 = flt.init(np.array([0.1, 0.0, -0.2, 0.0]))
    zb = flt.init(np.array([[0.1, 0.0, -0.2, 0.0]]))
    fresh = np.ones(2, dtype=bool)
    for k in range(200):
        u, y = np.array([0.3 * np.sin(k / 50)]), rng.normal(0.0, 0.01, 2)
        z1 = flt.correct(k * 1e-3, z1, u, y, fresh)
        zb = flt.correct(k * 1e-3, zb, u[None], y[None], fresh)
        z1 = rk4_step(lambda t, z: flt.rhs(t, z, u, y), k * 1e-3, z1, 1e-3)
        zb = rk4_step(lambda t, z: flt.rhs(t, z, u[None], y[None]), k * 1e-3, zb, 1e-3)
    np.testing.assert_allclose(z1.x, zb.x[0], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(z1.P, zb.P[0], rtol=1e-10, atol=1e-15)


def test_a_matrix_compiled_twice_is_compiled_once_and_the_cache_is_bounded() -> None:
    import sympy as sp

    from nlobs.systems import codegen

    x = sp.symbols("x1 x2")
    a = codegen.compile_matrix([x[0] * x[1], sp.sin(x[1])], (x,), vector=True, what="first")
    b = codegen.compile_matrix(sp.Matrix([x[0] * x[1], sp.sin(x[1])]), (x,), vector=True, what="second")
    assert a is b  # the same expressions of the same arguments
    c = codegen.compile_matrix([x[0] * x[1], sp.sin(x[1])], (x,), what="matrix")  # not vector: another function
    assert c is not a and c(np.array([2.0, 0.0])).shape == (2, 1)
    d = codegen.compile_matrix([x[1] * x[0], sp.sin(x[1])], (tuple(reversed(x)),), vector=True)  # other arguments
    assert d is not a and d(np.array([0.0, 2.0])).tolist() == a(np.array([2.0, 0.0])).tolist()
    for i in range(codegen.COMPILED_CACHE_SIZE + 5):
        codegen.compile_matrix([x[0] + i], (x,), vector=True)
    assert len(codegen._COMPILED) == codegen.COMPILED_CACHE_SIZE


def test_rk4_of_a_plant_and_filter_tuple_equals_the_tree_walk() -> None:
    """The loop integrates ``(x, z)`` together; with ``z`` a filter's state the members are combined directly."""
    rng = np.random.default_rng(4)
    x = rng.normal(size=4)
    z = FilterState(rng.normal(size=3), rng.normal(size=(3, 3)), np.float64(1.5))
    A = rng.normal(size=(3, 3))

    def f(t, xz):  # type: ignore[no-untyped-def]
        xs, zs = xz
        return np.cos(xs) + t, FilterState(np.sin(zs.x) @ A.T, zs.P @ A + A.T @ zs.P, np.zeros(()))

    fast, slow = rk4_step(f, 0.1, (x, z), 1e-2), _rk4_by_tree(f, 0.1, (x, z), 1e-2)
    np.testing.assert_array_equal(fast[0], slow[0])
    np.testing.assert_array_equal(fast[1].x, slow[1].x)
    np.testing.assert_array_equal(fast[1].P, slow[1].P)
    assert fast[1].nis == slow[1].nis == 1.5


def test_one_run_of_simulate_equals_a_batch_of_one() -> None:
    """``nlobs simulate MODEL --runs 1`` runs without a batch axis and puts one back (``with_run_axis``)."""
    from nlobs.simulate import simulate
    from nlobs.simulate.result import with_run_axis
    from nlobs.systems.sensors import MeasurementGroup

    plant = _flexible_joint()
    Q, R, P0 = np.diag([1e-6, 1e-4, 1e-6, 1e-4]), np.diag([1e-6, 1e-4]), np.eye(4) * 0.1
    x0, xh0 = np.array([0.3, 0.0, 0.2, 0.0]), np.zeros(4)
    sensors = [MeasurementGroup("enc", (0, 1), rate=100.0, noise_std=(1e-3, 1e-2))]
    for flt in (EKF(plant, Q, R, P0), UKF(plant, Q, R, P0)):
        kw = dict(duration=0.5, dt=1e-3, u=lambda t: np.array([0.2]), measurements=sensors, seed=3,
                  process_noise=np.array([0.0, 1e-3, 0.0, 1e-3]))
        one = with_run_axis(simulate(plant, flt, x0, xh0, **kw))
        batch = simulate(plant, flt, x0[None], xh0[None], **kw)
        assert one.x_hat.shape == batch.x_hat.shape == (1, 501, 4)
        np.testing.assert_array_equal(one.x, batch.x)  # the plant: bit for bit (same code, same noise)
        np.testing.assert_array_equal(one.y, batch.y)
        np.testing.assert_allclose(one.x_hat, batch.x_hat, rtol=1e-11, atol=1e-14)
        assert set(one.extras) == set(batch.extras)
        for k in one.extras:
            np.testing.assert_allclose(one.extras[k], batch.extras[k], rtol=1e-9, atol=1e-14)
    with pytest.raises(Exception, match="batch shape"):
        with_run_axis(batch)


def test_constant_entries_assigned_at_once_equal_the_entry_by_entry_values() -> None:
    """A batch's constant entries (a Jacobian's zeros and ones) are written in one assignment from the values the
    generated code gave at the first call; every batch shape after it gets the same array as entry by entry."""
    import sympy as sp

    from nlobs.systems.codegen import compile_matrix

    x = sp.symbols("x1 x2")
    fn = compile_matrix(sp.Matrix([[x[0] * x[1], 0, sp.Rational(10, 11)], [sp.pi, x[1] ** 3, 1]]), (x,))
    rng = np.random.default_rng(0)
    for shape in [(3,), (2, 5), (1,)]:
        X = rng.normal(size=(*shape, 2))
        want = np.empty((*shape, 2, 3))
        want[..., 0, 0] = X[..., 0] * X[..., 1]
        want[..., 0, 1] = 0.0
        want[..., 0, 2] = 10 / 11
        want[..., 1, 0] = np.pi
        want[..., 1, 1] = np.power(X[..., 1], 3)
        want[..., 1, 2] = 1.0
        np.testing.assert_array_equal(fn(X), want)
        np.testing.assert_array_equal(fn(X[(0,) * len(shape)]), want[(0,) * len(shape)])
