"""Small input cannot exhaust time or memory: bounded numbers, expressions, files and models.

Cases that used to hang run in a subprocess with a timeout, so that a
regression fails the test instead of hanging the suite.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import sympy as sp
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.errors import ModelFileError
from nlobs.systems.expressions import MAX_DEPTH, MAX_DIGITS, MAX_EXPONENT, ExpressionError, parse_expression
from nlobs.systems.modelfile import (
    MAX_FILE_BYTES,
    MAX_NAMES,
    MAX_STRINGS,
    load_discrete_ui_model,
    load_model,
    parse_model,
)

SRC = Path(__file__).resolve().parents[1] / "src"
SYMS = {"x": sp.Symbol("x", real=True)}
runner = CliRunner()
MODEL = 'states = ["x"]\noutputs = ["y"]\n[dynamics]\nrhs = ["-x"]\nh = ["x"]\n'


def _isolated(code: str, timeout: float = 20.0) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a fresh interpreter with nlobs on the path; a hang is a test failure, not a stuck suite."""
    env = {**os.environ, "PYTHONPATH": str(SRC), "MPLBACKEND": "Agg"}
    try:
        return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail(f"did not finish within {timeout} s:\n{code}")


def _parse_quickly(text: str) -> ExpressionError:
    t0 = time.perf_counter()
    with pytest.raises(ExpressionError) as info:
        parse_expression(text, SYMS)
    assert time.perf_counter() - t0 < 1.0
    assert "\n" not in str(info.value)
    return info.value


# ------------------------------------------------------------------ numbers
def test_nested_integer_powers_are_refused_before_they_are_computed() -> None:
    code = ("from nlobs.systems.expressions import parse_expression, ExpressionError\n"
            "import sympy as sp\n"
            "try:\n    parse_expression('((9**999)**999)**999', {'x': sp.Symbol('x', real=True)})\n"
            "except ExpressionError as e:\n    print('refused:', e)\n")
    res = _isolated(code)
    assert res.returncode == 0 and res.stdout.startswith("refused: power out of range"), res.stdout + res.stderr


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("9**999", "power out of range"),
        ("(1/9)**999", "power out of range"),
        ("2.0**999", "power out of range"),
        ("*".join(["9**90"] * 10), "product of numbers out of range"),
        ("9**300*9**300*x", "product of numbers out of range"),
        ("1" * (MAX_DIGITS + 1), "number literal with more than"),
        ("9*10**299 + 2*10**299", "number out of range"),
        ("1" * 5000, "number literal with more than"),
        ("1" * 19000 + "*x", "number literal with more than"),  # beyond Python's own int() digit limit
        ("0." + "0" * 400 + "1", "number literal with more than"),
        ("1e400", "float literal overflows a double"),
        ("1e400*x - 1e400*x", "float literal overflows a double"),
        ("10.0**299*10.0**299", "product of numbers out of range"),
        ("(x**999)**999", "once powers are combined"),
        ("x**999*x**999", "once powers are combined"),
        ("((x+1)**999)**999", "power out of range"),  # (x+1)**999's binomial coefficients reach 10^299
        ("sqrt(-1)*x", "non-real constant"),
        ("9**9**9**9", "exponent larger than"),
    ],
)
def test_numbers_beyond_the_bounds_are_refused_quickly(text: str, match: str) -> None:
    assert match in str(_parse_quickly(text))


def test_numbers_within_the_bounds_still_fold_exactly() -> None:
    assert parse_expression("2**996", SYMS) == sp.Integer(2) ** 996
    assert parse_expression("1" * MAX_DIGITS, SYMS) == sp.Integer("1" * MAX_DIGITS)
    assert parse_expression("(1/3)**5 * x", SYMS) == SYMS["x"] / 243
    assert parse_expression("*".join(["2"] * 400), SYMS) == sp.Integer(2) ** 400
    assert parse_expression(f"x**{MAX_EXPONENT}", SYMS) == SYMS["x"] ** MAX_EXPONENT
    assert float(parse_expression("10.0**299", SYMS)) == pytest.approx(1e299)


