r"""Gains of the drift-observability observer (Dalla Mora, Germani & Manes).

The observer (3.1) needs a gain ``K`` (``n × q``) and a matrix ``P ≻ 0`` solving the
H∞ Riccati-like inequality (2.17)

.. math::

    (A_s − K C_s) P + P (A_s − K C_s)ᵀ + B_s B_sᵀ + μ² F_{s,r} F_{s,r}ᵀ + 2αP + γ² P² ⪯ 0,

with ``(A_s, B_s, C_s)`` the block Brunovsky triple of the multi-index ``s`` (2.16),
``F_{s,r}`` the 0/1 matrix of (2.12), ``α`` the decay rate, ``μ`` the input bound and
``γ² = γ_L² + γ_H²`` the Lipschitz (ALG) constants of ``L_s`` and ``H_{s,r}`` in the
``z = Φ_s(x)`` coordinates (Assumption H0/H1). A *stabilising solution pair*
(Def. 2.6) also has ``A_s − K C_s`` Hurwitz and ``P`` symmetric positive definite.

Two designs, both verified by the eigenvalues of the left side of (2.17), scaled (see below):

* :func:`vandermonde_gain` — Remark 2.11: per output block, ``K_j(w)`` assigns the
  eigenvalues ``−w, −2w, …, −s_j w``; the block Vandermonde matrix ``V_s(w)``
  diagonalises ``A_s − K(w) C_s`` and ``P(w) = (V_sᵀ V_s)⁻¹``. For ``w`` large
  enough the pair solves (2.17) (always when ``s ≤ r``, Theorem 2.9);
  :func:`smallest_w` finds the smallest such ``w`` (bracketing + bisection).
* :func:`design_drift_gain_sdp` — with ``S = P⁻¹`` and ``Y = S K``, multiplying
  (2.17) by ``S`` on both sides and taking a Schur complement gives the LMI

  .. math::

      \begin{bmatrix} S A_s + A_sᵀ S − Y C_s − C_sᵀ Yᵀ + 2αS + γ² I & S [B_s\ \ μF_{s,r}] \\
      [B_s\ \ μF_{s,r}]ᵀ S & −I \end{bmatrix} ⪯ −ε I,

  solved with Clarabel (default) for the smallest bound on ``cn(P)`` (the paper's
  advice in Sec. IV: the region of convergence shrinks with ``cn(P)``) or on ``‖K‖``.

Conventions. ``V(λ)`` of one block has rows ``[λ_i^{s_j−1}, …, λ_i, 1]``: these are
the left eigenvectors of the observer-companion matrix ``A_j − K_j C_j`` (first
column ``−K_j``, ones on the superdiagonal), so ``V (A_s − K C_s) V⁻¹ = Λ`` and
``(A_s − K C_s) P + P (A_s − K C_s)ᵀ = 2 V⁻¹ Λ V⁻ᵀ ≺ 0`` for ``P = V⁻¹ V⁻ᵀ``.

Verification in scaled coordinates. ``P(w) = T_w⁻¹ P(1) T_w⁻¹`` with ``T_w = blockdiag(w^{s_j−1}, …, w, 1)``,
so ``P`` has eigenvalues down to ``~w^{−2(s_j−1)}`` and the left side ``L`` of (2.17) has its
decisive eigenvalue far below the rounding level ``ε‖L‖`` of its own computation once
``s_j ≥ 5`` (``s = (5,)``, ``w = 1000``: ``λ_max(L) = −1.2·10⁻²⁴`` against ``ε‖L‖ = 2.7·10⁻¹⁰``):
the sign of ``λ_max(L)`` computed in double precision means nothing. (2.17) and ``P ≻ 0`` are
invariant in sign under a congruence ``X ↦ D X D`` (Sylvester), so they are checked on

.. math::

    D L D = Ã P̃ + P̃ Ãᵀ + (DB_s)(DB_s)ᵀ + μ² (DF)(DF)ᵀ + 2α P̃ + γ² P̃ D^{−2} P̃,
    \quad Ã = D (A_s − K C_s) D^{−1},\ P̃ = D P D,

with ``D = diag(2^{k_i})`` the powers of two nearest the Jacobi equilibration
``P_ii^{−1/2}`` (so ``P̃_ii ∈ [½, 2]``; for ``P(w)`` this is ``T_w`` up to a ``w``-independent
diagonal). The scaled factors ``Ã``, ``P̃``, ``DB_s``, ``DF`` are formed entrywise from
``K`` and ``P`` (powers of two: exactly; ``A_s − K C_s`` has no cancellation since ``A_s``
and ``K C_s`` have disjoint supports) — never by scaling an already rounded ``L``. A check
passes only with a margin above rounding: ``λ_max(D L D) < −c n ε ‖N‖₂`` and
``λ_min(P̃) > c n ε ‖P̃‖₂``, where ``N`` is the sum of the absolute values of the terms
(``2|Ã||P̃| + |DB||DB|ᵀ + …``, the standard bound of the products' rounding errors) and
``c = 10`` (:data:`ROUNDING_FACTOR`). The certificate reports both numbers, scaled and unscaled.

The Brunovsky triple (:func:`brunovsky_triple`) is :func:`nlobs.systems.brunovsky.brunovsky`,
shared with the symbolic layer.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from fractions import Fraction
from functools import lru_cache
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._lazy import LazyModule
from nlobs._typing import Array
from nlobs._validate import as_matrix, positive, readonly
from nlobs.errors import CertificateError, DesignInfeasible, InvalidArgumentError
from nlobs.checks import Check, CheckKind
from nlobs.synthesis.certificate import CertificateMixin, checks_dict, complex_pairs
from nlobs.systems.brunovsky import brunovsky as brunovsky_triple
from nlobs.systems.brunovsky import positive_multi_index
from nlobs.synthesis.lmi import (
    Solver,
    SolveStatus,
    as_enum,
    as_solver,
    bmat,
    max_eig,
    require_lmi_size,
    solve,
    symmetrise,
)

cp = LazyModule("cvxpy")  # imported by the first problem built (see nlobs._lazy)

__all__ = [
    "ROUNDING_FACTOR",
    "DriftGainCertificate",
    "DriftObjective",
    "RiccatiConstants",
    "VandermondeGain",
    "WSearch",
    "brunovsky_triple",
    "design_drift_gain",
    "design_drift_gain_sdp",
    "require_sdp_size",
    "riccati_lhs",
    "sdp_size",
    "smallest_w",
    "vandermonde_gain",
    "verify_drift_gain",
]

_EPS = float(np.finfo(float).eps)
#: Largest ``α``, ``μ``, ``γ`` of (2.17): their squares and products with ``P`` stay finite doubles
#: (a larger value is no design problem, only an overflow; (2.17) has no solution far below it).
MAX_CONSTANT = 1e100
#: ``c`` of the verification margin: a scaled check passes when it holds by more than ``c n ε``
#: times the norm of the absolute values of its terms (see the module docstring).
ROUNDING_FACTOR = 10.0
#: The certificate is computed at this multiple of the smallest feasible κ (bisection), so that
#: the returned pair has slack instead of sitting on the boundary of the LMI.
_FINAL_KAPPA_FACTOR = 1.1


# --------------------------------------------------------------------------- data


def riccati_constant(name: str, value: float, *, allow_zero: bool = False) -> float:
    """``α``, ``μ`` or ``γ`` of (2.17): finite, positive (``allow_zero``: non-negative), at most :data:`MAX_CONSTANT`.

    Raises
    ------
    NonFiniteError, InvalidArgumentError
        Naming ``name``.
    """
    v = positive(name, value, allow_zero=allow_zero)
    if v > MAX_CONSTANT:
        raise InvalidArgumentError(f"{name}: {v:g} is larger than {MAX_CONSTANT:g}; (2.17) would overflow (no gain "
                                   "satisfies it for such a constant)")
    return v


@dataclass(frozen=True)
class RiccatiConstants:
    """The data of inequality (2.17): multi-index, ``F_{s,r}`` and ``(α, μ, γ)``.

    Parameters
    ----------
    s : sequence of int
        Multi-index (``n = Σ s_j``).
    F : array_like, shape (n, d)
        ``F_{s,r}`` of (2.12) (``d = 0`` columns when no output has ``s_j ≥ r_j``);
        ``None`` means ``d = 0``.
    alpha : float
        Decay rate ``α > 0`` (Theorem 3.1).
    mu : float
        Input bound ``μ = u_M ≥ 0`` (``‖u(t)‖ ≤ μ``).
    gamma : float
        ``γ = √(γ_L² + γ_H²) ≥ 0``, the ALG/Lipschitz constants of ``L_s`` and ``H_{s,r}``
        in ``z``-coordinates (Assumption H0).

    Examples
    --------
    One output with ``s = r = (2,)``, so ``F_{s,r} = B_s`` (the input enters at the end of the chain),
    and ``α = μ = γ = 1``; the Brunovsky triple ``(A_s, B_s, C_s)`` of (2.16) is a double integrator:

    >>> c = RiccatiConstants((2,), [[0.0], [1.0]], alpha=1.0, mu=1.0, gamma=1.0)
    >>> c.n, c.q, c.describe()
    (2, 1, 's = (2,), α = 1, μ = 1, γ = 1')
    >>> [m.tolist() for m in c.triple()]
    [[[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]]]
    >>> try:
    ...     RiccatiConstants((2,), None, alpha=0.0, mu=1.0, gamma=1.0)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError `alpha`: must be positive, got 0.0
    """

    s: tuple[int, ...]
    F: Array
    alpha: float
    mu: float
    gamma: float

    def __init__(self, s: Sequence[int], F: ArrayLike | None, alpha: float, mu: float, gamma: float) -> None:
        s_ = positive_multi_index(s)
        n = sum(s_)
        F_ = np.zeros((n, 0)) if F is None else as_matrix("F", F, (n, None))
        F_.setflags(write=False)
        object.__setattr__(self, "s", s_)
        object.__setattr__(self, "F", F_)
        object.__setattr__(self, "alpha", riccati_constant("`alpha`", alpha))
        object.__setattr__(self, "mu", riccati_constant("`mu`", mu, allow_zero=True))
        object.__setattr__(self, "gamma", riccati_constant("`gamma`", gamma, allow_zero=True))

    @property
    def n(self) -> int:
        return sum(self.s)

    @property
    def q(self) -> int:
        return len(self.s)

    def triple(self) -> tuple[Array, Array, Array]:
        return brunovsky_triple(self.s)

    def describe(self) -> str:
        return f"s = {self.s}, α = {self.alpha:g}, μ = {self.mu:g}, γ = {self.gamma:g}"


def riccati_lhs(c: RiccatiConstants, K: ArrayLike, P: ArrayLike) -> Array:
    """The (symmetrised) left side of (2.17) for a pair ``(K, P)``, unscaled.

    For long chains its decisive eigenvalue is below the rounding level of this computation;
    the certificates use the scaled form ``D L D`` instead (module docstring).

    Parameters
    ----------
    c : RiccatiConstants
        The data of (2.17).
    K : array_like, shape (n, q)
        The gain.
    P : array_like, shape (n, n)
        The Lyapunov matrix (symmetrised before use).

    Returns
    -------
    ndarray, shape (n, n)
        The symmetrised left side ``L`` of (2.17).
    """
    K_ = as_matrix("K", K, (c.n, c.q))
    P_ = as_matrix("P", P, (c.n, c.n))
    return _lhs(c, K_, 0.5 * (P_ + P_.T), np.ones(c.n))[0]


def _equilibration(P: Array) -> Array:
    """``D``: the powers of two nearest ``P_ii^{−1/2}`` (``D_i² P_ii ∈ [½, 2]``); ones if a ``P_ii ≤ 0``."""
    dg = np.diag(P)
    if not (np.all(np.isfinite(dg)) and np.all(dg > 0)):
        return np.ones(len(dg))
    return np.ldexp(1.0, (-np.round(0.5 * np.log2(dg))).astype(int))


def _lhs(c: RiccatiConstants, K: Array, P: Array, d: Array) -> tuple[Array, float, Array, Array]:
    """``D L D`` from the scaled factors, its rounding level ``c n ε ‖N‖₂``, ``Ã`` and ``P̃`` (``D = diag(d)``)."""
    A, B, C = c.triple()
    with np.errstate(all="ignore"):  # overflow (a wild P) gives non-finite values, which fail the checks
        At = d[:, None] * (A - K @ C) / d[None, :]  # A_s and K C_s have disjoint supports: no cancellation
        Pt = d[:, None] * P * d[None, :]
        Bt = d[:, None] * B
        Ft = d[:, None] * c.F
        dinv2 = d**-2.0
        AP = At @ Pt
        M = AP + AP.T + Bt @ Bt.T + c.mu**2 * (Ft @ Ft.T) + 2.0 * c.alpha * Pt + c.gamma**2 * (Pt @ (dinv2[:, None] * Pt))
        aA, aP, aB, aF = np.abs(At), np.abs(Pt), np.abs(Bt), np.abs(Ft)
        N = (2.0 * (aA @ aP) + aB @ aB.T + c.mu**2 * (aF @ aF.T) + 2.0 * c.alpha * aP
             + c.gamma**2 * (aP @ (dinv2[:, None] * aP)))
        tol = ROUNDING_FACTOR * c.n * _EPS * float(np.linalg.norm(N, 2)) if np.all(np.isfinite(N)) else math.inf
        return 0.5 * (M + M.T), tol, At, Pt


# --------------------------------------------------------------------------- certificate


@dataclass(frozen=True, eq=False)
class DriftGainCertificate(CertificateMixin):
    """A gain pair ``(K, P)`` for the observer (3.1), re-verified against (2.17): a :class:`~nlobs.synthesis.certificate.Certificate`.

    Attributes
    ----------
    constants : RiccatiConstants
        ``s``, ``F_{s,r}``, ``α``, ``μ``, ``γ`` the pair was checked for.
    gain : ndarray, shape (n, q)
        The gain ``K`` of (3.1).
    P : ndarray, shape (n, n)
    method : str
        ``"vandermonde"`` (Remark 2.11), ``"sdp"`` or ``"given"``.
    w : float or None
        The Vandermonde parameter (``None`` otherwise).
    lhs_max_eig : float
        Largest eigenvalue of the *unscaled* left side ``L`` of (2.17), as computed in double
        precision: reported, not trusted — compare it with :attr:`lhs_rounding`.
    eigenvalues : ndarray of complex
        ``eig(A_s − K C_s)`` (computed from ``D(A_s − K C_s)D⁻¹``), sorted by real part.
    checks : tuple of Check
        (2.17) as ``λ_max(D L D) < −tolerance``, ``P ≻ 0`` as ``λ_min(D P D)`` above its rounding
        level, ``A_s − K C_s`` Hurwitz (and, for the SDP, the LMI block recomputed in the
        solver's scaled variables).
    objective : str or None
    solver : Solver or None
    solver_status : str
    margin : float
        Strictness margin ``ε`` of the SDP (0 for the Vandermonde construction).
    seconds : float
    scaling : float
        High-gain scaling ``θ`` of the SDP variables (1: none).
    lhs_max_eig_scaled : float
        ``λ_max(D L D)``, ``D = diag(2^{k_i})`` equilibrating ``P`` (module docstring).
    lhs_tolerance : float
        Rounding level of ``D L D`` (``c n ε ‖N‖₂``): (2.17) is verified when
        ``lhs_max_eig_scaled < −lhs_tolerance``.
    lhs_rounding : float
        The same level for the unscaled ``L`` — above ``|lhs_max_eig|`` the unscaled sign means nothing.

    Examples
    --------
    The Vandermonde pair of Remark 2.11 at ``w = 10`` for ``s = (2,)``, ``α = μ = γ = 1``: (2.17)
    holds with room to spare (its decay margin adds about 6 to ``α``), and ``A_s − K C_s`` has the
    assigned eigenvalues ``−10, −20``, well below ``−α``:

    >>> c = RiccatiConstants((2,), [[0.0], [1.0]], alpha=1.0, mu=1.0, gamma=1.0)
    >>> g = vandermonde_gain((2,), 10.0)
    >>> cert = verify_drift_gain(c, g.K, g.P, method="vandermonde", w=10.0)
    >>> cert.verified, cert.method, cert.spectral_abscissa
    (True, 'vandermonde', -10.0)
    >>> bool(cert.lhs_max_eig_scaled < -cert.lhs_tolerance), round(cert.decay_margin, 2)
    (True, 5.99)
    >>> round(cert.cond_P), round(cert.norm_P, 3), round(cert.gain_norm, 2)  # cn(P), ‖P‖, ‖K‖₂
    (2518, 5.018, 202.24)
    """

    constants: RiccatiConstants
    gain: Array
    P: Array
    method: str
    w: float | None
    lhs_max_eig: float
    eigenvalues: NDArray[np.complex128]
    checks: tuple[Check, ...]
    objective: str | None = None
    solver: Solver | None = None
    solver_status: str = ""
    margin: float = 0.0
    seconds: float = 0.0
    scaling: float = 1.0
    lhs_max_eig_scaled: float = math.nan
    lhs_tolerance: float = math.nan
    lhs_rounding: float = math.nan

    def _scaled(self) -> tuple[Array, Array, Array, float] | None:
        """``(d, D L D, D P D, eigenvalues of D P D)``, or ``None`` unless ``D P D`` is positive definite (and all finite)."""
        d = _equilibration(self.P)
        L, _, _, Pt = _lhs(self.constants, self.gain, self.P, d)
        if not (np.all(np.isfinite(L)) and np.all(np.isfinite(Pt))):
            return None
        ev = np.linalg.eigvalsh(Pt)
        if not ev[0] > ROUNDING_FACTOR * self.constants.n * _EPS * ev[-1]:
            return None
        return d, L, Pt, ev

    @property
    def cond_P(self) -> float:
        """``cn(P) = λ_max(P) / λ_min(P)``, with ``1/λ_min(P) = λ_max(D P̃⁻¹ D)`` (``inf`` unless ``P ≻ 0``).

        ``λ_min(P)`` itself is below the rounding level of ``P`` for long chains; ``P̃ = D P D``
        is well scaled, and the largest eigenvalue of ``P⁻¹ = D P̃⁻¹ D`` is computed to working accuracy.
        """
        sc = self._scaled()
        if sc is None:
            return math.inf
        d, _, Pt, _ = sc
        with np.errstate(over="ignore"):
            Pinv = d[:, None] * np.linalg.inv(Pt) * d[None, :]
            return float(np.linalg.eigvalsh(self.P)[-1] * np.linalg.eigvalsh(0.5 * (Pinv + Pinv.T))[-1])

    @property
    def norm_P(self) -> float:
        """``‖P‖ = λ_max(P)``."""
        return float(np.linalg.eigvalsh(self.P)[-1])

    @property
    def gain_norm(self) -> float:
        """``‖K‖₂``."""
        return float(np.linalg.norm(self.gain, 2))

    @property
    def decay_margin(self) -> float:
        """``δ/2`` with ``δ = −λ_max(P^{−1/2} L P^{−1/2})``, ``L`` the left side of (2.17); NaN unless ``P ≻ 0``.

        ``L ⪯ −δ P`` means (2.17) still holds with ``α + δ/2`` in place of ``α``: the
        scale-free slack of the pair (``λ_max(L)`` itself scales with ``P``). Computed as
        ``−λ_max(P̃^{−1/2} L̃ P̃^{−1/2})/2`` in the scaled coordinates (the same number:
        ``P⁻¹L`` and ``P̃⁻¹L̃`` are similar). NaN (see :attr:`decay_margin_note`) when ``P̃`` is
        not positive definite above its rounding level: ``P^{−1/2}`` does not exist.
        """
        sc = self._scaled()
        if sc is None:
            return math.nan
        _, L, Pt, _ = sc
        ev, U = np.linalg.eigh(Pt)
        Pm = (U / np.sqrt(ev)) @ U.T
        return float(-np.linalg.eigvalsh(Pm @ L @ Pm)[-1] / 2.0)

    @property
    def decay_margin_note(self) -> str:
        """Why :attr:`decay_margin` is NaN (empty when it is a number)."""
        return "" if self._scaled() is not None else "undefined: P is not positive definite (above rounding) or not finite"

    @property
    def spectral_abscissa(self) -> float:
        """``max Re λ(A_s − K C_s)``; (2.17) implies it is ``< −α`` when ``γ > 0``."""
        return float(np.max(self.eigenvalues.real))

    def summary(self) -> str:
        """A multi-line report: the pair, (2.17) scaled and unscaled, ``cn(P)``, the eigenvalues and every check."""
        head = f"{self.method} gain" + (f" (w = {self.w:.6g})" if self.w is not None else "")
        if self.scaling != 1.0:
            head += f" (scaling θ = {self.scaling:.4g})"
        dm = self.decay_margin
        lines = [
            f"{head} for {self.constants.describe()}: {'verified' if self.verified else 'NOT verified'}",
            f"  (2.17) scaled: λ_max(D L D) = {self.lhs_max_eig_scaled:.6g} (must be < −{self.lhs_tolerance:.3g}); "
            f"unscaled: λ_max(L) = {self.lhs_max_eig:.6g} (rounding level {self.lhs_rounding:.3g})",
            f"  cn(P) = {self.cond_P:.6g}, ‖P‖ = {self.norm_P:.6g}, ‖K‖ = {self.gain_norm:.6g}, "
            + (f"decay margin {dm:.4g}" if dm == dm else f"decay margin {self.decay_margin_note}"),
            "  eig(A_s − K C_s) = " + ", ".join(_fmt_complex(z) for z in self.eigenvalues),
        ]
        lines += ["  " + c.summary() for c in self.checks]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view (``"K"`` and ``"gain"`` hold the same gain)."""
        c = self.constants
        return {
            "method": self.method,
            "s": list(c.s),
            "alpha": c.alpha,
            "mu": c.mu,
            "gamma": c.gamma,
            "w": self.w,
            "K": self.gain.tolist(),
            "gain": self.gain.tolist(),
            "P": self.P.tolist(),
            "verified": self.verified,
            "lhs_max_eig": self.lhs_max_eig,
            "lhs_rounding": self.lhs_rounding,
            "lhs_max_eig_scaled": self.lhs_max_eig_scaled,
            "lhs_tolerance": self.lhs_tolerance,
            "cond_P": self.cond_P,
            "norm_P": self.norm_P,
            "gain_norm": self.gain_norm,
            "decay_margin": self.decay_margin,
            "eigenvalues": complex_pairs(self.eigenvalues),
            "checks": checks_dict(self.checks),
            "objective": self.objective,
            "solver": None if self.solver is None else self.solver.value,
            "solver_status": self.solver_status,
            "margin": self.margin,
            "scaling": self.scaling,
        }


def _fmt_complex(z: complex) -> str:
    return f"{z.real:.4g}" if abs(z.imag) < 1e-9 * max(1.0, abs(z)) else f"{z.real:.4g}{z.imag:+.4g}j"


class _Verification(NamedTuple):
    checks: list[Check]
    eigenvalues: NDArray[np.complex128]
    fields: dict[str, float]  # lhs_max_eig, lhs_rounding, lhs_max_eig_scaled, lhs_tolerance


def _checks(c: RiccatiConstants, K: Array, P: Array) -> _Verification:
    """(2.17) and ``P ≻ 0`` on ``D L D``, ``D P D`` (with margins above rounding), and the spectrum."""
    n = c.n
    d = _equilibration(P)
    Ls, tol, At, Pt = _lhs(c, K, P, d)
    L, tol_u, _, _ = _lhs(c, K, P, np.ones(n))
    with np.errstate(all="ignore"):
        lam_s = float(np.linalg.eigvalsh(Ls)[-1]) if np.all(np.isfinite(Ls)) else math.nan
        lam_u = float(np.linalg.eigvalsh(L)[-1]) if np.all(np.isfinite(L)) else math.nan
        evP = np.linalg.eigvalsh(Pt) if np.all(np.isfinite(Pt)) else np.array([math.nan])
        eigs = np.linalg.eigvals(At) if np.all(np.isfinite(At)) else np.full(n, complex(math.nan))
    eigs = eigs[np.lexsort((eigs.imag, eigs.real))]
    p_tol = ROUNDING_FACTOR * n * _EPS * float(np.max(np.abs(evP)))
    checks = [
        Check.compare("(2.17) scaled: λ_max(D L D)", lam_s, -tol, kind=CheckKind.LMI),
        Check.compare("P ≻ 0 scaled: −λ_min(D P D)", -float(evP[0]), -p_tol, kind=CheckKind.POSITIVITY),
        Check.compare("A_s − K C_s Hurwitz (max Re λ)", float(np.max(eigs.real)), 0.0, kind=CheckKind.SPECTRUM),
    ]
    fields = {"lhs_max_eig": lam_u, "lhs_rounding": tol_u, "lhs_max_eig_scaled": lam_s, "lhs_tolerance": tol}
    return _Verification(checks, eigs, fields)


def verify_drift_gain(c: RiccatiConstants, K: ArrayLike, P: ArrayLike, *, method: str = "given",
                      w: float | None = None) -> DriftGainCertificate:
    """Verify a pair ``(K, P)`` against (2.17) in scaled coordinates (Def. 2.6); never raises on failure.

    Bad input is still refused: ``K``, ``P`` not finite, real and of the right shape, or ``w`` (the
    Remark 2.11 parameter the certificate records) not positive and finite.

    Parameters
    ----------
    c : RiccatiConstants
        The constants of (2.17).
    K : array_like, shape (n, q)
        The gain of observer (3.1) in scaled coordinates.
    P : array_like, shape (n, n)
        The Lyapunov matrix (symmetrised).
    method : str
        How the pair was found (recorded in the certificate).
    w : float, optional
        The Remark 2.11 parameter, when the pair is ``(K(w), P(w))``.

    Returns
    -------
    DriftGainCertificate
        ``verified`` is False with the failed checks named when (2.17) does not hold.

    Raises
    ------
    InvalidArgumentError, NonFiniteError, DimensionError
        Bad ``K``, ``P`` or ``w``.

    Examples
    --------
    One output with ``s = r = (2,)`` and ``α = μ = γ = 1``: the Vandermonde pair of Remark 2.11 at
    ``w = 10`` (eigenvalues ``−10, −20``) solves (2.17); at ``w = 1`` it does not, and the failed
    check says which:

    >>> c = RiccatiConstants((2,), [[0.0], [1.0]], alpha=1.0, mu=1.0, gamma=1.0)
    >>> g = vandermonde_gain((2,), 10.0)
    >>> g.K.ravel().tolist(), g.eigenvalues.tolist()
    ([30.0, 200.0], [-10.0, -20.0])
    >>> cert = verify_drift_gain(c, g.K, g.P, method="vandermonde", w=10.0)
    >>> cert.verified, [x.name for x in cert.checks]
    (True, ['(2.17) scaled: λ_max(D L D)', 'P ≻ 0 scaled: −λ_min(D P D)', 'A_s − K C_s Hurwitz (max Re λ)'])
    >>> g1 = vandermonde_gain((2,), 1.0)
    >>> [x.name for x in verify_drift_gain(c, g1.K, g1.P, w=1.0).failed_checks]
    ['(2.17) scaled: λ_max(D L D)']
    """
    w = None if w is None else positive("`w`", w)
    K_ = as_matrix("K", K, (c.n, c.q)).copy()
    P_ = as_matrix("P", P, (c.n, c.n))
    P_ = 0.5 * (P_ + P_.T)
    v = _checks(c, K_, P_)
    K_.setflags(write=False)
    P_.setflags(write=False)
    f = v.fields
    return DriftGainCertificate(c, K_, P_, method, w, f["lhs_max_eig"], v.eigenvalues, tuple(v.checks),
                                lhs_max_eig_scaled=f["lhs_max_eig_scaled"], lhs_tolerance=f["lhs_tolerance"],
                                lhs_rounding=f["lhs_rounding"])


# --------------------------------------------------------------------------- Remark 2.11


class VandermondeGain(NamedTuple):
    """``K(w)``, ``V_s(w)``, ``P(w) = (V_sᵀ V_s)⁻¹`` and the assigned eigenvalues (Remark 2.11).

    Attributes
    ----------
    K : ndarray, shape (n, q)
        The block gain ``K(w)``.
    V : ndarray, shape (n, n)
        The block Vandermonde matrix ``V_s(w)``.
    P : ndarray, shape (n, n)
        ``P(w) = V_s⁻¹ V_s⁻ᵀ``.
    eigenvalues : ndarray, shape (n,)
        The assigned eigenvalues ``−w, …, −s_j w`` of each block, in block order.
    """

    K: Array
    V: Array
    P: Array
    eigenvalues: Array


@lru_cache(maxsize=64)
def _unit_block(sj: int) -> tuple[tuple[float, ...], tuple[tuple[float, ...], ...]]:
    """``w = 1``: the coefficients of ``∏_{i=1}^{s_j}(λ + i)`` and ``P(1) = V⁻¹V⁻ᵀ``, exact (rationals), rounded once.

    Column ``i`` of ``V(1)⁻¹`` holds the coefficients (highest power first) of the Lagrange
    polynomial ``ℓ_i`` of the nodes ``−1, …, −s_j``, since row ``m`` of ``V`` evaluates a
    polynomial at ``−m``.
    """
    nodes = [-(i + 1) for i in range(sj)]

    def poly(roots: list[int]) -> list[Fraction]:  # coefficients of ∏(λ − ρ), highest power first
        cf = [Fraction(1)]
        for rho in roots:
            cf = [a - rho * b for a, b in zip([*cf, Fraction(0)], [Fraction(0), *cf])]
        return cf

    charpoly = poly(nodes)
    cols = []
    for i, li in enumerate(nodes):
        others = nodes[:i] + nodes[i + 1 :]
        den = math.prod(li - o for o in others)
        cols.append([a / den for a in poly(others)])
    P1 = tuple(tuple(float(sum(cols[i][a] * cols[i][b] for i in range(sj))) for b in range(sj)) for a in range(sj))
    return tuple(float(x) for x in charpoly[1:]), P1


def vandermonde_gain(s: Sequence[int], w: float) -> VandermondeGain:
    """Remark 2.11: the block gain assigning ``−w, …, −s_j w`` per block, ``V_s(w)`` and ``P(w)``.

    ``K_j`` holds the coefficients of ``∏_{i=1}^{s_j} (λ + i w) = λ^{s_j} + k_{j,1} λ^{s_j−1} + … + k_{j,s_j}``
    (the characteristic polynomial of ``A_j − K_j C_j``); ``V(λ_j)`` has rows
    ``[λ^{s_j−1}, …, λ, 1]`` so that ``V_s (A_s − K C_s) V_s⁻¹ = diag(λ)``.
    ``V_s(w) = V_s(1) T_w`` with ``T_w = blockdiag(w^{s_j−1}, …, w, 1)``, so
    ``P(w) = V_s⁻¹ V_s⁻ᵀ = T_w⁻¹ P(1) T_w⁻¹`` and ``k_{j,i}(w) = w^i k_{j,i}(1)``: both are formed
    entrywise from the exact ``w = 1`` data (rationals, rounded once), so that every entry of
    ``P(w)`` — down to ``~w^{−2(s_j−1)}`` — has full relative accuracy, which inverting
    ``V_s(w)`` in floating point does not give.

    Parameters
    ----------
    s : sequence of int
        Multi-index (positive; ``n = Σ s_j``, ``q = len(s)``).
    w : float
        Eigenvalue scale ``w > 0``.

    Returns
    -------
    VandermondeGain
        Read-only arrays ``K``, ``V``, ``P`` and ``eigenvalues``.

    Raises
    ------
    InvalidArgumentError
        ``w`` is so large that ``K(w)`` or ``P(w)`` overflows a double (or ``s``, ``w`` are invalid).

    Examples
    --------
    ``s = (2,)``, ``w = 10``: ``(λ + 10)(λ + 20) = λ² + 30λ + 200``; ``V_s`` diagonalises
    ``A_s − K C_s`` and ``P = (V_sᵀ V_s)⁻¹``:

    >>> import numpy as np
    >>> g = vandermonde_gain((2,), 10.0)
    >>> g.K.ravel().tolist(), g.V.tolist(), g.eigenvalues.tolist()
    ([30.0, 200.0], [[-10.0, 1.0], [-20.0, 1.0]], [-10.0, -20.0])
    >>> A, B, C = brunovsky_triple((2,))
    >>> bool(np.allclose(g.V @ (A - g.K @ C) @ np.linalg.inv(g.V), np.diag(g.eigenvalues)))
    True
    >>> bool(np.allclose(g.P, np.linalg.inv(g.V.T @ g.V)))
    True

    Two outputs, ``s = (2, 1)``, ``w = 3``: one block per output, ``−3, −6`` and ``−3``:

    >>> g2 = vandermonde_gain((2, 1), 3.0)
    >>> g2.K.tolist(), g2.eigenvalues.tolist()
    ([[9.0, 0.0], [18.0, 0.0], [0.0, 3.0]], [-3.0, -6.0, -3.0])
    """
    s_ = positive_multi_index(s)
    w = positive("`w`", w)
    n, q = sum(s_), len(s_)
    K = np.zeros((n, q))
    V = np.zeros((n, n))
    P = np.zeros((n, n))
    lam_all = np.zeros(n)
    i = 0
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused below, not warned
        for j, sj in enumerate(s_):
            lam = -w * np.arange(1, sj + 1, dtype=float)
            coef, P1 = _unit_block(sj)
            K[i : i + sj, j] = np.array(coef) * w ** np.arange(1, sj + 1, dtype=float)
            V[i : i + sj, i : i + sj] = np.vander(lam, sj)  # rows [λ^{s−1}, …, λ, 1]
            tinv = w ** -np.arange(sj - 1, -1, -1, dtype=float)  # T_w⁻¹
            P[i : i + sj, i : i + sj] = tinv[:, None] * np.array(P1) * tinv[None, :]
            lam_all[i : i + sj] = lam
            i += sj
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(V)) and np.all(np.isfinite(P))):
        raise InvalidArgumentError(f"`w`: {w:g} is too large: K(w) ~ w^{max(s_)} or P(w) overflows a double "
                                   f"(s = {s_}); use a smaller w")
    for a in (K, V, P, lam_all):
        a.setflags(write=False)
    return VandermondeGain(K, V, P, lam_all)


