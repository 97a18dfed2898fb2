r"""Sound gain design for the set-valued unknown-input observer of Khajenejad & Yong,.

The error dynamics (16) of the observer (10)-(15), with ``f = A x + φ`` and
the gains of Lemma 5.1, is (derived in ``docs/setvalued.md``)

.. math::

    \tilde x_k = \Xi(\tilde L)\,[\zeta;\ \pi;\ \omega], \qquad
    \Xi(\tilde L) = \Xi_0 - \tilde L\,\Xi_c,

with ``ζ = x̃_{k−1}``, ``π = φ(x_{k−1}) − φ(x̂_{k−1})``,
``ω = (v_{k−1}, w_{k−1}, v_k)``,
``Ξ₀ = [Φ(A − Ψ), Φ, −ΦG₁M₁T₁, ΦW, −G₂M₂T₂]`` and ``Ξ_c = C₂Ξ₀ + [0, 0, 0, 0, T₂]``.

With ``V = x̃ᵀPx̃`` and the multiplier ``(M, γ)`` of the class of ``φ``, the
S-procedure condition

.. math::

    \Xi^\top P\,\Xi + \mathrm{diag}(qI - \lambda P,\ 0,\ -\Theta) + \kappa \hat M \preceq 0
    \qquad (\star)

gives ``V_k ≤ λ V_{k−1} − q‖x̃_{k−1}‖² + ωᵀΘω − κγ`` for every admissible
``π``. A Schur complement makes (⋆) an LMI in ``(P, Y = P L̃, κ, Θ)`` for fixed
``λ``:

.. math::

    \begin{bmatrix} -P & P\Xi_0 - Y\Xi_c \\ \star & \mathrm{diag}(qI-\lambda P, 0, -\Theta) + \kappa\hat M \end{bmatrix}
    \preceq -\varepsilon I.

Two objectives:

* ``"radius"`` (default): ``q = 0``, ``Θ = diag(θ₁I, θ_wI, θ₂I)``, ``P ⪰ I``;
  minimise the steady-state bound ``c/(1 − λ)`` on ``V`` with
  ``c = (θ₁ + θ₂)η_v² + θ_wη_w² − κγ``; ``λ`` is found by bisection (smallest
  feasible) and a golden-section search, on one problem compiled with
  ``cp.Parameter``.
* ``"hinf"``: ``q = 1``, ``λ = 1``, ``Θ = ρ² diag(I/2, I, I/2)`` — the
  ℓ₂-gain bound of Definition 5.9 / Theorem 5.10 (needs ``γ ≥ 0``);
  minimise ``ρ²``.

For :class:`~nlobs.systems.discrete_ui.LPV` the condition is imposed at each
vertex ``π = Aᵢζ`` (polytopic, no multiplier).

Every design is re-verified without the solver: ``P ≻ 0``; the exact condition
(⋆) recomputed from the returned ``P``, ``L̃``, ``κ``, ``Θ``; the spectral
radius of every linear member ``(I − L̃C₂)Φ(A + K − Ψ)`` of the class against
``√λ``; and, for ``"hinf"``, the H∞ norm of those linear instances by
:func:`nlobs.linear.norms.hinf_norm` against ``ρ``. (⋆) and ``P ≻ 0`` are checked with no
allowance; the spectral-radius and H∞ checks (consequences of (⋆), computed by a non-symmetric
eigensolver and a bisection) allow a relative ``1e-7``. A failed check raises
:class:`~nlobs.errors.CertificateError` (after trying the line search's other solved ``λ`` in order
of cost).

The paper's printed LMIs (18), (26)-(28) are *not* a design of the library: they are not sufficient
(measured in ``docs/setvalued.md``); the reading room has them for comparison
(:mod:`nlobs.papers.khajenejad_yong_printed`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from nlobs._lazy import LazyModule
from nlobs._typing import Array
from nlobs._validate import as_count, as_finite_array, as_square, in_range, positive, readonly
from nlobs.errors import CertificateError, DesignInfeasible, DimensionError, InvalidArgumentError
from nlobs.linear.norms import hinf_norm
from nlobs.linear.transform_ui import (
    StructuralReport,
    UITransform,
    require_structure,
    structural_check,
    structure_inputs,
    ui_transform,
)
from nlobs.checks import Check, CheckKind
from nlobs.synthesis.certificate import CertificateMixin, checks_dict
from nlobs.synthesis.lmi import Solver, as_enum, as_solver, max_eig, require_lmi_size, solve
from nlobs.systems.discrete_ui import LPV, DiscreteUISystem, FunctionClass, Lipschitz

cp = LazyModule("cvxpy")  # imported by the first problem built (see nlobs._lazy)

__all__ = [
    "SetValuedObjective",
    "LPVMode",
    "CertifiedFor",
    "ErrorDynamics",
    "SetValuedDesign",
    "error_dynamics",
    "design_setvalued",
    "verify_setvalued",
]


class SetValuedObjective(str, Enum):
    """What :func:`design_setvalued` optimises.

    Examples
    --------
    A linear plant (``γ = 0``) with three states, two outputs and one unknown input: the ``"hinf"``
    design bounds the ℓ₂ gain of Definition 5.9 by ``ρ``, which the H∞ norm of the linear error
    dynamics (computed independently) does not exceed, and contracts by ``λ_eff = 1 − 1/λ_max(P)``;
    the ``"radius"`` design (the default) bounds the steady radius, here at a fixed ``λ``:

    >>> import numpy as np
    >>> from nlobs.systems.timebase import Discrete
    >>> A = np.array([[0.9, 0.2, 0.0], [0.0, 0.8, 0.3], [0.1, 0.0, 1.05]])
    >>> system = DiscreteUISystem(A, [[1.0], [0.0], [0.5]], [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], [[0.0], [0.2]],
    ...                           function_class=Lipschitz(0.0, 3), eta_w=0.05, eta_v=0.02, time=Discrete(1.0))
    >>> hinf = design_setvalued(system, objective="hinf")
    >>> hinf.objective, hinf.verified, hinf.lam, round(hinf.rho, 1)
    (<SetValuedObjective.HINF: 'hinf'>, True, 1.0, 5.2)
    >>> bool(hinf.hinf_linear[0] <= hinf.rho * (1 + 1e-7)), bool(hinf.lam_eff < 1)
    (True, True)
    >>> radius = design_setvalued(system, lam=0.5)
    >>> radius.objective.value, radius.rho, radius.verified, bool(np.isfinite(radius.steady_radius))
    ('radius', None, True, True)
    """

    RADIUS = "radius"
    """Smallest steady-state bound on ``V`` (hence on the radius), with a line search over ``λ``."""
    HINF = "hinf"
    """Smallest ℓ₂ gain ``ρ`` from the noises to the error (Definition 5.9)."""


class LPVMode(str, Enum):
    """How a Class III (LPV) system is designed (docs/setvalued.md, "Soundness conditions")."""

    VERTICES = "vertices"
    """One condition (⋆) per vertex ``π = Aᵢζ``, no multiplier. Sound only when plant and observer use
    the **same run-time weights** ``λ_k`` (``simulate(..., weights=)``, ``run_setvalued(..., weights=)``),
    so that ``π = Σλᵢ Aᵢ ζ``; :func:`~nlobs.observers.setvalued.run_setvalued` refuses such a design
    without ``weights``."""
    LIPSCHITZ = "lipschitz"
    """The Lipschitz multiplier with ``σ̃ = maxᵢ ‖Aᵢ‖`` (Proposition 2.16): sound when the observer
    evaluates the plant's own ``φ`` (no weights), given ``‖φ(x) − φ(x̂)‖ ≤ σ̃ ‖x − x̂‖``."""


