"""Observer-gain synthesis at scale: ``design_observer_gain`` (central objective, LMIs (14), (15)) for n = 4 … 100.

The targets: ``n = 50`` in at most 5 s and ``n = 100`` in at most 30 s, with at most 2 GB peak memory, the
certificate re-verified as always (every LMI block with the returned ``P``, the spectrum, ``‖H‖∞`` and
``‖G‖∞`` recomputed with ``nlobs.linear.hinf_norm``).

Each size runs in its own subprocess (so the peak resident memory, ``resource.getrusage(...).ru_maxrss``,
is that design's and includes the process's own ~0.2 GB of Python, NumPy, SciPy and CVXPY), on a dense
random system: ``A`` with i.i.d. N(0, 1/n) entries (about half its eigenvalues unstable), ``p = n/5``
outputs, ``m = n/10`` disturbances, ``N = I``, ``γ = γn = 40``.

* **auto** — ``method="auto"``: the H∞ filter Riccati equation here (Grip, Saberi & Johansen's (14)–(15)
  in Riccati form; ``docs/synthesis.md``, "The Riccati path").
* **sdp** — ``method="sdp"``: the analytic centre of the LMIs by Clarabel, timed only for ``n ≤ 20`` (at
  ``n = 30`` it already takes minutes on a shared 2-core machine; beyond, its estimated memory is printed).

Printed: seconds and peak memory per size with the target beside it, the SDP's time and the ratio, and
both gains' ``‖H‖∞``. BLAS runs with one thread in the subprocesses (``--blas-threads``): on a loaded
machine a multi-threaded BLAS was measured 5–10× slower on these 200 × 200 eigenproblems.

``--old SRC`` runs the same measurement on another checkout's ``src`` (no ``method`` argument: the code
before the Riccati path) for the before/after table.

Run ``python benchmarks/synthesis_scale.py [--json] [--sizes 4,10,20,50,100] [--sdp-max 20] [--old SRC]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

TARGET_SECONDS = {50: 5.0, 100: 30.0}
TARGET_MB = 2000.0
GAMMA = 40.0


def system(n: int) -> tuple[Any, Any, Any]:
    import numpy as np

    rng = np.random.default_rng(1000 + n)
    A = rng.standard_normal((n, n)) / np.sqrt(n)
    p, m = max(1, n // 5), max(1, n // 10)
    C = 2.0 * rng.standard_normal((p, n)) / np.sqrt(n)
    Bd = rng.standard_normal((n, m)) / np.sqrt(m)
    return A, C, Bd


def one(n: int, method: str) -> dict[str, Any]:
    """Run one design in this process and report it (the child side)."""
    from nlobs.synthesis.observer_gain import design_observer_gain

    A, C, Bd = system(n)
    base_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    kw = {} if method == "old" else {"method": method}
    t = time.perf_counter()
    out: dict[str, Any] = {"n": n, "method": method}
    try:
        cert = design_observer_gain(A, C, Bd, gamma=GAMMA, gamma_n=GAMMA, **kw)
        out.update(ok=bool(cert.verified), hinf_H=cert.hinf_H, hinf_G=cert.hinf_G,
                   path=getattr(getattr(cert, "method", None), "value", "sdp"))
    except Exception as exc:  # noqa: BLE001 - reported, not handled
        out.update(ok=False, error=f"{type(exc).__name__}: {str(exc)[:300]}")
    out["seconds"] = time.perf_counter() - t
    out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    out["base_mb"] = base_mb
    return out


def run(n: int, method: str, src: str, timeout: float, threads: int) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=src)
    for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env[k] = str(threads)
    cmd = [sys.executable, __file__, "--child", str(n), method]
    t = time.perf_counter()
    try:
        res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return {"n": n, "method": method, "ok": False, "error": f"not finished within {timeout:g} s",
                "seconds": time.perf_counter() - t, "peak_mb": None}
    lines = [ln for ln in res.stdout.splitlines() if ln.startswith("{")]
    if res.returncode != 0 or not lines:
        return {"n": n, "method": method, "ok": False, "seconds": time.perf_counter() - t, "peak_mb": None,
                "error": f"exit {res.returncode}: {res.stderr.strip().splitlines()[-1:] or ''}"}
    return json.loads(lines[-1])


def sdp_estimate_mb(n: int, src: str) -> float | None:
    """The refusal estimate of the SDP at size n (new code only)."""
    sys.path.insert(0, src)
    try:
        from nlobs.synthesis import observer_gain as og
        from nlobs.synthesis.certificate import Objective
    except ImportError:
        return None
    if not hasattr(og, "sdp_estimate"):
        return None
    A, C, Bd = system(n)
    return og.sdp_estimate(A, C, Bd, gamma_n=GAMMA, objective=Objective.CENTRAL).memory_bytes / 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--sizes", default="4,10,20,50,100")
    ap.add_argument("--sdp-max", type=int, default=20, help="time the SDP only up to this n")
    ap.add_argument("--old", default=None, help="src folder of the code before the Riccati path")
    ap.add_argument("--timeout", type=float, default=300.0)
    ap.add_argument("--blas-threads", type=int, default=1)
    ap.add_argument("--child", nargs=2, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(one(int(args.child[0]), args.child[1])))
        return
    here = str(Path(__file__).resolve().parents[1] / "src")
    sizes = [int(s) for s in args.sizes.split(",")]
    rows = []
    for n in sizes:
        if args.old:
            auto = run(n, "old", args.old, args.timeout, args.blas_threads)
            sdp = None
        else:
            auto = run(n, "auto", here, args.timeout, args.blas_threads)
            sdp = run(n, "sdp", here, args.timeout, args.blas_threads) if n <= args.sdp_max else None
        est = None if args.old else sdp_estimate_mb(n, here)
        rows.append({"n": n, "auto": auto, "sdp": sdp, "sdp_estimate_mb": est,
                     "target_seconds": TARGET_SECONDS.get(n), "target_mb": TARGET_MB})
    if args.json:
        print(json.dumps(rows, indent=2))
        return
    label = "old code (SDP)" if args.old else "auto"
    print(f"design_observer_gain, central objective, γ = γn = {GAMMA:g}, BLAS threads {args.blas_threads}")
    print(f"{'n':>4} | {label:>14} s | peak MB | target s | target MB | met | path    | ‖H‖∞    | "
          f"sdp s   | sdp/auto | sdp ‖H‖∞ | sdp est. MB")
    all_met = True
    for r in rows:
        a, s = r["auto"], r["sdp"]
        tgt = r["target_seconds"]
        met = a.get("ok") and (tgt is None or a["seconds"] <= tgt) and (a["peak_mb"] or 1e99) <= TARGET_MB
        all_met = all_met and bool(met)
        err = "" if a.get("ok") else f"  [{a.get('error', 'not verified')}]"
        sdp_s = f"{s['seconds']:7.2f}" if s and s.get("ok") else ("   -   " if s is None else " failed")
        ratio = f"{s['seconds'] / a['seconds']:8.1f}" if s and s.get("ok") and a.get("ok") else "    -   "
        sdp_h = f"{s['hinf_H']:8.4g}" if s and s.get("ok") else "    -   "
        est = f"{r['sdp_estimate_mb']:10.0f}" if r["sdp_estimate_mb"] is not None else "    -     "
        peak = f"{a['peak_mb']:7.0f}" if a.get("peak_mb") else "   -   "
        hh = f"{a['hinf_H']:7.4g}" if a.get("ok") else "   -   "
        print(f"{r['n']:>4} | {a['seconds']:16.2f} | {peak} | {tgt if tgt else '-':>8} | {TARGET_MB:9.0f} | "
              f"{'yes' if met else 'NO ':3} | {a.get('path', '-'):7} | {hh} | {sdp_s} | {ratio} | {sdp_h} | "
              f"{est}{err}")
    print("all targets met" if all_met else "some targets NOT met (see the rows marked NO)")


if __name__ == "__main__":
    main()
