"""Multi-rate sample-and-hold, noise, input sensors and corrections at sample instants."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import DimensionError, InvalidArgumentError, UnknownNameError
from nlobs.observers.luenberger import LuenbergerObserver
from nlobs.simulate import InputSensor, MeasurementGroup, SampledSignal, simulate
from nlobs.systems.linear import LinearSystem
from nlobs.systems.timebase import CONTINUOUS

# A rotating 3-state system: every output moves all the time, so a held value that did not change
# at a sample instant (or changed between two) would be visible.
A = np.array([[0.0, 2.0, 0.0], [-2.0, 0.0, 0.0], [0.0, 0.0, 0.3]])
B = np.array([[1.0], [0.0], [0.0]])
C = np.eye(3)
SYS = LinearSystem(A, B, C, outputs=("ax", "ay", "pos"))
OBS = LuenbergerObserver(SYS, np.eye(3))
IMU = MeasurementGroup("imu", ["ax", "ay"], rate=100.0)
GNSS = MeasurementGroup("gnss", ["pos"], rate=5.0)


def test_held_values_change_only_at_each_groups_sample_instants() -> None:
    dt = 1e-3
    res = simulate(SYS, OBS, [1.0, 0.0, 1.0], np.zeros(3), duration=1.0, dt=dt, u=0.0, measurements=[IMU, GNSS])
    k = np.arange(res.t.size)
    for cols, stride in (([0, 1], 10), ([2], 200)):
        sample_k = k - k % stride  # last sample instant at or before step k
        np.testing.assert_array_equal(res.y[:, cols], res.x[sample_k][:, cols])
        changed = np.any(np.diff(res.y[:, cols], axis=0) != 0, axis=1)
        np.testing.assert_array_equal(np.flatnonzero(changed) + 1, k[1:][k[1:] % stride == 0])
        np.testing.assert_array_equal(res.sampled[:, cols[0]], k % stride == 0)


def _noise_run(seed: int | np.random.Generator, std: float = 0.3) -> np.ndarray:
    still = LinearSystem(np.zeros((2, 2)), np.zeros((2, 0)), np.eye(2))
    obs = LuenbergerObserver(still, np.zeros((2, 2)))
    groups = [MeasurementGroup("fast", [0], rate=100.0, noise_std=std), MeasurementGroup("slow", [1], rate=5.0, noise_std=2 * std)]
    x0 = np.zeros((20, 2))
    return simulate(still, obs, x0, np.zeros(2), duration=10.0, dt=1e-3, measurements=groups, seed=seed).y


@pytest.mark.slow
def test_noise_is_reproducible_with_a_seed_and_has_the_requested_std() -> None:
    y1, y2, y3 = _noise_run(7), _noise_run(7), _noise_run(8)
    np.testing.assert_array_equal(y1, y2)
    assert not np.allclose(y1, y3)
    np.testing.assert_array_equal(_noise_run(np.random.default_rng(7)), y1)
    # One reading per sample instant: 100 Hz → steps multiple of 10, 5 Hz → multiple of 200.
    fast = y1[:, ::10, 0].ravel()
    slow = y1[:, ::200, 1].ravel()
    for sample, std in ((fast, 0.3), (slow, 0.6)):
        se = std / np.sqrt(2 * sample.size)  # standard error of a sample standard deviation
        assert abs(sample.std(ddof=1) - std) < 5 * se
        assert abs(sample.mean()) < 5 * std / np.sqrt(sample.size)


def test_noise_without_seed_is_refused() -> None:
    noisy = MeasurementGroup("gnss", ["ax", "ay", "pos"], rate=5.0, noise_std=0.1)
    with pytest.raises(InvalidArgumentError, match="seed"):
        simulate(SYS, OBS, np.zeros(3), np.zeros(3), duration=1.0, dt=1e-3, u=0.0, measurements=[noisy])


@pytest.mark.parametrize(
    ("rate", "dt", "pattern"),
    [(3.0, 1e-3, r"'gnss'.*rate 3 Hz.*dt=0\.001"), (2000.0, 1e-3, r"'gnss'.*faster")],
)
def test_rates_must_fit_the_grid(rate: float, dt: float, pattern: str) -> None:
    g = MeasurementGroup("gnss", ["pos"], rate=rate)
    with pytest.raises(InvalidArgumentError, match=pattern):
        simulate(SYS, OBS, np.zeros(3), np.zeros(3), duration=1.0, dt=dt, u=0.0, measurements=[IMU, g])


def test_group_definitions_are_checked() -> None:
    with pytest.raises(TypeError):
        MeasurementGroup("imu", ["ax"])  # type: ignore[call-arg]  # no default rate
    with pytest.raises(InvalidArgumentError, match="rate"):
        MeasurementGroup("imu", ["ax"], rate=0.0)
    with pytest.raises(DimensionError, match="noise_std"):
        MeasurementGroup("imu", ["ax", "ay"], rate=10.0, noise_std=[0.1, 0.2, 0.3])
    with pytest.raises(InvalidArgumentError, match="non-negative"):
        MeasurementGroup("imu", ["ax"], rate=10.0, noise_std=-1.0)
    kw = dict(duration=1.0, dt=1e-3, u=0.0)
    with pytest.raises(InvalidArgumentError, match=r"\['pos'\] belong to no measurement group"):
        simulate(SYS, OBS, np.zeros(3), np.zeros(3), measurements=[IMU], **kw)
    with pytest.raises(InvalidArgumentError, match="both"):
        simulate(SYS, OBS, np.zeros(3), np.zeros(3), measurements=[IMU, MeasurementGroup("g", ["ax", "pos"], rate=5.0)], **kw)
    with pytest.raises(UnknownNameError, match="'alt'"):
        simulate(SYS, OBS, np.zeros(3), np.zeros(3), measurements=[IMU, MeasurementGroup("g", ["alt"], rate=5.0)], **kw)


def test_input_sensor_feeds_the_observer_a_held_noisy_input_and_the_plant_the_true_one() -> None:
    u = lambda t: np.array([np.sin(5.0 * t)])  # noqa: E731
    kw = dict(duration=2.0, dt=1e-3, u=u, measurements=[IMU, GNSS])
    exact = simulate(SYS, OBS, [1.0, 0.0, 1.0], np.zeros(3), **kw)
    sensed = simulate(SYS, OBS, [1.0, 0.0, 1.0], np.zeros(3), input_sensors=InputSensor("acc", [0], rate=50.0, noise_std=0.5), seed=3, **kw)
    np.testing.assert_array_equal(sensed.x, exact.x)  # the plant never sees the sensor
    assert np.max(np.abs(sensed.x_hat - exact.x_hat)) > 1e-3  # the observer does

    # A noise-free held input: the observer error now obeys ė = (A − LC) e + B (u_held − u), which
    # differs from the exact-input run by O(period) but not by more.
    held = simulate(SYS, OBS, [1.0, 0.0, 1.0], np.zeros(3), input_sensors=InputSensor("acc", [0], rate=50.0), **kw)
    gap = np.max(np.abs(held.x_hat - exact.x_hat))
    assert 1e-4 < gap < 0.1


class _SpyCorrecting:
    """A continuous observer that copies the held measurement into its state at each correction."""

    time = CONTINUOUS
    n_z = 3
    n_x = 3

    def __init__(self) -> None:
        self.calls: list[tuple[float, np.ndarray]] = []

    def init(self, x_hat0: np.ndarray) -> np.ndarray:
        return np.array(x_hat0, dtype=float)

    def rhs(self, t: float, z: np.ndarray, u: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.zeros_like(z)

    def estimate(self, z: np.ndarray) -> np.ndarray:
        return z

    def correct(self, t: float, z: np.ndarray, u: np.ndarray, y: np.ndarray, fresh: np.ndarray) -> np.ndarray:
        self.calls.append((t, fresh.copy()))
        return np.where(fresh, y, z)


def test_correct_is_called_at_every_sample_instant_with_the_fresh_mask() -> None:
    spy = _SpyCorrecting()
    res = simulate(SYS, spy, [1.0, 0.0, 1.0], np.zeros(3), duration=0.5, dt=1e-3, u=0.0, measurements=[IMU, GNSS])
    times = np.array([c[0] for c in spy.calls])
    expected = np.arange(0, 501, 10) * 1e-3
    np.testing.assert_allclose(times, expected, atol=1e-12)
    for t, fresh in spy.calls:
        gnss_due = round(t * 1000) % 200 == 0
        np.testing.assert_array_equal(fresh, [True, True, gnss_due])
    # The estimate after correction equals the measurement just received.
    np.testing.assert_array_equal(res.x_hat[::10], res.y[::10])


def test_correcting_observer_needs_explicit_rates_in_continuous_time() -> None:
    with pytest.raises(InvalidArgumentError, match="explicit rates"):
        simulate(SYS, _SpyCorrecting(), np.zeros(3), np.zeros(3), duration=0.1, dt=1e-3, u=0.0)


def test_sampled_signal_hold_and_linear() -> None:
    times = np.array([0.0, 1.0, 2.0])
    vals = np.array([[0.0], [10.0], [20.0]])
    hold = SampledSignal(times, vals)
    lin = SampledSignal(times, vals, kind="linear")
    assert hold(1.5)[0] == 10.0 and lin(1.5)[0] == pytest.approx(15.0)
    assert hold(5.0)[0] == 20.0 and lin(5.0)[0] == 20.0
    with pytest.raises(InvalidArgumentError, match="increasing"):
        SampledSignal([0.0, 0.0], [[1.0], [2.0]])
    # ẋ = u with u held: x(2) = 0·1 + 10·1 (integral of the staircase), exact for RK4.
    integ = LinearSystem([[0.0]], [[1.0]], [[1.0]])
    res = simulate(integ, None, [0.0], duration=2.0, dt=0.01, u=hold)
    assert res.x[-1, 0] == pytest.approx(10.0, abs=1e-12)
    res = simulate(integ, None, [0.0], duration=2.0, dt=0.01, u=lin)
    assert res.x[-1, 0] == pytest.approx(20.0, abs=1e-10)  # ∫0^2 10 t dt
