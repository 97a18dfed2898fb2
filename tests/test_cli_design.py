"""``nlobs design drift`` and ``nlobs design pinv``: closed-form gains, simulation, exit statuses."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs.cli import app

runner = CliRunner()


def _json(*args: str) -> dict:
    res = runner.invoke(app, [*args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def _write(tmp_path: Path, body: str) -> str:
    p = tmp_path / "m.toml"
    p.write_text(body, encoding="utf-8")
    return str(p)


def test_pinv_high_gain_vector_is_the_closed_form_polynomial() -> None:
    # θ = 2, roots −θ, −θ²: (λ + 2)(λ + 4) = λ² + 6λ + 8 → k = (6, 8) (Röbenack (10))
    d = _json("design", "pinv", "isidori-146")["design"]
    assert d["k"] == pytest.approx([6.0, 8.0])
    assert sorted(d["roots"]) == pytest.approx([-4.0, -2.0])
    assert d["usable"] is True
    # (λ + 1)(λ + 2) = λ² + 3λ + 2: a given k has roots −1, −2
    d = _json("design", "pinv", "isidori-146", "--k", "3,2")["design"]
    assert sorted(d["roots"]) == pytest.approx([-2.0, -1.0])


def test_pinv_simulation_writes_plot_and_trajectories(tmp_path: Path) -> None:
    d = _json("design", "pinv", "pendulum", "--simulate", "--x0", "0.5,0", "--xhat0", "0,0", "--duration", "6",
              "--theta", "3", "--out", str(tmp_path))
    sim = d["simulation"]
    # pendulum: y = θ, r = n = 2, Q⁺ = I; the error converges (high gain dominates the Lipschitz sin term)
    assert sim["initial_error_norm"] == pytest.approx(0.5)
    assert sim["final_error_norm"] < 1e-3 * sim["initial_error_norm"]
    assert {Path(f).name for f in sim["files"]} == {"pinv.png", "pinv.npz"}
    assert (tmp_path / "pinv.png").stat().st_size > 10_000
    data = np.load(tmp_path / "pinv.npz")
    assert data["x"].shape[-1] == 2


def test_drift_vandermonde_gain_is_the_closed_form() -> None:
    # Remark 2.11, s = (2): eigenvalues −w, −2w → (λ + w)(λ + 2w) → K = (3w, 2w²)
    d = _json("design", "drift", "pendulum")["design"]
    cert = d["certificate"]
    w = cert["w"]
    assert cert["verified"] is True and cert["lhs_max_eig"] < 0
    K = np.array(cert["K"]).ravel()
    assert K == pytest.approx([3 * w, 2 * w**2], rel=1e-9)


@pytest.mark.slow
def test_drift_simulation_decays_at_least_at_alpha() -> None:
    """On a region that holds the run the certificate covers it; on the default [−1, 1]² the estimate's
    peaking (ω̂ reaches 1.27 at t = 4 ms) leaves the region: the gain is certified, the run is not covered."""
    d = _json("design", "drift", "pendulum", "--method", "sdp", "--alpha", "2", "--mu", "0.5", "--box", "-12,12",
              "--simulate", "--x0", "0.8,0", "--duration", "3")
    sim = d["simulation"]
    assert sim["certified"] is True and sim["certificate_covers_run"] is True
    assert sim["certificate_covered_fraction"] == 1.0 and sim["certificate_violations"] == []
    assert sim["decay_rate"] >= 2.0
    assert sim["bound_ratio"] <= 1.0  # ‖e(t)‖ ≤ κ₁ e^{−αt} ‖e(0)‖ (3.2) at every saved time
    d = _json("design", "drift", "pendulum", "--method", "sdp", "--alpha", "2", "--mu", "0.5", "--simulate",
              "--x0", "0.8,0", "--duration", "3")
    sim = d["simulation"]
    assert sim["gain_certified"] is True and sim["certified"] is False and sim["certificate_covers_run"] is False
    (v,) = sim["certificate_violations"]
    assert v["hypothesis"].startswith("estimate in the region") and v["time"] < 0.01 and "omega" in v["detail"]


FOLD = """
name = "fold"
time = "continuous"
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]
[dynamics]
f = ["x2**2", "-x1"]
g = [["0"], ["1"]]
h = ["x1"]
"""


def test_pinv_refuses_a_model_violating_a1_with_status_3(tmp_path: Path) -> None:
    # L_f h = x2², Q = [[1, 0], [0, 2 x2]]: dh, dL_f h dependent on x2 = 0 (Röbenack A1 fails).
    res = runner.invoke(app, ["design", "pinv", _write(tmp_path, FOLD)])
    assert res.exit_code == 3, res.output
    assert "A1 fails" in res.output and "det Q = 2*x2 changes sign" in res.output


@pytest.mark.parametrize(
    ("args", "status", "msg"),
    [
        (["design", "drift", "pendulum", "--s", "1"], 2, "sums to 1; it must sum to n = 2"),
        (["design", "drift", "pendulum", "--method", "magic"], 2, "'magic' is not one of 'vandermonde', 'sdp'"),
        (["design", "drift", "grip-example1-filter"], 2, "a nonlinear (symbolic) model is needed"),
        (["design", "pinv", "pendulum", "--simulate"], 2, "--simulate needs --x0"),
        (["design", "pinv", "pendulum", "--simulate", "--x0", "1,2,3"], 2, "--x0: expected 2 numbers"),
        (["design", "pinv", "pendulum", "--placement", "odd"], 2, "--placement"),
        # not observable (x3 is not seen from y; det Q_s ≡ 0): the cause, named, exit 3
        (["design", "drift", "isidori-146"], 3, "unobservable direction: x3"),
        (["design", "drift", "rossler", "--box", "-12,12,-12,12,0,25"], 3, "det Q_s = (10*x - 59)/10 changes sign"),
        (["design", "drift", "chemostat", "--box", "0.05,4,0.01,4"], 1, "has no Vandermonde solution"),
        (["design", "pinv", "no-such-model"], 2, "no such file"),
    ],
)
def test_bad_input_and_failures_are_one_line_errors(args: list[str], status: int, msg: str) -> None:
    res = runner.invoke(app, args)
    assert res.exit_code == status, res.output
    assert msg in res.output
    assert res.output.count("\n") <= 2


SING = """
name = "sing"
time = "continuous"
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]
[dynamics]
f = ["x2**3", "-x1"]
g = [["0"], ["1"]]
h = ["x1"]
"""


def test_drift_refuses_a_model_that_is_not_drift_observable_with_status_3(tmp_path: Path) -> None:
    # Φ_s = (x1, x2³): det Q_s = 3 x2² vanishes on x2 = 0 inside the box; with γ = 1 the gain itself is verified.
    path = _write(tmp_path, SING)
    res = runner.invoke(app, ["design", "drift", path, "--gamma", "1"])
    assert res.exit_code == 3, res.output
    assert "[FAILS] drift-observability" in res.output and "usable: NO" in res.output
    last = res.output.strip().splitlines()[-1]
    assert last.startswith("nlobs: error:") and "no usable observer: drift-observability fails" in last
    res = runner.invoke(app, ["design", "drift", path, "--gamma", "1", "--json"])
    assert res.exit_code == 3
    d = json.loads(res.stdout)["design"]
    assert d["usable"] is False and d["certificate"]["verified"] is True
    assert any("drift-observability fails" in r for r in d["reasons"])


def test_drift_refuses_a_gamma_below_the_sampled_estimate(tmp_path: Path) -> None:
    res = runner.invoke(app, ["design", "drift", "pendulum", "--gamma", "0.1", "--json"])
    assert res.exit_code == 1  # a design failure (an observer of this structure exists: pendulum is drift-observable)
    d = json.loads(res.stdout)["design"]
    assert d["usable"] is False and len(d["warnings"]) == 1
    assert "γ = 0.1 (given) is below the sampled" in d["warnings"][0]
    assert _json("design", "drift", "pendulum")["design"]["warnings"] == []  # γ estimated: no warning


def test_drift_model_undefined_on_the_region_is_a_one_line_error(tmp_path: Path) -> None:
    body = SING.replace('"x2**3", "-x1"', '"x2", "sqrt(x1 - 2)"').replace('"sing"', '"sqrtf"')
    res = runner.invoke(app, ["design", "drift", _write(tmp_path, body)])
    assert res.exit_code == 2, res.output
    assert "sqrtf: Q_s (s = [2])" in res.output and "not finite at any of the 2000 sampled points" in res.output
    assert "[-1, 1] × [-1, 1]" in res.output and res.output.count("\n") <= 2 and "Traceback" not in res.output


LORENZ = """
name = "lorenz"
states = ["x1", "x2", "x3"]
outputs = ["y"]
parameters = { sigma = 10.0, rho = 28.0, beta = 2.6666666666666665 }
[dynamics]
f = ["sigma*(x2 - x1)", "x1*(rho - x3) - x2", "x1*x2 - beta*x3"]
h = ["x1"]
"""


def test_default_region_is_the_files_box_and_a_pole_in_the_region_is_named() -> None:
    """The chemostat on the default [−1, 1]² held its Monod pole (γ = 1e12, advice "lower μ"): a region with the
    pole now says so (S = −K_s = −0.2), and the file's [simulation] box is the default region."""
    res = runner.invoke(app, ["design", "drift", "chemostat", "--box", "-1,1"])
    assert res.exit_code == 3, res.output
    assert "the denominator S + 0.2 vanishes at S = -0.2 inside the region" in res.stderr
    assert "nlobs advise suggests one" in res.stderr and res.stderr.strip().count("\n") == 0
    res = runner.invoke(app, ["design", "drift", "two-tank"])  # file box [1, 12]²: usable, local on that region
    assert res.exit_code == 0 and "usable: local, on the region [1, 12] × [1, 12]" in res.stdout


def test_lorenz_drift_names_the_singular_q_s_and_exits_3(tmp_path: Path) -> None:
    """det Q_s = −100 x₁ vanishes on the region: no observer (3.1) there (exit 3), not "raise w_max" (exit 1)."""
    res = runner.invoke(app, ["design", "drift", _write(tmp_path, LORENZ)])
    assert res.exit_code == 3, res.output
    err = res.stderr.strip()
    assert "\n" not in err and "drift-observability fails" in err and "-100*x1" in err and "w_max" not in err
