"""Time bases: a model is either continuous-time or discrete-time with an explicit step.

There is no ``dt=None``/``dt=True`` convention: a model carries a
:class:`Continuous` or a :class:`Discrete` instance.
"""

from __future__ import annotations

from dataclasses import dataclass

from nlobs._validate import positive


@dataclass(frozen=True)
class Continuous:
    """Continuous time, ``ẋ = f(x, u)``.

    Examples
    --------
    One instance, :data:`CONTINUOUS`, serves every continuous model (the default of
    :class:`~nlobs.systems.linear.LinearSystem`):

    >>> from nlobs.systems.linear import LinearSystem
    >>> Continuous() == CONTINUOUS, CONTINUOUS.is_discrete, str(CONTINUOUS)
    (True, False, 'continuous')
    >>> LinearSystem([[-1.0]], [[1.0]], [[1.0]]).time
    Continuous()
    """

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

    Examples
    --------
    >>> from nlobs.errors import InvalidArgumentError
    >>> T = Discrete(0.01)
    >>> T.dt, T.is_discrete, str(T), T == Discrete(0.01)
    (0.01, True, 'discrete (dt=0.01)', True)
    >>> try:
    ...     Discrete(0.0)  # the sampling period is never defaulted or zero
    ... except InvalidArgumentError:
    ...     print("refused")
    refused
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
