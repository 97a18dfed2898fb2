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
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import sympy as sp

from nlobs._typing import Array
from nlobs.errors import DimensionError, ModelError
from nlobs.systems.expressions import as_sympy_matrix, as_symbols


def _dirac_delta(x: Any, *order: Any) -> Any:
    """The pointwise value of SymPy's ``DiracDelta(x)`` (the derivative of a jump): 0 for ``x ≠ 0``, NaN at 0."""
    x = np.asarray(x, dtype=float)
    return np.where(x == 0.0, np.nan, 0.0)


_NUMPY_MODULES: list[Any] = [{"Abs": np.abs, "sign": np.sign, "DiracDelta": _dirac_delta}, "numpy"]


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

    def __call__(self, *args: Array) -> Array:
        if len(args) != len(self.groups):
            raise DimensionError(f"expected {len(self.groups)} argument arrays, got {len(args)}")
        flat: list[Array] = []
        batch: tuple[int, ...] = ()
        for i, (a, size) in enumerate(zip(args, self.groups)):
            a = np.asarray(a, dtype=float)
            if a.ndim == 0 or a.shape[-1] != size:
                raise DimensionError(f"argument {i}: expected shape (..., {size}), got {a.shape}")
            batch = np.broadcast_shapes(batch, a.shape[:-1])
            flat.extend(a[..., j] for j in range(size))
        values = self._fn(*flat)
        out = np.empty(batch + (len(values),), dtype=float)
        for j, v in enumerate(values):
            out[..., j] = v  # broadcasts constant entries
        rows, cols = self.shape
        return out if self.vector else out.reshape(batch + (rows, cols))


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
    # dummify only when needed: the generated code then names its arguments _Dummy_…, so a state called
    # ``sin``, ``exp`` or ``numpy`` cannot shadow the function the code calls; dummies change the printed
    # term order (and so the last bits of a result), which the other models keep as they were
    dummify = any(s.name in _RESERVED for s in args)
    fn = sp.lambdify(args, entries, modules=_NUMPY_MODULES, cse=True, dummify=dummify)
    return BatchedFunction(
        shape=(int(mat.shape[0]), int(mat.shape[1])),
        groups=tuple(len(g) for g in groups),
        vector=vector,
        _fn=fn,
        expressions=tuple(entries),
        arguments=tuple(tuple(g) for g in groups),
    )
