"""Whitelisted parsing of expression strings into SymPy.

Text from a model file or the command line is **never** passed to ``eval``,
``exec``, ``sympify`` or ``parse_expr``. It is parsed by :func:`ast.parse` in
``"eval"`` mode and the tree is walked node by node; only these constructs are
accepted:

* numbers (``int``, ``float``; not ``bool``, ``complex`` or strings),
* declared names (states, inputs, parameters) and the constant ``pi``,
* binary ``+ - * / **``, unary ``-`` and ``+``,
* calls of the functions in :data:`FUNCTIONS` with positional arguments only.

Anything else (attribute access, subscripts, lambdas, comparisons, keyword
arguments, ``__import__(...)``, ``^``) raises :class:`ExpressionError` naming
the offending text.

Small text must not make nlobs hang or crash, so the parser also bounds

* the length of the text (:data:`MAX_LENGTH` characters),
* its nesting (:data:`MAX_DEPTH` levels of calls, powers, unary signs and
  parenthesised sums or products; a flat sum or product is one level, however
  long, up to the roughly 2500 chained operators Python's own parser accepts;
  text beyond either bound raises :class:`ExpressionError`, never
  ``RecursionError``),
* the size of every number, as written and as SymPy folds it while building
  the expression: the numerator and denominator of an exact number are below
  ``10**MAX_DIGITS`` (:data:`MAX_DIGITS` digits), a float lies between
  ``10**-MAX_DIGITS`` and ``10**MAX_DIGITS`` in magnitude (or is zero), so every
  number is a finite double. The size of a power or of a product of numbers is
  estimated *before* SymPy computes it, so ``((9**999)**999)**999`` is refused
  at once instead of being evaluated,
* every numeric exponent, as written and after SymPy combined powers
  (``(x**999)**999`` is ``x**998001``), to :data:`MAX_EXPONENT` in magnitude.

Public functions of nlobs that take SymPy expressions from a caller convert
them with :func:`as_sympy_expr` / :func:`as_sympy_matrix`: strings are parsed by
:func:`parse_expression` where the caller declared the names, and rejected
otherwise, because SymPy's own constructors (``Matrix``, ``diff``, ``S``, ...)
would hand a string to ``eval``.
"""

from __future__ import annotations

import ast
import math
import re
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import sympy as sp

from nlobs.errors import InvalidArgumentError, ModelError

#: Functions an expression may call, with their arity.
FUNCTIONS: Mapping[str, tuple[object, int]] = {
    "sin": (sp.sin, 1),
    "cos": (sp.cos, 1),
    "tan": (sp.tan, 1),
    "asin": (sp.asin, 1),
    "acos": (sp.acos, 1),
    "atan": (sp.atan, 1),
    "atan2": (sp.atan2, 2),
    "sinh": (sp.sinh, 1),
    "cosh": (sp.cosh, 1),
    "tanh": (sp.tanh, 1),
    "exp": (sp.exp, 1),
    "log": (sp.log, 1),
    "sqrt": (sp.sqrt, 1),
    "abs": (sp.Abs, 1),
    "sign": (sp.sign, 1),
}

#: Named constants an expression may use.
CONSTANTS: Mapping[str, sp.Expr] = {"pi": sp.pi}

#: Longest expression text, in characters.
MAX_LENGTH = 20_000
#: Largest magnitude of a numeric exponent (as written, and after SymPy combined powers).
MAX_EXPONENT = 1000
#: Deepest nesting of calls, powers, unary signs and parenthesised sums/products.
MAX_DEPTH = 100
#: Numbers are below ``10**MAX_DIGITS`` (exact numbers: numerator and denominator;
#: floats: in magnitude, and above ``10**-MAX_DIGITS`` unless zero).
MAX_DIGITS = 300

_SHOWN = 200  # characters of the expression quoted in a message
_LONG_NUMBER = re.compile(rf"(?<![A-Za-z_0-9])[0-9]{{{MAX_DIGITS + 1},}}")
_LOG10_2 = math.log10(2.0)


class ExpressionError(ModelError):
    """An expression string uses a construct or name that is not allowed, or is too large.

    Attributes
    ----------
    expression : str
        The whole expression text.
    offending : str
        The part of it that was rejected.
    reason : str
        Why it was rejected.
    """

    def __init__(self, expression: str, offending: str, reason: str) -> None:
        self.expression = expression
        self.offending = offending
        self.reason = reason
        super().__init__(f"{reason}: {_short(offending)!r} in expression {_short(expression)!r}")


