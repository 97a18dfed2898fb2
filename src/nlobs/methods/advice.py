r"""Which of nlobs's observers applies to a model, with the evidence and the first command (``nlobs advise``).

:func:`advise_model` reads a model file (or a shipped name, or a model), chooses the region of its
analyses, and returns one :class:`MethodAdvice` per method of nlobs in an :class:`AdviceReport`:

* ``drift`` — the observer (3.1) of Dalla Mora, Germani & Manes: drift-observability on the region
  (Def. 2.3, ``det Q_s ≠ 0``; the smallest ``|det Q_s|`` over sampled points and where it vanishes),
  the observation relative degree ``r`` (Def. 2.5) and ``s ≤ r`` (Theorems 2.9, 3.4; otherwise
  Theorem 2.7 needs a small input bound ``μ`` of (2.17)); ``μ`` is the largest ``‖u(t)‖`` of the
  file's ``[input_signals]``. A sign change of ``det Q_s`` that depends on one state gives a *local*
  verdict: the largest part of the region on one side of its zeros;
* ``pinv`` — Röbenack's Moore–Penrose observer (7), (17): ``Σ r_j < n``, A1 and A5;
* ``luenberger`` — a Luenberger gain of LMIs (14), (15) of Grip, Saberi & Johansen for the
  linearisation at the file's ``x0`` (local: detectability of the linearisation);
* ``ekf-ukf`` — extended and unscented Kalman filters (any model): the generic rank of the
  observability codistribution (or observability of the linearisation);
* ``cascade`` — the observer (9)–(10) of Grip, Saberi & Johansen: a ``[cascade]`` table in the file
  (its contents are read by ``nlobs design cascade``), or else the *structure* (1a)–(1b) found in
  the equations: states ``w`` whose right-hand sides are affine in ``w`` with constant coefficients,
  driven by the other states, with every output linear in ``w`` (:func:`cascade_structure`);
* ``setvalued`` — the set-valued observer of Khajenejad & Yong for a discrete-time model with
  unknown inputs (the file's ``[unknown_inputs]``): strong detectability of ``(A, G, C, H)``
  (Def. 2.1).

The region: the given box, else the file's ``[simulation] box``, else ``[−1, 1]ⁿ``. Before any
analysis the region is searched for the singularities of ``f``, ``g`` and ``h``
(:func:`singularities`): denominators that vanish (a Monod pole ``K_s + S = 0``), arguments of
square roots and logarithms that are negative, and non-finite values of ``f`` at sampled points.
A region that contains one is replaced by a *suggested* box that avoids those of one state (cut at
the zeros, with a margin of 5 % of the remaining interval), and the analyses run on that box.

A verdict above is about the *theorems*: a high-gain observer whose hypotheses hold can still fail
once its output is sampled and noisy (a continuous high-gain design fed held samples at a rate
below its bandwidth diverges; a large gain amplifies the sensor noise). ``check=True``
(``check`` of ``nlobs advise``) runs every applicable observer nlobs can simulate and an EKF on a few
noisy Monte Carlo runs under the file's sensors (:func:`nlobs.methods.comparison.compare_observers`)
and ranks an observer that diverged or never converged below the Kalman filters, with the measured
numbers as its evidence (and, for the drift observer, its fastest error pole against the sampling
interval); one that converges with an error more than :data:`CHECK_RMS_FACTOR` times the EKF's
keeps its rank with a note on noise amplification.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from nlobs._schema import ANY, BOX, INTEGER, NUMBER, STRING, Record, array, enum, mapping, nullable
from nlobs.errors import InvalidArgumentError, ModelError, ModelFileError, NlobsError
from nlobs.geometry.budget import DEFAULT_SYMBOLIC_BUDGET
from nlobs.geometry.checks import SYMBOLIC_DET_MAX_N
from nlobs.geometry.lie import tidy
from nlobs.geometry.observability import AffineFields, observability_jacobian
from nlobs.geometry.region import Box, format_point
from nlobs.geometry.report import MAX_GEOMETRY_STATES, GeometryReport, geometry_report, too_many_states
from nlobs.geometry.unobservable import Unobservability, linear_unobservable_directions, unobservable_directions
from nlobs.geometry.singularities import (
    SINGULARITY_JSON,
    Singularity,
    expression_atoms,
    real_roots,
    sample_points,
    singularities,
)
from nlobs.linear import analyze_linear
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.linear import LinearSystem
from nlobs.systems.linearize import linearize
from nlobs.systems.modelfile import Model, load_discrete_ui_model, load_model, load_scenario, model_file_tables
from nlobs.systems.symbolic import SymbolicModel
from nlobs.checks import VERDICT_JSON, Verdict
from nlobs.methods.base import DESIGN_JSON
from nlobs.methods.problem import as_region, model_label, problem

#: With ``check``: an observer whose RMS error exceeds this multiple of the EKF's gets a note on noise amplification.
CHECK_RMS_FACTOR = 10.0
#: The advisor's methods that :func:`nlobs.methods.comparison.compare_observers` runs (under the same names).
_SIMULATED = ("drift", "pinv", "luenberger", "cascade")
#: The methods the check runs when they apply: the certified ones and the estimators without a certificate.
_CHECKED = (*_SIMULATED, "pf", "mhe")

__all__ = ["CHECK_RMS_FACTOR", "METHODS", "AdviceReport", "SensorCheck", "CascadeStructure", "MethodAdvice", "Singularity", "advise_model",
           "cascade_structure", "singularities"]

#: The methods the advisor reports on, in the order it prefers an applicable one.
METHODS: tuple[str, ...] = ("cascade", "setvalued", "drift", "pinv", "ekf-ukf", "luenberger", "pf", "mhe")
#: The estimators without a certificate that need what the Kalman filters need: where the EKF/UKF advice is "no",
#: theirs is too (the same observability verdict).
_LIKE_THE_FILTERS = ("pf", "mhe")
#: Fraction of the remaining interval kept away from a singular value of one state.
MARGIN = 0.05
#: Largest ``n`` whose subsets are searched for a cascade structure (2ⁿ subsets).
CASCADE_MAX_N = 12
#: Default decay rate α of (2.17) and of the Luenberger poles (the ``alpha`` of ``nlobs design drift``).
DEFAULT_ALPHA = 1.0


@dataclass(frozen=True)
class CascadeStructure:
    """States ``w`` with ``ẇ = A w + z(x, u)`` (``A`` constant), ``y = C w``, ``z`` depending on the other states.

    The form (1a)–(1b) of Grip, Saberi & Johansen: a linear measured subsystem Σ₂ (the states
    :attr:`linear_states`) driven by the nonlinear Σ₁ (:attr:`nonlinear_states`) through ``z``.

    Attributes
    ----------
    linear_states : tuple of str
        Names of the states ``w`` of the linear measured subsystem.
    nonlinear_states : tuple of str
        Names of the other states.
    drive : tuple of str
        ``"state: z_i"`` for each linear state driven by a nonlinear one, with its ``z_i``.
    """

    linear_states: tuple[str, ...]
    nonlinear_states: tuple[str, ...]
    drive: tuple[str, ...]

    def describe(self) -> str:
        return (f"linear measured states {', '.join(self.linear_states)} driven through z = ({', '.join(self.drive)}) "
                f"by {', '.join(self.nonlinear_states)}")

    def to_dict(self) -> dict[str, Any]:
        return {"linear_states": list(self.linear_states), "nonlinear_states": list(self.nonlinear_states),
                "drive": list(self.drive)}  # one of the parameters of MethodAdvice (not a record of its own)


#: The JSON of a :class:`MethodAdvice` (one entry of ``nlobs advise``'s ``methods``).
METHOD_ADVICE_JSON = Record("MethodAdvice", {
    "method": enum(*METHODS),
    "title": STRING,
    "applicable": enum("yes", "no", "local"),
    "reason": STRING.about("one line: why"),
    "region": nullable(STRING, "where a local verdict holds"),
    "evidence": array(STRING, "the numbers behind the verdict"),
    "parameters": mapping(ANY, "what to start from (box, alpha, mu, theta, ...)"),
    "command": nullable(STRING, "the first nlobs command to run (null when the method does not apply)"),
})

@dataclass(frozen=True)
class MethodAdvice:
    """The advisor's verdict on one method.

    Attributes
    ----------
    method : str
        One of :data:`METHODS`.
    title : str
    applicable : str
        ``"yes"``, ``"no"`` or ``"local"`` (on :attr:`region` only).
    reason : str
        One line: why.
    evidence : tuple of str
        The numbers behind the verdict.
    parameters : dict
        What to start from (box, α, μ, θ, ...).
    command : str or None
        The first ``nlobs`` command to run (``None`` when the method does not apply).
    region : str or None
        Where a local verdict holds.
    rank : int
        Preference among applicable methods (lower is preferred; not printed).
    """

    method: str
    title: str
    applicable: str
    reason: str
    evidence: tuple[str, ...] = ()
    parameters: dict[str, Any] = field(default_factory=dict)
    command: str | None = None
    region: str | None = None
    rank: int = 0  # lower is preferred among applicable methods (not printed)

    @property
    def usable(self) -> bool:
        return self.applicable in ("yes", "local") and self.command is not None

    def to_dict(self) -> dict[str, Any]:
        return METHOD_ADVICE_JSON.emit({
            "method": self.method, "title": self.title, "applicable": self.applicable, "reason": self.reason,
            "region": self.region, "evidence": list(self.evidence), "parameters": dict(self.parameters),
            "command": self.command})


#: One observer's line of a :class:`SensorCheck`.
SENSOR_OUTCOME_JSON = Record("SensorCheckOutcome", {
    "rms_error_norm": NUMBER.about("RMS of the error norm after the settling time, over the runs that did not diverge"),
    "diverged": INTEGER.about("runs that diverged"),
    "convergence_time": NUMBER,
    "skipped": nullable(STRING, "why it was not run"),
})

#: The JSON of a :class:`SensorCheck` (``nlobs advise`` with its check).
SENSOR_CHECK_JSON = Record("SensorCheck", {
    "runs": INTEGER,
    "seed": INTEGER,
    "outcomes": mapping(SENSOR_OUTCOME_JSON, "per observer"),
    "demoted": mapping(STRING, "the observers ranked below the Kalman filters, with the measured reason"),
    "time_unit": STRING,
})

@dataclass(frozen=True)
class SensorCheck:
    """The applicable observers and an EKF on the same noisy runs under the file's sensors (``check=True``).

    Attributes
    ----------
    runs, seed : int
    outcomes : dict
        Per observer (``"drift"``, ..., ``"ekf"``): ``rms_error_norm`` (after the settling time, runs
        that did not diverge), ``diverged`` (runs), ``convergence_time`` and ``skipped`` (why it was
        not run, else ``None``).
    demoted : dict
        The observers ranked below the Kalman filters, with the measured reason.
    time_unit : str
    """

    runs: int
    seed: int
    outcomes: dict[str, dict[str, Any]]
    demoted: dict[str, str]
    time_unit: str = "s"

    def describe(self, name: str) -> str:
        o = self.outcomes[name]
        if o["skipped"]:
            return f"under the file's sensors ({self.runs} runs): not run: {o['skipped']}"
        conv = o["convergence_time"]
        conv_txt = "never converged" if not np.isfinite(conv) else f"converged at {conv:.3g} {self.time_unit}"
        note = f"; {o['note']}" if o.get("note") else ""
        return (f"under the file's sensors ({self.runs} noisy runs, seed {self.seed}): RMS ‖e‖ = "
                f"{o['rms_error_norm']:.4g}, diverged {o['diverged']}/{self.runs}, {conv_txt}{note}")

    def to_dict(self) -> dict[str, Any]:
        return SENSOR_CHECK_JSON.emit({
            "runs": self.runs, "seed": self.seed,
            "outcomes": {k: SENSOR_OUTCOME_JSON.emit(v) for k, v in self.outcomes.items()},
            "demoted": dict(self.demoted), "time_unit": self.time_unit})


def _sensor_check(model: str | Path, methods: Sequence[MethodAdvice], region: Box, runs: int,
                  progress: bool | None) -> tuple[tuple[MethodAdvice, ...], SensorCheck]:
    """Run the applicable observers and an EKF under the file's sensors; demote those that fail there."""
    import math

    from nlobs.methods.comparison import compare_observers

    names = [m.method for m in methods if m.usable and m.method in _CHECKED]
    drift = next((m for m in methods if m.method == "drift" and m.usable), None)
    box = best_region(drift, region) if drift is not None else region
    flat = [float(v) for pair in zip(box.lower, box.upper) for v in pair]
    rep = compare_observers(model, observers=[*names, "ekf"], runs=runs, seed=0, box=flat, progress=progress)
    outcomes: dict[str, dict[str, Any]] = {}
    for name, o in rep.observers.items():
        outcomes[name] = {"rms_error_norm": o.rms_error_norm, "diverged": len(o.diverged_runs),
                          "convergence_time": o.convergence_time, "skipped": o.skipped}
    ekf = outcomes.get("ekf", {})
    ref = ekf.get("rms_error_norm", math.nan) if not ekf.get("skipped") else math.nan
    demoted: dict[str, str] = {}
    for name in names:
        o = outcomes[name]
        if o["skipped"]:
            demoted[name] = f"not run under the file's sensors: {o['skipped']}"
        elif o["diverged"]:
            demoted[name] = f"diverged in {o['diverged']} of {runs} noisy runs under the file's sensors"
        elif not math.isfinite(o["rms_error_norm"]):
            demoted[name] = "no finite error under the file's sensors"
        elif not math.isfinite(o["convergence_time"]):
            demoted[name] = ("its error never fell well below where it started under the file's sensors (RMS "
                             f"{o['rms_error_norm']:.3g}, the EKF's {ref:.3g})")
        elif math.isfinite(ref) and o["rms_error_norm"] > CHECK_RMS_FACTOR * ref:
            o["note"] = (f"converges, but its RMS error is {o['rms_error_norm'] / ref:.3g} × the EKF's: the gain "
                         "amplifies the sensor noise (the EKF is more accurate; it has no convergence certificate)")
    if "drift" in demoted and not outcomes["drift"]["skipped"]:
        demoted["drift"] += _sampling_note(rep.observers["drift"].observer, model, rep.time_unit)
    check = SensorCheck(runs, 0, outcomes, demoted, rep.time_unit)
    out = []
    for m in methods:
        sim = m.method if m.method in _CHECKED else ("ekf" if m.method == "ekf-ukf" else None)
        if sim is None or sim not in outcomes or not m.usable:
            out.append(m)
            continue
        ev = (*m.evidence, check.describe(sim))
        if sim in demoted:
            out.append(dataclasses.replace(m, evidence=ev, rank=m.rank + 100,
                                           reason=f"{m.reason}; but {demoted[sim]}"))
        else:
            out.append(dataclasses.replace(m, evidence=ev))
    return tuple(out), check


