"""Khajenejad & Yong model data and function classes: validation, sampled Lipschitz estimates, class checks."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from nlobs.errors import DimensionError, InvalidArgumentError, ModelError, NonFiniteError
from nlobs.systems.discrete_ui import (
    LPV,
    DiscreteUISystem,
    Lipschitz,
    QCStar,
    QuadraticConstraint,
    check_function_class,
    estimate_lipschitz,
    qcstar_from_bounded_split,
)
from nlobs.systems.symbolic import SymbolicModel
from nlobs.systems.timebase import Continuous, Discrete

A2 = np.array([[0.5, 0.1], [0.0, 0.3]])
G2 = np.array([[1.0], [0.0]])
C2 = np.array([[1.0, 0.0], [0.0, 1.0]])
T1 = Discrete(1.0)


def test_noise_bounds_are_validated() -> None:
    with pytest.raises(InvalidArgumentError, match="eta_w"):
        DiscreteUISystem(A2, G2, C2, eta_w=-0.1, time=T1)
    with pytest.raises(NonFiniteError, match="eta_v"):
        DiscreteUISystem(A2, G2, C2, eta_v=float("inf"), time=T1)
    with pytest.raises(NonFiniteError, match="eta_v"):
        DiscreteUISystem(A2, G2, C2, eta_v=float("nan"), time=T1)
    with pytest.raises(InvalidArgumentError, match="delta0"):
        DiscreteUISystem(A2, G2, C2, delta0=-1.0, time=T1)


def test_shapes_and_time_base_are_validated() -> None:
    with pytest.raises(TypeError, match="time"):
        DiscreteUISystem(A2, G2, C2)  # type: ignore[call-arg]  # the sampling period is never defaulted
    with pytest.raises(DimensionError, match="G"):
        DiscreteUISystem(A2, np.ones((3, 1)), C2, time=T1)
    with pytest.raises(DimensionError, match="H"):
        DiscreteUISystem(A2, G2, C2, np.ones((2, 2)), time=T1)
    with pytest.raises(DimensionError, match="phi"):
        DiscreteUISystem(A2, G2, C2, phi=lambda x: x[..., :1], time=T1)
    with pytest.raises(DimensionError, match="function_class"):
        DiscreteUISystem(A2, G2, C2, function_class=Lipschitz(1.0, 3), time=T1)
    with pytest.raises(ModelError, match="Discrete"):
        DiscreteUISystem(A2, G2, C2, time=Continuous())  # type: ignore[arg-type]


def test_class_constructors_validate() -> None:
    with pytest.raises(InvalidArgumentError, match="gamma"):
        QCStar(np.eye(2), 0.5)
    with pytest.raises(InvalidArgumentError, match="L"):
        Lipschitz(-1.0, 2)
    with pytest.raises(DimensionError, match="even"):
        QuadraticConstraint(np.eye(3))
    with pytest.raises(DimensionError, match="constituents"):
        LPV((np.eye(2), np.eye(3)))


def test_multipliers_match_the_paper() -> None:
    M, g = Lipschitz(2.0, 2).multiplier()  # (20)
    np.testing.assert_array_equal(M, np.diag([-1, -1, 4, 4.0]))
    assert g == 0.0
    Aa = np.array([[1.0, 2.0], [0.0, 1.0]])
    M, g = QCStar(Aa, -1.0).multiplier()  # (21)
    np.testing.assert_allclose(M, np.block([[-np.eye(2), Aa], [Aa.T, -Aa.T @ Aa]]))
    assert qcstar_from_bounded_split(Aa, 0.5).gamma == pytest.approx(-1.0)  # Lemma 2.14: -(2r)^2
    assert LPV((np.diag([3.0, 1.0]), np.eye(2))).sigma == pytest.approx(3.0)  # Prop. 2.16


def test_lipschitz_estimate_is_a_lower_estimate_close_to_the_true_constant() -> None:
    def phi(x: np.ndarray) -> np.ndarray:
        return 2.0 * np.sin(x)

    est = estimate_lipschitz(phi, [-1, -1], [1, 1], n_pairs=4000, seed=3)
    assert est.is_estimate
    assert 1.98 <= est.value <= 2.0 + 1e-12  # sup |2 cos| = 2, attained at 0
    K = np.array([[1.0, 2.0], [-0.5, 0.3]])
    est = estimate_lipschitz(lambda x: x @ K.T, [-1, -1], [1, 1], n_pairs=20000, seed=1)
    nK = np.linalg.norm(K, 2)
    assert est.value <= nK + 1e-12
    assert est.value >= 0.99 * nK
    # the reported pair attains the reported ratio
    r = np.linalg.norm((est.x2 - est.x1) @ K.T) / np.linalg.norm(est.x2 - est.x1)
    assert r == pytest.approx(est.value, rel=1e-12)


def test_check_function_class_reports_a_violating_pair() -> None:
    def phi(x: np.ndarray) -> np.ndarray:
        return 0.5 * np.sin(x)

    assert check_function_class(phi, Lipschitz(0.5, 2), [-2, -2], [2, 2], n_pairs=4000).passed
    bad = check_function_class(phi, Lipschitz(0.4, 2), [-2, -2], [2, 2], n_pairs=4000)
    assert not bad.passed
    x1, x2 = bad.values["x1"], bad.values["x2"]
    dphi = phi(x2) - phi(x1)
    assert np.linalg.norm(dphi) > 0.4 * np.linalg.norm(x2 - x1)
    assert "VIOLATED" in bad.evidence
    # Class II with the paper's γ = 0 for an affine-plus-bounded map is violated; Lemma 2.14's γ holds
    def g(x: np.ndarray) -> np.ndarray:
        return np.stack([np.zeros(x.shape[:-1]), 0.1 * np.sin(x[..., 0])], axis=-1)

    assert not check_function_class(g, QCStar(np.zeros((2, 2)), 0.0), [-3, -3], [3, 3]).passed
    assert check_function_class(g, qcstar_from_bounded_split(np.zeros((2, 2)), 0.1), [-3, -3], [3, 3]).passed


def test_increment_bounds_hold_on_samples() -> None:
    rng = np.random.default_rng(0)
    Acl = rng.standard_normal((2, 2))
    Bcl = rng.standard_normal((2, 2))
    phi = lambda x: 0.1 * np.sin(x[..., ::-1]) + x @ np.array([[0.2, 0.0], [0.1, 0.0]]).T  # noqa: E731
    classes = [Lipschitz(0.1 + np.linalg.norm([[0.2, 0.0], [0.1, 0.0]], 2), 2),
               qcstar_from_bounded_split(np.array([[0.2, 0.0], [0.1, 0.0]]), 0.1 * np.sqrt(2)),
               QuadraticConstraint(Lipschitz(0.33, 2).multiplier()[0])]
    x1, x2 = rng.uniform(-3, 3, (5000, 2)), rng.uniform(-3, 3, (5000, 2))
    dx, dp = x2 - x1, phi(x2) - phi(x1)
    lhs = np.linalg.norm(dx @ Acl.T + dp @ Bcl.T, axis=-1)
    for fc in classes:
        assert check_function_class(phi, fc, [-3, -3], [3, 3], n_pairs=4000).passed
        th, r = fc.increment_bound(Acl, Bcl)
        assert np.all(lhs <= th * np.linalg.norm(dx, axis=-1) + r + 1e-12)


def test_from_symbolic_compiles_phi_once() -> None:
    x1, x2 = sp.symbols("x1 x2", real=True)
    model = SymbolicModel.input_affine(["x1", "x2"], ["u1"], ["y1"], [0.5 * x1 + x2, -sp.tanh(x1)],
                                       [[1.0], [0.0]], [x1], time=Discrete(0.1))
    sysm = DiscreteUISystem.from_symbolic(model, G=[[1.0], [0.5]], C=[[0.0, 1.0]], eta_w=0.1)
    np.testing.assert_allclose(sysm.A, [[0.5, 1.0], [-1.0, 0.0]])  # Jacobian at 0
    x = np.random.default_rng(1).normal(size=(7, 2))
    np.testing.assert_allclose(sysm.f(x), np.stack([0.5 * x[:, 0] + x[:, 1], -np.tanh(x[:, 0])], -1), atol=1e-14)
    np.testing.assert_allclose(sysm.B, [[1.0], [0.0]])
    with pytest.raises(ModelError, match="Discrete"):
        DiscreteUISystem.from_symbolic(SymbolicModel.input_affine(["x1"], [], ["y"], [x1], None, [x1]),
                                       G=[[1.0]], C=[[1.0]])


def test_simulate_matches_a_hand_written_loop() -> None:
    sysm = DiscreteUISystem(A2, G2, C2, [[0.2], [0.0]], phi=lambda x: 0.1 * np.sin(x),
                            function_class=Lipschitz(0.1, 2), time=T1)
    rng = np.random.default_rng(2)
    B, K = 3, 5
    x0, d = rng.normal(size=(B, 2)), rng.normal(size=(B, K + 1, 1))
    w, v = rng.normal(size=(B, K, 2)), rng.normal(size=(B, K + 1, 2))
    x, y = sysm.simulate(x0, d, w, v)
    xi = x0[1]
    for k in range(K + 1):
        np.testing.assert_allclose(x[1, k], xi, atol=1e-14)
        np.testing.assert_allclose(y[1, k], C2 @ xi + np.array([0.2, 0.0]) * d[1, k, 0] + v[1, k], atol=1e-14)
        if k < K:
            xi = A2 @ xi + 0.1 * np.sin(xi) + G2[:, 0] * d[1, k, 0] + w[1, k]
