r"""A clock-dependent Lyapunov certificate of an observer run on sampled outputs through the output predictor.

The hybrid error system
-----------------------
With the inter-sample output predictor of Karafyllis & Kravaris (2009) (:mod:`nlobs.observers.sampled`), a
continuous observer with output injection ``K`` and the discrepancies ``δ_j = w_j − y_j`` of the sensor groups
form, while the state and the estimate stay in a region where the Jacobians lie in a matrix box
(:mod:`nlobs.geometry.jacobian_box`), the hybrid system

.. math::

    \dot e = M e + \textstyle\sum_j K_j \delta_j, \qquad \dot\delta_j = G_j e \qquad (t_{j,k} \le t < t_{j,k+1}),
    \qquad \delta_j(t_{j,k}) = v_{j,k},

``M = J̄_F − K J̄_h`` and ``G = ∂h/∂x · J̄_F`` (a linear output: the same mean-value matrix ``J̄_F``) in the convex
hull of their values at the box's vertices, ``v_{j,k}`` the noise of group ``j``'s sample, every gap
``t_{j,k+1} − t_{j,k} ≤ T_j``.

The certificate
---------------
A Lyapunov function that depends on the time ``τ_j`` since each group's last sample (clock-dependent Lyapunov
functions for aperiodic sampled-data and impulsive systems: Briat, Automatica 49(11), 2013; Seuret, Automatica
48(1), 2012, for the looped-functional view), ``V = ξᵀ P(τ) ξ`` with ``ξ = [e; δ]`` and
``P(τ) = P_0 + Σ_j (τ_j / T_j) D_j``, where ``P_0`` is block diagonal in ``(e, δ_1, …, δ_m)`` and ``D_j`` couples only
``e`` and ``δ_j``. It proves decay at rate ``2α`` between samples and no increase at a sample when, at every corner
``τ ∈ Π_j {0, T_j}`` and every vertex ``(M_v, G_v)``,

.. math::

    \textstyle\sum_j D_j / T_j + F_v^\top P(\tau) + P(\tau) F_v + 2\alpha P(\tau) \preceq 0,\qquad
    F_v = \begin{bmatrix} M_v & K \\ G_v & 0 \end{bmatrix}, \qquad (F)

.. math:: J_j^\top P(\tau|_{\tau_j=0}) J_j \preceq P(\tau|_{\tau_j=T_j}), \qquad (J)

``J_j`` the reset of ``δ_j`` (both conditions are affine in ``τ`` for a fixed vertex and affine in the vertex
for a fixed ``τ``, so corners and vertices suffice), with ``P(τ) ⪰ diag(I, 0)`` (so ``V ≥ |e|²``).

Noise. A sample of group ``j`` adds ``tr(P_{0,jj} (R_j + b_j b_jᵀ))`` to ``E V`` (``R_j`` its covariance, ``b_j`` its
bias; the cross term vanishes because ``P(τ|_{τ_j=0})`` does not couple ``δ_j``), the process noise ``dx = … + W dβ``
adds at most ``c = max tr(W_ξᵀ P(τ) W_ξ)``, ``W_ξ = [W; H W]``, per unit time (Itô), and samples of group ``j`` are
at least its nominal period ``T_j^0`` apart. Hence

.. math::

    E|e(t)|^2 \le E V(t) \le e^{-2\alpha t}\,\operatorname{tr}(P_{0,ee}\Sigma_0) + \frac{c}{2\alpha}
        + \sum_j \frac{\operatorname{tr}(P_{0,jj}(R_j + b_j b_j^\top))}{1 - e^{-2\alpha T_j^0}} . \qquad (B)

Bounded noise (input-to-state): with no process noise and ``|v_{j,k}| ≤ v̄_j``, a sample adds at most
``λ_max(P_{0,jj}) v̄_j²`` to ``V`` (the same reset, no cross term), so ``limsup |e|² ≤ Σ_j λ_max(P_{0,jj}) v̄_j² /
(1 − e^{−2αT_j^0})`` (:meth:`ClockCertificate.ultimate_bound`).

:func:`clock_certificate` finds ``P_0, D_j`` making (B) smallest (an SDP); :func:`verify_clock_certificate`
recomputes every block of (F), (J) and the positivity at every corner and vertex, and the numbers of (B), in NumPy.
"""

