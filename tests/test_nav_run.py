"""The navigation runner: multi-rate loop, batching, skipped fixes, validation, metrics, save/load."""

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
from nlobs.navigation.base import GnssSample, ImuSample, NavEstimate, NavFilter
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation.polar import nearest_rotation
from nlobs.navigation.run import NavResult, run_navigation
from nlobs.navigation.so3 import exp_so3, rot_z


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
    assert rb.batch_shape == (2,) and rb.p_hat.shape == (2, len(data.t_imu), 3)
    # a fixed number of RK4 steps gives identical arithmetic; with substeps=None a batch takes the
    # step count its stiffest member needs, so single runs agree only to RK4 accuracy (measured 3e-2 m
    # at the peak of the transient from a 1.1 rad attitude error)
    tol = {"rtol": 1e-12, "atol": 1e-9} if substeps else {"rtol": 0.0, "atol": 0.1}
    for i in range(2):
        single = dataclasses.replace(batch, omega_b=batch.omega_b[i], a_b=batch.a_b[i], p_gnss=batch.p_gnss[i],
                                     v_gnss=batch.v_gnss[i])
        rs = run_navigation(obs, single, data.p[0], data.v[0], R0[i])
        assert rs.batch_shape == ()
        np.testing.assert_allclose(rb.p_hat[i], rs.p_hat, **tol)
        np.testing.assert_allclose(rb.v_hat[i], rs.v_hat, **tol)
        np.testing.assert_allclose(rb.R_hat[i], rs.R_hat, **tol)
        np.testing.assert_allclose(rb.R_raw[i], rs.R_raw, **tol)
        np.testing.assert_allclose(rb.z_hat[i], rs.z_hat, **tol)


def test_nan_fix_is_skipped_and_counted(data, obs):
    p_g = np.stack([data.p_gnss, data.p_gnss])
    p_g[1, 3, 0] = np.nan  # flight 1 loses fix 3 (t = 0.6 s)
    p_g[1, 10] = np.nan  # and fix 10
    d2 = dataclasses.replace(data, p_gnss=p_g)
    r = run_navigation(obs, d2, data.p[0], data.v[0], data.R[0])
    np.testing.assert_array_equal(r.skipped_fixes, [0, 2])
    assert r.to_dict()["skipped_fixes"] == [0, 2]
    clean = run_navigation(obs, data, data.p[0], data.v[0], data.R[0])
    np.testing.assert_allclose(r.p_hat[0], clean.p_hat, atol=1e-9)
    # the flight with missing fixes keeps going on the predicted measurement: still accurate
    assert np.all(np.isfinite(r.p_hat[1]))
    assert r.position_error_m()[1].max() < 1e-2


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
    with pytest.raises(InvalidArgumentError, match="NavFilter"):
        run_navigation(object(), data, data.p[0], data.v[0], data.R[0])  # type: ignore[arg-type]


@dataclasses.dataclass(frozen=True)
class _DeadReckoning:
    """A minimal NavFilter (strapdown, no fixes used): checks the runner against the protocol only."""

    name: str = "dead-reckoning"
    blow_up_at: int = -1

    def init(self, p0: Any, v0: Any, R0: Any) -> Any:
        return (np.array(p0), np.array(v0), np.array(R0), 0)

    def propagate(self, state: Any, imu: ImuSample, dt: float) -> Any:
        p, v, R, k = state
        acc = np.einsum("...ij,...j->...i", R, imu.a_b) + G_N
        R = R @ exp_so3(imu.omega_b * dt)
        if k + 1 == self.blow_up_at:
            v = v * np.nan
        return (p + v * dt + 0.5 * acc * dt**2, v + acc * dt, R, k + 1)

    def update(self, state: Any, gnss: GnssSample) -> Any:
        return state

    def estimate(self, state: Any) -> NavEstimate:
        return NavEstimate(state[0], state[1], state[2])


