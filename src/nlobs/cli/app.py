"""The ``nlobs`` command line. Calls only the public API.

Exit statuses: 0 success; 1 a design/simulation failure reported by nlobs;
2 bad input (a model file that does not parse or validate, an unknown name,
a malformed option); 3 no observer of the requested structure exists;
130 interrupted by Ctrl-C (SIGINT), 143 terminated by SIGTERM (one line, no traceback;
every output file is written atomically, so the files of an interrupted run are the
previous complete ones or the new complete ones, never half-written, and no temporary is left).
"""

# No ``from __future__ import annotations``: typer reads the annotations of every command's parameters when the
# app starts, and evaluated ones spare it compiling and evaluating each string again (twice per command).

import importlib
import json
import signal
import sys
import threading
import warnings
from types import FrameType
from typing import Any
from pathlib import Path
from typing import Annotated

import typer

from nlobs.cli.common import (
    complete_model,
    EXIT_FAILURE,
    box_numbers,
    console,
    design_app,
    emit_json,
    fail,
    jsonable,
    parse_floats,
    print_table,
    simulate_app,
    Progress_,
)
from nlobs.cli.choices import Backend, Demo, DemoGains, Paper, Schedule, value
from nlobs.errors import ModelFileError, NlobsError, OutputError

class _Interrupted(BaseException):
    """SIGINT or SIGTERM arrived: unwinds the command (atomic writes remove their temporary files)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise _Interrupted(signum)


class _NlobsApp(typer.Typer):
    """The typer app, run with SIGINT and SIGTERM turned into one line and exit ``128 + signal``.

    Click turns ``KeyboardInterrupt`` into "Aborted!" and exit 1, and SIGTERM's default action
    kills the process without running any cleanup; both signals raise :class:`_Interrupted`
    instead, a ``BaseException`` that nothing in nlobs catches, so every ``finally`` and every
    atomic write's cleanup runs before the exit. The previous handlers are restored afterwards. A
    ``MemoryError`` that no size check foresaw ends in one line and exit 2 (the commands refuse the
    sizes they can estimate before allocating).
    """

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        warnings.formatwarning = _warning_line  # one line, never the generated source line of a compiled model
        previous: dict[int, Any] = {}
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                previous[sig] = signal.signal(sig, _interrupt)
        try:
            return super().__call__(*args, **kwargs)
        except MemoryError:  # e.g. --runs 99999999999: NumPy cannot allocate the runs' arrays
            sys.stderr.write("nlobs: error: not enough memory for this request (fewer runs, a shorter duration or a "
                             "larger step would fit); nothing was written half-way\n")
            sys.stderr.flush()
            raise SystemExit(2) from None
        except _Interrupted as exc:
            name = signal.Signals(exc.signum).name
            sys.stderr.write(f"nlobs: interrupted by {name}; the files already written are complete, "
                             "none is half-written\n")
            sys.stderr.flush()
            raise SystemExit(128 + exc.signum) from None
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)


def _warning_line(message: Any, category: type[Warning], filename: str, lineno: int, line: str | None = None) -> str:
    """A warning as one line (NumPy's RuntimeWarnings in a compiled model printed its generated source line)."""
    where = "" if filename.startswith("<") else f" ({Path(filename).name}:{lineno})"
    return f"nlobs: warning: {category.__name__}: {message}{where}\n"


def _usage_in_one_line(self: Any, file: Any = None) -> None:
    """A usage error (a missing argument, an unknown command or option) as one line: ``nlobs: error: … (see …)``."""
    hint = f" (see '{self.ctx.command_path} --help')" if getattr(self, "ctx", None) is not None else ""
    sys.stderr.write(f"nlobs: error: {self.format_message()}{hint}\n")
    sys.stderr.flush()


def _one_line_usage_errors() -> None:
    """Click prints a usage error in four lines (usage, a hint, a blank, the error); nlobs prints every error in one."""
    for name in ("typer._click.exceptions", "click.exceptions"):  # typer ≥ 0.26 bundles its own click
        try:
            module = importlib.import_module(name)
        except ImportError:
            continue
        module.UsageError.show = _usage_in_one_line


def _named_arguments_without_types() -> None:
    """typer ≥ 0.26 writes an argument's Python type after its name (``MODEL <str>``); an argument that names its
    value (a metavar) is shown by that name alone, choices still listed (``PAPER <grip2013|…>``)."""
    try:
        core = importlib.import_module("typer.core")
    except ImportError:  # pragma: no cover - typer is a dependency
        return
    cls = getattr(core, "TyperArgument", None)
    original = getattr(cls, "display_type", None)
    if original is None or getattr(original, "nlobs_named", False):
        return  # an older typer (click's own help), or already done

    def display_type(self: Any, ctx: Any) -> str:
        descriptor = getattr(self, "type_descriptor", None)
        if self.metavar is not None and not getattr(descriptor, "is_choice", False):
            return ""
        return original(self, ctx)  # type: ignore[no-any-return]

    display_type.nlobs_named = True  # type: ignore[attr-defined]
    cls.display_type = display_type  # type: ignore[union-attr]


_one_line_usage_errors()
_named_arguments_without_types()

app = _NlobsApp(
    name="nlobs",
    help="Design, certify and simulate nonlinear state observers.",
    no_args_is_help=True,
    add_completion=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # plain help: units in brackets ("[s]") are text, not markup; the same on every typer
)


def _installed_version() -> str:
    from importlib.metadata import version

    return version("nlobs")


def _print_version(value: bool) -> None:
    if value:
        typer.echo(_installed_version())
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                          help="Print the nlobs version and exit.")] = False,
) -> None:
    """Design, certify and simulate nonlinear state observers."""


