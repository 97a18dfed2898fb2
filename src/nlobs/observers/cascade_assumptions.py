r"""The assumptions and sufficient bounds of the cascade/feedback observer (seed 001, Secs. 2–4).

* :func:`check_assumption4` — Assumption 4 item by item (detectability of
  ``(A, C)``; left-invertibility of ``(A, B_z, C, D_z)``; no invariant zero at the
  origin; the rank conditions on ``[B_z; D_z]`` and ``[C, D_z]``), plus the
  minimum-phase property that decides ``γ* = 0`` in Theorem 2, as a readable
  :class:`Assumption4Report`. :func:`require_assumption4` raises
  :class:`~nlobs.errors.AssumptionViolated` naming the first failed item.
* :func:`theorem1_gamma_bound` — Theorem 1: ``γ = 4α₃/(4L₂² + α₄²L₁²)``;
  :func:`theorem1_prime_gamma_bound` — the two conditions of the proof of Theorem 1'.
* :func:`quadratic_lyapunov_constants` — Assumption 1 for an observer whose error
  dynamics is ``x̃̇ = F x̃ + δΦ`` with ``‖δΦ‖ ≤ ℓ‖x̃‖`` (Thau/Rajamani-type
  observers): a quadratic ``V = x̃ᵀ P x̃`` and its constants ``α₁ … α₄`` (5)–(7).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cvxpy as cp
import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_matrix, as_square, positive
from nlobs.checks import Check, CheckKind
from nlobs.errors import (
    AssumptionViolated,
    DesignInfeasible,
    DimensionError,
    InvalidArgumentError,
)
from nlobs.linear import (
    invariant_zeros,
    is_detectable,
    minimum_phase,
    unobservable_modes,
)
from nlobs.linear.stability import BOUNDARY_TOL
from nlobs.synthesis import extended_system
from nlobs.synthesis.lmi import Solver, max_eig, solve, symmetrise

Array = NDArray[np.float64]

__all__ = [
    "ASSUMPTION4_ITEMS",
    "Assumption4Report",
    "QuadraticLyapunov",
    "check_assumption4",
    "quadratic_lyapunov_constants",
    "require_assumption4",
    "theorem1_gamma_bound",
    "theorem1_optimal_scaling",
    "theorem1_prime_gamma_bound",
]

#: Keys of the items that make up Assumption 4 (in the order they are checked).
ASSUMPTION4_ITEMS: tuple[str, ...] = (
    "rank_Bz_Dz",
    "rank_C_Dz",
    "detectable",
    "left_invertible",
    "no_zero_at_origin",
)

_EPS = float(np.finfo(float).eps)


def _fmt_c(z: complex) -> str:
    z = complex(z)
    if abs(z.imag) < 1e-12 * max(1.0, abs(z)):
        return f"{z.real:.6g}"
    return f"{z.real:.6g}{'+' if z.imag >= 0 else '-'}{abs(z.imag):.6g}j"


def _fmt_list(z: NDArray[Any]) -> str:
    return "[" + ", ".join(_fmt_c(v) for v in z) + "]" if len(z) else "none"


def _item(key: str, title: str, holds: bool, evidence: str, required: bool, values: dict[str, Any],
          kind: CheckKind = CheckKind.STRUCTURAL) -> Check:
    """One item of Assumption 4 as a :class:`~nlobs.checks.Check` (``key`` its machine name, ``title`` its name)."""
    return Check.verdict(title, holds, evidence, kind=kind, method="numeric", required=required, key=key, values=values)


@dataclass(frozen=True)
class Assumption4Report:
    """Assumption 4 of seed 001, item by item, for ``(A, B_z, C, D_z)``.

    Attributes
    ----------
    items : tuple of Check
        Every item, required ones first (:data:`ASSUMPTION4_ITEMS`), then the
        informational ``"minimum_phase"`` and ``"extended_detectable"``
        (``required=False``). Each item's ``key`` is its machine name, ``name`` says
        what is checked, ``evidence`` and ``values`` give the numbers.
    n_w, p_z, p_y : int
        Dimensions of ``w``, ``z`` and ``y``.
    zeros : ndarray of complex
        Finite invariant zeros of ``(A, B_z, C, D_z)``.
    normal_rank : int
        Normal rank of the Rosenbrock matrix (``n_w + p_z`` iff left-invertible).
    """

    items: tuple[Check, ...]
    n_w: int
    p_z: int
    p_y: int
    zeros: NDArray[np.complex128]
    normal_rank: int

    @property
    def holds(self) -> bool:
        """Whether every required item holds (Assumption 4 with the rank conditions)."""
        return all(it.passed for it in self.items if it.required)

    @property
    def failed(self) -> tuple[Check, ...]:
        """The required items that fail."""
        return tuple(it for it in self.items if it.required and not it.passed)

    @property
    def minimum_phase(self) -> bool:
        """Whether ``(A, B_z, C, D_z)`` is minimum phase: then ``γ* = 0`` (Theorem 2)."""
        return self.item("minimum_phase").passed

    @property
    def gamma_star_zero(self) -> bool:
        """Theorem 2: ``‖H‖∞`` can be made arbitrarily small iff this is True (sufficient)."""
        return self.holds and self.minimum_phase

    def item(self, key: str) -> Check:
        """The item named ``key``."""
        for it in self.items:
            if it.key == key:
                return it
        raise InvalidArgumentError(f"key: no item {key!r} (known: {[it.key for it in self.items]})")

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view (JSON-serialisable)."""
        return {
            "holds": self.holds,
            "minimum_phase": self.minimum_phase,
            "gamma_star_zero": self.gamma_star_zero,
            "n_w": self.n_w,
            "p_z": self.p_z,
            "p_y": self.p_y,
            "normal_rank": self.normal_rank,
            "zeros": [[float(z.real), float(z.imag)] for z in self.zeros],
            "items": [{**it.to_dict(), "title": it.name} for it in self.items],
        }

    def summary(self) -> str:
        """A plain-text report, one line per item (no rich markup)."""
        lines = [
            f"Assumption 4 (seed 001) for Σ2 with n_w={self.n_w}, p_z={self.p_z}, p_y={self.p_y}: "
            + ("HOLDS" if self.holds else "FAILS (" + ", ".join(it.key for it in self.failed) + ")")
        ]
        for it in self.items:
            tag = ("ok  " if it.passed else "FAIL") if it.required else ("yes " if it.passed else "no  ")
            kind = "" if it.required else " [info]"
            lines.append(f"  [{tag}] {it.name}{kind}: {it.evidence}")
        if self.holds:
            lines.append(
                "  => γ* = 0 (Theorem 2): ‖H‖∞ < γ is achievable for every γ > 0"
                if self.minimum_phase
                else "  => γ* > 0 possible (not minimum phase): Theorem 1 may not be satisfiable"
            )
        return "\n".join(lines)


