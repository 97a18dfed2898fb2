r"""The fused single-flight kernel of the split (Strang) step of observer (24), in plain-Python floats.

:class:`~nlobs.navigation.gnss_ins.GnssInsObserver` with ``integrator="split"``
advances one IMU period ``h`` by ``C(h/2) A(h/2) B(h) A(h/2) C(h/2)`` (the three
exactly solved sub-flows are derived in its docstring):

* ``C`` — the linear part on ``L = [p̂, v̂, ẑ, y_p, (y_v)]`` with ``R̂`` frozen:
  ``L ← Φ L + d`` (``Φ = expm(F h/2)``, augmented with the constant ``gⁿ``);
* ``A`` — ``R̂ ← R̂ exp(S(ω^b) h/2)`` with ``ξ`` fixed;
* ``B`` — the injection, elementwise in ``R̃ = Vᵀ R̂ U``:
  ``R̃_ij ← e^{−γ_i μ_j h} R̃_ij + (1 − e^{−γ_i μ_j h}) (Vᵀ A_n)_ij / |c_j|``,
  then ``ξ = ẑ − R̂ a^b``.

For a batch of flights the observer evaluates this with about 40 NumPy calls on
``(..., 3, 3)`` arrays, vectorised over the batch. For **one** flight each of
those calls costs about 1 µs of fixed overhead for a handful of flops, so this
module evaluates the very same formulas on Python floats (9-tuples for 3×3
matrices, row-major) instead: about 750 float operations, 18 calls of ``math``
functions and no NumPy call in the arithmetic.

The linear sub-flow uses the structure of ``Φ``: with a gain ``K = kron(K3, I3)``
(every design of :mod:`nlobs.navigation.gains`) it does not couple the three
axes, so ``Φ`` is three 5×5 (4×4 for a position-only receiver) blocks, which
:class:`ScalarFlow` extracts (checked entry by entry: every coupling between axes
is exactly zero). For a general ``K`` it falls back to one NumPy product.

Rodrigues' formula is :func:`exp_so3_scalar`, the fused scalar form of
:func:`nlobs.navigation.so3.exp_so3` (the batched path's). The results equal the
batched path's to rounding (the sums are evaluated in a different order):
``tests/test_gnss_ins_split.py`` checks 1e-12 agreement along a noisy flight for
every mode.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from nlobs._typing import Array


__all__ = ["ScalarFlow", "SplitConstants", "exp_so3_scalar", "split_step"]

#: A 3×3 matrix as 9 floats, row-major.
Mat3 = tuple[float, ...]
#: A 3×3 matrix (row-major) or a 3-vector as any sequence of floats (a list from ``ndarray.tolist``).
Floats = Sequence[float]


def _mm(A: Floats, B: Floats) -> Mat3:
    """``A @ B`` of two row-major 3×3 matrices."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = A
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = B
    return (a0 * b0 + a1 * b3 + a2 * b6, a0 * b1 + a1 * b4 + a2 * b7, a0 * b2 + a1 * b5 + a2 * b8,
            a3 * b0 + a4 * b3 + a5 * b6, a3 * b1 + a4 * b4 + a5 * b7, a3 * b2 + a4 * b5 + a5 * b8,
            a6 * b0 + a7 * b3 + a8 * b6, a6 * b1 + a7 * b4 + a8 * b7, a6 * b2 + a7 * b5 + a8 * b8)


