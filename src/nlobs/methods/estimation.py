"""Observers on a logged run: ``nlobs estimate``, a model file and a log.

An engineer's log (:func:`nlobs.systems.recorded.read_log`: the inputs applied and the sensors' samples, multi-rate,
on one time grid) is replayed to every chosen observer through :func:`nlobs.simulate.run_observer`, each designed
by its method for the model file exactly as ``nlobs simulate`` designs it (:func:`~nlobs.methods.comparison.
design_observer`, the same options), with the log's inputs as the problem's known input. There is no truth: what
is reported is what the data say, per observer

* the estimates at every row of the log (and, for a filter, the standard deviation of each state from its
  covariance);
* the **residuals** ``y − h(x̂, u)`` at the samples, per output: their RMS over the samples after the settling time
  (the file's ``[simulation] settle``, else a quarter of the log), with the estimate recorded at the sample
  instant (after a correcting observer's correction, so a filter's residual is smaller than its innovation);
* for the Kalman filters, the normalised innovation squared (NIS) at the samples against the 95 % χ² band
  (Bar-Shalom, Li & Kirubarajan, Sec. 5.4.2; :func:`~nlobs.simulate.consistency.error_consistency` without a
  NEES): the one consistency check a log without truth allows.

The initial estimate is the one given, else the file's ``[simulation] x0``, else zeros; the filters start from
``P0 = diag(initial_error_std²)`` of the file (else 10 % of ``max(1, |x̂0|)``). A continuous observer is integrated
with steps of at most ``dt`` (given, else the file's ``[simulation] dt``): each interval between two rows of the log
is split evenly, the inputs held over it, so a high-gain observer is not integrated at the log's rate.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._schema import INTEGER, NUMBER, STRING, Node, Record, array, mapping, nullable
from nlobs._typing import Array
from nlobs._validate import as_vector
from nlobs.checks import VERDICT_JSON, Verdict
from nlobs.errors import InvalidArgumentError, NlobsError, SimulationDiverged
from nlobs.methods.base import DESIGN_JSON, Design
from nlobs.methods.comparison import DEFAULT_OBSERVERS, OBSERVERS, STOCHASTIC, design_observer, method_options
from nlobs.methods.problem import problem
from nlobs.observers.smoother import smooth_run
from nlobs.simulate.consistency import CONSISTENCY_JSON, Consistency, error_consistency
from nlobs.simulate.replay import run_observer
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.signals import SampledSignal
from nlobs.systems.modelfile import load_scenario
from nlobs.systems.recorded import RecordedLog, read_log
from nlobs.systems.scenario import Scenario
from nlobs.systems.timebase import Discrete

__all__ = ["ESTIMATE_JSON", "EstimateOutcome", "EstimationReport", "estimate", "model_outputs"]

#: One observer's part of ``nlobs estimate`` (JSON).
ESTIMATE_OUTCOME_JSON = Record("EstimateOutcome", {
    "skipped": nullable(STRING, "why it does not apply (the assumption or design that failed)"),
    "description": STRING,
    "design": nullable(DESIGN_JSON),
    "diverged": nullable(STRING, "why the run stopped (its estimate became non-finite)"),
    "residual_rms": nullable(array(NUMBER), "per output, RMS of y − h(x̂, u) at its samples after the settling time"),
    "residual_rms_all": nullable(array(NUMBER), "the same over the whole log"),
    "final_estimate": nullable(array(NUMBER)),
    "final_std": nullable(array(NUMBER), "a filter's standard deviation of each state at the end"),
    "consistency": nullable(CONSISTENCY_JSON, "a filter's NIS at the samples (no truth: no NEES)"),
    "cost_per_step_us": NUMBER,
    "smoothed": Record("Smoothed", {
        "residual_rms": array(NUMBER, "per output, RMS of y − h(x̂_s, u) at its samples after the settling time"),
        "residual_rms_all": array(NUMBER),
        "final_estimate": array(NUMBER),
        "final_std": array(NUMBER),
        "method": STRING.about("extended or unscented Rauch–Tung–Striebel"),
    }).about("with smoothing: the Rauch–Tung–Striebel smoother of the filter on the whole log"),
}, optional={"smoothed"})

#: The JSON report of ``nlobs estimate``.
ESTIMATE_JSON = Record("Estimate", {
    "model": STRING,
    "data": STRING.about("the log"),
    "states": array(STRING),
    "units": array(STRING),
    "outputs": array(STRING),
    "rows": INTEGER,
    "start": NUMBER,
    "end": NUMBER,
    "settle": NUMBER.about("the time after which the residuals' RMS is taken"),
    "samples": mapping(INTEGER, "per output, the samples in the log"),
    "x_hat0": array(NUMBER),
    "observers": mapping(ESTIMATE_OUTCOME_JSON, "per observer, in the order asked for"),
    "files": array(STRING),
    "verdict": VERDICT_JSON,
    "message": STRING,
}, description="Observers replayed on a logged run of a plant: the residuals at the samples, a filter's NIS.")


@dataclass(frozen=True, eq=False)
class EstimateOutcome:
    """One observer on the log.

    Attributes
    ----------
    name, description : str
    skipped : str or None
        Why it was not run.
    design : Design or None
    result : SimulationResult or None
        Its estimates at every row (``x`` is None: no truth).
    diverged : str or None
        Why the run stopped, when it did.
    residual_rms, residual_rms_all : tuple of float
        Per output, after the settling time and over the whole log.
    sigma : ndarray or None
        A filter's standard deviations, ``(K, n)``.
    consistency : Consistency or None
        A filter's NIS at the samples.
    smoothed : Smoothed or None
        With smoothing, a filter's Rauch–Tung–Striebel smoother on the whole log, at the log's rows
        (:func:`nlobs.observers.smoother.rts_smooth`).
    smoothed_residual_rms, smoothed_residual_rms_all : tuple of float
        Its residuals per output, after the settling time and over the whole log.

    Examples
    --------
    A 1 s log of the shipped pendulum's angle at 10 Hz (no torque), replayed to its Luenberger observer:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> t = np.arange(0.0, 1.0 + 1e-9, 0.1)
    >>> log = Path(tempfile.mkdtemp()) / "log.csv"
    >>> _ = log.write_text("t,tau,y\\n" + "".join(f"{a:.1f},0,{0.1 * np.cos(3 * a):.6f}\\n" for a in t))
    >>> report = estimate("pendulum", log, observers=["luenberger", "ekf"], x_hat0=[0.1, 0.0])
    >>> luenberger = report.observers["luenberger"]
    >>> luenberger.result.x_hat.shape, len(luenberger.residual_rms), luenberger.sigma is None
    ((11, 2), 1, True)
    >>> report.observers["ekf"].skipped  # the pendulum's file has no [sensors]: no noise for a filter
    'a Kalman filter needs sampled, noisy measurements: add [sensors] to the model file, or give a rate and a noise std'
    """

    name: str
    description: str = ""
    skipped: str | None = None
    design: Design | None = None
    result: SimulationResult | None = None
    diverged: str | None = None
    residual_rms: tuple[float, ...] = ()
    residual_rms_all: tuple[float, ...] = ()
    sigma: Array | None = None
    consistency: Consistency | None = None
    smoothed: Any = None
    smoothed_residual_rms: tuple[float, ...] = ()
    smoothed_residual_rms_all: tuple[float, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        res = self.result
        ran = res is not None
        sm = self.smoothed
        return ESTIMATE_OUTCOME_JSON.emit({
            "skipped": self.skipped, "description": self.description,
            "design": None if self.design is None else self.design.to_dict(),
            "diverged": self.diverged,
            "residual_rms": list(self.residual_rms) if ran else None,
            "residual_rms_all": list(self.residual_rms_all) if ran else None,
            "final_estimate": None if res is None else [float(v) for v in res.x_hat[-1]],
            "final_std": None if self.sigma is None else [float(v) for v in self.sigma[-1]],
            "consistency": None if self.consistency is None else self.consistency.to_dict(),
            "cost_per_step_us": float(res.info.get("cost_per_step_us", math.nan)) if ran else None,
            **({} if sm is None else {"smoothed": {
                "residual_rms": list(self.smoothed_residual_rms),
                "residual_rms_all": list(self.smoothed_residual_rms_all),
                "final_estimate": [float(v) for v in sm.x[-1]], "final_std": [float(v) for v in sm.std[-1]],
                "method": sm.method}}),
        })


@dataclass(frozen=True, eq=False)
class EstimationReport:
    """What ``nlobs estimate`` reports (``to_dict()`` is its JSON report).

    Attributes
    ----------
    model : str
    log : RecordedLog
    scenario : Scenario
    states, units : tuple of str
    settle : float
    x_hat0 : ndarray
    observers : Mapping[str, EstimateOutcome]
    files : tuple of Path
    verdict : Verdict
        ``OK`` when an observer ran to the end; ``NO_OBSERVER`` when none applies; ``FAILED`` when every one that
        ran diverged.
    message : str

    Examples
    --------
    A 1 s log of the shipped pendulum's angle at 10 Hz (no torque), replayed to its Luenberger observer:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> t = np.arange(0.0, 1.0 + 1e-9, 0.1)
    >>> log = Path(tempfile.mkdtemp()) / "log.csv"
    >>> _ = log.write_text("t,tau,y\\n" + "".join(f"{a:.1f},0,{0.1 * np.cos(3 * a):.6f}\\n" for a in t))
    >>> report = estimate("pendulum", log, observers=["luenberger", "ekf"], x_hat0=[0.1, 0.0])
    >>> report.verdict.value, report.log.samples, report.to_dict()["observers"]["luenberger"]["skipped"] is None
    ('ok', {'y': 11}, True)
    >>> report.table()[1]
    ['observer', 'RMS y−ŷ y', 'NIS in band', 'µs/step', 'note']
    """

    model: str
    log: RecordedLog
    scenario: Scenario
    states: tuple[str, ...]
    units: tuple[str, ...]
    settle: float
    x_hat0: Array
    observers: Mapping[str, EstimateOutcome]
    files: tuple[Path, ...] = ()
    verdict: Verdict = Verdict.OK
    message: str = ""

    def to_dict(self) -> dict[str, Any]:
        log = self.log
        return ESTIMATE_JSON.emit({
            "model": self.model, "data": log.path, "states": list(self.states), "units": list(self.units),
            "outputs": list(log.outputs), "rows": int(log.t.shape[0]), "start": float(log.t[0]),
            "end": float(log.t[-1]), "settle": float(self.settle), "samples": log.samples,
            "x_hat0": [float(v) for v in self.x_hat0],
            "observers": {k: v.to_dict() for k, v in self.observers.items()},
            "files": [str(f) for f in self.files], "verdict": self.verdict.value, "message": self.message,
        })

    def table(self) -> tuple[str, list[str], list[list[str]]]:
        """Title, column heads and rows of the table the command prints."""
        heads = ["observer", *(f"RMS y−ŷ {o}" for o in self.log.outputs), "NIS in band", "µs/step", "note"]
        smoothed = any(o.smoothed is not None for o in self.observers.values())
        rows = []
        for name, o in self.observers.items():
            if o.result is None:
                rows.append([name, *(["—"] * (len(self.log.outputs) + 2)), o.skipped or o.diverged or ""])
                continue
            c = None if o.consistency is None else o.consistency.to_dict()
            nis = "—" if c is None or c["nis_inside"] is None else f"{c['nis_inside']:.0%}"
            note = o.diverged or ""
            if smoothed and o.smoothed is not None:
                note = "smoothed: RMS y−ŷ " + ", ".join(f"{v:.4g}" for v in o.smoothed_residual_rms)
            rows.append([name, *(f"{v:.4g}" for v in o.residual_rms), nis,
                         f"{o.result.info.get('cost_per_step_us', math.nan):.3g}", note])
        log = self.log
        title = (f"{self.model} on {Path(log.path).name}: {log.t.shape[0]} rows, t ∈ [{log.t[0]:g}, {log.t[-1]:g}], "
                 "samples " + ", ".join(f"{k} {v}" for k, v in log.samples.items())
                 + f"; residuals after t = {self.settle:g}")
        return title, heads, rows


def model_outputs(scenario: Scenario) -> Any:
    """``h(t, x, u)`` of the file's model, batched over rows (``x`` ``(K, n)``, ``u`` ``(K, m)``).

    Parameters
    ----------
    scenario : Scenario
        The model file.

    Returns
    -------
    callable

    Examples
    --------
    >>> import numpy as np
    >>> from nlobs.systems.modelfile import load_scenario
    >>> h = model_outputs(load_scenario("pendulum"))
    >>> np.asarray(h(np.zeros(2), np.array([[0.1, 0.0], [0.2, 1.0]]), np.zeros((2, 1)))).ravel().tolist()
    [0.1, 0.2]
    """
    model = scenario.model
    compiled = model.compile() if hasattr(model, "compile") else model
    return compiled.output


def _residuals(h: Any, log: RecordedLog, x_hat: Array, settle: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    with np.errstate(all="ignore"):
        yhat = np.asarray(h(log.t, x_hat, log.u), dtype=float).reshape(log.y.shape)
    r = log.y - yhat
    late = log.t >= settle

    def rms(mask: Array) -> tuple[float, ...]:
        out = []
        for j in range(r.shape[1]):
            v = r[mask, j]
            v = v[np.isfinite(v)]
            out.append(float(np.sqrt(np.mean(v**2))) if v.size else math.nan)
        return tuple(out)

    return rms(late), rms(np.ones_like(late))


def _fine_grid(t: Array, dt: float | None) -> tuple[Array, Array]:
    """The integration grid: every interval of ``t`` split evenly into steps of at most ``dt``; and where the rows
    of ``t`` are in it."""
    if dt is None or not dt > 0 or t.shape[0] < 2:
        return t, np.arange(t.shape[0])
    gaps = np.diff(t)
    parts = np.maximum(1, np.ceil(gaps / dt * (1 - 1e-12))).astype(np.int64)
    if int(parts.sum()) > 50_000_000:
        raise InvalidArgumentError(f"`dt`: {dt:g} s splits the log into {int(parts.sum()):,} steps; give a longer one")
    pieces = [t[k] + gaps[k] * np.arange(parts[k]) / parts[k] for k in range(gaps.size)]
    grid = np.concatenate([*pieces, t[-1:]])
    return grid, np.concatenate([[0], np.cumsum(parts)])


def _smoothed_at(sm: Any, at: Array) -> Any:
    """A smoother's output on the integration grid thinned to the log's rows (``t``, ``x``, ``P``)."""
    return _Thinned(sm.t[at], sm.x[..., at, :], sm.P[..., at, :, :], sm.method)


@dataclasses.dataclass(frozen=True)
class _Thinned:
    """A smoother's estimate at the log's rows.

    Parameters
    ----------
    t : ndarray, shape (K,)
    x : ndarray, shape (K, n)
    P : ndarray, shape (K, n, n)
    method : str
    """

    t: Array
    x: Array
    P: Array
    method: str

    @property
    def std(self) -> Array:
        return np.sqrt(np.maximum(np.diagonal(self.P, axis1=-2, axis2=-1), 0.0))


def _at_rows(res: SimulationResult, at: Array, t: Array) -> SimulationResult:
    """A result on the integration grid thinned to the log's rows."""

    if at.shape[0] == res.t.shape[0]:
        return res
    extras = {k: np.asarray(v)[at] for k, v in res.extras.items()}
    return dataclasses.replace(res, t=t, x_hat=np.asarray(res.x_hat)[at], extras=extras)


