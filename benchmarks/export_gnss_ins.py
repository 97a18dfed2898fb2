"""Cost per IMU step of the GNSS/INS observer (24) in generated C against its fused Python kernel.

One recorded flight of the demo scenario (traffic pattern, IMU + magnetometer at 100 Hz, GNSS p, v
at 5 Hz with noise, 60° initial yaw error), the paper's gains, measured in one run:

* **C loop**: :meth:`~nlobs.export.compiled.CompiledObserver.run_record` of
  :func:`~nlobs.export.compile_observer` — the whole flight in one call of the generated ``P_run``
  (correction at the fixes, the split step, the raw estimate recorded), divided by the number of
  IMU instants;
* **Python, loop**: :func:`~nlobs.navigation.run.run_navigation` of the Python observer, whose single
  flight takes the fused scalar kernel (:mod:`nlobs.navigation.split_kernel`):
  ``info["cost_per_step_us"]`` (the time inside ``correct`` and ``step``);
* **Python, kernel only**: a bare loop of :func:`~nlobs.navigation.split_kernel.split_step` over the
  same IMU record (no state objects, no loop bookkeeping: the kernel's arithmetic alone).

Each is repeated ``--repeat`` times and the best is kept (machines are shared); the C estimates are
checked against the Python run (1e-12 relative) before anything is printed. Targets: the C loop at
most 1 µs per step and at least 15× faster than the fused Python kernel (the loop's cost).

Run ``python benchmarks/export_gnss_ins.py [--json] [--duration S] [--repeat N]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

from nlobs.export import compile_observer
from nlobs.navigation import metrics
from nlobs.navigation.gains import PAPER_GAMMA, paper_gains
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation.run import run_navigation
from nlobs.navigation.sensors import generate_sensors
from nlobs.navigation.so3 import rot_z
from nlobs.navigation.split_kernel import split_step
from nlobs.navigation.trajectory import traffic_pattern
from nlobs.workflows.demo import DEMO_NOISE

TARGET_US = 1.0
TARGET_RATIO = 15.0
RATE = 100.0


def _kernel_loop(obs: GnssInsObserver, u: np.ndarray, t: np.ndarray, R0: np.ndarray) -> float:
    """Seconds of a bare ``split_step`` loop over the record (with injection throughout)."""
    rows = u.tolist()
    hs = np.diff(t).tolist()
    L = [0.0] * 15
    R = R0.ravel().tolist()
    k = obs._scalar
    flows = {}
    for h in set(hs):
        flows[h] = obs._scalar_flows(0.5 * h)[0]
    t0 = time.perf_counter()
    for row, h in zip(rows, hs):
        L, R, _ = split_step(k, flows[h], h, L, R, row[0:3], row[3:6], row[6:9])
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=120.0, help="flight length [s] (at least 60)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    duration = max(float(args.duration), 60.0)

    flight = traffic_pattern(seed=args.seed, duration=duration)
    traj = flight.sample(RATE)
    data = generate_sensors(traj, imu_rate_hz=RATE, gnss_rate_hz=5.0, noise=DEMO_NOISE, seed=args.seed)
    R0 = rot_z(np.deg2rad(60.0)) @ traj.R[0]
    p0, v0 = traj.p[0] + 2.0, traj.v[0]
    obs = GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n)
    cobs = compile_observer(obs)

    t, u, y, sampled = data.record()
    x0 = np.concatenate([p0, v0, R0.ravel()])

    c_s, py_us, kern_s = [], [], []
    py = raw = None
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        raw = cobs.run_record(t, x0, u=u, y=y, sampled=sampled)
        c_s.append(time.perf_counter() - t0)
        py = run_navigation(obs, data, p0, v0, R0)
        py_us.append(float(py.info["cost_per_step_us"]))
        kern_s.append(_kernel_loop(obs, u, t, R0))
    assert py is not None and raw is not None
    worst = max(float(np.linalg.norm(a - b) / np.linalg.norm(b)) for a, b in (
        (raw[:, 0:3], metrics.p_hat(py)), (raw[:, 3:6], metrics.v_hat(py)),
        (raw[:, 6:15].reshape(-1, 3, 3), py.extras["R_raw"])))
    if not worst < 1e-12:
        raise SystemExit(f"the C estimates differ from the Python run by {worst:.3g} (relative)")

    K = t.size
    c_us = min(c_s) / K * 1e6
    loop_us = min(py_us)
    kernel_us = min(kern_s) / (K - 1) * 1e6
    out = {
        "machine": platform.processor() or platform.machine(), "python": platform.python_version(),
        "steps": int(K), "duration_s": float(t[-1] - t[0]), "repeat": args.repeat,
        "c_run_record_us_per_step": c_us, "python_loop_us_per_step": loop_us,
        "python_kernel_us_per_step": kernel_us,
        "ratio_python_loop_over_c": loop_us / c_us, "ratio_python_kernel_over_c": kernel_us / c_us,
        "max_relative_difference": worst, "target_us": TARGET_US, "target_ratio": TARGET_RATIO,
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"GNSS/INS observer (24), paper's gains: cost per IMU step of one flight "
          f"({K} steps, {out['duration_s']:g} s at {RATE:g} Hz), best of {args.repeat}")
    print(f"{'path':40s} {'µs/step':>9s} {'× C':>7s}")
    print(f"{'C, run_record (one call)':40s} {c_us:9.3f} {1.0:7.1f}")
    print(f"{'Python fused kernel, run_navigation':40s} {loop_us:9.3f} {loop_us / c_us:7.1f}")
    print(f"{'Python fused kernel, bare split_step':40s} {kernel_us:9.3f} {kernel_us / c_us:7.1f}")
    ok_us = "meets" if c_us <= TARGET_US else "MISSES"
    ok_ratio = "meets" if loop_us / c_us >= TARGET_RATIO else "MISSES"
    print(f"C: {c_us:.3f} µs/step ({ok_us} the target of {TARGET_US:g} µs); "
          f"ratio Python loop / C = {loop_us / c_us:.1f}x ({ok_ratio} the target of {TARGET_RATIO:g}x); "
          f"bare kernel / C = {kernel_us / c_us:.1f}x")
    print(f"C estimates vs Python run: {worst:.2g} relative (largest of p, v, raw R)")


if __name__ == "__main__":
    main()
