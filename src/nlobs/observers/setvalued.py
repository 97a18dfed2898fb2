r"""Simultaneous input and state set-valued observer (seed 004, Algorithm 1), batched.

The centres follow the three-step recursion (10)-(15):

* UIE: ``d̂₁,k = M₁(z₁,k − C₁x̂_{k|k} − D₁u_k)`` (10), ``d̂₂,k−1 = M₂(z₂,k − C₂x̂_{k|k−1} − D₂u_k)`` (11),
  ``d̂_{k−1} = V₁d̂₁,k−1 + V₂d̂₂,k−1`` (12);
* TU: ``x̂_{k|k−1} = f(x̂_{k−1|k−1}) + Bu_{k−1} + G₁d̂₁,k−1`` (13), ``x̂⋆ = x̂_{k|k−1} + G₂d̂₂,k−1`` (14);
* MU: ``x̂_{k|k} = x̂⋆ + L̃(z₂,k − C₂x̂⋆ − D₂u_k)`` (15).

The radii do not depend on the data; :func:`sound_radii` computes them from
re-derived bounds (``docs/setvalued.md``), each step taking the smaller of

1. the Lyapunov bound: ``V̄_k = λ_eff V̄_{k−1} + c``, ``δ_k ≤ √(V̄_k/λ_min(P))``
   (from the certified condition (⋆) of :mod:`nlobs.synthesis.setvalued`), and
2. the triangle bound: ``δ_k ≤ θ δ_{k−1} + r + η`` with ``‖𝒜ζ + ℬπ‖ ≤ θ‖ζ‖ + r``
   from the class (e.g. ``θ = ‖𝒜‖ + L‖ℬ‖`` for Lipschitz ``φ``) and
   ``η ≥ ‖ℰω‖`` (which *includes* the ``(I − L̃C₂)ΦW w`` term the printed
   ``η`` of Theorem 5.13 omits),

and ``V̄_k ← min(V̄_k, λ_max(P) δ_k²)``. The input radius is
``δᵈ_{k−1} = θ_d δ_{k−1} + r_d + α`` with ``d̃_{k−1} = F_ζζ + F_ππ + F_ωω``.

:func:`printed_radii` evaluates Theorem 5.13 exactly as printed, for comparison
only: it is not safe (facts.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_finite_array, as_vector, positive, readonly
from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.linear.transform_ui import UITransform, ui_transform
from nlobs.synthesis.setvalued import SetValuedDesign
from nlobs.systems.discrete_ui import DiscreteUISystem

__all__ = [
    "GivenGain",
    "Radii",
    "SetValuedRun",
    "input_error_map",
    "sound_radii",
    "printed_radii",
    "run_setvalued",
]

Array = NDArray[np.float64]



@dataclass(frozen=True)
class Radii:
    """Radius sequences of the state and (one-step-delayed) input balls.

    Attributes
    ----------
    state : ndarray, shape (K + 1,)
        ``δˣ_k`` for ``k = 0..K`` (``δˣ_0 = δ_0``).
    input : ndarray, shape (K,)
        ``δᵈ_{k−1}`` for ``k = 1..K`` (the ball of ``d_{k−1}``).
    state_steady, input_steady : float
        Limits of the bounds (``inf`` when they do not converge).
    label : str
        ``"sound"`` or ``"printed"``.
    """

    state: Array
    input: Array
    state_steady: float
    input_steady: float
    label: str


def _nrm(M: Array) -> float:
    """Spectral norm, ``0`` for an empty matrix."""
    return float(np.linalg.norm(M, 2)) if M.size else 0.0


def _noise_norm(blocks: tuple[Array, Array, Array], eta_v: float, eta_w: float) -> float:
    """A bound on ``‖E₁v_{k−1} + E_w w + E₂v_k‖`` over the noise balls (the smaller of two sound bounds)."""
    E1, Ew, E2 = blocks
    a = _nrm(E1) * eta_v + _nrm(Ew) * eta_w + _nrm(E2) * eta_v
    b = _nrm(np.hstack([E1, Ew, E2])) * math.sqrt(2 * eta_v**2 + eta_w**2)
    return min(a, b)


def input_error_map(system: DiscreteUISystem, design: SetValuedDesign) -> tuple[Array, Array, tuple[Array, Array, Array]]:
    r"""``(F_ζ, F_π, (F_{v,k−1}, F_w, F_{v,k}))`` with ``d̃_{k−1} = F_ζζ + F_ππ + F_ωω``.

    From (A.2), (A.7), (A.8) with ``Δf = Aζ + π``:
    ``F_ζ = −(V₁M₁C₁ + V₂M₂C₂(A − Ψ))``, ``F_π = −V₂M₂C₂``,
    ``F_ω = [(V₂M₂C₂G₁ − V₁)M₁T₁, −V₂M₂C₂W, −V₂M₂T₂]``.

    Raises :class:`~nlobs.errors.InvalidArgumentError` when ``design`` was certified for another system.
    """
    design.certified_for.require(system)
    tr = design.transform
    V2M2C2 = tr.V2 @ tr.M2 @ tr.C2
    Fz = -(tr.V1 @ tr.M1 @ tr.C1 + V2M2C2 @ (system.A - tr.Psi))
    Fp = -V2M2C2
    Fw = ((V2M2C2 @ tr.G1 - tr.V1) @ tr.M1 @ tr.T1, -V2M2C2 @ system.W, -tr.V2 @ tr.M2 @ tr.T2)
    return Fz, Fp, Fw


def sound_radii(system: DiscreteUISystem, design: SetValuedDesign, steps: int, *,
                delta0: float | None = None) -> Radii:
    """Re-derived radius bounds (module docstring; ``docs/setvalued.md``) for ``k = 0..steps``.

    Raises :class:`~nlobs.errors.InvalidArgumentError` when ``design`` was certified for another system
    (other matrices, class or constants, or larger noise bounds: :class:`~nlobs.synthesis.setvalued.CertifiedFor`).
    """
    design.certified_for.require(system)
    K = int(steps)
    if K < 0:
        raise InvalidArgumentError(f"steps: must be >= 0, got {steps!r}")
    d0 = system.delta0 if delta0 is None else positive("delta0", delta0, allow_zero=True)
    fc = design.function_class
    evP = np.linalg.eigvalsh(design.P)
    lmin, lmax = float(evP[0]), float(evP[-1])
    Acl, Bcl, E = design.dynamics.split(design.gain)
    l, nw = system.l, system.n_w
    Eb = (E[:, :l], E[:, l:l + nw], E[:, l + nw:])
    eta = _noise_norm(Eb, system.eta_v, system.eta_w)
    th, r = fc.increment_bound(Acl, Bcl)
    Fz, Fp, Fw = input_error_map(system, design)
    thd, rd = fc.increment_bound(Fz, Fp)
    alpha = _noise_norm(Fw, system.eta_v, system.eta_w)
    # ellipsoidal variants: ‖F ζ‖ ≤ ‖F P^{-1/2}‖ √V̄ for the ζ part, the class bound for the π part
    w, Q = np.linalg.eigh(design.P)
    Pmh = Q @ np.diag(w ** -0.5) @ Q.T
    nA, nFz = float(np.linalg.norm(Acl @ Pmh, 2)), float(np.linalg.norm(Fz @ Pmh, 2))
    thp, rp = fc.increment_bound(np.zeros_like(Acl), Bcl)
    thdp, rdp = fc.increment_bound(np.zeros_like(Fz), Fp)
    dx = np.empty(K + 1)
    dd = np.empty(K)
    dx[0] = d0
    V = lmax * d0**2
    for k in range(1, K + 1):
        sv = math.sqrt(V)
        dd[k - 1] = min(thd * dx[k - 1] + rd, nFz * sv + thdp * dx[k - 1] + rdp) + alpha
        tri = min(th * dx[k - 1] + r, nA * sv + thp * dx[k - 1] + rp) + eta
        V = design.lam_eff * V + design.c
        dx[k] = min(math.sqrt(V / lmin), tri)
        V = min(V, lmax * dx[k] ** 2)
    ss_lyap = math.sqrt(design.c / ((1 - design.lam_eff) * lmin)) if design.lam_eff < 1 else math.inf
    ss_tri = (r + eta) / (1 - th) if th < 1 else math.inf
    ssx = min(ss_lyap, ss_tri)
    return Radii(readonly(dx), readonly(dd), ssx, thd * ssx + rd + alpha, "sound")


def printed_radii(system: DiscreteUISystem, L_tilde: ArrayLike, P: ArrayLike, rho: float, steps: int, *,
                  L_f: float | None = None, A_aux: ArrayLike | None = None, delta0: float | None = None) -> Radii:
    r"""Theorem 5.13 **as printed** (for comparison; not safe, see facts.md and ``docs/setvalued.md``).

    ``δ_{k,1} = √(δ₀²θ₁ᵏ + ρ²/λ_min(P) (η_w² + η_v²) Σθ₁^{i−1})`` (31), ``θ₁ = |λ_max(P) − 1|/λ_min(P)`` (32),
    ``δ_{k,2} = δ₀θ₂ᵏ + η Σθ₂^{i−1}`` (33), ``η = ‖ℜ‖η_v + ‖ΨΦW‖η_w``,
    ``ℜ = −(ΨΦG₁M₁T₁ + ΨG₂M₂T₂ + L̃T₂)``; Class I (34): ``θ₂ = (L_f + ‖Ψ‖)‖(I − L̃C₂)Φ‖``,
    ``β = ‖V₁M₁C₁ − V₂M₂C₂Ψ‖ + L_f‖V₂M₂C₂‖``; Class II (35): ``λ_max(𝒜ᵀ𝒜)`` in place of ``L_f``;
    ``α = ‖V₂M₂C₂‖η_w + [‖(V₂M₂C₂G₁ − V₁)M₁T₁‖ + ‖V₂M₂T₂‖]η_v``; (29), (30).

    Exactly one of ``L_f`` (Class I) and ``A_aux`` (Class II) must be given; as
    in the paper they describe the whole ``f``.
    """
    if (L_f is None) == (A_aux is None):
        raise InvalidArgumentError("printed_radii: give exactly one of L_f (Class I) and A_aux (Class II)")
    tr = ui_transform(system.G, system.C, system.H, system.D)
    n = system.n
    L = np.asarray(L_tilde, dtype=float).reshape(n, tr.C2.shape[0])
    P_ = np.asarray(P, dtype=float)
    ev = np.linalg.eigvalsh(0.5 * (P_ + P_.T))
    d0 = system.delta0 if delta0 is None else float(delta0)
    nrm = _nrm
    Phi, Psi = tr.Phi, tr.Psi
    theta1 = abs(ev[-1] - 1) / ev[0]
    Lc = L_f if L_f is not None else float(np.linalg.eigvalsh(np.asarray(A_aux).T @ np.asarray(A_aux))[-1])
    theta2 = (Lc + nrm(Psi)) * nrm((np.eye(n) - L @ tr.C2) @ Phi)
    Rm = -(Psi @ Phi @ tr.G1 @ tr.M1 @ tr.T1 + Psi @ tr.G2 @ tr.M2 @ tr.T2 + L @ tr.T2)
    eta = nrm(Rm) * system.eta_v + nrm(Psi @ Phi @ system.W) * system.eta_w
    V2M2C2 = tr.V2 @ tr.M2 @ tr.C2
    beta = nrm(tr.V1 @ tr.M1 @ tr.C1 - V2M2C2 @ Psi) + Lc * nrm(V2M2C2)
    alpha = nrm(V2M2C2) * system.eta_w + (nrm((V2M2C2 @ tr.G1 - tr.V1) @ tr.M1 @ tr.T1)
                                          + nrm(tr.V2 @ tr.M2 @ tr.T2)) * system.eta_v
    K = int(steps)
    k = np.arange(1, K + 1)
    geo1 = np.array([np.sum(theta1 ** np.arange(i)) for i in k])
    geo2 = np.array([np.sum(theta2 ** np.arange(i)) for i in k])
    noise2 = system.eta_w**2 + system.eta_v**2
    with np.errstate(over="ignore", invalid="ignore"):
        d1 = np.sqrt(d0**2 * theta1**k + rho**2 / ev[0] * noise2 * geo1)
        d2 = d0 * theta2**k + eta * geo2
    dx = np.concatenate([[d0], np.minimum(d1, d2)])
    dd = beta * dx[:-1] + alpha
    s1 = rho * math.sqrt(noise2 / (ev[0] * (1 - theta1))) if theta1 < 1 else math.inf
    s2 = eta / (1 - theta2) if theta2 < 1 else math.inf
    ss = min(s1, s2)
    return Radii(readonly(dx), readonly(dd), ss, beta * ss + alpha, "printed")


@dataclass(frozen=True)
class GivenGain:
    """A gain ``L̃`` that was not designed by nlobs (e.g. a published one), with its transformation.

    Runs Algorithm 1's centres without a certificate; radii must then be supplied. ``gain`` and
    ``transform`` are read as those of a :class:`~nlobs.synthesis.setvalued.SetValuedDesign`.
    """

    gain: Array
    transform: UITransform

    @classmethod
    def for_system(cls, system: DiscreteUISystem, L_tilde: ArrayLike) -> GivenGain:
        """``L̃`` (reshaped to ``(n, l − p_H)``) with the transformation of ``system``."""
        tr = ui_transform(system.G, system.C, system.H, system.D)
        L = as_finite_array("L_tilde", L_tilde).reshape(system.n, tr.C2.shape[0])
        return cls(readonly(L), tr)


@dataclass(frozen=True)
class SetValuedRun:
    """Output of :func:`run_setvalued` (batch axis first).

    Attributes
    ----------
    x_hat : ndarray, shape (B, K + 1, n)
        Centres ``x̂_{k|k}``, ``k = 0..K``.
    d_hat : ndarray, shape (B, K, p)
        Centres ``d̂_{k−1}`` of the input balls, ``k = 1..K`` (index ``j`` holds ``d̂_j``).
    radii : Radii or None
        Radii (the same for every run); ``None`` for a :class:`GivenGain` run without radii.
    """

    x_hat: Array
    d_hat: Array
    radii: Radii | None

    def contains_state(self, x_true: ArrayLike, rtol: float = 1e-9) -> NDArray[np.bool_]:
        """``(B, K + 1)``: ``‖x_k − x̂_{k|k}‖ ≤ δˣ_k`` (with a relative round-off allowance)."""
        if self.radii is None:
            raise InvalidArgumentError("contains_state: this run has no radii")
        e = np.linalg.norm(np.asarray(x_true) - self.x_hat, axis=-1)
        return e <= self.radii.state * (1 + rtol) + rtol

    def contains_input(self, d_true: ArrayLike, rtol: float = 1e-9) -> NDArray[np.bool_]:
        """``(B, K)``: ``‖d_{k−1} − d̂_{k−1}‖ ≤ δᵈ_{k−1}`` for ``d_true`` of shape ``(B, K, p)`` (``d_0..d_{K−1}``)."""
        if self.radii is None:
            raise InvalidArgumentError("contains_input: this run has no radii")
        e = np.linalg.norm(np.asarray(d_true) - self.d_hat, axis=-1)
        return e <= self.radii.input * (1 + rtol) + rtol


def run_setvalued(system: DiscreteUISystem, design: SetValuedDesign | GivenGain, y: ArrayLike, *,
                  u: ArrayLike | None = None, x0_hat: ArrayLike | None = None,
                  radii: Radii | None = None, weights: ArrayLike | None = None) -> SetValuedRun:
    """Run Algorithm 1 on measurements ``y`` of shape ``(B, K + 1, l)`` (``y_0..y_K``), batched over ``B``.

    Parameters
    ----------
    system : DiscreteUISystem
    design : SetValuedDesign or GivenGain
        Gains from :func:`nlobs.synthesis.setvalued.design_setvalued` (or a given ``L̃``).
    y : array_like, shape (B, K + 1, l)
        Measurements (finite; NaN raises :class:`~nlobs.errors.NonFiniteError`).
    u : array_like, shape (B, K + 1, m), optional
        Known inputs (zero when omitted).
    x0_hat : array_like, shape (n,) or (B, n), optional
        Initial centre (``system.x0`` when omitted).
    radii : Radii, optional
        Radii to attach (default :func:`sound_radii` for a design, none for a :class:`GivenGain`).
    weights : array_like, shape (B, K + 1, N) or (K + 1, N), optional
        Run-time LPV weights ``λ_{i,k}`` (Class III, Definition 2.4): (13) uses ``f_{k−1}``. Required
        for a design certified at the LPV vertices (``lpv="vertices"``).

    Raises
    ------
    InvalidArgumentError
        ``design`` was certified for another system (:class:`~nlobs.synthesis.setvalued.CertifiedFor`),
        or is a vertex design run without ``weights``.
    """
    if isinstance(design, SetValuedDesign):
        design.certified_for.require(system, weights_given=weights is not None)
    y_ = as_finite_array("y", y)
    if y_.ndim != 3 or y_.shape[-1] != system.l or y_.shape[1] < 1:
        raise DimensionError(f"y: expected shape (B, K + 1, {system.l}), got {y_.shape}")
    Bn, K1, _ = y_.shape
    K = K1 - 1
    if u is None:
        u_ = np.zeros((Bn, K1, system.m))
    else:
        u_ = as_finite_array("u", u)
        if u_.shape != (Bn, K1, system.m):
            raise DimensionError(f"u: expected shape {(Bn, K1, system.m)}, got {u_.shape}")
    if x0_hat is None:
        xh = np.broadcast_to(system.x0, (Bn, system.n)).copy()
    else:
        x0a = as_finite_array("x0_hat", x0_hat)
        if x0a.ndim == 1:
            x0a = as_vector("x0_hat", x0a, system.n)
        xh = np.broadcast_to(x0a, (Bn, system.n)).copy()
    tr = design.transform
    Lt = design.gain
    z1 = y_ @ tr.U1
    z2 = y_ @ tr.U2
    X = np.empty((Bn, K1, system.n))
    Dh = np.empty((Bn, K, system.p))
    X[:, 0] = xh
    d1 = (z1[:, 0] - xh @ tr.C1.T - u_[:, 0] @ tr.D1.T) @ tr.M1.T
    lam = None
    if weights is not None:
        lw = system.lpv_weights(weights)
        lam = np.broadcast_to(lw, (Bn, K1, lw.shape[-1]))
    for k in range(1, K1):
        xp = system.f(xh, None if lam is None else lam[:, k - 1]) + u_[:, k - 1] @ system.B.T + d1 @ tr.G1.T  # (13)
        d2 = (z2[:, k] - xp @ tr.C2.T - u_[:, k] @ tr.D2.T) @ tr.M2.T  # (11)
        Dh[:, k - 1] = d1 @ tr.V1.T + d2 @ tr.V2.T  # (12)
        xs = xp + d2 @ tr.G2.T  # (14)
        xh = xs + (z2[:, k] - xs @ tr.C2.T - u_[:, k] @ tr.D2.T) @ Lt.T  # (15)
        X[:, k] = xh
        d1 = (z1[:, k] - xh @ tr.C1.T - u_[:, k] @ tr.D1.T) @ tr.M1.T  # (10)
    rad = radii
    if rad is None and isinstance(design, SetValuedDesign):
        rad = sound_radii(system, design, K)
    if rad is not None and rad.state.shape != (K1,):
        raise DimensionError(f"radii: expected {K1} state radii, got {rad.state.shape}")
    return SetValuedRun(readonly(X), readonly(Dh), rad)