@dataclass(frozen=True, eq=False)
class WSearch:
    """The smallest ``w`` for which ``(K(w), P(w))`` solves (2.17), and how it was found.

    Attributes
    ----------
    w : float
        Smallest ``w`` found (to relative tolerance ``rtol``).
    certificate : DriftGainCertificate
        The verified pair at ``w``.
    bracket : tuple of float
        ``(w_fail, w)``: the verification fails at ``w_fail`` and holds at ``w``.
    evaluations : int
        Number of verifications of (2.17).
    above : tuple of (float, float, bool)
        ``(w', λ_max(D L D), verified)`` at ``w' = 2w, 4w, 10w``: (2.17) keeps holding above ``w``
        (the search assumes this; a ``False`` would say otherwise).
    """

    w: float
    certificate: DriftGainCertificate
    bracket: tuple[float, float]
    evaluations: int
    above: tuple[tuple[float, float, bool], ...]

    @property
    def monotone(self) -> bool:
        """Whether (2.17) is also verified at every checked ``w' > w``."""
        return all(ok for _, _, ok in self.above)


def _at_w(c: RiccatiConstants, w: float) -> DriftGainCertificate:
    g = vandermonde_gain(c.s, w)
    return verify_drift_gain(c, g.K, g.P, method="vandermonde", w=w)


