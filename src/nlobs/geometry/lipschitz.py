r"""Sampled Lipschitz constants of the drift-observability map (Dalla Mora, Germani & Manes, (3.3) and H1).

For an input-affine model that is drift-observable with multi-index ``s`` (Def. 2.3), the error
bound (3.2) of the observer (3.1) uses the Lipschitz constants ``γ_Φ`` of ``Φ_s`` and
``γ_{Φ⁻¹}`` of ``Φ_s⁻¹`` (3.3), and the Riccati inequality (2.17) the constant
``γ = √(γ_L² + γ_H²)`` of Assumption H1, where ``γ_L`` and ``γ_H`` are the Lipschitz constants
of ``L_s∘Φ_s⁻¹`` (2.14) and ``H_{s,r}∘Φ_s⁻¹`` (2.11). :func:`lipschitz_estimates` samples
``‖Q_s‖₂``, ``‖Q_s⁻¹‖₂`` and the ``z``-Jacobians ``(∂L_s/∂x) Q_s⁻¹``, ``(∂H_{s,r}/∂x) Q_s⁻¹`` on
a region: their maxima are estimates from below of the suprema (the mean-value argument needs a
convex region, and ``Φ_s(region)`` convex for the ``z``-side constants).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from nlobs.errors import ModelError, NonFiniteError
from nlobs.geometry.observability import (
    AffineFields,
    check_multi_index,
    input_gain_structure,
    observability_jacobian,
    output_derivative_terms,
)
from nlobs.geometry.region import Box
from nlobs.systems.codegen import compile_matrix, has_jump

__all__ = ["LipschitzEstimates", "lipschitz_estimates"]


@dataclass(frozen=True)
class LipschitzEstimates:
    """Sampled estimates of the constants of (3.3) and Assumption H1 on a region.

    All are maxima over ``samples`` seeded points of the region (estimates from below
    of the suprema; the mean-value argument needs a convex region, and ``Φ_s(region)``
    convex for the ``z``-side constants).

    Attributes
    ----------
    gamma_phi : float
        ``max ‖Q_s(x)‖₂`` — Lipschitz constant of ``Φ_s`` (``‖e_z‖ ≤ γ_Φ ‖e_x‖``).
    gamma_phi_inv : float
        ``max ‖Q_s(x)⁻¹‖₂`` — Lipschitz constant of ``Φ_s⁻¹`` (``‖e_x‖ ≤ γ_{Φ⁻¹} ‖e_z‖``).
    gamma_L : float
        ``max ‖(∂L_s/∂x) Q_s⁻¹‖₂`` — Lipschitz constant of ``L_s∘Φ_s⁻¹`` (2.14).
    gamma_H : float
        ``max (Σ_entries ‖(∂H_{ik}/∂x) Q_s⁻¹‖²)^{1/2}`` — Lipschitz constant of
        ``H_{s,r}∘Φ_s⁻¹`` in the operator norm (Frobenius bound); 0 when ``H`` is constant.
    region : Box
    samples : int
    worst_Q_inv : tuple of float
        Where ``‖Q_s⁻¹‖`` is largest.

    Examples
    --------
    The shipped pendulum (``y = θ``, ``s = r = (2,)``): ``Φ_s(x) = (θ, ω)`` is the identity, so
    ``γ_Φ = γ_{Φ⁻¹} = 1``; ``L_s = −ω/5 − 9.81 sin θ`` has gradient norm at most ``√(9.81² + 0.2²)``
    (reached at ``θ = 0``); ``H_{s,r} = L_g L_f h = 2`` is constant, so ``γ_H = 0`` and ``γ = γ_L``.

    >>> import math
    >>> import nlobs
    >>> from nlobs.geometry.observability import AffineFields
    >>> fields = AffineFields.from_model(nlobs.load_model("pendulum"))
    >>> est = lipschitz_estimates(fields, (2,), (2,), Box.unit(2), samples=200)
    >>> est.gamma_phi, est.gamma_phi_inv, est.gamma_H, est.samples
    (1.0, 1.0, 0.0, 200)
    >>> round(est.gamma_L, 2), est.gamma_L <= math.hypot(9.81, 0.2), est.gamma == est.gamma_L
    (9.81, True, True)
    >>> sorted(est.to_dict())[:4]
    ['estimated', 'gamma', 'gamma_H', 'gamma_L']
    """

    gamma_phi: float
    gamma_phi_inv: float
    gamma_L: float
    gamma_H: float
    region: Box
    samples: int
    worst_Q_inv: tuple[float, ...]

    @property
    def gamma(self) -> float:
        """``√(γ_L² + γ_H²)``, the ``γ`` of (2.17)."""
        return math.hypot(self.gamma_L, self.gamma_H)

    def to_dict(self) -> dict[str, Any]:
        return {"gamma_phi": self.gamma_phi, "gamma_phi_inv": self.gamma_phi_inv, "gamma_L": self.gamma_L,
                "gamma_H": self.gamma_H, "gamma": self.gamma, "region": [self.region.lower.tolist(), self.region.upper.tolist()],
                "samples": self.samples, "worst_Q_inv": list(self.worst_Q_inv), "estimated": True}


def lipschitz_estimates(fields: AffineFields, s: Sequence[int], r: Sequence[int | None], region: Box, *,
                        samples: int = 2000, seed: int = 0) -> LipschitzEstimates:
    """Estimate ``γ_Φ``, ``γ_{Φ⁻¹}``, ``γ_L``, ``γ_H`` by sampling ``region`` (see :class:`LipschitzEstimates`).

    Points where any of the sampled quantities is not finite are left out (``samples`` counts the rest).

    Parameters
    ----------
    fields : AffineFields
        The input-affine model's ``f``, ``g``, ``h``.
    s : sequence of int
        Multi-index of ``Φ_s`` (one entry per output, summing to ``n``).
    r : sequence of int or None
        Observation relative degrees (``None`` where undefined), for ``H_{s,r}``.
    region : Box
        Region the points are sampled from.
    samples : int, default 2000
        Number of sampled points.
    seed : int, default 0
        Seed of the random number generator that draws the points.

    Returns
    -------
    LipschitzEstimates

    Raises
    ------
    NonFiniteError
        Not one sampled point gives finite values (the model is not defined on the region).
    ModelError
        ``Φ_s``, ``L_s`` or ``H_{s,r}`` jumps (it uses ``sign``, or ``abs`` inside a derivative):
        a jump is not Lipschitz, and a Jacobian sampled away from it would hide that.

    Examples
    --------
    The Van der Pol oscillator in Liénard form, ``y = x1``: ``Q_s = [[1, 0], [1 − x1², 1]]`` is largest
    (and so is its inverse ``[[1, 0], [x1² − 1, 1]]``) at ``x1 = 0``, where its norm is the golden
    ratio ``(1 + √5)/2``; the sampled maxima approach it from below.

    >>> import nlobs
    >>> from nlobs.geometry.observability import AffineFields
    >>> fields = AffineFields.from_model(nlobs.load_model("vanderpol-lienard"))
    >>> est = lipschitz_estimates(fields, (2,), (2,), Box.unit(2), samples=200, seed=0)
    >>> golden = (1 + 5 ** 0.5) / 2
    >>> round(est.gamma_phi, 3), round(est.gamma_phi_inv, 3), round(golden, 3)
    (1.618, 1.618, 1.618)
    >>> est.gamma_phi <= golden + 1e-12, est.gamma_H
    (True, 0.0)

    A model that jumps has no Lipschitz constant:

    >>> from nlobs.systems.symbolic import SymbolicModel
    >>> m = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=["x2", "-sign(x1)"], g=[[0], [1]], h=["x1"],
    ...                                name="relay")
    >>> try:
    ...     lipschitz_estimates(AffineFields.from_model(m), (2,), (2,), Box.unit(2))
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    ModelError relay: Φ_s, L_s or H_s,r (s = [2]) jumps where an argument of sign() ...
    """
    s_ = check_multi_index(s, fields.q, fields.n)
    Q = observability_jacobian(fields, s_)
    X = sp.Matrix(fields.x)
    dL = output_derivative_terms(fields, s_).jacobian(X)
    H, _ = input_gain_structure(fields, s_, r)
    dH = sp.Matrix(list(H)).jacobian(X) if H.shape[0] * H.shape[1] else sp.zeros(0, fields.n)
    n = fields.n
    stacked = sp.Matrix(list(Q) + list(dL) + list(dH))
    if has_jump(stacked):
        raise ModelError(
            f"{fields.name}: Φ_s, L_s or H_s,r (s = {list(s_)}) jumps where an argument of sign() (or of abs() "
            "inside a derivative) crosses 0: the model is not Lipschitz there, so the constants γ of the drift "
            "design do not exist (replace sign(x) by a smooth function, e.g. tanh(x/eps))")
    fn = compile_matrix(stacked, (fields.x,), vector=True, what="Lipschitz estimates")
    pts = region.sample(samples, seed)
    with np.errstate(all="ignore"):
        v = fn(pts)
    Qv = v[:, : n * n].reshape(-1, n, n)
    dLv = v[:, n * n : n * n + dL.shape[0] * n].reshape(len(v), dL.shape[0], n)
    dHv = v[:, n * n + dL.shape[0] * n :].reshape(len(v), dH.shape[0], n)
    ok = np.all(np.isfinite(v), axis=-1)
    if not np.any(ok):
        raise NonFiniteError(
            f"{fields.name}: Q_s (s = {list(s_)}) and the z-Jacobians of L_s and H_s,r are not finite at any of the "
            f"{len(pts)} sampled points of the region {region.describe()}: the model is not defined there "
            "(choose a region where it is: `region`)")
    sv = np.linalg.svd(Qv[ok], compute_uv=False)
    inv_norm = np.where(sv[:, -1] > 0, 1.0 / np.where(sv[:, -1] > 0, sv[:, -1], 1.0), np.inf)
    Qinv = np.linalg.pinv(Qv[ok])
    gL = np.linalg.norm(dLv[ok] @ Qinv, ord=2, axis=(-2, -1)) if dL.shape[0] else np.zeros(1)
    gH = np.linalg.norm(dHv[ok] @ Qinv, axis=(-2, -1)) if dH.shape[0] else np.zeros(1)
    i = int(np.argmax(inv_norm))
    return LipschitzEstimates(float(sv[:, 0].max()), float(inv_norm[i]), float(np.max(gL)), float(np.max(gH)),
                              region, int(ok.sum()), tuple(float(a) for a in pts[ok][i]))
