"""``nlobs design setvalued`` / ``nlobs simulate setvalued``: reports, --json keys, exit statuses 0/1/2/3."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from nlobs.cli import app

runner = CliRunner()
MODELS = Path(__file__).resolve().parents[1] / "src" / "nlobs" / "data" / "models"
TEXT61 = (MODELS / "khajenejad-6-1.toml").read_text()
SIM_KEYS = {"rho", "containment_rate_state", "containment_rate_input", "final_radius_state", "max_error_over_radius",
            "baseline_lipschitz_final_error", "baseline_ekf_final_error"}


def _variant(tmp_path: Path, old: str, new: str, name: str = "variant.toml") -> str:
    assert old in TEXT61
    p = tmp_path / name
    p.write_text(TEXT61.replace(old, new))
    return str(p)


def test_design_61_json_reports_structure_class_check_and_a_verified_design() -> None:
    res = runner.invoke(app, ["design", "setvalued", "khajenejad-6-1", "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert d["structure"]["exists"] is True and d["structure"]["strongly_detectable"] == [True]
    assert d["class_check"]["holds"] is True and d["class_check"]["pairs"] == 20000
    des = d["design"]
    assert des["verified"] is True and all(c["passed"] for c in des["checks"])
    assert 0 < des["spectral_radii"][0] < 1 and 0 < des["lambda"] < 1
    assert des["steady_radius"] == pytest.approx(20.38, rel=0.02)  # docs/setvalued.md, Sec. 7


def test_design_61_text() -> None:
    res = runner.invoke(app, ["design", "setvalued", "khajenejad-6-1"])
    assert res.exit_code == 0, res.output
    assert "stable observer of this structure exists: yes" in res.stdout
    assert "S-procedure condition (⋆)" in res.stdout and "(ok)" in res.stdout


@pytest.mark.parametrize("command", ["design", "simulate"])
def test_62_as_printed_has_no_stable_observer_exit_3_with_evidence(command: str) -> None:
    res = runner.invoke(app, [command, "setvalued", "khajenejad-6-2"])
    assert res.exit_code == 3, res.output
    assert "NO stable observer" in res.stdout and "-1.34308" in res.stdout
    assert "no stable observer of this structure exists" in res.stderr
    res = runner.invoke(app, [command, "setvalued", "khajenejad-6-2", "--json"])
    assert res.exit_code == 3
    d = json.loads(res.stdout)
    assert d["structure"]["exists"] is False and d["structure"]["strongly_detectable"] == [False]
    assert d["structure"]["unstable_error_modes"][0][0] == pytest.approx([-1.343077, 0.0], abs=1e-5)


def test_lemma_5_1_rank_failure_exits_3(tmp_path: Path) -> None:
    # H = 0 and C G = 0: (C2 G2) has rank 0 < p, so M2 of Lemma 5.1 does not exist
    path = _variant(tmp_path, 'G = [["5*Ts"], ["5*Ts"], ["2*Ts"], ["Ts"]]\nH = [["1.1*Ts"], ["2*Ts"]]',
                    'G = [[0], [0], [1], [0]]')
    res = runner.invoke(app, ["design", "setvalued", path, "--json"])
    assert res.exit_code == 3, res.output
    d = json.loads(res.stdout)
    assert d["structure"]["lemma_5_1_rank"] is False and "rank" in d["structure"]["evidence"]


def test_simulate_bounded_and_growing_same_runs(tmp_path: Path) -> None:
    out = {}
    for kind in ("bounded", "growing"):
        res = runner.invoke(app, ["simulate", "setvalued", "khajenejad-6-1", "--runs", "60", "--steps", "300",
                                  "--unknown-input", kind, "--seed", "3", "--json"])
        assert res.exit_code == 0, res.output
        out[kind] = d = json.loads(res.stdout)
        assert SIM_KEYS <= set(d)
        assert d["containment_rate_state"] == 1.0 and d["containment_rate_input"] == 1.0
        assert d["max_error_over_radius"] <= 1.0 + 1e-9
        assert d["rho"] is None and 0 < d["contraction_factor"] < 1
    b, g = out["bounded"], out["growing"]
    # the set-valued error dynamics do not depend on d: same radii, bounded errors under the growing d
    assert g["final_radius_state"] == b["final_radius_state"]
    assert g["final_error_state"] < g["final_radius_state"]
    assert g["final_error_state"] == pytest.approx(b["final_error_state"], rel=0.05)
    # the point observers that treat d as absent / bounded noise are driven away
    assert g["baseline_lipschitz_final_error"] > 10 * b["baseline_lipschitz_final_error"]
    assert g["baseline_ekf_final_error"] > 10 * b["baseline_ekf_final_error"]


def test_simulate_text_and_figures(tmp_path: Path) -> None:
    res = runner.invoke(app, ["simulate", "setvalued", "khajenejad-6-1", "--runs", "20", "--steps", "50",
                              "--out", str(tmp_path / "figs")])
    assert res.exit_code == 0, res.output
    assert "containment (truth inside the ball at every step): state 1.0000, input 1.0000" in res.stdout
    pngs = sorted((tmp_path / "figs").glob("*.png"))
    assert [p.name for p in pngs] == ["khajenejad-6-1-bounded-errors.png", "khajenejad-6-1-bounded-run0.png"]
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["design", "setvalued", "no-such-model"], "no such file"),
        (["simulate", "setvalued", "khajenejad-6-1", "--runs", "0"], "Invalid value"),
        (["simulate", "setvalued", "khajenejad-6-1", "--unknown-input", "wild"], "Invalid value"),
        (["design", "setvalued", "khajenejad-6-1", "--objective", "hinf"], "needs γ ≥ 0"),
    ],
)
def test_bad_input_exits_2(args: list[str], match: str) -> None:
    res = runner.invoke(app, args)
    assert res.exit_code == 2, res.output
    assert match in res.output


def test_bad_model_file_exits_2_with_file_and_line(tmp_path: Path) -> None:
    path = _variant(tmp_path, "eta_w = 0.1", "eta_w = -0.1")
    res = runner.invoke(app, ["design", "setvalued", path])
    assert res.exit_code == 2
    line = TEXT61.splitlines().index("eta_w = 0.1") + 1
    assert res.stderr.count("\n") == 1 and f"{path}:{line}: [noise].eta_w must be >= 0: '-0.1'" in res.stderr


def test_violated_class_is_reported_and_exits_2(tmp_path: Path) -> None:
    path = _variant(tmp_path, 'bound = "3.33*Ts"', 'bound = "0.1*Ts"')  # the sin term reaches 3.33 Ts
    res = runner.invoke(app, ["design", "setvalued", path])
    assert res.exit_code == 2
    assert "violates its stated class" in res.stderr and "VIOLATED" in res.stderr


def test_infeasible_design_exits_1(tmp_path: Path) -> None:
    text = 'kind = "I"\nlinear_part'
    path = _variant(tmp_path, 'kind = "II"\nlinear_part', text)
    p = Path(path)
    p.write_text(p.read_text().replace("A_aux = [[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]]\n", "")
                 .replace('bound = "3.33*Ts"', 'L = "3.33*Ts"'))
    res = runner.invoke(app, ["design", "setvalued", path])
    assert res.exit_code == 1, res.output
    assert "design infeasible" in res.stderr


def _two_state_file(name: str, f: str, bounded: str, growing: str, function_class: str) -> str:
    """A 2-state unknown-input model file (G = e1, H = e2, small noise, initial ball 0.5) for CLI tests."""
    return f"""name = "{name}"
