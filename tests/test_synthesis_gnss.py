"""Grip, Saberi & Johansen, GNSS/INS per-axis example: LMIs (14), (15).

Independent sources: numbers measured independently of this code, numpy
eigenvalues, and ``control.linfnorm`` as a second H∞ oracle.
"""

from __future__ import annotations

import control
import numpy as np
import pytest

from nlobs.errors import DesignUnbounded
from nlobs.synthesis import (
    CertificateStatus,
    CheckKind,
    GainBound,
    Objective,
    Solver,
    design_observer_gain,
    extended_system,
    verify_observer_gain,
)

# rows: p, v, z (= aⁿ); columns: position, velocity measurement (Grip, Saberi & Johansen, Sec. 5)
K_PAPER = np.array([[128.9, 17.5], [15.7, 2.4], [1.3, 0.2]])


@pytest.fixture(scope="module")
def axis():
    # Σ2 per axis: double integrator (p, v) driven by z = aⁿ, p and v measured
    return extended_system([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2), np.zeros((2, 1)))


def _linfnorm(A, B):
    """‖(sI − A)⁻¹ B‖∞ with python-control (only for Hurwitz A)."""
    assert np.max(np.linalg.eigvals(A).real) < 0
    n = A.shape[0]
    g, _ = control.linfnorm(control.ss(A, B, np.eye(n), np.zeros((n, B.shape[1]))))
    return float(g)


def test_extended_system_matches_8c(axis):
    np.testing.assert_array_equal(axis.A, [[0, 1, 0], [0, 0, 1], [0, 0, 0]])
    np.testing.assert_array_equal(axis.Bd, [[0], [0], [1]])
    np.testing.assert_array_equal(axis.C, [[1, 0, 0], [0, 1, 0]])
    Ae, Bde, Ce = axis  # a NamedTuple unpacks
    assert Ae.shape == (3, 3) and Bde.shape == (3, 1) and Ce.shape == (2, 3)


def test_paper_gain_verifies_with_facts_numbers(axis):
    cert = verify_observer_gain(axis.A, axis.C, axis.Bd, K_PAPER, gamma=50.0, gamma_n=1.01)
    assert cert.status is CertificateStatus.VERIFIED
    # measured independently: ‖H‖∞ ≈ 32.18 < 50, ‖G‖∞ ≈ 1.002 (N = I), poles ≈ −130.9, −0.257, −0.129
    assert cert.hinf_H == pytest.approx(32.18, abs=0.005)
    assert cert.hinf_G == pytest.approx(1.002, abs=0.0005)
    poles = np.sort(np.linalg.eigvals(axis.A - K_PAPER @ axis.C).real)
    assert np.all(np.abs(poles - [-130.9, -0.257, -0.129]) <= [0.05, 0.0005, 0.0005])
    np.testing.assert_allclose(np.sort(cert.eigenvalues.real), poles, rtol=1e-9)
    # second oracle for both norms
    Acl = axis.A - K_PAPER @ axis.C
    assert cert.hinf_H == pytest.approx(_linfnorm(Acl, axis.Bd), rel=1e-6)
    assert cert.hinf_G == pytest.approx(_linfnorm(Acl, -K_PAPER), rel=1e-6)
    # the LMIs hold with the returned P (re-evaluated in the test, independently)
    P = cert.P
    assert np.linalg.eigvalsh(P)[0] > 0
    X = P @ K_PAPER
    F11 = P @ axis.A + axis.A.T @ P - X @ axis.C - axis.C.T @ X.T + np.eye(3)
    F14 = np.block([[F11, P @ axis.Bd], [axis.Bd.T @ P, -(50.0**2) * np.eye(1)]])
    F15 = np.block([[F11, -X], [-X.T, -(1.01**2) * np.eye(2)]])
    assert np.linalg.eigvalsh(F14)[-1] < 0 and np.linalg.eigvalsh(F15)[-1] < 0
    assert {c.name for c in cert.lmi_checks} == {"LMI (14)", "LMI (15)"}


def test_paper_gain_does_not_meet_gamma_n_below_its_norm(axis):
    # ‖G‖∞ ≈ 1.00208 for the paper's gain: γn = 1.0019 must be refused
    cert = verify_observer_gain(axis.A, axis.C, axis.Bd, K_PAPER, gamma=50.0, gamma_n=1.0019, strict=False)
    assert cert.status is CertificateStatus.FAILED
    assert any(c.name == "‖G‖∞ ≤ γn" for c in cert.failed_checks)