from __future__ import annotations

import itertools
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
from nlobs.synthesis.sampled_data import as_noise_bounds

__all__ = ["ClockCertificate", "ClockGroup", "ClockSDP", "clock_certificate", "verify_clock_certificate"]

#: Margin asked of the SDP's inequalities (relative to the scale of ``P``) so that they survive re-verification.
MARGIN = 1e-7
#: Most sensor groups (clocks): the corners are ``2^m``.
MAX_GROUPS = 3


@dataclass(frozen=True)
class ClockGroup:
    """One sensor group as the hybrid system sees it.

    Attributes
    ----------
    name : str
    index : tuple of int
        Its outputs (rows of ``G``, columns of ``K``).
    gap : float
        ``T_j``: the longest time between two of its samples (its period, or an outage and one period).
    period : float
        ``T_j^0``: the shortest time between two samples (its nominal period).
    R : ndarray, shape (p_j, p_j)
        Covariance of a sample's noise.
    bias : ndarray, shape (p_j,)
        A constant offset of its samples.
    """

    name: str
    index: tuple[int, ...]
    gap: float
    period: float
    R: Array
    bias: Array

    def __post_init__(self) -> None:
        for what, v in (("gap", self.gap), ("period", self.period)):
            if not (math.isfinite(float(v)) and float(v) > 0):
                raise InvalidArgumentError(f"sensor group {self.name!r}: {what}: expected a positive finite number, "
                                           f"got {v!r}")
        if self.gap < self.period:
            raise InvalidArgumentError(f"sensor group {self.name!r}: gap {self.gap:g} < period {self.period:g}")
        k = len(self.index)
        R = np.asarray(self.R, dtype=float).reshape(k, k)
        b = np.zeros(k) if np.asarray(self.bias).size == 0 else np.asarray(self.bias, dtype=float).reshape(k)
        if not (np.all(np.isfinite(R)) and np.all(np.isfinite(b))):
            raise InvalidArgumentError(f"sensor group {self.name!r}: non-finite noise or bias")
        object.__setattr__(self, "index", tuple(int(i) for i in self.index))
        object.__setattr__(self, "R", (R + R.T) / 2)
        object.__setattr__(self, "bias", b)


