"""``nlobs simulate gnss-ins``: Monte Carlo flights of the GNSS/INS observer (24) of Grip, Saberi & Johansen.

Parse, call one workflow (:func:`nlobs.workflows.gnss_ins_monte_carlo`), print its report; exit 0 when
every flight converged, 1 when one did not, 2 on bad input (one line, :mod:`nlobs.cli.common`).
"""

# No ``from __future__ import annotations``: typer reads the annotations of every command's parameters when the
# app starts, and evaluated ones spare it compiling and evaluating each string again (twice per command).

from pathlib import Path
from typing import Annotated, Any

import typer

from nlobs.cli.common import EXIT_FAILURE, Progress_, console, emit_json, fail, finish, simulate_app
from nlobs.cli.choices import StudyGains, value
from nlobs.errors import DesignInfeasible, NlobsError, OutputError, StudyFailed


def _errors(exc: NlobsError) -> None:
    """The one-line message and exit status of a workflow error (never returns)."""
    if isinstance(exc, OutputError):
        fail(str(exc))
    if isinstance(exc, DesignInfeasible):
        fail(f"gnss-ins: {exc}", EXIT_FAILURE)
    if isinstance(exc, StudyFailed):
        fail(f"gnss-ins: {exc}", EXIT_FAILURE)
    fail(f"gnss-ins: {exc}")


def _show(report: Any, as_json: bool) -> None:
    if as_json:
        emit_json(report.to_dict())
    else:
        console().print(report.summary(), markup=False)
    finish(report, as_json)


@simulate_app.command("gnss-ins")
def simulate_gnss_ins_cmd(
    flights: Annotated[int, typer.Option(help="Monte Carlo flights (>= 1).")] = 1000,
    duration: Annotated[float, typer.Option(help="Flight length [s].")] = 60.0,
    seed: Annotated[int, typer.Option(help="Seed of the sensor noise and the initial errors (>= 0).")] = 0,
    gains: Annotated[StudyGains, typer.Option(
        help="'scheduled' (the noise-optimal K with Γ(t) scheduled from 0.5 I), 'noise-optimal' (Γ = 0.5 I) or "
             "'paper' (Sec. 5.2: the paper's K and Γ = diag(20, 0.2, 0.2)).")] = StudyGains.scheduled,
    attitude_error: Annotated[float, typer.Option(
        "--attitude-error", help="Largest initial attitude error [deg], about a random axis (0-180).")] = 90.0,
    position_error: Annotated[float, typer.Option(
        "--position-error", help="Initial position error [m], in a random direction.")] = 0.0,
    batch: Annotated[int | None, typer.Option(
        help="Flights computed together and drawn from one stream (with --seed, fixes the numbers).")] = None,
    chunk: Annotated[int | None, typer.Option(help="Flights per task and per file (any size: the same numbers).")
    ] = None,
    workers: Annotated[int | None, typer.Option(help="Run on a local Dask cluster of N worker processes.")] = None,
    scheduler: Annotated[str | None, typer.Option(help="Run on the Dask scheduler at ADDRESS (tcp://host:8786).")
    ] = None,
    out: Annotated[Path | None, typer.Option(
        help="Folder for the figure and, in DIR/runs, the chunk files (a run on the same folder resumes).")] = None,
    trajectories: Annotated[bool, typer.Option(
        "--trajectories", help="Also save every flight's estimate and truth at 10 Hz (needs --out).")] = False,
    progress: Progress_ = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print a machine-readable JSON report.")] = False,
) -> None:
    """Monte Carlo flights of observer (24) (Grip–Saberi–Johansen) from random initial errors: do all converge?"""
    from nlobs.workflows.gnss_ins_study import gnss_ins_monte_carlo

    try:
        report = gnss_ins_monte_carlo(flights=flights, duration=duration, seed=seed, gains=value(gains),
                                      attitude_error_deg=attitude_error, position_error_m=position_error,
                                      batch=batch, chunk=chunk, workers=workers, scheduler=scheduler, out=out,
                                      trajectories=trajectories, progress=progress)
    except NlobsError as exc:
        _errors(exc)
    _show(report, as_json)
