"""The workflow of ``nlobs estimate``: observers on a logged run, and the files they leave.

:func:`estimate_log` runs :func:`nlobs.methods.estimation.estimate` and, with ``out``, writes (atomically)

* ``estimates_<observer>.csv`` per observer that ran: ``t`` and one column per state, and for a filter one
  ``sigma_<state>`` column per state (its standard deviation); smoothed, also ``<state>_smoothed`` and
  ``sigma_<state>_smoothed`` (the Rauch–Tung–Striebel smoother on the whole log);
* ``estimate.png``: the log's samples and each observer's ``ŷ = h(x̂, u)`` per output, and each observer's
  estimate per state (a filter's ±3σ shaded), labelled with the model's names and units;
* ``estimate.json``: the JSON report.
"""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path
from typing import Any

import numpy as np

from nlobs._io import atomic_write_json, atomic_write_text, jsonable, save_figure, with_schema
from nlobs.methods.estimation import ESTIMATE_JSON, EstimationReport, estimate, model_outputs
from nlobs.workflows._results import prepare_out

__all__ = ["ESTIMATE_JSON", "estimate_log", "estimates_csv", "estimate_figure"]


def estimates_csv(report: EstimationReport, name: str) -> str:
    """The CSV text of one observer's estimates: ``t``, the states, and a filter's ``sigma_<state>``.

    Parameters
    ----------
    report : EstimationReport
    name : str
        An observer that ran.

    Returns
    -------
    str

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from nlobs.methods.estimation import estimate
    >>> t = np.arange(0.0, 1.0 + 1e-9, 0.1)
    >>> log = Path(tempfile.mkdtemp()) / "log.csv"
    >>> _ = log.write_text("t,tau,y\\n" + "".join(f"{a:.1f},0,{0.1 * np.cos(3 * a):.6f}\\n" for a in t))
    >>> report = estimate("pendulum", log, observers=["luenberger"], x_hat0=[0.1, 0.0])
    >>> estimates_csv(report, "luenberger").splitlines()[0]
    't,theta,omega'
    """
    o = report.observers[name]
    if o.result is None:
        raise KeyError(name)
    states = list(report.states)
    cols = ["t", *states, *([f"sigma_{s}" for s in states] if o.sigma is not None else [])]
    data = [report.log.t[:, None], np.asarray(o.result.x_hat, dtype=float)]
    if o.sigma is not None:
        data.append(np.asarray(o.sigma, dtype=float))
    if o.smoothed is not None:
        cols += [f"{s}_smoothed" for s in states] + [f"sigma_{s}_smoothed" for s in states]
        data += [np.asarray(o.smoothed.x, dtype=float), np.asarray(o.smoothed.std, dtype=float)]
    table = np.hstack(data)
    buf = io.StringIO()
    buf.write(",".join(cols) + "\n")
    for row in table:
        buf.write(",".join("" if not np.isfinite(v) else repr(float(v)) for v in row) + "\n")
    return buf.getvalue()


