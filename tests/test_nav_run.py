"""The navigation runner: multi-rate loop, batching, skipped fixes, validation, metrics, save/load.

``run_navigation`` is a thin call of ``run_observer``; the filters are correcting observers, the
result a ``SimulationResult`` and the metrics functions of it (``nlobs.navigation.metrics``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from test_gnss_ins_synthetic import G_N, M_N, turn_data

from nlobs.errors import (
    DimensionError,
    InvalidArgumentError,
    NonFiniteError,
    SimulationDiverged,
)
from nlobs.navigation import metrics as M
from nlobs.navigation.base import IMU_ACCEL, IMU_OMEGA, NAV_STATES, nav_vector, split_nav
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation.polar import nearest_rotation
from nlobs.navigation.run import run_navigation
from nlobs.navigation.so3 import exp_so3, rot_z, skew
from nlobs.observers.base import CorrectingObserver, DeferredEstimate, SelfStepping
from nlobs.simulate import SimulationResult, run_observer
from nlobs.systems.timebase import Continuous


@pytest.fixture(scope="module")
def data():
    return turn_data(8.0)


@pytest.fixture(scope="module")
def obs():
    return GnssInsObserver.paper(M_N, G_N)


@pytest.mark.parametrize("substeps", [3, None])
def test_batched_run_equals_single_runs(data, substeps):
    obs = GnssInsObserver.paper(M_N, G_N, substeps=substeps, integrator="rk4")
    rng = np.random.default_rng(7)
    # two noise realisations of the IMU and GNSS, and a different initial attitude per flight
    batch = dataclasses.replace(
        data, omega_b=data.omega_b + rng.normal(scale=1e-3, size=(2, *data.omega_b.shape)),
        a_b=data.a_b + rng.normal(scale=0.05, size=(2, *data.a_b.shape)),
        p_gnss=data.p_gnss + rng.normal(scale=0.5, size=(2, *data.p_gnss.shape)),
        v_gnss=data.v_gnss + rng.normal(scale=0.1, size=(2, *data.v_gnss.shape)))
    R0 = np.stack([rot_z(0.3) @ data.R[0], exp_so3([0.0, 1.0, 0.5]) @ data.R[0]])
    rb = run_navigation(obs, batch, data.p[0], data.v[0], R0)
    assert rb.batch_shape == (2,) and M.p_hat(rb).shape == (2, len(data.t_imu), 3)
    # a fixed number of RK4 steps gives identical arithmetic; with substeps=None a batch takes the
    # step count its stiffest member needs, so single runs agree only to RK4 accuracy (measured 3e-2 m
    # at the peak of the transient from a 1.1 rad attitude error)
    tol = {"rtol": 1e-12, "atol": 1e-9} if substeps else {"rtol": 0.0, "atol": 0.1}
    for i in range(2):
        single = dataclasses.replace(batch, omega_b=batch.omega_b[i], a_b=batch.a_b[i], p_gnss=batch.p_gnss[i],
                                     v_gnss=batch.v_gnss[i])
        rs = run_navigation(obs, single, data.p[0], data.v[0], R0[i])
        assert rs.batch_shape == ()
        for get in (M.p_hat, M.v_hat, M.R_hat, M.R_raw, M.z_hat):
            np.testing.assert_allclose(get(rb)[i], get(rs), **tol)


def test_nan_fix_is_skipped_and_counted(data, obs):
    p_g = np.stack([data.p_gnss, data.p_gnss])
    p_g[1, 3, 0] = np.nan  # flight 1 loses fix 3 (t = 0.6 s)
    p_g[1, 10] = np.nan  # and fix 10
    d2 = dataclasses.replace(data, p_gnss=p_g)
    r = run_navigation(obs, d2, data.p[0], data.v[0], data.R[0])
    np.testing.assert_array_equal(r.info["skipped_fixes"], [0, 2])
    assert M.summary_dict(r)["skipped_fixes"] == [0, 2]
    clean = run_navigation(obs, data, data.p[0], data.v[0], data.R[0])
    np.testing.assert_allclose(M.p_hat(r)[0], M.p_hat(clean), atol=1e-9)
    # the flight with missing fixes keeps going on the predicted measurement: still accurate
    assert np.all(np.isfinite(M.p_hat(r)[1]))
    assert M.position_error_m(r)[1].max() < 1e-2


def test_fixes_off_the_imu_grid_or_out_of_order_are_refused(data, obs):
    tg = data.t_gnss.copy()
    tg[4] += 0.003
    with pytest.raises(InvalidArgumentError, match=r"fix 4 at t = 0.803 s is not on the IMU grid"):
        run_navigation(obs, dataclasses.replace(data, t_gnss=tg), data.p[0], data.v[0], data.R[0])
    tg = data.t_gnss.copy()
    tg[[5, 6]] = tg[[6, 5]]
    with pytest.raises(InvalidArgumentError, match="fix 6 .* out of order"):
        run_navigation(obs, dataclasses.replace(data, t_gnss=tg), data.p[0], data.v[0], data.R[0])
    tg = data.t_gnss.copy()
    tg[-1] = data.t_imu[-1] + 0.2
    with pytest.raises(InvalidArgumentError, match="not on the IMU grid"):
        run_navigation(obs, dataclasses.replace(data, t_gnss=tg), data.p[0], data.v[0], data.R[0])


def test_nan_imu_sample_names_its_time(data, obs):
    a = data.a_b.copy()
    a[123, 1] = np.nan
    with pytest.raises(NonFiniteError, match=r"a_b: IMU sample at t = 1.23 s \(index 123\)"):
        run_navigation(obs, dataclasses.replace(data, a_b=a), data.p[0], data.v[0], data.R[0])


def test_other_bad_inputs(data, obs):
    t = data.t_imu.copy()
    t[50:] += 0.001
    with pytest.raises(InvalidArgumentError, match="not uniform"):
        run_navigation(obs, dataclasses.replace(data, t_imu=t), data.p[0], data.v[0], data.R[0])
    with pytest.raises(DimensionError, match="omega_b"):
        run_navigation(obs, dataclasses.replace(data, omega_b=data.omega_b[:-1]), data.p[0], data.v[0], data.R[0])
    with pytest.raises(NonFiniteError, match="p0"):
        run_navigation(obs, data, [np.nan, 0.0, 0.0], data.v[0], data.R[0])
    with pytest.raises(DimensionError, match="R0"):
        run_navigation(obs, data, data.p[0], data.v[0], np.eye(2))
    with pytest.raises(DimensionError, match="do not broadcast"):
        run_navigation(obs, data, np.zeros((2, 3)), np.zeros((3, 3)), data.R[0])
    with pytest.raises(InvalidArgumentError, match="not a navigation filter"):
        run_navigation(object(), data, data.p[0], data.v[0], data.R[0])  # type: ignore[arg-type]


@dataclasses.dataclass(frozen=True)
class _DeadReckoning:
    """A minimal navigation filter (strapdown, fixes ignored): checks the runner against the protocol only."""

    name: str = "dead-reckoning"
    blow_up_at: int = -1
    time: Continuous = Continuous()
    n_x: int = 15

    def init(self, x_hat0: np.ndarray) -> Any:
        p, v, R = split_nav(x_hat0)
        return (p.copy(), v.copy(), R.copy(), 0)

    def rhs(self, t: float, z: Any, u: np.ndarray, y: np.ndarray) -> Any:
        p, v, R, k = z
        return (v, np.einsum("...ij,...j->...i", R, u[..., IMU_ACCEL]) + G_N, R @ skew(u[..., IMU_OMEGA]), k)

    def step(self, t: float, z: Any, u: np.ndarray, y: np.ndarray, h: float) -> Any:
        p, v, R, k = z
        acc = np.einsum("...ij,...j->...i", R, u[..., IMU_ACCEL]) + G_N
        R = R @ exp_so3(u[..., IMU_OMEGA] * h)
        if k + 1 == self.blow_up_at:
            v = v * np.nan
        return (p + v * h + 0.5 * acc * h**2, v + acc * h, R, k + 1)

    def correct(self, t: float, z: Any, u: np.ndarray, y: np.ndarray, fresh: np.ndarray) -> Any:
        return z

    def estimate(self, z: Any) -> np.ndarray:
        return nav_vector(z[0], z[1], z[2])


def test_runner_takes_any_navigation_filter_and_reports_divergence(data):
    f = _DeadReckoning()
    assert isinstance(f, CorrectingObserver) and isinstance(f, SelfStepping)
    r = run_navigation(f, data, data.p[0], data.v[0], data.R[0])
    assert r.observer == "dead-reckoning" and M.R_raw(r) is None and M.z_hat(r) is None
    assert M.position_error_m(r).max() < 0.5  # exact strapdown on exact data, 8 s
    with pytest.raises(SimulationDiverged, match="t=0.47: dead-reckoning state 'p_n'"):
        run_navigation(_DeadReckoning(blow_up_at=47), data, data.p[0], data.v[0], data.R[0])


class _PerStepProjection:
    """The observer without ``raw_estimate``/``finish_estimates``: its estimate projects at every step."""

    def __init__(self, obs: GnssInsObserver) -> None:
        self.obs, self.name, self.time, self.n_x = obs, obs.name, obs.time, obs.n_x

    def init(self, x_hat0: np.ndarray) -> Any:
        return self.obs.init(x_hat0)

    def rhs(self, t: float, z: Any, u: np.ndarray, y: np.ndarray) -> Any:
        return self.obs.rhs(t, z, u, y)

    def step(self, t: float, z: Any, u: np.ndarray, y: np.ndarray, h: float) -> Any:
        return self.obs.step(t, z, u, y, h)

    def correct(self, t: float, z: Any, u: np.ndarray, y: np.ndarray, fresh: np.ndarray) -> Any:
        return self.obs.correct(t, z, u, y, fresh)

    def estimate(self, z: Any) -> np.ndarray:
        return self.obs.estimate(z)

    def diagnostics(self, z: Any, u: np.ndarray) -> dict[str, np.ndarray]:
        return {**self.obs.diagnostics(z, u), "R_raw": z.R}


@pytest.mark.parametrize("batch", [None, 3])
def test_projection_once_at_the_end_equals_projection_at_every_step(data, obs, batch):
    R0 = data.R[0] if batch is None else np.stack([rot_z(a) @ data.R[0] for a in (0.5, -1.5, 2.5)])
    deferred = run_navigation(obs, data, data.p[0], data.v[0], R0)
    per_step = run_navigation(_PerStepProjection(obs), data, data.p[0], data.v[0], R0)
    assert not isinstance(_PerStepProjection(obs), DeferredEstimate)
    np.testing.assert_array_equal(M.p_hat(deferred), M.p_hat(per_step))
    np.testing.assert_array_equal(M.R_raw(deferred), M.R_raw(per_step))
    np.testing.assert_array_equal(M.z_hat(deferred), M.z_hat(per_step))
    np.testing.assert_allclose(M.R_hat(deferred), M.R_hat(per_step), rtol=0.0, atol=1e-13)
    np.testing.assert_allclose(M.attitude_error_deg(deferred), M.attitude_error_deg(per_step), rtol=0.0, atol=1e-9)
    for get in (M.p_hat, M.R_hat, M.R_raw, M.z_hat):
        assert not get(deferred).flags.writeable, get.__name__


@dataclasses.dataclass(frozen=True)
class _ScaledAttitude(_DeadReckoning):
    """Dead reckoning whose raw attitude is 2R (projected at the end), optionally blowing up in R."""

    nan_R_at: int = -1

    def step(self, t: float, z: Any, u: np.ndarray, y: np.ndarray, h: float) -> Any:
        p, v, R, k = super().step(t, z, u, y, h)
        return (p, v, R * np.nan if k == self.nan_R_at else R, k)

    def raw_estimate(self, z: Any) -> np.ndarray:
        return nav_vector(z[0], z[1], 2.0 * z[2])

    def finish_estimates(self, raw: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        p, v, R_raw = split_nav(raw)
        return nav_vector(p, v, nearest_rotation(R_raw)), {"R_raw": R_raw}


def test_deferred_estimate_protocol_and_divergence_in_the_raw_attitude(data):
    assert isinstance(_ScaledAttitude(), DeferredEstimate)
    r = run_navigation(_ScaledAttitude(), data, data.p[0], data.v[0], data.R[0])
    np.testing.assert_allclose(M.R_raw(r), 2.0 * M.R_hat(r), rtol=0.0, atol=1e-12)
    assert M.attitude_error_deg(r).max() < 0.1
    with pytest.raises(SimulationDiverged, match="t=0.33: dead-reckoning state 'R11'"):
        run_navigation(_ScaledAttitude(nan_R_at=33), data, data.p[0], data.v[0], data.R[0])


def test_run_navigation_is_run_observer_on_the_sensor_channels(data, obs):
    R0 = rot_z(0.3) @ data.R[0]
    nav = run_navigation(obs, data, data.p[0], data.v[0], R0)
    direct = run_observer(obs, data.t_imu, x_hat0=nav_vector(data.p[0], data.v[0], R0), u=data.imu_input(),
                          y=data.gnss_output(), y_times=data.t_gnss, truth=data.truth(), states=NAV_STATES)
    np.testing.assert_array_equal(nav.x_hat, direct.x_hat)
    np.testing.assert_array_equal(nav.extras["R_raw"], direct.extras["R_raw"])
    assert nav.estimates == NAV_STATES and nav.method == "observer step"
    assert nav.info["n_fixes"] == data.t_gnss.size and nav.info["imu_rate_hz"] == 100.0
    assert nav.info["gnss_rate_hz"] == 5.0 and int(nav.info["skipped_fixes"]) == 0


def _result(att_deg: np.ndarray, t: np.ndarray, pos_err: float = 1.0) -> SimulationResult:
    K = len(t)
    R = np.broadcast_to(np.eye(3), (K, 3, 3))
    return SimulationResult(
        t=t, x=nav_vector(np.zeros((K, 3)), np.zeros((K, 3)) + [0.0, 2.0, 0.0], R),
        x_hat=nav_vector(np.zeros((K, 3)) + [pos_err, 0.0, 0.0], np.zeros((K, 3)), rot_z(np.radians(att_deg))),
        y=None, sampled=None, states=NAV_STATES, outputs=(), estimates=NAV_STATES, dt=float(t[1] - t[0]),
        method="observer step", observer="x",
        info={"cost_per_step_us": 1.5, "observer_s": 0.1, "skipped_fixes": np.array(0), "n_fixes": 3,
              "imu_rate_hz": 10.0, "gnss_rate_hz": 1.0})


def test_metrics_definitions():
    t = np.arange(11) / 10.0
    att = np.array([50.0, 10.0, 1.0, 3.0, 1.5, 1.0, 0.5, 0.5, 1.0, 0.5, 0.5])
    r = _result(att, t)
    np.testing.assert_allclose(M.attitude_error_deg(r), att, atol=1e-9)
    assert float(M.converge_s(r, 2.0)) == pytest.approx(0.4)  # last sample ≥ 2° is t = 0.3
    assert float(M.converge_s(r, 5.0)) == pytest.approx(0.2)
    assert float(M.converge_s(r, 100.0)) == 0.0
    assert np.isnan(float(M.converge_s(r, 0.4)))  # never below 0.4° at the end
    # RMS over t ≥ converge time (default) or t ≥ after
    assert float(M.attitude_rms_deg(r)) == pytest.approx(np.sqrt(np.mean(att[4:] ** 2)))
    assert float(M.attitude_rms_deg(r, after=0.65)) == pytest.approx(np.sqrt(np.mean(att[7:] ** 2)))
    assert float(M.position_rms_m(r)) == pytest.approx(1.0)
    assert float(M.velocity_rms_mps(r, after=0.0)) == pytest.approx(2.0)
    assert np.isnan(float(M.attitude_rms_deg(r, threshold_deg=0.4)))
    d = M.summary_dict(r)
    assert list(d) == ["filter", "position_rms_m", "velocity_rms_mps", "attitude_rms_deg", "converge_s",
                       "cost_per_step_us", "skipped_fixes", "n_fixes", "after", "threshold_deg"]
    for key in ("position_rms_m", "velocity_rms_mps", "attitude_rms_deg", "converge_s", "cost_per_step_us"):
        assert isinstance(d[key], float), key
    assert d["converge_s"] == pytest.approx(0.4) and d["cost_per_step_us"] == 1.5
    assert d["filter"] == "x" and d["skipped_fixes"] == 0 and d["n_fixes"] == 3
    with pytest.raises(InvalidArgumentError, match="no truth"):
        M.position_error_m(dataclasses.replace(r, x=None))
    with pytest.raises(InvalidArgumentError, match="info lacks"):
        M.summary_dict(dataclasses.replace(r, info={}))


def test_save_load_round_trip_and_timing(tmp_path, data, obs):
    r = run_navigation(obs, data, data.p[0], data.v[0], rot_z(0.05) @ data.R[0], progress=True)
    assert np.isfinite(M.summary_dict(r)["attitude_rms_deg"])
    assert r.info["cost_per_step_us"] > 0
    assert r.info["cost_per_step_us"] == pytest.approx(r.info["observer_s"] / len(r.t) * 1e6)
    path = r.save(tmp_path / "run.npz")
    back = SimulationResult.load(path)
    for get in (M.p_hat, M.v_hat, M.R_hat, M.p, M.v, M.R, M.R_raw, M.z_hat):
        np.testing.assert_array_equal(get(back), get(r))
    np.testing.assert_array_equal(back.t, r.t)
    np.testing.assert_array_equal(back.info["skipped_fixes"], r.info["skipped_fixes"])
    assert M.summary_dict(back) == M.summary_dict(r)
    assert not any(p.name.endswith(".tmp") for p in tmp_path.iterdir())
    with pytest.raises(ValueError):
        M.p_hat(r)[0, 0] = 1.0  # read-only
    np.savez(tmp_path / "other.npz", x=np.zeros(2))
    with pytest.raises(InvalidArgumentError, match="not an nlobs simulation result"):
        SimulationResult.load(tmp_path / "other.npz")

def test_figures_like_the_papers_figs_4_to_6(tmp_path, data):
    from nlobs.navigation.plots import (
        euler_error_deg,
        plot_euler_error,
        plot_navigation,
        plot_velocity_error,
    )

    t = np.arange(11) / 10.0
    att = np.linspace(30.0, 0.0, 11)
    r = _result(att, t)
    # level truth, R̂ = Rz(att): the yaw error (true − estimate) is −att, roll and pitch errors vanish
    np.testing.assert_allclose(euler_error_deg(r), np.column_stack([0 * att, 0 * att, -att]), atol=1e-9)
    fig = plot_velocity_error(r)
    err_line = fig.axes[0].get_lines()[0]  # first axis: North; solid = v − v̂ = [0, 2, 0] − 0
    assert [ax.get_ylabel() for ax in fig.axes[:3]] == ["North error [m/s]", "East error [m/s]", "Down error [m/s]"]
    np.testing.assert_allclose(err_line.get_ydata(), 0.0)
    np.testing.assert_allclose(fig.axes[1].get_lines()[0].get_ydata(), 2.0)
    assert len(fig.axes) == 4 and fig.axes[3].get_ylabel() == "true [m/s]"  # the truth in its own panel, no twin axes
    fig = plot_euler_error(r, compare=r, labels=("observer", "copy"))
    np.testing.assert_allclose(fig.axes[2].get_lines()[0].get_ydata(), -att, atol=1e-9)
    first, second = fig.axes[2].get_lines()[:2]  # the comparison is drawn above the main run, thinner
    assert second.get_zorder() > first.get_zorder() and second.get_linewidth() < first.get_linewidth()
    with pytest.raises(InvalidArgumentError, match="labels"):
        plot_euler_error(r, compare=r, labels=("one",))
    # more runs (the demo's EKF and the paper's gains): each drawn and named, the third below the others; the
    # axis holds the largest error, the initial one (30° here), with a tick at it
    fig = plot_euler_error(r, compare=[r, r], labels=("observer", "EKF", "paper"))
    lines = fig.axes[2].get_lines()[:3]
    assert [ln.get_label() for ln in lines] == ["observer", "EKF", "paper"]
    assert lines[2].get_zorder() < lines[0].get_zorder() < lines[1].get_zorder()
    lo, hi = fig.axes[2].get_ylim()
    assert lo <= -30.0 and hi >= 30.0 and 30.0 in [abs(v) for v in fig.axes[2].get_yticks()]
    with pytest.raises(InvalidArgumentError, match="at most 4 runs"):
        plot_euler_error(r, compare=[r] * 5)
    # the three PNGs of a real run
    res = run_navigation(GnssInsObserver.paper(M_N, G_N), data, data.p[0], data.v[0], rot_z(0.2) @ data.R[0])
    paths = plot_navigation(res, tmp_path, prefix="t")
    assert sorted(paths) == ["euler_error", "ground_track", "velocity_error"]
    for p in paths.values():
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 10_000
