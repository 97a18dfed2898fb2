"""Cost of the EKF and UKF of nlobs: batched against one run at a time, and against filterpy.

Two measurements, each repeated ``--repeat`` times with the alternatives interleaved (so that a
change of machine load hits both), in CPU time (``time.process_time``: a shared machine's load changes it far less
than the wall clock); the table shows medians and the median of the per-repeat ratios.

* **batch vs loop** — the flexible-joint robot (4 states, ``sin`` of the link angle; Raghavan &
  Hedrick's parameters) compiled from SymPy, continuous time, both motor outputs sampled at every
  step of ``dt = 1 ms``. One step is what the loop does at a sample: ``correct`` then one RK4 step of
  ``rhs``. *Batched*: one state of ``--runs`` members (default 1000); *loop*: the same filter object
  on ``--runs`` single-run states, one after the other. Reported: the cost of one step of one run
  (µs) and the ratio loop / batched.
* **nlobs EKF vs filterpy** — a discrete linear model (3 states, 2 outputs, 1 input), one run:
  ``correct`` + ``rhs`` of :class:`nlobs.EKF` (called directly, as the loop calls them) against
  ``update`` + ``predict`` of ``filterpy.kalman.KalmanFilter`` and of
  ``filterpy.kalman.ExtendedKalmanFilter`` (with the Jacobian and output functions of the same model).
  Reported: µs per step and the ratio nlobs / filterpy (below 1: nlobs is faster).

The single-run path of nlobs is written for this comparison: ``ndarray.dot`` instead of ``@`` on 2-d
matrices (``@`` costs about three times as much on 3 × 3), a closed-form ``S⁻¹`` for one or two fresh
outputs, ``S⁻¹ ν`` shared by the gain and the NIS, the plant's constant ``A`` and ``C`` returned without
broadcasting, and Python-level checks of the few fresh values.

Run ``python benchmarks/kalman_baselines.py`` (``filterpy`` from the ``test`` extra).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter, KalmanFilter

from nlobs import EKF, UKF, Discrete, LinearSystem
from nlobs.simulate import rk4_step
from nlobs.systems.symbolic import SymbolicModel

# Flexible-joint robot (Raghavan & Hedrick 1994; Rajamani 1998).
PARAMS = {"Jm": 3.7e-3, "Jl": 9.3e-3, "mass": 0.21, "hh": 0.15, "k": 0.18, "bv": 4.6e-2, "kt": 8e-2, "g": 9.8}


def flexible_joint():  # type: ignore[no-untyped-def]
    """The robot as a compiled symbolic model (its Jacobians compiled once)."""
    return SymbolicModel.general(
        ["th_m", "om_m", "th_l", "om_l"], ["tau"], ["y_th", "y_om"],
        ["om_m", "(k/Jm)*(th_l - th_m) - (bv/Jm)*om_m + (kt/Jm)*tau",
         "om_l", "-(k/Jl)*(th_l - th_m) - (mass*g*hh/Jl)*sin(th_l)"],
        ["th_m", "om_m"], parameters=PARAMS, name="flexible joint").compile()


def _step_cost(filt, z, u, y, fresh, dt, steps):  # type: ignore[no-untyped-def]
    t0 = time.process_time()
    for k in range(steps):
        t = k * dt
        z = filt.correct(t, z, u, y, fresh)
        z = rk4_step(lambda tt, zz: filt.rhs(tt, zz, u, y), t, z, dt)
    return time.process_time() - t0


def batch_vs_loop(runs: int, steps: int, repeat: int) -> dict[str, dict[str, float]]:
    plant = flexible_joint()
    Q, R, P0 = 1e-3 * np.eye(4), np.diag([1e-4, 1e-3]), 0.1 * np.eye(4)
    rng = np.random.default_rng(7)
    x0 = rng.uniform(-0.5, 0.5, size=(runs, 4))
    u = np.array([0.2])
    y = x0[:, :2] + 0.01 * rng.standard_normal((runs, 2))
    fresh = np.ones(2, dtype=bool)
    out = {}
    for filt in (EKF(plant, Q, R, P0), UKF(plant, Q, R, P0)):
        zb = filt.init(x0)
        singles = [filt.init(x0[b]) for b in range(runs)]
        _step_cost(filt, zb, u, y, fresh, 1e-3, 2)  # warm-up
        batched, loop = [], []
        for _ in range(repeat):
            batched.append(_step_cost(filt, zb, u, y, fresh, 1e-3, steps) / steps / runs)
            t0 = time.process_time()
            for b in range(runs):
                _step_cost(filt, singles[b], u, y[b], fresh, 1e-3, steps)
            loop.append((time.process_time() - t0) / steps / runs)
        out[filt.name] = {"batched_us": statistics.median(batched) * 1e6, "loop_us": statistics.median(loop) * 1e6,
                          "ratio": statistics.median(lp / bt for lp, bt in zip(loop, batched, strict=True))}
    return out


def versus_filterpy(steps: int, repeat: int) -> dict[str, float]:
    rng = np.random.default_rng(3)
    A = np.array([[0.95, 0.1, 0.0], [-0.1, 0.9, 0.1], [0.0, -0.1, 0.9]])
    B, C = rng.standard_normal((3, 1)), rng.standard_normal((2, 3))
    Q, R, P0 = 0.01 * np.eye(3), np.diag([0.1, 0.2]), np.eye(3)
    us = rng.standard_normal((steps, 1))
    ys = rng.standard_normal((steps, 2))
    ekf = EKF(LinearSystem(A, B, C, time=Discrete(0.1)), Q, R, P0)
    fresh = np.ones(2, dtype=bool)

    def run_nlobs() -> float:
        z = ekf.init(np.zeros(3))
        t0 = time.process_time()
        for k in range(steps):
            z = ekf.correct(0.1 * k, z, us[k], ys[k], fresh)
            z = ekf.rhs(0.1 * k, z, us[k], ys[k])
        return time.process_time() - t0

    def run_kf() -> float:
        kf = KalmanFilter(dim_x=3, dim_z=2, dim_u=1)
        kf.F, kf.B, kf.H, kf.Q, kf.R, kf.P, kf.x = A, B, C, Q, R, P0.copy(), np.zeros(3)
        t0 = time.process_time()
        for k in range(steps):
            kf.update(ys[k])
            kf.predict(u=us[k])
        return time.process_time() - t0

    def run_ekf() -> float:
        fp = ExtendedKalmanFilter(dim_x=3, dim_z=2, dim_u=1)
        fp.F, fp.B, fp.Q, fp.R, fp.P, fp.x = A, B, Q, R, P0.copy(), np.zeros(3)
        jac, hx = (lambda x: C), (lambda x: C @ x)
        t0 = time.process_time()
        for k in range(steps):
            fp.update(ys[k], jac, hx)
            fp.predict(u=us[k])
        return time.process_time() - t0

    times: dict[str, list[float]] = {"nlobs": [], "kf": [], "ekf": []}
    for fn in (run_nlobs, run_kf, run_ekf):
        fn()  # warm-up
    for _ in range(repeat):
        for name, fn in (("nlobs", run_nlobs), ("kf", run_kf), ("ekf", run_ekf)):
            times[name].append(fn() / steps)
    return {"nlobs_us": statistics.median(times["nlobs"]) * 1e6, "kf_us": statistics.median(times["kf"]) * 1e6,
            "ekf_us": statistics.median(times["ekf"]) * 1e6,
            "ratio_kf": statistics.median(a / b for a, b in zip(times["nlobs"], times["kf"], strict=True)),
            "ratio_ekf": statistics.median(a / b for a, b in zip(times["nlobs"], times["ekf"], strict=True))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=1000, help="Monte Carlo runs in the batch (default 1000)")
    ap.add_argument("--steps", type=int, default=3, help="filter steps per batch-vs-loop timing (default 3)")
    ap.add_argument("--fp-steps", type=int, default=2000, help="steps per filterpy comparison timing (default 2000)")
    ap.add_argument("--repeat", type=int, default=3, help="repetitions, interleaved (default 3)")
    args = ap.parse_args()
    wall = time.perf_counter()
    print(f"nlobs EKF/UKF cost; python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}")
    print(f"\n1) flexible-joint robot (n = 4, p = 2), correct + one RK4 step of rhs at dt = 1 ms, {args.runs} runs")
    print(f"{'filter':<8}{'batched [µs/run-step]':>24}{'loop [µs/run-step]':>22}{'loop / batched':>16}")
    for name, r in batch_vs_loop(args.runs, args.steps, args.repeat).items():
        print(f"{name:<8}{r['batched_us']:>24.2f}{r['loop_us']:>22.2f}{r['ratio']:>15.1f}x")
    fp = versus_filterpy(args.fp_steps, args.repeat)
    print("\n2) discrete linear model (n = 3, p = 2, m = 1), one run, update + predict per step")
    print(f"{'nlobs EKF (correct + rhs)':<44}{fp['nlobs_us']:>8.2f} µs")
    print(f"{'filterpy KalmanFilter (update + predict)':<44}{fp['kf_us']:>8.2f} µs")
    print(f"{'filterpy ExtendedKalmanFilter (update + predict)':<44}{fp['ekf_us']:>8.2f} µs")
    print(f"nlobs / filterpy KalmanFilter: {fp['ratio_kf']:.2f} (median of {args.repeat}); "
          f"nlobs / filterpy ExtendedKalmanFilter: {fp['ratio_ekf']:.2f}")
    print(f"\ntotal {time.perf_counter() - wall:.1f} s")


if __name__ == "__main__":
    main()
