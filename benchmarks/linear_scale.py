"""Linear analysis at scale: nlobs against SLICOT (through slycot) on random stable systems.

For ``n = 5, 50, 100, 200`` states (``m = p = 2``), one seeded random stable system per size
(Gaussian ``A`` shifted left of the imaginary axis, Gaussian ``B``, ``C``, ``D = 0``), printed per
operation: the nlobs time, the slycot time and their ratio, with the target ratio beside it.

* observability — :func:`nlobs.linear.is_observable` against ``slycot.tb01pd(job='O')``
  (the observability staircase, order of the observable part);
* unobservable modes — :func:`nlobs.linear.unobservable_modes` against ``slycot.ab01nd`` on the
  dual pair ``(Aᵀ, Cᵀ)`` followed by the eigenvalues of the uncontrollable block;
* H∞ norm — :func:`nlobs.linear.hinf_norm` with ``method="bruinsma-steinbuch"`` (nlobs's own
  algorithm, the slycot fast path off) against ``slycot.ab13dd`` (``tol = 1e−9``);
* invariant zeros — :func:`nlobs.linear.invariant_zeros` against ``slycot.ab08nd`` + QZ;
* for ``n ≥ 20``, unobservable modes of a pair with ``n/5`` planted hidden modes, where the
  staircase cannot decide and the eigenvalue-based test runs (no target; the count found by
  each beside it).

The targets (≤ 3× slycot) apply to observability and unobservable modes at every size and to
the H∞ norm at ``n = 50`` and ``200``; the other rows print "—".

Timings are noisy on a shared machine, so each ratio is measured in one run with the two
implementations interleaved, and each time is the minimum over ``k`` repetitions (fewer at
``n = 200``), with one BLAS thread (``OPENBLAS_NUM_THREADS=1`` unless set). Values are checked to agree. Needs slycot (a test extra); without it the
benchmark prints a message and exits 0.

Run ``python benchmarks/linear_scale.py [--sizes 5 50 100 200]`` (a few minutes).
"""

from __future__ import annotations

import argparse
import inspect
import math
import os
import sys
import time

# One BLAS thread for both sides: on a shared machine a multithreaded BLAS oversubscribes the
# cores and the timings (of both libraries) become meaningless.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

try:
    import slycot  # noqa: E402
except ImportError:  # pragma: no cover - depends on the environment
    slycot = None

import nlobs.linear as lin  # noqa: E402

TARGET = 3.0


def system(n: int, seed: int, m: int = 2, p: int = 2):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) / math.sqrt(n)
    A -= (np.max(np.linalg.eigvals(A).real) + 0.1) * np.eye(n)
    return A, rng.standard_normal((n, m)), rng.standard_normal((p, n)), np.zeros((p, m))


def hidden_system(n: int, seed: int, p: int = 2):
    """A pair with ``n // 5`` exactly unobservable modes (a Kalman decomposition behind an orthogonal similarity)."""
    rng = np.random.default_rng(seed + 1)
    nu = n // 5
    no = n - nu
    A = np.zeros((n, n))
    A[:no, :no] = rng.standard_normal((no, no)) / math.sqrt(no)
    A[no:, :no] = rng.standard_normal((nu, no))
    A[no:, no:] = rng.standard_normal((nu, nu)) / math.sqrt(nu) - 0.5 * np.eye(nu)
    C = np.zeros((p, n))
    C[:, :no] = rng.standard_normal((p, no))
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    return Q.T @ A @ Q, C @ Q, nu


def _has_target(name: str, n: int) -> bool:
    """Rows with a target: observability and unobservable modes at every n ≤ 200, H∞ at n = 50 and 200."""
    if name in ("observability", "unobservable modes"):
        return True
    return name == "H∞ norm" and n in (50, 200)


def slycot_observable_order(A, C):
    n, p = A.shape[0], C.shape[0]
    B = np.zeros((n, max(1, p)))
    _, _, _, nr = slycot.tb01pd(n, 1, p, A.copy(), B, C.copy(), job="O", equil="N")
    return nr


def slycot_unobservable(A, C):
    n, p = A.shape[0], C.shape[0]
    Ac, _, ncont, *_ = slycot.ab01nd(n, p, A.T.copy(), C.T.copy())
    return np.linalg.eigvals(Ac[ncont:, ncont:])


