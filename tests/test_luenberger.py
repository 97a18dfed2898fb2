"""Luenberger observer: the error obeys the linear error dynamics exactly (closed-form oracles)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.observers.base import CorrectingObserver, Observer
from nlobs.observers.luenberger import LuenbergerObserver
from nlobs.simulate import simulate
from nlobs.systems.linear import LinearSystem
from nlobs.systems.timebase import Discrete

A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-2.0, -3.0, -1.0]])
B = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
D = np.array([[0.0, 0.0], [0.5, 0.0]])  # a feed-through term, to check that -D u is in the innovation
# Chosen so that A - L C has eigenvalues with clearly separated real parts.
L = np.array([[4.0, 0.0], [3.0, 1.0], [0.0, 3.0]])


def _u(t: float) -> np.ndarray:
    return np.array([np.sin(3.0 * t), 0.5 * np.cos(t)])


def test_satisfies_the_observer_protocol() -> None:
    obs = LuenbergerObserver(LinearSystem(A, B, C, D), L)
    assert isinstance(obs, Observer)
    assert not isinstance(obs, CorrectingObserver)
    assert obs.n_z == obs.n_x == 3
    np.testing.assert_allclose(obs.error_matrix, A - L @ C)


def test_continuous_error_is_matrix_exponential() -> None:
    sys_ = LinearSystem(A, B, C, D)
    obs = LuenbergerObserver(sys_, L)
    x0 = np.array([[1.0, -1.0, 0.5], [0.0, 2.0, -1.0]])
    xh0 = np.array([0.3, 0.2, 0.1])
    res = simulate(sys_, obs, x0, xh0, duration=6.0, dt=1e-3, u=_u, save_every=5)
    F = A - L @ C
    e0 = xh0 - x0
    expected = np.stack([np.stack([sla.expm(F * t) @ e for t in res.t]) for e in e0])
    # RK4 global error ~ C h^4: far below 1e-9 at h = 1e-3 for these rates.
    np.testing.assert_allclose(res.error, expected, rtol=0, atol=1e-9)
    # The plant itself follows its closed form exp(A t) x0 when u = 0.
    res0 = simulate(sys_, obs, x0, xh0, duration=2.0, dt=1e-3, u=np.zeros(2))
    np.testing.assert_allclose(res0.x[:, -1, :], x0 @ sla.expm(A * 2.0).T, rtol=0, atol=1e-10)


def test_fitted_decay_rate_matches_spectral_abscissa() -> None:
    sys_ = LinearSystem(A, B, C, D)
    obs = LuenbergerObserver(sys_, L)
    F = A - L @ C
    alpha = -float(np.max(np.linalg.eigvals(F).real))
    assert alpha > 0
    res = simulate(sys_, obs, [1.0, 0.0, 0.0], [0.0, 1.0, -1.0], duration=15.0, dt=2e-3, u=_u)
    # Skip the fast transient; the tail is dominated by the slowest mode.
    lam = float(res.decay_rate(t_min=3.0))
    assert lam == pytest.approx(alpha, rel=0.03)


def test_discrete_error_is_matrix_power() -> None:
    dt = 0.05
    Ad = sla.expm(A * dt)
    Bd = dt * B
    sys_ = LinearSystem(Ad, Bd, C, D, time=Discrete(dt))
    Ld = np.array([[0.6, 0.0], [0.5, 0.1], [0.0, 0.5]])
    F = Ad - Ld @ C
    assert np.max(np.abs(np.linalg.eigvals(F))) < 1
    obs = LuenbergerObserver(sys_, Ld)
    x0 = np.array([1.0, -2.0, 0.5])
    xh0 = np.array([0.0, 0.0, 0.0])
    res = simulate(sys_, obs, x0, xh0, duration=5.0, u=_u)
    assert res.method == "discrete"
    assert res.t.shape == (101,)
    np.testing.assert_allclose(np.diff(res.t), dt, rtol=1e-12)
    e = xh0 - x0
    for k in range(res.t.size):
        np.testing.assert_allclose(res.error[k], e, rtol=0, atol=1e-12)
        e = F @ e
    # The plant is iterated exactly: x1 = Ad x0 + Bd u(0).
    np.testing.assert_allclose(res.x[1], Ad @ x0 + Bd @ _u(0.0), rtol=0, atol=1e-14)


def test_gain_shape_is_checked() -> None:
    sys_ = LinearSystem(A, B, C, D)
    with pytest.raises(DimensionError, match="L"):
        LuenbergerObserver(sys_, np.ones((3, 1)))
    with pytest.raises(InvalidArgumentError, match="LinearSystem"):
        LuenbergerObserver("not a system", L)  # type: ignore[arg-type]
