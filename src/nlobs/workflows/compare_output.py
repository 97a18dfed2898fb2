"""The files of :func:`~nlobs.workflows.compare.compare_observers` in its ``out`` folder: the JSON report, three
figures, the trajectories.

* ``compare.json`` — :meth:`~nlobs.workflows.compare.ComparisonReport.to_dict`;
* ``states.png`` — run 0: every state, true (black) and each observer's estimate, and every output
  with its measurement samples (dots) over the true output;
* ``error_norms.png`` — the error of every observer state by state (``|x̂_i − x_i|`` in its unit), then
  ``‖x̂ − x‖``, on log axes: the median over the runs that did not diverge and the band between the 10th and 90th
  percentiles; observers whose runs diverged named with when and why;
* ``closed_loop.png`` — with a ``[controller]``: run 0 of the loop around each observer, states and inputs,
  beside the loop around the true state;
* ``consistency.png`` — the Kalman filters' NEES and NIS over the runs against the 95 % χ² band
  (:mod:`nlobs.simulate.consistency`), when a filter ran;
* ``bode.png`` — for a continuous linear model's Luenberger design, ``σ_max`` of its error dynamics' ``H(jω)``
  and ``G(jω)`` with γ and γn (:func:`nlobs.linear.frequency.bode_figure`);
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
from collections.abc import Mapping
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
    """Each observer's colour (:func:`_styles`'s)."""
    return {k: v["color"] for k, v in _styles(report).items()}


#: One dash pattern per observer (with its colour): curves that coincide (an EKF and a UKF on a mildly nonlinear
#: plant) stay visible, each drawn over the other with its own gaps.
_DASHES: tuple[Any, ...] = ((0, (6, 2)), (0, (2, 2)), (0, (8, 2, 2, 2)), (0, (4, 3)), (0, (1, 1)), (0, (10, 3, 1, 3)))


def _styles(report: ComparisonReport) -> dict[str, dict[str, Any]]:
    """Colour, dash pattern and width of each observer's curves (the widths fall so that later curves sit on top)."""
    names = list(report.observers)
    return {k: {"color": f"C{i % 10}", "ls": _DASHES[i % len(_DASHES)], "lw": 1.7 - 0.15 * (i % 4)}
            for i, k in enumerate(names)}


def _diverged_note(o: Any, unit: str) -> str | None:
    """``"ekf: 3 of 20 runs diverged (first at t = 1.2 s: non-finite estimate)"``, or ``None``."""
    d = o.diverged_runs
    if not d:
        return None
    first = min(d, key=lambda r: r.time if np.isfinite(r.time) else np.inf)
    when = f"t = {first.time:.3g} {unit}: " if np.isfinite(first.time) else ""
    total = o.run_rms.size or len(d)
    return f"{o.name}: {len(d)} of {total} runs diverged (first at {when}{first.reason})"


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
    styles = _styles(report)
    loop = report.closed_loop is not None  # each observer drives its own plant: each has its own truth
    for i, name in enumerate(model.states):
        ax = axes[i]
        ax.plot(t, x[:, i], label=f"true ({ran[0].name}'s loop)" if loop else "true", **_TRUE)
        for o in ran[1:] if loop else ():
            ax.plot(t, o.result.x[0, :, i], color=colors[o.name], lw=0.8, alpha=0.7,
                    label=f"true ({o.name}'s loop)" if i == 0 else None)
        for o in ran:
            xh = o.result.x_hat[0, :, i]
            xh = np.where(np.isfinite(xh), xh, np.nan)
            var = o.result.extras.get("P_diag")
            if var is not None:  # a filter: x̂ ± 3σ of its own covariance
                sd = 3.0 * np.sqrt(np.maximum(np.asarray(var)[0, :, i], 0.0))
                ax.fill_between(t, xh - sd, xh + sd, color=colors[o.name], alpha=0.12, lw=0,
                                label=f"{o.name} ± 3σ" if i == 0 else None)
            ax.plot(t, xh, label=o.name, **styles[o.name])
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
    if loop and "u" in ref.extras:
        u = np.asarray(ref.extras["u"])[0]
    elif model.m and sig is not None:
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
    fig.suptitle(f"{report.model}: run 0 of {report.runs}, true (black) and estimated (dashed) states, a filter's "
                 "± 3σ shaded; outputs with their samples", fontsize="medium")
    return fig


