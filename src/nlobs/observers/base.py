"""The observer interface: explicit state in, explicit state out.

An observer is a dynamical system driven by the plant's known input ``u`` and
the (sampled, held) measurement ``y``. It never stores its state: the simulation
loop passes the observer state ``z`` in and receives the new one back.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from nlobs.systems.timebase import TimeBase

Array = NDArray[np.float64]


@runtime_checkable
class Observer(Protocol):
    """Protocol of every observer in :mod:`nlobs.observers`.

    Attributes
    ----------
    time : Continuous or Discrete
        Time base of the observer dynamics.
    n_z : int
        Dimension of the observer's internal state ``z`` (may differ from the
        plant's ``n``, e.g. an extended state or a covariance).
    n_x : int
        Dimension of the plant-state estimate returned by :meth:`estimate`.

    Notes
    -----
    An observer may also define ``state_names`` (a tuple of ``n_z`` strings);
    the simulation loop uses them in error messages (otherwise ``z[i]``).
    """

    time: TimeBase

    @property
    def n_z(self) -> int: ...

    @property
    def n_x(self) -> int: ...

    def init(self, x_hat0: Array) -> Array:
        """Observer state ``z`` from an initial plant-state estimate, shape ``(..., n_z)``."""
        ...

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``ż`` (continuous) or ``z⁺`` (discrete) given held measurement ``y``."""
        ...

    def estimate(self, z: Array) -> Array:
        """Plant-state estimate ``x̂``, shape ``(..., n_x)``."""
        ...


@runtime_checkable
class CorrectingObserver(Observer, Protocol):
    """An observer that also makes a discrete correction when a sample arrives.

    The simulation loop calls :meth:`correct` at each instant where at least one
    measurement group delivers a new sample (e.g. an EKF update at a GNSS fix),
    after the plant and observer were integrated up to that instant.
    """

    def correct(self, t: float, z: Array, u: Array, y: Array, fresh: NDArray[np.bool_]) -> Array:
        """Return the corrected ``z``; ``fresh[j]`` is True where output ``j`` was just sampled."""
        ...
