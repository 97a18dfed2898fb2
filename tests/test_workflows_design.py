"""The workflows behind ``nlobs design drift`` and ``nlobs design pinv``: the report is what the CLI prints.

Each workflow returns a frozen report whose ``to_dict()`` is the CLI's ``--json`` output, whose
``summary()`` is its text output, and whose verdict and message give the exit status and the last
line. The Moore–Penrose report keeps the observer it built, and its simulation runs that object.
"""

from __future__ import annotations

import ast
import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from nlobs._io import with_schema
from nlobs.cli import app
from nlobs.cli.common import jsonable
from nlobs.errors import DimensionError, InvalidArgumentError, ModelError, OutputError, StudyFailed
from nlobs.observers.pinv import PinvObserver
from nlobs.workflows import (
    SimulationRequest,
    Verdict,
    design_drift_observer,
    design_pinv_observer,
)
from nlobs.workflows import design_pinv as design_pinv_module
from nlobs.workflows.inputs import BoxError, as_region

runner = CliRunner()
SRC = Path(__file__).resolve().parents[1] / "src" / "nlobs"

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


def _cli(*args: str) -> tuple[int, str, str]:
    res = runner.invoke(app, list(args))
    return res.exit_code, res.stdout, res.stderr


# --------------------------------------------------------------------------- report == CLI output


