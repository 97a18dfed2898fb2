r"""Röbenack's Moore–Penrose observer (7), (17) as a method: its design report and its :class:`Method`.

For a continuous-time input-affine model with observation relative degree ``r`` (A1) the observer
is ``x̂̇ = f(x̂) + g(x̂) u + Q⁺(x̂) K (y − h(x̂))`` (7) with the gain field (17)
(:class:`nlobs.observers.pinv.PinvObserver`) and ``K`` from a high-gain placement of the roots of
(10) (:class:`nlobs.synthesis.pinv_gain.HighGain`).

* :func:`design_pinv_report` — builds the observer once (checking A1 and A5 on the region) and
  reports its structure, ``Q⁺`` (25), the gain field and ``k``; the :class:`PinvDesignReport`
  keeps that observer (:attr:`PinvDesignReport.observer`);
* :data:`PINV` — the method. Röbenack's reduced observer needs ``Σ r_j < n`` (with ``Σ r_j = n``
  the map (2) is a full change of coordinates and the drift observer or a high-gain observer in
  those coordinates is the tool); a design is usable when A1 and A5 hold on the region and never
  certified while A2, A3, A4 and A6 (global conditions of Corollary 4.1) are not checked.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from nlobs._schema import BOOLEAN, INTEGER, NUMBER, OBJECT, STRING, Record, array, nullable
from nlobs.checks import CHECK_JSON, Check, CheckKind
from nlobs.errors import InvalidArgumentError, ModelError, NlobsError
from nlobs.geometry.checks import observability_rank
from nlobs.geometry.lie import lie_derivative
from nlobs.geometry.region import Box
from nlobs.methods.base import Design
from nlobs.methods.problem import Problem
from nlobs.methods.sensor_design import on_samples, sampling_form
from nlobs.observers.pinv import AssumptionWarning, PinvObserver
from nlobs.simulate.coverage import InRegion, Premise
from nlobs.synthesis.pinv_gain import DEFAULT_THETA, PLACEMENTS, HighGain, Placement

#: The values of ``θ`` tried for the sensors (:meth:`PinvMethod.design` with ``[sensors]`` and no ``θ`` given).
THETA_GRID = (0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 8.0)
from nlobs.systems.symbolic import SymbolicModel

__all__ = ["PINV", "PLACEMENTS", "THETA_GRID", "PinvDesignReport", "PinvMethod", "design_pinv_report"]


def build_pinv_observer(
    model: SymbolicModel,
    k: ArrayLike | None,
    theta: float,
    placement: Placement,
    region: Box | None,
    parameters: Mapping[str, float] | None,
    pinv: Literal["symbolic", "numeric"],
) -> PinvObserver:
    """Observer (7)/(17) with ``k`` or ``HighGain(theta, placement)``; A5 failing only warns (silenced here)."""
    gain: ArrayLike | HighGain = HighGain(theta, placement) if k is None else k
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AssumptionWarning)
        return PinvObserver.from_model(model, parameters=parameters, k=gain, region=region, require_a5=False,
                                       pinv=pinv)


# ----------------------------------------------------------------------------- the design
def _strings(M: sp.MatrixBase) -> tuple[tuple[str, ...], ...]:
    return tuple(tuple(str(M[i, j]) for j in range(M.shape[1])) for i in range(M.shape[0]))


#: The JSON of a :class:`PinvDesignReport` (joined to the method's ``design`` object by ``nlobs design pinv``).
PINV_DESIGN_JSON = Record("PinvDesign", {
    "model": STRING, "states": array(STRING), "outputs": array(STRING),
    "observation_relative_degree": array(nullable(INTEGER)), "input_gains": array(STRING),
    "observability_rank": nullable(INTEGER), "checks": array(CHECK_JSON), "involutive": BOOLEAN.about("A5"),
    "Q": array(array(STRING), "the observability matrix Q(x)"), "pinv": array(array(STRING), "Q+(x)"),
    "pinv_gain": array(array(STRING), "Q+(x) k of (17)"), "pinv_gain_numeric": array(array(STRING)),
    "k": array(NUMBER), "roots": array(NUMBER), "theta": NUMBER, "placement": STRING,
    "usable": BOOLEAN, "usable_scope": STRING, "hypotheses": array(OBJECT, "A1-A6, each with its status"),
    "missing_hypotheses": array(STRING),
}, description="Röbenack's Moore-Penrose observer (7) with the gain (17)")

@dataclass(frozen=True)
class PinvDesignReport:
    """What ``nlobs design pinv`` prints: relative degree, checks, ``Q⁺``, the gain field and ``k``.

    Attributes
    ----------
    model : str
    states, outputs : tuple of str
    relative_degree : tuple of int
    input_gains : tuple of str
        Per output, ``L_g L_f^{r_j−1} h_j`` (where it vanishes the relative degree
        is not uniform, but the observation relative degree still is ``r_j``).
    observability_rank : int or None
        Generic rank of the codistribution spanned by the ``dL_f^k h`` (``None``: undecided, see
        :func:`nlobs.geometry.checks.observability_rank_evidence`).
    checks : tuple of Check
        A1 and A5.
    Q, pinv : tuple of tuple of str
        ``Q`` (13) and ``Q⁺`` (25), row by row.
    gain_field : tuple of tuple of str
        ``l(x) = Q⁺(x) K`` with the symbols ``k1, k2, …`` (n rows, q columns).
    gain_numeric : tuple of tuple of str
        The same with the numeric ``k``.
    k : tuple of float
    roots : tuple of float
        Eigenvalues of every ``A − k cᵀ`` (the roots of (10)).
    theta : float or None
    placement : str or None
    usable : bool
        A1 and A5 hold on the region — a *local* verdict (:attr:`usable_scope`): Corollary 4.1 also
        needs A3, A4 (global Lipschitz and output-to-state stability conditions in the coordinates (2))
        and A6 (the ``τ_i`` complete), which are not checked (:attr:`hypotheses`).
    region : str
        The region A1 and A5 were checked on.
    observer : PinvObserver
        The observer this report describes (built once; :func:`simulate_pinv` with
        ``report=`` runs this very object). Not part of :meth:`to_dict` nor of equality.

    Examples
    --------
    The shipped four-state model ``isidori-146`` with ``y = x4``: relative degree 2, so ``Q`` has two
    rows; the codistribution has generic rank 3, and the gain field ``Q⁺(x) k`` of (17) corrects
    ``x1``, ``x2`` and ``x4`` but not ``x3``. A1 and A5 hold on the region, the global A2–A4 and A6
    are not checked:

    >>> import nlobs
    >>> rep = design_pinv_report(nlobs.load_model("isidori-146"))
    >>> rep.outputs, rep.relative_degree, rep.input_gains, rep.observability_rank
    (('y',), (2,), ('2*(x3 + 1)',), 3)
    >>> [row[0] for row in rep.gain_field]
    ['2*k2*x1/(4*x1**2 + 1)', 'k2/(4*x1**2 + 1)', '0', 'k1']
    >>> rep.usable, rep.missing, rep.usable_scope
    (True, ('A2', 'A3', 'A4', 'A6'), 'local, on the region [-1, 1] × [-1, 1] × [-1, 1] × [-1, 1]')
    >>> rep.to_dict()["involutive"], type(rep.observer).__name__
    (True, 'PinvObserver')
    """

    model: str
    states: tuple[str, ...]
    outputs: tuple[str, ...]
    relative_degree: tuple[int, ...]
    input_gains: tuple[str, ...]
    observability_rank: int | None
    checks: tuple[Check, ...]
    Q: tuple[tuple[str, ...], ...]
    pinv: tuple[tuple[str, ...], ...]
    gain_field: tuple[tuple[str, ...], ...]
    gain_numeric: tuple[tuple[str, ...], ...]
    k: tuple[float, ...]
    roots: tuple[float, ...]
    theta: float | None
    placement: str | None
    usable: bool
    region: str = ""
    observer: PinvObserver = field(default=None, repr=False, compare=False)  # type: ignore[assignment]

    @property
    def hypotheses(self) -> tuple[dict[str, str], ...]:
        """Every hypothesis of Röbenack's Corollary 4.1 (A1, A3–A6; A2 through Theorem 4.1), each with its status.

        ``status`` is ``"verified on the region"`` / ``"fails on the region"`` (A1, A5: sampled rank and
        involutivity tests with their evidence) or ``"not checked"`` (the global conditions).
        """
        out = []
        for c in self.checks:
            key = "A1" if c.name.startswith("A1") else "A5" if c.name.startswith("A5") else c.name
            out.append({"name": key, "status": "verified on the region" if c.passed else "fails on the region",
                        "evidence": c.evidence})
        out += [
            {"name": "A2", "status": "not checked",
             "evidence": "Φ (2) a global diffeomorphism: given by Theorem 4.1 only when A1, A5 and A6 hold globally"},
            {"name": "A3", "status": "not checked",
             "evidence": "α, β globally Lipschitz (11) in the coordinates (2) on all of Ω, not only the region"},
            {"name": "A4", "status": "not checked",
             "evidence": "an exponential-decay OSS Lyapunov function V₂ of the zero dynamics (12)"},
            {"name": "A6", "status": "not checked", "evidence": "the vector fields τ_1, …, τ_r complete"},
        ]
        return tuple(out)

    @property
    def missing(self) -> tuple[str, ...]:
        """The hypotheses of Corollary 4.1 that are not verified (failed or not checked)."""
        return tuple(h["name"] for h in self.hypotheses if h["status"] != "verified on the region")

    @property
    def usable_scope(self) -> str:
        """``"local, on the region …"`` when A1 and A5 hold there (the global A2–A4, A6 unchecked), else ``"none"``."""
        return f"local, on the region {self.region}" if self.usable else "none"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (stable keys)."""
        return PINV_DESIGN_JSON.emit({
            "model": self.model, "states": list(self.states), "outputs": list(self.outputs),
            "observation_relative_degree": list(self.relative_degree), "input_gains": list(self.input_gains),
            "observability_rank": self.observability_rank, "checks": [c.to_dict() for c in self.checks],
            "involutive": next(c.passed for c in self.checks if c.name.startswith("A5")),
            "Q": [list(r) for r in self.Q], "pinv": [list(r) for r in self.pinv],
            "pinv_gain": [list(r) for r in self.gain_field], "pinv_gain_numeric": [list(r) for r in self.gain_numeric],
            "k": list(self.k), "roots": list(self.roots), "theta": self.theta, "placement": self.placement,
            "usable": self.usable, "usable_scope": self.usable_scope, "hypotheses": list(self.hypotheses),
            "missing_hypotheses": list(self.missing),
        })

    def summary(self) -> str:
        """A plain-text report."""
        lines = [f"Moore–Penrose observer (Röbenack 2008, (7) with (17)) for {self.model}"]
        for o, rj, lg in zip(self.outputs, self.relative_degree, self.input_gains):
            lines.append(f"  output {o}: observation relative degree r = {rj}, L_g L_f^{rj - 1} h = {lg}")
        if self.observability_rank is None:
            lines.append("  generic rank of the observability codistribution: undecided (a scaled singular value "
                         "lies within the rounding error; see nlobs analyze)")
        else:
            lines.append(f"  generic rank of the observability codistribution: {self.observability_rank} "
                         f"(n = {len(self.states)}; {len(self.states) - self.observability_rank} unobservable "
                         "direction(s))")
        for c in self.checks:
            lines.append(f"  {'ok  ' if c.passed else 'FAIL'} {c.name}: {c.evidence}")
        lines.append("  Q⁺(x) (columns τ_i, (18)):")
        lines += [f"    [{', '.join(r)}]" for r in self.pinv]
        lines.append("  gain field l(x) = Q⁺(x) k (17):")
        for s, g, gn in zip(self.states, self.gain_field, self.gain_numeric):
            lines.append(f"    {s}: {', '.join(g)}    = {', '.join(gn)}")
        design = f" (θ = {self.theta:g}, placement {self.placement})" if self.theta is not None else ""
        lines.append(f"  k = [{', '.join(f'{v:.6g}' for v in self.k)}]{design}; roots of (10): "
                     f"[{', '.join(f'{v:.6g}' for v in self.roots)}]")
        for h in self.hypotheses[len(self.checks):]:
            lines.append(f"  ?    {h['name']} {h['status']}: {h['evidence']}")
        if self.usable:
            lines.append(f"  usable: local only, on the region {self.region} (A1, A5 verified there by sampling); "
                         f"Corollary 4.1's convergence also needs {', '.join(self.missing)}, not checked")
        else:
            lines.append("  usable: no: A5 fails, Theorem 4.1 does not apply")
        return "\n".join(lines)


