"""Compile SymPy matrices to batched NumPy callables.

:func:`compile_matrix` is the one place where SymPy expressions become numeric
code. It uses :func:`sympy.lambdify` with ``cse=True`` on the flattened entries,
takes flat arguments (one array per symbol, so a leading batch axis comes for
free), broadcasts constant entries to the batch shape (lambdify alone would
return a scalar ``0`` for them) and refuses expressions with free symbols that
are not arguments. When a symbol is named like a name the generated code may call (a NumPy
function, a builtin: a state ``sin`` in ``sin(sin)``), the code names its arguments by dummies,
so it cannot shadow the function; other models keep their own names (and, with them, the
same generated code, term order and floating-point results as before).

``sign`` and ``abs`` are the only whitelisted functions that are not smooth. SymPy
differentiates ``sign(x)`` (and ``abs(x)`` twice) to ``2*DiracDelta(x)``, a distribution with
no value; its compiled form is the pointwise derivative of ``sign``: ``0`` where ``x ≠ 0`` and
NaN at ``x = 0``, where the derivative does not exist (so a Jacobian there is reported as not
finite, like ``log(x1)`` at ``x1 = 0``). A computation that needs a bound on a derivative over a
region (a Lipschitz constant) must refuse such an expression instead
(:func:`has_jump`), because a jump is not Lipschitz.
"""

from __future__ import annotations

import builtins
import threading
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import sympy as sp
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.precedence import precedence

from nlobs._typing import Array
from nlobs.errors import DimensionError, ModelError
from nlobs.systems.expressions import as_sympy_expr, as_sympy_matrix, as_symbols


def _dirac_delta(x: Any, *order: Any) -> Any:
    """The pointwise value of SymPy's ``DiracDelta(x)`` (the derivative of a jump): 0 for ``x ≠ 0``, NaN at 0."""
    x = np.asarray(x, dtype=float)
    return np.where(x == 0.0, np.nan, 0.0)


_F64 = np.dtype(np.float64)

_NUMPY_MODULES: list[Any] = [{"Abs": np.abs, "sign": np.sign, "DiracDelta": _dirac_delta}, "numpy"]


class _PowerPrinter(NumPyPrinter):
    """NumPy code with every power not written as ``sqrt`` or a quotient printed as ``power(base, exponent)``.

    ``a ** e`` on NumPy arrays is the ``power`` ufunc, but on a NumPy scalar it is the scalar type's own ``pow``,
    which differs in the last bit for about 3 % of arguments (``x**3``). The generated code is called with arrays
    for a batch and with NumPy scalars for one run (:meth:`BatchedFunction.__call__`); through the ufunc both get
    the batched code's numbers.
    """

    def _hprint_Pow(self, expr: Any, rational: bool = False, sqrt: str = "numpy.sqrt") -> str:
        text = super()._hprint_Pow(expr, rational=rational, sqrt=sqrt)
        prec = precedence(expr)
        if text != f"{self.parenthesize(expr.base, prec, strict=False)}**{self.parenthesize(expr.exp, prec, strict=False)}":
            return text  # sqrt(…), 1/sqrt(…) or 1/…: a ufunc or a division already
        return f"{self._module_format('numpy.power')}({self._print(expr.base)}, {self._print(expr.exp)})"


def _printer() -> _PowerPrinter:
    """The printer lambdify would choose for :data:`_NUMPY_MODULES`, with powers through the ufunc."""
    return _PowerPrinter({"fully_qualified_modules": False, "inline": True, "allow_unknown_functions": True,
                          "user_functions": {name: name for name in _NUMPY_MODULES[0]}})


#: Names the generated code may call or refer to: an argument with one of these names is dummified.
_RESERVED: frozenset[str] = frozenset(dir(np)) | frozenset(dir(builtins)) | frozenset(_NUMPY_MODULES[0]) | {
    "numpy", "math", "mpmath", "sympy", "scipy"}


def has_jump(expr: sp.Basic | sp.MatrixBase) -> bool:
    """Whether ``expr`` holds ``DiracDelta``: it is the derivative of a function that jumps (``sign``, ``abs′``)."""
    return bool(expr.has(sp.DiracDelta))


