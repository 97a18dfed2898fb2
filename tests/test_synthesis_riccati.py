"""The Riccati path of ``design_observer_gain``: closed forms, agreement with the SDP, the automatic choice."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nlobs.errors import DesignInfeasible, InvalidArgumentError
from nlobs.linear.norms import hinf_norm
from nlobs.synthesis import GainBound, HalfPlane, Objective, SynthesisMethod, design_observer_gain
from nlobs.synthesis.observer_gain import _RICCATI_SIGMAS
from nlobs.synthesis.riccati import filter_riccati, riccati_delta


def _random(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) / math.sqrt(n)
    p, m = max(1, n // 4), max(1, n // 5)
    C = 2.0 * rng.standard_normal((p, n)) / math.sqrt(n)
    Bd = rng.standard_normal((n, m)) / math.sqrt(m)
    return A, C, Bd


def _norm(A: np.ndarray, B: np.ndarray) -> float:
    n = A.shape[0]
    return float(hinf_norm(A, B, np.eye(n), np.zeros((n, B.shape[1]))))


# --------------------------------------------------------------------------- scalar closed form


@pytest.mark.parametrize("a, b, c", [(1.0, 1.0, 1.0), (-0.5, 2.0, 0.7), (0.3, 0.1, 3.0)])
def test_scalar_system_matches_the_closed_form(a: float, b: float, c: float) -> None:
    gamma, gamma_n = 20.0, 2.0
    cert = design_observer_gain([[a]], [[c]], [[b]], gamma=gamma, gamma_n=gamma_n, method="riccati")
    assert cert.method is SynthesisMethod.RICCATI and cert.verified and cert.solver is None
    # r Y² + 2 a Y + q = 0 with r = 1 + σ − γn² c², q = b²/γ² + δ; the stabilising root has a + r Y < 0
    sigma = _RICCATI_SIGMAS[0]
    assert f"σ = {sigma:.3g}," in cert.solver_status
    r = 1.0 + sigma - gamma_n**2 * c**2
    q = b**2 / gamma**2 + riccati_delta(np.array([[b]]), gamma, cert.margin)
    Y = (a + math.sqrt(a**2 - r * q)) / (-r)
    K = gamma_n**2 * Y * c
    assert cert.gain[0, 0] == pytest.approx(K, rel=1e-10)
    assert cert.P[0, 0] == pytest.approx(1.0 / Y, rel=1e-10)
    pole = c * K - a  # A − K C = −pole
    assert cert.hinf_H == pytest.approx(abs(b) / pole, rel=1e-8)
    assert cert.hinf_G == pytest.approx(abs(K) / pole, rel=1e-8)
    # the joint bound the equation certifies: b²/γ² + K²/γn² < pole²
    assert b**2 / gamma**2 + K**2 / gamma_n**2 < pole**2


def test_scalar_system_without_a_solution_is_infeasible_with_the_scaling() -> None:
    # unstable a = 1 and γn c = 0.5 < 1: ‖G‖∞ = K/(cK − 1) > 1/c = 2 > γn for every stabilising K
    with pytest.raises(DesignInfeasible) as exc:
        design_observer_gain([[1.0]], [[1.0]], [[1.0]], gamma=10.0, gamma_n=0.5, method="riccati")
    assert exc.value.constraint == "Riccati equation"
    assert "no stabilising solution at γ = 10, γn = 0.5" in str(exc.value) and "τ =" in str(exc.value)


def test_the_equation_residual_is_small() -> None:
    A, C, Bd = _random(8, 3)
    sol = filter_riccati(A, C, Bd, np.eye(C.shape[0]), 40.0, 40.0, 1e-6)
    assert not isinstance(sol, str)
    assert sol.residual < 1e-10 and sol.axis_gap > 0
    assert np.allclose(sol.P @ sol.Y, np.eye(8), atol=1e-8)


# --------------------------------------------------------------------------- agreement with the SDP


@pytest.mark.parametrize("n, seed", [(4, 0), (5, 1), (6, 2), (8, 3), (10, 4)])
def test_riccati_and_sdp_gains_both_verify_with_comparable_norms(n: int, seed: int) -> None:
    A, C, Bd = _random(n, seed)
    gamma = gamma_n = 40.0
    ric = design_observer_gain(A, C, Bd, gamma=gamma, gamma_n=gamma_n, method="riccati")
    sdp = design_observer_gain(A, C, Bd, gamma=gamma, gamma_n=gamma_n, method="sdp")
    assert ric.verified and sdp.verified
    assert ric.method is SynthesisMethod.RICCATI and sdp.method is SynthesisMethod.SDP
    assert [c.name for c in ric.checks] == [c.name for c in sdp.checks]
    # ‖H‖∞ < γ recomputed here, independently of the certificate
    h = _norm(A - ric.gain @ C, Bd)
    assert h == pytest.approx(ric.hinf_H, rel=1e-6) and h < gamma
    g = _norm(A - ric.gain @ C, -ric.gain)
    assert g == pytest.approx(ric.hinf_G, rel=1e-6) and g <= gamma_n
    # the Riccati gain achieves the joint bound ‖[H/γ, G/γn]‖∞ < 1 (which implies both LMIs)
    joint = _norm(A - ric.gain @ C, np.hstack([Bd / gamma, -ric.gain / gamma_n]))
    assert joint < 1.0
    # comparable closed loops: both well inside the bounds, within a factor of each other
    for a, b in ((ric.hinf_H, sdp.hinf_H), (ric.hinf_G, sdp.hinf_G)):
        assert a < gamma and b < gamma and 0.2 < a / b < 5.0


@pytest.mark.parametrize("n, seed", [(3, 5), (4, 0), (6, 2)])
def test_feasibility_agrees_with_the_sdp_up_to_the_joint_bound(n: int, seed: int) -> None:
    """SDP feasible at (γ, γn) ⇒ the Riccati equation is solvable at (√2 γ, √2 γn); auto is as feasible as the SDP."""
    A, C, Bd = _random(n, seed)
    feasible = None
    for tau in (1.0, 0.5, 0.3, 0.2, 0.15, 0.1, 0.07, 0.05):
        try:
            design_observer_gain(A, C, Bd, gamma=40.0 * tau, gamma_n=40.0 * tau, method="sdp")
        except DesignInfeasible:
            break
        feasible = 40.0 * tau
    assert feasible is not None
    # averaging (14) and (15) gives the joint bound at √2 (γ, γn) with the SDP's own P
    s2 = math.sqrt(2.0) * 1.001 * feasible
    assert design_observer_gain(A, C, Bd, gamma=s2, gamma_n=s2, method="riccati").verified
    auto = design_observer_gain(A, C, Bd, gamma=feasible, gamma_n=feasible)  # Riccati if it can, else the SDP
    assert auto.verified and auto.hinf_H < feasible and auto.hinf_G <= feasible


def test_auto_falls_back_to_the_sdp_when_the_riccati_form_is_too_conservative() -> None:
    # measured: at γ = γn = 2.8 the LMIs (14), (15) hold with a common P, the joint bound does not
    A, C, Bd = _random(4, 0)
    with pytest.raises(DesignInfeasible) as exc:
        design_observer_gain(A, C, Bd, gamma=2.8, gamma_n=2.8, method="riccati")
    assert exc.value.constraint == "Riccati equation" and "try method='sdp'" in str(exc.value)
    auto = design_observer_gain(A, C, Bd, gamma=2.8, gamma_n=2.8)
    sdp = design_observer_gain(A, C, Bd, gamma=2.8, gamma_n=2.8, method="sdp")
    assert auto.method is SynthesisMethod.SDP and auto.verified
    assert np.allclose(auto.gain, sdp.gain)


# --------------------------------------------------------------------------- the choice


def test_auto_picks_riccati_for_the_central_design_and_sdp_otherwise() -> None:
    A, C, Bd = _random(5, 7)
    assert design_observer_gain(A, C, Bd, gamma=40.0, gamma_n=40.0).method is SynthesisMethod.RICCATI
    assert design_observer_gain(A, C, Bd, gamma=40.0, gamma_n=40.0,
                                region=HalfPlane(0.01)).method is SynthesisMethod.SDP
    assert design_observer_gain(A, C, Bd, gamma=40.0, gain_bound=GainBound(1e3)).method is SynthesisMethod.SDP


def test_forcing_riccati_without_a_riccati_form_names_why() -> None:
    A, C, Bd = _random(4, 0)
    with pytest.raises(InvalidArgumentError, match="no Riccati form: a pole region is asked"):
        design_observer_gain(A, C, Bd, gamma=40.0, gamma_n=40.0, region=HalfPlane(0.1), method="riccati")
    with pytest.raises(InvalidArgumentError, match="no Riccati form: objective 'min_gamma_n'"):
        design_observer_gain(A, C, Bd, gamma=40.0, objective=Objective.MIN_GAMMA_N, method="riccati")
    with pytest.raises(InvalidArgumentError, match="N Nᵀ is singular"):
        design_observer_gain(A, C, Bd, gamma=40.0, gamma_n=40.0, N=np.zeros((C.shape[0], 1)), method="riccati")
    with pytest.raises(InvalidArgumentError, match="unknown method"):
        design_observer_gain(A, C, Bd, gamma=40.0, gamma_n=40.0, method="newton")


def test_the_certificate_says_which_path_produced_it() -> None:
    A, C, Bd = _random(4, 0)
    cert = design_observer_gain(A, C, Bd, gamma=40.0, gamma_n=40.0)
    d = cert.to_dict()
    assert d["method"] == "riccati" and d["solver"] is None and d["solver_status"].startswith("riccati:")
    assert "method=riccati" in cert.summary()
    assert design_observer_gain(A, C, Bd, gamma=40.0, gamma_n=40.0, method="sdp").to_dict()["method"] == "sdp"


def test_undetectable_pair_is_refused_by_pbh_on_the_riccati_path() -> None:
    A = np.diag([1.0, -1.0])
    C = np.array([[0.0, 1.0]])
    with pytest.raises(DesignInfeasible) as exc:
        design_observer_gain(A, C, np.eye(2), gamma=10.0, gamma_n=10.0)
    assert exc.value.constraint == "detectability"