def _class_arrays(fc: FunctionClass) -> tuple[str, tuple[float, ...], tuple[Array, ...]]:
    if isinstance(fc, LPV):
        return "LPV", (), fc.constituents
    M, g = fc.multiplier()
    return type(fc).__name__, (float(g),), (M,)


def _same_class(a: FunctionClass, b: FunctionClass) -> bool:
    ka, kb = _class_arrays(a), _class_arrays(b)
    return (ka[0] == kb[0] and ka[1] == kb[1] and len(ka[2]) == len(kb[2])
            and all(x.shape == y.shape and np.array_equal(x, y) for x, y in zip(ka[2], kb[2])))


def effective_class(system: DiscreteUISystem, lpv: LPVMode) -> FunctionClass:
    """The class the design uses: ``system.function_class``, or ``Lipschitz(σ̃)`` for LPV in :attr:`LPVMode.LIPSCHITZ`."""
    fc = system.function_class
    if isinstance(fc, LPV) and lpv is LPVMode.LIPSCHITZ:
        return Lipschitz(fc.sigma, fc.n)
    return fc


@dataclass(frozen=True, eq=False)
class CertifiedFor:
    """What a :class:`SetValuedDesign` was certified for: the increment ``c`` and the certificate hold only there.

    Attributes
    ----------
    A, G, C, H, D, W : ndarray
        The system matrices (the error dynamics (16) are built from them).
    eta_w, eta_v : float
        Noise bounds entering ``c`` (a system with smaller bounds is also covered: ``c`` grows with them).
    function_class : FunctionClass
        The class of ``φ`` used (for LPV in :attr:`LPVMode.LIPSCHITZ`, the ``Lipschitz(σ̃)`` class).
    system_class : FunctionClass
        The system's own class.
    lpv : LPVMode or None
        For Class III, how it was designed.
    """

    A: Array
    G: Array
    C: Array
    H: Array
    D: Array
    W: Array
    eta_w: float
    eta_v: float
    function_class: FunctionClass
    system_class: FunctionClass
    lpv: LPVMode | None

    @classmethod
    def of(cls, system: DiscreteUISystem, lpv: LPVMode) -> CertifiedFor:
        is_lpv = isinstance(system.function_class, LPV)
        return cls(system.A, system.G, system.C, system.H, system.D, system.W, system.eta_w, system.eta_v,
                   effective_class(system, lpv), system.function_class, lpv if is_lpv else None)

    def mismatches(self, system: DiscreteUISystem) -> list[str]:
        """What differs between ``system`` and the certified one (empty when the certificate applies)."""
        out = []
        for k in ("A", "G", "C", "H", "D", "W"):
            a, b = getattr(self, k), getattr(system, k)
            if a.shape != b.shape or not np.array_equal(a, b):
                out.append(f"{k} differs")
        for k in ("eta_w", "eta_v"):
            if getattr(system, k) > getattr(self, k):
                out.append(f"{k} = {getattr(system, k):g} exceeds the certified {getattr(self, k):g}")
        if not _same_class(self.system_class, system.function_class):
            out.append(f"function class {system.function_class.label} differs from the certified "
                       f"{self.system_class.label} (or its constants)")
        return out

    def require(self, system: DiscreteUISystem, *, weights_given: bool | None = None) -> None:
        """Raise :class:`~nlobs.errors.InvalidArgumentError` unless the certificate applies to ``system``.

        ``weights_given=False`` also refuses a :attr:`LPVMode.VERTICES` design: it needs run-time weights.
        """
        bad = self.mismatches(system)
        if bad:
            raise InvalidArgumentError(
                "design: certified for another system (" + "; ".join(bad) + "): the certificate and the increment "
                "c hold only for the system it was designed for; redesign with design_setvalued(system)")
        if weights_given is False and self.lpv is LPVMode.VERTICES:
            raise InvalidArgumentError(
                "weights: this Class III design was certified at the LPV vertices, which assumes that the observer "
                "uses the plant's run-time weights (pi = sum λ_i A_i ζ); pass weights= to run_setvalued, or design "
                "with lpv='lipschitz' to run the observer on the plant's own φ")


