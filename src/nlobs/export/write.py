"""Write an observer's generated C to a folder: ``P.h`` and ``P.c``, atomically, compiled once to check them."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nlobs._schema import BOOLEAN, INTEGER, STRING, Record, nullable
from nlobs._io import atomic_write_text, prepare_output_dir
from nlobs.errors import CompilerError, OutputError
from nlobs.export.compiler import compile_object, find_compiler
from nlobs.export.generate import default_prefix, generate
from nlobs.export.program import CProgram, nlobs_version, render

__all__ = ["ExportResult", "export_observer"]


@dataclass(frozen=True)
class ExportResult:
    """What :func:`export_observer` wrote.

    Attributes
    ----------
    program : CProgram
        The generated module.
    header, source : Path
        The two files.
    checked_with : str or None
        The compiler that compiled the module with ``-Wall -Wextra -Werror -std=c99 -pedantic``
        (``None``: no compiler was found, the files are unchecked).

    Examples
    --------
    What :func:`export_observer` returns for a Luenberger observer written without the strict check, and
    its JSON summary (the ``module`` of ``nlobs export``):

    >>> import tempfile
    >>> import nlobs
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.LuenbergerObserver(system, [[4.5], [1.75]])
    >>> res = export_observer(observer, tempfile.mkdtemp(), prefix="osc", check=False)
    >>> type(res).__name__, res.header.name, res.source.name, res.checked_with
    ('ExportResult', 'osc.h', 'osc.c', None)
    >>> source = res.source.read_text(encoding="utf-8")
    >>> res.header.parent == res.source.parent, "osc_Fz[4] = {(-4.5), 1.0, (-3.75), (-0.5)};" in source  # A − L C
    (True, True)
    >>> summary = res.to_dict()
    >>> summary["prefix"], summary["title"], summary["correcting"], summary["checked_with"]
    ('osc', 'Luenberger observer (2 states)', False, None)
    """

    program: CProgram
    header: Path
    source: Path
    checked_with: str | None

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary."""
        p = self.program
        return EXPORTED_MODULE_JSON.emit({
            "prefix": p.prefix, "title": p.title, "header": str(self.header), "source": str(self.source),
            "n_z": p.n_z, "n_x": p.n_x, "n_u": p.n_u, "n_y": p.n_y, "discrete": p.discrete,
            "correcting": p.correcting, "checked_with": self.checked_with})


#: ``module`` of ``nlobs export``: the C module written.
EXPORTED_MODULE_JSON = Record("ExportedModule", {
    "prefix": STRING.about("the prefix of every C name"), "title": STRING, "header": STRING, "source": STRING,
    "n_z": INTEGER.about("the observer's state size"), "n_x": INTEGER, "n_u": INTEGER, "n_y": INTEGER,
    "discrete": BOOLEAN, "correcting": BOOLEAN.about("it corrects at sample instants"),
    "checked_with": nullable(STRING, "the compiler that built it with -Wall -Wextra -Werror (null: none found)"),
})


def export_observer(observer: Any, out: str | Path, *, prefix: str | None = None,
                    notes: tuple[tuple[str, str], ...] = (), check: bool = True,
                    options: dict[str, Any] | None = None) -> ExportResult:
    """Write the C99 module of ``observer``'s step to the folder ``out``.

    Parameters
    ----------
    observer : Observer
        One of :func:`nlobs.export.generate.supported`.
    out : str or Path
        The folder (created; existing files of the same names are replaced atomically).
    prefix : str, optional
        The C prefix and file names (default from the observer's class; made a C identifier).
    notes : tuple of (str, str)
        More lines for the header's comment block (model, gain and certificate summary).
    check : bool
        Compile the module strictly once (when a compiler is found) before writing it.
    options : dict, optional
        Keyword arguments of the observer's generator (the GNSS/INS observer: ``imu_period``).

    Returns
    -------
    ExportResult

    Raises
    ------
    InvalidArgumentError
        The observer has no C generator.
    CompilerError
        The strict compilation failed (nothing is written).
    OutputError
        The folder cannot be written.

    Examples
    --------
    The C99 module of a Luenberger observer, checked by a strict compilation (when a compiler is
    found) and written to a folder:

    >>> import tempfile
    >>> import nlobs
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.LuenbergerObserver(system, [[4.5], [1.75]])
    >>> with tempfile.TemporaryDirectory() as out:
    ...     res = export_observer(observer, out, prefix="osc", notes=(("poles", "eig(A - L C) = -2, -3"),))
    ...     header = res.header.read_text(encoding="utf-8")
    ...     files = sorted(p.name for p in res.header.parent.iterdir())
    >>> files, res.program.prefix
    (['osc.c', 'osc.h'], 'osc')
    >>> "int osc_step(" in header, "eig(A - L C) = -2, -3" in header
    (True, True)
    >>> {k: res.to_dict()[k] for k in ("n_x", "n_u", "n_y", "discrete")}
    {'n_x': 2, 'n_u': 1, 'n_y': 1, 'discrete': False}
    """
    program = generate(observer, default_prefix(observer, prefix), notes=notes,
                       options=options)
    header, source = render(program, nlobs_version())
    checked: str | None = None
    if check:
        try:
            cc = find_compiler()
        except CompilerError:
            cc = None
        if cc is not None:
            compile_object(source, strict=True, compiler=cc, headers={program.header_name: header})
            checked = cc.describe()
    try:
        folder = prepare_output_dir(out)
        h = atomic_write_text(folder / program.header_name, header)
        c = atomic_write_text(folder / program.source_name, source)
    except OSError as exc:
        raise OutputError(f"{out}: cannot write the generated C ({getattr(exc, 'strerror', None) or exc})") from None
    return ExportResult(program, h, c, checked)