@app.command("analyze")
def analyze_cmd(
    model: Annotated[str, typer.Argument(
        metavar="MODEL", autocompletion=complete_model, help="A model file (.toml), or the name of a shipped model.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print a machine-readable JSON report.")] = False,
    x0: Annotated[str | None, typer.Option(
        help="Linearisation point of a nonlinear model, e.g. '0,1,0,0' (default: the file's [simulation] x0, "
             "else zeros).")] = None,
    u0: Annotated[str | None, typer.Option(
        help="Input at the linearisation point (default: the file's [input_signals] at t = 0, else zero).")] = None,
    box: Annotated[str | None, typer.Option(
        help="Region of the symbolic analyses of a nonlinear model: 'lo,hi' for every state, or 2n numbers "
             "lo1,hi1,lo2,hi2,... (default: the file's [simulation] box, else -1,1).")] = None,
    symbolic_budget: Annotated[float, typer.Option(
        "--symbolic-budget", min=0.0,
        help="Seconds for the optional symbolic parts (the gain field Q⁺(x)k), counted as work, not timed "
             "(200 000 term operations a second: the same report on any machine); a part that does not fit is "
             "evaluated numerically and named in the report.")] = 5.0,
) -> None:
    """Report a model's dimensions, structural properties and norms.

    A nonlinear model is linearised at --x0/--u0 (else the file's [simulation] x0 and its inputs at t = 0, else
    zero) and analysed on --box (else the file's [simulation] box, else [-1, 1]^n); the report says which.
    """
    from nlobs.workflows.analyze import analyze_model
    from nlobs.workflows.inputs import BoxError

    try:
        report = analyze_model(model, x0=parse_floats("--x0", x0), u0=parse_floats("--u0", u0),
                               box=box_numbers("--box", box), symbolic_budget=symbolic_budget)
    except ModelFileError as exc:
        fail(str(exc))
    except BoxError as exc:
        fail(f"--box: {exc}" if box is not None else f"{model}: {exc}")  # else the file's [simulation] box
    except NlobsError as exc:
        fail(f"{model}: {exc}")
    if as_json:
        emit_json(report.to_dict())
    else:
        console().print(report.summary(), markup=False)


@app.command("reproduce")
def reproduce_cmd(
    paper: Annotated[Paper, typer.Argument(metavar="PAPER", help=(
        "Which paper: grip2013 (Grip, Saberi & Johansen, cascade and GNSS/INS observers), dallamora2000 (Dalla "
        "Mora, Germani & Manes, drift observability), robenack2008 (Röbenack, the Moore–Penrose gain), "
        "khajenejad-yong (Khajenejad & Yong, set-valued input and state observers)."))],
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON list of rows.")] = False,
) -> None:
    """Print each number a paper reports beside the value nlobs computes."""
    from rich.table import Table

    from nlobs.papers.reproduce import format_value, reproduce

    paper = value(paper)
    try:
        rows = reproduce(paper)
    except NlobsError as exc:
        fail(f"reproduce {paper}: {exc}", EXIT_FAILURE)
    if as_json:
        typer.echo(json.dumps(jsonable([r.to_dict() for r in rows]), indent=2, allow_nan=False))
        return
    table = Table(title=f"nlobs reproduce {paper}", show_lines=False)
    for col in ("quantity", "paper", "nlobs", "note"):
        table.add_column(col, overflow="fold")
    for r in rows:
        table.add_row(r.quantity, format_value(r.paper), format_value(r.nlobs), r.note)
    console().print(table)


