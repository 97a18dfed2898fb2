r"""Design sweeps over a parameter grid: every point evaluated here or on Dask, results in grid order.

One entry, :func:`sweep`, evaluates a :class:`SweepProblem` at every point of a grid (a Cartesian
product of named values, or a list of points) and returns a :class:`SweepResult`.

* A problem is a small picklable recipe. Its :meth:`SweepProblem.prepare` builds what every point
  reuses (a loaded model, an extended system, compiled functions) **once per process**: on Dask,
  the problem is sent to each worker once and its prepared objects are kept there, by
  :meth:`SweepProblem.key` (the last :data:`PREPARED_CACHE` problems).
* Points travel in **chunks** of a few points, one task each, through
  :func:`nlobs.simulate.executors.run_tasks`; whatever the order in which chunks finish, the result
  lists the points in grid order.
* A point whose evaluation raises an :class:`nlobs.errors.NlobsError` (an infeasible design, a
  diverged simulation) is a **failed point**: its values are ``None`` and its error is the
  exception's type and text. Any other exception is a bug and ends the sweep.

Example (the γ sweep of Grip, Saberi & Johansen, Sec. 3.2, is one such problem:
:func:`nlobs.workflows.gamma_sweep` with ``executor=``)::

    from nlobs.simulate.executors import cluster
    from nlobs.simulate.sweep import sweep

    with cluster(workers=4) as client:
        res = sweep(problem, {"pole": [-1.0, -2.0], "gain": [0.1, 1.0, 10.0]}, executor=client)
    print(res.summary())
"""

from __future__ import annotations

import itertools
import math
import numbers
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, Union, runtime_checkable

import numpy as np

from nlobs._io import jsonable
from nlobs._progress import Progress
from nlobs._typing import Array
from nlobs._validate import as_count, escape_unsafe, readonly
from nlobs.errors import InvalidArgumentError, NlobsError, UnknownNameError
from nlobs.simulate._prepared import PreparedCache
from nlobs.simulate.executors import IN_FLIGHT_PER_WORKER, connect, describe, run_tasks

__all__ = ["SweepProblem", "SweepResult", "sweep", "MAX_POINTS", "MAX_CHUNK", "PREPARED_CACHE"]

#: Most points one sweep evaluates (a Cartesian product is counted before it is built).
MAX_POINTS = 1_000_000
#: Most points per task when the chunk is chosen automatically.
MAX_CHUNK = 16
#: Prepared problems kept per process, by :meth:`SweepProblem.key`.
PREPARED_CACHE = 4
#: Rows :meth:`SweepResult.summary` shows before it elides the middle of the table.
SUMMARY_ROWS = 50

#: A value a problem returns for one point.
Value = Union[float, int, bool, str, None]

_CACHE = PreparedCache(PREPARED_CACHE)


@runtime_checkable
class SweepProblem(Protocol):
    """A design (or any computation) evaluated at one point of a parameter grid, deterministic given the point.

    A problem is a small picklable recipe; :meth:`prepare` builds the heavy objects once per process
    and :func:`sweep` keeps them per worker (by :meth:`key`).

    Examples
    --------
    Any class with these four members is a problem: here the slowest error mode of the observer
    ``A − L C`` of a double integrator with the gain ``L = (l1, l2)``, whose characteristic polynomial is
    ``s² + l1 s + l2`` (a double root at ``−l1/2`` when ``l2 = l1²/4``):

    >>> import numpy as np
    >>> class DoubleIntegrator:
    ...     name = "double integrator"
    ...     def key(self):
    ...         return "double integrator, y = position"
    ...     def prepare(self):  # once per process: A and C
    ...         return np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[1.0, 0.0]])
    ...     def evaluate(self, prepared, point):
    ...         A, C = prepared
    ...         L = np.array([[point["l1"]], [point["l2"]]])
    ...         return {"abscissa": round(float(np.linalg.eigvals(A - L @ C).real.max()), 4)}
    >>> isinstance(DoubleIntegrator(), SweepProblem)
    True
    >>> res = sweep(DoubleIntegrator(), {"l1": [2.0, 4.0], "l2": [1.0, 4.0]}, progress=False)
    >>> [(p["l1"], p["l2"]) for p in res.points], res.column("abscissa").tolist()
    ([(2.0, 1.0), (2.0, 4.0), (4.0, 1.0), (4.0, 4.0)], [-1.0, -1.0, -0.2679, -2.0])
    """

    @property
    def name(self) -> str:
        """Label of the problem (progress bar, summaries)."""
        ...

    def key(self) -> str:
        """A text that identifies what :meth:`prepare` builds: problems with equal keys share it in a process."""
        ...

    def prepare(self) -> Any:
        """Build what every point needs (called once per process)."""
        ...

    def evaluate(self, prepared: Any, point: Mapping[str, float]) -> Mapping[str, Value]:
        """The values at one point: names → numbers, flags, texts or ``None``."""
        ...


