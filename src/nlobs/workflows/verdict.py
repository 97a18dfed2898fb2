"""What a workflow concluded, in the words the CLI turns into exit statuses.

Every workflow returns a frozen report with ``to_dict()`` (what ``--json`` prints), ``summary()`` (what
the CLI prints as text), ``verdict`` and ``message`` (the one line printed after the report when the
verdict is not :attr:`Verdict.OK`). The CLI maps the verdict to its exit status: ``OK`` 0,
``FAILED`` 1, ``NO_OBSERVER`` 3 (bad input is an exception, status 2).
"""

from __future__ import annotations

from enum import Enum

__all__ = ["Verdict"]


class Verdict(Enum):
    """The outcome of a workflow."""

    OK = "ok"
    """Everything asked for was done and holds (a design is usable, a guarantee held)."""
    FAILED = "failed"
    """A design is not usable, a certificate failed, or a guarantee was violated (exit status 1)."""
    NO_OBSERVER = "no observer"
    """No observer of the requested structure exists for this model (exit status 3)."""
