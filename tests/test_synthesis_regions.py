"""Chilali–Gahinet pole regions: LMIs vs eigenvalues, and region-constrained designs.

Independent source: numpy eigenvalues of the closed loop (and, for the region
LMIs themselves, Chilali–Gahinet's theorem checked against eigenvalues of
matrices built with known spectra).
"""

from __future__ import annotations

import math

import cvxpy as cp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nlobs.errors import DesignInfeasible, InvalidArgumentError, NotSymmetricError
from nlobs.synthesis import (
    Disk,
    GainBound,
    HalfPlane,
    LmiRegion,
    Sector,
    design_observer_gain,
    extended_system,
    verify_observer_gain,
)

AXIS = extended_system([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2))


def _matrix_with_spectrum(eigs, seed):
    """A real matrix with the given (conjugate-closed) spectrum, non-normal via a random similarity."""
    blocks = []
    for z in eigs:
        if abs(z.imag) < 1e-12:
            blocks.append(np.array([[z.real]]))
        elif z.imag > 0:
            blocks.append(np.array([[z.real, z.imag], [-z.imag, z.real]]))
    n = sum(b.shape[0] for b in blocks)
    D = np.zeros((n, n))
    i = 0
    for b in blocks:
        k = b.shape[0]
        D[i : i + k, i : i + k] = b
        i += k
    T = np.random.default_rng(seed).normal(size=(n, n)) + 3 * np.eye(n)
    return T @ D @ np.linalg.inv(T)


def _lmi_feasible(region, F):
    n = F.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    blk = region.lmi(P, P @ F)
    prob = cp.Problem(cp.Minimize(0), [P >> np.eye(n), blk << -1e-6 * np.eye(blk.shape[0])])
    prob.solve(solver="CLARABEL")
    return prob.status == cp.OPTIMAL


REGIONS = [
    HalfPlane(1.0),
    Disk(-4.0, 3.5),
    Sector(math.radians(40)),
    LmiRegion([[2.0]], [[1.0]], name="Re < -1 as a general LMI region"),
]
INSIDE = [-2.0, -3.0 + 1.5j, -3.0 - 1.5j, -5.0]  # in all four regions
OUTSIDE = [
    [-0.5, -3.0],  # Re > −1
    [-2.0, -8.0],  # outside the disk
    [-1.5 + 3j, -1.5 - 3j, -3.0],  # |arg(−λ)| = 63° > 40°
    [-0.9, -2.0],
]


@pytest.mark.parametrize("k", range(4))
def test_region_lmi_matches_eigenvalues(k):
    region = REGIONS[k]
    F_in = _matrix_with_spectrum(np.array(INSIDE), seed=k)
    assert region.contains(np.linalg.eigvals(F_in))
    assert _lmi_feasible(region, F_in)
    F_out = _matrix_with_spectrum(np.array(OUTSIDE[k], dtype=complex), seed=10 + k)
    assert not region.contains(np.linalg.eigvals(F_out))
    assert not _lmi_feasible(region, F_out)


@settings(max_examples=60, derandomize=True, deadline=None)
@given(st.floats(-5, 5), st.floats(-5, 5), st.floats(0.1, 3))
def test_halfplane_margin_agrees_with_general_region(re, im, alpha):
    z = complex(re, im)
    hp = HalfPlane(alpha)
    gen = LmiRegion([[2 * alpha]], [[1.0]])
    assert math.isclose(hp.margin([z]), -re - alpha, abs_tol=1e-12)
    # the general region's margin is −(2α + 2 Re z) = 2 × the half-plane margin
    assert math.isclose(gen.margin([z]), 2 * hp.margin([z]), abs_tol=1e-9)


@settings(max_examples=60, derandomize=True, deadline=None)
@given(st.floats(-10, 0.5), st.floats(-10, 10), st.floats(0.1, 1.5))
def test_sector_contains_matches_angle(re, im, theta):
    z = complex(re, im)
    inside_by_angle = re < 0 and abs(math.atan2(abs(im), -re)) < theta
    margin = Sector(theta).margin([z])
    if abs(margin) > 1e-9:
        assert (margin > 0) == inside_by_angle


