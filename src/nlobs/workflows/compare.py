r"""``nlobs simulate MODEL``: every applicable observer on the same noisy, multi-rate Monte Carlo runs, and its files.

The runs, the designs and the metrics are :func:`nlobs.methods.comparison.compare_observers` (every
method of the registry, each designed by the one rule of :mod:`nlobs.methods.problem`); this command
adds the files: ``compare.json``, the plots and the trajectories
(:func:`nlobs.workflows.compare_output.write_comparison`).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from nlobs._io import atomic_write_json, jsonable, with_schema
from nlobs.methods import comparison
from nlobs.methods.comparison import (
    BACKENDS,
    BLOWUP,
    COMPARISON_JSON,
    DEFAULT_FILTER_Q,
    MAX_SAVED_VALUES,
    OBSERVERS,
    SAVED_POINTS,
    ComparisonReport,
    DivergedRun,
    ObserverOutcome,
)
from nlobs.workflows._results import prepare_out

__all__ = [
    "BACKENDS",
    "BLOWUP",
    "DEFAULT_FILTER_Q",
    "MAX_SAVED_VALUES",
    "OBSERVERS",
    "SAVED_POINTS",
    "ComparisonReport",
    "DivergedRun",
    "ObserverOutcome",
    "compare_observers",
    "write_json",
]


def compare_observers(model: Any, *, out: Path | None = None, **options: Any) -> ComparisonReport:
    """Run the chosen observers on the same noisy, multi-rate Monte Carlo runs of a model and write the files.

    Parameters
    ----------
    model : str, Path, Scenario, SymbolicModel or LinearSystem
        A model file, a shipped model name, or a model (as
        :func:`nlobs.methods.comparison.compare_observers`).
    out : Path, optional
        Folder for ``compare.json``, the plots and the trajectories (``.npz`` and ``.csv``).
    **options
        The options of :func:`nlobs.methods.comparison.compare_observers` (``observers``, ``runs``,
        ``duration``, ``dt``, ``seed``, ``x0``, ``x_hat0``, ``initial_error_std``, ``box``, ``settle``,
        ``rate``, ``noise_std``, ``inputs``, ``process_noise``, ``filter_q``, ``alpha``, ``progress``,
        ``name``, ``backend``, ``executor``, ``workers``, ``scheduler``).

    Returns
    -------
    ComparisonReport
        With :attr:`~ComparisonReport.files` the files written to ``out``.

    Raises
    ------
    OutputError
        ``out`` cannot be written (checked before the runs).
    ModelFileError, UnknownNameError, InvalidArgumentError, DimensionError, NonFiniteError, StudyFailed
        As :func:`nlobs.methods.comparison.compare_observers`.
    """
    prepare_out(out)
    report = comparison.compare_observers(model, **options)
    if out is None:
        return report
    from nlobs.workflows.compare_output import write_comparison

    files = write_comparison(report, report.scenario, out, plant=report.plant)
    return dataclasses.replace(report, files=files)


def write_json(report: ComparisonReport, path: Path) -> Path:
    """``report.to_dict()`` as JSON, atomically.

    Parameters
    ----------
    report : ComparisonReport
        The comparison.
    path : Path
        The file.

    Returns
    -------
    Path
    """
    return atomic_write_json(path, with_schema(jsonable(report.to_dict())))

