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
"""

from __future__ import annotations

import ast
from collections.abc import Mapping

import sympy as sp

from nlobs.errors import ModelError

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

_BINOPS = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b,
    ast.Pow: lambda a, b: a**b,
}

_MAX_LENGTH = 20_000
_MAX_EXPONENT = 1000


class ExpressionError(ModelError):
    """An expression string uses a construct or name that is not allowed.

    Attributes
    ----------
    expression : str
        The whole expression text.
    offending : str
        The part of it that was rejected.
    """

    def __init__(self, expression: str, offending: str, reason: str) -> None:
        self.expression = expression
        self.offending = offending
        self.reason = reason
        super().__init__(f"{reason}: {offending!r} in expression {expression!r}")


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
        the wrong number of arguments, or a syntax error.
    """
    if not isinstance(text, str):
        raise ExpressionError(repr(text), repr(text), "expression must be a string")
    if len(text) > _MAX_LENGTH:
        raise ExpressionError(text[:60] + "...", text[:60], f"expression longer than {_MAX_LENGTH} characters")
    if not text.strip():
        raise ExpressionError(text, text, "empty expression")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(text, text.strip(), f"syntax error ({exc.msg})") from None
    src = text.strip()
    expr = _Walker(src, symbols).visit(tree.body)
    if expr.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
        raise ExpressionError(text, src, "expression contains a non-finite constant (e.g. a division by zero)")
    return expr


class _Walker:
    def __init__(self, src: str, symbols: Mapping[str, sp.Symbol]) -> None:
        self.src = src
        self.symbols = symbols

    def _segment(self, node: ast.AST) -> str:
        seg = ast.get_source_segment(self.src, node)
        return seg if seg is not None else type(node).__name__

    def _fail(self, node: ast.AST, reason: str) -> ExpressionError:
        return ExpressionError(self.src, self._segment(node), reason)

    def visit(self, node: ast.AST) -> sp.Expr:
        if isinstance(node, ast.Constant):
            v = node.value
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise self._fail(node, "only real numbers are allowed as constants")
            return sp.Integer(v) if isinstance(v, int) else sp.Float(v)
        if isinstance(node, ast.Name):
            if node.id in self.symbols:
                return self.symbols[node.id]
            if node.id in CONSTANTS:
                return CONSTANTS[node.id]
            if node.id in FUNCTIONS:
                raise self._fail(node, "function used without a call")
            raise self._fail(node, "undeclared name")
        if isinstance(node, ast.BinOp):
            op = _BINOPS.get(type(node.op))
            if op is None:
                hint = " (use ** for powers)" if isinstance(node.op, ast.BitXor) else ""
                raise self._fail(node, f"operator {type(node.op).__name__} is not allowed{hint}")
            left, right = self.visit(node.left), self.visit(node.right)
            if isinstance(node.op, ast.Pow) and right.is_Number and abs(float(right)) > _MAX_EXPONENT:
                raise self._fail(node, f"exponent larger than {_MAX_EXPONENT} in magnitude")
            return op(left, right)
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.USub):
                return -self.visit(node.operand)
            if isinstance(node.op, ast.UAdd):
                return self.visit(node.operand)
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
            return fn(*(self.visit(a) for a in node.args))  # type: ignore[operator]
        raise self._fail(node, f"{type(node).__name__} is not allowed in an expression")