def smallest_w(c: RiccatiConstants, *, w_max: float = 1e5, rtol: float = 1e-3) -> WSearch:
    """Smallest ``w`` for which ``(K(w), P(w))`` is verified to solve (2.17) (scaled check, module docstring).

    Bracketing: from ``w₀ = max(α, 10⁻³)`` (``A_s − K C_s`` must have abscissa
    ``< −α``, so no ``w ≤ α`` works) ``w`` doubles until the verification passes or ``w``
    exceeds ``w_max``; then bisection in ``log w`` to relative width ``rtol``.

    Parameters
    ----------
    c : RiccatiConstants
        The data of (2.17).
    w_max : float
        Largest ``w`` tried by the bracketing.
    rtol : float
        Relative width of the final bisection bracket.

    Returns
    -------
    WSearch

    Raises
    ------
    DesignInfeasible
        No ``w ≤ w_max`` works: the message gives the smallest ``λ_max(D L D)`` seen and where
        (``constraint="(2.17) with P(w) = (V_sᵀV_s)⁻¹"``, ``violation`` = that ``λ_max``).

    Examples
    --------
    ``s = r = (2,)``, ``α = μ = γ = 1``: (2.17) fails just below ``w ≈ 4.03`` and holds from there
    (also at ``2w``, ``4w``, ``10w``); with ``w_max = 2`` no ``w`` is found:

    >>> c = RiccatiConstants((2,), [[0.0], [1.0]], alpha=1.0, mu=1.0, gamma=1.0)
    >>> ws = smallest_w(c)
    >>> round(ws.w, 2), ws.certificate.verified, ws.monotone
    (4.03, True, True)
    >>> lo, hi = ws.bracket
    >>> g = vandermonde_gain((2,), lo)
    >>> verify_drift_gain(c, g.K, g.P).verified, bool(hi / lo <= 1.001)
    (False, True)
    >>> try:
    ...     smallest_w(c, w_max=2.0)
    ... except DesignInfeasible as exc:
    ...     print(type(exc).__name__, exc.constraint)
    DesignInfeasible (2.17) with P(w) = (V_sᵀV_s)⁻¹
    """
    w_max = positive("`w_max`", w_max)
    rtol = positive("rtol", rtol)
    evals = 0
    w_lo = max(c.alpha, 1e-3)
    w = w_lo
    best = (math.inf, w, math.nan)
    w_fail: float | None = None
    while True:
        cert = _at_w(c, w)
        evals += 1
        v = cert.lhs_max_eig_scaled
        if v < best[0]:
            best = (v, w, cert.lhs_tolerance)
        if cert.verified:
            break
        w_fail = w
        if w >= w_max:
            if c.F.size and not _s_le_r_F(c):
                why = "s ≰ r: lower the input bound μ (`mu`; Theorem 2.7) or use the SDP design (`method` sdp)"
            elif best[0] < 0:
                why = (f"it is negative but not below the rounding tolerance {best[2]:.3g} (or P(w) is not positive "
                       "definite above rounding): P(w) is too ill-conditioned to verify in double precision "
                       "(cn(D P D) grows fast with the chain length s_j); use shorter chains or the SDP design "
                       "(`method` sdp)")
            else:
                why = ("raise the search limit `w_max`, or lower α, μ or γ (`alpha`, `mu`, `gamma`; "
                       "γ also by a smaller region, `region`)")
            raise DesignInfeasible(
                f"(2.17) has no Vandermonde solution (K(w), P(w)) for w ≤ {w_max:g} with {c.describe()}: "
                f"the smallest λ_max of its (scaled) left side is {best[0]:.4g} (at w = {best[1]:.4g}); " + why,
                constraint="(2.17) with P(w) = (V_sᵀV_s)⁻¹",
                violation=best[0],
            )
        w = min(2.0 * w, w_max)
    hi, cert_hi = w, cert
    if w_fail is None:  # holds at w₀ = α: cannot go lower in theory, but check a bit below
        lo = w_lo / 2.0
        evals += 1
        if _at_w(c, lo).verified:
            lo = hi  # nothing to bisect
        w_fail = lo
    lo = w_fail
    while hi / lo > 1.0 + rtol:
        mid = math.sqrt(lo * hi)
        cm = _at_w(c, mid)
        evals += 1
        if cm.verified:
            hi, cert_hi = mid, cm
        else:
            lo = mid
    above = tuple((f * hi, ca.lhs_max_eig_scaled, ca.verified) for f in (2.0, 4.0, 10.0) for ca in [_at_w(c, f * hi)])
    return WSearch(hi, cert_hi, (lo, hi), evals + 3, above)


