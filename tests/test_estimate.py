"""``nlobs estimate``: observers replayed on a logged run. The log here is a run of the shipped cart-pole simulated
by nlobs with its file's sensors (50 Hz encoders with noise) and process noise, written as CSV with empty fields
where no sample came; the estimates are checked against that run's truth, the residuals against the sensors' noise,
the filters' NIS against the χ² band."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from jsonschema import Draft202012Validator
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.cli.schema import command_schema
from nlobs.methods.estimation import estimate
from nlobs.simulate import simulate_plant
from nlobs.systems.modelfile import load_scenario

X_HAT0 = [0.05, -0.1, 3.1, 0.2]


def _log(path: Path, *, drop_every: int = 0, seconds: float = 10.0) -> tuple[Path, object]:
    """A cart-pole run as an engineer logs it: 100 Hz rows, the 50 Hz encoders' samples (``drop_every``: the pole
    encoder keeps one sample in that many), the force applied."""
    sc = load_scenario("cartpole")
    run = simulate_plant(sc.model.compile(), np.asarray(sc.defaults.x0, dtype=float), duration=seconds, dt=0.001,
                         u=sc.input_signals, measurements=sc.sensors, process_noise=sc.process_noise, seed=3,
                         save_every=10)
    res = run.result
    F = np.array([np.atleast_1d(sc.input_signals(t))[0] for t in res.t])
    lines = ["t,F,x_enc,th_enc"]
    kept = 0
    for k, t in enumerate(res.t):
        fields = []
        for j in range(2):
            keep = bool(res.sampled[k, j])
            if keep and j == 1 and drop_every:
                kept += 1
                keep = kept % drop_every == 1
            fields.append(repr(float(res.y[k, j])) if keep else "")
        lines.append(f"{float(t)!r},{float(F[k])!r},{fields[0]},{fields[1]}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path, res


@pytest.fixture(scope="module")
def logged(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    return _log(tmp_path_factory.mktemp("log") / "cartpole.csv")


@pytest.mark.slow
def test_the_estimates_of_a_logged_run_against_its_truth(logged: tuple[Path, object]) -> None:
    path, truth = logged
    report = estimate("cartpole", path, observers=["luenberger", "ekf", "pinv"], x_hat0=X_HAT0)
    assert report.log.samples == {"x_enc": 501, "th_enc": 501} and report.settle == 5.0
    assert report.observers["pinv"].skipped and "Q⁺ = Q⁻¹" in report.observers["pinv"].skipped
    late = truth.t >= 5.0
    noise = [0.001, 0.005]  # the file's encoders
    for name in ("luenberger", "ekf"):
        o = report.observers[name]
        err = np.sqrt(np.mean((np.asarray(o.result.x_hat) - truth.x)[late] ** 2, axis=0))
        assert err[0] < 0.003 and err[2] < 0.005, (name, err)  # cart [m], pole [rad], measured 5e-4..1e-3, 1.5e-3
        # the residuals after the settling time are the sensors' noise (the estimate follows the truth)
        for r, s in zip(o.residual_rms, noise):  # measured: luenberger 1.43 and 0.92, EKF 0.95 and 0.99 × noise
            assert (0.8 * s < r < 1.2 * s) if name == "ekf" else (0.6 * s < r < 1.6 * s), (name, o.residual_rms)
    ekf = report.observers["ekf"]
    assert ekf.sigma is not None and ekf.sigma.shape == (1001, 4)
    nis = ekf.consistency.to_dict()
    assert nis["nees_inside"] is None and 0.85 <= nis["nis_inside"] <= 1.0 and 0.7 < nis["nis_mean"] < 1.3
    # the EKF's 3σ covers its error most of the time after it converged
    e = np.abs(np.asarray(ekf.result.x_hat) - truth.x)[late]
    assert float(np.mean(e <= 3 * ekf.sigma[late])) > 0.95


@pytest.mark.slow
def test_the_designs_are_those_of_nlobs_simulate(logged: tuple[Path, object]) -> None:
    from nlobs.methods.comparison import compare_observers

    path, _ = logged
    rep = estimate("cartpole", path, observers=["luenberger"], x_hat0=X_HAT0)
    # the same problem: the log's force (held) over the log's 10 s, as a comparison given that input sees it
    force = path.parent / "force.csv"
    force.write_text("\n".join(",".join(line.split(",")[:2]) for line in path.read_text().splitlines()) + "\n")
    cmp = compare_observers("cartpole", observers=["luenberger"], runs=1, duration=10.0,
                            inputs={"F": f"csv:{force}:F"})
    np.testing.assert_array_equal(rep.observers["luenberger"].design.gain, cmp.observers["luenberger"].design.gain)


@pytest.mark.slow
def test_a_multi_rate_log_and_a_high_gain_observer_on_a_finer_step(tmp_path: Path) -> None:
    path, truth = _log(tmp_path / "slow.csv", drop_every=5, seconds=4.0)
    fine = estimate("cartpole", path, observers=["drift"], x_hat0=X_HAT0)
    assert fine.log.samples == {"x_enc": 201, "th_enc": 41}
    assert fine.observers["drift"].result is not None  # integrated with the file's dt = 1 ms between the rows
    coarse = estimate("cartpole", path, observers=["drift"], x_hat0=X_HAT0, dt=0.01)
    assert coarse.observers["drift"].result is None and "not finite" in coarse.observers["drift"].diverged


@pytest.mark.slow
def test_the_command_writes_the_files_and_its_json_follows_the_schema(logged: tuple[Path, object],
                                                                      tmp_path: Path) -> None:
    path, _ = logged
    res = CliRunner().invoke(app, ["estimate", "cartpole", "--data", str(path), "--observer", "luenberger,ekf",
                                   "--xhat0", ",".join(map(str, X_HAT0)), "--out", str(tmp_path / "out"), "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert list(Draft202012Validator(command_schema("estimate")).iter_errors(data)) == []
    assert data == json.loads((tmp_path / "out" / "estimate.json").read_text())
    head = (tmp_path / "out" / "estimates_ekf.csv").read_text().splitlines()
    assert head[0] == "t,x,v,th,w,sigma_x,sigma_v,sigma_th,sigma_w" and len(head) == 1002
    assert (tmp_path / "out" / "estimates_luenberger.csv").read_text().splitlines()[0] == "t,x,v,th,w"
    assert (tmp_path / "out" / "estimate.png").stat().st_size > 10_000


@pytest.mark.slow
def test_the_smoother_on_the_log_halves_the_filters_error_against_the_truth(logged: tuple[Path, object],
                                                                           tmp_path: Path) -> None:
    """The Rauch–Tung–Striebel smoother of the EKF on the whole log: after 5 s its error against the truth is about
    half the filter's in every state (measured 0.45–0.50), its ±3σ covers the error, and the command writes it."""
    path, truth = logged
    res = CliRunner().invoke(app, ["estimate", "cartpole", "--data", str(path), "--observer", "ekf",
                                   "--xhat0", ",".join(map(str, X_HAT0)), "--smooth", "--out", str(tmp_path / "out"),
                                   "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert list(Draft202012Validator(command_schema("estimate")).iter_errors(data)) == []
    assert data["observers"]["ekf"]["smoothed"]["method"] == "extended"
    head = (tmp_path / "out" / "estimates_ekf.csv").read_text().splitlines()
    assert head[0].endswith("sigma_w,x_smoothed,v_smoothed,th_smoothed,w_smoothed,sigma_x_smoothed,"
                            "sigma_v_smoothed,sigma_th_smoothed,sigma_w_smoothed")
    rows = np.array([[float(v) for v in line.split(",")] for line in head[1:]])
    late = truth.t >= 5.0
    filtered, smoothed, std = rows[:, 1:5], rows[:, 9:13], rows[:, 13:17]
    rms_f = np.sqrt(np.mean((filtered - truth.x)[late] ** 2, axis=0))
    rms_s = np.sqrt(np.mean((smoothed - truth.x)[late] ** 2, axis=0))
    assert np.all(rms_s < 0.6 * rms_f), (rms_s, rms_f)
    assert np.mean(np.abs(smoothed - truth.x)[late] <= 3 * std[late]) > 0.97


@pytest.mark.parametrize(("text", "message"), [
    ("t,F,x_enc,th_enc\n0,1,0,3\n0,1,0,3\n", "time 0 is not after the previous time 0"),
    ("t,F,x_enc,speed\n0,1,0,3\n", "column 'speed' is not an input or an output of the model"),
    ("t,F,x_enc,th_enc\n0,1,nan,3\n", "'nan' is not a finite number"),
    ("t,x_enc,th_enc\n0,0,3\n", "no column for the input 'F'"),
])
def test_a_bad_log_is_one_line_and_exit_2(tmp_path: Path, text: str, message: str) -> None:
    p = tmp_path / "bad.csv"
    p.write_text(text)
    res = CliRunner().invoke(app, ["estimate", "cartpole", "--data", str(p), "--observer", "luenberger"])
    assert res.exit_code == 2 and message in res.stderr and res.stderr.count("\n") == 1, res.output


def test_unknown_observer_and_missing_file_are_exit_2(tmp_path: Path) -> None:
    p = tmp_path / "log.csv"
    p.write_text("t,F,x_enc,th_enc\n0,1,0,3\n0.1,1,0,3\n")
    res = CliRunner().invoke(app, ["estimate", "cartpole", "--data", str(p), "--observer", "kalman"])
    assert res.exit_code == 2 and "'kalman' is not an observer nlobs designs" in res.stderr
    res = CliRunner().invoke(app, ["estimate", "cartpole", "--data", str(tmp_path / "none.csv")])
    assert res.exit_code == 2 and "none.csv" in res.stderr
