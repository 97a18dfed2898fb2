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

import numpy as np
import sympy as sp
from scipy.optimize import minimize

from nlobs._typing import Array
from nlobs.checks import Check, CheckKind
from nlobs.geometry.lie import SIMPLIFY_OPS_LIMIT, lie_bracket, tidy
from nlobs.geometry.observability import (
    AffineFields,
    check_multi_index,
    lie_map,
    observability_jacobian,
    reduced_observability_matrix,
)
from nlobs.geometry.pinv import symbolic_pinv
from nlobs.geometry.region import Box, format_point
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.expressions import as_sympy_expr, as_sympy_matrix


#: Largest ``Q_s`` (rows) whose determinant is computed symbolically.
SYMBOLIC_DET_MAX_N = 4
#: A matrix is called (numerically) singular where ``σ_min ≤ RANK_RTOL · max(1, σ_max)``: an observer
#: that inverts it would amplify by more than ``1/RANK_RTOL`` there.
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
        res = minimize(lambda z: float(_sigma_min(fn, z[None, :])[0]), pts[i], method="L-BFGS-B", bounds=bounds,
                       options={"maxiter": 200})
        if res.fun < best:
            best_pt, best = np.clip(res.x, region.lower, region.upper), float(res.fun)
    return best_pt, best


def check_full_rank(name: str, what: str, M: sp.MatrixBase, fields: AffineFields, reg: Box, samples: int = 256,
                    seed: int = 0, *, det: sp.Expr | None = None, phrase: str | None = None) -> Check:
    """Full row rank of ``M(x)`` on the region, with the worst point.

    A sign change of ``det`` (square case) between two sampled points proves a singular point on the
    segment between them (intermediate values; located by bisection; ``method="intermediate value"``).
    Otherwise ``σ_min`` at sampled points, refined by a bounded local minimisation from the worst ones;
    singular where ``σ_min ≤ RANK_RTOL · max(1, σ_max)``. ``phrase`` words a failure (default
    "``what`` loses rank").
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
    fn = compile_matrix(as_sympy_matrix("M", M), (tuple(fields.x),), what=what)
    sv = _sigma_min(fn, pts)
    pt, worst = _refine(fn, pts, sv, reg)
    holds = bool(worst > RANK_RTOL * max(1.0, float(np.max(sv))))
    ev = (f"σ_min({what}) ≥ {worst:.3g} on {reg.describe()} ({samples} sampled points and local minimisation), "
          f"smallest at x = {format_point(pt)}" if holds
          else f"{phrase or what + ' loses rank'} at x = {format_point(pt)} (σ_min = {worst:.3g})")
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
    """
    s_ = check_multi_index(s, fields.q, fields.n)
    reg = region or Box.unit(fields.n)
    Q = observability_jacobian(fields, s_)
    det = None
    if fields.n <= SYMBOLIC_DET_MAX_N:
        det = sp.factor(tidy(Q.det(method="berkowitz")))
        if det.is_number:
            holds = bool(det != 0)
            return Check.verdict("drift-observability", holds,
                                 f"det Q_s = {det} (constant): " + ("Q_s is nonsingular everywhere" if holds
                                                                    else "Q_s is singular everywhere"),
                                 kind=CheckKind.RANK, method="symbolic", value=float(abs(det)), symbolic=str(det))
    return check_full_rank("drift-observability", "Q_s", Q, fields, reg, samples, seed, det=det)


def check_a1(fields: AffineFields, r: Sequence[int], region: Box | None = None, *, samples: int = 256, seed: int = 0) -> Check:
    """Röbenack A1 (second part): the rows ``dh, …, dL_f^{r−1} h`` of ``Q`` are linearly independent."""
    r_ = check_multi_index(r, fields.q)
    reg = region or Box.unit(fields.n)
    Q = reduced_observability_matrix(fields, r_)
    if Q.shape[0] > fields.n:
        return Check.verdict("A1 (independent dL_f^k h)", False,
                             f"Σ r_j = {Q.shape[0]} covectors dL_f^k h in ℝ^{fields.n} cannot be independent",
                             kind=CheckKind.RANK, method="structural")
    det = sp.factor(tidy(Q.det(method="berkowitz"))) if Q.shape[0] == Q.shape[1] <= SYMBOLIC_DET_MAX_N else None
    return check_full_rank("A1 (independent dL_f^k h)", "Q", Q, fields, reg, samples, seed, det=det,
                           phrase="dh, …, dL_f^(r−1) h are dependent")


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
    """``s ≤ r`` componentwise (Dalla Mora, Germani & Manes Theorems 2.9, 3.4); an undefined ``r_j`` is infinite."""
    ok = all(rj is None or sj <= rj for sj, rj in zip(s, r))
    rt = ["∞" if v is None else str(v) for v in r]
    return Check.verdict("s ≤ r", ok,
                         f"s = ({', '.join(map(str, s))}), r = ({', '.join(rt)}): "
                         + ("s ≤ r, (2.17) is solvable for every (α, μ, γ) (Thm 2.9)" if ok
                            else "s ≰ r: the input bound μ must be small enough (Thm 2.7)"),
                         kind=CheckKind.STRUCTURAL, method="structural")


def observability_rank(
    fields: AffineFields, region: Box | None = None, *, samples: int = 32, seed: int = 0, max_order: int | None = None
) -> int:
    """Generic rank of the codistribution spanned by ``dL_f^k h_j`` (``k < n``): its largest rank at sampled points."""
    reg = region or Box.unit(fields.n)
    kmax = fields.n if max_order is None else int(max_order)
    M = lie_map(fields, [kmax] * fields.q).jacobian(sp.Matrix(fields.x))
    fn = compile_matrix(M, (tuple(fields.x),), what="observability codistribution")
    with np.errstate(all="ignore"):
        vals = fn(reg.sample(samples, seed))
    vals = vals[np.all(np.isfinite(vals), axis=(-2, -1))]
    if len(vals) == 0:
        return 0
    sv = np.linalg.svd(vals, compute_uv=False)
    tol = RANK_RTOL * np.maximum(1.0, sv[:, :1])
    return int(np.max(np.sum(sv > tol, axis=-1)))


def default_multi_index(fields: AffineFields, region: Box | None = None, *, seed: int = 0) -> tuple[int, ...]:
    """Observability indices: add ``dL_f^k h_j`` in the order ``k = 0, 1, …`` (outputs in turn) while the
    rank at a random point of the region grows and output ``j`` has not stalled; ``Σ s_j`` is the
    generic rank (``= n`` for a drift-observable model). SISO: ``s = (n,)``."""
    if fields.q == 1:
        return (fields.n,)
    reg = region or Box.unit(fields.n)
    pt = reg.sample(1, seed)
    chains = lie_map(fields, [fields.n] * fields.q)
    rows_by_output = [list(range(j * fields.n, (j + 1) * fields.n)) for j in range(fields.q)]
    J = chains.jacobian(sp.Matrix(fields.x))
    vals = compile_matrix(J, (tuple(fields.x),), what="codistribution")(pt)[0]
    s = [0] * fields.q
    active = [True] * fields.q
    basis = np.zeros((0, fields.n))
    for k in range(fields.n):
        for j in range(fields.q):
            if not active[j] or basis.shape[0] == fields.n:
                continue
            cand = np.vstack([basis, vals[rows_by_output[j][k]]])
            sv = np.linalg.svd(cand, compute_uv=False)
            if np.sum(sv > RANK_RTOL * max(1.0, sv[0])) > basis.shape[0]:
                basis, s[j] = cand, s[j] + 1
            else:
                active[j] = False
    return tuple(s)
