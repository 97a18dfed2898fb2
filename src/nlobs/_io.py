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


def atomic_write(path: str | Path, write: Callable[[IO[bytes]], None]) -> Path:
    """Write ``path`` atomically.

    ``write`` receives a binary file object opened on a temporary file in the
    same directory; on success the temporary file replaces ``path`` with
    :func:`os.replace` (atomic on POSIX and Windows). On any exception the
    temporary file is removed and ``path`` is left as it was. The file gets the
    permissions a plain ``open(path, "w")`` would give it (an existing file's
    mode, else ``0o666`` less the umask), not ``mkstemp``'s private ``0o600``.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
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
    """Write a UTF-8 text file atomically (see :func:`atomic_write`)."""
    data = text.encode("utf-8")
    return atomic_write(path, lambda fh: fh.write(data))


def save_figure(fig: Any, path: str | Path, *, dpi: int = 110) -> Path:
    """Save a matplotlib figure atomically (:func:`atomic_write`); the format follows the suffix (PNG default).

    A killed run leaves the previous figure intact and no stray temporary file beyond the
    ``.name.*.tmp`` that :func:`atomic_write` removes on any exception.
    """
    target = Path(path)
    fmt = target.suffix.lstrip(".").lower() or "png"
    return atomic_write(target, lambda fh: fig.savefig(fh, format=fmt, dpi=dpi))


def jsonable(obj: Any) -> Any:
    """``obj`` with NumPy scalars and arrays as Python values and non-finite floats as ``None`` (JSON ``null``).

    The one conversion behind every JSON nlobs prints or writes (``json.dumps(..., allow_nan=False)``
    then never fails on a NaN metric, e.g. a convergence time that was never reached).
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
