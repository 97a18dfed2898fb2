"""Gains of the GNSS/INS observer (Grip, Saberi & Johansen, Sec. 5): the paper's, certified, and nlobs designs.

Independent sources: numbers measured independently of this code (‖H‖∞ ≈ 32.18,
‖G‖∞ ≈ 1.002, per-axis poles ≈ −130.9, −0.257, −0.129), closed-loop
eigenvalues recomputed here with numpy on matrices written out by hand, and the
9-state design solved directly (measured: same answer as the per-axis one).
"""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import (
    CertificateError,
    DesignInfeasible,
    DimensionError,
    InvalidArgumentError,
)
from nlobs.navigation.gains import (
    PAPER_GAMMA,
    PAPER_K3,
    axis_gain,
    axis_system,
    design_gains,
    kron_gain,
    paper_gains,
    verify_paper_gains,
)
from nlobs.synthesis import CertificateStatus, HalfPlane, verify_h2_gain, verify_observer_gain

# per-axis extended system (8c), written out by hand: states p, v, z; z = aⁿ drives v̇
A3 = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
C3 = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
C3_P = C3[:1]
# 9-state: ṗ = v, v̇ = z + g, ż = d; measurements p (3), v (3)
I3, Z3 = np.eye(3), np.zeros((3, 3))
A9 = np.block([[Z3, I3, Z3], [Z3, Z3, I3], [Z3, Z3, Z3]])
C9 = np.block([[I3, Z3, Z3], [Z3, I3, Z3]])


def test_paper_gain_blocks_as_printed():
    K = paper_gains()
    assert K.shape == (9, 6)
    blocks = {"K_pp": (0, 0, 128.9), "K_pv": (0, 1, 17.5), "K_vp": (1, 0, 15.7), "K_vv": (1, 1, 2.4),
              "K_zp": (2, 0, 1.3), "K_zv": (2, 1, 0.2)}
    for name, (i, j, val) in blocks.items():
        np.testing.assert_array_equal(K[3 * i:3 * i + 3, 3 * j:3 * j + 3], val * np.eye(3), err_msg=name)
    np.testing.assert_array_equal(PAPER_GAMMA, np.diag([20.0, 0.2, 0.2]))


def test_paper_gain_certificate_matches_facts():
    cert = verify_paper_gains()
    assert cert.status is CertificateStatus.VERIFIED
    assert cert.hinf_H == pytest.approx(32.18, abs=0.01)
    assert cert.hinf_H < 50.0
    assert cert.hinf_G == pytest.approx(1.002, abs=5e-4)
    K3 = axis_gain(paper_gains())
    poles = np.sort(np.linalg.eigvals(A3 - K3 @ C3).real)
    assert np.all(np.abs(poles - [-130.9, -0.257, -0.129]) <= [0.05, 5e-4, 5e-4])
    np.testing.assert_allclose(np.sort(cert.eigenvalues.real), poles, rtol=1e-9)


def test_kron_gain_has_each_axis_pole_three_times():
    K9 = paper_gains()
    poles9 = np.sort(np.linalg.eigvals(A9 - K9 @ C9).real)
    poles3 = np.sort(np.linalg.eigvals(A3 - axis_gain(K9) @ C3).real)
    np.testing.assert_allclose(poles9, np.repeat(poles3, 3), rtol=1e-7)


def test_paper_gain_fails_a_too_tight_gamma_n():
    # ‖G‖∞ ≈ 1.00208 > 1.0019
    with pytest.raises(CertificateError, match="G"):
        verify_paper_gains(gamma_n=1.0019)


def test_designed_gain_is_certified_and_kron_structured():
    K9, cert = design_gains(gamma=50.0, gamma_n=1.0019)
    assert cert.verified and cert.hinf_H < 50.0 and cert.hinf_G <= 1.0019
    K3 = axis_gain(K9)
    np.testing.assert_allclose(K9, np.kron(K3, np.eye(3)))
    # docs/synthesis.md: central solution ≈ [[126.6, 16.1], [15.6, 2.42], [1.16, 0.19]], within ~11 % of the paper's
    np.testing.assert_allclose(K3, [[126.61, 16.14], [15.56, 2.417], [1.156, 0.191]], rtol=0.01)
    np.testing.assert_allclose(K3, axis_gain(paper_gains()), rtol=0.12)
    assert np.max(np.linalg.eigvals(A9 - K9 @ C9).real) < 0
    # the designed gain passes the independent verification as well
    assert verify_observer_gain(A3, C3, np.array([[0.0], [0.0], [1.0]]), K3,
                                gamma=50.0, gamma_n=1.0019).verified


