"""Sensor noise with a full covariance, bias, outage windows, and process noise of the truth simulation.

Each statistic is checked against its closed form with a tolerance of about four standard errors of
the estimate (so a correct implementation fails with probability below 1e-4, a wrong one by far).
"""

from __future__ import annotations

import numpy as np
import pytest

from nlobs import LinearSystem
from nlobs.errors import DimensionError, InvalidArgumentError, NotSymmetricError
from nlobs.simulate import MeasurementGroup, simulate
from nlobs.systems import Discrete

ZERO2 = LinearSystem(np.zeros((2, 2)), np.zeros((2, 0)), np.eye(2))


def test_correlated_measurement_noise_has_the_given_covariance() -> None:
    cov = np.array([[1.0, 0.8], [0.8, 2.0]])
    g = MeasurementGroup("pair", [0, 1], rate=10.0, noise_cov=cov)
    np.testing.assert_allclose(g.noise_std, np.sqrt([1.0, 2.0]))
    res = simulate(ZERO2, None, np.zeros((4000, 2)), duration=1.0, dt=0.1, measurements=g, seed=3)
    y = res.y[:, -1, :]  # the last sample of every run: independent draws
    est = np.cov(y.T)
    se = np.sqrt((cov**2 + np.outer(np.diag(cov), np.diag(cov))) / 4000)  # standard error of a sample covariance
    assert np.all(np.abs(est - cov) < 4 * se)


def test_bias_is_added_and_outages_take_no_sample() -> None:
    g = MeasurementGroup("enc", [0, 1], rate=10.0, bias=[0.5, -1.0], outages=[[0.3, 0.6]])
    res = simulate(ZERO2, None, [[1.0, 2.0]], duration=1.0, dt=0.1, measurements=g)
    np.testing.assert_allclose(res.y[0, 0], [1.5, 1.0])
    fresh = res.sampled[:, 0]
    t = res.t
    assert not fresh[(t >= 0.3 - 1e-9) & (t < 0.6 - 1e-9)].any()
    assert fresh[(t < 0.3 - 1e-9) | (t >= 0.6 - 1e-9)].all()


@pytest.mark.parametrize("discrete", [False, True])
def test_process_noise_covariance_grows_as_Q_t(discrete: bool) -> None:
    """ẋ = w (continuous, spectral density Q): Cov x(T) = Q T; x⁺ = x + w_k: Cov x_K = K Q."""
    Q = np.array([[0.4, 0.1], [0.1, 0.2]])
    runs = 4000
    if discrete:
        plant = LinearSystem(np.eye(2), np.zeros((2, 0)), np.eye(2), time=Discrete(0.1))
        res = simulate(plant, None, np.zeros((runs, 2)), duration=2.0, process_noise=Q, seed=5)
        want = 20 * Q
    else:
        res = simulate(ZERO2, None, np.zeros((runs, 2)), duration=2.0, dt=0.01, process_noise=Q, seed=5)
        want = 2.0 * Q
    est = np.cov(res.x[:, -1, :].T)
    se = np.sqrt((want**2 + np.outer(np.diag(want), np.diag(want))) / runs)
    assert np.all(np.abs(est - want) < 4 * se)
    np.testing.assert_allclose(np.mean(res.x[:, -1, :], axis=0), 0.0, atol=4 * np.sqrt(np.diag(want) / runs).max())


def test_process_noise_as_standard_deviations_and_the_seed_reproduces_it() -> None:
    a = simulate(ZERO2, None, np.zeros((3, 2)), duration=1.0, dt=0.1, process_noise=[0.5, 0.0], seed=1)
    b = simulate(ZERO2, None, np.zeros((3, 2)), duration=1.0, dt=0.1, process_noise=[0.5, 0.0], seed=1)
    np.testing.assert_array_equal(a.x, b.x)
    assert np.all(a.x[..., 1] == 0.0) and np.any(a.x[..., 0] != 0.0)


@pytest.mark.parametrize(("kwargs", "error", "text"), [
    ({"process_noise": [[1.0, 2.0], [0.0, 1.0]]}, NotSymmetricError, "not symmetric"),
    ({"process_noise": [[1.0, 0.0], [0.0, -1.0]]}, InvalidArgumentError, "positive semidefinite"),
    ({"process_noise": [1.0, 2.0, 3.0]}, DimensionError, "standard deviations"),
    ({"process_noise": [-1.0, 0.0]}, InvalidArgumentError, "non-negative"),
    ({"process_noise": [[np.nan, 0.0], [0.0, 1.0]]}, ValueError, "finite"),
])
def test_bad_process_noise(kwargs: dict, error: type, text: str) -> None:
    with pytest.raises(error, match=text):
        simulate(ZERO2, None, np.zeros(2), duration=1.0, dt=0.1, seed=0, **kwargs)


def test_process_noise_needs_a_seed() -> None:
    with pytest.raises(InvalidArgumentError, match="process_noise"):
        simulate(ZERO2, None, np.zeros(2), duration=1.0, dt=0.1, process_noise=[1.0, 1.0])


@pytest.mark.parametrize(("kwargs", "text"), [
    ({"rate": 0.0}, "rate"),
    ({"rate": -5.0}, "rate"),
    ({"rate": 10.0, "noise_cov": [[1.0, 2.0], [2.0, 1.0]]}, "positive semidefinite"),
    ({"rate": 10.0, "noise_cov": [[1.0, 0.5], [0.0, 1.0]]}, "not symmetric"),
    ({"rate": 10.0, "noise_cov": [[1.0]]}, "shape"),
    ({"rate": 10.0, "noise_std": 0.1, "noise_cov": np.eye(2)}, "not both"),
    ({"rate": 10.0, "outages": [[2.0, 1.0]]}, "end > start"),
    ({"rate": 10.0, "bias": [1.0, 2.0, 3.0]}, "bias"),
])
def test_bad_sensor(kwargs: dict, text: str) -> None:
    with pytest.raises(ValueError, match=text):
        MeasurementGroup("s", [0, 1], **kwargs)
