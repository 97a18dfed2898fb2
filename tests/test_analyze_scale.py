"""``nlobs analyze`` at scale: polynomial and Duffing chains, the symbolic budget and its numeric stand-in."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.geometry.budget import TERM_OPERATIONS_PER_SECOND, OutOfBudget, SymbolicBudget
from nlobs.geometry.exact_inverse import exact_inverse
from nlobs.geometry.observability import AffineFields, reduced_observability_matrix
from nlobs.geometry.pinv import gain_within
from nlobs.geometry.report import geometry_report
from nlobs.workflows.analyze import analyze_model

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from analyze_scale import duffing_chain, poly_chain  # noqa: E402


def test_three_state_chain_is_exactly_as_before() -> None:
    # the report of the code before the budget (the symbolic gain of (17), A1, A5, the rank)
    d = analyze_model(poly_chain(3)).to_dict()
    assert d["pinv_gain"] == [
        "k1", "(3*k1*x1**2 + 5*k1 + 5*k2)/5",
        "-(6*k1*x1**4 + 15*k1*x1**3 - 9*k1*x1**2*x2**2 + 15*k1*x1**2 - 30*k1*x1*x2 + 25*k1*x1 - 15*k1*x2**2 "
        "+ 25*k1*x2 - 25*k1 - 15*k2*x1**2 + 25*k2*x1 - 15*k2*x2**2 - 50*k2 - 25*k3)/25"]
    assert d["a1"]["passed"] and d["involutive"] and d["drift_observable"]
    assert d["observability_rank"] == 3 and d["multi_index"] == [3]
    assert d["numeric_parts"] == [] and d["pinv_gain_numeric"] is None


def _independent_Q(model) -> tuple[list[sp.Symbol], object]:
    """Q = ∂(h, L_f h, …, L_f^{n−1} h)/∂x built here with plain SymPy (expand), lambdified."""
    x = list(model.x)
    f = model.drift
    phi = model.h[0]
    rows = []
    for _ in range(model.n):
        rows.append([sp.diff(phi, xi) for xi in x])
        phi = sp.expand(sum(sp.diff(phi, xi) * f[i] for i, xi in enumerate(x)))
    return x, sp.lambdify(x, sp.Matrix(rows), "numpy")


@pytest.mark.slow
def test_seven_state_chain_gain_is_numeric_and_agrees_with_numpy_pinv() -> None:
    m = poly_chain(7)
    g = geometry_report(m, symbolic_budget=0.0)
    assert g.pinv_gain is None and "pinv_gain" in g.numeric_parts
    assert any("not computed symbolically" in t for t in g.notes)
    assert g.a1 is not None and g.a1.passed and g.a5 is not None and g.a5.passed  # square Q: A5 is structural
    _, Qf = _independent_Q(m)
    for pt, P in zip(g.numeric_gain.points, g.numeric_gain.pinv):
        expected = np.linalg.pinv(np.asarray(Qf(*pt), dtype=float))
        np.testing.assert_allclose(np.asarray(P), expected, rtol=1e-9, atol=1e-9)
    d = g.to_dict()
    assert d["numeric_parts"] == ["pinv_gain"] and d["pinv_gain_numeric"]["method"] == "numpy.linalg.pinv"
    assert d["symbolic_budget"] == 0.0


def test_nine_state_chain_returns_with_a_small_budget() -> None:
    d = analyze_model(poly_chain(9), symbolic_budget=0.5).to_dict()
    assert d["observation_relative_degree"] == [9] and d["observability_rank"] == 9
    assert d["geometry_error"] is None


def test_duffing_chain_is_analysed() -> None:
    d = analyze_model(duffing_chain(3)).to_dict()
    assert d["observation_relative_degree"] == [6] and d["observability_rank"] == 6


def test_unlimited_budget_keeps_the_exact_gain() -> None:
    g = geometry_report(poly_chain(4), symbolic_budget=None)
    assert g.pinv_gain is not None and g.numeric_parts == ()


def test_exact_inverse_equals_sympys_and_refuses_what_it_cannot_invert() -> None:
    x, y, z = sp.symbols("x y z")
    cases = [sp.Matrix([[x, 1 / (1 + y)], [x * y, y**2 + 1]]),
             sp.Matrix([[0, 1, x], [y, 0, 1], [1, z**2, 0]]),  # a zero first pivot: rows are swapped
             sp.Matrix([[x + y, x - y, 1], [x * y, 1, z], [1 / (x + 2), y, z**3 - x]])]
    for Q in cases:
        inv = exact_inverse(Q, SymbolicBudget(None))
        assert sp.simplify(inv.as_matrix() - Q.inv()) == sp.zeros(*Q.shape)
    assert exact_inverse(sp.Matrix([[x, y], [2 * x, 2 * y]]), SymbolicBudget(None)) is None  # singular
    assert exact_inverse(sp.Matrix([[sp.sin(x), 0], [0, 1]]), SymbolicBudget(None)) is None  # not rational
    assert exact_inverse(sp.Matrix([[0.1 * x, 0], [0, 1]]), SymbolicBudget(None)) is None  # a float coefficient
    with pytest.raises(OutOfBudget, match="symbolic budget"):
        exact_inverse(cases[2], SymbolicBudget(0.0))


def test_the_count_not_the_clock_decides() -> None:
    """The work of the gain field is a count: a budget one operation short stops it, the exact count completes it."""
    m = poly_chain(4)
    Q = reduced_observability_matrix(AffineFields.from_model(m), [4])
    first, second = SymbolicBudget(None), SymbolicBudget(None)
    gain, _ = gain_within(Q, [4], 1, first)
    assert gain_within(Q, [4], 1, second)[0] == gain and first.used == second.used > 0
    exact = SymbolicBudget(first.used / TERM_OPERATIONS_PER_SECOND)
    assert exact.limit == first.used and gain_within(Q, [4], 1, exact)[0] == gain
    short = SymbolicBudget((first.used - 1) / TERM_OPERATIONS_PER_SECOND)
    with pytest.raises(OutOfBudget, match="cancelling and factoring"):
        gain_within(Q, [4], 1, short)
    assert short.used < first.used  # it stopped before the step that did not fit, having charged the ones before


def test_default_budget_draws_the_line_between_six_and_seven_states() -> None:
    """5 s of budget keeps the exact field of the 6-state chain (4.4 s of CPU measured) and refuses the 7-state one
    (29 s measured) before its expensive step, whatever the machine's load."""
    m = poly_chain(7)
    Q = reduced_observability_matrix(AffineFields.from_model(m), [7])
    budget = SymbolicBudget()
    with pytest.raises(OutOfBudget, match="cancelling and factoring"):
        gain_within(Q, [7], 1, budget)
    assert budget.used < budget.limit


