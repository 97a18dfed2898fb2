r"""Monte Carlo studies in chunks: in this process or on Dask, streamed to disk, resumable, seed-exact.

One entry, :func:`monte_carlo`, runs any :class:`Study` (a plant with an observer, the set-valued
study of Khajenejad & Yong, the GNSS/INS flights of Grip, Saberi & Johansen) for ``runs`` runs.

How the numbers are made, so that they never depend on where they ran:

* runs are computed in **batches** of ``batch`` runs along the batch axis; batch ``k`` holds runs
  ``k·batch … (k + 1)·batch − 1`` and draws all its randomness from its own generator,
  ``numpy.random.default_rng(SeedSequence(seed, spawn_key=(k,)))`` (the ``k``-th child of
  ``SeedSequence(seed).spawn``); the last batch is computed at full width too and cut, so run ``i``
  depends only on ``seed``, ``batch`` and ``i``;
* a **chunk** of ``chunk`` runs is the unit of work sent to a worker and of the files written; a chunk
  computes the batches it overlaps (choose ``chunk`` a multiple of ``batch`` so no batch is computed twice).

Hence one process, one worker, two workers, any chunk size: the same bits. Per-run **summaries**
(metrics, containment, certificate coverage) come back to this process; full **trajectories** are
written only when asked (``trajectories=True`` with ``out``), one ``.npz`` per chunk, atomically, so
memory stays flat as runs grow. With ``out``, every finished chunk is a file, and a run started again
on the same folder (after a crash, Ctrl-C or ``kill -9``) skips the chunks already there.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from nlobs._io import atomic_write, atomic_write_json, jsonable
from nlobs._progress import Progress
from nlobs._typing import Array
from nlobs._validate import as_count, readonly
from nlobs.errors import InvalidArgumentError, OutputError
from nlobs.simulate.executors import connect, describe, run_tasks

#: Format of the folder a study writes (``montecarlo.json``), checked when a run resumes.
FORMAT = 1
#: Runs per chunk by default: this many batches.
BATCHES_PER_CHUNK = 1
#: Prepared studies kept per process (designs, compiled functions, a flight), by :meth:`Study.key`.
PREPARED_CACHE = 4


@dataclass(frozen=True)
class RunBatch:
    """What one batch of runs returns.

    Attributes
    ----------
    summaries : mapping of str to ndarray
        Per-run values, each of shape ``(runs, ...)`` (a final error, a containment flag, whether the
        certificate covers the run).
    trajectories : mapping of str to ndarray
        Per-run records, each ``(runs, ...)``; only when they were asked for, else empty.

    Examples
    --------
    What :meth:`PlantStudy.run <nlobs.simulate.PlantStudy.run>` returns for a batch of four runs of ``ẋ = −x``
    with a Luenberger observer: one row per run in every summary and every record:

    >>> import numpy as np
    >>> from nlobs import LinearSystem, LuenbergerObserver
    >>> from nlobs.simulate import PlantStudy
    >>> plant = LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
    >>> study = PlantStudy("scalar, L = 3", plant, LuenbergerObserver(plant, [[3.0]]), [1.0], [1.0], 0.5,
    ...                    duration=1.0, dt=1e-2)
    >>> out = study.run(study.prepare(), np.random.default_rng(0), 4, trajectories=True)
    >>> sorted(out.summaries), out.summaries["rms_error"].shape, out.trajectories["x_hat"].shape
    (['diverged', 'final_error', 'rms_error'], (4, 1), (4, 101, 1))

    A study whose batch does not give one row per run is refused by :func:`monte_carlo`:

    >>> class OneNumber:
    ...     name = "one number"
    ...     def key(self):
    ...         return "one number"
    ...     def prepare(self):
    ...         return None
    ...     def run(self, prepared, rng, runs, trajectories):
    ...         return RunBatch({"mean": np.array([rng.standard_normal(runs).mean()])})
    >>> try:
    ...     monte_carlo(OneNumber(), 4)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError one number: summary 'mean' has shape (1,), expected (4, ...)
    """

    summaries: Mapping[str, Array]
    trajectories: Mapping[str, Array] = field(default_factory=dict)


@runtime_checkable
class Study(Protocol):
    """A Monte Carlo study: what one batch of runs computes, deterministic given its generator.

    A study is a small picklable recipe; :meth:`prepare` builds the heavy objects (a design, compiled
    functions, a flight) once per process and :func:`monte_carlo` keeps them per worker.

    Examples
    --------
    Any class with these four members is a study: here each run averages ten samples of ``1 + N(0, 0.5²)``, whose
    error has the standard deviation ``0.5/√10 ≈ 0.158``. The numbers depend on ``seed`` and ``batch``, not on the
    chunks:

    >>> import numpy as np
    >>> class MeanOfTen:
    ...     name = "mean of ten samples"
    ...     def key(self):
    ...         return "mean of 10 samples of 1 + N(0, 0.5^2)"
    ...     def prepare(self):
    ...         return None
    ...     def run(self, prepared, rng, runs, trajectories):
    ...         y = 1.0 + 0.5 * rng.standard_normal((runs, 10))
    ...         return RunBatch({"error": y.mean(axis=1) - 1.0}, {"y": y} if trajectories else {})
    >>> isinstance(MeanOfTen(), Study)
    True
    >>> res = monte_carlo(MeanOfTen(), 2000, batch=500)
    >>> res.summaries["error"].shape, round(float(res.summaries["error"].std()), 2)
    ((2000,), 0.16)
    >>> same_results(res, monte_carlo(MeanOfTen(), 2000, batch=500, chunk=1000))
    True
    """

    @property
    def name(self) -> str:
        """Label of the study (progress bar, summaries)."""
        ...

    def key(self) -> str:
        """A text that identifies the study's recipe: a resumed run refuses a folder of another study."""
        ...

    def prepare(self) -> Any:
        """Build what every batch needs (called once per process)."""
        ...

    def run(self, prepared: Any, rng: np.random.Generator, runs: int, trajectories: bool) -> RunBatch:
        """Compute ``runs`` runs drawing every random number from ``rng``."""
        ...