def estimate(model: str | Path | Scenario, data: str | Path | RecordedLog, *, observers: Sequence[str] | None = None,
             x_hat0: ArrayLike | None = None, dt: float | None = None,
             design_options: Mapping[str, Mapping[str, Any]] | None = None,
             progress: bool | None = None, smooth: bool = False) -> EstimationReport:
    """Run the chosen observers on a logged run of the model (module docstring).

    Parameters
    ----------
    model : str, Path or Scenario
        A model file or a shipped model's name (its ``[sensors]`` give the filters their noise, its
        ``[simulation]`` the defaults of ``x_hat0``, ``P0`` and the settling time).
    data : str, Path or RecordedLog
        The log (:func:`~nlobs.systems.recorded.read_log`).
    observers : sequence of str, optional
        Among :data:`~nlobs.methods.comparison.OBSERVERS`; default those run unless named otherwise
        (:data:`~nlobs.methods.comparison.DEFAULT_OBSERVERS`: all but the particle filter and moving-horizon
        estimation).
    x_hat0 : array_like, optional
        The initial estimate (default the file's ``[simulation] x0``, else zeros).
    dt : float, optional
        The longest integration step of a continuous observer (default the file's ``[simulation] dt``; the rows
        of the log when it has none).
    design_options : Mapping, optional
        Per method, design options (as ``nlobs simulate``'s ``design_options``).
    progress : bool, optional
        A progress bar per observer on a terminal.
    smooth : bool
        Also run the Rauch–Tung–Striebel smoother of each Kalman filter (EKF, UKF) on the whole log (Rauch, Tung &
        Striebel 1965; Särkkä 2008 for the UKF): the estimate at each row given every sample, before and after.

    Returns
    -------
    EstimationReport

    Raises
    ------
    ModelFileError, SignalFileError, UnknownNameError
        The model file or the log is not valid (one line naming the file and the line).
    InvalidArgumentError
        An unknown observer or option, or an ``x_hat0`` of the wrong size.

    Examples
    --------
    A log of the shipped pendulum's angle sampled at 20 Hz (no torque applied), replayed to its Luenberger
    observer and the EKF:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> t = np.arange(0.0, 5.0 + 1e-9, 0.05)
    >>> theta = 0.3 * np.exp(-0.1 * t) * np.cos(3.1 * t)  # a logged angle
    >>> log = Path(tempfile.mkdtemp()) / "log.csv"
    >>> _ = log.write_text("t,tau,y\\n" + "".join(f"{a:.2f},0,{b:.6f}\\n" for a, b in zip(t, theta)))
    >>> report = estimate("pendulum", log, observers=["luenberger", "ekf"], x_hat0=[0.0, 0.0])
    >>> report.log.samples, list(report.observers)
    ({'y': 101}, ['luenberger', 'ekf'])
    >>> all(max(o.residual_rms) < 0.05 for o in report.observers.values() if o.result is not None)
    True
    """
    scenario = model if isinstance(model, Scenario) else load_scenario(model)
    m = scenario.model
    chosen = list(DEFAULT_OBSERVERS if observers is None else observers)
    unknown = [c for c in chosen if c not in OBSERVERS]
    if unknown:
        raise InvalidArgumentError(f"`observers`: {unknown[0]!r} is not an observer nlobs designs; one of: "
                                   f"{', '.join(OBSERVERS)}")
    log = data if isinstance(data, RecordedLog) else read_log(data, inputs=m.inputs, outputs=m.outputs)
    if log.inputs != tuple(m.inputs) or log.outputs != tuple(m.outputs):
        raise InvalidArgumentError("`data`: a log read for another model's inputs and outputs")
    d = scenario.defaults
    x0 = d.x0 if d.x0 is not None else np.zeros(m.n)
    xh = as_vector("`x_hat0`", x_hat0, m.n) if x_hat0 is not None else np.asarray(x0, dtype=float)
    std = (np.broadcast_to(np.asarray(d.initial_error_std, dtype=float).reshape(-1), (m.n,))
           if d.initial_error_std is not None else 0.1 * np.maximum(1.0, np.abs(xh)))
    u = SampledSignal(log.t, log.u) if m.m else None
    pb = problem(scenario, duration=float(log.t[-1]), u=u, u_source=f"the inputs of {Path(log.path).name}")
    settle = float(d.settle) if d.settle is not None else float(log.t[0] + (log.t[-1] - log.t[0]) / 4)
    options = method_options(chosen, None, None, design_options)
    step = dt if dt is not None else d.dt
    rows = log.y_rows
    h = model_outputs(scenario)
    outcomes: dict[str, EstimateOutcome] = {}
    for name in chosen:
        opts = {**options[name], **({"p0_std": std} if name in STOCHASTIC and "p0_std" not in options[name]
                                    else {})}
        design = design_observer(name, pb, opts)
        if isinstance(design, str):
            outcomes[name] = EstimateOutcome(name, skipped=design)
            continue
        obs = design.observer
        smoothing = smooth and hasattr(obs, "record_covariance")
        if smoothing:
            obs = dataclasses.replace(obs, record_covariance=True)
        grid, at_rows = _fine_grid(log.t, None if isinstance(getattr(obs, "time", None), Discrete) else step)
        u_grid = log.u[np.searchsorted(log.t, grid, side="right") - 1] if m.m else None
        try:
            fine = run_observer(obs, grid, x_hat0=xh, u=u_grid, y=log.y[rows], y_times=log.t[rows],
                                sampled=np.isfinite(log.y[rows]), states=m.states, outputs=m.outputs,
                                progress=progress)
            smoothed = smooth_run(obs, fine, u_grid) if smoothing else None
            res = _at_rows(fine, at_rows, log.t)
            if "P" in res.extras:
                res = dataclasses.replace(res, extras={k: v for k, v in res.extras.items() if k != "P"})
        except (SimulationDiverged, InvalidArgumentError) as exc:
            if isinstance(exc, InvalidArgumentError) and not smoothing:
                raise
            outcomes[name] = EstimateOutcome(name, design.description, design=design, diverged=str(exc))
            continue
        rms, rms_all = _residuals(h, log, np.asarray(res.x_hat, dtype=float), settle)
        sigma = None
        if "P_diag" in res.extras:
            sigma = np.sqrt(np.maximum(np.asarray(res.extras["P_diag"], dtype=float), 0.0))
        cons = None
        if "nis" in res.extras:
            cons = error_consistency(log.t, np.zeros((log.t.shape[0], m.n)), None, res.extras["nis"],
                                     np.isfinite(log.y), log.y)
        extra: dict[str, Any] = {}
        if smoothed is not None:
            sm = _smoothed_at(smoothed, at_rows)
            s_rms, s_all = _residuals(h, log, sm.x, settle)
            extra = {"smoothed": sm, "smoothed_residual_rms": s_rms, "smoothed_residual_rms_all": s_all}
        outcomes[name] = EstimateOutcome(name, design.description, design=design, result=res, residual_rms=rms,
                                         residual_rms_all=rms_all, sigma=sigma, consistency=cons, **extra)
    ran = [o for o in outcomes.values() if o.result is not None]
    if not ran and all(o.skipped for o in outcomes.values()):
        verdict, msg = Verdict.NO_OBSERVER, "none of the observers applies: " + "; ".join(
            f"{k}: {o.skipped}" for k, o in outcomes.items())
    elif not ran:
        verdict, msg = Verdict.FAILED, "every observer that ran diverged: " + "; ".join(
            f"{k}: {o.diverged}" for k, o in outcomes.items() if o.diverged)
    else:
        verdict, msg = Verdict.OK, ""
    units = tuple(scenario.unit(s) for s in m.states)
    return EstimationReport(m.name, log, scenario, tuple(m.states), units, settle,
                            xh, outcomes, verdict=verdict, message=msg)
