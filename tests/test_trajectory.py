"""The generated flight: its inertial signals are exact (integrating them reproduces the flight),
it is a plausible light-aircraft traffic pattern, and it satisfies the TRIAD condition of Grip, Saberi &
Johansen (Sec. 5.1). The whole pattern of seed 0 is the session fixture ``pattern`` (``conftest.py``)."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError
from nlobs.navigation.so3 import exp_so3, log_so3, skew, unskew
from nlobs.navigation.trajectory import traffic_pattern, triad_margin


def test_strapdown_integration_of_the_exact_signals_reproduces_the_flight(pattern) -> None:  # type: ignore[no-untyped-def]
    """Ṙ = R S(ω^b), v̇ = R a^b + gⁿ, ṗ = v integrated by RK4 at 1 kHz (independent of how the
    generator computed ω^b and a^b) must return the flight's own p, v, R.

    To cover the whole flight cheaply, 4-s windows starting every 12 s (take-off, every turn,
    flare and roll-out included) are integrated side by side, each from the true state at its
    start. Measured: p 1e-9 m, v 3e-13 m/s, R 2e-14 (rounding level)."""
    h, span, every = 1e-3, 4.0, 12.0
    starts = np.arange(0.0, pattern.duration - span, every)
    n = int(round(span / h))
    ts = (starts[:, None] + np.arange(2 * n + 1)[None, :] * (h / 2)).ravel()
    tr = pattern(ts)
    W = tr.omega_b.reshape(starts.size, 2 * n + 1, 3)
    A = tr.a_b.reshape(starts.size, 2 * n + 1, 3)
    P, V, RR = (x.reshape(starts.size, 2 * n + 1, *x.shape[1:]) for x in (tr.p, tr.v, tr.R))
    p, v, R = P[:, 0].copy(), V[:, 0].copy(), RR[:, 0].copy()

    def d(Rx, vx, w, f):  # type: ignore[no-untyped-def]
        return Rx @ skew(w), np.einsum("bij,bj->bi", Rx, f) + tr.g_n, vx

    for k in range(0, 2 * n, 2):
        k1 = d(R, v, W[:, k], A[:, k])
        k2 = d(R + h / 2 * k1[0], v + h / 2 * k1[1], W[:, k + 1], A[:, k + 1])
        k3 = d(R + h / 2 * k2[0], v + h / 2 * k2[1], W[:, k + 1], A[:, k + 1])
        k4 = d(R + h * k3[0], v + h * k3[1], W[:, k + 2], A[:, k + 2])
        R, v, p = (x + h / 6 * (a + 2 * b + 2 * c + e) for x, a, b, c, e in zip((R, v, p), k1, k2, k3, k4))
    assert np.abs(R - RR[:, -1]).max() < 1e-10
    assert np.abs(v - V[:, -1]).max() < 1e-9
    assert np.abs(p - P[:, -1]).max() < 1e-7


def test_signals_are_the_exact_derivatives(pattern) -> None:  # type: ignore[no-untyped-def]
    """Central differences (h = 1e-4 s): ω^b = unskew(Rᵀ Ṙ), v = ṗ, v̇ = d/dt v (measured ≤ 1e-8)."""
    h = 1e-4
    ts = np.linspace(1.0, pattern.duration - 1.0, 1501)
    a, b, c = pattern(ts - h), pattern(ts), pattern(ts + h)
    np.testing.assert_allclose(unskew(np.swapaxes(b.R, -1, -2) @ (c.R - a.R) / (2 * h)), b.omega_b, atol=1e-8)
    np.testing.assert_allclose((c.p - a.p) / (2 * h), b.v, atol=1e-7)
    np.testing.assert_allclose((c.v - a.v) / (2 * h), b.vdot, atol=1e-7)
    np.testing.assert_allclose(np.einsum("kji,kj->ki", b.R, b.vdot - b.g_n), b.a_b, atol=1e-12)
    np.testing.assert_allclose(np.einsum("kji,j->ki", b.R, b.m_n), b.m_b, atol=1e-15)


def test_signals_are_smooth(pattern) -> None:  # type: ignore[no-untyped-def]
    """ȧ^b continuous and bounded (Grip, Saberi & Johansen, Sec. 5.1): second differences of a^b and ω^b divided by
    dt² stay bounded as dt shrinks (a jump in ȧ would grow like 1/dt). Measured 1.24 and 0.44."""
    for rate in (100.0, 400.0):
        tr = pattern(np.arange(60.0, 140.0, 1.0 / rate))  # rotation to downwind turn
        dt = 1.0 / rate
        assert np.abs(np.diff(tr.a_b, 2, axis=0)).max() / dt**2 < 3.0
        assert np.abs(np.diff(tr.omega_b, 2, axis=0)).max() / dt**2 < 1.0


def test_plausible_traffic_pattern(pattern) -> None:  # type: ignore[no-untyped-def]
    tr = pattern.sample(10.0)
    alt = -tr.p[:, 2]
    speed = np.linalg.norm(tr.v, axis=-1)
    roll, pitch = np.rad2deg(tr.rpy[:, 0]), np.rad2deg(tr.rpy[:, 1])
    assert 300.0 < pattern.duration < 600.0
    assert abs(alt[0]) < 1.0 and abs(alt[-1]) < 1.0  # takes off from and lands on the runway
    assert 200.0 < alt.max() < 400.0  # pattern altitude (≈ 280–300 m AGL)
    assert 25.0 < speed.max() < 70.0  # light aircraft
    assert np.abs(roll).max() <= 31.0 and np.abs(pitch).max() < 20.0
    yaw_span = np.rad2deg(tr.rpy[:, 2].max() - tr.rpy[:, 2].min())
    assert yaw_span == pytest.approx(360.0, abs=30.0)  # four turns of a closed pattern
    # a level aircraft at rest on the runway reads a^b = [0, 0, −g] (specific force convention)
    np.testing.assert_allclose(tr.a_b[0], [0.0, 0.0, -pattern.g_n[2]], atol=1e-6)


def test_triad_condition_holds_along_the_flight(pattern) -> None:  # type: ignore[no-untyped-def]
    """Grip, Saberi & Johansen, Sec. 5.1: ‖m^b × a^b‖ ≥ c_obs > 0 (non-parallel vector measurements)."""
    margin = triad_margin(pattern.sample(20.0))
    assert margin.min() > 1.0  # measured 1.38 for seed 0; 3.35 = g·sin 20° at rest


@pytest.mark.parametrize("seed", range(1, 6))
def test_every_seed_lands_on_the_runway_and_keeps_the_triad_margin(seed: int) -> None:
    f = traffic_pattern(seed=seed)
    tr = f.sample(10.0)
    assert triad_margin(tr).min() > 0.9  # measured 0.96–1.65 over seeds 0–9
    axis = np.array([np.cos(f.runway_heading), np.sin(f.runway_heading)])
    cross = np.array([-axis[1], axis[0]])
    assert abs(tr.p[-1, :2] @ cross) < 1e-6 and abs(tr.p[-1, 2]) < 1e-6  # on the centre line, on the ground
    assert np.linalg.norm(tr.v[-1]) < 1e-9 and np.abs(tr.omega_b[-1]).max() < 1e-12  # stopped
    assert 280.0 <= f.pattern_altitude <= 320.0 and tr.altitude.max() == pytest.approx(f.pattern_altitude, abs=1e-6)
    assert np.abs(np.rad2deg(tr.rpy[:, 0])).max() <= 30.0


def test_duration_truncates_or_pads_at_rest() -> None:
    full = traffic_pattern(seed=0)
    short = traffic_pattern(seed=0, duration=50.0)
    long = traffic_pattern(seed=0, duration=full.duration + 20.0)
    assert short.duration == 50.0 and all(t0 <= 50.0 for _, t0 in short.phases)
    np.testing.assert_array_equal(short(np.array([10.0, 50.0])).p, full(np.array([10.0, 50.0])).p)
    tail = long(np.array([full.duration, full.duration + 20.0]))
    np.testing.assert_allclose(tail.p[1], tail.p[0], atol=1e-12)
    np.testing.assert_allclose(tail.a_b[1], [0.0, 0.0, -full.g_n[2]], atol=1e-12)


def test_deterministic_given_seed_and_validated() -> None:
    a, b = traffic_pattern(seed=4, duration=30.0), traffic_pattern(seed=4, duration=30.0)
    np.testing.assert_array_equal(a.sample(5.0).p, b.sample(5.0).p)
    c = traffic_pattern(seed=5, duration=30.0)
    assert not np.array_equal(a.sample(5.0).R, c.sample(5.0).R)
    with pytest.raises(InvalidArgumentError, match="times must lie in"):
        a(np.array([0.0, 31.0]))
    # exp/log consistency used above
    np.testing.assert_allclose(log_so3(exp_so3(np.array([0.1, -0.2, 0.3]))), [0.1, -0.2, 0.3], atol=1e-14)
