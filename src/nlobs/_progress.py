"""The one progress bar of nlobs: long loops show it on stderr, on request or automatically.

``mode=True`` always shows it, ``False`` never, ``None`` (automatic) once the work has
taken :data:`PROGRESS_AFTER_S` seconds and stderr is a terminal. It updates at most
about 200 times per run, so it costs nothing measurable inside a loop.
"""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import Any

#: In automatic mode, a bar appears once the work has taken this long (seconds) on a terminal.
PROGRESS_AFTER_S = 2.0


class Progress:
    """A rich progress bar over ``total`` steps (context manager; :meth:`update` with the step reached).

    Parameters
    ----------
    total : int
        Number of steps.
    mode : bool or None
        ``True``: always show; ``False``: never; ``None``: automatically (module docstring).
    label : str
        Text before the bar (e.g. ``"simulating"`` or an observer's name).
    """

    def __init__(self, total: int, mode: bool | None, label: str = "simulating") -> None:
        self.total = max(int(total), 1)
        self.mode = mode
        self.label = label
        self.every = max(1, self.total // 200)
        self.next = 0
        self.start = time.perf_counter()
        self.bar: Any = None
        self.task: Any = None

    def __enter__(self) -> Progress:
        if self.mode:
            self._open()
        return self

    def _open(self) -> None:
        from rich.console import Console
        from rich.progress import BarColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn
        from rich.progress import Progress as RichProgress

        self.bar = RichProgress(
            TextColumn(self.label.replace("[", "\\[")),
            BarColumn(),
            TextColumn("{task.percentage:>5.1f}%"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=Console(stderr=True),
            transient=False,
        )
        self.bar.start()
        self.task = self.bar.add_task(self.label, total=self.total)

    def update(self, k: int) -> None:
        """Report that step ``k`` of ``total`` is done."""
        if k < self.next:
            return
        self.next = k + self.every
        if self.bar is None:
            if self.mode is not None or time.perf_counter() - self.start < PROGRESS_AFTER_S:
                return
            if not sys.stderr.isatty():
                self.mode = False
                return
            self._open()
        self.bar.update(self.task, completed=k)

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None) -> None:
        if self.bar is not None:
            if et is None:
                self.bar.update(self.task, completed=self.total)
            self.bar.stop()
