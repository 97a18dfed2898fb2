"""The symbolic layer (nlobs.geometry): identities, relative degrees, observability maps and the checks."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from nlobs.errors import DimensionError, InvalidArgumentError, ModelError, NonFiniteError
from nlobs.geometry import (
    AffineFields,
    Box,
    brunovsky,
    check_a1,
    check_drift_observability,
    check_involutive,
    check_s_le_r,
    covector_lie_derivative,
    default_multi_index,
    gradient,
    input_gain_structure,
    lie_bracket,
    lie_derivative,
    observability_jacobian,
    observability_map,
    observability_rank,
    observation_relative_degree,
    symbolic_pinv,
    vanishes_on,
)
from nlobs.systems.symbolic import SymbolicModel

X = sp.symbols("x1:4", real=True)
x1, x2, x3 = X
x4 = sp.Symbol("x4", real=True)


def _zero(M: sp.MatrixBase) -> bool:
    return all(sp.simplify(e) == 0 for e in sp.Matrix(M))


def _random_poly(rng: np.random.Generator, degree: int = 2) -> sp.Expr:
    monos = sorted(sp.itermonomials(list(X), degree), key=sp.default_sort_key)
    coeffs = rng.integers(-3, 4, size=len(monos))
    return sum((int(c) * m for c, m in zip(coeffs, monos)), sp.Integer(0))


def _random_field(rng: np.random.Generator) -> sp.Matrix:
    return sp.Matrix([_random_poly(rng) for _ in X])


def _fields(states: list[str], f: list[sp.Expr], g: list[list[sp.Expr]], h: list[sp.Expr], *, inputs: list[str] | None = None,
            outputs: list[str] | None = None, name: str = "m") -> AffineFields:
    m = SymbolicModel.input_affine(states, inputs or [f"u{i + 1}" for i in range(len(g[0]))],
                                   outputs or [f"y{j + 1}" for j in range(len(h))], f=f, g=g, h=h, name=name)
    return AffineFields.from_model(m)


# ------------------------------------------------------------------ Lie calculus identities
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_covector_lie_derivative_of_an_exact_form(seed: int) -> None:
    rng = np.random.default_rng(seed)
    f, phi = _random_field(rng), _random_poly(rng, 3)
    assert _zero(covector_lie_derivative(gradient(phi, X), f, X) - gradient(lie_derivative(phi, f, X), X))


@pytest.mark.parametrize("seed", [3, 4])
def test_covector_lie_derivative_is_the_dual_of_the_bracket(seed: int) -> None:
    # ⟨L_f ω, v⟩ = L_f ⟨ω, v⟩ − ⟨ω, [f, v]⟩ for any covector ω (not only exact ones)
    rng = np.random.default_rng(seed)
    f, v, om = _random_field(rng), _random_field(rng), _random_field(rng).T
    lhs = (covector_lie_derivative(om, f, X) * v)[0, 0]
    rhs = lie_derivative((om * v)[0, 0], f, X) - (om * lie_bracket(f, v, X))[0, 0]
    assert sp.expand(lhs - rhs) == 0


@pytest.mark.parametrize("seed", [5, 6])
def test_bracket_antisymmetry_and_jacobi(seed: int) -> None:
    rng = np.random.default_rng(seed)
    f, g, k = (_random_field(rng) for _ in range(3))
    assert _zero(lie_bracket(f, g, X) + lie_bracket(g, f, X))
    jac = (lie_bracket(f, lie_bracket(g, k, X), X) + lie_bracket(g, lie_bracket(k, f, X), X)
           + lie_bracket(k, lie_bracket(f, g, X), X))
    assert _zero(jac)


def test_bracket_by_hand_and_shape_errors() -> None:
    # [x2 ∂1, ∂2] = −∂1 with [f, g] = g' f − f' g
    assert lie_bracket([x2, 0, 0], [0, 1, 0], X) == sp.Matrix([-1, 0, 0])
    assert lie_derivative(x1**2, [x2, 0, 0], X, order=2) == 2 * x2**2  # L_f x1² = 2 x1 x2, then 2 x2²
    with pytest.raises(DimensionError, match="expected a vector field with 3 entries"):
        lie_bracket([x2, 0], [0, 1, 0], X)
    with pytest.raises(DimensionError, match="order"):
        lie_derivative(x1, [1, 0, 0], X, order=-1)


# ------------------------------------------------------------------ relative degree
def test_relative_degree_textbook_cases() -> None:
    chain = _fields(["x1", "x2", "x3"], [x2, x3, -x1 - x2], [[0], [0], [1]], [x1])
    assert observation_relative_degree(chain).r == (3,)  # integrator chain: r = n
    direct = _fields(["x1", "x2", "x3"], [x2, x3, -x1], [[1], [0], [0]], [x1])
    assert observation_relative_degree(direct).r == (1,)
    isidori = _fields(["x1", "x2", "x3", "x4"], [x1 * x2 - x1**3, x1, -x3, x1**2 + x2], [[0], [2 + 2 * x3], [1], [0]],
                      [x4])
    rd = observation_relative_degree(isidori)
    assert rd.r == (2,) and rd.tests[0][0].zero and rd.tests[0][0].method == "symbolic" and not rd.tests[0][1].zero


def test_relative_degree_undefined_is_an_error_from_require() -> None:
    F = _fields(["x1", "x2", "x3"], [x2, -x1, -x3], [[0], [0], [1]], [x1], outputs=["y"], name="decoupled")
    rd = observation_relative_degree(F, Box.around(np.zeros(3), 2.0))
    assert rd.r == (None,) and rd.max_order == 3
    with pytest.raises(ModelError, match=r"output\(s\) \['y'\] is not defined on \[-2, 2\]"):
        rd.require(F.outputs)


def test_relative_degree_is_decided_on_the_region() -> None:
    # L_g h = x1 − 5 vanishes nowhere on [−1, 1]³ … and L_g h = (x1 − 5)·0 nowhere non-zero
    F = _fields(["x1", "x2", "x3"], [x2, -x1, 0], [[0], [x1 - 5], [0]], [x2])
    assert observation_relative_degree(F).r == (1,)
    assert not observation_relative_degree(F).tests[0][0].zero
    # y = x1, g1 = x1 + |x1|: L_g h = x1 + |x1| vanishes for x1 ≤ 0 only, L_g L_f h = L_g x2 = 1.
    # By hand: r = 2 on a box with x1 < 0, r = 1 on a box with x1 > 0.
    G = _fields(["x1", "x2"], [x2, -x1], [[x1 + sp.Abs(x1)], [1]], [x1])
    assert observation_relative_degree(G, Box([-2.0, -1.0], [-1.0, 1.0])).r == (2,)
    assert observation_relative_degree(G, Box([1.0, -1.0], [2.0, 1.0])).r == (1,)


def test_a_tiny_exact_value_is_not_zero_and_cancellation_is() -> None:
    # L_g h = 10⁻¹⁰ exactly (g1 = 1/10¹⁰): r = 1, decided exactly, not by an absolute tolerance.
    F = _fields(["x1", "x2"], [x2, -x1], [[sp.Rational(1, 10**10)], [1]], [x1])
    rd = observation_relative_degree(F)
    assert rd.r == (1,) and rd.tests[0][0].method == "symbolic"
    # A non-rational expression that cancels to 0 up to rounding, sin²+cos²−1 at large scale, is zero;
    # the same at 10⁻¹⁰ of its scale is not.
    big = 1e6 * (sp.sin(x1) ** 2 + sp.cos(x1) ** 2) - 1e6
    assert vanishes_on(big, X, Box.unit(3)).zero
    assert not vanishes_on(big + sp.Float(1e-3) * sp.exp(x2), X, Box.unit(3)).zero


# ------------------------------------------------------------------ observability maps, (2.13), Brunovsky
def _mimo() -> AffineFields:
    # y1 = x1 (r1 = 2), y2 = x3 (r2 = 2)
    return _fields(["x1", "x2", "x3", "x4"], [x2 + x1**2, x3 + sp.sin(x1), x4, -x1 - x3],
                   [[0, 0], [1, 0], [0, 0], [x1, 1]], [x1, x3], name="mimo")


@pytest.mark.parametrize("s", [(2, 2), (3, 1), (1, 3)])
def test_Qs_g_equals_F_H_213(s: tuple[int, int]) -> None:
    F = _mimo()
    r = observation_relative_degree(F).r
    assert r == (2, 2)
    H, Fm = input_gain_structure(F, s, r)
    Qs = observability_jacobian(F, s)
    assert _zero(Qs * F.g - sp.Matrix(Fm) * H)
    assert H.shape[0] == Fm.shape[1] == sum(max(sj - rj + 1, 0) for sj, rj in zip(s, r))
    assert check_s_le_r(s, r).passed == all(sj <= rj for sj, rj in zip(s, r))


def test_brunovsky_shapes() -> None:
    A, B, C = brunovsky((2, 1, 3))
    assert A.shape == (6, 6) and B.shape == (6, 3) and C.shape == (3, 6)
    assert np.allclose(np.linalg.matrix_power(A, 3), 0)  # nilpotent of index max s_j
    O = np.vstack([C @ np.linalg.matrix_power(A, k) for k in range(3)])
    assert np.linalg.matrix_rank(O) == 6  # (A_s, C_s) observable
    for j, (sj, start) in enumerate(zip((2, 1, 3), (0, 2, 3))):
        assert (C @ np.linalg.matrix_power(A, sj - 1) @ B)[j, j] == 1.0
        assert C[j, start] == 1.0
    with pytest.raises(InvalidArgumentError, match="at least 1"):
        brunovsky((2, 0))


def test_multi_index_errors() -> None:
    F = _mimo()
    with pytest.raises(InvalidArgumentError, match=r"multi-index s=\[1, 2\] sums to 3; it must sum to n = 4"):
        observability_map(F, (1, 2))
    with pytest.raises(DimensionError, match="expected 2 entries"):
        observability_map(F, (4,))
    with pytest.raises(InvalidArgumentError, match="non-negative"):
        observability_map(F, (5, -1))
    with pytest.raises(InvalidArgumentError, match="integers"):
        observability_map(F, (1.5, 2.5))  # type: ignore[arg-type]


def test_non_input_affine_model_is_refused() -> None:
    u = sp.Symbol("u", real=True)
    m = SymbolicModel.general(["x1", "x2"], ["u"], ["y"], rhs=[x2, sp.sin(u)], h=[x1], name="sine-input")
    with pytest.raises(ModelError, match="sine-input: the method needs an input-affine model"):
        AffineFields.from_model(m)
    m2 = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2, -x1], g=[[0], [1]], h=[x1 + u], name="feedthrough")
    with pytest.raises(ModelError, match=r"feedthrough: the output h must not depend on inputs \['u'\]"):
        AffineFields.from_model(m2)


def test_default_multi_index_on_mimo_chains() -> None:
    assert default_multi_index(_mimo()) == (2, 2)
    # y1 = x1 on a chain of 3, y2 = x4: s = (3, 1)
    F = _fields(["x1", "x2", "x3", "x4"], [x2, x3, -x1 + x4, -x4], [[0], [0], [1], [1]], [x1, x4])
    assert default_multi_index(F) == (3, 1)
    assert check_drift_observability(F, (3, 1)).passed


def test_observability_rank_with_an_unobservable_state() -> None:
    F = _fields(["x1", "x2", "x3"], [x2, -x1, -x3], [[0], [1], [1]], [x1])
    assert observability_rank(F) == 2
    isidori = _fields(["x1", "x2", "x3", "x4"], [x1 * x2 - x1**3, x1, -x3, x1**2 + x2], [[0], [2 + 2 * x3], [1], [0]],
                      [x4])
    assert observability_rank(isidori) == 3  # x3 never enters h or f's other rows


# ------------------------------------------------------------------ checks with evidence
def test_drift_observability_reports_the_worst_point() -> None:
    # y = x1, ẋ1 = x2²: Q_s = [[1, 0], [0, 2 x2]] is singular on x2 = 0
    F = _fields(["x1", "x2"], [x2**2, -x1], [[0], [1]], [x1], name="fold")
    chk = check_drift_observability(F, (2,), Box([-1.0, -1.0], [1.0, 1.0]), samples=200, seed=1)
    assert chk.symbolic == "2*x2" and "det Q_s = 2*x2" in chk.evidence and not chk.passed
    # On x2 ∈ [0.25, 1] it is nonsingular; σ_min(Q_s) = min(1, 2 x2) is smallest (0.5) on the edge x2 = 0.25.
    chk = check_drift_observability(F, (2,), Box([-1.0, 0.25], [1.0, 1.0]), samples=200, seed=1)
    assert chk.passed and chk.method == "numeric"
    assert chk.value == pytest.approx(0.5, rel=1e-6)
    assert chk.worst_point is not None and chk.worst_point[1] == pytest.approx(0.25, abs=1e-6)
    # singular everywhere: det Q_s ≡ 0
    G = _fields(["x1", "x2"], [0, x1], [[1], [0]], [x1], name="flat")
    bad = check_drift_observability(G, (2,))
    assert not bad.passed and bad.method == "symbolic" and bad.symbolic == "0" and bad.worst_point is None


def test_drift_observability_sees_a_sign_change_of_det() -> None:
    # Q_s = [[1, 0], [0, 2 x2]]: det = 2 x2 changes sign across the line x2 = 0, which sampling never hits.
    F = _fields(["x1", "x2"], [x2**2, -x1], [[0], [1]], [x1], name="fold")
    chk = check_drift_observability(F, (2,), Box([-1.0, -1.0], [1.0, 1.0]))
    assert not chk.passed and "changes sign" in chk.evidence
    assert chk.worst_point is not None and abs(chk.worst_point[1]) < 1e-9


def test_local_minimisation_finds_a_thin_singular_set_without_sign_change() -> None:
    # det Q_s = x2² ≥ 0 touches 0 on x2 = 0 (no sign change): σ_min refined by local descent finds it.
    F = _fields(["x1", "x2"], [x2**3 / 3, -x1], [[0], [1]], [x1], name="touch")
    chk = check_drift_observability(F, (2,), Box([-1.0, -1.0], [1.0, 1.0]))
    assert not chk.passed and chk.worst_point is not None and abs(chk.worst_point[1]) < 1e-3


def test_a1_check() -> None:
    isidori = _fields(["x1", "x2", "x3", "x4"], [x1 * x2 - x1**3, x1, -x3, x1**2 + x2], [[0], [2 + 2 * x3], [1], [0]],
                      [x4])
    assert check_a1(isidori, (2,)).passed
    twice = _fields(["x1", "x2"], [-x1, -x2], [[1], [0]], [x1, 2 * x1])
    chk = check_a1(twice, (1, 1))
    assert not chk.passed and "dependent at x = (" in chk.evidence and chk.worst_point is not None


def test_non_involutive_distribution_by_hand() -> None:
    # y = x3, L_f h = x1 + x2 x3, r = 2: Q = [[0, 0, 1], [1, x3, x2]], Δ = range Qᵀ = span{e3, (1, x3, 0)}.
    # By hand: [e3, (1, x3, 0)] = (0, 1, 0) and det[e3; (1, x3, 0); (0, 1, 0)] = 1 ≠ 0, so Δ is not involutive.
    F = _fields(["x1", "x2", "x3"], [-x1, -x2, x1 + x2 * x3], [[1], [0], [0]], [x3], name="twisted")
    assert observation_relative_degree(F).r == (2,)
    assert lie_bracket([0, 0, 1], [1, x3, 0], F.x) == sp.Matrix([0, 1, 0])
    assert sp.Matrix([[0, 0, 1], [1, x3, 0], [0, 1, 0]]).det() != 0
    chk = check_involutive(F, (2,))
    assert not chk.passed and chk.method == "numeric" and "[τ_1, τ_2] leaves span{τ}" in chk.evidence
    assert chk.value is not None and chk.value > 1e-3
    # the columns of Q⁺ span the same distribution as the rows of Q
    Qp = symbolic_pinv(sp.Matrix([[0, 0, 1], [1, x3, x2]]))
    assert _zero(sp.Matrix([[0, 0, 1], [1, x3, x2]]) * Qp - sp.eye(2))


def test_involutive_cases() -> None:
    isidori = _fields(["x1", "x2", "x3", "x4"], [x1 * x2 - x1**3, x1, -x3, x1**2 + x2], [[0], [2 + 2 * x3], [1], [0]],
                      [x4])
    chk = check_involutive(isidori, (2,))
    assert chk.passed and chk.method == "symbolic"
    one = _fields(["x1", "x2", "x3"], [x2, x3, -x1], [[1], [0], [0]], [x1])
    assert check_involutive(one, (1,)).method == "structural"  # rank 1: always involutive


def test_vanishes_on_symbolic_and_numeric() -> None:
    region = Box.unit(3)
    assert vanishes_on(sp.sin(x1) ** 2 + sp.cos(x1) ** 2 - 1, X, region).method == "symbolic"
    t = vanishes_on(x1 * x2 - 0.25, X, region)
    assert not t.zero and t.witness is not None and abs(t.value - (t.witness[0] * t.witness[1] - 0.25)) < 1e-12
    with pytest.raises(InvalidArgumentError, match="dimension"):
        vanishes_on(x1, X, Box.unit(2))
    with pytest.raises(InvalidArgumentError, match="upper"):
        Box([0.0, 1.0], [1.0, 1.0])


def test_vanishes_on_does_not_call_a_nowhere_finite_expression_zero() -> None:
    with pytest.raises(NonFiniteError, match="not finite at any of 64 sampled points"):
        vanishes_on(sp.log(x1 - 5), X, Box.unit(3))