def _sampling_note(observer: Any, model: str | Path, time_unit: str) -> str:
    """The drift gain's fastest error pole against the sensors' sampling interval (why a run may diverge)."""
    from nlobs.systems.brunovsky import brunovsky

    sensors = load_scenario(model).sensors
    observer = getattr(observer, "observer", observer)  # the observer inside an output predictor
    K = getattr(observer, "K", None)
    if not sensors or K is None:
        return ""
    A, _, C = brunovsky(observer.s)
    lam = float(np.max(np.abs(np.linalg.eigvals(A - np.asarray(K) @ C))))
    ts = 1.0 / min(g.rate for g in sensors)
    return (f" (the gain's fastest error pole is {lam:.3g} per {time_unit} and the output is sampled every "
            f"{ts:.3g} {time_unit}: |λ|·Ts = {lam * ts:.2g}; a continuous high-gain design fed samples needs "
            "|λ|·Ts well below 1: a faster sensor, or a smaller gain (a smaller α of the design, a smaller region))")


#: The JSON of an :class:`AdviceReport` (``nlobs advise``; ``advice`` in ``nlobs analyze``).
ADVICE_JSON = Record("Advice", {
    "model": STRING,
    "box": nullable(BOX, "the region the methods were judged on"),
    "box_source": STRING,
    "region": nullable(BOX, "a suggested region that avoids the singularities"),
    "singularities": array(SINGULARITY_JSON),
    "methods": mapping(METHOD_ADVICE_JSON, "per method, in the advisor's order"),
    "recommended": STRING,
    "command": STRING,
    "compare_command": nullable(STRING),
    "verdict": VERDICT_JSON,
    "message": STRING,
    "check": nullable(SENSOR_CHECK_JSON, "the observers run under the file's sensors (the check)"),
    "design": nullable(DESIGN_JSON, "the recommended method's design"),
}, description="Which observer applies to a model, with the evidence.")

