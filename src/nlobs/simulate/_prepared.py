"""A small per-process cache of prepared recipes: what ``recipe.prepare()`` built, found again by ``recipe.key()``.

A recipe (a Monte Carlo study, a sweep's problem) is a small picklable object sent to every worker;
its ``prepare()`` builds the heavy objects (a design, compiled functions, a loaded model) and is
called once per process and recipe. The cache keeps the last few, keyed by the SHA-256 of ``key()``,
and evicts the oldest first. :func:`nlobs.simulate.montecarlo.prepared` keeps its own cache of
studies; :mod:`nlobs.simulate.sweep` uses one of these.
"""

from __future__ import annotations

import hashlib
from typing import Any, Protocol


class Recipe(Protocol):
    """What the cache needs: a text that identifies the recipe and the function that builds its objects."""

    def key(self) -> str:
        """A text identifying what :meth:`prepare` builds (equal texts: equal prepared objects)."""
        ...

    def prepare(self) -> Any:
        """Build the objects every task of the recipe reuses."""
        ...


class PreparedCache:
    """``recipe.prepare()`` built once per process and key, the last ``size`` kept.

    Parameters
    ----------
    size : int
        Recipes kept; the oldest is dropped when a new one arrives.
    """

    def __init__(self, size: int) -> None:
        self.size = max(1, int(size))
        self._items: dict[str, Any] = {}

    def get(self, recipe: Recipe) -> Any:
        """The prepared objects of ``recipe``, built on the first call in this process."""
        key = hashlib.sha256(recipe.key().encode()).hexdigest()
        if key not in self._items:
            if len(self._items) >= self.size:
                self._items.pop(next(iter(self._items)))
            self._items[key] = recipe.prepare()
        return self._items[key]

    def clear(self) -> None:
        """Forget every prepared recipe of this process."""
        self._items.clear()

    def __len__(self) -> int:
        return len(self._items)
