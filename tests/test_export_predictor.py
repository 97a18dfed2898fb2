"""The generated C of the inter-sample output predictor (:mod:`nlobs.export.predictor`) equals the Python one.

:class:`~nlobs.observers.sampled.OutputPredictor` around a constant-gain (Thau) observer of a compiled
symbolic model and around a Luenberger observer of a linear system: the compiled module, stepped and
corrected by :func:`nlobs.simulate.simulate` with sampled sensors (multi-rate), or called directly
(``rhs``, ``correct``, ``P_init``, ``P_run``), gives the Python observer's numbers; a non-finite sample
leaves the prediction running in C as in Python.
"""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import CompilerError, InvalidArgumentError
from nlobs.export import compile_observer, export_observer, find_compiler, generate, render
from nlobs.observers.luenberger import ConstantGainObserver, LuenbergerObserver
from nlobs.observers.pinv import PinvObserver
from nlobs.observers.sampled import OutputPredictor
from nlobs.simulate import run_observer, simulate
from nlobs.simulate.sampling import MeasurementGroup
from nlobs.synthesis.pinv_gain import HighGain
from nlobs.systems.linear import LinearSystem
from nlobs.systems.modelfile import load_model

try:
    find_compiler()
except CompilerError:  # pragma: no cover - make test installs the codegen extra (a compiler)
    pytest.skip("no C compiler", allow_module_level=True)


def rel(a: np.ndarray, b: np.ndarray) -> float:
    """Norm-wise relative difference ``max|a − b| / max|b|``."""
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300))


def _pendulum() -> tuple[OutputPredictor, object]:
    plant = load_model("pendulum").compile()
    return OutputPredictor(ConstantGainObserver(plant, np.array([[4.0], [6.0]])), plant), plant


