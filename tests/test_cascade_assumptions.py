"""Assumption 4 item by item, typed errors, Theorem 1 / 1' bounds, Assumption 1 constants."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import sympy as sp

from nlobs.errors import (
    AssumptionViolated,
    DesignError,
    DesignInfeasible,
    DimensionError,
    InvalidArgumentError,
    ModelError,
    NonFiniteError,
)
from nlobs.linear.assumption4 import check_assumption4, require_assumption4
from nlobs.observers.cascade import CascadeObserver
from nlobs.synthesis.cascade_bounds import (
    quadratic_lyapunov_constants,
    theorem1_gamma_bound,
    theorem1_optimal_scaling,
    theorem1_prime_gamma_bound,
)
from nlobs.synthesis.cascade_gain import design_cascade_gain, place_cascade_gain
from nlobs.systems.interconnected import LinearSubsystem, NonlinearSubsystem, interconnected_plant

EX1 = ([[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]])


def test_example1_filter_satisfies_assumption4() -> None:
    rep = check_assumption4(*EX1)
    assert rep.holds and rep.minimum_phase and rep.gamma_star_zero
    assert rep.zeros.size == 0 and rep.normal_rank == 3
    assert [it.key for it in rep.items if it.required] == [
        "rank_Bz_Dz", "rank_C_Dz", "detectable", "left_invertible", "no_zero_at_origin"]
    d = rep.to_dict()
    json.dumps(d)
    assert d["holds"] is True and len(d["items"]) == 7
    txt = rep.summary()
    assert "HOLDS" in txt and "γ* = 0" in txt and "no finite zeros" in txt


def test_zero_at_origin_is_reported_and_blocks_the_design() -> None:
    # s/(s + 1) = 1 − 1/(s + 1): A = −1, B_z = 1, C = −1, D_z = 1
    sys = ([[-1.0]], [[1.0]], [[-1.0]], [[1.0]])
    rep = check_assumption4(*sys)
    assert not rep.holds
    assert [it.key for it in rep.failed] == ["no_zero_at_origin"]
    np.testing.assert_allclose(rep.zeros, [0.0], atol=1e-12)
    assert rep.item("detectable").passed and rep.item("left_invertible").passed
    assert "FAIL" in rep.summary() and "zero(s) at s = 0" in rep.item("no_zero_at_origin").evidence
    with pytest.raises(AssumptionViolated, match="no invariant zero at the origin") as ei:
        design_cascade_gain(LinearSubsystem(*sys), gamma=1.0, gain_bound=100.0)
    assert ei.value.item == "no_zero_at_origin"
    assert isinstance(ei.value, DesignError)
    with pytest.raises(AssumptionViolated, match="no_zero_at_origin"):
        place_cascade_gain(sys, gamma=1.0)
    # Theorem 2's proof: the extended pair then has an unobservable mode at 0
    assert not rep.item("extended_detectable").passed


def test_undetectable_pair() -> None:
    A = np.diag([1.0, -1.0])  # mode +1 not seen by C
    rep = check_assumption4(A, [[1.0], [1.0]], [[0.0, 1.0]])
    assert not rep.item("detectable").passed
    assert "1" in rep.item("detectable").evidence
    with pytest.raises(AssumptionViolated, match=r"\(A, C\) detectable \[detectable\]"):
        require_assumption4(A, [[1.0], [1.0]], [[0.0, 1.0]])


def test_rank_deficient_Bz_Dz_and_C_Dz() -> None:
    A = [[0.0, 1.0], [-1.0, -1.0]]
    rep = check_assumption4(A, [[0.0, 0.0], [1.0, 2.0]], [[1.0, 0.0]])
    assert not rep.item("rank_Bz_Dz").passed
    assert rep.item("rank_Bz_Dz").values["rank"] == 1
    with pytest.raises(AssumptionViolated, match=r"rank \[B_z; D_z\] = 1 \(need 2\)"):
        require_assumption4(A, [[0.0, 0.0], [1.0, 2.0]], [[1.0, 0.0]])
    rep2 = check_assumption4(A, [[0.0], [1.0]], [[1.0, 0.0], [2.0, 0.0]])
    assert not rep2.item("rank_C_Dz").passed
    with pytest.raises(AssumptionViolated, match="rank_C_Dz"):
        require_assumption4(A, [[0.0], [1.0]], [[1.0, 0.0], [2.0, 0.0]])


def test_not_left_invertible_more_z_than_y() -> None:
    A = [[0.0, 1.0], [-1.0, -1.0]]
    rep = check_assumption4(A, np.eye(2), [[1.0, 0.0]])
    assert not rep.item("left_invertible").passed
    assert rep.normal_rank < 4


def test_non_minimum_phase_holds_but_gamma_star_may_be_positive() -> None:
    # (1 − s)/(s + 1)²: zero at s = 1
    A = [[0.0, 1.0], [-1.0, -2.0]]
    rep = check_assumption4(A, [[0.0], [1.0]], [[1.0, -1.0]])
    assert rep.holds and not rep.minimum_phase and not rep.gamma_star_zero
    np.testing.assert_allclose(rep.zeros, [1.0])
    assert "γ* > 0 possible" in rep.summary()


def test_dimension_mismatches_between_sigma1_and_sigma2() -> None:
    x1, x2, z1, z2, w1 = sp.symbols("x1 x2 z1 z2 w1")
    two_z = NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z1", "z2"], f=[x2, -x1], h=[x1, x2],
                                        g=[z1 - x1, z2 - x2])
    s2 = LinearSubsystem(*EX1)
    with pytest.raises(DimensionError, match="p_z mismatch: h of Σ1 has 2 outputs z but B_z/D_z of Σ2 have 1"):
        interconnected_plant(two_z, s2)
    with pytest.raises(DimensionError, match="p_z mismatch"):
        CascadeObserver(two_z, s2, np.ones((3, 1)))
    fb = NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z1"], f=[x2, -x1 + w1], h=[x1], g=[z1, 0],
                                     linear_states=["w1", "w2", "w3"])
    with pytest.raises(DimensionError, match="n_w mismatch: Σ1\\* uses 3 linear states"):
        interconnected_plant(fb, s2)
    with_u = NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z1"], inputs=["u"], f=[x2, -x1], h=[x1],
                                         g=[z1, 0])
    with pytest.raises(DimensionError, match="B_u/D_u have 2 columns but Σ1 has m = 1"):
        interconnected_plant(with_u, LinearSubsystem(*EX1, B_u=np.ones((2, 2))))
    with pytest.raises(DimensionError, match="K: expected shape"):
        CascadeObserver(NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z1"], f=[x2, -x1], h=[x1],
                                                    g=[z1, 0]), s2, np.ones((2, 1)))
    with pytest.raises(DimensionError, match="B_z"):
        LinearSubsystem([[0.0, 1.0], [-1.0, -1.0]], [[1.0]], [[1.0, 0.0]])


def test_symbolic_and_numeric_model_errors() -> None:
    x1, x2, z = sp.symbols("x1 x2 z")
    with pytest.raises(ModelError, match="z may appear only in g"):
        NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=[x2, z], h=[x1], g=[0, 0])
    with pytest.raises(ModelError, match="undeclared symbols \\['q'\\]"):
        NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=[x2, sp.Symbol("q")], h=[x1], g=[0, 0])
    with pytest.raises(ModelError, match="names used twice"):
        NonlinearSubsystem.symbolic(states=["x1", "z"], outputs=["z"], f=[x2, 0], h=[x1], g=[0, 0])
    with pytest.raises(DimensionError, match="g: expected 2 entries"):
        NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=[x2, x1], h=[x1], g=[0])
    ok = {"n_x": 2, "p_z": 1, "f": lambda u, x: x, "h": lambda u, x: x[..., :1],
          "g": lambda u, xh, z: np.concatenate([z, z], axis=-1),
          "h_x": lambda u, x: np.broadcast_to(np.array([[1.0, 0.0]]), (*x.shape[:-1], 1, 2))}
    NonlinearSubsystem.numeric(**ok)
    with pytest.raises(DimensionError, match=r"h_x: returned shape \(2, 1\)"):
        NonlinearSubsystem.numeric(**{**ok, "h_x": lambda u, x: np.zeros((*x.shape[:-1], 2, 1))})
    with pytest.raises(InvalidArgumentError, match="h_w: the feedback case needs"):
        NonlinearSubsystem.numeric(**{**ok, "n_w": 2})


def test_theorem1_bound_against_hand_formula() -> None:
    a3, a4, L1, L2 = 0.5, 3.0, 2.0, 1.5
    assert theorem1_gamma_bound(a3, a4, L1, L2) == pytest.approx(4 * 0.5 / (4 * 2.25 + 9.0 * 4.0), rel=1e-15)
    c, g = theorem1_optimal_scaling(a3, a4, L1, L2)
    assert c == pytest.approx(2 * 1.5 / (3.0 * 2.0))
    assert g == pytest.approx(0.5 / (3.0 * 2.0 * 1.5))
    # the optimum beats a grid of scalings
    assert all(theorem1_gamma_bound(s * a3, s * a4, L1, L2) <= g * (1 + 1e-12) for s in np.logspace(-3, 3, 61))
    for bad in (-0.1, 0.0):
        with pytest.raises(InvalidArgumentError, match="alpha3: must be positive"):
            theorem1_gamma_bound(bad, a4, L1, L2)
    with pytest.raises(InvalidArgumentError, match="L2: must be positive"):
        theorem1_gamma_bound(a3, a4, L1, -1.0)
    with pytest.raises(NonFiniteError, match="alpha4"):
        theorem1_gamma_bound(a3, math.nan, L1, L2)


def test_theorem1_prime_bound_satisfies_both_conditions_of_the_proof() -> None:
    a3, a4, L1, L2 = 0.5, 3.0, 2.0, 1.5

    def ok(g: float) -> bool:  # Appendix B, proof of Theorem 1', written out here
        return g < a3 / L2**2 and g < 4 * (a3 - g * L2**2) * (1 - g**2 * L2**2) / (a4**2 * L1**2)

    gb = theorem1_prime_gamma_bound(a3, a4, L1, L2, optimise_scaling=False)
    assert ok(0.999 * gb) and not ok(1.001 * gb)
    assert theorem1_prime_gamma_bound(a3, a4, L1, L2) >= gb


def test_assumption1_constants_for_a_lipschitz_observer_and_infeasibility() -> None:
    F = np.array([[0.0, -68.6], [1.0, -12.6]])  # Example 1: A1 − L C1
    q = quadratic_lyapunov_constants(F, 0.4)
    assert 0 < q.alpha1 <= q.alpha2 and q.alpha4 == pytest.approx(2 * q.alpha2)
    assert q.certificate_max_eig <= 0
    with pytest.raises(DesignInfeasible, match="Assumption 1"):
        quadratic_lyapunov_constants(F, 1.2)  # > 1/‖(sI − F)⁻¹‖∞ ≈ 0.98
