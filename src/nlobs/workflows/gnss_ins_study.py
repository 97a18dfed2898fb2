"""``nlobs simulate gnss-ins``: Monte Carlo flights of the GNSS/INS observer (24) of Grip, Saberi & Johansen.

:func:`gnss_ins_monte_carlo` runs :class:`~nlobs.navigation.montecarlo.GnssInsStudy` (the demo's
traffic pattern and sensors, :data:`~nlobs.workflows.demo.DEMO_NOISE`; random initial attitude errors
about random axes and position errors) through :func:`nlobs.simulate.monte_carlo`, in this process or
on Dask (``workers``: a local cluster; ``scheduler``: a running one; ``executor``: a client of your own),
and reports the fraction of flights whose attitude error falls below ``converge_deg`` for good, the
times to converge and the RMS errors over the last seconds. The paper proves observer (24) globally
exponentially stable (Theorems 1–3 with Lemma 1): the verdict is ``OK`` when every flight converged.

With ``out``: the chunk files and ``montecarlo.json`` of the engine in ``out/runs`` (a run started again
on the same folder resumes), and the figure ``out/gnss_ins_monte_carlo.png``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from nlobs._io import prepare_output_dir, save_figure
from nlobs._schema import INTEGER, NUMBER, STRING, Record, array, mapping, nullable
from nlobs.checks import VERDICT_JSON
from nlobs._validate import as_count
from nlobs.errors import InvalidArgumentError, OutputError
from nlobs.navigation.montecarlo import GnssInsStudy
from nlobs.simulate.executors import cluster
from nlobs.simulate.montecarlo import MonteCarloResult, monte_carlo
from nlobs.methods.gnss_ins import DEMO_NOISE
from nlobs.workflows.verdict import Verdict

__all__ = ["FIGURE", "GnssInsStudyReport", "RUNS_FOLDER", "gnss_ins_monte_carlo"]

#: The figure's file name in ``out``.
FIGURE = "gnss_ins_monte_carlo.png"
#: The engine's folder (``montecarlo.json``, ``chunks/``) in ``out``.
RUNS_FOLDER = "runs"


def _median(a: Any) -> float:
    v = np.asarray(a, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if v.size else math.nan


def _max(a: Any) -> float:
    v = np.asarray(a, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.max(v)) if v.size else math.nan


#: ``nlobs simulate gnss-ins``.
GNSS_INS_STUDY_JSON = Record("SimulateGnssIns", {
    "setup": Record("GnssInsStudySetup", {
        "flights": INTEGER, "duration_s": NUMBER, "seed": INTEGER, "flight_seed": INTEGER, "gains": STRING,
        "attitude_error_deg": NUMBER, "position_error_m": NUMBER, "imu_rate_hz": NUMBER, "gnss_rate_hz": NUMBER,
        "converge_deg": NUMBER, "tail_s": NUMBER}),
    "converged": INTEGER.about("flights whose attitude error converged below converge_deg"),
    "converged_fraction": NUMBER,
    "diverged": INTEGER,
    "statistics": mapping(NUMBER, "medians and extremes over the flights"),
    "executor": STRING, "workers": INTEGER, "batch": INTEGER, "chunk": INTEGER, "chunks": INTEGER,
    "resumed_chunks": INTEGER, "seconds": NUMBER,
    "out": nullable(STRING), "figure": nullable(STRING), "trajectories": array(STRING),
    "verdict": VERDICT_JSON, "message": STRING,
}, description="Monte Carlo flights of the GNSS/INS observer (24) of Grip, Saberi & Johansen.")


@dataclass(frozen=True, eq=False)
class GnssInsStudyReport:
    """What ``nlobs simulate gnss-ins`` prints: the set-up, the convergence of the flights, where it ran.

    Attributes
    ----------
    study : GnssInsStudy
        The recipe of every flight.
    result : MonteCarloResult
        The per-flight summaries (``final_attitude_error_deg``, ``converged``, ``converge_s``,
        ``rms_position_m``, ``rms_velocity_mps``, ``rms_attitude_deg``, ``diverged``) and the run's bookkeeping.
    figure : Path or None
        ``out/gnss_ins_monte_carlo.png`` (``None`` without ``out``).
    seconds : float
        Wall time of the workflow (a cluster's start included).
    verdict : Verdict
        ``OK`` when every flight converged (and none diverged), else ``FAILED``.
    message : str
        One line on what failed (empty when ``OK``).

    Examples
    --------
    Four flights of only 5 s with the paper's gains, from attitude errors up to 10°: two flights are not yet
    below 5° for good when the flight ends, and the report fails and says so (the last line of
    :meth:`summary`, where and how fast it ran, is left out here):

    >>> rep = gnss_ins_monte_carlo(flights=4, duration=5.0, gains="paper", attitude_error_deg=10.0, progress=False)
    >>> type(rep).__name__, rep.flights, rep.converged, rep.diverged, rep.verdict.value
    ('GnssInsStudyReport', 4, 2, 0, 'failed')
    >>> rep.message
    '2 of 4 flights did not converge below 5° within 5 s (worst final attitude error 6.74°)'
    >>> for line in rep.summary().splitlines()[1:4]:
    ...     print(line)
    converged (attitude error below 5° for good): 2/4 (50.0 %)
    time to converge: median 0.06 s, worst 0.12 s
    final attitude error: median 4.19°, worst 6.74°
    >>> d = rep.to_dict()
    >>> d["setup"]["gains"], d["setup"]["tail_s"], d["converged_fraction"], d["executor"], d["figure"]
    ('paper', 2.5, 0.5, 'in-process', None)
    """

    study: GnssInsStudy
    result: MonteCarloResult = field(repr=False)
    figure: Path | None
    seconds: float
    verdict: Verdict
    message: str

    # ---------------------------------------------------------------- numbers
    @property
    def flights(self) -> int:
        """Number of flights."""
        return self.result.runs

    @property
    def converged(self) -> int:
        """Flights whose attitude error fell below ``converge_deg`` for good."""
        return int(np.count_nonzero(self.result.summaries["converged"]))

    @property
    def diverged(self) -> int:
        """Flights with a non-finite estimate."""
        return int(np.count_nonzero(self.result.summaries["diverged"]))

    def statistics(self) -> dict[str, float]:
        """Medians and worst values over the flights (NaN where no flight gives a value)."""
        s = self.result.summaries
        conv = np.where(s["converged"], s["converge_s"], np.nan)
        return {"converge_s_median": _median(conv), "converge_s_max": _max(conv),
                "final_attitude_error_deg_median": _median(s["final_attitude_error_deg"]),
                "final_attitude_error_deg_max": _max(s["final_attitude_error_deg"]),
                "rms_position_m_median": _median(s["rms_position_m"]),
                "rms_velocity_mps_median": _median(s["rms_velocity_mps"]),
                "rms_attitude_deg_median": _median(s["rms_attitude_deg"])}

    def setup(self) -> str:
        """The set-up in one line."""
        st = self.study
        return (f"GNSS/INS observer (24), {st.gains} gains: {self.flights} flights × {st.duration:g} s of the traffic "
                f"pattern (flight seed {st.flight_seed}, noise seed {self.result.seed}), initial attitude errors up to "
                f"{st.attitude_error_deg:g}° about random axes, position errors {st.position_error_m:g} m; IMU "
                f"{st.imu_rate_hz:g} Hz, GNSS {st.gnss_rate_hz:g} Hz")

    def summary(self) -> str:
        """Set-up, converged fraction, median and worst time to converge, median RMS, where it ran, seconds."""
        st, r, x = self.study, self.result, self.statistics()
        lines = [self.setup(),
                 f"converged (attitude error below {st.converge_deg:g}° for good): {self.converged}/{self.flights} "
                 f"({100.0 * self.converged / self.flights:.1f} %)"
                 + (f", {self.diverged} diverged" if self.diverged else ""),
                 (f"time to converge: median {x['converge_s_median']:.2f} s, worst {x['converge_s_max']:.2f} s"
                  if self.converged else "time to converge: no flight converged"),
                 f"final attitude error: median {x['final_attitude_error_deg_median']:.3g}°, "
                 f"worst {x['final_attitude_error_deg_max']:.3g}°",
                 f"RMS over the last {st.tail:g} s (median over the flights): "
                 f"position {x['rms_position_m_median']:.3f} m, "
                 f"velocity {x['rms_velocity_mps_median']:.3f} m/s, attitude {x['rms_attitude_deg_median']:.3f}°",
                 f"ran {r.chunks} chunk{'s' if r.chunks != 1 else ''} (batch {r.batch}, chunk {r.chunk}) "
                 f"on {r.executor} "
                 f"({r.workers} worker{'s' if r.workers != 1 else ''})"
                 + (f", {r.resumed_chunks} resumed" if r.resumed_chunks else "") + f" in {self.seconds:.2f} s"]
        if r.out is not None:
            lines.append(f"wrote {r.out / 'montecarlo.json'} and {r.chunks} chunk file{'s' if r.chunks != 1 else ''}")
        if self.figure is not None:
            lines.append(f"wrote {self.figure}")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Plain values: the set-up, the counts, the statistics, where it ran, the files."""
        st, r = self.study, self.result
        return GNSS_INS_STUDY_JSON.emit({
            "setup": {"flights": self.flights, "duration_s": float(st.duration), "seed": r.seed,
                      "flight_seed": int(st.flight_seed), "gains": st.gains,
                      "attitude_error_deg": float(st.attitude_error_deg),
                      "position_error_m": float(st.position_error_m),
                      "imu_rate_hz": float(st.imu_rate_hz), "gnss_rate_hz": float(st.gnss_rate_hz),
                      "converge_deg": float(st.converge_deg), "tail_s": st.tail},
            "converged": self.converged,
            "converged_fraction": self.converged / self.flights,
            "diverged": self.diverged,
            "statistics": self.statistics(),
            "executor": r.executor,
            "workers": r.workers,
            "batch": r.batch,
            "chunk": r.chunk,
            "chunks": r.chunks,
            "resumed_chunks": r.resumed_chunks,
            "seconds": self.seconds,
            "out": None if r.out is None else str(r.out),
            "figure": None if self.figure is None else str(self.figure),
            "trajectories": list(r.trajectory_names),
            "verdict": self.verdict.value,
            "message": self.message,
        })


def _figure(report: GnssInsStudyReport, path: Path) -> Path:
    """Histograms of the final attitude error and of the times to converge, titled with the set-up."""
    from matplotlib.figure import Figure

    st, s = report.study, report.result.summaries
    fig = Figure(figsize=(11, 4.4))
    ax1, ax2 = fig.subplots(1, 2)
    final = np.asarray(s["final_attitude_error_deg"], dtype=float)
    final = final[np.isfinite(final)]
    if final.size:
        top = max(float(final.max()), st.converge_deg) * 1.05
        ax1.hist(final, bins=np.linspace(0.0, top, 41), color="tab:blue", edgecolor="white", linewidth=0.4)
    ax1.axvline(st.converge_deg, color="tab:red", lw=1.0, ls="--", label=f"threshold {st.converge_deg:g}°")
    ax1.set_xlabel("final attitude error [deg]")
    ax1.set_ylabel("flights")
    ax1.set_title(f"attitude error at t = {st.duration:g} s", fontsize=10)
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3)
    conv = np.asarray(s["converge_s"], dtype=float)[np.asarray(s["converged"], dtype=bool)]
    if conv.size:
        ax2.hist(conv, bins=np.linspace(0.0, float(st.duration), 41), color="tab:green", edgecolor="white",
                 linewidth=0.4)
    missing = report.flights - report.converged
    ax2.set_xlim(0.0, float(st.duration))
    ax2.set_xlabel(f"time to converge below {st.converge_deg:g}° for good [s]")
    ax2.set_ylabel("flights")
    ax2.set_title(f"{report.converged}/{report.flights} converged" + (f", {missing} did not" if missing else ""),
                  fontsize=10)
    ax2.grid(alpha=0.3)
    fig.suptitle(f"GNSS/INS observer (24), {st.gains} gains: {report.flights} flights × {st.duration:g} s, "
                 f"initial attitude errors up to {st.attitude_error_deg:g}°, "
                 f"position errors {st.position_error_m:g} m",
                 fontsize=11)
    fig.tight_layout()
    return save_figure(fig, path)


