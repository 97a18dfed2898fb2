"""``nlobs analyze``: what nlobs reports about any model.

For a linear model, the structural properties and norms of
:func:`nlobs.linear.analyze_linear`. For a nonlinear model, its dimensions and
form, and the same linear analysis of its Jacobian linearisation at an
operating point (the origin by default), clearly labelled as *local*, and for
a continuous-time input-affine model the symbolic (Lie-derivative) analyses of
Dalla Mora–Germani–Manes and Röbenack on a region
(:func:`nlobs.geometry.report.geometry_report`). :func:`analyze_model` is the workflow
behind the command (a file, a shipped name or a model; the region as numbers).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nlobs._validate import as_vector
from nlobs.errors import DimensionError, ModelError, NonFiniteError, NumericalError
from nlobs.geometry.budget import DEFAULT_SYMBOLIC_BUDGET
from nlobs.geometry.checks import codistribution_function
from nlobs.geometry.observability import AffineFields
from nlobs.geometry.region import Box, format_point
from nlobs.geometry.report import GeometryReport, geometry_report
from nlobs.linear import LinearReport, analyze_linear
from nlobs.systems.linear import LinearSystem
from nlobs.systems.linearize import linearize
from nlobs.systems.modelfile import Model, load_model
from nlobs.systems.symbolic import SymbolicModel
from nlobs.workflows.inputs import BoxError, box_from_numbers
from nlobs.workflows.verdict import Verdict


@dataclass(frozen=True)
class NonlinearReport:
    """What nlobs reports about a nonlinear model (see :func:`analyze`)."""

    name: str
    time: str
    dt: float | None
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    parameters: dict[str, float]
    input_affine: bool
    equations: tuple[str, ...]
    output_equations: tuple[str, ...]
    operating_point: tuple[tuple[float, ...], tuple[float, ...]]
    linearization: LinearReport | None
    linearization_error: str | None
    geometry: GeometryReport | None = None
    geometry_error: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable dict with stable keys (documented in the README)."""
        return {
            "kind": "nonlinear",
            "name": self.name,
            "time": self.time,
            "dt": self.dt,
            "n": len(self.states),
            "m": len(self.inputs),
            "p": len(self.outputs),
            "states": list(self.states),
            "inputs": list(self.inputs),
            "outputs": list(self.outputs),
            "parameters": dict(self.parameters),
            "input_affine": self.input_affine,
            "equations": list(self.equations),
            "output_equations": list(self.output_equations),
            "linearization": None
            if self.linearization is None
            else {
                "x0": list(self.operating_point[0]),
                "u0": list(self.operating_point[1]),
                **self.linearization.to_dict(),
            },
            "linearization_error": self.linearization_error,
            **(self.geometry.to_dict() if self.geometry is not None else {
                "observation_relative_degree": None, "observability_rank": None,
                "observability_rank_evidence": None, "involutive": None,
                "pinv_gain": None, "pinv_gain_numeric": None, "numeric_parts": []}),
            "geometry_error": self.geometry_error,
        }

    def summary(self) -> str:
        """Human-readable multi-line report."""
        dot = "x⁺" if self.time == "discrete" else "ẋ"
        lines = [
            f"model        {self.name}  (nonlinear, {self.time}{'' if self.dt is None else f', dt={self.dt:g}'})",
            f"dimensions   n={len(self.states)} states, m={len(self.inputs)} inputs, p={len(self.outputs)} outputs",
            f"form         {'input-affine  f(x) + g(x) u' if self.input_affine else 'general  F(x, u)'}",
        ]
        if self.parameters:
            lines.append("parameters   " + ", ".join(f"{k} = {v:g}" for k, v in self.parameters.items()))
        for s, e in zip(self.states, self.equations):
            lines.append(f"  {dot}_{s} = {e}" if self.time == "continuous" else f"  {s}⁺ = {e}")
        for o, e in zip(self.outputs, self.output_equations):
            lines.append(f"  {o} = {e}")
        x0, u0 = self.operating_point
        if self.linearization is not None:
            lines.append(f"linearisation at x0={list(x0)}, u0={list(u0)} (local properties only):")
            lines.extend("  " + ln for ln in self.linearization.summary().splitlines())
        else:
            lines.append(f"linearisation at x0={list(x0)}: not available ({self.linearization_error})")
        if self.geometry is not None:
            lines.append(self.geometry.summary())
        elif self.geometry_error:
            lines.append(f"differential geometry: not available ({self.geometry_error})")
        return "\n".join(lines)


def analyze(
    model: SymbolicModel | LinearSystem,
    *,
    x0: Sequence[float] | None = None,
    u0: Sequence[float] | None = None,
    region: Box | None = None,
    symbolic_budget: float | None = DEFAULT_SYMBOLIC_BUDGET,
) -> LinearReport | NonlinearReport:
    """Analyse a model as ``nlobs analyze`` does.

    Parameters
    ----------
    model : SymbolicModel or LinearSystem
    x0, u0 : sequence of float, optional
        Operating point of the linearisation of a nonlinear model (default: origin).
    region : Box, optional
        Region of the symbolic analyses of a nonlinear model (default ``[−1, 1]ⁿ``).
    symbolic_budget : float or None
        Seconds for the optional symbolic parts (:func:`~nlobs.geometry.report.geometry_report`).
    """
    if isinstance(model, LinearSystem):
        if x0 is not None or u0 is not None or region is not None:
            raise DimensionError("x0/u0/region are only used for nonlinear models")
        return analyze_linear(model)
    x = tuple(float(v) for v in (np.zeros(model.n) if x0 is None else as_vector("x0", x0, model.n)))
    u = tuple(float(v) for v in (np.zeros(model.m) if u0 is None else as_vector("u0", u0, model.m)))
    lin: LinearReport | None = None
    err: str | None = None
    try:
        lin = analyze_linear(linearize(model, x, u))
    except (NonFiniteError, NumericalError) as exc:
        err = str(exc)
    geo: GeometryReport | None = None
    geo_err: str | None = None
    try:
        geo = geometry_report(model, region, symbolic_budget=symbolic_budget)
    except ModelError as exc:
        geo_err = str(exc)
    return NonlinearReport(
        name=model.name,
        time=str(model.time).split(" ")[0],
        dt=getattr(model.time, "dt", None),
        states=model.states,
        inputs=model.inputs,
        outputs=model.outputs,
        parameters=dict(model.parameters),
        input_affine=model.is_input_affine,
        equations=tuple(str(e) for e in model.rhs),
        output_equations=tuple(str(e) for e in model.h),
        operating_point=(x, u),
        linearization=lin,
        linearization_error=err,
        geometry=geo,
        geometry_error=geo_err,
    )


