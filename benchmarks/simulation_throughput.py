"""Batched vs per-trajectory simulation throughput of :func:`nlobs.simulate.simulate`.

The plant is the single-link flexible-joint robot (4 states, nonlinear through
``sin`` of the link angle; Raghavan & Hedrick's parameters), measured at 100 Hz
with noise (motor angle and speed), observed by a Luenberger-type observer
``ż = f(z, u) + L (y − C z)``, integrated with RK4 at ``dt = 1 ms``.

Two measurements in the same run:

* **batched**: one call with ``B`` initial conditions (default 1000);
* **loop**: the same ``simulate`` called with one initial condition at a time.
  By default only ``--loop-sample`` trajectories (default 50) are timed and the
  time is extrapolated linearly to ``B`` (each call is independent and costs
  the same); ``--full-loop`` times all ``B`` calls.

Throughput is state-steps per second, ``B · K · n / seconds`` with ``K`` the
number of steps and ``n = 4``. Each measurement is repeated ``--repeat`` times;
the table shows the best and the median.

Run ``python benchmarks/simulation_throughput.py [--json]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time

import numpy as np
from scipy.signal import place_poles

from nlobs.simulate import MeasurementGroup, simulate
from nlobs.systems.timebase import CONTINUOUS

# Flexible-joint robot (Raghavan & Hedrick 1994; Rajamani 1998).
JM, JL, MASS, H, K, BV, KT, G = 3.7e-3, 9.3e-3, 0.21, 0.15, 0.18, 4.6e-2, 8e-2, 9.8
A = np.array(
    [
        [0.0, 1.0, 0.0, 0.0],
        [-K / JM, -BV / JM, K / JM, 0.0],
        [0.0, 0.0, 0.0, 1.0],
        [K / JL, 0.0, -K / JL, 0.0],
    ]
)
C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])


class FlexibleJoint:
    """``ẋ = A x + B u − [0, 0, 0, (m g h / J_l) sin x3]``, ``y = (θ_m, ω_m)``, batched."""

    time = CONTINUOUS
    states = ("theta_m", "omega_m", "theta_l", "omega_l")
    inputs = ("torque",)
    outputs = ("theta_m_meas", "omega_m_meas")
    n, m, p = 4, 1, 2

    def rhs(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        dx = x @ A.T
        dx[..., 1] += (KT / JM) * u[..., 0]
        dx[..., 3] -= (MASS * G * H / JL) * np.sin(x[..., 2])
        return dx

    def output(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return x[..., :2]


class FlexibleJointObserver:
    """Luenberger-type observer ``ż = f(z, u) + L (y − C z)``."""

    time = CONTINUOUS
    n_z = 4
    n_x = 4

    def __init__(self, L: np.ndarray) -> None:
        self._plant = FlexibleJoint()
        self._LT = np.ascontiguousarray(L.T)

    def init(self, x_hat0: np.ndarray) -> np.ndarray:
        return np.array(x_hat0, dtype=float)

    def rhs(self, t: float, z: np.ndarray, u: np.ndarray, y: np.ndarray) -> np.ndarray:
        return self._plant.rhs(t, z, u) + (y - z[..., :2]) @ self._LT

    def estimate(self, z: np.ndarray) -> np.ndarray:
        return z


def _torque(t: float) -> np.ndarray:
    return np.array([np.sin(2.0 * t)])


def _run(x0: np.ndarray, xh0: np.ndarray, obs: FlexibleJointObserver, duration: float, dt: float, seed: int):
    return simulate(
        FlexibleJoint(),
        obs,
        x0,
        xh0,
        duration=duration,
        dt=dt,
        u=_torque,
        measurements=[MeasurementGroup("encoder", ["theta_m_meas", "omega_m_meas"], rate=100.0, noise_std=1e-3)],
        seed=seed,
        progress=False,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=1000, help="number of trajectories B (default 1000)")
    ap.add_argument("--duration", type=float, default=1.0, help="simulated seconds (default 1.0)")
    ap.add_argument("--dt", type=float, default=1e-3, help="RK4 step (default 1e-3)")
    ap.add_argument("--repeat", type=int, default=3, help="repetitions of each measurement (default 3)")
    ap.add_argument("--loop-sample", type=int, default=50, help="trajectories timed in the loop (default 50)")
    ap.add_argument("--full-loop", action="store_true", help="time all B single-trajectory calls")
    ap.add_argument("--json", action="store_true", help="print a JSON object instead of a table")
    args = ap.parse_args()

    L = place_poles(A.T, C.T, [-8.0, -9.0, -10.0, -11.0]).gain_matrix.T  # (4, 2)
    obs = FlexibleJointObserver(L)
    rng = np.random.default_rng(2024)
    B = args.batch
    x0 = rng.uniform(-0.5, 0.5, size=(B, 4))
    xh0 = np.zeros(4)
    K = round(args.duration / args.dt)
    n = 4

    _run(x0[:2], xh0, obs, 0.01, args.dt, 0)  # warm-up (imports, caches)
    batched = []
    for r in range(args.repeat):
        t0 = time.perf_counter()
        res = _run(x0, xh0, obs, args.duration, args.dt, r)
        batched.append(time.perf_counter() - t0)
    final_rmse = float(np.sqrt(np.mean(res.error[:, -1, :] ** 2)))

    n_loop = B if args.full_loop else min(args.loop_sample, B)
    loop = []
    for r in range(args.repeat):
        t0 = time.perf_counter()
        for b in range(n_loop):
            _run(x0[b], xh0, obs, args.duration, args.dt, r)
        loop.append((time.perf_counter() - t0) * B / n_loop)

    work = B * K * n
    out = {
        "plant": "flexible-joint robot, 4 states, RK4, 100 Hz noisy encoder",
        "batch": B,
        "steps": K,
        "n": n,
        "dt": args.dt,
        "repeat": args.repeat,
        "loop_trajectories_timed": n_loop,
        "loop_extrapolated": n_loop < B,
        "batched_seconds_best": min(batched),
        "batched_seconds_median": statistics.median(batched),
        "loop_seconds_best": min(loop),
        "loop_seconds_median": statistics.median(loop),
        "batched_state_steps_per_s": work / min(batched),
        "loop_state_steps_per_s": work / min(loop),
        "speedup_best": min(loop) / min(batched),
        "speedup_median": statistics.median(loop) / statistics.median(batched),
        "final_rms_error": final_rmse,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "machine": platform.machine(),
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    note = f"(timed {n_loop} of {B} calls, extrapolated)" if n_loop < B else "(all calls timed)"
    print(f"simulate() throughput: {out['plant']}; B={B}, K={K} steps, n={n}")
    print(f"{'mode':<28}{'best [s]':>12}{'median [s]':>12}{'state-steps/s':>16}")
    print(f"{'batched (1 call, B traj.)':<28}{min(batched):>12.3f}{statistics.median(batched):>12.3f}{work / min(batched):>16.3e}")
    print(f"{'loop (B calls, 1 traj.)':<28}{min(loop):>12.3f}{statistics.median(loop):>12.3f}{work / min(loop):>16.3e}")
    print(f"speed-up batched / loop: {out['speedup_best']:.0f}x (best), {out['speedup_median']:.0f}x (median) {note}")


if __name__ == "__main__":
    main()