@dataclass(frozen=True)
class AdviceReport:
    """What ``nlobs advise`` prints: one :class:`MethodAdvice` per method and the recommendation.

    Attributes
    ----------
    model : str
        The model's name.
    target : str
        How commands name the model (the path or shipped name given).
    box : Box or None
        The region asked for (given, or from the file), ``None`` for a linear model.
    box_source : str
        ``"given"``, ``"file [simulation] box"`` or ``"default [-1, 1]^n"``.
    region : Box or None
        The region of the analyses (:attr:`box`, or the suggested box avoiding :attr:`singular`).
    singular : tuple of Singularity
        Singularities of the model found in :attr:`box`.
    methods : tuple of MethodAdvice
    recommended : str or None
        The preferred applicable method.
    compare_command : str or None
        The comparison of the recommended observer with an EKF and a UKF under the file's sensors.
    verdict : Verdict
        ``OK`` when a method applies, ``NO_OBSERVER`` otherwise.
    message : str
    check : SensorCheck or None
        With ``check=True``: the applicable observers and an EKF under the file's sensors.
    design : Design or None
        The recommended method's design for the model file (:mod:`nlobs.methods`), as ``nlobs design``,
        ``nlobs export`` and ``nlobs simulate`` make it (the region the advice recommends); ``None``
        without a model file, or when the design cannot be made (:attr:`design_error` says why).
    design_error : str
        Why there is no :attr:`design` for a recommended method.
    """

    model: str
    target: str
    box: Box | None
    box_source: str
    region: Box | None
    singular: tuple[Singularity, ...]
    methods: tuple[MethodAdvice, ...]
    recommended: str | None
    compare_command: str | None
    verdict: Verdict = Verdict.OK
    message: str = ""
    check: SensorCheck | None = None
    design: Any = None
    design_error: str = ""

    def method(self, name: str) -> MethodAdvice:
        """The advice on one method (``KeyError`` for an unknown name)."""
        for m in self.methods:
            if m.method == name:
                return m
        raise KeyError(name)

    @property
    def command(self) -> str | None:
        """The first command to run (the recommended method's)."""
        return None if self.recommended is None else self.method(self.recommended).command

    def to_dict(self) -> dict[str, Any]:
        def box(b: Box | None) -> Any:
            return None if b is None else {"lower": b.lower.tolist(), "upper": b.upper.tolist()}

        return ADVICE_JSON.emit({
            "model": self.model, "box": box(self.box), "box_source": self.box_source, "region": box(self.region),
            "singularities": [s.to_dict() for s in self.singular],
            "methods": {m.method: m.to_dict() for m in self.methods}, "recommended": self.recommended,
            "command": self.command, "compare_command": self.compare_command, "verdict": self.verdict.value,
            "message": self.message, "check": None if self.check is None else self.check.to_dict(),
            "design": None if self.design is None else self.design.to_dict()})

    def summary(self, *, short: bool = False) -> str:
        """The text report (``short``: the recommendation and one line per method, as ``nlobs analyze`` ends)."""
        lines = [f"observer advice for {self.model}"]
        if self.box is not None:
            lines.append(f"  box {self.box.describe()} ({self.box_source})")
        for s in self.singular:
            lines.append(f"  singular: {s.describe()}")
        if self.region is not None and self.box is not None and not _same(self.region, self.box):
            lines.append(f"  suggested box (avoids the singularities): {self.region.describe()}")
        for m in self.methods:
            where = "" if not m.region else (f" {m.region}" if m.region.startswith("near") else f" on {m.region}")
            lines.append(f"  [{m.applicable:5s}] {m.title}{where}: {m.reason}")
            if not short:
                lines.extend(f"          {e}" for e in m.evidence)
                if m.parameters:
                    lines.append("          start from: " + ", ".join(f"{k} = {_fmt_param(v)}"
                                                                      for k, v in m.parameters.items()))
                if m.command:
                    lines.append(f"          $ {m.command}")
        if self.check is not None:
            for name, why in self.check.demoted.items():
                lines.append(f"  checked: {name} ranked below the Kalman filters: {why}")
        elif not short and self.recommended in _SIMULATED:
            lines.append("  not checked under the file's sensors (a verdict of the theorems): nlobs advise `check` "
                         "runs the observers and an EKF on noisy runs first")
        if self.recommended is None:
            lines.append(f"  recommended: none — {self.message}")
        else:
            lines.append(f"  recommended: {self.method(self.recommended).title}")
            lines.append(f"    $ {self.command}")
            if self.compare_command:
                lines.append(f"    then compare with EKF/UKF under the file's sensors: $ {self.compare_command}")
        return "\n".join(lines)