def _short(text: str) -> str:
    return text if len(text) <= _SHOWN else text[:_SHOWN] + "..."


def parse_expression(text: str, symbols: Mapping[str, sp.Symbol]) -> sp.Expr:
    """Parse ``text`` into a SymPy expression over the declared ``symbols``.

    Parameters
    ----------
    text : str
        The expression, e.g. ``"x1*x2 - x1**3"``.
    symbols : mapping of str to sympy.Symbol
        Every name the expression may use (states, inputs, parameters).

    Returns
    -------
    sympy.Expr

    Raises
    ------
    ExpressionError
        On any construct outside the whitelist, an undeclared name, a call with
        the wrong number of arguments, a syntax error, a non-finite or non-real
        constant, or text beyond the bounds of the module docstring
        (:data:`MAX_LENGTH`, :data:`MAX_DEPTH`, :data:`MAX_DIGITS`,
        :data:`MAX_EXPONENT`).
    """
    if not isinstance(text, str):
        raise ExpressionError(repr(text), repr(text), "expression must be a string")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(text[:60] + "...", text[:60], f"expression longer than {MAX_LENGTH} characters")
    if not text.strip():
        raise ExpressionError(text, text, "empty expression")
    src = text.strip()
    long_number = _LONG_NUMBER.search(src)
    if long_number:  # before ast.parse, whose int() conversion has its own, larger limit
        raise ExpressionError(text, long_number.group()[:60] + "...",
                              f"number literal with more than {MAX_DIGITS} digits")
    try:
        tree = ast.parse(src, mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(text, src, f"syntax error ({exc.msg})") from None
    except (RecursionError, MemoryError, ValueError):  # Python's parser gives up before MAX_DEPTH is checked
        raise ExpressionError(text, src[:60], "expression too complex to parse (nested too deeply, or a chain "
                              "of more than about 2500 operators)") from None
    try:
        expr = _Walker(src, symbols).visit(tree.body, 0)
    except RecursionError:  # SymPy's own recursion on a large (but allowed) expression
        raise ExpressionError(text, src[:60], "expression too large to build") from None
    if expr.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
        raise ExpressionError(text, src, "expression contains a non-finite constant (e.g. a division by zero)")
    if expr.has(sp.I):
        raise ExpressionError(text, src,
                              "expression contains a non-real constant (e.g. the square root of a negative number)")
    for p in expr.atoms(sp.Pow):
        if p.exp.is_Number and abs(float(p.exp)) > MAX_EXPONENT:
            raise ExpressionError(text, src, f"exponent larger than {MAX_EXPONENT} in magnitude once powers are "
                                  f"combined (**{p.exp})")
    return expr


def _size(v: sp.Expr) -> tuple[float, float]:
    """``(log10 |numerator|, log10 denominator)`` of a number.

    A float ``f`` gives ``(max(l, 0), max(-l, 0))`` with ``l = log10 |f|``.
    """
    if isinstance(v, sp.Rational):
        p, q = abs(int(v.p)), int(v.q)
        return (math.log10(p) if p else 0.0, math.log10(q))
    if isinstance(v, sp.Float):
        man, exp = int(v._mpf_[1]), int(v._mpf_[2])
        if not man:
            return (0.0, 0.0)
        f = abs(float(v))
        lg = math.log10(f) if 0.0 < f < math.inf else (man.bit_length() + exp) * _LOG10_2
        return (max(lg, 0.0), max(-lg, 0.0))
    return (0.0, 0.0)


def _const_size(v: sp.Expr) -> float:
    """An upper bound of ``log10`` of the largest magnitude SymPy makes of the constants in ``v`` (and of their
    reciprocals): a number's digits; a constant expression (``pi``, ``E``, ``exp(3)``, ``pi**7``) evaluated to 15
    digits; a product adds its factors' sizes, a sum takes the largest term's plus ``log10`` of the number of
    terms, a power with a number for exponent multiplies its base's size by it (what SymPy's expansion of
    ``(3*x)**999`` into ``3**999 * x**999`` would create). Symbols and their functions count 0 (their values are the
    run's business)."""
    if v.is_Number:
        return max(_size(v))
    if not v.free_symbols:  # evaluated in SymPy's floats, whose exponent does not overflow (exp(1000) is 10^434)
        try:
            n = v.evalf(15)
            if n == 0 or n.has(sp.zoo, sp.oo, -sp.oo, sp.nan):  # a non-finite one is refused by name at the end
                return 0.0
            lg = float(sp.log(abs(n), 10).evalf(15))
        except (TypeError, ValueError, OverflowError, ZeroDivisionError):
            return math.inf
        return abs(lg) if math.isfinite(lg) else math.inf
    if v.is_Mul:
        return float(sum(_const_size(f) for f in v.args))
    if v.is_Add:
        return max(_const_size(t) for t in v.args) + math.log10(len(v.args))
    if v.is_Pow and v.exp.is_Number:
        return abs(float(v.exp)) * _const_size(v.base)
    return 0.0


def _non_real(v: sp.Expr) -> bool:
    """Whether ``v``, a constant (no free symbols), has a non-zero imaginary part (``asin(2)``, ``(-8)**(1/3)``)."""
    if v.free_symbols or v.is_Number:
        return False
    if v.is_real is True:
        return False
    try:
        z = complex(v.evalf(15))
    except (TypeError, ValueError, OverflowError, ZeroDivisionError):
        return True
    return abs(z.imag) > 1e-12 * max(1.0, abs(z.real))


def _out_of_range(what: str, size: float) -> str:
    return f"{what} out of range (about 10^{size:.0f}; the limit is 10^{MAX_DIGITS})"


class _Walker:
    def __init__(self, src: str, symbols: Mapping[str, sp.Symbol]) -> None:
        self.src = src
        self.symbols = symbols

    def _segment(self, node: ast.AST) -> str:
        seg = ast.get_source_segment(self.src, node)
        return seg if seg is not None else type(node).__name__

    def _fail(self, node: ast.AST, reason: str) -> ExpressionError:
        return ExpressionError(self.src, self._segment(node), reason)

    def _number(self, node: ast.AST, value: sp.Expr) -> sp.Expr:
        """``value``, checked against :data:`MAX_DIGITS` when it is a number, and when it is a constant expression
        (``pi**999``, ``exp(1000)``) against the same bound and for a non-real value (``asin(2)``)."""
        if value.is_Number:
            if max(_size(value)) >= MAX_DIGITS:
                raise self._fail(node, _out_of_range("number", max(_size(value))))
        elif not value.free_symbols:
            size = _const_size(value)
            if size >= MAX_DIGITS:
                raise self._fail(node, _out_of_range("constant", size))
            if _non_real(value):
                raise self._fail(node, "non-real constant (e.g. asin of a number above 1, or an odd root of a "
                                       "negative number: write -(8**(1/3)) for the real root)")
        return value

    def visit(self, node: ast.AST, depth: int) -> sp.Expr:
        if depth > MAX_DEPTH:
            raise self._fail(node, f"expression nested deeper than {MAX_DEPTH} levels")
        if isinstance(node, ast.Constant):
            v = node.value
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise self._fail(node, "only real numbers are allowed as constants")
            if isinstance(v, float) and not math.isfinite(v):
                raise self._fail(node, "float literal overflows a double")
            if isinstance(v, int) and v.bit_length() * _LOG10_2 > MAX_DIGITS + 1:  # before sp.Integer converts it
                raise self._fail(node, f"integer literal with more than {MAX_DIGITS} digits")
            return self._number(node, sp.Integer(v) if isinstance(v, int) else sp.Float(v))
        if isinstance(node, ast.Name):
            if node.id in self.symbols:
                return self.symbols[node.id]
            if node.id in CONSTANTS:
                return CONSTANTS[node.id]
            if node.id in FUNCTIONS:
                raise self._fail(node, "function used without a call")
            raise self._fail(node, "undeclared name")
        if isinstance(node, ast.BinOp):
            if isinstance(node.op, (ast.Add, ast.Sub)):
                return self._sum(node, depth)
            if isinstance(node.op, (ast.Mult, ast.Div)):
                return self._product(node, depth)
            if isinstance(node.op, ast.Pow):
                return self._power(node, depth)
            hint = " (use ** for powers)" if isinstance(node.op, ast.BitXor) else ""
            raise self._fail(node, f"operator {type(node.op).__name__} is not allowed{hint}")
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.USub):
                return -self.visit(node.operand, depth + 1)
            if isinstance(node.op, ast.UAdd):
                return self.visit(node.operand, depth + 1)
            raise self._fail(node, f"operator {type(node.op).__name__} is not allowed")
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name):
                raise self._fail(node.func, "only calls of whitelisted functions by plain name are allowed")
            entry = FUNCTIONS.get(node.func.id)
            if entry is None:
                raise self._fail(node.func, "function is not in the whitelist " + ", ".join(sorted(FUNCTIONS)))
            if node.keywords:
                raise self._fail(node, "keyword arguments are not allowed")
            fn, arity = entry
            if len(node.args) != arity or any(isinstance(a, ast.Starred) for a in node.args):
                raise self._fail(node, f"{node.func.id} takes {arity} argument(s)")
            args = [self.visit(a, depth + 1) for a in node.args]
            return self._number(node, fn(*args))  # type: ignore[operator]
        raise self._fail(node, f"{type(node).__name__} is not allowed in an expression")

    @staticmethod
    def _chain(node: ast.BinOp, ops: tuple[type, ...]) -> list[tuple[ast.operator | None, ast.expr]]:
        """The operands of a left-nested chain ``a op b op c ...`` (read iteratively: no recursion on its length)."""
        items: list[tuple[ast.operator | None, ast.expr]] = []
        cur: ast.expr = node
        while isinstance(cur, ast.BinOp) and isinstance(cur.op, ops):
            items.append((cur.op, cur.right))
            cur = cur.left
        items.append((None, cur))
        items.reverse()
        return items

    def _sum(self, node: ast.BinOp, depth: int) -> sp.Expr:
        terms = []
        for op, operand in self._chain(node, (ast.Add, ast.Sub)):
            v = self.visit(operand, depth + 1)
            terms.append(-v if isinstance(op, ast.Sub) else v)
        return self._number(node, sp.Add(*terms))

    def _product(self, node: ast.BinOp, depth: int) -> sp.Expr:
        factors = []
        for op, operand in self._chain(node, (ast.Mult, ast.Div)):
            v = self.visit(operand, depth + 1)
            factors.append(sp.Pow(v, -1) if isinstance(op, ast.Div) else v)
        sizes = [_size(f) for f in factors if f.is_Number]
        size = max(sum(s[0] for s in sizes), sum(s[1] for s in sizes)) if sizes else 0.0
        size = max(size, sum(_const_size(f) for f in factors if not f.is_Number))
        if size >= MAX_DIGITS:  # estimated before SymPy multiplies the numbers out
            raise self._fail(node, _out_of_range("product of numbers", size))
        return self._number(node, sp.Mul(*factors))

    def _power(self, node: ast.BinOp, depth: int) -> sp.Expr:
        base, exp = self.visit(node.left, depth + 1), self.visit(node.right, depth + 1)
        if exp.is_Number:
            e = abs(float(exp))
            if e > MAX_EXPONENT:
                raise self._fail(node, f"exponent larger than {MAX_EXPONENT} in magnitude")
            size = e * _const_size(base)  # (3*x)**999 is 3**999 * x**999 once SymPy distributes it
            if size >= MAX_DIGITS:  # estimated before SymPy computes the power
                raise self._fail(node, _out_of_range("power", size))
        value = base**exp
        if value.has(sp.I) or (base.is_Number and base.is_negative and exp.is_Number and not exp.is_Integer):
            raise self._fail(node, "non-real constant (an even or fractional root of a negative number: write "
                                   "-(8**(1/3)) for the real cube root)")
        return self._number(node, value)


