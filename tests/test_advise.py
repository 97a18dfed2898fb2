"""``nlobs advise``: the recommendation for the four worked plants, its evidence against independent numbers,
bad input, the JSON keys, a ``[cascade]`` table, and a model no method of nlobs applies to."""

from __future__ import annotations

import json
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.systems.modelfile import load_model, shipped_models
from nlobs.workflows.advise import advise_model, cascade_structure
from nlobs.workflows.inputs import BoxError, symbolic_model
from nlobs.workflows.verdict import Verdict

runner = CliRunner()


def _params(name: str) -> dict[str, float]:
    return tomllib.loads(shipped_models()[name].read_text())["parameters"]


def _min_det(report, method: str = "drift") -> float:
    ev = " ".join(report.method(method).evidence)
    m = re.search(r"min \|det Q_s\| over \d+ sampled points = ([-+0-9.eE]+)", ev)
    assert m, ev
    return float(m.group(1))


@pytest.mark.slow
def test_chemostat_pinv_with_det_qs_and_mu_from_the_file() -> None:
    """Under the file's analyser (every 6 min) only the Luenberger/Thau gain chosen for the sensors is certified
    on the file's region (the parallelotope of μ, Xμ' and D keeps the mass balance): it is recommended, ahead of
    the Moore–Penrose observer the theorems rank first without sensors."""
    rep = advise_model("chemostat")
    assert rep.verdict is Verdict.OK and rep.recommended == "luenberger"
    assert rep.box_source == "file [simulation] box" and rep.singular == ()
    assert rep.command == "nlobs simulate chemostat --observer luenberger,ekf,ukf"
    assert rep.design is not None and rep.design.bound is not None and rep.design.bound.verified
    assert rep.method("pinv").command == "nlobs design pinv chemostat --box=0.05,4,0.01,4 --theta 2"
    # (2.17) has no solution on the region (s ≰ r, μ = 0.3): the command would fail, so none is printed
    drift_ = rep.method("drift")
    assert drift_.command is None and not drift_.usable and "its design fails on the region: (2.17)" in drift_.reason
    # det Q_s by hand: h = S, L_f h = −μmax S X / ((K_s + S) Yxs) → det Q_s = μmax S / ((K_s + S) Yxs),
    # smallest on the box at its corner S = 0.01
    p = _params("chemostat")
    s = 0.01
    assert _min_det(rep) == pytest.approx(p["mu_max"] * s / ((p["K_s"] + s) * p["Yxs"]), rel=1e-3)
    drift = rep.method("drift")
    assert drift.applicable == "local" and "s ≰ r" in drift.reason and drift.region == "[0.05, 4] × [0.01, 4]"
    assert drift.parameters["mu"] == pytest.approx(0.3)  # the step 0.3 → 0.2 of [input_signals]
    assert rep.method("pinv").applicable == "local" and "not checked" in rep.method("pinv").reason
    assert rep.compare_command == "nlobs simulate chemostat --observer luenberger,ekf,ukf"


@pytest.mark.slow
def test_chemostat_default_box_contains_the_monod_pole() -> None:
    """On [−1, 1] (negative biomass and substrate) no gain is certified under the sensors: the theorems' order
    stands and the Moore–Penrose command carries the box."""
    rep = advise_model("chemostat", box=[-1, 1])
    assert rep.recommended == "pinv"
    assert any("T = 0.1 > T_max" in e for e in rep.method("luenberger").evidence)
    k_s = _params("chemostat")["K_s"]
    poles = [s for s in rep.singular if s.kind == "pole"]
    assert len(poles) == 1 and poles[0].state == "S"
    assert poles[0].values == pytest.approx((-k_s,))
    # the piece of [−1, 1] holding x0's S = 0.5 is [−K_s, 1]; 5 % of its width is kept away from the pole
    assert rep.region.lower[1] == pytest.approx(-k_s + 0.05 * (1 + k_s))
    assert rep.region.upper[1] == 1.0 and rep.region.lower[0] == -1.0
    assert "--box=-1,1,-0.14,1" in rep.command


