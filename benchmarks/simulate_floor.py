"""``nlobs simulate MODEL`` against NumPy's floor: the plant and N observers against N + 1 plain RK4 loops of the plant.

The comparison engine of ``nlobs simulate MODEL`` (:func:`nlobs.methods.comparison.compare_observers`) designs
each observer and runs it on the same noisy, sampled Monte Carlo runs of the plant (the plant integrated once and
its samples replayed to each observer, or, with exact outputs, integrated with each). The floor is the cheapest
loop that does the plant's share of that work: the compiled plant (the same generated NumPy code) integrated by
RK4 over the same steps for the same number of runs, one batched call per stage, nothing else. Target (everyday
speed): the CPU time of the simulations of the N observers (their designs excluded, timed apart) within 3 × (N + 1)
times that floor, for one run and for 50 runs. Then the same with ``--backend c`` (``backend="c"``): the plant's ``f``
and every observer with a C generator stepped by their generated C (one ctypes call per step for the batch), against
the same NumPy floor.

Both are timed in CPU time (``time.process_time``), interleaved: each simulation is followed at once by a floor
loop of the same runs and steps, and counted in those floors (so a slow spell of a shared machine slows both);
the ratio sums each part's best of ``ROUNDS`` rounds. The simulations are timed
inside the comparison (each call it makes of the loop: :func:`~nlobs.simulate.loop.simulate`, or the plant's one run,
:func:`~nlobs.simulate.loop.simulate_plant`, and each observer on it, :func:`~nlobs.simulate.loop.observe`), so the
designs, the metrics and the report are left out and printed apart.

Run: ``PYTHONPATH=src python benchmarks/simulate_floor.py [MODEL] [--duration S]`` (a few minutes for the
cartpole's 20 s at 1 ms).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import nlobs.methods.comparison as comparison
from nlobs.methods.problem import symbolic_model
from nlobs.simulate import rk4_step

ROUNDS = 5
TARGET = 3.0


def floor(plant, runs: int, steps: int, dt: float, x0: np.ndarray) -> float:  # type: ignore[no-untyped-def]
    """CPU seconds of ``steps`` RK4 steps of the compiled plant for ``runs`` runs (a sine input, held)."""
    x = np.broadcast_to(x0, (runs, plant.n)).copy() if runs > 1 else x0.copy()
    u = np.zeros((runs, plant.m) if runs > 1 else (plant.m,))
    c = time.process_time()
    for k in range(steps):
        u[...] = np.sin(np.pi * k * dt)
        x = rk4_step(lambda t, xx: plant.rhs(t, xx, u), k * dt, x, dt)
    return time.process_time() - c


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("model", nargs="?", default="cartpole")
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the file's)")
    args = ap.parse_args()
    plant = symbolic_model(args.model).compile()
    parts: list[tuple[str, float, float]] = []  # (what ran, its CPU seconds, the floor's right after it)
    grid: dict[str, float] = {}

    def timed(name: str, inner):  # type: ignore[no-untyped-def]
        def call(*a, **k):  # type: ignore[no-untyped-def]
            if "duration" in k:  # simulate_plant and simulate name the grid; observe replays the plant's
                grid["steps"], grid["dt"] = round(k["duration"] / k["dt"]), k["dt"]
            label = (("plant [C]" if hasattr(a[0], "step_stages") else "plant") if name == "simulate_plant"
                     else getattr(a[1], "name", type(a[1]).__name__))
            c = time.process_time()
            try:
                return inner(*a, **k)
            finally:
                spent = time.process_time() - c
                fl = floor(plant, grid["runs"], int(grid["steps"]), grid["dt"], np.zeros(plant.n))
                parts.append((label, spent, fl))
        return call

    for name in ("simulate", "simulate_plant", "observe"):  # the comparison's own calls of the loop, in CPU time
        if hasattr(comparison, name):  # (an older nlobs, measured for a note, has simulate alone)
            setattr(comparison, name, timed(name, getattr(comparison, name)))
    print(f"nlobs simulate {args.model}: CPU time of the plant's run and the N observers' simulations, each against "
          f"a plain batched RK4 loop of the plant timed right after it; best of {ROUNDS} interleaved rounds")
    print(f"{'backend':>7} {'runs':>5} {'N':>2} {'steps':>7} {'floor [s]':>10} {'simulations [s]':>16} {'× (N+1) floor':>14} "
          f"{'designs etc. [s]':>17}  target ≤ {TARGET:g}   each part in floors")
    ok = True
    for backend, runs in (("python", 1), ("python", 50), ("c", 1), ("c", 50)):
        grid["runs"] = runs
        best: dict[str, float] = {}
        cost: dict[str, float] = {}  # each part in floors (its time over the adjacent floor's), best round
        for _ in range(ROUNDS):
            parts.clear()
            c = time.process_time()
            rep = comparison.compare_observers(args.model, runs=runs, duration=args.duration, progress=False,
                                               backend=backend)
            total = time.process_time() - c
            d = rep.to_dict()
            n_obs = sum(1 for v in d["observers"].values() if not v.get("skipped"))
            steps = int(round(d["duration"] / d["dt"]))
            sim = sum(p[1] for p in parts)
            floors = sum(p[2] for p in parts)
            for label, spent, fl in parts:
                cost[label] = min(cost.get(label, np.inf), spent / fl)
            for key, val in (("sim", sim), ("floor", min(p[2] for p in parts)), ("rest", total - sim - floors)):
                best[key] = min(best.get(key, np.inf), val)
        ratio = sum(cost.values()) / (n_obs + 1)
        ok &= ratio <= TARGET
        each = ", ".join(f"{k} {v:.2f}" for k, v in cost.items())
        print(f"{backend:>7} {runs:>5} {n_obs:>2} {steps:>7} {best['floor']:>10.3f} {best['sim']:>16.3f} {ratio:>14.2f} "
              f"{best['rest']:>17.3f}   {each}")
    print("target: " + ("met" if ok else "MISSED"))


if __name__ == "__main__":
    main()
