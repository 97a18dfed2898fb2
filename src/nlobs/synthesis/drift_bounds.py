r"""The constants ``κ₁``, ``κ₂`` of the error bound (3.2) of Dalla Mora, Germani & Manes, from a certificate.

Theorem 3.1 (3.8) bounds the error of the drift-observability observer (3.1) by

.. math:: ‖x(t) − \hat x(t)‖ ≤ κ_1 e^{−αt} ‖x(0) − \hat x(0)‖ + κ_2 \sqrt{b_L² + b_H²}, \qquad (3.2)

with (3.17), read from the proof (3.15)–(3.16) (the scan drops the square root):
``κ₁ = γ_Φ γ_{Φ⁻¹} √cn(P)`` and ``κ₂ = γ_{Φ⁻¹} √(‖P‖ / (2α))``, where ``(K, P)`` solves (2.17)
(:mod:`nlobs.synthesis.drift_gain`) and ``γ_Φ``, ``γ_{Φ⁻¹}`` are the Lipschitz constants of
``Φ_s`` and ``Φ_s⁻¹`` (3.3) (sampled by :func:`nlobs.geometry.lipschitz.lipschitz_estimates`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import positive
from nlobs.synthesis.drift_gain import DriftGainCertificate

__all__ = ["ErrorBoundConstants", "error_bound_constants"]


@dataclass(frozen=True)
class ErrorBoundConstants:
    """``κ₁ = γ_Φ γ_{Φ⁻¹} √cn(P)``, ``κ₂ = γ_{Φ⁻¹} √(‖P‖/(2α))`` of (3.17), from (3.15)–(3.16).

    Valid (Theorem 3.1 / 3.8) when ``(K, P)`` solves (2.17) with ``γ ≥ √(γ_L² + γ_H²)``,
    ``‖u‖ ≤ μ``, and the trajectories stay where the Lipschitz constants hold; with
    sampled constants the bound is an estimate.

    Parameters
    ----------
    gamma_phi, gamma_phi_inv : float
        Lipschitz constants ``γ_Φ`` of ``Φ_s`` and ``γ_{Φ⁻¹}`` of ``Φ_s⁻¹`` (3.3).
    cond_P, norm_P : float
        Condition number ``cn(P)`` and spectral norm ``‖P‖`` of the Lyapunov matrix of (2.17).
    alpha : float
        Decay rate ``α`` of the certificate.
    kappa1, kappa2 : float
        The constants ``κ₁``, ``κ₂`` of (3.17).
    estimated : bool
        Whether the Lipschitz constants were estimated by sampling (rather than given).

    Examples
    --------
    The constants of the Vandermonde pair at ``w = 10`` for ``s = (2,)``, ``α = μ = γ = 1``, with
    ``Φ_s`` the identity (``γ_Φ = γ_{Φ⁻¹} = 1``); the bound (3.2) at ``t = 0, 1, 2`` for ``‖e(0)‖ = 1``
    and no perturbation decays like ``e^{−αt}`` from ``κ₁``:

    >>> import numpy as np
    >>> from nlobs.synthesis.drift_gain import RiccatiConstants, design_drift_gain
    >>> cert = design_drift_gain(RiccatiConstants((2,), [[0.0], [1.0]], 1.0, 1.0, 1.0), w=10.0)
    >>> k = error_bound_constants(cert, 1.0, 1.0, estimated=False)
    >>> round(k.kappa1, 2), round(k.kappa2, 3)
    (50.18, 1.584)
    >>> np.round(k.bound([0.0, 1.0, 2.0], 1.0), 3).tolist()
    [50.18, 18.46, 6.791]
    >>> float(k.bound(0.0, 0.0, b=2.0)[0]) == 2.0 * k.kappa2  # ‖e(0)‖ = 0: only the perturbation term
    True
    >>> k.describe()
    'κ₁ = γ_Φ γ_Φ⁻¹ √cn(P) = 1 · 1 · √2518 = 50.18; κ₂ = γ_Φ⁻¹ √(‖P‖/2α) = 1.584 (Lipschitz constants given)'
    """

    gamma_phi: float
    gamma_phi_inv: float
    cond_P: float
    norm_P: float
    alpha: float
    kappa1: float
    kappa2: float
    estimated: bool

    def bound(self, t: ArrayLike, e0_norm: float | ArrayLike, b: float = 0.0) -> Array:
        """``κ₁ e^{−αt} ‖e(0)‖ + κ₂ b`` (3.2), with ``b = √(b_L² + b_H²)`` (0 under H1)."""
        tt = np.asarray(t, dtype=float)
        return self.kappa1 * np.exp(-self.alpha * tt) * np.asarray(e0_norm, dtype=float)[..., None] + self.kappa2 * b

    def describe(self) -> str:
        src = "estimated by sampling" if self.estimated else "given"
        return (f"κ₁ = γ_Φ γ_Φ⁻¹ √cn(P) = {self.gamma_phi:.4g} · {self.gamma_phi_inv:.4g} · √{self.cond_P:.4g} = {self.kappa1:.4g}; "
                f"κ₂ = γ_Φ⁻¹ √(‖P‖/2α) = {self.kappa2:.4g} (Lipschitz constants {src})")

    def to_dict(self) -> dict[str, Any]:
        return {"gamma_phi": self.gamma_phi, "gamma_phi_inv": self.gamma_phi_inv, "cond_P": self.cond_P,
                "norm_P": self.norm_P, "alpha": self.alpha, "kappa1": self.kappa1, "kappa2": self.kappa2,
                "estimated": self.estimated}


def error_bound_constants(cert: DriftGainCertificate, gamma_phi: float, gamma_phi_inv: float, *,
                          estimated: bool = True) -> ErrorBoundConstants:
    """``κ₁``, ``κ₂`` of (3.17) for a verified pair and the Lipschitz constants of ``Φ_s``, ``Φ_s⁻¹``.

    Parameters
    ----------
    cert : DriftGainCertificate
        A certificate of (2.17); its ``cond_P``, ``norm_P`` and ``constants.alpha`` are used.
    gamma_phi, gamma_phi_inv : float
        Lipschitz constants of ``Φ_s`` and ``Φ_s⁻¹`` (positive).
    estimated : bool
        Whether those constants were estimated by sampling (recorded in the result).

    Returns
    -------
    ErrorBoundConstants

    Raises
    ------
    InvalidArgumentError, NonFiniteError
        ``gamma_phi`` or ``gamma_phi_inv`` is not a positive finite number.

    Examples
    --------
    For ``s = r = (2,)``, ``α = μ = γ = 1`` and the smallest Vandermonde ``w`` of Remark 2.11, with
    ``γ_Φ = 2``, ``γ_{Φ⁻¹} = 3``: ``κ₁ = 6 √cn(P)`` and ``κ₂ = 3 √(‖P‖/(2α))`` as in (3.17):

    >>> import math
    >>> from nlobs.synthesis.drift_gain import RiccatiConstants, design_drift_gain
    >>> cert = design_drift_gain(RiccatiConstants((2,), [[0.0], [1.0]], alpha=1.0, mu=1.0, gamma=1.0))
    >>> k = error_bound_constants(cert, 2.0, 3.0)
    >>> math.isclose(k.kappa1, 6.0 * math.sqrt(cert.cond_P)), math.isclose(k.kappa2, 3.0 * math.sqrt(cert.norm_P / 2.0))
    (True, True)
    >>> k.estimated, k.alpha
    (True, 1.0)
    >>> from nlobs.errors import InvalidArgumentError
    >>> try:
    ...     error_bound_constants(cert, 0.0, 1.0)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError gamma_phi: must be positive, got 0.0
    """
    gp = positive("gamma_phi", gamma_phi)
    gpi = positive("gamma_phi_inv", gamma_phi_inv)
    cn, nP, a = cert.cond_P, cert.norm_P, cert.constants.alpha
    return ErrorBoundConstants(gp, gpi, cn, nP, a, gp * gpi * math.sqrt(cn), gpi * math.sqrt(nP / (2.0 * a)), estimated)
