"""Shared pieces of the ``nlobs`` command line: exit statuses, one-line errors, option parsing and
JSON output. Every command module imports these; none defines its own.

From the library this module imports only :mod:`nlobs.workflows`: the escaping of terminal text and the JSON conversion come from
:mod:`nlobs.workflows`, and a ``--box`` goes to the workflows as numbers (:func:`box_numbers`),
which build the region. Both are imported on first use (they load NumPy), so that ``nlobs --help``
and ``nlobs version`` start without the numeric stack.
"""

from __future__ import annotations

import functools
import json
import math
from typing import TYPE_CHECKING, Any, NoReturn

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
        """A rich console that passes every string it renders (prints, table cells, titles) through :func:`safe_text`."""

        def render_str(self, text: str, **kwargs: Any) -> Text:
            return super().render_str(safe_text(text), **kwargs)

    return _SafeConsole


def console() -> Console:
    return _safe_console_class()(highlight=False, soft_wrap=True)


def fail(message: str, status: int = EXIT_BAD_INPUT) -> NoReturn:
    """Print a one-line error to stderr (control characters escaped) and exit."""
    from rich.console import Console

    Console(stderr=True, highlight=False, soft_wrap=True).print(f"nlobs: error: {safe_text(message, one_line=True)}",
                                                                markup=False)
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


def emit_json(data: dict[str, Any]) -> None:
    """Print a JSON report (with ``schema_version``, :data:`nlobs._io.SCHEMA_VERSION`)."""
    from nlobs.workflows import with_schema

    typer.echo(json.dumps(jsonable(with_schema(data)), indent=2, allow_nan=False))



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
