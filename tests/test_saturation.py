"""Saturations of Grip, Saberi & Johansen, Appendix A: identity on the box, bounded, smooth derivative."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.systems.saturation import Saturation, SmoothSaturation

LO = np.array([-1.0, 0.0, -3.0])
HI = np.array([2.0, 0.5, 3.0])
W = np.array([0.5, 0.2, 1.0])
RNG = np.random.default_rng(7)


def test_hard_saturation_identity_inside_and_clipped_outside() -> None:
    s = Saturation(LO, HI)
    inside = LO + (HI - LO) * RNG.random((100, 3))
    np.testing.assert_array_equal(s(inside), inside)
    assert s.contains(inside).all()
    far = RNG.normal(scale=50.0, size=(200, 3))
    out = s(far)
    assert np.all(out >= LO) and np.all(out <= HI)
    # 1-Lipschitz (projection onto a box), the property Appendix A uses for L1
    a, b = far[:100], far[100:]
    assert np.all(np.linalg.norm(s(a) - s(b), axis=-1) <= np.linalg.norm(a - b, axis=-1) + 1e-12)


def test_smooth_saturation_identity_inside_bounded_outside() -> None:
    s = SmoothSaturation(LO, HI, W)
    inside = LO + (HI - LO) * RNG.random((100, 3))
    np.testing.assert_array_equal(s(inside), inside)
    np.testing.assert_array_equal(s.derivative(inside), np.ones_like(inside))
    far = RNG.normal(scale=100.0, size=(500, 3))
    lo, hi = s.limits
    np.testing.assert_allclose(lo, LO - W / 2)
    y = s(far)
    assert np.all(y >= lo - 1e-12) and np.all(y <= hi + 1e-12)
    # saturated exactly beyond the transition
    np.testing.assert_allclose(s(HI + W + 1.0), HI + W / 2)
    np.testing.assert_allclose(s(LO - W - 1.0), LO - W / 2)
    # monotone and 1-Lipschitz: derivative in [0, 1]
    d = s.derivative(far)
    assert np.all(d >= 0) and np.all(d <= 1)


def test_derivatives_match_finite_differences() -> None:
    s = SmoothSaturation(LO, HI, W)
    x = np.concatenate([
        LO + (HI - LO) * RNG.random((50, 3)),
        HI + W * RNG.random((50, 3)),            # upper transition
        LO - W * RNG.random((50, 3)),            # lower transition
        RNG.normal(scale=10.0, size=(50, 3)),
    ])
    h = 1e-6
    fd1 = (s(x + h) - s(x - h)) / (2 * h)
    np.testing.assert_allclose(s.derivative(x), fd1, atol=1e-7)
    fd2 = (s.derivative(x + h) - s.derivative(x - h)) / (2 * h)
    np.testing.assert_allclose(s.second_derivative(x), fd2, atol=1e-5 * (1 / W).max())
    J = s.jacobian(x[:4])
    assert J.shape == (4, 3, 3)
    np.testing.assert_allclose(np.diagonal(J, axis1=-2, axis2=-1), s.derivative(x[:4]))


def test_c2_continuity_at_the_box_edges() -> None:
    s = SmoothSaturation(LO, HI, W)
    for edge in (LO, HI, HI + W, LO - W):
        for eps in (1e-9,):
            a, b = s(edge - eps), s(edge + eps)
            np.testing.assert_allclose(a, b, atol=1e-8)
            np.testing.assert_allclose(s.derivative(edge - eps), s.derivative(edge + eps), atol=1e-7)
            np.testing.assert_allclose(s.second_derivative(edge - eps), s.second_derivative(edge + eps), atol=1e-6)


def test_lipschitz_constant_of_the_derivative() -> None:
    """Estimated sup |Δ sat*'| / |Δx| over a fine grid equals 1.5/δ (the documented constant)."""
    s = SmoothSaturation(0.0, 1.0, 0.25)
    x = np.linspace(-1.0, 2.0, 300_001)[:, None]
    d = s.derivative(x)[:, 0]
    est = float(np.max(np.abs(np.diff(d)) / np.diff(x[:, 0])))
    assert est <= s.derivative_lipschitz[0] * (1 + 1e-9)
    assert est == pytest.approx(1.5 / 0.25, rel=1e-3)


def test_invalid_arguments() -> None:
    with pytest.raises(InvalidArgumentError, match="lower 1.0 > upper 0.0"):
        Saturation([1.0], [0.0])
    with pytest.raises(InvalidArgumentError, match="width"):
        SmoothSaturation([0.0], [1.0], 0.0)
    with pytest.raises(DimensionError, match="do not match"):
        Saturation([0.0, 1.0], [1.0, 2.0, 3.0])
    with pytest.raises(DimensionError, match=r"\(\.\.\., 3\)"):
        SmoothSaturation(LO, HI, W)(np.zeros(2))
