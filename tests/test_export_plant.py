"""The plant's ``f`` as C (:mod:`nlobs.export.plant`): the loop steps a compiled plant with the Python plant's numbers.

A compiled plant is stepped by the generated RK4 with the input at RK4's stage times; the outputs, the sensors and the
process noise stay in Python, so the random draws are the same. Checked against the Python plant in the same loop
(with a varying input, a held input, process noise and sampled sensors), against the exact solution of a linear
plant (the matrix exponential), for a discrete plant, and in a comparison with ``backend="c"``.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from nlobs import Discrete, LinearSystem
from nlobs.errors import InvalidArgumentError
from nlobs.export import find_compiler
from nlobs.export.plant import CompiledPlant, compile_plant, generate_plant, has_plant_generator
from nlobs.simulate import simulate, simulate_plant
from nlobs.systems.sensors import MeasurementGroup
from nlobs.systems.symbolic import SymbolicModel

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler")


def _cartpole():  # type: ignore[no-untyped-def]
    import nlobs

    return nlobs.load_model("cartpole")


def _x0(n_runs: int) -> np.ndarray:
    return np.array([0.0, 0.0, 3.0, 0.0]) + 0.02 * np.arange(n_runs)[:, None] * np.array([1.0, -1.0, 0.5, 2.0])


def test_a_varying_input_and_process_noise_give_the_python_plant_numbers() -> None:
    model = _cartpole().compile()
    plant = compile_plant(model)
    assert isinstance(plant, CompiledPlant) and (plant.n, plant.m, plant.p) == (4, 1, 2)
    assert plant.states == model.states and plant.name == "cartpole [C]"
    kw = dict(duration=2.0, dt=1e-3, u=lambda t: np.array([2.0 * np.sin(7.0 * t)]),
              process_noise=np.diag([0.0, 1e-3, 0.0, 1e-3]), seed=4)
    a = simulate(model, None, _x0(6), **kw)
    b = simulate(plant, None, _x0(6), **kw)
    scale = np.abs(a.x).max()
    assert np.abs(a.x - b.x).max() <= 1e-12 * scale
    assert np.abs(a.x[:, -1] - a.x[:, 0]).max() > 0.1  # the runs moved: not a trivial agreement
    held = simulate(model, None, _x0(3), duration=1.0, dt=1e-3, u=np.array([0.4]))
    held_c = simulate(plant, None, _x0(3), duration=1.0, dt=1e-3, u=np.array([0.4]))
    assert np.abs(held.x - held_c.x).max() <= 1e-12 * np.abs(held.x).max()


def test_the_stages_read_the_input_at_their_times() -> None:
    """Holding ``u(t_k)`` over the step would be a first-order error: 1e-4 apart here; the stages agree to 1e-12."""
    model = _cartpole().compile()
    plant = compile_plant(model)
    x = _x0(2)
    u = lambda t: np.array([50.0 * np.sin(40.0 * t)])  # noqa: E731
    h = 1e-2
    a = simulate(model, None, x, duration=h, dt=h, u=u).x[:, -1]
    b = plant.step_stages(0.0, x, u(0.0), u(0.5 * h), u(h), h)
    held = plant.step_stages(0.0, x, u(0.0), u(0.0), u(0.0), h)
    assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max()
    assert np.abs(a - held).max() > 1e-4


def test_a_linear_plant_against_its_exact_solution() -> None:
    A = np.array([[0.0, 1.0, 0.0], [-4.0, -0.4, 1.0], [0.0, 0.0, -2.0]])
    B = np.array([[0.0], [0.0], [1.0]])
    C = np.array([[1.0, 0.0, 0.0]])
    s = LinearSystem(A, B, C)
    assert has_plant_generator(s)
    plant = compile_plant(s)
    x0 = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, -1.0]])
    T, dt = 3.0, 1e-3
    r = simulate(plant, None, x0, duration=T, dt=dt, u=np.array([0.5]))
    # x(T) = e^{AT} x0 + A⁻¹ (e^{AT} − I) B u (A is invertible)
    E = scipy.linalg.expm(A * T)
    exact = x0 @ E.T + (np.linalg.solve(A, (E - np.eye(3)) @ B) @ np.array([0.5]))
    assert np.abs(r.x[:, -1] - exact).max() < 1e-10  # RK4 at 1 ms: error O(h⁴)


def test_a_discrete_plant_is_its_map() -> None:
    m = SymbolicModel.general(["p", "q"], ["u"], ["y"], ["p + 0.1*q", "q - 0.1*sin(p) + 0.1*u"], ["sin(p)"],
                              time=Discrete(0.1), name="discrete-pendulum").compile()
    plant = compile_plant(m)
    assert generate_plant(m, "dp").discrete
    x = np.array([[1.0, 0.0], [0.3, -0.2]])
    u = np.array([[0.2], [-0.1]])
    assert np.allclose(plant.rhs(0.0, x, u), m.rhs(0.0, x, u), rtol=1e-15, atol=0)
    a = simulate(m, None, x, duration=3.0, u=np.array([0.2]))
    b = simulate(plant, None, x, duration=3.0, u=np.array([0.2]))
    assert np.abs(a.x - b.x).max() <= 1e-14


def test_sensors_and_replay_see_the_same_run() -> None:
    model = _cartpole().compile()
    sensors = [MeasurementGroup("enc", ["x_enc", "th_enc"], rate=50.0, noise_std=[1e-3, 5e-3])]
    kw = dict(duration=1.0, dt=1e-3, u=lambda t: np.array([np.sin(3.0 * t)]), measurements=sensors,
              process_noise=np.diag([0.0, 1e-4, 0.0, 1e-4]), seed=9)
    a = simulate_plant(model, _x0(4), **kw)
    b = simulate_plant(compile_plant(model), _x0(4), **kw)
    assert np.abs(a.result.x - b.result.x).max() <= 1e-12 * np.abs(a.result.x).max()
    fresh = a.result.sampled
    assert fresh.any() and np.array_equal(fresh, b.result.sampled)
    # the sensors' noise draws are the same: the readings differ by the plant's rounding only
    assert np.nanmax(np.abs(a.result.y - b.result.y)) <= 1e-11


def test_a_plant_without_expressions_is_refused() -> None:
    class Custom:
        time = Discrete(1.0)
        states, inputs, outputs = ("a",), (), ("a",)
        n, m, p = 1, 0, 1

        def rhs(self, t, x, u):  # type: ignore[no-untyped-def]
            return 0.5 * x

        def output(self, t, x, u):  # type: ignore[no-untyped-def]
            return x

    assert not has_plant_generator(Custom())
    with pytest.raises(InvalidArgumentError, match="no C generator"):
        compile_plant(Custom())


@pytest.mark.slow
def test_a_comparison_with_backend_c_steps_the_plant_in_c(monkeypatch) -> None:
    import nlobs.export.plant as plant_module
    from nlobs.workflows.compare import compare_observers

    made: list[CompiledPlant] = []
    original = plant_module.compile_plant

    def spy(plant, **kw):  # type: ignore[no-untyped-def]
        made.append(original(plant, **kw))
        return made[-1]

    monkeypatch.setattr(plant_module, "compile_plant", spy)
    kw = dict(observers=["luenberger", "ekf"], runs=3, duration=2.0, dt=1e-3, rate=100.0, noise_std=0.01)
    a = compare_observers("cartpole", **kw)
    assert not made
    b = compare_observers("cartpole", backend="c", **kw)
    assert len(made) == 1  # one plant for the comparison, integrated once and replayed to both observers
    for name in kw["observers"]:
        oa, ob = a.observers[name], b.observers[name]
        assert np.abs(ob.result.x - oa.result.x).max() <= 1e-11 * np.abs(oa.result.x).max()
        assert np.abs(ob.result.x_hat - oa.result.x_hat).max() <= 1e-9 * np.abs(oa.result.x_hat).max()