def closed_loop_figure(report: ComparisonReport, scenario: Scenario) -> Any | None:
    """Run 0 of each closed loop beside the reference loop (the law fed the true state): every state, then every
    input (``closed_loop.png``); ``None`` without a ``[controller]``."""
    from matplotlib.figure import Figure

    ref = report.reference
    if report.closed_loop is None or ref is None:
        return None
    ran = [o for o in _ran(report) if "u" in o.result.extras]
    model = scenario.model
    n, m = model.n, model.m
    fig = Figure(figsize=(9.0, 1.8 * (n + m) + 1.0), layout="constrained")
    axes = fig.subplots(n + m, 1, sharex=True, squeeze=False)[:, 0]
    styles = _styles(report)
    t = ref.t
    x_ref, u_ref = ref.x[0], np.asarray(ref.extras["u"])[0]
    series = [(name, i, x_ref[:, i], [o.result.x[0, :, i] for o in ran]) for i, name in enumerate(model.states)]
    series += [(name, n + j, u_ref[:, j], [np.asarray(o.result.extras["u"])[0, :, j] for o in ran])
               for j, name in enumerate(model.inputs)]
    for name, k, reference, loops in series:
        ax = axes[k]
        ax.plot(t, reference, label="true state fed back", **_TRUE)
        for o, v in zip(ran, loops):
            ax.plot(t, np.where(np.isfinite(v), v, np.nan), label=f"{o.name} fed back", **styles[o.name])
        lo, hi = np.nanmin(reference), np.nanmax(reference)
        pad = 0.75 * max(hi - lo, 1e-9) + 1e-9
        peak = max([float(np.nanmax(np.abs(v))) for v in loops if np.isfinite(v).any()] + [0.0])
        if peak > max(abs(lo), abs(hi)) + pad:  # peaking: the reference stays readable, the peak is named
            ax.set_title(f"{name}: peak |{name}| = {peak:.3g} (clipped in the plot)", fontsize="small", loc="left")
        ax.set_ylim(lo - pad, hi + pad)
        ax.set_ylabel(scenario.label(name))
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize="small", ncol=min(3, len(ran) + 1))
    axes[-1].set_xlabel(f"time [{report.time_unit}]")
    law = ", ".join(f"{i} = {e}" for i, e in zip(report.closed_loop["inputs"], report.closed_loop["law"]))
    fig.suptitle(f"{report.model}, closed loop {law}\nrun 0: states and inputs of the loop around each observer "
                 "beside the loop around the true state (black)", fontsize="medium")
    return fig