@dataclass(frozen=True, eq=False)
class AnalysisReport:
    """What ``nlobs analyze`` prints: the linear report of a linear model, or the nonlinear report.

    Attributes
    ----------
    report : LinearReport or NonlinearReport
    verdict : Verdict
        Always ``OK`` (an analysis reports; it does not fail).
    message : str
    """

    report: LinearReport | NonlinearReport
    verdict: Verdict = Verdict.OK
    message: str = ""
    advice: Any = None

    def to_dict(self) -> dict[str, Any]:
        """The JSON report (``kind`` is ``"linear"`` or ``"nonlinear"``; ``advice`` the advisor's report or ``null``)."""
        data = self.report.to_dict()
        data.setdefault("kind", "linear")
        data["advice"] = None if self.advice is None else self.advice.to_dict()
        return data

    def summary(self) -> str:
        """The text report, ending with the advisor's short summary (``nlobs advise`` for the evidence)."""
        text = self.report.summary()
        if self.advice is not None:
            text += "\n" + self.advice.summary(short=True) + "\n  (evidence and parameters: nlobs advise)"
        return text


def analyze_model(model: str | Path | Model, *, x0: Sequence[float] | None = None,
                  u0: Sequence[float] | None = None, box: Sequence[float] | None = None,
                  symbolic_budget: float | None = DEFAULT_SYMBOLIC_BUDGET) -> AnalysisReport:
    """The workflow of ``nlobs analyze``: load the model and :func:`analyze` it.

    Parameters
    ----------
    model : str, Path, SymbolicModel or LinearSystem
        A model file, the name of a shipped model, or a model.
    x0, u0 : sequence of float, optional
        Operating point of the linearisation of a nonlinear model.
    box : sequence of float, optional
        Region of the symbolic analyses: ``lo, hi`` for every state or ``lo1, hi1, lo2, hi2, ...``
        (:func:`~nlobs.workflows.inputs.box_from_numbers`).
    symbolic_budget : float or None
        Seconds for the optional symbolic parts (``--symbolic-budget``; ``None``: unlimited). A part
        that does not finish is evaluated numerically and named in the report's ``numeric_parts``.

    Raises
    ------
    ModelFileError
        The file cannot be read or is invalid.
    BoxError
        A malformed region.
    NlobsError
        Anything else the analysis refuses (a typed error naming the quantity).
    """
    from nlobs.workflows.advise import advise_model

    m = model if isinstance(model, (SymbolicModel, LinearSystem)) else load_model(model)
    region = box_from_numbers(box, m.n) if box is not None else None
    if region is not None and isinstance(m, SymbolicModel):
        _require_evaluable(m, region)
    report = analyze(m, x0=x0, u0=u0, region=region, symbolic_budget=symbolic_budget)
    geo = getattr(report, "geometry", None)
    advice = advise_model(model if isinstance(model, (str, Path)) else m, box=region, geometry=geo,
                          symbolic_budget=symbolic_budget)
    return AnalysisReport(report, advice=advice)


def _require_evaluable(model: SymbolicModel, region: Box, samples: int = 32, seed: int = 0) -> None:
    """Raise :class:`BoxError` when the region's points or the observability codistribution overflow there.

    The symbolic analyses sample the region and evaluate ``d L_f^k h`` at the samples; a box
    such as ``[−1e308, 1e308]`` makes the samples themselves overflow (``upper − lower = ∞``),
    and a wide box can overflow ``L_f^k h`` (``x³`` at ``1e200``). Non-finite evaluations were
    dropped and, none left, the observability rank was reported as 0 — a wrong number.
    """
    with np.errstate(over="ignore"):
        width = region.upper - region.lower
    bad = np.flatnonzero(~np.isfinite(width))
    if bad.size:
        i = int(bad[0])
        raise BoxError(f"the width of the interval of state {model.states[i]!r}, "
                       f"[{region.lower[i]:g}, {region.upper[i]:g}], overflows double precision")
    try:
        fields = AffineFields.from_model(model)
    except ModelError:
        return  # no symbolic analyses for this model (reported by geometry_error)
    if fields.n > 12:
        return  # the codistribution of a large model is not built twice
    fn = codistribution_function(fields, [fields.n] * fields.q)
    pts = np.vstack([region.sample(samples, seed), region.lower, region.upper])
    with np.errstate(all="ignore"):
        vals = np.asarray(fn(pts), dtype=float)
    finite = np.all(np.isfinite(vals), axis=(-2, -1))
    if not np.all(finite):
        k = int(np.argmin(finite))
        raise BoxError(f"the observability codistribution d L_f^k h overflows (is not finite) at x = "
                       f"{format_point(pts[k])} of the region {region.describe()}; choose a smaller box")
