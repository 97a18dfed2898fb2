"""The generated flight: its inertial signals are exact (integrating them reproduces the flight),
it is a plausible light-aircraft traffic pattern, and it satisfies the TRIAD condition of seed 001."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError
from nlobs.navigation.so3 import exp_so3, log_so3
from nlobs.navigation.trajectory import traffic_pattern, triad_margin


@pytest.fixture(scope="module")
def flight():  # type: ignore[no-untyped-def]
    return traffic_pattern(seed=0)


def test_strapdown_integration_of_the_exact_signals_reproduces_the_flight(flight) -> None:  # type: ignore[no-untyped-def]
    """Ṙ = R S(ω^b), v̇ = R a^b + gⁿ, ṗ = v integrated from the initial state (independent of how
    the generator computed ω^b and a^b) must return the flight's own p, v, R."""
    T, h = 120.0, 1e-3
    # RK4 with the signals evaluated at the stage times (midpoints from the exact flight)
    ts = np.arange(0.0, T + h / 2, h / 2)
    tr = flight(ts)
    p, v, R = tr.p[0].copy(), tr.v[0].copy(), tr.R[0].copy()
    worst_p = worst_v = worst_R = 0.0
    for k in range(0, ts.size - 2, 2):
        w0, w1, w2 = tr.omega_b[k], tr.omega_b[k + 1], tr.omega_b[k + 2]
        f0, f1, f2 = tr.a_b[k], tr.a_b[k + 1], tr.a_b[k + 2]

        def d(Rx, vx, w, f):  # type: ignore[no-untyped-def]
            return Rx @ np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]), Rx @ f + tr.g_n

        kR1, kv1 = d(R, v, w0, f0)
        kp1 = v
        kR2, kv2 = d(R + h / 2 * kR1, v + h / 2 * kv1, w1, f1)
        kp2 = v + h / 2 * kv1
        kR3, kv3 = d(R + h / 2 * kR2, v + h / 2 * kv2, w1, f1)
        kp3 = v + h / 2 * kv2
        kR4, kv4 = d(R + h * kR3, v + h * kv3, w2, f2)
        kp4 = v + h * kv3
        R = R + h / 6 * (kR1 + 2 * kR2 + 2 * kR3 + kR4)
        v = v + h / 6 * (kv1 + 2 * kv2 + 2 * kv3 + kv4)
        p = p + h / 6 * (kp1 + 2 * kp2 + 2 * kp3 + kp4)
        if k % 2000 == 0 or k + 2 >= ts.size - 2:
            j = k + 2
            worst_p = max(worst_p, float(np.linalg.norm(p - tr.p[j])))
            worst_v = max(worst_v, float(np.linalg.norm(v - tr.v[j])))
            worst_R = max(worst_R, float(np.linalg.norm(log_so3(tr.R[j].T @ R))))
    assert worst_R < 1e-6, worst_R
    assert worst_v < 1e-4, worst_v
    assert worst_p < 1e-3, worst_p


def test_plausible_traffic_pattern(flight) -> None:  # type: ignore[no-untyped-def]
    tr = flight.sample(10.0)
    alt = -tr.p[:, 2]
    speed = np.linalg.norm(tr.v, axis=-1)
    roll, pitch = np.rad2deg(tr.rpy[:, 0]), np.rad2deg(tr.rpy[:, 1])
    assert 300.0 < flight.duration < 600.0
    assert abs(alt[0]) < 1.0 and abs(alt[-1]) < 1.0  # takes off from and lands on the runway
    assert 200.0 < alt.max() < 400.0  # pattern altitude (≈ 280–300 m AGL)
    assert 25.0 < speed.max() < 70.0  # light aircraft
    assert np.abs(roll).max() <= 31.0 and np.abs(pitch).max() < 20.0
    yaw_span = np.rad2deg(tr.rpy[:, 2].max() - tr.rpy[:, 2].min())
    assert yaw_span == pytest.approx(360.0, abs=30.0)  # four turns of a closed pattern
    # a level aircraft at rest on the runway reads a^b = [0, 0, −g] (specific force convention)
    np.testing.assert_allclose(tr.a_b[0], [0.0, 0.0, -flight.g_n[2]], atol=1e-6)


def test_triad_condition_holds_along_the_flight(flight) -> None:  # type: ignore[no-untyped-def]
    """Seed 001, Sec. 5.1: ‖m^b × a^b‖ ≥ c_obs > 0 (non-parallel vector measurements)."""
    margin = triad_margin(flight.sample(20.0))
    assert margin.min() > 1.0


def test_deterministic_given_seed_and_validated() -> None:
    a, b = traffic_pattern(seed=4, duration=30.0), traffic_pattern(seed=4, duration=30.0)
    np.testing.assert_array_equal(a.sample(5.0).p, b.sample(5.0).p)
    c = traffic_pattern(seed=5, duration=30.0)
    assert not np.array_equal(a.sample(5.0).R, c.sample(5.0).R)
    with pytest.raises(InvalidArgumentError, match="times must lie in"):
        a(np.array([0.0, 31.0]))
    # exp/log consistency used above
    np.testing.assert_allclose(log_so3(exp_so3(np.array([0.1, -0.2, 0.3]))), [0.1, -0.2, 0.3], atol=1e-14)
