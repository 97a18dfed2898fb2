"""Filter consistency (NEES, NIS against χ² bands): the band against sampled χ² variables, the statistics on
synthetic runs whose errors are drawn from the covariance, multi-rate NIS with missing samples, and the EKF of a
comparison: consistent with the plant's own noise, far above the band with a process noise 100 times too small."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.simulate.consistency import chi2_band, filter_consistency
from nlobs.simulate.result import SimulationResult


@pytest.mark.parametrize("dof", [1, 4, 40, 400])
def test_the_band_holds_its_probability(dof: int) -> None:
    lo, hi = chi2_band(dof, 0.95)
    draws = np.random.default_rng(dof).chisquare(dof, 400_000) / dof
    inside = np.mean((draws >= lo) & (draws <= hi))
    assert abs(inside - 0.95) < 0.002
    assert abs(np.mean(draws < lo) - 0.025) < 0.002  # two-sided: 2.5 % on each side


def _result(e, P, nis, sampled=None, y=None):  # type: ignore[no-untyped-def]
    N, K, n = e.shape
    p = 0 if sampled is None else sampled.shape[1]
    return SimulationResult(t=np.arange(K) * 0.1, x=np.zeros((N, K, n)), x_hat=e,
                            y=np.zeros((N, K, p)) if y is None else y, sampled=sampled,
                            states=tuple(f"s{i}" for i in range(n)), outputs=tuple(f"o{j}" for j in range(p)),
                            estimates=tuple(f"s{i}" for i in range(n)), dt=0.1, method="rk4",
                            extras={"P": P, "nis": nis})


def test_errors_drawn_from_the_covariance_are_consistent_and_a_small_covariance_is_not() -> None:
    rng = np.random.default_rng(0)
    N, K = 50, 400
    L = np.array([[1.0, 0.0, 0.0], [0.8, 0.6, 0.0], [0.1, -0.3, 2.0]])  # a correlated covariance
    P = L @ L.T
    e = rng.standard_normal((N, K, 3)) @ L.T
    c = filter_consistency(_result(e, np.broadcast_to(P, (N, K, 3, 3)), np.zeros((N, K))))
    assert c is not None and c.runs == N
    assert 0.92 <= c.nees_inside <= 0.98 and abs(float(np.mean(c.nees)) - 1.0) < 0.02
    small = filter_consistency(_result(e, np.broadcast_to(P / 4.0, (N, K, 3, 3)), np.zeros((N, K))))
    assert small.nees_inside < 0.01 and abs(float(np.mean(small.nees)) - 4.0) < 0.1
    # the full covariance, not its diagonal: each instant against eᵀ P⁻¹ e written out with the inverse
    Pinv = np.linalg.inv(P)
    ref = np.einsum("rki,ij,rkj->k", e, Pinv, e) / (N * 3)
    assert np.allclose(c.nees, ref, rtol=1e-12)
    assert not np.allclose(ref, np.einsum("rki,rki->k", e, e / np.diag(P)) / (N * 3), rtol=1e-2)


def test_the_nis_counts_the_outputs_each_run_used() -> None:
    """Two outputs at different rates, a missing sample in some runs: NIS_r ~ χ²(d_r) with its own d_r."""
    rng = np.random.default_rng(1)
    N, K = 400, 60
    sampled = np.zeros((K, 2), dtype=bool)
    sampled[::2, 0] = True
    sampled[::3, 1] = True
    y = np.zeros((N, K, 2))
    y[: N // 4, 6, 0] = np.nan  # a quarter of the runs missed output 0 at instant 6 (it also has output 1)
    dof = (sampled[None] & np.isfinite(y)).sum(axis=-1)
    nis = np.where(dof > 0, rng.chisquare(np.maximum(dof, 1)), 123.0)  # 123: a held value where nothing arrived
    c = filter_consistency(_result(np.zeros((N, K, 1)), np.ones((N, K, 1, 1)), nis, sampled, y))
    rows = np.flatnonzero(sampled.any(axis=1))
    assert np.array_equal(c.t_nis, np.arange(K)[rows] * 0.1)
    assert 0.85 <= c.nis_inside <= 1.0 and abs(float(np.mean(c.nis)) - 1.0) < 0.03
    i6 = int(np.flatnonzero(rows == 6)[0])
    lo, hi = chi2_band(N * 2 - N // 4)  # instant 6: both outputs, one missing in a quarter of the runs
    assert c.nis_lo[i6] == pytest.approx(lo) and c.nis_hi[i6] == pytest.approx(hi)


def test_a_result_without_a_filter_has_none() -> None:
    e = np.zeros((2, 5, 1))
    res = SimulationResult(t=np.arange(5.0), x=e, x_hat=e, y=None, sampled=None, states=("a",), outputs=(),
                           estimates=("a",), dt=1.0, method="rk4")
    assert filter_consistency(res) is None


@pytest.mark.slow
def test_the_comparison_reports_the_filters_consistency(tmp_path) -> None:
    from nlobs.workflows.compare import compare_observers

    good = compare_observers("cartpole", observers=["ekf", "ukf"], runs=10, duration=5.0, seed=1, out=tmp_path)
    for name in ("ekf", "ukf"):
        c = good.observers[name].consistency.to_dict()
        assert c["runs"] == 10 and c["nees_inside"] >= 0.85 and c["nis_inside"] >= 0.85
        assert 0.8 < c["nees_mean"] < 1.25 and 0.8 < c["nis_mean"] < 1.25
        assert "P" not in good.observers[name].result.extras  # recorded for the NEES only
    assert (tmp_path / "consistency.png").stat().st_size > 10_000
    assert good.to_dict()["observers"]["ekf"]["consistency"]["level"] == 0.95
    bad = compare_observers("cartpole", observers=["ekf"], runs=10, duration=5.0, seed=1,
                            filter_q=[0.0, 0.001, 0.0, 0.001])  # the plant's std is 0.01: Q 100 times too small
    c = bad.observers["ekf"].consistency.to_dict()
    assert c["nees_mean"] > 10.0 and c["nees_inside"] < 0.1 and c["nis_mean"] > 1.5


# ----------------------------------------------------------------------------- the navigation EKF (GNSS/INS demo)

def _nav_run(duration: float, backend: str = "python"):  # type: ignore[no-untyped-def]
    import dataclasses

    from nlobs.methods.gnss_ins import DemoConfig, demo_ekf
    from nlobs.navigation.run import run_navigation
    from nlobs.navigation.sensors import generate_sensors
    from nlobs.navigation.so3 import rot_z
    from nlobs.navigation.trajectory import traffic_pattern

    cfg = DemoConfig(duration=duration)
    flight = traffic_pattern(seed=cfg.seed, duration=cfg.duration)
    traj = flight.sample(cfg.imu_rate_hz)
    data = generate_sensors(traj, imu_rate_hz=cfg.imu_rate_hz, gnss_rate_hz=cfg.gnss_rate_hz, noise=cfg.noise,
                            seed=cfg.seed, position_only=cfg.position_only)
    ekf = dataclasses.replace(demo_ekf(cfg, flight), record_covariance=True)
    if backend == "c":
        from nlobs.export import compile_observer

        ekf = compile_observer(ekf)
    R0 = rot_z(np.deg2rad(cfg.yaw_error_deg)) @ traj.R[0]
    return ekf, data, run_navigation(ekf, data, data.p_gnss[0], np.zeros(3), R0)


def test_the_navigation_ekf_records_the_nis_of_each_fix() -> None:
    """The NIS the filter records equals νᵀ S⁻¹ ν computed here from its state before the fix (S = H P Hᵀ + R)."""
    from nlobs.navigation.ekf import EkfState

    ekf, data, _ = _nav_run(2.0)
    st = ekf.init_state([1.0, 2.0, 3.0], [0.5, 0.0, 0.0], np.eye(3))
    P = st.P + 0.01 * np.ones((9, 9)) + np.diag(np.arange(1.0, 10.0))  # a full covariance
    st = EkfState(p=st.p, v=st.v, R=st.R, P=P, skipped=st.skipped, nis=st.nis)
    y = np.array([2.0, 1.0, 4.0, 0.2, 0.3, -0.1])
    c = ekf.config
    H = np.zeros((6, 9))
    H[:6, :6] = np.eye(6)
    S = H @ P @ H.T + np.diag([c.gnss_p_std**2] * 3 + [c.gnss_v_std**2] * 3)
    nu = y - np.r_[st.p, st.v]
    want = float(nu @ np.linalg.solve(S, nu))
    one = ekf.correct(0.0, st, np.zeros(9), y, np.ones(6, dtype=bool))  # the one-flight path
    assert float(one.nis) == pytest.approx(want, rel=1e-12)
    batched = ekf.correct(0.0, EkfState(p=st.p[None], v=st.v[None], R=st.R[None], P=P[None], skipped=st.skipped[None],
                                        nis=np.zeros(1)), np.zeros((1, 9)), y[None], np.ones(6, dtype=bool))
    assert float(batched.nis[0]) == pytest.approx(want, rel=1e-12)
    assert set(ekf.diagnostics(one, np.zeros(9))) == {"P_diag", "nis", "P"}


@pytest.mark.slow
def test_the_demo_ekf_is_consistent_after_it_converged() -> None:
    """Over 120 s of the demo's flight the EKF's NEES (its 9-dimensional error state) and the NIS of its fixes lie
    in the 95 % band about 95 % of the time once it converged, with means near 1 (measured 0.96 and 0.95, 1.0 and
    1.0 over the whole 369 s flight); the initial 60° yaw error is outside its covariance at first."""
    from nlobs.navigation.metrics import navigation_consistency

    _, data, res = _nav_run(120.0)
    c = navigation_consistency(res, data)
    late, late_nis = c.t > 30.0, c.t_nis > 30.0
    inside = np.mean((c.nees[late] >= c.nees_band[0]) & (c.nees[late] <= c.nees_band[1]))
    nis_inside = np.mean((c.nis[late_nis] >= c.nis_lo[late_nis]) & (c.nis[late_nis] <= c.nis_hi[late_nis]))
    assert 0.85 <= inside <= 1.0 and 0.85 <= nis_inside <= 1.0
    assert 0.7 < float(np.mean(c.nees[late])) < 1.4 and 0.7 < float(np.mean(c.nis[late_nis])) < 1.4
    assert float(np.max(c.nees[c.t < 2.0])) > c.nees_band[1]  # the 60° start is far outside its covariance
    assert c.to_dict()["nis_instants"] == int(np.isfinite(data.gnss_output()).all(axis=-1).sum())


@pytest.mark.slow
def test_the_compiled_navigation_ekf_gives_the_nees_alone() -> None:
    from nlobs.navigation.metrics import navigation_consistency

    _, data, res_py = _nav_run(20.0)
    _, _, res_c = _nav_run(20.0, backend="c")
    assert "nis" not in res_c.extras and "P" in res_c.extras
    c_py, c_c = navigation_consistency(res_py, data), navigation_consistency(res_c, data)
    np.testing.assert_allclose(c_c.nees, c_py.nees, rtol=1e-6)
    assert c_c.to_dict()["nis_inside"] is None and c_py.to_dict()["nis_inside"] is not None