@dataclass(frozen=True, eq=False)
class ClockCertificate(CertificateMixin):
    """``P_0``, ``D_j`` proving (F), (J) and the bound (B) (module docstring).

    Attributes
    ----------
    gain : ndarray, shape (n, p)
        The output injection ``K``.
    P0 : ndarray, shape (n + p, n + p)
        ``P(0)``.
    D : tuple of ndarray
        ``D_j``, one per group (several groups: ``P(τ)`` affine in each clock).
    nodes : tuple of ndarray
        One group: ``P`` at ``τ = kT/K``, ``k = 0 … K`` (``P(τ)`` piecewise linear between them; ``nodes[0] = P0``);
        empty for several groups.
    alpha : float
        The decay rate of (F).
    vertices : tuple of (ndarray, ndarray)
        ``(M_v, G_v)``.
    groups : tuple of ClockGroup
    process : ndarray, shape (n, n)
        ``W Wᵀ``.
    H : tuple of ndarray
        The vertices of ``∂h/∂x`` (``p × n``) the process noise is seen through.
    p0 : ndarray or None
        Covariance of the initial error.
    settle : float
        The time after which :attr:`rms_bound` holds.
    solver : Solver or None
    checks : tuple of Check
        (F), (J) and positivity at every corner and vertex, recomputed.
    c : float
        ``c`` of (B).
    jumps : tuple of float
        ``tr(P_{0,jj}(R_j + b_j b_jᵀ))`` per group.
    v0 : float
        ``tr(P_{0,ee} Σ0)``.
    """

    gain: Array
    P0: Array
    D: tuple[Array, ...]
    nodes: tuple[Array, ...]
    alpha: float
    vertices: tuple[tuple[Array, Array], ...]
    groups: tuple[ClockGroup, ...]
    process: Array
    H: tuple[Array, ...]
    p0: Array | None
    settle: float
    solver: Solver | None
    checks: tuple[Check, ...]
    c: float
    jumps: tuple[float, ...]
    v0: float

    @property
    def P(self) -> Array:  # noqa: N802 - the papers' symbol
        """``P(0)``, the Lyapunov matrix at the sample instants."""
        return self.P0

    @property
    def ultimate_ms(self) -> float:
        """``limsup E|e|²`` of (B) (``inf`` when not verified)."""
        if not self.verified:
            return math.inf
        a2 = 2 * self.alpha
        return self.c / a2 + sum(j / (1 - math.exp(-a2 * g.period)) for j, g in zip(self.jumps, self.groups))

    def ms_after(self, settle: float, p0: ArrayLike | None = None) -> float:
        """The bound (B) on ``E|e(t)|²`` for every ``t ≥ settle``, for an initial error of covariance ``p0``.

        Parameters
        ----------
        settle : float
            The time after which it holds.
        p0 : array_like, shape (n, n), optional
            Covariance (or second moment) of the initial error (default: the certificate's).
        """
        if not self.verified:
            return math.inf
        n = self.gain.shape[0]
        v0 = self.v0 if p0 is None else float(np.trace(self.P0[:n, :n] @ np.asarray(p0, dtype=float)))
        return math.exp(-2 * self.alpha * max(float(settle), 0.0)) * v0 + self.ultimate_ms

    def rms_after(self, settle: float, p0: ArrayLike | None = None) -> float:
        """``√`` of :meth:`ms_after`.

        Parameters
        ----------
        settle : float
            The time after which it holds.
        p0 : array_like, shape (n, n), optional
            Covariance of the initial error.
        """
        return math.sqrt(self.ms_after(settle, p0))

    @property
    def rms_bound(self) -> float:
        """The RMS bound after :attr:`settle` for :attr:`p0`."""
        return self.rms_after(self.settle)

    def ultimate_bound(self, noise_bounds: float | Sequence[float]) -> float:
        """``limsup |e|`` when every sample of group ``j`` has noise (bias included) of norm ``≤ v̄_j`` and there is no
        process noise: (B) with ``λ_max(P_{0,jj}) v̄_j²`` for ``tr(P_{0,jj}(R_j + b_j b_jᵀ))`` (a sample adds at most
        that to ``V``; module docstring), ``inf`` when not verified.

        Parameters
        ----------
        noise_bounds : float or sequence of float
            ``v̄_j`` per group (one number: every group).
        """
        v = as_noise_bounds(noise_bounds, len(self.groups))
        if not self.verified:
            return math.inf
        n = self.gain.shape[0]
        total = 0.0
        for b, g, vj in zip(_blocks(n, self.groups)[1:], self.groups, v):
            lam = float(np.linalg.eigvalsh(self.P0[np.ix_(b, b)])[-1])
            total += lam * float(vj) ** 2 / (1 - math.exp(-2 * self.alpha * g.period))
        return math.sqrt(total)

    @property
    def iss_gain(self) -> float:
        """``γ`` with ``limsup |e| ≤ γ v̄`` for sample noise bounded by ``v̄`` in every group and no process noise."""
        return self.ultimate_bound(1.0)

    @property
    def t_max(self) -> tuple[float, ...]:
        """The longest gap per group the certificate covers (its ``T_j``)."""
        return tuple(g.gap for g in self.groups)

    @property
    def budget(self) -> float:
        """``max_j`` gap / ``T_j`` (1 by construction: the certificate is for the gaps themselves)."""
        return 1.0 if self.verified else math.inf

    def violation(self) -> str | None:
        """Which inequality fails, with its largest eigenvalue (``None`` when verified)."""
        if self.verified:
            return None
        return "; ".join(f"{c.name}: {c.evidence}" for c in self.failed_checks)

    def summary(self) -> str:
        """The groups' gaps, the decay, the noise terms and every check."""
        lines = [f"clock-dependent certificate: α = {self.alpha:.4g} on {len(self.vertices)} vertices, "
                 f"{len(self.groups)} sensor group(s)"]
        for g, j in zip(self.groups, self.jumps):
            lines.append(f"  {g.name}: gaps ≤ {g.gap:.4g}, period {g.period:.4g}, noise per sample {j:.4g}")
        lines.append(f"  process noise c = {self.c:.4g}; RMS bound after t = {self.settle:g}: {self.rms_bound:.4g}; "
                     f"bounded noise |v| ≤ v̄ and no process noise: limsup |e| ≤ {self.iss_gain:.4g} v̄")
        lines += [f"  [{'ok' if c.passed else 'FAIL'}] {c.name}: {c.evidence}" for c in self.checks]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view."""
        return {"kind": "clock", "alpha": self.alpha, "c": self.c, "v0": self.v0, "settle": self.settle,
                "rms_bound": self.rms_bound if self.verified else None,
                "iss_gain": self.iss_gain if self.verified else None,
                "groups": [{"name": g.name, "gap": g.gap, "period": g.period, "jump": j}
                           for g, j in zip(self.groups, self.jumps)],
                "vertices": len(self.vertices), "verified": self.verified, "checks": checks_dict(self.checks)}


# ------------------------------------------------------------------ structure
def _blocks(n: int, groups: Sequence[ClockGroup]) -> list[list[int]]:
    """Indices of ``ξ = [e; δ]`` per block: ``e``, then each group's outputs."""
    return [list(range(n)), *([n + i for i in g.index] for g in groups)]