# ----------------------------------------------------------------------------- helpers
def _same(a: Box, b: Box) -> bool:
    return bool(np.array_equal(a.lower, b.lower) and np.array_equal(a.upper, b.upper))


def _fmt_param(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt_param(x) for x in v) + "]"
    return str(v)


def _num(v: float) -> str:
    return f"{float(v):.6g}"


def box_option(box: Box) -> str:
    """``--box=lo1,hi1,...`` as the commands read it (the ``=`` keeps a leading minus an option value)."""
    lo, hi = box.lower, box.upper
    if np.all(lo == lo[0]) and np.all(hi == hi[0]):
        return f"--box={_num(lo[0])},{_num(hi[0])}"
    return "--box=" + ",".join(f"{_num(a)},{_num(b)}" for a, b in zip(lo, hi))


def _cut_box(box: Box, cuts: dict[int, list[float]], keep: dict[int, Any], x0: np.ndarray | None) -> Box:
    """The box cut at the given values of its states: per state the piece holding ``x0`` (else the widest).

    ``keep[i](value) -> bool`` says whether a piece is admissible (a root's argument positive there).
    Each cut end moves :data:`MARGIN` of the piece's width away from the cut.
    """
    lo, hi = box.lower.copy(), box.upper.copy()
    for i, vals in cuts.items():
        edges = [float(lo[i]), *sorted(v for v in vals if lo[i] < v < hi[i]), float(hi[i])]
        pieces = [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a and keep.get(i, lambda _v: True)((a + b) / 2)]
        if not pieces:
            continue
        inside = [p for p in pieces if x0 is not None and p[0] <= x0[i] <= p[1]]
        a, b = inside[0] if inside else max(pieces, key=lambda p: p[1] - p[0])
        width = b - a
        lo[i] = a + (MARGIN * width if a != box.lower[i] or a in vals else 0.0)
        hi[i] = b - (MARGIN * width if b != box.upper[i] or b in vals else 0.0)
    return Box(lo, hi)


def _suggested_box(model: SymbolicModel, box: Box, sing: Sequence[Singularity], x0: np.ndarray | None) -> Box:
    cuts: dict[int, list[float]] = {}
    keep: dict[int, Any] = {}
    for s in sing:
        if s.state is None or not s.values:
            continue
        i = model.states.index(s.state)
        cuts.setdefault(i, []).extend(s.values)
        if s.kind == "domain":
            atom_fn = _univariate(model, s.expression, i)
            prev = keep.get(i, lambda _v: True)
            keep[i] = (lambda f, p: (lambda v: p(v) and f(v) > 0))(atom_fn, prev)
    return _cut_box(box, cuts, keep, x0) if cuts else box


def _univariate(model: SymbolicModel, text: str, i: int) -> Any:
    """The singular expression ``text`` (found among the model's atoms) as a function of state ``i``."""
    subs = model.substituted()
    for e in (*model.rhs, *model.h):
        for _kind, atom in expression_atoms(e.subs(subs)):
            if str(atom) == text:
                fn = compile_matrix(sp.Matrix([atom]), ((model.x[i],),), vector=True, what=text)
                return lambda v: float(np.asarray(fn(np.array([[v]])), dtype=float)[0, 0])
    return lambda _v: True


def cascade_structure(model: SymbolicModel) -> CascadeStructure | None:
    """The largest set of states ``w`` in the form (1a)–(1b) of Grip, Saberi & Johansen, or ``None``.

    ``w`` qualifies when, for every ``i`` in ``w``, ``∂ẋ_i/∂w_j`` is a constant for every ``j`` in
    ``w`` (``ẇ = A w + z(x, u)``), every output is ``C w`` (constant ``∂h/∂w``, no other state),
    some ``z_i`` depends on a state outside ``w`` (the linear part is driven by the nonlinear one),
    and ``w`` is neither empty nor all the states. Subsets are searched largest first, for
    ``n ≤`` :data:`CASCADE_MAX_N` (the Jacobian is built once; each test is a table look-up).

    Parameters
    ----------
    model : SymbolicModel
        A continuous-time model (a discrete-time one gives ``None``).

    Returns
    -------
    CascadeStructure or None
    """
    n = model.n
    if n < 2 or n > CASCADE_MAX_N or model.time.is_discrete:
        return None
    subs = model.substituted()
    xs = tuple(model.x)
    var = set(xs) | set(model.u)
    rhs = [e.subs(subs) for e in model.rhs]
    h = [e.subs(subs) for e in model.h]
    const = [[not (sp.diff(rhs[i], xs[j]).free_symbols & var) for j in range(n)] for i in range(n)]
    dep = [[bool(sp.diff(rhs[i], xs[j]) != 0) for j in range(n)] for i in range(n)]
    hconst = [[not (sp.diff(e, xs[j]).free_symbols & var) for j in range(n)] for e in h]
    hdep = [[bool(sp.diff(e, xs[j]) != 0) for j in range(n)] for e in h]
    for size in range(n - 1, 0, -1):
        for w in combinations(range(n), size):
            v = [j for j in range(n) if j not in w]
            if not all(const[i][j] for i in w for j in w):
                continue
            if not all(hconst[k][j] for k in range(len(h)) for j in w) or any(hdep[k][j] for k in range(len(h))
                                                                              for j in v):
                continue
            if not any(hdep[k][j] for k in range(len(h)) for j in w):
                continue
            drive = [i for i in w if any(dep[i][j] for j in v)]
            if not drive:
                continue
            z = []
            for i in drive:
                zi = sp.expand(rhs[i] - sum(sp.diff(rhs[i], xs[j]) * xs[j] for j in w))
                z.append(f"{model.states[i]}: {zi}")
            return CascadeStructure(tuple(model.states[i] for i in w), tuple(model.states[j] for j in v), tuple(z))
    return None


def _input_bound(scenario: Any) -> tuple[float, str]:
    """``μ``: the largest ``‖u(t)‖`` of the file's input signals over its run, by the one rule of every command."""
    if getattr(scenario, "input_signals", None) is None:
        return 0.0, "no [input_signals] in the file (μ = 0: give the drift design your inputs' bound μ)"
    pb = problem(scenario)
    return pb.mu, f"{pb.sources['mu']} = {pb.mu:.4g}"


