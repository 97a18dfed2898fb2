"""``nlobs analyze``: what nlobs reports about any model.

For a linear model, the structural properties and norms of
:func:`nlobs.linear.analyze_linear`. For a nonlinear model, its dimensions and
form, and the same linear analysis of its Jacobian linearisation at an
operating point, clearly labelled as *local*, and for a continuous-time
input-affine model the symbolic (Lie-derivative) analyses of
Dalla Mora–Germani–Manes and Röbenack on a region
(:func:`nlobs.geometry.report.geometry_report`). :func:`analyze_model` is the workflow
behind the command (a file, a shipped name or a model; the region as numbers).

Where the point and the region come from (:func:`analyze_model`, as ``nlobs simulate`` reads a file):

* the region: the given ``box``, else the file's ``[simulation] box``, else ``[−1, 1]ⁿ``;
* ``x0``: the given one, else the file's ``[simulation] x0``, else zeros;
* ``u0``: the given one, else the file's ``[input_signals]`` at ``t = 0``, else zero.

The report says which (``region_source``, ``x0_source``, ``u0_source``). Where ``F(x0, u0)``,
``h(x0, u0)`` or one of their Jacobians ``A, B, C, D`` is not finite (the model is not defined
or not differentiable there: ``exp(−E/T)`` or ``sqrt(h)`` at ``0``), the linear part is skipped
and the report names the quantities, their entries and the point, instead of analysing NaNs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nlobs._validate import as_vector
from nlobs.errors import DimensionError, ModelError, ModelFileError, NonFiniteError, NumericalError
from nlobs.geometry.budget import DEFAULT_SYMBOLIC_BUDGET
from nlobs.geometry.checks import codistribution_function
from nlobs.geometry.observability import AffineFields
from nlobs.geometry.region import Box, format_point
from nlobs._schema import BOOLEAN, INTEGER, NUMBER, STRING, Node, Record, array, enum, mapping, nullable
from nlobs.geometry.report import (
    GEOMETRY_JSON,
    MAX_GEOMETRY_STATES,
    GeometryReport,
    geometry_report,
    too_many_states,
)
from nlobs.linear import LinearReport, analyze_linear
from nlobs.linear.report import LINEAR_REPORT_JSON
from nlobs.methods.advice import ADVICE_JSON
from nlobs.systems.linear import LinearSystem
from nlobs.systems.modelfile import Model, load_model, load_scenario, model_file_tables
from nlobs.systems.symbolic import SymbolicModel
from nlobs.workflows.inputs import BoxError, box_from_numbers
from nlobs.workflows.verdict import Verdict


#: Where a point or a region came from (``x0_source``, ``u0_source``, ``region_source`` of the report).
GIVEN = "given"
X0_FILE = "[simulation] x0"
X0_DEFAULT = "default zeros"
U0_FILE = "[input_signals] at t = 0"
U0_DEFAULT = "default zero"
REGION_FILE = "[simulation] box"
REGION_DEFAULT = "default [-1, 1]^n"

#: At most this many non-finite entries are named per quantity (the count says how many there are).
MAX_NAMED_ENTRIES = 8


#: One quantity of the linearisation that is not finite (``linearization_nonfinite``).
NONFINITE_JSON = Record("NonFinite", {
    "quantity": enum("F", "h", "A", "B", "C", "D"), "label": STRING,
    "entries": array(array(INTEGER), "0-based [row, column], or [row] for F and h"), "names": array(STRING)})

@dataclass(frozen=True)
class NonFinite:
    """A quantity of the linearisation that is not finite at the operating point.

    Attributes
    ----------
    quantity : str
        ``"F"`` (``F(x0, u0)``), ``"h"``, ``"A"`` (``∂F/∂x``), ``"B"`` (``∂F/∂u``), ``"C"``
        (``∂h/∂x``) or ``"D"`` (``∂h/∂u``).
    label : str
        ``"f(x0, u0)"``, ``"∂f/∂x"``, …, as the report prints it.
    entries : tuple of tuple of int
        The ``(row, column)`` (matrices) or ``(row,)`` (vectors) indices that are NaN or ±∞, 0-based.
    names : tuple of str
        The same entries in the model's names (``∂f_C/∂T``, ``f_T``).
    """

    quantity: str
    label: str
    entries: tuple[tuple[int, ...], ...]
    names: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        return NONFINITE_JSON.emit({"quantity": self.quantity, "label": self.label,
                                    "entries": [list(e) for e in self.entries], "names": list(self.names)})

    def describe(self) -> str:
        shown = [f"({','.join(map(str, e))}) {nm}" for e, nm in zip(self.entries, self.names)][:MAX_NAMED_ENTRIES]
        more = len(self.entries) - len(shown)
        return (f"{self.label} (entr{'y' if len(self.entries) == 1 else 'ies'} " + ", ".join(shown)
                + (f" and {more} more" if more > 0 else "") + ")")


def _fmt(v: Sequence[float]) -> str:
    """``[0.5, 350]``: a point as the report prints it (``%g``, so ``350`` and not ``350.0``)."""
    return "[" + ", ".join(f"{float(a):g}" for a in v) + "]"


def _from(source: str) -> str:
    """``from [simulation] x0`` for a file's value; ``given``, ``default zeros``, … otherwise."""
    return f"from {source}" if source.startswith("[") else source


