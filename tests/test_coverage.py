"""The certificate monitor: hypotheses checked along every run; first violations against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nlobs import LinearSystem, LuenbergerObserver
from nlobs.simulate import simulate
from nlobs.simulate.coverage import InputBound, InRegion, Premise, monitor
from nlobs.systems.modelfile import parse_scenario
from nlobs.workflows.compare import compare_observers

OSC = LinearSystem([[0.0, 1.0], [-1.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]])


def _runs() -> object:
    obs = LuenbergerObserver(OSC, [[2.0], [1.0]])
    x0 = np.array([[1.0, 0.0], [0.5, 0.0]])  # x1(t) = a cos t
    return simulate(OSC, obs, x0, [0.0, 0.0], duration=7.0, dt=0.01, u=0.0)


def test_first_leaving_of_the_region_is_the_closed_form_time() -> None:
    res = _runs()
    cov = monitor(res, [InRegion(np.array([-0.6, -2.0]), np.array([1.0, 2.0]), "state", "B")])
    # run 0: cos t < −0.6 first at t = acos(−0.6) = 2.2143; run 1: 0.5 cos t ≥ −0.5 always inside
    (v,) = cov.violations
    assert v.run == 0 and v.hypothesis == "state in the region B"
    assert v.time == pytest.approx(math.ceil(math.acos(-0.6) / 0.01) * 0.01, abs=1e-9)
    assert "x1 = " in v.detail
    assert cov.covered_runs == 1 and cov.covered_fraction == 0.5 and not cov.covers_run
    d = cov.to_dict()
    assert d["certificate_covers_run"] is False and d["certificate_covered_fraction"] == 0.5
    assert d["certificate_violations"][0]["run"] == 0


def test_input_bound_and_premises() -> None:
    res = _runs()
    cov = monitor(res, [InputBound(0.5)], u=lambda t: np.array([0.8 * math.sin(t)]))
    # 0.8 |sin t| > 0.5 first at t = asin(0.625) = 0.6751
    assert {v.run for v in cov.violations} == {0, 1}
    assert cov.violations[0].time == pytest.approx(math.ceil(math.asin(0.625) / 0.01) * 0.01, abs=1e-9)
    ok = monitor(res, [InputBound(0.81)], u=lambda t: np.array([0.8 * math.sin(t)]))
    assert ok.covers_run and ok.covered_fraction == 1.0
    bad = monitor(res, [Premise("exact measurement", False, "noise")])
    assert bad.covered_runs == 0 and bad.reasons == ("exact measurement: noise",)
    assert not monitor(res, [], verified=False).covers_run


PEND = '''name = "pend"
states = ["theta", "omega"]
inputs = ["tau"]
outputs = ["y"]
[dynamics]
f = ["omega", "-9.81*sin(theta) - 0.5*omega"]
g = [["0"], ["1"]]
h = ["theta"]
[input_signals]
tau = 0.2
[simulation]
x0 = [0.4, 0.0]
initial_error_std = [0.05, 0.05]
duration = 4.0
dt = 0.002
'''


def test_the_comparison_reports_coverage_run_by_run() -> None:
    """Noise-free drift design: covered where the region holds the runs (the high gain w ≈ 218 makes ω̂ peak to
    about −11 in the first step, so ω needs room), not where it does not."""
    wide = compare_observers(parse_scenario(PEND), observers=["drift"], runs=4, box=[-3, 3, -60, 60], seed=1)
    cert = wide.observers["drift"].certificate
    assert cert["verified"] and cert["covers_run"] and cert["covered_fraction"] == 1.0 and cert["violations"] == []
    assert cert["mu"] == pytest.approx(0.2)
    narrow = compare_observers(parse_scenario(PEND), observers=["drift"], runs=4, box=[-0.3, 0.3], seed=1)
    cert = narrow.observers["drift"].certificate
    res = narrow.observers["drift"].result
    assert not cert["covers_run"] and cert["covered_fraction"] == 0.0
    for v in cert["violations"]:  # the first saved time where the state or the estimate leaves [−0.3, 0.3]²
        run = v["run"]
        outside = ((np.abs(res.x[run]) > 0.3).any(axis=-1)) | ((np.abs(res.x_hat[run]) > 0.3).any(axis=-1))
        assert v["time"] == pytest.approx(res.t[int(np.argmax(outside))])


def test_a_failed_design_names_cli_options_and_w_max_is_one() -> None:
    """The Vandermonde search's limit is the option --w-max, and the message says which options to change."""
    from typer.testing import CliRunner

    from nlobs.cli import app

    res = CliRunner().invoke(app, ["design", "drift", "vanderpol-lienard", "--alpha", "50", "--w-max", "10"])
    assert res.exit_code == 1, res.output
    err = res.stderr
    assert "w ≤ 10 " in err and "--w-max" in err and "--alpha, --mu, --gamma" in err and "Traceback" not in err


def test_condition_margins_first_negative_instant_and_shape_errors() -> None:
    from nlobs.simulate.coverage import Condition

    res = _runs()
    t = res.t
    m = np.stack([0.5 - np.sin(t), 2.0 - np.sin(t)])  # run 0 crosses at t = asin(0.5) = π/6, run 1 never
    cov = monitor(res, [Condition("sin t ≤ 1/2", m[:, :-1], "1/2 − sin t")])
    (v,) = cov.violations
    assert v.run == 0 and v.time == pytest.approx(math.ceil(math.pi / 6 / 0.01) * 0.01, abs=1e-9)
    assert v.detail.startswith("1/2 − sin t = -") and cov.covered_fraction == 0.5
    nan = monitor(res, [Condition("finite", np.full(t.size, np.nan))])
    assert nan.covered_runs == 0 and all(v.time == t[0] for v in nan.violations)
    with pytest.raises(Exception, match="margin has"):
        monitor(res, [Condition("too long", np.zeros(t.size + 1))])


def test_chemostat_drift_run_with_an_input_200_times_mu_is_not_certified() -> None:
    """The user's run: ``--u 0.2`` against a design bound μ = 0.001 was reported "certified": true."""
    import json

    from typer.testing import CliRunner

    from nlobs.cli import app

    res = CliRunner().invoke(app, ["design", "drift", "chemostat", "--box", "0.5,8,0.3,9", "--mu", "0.001", "--method",
                                   "sdp", "--alpha", "0.5", "--simulate", "--x0", "4,1.5", "--xhat0", "2,1", "--u",
                                   "0.2", "--duration", "2", "--json"])
    assert res.exit_code in (0, 1), res.output
    sim = json.loads(res.stdout)["simulation"]
    assert sim["gain_certified"] is True  # (2.17) holds with the region's premises ...
    assert sim["certified"] is False and sim["certificate_covers_run"] is False  # ... but the run is not covered
    (v,) = sim["certificate_violations"]
    assert v["hypothesis"] == "‖u‖ ≤ μ = 0.001" and v["time"] == 0.0 and v["detail"] == "‖u‖ = 0.2 > 0.001"
