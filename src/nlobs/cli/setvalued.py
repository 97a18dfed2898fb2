"""``nlobs design setvalued`` and ``nlobs simulate setvalued``: the set-valued observer of Khajenejad & Yong.

Parse, call one workflow (:mod:`nlobs.workflows.setvalued`), print its report; the exit status follows
the report's verdict (3 when no stable observer of the structure (10)-(15) exists, 1 when the certified
balls missed the truth) or the error (:mod:`nlobs.cli.common`).
"""

# No ``from __future__ import annotations``: typer reads the annotations of every command's parameters when the
# app starts, and evaluated ones spare it compiling and evaluating each string again (twice per command).

from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import typer

from nlobs.cli.common import (
    complete_model,
    EXIT_FAILURE,
    Progress_,
    console,
    design_app,
    emit_json,
    fail,
    finish,
    simulate_app,
)
from nlobs.errors import CertificateError, DesignInfeasible, ModelFileError, NlobsError, OutputError, StudyFailed


class Objective(str, Enum):
    radius = "radius"
    hinf = "hinf"


class UnknownInput(str, Enum):
    bounded = "bounded"
    growing = "growing"


def _errors(model: str, exc: NlobsError) -> None:
    """The one-line message and exit status of a workflow error (never returns)."""
    if isinstance(exc, ModelFileError):
        fail(str(exc))
    if isinstance(exc, DesignInfeasible):
        fail(f"{model}: design infeasible: {exc}", EXIT_FAILURE)
    if isinstance(exc, CertificateError):
        fail(f"{model}: the solver's answer failed the independent verification: {exc}", EXIT_FAILURE)
    if isinstance(exc, StudyFailed):
        fail(f"{model}: {exc}", EXIT_FAILURE)
    if isinstance(exc, OutputError):
        fail(str(exc))
    fail(f"{model}: {exc}")


def _show(report: Any, as_json: bool) -> None:
    if as_json:
        emit_json(report.to_dict())
    else:
        console().print(report.summary(), markup=False)
    finish(report, as_json)


@design_app.command("setvalued")
def design_setvalued_cmd(
    model: Annotated[str, typer.Argument(
        metavar="MODEL", autocompletion=complete_model, help="A model file with unknown inputs (.toml), or a shipped model name.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print a machine-readable JSON report.")] = False,
    objective: Annotated[Objective, typer.Option(help="radius: smallest steady radius bound; hinf: ℓ2 gain ρ.")]
    = Objective.radius,
    samples: Annotated[int, typer.Option(min=2, help="Sampled pairs for the function-class check.")] = 20_000,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the function-class sampling (>= 0).")] = 0,
) -> None:
    """Set-valued observer (Khajenejad–Yong): structural checks, the design and its independent verification."""
    from nlobs.workflows.setvalued import design_setvalued_observer

    try:
        report = design_setvalued_observer(model, objective=objective.value, samples=samples, seed=seed)
    except NlobsError as exc:
        _errors(model, exc)
    _show(report, as_json)


@simulate_app.command("setvalued")
def simulate_setvalued_cmd(
    model: Annotated[str, typer.Argument(
        metavar="MODEL", autocompletion=complete_model, help="A model file with unknown inputs (.toml), or a shipped model name.")],
    runs: Annotated[int, typer.Option(min=1, help="Monte Carlo runs.")] = 1000,
    steps: Annotated[int, typer.Option(min=1, help="Steps per run.")] = 200,
    unknown_input: Annotated[UnknownInput, typer.Option(
        "--unknown-input", help="The file's bounded or growing signal d(t) (defaults sin t and t²).")]
    = UnknownInput.bounded,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the initial states and noises (>= 0).")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print a machine-readable JSON report.")] = False,
    out: Annotated[Path | None, typer.Option(help="Folder for the figures.")] = None,
    objective: Annotated[Objective, typer.Option(help="Design objective (see design setvalued).")] = Objective.radius,
    baselines: Annotated[bool, typer.Option(help="Also run the Lipschitz LMI observer and the EKF.")] = True,
    samples: Annotated[int, typer.Option(min=2, help="Sampled pairs for the function-class check.")] = 20_000,
    batch: Annotated[int | None, typer.Option(min=1, help="Runs computed together, each batch from its own seed "
                                              "stream (default min(runs, 1000)); with --seed, fixes the numbers.")]
    = None,
    chunk: Annotated[int | None, typer.Option(min=1, help="Runs per task and per file (default one batch); any "
                                              "value gives the same numbers.")] = None,
    workers: Annotated[int | None, typer.Option(min=1, help="Run the chunks on a local Dask cluster of N worker "
                                                "processes (needs nlobs[dask]).")] = None,
    scheduler: Annotated[str | None, typer.Option(help="Run the chunks on the Dask scheduler at this address "
                                                  "(tcp://host:8786).")] = None,
    trajectories: Annotated[bool, typer.Option(help="Save every run's truth and centres in the chunk files of "
                                               "OUT/runs (needs --out).")] = False,
    progress: Progress_ = None,
) -> None:
    """Run Algorithm 1 (Khajenejad–Yong) in Monte Carlo: containment rates, radii and the point baselines.

    With --out, every finished chunk is a file in OUT/runs and the same command resumes where it stopped.
    """
    from nlobs.workflows.setvalued import simulate_setvalued_observer

    try:
        report = simulate_setvalued_observer(model, runs=runs, steps=steps, unknown_input=unknown_input.value,
                                             seed=seed, objective=objective.value, baselines=baselines,
                                             samples=samples, out=out, batch=batch, chunk=chunk, workers=workers,
                                             scheduler=scheduler, trajectories=trajectories, progress=progress)
    except NlobsError as exc:
        _errors(model, exc)
    _show(report, as_json)