def _linearisation(model: SymbolicModel, x: tuple[float, ...],
                   u: tuple[float, ...]) -> tuple[LinearSystem | None, tuple[NonFinite, ...]]:
    """``(A, B, C, D)`` at ``(x, u)`` as :func:`~nlobs.systems.linearize.linearize` builds it (one compilation),
    or ``None`` and what is not finite there: ``F(x, u)``, ``h(x, u)`` and the four Jacobians are all evaluated."""
    c = model.compile()
    xa, ua = np.asarray(x, dtype=float), np.asarray(u, dtype=float)
    f = "x⁺" if model.time.is_discrete else "f"
    with np.errstate(all="ignore"):
        values = {
            "F": (f"{f}(x0, u0)", c.rhs(0.0, xa, ua), model.states, None),
            "A": (f"∂{f}/∂x", c.rhs_jacobian_x(0.0, xa, ua), model.states, model.states),
            "B": (f"∂{f}/∂u", c.rhs_jacobian_u(0.0, xa, ua), model.states, model.inputs),
            "h": ("h(x0, u0)", c.output(0.0, xa, ua), model.outputs, None),
            "C": ("∂h/∂x", c.output_jacobian_x(0.0, xa, ua), model.outputs, model.states),
            "D": ("∂h/∂u", c.output_jacobian_u(0.0, xa, ua), model.outputs, model.inputs),
        }
    bad = []
    for key, (label, val, rows, cols) in values.items():
        idx = [tuple(int(i) for i in e) for e in np.argwhere(~np.isfinite(np.asarray(val, dtype=float)))]
        if idx:
            row = [f"{f}_{r}" if key in "FAB" else r for r in rows]
            names = tuple(row[e[0]] if cols is None else f"∂{row[e[0]]}/∂{cols[e[1]]}" for e in idx)
            bad.append(NonFinite(key, label, tuple(idx), names))
    if bad:
        return None, tuple(bad)
    return LinearSystem(values["A"][1], values["B"][1], values["C"][1], values["D"][1], time=model.time,
                        states=model.states, inputs=model.inputs, outputs=model.outputs,
                        name=f"{model.name} (linearised)"), ()