@pytest.mark.slow
def test_drift_report_is_what_the_cli_prints(tmp_path: Path) -> None:
    out = tmp_path / "out"
    args = ("pendulum", "--method", "sdp", "--alpha", "2", "--mu", "0.5", "--simulate", "--x0", "0.8,0",
            "--duration", "1", "--out", str(out))
    req = SimulationRequest([0.8, 0.0], duration=1.0, out=out)
    rep = design_drift_observer("pendulum", method="sdp", alpha=2.0, mu=0.5, simulate=req)
    assert rep.verdict is Verdict.OK and rep.message == ""
    assert [p.name for p in rep.files] == ["drift.png", "drift.npz"] and all(p.is_file() for p in rep.files)
    status, stdout, _ = _cli("design", "drift", *args, "--json")
    assert status == 0
    cli = json.loads(stdout)
    mine = json.loads(json.dumps(jsonable(with_schema(rep.to_dict()))))
    for d in (cli, mine):  # the wall-clock time of the design is the one thing that differs between runs
        d["design"]["certificate"].pop("seconds", None)
    assert mine == cli
    assert list(rep.to_dict()) == ["design", "simulation"] and list(cli) == ["schema_version", "design", "simulation"]
    assert list(rep.to_dict()["simulation"]) == ["final_error_norm", "initial_error_norm", "max_error_norm", "files",
                                                 "decay_rate", "bound_ratio", "certified", "gain_certified",
                                                 "certificate_covers_run", "certificate_covered_fraction",
                                                 "certificate_violations", "certificate_failed_premises",
                                                 "certificate_hypotheses"]
    status, stdout, _ = _cli("design", "drift", *args)
    assert status == 0 and stdout == rep.summary() + "\n"
    assert rep.summary().splitlines()[-2:] == [f"wrote {out / 'drift.png'}", f"wrote {out / 'drift.npz'}"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        rep.verdict = Verdict.FAILED  # type: ignore[misc]


def test_drift_verdicts_and_messages_are_the_cli_exit_statuses(tmp_path: Path) -> None:
    path = tmp_path / "sing.toml"
    path.write_text(SING, encoding="utf-8")
    rep = design_drift_observer(str(path), gamma=1.0, simulate=SimulationRequest([1.0, 0.0]))
    assert rep.verdict is Verdict.NO_OBSERVER and rep.simulation is None  # nothing simulated without an observer
    assert rep.message.startswith(f"{path}: no usable observer: drift-observability fails on the region")
    status, stdout, stderr = _cli("design", "drift", str(path), "--gamma", "1")
    assert status == 3 and stdout == rep.summary() + "\n"
    assert stderr.strip() == f"nlobs: error: {rep.message}"
    low = design_drift_observer("pendulum", gamma=0.1)
    assert low.verdict is Verdict.FAILED and "γ = 0.1 (given) is below the sampled" in low.message
    status, _, stderr = _cli("design", "drift", "pendulum", "--gamma", "0.1")
    assert status == 1 and stderr.strip() == f"nlobs: error: {low.message}"


def test_pinv_report_is_what_the_cli_prints(tmp_path: Path) -> None:
    out = tmp_path / "out"
    args = ("isidori-146", "--simulate", "--x0", "1,0,0,0.5", "--xhat0", "0.5,0.5,-0.5,0", "--duration", "1",
            "--out", str(out))
    req = SimulationRequest([1.0, 0.0, 0.0, 0.5], [0.5, 0.5, -0.5, 0.0], duration=1.0, out=out)
    rep = design_pinv_observer("isidori-146", simulate=req)
    assert rep.verdict is Verdict.OK and rep.message == ""
    status, stdout, _ = _cli("design", "pinv", *args, "--json")
    assert status == 0 and json.loads(stdout) == json.loads(json.dumps(jsonable(with_schema(rep.to_dict()))))
    status, stdout, _ = _cli("design", "pinv", *args)
    assert status == 0 and stdout == rep.summary() + "\n"
    assert {p.name for p in rep.files} == {"pinv.png", "pinv.npz"}


# --------------------------------------------------------------------------- one observer, no rebuild


def test_pinv_simulation_runs_the_reports_own_observer(monkeypatch: pytest.MonkeyPatch) -> None:
    built: list[PinvObserver] = []
    post_init = PinvObserver.__post_init__

    def counting(self: PinvObserver) -> None:
        post_init(self)
        built.append(self)

    seen = []
    simulate = design_pinv_module.simulate

    def spy(plant, observer, *args, **kwargs):  # type: ignore[no-untyped-def]
        seen.append(observer)
        return simulate(plant, observer, *args, **kwargs)

    monkeypatch.setattr(PinvObserver, "__post_init__", counting)
    monkeypatch.setattr(design_pinv_module, "simulate", spy)
    rep = design_pinv_observer("pendulum", theta=3.0, simulate=SimulationRequest([0.5, 0.0], duration=0.5))
    assert len(built) == 1  # built once, by the design
    assert seen == [rep.design.observer] and seen[0] is rep.design.observer is built[0]
    assert rep.simulation is not None and rep.simulation.error_norm[-1] < rep.simulation.error_norm[0]
    d = rep.design
    assert dataclasses.replace(d) == d  # the observer takes no part in equality
    assert "observer" not in d.to_dict()


# --------------------------------------------------------------------------- errors


@pytest.mark.parametrize("command", ["drift", "pinv"])
def test_an_unwritable_out_is_one_line_with_status_2(tmp_path: Path, command: str) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder", encoding="utf-8")
    extra = ("--method", "sdp") if command == "drift" else ()
    res = runner.invoke(app, ["design", command, "pendulum", *extra, "--simulate", "--x0", "0.5,0", "--duration", "0.2",
                              "--out", str(blocker / "sub")])
    assert res.exit_code == 2, res.output
    assert res.stderr.count("\n") == 1 and "Traceback" not in res.output
    assert res.stderr.startswith(f"nlobs: error: --out {blocker / 'sub'}: cannot create the folder")
    with pytest.raises(OutputError) as info:
        design_drift_observer("pendulum", method="sdp",
                              simulate=SimulationRequest([0.5, 0.0], duration=0.2, out=blocker))
    assert isinstance(info.value, OSError) and str(info.value).startswith(f"{blocker}: cannot create the folder")


def test_a_failure_inside_the_simulation_is_status_1() -> None:
    # K(w*) is far too stiff for dt = 1: Q_s is singular along the exploding estimate
    res = runner.invoke(app, ["design", "drift", "pendulum", "--simulate", "--x0", "0.5,0", "--dt", "1",
                              "--duration", "50"])
    assert res.exit_code == 1 and "Q_s (s = [2]) is singular" in res.stderr and res.stderr.count("\n") == 1
    with pytest.raises(StudyFailed, match=r"Q_s \(s = \[2\]\) is singular") as info:
        design_drift_observer("pendulum", simulate=SimulationRequest([0.5, 0.0], duration=50.0, dt=1.0))
    assert info.value.__cause__ is not None


def test_workflow_inputs_are_checked() -> None:
    with pytest.raises(ModelError, match="a nonlinear \\(symbolic\\) model is needed"):
        design_drift_observer("grip-example1-filter")
    with pytest.raises(InvalidArgumentError, match="`method`: expected 'vandermonde' or 'sdp'"):
        design_drift_observer("pendulum", method="magic")
    with pytest.raises(InvalidArgumentError, match="`placement`: expected 'powers' or 'multiple'"):
        design_pinv_observer("pendulum", placement="odd")  # type: ignore[arg-type]
    with pytest.raises(DimensionError, match="`x0`: expected 2 numbers for model pendulum, got 3"):
        design_pinv_observer("pendulum", simulate=SimulationRequest([1.0, 2.0, 3.0]))
    with pytest.raises(BoxError, match="expected 'lo,hi' or 4 numbers"):
        as_region([1.0, 2.0, 3.0], 2)
    box = as_region([-2.0, 2.0], 2)
    assert box is not None and box.lower.tolist() == [-2.0, -2.0] and as_region(box, 2) is box
    assert as_region(None, 2) is None
    with pytest.raises(BoxError, match="the region has dimension 2, the model has n = 3"):
        as_region(box, 3)
    with pytest.raises(BoxError, match="expected 'lo,hi' or 4 numbers"):
        design_drift_observer("pendulum", box=[1.0, 2.0, 3.0])
    res = runner.invoke(app, ["design", "pinv", "pendulum", "--box", "1,-1"])
    assert res.exit_code == 2 and res.stderr.startswith("nlobs: error: --box: Box: upper[0] = -1 must exceed")
    rep = design_pinv_observer("pendulum", box=[-2.0, 2.0])
    assert rep.design.observer.region.upper.tolist() == [2.0, 2.0]


# --------------------------------------------------------------------------- imports


def _nlobs_imports(path: Path) -> set[str]:
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("nlobs"):
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("nlobs"))
    return out


