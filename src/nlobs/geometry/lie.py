"""Lie derivatives, covector Lie derivatives and Lie brackets (SymPy).

Notation of seeds 002 (2.1) and 003 (Sec. 2), for vector fields ``f, g`` and a
scalar function ``φ`` on an open set of ``ℝⁿ`` with coordinates ``x``::

    L_f φ      = ⟨dφ, f⟩ = (∂φ/∂x) f                         (002: 2.1)
    L_f^{k+1} φ = L_f (L_f^k φ),   L_f^0 φ = φ
    [f, g]     = (∂g/∂x) f − (∂f/∂x) g                        (003: Sec. 2)
    (L_f ω)ᵢ   = Σⱼ fⱼ ∂ωᵢ/∂xⱼ + Σⱼ ωⱼ ∂fⱼ/∂xᵢ                  (ω a covector field, a row)

so that ``L_f dφ = d(L_f φ)`` (tested). Expressions are not simplified here:
callers decide (``tidy`` is a cheap, exact normalisation for rational functions).

Every argument must be built from SymPy objects (or numbers): a string raises
:class:`~nlobs.errors.InvalidArgumentError`, because SymPy would evaluate it.
Text is parsed with :func:`nlobs.systems.expressions.parse_expression`.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from nlobs.errors import DimensionError
from nlobs.systems.expressions import as_sympy_expr, as_sympy_matrix, as_symbols

Symbols = Sequence[sp.Symbol]


def _column(name: str, v: sp.MatrixBase | Sequence[sp.Expr], n: int) -> sp.Matrix:
    mat = sp.Matrix(as_sympy_matrix(name, v))
    if mat.shape == (1, n) and n != 1:
        mat = mat.T
    if mat.shape != (n, 1):
        raise DimensionError(f"{name}: expected a vector field with {n} entries, got shape {mat.shape}")
    return mat


def tidy(expr: sp.Expr) -> sp.Expr:
    """A cheap exact normalisation: ``cancel`` for rational functions, ``expand`` otherwise."""
    if not isinstance(expr, sp.Basic):
        expr = as_sympy_expr("expr", expr)
    if expr.is_rational_function():
        return sp.cancel(expr)
    return sp.expand(expr)


#: Largest expression (``count_ops``) handed to ``sympy.simplify``; larger ones are only :func:`tidy`-ed.
SIMPLIFY_OPS_LIMIT = 300


def simplify_bounded(expr: sp.Expr) -> sp.Expr:
    """:func:`tidy`, then ``sympy.simplify`` when the expression is small enough (:data:`SIMPLIFY_OPS_LIMIT`)."""
    expr = tidy(expr)
    if sp.count_ops(expr) <= SIMPLIFY_OPS_LIMIT:
        expr = sp.simplify(expr)
    return expr


def gradient(phi: sp.Expr, x: Symbols) -> sp.Matrix:
    """``dφ = ∂φ/∂x`` as a 1 × n row."""
    phi = as_sympy_expr("phi", phi)
    return sp.Matrix([[sp.diff(phi, xi) for xi in as_symbols("x", x)]])


def lie_derivative(phi: sp.Expr, f: sp.MatrixBase | Sequence[sp.Expr], x: Symbols, order: int = 1) -> sp.Expr:
    """``L_f^order φ`` (Dalla Mora, Germani & Manes (2.1)).

    Parameters
    ----------
    phi : sympy.Expr
        Scalar function of ``x``.
    f : sympy.Matrix or sequence
        Vector field (n entries).
    x : sequence of sympy.Symbol
        Coordinates.
    order : int
        Number of iterations (``0`` returns ``phi``).
    """
    if order < 0:
        raise DimensionError(f"order: expected a non-negative integer, got {order}")
    x = as_symbols("x", x)
    fv = _column("f", f, len(x))
    out = as_sympy_expr("phi", phi)
    for _ in range(order):
        out = tidy((gradient(out, x) * fv)[0, 0])
    return out


def lie_derivatives(phi: sp.Expr, f: sp.MatrixBase | Sequence[sp.Expr], x: Symbols, count: int) -> tuple[sp.Expr, ...]:
    """``(L_f^0 φ, …, L_f^{count−1} φ)``, each computed from the previous one."""
    x = as_symbols("x", x)
    fv = _column("f", f, len(x))
    out: list[sp.Expr] = []
    cur = as_sympy_expr("phi", phi)
    for k in range(count):
        out.append(cur)
        if k + 1 < count:
            cur = tidy((gradient(cur, x) * fv)[0, 0])
    return tuple(out)


def lie_derivative_along_columns(phi: sp.Expr, g: sp.MatrixBase, x: Symbols) -> sp.Matrix:
    """``L_g φ = [L_{g_1} φ, …, L_{g_m} φ]`` (1 × m) for a matrix ``g`` of m vector fields (Dalla Mora, Germani & Manes (2.7))."""
    x = as_symbols("x", x)
    g = as_sympy_matrix("g", g)
    if g.shape[0] != len(x):
        raise DimensionError(f"g: expected {len(x)} rows, got shape {g.shape}")
    if g.shape[1] == 0:
        return sp.zeros(1, 0)
    return (gradient(phi, x) * g).applyfunc(tidy)


def lie_bracket(f: sp.MatrixBase | Sequence[sp.Expr], g: sp.MatrixBase | Sequence[sp.Expr], x: Symbols) -> sp.Matrix:
    """``[f, g] = (∂g/∂x) f − (∂f/∂x) g`` (Röbenack, Sec. 2)."""
    x = as_symbols("x", x)
    n = len(x)
    fv, gv = _column("f", f, n), _column("g", g, n)
    X = sp.Matrix(x)
    return (gv.jacobian(X) * fv - fv.jacobian(X) * gv).applyfunc(tidy)


def covector_lie_derivative(omega: sp.MatrixBase, f: sp.MatrixBase | Sequence[sp.Expr], x: Symbols) -> sp.Matrix:
    """Lie derivative of a covector field ``ω`` (a 1 × n row) along ``f``.

    ``(L_f ω)ᵢ = Σⱼ fⱼ ∂ωᵢ/∂xⱼ + Σⱼ ωⱼ ∂fⱼ/∂xᵢ``; for an exact form ``ω = dφ`` it
    equals ``d(L_f φ)``.
    """
    x = as_symbols("x", x)
    n = len(x)
    om = sp.Matrix(as_sympy_matrix("omega", omega))
    if om.shape == (n, 1) and n != 1:
        om = om.T
    if om.shape != (1, n):
        raise DimensionError(f"omega: expected a 1 × {n} covector field, got shape {om.shape}")
    fv = _column("f", f, n)
    X = sp.Matrix(x)
    return (fv.T * om.T.jacobian(X).T + om * fv.jacobian(X)).applyfunc(tidy)
