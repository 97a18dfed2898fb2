"""Khajenejad & Yong figures (Figs. 2-7 analogues, Sec. 6.2 claim, affine output): the runs behind them can fail."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nlobs.errors import AssumptionViolated, InvalidArgumentError
from nlobs.papers.khajenejad_yong import example_62
from nlobs.papers.khajenejad_yong_figures import (
    example_62_variant,
    fig_61_states,
    fig_affine_output,
    fig_unbounded_input,
)
from nlobs.linear.transform_ui import structural_check
from nlobs.synthesis.setvalued import design_setvalued

PNG = b"\x89PNG\r\n\x1a\n"


def test_variant_differs_from_the_printed_example_only_where_stated() -> None:
    v, p = example_62_variant().system, example_62().system
    np.testing.assert_array_equal(v.A, p.A)
    np.testing.assert_array_equal(v.C, p.C)
    np.testing.assert_array_equal(v.G, -p.G * np.array([[-1.0], [1.0]]))  # only the sign of G2 flips
    assert (v.eta_w, v.eta_v) == (p.eta_w, p.eta_v)
    assert "variant" in v.name and "NOT the paper" in example_62_variant().note
    with pytest.raises(AssumptionViolated, match="no stable observer"):
        design_setvalued(p)
    chk = structural_check(v.A, v.G, v.C, v.H)
    assert chk.exists  # invariant zero 0.5031 inside the unit circle


@pytest.fixture(scope="module")
def claim62(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return fig_unbounded_input(tmp_path_factory.mktemp("f"), example="62-variant", runs=50, steps=200, seed=1)


def test_sec62_claim_on_the_variant(claim62) -> None:  # type: ignore[no-untyped-def]
    r = claim62
    for st in (r.bounded, r.growing):  # containment in every run, bounded and growing d
        assert st.containment.rate_state == 1.0 and st.containment.rate_input == 1.0
    sv_b, sv_g = r.growth("setvalued")
    assert sv_g < 2.0 and sv_b < 2.0  # the set-valued error does not grow with d
    for which in ("lipschitz", "ekf"):
        b, g = r.growth(which)
        assert b < 2.0, which  # bounded d: the baselines stay bounded
        assert g > 5.0, which  # growing d: they are driven away (d_k = 0.1 k)
        assert r.first_step_above_radius(which) is not None  # and leave the sound ball
        assert r.first_step_above_radius(which, growing=False) is None
    assert r.growing.final_error_state < r.growing.containment.final_radius_state
    assert all(p.read_bytes()[:8] == PNG for p in r.paths) and len(r.paths) == 4


@pytest.mark.slow
def test_sec62_claim_on_61_bounded_radii_equal(tmp_path: Path) -> None:
    r = fig_unbounded_input(tmp_path, example="61", runs=20, steps=300, seed=2)
    assert r.bounded.containment.rate_state == r.growing.containment.rate_state == 1.0
    np.testing.assert_array_equal(r.bounded.containment.radii.state, r.growing.containment.radii.state)
    assert r.growth("lipschitz")[1] > 10 and r.growth("ekf")[1] > 5


def test_fig2_and_affine_output(tmp_path: Path) -> None:
    f = fig_61_states(tmp_path / "f2.png", steps=150)
    assert f.numbers["rate_state"] == 1.0 and f.path.read_bytes()[:8] == PNG
    assert f.numbers["final_radius_state_0_structured"] < f.numbers["final_radius_state_II"]
    a = fig_affine_output(tmp_path / "aff.png", runs=100, steps=80)
    assert a.inside_box == 1.0  # the guarantee needs the state to stay in the abstraction's box
    assert a.rate_state == 1.0 and a.rate_input == 1.0
    assert a.eta_abstraction[1] == pytest.approx(0.05 * 1.5**2 / 2, rel=0.02)  # minimax line of 0.05 x² on [−1.5, 1.5] (+ σ)
    assert a.eta_v_total == pytest.approx(0.02 + float(np.linalg.norm(a.eta_abstraction)), rel=1e-12)


def test_unknown_example_name(tmp_path: Path) -> None:
    with pytest.raises(InvalidArgumentError, match="62-variant"):
        fig_unbounded_input(tmp_path, example="6.3")