@dataclass(frozen=True)
class ErrorDynamics:
    r"""Matrices of the error dynamics (16) in the split form used for the design.

    ``x̃_k = (Ξ₀ − L̃ Ξ_c) [ζ; π; ω]`` with ``ω = (v_{k−1}, w_{k−1}, v_k)``.

    Attributes
    ----------
    Xi0 : ndarray, shape (n, 2n + 2l + n_w)
    Xic : ndarray, shape (l − p_H, 2n + 2l + n_w)
    n, l, n_w : int
    transform : UITransform

    Examples
    --------
    A linear plant with three states and one unknown input: ``Ξ(L̃)`` of a designed gain, split into
    its ``ζ``, ``π`` and ``ω`` columns; the ``ζ`` block ``𝒜`` is the error matrix whose spectral radius
    the design certifies (the only linear member of the class, ``γ = 0``, is ``K = 0``):

    >>> import numpy as np
    >>> from nlobs.systems.timebase import Discrete
    >>> A = np.array([[0.9, 0.2, 0.0], [0.0, 0.8, 0.3], [0.1, 0.0, 1.05]])
    >>> system = DiscreteUISystem(A, [[1.0], [0.0], [0.5]], [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], [[0.0], [0.2]],
    ...                           function_class=Lipschitz(0.0, 3), eta_w=0.05, eta_v=0.02, time=Discrete(1.0))
    >>> design = design_setvalued(system, lam=0.5)
    >>> dyn = design.dynamics
    >>> Acl, Bcl, E = dyn.split(design.gain)
    >>> Acl.shape, Bcl.shape, E.shape  # ω = (v_{k−1}, w_{k−1}, v_k): 2 + 3 + 2 columns
    ((3, 3), (3, 3), (3, 7))
    >>> bool(np.isclose(max(abs(np.linalg.eigvals(Acl))), design.spectral_radii[0]))
    True
    >>> bool(design.spectral_radii[0] <= np.sqrt(design.lam))
    True
    >>> bool(np.array_equal(dyn.closed_loop(np.zeros_like(design.gain)), dyn.Xi0))  # L̃ = 0: Ξ₀
    True
    """

    Xi0: Array
    Xic: Array
    n: int
    l: int  # noqa: E741
    n_w: int
    transform: UITransform

    def closed_loop(self, L_tilde: Array) -> Array:
        """``Ξ(L̃) = Ξ₀ − L̃ Ξ_c``."""
        return self.Xi0 - L_tilde @ self.Xic

    def split(self, L_tilde: Array) -> tuple[Array, Array, Array]:
        """``(𝒜, ℬ, ℰ)``: the ``ζ``, ``π`` and ``ω`` columns of ``Ξ(L̃)``."""
        X = self.closed_loop(L_tilde)
        n = self.n
        return X[:, :n], X[:, n:2 * n], X[:, 2 * n:]


def error_dynamics(system: DiscreteUISystem, transform: UITransform | None = None) -> ErrorDynamics:
    """Build ``Ξ₀`` and ``Ξ_c`` of the error dynamics (16) for ``system`` (see module docstring).

    Parameters
    ----------
    system : DiscreteUISystem
        The discrete-time system with unknown inputs.
    transform : UITransform, optional
        The transformation of Appendix A.1; default :func:`~nlobs.linear.transform_ui.ui_transform`
        of ``system``'s ``G, C, H, D``.

    Returns
    -------
    ErrorDynamics

    Examples
    --------
    A linear plant with three states, two outputs (``l = 2``), one unknown input, ``W = I``
    (``n_w = 3``): ``Ξ₀`` has ``2n + 2l + n_w = 13`` columns, and its ``ζ`` and ``π`` blocks are
    ``Φ(A − Ψ)`` and ``Φ`` of the transformation (Appendix A.1); one output is left for the gain:

    >>> import numpy as np
    >>> from nlobs.systems.timebase import Discrete
    >>> A = np.array([[0.9, 0.2, 0.0], [0.0, 0.8, 0.3], [0.1, 0.0, 1.05]])
    >>> system = DiscreteUISystem(A, [[1.0], [0.0], [0.5]], [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], [[0.0], [0.2]],
    ...                           function_class=Lipschitz(0.0, 3), eta_w=0.05, eta_v=0.02, time=Discrete(1.0))
    >>> dyn = error_dynamics(system)
    >>> dyn.Xi0.shape, dyn.Xic.shape, (dyn.n, dyn.l, dyn.n_w)
    ((3, 13), (1, 13), (3, 2, 3))
    >>> tr = dyn.transform
    >>> bool(np.allclose(dyn.Xi0[:, :3], tr.Phi @ (A - tr.Psi))), bool(np.allclose(dyn.Xi0[:, 3:6], tr.Phi))
    (True, True)
    """
    tr = ui_transform(system.G, system.C, system.H, system.D) if transform is None else transform
    n, l, nw = system.n, system.l, system.n_w
    Phi, Psi = tr.Phi, tr.Psi
    Xi0 = np.hstack([Phi @ (system.A - Psi), Phi, -Phi @ tr.G1 @ tr.M1 @ tr.T1, Phi @ system.W,
                     -tr.G2 @ tr.M2 @ tr.T2])
    q = tr.C2.shape[0]
    Xi1 = np.hstack([np.zeros((q, 2 * n + l + nw)), tr.T2])
    Xic = tr.C2 @ Xi0 + Xi1
    return ErrorDynamics(Xi0, Xic, n, l, nw, tr)


