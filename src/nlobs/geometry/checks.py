"""The checks a user needs before trusting a differential-geometric observer.

Each returns a :class:`nlobs.checks.Check` (a verdict with its evidence):

* :func:`check_drift_observability` — ``Φ_s`` is a local diffeomorphism on the
  region: ``det Q_s`` symbolically where tractable, and the smallest singular
  value of ``Q_s`` over sampled points, with the point where it is smallest
  (Dalla Mora, Germani & Manes Def. 2.3).
* :func:`check_a1` — ``dh, …, dL_f^{r−1}h`` linearly independent (Röbenack A1):
  the smallest singular value of ``Q`` (13) over sampled points.
* :func:`check_involutive` — the distribution spanned by the columns of ``Q⁺``
  is involutive (Röbenack A5): every bracket ``[τ_i, τ_j]`` lies in it, tested by
  its residual ``(I − Q⁺Q)[τ_i, τ_j]`` (``Q⁺Q`` projects onto ``span τ``),
  symbolically where SymPy proves it zero and at sampled points otherwise.
* :func:`check_s_le_r` — ``s ≤ r`` componentwise (Dalla Mora, Germani & Manes Theorems 2.9, 3.4).

Plus the generic rank of the observability codistribution and a default
multi-index (the observability indices found by a rank-greedy selection).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp
import scipy

from nlobs._typing import Array
from nlobs.checks import Check, CheckKind
from nlobs.errors import ModelError
from nlobs.geometry.lie import FAST_EVAL_TERMS, SIMPLIFY_OPS_LIMIT, PolynomialMatrixFunction, lie_bracket, tidy
from nlobs.geometry.observability import (
    AffineFields,
    check_multi_index,
    observability_jacobian,
    reduced_observability_matrix,
)
from nlobs.geometry.pinv import symbolic_pinv
from nlobs.geometry.region import Box, format_point
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.expressions import as_sympy_expr, as_sympy_matrix


#: Largest ``Q_s`` (rows) whose determinant is computed symbolically.
SYMBOLIC_DET_MAX_N = 4
#: A matrix is called (numerically) singular where the ``σ_min`` of its scaled form (columns times
#: the state scales, rows divided by their size on the region) is ``≤ RANK_RTOL · σ_max``: an
#: observer that inverts it would amplify relative errors by more than ``1/RANK_RTOL`` there.
RANK_RTOL = 1e-7


def _sigma_min(fn: object, pts: Array) -> Array:
    """Smallest singular value of a compiled matrix function at each point (non-finite → 0)."""
    with np.errstate(all="ignore"):
        vals = fn(pts)  # type: ignore[operator]
    finite = np.all(np.isfinite(vals), axis=(-2, -1))
    sv = np.zeros(len(pts))
    if np.any(finite):
        sv[finite] = np.linalg.svd(vals[finite], compute_uv=False)[..., -1]
    return sv


def _refine(fn: object, pts: Array, sv: Array, region: Box, starts: int = 4) -> tuple[Array, float]:
    """Locally minimise ``σ_min`` over the box from the ``starts`` worst sampled points (L-BFGS-B).

    Random points miss thin singular sets (a hyperplane ``x2 = 0``); a bounded local descent
    from the worst samples finds them.
    """
    bounds = list(zip(region.lower, region.upper))
    best_pt, best = pts[int(np.argmin(sv))], float(np.min(sv))
    for i in np.argsort(sv)[:starts]:
        res = scipy.optimize.minimize(lambda z: float(_sigma_min(fn, z[None, :])[0]), pts[i], method="L-BFGS-B", bounds=bounds,
                       options={"maxiter": 200})
        if res.fun < best:
            best_pt, best = np.clip(res.x, region.lower, region.upper), float(res.fun)
    return best_pt, best


def check_full_rank(name: str, what: str, M: sp.MatrixBase | None, fields: AffineFields, reg: Box, samples: int = 256,
                    seed: int = 0, *, det: sp.Expr | None = None, phrase: str | None = None,
                    rows: Sequence[int] | None = None) -> Check:
    """Full row rank of ``M(x)`` on the region, with the worst point.

    A sign change of ``det`` (square case) between two sampled points proves a singular point on the
    segment between them (intermediate values; located by bisection; ``method="intermediate value"``).
    Otherwise ``σ_min`` at sampled points, refined by a bounded local minimisation from the worst ones.
    The decision is taken on the scaled matrix of :func:`observability_rank_evidence` (columns times
    the state scales of the region, rows divided by their largest norm over the points examined), at
    every sampled point and the refined one:
    singular where its ``σ_min ≤ max(RANK_RTOL · σ_max, RANK_GAP_FACTOR · η)``, ``η`` the error bound
    of the evaluation (a non-finite point counts as singular). ``value`` is the unscaled ``σ_min``.
    ``phrase`` words a failure (default "``what`` loses rank").
    """
    pts = reg.sample(samples, seed)
    det_txt = None if det is None else str(det)
    if det is not None:
        dfn = compile_matrix(sp.Matrix([as_sympy_expr("det", det)]), (tuple(fields.x),), vector=True,
                             what=f"det {what}")
        with np.errstate(all="ignore"):
            dv = dfn(pts)[:, 0]
        ok = np.isfinite(dv)
        if np.any(dv[ok] > 0) and np.any(dv[ok] < 0):
            a, b = pts[ok][int(np.argmax(dv[ok]))], pts[ok][int(np.argmin(dv[ok]))]
            for _ in range(60):
                mid = (a + b) / 2
                with np.errstate(all="ignore"):
                    dm = float(dfn(mid[None, :])[0, 0])
                if not np.isfinite(dm):
                    break
                a, b = (mid, b) if dm > 0 else (a, mid)
            pt = (a + b) / 2
            return Check.verdict(name, False, f"det {what} = {det_txt} changes sign on the region: {what} is singular "
                                 f"at x ≈ {format_point(pt)}", kind=CheckKind.RANK, method="intermediate value",
                                 worst_point=tuple(map(float, pt)), value=0.0, symbolic=det_txt)
    if rows is not None:
        # M is the codistribution of the multi-index `rows`: compiled (or evaluated from its monomials) once
        scd = _ScaledCodistribution.for_fields(fields, rows, reg)
        fn = scd.J
    else:
        M = as_sympy_matrix("M", M)
        fn = compile_matrix(M, (tuple(fields.x),), what=what)
        scd = None
    sv = _sigma_min(fn, pts)
    pt, worst = _refine(fn, pts, sv, reg)
    # the decision is taken on the scaled matrix (columns × state scales, rows by their size), as the
    # observability rank is, so that units and the growth of L_f^k h cannot decide it
    if scd is None:
        scd = _ScaledCodistribution.build(M, fields.x, reg)
    spts, S, E = scd._scale(np.vstack([pts, pt[None, :]]))
    holds, ssv = False, 0.0
    if len(spts):
        ssvs = np.linalg.svd(S, compute_uv=False)
        eta = np.linalg.norm(E, axis=(-2, -1)) + 4 * max(S.shape[-2:]) * UNIT_ROUNDOFF * ssvs[:, 0]
        thr = np.maximum(RANK_RTOL * ssvs[:, 0], RANK_GAP_FACTOR * eta)
        margin = ssvs[:, -1] / thr
        holds = bool(np.all(margin > 1.0)) and len(spts) == len(pts) + 1
        j = int(np.argmin(margin))
        ssv = float(ssvs[j, -1])
        if not holds:
            pt = spts[j] if margin[j] <= 1.0 else pt
            worst = float(_sigma_min(fn, pt[None, :])[0])
    ev = (f"σ_min({what}) ≥ {worst:.3g} on {reg.describe()} ({samples} sampled points and local minimisation), "
          f"smallest at x = {format_point(pt)}; scaled σ_min ≥ {ssv:.3g}" if holds
          else f"{phrase or what + ' loses rank'} at x = {format_point(pt)} (σ_min = {worst:.3g}, scaled {ssv:.3g})")
    if det_txt is not None:
        ev += f"; det {what} = {det_txt}"
    return Check.verdict(name, holds, ev, kind=CheckKind.RANK, method="numeric", worst_point=tuple(map(float, pt)),
                         value=worst, symbolic=det_txt)


def check_drift_observability(
    fields: AffineFields, s: Sequence[int], region: Box | None = None, *, samples: int = 256, seed: int = 0
) -> Check:
    """Is ``Φ_s`` a local diffeomorphism on the region (``Q_s`` nonsingular)? (Dalla Mora, Germani & Manes Def. 2.3)

    Symbolic evidence for ``n ≤ 4``: ``det Q_s``; a nonzero constant proves it everywhere, a
    sign change between two sampled points proves a singular point between them. Numeric
    evidence: ``σ_min(Q_s)`` at ``samples`` seeded points, refined by a bounded local
    minimisation from the worst ones. Sampling cannot prove nonsingularity everywhere: a
    positive numeric verdict says "nonsingular at every point examined".

    Examples
    --------
    ``ẋ1 = x2²``, ``y = x1``: ``Q_s = [[1, 0], [0, 2 x2]]``. On ``[−1, 1]²`` its determinant ``2 x2``
    changes sign, which proves a singular point (found on ``x2 = 0``); on ``x2 ∈ [0.25, 1]`` it is
    nonsingular, ``σ_min(Q_s) = min(1, 2 x2)`` smallest (``0.5``) on the edge ``x2 = 0.25``.

    >>> from nlobs.geometry.observability import AffineFields
    >>> from nlobs.systems.symbolic import SymbolicModel
    >>> m = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=["x2**2", "-x1"], g=[[0], [1]], h=["x1"],
    ...                                name="fold")
    >>> fields = AffineFields.from_model(m)
    >>> chk = check_drift_observability(fields, (2,))
    >>> chk.passed, chk.method, chk.symbolic, abs(chk.worst_point[1]) < 1e-9
    (False, 'intermediate value', '2*x2', True)
    >>> chk = check_drift_observability(fields, (2,), Box([-1.0, 0.25], [1.0, 1.0]), samples=64)
    >>> chk.passed, chk.method, round(chk.value, 3), round(chk.worst_point[1], 3)
    (True, 'numeric', 0.5, 0.25)

    A constant determinant is a proof everywhere (the shipped pendulum, ``y = θ``: ``Q_s = I``):

    >>> import nlobs
    >>> check_drift_observability(AffineFields.from_model(nlobs.load_model("pendulum")), (2,)).evidence
    'det Q_s = 1 (constant): Q_s is nonsingular everywhere'
    """
    s_ = check_multi_index(s, fields.q, fields.n)
    reg = region or Box.unit(fields.n)
    det = None
    if fields.n <= SYMBOLIC_DET_MAX_N:
        Q = observability_jacobian(fields, s_)
        det = sp.factor(tidy(Q.det(method="berkowitz")))
        if det.is_number:
            holds = bool(det != 0)
            return Check.verdict("drift-observability", holds,
                                 f"det Q_s = {det} (constant): " + ("Q_s is nonsingular everywhere" if holds
                                                                    else "Q_s is singular everywhere"),
                                 kind=CheckKind.RANK, method="symbolic", value=float(abs(det)), symbolic=str(det))
    return check_full_rank("drift-observability", "Q_s", None, fields, reg, samples, seed, det=det, rows=s_)


def check_a1(fields: AffineFields, r: Sequence[int], region: Box | None = None, *, samples: int = 256, seed: int = 0) -> Check:
    """Röbenack A1 (second part): the rows ``dh, …, dL_f^{r−1} h`` of ``Q`` are linearly independent.

    Examples
    --------
    The shipped Isidori example (``y = x4``, ``r = 2``): ``Q = [[0, 0, 0, 1], [2 x1, 1, 0, 0]]`` has
    ``σ_min ≥ 1`` everywhere. Two outputs ``y1 = x1``, ``y2 = 2 x1`` have dependent differentials.

    >>> import nlobs
    >>> from nlobs.geometry.observability import AffineFields
    >>> chk = check_a1(AffineFields.from_model(nlobs.load_model("isidori-146")), (2,))
    >>> chk.passed, chk.method, round(chk.value, 6)
    (True, 'numeric', 1.0)
    >>> from nlobs.systems.symbolic import SymbolicModel
    >>> m = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y1", "y2"], f=["-x1", "-x2"], g=[[1], [0]],
    ...                                h=["x1", "2*x1"])
    >>> chk = check_a1(AffineFields.from_model(m), (1, 1))
    >>> chk.passed, chk.evidence.split(" at ")[0]
    (False, 'dh, …, dL_f^(r−1) h are dependent')
    """
    r_ = check_multi_index(r, fields.q)
    reg = region or Box.unit(fields.n)
    if sum(r_) > fields.n:
        return Check.verdict("A1 (independent dL_f^k h)", False,
                             f"Σ r_j = {sum(r_)} covectors dL_f^k h in ℝ^{fields.n} cannot be independent",
                             kind=CheckKind.RANK, method="structural")
    det = None
    if sum(r_) == fields.n <= SYMBOLIC_DET_MAX_N:
        det = sp.factor(tidy(reduced_observability_matrix(fields, r_).det(method="berkowitz")))
    return check_full_rank("A1 (independent dL_f^k h)", "Q", None, fields, reg, samples, seed, det=det,
                           phrase="dh, …, dL_f^(r−1) h are dependent", rows=r_)


def check_involutive(
    fields: AffineFields,
    r: Sequence[int],
    region: Box | None = None,
    *,
    Qp: sp.MatrixBase | None = None,
    samples: int = 128,
    seed: int = 0,
) -> Check:
    """Röbenack A5: ``Δ = span{τ_1, …, τ_r}`` (columns of ``Q⁺``) is involutive.

    Every bracket ``[τ_i, τ_j]`` must lie in ``Δ = range Qᵀ``; its residual
    ``(I − Q⁺ Q)[τ_i, τ_j]`` is tested symbolically, then at sampled points
    (relative to ``‖[τ_i, τ_j]‖``). ``Δ`` of rank 1 (or ``n``) is always involutive.

    Examples
    --------
    The shipped Isidori example passes symbolically. For ``y = x3`` with ``L_f h = x1 + x2 x3``
    (``r = 2``), ``Δ = span{e3, (1, x3, 0)}`` and by hand ``[e3, (1, x3, 0)] = (0, 1, 0) ∉ Δ``.

    >>> import nlobs
    >>> from nlobs.geometry.observability import AffineFields
    >>> chk = check_involutive(AffineFields.from_model(nlobs.load_model("isidori-146")), (2,))
    >>> chk.passed, chk.method
    (True, 'symbolic')
    >>> from nlobs.systems.symbolic import SymbolicModel
    >>> m = SymbolicModel.input_affine(["x1", "x2", "x3"], ["u"], ["y"], f=["-x1", "-x2", "x1 + x2*x3"],
    ...                                g=[[1], [0], [0]], h=["x3"], name="twisted")
    >>> chk = check_involutive(AffineFields.from_model(m), (2,))
    >>> chk.passed, chk.method, chk.evidence.split(" at ")[0], chk.value > 1e-3
    (False, 'numeric', '[τ_1, τ_2] leaves span{τ}', True)
    """
    r_ = check_multi_index(r, fields.q)
    reg = region or Box.unit(fields.n)
    Q = reduced_observability_matrix(fields, r_)
    rank = Q.shape[0]
    if rank <= 1 or rank >= fields.n:
        return Check.verdict("A5 (involutive)", True, f"Δ has rank {rank} ∈ {{1, n}}: always involutive",
                             kind=CheckKind.STRUCTURAL, method="structural")
    P = sp.Matrix(symbolic_pinv(Q) if Qp is None else as_sympy_matrix("Qp", Qp))
    proj = sp.eye(fields.n) - (P * Q)
    residuals: list[sp.Matrix] = []
    pairs: list[tuple[int, int]] = []
    for a in range(rank):
        for b in range(a + 1, rank):
            br = lie_bracket(P[:, a], P[:, b], fields.x)
            res = (proj * br).applyfunc(tidy)
            if all(sp.count_ops(e) <= SIMPLIFY_OPS_LIMIT and sp.simplify(e) == 0 for e in res):
                continue
            residuals.append(sp.Matrix.hstack(res, br))
            pairs.append((a + 1, b + 1))
    if not residuals:
        return Check.verdict("A5 (involutive)", True,
                             f"every [τ_i, τ_j] lies in span{{τ}} ((I − Q⁺Q)[τ_i, τ_j] ≡ 0 for all {rank * (rank - 1) // 2} "
                             "pairs)", kind=CheckKind.STRUCTURAL, method="symbolic")
    pts = reg.sample(samples, seed)
    worst, worst_pt, worst_pair = 0.0, pts[0], pairs[0]
    for pair, M in zip(pairs, residuals):
        fn = compile_matrix(M, (tuple(fields.x),), what="bracket residual")
        with np.errstate(all="ignore"):
            vals = fn(pts)
        rel = np.linalg.norm(vals[..., 0], axis=-1) / np.maximum(1.0, np.linalg.norm(vals[..., 1], axis=-1))
        rel = np.where(np.isfinite(rel), rel, np.inf)
        i = int(np.argmax(rel))
        if rel[i] > worst or worst == 0.0:
            worst, worst_pt, worst_pair = float(rel[i]), pts[i], pair
    holds = worst <= 1e-9
    ev = (f"every [τ_i, τ_j] lies in span{{τ}} at {samples} sampled points (largest relative residual {worst:.2g})"
          if holds else f"[τ_{worst_pair[0]}, τ_{worst_pair[1]}] leaves span{{τ}} at x = {format_point(worst_pt)} "
          f"(relative residual {worst:.3g})")
    return Check.verdict("A5 (involutive)", holds, ev, kind=CheckKind.STRUCTURAL, method="numeric",
                         worst_point=tuple(map(float, worst_pt)), value=worst)


def check_s_le_r(s: Sequence[int], r: Sequence[int | None]) -> Check:
    """``s ≤ r`` componentwise (Dalla Mora, Germani & Manes Theorems 2.9, 3.4); an undefined ``r_j`` is infinite.

    Examples
    --------
    >>> check_s_le_r((2, 2), (2, 2)).evidence
    's = (2, 2), r = (2, 2): s ≤ r, (2.17) is solvable for every (α, μ, γ) (Thm 2.9)'
    >>> chk = check_s_le_r((3, 1), (2, 2))
    >>> chk.passed, chk.evidence
    (False, 's = (3, 1), r = (2, 2): s ≰ r: the input bound μ must be small enough (Thm 2.7)')
    >>> check_s_le_r((3,), (None,)).passed  # no input reaches the output: r = ∞
    True
    """
    ok = all(rj is None or sj <= rj for sj, rj in zip(s, r))
    rt = ["∞" if v is None else str(v) for v in r]
    return Check.verdict("s ≤ r", ok,
                         f"s = ({', '.join(map(str, s))}), r = ({', '.join(rt)}): "
                         + ("s ≤ r, (2.17) is solvable for every (α, μ, γ) (Thm 2.9)" if ok
                            else "s ≰ r: the input bound μ must be small enough (Thm 2.7)"),
                         kind=CheckKind.STRUCTURAL, method="structural")


#: Unit roundoff of IEEE double precision.
UNIT_ROUNDOFF = float(np.finfo(float).eps) / 2
#: A scaled singular value counts as nonzero above ``RANK_GAP_FACTOR · η`` and as zero at or below
#: ``η`` (the error bound of the evaluation); between the two the rank is undecided.
RANK_GAP_FACTOR = 10.0


@dataclass(frozen=True)
class RankEvidence:
    """How :func:`observability_rank_evidence` decided the generic rank (or why it could not).

    Attributes
    ----------
    rank : int or None
        The generic rank, or ``None`` (undecided: a scaled singular value lies within a factor
        ``RANK_GAP_FACTOR`` above the evaluation's error bound, or no sampled point is finite).
    lower, upper : int
        The counts ``#{σ > RANK_GAP_FACTOR · η}`` and ``#{σ > η}`` maximised over the sampled
        points (``lower ≤ rank ≤ upper``; equal when decided).
    singular_values : tuple of float
        Singular values of the scaled codistribution matrix at ``point``.
    tolerance : float or None
        ``η`` at ``point``: the bound on the error of those singular values (``None``: no point).
    gap : float or None
        ``σ_r / max(σ_(r+1), η)`` at ``point``, ``r`` the rank (for an undecided rank, ``#{σ > η}``
        there): how far the last nonzero singular value stands above the next one or the noise
        (``None`` when ``r`` is ``0`` or ``n``).
    point : tuple of float or None
        The sampled point whose singular values are reported (the one of largest rank, or for an
        undecided rank the one with a singular value in the undecided band).
    points : int
        Finite sampled points used.
    state_scales : tuple of float
        Column scales ``d_i = max(|lower_i|, |upper_i|)`` from the region.
    method : str
        How the rank was decided (double precision; checked or decided at ``HIGH_PRECISION_DIGITS``
        digits).
    high_precision_singular_values, high_precision_tolerance : tuple of float or None, float or None
        The scaled singular values at ``point`` recomputed at ``HIGH_PRECISION_DIGITS`` digits and
        their error bound (``None`` when not needed: double precision proved full rank).

    Examples
    --------
    An oscillator ``(x1, x2)`` measured by ``y = x1`` next to a state ``x3`` it never sees: rank 2 of 3,
    the third scaled singular value is zero (below ``η``) and the deficiency is confirmed at 48 digits.

    >>> from nlobs.geometry.observability import AffineFields
    >>> from nlobs.systems.symbolic import SymbolicModel
    >>> m = SymbolicModel.input_affine(["x1", "x2", "x3"], ["u"], ["y"], f=["x2", "-x1", "-x3"],
    ...                                g=[[0], [1], [1]], h=["x1"])
    >>> ev = observability_rank_evidence(AffineFields.from_model(m))
    >>> ev.rank, ev.lower, ev.upper, ev.points, ev.method
    (2, 2, 2, 32, 'double precision, checked at 48 digits')
    >>> [round(v, 6) for v in ev.singular_values], ev.singular_values[-1] <= ev.tolerance, ev.gap > 1e10
    ([1.414214, 1.0, 0.0], True, True)
    >>> [round(v, 6) for v in ev.high_precision_singular_values], ev.to_dict()["rank"]
    ([1.414214, 1.0, 0.0], 2)
    """

    rank: int | None
    lower: int
    upper: int
    singular_values: tuple[float, ...]
    tolerance: float | None
    gap: float | None
    point: tuple[float, ...] | None
    points: int
    state_scales: tuple[float, ...]
    method: str = "double precision"
    high_precision_singular_values: tuple[float, ...] | None = None
    high_precision_tolerance: float | None = None

    def describe(self) -> str:
        """One line of evidence."""
        sv = ", ".join(f"{v:.3g}" for v in self.singular_values)
        where = "" if self.point is None else f" at x = {format_point(self.point)}"
        if self.tolerance is None:
            return f"undecided: {self.method}"
        if self.rank is None:
            return (f"undecided: rank between {self.lower} and {self.upper}; scaled singular values ({sv}){where}, "
                    f"error bound η = {self.tolerance:.2g}; {self.method}")
        gap = "" if self.gap is None else f", gap σ_{self.rank}/σ_{self.rank + 1} = {self.gap:.3g}"
        return f"scaled singular values ({sv}){where}, error bound η = {self.tolerance:.2g}{gap}; {self.method}"

    def to_dict(self) -> dict[str, Any]:
        """JSON view (the ``observability_rank_evidence`` key of the JSON report of ``nlobs analyze``)."""
        return {"rank": self.rank, "lower": self.lower, "upper": self.upper,
                "singular_values": list(self.singular_values), "tolerance": self.tolerance, "gap": self.gap,
                "point": None if self.point is None else list(self.point), "points": self.points,
                "state_scales": list(self.state_scales), "gap_factor": RANK_GAP_FACTOR, "method": self.method,
                "high_precision_singular_values": None if self.high_precision_singular_values is None
                else list(self.high_precision_singular_values),
                "high_precision_tolerance": self.high_precision_tolerance}


@dataclass(frozen=True)
class _ScaledCodistribution:
    """The compiled codistribution matrix ``J(x)``, its entries' term magnitudes and rounding factors."""

    J: Any
    A: Any
    gamma: Array
    scales: Array

    @classmethod
    def build(cls, M: sp.MatrixBase, x: Sequence[sp.Symbol], region: Box) -> _ScaledCodistribution:
        terms = [sp.Add.make_args(sp.expand(e)) for e in M]
        A = sp.Matrix(M.shape[0], M.shape[1], [sp.Add(*[sp.Abs(t) for t in ts]) for ts in terms])
        # γ_m = m·u/(1 − m·u) with m the floating operations of an entry (Higham, Accuracy and
        # Stability of Numerical Algorithms, §3.1), plus one rounding of each parameter and of the result
        ops = np.array([float(sp.count_ops(e)) + len(ts) + 2 for e, ts in zip(M, terms)]).reshape(M.shape)
        gamma = ops * UNIT_ROUNDOFF / (1 - ops * UNIT_ROUNDOFF)
        scales = np.maximum(np.abs(region.lower), np.abs(region.upper))
        return cls(compile_matrix(M, (tuple(x),), what="observability codistribution"),
                   compile_matrix(A, (tuple(x),), what="codistribution term magnitudes"), gamma, scales)

    @classmethod
    def for_fields(cls, fields: AffineFields, s: Sequence[int], region: Box, *, tidied: bool = True) -> _ScaledCodistribution:
        """:meth:`build` for the rows ``d L_f^k h_j`` of the multi-index ``s``; a big polynomial matrix
        (more than ``FAST_EVAL_TERMS`` terms) is evaluated from its monomials, without generated code."""
        rows = fields.ring_codistribution(s)
        if rows is None or sum(len(p) for p in rows) <= FAST_EVAL_TERMS:
            return cls.build(fields.codistribution(s, tidied=tidied), fields.x, region)
        shape = (len(rows) // fields.n, fields.n)
        J = PolynomialMatrixFunction(rows, shape, fields.n)
        A = PolynomialMatrixFunction(rows, shape, fields.n, absolute=True)
        ops = J.ops + 2
        gamma = ops * UNIT_ROUNDOFF / (1 - ops * UNIT_ROUNDOFF)
        return cls(J, A, gamma, np.maximum(np.abs(region.lower), np.abs(region.upper)))

    def row_factors(self, pts: Array) -> Array:
        """The diagonal of ``R`` (see :meth:`_scale`) over ``pts``."""
        return self._scale(pts, factors=True)[1]

    def _scale(self, pts: Array, factors: bool = False) -> tuple[Array, Array, Array]:
        """Finite points, the scaled matrices ``R J D`` and their entrywise error bounds ``R (γ ∘ A) D``.

        ``D`` holds the state scales; ``R`` divides each row by its largest norm over ``pts`` (the
        magnitude of that Lie derivative on the region, so that a row vanishing at a point still shows
        as a loss of rank there). A row never above its own error bound is dropped (zero).
        """
        with np.errstate(all="ignore"):
            J, A = self.J(pts), self.A(pts)
        ok = np.all(np.isfinite(J), axis=(-2, -1)) & np.all(np.isfinite(A), axis=(-2, -1))
        JD = J[ok] * self.scales
        ED = self.gamma * A[ok] * self.scales
        if len(JD) == 0:
            return pts[ok], np.zeros(self.gamma.shape[0]) if factors else JD, ED
        norms = np.max(np.linalg.norm(JD, axis=-1), axis=0)
        keep = np.any(np.linalg.norm(JD, axis=-1) > np.linalg.norm(ED, axis=-1), axis=0)
        inv = np.where(keep, 1.0 / np.where(keep, norms, 1.0), 0.0)
        if factors:
            return pts[ok], inv, ED
        return pts[ok], JD * inv[:, None], ED * inv[:, None]

    def scaled(self, pt: Array, region: Box) -> tuple[Array | None, Array | None]:
        """The scaled matrix and its error bounds at one point, rows scaled over 32 points of the region
        and ``pt`` (``None, None`` where not finite)."""
        pts = np.vstack([pt, region.sample(32, 1)])
        with np.errstate(all="ignore"):
            finite = bool(np.all(np.isfinite(self.J(pt))))
        if not finite:
            return None, None
        _, S, E = self._scale(pts)
        return S[0], E[0]

    def svd(self, pts: Array) -> tuple[Array, Array, Array]:
        """Finite points, the scaled singular values at each and their error bounds ``η``.

        Columns are multiplied by the state scales, rows divided by their largest norm over
        ``pts``; a row never above its own error bound is indistinguishable from zero and is
        dropped (set to zero).
        """
        pts, S, E = self._scale(pts)
        if len(pts) == 0:
            return pts, np.zeros((0, min(self.gamma.shape))), np.zeros(0)
        sv = np.linalg.svd(S, compute_uv=False)
        # evaluation error (Weyl: |σ_i(S + ΔS) − σ_i(S)| ≤ ‖ΔS‖₂ ≤ ‖ΔS‖_F) plus the SVD's backward error
        eta = np.linalg.norm(E, axis=(-2, -1)) + 4 * max(S.shape[-2:]) * UNIT_ROUNDOFF * sv[:, 0]
        return pts, sv, eta


def codistribution_function(fields: AffineFields, s: Sequence[int]) -> Any:
    """The rows ``d L_f^k h_j`` of the multi-index ``s`` (not simplified) as a function of points ``(N, n)``
    (generated code, or for a big polynomial matrix its monomial tables)."""
    rows = fields.ring_codistribution(s)
    if rows is not None and sum(len(p) for p in rows) > FAST_EVAL_TERMS:
        return PolynomialMatrixFunction(rows, (len(rows) // fields.n, fields.n), fields.n)
    return compile_matrix(fields.codistribution(s, tidied=False), (tuple(fields.x),),
                          what="observability codistribution")


def observability_rank_evidence(
    fields: AffineFields, region: Box | None = None, *, samples: int = 32, seed: int = 0, max_order: int | None = None
) -> RankEvidence:
    """Generic rank of the codistribution spanned by ``dL_f^k h_j`` (``k < n``), with its evidence.

    The rank is decided on a scaled matrix, at ``samples`` seeded points of the region:

    1. ``J(x)``, the Jacobian of ``(L_f^k h_j)``, has its columns multiplied by the state scales
       ``d_i = max(|lower_i|, |upper_i|)`` of the region and each row divided by its largest norm
       over the sampled points (the magnitude of that Lie derivative on the region; a
       nonsingular diagonal scaling on either side leaves the exact rank unchanged; it removes the
       spread of magnitudes that physical units and high-order Lie derivatives put into ``J``).
    2. The error of the evaluated scaled matrix is bounded entrywise by ``γ_m · Σ|terms|``: each
       entry is expanded into its terms, ``m`` counts its floating operations and
       ``γ_m = m·u/(1 − m·u)`` (``u`` the unit roundoff). By Weyl's inequality the singular values
       of the scaled matrix are then within ``η = ‖R (γ ∘ A) D‖_F + 4 max(rows, n) u σ_1`` of the exact
       ones. A row not above its own error bound is indistinguishable from zero and is dropped.
    3. At each point ``lower(x) = #{σ > RANK_GAP_FACTOR · η}`` and ``upper(x) = #{σ > η}``. The
       generic rank (the largest rank on the region; sampled points are generic with probability
       one) is decided when ``max lower(x) = max upper(x)``; otherwise it is ``None`` (undecided)
       and the evidence keeps both counts, the singular values and ``η``.

    Raises
    ------
    ModelError
        If the region's dimension differs from the model's.

    Examples
    --------
    The shipped pendulum (``y = θ``): ``[dh; dL_f h] = I``, full rank, decided in double precision.

    >>> import nlobs
    >>> from nlobs.geometry.observability import AffineFields
    >>> fields = AffineFields.from_model(nlobs.load_model("pendulum"))
    >>> ev = observability_rank_evidence(fields)
    >>> ev.rank, ev.method, [round(v, 6) for v in ev.singular_values], ev.state_scales
    (2, 'double precision', [1.0, 1.0], (1.0, 1.0))
    >>> observability_rank_evidence(fields, Box.around([0.0, 0.0], 3.0)).state_scales
    (3.0, 3.0)
    >>> try:
    ...     observability_rank_evidence(fields, Box.unit(3))
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    ModelError pendulum: region has dimension 3, the model 2
    """
    reg = region or Box.unit(fields.n)
    if reg.n != fields.n:
        raise ModelError(f"{fields.name}: region has dimension {reg.n}, the model {fields.n}")
    kmax = fields.n if max_order is None else int(max_order)
    scd = _ScaledCodistribution.for_fields(fields, [kmax] * fields.q, reg, tidied=False)
    shape = (kmax * fields.q, fields.n)
    pts, sv, eta = scd.svd(reg.sample(samples, seed))
    scales = tuple(map(float, scd.scales))
    if len(pts) == 0:
        return RankEvidence(None, 0, 0, (), None, None, None, 0, scales, "no finite sampled point")
    lower = np.sum(sv > RANK_GAP_FACTOR * eta[:, None], axis=-1)
    upper = np.sum(sv > eta[:, None], axis=-1)
    lo, hi = int(np.max(lower)), int(np.max(upper))
    i = int(np.argmax(lower)) if lo == hi else int(np.argmax((upper > lower) * (upper + 1)))
    s, e, pt = sv[i], float(eta[i]), pts[i]
    rank: int | None = lo if lo == hi else None
    method = "double precision"
    hp_sv: tuple[float, ...] | None = None
    hp_eta: float | None = None
    if rank is None or rank < min(shape):
        # a deficiency (or no decision) in double precision: the singular values at or near the rounding
        # error are recomputed from the exact rational point at HIGH_PRECISION_DIGITS digits
        ring_rows = fields.ring_codistribution([kmax] * fields.q)
        # a polynomial model's rows are evaluated exactly in the sparse ring (no expression is built)
        M = (fields.codistribution([kmax] * fields.q, tidied=False) if ring_rows is None
             else _RingRows(ring_rows, shape))
        hp = _high_precision_singular_values(M, fields.x, pt, scd.scales, scd.row_factors(pts))
        if hp is None:
            method = "double precision (the high-precision evaluation is not finite)"
        else:
            hp_sv, hp_eta = hp
            hp_lo = sum(v > RANK_GAP_FACTOR * hp_eta for v in hp_sv)
            hp_hi = sum(v > hp_eta for v in hp_sv)
            method = f"double precision, checked at {HIGH_PRECISION_DIGITS} digits"
            if hp_lo != hp_hi:
                rank, lo, hi = None, max(lo, hp_lo), max(hi, hp_hi)
                s, e = np.array(hp_sv), hp_eta
                method = f"undecided at {HIGH_PRECISION_DIGITS} digits too"
            elif rank is None or hp_lo != rank:
                rank = lo = hi = max(lo, hp_lo)
                s, e = np.array(hp_sv), hp_eta
                method = f"{HIGH_PRECISION_DIGITS} digits (double precision could not decide)"
    r = rank if rank is not None else int(np.sum(s > e))
    gap = float(s[r - 1] / max(float(s[r]), e)) if 0 < r < len(s) else None
    return RankEvidence(rank, lo, hi, tuple(map(float, s)), e, gap, tuple(map(float, pt)), len(pts), scales, method,
                        hp_sv, hp_eta)


#: Digits of the high-precision re-evaluation that confirms or corrects a double-precision deficiency.
HIGH_PRECISION_DIGITS = 48


@dataclass(frozen=True)
class _RingRows:
    """A matrix of sparse polynomials over ℚ (row-major ``entries``) to evaluate exactly at rational points."""

    entries: Sequence[Any]
    shape: tuple[int, int]

    def at(self, subs: dict[sp.Symbol, sp.Rational]) -> list[sp.Rational]:
        """Every entry's exact value at the point ``subs`` (one value per state symbol)."""
        if not self.entries:
            return []
        R = self.entries[0].ring
        point = [(g, R.domain.convert(subs[s])) for g, s in zip(R.gens, R.symbols)]
        out = []
        for p in self.entries:
            v = p.evaluate(point) if p else R.domain.zero
            out.append(sp.Rational(int(v.numerator), int(v.denominator)))
        return out


def _high_precision_singular_values(M: sp.MatrixBase | _RingRows, x: Sequence[sp.Symbol], pt: Array, scales: Array,
                                    rows: Array) -> tuple[tuple[float, ...], float] | None:
    """Singular values of the scaled ``M`` (the same column and row factors as in double precision; a
    row that double precision dropped is scaled to unit norm) at ``pt`` (taken as exact binary
    rationals) to ``HIGH_PRECISION_DIGITS`` digits, and their error bound; ``None`` if an entry is
    not finite."""
    import mpmath

    subs = {xi: sp.Rational(float(v)) for xi, v in zip(x, pt)}
    digits = HIGH_PRECISION_DIGITS
    exact = M.at(subs) if isinstance(M, _RingRows) else None
    with mpmath.workdps(digits + 10):
        out = []
        for i in range(M.shape[0]):
            row = []
            for j in range(M.shape[1]):
                e = M[i, j].xreplace(subs) if exact is None else exact[i * M.shape[1] + j]
                v = sp.N(e, digits + 10)
                if not (v.is_real and v.is_finite):
                    return None
                row.append(mpmath.mpf(v) * mpmath.mpf(float(scales[j])))
            norm = mpmath.norm(row)
            factor = mpmath.mpf(float(rows[i])) if rows[i] > 0 else (1 / norm if norm > 0 else mpmath.mpf(1))
            out.append([v * factor for v in row])
        S = mpmath.matrix(out)
        sv = sorted((abs(v) for v in mpmath.svd_r(S, compute_uv=False)), reverse=True)
        # entries correct to `digits` significant digits (SymPy's evalf), the SVD at digits + 10
        eta = mpmath.mpf(10) ** (2 - digits) * mpmath.sqrt(M.shape[0] * M.shape[1])
        return tuple(float(v) for v in sv), float(eta)


def observability_rank(
    fields: AffineFields, region: Box | None = None, *, samples: int = 32, seed: int = 0, max_order: int | None = None
) -> int | None:
    """Generic rank of the codistribution spanned by ``dL_f^k h_j`` (``k < n``), ``None`` when undecided.

    The rank of :func:`observability_rank_evidence` (scaled matrix, tolerance from the evaluation's
    rounding error; see there for the rule and the evidence).

    Examples
    --------
    The shipped Isidori example has ``n = 4`` but rank 3: ``x3`` enters neither ``h = x4`` nor the
    other rows of ``f``.

    >>> import nlobs
    >>> from nlobs.geometry.observability import AffineFields
    >>> observability_rank(AffineFields.from_model(nlobs.load_model("isidori-146")))
    3
    >>> observability_rank(AffineFields.from_model(nlobs.load_model("pendulum")))
    2
    """
    return observability_rank_evidence(fields, region, samples=samples, seed=seed, max_order=max_order).rank


def default_multi_index(fields: AffineFields, region: Box | None = None, *, seed: int = 0) -> tuple[int, ...]:
    """Observability indices: add ``dL_f^k h_j`` in the order ``k = 0, 1, …`` (outputs in turn) while the
    rank at a random point of the region grows and output ``j`` has not stalled; ``Σ s_j`` is the
    generic rank (``= n`` for a drift-observable model). SISO: ``s = (n,)``.

    The rows are scaled as in :func:`observability_rank_evidence` (columns by the state scales, each
    row by its largest norm on the region); a row is added when the smallest singular value of the scaled rows chosen so
    far and the candidate exceeds ``RANK_GAP_FACTOR`` times their error bound ``η``.

    Examples
    --------
    The shipped Duffing oscillator driven through an actuator (``y1 = x1``, ``y2 = x4``): ``x1``
    and its first two derivatives see ``x1, x2, x3``, then ``x4`` completes the rank, so
    ``s = (3, 1)``, and ``Q_s`` is nonsingular (``det Q_s = 1``).

    >>> import nlobs
    >>> from nlobs.geometry.observability import AffineFields
    >>> fields = AffineFields.from_model(nlobs.load_model("duffing-actuator"))
    >>> s = default_multi_index(fields)
    >>> s, check_drift_observability(fields, s).passed
    ((3, 1), True)
    >>> default_multi_index(AffineFields.from_model(nlobs.load_model("pendulum")))  # one output: (n,)
    (2,)
    """
    if fields.q == 1:
        return (fields.n,)
    reg = region or Box.unit(fields.n)
    pt = reg.sample(1, seed)
    rows_by_output = [list(range(j * fields.n, (j + 1) * fields.n)) for j in range(fields.q)]
    scd = _ScaledCodistribution.for_fields(fields, [fields.n] * fields.q, reg, tidied=False)
    S, E = scd.scaled(pt, reg)
    s = [0] * fields.q
    active = [True] * fields.q
    chosen: list[int] = []
    for k in range(fields.n):
        for j in range(fields.q):
            if not active[j] or len(chosen) == fields.n:
                continue
            cand = chosen + [rows_by_output[j][k]]
            if S is not None and _independent(S[cand], E[cand]):
                chosen, s[j] = cand, s[j] + 1
            else:
                active[j] = False
    return tuple(s)


def _independent(S: Array, E: Array) -> bool:
    """The rows of the scaled ``S`` are independent: ``σ_min > RANK_GAP_FACTOR · η`` (``E`` the error bounds)."""
    sv = np.linalg.svd(S, compute_uv=False)
    eta = float(np.linalg.norm(E)) + 4 * max(S.shape) * UNIT_ROUNDOFF * float(sv[0])
    return bool(sv[-1] > RANK_GAP_FACTOR * eta)
