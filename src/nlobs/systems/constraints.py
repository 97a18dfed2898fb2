r"""Bounds on the state: ``lower ≤ x ≤ upper`` per state (``±inf`` where a state has none).

A model file's ``[constraints]`` table::

    [constraints]
    lower = [0.0, 0.0, 0.0]     # per state (TOML's inf and -inf allowed)
    upper = [1.0, 1.0, inf]

Physical states have bounds (fractions in ``[0, 1]``, concentrations ``≥ 0``). A simulation reports how often
the truth and each estimate leave them; the estimators that can respect them do: the EKF and UKF project
their mean onto the box after each correction (estimate projection, Simon 2010, *IET Control Theory Appl.*
4(8), §3 with the weight ``W = I``: for a box, the clip), the particle filter keeps its particles inside, and
moving-horizon estimation has them as constraints of its program.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs.errors import DimensionError, InvalidArgumentError

__all__ = ["StateBounds"]


@dataclass(frozen=True, eq=False)
class StateBounds:
    """Per-state bounds ``lower ≤ x ≤ upper`` (module docstring).

    Parameters
    ----------
    lower, upper : array_like, shape (n,)
        Bounds per state; ``-inf`` / ``inf`` where there is none. ``lower < upper`` for every state.

    Raises
    ------
    DimensionError
        ``lower`` and ``upper`` are not two vectors of the same length.
    InvalidArgumentError
        A NaN, a ``lower ≥ upper``, or no finite bound at all.

    Examples
    --------
    Fractions in ``[0, 1]``: a batch of two estimates, the second outside in its first state:

    >>> import numpy as np
    >>> b = StateBounds([0.0, 0.0], [1.0, np.inf])
    >>> x = np.array([[0.5, 3.0], [1.2, 0.1]])
    >>> b.inside(x)
    array([ True, False])
    >>> b.project(x)
    array([[0.5, 3. ],
           [1. , 0.1]])
    >>> b.describe(["S", "I"])
    'S ∈ [0, 1], I ≥ 0'
    """

    lower: Array
    upper: Array

    def __post_init__(self) -> None:
        try:
            lo = np.array(self.lower, dtype=float)
            hi = np.array(self.upper, dtype=float)
        except (TypeError, ValueError):
            raise InvalidArgumentError("constraints: lower and upper must be lists of numbers (inf allowed)") from None
        if lo.ndim != 1 or hi.shape != lo.shape:
            raise DimensionError(f"constraints: lower and upper must be vectors of the same length, got shapes "
                                 f"{lo.shape} and {hi.shape}")
        if np.isnan(lo).any() or np.isnan(hi).any():
            raise InvalidArgumentError("constraints: a bound is NaN (use inf or -inf for none)")
        bad = np.flatnonzero(lo >= hi)
        if bad.size:
            i = int(bad[0])
            raise InvalidArgumentError(f"constraints: state {i}: lower {lo[i]:g} is not below upper {hi[i]:g}")
        if not (np.isfinite(lo).any() or np.isfinite(hi).any()):
            raise InvalidArgumentError("constraints: every bound is infinite (give at least one finite bound)")
        lo.flags.writeable = hi.flags.writeable = False
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    @property
    def n(self) -> int:
        """Number of states."""
        return int(self.lower.size)

    def check_size(self, n: int) -> None:
        """Raise :class:`~nlobs.errors.DimensionError` unless the bounds are for ``n`` states."""
        if self.n != n:
            raise DimensionError(f"constraints: {self.n} bounds for a model of {n} states")

    def inside(self, x: ArrayLike) -> Any:
        """Whether each ``x`` (``(..., n)``) is inside the box (NaN is not), shape ``(...)``."""
        xa = np.asarray(x, dtype=float)
        return np.all((xa >= self.lower) & (xa <= self.upper), axis=-1)

    def project(self, x: ArrayLike) -> Array:
        """``x`` clipped into the box (the Euclidean projection), same shape; NaN stays NaN."""
        return np.clip(np.asarray(x, dtype=float), self.lower, self.upper)

    def fraction_outside(self, x: ArrayLike, axis: Any = None) -> Any:
        """The fraction of the points ``x`` (``(..., n)``) outside the box (NaN points excluded).

        Parameters
        ----------
        x : array_like, shape (..., n)
        axis : int or tuple of int, optional
            Axes of ``x[..., 0]`` to average over (``None``: all).

        Returns
        -------
        float or ndarray
        """
        xa = np.asarray(x, dtype=float)
        finite = np.isfinite(xa).all(axis=-1)
        out = ~self.inside(xa) & finite
        count = np.sum(finite, axis=axis)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.sum(out, axis=axis) / np.maximum(count, 1)

    def describe(self, names: Any = None) -> str:
        """The bounds as text (``S ∈ [0, 1], I ≥ 0``), states without a bound left out."""
        names = list(names) if names is not None else [f"x{i + 1}" for i in range(self.n)]
        parts = []
        for name, lo, hi in zip(names, self.lower.tolist(), self.upper.tolist()):
            if np.isfinite(lo) and np.isfinite(hi):
                parts.append(f"{name} ∈ [{lo:g}, {hi:g}]")
            elif np.isfinite(lo):
                parts.append(f"{name} ≥ {lo:g}")
            elif np.isfinite(hi):
                parts.append(f"{name} ≤ {hi:g}")
        return ", ".join(parts)