def _s_le_r_F(c: RiccatiConstants) -> bool:
    """``s ≤ r`` in terms of ``F``: every column of ``F`` is some ``B_s`` column (input only at chain ends)."""
    _, B, _ = c.triple()
    ends = set(np.flatnonzero(B.sum(axis=1)))
    rows = set(np.flatnonzero(np.abs(c.F).sum(axis=1)))
    return rows <= ends


# --------------------------------------------------------------------------- SDP


class DriftObjective(str, Enum):
    """What :func:`design_drift_gain_sdp` minimises over the LMI-feasible set."""

    MIN_CONDITION = "min_condition"
    """Smallest ``κ`` with ``σ I ⪯ S ⪯ κ σ I`` (so ``cn(P) ≤ κ``), by bisection on ``κ``."""
    MIN_GAIN = "min_gain"
    """Smallest ``κ`` with ``S ⪰ σ I``, ``‖Y‖₂ ≤ κ σ`` (so ``‖K‖₂ ≤ κ``), by bisection on ``κ``."""


@dataclass
class _Sdp:
    problem: cp.Problem
    S: cp.Variable
    Y: cp.Variable
    kappa: cp.Parameter
    slack: cp.Variable
    T: Array  # S = T S̃ T
    Th: Array  # Y = T Ŷ diag(Th)