def estimate_figure(report: EstimationReport) -> Any:
    """The outputs (samples and each observer's ``ŷ``) and the states (each observer's estimate, a filter's ±3σ).

    Parameters
    ----------
    report : EstimationReport

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from nlobs.methods.estimation import estimate
    >>> t = np.arange(0.0, 1.0 + 1e-9, 0.1)
    >>> log = Path(tempfile.mkdtemp()) / "log.csv"
    >>> _ = log.write_text("t,tau,y\\n" + "".join(f"{a:.1f},0,{0.1 * np.cos(3 * a):.6f}\\n" for a in t))
    >>> fig = estimate_figure(estimate("pendulum", log, observers=["luenberger"], x_hat0=[0.1, 0.0]))
    >>> [ax.get_ylabel() for ax in fig.axes]  # the shipped pendulum gives no units
    ['y', 'theta', 'omega']
    """
    from matplotlib.figure import Figure

    log, sc = report.log, report.scenario
    ran = {k: o for k, o in report.observers.items() if o.result is not None}
    p, n = len(log.outputs), len(report.states)
    fig = Figure(figsize=(9.0, 1.9 * (p + n) + 0.8), layout="constrained")
    axes = fig.subplots(p + n, 1, sharex=True, squeeze=False)[:, 0]
    h = model_outputs(sc)
    for j, name in enumerate(log.outputs):
        ax = axes[j]
        got = np.isfinite(log.y[:, j])
        ax.plot(log.t[got], log.y[got, j], ".", color="black", ms=2.5, label=f"{name}: {int(got.sum())} samples")
        for i, (k, o) in enumerate(ran.items()):
            with np.errstate(all="ignore"):
                yhat = np.asarray(h(log.t, np.asarray(o.result.x_hat, dtype=float), log.u), dtype=float)
            ax.plot(log.t, yhat.reshape(log.y.shape)[:, j], color=f"C{i}", lw=1.2, ls=("-", "--", ":", "-.")[i % 4],
                    label=f"ŷ, {k}")
        unit = sc.unit(name)
        ax.set_ylabel(f"{name}" + (f" [{unit}]" if unit else ""))
        ax.legend(loc="upper right", fontsize="small", ncols=2)
        ax.grid(True, alpha=0.3)
    for s, (state, unit) in enumerate(zip(report.states, report.units)):
        ax = axes[p + s]
        for i, (k, o) in enumerate(ran.items()):
            x = np.asarray(o.result.x_hat, dtype=float)[:, s]
            ax.plot(log.t, x, color=f"C{i}", lw=1.2, ls=("-", "--", ":", "-.")[i % 4], label=k)
            if o.sigma is not None:
                sd = np.asarray(o.sigma, dtype=float)[:, s]
                ax.fill_between(log.t, x - 3 * sd, x + 3 * sd, color=f"C{i}", alpha=0.15, lw=0,
                                label=f"{k} ± 3σ")
            if o.smoothed is not None:
                ax.plot(log.t, np.asarray(o.smoothed.x, dtype=float)[:, s], color=f"C{i}", lw=2.0, alpha=0.6,
                        label=f"{k} smoothed")
        ax.set_ylabel(f"{state}" + (f" [{unit}]" if unit else ""))
        ax.grid(True, alpha=0.3)
        if s == 0:
            ax.legend(loc="upper right", fontsize="small", ncols=2)
    axes[-1].set_xlabel(f"time [{sc.time_unit}]")
    skipped = [k for k, o in report.observers.items() if o.result is None]
    fig.suptitle(f"{report.model} on {Path(log.path).name}: samples and ŷ, then the estimates (no truth in a log)"
                 + (f"\nnot run: {', '.join(skipped)}" if skipped else ""), fontsize="medium")
    return fig


def estimate_log(model: Any, data: Any, *, out: Path | None = None, **options: Any) -> EstimationReport:
    """Run the observers on a logged run (:func:`nlobs.methods.estimation.estimate`) and write the files.

    Parameters
    ----------
    model : str, Path or Scenario
        The model file or a shipped model's name.
    data : str, Path or RecordedLog
        The log.
    out : Path, optional
        Folder for ``estimates_<observer>.csv``, ``estimate.png`` and ``estimate.json`` (module docstring).
    **options
        ``observers``, ``x_hat0``, ``dt``, ``design_options``, ``progress``, ``smooth`` of
        :func:`~nlobs.methods.estimation.estimate`.

    Returns
    -------
    EstimationReport
        With ``files`` the files written.

    Raises
    ------
    OutputError
        ``out`` cannot be written (checked before the runs).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> t = np.arange(0.0, 1.0 + 1e-9, 0.1)
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "log.csv").write_text("t,tau,y\\n" + "".join(f"{a:.1f},0,{0.1 * np.cos(3 * a):.6f}\\n"
    ...                                                          for a in t))
    >>> report = estimate_log("pendulum", folder / "log.csv", observers=["luenberger"], out=folder / "out")
    >>> sorted(f.name for f in report.files)
    ['estimate.json', 'estimate.png', 'estimates_luenberger.csv']
    """
    prepare_out(out)
    report = estimate(model, data, **options)
    if out is None:
        return report
    out = Path(out)
    files = []
    for name, o in report.observers.items():
        if o.result is not None:
            files.append(atomic_write_text(out / f"estimates_{name}.csv", estimates_csv(report, name)))
    if any(o.result is not None for o in report.observers.values()):
        files.append(save_figure(estimate_figure(report), out / "estimate.png"))
    report = dataclasses.replace(report, files=tuple(files) + (out / "estimate.json",))
    atomic_write_json(out / "estimate.json", with_schema(jsonable(report.to_dict())))
    return report