# ---------------------------------------------------------------------- values given to the Python API
def _leaf(name: str, value: Any, symbols: Mapping[str, sp.Symbol] | None) -> Any:
    if isinstance(value, str):
        if symbols is None:
            raise InvalidArgumentError(
                f"{name}: expected a SymPy expression, got the string {_short(value)!r}; text is not evaluated "
                "(build the expression from sympy.Symbol objects)")
        try:
            return parse_expression(value, symbols)
        except ExpressionError as exc:
            raise ExpressionError(exc.expression, exc.offending, f"{name}: {exc.reason}") from None
    if isinstance(value, (sp.Expr, sp.MatrixBase)):
        return value
    if isinstance(value, (bool, np.bool_)):
        raise InvalidArgumentError(f"{name}: expected a SymPy expression or a number, got {value!r}")
    if isinstance(value, (int, np.integer)):
        return sp.Integer(int(value))
    if isinstance(value, (float, np.floating)):
        return sp.Float(float(value))
    raise InvalidArgumentError(f"{name}: expected a SymPy expression or a number, got {type(value).__name__} "
                               f"{_short(repr(value))}")


def _is_nested(value: Any) -> bool:
    return isinstance(value, (list, tuple, np.ndarray))


def as_sympy_expr(name: str, value: Any, symbols: Mapping[str, sp.Symbol] | None = None) -> sp.Expr:
    """A caller's scalar as a SymPy expression, never evaluating text.

    Parameters
    ----------
    name : str
        The argument's name, for messages.
    value : sympy.Expr, int, float or str
        A string is parsed by :func:`parse_expression` over ``symbols``.
    symbols : mapping of str to sympy.Symbol, optional
        The names a string may use; without it a string is rejected.

    Returns
    -------
    sympy.Expr

    Raises
    ------
    InvalidArgumentError
        If ``value`` is a string and no ``symbols`` are given, or is neither a
        SymPy expression nor a real number.
    ExpressionError
        If a string does not parse.
    """
    out = _leaf(name, value, symbols)
    if isinstance(out, sp.MatrixBase):
        raise InvalidArgumentError(f"{name}: expected a scalar expression, got a matrix of shape {out.shape}")
    return out