def _nonfinite_message(bad: Sequence[NonFinite], x: Sequence[float], u: Sequence[float], x0_source: str) -> str:
    """The one sentence of the report: which quantities, which entries, the point, why and what to do."""
    parts = [b.describe() for b in bad]
    what = parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
    hint = {GIVEN: "choose `x0` inside the model's domain",
            X0_FILE: "the file's [simulation] x0 is outside the model's domain; give `x0` inside it"}.get(
        x0_source, "give `x0` or [simulation] x0 inside the model's domain")
    return (f"{what} {'is' if len(bad) == 1 else 'are'} not finite at x0={[float(v) for v in x]}, "
            f"u0={[float(v) for v in u]}: the model is not defined or not differentiable there; {hint}")


#: ``nlobs analyze`` of a nonlinear model, without ``advice``.
NONLINEAR_REPORT_JSON = Record("NonlinearReport", {
    "kind": Node({"const": "nonlinear"}),
    "name": STRING, "time": enum("continuous", "discrete"), "dt": NUMBER,
    "n": INTEGER, "m": INTEGER, "p": INTEGER,
    "states": array(STRING), "inputs": array(STRING), "outputs": array(STRING),
    "parameters": mapping(NUMBER), "input_affine": BOOLEAN,
    "equations": array(STRING), "output_equations": array(STRING),
    "linearization": nullable(LINEAR_REPORT_JSON.extend(
        "Linearization", {"x0": array(NUMBER), "u0": array(NUMBER)}),
        "the linear keys for the Jacobian linearisation at x0, u0"),
    "linearization_error": nullable(STRING, "why the linear part is skipped"),
    "linearization_nonfinite": nullable(array(NONFINITE_JSON)),
    "operating_point": Record("OperatingPoint", {
        "x0": array(NUMBER), "u0": array(NUMBER), "x0_source": STRING, "u0_source": STRING}),
    "region_source": STRING,
    **GEOMETRY_JSON.fields,
    "geometry_error": nullable(STRING),
}, optional={"relative_degree_evidence", "multi_index", "drift_observable", "drift_observability", "a1", "a5",
             "symbolic_budget", "notes"},
   description="A nonlinear model: dimensions, equations, the linearisation at an operating point and the "
               "differential-geometric analysis on a region.")

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
    region: Box | None = None
    region_source: str = REGION_DEFAULT
    x0_source: str = X0_DEFAULT
    u0_source: str = U0_DEFAULT
    linearization_nonfinite: tuple[NonFinite, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable dict with stable keys (documented in the README)."""
        x0, u0 = self.operating_point
        region = self.region if self.region is not None else Box.unit(len(self.states))
        return NONLINEAR_REPORT_JSON.emit({
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
            "linearization_nonfinite": [nf.to_dict() for nf in self.linearization_nonfinite] or None,
            "operating_point": {"x0": list(x0), "u0": list(u0), "x0_source": self.x0_source,
                                "u0_source": self.u0_source},
            "region_source": self.region_source,
            **(self.geometry.to_dict() if self.geometry is not None else {
                "region": {"lower": region.lower.tolist(), "upper": region.upper.tolist()},
                "observation_relative_degree": None, "observability_rank": None,
                "observability_rank_evidence": None, "involutive": None,
                "pinv_gain": None, "pinv_gain_numeric": None, "numeric_parts": []}),
            "geometry_error": self.geometry_error,
        })

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
        point = f"x0 = {_fmt(x0)} {_from(self.x0_source)}, u0 = {_fmt(u0)} {_from(self.u0_source)}"
        if self.linearization is not None:
            lines.append(f"linearised at {point} — local properties only:")
            lines.extend("  " + ln for ln in self.linearization.summary().splitlines())
        else:
            lines.append(f"linearised at {point}: skipped — {self.linearization_error}")
        if self.geometry is not None:
            lines.append(f"region       {self.geometry.region.describe()} {_from(self.region_source)}")
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
    sources: dict[str, str] | None = None,
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
    sources : dict, optional
        Where ``"x0"``, ``"u0"`` and ``"region"`` came from, as the report states it (default:
        ``"given"`` for a given one, else the default's name).

    Where ``F``, ``h`` or a Jacobian is not finite at ``(x0, u0)`` the linearisation is skipped
    and ``linearization_error`` / ``linearization_nonfinite`` say which entries (module docstring).
    """
    if isinstance(model, LinearSystem):
        if x0 is not None or u0 is not None or region is not None:
            raise DimensionError("x0/u0/region are only used for nonlinear models")
        return analyze_linear(model)
    src = {"x0": X0_DEFAULT if x0 is None else GIVEN, "u0": U0_DEFAULT if u0 is None else GIVEN,
           "region": REGION_DEFAULT if region is None else GIVEN, **(sources or {})}
    if model.m == 0:
        src["u0"] = "no inputs"
    x = tuple(float(v) for v in (np.zeros(model.n) if x0 is None else as_vector("`x0`", x0, model.n)))
    u = tuple(float(v) for v in (np.zeros(model.m) if u0 is None else as_vector("`u0`", u0, model.m)))
    lin: LinearReport | None = None
    err: str | None = None
    bad: tuple[NonFinite, ...] = ()
    try:
        sys_, bad = _linearisation(model, x, u)
        if sys_ is None:
            err = _nonfinite_message(bad, x, u, src["x0"])
        else:
            lin = analyze_linear(sys_)
    except (NonFiniteError, NumericalError) as exc:
        err = str(exc)
    geo: GeometryReport | None = None
    geo_err: str | None = None
    if model.n > MAX_GEOMETRY_STATES:  # not attempted: the linearisation and the rest of the report still stand
        geo_err = too_many_states(model.n)
    else:
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
        region=region if region is not None else Box.unit(model.n),
        region_source=src["region"],
        x0_source=src["x0"],
        u0_source=src["u0"],
        linearization_nonfinite=bad,
    )


