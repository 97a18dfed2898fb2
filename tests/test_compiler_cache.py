"""The compiled-library cache is private and checked: a planted or altered library is never loaded.

A library planted in the cache under the key of a module nlobs is about to build (with a constructor that writes a
file when loaded) must not run; a world-writable cache is refused with one line.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from nlobs.errors import CompilerError, NlobsError
from nlobs.export.compiler import build_shared, find_compiler

SOURCE = "double nlobs_probe(double x) { return 2.0 * x; }\n"
PLANT = """#include <stdio.h>
__attribute__((constructor)) static void planted(void) {{ FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}
double nlobs_probe(double x) {{ return 3.0 * x; }}
"""


@pytest.fixture()
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("NLOBS_CACHE", str(folder))
    try:
        find_compiler()
    except NlobsError:
        pytest.skip("no C compiler")
    return folder


def _load(path: Path) -> float:
    """Load a copy under a fresh name (the loader would return a library already loaded from the same path)."""
    import ctypes
    import shutil
    import tempfile

    copy = Path(tempfile.mkdtemp()) / "lib.so"
    shutil.copyfile(path, copy)
    lib = ctypes.CDLL(str(copy))
    lib.nlobs_probe.restype = ctypes.c_double
    lib.nlobs_probe.argtypes = [ctypes.c_double]
    return float(lib.nlobs_probe(1.5))


def test_the_cache_is_private_and_each_library_has_its_digest(cache: Path) -> None:
    path = build_shared(SOURCE)
    assert stat.S_IMODE(cache.stat().st_mode) == 0o700
    assert path.with_suffix(".sha256").is_file()
    assert build_shared(SOURCE) == path  # cached: the digest matches


def test_a_planted_library_is_rebuilt_not_loaded(cache: Path, tmp_path: Path) -> None:
    path = build_shared(SOURCE)
    marker = tmp_path / "planted-ran"
    other = tmp_path / "plant"
    other.mkdir(mode=0o700)
    os.environ["NLOBS_CACHE"] = str(other)
    planted = build_shared(PLANT.format(marker=marker))
    os.environ["NLOBS_CACHE"] = str(cache)
    assert not marker.exists()  # built, never loaded
    path.write_bytes(planted.read_bytes())  # the attacker's library under the module's key, the old digest kept
    rebuilt = build_shared(SOURCE)
    assert _load(rebuilt) == 3.0 and not marker.exists()  # 2 × 1.5: the module's own code, not the plant's 4.5
    path.with_suffix(".sha256").unlink()  # a library without a digest
    path.write_bytes(planted.read_bytes())
    assert _load(build_shared(SOURCE)) == 3.0 and not marker.exists()
    path.write_bytes(b"\x7fELF garbage")  # a truncated library
    assert _load(build_shared(SOURCE)) == 3.0


def test_a_cache_others_can_write_is_refused(cache: Path) -> None:
    build_shared(SOURCE)
    cache.chmod(0o777)
    try:
        with pytest.raises(CompilerError, match="writable by other users .*chmod 700"):
            build_shared(SOURCE)
    finally:
        cache.chmod(0o700)
