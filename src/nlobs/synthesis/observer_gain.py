r"""Certified LMI synthesis of observer gains (Grip, Saberi & Johansen, Sec. 3.2).

Error dynamics of the observer (9) for the extended system (8):

.. math:: \dot{\tilde w}_e = (𝔄 − K ℭ)\tilde w_e + 𝔅_d \tilde d − K N n,

with ``H(s) = (sI − 𝔄 + Kℭ)⁻¹ 𝔅_d`` (13) and ``G(s) = −(sI − 𝔄 + Kℭ)⁻¹ K N``.
Below ``A, C, Bd`` stand for ``𝔄, ℭ, 𝔅_d`` (any ``(A, C, Bd)`` may be given).

With ``X = P K`` the conditions are LMIs in ``(P, X)``:

* (14) bounded-real lemma, ``‖H‖∞ < γ``:
  ``[[P A + Aᵀ P − X C − Cᵀ Xᵀ + I, P Bd], [Bdᵀ P, −γ² I]] ≺ 0``, ``P ≻ 0``;
* (15) noise attenuation, ``‖G‖∞ ≤ γn``:
  ``[[P A + Aᵀ P − X C − Cᵀ Xᵀ + I, −X N], [−Nᵀ Xᵀ, −γn² I]] ≺ 0`` (same ``P``);
* pole regions of Chilali & Gahinet (1996) for ``A − K C`` with the same ``P``
  (:mod:`nlobs.synthesis.regions`), written with ``P (A − K C) = P A − X C``;
* optionally a gain bound ``‖K‖₂ ≤ κ`` (:class:`GainBound`).

Strict inequalities are imposed with an explicit margin ``ε`` (``F ⪯ −ε I``,
``P ⪰ ε I``) and every answer is re-verified independently of the solver
(:class:`~nlobs.synthesis.certificate.ObserverGainCertificate`).

Well-posedness. "Minimise γn² subject to (14), (15)" — the paper's recipe —
has no minimum in the paper's own GNSS/INS example: ``‖G‖∞ ≥ 1`` for every
stabilising gain and ``γn → 1`` only as ``‖K‖ → ∞``, so the solver returns a
gain set by ``ε`` (``ε = 10⁻³ → K_pp ≈ 998``, ``ε = 10⁻⁶ → K_pp ≈ 9.9·10⁵``).
:func:`design_observer_gain` therefore offers well-posed formulations — the
analytic centre at fixed ``γ, γn`` (:attr:`Objective.CENTRAL`), a gain bound,
pole regions — and runs the minimisations only with a check that the optimum
does not move with ``ε`` (else :class:`~nlobs.errors.DesignUnbounded`). See
``docs/synthesis.md``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NoReturn

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._lazy import LazyModule
from nlobs._validate import as_matrix, as_square, positive, readonly
from nlobs.errors import (
    CertificateError,
    DesignInfeasible,
    DesignUnbounded,
    DimensionError,
    InvalidArgumentError,
    ProblemTooLarge,
)
from nlobs.linear.assumption4 import ExtendedSystem, extended_system
from nlobs.linear.norms import hinf_norm
from nlobs.linear.observability import unobservable_modes
from nlobs.linear.stability import require_magnitude, strictly_inside
from nlobs.synthesis.certificate import (
    Check,
    CheckKind,
    Objective,
    ObserverGainCertificate,
    SynthesisMethod,
)
from nlobs.synthesis.lmi import (
    MAX_LMI_SIZE,  # noqa: F401  (re-exported: observer_gain.MAX_LMI_SIZE)
    Solver,
    SolveResult,
    SolveStatus,
    as_enum,
    as_solver,
    bmat,
    is_expression,
    max_eig,
    require_lmi_size,
    solve,
    symmetrise,
)
from nlobs.synthesis.regions import PoleRegion, as_regions
from nlobs.synthesis.riccati import FilterRiccati, filter_riccati, riccati_delta, smallest_riccati_scale
from nlobs.systems.linear import takes_system

cp = LazyModule("cvxpy")  # imported by the first problem built (see nlobs._lazy)

__all__ = [
    "ExtendedSystem",
    "GainBound",
    "MAX_SDP_MEMORY",
    "SdpEstimate",
    "SynthesisMethod",
    "sdp_estimate",
    "extended_system",
    "design_observer_gain",
    "verify_observer_gain",
]

RegionArg = PoleRegion | Sequence[PoleRegion] | None

_EPS = float(np.finfo(float).eps)
_SLACK_TOL = 1e-9  # a stage is infeasible when its minimal slack exceeds this
_UNBOUNDED_GROWTH = 10.0  # gain growth (per 100× change of ε) that flags a margin-driven optimum


# --------------------------------------------------------------------------- data


@dataclass(frozen=True)
class GainBound:
    r"""Gain bound ``‖K‖₂ ≤ κ``, imposed as an LMI.

    With a scalar decision variable ``μ ≥ 0`` the constraints ``P ⪰ μ I`` and
    ``[[κ μ I, Xᵀ], [X, κ μ I]] ⪰ 0`` (i.e. ``‖X‖₂ ≤ κ μ``) are jointly linear in
    ``(P, X, μ)`` and give ``‖K‖₂ = ‖P⁻¹ X‖₂ ≤ ‖P⁻¹‖₂ ‖X‖₂ ≤ (1/μ)(κ μ) = κ``.
    Letting ``μ`` float (instead of the textbook ``P ⪰ I, ‖X‖ ≤ κ``) removes most
    of the conservatism: on a Grip–Saberi–Johansen example the fixed ``P ⪰ I`` version
    capped ``‖K‖₂`` at 1.42 whatever ``κ`` was, while this one reaches ``‖K‖₂ ≈ κ``.

    Parameters
    ----------
    kappa : float
        The bound ``κ > 0`` on the spectral norm of ``K``.

    Examples
    --------
    The smallest ``γ`` of LMI (14) (Grip, Saberi & Johansen) for a damped oscillator under ``‖K‖₂ ≤ κ``:
    the bound is re-verified, and a larger ``κ`` allows a smaller ``γ``:

    >>> import numpy as np
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> kappas = (0.5, 2.0)
    >>> certs = [design_observer_gain(A, C, Bd, objective="min_gamma", gain_bound=GainBound(k)) for k in kappas]
    >>> [(c.verified, c.checks[-1].name, bool(c.gain_norm <= k)) for c, k in zip(certs, kappas)]
    [(True, '‖K‖₂ ≤ κ', True), (True, '‖K‖₂ ≤ κ', True)]
    >>> bool(certs[1].gamma < certs[0].gamma)
    True
    >>> try:
    ...     GainBound(0.0)
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError gain_bound.kappa: must be positive, got 0.0
    """

    kappa: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "kappa", positive("gain_bound.kappa", self.kappa))


@dataclass(frozen=True)
class _Data:
    """Validated problem data."""

    A: NDArray[np.float64]
    C: NDArray[np.float64]
    Bd: NDArray[np.float64]
    N: NDArray[np.float64] | None
    regions: tuple[PoleRegion, ...]
    gain_bound: GainBound | None

    @property
    def n(self) -> int:
        return self.A.shape[0]


def _validate_data(A: ArrayLike, C: ArrayLike, Bd: ArrayLike, N: ArrayLike | None, need_noise: bool,
                   region: RegionArg, gain_bound: GainBound | float | None) -> _Data:
    A_ = as_square("A", A)
    n = A_.shape[0]
    if n == 0:
        raise DimensionError("A: the state dimension must be at least 1")
    C_ = as_matrix("C", C, (None, n))
    Bd_ = as_matrix("Bd", Bd, (n, None))
    p = C_.shape[0]
    if p == 0:
        raise DimensionError("C: at least one measurement is needed")
    N_: NDArray[np.float64] | None = None
    if N is not None:
        N_ = as_matrix("N", N, (p, None))
    elif need_noise:
        N_ = np.eye(p)
    for name, M in (("A", A_), ("C", C_), ("Bd", Bd_), ("N", N_)):
        if M is not None:
            require_magnitude(name, M)
    gb = _as_gain_bound(gain_bound)
    return _Data(A_, C_, Bd_, N_, as_regions(region), gb)  # type: ignore[arg-type]


def _as_gain_bound(gain_bound: GainBound | float | None) -> GainBound | None:
    if gain_bound is None or isinstance(gain_bound, GainBound):
        return gain_bound
    if isinstance(gain_bound, (int, float, np.floating, np.integer)) and not isinstance(gain_bound, bool):
        return GainBound(float(gain_bound))
    raise InvalidArgumentError(f"gain_bound: expected a GainBound or a positive number, got {gain_bound!r}")


def _as_objective(objective: Objective | str) -> Objective:
    return as_enum("objective", Objective, objective)


def _margin(margin: float) -> float:
    m = positive("margin", margin)
    if m >= 1.0:
        raise InvalidArgumentError(f"margin: must be a small positive number (< 1), got {m!r}")
    return m


# --------------------------------------------------------------------------- detectability


def _require_detectable(A: NDArray[np.float64], C: NDArray[np.float64]) -> None:
    """Raise :class:`DesignInfeasible` naming the first unobservable mode that is not stable (PBH)."""
    bad = [lam for lam in unobservable_modes(A, C) if not strictly_inside(np.array([lam]))[0]]
    if bad:
        lam = complex(bad[0])
        raise DesignInfeasible(
            f"(A, C) is not detectable: the mode λ = {lam:.6g} (Re λ ≥ 0) is unobservable "
            f"(PBH: rank [λI − A; C] < n), so no gain K makes A − K C Hurwitz "
            "and LMI (14) is infeasible for every γ; add a measurement of that mode",
            constraint="detectability",
            violation=float(lam.real),
        )


# --------------------------------------------------------------------------- LMI blocks


def lmi_size(d: _Data) -> tuple[int, tuple[int, ...]]:
    """``(scalar decision variables, sizes of the semidefinite blocks)`` of the problem :func:`_formulate` builds.

    Counted from the numeric blocks (:func:`_blocks` with zero ``P``, ``X``): ``P`` and ``X``, up to
    three scalars (``γ²``, ``γn²``, ``μ``), ``P ⪰ εI``, LMIs (14)/(15), every region block and the gain bound.
    """
    n, p = d.n, d.C.shape[0]
    blocks = [n] + [int(b.shape[0]) for _, b in _blocks(d, np.zeros((n, n)), np.zeros((n, p)), 1.0, 1.0)]
    if d.gain_bound is not None:
        blocks += [n, n + p]
    return n * (n + 1) // 2 + n * p + 3, tuple(blocks)


def _check_size(d: _Data, *, with_K: bool = False) -> None:
    """Refuse a problem above :data:`~nlobs.synthesis.lmi.MAX_LMI_SIZE` before CVXPY builds it (it would exhaust memory).

    ``with_K``: the verification of a given ``K`` (``P`` the only matrix variable, no gain bound).
    """
    nvar, blocks = lmi_size(d)
    if with_K:
        nvar = d.n * (d.n + 1) // 2
        blocks = blocks[:-2] if d.gain_bound is not None else blocks
    advice = ("about n = 50 states is the most; reduce the model (e.g. verify per decoupled axis)" if with_K else
              "about n = 50 states is the most on the SDP path; the Riccati path (method='riccati': objective "
              "'central' with gamma and gamma_n, no region, no gain bound) has no such limit, or reduce the model "
              "(e.g. design per decoupled axis)")
    require_lmi_size("LMI problem", f"n = {d.n} states", nvar, blocks, advice)


#: Largest estimated peak memory (bytes) of the interior-point solve of :func:`design_observer_gain`'s
#: SDP (:func:`sdp_estimate`); a larger problem is refused with :class:`~nlobs.errors.ProblemTooLarge`
#: before CVXPY builds it.
MAX_SDP_MEMORY = 4 * 2**30

# Calibration of the memory model (Clarabel through CVXPY, measured as the peak resident set of a
# process running one design): a process baseline plus a factor times the dense PSD-cone blocks of
# the KKT system, 8 bytes · Σ (k(k+1)/2)² over the cones. Least-squares fit on the central design of
# dense random systems (p = n/5 outputs, n/10 disturbances) at n = 16, 20, 25, 30: 206, 270, 408,
# 580 MB measured, 210, 258, 363, 567 MB estimated (``docs/synthesis.md``, "Problem size").
_MEM_BASE = 190e6
_MEM_FACTOR = 3.3
# A rough time model for the message only (never a gate: the machine's speed varies): a power law in
# f = Σ (k(k+1)/2)³ over the dense cone blocks, seconds ≈ 266 (f / 3.57e10)^0.85, from the same runs
# on a shared 2-core machine (11, 30, 114, 266 s measured at n = 16 … 30).
_SECONDS_AT_N30 = 266.0
_FLOPS_AT_N30 = 3.57e10
_TIME_EXPONENT = 0.85


@dataclass(frozen=True)
class SdpEstimate:
    """The size of the SDP :func:`design_observer_gain` would hand to the interior-point solver.

    Counted as CVXPY compiles it: each ``log det`` of a ``k × k`` block (objective ``CENTRAL``) adds a
    semidefinite cone of size ``2k``, ``k(k+1)/2 + k`` variables and ``k`` exponential cones.

    Attributes
    ----------
    variables : int
        Scalar variables of the compiled problem.
    cones : tuple of int
        Sizes of its semidefinite cones.
    rows : int
        Rows of its constraint matrix (``Σ k(k+1)/2`` over the cones, 3 per exponential cone).
    kkt_dense : int
        ``Σ (k(k+1)/2)²``: the entries of the dense cone blocks of the solver's KKT matrix.
    memory_bytes : float
        Estimated peak memory of the process, ``base + factor · 8 · kkt_dense`` (calibrated).
    seconds : float
        A rough time estimate (machine-dependent; reported, never used to refuse).
    limit_bytes : float
        :data:`MAX_SDP_MEMORY` at the time of the estimate.
    """

    variables: int
    cones: tuple[int, ...]
    rows: int
    kkt_dense: int
    memory_bytes: float
    seconds: float
    limit_bytes: float

    @property
    def fits(self) -> bool:
        """Whether the estimated memory is within the limit."""
        return self.memory_bytes <= self.limit_bytes

    def describe(self) -> str:
        """One clause: variables, cones, rows, estimated memory and time."""
        return (f"{self.variables} variables, semidefinite cones of sizes {', '.join(map(str, self.cones))}, "
                f"{self.rows} constraint rows; estimated {self.memory_bytes / 2**30:.2g} GiB and "
                f"~{self.seconds:.2g} s for the interior-point solver")


@takes_system(time="continuous", A="A", C="C", Bd="B")
def sdp_estimate(A: ArrayLike, C: ArrayLike, Bd: ArrayLike, *, N: ArrayLike | None = None,
                 gamma_n: float | None = None, region: RegionArg = None, gain_bound: GainBound | float | None = None,
                 objective: Objective | str = Objective.CENTRAL) -> SdpEstimate:
    """Estimate the SDP :func:`design_observer_gain` would solve with these arguments (nothing is built).

    ``gamma_n`` (or ``N``, or objective ``MIN_GAMMA_N``) adds LMI (15); the other arguments as in
    :func:`design_observer_gain`. The estimate's ``fits`` is what ``method="sdp"`` checks first.

    Parameters
    ----------
    A, C, Bd : array_like
        ``𝔄 (n×n)``, ``ℭ (p×n)``, ``𝔅_d (n×m)`` of the error dynamics (12a).
    N : array_like, shape (p, q), optional
        Noise input matrix of LMI (15).
    gamma_n : float, optional
        ``γn`` of LMI (15); given, it adds that LMI.
    region : PoleRegion or sequence of PoleRegion, optional
        Chilali–Gahinet region(s) for the eigenvalues of ``A − K C``.
    gain_bound : GainBound or float, optional
        ``‖K‖₂ ≤ κ``.
    objective : Objective or str
        As in :func:`design_observer_gain`; ``CENTRAL`` adds the log-det cones.

    Returns
    -------
    SdpEstimate
    """
    obj = _as_objective(objective)
    need_noise = gamma_n is not None or N is not None or obj is Objective.MIN_GAMMA_N
    return _sdp_estimate(_validate_data(A, C, Bd, N, need_noise, region, gain_bound), obj)


def _sdp_estimate(d: _Data, objective: Objective, *, with_K: bool = False) -> SdpEstimate:
    """:func:`sdp_estimate` for validated data; ``with_K``: the SDP of :func:`verify_observer_gain` (``P`` only)."""
    nvar, blocks = lmi_size(d)
    if with_K:  # K given: P is the only matrix variable, no gain-bound blocks
        nvar = d.n * (d.n + 1) // 2
        blocks = blocks[:-2] if d.gain_bound is not None else blocks
        d = _Data(d.A, d.C, d.Bd, d.N, d.regions, None)
    cones = list(blocks)
    n_exp = 0
    if objective is Objective.CENTRAL:
        n, p = d.n, d.C.shape[0]
        logdet = [n] + [int(b.shape[0]) for _, b in _blocks(d, np.zeros((n, n)), np.zeros((n, p)), 1.0, 1.0)]
        if d.gain_bound is not None:
            logdet.append(n + p)
        for k in logdet:
            cones.append(2 * k)
            nvar += k * (k + 1) // 2 + k
            n_exp += k
    svec = [k * (k + 1) // 2 for k in cones]
    dense = sum(v * v for v in svec)
    mem = _MEM_BASE + _MEM_FACTOR * 8.0 * dense
    secs = _SECONDS_AT_N30 * (float(sum(v**3 for v in svec)) / _FLOPS_AT_N30) ** _TIME_EXPONENT
    return SdpEstimate(int(nvar), tuple(cones), int(sum(svec) + 3 * n_exp), int(dense), float(mem), secs,
                       float(MAX_SDP_MEMORY))


def _require_sdp_fits(d: _Data, objective: Objective, why_sdp: str) -> SdpEstimate:
    """Refuse (:class:`ProblemTooLarge`) an SDP whose estimated memory exceeds :data:`MAX_SDP_MEMORY`."""
    est = _sdp_estimate(d, objective)
    if not est.fits:
        raise ProblemTooLarge(
            f"observer-gain SDP too large: n = {d.n} states, {d.C.shape[0]} outputs give {est.describe()}; "
            f"the limit is {est.limit_bytes / 2**30:.2g} GiB (nlobs.synthesis.observer_gain.MAX_SDP_MEMORY). "
            f"The SDP is used because {why_sdp}; the Riccati path (method='riccati', objective 'central' with "
            "gamma and gamma_n, no region, no gain bound) needs no SDP, or reduce the model "
            "(e.g. design per decoupled axis)")
    return est


def _blocks(d: _Data, P: Any, X: Any, gamma2: Any, gamma_n2: Any, *, with14: bool = True,
            with15: bool = True, regions: tuple[PoleRegion, ...] | None = None) -> list[tuple[str, Any]]:
    """The LMI blocks that must be ``≺ 0``, for CVXPY or numeric ``(P, X)``.

    ``gamma2``/``gamma_n2`` may be numbers or CVXPY variables. Written once and
    used both to build the SDP and to re-verify it in NumPy.
    """
    n = d.n
    PF = P @ d.A - X @ d.C  # P (A − K C)
    F11 = PF + PF.T + np.eye(n)
    out: list[tuple[str, Any]] = []
    if with14:
        PB = P @ d.Bd
        m = d.Bd.shape[1]
        out.append(("LMI (14)", symmetrise(bmat([[F11, PB], [PB.T, -gamma2 * np.eye(m)]]))))
    if with15 and d.N is not None:
        XN = X @ d.N
        q = d.N.shape[1]
        out.append(("LMI (15)", symmetrise(bmat([[F11, -XN], [-XN.T, -gamma_n2 * np.eye(q)]]))))
    for r in d.regions if regions is None else regions:
        out.append((f"region: {r.description}", r.lmi(P, PF)))
    return out


@dataclass
class _Formulation:
    P: cp.Variable
    X: Any
    constraints: list[Any]
    neg_blocks: list[Any]  # blocks F with F ⪯ −εI (for log-det terms)
    pos_blocks: list[Any]  # blocks G ⪰ 0 (gain bound)


def _formulate(d: _Data, *, margin: float, gamma2: Any, gamma_n2: Any, with15: bool,
               regions: tuple[PoleRegion, ...], gain_bound: GainBound | None,
               K: NDArray[np.float64] | None = None, slack: Any = None, slack_on: str | None = None,
               with14: bool = True) -> _Formulation:
    """Build the constraints. ``slack_on`` names one block imposed as ``F ⪯ (t − ε) I`` instead."""
    n, p = d.n, d.C.shape[0]
    P = cp.Variable((n, n), symmetric=True, name="P")
    X = P @ K if K is not None else cp.Variable((n, p), name="X")
    cons: list[Any] = [P >> margin * np.eye(n)]
    neg: list[Any] = []
    for name, blk in _blocks(d, P, X, gamma2, gamma_n2, with14=with14, with15=with15, regions=regions):
        k = blk.shape[0]
        if name == slack_on:
            cons.append(blk << (slack - margin) * np.eye(k))
        else:
            cons.append(blk << -margin * np.eye(k))
            neg.append(blk)
    pos: list[Any] = []
    if gain_bound is not None and K is None:
        mu = cp.Variable(nonneg=True, name="mu")
        km = gain_bound.kappa * mu
        G = symmetrise(cp.bmat([[km * np.eye(p), X.T], [X, km * np.eye(n)]]))
        cons.append(P - mu * np.eye(n) >> 0)
        if slack_on == "gain bound":
            cons.append(G >> -slack * np.eye(n + p))
        else:
            cons.append(G >> 0)
            pos.append(G)
    return _Formulation(P, X, cons, neg, pos)


def _central_objective(f: _Formulation) -> cp.Maximize:
    """Analytic centre: ``log det P + Σ log det(−F_i) + Σ log det(G_j)``."""
    terms = [cp.log_det(f.P)] + [cp.log_det(-b) for b in f.neg_blocks] + [cp.log_det(g) for g in f.pos_blocks]
    return cp.Maximize(cp.sum(cp.hstack(terms)))


# --------------------------------------------------------------------------- verification


def _certify(d: _Data, K: NDArray[np.float64], P: NDArray[np.float64] | None, gamma: float,
             gamma_n: float | None) -> tuple[list[Check], float, float | None, NDArray[np.complex128]]:
    """Re-verify a gain independently of any solver (numpy eig + :func:`hinf_norm`)."""
    n = d.n
    Acl = d.A - K @ d.C
    eigs = np.linalg.eigvals(Acl)
    eigs = eigs[np.lexsort((eigs.imag, eigs.real))]
    checks: list[Check] = []
    if P is not None:
        P = 0.5 * (P + P.T)
        X = P @ K  # recomputed from the returned K
        lam_min = float(np.linalg.eigvalsh(P)[0])
        checks.append(Check.compare("P ≻ 0", -lam_min, 0.0, kind=CheckKind.POSITIVITY))
        g2 = gamma**2
        gn2 = gamma_n**2 if gamma_n is not None else 0.0
        for name, blk in _blocks(d, P, X, g2, gn2):
            tol = 100 * _EPS * max(1.0, float(np.linalg.norm(blk, 2)))
            checks.append(Check.compare(name, max_eig(blk), -tol, kind=CheckKind.LMI))
    checks.append(Check.compare("A − K C Hurwitz (max Re λ)", float(np.max(eigs.real)), 0.0, kind=CheckKind.SPECTRUM))
    for r in d.regions:
        checks.append(Check.compare(f"eigenvalues in {r.description} (−margin)", -r.margin(eigs), 0.0,
                                    kind=CheckKind.REGION))
    hH = hinf_norm(Acl, d.Bd, np.eye(n), np.zeros((n, d.Bd.shape[1])))
    checks.append(Check.compare("‖H‖∞ < γ", hH, gamma, kind=CheckKind.NORM))
    hG: float | None = None
    if d.N is not None and gamma_n is not None:
        KN = K @ d.N
        hG = hinf_norm(Acl, -KN, np.eye(n), np.zeros((n, KN.shape[1])))
        checks.append(Check.compare("‖G‖∞ ≤ γn", hG, gamma_n, kind=CheckKind.NORM, strict=False))
    if d.gain_bound is not None:
        checks.append(Check.compare("‖K‖₂ ≤ κ", float(np.linalg.norm(K, 2)), d.gain_bound.kappa, kind=CheckKind.GAIN,
                                    strict=False))
    return checks, float(hH), (None if hG is None else float(hG)), eigs


def _failure_text(checks: Sequence[Check]) -> str:
    return "; ".join(c.summary() for c in checks if not c.passed)


# --------------------------------------------------------------------------- diagnosis


def _stage_slack(d: _Data, stage: str, *, margin: float, gamma2: Any, gamma_n2: Any, with15: bool,
                 regions: tuple[PoleRegion, ...], gain_bound: GainBound | None, with14: bool,
                 solver: Solver, options: Mapping[str, Any] | None) -> tuple[SolveResult, float | None]:
    """Minimal slack ``t`` of ``stage`` with the other listed constraints imposed."""
    t = cp.Variable(name="t")
    f = _formulate(d, margin=margin, gamma2=gamma2, gamma_n2=gamma_n2, with15=with15, regions=regions,
                   gain_bound=gain_bound, slack=t, slack_on=stage, with14=with14)
    prob = cp.Problem(cp.Minimize(t), f.constraints + [t >= -1.0])
    res = solve(prob, solver, options)
    return res, (float(t.value) if res.status.has_solution and t.value is not None else None)


def _min_bound(d: _Data, which: str, *, margin: float, gamma2: Any, gamma_n2: Any, with15: bool,
               regions: tuple[PoleRegion, ...], solver: Solver,
               options: Mapping[str, Any] | None) -> float | None:
    """Smallest γ (``which='gamma'``) or γn (``'gamma_n'``) with the given other constraints."""
    v = cp.Variable(nonneg=True, name=which)
    g2 = v if which == "gamma" else gamma2
    gn2 = v if which == "gamma_n" else gamma_n2
    f = _formulate(d, margin=margin, gamma2=g2, gamma_n2=gn2, with15=with15, regions=regions, gain_bound=None)
    res = solve(cp.Problem(cp.Minimize(v), f.constraints), solver, options)
    if not res.status.has_solution or v.value is None:
        return None
    return math.sqrt(max(float(v.value), 0.0))


def _value(x: Any) -> float:
    """A number, or the value a CVXPY variable took in the last solve."""
    return float(x.value) if is_expression(x) else float(x)


def _verified_feasible(d: _Data, *, gain_bound: GainBound | None, margin: float, gamma2: Any, gamma_n2: Any,
                       with15: bool, regions: tuple[PoleRegion, ...], with14: bool, solver: Solver,
                       options: Mapping[str, Any] | None) -> bool | None:
    """Feasibility of the constraints themselves (no slack): ``True`` only for an answer re-verified in NumPy.

    ``False`` when the solver claims infeasibility, ``None`` when undecided (a solver failure, or an
    answer that does not verify). The slack problems of :func:`_stage_slack` add a variable whose
    scale differs from the blocks'; on stiff data (eigenvalues spanning 1e−3 … 1e4) Clarabel was
    measured to fail on every one of them while the plain problem solves and verifies.
    """
    f = _formulate(d, margin=margin, gamma2=gamma2, gamma_n2=gamma_n2, with15=with15, regions=regions,
                   gain_bound=gain_bound, with14=with14)
    # With a gain bound the feasible set is bounded and its analytic centre (the design's own
    # objective) exists; it is also the better-conditioned problem for the interior-point solver.
    obj = _central_objective(f) if gain_bound is not None else cp.Minimize(0)
    res = solve(cp.Problem(obj, f.constraints), solver, options)
    if res.status.is_infeasible:
        return False
    if not res.status.has_solution or f.P.value is None or f.X.value is None:
        return None
    P = 0.5 * (np.asarray(f.P.value) + np.asarray(f.P.value).T)
    X = np.asarray(f.X.value)
    try:
        g2 = _value(gamma2) if with14 else 0.0
        gn2 = _value(gamma_n2) if with15 else 0.0
        K = np.linalg.solve(P, X)
    except (TypeError, np.linalg.LinAlgError):
        return None
    if not (np.all(np.isfinite(K)) and float(np.linalg.eigvalsh(P)[0]) > 0.0):
        return None
    blocks = _blocks(d, P, X, g2, gn2, with14=with14, with15=with15, regions=regions)
    if any(max_eig(blk) >= 0.0 for _, blk in blocks):
        return None
    if gain_bound is not None and float(np.linalg.norm(K, 2)) > gain_bound.kappa:
        return None
    return True


def _smallest_gain_bound(d: _Data, kappa: float, *, undecided: list[str] | None = None,
                         **kw: Any) -> float | None:
    """Bisection (in log κ) for the smallest feasible gain bound, or ``None`` beyond 1e9.

    A bound is feasible when the plain problem gives a verified answer, or else when the slack
    problem's minimal slack is ≤ 0; bounds the solver could not decide either way are
    recorded in ``undecided`` (and treated as infeasible by the bisection).
    """

    def feasible(k: float) -> bool:
        v = _verified_feasible(d, gain_bound=GainBound(k), **kw)
        if v is not None:
            return v
        res, t = _stage_slack(d, "gain bound", gain_bound=GainBound(k), **kw)
        if t is None and not res.status.is_infeasible and undecided is not None:
            undecided.append(f"κ = {k:.3g}: {res.raw_status}")
        return t is not None and t <= _SLACK_TOL

    hi = kappa
    while True:
        hi *= 10.0
        if hi > 1e9:
            return None
        if feasible(hi):
            break
    lo = hi / 10.0
    for _ in range(14):
        mid = math.sqrt(lo * hi)
        if feasible(mid):
            hi = mid
        else:
            lo = mid
    return hi


def _diagnose(d: _Data, *, gamma: float | None, gamma_n: float | None, margin: float, solver: Solver,
              options: Mapping[str, Any] | None, main: SolveResult) -> NoReturn:
    """Find the first constraint whose addition makes the design infeasible and raise."""
    with15 = d.N is not None and gamma_n is not None
    free = cp.Variable(nonneg=True)  # unconstrained γ² when it is minimised without bound
    g2: Any = gamma**2 if gamma is not None else free
    gn2: Any = gamma_n**2 if gamma_n is not None else cp.Variable(nonneg=True)
    common = dict(margin=margin, solver=solver, options=options)

    stages: list[str] = []
    if gamma is not None:
        stages.append("LMI (14)")
    if with15:
        stages.append("LMI (15)")
    stages += [f"region: {r.description}" for r in d.regions]
    if d.gain_bound is not None:
        stages.append("gain bound")

    for k, stage in enumerate(stages):
        on = stages[: k + 1]
        regions = tuple(r for r in d.regions if f"region: {r.description}" in on)
        kw = dict(gamma2=g2, gamma_n2=gn2, with15=with15 and "LMI (15)" in on, regions=regions, with14=True, **common)
        gb = d.gain_bound if "gain bound" in on else None
        res, t = _stage_slack(d, stage, gain_bound=gb, **kw)  # type: ignore[arg-type]
        if t is not None and t <= _SLACK_TOL:
            continue
        if t is None and not res.status.is_infeasible and _verified_feasible(d, gain_bound=gb, **kw):  # type: ignore[arg-type]
            continue  # the slack problem failed, the constraints themselves hold (verified)
        before = ", ".join(on[:-1]) or "P ≻ 0"
        if stage == "LMI (14)":
            gmin = _min_bound(d, "gamma", gamma_n2=gn2, gamma2=None, with15=False, regions=(), **common)  # type: ignore[arg-type]
            shown = f"≈ {gmin:.6g}" if gmin is not None else "unknown (the solver failed)"
            assert gamma is not None
            raise DesignInfeasible(
                f"LMI (14) (bounded-real lemma, ‖H‖∞ < γ) is infeasible for γ = {gamma:g}: the smallest "
                f"achievable γ is {shown} (an infimum over stabilising gains; by Theorem 2 it is > 0 when "
                "(A, B_z, C, D_z) is not minimum phase). Choose γ above it.",
                constraint="LMI (14)",
                violation=(gmin - gamma) if gmin is not None else t,
            )
        if stage == "LMI (15)":
            gnmin = _min_bound(d, "gamma_n", gamma2=g2, gamma_n2=None, with15=True, regions=(), **common)  # type: ignore[arg-type]
            shown = f"≈ {gnmin:.6g}" if gnmin is not None else "unknown (the solver failed)"
            assert gamma_n is not None
            raise DesignInfeasible(
                f"LMI (15) (‖G‖∞ ≤ γn) cannot hold with a common P together with LMI (14) at "
                f"{'γ = ' + format(gamma, 'g') if gamma is not None else 'free γ'}: γn = {gamma_n:g} is too small; "
                f"the smallest achievable γn is {shown} (possibly an infimum approached only as ‖K‖ → ∞: "
                "choose γn somewhat above it).",
                constraint="LMI (15)",
                violation=(gnmin - gamma_n) if gnmin is not None else t,
            )
        if stage == "gain bound":
            assert d.gain_bound is not None
            kw2 = dict(kw)
            undecided: list[str] = []
            kmin = _smallest_gain_bound(d, d.gain_bound.kappa, undecided=undecided, **kw2)
            if kmin is not None:
                shown = f"≈ {kmin:.4g}"
            elif undecided:
                shown = ("unknown: the solver could not decide the larger bounds "
                         f"({'; '.join(undecided[:3])}), so none up to 1e9 was verified")
            else:
                shown = "above 1e9"
            raise DesignInfeasible(
                f"the gain bound ‖K‖₂ ≤ κ = {d.gain_bound.kappa:g} is infeasible together with {before}: "
                f"the smallest feasible gain bound with these constraints is {shown}. Relax the pole region(s), "
                "γ/γn, or the bound.",
                constraint="gain bound",
                violation=(kmin - d.gain_bound.kappa) if kmin is not None else t,
            )
        # a pole region
        by = f"{t:.3g}" if t is not None else f"unknown (solver status {res.raw_status})"
        raise DesignInfeasible(
            f"the pole {stage} is infeasible together with {before} (common Lyapunov matrix P, margin "
            f"ε = {margin:g}): the largest eigenvalue of its LMI block cannot be brought below {by} > 0. "
            "Enlarge the region or relax γ/γn.",
            constraint=stage,
            violation=t,
        )
    raise DesignInfeasible(
        f"the solver ({main.solver.value}) returned '{main.raw_status}' although every constraint stage "
        f"({', '.join(stages) or 'LMI (14)'}) is feasible on its own path; try solver=Solver.CLARABEL/SCS, a larger "
        f"margin than ε = {margin:g}, or rescale the channels",
        constraint="solver",
    )


# --------------------------------------------------------------------------- design


@dataclass(frozen=True)
class _Solved:
    K: NDArray[np.float64]
    P: NDArray[np.float64]
    gamma: float
    gamma_n: float | None
    result: SolveResult


def _solve_once(d: _Data, objective: Objective, gamma: float | None, gamma_n: float | None, margin: float,
                solver: Solver, options: Mapping[str, Any] | None) -> _Solved | SolveResult:
    """One SDP at margin ``ε``; returns the solution or the failed :class:`SolveResult`."""
    g2: Any = gamma**2 if gamma is not None else None
    gn2: Any = gamma_n**2 if gamma_n is not None else None
    extra: list[Any] = []
    var: cp.Variable | None = None
    if objective is Objective.MIN_GAMMA:
        var = cp.Variable(nonneg=True, name="gamma2")
        if g2 is not None:
            extra.append(var <= g2)
        g2 = var
    elif objective is Objective.MIN_GAMMA_N:
        var = cp.Variable(nonneg=True, name="gamma_n2")
        if gn2 is not None:
            extra.append(var <= gn2)
        gn2 = var
    with15 = d.N is not None and gn2 is not None
    f = _formulate(d, margin=margin, gamma2=g2, gamma_n2=gn2, with15=with15, regions=d.regions,
                   gain_bound=d.gain_bound)
    obj = _central_objective(f) if var is None else cp.Minimize(var)
    res = solve(cp.Problem(obj, f.constraints + extra), solver, options)
    if not res.status.has_solution or f.P.value is None:
        return res
    P = 0.5 * (f.P.value + f.P.value.T)
    X = np.asarray(f.X.value, dtype=float)
    try:
        K = np.linalg.solve(P, X)
    except np.linalg.LinAlgError:
        return SolveResult(SolveStatus.SOLVER_ERROR, "singular P", res.solver, None, res.seconds)
    g_out = math.sqrt(float(var.value)) if objective is Objective.MIN_GAMMA and var is not None else gamma
    gn_out = math.sqrt(float(var.value)) if objective is Objective.MIN_GAMMA_N and var is not None else gamma_n
    assert g_out is not None
    return _Solved(K, P, float(g_out), gn_out, res)


def _check_attained(d: _Data, objective: Objective, gamma: float | None, gamma_n: float | None, margin: float,
                    first: _Solved, solver: Solver, options: Mapping[str, Any] | None) -> None:
    """Raise :class:`DesignUnbounded` when the minimiser is set by the margin ``ε``, not by the problem.

    Re-solves at ``100 ε`` (or, if that is infeasible, at ``ε/100``). The
    minimum is declared not attained when, between the two margins,

    * the gain grows by more than 10× (``ε`` shrinks 100×), or
    * the optimal value moves by more than 1 % (relative), or
    * either solve ends ``optimal_inaccurate`` (the solver is chasing an
      infimum with exploding gains; seen on non-minimum-phase examples).
    """
    if objective is Objective.MIN_GAMMA_N:
        sym, lmis, fix = "γn", "(14), (15)", "gamma_n"

        def val(s: _Solved) -> float:
            assert s.gamma_n is not None
            return s.gamma_n
    else:
        sym, lmis, fix = "γ", "(14)", "gamma"

        def val(s: _Solved) -> float:
            return s.gamma

    advice = (
        f"Use objective=Objective.CENTRAL with {fix} fixed slightly above the infimum "
        f"(e.g. {val(first) * 1.002:.5g}), or pass gain_bound=GainBound(κ) so that the minimum is attained."
    )
    other = _solve_once(d, objective, gamma, gamma_n, 100 * margin, solver, options)
    if isinstance(other, _Solved):
        (e_big, big), (e_small, small) = (100 * margin, other), (margin, first)
    else:
        other = _solve_once(d, objective, gamma, gamma_n, margin / 100, solver, options)
        if not isinstance(other, _Solved):
            return
        (e_big, big), (e_small, small) = (margin, first), (margin / 100, other)
    k_big, k_small = float(np.linalg.norm(big.K, 2)), float(np.linalg.norm(small.K, 2))
    v_big, v_small = val(big), val(small)
    numbers = (
        f"At ε = {e_big:g}: ‖K‖₂ = {k_big:.4g}, {sym} = {v_big:.7g} ({big.result.raw_status}); at ε = "
        f"{e_small:g}: ‖K‖₂ = {k_small:.4g}, {sym} = {v_small:.7g} ({small.result.raw_status})."
    )
    change = abs(v_big - v_small) / max(abs(v_big), 1e-300)
    if k_small > _UNBOUNDED_GROWTH * k_big or change > 1e-2:
        raise DesignUnbounded(
            f"minimising {sym}² subject to LMIs {lmis} has no minimum here: the optimum is set by the strictness "
            f"margin ε, not by the problem. {numbers} (gain ×{k_small / max(k_big, 1e-300):.3g}, {sym} changed by "
            f"{100 * change:.2g} %). The infimum {sym} ≈ {v_small:.6g} is approached only as ‖K‖ → ∞. {advice}"
        )
    if SolveStatus.OPTIMAL_INACCURATE in (big.result.status, small.result.status):
        raise DesignUnbounded(
            f"minimising {sym}² subject to LMIs {lmis} is numerically ill-posed: the solver could only reach "
            f"'optimal_inaccurate' with ‖K‖₂ up to {max(k_big, k_small):.4g}. {numbers} Such an infimum is "
            f"typically approached only as ‖K‖ → ∞ (≈ {min(v_big, v_small):.6g}). {advice}"
        )


def _riccati_inapplicable(d: _Data, objective: Objective, gamma_n: float | None) -> str | None:
    """Why the problem has no Riccati form (``None`` when it has one): the reason the SDP is needed."""
    if objective is not Objective.CENTRAL:
        return f"objective {objective.value!r} is a minimisation over the LMIs"
    if gamma_n is None or d.N is None:
        return "gamma_n is not given (the Riccati form bounds ‖H‖∞ and ‖G‖∞ together)"
    if d.regions:
        return "a pole region is asked (Chilali–Gahinet LMIs)"
    if d.gain_bound is not None:
        return "a gain bound is asked"
    sv = np.linalg.svd(d.N, compute_uv=False)
    if sv.size == 0 or sv[-1] <= 1e-8 * max(sv[0], 1e-300) or d.N.shape[1] < d.N.shape[0]:
        return "N Nᵀ is singular (every measurement needs its own noise for the Riccati form)"
    return None


_RiccatiOut = tuple[FilterRiccati, tuple[list[Check], float, float | None, NDArray[np.complex128]]]


#: Output weights ``1 + σ`` tried in turn on the Riccati path (the first whose LMI blocks verify is kept).
_RICCATI_SIGMAS = (1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1)


def _blocks_verify(d: _Data, K: NDArray[np.float64], P: NDArray[np.float64], gamma: float, gamma_n: float) -> bool:
    """Whether the LMI blocks pass the certificate's own test (cheap: no H∞ norm)."""
    for _, blk in _blocks(d, P, P @ K, gamma**2, gamma_n**2):
        if not max_eig(blk) < -100 * _EPS * max(1.0, float(np.linalg.norm(blk, 2))):
            return False
    return True


