"""Cost per step of the particle filter and moving-horizon estimation beside the EKF and the UKF, single and batched.

On the shipped cart-pole (4 states; encoders of the cart and the pole at 50 Hz with noise; RK4 step 1 ms; the file's
process noise and force), the plant is simulated once (:func:`nlobs.simulate.simulate_plant`) and each estimator,
designed from the model file as ``nlobs simulate`` designs it, replays the same run
(:func:`nlobs.simulate.observe`): one run (batch 1) and a batch of ``--batch`` runs. Timed: the CPU time of the
whole replay (the loop, the estimator's steps and corrections, the recording), divided by the grid's steps and by
the runs: µs per step and run. The estimators are run interleaved, ``--repeat`` times each, and the smallest CPU
time of each is kept (the machine may be shared). Printed: µs per step and run of each, its ratio to the EKF's in
the same setting, and the batched run's speed-up per run over the single one.

* ``pf`` — :class:`nlobs.observers.particle.ParticleFilter`, ``--particles`` particles (default 1000), vectorised
  over runs and particles: its cost per run falls with the batch;
* ``mhe`` — :class:`nlobs.observers.mhe.MHE`, a window of 10 samples, one IPOPT solve per run and sample (a loop
  over the batch: no gain from batching); skipped when CasADi (the extra ``nlobs[mhe]``) is missing.

Run ``python benchmarks/estimator_cost.py [--duration S] [--batch B] [--particles N] [--repeat K]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from nlobs.methods.comparison import design_observer, method_options
from nlobs.methods.problem import problem
from nlobs.simulate import observe, simulate_plant
from nlobs.systems.modelfile import load_scenario

NAMES = ("ekf", "ukf", "pf", "mhe")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=2.0)
    ap.add_argument("--batch", type=int, default=10)
    ap.add_argument("--particles", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()

    sc = load_scenario("cartpole")
    pb = problem(sc)
    x0 = np.asarray(sc.defaults.x0, dtype=float)
    std = np.asarray(sc.defaults.initial_error_std, dtype=float)
    opts = method_options(NAMES, None, None, {"pf": {"particles": args.particles}})
    designs = {}
    for name in NAMES:
        d = design_observer(name, pb, {**opts[name], "p0_std": std})
        if isinstance(d, str):
            print(f"{name}: skipped ({d})")
            continue
        designs[name] = d.observer
    plant = sc.model.compile()
    rng = np.random.default_rng(1)
    runs = {}
    for label, batch in (("single", 1), ("batched", args.batch)):
        xs = x0 if batch == 1 else np.broadcast_to(x0, (batch, x0.size))
        xh = x0 + std * rng.standard_normal(x0.shape if batch == 1 else (batch, x0.size))
        run = simulate_plant(plant, xs, duration=args.duration, dt=sc.defaults.dt or 1e-3, u=sc.input_signals,
                             measurements=sc.sensors, process_noise=sc.process_noise, seed=3)
        runs[label] = (run, xh, batch)
    best: dict[tuple[str, str], float] = {}
    errors: dict[tuple[str, str], float] = {}
    for _ in range(args.repeat):
        for label, (run, xh, batch) in runs.items():
            for name, obs in designs.items():
                tic = time.process_time()
                res = observe(run, obs, xh)
                cpu = time.process_time() - tic
                steps = run.result.t.size
                key = (name, label)
                best[key] = min(best.get(key, np.inf), 1e6 * cpu / (steps * batch))
                late = run.result.t >= args.duration / 2
                e = np.asarray(res.x_hat) - np.asarray(run.result.x)
                errors[key] = float(np.sqrt(np.mean(e[..., late, :] ** 2)))
    print(f"cart-pole, {args.duration:g} s at dt = 1 ms ({runs['single'][0].result.t.size} steps), encoders at 50 Hz; "
          f"pf with {args.particles} particles, mhe over 10 samples; CPU µs per step and run (best of {args.repeat})")
    print(f"{'estimator':10s} {'single':>10s} {'÷ EKF':>8s} {'batch ' + str(args.batch):>10s} {'÷ EKF':>8s} "
          f"{'single/batched':>15s} {'RMS e (2nd half)':>17s}")
    for name in designs:
        s, b = best[(name, "single")], best[(name, "batched")]
        print(f"{name:10s} {s:10.1f} {s / best[('ekf', 'single')]:8.1f} {b:10.1f} {b / best[('ekf', 'batched')]:8.1f} "
              f"{s / b:15.2f} {errors[(name, 'batched')]:17.3g}")


if __name__ == "__main__":
    main()
