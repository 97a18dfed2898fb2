"""Shared pieces of the ``nlobs`` command line: exit statuses, one-line errors, option parsing and
JSON output. Every command module imports these; none defines its own.

From the library this module imports only :mod:`nlobs.workflows`: the escaping of terminal text and the JSON conversion come from
:mod:`nlobs.workflows`, and a ``--box`` goes to the workflows as numbers (:func:`box_numbers`),
which build the region. Both are imported on first use (they load NumPy), so that ``nlobs --help``
and ``nlobs version`` start without the numeric stack.

The library speaks Python: its messages name a parameter between single backticks (``"`noise_std`:
expected 2 numbers"``), and :func:`flags` spells each as the command's flag (``--noise-std``). Every
line a command prints goes through it: :func:`fail` (the one-line errors, also a report's last line
from :func:`finish`), the console (text reports, :func:`console`) and :func:`emit_json`; a command
with a spelling of its own maps the message itself, ``fail(flags(str(exc), {"name": "--flag"}))``.
"""

from __future__ import annotations

import functools
import json
import math
import re
from collections.abc import Collection, Mapping
from typing import TYPE_CHECKING, Annotated, Any, NoReturn

import typer
from typer.core import TyperGroup

if TYPE_CHECKING:  # rich is imported on first output (``nlobs version`` needs none of it)
    from rich.console import Console


EXIT_FAILURE = 1
EXIT_BAD_INPUT = 2
EXIT_NO_OBSERVER = 3


def safe_text(text: object, *, one_line: bool = False) -> str:
    """``str(text)`` with control characters and bidirectional overrides written as ``\\xNN`` / ``\\uNNNN``.

    Whatever a model file or an argument holds, the result cannot send an
    escape sequence to the terminal. ``one_line`` escapes tab and newline too.
    """
    from nlobs.workflows import escape_unsafe

    return escape_unsafe(str(text), one_line=one_line)


@functools.cache
def _safe_console_class() -> type[Console]:
    from rich.console import Console
    from rich.text import Text

    class _SafeConsole(Console):
        """A rich console that passes every string it renders (prints, table cells, titles) through :func:`flags`
        (a report's backticked parameters as the command's flags) and :func:`safe_text`."""

        def render_str(self, text: str, **kwargs: Any) -> Text:
            return super().render_str(safe_text(flags(text)), **kwargs)

    return _SafeConsole


def console() -> Console:
    return _safe_console_class()(highlight=False, soft_wrap=True)


#: The library's parameters whose flag is not ``--`` + the name with ``_`` written ``-`` (:func:`flags`), for every
#: command; a command with a spelling of its own passes it to :func:`flags` as ``extra``.
FLAG_EXCEPTIONS: dict[str, str] = {
    "x_hat0": "--xhat0",  # SimulationRequest(x_hat0=), compare_observers(x_hat0=)
    "region": "--box",  # the region of the lower layers (design_drift_report(region=), ...) is the workflows' box
    "gain_method": "--method",  # the drift and cascade methods' design option (nlobs export --method)
    "observers": "--observer",  # compare_observers(observers=)
    "inputs": "--input",  # compare_observers(inputs=)
    "design_options": "--option",  # compare_observers(design_options=)
    "yaw_error_deg": "--yaw-error",  # DemoConfig(yaw_error_deg=) (nlobs demo)
    "attitude_error_deg": "--attitude-error",  # gnss_ins_monte_carlo(attitude_error_deg=) (nlobs simulate gnss-ins)
    "position_error_m": "--position-error",  # gnss_ins_monte_carlo(position_error_m=)
}

#: A parameter named in a library message: an identifier between single backticks (not RST's double ones).
_PARAMETER = re.compile(r"(?<!`)`([A-Za-z_][A-Za-z0-9_]*)`(?!`)")


def _command_options() -> frozenset[str] | None:
    """Every flag of the command being run (``--out``, ``--no-progress``, ...); ``None`` outside a command."""
    try:  # typer >= 0.2x runs its commands on its own copy of click, with its own current context
        from typer._click.globals import get_current_context
    except ImportError:  # older typer: click itself
        from click import get_current_context
    ctx = get_current_context(silent=True)
    if ctx is None:
        return None
    return frozenset(opt for p in ctx.command.params for opt in (*p.opts, *getattr(p, "secondary_opts", ()))
                     if opt.startswith("-"))


def flags(message: str, extra: Mapping[str, str] | None = None, *, options: Collection[str] | None = None) -> str:
    """A library message in the command line's words: each backticked parameter name spelled as its flag.

    Below the CLI a message names the Python parameter it is about between single backticks, the keyword
    of the function the user called, never a flag (``"`runs`: expected an integer ≥ 1, got 0"``). Here
    each backticked name becomes its flag: ``extra[name]`` when the command gives one, else
    ``FLAG_EXCEPTIONS[name]``, else ``--`` + the name with ``_`` written ``-`` (``noise_std`` →
    ``--noise-std``). A name whose flag the command does not have stays, without its backticks
    (``options``: the command's flags; by default those of the command being run, and outside a command
    every name is spelled as a flag). Anything else (text without backticks, RST's double backticks, a
    backticked text that is not an identifier) is left as it is, so a mapped message maps to itself.

    >>> flags("`duration` 10 / `dt` 1e-07 is 1e8 steps (raise `dt`)", options=["--duration", "--dt"])
    '--duration 10 / --dt 1e-07 is 1e8 steps (raise --dt)'
    >>> flags("`x_hat0`: expected 2 numbers; `executor`: not here", options=["--xhat0"])
    '--xhat0: expected 2 numbers; executor: not here'
    """
    if "`" not in message:  # most strings a command prints (every table cell goes through here)
        return message
    known = _command_options() if options is None else frozenset(options)

    def flag(m: re.Match[str]) -> str:
        name = m.group(1)
        spelled = (extra or {}).get(name) or FLAG_EXCEPTIONS.get(name) or "--" + name.replace("_", "-")
        return spelled if known is None or spelled in known else name

    return _PARAMETER.sub(flag, message)


