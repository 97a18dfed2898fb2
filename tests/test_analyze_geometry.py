"""``nlobs analyze`` on nonlinear models: the symbolic (seeds 002/003) part of the report.

Expected values are derived by hand from the models (closed forms) or quoted from
Röbenack (Example (21): r = 2, Q⁺ = (25), l = (26), [τ1, τ2] ≡ 0).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from typer.testing import CliRunner

from nlobs.workflows.analyze import analyze
from nlobs.cli import app
from nlobs.geometry import Box
from nlobs.systems.expressions import parse_expression
from nlobs.systems.modelfile import load_model

runner = CliRunner()


def _json(*args: str) -> dict:
    res = runner.invoke(app, [*args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def _write(tmp_path: Path, name: str, body: str) -> str:
    p = tmp_path / f"{name}.toml"
    p.write_text(body, encoding="utf-8")
    return str(p)


def test_example_21_relative_degree_rank_involutivity_and_gain_26() -> None:
    d = _json("analyze", "isidori-146")
    assert d["observation_relative_degree"] == [2]  # L_g h = 0, L_g L_f h = 2 + 2 x3 (Röbenack, Sec. 5)
    assert d["observability_rank"] == 3  # x3 never reaches y: dL_f^k h never involves dx3
    assert d["involutive"] is True  # [τ1, τ2] ≡ 0 (Röbenack, Sec. 5)
    assert d["drift_observable"] is False  # rank 3 < 4: Q_s is singular everywhere
    names = {s: sp.Symbol(s, real=True) for s in ("x1", "x2", "x3", "x4", "k1", "k2")}
    got = [parse_expression(e, names) for e in d["pinv_gain"]]
    x1, k1, k2 = names["x1"], names["k1"], names["k2"]
    paper_26 = [2 * k2 * x1 / (4 * x1**2 + 1), k2 / (4 * x1**2 + 1), 0, k1]
    for g, p in zip(got, paper_26, strict=True):
        assert sp.simplify(g - p) == 0
    rng = np.random.default_rng(3)
    for _ in range(5):
        vals = dict(zip(names.values(), rng.normal(size=6)))
        assert [float(g.subs(vals)) for g in got] == pytest.approx([float(sp.sympify(p).subs(vals)) for p in paper_26])


def test_text_report_names_each_item() -> None:
    res = runner.invoke(app, ["analyze", "isidori-146"])
    assert res.exit_code == 0, res.output
    out = res.stdout
    assert "observation relative degree of y: 2" in out
    assert "generic rank 3 of n = 4" in out
    assert "A5 (involutive): holds" in out
    assert "l_x4 = k1" in out


MIMO = """
name = "mimo3"
time = "continuous"
states = ["x1", "x2", "x3"]
inputs = ["u"]
outputs = ["y1", "y2"]
[dynamics]
f = ["x2", "-x1", "-x3 + x1*x2"]
g = [["0"], ["1"], ["0"]]
h = ["x1", "x3"]
"""


def test_mimo_multi_index_and_relative_degrees(tmp_path: Path) -> None:
    # By hand: L_g x1 = 0, L_g L_f x1 = L_g x2 = 1 → r1 = 2; L_g x3 = 0, L_f x3 = −x3 + x1 x2,
    # L_g L_f x3 = x1 ≢ 0 → r2 = 2. Observability indices: dx1, dx3 (k = 0), dx2 (k = 1) → s = (2, 1),
    # Q_s = I so Φ_s is a global diffeomorphism. Σ r = 4 > n: no Röbenack gain.
    d = _json("analyze", _write(tmp_path, "mimo3", MIMO))
    assert d["observation_relative_degree"] == [2, 2]
    assert d["multi_index"] == [2, 1]
    assert d["observability_rank"] == 3
    assert d["drift_observable"] is True
    assert d["drift_observability"]["symbolic"] == "1"
    assert d["pinv_gain"] is None
    assert any("Σ r_j = 4 > n" in t for t in d["notes"])


def test_witness_point_is_inside_the_region_and_nonzero(tmp_path: Path) -> None:
    m = load_model(_write(tmp_path, "mimo3", MIMO))
    rep = analyze(m, region=Box(np.array([2.0, -1, -1]), np.array([3.0, 1, 1])))
    geo = rep.geometry
    assert geo is not None
    witness = [t for t in geo.relative_degree_evidence]
    assert "≢ 0 (exact)" in witness[1]  # x1 is a polynomial: decided exactly
    # The witness of L_g L_f x3 = x1 on x1 ∈ [2, 3] is a value between 2 and 3.
    ev = witness[1].split("e.g. ")[1]
    val = float(ev.split(" at ")[0])
    assert 2.0 <= val <= 3.0


def test_autonomous_model_has_undefined_relative_degree(tmp_path: Path) -> None:
    body = """
name = "vdp"
time = "continuous"
states = ["x1", "x2"]
inputs = []
outputs = ["y"]
[dynamics]
f = ["x2", "-x1 + (1 - x1**2)*x2"]
h = ["x1"]
"""
    d = _json("analyze", _write(tmp_path, "vdp", body))
    assert d["observation_relative_degree"] == [None]
    assert d["pinv_gain"] is None and d["involutive"] is None
    assert d["observability_rank"] == 2 and d["drift_observable"] is True


def test_discrete_and_general_models_say_why_there_is_no_geometry(tmp_path: Path) -> None:
    general = """
name = "gen"
time = "continuous"
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]
[dynamics]
rhs = ["x2", "-x1 + u**3"]
h = ["x1"]
"""
    d = _json("analyze", _write(tmp_path, "gen", general))
    assert d["observation_relative_degree"] is None
    assert "input-affine" in d["geometry_error"]
    discrete = general.replace('time = "continuous"', 'time = "discrete"\ndt = 0.1').replace(
        'rhs = ["x2", "-x1 + u**3"]', 'f = ["x2", "-x1"]\ng = [["0"], ["1"]]')
    d = _json("analyze", _write(tmp_path, "disc", discrete))
    assert "continuous-time" in d["geometry_error"]


@pytest.mark.parametrize(("box", "msg"), [("0,1,2", "expected 'lo,hi' or 4 numbers"), ("1,0", "must exceed"),
                                           ("0,nan", "finite")])
def test_bad_box_is_a_one_line_error(box: str, msg: str) -> None:
    res = runner.invoke(app, ["analyze", "pendulum", "--box", box])
    assert res.exit_code == 2
    assert msg in res.output


def test_box_on_a_linear_model_is_refused() -> None:
    res = runner.invoke(app, ["analyze", "grip-example1-filter", "--box", "-1,1"])
    assert res.exit_code == 2
    assert "only used for nonlinear models" in res.output