@dataclass(frozen=True, eq=False)
class SetValuedDesign(CertificateMixin):
    r"""A verified gain ``L̃`` for the observer (10)-(15) with its Lyapunov certificate (a :class:`~nlobs.synthesis.certificate.Certificate`).

    Attributes
    ----------
    objective : SetValuedObjective
    gain : ndarray, shape (n, l − p_H)
        Measurement-update gain ``L̃`` of (15) (``L = L̃ U₂ᵀ``).
    P : ndarray, shape (n, n)
        Lyapunov matrix.
    kappa : float
        S-procedure multiplier weight (``0`` for LPV vertices).
    lam : float
        Contraction factor ``λ`` of (⋆) (``1`` for ``"hinf"``).
    q : float
        Weight of ``‖x̃‖²`` in (⋆) (``1`` for ``"hinf"``, else ``0``).
    theta : tuple of float
        ``(θ₁, θ_w, θ₂)``, the noise weights ``Θ``.
    rho : float or None
        ℓ₂-gain bound ``ρ`` (``"hinf"`` only).
    lam_eff : float
        ``V_k ≤ lam_eff V_{k−1} + c`` (``λ − q/λ_max(P)``).
    c : float
        ``(θ₁ + θ₂)η_v² + θ_wη_w² − κγ``, the per-step increment bound of ``V``.
    steady_radius : float
        ``√(c / ((1 − lam_eff) λ_min(P)))``, the limit of the Lyapunov radius bound.
    spectral_radii : tuple of float
        Of ``(I − L̃C₂)Φ(A + K − Ψ)`` for the class's linear members ``K``.
    hinf_linear : tuple of float
        H∞ norms (scaled noise → error) of those linear instances.
    checks : tuple of Check
        Independent re-verification.
    dynamics : ErrorDynamics
    structure : StructuralReport
    solver : Solver
    solver_status : str
    margin : float
    seconds : float
    solves : int
        Number of SDP solves (one compiled problem).
    certified_for : CertifiedFor
        The system data the certificate holds for (checked by the observer's runners).

    Examples
    --------
    The flexible-joint robot of Khajenejad & Yong, Sec. 6.1, designed at ``λ = 0.98``: ``V_k ≤ λ V_{k−1} + c``
    gives the steady radius ``√(c / ((1 − λ) λ_min(P)))``; the certificate holds for this system only:

    >>> import dataclasses, math
    >>> import numpy as np
    >>> from nlobs.systems.modelfile import load_discrete_ui
    >>> system = load_discrete_ui("khajenejad-6-1")
    >>> d = design_setvalued(system, lam=0.98)
    >>> d.verified, d.lam, d.q, d.lam_eff, d.gain.shape, d.P.shape
    (True, 0.98, 0.0, 0.98, (4, 1), (4, 4))
    >>> math.isclose(d.steady_radius, math.sqrt(d.c / ((1 - d.lam_eff) * np.linalg.eigvalsh(d.P)[0])))
    True
    >>> d.certified_for.mismatches(system)
    []
    >>> d.certified_for.mismatches(dataclasses.replace(system, eta_v=1.0))
    ['eta_v = 1 exceeds the certified 0.1']
    """

    objective: SetValuedObjective
    gain: Array
    P: Array
    kappa: float
    lam: float
    q: float
    theta: tuple[float, float, float]
    rho: float | None
    lam_eff: float
    c: float
    steady_radius: float
    spectral_radii: tuple[float, ...]
    hinf_linear: tuple[float, ...]
    checks: tuple[Check, ...]
    dynamics: ErrorDynamics
    structure: StructuralReport
    solver: Solver
    solver_status: str
    margin: float
    seconds: float
    solves: int
    certified_for: CertifiedFor

    @property
    def function_class(self) -> FunctionClass:
        """The class whose multiplier (or vertices) the certificate uses."""
        return self.certified_for.function_class

    @property
    def transform(self) -> UITransform:
        return self.dynamics.transform

    def summary(self) -> str:
        """Multi-line report of the design and its checks."""
        lines = [
            f"set-valued observer design ({self.objective.value}), solver {self.solver.value} "
            f"({self.solver_status}), {self.solves} solves, {self.seconds:.2f} s",
            f"  L~ = {np.array2string(self.gain.ravel(), precision=5)}",
            f"  λ = {self.lam:.6g}, λ_eff = {self.lam_eff:.6g}, κ = {self.kappa:.4g}, c = {self.c:.4g}, "
            f"steady radius ≤ {self.steady_radius:.5g}" + (f", ρ = {self.rho:.5g}" if self.rho is not None else ""),
            f"  function class used: {self.function_class.label}"
            + (f" (Class III design: {self.certified_for.lpv.value})" if self.certified_for.lpv else ""),
            "  spectral radii of linear members: " + ", ".join(f"{r:.5g}" for r in self.spectral_radii),
        ]
        lines += ["  " + c.summary() for c in self.checks]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view (the ``"design"`` of the JSON report of ``nlobs design setvalued``; ``"L_tilde"``
        and ``"gain"`` hold the same gain)."""
        return {
            "objective": self.objective.value, "L_tilde": self.gain.tolist(), "gain": self.gain.tolist(),
            "P": self.P.tolist(), "lambda": self.lam, "lambda_eff": self.lam_eff, "kappa": self.kappa, "q": self.q,
            "c": self.c, "theta": list(self.theta), "rho": self.rho, "steady_radius": self.steady_radius,
            "spectral_radii": list(self.spectral_radii), "hinf_linear": list(self.hinf_linear),
            "solver": self.solver.value, "solver_status": self.solver_status, "margin": self.margin,
            "solves": self.solves, "seconds": self.seconds, "function_class_used": self.function_class.label,
            "lpv_design": self.certified_for.lpv.value if self.certified_for.lpv else None,
            "checks": checks_dict(self.checks), "verified": self.verified,
        }


# --------------------------------------------------------------------------- problem


def _scenarios(system: DiscreteUISystem, dyn: ErrorDynamics) -> list[tuple[Array, Array, Array | None]]:
    """``(Ξ₀, Ξ_c, M̂)`` per scenario: one with ``π`` and the multiplier, or one per LPV vertex."""
    n = dyn.n
    fc = system.function_class
    if isinstance(fc, LPV):
        out = []
        for Ai in fc.constituents:
            # substitute π = Aᵢ ζ: the ζ columns become Ξ[:, :n] + Ξ[:, n:2n] Aᵢ, π columns dropped
            def sub(X: Array, Ai: Array = Ai) -> Array:
                return np.hstack([X[:, :n] + X[:, n:2 * n] @ Ai, X[:, 2 * n:]])
            out.append((sub(dyn.Xi0), sub(dyn.Xic), None))
        return out
    M, _ = fc.multiplier()
    M11, M12, M22 = M[:n, :n], M[:n, n:], M[n:, n:]
    N = dyn.Xi0.shape[1]
    Mh = np.zeros((N, N))
    Mh[:n, :n] = M22
    Mh[:n, n:2 * n] = M12.T
    Mh[n:2 * n, :n] = M12
    Mh[n:2 * n, n:2 * n] = M11
    return [(dyn.Xi0, dyn.Xic, Mh)]


def lmi_size(system: DiscreteUISystem, transform: UITransform | None = None) -> tuple[int, tuple[int, ...]]:
    """``(scalar decision variables, sizes of the semidefinite blocks)`` of the LMI (⋆) :func:`_build` builds.

    ``P``, ``Y = P L̃`` (``n × (l − p_H)``), ``κ`` and the three weights ``Θ``; ``P ⪰ I`` (or ``⪰ εI``) and
    one block ``n + 2n + 2l + n_w`` — per LPV vertex ``n + n + 2l + n_w`` (``π`` substituted) — of (⋆).
    Counted from the dimensions and :func:`~nlobs.linear.transform_ui.ui_transform` only.
    """
    tr = ui_transform(system.G, system.C, system.H, system.D) if transform is None else transform
    n, l, nw = system.n, system.l, system.n_w
    qdim = tr.C2.shape[0]
    fc = system.function_class
    if isinstance(fc, LPV):
        blocks = [n] + [2 * n + 2 * l + nw] * len(fc.constituents)
    else:
        blocks = [n, 3 * n + 2 * l + nw]
    return n * (n + 1) // 2 + n * qdim + 4, tuple(blocks)


def _check_size(system: DiscreteUISystem, tr: UITransform) -> None:
    nvar, blocks = lmi_size(system, tr)
    require_lmi_size("set-valued LMI (⋆)", f"n = {system.n} states, l = {system.l} outputs, n_w = {system.n_w} "
                     "noise inputs", nvar, blocks, "reduce the model (fewer states, or for Class III fewer LPV vertices)")


@dataclass
class _Problem:
    prob: cp.Problem
    lam: cp.Parameter
    P: cp.Variable
    Y: cp.Variable | None
    kappa: cp.Variable
    th: cp.Variable
    obj_kind: SetValuedObjective


def _theta_diag(th: Any, l: int, nw: int) -> Any:  # noqa: E741
    return cp.diag(cp.hstack([th[0] * np.ones(l), th[1] * np.ones(nw), th[2] * np.ones(l)]))


def _build(system: DiscreteUISystem, dyn: ErrorDynamics, obj: SetValuedObjective, margin: float) -> _Problem:
    n, l, nw = dyn.n, dyn.l, dyn.n_w
    qdim = dyn.Xic.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    Y = cp.Variable((n, qdim)) if qdim else None
    kappa = cp.Variable(nonneg=True)
    th = cp.Variable(3, nonneg=True)
    lam = cp.Parameter(nonneg=True, value=0.5)
    gamma = system.function_class.gamma
    cons = []
    for Xi0, Xic, Mh in _scenarios(system, dyn):
        N = Xi0.shape[1]
        top = P @ Xi0 - (Y @ Xic if Y is not None else 0)
        nz = N - 2 * l - nw  # n (ζ) [+ n (π)]
        if obj is SetValuedObjective.HINF:
            Sz = P - np.eye(n)  # q = 1, λ = 1
            Th = cp.diag(cp.hstack([th[0] * np.ones(l), th[1] * np.ones(nw), th[0] * np.ones(l)]))
        else:
            Sz = lam * P
            Th = _theta_diag(th, l, nw)
        S = cp.bmat([[-Sz, np.zeros((n, nz - n)), np.zeros((n, N - nz))],
                     [np.zeros((nz - n, n)), np.zeros((nz - n, nz - n)), np.zeros((nz - n, N - nz))],
                     [np.zeros((N - nz, n)), np.zeros((N - nz, nz - n)), -Th]]) if nz > n else cp.bmat(
            [[-Sz, np.zeros((n, N - n))], [np.zeros((N - n, n)), -Th]])
        if Mh is not None:
            S = S + kappa * Mh
        F = cp.bmat([[-P, top], [top.T, S]])
        F = (F + F.T) / 2
        cons.append(F << -margin * np.eye(n + N))
    if obj is SetValuedObjective.HINF:
        cons.append(P >> margin * np.eye(n))
        cons.append(th[1] == 2 * th[0])  # Θ = ρ² diag(I/2, I, I/2): th[1] = ρ², th[0] = ρ²/2
        cons.append(th[2] == th[0])
        objective = cp.Minimize(th[1])
    else:
        cons.append(P >> np.eye(n))
        ev = max(system.eta_v, 1e-3 * max(system.eta_v, system.eta_w, 1.0))
        ew = max(system.eta_w, 1e-3 * max(system.eta_v, system.eta_w, 1.0))
        reg = 1e-9 * cp.trace(P)
        objective = cp.Minimize((th[0] + th[2]) * ev**2 + th[1] * ew**2 - kappa * min(gamma, 0.0) + reg)
    if isinstance(system.function_class, LPV):
        cons.append(kappa == 0)
    return _Problem(cp.Problem(objective, cons), lam, P, Y, kappa, th, obj)


@dataclass
class _Sol:
    P: Array
    L: Array
    kappa: float
    theta: tuple[float, float, float]
    lam: float
    status: str


def _solve_at(pb: _Problem, lam: float, solver: Solver, options: Mapping[str, Any] | None,
              qdim: int, n: int) -> _Sol | None:
    pb.lam.value = lam
    res = solve(pb.prob, solver, options)
    if not res.status.has_solution or pb.P.value is None:
        return None
    P = 0.5 * (pb.P.value + pb.P.value.T)
    try:
        L = np.linalg.solve(P, pb.Y.value) if pb.Y is not None else np.zeros((n, 0))
    except np.linalg.LinAlgError:
        return None
    th = tuple(float(max(t, 0.0)) for t in pb.th.value)
    return _Sol(P, L, float(max(pb.kappa.value, 0.0)), th, lam, res.raw_status)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- verification


def _condition(system: DiscreteUISystem, dyn: ErrorDynamics, P: Array, L: Array, kappa: float, lam: float,
               q: float, theta: tuple[float, float, float]) -> list[Array]:
    """The exact matrices of (⋆) recomputed from ``(P, L̃, κ, λ, Θ)``, one per scenario (must be ⪯ 0)."""
    n, l, nw = dyn.n, dyn.l, dyn.n_w
    out = []
    Thd = np.concatenate([np.full(l, theta[0]), np.full(nw, theta[1]), np.full(l, theta[2])])
    for Xi0, Xic, Mh in _scenarios(system, dyn):
        Xi = Xi0 - L @ Xic
        N = Xi.shape[1]
        S = np.zeros((N, N))
        S[:n, :n] = q * np.eye(n) - lam * P
        S[N - Thd.size:, N - Thd.size:] -= np.diag(Thd)
        if Mh is not None:
            S = S + kappa * Mh
        out.append(Xi.T @ P @ Xi + S)
    return out


def _linear_instances(system: DiscreteUISystem, dyn: ErrorDynamics, L: Array) -> list[tuple[Array, Array]]:
    """``(𝒜 + ℬK, ℰ)`` for the class's linear members ``K`` whose QC value is ``≥ 0``."""
    Acl, Bcl, E = dyn.split(L)
    return [(Acl + Bcl @ K, E) for K in system.function_class.linear_members()]


