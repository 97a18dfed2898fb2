"""Generated C against the Python observers of the shipped models, and what generation costs.

Two measurements, each in one run of this script (machines are shared: ratios, best of ``--repeat``):

* **step cost** — one run (a single state, the case of an embedded loop) of ``--steps`` RK4 steps on
  a recorded noisy output: the Python observer through :func:`nlobs.simulate.run_observer` (its
  compiled-NumPy right-hand side, four calls per step; ``info["cost_per_step_us"]``, the time inside
  the observer only) against the generated C, the whole record in one ``P_run`` call
  (:meth:`nlobs.export.CompiledObserver.run_record`), wall time divided by the steps. Target: C ≥ 50×
  for the drift observer (3.1) of Dalla Mora, Germani & Manes and Röbenack's observer (7); the constant
  gain, the EKF and the UKF of the pendulum are shown beside them (a correction at every step).
* **generation + compilation** — from the observer object to a loaded library, with an empty
  library cache: :func:`nlobs.export.generate`, :func:`~nlobs.export.render`, the compiler, ``dlopen``.
  Target ≤ 5 s per shipped model's observer. The Zig toolchain builds its own C runtime once per
  machine (seconds, on the first compilation ever); the script compiles a one-line file first so that
  cost is shown on its own line and not charged to a model.

Run ``python benchmarks/export_speed.py [--steps K] [--repeat R] [--json]``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
import uuid

import numpy as np

from nlobs.export import compile_observer, find_compiler
from nlobs.export.compiler import build_shared
from nlobs.geometry import Box
from nlobs.observers.drift import DriftObserver
from nlobs.observers.ekf import EKF
from nlobs.observers.ukf import UKF
from nlobs.observers.luenberger import ConstantGainObserver
from nlobs.observers.pinv import PinvObserver
from nlobs.simulate import run_observer
from nlobs.simulate.integrators import rk4_step
from nlobs.synthesis.drift_gain import vandermonde_gain
from nlobs.synthesis.pinv_gain import HighGain
from nlobs.systems.modelfile import load_model


def _cases():
    duff = load_model("duffing-actuator")
    isi = load_model("isidori-146")
    pend = load_model("pendulum")
    box = Box.around(np.zeros(4), 1.0)
    return [
        ("drift (3.1), duffing-actuator", duff, lambda: DriftObserver.from_model(duff, vandermonde_gain((3, 1), 3.0).K)),
        ("drift (3.1) saturated, duffing-actuator", duff,
         lambda: DriftObserver.from_model(duff, vandermonde_gain((3, 1), 3.0).K, saturation=box)),
        ("Röbenack (7), isidori-146", isi, lambda: PinvObserver.from_model(isi, k=HighGain(3.0))),
        ("constant gain, pendulum", pend, lambda: ConstantGainObserver(pend.compile(), np.array([[4.0], [6.0]]))),
        ("EKF, pendulum", pend, lambda: EKF(pend.compile(), np.eye(2) * 1e-4, np.eye(1) * 1e-6, np.eye(2) * 0.1)),
        ("UKF, pendulum", pend, lambda: UKF(pend.compile(), np.eye(2) * 1e-4, np.eye(1) * 1e-6, np.eye(2) * 0.1)),
    ]


def _record(model, K: int, dt: float, seed: int = 0):
    plant = model.compile()
    m = len(plant.inputs)
    t = dt * np.arange(K)
    U = np.full((K, m), 0.1)
    x = np.full(len(plant.states), 0.2)
    xs = np.empty((K, x.size))
    for k in range(K):
        xs[k] = x
        x = rk4_step(lambda tt, xx, uk=U[k]: plant.rhs(tt, xx, uk), t[k], x, dt)
    Y = plant.output(0.0, xs, U) + 1e-3 * np.random.default_rng(seed).standard_normal((K, len(plant.outputs)))
    return t, U, Y


def step_costs(steps: int, repeat: int) -> list[dict]:
    rows = []
    for label, model, make in _cases():
        obs = make()
        co = compile_observer(obs)
        t, U, Y = _record(model, steps, 0.002)
        xh0 = np.zeros(obs.n_x)
        py = min(run_observer(obs, t, x_hat0=xh0, u=U, y=Y).info["cost_per_step_us"] for _ in range(repeat))
        best = np.inf
        for _ in range(max(repeat, 3)):
            tic = time.perf_counter()
            xc = co.run_record(t, xh0, u=U, y=Y)
            best = min(best, time.perf_counter() - tic)
        c_us = best / steps * 1e6
        ref = run_observer(obs, t, x_hat0=xh0, u=U, y=Y).x_hat
        rows.append({"observer": label, "python_us": py, "c_us": c_us, "ratio": py / c_us,
                     "max_rel_diff": float(np.max(np.abs(xc - ref)) / np.max(np.abs(ref)))})
    return rows


def generation_costs() -> tuple[float, list[dict]]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["NLOBS_CACHE"] = tmp
        tic = time.perf_counter()
        build_shared(f"double nlobs_warm(double x) {{ return x; }} /* {uuid.uuid4().hex} */\n")
        warm = time.perf_counter() - tic
        for label, _model, make in _cases():
            obs = make()
            tic = time.perf_counter()
            # a fresh token in the header: the compiler's own cache (Zig keeps one) cannot serve this source
            compile_observer(obs, prefix="gen_" + str(len(rows)), notes=(("build", uuid.uuid4().hex),))
            rows.append({"observer": label, "seconds": time.perf_counter() - tic})
        del os.environ["NLOBS_CACHE"]
    return warm, rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    cc = find_compiler()
    warm, gen = generation_costs()
    rows = step_costs(a.steps, a.repeat)
    if a.json:
        print(json.dumps({"compiler": cc.describe(), "first_compile_s": warm, "generation": gen, "steps": rows}, indent=2))
        return
    print(f"compiler: {cc.describe()} ({cc.label}); its first compilation in an empty cache: {warm:.2f} s")
    print("\ngeneration + compilation + load, empty library cache (target ≤ 5 s):")
    for r in gen:
        print(f"  {r['observer']:<42} {r['seconds']:6.2f} s  {'ok' if r['seconds'] <= 5.0 else 'NOT met'}")
    print(f"\none run, {a.steps} steps (Python: run_observer, time inside the observer; C: one P_run call):")
    print(f"  {'observer':<42} {'Python µs':>10} {'C µs':>8} {'ratio':>8}  {'max rel diff':>12}")
    for r in rows:
        checked = r["observer"].startswith(("drift", "Röbenack"))  # the targets of the script's docstring
        target = " (target ≥ 50×: " + ("met)" if r["ratio"] >= 50 else "NOT met)") if checked else ""
        print(f"  {r['observer']:<42} {r['python_us']:10.2f} {r['c_us']:8.3f} {r['ratio']:7.0f}×  "
              f"{r['max_rel_diff']:12.2e}{target}")


if __name__ == "__main__":
    main()