def prepared(problem: SweepProblem) -> Any:
    """``problem.prepare()``, built once per process and kept (:data:`PREPARED_CACHE` problems).

    Parameters
    ----------
    problem : SweepProblem
        The recipe; :meth:`SweepProblem.key` finds its prepared objects again.

    Returns
    -------
    object
        What :meth:`SweepProblem.prepare` returned, in this process.
    """
    return _CACHE.get(problem)


# ---------------------------------------------------------------------------------------------- the grid
def _number(where: str, v: Any) -> float:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise InvalidArgumentError(f"{where}: expected a real number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise InvalidArgumentError(f"{where}: must be finite, got {x!r}")
    return x


def _name(where: str, name: Any) -> str:
    if not isinstance(name, str) or not name:
        raise InvalidArgumentError(f"{where}: a parameter name must be a non-empty text, got {name!r}")
    return name


def _values_of(name: str, seq: Any) -> list[float]:
    where = f"grid[{name!r}]"
    if isinstance(seq, (str, bytes, Mapping)) or not hasattr(seq, "__iter__"):
        raise InvalidArgumentError(f"{where}: expected a sequence of numbers, got {type(seq).__name__}")
    if isinstance(seq, np.ndarray) and seq.ndim != 1:
        raise InvalidArgumentError(f"{where}: expected a 1-D sequence of numbers, got an array of shape {seq.shape}")
    vals = list(seq)
    if not vals:
        raise InvalidArgumentError(f"{where}: no values (every parameter needs at least one)")
    return [_number(f"{where}[{i}]", v) for i, v in enumerate(vals)]


def grid_points(grid: Mapping[str, Sequence[float]] | Sequence[Mapping[str, float]]
                ) -> tuple[tuple[str, ...], tuple[dict[str, float], ...]]:
    """The parameter names and the points of a grid, validated.

    Parameters
    ----------
    grid : mapping of str to sequence of float, or sequence of mapping of str to float
        A mapping is the Cartesian product of its values in row-major order of the mapping's order
        (the last name varies fastest); a sequence lists the points as given.

    Returns
    -------
    names : tuple of str
    points : tuple of dict
        Each ``name → float``.

    Raises
    ------
    InvalidArgumentError
        ``grid`` is empty, has a value that is not a finite real number, points with other keys than
        the first, or more than :data:`MAX_POINTS` points.
    """
    if isinstance(grid, Mapping):
        names = tuple(_name("grid", k) for k in grid)
        if not names:
            raise InvalidArgumentError("grid: no parameters (expected name → sequence of values)")
        axes = [_values_of(n, grid[n]) for n in names]
        count = math.prod(len(a) for a in axes)
        if count > MAX_POINTS:
            raise InvalidArgumentError(f"grid: the product of {' × '.join(str(len(a)) for a in axes)} values is "
                                       f"{count} points; at most {MAX_POINTS} are swept")
        return names, tuple(dict(zip(names, p)) for p in itertools.product(*axes))
    if isinstance(grid, (str, bytes)) or not hasattr(grid, "__iter__"):
        raise InvalidArgumentError(f"grid: expected a mapping name → values or a sequence of points, got "
                                   f"{type(grid).__name__}")
    raw = list(grid)
    if not raw:
        raise InvalidArgumentError("grid: no points")
    if len(raw) > MAX_POINTS:
        raise InvalidArgumentError(f"grid: {len(raw)} points; at most {MAX_POINTS} are swept")
    first = raw[0]
    if not isinstance(first, Mapping) or not first:
        raise InvalidArgumentError(f"grid[0]: expected a non-empty mapping name → value, got {first!r}")
    names = tuple(_name("grid[0]", k) for k in first)
    points = []
    for i, p in enumerate(raw):
        if not isinstance(p, Mapping):
            raise InvalidArgumentError(f"grid[{i}]: expected a mapping name → value, got {type(p).__name__}")
        if set(p) != set(names):
            missing, extra = sorted(set(names) - set(p), key=str), sorted(set(p) - set(names), key=str)
            raise InvalidArgumentError(f"grid[{i}]: every point needs the keys of the first, {list(names)}"
                                       + (f"; missing {missing}" if missing else "")
                                       + (f"; unexpected {extra}" if extra else ""))
        points.append({n: _number(f"grid[{i}][{n!r}]", p[n]) for n in names})
    return names, tuple(points)


# ---------------------------------------------------------------------------------------------- workers
def _value(problem: str, point: Mapping[str, float], name: str, v: Any) -> Value:
    if v is None or isinstance(v, (bool, str)):
        return v
    if isinstance(v, np.generic) and v.ndim == 0 and isinstance(v, (np.bool_, np.number, np.str_)):
        v = v.item()
        if isinstance(v, complex):
            raise InvalidArgumentError(f"{problem}: value {name!r} at {dict(point)} is complex ({v!r})")
        return v
    if isinstance(v, (int, float)):
        return v
    raise InvalidArgumentError(f"{problem}: value {name!r} at {dict(point)} is a {type(v).__name__}; expected a "
                               "float, int, bool, str or None")


def _clean(problem: SweepProblem, point: Mapping[str, float], out: Any) -> dict[str, Value]:
    if not isinstance(out, Mapping):
        raise InvalidArgumentError(f"{problem.name}: evaluate returned a {type(out).__name__} at {dict(point)}; "
                                   "expected a mapping name → value")
    clean: dict[str, Value] = {}
    for name, v in out.items():
        if not isinstance(name, str) or not name:
            raise InvalidArgumentError(f"{problem.name}: value name {name!r} at {dict(point)} is not a non-empty text")
        if name in point or name == "error":
            raise InvalidArgumentError(f"{problem.name}: value name {name!r} is a grid parameter or 'error'; the "
                                       "table holds the point, its values and its error side by side")
        clean[name] = _value(problem.name, point, name, v)
    return clean


def evaluate_chunk(problem: SweepProblem, record: tuple[type[BaseException], ...],
                   points: Sequence[Mapping[str, float]]) -> list[tuple[dict[str, Value] | None, str | None]]:
    """Evaluate some points of a sweep in this process: ``(values, None)`` or ``(None, "Type: text")`` each.

    Parameters
    ----------
    problem : SweepProblem
        Prepared once per process (:func:`prepared`).
    record : tuple of exception types
        Exceptions recorded as a failed point; any other propagates.
    points : sequence of mapping
        The points, in grid order.

    Returns
    -------
    list of (dict or None, str or None)
    """
    prep = prepared(problem)
    out: list[tuple[dict[str, Value] | None, str | None]] = []
    for p in points:
        try:
            res = problem.evaluate(prep, dict(p))
        except record as exc:
            out.append((None, f"{type(exc).__name__}: {exc}"))
            continue
        out.append((_clean(problem, p, res), None))
    return out


# ---------------------------------------------------------------------------------------------- the result
def _cell(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return "-" if math.isnan(v) else f"{v:.6g}"
    if isinstance(v, int):
        return str(v)
    return escape_unsafe(str(v), one_line=True)


@dataclass(frozen=True)
class SweepResult:
    """The values of a problem at every point of a grid, in grid order.

    Attributes
    ----------
    problem : str
        The problem's name.
    names : tuple of str
        The grid's parameters, in order.
    points : tuple of dict
        Each point, ``name → float``, in grid order.
    values : tuple of dict or None
        The values at each point (``None`` where it failed).
    errors : tuple of str or None
        ``"Type: text"`` of the error at each failed point, else ``None``.
    executor : str
        ``"in-process"``, ``"dask"`` or ``"executor"``.
    workers : int
        How many workers ran it.
    seconds : float
        Wall time of the sweep.
    chunk : int
        Points per task.

    Examples
    --------
    What :func:`sweep` returns, here written out for two points, the second failed:

    >>> res = SweepResult("demo", ("gamma",), ({"gamma": 1.0}, {"gamma": 0.1}), ({"gain": 4.0, "ok": True}, None),
    ...                   (None, "DesignInfeasible: γ = 0.1 is below the attainable level"), "in-process", 1, 0.0)
    >>> len(res), res.ok, res.failed, res.value_names
    (2, (True, False), 1, ('gain', 'ok'))
    >>> res.column("gain").tolist()[0], res.column("ok").tolist()[0]  # flags as 0/1, NaN where a point failed
    (4.0, 1.0)
    >>> res.table()[1]
    {'gamma': 0.1, 'gain': None, 'ok': None, 'error': 'DesignInfeasible: γ = 0.1 is below the attainable level'}
    """

    problem: str
    names: tuple[str, ...]
    points: tuple[dict[str, float], ...]
    values: tuple[dict[str, Value] | None, ...]
    errors: tuple[str | None, ...]
    executor: str
    workers: int
    seconds: float
    chunk: int = 1

    def __len__(self) -> int:
        return len(self.points)

    @property
    def ok(self) -> tuple[bool, ...]:
        """Whether each point was evaluated (no error)."""
        return tuple(e is None for e in self.errors)

    @property
    def failed(self) -> int:
        """Number of failed points."""
        return sum(e is not None for e in self.errors)

    @property
    def value_names(self) -> tuple[str, ...]:
        """Every value name any point returned, in order of first appearance."""
        seen: dict[str, None] = {}
        for v in self.values:
            if v is not None:
                seen.update(dict.fromkeys(v))
        return tuple(seen)

    def table(self) -> list[dict[str, Any]]:
        """One dict per point, in grid order: its parameters, its values (absent ones ``None``) and ``error``."""
        vn = self.value_names
        rows = []
        for p, v, e in zip(self.points, self.values, self.errors):
            row: dict[str, Any] = dict(p)
            row.update({n: (v or {}).get(n) for n in vn})
            row["error"] = e
            rows.append(row)
        return rows

    def column(self, name: str) -> Array:
        """One parameter or value over the points, as floats (NaN at failed points and for ``None``; flags 0/1).

        Parameters
        ----------
        name : str
            A grid parameter or a value name.

        Returns
        -------
        ndarray, shape (points,)
            Read-only.

        Raises
        ------
        UnknownNameError
            ``name`` is neither a parameter nor a value.
        InvalidArgumentError
            The value is a text.
        """
        if name in self.names:
            return readonly(np.array([p[name] for p in self.points], dtype=float), owned=True)
        if name not in self.value_names:
            raise UnknownNameError(f"column {name!r}: not a parameter ({list(self.names)}) nor a value "
                                   f"({list(self.value_names)})")
        out = np.full(len(self.points), math.nan)
        for i, v in enumerate(self.values):
            x = None if v is None else v.get(name)
            if isinstance(x, str):
                raise InvalidArgumentError(f"column {name!r}: holds text ({x!r} at point {i}), not numbers")
            if x is not None:
                out[i] = float(x)
        return readonly(out, owned=True)

    def to_dict(self) -> dict[str, Any]:
        """Plain values (JSON-ready, non-finite numbers as ``None``): the set-up, how it ran, and every row."""
        return jsonable({"problem": self.problem, "names": list(self.names), "points": len(self.points),
                         "failed": self.failed, "executor": self.executor, "workers": self.workers,
                         "chunk": self.chunk, "seconds": self.seconds, "values": list(self.value_names),
                         "rows": self.table()})

    def summary(self) -> str:
        """A plain-text table: one line per point (the middle elided past :data:`SUMMARY_ROWS`), errors last."""
        n = len(self.points)
        head = [f"{escape_unsafe(self.problem, one_line=True)}: {n} point{'s' if n != 1 else ''} on {self.executor} "
                f"({self.workers} worker{'s' if self.workers != 1 else ''}), {self.failed} failed, "
                f"{self.seconds:.2f} s"]
        cols = [*self.names, *self.value_names]
        shown = list(range(n)) if n <= SUMMARY_ROWS else [*range(SUMMARY_ROWS // 2), *range(n - SUMMARY_ROWS // 2, n)]
        rows = self.table()
        body = [[_cell(rows[i][c]) for c in cols] + ["ok" if rows[i]["error"] is None else "failed"] for i in shown]
        titles = [escape_unsafe(c, one_line=True) for c in cols] + ["status"]
        widths = [max(len(t), *(len(b[j]) for b in body)) for j, t in enumerate(titles)]
        lines = head + ["  ".join(t.rjust(w) for t, w in zip(titles, widths))]
        for k, (i, b) in enumerate(zip(shown, body)):
            if k and shown[k - 1] != i - 1:
                lines.append(f"  … {i - shown[k - 1] - 1} points …")
            lines.append("  ".join(c.rjust(w) for c, w in zip(b, widths)))
        for i, e in enumerate(self.errors):
            if e is not None:
                where = ", ".join(f"{escape_unsafe(k, one_line=True)} = {v:.6g}" for k, v in self.points[i].items())
                lines.append(f"  {where}: {escape_unsafe(e, one_line=True)}")
        return "\n".join(lines)


# ---------------------------------------------------------------------------------------------- the sweep
def _as_record(record: Any) -> tuple[type[BaseException], ...]:
    items = record if isinstance(record, tuple) else (record,)
    if not all(isinstance(c, type) and issubclass(c, BaseException) for c in items):
        raise InvalidArgumentError(f"record: expected an exception class or a tuple of them, got {record!r}")
    return items


def sweep(problem: SweepProblem, grid: Mapping[str, Sequence[float]] | Sequence[Mapping[str, float]], *,
          executor: Any = None, progress: bool | None = None, chunk: int | None = None,
          record: type[BaseException] | tuple[type[BaseException], ...] = NlobsError) -> SweepResult:
    """Evaluate ``problem`` at every point of ``grid``, here or on Dask, and return the values in grid order.

    Parameters
    ----------
    problem : SweepProblem
        ``name``, ``key()``, ``prepare()`` (once per process) and ``evaluate(prepared, point)``.
    grid : mapping of str to sequence of float, or sequence of mapping of str to float
        ``{"a": [1, 2], "b": [10, 20, 30]}`` is the Cartesian product in row-major order (``b`` varies
        fastest: ``(1, 10), (1, 20), …, (2, 30)``); a sequence of mappings lists the points as given
        (every one with the same keys). Values are finite real numbers, passed to ``evaluate`` as floats.
    executor : None, dask.distributed.Client, str or concurrent.futures.Executor
        Where the chunks run (:mod:`nlobs.simulate.executors`; ``None``: this process). A Dask client
        receives ``problem`` once per worker.
    progress : bool, optional
        A progress bar over evaluated points (``None``: automatic).
    chunk : int, optional
        Points per task (default: a quarter of the points per worker, at most :data:`MAX_CHUNK`).
    record : exception class or tuple of them
        What a failed point is: such an exception from ``evaluate`` is recorded with its type and text
        (default :class:`~nlobs.errors.NlobsError`, e.g. ``DesignInfeasible``); any other propagates.
        ``()`` records nothing.

    Returns
    -------
    SweepResult

    Raises
    ------
    InvalidArgumentError
        A bad grid (empty, a non-finite or non-numeric value, points with other keys), a problem that
        is not a :class:`SweepProblem`, a bad ``chunk``, or values that are not name → scalar.

    Examples
    --------
    The H∞ norm of ``G(s) = c b / (s − a)`` (``c b / |a|``) over three poles; the unstable one is a
    failed point, recorded with its error, and the sweep goes on:

    >>> import numpy as np
    >>> from nlobs.errors import DesignInfeasible
    >>> from nlobs.linear import hinf_norm
    >>> class FirstOrder:
    ...     name = "first order"
    ...     def key(self):
    ...         return "first order, b = 2, c = 1.5"
    ...     def prepare(self):  # once per process: B and C
    ...         return np.array([[2.0]]), np.array([[1.5]])
    ...     def evaluate(self, prepared, point):
    ...         a = point["a"]
    ...         if a >= 0:
    ...             raise DesignInfeasible(f"pole a = {a:g} is not in the open left half-plane")
    ...         B, C = prepared
    ...         return {"hinf": round(float(hinf_norm(np.array([[a]]), B, C, np.zeros((1, 1)))), 6)}
    >>> res = sweep(FirstOrder(), {"a": [-1.0, -4.0, 0.5]}, progress=False)
    >>> res.ok, res.column("hinf").tolist()[:2], res.errors[2]
    ((True, True, False), [3.0, 0.75], 'DesignInfeasible: pole a = 0.5 is not in the open left half-plane')
    >>> print(res.summary())
    first order: 3 points on in-process (1 worker), 1 failed, ... s
      a  hinf  status
     -1     3      ok
     -4  0.75      ok
    0.5     -  failed
      a = 0.5: DesignInfeasible: pole a = 0.5 is not in the open left half-plane
    """
    if isinstance(executor, str):
        client = connect(executor)
        try:
            return sweep(problem, grid, executor=client, progress=progress, chunk=chunk, record=record)
        finally:
            client.close()
    if not isinstance(problem, SweepProblem):
        raise InvalidArgumentError(f"problem: expected a SweepProblem (name, key, prepare, evaluate), got "
                                   f"{type(problem).__name__}")
    rec = _as_record(record)
    names, points = grid_points(grid)
    n = len(points)
    kind, workers = describe(executor)
    if chunk is None:
        size = max(1, min(MAX_CHUNK, -(-n // (2 * IN_FLIGHT_PER_WORKER * workers))))
    else:
        size = as_count("chunk", chunk, minimum=1)
    bounds = [(a, min(a + size, n)) for a in range(0, n, size)]
    values: list[dict[str, Value] | None] = [None] * n
    errors: list[str | None] = [None] * n
    t0 = time.perf_counter()
    finished = [0]
    with Progress(n, progress, f"{problem.name}: points") as bar:

        def done(i: int, res: list[tuple[dict[str, Value] | None, str | None]]) -> None:
            a, b = bounds[i]
            if len(res) != b - a:  # pragma: no cover - a worker of another nlobs version
                raise InvalidArgumentError(f"{problem.name}: a chunk of {b - a} points returned {len(res)} results")
            for k, (v, e) in enumerate(res):
                values[a + k], errors[a + k] = v, e
            finished[0] += b - a
            bar.update(finished[0])

        run_tasks(executor, evaluate_chunk, problem, [(rec, points[a:b]) for a, b in bounds], done)
    return SweepResult(problem.name, names, points, tuple(values), tuple(errors), kind, workers,
                       time.perf_counter() - t0, size)
