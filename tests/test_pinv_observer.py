"""Röbenack's Moore–Penrose observer: high-gain vectors, (17), (25), (26), checks, BI gain (24)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from nlobs.errors import AssumptionViolated, DimensionError, InvalidArgumentError, ModelError
from nlobs.geometry import AffineFields, Box, reduced_observability_matrix
from nlobs.observers.base import Observer
from nlobs.observers.pinv import AssumptionWarning, ByrnesIsidoriObserver, PinvObserver
from nlobs.synthesis.pinv_gain import HighGain, companion_error_matrix, high_gain_coefficients, high_gain_roots
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.modelfile import load_model
from nlobs.systems.symbolic import SymbolicModel
from nlobs.workflows.design_pinv import design_pinv_report

MODEL = Path(__file__).resolve().parents[1] / "src" / "nlobs" / "data" / "models" / "isidori-146.toml"
x1, x2, x3, x4 = sp.symbols("x1:5", real=True)
k1, k2 = sp.symbols("k1 k2", real=True)


@pytest.fixture(scope="module")
def model() -> SymbolicModel:
    return load_model(MODEL)  # type: ignore[return-value]


@pytest.fixture(scope="module")
def pinv_obs(model: SymbolicModel) -> PinvObserver:
    return PinvObserver.from_model(model, k=HighGain(3.0))


def _same(a: sp.MatrixBase, b: sp.MatrixBase) -> bool:
    return bool(sp.simplify(sp.Matrix(a) - sp.Matrix(b)) == sp.zeros(*sp.Matrix(a).shape))


def _spot(a: sp.MatrixBase, b: sp.MatrixBase, syms: tuple[sp.Symbol, ...], seed: int = 0) -> float:
    pts = np.random.default_rng(seed).uniform(-3, 3, size=(50, len(syms)))
    fa = compile_matrix(sp.Matrix(a), (syms,))(pts)
    fb = compile_matrix(sp.Matrix(b), (syms,))(pts)
    return float(np.max(np.abs(fa - fb)))


# ------------------------------------------------------------------ high gain (10)
@pytest.mark.parametrize("placement", ["powers", "multiple"])
@pytest.mark.parametrize("r", [1, 2, 3, 5])
def test_high_gain_places_the_roots_of_10(r: int, placement: str) -> None:
    theta = 1.7
    k = high_gain_coefficients(r, theta, placement)  # type: ignore[arg-type]
    eig = np.sort(np.linalg.eigvals(companion_error_matrix(k)).real)
    want = np.sort(high_gain_roots(r, theta, placement))  # type: ignore[arg-type]
    # a multiple root of multiplicity r moves by ~ eps^(1/r) under rounding
    np.testing.assert_allclose(eig, want, rtol=1e-6 if placement == "powers" else 1e-2)
    np.testing.assert_allclose(np.poly(want)[1:], k, rtol=1e-12)
    # (10): det(λI − (A − k cᵀ)) = λ^r + k1 λ^{r−1} + … + kr
    np.testing.assert_allclose(np.poly(companion_error_matrix(k))[1:], k, rtol=1e-10)


def test_high_gain_closed_forms() -> None:
    np.testing.assert_allclose(high_gain_coefficients(3, 2.0, "multiple"), [6.0, 12.0, 8.0])  # C(3,i) θ^i
    np.testing.assert_allclose(high_gain_coefficients(2, 2.0, "powers"), [6.0, 8.0])  # (λ+2)(λ+4)
    np.testing.assert_allclose(high_gain_coefficients(3, 2.0, "powers"), [14.0, 56.0, 64.0])  # (λ+2)(λ+4)(λ+8)
    assert math.isclose(high_gain_coefficients(4, 3.0, "powers")[-1], 3.0 ** (1 + 2 + 3 + 4))
    np.testing.assert_allclose(HighGain(2.0).vector([2, 1]), [6.0, 8.0, 2.0])  # one block per output


def test_high_gain_rejects_bad_arguments() -> None:
    with pytest.raises(InvalidArgumentError, match="placement"):
        HighGain(2.0, "random")  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="theta"):
        HighGain(-1.0)
    with pytest.raises(InvalidArgumentError, match="positive integer"):
        high_gain_coefficients(0, 2.0)


# ------------------------------------------------------------------ (17), (25), (26)
def test_pinv_observer_reproduces_25_and_26(pinv_obs: PinvObserver) -> None:
    assert isinstance(pinv_obs, Observer)
    assert pinv_obs.r == (2,)
    q25 = sp.Matrix([[0, 2 * x1 / (4 * x1**2 + 1)], [0, 1 / (4 * x1**2 + 1)], [0, 0], [1, 0]])
    l26 = sp.Matrix([2 * k2 * x1 / (4 * x1**2 + 1), k2 / (4 * x1**2 + 1), 0, k1])
    assert _same(pinv_obs.Qp, q25)
    assert _same(pinv_obs.gain_symbolic, l26)
    assert _spot(pinv_obs.gain_symbolic.xreplace({k1: 2, k2: 5}), l26.xreplace({k1: 2, k2: 5}), (x1, x2, x3, x4)) < 1e-12
    np.testing.assert_allclose(pinv_obs.k_vector, [12.0, 27.0])  # roots −3, −9
    assert all(c.passed for c in pinv_obs.checks)


def test_symbolic_and_numeric_pinv_agree(model: SymbolicModel, pinv_obs: PinvObserver) -> None:
    num = PinvObserver.from_model(model, k=HighGain(3.0), pinv="numeric")
    X = np.random.default_rng(3).normal(scale=2.0, size=(40, 4))
    u, y = np.random.default_rng(4).normal(size=(40, 1)), np.random.default_rng(5).normal(size=(40, 1))
    np.testing.assert_allclose(num.gain_at(X), pinv_obs.gain_at(X), atol=1e-12, rtol=1e-12)
    np.testing.assert_allclose(num.rhs(0.0, X, u, y), pinv_obs.rhs(0.0, X, u, y), atol=1e-10, rtol=1e-12)
    # and lstsq agrees with both: l = argmin ‖Q l − k‖ of least norm
    Qf = compile_matrix(pinv_obs.Q, (pinv_obs.fields.x,))(X)
    l_ls = np.stack([np.linalg.lstsq(Q, pinv_obs.k_vector, rcond=None)[0] for Q in Qf])
    np.testing.assert_allclose(l_ls, pinv_obs.gain_at(X)[..., 0], atol=1e-10)


def test_rhs_is_observer_7(pinv_obs: PinvObserver, model: SymbolicModel) -> None:
    plant = model.compile()
    X = np.random.default_rng(6).normal(size=(10, 4))
    u = np.random.default_rng(7).normal(size=(10, 1))
    y = np.random.default_rng(8).normal(size=(10, 1))
    want = plant.rhs(0.0, X, u) + (pinv_obs.gain_at(X) @ (y - plant.output(0.0, X, u))[..., None])[..., 0]
    np.testing.assert_allclose(pinv_obs.rhs(0.0, X, u, y), want, atol=1e-12)
    np.testing.assert_array_equal(pinv_obs.init([1.0, 2, 3, 4]), [1.0, 2, 3, 4])
    # exact measurement at the true state: the observer copies the plant
    np.testing.assert_allclose(pinv_obs.rhs(0.0, X, u, plant.output(0.0, X, u)), plant.rhs(0.0, X, u), atol=1e-12)


def test_k_of_wrong_length_is_refused(model: SymbolicModel) -> None:
    with pytest.raises(DimensionError, match=r"`k`: expected 2 entries"):
        PinvObserver.from_model(model, k=[1.0, 2.0, 3.0])


# ------------------------------------------------------------------ refusals (A1, A5) and warnings
def test_undefined_relative_degree_is_refused() -> None:
    # the input never reaches y = x1 (x3 is driven by u alone)
    m = SymbolicModel.input_affine(["x1", "x2", "x3"], ["u"], ["y"], f=[x2, -x1, -x3], g=[[0], [0], [1]], h=[x1],
                                   name="uncoupled")
    with pytest.raises(AssumptionViolated, match=r"uncoupled: A1 fails: the observation relative degree of output 'y' is not defined on \[-1, 1\]"):
        PinvObserver.from_model(m)


def test_dependent_rows_of_Q_are_refused_with_the_point() -> None:
    m = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y1", "y2"], f=[-x1, -x2], g=[[1], [0]], h=[x1, 2 * x1],
                                   name="twice")
    with pytest.raises(AssumptionViolated, match=r"twice: A1 fails on .*dependent at x = \("):
        PinvObserver.from_model(m)


def _non_involutive() -> SymbolicModel:
    # y = x3, L_f h = x1 + x2 x3: Δ = span{e3, (1, x3, 0)} and [e3, (1, x3, 0)] = e2 ∉ Δ
    return SymbolicModel.input_affine(["x1", "x2", "x3"], ["u"], ["y"], f=[-x1, -x2, x1 + x2 * x3],
                                      g=[[1], [0], [0]], h=[x3], name="twisted")


def test_non_involutive_distribution_is_refused_or_warned() -> None:
    m = _non_involutive()
    with pytest.raises(AssumptionViolated, match=r"twisted: A5 fails .*\[τ_1, τ_2\] leaves span\{τ\} at x = \("):
        PinvObserver.from_model(m)
    with pytest.warns(AssumptionWarning, match="Theorem 4.1 does not apply"):
        obs = PinvObserver.from_model(m, require_a5=False)
    assert not obs.checks[1].passed and obs.checks[1].worst_point is not None
    rep = design_pinv_report(m)
    assert rep.to_dict()["involutive"] is False and not rep.usable
    assert "FAIL A5" in rep.summary()


def test_non_input_affine_model_is_refused() -> None:
    u = sp.Symbol("u", real=True)
    m = SymbolicModel.general(["x1", "x2"], ["u"], ["y"], rhs=[x2, -x1 + u**2], h=[x1], name="squared")
    with pytest.raises(ModelError, match="squared: the method needs an input-affine model"):
        PinvObserver.from_model(m)


# ------------------------------------------------------------------ MIMO
def test_mimo_gain_inverts_Q_blockwise() -> None:
    # y1 = x1 (r1 = 2), y2 = x4 (r2 = 1), n = 4
    m = SymbolicModel.input_affine(["x1", "x2", "x3", "x4"], ["u1", "u2"], ["y1", "y2"],
                                   f=[x2 + x1**2, -x1 + x3**2, -x3, x1 - x4], g=[[0, 0], [1, 0], [0, 1], [0, 1]],
                                   h=[x1, x4], name="mimo")
    obs = PinvObserver.from_model(m, k=HighGain(2.0, "multiple"))
    assert obs.r == (2, 1)
    np.testing.assert_allclose(obs.k_vector, [4.0, 4.0, 2.0])
    F = AffineFields.from_model(m)
    Q = compile_matrix(reduced_observability_matrix(F, obs.r), (F.x,))
    X = np.random.default_rng(9).normal(size=(20, 4))
    K = np.array([[4.0, 0.0], [4.0, 0.0], [0.0, 2.0]])
    np.testing.assert_allclose(Q(X) @ obs.gain_at(X), np.broadcast_to(K, (20, 3, 2)), atol=1e-12)  # Q Q⁺ K = K


# ------------------------------------------------------------------ Byrnes–Isidori gain (15)/(24)
def test_byrnes_isidori_gain_of_example_21(model: SymbolicModel) -> None:
    bi = ByrnesIsidoriObserver.from_model(model, [x2 - 2 * x3 - x3**2, x1], k=HighGain(3.0))
    assert isinstance(bi, Observer)
    assert sp.simplify(bi.det - 2 * (x3 + 1)) == 0 or sp.simplify(bi.det + 2 * (x3 + 1)) == 0
    assert bi.singular_set == ("x3 = -1",)
    derived = sp.Matrix([0, k2, k2 / (2 + 2 * x3), k1])  # (Φ')⁻¹ [k; 0] with Φ' of (23)
    printed = sp.Matrix([0, k2, k2, (2 + 2 * x3) / k1])  # (24) as printed
    assert _same(bi.gain_symbolic, derived)
    assert not _same(bi.gain_symbolic, printed)
    assert bi.checks[1].passed  # (5): L_g φ ≡ 0
    assert not bi.checks[2].passed and "x3 = -1" in bi.checks[2].evidence
    g = bi.gain_at(np.array([[0.3, 0.1, -1.0, 0.0], [0.3, 0.1, -1.0 + 1e-6, 0.0]]))
    assert not np.isfinite(g[0, 2, 0]) and abs(g[1, 2, 0]) > 1e6
    # (26) has no pole: 4 x1² + 1 ≥ 1
    pinv = PinvObserver.from_model(model, k=HighGain(3.0))
    assert np.all(np.isfinite(pinv.gain_at(np.array([[0.3, 0.1, -1.0, 0.0]]))))


def test_byrnes_isidori_with_the_texts_phi4_is_refused(model: SymbolicModel) -> None:
    # the text says φ4 = x4 (= h): Φ' would have two equal rows
    with pytest.raises(AssumptionViolated, match="det Φ' ≡ 0"):
        ByrnesIsidoriObserver.from_model(model, [x2 - 2 * x3 - x3**2, x4])


def test_byrnes_isidori_warns_when_5_fails(model: SymbolicModel) -> None:
    with pytest.warns(AssumptionWarning, match="not the Byrnes–Isidori form"):
        bi = ByrnesIsidoriObserver.from_model(model, [x3, x1])
    assert not bi.checks[1].passed


def test_byrnes_isidori_rejects_text_and_stray_symbols(model: SymbolicModel) -> None:
    with pytest.raises(InvalidArgumentError, match="phi"):
        ByrnesIsidoriObserver.from_model(model, ["x3", "x1"])  # type: ignore[list-item]
    with pytest.raises(ModelError, match="not states: z"):
        ByrnesIsidoriObserver.from_model(model, [x3, sp.Symbol("z")])
    with pytest.raises(DimensionError, match="expected n − Σ r_j = 2"):
        ByrnesIsidoriObserver.from_model(model, [x3])


# ------------------------------------------------------------------ report for the CLI
def test_design_report(model: SymbolicModel) -> None:
    rep = design_pinv_report(model, theta=3.0, placement="multiple")
    d = rep.to_dict()
    assert d["observation_relative_degree"] == [2] and d["observability_rank"] == 3 and d["involutive"] is True
    assert d["k"] == [6.0, 9.0] and d["roots"] == pytest.approx([-3.0, -3.0], abs=1e-6)
    assert d["pinv_gain"][3] == ["k1"] and d["pinv_gain"][2] == ["0"]
    assert rep.input_gains == ("2*(x3 + 1)",) and rep.usable
    txt = rep.summary()
    assert "r = 2" in txt and "2*k2*x1/(4*x1**2 + 1)" in txt
    rep2 = design_pinv_report(model, k=[1.0, 2.0], region=Box.around(np.zeros(4), 2.0))
    assert rep2.k == (1.0, 2.0) and rep2.theta is None


def test_full_relative_degree_gives_the_inverse_jacobian() -> None:
    # r = n (Sec. 4: Q = Φ', Q⁺ = (Φ')⁻¹, the gain of [9, 10, 13]); A5 holds structurally
    m = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2 + x1**2, -x1], g=[[0], [1]], h=[x1], name="chain")
    obs = PinvObserver.from_model(m, k=HighGain(2.0))
    assert obs.r == (2,) and obs.checks[1].method == "structural"
    Q = sp.Matrix([[1, 0], [2 * x1, 1]])
    assert _same(obs.Qp, Q.inv())
    np.testing.assert_allclose(obs.gain_at([[0.5, 0.0]])[0, :, 0], [6.0, 8.0 - 2 * 0.5 * 6.0])
