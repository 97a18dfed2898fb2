"""Röbenack (2008), Section 5: Example (21) reproduced (robenack2008), simulations of both observers, reproduce rows."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from nlobs.papers import robenack2008 as R
from nlobs.papers.reproduce import ReproRow
from nlobs.workflows.design_pinv import simulate_pinv


@pytest.fixture(scope="module")
def findings() -> R.SymbolicFindings:
    return R.symbolic_findings()


def test_section5_symbolic_statements(findings: R.SymbolicFindings) -> None:
    x1, x3 = sp.symbols("x1 x3", real=True)
    assert findings.lg_h == 0
    assert sp.simplify(findings.lg_lf_h - 2 * (1 + x3)) == 0
    assert sp.simplify(findings.lg_lf2_h - 4 * x1**2 * (x3 + 1)) == 0  # derived by hand
    assert findings.r == 2 and findings.observability_rank == 3
    assert findings.Qp_equals_25 and findings.Qp_spot < 1e-12
    assert findings.gain_equals_26 and findings.gain_spot < 1e-12
    assert findings.bracket_zero and findings.involutive
    assert findings.pinv_pole_free


def test_byrnes_isidori_24_and_its_pole(findings: R.SymbolicFindings) -> None:
    assert findings.bi_jacobian_equals_23  # φ4 = x1 reproduces (23)
    assert findings.text_phi4_det == 0  # the text's φ4 = x4 cannot be used
    assert not findings.bi_equals_24_printed  # (24) as printed is not (Φ')⁻¹ [k; 0]
    assert findings.bi_equals_24_derived and findings.bi_spot_derived < 1e-12
    assert findings.bi_pole == ("x3 = -1",)
    assert findings.bi_map_folds  # Φ(x3) = Φ(−2 − x3): A2 fails for (23)


def test_theorem_41_coordinates_give_26(findings: R.SymbolicFindings) -> None:
    assert findings.orthogonal_rq == sp.zeros(2, 2)  # (16)
    assert findings.orthogonal_gain_equals_26


@pytest.fixture(scope="module")
def crossing() -> R.ScenarioResult:
    sc = next(s for s in R.SCENARIOS if s.slug == "estimate_crosses")
    return R.simulate_scenarios([sc], duration=6.0)[0]


def test_pinv_estimate_of_x3_follows_its_own_dynamics(crossing: R.ScenarioResult) -> None:
    res = crossing.pinv.result
    assert res is not None
    e3 = res.x_hat[:, 2] - res.x[:, 2]
    np.testing.assert_allclose(e3, e3[0] * np.exp(-res.t), atol=1e-9)  # l3 ≡ 0: ė3 = −e3 (A4)
    k = np.array([12.0, 27.0])
    assert crossing.pinv.max_gain <= np.linalg.norm(k) + 1e-9  # ‖Q⁺k‖² = k1² + k2²/(4x1² + 1)
    assert crossing.pinv.crossings  # x̂3 passes −1 without effect on the gain


def test_bi_gain_blows_up_when_the_estimate_crosses_the_pole(crossing: R.ScenarioResult) -> None:
    bi = crossing.bi
    assert bi.gain_blew_up and bi.max_gain > 1e3
    assert bi.crossings and abs(bi.max_gain_time - bi.crossings[0]) < 0.1
    assert "x̂3 crosses −1" in bi.summary()


def test_plot_writes_a_png(crossing: R.ScenarioResult, tmp_path: Path) -> None:
    p = tmp_path / "s.png"
    fig = R.plot_scenario(crossing, p)
    assert p.stat().st_size > 10_000 and len(fig.axes) == 4


def test_simulate_pinv_helper() -> None:
    res = simulate_pinv(R.model(), [0.5, -2.0, 0.0, 0.0], [0.3, -1.5, -1.5, 0.5], 4.0, dt=2e-3,
                          u=R.SineInput(-0.5, 0.5), theta=3.0)
    assert res.error_norm[-1] < 0.05 * res.error_norm[0]  # x̂3: e^{−4}·1.5


def test_reproduce_rows() -> None:
    rows = R.rows(duration=3.0, dt=2e-3)
    assert all(isinstance(r, ReproRow) for r in rows)
    by = {r.quantity: r for r in rows}
    assert by["observation relative degree r (A1)"].nlobs == 2
    assert "k2/(2*(x3 + 1))" in str(by["BI gain (24) = (Φ')⁻¹ [k; 0]"].nlobs)
    assert by["pole of the BI gain"].nlobs == "x3 = -1"
    assert by["Φ of (23) injective (A2)"].nlobs is False
    assert sum(r.quantity.startswith("simulation") for r in rows) == len(R.SCENARIOS)
    assert R.reproduce is R.rows
    from nlobs.papers.reproduce import PAPERS

    assert PAPERS["robenack2008"] == "nlobs.papers.robenack2008"


def test_simulate_pinv_with_sampled_noisy_measurements() -> None:
    from nlobs.simulate import MeasurementGroup

    kw = dict(dt=2e-3, u=R.SineInput(-0.5, 0.5), theta=3.0,
              measurements=MeasurementGroup("y", ["y"], rate=100.0, noise_std=0.01))
    a = simulate_pinv(R.model(), [0.5, -2.0, 0.0, 0.0], [0.3, -1.5, -1.5, 0.5], 3.0, seed=1, **kw)  # type: ignore[arg-type]
    b = simulate_pinv(R.model(), [0.5, -2.0, 0.0, 0.0], [0.3, -1.5, -1.5, 0.5], 3.0, seed=1, **kw)  # type: ignore[arg-type]
    np.testing.assert_array_equal(a.x_hat, b.x_hat)  # seeded
    assert a.sampled[::5].any() and a.error_norm[-1] < 0.2 * a.error_norm[0]
