r"""The gain of a Thau observer certified on a region: vertex LMIs of the Jacobian box.

The observer (Thau, Int. J. Control 17(3), 1973) is the copy of the plant with constant output injection,

.. math:: \dot{\hat x} = F(\hat x, u) + L\,(y - h(\hat x)) ,

and its error ``e = x̂ − x`` obeys ``ė = (J̄_F − L J̄_h) e`` where, by the differential mean value theorem, the
rows of ``J̄_F``, ``J̄_h`` are those of ``∂F/∂x``, ``∂h/∂x`` at points of the segment from ``x`` to ``x̂``
(:mod:`nlobs.geometry.jacobian_box`; Zemouche, Boutayeb & Bara, Systems & Control Letters 57, 2008). When
both stay in a convex region where the Jacobians lie in a matrix box, ``V = eᵀPe`` satisfies
``V̇ ≤ −2αV`` for every such error as soon as, at every vertex ``(A_v, C_v)`` of the box,

.. math:: A_v^\top P + P A_v - C_v^\top Y^\top - Y C_v + 2\alpha P \preceq 0, \qquad Y = P L ,\ P \succeq I \qquad (V)

(affine in the box's entries, so its vertices suffice). This is (1) of :mod:`nlobs.synthesis.sampled_data`
with ``K = L``, so the sampling budget and the noise bound of that module apply to it.

Among the gains satisfying (V) at a given ``α``, :func:`design_thau_gain` takes the one that makes the noise
terms of the mean-square bound small: it minimises ``tr(R Lᵀ P L)/α + tr(P W Wᵀ)`` (a Schur complement in
``Y``), ``R`` the covariance of a sample's noise and ``W Wᵀ`` the process-noise intensity.
:func:`certify_thau_gain` finds, for a gain given (e.g. a Kalman gain), the ``P`` of (V) with the same
objective. Either certificate is re-verified in NumPy (:func:`verify_thau_gain`): ``L`` and ``P`` are
read back, every vertex block is recomputed, and the certified decay rate is
``α = min_v −λ_max(P^{−1/2}(M_vᵀP + P M_v)P^{−1/2}) / 2`` with ``M_v = A_v − L C_v``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import positive
from nlobs.checks import Check, CheckKind
from nlobs.errors import DesignInfeasible, InvalidArgumentError
from nlobs.synthesis.certificate import CertificateMixin, checks_dict
from nlobs.synthesis.lmi import Solver, as_solver, psd_sqrt, solve, symmetrise

__all__ = ["ThauGainCertificate", "VertexLMIs", "certified_decay", "certify_thau_gain", "design_thau_gain", "verify_thau_gain"]

#: Most vertices the LMIs (V) are written at (``2^k`` for ``k`` varying Jacobian entries).
MAX_VERTICES = 1024


def _pairs(vertices: Sequence[tuple[ArrayLike, ArrayLike]]) -> tuple[tuple[Array, Array], ...]:
    out = []
    for A, C in vertices:
        Am, Cm = np.asarray(A, dtype=float), np.asarray(C, dtype=float)
        if Am.ndim != 2 or Am.shape[0] != Am.shape[1] or Cm.ndim != 2 or Cm.shape[1] != Am.shape[0]:
            raise InvalidArgumentError(f"vertices: expected (A (n, n), C (p, n)) pairs, got {Am.shape}, {Cm.shape}")
        if not (np.all(np.isfinite(Am)) and np.all(np.isfinite(Cm))):
            raise InvalidArgumentError("vertices: non-finite entries")
        out.append((Am, Cm))
    if not out:
        raise InvalidArgumentError("vertices: none given")
    if len(out) > MAX_VERTICES:
        raise InvalidArgumentError(f"vertices: {len(out)} > {MAX_VERTICES} (too many varying Jacobian entries for "
                                   "the vertex LMIs; shrink the region)")
    if len({(a.shape, c.shape) for a, c in out}) != 1:
        raise InvalidArgumentError("vertices: the pairs differ in shape")
    return tuple(out)


def certified_decay(P: ArrayLike, L: ArrayLike, vertices: Sequence[tuple[ArrayLike, ArrayLike]]) -> float:
    """The decay rate ``α`` that ``P`` certifies for ``L`` at every vertex (module docstring); NumPy only.

    Parameters
    ----------
    P : array_like, shape (n, n)
        A positive definite matrix.
    L : array_like, shape (n, p)
        The gain.
    vertices : sequence of (A, C)
        The vertices of the Jacobian box.

    Returns
    -------
    float
        ``min_v −λ_max(P^{−1/2}(M_vᵀP + P M_v)P^{−1/2}) / 2`` (``−inf`` when ``P`` is not positive definite).
    """
    Pm, Lm = np.asarray(P, dtype=float), np.asarray(L, dtype=float)
    Pm = (Pm + Pm.T) / 2
    w, V = np.linalg.eigh(Pm)
    if w[0] <= 0:
        return -math.inf
    Si = (V / np.sqrt(w)) @ V.T
    worst = math.inf
    for A, C in _pairs(vertices):
        M = A - Lm @ C
        B = Si @ (M.T @ Pm + Pm @ M) @ Si
        worst = min(worst, -float(np.linalg.eigvalsh((B + B.T) / 2)[-1]) / 2)
    return worst


@dataclass(frozen=True, eq=False)
class ThauGainCertificate(CertificateMixin):
    """A Thau gain with the ``P`` of the vertex LMIs (V) (module docstring).

    Attributes
    ----------
    gain : ndarray, shape (n, p)
        ``L``.
    P : ndarray, shape (n, n)
        The Lyapunov matrix.
    alpha : float
        The decay rate asked of the design.
    decay : float
        The decay rate ``P`` certifies, recomputed in NumPy (:func:`certified_decay`).
    vertices : tuple of (ndarray, ndarray)
        The vertices ``(A_v, C_v)`` of the Jacobian box.
    solver : Solver or None
        The solver that found ``P`` (and ``L``).
    checks : tuple of Check
        ``P ≻ 0`` and (V) at every vertex, recomputed.
    """

    gain: Array
    P: Array
    alpha: float
    decay: float
    vertices: tuple[tuple[Array, Array], ...]
    solver: Solver | None
    checks: tuple[Check, ...]

    def summary(self) -> str:
        """The gain, the decay and the checks."""
        lines = [f"Thau gain on {len(self.vertices)} vertices: L = {np.round(self.gain, 6).tolist()}, "
                 f"certified decay α = {self.decay:.4g}"]
        lines += [f"  [{'ok' if c.passed else 'FAIL'}] {c.name}: {c.evidence}" for c in self.checks]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view."""
        return {"gain": self.gain.tolist(), "P": self.P.tolist(), "alpha": self.alpha, "decay": self.decay,
                "vertices": len(self.vertices), "solver": None if self.solver is None else self.solver.value,
                "verified": self.verified, "checks": checks_dict(self.checks)}


