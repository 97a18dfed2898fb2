"""The Moore–Penrose inverse of the reduced observability matrix (Röbenack, Sec. 4).

``Q⁺(x) = Qᵀ (Q Qᵀ)⁻¹`` for ``Q`` of full row rank (A1), whose columns are the
vector fields ``τ_1, …, τ_r`` (18); the gain vector field is ``l(x) = Q⁺(x) k`` (17).
For several outputs (``Q`` stacked over outputs) the gain is ``Q⁺(x) K`` with
``K = blockdiag(k^1, …, k^q)``, one high-gain vector per output block.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

from nlobs.errors import DimensionError
from nlobs.geometry.budget import OPERATIONS_PER_NODE, SymbolicBudget
from nlobs.geometry.exact_inverse import exact_inverse
from nlobs.geometry.lie import derivative_size, simplify_bounded, tidy
from nlobs.systems.expressions import as_sympy_expr, as_sympy_matrix


def symbolic_pinv(Q: sp.MatrixBase) -> sp.ImmutableMatrix:
    """``Q⁺ = Qᵀ (Q Qᵀ)⁻¹`` for a full-row-rank ``Q`` (entries simplified where SymPy can).

    Full row rank is the caller's check (:func:`nlobs.geometry.checks.check_a1`);
    the formula is the Moore–Penrose inverse exactly when it holds.

    Examples
    --------
    ``Q = [dh; dL_f h]`` of ``y = x3``, ``L_f h = x1 + x2 x3`` (``r = 2 < n = 3``): ``Q⁺`` is a right inverse.

    >>> import sympy as sp
    >>> x1, x2, x3 = sp.symbols("x1:4", real=True)
    >>> Q = sp.Matrix([[0, 0, 1], [1, x3, x2]])
    >>> Qp = symbolic_pinv(Q)
    >>> Qp
    Matrix([
    [   -x2/(x3**2 + 1),    1/(x3**2 + 1)],
    [-x2*x3/(x3**2 + 1), x3/(x3**2 + 1)],
    [                 1,                0]])
    >>> (Q * Qp).applyfunc(sp.simplify) == sp.eye(2)
    True
    >>> try:
    ...     symbolic_pinv(Q.T)
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    DimensionError Q: expected at most as many rows as columns, got shape (3, 2)
    """
    Qm = sp.Matrix(as_sympy_matrix("Q", Q))
    if Qm.shape[0] > Qm.shape[1]:
        raise DimensionError(f"Q: expected at most as many rows as columns, got shape {Qm.shape}")
    gram = (Qm * Qm.T).applyfunc(tidy)
    inv = gram.inv(method="LU") if gram.shape[0] > 3 else gram.inv()
    return sp.ImmutableMatrix((Qm.T * inv).applyfunc(simplify_bounded))


def gain_symbols(r: Sequence[int]) -> tuple[sp.Symbol, ...]:
    """``k1, k2, …`` (``Σ r_j`` of them), the symbolic high-gain vector entries.

    Examples
    --------
    >>> gain_symbols((2, 1))
    (k1, k2, k3)
    >>> gain_symbols((2, 1))[0].is_real
    True
    """
    return tuple(sp.Symbol(f"k{i + 1}", real=True) for i in range(sum(int(v) for v in r)))


def block_gain(r: Sequence[int], k: Sequence[sp.Expr | float]) -> sp.Matrix:
    """``K = blockdiag(k^1, …, k^q)`` (``Σ r_j × q``) from the stacked entries ``k``.

    Examples
    --------
    Two outputs with ``r = (2, 1)``: ``k^1 = (1, 2)`` in the first column, ``k^2 = (3,)`` in the second.

    >>> block_gain((2, 1), [1, 2, 3])
    Matrix([
    [1, 0],
    [2, 0],
    [0, 3]])
    >>> block_gain((2, 1), gain_symbols((2, 1))).shape
    (3, 2)
    >>> try:
    ...     block_gain((2, 1), [1, 2])
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    DimensionError `k`: expected 3 entries (Σ r_j), got 2
    """
    rs = [int(v) for v in r]
    k = [as_sympy_expr(f"k[{i}]", v) for i, v in enumerate(k)]
    if len(k) != sum(rs):
        raise DimensionError(f"`k`: expected {sum(rs)} entries (Σ r_j), got {len(k)}")
    K = sp.zeros(sum(rs), len(rs))
    i = 0
    for j, rj in enumerate(rs):
        for a in range(rj):
            K[i + a, j] = k[i + a]
        i += rj
    return K


def pinv_gain_field(Qp: sp.MatrixBase, r: Sequence[int], k: Sequence[sp.Expr | float] | None = None) -> sp.ImmutableMatrix:
    """``l(x) = Q⁺(x) K`` (Röbenack (17)); ``n × q`` (a column for one output).

    ``k`` defaults to the symbols ``k1, k2, …``.

    Examples
    --------
    For the Van der Pol oscillator in Liénard form (``y = x1``), ``Q = [[1, 0], [1 − x1², 1]]`` is square,
    so ``l(x) = Q⁻¹ k`` and ``Q l = k``.

    >>> import sympy as sp
    >>> x1 = sp.Symbol("x1", real=True)
    >>> Q = sp.Matrix([[1, 0], [1 - x1**2, 1]])
    >>> l = pinv_gain_field(symbolic_pinv(Q), (2,))
    >>> l
    Matrix([
    [               k1],
    [k1*x1**2 - k1 + k2]])
    >>> (Q * l).applyfunc(sp.expand) == sp.Matrix(gain_symbols((2,)))
    True
    >>> pinv_gain_field(symbolic_pinv(Q), (2,), [10, 25]).T
    Matrix([[10, 10*x1**2 + 15]])
    """
    kk = gain_symbols(r) if k is None else tuple(k)
    return sp.ImmutableMatrix((sp.Matrix(as_sympy_matrix("Qp", Qp)) * block_gain(r, kk)).applyfunc(tidy))


def gain_strings(field_: sp.MatrixBase, q: int) -> tuple[Any, ...]:
    """The report's text of ``l(x)``: one factored string per state (one output), else rows of ``q`` strings."""
    if q == 1:
        return tuple(str(sp.factor(e)) if e.is_rational_function() else str(e) for e in field_[:, 0])
    return tuple(tuple(str(e) for e in field_.row(i)) for i in range(field_.shape[0]))


