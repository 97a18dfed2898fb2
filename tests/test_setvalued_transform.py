"""Khajenejad & Yong Appendix A.1 transformation, Lemma 5.1 gains and the structural checks."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import AssumptionViolated
from nlobs.linear.transform_ui import require_structure, structural_check, ui_transform

RNG = np.random.default_rng(0)


def _check_common(tr, G, C, H) -> None:  # type: ignore[no-untyped-def]
    l, p = H.shape
    U = np.hstack([tr.U1, tr.U2])
    V = np.hstack([tr.V1, tr.V2])
    np.testing.assert_allclose(U.T @ U, np.eye(l), atol=1e-12)
    np.testing.assert_allclose(V.T @ V, np.eye(p), atol=1e-12)
    np.testing.assert_allclose(tr.U1 @ tr.Sigma @ tr.V1.T, H, atol=1e-12)  # H = U1 Σ V1ᵀ
    np.testing.assert_allclose(tr.M1 @ tr.Sigma, np.eye(tr.p_H), atol=1e-12)  # M1 Σ = I
    np.testing.assert_allclose(tr.M2 @ tr.C2 @ tr.G2, np.eye(p - tr.p_H), atol=1e-10)  # M2 C2 G2 = I
    np.testing.assert_allclose(tr.T2 @ H, 0, atol=1e-12)  # z2 free of d
    np.testing.assert_allclose(tr.Phi @ tr.G2, 0, atol=1e-10)  # Φ annihilates G2


def test_no_feedthrough_pH_0() -> None:
    G, C = RNG.normal(size=(4, 2)), RNG.normal(size=(3, 4))
    H = np.zeros((3, 2))
    tr = ui_transform(G, C, H)
    assert tr.p_H == 0 and tr.U1.shape == (3, 0) and tr.Sigma.shape == (0, 0)
    _check_common(tr, G, C, H)
    np.testing.assert_allclose(tr.Psi, 0)


def test_full_feedthrough_pH_equals_l() -> None:
    G, C = RNG.normal(size=(3, 2)), RNG.normal(size=(2, 3))
    H = RNG.normal(size=(2, 2))
    tr = ui_transform(G, C, H)
    assert tr.p_H == 2 and tr.U2.shape == (2, 0) and tr.C2.shape == (0, 3)
    _check_common(tr, G, C, H)
    np.testing.assert_allclose(tr.Phi, np.eye(3))
    np.testing.assert_allclose(tr.Psi, G @ np.linalg.solve(H, C), atol=1e-10)  # G1 M1 C1 = G H⁻¹ C


def test_partial_feedthrough() -> None:
    G, C = RNG.normal(size=(4, 2)), RNG.normal(size=(3, 4))
    H = np.outer(RNG.normal(size=3), RNG.normal(size=2))  # rank 1
    tr = ui_transform(G, C, H)
    assert tr.p_H == 1
    _check_common(tr, G, C, H)


def test_lemma_5_1_rank_condition_is_checked() -> None:
    C = np.array([[1.0, 0.0, 0.0]])
    G = np.array([[0.0], [1.0], [0.0]])  # C G = 0: d enters a state the output does not see one step later
    with pytest.raises(AssumptionViolated, match="Lemma 5.1: rank\\(C2 G2\\) = 0") as info:
        ui_transform(G, C)
    assert info.value.item == "lemma_5_1_rank"
    with pytest.raises(AssumptionViolated, match="l >= p"):
        ui_transform(np.ones((3, 2)), C)


def _example_62() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return np.array([[-0.42, 1.0], [-0.6, 0.0]]), np.array([[1.0], [-0.65]]), np.array([[0.0, 1.0]])


def test_example_62_as_printed_admits_no_stable_observer() -> None:
    A, G, C = _example_62()
    chk = structural_check(A, G, C)
    assert not chk.exists and chk.strongly_detectable == (False,)
    # closed form of the invariant zero: y = x2 ≡ 0 forces d = -0.6 x1 / 0.65, so x1⁺ = -(0.42 + 0.6/0.65) x1
    z = -(0.42 + 0.6 / 0.65)
    bad = chk.unstable_error_modes[0]
    assert bad.size == 1 and bad[0] == pytest.approx(z, abs=1e-9)
    # independent check: the Rosenbrock matrix drops rank exactly there
    R = np.block([[z * np.eye(2) - A, -G], [C, np.zeros((1, 1))]])
    assert np.linalg.matrix_rank(R, tol=1e-9) < 3
    with pytest.raises(AssumptionViolated, match="no stable observer of the structure") as info:
        require_structure(chk)
    assert "-1.34308" in info.value.evidence


def test_example_61_is_strongly_detectable() -> None:
    Ts = 0.01
    A = np.array([[1, Ts, 0, 0], [-48.6 * Ts, 1 - 1.25 * Ts, 48.6 * Ts, 0], [0, 0, 1, Ts], [19.5 * Ts, 0, -19.5 * Ts, 1]])
    G = Ts * np.array([[5.0, 5, 2, 1]]).T
    C = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
    H = Ts * np.array([[1.1, 2.0]]).T
    chk = structural_check(A, G, C, H)
    assert chk.exists and chk.transform.p_H == 1
    require_structure(chk)  # does not raise