def test_central_design_near_paper_gain(axis):
    # the SDP's analytic centre (method="auto" would take the Riccati path: a different, smaller gain)
    cert = design_observer_gain(axis.A, axis.C, axis.Bd, gamma=50.0, gamma_n=1.0019, objective=Objective.CENTRAL,
                                method="sdp")
    assert cert.verified and cert.solver is Solver.CLARABEL
    K = cert.gain
    assert np.all(np.isfinite(K)) and cert.gain_norm < 200
    # measured: [[126.61, 16.14], [15.56, 2.417], [1.156, 0.191]]; worst entry 11 % from the paper's (K_zp)
    np.testing.assert_allclose(K, [[126.61, 16.14], [15.56, 2.417], [1.156, 0.191]], rtol=2e-3)
    assert np.all(np.abs(K - K_PAPER) <= 0.15 * np.abs(K_PAPER))
    Acl = axis.A - K @ axis.C
    assert np.max(np.linalg.eigvals(Acl).real) < 0
    hH, hG = _linfnorm(Acl, axis.Bd), _linfnorm(Acl, -K)
    assert hH == pytest.approx(cert.hinf_H, rel=1e-6) and hH < 50.0
    assert hG == pytest.approx(cert.hinf_G, rel=1e-6) and hG <= 1.0019
    assert all(c.passed for c in cert.checks)
    assert cert.hinf_ratio < 1 and cert.noise_ratio <= 1


def test_min_gamma_n_without_bound_is_unbounded(axis):
    with pytest.raises(DesignUnbounded, match=r"no minimum.*‖K‖₂.*GainBound"):
        design_observer_gain(axis.A, axis.C, axis.Bd, gamma=50.0, objective=Objective.MIN_GAMMA_N)


def test_min_gamma_without_bound_is_unbounded(axis):
    # minimum phase: γ* = 0 (Theorem 2) is only approached as K → ∞
    with pytest.raises(DesignUnbounded, match="no minimum|ill-posed"):
        design_observer_gain(axis.A, axis.C, axis.Bd, objective="min_gamma")


@pytest.mark.parametrize("kappa", [130.0, 1000.0])
def test_min_gamma_n_with_gain_bound(axis, kappa):
    cert = design_observer_gain(
        axis.A, axis.C, axis.Bd, gamma=50.0, objective=Objective.MIN_GAMMA_N, gain_bound=GainBound(kappa)
    )
    assert cert.verified
    assert np.linalg.norm(cert.gain, 2) <= kappa
    assert np.linalg.norm(cert.gain, 2) >= 0.99 * kappa  # the bound is active (γn → 1 only as K → ∞)
    assert 1.0 < cert.gamma_n < 1.0019
    Acl = axis.A - cert.gain @ axis.C
    assert _linfnorm(Acl, -cert.gain) <= cert.gamma_n * (1 + 1e-9)
    assert _linfnorm(Acl, axis.Bd) < 50.0
    assert any(c.kind is CheckKind.GAIN and c.passed for c in cert.checks)


def test_gain_bound_as_float_and_central(axis):
    cert = design_observer_gain(axis.A, axis.C, axis.Bd, gamma=50.0, gain_bound=50.0)
    assert cert.verified and cert.gain_norm <= 50.0
    Acl = axis.A - cert.gain @ axis.C
    assert _linfnorm(Acl, axis.Bd) == pytest.approx(cert.hinf_H, rel=1e-6)


def test_scs_answer_is_reverified(axis):
    # SCS on a comfortable γn: verified after the independent checks (the SDP path: auto takes the Riccati one)
    cert = design_observer_gain(axis.A, axis.C, axis.Bd, gamma=50.0, gamma_n=1.05, solver="scs", method="sdp")
    assert cert.verified and cert.solver is Solver.SCS
    clar = design_observer_gain(axis.A, axis.C, axis.Bd, gamma=50.0, gamma_n=1.05, method="sdp")
    np.testing.assert_allclose(cert.gain, clar.gain, rtol=0.1, atol=0.05)
