"""Noise-optimal gains under LMI (14): closed forms, the Kalman–Bucy filter of python-control, the paper's gains.

Oracles: the scalar observer (``ė = −k e + w − k v``, ``‖T‖₂² = (W + k² V)/(2k)``, ``‖H‖∞ = 1/k``)
whose constrained optimum is known in closed form on both sides of the constraint;
``control.lqe`` (python-control's Kalman–Bucy gain) when LMI (14) is slack; python-control's
``system_norm(p=2)`` for the norm of a designed gain; the GNSS/INS axis problem of Grip, Saberi & Johansen.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from nlobs.errors import DesignInfeasible, DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.navigation.gains import PAPER_K3, axis_system
from nlobs.synthesis import (
    NoiseModel,
    design_h2_gain,
    error_covariance,
    h2_error_norm,
    kalman_bucy_gain,
    sampled_intensity,
    verify_h2_gain,
)

control = pytest.importorskip("control")


def _scalar(W: float, V: float) -> NoiseModel:
    return NoiseModel(np.array([[V]]), np.array([[1.0]]), np.array([[W]]))


@pytest.mark.parametrize("W, V", [(1.0, 1.0), (4.0, 0.25), (0.01, 9.0)])
def test_scalar_norm_matches_the_closed_form(W: float, V: float) -> None:
    for k in (0.3, 1.0, 7.0):
        expected = math.sqrt((W + k * k * V) / (2 * k))
        assert h2_error_norm([[0.0]], [[1.0]], [[k]], _scalar(W, V)) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("W, V", [(1.0, 1.0), (4.0, 0.25)])
def test_scalar_slack_constraint_gives_the_kalman_gain(W: float, V: float) -> None:
    # k* = √(W/V) minimises (W + k² V)/(2k); ‖H‖∞ = 1/k* is far below γ = 100
    cert = design_h2_gain([[0.0]], [[1.0]], [[1.0]], gamma=100.0, noise=_scalar(W, V))
    assert cert.verified
    assert float(cert.gain[0, 0]) == pytest.approx(math.sqrt(W / V), rel=1e-5)
    assert cert.h2 == pytest.approx((W * V) ** 0.25, rel=1e-9)
    assert cert.h2 == pytest.approx(cert.h2_kalman, rel=1e-9)


def test_scalar_binding_constraint_gives_the_boundary_gain() -> None:
    # k* = √(W/V) = 0.1 would need γ ≥ 10; at γ = 2 the optimum is the boundary k = 1/γ (backed off by 1e−4)
    W, V, gamma = 0.01, 1.0, 2.0
    cert = design_h2_gain([[0.0]], [[1.0]], [[1.0]], gamma=gamma, noise=_scalar(W, V))
    assert cert.verified and cert.refined
    k = float(cert.gain[0, 0])
    assert k == pytest.approx(1.0 / gamma, rel=2e-4)
    assert k > 1.0 / gamma  # ‖H‖∞ = 1/k < γ strictly
    assert cert.hinf_H == pytest.approx(1.0 / k, rel=1e-9)
    assert cert.h2 == pytest.approx(math.sqrt((W + k * k * V) / (2 * k)), rel=1e-12)
    assert cert.h2_kalman == pytest.approx((W * V) ** 0.25, rel=1e-9)
    assert cert.hinf_kalman == pytest.approx(1.0 / math.sqrt(W / V), rel=1e-9)  # the γ the Kalman gain needs
    assert cert.h2 > cert.h2_kalman


def test_kalman_bucy_gain_matches_python_control() -> None:
    rng = np.random.default_rng(3)
    n, p, q = 4, 2, 2
    A = rng.normal(size=(n, n)) - 2 * np.eye(n)
    C = rng.normal(size=(p, n))
    Bw = rng.normal(size=(n, q))
    W = np.diag([0.5, 2.0])
    V = np.diag([0.1, 0.3])
    K, reg = kalman_bucy_gain(A, C, NoiseModel(V, Bw, W))
    L, _, _ = control.lqe(A, Bw, C, W, V)
    assert not reg
    np.testing.assert_allclose(K, np.asarray(L), rtol=1e-9, atol=1e-12)


def test_slack_constraint_reproduces_the_kalman_filter_of_python_control() -> None:
    rng = np.random.default_rng(5)
    n, p = 3, 1
    A = rng.normal(size=(n, n)) - 1.5 * np.eye(n)
    C = rng.normal(size=(p, n))
    Bd = rng.normal(size=(n, 1))
    noise = NoiseModel(np.array([[0.2]]), np.eye(n), np.diag([1.0, 0.5, 0.3]))
    L, _, _ = control.lqe(A, np.eye(n), C, np.diag([1.0, 0.5, 0.3]), np.array([[0.2]]))
    hk = float(control.linfnorm(control.ss(A - np.asarray(L) @ C, Bd, np.eye(n), 0))[0])
    cert = design_h2_gain(A, C, Bd, gamma=10 * hk, noise=noise)
    assert cert.verified
    np.testing.assert_allclose(cert.gain, np.asarray(L), rtol=1e-4, atol=1e-6)
    assert cert.h2 == pytest.approx(cert.h2_kalman, rel=1e-7)


def test_designed_norm_matches_python_control_h2norm() -> None:
    pytest.importorskip("slycot")  # control.system_norm(p=2) needs it
    A, Bd, C = axis_system(False)
    noise = _gnss_noise()
    cert = design_h2_gain(A, C, Bd, gamma=50.0, noise=noise)
    sys = control.ss(A - cert.gain @ C, noise.inputs(np.asarray(cert.gain)), noise.weight(3), 0)
    assert cert.h2 == pytest.approx(float(control.system_norm(sys, p=2)), rel=1e-9)


def _gnss_noise() -> NoiseModel:
    """The demo's sensors on one axis: GNSS p, v at 5 Hz (1.5 m, 0.1 m/s), accelerometer 0.05 m/s² at 100 Hz."""
    V = np.diag([sampled_intensity(1.5, 5.0), sampled_intensity(0.1, 5.0)])
    return NoiseModel(V, np.array([[0.0], [1.0], [0.0]]), np.array([[sampled_intensity(0.05, 100.0)]]),
                      np.diag([1.0, 1.0, 0.0]))


