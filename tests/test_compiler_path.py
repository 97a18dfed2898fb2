"""The C compiler is found without the current folder on ``sys.path``.

``import ziglang`` and ``python -m ziglang cc`` both search the current folder first, so a
``ziglang`` package or ``ziglang.py`` planted where a user runs ``nlobs export`` would be imported
and run. :func:`nlobs.export.compiler.find_compiler` runs the packaged ``ziglang/zig`` binary of
site-packages directly instead; these tests plant such a package in a temporary working folder and
check that nothing of it runs while code is compiled there.
"""

from __future__ import annotations

import importlib.metadata
import os
import site
import subprocess
import sys
import sysconfig
import textwrap
from pathlib import Path

import pytest

from nlobs.errors import CompilerError
from nlobs.export import compiler as compiler_mod
from nlobs.export.compiler import find_compiler

try:
    importlib.metadata.distribution("ziglang")  # metadata only: nothing of the package is imported
    HAVE_ZIGLANG = True
except importlib.metadata.PackageNotFoundError:  # pragma: no cover - make test installs the codegen extra
    HAVE_ZIGLANG = False

_SOURCE = "double nlobs_probe(double x) { return 2.0 * x + 1.0; }\n"

_PROBE = textwrap.dedent("""
    import ctypes, sys
    from nlobs.export.compiler import build_shared, compile_object, find_compiler
    cc = find_compiler()
    compile_object(%r)
    lib = ctypes.CDLL(str(build_shared(%r)))
    lib.nlobs_probe.restype = ctypes.c_double
    lib.nlobs_probe.argtypes = [ctypes.c_double]
    print("label=" + cc.label)
    print("value=%%r" %% lib.nlobs_probe(3.0))
    print("ziglang-imported=%%s" %% ("ziglang" in sys.modules))
""") % (_SOURCE, _SOURCE)


def _have_compiler() -> bool:
    try:
        find_compiler()
    except CompilerError:
        return False
    return True


def _plant(folder: Path, layout: str, marker: Path) -> None:
    """A ``ziglang`` in ``folder`` that appends to ``marker`` when imported or run."""
    code = f"open({str(marker)!r}, 'a').write(__name__ + '\\n')\n"
    if layout == "package":
        pkg = folder / "ziglang"
        pkg.mkdir()
        (pkg / "__init__.py").write_text(code, encoding="utf-8")
        (pkg / "__main__.py").write_text(code + "import sys\nsys.exit(0)\n", encoding="utf-8")
    else:
        (folder / "ziglang.py").write_text(code, encoding="utf-8")


def _env(tmp: Path) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("NLOBS_CC", None)
    env.pop("PYTHONSAFEPATH", None)  # the attack needs the current folder on sys.path, as by default
    env["NLOBS_CACHE"] = str(tmp / "cache")  # an empty cache: the source is really compiled
    env["MPLBACKEND"] = "Agg"
    return env


@pytest.mark.skipif(not _have_compiler(), reason="no C compiler")
@pytest.mark.parametrize("layout", ["package", "module"])
def test_planted_ziglang_in_cwd_is_not_run_when_compiling(tmp_path: Path, layout: str) -> None:
    work = tmp_path / "work"
    work.mkdir()
    marker = tmp_path / "MARKER"
    _plant(work, layout, marker)
    proc = subprocess.run([sys.executable, "-c", _PROBE], cwd=work, env=_env(tmp_path),
                          capture_output=True, text=True, timeout=300, check=False)
    assert not marker.exists(), f"planted ziglang ran: {marker.read_text()!r}"
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert "value=7.0" in lines
    assert "ziglang-imported=False" in lines
    if HAVE_ZIGLANG:
        assert "label=ziglang" in lines


