r"""The sufficient bounds of the cascade/feedback observer of Grip, Saberi & Johansen (Secs. 3–4).

* :func:`theorem1_gamma_bound` — Theorem 1: ``γ = 4α₃/(4L₂² + α₄²L₁²)``;
  :func:`theorem1_optimal_scaling` — the best scaling of ``V`` for it;
  :func:`theorem1_prime_gamma_bound` — the two conditions of the proof of Theorem 1'
  (Appendix B, feedback case).
* :func:`quadratic_lyapunov_constants` — Assumption 1 for an observer whose error
  dynamics is ``x̃̇ = F x̃ + δΦ`` with ``‖δΦ‖ ≤ ℓ‖x̃‖`` (Thau/Rajamani-type
  observers): a quadratic ``V = x̃ᵀ P x̃`` and its constants ``α₁ … α₄`` (5)–(7), from an
  S-procedure SDP re-verified in NumPy.

A gain meeting the bound is designed by :mod:`nlobs.synthesis.cascade_gain`; the structural
Assumption 4 is checked by :mod:`nlobs.linear.assumption4`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy
from numpy.typing import ArrayLike

from nlobs._lazy import LazyModule
from nlobs._typing import Array
from nlobs._validate import as_square, positive, readonly
from nlobs.errors import DesignInfeasible
from nlobs.synthesis.lmi import Solver, max_eig, solve, symmetrise

cp = LazyModule("cvxpy")  # imported by the first problem built (see nlobs._lazy)

__all__ = [
    "QuadraticLyapunov",
    "quadratic_lyapunov_constants",
    "theorem1_gamma_bound",
    "theorem1_optimal_scaling",
    "theorem1_prime_gamma_bound",
]


# --------------------------------------------------------------------------- Theorem 1


def _constants(alpha3: float, alpha4: float, L1: float, L2: float) -> tuple[float, float, float, float]:
    return (
        positive("alpha3", alpha3),
        positive("alpha4", alpha4),
        positive("L1", L1),
        positive("L2", L2),
    )


def theorem1_gamma_bound(alpha3: float, alpha4: float, L1: float, L2: float) -> float:
    r"""Theorem 1 of Grip, Saberi & Johansen: ``γ = 4α₃ / (4L₂² + α₄²L₁²)``.

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

    Examples
    --------
    With ``α₃ = 0.5, α₄ = 3, L₁ = 2, L₂ = 1.5`` the bound is ``4·0.5/(4·1.5² + 3²·2²) = 2/45``:

    >>> g = theorem1_gamma_bound(0.5, 3.0, 2.0, 1.5)
    >>> round(g, 6), bool(abs(g - 2 / 45) < 1e-15)
    (0.044444, True)

    Scaling ``V`` by ``c* = 2L₂/(α₄L₁) = 0.5`` raises it to ``α₃/(α₄L₁L₂) = 1/18``:

    >>> round(theorem1_gamma_bound(0.5 * 0.5, 0.5 * 3.0, 2.0, 1.5), 6), round(1 / 18, 6)
    (0.055556, 0.055556)
    >>> try:
    ...     theorem1_gamma_bound(0.0, 3.0, 2.0, 1.5)
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError alpha3: must be positive, got 0.0
    """
    a3, a4, l1, l2 = _constants(alpha3, alpha4, L1, L2)
    return 4.0 * a3 / (4.0 * l2**2 + a4**2 * l1**2)


def theorem1_optimal_scaling(alpha3: float, alpha4: float, L1: float, L2: float) -> tuple[float, float]:
    r"""Best scaling ``c*`` of ``V`` for Theorem 1 and the bound it gives.

    ``γ(c) = 4cα₃/(4L₂² + c²α₄²L₁²)`` is maximal at ``c* = 2L₂/(α₄L₁)`` with
    ``γ(c*) = α₃/(α₄L₁L₂)``; the ratio ``α₃/α₄`` is scale-invariant.

    Parameters
    ----------
    alpha3, alpha4 : float
        Constants of Assumption 1, (6) and (7) (positive).
    L1, L2 : float
        Lipschitz constants of Assumptions 2 and 3 (positive).

    Returns
    -------
    (c_star, gamma) : tuple of float

    Examples
    --------
    ``c* = 2·1.5/(3·2) = 0.5`` and ``γ(c*) = 0.5/(3·2·1.5) = 1/18``; no other scaling does better:

    >>> import numpy as np
    >>> c, g = theorem1_optimal_scaling(0.5, 3.0, 2.0, 1.5)
    >>> round(c, 6), round(g, 6), round(1 / 18, 6)
    (0.5, 0.055556, 0.055556)
    >>> all(theorem1_gamma_bound(s * 0.5, s * 3.0, 2.0, 1.5) <= g * (1 + 1e-12) for s in np.logspace(-2, 2, 41))
    True
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

    Examples
    --------
    The two conditions of Appendix B written out: they hold just below ``γ̄`` and fail just above it:

    >>> a3, a4, L1, L2 = 0.5, 3.0, 2.0, 1.5
    >>> def ok(g):
    ...     return g < a3 / L2**2 and g < 4 * (a3 - g * L2**2) * (1 - g**2 * L2**2) / (a4**2 * L1**2)
    >>> gb = theorem1_prime_gamma_bound(a3, a4, L1, L2, optimise_scaling=False)
    >>> round(gb, 4), ok(0.999 * gb), ok(1.001 * gb)
    (0.0443, True, False)
    >>> round(theorem1_prime_gamma_bound(a3, a4, L1, L2), 4)  # the best scaling of V raises it
    0.0554
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

    Examples
    --------
    The Rajamani-type observer of Example 1 (Grip, Saberi & Johansen, Sec. 4), ``F = A₁ − L C₁``, with
    ``ℓ = 0.4``; (5)–(7) hold, and ``V̇ ≤ −α₃‖x̃‖²`` (6) on sampled errors and perturbations with
    ``‖δΦ‖ ≤ ℓ‖x̃‖``:

    >>> import numpy as np
    >>> F = np.array([[0.0, -68.6], [1.0, -12.6]])
    >>> q = quadratic_lyapunov_constants(F, 0.4)
    >>> q.P.shape, bool(0 < q.alpha1 <= q.alpha2), bool(np.isclose(q.alpha4, 2 * q.alpha2)), q.certificate_max_eig <= 0
    ((2, 2), True, True, True)
    >>> rng = np.random.default_rng(0)
    >>> e, d = rng.normal(size=(1000, 2)), rng.normal(size=(1000, 2))
    >>> d *= 0.4 * rng.uniform(size=(1000, 1)) * np.linalg.norm(e, axis=1, keepdims=True) / np.linalg.norm(
    ...     d, axis=1, keepdims=True)
    >>> bool(np.all(q.derivative_bound(F, e, d) <= -q.alpha3 * np.sum(e**2, axis=1)))
    True
    >>> bool(np.isclose(q.ratio, q.alpha3 / q.alpha4))  # the scale-invariant ratio of Theorem 1
    True
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

    Examples
    --------
    For ``F = −I`` the best ``P`` is ``I`` and the S-procedure gives
    ``α₃ = max_τ (2 − τℓ² − 1/τ) = 2(1 − ℓ)`` at ``τ = 1/ℓ``; with ``ℓ = 0.5``:

    >>> import numpy as np
    >>> q = quadratic_lyapunov_constants(-np.eye(2), 0.5)
    >>> round(q.alpha1, 4), round(q.alpha2, 4), round(q.alpha3, 4), round(q.alpha4, 4), round(q.tau, 2)
    (1.0, 1.0, 1.0, 2.0, 2.0)

    Here ``‖(sI − F)⁻¹‖∞ = 1``, so no quadratic ``V`` exists for ``ℓ = 1.2``:

    >>> try:
    ...     quadratic_lyapunov_constants(-np.eye(2), 1.2)
    ... except DesignInfeasible as exc:
    ...     print(type(exc).__name__, "-", exc.constraint)
    DesignInfeasible - Assumption 1
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
    return QuadraticLyapunov(
        P=readonly(Pv, owned=True),
        alpha1=float(lam[0]),
        alpha2=float(lam[-1]),
        alpha3=float(alpha3),
        alpha4=float(2.0 * lam[-1]),
        tau=tv,
        lipschitz=ell,
        certificate_max_eig=max_eig(full),
    )