def fail(message: str, status: int = EXIT_BAD_INPUT) -> NoReturn:
    """Print a one-line error to stderr (control characters escaped, parameters as flags: :func:`flags`) and exit."""
    from rich.console import Console

    Console(stderr=True, highlight=False, soft_wrap=True).print(
        f"nlobs: error: {safe_text(flags(message), one_line=True)}", markup=False)
    raise typer.Exit(status)


def on_off(option: str, text: str) -> bool:
    """``"on"`` → ``True``, ``"off"`` → ``False``; anything else is one line and exit 2."""
    if text not in ("on", "off"):
        fail(f"{option}: expected 'on' or 'off', got {text!r}")
    return text == "on"


def finish(report: Any, as_json: bool = False) -> None:
    """Exit by a workflow report's verdict after it was printed: 0 ``OK``, 1 ``FAILED``, 3 ``NO_OBSERVER``.

    The report's ``message`` (or, after ``--json``, its ``json_message`` when it has one) is the one line.
    """
    from nlobs.workflows.verdict import Verdict

    verdict = report.verdict
    if verdict is Verdict.OK:
        return
    message = getattr(report, "json_message", None) if as_json else None
    fail(message or report.message, EXIT_NO_OBSERVER if verdict is Verdict.NO_OBSERVER else EXIT_FAILURE)


def parse_floats(option: str, text: str | None) -> list[float] | None:
    if text is None:
        return None
    try:
        vals = [float(s) for s in text.replace(",", " ").split()]
    except ValueError:
        fail(f"{option}: expected comma-separated numbers, got {text!r}")
    if not all(math.isfinite(v) for v in vals):
        fail(f"{option}: values must be finite, got {text!r}")
    return vals


def box_numbers(option: str, text: str | None) -> list[float] | None:
    """The numbers of a ``--box`` option (the workflow builds the region and checks their count)."""
    return parse_floats(option, text) if text is not None else None


def print_table(title: str, heads: list[str], rows: list[list[str]]) -> None:
    """A report's table (first column left, the others right-aligned), its cells printed as text, not markup."""
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=escape(title))
    table.add_column(escape(heads[0]))
    for h in heads[1:]:
        table.add_column(escape(h), justify="right")
    for row in rows:
        table.add_row(*(escape(c) for c in row))
    console().print(table)


def jsonable(data: Any) -> Any:
    """:func:`nlobs.workflows.jsonable`: NumPy scalars and arrays as Python values, non-finite floats as ``None``."""
    from nlobs.workflows import jsonable as _jsonable

    return _jsonable(data)


def _flagged(data: Any, options: Collection[str] | None) -> Any:
    """Every string value of a JSON report through :func:`flags` (the keys are the report's own names)."""
    if isinstance(data, str):
        return flags(data, options=options)
    if isinstance(data, dict):
        return {k: _flagged(v, options) for k, v in data.items()}
    if isinstance(data, list):
        return [_flagged(v, options) for v in data]
    return data


def emit_json(data: dict[str, Any]) -> None:
    """Print a JSON report (with ``schema_version``, :data:`nlobs._io.SCHEMA_VERSION`), its backticked parameters
    spelled as the command's flags (:func:`flags`, as in every line the command prints)."""
    from nlobs.workflows import with_schema

    report = _flagged(jsonable(with_schema(data)), _command_options())
    typer.echo(json.dumps(report, indent=2, allow_nan=False))



def complete_model(incomplete: str) -> list[str]:
    """Shell completion of a MODEL argument: the shipped models and the ``.toml`` files here that start so."""
    from pathlib import Path

    from nlobs.systems.modelfile import shipped_models

    names = sorted(n for n in shipped_models() if n.startswith(incomplete))
    folder = Path(incomplete).parent if incomplete else Path(".")
    try:
        files = sorted(str(p) if str(folder) != "." else p.name for p in folder.glob("*.toml")
                       if str(p).startswith(incomplete) or (str(folder) == "." and p.name.startswith(incomplete)))
    except OSError:
        files = []
    return names + files


#: The one progress convention of the long commands: a bar on stderr, shown automatically on a terminal.
Progress_ = Annotated[bool | None, typer.Option(
    "--progress/--no-progress", help="A progress bar on stderr (default: on a terminal, once the work takes a "
                                     "while; never in redirected output).")]

design_app = typer.Typer(help="Design an observer for a model and print its verification.", no_args_is_help=True,
                         rich_markup_mode=None)
class _SimulateGroup(TyperGroup):
    """``nlobs simulate``: its subcommands, and ``nlobs simulate MODEL ...`` as ``nlobs simulate compare MODEL ...``."""

    def parse_args(self, ctx: Any, args: list[str]) -> list[str]:
        if args and not args[0].startswith("-") and args[0] not in self.commands:
            args = ["compare", *args]
        return super().parse_args(ctx, args)


simulate_app = typer.Typer(
    cls=_SimulateGroup, no_args_is_help=True, rich_markup_mode=None,
    help="Simulate observers on a model: 'nlobs simulate MODEL' compares every applicable observer (and EKF/UKF) "
         "on the same noisy Monte Carlo runs; 'nlobs simulate setvalued' runs the set-valued study.")