def test_two_tank_drift_with_det_qs() -> None:
    """The theorems make drift applicable; under the file's 10 Hz level sensor only the Luenberger/Thau design
    has a certificate (its bound), so it is recommended and drift says why it has none."""
    rep = advise_model("two-tank")
    assert rep.recommended == "luenberger"
    assert rep.command == "nlobs simulate two-tank --observer luenberger,ekf,ukf"
    assert rep.design is not None and rep.design.bound is not None and rep.design.bound.verified
    assert any(e.startswith("certified under the file's sensors: RMS ‖e‖ ≤") for e in rep.method("luenberger").evidence)
    drift = rep.method("drift")
    assert drift.command == "nlobs design drift two-tank --box=1,12 --alpha 1 --mu 6"
    assert any(e.startswith("no certificate under the file's sensors: the output is sampled") for e in drift.evidence)
    p = _params("two-tank")
    # det Q_s = −a1 √(2 g0) / (2 A2 √h1), smallest in modulus at h1 = 12
    want = p["a1"] * math.sqrt(2 * p["g0"]) / (2 * p["A2"] * math.sqrt(12.0))
    assert _min_det(rep) == pytest.approx(want, rel=1e-3)
    pinv = rep.method("pinv")
    assert pinv.applicable == "no" and "Σ r_j = 2" in pinv.reason
    assert rep.method("cascade").applicable == "no" and "no subset" in rep.method("cascade").reason


def test_two_tank_box_through_the_square_roots() -> None:
    rep = advise_model("two-tank", box=[-1, 1])
    kinds = {(s.kind, s.state) for s in rep.singular}
    assert kinds == {("domain", "h1"), ("domain", "h2")}
    assert rep.region.lower.tolist() == pytest.approx([0.05, 0.05]) and rep.region.upper.tolist() == [1.0, 1.0]


@pytest.mark.slow
def test_cartpole_drift_constant_det_and_cascade_structure() -> None:
    rep = advise_model("cartpole")
    assert rep.recommended == "luenberger"  # the one certificate under the 50 Hz encoders
    assert "det Q_s = 1 (constant)" in rep.method("drift").evidence
    assert rep.method("drift").parameters["mu"] == pytest.approx(1.0)  # sine amplitude 1 N
    cs = cascade_structure(symbolic_model("cartpole"))
    assert cs is not None and cs.linear_states == ("x", "th") and cs.nonlinear_states == ("v", "w")
    assert "cascade structure found: states x, th" in rep.method("cascade").reason


def test_rossler_ekf_local_drift_and_cascade_structure() -> None:
    rep = advise_model("rossler")
    assert rep.recommended == "ekf-ukf" and rep.command == "nlobs simulate rossler --observer ekf,ukf"
    drift = rep.method("drift")
    assert drift.applicable == "local"
    # det Q_s = x − c (c = 5.7 + a); the piece x < 5.9 holds x0 = 1; 5 % of its width is kept from x = 5.9
    p = _params("rossler")
    root = p["c"] + p["a"]
    assert drift.parameters["box"][0] == pytest.approx([-12.0, root - 0.05 * (root + 12.0)])
    assert rep.method("pinv").applicable == "no"
    assert "cascade structure found: states x, y" in rep.method("cascade").reason


@pytest.mark.slow
def test_cascade_table_is_recommended(tmp_path: Path) -> None:
    """A [cascade] table ranks the cascade observer first among the uncertified; under the file's analyser the
    Luenberger/Thau gain chosen for the sensors is certified and goes ahead of it, and says so."""
    rep = advise_model("chemostat-analyser")  # the shipped [cascade] file: Σ1 (chemostat) → Σ2 (analyser lag)
    assert rep.recommended == "luenberger"
    ranked = sorted((m for m in rep.methods if m.usable), key=lambda m: m.rank)
    assert [m.method for m in ranked[:2]] == ["luenberger", "cascade"]
    assert rep.method("cascade").command == "nlobs design cascade chemostat-analyser"
    assert any(e.startswith("certified under the file's sensors: RMS ‖e‖ ≤") for e in rep.method("luenberger").evidence)
    assert any(e.startswith("no certificate under the file's sensors") for e in rep.method("cascade").evidence)
    res = runner.invoke(app, ["advise", "chemostat-analyser", "--json"])
    assert res.exit_code == 0
    assert json.loads(res.stdout)["command"] == "nlobs simulate chemostat-analyser --observer luenberger,ekf,ukf"
    # a [cascade] table next to [dynamics] describes the plant twice: one line, exit 2
    f = tmp_path / "ross-cascade.toml"
    f.write_text(shipped_models()["rossler"].read_text() + '\n[cascade]\nform = "cascade"\n')
    res = runner.invoke(app, ["advise", str(f)])
    assert res.exit_code == 2 and "[cascade]" in res.stderr and "\n" not in res.stderr.strip()