@dataclass(frozen=True)
class BatchedFunction:
    """A compiled matrix-valued function of stacked argument vectors.

    Calling it with arrays of shapes ``(..., len(group))`` for each argument
    group returns an array of shape ``(..., rows, cols)`` (or ``(..., rows)``
    when compiled with ``vector=True``).
    """

    shape: tuple[int, int]
    groups: tuple[int, ...]
    vector: bool
    _fn: Callable[..., Any]
    #: The compiled entries, row-major, and the argument symbols of each group: what it was compiled
    #: from (the C export prints the same expressions; ``()`` for a function built otherwise).
    expressions: tuple[sp.Expr, ...] = field(default=(), repr=False, compare=False)
    arguments: tuple[tuple[sp.Symbol, ...], ...] = field(default=(), repr=False, compare=False)
    #: The entries that are numbers, found at the first batched call (:meth:`_constant_entries`).
    _split: dict[str, Any] = field(default_factory=dict, init=False, repr=False, compare=False)

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        """Pickled as what it was compiled from (the expressions and argument symbols), compiled again where it is
        unpickled: generated code cannot be pickled. A function built otherwise pickles as its fields."""
        if self.arguments and len(self.expressions) == self.shape[0] * self.shape[1]:
            return (_recompile, (self.shape, self.expressions, self.arguments, self.vector))
        return (BatchedFunction, (self.shape, self.groups, self.vector, self._fn, self.expressions, self.arguments))

    def __call__(self, *args: Array) -> Array:
        flat, batch = self._flatten(args)
        return self._assemble(self._fn(*flat), batch)

    def _flatten(self, args: tuple[Array, ...]) -> tuple[list[Any], tuple[int, ...] | None]:
        """The generated code's arguments, one per symbol, and the batch shape (``None``: one run, NumPy scalars)."""
        if len(args) != len(self.groups):
            raise DimensionError(f"expected {len(self.groups)} argument arrays, got {len(args)}")
        single = True  # one run: every argument a float64 vector of its group's size
        for a, size in zip(args, self.groups):
            if type(a) is not np.ndarray or not (a.dtype is _F64 or a.dtype == _F64) or a.shape != (size,):
                single = False
                break
        if single:
            # NumPy scalars, not 0-d arrays: the same IEEE operations and ufuncs, a fifth of the call's cost
            return [v for a in args for v in a], None
        flat: list[Any] = []
        batch: tuple[int, ...] | None = None
        for i, (a, size) in enumerate(zip(args, self.groups)):
            a = np.asarray(a, dtype=float)
            if a.ndim == 0 or a.shape[-1] != size:
                raise DimensionError(f"argument {i}: expected shape (..., {size}), got {a.shape}")
            lead = a.shape[:-1]
            batch = lead if batch is None or batch == lead else np.broadcast_shapes(batch, lead)
            flat.extend(a.T if a.ndim == 2 else [a[..., j] for j in range(size)])  # the views a[..., j]
        return flat, () if batch is None else batch

    def _assemble(self, values: Sequence[Any], batch: tuple[int, ...] | None) -> Array:
        if batch is None:
            out = np.array(values, dtype=float)
            return out if self.vector else out.reshape(self.shape)
        out = np.empty(batch + (len(values),), dtype=float)
        split = self._constant_entries(values)
        if split is None:
            for j, v in enumerate(values):
                out[..., j] = v  # broadcasts constant entries
        else:  # the constant entries (a Jacobian's zeros and ones) in one assignment, the others one by one
            varying, const_idx, const_val = split
            out[..., const_idx] = const_val
            for j in varying:
                out[..., j] = values[j]
        rows, cols = self.shape
        return out if self.vector else out.reshape(batch + (rows, cols))


    def _constant_entries(self, values: Sequence[Any]) -> tuple[list[int], Array, Array] | None:
        """``(varying entries, constant entries, their values)`` when two or more entries are numbers, else ``None``.

        Decided once, at the first batched call, from :attr:`expressions`; the constants' values are the ones the
        generated code returned then (the same every call: they depend on no argument)."""
        if "split" not in self._split:
            found = None
            if len(self.expressions) == len(values):
                const = [j for j, e in enumerate(self.expressions) if getattr(e, "is_number", False)]
                try:
                    values_ = np.array([float(values[j]) for j in const])
                except (TypeError, ValueError):  # a constant that is no real number: every entry as it comes
                    const = []
                if len(const) >= 2:
                    found = ([j for j in range(len(values)) if j not in set(const)], np.array(const, dtype=np.intp),
                             values_)
            self._split["split"] = found
        return self._split["split"]  # type: ignore[no-any-return]


