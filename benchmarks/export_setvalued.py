"""Algorithm 1 of Khajenejad & Yong in generated C against the Python observer: µs per step of one run.

For the shipped models ``khajenejad-6-1`` (designed as ``nlobs design setvalued`` does, sound radii) and
``khajenejad-6-2`` (the paper's printed gain and bounds: no observer of the structure exists): one noisy run
of 20 000 steps (6.2: 200, its error grows by 1.34 a step), measured in this one process:

* Python: :func:`nlobs.simulate.run_observer` of :class:`~nlobs.observers.setvalued.SetValuedObserver`,
  ``info["cost_per_step_us"]`` (the time inside ``correct`` and ``rhs``, per grid instant, one run);
* C: :meth:`nlobs.export.CompiledObserver.run_record`, the whole loop in C (``P_run``) called once from
  Python, its wall time per grid instant (the compilation is done, and cached, before the timing).

The ratio Python/C is printed, and the norm-wise relative difference of the two runs' centres.

Run: ``python benchmarks/export_setvalued.py`` (a few seconds).
"""

from __future__ import annotations

import time

import numpy as np

from nlobs.export import compile_observer
from nlobs.observers.setvalued import GivenGain, SetValuedObserver
from nlobs.papers.khajenejad_yong import example_62
from nlobs.papers.khajenejad_yong_printed import printed_radii
from nlobs.simulate import run_observer
from nlobs.simulate.setvalued import ball_samples
from nlobs.systems.modelfile import load_discrete_ui_model
from nlobs.workflows.setvalued import design_setvalued_observer

STEPS = 20_000
SHORT = 200


def _observer(name: str, steps: int) -> tuple[object, SetValuedObserver]:
    m = load_discrete_ui_model(name)
    s = m.system
    if name == "khajenejad-6-1":
        return m, SetValuedObserver(s, design_setvalued_observer(m, samples=2000).design)
    pr = example_62().printed
    gain = GivenGain.for_system(s, np.reshape(pr["L_tilde"], (2, 1)))
    with np.errstate(over="ignore"):
        radii = printed_radii(s, gain.gain, pr["P"], pr["rho"], steps, L_f=pr["L_f"])
    return m, SetValuedObserver(s, gain, radii=radii)


def main() -> None:
    print(f"{'model':<16} {'steps':>6} {'Python [µs/step]':>16} {'C run_record [µs/step]':>22} {'ratio':>7} "
          f"{'‖Δx̂‖/‖x̂‖':>12}")
    for name in ("khajenejad-6-1", "khajenejad-6-2"):
        # 6.2 has no stable observer: its error grows by 1.34 a step, so its run is short (no overflow)
        steps = STEPS if name == "khajenejad-6-1" else SHORT
        m, obs = _observer(name, steps)
        s = obs.system
        rng = np.random.default_rng(0)
        t = np.arange(steps + 1) * s.time.dt
        x0 = s.x0 + ball_samples(rng, (1,), s.delta0, s.n)
        d = m.signals["bounded"](t)[None]
        _, y = s.simulate(x0, d, ball_samples(rng, (1, steps), s.eta_w, s.n_w),
                          ball_samples(rng, (1, steps + 1), s.eta_v, s.l))
        py = run_observer(obs, t, x_hat0=s.x0, y=y[0])
        co = compile_observer(obs)
        co.run_record(t[:10], s.x0, y=y[0, :10])  # loaded and warm
        t0 = time.perf_counter()
        xc = co.run_record(t, s.x0, y=y[0])  # the whole run, one call
        c_us = (time.perf_counter() - t0) / t.size * 1e6
        p_us = float(py.info["cost_per_step_us"])
        diff = float(np.linalg.norm(xc - py.x_hat) / np.linalg.norm(py.x_hat))
        print(f"{name:<16} {steps:>6} {p_us:>16.2f} {c_us:>22.3f} {p_us / c_us:>7.0f} {diff:>12.2e}")


if __name__ == "__main__":
    main()
