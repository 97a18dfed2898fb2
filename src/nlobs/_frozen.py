"""A read-only mapping that pickles: what results, checks and signals hold their named values in.

:class:`types.MappingProxyType` is read-only but cannot be pickled, so a result holding one could not be returned
from a :class:`concurrent.futures.ProcessPoolExecutor`; :class:`FrozenMapping` is read-only, compares equal to a dict
with the same items, and pickles as the dict it copies.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any, TypeVar

K = TypeVar("K")
V = TypeVar("V")

__all__ = ["FrozenMapping"]


class FrozenMapping(Mapping[K, V]):
    """A read-only copy of a mapping (no item assignment, no ``update``); pickles as its items.

    Parameters
    ----------
    data : mapping or iterable of (key, value), optional
        The items (copied).

    Examples
    --------
    >>> import pickle
    >>> m = FrozenMapping({"a": 1.0})
    >>> m["a"], m == {"a": 1.0}, pickle.loads(pickle.dumps(m)) == m
    (1.0, True, True)
    """

    __slots__ = ("_data",)

    def __init__(self, data: Mapping[K, V] | Any = ()) -> None:
        object.__setattr__(self, "_data", dict(data))

    def __getitem__(self, key: K) -> V:
        return self._data[key]  # type: ignore[no-any-return]

    def __iter__(self) -> Iterator[K]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{type(self).__name__} is read-only")

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._data!r})"

    def __reduce__(self) -> tuple[Any, tuple[dict[K, V]]]:
        return (type(self), (self._data,))
