"""A synthetic flight with exact kinematics for the GNSS/INS observer tests (and a check of it).

A steady, climbing, coordinated turn: heading ``ψ = ψ0 + r t``, bank ``φ = atan(V r / g)``,
``R = Rz(ψ) Rx(φ)`` (body→NED), ``vⁿ = [V cos ψ, V sin ψ, v_d]``. Then, exactly,
``ω^b = r [0, sin φ, cos φ]``, ``a^b = Rᵀ(v̇ⁿ − gⁿ) = [0, 0, −√((V r)² + g²)]`` (no
side force), ``m^b = Rᵀ mⁿ``. The derivation is independent of nlobs; the test below
checks it against finite differences of the closed-form truth (conventions of
``nlobs.navigation.base``: ``Ṙ = R S(ω^b)``, ``v̇ⁿ = R a^b + gⁿ``).
"""

from __future__ import annotations

import numpy as np

from nlobs.navigation.base import G0, SensorData

G_N = np.array([0.0, 0.0, G0])
#: A normalised Earth field with ~70° inclination (northern mid-latitudes).
M_N = np.array([np.cos(np.radians(70.0)), 0.05, np.sin(np.radians(70.0))])
M_N = M_N / np.linalg.norm(M_N)


def _rz(psi):
    c, s = np.cos(psi), np.sin(psi)
    out = np.zeros((*np.shape(psi), 3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1], out[..., 2, 2] = c, -s, s, c, 1.0
    return out


def _rx(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def turn_truth(t, *, V=50.0, r=0.05, vd=-2.0, psi0=0.3, p0=(0.0, 0.0, -300.0)):
    """Closed-form truth at times ``t``: p, v (K,3), R (K,3,3), ω^b, a^b (K,3)."""
    t = np.asarray(t, dtype=float)
    psi = psi0 + r * t
    phi = np.arctan2(V * r, G0)
    R = _rz(psi) @ _rx(phi)
    v = np.stack([V * np.cos(psi), V * np.sin(psi), np.full_like(t, vd)], -1)
    p = np.asarray(p0) + np.stack([V / r * (np.sin(psi) - np.sin(psi0)), -V / r * (np.cos(psi) - np.cos(psi0)), vd * t], -1)
    w_b = np.broadcast_to(r * np.array([0.0, np.sin(phi), np.cos(phi)]), p.shape).copy()
    a_b = np.broadcast_to(np.array([0.0, 0.0, -np.hypot(V * r, G0)]), p.shape).copy()
    return p, v, R, w_b, a_b


def turn_data(duration=20.0, *, imu_rate_hz=100.0, gnss_rate_hz=5.0, position_only=False, **kw) -> SensorData:
    """Noise-free :class:`SensorData` of :func:`turn_truth` (GNSS fixes on the IMU grid)."""
    K = round(duration * imu_rate_hz) + 1
    t = np.arange(K) / imu_rate_hz
    p, v, R, w_b, a_b = turn_truth(t, **kw)
    m_b = np.einsum("kji,j->ki", R, M_N)
    step = round(imu_rate_hz / gnss_rate_hz)
    gi = np.arange(0, K, step)
    return SensorData(
        t_imu=t, omega_b=w_b, a_b=a_b, m_b=m_b, t_gnss=t[gi], p_gnss=p[gi], v_gnss=None if position_only else v[gi],
        m_n=M_N.copy(), g_n=G_N.copy(), p=p, v=v, R=R, imu_rate_hz=imu_rate_hz, gnss_rate_hz=gnss_rate_hz,
    )


def test_synthetic_turn_has_exact_kinematics():
    # central differences of the closed form (independent of the formulas for ω^b, a^b)
    t = np.linspace(0.0, 30.0, 31)
    h = 1e-4
    _p, v, R, w_b, a_b = turn_truth(t)
    pp, vp, Rp, _, _ = turn_truth(t + h)
    pm, vm, Rm, _, _ = turn_truth(t - h)
    np.testing.assert_allclose((pp - pm) / (2 * h), v, atol=1e-6)
    vdot = (vp - vm) / (2 * h)
    np.testing.assert_allclose(vdot, np.einsum("kij,kj->ki", R, a_b) + G_N, atol=1e-6)
    Rdot = (Rp - Rm) / (2 * h)
    S = np.zeros((len(t), 3, 3))
    S[:, 0, 1], S[:, 0, 2], S[:, 1, 2] = -w_b[:, 2], w_b[:, 1], -w_b[:, 0]
    S = S - np.swapaxes(S, -1, -2)
    np.testing.assert_allclose(Rdot, R @ S, atol=1e-7)
    np.testing.assert_allclose(np.swapaxes(R, -1, -2) @ R, np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    assert np.linalg.det(R) == __import__("pytest").approx(np.ones(len(t)))
    # the TRIAD condition of Sec. 5.1: m^b × a^b bounded away from zero
    m_b = np.einsum("kji,j->ki", R, M_N)
    assert np.min(np.linalg.norm(np.cross(m_b, a_b), axis=-1)) > 1.0
