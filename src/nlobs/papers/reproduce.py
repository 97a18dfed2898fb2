"""Reproduction tables: what a paper states beside what nlobs computes.

Each paper module exposes ``reproduce() -> list[ReproRow]``; :data:`PAPERS`
maps the names accepted by ``nlobs reproduce NAME`` to those modules, imported
lazily so that the CLI starts fast.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from nlobs._schema import STRING, Node, Record, array
from nlobs.errors import UnknownNameError

Value = float | int | str | bool | list[Any] | None

#: A reported value: a number, a text, a truth value, a list of them (e.g. a matrix), or null.
_VALUE = Node({"type": ["number", "string", "boolean", "array", "null"]})

#: One row of ``nlobs reproduce PAPER``.
REPRO_ROW_JSON = Record("ReproRow", {
    "quantity": STRING.about("what the paper reports, with its equation, table or figure"),
    "paper": _VALUE.about("the paper's value (null: the paper gives none)"),
    "nlobs": _VALUE.about("the value nlobs computes"),
    "note": STRING.about("how they compare, and why they differ where they do"),
})
#: ``nlobs reproduce PAPER``: a list of rows (no ``schema_version``).
REPRODUCE_JSON = array(REPRO_ROW_JSON, "each number a paper reports beside the value nlobs computes")


@dataclass(frozen=True)
class ReproRow:
    """One reported (or derived) quantity.

    Attributes
    ----------
    quantity : str
        What is compared, with the paper's symbol and equation/section number.
    paper : float, str, list or None
        The value the paper states (``None`` when the paper does not state it and
        the row is derived by nlobs from the paper's data).
    nlobs : float, str, list or None
        What nlobs computes.
    note : str
        Where and why they differ (empty when they agree to the paper's digits).
    """

    quantity: str
    paper: Value
    nlobs: Value
    note: str = ""

    def to_dict(self) -> dict[str, Value]:
        """The stable JSON form: keys ``quantity``, ``paper``, ``nlobs``, ``note``."""
        return REPRO_ROW_JSON.emit({"quantity": self.quantity, "paper": self.paper, "nlobs": self.nlobs,
                                    "note": self.note})


#: ``nlobs reproduce NAME`` → module under ``nlobs.papers`` with a ``reproduce()`` function.
PAPERS: dict[str, str] = {
    "grip2013": "nlobs.papers.grip2013",
    "dallamora2000": "nlobs.papers.dallamora2000",
    "robenack2008": "nlobs.papers.robenack2008",
    "khajenejad-yong": "nlobs.papers.khajenejad_yong",
}


def reproduce(name: str) -> list[ReproRow]:
    """Run the reproduction of paper ``name`` (one of :data:`PAPERS`)."""
    if name not in PAPERS:
        raise UnknownNameError(f"unknown paper {name!r} (known: {', '.join(sorted(PAPERS))})")
    module = importlib.import_module(PAPERS[name])
    fn: Callable[[], Sequence[ReproRow]] = module.reproduce
    return list(fn())


def format_value(v: Value, digits: int = 4) -> str:
    """Compact text for a table cell."""
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.{digits}g}"
    if isinstance(v, list):
        return "[" + ", ".join(format_value(x, digits) for x in v) + "]"
    return str(v)
