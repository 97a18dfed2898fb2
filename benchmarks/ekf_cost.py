"""Cost per IMU step of the library's navigation EKF against straightforward implementations of it.

On the demo flight (:mod:`nlobs.workflows.demo`: traffic pattern, IMU + magnetometer at 100 Hz, GNSS
p, v at 5 Hz with the demo's noise, 60° initial yaw error, the demo's EKF tuning), one flight
(batch 1), the same data for every filter:

* **library** — :class:`nlobs.navigation.ekf.ExtendedKalmanFilter` (``kernel="auto"``: its
  single-flight path) run by :func:`nlobs.navigation.run.run_navigation`; for reference the row
  ``library[batched]`` runs the same flight through its vectorised path (``kernel="batched"``, the
  only path before the single-flight one existed);
* **plain** — :class:`PlainEkf` below: the same error-state equations (the module docstring of
  :mod:`nlobs.navigation.ekf`) written the straightforward way, dense ``F``, ``G``, ``Φ``, ``Q``
  and ``H``, ``@`` products, ``np.linalg.inv`` and a plain Rodrigues exponential;
* **filterpy** — the same nominal propagation and ``Φ``, ``Q``, ``H`` with the covariance
  prediction and the (Joseph-form) updates done by ``filterpy.kalman.ExtendedKalmanFilter``
  (``predict``, ``update``) on the 9-dimensional error state, reset after each injection; the
  covariance is symmetrised after each call as the library does (skipped when filterpy, a test
  extra, is not installed);
* **observer** — observer (24) of Grip, Saberi & Johansen (:class:`~nlobs.navigation.gnss_ins.GnssInsObserver`,
  the paper's gains, its fused single-flight kernel), the honest cost baseline of the comparison.

What is timed is the wall time inside the GNSS correction and the IMU step (the loop of
:func:`~nlobs.simulate.run_observer`: ``info["cost_per_step_us"]``; the plain and filterpy
filters run in a copy of that loop that brackets the same two calls), divided by the number of IMU
steps. The filters are run interleaved, ``--repeat`` times each, and the best time of each is kept
(the machine may be shared). Printed: µs per step, the ratios library / plain and library /
filterpy with their target (≤ 1), the ratio EKF / observer, and the largest difference between
the library's and the plain filter's estimates along the flight (position and velocity relative to
their largest magnitude along the flight, attitude entries absolute), target 1e-12.

Run ``python benchmarks/ekf_cost.py [--duration S] [--repeat K]``.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from nlobs.navigation.base import split_nav
from nlobs.navigation.ekf import EkfConfig, ExtendedKalmanFilter
from nlobs.navigation.gains import PAPER_GAMMA, paper_gains
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation.run import run_navigation
from nlobs.navigation.sensors import generate_sensors
from nlobs.navigation.so3 import rot_z
from nlobs.navigation.trajectory import traffic_pattern
from nlobs.workflows.demo import DemoConfig

try:
    from filterpy.kalman import ExtendedKalmanFilter as FilterpyEKF
except ImportError:  # a test extra
    FilterpyEKF = None

TARGET_RATIO = 1.0
TARGET_DIFF = 1e-12


def skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def rodrigues(phi: np.ndarray) -> np.ndarray:
    """``exp(S(φ)) = I + sin θ S(u) + (1 − cos θ) S(u)²``, ``u = φ/θ``."""
    th = float(np.linalg.norm(phi))
    if th < 1e-12:
        return np.eye(3) + skew(phi)
    K = skew(phi / th)
    return np.eye(3) + math.sin(th) * K + (1.0 - math.cos(th)) * (K @ K)


class PlainEkf:
    """The error-state EKF of :mod:`nlobs.navigation.ekf`, written the straightforward way (dense matrices)."""

    def __init__(self, c: EkfConfig, m_n: np.ndarray, g_n: np.ndarray) -> None:
        self.m_n, self.g_n = np.asarray(m_n, float), np.asarray(g_n, float)
        self.Qc = np.diag([c.accel_std**2] * 3 + [c.gyro_std**2] * 3)
        self.R_mag = np.eye(3) * c.mag_std**2
        self.H_gnss = np.hstack([np.eye(6), np.zeros((6, 3))])
        self.R_gnss = np.diag([c.gnss_p_std**2] * 3 + [c.gnss_v_std**2] * 3)
        self.P0 = np.diag([c.p0_std**2] * 3 + [c.v0_std**2] * 3
                          + list(np.deg2rad([c.tilt0_std_deg, c.tilt0_std_deg, c.yaw0_std_deg]) ** 2))

    def init(self, p, v, R):  # type: ignore[no-untyped-def]
        self.p, self.v, self.R, self.P = np.array(p, float), np.array(v, float), np.array(R, float), self.P0.copy()

    def jacobians(self, w, a, dt):  # type: ignore[no-untyped-def]
        """``Φ = I + F dt + ½ (F dt)²`` and ``Q = G Qc Gᵀ dt²``."""
        F = np.zeros((9, 9))
        F[0:3, 3:6] = np.eye(3)
        F[3:6, 6:9] = -self.R @ skew(a)
        F[6:9, 6:9] = -skew(w)
        G = np.zeros((9, 6))
        G[3:6, 0:3] = -self.R
        G[6:9, 3:6] = -np.eye(3)
        Fdt = F * dt
        return np.eye(9) + Fdt + 0.5 * Fdt @ Fdt, G @ self.Qc @ G.T * dt**2

    def nominal(self, w, a, dt):  # type: ignore[no-untyped-def]
        acc = self.R @ a + self.g_n
        self.p = self.p + self.v * dt + 0.5 * acc * dt**2
        self.v = self.v + acc * dt
        self.R = self.R @ rodrigues(w * dt)

    def mag_model(self):  # type: ignore[no-untyped-def]
        m_pred = self.R.T @ self.m_n
        H = np.zeros((3, 9))
        H[:, 6:9] = skew(m_pred)
        return m_pred, H

    def inject(self, dx):  # type: ignore[no-untyped-def]
        self.p = self.p + dx[0:3]
        self.v = self.v + dx[3:6]
        self.R = self.R @ rodrigues(dx[6:9])

    def update(self, H, Rm, nu):  # type: ignore[no-untyped-def]
        S = H @ self.P @ H.T + Rm
        K = self.P @ H.T @ np.linalg.inv(S)
        IKH = np.eye(9) - K @ H
        P = IKH @ self.P @ IKH.T + K @ Rm @ K.T
        self.P = 0.5 * (P + P.T)
        self.inject(K @ nu)

    def step(self, u, dt):  # type: ignore[no-untyped-def]
        w, a, m = u[0:3], u[3:6], u[6:9]
        Phi, Q = self.jacobians(w, a, dt)
        self.nominal(w, a, dt)
        P = Phi @ self.P @ Phi.T + Q
        self.P = 0.5 * (P + P.T)
        m_pred, H = self.mag_model()
        self.update(H, self.R_mag, m - m_pred)

    def correct(self, y):  # type: ignore[no-untyped-def]
        self.update(self.H_gnss, self.R_gnss, y - np.concatenate([self.p, self.v]))

    def estimate(self):  # type: ignore[no-untyped-def]
        return np.concatenate([self.p, self.v, self.R.ravel()])


class FilterpyBased(PlainEkf):
    """:class:`PlainEkf` with the covariance prediction and the updates done by filterpy's EKF."""

    def init(self, p, v, R):  # type: ignore[no-untyped-def]
        super().init(p, v, R)
        self.kf = FilterpyEKF(dim_x=9, dim_z=3)
        self.kf.x = np.zeros(9)
        self.kf.P = self.P0.copy()

    def _update(self, z, hx, H, Rm):  # type: ignore[no-untyped-def]
        kf = self.kf
        kf.update(z, lambda x: H, lambda x: hx, R=Rm)
        kf.P = 0.5 * (kf.P + kf.P.T)
        self.inject(kf.x)
        kf.x = np.zeros(9)

    def step(self, u, dt):  # type: ignore[no-untyped-def]
        w, a, m = u[0:3], u[3:6], u[6:9]
        kf = self.kf
        kf.F, kf.Q = self.jacobians(w, a, dt)
        self.nominal(w, a, dt)
        kf.predict()
        kf.P = 0.5 * (kf.P + kf.P.T)
        m_pred, H = self.mag_model()
        self._update(m, m_pred, H, self.R_mag)

    def correct(self, y):  # type: ignore[no-untyped-def]
        self._update(y, np.concatenate([self.p, self.v]), self.H_gnss, self.R_gnss)


