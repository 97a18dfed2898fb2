"""Peaking of high-gain observers, with and without saturation: drift (3.1) and Moore–Penrose (7), (17).

Rössler (``rossler``, ``x`` measured) on the region ``[-4, 4] × [-4, 4] × [-1, 4]`` (drift-observable:
``det Q_s = x − 5.9`` does not vanish there), the gain of Remark 2.11 with the smallest ``w`` solving
(2.17) (γ sampled on the region), the true state starting at ``(0.3, 0, 0.05)`` (it stays in the region
for the run). The initial estimate is the truth plus ``p`` times the region's widths along a random
unit direction (``RUNS`` directions per size, one batched simulation each), clipped to the region.
Saturation off: (3.1) as printed; on: Khalil's form of :mod:`nlobs.observers.drift`.

Printed per row: the fraction of runs whose final error is below 1e-3 of the initial one, the largest
``|x̂|`` over all runs and times (NaN runs excluded; "inf" when some run became non-finite), the
number of non-finite runs and the largest final error among the finite ones.

Cart-pole (``cartpole``, cart position and pole angle measured, hanging pole at rest at ``θ = 3``, no
force): the drift observer with the design ``nlobs advise cartpole`` recommends (box
``[-20, 20] × [-5, 5] × [2, 4.3] × [-5, 5]``, ``α = μ = 1``), initial errors of 1, 5 and 20 %.

Moore–Penrose observer (7), (17) of Röbenack: on the cart-pole ``Σ r_j = n`` (``Q`` is a permutation, the
gain constant: the observer is a constant-gain copy, the drift observer's structure), so it runs on
``isidori-146`` (``r = 2 < n = 4``) on ``[-2, 2]⁴`` from its equilibrium ``x = 0`` (``u = 0``), ``θ = 20``
(roots ``−20, −400``), saturation off vs on (:mod:`nlobs.observers.pinv`). Its zero dynamics
(``ẋ1 = −x1³`` there) are slow, so no run converges to 1e-3 of its initial error in the second simulated; the final error
is the column to read.

Run: ``PYTHONPATH=src python benchmarks/peaking.py`` (about two and a half minutes; the Rössler part about two).
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from nlobs.geometry import Box
from nlobs.observers.pinv import PinvObserver
from nlobs.simulate import simulate
from nlobs.synthesis.pinv_gain import HighGain
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


CARTPOLE_BOX = Box([-20.0, -5.0, 2.0, -5.0], [20.0, 5.0, 4.3, 5.0])
CARTPOLE_X0 = np.array([0.0, 0.0, 3.0, 0.0])
PINV_BOX = Box([-2.0] * 4, [2.0] * 4)
PINV_X0 = np.zeros(4)
PINV_THETA = 20.0
SMALL_SIZES = (0.01, 0.05, 0.20)


def _rows(plant, observers, box, x0, u, sizes, runs, duration, dt, seed, save_every=1):
    """Rows ``(p, saturation, converged fraction, max |x̂|, non-finite runs, max final error)`` for each size."""
    n = box.n
    d = np.random.default_rng(seed).normal(size=(runs, n))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rows = []
    for p in sizes:
        xh0 = np.clip(x0 + p * (box.upper - box.lower) * d, box.lower, box.upper)
        for sat, obs in zip((False, True), observers):
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore")
                res = simulate(plant, obs, np.broadcast_to(x0, (runs, n)), xh0, duration=duration, dt=dt, u=u,
                               divergence="keep", save_every=save_every)
            e = res.error_norm
            finite = np.all(np.isfinite(res.x_hat), axis=(-2, -1))
            conv = finite & (e[..., -1] < 1e-3 * e[..., 0])
            xmax = float(np.max(np.abs(res.x_hat[finite]))) if finite.any() else float("nan")
            rows.append((p, sat, float(conv.mean()), xmax, int((~finite).sum()),
                         float(np.max(e[finite, -1])) if finite.any() else float("nan")))
    return rows


def run_cartpole(sizes=SMALL_SIZES, runs=RUNS, duration=0.5, dt=1e-3, seed=0):
    """The drift observer on the cart-pole (the design of ``nlobs advise cartpole``): the report and its rows."""
    model = load_model("cartpole")
    rep = design_drift_report(model, alpha=1.0, mu=1.0, region=CARTPOLE_BOX)
    obs = [rep.observer(on_singular="nan", saturation=s) for s in (False, True)]
    return rep, _rows(model.compile(), obs, CARTPOLE_BOX, CARTPOLE_X0, [0.0], sizes, runs, duration, dt, seed)


def run_pinv(sizes=SMALL_SIZES, runs=RUNS, duration=1.0, dt=1e-3, seed=0, theta=PINV_THETA):
    """The Moore–Penrose observer on ``isidori-146``: the observer (unsaturated) and the rows."""
    model = load_model("isidori-146")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = PinvObserver.from_model(model, k=HighGain(theta), region=PINV_BOX, require_a5=False)
    obs = [plain, plain.with_saturation(PINV_BOX)]
    return plain, _rows(model.compile(), obs, PINV_BOX, PINV_X0, [0.0], sizes, runs, duration, dt, seed)


def _table(rows) -> None:
    print("| initial error (of the region's widths) | saturation | converged | max abs(x̂) | non-finite runs | "
          "max final error |")
    print("|---|---|---|---|---|---|")
    for p, sat, conv, xmax, bad, fin in rows:
        print(f"| {100 * p:g} % | {'on' if sat else 'off'} | {conv:.2f} | {xmax:.3g} | {bad} | {fin:.3g} |")


def main() -> None:
    cases = (
        (run, lambda rep: f"Rössler, drift observer (3.1), region {REGION.describe()}, w = {rep.certificate.w:.4g}, "
                          f"{RUNS} runs per row, {DURATION:g} s, dt = {DT:g}"),
        (run_cartpole, lambda rep: f"\nCart-pole, drift observer (3.1), region {CARTPOLE_BOX.describe()}, w = "
                                   f"{rep.certificate.w:.4g}, {RUNS} runs per row, 0.5 s, dt = 0.001, every step kept"),
        (run_pinv, lambda obs: f"\nisidori-146, Moore–Penrose observer (7), (17), region {PINV_BOX.describe()}, θ = "
                               f"{PINV_THETA:g} (k = {[float(v) for v in obs.k_vector]}), {RUNS} runs per row, 1 s, "
                               "dt = 0.001, every step kept"),
    )
    for case, title in cases:
        t = time.perf_counter()
        design, rows = case()
        print(title(design))
        _table(rows)
        print(f"({time.perf_counter() - t:.0f} s)")


if __name__ == "__main__":
    main()
