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

from dataclasses import dataclass
from typing import Any

import numpy as np

from nlobs._typing import Array, BoolArray
from nlobs.errors import InvalidArgumentError
from nlobs.observers.luenberger import _PlantCopy

__all__ = ["ImpulsiveObserver"]


@dataclass(frozen=True, eq=False)
class ImpulsiveObserver(_PlantCopy):
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

    Examples
    --------
    The pendulum (a shipped model) with its angle sampled at 10 Hz: between samples the estimate follows the
    model, at each sample it jumps by ``L (y_k − h(x̂))``:

    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup
    >>> plant = nlobs.load_model("pendulum").compile()
    >>> observer = nlobs.ImpulsiveObserver(plant, [[0.5], [1.0]])
    >>> encoder = MeasurementGroup("encoder", ["y"], rate=10.0)
    >>> res = nlobs.simulate(plant, observer, [0.5, 0.0], [0.2, 0.3], duration=5.0, dt=1e-2, u=0.0,
    ...                      measurements=encoder)
    >>> res.x_hat[0].round(6)  # the sample at t = 0 has moved x̂0 = [0.2, 0.3] by L (0.5 − 0.2)
    array([0.35, 0.6 ])
    >>> bool(res.error_norm[-1] < 1e-4)
    True
    """

    plant: Any
    L: Array
    name: str = "Thau (impulsive)"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.plant.time.is_discrete:
            raise InvalidArgumentError("plant: the impulsive observer is for a continuous-time model")

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

