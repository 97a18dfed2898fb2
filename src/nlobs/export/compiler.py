"""Find a C compiler and build generated C into a shared library, cached by content.

The compiler is, in this order: the command in the ``NLOBS_CC`` environment variable (split like
a shell word list, e.g. ``"zig cc"``), the Zig toolchain of the ``ziglang`` package (the
``codegen`` extra: a C compiler from the package index, so a fresh machine needs nothing else),
then ``cc``, ``gcc`` or ``clang`` on the ``PATH``.

The ``ziglang`` package is never imported and never started as ``python -m ziglang``: both put
the current folder first on ``sys.path``, so a ``ziglang`` folder or ``ziglang.py`` where nlobs is
run would be imported and its code run. Instead the packaged binary ``ziglang/zig`` (``zig.exe``
on Windows) is looked up in the installation's site-packages folders only (``sysconfig``'s
``purelib`` and ``platlib``, :func:`site.getsitepackages`, and the user site when enabled; never
``''``, the current folder or a relative ``sys.path`` entry) and run directly as ``(zig, "cc")``:
the argument vector ``python -m ziglang cc`` itself executes. An absent or non-executable binary
falls through to the ``PATH`` compilers.

Flags. Every build is ``-std=c99 -O2 -ffp-contract=off``: no fused multiply-adds are formed, so
the compiled arithmetic rounds like NumPy's (``a*b + c`` is two roundings on both sides). Strict
builds add ``-Wall -Wextra -Werror -pedantic`` (the tests compile every generated module so).

Cache. A library is stored as ``<cache>/<sha256 of compiler, flags and source>.so`` (``cache``:
``NLOBS_CACHE``, else ``$XDG_CACHE_HOME/nlobs/c``, else ``~/.cache/nlobs/c``), written atomically:
compiling the same source again costs nothing, and two processes building one source at once each
leave a complete file. The cache is private: created with mode 0700, and refused (:class:`CompilerError`)
when it belongs to another user or its group or others may write to it, since a library planted there
would be loaded and run. Each library is stored with the SHA-256 of its bytes (``<key>.sha256``, written
after the library); a library whose digest is missing or differs is built again, never loaded.
"""

from __future__ import annotations

import hashlib
import os
import shlex
import shutil
import site
import subprocess
import sys
import sysconfig
import tempfile
from dataclasses import dataclass
from pathlib import Path

from nlobs.errors import CompilerError

__all__ = ["BASE_FLAGS", "STRICT_FLAGS", "Compiler", "build_shared", "cache_dir", "compile_object", "find_compiler"]

#: Flags of every build (module docstring).
BASE_FLAGS: tuple[str, ...] = ("-std=c99", "-O2", "-ffp-contract=off")
#: Added by a strict build: any warning is an error.
STRICT_FLAGS: tuple[str, ...] = ("-Wall", "-Wextra", "-Werror", "-pedantic")

_TIMEOUT_S = 120.0


@dataclass(frozen=True)
class Compiler:
    """A C compiler command.

    Attributes
    ----------
    command : tuple of str
        The argument vector that starts it (``("/usr/bin/cc",)``,
        ``("<site-packages>/ziglang/zig", "cc")``).
    label : str
        How it was found: ``"NLOBS_CC"``, ``"ziglang"`` or ``"PATH"``.

    Examples
    --------
    A compiler named by hand, and the one nlobs finds here (the Zig toolchain of the ``codegen`` extra,
    or a ``cc`` on the ``PATH``), which compiles a strict C99 function (in a temporary folder, discarded)
    and refuses one with a warning (an unused variable, under ``-Werror``):

    >>> Compiler(("zig", "cc"), "NLOBS_CC").describe()
    'zig cc'
    >>> cc = find_compiler()
    >>> isinstance(cc, Compiler), cc.label in ("NLOBS_CC", "ziglang", "PATH")
    (True, True)
    >>> compile_object("double twice(double x) { return 2.0 * x; }\\n", compiler=cc) is None
    True
    >>> try:
    ...     compile_object("double twice(double x) { int spare; return 2.0 * x; }\\n", compiler=cc)
    ... except CompilerError as exc:
    ...     print(type(exc).__name__, "unused" in str(exc))
    CompilerError True
    """

    command: tuple[str, ...]
    label: str

    def describe(self) -> str:
        """The command as one line (for messages and headers)."""
        return " ".join(self.command)