def _riccati_design(d: _Data, gamma: float, gamma_n: float, margin: float) -> _RiccatiOut | str:
    """The gain of the H∞ filter Riccati equation with its certificate checks, or why no solution exists.

    The output weight ``1 + σ`` (the strictness) starts at ``σ = 10⁻⁶`` and grows tenfold while the
    LMI blocks lose their sign to rounding (:data:`_RICCATI_SIGMAS`); ``δ`` is
    :func:`~nlobs.synthesis.riccati.riccati_delta`. The first solution whose blocks verify is certified
    in full; if none does, the last solution's checks are returned (they fail).
    """
    assert d.N is not None
    W = d.N @ d.N.T
    W = 0.5 * (W + W.T)
    delta = riccati_delta(d.Bd, gamma, margin)
    last: FilterRiccati | None = None
    for sigma in _RICCATI_SIGMAS:
        sol = filter_riccati(d.A, d.C, d.Bd, W, gamma, gamma_n, delta, sigma)
        if isinstance(sol, str):
            if last is None:
                return sol
            break
        last = sol
        if _blocks_verify(d, sol.K, sol.P, gamma, gamma_n):
            break
    assert last is not None
    return last, _certify(d, last.K, last.P, gamma, gamma_n)


def _riccati_infeasible(d: _Data, gamma: float, gamma_n: float, margin: float, reason: str, tail: str) -> NoReturn:
    assert d.N is not None
    W = d.N @ d.N.T
    tau = smallest_riccati_scale(d.A, d.C, d.Bd, 0.5 * (W + W.T), gamma, gamma_n, margin)
    shown = (f"it holds from about τ = {tau:.4g} (γ = {tau * gamma:.6g}, γn = {tau * gamma_n:.6g})" if tau is not None
             else "no scaling τ ≤ 10⁶ of (γ, γn) makes it solvable")
    raise DesignInfeasible(
        f"the H∞ filter Riccati equation (the sufficient form of LMIs (14), (15): ‖[H/γ, G/γn]‖∞ < 1) has no "
        f"stabilising solution at γ = {gamma:g}, γn = {gamma_n:g}: {reason}; scaling both bounds by τ, {shown}. "
        f"{tail}",
        constraint="Riccati equation",
        violation=(tau - 1.0) if tau is not None else None,
    )


