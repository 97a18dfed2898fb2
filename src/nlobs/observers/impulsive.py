r"""The impulsive (continuous-discrete) Thau observer: a copy of the model between samples, a jump at each sample.

For sensors much slower than the plant, injecting an output continuously has nothing to inject between samples.
The impulsive observer (Raff & Allgöwer, "Observers with impulsive dynamical behavior for linear and nonlinear
continuous-time systems", IEEE CDC 2007) runs the model between samples and corrects the estimate at each:

.. math::

    \dot{\hat x} = F(\hat x, u) \quad (t_k \le t < t_{k+1}), \qquad
    \hat x(t_k^+) = \hat x(t_k^-) + L_J\,\big(y_J(t_k) - h_J(\hat x(t_k^-))\big),

``J`` the outputs sampled at ``t_k`` (``L_J`` their columns of ``L``; several groups at their own rates). Its error
flows with ``ė = J̄_F e`` and jumps by ``e⁺ = (I − L_J J̄_h) e − L_J v``: the certificate
(:mod:`nlobs.synthesis.impulsive_gain`) is exact about the sampling, whatever its period. A non-finite sample
is missing: that output is not corrected.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray
from nlobs._validate import as_batch, as_matrix
from nlobs.errors import InvalidArgumentError
from nlobs.observers.base import ToControl
from nlobs.systems.timebase import TimeBase

__all__ = ["ImpulsiveObserver"]


@dataclass(frozen=True, eq=False)
class ImpulsiveObserver(ToControl):
    """The impulsive Thau observer (module docstring).

    Parameters
    ----------
    plant : PlantModel
        The continuous-time model (``rhs``, ``output``; a compiled symbolic model or a linear system).
    L : array_like, shape (n, p)
        The jump gain.
    name : str
        Label in results.

    Attributes
    ----------
    time : Continuous
        The plant's time base.
    state_names : tuple of str
        ``<state>_hat``.
    """

    plant: Any
    L: Array
    name: str = "Thau (impulsive)"
    time: TimeBase = field(init=False)
    state_names: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        for attr in ("rhs", "output", "states", "outputs", "time"):
            if not hasattr(self.plant, attr):
                raise InvalidArgumentError(f"plant: expected a PlantModel; {type(self.plant).__name__} has no {attr!r}")
        if self.plant.time.is_discrete:
            raise InvalidArgumentError("plant: the impulsive observer is for a continuous-time model")
        n, p = len(self.plant.states), len(self.plant.outputs)
        gain = as_matrix("L", self.L, (n, p))
        gain.setflags(write=False)
        object.__setattr__(self, "L", gain)
        object.__setattr__(self, "time", self.plant.time)
        object.__setattr__(self, "state_names", tuple(f"{s}_hat" for s in self.plant.states))

    @property
    def n_x(self) -> int:
        """Estimate dimension (``n``)."""
        return int(self.L.shape[0])

    @property
    def n_z(self) -> int:
        """Observer state dimension (``n``)."""
        return int(self.L.shape[0])

    def init(self, x_hat0: ArrayLike) -> Array:
        """``z0 = x̂0``, shape ``(..., n)``."""
        return np.array(as_batch("x_hat0", x_hat0, self.n_x), dtype=float)

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``F(x̂, u)``: the model between samples (``y`` is not used; samples enter in :meth:`correct`)."""
        return self.plant.rhs(t, z, u)

    def correct(self, t: float, z: Array, u: Array, y: Array, fresh: BoolArray) -> Array:
        """``x̂ + L_J (y_J − h_J(x̂))`` for the outputs ``J`` sampled at ``t`` (a non-finite sample is skipped).

        Parameters
        ----------
        t : float
            The sample instant.
        z : ndarray, shape (..., n)
            The estimate before the sample.
        u : ndarray, shape (..., m)
            The known input.
        y : ndarray, shape (..., p)
            The samples.
        fresh : ndarray of bool, shape (p,)
            Which outputs were sampled at ``t``.
        """
        fresh = np.asarray(fresh, dtype=bool)
        if not fresh.any():
            return z
        y = np.asarray(y, dtype=float)
        innovation = y - self.plant.output(t, z, u)
        innovation = np.where(fresh & np.isfinite(innovation), innovation, 0.0)
        return z + innovation @ self.L.T

    def estimate(self, z: Array) -> Array:
        """The estimate is the state, ``x̂ = z``."""
        return z