def _rank_item(key: str, title: str, M: Array, want: int, what: str) -> Check:
    s = np.linalg.svd(M, compute_uv=False) if M.size else np.zeros(0)
    tol = max(M.shape, default=1) * _EPS * (float(s[0]) if s.size else 0.0) * 10.0
    r = int(np.sum(s > tol)) if s.size else 0
    smin = float(s[want - 1]) if s.size >= want > 0 else 0.0
    ok = r == want
    ev = f"rank {what} = {r} (need {want}); σ_min = {smin:.3g}" + ("" if ok else " — redundant components: redefine them")
    return _item(key, title, ok, ev, True, {"rank": r, "required_rank": want, "sigma_min": smin,
                                            "singular_values": [float(v) for v in s]}, CheckKind.RANK)


def check_assumption4(
    A: ArrayLike,
    B_z: ArrayLike,
    C: ArrayLike,
    D_z: ArrayLike | None = None,
    *,
    tol: float = BOUNDARY_TOL,
) -> Assumption4Report:
    r"""Check Assumption 4 of seed 001 item by item, with the rank conditions of Sec. 2.

    Parameters
    ----------
    A : array_like, shape (n_w, n_w)
    B_z : array_like, shape (n_w, p_z)
    C : array_like, shape (p_y, n_w)
    D_z : array_like, shape (p_y, p_z), optional
        Zero when omitted.
    tol : float
        Distance from the imaginary axis (and from the origin, for zeros) below
        which a mode or zero counts as on it.

    Returns
    -------
    Assumption4Report
        Items (required): ``rank_Bz_Dz`` — ``rank [B_z; D_z] = p_z``;
        ``rank_C_Dz`` — ``rank [C, D_z] = p_y``; ``detectable`` — ``(A, C)``
        detectable (PBH, unobservable modes listed); ``left_invertible`` —
        normal rank of ``[[sI − A, −B_z], [C, D_z]]`` equal to ``n_w + p_z``;
        ``no_zero_at_origin`` — no finite invariant zero with ``|z| ≤ tol``.
        Informational: ``minimum_phase`` (Theorem 2: ``γ* = 0``) and
        ``extended_detectable`` — ``(𝔄, ℭ)`` of (8c) detectable, which
        Assumption 4 implies (proof of Theorem 2).

    Raises
    ------
    DimensionError
        Inconsistent shapes.
    """
    A_ = as_square("A", A)
    n = A_.shape[0]
    Bz = as_matrix("B_z", B_z, (n, None))
    C_ = as_matrix("C", C, (None, n))
    pz, py = Bz.shape[1], C_.shape[0]
    Dz = np.zeros((py, pz)) if D_z is None else as_matrix("D_z", D_z, (py, pz))
    if pz == 0:
        raise DimensionError("B_z: Σ2 needs at least one input z (p_z ≥ 1)")
    if py == 0:
        raise DimensionError("C: Σ2 needs at least one measurement y (p_y ≥ 1)")
    items: list[Check] = [
        _rank_item("rank_Bz_Dz", "rank [B_z; D_z] = p_z (no redundant z)", np.vstack([Bz, Dz]), pz, "[B_z; D_z]"),
        _rank_item("rank_C_Dz", "rank [C, D_z] = p_y (independent y)", np.hstack([C_, Dz]), py, "[C, D_z]"),
    ]
    # detectability of (A, C)
    unobs = unobservable_modes(A_, C_)
    det = is_detectable(A_, C_, tol=tol)
    bad_modes = unobs[unobs.real >= -tol] if unobs.size else unobs
    ev = f"unobservable modes {_fmt_list(unobs)}"
    ev += "; all strictly stable" if det else f"; not strictly stable: {_fmt_list(bad_modes)}"
    items.append(_item("detectable", "(A, C) detectable", det, ev, True,
                       {"unobservable_modes": [[float(z.real), float(z.imag)] for z in unobs]}))
    # left-invertibility and zeros
    iz = invariant_zeros(A_, Bz, C_, Dz)
    want = n + pz
    li = iz.normal_rank == want
    items.append(_item(
        "left_invertible", "(A, B_z, C, D_z) left-invertible", li,
        f"normal rank of the Rosenbrock matrix = {iz.normal_rank} (n_w + p_z = {want})", True,
        {"normal_rank": iz.normal_rank, "required": want}, CheckKind.RANK,
    ))
    zeros = iz.zeros
    at0 = zeros[np.abs(zeros) <= tol] if zeros.size else zeros
    dist = float(np.min(np.abs(zeros))) if zeros.size else math.inf
    ok0 = at0.size == 0
    ev0 = f"finite invariant zeros {_fmt_list(zeros)}"
    ev0 += f"; closest to the origin at distance {dist:.3g}" if zeros.size else " (no finite zeros)"
    if not ok0:
        ev0 += f"; {at0.size} zero(s) at s = 0"
    items.append(_item("no_zero_at_origin", "no invariant zero at the origin", ok0, ev0, True,
                       {"zeros": [[float(z.real), float(z.imag)] for z in zeros], "min_abs_zero": dist}))
    # informational
    mp = minimum_phase(A_, Bz, C_, Dz, tol=tol)
    items.append(_item(
        "minimum_phase", "(A, B_z, C, D_z) minimum phase (Theorem 2: γ* = 0)", mp.passed, mp.evidence, False,
        {"unstable_zeros": [[float(z.real), float(z.imag)] for z in mp.values["unstable_zeros"]]},
    ))
    ext = extended_system(A_, Bz, C_, Dz)
    edet = is_detectable(ext.A, ext.C, tol=tol)
    eun = unobservable_modes(ext.A, ext.C)
    items.append(_item(
        "extended_detectable", "(𝔄, ℭ) of (8c) detectable (implied by Assumption 4)", edet,
        f"unobservable modes of the extended pair {_fmt_list(eun)}", False,
        {"unobservable_modes": [[float(z.real), float(z.imag)] for z in eun]},
    ))
    z_ro = np.array(zeros, dtype=complex)
    z_ro.setflags(write=False)
    return Assumption4Report(tuple(items), n, pz, py, z_ro, int(iz.normal_rank))


