"""``nlobs estimate MODEL --data FILE.csv``: the observers on a logged run of the plant."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from nlobs.cli.common import (
    EXIT_FAILURE,
    Progress_,
    complete_model,
    console,
    emit_json,
    fail,
    finish,
    parse_floats,
    print_table,
)
from nlobs.cli.compare import design_options, estimator_options
from nlobs.errors import ModelFileError, NlobsError, OutputError
from nlobs.methods.registry import REGISTRY, names

_KNOWN = ",".join(names(simulated=True, default=True))
_HELP = "; ".join(f"{e.name}: {e.help}" for e in REGISTRY if e.simulated)


def estimate_cmd(
    model: Annotated[str, typer.Argument(
        metavar="MODEL", autocompletion=complete_model,
        help="A model file (.toml; its [sensors] give the filters their noise, its [simulation] the defaults of "
             "--xhat0, P0, --dt and the settling time), or a shipped model.")],
    data: Annotated[Path, typer.Option(
        "--data", metavar="FILE.csv", help="The log: a column t, one column per input and per output named as in "
                                           "the model file; an empty field where a sensor gave no sample.")],
    observer: Annotated[str, typer.Option("--observer", metavar="NAME,...",
                                          help=f"Comma-separated observers (default: all but pf and mhe). {_HELP}.")]
    = _KNOWN,
    particles: Annotated[int | None, typer.Option(min=2, help="Particles of the particle filter (default 1000).")]
    = None,
    horizon: Annotated[int | None, typer.Option(min=1, help="Samples in the moving horizon (default 10).")] = None,
    xhat0: Annotated[str | None, typer.Option(
        "--xhat0", help="Initial estimate (default: [simulation].x0, else 0).")] = None,
    dt: Annotated[float | None, typer.Option(
        help="Longest integration step of a continuous observer [s] (default: [simulation].dt, else the log's "
             "rows).")] = None,
    option: Annotated[list[str] | None, typer.Option(
        "--option", metavar="METHOD.KEY=VALUE", help="A method's design option, repeatable (as nlobs simulate).")]
    = None,
    smooth: Annotated[bool, typer.Option(
        "--smooth", help="Also run the Rauch-Tung-Striebel smoother of the EKF and the UKF on the whole log (their "
                         "estimates given every sample; columns <state>_smoothed in the CSV).")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the report as JSON.")] = False,
    out: Annotated[Path | None, typer.Option(
        "--out", metavar="DIR", help="Folder for estimates_<observer>.csv, estimate.png and estimate.json.")] = None,
    progress: Progress_ = None,
) -> None:
    """Run observers on a logged run of the plant (recorded inputs and sensor samples)."""
    from nlobs.workflows.estimate import estimate_log

    chosen = [o.strip() for o in observer.split(",") if o.strip()]
    if not chosen:
        fail("--observer: give at least one of " + ",".join(names(simulated=True)))
    try:
        report = estimate_log(model, data, observers=chosen, x_hat0=parse_floats("--xhat0", xhat0), dt=dt,
                              design_options=estimator_options(design_options(option), chosen, particles, horizon), out=out, progress=progress,
                              smooth=smooth)
    except ModelFileError as exc:
        fail(str(exc))
    except OutputError as exc:
        fail(f"--out {exc}")
    except NlobsError as exc:
        fail(f"{model}: {exc}")
    if as_json:
        emit_json(report.to_dict())
    else:
        print_table(*report.table())
        con = console()
        for f in report.files:
            con.print(f"wrote {f}", markup=False)
    finish(report, as_json)