@takes_system(time="continuous", A="A", C="C", Bd="B")
def design_observer_gain(
    A: ArrayLike,
    C: ArrayLike,
    Bd: ArrayLike,
    *,
    gamma: float | None = None,
    N: ArrayLike | None = None,
    gamma_n: float | None = None,
    region: RegionArg = None,
    gain_bound: GainBound | float | None = None,
    objective: Objective | str = Objective.CENTRAL,
    solver: Solver | str = Solver.CLARABEL,
    margin: float = 1e-6,
    solver_options: Mapping[str, Any] | None = None,
    method: SynthesisMethod | str = SynthesisMethod.AUTO,
) -> ObserverGainCertificate:
    r"""Design an observer gain ``K`` from LMIs (14), (15) of Grip, Saberi & Johansen and certify it.

    Parameters
    ----------
    A, C, Bd : array_like
        ``𝔄 (n×n)``, ``ℭ (p×n)``, ``𝔅_d (n×m)`` of the error dynamics (12a); see
        :func:`extended_system` for (8c).
    gamma : float
        ``γ`` of LMI (14), ``‖H‖∞ < γ``. Required except for
        :attr:`Objective.MIN_GAMMA`, where a given value is an upper bound.
    N : array_like, shape (p, q), optional
        Noise input matrix (``y = ℭ w_e + N n``); ``I_p`` when ``gamma_n`` is given
        or ``γn`` is minimised.
    gamma_n : float, optional
        ``γn`` of LMI (15), ``‖G‖∞ ≤ γn``. With :attr:`Objective.MIN_GAMMA_N` a
        given value is an upper bound.
    region : PoleRegion or sequence of PoleRegion, optional
        Chilali–Gahinet region(s) for the eigenvalues of ``A − K C`` (the
        intersection when several), with the common ``P``.
    gain_bound : GainBound or float, optional
        ``‖K‖₂ ≤ κ`` (see :class:`GainBound`).
    objective : Objective or str
        :attr:`~Objective.CENTRAL` (default; analytic centre at fixed ``γ`` and
        ``γn``; needs ``gamma_n`` or ``gain_bound`` so that the centre exists),
        :attr:`~Objective.MIN_GAMMA_N` or :attr:`~Objective.MIN_GAMMA` (checked
        for attainment, see Raises).
    solver : Solver or str
        :attr:`Solver.CLARABEL` (default) or :attr:`Solver.SCS`.
    margin : float
        Strictness margin ``ε``: ``F ⪯ −ε I`` for each block, ``P ⪰ ε I``.
    solver_options : mapping, optional
        Extra solver options.
    method : SynthesisMethod or str
        ``"auto"`` (default): the Riccati path when the problem has a Riccati form — objective
        ``CENTRAL`` with ``gamma`` and ``gamma_n``, no ``region``, no ``gain_bound``, ``N Nᵀ ≻ 0`` —
        else the SDP; when the Riccati equation has no solution (it is only sufficient for the LMIs) the
        SDP is tried if its estimated size fits. ``"riccati"`` forces the H∞ filter Riccati equation
        (:mod:`nlobs.synthesis.riccati`; ``K = γn² Y Cᵀ (N Nᵀ)⁻¹``, ``P = Y⁻¹``), ``"sdp"`` the LMIs.
        The certificate's ``method`` says which path produced it; its checks are the same.

    Returns
    -------
    ObserverGainCertificate
        Status :attr:`~CertificateStatus.VERIFIED`; ``K = P⁻¹ X``.

    Raises
    ------
    DesignInfeasible
        ``(A, C)`` not detectable (``constraint='detectability'``), or the first
        constraint that makes the problem infeasible — ``'Riccati equation'`` (Riccati path: no
        stabilising solution; the message gives the scaling of ``(γ, γn)`` from which one exists),
        ``'LMI (14)'`` (message
        gives the smallest achievable ``γ``), ``'LMI (15)'`` (smallest ``γn``), a
        region (minimal slack of its block) or ``'gain bound'`` (smallest ``κ``,
        a bound for which the design was solved and re-verified, or "unknown" with
        the solver statuses when the solver could not decide the larger bounds).
    DesignUnbounded
        A minimisation whose optimum moves with ``ε`` (gain ×>10 when ``ε``
        shrinks 100×): the infimum is not attained.
    CertificateError
        The solver's answer failed the independent re-verification.
    ProblemTooLarge
        An SDP whose estimated solver memory (:func:`sdp_estimate`) exceeds :data:`MAX_SDP_MEMORY`,
        refused before it is built (the message gives the size, the limit and what to change).
    DimensionError, NonFiniteError, InvalidArgumentError
        Bad input; or a problem larger than :data:`MAX_LMI_SIZE` (refused before it is built,
        the message gives the variables, the block sizes and the bound).
    NumericalError
        An entry of ``A, C, Bd`` or ``N`` exceeds
        :data:`~nlobs.linear.stability.MAGNITUDE_LIMIT` in magnitude.

    Examples
    --------
    A damped oscillator measured in position, the disturbance entering the velocity:

    >>> import numpy as np
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> cert = design_observer_gain(A, C, Bd, gamma=10.0, gamma_n=10.0)
    >>> cert.verified, cert.method.value  # re-verified without the solver; the Riccati path needed no SDP
    (True, 'riccati')
    >>> bool(cert.hinf_H < 10.0 and np.linalg.eigvals(A - cert.gain @ C).real.max() < 0)
    True
    """
    t0 = time.perf_counter()
    obj = _as_objective(objective)
    slv = as_solver(solver)
    eps = _margin(margin)
    g = positive("gamma", gamma) if gamma is not None else None
    gn = positive("gamma_n", gamma_n) if gamma_n is not None else None
    if g is None and obj is not Objective.MIN_GAMMA:
        raise InvalidArgumentError(f"gamma: required for objective {obj.value!r} (the bound of LMI (14))")
    need_noise = gn is not None or obj is Objective.MIN_GAMMA_N
    if N is not None and not need_noise:
        raise InvalidArgumentError("N: given without gamma_n; pass gamma_n (LMI (15)) or objective=MIN_GAMMA_N")
    d = _validate_data(A, C, Bd, N, need_noise, region, gain_bound)
    if obj is Objective.CENTRAL and gn is None and d.gain_bound is None:
        raise InvalidArgumentError(
            "objective CENTRAL needs a bounded feasible set: give gamma_n (LMI (15) bounds the gain) or "
            "gain_bound=GainBound(κ); with LMI (14) alone the analytic centre does not exist (gains can grow "
            "without bound)"
        )
    meth = as_enum("method", SynthesisMethod, method)
    why_sdp = _riccati_inapplicable(d, obj, gn)
    if meth is SynthesisMethod.RICCATI and why_sdp is not None:
        raise InvalidArgumentError(f"method 'riccati': the problem has no Riccati form: {why_sdp}; use "
                                   "method='sdp' or 'auto'")
    if meth is not SynthesisMethod.SDP and why_sdp is None:
        assert g is not None and gn is not None
        _require_detectable(d.A, d.C)
        out = _riccati_design(d, g, gn, eps)
        if not isinstance(out, str):
            if meth is SynthesisMethod.RICCATI or all(c.passed for c in out[1][0]) or not _sdp_estimate(d, obj).fits:
                return _riccati_certificate(d, out, g, gn, obj, eps, t0)  # raises CertificateError if unverified
            out = f"its answer failed the re-verification: {_failure_text(out[1][0])}"
        if meth is SynthesisMethod.RICCATI:
            _riccati_infeasible(d, g, gn, eps, out, "The exact LMIs may still hold: try method='sdp'.")
        est = _sdp_estimate(d, obj)
        if not est.fits:
            _riccati_infeasible(
                d, g, gn, eps, out,
                f"The exact LMIs (an SDP) may still hold, but that SDP is too large here ({est.describe()}; the "
                f"limit is {est.limit_bytes / 2**30:.2g} GiB): raise γ or γn, or reduce the model.")
        why_sdp = f"the Riccati path gave no verified gain ({out})"
    _check_size(d)
    _require_sdp_fits(d, obj, why_sdp or "method='sdp' was asked")
    _require_detectable(d.A, d.C)

    sol = _solve_once(d, obj, g, gn, eps, slv, solver_options)
    if not isinstance(sol, _Solved):
        if sol.status.name.startswith("UNBOUNDED"):
            raise DesignUnbounded(
                f"the solver reports the {obj.value} problem unbounded ({sol.raw_status}); add gamma_n or a gain bound"
            )
        _diagnose(d, gamma=g, gamma_n=gn, margin=eps, solver=slv,
                  options=solver_options, main=sol)
    if obj is not Objective.CENTRAL and d.gain_bound is None:
        _check_attained(d, obj, g, gn, eps, sol, slv, solver_options)

    checks, hH, hG, eigs = _certify(d, sol.K, sol.P, sol.gamma, sol.gamma_n)
    cert = ObserverGainCertificate(
        gain=readonly(sol.K, None), P=readonly(sol.P, None), gamma=sol.gamma, gamma_n=sol.gamma_n, hinf_H=hH, hinf_G=hG,
        eigenvalues=readonly(eigs, None), checks=tuple(checks), objective=obj, solver=slv,
        solver_status=sol.result.raw_status, margin=eps, seconds=time.perf_counter() - t0,
    )
    if not cert.verified:
        raise CertificateError(
            f"the {slv.value} answer ('{sol.result.raw_status}') failed the independent re-verification: "
            f"{_failure_text(checks)}"
        )
    return cert