def _corners(m: int) -> list[tuple[int, ...]]:
    return list(itertools.product((0, 1), repeat=m))


def _P_at(P0: Any, D: Sequence[Any], corner: Sequence[int]) -> Any:
    out = P0
    for d, c in zip(D, corner):
        if c:
            out = out + d
    return out


def _reset(N: int, rows: Sequence[int]) -> Array:
    J = np.eye(N)
    for r in rows:
        J[r, r] = 0.0
    return J


def _flow(M: Array, G: Array, K: Array) -> Array:
    p = K.shape[1]
    return np.block([[M, K], [G, np.zeros((p, p))]])


def _noise_map(W: Array, H: Array) -> Array:
    return np.vstack([W, H @ W])



# ------------------------------------------------------------------ the conditions at corners and nodes
def _points(P0: Any, D: Sequence[Any], nodes: Sequence[Any], groups: Sequence[ClockGroup]
            ) -> tuple[list[tuple[Any, Any]], list[tuple[int, Any, Any]], list[Any]]:
    """Where (F), (J) and positivity are imposed, for NumPy arrays or CVXPY expressions alike.

    Returns the flow points ``(P, dP/dt)``, the jump pairs ``(j, P after, P before)`` and every ``P`` (module
    docstring: the corners of an affine ``P(τ)``, or both ends of each segment of a piecewise-linear one).
    """
    m = len(groups)
    if nodes:  # one group, P piecewise linear in τ on K segments of [0, T]
        h = groups[0].gap / (len(nodes) - 1)
        flows = []
        for k in range(len(nodes) - 1):
            dP = (nodes[k + 1] - nodes[k]) / h
            flows += [(nodes[k], dP), (nodes[k + 1], dP)]
        return flows, [(0, nodes[0], nodes[k]) for k in range(1, len(nodes))], list(nodes)
    dP = sum((d / g.gap for d, g in zip(D, groups)), 0 * P0)
    corners = _corners(m)
    flows = [(_P_at(P0, D, c), dP) for c in corners]
    jumps = [(j, _P_at(P0, D, c), _P_at(P0, D, tuple(1 if i == j else ci for i, ci in enumerate(c))))
             for j in range(m) for c in corners if not c[j]]
    return flows, jumps, [P for P, _ in flows]


