"""Observers: one module per method, each satisfying :class:`nlobs.observers.base.Observer`."""

from nlobs.observers.base import CorrectingObserver, Observer
from nlobs.observers.discrete_baselines import DiscreteLipschitzObserver, EkfState, UnknownInputEKF, joseph_update
from nlobs.observers.luenberger import LuenbergerObserver
from nlobs.observers.setvalued import (
    GivenGain,
    Radii,
    SetValuedRun,
    input_error_map,
    printed_radii,
    run_setvalued,
    sound_radii,
)

__all__ = [
    "CorrectingObserver",
    "DiscreteLipschitzObserver",
    "EkfState",
    "GivenGain",
    "LuenbergerObserver",
    "Observer",
    "Radii",
    "SetValuedRun",
    "UnknownInputEKF",
    "input_error_map",
    "joseph_update",
    "printed_radii",
    "run_setvalued",
    "sound_radii",
]
