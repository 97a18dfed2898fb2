"""Cost of the drift-observability observer (Dalla Mora, Germani & Manes): symbolic set-up and compiled run time.

Models: chains of Duffing oscillators ``p̈_k = −p_k − p_k³ − 0.2 ṗ_k + c (p_{k−1} − 2p_k + p_{k+1})``
(free ends), ``y = p_1``, the input on the last oscillator (through a first-order
actuator state when ``n`` is odd), ``n = 2 … 8``, ``s = (n)``.

Printed per ``n``:

* set-up: Lie derivatives ``Φ_s`` (``L_f^k h``, k < n), ``Q_s = ∂Φ_s/∂x``, and compiling
  ``f, g, h, Q_s`` into one batched NumPy function (``DriftObserver.from_fields``);
* run time of one observer right-hand side (3.1) — compiled, for one state and for a
  batch of 1000 — against the naive way: SymPy ``subs``/``evalf`` of the same
  ``f, g, h, Q_s`` at one point, then ``numpy.linalg.solve``; the ratios are
  naive/compiled per evaluation (single) and per state (batch).

Run: ``python benchmarks/drift_observer.py`` (about a minute).
"""

from __future__ import annotations

import time

import numpy as np
import sympy as sp

from nlobs.geometry import AffineFields, observability_jacobian, observability_map
from nlobs.observers.drift import DriftObserver
from nlobs.synthesis.drift_gain import vandermonde_gain
from nlobs.systems.symbolic import SymbolicModel

COUPLING = 0.5


def chain(n: int) -> SymbolicModel:
    """``n // 2`` coupled Duffing oscillators (+ one actuator state when ``n`` is odd)."""
    k = n // 2
    states = [f"{v}{i + 1}" for i in range(k) for v in ("p", "v")] + (["a"] if n % 2 else [])
    X = {s: sp.Symbol(s, real=True) for s in states}
    f, g = [], []
    for i in range(k):
        p, v = X[f"p{i + 1}"], X[f"v{i + 1}"]
        left = X[f"p{i}"] if i > 0 else p
        right = X[f"p{i + 2}"] if i + 1 < k else p
        acc = -p - p**3 - sp.Rational(1, 5) * v + COUPLING * (left - 2 * p + right)
        last = i == k - 1
        if last and n % 2:
            acc += X["a"]
        f += [v, acc]
        g += [0, 1 if last and not n % 2 else 0]
    if n % 2:
        f.append(-X["a"])
        g.append(1)
    return SymbolicModel.input_affine(states, ["u"], ["y"], f=f, g=[[e] for e in g], h=[X["p1"]], name=f"duffing-chain-{n}")


def _time(fn, reps: int) -> float:
    fn()
    t0 = time.perf_counter()
    for _ in range(reps):
        fn()
    return (time.perf_counter() - t0) / reps


def main() -> None:
    rng = np.random.default_rng(0)
    print(f"{'n':>2} {'Φ_s [s]':>9} {'Q_s [s]':>9} {'compile [s]':>11} {'ops(Q_s)':>9} | {'single [µs]':>11} "
          f"{'batch/state [µs]':>16} {'naive [ms]':>10} {'ratio single':>12} {'ratio batch':>11}")
    for n in range(2, 9):
        model = chain(n)
        t0 = time.perf_counter()
        fields = AffineFields.from_model(model)
        Phi = observability_map(fields, (n,))
        t1 = time.perf_counter()
        Q = observability_jacobian(fields, (n,))
        t2 = time.perf_counter()
        obs = DriftObserver.from_fields(fields, (n,), vandermonde_gain((n,), 3.0).K)
        t3 = time.perf_counter()
        ops = int(sum(sp.count_ops(e) for e in Q))
        assert Phi.shape == (n, 1)
        x1 = 0.3 * rng.normal(size=n)
        xb = 0.3 * rng.normal(size=(1000, n))
        u1, ub = np.array([0.1]), np.full((1000, 1), 0.1)
        y1, yb = np.array([0.2]), np.full((1000, 1), 0.2)
        single = _time(lambda: obs.rhs(0.0, x1, u1, y1), 200)
        batch = _time(lambda: obs.rhs(0.0, xb, ub, yb), 20) / 1000
        # naive: the same expressions through SymPy subs/evalf at one point
        K = obs.K
        ents = list(fields.f) + list(fields.g) + list(fields.h) + list(Q)

        def naive() -> np.ndarray:
            sub = dict(zip(fields.x, x1))
            v = np.array([float(e.subs(sub).evalf()) for e in ents])
            f_ = v[:n]
            g_ = v[n : 2 * n]
            h_ = v[2 * n : 2 * n + 1]
            Q_ = v[2 * n + 1 :].reshape(n, n)
            return f_ + g_ * u1[0] + np.linalg.solve(Q_, K @ (y1 - h_))

        reps = 3 if n >= 6 else 10
        t_naive = _time(naive, reps)
        np.testing.assert_allclose(naive(), obs.rhs(0.0, x1, u1, y1), rtol=1e-8, atol=1e-10)
        print(f"{n:>2} {t1 - t0:>9.3f} {t2 - t1:>9.3f} {t3 - t2:>11.3f} {ops:>9d} | {single * 1e6:>11.1f} "
              f"{batch * 1e6:>16.2f} {t_naive * 1e3:>10.2f} {t_naive / single:>12.0f} {t_naive / batch:>11.0f}")


if __name__ == "__main__":
    main()