CHAIN_FILE = """name = "poly-chain-5"
time = "continuous"
states = ["x1", "x2", "x3", "x4", "x5"]
inputs = ["u"]
outputs = ["y"]

[dynamics]
f = ["x2 - x1 - x1**3/5", "x3 - x2 - x2**3/5 + x1*x2", "x4 - x3 - x3**3/5 + x2*x3", "x5 - x4 - x4**3/5 + x3*x4",
     "-x5 - x5**3/5 + x4*x5"]
g = [["0"], ["0"], ["0"], ["0"], ["1"]]
h = ["x1"]
"""


def test_cli_names_the_numeric_part(tmp_path: Path) -> None:
    p = tmp_path / "chain.toml"
    p.write_text(CHAIN_FILE, encoding="utf-8")
    res = CliRunner().invoke(app, ["analyze", str(p), "--symbolic-budget", "0"])
    assert res.exit_code == 0, res.output
    assert "evaluated numerically (numpy.linalg.pinv)" in res.stdout
    assert "not computed symbolically" in res.stdout


def test_polynomial_zero_test_agrees_with_the_expression_one() -> None:
    """The ring-element zero test decides as :func:`vanishes_on` does, with the same witness and value."""
    import sympy as sp

    from nlobs.geometry.region import Box, polynomial_vanishes_on, vanishes_on

    x1, x2, x3 = sp.symbols("x1 x2 x3")
    R, *gens = sp.ring("x1 x2 x3", sp.QQ)
    box = Box([-1.0, -2.0, 0.5], [1.0, 3.0, 2.0])
    for expr in (x1 * x2 - x3**2 / 3 + 7, (x1 + x2) ** 3 - x1**3 - 3 * x1**2 * x2 - 3 * x1 * x2**2 - x2**3,
                 sp.Integer(0), x3**5 - 2 * x1 * x2 * x3):
        p = R.from_expr(sp.expand(expr))
        a, b = polynomial_vanishes_on(p, 3, box), vanishes_on(expr, (x1, x2, x3), box)
        assert a.zero == b.zero == (sp.expand(expr) == 0)
        if not a.zero:
            assert a.witness == pytest.approx(b.witness) and a.value == pytest.approx(b.value, rel=1e-12)
            # the witness is where |p| is largest among the sampled points: evaluate it independently
            f = sp.lambdify((x1, x2, x3), expr)
            assert abs(a.value) == pytest.approx(abs(f(*a.witness)), rel=1e-12)