def _checks(P: Array, L: Array, vertices: tuple[tuple[Array, Array], ...], alpha: float) -> tuple[float, tuple[Check, ...]]:
    lam = float(np.linalg.eigvalsh((P + P.T) / 2)[0])
    decay = certified_decay(P, L, vertices) if lam > 0 else -math.inf
    return decay, (
        Check.compare("P ≻ 0", -lam, 0.0, kind=CheckKind.POSITIVITY, evidence=f"λ_min(P) = {lam:.4g}"),
        Check.compare(f"(V) at the {len(vertices)} vertices of the Jacobian box: decay α > 0", -decay, 0.0,
                      kind=CheckKind.LMI, evidence=f"certified α = {decay:.4g} (asked {alpha:.4g})",
                      values={"decay": decay, "alpha": alpha, "vertices": len(vertices)}))


def verify_thau_gain(cert: ThauGainCertificate) -> ThauGainCertificate:
    """Recompute the checks of ``cert`` from its ``L``, ``P`` and vertices (NumPy only).

    Parameters
    ----------
    cert : ThauGainCertificate
        A certificate (from :func:`design_thau_gain`, :func:`certify_thau_gain` or built by hand).

    Returns
    -------
    ThauGainCertificate
        With ``decay`` and ``checks`` recomputed.
    """
    decay, checks = _checks(cert.P, cert.gain, cert.vertices, cert.alpha)
    return ThauGainCertificate(cert.gain, cert.P, cert.alpha, decay, cert.vertices, cert.solver, checks)


