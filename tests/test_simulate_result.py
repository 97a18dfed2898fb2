"""SimulationResult: metrics against closed forms, .npz round trip, atomic writes, plots."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest

from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.observers.luenberger import LuenbergerObserver
from nlobs.simulate import MeasurementGroup, SimulationResult, simulate
from nlobs.simulate import metrics as M
from nlobs.systems.linear import LinearSystem


def _synthetic(rates: np.ndarray, t: np.ndarray) -> SimulationResult:
    """Error e_i(t) = exp(-rate t) on every state (x = 0, x_hat = e), one trajectory per rate."""
    e = np.exp(-np.multiply.outer(rates, t))[..., None] * np.array([1.0, 0.0])
    return SimulationResult(
        t=t,
        x=np.zeros_like(e),
        x_hat=e,
        y=np.zeros((rates.size, t.size, 1)),
        sampled=np.ones((t.size, 1), dtype=bool),
        states=("a", "b"),
        outputs=("y",),
        estimates=("a", "b"),
        dt=float(t[1] - t[0]),
        method="synthetic",
    )


def test_metrics_match_closed_forms() -> None:
    t = np.linspace(0.0, 5.0, 5001)
    rates = np.array([0.5, 2.0])
    res = _synthetic(rates, t)
    m = res.metrics(tol=1e-2, after=1.0)
    # RMSE of exp(-r t) over [1, 5]: sqrt( (e^{-2r} - e^{-10r}) / (2r · 4) ), up to the sample-mean error.
    exact = np.sqrt((np.exp(-2 * rates) - np.exp(-10 * rates)) / (2 * rates * 4.0))
    np.testing.assert_allclose(m.rmse[:, 0], exact, rtol=2e-3)
    np.testing.assert_array_equal(m.rmse[:, 1], 0.0)
    np.testing.assert_allclose(m.final_error_norm, np.exp(-5 * rates), rtol=1e-12)
    # exp(-r t) < 1e-2 from t = ln(100)/r on (only 2.0 reaches it within 5 s).
    assert np.isnan(m.time_to_tolerance[0])
    assert m.time_to_tolerance[1] == pytest.approx(np.log(100) / 2.0, abs=1e-3)
    np.testing.assert_allclose(m.decay_rate, rates, rtol=1e-9)


def test_time_to_tolerance_requires_staying_below() -> None:
    t = np.arange(6.0)
    enorm = np.array([5.0, 0.5, 2.0, 0.5, 0.4, 0.3])
    assert M.time_to_tolerance(t, enorm, 1.0) == 3.0
    assert np.isnan(M.time_to_tolerance(t, enorm, 0.1))
    assert M.time_to_tolerance(t, enorm, 10.0) == 0.0
    with pytest.raises(InvalidArgumentError, match="tol"):
        M.time_to_tolerance(t, enorm, -1.0)


def test_decay_rate_floor_and_window() -> None:
    t = np.linspace(0.0, 10.0, 1001)
    # Decays at rate 3 until it hits a noise floor of 1e-6.
    enorm = np.maximum(np.exp(-3.0 * t), 1e-6)
    assert float(M.decay_rate(t, enorm, floor=2e-6)) == pytest.approx(3.0, rel=1e-9)
    assert float(M.decay_rate(t, enorm, t_max=4.0)) == pytest.approx(3.0, rel=1e-9)
    assert float(M.decay_rate(t, enorm)) < 2.0  # the floor biases an unwindowed fit
    assert np.isnan(M.decay_rate(t, np.zeros_like(t)))


def test_error_requires_matching_dimensions() -> None:
    res = simulate(LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]]), None, [1.0], duration=0.1, dt=0.01)
    with pytest.raises(DimensionError, match="undefined"):
        res.error  # noqa: B018


def _small_run() -> SimulationResult:
    A = np.array([[0.0, 1.0], [-4.0, -0.4]])
    sys_ = LinearSystem(A, [[0.0], [1.0]], [[1.0, 0.0]], states=("pos", "vel"), outputs=("gps",))
    obs = LuenbergerObserver(sys_, [[3.0], [2.0]])
    return simulate(
        sys_,
        obs,
        [[1.0, 0.0], [0.5, -1.0], [-0.5, 0.5]],
        [0.0, 0.0],
        duration=8.0,
        dt=2e-3,
        u=lambda t: np.array([np.sin(t)]),
        measurements=[MeasurementGroup("gps", ["gps"], rate=10.0, noise_std=1e-3)],
        seed=0,
    )


def test_result_is_immutable() -> None:
    res = _small_run()
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.t = np.zeros(3)  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        res.x[0, 0, 0] = 1.0


def test_save_load_round_trip(tmp_path: Path) -> None:
    res = _small_run()
    path = res.save(tmp_path / "run.npz")
    back = SimulationResult.load(path)
    for f in dataclasses.fields(SimulationResult):
        a, b = getattr(res, f.name), getattr(back, f.name)
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)
            assert a.dtype == b.dtype
        else:
            assert a == b
    assert sorted(os.listdir(tmp_path)) == ["run.npz"]
    np.savez(tmp_path / "other.npz", t=np.zeros(2))
    with pytest.raises(InvalidArgumentError, match="format"):
        SimulationResult.load(tmp_path / "other.npz")


@pytest.mark.parametrize("fail_in", ["savez", "replace"])
def test_atomic_save_leaves_target_untouched_on_failure(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fail_in: str) -> None:
    target = tmp_path / "run.npz"
    target.write_bytes(b"previous contents")

    def boom(*args: object, **kwargs: object) -> None:
        raise OSError("disk full (simulated)")

    if fail_in == "savez":
        monkeypatch.setattr(np, "savez", boom)
    else:
        monkeypatch.setattr(os, "replace", boom)
    res = _synthetic(np.array([1.0]), np.linspace(0.0, 1.0, 11))
    with pytest.raises(OSError, match="simulated"):
        res.save(target)
    assert target.read_bytes() == b"previous contents"
    assert os.listdir(tmp_path) == ["run.npz"]  # no temporary file left behind


def test_plot_writes_a_png(tmp_path: Path) -> None:
    res = _small_run()
    path = tmp_path / "sim.png"
    fig = res.plot(path, states=["pos", 1])
    assert path.exists() and path.stat().st_size > 10_000
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    axes = fig.get_axes()
    assert len(axes) == 3
    assert axes[-1].get_yscale() == "log"
    assert [ax.get_ylabel() for ax in axes[:2]] == ["pos", "vel"]
    labels = axes[0].get_legend_handles_labels()[1]
    assert labels == ["true", "estimate"]
    assert axes[-1].get_xlabel() == "time [s]"
    # with the model file's units: every axis names its unit, the error axis the shared one
    fig = res.plot(states=["pos", 1], units={"t": "h", "pos": "m", "vel": "m"})
    axes = fig.get_axes()
    assert [ax.get_ylabel() for ax in axes] == ["pos [m]", "vel [m]", "‖x̂ − x‖ [m]"]
    assert axes[-1].get_xlabel() == "time [h]"
    fig = res.plot(states=["pos", 1], units={"pos": "m", "vel": "m/s"})
    assert fig.get_axes()[-1].get_ylabel() == "‖x̂ − x‖"  # no shared unit


def test_export_to_dict_csv_and_xarray(tmp_path: Path) -> None:
    import csv
    import json

    res = _small_run()  # 3 runs, multi-rate output (10 Hz on a 2 ms grid)
    d = res.to_dict()
    json.dumps(d, allow_nan=False)  # plain JSON
    assert d["states"] == ["pos", "vel"] and np.array_equal(np.asarray(d["x_hat"]), res.x_hat)
    assert len(d["t"]) == res.t.size and d["dt"] == res.dt
    # CSV of run 1: t, the true states, the estimates, the output where it was sampled
    path = res.to_csv(tmp_path / "run1.csv", run=1)
    rows = list(csv.reader(path.open()))
    assert rows[0] == ["t", "pos", "vel", "pos_hat", "vel_hat", "gps"]
    body = np.array([[float(c) if c else np.nan for c in r] for r in rows[1:]])
    np.testing.assert_array_equal(body[:, 0], res.t)
    np.testing.assert_array_equal(body[:, 1:3], res.x[1])
    np.testing.assert_array_equal(body[:, 3:5], res.x_hat[1])
    sampled = res.sampled[1][:, 0] if res.sampled.ndim > 2 else res.sampled[:, 0]
    assert np.isnan(body[~sampled, 5]).all() and np.isfinite(body[sampled, 5]).all()
    with pytest.raises(InvalidArgumentError, match="out of range"):
        res.to_csv(tmp_path / "bad.csv", run=7)
    assert not (tmp_path / "bad.csv").exists()
    xr = pytest.importorskip("xarray")
    ds = res.to_xarray()
    assert isinstance(ds, xr.Dataset) and ds.sizes["time"] == res.t.size and ds.sizes["run0"] == 3
    np.testing.assert_array_equal(ds["x_hat"].sel(estimate="vel").values, res.x_hat[..., 1])
    np.testing.assert_array_equal(ds["x"].sel(state="pos").isel(run0=2).values, res.x[2, :, 0])
    np.testing.assert_array_equal(ds["time"].values, res.t)
    assert ds.attrs["dt"] == res.dt