def _lmi_block(c: RiccatiConstants, S: Array, Y: Array, theta: float = 1.0) -> Array:
    """The LMI of (2.17) in the scaled ``(S̃, Ŷ)`` of :func:`_build_sdp` (must be ``⪯ 0``), in NumPy."""
    A, B, C = c.triple()
    T, _ = _scaling(c.s, theta)
    W = T[:, None] * np.hstack([B, c.mu * c.F])
    SA = theta * (S @ A)
    M11 = SA + SA.T - Y @ C - C.T @ Y.T + 2.0 * c.alpha * S + c.gamma**2 * np.diag(T**-2.0)
    SW = S @ W
    return symmetrise(bmat([[M11, SW], [SW.T, -np.eye(W.shape[1])]]))


def _scaling(s: tuple[int, ...], theta: float) -> tuple[Array, Array]:
    """``T = blockdiag(θ^{s_j−1}, …, θ, 1)`` and ``Θ = diag(θ^{s_j−1})``."""
    T = np.concatenate([theta ** np.arange(sj - 1, -1, -1, dtype=float) for sj in s])
    return T, np.array([theta ** (sj - 1) for sj in s], dtype=float)


def sdp_size(c: RiccatiConstants, objective: DriftObjective | str = DriftObjective.MIN_GAIN,
             gain_bound: float | None = None) -> tuple[int, tuple[int, ...]]:
    """``(scalar decision variables, sizes of the semidefinite blocks)`` of the problem :func:`_build_sdp` builds.

    ``S̃`` and ``Ŷ`` with ``σ`` and the slack ``t``; the LMI of (2.17) (``n + q + w`` with ``w`` the columns
    of ``F``), ``S̃ ⪰ σ I``, and ``S̃ ⪯ κ σ I`` and/or the gain block ``n + q``.

    Parameters
    ----------
    c : RiccatiConstants
        The data of (2.17).
    objective : DriftObjective or str
        As in :func:`design_drift_gain_sdp`.
    gain_bound : float, optional
        As in :func:`design_drift_gain_sdp` (adds the gain block with ``"min_condition"``).

    Returns
    -------
    tuple of (int, tuple of int)
    """
    return _sdp_size(c.s, c.F.shape[1], as_enum("objective", DriftObjective, objective), gain_bound)


