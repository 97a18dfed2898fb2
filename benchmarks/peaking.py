"""Peaking of the drift observer (3.1) of Dalla Mora, Germani & Manes, with and without saturation.

Rössler (``rossler``, ``x`` measured) on the region ``[-4, 4] × [-4, 4] × [-1, 4]`` (drift-observable:
``det Q_s = x − 5.9`` does not vanish there), the gain of Remark 2.11 with the smallest ``w`` solving
(2.17) (γ sampled on the region), the true state starting at ``(0.3, 0, 0.05)`` (it stays in the region
for the run). The initial estimate is the truth plus ``p`` times the region's widths along a random
unit direction (``RUNS`` directions per size, one batched simulation each), clipped to the region.
Saturation off: (3.1) as printed; on: Khalil's form of :mod:`nlobs.observers.drift`.

Printed per row: the fraction of runs whose final error is below 1e-3 of the initial one, the largest
``|x̂|`` over all runs and times (NaN runs excluded; "inf" when some run became non-finite), the
number of non-finite runs and the largest final error among the finite ones.

Run: ``PYTHONPATH=src python benchmarks/peaking.py`` (about two minutes).
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from nlobs.geometry import Box
from nlobs.simulate import simulate
from nlobs.systems.modelfile import load_model
from nlobs.workflows.design_drift import design_drift_report

RUNS = 20
SIZES = (0.01, 0.05, 0.20, 0.50)
REGION = Box([-4.0, -4.0, -1.0], [4.0, 4.0, 4.0])
X0 = np.array([0.3, 0.0, 0.05])
DURATION, DT = 0.5, 5e-5


def run(sizes=SIZES, runs=RUNS, duration=DURATION, dt=DT, seed=0):
    """Rows ``(p, saturation, converged fraction, max |x̂|, non-finite runs, max final error)``."""
    model = load_model("rossler")
    rep = design_drift_report(model, mu=0.0, region=REGION)
    plant = model.compile()
    d = np.random.default_rng(seed).normal(size=(runs, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rows = []
    for p in sizes:
        xh0 = np.clip(X0 + p * (REGION.upper - REGION.lower) * d, REGION.lower, REGION.upper)
        for sat in (False, True):
            obs = rep.observer(on_singular="nan", saturation=sat)
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore")
                res = simulate(plant, obs, np.broadcast_to(X0, (runs, 3)), xh0, duration=duration, dt=dt,
                               divergence="keep", save_every=10)
            e = res.error_norm
            finite = np.all(np.isfinite(res.x_hat), axis=(-2, -1))
            conv = finite & (e[..., -1] < 1e-3 * e[..., 0])
            xmax = float(np.max(np.abs(res.x_hat[finite]))) if finite.any() else float("nan")
            rows.append((p, sat, float(conv.mean()), xmax, int((~finite).sum()),
                         float(np.max(e[finite, -1])) if finite.any() else float("nan")))
    return rep, rows


def main() -> None:
    t = time.perf_counter()
    rep, rows = run()
    print(f"Rössler, drift observer (3.1), region {REGION.describe()}, w = {rep.certificate.w:.4g}, "
          f"{RUNS} runs per row, {DURATION:g} s, dt = {DT:g}")
    print("| initial error (of the region's widths) | saturation | converged | max abs(x̂) | non-finite runs | "
          "max final error |")
    print("|---|---|---|---|---|---|")
    for p, sat, conv, xmax, bad, fin in rows:
        print(f"| {100 * p:g} % | {'on' if sat else 'off'} | {conv:.2f} | {xmax:.3g} | {bad} | {fin:.3g} |")
    print(f"({time.perf_counter() - t:.0f} s)")


if __name__ == "__main__":
    main()