def test_gnss_axis_noise_optimal_gain_is_certified_and_beats_the_papers() -> None:
    A, Bd, C = axis_system(False)
    noise = _gnss_noise()
    cert = design_h2_gain(A, C, Bd, gamma=50.0, noise=noise)
    paper = verify_h2_gain(A, C, Bd, PAPER_K3, gamma=50.0, noise=noise)
    assert cert.verified and paper.verified
    assert cert.hinf_H < 50.0
    assert any(c.name == "LMI (14)" and c.passed for c in cert.checks)
    # the paper's gain passes the GNSS noise straight through; the designed one averages it
    assert paper.h2 > 20 * cert.h2
    assert cert.h2 >= cert.h2_kalman
    # the steady-state standard deviations agree with the covariance
    S = error_covariance(A, C, cert.gain, noise)
    np.testing.assert_allclose(cert.error_std[:2], np.sqrt(np.diag(S)[:2]), rtol=1e-9)
    # the Kalman–Bucy gain of this model leaves z (no process noise) unstabilised: regularised, an infimum
    assert cert.kalman_regularised and cert.hinf_kalman > 1e3


def test_bad_inputs_get_typed_errors() -> None:
    with pytest.raises(InvalidArgumentError, match="semidefinite"):
        NoiseModel(np.array([[-1.0]]))
    with pytest.raises(InvalidArgumentError, match="both or neither"):
        NoiseModel(np.eye(1), np.eye(1))
    with pytest.raises(DimensionError, match="measurement"):
        design_h2_gain([[0.0]], [[1.0]], [[1.0]], gamma=1.0, noise=NoiseModel(np.eye(2)))
    with pytest.raises(InvalidArgumentError, match="NoiseModel"):
        design_h2_gain([[0.0]], [[1.0]], [[1.0]], gamma=1.0, noise=np.eye(1))  # type: ignore[arg-type]
    with pytest.raises(NonFiniteError):
        NoiseModel(np.array([[np.nan]]))
    with pytest.raises(DesignInfeasible, match="detectable"):
        design_h2_gain([[1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0]], [[1.0], [1.0]], gamma=10.0,
                       noise=NoiseModel(np.eye(1)))


def test_the_kalman_infimum_of_the_gnss_axis_is_the_limit_of_the_regularised_filters() -> None:
    # before: one regularised value, 0.16804, printed as the infimum; the limit (SciPy's CARE with z's process
    # noise shrinking: 0.167631, 0.167458, 0.167441 at 1e-10, 1e-12, 1e-14) is 0.167439
    import scipy.linalg as sl

    from nlobs.methods.gnss_ins import DEMO_NOISE
    from nlobs.navigation.gains import axis_noise_model, axis_system, noise_optimal_gains

    A, _, C = (np.asarray(x) for x in axis_system(False))
    m = axis_noise_model(DEMO_NOISE, imu_rate_hz=100, gnss_rate_hz=5)
    Bw, W, V = m.process_input, m.process, m.measurement

    def h2(qz: float) -> float:
        P = sl.solve_continuous_are(A.T, C.T, Bw @ W @ Bw.T + np.diag([0, 0, qz]), V)
        K = P @ C.T @ np.linalg.inv(V)
        F = A - K @ C
        B = np.hstack([Bw @ np.sqrt(W), -K @ sl.sqrtm(V).real])
        X = sl.solve_continuous_lyapunov(F, -B @ B.T)
        return float(np.sqrt(np.trace(m.error_weight @ X @ m.error_weight.T)))

    seq = [h2(q) for q in (1e-12, 1e-14, 1e-16)]
    assert seq[0] > seq[1] > seq[2]
    _, cert = noise_optimal_gains(DEMO_NOISE, imu_rate_hz=100, gnss_rate_hz=5)
    assert cert.kalman_regularised
    assert cert.h2_kalman == pytest.approx(0.167439, abs=2e-6)
    assert seq[2] >= cert.h2_kalman - 1e-6 and seq[2] - cert.h2_kalman < 5e-6
    assert cert.h2 / cert.h2_kalman - 1 == pytest.approx(0.038, abs=5e-4)