def _det_evidence(fields: AffineFields, s: tuple[int, ...], region: Box) -> tuple[str | None, Any]:
    """``det Q_s`` (``n ≤ 4``) and the smallest ``|det Q_s|`` over sampled points of the region."""
    if fields.n > SYMBOLIC_DET_MAX_N or sum(s) != fields.n:
        return None, None
    det = sp.factor(tidy(observability_jacobian(fields, s).det(method="berkowitz")))
    if det.is_number:
        return f"det Q_s = {det} (constant)", det
    fn = compile_matrix(sp.Matrix([det]), (tuple(fields.x),), vector=True, what="det Q_s")
    pts = sample_points(region)
    with np.errstate(all="ignore"):
        v = np.abs(np.asarray(fn(pts), dtype=float)[:, 0])
    v = np.where(np.isfinite(v), v, 0.0)
    k = int(np.argmin(v))
    return f"det Q_s = {det}; min |det Q_s| over {len(pts)} sampled points = {v[k]:.4g} at x = {format_point(pts[k])}", det


def _local_drift_box(fields: AffineFields, det: Any, region: Box, x0: np.ndarray | None) -> Box | None:
    """The part of the region on one side of the zeros of ``det Q_s`` when it depends on one state."""
    if det is None or getattr(det, "is_number", True):
        return None
    free = sorted(det.free_symbols & set(fields.x), key=fields.x.index)
    if len(free) != 1:
        return None
    i = fields.x.index(free[0])
    roots = real_roots(det, free[0], float(region.lower[i]), float(region.upper[i]))
    if not roots:
        return None
    return _cut_box(region, {i: list(roots)}, {}, x0)


# ----------------------------------------------------------------------------- the methods
def _drift(target: str, geo: GeometryReport | None, geo_err: str | None, fields: AffineFields | None, region: Box,
           mu: float, mu_src: str, x0: np.ndarray | None) -> MethodAdvice:
    title = "drift observer (Dalla Mora, Germani & Manes (3.1))"
    if geo is None or fields is None:
        return MethodAdvice("drift", title, "no", f"needs a continuous-time input-affine model ({geo_err})")
    r = geo.relative_degree
    r_txt = ", ".join("undefined" if v is None else str(v) for v in r)
    ev = [f"observation relative degree r = ({r_txt}); multi-index s = {tuple(geo.multi_index)}"]
    r_txt = r_txt.replace("undefined", "∞")
    if geo.drift is None:
        return MethodAdvice("drift", title, "no", "the observability codistribution has rank < n: no Φ_s is a "
                            "diffeomorphism", tuple(ev))
    det_txt, det = _det_evidence(fields, tuple(geo.multi_index), region)
    if det_txt:
        ev.append(det_txt)
    ev.append(f"drift-observability on {region.describe()}: {'yes' if geo.drift.passed else 'NO'} — {geo.drift.evidence}")
    s_le_r = all(v is None or si <= v for si, v in zip(geo.multi_index, r))  # undefined r: r = ∞
    ev.append(f"s ≤ r: {'yes' if s_le_r else 'no'} (Theorems 2.9, 3.4" + ("" if s_le_r else
              "; otherwise Theorem 2.7: (2.17) needs a small input bound μ") + ")")
    ev.append(f"μ: {mu_src}")
    params: dict[str, Any] = {"box": _box_list(region), "alpha": DEFAULT_ALPHA, "mu": mu, "w_max": 1e5}
    if geo.drift.passed:
        cmd = f"nlobs design drift {target} {box_option(region)} --alpha {DEFAULT_ALPHA:g} --mu {mu:.4g}"
        where = region.describe()
        if s_le_r or mu == 0.0:
            return MethodAdvice("drift", title, "local", "drift-observable on the region" + (", s ≤ r" if s_le_r else
                                ", no input") + " (Theorem 3.1's Lipschitz premises are checked there only)",
                                tuple(ev), params, cmd, region=where, rank=2)
        return MethodAdvice("drift", title, "local", f"drift-observable on the region, but s ≰ r: (2.17) holds only "
                            f"for a small input bound, here μ = {mu:.4g} (a smaller μ, or the SDP gain method)", tuple(ev),
                            params, cmd, region=where, rank=5)
    local = _local_drift_box(fields, det, region, x0)
    if local is not None:
        params["box"] = _box_list(local)
        cmd = f"nlobs design drift {target} {box_option(local)} --alpha {DEFAULT_ALPHA:g} --mu {mu:.4g}"
        return MethodAdvice("drift", title, "local", "det Q_s vanishes inside the box; Q_s is nonsingular on one side "
                            "(a trajectory that crosses the singular set leaves what the observer covers)",
                            tuple(ev), params, cmd, region=local.describe(), rank=8)
    return MethodAdvice("drift", title, "no", "Q_s is singular inside the region", tuple(ev), params)


def _box_list(b: Box) -> list[list[float]]:
    return [[float(a), float(c)] for a, c in zip(b.lower, b.upper)]


def _pinv(target: str, geo: GeometryReport | None, geo_err: str | None, region: Box) -> MethodAdvice:
    from nlobs.synthesis.pinv_gain import DEFAULT_THETA

    title = "Moore–Penrose observer (Röbenack (7), (17))"
    if geo is None:
        return MethodAdvice("pinv", title, "no", f"needs a continuous-time input-affine model ({geo_err})")
    r = geo.relative_degree
    n = len(geo.states)
    ev = ["observation relative degree r = (" + ", ".join("undefined" if v is None else str(v) for v in r) + ")"]
    if any(v is None for v in r):
        return MethodAdvice("pinv", title, "no", "the observation relative degree is not defined on the region "
                            "(L_g L_f^k h ≡ 0 for k < n, or no input)", tuple(ev))
    total = sum(v for v in r if v is not None)
    ev.append(f"Σ r_j = {total}, n = {n}")
    for c in (geo.a1, geo.a5):
        if c is not None:
            ev.append(c.summary())
    if total >= n:
        return MethodAdvice("pinv", title, "no", f"Σ r_j = {total} is not < n = {n}: Q is square, Q⁺ = Q⁻¹ (the drift "
                            "observer with s = r is that case)", tuple(ev))
    if geo.a1 is None or not geo.a1.passed:
        return MethodAdvice("pinv", title, "no", "A1 fails on the region", tuple(ev))
    if geo.a5 is None:
        return MethodAdvice("pinv", title, "no", "A5 (involutivity) was not checked (the symbolic Q⁺ did not finish "
                            "within the symbolic budget)", tuple(ev))
    if not geo.a5.passed:
        return MethodAdvice("pinv", title, "no", "A5 (involutivity) fails on the region", tuple(ev))
    cmd = f"nlobs design pinv {target} {box_option(region)} --theta {DEFAULT_THETA:g}"
    return MethodAdvice("pinv", title, "local", f"Σ r_j = {total} < n, A1 and A5 hold on the region (A2–A4, A6 of "
                        "Corollary 4.1, global conditions, are not checked)",
                        tuple(ev), {"box": _box_list(region), "theta": DEFAULT_THETA}, cmd, region=region.describe(),
                        rank=3)


