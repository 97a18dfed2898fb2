"""``nlobs reproduce khajenejad-yong`` rows (Khajenejad & Yong, Sec. 6): computed, not pasted."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.papers.khajenejad_yong import reproduce
from nlobs.papers.reproduce import PAPERS, ReproRow

pytestmark = pytest.mark.slow  # its module fixture alone takes seconds

QUANTITIES = ("ρ", "α", "L̃", "P", "Y")


@pytest.fixture(scope="module")
def rows() -> dict[str, ReproRow]:
    out = reproduce()
    assert all(set(r.to_dict()) == {"quantity", "paper", "nlobs", "note"} for r in out)
    names = [r.quantity for r in out]
    assert len(names) == len(set(names)), "duplicate quantities"
    return {r.quantity: r for r in out}


def test_registered() -> None:
    assert PAPERS["khajenejad-yong"] == "nlobs.papers.khajenejad_yong"


def test_printed_values_are_inconsistent_and_destabilising(rows: dict[str, ReproRow]) -> None:
    r = rows["6.1 Class I: P*⁻¹Y* (should equal L̃*)"]
    np.testing.assert_allclose(r.nlobs, [14.04, 10.07, 7.944, 3.353], rtol=2e-3)  # measured independently: [14.0, 10.1, 7.9, 3.4]
    assert r.paper == [1.262, 0.4288, 0.4244, 0.2667]
    for cls in ("0", "I", "II"):
        assert rows[f"6.1 Class {cls}: spectral radius of (I − L̃*C₂)(A − Ψ) with the printed L̃*"].nlobs > 1
    assert rows["6.1 Class I: max |P* − P*ᵀ| of the printed P*"].nlobs == pytest.approx(0.2268 - 0.2208, abs=1e-12)
    assert rows["6.1 Class I: λ_min(α*P*) − (1 + L_f²), needed ≥ 0 by N22 ⪰ 0 of (26)-(28)"].nlobs < 0
    lb = rows["6.1 Class I: lower bound √((1 + L_f²)/α*) on ρ implied by N11 ⪰ 0, N22 ⪰ 0"]
    assert lb.paper == 0.9436 and lb.nlobs > 1 > lb.paper
    r62 = rows["6.2 P*⁻¹Y* (should equal L̃*)"]
    assert abs(r62.nlobs[0] - r62.paper[0]) / abs(r62.paper[0]) > 0.05  # inconsistent beyond the printed digits


def test_every_reported_value_has_a_printed_and_a_sound_row(rows: dict[str, ReproRow]) -> None:
    printed_keys = {"ρ": "rho", "α": "alpha", "L̃": "L_tilde", "P": "P", "Y": "Y"}
    for tag in ("6.1 Class 0", "6.1 Class I", "6.1 Class II", "6.2"):
        for q in QUANTITIES:
            pr = rows[f"{tag}: {q}* (Thm 5.10 as printed)" if tag != "6.2" else f"6.2 {q}* (Thm 5.10 as printed)"]
            assert pr.paper is not None and pr.nlobs is not None, (tag, q, printed_keys[q])
            sound = [k for k in rows if k.startswith(f"{tag}: {q} (sound" if tag != "6.2" else f"6.2 {q} (sound")
                     or (q == "Y" and k.startswith(f"{tag}: Y = P L̃ (sound"))]
            assert sound, (tag, q)


def test_sound_and_printed_outcomes(rows: dict[str, ReproRow]) -> None:
    assert rows["6.1 Class I: ρ* (Thm 5.10 as printed)"].nlobs == "infeasible"
    assert rows["6.1 Class I: sound design"].nlobs == "infeasible"
    assert rows["6.1 Class II: containment state/input, 1000 runs (sound)"].nlobs == [1.0, 1.0]
    r = rows["6.1 Class II: ρ* (Thm 5.10 as printed)"]
    assert r.paper == 0.9783 and r.nlobs > 1  # the printed LMIs' optimum, and it is not certified:
    assert "spectral radius 1.7" in r.note
    assert rows["6.1 Class II: sound design (radius objective), steady radius bound"].nlobs == pytest.approx(20.38, rel=0.02)
    assert rows["6.2 stable observer of this structure exists"].nlobs is False
    assert "-1.34308" in rows["6.2 stable observer of this structure exists"].note
    assert rows["6.2 L̃ (sound)"].nlobs == "no stable observer"
    assert rows["6.2 spectral radius of (I − L̃*C₂)Φ(A − Ψ) with the printed L̃*"].nlobs >= 1.343
    assert rows["6.2 Lipschitz constant of f on [−3, 3]² (sampled estimate)"].nlobs > 1.9  # not 1.1171
    rate = rows["6.2 containment state/input, printed L̃* and Thm 5.13 bounds, 1000 runs"].nlobs
    assert rate[0] < 0.5 and rate[1] < 0.6


def test_affine_abstraction_printed_eta_is_exceeded_and_the_certified_one_holds(rows: dict[str, ReproRow]) -> None:
    printed = rows["Prop. 2.18 η_vᵃ of μ = [sin z₁, z₁z₂] on [−1, 1]², corners only: as printed (θ*/2)"]
    sound = rows["Prop. 2.18 η_vᵃ, same LP: certified by nlobs (θ*/2 + σ)"]
    assert printed.nlobs[0] == pytest.approx(0.0, abs=1e-12)  # docs/affine_abstraction.md: printed 0 for sin z1
    assert "component(s) [1]" in printed.note  # the sampled residual (0.060) exceeds it
    np.testing.assert_allclose(sound.nlobs, [np.sin(1.0), 2.0], rtol=1e-3)
    fine = rows["Prop. 2.18 η_vᵃ, same μ: certified on a 21-point grid"].nlobs
    assert fine[0] < 0.05 < sound.nlobs[0]


def test_prop516_rows_converging_bounds_with_a_diverging_gain(rows: dict[str, ReproRow]) -> None:
    from nlobs.papers.khajenejad_yong import example_61
    from nlobs.linear.transform_ui import ui_transform

    assert rows["6.1 Class II: θ₁ = |λmax(P**) − 1|/λmin(P**) (32) at Prop. 5.16's P**"].nlobs < 1
    # The gain Prop. 5.16 returns, checked here from its printed entries: (I − L̃C₂)Φ(A − Ψ) has |λ| > 1.
    s = example_61("II").system
    tr = ui_transform(s.G, s.C, s.H)
    L = np.asarray(rows["6.1 Class II: L̃** (Prop. 5.16 as printed)"].nlobs, dtype=float)[:, None]
    E = (np.eye(4) - L @ tr.C2) @ tr.Phi @ (s.A - tr.Psi)
    assert np.max(np.abs(np.linalg.eigvals(E))) > 1.5  # 4-digit entries: far from the stability boundary
    for cls in ("0", "I"):
        assert rows[f"6.1 Class {cls}: ρ** (Prop. 5.16 as printed, two SDPs)"].nlobs == "infeasible"
