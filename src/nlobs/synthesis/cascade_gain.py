r"""Gains ``K = [K_w; K_z]`` of the cascade/feedback observer of Grip, Saberi & Johansen (Sec. 3.2), certified.

The observer (:class:`nlobs.observers.cascade.CascadeObserver`, (9)–(10) / (17)–(18)) needs a
gain for which ``𝔄 − Kℭ`` is Hurwitz and ``‖H‖∞ < γ``, ``H(s) = (sI − 𝔄 + Kℭ)⁻¹𝔅_d`` (13), on the
extended system (8c) of Σ₂ (:func:`nlobs.linear.assumption4.extended_system`). Theorem 1 (1')
then gives global exponential stability for ``γ`` below the bound of
:func:`nlobs.synthesis.cascade_bounds.theorem1_gamma_bound`.

* :func:`design_cascade_gain` — the LMIs (14)–(15) after checking Assumption 4
  (:func:`nlobs.synthesis.design_observer_gain` on ``(𝔄, ℭ, 𝔅_d)``).
* :func:`place_cascade_gain` — pole placement scaled until ``‖H‖∞ < γ``, for the very small
  ``γ`` of Theorem 1 that the LMIs cannot reach numerically; ``‖H‖∞`` is computed with the H∞
  grid safeguard (:func:`nlobs.linear.hinf_norm` with ``grid=True``).
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Sequence

import numpy as np
import scipy
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import positive, readonly
from nlobs.errors import DesignError, DimensionError, InvalidArgumentError
from nlobs.linear.assumption4 import extended_system, require_assumption4
from nlobs.linear.norms import hinf_norm
from nlobs.synthesis.certificate import Check, CheckKind, Objective, ObserverGainCertificate
from nlobs.synthesis.lmi import Solver
from nlobs.synthesis.observer_gain import GainBound, design_observer_gain
from nlobs.synthesis.regions import PoleRegion
from nlobs.systems.interconnected import LinearSubsystem, as_linear_subsystem

__all__ = ["design_cascade_gain", "place_cascade_gain"]


def _hinf_H(Ae: Array, Ce: Array, Bd: Array, K: Array) -> float:
    """``‖H‖∞`` of (13) for ``F = 𝔄 − Kℭ``, with the grid safeguard (``inf`` when ``F`` is not Hurwitz)."""
    F = Ae - K @ Ce
    return float(hinf_norm(F, Bd, np.eye(F.shape[0]), np.zeros((F.shape[0], Bd.shape[1])), grid=True))


def design_cascade_gain(
    sigma2: LinearSubsystem | Sequence[ArrayLike],
    *,
    gamma: float,
    N: ArrayLike | None = None,
    gamma_n: float | None = None,
    region: PoleRegion | Sequence[PoleRegion] | None = None,
    gain_bound: GainBound | float | None = None,
    objective: Objective | str = Objective.CENTRAL,
    solver: Solver | str = Solver.CLARABEL,
    margin: float = 1e-6,
    check_assumptions: bool = True,
    method: str = "auto",
) -> ObserverGainCertificate:
    r"""Design ``K = [K_w; K_z]`` for the extended system (8c) from LMIs (14)–(15), certified.

    Checks Assumption 4 first (:func:`~nlobs.linear.assumption4.require_assumption4`),
    then calls :func:`nlobs.synthesis.design_observer_gain` on ``(𝔄, ℭ, 𝔅_d)``.

    Parameters
    ----------
    sigma2 : LinearSubsystem or tuple (A, B_z, C[, D_z])
    gamma : float
        ``‖H‖∞ < γ`` (Theorem 1; see :func:`~nlobs.synthesis.cascade_bounds.theorem1_gamma_bound`).
    N, gamma_n, region, gain_bound, objective, solver, margin, method
        As in :func:`nlobs.synthesis.design_observer_gain` (``method="auto"``: the Riccati path for
        the central design with ``gamma_n`` and neither region nor gain bound, else the SDP). The default
        ``Objective.CENTRAL`` needs ``gamma_n`` or ``gain_bound`` (a well-posed
        problem, see ``docs/synthesis.md``).
    check_assumptions : bool
        Raise :class:`~nlobs.errors.AssumptionViolated` if Assumption 4 fails
        (default). ``False`` skips the check (the LMIs may still succeed, e.g.
        for an invariant zero at the origin that is not unobservable).

    Returns
    -------
    ObserverGainCertificate

    Raises
    ------
    AssumptionViolated
        Assumption 4 fails (the item is named).
    DesignInfeasible, DesignUnbounded, CertificateError
        From the LMI design.

    Examples
    --------
    The filter Σ₂ = 1/(s² + s + 1) of Example 1 (Grip, Saberi & Johansen, Sec. 4), as ``(A, B_z, C)``;
    ``K`` stacks ``K_w`` (two rows) and ``K_z`` (one row) for the extended system (8c):

    >>> import numpy as np
    >>> sigma2 = ([[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> cert = design_cascade_gain(sigma2, gamma=1.0, gamma_n=10.0)
    >>> cert.verified, cert.gain.shape, cert.method.value
    (True, (3, 1), 'riccati')
    >>> bool(cert.hinf_H < 1.0 and cert.eigenvalues.real.max() < 0)  # (13) below γ, 𝔄 − Kℭ Hurwitz
    True
    """
    s2 = as_linear_subsystem(sigma2)
    if check_assumptions:
        require_assumption4(s2.A, s2.B_z, s2.C, s2.D_z)
    ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
    return design_observer_gain(
        ext.A, ext.C, ext.Bd, gamma=gamma, N=N, gamma_n=gamma_n, region=region, gain_bound=gain_bound,
        objective=objective, solver=solver, margin=margin, method=method,
    )


def _default_poles(n: int) -> Array:
    """Unit-radius Butterworth pattern, ``exp(j(π/2 + (2k + 1)π/(2n)))``, distinct."""
    out: list[complex] = []
    for k in range(n // 2):
        theta = np.pi / 2 + (2 * k + 1) * np.pi / (2 * n)
        c, s = math.cos(theta), math.sin(theta)
        out += [complex(c, s), complex(c, -s)]
    if n % 2:
        out.append(complex(-1.0, 0.0))
    return np.array(out, dtype=complex)




def place_cascade_gain(
    sigma2: LinearSubsystem | Sequence[ArrayLike],
    *,
    gamma: float,
    poles: ArrayLike | None = None,
    omega_max: float = 1e6,
    check_assumptions: bool = True,
) -> ObserverGainCertificate:
    r"""A gain with ``‖H‖∞ < γ`` by pole placement at ``ω·p₀``, ``ω`` found by search.

    For the very small ``γ`` of Theorem 1 (often ``< 10⁻³``) the LMI (14) cannot
    be solved reliably: with the strictness margin ``ε`` its smallest
    achievable ``γ`` is about ``ε^{1/4}`` (measured: 0.031 for ``ε = 10⁻⁶`` on
    Example 1). Theorem 1 itself only needs ``𝔄 − Kℭ`` Hurwitz and
    ``‖H‖∞ < γ``, which this function checks directly: it places the
    eigenvalues of ``𝔄 − Kℭ`` at ``ω p₀`` (:func:`scipy.signal.place_poles` on
    the dual pair) and doubles ``ω`` until ``‖H‖∞ < γ`` (Bruinsma–Steinbuch,
    :func:`nlobs.linear.hinf_norm`, with the grid safeguard
    :func:`nlobs.linear.hinf_grid_peak`: a missed peak would certify a gain that
    violates the bound), then bisects ``ω`` down to the smallest value found that
    still satisfies it.

    When Σ₂ is minimum phase and left-invertible with all infinite zeros of the
    same order (e.g. SISO), ``‖H‖∞ → 0`` as ``ω → ∞``; otherwise the search may
    fail, and the function says so.

    Parameters
    ----------
    sigma2 : LinearSubsystem or tuple (A, B_z, C[, D_z])
    gamma : float
    poles : array_like of complex, shape (n_w + p_z,), optional
        Pattern ``p₀`` (conjugate-closed, in the open left half-plane);
        default: unit Butterworth.
    omega_max : float
        Largest scale tried.
    check_assumptions : bool
        Check Assumption 4 first.

    Returns
    -------
    ObserverGainCertificate
        ``P = None``; checks: Hurwitz spectrum and ``‖H‖∞ < γ``;
        ``solver_status`` records ``ω``.

    Raises
    ------
    AssumptionViolated
        Assumption 4 fails.
    DesignError
        No ``ω ≤ omega_max`` gives ``‖H‖∞ < γ``, or placement fails (e.g. an
        unobservable extended pair).

    Examples
    --------
    The filter Σ₂ = 1/(s² + s + 1) of Example 1 (Grip, Saberi & Johansen, Sec. 4) at ``γ = 0.5``: the
    unit Butterworth pattern of the three poles of ``𝔄 − Kℭ`` is scaled until ``‖H‖∞ < γ``:

    >>> import numpy as np
    >>> sigma2 = ([[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> cert = place_cascade_gain(sigma2, gamma=0.5)
    >>> cert.verified, cert.gain.shape, cert.P is None, cert.solver_status
    (True, (3, 1), True, 'pole placement at ω = 4.10156 × pattern')
    >>> bool(cert.hinf_H < 0.5), np.round(np.abs(cert.eigenvalues), 2).tolist()  # |λ| = ω for each pole
    (True, [4.1, 4.1, 4.1])
    """
    t0 = _time.perf_counter()
    s2 = as_linear_subsystem(sigma2)
    g = positive("gamma", gamma)
    if check_assumptions:
        require_assumption4(s2.A, s2.B_z, s2.C, s2.D_z)
    ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
    ne = ext.A.shape[0]
    p0 = _default_poles(ne) if poles is None else np.asarray(poles, dtype=complex).ravel()
    if p0.shape != (ne,):
        raise DimensionError(f"poles: expected {ne} poles, got {p0.shape[0]}")
    if np.any(p0.real >= 0):
        raise InvalidArgumentError("poles: every pole of the pattern must have a negative real part")

    def gain(om: float) -> Array:
        try:
            res = scipy.signal.place_poles(ext.A.T, ext.C.T, om * p0)
        except (ValueError, np.linalg.LinAlgError) as exc:
            raise DesignError(f"pole placement failed at ω = {om:g}: {exc}") from exc
        return np.asarray(res.gain_matrix, dtype=float).T

    om, K = 1.0, gain(1.0)
    hH = _hinf_H(ext.A, ext.C, ext.Bd, K)
    lo = 0.0
    while not hH < g:
        lo = om
        om *= 2.0
        if om > omega_max:
            raise DesignError(
                f"no pole scale ω ≤ {omega_max:g} gives ‖H‖∞ < γ = {g:g} (last: ‖H‖∞ = {hH:.4g} at ω = {lo:g}); "
                "Σ2 may not be minimum phase (Theorem 2: γ* > 0), or try another pole pattern"
            )
        K = gain(om)
        hH = _hinf_H(ext.A, ext.C, ext.Bd, K)
    hi = om
    for _ in range(40):  # bisection on the smallest ω that meets the bound
        if hi - lo <= 1e-3 * hi:
            break
        mid = 0.5 * (lo + hi)
        Km = gain(mid)
        hm = _hinf_H(ext.A, ext.C, ext.Bd, Km)
        if hm < g:
            hi, K, hH = mid, Km, hm
        else:
            lo = mid
    eig = np.linalg.eigvals(ext.A - K @ ext.C)
    eig = eig[np.lexsort((eig.imag, eig.real))]
    checks = (
        Check.compare("max Re λ(𝔄 − Kℭ) < 0", float(np.max(eig.real)), 0.0, kind=CheckKind.SPECTRUM),
        Check.compare("‖H‖∞ < γ", float(hH), g, kind=CheckKind.NORM),
    )
    ok = all(c.passed for c in checks)
    cert = ObserverGainCertificate(
        gain=readonly(K), P=None, gamma=g, gamma_n=None, hinf_H=float(hH), hinf_G=None,
        eigenvalues=readonly(eig, complex), checks=checks, objective=None, solver=None,
        solver_status=f"pole placement at ω = {hi:.6g} × pattern", margin=0.0,
        seconds=_time.perf_counter() - t0,
    )
    if not ok:
        raise DesignError("pole placement: " + "; ".join(c.summary() for c in cert.failed_checks))
    return cert