def require_assumption4(
    A: ArrayLike, B_z: ArrayLike, C: ArrayLike, D_z: ArrayLike | None = None, *, tol: float = BOUNDARY_TOL
) -> Assumption4Report:
    """Like :func:`check_assumption4`, but raise if a required item fails.

    Raises
    ------
    AssumptionViolated
        Naming the first failed item (``.item``) with its evidence, e.g.
        ``"Assumption 4 fails: no invariant zero at the origin — finite invariant zeros [0] ..."``.
    """
    rep = check_assumption4(A, B_z, C, D_z, tol=tol)
    if not rep.holds:
        it = rep.failed[0]
        more = f" (also failing: {', '.join(f.key for f in rep.failed[1:])})" if len(rep.failed) > 1 else ""
        raise AssumptionViolated(
            f"Assumption 4 (seed 001) fails: {it.name} [{it.key}] — {it.evidence}{more}",
            item=it.key,
            evidence=it.evidence,
        )
    return rep


# --------------------------------------------------------------------------- Theorem 1


def _constants(alpha3: float, alpha4: float, L1: float, L2: float) -> tuple[float, float, float, float]:
    return (
        positive("alpha3", alpha3),
        positive("alpha4", alpha4),
        positive("L1", L1),
        positive("L2", L2),
    )