def test_no_method_applies(tmp_path: Path) -> None:
    f = tmp_path / "hidden.toml"
    f.write_text('name = "hidden"\nstates = ["x1", "x2"]\noutputs = ["y"]\n'
                 '[dynamics]\nf = ["-x1", "x2"]\nh = ["x1"]\n')
    rep = advise_model(str(f))
    assert rep.verdict is Verdict.NO_OBSERVER and rep.recommended is None
    res = runner.invoke(app, ["advise", str(f)])
    assert res.exit_code == 3


@pytest.mark.parametrize("args", [["advise", "no-such-model"], ["advise", "chemostat", "--box", "1,2,3"],
                                  ["advise", "chemostat", "--box=2,1"], ["advise", "chemostat", "--box", "a,b"]])
def test_bad_input_is_one_line_exit_2(args: list[str]) -> None:
    res = runner.invoke(app, args)
    assert res.exit_code == 2
    assert "Traceback" not in res.output
    err = res.stderr.strip()
    assert err.startswith("nlobs: error:") and "\n" not in err


def test_bad_box_in_the_workflow() -> None:
    with pytest.raises(BoxError):
        advise_model("chemostat", box=[0.0, 1.0, 2.0])


@pytest.mark.slow
def test_json_keys_and_analyze_keeps_its_keys() -> None:
    res = runner.invoke(app, ["advise", "two-tank", "--json"])
    assert res.exit_code == 0
    data = json.loads(res.stdout)
    assert set(data) == {"schema_version", "model", "box", "box_source", "region", "singularities", "methods", "recommended", "command",
                         "compare_command", "verdict", "message", "check", "design"}
    assert set(data["methods"]) == {"cascade", "setvalued", "drift", "pinv", "ekf-ukf", "luenberger", "pf", "mhe"}
    assert set(data["methods"]["drift"]) == {"method", "title", "applicable", "reason", "region", "evidence",
                                             "parameters", "command"}
    assert data["region"] == {"lower": [1.0, 1.0], "upper": [12.0, 12.0]}
    res = runner.invoke(app, ["analyze", "two-tank", "--json"])
    assert res.exit_code == 0
    an = json.loads(res.stdout)
    assert {"kind", "linearization", "observation_relative_degree", "drift_observable", "a1", "advice"} <= set(an)
    assert an["advice"]["recommended"] == "luenberger"
    text = runner.invoke(app, ["analyze", "two-tank"]).stdout
    assert "recommended: Luenberger" in text and "$ nlobs simulate two-tank --observer luenberger,ekf,ukf" in text


PEND_SENSED = '''name = "pend"
states = ["theta", "omega"]
inputs = ["tau"]
outputs = ["y"]
[dynamics]
f = ["omega", "-9.81*sin(theta) - 0.5*omega"]
g = [["0"], ["1"]]
h = ["theta"]
[sensors.enc]
outputs = ["y"]
rate = RATE
noise_std = 0.001
[input_signals]
tau = 0.2
[simulation]
x0 = [0.4, 0.0]
initial_error_std = [0.05, 0.05]
duration = 3.0
dt = 0.002
box = [[-3, 3], [-60, 60]]
'''