time = "discrete"
dt = 1.0
states = ["x1", "x2"]
outputs = ["y1", "y2"]

[dynamics]
f = {f}
h = ["x1", "0"]

[unknown_inputs]
G = [[1.0], [0.0]]
H = [[0.0], [1.0]]
bounded = ["{bounded}"]
growing = ["{growing}"]

[noise]
eta_w = 0.01
eta_v = 0.01

[initial]
centre = [0.0, 0.0]
radius = 0.5

[function_class]
{function_class}
"""


def _lpv_file(*, f: str, A: str, V: str) -> str:
    return _two_state_file("lpv", f, "0.2*sin(t)", "0.1*t",
                           f'kind = "III"\nlinear_part = {A}\nconstituents = {V}\nbox = [[-3, 3], [-3, 3]]')


def test_lpv_file_outside_its_polytope_is_refused(tmp_path: Path) -> None:
    """φ = [0, 1.5x₂] is σ̃-Lipschitz, but no difference quotient lies in the stated polytope: refused, exit 2."""
    p = tmp_path / "lpv_outside_polytope.toml"
    p.write_text(_lpv_file(f='["0", "1.5*x2"]', A="[[0, 0], [0, 0]]", V="[[[0, 1.5], [0, 0]], [[0, 0], [0, 0]]]"))
    for cmd in ("design", "simulate"):
        res = runner.invoke(app, [cmd, "setvalued", str(p), "--runs", "5", "--steps", "5"][: 3 if cmd == "design" else 7])
        assert res.exit_code == 2, res.output
        assert "violates its stated class" in res.stderr and "Class III (LPV): VIOLATED" in res.stderr


def test_lpv_file_is_designed_with_the_lipschitz_multiplier_and_contained(tmp_path: Path) -> None:
    p = tmp_path / "lpvok.toml"
    p.write_text(_lpv_file(f='["0.6*x1 + 0.2*x2", "0.3*x2"]', A="[[0.5, 0.2], [0, 0.3]]",
                                 V="[[[0.2, 0], [0, 0]], [[0, 0], [0, 0]]]"))
    res = runner.invoke(app, ["simulate", "setvalued", str(p), "--runs", "100", "--steps", "50", "--no-baselines",
                              "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert d["containment_rate_state"] == 1.0 and d["design"]["kappa"] > 0
    assert d["design"]["function_class_used"] == "Class I (Lipschitz)" and d["design"]["lpv_design"] == "lipschitz"


def _cubic_on_box_file(*, bounded: str) -> str:
    """φ = [0, 0.1x₁³], stated 0.3-Lipschitz (Class I) on the box |x₁|, |x₂| ≤ 1 only."""
    return _two_state_file("cubic-on-box", '["0.5*x1 + 0.2*x2", "0.3*x2 + 0.1*x1**3"]', bounded, "3 + 0.1*t",
                           'kind = "I"\nlinear_part = [[0.5, 0.2], [0, 0.3]]\nL = 0.3\nbox = [[-1, 1], [-1, 1]]')


def test_class_violated_along_trajectories_is_a_violated_guarantee(tmp_path: Path) -> None:
    """0.1x₁³ is 0.3-Lipschitz on the box only, and an input d = 0.8 + 0.2 sin t drives x₁ out of it."""
    p = tmp_path / "cubic_leaves_box.toml"
    p.write_text(_cubic_on_box_file(bounded="0.8 + 0.2*sin(t)"))
    res = runner.invoke(app, ["simulate", "setvalued", str(p), "--runs", "100", "--steps", "100", "--no-baselines",
                              "--json"])
    assert res.exit_code == 1, res.output  # the containment (0.81) is not the verdict: the guarantee is lost
    d = json.loads(res.stdout)
    assert d["containment_rate_state"] < 1 and d["guarantee_held"] is False
    assert d["class_violated_in_runs"] == 100 and d["class_worst_margin_in_runs"] < 0 and d["left_box_runs"] == 100
    assert d["roundoff_runs"] == 0
    assert d["certificate_covers_run"] is False and d["certificate_covered_fraction"] == 0.0
    assert len(d["certificate_violations"]) == 100
    assert all(v["hypothesis"].startswith("function class") for v in d["certificate_violations"])
    assert any("violated along the trajectories" in c for c in d["likely_causes"])
    assert "GUARANTEE VIOLATED" in res.stderr
    res = runner.invoke(app, ["simulate", "setvalued", str(p), "--runs", "100", "--steps", "100", "--no-baselines"])
    assert res.exit_code == 1
    assert "warning: the function class is violated along the trajectories in 100 of 100 runs" in res.stdout
    assert "GUARANTEE VIOLATED" in res.stdout and "likely cause: the function class is violated" in res.stdout


def test_guarantee_held_is_reported(tmp_path: Path) -> None:
    p = tmp_path / "cubic_stays_in_box.toml"
    p.write_text(_cubic_on_box_file(bounded="0.2*sin(t)"))
    res = runner.invoke(app, ["simulate", "setvalued", str(p), "--runs", "50", "--steps", "50", "--no-baselines",
                              "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert d["guarantee_held"] is True and d["likely_causes"] == [] and d["warnings"] == []
    assert d["class_violated_in_runs"] == 0 and d["left_box_runs"] == 0 and d["roundoff_runs"] == 0
    assert d["certificate_covers_run"] is True and d["certificate_covered_fraction"] == 1.0
    assert d["certificate_violations"] == [] and len(d["certificate_hypotheses"]) == 2


def test_roundoff_with_an_unbounded_input_is_flagged() -> None:
    res = runner.invoke(app, ["simulate", "setvalued", "khajenejad-6-1", "--runs", "10", "--steps", "4000",
                              "--unknown-input", "growing", "--no-baselines", "--json"])
    assert res.exit_code == 1, res.output  # containment 0.0, the overflow reported, not suppressed
    d = json.loads(res.stdout)
    assert d["containment_rate_state"] == 0.0 and d["guarantee_held"] is False
    assert d["roundoff_runs"] == 10 and d["roundoff_over_radius"] > 1 and d["max_abs_unknown_input"] > 1e18
    assert d["class_violated_in_runs"] == 0  # Class II holds everywhere: not the cause
    assert any("containment lost to floating-point round-off" in c and "|d| = 4.708e+18" in c
               for c in d["likely_causes"])


def test_plant_overflow_names_the_step(tmp_path: Path) -> None:
    p = tmp_path / "cubic_growing_input.toml"
    p.write_text(_cubic_on_box_file(bounded="0.2*sin(t)"))
    res = runner.invoke(app, ["simulate", "setvalued", str(p), "--runs", "10", "--steps", "100", "--unknown-input",
                              "growing"])
    assert res.exit_code == 1, res.output
    assert "the plant overflowed at step 17" in res.stderr and "is nan" not in res.stderr
    assert res.stderr.count("\n") == 1


def test_ekf_that_cannot_run_is_a_note_not_a_traceback(tmp_path: Path) -> None:
    """d = exp(1000 t) makes the EKF's R + H Q_d Hᵀ singular: a note in the report, not a LinAlgError traceback."""
    path = _variant(tmp_path, 'bounded = ["5*sin(2*t) + 1 + sign(t - 1)"]', 'bounded = ["exp(1000*t)"]')
    res = runner.invoke(app, ["simulate", "setvalued", path, "--runs", "3", "--steps", "30", "--json"])
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exception
    assert res.exit_code == 1  # the guarantee is lost to round-off (|d| ~ 1e130)
    d = json.loads(res.stdout)
    assert d["baseline_ekf_final_error"] is None and d["baseline_ekf_failure"].startswith("EKF diverged")
    assert d["roundoff_runs"] == 3


@pytest.mark.parametrize("command", ["design", "simulate"])
def test_negative_seed_is_a_one_line_error(command: str) -> None:
    res = runner.invoke(app, [command, "setvalued", "khajenejad-6-1", "--seed", "-1"])
    assert res.exit_code == 2
    assert "Invalid value for '--seed'" in res.output
