"""Design speed of the seed-004 set-valued observer: one compiled problem vs rebuilding it per point.

Example 6.1 (flexible-joint robot, Class II with Lemma 2.14's γ):

* **sound design** (:func:`nlobs.synthesis.setvalued.design_setvalued`): the LMI (⋆) is compiled once
  with ``λ`` a ``cp.Parameter``; bisection for the smallest feasible ``λ`` then a golden-section search.
  Baseline: a uniform ``λ`` grid that rebuilds the CVXPY problem at every point.
* **Theorem 5.10 as printed** (:func:`nlobs.synthesis.setvalued_printed.design_printed`): compiled once,
  ``α`` line search × coarse ``ε`` grid + refinement. Baseline: the same 95 coarse ``(α, ε₁ = ε₂)``
  points, rebuilding the problem per point.

Both run in one process on the same machine; the best of ``--repeat`` is kept. Reported: wall time,
number of solves and the objective reached (the baseline must reach the same value to 1 %).

Run ``python benchmarks/setvalued_design.py [--json] [--repeat R] [--points N]``.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from nlobs.errors import DesignInfeasible
from nlobs.examples.khajenejad_yong import example_61
from nlobs.synthesis import setvalued as sv
from nlobs.synthesis.lmi import Solver
from nlobs.synthesis.setvalued_printed import design_printed


def _sound(system) -> tuple[float, int, float]:  # type: ignore[no-untyped-def]
    t = time.perf_counter()
    d = sv.design_setvalued(system)
    return time.perf_counter() - t, d.solves, d.steady_radius


def _sound_naive(system, points: int) -> tuple[float, int, float]:  # type: ignore[no-untyped-def]
    dyn = sv.error_dynamics(system)
    t = time.perf_counter()
    best = math.inf
    for lv in np.linspace(0.90, 1 - 1e-6, points):
        pb = sv._build(system, dyn, sv.SetValuedObjective.RADIUS, 1e-7)  # rebuilt every time
        sol = sv._solve_at(pb, float(lv), Solver.CLARABEL, None, dyn.Xic.shape[0], dyn.n)
        if sol is not None:
            P_min = float(np.linalg.eigvalsh(sol.P)[0])
            best = min(best, math.sqrt(sv._cost(system, sol) / ((1 - lv) * P_min)))
    return time.perf_counter() - t, points, best


def _printed(system, M) -> tuple[float, int, float]:  # type: ignore[no-untyped-def]
    t = time.perf_counter()
    d = design_printed(system, M)
    return time.perf_counter() - t, d.solves, d.rho


def _printed_naive(system, M) -> tuple[float, int, float]:  # type: ignore[no-untyped-def]
    pts = [(0.05 * i, e) for i in range(1, 20) for e in (0.01, 0.1, 1.0, 10.0, 100.0)]
    t = time.perf_counter()
    best = math.inf
    for a, e in pts:
        try:  # one call = one freshly built problem solved at a single (α, ε1 = ε2) point
            best = min(best, design_printed(system, M, alphas=[a], eps_grid=(e,), refine=0).rho)
        except DesignInfeasible:
            pass
    return time.perf_counter() - t, len(pts), best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--points", type=int, default=60, help="λ grid points of the rebuilt baseline")
    args = ap.parse_args()
    system = example_61("II").system
    A = system.A
    M = np.block([[-np.eye(4), A], [A.T, -A.T @ A]])
    rows = {}
    for name, fn in (("sound: compiled once", lambda: _sound(system)),
                     ("sound: rebuilt per λ point", lambda: _sound_naive(system, args.points)),
                     ("printed Thm 5.10: compiled once", lambda: _printed(system, M)),
                     ("printed Thm 5.10: rebuilt per point", lambda: _printed_naive(system, M))):
        runs = [fn() for _ in range(max(1, args.repeat))]
        sec, n, val = min(runs, key=lambda r: r[0])
        rows[name] = {"seconds": round(sec, 3), "solves": n, "objective": val}
    if args.json:
        print(json.dumps(rows, indent=2))
        return
    for k, v in rows.items():
        print(f"{k:40s} {v['seconds']:8.3f} s  {v['solves']:4d} solves  objective {v['objective']:.6g}")
    s, n = rows["sound: compiled once"], rows["sound: rebuilt per λ point"]
    print(f"sound: speed-up {n['seconds'] / s['seconds']:.1f}x, objective ratio {n['objective'] / s['objective']:.4f}")
    p, q = rows["printed Thm 5.10: compiled once"], rows["printed Thm 5.10: rebuilt per point"]
    print(f"printed: speed-up {q['seconds'] / p['seconds']:.1f}x, objective ratio {q['objective'] / p['objective']:.4f}")


if __name__ == "__main__":
    main()