def theorem1_gamma_bound(alpha3: float, alpha4: float, L1: float, L2: float) -> float:
    r"""Theorem 1 of seed 001: ``γ = 4α₃ / (4L₂² + α₄²L₁²)``.

    If ``𝔄 − Kℭ`` is Hurwitz and ``‖H‖∞ < γ`` the error dynamics (12) is
    globally exponentially stable.

    Parameters
    ----------
    alpha3, alpha4 : float
        Constants of Assumption 1, (6) and (7) (positive).
    L1, L2 : float
        Lipschitz constants of Assumptions 2 and 3 (positive).

    Returns
    -------
    float

    Raises
    ------
    InvalidArgumentError, NonFiniteError
        A constant is not a positive finite number.

    Notes
    -----
    ``V`` may be scaled by any ``c > 0`` (``α₃, α₄ → cα₃, cα₄``); the bound is
    largest for ``c* = 2L₂/(α₄L₁)``, where it equals ``α₃/(α₄L₁L₂)``
    (:func:`theorem1_optimal_scaling`).
    """
    a3, a4, l1, l2 = _constants(alpha3, alpha4, L1, L2)
    return 4.0 * a3 / (4.0 * l2**2 + a4**2 * l1**2)


def theorem1_optimal_scaling(alpha3: float, alpha4: float, L1: float, L2: float) -> tuple[float, float]:
    r"""Best scaling ``c*`` of ``V`` for Theorem 1 and the bound it gives.

    ``γ(c) = 4cα₃/(4L₂² + c²α₄²L₁²)`` is maximal at ``c* = 2L₂/(α₄L₁)`` with
    ``γ(c*) = α₃/(α₄L₁L₂)``; the ratio ``α₃/α₄`` is scale-invariant.

    Returns
    -------
    (c_star, gamma) : tuple of float
    """
    a3, a4, l1, l2 = _constants(alpha3, alpha4, L1, L2)
    c = 2.0 * l2 / (a4 * l1)
    return c, theorem1_gamma_bound(c * a3, c * a4, l1, l2)