def _linear_part(target: str, model: Model, x0: np.ndarray, u0: np.ndarray, geo: GeometryReport | None,
                 err: str | None, unobs: Unobservability | None) -> tuple[MethodAdvice, MethodAdvice]:
    """Luenberger on the linearisation at ``x0``, ``u0``, and the EKF/UKF (open loop along what is unobservable)."""
    lt = "Luenberger / LMI (14), (15) of Grip, Saberi & Johansen"
    kt = "EKF / UKF"
    obs_rank = None if geo is None else geo.observability_rank
    ev: list[str] = []
    observable = detectable = None
    try:
        if isinstance(model, LinearSystem):
            rep = analyze_linear(model)
        else:
            rep = analyze_linear(linearize(model, tuple(x0), tuple(u0)))
        observable, detectable = bool(rep.observable), bool(rep.detectable)
        where = "" if isinstance(model, LinearSystem) else (
            f" of the linearisation at x0 = {format_point(x0)}" + (f", u0 = {format_point(u0)}" if model.m else ""))
        ev.append(f"observable{where}: {'yes' if observable else 'no'}; detectable: {'yes' if detectable else 'no'}")
    except NlobsError as exc:
        ev.append(f"linearisation at x0 = {format_point(x0)} not available: {exc}")
    cmp = f"nlobs simulate {target} --observer luenberger,ekf,ukf"
    if detectable:
        kind = "yes" if isinstance(model, LinearSystem) else "local"
        luen = MethodAdvice("luenberger", lt, kind, "detectable" + ("" if kind == "yes" else " linearisation: a local "
                            "guarantee near x0"), tuple(ev), {"alpha": DEFAULT_ALPHA, "x0": [float(v) for v in x0]},
                            cmp, region=None if kind == "yes" else f"near x0 = {format_point(x0)}",
                            rank=1 if kind == "yes" else 9)
    else:
        luen = MethodAdvice("luenberger", lt, "no", "the linearisation is not detectable" if detectable is False
                            else "no linearisation", tuple(ev))
    kev = list(ev)
    if obs_rank is not None:
        kev.insert(0, f"generic rank of the observability codistribution: {obs_rank} of n = {model.n}")
    ok = (obs_rank == model.n) if obs_rank is not None else bool(observable or detectable)
    kcmd = f"nlobs simulate {target} --observer ekf,ukf"
    if ok:
        kal = MethodAdvice("ekf-ukf", kt, "yes", "observable (no convergence certificate: a tuned filter)", tuple(kev),
                           {"Q": "the file's [process_noise]", "R": "the file's [sensors]"}, kcmd, rank=6)
    elif unobs is not None and unobs.rank and unobs.directions:
        kev.append(f"unobservable: {'; '.join(unobs.directions)}")
        if detectable:  # the unobservable part decays by itself: the filters' open-loop estimate of it converges
            kal = MethodAdvice("ekf-ukf", kt, "local", f"the model is {unobs.describe()}: the filters estimate the "
                               "observable part; their estimate along the unobservable "
                               f"{'direction' if len(unobs.directions) == 1 else 'directions'} runs open loop (it "
                               "decays: the linearisation is detectable)", tuple(kev),
                               {"Q": "the file's [process_noise]", "R": "the file's [sensors]"}, kcmd, rank=12)
        else:
            kal = MethodAdvice("ekf-ukf", kt, "no", f"the model is {unobs.describe()}, and that part does not "
                               "decay (the linearisation is not detectable): a filter's estimate of it runs open loop "
                               "and does not converge", tuple(kev))
    else:
        kal = MethodAdvice("ekf-ukf", kt, "no", "the model is not observable from its outputs", tuple(kev))
    return luen, kal


def _cascade(target: str, model: Model, tables: frozenset[str]) -> MethodAdvice:
    title = "cascade/feedback observer (Grip, Saberi & Johansen (9)–(10))"
    if "cascade" in tables:
        return MethodAdvice("cascade", title, "yes", "the file has a [cascade] table", ("[cascade] table present",),
                            {}, f"nlobs design cascade {target}", rank=0)
    if not isinstance(model, SymbolicModel):
        return MethodAdvice("cascade", title, "no", "a linear model: the Luenberger observer applies directly")
    cs = cascade_structure(model)
    if cs is None:
        return MethodAdvice("cascade", title, "no", "no subset of states is linear, measured and driven by the others "
                            "((1a)–(1b))")
    return MethodAdvice("cascade", title, "no",
                        f"cascade structure found: states {', '.join(cs.linear_states)}; describe it in a [cascade] "
                        "table to use the Grip–Saberi–Johansen observer", (cs.describe(),), cs.to_dict())


def _unknown_input_hidden(target: str, tables: frozenset[str], model: Model) -> tuple[str, ...]:
    """The states the file's unknown input moves without a trace in the output (the weakly unobservable subspace
    ``V*`` of ``(A, G, C, H)``: ``V_{k+1} = {x : ∃ d, A x + G d ∈ V_k, C x + H d = 0}``, ``V_0 = ℝⁿ``), named by
    the states with a component in it; empty without ``[unknown_inputs]`` or when ``V* = {0}``."""
    if "unknown_inputs" not in tables:
        return ()
    import scipy.linalg

    try:
        s = load_discrete_ui_model(target).system
    except NlobsError:
        return ()
    A, G, C, H = (np.asarray(x, dtype=float) for x in (s.A, s.G, s.C, s.H))
    n = A.shape[0]
    V = np.eye(n)
    for _ in range(n + 1):
        M = np.block([[(np.eye(n) - V @ np.linalg.pinv(V)) @ A, (np.eye(n) - V @ np.linalg.pinv(V)) @ G], [C, H]])
        N = scipy.linalg.null_space(M, rcond=1e-10)
        Vn = scipy.linalg.orth(N[:n, :]) if N.size else np.zeros((n, 0))
        if Vn.shape[1] == V.shape[1]:
            break
        V = Vn
    if V.shape[1] == 0:
        return ()
    names = list(getattr(model, "states", ())) or [f"x{i + 1}" for i in range(n)]
    return tuple(nm for nm, row in zip(names, V) if np.max(np.abs(row)) > 1e-8)


def _setvalued(target: str, tables: frozenset[str], model: Model) -> MethodAdvice:
    from nlobs.linear.zeros import is_strongly_detectable

    title = "set-valued observer (Khajenejad & Yong)"
    if "unknown_inputs" not in tables:
        why = ("needs a discrete-time model with unknown inputs ([unknown_inputs], [noise], [initial], "
               "[function_class])")
        return MethodAdvice("setvalued", title, "no", why if model.time.is_discrete else "a continuous-time model; "
                            + why)
    ui = load_discrete_ui_model(target)
    s = ui.system
    sd = bool(is_strongly_detectable(s.A, s.G, s.C, s.H, discrete=True))
    ev = (f"strong detectability of (A, G, C, H) (Def. 2.1): {'yes' if sd else 'no'}",
          f"function class: {s.function_class.label}")
    if not sd:
        return MethodAdvice("setvalued", title, "no", "not strongly detectable", ev)
    return MethodAdvice("setvalued", title, "yes", "strongly detectable", ev, {}, f"nlobs design setvalued {target}",
                        rank=1)


