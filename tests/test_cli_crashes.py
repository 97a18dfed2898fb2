"""No traceback for any input: inputs that used to crash the command line end in one line and exit 2, or work.

Each case was a traceback (NameError, TypeError, RecursionError, OSError, MemoryError) or an
unclear exit before; the tests pin the typed error, its option or file line, and that it comes
before any expensive work.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from nlobs.cli import app

runner = CliRunner()


def _model(tmp_path: Path, f: list[str], *, states: tuple[str, str] = ("x1", "x2"), h: str | None = None,
           name: str = "m.toml") -> str:
    p = tmp_path / name
    fs = ", ".join(json.dumps(e) for e in f)
    p.write_text(f'name = "m"\ntime = "continuous"\nstates = ["{states[0]}", "{states[1]}"]\ninputs = ["u"]\n'
                 f'outputs = ["y"]\n\n[dynamics]\nf = [{fs}]\ng = [["0"], ["1"]]\nh = ["{h or states[0]}"]\n',
                 encoding="utf-8")
    return str(p)


def _one_line_error(res, *needles: str) -> str:  # type: ignore[no-untyped-def]
    """The run exited 2 with exactly one ``nlobs: error:`` line naming every needle, and no traceback."""
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    assert res.exit_code == 2, (res.exit_code, res.output)
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("nlobs: error: "), res.stderr
    assert "Traceback" not in res.output
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


# ----------------------------------------------------------------------------- 1. sign()
def test_sign_model_is_analyzed(tmp_path: Path) -> None:
    # d sign(x)/dx is DiracDelta(x): its compiled form is 0 away from 0 and NaN at 0 (not a NameError)
    model = _model(tmp_path, ["x2", "-sign(x1)"])
    res = runner.invoke(app, ["analyze", model, "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert "not finite at x0=[0.0, 0.0]" in data["linearization_error"]  # no derivative at the jump
    res = runner.invoke(app, ["analyze", model, "--x0", "1,0", "--json"])
    assert res.exit_code == 0, res.output
    lin = json.loads(res.stdout)["linearization"]  # away from the jump the derivative is 0: A = [[0, 1], [0, 0]]
    assert lin["eigenvalues"] == [[0.0, 0.0], [0.0, 0.0]] and lin["observable"] is True


def test_sign_model_drift_design_is_refused_because_it_jumps(tmp_path: Path) -> None:
    model = _model(tmp_path, ["x2", "-sign(x1)"])
    _one_line_error(runner.invoke(app, ["design", "drift", model]), "sign()", "not Lipschitz")
    # the Moore–Penrose observer needs no Lipschitz constant: the plant with a jump still simulates
    res = runner.invoke(app, ["design", "pinv", model, "--simulate", "--x0", "1,0", "--duration", "0.5", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["simulation"]["final_error_norm"] < 1.0


# ----------------------------------------------------------------------------- 2. names and nesting
@pytest.mark.parametrize(("states", "f", "h"), [
    (("sin", "x2"), ["sin(x2)", "-sin"], "sin"),      # a state named like the function the model calls
    (("x1", "cos"), ["sin(cos) + cos(x1)", "-x1"], "x1"),
    (("x1", "exp"), ["exp", "-x1 - exp(exp)"], "x1"),
])
def test_state_named_like_a_function_simulates(tmp_path: Path, states: tuple[str, str], f: list[str], h: str) -> None:
    model = _model(tmp_path, f, states=states, h=h)
    res = runner.invoke(app, ["design", "pinv", model, "--simulate", "--x0", "0.1,0", "--duration", "0.2", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["simulation"]["initial_error_norm"] == pytest.approx(0.1)


@pytest.mark.parametrize(("expr", "reason"), [
    ("sin(" * 150 + "x2" + ")" * 150, "nested deeper than 100 levels"),
    ("-" * 3000 + "x2", "too complex to parse"),
    ("-" * 1000 + "x2", "nested deeper than 100 levels"),
])
def test_deep_expressions_are_a_model_file_error_with_its_line(tmp_path: Path, expr: str, reason: str) -> None:
    model = _model(tmp_path, [expr, "-x1"])
    _one_line_error(runner.invoke(app, ["analyze", model]), f"{model}:8: [dynamics].f: expression {reason}")


def test_long_sum_is_analyzed(tmp_path: Path) -> None:
    model = _model(tmp_path, ["+".join(["x2"] * 1000), "-x1"])
    res = runner.invoke(app, ["analyze", model, "--json"])
    assert res.exit_code == 0, res.output
