"""``nlobs advise MODEL``: which observer of nlobs applies, with its evidence and the first command to run.

Parses the options, calls :func:`nlobs.workflows.advise.advise_model`, prints the report's
``summary()`` (or ``to_dict()`` with ``--json``) and exits by its verdict (0 a method applies,
3 none does; bad input 2, one line).
"""

# No ``from __future__ import annotations``: typer reads the annotations of every command's parameters when the
# app starts, and evaluated ones spare it compiling and evaluating each string again (twice per command).

from typing import Annotated

import typer

from nlobs.cli.common import Progress_, box_numbers, complete_model, console, emit_json, fail, finish
from nlobs.errors import ModelFileError, NlobsError


def advise_cmd(
    model: Annotated[str, typer.Argument(
        metavar="MODEL", autocompletion=complete_model, help="A model file (.toml), or the name of a shipped model.")],
    box: Annotated[str | None, typer.Option(
        help="Region of the analyses: 'lo,hi' for every state, or 2n numbers lo1,hi1,... "
             "(default: the file's [simulation] box, else -1,1).")] = None,
    check: Annotated[bool, typer.Option(
        "--check", help="Also run the applicable observers and an EKF on a few noisy runs under the file's sensors, "
                        "and rank an observer that diverges or never converges below the Kalman filters "
                        "(seconds to minutes).")] = False,
    runs: Annotated[int, typer.Option(help="Monte Carlo runs of --check.")] = 3,
    as_json: Annotated[bool, typer.Option("--json", help="Print a machine-readable JSON report.")] = False,
    progress: Progress_ = None,
) -> None:
    """Say which observer applies to a model, with the evidence, the parameters to start from and the command."""
    from nlobs.workflows.advise import advise_model
    from nlobs.workflows.inputs import BoxError

    try:
        report = advise_model(model, box=box_numbers("--box", box), check=check, runs=runs,
                              progress=progress)
    except ModelFileError as exc:
        fail(str(exc))
    except BoxError as exc:
        fail(f"--box: {exc}")
    except NlobsError as exc:
        fail(f"{model}: {exc}")
    if as_json:
        emit_json(report.to_dict())
    else:
        console().print(report.summary(), markup=False)
    finish(report, as_json)
