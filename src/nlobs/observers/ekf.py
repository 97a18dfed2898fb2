r"""The extended Kalman filter for any plant with Jacobians: continuous-discrete or discrete.

A :class:`~nlobs.observers.base.CorrectingObserver` whose state is a
:class:`~nlobs.observers.gaussian.FilterState`. Between samples of a continuous-time plant it is the
continuous-discrete EKF of Jazwinski (1970, *Stochastic Processes and Filtering Theory*, §8.3): the
mean and covariance follow

.. math:: \dot{\hat x} = f(\hat x, u), \qquad \dot P = F P + P F^\top + Q, \qquad F = \partial f/\partial x(\hat x, u),

integrated by the loop (RK4 on the dataclass state); for a discrete-time plant ``rhs`` is the
prediction ``x̂⁺ = f(x̂, u)``, ``P⁺ = F P Fᵀ + Q``. At a sample the correction linearises the output,
``H = ∂h/∂x(x̂, u)``, and updates in Joseph form (:func:`~nlobs.observers.kalman.joseph_update`).

The Jacobians are the plant's ``rhs_jacobian_x(t, x, u)`` and ``output_jacobian_x(t, x, u)``: compiled
once by :meth:`~nlobs.systems.symbolic.SymbolicModel.compile`, the constant ``A`` and ``C`` of a
:class:`~nlobs.systems.linear.LinearSystem`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nlobs._typing import Array
from nlobs.errors import InvalidArgumentError
from nlobs.observers.gaussian import ZERO_RATE, FilterState, GaussianFilterBase
from nlobs.observers.kalman import joseph_update

__all__ = ["EKF"]

_JACOBIANS = ("rhs_jacobian_x", "output_jacobian_x")

#: The NIS rate of one run between samples (read-only: RK4 combines it into new arrays, never in place).


@dataclass(frozen=True, eq=False)
class EKF(GaussianFilterBase):
    r"""Extended Kalman filter (continuous-discrete for a continuous plant, discrete otherwise).

    Parameters
    ----------
    plant : PlantModel
        The model, with ``rhs_jacobian_x(t, x, u)`` ``(..., n, n)`` and ``output_jacobian_x(t, x, u)``
        ``(..., p, n)`` (a compiled symbolic model or a linear system).
    Q : array_like, shape (n, n)
        Symmetric positive semi-definite process noise: the spectral density of ``w`` in
        ``ẋ = f(x, u) + w`` (continuous plant), the covariance of ``w_k`` in ``x⁺ = f(x, u) + w_k``
        (discrete plant).
    R : array_like, shape (p, p)
        Symmetric positive definite covariance of the noise on all outputs.
    P0 : array_like, shape (n, n)
        Symmetric positive semi-definite initial covariance (:meth:`init`).
    name : str
        Label in results.
    record_covariance : bool
        Also record the full ``P`` among the diagnostics.
    bounds : StateBounds, optional
        Bounds on the state: the mean is projected onto them after each correction (Simon 2010).

    Notes
    -----
    ``rhs`` returns ``(f(x̂, u), F P + P Fᵀ + Q)`` as the time derivative of the state (continuous) or
    ``(f(x̂, u), F P Fᵀ + Q)`` (discrete), covariances symmetrised; the state's ``nis`` is carried
    unchanged. Jazwinski (1970), §8.3 (continuous-discrete EKF).

    Raises
    ------
    InvalidArgumentError
        The plant has no Jacobians (the message names the missing methods), or a covariance is not
        positive (semi-)definite.
    DimensionError, NonFiniteError, NotSymmetricError
        For ``Q``, ``R``, ``P0`` of the wrong shape, with a non-finite entry, not symmetric.

    Examples
    --------
    The pendulum (a shipped model) with its angle sampled at 10 Hz, started 1 rad/s off in the unmeasured
    velocity: the first sample (at ``t = 0``) corrects the angle at once, the velocity follows, and the
    covariance shrinks to its steady state:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup
    >>> plant = nlobs.load_model("pendulum").compile()
    >>> ekf = nlobs.EKF(plant, Q=1e-4 * np.eye(2), R=[[1e-4]], P0=np.eye(2))
    >>> res = nlobs.simulate(plant, ekf, [1.0, 0.0], [0.0, 1.0], duration=3.0, dt=1e-2, u=0.0,
    ...                      measurements=MeasurementGroup("encoder", ["y"], rate=10.0))
    >>> np.abs(res.error[0]).round(3), bool(res.error_norm[-1] < 1e-4)
    (array([0., 1.]), True)
    >>> np.sqrt(res.extras["P_diag"][-1]).round(3)  # standard deviations of the angle and the velocity
    array([0.005, 0.017])
    """

    name: str = field(default="EKF", kw_only=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        missing = [m for m in _JACOBIANS if not callable(getattr(self.plant, m, None))]
        if missing:
            raise InvalidArgumentError(
                f"plant: the EKF needs the Jacobian{'s' if len(missing) > 1 else ''} "
                f"{', '.join(f'{m}(t, x, u)' for m in missing)}, which {type(self.plant).__name__} lacks "
                "(a compiled SymbolicModel and a LinearSystem have them; the UKF needs none)")

    def _predicted(self, t: float, x: Array, u: Array) -> tuple[Array, Array]:
        """``(f, ∂f/∂x)`` at ``(t, x, u)``: from one call of a compiled model, else from the plant's two methods."""
        plant = self.plant
        both = getattr(plant, "rhs_and_jacobian_x", None)
        return both(t, x, u) if both is not None else (plant.rhs(t, x, u), plant.rhs_jacobian_x(t, x, u))

    def _linearised_output(self, t: float, x: Array, u: Array) -> tuple[Array, Array]:
        """``(h, ∂h/∂x)`` at ``(t, x, u)``: from one call of a compiled model, else from the plant's two methods."""
        plant = self.plant
        both = getattr(plant, "output_and_jacobian_x", None)
        return both(t, x, u) if both is not None else (plant.output(t, x, u), plant.output_jacobian_x(t, x, u))

    def rhs(self, t: float, z: FilterState, u: Array, y: Array) -> FilterState:
        """Time derivative of ``(x̂, P)`` (continuous plant) or the prediction (discrete plant)."""
        x, P = z.x, z.P
        f, F = self._predicted(t, x, u)
        if F.ndim == 2 and P.ndim == 2:  # one run: ndarray.dot costs a third of @ on small matrices
            FP = F.dot(P)
            P_new = FP.dot(F.T) if self.discrete else FP + FP.T
        else:
            FP = F @ P
            P_new = FP @ F.mT if self.discrete else FP + FP.mT
        P_new += self.Q
        if self.discrete:
            P_new = P_new + P_new.mT.copy()  # F P Fᵀ, unlike F P + (F P)ᵀ, is not symmetric to the last bit
            P_new *= 0.5
            return FilterState(f, P_new, z.nis)
        nis = z.nis  # constant between samples: a zero rate (a NumPy scalar is carried by RK4 as it is)
        return FilterState(f, P_new, ZERO_RATE if nis.ndim == 0 else np.zeros(nis.shape))

    def _update(self, t: float, x: Array, P: Array, u: Array, y: Array, rows: Any) -> tuple[Array, Array, Array]:
        h, H = self._linearised_output(t, x, u)
        if rows is not None:
            h, H = h[..., rows], H[..., rows, :]
        dx, P_new, nis = joseph_update(P, H, self.R if rows is None else self.R[np.ix_(rows, rows)], y - h, nis=True)
        return x + dx, P_new, nis
