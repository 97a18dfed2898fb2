"""Matrix-valued states as vectors: ``vec`` stacks columns (Grip, Saberi & Johansen, Sec. 3 and 5: ``x = vec R``)."""

from __future__ import annotations

import numpy as np

from nlobs._typing import Array
from nlobs.errors import DimensionError


def vec(M: Array) -> Array:
    """Stack the columns of ``M``: shape ``(..., r, c)`` → ``(..., r·c)``.

    ``vec(M)[..., i + r*j] == M[..., i, j]`` (column-major, as in the paper).
    """
    M = np.asarray(M)
    if M.ndim < 2:
        raise DimensionError(f"vec: expected a (..., r, c) array, got shape {M.shape}")
    return np.swapaxes(M, -1, -2).reshape(*M.shape[:-2], M.shape[-1] * M.shape[-2])


def unvec(x: Array, rows: int, cols: int | None = None) -> Array:
    """Inverse of :func:`vec`: shape ``(..., rows·cols)`` → ``(..., rows, cols)``."""
    x = np.asarray(x)
    cols = rows if cols is None else cols
    if x.ndim < 1 or x.shape[-1] != rows * cols:
        raise DimensionError(f"unvec: expected shape (..., {rows * cols}), got {x.shape}")
    return np.swapaxes(x.reshape(*x.shape[:-1], cols, rows), -1, -2)