# ----------------------------------------------------------------------------- the workflow
def advise_model(model: str | Path | Model, box: Sequence[float] | Box | None = None, *,
                 geometry: GeometryReport | None = None, check: bool = False, runs: int = 3,
                 progress: bool | None = None,
                 symbolic_budget: float | None = DEFAULT_SYMBOLIC_BUDGET, scenario: Any = None) -> AdviceReport:
    """Which of nlobs's observers applies to ``model``, with the evidence and the first command (module docstring).

    Parameters
    ----------
    model : str, Path, SymbolicModel or LinearSystem
        A model file, a shipped model name, or a model (then no file tables, sensors or inputs).
    box : sequence of float or Box, optional
        The region: ``lo, hi`` for every state or ``lo1, hi1, ...``; default the file's
        ``[simulation] box``, else ``[−1, 1]ⁿ``.
    geometry : GeometryReport, optional
        The symbolic analyses on the region, when already computed (``nlobs analyze``); used only
        when its region is the advisor's.
    check : bool
        Also run the applicable observers and an EKF on ``runs`` noisy Monte Carlo runs under the
        file's sensors, and rank an observer that fails there below the Kalman filters (module
        docstring). Needs a model file.
    runs : int
        Runs of the check.
    progress : bool, optional
        The check's progress bar (default: on a terminal).
    symbolic_budget : float or None
        Seconds for the optional symbolic parts of the geometric analysis
        (:func:`~nlobs.geometry.report.geometry_report`).
    scenario : Scenario, optional
        The model file ``model`` names, when the caller has already read it (``nlobs analyze``): it is
        not read again.

    Raises
    ------
    ModelFileError
        The file cannot be read or is invalid.
    BoxError
        A malformed box.
    """
    is_file = isinstance(model, (str, Path))
    target = str(model) if is_file else model_label(model)
    tables: frozenset[str] = frozenset() if scenario is None else scenario.tables
    if is_file and scenario is None:
        try:
            scenario = load_scenario(model)  # the model file is parsed once, here (its tables too)
            tables = scenario.tables
        except ModelFileError:
            tables = model_file_tables(model)
            if "unknown_inputs" not in tables:
                raise
    m = scenario.model if scenario is not None else (load_model(model) if is_file else model)
    if not isinstance(m, (SymbolicModel, LinearSystem)):
        raise ModelError(f"model: expected a model file, a shipped model name or a model, got {type(m).__name__}")
    defaults = getattr(scenario, "defaults", None)
    given = as_region(box, m.n)
    if given is not None:
        reg0, src = given, "given"
    elif defaults is not None and defaults.box is not None:
        reg0, src = Box(*defaults.box), "file [simulation] box"
    else:
        reg0, src = Box.unit(m.n), "default [-1, 1]^n"
    x0 = None if defaults is None or defaults.x0 is None else np.asarray(defaults.x0, dtype=float)
    sing: tuple[Singularity, ...] = ()
    region = reg0
    if isinstance(m, SymbolicModel):
        sing = singularities(m, reg0)
        region = _suggested_box(m, reg0, sing, x0)
    x_lin = x0 if x0 is not None else (np.zeros(m.n) if isinstance(m, LinearSystem) else (region.lower + region.upper) / 2)
    geo, geo_err, fields = None, None, None
    if isinstance(m, SymbolicModel):
        try:
            fields = AffineFields.from_model(m)
            if m.n > MAX_GEOMETRY_STATES:  # not attempted: the other methods' advice still stands
                raise ModelError(too_many_states(m.n))
            geo = geometry if geometry is not None and _same(geometry.region, region) else geometry_report(
                m, region, symbolic_budget=symbolic_budget)
        except ModelError as exc:
            geo_err, fields = str(exc), None
    else:
        geo_err = "a linear model"
    mu, mu_src = _input_bound(scenario)
    u_lin = problem(scenario).u0 if scenario is not None else np.zeros(m.m)
    unobs = None
    if geo is not None and geo.observability_rank is not None and geo.observability_rank < m.n and fields is not None:
        unobs = unobservable_directions(fields, region)
    elif isinstance(m, LinearSystem):
        unobs = linear_unobservable_directions(m.A, m.C, m.states)
    luen, kal = _linear_part(target, m, x_lin, u_lin, geo, geo_err, unobs)
    hidden = _unknown_input_hidden(target, tables, m)
    if hidden:  # the filters' and the Luenberger observer's models leave the unknown input out: say what it hides
        note = (f"the file's unknown input can move {', '.join(hidden)} without changing the output (the weakly "
                "unobservable subspace of (A, G, C, H)): no observer recovers "
                f"{'it' if len(hidden) == 1 else 'them'}, and this estimate is biased by the unknown input")
        kal = dataclasses.replace(kal, evidence=(*kal.evidence, note))
        luen = dataclasses.replace(luen, evidence=(*luen.evidence, note))
    methods = (
        _cascade(target, m, tables),
        _setvalued(target, tables, m),
        _drift(target, geo, geo_err, fields, region, mu, mu_src, x0),
        _pinv(target, geo, geo_err, region),
        kal,
        luen,
        *_registered(target, scenario, is_file, kal),
    )
    designs: dict[str, Any] = {}
    if scenario is not None and is_file and scenario.sensors:
        methods, designs = _rank_by_bound(methods, scenario, region, reg0, src)
    sensor_check = None
    if check:
        if not is_file:
            raise InvalidArgumentError("check: needs a model file (its sensors and inputs)")
        if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
            raise InvalidArgumentError(f"`runs`: expected a positive integer, got {runs!r}")
        methods, sensor_check = _sensor_check(model, methods, region if region is not None else reg0, runs, progress)
    usable = sorted((mm for mm in methods if mm.usable), key=lambda mm: mm.rank)
    best = usable[0] if usable else None
    if best is None:
        verdict, msg = Verdict.NO_OBSERVER, f"{m.name}: no method of nlobs applies: " + "; ".join(
            f"{mm.method}: {mm.reason}" for mm in methods)
        cmp = None
    else:
        verdict, msg = Verdict.OK, ""
        sim = best.method if best.method in _SIMULATED and best.method != "cascade" else None
        cmp = f"nlobs simulate {target} --observer {sim},ekf,ukf" if sim and is_file else None
        if cmp and (not _same(best_region(best, region), reg0) or _design_box(best, region, reg0, src) is not None):
            cmp += f" {box_option(best_region(best, region))}"  # the region the recommended design is made on
    design, design_error = None, ""
    if best is not None and best.method in designs:
        design = designs[best.method]
    elif best is not None and scenario is not None:
        design, design_error, _ = _recommended_design(best, scenario, region, reg0, src)
    return AdviceReport(m.name, target, reg0 if isinstance(m, SymbolicModel) else None, src,
                        region if isinstance(m, SymbolicModel) else None, sing, methods,
                        None if best is None else best.method, cmp, verdict, msg, sensor_check, design, design_error)