def _checks(P0: Array, D: Sequence[Array], nodes: Sequence[Array], K: Array, alpha: float,
            vertices: Sequence[tuple[Array, Array]], groups: Sequence[ClockGroup]) -> tuple[Check, ...]:
    n, p = K.shape
    N = n + p
    blocks = _blocks(n, groups)
    mats = [P0, *D, *nodes]
    scale = max(1.0, *(float(np.abs(x).max()) for x in mats))
    tol = 1e-9 * scale
    # structure: P0 block diagonal; D_j couples only e and δ_j
    leak = 0.0
    for a, ia in enumerate(blocks):
        for b, ib in enumerate(blocks):
            if a != b:
                leak = max(leak, float(np.abs(P0[np.ix_(ia, ib)]).max(initial=0.0)))
    for j, d in enumerate(D):
        idx = sorted(set(blocks[0]) | set(blocks[j + 1]))
        mask = np.ones((N, N), dtype=bool)
        mask[np.ix_(idx, idx)] = False
        leak = max(leak, float(np.abs(d[mask]).max(initial=0.0)))
    if nodes:
        leak = max(leak, float(np.abs(nodes[0] - P0).max()))
    flows, jumps, points = _points(P0, D, nodes, groups)
    E = np.zeros((N, N))
    E[:n, :n] = np.eye(n)
    pos = min(float(np.linalg.eigvalsh((Pc - E + (Pc - E).T) / 2)[0]) for Pc in points)
    flow = -math.inf
    for Pc, dP in flows:
        for M, G in vertices:
            F = _flow(M, G, K)
            S = dP + F.T @ Pc + Pc @ F + 2 * alpha * Pc
            flow = max(flow, float(np.linalg.eigvalsh((S + S.T) / 2)[-1]))
    jump = -math.inf
    for j, after, before in jumps:
        J = _reset(N, blocks[j + 1])
        S = J.T @ after @ J - before
        jump = max(jump, float(np.linalg.eigvalsh((S + S.T) / 2)[-1]))
    where = f"{len(nodes) - 1} segments of [0, T]" if nodes else f"{2 ** len(groups)} corners"
    nv = len(vertices)
    return (
        Check.compare("structure of P(τ) (P(0) block diagonal in e, δ_1, …, δ_m)", leak, tol, kind=CheckKind.STRUCTURAL,
                      strict=False, evidence=f"largest entry outside the pattern {leak:.3g} ≤ {tol:.3g}"),
        Check.compare("P(τ) ⪰ diag(I, 0)", -pos, tol, kind=CheckKind.POSITIVITY, strict=False,
                      evidence=f"λ_min(P(τ) − diag(I, 0)) = {pos:.4g} at worst ({where})"),
        Check.compare(f"(F): decay 2α between samples ({where} × {nv} vertices)", flow, tol, kind=CheckKind.LMI,
                      strict=False, evidence=f"largest eigenvalue {flow:.4g} ≤ {tol:.3g} (α = {alpha:.4g})"),
        Check.compare("(J): no increase at a sample", jump if jumps else -1.0, tol, kind=CheckKind.LMI, strict=False,
                      evidence=f"largest eigenvalue {jump:.4g} ≤ {tol:.3g}" if jumps else "no sensor group"),
    )


