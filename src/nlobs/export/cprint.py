"""SymPy expressions printed as C99, with common subexpressions shared, and safe C text.

This is the one place where a model's expressions become C. Nothing of a model's *text* reaches the
C source: the expressions were parsed from the whitelisted AST (:mod:`nlobs.systems.expressions`) and
are printed by SymPy's C99 printer after every symbol was renamed to a generated identifier
(``z_0``, ``u_1``, ``y_0``; common subexpressions ``w0, w1, …``). A model's names appear only in
comments, through :func:`comment`, which cannot close the comment or form a trigraph.

Numbers are printed with 17 significant digits (the double is read back exactly); ``pi`` and ``E``
as such literals (``M_PI`` is not part of C99). ``sign``, the pointwise ``DiracDelta`` of
:mod:`nlobs.systems.codegen`, ``Min`` and ``Max`` are the small functions ``nlobs_sign``, ``nlobs_dirac``,
``nlobs_min`` and ``nlobs_max`` of :data:`PRELUDE`, with NumPy's values (``sign(0) = 0``; ``DiracDelta``
NaN at 0, else 0; a NaN argument of ``sign``, ``min`` or ``max`` gives NaN, where C's ``fmin`` would drop it).
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Mapping, Sequence
from typing import Any

import sympy as sp
from sympy.printing.c import C99CodePrinter

from nlobs.errors import ModelError

__all__ = ["PRELUDE", "c_double", "c_identifier", "comment", "emit_assignments", "matrix_literal"]

#: Helpers a generated module defines where it uses them (static, so two modules link together).
PRELUDE: dict[str, str] = {
    "nlobs_sign": "static double nlobs_sign(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : x); }\n",
    "nlobs_dirac": "static double nlobs_dirac(double x) { return x == 0.0 ? NAN : 0.0; }\n",
    "nlobs_min": "static double nlobs_min(double a, double b) { return (a != a || b != b) ? NAN : (b < a ? b : a); }\n",
    "nlobs_max": "static double nlobs_max(double a, double b) { return (a != a || b != b) ? NAN : (b > a ? b : a); }\n",
}

_C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum extern float for goto if
inline int long register restrict return short signed sizeof static struct switch typedef union unsigned void
volatile while _Bool _Complex _Imaginary main""".split())


def c_double(value: float) -> str:
    """A C literal of the double ``value`` that reads back exactly (17 significant digits).

    Parameters
    ----------
    value : float
        A finite number (a non-finite one raises :class:`ModelError`: C99 has no literal for it).
    """
    v = float(value)
    if v != v or v in (float("inf"), float("-inf")):
        raise ModelError(f"cannot write the non-finite number {v!r} into C")
    text = f"{v:.17g}"
    if not any(c in text for c in ".en"):
        text += ".0"
    return f"({text})" if text.startswith("-") else text


def c_identifier(text: str, *, prefix: str = "nlobs") -> str:
    """A C identifier made from ``text``: letters, digits and ``_`` only, not a keyword, not starting with a digit.

    Parameters
    ----------
    text : str
        Any name (a model's, a user's).
    prefix : str
        Put in front when the cleaned name is empty, starts with a digit or is a C keyword.
    """
    clean = re.sub(r"[^A-Za-z0-9_]", "_", text)
    clean = re.sub(r"_+", "_", clean).strip("_")[:48]
    if not clean or clean[0].isdigit() or clean in _C_KEYWORDS or clean.startswith("_"):
        clean = f"{prefix}_{clean}" if clean else prefix
    return clean


def comment(text: str) -> str:
    """``text`` made safe inside a ``/* … */`` block comment: no ``*/``, no trigraph ``??``, no control characters.

    Parameters
    ----------
    text : str
        Any text (names from a model file).
    """
    out = "".join(ch if ch.isprintable() or ch == "\n" else "?" for ch in str(text))
    out = out.replace("*/", "* /").replace("/*", "/ *")
    while "??" in out:
        out = out.replace("??", "? ?")
    return out