def evaluate_together(functions: Sequence[BatchedFunction], *args: Array) -> tuple[Array, ...]:
    """Several compiled functions of the same arguments, the arguments prepared once (the EKF's ``f`` and ``∂f/∂x``).

    Parameters
    ----------
    functions : sequence of BatchedFunction
        Functions with the same argument groups.
    *args : ndarray
        One array per group, as for a single call.

    Returns
    -------
    tuple of ndarray
        Each function's value, exactly as its own call returns it.

    Examples
    --------
    >>> import sympy as sp
    >>> x = sp.symbols("x1 x2")
    >>> f = compile_matrix([x[0] * x[1], x[1]], (x,), vector=True)
    >>> J = compile_matrix(sp.Matrix([x[0] * x[1], x[1]]).jacobian(x), (x,))
    >>> fx, Jx = evaluate_together((f, J), np.array([2.0, 3.0]))
    >>> fx.tolist(), Jx.tolist()
    ([6.0, 3.0], [[3.0, 2.0], [0.0, 1.0]])
    """
    first = functions[0]
    for fn in functions:
        if fn.groups != first.groups:
            raise DimensionError("evaluate_together: the functions take different arguments")
    flat, batch = first._flatten(args)
    return tuple([fn._assemble(fn._fn(*flat), batch) for fn in functions])


#: Functions compiled in this process, most recent last: an analysis that meets the same matrix twice (a model
#: compiled by two steps of ``nlobs analyze``, the codistribution of two checks) compiles it once.
COMPILED_CACHE_SIZE = 256
_COMPILED: OrderedDict[tuple[Any, ...], BatchedFunction] = OrderedDict()
_COMPILED_LOCK = threading.Lock()


def _recompile(shape: tuple[int, int], expressions: tuple[sp.Expr, ...], arguments: tuple[tuple[sp.Symbol, ...], ...],
               vector: bool) -> BatchedFunction:
    """Unpickle a :class:`BatchedFunction`: compile its expressions again."""
    rows, cols = (int(v) for v in shape)
    entries = [as_sympy_expr("expressions", e) for e in expressions]  # SymPy objects only, never text
    return compile_matrix(sp.ImmutableMatrix(rows, cols, entries), arguments, vector=vector)


def compile_matrix(
    expr: sp.Matrix | Sequence[sp.Expr],
    groups: Sequence[Sequence[sp.Symbol]],
    *,
    vector: bool = False,
    what: str = "expression",
) -> BatchedFunction:
    """Compile a SymPy matrix into a :class:`BatchedFunction`.

    Parameters
    ----------
    expr : sympy.Matrix or sequence of expressions
        The function to compile. A sequence is treated as a column vector.
    groups : sequence of sequences of sympy.Symbol
        Argument groups, e.g. ``(states, inputs)``; the compiled function takes
        one array per group.
    vector : bool
        Return shape ``(..., rows)`` instead of ``(..., rows, cols)``
        (requires a column vector).
    what : str
        Name used in error messages.

    Raises
    ------
    ModelError
        If ``expr`` has free symbols that are not in ``groups``.
    InvalidArgumentError
        If an entry of ``expr`` is a string or a group holds anything but
        ``sympy.Symbol`` (SymPy would evaluate a string).
    """
    mat = as_sympy_matrix(what, expr)
    groups = [as_symbols(f"{what}: argument group {i}", grp) for i, grp in enumerate(groups)]
    if vector and mat.shape[1] != 1 and mat.shape[0] * mat.shape[1] > 0:
        raise DimensionError(f"{what}: vector=True needs a column vector, got shape {mat.shape}")
    args = [s for grp in groups for s in grp]
    stray = sorted(str(s) for s in mat.free_symbols - set(args))
    if stray:
        raise ModelError(f"{what}: free symbols that are not arguments: {', '.join(stray)}")
    entries = list(mat)  # row-major
    key = (tuple(entries), tuple(tuple(g) for g in groups), bool(vector), tuple(mat.shape))
    with _COMPILED_LOCK:
        known = _COMPILED.get(key)
        if known is not None:  # the same expressions of the same arguments: the same pure function
            _COMPILED.move_to_end(key)
            return known
    # dummify only when needed: the generated code then names its arguments _Dummy_…, so a state called
    # ``sin``, ``exp`` or ``numpy`` cannot shadow the function the code calls; dummies change the printed
    # term order (and so the last bits of a result), which the other models keep as they were
    dummify = any(s.name in _RESERVED for s in args)
    fn = sp.lambdify(args, entries, modules=_NUMPY_MODULES, cse=True, dummify=dummify, printer=_printer())
    compiled = BatchedFunction(
        shape=(int(mat.shape[0]), int(mat.shape[1])),
        groups=tuple(len(g) for g in groups),
        vector=vector,
        _fn=fn,
        expressions=tuple(entries),
        arguments=tuple(tuple(g) for g in groups),
    )
    with _COMPILED_LOCK:
        _COMPILED[key] = compiled
        while len(_COMPILED) > COMPILED_CACHE_SIZE:
            _COMPILED.popitem(last=False)
    return compiled
