"""Write an observer's generated C to a folder: ``P.h`` and ``P.c``, atomically, compiled once to check them."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

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
    """

    program: CProgram
    header: Path
    source: Path
    checked_with: str | None

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary."""
        p = self.program
        return {"prefix": p.prefix, "title": p.title, "header": str(self.header), "source": str(self.source),
                "n_z": p.n_z, "n_x": p.n_x, "n_u": p.n_u, "n_y": p.n_y, "discrete": p.discrete,
                "correcting": p.correcting, "checked_with": self.checked_with}


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