#: Work charged per pair of terms (numerator × denominator) for cancelling and factoring an entry of ``Q⁻¹ k``:
#: SymPy's dense multivariate gcd and factorisation cost about this many sparse products per pair (measured on the
#: polynomial and Duffing chains of ``benchmarks/analyze_scale.py``, where they are nearly all of the step's time).
CANCEL_FACTOR_WEIGHT = 500


def gain_within(Q: sp.MatrixBase, r: Sequence[int], q: int,
                budget: SymbolicBudget) -> tuple[tuple[Any, ...], sp.ImmutableMatrix | None]:
    """The symbolic gain field ``l(x) = Q⁺(x) K`` (17) as the report prints it, and ``Q⁺`` when it was built.

    A square ``Q`` of rational functions over ℚ (Σ r_j = n: ``Q⁺ = Q⁻¹``) is inverted exactly by
    :func:`~nlobs.geometry.exact_inverse.exact_inverse`, every step of it counted against ``budget``, and each
    entry of ``Q⁻¹ K`` is cancelled and factored, charged :data:`CANCEL_FACTOR_WEIGHT` per pair of terms of
    its numerator and denominator.
    Otherwise (several outputs with Σ r_j < n, a transcendental entry) ``Q⁺ = Qᵀ (Q Qᵀ)⁻¹`` by
    :func:`symbolic_pinv`, charged in advance by the predicted size of ``Q``
    (:data:`~nlobs.geometry.budget.OPERATIONS_PER_NODE` per node of :func:`~nlobs.geometry.lie.derivative_size`).

    Parameters
    ----------
    Q : sympy.Matrix
        The reduced observability matrix (13), ``Σ r_j × n``.
    r : sequence of int
        The observation relative degrees.
    q : int
        The number of outputs.
    budget : SymbolicBudget
        The work the step may use; the same model stops at the same step on every machine.

    Returns
    -------
    tuple
        The printed field (one string per state for one output, else rows of ``q`` strings) and ``Q⁺`` (``None``
        when ``Q`` was inverted exactly).

    Raises
    ------
    OutOfBudget
        When the work would exceed ``budget``.
    """
    Qm = sp.Matrix(as_sympy_matrix("Q", Q))
    inverse = exact_inverse(Qm, budget)
    if inverse is not None:
        K = block_gain(r, gain_symbols(r))
        pairs = sum(len(x) for row in inverse.X for x in row) * len(inverse.d)  # each row of K holds one k_j
        budget.charge(CANCEL_FACTOR_WEIGHT * pairs, "cancelling and factoring the entries of Q⁻¹ k")
        den = inverse.d.as_expr()
        entries = [[tidy(sum((x.as_expr() * kk for x, kk in zip(inverse.X[i], K.col(c)) if x), sp.Integer(0)) / den)
                    for c in range(K.shape[1])] for i in range(Qm.shape[0])]
        return gain_strings(sp.Matrix(entries), q), None
    budget.charge(sum(derivative_size(e) for e in Qm) * OPERATIONS_PER_NODE, "the symbolic Q⁺ = Qᵀ (Q Qᵀ)⁻¹")
    Qp = symbolic_pinv(Qm)
    return gain_strings(pinv_gain_field(Qp, r), q), Qp