def test_nine_state_design_equals_kron_of_axis_design():
    K_axis, _ = design_gains(gamma_n=1.002)
    K_full, cert_full = design_gains(gamma_n=1.002, per_axis=False)
    assert cert_full.verified and cert_full.gain.shape == (9, 6)
    # measured (docs/navigation.md): the 9-state answer reproduces kron(K3, I3) to ~1e-3
    np.testing.assert_allclose(K_full, K_axis, atol=5e-3 * np.max(np.abs(K_axis)))


def test_position_only_design_is_certified():
    K9, cert = design_gains(position_only=True)
    assert K9.shape == (9, 3) and cert.verified
    K3 = axis_gain(K9)
    assert cert.hinf_H < 50.0 and cert.hinf_G <= 1.05
    poles = np.linalg.eigvals(A3 - K3 @ C3_P)
    assert np.max(poles.real) < -0.1
    np.testing.assert_allclose(K3[:, 0], [25.75, 5.92, 0.719], rtol=0.01)  # measured (module docstring)
    np.testing.assert_allclose(paper_gains(position_only=True), K9)


def test_position_only_gamma_n_below_its_infimum_is_infeasible():
    with pytest.raises(DesignInfeasible, match="γn"):
        design_gains(position_only=True, gamma_n=1.01)


def test_design_with_a_region_places_the_poles():
    K9, _cert = design_gains(gamma_n=1.01, region=HalfPlane(0.15))
    assert np.max(np.linalg.eigvals(A9 - K9 @ C9).real) < -0.15


def test_gain_helpers_reject_bad_shapes():
    with pytest.raises(DimensionError, match="K3"):
        kron_gain(np.ones((2, 2)))
    with pytest.raises(DimensionError, match="K9"):
        axis_gain(np.ones((6, 6)))
    bad = paper_gains().copy()
    bad[0, 1] = 0.5
    with pytest.raises(InvalidArgumentError, match="kron"):
        axis_gain(bad)
    with pytest.raises(InvalidArgumentError, match="objective"):
        design_gains(objective="fastest")


# --------------------------------------------------------------------------- noise-optimal gains


def test_axis_noise_model_is_the_sampled_sensor_intensities() -> None:
    from nlobs.navigation.gains import axis_noise_model
    from nlobs.navigation.sensors import SensorNoise

    nm = axis_noise_model(SensorNoise(accel_std=0.05, gnss_p_std=1.5, gnss_v_std=0.1), imu_rate_hz=100.0,
                          gnss_rate_hz=5.0)
    np.testing.assert_allclose(nm.measurement, np.diag([1.5**2 / 5.0, 0.1**2 / 5.0]), rtol=1e-15)
    np.testing.assert_allclose(nm.process, [[0.05**2 / 100.0]], rtol=1e-15)
    np.testing.assert_array_equal(nm.process_input, [[0.0], [1.0], [0.0]])
    po = axis_noise_model(SensorNoise(gnss_p_std=2.0), imu_rate_hz=50.0, gnss_rate_hz=1.0, position_only=True)
    assert po.measurement.shape == (1, 1) and po.measurement[0, 0] == pytest.approx(4.0)
    assert po.process[0, 0] == pytest.approx(1e-8 / 50.0)  # a noise-free accelerometer is floored at 1e-4


@pytest.mark.slow
def test_noise_optimal_gains_are_certified_and_near_the_kalman_infimum() -> None:
    from nlobs.navigation.gains import noise_optimal_gains
    from nlobs.workflows.demo import DEMO_NOISE

    K9, cert = noise_optimal_gains(DEMO_NOISE, imu_rate_hz=100.0, gnss_rate_hz=5.0)
    assert cert.verified and cert.hinf_H < 50.0
    np.testing.assert_allclose(K9, kron_gain(cert.gain), rtol=0, atol=0)
    # measured: 0.1738 against the Kalman–Bucy infimum 0.1680 (LMI (14) at γ = 50 costs 3.4 %)
    assert cert.h2_kalman <= cert.h2 <= 1.05 * cert.h2_kalman
    # the paper's gain, on the same noise model, is far from it
    paper = verify_h2_gain(*_axis_acbd(), PAPER_K3, gamma=50.0, noise=cert.noise)
    assert paper.h2 > 20 * cert.h2
    K3p, certp = noise_optimal_gains(DEMO_NOISE, imu_rate_hz=100.0, gnss_rate_hz=5.0, position_only=True)
    assert certp.verified and K3p.shape == (9, 3)
    with pytest.raises(InvalidArgumentError, match="SensorNoise"):
        noise_optimal_gains({"gnss_p_std": 1.0}, imu_rate_hz=100.0, gnss_rate_hz=5.0)  # type: ignore[arg-type]


def _axis_acbd():
    A, Bd, C = axis_system(False)
    return A, C, Bd