def _verify(system: DiscreteUISystem, dyn: ErrorDynamics, P: Array, L: Array, kappa: float, lam: float, q: float,
            theta: tuple[float, float, float], rho: float | None) -> tuple[list[Check], float, float,
                                                                           tuple[float, ...], tuple[float, ...]]:
    checks: list[Check] = []
    ev = np.linalg.eigvalsh(P)
    checks.append(Check.compare("P ≻ 0", -float(ev[0]), 0.0, kind=CheckKind.POSITIVITY))
    for i, Nm in enumerate(_condition(system, dyn, P, L, kappa, lam, q, theta)):
        # exactly ⪯ 0 (no tolerance): (V) is then implied without any round-off allowance
        checks.append(Check.compare(f"S-procedure condition (⋆) [{i}] (max eig)", max_eig(Nm), 0.0, kind=CheckKind.LMI,
                                    strict=False))
    lam_eff = lam - q / float(ev[-1])
    nv, nw = system.eta_v, system.eta_w
    c = (theta[0] + theta[2]) * nv**2 + theta[1] * nw**2 - kappa * system.function_class.gamma
    c = max(c, 0.0)
    radii, norms = [], []
    scale = np.concatenate([np.full(dyn.l, math.sqrt(2.0)), np.ones(dyn.n_w), np.full(dyn.l, math.sqrt(2.0))])
    for j, (Ak, E) in enumerate(_linear_instances(system, dyn, L)):
        r = float(np.max(np.abs(np.linalg.eigvals(Ak))))
        radii.append(r)
        checks.append(Check.compare(f"spectral radius of linear member {j} ≤ √λ_eff", r,
                                    math.sqrt(max(lam_eff, 0.0)) * (1 + 1e-7) + 1e-12, kind=CheckKind.SPECTRUM,
                                    strict=False))
        h = hinf_norm(Ak, E * scale, np.eye(dyn.n), np.zeros((dyn.n, E.shape[1])), discrete=True) if r < 1 else math.inf
        norms.append(float(h))
        if rho is not None:
            checks.append(Check.compare(f"H∞ norm of linear member {j} ≤ ρ", float(h), rho * (1 + 1e-7),
                                        kind=CheckKind.NORM, strict=False))
    return checks, lam_eff, c, tuple(radii), tuple(norms)


