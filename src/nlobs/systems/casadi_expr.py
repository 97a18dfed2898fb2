r"""SymPy expressions as CasADi expressions, by a walk of the expression tree (never through text).

CasADi (an optional extra: ``pip install 'nlobs[mhe]'``) builds the optimisation problems of
moving-horizon estimation from symbolic expressions with exact derivatives. A model of nlobs holds
SymPy expressions; :func:`to_casadi` converts one by visiting its nodes, bottom up, without recursion
(however deep the expression):

* a symbol becomes the CasADi symbol it is mapped to (an unmapped symbol is refused by name);
* a sub-expression without symbols (``2``, ``pi/2``, ``sqrt(3)``) becomes its float value;
* ``Add``, ``Mul`` and ``Pow`` become CasADi sums, products and powers (a power with a half-integer
  exponent through ``sqrt``);
* the functions an expression string may call (:data:`nlobs.systems.expressions.FUNCTIONS`):
  ``sin``, ``cos``, ``tan``, ``asin``, ``acos``, ``atan``, ``atan2``, ``sinh``, ``cosh``, ``tanh``,
  ``exp``, ``log``, ``abs`` and ``sign`` become their CasADi namesakes (``fabs`` for ``abs``).

Anything else is refused with :class:`~nlobs.errors.ModelError` naming it. No text is evaluated or
compiled: neither ``lambdify`` nor ``eval`` nor ``sympify`` is used.

:func:`casadi_model` gives the CasADi functions ``f(x, u)`` and ``h(x, u)`` of a plant: a
:class:`~nlobs.systems.symbolic.SymbolicModel` (its parameters substituted), the
:class:`~nlobs.systems.symbolic.CompiledModel` compiled from one (the expressions it evaluates) or a
:class:`~nlobs.systems.linear.LinearSystem` (its matrices).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from nlobs.errors import InvalidArgumentError, ModelError
from nlobs.systems.timebase import TimeBase

__all__ = ["CasadiModel", "casadi_model", "import_casadi", "to_casadi"]

#: SymPy function classes of one argument and the CasADi function of each.
UNARY: Mapping[type, str] = {
    sp.sin: "sin", sp.cos: "cos", sp.tan: "tan", sp.asin: "asin", sp.acos: "acos", sp.atan: "atan",
    sp.sinh: "sinh", sp.cosh: "cosh", sp.tanh: "tanh", sp.exp: "exp", sp.log: "log", sp.Abs: "fabs",
    sp.sign: "sign",
}
#: SymPy function classes of two arguments and the CasADi function of each.
BINARY: Mapping[type, str] = {sp.atan2: "atan2"}


def import_casadi(what: str = "this feature") -> Any:
    """The ``casadi`` module, or a one-line typed error saying how to install it.

    Parameters
    ----------
    what : str
        What needs CasADi (named in the message).

    Returns
    -------
    module
        ``casadi``.

    Raises
    ------
    InvalidArgumentError
        CasADi is not installed.

    Examples
    --------
    >>> import_casadi("moving-horizon estimation").__name__
    'casadi'
    """
    try:
        import casadi
    except ImportError:
        raise InvalidArgumentError(f"{what} needs CasADi, which is not installed: pip install 'nlobs[mhe]'") \
            from None
    return casadi


def _constant(node: sp.Expr, expr: sp.Basic) -> float:
    if isinstance(node, sp.Number):
        value = complex(float(node)) if node.is_finite else complex(math.nan)
    else:
        try:
            value = complex(node.evalf(30))
        except (TypeError, ValueError, OverflowError, ZeroDivisionError):
            raise ModelError(f"constant {node} in {_shown(expr)} has no numeric value") from None
    if value.imag != 0.0 or not math.isfinite(value.real):
        raise ModelError(f"constant {node} in {_shown(expr)} is not a finite real number")
    return value.real


def _shown(expr: sp.Basic) -> str:
    text = str(expr)
    return repr(text if len(text) <= 120 else text[:120] + "...")


def _power(ca: Any, node: sp.Pow, base: Any) -> Any:
    e = node.exp
    if e.is_Integer:
        return base ** int(e)
    if e.is_Rational and int(e.q) == 2:  # x**(k/2): sqrt(x)**k, exact where x ≥ 0 like SymPy's own sqrt
        return ca.sqrt(base) ** int(e.p)
    return None


def to_casadi(expr: sp.Basic, symbols: Mapping[sp.Symbol, Any]) -> Any:
    """``expr`` as a CasADi expression over the CasADi symbols that ``symbols`` maps its symbols to.

    Parameters
    ----------
    expr : sympy.Expr
        A scalar SymPy expression built from numbers, symbols, ``+``, ``*``, ``**`` and the whitelisted
        functions (module docstring).
    symbols : mapping of sympy.Symbol to casadi.SX or casadi.MX
        The CasADi symbol of every symbol of ``expr``.

    Returns
    -------
    casadi.SX or casadi.MX
        The expression (a constant is a 1 × 1 ``SX``).

    Raises
    ------
    ModelError
        A symbol not in ``symbols``, a node without a CasADi form (naming its SymPy type), or a
        constant that is not a finite real number.
    InvalidArgumentError
        CasADi is not installed, or ``expr`` is not a SymPy expression.

    Examples
    --------
    The pendulum's ``−(g/l) sin θ − c ω`` with ``g/l = 9.81``, ``c = 0.2``: the CasADi function agrees with
    the SymPy expression, and its derivative is CasADi's own:

    >>> import casadi as ca
    >>> import sympy as sp
    >>> theta, omega = sp.symbols("theta omega", real=True)
    >>> th, om = ca.SX.sym("th"), ca.SX.sym("om")
    >>> e = to_casadi(-9.81 * sp.sin(theta) - sp.Rational(1, 5) * omega, {theta: th, omega: om})
    >>> fn = ca.Function("f", [th, om], [e, ca.jacobian(e, th)])
    >>> value, slope = (float(v) for v in fn(0.5, 1.0))
    >>> import math
    >>> math.isclose(value, -9.81 * math.sin(0.5) - 0.2, rel_tol=1e-15), math.isclose(slope, -9.81 * math.cos(0.5))
    (True, True)

    Symbols the map does not know, and functions without a CasADi form, are refused by name:

    >>> try:
    ...     to_casadi(sp.sin(theta) + sp.Symbol("k"), {theta: th})
    ... except ModelError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ModelError - symbol 'k' of 'k + sin(theta)' is not an argument
    >>> try:
    ...     to_casadi(sp.gamma(theta), {theta: th})
    ... except ModelError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ModelError - gamma in 'gamma(theta)' has no CasADi form (allowed: +, *, **, numbers, acos, asin, atan, ...)
    """
    ca = import_casadi("to_casadi")
    if not isinstance(expr, sp.Basic):
        raise InvalidArgumentError(f"expr: expected a SymPy expression, got {type(expr).__name__}")
    memo: dict[sp.Basic, Any] = {}
    stack: list[tuple[sp.Basic, bool]] = [(expr, False)]
    while stack:  # post-order walk with an explicit stack: no recursion on deep expressions
        node, ready = stack.pop()
        if node in memo:
            continue
        if isinstance(node, sp.Symbol):
            if node not in symbols:
                raise ModelError(f"symbol {node.name!r} of {_shown(expr)} is not an argument")
            memo[node] = symbols[node]
            continue
        if not node.free_symbols:
            if isinstance(node, sp.Expr):
                memo[node] = _constant(node, expr)
                continue
            raise ModelError(f"{type(node).__name__} {_shown(node)} in {_shown(expr)} has no CasADi form")
        if not ready:
            stack.append((node, True))
            stack.extend((a, False) for a in node.args if a not in memo)
            continue
        memo[node] = _combine(ca, node, memo, expr)
    out = memo[expr]
    return ca.SX(out) if isinstance(out, float) else out


def _combine(ca: Any, node: sp.Basic, memo: Mapping[sp.Basic, Any], expr: sp.Basic) -> Any:
    if isinstance(node, sp.Add):
        args = [memo[a] for a in node.args]
        total = args[0]
        for a in args[1:]:
            total = total + a
        return total
    if isinstance(node, sp.Mul):
        args = [memo[a] for a in node.args]
        prod = args[0]
        for a in args[1:]:
            prod = prod * a
        return prod
    if isinstance(node, sp.Pow):
        base = memo[node.base]
        if node.exp.is_Rational:
            out = _power(ca, node, base)
            if out is not None:
                return out
            return ca.power(base, float(node.exp))
        return ca.power(base, memo[node.exp])
    fn = type(node)
    if fn in UNARY and len(node.args) == 1:
        return getattr(ca, UNARY[fn])(memo[node.args[0]])
    if fn in BINARY and len(node.args) == 2:
        return getattr(ca, BINARY[fn])(memo[node.args[0]], memo[node.args[1]])
    raise ModelError(f"{fn.__name__} in {_shown(expr)} has no CasADi form (allowed: +, *, **, numbers, "
                     f"{', '.join(sorted([*UNARY.values(), *BINARY.values()]))})")


@dataclass(frozen=True)
class CasadiModel:
    """A plant's right-hand side and output map as CasADi functions.

    Attributes
    ----------
    f : casadi.Function
        ``f(x, u)``: ``ẋ`` (continuous time) or ``x⁺`` (discrete time), an ``n``-vector.
    h : casadi.Function
        ``h(x, u)``: the output, a ``p``-vector.
    n, m, p : int
        Numbers of states, inputs and outputs.
    time : Continuous or Discrete
        The plant's time base.

    Examples
    --------
    A double integrator as a linear system: ``f(x, u) = (x₂, u)``, ``h(x, u) = x₁``, evaluated by CasADi:

    >>> from nlobs.systems.linear import LinearSystem
    >>> cm = casadi_model(LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]]))
    >>> (cm.n, cm.m, cm.p), cm.f([3.0, 2.0], [0.5]).full().ravel().tolist(), float(cm.h([3.0, 2.0], [0.5]))
    ((2, 1, 1), [2.0, 0.5], 3.0)
    """

    f: Any
    h: Any
    n: int
    m: int
    p: int
    time: TimeBase


def _symbolic_parts(plant: Any) -> tuple[tuple[sp.Symbol, ...], tuple[sp.Symbol, ...], list[sp.Expr],
                                         list[sp.Expr]] | None:
    """``(x symbols, u symbols, rhs entries, h entries)`` with the parameters' values, or ``None``."""
    from nlobs.systems.symbolic import CompiledModel, SymbolicModel

    if isinstance(plant, SymbolicModel):
        values = plant.substituted()
        return plant.x, plant.u, list(plant.rhs.xreplace(values)), list(plant.h.xreplace(values))
    if isinstance(plant, CompiledModel):
        rhs_fn, h_fn = plant._rhs, plant._h  # the very expressions the compiled plant evaluates
        if rhs_fn.expressions and h_fn.expressions and len(rhs_fn.arguments) == 2:
            x, u = rhs_fn.arguments
            return tuple(x), tuple(u), list(rhs_fn.expressions), list(h_fn.expressions)
        origin = plant._origin
        if origin is not None and isinstance(origin[0], SymbolicModel):
            model, parameters = origin
            values = model.substituted(parameters)
            return model.x, model.u, list(model.rhs.xreplace(values)), list(model.h.xreplace(values))
    return None


