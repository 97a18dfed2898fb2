"""Inputs of the workflows given as plain numbers (what a command line or a script has): regions."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from nlobs.errors import InvalidArgumentError, NlobsError
from nlobs.geometry.region import Box

__all__ = ["BoxError", "box_from_numbers"]


class BoxError(InvalidArgumentError):
    """A region given as numbers is malformed (the CLI prefixes the option name, ``--box``)."""


def box_from_numbers(values: Sequence[float], n: int) -> Box:
    """A box from ``lo, hi`` (the same interval for every state) or ``2n`` numbers ``lo1, hi1, lo2, hi2, ...``.

    Raises
    ------
    BoxError
        Not 2 or ``2n`` numbers, or an invalid box (non-finite, ``lo > hi``).
    """
    vals = [float(v) for v in values]
    if len(vals) == 2:
        vals = vals * n
    if len(vals) != 2 * n:
        raise BoxError(f"expected 'lo,hi' or {2 * n} numbers lo1,hi1,...; got {len(values)} numbers")
    try:
        return Box(np.array(vals[0::2]), np.array(vals[1::2]))
    except NlobsError as exc:
        raise BoxError(str(exc)) from exc
