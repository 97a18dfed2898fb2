"""Where a model is not defined: vanishing denominators, negative arguments of roots and logarithms.

:func:`singularities` searches a region of the state space for the places where ``f``, ``g`` or ``h``
of a symbolic model is not defined or not finite (a Monod pole ``K_s + S = 0``, ``sqrt`` of a
negative number, a logarithm of a non-positive one). ``nlobs advise`` replaces a region that holds
one by a suggested box; the drift design names one when drift-observability fails there.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from nlobs._schema import NUMBER, STRING, Record, array, enum, nullable
from nlobs.geometry.region import Box, format_point
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.expressions import as_sympy_expr, as_symbols
from nlobs.systems.symbolic import SymbolicModel

__all__ = ["SAMPLES", "Singularity", "expression_atoms", "real_roots", "sample_points", "singularities"]

#: Sampled points of the region (plus its corners up to n = 10).
SAMPLES = 512


@dataclass(frozen=True)
class Singularity:
    """A place in the region where ``f``, ``g`` or ``h`` is not defined or not finite.

    Attributes
    ----------
    kind : str
        ``"pole"`` (a denominator vanishes), ``"domain"`` (a square-root or logarithm argument is
        negative there) or ``"non-finite"`` (a sampled value of ``f`` is not finite).
    expression : str
        The denominator or argument (parameters substituted), or the equation.
    state : str or None
        The one state it depends on (``None``: several, or a sampled value).
    values : tuple of float
        Its zeros in that state inside the region (empty when not located).
    point : tuple of float or None
        A point of the region where it happens.
    """

    kind: str
    expression: str
    state: str | None
    values: tuple[float, ...] = ()
    point: tuple[float, ...] | None = None

    def describe(self) -> str:
        what = {"pole": f"the denominator {self.expression} vanishes",
                "domain": f"the argument {self.expression} is negative",
                "non-finite": f"{self.expression} is not finite"}[self.kind]
        if self.state is not None and self.values:
            where = ", ".join(f"{self.state} = {v:.4g}" for v in self.values)
            return f"{what} at {where} inside the region"
        return f"{what} at x = {format_point(np.asarray(self.point))}" if self.point is not None else what

    def to_dict(self) -> dict[str, Any]:
        return SINGULARITY_JSON.emit({
            "kind": self.kind, "expression": self.expression, "state": self.state, "values": list(self.values),
            "point": None if self.point is None else list(self.point), "description": self.describe()})


#: The JSON of a :class:`Singularity` (``nlobs advise``'s ``singularities``).
SINGULARITY_JSON = Record("Singularity", {
    "kind": enum("pole", "domain", "non-finite"),
    "expression": STRING,
    "state": nullable(STRING, "the one state it depends on"),
    "values": array(NUMBER, "its zeros in that state inside the region"),
    "point": nullable(array(NUMBER), "a point of the region where it happens"),
    "description": STRING,
})


def sample_points(box: Box, count: int = SAMPLES, seed: int = 0) -> np.ndarray:
    """``count`` seeded points of the box, its two extreme corners and centre, and every corner up to n = 10.

    Parameters
    ----------
    box : Box
        The region.
    count : int
        Seeded random points.
    seed : int
        The seed of those points.

    Returns
    -------
    ndarray, shape (k, n)
    """
    pts = [box.sample(count, seed), box.lower[None, :], box.upper[None, :], ((box.lower + box.upper) / 2)[None, :]]
    if box.n <= 10:
        corners = np.array(np.meshgrid(*[(a, b) for a, b in zip(box.lower, box.upper)], indexing="ij"))
        pts.append(corners.reshape(box.n, -1).T)
    return np.vstack(pts)


def expression_atoms(e: sp.Expr) -> list[tuple[str, sp.Expr]]:
    """Denominators (``"pole"``) and square-root / logarithm arguments (``"domain"``) of an expression.

    Parameters
    ----------
    e : sympy.Expr
        The expression.

    Returns
    -------
    list of (str, sympy.Expr)
    """
    e = as_sympy_expr("e", e)
    out: list[tuple[str, sp.Expr]] = []
    for a in sp.preorder_traversal(e):
        if isinstance(a, sp.Pow) and a.exp.is_number:
            if a.exp.is_negative:
                out.append(("pole", a.base))
            if a.exp.is_Rational and not a.exp.is_Integer and int(a.exp.q) % 2 == 0:
                out.append(("domain", a.base))
        elif isinstance(a, sp.log):
            out.append(("domain", a.args[0]))
    return out


def real_roots(e: sp.Expr, x: sp.Symbol, lo: float, hi: float) -> tuple[float, ...] | None:
    """The real zeros of ``e`` in ``[lo, hi]`` when it is a polynomial in ``x`` of degree ≤ 8 (else ``None``).

    Parameters
    ----------
    e : sympy.Expr
        The expression (its numerator is solved).
    x : sympy.Symbol
        The variable.
    lo, hi : float
        The interval.

    Returns
    -------
    tuple of float or None
    """
    e = as_sympy_expr("e", e)
    (x,) = as_symbols("x", [x])
    num = sp.numer(sp.together(e))
    try:
        poly = sp.Poly(num, x)
    except sp.PolynomialError:
        return None
    if poly.degree() > 8 or poly.degree() < 1:
        return None
    coeffs = [float(c) for c in poly.all_coeffs()]
    roots = np.roots(coeffs)
    real = sorted({float(r.real) for r in roots if abs(r.imag) <= 1e-9 * (1 + abs(r.real)) and lo <= r.real <= hi})
    return tuple(real)


def singularities(model: SymbolicModel, box: Box) -> tuple[Singularity, ...]:
    """Where ``f``, ``g`` or ``h`` is not defined in the box: vanishing denominators, negative roots' arguments.

    Each denominator and each argument of an even root or a logarithm (parameters substituted) is
    evaluated at :data:`SAMPLES` seeded points and the corners; one of a single state that is a
    polynomial in it is solved for its zeros inside the box. Then ``f`` itself is evaluated at the
    points (zero input) and a non-finite value is reported with its point.

    Parameters
    ----------
    model : SymbolicModel
        The model (its parameters are substituted).
    box : Box
        The state region searched.

    Returns
    -------
    tuple of Singularity
        Empty when none was found.
    """
    subs = model.substituted()
    exprs = [e.subs(subs) for e in (*model.rhs, *model.h)]
    xs = tuple(model.x)
    states = set(xs)
    pts = sample_points(box)
    found: list[Singularity] = []
    seen: set[tuple[str, str]] = set()
    for e in exprs:
        for kind, atom in expression_atoms(e):
            if not atom.free_symbols or not atom.free_symbols <= states or (kind, str(atom)) in seen:
                continue
            seen.add((kind, str(atom)))
            fn = compile_matrix(sp.Matrix([atom]), (xs,), vector=True, what=f"the {kind} {atom}")
            with np.errstate(all="ignore"):
                v = np.asarray(fn(pts), dtype=float)[:, 0]
            ok = np.isfinite(v)
            if kind == "domain":
                bad = bool(np.any(v[ok] < 0))
            else:
                bad = bool(np.any(v[ok] == 0) or (np.any(v[ok] > 0) and np.any(v[ok] < 0)))
            if not bad:
                continue
            free = sorted(atom.free_symbols, key=xs.index)
            state, values = None, ()
            if len(free) == 1:
                i = xs.index(free[0])
                roots = real_roots(atom, free[0], float(box.lower[i]), float(box.upper[i]))
                if roots is not None:
                    state, values = model.states[i], roots
            k = int(np.argmin(np.abs(np.where(ok, v, 0.0)))) if kind == "pole" else int(np.argmax(v <= 0))
            found.append(Singularity(kind, str(atom), state, values, tuple(float(c) for c in pts[k])))
    if not found:
        f = compile_matrix(sp.Matrix([e.subs({u: 0 for u in model.u}) for e in exprs[: model.n]]), (xs,), vector=True,
                           what="f")
        with np.errstate(all="ignore"):
            fv = np.asarray(f(pts), dtype=float)
        nonfinite = ~np.all(np.isfinite(fv), axis=-1)
        if np.any(nonfinite):
            k = int(np.argmax(nonfinite))
            found.append(Singularity("non-finite", "f(x)", None, (), tuple(float(c) for c in pts[k])))
    return tuple(found)
