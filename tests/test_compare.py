"""``nlobs simulate MODEL``: every observer on the same runs, metrics against closed forms, skips, divergence, files."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.simulate import SimulationResult
from nlobs.systems.modelfile import parse_scenario
from nlobs.workflows.compare import compare_observers
from nlobs.workflows.verdict import Verdict

runner = CliRunner()

LINEAR = '''name = "osc"
states = ["p", "v"]
outputs = ["y"]
units = { p = "m", v = "m/s", y = "m" }
[linear]
A = [[0.0, 1.0], [-2.0, -0.5]]
C = [[1.0, 0.0]]
'''

PEND = '''name = "pend"
states = ["theta", "omega"]
inputs = ["tau"]
outputs = ["y"]
[dynamics]
f = ["omega", "-9.81*sin(theta) - 0.2*omega"]
g = [["0"], ["1"]]
h = ["theta"]
[sensors.enc]
outputs = ["y"]
rate = 50.0
noise_std = 0.01
[input_signals]
tau = { kind = "sine", amplitude = 0.5, frequency = 0.3 }
[process_noise]
std = [0.0, 0.02]
[simulation]
x0 = [0.5, 0.0]
initial_error_std = [0.2, 0.2]
duration = 4.0
dt = 0.002
box = [-2, 2]
'''


@pytest.mark.slow
def test_same_truth_and_noise_for_every_observer() -> None:
    # luenberger through the output predictor (not the impulsive form, which jumps at t = 0 like the EKF)
    rep = compare_observers(parse_scenario(PEND), observers=["ekf", "luenberger", "drift"], runs=4, seed=11,
                            design_options={"luenberger": {"sampling": "predictor"}})
    results = [o.result for o in rep.observers.values() if o.result is not None]
    assert len(results) == 3
    for r in results[1:]:
        np.testing.assert_array_equal(r.x, results[0].x)  # the same truth, process noise included
        np.testing.assert_array_equal(r.y, results[0].y)  # the same sensor samples
        np.testing.assert_array_equal(r.sampled, results[0].sampled)
    assert not np.array_equal(results[0].x[0], results[0].x[1])  # the runs differ (process noise)
    x_hat0 = np.stack([r.x_hat[:, 0] for r in results[1:]])  # the EKF's first value is already corrected
    np.testing.assert_array_equal(x_hat0[1], x_hat0[0])  # the same initial estimates
    # the noise realisation follows the seed
    again = compare_observers(parse_scenario(PEND), observers=["luenberger"], runs=4, seed=11)
    np.testing.assert_array_equal(again.observers["luenberger"].result.x, results[0].x)


def test_drift_design_takes_the_input_bound_of_the_run() -> None:
    """μ of (2.17) is the largest ‖u(t)‖ of the run's input (0.5 for this sine), so ‖u‖ ≤ μ holds by construction."""
    rep = compare_observers(parse_scenario(PEND), observers=["drift"], runs=2, seed=1)
    cert = rep.observers["drift"].certificate
    assert cert["mu"] == pytest.approx(0.5, rel=1e-6)
    assert cert["verified"] is True and cert["covers_run"] is False  # noise: outside Theorem 3.1
    assert not any("μ" in r for r in cert["reasons"])
    assert any("measurement noise" in r for r in cert["reasons"])


def test_metrics_on_a_linear_plant_equal_the_closed_form() -> None:
    """Exact measurement, Luenberger observer: e(t) = expm((A − LC) t) e0; the RMS and final errors follow."""
    rep = compare_observers(parse_scenario(LINEAR), observers=["luenberger"], runs=6, duration=3.0, dt=1e-3,
                            x0=[1.0, 0.0], settle=1.0, seed=2)
    o = rep.observers["luenberger"]
    res = o.result
    assert o.certificate["covers_run"] is True and o.certificate["reasons"] == []
    A = np.array([[0.0, 1.0], [-2.0, -0.5]])
    C = np.array([[1.0, 0.0]])
    e0 = res.x_hat[:, 0] - res.x[:, 0]
    lin_gain = o.observer.L
    Fm = A - lin_gain @ C
    want = np.einsum("kij,bj->bki", sla.expm(res.t[:, None, None] * Fm), e0)
    np.testing.assert_allclose(res.error, want, atol=1e-8)
    after = res.t >= 1.0 - 1e-12
    np.testing.assert_allclose(o.rms_error, np.sqrt(np.mean(want[:, after] ** 2, axis=(0, 1))), rtol=1e-6)
    en = np.linalg.norm(want, axis=-1)
    assert o.final_error_norm == pytest.approx(np.sqrt(np.mean(en[:, -1] ** 2)), rel=1e-6)
    assert o.rms_error_norm_all == pytest.approx(np.sqrt(np.mean(en**2)), rel=1e-6)
    assert o.diverged_runs == ()
    assert o.cost_per_step_us > 0


