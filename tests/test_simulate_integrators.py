"""RK4 and solve_ivp paths against closed forms, and against each other inside simulate()."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError
from nlobs.observers.luenberger import LuenbergerObserver
from nlobs.simulate import RK4, InputSensor, MeasurementGroup, SolveIVP, rk4_integrate, rk4_step, rk4_step_joint, simulate, solve_ivp_batch
from nlobs.systems.linear import LinearSystem
from nlobs.systems.timebase import Discrete


def _fitted_order(errors: list[float], hs: list[float]) -> float:
    slope, _ = np.polyfit(np.log(hs), np.log(errors), 1)
    return float(slope)


def test_rk4_decay_converges_with_order_four() -> None:
    # ẋ = −x, x(0) = 1: x(2) = exp(−2).
    hs = [0.2, 0.1, 0.05, 0.025]
    errs = []
    for h in hs:
        t = np.linspace(0.0, 2.0, round(2.0 / h) + 1)
        y = rk4_integrate(lambda t, x: -x, [1.0], t)
        errs.append(abs(y[-1, 0] - np.exp(-2.0)))
    assert _fitted_order(errs, hs) == pytest.approx(4.0, abs=0.15)


def test_rk4_harmonic_oscillator_batch_order_four() -> None:
    # ẍ = −ω² x for a batch of initial conditions; closed form x(t) = x0 cos ωt + v0/ω sin ωt.
    w = 3.0
    x0 = np.array([[1.0, 0.0], [0.0, 2.0], [-0.5, 1.5]])

    def f(t: float, s: np.ndarray) -> np.ndarray:
        return np.stack([s[..., 1], -(w**2) * s[..., 0]], axis=-1)

    T = 2.0
    exact = x0[:, 0] * np.cos(w * T) + x0[:, 1] / w * np.sin(w * T)
    hs = [0.04, 0.02, 0.01, 0.005]
    errs = []
    for h in hs:
        y = rk4_integrate(f, x0, np.linspace(0.0, T, round(T / h) + 1))
        assert y.shape == (3, round(T / h) + 1, 2)
        errs.append(float(np.max(np.abs(y[:, -1, 0] - exact))))
    assert _fitted_order(errs, hs) == pytest.approx(4.0, abs=0.15)
    assert errs[-1] < 1e-8


def test_rk4_step_joint_equals_rk4_step_on_the_stacked_state() -> None:
    rng = np.random.default_rng(0)
    M = rng.standard_normal((5, 5))
    y = rng.standard_normal((4, 5))

    def f(t: float, s: np.ndarray) -> np.ndarray:
        return np.sin(t) * s @ M.T + np.tanh(s)

    def g(t: float, parts: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
        d = f(t, np.concatenate(parts, axis=-1))
        return d[..., :2], d[..., 2:]

    one = rk4_step(f, 0.3, y, 0.01)
    a, b = rk4_step_joint(g, 0.3, (y[..., :2], y[..., 2:]), 0.01)
    np.testing.assert_allclose(np.concatenate([a, b], axis=-1), one, rtol=0, atol=1e-14)


def test_solve_ivp_batch_matches_closed_form() -> None:
    lam = np.array([0.5, 1.0, 2.0])
    y0 = np.ones((3, 1))
    t_eval = np.linspace(0.0, 1.0, 11)
    ys, sol = solve_ivp_batch(lambda t, y: -lam[:, None] * y, y0, (0.0, 1.0), t_eval, SolveIVP().options())
    assert sol.status == 0 and ys.shape == (11, 3, 1)
    np.testing.assert_allclose(ys[..., 0], np.exp(-np.outer(t_eval, lam)), rtol=1e-9)


def _plant_and_observer() -> tuple[LinearSystem, LuenbergerObserver]:
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, -2.0, -1.5]])
    B = np.array([[0.0], [0.0], [1.0]])
    C = np.array([[1.0, 0.0, 0.0]])
    sys_ = LinearSystem(A, B, C)
    return sys_, LuenbergerObserver(sys_, [[6.0], [12.0], [8.0]])


def test_solve_ivp_path_agrees_with_rk4_in_simulate() -> None:
    sys_, obs = _plant_and_observer()
    x0 = np.array([[1.0, 0.0, -1.0], [0.5, 0.5, 0.5]])
    kw = dict(duration=4.0, dt=1e-3, u=lambda t: np.array([np.cos(2 * t)]), save_every=10)
    r1 = simulate(sys_, obs, x0, np.zeros(3), integrator=RK4(), **kw)
    r2 = simulate(sys_, obs, x0, np.zeros(3), integrator=SolveIVP(method="DOP853", rtol=1e-11, atol=1e-13), **kw)
    assert r2.method == "solve_ivp:DOP853"
    np.testing.assert_array_equal(r1.t, r2.t)
    np.testing.assert_allclose(r2.x, r1.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r2.x_hat, r1.x_hat, rtol=0, atol=1e-9)


def test_solve_ivp_rejects_discrete_plants() -> None:
    sys_ = LinearSystem([[0.5]], [[0.0]], [[1.0]], time=Discrete(0.1))
    obs = LuenbergerObserver(sys_, [[0.2]])
    with pytest.raises(InvalidArgumentError, match="continuous-time plants only"):
        simulate(sys_, obs, [1.0], [0.0], duration=1.0, integrator=SolveIVP())


def test_solve_ivp_options_are_validated() -> None:
    with pytest.raises(InvalidArgumentError, match="method"):
        SolveIVP(method="Euler")
    with pytest.raises(InvalidArgumentError, match="rtol"):
        SolveIVP(rtol=-1.0)


def test_solve_ivp_path_agrees_with_rk4_with_sampled_noisy_sensors() -> None:
    # Between samples the held measurement and input are constant, so both paths integrate the
    # same piecewise-smooth system; the noise draws happen in the same order.
    sys_, obs = _plant_and_observer()
    kw = dict(
        duration=2.0,
        dt=1e-3,
        u=lambda t: np.array([np.sin(3 * t)]),
        measurements=[MeasurementGroup("pos", [0], rate=50.0, noise_std=0.01)],
        input_sensors=[InputSensor("acc", [0], rate=100.0, noise_std=0.1)],
        seed=5,
        save_every=20,
    )
    r1 = simulate(sys_, obs, [1.0, 0.0, 0.0], np.zeros(3), **kw)
    r2 = simulate(sys_, obs, [1.0, 0.0, 0.0], np.zeros(3), integrator=SolveIVP(), **kw)
    np.testing.assert_allclose(r2.y, r1.y, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r2.x, r1.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r2.x_hat, r1.x_hat, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(r1.sampled, r2.sampled)
