"""The generic observability rank of nonlinear models when the numbers span many decades.

Every expected rank is computed independently of nlobs: the Lie derivatives ``L_f^k h_j`` are
built here with plain SymPy from the equations written in the test, their Jacobian is evaluated at
a random rational point, and its rank is taken in exact rational arithmetic (fraction-field
Gaussian elimination, ``sympy.Matrix.rank``). The rank at a random rational point equals the
generic rank unless the point lies on a proper algebraic subset (probability zero).

Models:

* a four-state HIV model with a cytotoxic-lymphocyte state (the Wodarz–Nowak form of the HIV
  example of the STRIKE-GOLDD collection of Villaverde, Barreiro & Papachristodoulou), uninfected
  cells ``T`` and CTL ``Z`` measured, on a box of physical scale (``T ≈ 10³``, ``V ≈ 10⁴…10⁵``);
  its unscaled observability Jacobian has ``σ_min/σ_max ≈ 10⁻¹²``;
* the same model with a fifth, unmeasured state that nothing sees (true rank 4 of 5);
* a six-state leaky chain with rates 20 and a quadratic term;
* couplings far below and inside the rounding level (a second precision decides, or nobody).
"""

from __future__ import annotations

import json
import random
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.geometry import AffineFields, Box
from nlobs.geometry.checks import observability_rank, observability_rank_evidence
from nlobs.workflows.analyze import analyze_model

runner = CliRunner()

T, I, V, Z, W = sp.symbols("T I V Z W")
lm, d, beta, a, k, u, c, q, b, e, w = sp.symbols("lm d beta a k u c q b e w")
HIV_PARAMETERS = {lm: "20", d: "0.04", beta: "2e-5", a: "0.3", k: "100", u: "1", c: "0.1", q: "3", b: "0.4", e: "0.5"}
HIV_F = [lm - d * T - beta * T * V, beta * T * V - a * I, k * I - u * V, c * T * I * Z - c * q * I * Z - b * Z]
HIV_BOX = [500, 1500, 10, 100, 1e4, 1e5, 10, 100]


def _toml(name: str, x: list[sp.Symbol], f: list[sp.Expr], h: list[sp.Expr], params: dict[sp.Symbol, str]) -> str:
    g = [["1"] if i == 0 else ["0"] for i in range(len(x))]
    return "\n".join([
        f'name = "{name}"', 'time = "continuous"', f"states = {json.dumps([str(s) for s in x])}",
        'inputs = ["u_in"]', f"outputs = {json.dumps([f'y{j + 1}' for j in range(len(h))])}",
        "parameters = { " + ", ".join(f"{p} = {float(v)!r}" for p, v in params.items()) + " }", "",
        "[dynamics]", f"f = {json.dumps([str(fi) for fi in f])}", f"g = {json.dumps(g)}",
        f"h = {json.dumps([str(hj) for hj in h])}", ""])


def _jacobian(x: list[sp.Symbol], f: list[sp.Expr], h: list[sp.Expr], params: dict[sp.Symbol, str]) -> sp.Matrix:
    """Rows d(L_f^k h_j), k < n, built here with plain SymPy (parameters as exact rationals)."""
    sub = {p: sp.Rational(v) for p, v in params.items()}
    fx = [fi.xreplace(sub) for fi in f]
    rows = []
    for hj in h:
        L = hj
        for _ in range(len(x)):
            rows.append([sp.diff(L, xi) for xi in x])
            L = sp.expand(sum(sp.diff(L, xi) * fi for xi, fi in zip(x, fx)))
    return sp.Matrix(rows)


def _exact_generic_rank(x: list[sp.Symbol], f: list[sp.Expr], h: list[sp.Expr], params: dict[sp.Symbol, str],
                        box: list[float], seed: int = 7) -> int:
    """Exact rank of the Jacobian at a random rational point of the box (fraction-field elimination)."""
    rng = random.Random(seed)
    pt = {xi: sp.Rational(lo) + (sp.Rational(hi) - sp.Rational(lo)) * sp.Rational(rng.randint(1, 999), 1000)
          for xi, lo, hi in zip(x, box[0::2], box[1::2])}
    return _jacobian(x, f, h, params).xreplace(pt).rank()


