r"""Unknown-input decoupling of Khajenejad & Yong (Appendix A.1, Lemma 5.1) and its structural checks.

:func:`ui_transform` computes the SVD ``H = [U₁ U₂] [[Σ, 0], [0, 0]] [V₁ V₂]ᵀ``
(``p_H = rank H``; the cases ``p_H = 0`` and ``p_H = l`` give empty blocks), the
transformed matrices of (9) and (A.3)-(A.4), and the gains of Lemma 5.1,
``M₁ = Σ⁻¹`` and ``M₂ = (C₂ G₂)†``, after checking its rank condition
``rank(C₂ G₂) = p − p_H``.

:func:`structural_check` gathers the conditions under which an observer of the
structure (10)-(15) can be stable, for a linear part ``A`` and the linear maps
``K`` the nonlinearity class contains (``φ(x) = K x``):

* strong detectability of ``(A + K, G, C, H)`` (Definition 2.1, Remark 2.2,
  Corollary 5.8; Lemma 5.7 for the vertices of an LPV class), via
  :func:`nlobs.linear.zeros.minimum_phase`;
* detectability of ``(Φ (A + K − Ψ), C₂)`` — the error dynamics (16) of that
  linear instance is ``x̃⁺ = (I − L̃C₂) Φ (A + K − Ψ) x̃``, so no gain ``L̃``
  stabilises it when an unobservable mode of this pair has ``|λ| ≥ 1``.

Either failure means that *no stable observer of this structure exists* for the
class (a member of the class defeats every gain).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from nlobs._typing import Array
from nlobs._validate import as_matrix, as_square, in_range, readonly
from nlobs.checks import Check, CheckKind
from nlobs.errors import AssumptionViolated
from nlobs.linear.observability import unobservable_modes
from nlobs.linear.stability import strictly_inside
from nlobs.linear.zeros import minimum_phase

__all__ = ["UITransform", "ui_transform", "StructuralReport", "structural_check", "require_structure"]

_EPS = float(np.finfo(float).eps)



@dataclass(frozen=True)
class UITransform:
    r"""The transformation of Appendix A.1 and the gains of Lemma 5.1.

    Attributes
    ----------
    p_H : int
        ``rank H``.
    U1, U2 : ndarray, shapes (l, p_H), (l, l − p_H)
        Left singular vectors; ``T₁ = U₁ᵀ``, ``T₂ = U₂ᵀ`` (A.4).
    V1, V2 : ndarray, shapes (p, p_H), (p, p − p_H)
        Right singular vectors; ``d₁ = V₁ᵀ d``, ``d₂ = V₂ᵀ d`` (A.1).
    Sigma : ndarray, shape (p_H, p_H)
        Nonzero singular values of ``H`` (diagonal).
    G1, G2 : ndarray
        ``G V₁``, ``G V₂``.
    C1, C2 : ndarray
        ``U₁ᵀ C``, ``U₂ᵀ C``.
    D1, D2 : ndarray
        ``U₁ᵀ D``, ``U₂ᵀ D``.
    M1, M2 : ndarray
        ``Σ⁻¹`` and ``(C₂ G₂)†`` (Lemma 5.1), so ``M₁ Σ = I``, ``M₂ C₂ G₂ = I``.
    Phi : ndarray, shape (n, n)
        ``Φ = I − G₂ M₂ C₂``.
    Psi : ndarray, shape (n, n)
        ``Ψ = G₁ M₁ C₁``.
    """

    p_H: int
    U1: Array
    U2: Array
    V1: Array
    V2: Array
    Sigma: Array
    G1: Array
    G2: Array
    C1: Array
    C2: Array
    D1: Array
    D2: Array
    M1: Array
    M2: Array
    Phi: Array
    Psi: Array

    @property
    def T1(self) -> Array:
        """``U₁ᵀ``."""
        return self.U1.T

    @property
    def T2(self) -> Array:
        """``U₂ᵀ``."""
        return self.U2.T


def _rank_tol(M: Array) -> float:
    s = float(np.linalg.norm(M, 2)) if M.size else 0.0
    return max(M.shape, default=1) * _EPS * max(s, 1.0) * 100.0


def ui_transform(G: ArrayLike, C: ArrayLike, H: ArrayLike | None = None, D: ArrayLike | None = None, *,
                 rtol: float | None = None) -> UITransform:
    r"""Transformation of Appendix A.1 and the gains ``M₁ = Σ⁻¹``, ``M₂ = (C₂G₂)†`` of Lemma 5.1.

    Parameters
    ----------
    G : array_like, shape (n, p)
    C : array_like, shape (l, n)
    H : array_like, shape (l, p), optional
        Zero when omitted (then ``p_H = 0``: ``Σ, U₁, V₁`` are empty and
        ``U₂ = I_l``, ``V₂ = I_p``).
    D : array_like, shape (l, m), optional
    rtol : float, optional
        Rank tolerance for ``H`` and ``C₂G₂``, relative to their norms (default
        ``100 max(shape) ε``).

    Returns
    -------
    UITransform

    Raises
    ------
    AssumptionViolated
        ``item="lemma_5_1_rank"``: ``rank(C₂ G₂) < p − p_H`` (Lemma 5.1): the
        component ``d₂`` of the unknown input is not visible in ``z₂`` one step
        later, so it cannot be decoupled from the error dynamics.
    """
    C_ = as_matrix("C", C)
    l, n = C_.shape
    G_ = as_matrix("G", G, (n, None))
    p = G_.shape[1]
    H_ = np.zeros((l, p)) if H is None else as_matrix("H", H, (l, p))
    D_ = np.zeros((l, 0)) if D is None else as_matrix("D", D, (l, None))
    if p > l:
        raise AssumptionViolated(
            f"p = {p} unknown inputs but only l = {l} measurements: the paper assumes l >= p (Sec. 3)",
            item="l_ge_p", evidence=f"p={p}, l={l}")
    if p == 0:
        U, s, Vt = np.eye(l), np.zeros(0), np.zeros((0, 0))
    else:
        U, s, Vt = scipy.linalg.svd(H_, full_matrices=True)
    rt = in_range("rtol", rtol, 0.0, 1.0) if rtol is not None else None
    tolH = (rt * float(s[0]) if rt is not None else _rank_tol(H_)) if s.size else 0.0
    pH = int(np.sum(s > tolH)) if s.size else 0
    V = Vt.T if p else np.zeros((0, 0))
    U1, U2 = U[:, :pH], U[:, pH:]
    V1, V2 = V[:, :pH], V[:, pH:]
    Sigma = np.diag(s[:pH])
    G1, G2 = G_ @ V1, G_ @ V2
    C1, C2 = U1.T @ C_, U2.T @ C_
    D1, D2 = U1.T @ D_, U2.T @ D_
    M1 = np.diag(1.0 / s[:pH])
    CG = C2 @ G2
    q = p - pH
    if q:
        sv = scipy.linalg.svdvals(CG)
        tol = rt * float(sv[0]) if (rt is not None and sv.size) else _rank_tol(CG)
        r = int(np.sum(sv > tol))
        if r < q:
            raise AssumptionViolated(
                f"Lemma 5.1: rank(C2 G2) = {r} < p - p_H = {q}; the unknown-input component d2 does not reach the "
                "measurements one step later, so it cannot be decoupled and no observer of the structure (10)-(15) "
                "exists for this (G, C, H)",
                item="lemma_5_1_rank",
                evidence="singular values of C2 G2: " + ", ".join(f"{v:.3g}" for v in sv),
            )
        M2 = np.linalg.pinv(CG)
    else:
        M2 = np.zeros((0, l - pH))
    Phi = np.eye(n) - G2 @ M2 @ C2
    Psi = G1 @ M1 @ C1
    return UITransform(pH, *(readonly(a) for a in (U1, U2, V1, V2, Sigma, G1, G2, C1, C2, D1, D2, M1, M2, Phi, Psi)))


@dataclass(frozen=True)
class StructuralReport:
    """Structural conditions for a stable observer of the structure (10)-(15), one :class:`~nlobs.checks.Check` per member.

    Attributes
    ----------
    checks : tuple of Check
        Per linear member ``K`` of the class (in the order given): passes when ``(A + K, G, C, H)``
        is strongly detectable and ``(Φ(A + K − Ψ), C₂)`` leaves no undetectable error mode with
        ``|λ| ≥ 1``. ``values``: ``strongly_detectable`` (bool), ``reason`` (the minimum-phase
        verdict with the offending zeros) and ``unstable_error_modes`` (tuple of complex).
    transform : UITransform
    inputs : str
        A digest of the matrices and linear members it was computed for (:func:`structure_inputs`),
        so that a design can reuse this report only for the same system.
    """

    checks: tuple[Check, ...]
    transform: UITransform
    inputs: str = ""

    @property
    def exists(self) -> bool:
        """``False`` when some checked linear member of the class is not strongly detectable or leaves an
        undetectable error mode: then no stable observer of this structure exists."""
        return all(c.passed for c in self.checks)

    @property
    def strongly_detectable(self) -> tuple[bool, ...]:
        """Per linear member ``K``: strong detectability of ``(A + K, G, C, H)``."""
        return tuple(bool(c.values["strongly_detectable"]) for c in self.checks)

    @property
    def reasons(self) -> tuple[str, ...]:
        """Per member: the minimum-phase verdict with the offending zeros."""
        return tuple(str(c.values["reason"]) for c in self.checks)

    @property
    def unstable_error_modes(self) -> tuple[NDArray[np.complex128], ...]:
        """Per member: unobservable modes of ``(Φ(A + K − Ψ), C₂)`` with ``|λ| ≥ 1`` (read-only arrays)."""
        out = []
        for c in self.checks:
            modes = np.array(c.values["unstable_error_modes"], dtype=complex)
            modes.setflags(write=False)
            out.append(modes)
        return tuple(out)

    def summary(self) -> str:
        """The numbers behind the verdict, one line per linear member."""
        if not self.checks:
            return ("no linear member of the class is known, so strong detectability was not checked "
                    "(Lemma 5.1's rank condition holds)")
        return "\n".join(f"member {i}: {c.evidence}" for i, c in enumerate(self.checks))

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view: ``exists``, ``strongly_detectable``, ``reasons``, ``unstable_error_modes`` (``[re, im]``
        pairs per member), ``evidence`` (:meth:`summary`) and the per-member ``checks``."""
        return {"exists": self.exists, "strongly_detectable": list(self.strongly_detectable),
                "reasons": list(self.reasons),
                "unstable_error_modes": [[[float(z.real), float(z.imag)] for z in b] for b in self.unstable_error_modes],
                "evidence": self.summary(), "checks": [c.to_dict() for c in self.checks]}


