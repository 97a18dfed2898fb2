"""The generated C of the impulsive observer (:mod:`nlobs.export.impulsive`) equals the Python one.

:class:`~nlobs.observers.impulsive.ImpulsiveObserver` of a compiled symbolic model (the shipped pendulum, and a
two-output nonlinear model) and of a linear system: the compiled module, stepped and corrected by
:func:`nlobs.simulate.simulate` with sampled sensors (multi-rate), or called directly (``rhs``, ``correct``,
``P_init``, ``P_run``), gives the Python observer's numbers; a non-finite sample is not corrected in C as in Python.
"""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import CompilerError, InvalidArgumentError
from nlobs.export import compile_observer, export_observer, find_compiler, generate, render, supported
from nlobs.observers.impulsive import ImpulsiveObserver
from nlobs.simulate import run_observer, simulate
from nlobs.simulate.integrators import rk4_step
from nlobs.simulate.sampling import MeasurementGroup
from nlobs.systems.linear import LinearSystem
from nlobs.systems.modelfile import load_model, parse_model

try:
    find_compiler()
except CompilerError:  # pragma: no cover - make test installs the codegen extra (a compiler)
    pytest.skip("no C compiler", allow_module_level=True)

_TWO_OUTPUTS = """
name = "pendulum2"
time = "continuous"
states = ["theta", "omega"]
inputs = ["tau"]
outputs = ["angle", "rate"]
parameters = { g = 9.81, l = 1.0, c = 0.2 }

[dynamics]
f = ["omega", "-(g/l)*sin(theta) - c*omega"]
g = [["0"], ["2"]]
h = ["theta", "omega + 0.1*sin(theta)"]
"""


def rel(a: np.ndarray, b: np.ndarray) -> float:
    """Norm-wise relative difference ``max|a − b| / max|b|``."""
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300))


def _pendulum() -> tuple[ImpulsiveObserver, object]:
    plant = load_model("pendulum").compile()
    return ImpulsiveObserver(plant, np.array([[0.3], [0.4]])), plant


def _two_outputs() -> tuple[ImpulsiveObserver, object]:
    plant = parse_model(_TWO_OUTPUTS).compile()
    return ImpulsiveObserver(plant, np.array([[0.4, 0.05], [0.1, 0.3]])), plant