def slycot_hinf(A, B, C, D):
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    g, _ = slycot.ab13dd("C", "I", "N", "Z", n, m, p, A, np.eye(n), B, C, D, tol=1e-9)
    return g


def slycot_zeros(A, B, C, D):
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    out = slycot.ab08nd(n, m, p, A, B, C, D, equil="N")
    nu, Af, Bf = out[0], out[-2], out[-1]
    if nu == 0:
        return np.zeros(0)
    import scipy.linalg

    return scipy.linalg.eigvals(Af[:nu, :nu], Bf[:nu, :nu])


def nlobs_hinf(A, B, C, D):
    if "method" in inspect.signature(lin.hinf_norm).parameters:
        return lin.hinf_norm(A, B, C, D, method="bruinsma-steinbuch")
    return lin.hinf_norm(A, B, C, D)


def timed(f, *args):
    t0 = time.perf_counter()
    out = f(*args)
    return time.perf_counter() - t0, out


def compare(f_nl, f_sl, args, reps):
    t_nl, t_sl = math.inf, math.inf
    out_nl = out_sl = None
    for _ in range(reps):
        t, out_nl = timed(f_nl, *args)
        t_nl = min(t_nl, t)
        t, out_sl = timed(f_sl, *args)
        t_sl = min(t_sl, t)
    return t_nl, t_sl, out_nl, out_sl


def fmt(t: float) -> str:
    return f"{t * 1e3:9.2f} ms" if t < 1 else f"{t:9.2f} s "


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[5, 50, 100, 200])
    ap.add_argument("--reps", type=int, default=5)
    args = ap.parse_args(argv)
    if slycot is None:
        print("linear_scale: slycot is not installed (pip install nlobs[test]); benchmark skipped.")
        return 0
    print(f"nlobs vs slycot {slycot.__version__}: min of k interleaved repetitions; ratio = nlobs / slycot, "
          f"target ≤ {TARGET:g}×")
    head = f"{'n':>4} {'operation':<20} {'nlobs':>12} {'slycot':>12} {'ratio':>9}  target  agree"
    print(head)
    print("-" * len(head))
    for n in args.sizes:
        reps = max(1, args.reps if n <= 100 else args.reps // 2)
        A, B, C, D = system(n, seed=n)
        rows = []

        t_nl, t_sl, o_nl, o_sl = compare(lambda A, C: lin.is_observable(A, C), slycot_observable_order, (A, C), reps)
        rows.append(("observability", t_nl, t_sl, f"nlobs {o_nl}, slycot order {o_sl}/{n}"))

        t_nl, t_sl, o_nl, o_sl = compare(lambda A, C: lin.unobservable_modes(A, C), slycot_unobservable, (A, C), reps)
        rows.append(("unobservable modes", t_nl, t_sl, f"nlobs {o_nl.size}, slycot {o_sl.size}"))

        t_nl, t_sl, o_nl, o_sl = compare(nlobs_hinf, slycot_hinf, (A, B, C, D), max(1, reps if n <= 50 else 2))
        rel = abs(o_nl - o_sl) / o_sl
        rows.append(("H∞ norm", t_nl, t_sl, f"rel. diff {rel:.1e}"))

        t_nl, t_sl, o_nl, o_sl = compare(lambda *a: lin.invariant_zeros(*a).zeros, slycot_zeros, (A, B, C, D), reps)
        rows.append(("invariant zeros", t_nl, t_sl, f"nlobs {np.size(o_nl)}, slycot {np.size(o_sl)}"))

        if n >= 20:  # where the staircase cannot decide: a planted unobservable part (no target)
            Ah, Ch, nu = hidden_system(n, seed=n)
            t_nl, t_sl, o_nl, o_sl = compare(lambda A, C: lin.unobservable_modes(A, C), slycot_unobservable,
                                             (Ah, Ch), max(1, reps // 2))
            rows.append((f"  {nu} planted hidden", t_nl, t_sl, f"nlobs {o_nl.size}, slycot {o_sl.size} (of {nu})"))

        for name, t_nl, t_sl, agree in rows:
            ratio = t_nl / t_sl
            if _has_target(name, n):
                ok = "ok" if ratio <= TARGET else "MISS"
                tgt = f"≤{TARGET:g}× {ok:<4}"
            else:
                tgt = f"{'—':<8}"
            print(f"{n:>4} {name:<20} {fmt(t_nl)} {fmt(t_sl)} {ratio:8.1f}×  {tgt}  {agree}")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
