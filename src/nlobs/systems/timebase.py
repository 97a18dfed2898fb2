"""Time bases: a model is either continuous-time or discrete-time with an explicit step.

There is no ``dt=None``/``dt=True`` convention: a model carries a
:class:`Continuous` or a :class:`Discrete` instance.
"""

from __future__ import annotations

from dataclasses import dataclass

from nlobs._validate import positive


@dataclass(frozen=True)
class Continuous:
    """Continuous time, ``ẋ = f(x, u)``."""

    @property
    def is_discrete(self) -> bool:
        return False

    def __str__(self) -> str:
        return "continuous"


@dataclass(frozen=True)
class Discrete:
    """Discrete time with sampling period ``dt`` (seconds), ``x⁺ = f(x, u)``.

    Parameters
    ----------
    dt : float
        The sampling period, positive and finite.
    """

    dt: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dt", positive("dt", self.dt))

    @property
    def is_discrete(self) -> bool:
        return True

    def __str__(self) -> str:
        return f"discrete (dt={self.dt:g})"


TimeBase = Continuous | Discrete

CONTINUOUS = Continuous()