def _write(tmp_path: Path, name: str, body: str) -> str:
    p = tmp_path / f"{name}.toml"
    p.write_text(body, encoding="utf-8")
    return str(p)


def test_hiv_model_on_a_physical_box_has_rank_4_as_the_exact_rank_says(tmp_path: Path) -> None:
    x = [T, I, V, Z]
    exact = _exact_generic_rank(x, HIV_F, [T, Z], HIV_PARAMETERS, HIV_BOX)
    assert exact == 4
    path = _write(tmp_path, "hiv", _toml("hiv", x, HIV_F, [T, Z], HIV_PARAMETERS))
    d = analyze_model(path, box=HIV_BOX).to_dict()
    assert d["observability_rank"] == exact  # the fixed relative tolerance said 2
    assert d["drift_observable"] is True and sum(d["multi_index"]) == 4
    ev = d["observability_rank_evidence"]
    assert ev["rank"] == 4 and ev["state_scales"] == [1500.0, 100.0, 1e5, 100.0]
    sv = ev["singular_values"]
    assert len(sv) == 4 and sv[-1] > ev["gap_factor"] * ev["tolerance"] and ev["tolerance"] < 1e-12
    # the unscaled Jacobian at the same point spans more than ten decades: no fixed relative tolerance fits
    J = np.array(_jacobian(x, HIV_F, [T, Z], HIV_PARAMETERS).xreplace(dict(zip(x, ev["point"]))), dtype=float)
    raw = np.linalg.svd(J, compute_uv=False)
    assert raw[-1] / raw[0] < 1e-10


@pytest.mark.slow
def test_hiv_model_with_an_unseen_state_is_rank_deficient_4_of_5(tmp_path: Path) -> None:
    x = [T, I, V, Z, W]
    f = HIV_F + [I - e * W]  # W is driven by I but feeds back nowhere: no output sees it
    box = HIV_BOX + [1, 1000]
    exact = _exact_generic_rank(x, f, [T, Z], HIV_PARAMETERS, box)
    assert exact == 4
    path = _write(tmp_path, "hiv5", _toml("hiv5", x, f, [T, Z], HIV_PARAMETERS))
    d = analyze_model(path, box=box).to_dict()
    assert d["observability_rank"] == exact  # the fixed relative tolerance said 2
    assert d["drift_observable"] is None  # Σ s_j = 4 < 5: no Φ_s to test, consistently with rank 4 < 5
    assert sum(d["multi_index"]) == 4
    ev = d["observability_rank_evidence"]
    sv = ev["singular_values"]
    assert sv[3] > ev["gap_factor"] * ev["tolerance"] and sv[4] <= ev["tolerance"]
    assert ev["high_precision_singular_values"][4] <= ev["high_precision_tolerance"] < 1e-40


X6 = list(sp.symbols("x1:7"))
CHAIN_F = [w * (X6[i + 1] - X6[i]) for i in range(5)] + [-w * X6[5] + X6[0] ** 2]


