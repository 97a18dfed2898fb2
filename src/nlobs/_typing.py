"""Array type aliases used across nlobs (one place, imported everywhere)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: A float64 array (states, inputs, outputs, matrices).
Array = NDArray[np.float64]
#: A boolean array (masks: sampled channels, containment).
BoolArray = NDArray[np.bool_]
#: An integer array (indices, counts).
IntArray = NDArray[np.intp]
#: A complex array (eigenvalues, zeros).
ComplexArray = NDArray[np.complex128]

__all__ = ["Array", "BoolArray", "ComplexArray", "IntArray"]