# --------------------------------------------------------------------------- public API


def _structure(system: DiscreteUISystem, tr: UITransform, given: StructuralReport | None = None) -> StructuralReport:
    """The structural check of ``system``, reusing ``given`` when it was computed for exactly these inputs."""
    members = system.function_class.linear_members()
    if given is not None and given.inputs and given.inputs == structure_inputs(
            system.A, system.G, system.C, system.H, tuple(members), tr):
        return given
    return structural_check(system.A, system.G, system.C, system.H, members=members, transform=tr)


#: The bisection for the smallest feasible ``λ`` stops once its bracket is below this fraction of ``1 − λ_min``.
LAMBDA_BRACKET = 0.02


def design_setvalued(
    system: DiscreteUISystem,
    *,
    objective: SetValuedObjective | str = SetValuedObjective.RADIUS,
    lam: float | None = None,
    solver: Solver | str = Solver.CLARABEL,
    margin: float = 1e-7,
    bisection_steps: int = 14,
    golden_steps: int = 14,
    rtol: float = 1e-3,
    solver_options: Mapping[str, Any] | None = None,
    lpv: LPVMode | str = LPVMode.VERTICES,
    structure: StructuralReport | None = None,
) -> SetValuedDesign:
    r"""Design and certify ``L̃`` for the observer (10)-(15) of Khajenejad & Yong (sound replacement of Thms. 5.4/5.10).

    Parameters
    ----------
    system : DiscreteUISystem
        The model (8) with the class of its nonlinear part and the noise bounds.
    objective : SetValuedObjective or str
        ``"radius"`` (default): minimise the steady-state radius bound with a
        search over ``λ`` (bisection for the smallest feasible ``λ``, then a
        golden-section search of ``c(λ)/(1 − λ)``); ``"hinf"``: minimise the
        ℓ₂ gain ``ρ`` (Definition 5.9), needs ``γ ≥ 0``.
    lam : float, optional
        Fix ``λ ∈ (0, 1)`` instead of searching (``"radius"`` only).
    solver : Solver or str
        Clarabel by default.
    margin : float
        Strictness margin ``ε`` of the LMI (``⪯ −εI``).
    bisection_steps, golden_steps : int
        Most iterations of the two line searches.
    rtol : float
        Early stop of the golden section: once the objective at its two inner points agrees to
        ``rtol`` (relative). The bisection stops once its bracket is below
        :data:`LAMBDA_BRACKET` of the remaining interval ``[λ_min, 1)`` (a finer ``λ_min`` only
        moves the start of the golden section).
    solver_options : mapping, optional
    lpv : LPVMode or str
        Class III only: ``"vertices"`` (default; the observer must then be run with the plant's run-time
        weights) or ``"lipschitz"`` (the ``σ̃`` multiplier; for an observer that evaluates the plant's own
        ``φ``). See :class:`LPVMode`.
    structure : StructuralReport, optional
        A structural check already computed (:func:`~nlobs.linear.transform_ui.structural_check`); reused
        only when its inputs digest matches this system and class (else recomputed).

    Returns
    -------
    SetValuedDesign
        Verified: every check passed. When the chosen ``λ`` fails the re-verification, the other
        solved candidates of the line search are verified in order of cost before giving up.

    Raises
    ------
    AssumptionViolated
        Lemma 5.1's rank condition fails (``item="lemma_5_1_rank"``), or no
        stable observer of this structure exists (``item="no_stable_observer"``:
        a linear member of the class is not strongly detectable; the evidence
        lists the offending invariant zeros and error modes).
    DesignInfeasible
        The LMI (⋆) has no solution for any ``λ < 1`` (``constraint="(⋆)"``).
    CertificateError
        The solver's answer failed the independent re-verification.
    InvalidArgumentError
        ``"hinf"`` with ``γ < 0`` (no finite ℓ₂ gain follows from the multiplier) or with ``lam``; ``lam``
        outside ``(0, 1)``; negative ``bisection_steps`` / ``golden_steps``; a ``rtol`` or ``margin`` that
        is not positive (``NonFiniteError`` when not finite).

    Examples
    --------
    The flexible-joint robot of Khajenejad & Yong, Sec. 6.1 (shipped as a model file, Class II on ``φ``):
    the ``"radius"`` design, re-verified without the solver, contracts every linear member of the class:

    >>> import math
    >>> from nlobs.systems.modelfile import load_discrete_ui
    >>> system = load_discrete_ui("khajenejad-6-1")
    >>> design = design_setvalued(system)
    >>> design.verified, design.objective.value, design.gain.shape, design.function_class.label
    (True, 'radius', (4, 1), 'Class II ((A, γ)-QC*)')
    >>> bool(max(design.spectral_radii) <= math.sqrt(design.lam) < 1 and math.isfinite(design.steady_radius))
    True
    """
    t0 = time.perf_counter()
    obj = as_enum("objective", SetValuedObjective, objective)
    slv = as_solver(solver)
    eps = positive("margin", margin)
    n_bisect = as_count("bisection_steps", bisection_steps)
    n_golden = as_count("golden_steps", golden_steps)
    rtol = positive("rtol", rtol)
    mode = as_enum("lpv", LPVMode, lpv)
    certified_for = CertifiedFor.of(system, mode)
    if certified_for.function_class is not system.function_class:
        system = dataclasses.replace(system, function_class=certified_for.function_class)
    tr = ui_transform(system.G, system.C, system.H, system.D)
    _check_size(system, tr)
    st = _structure(system, tr, structure)
    require_structure(st)
    dyn = error_dynamics(system, tr)
    gamma = system.function_class.gamma
    if obj is SetValuedObjective.HINF and lam is not None:
        raise InvalidArgumentError(f"lam: the 'hinf' objective fixes λ = 1 (with q = 1); lam={lam!r} applies to "
                                   "objective='radius' only")
    if obj is SetValuedObjective.HINF and gamma < 0:
        raise InvalidArgumentError(
            f"objective: 'hinf' needs γ ≥ 0 (got γ = {gamma:g}); with γ < 0 the multiplier leaves a constant term "
            "-κγ and no finite ℓ2 gain follows — use objective='radius'")
    if obj is SetValuedObjective.HINF and not system.function_class.linear_members():
        raise InvalidArgumentError(
            f"objective: 'hinf' needs a known linear member of the class to check the ℓ2 gain by the bounded-real "
            f"lemma, and none is known for this {system.function_class.label} multiplier (M11 is not negative "
            "definite, or K* = -M11⁻¹M12 fails [K; I]ᵀM[K; I] ⪰ 0) — use objective='radius'")
    pb = _build(system, dyn, obj, eps)
    n, qdim = dyn.n, dyn.Xic.shape[0]
    solves = 0

    def at(lv: float) -> _Sol | None:
        nonlocal solves
        solves += 1
        return _solve_at(pb, lv, slv, solver_options, qdim, n)

    if obj is SetValuedObjective.HINF:
        sol = at(1.0)
        if sol is None:
            raise DesignInfeasible("the H∞ condition (⋆) with q = 1, λ = 1 is infeasible: no quadratic Lyapunov "
                                   "function with this multiplier proves a finite ℓ2 gain", constraint="(⋆)")
        rho = math.sqrt(sol.theta[1])
        qq = 1.0
    else:
        rho, qq = None, 0.0
        if lam is not None:
            lv = in_range("lam", lam, 0.0, 1.0, lo_open=True)
            sol = at(lv)
            if sol is None:
                raise DesignInfeasible(f"the LMI (⋆) is infeasible at λ = {lv:g}", constraint="(⋆)")
        else:
            hi_l = 1.0 - 1e-6
            best = at(hi_l)
            if best is None:
                raise DesignInfeasible(
                    "the LMI (⋆) is infeasible for every λ < 1: no quadratic Lyapunov function with the class's "
                    "multiplier contracts the error dynamics (16); try a tighter class (smaller constants) or a "
                    "Class 0 multiplier that describes φ better", constraint="(⋆)")
            lo_l = 0.0
            for _ in range(n_bisect):
                if hi_l - lo_l <= LAMBDA_BRACKET * (1.0 - hi_l):
                    break
                mid = 0.5 * (lo_l + hi_l)
                s = at(mid)
                if s is None:
                    lo_l = mid
                else:
                    hi_l, best = mid, s
            lam_min = hi_l
            cache: dict[float, tuple[float, _Sol | None]] = {}

            def J(lv: float) -> float:
                if lv not in cache:
                    s = at(lv)
                    val = math.inf if s is None else _cost(system, s) / (1.0 - lv)
                    cache[lv] = (val, s)
                return cache[lv][0]

            a, b = lam_min, 1.0 - 1e-6
            gr = (math.sqrt(5.0) - 1) / 2
            x1, x2 = b - gr * (b - a), a + gr * (b - a)
            for _ in range(n_golden):
                j1, j2 = J(x1), J(x2)
                if math.isfinite(j1) and math.isfinite(j2) and abs(j1 - j2) <= rtol * min(j1, j2):
                    break
                if j1 <= j2:
                    b, x2 = x2, x1
                    x1 = b - gr * (b - a)
                else:
                    a, x1 = x1, x2
                    x2 = a + gr * (b - a)
            cands = [(v, s) for v, s in cache.values() if s is not None]
            cands.append((_cost(system, best) / (1.0 - best.lam), best))
            cands.sort(key=lambda t: t[0])
            return _first_verified(system, dyn, [s for _, s in cands], obj, 0.0, None, st, slv, eps, t0,
                                   solves, certified_for)
    return _first_verified(system, dyn, [sol], obj, qq, rho, st, slv, eps, t0, solves, certified_for)


