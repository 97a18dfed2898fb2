"""Where Monte Carlo chunks and sweep points run: in this process, or on a Dask cluster.

An *executor* is ``None`` (this process, nothing to install), a ``dask.distributed.Client``, the
address of a running Dask scheduler (``"tcp://host:8786"``, connected for the call and closed after),
or any :class:`concurrent.futures.Executor`. :func:`cluster` starts a ``LocalCluster`` of ``workers``
single-threaded processes, or connects to ``scheduler`` (the ``workers`` and ``scheduler`` of the workflows
and of the command line). Dask is the optional extra ``nlobs[dask]``.
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Callable, Iterable, Iterator
from typing import Any

from nlobs.errors import InvalidArgumentError

#: Tasks kept in flight per worker: enough to keep every worker busy, few enough that results do not pile up.
IN_FLIGHT_PER_WORKER = 2


def _dask() -> Any:
    try:
        import distributed
    except ImportError as exc:  # pragma: no cover - the extra is installed by `make test`
        raise InvalidArgumentError("a Dask executor needs the optional extra: pip install 'nlobs[dask]'") from exc
    return distributed


def is_dask_client(executor: Any) -> bool:
    """Whether ``executor`` is a ``dask.distributed.Client`` (checked without importing Dask)."""
    return type(executor).__module__.startswith("distributed") and hasattr(executor, "scheduler_info")


@contextlib.contextmanager
def cluster(workers: int | None = None, scheduler: str | None = None) -> Iterator[Any]:
    """A Dask client for the duration of the block: ``None`` when neither is given (in-process).

    Parameters
    ----------
    workers : int, optional
        Start a ``LocalCluster`` of this many worker processes, one thread each (closed after the block).
    scheduler : str, optional
        Connect to the Dask scheduler at this address instead (``tcp://host:8786``).

    Raises
    ------
    InvalidArgumentError
        Both given, ``workers < 1``, Dask not installed, or the scheduler cannot be reached.
    """
    if workers is not None and scheduler is not None:
        raise InvalidArgumentError("`workers` and `scheduler`: give one (workers start a local cluster, a scheduler "
                                   "address uses a running one)")
    if workers is None and scheduler is None:
        yield None
        return
    distributed = _dask()
    if workers is not None:
        import dask

        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise InvalidArgumentError(f"`workers`: expected an integer >= 1, got {workers!r}")
        # Dask starts its workers with MALLOC_TRIM_THRESHOLD_=65536, which makes glibc hand every large
        # array back to the kernel: NumPy's batch arrays then fault in fresh pages at every step
        # (measured: a set-valued batch 1.5x slower in a worker than in this process); one thread of BLAS
        # per worker is kept
        environ = {k: v for k, v in dask.config.get("distributed.nanny.pre-spawn-environ", {}).items()
                   if k != "MALLOC_TRIM_THRESHOLD_"}
        with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}), \
                distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                      dashboard_address=":0", silence_logs=logging.ERROR) as lc, \
                distributed.Client(lc) as client:
            yield client
        return
    client = connect(str(scheduler))
    try:
        yield client
    finally:
        client.close()


def connect(address: str) -> Any:
    """A ``Client`` of the Dask scheduler at ``address`` (:class:`InvalidArgumentError` if it cannot be reached)."""
    distributed = _dask()
    try:
        return distributed.Client(address, timeout=float(os.environ.get("NLOBS_DASK_TIMEOUT", "10")))
    except (OSError, TimeoutError, ValueError) as exc:
        raise InvalidArgumentError(f"scheduler {address!r}: cannot connect ({type(exc).__name__}: {exc})") from exc


def describe(executor: Any) -> tuple[str, int]:
    """``(kind, workers)`` of an executor: ``("in-process", 1)``, ``("dask", n)`` or ``("executor", n)``."""
    if executor is None:
        return "in-process", 1
    if is_dask_client(executor):
        return "dask", max(1, len(executor.scheduler_info().get("workers", {})))
    return "executor", max(1, int(getattr(executor, "_max_workers", 1) or 1))


_UNPICKLED: dict[str, Any] = {}


def _dumps(obj: Any) -> bytes:
    """``obj`` pickled by value where it must be (generated functions): cloudpickle when installed."""
    try:
        import cloudpickle
    except ImportError:  # pragma: no cover - cloudpickle comes with the dask extra
        import pickle

        return pickle.dumps(obj)
    return cloudpickle.dumps(obj)


def _call_pickled(blob: bytes, digest: str, *args: Any) -> Any:
    """In a pool's process: ``fn(shared, *args)`` from their pickle, unpickled once per process; its result pickled."""
    import pickle

    if digest not in _UNPICKLED:
        _UNPICKLED.clear()
        _UNPICKLED[digest] = pickle.loads(blob)
    fn, shared = _UNPICKLED[digest]
    return _dumps(fn(shared, *args))  # the result by value too (an observer with generated functions)


def run_tasks(executor: Any, fn: Callable[..., Any], shared: Any, tasks: Iterable[tuple[Any, ...]],
              done: Callable[[int, Any], None]) -> None:
    """Run ``fn(shared, *args)`` for every task; ``done(i, result)`` in this process as each finishes (any order).

    ``shared`` (the study, the sweep's problem) is sent to each Dask worker once, not with every task.

    In-process, tasks run one after another. On an executor, at most
    :data:`IN_FLIGHT_PER_WORKER` × workers tasks are in flight, so finished results never pile up
    in memory; the first task that fails cancels the rest and its exception is raised here.
    """
    tasks = list(enumerate(tasks))
    if executor is None:
        for i, args in tasks:
            done(i, fn(shared, *args))
        return
    if isinstance(executor, str):
        client = connect(executor)
        try:
            run_tasks(client, fn, shared, [a for _, a in tasks], done)
        finally:
            client.close()
        return
    dask = is_dask_client(executor)
    if not dask and not hasattr(executor, "submit"):
        raise InvalidArgumentError(f"executor: expected None, a dask.distributed.Client, a scheduler address or a "
                                   f"concurrent.futures.Executor, got {type(executor).__name__}")
    window = IN_FLIGHT_PER_WORKER * describe(executor)[1]
    if dask:
        shared = executor.scatter(shared, broadcast=True, hash=False)
    else:  # a concurrent.futures pool pickles by reference: send the function and the shared object by value
        import hashlib

        blob = _dumps((fn, shared))
        fn, shared = _call_pickled, blob
        first_args: tuple[Any, ...] = (hashlib.sha256(blob).hexdigest(),)
        tasks = [(i, first_args + tuple(a)) for i, a in tasks]
    pending = iter(tasks)
    index: dict[Any, int] = {}

    def submit() -> Any:
        nxt = next(pending, None)
        if nxt is None:
            return None
        i, args = nxt
        fut = executor.submit(fn, shared, *args, pure=False) if dask else executor.submit(fn, shared, *args)
        index[fut] = i
        return fut

    first = [f for f in (submit() for _ in range(window)) if f is not None]
    if dask:
        ac = _dask().as_completed(first)
        try:
            for fut in ac:
                i = index.pop(fut)
                result = fut.result()
                fut.release()
                done(i, result)
                nxt = submit()
                if nxt is not None:
                    ac.add(nxt)
        except BaseException:
            for f in index:
                f.cancel()
            raise
        return
    import concurrent.futures as cf
    import pickle

    live = set(first)
    try:
        while live:
            finished, live = cf.wait(live, return_when=cf.FIRST_COMPLETED)
            for fut in finished:
                done(index.pop(fut), pickle.loads(fut.result()))
                nxt = submit()
                if nxt is not None:
                    live.add(nxt)
    except BaseException:
        for f in live:
            f.cancel()
        raise