class _Printer(C99CodePrinter):
    """SymPy's C99 printer with exact double literals and nlobs's ``sign`` and ``DiracDelta``."""

    def _print_Float(self, expr: sp.Float) -> str:
        return c_double(float(expr))

    def _print_Pi(self, expr: Any) -> str:
        return c_double(float(sp.pi))

    def _print_Exp1(self, expr: Any) -> str:
        return c_double(float(sp.E))

    def _print_sign(self, expr: Any) -> str:
        return f"nlobs_sign({self._print(expr.args[0])})"

    def _print_DiracDelta(self, expr: Any) -> str:
        return f"nlobs_dirac({self._print(expr.args[0])})"

    def _fold(self, name: str, args: Any) -> str:
        items = [self._print(a) for a in args]
        out = items[0]
        for item in items[1:]:
            out = f"{name}({out}, {item})"
        return out

    def _print_Min(self, expr: Any) -> str:  # NumPy's minimum: NaN propagates (C's fmin drops it)
        return self._fold("nlobs_min", expr.args)

    def _print_Max(self, expr: Any) -> str:
        return self._fold("nlobs_max", expr.args)

    def _print_Rational(self, expr: sp.Rational) -> str:
        return f"({c_double(float(expr.p))}/{c_double(float(expr.q))})"

    def _print_Integer(self, expr: sp.Integer) -> str:
        return c_double(float(expr))


def _as_expr(value: Any, what: str) -> sp.Expr:
    """A SymPy expression, or a plain number as one (text is refused: it would have to be parsed)."""
    if isinstance(value, sp.Basic):
        return value  # type: ignore[return-value]
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return sp.Float(float(value)) if isinstance(value, float) else sp.Integer(value)
    raise ModelError(f"{what}: expected SymPy expressions or numbers, got {type(value).__name__}")


def emit_assignments(exprs: Sequence[sp.Expr], inputs: Mapping[sp.Symbol, str], targets: Sequence[str], *,
                     what: str = "expression", indent: str = "    ") -> str:
    """C statements ``target_i = expr_i;`` with common subexpressions in ``const double w…`` locals.

    Parameters
    ----------
    exprs : sequence of sympy expressions
        The values.
    inputs : mapping of sympy.Symbol to str
        Every free symbol, with the C expression it stands for (``"z[0]"``). Each is read once into
        a local ``const double``.
    targets : sequence of str
        The C lvalues, one per expression (``"out[3]"``).
    what : str
        Named in errors.
    indent : str
        Put in front of every line.

    Raises
    ------
    ModelError
        An expression has a free symbol not in ``inputs``, or a function C99 cannot print.
    """
    if len(exprs) != len(targets):
        raise ValueError("one target per expression")
    exprs = [_as_expr(e, what) for e in exprs]
    local = {s: sp.Symbol(f"a{i}", real=True) for i, s in enumerate(inputs)}
    stray = sorted(str(s) for e in exprs for s in e.free_symbols if s not in local)
    if stray:
        raise ModelError(f"{what}: free symbols that are not inputs: {', '.join(sorted(set(stray)))}")
    renamed = [e.xreplace(local) for e in exprs]
    temps, reduced = sp.cse(renamed, symbols=(sp.Symbol(f"w{i}", real=True) for i in itertools.count()))
    printer = _Printer({"strict": False})
    used = set().union(*(e.free_symbols for e in renamed)) if renamed else set()
    lines = [f"{indent}const double {local[s]} = {src};" for s, src in inputs.items() if local[s] in used]
    for sym, value in temps:
        lines.append(f"{indent}const double {sym} = {printer.doprint(value)};")
    for tgt, value in zip(targets, reduced):
        lines.append(f"{indent}{tgt} = {printer.doprint(value)};")
    missing = getattr(printer, "_not_supported", set())
    if missing:
        names = sorted({type(m).__name__ for m in missing})
        raise ModelError(f"{what}: C99 has no form of {', '.join(names)}")
    # a local that no expression reads would warn (-Wunused-variable): only the used ones are declared
    return "\n".join(lines) + ("\n" if lines else "")


def matrix_literal(values: Any) -> str:
    """The entries of an array, row-major, as a C initializer ``{a, b, …}`` of exact doubles.

    Parameters
    ----------
    values : array_like
        Finite numbers (any shape; an empty array gives ``{0.0}``, C has no empty initializer).
    """
    import numpy as np

    flat = np.asarray(values, dtype=float).reshape(-1)
    if flat.size == 0:
        return "{0.0}"
    return "{" + ", ".join(c_double(v) for v in flat) + "}"
