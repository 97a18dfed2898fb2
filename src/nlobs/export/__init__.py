"""Generated code: an observer as dependency-free C99, and the compiled fast path.

* :func:`export_observer` writes ``P.h`` and ``P.c`` for one observer step (:mod:`nlobs.export.program`
  for the C interface), with a header that carries the model, the gain and the certificate summary;
* :func:`compile_observer` compiles the same C and returns an observer the loops run like any other
  (:mod:`nlobs.export.compiled`);
* :mod:`nlobs.export.compiler` finds a C compiler (``NLOBS_CC``, the ``ziglang`` package, ``cc``).
"""

from nlobs.export.compiled import CompiledCorrectingObserver, CompiledObserver, compile_observer
from nlobs.export.compiler import Compiler, find_compiler
from nlobs.export.generate import generate, supported
from nlobs.export.program import CProgram, render
from nlobs.export.write import ExportResult, export_observer

__all__ = ["CProgram", "CompiledCorrectingObserver", "CompiledObserver", "Compiler", "ExportResult",
           "compile_observer", "export_observer", "find_compiler", "generate", "render", "supported"]
