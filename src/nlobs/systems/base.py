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