def test_runner_takes_any_navfilter_and_reports_divergence(data):
    f = _DeadReckoning()
    assert isinstance(f, NavFilter)
    r = run_navigation(f, data, data.p[0], data.v[0], data.R[0])
    assert r.filter_name == "dead-reckoning" and r.R_raw is None and r.z_hat is None
    assert r.position_error_m().max() < 0.5  # exact strapdown on exact data, 8 s
    with pytest.raises(SimulationDiverged, match="t=0.47: dead-reckoning state 'p'"):
        run_navigation(_DeadReckoning(blow_up_at=47), data, data.p[0], data.v[0], data.R[0])


class _PerStepProjection:
    """The observer without ``raw_estimate``/``project_attitude``: the runner projects at every step."""

    def __init__(self, obs: GnssInsObserver) -> None:
        self.obs, self.name = obs, obs.name

    def init(self, p0: Any, v0: Any, R0: Any) -> Any:
        return self.obs.init(p0, v0, R0)

    def propagate(self, state: Any, imu: ImuSample, dt: float) -> Any:
        return self.obs.propagate(state, imu, dt)

    def update(self, state: Any, gnss: GnssSample) -> Any:
        return self.obs.update(state, gnss)

    def estimate(self, state: Any) -> NavEstimate:
        return self.obs.estimate(state)

    def diagnostics(self, state: Any, imu: ImuSample | None = None) -> dict[str, np.ndarray]:
        return self.obs.diagnostics(state, imu)


@pytest.mark.parametrize("batch", [None, 3])
def test_projection_once_at_the_end_equals_projection_at_every_step(data, obs, batch):
    R0 = data.R[0] if batch is None else np.stack([rot_z(a) @ data.R[0] for a in (0.5, -1.5, 2.5)])
    deferred = run_navigation(obs, data, data.p[0], data.v[0], R0)
    per_step = run_navigation(_PerStepProjection(obs), data, data.p[0], data.v[0], R0)
    np.testing.assert_array_equal(deferred.p_hat, per_step.p_hat)
    np.testing.assert_array_equal(deferred.R_raw, per_step.R_raw)
    np.testing.assert_array_equal(deferred.z_hat, per_step.z_hat)
    np.testing.assert_allclose(deferred.R_hat, per_step.R_hat, rtol=0.0, atol=1e-13)
    np.testing.assert_allclose(deferred.attitude_error_deg(), per_step.attitude_error_deg(), rtol=0.0, atol=1e-9)
    for name in ("p_hat", "R_hat", "R_raw", "z_hat"):
        assert not getattr(deferred, name).flags.writeable, name


@dataclasses.dataclass(frozen=True)
class _ScaledAttitude(_DeadReckoning):
    """Dead reckoning whose raw attitude is 2R (projected at the end), optionally blowing up in R."""

    nan_R_at: int = -1

    def propagate(self, state: Any, imu: ImuSample, dt: float) -> Any:
        p, v, R, k = super().propagate(state, imu, dt)
        return (p, v, R * np.nan if k == self.nan_R_at else R, k)

    def raw_estimate(self, state: Any) -> NavEstimate:
        return NavEstimate(state[0], state[1], 2.0 * state[2])

    @staticmethod
    def project_attitude(R_raw: Any) -> np.ndarray:
        return nearest_rotation(R_raw)


def test_deferred_projection_protocol_and_divergence_in_the_raw_attitude(data):
    r = run_navigation(_ScaledAttitude(), data, data.p[0], data.v[0], data.R[0])
    np.testing.assert_allclose(r.R_raw, 2.0 * r.R_hat, rtol=0.0, atol=1e-12)
    assert r.attitude_error_deg().max() < 0.1
    with pytest.raises(SimulationDiverged, match="t=0.33: dead-reckoning state 'R'"):
        run_navigation(_ScaledAttitude(nan_R_at=33), data, data.p[0], data.v[0], data.R[0])


