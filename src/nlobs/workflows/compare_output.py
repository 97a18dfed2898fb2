"""The files of :func:`~nlobs.workflows.compare.compare_observers` in its ``out`` folder: the JSON report, three
figures, the trajectories.

* ``compare.json`` — :meth:`~nlobs.workflows.compare.ComparisonReport.to_dict`;
* ``states.png`` — run 0: every state, true (black) and each observer's estimate, and every output
  with its measurement samples (dots) over the true output;
* ``error_norms.png`` — ``‖x̂ − x‖`` of all observers on one log axis: the median over the runs and
  the band between the 10th and 90th percentiles;
* ``rms_boxplot.png`` — a box plot over the Monte Carlo runs of each observer's RMS ``‖e‖`` after the
  settling time, with the certified bound of a design under the sensors as a dashed mark (also a dashed line
  on ``error_norms.png``);
* ``<observer>.npz`` — each observer's :class:`~nlobs.simulate.result.SimulationResult`;
* ``trajectories.csv`` — run 0 on the saved grid: ``t``, the true states, the outputs held by the
  sensors, and each observer's estimates.

Axis labels carry the model's names and units (the ``units`` table of the model file). Every file
is written atomically.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from nlobs._io import atomic_write_json, atomic_write_text, jsonable, save_figure, with_schema
from nlobs.errors import OutputError
from nlobs.systems.scenario import Scenario

if TYPE_CHECKING:
    from nlobs.methods.comparison import ComparisonReport

__all__ = ["write_comparison"]

_TRUE = dict(color="black", lw=1.6)


def _ran(report: ComparisonReport) -> list[Any]:
    return [o for o in report.observers.values() if o.skipped is None and o.result is not None]


def _colors(report: ComparisonReport) -> dict[str, str]:
    names = list(report.observers)
    return {k: f"C{i % 10}" for i, k in enumerate(names)}


def states_figure(report: ComparisonReport, scenario: Scenario, plant: Any = None) -> Any:
    """Run 0: states (true and estimated) and outputs (true and sampled); ``plant`` the compiled model
    (compiled here when not given)."""
    from matplotlib.figure import Figure

    ran = _ran(report)
    model = scenario.model
    n, p = model.n, len(model.outputs)
    fig = Figure(figsize=(9.0, 1.8 * (n + p) + 1.0), layout="constrained")
    axes = fig.subplots(n + p, 1, sharex=True, squeeze=False)[:, 0]
    colors = _colors(report)
    ref = ran[0].result if ran else None
    if ref is None:
        return fig
    t = ref.t
    x = ref.x[0]
    for i, name in enumerate(model.states):
        ax = axes[i]
        ax.plot(t, x[:, i], label="true", **_TRUE)
        for o in ran:
            xh = o.result.x_hat[0, :, i]
            ax.plot(t, np.where(np.isfinite(xh), xh, np.nan), ls="--", lw=1.2, color=colors[o.name], label=o.name)
        ax.set_ylabel(scenario.label(name))
        if name in report.unobservable:
            ax.set_title(f"{name} is not observable from the outputs: every estimate of it runs open loop",
                         fontsize="small", loc="left")
        lo, hi = np.nanmin(x[:, i]), np.nanmax(x[:, i])
        pad = 0.5 * max(hi - lo, 1e-9) + 1e-9
        ax.set_ylim(lo - pad, hi + pad)  # estimates that run away do not flatten the truth
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize="small", ncol=min(4, len(ran) + 1))
    if plant is None:
        plant = model.compile() if hasattr(model, "compile") else model
    u = np.zeros((t.size, model.m))
    sig = scenario.input_signals
    if model.m and sig is not None:
        u = np.stack([np.asarray(sig(float(tk)), dtype=float).reshape(model.m) for tk in t])
    y_true = np.asarray(plant.output(0.0, x, u), dtype=float)
    for j, name in enumerate(model.outputs):
        ax = axes[n + j]
        ax.plot(t, y_true[:, j], label=f"true {name}", **_TRUE)
        fresh = ref.sampled[:, j]
        if not fresh.all():  # sampled sensors: the samples at the saved instants
            ax.plot(t[fresh], ref.y[0, fresh, j], ".", ms=2.5, color="C3", alpha=0.6, label="samples")
        ax.set_ylabel(scenario.label(name))
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel(f"time [{report.time_unit}]")
    fig.suptitle(f"{report.model}: run 0 of {report.runs}, true (black) and estimated (dashed) states; "
                 "outputs with their samples", fontsize="medium")
    return fig


def error_figure(report: ComparisonReport) -> Any:
    """``‖x̂ − x‖`` of every observer on one log axis (median and 10–90 % band over the runs)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 4.2), layout="constrained")
    ax = fig.subplots()
    colors = _colors(report)
    for o in _ran(report):
        r = o.result
        with np.errstate(all="ignore"):
            en = np.linalg.norm(r.x_hat - r.x, axis=-1)
        ok = np.isfinite(en).all(axis=-1)
        if not ok.any():
            continue
        q10, q50, q90 = np.percentile(en[ok], [10, 50, 90], axis=0)
        ax.semilogy(r.t, np.where(q50 > 0, q50, np.nan), color=colors[o.name], lw=1.4,
                    label=f"{o.name} (median of {int(ok.sum())} runs)")
        ax.fill_between(r.t, np.where(q10 > 0, q10, np.nan), np.where(q90 > 0, q90, np.nan), color=colors[o.name],
                        alpha=0.15, lw=0)
        bound = _bound(o)
        if bound is not None:
            ax.hlines(bound, report.settle, r.t[-1], color=colors[o.name], ls="--", lw=1.0,
                      label=f"{o.name}: certified RMS bound {bound:.3g} (after the settling time)")
    ax.axvline(report.settle, color="grey", ls=":", lw=1.0,
               label=f"settling time {report.settle:g} {report.time_unit}")
    units = {u for u in report.units if u}
    unit = f" [{units.pop()}]" if len(units) == 1 else ""
    ax.set_xlabel(f"time [{report.time_unit}]")
    ax.set_ylabel(f"‖x̂ − x‖{unit}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(f"{report.model}: estimation error of every observer (band: 10–90 % of the runs)", fontsize="medium")
    return fig


def _bound(outcome: Any) -> float | None:
    """The certified RMS bound of an observer's run under the sensors (``certificate.rms_bound``), if any."""
    cert = outcome.certificate or {}
    value = cert.get("rms_bound")
    return float(value) if value is not None and np.isfinite(value) else None


def boxplot_figure(report: ComparisonReport) -> Any:
    """Box plot over the runs of each observer's RMS ``‖e‖`` after the settling time."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.5, 4.2), layout="constrained")
    ax = fig.subplots()
    ran = [o for o in _ran(report) if np.isfinite(o.run_rms).any()]
    data = [o.run_rms[np.isfinite(o.run_rms)] for o in ran]
    if data:
        colors = _colors(report)
        parts = ax.boxplot(data, tick_labels=[f"{o.name}\n({len(o.diverged_runs)} diverged)" for o in ran],
                           patch_artist=True, medianprops={"color": "black"})
        for box, o in zip(parts["boxes"], ran):
            box.set_facecolor(colors[o.name])
            box.set_alpha(0.6)
        marked = False
        for i, o in enumerate(ran, start=1):
            bound = _bound(o)
            if bound is not None:
                ax.plot([i - 0.3, i + 0.3], [bound, bound], color="black", ls="--", lw=1.2,
                        label=None if marked else "certified bound on the RMS ‖e‖")
                marked = True
        if marked:
            ax.legend(loc="best", fontsize="small")
        if all(np.all(d > 0) for d in data):
            ax.set_yscale("log")
    units = {u for u in report.units if u}
    unit = f" [{units.pop()}]" if len(units) == 1 else ""
    ax.set_ylabel(f"RMS ‖x̂ − x‖ after {report.settle:g} {report.time_unit}{unit}")
    ax.grid(True, which="both", axis="y", alpha=0.3)
    ax.set_title(f"{report.model}: RMS error over {report.runs} Monte Carlo runs", fontsize="medium")
    return fig


def trajectories_csv(report: ComparisonReport, scenario: Scenario) -> str:
    """Run 0 on the saved grid: ``t``, true states, held outputs, each observer's estimates."""
    ran = _ran(report)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    model = scenario.model
    if not ran:
        w.writerow(["t"])
        return buf.getvalue()
    ref = ran[0].result
    head = ["t", *(f"x_{s}" for s in model.states), *(f"y_{s}" for s in model.outputs)]
    for o in ran:
        head += [f"{o.name}_{s}" for s in model.states]
    w.writerow(head)
    cols = [ref.t[:, None], ref.x[0], ref.y[0], *(o.result.x_hat[0] for o in ran)]
    table = np.concatenate(cols, axis=1)
    for row in table:
        w.writerow([repr(float(v)) if math.isfinite(v) else "nan" for v in row])
    return buf.getvalue()


def write_comparison(report: ComparisonReport, scenario: Scenario, out: Path, *,
                     plant: Any = None) -> tuple[Path, ...]:
    """Write the JSON, the figures, the ``.npz`` and the CSV into ``out`` (each atomically); their paths.

    ``plant`` is the compiled model the runs used (the output panel evaluates ``h`` on the truth).

    Parameters
    ----------
    report : ComparisonReport
        The comparison to write.
    scenario : Scenario
        The scenario it ran.
    out : Path
        Output directory.
    plant : optional
        The compiled model the runs used.

    Returns
    -------
    tuple of Path
        The files written, ``compare.json`` last.

    Raises
    ------
    OutputError
        A file cannot be written (a file that was there before is left as it was).
    """
    written: list[Path] = []

    def put(path: Path, write: Any) -> None:
        try:
            written.append(write(path))
        except OSError as exc:
            raise OutputError(f"{path}: {exc.strerror or exc}") from exc

    put(out / "states.png", lambda p: save_figure(states_figure(report, scenario, plant), p))
    put(out / "error_norms.png", lambda p: save_figure(error_figure(report), p))
    put(out / "rms_boxplot.png", lambda p: save_figure(boxplot_figure(report), p))
    for o in _ran(report):
        put(out / f"{o.name}.npz", lambda p, o=o: o.result.save(p))
    put(out / "trajectories.csv", lambda p: atomic_write_text(p, trajectories_csv(report, scenario)))
    data = report.to_dict()
    data["files"] = [str(f) for f in (*written, out / "compare.json")]
    put(out / "compare.json", lambda p: atomic_write_json(p, with_schema(jsonable(data))))
    return tuple(written)