def _first_verified(system: DiscreteUISystem, dyn: ErrorDynamics, cands: list[_Sol], obj: SetValuedObjective,
                    qq: float, rho: float | None, st: StructuralReport, slv: Solver, eps: float, t0: float,
                    solves: int, certified_for: CertifiedFor) -> SetValuedDesign:
    """The first candidate (in the given order) that passes the independent re-verification."""
    failures = []
    for sol in cands:
        lam_used = 1.0 if obj is SetValuedObjective.HINF else sol.lam
        checks, lam_eff, c, radii, norms = _verify(system, dyn, sol.P, sol.L, sol.kappa, lam_used, qq, sol.theta,
                                                   rho)
        if not all(ch.passed for ch in checks):
            bad = "; ".join(ch.summary() for ch in checks if not ch.passed)
            failures.append(f"λ = {lam_used:.6g} ('{sol.status}'): {bad}")
            continue
        evP = np.linalg.eigvalsh(sol.P)
        steady = math.sqrt(c / ((1.0 - lam_eff) * evP[0])) if lam_eff < 1 else math.inf
        return SetValuedDesign(
            objective=obj, gain=readonly(sol.L), P=readonly(sol.P), kappa=sol.kappa, lam=lam_used, q=qq, theta=sol.theta,
            rho=rho, lam_eff=lam_eff, c=c, steady_radius=steady, spectral_radii=radii, hinf_linear=norms,
            checks=tuple(checks), dynamics=dyn, structure=st, solver=slv, solver_status=sol.status, margin=eps,
            seconds=time.perf_counter() - t0, solves=solves, certified_for=certified_for,
        )
    raise CertificateError(f"the {slv.value} answer failed the independent re-verification at every solved λ "
                           f"({len(cands)} tried, in order of cost): " + " | ".join(failures))


