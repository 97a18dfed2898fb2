"""Monte Carlo flights of the GNSS/INS observer (24) of Grip, Saberi & Johansen: the study, the workflow, the command.

* the numbers do not depend on where they ran: in this process with chunk = batch, with a chunk of 7
  (not a multiple of the batch), on a 2-worker local Dask cluster — bitwise;
* one batch recomputed by hand with :func:`run_navigation` from the batch's generator, drawn in the
  documented order, gives the same final attitude errors;
* the paper's claim of global convergence (Theorems 1–3 with Lemma 1): with the paper's gains, attitude
  errors up to 180° and 100 m position errors, every flight of 60 s converges below 5° (the global
  benchmark measures the worst at about 40 s);
* ``nlobs simulate gnss-ins``: its JSON keys, exit 1 when flights did not converge, exit 2 with one line
  on bad input, and a ``--help`` without the numeric stack.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.errors import InvalidArgumentError, OutputError
from nlobs.navigation import GnssInsStudy, metrics
from nlobs.navigation.gains import PAPER_GAMMA, paper_gains
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation.run import run_navigation
from nlobs.navigation.sensors import generate_sensors
from nlobs.navigation.so3 import exp_so3
from nlobs.navigation.trajectory import traffic_pattern
from nlobs.simulate.executors import cluster
from nlobs.simulate.montecarlo import batch_rng, monte_carlo
from nlobs.workflows import Verdict, gnss_ins_monte_carlo
from nlobs.workflows.demo import DEMO_NOISE

SRC = Path(__file__).resolve().parents[1] / "src"
runner = CliRunner()


def _bits(summaries: dict[str, np.ndarray]) -> dict[str, bytes]:
    return {k: np.ascontiguousarray(v).tobytes() for k, v in summaries.items()}


@pytest.mark.slow
def test_summaries_are_bitwise_the_same_whatever_the_chunk_and_the_workers(tmp_path: Path) -> None:
    study = GnssInsStudy(DEMO_NOISE, duration=10.0, gains="scheduled", attitude_error_deg=120.0, position_error_m=20.0,
                         trajectory_every=25).solved()  # the SDP's gain solved once, sent with the recipe
    assert study.axis_gain is not None
    whole = monte_carlo(study, 23, seed=5, batch=10, progress=False)  # chunk = batch, the last batch cut
    assert whole.chunk == 10 and whole.chunks == 3
    assert set(whole.summaries) == {"final_attitude_error_deg", "converged", "converge_s", "rms_position_m",
                                    "rms_velocity_mps", "rms_attitude_deg", "diverged"}
    assert all(v.shape == (23,) for v in whole.summaries.values())
    sevens = monte_carlo(study, 23, seed=5, batch=10, chunk=7, out=tmp_path / "sevens", trajectories=True,
                         progress=False)
    with cluster(workers=2) as client:
        dask = monte_carlo(study, 23, seed=5, batch=10, chunk=7, executor=client, progress=False)
    assert dask.executor == "dask" and dask.workers == 2
    assert _bits(whole.summaries) == _bits(sevens.summaries) == _bits(dask.summaries)
    assert np.isfinite(whole.summaries["final_attitude_error_deg"]).all()
    assert not whole.summaries["diverged"].any()
    # another seed or batch width gives other numbers
    other = monte_carlo(study, 23, seed=6, batch=10, progress=False)
    assert _bits(other.summaries)["final_attitude_error_deg"] != _bits(whole.summaries)["final_attitude_error_deg"]
    # trajectories, subsampled consistently: (runs, ceil(K / every), 15), the same flight's truth in every run
    x_hat, x = sevens.trajectories("x_hat"), sevens.trajectories("x")
    K = 1001  # 10 s at 100 Hz
    assert x_hat.shape == x.shape == (23, -(-K // 25), 15)
    assert np.array_equal(x[0], x[22])
    again = monte_carlo(study, 23, seed=5, batch=10, out=tmp_path / "tens", trajectories=True, progress=False)
    assert again.trajectories("x_hat").tobytes() == x_hat.tobytes()


def test_one_batch_recomputed_by_hand_from_the_batch_generator() -> None:
    """Independent of the study's code: the flight, the observer and the draws written out here."""
    duration, runs, seed, max_deg, pos_m = 8.0, 12, 3, 150.0, 50.0
    study = GnssInsStudy(DEMO_NOISE, duration=duration, gains="paper", attitude_error_deg=max_deg,
                         position_error_m=pos_m)
    got = monte_carlo(study, runs, seed=seed, batch=runs, progress=False).summaries

    flight = traffic_pattern(seed=0, duration=duration)
    traj = flight.sample(100.0)
    rng = batch_rng(seed, 0)
    data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=DEMO_NOISE, seed=rng, batch=runs)
    axis = rng.normal(size=(runs, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    angle = np.deg2rad(rng.uniform(0.0, max_deg, size=(runs, 1)))
    R0 = exp_so3(axis * angle) @ traj.R[0]
    d = rng.normal(size=(runs, 3))
    p0 = traj.p[0] + pos_m * d / np.linalg.norm(d, axis=-1, keepdims=True)
    res = run_navigation(GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n), data, p0,
                         data.v_gnss[:, 0], R0)
    err = metrics.attitude_error_deg(res)
    np.testing.assert_array_equal(got["final_attitude_error_deg"], err[:, -1])
    np.testing.assert_array_equal(got["converge_s"], metrics.converge_s(res, 5.0))
    np.testing.assert_array_equal(got["rms_position_m"], metrics.position_rms_m(res, after=duration - 4.0))
    # the initial errors are what was asked: the first recorded attitude error is the drawn angle
    np.testing.assert_allclose(err[:, 0], np.degrees(angle[:, 0]), atol=1e-6)
    np.testing.assert_allclose(metrics.position_error_m(res)[:, 0], pos_m, rtol=1e-12)


@pytest.mark.slow
def test_paper_gains_converge_globally_from_errors_up_to_180_degrees(tmp_path: Path) -> None:
    report = gnss_ins_monte_carlo(flights=48, duration=60.0, seed=2, gains="paper", attitude_error_deg=180.0,
                                  position_error_m=100.0, batch=24, out=tmp_path, progress=False)
    s = report.result.summaries
    assert report.verdict is Verdict.OK and report.message == ""
    assert report.converged == 48 and report.diverged == 0
    assert np.all(s["final_attitude_error_deg"] < 5.0)
    assert np.nanmax(s["converge_s"]) < 50.0
    text = report.summary()
    assert "48/48 (100.0 %)" in text and "paper gains" in text
    assert report.figure == tmp_path / "gnss_ins_monte_carlo.png" and report.figure.stat().st_size > 10_000
    assert (tmp_path / "runs" / "montecarlo.json").is_file()
    assert len(list((tmp_path / "runs" / "chunks").glob("chunk-*.npz"))) == 2
    d = json.loads(json.dumps(report.to_dict(), allow_nan=False))
    assert d["converged_fraction"] == 1.0 and d["verdict"] == "ok"
    # the same folder again resumes: no chunk recomputed, the same numbers
    again = gnss_ins_monte_carlo(flights=48, duration=60.0, seed=2, gains="paper", attitude_error_deg=180.0,
                                 position_error_m=100.0, batch=24, out=tmp_path, progress=False)
    assert again.result.resumed_chunks == 2 and _bits(again.result.summaries) == _bits(s)


def test_short_flights_fail_and_say_so() -> None:
    report = gnss_ins_monte_carlo(flights=4, duration=3.0, gains="noise-optimal", progress=False)
    assert report.verdict is Verdict.FAILED
    assert f"{4 - report.converged} of 4 flights did not converge below 5° within 3 s" in report.message
    assert f"{report.converged}/4" in report.summary()


def test_the_key_covers_every_field_and_bad_values_are_refused() -> None:
    base = GnssInsStudy(DEMO_NOISE)
    changes = {"noise": dataclasses.replace(DEMO_NOISE, mag_std=0.02), "duration": 30.0, "flight_seed": 1,
               "imu_rate_hz": 200.0, "gnss_rate_hz": 10.0, "gains": "paper", "attitude_error_deg": 45.0,
               "position_error_m": 1.0, "converge_deg": 2.0, "tail_s": 10.0, "trajectory_every": 1,
               "default_batch": 7, "axis_gain": ((1.0, 0.1), (0.5, 0.2), (0.01, 0.001))}
    assert set(changes) == {f.name for f in dataclasses.fields(GnssInsStudy)}
    keys = {dataclasses.replace(base, **{k: v}).key() for k, v in changes.items()}
    assert len(keys) == len(changes) and base.key() not in keys
    assert GnssInsStudy(DEMO_NOISE).key() == base.key()
    for bad in ({"gains": "nope"}, {"attitude_error_deg": 181.0}, {"position_error_m": -1.0}, {"duration": 0.0},
                {"tail_s": 100.0}, {"trajectory_every": 0}, {"converge_deg": 0.0}):
        with pytest.raises(InvalidArgumentError):
            GnssInsStudy(DEMO_NOISE, **bad)
    with pytest.raises(InvalidArgumentError):
        GnssInsStudy("noise")  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="give one"):
        gnss_ins_monte_carlo(flights=2, duration=2.0, executor=object(), workers=2)
    with pytest.raises(InvalidArgumentError, match="output folder"):
        gnss_ins_monte_carlo(flights=2, duration=2.0, trajectories=True)


