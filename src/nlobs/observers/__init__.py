"""Observers: one module per method, every estimator satisfying :class:`nlobs.observers.base.Observer`."""

from nlobs.observers.base import CorrectingObserver, DeferredEstimate, Diagnosing, Observer, SelfStepping
from nlobs.observers.kalman import GaussianState, UnknownInputEKF, joseph_update
from nlobs.observers.lipschitz import DiscreteLipschitzObserver
from nlobs.observers.luenberger import LuenbergerObserver
from nlobs.observers.setvalued import (
    GivenGain,
    Radii,
    RadiusRecursion,
    SetValuedObserver,
    SetValuedState,
    input_error_map,
    printed_radii,
    sound_radii,
)

__all__ = [
    "CorrectingObserver",
    "DeferredEstimate",
    "Diagnosing",
    "DiscreteLipschitzObserver",
    "GaussianState",
    "GivenGain",
    "LuenbergerObserver",
    "Observer",
    "Radii",
    "RadiusRecursion",
    "SelfStepping",
    "SetValuedObserver",
    "SetValuedState",
    "UnknownInputEKF",
    "input_error_map",
    "joseph_update",
    "printed_radii",
    "sound_radii",
]
