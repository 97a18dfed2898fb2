"""Atomic file writing: a reader never sees a half-written file, and a failed write loses nothing."""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import numpy as np


def _mode_for(target: Path) -> int:
    """The mode ``open(target, "w")`` would leave: the existing file's, else ``0o666 & ~umask``."""
    try:
        return target.stat().st_mode & 0o7777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (on this machine); ``True`` when that cannot be told."""
    if pid <= 0:
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # it exists (another user's), or nothing can be told: keep its file
    return True


def remove_stale_temporaries(target: str | Path) -> list[Path]:
    """Remove the temporary files of ``target`` that a dead earlier run left (returns them).

    :func:`atomic_write` names its temporary file ``.{name}.{pid}.{random}.tmp``; a run killed
    with SIGKILL (or a power cut) between creating and renaming it cannot remove it. A later
    write of the same target removes every such file whose process no longer exists; a live
    process's file (another run writing the same folder at the same time) is never touched.
    Process ids are those of this machine: two machines writing one network folder at once
    are not told apart.
    """
    folder, name = Path(target).parent, Path(target).name
    prefix = f".{name}."
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        rest = entry.name[len(prefix):]
        if not (entry.name.startswith(prefix) and rest.endswith(".tmp")):
            continue
        parts = rest.split(".")  # pid, mkstemp's random letters (no dot), "tmp"
        if len(parts) != 3 or not parts[0].isdigit() or _pid_alive(int(parts[0])):
            continue
        try:
            if entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            pass  # removed by another run meanwhile, or not ours to remove
    return removed


def atomic_write(path: str | Path, write: Callable[[IO[bytes]], None]) -> Path:
    """Write ``path`` atomically.

    ``write`` receives a binary file object opened on a temporary file
    ``.{name}.{pid}.{random}.tmp`` in the same directory; on success the
    temporary file replaces ``path`` with :func:`os.replace` (atomic on POSIX
    and Windows), so a reader, or another run writing the same file at the same
    time, only ever sees a complete file. On any exception (``KeyboardInterrupt``
    and the CLI's SIGTERM included) the temporary file is removed and ``path`` is
    left as it was. The temporary files of the same target that a killed earlier
    run left behind are removed first (:func:`remove_stale_temporaries`). The file gets the
    permissions a plain ``open(path, "w")`` would give it (an existing file's
    mode, else ``0o666`` less the umask), not ``mkstemp``'s private ``0o600``.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(target)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, _mode_for(target))
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return target


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write a UTF-8 text file atomically (see :func:`atomic_write`).

    Examples
    --------
    The file holds the whole text, and no temporary file is left beside it; a write that fails
    half-way (here the disk fills after a first chunk) leaves the previous text as it was:

    >>> import shutil
    >>> import tempfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> target = atomic_write_text(folder / "report.txt", "γ = 0.5\\n")
    >>> target.read_text(encoding="utf-8"), sorted(p.name for p in folder.iterdir())
    ('γ = 0.5\\n', ['report.txt'])
    >>> def disk_full(fh):
    ...     fh.write(b"half a rep")
    ...     raise OSError(28, "No space left on device")
    >>> try:
    ...     atomic_write(target, disk_full)
    ... except OSError as exc:
    ...     print(type(exc).__name__, "-", exc.strerror)
    OSError - No space left on device
    >>> target.read_text(encoding="utf-8"), sorted(p.name for p in folder.iterdir())
    ('γ = 0.5\\n', ['report.txt'])
    >>> shutil.rmtree(folder)
    """
    data = text.encode("utf-8")
    return atomic_write(path, lambda fh: fh.write(data))


def save_figure(fig: Any, path: str | Path, *, dpi: int = 110) -> Path:
    """Save a matplotlib figure atomically (:func:`atomic_write`); the format follows the suffix (PNG default).

    A killed run leaves the previous figure intact; its temporary ``.name.{pid}.*.tmp`` is removed
    on any exception, or, after a SIGKILL, by the next write of the same figure (:func:`atomic_write`).
    """
    target = Path(path)
    fmt = target.suffix.lstrip(".").lower() or "png"
    return atomic_write(target, lambda fh: fig.savefig(fh, format=fmt, dpi=dpi))


def jsonable(obj: Any) -> Any:
    """``obj`` with NumPy scalars and arrays as Python values and non-finite floats as ``None`` (JSON ``null``).

    The one conversion behind every JSON nlobs prints or writes (``json.dumps(..., allow_nan=False)``
    then never fails on a NaN metric, e.g. a convergence time that was never reached).

    Examples
    --------
    NumPy arrays and scalars become lists and Python numbers, a NaN becomes ``None``, so strict JSON
    (``allow_nan=False``) can be written:

    >>> import json
    >>> import numpy as np
    >>> report = {"gain": np.array([[1.5], [0.25]]), "runs": np.int64(3), "t_conv": np.float64("nan"),
    ...           "bounds": (np.float32(0.5), float("inf"))}
    >>> jsonable(report)
    {'gain': [[1.5], [0.25]], 'runs': 3, 't_conv': None, 'bounds': [0.5, None]}
    >>> json.dumps(jsonable(report), allow_nan=False)
    '{"gain": [[1.5], [0.25]], "runs": 3, "t_conv": null, "bounds": [0.5, null]}'
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


#: Version of the layout of every JSON report nlobs prints (the commands' JSON output) or writes (``results.json``,
#: ``compare.json``): the ``schema_version`` key of each. It grows when a key changes meaning or is
#: removed; new keys do not change it.
SCHEMA_VERSION = 1


def with_schema(data: Any) -> Any:
    """A JSON report (a mapping) with ``schema_version`` first; anything else unchanged.

    The two list outputs (the JSON of ``nlobs reproduce`` and of ``nlobs models``) stay lists.

    Examples
    --------
    The version goes first, replacing any the report already had; a list is returned unchanged:

    >>> with_schema({"verdict": "ok", "schema_version": 0, "gamma": 0.5})
    {'schema_version': 1, 'verdict': 'ok', 'gamma': 0.5}
    >>> with_schema([{"name": "pendulum"}])
    [{'name': 'pendulum'}]
    """
    if isinstance(data, dict):
        return {"schema_version": SCHEMA_VERSION, **{k: v for k, v in data.items() if k != "schema_version"}}
    return data


def atomic_write_json(path: str | Path, data: Any) -> Path:
    """Write ``data`` as indented JSON (:func:`jsonable`) atomically."""
    import json

    return atomic_write_text(path, json.dumps(jsonable(data), indent=2, allow_nan=False) + "\n")


def prepare_output_dir(path: str | Path) -> Path:
    """Create the folder ``path`` (and its parents) and check a file can be written in it, before any work.

    Raises
    ------
    OSError
        It exists and is not a folder, or it cannot be created or written (no temporary file is left).
    """
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise NotADirectoryError(20, "exists and is not a folder", str(folder))
    folder.mkdir(parents=True, exist_ok=True)
    fd, probe = tempfile.mkstemp(prefix=".nlobs-probe.", dir=folder)
    os.close(fd)
    os.unlink(probe)
    return folder


def _size_text(n: int) -> str:
    """``n`` bytes in words, e.g. ``"1 MiB"`` (exact multiples of KiB/MiB/GiB only; else ``"n bytes"``)."""
    for unit, size in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size and n % size == 0:
            return f"{n // size} {unit}"
    return f"{n} bytes"


def read_regular_text(path: str | Path, max_bytes: int, refuse: Callable[[str], Exception]) -> str:
    """The UTF-8 text of the regular file ``path`` of at most ``max_bytes`` bytes, read without ever blocking.

    ``os.stat`` first (a FIFO is never opened, a device such as ``/dev/zero`` never read), then the
    file is opened with ``O_NONBLOCK`` and checked again with ``fstat`` (it may have been replaced in
    between), and at most one byte more than the limit is read.

    Parameters
    ----------
    path : str or Path
        The file.
    max_bytes : int
        The largest size accepted.
    refuse : callable
        ``refuse(reason)`` builds the exception raised (a typed error naming the file), e.g.
        ``"not a regular file (a FIFO)"``, ``"file larger than 1048576 bytes (1 MiB)"``,
        ``"file is not UTF-8 text (byte 17)"``, ``"cannot read file (No such file or directory)"``.
    """
    import stat

    limit = f"file larger than {max_bytes} bytes ({_size_text(max_bytes)})"

    def require_regular(st: os.stat_result) -> None:
        mode = st.st_mode
        if stat.S_ISREG(mode):
            if st.st_size > max_bytes:
                raise refuse(f"{limit}: {st.st_size} bytes")
            return
        kind = ("a directory" if stat.S_ISDIR(mode) else "a FIFO" if stat.S_ISFIFO(mode)
                else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a socket" if stat.S_ISSOCK(mode)
                else "not a file")
        raise refuse(f"not a regular file ({kind})")

    try:
        st = os.stat(path)
    except (OSError, ValueError) as exc:
        raise refuse(f"cannot read file ({getattr(exc, 'strerror', None) or exc})") from None
    require_regular(st)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
                     | getattr(os, "O_BINARY", 0))
    except OSError as exc:
        raise refuse(f"cannot read file ({exc.strerror})") from None
    try:
        with os.fdopen(fd, "rb") as fh:
            require_regular(os.fstat(fh.fileno()))
            raw = fh.read(max_bytes + 1)
    except OSError as exc:
        raise refuse(f"cannot read file ({exc.strerror})") from None
    if len(raw) > max_bytes:
        raise refuse(limit)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise refuse(f"file is not UTF-8 text (byte {exc.start})") from None
