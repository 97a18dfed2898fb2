"""The nlobs command line: reports, --json keys, exit statuses and one-line errors."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs.cli import app

runner = CliRunner()
LINEAR_KEYS = {
    "observable", "detectable", "left_invertible", "minimum_phase", "invariant_zeros",
    "stable", "hinf_norm", "strongly_detectable", "h2_norm", "normal_rank", "eigenvalues",
    "n", "m", "p", "name", "time", "dt", "kind",
}


def _json(*args: str) -> dict:
    res = runner.invoke(app, [*args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_linear_json_keys_and_closed_form_values() -> None:
    d = _json("analyze", "grip-example1-filter")
    assert LINEAR_KEYS <= set(d)
    assert d["kind"] == "linear" and (d["n"], d["m"], d["p"]) == (2, 1, 1)
    # 1/(s^2+s+1): peak |G(jω)| at ω² = 1/2 is 2/√3; H2 norm² = 1/2 (closed forms)
    assert d["hinf_norm"] == pytest.approx(2 / math.sqrt(3), rel=1e-8)
    assert d["h2_norm"] == pytest.approx(math.sqrt(0.5), rel=1e-10)
    assert d["invariant_zeros"] == [] and d["normal_rank"] == 3
    for key in ("observable", "detectable", "left_invertible", "minimum_phase", "stable", "strongly_detectable"):
        assert d[key] is True, key


def test_unstable_linear_model_has_null_hinf_norm() -> None:
    d = _json("analyze", "gnss-ins-axis")
    assert d["stable"] is False and d["hinf_norm"] is None and d["h2_norm"] is None
    assert d["left_invertible"] is True and d["minimum_phase"] is True


def test_discrete_model_reports_its_time_base() -> None:
    d = _json("analyze", "double-integrator-discrete")
    assert d["time"] == "discrete" and d["dt"] == 0.1
    assert d["observable"] is True and d["stable"] is False
    # ZOH double integrator with position output has the invariant zero z = -1 (on the unit circle)
    zeros = [complex(*z) for z in d["invariant_zeros"]]
    assert len(zeros) == 1 and abs(zeros[0] + 1) < 1e-9
    assert d["minimum_phase"] is False


def test_nonlinear_report_and_linearisation_match_the_hand_jacobian() -> None:
    d = _json("analyze", "pendulum", "--x0", "0.5,0")
    assert d["kind"] == "nonlinear" and d["input_affine"] is True
    assert d["states"] == ["theta", "omega"] and d["parameters"]["g"] == 9.81
    lin = d["linearization"]
    assert lin["x0"] == [0.5, 0.0]
    # A = [[0, 1], [-(g/l) cos θ0, -c]] -> eigenvalues of the damped linearisation
    A = np.array([[0.0, 1.0], [-9.81 * np.cos(0.5), -0.2]])
    expected = sorted(np.linalg.eigvals(A), key=lambda z: z.imag)
    got = sorted((complex(*e) for e in lin["eigenvalues"]), key=lambda z: z.imag)
    np.testing.assert_allclose(got, expected, rtol=1e-12)
    assert lin["observable"] is True and lin["stable"] is True


def test_text_report_is_readable() -> None:
    res = runner.invoke(app, ["analyze", "isidori-146"])
    assert res.exit_code == 0
    assert "input-affine" in res.stdout and "n=4 states" in res.stdout and "y = x4" in res.stdout


def test_models_lists_the_shipped_files() -> None:
    res = runner.invoke(app, ["models", "--json"])
    names = {m["name"] for m in json.loads(res.stdout)}
    assert {"isidori-146", "gnss-ins-axis", "pendulum", "grip-example1-filter"} <= names


@pytest.mark.parametrize(
    ("content", "pieces"),
    [
        ('states = ["x"]\noutputs = ["y"]\n[dynamics]\nf = ["__import__(\'os\')"]\nh = ["x"]\n',
         [":4:", "not in the whitelist", "__import__"]),
        ('states = ["x"]\noutputs = ["y"]\n[dynamics]\nf = ["x"]\nh = ["q"]\n', [":5:", "undeclared name", "'q'"]),
        ('states = ["x"\n', [":", "invalid TOML"]),
    ],
)
def test_bad_model_file_exits_2_with_one_line(tmp_path: Path, content: str, pieces: list[str]) -> None:
    p = tmp_path / "bad.toml"
    p.write_text(content)
    for cmd in (["analyze", str(p)], ["analyze", str(p), "--json"]):
        res = runner.invoke(app, cmd)
        assert res.exit_code == 2
        err = res.stderr.strip()
        assert len(err.splitlines()) == 1, err
        assert str(p) in err
        for piece in pieces:
            assert piece in err, err


def test_missing_file_and_bad_options_exit_2() -> None:
    res = runner.invoke(app, ["analyze", "no-such-model"])
    assert res.exit_code == 2 and "no such file" in res.stderr and "isidori-146" in res.stderr
    res = runner.invoke(app, ["analyze", "pendulum", "--x0", "0,abc"])
    assert res.exit_code == 2 and "--x0: expected comma-separated numbers" in res.stderr
    res = runner.invoke(app, ["analyze", "pendulum", "--x0", "0,nan"])
    assert res.exit_code == 2 and "finite" in res.stderr
    res = runner.invoke(app, ["analyze", "pendulum", "--x0", "0,1,2"])
    assert res.exit_code == 2 and "x0: expected length 2" in res.stderr
    res = runner.invoke(app, ["analyze", "gnss-ins-axis", "--x0", "0,1"])
    assert res.exit_code == 2 and "only used for nonlinear" in res.stderr


def test_installed_console_script_runs() -> None:
    exe = Path(sys.executable).with_name("nlobs")
    if not exe.exists():
        pytest.skip("console script not installed next to this interpreter")
    out = subprocess.run([str(exe), "analyze", "grip-example1-filter", "--json"], capture_output=True, text=True,
                         check=True, timeout=120)
    assert json.loads(out.stdout)["hinf_norm"] == pytest.approx(2 / math.sqrt(3), rel=1e-8)


def test_reproduce_help_names_every_paper_and_version_flag() -> None:
    from nlobs.papers.reproduce import PAPERS

    r = CliRunner()
    res = r.invoke(app, ["reproduce", "--help"])
    assert res.exit_code == 0
    for name in PAPERS:
        assert name in res.output, name
    # the plain help keeps units in brackets (rich markup would eat "[s]") and shows no type on flags
    res = r.invoke(app, ["design", "cascade", "--help"], terminal_width=100)
    assert "Simulated time [s]." in " ".join(res.output.split()) and "<bool>" not in res.output
    from importlib.metadata import version

    for args in (["--version"], ["version"]):
        res = r.invoke(app, args)
        assert res.exit_code == 0 and res.stdout.strip() == version("nlobs")


def test_python_dash_m_nlobs_runs_the_cli() -> None:
    res = subprocess.run([sys.executable, "-m", "nlobs", "--version"], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0 and res.stdout.strip()