def _result(att_deg: np.ndarray, t: np.ndarray, pos_err: float = 1.0) -> NavResult:
    K = len(t)
    R = np.broadcast_to(np.eye(3), (K, 3, 3))
    return NavResult(
        t=t, p_hat=np.zeros((K, 3)) + [pos_err, 0.0, 0.0], v_hat=np.zeros((K, 3)), R_hat=rot_z(np.radians(att_deg)),
        p=np.zeros((K, 3)), v=np.zeros((K, 3)) + [0.0, 2.0, 0.0], R=R, filter_name="x",
        skipped_fixes=np.array(0), n_fixes=3, cost_per_step_us=1.5, wall_s=0.1, imu_rate_hz=10.0, gnss_rate_hz=1.0)


def test_metrics_definitions():
    t = np.arange(11) / 10.0
    att = np.array([50.0, 10.0, 1.0, 3.0, 1.5, 1.0, 0.5, 0.5, 1.0, 0.5, 0.5])
    r = _result(att, t)
    np.testing.assert_allclose(r.attitude_error_deg(), att, atol=1e-9)
    assert float(r.converge_s(2.0)) == pytest.approx(0.4)  # last sample ≥ 2° is t = 0.3
    assert float(r.converge_s(5.0)) == pytest.approx(0.2)
    assert float(r.converge_s(100.0)) == 0.0
    assert np.isnan(float(r.converge_s(0.4)))  # never below 0.4° at the end
    # RMS over t ≥ converge time (default) or t ≥ after
    assert float(r.attitude_rms_deg()) == pytest.approx(np.sqrt(np.mean(att[4:] ** 2)))
    assert float(r.attitude_rms_deg(after=0.65)) == pytest.approx(np.sqrt(np.mean(att[7:] ** 2)))
    assert float(r.position_rms_m()) == pytest.approx(1.0)
    assert float(r.velocity_rms_mps(after=0.0)) == pytest.approx(2.0)
    assert np.isnan(float(r.attitude_rms_deg(threshold_deg=0.4)))
    d = r.to_dict()
    for key in ("position_rms_m", "velocity_rms_mps", "attitude_rms_deg", "converge_s", "cost_per_step_us"):
        assert isinstance(d[key], float), key
    assert d["converge_s"] == pytest.approx(0.4) and d["cost_per_step_us"] == 1.5


def test_save_load_round_trip_and_timing(tmp_path, data, obs):
    r = run_navigation(obs, data, data.p[0], data.v[0], rot_z(0.05) @ data.R[0], progress=True)
    assert np.isfinite(r.to_dict()["attitude_rms_deg"])
    assert r.cost_per_step_us > 0
    assert r.cost_per_step_us == pytest.approx(r.wall_s / len(r.t) * 1e6)
    path = r.save(tmp_path / "run.npz")
    back = NavResult.load(path)
    for name in ("t", "p_hat", "v_hat", "R_hat", "p", "v", "R", "R_raw", "z_hat", "skipped_fixes"):
        np.testing.assert_array_equal(getattr(back, name), getattr(r, name))
    assert back.to_dict() == r.to_dict()
    assert not any(p.name.endswith(".tmp") for p in tmp_path.iterdir())
    with pytest.raises(ValueError):
        r.p_hat[0, 0] = 1.0  # read-only
    np.savez(tmp_path / "other.npz", x=np.zeros(2))
    with pytest.raises(InvalidArgumentError, match="not an nlobs navigation result"):
        NavResult.load(tmp_path / "other.npz")


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
    fig = plot_euler_error(r, compare=r, labels=("observer", "copy"))
    np.testing.assert_allclose(fig.axes[2].get_lines()[0].get_ydata(), -att, atol=1e-9)
    with pytest.raises(InvalidArgumentError, match="labels"):
        plot_euler_error(r, compare=r, labels=("one",))
    # the three PNGs of a real run
    res = run_navigation(GnssInsObserver.paper(M_N, G_N), data, data.p[0], data.v[0], rot_z(0.2) @ data.R[0])
    paths = plot_navigation(res, tmp_path, prefix="t")
    assert sorted(paths) == ["euler_error", "ground_track", "velocity_error"]
    for p in paths.values():
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 10_000