def run_plain(filt: PlainEkf, data, x0):  # type: ignore[no-untyped-def]
    """The loop of ``run_navigation`` for :class:`PlainEkf`: (cost per step [µs], estimates ``(K, 15)``)."""
    t = np.asarray(data.t_imu)
    u = data.imu_input()
    y = data.gnss_output()
    fix = np.full(t.size, -1)
    fix[np.rint((np.asarray(data.t_gnss) - t[0]) * data.imu_rate_hz).astype(int)] = np.arange(data.t_gnss.size)
    fix_list, h_list = fix.tolist(), np.diff(t).tolist()
    p0, v0, R0 = split_nav(x0)
    filt.init(p0, v0, R0)
    rec = np.empty((t.size, 15))
    busy = 0.0
    perf = time.perf_counter
    K = t.size
    for k in range(K):
        g = fix_list[k]
        if g >= 0:
            t0 = perf()
            filt.correct(y[g])
            busy += perf() - t0
        rec[k] = filt.estimate()
        if k < K - 1:
            t0 = perf()
            filt.step(u[k], h_list[k])
            busy += perf() - t0
    return busy / (K - 1) * 1e6, rec


def max_difference(a: np.ndarray, b: np.ndarray) -> float:
    """Largest difference of two estimate records ``(K, 15)``: p and v relative to their largest magnitude, R absolute."""
    out = 0.0
    for sl, rel in ((slice(0, 3), True), (slice(3, 6), True), (slice(6, 15), False)):
        d = float(np.max(np.abs(a[:, sl] - b[:, sl])))
        out = max(out, d / max(1.0, float(np.max(np.abs(b[:, sl])))) if rel else d)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=120.0, help="flight length [s] (the demo flies 369 s)")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    cfg = DemoConfig(duration=args.duration)
    flight = traffic_pattern(seed=cfg.seed, duration=cfg.duration)
    traj = flight.sample(cfg.imu_rate_hz)
    data = generate_sensors(traj, imu_rate_hz=cfg.imu_rate_hz, gnss_rate_hz=cfg.gnss_rate_hz, noise=cfg.noise,
                            seed=cfg.seed)
    R0 = rot_z(np.deg2rad(cfg.yaw_error_deg)) @ traj.R[0]
    p0, v0 = data.p_gnss[0], data.v_gnss[0]
    x0 = np.concatenate([p0, v0, R0.ravel()])
    ekf_cfg = EkfConfig.for_noise(cfg.noise, yaw_std_deg=max(30.0, abs(cfg.yaw_error_deg)),
                                  sample_period_s=1.0 / cfg.imu_rate_hz)
    lib = ExtendedKalmanFilter(ekf_cfg, flight.m_n, flight.g_n)
    lib_batched = ExtendedKalmanFilter(ekf_cfg, flight.m_n, flight.g_n, kernel="batched")
    obs = GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n)

    runners = {
        "library": lambda: _run_lib(lib, data, p0, v0, R0),
        "library[batched]": lambda: _run_lib(lib_batched, data, p0, v0, R0),
        "plain": lambda: run_plain(PlainEkf(ekf_cfg, flight.m_n, flight.g_n), data, x0),
    }
    if FilterpyEKF is not None:
        runners["filterpy"] = lambda: run_plain(FilterpyBased(ekf_cfg, flight.m_n, flight.g_n), data, x0)
    runners["observer"] = lambda: _run_lib(obs, data, p0, v0, R0)
    best = {name: math.inf for name in runners}
    est = {}
    for _ in range(args.repeat):
        for name, run in runners.items():
            cost, x_hat = run()
            best[name] = min(best[name], cost)
            est[name] = x_hat

    steps = data.t_imu.size - 1
    print(f"navigation EKF cost per IMU step, one flight of {args.duration:g} s ({steps} steps), "
          f"best of {args.repeat}, interleaved")
    for name in runners:
        print(f"  {name:16s} {best[name]:8.2f} µs/step")
    for other in ("plain", "filterpy"):
        if other in best:
            r = best["library"] / best[other]
            print(f"  ratio library/{other:10s} = {r:.3f}  (target ≤ {TARGET_RATIO:g}: "
                  f"{'meets' if r <= TARGET_RATIO else 'MISSES'})")
        else:
            print(f"  ratio library/{other:10s}: filterpy is not installed (a test extra)")
    print(f"  ratio EKF/observer       = {best['library'] / best['observer']:.3f}  "
          f"(library[batched]/observer = {best['library[batched]'] / best['observer']:.3f})")
    print(f"  max difference library vs library[batched] estimates = "
          f"{max_difference(est['library'], est['library[batched]']):.2e}")
    d = max_difference(est["library"], est["plain"])
    print(f"  max difference library vs plain estimates = {d:.2e}  (target ≤ {TARGET_DIFF:g}: "
          f"{'meets' if d <= TARGET_DIFF else 'MISSES'})")
    if "filterpy" in est:
        print(f"  max difference library vs filterpy estimates = "
              f"{max_difference(est['library'], est['filterpy']):.2e}")


def _run_lib(filt, data, p0, v0, R0):  # type: ignore[no-untyped-def]
    r = run_navigation(filt, data, p0, v0, R0)
    return float(r.info["cost_per_step_us"]), np.asarray(r.x_hat)


if __name__ == "__main__":
    main()