#: The registry's methods this module analyses itself (the others are asked whether they apply).
_ANALYSED = frozenset({"drift", "pinv", "luenberger", "cascade", "ekf", "ukf", "setvalued", "gnss-ins"})


def _registered(target: str, scenario: Any, is_file: bool, kal: MethodAdvice | None = None) -> tuple[MethodAdvice, ...]:
    """Every other method of the registry, by its own :meth:`~nlobs.methods.base.Method.applies` (a new method
    appears in the advice without a line here)."""
    from nlobs.methods.registry import REGISTRY, get

    out = []
    pb: Any = None
    for e in REGISTRY:
        if e.name in _ANALYSED:
            continue
        title = f"{e.name} ({e.help})"
        if scenario is None:
            out.append(MethodAdvice(e.name, title, "no", "needs a model file"))
            continue
        if e.name in _LIKE_THE_FILTERS and kal is not None and kal.applicable == "no":
            out.append(MethodAdvice(e.name, title, "no", f"as the EKF/UKF: {kal.reason}"))
            continue
        try:
            pb = pb if pb is not None else problem(scenario)  # the file's problem, made once for every method
            why = get(e.name).applies(pb)
        except NlobsError as exc:
            why = str(exc)
        if why is not None:
            out.append(MethodAdvice(e.name, title, "no", why))
            continue
        cmd = f"nlobs simulate {target} --observer {e.name},ekf,ukf" if e.simulated and is_file else None
        out.append(MethodAdvice(e.name, title, "yes", "applies (by the method's own check)", (), {}, cmd, rank=20))
    return tuple(out)


#: Rank of a method certified under the file's sensors (ahead of every other; the smaller bound first).
CERTIFIED_RANK = -1000


def _rank_by_bound(methods: Sequence[MethodAdvice], scenario: Any, region: Box, reg0: Box,
                   src: str) -> tuple[tuple[MethodAdvice, ...], dict[str, Any]]:
    """With ``[sensors]``: the simulated methods whose certificate states an RMS bound under the file's sensors and
    noise (:mod:`nlobs.methods.sensor_design`) ranked ahead of every other, the smaller bound first; the others keep
    the theorems' order, with why their certificate does not survive the sensors in their evidence (``check``
    measures them under the sensors and ranks those that fail below the Kalman filters)."""
    ranked = []
    bounds: list[tuple[float, str]] = []
    designs: dict[str, Any] = {}
    for m in methods:
        if m.method not in _SIMULATED or not m.usable:
            ranked.append(m)
            continue
        design, error, fails = _recommended_design(m, scenario, region, reg0, src)
        if design is None:  # its command would fail: not printed, and the method not recommended
            if fails:  # the theorems' verdict stands; no command, since it would fail
                ranked.append(dataclasses.replace(m, command=None,
                                                  reason=f"{m.reason}; but its design fails on the region: {error}"))
            else:
                ranked.append(dataclasses.replace(m, evidence=(*m.evidence, f"no design for the file's sensors: {error}"))
                              if error else m)
            continue
        designs[m.method] = design
        bound = design.bound
        given = _design_box(m, region, reg0, src)
        pb = problem(scenario, box=given)
        value = (bound.rms_after(pb.settle) if bound is not None and bound.verified and design.usable
                 and design.verified else math.inf)
        if math.isfinite(value):  # a bound that counts the file's noise (drift's counts no process noise)
            bounds.append((value, m.method))
            tmax = "; ".join(f"{g.name}: T = {g.gap:.3g} ≤ T_max = {t:.3g}" for g, t in zip(bound.groups, bound.t_max))
            params = {k: v for k, v in design.parameters.items() if k in ("alpha", "tuning", "sampling")}
            command = m.command
            if given is not None:  # the command designs on the same region as the certificate
                if command and "box" not in m.parameters:  # a command built without the region: give it
                    command = f"{command} {box_option(given)}"
                params["box"] = _box_list(given)
            title = m.title
            if m.method == "luenberger":
                title = (f"Luenberger / Thau gain chosen for the file's sensors on "
                         f"{pb.region.describe()} ({design.parameters.get('sampling', '')})")
            ranked.append(dataclasses.replace(
                m, title=title, applicable="yes", parameters=params or m.parameters, command=command,
                reason=f"certified under the file's sensors ({design.theorem})",
                evidence=(*m.evidence, f"certified under the file's sensors: RMS ‖e‖ ≤ {value:.4g} after t = "
                          f"{pb.settle:g} ({tmax})")))
        else:
            why = next((h.reason for h in design.hypotheses if getattr(h, "holds", True) is False
                        and "sampled" in getattr(h, "name", "")), "") or "; ".join(design.warnings) or \
                "its certificate states no bound under sampled, noisy outputs"
            ranked.append(dataclasses.replace(m, evidence=(*m.evidence, f"no certificate under the file's sensors: {why}")))
    order = {name: i for i, (_, name) in enumerate(sorted(bounds))}
    out = tuple(dataclasses.replace(m, rank=CERTIFIED_RANK + order[m.method]) if m.method in order else m
                for m in ranked)
    return out, designs


def _design_box(best: MethodAdvice, region: Box, reg0: Box, src: str) -> Box | None:
    """The box the design of a method is made on when it is not the file's (``None``: the file's, or none used)."""
    from nlobs.methods.registry import get, names

    name = "ekf" if best.method == "ekf-ukf" else best.method
    if name not in names() or not get(name).uses_region:
        return None
    box = best_region(best, region)
    return None if _same(box, reg0) and src != "given" else box


def _recommended_design(best: MethodAdvice, scenario: Any, region: Box, reg0: Box,
                        src: str) -> tuple[Any, str, bool]:
    """The registry's design of the recommended method, on the region the advice recommends (or the file's): the
    design, or why not, and whether the design itself has no solution there (the method does not apply, an
    assumption fails, or it is infeasible: its command would fail)."""
    from nlobs.errors import AssumptionViolated, DesignInfeasible
    from nlobs.methods.registry import get, names

    name = "ekf" if best.method == "ekf-ukf" else best.method
    if name not in names():
        return None, "", False
    method = get(name)
    given = _design_box(best, region, reg0, src)
    try:
        pb = problem(scenario, box=given)
        why = method.applies(pb)
        if why is not None:
            return None, why, True
        return method.design(pb), "", False
    except (AssumptionViolated, DesignInfeasible, ModelError) as exc:
        return None, str(exc), True
    except NlobsError as exc:
        return None, str(exc), False


def best_region(advice: MethodAdvice, region: Box) -> Box:
    """The box a method's command uses (its ``parameters["box"]``, else ``region``)."""
    b = advice.parameters.get("box")
    return region if b is None else Box(np.array([v[0] for v in b]), np.array([v[1] for v in b]))
