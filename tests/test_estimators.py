"""The particle filter and moving-horizon estimation as methods: designed from a model file as the Kalman filters are,
run by ``nlobs simulate`` and ``nlobs estimate`` when named, kept inside the file's ``[constraints]``."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from jsonschema import Draft202012Validator
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.cli.schema import command_schema
from nlobs.methods.comparison import DEFAULT_OBSERVERS, OBSERVERS, compare_observers, design_observer
from nlobs.methods.problem import problem
from nlobs.methods.registry import names

pytest.importorskip("casadi")


def test_the_registry_runs_them_only_when_named() -> None:
    assert "pf" in OBSERVERS and "mhe" in OBSERVERS
    assert "pf" not in DEFAULT_OBSERVERS and "mhe" not in DEFAULT_OBSERVERS
    assert "pf" not in names(exported=True) and "mhe" not in names(exported=True)


def test_designs_share_the_kalman_filters_tuning_and_the_bounds() -> None:
    pb = problem("sir")
    ekf = design_observer("ekf", pb, {})
    pf = design_observer("pf", pb, {"particles": 300, "seed": 4})
    mhe = design_observer("mhe", pb, {"horizon": 6})
    assert not isinstance(pf, str) and not isinstance(mhe, str) and not isinstance(ekf, str)
    np.testing.assert_array_equal(pf.observer.R, ekf.observer.R)
    np.testing.assert_array_equal(pf.observer.Q, ekf.observer.Q)
    np.testing.assert_array_equal(pf.observer.lower, [0.0, 0.0])
    np.testing.assert_array_equal(mhe.observer.upper, [1.0, 1.0])
    assert pf.observer.particles == 300 and pf.observer.seed == 4 and mhe.observer.horizon == 6
    why = design_observer("pf", problem("pendulum"), {})
    assert isinstance(why, str) and "particle filter needs sampled, noisy measurements" in why


@pytest.mark.slow
def test_on_the_sir_model_both_stay_in_the_bounds_within_twice_the_ekf() -> None:
    """Daily reports of the infected fraction (noise 0.003), 6 runs of 80 days: neither diverges, both are within
    2 × the EKF's RMS error after day 30 (measured over 20 runs of 150 days: EKF 0.00352, PF 0.00354, MHE 0.00352),
    and no estimate of either leaves [0, 1] (the truth never does)."""
    rep = compare_observers("sir", observers=["ekf", "pf", "mhe"], runs=6, duration=80.0,
                            design_options={"pf": {"particles": 500}})
    ekf = rep.observers["ekf"].rms_error_norm
    assert rep.constraints["truth_runs_outside"] == 0
    for name in ("pf", "mhe"):
        o = rep.observers[name]
        assert not o.diverged_runs, name
        assert o.rms_error_norm < 2.0 * ekf, (name, o.rms_error_norm, ekf)
        assert o.bounds["outside_fraction"] == 0.0 and o.bounds["runs_outside"] == 0, name
    json.dumps(rep.to_dict())


@pytest.mark.slow
def test_the_command_runs_them_with_their_options_and_its_json_follows_the_schema(tmp_path: Path) -> None:
    runner = CliRunner()
    res = runner.invoke(app, ["simulate", "sir", "--observer", "pf,mhe", "--particles", "200", "--horizon", "4",
                              "--runs", "2", "--duration", "40", "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert list(Draft202012Validator(command_schema("simulate")).iter_errors(data)) == []
    assert "200 particles" in data["observers"]["pf"]["description"]
    assert "last 4 samples" in data["observers"]["mhe"]["description"]
    bad = runner.invoke(app, ["simulate", "sir", "--observer", "ekf", "--particles", "200"])
    assert bad.exit_code == 2 and "--particles: applies to the particle filter" in bad.output


@pytest.mark.slow
def test_on_a_logged_run_both_estimate_the_cart_pole_as_well_as_the_ekf(tmp_path: Path) -> None:
    """The cart-pole log of ``test_estimate.py`` (50 Hz encoders, 1 mm and 5 mrad): after 5 s the PF (1000
    particles) is within 1.2 × the EKF's RMS error against the truth in every state (measured 0.88–1.0 ×) and the
    MHE within 2 × (measured 1.1–1.4 ×)."""
    sys.path.insert(0, str(Path(__file__).parent))
    from test_estimate import X_HAT0, _log

    from nlobs.methods.estimation import estimate

    path, truth = _log(tmp_path / "cartpole.csv")
    rep = estimate("cartpole", path, observers=["ekf", "pf", "mhe"], x_hat0=X_HAT0)
    late = truth.t >= 5.0

    def rms(name: str) -> np.ndarray:
        e = np.asarray(rep.observers[name].result.x_hat) - truth.x
        return np.sqrt(np.mean(e[late] ** 2, axis=0))

    assert np.all(rms("pf") < 1.2 * rms("ekf")), (rms("pf"), rms("ekf"))
    assert np.all(rms("mhe") < 2.0 * rms("ekf")), (rms("mhe"), rms("ekf"))
    assert rep.observers["pf"].consistency is not None  # the PF's NIS from its Gaussian approximation