def test_chain_with_rates_20_has_rank_6_consistently_with_drift_observability(tmp_path: Path) -> None:
    exact = _exact_generic_rank(X6, CHAIN_F, [X6[0]], {w: "20"}, [-1, 1] * 6)
    assert exact == 6
    path = _write(tmp_path, "chain", _toml("chain", X6, CHAIN_F, [X6[0]], {w: "20"}))
    res = runner.invoke(app, ["analyze", path, "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert d["observability_rank"] == exact  # the fixed relative tolerance said 4
    assert d["drift_observable"] is True
    ev = d["observability_rank_evidence"]
    assert ev["rank"] == 6 and ev["method"] == "double precision"
    assert min(ev["singular_values"]) > ev["gap_factor"] * ev["tolerance"]


def _two_state(eps: str) -> AffineFields:
    x1, x2 = sp.symbols("x1 x2")
    return AffineFields("tiny", (x1, x2), sp.ImmutableMatrix([x1**2 / 2 + sp.Rational(eps) * x2, -x2]),
                        sp.ImmutableMatrix([0, 1]), sp.ImmutableMatrix([x1]), ("x1", "x2"), ("y",))


@pytest.mark.parametrize("eps", ["1e-17", "1e-30"])
def test_a_coupling_below_double_precision_is_resolved_at_high_precision(eps: str) -> None:
    # J = [[1, 0], [x1, ε]]: rank 2 exactly for every ε ≠ 0 (det = ε)
    assert sp.Matrix([[1, 0], [sp.Rational(1, 3), sp.Rational(eps)]]).rank() == 2
    ev = observability_rank_evidence(_two_state(eps))
    assert ev.rank == 2  # double precision alone calls σ_2 ≈ ε zero: the fixed tolerance said 1
    assert ev.high_precision_singular_values is not None
    # scaled rows [1, 0] and t·[x1, ε] (t = 1/largest row norm): σ_1 σ_2 = |det| = t ε and
    # σ_1² + σ_2² = ‖·‖_F² = 1 + t² (x1² + ε²); eliminating t ties the two reported values together
    s1, s2 = ev.high_precision_singular_values
    t = s1 * s2 / float(eps)
    assert s1**2 + s2**2 == pytest.approx(1 + t**2 * ev.point[0] ** 2, rel=1e-12)
    assert 0.9 < 1 / t < 1.0 + 1e-12  # the largest |x1| over the sampled points of [−1, 1]²


def test_a_coupling_at_the_high_precision_rounding_level_is_undecided() -> None:
    ev = observability_rank_evidence(_two_state("1e-45"))
    assert ev.rank is None and observability_rank(_two_state("1e-45")) is None  # the fixed tolerance said 1
    assert (ev.lower, ev.upper) == (1, 2)
    assert ev.high_precision_tolerance < ev.high_precision_singular_values[1] <= 10 * ev.high_precision_tolerance


def test_no_finite_point_is_undecided_not_rank_0() -> None:
    x1, x2 = sp.symbols("x1 x2")
    F = AffineFields("sqrt", (x1, x2), sp.ImmutableMatrix([x2, -x1]), sp.ImmutableMatrix([0, 1]),
                     sp.ImmutableMatrix([sp.sqrt(x1 - 5)]), ("x1", "x2"), ("y",))
    # d√(x1 − 5) is not real anywhere on [−1, 1]²; where it is defined (x1 = 6) the rank is 2
    assert _jacobian([x1, x2], [x2, -x1], [sp.sqrt(x1 - 5)], {}).xreplace({x1: 6, x2: 1}).rank() == 2
    ev = observability_rank_evidence(F, Box.unit(2))
    assert ev.rank is None and ev.points == 0 and ev.tolerance is None  # the fixed tolerance said 0


def test_slow_chain_is_drift_observable_with_rank_6(tmp_path: Path) -> None:
    # rates 1/1000: the rows d(L_f^k h) shrink like 10^(−3k); the unscaled σ_min(Q_s) is ≈ 10⁻¹⁵
    exact = _exact_generic_rank(X6, CHAIN_F, [X6[0]], {w: "0.001"}, [-1, 1] * 6)
    assert exact == 6
    path = _write(tmp_path, "slow", _toml("slow", X6, CHAIN_F, [X6[0]], {w: "0.001"}))
    d = analyze_model(path).to_dict()
    assert d["observability_rank"] == exact  # the fixed relative tolerance said 3
    assert d["drift_observable"] is True  # it said "Q_s loses rank" (σ_min ≤ 10⁻⁷ · max(1, ·))
    assert d["drift_observability"]["value"] < 1e-14  # the unscaled σ_min it reports is unchanged


def test_a_drift_observable_report_never_states_a_smaller_rank(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import nlobs.geometry.report as report
    from nlobs.geometry.checks import RankEvidence

    path = _write(tmp_path, "chain", _toml("chain", X6, CHAIN_F, [X6[0]], {w: "20"}))
    wrong = RankEvidence(4, 4, 4, (1.0,) * 4 + (0.0, 0.0), 1e-15, 1e15, (0.0,) * 6, 32, (1.0,) * 6)
    monkeypatch.setattr(report, "observability_rank_evidence", lambda *a, **k: wrong)
    d = analyze_model(path).to_dict()
    # Q_s is six of the codistribution's rows: nonsingular at a point means rank 6 (= n) there
    assert d["drift_observable"] is True and d["observability_rank"] == 6
    assert d["observability_rank_evidence"]["rank"] == 4 and any("rank 4" in t for t in d["notes"])
