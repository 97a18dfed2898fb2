"""One plant run for many observers: ``observe(simulate_plant(...), observer)`` is ``simulate(...)``, bit for bit.

A comparison of N observers integrates the plant once and replays its sampled, noisy readings to each observer.
The observer sees the plant only through the held readings and the known input, so every number must be the
one a joint simulation of the plant and that observer gives: each test runs both and compares every array.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from nlobs import EKF, UKF
from nlobs.errors import DimensionError, InvalidArgumentError, SimulationDiverged
from nlobs.methods.problem import symbolic_model
from nlobs.observers.luenberger import LuenbergerObserver
from nlobs.simulate import InputSensor, MeasurementGroup, SampledSignal, simulate
from nlobs.simulate.loop import PlantRun, observe, simulate_plant
from nlobs.systems.linear import LinearSystem
from nlobs.systems.timebase import CONTINUOUS, Discrete

FIELDS = ("t", "x", "x_hat", "y", "sampled")


def _same(a: Any, b: Any) -> None:
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert set(a.extras) == set(b.extras)
    for name in a.extras:
        np.testing.assert_array_equal(a.extras[name], b.extras[name], err_msg=name)
    assert (a.method, a.observer, a.estimates) == (b.method, b.observer, b.estimates)
    np.testing.assert_array_equal(a.info.get("diverged_at", 0.0), b.info.get("diverged_at", 0.0))


def _both(plant: Any, observer: Any, x0: Any, x_hat0: Any, divergence: str = "raise", **kw: Any) -> Any:
    joint = simulate(plant, observer, x0, x_hat0, divergence=divergence, **kw)
    run = simulate_plant(plant, x0, **kw)
    replayed = observe(run, observer, x_hat0, divergence=divergence)
    _same(joint, replayed)
    plain = simulate(plant, None, x0, **kw)  # the plant alone: the run's own result
    for name in ("t", "x", "y", "sampled"):
        np.testing.assert_array_equal(getattr(plain, name), getattr(run.result, name), err_msg=name)
    return replayed


@pytest.fixture(scope="module")
def pendulum() -> Any:
    return symbolic_model("pendulum").compile()


def _sensors(plant: Any) -> list[MeasurementGroup]:
    return [MeasurementGroup("enc", list(plant.outputs), rate=100.0, noise_std=0.01)]


@pytest.mark.parametrize("runs", [None, 4], ids=["one run", "batch"])
@pytest.mark.parametrize("kind", ["ekf", "ukf"])
def test_kalman_filters_on_a_replayed_run_equal_the_joint_simulation(pendulum: Any, kind: str,
                                                                     runs: int | None) -> None:
    """Correcting, diagnosing filters with a flat-record state; process noise; a sine input; save_every."""
    n = pendulum.n
    cls = EKF if kind == "ekf" else UKF
    obs = cls(pendulum, Q=1e-3 * np.eye(n), R=1e-4 * np.eye(pendulum.p),
              P0=0.1 * np.eye(n))
    x0 = np.full(n, 0.3) if runs is None else np.linspace(0.1, 0.5, runs * n).reshape(runs, n)
    res = _both(pendulum, obs, x0, np.zeros(n), duration=1.0, dt=2e-3,
                u=lambda t: np.full(pendulum.m, 0.2 * np.sin(3.0 * t)), measurements=_sensors(pendulum),
                process_noise=0.05 * np.ones(n), seed=3, save_every=7)
    assert res.extras and np.all(np.isfinite(res.x_hat))


class _Plant:
    """ẋ₁ = x₂, ẋ₂ = −x₁ − 0.3 x₂ + u₁ + 0.1 u₂; outputs x₁ and x₂ (batched NumPy)."""

    time = CONTINUOUS
    states = ("a", "b")
    inputs = ("u1", "u2")
    outputs = ("ya", "yb")
    n, m, p = 2, 2, 2

    def rhs(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return np.stack([x[..., 1], -x[..., 0] - 0.3 * x[..., 1] + u[..., 0] + 0.1 * u[..., 1]], axis=-1)

    def output(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return x.copy()


class _Stepping:
    """A continuous observer with its own Euler step and diagnostics, and deferred estimates (scaled at the end)."""

    time = CONTINUOUS
    n_z = 2
    n_x = 2

    def init(self, x_hat0: np.ndarray) -> np.ndarray:
        return np.array(x_hat0, dtype=float)

    def rhs(self, t: float, z: np.ndarray, u: np.ndarray, y: np.ndarray) -> np.ndarray:
        return _Plant().rhs(t, z, u) + 3.0 * (y - z)

    def step(self, t: float, z: np.ndarray, u: np.ndarray, y: np.ndarray, h: float) -> np.ndarray:
        return z + h * self.rhs(t, z, u, y)

    def estimate(self, z: np.ndarray) -> np.ndarray:
        return z

    def raw_estimate(self, z: np.ndarray) -> np.ndarray:
        return z

    def finish_estimates(self, raw: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        return 2.0 * raw, {"scaled": raw[..., :1]}

    def diagnostics(self, z: np.ndarray, u: np.ndarray) -> dict[str, np.ndarray]:
        return {"u_seen": np.asarray(u, dtype=float), "norm": np.linalg.norm(z, axis=-1)}


def test_self_stepping_deferred_observer_with_input_sensors_outages_and_held_input() -> None:
    """Its own step, deferred estimates, diagnostics of the input it sees (one input sensed, the other true),
    two groups at different rates, one with an outage, a zero-order-hold input."""
    plant = _Plant()
    t = np.linspace(0.0, 2.0, 21)
    u = SampledSignal(t, np.stack([np.sin(t), np.cos(2 * t)], axis=-1), kind="hold")
    groups = [MeasurementGroup("fast", ["ya"], rate=50.0, noise_std=0.02),
              MeasurementGroup("slow", ["yb"], rate=10.0, noise_std=0.05, outages=[(0.5, 0.9)])]
    res = _both(plant, _Stepping(), np.array([[1.0, 0.0], [0.5, -0.5], [0.0, 1.0]]), np.zeros(2), duration=2.0,
                dt=1e-2, u=u, measurements=groups, input_sensors=[InputSensor("torque", [0], rate=20.0,
                                                                              noise_std=0.1)], seed=5)
    assert res.method == "rk4+observer step" and "scaled" in res.extras and "u_seen" in res.extras


def test_discrete_observer_on_a_continuous_plant_and_a_discrete_plant() -> None:
    A = np.array([[0.0, 1.0], [-2.0, -0.5]])
    C = np.array([[1.0, 0.0]])
    dt = 0.05
    Ad = np.eye(2) + dt * A
    discrete = LuenbergerObserver(LinearSystem(Ad, np.zeros((2, 0)), C, time=Discrete(dt)), [[0.5], [0.3]])
    sensors = [MeasurementGroup("y", ["y1"], rate=1 / dt, noise_std=0.01)]
    res = _both(LinearSystem(A, np.zeros((2, 0)), C), discrete, np.array([1.0, 0.0]), np.zeros(2), duration=1.0,
                dt=dt, measurements=sensors, seed=1)
    assert res.method == "rk4+discrete observer"
    res = _both(LinearSystem(Ad, np.zeros((2, 0)), C, time=Discrete(dt)), discrete, np.array([1.0, 0.0]),
                np.zeros(2), duration=1.0, measurements=[MeasurementGroup("y", ["y1"], rate=1 / (2 * dt))])
    assert res.method == "discrete"


def test_a_diverging_observer_is_kept_or_raised_as_in_the_joint_simulation() -> None:
    A = np.array([[0.0, 1.0], [-1.0, 0.0]])
    C = np.array([[1.0, 0.0]])
    plant = LinearSystem(A, np.zeros((2, 0)), C)
    bad = LuenbergerObserver(plant, [[-400.0], [0.0]])  # A − LC unstable: the estimate overflows
    kw: dict[str, Any] = dict(duration=3.0, dt=1e-2, measurements=[MeasurementGroup("y", ["y1"], rate=100.0)])
    res = _both(plant, bad, np.array([1.0, 0.0]), np.zeros(2), divergence="keep", **kw)
    assert np.isfinite(res.info["diverged_at"])
    run = simulate_plant(plant, np.array([1.0, 0.0]), **kw)
    with pytest.raises(SimulationDiverged) as joint:
        simulate(plant, bad, np.array([1.0, 0.0]), np.zeros(2), **kw)
    with pytest.raises(SimulationDiverged) as replayed:
        observe(run, bad, np.zeros(2))
    assert str(joint.value) == str(replayed.value)


def test_a_diverging_plant_stops_its_run() -> None:
    plant = LinearSystem([[50.0]], np.zeros((1, 0)), [[1.0]])
    with pytest.raises(SimulationDiverged) as stop:
        simulate_plant(plant, np.array([1e300]), duration=1.0, dt=0.1,
                       measurements=[MeasurementGroup("y", ["y1"], rate=10.0)])
    assert stop.value.which == "plant"


def test_bad_arguments_are_refused() -> None:
    plant = LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
    with pytest.raises(InvalidArgumentError, match="measurements"):
        simulate_plant(plant, np.array([1.0]), duration=1.0, dt=0.1, measurements=None)  # type: ignore[arg-type]
    run = simulate_plant(plant, np.array([1.0]), duration=1.0, dt=0.1,
                         measurements=[MeasurementGroup("y", ["y1"], rate=10.0)])
    assert isinstance(run, PlantRun)
    obs = LuenbergerObserver(plant, [[1.0]])
    with pytest.raises(InvalidArgumentError, match="PlantRun"):
        observe(run.result, obs, np.zeros(1))  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="Observer"):
        observe(run, object(), np.zeros(1))  # type: ignore[arg-type]
    with pytest.raises(DimensionError, match="x_hat0"):
        observe(run, obs, np.zeros(3))
    other = LuenbergerObserver(LinearSystem([[0.9]], np.zeros((1, 0)), [[1.0]], time=Discrete(0.2)), [[0.5]])
    with pytest.raises(InvalidArgumentError, match="mismatch"):
        observe(run, other, np.zeros(1))
    with pytest.raises(InvalidArgumentError, match="divergence"):
        observe(run, obs, np.zeros(1), divergence="ignore")  # type: ignore[arg-type]