@pytest.mark.slow
@pytest.mark.skipif(not _have_compiler(), reason="no C compiler")
def test_planted_ziglang_in_cwd_is_not_run_by_nlobs_export(tmp_path: Path) -> None:
    """``python -m nlobs export`` from a folder with a planted ``ziglang`` package."""
    work = tmp_path / "work"
    work.mkdir()
    marker = tmp_path / "MARKER"
    _plant(work, "package", marker)
    (work / "ziglang.py").write_text("raise SystemExit('must not be imported')\n", encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "nlobs", "export", "pendulum", "--observer", "luenberger",
                           "--out", "OUT"], cwd=work, env=_env(tmp_path),
                          capture_output=True, text=True, timeout=300, check=False)
    assert not marker.exists(), f"planted ziglang ran: {marker.read_text()!r}"
    # The pendulum's luenberger design is not certified for the nonlinear plant (exit 1), but the
    # files are written after a strict compile, which is what matters here.
    assert proc.returncode in (0, 1), proc.stderr
    assert "compiled with" in proc.stdout, proc.stdout + proc.stderr
    assert (work / "OUT" / "pendulum_luenberger.c").is_file()
    if HAVE_ZIGLANG:
        assert "ziglang/zig cc" in proc.stdout.replace(os.sep, "/")


def _site_folders() -> list[Path]:
    paths = sysconfig.get_paths()
    folders = [paths["purelib"], paths["platlib"], *getattr(site, "getsitepackages", list)()]
    if site.ENABLE_USER_SITE:
        folders.append(site.getusersitepackages())
    return [Path(f).resolve() for f in folders if f]


@pytest.mark.skipif(not HAVE_ZIGLANG, reason="the ziglang package (codegen extra) is not installed")
def test_ziglang_command_is_the_packaged_binary(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("NLOBS_CC", raising=False)
    cc = find_compiler()
    assert cc.label == "ziglang"
    assert len(cc.command) == 2 and cc.command[1] == "cc"
    exe = Path(cc.command[0])
    assert exe.is_absolute() and exe.is_file() and os.access(exe, os.X_OK)
    assert exe.parent.name == "ziglang" and exe.name in ("zig", "zig.exe")
    assert exe.resolve().parent.parent in _site_folders()
    assert exe.resolve() != Path(sys.executable).resolve()
    assert "-m" not in cc.command


def test_find_compiler_in_process_does_not_import_from_cwd(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Like ``python -m nlobs``: the current folder first on sys.path, a ``ziglang`` planted there."""
    marker = tmp_path / "MARKER"
    _plant(tmp_path, "package", marker)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.syspath_prepend("")
    monkeypatch.delitem(sys.modules, "ziglang", raising=False)
    monkeypatch.delenv("NLOBS_CC", raising=False)
    try:
        find_compiler()
    except CompilerError:
        pass
    assert "ziglang" not in sys.modules
    assert not marker.exists()


def test_site_dirs_are_absolute_only(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compiler_mod.sysconfig, "get_paths", lambda: {"purelib": "", "platlib": "lib/site"})
    monkeypatch.setattr(compiler_mod.site, "getsitepackages", lambda: [".", os.getcwd()], raising=False)
    monkeypatch.setattr(compiler_mod.site, "ENABLE_USER_SITE", False)
    assert compiler_mod._site_dirs() == [os.path.normpath(os.getcwd())]


def test_non_executable_or_absent_binary_falls_back(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compiler_mod, "_site_dirs", lambda: [str(tmp_path)])
    assert compiler_mod._ziglang() is None  # absent
    (tmp_path / "ziglang").mkdir()
    zig = tmp_path / "ziglang" / ("zig.exe" if os.name == "nt" else "zig")
    zig.write_text("", encoding="utf-8")
    if os.name != "nt":
        zig.chmod(0o644)
        assert compiler_mod._ziglang() is None  # not executable
        zig.chmod(0o755)
    assert compiler_mod._ziglang() == compiler_mod.Compiler((str(zig), "cc"), "ziglang")
    monkeypatch.setattr(compiler_mod, "_ziglang", lambda: None)
    monkeypatch.delenv("NLOBS_CC", raising=False)
    try:
        cc = find_compiler()
    except CompilerError:
        return  # no compiler on the PATH either
    assert cc.label == "PATH"