@dataclass(frozen=True)
class NumericGain:
    """``Q⁺(x)`` evaluated by ``numpy.linalg.pinv`` at points of the region (the symbolic one was not computed).

    ``l(x) = Q⁺(x) K`` is linear in the gains: at each point the columns of ``Q⁺(x)`` are the
    coefficients of ``k1, k2, …`` in ``l(x)``.

    Attributes
    ----------
    points : tuple of tuple of float
        The centre of the region, then the point of largest ``‖Q⁺(x)‖₂`` among the samples.
    pinv : tuple
        ``Q⁺`` at each point (``n × Σ r_j`` nested tuples).
    max_norm : float
        ``max ‖Q⁺(x)‖₂ = 1 / min σ_min(Q)`` over the sampled points.
    samples : int
    reason : str
        Why the symbolic field is missing.
    """

    points: tuple[tuple[float, ...], ...]
    pinv: tuple[Any, ...]
    max_norm: float
    samples: int
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return {"points": [list(p) for p in self.points], "pinv": [[list(row) for row in m] for m in self.pinv],
                "max_norm": self.max_norm, "samples": self.samples, "method": "numpy.linalg.pinv",
                "reason": self.reason}


def numeric_gain(fn: Any, region: Any, reason: str, *, samples: int = 64, seed: int = 0) -> NumericGain:
    """:class:`NumericGain` of the compiled ``Q(x)`` (``fn``: points ``(N, n)`` → ``(N, Σ r_j, n)``)."""
    import numpy as np

    centre = (region.lower + region.upper) / 2
    pts = np.vstack([centre[None, :], region.sample(samples, seed)])
    with np.errstate(all="ignore"):
        Q = np.asarray(fn(pts), dtype=float)
    ok = np.all(np.isfinite(Q), axis=(-2, -1))
    P = np.full(Q.shape[:-2] + (Q.shape[-1], Q.shape[-2]), np.nan)
    P[ok] = np.linalg.pinv(Q[ok])
    norms = np.where(ok, np.linalg.norm(np.nan_to_num(P), ord=2, axis=(-2, -1)), np.inf)
    i = int(np.argmax(norms))
    keep = [0] if i == 0 else [0, i]
    return NumericGain(tuple(tuple(map(float, pts[k])) for k in keep),
                       tuple(tuple(tuple(map(float, row)) for row in P[k]) for k in keep),
                       float(norms[i]), len(pts), reason)