@app.command("demo")
def demo_cmd(
    name: Annotated[Demo, typer.Argument(metavar="NAME", help="Which demo: gnss-ins.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the results as JSON.")] = False,
    seed: Annotated[int, typer.Option(help="Seed of the flight and of the sensor noise.")] = 0,
    duration: Annotated[float | None, typer.Option(help="Flight length [s] (default: the whole pattern).")] = None,
    out: Annotated[Path, typer.Option(help="Folder for the figures and results.json.")] = Path("out/gnss-ins"),
    yaw_error: Annotated[float, typer.Option(help="Initial yaw error [deg].")] = 60.0,
    gains: Annotated[DemoGains, typer.Option(
        help="'noise-optimal' (the certified gain with the smallest noise-to-error H2 norm under LMI (14), "
             "the paper's gains beside it), 'paper' (Sec. 5.2) or 'designed' (nlobs's central LMI design).")
    ] = DemoGains.noise_optimal,
    attitude_gain: Annotated[Schedule | None, typer.Option(
        help="Attitude gain of the noise-optimal observer: 'scheduled' (its default: Γ(t) = γ(t) I from 0.5 I "
             "down to the steady-state gain set by the gyro and magnetometer noise) or 'constant' (0.5 I).")
    ] = None,
    translation_gain: Annotated[Schedule | None, typer.Option(
        help="Gain K of the noise-optimal observer's position and velocity: 'scheduled' (its default: certified "
             "Kalman–Bucy levels from the first fix's uncertainty down to the noise-optimal K) or 'constant' "
             "(the noise-optimal K throughout).")
    ] = None,
    position_only: Annotated[bool, typer.Option(help="GNSS position only (Sec. 5.2, C = [I 0]).")] = False,
    ekf: Annotated[bool, typer.Option(help="Also run the EKF baseline.")] = True,
    backend: Annotated[Backend, typer.Option(
        help="'python' (default) or 'c': observer (24) and the EKF run as their generated, compiled C.")]
    = Backend.python,
    progress: Progress_ = None,
) -> None:
    """Run a demo: gnss-ins simulates a flight and compares observer (24) with an EKF."""
    from nlobs.workflows.demo import DemoConfig, gnss_ins_demo

    name = value(name)
    try:
        config = DemoConfig(seed=seed, duration=duration, yaw_error_deg=yaw_error, gains=value(gains),
                            attitude_gain=value(attitude_gain), translation_gain=value(translation_gain),
                            position_only=position_only, ekf=ekf, backend=value(backend))
    except NlobsError as exc:
        fail(str(exc))
    try:
        report = gnss_ins_demo(config, out, progress=progress)
    except OutputError as exc:
        fail(str(exc))
    except NlobsError as exc:
        fail(f"demo {name}: {exc}", EXIT_FAILURE)
    if as_json:
        emit_json(report.to_dict())
        return
    print_table(*report.table())
    con = console()
    if report.consistency_line():
        con.print(report.consistency_line(), markup=False)
    for f in report.files:
        con.print(f"wrote {f}", markup=False)


@app.command("models")
def models_cmd(
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON list.")] = False,
) -> None:
    """List the model files shipped with nlobs."""
    from nlobs.systems.modelfile import SHIPPED_MODEL_JSON, shipped_models

    shipped = shipped_models()
    if as_json:
        rows = [SHIPPED_MODEL_JSON.emit({"name": k, "path": str(v)}) for k, v in sorted(shipped.items())]
        typer.echo(json.dumps(rows, indent=2))
        return
    con = console()
    for name, path in sorted(shipped.items()):
        con.print(f"{name:28s} {path}", markup=False)


@app.command("version")
def version_cmd() -> None:
    """Print the nlobs version (the same as nlobs --version)."""
    typer.echo(_installed_version())


from nlobs.cli.advise import advise_cmd  # noqa: E402 - registered after the app exists

app.command("advise")(advise_cmd)
from nlobs.cli.export import export_cmd  # noqa: E402 - registered after the app exists

app.command("export")(export_cmd)
from nlobs.cli import gnss_ins as _gnss_ins  # noqa: E402,F401 - registers `simulate gnss-ins`
from nlobs.cli.schema import schema_cmd  # noqa: E402 - registered after the app exists

app.command("schema")(schema_cmd)
from nlobs.cli.estimate import estimate_cmd  # noqa: E402 - registered after the app exists

app.command("estimate")(estimate_cmd)

app.add_typer(design_app, name="design")
app.add_typer(simulate_app, name="simulate")


def main() -> None:  # pragma: no cover - entry point convenience
    app()