# ------------------------------------------------------------------ depth and size
@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("sin(" * 150 + "x" + ")" * 150, f"nested deeper than {MAX_DEPTH} levels"),
        ("-" * 3000 + "x", "too complex to parse"),
        ("+".join(["x"] * 5000), "too complex to parse"),
        ("-" * 500 + "x", f"nested deeper than {MAX_DEPTH} levels"),
        ("(" * 3000 + "x" + ")" * 3000, "too many nested parentheses"),
        ("x" + "**x" * 200, f"nested deeper than {MAX_DEPTH} levels"),
        ("x+" * 12000 + "x", "longer than"),
    ],
)
def test_deep_expressions_raise_expression_error_not_recursion_error(text: str, match: str) -> None:
    assert match in str(_parse_quickly(text))


def test_long_flat_sums_and_products_are_one_level_and_parse_fast() -> None:
    x = SYMS["x"]
    t0 = time.perf_counter()
    assert parse_expression("+".join(["x"] * 1000), SYMS) == 1000 * x
    assert parse_expression("-".join(["x"] * 2000), SYMS) == -1998 * x
    assert parse_expression("*".join(["x"] * 500), SYMS) == x**500
    assert parse_expression("+".join(f"{i}*x**2" for i in range(2000)), SYMS) == sum(range(2000)) * x**2
    assert parse_expression("sin(" * 50 + "x" + ")" * 50, SYMS).count(sp.sin) == 50
    assert time.perf_counter() - t0 < 5.0


def test_messages_quote_at_most_a_few_hundred_characters() -> None:
    err = _parse_quickly("+".join(["x"] * 2000) + "+z")
    assert len(str(err)) < 600 and err.offending == "z" and len(err.expression) > 4000


# ------------------------------------------------------------------ models
def _states(n: int) -> str:
    names = [f"x{i}" for i in range(n)]
    return ("states = [" + ", ".join(f'"{s}"' for s in names) + ']\noutputs = ["y"]\n[dynamics]\nrhs = ['
            + ", ".join(f'"-{s} + x0"' for s in names) + ']\nh = ["x0"]\n')


def test_a_thousand_state_model_parses_in_well_under_a_second() -> None:
    t0 = time.perf_counter()
    model = parse_model(_states(MAX_NAMES))
    assert time.perf_counter() - t0 < 2.0
    assert model.n == MAX_NAMES


def test_too_many_names_are_refused_quickly_with_the_line() -> None:
    t0 = time.perf_counter()
    with pytest.raises(ModelFileError, match=f"30000 names, more than the limit of {MAX_NAMES}") as info:
        parse_model(_states(30_000), source="big.toml")
    assert time.perf_counter() - t0 < 3.0
    assert info.value.line == 1
    params = "parameters = {" + ", ".join(f"p{i} = 1" for i in range(MAX_NAMES + 1)) + "}\n"
    with pytest.raises(ModelFileError, match="more than the limit"):
        parse_model(params + MODEL)


def test_too_many_strings_are_refused_before_parsing_them() -> None:
    n = 150
    st = ", ".join(f'"x{i}"' for i in range(n))
    zeros = ", ".join(['"0"'] * n)
    rows = ", ".join([f"[{zeros}]"] * n)
    text = (f"states = [{st}]\ninputs = [{st.replace('x', 'u')}]\noutputs = [\"y\"]\n[dynamics]\n"
            f"f = [{zeros}]\ng = [{rows}]\nh = [\"x0\"]\n")
    assert n * n > MAX_STRINGS
    t0 = time.perf_counter()
    with pytest.raises(ModelFileError, match=f"more than {MAX_STRINGS} strings"):
        parse_model(text)
    assert time.perf_counter() - t0 < 3.0


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("a = " + "[" * 3000 + "]" * 3000 + "\n" + MODEL, "nested too deeply"),
        ("a = " + "{b=" * 3000 + "1" + "}" * 3000 + "\n" + MODEL, "nested too deeply"),
        ("parameters = { k = 1" + "0" * 5000 + " }\n" + MODEL, "invalid TOML"),
        ("parameters = { k = 1" + "0" * 400 + " }\n" + MODEL, "integer too large"),
        ('name = "l"\n[linear]\nA = [[1' + "0" * 400 + "]]\nC = [[1]]\n", "integer too large"),
        ("dt = 1" + "0" * 400 + '\ntime = "discrete"\n' + MODEL, "integer too large"),
        (MODEL.replace('"-x"', '"' + "-" * 3000 + 'x"'), "too complex to parse"),
    ],
)
def test_hostile_model_text_gives_a_model_file_error(text: str, match: str) -> None:
    t0 = time.perf_counter()
    with pytest.raises(ModelFileError, match=match) as info:
        parse_model(text, source="m.toml")
    assert time.perf_counter() - t0 < 3.0
    assert str(info.value).startswith("m.toml") and "\n" not in str(info.value)