def error_figure(report: ComparisonReport) -> Any:
    """The error of every observer, state by state in its own unit (``|x̂_i − x_i|``), then ``‖x̂ − x‖`` with the
    certified bounds: the median over the runs that did not diverge and the band between their 10th and 90th
    percentiles, on log axes (the transient and the noise floor both readable); an observer whose runs diverged is
    named with when and why."""
    from matplotlib.figure import Figure

    n = len(report.states)
    extra = n > 1  # one state: its error is the norm
    fig = Figure(figsize=(9.0, 2.0 * (n + extra) + 1.2), layout="constrained")
    axes = fig.subplots(n + extra, 1, sharex=True, squeeze=False)[:, 0]
    last = len(axes) - 1
    colors, styles = _colors(report), _styles(report)
    notes = []
    for o in _ran(report):
        r = o.result
        with np.errstate(all="ignore"):
            e = np.abs(r.x_hat - r.x)
            en = np.linalg.norm(r.x_hat - r.x, axis=-1)
        ok = np.isfinite(en).all(axis=-1) & ~np.isin(np.arange(en.shape[0]), [d.run for d in o.diverged_runs])
        note = _diverged_note(o, report.time_unit)
        if note is not None:
            notes.append(note)
        if not ok.any():
            for ax in axes:  # every run diverged: named in the legend, no curve
                ax.plot([], [], label=f"{o.name}: every run diverged", **styles[o.name])
            continue
        for i, ax in enumerate(axes):
            data = e[ok][..., i] if i < n else en[ok]
            q10, q50, q90 = np.percentile(data, [10, 50, 90], axis=0)
            label = f"{o.name} (median of {int(ok.sum())} runs)" if i in (0, last) else None
            ax.semilogy(r.t, np.where(q50 > 0, q50, np.nan), label=label, **styles[o.name])
            ax.fill_between(r.t, np.where(q10 > 0, q10, np.nan), np.where(q90 > 0, q90, np.nan),
                            color=colors[o.name], alpha=0.12, lw=0)
        bound = _bound(o)
        if bound is not None:
            axes[last].hlines(bound, report.settle, r.t[-1], color=colors[o.name], ls="-", lw=1.0,
                           label=f"{o.name}: certified RMS bound {bound:.3g} (after the settling time)")
    for i, ax in enumerate(axes):
        ax.axvline(report.settle, color="grey", ls=":", lw=1.0,
                   label=f"settling time {report.settle:g} {report.time_unit}" if i == last else None)
        ax.grid(True, which="both", alpha=0.3)
    for i, name in enumerate(report.states):
        unit = report.units[i] if i < len(report.units) else ""
        axes[i].set_ylabel(f"|{name}̂ − {name}|" + (f" [{unit}]" if unit else ""), fontsize="small")
    units = [u for u in report.units if u]
    mixed = len(set(units)) > 1
    if extra:
        axes[last].set_ylabel("‖x̂ − x‖" + ("" if mixed or not units else f" [{units[0]}]"), fontsize="small")
    if mixed:
        axes[last].set_title("‖x̂ − x‖ mixes the units " + ", ".join(dict.fromkeys(units)) + " (the certificates bound "
                          "this norm)", fontsize="small", loc="left")
    if extra:
        axes[0].legend(loc="upper right", fontsize="x-small", ncol=2)
    axes[last].legend(loc="upper right", fontsize="x-small")
    axes[last].set_xlabel(f"time [{report.time_unit}]")
    title = f"{report.model}: estimation error per state (median over the runs; band: 10–90 %)"
    if notes:
        title += "\n" + "; ".join(notes)
    fig.suptitle(title, fontsize="medium")
    return fig


def consistency_figure(report: ComparisonReport) -> Any | None:
    """The Kalman filters' NEES and NIS over the runs, each divided by its degrees of freedom, with the 95 % χ²
    band; ``None`` when no observer records them."""
    from matplotlib.figure import Figure

    filters = {o.name: o.consistency for o in _ran(report) if o.consistency is not None and o.consistency.runs}
    if not filters:
        return None
    return consistency_plot(filters, title=f"{report.model}: filter consistency", time_unit=report.time_unit,
                            styles=_styles(report))