def test_skips_say_why() -> None:
    rep = compare_observers(parse_scenario(LINEAR), observers=["drift", "pinv", "cascade", "ekf", "ukf"], runs=2,
                            duration=1.0)
    assert rep.verdict is Verdict.NO_OBSERVER
    assert "linear" in rep.observers["drift"].skipped and "linear" in rep.observers["pinv"].skipped
    assert "Σ₁" in rep.observers["cascade"].skipped
    for k in ("ekf", "ukf"):
        assert "sampled, noisy measurements" in rep.observers[k].skipped
    res = runner.invoke(app, ["simulate", "pendulum", "--observer", "cascade", "--runs", "2", "--duration", "1"])
    assert res.exit_code == 3 and "none of the observers applies" in res.stderr


def test_rossler_drift_design_fails_with_the_reason() -> None:
    rep = compare_observers("rossler", observers=["drift", "pinv"], runs=2, duration=1.0)
    assert "(2.17)" in rep.observers["drift"].skipped
    assert "A1 fails" in rep.observers["pinv"].skipped


def test_diverging_runs_are_named_and_the_others_kept() -> None:
    """x' = −x + x³, truth at 0: the constant-gain copy blows up in finite time from a large initial estimate."""
    text = '''name = "cubic"
states = ["x"]
outputs = ["y"]
[dynamics]
f = ["-x + x**3"]
h = ["x"]
'''
    rep = compare_observers(parse_scenario(text), observers=["luenberger"], runs=40, duration=3.0, dt=1e-3,
                            x0=[0.0], initial_error_std=2.5, seed=4)
    o = rep.observers["luenberger"]
    x_hat0 = o.result.x_hat[:, 0, 0]
    named = {d.run for d in o.diverged_runs}
    assert 0 < len(named) < 40
    # exact measurement y = x = 0: the copy x̂' = −(1 + L) x̂ + x̂³ blows up exactly when |x̂(0)| > √(1 + L)
    threshold = np.sqrt(1.0 + float(o.observer.L[0, 0]))
    clear = np.abs(np.abs(x_hat0) - threshold) > 1e-3 * threshold
    assert {i for i in named if clear[i]} == set(np.flatnonzero(clear & (np.abs(x_hat0) > threshold)))
    finite = np.isfinite(o.result.x_hat).all(axis=(1, 2))
    assert finite[sorted(set(range(40)) - named)].all()
    assert np.isfinite(o.rms_error_norm)
    assert all(d.time > 0 for d in o.diverged_runs)


DISCRETE = '''name = "dlin"
time = "discrete"
dt = 0.1
states = ["p", "v"]
inputs = ["a"]
outputs = ["y1", "y2"]
[linear]
A = [[1.0, 0.1], [-0.2, 0.95]]
B = [[0.005], [0.1]]
C = [[1.0, 0.0], [0.5, 1.0]]
[sensors.pos]
outputs = ["y1", "y2"]
rate = 10.0
noise_cov = [[0.04, 0.01], [0.01, 0.09]]
[input_signals]
a = { kind = "sine", amplitude = 1.0, frequency = 0.1 }
[process_noise]
covariance = [[0.001, 0.0], [0.0, 0.004]]
'''


