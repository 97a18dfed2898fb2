"""The ``nlobs`` command line (typer + rich). Calls only the public API.

Exit statuses: 0 success; 1 a design/simulation failure reported by nlobs;
2 bad input (a model file that does not parse or validate, an unknown name,
a malformed option); 3 no observer of the requested structure exists.

:mod:`~nlobs.cli.app` holds the top-level commands, :mod:`~nlobs.cli.common`
the shared helpers, and one module per command group registers its commands
on ``design`` / ``simulate`` (:mod:`~nlobs.cli.design`).
"""

from nlobs.cli import compare as _compare  # noqa: F401  (registers `simulate compare`, also `simulate MODEL`)
from nlobs.cli import design as _design  # noqa: F401  (registers the `design` commands)
from nlobs.cli import setvalued as _setvalued  # noqa: F401  (registers `design setvalued`, `simulate setvalued`)
from nlobs.cli.app import app, main

__all__ = ["app", "main"]