@pytest.mark.parametrize("name", ["design.py", "common.py"])
def test_the_design_commands_import_only_workflows_modelfile_and_errors(name: str) -> None:
    allowed = ("nlobs.workflows", "nlobs.cli", "nlobs.systems.modelfile", "nlobs.errors")
    bad = {m for m in _nlobs_imports(SRC / "cli" / name) if not any(m == a or m.startswith(a + ".") for a in allowed)}
    assert not bad, f"cli/{name} imports {sorted(bad)}"


def test_importing_the_workflows_package_does_not_load_the_observers_or_the_solvers() -> None:
    code = ("import sys, nlobs.workflows as w; "
            "print(sorted(m for m in ('cvxpy', 'matplotlib', 'nlobs.observers', 'nlobs.simulate', 'nlobs.synthesis') "
            "if m in sys.modules)); w.design_pinv_observer; print('nlobs.observers' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(SRC.parent), "PATH": "/usr/bin:/bin"}).stdout.split("\n")
    assert out[0] == "[]" and out[1] == "True"


def test_the_moved_names_are_exported_where_they_now_live() -> None:
    import nlobs.geometry as geometry
    import nlobs.linear as linear
    import nlobs.observers as observers
    import nlobs.synthesis as synthesis
    import nlobs.systems as systems
    import nlobs.workflows as workflows

    for pkg, names in (
        (systems, ["NonlinearSubsystem", "LinearSubsystem", "InterconnectedPlant", "interconnected_plant"]),
        (geometry, ["LipschitzEstimates", "lipschitz_estimates"]),
        (linear, ["check_assumption4", "require_assumption4", "Assumption4Report", "extended_system", "hinf_grid_peak"]),
        (synthesis, ["design_cascade_gain", "place_cascade_gain", "theorem1_gamma_bound", "quadratic_lyapunov_constants",
                     "ErrorBoundConstants", "error_bound_constants", "HighGain", "high_gain_coefficients"]),
        (observers, ["CascadeObserver", "DriftObserver", "PinvObserver", "ByrnesIsidoriObserver"]),
        (workflows, ["design_drift_observer", "DriftWorkflowReport", "design_pinv_observer", "PinvWorkflowReport",
                     "gamma_sweep", "GammaSweep", "SimulationRequest", "escape_unsafe"]),
    ):
        for n in names:
            assert n in pkg.__all__ and getattr(pkg, n) is not None, (pkg.__name__, n)
    assert synthesis.extended_system is linear.extended_system