def _objective_parts(n: int, p: int, R: ArrayLike | None, process: ArrayLike | None) -> tuple[Array, Array]:
    Rm = np.zeros((p, p)) if R is None else np.asarray(R, dtype=float)
    Wm = np.zeros((n, n)) if process is None else np.asarray(process, dtype=float)
    if Rm.shape != (p, p) or Wm.shape != (n, n) or not (np.all(np.isfinite(Rm)) and np.all(np.isfinite(Wm))):
        raise InvalidArgumentError(f"R, process: expected finite ({p}, {p}) and ({n}, {n}) matrices")
    scale = max(float(np.trace(Rm)), 1e-300)
    # a floor on R keeps the gain bounded when the outputs are exact (nothing else would penalise it)
    Rm = (Rm + Rm.T) / 2 + 1e-9 * scale * np.eye(p) if np.trace(Rm) > 0 else np.eye(p) * 1e-6
    return Rm, (Wm + Wm.T) / 2



def design_thau_gain(vertices: Sequence[tuple[ArrayLike, ArrayLike]], alpha: float, *, R: ArrayLike | None = None,
                     process: ArrayLike | None = None, objective: str = "noise",
                     rate_vertices: Sequence[ArrayLike] = (),
                     solver: Solver | str = Solver.CLARABEL) -> ThauGainCertificate:
    """The gain of (V) at decay ``α`` with the smallest noise terms, or the smallest ``‖P^{1/2}L‖`` (module docstring).

    Parameters
    ----------
    vertices : sequence of (A, C)
        The vertices of the Jacobian box of ``(∂F/∂x, ∂h/∂x)``.
    alpha : float
        The decay rate, ``> 0``.
    R : array_like, shape (p, p), optional
        Covariance of a sample's measurement noise (default: a small multiple of the identity).
    process : array_like, shape (n, n), optional
        ``W Wᵀ``.
    objective : {"noise", "sampling"}
        ``"noise"``: minimise ``tr(R Lᵀ P L)/α + tr(P W Wᵀ)``; ``"sampling"``: minimise ``‖P^{1/2} L‖₂²`` (with
        ``P ⪰ I``), which makes the longest sampling period of the bound of :mod:`nlobs.synthesis.sampled_data`,
        ``α / (‖P^{1/2}L‖ ℓ)``, large (a slow gain for sparse or interrupted samples).
    rate_vertices : sequence of array_like, shape (p, n)
        With ``objective="sampling"``: the vertices ``G_v`` of the Jacobian box of ``L_F h``; ``P ⪰ G_vᵀG_v`` then
        makes ``ℓ = max_v ‖G_v P^{−1/2}‖ ≤ 1``, so that the minimised ``‖P^{1/2}L‖`` is ``α / T_max`` itself.
    solver : Solver or str
        Clarabel (default) or SCS.

    Returns
    -------
    ThauGainCertificate

    Raises
    ------
    DesignInfeasible
        (V) has no solution at this ``α`` (the solver's status says why).
    """
    if objective not in ("noise", "sampling"):
        raise InvalidArgumentError(f"objective: expected 'noise' or 'sampling', got {objective!r}")
    return VertexLMIs(vertices, R=R, process=process, objective=objective, rate_vertices=rate_vertices,
                      solver=solver).solve(alpha)


