"""Model files with unknown inputs (Khajenejad & Yong, (8)): shipped examples load to the systems the examples build;
every bad input names the file, the line and the text."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nlobs.errors import ModelFileError
from nlobs.papers.khajenejad_yong import example_61, example_62
from nlobs.systems.discrete_ui import LPV, DiscreteUISystem, Lipschitz, QCStar, QuadraticConstraint
from nlobs.systems.modelfile import load_discrete_ui, load_discrete_ui_model, load_model, parse_discrete_ui
from nlobs.systems.symbolic import SymbolicModel

MODELS = Path(__file__).resolve().parents[1] / "src" / "nlobs" / "data" / "models"
FIELDS = ("A", "G", "C", "H", "B", "D", "W", "x0")


@pytest.mark.parametrize(("stem", "example"), [("khajenejad-6-1", lambda: example_61("II")),
                                               ("khajenejad-6-2", example_62)])
def test_shipped_files_load_to_the_printed_examples(stem: str, example) -> None:  # type: ignore[no-untyped-def]
    got = load_discrete_ui(MODELS / f"{stem}.toml")
    ex = example()
    want = ex.system
    assert isinstance(got, DiscreteUISystem) and got.name == stem
    for k in FIELDS:
        np.testing.assert_allclose(getattr(got, k), getattr(want, k), rtol=0, atol=1e-15, err_msg=k)
    assert (got.eta_w, got.eta_v, got.delta0, got.time.dt) == (want.eta_w, want.eta_v, want.delta0, want.time.dt)
    assert type(got.function_class) is type(want.function_class)
    np.testing.assert_allclose(got.function_class.multiplier()[0], want.function_class.multiplier()[0], atol=1e-15)
    assert got.function_class.gamma == pytest.approx(want.function_class.gamma, rel=1e-14)
    x = np.random.default_rng(0).uniform(-5, 5, (200, got.n))
    np.testing.assert_allclose(got.f(x), want.f(x), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(got.nonlinear(x), want.nonlinear(x), rtol=1e-13, atol=1e-13)
    # the nominal model of the same file (d = w = v = 0) for the other commands
    nominal = load_model(MODELS / f"{stem}.toml")
    assert isinstance(nominal, SymbolicModel) and nominal.name == stem


def test_signals_of_the_file() -> None:
    m = load_discrete_ui_model(MODELS / "khajenejad-6-1.toml")
    t = np.arange(301) * 0.01
    d = m.signals["bounded"](t)
    ref = example_61("II").unknown_input(t)
    off = np.flatnonzero(np.abs(d - ref)[:, 0] > 1e-12)
    assert off.tolist() == [100]  # sign(t - 1) = 0 at t = 1 exactly, the example's indicator is 1 there
    np.testing.assert_allclose(m.signals["growing"](t)[:, 0], 50 * t**2 + 20 * np.exp(t), rtol=1e-14)
    lo, hi = m.box
    np.testing.assert_array_equal(lo, -1000 * np.ones(4))  # the box of the file (the class holds on all of R^4)
    np.testing.assert_array_equal(hi, 1000 * np.ones(4))


GOOD = """\
time = "discrete"
dt = 1.0
states = ["x1", "x2"]
outputs = ["y"]
parameters = { c = 0.5 }
[dynamics]
f = ["-0.42*x1 + x2", "-0.6*x1 - 1.25*tanh(x1)"]
h = ["x2"]
[unknown_inputs]
G = [[1.0], [-0.65]]
[noise]
eta_w = 0.2
eta_v = "c/5"
[initial]
radius = 0.5
[function_class]
kind = "I"
linear_part = [[-0.42, 1.0], [-0.6, 0.0]]
L = 1.25
"""


def test_defaults_and_constant_expressions() -> None:
    m = parse_discrete_ui(GOOD)
    s = m.system
    assert s.eta_v == pytest.approx(0.1) and m.box is None
    np.testing.assert_array_equal(s.W, np.eye(2))
    np.testing.assert_array_equal(s.H, np.zeros((1, 1)))
    np.testing.assert_array_equal(s.x0, np.zeros(2))
    np.testing.assert_allclose(m.signals["bounded"](np.array([0.5]))[0], [np.sin(0.5)])
    np.testing.assert_allclose(m.signals["growing"](np.array([3.0]))[0], [9.0])


@pytest.mark.parametrize(
    ("old", "new", "cls"),
    [
        ('kind = "I"\nlinear_part = [[-0.42, 1.0], [-0.6, 0.0]]\nL = 1.25',
         'kind = "II"\nlinear_part = [[-0.42, 1.0], [-0.6, 0.0]]\nA_aux = [[0, 0], [0, 0]]\nbound = 1.25', QCStar),
        ('L = 1.25', 'L = 1.25', Lipschitz),
        ('kind = "I"\nlinear_part = [[-0.42, 1.0], [-0.6, 0.0]]\nL = 1.25',
         'kind = "0"\nlinear_part = [[-0.42, 1.0], [-0.6, 0.0]]\nM = [[-1,0,0,0],[0,-1,0,0],[0,0,1.5625,0],[0,0,0,0]]\n'
         'gamma = 0', QuadraticConstraint),
        ('kind = "I"\nlinear_part = [[-0.42, 1.0], [-0.6, 0.0]]\nL = 1.25',
         'kind = "III"\nlinear_part = [[-0.42, 1.0], [-0.6, 0.0]]\nconstituents = [[[0, 0], [-1.25, 0]], [[0, 0], [0, 0]]]',
         LPV),
    ],
)
def test_every_class(old: str, new: str, cls: type) -> None:
    s = parse_discrete_ui(GOOD.replace(old, new)).system
    assert isinstance(s.function_class, cls)
    if cls is QCStar:
        assert s.function_class.gamma == pytest.approx(-(2 * 1.25) ** 2)


def test_linear_model_with_unknown_inputs() -> None:
    text = GOOD.replace('parameters = { c = 0.5 }\n', "").replace(
        '[dynamics]\nf = ["-0.42*x1 + x2", "-0.6*x1 - 1.25*tanh(x1)"]\nh = ["x2"]',
        "[linear]\nA = [[-0.42, 1.0], [-0.6, 0.0]]\nC = [[0, 1]]").replace('"c/5"', "0.1")
    s = parse_discrete_ui(text).system
    assert s.phi is None
    np.testing.assert_array_equal(s.C, [[0.0, 1.0]])
    s2 = parse_discrete_ui(text.replace("linear_part = [[-0.42, 1.0], [-0.6, 0.0]]",
                                        "linear_part = [[-0.42, 1.0], [0.0, 0.0]]")).system
    np.testing.assert_allclose(s2.f(np.array([[1.0, 2.0]])), [[1.58, -0.6]])


def _err(text: str) -> ModelFileError:
    with pytest.raises(ModelFileError) as info:
        parse_discrete_ui(text, source="m.toml")
    return info.value


@pytest.mark.parametrize(
    ("old", "new", "line", "match", "offending"),
    [
        ("eta_w = 0.2", "eta_w = -0.2", 12, "[noise].eta_w must be >= 0", "-0.2"),
        ("eta_w = 0.2", "eta_w = nan", 12, "non-finite", "nan"),
        ("eta_w = 0.2", "eta_w = inf", 12, "non-finite", "inf"),
        ("eta_w = 0.2\n", "", 11, "[noise] needs 'eta_w'", "eta_w"),
        ("radius = 0.5", "radius = -1", 15, "[initial].radius must be >= 0", "-1"),
        ('eta_v = "c/5"', 'eta_v = "c/z"', 13, "undeclared name", "z"),
        ('eta_v = "c/5"', 'eta_v = "x1"', 13, "undeclared name", "x1"),
        ("G = [[1.0], [-0.65]]", "G = [[1.0], [-0.65], [2.0]]", 10, "[unknown_inputs].G has shape (3, 1)", "G"),
        ("G = [[1.0], [-0.65]]", "G = [[1.0], [-0.65, 1]]", 10, "rows have different lengths", "G"),
        ("G = [[1.0], [-0.65]]", 'G = [[1.0], ["__import__(\'os\')"]]', 10, "not in the whitelist", "__import__"),
        ('h = ["x2"]', 'h = ["x2**2"]', 8, "must be linear in the states", "x2**2"),
        ('h = ["x2"]', 'h = ["x2 + 1"]', 8, "must be linear in the states", "x2 + 1"),
        ('kind = "I"', 'kind = "IV"', 17, "kind must be", "'IV'"),
        ("L = 1.25", "L = -1.25", 19, "L: must be non-negative", "L = -1.25"),
        ("L = 1.25", "L = 1.25\nbound = 1", 20, "'bound' does not belong to class I", "bound"),
        ("L = 1.25", "", 16, "class I needs 'L'", "L"),
        ("linear_part = [[-0.42, 1.0], [-0.6, 0.0]]\n", "", 16, "needs 'linear_part'", "linear_part"),
        ("radius = 0.5", "radius = 0.5\ncolour = 1", 16, "unknown key in [initial]", "colour"),
        ("[initial]\nradius = 0.5\n", "", None, "needs the table [initial]", "initial"),
        ('time = "discrete"\ndt = 1.0', 'time = "continuous"', 8, "needs time = \"discrete\"", "unknown_inputs"),
        ("L = 1.25", "L = 1.25\nbox = [[1, 0], [0, 1]]", 20, "lo <= hi", "box"),
    ],
)
def test_bad_files_name_file_line_and_text(old: str, new: str, line: int | None, match: str, offending: str) -> None:
    assert old in GOOD
    err = _err(GOOD.replace(old, new))
    assert err.path == "m.toml"
    assert err.line == line, str(err)
    assert offending in err.text, str(err)
    assert match in str(err), str(err)


def test_class_ii_needs_gamma_or_bound_and_rejects_positive_gamma() -> None:
    base = GOOD.replace('kind = "I"', 'kind = "II"').replace("L = 1.25", "A_aux = [[0, 0], [0, 0]]")
    assert "exactly one of 'gamma' or 'bound'" in str(_err(base))
    assert "exactly one of 'gamma' or 'bound'" in str(_err(base + "gamma = -1\nbound = 1\n"))
    with pytest.raises(ModelFileError, match="gamma <= 0"):
        parse_discrete_ui(base + "gamma = 0.5\n")


def test_missing_file() -> None:
    with pytest.raises(ModelFileError, match="cannot read file"):
        load_discrete_ui("/nonexistent/x.toml")