def _linear() -> tuple[ImpulsiveObserver, LinearSystem]:
    A = np.array([[0.0, 1.0, 0.0], [-2.0, -0.5, 1.0], [0.0, 0.0, -1.0]])
    B = np.array([[0.0], [1.0], [0.5]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    D = np.array([[0.0], [0.1]])
    sys = LinearSystem(A, B, C, D)
    L = np.array([[0.5, 0.05], [0.4, 0.1], [0.0, 0.6]])
    return ImpulsiveObserver(sys, L), sys


_CASES = {"pendulum": _pendulum, "two-outputs": _two_outputs, "linear": _linear}


def test_the_impulsive_observer_is_exported() -> None:
    assert "ImpulsiveObserver" in supported()


@pytest.mark.parametrize("which", list(_CASES))
def test_simulate_with_sampled_sensors_gives_the_python_numbers(which: str) -> None:
    obs, plant = _CASES[which]()
    if which == "pendulum":
        sens = (MeasurementGroup("enc", ("y",), rate=20.0, noise_std=0.01),)
        x0, xh0, u = [[1.0, 0.0], [0.5, -0.5]], [[0.0, 0.0], [1.5, 0.5]], [0.3]
    elif which == "two-outputs":
        sens = (MeasurementGroup("angle", ("angle",), rate=40.0, noise_std=0.01),
                MeasurementGroup("rate", ("rate",), rate=10.0, noise_std=0.02))  # multi-rate
        x0, xh0, u = [[1.0, 0.0], [0.5, -0.5]], [[0.0, 0.0], [1.5, 0.5]], [0.3]
    else:
        sens = (MeasurementGroup("a", (0,), rate=40.0, noise_std=0.01),
                MeasurementGroup("b", (1,), rate=12.5, noise_std=0.02))  # multi-rate: each group at its instants
        x0, xh0, u = [[1.0, 0.0, 0.5], [0.0, 1.0, -0.5]], [[0.0, 0.0, 0.0], [2.0, -1.0, 1.0]], [0.2]
    co = compile_observer(obs)
    assert co.program.correcting and co.program.n_z == obs.n_z and co.name.endswith("[C]")
    kw = dict(duration=8.0, dt=0.005, u=u, measurements=sens, seed=5)
    a = simulate(plant, obs, x0, xh0, **kw)
    b = simulate(plant, co, x0, xh0, **kw)
    assert np.all(np.isfinite(a.x_hat)) and rel(b.x, a.x) == 0.0
    assert rel(b.x_hat, a.x_hat) < 1e-9
    # the observer converged (the jumps do their work)
    assert np.max(np.abs(a.x_hat[:, -1] - a.x[:, -1])) < 0.2 * np.max(np.abs(a.x_hat[:, 0] - a.x[:, 0]))


@pytest.mark.parametrize("which", list(_CASES))
def test_rhs_and_correct_equal_python_and_a_non_finite_sample_is_skipped(which: str) -> None:
    obs, plant = _CASES[which]()
    co = compile_observer(obs)
    n, p = obs.n_x, len(plant.outputs)
    m = len(plant.inputs)
    rng = np.random.default_rng(2)
    Z = rng.standard_normal((6, n))
    U = rng.standard_normal((6, m))
    Y = rng.standard_normal((6, p))
    # rhs: the model F(x_hat, u); the held y is not read
    a = obs.rhs(0.3, Z, U, Y)
    assert rel(co.rhs(0.3, Z, U, Y), a) < 1e-12
    assert rel(co.rhs(0.3, Z, U, np.full_like(Y, np.nan)), a) < 1e-12
    ref = rk4_step(lambda tt, zz: obs.rhs(tt, zz, U, Y), 0.3, Z, 0.01)
    assert rel(co.step(0.3, Z, U, Y, 0.01), ref) < 1e-12
    # correct: x_hat + L_J (y_J - h_J(x_hat)) over the fresh, finite samples
    Yn = Y.copy()
    Yn[:, 0] = np.nan
    Yn[0, :] = np.inf
    fresh = np.ones(p, dtype=bool)
    for yy in (Y, Yn):
        for fr in (fresh, np.zeros(p, dtype=bool), np.arange(p) == p - 1):
            assert rel(co.correct(0.3, Z, U, yy, fr), obs.correct(0.3, Z, U, yy, fr)) < 1e-14
    assert np.array_equal(co.correct(0.3, Z, U, Y, np.zeros(p, dtype=bool)), Z)
    got = co.correct(0.3, Z, U, Yn, fresh)
    assert np.array_equal(got[0], Z[0])  # every sample of run 0 missing: no jump
    if p == 1:  # the only output missing everywhere: no jump at all
        assert np.array_equal(got, Z)
    else:  # output 0 missing: only the other outputs' columns of L move the estimate
        L = np.asarray(obs.L)
        inn = Yn[1:, 1:] - plant.output(0.3, Z[1:], U[1:])[:, 1:]
        assert rel(got[1:], Z[1:] + inn @ L[:, 1:].T) < 1e-14
    # P_init and P_estimate: z = x_hat0, x_hat = z
    x0 = rng.standard_normal(n)
    z = np.zeros(n)
    P = co.program.prefix
    assert getattr(co.library, f"{P}_init")(np.ascontiguousarray(x0).ctypes.data, z.ctypes.data) == 0
    assert np.array_equal(z, obs.init(x0))
    est = np.zeros(n)
    getattr(co.library, f"{P}_estimate")(z.ctypes.data, est.ctypes.data)
    assert np.array_equal(est, x0)


@pytest.mark.parametrize("which", ["pendulum", "linear"])
def test_a_record_with_missing_samples_runs_in_c_as_in_python(which: str) -> None:
    """``P_run`` (the whole record in C) and the Python loop on a record whose samples are sparse and partly NaN."""
    obs, plant = _CASES[which]()
    n, p, m = obs.n_x, len(plant.outputs), len(plant.inputs)
    co = compile_observer(obs)
    dt, K = 0.005, 1200
    t = dt * np.arange(K)
    U = np.full((K, m), 0.3)
    rng = np.random.default_rng(3)
    Y = np.sin(t)[:, None] * np.ones(p) + 0.01 * rng.standard_normal((K, p))
    sampled = np.zeros((K, p), dtype=bool)
    sampled[::10, 0] = True  # 20 Hz on a 200 Hz grid
    sampled[::25, p - 1] = True  # and 8 Hz for the last output (the same one for the pendulum)
    Y[400:600, 0] = np.nan  # an outage of non-finite samples: no jump on that output in both
    xh0 = np.full(n, 0.5)
    py = run_observer(obs, t, x_hat0=xh0, u=U, y=Y, sampled=sampled)
    one = co.run_record(t, xh0, u=U, y=Y, sampled=sampled)
    assert np.all(np.isfinite(py.x_hat)) and rel(one, py.x_hat) < 1e-9
    cc = run_observer(co, t, x_hat0=xh0, u=U, y=Y, sampled=sampled)
    assert rel(cc.x_hat, py.x_hat) < 1e-9


def test_header_names_the_impulsive_observer_and_the_module_compiles_strictly(tmp_path) -> None:
    for i, make in enumerate(_CASES.values()):
        obs, _ = make()
        res = export_observer(obs, tmp_path / str(i), prefix=f"imp{i}")
        assert res.checked_with is not None  # compiled with -Wall -Wextra -Werror -std=c99 -pedantic
        header = res.header.read_text()
        assert "impulsive observer of Raff & Allgöwer, IEEE CDC 2007" in header
        assert "the model between samples" in header and "a jump at each sample" in header
        assert f"imp{i}_correct(t_k, z, u, y, fresh)" in header and "non-finite" in header
        assert f"int imp{i}_correct(" in header
    h, c = render(generate(_linear()[0], "lin"), "test")
    assert "lin_F_M" in c and "lin_h_M" in c and "lin_h_N" in c and "lin_L" in c


def test_a_plant_without_expressions_is_refused_with_a_clear_message() -> None:
    obs, plant = _pendulum()

    class Opaque:  # a PlantModel built outside nlobs's code generation
        states, inputs, outputs, time, name = plant.states, plant.inputs, plant.outputs, plant.time, "opaque"

        def rhs(self, t, x, u):
            return plant.rhs(t, x, u)

        def output(self, t, x, u):
            return plant.output(t, x, u)

    with pytest.raises(InvalidArgumentError, match="opaque.rhs: its compiled function carries no expressions"):
        generate(ImpulsiveObserver(Opaque(), obs.L), "x")