def design_pinv_report(
    model: SymbolicModel,
    k: ArrayLike | None = None,
    theta: float = DEFAULT_THETA,
    placement: Placement = "powers",
    region: Box | None = None,
    *,
    parameters: Mapping[str, float] | None = None,
    pinv: Literal["symbolic", "numeric"] = "symbolic",
) -> PinvDesignReport:
    """Design the Moore–Penrose observer of ``model`` and report it (for ``nlobs design pinv``).

    ``k`` (stacked, ``Σ r_j`` entries) overrides the high-gain design ``(theta, placement)``.
    A5 failing is reported (``usable`` false), not raised; A1 failing raises
    :class:`~nlobs.errors.AssumptionViolated` (no ``Q⁺`` exists). The observer is built once and
    kept in the report (:attr:`PinvDesignReport.observer`).

    Parameters
    ----------
    model : SymbolicModel
        Continuous-time, input-affine model.
    k : array_like, optional
        Stacked gain vector (``Σ r_j`` entries); default: the high-gain design.
    theta : float
        ``θ > 0`` of :class:`~nlobs.synthesis.pinv_gain.HighGain`.
    placement : {"powers", "multiple"}
        Root placement of the high-gain design.
    region : Box, optional
        Where A1 and A5 are checked (default ``[−1, 1]ⁿ``).
    parameters : mapping of str to float, optional
        Override values of the model's named parameters.
    pinv : {"symbolic", "numeric"}
        ``Q⁺`` from its simplified closed form, or ``np.linalg.pinv`` of ``Q`` at each evaluation.

    Returns
    -------
    PinvDesignReport

    Raises
    ------
    AssumptionViolated
        A1 fails on the region.

    Examples
    --------
    ``placement="multiple"`` puts every root of (10) at ``−θ``: with ``θ = 3`` the gain is the
    coefficients of ``(s + 3)² = s² + 6s + 9``; a given ``k`` overrides the high-gain design:

    >>> import nlobs
    >>> model = nlobs.load_model("isidori-146")
    >>> rep = design_pinv_report(model, theta=3.0, placement="multiple")
    >>> rep.k, [round(r, 6) for r in rep.roots], rep.theta, rep.placement
    ((6.0, 9.0), [-3.0, -3.0], 3.0, 'multiple')
    >>> [row[0] for row in rep.gain_numeric]
    ['18*x1/(4*x1**2 + 1)', '9/(4*x1**2 + 1)', '0', '6']
    >>> given = design_pinv_report(model, k=[3.0, 2.0])
    >>> given.k, [round(r, 6) for r in given.roots], given.theta
    ((3.0, 2.0), [-2.0, -1.0], None)
    """
    obs = build_pinv_observer(model, k, theta, placement, region, parameters, pinv)
    F = obs.fields
    lg = []
    for j, rj in enumerate(obs.r):
        phi = F.lie_chain(j, rj)[-1]
        row = ", ".join(str(sp.factor(lie_derivative(phi, F.g[:, c], F.x))) for c in range(F.m))
        lg.append(row if F.m == 1 else f"[{row}]")
    roots = np.concatenate([np.sort(np.linalg.eigvals(M).real) for M in obs.error_matrices])
    return PinvDesignReport(
        model=F.name, states=F.states, outputs=F.outputs, relative_degree=obs.r, input_gains=tuple(lg),
        observability_rank=observability_rank(F, obs.region), checks=obs.checks, Q=_strings(obs.Q),
        pinv=_strings(obs.Qp), gain_field=_strings(obs.gain_symbolic), gain_numeric=_strings(obs.gain),
        k=tuple(float(v) for v in obs.k_vector), roots=tuple(float(v) for v in roots),
        theta=None if obs.high_gain is None else obs.high_gain.theta,
        placement=None if obs.high_gain is None else obs.high_gain.placement,
        usable=all(c.passed for c in obs.checks), region=obs.region.describe(), observer=obs,
    )