def _mmT(A: Floats, B: Floats) -> Mat3:
    """``A @ Bᵀ`` of two row-major 3×3 matrices."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = A
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = B
    return (a0 * b0 + a1 * b1 + a2 * b2, a0 * b3 + a1 * b4 + a2 * b5, a0 * b6 + a1 * b7 + a2 * b8,
            a3 * b0 + a4 * b1 + a5 * b2, a3 * b3 + a4 * b4 + a5 * b5, a3 * b6 + a4 * b7 + a5 * b8,
            a6 * b0 + a7 * b1 + a8 * b2, a6 * b3 + a7 * b4 + a8 * b5, a6 * b6 + a7 * b7 + a8 * b8)


def _mTm(A: Floats, B: Floats) -> Mat3:
    """``Aᵀ @ B`` of two row-major 3×3 matrices."""
    a0, a1, a2, a3, a4, a5, a6, a7, a8 = A
    b0, b1, b2, b3, b4, b5, b6, b7, b8 = B
    return (a0 * b0 + a3 * b3 + a6 * b6, a0 * b1 + a3 * b4 + a6 * b7, a0 * b2 + a3 * b5 + a6 * b8,
            a1 * b0 + a4 * b3 + a7 * b6, a1 * b1 + a4 * b4 + a7 * b7, a1 * b2 + a4 * b5 + a7 * b8,
            a2 * b0 + a5 * b3 + a8 * b6, a2 * b1 + a5 * b4 + a8 * b7, a2 * b2 + a5 * b5 + a8 * b8)


def exp_so3_scalar(p0: float, p1: float, p2: float) -> Mat3:
    """Rodrigues' ``exp(S(φ)) = cos θ I + (sin θ/θ) S(φ) + ((1 − cos θ)/θ²) φφᵀ`` on floats (row-major 9-tuple).

    The fused scalar form of :func:`nlobs.navigation.so3.exp_so3` (the one NumPy form): the same
    map, with ``(1 − cos θ)/θ² = 2 sin²(θ/2)/θ²`` (no cancellation) and ``θ + 1e-300`` instead of a
    Taylor series near 0 (``sin(1e-300)/1e-300 = 1``: exact at ``θ = 0``). The two agree to rounding
    (tested to 1e-15 for angles from 0 to π).

    Parameters
    ----------
    p0, p1, p2 : float
        Components of the rotation vector ``φ`` [rad].

    Returns
    -------
    tuple of 9 float
        ``exp(S(φ))``, row-major.
    """
    th = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2) + 1e-300
    A = math.sin(th) / th
    sh = math.sin(0.5 * th)
    B = 2.0 * (sh / th) ** 2
    c = 1.0 - 2.0 * sh * sh
    Ap0, Ap1, Ap2 = A * p0, A * p1, A * p2
    Bp0, Bp1, Bp2 = B * p0, B * p1, B * p2
    return (c + Bp0 * p0, Bp0 * p1 - Ap2, Bp0 * p2 + Ap1,
            Bp1 * p0 + Ap2, c + Bp1 * p1, Bp1 * p2 - Ap0,
            Bp2 * p0 - Ap1, Bp2 * p1 + Ap0, c + Bp2 * p2)


@dataclass(frozen=True)
class ScalarFlow:
    """The linear sub-flow ``L ← Φ L + d`` over one half step, ready for scalar evaluation.

    ``L = [p̂, v̂, ẑ, y_p, (y_v)]`` in blocks of three (one entry per axis).

    Attributes
    ----------
    blocks : int
        Number of 3-blocks of ``L``: 5, or 4 for a position-only receiver.
    per_axis : tuple of tuple of float
        For each axis ``a``, the ``blocks × blocks`` matrix ``Φ[3i + a, 3j + a]``
        (row-major) and then the ``blocks`` offsets ``d[3i + a]``; empty when
        ``Φ`` couples the axes (general ``K``).
    dense : (ndarray, ndarray) or None
        ``(Φᵀ, d)`` for the coupled case (``L @ Φᵀ + d``); ``None`` otherwise.
    """

    blocks: int
    per_axis: tuple[tuple[float, ...], ...]
    dense: tuple[Array, Array] | None

    @classmethod
    def from_transition(cls, P: Array, d: Array) -> ScalarFlow:
        """From ``P = Φᵀ`` (``(n, n)``, ``n = 3·blocks``) and ``d`` (``(n,)``) of the batched path."""
        n = P.shape[0]
        nb = n // 3
        Phi = P.T
        axis = np.arange(n) % 3
        if np.any(Phi[axis[:, None] != axis[None, :]] != 0.0):
            return cls(blocks=nb, per_axis=(), dense=(P, d))
        per_axis = tuple(
            tuple(float(x) for x in Phi[a::3, a::3].ravel()) + tuple(float(x) for x in d[a::3])
            for a in range(3))
        return cls(blocks=nb, per_axis=per_axis, dense=None)

    def apply(self, L: list[float]) -> list[float]:
        """``Φ L + d`` for ``L`` a list of ``3·blocks`` floats (a new list)."""
        if self.dense is not None:
            P, d = self.dense
            out: list[float] = (np.array(L) @ P + d).tolist()
            return out
        per_axis = self.per_axis
        out = [0.0] * len(L)
        if self.blocks == 5:
            for a in range(3):
                (f00, f01, f02, f03, f04, f10, f11, f12, f13, f14, f20, f21, f22, f23, f24,
                 f30, f31, f32, f33, f34, f40, f41, f42, f43, f44, d0, d1, d2, d3, d4) = per_axis[a]
                x0, x1, x2, x3, x4 = L[a], L[3 + a], L[6 + a], L[9 + a], L[12 + a]
                out[a] = f00 * x0 + f01 * x1 + f02 * x2 + f03 * x3 + f04 * x4 + d0
                out[3 + a] = f10 * x0 + f11 * x1 + f12 * x2 + f13 * x3 + f14 * x4 + d1
                out[6 + a] = f20 * x0 + f21 * x1 + f22 * x2 + f23 * x3 + f24 * x4 + d2
                out[9 + a] = f30 * x0 + f31 * x1 + f32 * x2 + f33 * x3 + f34 * x4 + d3
                out[12 + a] = f40 * x0 + f41 * x1 + f42 * x2 + f43 * x3 + f44 * x4 + d4
        else:
            for a in range(3):
                (f00, f01, f02, f03, f10, f11, f12, f13, f20, f21, f22, f23,
                 f30, f31, f32, f33, d0, d1, d2, d3) = per_axis[a]
                x0, x1, x2, x3 = L[a], L[3 + a], L[6 + a], L[9 + a]
                out[a] = f00 * x0 + f01 * x1 + f02 * x2 + f03 * x3 + d0
                out[3 + a] = f10 * x0 + f11 * x1 + f12 * x2 + f13 * x3 + d1
                out[6 + a] = f20 * x0 + f21 * x1 + f22 * x2 + f23 * x3 + d2
                out[9 + a] = f30 * x0 + f31 * x1 + f32 * x2 + f33 * x3 + d3
        return out


@dataclass(frozen=True)
class SplitConstants:
    """The constants of the ``A`` and ``B`` sub-flows, as floats.

    Attributes
    ----------
    gamma : (3,) tuple of float
        Eigenvalues ``γ_i`` of ``Γ`` (its diagonal when ``Γ`` is diagonal).
    V : 9-tuple of float or None
        Eigenvectors of ``Γ`` (row-major), ``None`` when ``Γ`` is diagonal.
    m_n : (3,) tuple of float
        ``mⁿ``.
    Sn, Sn2 : 9-tuples of float
        ``S(mⁿ)`` and ``S(mⁿ)²`` (row-major): ``A_n = [mⁿ, S(mⁿ) ẑ, S(mⁿ)² ẑ]``.
    """

    gamma: tuple[float, float, float]
    V: Mat3 | None
    m_n: tuple[float, float, float]
    Sn: Mat3
    Sn2: Mat3

    @classmethod
    def build(cls, gamma: Array, V: Array | None, m_n: Array, Sn_powers: Array) -> SplitConstants:
        """From the observer's ``γ``, ``V``, ``mⁿ`` and ``[S(mⁿ), S(mⁿ)²]`` (``(2, 3, 3)``)."""
        g0, g1, g2 = (float(x) for x in gamma)
        m0, m1, m2 = (float(x) for x in m_n)
        return cls(gamma=(g0, g1, g2), V=None if V is None else tuple(float(x) for x in np.ravel(V)),
                   m_n=(m0, m1, m2), Sn=tuple(float(x) for x in Sn_powers[0].ravel()),
                   Sn2=tuple(float(x) for x in Sn_powers[1].ravel()))