#: ``nlobs analyze`` of a linear model.
ANALYZE_LINEAR_JSON = LINEAR_REPORT_JSON.extend("LinearAnalysis", {
    "kind": Node({"const": "linear"}),
    "advice": nullable(ADVICE_JSON, "the advisor's report (nlobs advise)"),
})
#: ``nlobs analyze`` of a nonlinear model.
ANALYZE_NONLINEAR_JSON = NONLINEAR_REPORT_JSON.extend("NonlinearAnalysis", {
    "advice": nullable(ADVICE_JSON, "the advisor's report (nlobs advise)"),
})

@dataclass(frozen=True, eq=False)
class AnalysisReport:
    """What ``nlobs analyze`` prints: the linear report of a linear model, or the nonlinear report.

    Attributes
    ----------
    report : LinearReport or NonlinearReport
    verdict : Verdict
        Always ``OK`` (an analysis reports; it does not fail).
    message : str

    Examples
    --------
    The report of a linear model, ``G(s) = 1 / (s² + 0.5 s + 2)``: its poles ``−0.25 ± j√1.9375``, and its H2
    norm ``1 / √(2 · 0.5 · 2) = 1/√2``; the advisor recommends a Luenberger observer:

    >>> import math
    >>> import nlobs
    >>> report = analyze_model(nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]]))
    >>> type(report.report).__name__, report.verdict.value, report.message
    ('LinearReport', 'ok', '')
    >>> data = report.to_dict()
    >>> data["kind"], data["observable"], data["stable"], [round(im, 4) for _, im in data["eigenvalues"]]
    ('linear', True, True, [-1.3919, 1.3919])
    >>> round(data["h2_norm"], 6), round(1 / math.sqrt(2), 6), data["advice"]["recommended"]
    (0.707107, 0.707107, 'luenberger')
    >>> print(report.summary().splitlines()[0])
    Linear system 'linear': continuous, n=2, m=1, p=1
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
        return (ANALYZE_NONLINEAR_JSON if data["kind"] == "nonlinear" else ANALYZE_LINEAR_JSON).emit(data)

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
        Operating point of the linearisation of a nonlinear model; default the file's
        ``[simulation] x0``, else zeros, and the file's ``[input_signals]`` at ``t = 0``, else zero
        (as ``nlobs simulate`` starts its runs).
    box : sequence of float, optional
        Region of the symbolic analyses: ``lo, hi`` for every state or ``lo1, hi1, lo2, hi2, ...``
        (:func:`~nlobs.workflows.inputs.box_from_numbers`); default the file's ``[simulation] box``,
        else ``[−1, 1]ⁿ``.
    symbolic_budget : float or None
        Seconds for the optional symbolic parts (``None``: unlimited), counted as work
        (:class:`~nlobs.geometry.budget.SymbolicBudget`), never timed. A part that does not fit is
        evaluated numerically and named in the report's ``numeric_parts``.

    Raises
    ------
    ModelFileError
        The file cannot be read or is invalid.
    BoxError
        A malformed region (given, or the file's ``[simulation] box``: the message then starts
        with ``[simulation] box:``).
    NlobsError
        Anything else the analysis refuses (a typed error naming the quantity).

    Examples
    --------
    The shipped pendulum: its linearisation at the origin, the observability codistribution and observation
    relative degree on ``[−1, 1]²`` (Dalla Mora, Germani & Manes; Röbenack), and the advisor's choice:

    >>> report = analyze_model("pendulum")
    >>> lin = report.report.linearization
    >>> bool(lin.observable), bool(lin.stable)
    (True, True)
    >>> data = report.to_dict()
    >>> data["kind"], data["observation_relative_degree"], data["observability_rank"], data["drift_observable"]
    ('nonlinear', [2], 2, True)
    >>> report.advice.recommended  # the drift observer (3.1) of Dalla Mora, Germani & Manes
    'drift'
    """
    from nlobs.methods.advice import advise_model

    is_file = isinstance(model, (str, Path))
    scenario = _scenario(model) if is_file else None
    m = model if not is_file else (scenario.model if scenario is not None else load_model(model))
    region = box_from_numbers(box, m.n) if box is not None else None
    sources: dict[str, str] = {}
    if isinstance(m, SymbolicModel):
        defaults = getattr(scenario, "defaults", None)
        if region is None and defaults is not None and defaults.box is not None:
            file_box = Box(*defaults.box)
            try:
                _require_evaluable(m, file_box)
            except BoxError as exc:
                raise BoxError(f"{REGION_FILE}: {exc}; give `box` to analyse another region") from None
            region, sources["region"] = file_box, REGION_FILE
        elif region is not None:
            _require_evaluable(m, region)
        if x0 is None and defaults is not None and defaults.x0 is not None:
            x0, sources["x0"] = [float(v) for v in defaults.x0], X0_FILE
        if u0 is None and m.m and scenario is not None and scenario.input_signals is not None:
            sig = scenario.input_signals
            u0 = [float(v) for v in np.asarray(sig(0.0), dtype=float).reshape(m.m)]
            sources["u0"] = U0_FILE
        report = analyze(m, x0=x0, u0=u0, region=region, symbolic_budget=symbolic_budget, sources=sources)
    else:
        report = analyze(m, x0=x0, u0=u0, region=region, symbolic_budget=symbolic_budget)
    geo = getattr(report, "geometry", None)
    advice = advise_model(model if is_file else m, box=None if box is None else region, geometry=geo,
                          symbolic_budget=symbolic_budget, scenario=scenario)
    return AnalysisReport(report, advice=advice)


def _scenario(path: str | Path) -> Any:
    """The file's scenario (``[simulation]``, ``[input_signals]``), or ``None`` for a file of Khajenejad & Yong's
    unknown-input tables, whose scenario is read elsewhere (as ``nlobs advise`` reads it)."""
    try:
        return load_scenario(path)
    except ModelFileError:
        if "unknown_inputs" not in model_file_tables(path):
            raise
        return None


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