def _riccati_certificate(d: _Data, out: _RiccatiOut, gamma: float, gamma_n: float, obj: Objective, eps: float,
                         t0: float) -> ObserverGainCertificate:
    sol, (checks, hH, hG, eigs) = out
    status = (f"riccati: stabilising solution (σ = {sol.sigma:.3g}, δ = {sol.delta:.3g}, relative residual "
              f"{sol.residual:.2g}, "
              f"Hamiltonian axis gap {sol.axis_gap:.2g})")
    cert = ObserverGainCertificate(
        gain=readonly(sol.K, None), P=readonly(sol.P, None), gamma=gamma, gamma_n=gamma_n, hinf_H=hH, hinf_G=hG,
        eigenvalues=readonly(eigs, None), checks=tuple(checks), objective=obj, solver=None, solver_status=status,
        margin=eps, seconds=time.perf_counter() - t0, method=SynthesisMethod.RICCATI,
    )
    if not cert.verified:
        raise CertificateError(
            f"the Riccati answer ({status}) failed the independent re-verification: {_failure_text(checks)}")
    return cert


@takes_system(time="continuous", A="A", C="C", Bd="B")
def verify_observer_gain(
    A: ArrayLike,
    C: ArrayLike,
    Bd: ArrayLike,
    K: ArrayLike,
    *,
    gamma: float,
    N: ArrayLike | None = None,
    gamma_n: float | None = None,
    region: RegionArg = None,
    gain_bound: GainBound | float | None = None,
    solver: Solver | str = Solver.CLARABEL,
    margin: float = 1e-6,
    strict: bool = True,
    solver_options: Mapping[str, Any] | None = None,
) -> ObserverGainCertificate:
    r"""Certify a *given* gain ``K`` (e.g. a published one) against LMIs (14), (15) and regions.

    With ``K`` fixed, ``X = P K`` and every block is linear in ``P`` alone; the
    analytic centre ``P`` of those LMIs is computed, then everything is
    re-verified as in :func:`design_observer_gain` (closed-loop eigenvalues,
    region margins, ``‖H‖∞ < γ`` and ``‖G‖∞ ≤ γn`` with
    :func:`~nlobs.linear.norms.hinf_norm`, each LMI block with that ``P``).

    Parameters
    ----------
    A, C, Bd : array_like
        As in :func:`design_observer_gain`.
    K : array_like, shape (n, p)
        The gain to certify.
    gamma, N, gamma_n, region, gain_bound, solver, margin, solver_options
        As in :func:`design_observer_gain` (``N = I`` when ``gamma_n`` is given).
    strict : bool
        Raise :class:`~nlobs.errors.CertificateError` on failure (default);
        with ``False`` return a certificate with status
        :attr:`~CertificateStatus.FAILED` and the failed checks.

    Raises
    ------
    ProblemTooLarge
        The SDP in ``P`` would exceed :data:`MAX_SDP_MEMORY` (estimated before it is built).

    Returns
    -------
    ObserverGainCertificate
        ``P`` is ``None`` when no common Lyapunov matrix exists (e.g. a
        non-Hurwitz ``A − K C``); then a check named ``'common P for the LMIs'``
        reports the smallest achievable largest eigenvalue over the blocks.

    Examples
    --------
    A hand-placed gain for the damped oscillator of :func:`design_observer_gain` (eigenvalues of
    ``A − K C`` at ``−2, −3``) certified against LMI (14); a destabilising one fails, with reasons:

    >>> import numpy as np
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> cert = verify_observer_gain(A, C, Bd, [[4.5], [1.75]], gamma=10.0)
    >>> cert.verified, cert.objective, round(cert.hinf_H, 3), np.round(cert.eigenvalues.real, 6).tolist()
    (True, None, 0.768, [-3.0, -2.0])
    >>> bad = verify_observer_gain(A, C, Bd, [[-1.0], [0.0]], gamma=10.0, strict=False)
    >>> bad.status.value, bad.P is None, [c.name for c in bad.failed_checks]
    ('failed', True, ['A − K C Hurwitz (max Re λ)', '‖H‖∞ < γ'])
    """
    t0 = time.perf_counter()
    slv = as_solver(solver)
    eps = _margin(margin)
    g = positive("gamma", gamma)
    gn = positive("gamma_n", gamma_n) if gamma_n is not None else None
    if N is not None and gn is None:
        raise InvalidArgumentError("N: given without gamma_n; pass gamma_n (LMI (15))")
    d = _validate_data(A, C, Bd, N, gn is not None, region, gain_bound)
    K_ = as_matrix("K", K, (d.n, d.C.shape[0]))
    _check_size(d, with_K=True)

    eig_max = float(np.max(np.linalg.eigvals(d.A - K_ @ d.C).real))
    P_val: NDArray[np.float64] | None = None
    raw = "not run (A − K C is not Hurwitz: no P ≻ 0 can exist)"
    extra: list[Check] = []
    if eig_max < 0:
        est = _sdp_estimate(d, Objective.CENTRAL, with_K=True)
        if not est.fits:
            raise ProblemTooLarge(
                f"observer-gain verification SDP too large: n = {d.n} states, {d.C.shape[0]} outputs give "
                f"{est.describe()}; the limit is {est.limit_bytes / 2**30:.2g} GiB "
                "(nlobs.synthesis.observer_gain.MAX_SDP_MEMORY). The norms alone need no SDP "
                "(nlobs.linear.hinf_norm of A − K C); or reduce the model (e.g. verify per decoupled axis)")
        gn2 = gn**2 if gn is not None else None
        f = _formulate(d, margin=eps, gamma2=g**2, gamma_n2=gn2, with15=gn is not None, regions=d.regions,
                       gain_bound=None, K=K_)
        res = solve(cp.Problem(_central_objective(f), f.constraints), slv, solver_options)
        raw = res.raw_status
        if res.status.has_solution and f.P.value is not None:
            P_val = 0.5 * (f.P.value + f.P.value.T)
        else:
            # how far from feasible: min t with every block ⪯ t I (common P)
            t = cp.Variable()
            P = cp.Variable((d.n, d.n), symmetric=True)
            blocks = _blocks(d, P, P @ K_, g**2, gn2 if gn2 is not None else 0.0)
            cons = [P >> eps * np.eye(d.n)] + [b << t * np.eye(b.shape[0]) for _, b in blocks]
            r2 = solve(cp.Problem(cp.Minimize(t), cons + [t >= -1.0]), slv, solver_options)
            tv = float(t.value) if r2.status.has_solution and t.value is not None else math.inf
            extra.append(Check.compare("common P for the LMIs (min over P of the largest block eigenvalue)", tv, -eps,
                                       kind=CheckKind.LMI))
    checks, hH, hG, eigs = _certify(d, K_, P_val, g, gn)
    checks = extra + checks
    ok = all(c.passed for c in checks)
    cert = ObserverGainCertificate(
        gain=readonly(K_, None), P=None if P_val is None else readonly(P_val, None), gamma=g, gamma_n=gn,
        hinf_H=hH, hinf_G=hG,
        eigenvalues=readonly(eigs, None), checks=tuple(checks), objective=None, solver=slv, solver_status=raw,
        margin=eps, seconds=time.perf_counter() - t0,
    )
    if strict and not ok:
        raise CertificateError(f"the given gain K failed verification: {_failure_text(checks)}")
    return cert
