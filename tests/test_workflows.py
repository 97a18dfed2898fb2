"""The workflows layer: one call per CLI command, its report equal to what the CLI prints, bad output refused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from nlobs._io import with_schema
from nlobs.cli import app
from nlobs.errors import InvalidArgumentError, OutputError
from nlobs.workflows import Verdict
from nlobs.workflows.analyze import analyze_model
from nlobs.workflows.demo import DemoConfig, gnss_ins_demo
from nlobs.workflows.setvalued import design_setvalued_observer, simulate_setvalued_observer

runner = CliRunner()


def _json(args: list[str]) -> tuple[int, object, str]:
    res = runner.invoke(app, args)
    return res.exit_code, json.loads(res.stdout) if res.stdout.strip().startswith(("{", "[")) else None, res.stderr


def test_analyze_report_is_what_the_cli_prints() -> None:
    rep = analyze_model("isidori-146", box=[-1.0, 1.0])
    code, data, _ = _json(["analyze", "isidori-146", "--box", "-1,1", "--json"])
    assert code == 0 and data == json.loads(json.dumps(with_schema(rep.to_dict()))) and rep.verdict is Verdict.OK
    res = runner.invoke(app, ["analyze", "isidori-146", "--box", "-1,1"])
    assert res.stdout.strip() == rep.summary().strip()


def test_setvalued_reports_are_what_the_cli_prints() -> None:
    rep = design_setvalued_observer("khajenejad-6-1", samples=2000)
    code, data, _ = _json(["design", "setvalued", "khajenejad-6-1", "--samples", "2000", "--json"])
    assert code == 0 and rep.verdict is Verdict.OK
    drop = {"seconds"}
    assert {k: v for k, v in data["design"].items() if k not in drop} == \
        {k: v for k, v in json.loads(json.dumps(rep.to_dict()["design"])).items() if k not in drop}
    study = simulate_setvalued_observer("khajenejad-6-1", runs=20, steps=30, samples=2000)
    code, data, _ = _json(["simulate", "setvalued", "khajenejad-6-1", "--runs", "20", "--steps", "30",
                           "--samples", "2000", "--json"])
    assert code == 0 and study.verdict is Verdict.OK and data["guarantee_held"] is True
    for key in ("containment_rate_state", "final_radius_state", "max_error_over_radius", "final_error_state",
                "baseline_lipschitz_final_error"):
        assert data[key] == pytest.approx(study.to_dict()[key], rel=1e-12)
    assert "Monte Carlo: 20 runs x 30 steps" in study.summary()


def test_no_observer_is_a_verdict_with_the_evidence() -> None:
    rep = design_setvalued_observer("khajenejad-6-2", samples=2000)
    assert rep.verdict is Verdict.NO_OBSERVER and rep.design is None
    assert "no stable observer" in rep.message and "NO stable observer" in rep.summary()
    res = runner.invoke(app, ["design", "setvalued", "khajenejad-6-2", "--samples", "2000"])
    assert res.exit_code == 3 and rep.summary().splitlines()[0] in res.stdout


def test_the_batch_bound_is_refused_before_any_work() -> None:
    with pytest.raises(InvalidArgumentError, match="too large for one batch"):
        simulate_setvalued_observer("khajenejad-6-1", runs=10**7, batch=10**7, steps=100)
    with pytest.raises(InvalidArgumentError, match="per-run summaries alone"):
        simulate_setvalued_observer("khajenejad-6-1", runs=10**8, steps=100)


@pytest.mark.parametrize("kind", ["file", "under-a-file"])
def test_an_unwritable_out_is_a_typed_error_and_one_line(tmp_path: Path, kind: str) -> None:
    taken = tmp_path / "taken"
    taken.write_text("not a folder")
    out = taken if kind == "file" else taken / "sub"
    with pytest.raises(OutputError, match="^`out` "):  # the parameter; the command line says --out
        gnss_ins_demo(DemoConfig(duration=2.0, ekf=False), out)
    assert taken.read_text() == "not a folder" and sorted(p.name for p in tmp_path.iterdir()) == ["taken"]
    res = runner.invoke(app, ["demo", "gnss-ins", "--duration", "2", "--no-ekf", "--out", str(out)])
    assert res.exit_code == 2 and res.stderr.count("\n") == 1 and "--out" in res.stderr, res.output
    res = runner.invoke(app, ["simulate", "setvalued", "khajenejad-6-1", "--runs", "3", "--steps", "5",
                              "--samples", "200", "--out", str(out)])
    assert res.exit_code == 2 and res.stderr.count("\n") == 1 and "--out" in res.stderr, res.output


@pytest.mark.slow
def test_a_short_demo_that_never_converges_writes_null_metrics(tmp_path: Path) -> None:
    rep = gnss_ins_demo(DemoConfig(duration=1.0, ekf=False), tmp_path)
    data = json.loads((tmp_path / "results.json").read_text())
    assert data["observer"]["converge_s"] is None and rep.to_dict()["observer"]["converge_s"] != 0.0


def test_the_demo_refuses_a_negative_seed_and_an_endless_flight() -> None:
    with pytest.raises(InvalidArgumentError, match="seed"):
        DemoConfig(seed=-1)
    res = runner.invoke(app, ["demo", "gnss-ins", "--seed", "-1"])
    assert res.exit_code == 2 and "seed" in res.stderr and "Traceback" not in res.output
    res = runner.invoke(app, ["demo", "gnss-ins", "--duration", "1e12"])
    assert res.exit_code == 2 and "IMU samples" in res.stderr
