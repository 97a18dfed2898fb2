"""One run of the EKF and the UKF of nlobs on a nonlinear plant, per step, against filterpy doing the same work.

The plant is the flexible-joint robot of ``kalman_baselines.py`` (4 states, ``sin`` of the link angle,
Raghavan & Hedrick's parameters), compiled from SymPy; both motor outputs are sampled at every step of
``dt = 1 ms`` with noise, over ``STEPS`` steps, from a wrong initial estimate. Every filter sees the same
data and the same compiled functions (``rhs``, ``output`` and their Jacobians):

* **nlobs** — :func:`nlobs.simulate.run_observer` with :class:`nlobs.EKF` / :class:`nlobs.UKF`, as a user
  runs a filter on data (the whole loop: correction, RK4 of the filter's ODEs, recording).
* **filterpy EKF** — ``filterpy.kalman.ExtendedKalmanFilter``: its ``update`` (Joseph form) with the
  compiled ``output`` and ``output_jacobian_x``, and the same continuous-discrete prediction written
  plainly: one RK4 step of ``(ẋ = f, Ṗ = F P + P Fᵀ + Q)``. Its estimates equal nlobs' (the difference is
  printed).
* **nlobs EKF as C** — the same filter's generated C (``nlobs export MODEL --observer ekf``,
  :func:`nlobs.export.compile_observer`) in the same loop, for reference (not part of the target).
* **filterpy UKF** — ``filterpy.kalman.UnscentedKalmanFilter`` with the same sigma points (Merwe, α = 1,
  β = 2, κ = 0), ``fx`` one RK4 step of the plant, ``Q·dt`` added: filterpy's own discrete prediction of a
  sampled continuous plant (nlobs integrates Särkkä's moment ODEs instead; both RMS errors are printed).

CPU time (``time.process_time``) of each whole run, the filters interleaved ``ROUNDS`` times, the best
of each kept; printed as µs per step and the ratio nlobs / filterpy. Target (everyday speed): ≤ 1.

Run: ``PYTHONPATH=src python benchmarks/filter_single_run.py`` (filterpy from the ``test`` extra).
"""

from __future__ import annotations

import time

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter, MerweScaledSigmaPoints, UnscentedKalmanFilter
from kalman_baselines import flexible_joint

from nlobs import EKF, UKF
from nlobs.simulate import rk4_step, run_observer

STEPS = 2000
DT = 1e-3
ROUNDS = 5
TARGET = 1.0


def data(plant, seed: int = 0):  # type: ignore[no-untyped-def]
    """Truth by RK4, the input ``τ = 0.5 sin(2t)``, both outputs with noise at every step."""
    rng = np.random.default_rng(seed)
    t = DT * np.arange(STEPS)
    u = 0.5 * np.sin(2.0 * t)[:, None]
    x = np.zeros((STEPS, 4))
    x[0] = [0.3, 0.0, 0.2, 0.0]
    for k in range(STEPS - 1):
        x[k + 1] = rk4_step(lambda tt, xx: plant.rhs(tt, xx, u[k]), t[k], x[k], DT)
    y = np.stack([plant.output(t[k], x[k], u[k]) for k in range(STEPS)]) + rng.normal(0.0, [1e-3, 1e-2], (STEPS, 2))
    return t, u, x, y


