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
    """
    kk = gain_symbols(r) if k is None else tuple(k)
    return sp.ImmutableMatrix((sp.Matrix(as_sympy_matrix("Qp", Qp)) * block_gain(r, kk)).applyfunc(tidy))


def gain_strings(field_: sp.MatrixBase, q: int) -> tuple[Any, ...]:
    """The report's text of ``l(x)``: one factored string per state (one output), else rows of ``q`` strings."""
    if q == 1:
        return tuple(str(sp.factor(e)) if e.is_rational_function() else str(e) for e in field_[:, 0])
    return tuple(tuple(str(e) for e in field_.row(i)) for i in range(field_.shape[0]))


def gain_job(Q: sp.MatrixBase, r: Sequence[int], q: int) -> tuple[tuple[Any, ...], sp.ImmutableMatrix | None]:
    """The symbolic gain field ``l(x) = Q⁺(x) K`` (17) as the report prints it, and ``Q⁺`` when it was built.

    A square ``Q`` with rational entries (Σ r_j = n: ``Q⁺ = Q⁻¹``) is inverted over the field of rational
    functions (SymPy's ``DomainMatrix``), not through ``Qᵀ (Q Qᵀ)⁻¹`` of expressions — the same rational
    functions, so the same factored text, at a fraction of the cost; otherwise :func:`symbolic_pinv`. The step :func:`~nlobs.geometry.budget.run_bounded`
    runs within the symbolic budget.
    """
    Qm = sp.Matrix(as_sympy_matrix("Q", Q))
    if Qm.shape[0] == Qm.shape[1] and all(e.is_rational_function() for e in Qm):
        from sympy.polys.matrices import DomainMatrix

        X = DomainMatrix.from_Matrix(Qm).to_field().inv().to_Matrix()  # Q⁻¹ over the rational functions
        field_ = (X * block_gain(r, gain_symbols(r))).applyfunc(tidy)
        return gain_strings(field_, q), None
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
