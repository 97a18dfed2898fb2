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


def _chain(tmp_path: Path, n: int, extra: str = "") -> Path:
    """A chain of ``n`` integrators ``ẋ_i = x_{i+1}`` (plus ``extra`` with ``{i}``), ``ẋ_n = −x1 + u``, ``y = x1``."""
    p = tmp_path / "chain.toml"
    states = ", ".join(f'"x{i}"' for i in range(1, n + 1))
    f = ", ".join(f'"x{i + 1}{extra.format(i=i)}"' for i in range(1, n)) + ', "-x1"'
    g = ", ".join('["0"]' for _ in range(n - 1)) + ', ["1"]'
    p.write_text(f'name = "chain"\ntime = "continuous"\nstates = [{states}]\ninputs = ["u"]\noutputs = ["y"]\n'
                 f'[dynamics]\nf = [{f}]\ng = [{g}]\nh = ["x1"]\n', encoding="utf-8")
    return p


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


# ----------------------------------------------------------------------------- 3. --out
def _no_design(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if a design starts: a bad option must be refused before it."""
    import nlobs.workflows.design_drift as dd
    import nlobs.workflows.design_pinv as dp

    def boom(*args: object, **kwargs: object) -> None:
        raise AssertionError("the design ran before the bad option was refused")

    monkeypatch.setattr(dd, "design_drift_report", boom)
    monkeypatch.setattr(dp, "design_pinv_report", boom)


SIM = ["--simulate", "--x0", "0.1,0", "--duration", "0.1"]


@pytest.mark.parametrize("command", ["drift", "pinv"])
def test_out_that_is_a_file_is_refused_before_the_design_and_kept(tmp_path: Path, command: str,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    precious = tmp_path / "results"
    precious.write_text("a previous good output\n", encoding="utf-8")
    _no_design(monkeypatch)
    for out in (precious, precious / "sub", Path("/dev/full")):
        line = _one_line_error(runner.invoke(app, ["design", command, "pendulum", *SIM, "--out", str(out)]),
                               f"--out {out}: cannot create the folder")
        assert "Traceback" not in line
    assert precious.read_text(encoding="utf-8") == "a previous good output\n"


def test_out_keeps_previous_files_when_the_run_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "out"
    res = runner.invoke(app, ["design", "pinv", "pendulum", *SIM, "--out", str(out)])
    assert res.exit_code == 0, res.output
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(before) == {"pinv.png", "pinv.npz"}
    _no_design(monkeypatch)
    _one_line_error(runner.invoke(app, ["design", "pinv", "pendulum", *SIM[:-1], "1e12", "--out", str(out)]),
                    "--duration 1e+12")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


# ----------------------------------------------------------------------------- 4. sizes and numbers
@pytest.mark.parametrize("command", ["drift", "pinv"])
@pytest.mark.parametrize(("options", "needles"), [
    (["--duration", "1e12"], ["--duration 1e+12 / --dt 0.001 is 1e+15 RK4 steps", "at most 1e+07"]),
    (["--dt", "1e-12"], ["--duration 10 / --dt 1e-12 is 1e+13 RK4 steps"]),
    (["--duration", "-1"], ["--duration: must be positive"]),
    (["--duration", "0"], ["--duration: must be positive"]),
    (["--dt", "0"], ["--dt: must be positive"]),
    (["--dt", "nan"], ["--dt: must be finite"]),
    (["--duration", "inf"], ["--duration: must be finite"]),
])
def test_bad_duration_and_dt_are_refused_at_once(command: str, options: list[str], needles: list[str],
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    _no_design(monkeypatch)
    t0 = time.perf_counter()
    res = runner.invoke(app, ["design", command, "pendulum", "--simulate", "--x0", "0.1,0", *options])
    _one_line_error(res, *needles)
    assert time.perf_counter() - t0 < 5.0


def test_simulation_memory_estimate_is_refused_before_the_design(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    # a chain of 14 integrators: 1e7 steps (within the step bound) of t, x, x̂ (14 each), y: about 2.24 GiB
    n = 14
    p = _chain(tmp_path, n)
    _no_design(monkeypatch)
    res = runner.invoke(app, ["design", "pinv", str(p), "--simulate", "--x0", ",".join(["0"] * n),
                              "--duration", "1e7", "--dt", "1"])
    _one_line_error(res, "--duration 1e+07 / --dt 1: 10000000 steps of model chain need about 2.24 GiB",
                    "at most 2 GiB")


@pytest.mark.parametrize(("options", "needle"), [
    (["--mu", "1e308"], "--mu: 1e+308 is larger than 1e+100"),
    (["--alpha", "1e308"], "--alpha: 1e+308 is larger than 1e+100"),
    (["--gamma", "1e200"], "--gamma: 1e+200 is larger than 1e+100"),
    (["--mu", "nan"], "--mu: must be finite"),
    (["--alpha", "-1"], "--alpha: must be positive"),
])
def test_drift_constants_that_overflow_are_refused_before_the_design(options: list[str], needle: str,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    _no_design(monkeypatch)
    _one_line_error(runner.invoke(app, ["design", "drift", "pendulum", *options]), needle)


def test_drift_w_that_overflows_is_a_one_line_error() -> None:
    _one_line_error(runner.invoke(app, ["design", "drift", "pendulum", "--w", "1e308"]), "w: 1e+308 is too large")


def test_demo_out_that_is_a_file_is_one_line(tmp_path: Path) -> None:
    precious = tmp_path / "results"
    precious.write_text("a previous good output\n", encoding="utf-8")
    for out in (precious, precious / "sub", Path("/dev/full")):
        _one_line_error(runner.invoke(app, ["demo", "gnss-ins", "--duration", "1", "--out", str(out)]), f"--out {out}: ")
    assert precious.read_text(encoding="utf-8") == "a previous good output\n"


@pytest.mark.parametrize(("options", "needle"), [
    (["--runs", "100000000"], "--runs 100000000: the per-run summaries alone would take about 37.3 GiB"),
    (["--steps", "100000000000"], "--batch 1000 x --steps 100000000000: too large for one batch: about 2.38e+07 GiB"),
    # within the old bound runs·(steps + 1)·n ≤ 5e8, but about 9.6 GiB: it ended in a MemoryError after the design
    (["--runs", "200000", "--batch", "200000"],
     "--batch 200000 x --steps 200: too large for one batch: about 9.58 GiB"),
])
def test_setvalued_study_memory_is_estimated_and_refused_before_the_design(options: list[str], needle: str,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    import nlobs.workflows.setvalued as sv

    def boom(*args: object, **kwargs: object) -> None:
        raise AssertionError("the design ran before the batch was refused")

    monkeypatch.setattr(sv, "design_setvalued_observer", boom)
    _one_line_error(runner.invoke(app, ["simulate", "setvalued", "khajenejad-6-1", *options]), needle,
                    "at most 4 GiB")


# ----------------------------------------------------------------------------- 5. LMI size
_LMI = """
import sys, time
import numpy as np
import nlobs.synthesis.observer_gain as og
from nlobs.errors import InvalidArgumentError

def no_solver(*args, **kwargs):
    raise AssertionError("the solver was called")

n = int(sys.argv[1])
A = -np.eye(n) + np.diag(np.ones(n - 1), 1)
C, Bd = np.eye(min(n, 10), n), np.eye(n, 1)
if n > 50:
    og.solve = no_solver
t0 = time.perf_counter()
try:
    cert = og.design_observer_gain(A, C, Bd, gamma=10.0, gain_bound=og.GainBound(100.0))
    print("verified", cert.verified)
except InvalidArgumentError as exc:
    print("refused", round(time.perf_counter() - t0, 3), exc)
"""


def _lmi(n: int) -> str:
    import os
    import subprocess
    import sys

    src = str(Path(__file__).resolve().parents[1] / "src")
    res = subprocess.run([sys.executable, "-c", _LMI, str(n)], capture_output=True, text=True, timeout=120,
                         env={**os.environ, "PYTHONPATH": src, "MPLBACKEND": "Agg"})
    assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr
    return res.stdout.strip()


def test_lmi_synthesis_at_n_100_is_refused_before_it_is_built() -> None:
    out = _lmi(100)
    assert out.startswith("refused "), out
    seconds = float(out.split()[1])
    assert seconds < 2.0
    assert "LMI problem too large: n = 100 states give 6053 scalar variables" in out
    assert "semidefinite blocks of sizes 100, 101, 100, 110" in out and "at most 25000" in out
    assert "\n" not in out


def test_lmi_synthesis_at_small_n_still_works() -> None:
    assert _lmi(4) == "verified True"


# ----------------------------------------------------------------------------- 6. model-file lines
_HEAD = 'name = "m"\ntime = "continuous"\nstates = ["x"]\noutputs = ["y"]\n'


@pytest.mark.parametrize(("body", "line", "reason"), [
    # a key written as a dotted key, a quoted key, or inside an inline table
    (_HEAD + 'dynamics.rhs = ["-x", "1"]\ndynamics.h = ["x"]\n', 5, "[dynamics].rhs has 2 entries"),
    (_HEAD + '[dynamics]\n"rhs" = ["-x", "1"]\nh = ["x"]\n', 6, "[dynamics].rhs has 2 entries"),
    (_HEAD + 'dynamics = { rhs = ["-x", "1"], h = ["x"] }\n', 5, "[dynamics].rhs has 2 entries"),
    # a parameter is found as a whole name (it was the first line holding the letter 'a')
    (_HEAD + 'parameters = { a = nan }\n[dynamics]\nrhs = ["-x"]\nh = ["x"]\n', 5, "parameter 'a' must be a finite"),
    # errors of the model constructors, on the key they name
    ('name = "m"\ntime = "continuous"\nstates = []\noutputs = ["y"]\n[dynamics]\nrhs = []\nh = ["1"]\n', 3,
     "a model needs at least one state"),
    # TOML the reader refuses as a whole: the line of the offending text
    (_HEAD + 'parameters = { a = ' + "9" * 5000 + ' }\n[dynamics]\nrhs = ["-x"]\nh = ["x"]\n', 5,
     "invalid TOML (Exceeds the limit"),
    (_HEAD + "z = " + "[" * 3000 + "]" * 3000 + '\n[dynamics]\nrhs = ["-x"]\nh = ["x"]\n', 5,
     "invalid TOML (arrays or tables nested too deeply)"),
])
def test_model_file_errors_name_their_line(tmp_path: Path, body: str, line: int, reason: str) -> None:
    p = tmp_path / "m.toml"
    p.write_text(body, encoding="utf-8")
    _one_line_error(runner.invoke(app, ["analyze", str(p)]), f"{p}:{line}: {reason}")


# ----------------------------------------------------------------------------- second hardening round
def test_hostile_numbers_end_in_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # each was a traceback (exit 1): pi**999 and (10*x1)**400 in a model, θ = 1e300, 99999999999 runs,
    # a 300-character --out, a non-real constant
    for f, needle in ((["x2", "-pi**999*x1"], "power out of range"), (["x2", "-(10*x1)**400"], "power out of range"),
                      (["x2", "-asin(2)*x1"], "non-real constant")):
        _one_line_error(runner.invoke(app, ["analyze", _model(tmp_path, f)]), needle)
    _one_line_error(runner.invoke(app, ["design", "pinv", "pendulum", "--theta", "1e300"]), "beyond double precision",
                    "take θ below")
    _one_line_error(runner.invoke(app, ["simulate", "compare", "pendulum", "--observer", "ekf", "--runs", "99999999999"]),
                    "--runs 99999999999", "use fewer runs")
    long = tmp_path / ("a" * 300)
    _one_line_error(runner.invoke(app, ["simulate", "compare", "pendulum", "--runs", "2", "--out", str(long)]),
                    "File name too long")


def test_an_integer_parameter_beyond_a_double_is_a_model_file_error(tmp_path: Path) -> None:
    p = tmp_path / "big.toml"
    p.write_text('name = "m"\ntime = "continuous"\nstates = ["x1", "x2"]\noutputs = ["y"]\n'
                 f"parameters = {{ a = {10**400} }}\n\n[dynamics]\nf = [\"x2\", \"-a*x1\"]\nh = [\"x1\"]\n",
                 encoding="utf-8")
    _one_line_error(runner.invoke(app, ["analyze", str(p)]), "integer too large")
    p.write_text(p.read_text().replace(str(10**400), "99999999999999999999999"), encoding="utf-8")  # above int64
    res = runner.invoke(app, ["analyze", str(p)])
    assert res.exit_code == 0 and "Traceback" not in res.output, res.output


def test_a_step_longer_than_the_run_is_refused() -> None:
    # before: ran, exit 0, and reported an RMS of 917 for an error that decays
    _one_line_error(runner.invoke(app, ["simulate", "compare", "pendulum", "--runs", "2", "--dt", "10",
                                        "--duration", "1"]), "--dt 10 is longer than --duration 1")
    _one_line_error(runner.invoke(app, ["design", "drift", "pendulum", "--simulate", "--x0", "0.1,0", "--dt", "10",
                                        "--duration", "1"]), "longer than")


def test_the_python_api_refuses_a_step_longer_than_the_run() -> None:
    import nlobs
    from nlobs.errors import InvalidArgumentError
    from nlobs.methods.problem import problem
    from nlobs.methods.registry import get

    pb = problem("pendulum")
    obs = get("luenberger").design(pb).observer
    with pytest.raises(InvalidArgumentError, match="longer than the duration"):
        nlobs.simulate(pb.model.compile(), obs, [0.1, 0.0], [0.0, 0.0], duration=1.0, dt=10.0, u=[0.0])
    res = nlobs.simulate(pb.model.compile(), obs, [0.1, 0.0], [0.0, 0.0], duration=1.0, dt=1.0, u=[0.0])  # one step
    assert res.t[-1] == pytest.approx(1.0)


def test_a_box_beyond_1e100_is_refused_not_called_a_rank_failure() -> None:
    # before: --box ±1e300 said "A1 fails … (σ_min = 1, scaled 0); det Q = 1"
    _one_line_error(runner.invoke(app, ["design", "pinv", "pendulum", "--box", "-1e300,1e300"]),
                    "--box", "larger than 1e+100")
    res = runner.invoke(app, ["design", "pinv", "pendulum", "--box", "-1e50,1e50"])
    assert "A1 (independent dL_f^k h): σ_min(Q) ≥ 1" in res.stdout


@pytest.mark.parametrize(("args", "needle"), [
    (["analyze"], "Missing argument 'MODEL'"), (["bogus"], "No such command 'bogus'"),
    (["simulate", "compare", "pendulum", "--runs", "x"], "Invalid value for '--runs'"),
])
def test_usage_errors_are_one_line(args: list[str], needle: str) -> None:
    # before: click's four lines (usage, a hint, a blank line, the error)
    _one_line_error(runner.invoke(app, args), needle, "--help")


def test_warnings_print_one_line_without_generated_source() -> None:
    # before: a NumPy RuntimeWarning inside a compiled model printed "<lambdifygenerated-3>:2: …" and the source line
    from nlobs.cli.app import _warning_line

    text = _warning_line("overflow encountered in exp", RuntimeWarning, "<lambdifygenerated-3>", 2, "return exp(x1)")
    assert text == "nlobs: warning: RuntimeWarning: overflow encountered in exp\n"
    assert _warning_line("m", UserWarning, "/x/y/z.py", 7) == "nlobs: warning: UserWarning: m (z.py:7)\n"


def test_a_large_model_is_analysed_without_its_lie_derivatives(tmp_path: Path) -> None:
    # before: a 300-state model did not finish in 900 s; a 20-state cubic chain ended in an error after 24 s
    p = _chain(tmp_path, 60, " - 0.1*x{i}**3")
    res = runner.invoke(app, ["analyze", str(p), "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert "60 states: the Lie-derivative analysis is done up to 50 states" in data["geometry_error"]
    assert data["linearization"]["observable"] is True
