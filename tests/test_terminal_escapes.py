"""Text from a file or an argument never reaches the terminal raw, and names are unambiguous.

A model file is refused at load time when any of its strings holds a control
character (``ESC`` among them) or a bidirectional override, and the CLI
escapes such characters again at the output boundary (``safe_text``), so that
text nobody anticipated cannot emit an escape sequence either.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import sympy as sp
from rich.table import Table
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.cli.common import console, safe_text
from nlobs.errors import ModelError, ModelFileError
from nlobs.systems.modelfile import parse_model
from nlobs.systems.symbolic import SymbolicModel

runner = CliRunner()
MODEL = 'name = "NAME"\nstates = ["x", "STATE"]\noutputs = ["y"]\n[dynamics]\nrhs = ["-x", "0"]\nh = ["x"]\n'
# TOML escapes: the file itself is plain ASCII, the strings it defines are not
HOSTILE = ["\\u001b[31mred", "\\u001b]0;title\\u0007", "evil\\u202etxt.exe", "a\\u2066b", "\\u009b31m", "x\\r\\u007f"]


def _file(tmp_path: Path, text: str, name: str = "m.toml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def _assert_clean_failure(res: object) -> str:
    out = res.stdout + res.stderr  # type: ignore[attr-defined]
    assert res.exit_code == 2, out  # type: ignore[attr-defined]
    assert "\x1b" not in out and "\x07" not in out and "\u202e" not in out and "\x9b" not in out, repr(out)
    assert "Traceback" not in out
    lines = res.stderr.splitlines()  # type: ignore[attr-defined]
    assert len(lines) == 1 and lines[0].startswith("nlobs: error: "), repr(res.stderr)  # type: ignore[attr-defined]
    return lines[0]


@pytest.mark.parametrize("hostile", HOSTILE)
@pytest.mark.parametrize("where", ["name", "state", "expression", "description", "parameter"])
def test_control_characters_in_a_model_file_exit_2_without_reaching_the_terminal(
        hostile: str, where: str, tmp_path: Path) -> None:
    text = MODEL.replace("NAME", "model").replace('"STATE"', '"x2"')
    if where == "name":
        text = text.replace('name = "model"', f'name = "{hostile}"')
    elif where == "state":
        text = text.replace('"x2"', f'"{hostile}"', 1)
    elif where == "expression":
        text = text.replace('"-x"', f'"-x + {hostile}"')
    elif where == "description":
        text = f'description = "{hostile}"\n' + text
    else:
        text = f'parameters = {{ "{hostile}" = 1.0 }}\n' + text
    p = _file(tmp_path, text)
    line = _assert_clean_failure(runner.invoke(app, ["analyze", str(p)]))
    assert str(p) in line


def test_the_load_time_error_names_the_file_line_and_escaped_text() -> None:
    with pytest.raises(ModelFileError) as info:
        parse_model(MODEL.replace("NAME", "\\u001b[31mred").replace('"STATE"', '"x2"'), source="m.toml")
    err = info.value
    assert err.line == 1 and "U+001B" in str(err) and "\\x1b[31mred" in str(err) and "\x1b" not in str(err)
    with pytest.raises(ModelFileError, match="'name' must be one line") as info:
        parse_model(MODEL.replace("NAME", "two\\nlines").replace('"STATE"', '"x2"'), source="m.toml")
    assert info.value.line == 1
    # a multi-line description is fine; control characters are not
    ok = 'description = """two\nlines"""\n' + MODEL.replace("NAME", "m").replace('"STATE"', '"x2"')
    assert parse_model(ok).n == 2


def test_an_escape_in_the_file_name_or_an_argument_is_escaped_on_output(tmp_path: Path) -> None:
    p = _file(tmp_path, MODEL.replace('name = "NAME"\n', "").replace('"STATE"', '"x2"'), "m\x1b[31m.toml")
    res = runner.invoke(app, ["analyze", str(p)])
    assert res.exit_code == 0, res.output
    assert "\x1b" not in res.stdout and "m\\x1b[31m" in res.stdout  # the default name is the file's stem, escaped
    line = _assert_clean_failure(runner.invoke(app, ["analyze", "no\x1b]0;pwned\x07such.toml"]))
    assert "no\\x1b]0;pwned\\x07such.toml: no such file" in line


def test_safe_text_and_the_report_console_escape_every_control_character() -> None:
    assert safe_text("a\x1b[31mb\x07c\u202ed\u2069e\x9bf\x7fg") == "a\\x1b[31mb\\x07c\\u202ed\\u2069e\\x9bf\\x7fg"
    assert safe_text("two\nlines\tok θ≤ẋ") == "two\nlines\tok θ≤ẋ"
    assert safe_text("two\nlines", one_line=True) == "two\\x0alines"
    con = console()
    table = Table(title="t\x1b[2J")
    table.add_column("c\x1b[31m")
    table.add_row("\x1b]0;title\x07")
    with con.capture() as cap:
        con.print("model \x1b[31mred\u202e", markup=False)
        con.print(table)
    out = cap.get()
    assert "\x1b" not in out and "\x07" not in out and "\u202e" not in out
    assert "\\x1b[31mred\\u202e" in out and "\\x1b]0;title\\x07" in out


# ------------------------------------------------------------------ names
def test_fullwidth_names_that_python_reads_as_ascii_are_refused(tmp_path: Path) -> None:
    text = MODEL.replace("NAME", "m").replace('"STATE"', '"ｘ"')
    with pytest.raises(ModelFileError, match="NFKC") as info:
        parse_model(text, source="m.toml")
    assert info.value.line == 2 and "'x'" in str(info.value)
    _assert_clean_failure(runner.invoke(app, ["analyze", str(_file(tmp_path, text))]))
    with pytest.raises(ModelError, match="NFKC"):
        SymbolicModel.general(["x", "ｘ"], [], ["y"], rhs=[0, 0], h=[sp.Symbol("x")])
    with pytest.raises(ModelError, match="NFKC"):
        SymbolicModel.general(["ﬁ"], [], ["y"], rhs=[0], h=[0])  # the ligature reads as "fi"
    # names already in NFKC form, ASCII or not, are fine
    assert SymbolicModel.general(["θ", "ω"], [], ["y"], rhs=["ω", "-sin(θ)"], h=["θ"]).states == ("θ", "ω")


def test_keywords_are_refused_as_names(tmp_path: Path) -> None:
    text = MODEL.replace("NAME", "m").replace('"STATE"', '"lambda"')
    with pytest.raises(ModelFileError, match="'lambda' is not a valid name \\(a Python keyword\\)"):
        parse_model(text)
    with pytest.raises(ModelError, match="keyword"):
        SymbolicModel.general(["x", "None"], [], ["y"], rhs=[0, 0], h=[0])
    with pytest.raises(ModelFileError, match="keyword"):
        parse_model("parameters = { if = 1.0 }\n" + MODEL.replace("NAME", "m").replace('"STATE"', '"x2"'))