def split_step(k: SplitConstants, flow: ScalarFlow, h: float, L: list[float], R: Floats,
               w: Floats, a: Floats, m: Floats) -> tuple[list[float], Mat3, tuple[float, float, float]]:
    """One Strang step ``C(h/2) A(h/2) B(h) A(h/2) C(h/2)`` of observer (24) for one flight.

    Parameters
    ----------
    k : SplitConstants
    flow : ScalarFlow
        ``C(h/2)`` (with or without injection, as the flight's ``has_fix``).
    h : float
        The IMU period.
    L : list of float
        ``[p̂, v̂, ẑ, y_p, (y_v)]`` at the start of the step, ``ẑ = R̂ a^b + ξ``.
    R : sequence of 9 floats
        ``R̂`` (row-major).
    w, a, m : sequences of 3 floats
        The held IMU sample ``ω^b``, ``a^b``, ``m^b``.

    Returns
    -------
    L : list of float
        ``[p̂, v̂, ẑ, y_p, (y_v)]`` at the end of the step.
    R : 9-tuple of float
        ``R̂`` at the end of the step.
    Ra : 3-tuple of float
        ``R̂ a^b`` at the end of the step (``ξ = ẑ − R̂ a^b``).
    """
    a0, a1, a2 = a
    m0, m1, m2_ = m
    L = flow.apply(L)                                                   # C(h/2)
    hh = 0.5 * h
    E = exp_so3_scalar(w[0] * hh, w[1] * hh, w[2] * hh)                       # A(h/2)
    RE = _mm(R, E)
    D = [x - y for x, y in zip(RE, R)]                                  # ẑ += (R̂ E − R̂) a^b
    z0 = L[6] + (D[0] * a0 + D[1] * a1 + D[2] * a2)
    z1 = L[7] + (D[3] * a0 + D[4] * a1 + D[5] * a2)
    z2 = L[8] + (D[6] * a0 + D[7] * a1 + D[8] * a2)
    # B(h): A_b's columns m, c = m × a, m × c (orthogonal), normalised into U
    c0, c1, c2 = m1 * a2 - m2_ * a1, m2_ * a0 - m0 * a2, m0 * a1 - m1 * a0
    mm = m0 * m0 + m1 * m1 + m2_ * m2_
    q = c0 * c0 + c1 * c1 + c2 * c2
    if not q > 1e-18 * mm * (a0 * a0 + a1 * a1 + a2 * a2):
        # m^b ∥ a^b (TRIAD condition violated): μ₂ = μ₃ = 0, any orthonormal completion of U will do
        if abs(m0) < 0.9 * math.sqrt(mm):
            c0, c1, c2 = 0.0, m2_, -m1                                  # m × e₁
        else:
            c0, c1, c2 = -m2_, 0.0, m0                                  # m × e₂
    e0, e1, e2 = m1 * c2 - m2_ * c1, m2_ * c0 - m0 * c2, m0 * c1 - m1 * c0
    n0 = math.sqrt(m0 * m0 + m1 * m1 + m2_ * m2_)
    n1 = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    n2 = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    U = (m0 / n0, c0 / n1, e0 / n2, m1 / n0, c1 / n1, e1 / n2, m2_ / n0, c2 / n1, e2 / n2)
    s0, s1, s2 = mm, q, mm * q                                          # μ_j = |c_j|²
    Sn, Sn2, mn = k.Sn, k.Sn2, k.m_n
    An = (mn[0], Sn[0] * z0 + Sn[1] * z1 + Sn[2] * z2, Sn2[0] * z0 + Sn2[1] * z1 + Sn2[2] * z2,
          mn[1], Sn[3] * z0 + Sn[4] * z1 + Sn[5] * z2, Sn2[3] * z0 + Sn2[4] * z1 + Sn2[5] * z2,
          mn[2], Sn[6] * z0 + Sn[7] * z1 + Sn[8] * z2, Sn2[6] * z0 + Sn2[7] * z1 + Sn2[8] * z2)
    r0 = -math.sqrt(max(s0, 1e-300))
    r1 = -math.sqrt(max(s1, 1e-300))
    r2 = -math.sqrt(max(s2, 1e-300))
    V = k.V
    T = _mm(RE, U) if V is None else _mm(_mTm(V, RE), U)
    W = An if V is None else _mTm(V, An)
    expm1 = math.expm1
    X = []
    for i in range(3):
        gi = -h * k.gamma[i]
        x0, x1, x2 = expm1(gi * s0), expm1(gi * s1), expm1(gi * s2)
        X += ((1.0 + x0) * T[3 * i] + x0 / r0 * W[3 * i],
              (1.0 + x1) * T[3 * i + 1] + x1 / r1 * W[3 * i + 1],
              (1.0 + x2) * T[3 * i + 2] + x2 / r2 * W[3 * i + 2])
    R1 = _mmT(tuple(X), U) if V is None else _mmT(_mm(V, tuple(X)), U)
    xi0 = z0 - (R1[0] * a0 + R1[1] * a1 + R1[2] * a2)
    xi1 = z1 - (R1[3] * a0 + R1[4] * a1 + R1[5] * a2)
    xi2 = z2 - (R1[6] * a0 + R1[7] * a1 + R1[8] * a2)
    R2 = _mm(R1, E)                                                     # A(h/2)
    Ra = (R2[0] * a0 + R2[1] * a1 + R2[2] * a2, R2[3] * a0 + R2[4] * a1 + R2[5] * a2,
          R2[6] * a0 + R2[7] * a1 + R2[8] * a2)
    L[6], L[7], L[8] = xi0 + Ra[0], xi1 + Ra[1], xi2 + Ra[2]
    return flow.apply(L), R2, Ra                                        # C(h/2)