def as_sympy_matrix(name: str, value: Any, symbols: Mapping[str, sp.Symbol] | None = None) -> sp.ImmutableMatrix:
    """A caller's matrix or vector (a SymPy matrix, or nested sequences of entries) as a SymPy matrix.

    A flat sequence becomes a column, as with ``sympy.Matrix``; every entry is
    checked by :func:`as_sympy_expr` first, so no string reaches SymPy.

    Parameters
    ----------
    name : str
        The argument's name, for messages (entries are named ``name[i]`` or ``name[i][j]``).
    value : sympy.Matrix, ndarray or (nested) sequence
    symbols : mapping of str to sympy.Symbol, optional
        The names string entries may use; without it strings are rejected.

    Returns
    -------
    sympy.ImmutableMatrix

    Raises
    ------
    InvalidArgumentError
        For a string without ``symbols``, an entry that is neither a SymPy
        expression nor a real number, or a value that is not a matrix or sequence.
    ExpressionError
        If a string entry does not parse.
    """
    if isinstance(value, sp.MatrixBase):
        return value.as_immutable()
    if isinstance(value, str) or not isinstance(value, Iterable):
        raise InvalidArgumentError(f"{name}: expected a SymPy matrix or a sequence of expressions, got "
                                   f"{type(value).__name__} {_short(repr(value))}")
    rows = value.tolist() if isinstance(value, np.ndarray) else list(value)
    entries: list[Any] = []
    for i, row in enumerate(rows):
        if _is_nested(row):
            cells = row.tolist() if isinstance(row, np.ndarray) else list(row)
            entries.append([_leaf(f"{name}[{i}][{j}]", c, symbols) for j, c in enumerate(cells)])
        else:
            entries.append(_leaf(f"{name}[{i}]", row, symbols))
    try:
        return sp.ImmutableMatrix(entries)
    except (ValueError, TypeError, IndexError) as exc:
        raise InvalidArgumentError(f"{name}: not a matrix ({exc})") from None


def as_symbols(name: str, value: Any) -> tuple[sp.Symbol, ...]:
    """A caller's coordinates or argument group as a tuple of ``sympy.Symbol`` (no strings: SymPy would parse them).

    Raises
    ------
    InvalidArgumentError
        If ``value`` is a string or holds anything but SymPy symbols.
    """
    if isinstance(value, sp.MatrixBase):
        value = list(value)
    if isinstance(value, (str, sp.Basic)) or not isinstance(value, Iterable):
        raise InvalidArgumentError(f"{name}: expected a sequence of sympy.Symbol, got {type(value).__name__} "
                                   f"{_short(repr(value))}")
    out = tuple(value)
    for i, s in enumerate(out):
        if not isinstance(s, sp.Symbol):
            raise InvalidArgumentError(f"{name}[{i}]: expected a sympy.Symbol, got {type(s).__name__} "
                                       f"{_short(repr(s))}")
    return out
