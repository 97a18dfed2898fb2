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
