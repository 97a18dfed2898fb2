"""A logged run of a plant: the inputs applied and the sensor readings, as an engineer records them.

The file is CSV (:func:`~nlobs.systems.signals.read_csv_table`): a time column ``t`` (or ``time``), then one
column per input and per output, named as in the model file. A multi-rate log leaves a field empty where a sensor
gave no sample; an input's empty field holds its previous value (a zero-order hold, as a controller's output is
held between updates). Numbers are parsed, never evaluated::

    t,F,x_enc,th_enc
    0.00,1.0,0.001,3.002
    0.01,1.0,,
    0.02,0.9,0.003,2.998

:func:`read_log` checks the columns against the model's names and returns a :class:`RecordedLog` whose arrays are
what :func:`nlobs.simulate.run_observer` takes (``u`` on every row, ``y`` with NaN where nothing was sampled).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nlobs._typing import Array
from nlobs._validate import escape_unsafe, readonly
from nlobs.errors import SignalFileError, UnknownNameError
from nlobs.systems.signals import read_csv_table

__all__ = ["RecordedLog", "read_log"]


@dataclass(frozen=True)
class RecordedLog:
    """A log of inputs and sensor readings on one time grid (read-only arrays).

    Attributes
    ----------
    path : str
        The file it was read from.
    t : ndarray, shape (K,)
        The strictly increasing times of the rows.
    u : ndarray, shape (K, m)
        The inputs at every row (an empty field held from the row before).
    y : ndarray, shape (K, p)
        The outputs, NaN where the sensor gave no sample (or the log has no column for that output).
    inputs, outputs : tuple of str
        The model's names, in the model's order (the columns of ``u`` and ``y``).
    """

    path: str
    t: Array
    u: Array
    y: Array
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]

    @property
    def samples(self) -> dict[str, int]:
        """The number of samples of each output (its non-empty fields)."""
        return {name: int(np.isfinite(self.y[:, j]).sum()) for j, name in enumerate(self.outputs)}

    @property
    def y_rows(self) -> Array:
        """The rows with at least one sample, ``(G,)`` indices into :attr:`t`."""
        return np.flatnonzero(np.isfinite(self.y).any(axis=1))


def read_log(path: str | Path, *, inputs: Sequence[str], outputs: Sequence[str]) -> RecordedLog:
    """Read a logged run (module docstring) for a model with these inputs and outputs.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    inputs, outputs : sequence of str
        The model's input and output names: the log has a column for every input, and for at least one output.

    Returns
    -------
    RecordedLog

    Raises
    ------
    SignalFileError
        The file cannot be read as a CSV table of finite numbers with strictly increasing times
        (:func:`~nlobs.systems.signals.read_csv_table`), an input has no column or no value on the first row, or
        no output has a column or a sample. One line naming the file (and the line).
    UnknownNameError
        A column is neither an input nor an output of the model (the message lists the names it knows).

    Examples
    --------
    A cart encoder at 100 Hz and a pole encoder at 50 Hz, the force held between its updates:

    >>> import shutil
    >>> import tempfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> text = "t,F,x_enc,th_enc\\n0.00,1.0,0.001,3.002\\n0.01,,0.002,\\n0.02,0.9,0.003,2.998\\n"
    >>> _ = (folder / "log.csv").write_text(text, encoding="utf-8")
    >>> log = read_log(folder / "log.csv", inputs=["F"], outputs=["x_enc", "th_enc"])
    >>> log.u[:, 0].tolist(), log.samples, log.y_rows.tolist()
    ([1.0, 1.0, 0.9], {'x_enc': 3, 'th_enc': 2}, [0, 1, 2])
    >>> try:
    ...     read_log(folder / "log.csv", inputs=["F"], outputs=["x_enc"])
    ... except UnknownNameError as exc:
    ...     print(str(exc).split("log.csv: ")[1])
    column 'th_enc' is not an input or an output of the model (inputs: F; outputs: x_enc)
    >>> shutil.rmtree(folder)
    """
    table = read_csv_table(path, empty_fields=True)
    p = table.path
    inputs, outputs = tuple(inputs), tuple(outputs)
    known = set(inputs) | set(outputs)
    for name in table.columns:
        if name not in known:
            raise UnknownNameError(
                f"{p}: column {escape_unsafe(name, one_line=True)!r} is not an input or an output of the model "
                f"(inputs: {', '.join(inputs) or 'none'}; outputs: {', '.join(outputs)})")
    K = table.t.shape[0]
    u = np.empty((K, len(inputs)))
    for j, name in enumerate(inputs):
        if name not in table.columns:
            raise SignalFileError(p, None, "", f"no column for the input {name!r} (a log has every input of the "
                                               f"model: {', '.join(inputs)})")
        col = table.columns[name]
        if not np.isfinite(col[0]):
            raise SignalFileError(p, int(table.lines[0]), "", f"the input {name!r} has no value on the first row "
                                                              "(a later empty field holds the previous value)")
        idx = np.where(np.isfinite(col), np.arange(K), 0)
        u[:, j] = col[np.maximum.accumulate(idx)]
    y = np.full((K, len(outputs)), np.nan)
    for j, name in enumerate(outputs):
        if name in table.columns:
            y[:, j] = table.columns[name]
    if not np.isfinite(y).any():
        raise SignalFileError(p, None, "", f"no sample of any output (a column for at least one of "
                                           f"{', '.join(outputs)}, with a number in it)")
    return RecordedLog(p, readonly(table.t), readonly(u), readonly(y), inputs, outputs)
