"""Shared fixtures of the navigation tests: traffic-pattern flights and their sampled trajectories.

Flights are built once per session and cached by ``(seed, duration)``; a
:class:`~nlobs.navigation.trajectory.Flight` is a frozen, pure function of time, and the sampled
:class:`~nlobs.navigation.trajectory.Trajectory` objects handed out here have read-only arrays,
so sharing them across tests is safe.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

import numpy as np
import pytest

from nlobs.navigation.trajectory import Flight, Trajectory, traffic_pattern


@functools.lru_cache(maxsize=None)
def _flight(seed: int, duration: float | None) -> Flight:
    return traffic_pattern(seed=seed, duration=duration)


@functools.lru_cache(maxsize=None)
def _trajectory(seed: int, duration: float | None, rate_hz: float) -> Trajectory:
    traj = _flight(seed, duration).sample(rate_hz)
    for f in dataclasses.fields(traj):
        val = getattr(traj, f.name)
        if isinstance(val, np.ndarray):
            val.setflags(write=False)
    return traj


@pytest.fixture(scope="session")
def make_flight() -> Callable[[int, float | None], Flight]:
    """``make_flight(seed, duration)``: the traffic pattern of ``seed`` cut at ``duration`` s (cached)."""
    return _flight


@pytest.fixture(scope="session")
def make_traj() -> Callable[[int, float | None, float], Trajectory]:
    """``make_traj(seed, duration, rate_hz)``: that flight sampled at ``rate_hz`` (cached, read-only arrays)."""
    return _trajectory


@pytest.fixture(scope="session")
def flight() -> Flight:
    """The first 60 s of the traffic pattern of seed 0 (its ``m_n``, ``g_n`` and short runs)."""
    return _flight(0, 60.0)


@pytest.fixture(scope="session")
def pattern() -> Flight:
    """The whole traffic pattern of seed 0 (take-off to landing, ≈ 370 s)."""
    return _flight(0, None)


def _predictor_worst_case(A: np.ndarray, C: np.ndarray, L: np.ndarray, T: float) -> float:
    """``sup limsup |e|`` over sample noise ``|v_k| ≤ 1`` of the output predictor's exact hybrid error system.

    ``[ė; δ̇] = [[A − LC, L], [CA, 0]] [e; δ]``, ``δ(t_k) = v_k`` (one output, period ``T``): the signs of
    ``v_k`` reach ``sup_{d,τ} |dᵀΦ_eδ(τ)| + Σ_i |dᵀΦ_ee(τ) Φ_ee(T)^i Φ_eδ(T)|`` (SciPy's expm; two states,
    directions ``d`` on a half circle, six instants ``τ`` in a period).
    """
    import math

    import scipy.linalg as sl

    n = A.shape[0]
    big = np.block([[A - L @ C, L], [C @ A, np.zeros((1, 1))]])

    def flow(t: float) -> tuple[np.ndarray, np.ndarray]:
        E = sl.expm(big * t)
        return E[:n, :n], E[:n, n:]

    Mee, Med = flow(T)
    powers = [np.eye(n)]
    for _ in range(3000):
        powers.append(Mee @ powers[-1])
    tail = np.array([(Mi @ Med)[:, 0] for Mi in powers])
    worst = 0.0
    for tau in np.linspace(0.0, T, 6):
        Fee, Fed = flow(tau)
        terms = tail @ Fee.T
        for th in np.linspace(0, math.pi, 91):
            d = np.array([math.cos(th), math.sin(th)])
            worst = max(worst, abs(float(d @ Fed[:, 0])) + float(np.sum(np.abs(terms @ d))))
    return worst


@pytest.fixture(scope="session")
def predictor_worst_case() -> Callable[[np.ndarray, np.ndarray, np.ndarray, float], float]:
    """The exact worst case of bounded sample noise through the output predictor (:func:`_predictor_worst_case`)."""
    return _predictor_worst_case