def test_an_unwritable_out_is_an_output_error(tmp_path: Path) -> None:
    f = tmp_path / "a-file"
    f.write_text("x")
    with pytest.raises(OutputError):
        gnss_ins_monte_carlo(flights=2, duration=2.0, out=f, progress=False)


def test_cli_json_and_exit_statuses(tmp_path: Path) -> None:
    res = runner.invoke(app, ["simulate", "gnss-ins", "--flights", "6", "--duration", "20", "--gains", "paper",
                              "--attitude-error", "10", "--batch", "3", "--chunk", "2", "--out", str(tmp_path / "o"),
                              "--no-progress", "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert {"schema_version", "setup", "converged", "converged_fraction", "diverged", "statistics", "executor",
            "workers", "batch", "chunk", "chunks", "seconds", "out", "figure", "verdict", "message"} <= set(d)
    assert d["setup"]["flights"] == 6 and d["batch"] == 3 and d["chunk"] == 2 and d["chunks"] == 3
    assert d["verdict"] == "ok" and Path(d["figure"]).is_file()
    failed = runner.invoke(app, ["simulate", "gnss-ins", "--flights", "2", "--duration", "2", "--no-progress"])
    assert failed.exit_code == 1 and "did not converge" in failed.stderr
    assert "converged (attitude error below 5° for good): 0/2" in failed.stdout


@pytest.mark.parametrize("args", [["--flights", "0"], ["--gains", "nope"], ["--workers", "1", "--scheduler", "x"],
                                  ["--attitude-error", "200"], ["--trajectories"], ["--out", "FILE"]],
                         ids=lambda a: " ".join(a))
def test_cli_bad_input_is_exit_2_with_one_line(args: list[str], tmp_path: Path) -> None:
    f = tmp_path / "a-file"
    f.write_text("x")
    args = [str(f) if a == "FILE" else a for a in args]
    res = runner.invoke(app, ["simulate", "gnss-ins", "--duration", "2", "--flights", "2", *args, "--no-progress"])
    assert res.exit_code == 2, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("nlobs: error:"), res.stderr
    assert "Traceback" not in res.output


def test_the_help_loads_no_numeric_library() -> None:
    code = ("import json, sys\nfrom nlobs.cli import app\nsys.argv[0] = 'nlobs'\ntry:\n    app()\nexcept SystemExit:\n"
            "    pass\nprint(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in "
            "{'numpy', 'scipy', 'sympy', 'matplotlib', 'cvxpy'})))")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.run([sys.executable, "-c", code, "simulate", "gnss-ins", "--help"], env=env,
                          capture_output=True, text=True, timeout=120, check=True)
    assert "--attitude-error" in proc.stdout
    assert json.loads(proc.stdout.strip().splitlines()[-1]) == []


@pytest.mark.filterwarnings("ignore:Input .a. has an eigenvalue pair:RuntimeWarning")
def test_a_given_gain_is_reverified_and_a_bad_one_refused() -> None:
    from nlobs.errors import DesignInfeasible

    study = GnssInsStudy(DEMO_NOISE, duration=2.0, gains="noise-optimal")
    solved = study.solved()
    assert solved.solved() is solved and GnssInsStudy(DEMO_NOISE, gains="paper").solved().axis_gain is None
    # the gain given in the recipe is the one flown (kron(K3, I3))
    np.testing.assert_array_equal(solved.prepare().observer.K, np.kron(np.array(solved.axis_gain), np.eye(3)))
    unstable = dataclasses.replace(solved, axis_gain=((-1.0, 0.0), (0.0, -1.0), (0.0, 0.0)))
    with pytest.raises(DesignInfeasible, match="certificate"):
        unstable.prepare()
    with pytest.raises(InvalidArgumentError, match="paper"):
        GnssInsStudy(DEMO_NOISE, gains="paper", axis_gain=solved.axis_gain)
    with pytest.raises(InvalidArgumentError, match="3×2"):
        GnssInsStudy(DEMO_NOISE, axis_gain=((1.0,), (2.0,), (3.0,)))