# ------------------------------------------------------------------ files
def test_special_files_are_refused_without_reading_them(tmp_path: Path) -> None:
    fifo = tmp_path / "model.toml"
    os.mkfifo(fifo)
    code = ("from nlobs.systems.modelfile import load_model, load_discrete_ui_model\n"
            "from nlobs.errors import ModelFileError\n"
            f"for load in (load_model, load_discrete_ui_model):\n"
            f"    for p in ({str(fifo)!r}, '/dev/zero', {str(tmp_path)!r}):\n"
            "        try:\n            load(p)\n        except ModelFileError as e:\n            print(e)\n")
    res = _isolated(code)
    lines = res.stdout.splitlines()
    assert res.returncode == 0 and len(lines) == 6, res.stdout + res.stderr
    assert lines[0].endswith("not a regular file (a FIFO)") and lines[1].endswith("not a regular file (a device)")
    assert lines[2].endswith("not a regular file (a directory)")


def test_files_over_the_size_bound_and_non_utf8_are_refused(tmp_path: Path) -> None:
    big = tmp_path / "big.toml"
    big.write_text("# " + "a" * (2 * MAX_FILE_BYTES) + "\n" + MODEL)
    for load in (load_model, load_discrete_ui_model):
        with pytest.raises(ModelFileError, match="file larger than 1048576 bytes"):
            load(big)
    at_limit = tmp_path / "ok.toml"
    at_limit.write_text("#" * (MAX_FILE_BYTES - len(MODEL) - 1) + "\n" + MODEL)
    assert load_model(at_limit).n == 1
    bad = tmp_path / "bad.toml"
    bad.write_bytes(MODEL.encode() + b"# \xff\xfe\n")
    with pytest.raises(ModelFileError, match="not UTF-8"):
        load_model(bad)


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    code = "import sys\nfrom nlobs.cli import app\napp(sys.argv[1:], prog_name='nlobs')\n"
    env = {**os.environ, "PYTHONPATH": str(SRC), "MPLBACKEND": "Agg"}
    try:
        return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=20, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail(f"nlobs {' '.join(args)} did not finish within 20 s")


@pytest.mark.parametrize("kind", ["dev-zero", "fifo", "directory", "2 MB file"])
@pytest.mark.parametrize("command", [["analyze"], ["design", "setvalued"]])
def test_cli_refuses_special_and_huge_files_with_one_line(kind: str, command: list[str], tmp_path: Path) -> None:
    if kind == "dev-zero":
        target = "/dev/zero"
    elif kind == "fifo":
        target = str(tmp_path / "m.toml")
        os.mkfifo(target)
    elif kind == "directory":
        target = str(tmp_path)
    else:
        target = str(tmp_path / "big.toml")
        Path(target).write_text("# " + "a" * 2_000_000 + "\n" + MODEL)
    res = _cli(*command, target)
    assert res.returncode == 2, res.stdout + res.stderr
    assert "Traceback" not in res.stderr and res.stdout == ""
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"nlobs: error: {target}: "), res.stderr


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (MODEL.replace('"-x"', '"((9**999)**999)**999"'), "power out of range"),
        (MODEL.replace('"-x"', '"' + "-" * 3000 + 'x"'), "too complex to parse"),
        (MODEL.replace('"-x"', '"' + "+".join(["x"] * 3000) + '"'), "too complex to parse"),
        ("a = " + "[" * 3000 + "]" * 3000 + "\n" + MODEL, "nested too deeply"),
        ("parameters = { k = 1" + "0" * 5000 + " }\n" + MODEL, "invalid TOML"),
        (MODEL.replace('"-x"', '"sqrt(-1)*x"'), "non-real constant"),
    ],
)
def test_cli_hostile_model_text_exits_2_with_one_line(text: str, match: str, tmp_path: Path) -> None:
    p = tmp_path / "m.toml"
    p.write_text(text)
    res = _cli("analyze", str(p))
    assert res.returncode == 2, res.stdout + res.stderr
    assert "Traceback" not in res.stderr and res.stdout == ""
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"nlobs: error: {p}") and match in lines[0], res.stderr


