"""Regions of the state space and the evidence-backed tests run on them.

The differential-geometric conditions of Dalla Mora, Germani & Manes and of Röbenack are stated on a set
``Ω`` ("``L_g L_f^k h(x) = 0`` for all ``x ∈ Ω``", "``Q_s`` nonsingular in ``Ω``").
nlobs decides them by a symbolic test where SymPy can prove it, backed by
evaluation at seeded random points of a :class:`Box`; every verdict carries its
evidence (the method, the number of points, and a witness point).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_vector
from nlobs.errors import InvalidArgumentError, NonFiniteError
from nlobs.geometry.lie import PolynomialMatrixFunction, simplify_bounded
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.expressions import as_sympy_expr, as_symbols


#: A numeric zero test calls a value zero when ``|value| ≤ ZERO_RTOL · Σ|terms|`` (cancellation level).
ZERO_RTOL = 1e-9


def format_point(pt: Sequence[float]) -> str:
    """``(x1, x2, …)`` with 4 significant digits, for evidence strings."""
    return "(" + ", ".join(f"{v:.4g}" for v in pt) + ")"


@dataclass(frozen=True)
class Box:
    """An axis-aligned box ``{x : lower ≤ x ≤ upper}`` of ``ℝⁿ``.

    Parameters
    ----------
    lower, upper : array_like, shape (n,)
        Finite bounds with ``lower < upper`` componentwise.

    Examples
    --------
    >>> import numpy as np
    >>> box = Box.around([0.0, 1.0], 0.5)
    >>> box.n, box.describe(), Box.unit(2).describe()
    (2, '[-0.5, 0.5] × [0.5, 1.5]', '[-1, 1] × [-1, 1]')
    >>> pts = box.sample(100, seed=0)
    >>> pts.shape, bool(np.all((box.lower <= pts) & (pts <= box.upper)))
    ((100, 2), True)
    >>> bool(np.array_equal(pts, box.sample(100, seed=0)))  # seeded: the same points every time
    True

    An empty side is refused.

    >>> try:
    ...     Box([0.0, 1.0], [1.0, 1.0])
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError Box: upper[1] = 1 must exceed lower[1] = 1
    """

    lower: Array
    upper: Array

    def __post_init__(self) -> None:
        lo = as_vector("lower", self.lower)
        hi = as_vector("upper", self.upper, lo.size)
        if np.any(hi <= lo):
            i = int(np.argmax(hi <= lo))
            raise InvalidArgumentError(f"Box: upper[{i}] = {hi[i]:g} must exceed lower[{i}] = {lo[i]:g}")
        lo.setflags(write=False)
        hi.setflags(write=False)
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    @classmethod
    def around(cls, center: ArrayLike, half_width: float | ArrayLike) -> Box:
        """The box ``center ± half_width``."""
        c = as_vector("center", center)
        w = np.broadcast_to(np.asarray(half_width, dtype=float), c.shape)
        return cls(c - w, c + w)

    @classmethod
    def unit(cls, n: int) -> Box:
        """The default region ``[−1, 1]ⁿ``."""
        return cls(-np.ones(n), np.ones(n))

    @property
    def n(self) -> int:
        return int(self.lower.size)

    def sample(self, count: int, seed: int | np.random.Generator = 0) -> Array:
        """``count`` uniform points, shape ``(count, n)``, from a seeded generator."""
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        return self.lower + (self.upper - self.lower) * rng.random((int(count), self.n))

    def describe(self) -> str:
        return " × ".join(f"[{a:g}, {b:g}]" for a, b in zip(self.lower, self.upper))


@dataclass(frozen=True)
class ZeroTest:
    """Whether a scalar expression vanishes on a region, with its evidence.

    Attributes
    ----------
    zero : bool
        ``True`` if the expression vanishes on the region.
    method : {"symbolic", "numeric"}
        ``"symbolic"``: decided exactly (a rational function's canonical form, or
        ``simplify`` proving ``0``); ``"numeric"``: decided by evaluation at ``points``
        random points (``zero`` then means "at the cancellation level at every point").
    points : int
        Number of finite evaluations made (0 for a symbolic proof).
    witness : tuple of float or None
        A point where the expression is largest in magnitude (``None`` when proven zero).
    value : float or None
        The expression's value at ``witness``.

    Examples
    --------
    :func:`vanishes_on` returns one: ``|x1| − x1`` vanishes where ``x1 > 0`` (only numerically decidable,
    ``abs`` is not rational) and not on ``[−1, 1]³``, where the witness shows a point with ``x1 < 0``.

    >>> import sympy as sp
    >>> x = sp.symbols("x1:4", real=True)
    >>> t = vanishes_on(sp.Abs(x[0]) - x[0], x, Box([0.1, -1.0, -1.0], [1.0, 1.0, 1.0]))
    >>> t.zero, t.method, t.describe()
    (True, 'numeric', '= 0 at 64 sampled points (numeric)')
    >>> t = vanishes_on(sp.Abs(x[0]) - x[0], x, Box.unit(3))
    >>> t.zero, t.method, t.witness[0] < 0, abs(t.value + 2 * t.witness[0]) < 1e-12
    (False, 'numeric', True, True)
    """

    zero: bool
    method: Literal["symbolic", "numeric"]
    points: int
    witness: tuple[float, ...] | None
    value: float | None

    def describe(self) -> str:
        if self.zero and self.method == "symbolic":
            return "≡ 0 (symbolic)"
        if self.zero:
            return f"= 0 at {self.points} sampled points (numeric)"
        how = "≢ 0 (exact)" if self.method == "symbolic" else "≠ 0"
        return f"{how}, e.g. {self.value:.4g} at x = {format_point(self.witness or ())}"


def vanishes_on(
    expr: sp.Expr,
    x: Sequence[sp.Symbol],
    region: Box,
    *,
    samples: int = 64,
    seed: int = 0,
) -> ZeroTest:
    """Decide whether ``expr`` vanishes on ``region``.

    A rational function of ``x`` (every polynomial model, parameters being exact rationals) is decided
    exactly: ``cancel`` gives its canonical form, which is ``0`` iff it vanishes identically, and a
    nonzero rational function cannot vanish on an open box (its witness is the sampled point where it
    is largest). Otherwise SymPy's ``simplify`` may prove it zero; failing that, it is evaluated at
    ``samples`` seeded points and called zero where ``|value| ≤ ZERO_RTOL · Σ|terms|`` (the level of
    cancellation between its terms), so a small but genuine value is not mistaken for zero.

    Raises
    ------
    NonFiniteError
        If the expression is finite at none of the sampled points (no evidence either way).

    Examples
    --------
    ``sin² + cos² − 1`` is proven zero by SymPy; a polynomial is decided exactly (a nonzero one cannot
    vanish on an open box), its witness being the sampled point where it is largest.

    >>> import sympy as sp
    >>> x = sp.symbols("x1:4", real=True)
    >>> vanishes_on(sp.sin(x[0])**2 + sp.cos(x[0])**2 - 1, x, Box.unit(3)).describe()
    '≡ 0 (symbolic)'
    >>> t = vanishes_on(x[0] * x[1] - sp.Rational(1, 4), x, Box.unit(3))
    >>> t.zero, t.method, abs(t.value - (t.witness[0] * t.witness[1] - 0.25)) < 1e-12
    (False, 'symbolic', True)

    An expression defined nowhere on the region gives no evidence:

    >>> try:
    ...     vanishes_on(sp.log(x[0] - 5), x, Box.unit(3))
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    NonFiniteError log(x1 - 5) is not finite at any of 64 sampled points of [-1, 1] × [-1, 1] × [-1, 1]: ...
    """
    expr, x = as_sympy_expr("expr", expr), as_symbols("x", x)
    if region.n != len(x):
        raise InvalidArgumentError(f"region has dimension {region.n}, the model {len(x)}")
    if expr == 0:
        return ZeroTest(True, "symbolic", 0, None, None)
    rational = bool(expr.is_rational_function(*x)) and not (expr.free_symbols - set(x))
    if rational:
        expr = sp.cancel(expr)
        if expr == 0:
            return ZeroTest(True, "symbolic", 0, None, None)
    else:
        expr = simplify_bounded(expr)
        if expr == 0:
            return ZeroTest(True, "symbolic", 0, None, None)
    terms = list(sp.Add.make_args(sp.expand(expr))) if not rational else [expr]
    fn = compile_matrix(sp.Matrix(terms), (tuple(x),), vector=True, what="zero test")
    pts = region.sample(samples, seed)
    with np.errstate(all="ignore"):
        tv = fn(pts)
        vals, scale = tv.sum(axis=-1), np.abs(tv).sum(axis=-1)
    ok = np.isfinite(vals) & np.isfinite(scale)
    if not np.any(ok):
        raise NonFiniteError(f"{expr} is not finite at any of {samples} sampled points of {region.describe()}: "
                             "the model is not defined on this region")
    mag = np.where(ok, np.abs(vals), -1.0)
    i = int(np.argmax(mag))
    if rational:  # proven nonzero: report where it is largest
        return ZeroTest(False, "symbolic", int(ok.sum()), tuple(float(v) for v in pts[i]), float(vals[i]))
    nonzero = ok & (np.abs(vals) > ZERO_RTOL * scale)
    if not np.any(nonzero):
        return ZeroTest(True, "numeric", int(ok.sum()), None, None)
    return ZeroTest(False, "numeric", int(ok.sum()), tuple(float(v) for v in pts[i]), float(vals[i]))


def polynomial_vanishes_on(p: Any, n: int, region: Box, *, samples: int = 64, seed: int = 0) -> ZeroTest:
    """:func:`vanishes_on` for a sparse polynomial over ℚ (a ``PolyElement`` in ``n`` variables), without
    building its expression.

    Exact as for any rational function: it vanishes identically iff it has no terms, and a nonzero
    polynomial cannot vanish on an open box; the witness is the sampled point (the same points as
    :func:`vanishes_on`) where it is largest, its value evaluated from the monomials.

    Raises
    ------
    NonFiniteError
        If the polynomial overflows at every sampled point.
    """
    if region.n != n:
        raise InvalidArgumentError(f"region has dimension {region.n}, the model {n}")
    if not p:
        return ZeroTest(True, "symbolic", 0, None, None)
    pts = region.sample(samples, seed)
    with np.errstate(all="ignore"):
        vals = np.asarray(PolynomialMatrixFunction([p], (1, 1), n)(pts), dtype=float)[:, 0, 0]
    ok = np.isfinite(vals)
    if not np.any(ok):
        raise NonFiniteError(f"{p.as_expr()} is not finite at any of {samples} sampled points of "
                             f"{region.describe()}: the model is not defined on this region")
    mag = np.where(ok, np.abs(vals), -1.0)
    i = int(np.argmax(mag))
    return ZeroTest(False, "symbolic", int(ok.sum()), tuple(float(v) for v in pts[i]), float(vals[i]))
