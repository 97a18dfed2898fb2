r"""A sampled-data bound stated in other coordinates ``z = Φ(x)``, read in the plant's coordinates ``x``.

The drift-observability observer of Dalla Mora, Germani & Manes is certified in the coordinates
``z = Φ_s(x)`` of its observability map: the sampling budget of :mod:`nlobs.synthesis.sampled_data`
holds there for ``V = e_zᵀ P⁻¹ e_z``. On a region where ``Φ_s`` and ``Φ_s⁻¹`` are Lipschitz with
constants ``γ_Φ`` and ``γ_Φ⁻¹`` (the constants of its bound (3.2)), an error in one set of coordinates
bounds the other:

    |e_x| ≤ γ_Φ⁻¹ |e_z|,        |e_z| ≤ γ_Φ |e_x|,

while the plant and the estimate stay in the region (a premise the coverage monitor checks).
:class:`MappedBound` carries those two constants with the bound in ``z`` and states, in ``x``:

* the bounded-noise bound (input-to-state): ``limsup |e_x| ≤ γ_Φ⁻¹ · ultimate_bound_z(v̄)``, for
  measurement noise ``|v_j| ≤ v̄_j`` and no process noise;
* the mean-square bound after a settling time, from the initial second moment in ``x``:
  ``E e_zᵀP_z e_z ≤ λmax(P_z) γ_Φ² E|e_x|²`` — unless the runs have process noise the bound in ``z`` does not
  count (``process_noise``; the drift observer's counts it, :func:`~nlobs.methods.sensor_design.drift_process_noise`).

A linear map is the exact special case: the cascade observer of Grip, Saberi & Johansen is certified in the
coordinates ``χ = (x, w, z)`` of its augmented plant (:mod:`nlobs.methods.cascade_sampling`), where the initial
error is ``χ̃₀ = M x̃₀`` and ``x̃`` is a part of ``χ̃`` (``γ_Φ⁻¹ = 1``); with ``into = M`` the initial term is
``E χ̃₀ᵀ P χ̃₀ = tr(P M E[x̃₀x̃₀ᵀ] Mᵀ)`` exactly, and the bound there counts the process noise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._validate import positive
from nlobs.checks import Check
from nlobs.errors import InvalidArgumentError
from nlobs.synthesis.sampled_data import SampledDataBound

__all__ = ["MappedBound"]


@dataclass(frozen=True)
class MappedBound:
    """A :class:`~nlobs.synthesis.sampled_data.SampledDataBound` in ``z = Φ(x)``, read in ``x`` (module docstring).

    Parameters
    ----------
    inner : SampledDataBound
        The bound in ``z``.
    gamma_phi, gamma_phi_inv : float
        Lipschitz constants of ``Φ`` and ``Φ⁻¹`` on the region (positive, finite).
    process_noise : bool
        Whether the runs it is read for have process noise the bound in ``z`` does not count (then no
        mean-square bound is stated).
    into : array_like, shape (n_z, n_x), optional
        A linear map of the initial error into ``z`` (then used exactly, instead of ``γ_Φ``).

    Raises
    ------
    InvalidArgumentError
        ``inner`` is not a :class:`SampledDataBound`, or a constant is not positive.
    NonFiniteError
        A constant is not finite.
    """

    inner: SampledDataBound
    gamma_phi: float
    gamma_phi_inv: float
    process_noise: bool
    into: Any = None

    def __post_init__(self) -> None:
        if not isinstance(self.inner, SampledDataBound):
            raise InvalidArgumentError(f"inner: expected a SampledDataBound, got {type(self.inner).__name__}")
        object.__setattr__(self, "gamma_phi", positive("gamma_phi", self.gamma_phi))
        object.__setattr__(self, "gamma_phi_inv", positive("gamma_phi_inv", self.gamma_phi_inv))
        object.__setattr__(self, "process_noise", bool(self.process_noise))
        if self.into is not None:
            M = np.asarray(self.into, dtype=float)
            nz = self.inner.P.shape[0]
            if M.ndim != 2 or M.shape[0] != nz or not np.all(np.isfinite(M)):
                raise InvalidArgumentError(f"into: expected a finite ({nz}, n) matrix, got shape {M.shape}")
            object.__setattr__(self, "into", M)

    # what the sampling premise and the reports read, as the bound in z has them
    @property
    def verified(self) -> bool:
        """Whether the bound in ``z`` is verified (every check passed)."""
        return self.inner.verified

    @property
    def checks(self) -> tuple[Check, ...]:
        """The checks of the bound in ``z``."""
        return self.inner.checks

    @property
    def groups(self) -> tuple[Any, ...]:
        """The sensor groups (period, noise, ``ℓ_j``)."""
        return self.inner.groups

    @property
    def t_max(self) -> tuple[float, ...]:
        """``T_max`` per group (the same in any coordinates)."""
        return self.inner.t_max

    @property
    def budget(self) -> float:
        """``Σ T_j / T_max,j``."""
        return self.inner.budget

    def violation(self) -> str | None:
        """Which hypothesis of the bound in ``z`` fails (``None`` when verified)."""
        return self.inner.violation()

    # the bounds, in x
    def ultimate_bound(self, noise_bounds: float | Sequence[float]) -> float:
        """``limsup |e_x| ≤ γ_Φ⁻¹ · limsup |e_z|`` for sample noise ``|v_j| ≤ v̄_j`` and no process noise.

        Parameters
        ----------
        noise_bounds : float or sequence of float
            ``v̄_j`` per group (one number: every group).
        """
        return self.gamma_phi_inv * self.inner.ultimate_bound(noise_bounds)

    @property
    def iss_gain(self) -> float:
        """``γ`` with ``limsup |e_x| ≤ γ v̄`` (bounded measurement noise, no process noise)."""
        return self.ultimate_bound(1.0)

    def rms_after(self, settle: float, p0: ArrayLike | None = None) -> float:
        """The bound on ``√E|e_x(t)|²`` for ``t ≥ settle`` (``inf`` with process noise or when not verified).

        Parameters
        ----------
        settle : float
            The time after which the RMS is taken.
        p0 : array_like, shape (n, n), optional
            Second moment of the initial error in ``x`` (default: the bound's own, read in ``z``).
        """
        if self.process_noise or not self.verified:
            return math.inf
        b = self.inner
        if p0 is None:
            return self.gamma_phi_inv * b.rms_after(settle)
        m = np.asarray(p0, dtype=float)
        if m.ndim != 2 or m.shape[0] != m.shape[1] or not np.all(np.isfinite(m)):
            raise InvalidArgumentError(f"p0: expected a finite square matrix, got shape {m.shape}")
        if self.into is not None:  # χ̃₀ = M x̃₀: E χ̃₀ᵀ P χ̃₀ = tr(P M E[x̃₀x̃₀ᵀ] Mᵀ)
            if m.shape[0] != self.into.shape[1]:
                raise InvalidArgumentError(f"p0: expected shape ({self.into.shape[1]}, {self.into.shape[1]}), "
                                           f"got {m.shape}")
            v0 = float(np.trace(b.P @ self.into @ m @ self.into.T))
        else:  # E e_zᵀ P e_z ≤ λmax(P) E|e_z|² ≤ λmax(P) γ_Φ² trace E[e_x e_xᵀ]
            v0 = float(np.linalg.eigvalsh(b.P)[-1]) * self.gamma_phi ** 2 * float(np.trace(m))
        return self.gamma_phi_inv * b.rms_from(settle, v0)

    def summary(self) -> str:
        """The bound in ``z`` and the constants that read it in ``x``."""
        return (self.inner.summary() + f"\n  in x: γ_Φ = {self.gamma_phi:.4g}, γ_Φ⁻¹ = {self.gamma_phi_inv:.4g}; bounded "
                f"measurement noise |v| ≤ v̄, no process noise: limsup |e_x| ≤ {self.iss_gain:.4g} v̄")

    def to_dict(self) -> dict[str, Any]:
        """The bound in ``z`` (``inner``) and, in ``x``, ``gamma_phi``, ``gamma_phi_inv``, ``iss_gain``."""
        iss = self.iss_gain
        return {"inner": self.inner.to_dict(), "gamma_phi": self.gamma_phi, "gamma_phi_inv": self.gamma_phi_inv,
                "iss_gain": iss if self.verified and math.isfinite(iss) else None,
                "process_noise": self.process_noise, "verified": self.verified, "budget": self.budget}