def _sdp_size(s: tuple[int, ...], f_columns: int, obj: DriftObjective,
              gain_bound: float | None) -> tuple[int, tuple[int, ...]]:
    n, q = sum(s), len(s)
    blocks = [n + q + f_columns, n]
    if obj is DriftObjective.MIN_CONDITION:
        blocks.append(n)
        if gain_bound is not None:
            blocks.append(n + q)
    else:
        blocks.append(n + q)
    return n * (n + 1) // 2 + n * q + 2, tuple(blocks)


def require_sdp_size(s: Sequence[int], f_columns: int = 0, objective: DriftObjective | str = DriftObjective.MIN_GAIN,
                     gain_bound: float | None = None) -> None:
    """Refuse the SDP of :func:`design_drift_gain_sdp` above :data:`~nlobs.synthesis.lmi.MAX_LMI_SIZE`.

    Counted from the multi-index ``s`` and the columns of ``F`` alone (``f_columns = 0`` gives a lower bound,
    for a refusal before ``F`` is computed); raises :class:`~nlobs.errors.InvalidArgumentError`.

    Parameters
    ----------
    s : sequence of int
        Multi-index.
    f_columns : int
        Number of columns of ``F_{s,r}``.
    objective : DriftObjective or str
        As in :func:`design_drift_gain_sdp`.
    gain_bound : float, optional
        As in :func:`design_drift_gain_sdp`.
    """
    s_ = tuple(int(k) for k in s)
    nvar, blocks = _sdp_size(s_, int(f_columns), as_enum("objective", DriftObjective, objective), gain_bound)
    outputs = f"{len(s_)} output{'s' if len(s_) > 1 else ''}"
    require_lmi_size("drift-observability SDP", f"n = {sum(s_)} states (s = {_short(s_)}) with {outputs}", nvar, blocks,
                     "use the closed-form Vandermonde gain instead (method 'vandermonde', Remark 2.11), which has "
                     "no size limit")


def _short(s: tuple[int, ...]) -> str:
    return str(s) if len(s) <= 6 else f"({', '.join(map(str, s[:3]))}, …, {s[-1]})"


def _build_sdp(c: RiccatiConstants, objective: DriftObjective, margin: float, gain_bound: float | None,
               theta: float = 1.0) -> _Sdp:
    """The LMI in the scaled variables ``S = T S̃ T``, ``Y = T Ŷ Θ`` (the identity for ``θ = 1``).

    The congruence by ``diag(T⁻¹, I)`` turns the LMI into
    ``[[θ(S̃A_s + A_sᵀS̃) − ŶC_s − C_sᵀŶᵀ + 2αS̃ + γ²T⁻², S̃ T W], [·ᵀ, −I]]`` (``W = [B_s μF]``,
    ``T A_s T⁻¹ = θA_s``, ``C_s T⁻¹ = Θ⁻¹ C_s``, ``T B_s = B_s``): the high-gain solution, whose ``S``
    spans ``θ^{2(s_j−1)}``, has a well-conditioned ``S̃``.
    """
    A, B, C = c.triple()
    n, q = c.n, c.q
    T, Th = _scaling(c.s, theta)
    W = T[:, None] * np.hstack([B, c.mu * c.F])
    S = cp.Variable((n, n), symmetric=True, name="S")
    Y = cp.Variable((n, q), name="Y")
    sigma = cp.Variable(name="sigma")
    t = cp.Variable(name="t")  # slack: the LMI is imposed as ⪯ (t − ε) I; t ≤ 0 means feasible
    kappa = cp.Parameter(nonneg=True, name="kappa", value=1.0)
    SA = theta * (S @ A)
    M11 = SA + SA.T - Y @ C - C.T @ Y.T + 2.0 * c.alpha * S + c.gamma**2 * np.diag(T**-2.0)
    SW = S @ W
    L = symmetrise(cp.bmat([[M11, SW], [SW.T, -np.eye(W.shape[1])]]))
    k = L.shape[0]
    cons = [L << (t - margin) * np.eye(k), S >> sigma * np.eye(n), sigma >= margin, sigma <= 1e6, t >= -1.0]
    if objective is DriftObjective.MIN_CONDITION:
        cons.append(S << kappa * sigma * np.eye(n))
        if gain_bound is not None:
            cons.append(symmetrise(cp.bmat([[gain_bound * sigma * np.eye(q), Y.T], [Y, gain_bound * sigma * np.eye(n)]])) >> 0)
    else:
        cons.append(symmetrise(cp.bmat([[kappa * sigma * np.eye(q), Y.T], [Y, kappa * sigma * np.eye(n)]])) >> 0)
    return _Sdp(cp.Problem(cp.Minimize(t), cons), S, Y, kappa, t, T, Th)


