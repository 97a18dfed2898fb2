r"""The gain of the impulsive Thau observer and its clock-dependent certificate under one sensor group.

The error of the impulsive observer (:mod:`nlobs.observers.impulsive`) with samples every ``T_0`` to ``T`` time
units (``T_0`` the sensor's period, ``T`` its longest gap), while the state and the estimate stay in a region whose
Jacobian box has the vertices ``A_v`` (of ``∂F/∂x``) and ``C_w`` (of ``∂h/∂x``), is the hybrid system

.. math:: \dot e = \bar J_F\, e, \qquad e^+ = (I - L \bar J_h)\, e - L v

(differential mean value theorem; Zemouche, Boutayeb & Bara 2008). A clock-dependent Lyapunov function
``V = eᵀ P(τ) e`` (Briat, Automatica 49(11), 2013), ``P`` piecewise linear in the time ``τ`` since the last sample
on nodes ``0 = τ_0 < … < τ_K = T_0 (≤ τ_{K+1} = T)``, proves

.. math::

    \dot P + A_v^\top P(\tau) + P(\tau) A_v + 2\alpha P(\tau) \preceq 0 \ \ (\text{both ends of each segment}),
    \qquad
    \begin{bmatrix} P(\tau) & (P_0 - Y C_w)^\top \\ P_0 - Y C_w & P_0 \end{bmatrix} \succeq 0
    \ \ (\tau \in \{T_0, T\}),

``Y = P_0 L`` (the jump ``(I − LC)ᵀP_0(I − LC) ⪯ P(τ)`` by a Schur complement: convex in ``(P, Y)``), with
``P(τ) ⪰ I``. Noise: a sample adds ``tr(Lᵀ P_0 L R)`` to ``E V`` (``R`` the sample's covariance; the cross term has
zero mean), the process noise at most ``c = max_k tr(Wᵀ P_k W)`` per unit time, and samples are ``≥ T_0`` apart:

.. math::

    E|e(t)|^2 \le e^{-2\alpha t}\operatorname{tr}(P(T_0)\Sigma_0) + \frac{c}{2\alpha}
        + \frac{\operatorname{tr}(L^\top P_0 L R)}{1 - e^{-2\alpha T_0}} . \qquad (B)

Bounded noise (input-to-state): with no process noise and every sample's noise ``|v| ≤ v̄`` (a bias included),
Young's inequality on the jump gives ``V⁺ ≤ (1+ε) V⁻ + (1+1/ε) ‖P_0^{1/2}L‖² v̄²`` and the flow
``V⁻ ≤ e^{−2αT_0} V⁺`` of the previous sample; the best ``ε`` and ``P ⪰ I`` (``|e|² ≤ V``) give

.. math:: \limsup_{t\to\infty} |e(t)| \le \frac{‖P_0^{1/2} L‖_2}{1 - e^{-\alpha T_0}}\, \bar v . \qquad (I)

:func:`design_impulsive_gain` finds ``L`` and ``P`` making (B) after the settling time smallest (an SDP);
:func:`verify_impulsive_gain` recomputes every block and number in NumPy.
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
from nlobs.synthesis.sampled_clock import MARGIN, ClockGroup

__all__ = ["ImpulsiveCertificate", "ImpulsiveSDP", "design_impulsive_gain", "verify_impulsive_gain"]


def _times(group: ClockGroup, segments: int) -> tuple[float, ...]:
    ts = tuple(float(v) for v in np.linspace(0.0, group.period, segments + 1))
    return ts + ((float(group.gap),) if group.gap > group.period * (1 + 1e-12) else ())



@dataclass(frozen=True, eq=False)
class ImpulsiveCertificate(CertificateMixin):
    """The jump gain ``L`` with the clock-dependent ``P(τ)`` that proves it (module docstring).

    Attributes
    ----------
    gain : ndarray, shape (n, p)
        ``L``.
    nodes : tuple of ndarray
        ``P`` at :attr:`times`.
    times : tuple of float
        The nodes ``τ_k``.
    alpha : float
        The decay rate.
    A_vertices, C_vertices : tuple of ndarray
        The vertices of ``∂F/∂x`` and of ``∂h/∂x``.
    group : ClockGroup
        The sensor group (its period, longest gap and noise).
    process : ndarray
        ``W Wᵀ``.
    p0 : ndarray or None
        Covariance of the initial error.
    settle : float
        The time after which :attr:`rms_bound` holds.
    solver : Solver or None
    checks : tuple of Check
    c, jump, v0 : float
        The numbers of (B).
    """

    gain: Array
    nodes: tuple[Array, ...]
    times: tuple[float, ...]
    alpha: float
    A_vertices: tuple[Array, ...]
    C_vertices: tuple[Array, ...]
    group: ClockGroup
    process: Array
    p0: Array | None
    settle: float
    solver: Solver | None
    checks: tuple[Check, ...]
    c: float
    jump: float
    v0: float

    @property
    def P(self) -> Array:  # noqa: N802 - the papers' symbol
        """``P(0)``, after a sample."""
        return self.nodes[0]

    @property
    def groups(self) -> tuple[ClockGroup, ...]:
        """The one sensor group."""
        return (self.group,)

    @property
    def t_max(self) -> tuple[float, ...]:
        """The longest gap the certificate covers."""
        return (self.group.gap,)

    @property
    def budget(self) -> float:
        """1 by construction (the certificate is for the gaps themselves)."""
        return 1.0 if self.verified else math.inf

    @property
    def ultimate_ms(self) -> float:
        """``limsup E|e|²`` of (B)."""
        if not self.verified:
            return math.inf
        a2 = 2 * self.alpha
        return self.c / a2 + self.jump / (1 - math.exp(-a2 * self.group.period))

    def ms_after(self, settle: float, p0: ArrayLike | None = None) -> float:
        """(B) for every ``t ≥ settle`` and an initial error of covariance ``p0`` (default the certificate's).

        Parameters
        ----------
        settle : float
        p0 : array_like, optional
        """
        if not self.verified:
            return math.inf
        v0 = self.v0 if p0 is None else float(np.trace(self._p_first() @ np.asarray(p0, dtype=float)))
        return math.exp(-2 * self.alpha * max(float(settle), 0.0)) * v0 + self.ultimate_ms

    def rms_after(self, settle: float, p0: ArrayLike | None = None) -> float:
        """``√`` of :meth:`ms_after`.

        Parameters
        ----------
        settle : float
        p0 : array_like, optional
        """
        return math.sqrt(self.ms_after(settle, p0))

    @property
    def rms_bound(self) -> float:
        """The RMS bound after :attr:`settle`."""
        return self.rms_after(self.settle)

    @property
    def iss_gain(self) -> float:
        """``γ`` of (I): ``limsup |e| ≤ γ v̄`` for sample noise bounded by ``v̄`` and no process noise."""
        if not self.verified:
            return math.inf
        Lj = self.gain[:, list(self.group.index)]
        return float(np.linalg.norm(psd_sqrt(self.nodes[0]) @ Lj, 2)) / (1 - math.exp(-self.alpha * self.group.period))

    def ultimate_bound(self, noise_bound: float) -> float:
        """(I): the ultimate bound on ``|e|`` when every sample's noise (bias included) has norm ``≤ noise_bound``.

        Parameters
        ----------
        noise_bound : float
            ``v̄ ≥ 0``.
        """
        v = float(noise_bound)
        if not math.isfinite(v) or v < 0:
            raise InvalidArgumentError(f"`noise_bound`: expected a non-negative finite number, got {noise_bound!r}")
        return self.iss_gain * v

    def _p_first(self) -> Array:
        """``P(T_0)``: the first sample at ``t = 0`` is a jump from it."""
        return self.nodes[self.times.index(min(self.times, key=lambda t: abs(t - self.group.period)))]

    def violation(self) -> str | None:
        """Which inequality fails (``None`` when verified)."""
        return None if self.verified else "; ".join(f"{c.name}: {c.evidence}" for c in self.failed_checks)

    def summary(self) -> str:
        """The gain, the decay, the noise terms and the checks."""
        lines = [f"impulsive observer: L = {np.round(self.gain, 6).tolist()}, α = {self.alpha:.4g}, samples every "
                 f"{self.group.period:.4g} (gaps ≤ {self.group.gap:.4g}); RMS bound after t = {self.settle:g}: "
                 f"{self.rms_bound:.4g}; bounded noise |v| ≤ v̄: limsup |e| ≤ {self.iss_gain:.4g} v̄"]
        lines += [f"  [{'ok' if c.passed else 'FAIL'}] {c.name}: {c.evidence}" for c in self.checks]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view."""
        return {"kind": "impulsive", "gain": self.gain.tolist(), "alpha": self.alpha, "c": self.c, "jump": self.jump,
                "v0": self.v0, "settle": self.settle, "rms_bound": self.rms_bound if self.verified else None,
                "iss_gain": self.iss_gain if self.verified else None,
                "groups": [{"name": self.group.name, "gap": self.group.gap, "period": self.group.period}],
                "verified": self.verified, "checks": checks_dict(self.checks)}


def _checks(nodes: Sequence[Array], times: Sequence[float], L: Array, alpha: float, A_vertices: Sequence[Array],
            C_vertices: Sequence[Array], group: ClockGroup) -> tuple[Check, ...]:
    n = L.shape[0]
    scale = max(1.0, *(float(np.abs(P).max()) for P in nodes))
    tol = 1e-9 * scale
    pos = min(float(np.linalg.eigvalsh((P + P.T) / 2 - np.eye(n))[0]) for P in nodes)
    flow = -math.inf
    for k in range(len(nodes) - 1):
        dP = (nodes[k + 1] - nodes[k]) / (times[k + 1] - times[k])
        for P in (nodes[k], nodes[k + 1]):
            for A in A_vertices:
                S = dP + A.T @ P + P @ A + 2 * alpha * P
                flow = max(flow, float(np.linalg.eigvalsh((S + S.T) / 2)[-1]))
    jump = -math.inf
    P0 = nodes[0]
    for k, t in enumerate(times):
        if t < group.period * (1 - 1e-12):
            continue
        for C in C_vertices:
            E = np.eye(n) - L @ C
            S = E.T @ P0 @ E - nodes[k]
            jump = max(jump, float(np.linalg.eigvalsh((S + S.T) / 2)[-1]))
    segs = len(nodes) - 1
    return (
        Check.compare("P(τ) ⪰ I at every node", -pos, tol, kind=CheckKind.POSITIVITY, strict=False,
                      evidence=f"λ_min(P(τ) − I) = {pos:.4g} at worst ({len(nodes)} nodes)"),
        Check.compare(f"flow: decay 2α between samples ({segs} segments × {len(A_vertices)} vertices)", flow, tol,
                      kind=CheckKind.LMI, strict=False,
                      evidence=f"largest eigenvalue {flow:.4g} ≤ {tol:.3g} (α = {alpha:.4g})"),
        Check.compare(f"jump: (I − LC)ᵀP(0)(I − LC) ⪯ P(τ) for gaps in [{group.period:.4g}, {group.gap:.4g}] "
                      f"({len(C_vertices)} vertices of ∂h/∂x)", jump, tol, kind=CheckKind.LMI, strict=False,
                      evidence=f"largest eigenvalue {jump:.4g} ≤ {tol:.3g}"),
    )


def _numbers(nodes: Sequence[Array], times: Sequence[float], L: Array, group: ClockGroup, process: Array,
             p0: Array | None) -> tuple[float, float, float]:
    W = psd_sqrt(process)
    c = max(float(np.trace(W.T @ P @ W)) for P in nodes) if np.any(process) else 0.0
    cols = list(group.index)
    Lj = L[:, cols]
    jump = float(np.trace(Lj.T @ nodes[0] @ Lj @ group.R))
    first = nodes[times.index(min(times, key=lambda t: abs(t - group.period)))]
    v0 = float(np.trace(first @ p0)) if p0 is not None else 0.0
    return c, jump, v0


def verify_impulsive_gain(cert: ImpulsiveCertificate) -> ImpulsiveCertificate:
    """Recompute the checks and the numbers of (B) from ``cert``'s matrices (NumPy only).

    Parameters
    ----------
    cert : ImpulsiveCertificate
    """
    checks = _checks(cert.nodes, cert.times, cert.gain, cert.alpha, cert.A_vertices, cert.C_vertices, cert.group)
    c, jump, v0 = _numbers(cert.nodes, cert.times, cert.gain, cert.group, cert.process, cert.p0)
    return ImpulsiveCertificate(cert.gain, cert.nodes, cert.times, cert.alpha, cert.A_vertices, cert.C_vertices,
                                cert.group, cert.process, cert.p0, cert.settle, cert.solver, checks, c, jump, v0)


def design_impulsive_gain(A_vertices: Sequence[ArrayLike], C_vertices: Sequence[ArrayLike], alpha: float,
                          group: ClockGroup, *, process: ArrayLike | None = None, p0: ArrayLike | None = None,
                          settle: float = 0.0, segments: int = 4,
                          solver: Solver | str = Solver.CLARABEL) -> ImpulsiveCertificate:
    """``L`` and ``P(τ)`` of the module's LMIs making the bound (B) after ``settle`` smallest.

    Parameters
    ----------
    A_vertices : sequence of array_like, shape (n, n)
        The vertices of ``∂F/∂x`` on the region.
    C_vertices : sequence of array_like, shape (p, n)
        The vertices of ``∂h/∂x``.
    alpha : float
        The decay rate, ``> 0``.
    group : ClockGroup
        The one sensor group: every output, its period, longest gap and noise.
    process : array_like, shape (n, n), optional
        ``W Wᵀ``.
    p0 : array_like, shape (n, n), optional
        Covariance of the initial error.
    settle : float
        The time after which (B) is minimised.
    segments : int
        Segments of ``[0, T_0]`` on which ``P`` is linear.
    solver : Solver or str

    Returns
    -------
    ImpulsiveCertificate

    Raises
    ------
    DesignInfeasible
        No ``L``, ``P(τ)`` at this ``α``.
    """
    return ImpulsiveSDP(A_vertices, C_vertices, group, process=process, p0=p0, settle=settle, segments=segments,
                        solver=solver).solve(alpha)


class ImpulsiveSDP:
    """The LMIs of the module and the bound (B) compiled once, solved for any ``α`` (a CVXPY parameter).

    Parameters
    ----------
    A_vertices, C_vertices, group, process, p0, settle, segments, solver
        As :func:`design_impulsive_gain`.
    """

    def __init__(self, A_vertices: Sequence[ArrayLike], C_vertices: Sequence[ArrayLike], group: ClockGroup, *,
                 process: ArrayLike | None = None, p0: ArrayLike | None = None, settle: float = 0.0,
                 segments: int = 4, solver: Solver | str = Solver.CLARABEL) -> None:
        import cvxpy as cp

        As = [np.asarray(A, dtype=float) for A in A_vertices]
        Cs = [np.asarray(C, dtype=float) for C in C_vertices]
        if not As or not Cs:
            raise InvalidArgumentError("A_vertices, C_vertices: none given")
        n, p = As[0].shape[0], Cs[0].shape[0]
        if any(A.shape != (n, n) for A in As) or any(C.shape != (p, n) for C in Cs) or \
                not all(np.all(np.isfinite(M)) for M in (*As, *Cs)):
            raise InvalidArgumentError(f"vertices: expected finite ({n}, {n}) and ({p}, {n}) matrices")
        if sorted(group.index) != list(range(p)):
            raise InvalidArgumentError(f"group: the impulsive design takes one group with all {p} outputs")
        self.As, self.Cs, self.group = tuple(As), tuple(Cs), group
        self.W2 = np.zeros((n, n)) if process is None else np.asarray(process, dtype=float)
        self.S0 = None if p0 is None else np.asarray(p0, dtype=float)
        self.settle = float(settle)
        self.solver = as_solver(solver)
        self.times = times = _times(group, segments)
        self.nodes = nodes = [cp.Variable((n, n), symmetric=True) for _ in times]
        self.Y = Y = cp.Variable((n, p))
        Z = cp.Variable((p, p), symmetric=True)
        cvar = cp.Variable(nonneg=True)
        self.alpha = cp.Parameter(nonneg=True)
        self.inv2a = cp.Parameter(nonneg=True)
        self.jw = cp.Parameter(nonneg=True)
        self.tw = cp.Parameter(nonneg=True)
        eps = MARGIN * np.eye(n)
        W = psd_sqrt(self.W2)
        R = np.zeros((p, p))  # R in the model's output order
        R[np.ix_(list(group.index), list(group.index))] = group.R
        Rh = psd_sqrt(R)
        cons = [Z >> 0, cp.bmat([[Z, Rh @ Y.T], [Y @ Rh, nodes[0]]]) >> 0]
        for P in nodes:
            cons.append(symmetrise(P) >> np.eye(n) + eps)
            if np.any(self.W2):
                cons.append(cp.trace(P @ (W @ W.T)) <= cvar)
        for k in range(len(nodes) - 1):
            dP = (nodes[k + 1] - nodes[k]) / (times[k + 1] - times[k])
            for P in (nodes[k], nodes[k + 1]):
                for A in As:
                    cons.append(symmetrise(dP + A.T @ P + P @ A + 2 * self.alpha * P) << -eps)
        margin = np.block([[eps, np.zeros((n, n))], [np.zeros((n, n)), np.zeros((n, n))]])
        for k, t in enumerate(times):
            if t < group.period * (1 - 1e-12):
                continue
            for C in Cs:
                G = nodes[0] - Y @ C
                cons.append(symmetrise(cp.bmat([[nodes[k], G.T], [G, nodes[0]]])) >> margin)
        self.k_first = times.index(min(times, key=lambda t: abs(t - group.period)))
        transient = 0.0 if self.S0 is None else self.tw * cp.trace(nodes[self.k_first] @ self.S0)
        obj = cp.Minimize(self.inv2a * cvar + self.jw * cp.trace(Z) + transient)
        self.problem = cp.Problem(obj, cons)

    def solve(self, alpha: float) -> ImpulsiveCertificate:
        """``L`` and ``P(τ)`` at decay ``alpha`` (raises :class:`DesignInfeasible` without them).

        Parameters
        ----------
        alpha : float
            The decay rate, ``> 0``.
        """
        a = positive("alpha", alpha)
        g = self.group
        self.alpha.value, self.inv2a.value = a, 1.0 / (2 * a)
        self.jw.value = 1.0 / (1 - math.exp(-2 * a * g.period))
        self.tw.value = math.exp(-2 * a * max(self.settle, 0.0))
        result = solve(self.problem, self.solver)
        if not result.status.has_solution or self.Y.value is None:
            raise DesignInfeasible(f"no impulsive gain at α = {a:.4g} for samples every {g.period:.4g} "
                                   f"(gaps ≤ {g.gap:.4g}): {result.raw_status}",
                                   constraint="flow and jump LMIs" if result.status.is_infeasible else "")
        vals = tuple((np.asarray(P.value) + np.asarray(P.value).T) / 2 for P in self.nodes)
        L = np.linalg.solve(vals[0], np.asarray(self.Y.value))
        cert = ImpulsiveCertificate(L, vals, self.times, a, self.As, self.Cs, g, self.W2, self.S0, self.settle,
                                    result.solver, (), 0.0, 0.0, 0.0)
        return verify_impulsive_gain(cert)
