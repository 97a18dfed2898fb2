"""The numeric model interface every plant satisfies (linear, compiled symbolic, hand-written).

Simulation and observers see only this protocol, never SymPy objects.
All callables accept a leading batch axis: ``x`` of shape ``(..., n)``,
``u`` of shape ``(..., m)``; they return arrays with the same leading axes.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable


from nlobs._typing import Array
from nlobs.systems.timebase import TimeBase


@runtime_checkable
class PlantModel(Protocol):
    """A numeric plant ``ẋ = f(t, x, u)`` (or ``x⁺ = f(t, x, u)``), ``y = h(t, x, u)``.

    Attributes
    ----------
    time : Continuous or Discrete
        Time base. For a discrete model ``rhs`` returns the *next* state.
    states, inputs, outputs : tuple of str
        Names, which fix the dimensions ``n``, ``m``, ``p``.

    Examples
    --------
    The shipped models, compiled, and linear systems satisfy the protocol; so does a plant written by hand,
    here ``ẋ = −2 x + u``, ``y = x``, which the simulation then runs like any other
    (``x(1) = e⁻²`` from ``x(0) = 1``):

    >>> import math
    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.systems.timebase import CONTINUOUS
    >>> pendulum = nlobs.load_model("pendulum").compile()
    >>> isinstance(pendulum, PlantModel), (pendulum.n, pendulum.m, pendulum.p)
    (True, (2, 1, 1))
    >>> pendulum.rhs(0.0, np.zeros((5, 2)), np.zeros((5, 1))).shape  # a batch of 5 states
    (5, 2)
    >>> class Decay:
    ...     time, states, inputs, outputs = CONTINUOUS, ("x",), ("u",), ("y",)
    ...     n = m = p = 1
    ...     def rhs(self, t, x, u):
    ...         return -2.0 * x + u
    ...     def output(self, t, x, u):
    ...         return x
    >>> isinstance(Decay(), PlantModel), isinstance(object(), PlantModel)
    (True, False)
    >>> res = nlobs.simulate(Decay(), None, [1.0], duration=1.0, dt=0.01, u=0.0)
    >>> bool(abs(res.x[-1, 0] - math.exp(-2.0)) < 1e-8)
    True
    """

    time: TimeBase
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]

    @property
    def n(self) -> int: ...

    @property
    def m(self) -> int: ...

    @property
    def p(self) -> int: ...

    def rhs(self, t: float, x: Array, u: Array) -> Array:
        """Right-hand side: ``ẋ`` (continuous) or ``x⁺`` (discrete), shape ``(..., n)``."""
        ...

    def output(self, t: float, x: Array, u: Array) -> Array:
        """Output ``y``, shape ``(..., p)``."""
        ...