def _sdp_solve(sdp: _Sdp, kappa: float, solver: Solver, options: Mapping[str, Any] | None) -> tuple[float | None, Any]:
    sdp.kappa.value = kappa
    res = solve(sdp.problem, solver, options)
    if res.status is not SolveStatus.OPTIMAL or sdp.slack.value is None:  # "inaccurate" answers are not used
        return None, res
    return float(sdp.slack.value), res


def _sdp_at(c: RiccatiConstants, obj: DriftObjective, margin: float, gb: float | None, theta: float, sol: Solver,
            options: Mapping[str, Any] | None, kappa_max: float, rtol: float, t0: float) -> DriftGainCertificate:
    sdp = _build_sdp(c, obj, margin, gb, theta)
    tol = 1e-9
    hi = 10.0
    t_hi, res = _sdp_solve(sdp, hi, sol, options)
    while t_hi is None or t_hi > tol:
        if hi >= kappa_max:
            what = "cn(P̃)" if obj is DriftObjective.MIN_CONDITION else "‖K̃‖"
            viol = t_hi if t_hi is not None else math.nan
            raise DesignInfeasible(
                f"(2.17) as an LMI in (S, Y) is infeasible for {c.describe()} with {what} ≤ {kappa_max:g} "
                f"(scaling θ = {theta:.4g})"
                + (f", gain bound {gb:g}" if gb is not None else "")
                + f": the smallest slack is t = {viol:.4g} (LMI ⪯ (t − ε)I, ε = {margin:g}; solver: {res.raw_status}); "
                + ("s ≰ r: lower μ (Theorem 2.7)" if c.F.size and not _s_le_r_F(c) else
                   "s ≤ r, so Theorem 2.9 says (2.17) is solvable: the solution is out of the solver's numerical "
                   "reach (high gains need cn(P) ~ w^(2(s_max−1))); try scaling='auto' or method='vandermonde'"),
                constraint="(2.17) as LMI in (S = P⁻¹, Y = S K)",
                violation=viol,
            )
        hi = min(hi * 10.0, kappa_max)
        t_hi, res = _sdp_solve(sdp, hi, sol, options)
    lo = 1.0 if obj is DriftObjective.MIN_CONDITION else hi / 10.0
    if obj is DriftObjective.MIN_GAIN:
        while lo > 1e-6:
            t_lo, _ = _sdp_solve(sdp, lo, sol, options)
            if t_lo is None or t_lo > tol:
                break
            hi, lo = lo, lo / 10.0
    while hi / lo > 1.0 + rtol:
        mid = math.sqrt(lo * hi)
        t_mid, _ = _sdp_solve(sdp, mid, sol, options)
        if t_mid is not None and t_mid <= tol:
            hi = mid
        else:
            lo = mid
    hi *= _FINAL_KAPPA_FACTOR  # a little inside the bound: an interior answer, not one on the boundary
    t_fin, res = _sdp_solve(sdp, hi, sol, options)
    if t_fin is None or sdp.S.value is None or sdp.Y.value is None:
        raise DesignInfeasible(f"the solver failed at the final κ = {hi:g} (θ = {theta:.4g}): {res.raw_status}",
                               constraint="(2.17) as LMI in (S, Y)", violation=None)
    T, Th = sdp.T, sdp.Th
    St = 0.5 * (sdp.S.value + sdp.S.value.T)
    # S = T S̃ T, Y = T Ŷ Θ: K = S⁻¹Y = T⁻¹ (S̃⁻¹Ŷ) Θ and P = T⁻¹ S̃⁻¹ T⁻¹, formed entrywise from the
    # well-conditioned S̃ (inverting the unscaled S would lose the small entries of P)
    K = np.linalg.solve(St, sdp.Y.value) * Th[None, :] / T[:, None]
    Pt = np.linalg.inv(St)
    P = 0.5 * (Pt + Pt.T) / (T[:, None] * T[None, :])
    v = _checks(c, K, P)
    checks = v.checks
    Yt = St @ (T[:, None] * K / Th[None, :])  # Ŷ recomputed from the returned K
    blk = _lmi_block(c, St, Yt, theta)
    checks.append(Check.compare("LMI in (S̃, Ŷ) recomputed (λ_max)", max_eig(blk),
                                100 * _EPS * max(1.0, float(np.linalg.norm(blk, 2))), kind=CheckKind.LMI))
    f = v.fields
    cert = DriftGainCertificate(c, readonly(K), readonly(P), "sdp", None, f["lhs_max_eig"], v.eigenvalues, tuple(checks),
                                obj.value, sol, res.raw_status, margin, time.perf_counter() - t0, theta,
                                lhs_max_eig_scaled=f["lhs_max_eig_scaled"], lhs_tolerance=f["lhs_tolerance"],
                                lhs_rounding=f["lhs_rounding"])
    if not cert.verified:
        raise CertificateError(f"SDP answer (θ = {theta:.4g}) failed re-verification: "
                               + "; ".join(x.summary() for x in cert.failed_checks))
    return cert


def _thetas(c: RiccatiConstants, scaling: float | str | None) -> list[float]:
    if scaling is None:
        return [1.0]
    if isinstance(scaling, str):
        if scaling.lower() != "auto":
            raise InvalidArgumentError(f"scaling: expected 'auto', None or a positive number, got {scaling!r}")
        if max(c.s) == 1:
            return [1.0]
        try:
            w = smallest_w(c, w_max=1e6, rtol=1e-2).w
        except (DesignInfeasible, CertificateError):
            return [1.0]
        cands = [w / 4.0**k for k in range(4) if w / 4.0**k >= 1.0]
        return cands + [1.0] if 1.0 not in cands else cands
    return [positive("scaling", scaling)]