def _cost(system: DiscreteUISystem, s: _Sol) -> float:
    return max((s.theta[0] + s.theta[2]) * system.eta_v**2 + s.theta[1] * system.eta_w**2
               - s.kappa * system.function_class.gamma, 0.0)


def verify_setvalued(system: DiscreteUISystem, L_tilde: Any, P: Any, *, kappa: float, lam: float,
                     theta: tuple[float, float, float], q: float = 0.0, rho: float | None = None,
                     strict: bool = True) -> tuple[Check, ...]:
    """Re-verify a given ``(L̃, P, κ, λ, Θ)`` against (⋆), the spectral radii and (with ``rho``) the H∞ norms.

    Used to check published gains. Returns the checks; with ``strict`` raises
    :class:`~nlobs.errors.CertificateError` when one fails.

    The scalars are those of condition (⋆) (``docs/setvalued.md`` §4): ``κ ≥ 0``, ``q ≥ 0``,
    ``Θ = (θ₁, θ_w, θ₂) ⪰ 0``, and ``λ ∈ (0, 1)`` — or ``λ = 1`` with ``q > 0`` (the ``hinf`` form,
    whose contraction is ``λ_eff = λ − q/λ_max(P) < 1``); ``rho`` positive when given.

    Parameters
    ----------
    system : DiscreteUISystem
        The discrete-time system with unknown inputs (Khajenejad & Yong, (1)).
    L_tilde : array_like
        The observer gain ``L̃`` of the transformed error dynamics (App. A.1).
    P : array_like, shape (n, n)
        The Lyapunov matrix.
    kappa, lam : float
        ``κ ≥ 0`` and ``λ`` of condition (⋆).
    theta : tuple of three floats
        ``Θ = (θ₁, θ_w, θ₂) ⪰ 0`` of (⋆).
    q : float
        ``q ≥ 0`` of the ``hinf`` form.
    rho : float, optional
        An H∞ level to check as well.
    strict : bool
        Raise when a check fails (else return the checks).

    Returns
    -------
    tuple of Check
        Every condition with its value and margin.

    Raises
    ------
    InvalidArgumentError, NonFiniteError, DimensionError
        A scalar outside its range or not finite (a ``λ ≥ 1`` with ``q = 0`` certifies no
        contraction), or a complex, non-finite or wrongly shaped ``L̃`` or ``P``.

    Examples
    --------
    Khajenejad & Yong, Sec. 6.1: a design at ``λ = 0.98`` re-verified from its numbers alone; the same
    ``P`` with no measurement update (``L̃ = 0``) fails (⋆), and the error dynamics are unstable:

    >>> import numpy as np
    >>> from nlobs.systems.modelfile import load_discrete_ui
    >>> system = load_discrete_ui("khajenejad-6-1")
    >>> d = design_setvalued(system, lam=0.98)
    >>> checks = verify_setvalued(system, d.gain, d.P, kappa=d.kappa, lam=d.lam, theta=d.theta)
    >>> [(c.name, c.passed) for c in checks]
    [('P ≻ 0', True), ('S-procedure condition (⋆) [0] (max eig)', True),
     ('spectral radius of linear member 0 ≤ √λ_eff', True)]
    >>> bad = verify_setvalued(system, np.zeros((4, 1)), d.P, kappa=d.kappa, lam=d.lam, theta=d.theta,
    ...                        strict=False)
    >>> [c.passed for c in bad], bool(bad[2].value > 1)
    ([True, False, False], True)
    """
    tr = ui_transform(system.G, system.C, system.H, system.D)
    dyn = error_dynamics(system, tr)
    shape = (system.n, dyn.Xic.shape[0])
    L = as_finite_array("L_tilde", L_tilde)
    if L.size != shape[0] * shape[1]:
        raise DimensionError(f"L_tilde: expected shape {shape}, got {L.shape}")
    L = L.reshape(shape)
    P_ = as_square("P", P, system.n)
    kv = positive("kappa", kappa, allow_zero=True)
    qv = positive("q", q, allow_zero=True)
    lv = in_range("lam", lam, 0.0, 1.0, lo_open=True, hi_open=qv == 0.0)
    th = as_finite_array("theta", theta, ndim=1)
    if th.shape != (3,) or np.any(th < 0):
        raise InvalidArgumentError(f"theta: expected three non-negative weights (θ₁, θ_w, θ₂), got {th.tolist()}")
    rv = None if rho is None else positive("rho", rho)
    checks, *_ = _verify(system, dyn, 0.5 * (P_ + P_.T), L, kv, lv, qv,
                         (float(th[0]), float(th[1]), float(th[2])), rv)
    if strict and not all(c.passed for c in checks):
        raise CertificateError("; ".join(c.summary() for c in checks if not c.passed))
    return tuple(checks)
