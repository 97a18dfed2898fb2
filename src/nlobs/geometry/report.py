"""The differential-geometric part of ``nlobs analyze`` for a nonlinear model.

Per output the observation relative degree (Dalla Mora, Germani & Manes Def. 2.5 / Röbenack A1),
the generic rank of the observability codistribution, whether ``Φ_s`` for the
default multi-index is a local diffeomorphism at sampled points (and the worst
point), A1 and A5 of Röbenack, and the Moore–Penrose gain field ``Q⁺(x) k`` (17).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from nlobs._schema import ANY, BOOLEAN, BOX, INTEGER, NUMBER, STRING, Record, array, nullable, one_of
from nlobs.checks import CHECK_JSON
from nlobs.errors import ExpressionTooLarge, ModelError
from nlobs.geometry.checks import (
    Check,
    RankEvidence,
    check_a1,
    check_drift_observability,
    check_involutive,
    default_multi_index,
    observability_rank_evidence,
)
from nlobs.geometry.observability import AffineFields, observation_relative_degree, reduced_observability_matrix
from nlobs.geometry.budget import DEFAULT_SYMBOLIC_BUDGET, OutOfBudget, SymbolicBudget
from nlobs.geometry.checks import _ScaledCodistribution
from nlobs.geometry.pinv import NumericGain, gain_within, numeric_gain
from nlobs.geometry.region import Box, format_point
from nlobs.systems.symbolic import SymbolicModel


#: ``observability_rank_evidence`` of ``nlobs analyze``.
RANK_EVIDENCE_JSON = Record("RankEvidence", {
    "rank": nullable(INTEGER), "lower": INTEGER.about("count of singular values above 10 eta"),
    "upper": INTEGER.about("count above eta"), "singular_values": array(NUMBER, "scaled, at point"),
    "tolerance": NUMBER.about("eta, their error bound"), "gap": NUMBER, "point": nullable(array(NUMBER)),
    "points": INTEGER, "state_scales": array(NUMBER), "gap_factor": NUMBER, "method": STRING,
    "high_precision_singular_values": nullable(array(NUMBER)), "high_precision_tolerance": NUMBER,
}, description="The numerical evidence for the generic rank of the observability codistribution.")

#: ``pinv_gain_numeric`` of ``nlobs analyze``.
NUMERIC_GAIN_JSON = Record("NumericPinvGain", {
    "points": array(array(NUMBER)), "pinv": array(array(array(NUMBER))), "max_norm": NUMBER, "samples": INTEGER,
    "method": STRING, "reason": STRING,
}, description="Q+(x) by numpy.linalg.pinv at sampled points, when the symbolic gain did not fit the budget.")

#: The keys the differential-geometric analysis adds to ``nlobs analyze`` (Dalla Mora, Germani & Manes;
#: Röbenack).
GEOMETRY_JSON = Record("Geometry", {
    "region": BOX,
    "observation_relative_degree": nullable(array(nullable(INTEGER)),
                                            "per output, Dalla Mora, Germani & Manes Def. 2.5 / Röbenack A1"),
    "relative_degree_evidence": array(STRING),
    "observability_rank": nullable(INTEGER, "null: undecided"),
    "observability_rank_evidence": nullable(RANK_EVIDENCE_JSON),
    "multi_index": array(INTEGER),
    "drift_observable": nullable(BOOLEAN),
    "drift_observability": nullable(CHECK_JSON),
    "a1": nullable(CHECK_JSON),
    "involutive": nullable(BOOLEAN, "Röbenack A5"),
    "a5": nullable(CHECK_JSON),
    "pinv_gain": nullable(array(one_of(STRING, array(STRING))), "Q+(x) k of Röbenack (17), in the model's names"),
    "pinv_gain_numeric": nullable(NUMERIC_GAIN_JSON),
    "numeric_parts": array(STRING),
    "symbolic_budget": NUMBER,
    "notes": array(STRING),
})


@dataclass(frozen=True)
class GeometryReport:
    """What the symbolic layer says about an input-affine model (see :func:`geometry_report`).

    Attributes
    ----------
    region : Box
    relative_degree : tuple of int or None
        Observation relative degree per output (``None``: not defined on the region).
    relative_degree_evidence : tuple of str
        Per output, the zero test that decided it.
    observability_rank : int or None
        Generic rank of ``span{dL_f^k h_j : k < n}`` decided on the scaled matrix
        (:func:`~nlobs.geometry.checks.observability_rank_evidence`); ``None``: undecided (the
        numerics cannot separate a singular value from the rounding error), unless ``Φ_s`` is a
        local diffeomorphism at a sampled point, which proves rank ``n`` (the rank and the
        drift-observability verdict never contradict each other).
    rank_evidence : RankEvidence
        The scaled singular values, their error bound, the gap and the point.
    multi_index : tuple of int
        Default ``s`` (observability indices; ``Σ s_j`` is the generic rank).
    drift : Check or None
        Drift-observability for ``s`` (``None`` when ``Σ s_j < n``: not drift-observable).
    a1, a5 : Check or None
        Röbenack's A1 and A5 (``None`` when a relative degree is undefined).
    pinv_gain : tuple of str or None
        ``Q⁺(x) k`` with ``k = (k1, k2, …)``: one string per state (one output), or one
        row of ``q`` strings per state (several outputs, ``K = blockdiag``).
    notes : tuple of str
    numeric_gain : NumericGain or None
        ``Q⁺(x)`` at points of the region (``numpy.linalg.pinv``) when the symbolic gain field did not
        fit in the symbolic budget (``pinv_gain`` is then ``None``).
    numeric_parts : tuple of str
        The optional symbolic parts replaced by a numeric evaluation or left out (``"pinv_gain"``,
        ``"a5"``), each with a note saying why.
    symbolic_budget : float or None
        Seconds allowed for the optional symbolic parts (``None``: unlimited).
    """

    region: Box
    relative_degree: tuple[int | None, ...]
    relative_degree_evidence: tuple[str, ...]
    observability_rank: int | None
    multi_index: tuple[int, ...]
    drift: Check | None
    a1: Check | None
    a5: Check | None
    pinv_gain: tuple[Any, ...] | None
    outputs: tuple[str, ...]
    states: tuple[str, ...]
    notes: tuple[str, ...]
    rank_evidence: RankEvidence | None = None
    numeric_gain: NumericGain | None = None
    numeric_parts: tuple[str, ...] = ()
    symbolic_budget: float | None = DEFAULT_SYMBOLIC_BUDGET

    def to_dict(self) -> dict[str, Any]:
        """JSON keys (stable, documented in the README)."""
        return GEOMETRY_JSON.emit({
            "region": {"lower": self.region.lower.tolist(), "upper": self.region.upper.tolist()},
            "observation_relative_degree": list(self.relative_degree),
            "relative_degree_evidence": list(self.relative_degree_evidence),
            "observability_rank": self.observability_rank,
            "observability_rank_evidence": None if self.rank_evidence is None else self.rank_evidence.to_dict(),
            "multi_index": list(self.multi_index),
            "drift_observable": None if self.drift is None else self.drift.passed,
            "drift_observability": None if self.drift is None else self.drift.to_dict(),
            "a1": None if self.a1 is None else self.a1.to_dict(),
            "involutive": None if self.a5 is None else self.a5.passed,
            "a5": None if self.a5 is None else self.a5.to_dict(),
            "pinv_gain": None if self.pinv_gain is None else [list(v) if isinstance(v, tuple) else v for v in self.pinv_gain],
            "pinv_gain_numeric": None if self.numeric_gain is None else self.numeric_gain.to_dict(),
            "numeric_parts": list(self.numeric_parts),
            "symbolic_budget": self.symbolic_budget,
            "notes": list(self.notes),
        })

    def summary(self) -> str:
        n = len(self.states)
        lines = [f"differential geometry on {self.region.describe()} (Dalla Mora, Germani & Manes; Röbenack):"]
        for o, r, ev in zip(self.outputs, self.relative_degree, self.relative_degree_evidence):
            lines.append(f"  observation relative degree of {o}: {'undefined' if r is None else r}   ({ev})")
        rank = "undecided" if self.observability_rank is None else f"generic rank {self.observability_rank} of n = {n}"
        ev = "" if self.rank_evidence is None else f"   ({self.rank_evidence.describe()})"
        if self.rank_evidence is not None and self.rank_evidence.rank != self.observability_rank:
            ev = f"   (from Q_s nonsingular; the scaled singular values alone: {self.rank_evidence.describe()})"
        lines.append(f"  observability codistribution: {rank}{ev}")
        lines.append(f"  default multi-index s = {list(self.multi_index)}")
        if self.drift is None:
            if self.observability_rank is not None and self.observability_rank < n:
                lines.append("  drift-observable: no (the codistribution has rank < n, no Φ_s is a diffeomorphism)")
            else:
                lines.append(f"  drift-observable: not checked (the default multi-index has Σ s_j = {sum(self.multi_index)} "
                             f"< n at its sample point)")
        else:
            lines.append(f"  drift-observable (Φ_s local diffeomorphism): {'yes' if self.drift.passed else 'NO'} — {self.drift.evidence}")
        for c in (self.a1, self.a5):
            if c is not None:
                lines.append(f"  {c.summary()}")
        if self.pinv_gain is not None:
            lines.append("  Moore–Penrose gain l(x) = Q⁺(x) k (Röbenack (17)):")
            for s, e in zip(self.states, self.pinv_gain):
                lines.append(f"    l_{s} = {e if not isinstance(e, tuple) else ', '.join(e)}")
        if self.numeric_gain is not None:
            g = self.numeric_gain
            lines.append(f"  Moore–Penrose gain l(x) = Q⁺(x) k (Röbenack (17)): evaluated numerically (numpy.linalg.pinv) "
                         f"at {g.samples} points, max ‖Q⁺(x)‖₂ = {g.max_norm:.4g} at x = {format_point(g.points[-1])}")
        lines.extend(f"  note: {t}" for t in self.notes)
        return "\n".join(lines)


#: Above this many states the symbolic analyses are not attempted (a 300-state model did not finish in 900 s; a
#: 20-state cubic chain reaches the polynomial-size limit after 24 s).
MAX_GEOMETRY_STATES = 50


def too_many_states(n: int) -> str:
    """Why the symbolic analyses are not attempted for ``n`` states (above :data:`MAX_GEOMETRY_STATES`).

    Parameters
    ----------
    n : int
        The number of states.

    Returns
    -------
    str
    """
    return (f"{n} states: the Lie-derivative analysis is done up to {MAX_GEOMETRY_STATES} states (the size of "
            "L_f^k h grows with every k)")


def geometry_report(model: SymbolicModel, region: Box | None = None, *, seed: int = 0,
                    symbolic_budget: float | None = DEFAULT_SYMBOLIC_BUDGET) -> GeometryReport:
    """Run the symbolic analyses of Dalla Mora–Germani–Manes and Röbenack on a continuous-time input-affine model.

    ``symbolic_budget`` bounds, in seconds of counted work (:class:`~nlobs.geometry.budget.SymbolicBudget`,
    never the clock), the optional symbolic parts (``None``: unlimited): the gain
    field ``Q⁺(x) k`` (17) and, with it, the symbolic ``Q⁺`` of the involutivity check A5. A part that
    does not fit is replaced by a numeric evaluation (``Q⁺(x)`` by ``numpy.linalg.pinv`` at
    sampled points; A5 is then not checked when ``Q`` is not square) and named in ``numeric_parts``
    with a note; every symbolic result that is reported is exact.

    Raises
    ------
    ModelError
        If the model is not continuous-time input-affine with an input-free output.
    ExpressionTooLarge
        More than :data:`MAX_GEOMETRY_STATES` states, or a Lie derivative beyond the polynomial-size limit.
    """
    if model.n > MAX_GEOMETRY_STATES:  # before any Lie derivative: their size grows with every order
        raise ExpressionTooLarge(too_many_states(model.n))
    fields = AffineFields.from_model(model)
    reg = region or Box.unit(fields.n)
    if reg.n != fields.n:
        raise ModelError(f"{model.name}: region has dimension {reg.n}, the model {fields.n}")
    rd = observation_relative_degree(fields, reg, seed=seed)
    evidence = []
    for r, tests in zip(rd.r, rd.tests):
        last = tests[-1] if tests else None
        if r is None:
            evidence.append(f"L_g L_f^k h = 0 for k < {rd.max_order} on the region")
        else:
            evidence.append(f"L_g L_f^{r - 1} h {last.describe() if last else ''}")
    evidence_rank = observability_rank_evidence(fields, reg, seed=seed)
    rank = evidence_rank.rank
    s = default_multi_index(fields, reg, seed=seed)
    notes: list[str] = []
    drift = check_drift_observability(fields, s, reg, seed=seed) if sum(s) == fields.n else None
    if drift is not None and drift.passed and rank != fields.n:
        # Q_s (rows of the codistribution) nonsingular at a point: the codistribution has rank n there
        notes.append(f"Q_s is nonsingular on the region ({drift.evidence}), so the codistribution has rank "
                     f"n = {fields.n}; its scaled singular values alone gave "
                     + ("no decision" if rank is None else f"rank {rank}"))
        rank = fields.n
    elif rank is None:
        notes.append(f"generic rank undecided: {evidence_rank.describe()}")
    a1 = a5 = None
    gain: tuple[Any, ...] | None = None
    value = ""
    numeric: NumericGain | None = None
    parts: list[str] = []
    if all(r is not None for r in rd.r):
        r_ = rd.require(fields.outputs)
        a1 = check_a1(fields, r_, reg, seed=seed)
        if sum(r_) > fields.n:
            notes.append(f"Σ r_j = {sum(r_)} > n: Röbenack's decomposition needs Σ r_j ≤ n")
        elif a1.passed:
            Q = reduced_observability_matrix(fields, r_)
            square = sum(r_) == fields.n
            try:
                gain, Qp = gain_within(Q, r_, fields.q, SymbolicBudget(symbolic_budget))
            except OutOfBudget as exc:
                value = str(exc)
            else:
                a5 = check_involutive(fields, r_, reg, Qp=Qp, seed=seed)
            if gain is None:
                scd = _ScaledCodistribution.for_fields(fields, r_, reg)
                numeric = numeric_gain(scd.J, reg, f"the symbolic Q⁺(x) k: {value}", seed=seed)
                parts.append("pinv_gain")
                notes.append(f"the gain field Q⁺(x) k (Röbenack (17)) was not computed symbolically: {value}; "
                             f"Q⁺(x) is evaluated numerically (numpy.linalg.pinv) at {numeric.samples} points of the "
                             "region instead (`symbolic_budget` to allow more time)")
                if square or sum(r_) <= 1:
                    a5 = check_involutive(fields, r_, reg, seed=seed)  # structural: Δ has rank 1 or n
                else:
                    parts.append("a5")
                    notes.append("A5 (involutivity of span{τ}) was not checked: it needs the symbolic Q⁺")
    else:
        notes.append("a relative degree is undefined on the region: Röbenack's gain Q⁺k is not available")
    return GeometryReport(reg, rd.r, tuple(evidence), rank, s, drift, a1, a5, gain, fields.outputs, fields.states,
                          tuple(notes), evidence_rank, numeric, tuple(parts), symbolic_budget)