def theorem1_prime_gamma_bound(
    alpha3: float, alpha4: float, L1: float, L2: float, *, optimise_scaling: bool = True
) -> float:
    r"""The supremum of the ``γ`` allowed by the proof of Theorem 1' (feedback case).

    The proof (Appendix B) needs ``γ < α₃/L₂²`` and
    ``γ < 4(α₃ − γL₂²)(1 − γ²L₂²)/(α₄²L₁²)``. The left side grows and the right
    side shrinks with ``γ``, so the admissible set is an interval ``(0, γ̄)``;
    ``γ̄`` is found by bisection.

    Parameters
    ----------
    alpha3, alpha4, L1, L2 : float
        Constants of Assumptions 1, 2', 3' (positive).
    optimise_scaling : bool
        Also maximise over the scaling ``V → cV`` (``α₃, α₄ → cα₃, cα₄``), a
        one-dimensional search; ``False`` uses the constants as given.

    Returns
    -------
    float
        ``γ̄`` (any ``0 < γ < γ̄`` satisfies both conditions).
    """
    a3, a4, l1, l2 = _constants(alpha3, alpha4, L1, L2)

    def sup_gamma(c: float) -> float:
        def ok(g: float) -> bool:
            return g < c * a3 / l2**2 and g * (c * a4 * l1) ** 2 < 4 * (c * a3 - g * l2**2) * (1 - g**2 * l2**2)

        hi = min(c * a3 / l2**2, 1.0 / l2)
        lo = 0.0
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if ok(mid):
                lo = mid
            else:
                hi = mid
        return lo

    if not optimise_scaling:
        return sup_gamma(1.0)
    # bounded scalar search on log c
    res = scipy.optimize.minimize_scalar(lambda lc: -sup_gamma(math.exp(lc)), bounds=(-30.0, 30.0), method="bounded",
                                         options={"xatol": 1e-10})
    return max(sup_gamma(math.exp(float(res.x))), sup_gamma(1.0))


# --------------------------------------------------------------------------- Assumption 1


@dataclass(frozen=True, eq=False)
class QuadraticLyapunov:
    r"""A quadratic Lyapunov function ``V = x̃ᵀ P x̃`` and the constants of Assumption 1.

    Attributes
    ----------
    P : ndarray, shape (n, n)
        Symmetric positive definite.
    alpha1, alpha2 : float
        ``λ_min(P)``, ``λ_max(P)``: (5).
    alpha3 : float
        ``V̇ ≤ −α₃‖x̃‖²`` (6) for every perturbation with ``‖δΦ‖ ≤ ℓ‖x̃‖``.
    alpha4 : float
        ``‖∂V/∂x̃‖ = 2‖P x̃‖ ≤ 2λ_max(P)‖x̃‖`` (7).
    tau : float
        S-procedure multiplier certifying ``α₃``.
    lipschitz : float
        ``ℓ``.
    certificate_max_eig : float
        Largest eigenvalue of the S-procedure block recomputed in NumPy (≤ 0).
    """

    P: Array
    alpha1: float
    alpha2: float
    alpha3: float
    alpha4: float
    tau: float
    lipschitz: float
    certificate_max_eig: float

    @property
    def ratio(self) -> float:
        """``α₃/α₄`` (invariant under scaling of ``V``)."""
        return self.alpha3 / self.alpha4

    def derivative_bound(self, F: ArrayLike, x_err: ArrayLike, dphi: ArrayLike) -> Array:
        """``V̇ = 2x̃ᵀP(F x̃ + δΦ)`` for batches (to check (6) on samples)."""
        xe = np.asarray(x_err, dtype=float)
        rhs = xe @ np.asarray(F, dtype=float).T + np.asarray(dphi, dtype=float)
        return 2.0 * np.einsum("...i,ij,...j->...", xe, self.P, rhs)