@pytest.mark.slow
def test_check_ranks_a_high_gain_design_fed_slow_samples_below_the_kalman_filters(tmp_path: Path) -> None:
    """The theorems' verdict makes drift applicable; under a 5 Hz encoder it never converges (held samples), and
    --check says why."""
    import math

    from nlobs.geometry import Box
    from nlobs.systems.brunovsky import brunovsky
    from nlobs.workflows.compare import compare_observers
    from nlobs.workflows.design_drift import design_drift_report

    f = tmp_path / "pend5.toml"
    f.write_text(PEND_SENSED.replace("RATE", "5.0"))
    plain = advise_model(str(f))
    # under the 5 Hz encoder only the Luenberger/Thau design keeps a certificate: it is recommended
    assert plain.recommended == "luenberger" and plain.check is None
    assert any("no certificate under the file's sensors" in e for e in plain.method("drift").evidence)
    rep = advise_model(str(f), check=True, runs=2, progress=False)
    assert rep.recommended == "luenberger" and "drift" in rep.check.demoted and "luenberger" not in rep.check.demoted
    out = rep.check.outcomes
    assert out["drift"]["diverged"] == 0 and math.isinf(out["drift"]["convergence_time"])
    assert math.isfinite(out["ekf"]["convergence_time"])
    # the same runs compared directly: the check's numbers are the comparison's
    cmp = compare_observers(str(f), observers=["drift", "luenberger", "ekf"], runs=2, seed=0, box=[-3, 3, -60, 60],
                            progress=False)
    assert out["drift"]["rms_error_norm"] == pytest.approx(cmp.observers["drift"].rms_error_norm, rel=1e-12)
    assert out["ekf"]["rms_error_norm"] == pytest.approx(cmp.observers["ekf"].rms_error_norm, rel=1e-12)
    # the fastest error pole of A_s − K C_s against the 0.2 s sampling interval
    d = design_drift_report(load_model(str(f)), region=Box([-3, -60], [3, 60]), mu=0.2)
    A, _, C = brunovsky(d.s)
    lam = float(np.max(np.abs(np.linalg.eigvals(A - d.certificate.gain @ C))))
    assert f"|λ|·Ts = {lam * 0.2:.2g}" in rep.check.demoted["drift"]
    res = runner.invoke(app, ["advise", str(f), "--check", "--runs", "2", "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["recommended"] == "luenberger" and set(data["check"]["demoted"]) >= {"drift"}
    assert runner.invoke(app, ["advise", str(f), "--check", "--runs", "0"]).exit_code == 2


@pytest.mark.slow
def test_check_keeps_an_observer_that_converges_and_notes_noise_only_above_the_factor(tmp_path: Path) -> None:
    """The Luenberger gain chosen for a 500 Hz encoder converges within CHECK_RMS_FACTOR of the EKF: no note."""
    from nlobs.methods.advice import CHECK_RMS_FACTOR

    f = tmp_path / "pend500.toml"
    f.write_text(PEND_SENSED.replace("RATE", "500.0"))
    rep = advise_model(str(f), check=True, runs=2, progress=False)
    luen = rep.check.outcomes["luenberger"]
    assert "luenberger" not in rep.check.demoted and np.isfinite(luen["convergence_time"])
    ratio = luen["rms_error_norm"] / rep.check.outcomes["ekf"]["rms_error_norm"]
    assert 1 < ratio < CHECK_RMS_FACTOR and "note" not in luen
    assert not any("amplifies the sensor noise" in e for e in rep.method("luenberger").evidence)


@pytest.mark.slow
def test_a_certified_design_on_a_given_box_prints_commands_on_that_box() -> None:
    """A box given to advise: the certificate is for it, so both printed commands carry it (else `simulate` would
    design on the file's region, another observer than the one advised)."""
    rep = advise_model("cstr", box=[0.62, 0.88, 3.9, 5.5])
    assert rep.recommended == "luenberger"
    assert rep.design is not None and rep.design.bound is not None and rep.design.bound.verified
    want = "nlobs simulate cstr --observer luenberger,ekf,ukf --box=0.62,0.88,3.9,5.5"
    assert rep.command == want and rep.compare_command == want
    res = runner.invoke(app, want.split()[1:] + ["--runs", "2", "--duration", "12"])
    assert res.exit_code == 0, res.output
    assert "covers run" in res.output and "[0.62, 0.88] × [3.9, 5.5]" in res.output


def test_an_unknown_input_that_hides_a_state_is_named_beside_the_filters() -> None:
    # khajenejad-6-2: A = [[-0.42, 1], [-0.6, 0]], G = [1, -0.65]ᵀ, C = [0, 1], H = 0. From x = e1 the unknown input
    # d = -0.6/0.65 keeps x2 = 0 at the next step: x1 moves, the output never sees it (V* = span(e1))
    import numpy as np

    from nlobs.methods.advice import _unknown_input_hidden
    from nlobs.systems.modelfile import load_model

    A = np.array([[-0.42, 1.0], [-0.6, 0.0]])
    G = np.array([[1.0], [-0.65]])
    C = np.array([[0.0, 1.0]])
    # by hand: x = e1 with d chosen so that C(A x + G d) = 0 and C x = 0 stays: A e1 + G d = (-0.42 + d, -0.6 - 0.65 d)
    d = -0.6 / 0.65
    nxt = A @ np.array([1.0, 0.0]) + G[:, 0] * d
    assert abs(C @ np.array([1.0, 0.0])) == 0 and abs(nxt[1]) < 1e-12  # stays in span(e1), unseen
    assert _unknown_input_hidden("khajenejad-6-2", frozenset({"unknown_inputs"}), load_model("khajenejad-6-2")) == ("x1",)
    rep = advise_model("khajenejad-6-2")
    named = {m.method: m for m in rep.methods}
    for key in ("ekf-ukf", "luenberger"):
        assert any("unknown input can move x1" in e for e in named[key].evidence), named[key].evidence
    assert not any("unknown input can move" in e for m in advise_model("khajenejad-6-1").methods for e in m.evidence)