def _linear() -> tuple[OutputPredictor, LinearSystem]:
    A = np.array([[0.0, 1.0, 0.0], [-2.0, -0.5, 1.0], [0.0, 0.0, -1.0]])
    B = np.array([[0.0], [1.0], [0.5]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    D = np.array([[0.0], [0.1]])
    sys = LinearSystem(A, B, C, D)
    L = np.array([[3.0, 0.1], [4.0, 0.2], [0.0, 1.5]])
    return OutputPredictor(LuenbergerObserver(sys, L), sys), sys


@pytest.mark.parametrize("which", ["constant-gain", "luenberger"])
def test_simulate_with_sampled_sensors_gives_the_python_numbers(which: str) -> None:
    if which == "constant-gain":
        obs, plant = _pendulum()
        sens = (MeasurementGroup("y", ("y",), rate=50.0, noise_std=0.01),)
        x0, xh0, u = [[1.0, 0.0], [0.5, -0.5]], [[0.0, 0.0], [1.5, 0.5]], [0.3]
    else:
        obs, plant = _linear()
        sens = (MeasurementGroup("a", (0,), rate=40.0, noise_std=0.01),
                MeasurementGroup("b", (1,), rate=12.5, noise_std=0.02))  # multi-rate: each group at its instants
        x0, xh0, u = [[1.0, 0.0, 0.5], [0.0, 1.0, -0.5]], [[0.0, 0.0, 0.0], [2.0, -1.0, 1.0]], [0.2]
    co = compile_observer(obs)
    assert co.program.correcting and co.program.n_z == obs.n_z and co.name.endswith("[C]")
    kw = dict(duration=4.0, dt=0.005, u=u, measurements=sens, seed=5)
    a = simulate(plant, obs, x0, xh0, **kw)
    b = simulate(plant, co, x0, xh0, **kw)
    assert np.all(np.isfinite(a.x_hat)) and rel(b.x, a.x) == 0.0
    assert rel(b.x_hat, a.x_hat) < 1e-9
    # the observer converged (the predictor does its work between samples)
    assert np.max(np.abs(a.x_hat[:, -1] - a.x[:, -1])) < 0.2 * np.max(np.abs(a.x_hat[:, 0] - a.x[:, 0]))


@pytest.mark.parametrize("which", ["constant-gain", "luenberger"])
def test_rhs_correct_and_init_equal_python_and_a_non_finite_sample_lets_w_run_on(which: str) -> None:
    obs, plant = _pendulum() if which == "constant-gain" else _linear()
    co = compile_observer(obs)
    n, p, ni = obs.n_x, obs.p, obs.n_inner
    m = len(plant.inputs)
    rng = np.random.default_rng(2)
    Z = rng.standard_normal((6, obs.n_z))
    U = rng.standard_normal((6, m))
    Y = rng.standard_normal((6, p))
    # rhs: the inner observer driven by w, and w' = dh/dx F; the held y is not read
    a = obs.rhs(0.3, Z, U, Y)
    assert rel(co.rhs(0.3, Z, U, Y), a) < 1e-12
    assert rel(co.rhs(0.3, Z, U, np.full_like(Y, np.nan)), a) < 1e-12
    # one RK4 step in C equals rk4_step of the Python rhs
    from nlobs.simulate.integrators import rk4_step

    ref = rk4_step(lambda tt, zz: obs.rhs(tt, zz, U, Y), 0.3, Z, 0.01)
    assert rel(co.step(0.3, Z, U, Y, 0.01), ref) < 1e-12
    # correct: w_j <- y_j where fresh and finite; a NaN sample is skipped, the rest of the state untouched
    Yn = Y.copy()
    Yn[:, 0] = np.nan
    fresh = np.ones(p, dtype=bool)
    for yy in (Y, Yn):
        for fr in (fresh, np.zeros(p, dtype=bool), np.arange(p) == p - 1):
            assert np.array_equal(co.correct(0.3, Z, U, yy, fr), obs.correct(0.3, Z, U, yy, fr))
    got = co.correct(0.3, Z, U, Yn, fresh)
    assert np.array_equal(got[:, ni], Z[:, ni]) and np.array_equal(got[:, :ni], Z[:, :ni])
    # P_init: [z0, h(x_hat0, 0)] (the compiled observer's init is the Python one; the C one for a deployment)
    x0 = rng.standard_normal(n)
    z = np.zeros(obs.n_z)
    P = co.program.prefix
    fn = getattr(co.library, f"{P}_init")
    assert fn(np.ascontiguousarray(x0).ctypes.data, z.ctypes.data) == 0
    assert rel(z, obs.init(x0)) < 1e-15
    est = np.zeros(n)
    getattr(co.library, f"{P}_estimate")(z.ctypes.data, est.ctypes.data)
    assert np.array_equal(est, obs.estimate(obs.init(x0)))


def test_a_record_with_missing_samples_runs_in_c_as_in_python() -> None:
    """``P_run`` (the whole record in C) and the Python loop on a record whose samples are sparse and partly NaN."""
    obs, plant = _pendulum()
    co = compile_observer(obs)
    dt, K = 0.005, 1200
    t = dt * np.arange(K)
    U = np.full((K, 1), 0.3)
    Y = np.sin(t)[:, None] + 0.01 * np.random.default_rng(3).standard_normal((K, 1))
    sampled = np.zeros((K, 1), dtype=bool)
    sampled[::4] = True  # 50 Hz on a 200 Hz grid
    Y[400:600] = np.nan  # an outage of non-finite samples: w runs on in both
    py = run_observer(obs, t, x_hat0=[0.5, 0.0], u=U, y=Y, sampled=sampled)
    one = co.run_record(t, [0.5, 0.0], u=U, y=Y, sampled=sampled)
    assert np.all(np.isfinite(py.x_hat)) and rel(one, py.x_hat) < 1e-9
    cc = run_observer(co, t, x_hat0=[0.5, 0.0], u=U, y=Y, sampled=sampled)
    assert rel(cc.x_hat, py.x_hat) < 1e-9


def test_header_names_the_predictor_and_the_module_compiles_strictly(tmp_path) -> None:
    for i, (obs, _) in enumerate((_pendulum(), _linear())):
        res = export_observer(obs, tmp_path / str(i), prefix=f"pred{i}")
        assert res.checked_with is not None  # compiled with -Wall -Wextra -Werror -std=c99 -pedantic
        header = res.header.read_text()
        assert "Karafyllis & Kravaris, IEEE TAC 54(9), 2009" in header and "inter-sample output predictor" in header
        assert f"pred{i}_correct(t_k, z, u, y, fresh)" in header and "non-finite" in header
        assert f"int pred{i}_correct(" in header
    h, c = render(generate(_linear()[0], "lin"), "test")
    assert "lin_inner_rhs_" in c and "lin_A" in c and "lin_C" in c


def test_an_inner_observer_without_c_is_refused_with_a_clear_message() -> None:
    model = load_model("isidori-146")
    inner = PinvObserver.from_model(model, k=HighGain(3.0), pinv="numeric")
    obs = OutputPredictor(inner, model.compile())
    with pytest.raises(InvalidArgumentError, match="OutputPredictor: the wrapped PinvObserver has no C export"):
        generate(obs, "x")
