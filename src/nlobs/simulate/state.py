"""Observer states as trees of arrays: the arithmetic and checks the loops need for any ``Z``.

An observer state ``z`` is an ``ndarray`` (most observers), a frozen dataclass whose fields
are arrays (a Kalman filter's mean and covariance, the set-valued observer's centres and
radii), or a tuple of those. The loops need three things from it: linear combinations (RK4
stages of a continuous observer without its own step), the first non-finite entry (divergence
reports) and names for its parts. Fields that are not arrays (counters, flags, ``None``) are
carried over unchanged from the first operand.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from nlobs._typing import Array


def _is_leaf(v: Any) -> bool:
    return isinstance(v, np.ndarray) and v.dtype.kind == "f"


def tree_map(fn: Callable[..., Array], first: Any, *rest: Any) -> Any:
    """Apply ``fn`` to the float-array leaves of ``first`` and the matching leaves of ``rest``.

    Parameters
    ----------
    fn : callable
        ``fn(a, b, ...)`` on arrays.
    first, *rest : state
        Trees of the same structure (ndarray, tuple, or dataclass of those).

    Returns
    -------
    state
        A tree of ``first``'s structure; non-float fields come from ``first``.
    """
    if isinstance(first, np.ndarray):
        return fn(first, *rest)
    if isinstance(first, tuple):
        return tuple(tree_map(fn, a, *(r[i] for r in rest)) for i, a in enumerate(first))
    names = _init_fields(type(first))
    if names is None:
        return first
    values = {}
    for name in names:
        v = getattr(first, name)
        if type(v) is np.ndarray and v.dtype.kind == "f":
            v = fn(v, *(getattr(r, name) for r in rest))
        elif isinstance(v, tuple) or (dataclasses.is_dataclass(v) and not isinstance(v, type)):
            v = tree_map(fn, v, *(getattr(r, name) for r in rest))
        values[name] = v
    return type(first)(**values)  # dataclasses.replace, without its per-call field introspection


_FIELDS: dict[type, tuple[str, ...] | None] = {}


def flat_fields(z: Any) -> tuple[tuple[str, ...], tuple[int, ...]] | None:
    """A dataclass state that is a flat record of floats: its field names and the indices of its float arrays.

    A flat record: every ``__init__`` field positional and a float array or a NumPy float scalar (a Kalman
    filter's mean, covariance and NIS). Combining its float arrays field by field, carrying its scalars over
    from the first operand and building it positionally gives exactly what :func:`tree_map` gives, without
    walking the tree at every stage. Anything else (a bare array, a tuple, a dataclass with other fields) is
    ``None``: those go through :func:`tree_map`.
    """
    cls = type(z)
    names = _POSITIONAL.get(cls, ())
    if names == ():
        names = _POSITIONAL[cls] = _positional_fields(cls)
    if names is None:
        return None
    arrays = []
    for i, name in enumerate(names):
        v = getattr(z, name)
        if type(v) is np.ndarray and v.dtype.kind == "f":
            arrays.append(i)
        elif not isinstance(v, np.floating):
            return None
    return names, tuple(arrays)


_POSITIONAL: dict[type, tuple[str, ...] | None] = {}


def _positional_fields(cls: type) -> tuple[str, ...] | None:
    """The ``__init__`` fields of a dataclass type, all positional (``None``: not a dataclass, or a keyword-only field)."""
    if not dataclasses.is_dataclass(cls):
        return None
    fields = [f for f in dataclasses.fields(cls) if f.init]
    if not fields or any(f.kw_only for f in fields):
        return None
    return tuple(f.name for f in fields)


def _init_fields(cls: type) -> tuple[str, ...] | None:
    """The ``__init__`` fields of a dataclass type (``None``: not a dataclass), looked up once per type."""
    try:
        return _FIELDS[cls]
    except KeyError:
        names = tuple(f.name for f in dataclasses.fields(cls) if f.init) if dataclasses.is_dataclass(cls) else None
        _FIELDS[cls] = names
        return names


def leaves(z: Any, prefix: str = "") -> Iterator[tuple[str, Array]]:
    """``(name, array)`` for every float-array leaf of a state (``""`` for a bare array)."""
    if isinstance(z, np.ndarray):
        if z.dtype.kind == "f":
            yield prefix, z
    elif isinstance(z, tuple):
        for i, v in enumerate(z):
            yield from leaves(v, f"{prefix}[{i}]")
    elif not isinstance(z, type):
        for name in _all_fields(type(z)):  # () for anything but a dataclass instance
            yield from leaves(getattr(z, name), f"{prefix}.{name}" if prefix else name)


_ALL_FIELDS: dict[type, tuple[str, ...]] = {}


def _all_fields(cls: type) -> tuple[str, ...]:
    """Every field of a dataclass type, in order (``()`` for any other type), looked up once per type."""
    try:
        return _ALL_FIELDS[cls]
    except KeyError:
        names = tuple(f.name for f in dataclasses.fields(cls)) if dataclasses.is_dataclass(cls) else ()
        _ALL_FIELDS[cls] = names
        return names


def first_nonfinite(z: Any, names: tuple[str, ...] | None = None) -> str | None:
    """Name of the first non-finite component of a state, or ``None`` when it is finite everywhere.

    For a bare array the component is named by ``names[i]`` (``z[i]`` without names); for a
    dataclass by its field (and index: ``R[1, 2]`` is reported as ``R``).
    """
    for name, arr in leaves(z):
        if not np.isfinite(arr).all():
            if name == "":
                if arr.ndim == 0:
                    return "z"
                bad = ~np.isfinite(arr).reshape(-1, arr.shape[-1]).all(axis=0)
                i = int(np.flatnonzero(bad)[0])
                return names[i] if names is not None and i < len(names) else f"z[{i}]"
            return name
    return None


def batch_shape_of(z: Any) -> tuple[int, ...] | None:
    """The leading shape of a bare-array state (all but the last axis), else ``None``."""
    if isinstance(z, np.ndarray) and z.ndim >= 1:
        return tuple(z.shape[:-1])
    return None
