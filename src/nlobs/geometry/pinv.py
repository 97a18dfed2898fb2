"""The Moore–Penrose inverse of the reduced observability matrix (Röbenack, Sec. 4).

``Q⁺(x) = Qᵀ (Q Qᵀ)⁻¹`` for ``Q`` of full row rank (A1), whose columns are the
vector fields ``τ_1, …, τ_r`` (18); the gain vector field is ``l(x) = Q⁺(x) k`` (17).
For several outputs (``Q`` stacked over outputs) the gain is ``Q⁺(x) K`` with
``K = blockdiag(k^1, …, k^q)``, one high-gain vector per output block.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from nlobs.errors import DimensionError
from nlobs.geometry.lie import simplify_bounded, tidy
from nlobs.systems.expressions import as_sympy_expr, as_sympy_matrix


def symbolic_pinv(Q: sp.MatrixBase) -> sp.ImmutableMatrix:
    """``Q⁺ = Qᵀ (Q Qᵀ)⁻¹`` for a full-row-rank ``Q`` (entries simplified where SymPy can).

    Full row rank is the caller's check (:func:`nlobs.geometry.checks.check_a1`);
    the formula is the Moore–Penrose inverse exactly when it holds.
    """
    Qm = sp.Matrix(as_sympy_matrix("Q", Q))
    if Qm.shape[0] > Qm.shape[1]:
        raise DimensionError(f"Q: expected at most as many rows as columns, got shape {Qm.shape}")
    gram = (Qm * Qm.T).applyfunc(tidy)
    inv = gram.inv(method="LU") if gram.shape[0] > 3 else gram.inv()
    return sp.ImmutableMatrix((Qm.T * inv).applyfunc(simplify_bounded))


def gain_symbols(r: Sequence[int]) -> tuple[sp.Symbol, ...]:
    """``k1, k2, …`` (``Σ r_j`` of them), the symbolic high-gain vector entries."""
    return tuple(sp.Symbol(f"k{i + 1}", real=True) for i in range(sum(int(v) for v in r)))


def block_gain(r: Sequence[int], k: Sequence[sp.Expr | float]) -> sp.Matrix:
    """``K = blockdiag(k^1, …, k^q)`` (``Σ r_j × q``) from the stacked entries ``k``."""
    rs = [int(v) for v in r]
    k = [as_sympy_expr(f"k[{i}]", v) for i, v in enumerate(k)]
    if len(k) != sum(rs):
        raise DimensionError(f"k: expected {sum(rs)} entries (Σ r_j), got {len(k)}")
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
    """
    kk = gain_symbols(r) if k is None else tuple(k)
    return sp.ImmutableMatrix((sp.Matrix(as_sympy_matrix("Qp", Qp)) * block_gain(r, kk)).applyfunc(tidy))
