"""What a workflow concluded, in the words the CLI turns into exit statuses.

Every workflow returns a frozen report with ``to_dict()`` (the JSON report the CLI prints), ``summary()``
(what the CLI prints as text), ``verdict`` and ``message`` (the one line printed after the report when the
verdict is not :attr:`Verdict.OK`). The CLI maps the verdict to its exit status: ``OK`` 0,
``FAILED`` 1, ``NO_OBSERVER`` 3 (bad input is an exception, status 2).
"""

from __future__ import annotations

from nlobs.checks import Verdict

__all__ = ["Verdict"]
