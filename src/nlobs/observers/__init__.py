"""Observers: one module per method, each satisfying :class:`nlobs.observers.base.Observer`."""

from nlobs.observers.base import CorrectingObserver, Observer
from nlobs.observers.luenberger import LuenbergerObserver

__all__ = ["CorrectingObserver", "LuenbergerObserver", "Observer"]
