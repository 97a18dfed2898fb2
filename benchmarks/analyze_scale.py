"""``nlobs analyze`` on Duffing chains and polynomial chains: seconds, which parts were numeric, the target.

A polynomial chain of n states: ẋ_i = x_{i+1} − x_i − x_i³/5 + x_{i−1} x_i, ẋ_n = … + u, y = x_1.
A Duffing chain of N oscillators (2N states): q̈_i = −q_i − q_i³ + (q_{i−1} − 2 q_i + q_{i+1})/2, the
input on the last one, y = q_1. Target: each analysis within 10 s (the optional symbolic parts within
the default symbolic budget of 5 s, else evaluated numerically and named).
"""

from __future__ import annotations

import sys
import time

import sympy as sp

from nlobs.systems.symbolic import SymbolicModel
from nlobs.workflows.analyze import analyze_model

TARGET_S = 10.0


def poly_chain(n: int) -> SymbolicModel:
    xs = sp.symbols(f"x1:{n + 1}")
    f = [(xs[i + 1] if i + 1 < n else 0) - xs[i] - xs[i] ** 3 / 5 + (xs[i - 1] * xs[i] if i else 0) for i in range(n)]
    return SymbolicModel.input_affine([str(s) for s in xs], ["u"], ["y"], f, [[0]] * (n - 1) + [[1]], [xs[0]],
                                      name=f"poly-chain-{n}")


def duffing_chain(N: int) -> SymbolicModel:
    names = [f"{a}{i + 1}" for i in range(N) for a in ("q", "v")]
    sy = sp.symbols(names)
    q, v = sy[0::2], sy[1::2]
    f = []
    for i in range(N):
        c = (q[i - 1] - q[i] if i else 0) + (q[i + 1] - q[i] if i + 1 < N else 0)
        f += [v[i], -q[i] - q[i] ** 3 + sp.Rational(1, 2) * c]
    return SymbolicModel.input_affine(names, ["u"], ["y"], f, [[0]] * (2 * N - 1) + [[1]], [q[0]],
                                      name=f"duffing-chain-{N}")


def main(sizes: tuple[int, ...] = (3, 5, 7, 9)) -> None:
    print(f"{'model':<18} {'states':>6} {'seconds':>8} {'target':>7}  numeric parts")
    for build in (poly_chain, duffing_chain):
        for n in sizes:
            m = build(n)
            t = time.perf_counter()
            try:
                d = analyze_model(m).to_dict()
                parts = ", ".join(d.get("numeric_parts") or []) or "none (all symbolic)"
            except Exception as exc:  # a refused model is a row of the table, not the end of it
                parts = f"refused: {type(exc).__name__}"
            dt = time.perf_counter() - t
            ok = "ok" if dt <= TARGET_S else "SLOW"
            print(f"{m.name:<18} {m.n:>6} {dt:>8.2f} {TARGET_S:>5.0f} s  {parts}  [{ok}]", flush=True)


if __name__ == "__main__":
    main(tuple(int(a) for a in sys.argv[1:]) or (3, 5, 7, 9))