def design_drift_gain_sdp(
    c: RiccatiConstants,
    *,
    objective: DriftObjective | str = DriftObjective.MIN_GAIN,
    margin: float = 1e-6,
    gain_bound: float | None = None,
    scaling: float | str | None = "auto",
    solver: Solver | str = Solver.CLARABEL,
    options: Mapping[str, Any] | None = None,
    kappa_max: float = 1e8,
    rtol: float = 1e-2,
) -> DriftGainCertificate:
    """(2.17) as an LMI in ``(S, Y) = (P⁻¹, P⁻¹K)`` (see the module docstring), solved and re-verified.

    Parameters
    ----------
    c : RiccatiConstants
    objective : DriftObjective or str
        ``"min_gain"`` (default): smallest ``κ ≥ ‖K̃‖₂``; ``"min_condition"``: smallest
        ``κ ≥ cn(P̃)``, for the scaled ``K̃ = S̃⁻¹Ŷ``, ``P̃ = S̃⁻¹`` (``= K``, ``P`` without
        scaling). Both quasi-convex: bisection in ``log κ`` (one compiled problem per ``θ``,
        ``κ`` a :class:`cvxpy.Parameter`). Without ``gain_bound``, ``"min_condition"``
        drives the gain up for a negligible gain in ``cn(P)`` (measured on ``s = (2,)``,
        ``α = μ = γ = 1``, unscaled: ``cn(P) = 25.48`` with ``‖K‖ = 3.5·10⁵`` against ``25.51``
        with ``‖K‖ = 15.8`` for ``"min_gain"``), so give it a ``gain_bound``.
    margin : float
        ``ε``: the LMI is imposed as ``⪯ −ε I`` and ``S̃ ⪰ σ I`` with ``σ ≥ ε``.
    gain_bound : float, optional
        With ``"min_condition"``, also impose ``‖K̃‖₂ ≤ gain_bound`` (via ``‖Ŷ‖ ≤ gain_bound σ``).
    scaling : "auto", float or None
        High-gain scaling ``θ`` of the variables, ``S = T S̃ T``, ``Y = T Ŷ Θ`` with
        ``T = blockdiag(θ^{s_j−1}, …, θ, 1)``, ``Θ = diag(θ^{s_j−1})`` — an exact congruence that
        keeps the solver's variables well conditioned when the solution needs high gain.
        ``None``: ``θ = 1`` (no scaling). ``"auto"`` (default): ``θ = w*/4^k`` (``k = 0..3``,
        ``θ ≥ 1``, ``w*`` the smallest Vandermonde ``w``) and ``θ = 1``; the verified answer with
        the smallest ``‖K‖`` (``"min_gain"``) or ``cn(P)`` (``"min_condition"``) is kept. Measured
        on ``s = (3, 1)``, ``α = μ = 1``: unscaled, the LMI is solved for ``γ ≤ 5`` only; scaled,
        for ``γ = 60`` too.
    solver, options
        Clarabel by default (:func:`nlobs.synthesis.lmi.solve`).
    kappa_max : float
        Largest ``κ`` tried.
    rtol : float
        Relative width of the final ``κ`` bracket.

    Returns
    -------
    DriftGainCertificate
        ``K = S⁻¹ Y``, ``P = S⁻¹`` (formed entrywise from the scaled ``S̃``, ``Ŷ``), verified by the
        eigenvalues of the scaled left side ``D L D`` of (2.17) (independently of the solver),
        ``P ≻ 0`` and ``eig(A_s − K C_s)``;
        :attr:`DriftGainCertificate.scaling` is the ``θ`` used.

    Raises
    ------
    DesignInfeasible
        The LMI has no solution with ``κ ≤ kappa_max`` for any ``θ`` tried: ``constraint`` names
        it and ``violation`` is the smallest slack ``t`` found (the LMI holds as ``⪯ (t − ε) I``).
    CertificateError
        Every solver answer failed the re-verification.

    Examples
    --------
    ``s = r = (2,)``, ``α = μ = γ = 1``: the smallest-gain SDP answer, re-verified without the
    solver, needs a much smaller gain than the smallest-``w`` Vandermonde pair of Remark 2.11
    (``‖K(w*)‖ ≈ 34.7``); a bound ``κ ≤ 5`` on the gain is infeasible:

    >>> c = RiccatiConstants((2,), [[0.0], [1.0]], alpha=1.0, mu=1.0, gamma=1.0)
    >>> cert = design_drift_gain_sdp(c)
    >>> cert.verified, cert.method, cert.objective, cert.spectral_abscissa < -c.alpha
    (True, 'sdp', 'min_gain', True)
    >>> bool(cert.gain_norm < 20.0 < smallest_w(c).certificate.gain_norm)
    True
    >>> try:
    ...     design_drift_gain_sdp(c, kappa_max=5.0, scaling=None)
    ... except DesignInfeasible as exc:
    ...     print(type(exc).__name__, exc)
    DesignInfeasible (2.17) as an LMI in (S, Y) is infeasible for s = (2,), α = 1, μ = 1, γ = 1 with ‖K̃‖ ≤ 5 ...
    """
    t0 = time.perf_counter()
    obj = as_enum("objective", DriftObjective, objective)
    sol = as_solver(solver)
    margin = positive("margin", margin)
    gb = None if gain_bound is None else positive("`gain_bound`", gain_bound)
    require_sdp_size(c.s, c.F.shape[1], obj, gb)
    found: list[DriftGainCertificate] = []
    errors: list[Exception] = []
    for theta in _thetas(c, scaling):
        try:
            found.append(_sdp_at(c, obj, margin, gb, theta, sol, options, kappa_max, rtol, t0))
        except (DesignInfeasible, CertificateError) as exc:
            errors.append(exc)
    if not found:
        infeasible = [e for e in errors if isinstance(e, DesignInfeasible) and e.violation is not None]
        if infeasible:
            raise min(infeasible, key=lambda e: e.violation if e.violation == e.violation else math.inf)  # type: ignore[operator]
        raise errors[0]
    key = (lambda x: x.gain_norm) if obj is DriftObjective.MIN_GAIN else (lambda x: x.cond_P)
    return min(found, key=key)



def design_drift_gain(
    c: RiccatiConstants,
    method: str = "vandermonde",
    *,
    w: float | None = None,
    w_max: float = 1e5,
    **sdp_options: Any,
) -> DriftGainCertificate:
    """One entry point: ``"vandermonde"`` (smallest ``w``, or the given ``w`` verified) or ``"sdp"``.

    Dalla Mora, Germani & Manes: a gain ``K`` and ``P ≻ 0`` solving the Riccati-like inequality (2.17)
    in scaled coordinates (Def. 2.6), by the Vandermonde construction ``K(w), P(w)`` of Remark 2.11 or
    by an SDP in ``S = P⁻¹``, ``Y = S K``.

    Parameters
    ----------
    c : RiccatiConstants
        The constants of (2.17): the multi-index ``s``, ``α``, ``μ``, ``γ`` and the sizes.
    method : {"vandermonde", "sdp"}
        The construction.
    w : float, optional
        ``"vandermonde"``: verify ``K(w)`` at this ``w`` instead of searching the smallest one.
    w_max : float
        ``"vandermonde"``: the largest ``w`` the search tries.
    **sdp_options
        ``"sdp"`` only: options of the SDP design (solver, margins).

    Returns
    -------
    DriftGainCertificate
        The gain, ``P`` and every check of (2.17), re-verified without the solver.

    Raises
    ------
    DesignInfeasible
        No solution (Vandermonde: none up to ``w_max``, or the given ``w`` fails (2.17)).

    Examples
    --------
    Remark 2.11 for one output with ``s = r = (2,)`` (``F_{s,r} = B_s``) and ``α = μ = γ = 1``: the
    smallest ``w`` for which ``(K(w), P(w))`` solves (2.17), and ``A_s − K C_s`` with eigenvalues
    ``−w, −2w``:

    >>> import numpy as np
    >>> c = RiccatiConstants((2,), [[0.0], [1.0]], alpha=1.0, mu=1.0, gamma=1.0)
    >>> cert = design_drift_gain(c)
    >>> cert.verified, cert.method, round(cert.w, 1)
    (True, 'vandermonde', 4.0)
    >>> bool(np.allclose(np.sort(cert.eigenvalues.real), [-2 * cert.w, -cert.w]))
    True
    >>> design_drift_gain(c, w=10.0).gain.ravel().tolist()  # a given w, verified: K = [3w, 2w²]
    [30.0, 200.0]
    """
    m = str(method).lower()
    if m == "vandermonde":
        if sdp_options:
            raise InvalidArgumentError(f"options {sorted(sdp_options)} apply to method='sdp' only")
        if w is None:
            return smallest_w(c, w_max=w_max).certificate
        g = vandermonde_gain(c.s, w)
        cert = verify_drift_gain(c, g.K, g.P, method="vandermonde", w=float(w))
        if not cert.verified:
            raise DesignInfeasible(
                f"(K(w), P(w)) with w = {w:g} does not solve (2.17) for {c.describe()}: "
                + "; ".join(x.summary() for x in cert.failed_checks),
                constraint="(2.17) with P(w) = (V_sᵀV_s)⁻¹", violation=cert.lhs_max_eig_scaled)
        return cert
    if m == "sdp":
        if w is not None:
            raise InvalidArgumentError("`w`: applies to `method` 'vandermonde' only")
        return design_drift_gain_sdp(c, **sdp_options)
    raise InvalidArgumentError(f"`method`: expected 'vandermonde' or 'sdp', got {method!r}")
