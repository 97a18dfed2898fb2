"""The exact inverse of a matrix of rational functions, by fraction-free elimination with its work counted.

``Q = D⁻¹ A`` with ``A`` polynomial (each row multiplied by the least common multiple ``L_i`` of its
denominators, ``D = diag(L_i)``), so ``Q⁻¹ = A⁻¹ D``. Bareiss' fraction-free Gauss–Jordan elimination of
``[A | D]`` over the polynomial ring ends at ``[d I | d Q⁻¹]`` with ``d = ±det A``: every entry on the way
is a minor of ``[A | D]``, so every division is exact and nothing grows beyond the minors themselves.
Each product and exact division is charged to a :class:`~nlobs.geometry.budget.SymbolicBudget`
(``a·b`` term operations for operands of ``a`` and ``b`` terms) before it is done, so an inverse too big
for the budget stops at the same step on every machine.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy as sp

from nlobs.geometry.budget import SymbolicBudget


@dataclass(frozen=True)
class ExactInverse:
    """``Q⁻¹ = X / d``: polynomial numerators ``X`` and one common denominator ``d`` (ring elements).

    Attributes
    ----------
    X : tuple of tuple
        ``n × n`` elements of :attr:`ring`.
    d : Any
        The common denominator, an element of :attr:`ring` (``±det A``, up to the row scaling).
    ring : Any
        SymPy's sparse polynomial ring ``QQ[x…]`` of the entries.
    """

    X: tuple[tuple[Any, ...], ...]
    d: Any
    ring: Any

    def as_matrix(self) -> sp.Matrix:
        """``Q⁻¹`` as a SymPy matrix of ``X_ij / d`` (not cancelled)."""
        den = self.d.as_expr()
        return sp.Matrix([[x.as_expr() / den for x in row] for row in self.X])


def _ring_of(Q: sp.MatrixBase) -> Any:
    names = sorted((s for s in Q.free_symbols if isinstance(s, sp.Symbol)), key=lambda s: s.name)
    ring, *_ = sp.ring(names or [sp.Dummy("one")], sp.QQ)
    return ring


def exact_inverse(Q: sp.MatrixBase, budget: SymbolicBudget) -> ExactInverse | None:
    """``Q⁻¹`` of a square matrix of rational functions with rational coefficients, within ``budget``.

    Parameters
    ----------
    Q : sympy.Matrix
        Square; every entry a rational function of its symbols over ℚ.
    budget : SymbolicBudget
        Charged for every product and division (see the module's docstring).

    Returns
    -------
    ExactInverse or None
        ``None`` when an entry is not a rational function over ℚ (a float coefficient, ``sin x``) or ``Q`` is
        singular as a matrix of rational functions.

    Raises
    ------
    OutOfBudget
        When the next step of the elimination would exceed the budget (nothing is returned).
    """
    n, m = Q.shape
    if n != m or n == 0 or any(e.has(sp.Float) for e in Q):
        return None  # a float coefficient has no exact rational meaning here
    ring = _ring_of(Q)
    A: list[list[Any]] = []
    try:
        for i in range(n):
            fracs = []
            for e in Q.row(i):
                num, den = sp.fraction(sp.together(e))
                fracs.append((ring.from_expr(num) if num != 0 else ring.zero, ring.from_expr(den)))
            L = ring.one
            for _, den in fracs:
                budget.charge(len(L) * len(den), "the common denominator of a row of Q")
                L = L.lcm(den)
            row = []
            for num, den in fracs:
                budget.charge(len(num) * len(L), "a row of Q over its common denominator")
                row.append(num * L.exquo(den))
            A.append(row + [L if j == i else ring.zero for j in range(n)])
    except (sp.polys.polyerrors.CoercionFailed, sp.polys.polyerrors.PolynomialError, ValueError, TypeError):
        return None
    prev = ring.one
    for k in range(n):
        candidates = [i for i in range(k, n) if A[i][k]]
        if not candidates:
            return None  # singular over the rational functions
        p = min(candidates, key=lambda i: (len(A[i][k]), i))
        A[k], A[p] = A[p], A[k]
        pivot = A[k][k]
        for i in range(n):
            if i == k:
                continue
            aik = A[i][k]
            row_i, row_k = A[i], A[k]
            for j in range(2 * n):
                if j == k:
                    continue
                a, b = row_i[j], row_k[j]
                budget.charge(len(pivot) * len(a) + len(aik) * len(b), "the fraction-free inverse of Q")
                value = pivot * a - aik * b
                if value and prev != 1:
                    budget.charge(len(value) * len(prev), "the fraction-free inverse of Q")
                    value = value.exquo(prev)
                row_i[j] = value
            row_i[k] = ring.zero
        prev = pivot
    return ExactInverse(tuple(tuple(A[i][n:]) for i in range(n)), prev, ring)