def test_cli_analyzes_a_long_flat_sum(tmp_path: Path) -> None:
    p = tmp_path / "m.toml"
    p.write_text(MODEL.replace('"-x"', '"' + "+".join(["-x"] * 1000) + '"').replace("rhs", "f"))
    res = runner.invoke(app, ["analyze", str(p), "--json"])
    assert res.exit_code == 0, res.output


def _nested_sin_model(tmp_path: Path, depth: int) -> Path:
    h = "sin(" * depth + "x1" + ")" * depth
    p = tmp_path / f"deep{depth}.toml"
    p.write_text(f'name = "deep{depth}"\nstates = ["x1", "x2"]\ninputs = []\noutputs = ["y"]\n'
                 f'[dynamics]\nf = ["x2", "-x1"]\nh = ["{h}"]\n')
    return p


def test_the_derivative_size_estimate_is_exact_for_a_chain_and_bounds_lie_derivatives() -> None:
    from nlobs.errors import ExpressionTooLarge
    from nlobs.geometry.lie import MAX_DERIVATIVE_NODES, derivative_size, lie_derivatives

    x1, x2 = sp.symbols("x1 x2", real=True)
    chain = x1
    for _ in range(30):
        chain = sp.sin(chain)
    exact = sum(1 for _ in sp.preorder_traversal(sp.diff(chain, x1)))
    assert derivative_size(chain) == exact == 31 * 32 // 2
    assert derivative_size(sp.sin(sp.sin(x1))) == 6
    # h itself passes (5 050); L_f h of the 99-deep chain would have a gradient of about 510 000 nodes
    deep = x1
    for _ in range(99):
        deep = sp.sin(deep)
    (h,) = lie_derivatives(deep, [x2, -x1], [x1, x2], 1, name="h of output 'y'")
    assert h == deep
    with pytest.raises(ExpressionTooLarge, match=f"L_f\\^1 h of output 'y'.*limit of {MAX_DERIVATIVE_NODES}"):
        lie_derivatives(deep, [x2, -x1], [x1, x2], 2, name="h of output 'y'")


@pytest.mark.parametrize("command", [["analyze"], ["design", "drift"]])
def test_cli_refuses_a_99_deep_nested_output_with_one_line_instead_of_running_for_minutes(
    command: list[str], tmp_path: Path
) -> None:
    p = _nested_sin_model(tmp_path, MAX_DEPTH - 1)
    code = "import sys\nfrom nlobs.cli import app\napp(sys.argv[1:], prog_name='nlobs')\n"
    env = {**os.environ, "PYTHONPATH": str(SRC), "MPLBACKEND": "Agg"}
    try:  # a guard against the old minutes-long run, not a measurement of speed
        res = subprocess.run([sys.executable, "-c", code, *command, str(p)], capture_output=True, text=True,
                             timeout=100, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail(f"nlobs {' '.join(command)} of a {MAX_DEPTH - 1}-deep sin( chain did not finish within 100 s")
    assert res.returncode == 2, res.stdout + res.stderr
    assert "Traceback" not in res.stderr
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"nlobs: error: {p}: L_f^1 h of output 'y'"), res.stderr
    assert "MAX_DERIVATIVE_NODES" in lines[0]