@dataclass(frozen=True)
class PinvMethod:
    """Röbenack's Moore–Penrose observer (7) with the gain field ``l(x) = Q⁺(x) k`` (17).

    Defaults: the problem's region, the high-gain placement of (10) with ``θ`` =
    :data:`~nlobs.synthesis.pinv_gain.DEFAULT_THETA`; with ``[sensors]`` (and neither ``θ`` nor ``k`` given, through
    the predictor) the ``θ`` of :data:`THETA_GRID` with the smallest certified RMS bound under them
    (:mod:`nlobs.methods.pinv_sampling`), else the default. Premises of Corollary 4.1 checked on the
    region: A1 and A5 (sampled), and ``Σ r_j < n``; A2, A3, A4 and A6 are global conditions nobody
    checks, so Corollary 4.1 never certifies the design; under sensors the vertex LMIs of its gain field
    on the region do, where they hold (a local certificate of its own).

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

    name: str = "pinv"
    title: str = "Moore–Penrose observer (Röbenack (7), (17))"
    uses_region: bool = True
    options: frozenset[str] = frozenset({"k", "theta", "placement", "saturation", "pinv", "sampling"})

    def applies(self, problem: Problem) -> str | None:
        model = problem.model
        if not isinstance(model, SymbolicModel):
            return "Röbenack's observer (7) is for nonlinear input-affine models; this one is linear"
        if model.time.is_discrete:
            return "Röbenack's observer (7) is for continuous-time models"
        return None

    def design(self, problem: Problem, *, k: ArrayLike | None = None, theta: float | None = None,
               placement: Placement = "powers", saturation: bool = False,
               pinv: Literal["symbolic", "numeric"] = "symbolic", sampling: str | None = None) -> Design:
        """The design (7), (17) for the problem (the options as :func:`design_pinv_report`).

        Raises
        ------
        ModelError
            Not a continuous-time input-affine model.
        AssumptionViolated
            A1 fails on the region (no ``Q⁺`` exists).
        """
        if not isinstance(saturation, bool):
            raise InvalidArgumentError(f"`saturation`: expected on or off (a bool), got {saturation!r}")
        form = sampling_form(sampling)
        why = self.applies(problem)
        if why is not None:
            raise ModelError(why)
        if problem.sensors and k is None and theta is None and form == "predictor" and not saturation:
            return self._for_sensors(problem, placement, pinv)
        return self._design(problem, k, theta, placement, saturation, pinv, form)

    def _for_sensors(self, problem: Problem, placement: Placement, pinv: Literal["symbolic", "numeric"]) -> Design:
        """``θ`` of :data:`THETA_GRID` with the smallest certified RMS bound under the sensors (else the default)."""
        designs = []
        for th in THETA_GRID:
            try:
                designs.append(self._design(problem, None, th, placement, False, pinv, "predictor"))
            except NlobsError:  # A1 may fail for no θ (it does not involve θ); a θ whose roots fail is skipped
                continue
        certified = [d for d in designs if d.bound is not None and math.isfinite(d.parameters.get("rms_bound", math.inf))]
        if certified:
            best = min(certified, key=lambda d: d.parameters["rms_bound"])
            how = f"the smallest certified RMS bound of {len(designs)} values of θ ({len(certified)} certified)"
        else:
            best = next((d for d in designs if d.parameters.get("theta") == DEFAULT_THETA), None) or \
                self._design(problem, None, None, placement, False, pinv, "predictor")
            how = f"default (no θ of {THETA_GRID[0]:g} … {THETA_GRID[-1]:g} is certified under the sensors)"
        return dataclasses.replace(best, sources={**best.sources, "theta": how})

    def _design(self, problem: Problem, k: ArrayLike | None, theta: float | None, placement: Placement,
                saturation: bool, pinv: Literal["symbolic", "numeric"], form: str) -> Design:
        """The design at one ``θ`` (or ``k``), with its certificate under the sensors where it holds."""
        model = problem.model
        assert isinstance(model, SymbolicModel)
        th = DEFAULT_THETA if theta is None else theta
        rep = design_pinv_report(model, k, th, placement, problem.region, pinv=pinv)
        obs = rep.observer
        n, total = len(rep.states), int(sum(rep.relative_degree))
        premises = (*rep.checks, Check.compare("Σ r_j < n (a reduced observability map)", total, n,
                                               kind=CheckKind.STRUCTURAL,
                                               key="sum_r", evidence=f"Σ r_j = {total}, n = {n}"))
        failed = [f"{c.name} fails: {c.evidence}" for c in rep.checks if not c.passed]
        if total >= n:
            failed.append(f"Σ r_j = {total} is not < n = {n}: Q is square, Q⁺ = Q⁻¹ (the drift observer with s = r "
                          "is that case)")
        unchecked = tuple(h["name"] for h in rep.hypotheses if h["status"] == "not checked")
        if saturation:
            obs = obs.with_saturation(obs.region)
        parameters: dict[str, Any] = {
            "region": [[float(a), float(b)] for a, b in zip(problem.region.lower, problem.region.upper)],
            "k": list(rep.k), "theta": rep.theta, "placement": rep.placement}
        sources = {"region": problem.sources.get("region", "given"),
                   "theta": "given" if k is not None or (theta is not None and theta != DEFAULT_THETA) else "default"}
        exact, what = problem.exact
        where = problem.region.describe()
        hyps = (Premise("exact measurement and model", exact, f"{what} (Corollary 4.1 assumes an exact output)"),
                InRegion(problem.region.lower, problem.region.upper, "state", where),
                InRegion(problem.region.lower, problem.region.upper, "estimate", where))
        desc = f"(7) with l(x) = Q⁺(x) k (17), k = {[round(v, 6) for v in rep.k]}" + (
            f" (θ = {rep.theta:g}, {rep.placement})" if rep.theta is not None else " (given)")
        sampled, why_not, box_check = None, "", None
        if problem.sensors and form == "predictor" and not failed:
            from nlobs.methods.pinv_sampling import pinv_sampling_bound

            sampled, why_not, box_check = pinv_sampling_bound(problem, obs)
        theorem = f"Röbenack, Theorem 4.1 / Corollary 4.1 on {where}"
        details: tuple[str, ...] = ()
        bound = None
        if sampled is not None:  # the vertex LMIs on the region replace Corollary 4.1's global conditions there
            from nlobs.methods.sensor_design import sampling_hypotheses

            obs, _ = on_samples(obs, problem, form, "Corollary 4.1")
            bound = sampled.bound
            assert box_check is not None
            premises = (*premises, box_check, *sampled.checks)
            unchecked = ()
            hyps = sampling_hypotheses(problem, bound)
            rms = bound.rms_after(problem.settle)
            parameters.update({"decay": sampled.continuous.decay, "rms_bound": rms,
                               "T_max": {g.name: t for g, t in zip(bound.groups, bound.t_max)}})
            desc += f"; certified under the sensors on {where} (vertex LMIs of the gain field): RMS ≤ {rms:.4g}"
            theorem = ("vertex LMIs of the Jacobian and gain-field boxes on the region (Zemouche, Boutayeb & Bara "
                       "2008) with the sampled-data bound of the inter-sample predictor (Karafyllis & Kravaris 2009)")
            details = tuple(bound.summary().splitlines())
        else:
            obs, lacking = on_samples(obs, problem, form, "Corollary 4.1", reason=why_not)
            hyps += lacking
            if why_not and problem.sensors:
                details = (f"no certificate under the sensors: {why_not}",)
        if problem.sensors:
            parameters["sampling"] = form
        return Design(self.name, obs, sampled, premises, unchecked, parameters, sources, desc,
                      gain=np.asarray(rep.k, dtype=float), failed=tuple(failed), hypotheses=hyps,
                      coverage_extras={"region": where}, report=rep, theorem=theorem, details=details, bound=bound)


#: The Moore–Penrose method of the registry.
PINV = PinvMethod()
