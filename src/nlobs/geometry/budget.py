"""A budget of counted work for the optional symbolic steps of the geometric analysis.

Some exact results are worth having only when they are cheap: the Moore–Penrose gain field
``l(x) = Q⁺(x) k`` of Röbenack (17) of a 9-state polynomial chain has entries of tens of thousands of
terms. Whether such a step is done must not depend on the machine or its load (the same model file
gets the same report everywhere), so the budget counts *work*, never the clock: a step charges the
term operations it is about to do (a product of polynomials with ``a`` and ``b`` terms costs ``a·b``)
and stops, before doing them, when they would exceed what is left. The budget is stated in seconds,
the work a typical machine does in that time (:data:`TERM_OPERATIONS_PER_SECOND`), so that
a budget of 5 s reads as before; the count alone decides.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Default seconds, in all, of the optional symbolic steps of ``nlobs analyze`` (its ``symbolic_budget``).
DEFAULT_SYMBOLIC_BUDGET = 5.0

#: Term operations a second of the budget buys: a round figure, fixed, so that every machine draws the same line.
#: Measured on the polynomial and Duffing chains of ``benchmarks/analyze_scale.py`` (the exact inverse of ``Q`` and
#: the cancelled, factored entries of ``Q⁻¹ k``, in CPU time on an idle 2-core machine): 1.4–3.1 × 10⁵ a second.
TERM_OPERATIONS_PER_SECOND = 200_000

#: Work charged for a step whose cost is not counted term by term (a ``simplify`` of an expression predicted
#: small): its predicted size (expression-tree nodes) times this.
OPERATIONS_PER_NODE = 100


class OutOfBudget(Exception):
    """The next symbolic step would use more work than is left in the :class:`SymbolicBudget`."""


@dataclass
class SymbolicBudget:
    """Term operations left for the optional symbolic steps (``seconds=None``: unlimited).

    Parameters
    ----------
    seconds : float or None
        The budget in seconds of a typical machine (:data:`TERM_OPERATIONS_PER_SECOND` operations each).
    used : int
        Term operations charged so far.
    """

    seconds: float | None = DEFAULT_SYMBOLIC_BUDGET
    used: int = 0

    @property
    def limit(self) -> int | None:
        """The budget in term operations (``None``: unlimited)."""
        if self.seconds is None:
            return None
        return int(float(self.seconds) * TERM_OPERATIONS_PER_SECOND)

    def charge(self, operations: int, what: str) -> None:
        """Count ``operations`` for ``what``, or raise :class:`OutOfBudget` (counting nothing) when they do not fit.

        Parameters
        ----------
        operations : int
            Term operations the step is about to do.
        what : str
            The step, for the reason the report prints.

        Raises
        ------
        OutOfBudget
            When ``used + operations`` exceeds :attr:`limit`.
        """
        limit = self.limit
        if limit is not None and self.used + int(operations) > limit:
            raise OutOfBudget(f"{what} needs more than the symbolic budget ({self.seconds:g} s, "
                              f"{limit:,} term operations; {self.used:,} used)")
        self.used += int(operations)
