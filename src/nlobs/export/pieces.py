"""The pieces every C generator of :mod:`nlobs.export` shares.

A compiled function (:class:`~nlobs.systems.codegen.BatchedFunction`) as a static C function of its
expressions (through :func:`nlobs.export.cprint.emit_assignments`), a constant array, a matrix written
into a header's comment block, and the spectral abscissa (or radius) named there. Used by
:mod:`nlobs.export.generate` and the generators of the other observers (:mod:`nlobs.export.cascade`,
:mod:`nlobs.export.gnss_ins`, :mod:`nlobs.export.setvalued`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import sympy as sp

from nlobs.errors import InvalidArgumentError
from nlobs.export.cprint import emit_assignments, matrix_literal
from nlobs.systems.codegen import BatchedFunction

__all__ = ["abscissa", "affine_function", "invert_c", "matrix_note", "require_source", "static_array", "static_function",
           "symbol_inputs"]


def symbol_inputs(groups: tuple[tuple[sp.Symbol, ...], ...], names: tuple[str, ...]) -> dict[sp.Symbol, str]:
    """Each symbol of ``groups[i]`` as the C array entry ``names[i][j]``.

    Parameters
    ----------
    groups : tuple of tuples of sympy.Symbol
        The argument symbols of each group, e.g. ``BatchedFunction.arguments``.
    names : tuple of str
        The C array of each group (``("z", "u", "y")``); pairs past the shorter of the two are ignored.

    Returns
    -------
    dict of sympy.Symbol to str
        The ``inputs`` of :func:`~nlobs.export.cprint.emit_assignments` (``{x1: "z[0]", ...}``).
    """
    out: dict[sp.Symbol, str] = {}
    for grp, arr in zip(groups, names):
        for j, s in enumerate(grp):
            out[s] = f"{arr}[{j}]"
    return out


def affine_function(name: str, M: np.ndarray, N: np.ndarray, rows: int, n: int, m: int) -> str:
    """``static void name(x, u, out)``: ``out = M x + N u``, with the constant arrays ``name_M`` and ``name_N``.

    Parameters
    ----------
    name : str
        The C function's name (a C identifier).
    M, N : ndarray
        ``rows × n`` and ``rows × m`` (a linear system's ``A, B`` or ``C, D``); ``N`` is left out when ``m = 0``.
    rows, n, m : int
        The sizes.

    Returns
    -------
    str
        C99 definitions.
    """
    nu = (f"""
        for (j = 0; j < {m}; ++j) {{
            acc += {name}_N[i * {m} + j] * u[j];
        }}""" if m else "")
    return (static_array(f"{name}_M", M) + (static_array(f"{name}_N", N) if m else "") + f"""\
static void {name}(const double *x, const double *u, double *out)
{{
    int i, j;
    (void)u;
    for (i = 0; i < {rows}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {n}; ++j) {{
            acc += {name}_M[i * {n} + j] * x[j];
        }}{nu}
        out[i] = acc;
    }}
}}
""")


def require_source(fn: Any, what: str) -> BatchedFunction:
    """``fn`` when it carries the expressions it was compiled from (nlobs's code generation), else an error.

    Parameters
    ----------
    fn : object
        A system's compiled function (``f``, ``h``, a Jacobian...).
    what : str
        Names the function in the error (e.g. ``"pendulum.f: ..."``).

    Returns
    -------
    BatchedFunction
        ``fn`` itself.

    Raises
    ------
    InvalidArgumentError
        ``fn`` is not a :class:`~nlobs.systems.codegen.BatchedFunction` or carries no argument symbols
        (built outside nlobs's code generation, e.g. a Python callable).
    """
    if not isinstance(fn, BatchedFunction) or not fn.arguments:
        raise InvalidArgumentError(f"{what}: its compiled function carries no expressions to print as C "
                                   "(built outside nlobs's code generation)")
    return fn


def static_function(name: str, fn: BatchedFunction, params: tuple[str, ...], what: str) -> str:
    """``static void name(const double *p0, …, double *out)``: the entries of ``fn``, row-major.

    Each argument group ``i`` of ``fn`` is read from the array ``params[i]`` (:func:`symbol_inputs`); every
    parameter is cast to ``void`` first, so that one the expressions do not use draws no warning.

    Parameters
    ----------
    name : str
        The C function's name.
    fn : BatchedFunction
        A function carrying its expressions (see :func:`require_source`).
    params : tuple of str
        The names of the C array parameters, one per argument group of ``fn``.
    what : str
        Names the function in errors.

    Returns
    -------
    str
        The C definition, ending in a newline.

    Raises
    ------
    ModelError
        An expression has a free symbol that is not an argument, or a function C99 cannot print
        (:func:`~nlobs.export.cprint.emit_assignments`).
    """
    inputs = symbol_inputs(fn.arguments, params)
    sig = ", ".join(f"const double *{p}" for p in params)
    body = emit_assignments(list(fn.expressions), inputs, [f"out[{i}]" for i in range(len(fn.expressions))],
                            what=what)
    unused = "".join(f"    (void){p};\n" for p in params)
    return f"static void {name}({sig}, double *out)\n{{\n{unused}{body}}}\n"


def static_array(name: str, values: Any) -> str:
    """``static const double name[size] = {…};`` (row-major, 17 significant digits).

    Parameters
    ----------
    name : str
        The C array's name.
    values : array_like
        Finite numbers, any shape (an empty array gives ``name[1] = {0.0}``: C has no empty array).

    Returns
    -------
    str
        The C definition, ending in a newline.
    """
    arr = np.asarray(values, dtype=float)
    return f"static const double {name}[{max(arr.size, 1)}] = {matrix_literal(arr)};\n"


def matrix_note(M: Any) -> str:
    """A matrix as rows of 17-digit numbers, one per line (for a header's comment block).

    Parameters
    ----------
    M : array_like
        The matrix (a scalar or a vector is one row).

    Returns
    -------
    str
        One line ``[a, b, ...]`` per row, joined by newlines (no trailing newline).
    """
    arr = np.atleast_2d(np.asarray(M, dtype=float))
    return "\n".join("[" + ", ".join(f"{v:.17g}" for v in row) + "]" for row in arr)


def abscissa(M: Any, discrete: bool) -> float:
    """The spectral radius of ``M`` (``discrete``) or its spectral abscissa (continuous time).

    The stability margin of an error matrix (``A - L C``) that a generated header reports: below 1 in
    discrete time, below 0 in continuous time, when the error decays.

    Parameters
    ----------
    M : array_like
        A square matrix (an empty one counts as having the single eigenvalue 0).
    discrete : bool
        Whether ``M`` is a discrete-time matrix (spectral radius) or continuous-time (spectral abscissa).

    Returns
    -------
    float
        ``max |eig(M)|`` when ``discrete``, else ``max Re eig(M)``.
    """
    ev = np.linalg.eigvals(np.asarray(M, dtype=float)) if np.size(M) else np.zeros(1)
    return float(np.max(np.abs(ev))) if discrete else float(np.max(ev.real))


def invert_c(P: str, size: int) -> str:
    """``static int P_invert(double *S, double *Si, int q)``: ``Si = S⁻¹`` of a ``q × q`` matrix (``q ≤ size``).

    Gauss–Jordan elimination with partial pivoting, row-major with stride ``q``; ``S`` is overwritten.
    It returns 1 for an exact zero pivot or a non-finite one (``S`` singular or not finite), else 0: the
    innovation covariance of the Kalman filters' updates (:mod:`nlobs.export.kalman`,
    :mod:`nlobs.export.nav_ekf`).

    Parameters
    ----------
    P : str
        The module's C prefix.
    size : int
        The largest ``q`` the module calls it with (the arrays it is given hold ``size²`` entries).

    Returns
    -------
    str
        The static C function.
    """
    return f"""
/* Si = S^-1 (q x q, q <= {max(size, 1)}, row-major) by Gauss-Jordan elimination with partial pivoting; S is
   overwritten; 1: a zero or non-finite pivot (S singular or not finite) */
static int {P}_invert(double *S, double *Si, int q)
{{
    int i, j, k, r;
    for (i = 0; i < q; ++i) {{
        for (j = 0; j < q; ++j) {{
            Si[i * q + j] = i == j ? 1.0 : 0.0;
        }}
    }}
    for (k = 0; k < q; ++k) {{
        int piv = k;
        double best = fabs(S[k * q + k]);
        for (r = k + 1; r < q; ++r) {{
            if (fabs(S[r * q + k]) > best) {{
                best = fabs(S[r * q + k]);
                piv = r;
            }}
        }}
        if (!(best > 0.0) || best - best != 0.0) {{
            return 1;
        }}
        if (piv != k) {{
            for (j = 0; j < q; ++j) {{
                double a = S[k * q + j], b = Si[k * q + j];
                S[k * q + j] = S[piv * q + j];
                Si[k * q + j] = Si[piv * q + j];
                S[piv * q + j] = a;
                Si[piv * q + j] = b;
            }}
        }}
        {{
            double d = S[k * q + k];
            for (j = 0; j < q; ++j) {{
                S[k * q + j] /= d;
                Si[k * q + j] /= d;
            }}
        }}
        for (r = 0; r < q; ++r) {{
            if (r != k) {{
                double c = S[r * q + k];
                for (j = 0; j < q; ++j) {{
                    S[r * q + j] -= c * S[k * q + j];
                    Si[r * q + j] -= c * Si[k * q + j];
                }}
            }}
        }}
    }}
    return 0;
}}
"""
