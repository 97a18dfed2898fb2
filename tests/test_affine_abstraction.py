"""Affine abstraction (Khajenejad & Yong, Prop. 2.18, LP (3), form (6)): closed forms, certified bound, bad input."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from nlobs.errors import AssumptionViolated, DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.synthesis.affine_abstraction import AbstractionBound, affine_abstraction
from nlobs.systems.codegen import compile_matrix


def square(z: np.ndarray) -> np.ndarray:
    return z[..., :1] ** 2


def test_affine_function_is_recovered_exactly() -> None:
    M = np.array([[1.0, 2.0], [-3.0, 0.5], [0.0, 1.0]])
    c = np.array([0.3, -1.0, 2.0])
    r = affine_abstraction(lambda z: z @ M.T + c, [-1.0, 0.0], [2.0, 3.0], gradient_lipschitz=0.0, points_per_axis=4)
    np.testing.assert_allclose(r.A, M, atol=1e-9)
    np.testing.assert_allclose(r.e, c, atol=1e-9)
    assert np.all(r.sigma == 0.0)
    assert np.all(r.residual_bound <= 1e-9)
    np.testing.assert_allclose(r.A_upper, r.A_lower, atol=1e-9)


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_exact_constants_of_an_affine_map_at_any_scale_are_accepted(scale: float) -> None:
    # the stated constants are the true ones (|Δq|/h equals ‖M_i‖ along an axis, zero curvature):
    # rounding must not turn them into a reported violation
    M = scale * np.array([[3.0], [-7.0]])
    c = np.array([1e8 * scale, -2.0])
    r = affine_abstraction(lambda z: z @ M.T + c, [-5.0], [5.0], lipschitz=np.abs(M[:, 0]), gradient_lipschitz=0.0,
                           points_per_axis=101, n_check=10_000)
    np.testing.assert_allclose(r.A, M, rtol=1e-9)
    assert np.all(r.residual_bound <= 1e-9 * (1.0 + np.abs(c)))


@pytest.mark.parametrize("m", [3, 5, 21, 201])
def test_square_on_unit_interval_matches_the_minimax_line(m: int) -> None:
    # Best uniform affine approximation of x² on [−1, 1]: the constant 1/2, error 1/2
    # (equioscillation at −1, 0, 1). With a grid of spacing h containing 0, LP (3) gives
    # upper = 1 + σ, lower = −σ with σ = λh²/8 = h²/4 (λ = 2), so η = 1/2 + h²/4 exactly.
    r = affine_abstraction(square, [-1.0], [1.0], gradient_lipschitz=2.0, points_per_axis=m)
    h = 2.0 / (m - 1)
    np.testing.assert_allclose(r.A, [[0.0]], atol=1e-9)
    np.testing.assert_allclose(r.e, [0.5], atol=1e-9)
    np.testing.assert_allclose(r.sigma, [h**2 / 4], rtol=1e-12)
    np.testing.assert_allclose(r.residual_bound, [0.5 + h**2 / 4], rtol=1e-9)
    assert r.bound == (AbstractionBound.GRADIENT_LIPSCHITZ,)
    # the true sup residual of the midpoint is 1/2 (at −1, 0, 1, all grid points)
    np.testing.assert_allclose(r.sampled_max_residual, [0.5], atol=1e-9)


def test_corners_only_is_prop_2_18_as_printed() -> None:
    # only the vertices ±1: σ = λ R²/2 = 1 (R = 1), upper ≥ 2, lower ≤ 0 ⇒ e = 1, η = 1
    r = affine_abstraction(square, [-1.0], [1.0], gradient_lipschitz=2.0)
    assert r.points.shape == (2, 1)
    np.testing.assert_allclose([r.A[0, 0], r.e[0], r.residual_bound[0]], [0.0, 1.0, 1.0], atol=1e-9)
    # (3) as printed subtracts 2σ in the objective constraint, so θ*/2 misses σ: here it
    # claims a zero residual, while |z² − 1| = 1 at z = 0
    np.testing.assert_allclose(r.eta_as_printed, [0.0], atol=1e-9)
    assert abs(square(np.zeros((1, 1)))[0, 0] - r(np.zeros((1, 1)))[0, 0]) == pytest.approx(1.0)
    assert r.sampled_max_residual[0] == pytest.approx(1.0, abs=1e-3)


def test_lipschitz_correction_is_first_order_in_h() -> None:
    # L = 2 for x² on [−1, 1]: σ = L h / 2 = h, η = 1/2 + h
    r = affine_abstraction(square, [-1.0], [1.0], lipschitz=2.0, points_per_axis=21)
    np.testing.assert_allclose(r.sigma, [0.1], rtol=1e-12)
    np.testing.assert_allclose(r.residual_bound, [0.6], rtol=1e-9)
    # with both constants the smaller σ is used, per component
    both = affine_abstraction(square, [-1.0], [1.0], lipschitz=2.0, gradient_lipschitz=2.0, points_per_axis=21)
    np.testing.assert_allclose(both.sigma, [0.0025], rtol=1e-12)


def _trig(z: np.ndarray) -> np.ndarray:
    x1, x2 = z[..., 0], z[..., 1]
    return np.stack([np.sin(x1) * x2, x1**2 - np.cos(x2)], axis=-1)


LO, HI = np.array([-1.0, -1.5]), np.array([2.0, 1.0])
# ‖∇²(sin x1 · x2)‖₂ ≤ ‖·‖_F ≤ √(x2² + 2) ≤ √(1.5² + 2)
# ∇²(x1² − cos x2) = diag(2, cos x2)
GRAD_LIP = [np.sqrt(1.5**2 + 2.0), 2.0]
# ‖∇(sin x1 · x2)‖ ≤ √(1.5² + 1); ‖∇(x1² − cos x2)‖ ≤ √(4² + 1)
LIP = [np.sqrt(1.5**2 + 1.0), np.sqrt(17.0)]


@pytest.mark.parametrize("kw", [{"gradient_lipschitz": GRAD_LIP}, {"lipschitz": LIP}], ids=["gradient", "lipschitz"])
def test_certified_bound_holds_on_dense_random_points(kw: dict[str, list[float]]) -> None:
    r = affine_abstraction(_trig, LO, HI, points_per_axis=21, n_check=0, **kw)
    rng = np.random.default_rng(12345)
    z = LO + (HI - LO) * rng.random((100_000, 2))
    resid = np.abs(_trig(z) - r(z))
    assert np.all(resid <= r.residual_bound)
    # and the bounds (5) themselves hold
    assert np.all(z @ r.A_lower.T + r.e_lower <= _trig(z))
    assert np.all(_trig(z) <= z @ r.A_upper.T + r.e_upper)
    # not vacuous: the residual comes within σ (+ 1 %) of the bound
    assert np.all(resid.max(axis=0) >= r.residual_bound - r.sigma - 0.01 * r.residual_bound)


def test_composes_with_a_compiled_symbolic_function() -> None:
    x1, x2 = sp.symbols("x1 x2")
    f = compile_matrix([sp.sin(x1) * x2, x1**2 - sp.cos(x2)], [(x1, x2)], vector=True)
    r = affine_abstraction(f, LO, HI, gradient_lipschitz=GRAD_LIP, points_per_axis=11)
    ref = affine_abstraction(_trig, LO, HI, gradient_lipschitz=GRAD_LIP, points_per_axis=11)
    np.testing.assert_allclose(r.A, ref.A, atol=1e-9)
    np.testing.assert_allclose(r.residual_bound, ref.residual_bound, atol=1e-9)


def test_refining_the_grid_tightens_the_bound() -> None:
    etas = [affine_abstraction(_trig, LO, HI, gradient_lipschitz=GRAD_LIP, points_per_axis=m,
                               n_check=0).residual_bound for m in (3, 9, 33)]
    assert np.all(etas[0] > etas[1]) and np.all(etas[1] > etas[2])


def test_form_6_split_and_noise_bound() -> None:
    # z = (x, u): μ(x, u) = x·u on [0, 1]²; C and D̃ are the columns of A
    r = affine_abstraction(lambda z: z[..., :1] * z[..., 1:], [0.0, 0.0], [1.0, 1.0], gradient_lipschitz=1.0,
                           points_per_axis=9)
    C, D = r.split(1)
    assert C.shape == (1, 1) and D.shape == (1, 1)
    np.testing.assert_allclose(np.hstack([C, D]), r.A)
    two = affine_abstraction(lambda z: np.concatenate([square(z), square(z)], axis=-1), [-1.0], [1.0],
                             gradient_lipschitz=2.0, points_per_axis=21)
    # ‖v^a‖₂ ≤ ‖η‖₂ = √2 η₁ (not the ∞-norm bound η₁ the printed (7) adds)
    assert two.noise_bound(0.1) == pytest.approx(0.1 + np.sqrt(2.0) * 0.5025, rel=1e-9)
    assert two.eta_inf == pytest.approx(0.5025, rel=1e-9)
    with pytest.raises(InvalidArgumentError, match="n_x"):
        r.split(3)


def test_too_small_constant_is_reported_with_evidence() -> None:
    with pytest.raises(AssumptionViolated, match="not lipschitz with constant 1") as info:
        affine_abstraction(lambda z: np.sin(5.0 * z), [0.0], [1.0], lipschitz=1.0, points_per_axis=11)
    assert info.value.item == "lipschitz_constant"
    # corners only: no grid evidence, the random check points catch it
    with pytest.raises(AssumptionViolated, match="residual .* > certified"):
        affine_abstraction(square, [-1.0], [1.0], gradient_lipschitz=0.1)


@pytest.mark.parametrize(
    ("lo", "hi", "match"),
    [([0.0, 1.0], [1.0, 0.5], "box is empty: upper\\[1\\]"),
     ([0.0, 1.0], [1.0, 1.0], "box is degenerate: upper\\[1\\] = lower\\[1\\]"),
     ([], [], "at least one coordinate")],
)
def test_bad_box(lo: list[float], hi: list[float], match: str) -> None:
    err = DimensionError if not lo else InvalidArgumentError
    with pytest.raises(err, match=match):
        affine_abstraction(square, lo, hi, lipschitz=1.0)


def test_bad_values_shapes_and_options() -> None:
    with pytest.raises(NonFiniteError, match="component 0 is -inf at z = \\[0.\\]"):
        with np.errstate(divide="ignore"):
            affine_abstraction(lambda z: np.log(z), [0.0], [1.0], lipschitz=1.0)
    with pytest.raises(DimensionError, match="returned shape \\(2,\\)"):
        affine_abstraction(lambda z: z[..., 0] ** 2, [-1.0], [1.0], lipschitz=2.0)
    with pytest.raises(DimensionError, match="upper: expected length 1"):
        affine_abstraction(square, [-1.0], [1.0, 2.0], lipschitz=2.0)
    with pytest.raises(NonFiniteError, match="lower"):
        affine_abstraction(square, [np.nan], [1.0], lipschitz=2.0)
    with pytest.raises(InvalidArgumentError, match="give at least one constant"):
        affine_abstraction(square, [-1.0], [1.0])
    with pytest.raises(InvalidArgumentError, match="lipschitz\\[0\\]: must be non-negative"):
        affine_abstraction(square, [-1.0], [1.0], lipschitz=-1.0)
    with pytest.raises(DimensionError, match="lipschitz: expected a number or shape \\(1,\\)"):
        affine_abstraction(square, [-1.0], [1.0], lipschitz=[1.0, 2.0])
    with pytest.raises(InvalidArgumentError, match="points_per_axis\\[0\\]: must be an integer ≥ 2"):
        affine_abstraction(square, [-1.0], [1.0], lipschitz=2.0, points_per_axis=1)
    with pytest.raises(InvalidArgumentError, match="at most 200000"):
        affine_abstraction(lambda z: z[..., :1], [0.0] * 3, [1.0] * 3, lipschitz=1.0, points_per_axis=100)