def _member_check(i: int, mp: Check, bad: NDArray[np.complex128]) -> Check:
    modes = ", ".join(f"{complex(z):.6g}" for z in bad) or "none"
    return Check.verdict(
        f"member {i}: strongly detectable with detectable error dynamics (Corollary 5.8, Lemma 5.7)",
        mp.passed and bad.size == 0,
        f"strongly detectable={mp.passed} ({mp.evidence}); undetectable error modes |λ|>=1: {modes}",
        kind=CheckKind.STRUCTURAL, method="numeric",
        values={"strongly_detectable": mp.passed, "reason": mp.evidence,
                "unstable_error_modes": tuple(complex(z) for z in bad)})


def structural_check(A: ArrayLike, G: ArrayLike, C: ArrayLike, H: ArrayLike | None = None, *,
                     members: tuple[ArrayLike, ...] | None = None,
                     transform: UITransform | None = None) -> StructuralReport:
    r"""Strong detectability (Corollary 5.8, Lemma 5.7) and detectability of the error dynamics.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Linear part of ``f``.
    G, C, H : array_like
        As in (8).
    members : tuple of array_like, each (n, n), optional
        Linear maps ``K`` contained in the nonlinearity class (``φ(x) = K x``). Omitted (``None``):
        ``(0,)``, the LTI system ``(A, G, C, H)`` of Corollary 5.8. An empty tuple (a class with no known
        linear member) checks no member: ``exists`` is then ``True`` by default (nothing shows that no
        stable observer exists), and :meth:`StructuralReport.summary` says that nothing was checked.
    transform : UITransform, optional
        Precomputed :func:`ui_transform` (computed here when omitted; raises
        :class:`~nlobs.errors.AssumptionViolated` when Lemma 5.1's rank fails).

    Returns
    -------
    StructuralReport
    """
    A_ = as_square("A", A)
    n = A_.shape[0]
    G_ = as_matrix("G", G, (n, None))
    C_ = as_matrix("C", C, (None, n))
    H_ = np.zeros((C_.shape[0], G_.shape[1])) if H is None else as_matrix("H", H, (C_.shape[0], G_.shape[1]))
    tr = ui_transform(G_, C_, H_) if transform is None else transform
    Ks = (np.zeros((n, n)),) if members is None else tuple(as_square(f"members[{i}]", K, n)
                                                            for i, K in enumerate(members))
    checks = []
    for i, K in enumerate(Ks):
        mp = minimum_phase(A_ + K, G_, C_, H_, discrete=True)
        Ae = tr.Phi @ (A_ + K - tr.Psi)
        um = unobservable_modes(Ae, tr.C2, discrete=True)
        checks.append(_member_check(i, mp, um[~strictly_inside(um, discrete=True)]))
    return StructuralReport(tuple(checks), tr, structure_inputs(A_, G_, C_, H_, Ks, tr))