def consistency_plot(filters: Mapping[str, Any], *, title: str, time_unit: str,
                     styles: Mapping[str, Mapping[str, Any]] | None = None) -> Any:
    """NEES and NIS of each filter (a :class:`~nlobs.simulate.consistency.Consistency` by name) over time, each
    divided by its degrees of freedom, with the χ² band: ``consistency.png`` of ``nlobs simulate`` and the
    GNSS/INS demo's ``gnss_ins_consistency.png``.

    Parameters
    ----------
    filters : Mapping[str, Consistency]
        By the name shown in the legend.
    title : str
        The figure's title (the band's meaning is added).
    time_unit : str
        The unit of the time axis.
    styles : Mapping, optional
        Matplotlib line properties by name (default: the colour cycle).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 6.0), layout="constrained")
    ax_nees, ax_nis = fig.subplots(2, 1, sharex=True)
    styles = styles or {name: {"color": f"C{i}"} for i, name in enumerate(filters)}
    banded = False
    first = next(iter(filters.values()))
    for name, c in filters.items():
        if c.nees is not None:
            if not banded:
                ax_nees.axhspan(*c.nees_band, color="grey", alpha=0.2, lw=0,
                                label=f"{c.level:.0%} χ² band ({c.runs} run{'' if c.runs == 1 else 's'})")
                banded = True
            ax_nees.plot(c.t, c.nees, label=f"{name}: {c.nees_inside:.0%} inside", **styles[name])
        if c.nis.size:
            if c is first:
                ax_nis.fill_between(c.t_nis, c.nis_lo, c.nis_hi, color="grey", alpha=0.2, lw=0, step="mid",
                                    label=f"{c.level:.0%} χ² band")
            ax_nis.plot(c.t_nis, c.nis, marker="." if c.nis.size <= 100 else None, ms=3.0,
                        label=f"{name}: {c.nis_inside:.0%} inside", **styles[name])
    for ax, what in ((ax_nees, "NEES / n"), (ax_nis, "NIS / outputs")):
        ax.axhline(1.0, color="black", lw=0.8)
        ax.set_ylabel(what)
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(loc="upper right", fontsize="small")
    ax_nees.set_title("estimation error against the filter's covariance, averaged over the runs", fontsize="small",
                      loc="left")
    ax_nis.set_title("innovations at the samples against their predicted covariance", fontsize="small", loc="left")
    ax_nis.set_xlabel(f"time [{time_unit}]")
    fig.suptitle(f"{title}\n(inside the band about {first.level:.0%} of the time when the filter's covariance "
                 "describes its error)", fontsize="medium")
    return fig


def _linear_bode(report: ComparisonReport, scenario: Scenario) -> Any | None:
    """The frequency response of a continuous linear model's Luenberger error dynamics (``bode.png``): ``𝔄 − Kℭ``
    with ``𝔅_d = I`` as LMIs (14), (15) designed it, γ and γn of its certificate; ``None`` otherwise."""
    from nlobs.linear.frequency import bode_figure
    from nlobs.systems.linear import LinearSystem

    model = scenario.model
    o = report.observers.get("luenberger")
    if not isinstance(model, LinearSystem) or model.time.is_discrete or o is None or o.skipped is not None:
        return None
    cert = None if o.design is None else o.design.certificate
    if cert is None or getattr(cert, "gamma", None) is None or getattr(cert, "gain", None) is None:
        return None
    K = np.asarray(cert.gain, dtype=float)
    F = np.asarray(model.A, dtype=float) - K @ np.asarray(model.C, dtype=float)
    if float(np.max(np.linalg.eigvals(F).real)) >= 0.0:
        return None
    return bode_figure(F, np.eye(model.n), gamma=cert.gamma, KN=K, gamma_n=getattr(cert, "gamma_n", None),
                       time_unit=report.time_unit,
                       title=f"{report.model}: error dynamics of the Luenberger observer (B_d = I, N = I)")


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
    consistency = consistency_figure(report)
    if consistency is not None:
        put(out / "consistency.png", lambda p: save_figure(consistency, p))
    loop = closed_loop_figure(report, scenario)
    if loop is not None:
        put(out / "closed_loop.png", lambda p: save_figure(loop, p))
    bode = _linear_bode(report, scenario)
    if bode is not None:
        put(out / "bode.png", lambda p: save_figure(bode, p))
    for o in _ran(report):
        put(out / f"{o.name}.npz", lambda p, o=o: o.result.save(p))
    put(out / "trajectories.csv", lambda p: atomic_write_text(p, trajectories_csv(report, scenario)))
    data = report.to_dict()
    data["files"] = [str(f) for f in (*written, out / "compare.json")]
    put(out / "compare.json", lambda p: atomic_write_json(p, with_schema(jsonable(data))))
    return tuple(written)