def test_alpha_stability_design():
    alpha = 0.2
    cert = design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gamma_n=1.0019, region=HalfPlane(alpha))
    assert cert.verified
    lam = np.linalg.eigvals(AXIS.A - cert.gain @ AXIS.C)
    assert np.all(lam.real < -alpha)
    # the unconstrained central design has a slower pole (−0.122), so the region is active
    free = design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gamma_n=1.0019)
    assert np.max(np.linalg.eigvals(AXIS.A - free.gain @ AXIS.C).real) > -alpha


def test_disk_design():
    region = Disk(-60.0, 80.0)
    cert = design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gamma_n=1.0019, region=region)
    lam = np.linalg.eigvals(AXIS.A - cert.gain @ AXIS.C)
    assert np.all(np.abs(lam + 60.0) < 80.0)
    assert cert.verified and np.max(np.abs(lam)) < 140.0


def test_sector_design_with_complex_poles():
    # with ‖K‖ ≤ 50 and only (14) the central gain has poles −1.40 ± 4.59j (73° from the negative axis)
    free = design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gain_bound=GainBound(50.0))
    lam0 = np.linalg.eigvals(AXIS.A - free.gain @ AXIS.C)
    assert np.max(np.abs(np.angle(-lam0))) > math.radians(45)
    cert = design_observer_gain(
        AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gain_bound=GainBound(50.0), region=Sector(math.radians(45))
    )
    lam = np.linalg.eigvals(AXIS.A - cert.gain @ AXIS.C)
    assert np.all(lam.real < 0)
    assert np.all(np.abs(lam.imag) < -lam.real)  # tan 45° = 1
    assert cert.gain_norm <= 50.0


def test_intersection_of_regions():
    regions = [HalfPlane(0.5), Disk(-10.0, 20.0), Sector.from_damping(0.7)]
    cert = design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gamma_n=1.05, region=regions)
    lam = np.linalg.eigvals(AXIS.A - cert.gain @ AXIS.C)
    assert np.all(lam.real < -0.5) and np.all(np.abs(lam + 10) < 20)
    zeta = -lam.real / np.abs(lam)
    assert np.all(zeta > 0.7)
    assert sum(c.name.startswith("region") for c in cert.lmi_checks) == 3


def test_region_with_gain_bound_infeasible_reports_smallest_bound():
    with pytest.raises(DesignInfeasible, match=r"gain bound ‖K‖₂ ≤ κ = 10 .*half-plane.*smallest feasible gain bound") as ei:
        design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gain_bound=10.0, region=HalfPlane(3.0))
    assert ei.value.constraint == "gain bound"
    # measured ≈ 105: a design at 1.2× that bound is feasible and meets the region
    kmin = 10.0 + ei.value.violation
    assert 50 < kmin < 300
    cert = design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gain_bound=1.2 * kmin, region=HalfPlane(3.0))
    assert np.all(np.linalg.eigvals(AXIS.A - cert.gain @ AXIS.C).real < -3.0)


def test_region_infeasible_with_noise_bound():
    # at γn = 1.0019 the slow poles sit near −0.12 … −0.43; Re λ < −5 is incompatible with that bound
    with pytest.raises(DesignInfeasible, match=r"region: half-plane Re λ < -5 is infeasible together with LMI \(14\), LMI \(15\)") as ei:
        design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gamma_n=1.0019, region=HalfPlane(5.0))
    assert ei.value.violation is not None and ei.value.violation > 0


def test_verify_given_gain_against_region():
    K = np.array([[128.9, 17.5], [15.7, 2.4], [1.3, 0.2]])
    ok = verify_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, K, gamma=50.0, region=HalfPlane(0.1))
    assert ok.verified
    bad = verify_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, K, gamma=50.0, region=HalfPlane(0.2), strict=False)
    assert not bad.verified
    assert any("half-plane" in c.name for c in bad.failed_checks)


def test_region_parameters_validated():
    with pytest.raises(InvalidArgumentError, match="radius"):
        Disk(-1.0, -2.0)
    with pytest.raises(InvalidArgumentError, match="half_angle"):
        Sector(2.0)
    with pytest.raises(InvalidArgumentError, match="zeta"):
        Sector.from_damping(1.5)
    with pytest.raises(NotSymmetricError, match="L"):
        LmiRegion([[1.0, 2.0], [0.0, 1.0]], np.eye(2))
    with pytest.raises(InvalidArgumentError, match="region"):
        design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gamma_n=1.01, region="left half-plane")
