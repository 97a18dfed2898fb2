"""Shared navigation data types and the filter protocol.

Conventions (seed 001, Sec. 5; tested in ``tests/test_navigation_conventions.py``):

* Earth-fixed frame: local **NED** (north, east, down), treated as inertial.
* ``R`` maps **body to Earth** (NED) coordinates: ``vⁿ = R v^b``; ``Ṙ = R S(ω^b)``
  with ``ω^b`` the body angular rate in body axes and ``S(a) b = a × b``.
* Gravity ``gⁿ = [0, 0, +g]`` (down is positive in NED), ``v̇ⁿ = aⁿ + gⁿ`` where
  ``aⁿ = R a^b`` is the proper acceleration; the accelerometer reads the
  **specific force** ``a^b = Rᵀ(v̇ⁿ − gⁿ)`` (a level aircraft at rest reads
  ``a^b = [0, 0, −g]``).
* Magnetometer: ``m^b = Rᵀ mⁿ`` with ``mⁿ`` the known Earth field in NED.
* Euler angles: ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (aerospace ZYX), angles in radians.
* ``vec`` stacks the **columns** of a matrix (seed 001: ``x = vec R``).

Arrays carry a leading batch axis (Monte Carlo flights) where noted.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: Standard gravity used by the generators, m/s².
G0 = 9.80665


@dataclass(frozen=True)
class ImuSample:
    """One IMU (+ magnetometer) sample, each of shape ``(..., 3)``: body rate [rad/s],
    specific force [m/s²], magnetic field in body axes [normalised units]."""

    omega_b: Array
    a_b: Array
    m_b: Array


@dataclass(frozen=True)
class GnssSample:
    """One GNSS fix: position [m] and velocity [m/s] in NED, each ``(..., 3)``.

    ``valid`` (shape ``(...)``, bool) is False where the fix is missing or has a
    non-finite entry; filters must skip invalid fixes (per batch member).
    ``v`` is ``None`` for a position-only receiver (seed 001, Sec. 5.2, C = [I 0]).
    """

    p: Array
    v: Array | None
    valid: NDArray[np.bool_]


@dataclass(frozen=True)
class NavEstimate:
    """A navigation estimate: ``p``, ``v`` of shape ``(..., 3)``, ``R`` of shape ``(..., 3, 3)``.

    ``R`` is the filter's attitude estimate projected onto SO(3) (the seed-001
    observer's ``R̂`` is not a rotation matrix in general; see Sec. 5.2).
    """

    p: Array
    v: Array
    R: Array


@runtime_checkable
class NavFilter(Protocol):
    """A navigation filter run on sampled data by :func:`nlobs.navigation.run.run_navigation`.

    State is explicit: every method takes the filter state and returns a new one.
    At each IMU instant ``t_k`` the runner calls :meth:`update` if a GNSS fix
    arrives at ``t_k``, then :meth:`propagate` over ``[t_k, t_k + dt]`` with the
    IMU sample at ``t_k`` held.
    """

    name: str

    def init(self, p0: Array, v0: Array, R0: Array) -> Any:
        """Initial filter state from initial estimates (batched)."""
        ...

    def propagate(self, state: Any, imu: ImuSample, dt: float) -> Any:
        """Advance the state over one IMU period."""
        ...

    def update(self, state: Any, gnss: GnssSample) -> Any:
        """Take a GNSS fix (ignoring batch members where ``gnss.valid`` is False)."""
        ...

    def estimate(self, state: Any) -> NavEstimate:
        """The current estimate."""
        ...


@dataclass(frozen=True)
class SensorData:
    """Sampled sensor streams of one flight, possibly for a batch of noise realisations.

    Attributes
    ----------
    t_imu : (K,) IMU sample times [s] (uniform, ``imu_rate_hz``).
    omega_b, a_b, m_b : (..., K, 3) measured body rate, specific force, magnetic field.
    t_gnss : (G,) GNSS fix times [s]; each is (to rounding) one of ``t_imu``.
    p_gnss : (..., G, 3) measured position; may contain NaN for a missing fix.
    v_gnss : (..., G, 3) measured velocity, or None for a position-only receiver.
    m_n, g_n : (3,) Earth magnetic field and gravity in NED.
    p, v : (K, 3) true position and velocity at ``t_imu``; R : (K, 3, 3) true attitude.
    imu_rate_hz, gnss_rate_hz : the rates (required, never defaulted).
    """

    t_imu: Array
    omega_b: Array
    a_b: Array
    m_b: Array
    t_gnss: Array
    p_gnss: Array
    v_gnss: Array | None
    m_n: Array
    g_n: Array
    p: Array
    v: Array
    R: Array
    imu_rate_hz: float
    gnss_rate_hz: float