def quadratic_lyapunov_constants(
    F: ArrayLike,
    lipschitz: float,
    *,
    solver: Solver | str = Solver.CLARABEL,
) -> QuadraticLyapunov:
    r"""Assumption 1 for ``x̃̇ = F x̃ + δΦ``, ``‖δΦ‖ ≤ ℓ‖x̃‖``: a quadratic ``V`` and ``α₁…α₄``.

    This is the error dynamics of an observer ``x̂̇ = A x̂ + Φ(x̂) + L(z − H x̂)`` for
    ``ẋ = A x + Φ(x)`` with a globally ``ℓ``-Lipschitz ``Φ`` (Thau 1973; Rajamani
    1998), ``F = A − L H``, ``δΦ = Φ(x) − Φ(x̂)``.

    With ``V = x̃ᵀ P x̃`` and the S-procedure (``τ(ℓ²‖x̃‖² − ‖δΦ‖²) ≥ 0``),
    ``V̇ + α₃‖x̃‖² ≤ [x̃; δΦ]ᵀ [[FᵀP + PF + (α₃ + τℓ²) I, P], [P, −τ I]] [x̃; δΦ]``.
    The SDP maximises ``α₃`` subject to that block ``⪯ 0`` and ``εI ⪯ P ⪯ I``
    (the normalisation fixes ``λ_max(P) ≤ 1``, so it maximises the
    scale-invariant ``α₃/α₄``). The returned ``α₃`` is recomputed in NumPy from
    ``P`` and ``τ`` (largest ``α`` with the block ``⪯ 0``), never taken from the
    solver.

    Parameters
    ----------
    F : array_like, shape (n, n)
        Linear part of the error dynamics (must be Hurwitz).
    lipschitz : float
        ``ℓ ≥ 0``.
    solver : Solver or str

    Returns
    -------
    QuadraticLyapunov

    Raises
    ------
    DesignInfeasible
        No quadratic ``V`` proves (6) (e.g. ``ℓ ≥ 1/‖(sI − F)⁻¹‖∞``).
    """
    F_ = as_square("F", F)
    n = F_.shape[0]
    ell = positive("lipschitz", lipschitz, allow_zero=True)
    P = cp.Variable((n, n), symmetric=True)
    tau = cp.Variable(nonneg=True)
    a3 = cp.Variable()
    I = np.eye(n)
    blk = cp.bmat([[F_.T @ P + P @ F_ + a3 * I + tau * ell**2 * I, P], [P, -tau * I]])
    prob = cp.Problem(cp.Maximize(a3), [symmetrise(blk) << 0, P << I, P >> 1e-6 * I])
    res = solve(prob, solver)
    if not res.status.has_solution or P.value is None or tau.value is None:
        raise DesignInfeasible(f"Assumption 1: the S-procedure SDP failed ({res.raw_status})", constraint="Assumption 1")
    Pv = 0.5 * (P.value + P.value.T)
    tv = float(tau.value)
    # recompute α₃ from (P, τ): largest α with [[Q + αI, P], [P, −τI]] ⪯ 0, Q = FᵀP + PF + τℓ² I.
    Q = F_.T @ Pv + Pv @ F_ + tv * ell**2 * I
    if tv <= 0:
        if ell > 0:
            raise DesignInfeasible("Assumption 1: the S-procedure multiplier is zero", constraint="Assumption 1")
        alpha3 = -max_eig(Q)
    else:
        alpha3 = -max_eig(Q + Pv @ Pv / tv)  # Schur complement
    alpha3 *= 1.0 - 1e-9  # stay strictly inside
    lam = np.linalg.eigvalsh(Pv)
    if alpha3 <= 0 or lam[0] <= 0:
        raise DesignInfeasible(
            f"Assumption 1: no quadratic V proves V̇ ≤ −α₃‖x̃‖² for ℓ = {ell:g} (best α₃ = {alpha3:.3g}); "
            "the Lipschitz constant is too large for this observer gain",
            constraint="Assumption 1",
            violation=-alpha3,
        )
    full = np.block([[Q + alpha3 * I, Pv], [Pv, -tv * I]])
    Pv.setflags(write=False)
    return QuadraticLyapunov(
        P=Pv,
        alpha1=float(lam[0]),
        alpha2=float(lam[-1]),
        alpha3=float(alpha3),
        alpha4=float(2.0 * lam[-1]),
        tau=tv,
        lipschitz=ell,
        certificate_max_eig=max_eig(full),
    )
