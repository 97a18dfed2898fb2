"""Workflows: one call per CLI command, each returning a frozen report with ``to_dict()`` and ``summary()``.

The command line parses its options, calls one workflow and prints the report; the same calls serve
scripts and notebooks. See :mod:`nlobs.workflows.verdict` for how a report says what it concluded.
"""

from nlobs._io import jsonable
from nlobs._validate import escape_unsafe
from nlobs.workflows.verdict import Verdict

__all__ = ["Verdict", "escape_unsafe", "jsonable"]