def _numbers(P0: Array, D: Sequence[Array], nodes: Sequence[Array], n: int, groups: Sequence[ClockGroup],
             process: Array, H: Sequence[Array], p0: Array | None) -> tuple[float, tuple[float, ...], float]:
    """``c``, the jump terms and ``v0`` of (B)."""
    blocks = _blocks(n, groups)
    W = psd_sqrt(process)
    c = 0.0
    if np.any(process):
        for Pc in _points(P0, D, nodes, groups)[2]:
            for Hv in H:
                X = _noise_map(W, Hv)
                c = max(c, float(np.trace(X.T @ Pc @ X)))
    jumps = tuple(float(np.trace(P0[np.ix_(b, b)] @ (g.R + np.outer(g.bias, g.bias))))
                  for g, b in zip(groups, blocks[1:]))
    v0 = float(np.trace(P0[:n, :n] @ p0)) if p0 is not None else 0.0
    return c, jumps, v0


def verify_clock_certificate(cert: ClockCertificate) -> ClockCertificate:
    """Recompute the checks and the numbers of (B) of ``cert`` from its matrices (NumPy only).

    Parameters
    ----------
    cert : ClockCertificate
        A certificate (from :func:`clock_certificate`, or built by hand).

    Returns
    -------
    ClockCertificate
    """
    n = cert.gain.shape[0]
    checks = _checks(cert.P0, cert.D, cert.nodes, cert.gain, cert.alpha, cert.vertices, cert.groups)
    c, jumps, v0 = _numbers(cert.P0, cert.D, cert.nodes, n, cert.groups, cert.process, cert.H, cert.p0)
    return ClockCertificate(cert.gain, cert.P0, cert.D, cert.nodes, cert.alpha, cert.vertices, cert.groups,
                            cert.process, cert.H, cert.p0, cert.settle, cert.solver, checks, c, jumps, v0)


# ------------------------------------------------------------------ synthesis
def clock_certificate(vertices: Sequence[tuple[ArrayLike, ArrayLike]], K: ArrayLike, alpha: float,
                      groups: Sequence[ClockGroup], *, process: ArrayLike | None = None,
                      H: Sequence[ArrayLike] = (), p0: ArrayLike | None = None, settle: float = 0.0,
                      segments: int = 4, solver: Solver | str = Solver.CLARABEL) -> ClockCertificate:
    """``P_0``, ``D_j`` of (F), (J) making the bound (B) after ``settle`` smallest (module docstring).

    Parameters
    ----------
    vertices : sequence of (M, G)
        The vertices of the closed loop ``M = J̄_F − K J̄_h`` (``n × n``) and of ``G`` (``p × n``).
    K : array_like, shape (n, p)
        The output injection.
    alpha : float
        The decay rate asked of (F), ``> 0``.
    groups : sequence of ClockGroup
        At most :data:`MAX_GROUPS`; every output in at most one.
    process : array_like, shape (n, n), optional
        ``W Wᵀ``.
    H : sequence of array_like, shape (p, n)
        The vertices of ``∂h/∂x`` (for the process noise the outputs see).
    p0 : array_like, shape (n, n), optional
        Covariance of the initial error.
    settle : float
        The time after which the bound is minimised.
    segments : int
        One group: the number ``K`` of segments of ``[0, T]`` on which ``P(τ)`` is linear (more: less conservative,
        larger SDP).
    solver : Solver or str

    Returns
    -------
    ClockCertificate

    Raises
    ------
    DesignInfeasible
        No ``P(τ)`` proves (F), (J) at this ``α`` for these gaps.
    InvalidArgumentError
        Malformed matrices, too many groups.
    """
    Km = np.asarray(K, dtype=float)
    if Km.ndim != 2 or not np.all(np.isfinite(Km)):
        raise InvalidArgumentError("K: expected a finite 2-D array")
    n, p = Km.shape
    triples = []
    for M, G in vertices:
        Mm, Gm = np.asarray(M, dtype=float), np.asarray(G, dtype=float)
        if Mm.shape != (n, n) or Gm.shape != (p, n) or not (np.all(np.isfinite(Mm)) and np.all(np.isfinite(Gm))):
            raise InvalidArgumentError(f"vertices: expected finite ({n}, {n}) and ({p}, {n}) pairs")
        triples.append((Mm, np.zeros((p, n)), Gm))  # M = A − K C with C = 0: the closed loop as given
    return ClockSDP(triples, groups, process=process, H=H, p0=p0, settle=settle, segments=segments,
                    solver=solver).solve(Km, alpha)


