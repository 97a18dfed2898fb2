"""Model files: every shipped model loads; every bad input names file, line and offending text."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nlobs.errors import ModelFileError
from nlobs.systems.linear import LinearSystem
from nlobs.systems.modelfile import load_model, parse_model
from nlobs.systems.symbolic import SymbolicModel

MODELS = Path(__file__).resolve().parents[1] / "src" / "nlobs" / "data" / "models"

GOOD = """\
name = "demo"
time = "continuous"
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]
parameters = { k = 2.0 }
[dynamics]
f = ["x2", "-k*sin(x1)"]
g = [["0"], ["1"]]
h = ["x1"]
"""


@pytest.mark.parametrize("path", sorted(MODELS.glob("*.toml")), ids=lambda p: p.stem)
def test_every_shipped_model_loads(path: Path) -> None:
    model = load_model(path)
    assert model.name == path.stem


def test_nonlinear_file_matches_the_same_model_built_in_python() -> None:
    m = parse_model(GOOD)
    assert isinstance(m, SymbolicModel) and m.is_input_affine
    c = m.compile()
    x = np.array([[0.3, -0.2], [1.0, 2.0]])
    w = np.array([[0.5], [-1.0]])
    expected = np.stack([x[:, 1], -2.0 * np.sin(x[:, 0]) + w[:, 0]], axis=-1)
    np.testing.assert_allclose(c.rhs(0.0, x, w), expected, rtol=1e-14)


def test_linear_discrete_file() -> None:
    m = load_model(MODELS / "double-integrator-discrete.toml")
    assert isinstance(m, LinearSystem) and m.is_discrete and m.time.dt == 0.1
    np.testing.assert_array_equal(m.D, np.zeros((1, 1)))
    np.testing.assert_array_equal(m.B, [[0.005], [0.1]])


def test_general_rhs_form() -> None:
    text = GOOD.replace('f = ["x2", "-k*sin(x1)"]\ng = [["0"], ["1"]]', 'rhs = ["x2", "-k*sin(x1) + u**3"]')
    m = parse_model(text)
    assert not m.is_input_affine
    out = m.compile().rhs(0.0, np.array([0.0, 1.0]), np.array([2.0]))
    np.testing.assert_allclose(out, [1.0, 8.0])


def _err(text: str) -> ModelFileError:
    with pytest.raises(ModelFileError) as info:
        parse_model(text, source="m.toml")
    return info.value


@pytest.mark.parametrize(
    ("old", "new", "line", "match", "offending"),
    [
        ('h = ["x1"]', 'h = ["__import__(\'os\').system(\'rm -rf /\')"]', 10, "whitelisted functions", "__import__('os').system"),
        ('h = ["x1"]', 'h = ["x1.real"]', 10, "Attribute is not allowed", "x1.real"),
        ('h = ["x1"]', 'h = ["(lambda: 0)()"]', 10, "whitelisted functions", "lambda: 0"),
        ('h = ["x1"]', 'h = ["zz + x1"]', 10, "undeclared name", "zz"),
        ('f = ["x2", "-k*sin(x1)"]', 'f = ["x2", "-k*sin(x1) + u"]', 8, "undeclared name", "u"),
        ('h = ["x1"]', 'h = ["x1", "x2"]', 10, "2 entries but there are 1 outputs", "h"),
        ('g = [["0"], ["1"]]', 'g = [["0"], ["1", "2"]]', 9, "each row needs 1 entries", ""),
        ('time = "continuous"', 'time = "hybrid"', 2, "'time' must be", "'hybrid'"),
        ('time = "continuous"', 'time = "discrete"', 2, "needs 'dt'", "dt"),
        ('parameters = { k = 2.0 }', 'parameters = { k = "two" }', 6, "must be a finite number", "'two'"),
        ('parameters = { k = 2.0 }', 'parameters = { k = nan }', 6, "must be a finite number", "nan"),
        ('outputs = ["y"]', 'outputs = ["y"]\ncolour = "red"', 6, "unknown key", "colour"),
        ('states = ["x1", "x2"]', 'states = ["x1", "x1"]', 3, "duplicate names", "x1"),
        ('inputs = ["u"]', 'inputs = ["x1"]', 3, "declared twice", "x1"),
        ('h = ["x1"]', 'h = "x1"', 10, "must be a list", "'x1'"),
        ('outputs = ["y"]', 'outputs = ["y"', 6, "invalid TOML", "parameters"),
    ],
)
def test_bad_files_name_file_line_and_text(old: str, new: str, line: int, match: str, offending: str) -> None:
    assert old in GOOD
    err = _err(GOOD.replace(old, new))
    assert err.path == "m.toml"
    assert err.line == line, str(err)
    assert offending in err.text, str(err)
    assert match in str(err)
    assert str(err).startswith(f"m.toml:{line}: ")


def test_linear_shape_and_value_errors() -> None:
    base = 'states = ["a", "b"]\noutputs = ["y"]\n[linear]\nA = [[0, 1], [0, 0]]\nC = [[1, 0]]\n'
    assert isinstance(parse_model(base), LinearSystem)
    e = _err(base.replace("C = [[1, 0]]", "C = [[1, 0, 0]]"))
    assert e.line == 5 and "shape (1, 3)" in str(e)
    e = _err(base.replace("A = [[0, 1], [0, 0]]", "A = [[0, 1], [0]]"))
    assert e.line == 4 and "rows have different lengths" in str(e)
    e = _err(base.replace("A = [[0, 1], [0, 0]]", "A = [[0, inf], [0, 0]]"))
    assert "non-finite" in str(e)
    e = _err(base.replace("A = [[0, 1], [0, 0]]", 'A = [[0, "1"], [0, 0]]'))
    assert "rows of numbers" in str(e)
    e = _err(base.replace("[linear]", 'inputs = ["u1", "u2"]\n[linear]') + "B = [[1], [0]]\n")
    assert e.line == 7 and "[linear].B has shape (2, 1), expected (2, 2)" in str(e)


def test_structure_errors() -> None:
    assert "exactly one of the tables" in str(_err('states = ["x"]\noutputs = ["y"]\n'))
    assert "needs 'h'" in str(_err(GOOD.replace('h = ["x1"]', "")))
    assert "exactly one of 'f'" in str(_err(GOOD.replace("[dynamics]", '[dynamics]\nrhs = ["1", "2"]')))
    assert "needs 'g'" in str(_err(GOOD.replace('g = [["0"], ["1"]]', "")))
    e = _err(GOOD.replace('states = ["x1", "x2"]\n', ""))
    assert "missing key 'states'" in str(e)


def test_unreadable_and_non_utf8_files(tmp_path: Path) -> None:
    with pytest.raises(ModelFileError, match="cannot read file"):
        load_model(tmp_path / "missing.toml")
    p = tmp_path / "latin1.toml"
    p.write_bytes(b'name = "caf\xe9"\n')
    with pytest.raises(ModelFileError, match="not UTF-8"):
        load_model(p)


def test_shipped_names_load_and_a_local_namesake_is_refused_as_ambiguous(tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    from nlobs.errors import ModelFileError
    from nlobs.systems.modelfile import load_model, resolve_model, shipped_models

    shipped = shipped_models()
    assert "pendulum" in shipped and resolve_model("pendulum") == shipped["pendulum"]
    assert load_model("pendulum").n == load_model(shipped["pendulum"]).n
    monkeypatch.chdir(tmp_path)
    (tmp_path / "pendulum").write_text(shipped["pendulum"].read_text())
    with pytest.raises(ModelFileError, match="ambiguous"):
        load_model("pendulum")
    assert load_model("./pendulum").n == 2
    with pytest.raises(ModelFileError, match="no such file .shipped models: .*pendulum"):
        load_model("no-such-model")
