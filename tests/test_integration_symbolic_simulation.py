"""A model read from a file, compiled, and simulated, against SciPy on hand-written dynamics."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nlobs.systems.linearize import linearize
from nlobs.observers import LuenbergerObserver
from nlobs.simulate import simulate
from nlobs.systems.modelfile import load_model

MODELS = Path(__file__).resolve().parents[1] / "src" / "nlobs" / "data" / "models"


def pendulum_rhs(t: float, x: np.ndarray, tau: float) -> np.ndarray:
    g, l, c, mass = 9.81, 1.0, 0.2, 0.5
    return np.array([x[1], -(g / l) * np.sin(x[0]) - c * x[1] + tau / (mass * l**2)])


def test_compiled_pendulum_batch_matches_scipy_dop853() -> None:
    plant = load_model(MODELS / "pendulum.toml").compile()
    x0 = np.array([[0.3, 0.0], [2.5, -1.0], [-1.0, 3.0]])
    res = simulate(plant, None, x0, duration=5.0, dt=1e-3, u=0.4)
    for i, x0_i in enumerate(x0):
        ref = solve_ivp(pendulum_rhs, (0.0, 5.0), x0_i, args=(0.4,), method="DOP853", rtol=1e-11, atol=1e-12,
                        t_eval=res.t)
        np.testing.assert_allclose(res.x[i], ref.y.T, atol=1e-9)


def test_luenberger_on_the_linearisation_converges_near_the_equilibrium() -> None:
    """A gain designed on the Jacobian linearisation gives local convergence on the nonlinear plant.

    Near the origin the error decays at the rate of eig(A - L C) of the linearisation
    (the nonlinearity is second order there), so the fitted decay rate must match it.
    """
    model = load_model(MODELS / "pendulum.toml")
    lin = linearize(model)
    L = np.array([[4.0], [10.0]])
    rate = -np.max(np.linalg.eigvals(lin.A - L @ lin.C).real)
    obs = LuenbergerObserver(lin, L)
    res = simulate(model.compile(), obs, [0.02, 0.0], [0.0, 0.0], duration=6.0, dt=1e-3, u=0.0)
    assert res.error_norm[-1] < 1e-4 * res.error_norm[0]
    fitted = res.decay_rate(t_min=0.5, t_max=5.0)
    assert fitted == pytest.approx(rate, rel=0.1)
