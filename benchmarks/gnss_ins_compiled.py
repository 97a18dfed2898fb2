"""Observer (24) against the navigation EKF, both as generated C: Grip, Saberi & Johansen's cost claim, compiled.

Grip, Saberi & Johansen (Sec. 5) motivate observer (24) by its lower computational cost than an EKF.
``gnss_ins_cost.py`` measures it in Python, where NumPy's per-call overhead blurs it; here both filters run
as their generated, compiled C (:func:`nlobs.export.compile_observer`), each over the whole recorded flight in
one call of its ``P_run`` (:meth:`~nlobs.export.compiled.CompiledObserver.run_record`): the demo scenario
(traffic pattern, IMU + magnetometer at 100 Hz, GNSS p, v at 5 Hz with noise, 60° initial yaw error), the
observer with the paper's gains, the EKF tuned to the sensors (the demo's baseline).

The EKF's C is the filter of :mod:`nlobs.navigation.ekf` as a textbook implementation writes it (dense
9 × 9 products with fixed sizes: about 3 800 multiply-adds per IMU step, the prediction ``Φ P Φᵀ`` and the
magnetometer's Joseph update each about 1 500); the observer's is its fused split step (per-axis blocks,
Rodrigues' formula, the TRIAD injection).

Before anything is timed, each compiled filter's estimates are checked against its Python original on the
same flight (1e-12 relative). Then the two run interleaved (EKF, observer, EKF, …), ``--repeat`` rounds,
CPU time (``time.process_time``), and the best round of each is kept (machines are shared). Target: the
observer at least 5× cheaper per IMU step than the EKF.

Run ``python benchmarks/gnss_ins_compiled.py [--json] [--duration S] [--repeat N]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

from nlobs.export import compile_observer
from nlobs.methods.gnss_ins import DemoConfig, demo_ekf
from nlobs.navigation import metrics
from nlobs.navigation.gains import PAPER_GAMMA, paper_gains
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation.run import run_navigation
from nlobs.navigation.sensors import generate_sensors
from nlobs.navigation.so3 import rot_z
from nlobs.navigation.trajectory import traffic_pattern
from nlobs.workflows.demo import DEMO_NOISE

TARGET = 5.0
RATE = 100.0


def _worst(raw: np.ndarray, py) -> float:  # type: ignore[no-untyped-def]
    """Largest relative difference of the C run's p, v and raw R from the Python run's."""
    R_py = py.extras["R_raw"] if "R_raw" in py.extras else metrics.R_hat(py)
    return max(float(np.linalg.norm(a - b) / np.linalg.norm(b)) for a, b in (
        (raw[:, 0:3], metrics.p_hat(py)), (raw[:, 3:6], metrics.v_hat(py)), (raw[:, 6:15].reshape(-1, 3, 3), R_py)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=120.0, help="flight length [s] (at least 30)")
    ap.add_argument("--repeat", type=int, default=21, help="interleaved rounds (the best of each is kept)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    duration = max(float(args.duration), 30.0)

    flight = traffic_pattern(seed=args.seed, duration=duration)
    traj = flight.sample(RATE)
    data = generate_sensors(traj, imu_rate_hz=RATE, gnss_rate_hz=5.0, noise=DEMO_NOISE, seed=args.seed)
    R0 = rot_z(np.deg2rad(60.0)) @ traj.R[0]
    p0, v0 = traj.p[0] + 2.0, traj.v[0]
    filters = {"EKF": demo_ekf(DemoConfig(), flight),
               "observer (24)": GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n)}
    compiled = {name: compile_observer(f) for name, f in filters.items()}
    t, u, y, sampled = data.record()
    x0 = np.concatenate([p0, v0, R0.ravel()])

    worst = {}
    for name, f in filters.items():
        raw = compiled[name].run_record(t, x0, u=u, y=y, sampled=sampled)
        worst[name] = _worst(raw, run_navigation(f, data, p0, v0, R0))
        if not worst[name] < 1e-12:
            raise SystemExit(f"{name}: the C estimates differ from the Python run by {worst[name]:.3g} (relative)")

    best = dict.fromkeys(compiled, float("inf"))
    for _ in range(args.repeat):
        for name, c in compiled.items():
            t0 = time.process_time()
            c.run_record(t, x0, u=u, y=y, sampled=sampled)
            best[name] = min(best[name], time.process_time() - t0)
    K = t.size
    us = {name: s / K * 1e6 for name, s in best.items()}
    ratio = us["EKF"] / us["observer (24)"]
    out = {"machine": platform.processor() or platform.machine(), "python": platform.python_version(),
           "steps": int(K), "duration_s": float(t[-1] - t[0]), "repeat": args.repeat,
           "ekf_c_us_per_step": us["EKF"], "observer_c_us_per_step": us["observer (24)"],
           "ratio_ekf_over_observer": ratio, "max_relative_difference": worst, "target": TARGET,
           "met": bool(ratio >= TARGET)}
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"GNSS/INS, both filters as generated C: CPU time per IMU step of one flight ({K} steps, "
          f"{out['duration_s']:g} s at {RATE:g} Hz), best of {args.repeat} interleaved rounds")
    print(f"{'filter':32s} {'µs/step':>9s} {'C vs Python':>12s}")
    for name in compiled:
        print(f"{name + ' [C]':32s} {us[name]:9.3f} {worst[name]:12.1e}")
    verdict = "met" if ratio >= TARGET else "NOT met"
    print(f"EKF / observer (24) = {ratio:.2f}x (target >= {TARGET:g}x: {verdict})")


if __name__ == "__main__":
    main()
