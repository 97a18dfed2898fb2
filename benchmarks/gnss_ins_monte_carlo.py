"""Batched Monte Carlo of the GNSS/INS observer (24): flights·steps per second, batch axis vs a loop.

``--flights`` (default 1000) Monte Carlo flights of the same trajectory, each with
its own sensor-noise realisation and its own random initial attitude error (a
rotation about a uniformly random axis by an angle uniform in [0°, 90°]), run:

* **batched**: one :func:`run_navigation` call with all flights on the batch axis;
* **loop**: one call per flight; ``--loop-sample`` flights (default 20) are timed
  and the time is extrapolated linearly to all flights (each call costs the same).

Throughput is flights·steps per second, measured in the same run; the wall time
includes the loop's recording of the estimates (and the projection of the
observer's ``R̂`` onto SO(3), done once per run on the whole record), so the time
spent inside the observer (``info["observer_s"]``) is printed beside it. Also printed: the
fraction of flights whose attitude error ends below 5°.

Run ``python benchmarks/gnss_ins_monte_carlo.py [--json] [--flights N] [--duration S]``.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace

import numpy as np

from nlobs.workflows.demo import DEMO_NOISE
from nlobs.navigation.gains import PAPER_GAMMA, paper_gains
from nlobs.navigation import metrics
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation.run import run_navigation
from nlobs.navigation.sensors import generate_sensors
from nlobs.navigation.so3 import exp_so3
from nlobs.navigation.trajectory import traffic_pattern


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--flights", type=int, default=1000)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--loop-sample", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    rng = np.random.default_rng(args.seed)
    flight = traffic_pattern(seed=args.seed, duration=args.duration)
    traj = flight.sample(100.0)
    data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=DEMO_NOISE, seed=rng,
                            batch=args.flights)
    axis = rng.normal(size=(args.flights, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    angle = np.deg2rad(rng.uniform(0.0, 90.0, size=(args.flights, 1)))
    R0 = exp_so3(axis * angle) @ traj.R[0]
    obs = GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n)
    steps = traj.t.size - 1

    t0 = time.perf_counter()
    batched = run_navigation(obs, data, traj.p[0], traj.v[0], R0)
    t_batch = time.perf_counter() - t0

    n_loop = min(args.loop_sample, args.flights)
    t0 = time.perf_counter()
    for i in range(n_loop):
        di = replace(data, omega_b=data.omega_b[i], a_b=data.a_b[i], m_b=data.m_b[i], p_gnss=data.p_gnss[i],
                     v_gnss=data.v_gnss[i])
        run_navigation(obs, di, traj.p[0], traj.v[0], R0[i])
    t_loop = (time.perf_counter() - t0) / n_loop * args.flights

    final = metrics.attitude_error_deg(batched)[..., -1]
    inside = float(batched.info["observer_s"])
    out = {
        "flights": args.flights,
        "steps": steps,
        "batched_s": t_batch,
        "batched_filter_s": inside,
        "loop_s_extrapolated": t_loop,
        "loop_flights_timed": n_loop,
        "batched_flight_steps_per_s": args.flights * steps / t_batch,
        "loop_flight_steps_per_s": args.flights * steps / t_loop,
        "speedup": t_loop / t_batch,
        "fraction_converged_below_5deg": float(np.mean(final < 5.0)),
        "final_attitude_error_deg_max": float(np.max(final)),
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"GNSS/INS observer (24): {args.flights} Monte Carlo flights × {steps} IMU steps "
          f"({args.duration:g} s at 100 Hz), random initial attitude errors up to 90°")
    print(f"batched (1 call)      {t_batch:8.2f} s   {out['batched_flight_steps_per_s']:12.4g} flight·steps/s "
          f"({inside:.2f} s inside the observer)")
    print(f"loop (1 flight/call)  {t_loop:8.2f} s   {out['loop_flight_steps_per_s']:12.4g} flight·steps/s "
          f"(timed {n_loop} flights, extrapolated)")
    print(f"speed-up batched/loop: {out['speedup']:.1f}x")
    print(f"flights with final attitude error < 5°: {100 * out['fraction_converged_below_5deg']:.1f} % "
          f"(max {out['final_attitude_error_deg_max']:.2f}°)")


if __name__ == "__main__":
    main()
