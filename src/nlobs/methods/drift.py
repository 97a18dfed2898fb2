r"""The drift observer (3.1) of Dalla Mora, Germani & Manes as a method: its design report and its :class:`Method`.

For a continuous-time input-affine model that is drift-observable with multi-index ``s``
(Def. 2.3) the observer is (3.1), ``x̂̇ = f(x̂) + g(x̂) u + Q_s(x̂)⁻¹ K (y − h(x̂))``
(:class:`nlobs.observers.drift.DriftObserver`).

* :func:`design_drift_report` — structure on a region (``s``, the observation relative degree
  ``r``, drift-observability, ``s ≤ r``), ``F_{s,r}`` (2.12) and ``H_{s,r}`` (2.11), the sampled
  Lipschitz constants (:func:`nlobs.geometry.lipschitz.lipschitz_estimates`), the gain of (2.17)
  (Remark 2.11 or the SDP, :mod:`nlobs.synthesis.drift_gain`) and the constants ``κ₁``, ``κ₂`` of
  (3.17) (:mod:`nlobs.synthesis.drift_bounds`), as a :class:`DriftDesignReport` with a verdict;
* :data:`DRIFT` — the method: the region of the problem, ``α = 1`` and the input bound ``μ`` of
  (2.17) the largest ``‖u(t)‖`` of the problem's known input (:mod:`nlobs.methods.problem`),
  unless given.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from nlobs._typing import Array
from nlobs._validate import positive, readonly
from nlobs._schema import BOOLEAN, INTEGER, MATRIX, NUMBER, OBJECT, STRING, Record, array
from nlobs.checks import CHECK_JSON, Check, CheckKind
from nlobs.errors import InvalidArgumentError, AssumptionViolated, DesignInfeasible, ModelError, NlobsError
from nlobs.geometry.checks import check_drift_observability, check_s_le_r, default_multi_index
from nlobs.geometry.lipschitz import LipschitzEstimates, lipschitz_estimates
from nlobs.geometry.observability import (
    AffineFields,
    check_multi_index,
    input_gain_structure,
    observation_relative_degree,
)
from nlobs.geometry.region import Box
from nlobs.methods.base import Design
from nlobs.methods.problem import Problem
from nlobs.methods.sensor_design import drift_sampling_bound, on_samples, sampling_form
from nlobs.observers.drift import COND_LIMIT, DriftObserver
from nlobs.simulate.coverage import InputBound, InRegion, Premise
from nlobs.synthesis.drift_bounds import ErrorBoundConstants, error_bound_constants
from nlobs.synthesis.drift_gain import DriftGainCertificate, RiccatiConstants, design_drift_gain, require_sdp_size
from nlobs.synthesis.mapped_bound import MappedBound
from nlobs.systems.symbolic import SymbolicModel

__all__ = ["DEFAULT_ALPHA", "DRIFT", "METHODS", "DriftDesignReport", "DriftMethod", "design_drift_report"]

#: The gain designs of (2.17): Remark 2.11 (Vandermonde) and the LMI in ``S = P⁻¹``, ``Y = S K``.
METHODS: tuple[str, ...] = ("vandermonde", "sdp")
#: A given ``γ`` counts as below the sampled estimate when smaller by more than this relative amount.
_GAMMA_RTOL = 1e-9
#: The decay rate ``α`` of (2.17) unless given.
DEFAULT_ALPHA = 1.0


@dataclass(frozen=True, eq=False)
class DriftDesignReport:
    """Everything ``nlobs design drift`` prints: structure, checks, gain, verification, bound constants.

    Attributes
    ----------
    fields : AffineFields
    s, r : tuple
        Multi-index and observation relative degrees (``None``: undefined on the region).
    checks : tuple of Check
        Drift-observability on the region and ``s ≤ r``.
    F : ndarray
        ``F_{s,r}`` (2.12).
    H : str
        ``H_{s,r}(x)`` (2.11), as text.
    gamma : float
        ``γ`` used in (2.17).
    gamma_source : str
        ``"given"`` or ``"estimated"`` (``√(γ_L² + γ_H²)`` from :attr:`lipschitz`).
    certificate : DriftGainCertificate
    lipschitz : LipschitzEstimates
    bound : ErrorBoundConstants
    region : Box

    The verdict (:attr:`usable`, with :attr:`reasons`) collects the premises of Theorem 3.1
    that the report can check: drift-observability on the region, the certificate of
    (2.17), and ``γ`` not below the sampled ``√(γ_L² + γ_H²)`` (the sampled values are
    attained, so a ``γ`` below them is too small for the region: :attr:`warnings`). The
    gain's own certificate may be verified while the design is not usable.

    Examples
    --------
    The shipped pendulum measured by its angle: one output with ``s = r = 2``, ``Q_s`` constant, and
    the observer (3.1) with this report's gain:

    >>> import nlobs
    >>> rep = design_drift_report(nlobs.load_model("pendulum"), samples=200)
    >>> rep.model, rep.s, rep.r, rep.usable
    ('pendulum', (2,), (2,), True)
    >>> [(k.name, k.passed) for k in rep.checks]
    [('drift-observability', True), ('s ≤ r', True)]
    >>> rep.drift_check.evidence
    'det Q_s = 1 (constant): Q_s is nonsingular everywhere'
    >>> rep.usable_scope, type(rep.observer()).__name__
    ('local, on the region [-1, 1] × [-1, 1]', 'DriftObserver')
    >>> rep.to_dict()["certificate"]["verified"], rep.reasons
    (True, ())
    """

    fields: AffineFields
    s: tuple[int, ...]
    r: tuple[int | None, ...]
    checks: tuple[Check, ...]
    F: Array
    H: str
    gamma: float
    gamma_source: str
    certificate: DriftGainCertificate
    lipschitz: LipschitzEstimates
    bound: ErrorBoundConstants
    region: Box

    @property
    def model(self) -> str:
        return self.fields.name

    @property
    def drift_check(self) -> Check:
        """The drift-observability check on the region (Def. 2.3: ``Q_s`` nonsingular)."""
        return next(k for k in self.checks if k.name == "drift-observability")

    @property
    def warnings(self) -> tuple[str, ...]:
        """A given ``γ`` below the sampled estimate on the region (the certificate does not cover the model there)."""
        est = self.lipschitz.gamma
        if self.gamma < est * (1.0 - _GAMMA_RTOL):
            return (f"γ = {self.gamma:.4g} ({self.gamma_source}) is below the sampled √(γ_L² + γ_H²) = {est:.4g} on the "
                    "region: the certificate of (2.17) does not cover the model there (raise γ or shrink the region)",)
        return ()

    @property
    def reasons(self) -> tuple[str, ...]:
        """Why the design is not usable (empty when it is): failed premises, a failed certificate, :attr:`warnings`."""
        out = []
        drift = self.drift_check
        if not drift.passed:
            out.append(f"drift-observability fails on the region ({drift.evidence}): Theorem 3.1 does not apply")
        if not self.certificate.verified:
            out.append("the gain certificate of (2.17) failed: "
                       + "; ".join(k.summary() for k in self.certificate.failed_checks))
        return (*out, *self.warnings)

    @property
    def usable(self) -> bool:
        """Drift-observable on the region, (2.17) verified, and ``γ`` covering the sampled estimate."""
        return not self.reasons

    def observer(self, *, regularization: float = 0.0, cond_limit: float = COND_LIMIT,
                 on_singular: str = "raise", saturation: bool = False) -> DriftObserver:
        """The observer (3.1) with this report's ``s`` and ``K``; ``saturation=True``: saturated on the region
        (Khalil's form, :mod:`nlobs.observers.drift`; the same as (3.1) while the estimate is in the region)."""
        return DriftObserver.from_fields(self.fields, self.s, self.certificate.gain, regularization=regularization,
                                         cond_limit=cond_limit, on_singular=on_singular,
                                         saturation=self.region if saturation else None)

    @property
    def usable_scope(self) -> str:
        """``"local, on the region …"`` when usable: the premises of Theorem 3.1 (Lipschitz constants of Φ_s,
        Φ_s⁻¹, L_s, H_{s,r}, asked on all of ℝⁿ) are estimated by sampling on the region only; else ``"none"``."""
        return f"local, on the region {self.region.describe()}" if self.usable else "none"

    def summary(self) -> str:
        c = self.certificate.constants
        r_txt = ", ".join("∞" if v is None else str(v) for v in self.r)
        lines = [
            f"drift-observability observer (Dalla Mora–Germani–Manes) for {self.model}",
            f"  multi-index s = ({', '.join(map(str, self.s))}), observation relative degree r = ({r_txt})",
            f"  region {self.region.describe()}",
        ]
        lines += [f"  [{'ok' if k.passed else 'FAILS'}] {k.name}: {k.evidence}" for k in self.checks]
        lines.append(f"  H_s,r(x) = {self.H}")
        L = self.lipschitz
        lines.append(f"  sampled on the region ({L.samples} points): γ_Φ ≈ {L.gamma_phi:.4g}, γ_Φ⁻¹ ≈ {L.gamma_phi_inv:.4g}, "
                     f"γ_L ≈ {L.gamma_L:.4g}, γ_H ≈ {L.gamma_H:.4g}")
        lines.append(f"  (2.17) with α = {c.alpha:g}, μ = {c.mu:g}, γ = {self.gamma:.4g} ({self.gamma_source})")
        lines += ["  " + ln for ln in self.certificate.summary().splitlines()]
        lines.append("  K = " + np.array2string(self.certificate.gain, precision=5, separator=", ").replace("\n", "\n      "))
        lines.append("  " + self.bound.describe())
        lines += [f"  warning: {m}" for m in self.warnings]
        lines.append(f"  usable: {self.usable_scope} (drift-observable there, (2.17) verified, γ covers the Lipschitz "
                     "constants sampled there; Theorem 3.1 asks them globally: it covers a run while its state and "
                     "estimate stay in the region, which a simulation checks)"
                     if self.usable else "  usable: NO — " + "; ".join(self.reasons))
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        return DRIFT_DESIGN_JSON.emit({
            "model": self.model,
            "s": list(self.s),
            "r": list(self.r),
            "checks": [k.to_dict() for k in self.checks],
            "F": self.F.tolist(),
            "H": self.H,
            "gamma": self.gamma,
            "gamma_source": self.gamma_source,
            "certificate": self.certificate.to_dict(),
            "lipschitz": self.lipschitz.to_dict(),
            "bound": self.bound.to_dict(),
            "usable": self.usable,
            "usable_scope": self.usable_scope,
            "reasons": list(self.reasons),
            "warnings": list(self.warnings),
        })


#: The JSON of a :class:`DriftDesignReport` (joined to the method's ``design`` object by ``nlobs design drift``).
DRIFT_DESIGN_JSON = Record("DriftDesign", {
    "model": STRING,
    "s": array(INTEGER, "the multi-index"),
    "r": array(INTEGER, "the observation relative degrees"),
    "checks": array(CHECK_JSON),
    "F": MATRIX.about("the gain's Brunovsky matrix"),
    "H": STRING,
    "gamma": NUMBER.about("the Lipschitz constant of (2.5)"),
    "gamma_source": STRING,
    "certificate": OBJECT.about("the gain's certificate (2.17), re-verified"),
    "lipschitz": OBJECT.about("the sampled Lipschitz estimates on the region"),
    "bound": OBJECT.about("the constants of the error bound (3.2)"),
    "usable": BOOLEAN,
    "usable_scope": STRING,
    "reasons": array(STRING),
    "warnings": array(STRING),
}, description="The drift-observability observer (3.1) of Dalla Mora, Germani & Manes, designed and verified")


def _singular_note(model: Any, region: Box) -> str:
    """``"; the model is singular in the region: …"`` (a pole or a root's domain, :func:`singularities`), or ``""``."""
    from nlobs.geometry.singularities import singularities

    if not isinstance(model, SymbolicModel):
        return ""
    try:
        found = singularities(model, region)
    except NlobsError:
        return ""
    return "; the model itself is singular in the region: " + "; ".join(f.describe() for f in found) if found else ""


def design_drift_report(
    model: SymbolicModel,
    s: Sequence[int] | None = None,
    *,
    alpha: float = 1.0,
    mu: float = 1.0,
    gamma: float | None = None,
    method: str = "vandermonde",
    region: Box | None = None,
    parameters: Mapping[str, float] | None = None,
    w: float | None = None,
    w_max: float = 1e5,
    objective: str = "min_gain",
    samples: int = 2000,
    seed: int = 0,
) -> DriftDesignReport:
    """Design and verify the gain of observer (3.1) for a model; the function behind ``nlobs design drift``.

    Parameters
    ----------
    model : SymbolicModel
        Continuous-time, input-affine, ``h`` independent of ``u``.
    s : sequence of int, optional
        Multi-index; default: the observability indices on the region.
    alpha, mu : float
        Decay rate ``α`` and input bound ``μ`` of (2.17).
    gamma : float, optional
        ``γ = √(γ_L² + γ_H²)``; default: estimated by sampling the region
        (:func:`~nlobs.geometry.lipschitz.lipschitz_estimates`).
    method : {"vandermonde", "sdp"}
        Remark 2.11 (smallest ``w``, or the given ``w`` checked) or the LMI design.
    region : Box, optional
        Where the checks and constants are evaluated (default ``[−1, 1]ⁿ``).
    parameters : mapping of str to float, optional
        Override values of the model's named parameters.
    w : float, optional
        ``"vandermonde"``: verify ``K(w)`` at this ``w`` instead of searching the smallest one.
    w_max : float
        ``"vandermonde"``: the largest ``w`` the search tries.
    objective : {"min_gain", "min_condition"}
        SDP objective.
    samples : int
        Number of sampled points of the region for the Lipschitz estimates.
    seed : int
        State of the random generator that draws the sampled points (checks and Lipschitz estimates).

    Returns
    -------
    DriftDesignReport
        Also when drift-observability fails on the region or a given ``γ`` is below the
        sampled estimate: then :attr:`DriftDesignReport.usable` is false and
        :attr:`~DriftDesignReport.reasons` says why.

    Raises
    ------
    ModelError
        Not input-affine / not continuous-time.
    InvalidArgumentError
        ``s`` does not sum to ``n``.
    NonFiniteError
        The model is not finite at any sampled point of the region.
    DesignInfeasible
        No gain satisfies (2.17) (the message names the constraint and by how much).
    AssumptionViolated
        No gain satisfies (2.17) *and* drift-observability fails on the region: the failed check is the
        cause (``Q_s`` singular there), named with its evidence.

    Examples
    --------
    The shipped pendulum ``θ̈ = −(g/l) sin θ − c θ̇ + τ/(m l²)``, ``y = θ``, on ``[−1, 1]²``: the
    sampled ``γ`` is the Lipschitz constant ``√((g/l)² + c²)`` of the drift, attained at ``θ = 0``,
    and the Vandermonde gain of Remark 2.11 puts the poles of ``A_s − K C_s`` at ``−w`` and ``−2w``:

    >>> import numpy as np
    >>> import nlobs
    >>> rep = design_drift_report(nlobs.load_model("pendulum"), samples=200)
    >>> rep.gamma_source, round(rep.gamma, 3), round(float(np.hypot(9.81, 0.2)), 3)
    ('estimated', 9.812, 9.812)
    >>> cert = rep.certificate
    >>> lam = np.linalg.eigvals(np.array([[0.0, 1.0], [0.0, 0.0]]) - cert.gain @ np.array([[1.0, 0.0]]))
    >>> cert.verified, sorted(np.round(lam.real / cert.w, 6).tolist())
    (True, [-2.0, -1.0])

    A ``γ`` given below the sampled constant is reported, not raised:

    >>> low = design_drift_report(nlobs.load_model("pendulum"), gamma=1.0, samples=200)
    >>> low.usable, low.reasons
    (False, ('γ = 1 (given) is below the sampled √(γ_L² + γ_H²) = 9.812 on the region: ...',))
    """
    fields = AffineFields.from_model(model, parameters)
    reg = region or Box.unit(fields.n)
    s_ = check_multi_index(default_multi_index(fields, reg) if s is None else s, fields.q, fields.n)
    if str(method).lower() == "sdp":  # a lower bound (F not yet known), before the geometry; exact in the design
        require_sdp_size(s_)
    rd = observation_relative_degree(fields, reg)
    checks = (check_drift_observability(fields, s_, reg, seed=seed), check_s_le_r(s_, rd.r))
    H, F = input_gain_structure(fields, s_, rd.r)
    lip = lipschitz_estimates(fields, s_, rd.r, reg, samples=samples, seed=seed)
    g = lip.gamma if gamma is None else positive("`gamma`", gamma, allow_zero=True)
    c = RiccatiConstants(s_, F, alpha, mu, g)
    kw: dict[str, Any] = {"objective": objective} if str(method).lower() == "sdp" else {}
    try:
        cert = design_drift_gain(c, method, w=w, w_max=w_max, **kw)
    except DesignInfeasible as exc:
        drift = checks[0]
        if not drift.passed:  # the real cause: Q_s is singular in the region, so no observer (3.1) exists there
            raise AssumptionViolated(
                f"drift-observability fails on {reg.describe()} ({drift.evidence}){_singular_note(model, reg)}: "
                f"there is no observer (3.1) there, and (2.17) has no solution either (γ = {g:.4g}, sampled where "
                "Q_s⁻¹ is large or undefined); choose a region (`region`) where Q_s is nonsingular (nlobs advise "
                "suggests one), or another output",
                item="drift-observability", evidence=drift.evidence) from exc
        raise
    if not (np.isfinite(lip.gamma_phi) and np.isfinite(lip.gamma_phi_inv)):
        drift = checks[0]
        raise AssumptionViolated(
            f"drift-observability fails on {reg.describe()} ({drift.evidence}){_singular_note(model, reg)}: Φ_s or "
            f"Φ_s⁻¹ has no finite Lipschitz constant there (γ_Φ = {lip.gamma_phi:.4g}, γ_Φ⁻¹ = "
            f"{lip.gamma_phi_inv:.4g}), so Theorem 3.1 gives no bound; choose a region where Q_s is nonsingular",
            item="drift-observability", evidence=drift.evidence)
    bound = error_bound_constants(cert, lip.gamma_phi, lip.gamma_phi_inv)
    return DriftDesignReport(fields, s_, rd.r, checks, readonly(F), str(H.tolist()), float(g),
                             "estimated" if gamma is None else "given", cert, lip, bound, reg)


def _mu_check(problem: Problem, mu: float, mu_given: bool) -> Check:
    """``μ`` of (2.17) against the largest ``‖u(t)‖`` of the problem's input (Theorem 3.1 asks ``‖u‖ ≤ μ``)."""
    return Check.compare("input bound μ of (2.17) covers the known input", problem.mu, mu, kind=CheckKind.STRUCTURAL,
                         strict=False, key="input_bound",
                         evidence=f"max ‖u(t)‖ = {problem.mu:.4g} ({problem.sources.get('mu', '')}) ≤ μ = {mu:.4g}"
                         + (" (given)" if mu_given else ""))


@dataclass(frozen=True)
class DriftMethod:
    """The observer (3.1) of Dalla Mora, Germani & Manes, with the gain of (2.17) (Remark 2.11 or the SDP).

    Defaults: the problem's region, ``α = 1`` (:data:`DEFAULT_ALPHA`), ``μ`` the largest ``‖u(t)‖``
    of the problem's known input (:attr:`~nlobs.methods.problem.Problem.mu`), ``γ`` estimated on
    the region, the multi-index of the observability indices. Premises of Theorem 3.1 checked:
    drift-observability on the region and ``‖u(t)‖ ≤ μ``; the Lipschitz constants are sampled on
    the region (the certificate is local: it covers a run while state and estimate stay there).

    Attributes
    ----------
    name : str
        The name in the registry.
    title : str
        The method with its paper and equation numbers.
    uses_region : bool
        Whether the design reads the problem's region.
    options : frozenset of str
        The options :meth:`design` takes.
    """

    name: str = "drift"
    title: str = "drift observer (Dalla Mora, Germani & Manes (3.1))"
    uses_region: bool = True
    options: frozenset[str] = frozenset({"s", "alpha", "mu", "gamma", "gain_method", "w", "w_max", "saturation", "sampling",
                                         "on_singular", "samples", "seed", "objective"})

    def applies(self, problem: Problem) -> str | None:
        model = problem.model
        if not isinstance(model, SymbolicModel):
            return "(3.1) of Dalla Mora, Germani & Manes is for nonlinear input-affine models; this one is linear"
        if model.time.is_discrete:
            return "(3.1) of Dalla Mora, Germani & Manes is for continuous-time models"
        unobservable = problem.not_observable()
        if unobservable is not None:
            return f"(3.1) needs a drift-observable model (Def. 2.3, Q_s nonsingular); {unobservable}"
        return None

    def design(self, problem: Problem, *, s: Sequence[int] | None = None, alpha: float | None = None,
               mu: float | None = None, gamma: float | None = None, gain_method: str = "vandermonde",
               w: float | None = None, w_max: float = 1e5, saturation: bool = False, on_singular: str = "raise",
               samples: int = 2000, seed: int = 0, objective: str = "min_gain", sampling: str | None = None) -> Design:
        """The design (3.1) for the problem (the options as :func:`design_drift_report`).

        Raises
        ------
        ModelError
            Not a continuous-time input-affine model.
        AssumptionViolated, DesignInfeasible
            As :func:`design_drift_report`.
        """
        if not isinstance(saturation, bool):
            raise InvalidArgumentError(f"`saturation`: expected on or off (a bool), got {saturation!r}")
        why = self.applies(problem)
        if why is not None:
            # no observer (3.1) for this model: an unobservable model is an assumption that fails, not bad input
            raise (AssumptionViolated if problem.not_observable() else ModelError)(why)
        model = problem.model
        assert isinstance(model, SymbolicModel)
        alpha_ = DEFAULT_ALPHA if alpha is None else positive("`alpha`", alpha)
        mu_ = problem.mu if mu is None else positive("`mu`", mu, allow_zero=True)
        rep = design_drift_report(model, s, alpha=alpha_, mu=mu_, gamma=gamma, method=gain_method,
                                  region=problem.region, w=w, w_max=w_max, samples=samples, seed=seed,
                                  objective=objective)
        cert = rep.certificate
        premises = (rep.drift_check, _mu_check(problem, mu_, mu is not None))
        # a μ below the file's input is a design for smaller inputs: usable, not certified for this model file
        failed = tuple(rep.reasons)
        sources = {"region": problem.sources.get("region", "given"),
                   "alpha": "given" if alpha is not None else "default",
                   "mu": "given" if mu is not None else problem.sources.get("mu", ""),
                   "gamma": rep.gamma_source if gamma is None else "given"}
        parameters: dict[str, Any] = {
            "region": [[float(a), float(b)] for a, b in zip(rep.region.lower, rep.region.upper)],
            "s": list(rep.s), "alpha": cert.constants.alpha, "mu": cert.constants.mu, "gamma": rep.gamma,
            "gain_method": gain_method, "w": getattr(cert, "w", None)}
        where = rep.region.describe()
        exact, what = problem.exact
        hyps: list[Any] = [Premise("exact measurement and model", exact,
                                   f"{what} (Theorem 3.1 assumes an exact output and an exact model)"),
                           InRegion(rep.region.lower, rep.region.upper, "state", where),
                           InRegion(rep.region.lower, rep.region.upper, "estimate", where)]
        if model.m:
            hyps.append(InputBound(cert.constants.mu))
        w_txt = f"w = {cert.w:.4g}" if getattr(cert, "w", None) is not None else "the SDP"
        desc = (f"(3.1), s = {list(rep.s)}, K of {'Remark 2.11' if gain_method == 'vandermonde' else 'the SDP'} "
                f"({w_txt}), α = {cert.constants.alpha:g}, μ = {cert.constants.mu:.4g}, γ = {rep.gamma:.4g} on {where}")
        # the sampling budget of (2.17)'s own (K, P) through the predictor; where it holds the predictor is the
        # certified form, else the held sample by default: the predictor's loop with a high gain (|λ|·T ≫ 1 at
        # the shipped sensors) diverges where the held sample stays bounded (cart-pole, ball and beam)
        bound = drift_sampling_bound(problem, rep)
        form = sampling_form(sampling, "predictor" if bound is not None and bound.verified else "hold")
        obs, lacking = on_samples(rep.observer(on_singular=on_singular, saturation=saturation), problem, form,
                                  "Theorem 3.1", bound)
        hyps += lacking
        in_x = None
        if problem.sensors:
            parameters["sampling"] = form
            if bound is not None:
                parameters["T_max"] = {g.name: t for g, t in zip(bound.groups, bound.t_max)}
                if form == "predictor":  # the budget is the predictor's: read it in x for that form only
                    in_x = MappedBound(bound, rep.bound.gamma_phi, rep.bound.gamma_phi_inv, process_noise=False)
                    if in_x.verified:  # the bound counts the sensors' and the process noise: no exact output assumed
                        hyps = [h for h in hyps if getattr(h, "name", "") != "exact measurement and model"]
        return Design(self.name, obs, cert, premises, (),
                      parameters, sources, desc, gain=cert.gain, failed=failed, hypotheses=tuple(hyps), bound=in_x,
                      coverage_extras={"region": where, "mu": cert.constants.mu}, report=rep,
                      warnings=tuple(rep.warnings), theorem=f"Dalla Mora, Germani & Manes, Theorem 3.1 on {where}",
                      details=(f"bound (3.2): {rep.bound.describe()}",
                               *(() if bound is None else (
                                   "sampling budget (3) in z = Φ_s(x), V = e_zᵀP⁻¹e_z of (2.17): " + "; ".join(
                                       f"{g.name}: T = {g.period:.4g}, T_max = {t:.4g}"
                                       for g, t in zip(bound.groups, bound.t_max))
                                   + f" (Σ T/T_max = {bound.budget:.3g})",)),
                               *(() if in_x is None or not in_x.verified else (
                                   f"bounded measurement noise |v| ≤ v̄, no process noise: limsup |e| ≤ "
                                   f"{in_x.iss_gain:.4g} v̄ in x (γ_Φ⁻¹ = {in_x.gamma_phi_inv:.4g} times the bound in z); "
                                   f"the file's noise: RMS ≤ {in_x.rms_after(problem.settle):.4g} after t = "
                                   f"{problem.settle:g}",))))


#: The drift method of the registry.
DRIFT = DriftMethod()