_PREPARED: dict[str, Any] = {}


def prepared(study: Study) -> Any:
    """``study.prepare()``, built once per process and kept (:data:`PREPARED_CACHE` studies)."""
    key = hashlib.sha256(study.key().encode()).hexdigest()
    if key not in _PREPARED:
        if len(_PREPARED) >= PREPARED_CACHE:
            _PREPARED.pop(next(iter(_PREPARED)))
        _PREPARED[key] = study.prepare()
    return _PREPARED[key]


def batch_rng(seed: int, k: int) -> np.random.Generator:
    """The generator of batch ``k``: ``default_rng(SeedSequence(seed, spawn_key=(k,)))``."""
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(int(k),)))


def _checked(out: RunBatch, width: int, what: str) -> RunBatch:
    for kind, table in (("summary", out.summaries), ("trajectory", out.trajectories)):
        for name, a in table.items():
            arr = np.asarray(a)
            if arr.ndim < 1 or arr.shape[0] != width:
                raise InvalidArgumentError(f"{what}: {kind} {name!r} has shape {arr.shape}, expected ({width}, ...)")
    return out


def run_chunk(study: Study, seed: int, batch: int, start: int, stop: int, trajectories: bool
              ) -> tuple[dict[str, Array], dict[str, Array]]:
    """Runs ``start … stop − 1`` of a study: the batches they overlap, computed whole and cut.

    Returns ``(summaries, trajectories)``, each name → ``(stop − start, ...)``.
    """
    prep = prepared(study)
    parts_s: list[dict[str, Array]] = []
    parts_t: list[dict[str, Array]] = []
    for k in range(start // batch, (stop - 1) // batch + 1):
        out = _checked(study.run(prep, batch_rng(seed, k), batch, trajectories), batch, study.name)
        lo, hi = max(start - k * batch, 0), min(stop - k * batch, batch)
        parts_s.append({n: np.asarray(a)[lo:hi] for n, a in out.summaries.items()})
        parts_t.append({n: np.asarray(a)[lo:hi] for n, a in out.trajectories.items()} if trajectories else {})
    summ = {n: np.concatenate([p[n] for p in parts_s]) for n in parts_s[0]}
    traj = {n: np.concatenate([p[n] for p in parts_t]) for n in parts_t[0]} if trajectories else {}
    return summ, traj


@dataclass(frozen=True)
class MonteCarloResult:
    """The per-run summaries of a study, in run order, and where its files are.

    Attributes
    ----------
    study : str
        The study's name.
    runs, seed, batch, chunk : int
        As given (``batch`` and ``seed`` fix the numbers; ``chunk`` only how they were split).
    summaries : dict of str to ndarray
        Per-run values, each ``(runs, ...)``, read-only.
    chunks : int
        Number of chunks; ``resumed_chunks`` of them were read back from ``out``.
    resumed_chunks : int
    executor : str
        ``"in-process"``, ``"dask"`` or ``"executor"``; ``workers`` how many ran it.
    workers : int
    seconds : float
        Wall time of this call.
    out : Path or None
        The folder of the chunk files (``montecarlo.json``, ``chunks/chunk-NNNNNN.npz``).
    trajectory_names : tuple of str
        The records saved per chunk (empty unless trajectories were asked for).

    Examples
    --------
    Twenty runs of ``ẋ = −x`` with a Luenberger observer, written to a folder in chunks of eight: the per-run
    summaries, their statistics, the chunk files and the records read back; the same call again finds every
    chunk done and reads them instead of running them:

    >>> import tempfile
    >>> import numpy as np
    >>> from nlobs import LinearSystem, LuenbergerObserver
    >>> from nlobs.simulate import PlantStudy
    >>> plant = LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
    >>> study = PlantStudy("scalar, L = 3", plant, LuenbergerObserver(plant, [[3.0]]), [1.0], [1.0], 0.5,
    ...                    duration=1.0, dt=1e-2)
    >>> folder = tempfile.mkdtemp()
    >>> res = monte_carlo(study, 20, batch=8, out=folder, trajectories=True)
    >>> res.runs, res.chunks, res.resumed_chunks, res.executor, res.workers, res.trajectory_names
    (20, 3, 0, 'in-process', 1, ('x', 'x_hat'))
    >>> [path.name for path in res.chunk_files()]
    ['chunk-000000.npz', 'chunk-000001.npz', 'chunk-000002.npz']
    >>> res.trajectories("x_hat", slice(5, 10)).shape
    (5, 101, 1)
    >>> e0 = res.trajectories("x_hat")[:, 0, 0] - 1.0  # each run's initial error, decaying as e^{−4t}
    >>> bool(np.allclose(res.summaries["final_error"], np.abs(e0) * np.exp(-4.0), rtol=1e-5))
    True
    >>> stats = res.statistics()["final_error"]
    >>> bool(stats["min"] <= stats["mean"] <= stats["max"]), stats["non_finite"]
    (True, 0)
    >>> print(res.summary())
    scalar, L = 3: 20 runs (seed 0, batch 8, chunk 8); 3 chunks on in-process (1 worker), ... s
      rms_error: mean ...
      final_error: mean ...
      diverged: mean 0, range [0, 0]
    >>> again = monte_carlo(study, 20, batch=8, out=folder, trajectories=True)
    >>> again.resumed_chunks, same_results(res, again)
    (3, True)
    """

    study: str
    runs: int
    seed: int
    batch: int
    chunk: int
    summaries: dict[str, Array] = field(repr=False)
    chunks: int
    resumed_chunks: int
    executor: str
    workers: int
    seconds: float
    out: Path | None = None
    trajectory_names: tuple[str, ...] = ()

    def chunk_files(self) -> list[Path]:
        """The chunk files, in run order (empty without ``out``)."""
        if self.out is None:
            return []
        return [chunk_path(self.out, c) for c in range(self.chunks)]

    def trajectories(self, name: str, runs: slice | None = None) -> Array:
        """One saved record, ``(runs, ...)``, read from the chunk files (``runs``: a slice of run indices).

        Raises
        ------
        InvalidArgumentError
            No trajectories were saved, or ``name`` is not one of :attr:`trajectory_names`.
        """
        if name not in self.trajectory_names:
            raise InvalidArgumentError(f"trajectory {name!r}: saved are {list(self.trajectory_names) or 'none'} "
                                       "(run with trajectories=True and an output folder)")
        sel = range(self.runs)[runs if runs is not None else slice(None)]
        if len(sel) == 0:
            raise InvalidArgumentError(f"runs {runs!r}: selects no run of {self.runs}")
        lo, hi = min(sel), max(sel) + 1
        parts = []
        for c in range(lo // self.chunk, (hi - 1) // self.chunk + 1):
            with np.load(chunk_path(self.out, c)) as f:  # type: ignore[arg-type]
                parts.append(f["trajectory__" + name])
        whole = np.concatenate(parts)
        first = (lo // self.chunk) * self.chunk
        return whole[[i - first for i in sel]]

    def statistics(self) -> dict[str, dict[str, float]]:
        """Per numeric summary: ``mean``, ``min``, ``max`` over runs and values (NaN-aware), and the count of
        non-finite values; a flag's ``mean`` is the fraction of runs where it holds."""
        out: dict[str, dict[str, float]] = {}
        for name, a in self.summaries.items():
            if a.dtype.kind not in "biuf":
                continue  # text (a run's first violation, say): per run only
            v = np.asarray(a, dtype=float).reshape(-1)
            fin = v[np.isfinite(v)]
            out[name] = {"mean": float(fin.mean()) if fin.size else math.nan,
                         "min": float(fin.min()) if fin.size else math.nan,
                         "max": float(fin.max()) if fin.size else math.nan,
                         "non_finite": int(v.size - fin.size)}
        return out

    def to_dict(self) -> dict[str, Any]:
        """Plain values: the set-up, how it ran, and the statistics of every summary."""
        return {"study": self.study, "runs": self.runs, "seed": self.seed, "batch": self.batch, "chunk": self.chunk,
                "chunks": self.chunks, "resumed_chunks": self.resumed_chunks, "executor": self.executor,
                "workers": self.workers, "seconds": self.seconds, "out": None if self.out is None else str(self.out),
                "trajectories": list(self.trajectory_names), "statistics": jsonable(self.statistics())}

    def summary(self) -> str:
        """A few lines: set-up, where it ran, and each summary's mean and range."""
        lines = [f"{self.study}: {self.runs} runs (seed {self.seed}, batch {self.batch}, chunk {self.chunk}); "
                 f"{self.chunks} chunks on {self.executor} ({self.workers} worker{'s' if self.workers != 1 else ''})"
                 + (f", {self.resumed_chunks} resumed from {self.out}" if self.resumed_chunks else "")
                 + f", {self.seconds:.2f} s"]
        for name, st in self.statistics().items():
            extra = f", {st['non_finite']} non-finite" if st["non_finite"] else ""
            lines.append(f"  {name}: mean {st['mean']:.6g}, range [{st['min']:.6g}, {st['max']:.6g}]{extra}")
        return "\n".join(lines)


def chunk_path(out: Path, c: int) -> Path:
    """``out/chunks/chunk-NNNNNN.npz``, the file of chunk ``c``."""
    return Path(out) / "chunks" / f"chunk-{c:06d}.npz"


def _manifest(study: Study, runs: int, seed: int, batch: int, chunk: int, trajectories: bool) -> dict[str, Any]:
    from importlib.metadata import PackageNotFoundError, version

    try:
        v = version("nlobs")
    except PackageNotFoundError:  # a source tree that was never installed
        v = "0+unknown"
    return {"format": FORMAT, "study": study.name, "key": hashlib.sha256(study.key().encode()).hexdigest(),
            "runs": runs, "seed": seed, "batch": batch, "chunk": chunk, "trajectories": trajectories, "nlobs": v}


def _open_folder(out: Path, manifest: dict[str, Any], resume: bool) -> None:
    mf = out / "montecarlo.json"
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{out}: cannot create the output folder ({exc.strerror or exc})") from exc
    if not out.is_dir():
        raise OutputError(f"{out}: not a folder")
    if mf.exists():
        try:
            old = json.loads(mf.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise OutputError(f"{mf}: not a Monte Carlo folder nlobs can read ({exc})") from exc
        if not resume:
            raise InvalidArgumentError(f"{out} already holds a Monte Carlo run; resume it or choose another folder")
        for k in ("format", "key", "seed", "batch", "chunk", "trajectories"):
            if old.get(k) != manifest[k]:
                what = "the study (model, observer or options)" if k == "key" else k
                raise InvalidArgumentError(f"{out}: holds a run with another {what} ({old.get(k)!r} there, "
                                           f"{manifest[k]!r} now); choose another folder to start a new one")
    elif any((out / "chunks").glob("chunk-*.npz")):
        raise InvalidArgumentError(f"{out}: holds chunk files without montecarlo.json; choose another folder")
    try:
        atomic_write_json(mf, manifest)
    except OSError as exc:
        raise OutputError(f"{mf}: cannot write ({exc.strerror or exc})") from exc


def _chunk_digest(data: dict[str, Array]) -> str:
    """SHA-256 of a chunk's arrays: each name, dtype, shape and bytes, in name order (``digest`` itself left out)."""
    h = hashlib.sha256()
    for k in sorted(data):
        if k == "digest":
            continue
        a = np.ascontiguousarray(data[k])
        h.update(f"{k}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _read_chunk(path: Path, start: int, stop: int, trajectories: bool = False) -> dict[str, Array] | None:
    """A finished chunk's summaries, or ``None`` when the file is absent or not exactly the chunk it was written as.

    The file must open (a truncated, empty or garbage file does not), hold ``runs = [start, stop]``, summaries (and,
    when asked, trajectories) of ``stop − start`` rows each, and the digest written with it; anything else is
    computed again (and the file written anew).
    """
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as f:
            data = {k: f[k] for k in f.files}
    except Exception:  # noqa: BLE001 - a damaged file of any kind (BadZipFile, EOFError, ValueError, OSError…)
        return None
    runs = data.get("runs")
    if runs is None or runs.shape != (2,) or list(runs) != [start, stop] or "digest" not in data:
        return None
    if str(data["digest"]) != _chunk_digest(data):
        return None
    summ = {k[len("summary__"):]: v for k, v in data.items() if k.startswith("summary__")}
    rows = [v for k, v in data.items() if k.startswith("summary__") or (trajectories and k.startswith("trajectory__"))]
    if not summ or any(v.ndim == 0 or v.shape[0] != stop - start for v in rows):
        return None
    if trajectories and not any(k.startswith("trajectory__") for k in data):
        return None
    return summ


def _write_chunk(path: Path, start: int, stop: int, summ: dict[str, Array], traj: dict[str, Array]) -> None:
    data = {"runs": np.array([start, stop])}
    data.update({"summary__" + k: v for k, v in summ.items()})
    data.update({"trajectory__" + k: v for k, v in traj.items()})
    data["digest"] = np.array(_chunk_digest(data))
    try:
        atomic_write(path, lambda fh: np.savez(fh, **data))
    except OSError as exc:
        raise OutputError(f"{path}: cannot write ({exc.strerror or exc})") from exc


def same_results(a: MonteCarloResult, b: MonteCarloResult) -> bool:
    """Whether two results hold the same summaries, bit for bit (NaN equal to NaN)."""
    if a.summaries.keys() != b.summaries.keys():
        return False
    for k, x in a.summaries.items():
        y = b.summaries[k]
        if x.dtype != y.dtype or x.shape != y.shape:
            return False
        if x.dtype.kind in "fc":
            if not np.array_equal(x.view(np.uint8), y.view(np.uint8)):
                return False
        elif not np.array_equal(x, y):
            return False
    return True


def monte_carlo(study: Study, runs: int, *, seed: int = 0, batch: int | None = None, chunk: int | None = None,
                executor: Any = None, out: str | Path | None = None, trajectories: bool = False,
                resume: bool = True, progress: bool | None = None) -> MonteCarloResult:
    """Run ``runs`` runs of ``study`` in chunks, here or on Dask, with results independent of the split.

    Parameters
    ----------
    study : Study
        What a batch of runs computes (:class:`nlobs.simulate.PlantStudy`,
        :class:`nlobs.simulate.SetValuedStudy`, :class:`nlobs.navigation.GnssInsStudy`, or your own).
    runs : int
        Number of runs (``>= 1``).
    seed : int
        Root of every batch's :class:`numpy.random.SeedSequence` (module docstring).
    batch : int, optional
        Runs computed together along the batch axis and drawn from one stream (default: the study's
        ``default_batch``, at most ``runs``). Part of what fixes the numbers, with ``seed``.
    chunk : int, optional
        Runs per task and per file (default: one batch). Any size gives the same numbers.
    executor : None, dask.distributed.Client, str or concurrent.futures.Executor
        Where chunks run (:mod:`nlobs.simulate.executors`; ``None``: this process).
    out : path, optional
        Folder for the chunk files and ``montecarlo.json``; a run on a folder of the same study resumes.
    trajectories : bool
        Also save each run's records per chunk (needs ``out``).
    resume : bool
        Skip the chunks ``out`` already holds (``False``: refuse a folder that holds a run).
    progress : bool, optional
        A progress bar over finished runs (``None``: automatic).

    Returns
    -------
    MonteCarloResult

    Raises
    ------
    InvalidArgumentError
        A bad count, trajectories without ``out``, or a folder of another study.
    OutputError
        ``out`` cannot be written.

    Examples
    --------
    Twenty runs of ``ẋ = −x`` with the Luenberger gain 3, so that ``ė = −4e``, from initial estimates drawn
    about the truth with standard deviation 0.5, in batches of 8: every run's error after 1 s is its initial
    error times ``e⁻⁴``, and another split into chunks gives the same bits:

    >>> import tempfile
    >>> import numpy as np
    >>> from nlobs import LinearSystem, LuenbergerObserver
    >>> from nlobs.simulate import PlantStudy
    >>> plant = LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
    >>> study = PlantStudy("scalar, L = 3", plant, LuenbergerObserver(plant, [[3.0]]), [1.0], [1.0], 0.5,
    ...                    duration=1.0, dt=1e-3, default_batch=8)
    >>> res = monte_carlo(study, 20, out=tempfile.mkdtemp(), trajectories=True)
    >>> res.runs, res.batch, res.chunks, res.summaries["final_error"].shape, bool(res.summaries["diverged"].any())
    (20, 8, 3, (20,), False)
    >>> e0 = res.trajectories("x_hat")[:, 0, 0] - 1.0  # read back from the chunk files
    >>> bool(np.allclose(res.summaries["final_error"], np.abs(e0) * np.exp(-4.0), rtol=1e-9))
    True
    >>> same_results(res, monte_carlo(study, 20, chunk=3))
    True
    """
    if isinstance(executor, str):
        client = connect(executor)
        try:
            return monte_carlo(study, runs, seed=seed, batch=batch, chunk=chunk, executor=client, out=out,
                               trajectories=trajectories, resume=resume, progress=progress)
        finally:
            client.close()
    if not isinstance(study, Study):
        raise InvalidArgumentError(f"study: expected a Study (name, key, prepare, run), got {type(study).__name__}")
    runs_ = as_count("`runs`", runs, minimum=1)
    seed_ = as_count("`seed`", seed)
    default = int(getattr(study, "default_batch", 256))
    batch_ = min(as_count("`batch`", batch, minimum=1) if batch is not None else default, runs_)
    chunk_ = min(as_count("`chunk`", chunk, minimum=1) if chunk is not None else batch_ * BATCHES_PER_CHUNK, runs_)
    if trajectories and out is None:
        raise InvalidArgumentError("`trajectories`: saving them needs an output folder (`out`)")
    folder = None if out is None else Path(out)
    n_chunks = -(-runs_ // chunk_)
    bounds = [(c * chunk_, min((c + 1) * chunk_, runs_)) for c in range(n_chunks)]
    t0 = time.perf_counter()
    results: list[dict[str, Array] | None] = [None] * n_chunks
    resumed = 0
    if folder is not None:
        _open_folder(folder, _manifest(study, runs_, seed_, batch_, chunk_, trajectories), resume)
        for c, (a, b) in enumerate(bounds):
            results[c] = _read_chunk(chunk_path(folder, c), a, b, trajectories)
            resumed += results[c] is not None
    todo = [c for c in range(n_chunks) if results[c] is None]
    kind, workers = describe(executor)
    finished = [sum(b - a for c, (a, b) in enumerate(bounds) if results[c] is not None)]
    with Progress(runs_, progress, f"{study.name}: runs") as bar:
        bar.update(finished[0])

        def done(i: int, res: tuple[dict[str, Array], dict[str, Array]]) -> None:
            c = todo[i]
            summ, traj = res
            if folder is not None:
                _write_chunk(chunk_path(folder, c), *bounds[c], summ, traj)
            results[c] = summ
            finished[0] += bounds[c][1] - bounds[c][0]
            bar.update(finished[0])

        run_tasks(executor, run_chunk, study, [(seed_, batch_, *bounds[c], trajectories) for c in todo], done)
    names = list(results[0])  # type: ignore[arg-type]
    summaries = {n: readonly(np.concatenate([r[n] for r in results]), dtype=None, owned=True)  # type: ignore[index]
                 for n in names}
    traj_names: tuple[str, ...] = ()
    if trajectories and folder is not None:
        with np.load(chunk_path(folder, 0)) as f:
            traj_names = tuple(k[len("trajectory__"):] for k in f.files if k.startswith("trajectory__"))
    return MonteCarloResult(study.name, runs_, seed_, batch_, chunk_, summaries, n_chunks, resumed, kind, workers,
                            time.perf_counter() - t0, folder, traj_names)