def casadi_model(plant: Any) -> CasadiModel:
    """The CasADi functions ``f(x, u)`` and ``h(x, u)`` of a plant (module docstring).

    Parameters
    ----------
    plant : SymbolicModel, CompiledModel or LinearSystem
        The plant: a symbolic model (its parameters substituted), one compiled from a symbolic model,
        or a linear system ``(A, B, C, D)``.

    Returns
    -------
    CasadiModel

    Raises
    ------
    InvalidArgumentError
        CasADi is not installed, or ``plant`` is none of the three (a plant written by hand has no
        expressions to translate).
    ModelError
        An expression has no CasADi form (:func:`to_casadi`).

    Examples
    --------
    The shipped pendulum: the CasADi functions and the compiled NumPy plant agree:

    >>> import numpy as np
    >>> import nlobs
    >>> plant = nlobs.load_model("pendulum").compile()
    >>> cm = casadi_model(plant)
    >>> (cm.n, cm.m, cm.p), str(cm.time)
    ((2, 1, 1), 'continuous')
    >>> x, u = np.array([0.3, -0.4]), np.array([0.5])
    >>> bool(np.allclose(np.array(cm.f(x, u)).ravel(), plant.rhs(0.0, x, u), rtol=1e-14))
    True
    """
    ca = import_casadi("casadi_model")
    from nlobs.systems.linear import LinearSystem

    if isinstance(plant, LinearSystem):
        n, m, p = plant.n, plant.m, plant.p
        x, u = ca.SX.sym("x", n), ca.SX.sym("u", m)
        A, B, C, D = (ca.DM(np.asarray(M, dtype=float)) for M in (plant.A, plant.B, plant.C, plant.D))
        fx = ca.mtimes(A, x) + (ca.mtimes(B, u) if m else ca.SX.zeros(n))
        hx = ca.mtimes(C, x) + (ca.mtimes(D, u) if m else ca.SX.zeros(p))
        return CasadiModel(ca.Function("f", [x, u], [fx]), ca.Function("h", [x, u], [hx]), n, m, p, plant.time)
    parts = _symbolic_parts(plant)
    if parts is None:
        raise InvalidArgumentError(
            f"plant: expected a SymbolicModel, a model compiled from one or a LinearSystem, got "
            f"{type(plant).__name__} (its equations are needed as expressions)")
    xs, us, rhs, hs = parts
    n, m, p = len(xs), len(us), len(hs)
    x, u = ca.SX.sym("x", n), ca.SX.sym("u", m)
    symbols = {**{s: x[i] for i, s in enumerate(xs)}, **{s: u[i] for i, s in enumerate(us)}}
    fx = ca.vertcat(*[to_casadi(e, symbols) for e in rhs]) if rhs else ca.SX.zeros(0)
    hx = ca.vertcat(*[to_casadi(e, symbols) for e in hs]) if hs else ca.SX.zeros(0)
    return CasadiModel(ca.Function("f", [x, u], [fx]), ca.Function("h", [x, u], [hx]), n, m, p, plant.time)