def structure_inputs(A: ArrayLike, G: ArrayLike, C: ArrayLike, H: ArrayLike, members: tuple[ArrayLike, ...],
                     transform: UITransform) -> str:
    """A digest of what :func:`structural_check` depends on (matrices, members, transformation)."""
    import hashlib

    h = hashlib.sha256()
    for M in (A, G, C, H, *members, transform.Phi, transform.Psi, transform.C2):
        arr = np.ascontiguousarray(np.asarray(M, dtype=float))
        h.update(repr(arr.shape).encode())
        h.update(arr.tobytes())
    return h.hexdigest()


def require_structure(check: StructuralReport) -> None:
    """Raise :class:`~nlobs.errors.AssumptionViolated` (``item="no_stable_observer"``) when ``check.exists`` is false.

    Parameters
    ----------
    check : StructuralReport
        Result of :func:`structural_check`.

    Raises
    ------
    AssumptionViolated
        Some checked linear member of the class is not strongly detectable or leaves an
        undetectable error mode; the message lists :meth:`StructuralReport.summary`.
    """
    if not check.exists:
        raise AssumptionViolated(
            "no stable observer of the structure (10)-(15) exists: a linear member of the nonlinearity class is not "
            "strongly detectable (Corollary 5.8 / Lemma 5.7), so every gain L~ leaves an error mode with |λ| >= 1\n"
            + check.summary(),
            item="no_stable_observer",
            evidence=check.summary(),
        )
