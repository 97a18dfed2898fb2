"""Linear state-space models ``(A, B, C, D)``, continuous or discrete time.

``ẋ = A x + B u``, ``y = C x + D u`` (continuous) or ``x⁺ = A x + B u`` (discrete).
Shapes and finiteness are checked at construction; the matrices are stored as
read-only float arrays.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_matrix, as_square, default_names, readonly
from nlobs.systems.timebase import CONTINUOUS, TimeBase


@dataclass(frozen=True)
class LinearSystem:
    """A linear time-invariant system.

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices of shapes ``(n, n)``, ``(n, m)``, ``(p, n)``, ``(p, m)``.
        ``B`` and ``D`` may have zero columns (``m = 0``).
    time : Continuous or Discrete
        Time base; :data:`~nlobs.systems.timebase.CONTINUOUS` by default.
    states, inputs, outputs : sequence of str, optional
        Names; default ``x1..xn``, ``u1..um``, ``y1..yp``.
    name : str
        A label used in reports.
    """

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    C: NDArray[np.float64]
    D: NDArray[np.float64]
    time: TimeBase = CONTINUOUS
    states: tuple[str, ...] = field(default=())
    inputs: tuple[str, ...] = field(default=())
    outputs: tuple[str, ...] = field(default=())
    name: str = "linear"

    def __init__(
        self,
        A: ArrayLike,
        B: ArrayLike,
        C: ArrayLike,
        D: ArrayLike | None = None,
        *,
        time: TimeBase = CONTINUOUS,
        states: Sequence[str] | None = None,
        inputs: Sequence[str] | None = None,
        outputs: Sequence[str] | None = None,
        name: str = "linear",
    ) -> None:
        A_ = as_square("A", A)
        n = A_.shape[0]
        B_ = as_matrix("B", B, (n, None))
        C_ = as_matrix("C", C, (None, n))
        m, p = B_.shape[1], C_.shape[0]
        D_ = np.zeros((p, m)) if D is None else as_matrix("D", D, (p, m))
        object.__setattr__(self, "A", readonly(A_))
        object.__setattr__(self, "B", readonly(B_))
        object.__setattr__(self, "C", readonly(C_))
        object.__setattr__(self, "D", readonly(D_))
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "states", default_names("state", "x", states, n))
        object.__setattr__(self, "inputs", default_names("input", "u", inputs, m))
        object.__setattr__(self, "outputs", default_names("output", "y", outputs, p))
        object.__setattr__(self, "name", str(name))

    @property
    def n(self) -> int:
        """Number of states."""
        return self.A.shape[0]

    @property
    def m(self) -> int:
        """Number of inputs."""
        return self.B.shape[1]

    @property
    def p(self) -> int:
        """Number of outputs."""
        return self.C.shape[0]

    @property
    def is_discrete(self) -> bool:
        return self.time.is_discrete

    def rhs(self, t: float, x: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``A x + B u`` for a batch ``x`` of shape ``(..., n)`` and ``u`` of shape ``(..., m)``."""
        if x.ndim == 1 and u.ndim == 1:  # one run: ndarray.dot costs a third of @ on small matrices
            return self.A.dot(x) + self.B.dot(u)
        return x @ self.A.T + u @ self.B.T

    def output(self, t: float, x: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``C x + D u`` for batches, shape ``(..., p)``."""
        if x.ndim == 1 and u.ndim == 1:
            return self.C.dot(x) + self.D.dot(u)
        return x @ self.C.T + u @ self.D.T

    def rhs_jacobian_x(self, t: float, x: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``∂(A x + B u)/∂x = A``, broadcast to the batch, shape ``(..., n, n)`` (read-only)."""
        if x.ndim == 1 and np.ndim(u) <= 1:
            return self.A
        return np.broadcast_to(self.A, (*np.broadcast_shapes(x.shape[:-1], np.shape(u)[:-1]), *self.A.shape))

    def output_jacobian_x(self, t: float, x: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``∂(C x + D u)/∂x = C``, broadcast to the batch, shape ``(..., p, n)`` (read-only)."""
        if x.ndim == 1 and np.ndim(u) <= 1:
            return self.C
        return np.broadcast_to(self.C, (*np.broadcast_shapes(x.shape[:-1], np.shape(u)[:-1]), *self.C.shape))