class ClockSDP:
    """(F), (J) and the bound (B) compiled once for the vertices ``(A_v, C_v, G_v)`` of an error system whose
    closed loop is ``M_v = A_v − K C_v``; solved for any gain ``K`` and decay ``α`` (CVXPY parameters: a tuning
    re-solves without re-canonicalising).

    Parameters
    ----------
    triples : sequence of (A, C, G)
        ``A`` (``n × n``), ``C`` (``p × n``), ``G`` (``p × n``) at each vertex.
    groups, process, H, p0, settle, segments, solver
        As :func:`clock_certificate`.
    """

    def __init__(self, triples: Sequence[tuple[ArrayLike, ArrayLike, ArrayLike]], groups: Sequence[ClockGroup], *,
                 process: ArrayLike | None = None, H: Sequence[ArrayLike] = (), p0: ArrayLike | None = None,
                 settle: float = 0.0, segments: int = 4, solver: Solver | str = Solver.CLARABEL) -> None:
        import cvxpy as cp

        trip = [tuple(np.asarray(v, dtype=float) for v in t) for t in triples]
        if not trip:
            raise InvalidArgumentError("vertices: none given")
        n, p = trip[0][0].shape[0], trip[0][1].shape[0]
        if any(A.shape != (n, n) or C.shape != (p, n) or G.shape != (p, n) or
               not (np.all(np.isfinite(A)) and np.all(np.isfinite(C)) and np.all(np.isfinite(G)))
               for A, C, G in trip):
            raise InvalidArgumentError(f"vertices: expected finite ({n}, {n}), ({p}, {n}), ({p}, {n}) matrices")
        groups = tuple(groups)
        m = len(groups)
        if m > MAX_GROUPS:
            raise InvalidArgumentError(f"groups: {m} > {MAX_GROUPS} sensor groups (2^m clock corners)")
        seen = [i for g in groups for i in g.index]
        if len(set(seen)) != len(seen) or any(not 0 <= i < p for i in seen) or len(seen) != p:
            raise InvalidArgumentError(f"groups: every one of the {p} outputs must be in exactly one group")
        N = n + p
        self.n, self.p, self.triples, self.groups = n, p, trip, groups
        self.W2 = np.zeros((n, n)) if process is None else np.asarray(process, dtype=float)
        self.Hs = [np.asarray(h, dtype=float) for h in H] or [np.zeros((p, n))]
        self.S0 = None if p0 is None else np.asarray(p0, dtype=float)
        self.settle = float(settle)
        self.solver = as_solver(solver)
        blocks = _blocks(n, groups)
        self.blocks = blocks
        self.K = Kp = cp.Parameter((n, p))
        self.alpha = cp.Parameter(nonneg=True)
        self.inv2a = cp.Parameter(nonneg=True)
        self.jw = [cp.Parameter(nonneg=True) for _ in groups]
        self.tw = cp.Parameter(nonneg=True)

        def sym_block(size: int) -> Any:
            return cp.Variable((size, size), symmetric=True)

        def embed(block: Any, rows: list[int]) -> Any:
            Er = np.zeros((N, len(rows)))
            Er[rows, range(len(rows))] = 1.0
            return Er @ block @ Er.T

        self.P0_parts = [sym_block(len(b)) for b in blocks]
        P0 = sum((embed(Pb, b) for Pb, b in zip(self.P0_parts, blocks)), np.zeros((N, N)))
        D: list[Any] = []
        nodes: list[Any] = []
        if m == 1 and segments > 1:
            nodes = [P0, *(sym_block(N) for _ in range(segments))]
        else:
            D = [embed(sym_block(len(blocks[0]) + len(blocks[j + 1])), blocks[0] + blocks[j + 1]) for j in range(m)]
        self.D, self.nodes = D, nodes
        E = np.zeros((N, N))
        E[:n, :n] = np.eye(n)
        eps = MARGIN * np.eye(N)
        cons = []
        W = psd_sqrt(self.W2)
        cvar = cp.Variable(nonneg=True)
        flows, jumps, points = _points(P0, D, nodes, groups)
        for Pc in points:
            cons.append(symmetrise(Pc) >> E + eps)
            if np.any(self.W2):
                for Hv in self.Hs:
                    X = _noise_map(W, Hv)
                    cons.append(cp.trace(Pc @ (X @ X.T)) <= cvar)
        for A, C, G in trip:
            F = cp.bmat([[A - Kp @ C, Kp], [G, np.zeros((p, p))]])
            for Pc, dP in flows:
                cons.append(symmetrise(dP + F.T @ Pc + Pc @ F + 2 * self.alpha * Pc) << -eps)
        for j, after, before in jumps:
            J = _reset(N, blocks[j + 1])
            cons.append(symmetrise(J.T @ after @ J - before) << -eps)
        jump_terms = [w * cp.trace(self.P0_parts[j + 1] @ (g.R + np.outer(g.bias, g.bias)))
                      for j, (w, g) in enumerate(zip(self.jw, groups))]
        transient = 0.0 if self.S0 is None else self.tw * cp.trace(self.P0_parts[0] @ self.S0)
        obj = cp.Minimize(self.inv2a * cvar + sum(jump_terms, 0.0) + transient + 1e-9 * cp.trace(P0))
        self.problem = cp.Problem(obj, cons)

    def solve(self, K: ArrayLike, alpha: float) -> ClockCertificate:
        """The certificate for gain ``K`` at decay ``alpha`` (raises :class:`DesignInfeasible` without one).

        Parameters
        ----------
        K : array_like, shape (n, p)
            The output injection.
        alpha : float
            The decay rate, ``> 0``.
        """
        n, p = self.n, self.p
        Km = np.asarray(K, dtype=float)
        if Km.shape != (n, p) or not np.all(np.isfinite(Km)):
            raise InvalidArgumentError(f"K: expected a finite ({n}, {p}) array")
        a = positive("alpha", alpha)
        self.K.value, self.alpha.value, self.inv2a.value = Km, a, 1.0 / (2 * a)
        for w, g in zip(self.jw, self.groups):
            w.value = 1.0 / (1 - math.exp(-2 * a * g.period))
        self.tw.value = math.exp(-2 * a * max(self.settle, 0.0))
        result = solve(self.problem, self.solver)
        if not result.status.has_solution or self.P0_parts[0].value is None:
            raise DesignInfeasible(f"no clock-dependent Lyapunov function at α = {a:.4g} for the gaps "
                                   + ", ".join(f"{g.name} ≤ {g.gap:.4g}" for g in self.groups)
                                   + f": {result.raw_status}")
        N = n + p
        P0v = np.zeros((N, N))
        for Pb, b in zip(self.P0_parts, self.blocks):
            v = np.asarray(Pb.value)
            P0v[np.ix_(b, b)] = (v + v.T) / 2

        def value(x: Any) -> Array:
            v = np.asarray(x.value, dtype=float)
            return (v + v.T) / 2

        Dv = tuple(value(d) for d in self.D)
        nv = (P0v, *(value(x) for x in self.nodes[1:])) if self.nodes else ()
        verts = tuple((A - Km @ C, G) for A, C, G in self.triples)
        cert = ClockCertificate(Km, P0v, Dv, nv, a, verts, self.groups, self.W2, tuple(self.Hs), self.S0,
                                self.settle, result.solver, (), 0.0, (), 0.0)
        return verify_clock_certificate(cert)
