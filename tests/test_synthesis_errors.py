"""Infeasible, ill-posed and invalid synthesis problems, and the certificate's own checks.

Independent sources: the PBH rank test by hand, the interpolation bound at an
RHP invariant zero, numpy eigenvalues and ``control.linfnorm``.
"""

from __future__ import annotations

import dataclasses

import control
import numpy as np
import pytest

from nlobs.errors import (
    CertificateError,
    DesignInfeasible,
    DesignUnbounded,
    DimensionError,
    InvalidArgumentError,
    NonFiniteError,
)
from nlobs.synthesis import (
    CertificateStatus,
    CheckKind,
    GainBound,
    Objective,
    design_observer_gain,
    extended_system,
    verify_observer_gain,
)

AXIS = extended_system([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2))
K_PAPER = np.array([[128.9, 17.5], [15.7, 2.4], [1.3, 0.2]])

# Non-minimum-phase Σ2: C (sI − A)⁻¹ B_z = (1 − s)/(s + 1)², invariant zero at s = 1
A_NMP = np.array([[0.0, 1.0], [-1.0, -2.0]])
BZ_NMP = np.array([[0.0], [1.0]])
C_NMP = np.array([[1.0, -1.0]])
NMP = extended_system(A_NMP, BZ_NMP, C_NMP)


def _interpolation_bound():
    """‖H‖∞ ≥ ‖x0‖/‖u0‖ for every stabilising K, with (1·I − 𝔄) x0 = 𝔅_d u0, ℭ x0 = 0 (zero at s = 1).

    Then (I − 𝔄 + Kℭ) x0 = 𝔅_d u0, i.e. H(1) u0 = x0, and by the maximum modulus
    principle ‖H‖∞ ≥ ‖H(1) u0‖/‖u0‖.
    """
    w0 = np.linalg.solve(np.eye(2) - A_NMP, BZ_NMP[:, 0])  # z-component 1, u0 = d = 1·z
    x0 = np.concatenate([w0, [1.0]])
    assert abs((NMP.C @ x0)[0]) < 1e-12
    np.testing.assert_allclose((np.eye(3) - NMP.A) @ x0, NMP.Bd[:, 0] * 1.0)
    return float(np.linalg.norm(x0))


def test_undetectable_pair_is_reported():
    A = np.diag([1.0, -1.0])
    C = np.array([[0.0, 1.0]])  # the unstable mode x1 is unobservable
    # PBH by hand: rank [λI − A; C] at λ = 1 is 1 < 2
    assert np.linalg.matrix_rank(np.vstack([np.eye(2) - A, C])) == 1
    with pytest.raises(DesignInfeasible, match=r"not detectable.*λ = 1") as ei:
        design_observer_gain(A, C, np.eye(2), gamma=10.0, gain_bound=10.0)
    assert ei.value.constraint == "detectability"


def test_gamma_below_infimum_names_lmi_14_and_smallest_gamma():
    lower = _interpolation_bound()  # ≈ 1.0607
    with pytest.raises(DesignInfeasible, match=r"LMI \(14\).*γ = 0.5.*smallest achievable γ is ≈ 1\.\d+") as ei:
        design_observer_gain(NMP.A, NMP.C, NMP.Bd, gamma=0.5, gamma_n=200.0)
    assert ei.value.constraint == "LMI (14)"
    gmin = 0.5 + ei.value.violation
    assert gmin >= lower * (1 - 1e-6)  # the LMI infimum respects the interpolation bound
    assert gmin < 1.2  # measured ≈ 1.098
    # and a γ above it is achievable, cross-checked with python-control
    cert = design_observer_gain(NMP.A, NMP.C, NMP.Bd, gamma=1.2, gamma_n=200.0)
    Acl = NMP.A - cert.gain @ NMP.C
    assert np.max(np.linalg.eigvals(Acl).real) < 0
    g, _ = control.linfnorm(control.ss(Acl, NMP.Bd, np.eye(3), np.zeros((3, 1))))
    assert lower <= float(g) < 1.2
    assert float(g) == pytest.approx(cert.hinf_H, rel=1e-6)


def test_gamma_n_too_small_names_lmi_15():
    with pytest.raises(DesignInfeasible, match=r"LMI \(15\).*γn = 0.9.*smallest achievable γn is ≈ 1") as ei:
        design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gamma_n=0.9)
    assert ei.value.constraint == "LMI (15)"
    assert ei.value.violation == pytest.approx(0.1, abs=1e-3)  # ‖G‖∞ ≥ 1 for every stabilising K