def _site_dirs() -> list[str]:
    """The installation's site-packages folders: absolute paths only, never ``''`` or the current folder."""
    found: list[str] = []
    paths = sysconfig.get_paths()
    candidates = [paths.get("purelib"), paths.get("platlib")]
    try:
        candidates.extend(site.getsitepackages())
    except AttributeError:  # some old virtualenv builds of site.py lack it
        pass
    if site.ENABLE_USER_SITE and not sys.flags.no_user_site:
        try:
            candidates.append(site.getusersitepackages())
        except AttributeError:
            pass
    for folder in candidates:
        if not folder or not os.path.isabs(folder):
            continue
        folder = os.path.normpath(folder)
        if folder not in found:
            found.append(folder)
    return found


def _ziglang() -> Compiler | None:
    names = ("zig.exe", "zig") if os.name == "nt" else ("zig",)
    for folder in _site_dirs():
        for name in names:
            path = os.path.join(folder, "ziglang", name)
            if os.path.isfile(path) and os.access(path, os.X_OK):
                # ``python -m ziglang cc ...`` execs ``[<package>/zig, "cc", ...]``: the same vector, no Python.
                return Compiler((path, "cc"), "ziglang")
    return None


def find_compiler() -> Compiler:
    """The C compiler nlobs uses (module docstring for the order).

    Returns
    -------
    Compiler

    Raises
    ------
    CompilerError
        ``NLOBS_CC`` is set but empty or not found, or no compiler is installed.

    Examples
    --------
    Without ``NLOBS_CC`` the packaged Zig toolchain or a compiler on the ``PATH`` is found; a
    ``NLOBS_CC`` that names no command is refused rather than passed over:

    >>> import os
    >>> saved = os.environ.pop("NLOBS_CC", None)
    >>> try:
    ...     found = find_compiler()
    ...     os.environ["NLOBS_CC"] = "no-such-cc-for-nlobs -c"
    ...     find_compiler()
    ... except CompilerError as exc:
    ...     print(type(exc).__name__, exc)
    ... finally:
    ...     _ = os.environ.pop("NLOBS_CC", None)
    ...     if saved is not None:
    ...         os.environ["NLOBS_CC"] = saved
    CompilerError NLOBS_CC='no-such-cc-for-nlobs -c': no such compiler command
    >>> found.label in ("ziglang", "PATH"), found.describe() == " ".join(found.command)
    (True, True)
    """
    env = os.environ.get("NLOBS_CC")
    if env is not None:
        try:
            words = shlex.split(env)
        except ValueError as exc:
            raise CompilerError(f"NLOBS_CC={env!r}: {exc}") from None
        if not words or shutil.which(words[0]) is None:
            raise CompilerError(f"NLOBS_CC={env!r}: no such compiler command")
        return Compiler(tuple(words), "NLOBS_CC")
    zig = _ziglang()
    if zig is not None:
        return zig
    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path is not None:
            return Compiler((path,), "PATH")
    raise CompilerError("no C compiler found (looked for NLOBS_CC, the ziglang package, cc, gcc, clang); "
                        "install one, e.g. pip install 'nlobs[codegen]'")


def cache_dir() -> Path:
    """The folder of compiled libraries (module docstring)."""
    env = os.environ.get("NLOBS_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "nlobs" / "c"


def _digest(path: Path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 16), b""):
            h.update(block)
    return h.hexdigest()


def _require_private(folder: Path) -> None:
    """Refuse a cache folder another user could write a library into (POSIX; elsewhere nothing to check).

    Raises
    ------
    CompilerError
        The folder is not owned by this user, or is writable by its group or by others.
    """
    if os.name != "posix":
        return
    st = folder.stat()
    if st.st_uid != os.getuid() or st.st_mode & 0o022:
        who = "not owned by this user" if st.st_uid != os.getuid() else \
            f"writable by other users (mode {st.st_mode & 0o777:o})"
        raise CompilerError(f"{folder}: the compiled-code cache is {who}; nlobs loads no library from it: make it "
                            "private (chmod 700) or set NLOBS_CACHE to a private folder")