class VertexLMIs:
    """(V) and its objective compiled once, solved for any ``α`` (a CVXPY parameter: the α grid of a tuning
    re-solves without re-canonicalising).

    Parameters
    ----------
    vertices, R, process, objective, rate_vertices, solver
        As :func:`design_thau_gain`.
    """

    def __init__(self, vertices: Sequence[tuple[ArrayLike, ArrayLike]], *, R: ArrayLike | None = None,
                 process: ArrayLike | None = None, objective: str = "noise", rate_vertices: Sequence[ArrayLike] = (),
                 solver: Solver | str = Solver.CLARABEL) -> None:
        import cvxpy as cp

        if objective not in ("noise", "sampling"):
            raise InvalidArgumentError(f"objective: expected 'noise' or 'sampling', got {objective!r}")
        self.pairs = pairs = _pairs(vertices)
        n, p = pairs[0][0].shape[0], pairs[0][1].shape[0]
        Rm, Wm = _objective_parts(n, p, R, process)
        Rh = psd_sqrt(Rm)
        self.solver = as_solver(solver)
        self.alpha = cp.Parameter(nonneg=True)
        self.inv_alpha = cp.Parameter(nonneg=True)
        self.P = P = cp.Variable((n, n), symmetric=True)
        self.Y = Y = cp.Variable((n, p))
        Z = cp.Variable((p, p), symmetric=True)
        cons = [P >> np.eye(n), cp.bmat([[Z, Rh @ Y.T], [Y @ Rh, P]]) >> 0]
        for A, C in pairs:
            cons.append(symmetrise(A.T @ P + P @ A - C.T @ Y.T - Y @ C + 2 * self.alpha * P) << 0)
        noise = self.inv_alpha * cp.trace(Z) + cp.trace(P @ Wm) + 1e-9 * cp.trace(P)
        if objective == "sampling":
            k2 = cp.Variable(nonneg=True)
            cons.append(cp.bmat([[k2 * np.eye(p), Y.T], [Y, P]]) >> 0)
            for G in rate_vertices:
                Gm = np.asarray(G, dtype=float)
                cons.append(P >> Gm.T @ Gm)
            obj = cp.Minimize(k2 + 1e-6 * noise)
        else:
            obj = cp.Minimize(noise)
        self.problem = cp.Problem(obj, cons)

    def solve(self, alpha: float) -> ThauGainCertificate:
        """The gain of (V) at decay ``alpha`` (raises :class:`DesignInfeasible` without one).

        Parameters
        ----------
        alpha : float
            The decay rate, ``> 0``.
        """
        a = positive("alpha", alpha)
        self.alpha.value, self.inv_alpha.value = a, 1.0 / a
        result = solve(self.problem, self.solver)
        P, Y = self.P, self.Y
        if not result.status.has_solution or P.value is None or Y.value is None:
            raise DesignInfeasible(f"(V) at {len(self.pairs)} vertices with decay α = {a:g}: {result.raw_status}",
                                   constraint="(V)" if result.status.is_infeasible else "")
        Pv = (np.asarray(P.value) + np.asarray(P.value).T) / 2
        L = np.linalg.solve(Pv, np.asarray(Y.value))
        decay, checks = _checks(Pv, L, self.pairs, a)
        return ThauGainCertificate(L, Pv, a, decay, self.pairs, result.solver, checks)


def certify_thau_gain(vertices: Sequence[tuple[ArrayLike, ArrayLike]], L: ArrayLike, alpha: float, *,
                      R: ArrayLike | None = None, process: ArrayLike | None = None,
                      solver: Solver | str = Solver.CLARABEL) -> ThauGainCertificate:
    """The ``P`` of (V) for a given gain ``L`` at decay ``α``, with the smallest noise terms.

    Parameters
    ----------
    vertices : sequence of (A, C)
        The vertices of the Jacobian box.
    L : array_like, shape (n, p)
        The gain.
    alpha : float
        The decay rate, ``> 0``.
    R, process, solver
        As :func:`design_thau_gain`.

    Returns
    -------
    ThauGainCertificate

    Raises
    ------
    DesignInfeasible
        No ``P`` proves (V) for this ``L`` at this ``α``.
    """
    import cvxpy as cp

    pairs = _pairs(vertices)
    n, p = pairs[0][0].shape[0], pairs[0][1].shape[0]
    Lm = np.asarray(L, dtype=float)
    if Lm.shape != (n, p) or not np.all(np.isfinite(Lm)):
        raise InvalidArgumentError(f"L: expected a finite ({n}, {p}) matrix, got shape {Lm.shape}")
    a = positive("alpha", alpha)
    Rm, Wm = _objective_parts(n, p, R, process)
    P = cp.Variable((n, n), symmetric=True)
    cons = [P >> np.eye(n)]
    for A, C in pairs:
        M = A - Lm @ C
        cons.append(symmetrise(M.T @ P + P @ M + 2 * a * P) << 0)
    obj = cp.Minimize(cp.trace(P @ (Lm @ Rm @ Lm.T)) / a + cp.trace(P @ Wm) + 1e-9 * cp.trace(P))
    result = solve(cp.Problem(obj, cons), as_solver(solver))
    if not result.status.has_solution or P.value is None:
        raise DesignInfeasible(f"(V) for the given gain at {len(pairs)} vertices with decay α = {a:g}: "
                               f"{result.raw_status}")
    Pv = (np.asarray(P.value) + np.asarray(P.value).T) / 2
    decay, checks = _checks(Pv, Lm, pairs, a)
    return ThauGainCertificate(Lm, Pv, a, decay, pairs, result.solver, checks)