def test_min_gamma_nonminimum_phase_not_returned_silently():
    # the infimum ≈ 1.098 is chased with gains ~1e6 and inaccurate solves: refuse
    with pytest.raises(DesignUnbounded, match=r"minimising γ².*‖K‖₂.*GainBound"):
        design_observer_gain(NMP.A, NMP.C, NMP.Bd, objective=Objective.MIN_GAMMA)


def test_non_hurwitz_gain_rejected():
    with pytest.raises(CertificateError, match=r"Hurwitz.*FAILED by 131"):
        verify_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, -K_PAPER, gamma=50.0)
    cert = verify_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, -K_PAPER, gamma=50.0, strict=False)
    assert cert.status is CertificateStatus.FAILED and cert.P is None
    assert cert.hinf_H == np.inf
    kinds = {c.kind for c in cert.failed_checks}
    assert CheckKind.SPECTRUM in kinds and CheckKind.NORM in kinds


def test_gain_meeting_norm_but_exceeding_gamma_rejected():
    # ‖H‖∞ ≈ 32.18 for the paper's gain: γ = 30 must fail (both the LMI search and the norm)
    with pytest.raises(CertificateError, match=r"‖H‖∞ < γ: 32.18"):
        verify_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, K_PAPER, gamma=30.0)


def test_certificate_is_frozen_and_readonly():
    cert = design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gamma_n=1.0019)
    with pytest.raises(dataclasses.FrozenInstanceError):
        cert.gamma = 1.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        cert.gain[0, 0] = 0.0
    assert "verified" in cert.summary()


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        (dict(A=np.zeros((3, 2))), DimensionError, "A: expected a square"),
        (dict(C=np.ones((2, 4))), DimensionError, r"C: expected shape \(\?, 3\)"),
        (dict(Bd=np.ones(3)), DimensionError, "Bd: expected a 2-d"),
        (dict(A=np.full((3, 3), np.nan)), NonFiniteError, "A: entry"),
        (dict(gamma=-1.0), InvalidArgumentError, "gamma: must be positive"),
        (dict(gamma=float("nan")), NonFiniteError, "gamma: must be finite"),
        (dict(gamma_n=0.0), InvalidArgumentError, "gamma_n: must be positive"),
        (dict(margin=-1e-6), InvalidArgumentError, "margin"),
        (dict(margin=2.0), InvalidArgumentError, "margin"),
        (dict(objective="fastest"), InvalidArgumentError, "objective: unknown"),
        (dict(solver="MOSEK"), InvalidArgumentError, "solver: unknown"),
        (dict(N=np.eye(3)), DimensionError, r"N: expected shape \(2, \?\)"),
        (dict(gain_bound=-3.0), InvalidArgumentError, "kappa: must be positive"),
        (dict(gain_bound="big"), InvalidArgumentError, "gain_bound"),
    ],
)
def test_bad_input(kwargs, exc, match):
    args = dict(A=AXIS.A, C=AXIS.C, Bd=AXIS.Bd, gamma=50.0, gamma_n=1.01)
    args.update(kwargs)
    with pytest.raises(exc, match=match):
        design_observer_gain(args.pop("A"), args.pop("C"), args.pop("Bd"), **args)


def test_option_combinations_rejected():
    with pytest.raises(InvalidArgumentError, match="CENTRAL needs a bounded feasible set"):
        design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0)
    with pytest.raises(InvalidArgumentError, match="gamma: required"):
        design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma_n=1.01)
    with pytest.raises(InvalidArgumentError, match="N: given without gamma_n"):
        design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, N=np.eye(2), gain_bound=GainBound(10))
    with pytest.raises(DimensionError, match=r"K: expected shape \(3, 2\)"):
        verify_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, K_PAPER.T, gamma=50.0)


def test_noise_matrix_scales_lmi_15():
    # with N = 2 I the noise gain doubles: ‖G‖∞ for the paper's gain is 2 × 1.00208
    cert = verify_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, K_PAPER, gamma=50.0, N=2 * np.eye(2), gamma_n=2.1)
    Acl = AXIS.A - K_PAPER @ AXIS.C
    g, _ = control.linfnorm(control.ss(Acl, -K_PAPER @ (2 * np.eye(2)), np.eye(3), np.zeros((3, 2))))
    assert cert.hinf_G == pytest.approx(float(g), rel=1e-6)
    assert cert.hinf_G == pytest.approx(2 * 1.00208, abs=1e-4)