def run_filterpy_ekf(plant, t, u, y, x0, Q, R, P0):  # type: ignore[no-untyped-def]
    f, F, h, H = plant.rhs, plant.rhs_jacobian_x, plant.output, plant.output_jacobian_x
    ekf = ExtendedKalmanFilter(dim_x=4, dim_z=2)
    ekf.x, ekf.P, ekf.R = x0.copy(), P0.copy(), R.copy()
    out = np.empty((len(t), 4))

    def moments(tt: float, x: np.ndarray, P: np.ndarray, uk: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        FP = F(tt, x, uk).dot(P)
        return f(tt, x, uk), FP + FP.T + Q

    for k in range(len(t)):
        tk, uk = t[k], u[k]
        ekf.update(y[k], HJacobian=lambda x: H(tk, x, uk), Hx=lambda x: h(tk, x, uk))
        out[k] = ekf.x
        x, P = ekf.x, ekf.P
        k1 = moments(tk, x, P, uk)
        k2 = moments(tk + DT / 2, x + DT / 2 * k1[0], P + DT / 2 * k1[1], uk)
        k3 = moments(tk + DT / 2, x + DT / 2 * k2[0], P + DT / 2 * k2[1], uk)
        k4 = moments(tk + DT, x + DT * k3[0], P + DT * k3[1], uk)
        ekf.x = x + DT / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        ekf.P = P + DT / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    return out


def run_filterpy_ukf(plant, t, u, y, x0, Q, R, P0):  # type: ignore[no-untyped-def]
    f, h = plant.rhs, plant.output
    current = {"t": 0.0, "u": u[0]}

    def fx(x: np.ndarray, dt: float) -> np.ndarray:
        return rk4_step(lambda tt, xx: f(tt, xx, current["u"]), current["t"], x, dt)

    def hx(x: np.ndarray) -> np.ndarray:
        return h(current["t"], x, current["u"])

    ukf = UnscentedKalmanFilter(dim_x=4, dim_z=2, dt=DT, hx=hx, fx=fx,
                                points=MerweScaledSigmaPoints(4, alpha=1.0, beta=2.0, kappa=0.0))
    ukf.x, ukf.P, ukf.R, ukf.Q = x0.copy(), P0.copy(), R.copy(), Q * DT
    out = np.empty((len(t), 4))
    for k in range(len(t)):
        current["t"], current["u"] = t[k], u[k]
        if k:
            ukf.predict()
        ukf.update(y[k])
        out[k] = ukf.x
    return out


def main() -> None:
    plant = flexible_joint()
    t, u, x, y = data(plant)
    x0 = np.array([0.0, 0.0, 0.0, 0.0])
    Q, R, P0 = np.diag([1e-6, 1e-4, 1e-6, 1e-4]), np.diag([1e-6, 1e-4]), np.eye(4) * 0.1
    ekf, ukf = EKF(plant, Q, R, P0), UKF(plant, Q, R, P0)
    ekf_c = None
    try:
        from nlobs.errors import NlobsError
        from nlobs.export import compile_observer, find_compiler

        ekf_c = compile_observer(ekf) if find_compiler() is not None else None
    except (ImportError, NlobsError):  # no compiler (the codegen extra), or a version without the EKF's C
        pass
    runs = {
        "nlobs EKF": lambda: run_observer(ekf, t, x_hat0=x0, u=u, y=y, progress=False).x_hat,
        "filterpy EKF": lambda: run_filterpy_ekf(plant, t, u, y, x0, Q, R, P0),
        "nlobs UKF": lambda: run_observer(ukf, t, x_hat0=x0, u=u, y=y, progress=False).x_hat,
        "filterpy UKF": lambda: run_filterpy_ukf(plant, t, u, y, x0, Q, R, P0),
    }
    if ekf_c is not None:  # the generated C of the same filter, in the same loop (``nlobs export MODEL --observer ekf``)
        runs["nlobs EKF as C"] = lambda: run_observer(ekf_c, t, x_hat0=x0, u=u, y=y, progress=False).x_hat
    cpu: dict[str, list[float]] = {name: [] for name in runs}
    est: dict[str, np.ndarray] = {}
    for name, fn in runs.items():  # warm-up
        est[name] = np.asarray(fn())
    for _ in range(ROUNDS):
        for name, fn in runs.items():
            c = time.process_time()
            fn()
            cpu[name].append(time.process_time() - c)
    print(f"one run of the flexible-joint robot (n = 4, p = 2), {STEPS} steps of {DT * 1e3:g} ms, CPU time, "
          f"best of {ROUNDS} interleaved rounds")
    print(f"{'filter':<14} {'µs/step':>8} {'RMS error':>10}")
    for name in runs:
        rms = float(np.sqrt(np.mean((est[name][STEPS // 2:] - x[STEPS // 2:]) ** 2)))
        print(f"{name:<14} {min(cpu[name]) / STEPS * 1e6:>8.1f} {rms:>10.3e}")
    d = float(np.max(np.abs(est["nlobs EKF"] - est["filterpy EKF"])))
    print(f"largest difference of the EKF estimates, nlobs against filterpy: {d:.2e}")
    if ekf_c is not None:
        d = float(np.max(np.abs(est["nlobs EKF"] - est["nlobs EKF as C"])))
        print(f"largest difference of the EKF estimates, Python against its generated C: {d:.2e}")
    ok = True
    for kind in ("EKF", "UKF"):
        ratio = min(cpu[f"nlobs {kind}"]) / min(cpu[f"filterpy {kind}"])
        ok &= ratio <= TARGET
        print(f"{kind}: nlobs / filterpy = {ratio:.2f} (target ≤ {TARGET:g})")
    print("target: " + ("met" if ok else "MISSED"))


if __name__ == "__main__":
    main()
