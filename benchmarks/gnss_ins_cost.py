"""Cost per step of the GNSS/INS observer (24) against the EKF baseline, with accuracy beside it.

Grip, Saberi & Johansen (Sec. 5) motivate observer (24) by its "lower computational
complexity than the EKF". This script measures it on the demo scenario (traffic-pattern flight, IMU
+ magnetometer at 100 Hz, GNSS p, v at 5 Hz with noise, 60° initial yaw error):

* **single flight** (batch 1): the wall time inside the filter's ``correct`` + ``step``
  per IMU step (``info["cost_per_step_us"]`` of the run), as an embedded loop would run it. The observer runs with its
  default ``kernel="auto"``, which takes the fused scalar kernel for one flight
  (:mod:`nlobs.navigation.split_kernel`); for reference the row
  ``observer[batched]`` runs the same flight through the vectorised NumPy path
  (``kernel="batched"``, the only path before the scalar kernel existed);
* **batched** (``--batch`` noise realisations, default 1000, shorter flight):
  the same per flight-step, where NumPy's per-call overhead is amortised and the
  arithmetic dominates.

Both filters run on the same data in the same process; each measurement is
repeated ``--repeat`` times and the best is kept (machines are shared). The
target is a ratio EKF / observer ≥ 3. The EKF
(:mod:`nlobs.navigation.ekf`) is the library's NumPy implementation, vectorised over
the batch like the observer, with a fused single-flight path of its own (``kernel="auto"``;
``benchmarks/ekf_cost.py`` compares it with plain NumPy and filterpy EKFs; see
``docs/navigation.md`` for what that means for the comparison).

Run ``python benchmarks/gnss_ins_cost.py [--json] [--duration S] [--batch B]``.
"""

from __future__ import annotations

import argparse
import json
import platform

import numpy as np

from nlobs.workflows.demo import DEMO_NOISE
from nlobs.navigation.ekf import EkfConfig, ExtendedKalmanFilter
from nlobs.navigation.gains import PAPER_GAMMA, paper_gains
from nlobs.navigation import metrics
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation.run import run_navigation
from nlobs.navigation.sensors import generate_sensors
from nlobs.navigation.so3 import rot_z
from nlobs.navigation.trajectory import traffic_pattern
from nlobs.simulate import SimulationResult

TARGET = 3.0


def _filters(flight, single: bool):  # type: ignore[no-untyped-def]
    obs = GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n)
    ekf = ExtendedKalmanFilter(EkfConfig.for_noise(DEMO_NOISE), flight.m_n, flight.g_n)
    out = {"observer": obs, "ekf": ekf}
    if single:
        out["observer[batched]"] = GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n,
                                                   kernel="batched")
    return out


def _cost(r: SimulationResult) -> float:
    return float(r.info["cost_per_step_us"])


def _best(filt, data, p0, v0, R0, repeat: int) -> SimulationResult:  # type: ignore[no-untyped-def]
    runs = [run_navigation(filt, data, p0, v0, R0) for _ in range(repeat)]
    return min(runs, key=_cost)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=120.0, help="single-flight length [s]")
    ap.add_argument("--batch", type=int, default=1000, help="noise realisations in the batched run")
    ap.add_argument("--batch-duration", type=float, default=10.0, help="flight length of the batched run [s]")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    rows = {}
    for mode, duration, batch in (("single", args.duration, None), ("batched", args.batch_duration, args.batch)):
        flight = traffic_pattern(seed=args.seed, duration=duration)
        traj = flight.sample(100.0)
        data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=DEMO_NOISE, seed=args.seed,
                                batch=batch)
        R0 = rot_z(np.deg2rad(60.0)) @ traj.R[0]
        p0, v0 = traj.p[0] + 2.0, traj.v[0]
        res = {name: _best(f, data, p0, v0, R0, args.repeat) for name, f in _filters(flight, batch is None).items()}
        rows[mode] = {
            name: {
                "cost_per_step_us": _cost(r),
                "position_rms_m": float(np.mean(metrics.position_rms_m(r, after=20.0 if duration > 40 else duration / 2))),
                "attitude_rms_deg": float(np.mean(metrics.attitude_rms_deg(r, after=20.0 if duration > 40 else duration / 2))),
                "converge_s": float(np.nanmean(metrics.converge_s(r, 5.0))),
            }
            for name, r in res.items()
        }
        rows[mode]["ratio_ekf_over_observer"] = _cost(res["ekf"]) / _cost(res["observer"])
        if "observer[batched]" in res:
            rows[mode]["ratio_ekf_over_observer_batched_kernel"] = (_cost(res["ekf"])
                                                                    / _cost(res["observer[batched]"]))
        rows[mode]["batch"] = batch or 1
        rows[mode]["steps"] = int(traj.t.size - 1)

    out = {"machine": platform.processor() or platform.machine(), "python": platform.python_version(),
           "target_ratio": TARGET, **rows}
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print("GNSS/INS cost per IMU step (per flight), observer (24) vs EKF, same data, best of "
          f"{args.repeat}")
    print(f"{'mode':8s} {'batch':>6s} {'filter':17s} {'µs/step':>9s} {'pos RMS m':>10s} {'att RMS °':>10s} "
          f"{'conv. s':>8s}")
    for mode in ("single", "batched"):
        r = rows[mode]
        for name in ("observer", "observer[batched]", "ekf"):
            if name not in r:
                continue
            m = r[name]
            print(f"{mode:8s} {r['batch']:6d} {name:17s} {m['cost_per_step_us']:9.2f} {m['position_rms_m']:10.3f} "
                  f"{m['attitude_rms_deg']:10.3f} {m['converge_s']:8.2f}")
        ratio = r["ratio_ekf_over_observer"]
        verdict = "meets" if ratio >= TARGET else "MISSES"
        print(f"{mode:8s} ratio EKF/observer = {ratio:.2f}x ({verdict} the target of {TARGET:g}x)")
        if "ratio_ekf_over_observer_batched_kernel" in r:
            print(f"{mode:8s} (with the batched NumPy kernel for the single flight: "
                  f"{r['ratio_ekf_over_observer_batched_kernel']:.2f}x)")


if __name__ == "__main__":
    main()