def test_the_filters_in_the_comparison_equal_filterpy_on_its_recorded_measurements() -> None:
    """A discrete linear model: EKF and UKF of the comparison, fed with R, Q, P0 from the file, equal filterpy's
    Kalman filter run here on the same recorded samples and inputs (a second implementation)."""
    from filterpy.kalman import KalmanFilter

    rep = compare_observers(parse_scenario(DISCRETE), observers=["ekf", "ukf"], runs=3, duration=6.0, x0=[1.0, 0.0],
                            x_hat0=[0.0, 0.5], initial_error_std=[0.7, 0.4], seed=9)
    A = np.array([[1.0, 0.1], [-0.2, 0.95]])
    B = np.array([[0.005], [0.1]])
    C = np.array([[1.0, 0.0], [0.5, 1.0]])
    for name in ("ekf", "ukf"):
        res = rep.observers[name].result
        assert res.sampled.all()
        for run in range(3):
            kf = KalmanFilter(dim_x=2, dim_z=2, dim_u=1)
            kf.F, kf.B, kf.H = A, B, C
            kf.Q = np.diag([0.001, 0.004])
            kf.R = np.array([[0.04, 0.01], [0.01, 0.09]])
            kf.x = np.array([0.0, 0.5])
            kf.P = np.diag([0.7**2, 0.4**2])
            for k, t in enumerate(res.t):
                kf.update(res.y[run, k])
                np.testing.assert_allclose(res.x_hat[run, k], kf.x, atol=1e-10)
                kf.predict(u=np.array([np.sin(2 * np.pi * 0.1 * t)]))


JSON_KEYS = {"skipped", "rms_error", "rms_error_norm", "final_error_norm", "diverged_runs", "cost_per_step_us"}


@pytest.mark.slow
def test_cli_json_keys_and_files(tmp_path: Path) -> None:
    model = tmp_path / "pend.toml"
    model.write_text(PEND)
    out = tmp_path / "out"
    res = runner.invoke(app, ["simulate", str(model), "--observer", "pinv,ekf,luenberger,cascade", "--runs", "3",
                              "--json", "--out", str(out)])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert {"observers", "runs", "seed", "states"} <= set(d)
    assert d["runs"] == 3 and d["seed"] == 0 and d["states"] == ["theta", "omega"]
    assert list(d["observers"]) == ["pinv", "ekf", "luenberger", "cascade"]
    # the pendulum's Σ r_j = n: Röbenack's reduced observer does not apply (as nlobs advise says)
    assert d["observers"]["pinv"]["skipped"].startswith("Σ r_j = 2 is not < n = 2")
    for name in ("ekf", "luenberger"):
        o = d["observers"][name]
        assert JSON_KEYS <= set(o) and o["skipped"] is None and len(o["rms_error"]) == 2
    assert d["observers"]["cascade"]["skipped"]
    for f in ("states.png", "error_norms.png", "rms_boxplot.png", "ekf.npz", "luenberger.npz", "trajectories.csv",
              "compare.json"):
        assert (out / f).is_file(), f
    assert json.loads((out / "compare.json").read_text())["observers"]["ekf"]["rms_error"] == d["observers"]["ekf"]["rms_error"]
    back = SimulationResult.load(out / "ekf.npz")
    rows = list(csv.reader((out / "trajectories.csv").open()))
    assert rows[0][:3] == ["t", "x_theta", "x_omega"] and "ekf_theta" in rows[0]
    assert len(rows) - 1 == back.t.size
    np.testing.assert_allclose([float(r[1]) for r in rows[1:]], back.x[0, :, 0], rtol=1e-15)


def test_shorthand_and_subcommand_are_the_same_and_setvalued_stays() -> None:
    a = runner.invoke(app, ["simulate", "pendulum", "--observer", "luenberger", "--runs", "2", "--duration", "1",
                            "--json"])
    b = runner.invoke(app, ["simulate", "compare", "pendulum", "--observer", "luenberger", "--runs", "2",
                            "--duration", "1", "--json"])
    assert a.exit_code == b.exit_code == 0
    da, db = json.loads(a.stdout), json.loads(b.stdout)
    assert da["observers"]["luenberger"]["rms_error"] == db["observers"]["luenberger"]["rms_error"]
    res = runner.invoke(app, ["simulate", "setvalued", "--help"])
    assert res.exit_code == 0 and "Algorithm 1" in res.output