def gnss_ins_monte_carlo(*, flights: int = 1000, duration: float = 60.0, seed: int = 0, gains: str = "scheduled",
                         attitude_error_deg: float = 90.0, position_error_m: float = 0.0, batch: int | None = None,
                         chunk: int | None = None, executor: Any = None, workers: int | None = None,
                         scheduler: str | None = None, out: str | Path | None = None, trajectories: bool = False,
                         progress: bool | None = None, flight_seed: int = 0) -> GnssInsStudyReport:
    """Monte Carlo flights of observer (24) (Grip, Saberi & Johansen) from random initial errors (module docstring).

    Parameters
    ----------
    flights : int
        Number of flights (``>= 1``).
    duration : float
        Flight length [s].
    seed : int
        Seed of the sensor noise and the initial errors (:func:`nlobs.simulate.monte_carlo`'s ``seed``).
    gains : {"scheduled", "noise-optimal", "paper"}
        See :class:`~nlobs.navigation.montecarlo.GnssInsStudy`.
    attitude_error_deg : float
        Largest initial attitude error [deg] (``[0, 180]``).
    position_error_m : float
        Initial position error [m].
    batch, chunk : int, optional
        Flights per batch (they fix the numbers with ``seed``) and per task and file (they do not).
    executor : dask.distributed.Client or concurrent.futures.Executor, optional
        Where the chunks run (an existing client).
    workers : int, optional
        Start a local Dask cluster of this many processes for the call.
    scheduler : str, optional
        Address of a running Dask scheduler.
    out : path, optional
        Folder for the figure and, in ``out/runs``, the chunk files (resumable).
    trajectories : bool
        Also save every flight's ``x_hat`` and ``x`` (needs ``out``; 10 Hz, see ``trajectory_every``).
    progress : bool, optional
        A progress bar over finished flights (``None``: automatic).
    flight_seed : int
        Seed of the traffic pattern (the same flight in every run).

    Returns
    -------
    GnssInsStudyReport

    Raises
    ------
    InvalidArgumentError
        A bad value, more than one of ``executor``, ``workers`` and ``scheduler``, trajectories without
        ``out``, or a folder of another study.
    OutputError
        ``out`` cannot be written.
    DesignInfeasible
        The noise-optimal gain failed its certificate.

    Examples
    --------
    Four 30 s flights of the traffic pattern with the paper's gains, each from an attitude error up to 30°
    about a random axis: every one converges below 5° for good, without a diverged flight:

    >>> import numpy as np
    >>> rep = gnss_ins_monte_carlo(flights=4, duration=30.0, gains="paper", attitude_error_deg=30.0, progress=False)
    >>> rep.verdict.value, rep.message, rep.converged, rep.diverged
    ('ok', '', 4, 0)
    >>> s = rep.result.summaries
    >>> bool(np.all(s["final_attitude_error_deg"] < 5.0)), bool(np.all(s["converge_s"] < 30.0))
    (True, True)
    >>> round(rep.statistics()["final_attitude_error_deg_max"], 2), rep.result.chunks, rep.figure
    (2.31, 1, None)
    """
    t0 = time.perf_counter()
    runs = as_count("`flights`", flights, minimum=1)
    given = [name for name, v in (("executor", executor), ("workers", workers), ("scheduler", scheduler))
             if v is not None]
    if len(given) > 1:
        raise InvalidArgumentError(f"{' and '.join(f'`{g}`' for g in given)}: give one (where the flights run)")
    if batch is not None:
        as_count("`batch`", batch, minimum=1)
    if chunk is not None:
        as_count("`chunk`", chunk, minimum=1)
    as_count("`seed`", seed)
    if trajectories and out is None:
        raise InvalidArgumentError("`trajectories`: saving them needs an output folder (`out`)")
    study = GnssInsStudy(DEMO_NOISE, duration=duration, flight_seed=flight_seed, gains=gains,
                         attitude_error_deg=attitude_error_deg, position_error_m=position_error_m)
    study = study.solved()  # the noise-optimal gain solved once, here: the same bits on every worker
    folder = None if out is None else Path(out)
    if folder is not None:
        try:
            prepare_output_dir(folder)
        except OSError as exc:
            raise OutputError(f"`out` {folder}: {exc.strerror or exc}") from exc
    runs_folder = None if folder is None else folder / RUNS_FOLDER
    with cluster(workers=workers, scheduler=scheduler) as client:
        result = monte_carlo(study, runs, seed=seed, batch=batch, chunk=chunk,
                             executor=client if client is not None else executor, out=runs_folder,
                             trajectories=trajectories, progress=progress)
    s = result.summaries
    bad = ~np.asarray(s["converged"], dtype=bool) | np.asarray(s["diverged"], dtype=bool)
    n_bad = int(np.count_nonzero(bad))
    if n_bad:
        verdict = Verdict.FAILED
        message = (f"{n_bad} of {runs} flights did not converge below {study.converge_deg:g}° within "
                   f"{study.duration:g} s (worst final attitude error {_max(s['final_attitude_error_deg']):.3g}°"
                   + (f", {int(np.count_nonzero(s['diverged']))} diverged" if np.any(s["diverged"]) else "") + ")")
    else:
        verdict, message = Verdict.OK, ""
    report = GnssInsStudyReport(study, result, None, time.perf_counter() - t0, verdict, message)
    if folder is not None:
        try:
            fig = _figure(report, folder / FIGURE)
        except OSError as exc:
            raise OutputError(f"`out` {folder}: {exc.strerror or exc}") from exc
        report = GnssInsStudyReport(study, result, fig, time.perf_counter() - t0, verdict, message)
    return report