def _run(compiler: Compiler, args: list[str], what: str) -> None:
    cmd = [*compiler.command, *args]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=_TIMEOUT_S, check=False)
    except FileNotFoundError as exc:
        raise CompilerError(f"{compiler.describe()}: cannot start the compiler ({exc})") from None
    except subprocess.TimeoutExpired:
        raise CompilerError(f"{compiler.describe()}: compiling {what} took more than {_TIMEOUT_S:g} s") from None
    if proc.returncode != 0:
        lines = [ln for ln in (proc.stderr or proc.stdout).splitlines() if ln.strip()]
        detail = "\n".join(lines[:12])
        raise CompilerError(f"{compiler.describe()} failed on {what} (exit {proc.returncode}):\n{detail}")


def compile_object(source: str, *, strict: bool = True, compiler: Compiler | None = None,
                   headers: dict[str, str] | None = None) -> None:
    """Compile ``source`` to an object file in a temporary folder and discard it: a syntax and warning check.

    Parameters
    ----------
    source : str
        C99 source text.
    strict : bool
        Add :data:`STRICT_FLAGS` (any warning fails).
    compiler : Compiler, optional
        Default :func:`find_compiler`.
    headers : dict of str to str, optional
        Header files (name → text) placed beside the source.

    Raises
    ------
    CompilerError
        The compiler reported an error (or a warning, when strict).
    """
    cc = compiler or find_compiler()
    with tempfile.TemporaryDirectory(prefix="nlobs-cc-") as tmp:
        for name, text in (headers or {}).items():
            Path(tmp, name).write_text(text, encoding="utf-8")
        src = Path(tmp, "module.c")
        src.write_text(source, encoding="utf-8")
        flags = [*BASE_FLAGS, *(STRICT_FLAGS if strict else ())]
        _run(cc, [*flags, "-c", str(src), "-o", str(Path(tmp, "module.o"))], "the generated module")


def build_shared(source: str, *, headers: dict[str, str] | None = None, strict: bool = False,
                 compiler: Compiler | None = None) -> Path:
    """A shared library compiled from ``source`` (from the cache when it was built before).

    Parameters
    ----------
    source : str
        C99 source text.
    headers : dict of str to str, optional
        Header files the source includes (name → text); part of the cache key.
    strict : bool
        Add :data:`STRICT_FLAGS`.
    compiler : Compiler, optional
        Default :func:`find_compiler`.

    Returns
    -------
    Path
        The library file (``.so``; ``.dylib``/``.dll`` names are not used: ctypes loads any name).

    Raises
    ------
    CompilerError
        No compiler, or it failed.
    OutputError
        The cache folder cannot be written.
    """
    from nlobs.errors import OutputError

    cc = compiler or find_compiler()
    flags = [*BASE_FLAGS, *(STRICT_FLAGS if strict else ()), "-shared", "-fPIC"]
    key = hashlib.sha256()
    for part in (cc.describe(), " ".join(flags), source, *(f"{k}\0{v}" for k, v in sorted((headers or {}).items()))):
        key.update(part.encode("utf-8"))
        key.update(b"\0")
    folder = cache_dir()
    target = folder / f"{key.hexdigest()[:32]}.so"
    stamp = target.with_suffix(".sha256")
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{folder}: cannot write the compiled-code cache ({exc.strerror or exc}); "
                          "set NLOBS_CACHE to a writable folder") from None
    _require_private(folder)
    if target.is_file() and stamp.is_file() and _digest(target) == stamp.read_text(encoding="ascii").strip():
        return target  # built here before, unchanged since (else it is built again)
    try:
        tmp = Path(tempfile.mkdtemp(prefix=".build-", dir=folder))
    except OSError as exc:
        raise OutputError(f"{folder}: cannot write the compiled-code cache ({exc.strerror or exc}); "
                          "set NLOBS_CACHE to a writable folder") from None
    try:
        for name, text in (headers or {}).items():
            (tmp / name).write_text(text, encoding="utf-8")
        src = tmp / "module.c"
        src.write_text(source, encoding="utf-8")
        out = tmp / "module.so"
        _run(cc, [*flags, str(src), "-o", str(out), "-lm"], "the generated module")
        digest = tmp / "module.sha256"
        digest.write_text(_digest(out) + "\n", encoding="ascii")
        os.replace(out, target)
        os.replace(digest, stamp)  # the digest last: a library without its digest is never loaded
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return target
