"""Rotation-group utilities: skew matrices, exponential/logarithm, projection, Euler angles.

Conventions (see :mod:`nlobs.navigation.base`): ``R`` maps **body to Earth** (NED)
coordinates, ``Ṙ = R S(ω^b)`` with ``S(a) b = a × b`` (Grip, Saberi & Johansen, (21)), and
Euler angles are aerospace ZYX, ``R = Rz(yaw) Ry(pitch) Rx(roll)``.

Every function is batched over leading axes: a ``(..., 3)`` vector argument gives
a ``(..., 3, 3)`` matrix result and vice versa. Only shapes are checked (cheaply,
these functions sit in filter inner loops); NaN entries propagate to NaN results.
The name ``S`` of the paper is spelled :func:`skew` here.

Rodrigues' formula has one NumPy implementation, :func:`exp_so3` (batch axes first), with
:func:`exp_so3_columns` the same formula on the batch-last layout ``(3, n) → (3, 3, n)`` that the
GNSS/INS observer's large-batch step uses (there every 3×3 product is an ``einsum`` over contiguous
rows of length ``n``; transposing :func:`exp_so3`'s result would cost twice as much). The fused
single-flight form on Python floats is :func:`nlobs.navigation.split_kernel.exp_so3_scalar`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import readonly
from nlobs.errors import DimensionError


__all__ = [
    "skew",
    "unskew",
    "exp_so3",
    "exp_so3_columns",
    "skew_columns",
    "log_so3",
    "project_so3",
    "euler_from_R",
    "R_from_euler",
    "angle_between",
    "rot_x",
    "rot_y",
    "rot_z",
    "quat_from_R",
]

# Below this angle [rad] the Rodrigues coefficients use their Taylor series.
_SMALL = 1e-3


def _vec3(name: str, a: ArrayLike) -> Array:
    arr = np.asarray(a, dtype=float)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise DimensionError(f"{name}: expected shape (..., 3), got {arr.shape}")
    return arr


def _mat3(name: str, M: ArrayLike) -> Array:
    arr = np.asarray(M, dtype=float)
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise DimensionError(f"{name}: expected shape (..., 3, 3), got {arr.shape}")
    return arr


def skew(a: ArrayLike) -> Array:
    """The skew-symmetric matrix ``S(a)`` with ``S(a) b = a × b`` (Grip, Saberi & Johansen, Sec. 5).

    Parameters
    ----------
    a : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``[[0, -a3, a2], [a3, 0, -a1], [-a2, a1, 0]]``.
    """
    a = _vec3("skew: a", a)
    out = np.zeros(a.shape + (3,))
    out[..., 0, 1] = -a[..., 2]
    out[..., 0, 2] = a[..., 1]
    out[..., 1, 0] = a[..., 2]
    out[..., 1, 2] = -a[..., 0]
    out[..., 2, 0] = -a[..., 1]
    out[..., 2, 1] = a[..., 0]
    return out


def unskew(M: ArrayLike) -> Array:
    """Inverse of :func:`skew`: the vector ``a`` with ``S(a)`` the skew part of ``M``.

    For a non-skew ``M`` this returns the vector of its skew-symmetric part
    ``(M − Mᵀ)/2``, which is what ``ω^b = unskew(Rᵀ Ṙ)`` needs numerically.

    Parameters
    ----------
    M : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    M = _mat3("unskew: M", M)
    return 0.5 * np.stack(
        [M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]],
        axis=-1,
    )


#: ``S(x) = (_S9 @ x).reshape(3, 3, n)`` for ``x`` of shape ``(3, n)`` (batch last; exact: one ±1 per row).
_S9 = np.zeros((9, 3))
_S9[1, 2], _S9[2, 1], _S9[3, 2], _S9[5, 0], _S9[6, 1], _S9[7, 0] = -1.0, 1.0, 1.0, -1.0, -1.0, 1.0
_S9 = readonly(_S9, owned=True)
_I33 = readonly(np.eye(3)[:, :, None])
_S9T = readonly(np.ascontiguousarray(_S9.T))  # S(x) = (x @ _S9T).reshape(..., 3, 3), batch first
_EYE3 = readonly(np.eye(3))


def exp_so3(phi: ArrayLike) -> Array:
    r"""Rotation matrix ``exp(S(φ))`` by Rodrigues' formula, stable near ``φ = 0``.

    .. math:: \exp(S(\phi)) = I + \frac{\sin\theta}{\theta} S(\phi)
              + \frac{1-\cos\theta}{\theta^2} S(\phi)^2, \qquad \theta = \|\phi\|,

    with the coefficients replaced by their Taylor series for ``θ < 1e-3``.

    Parameters
    ----------
    phi : array_like, shape (..., 3)
        Rotation vector [rad] (axis times angle).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    phi = _vec3("exp_so3: phi", phi)
    A, B = _rodrigues_coefficients(np.sum(phi * phi, axis=-1))
    K = (phi @ _S9T).reshape(*phi.shape[:-1], 3, 3)  # S(φ), exactly (one ±φ_i per entry)
    return _EYE3 + A[..., None, None] * K + B[..., None, None] * (K @ K)


def _rodrigues_coefficients(th2: Array) -> tuple[Array, Array]:
    """``A = sin θ / θ`` and ``B = (1 − cos θ)/θ²`` of ``θ² = th2``, by their Taylor series below :data:`_SMALL`.

    The series and the closed forms are evaluated only where they are used (the same values as
    evaluating both everywhere and selecting).
    """
    th2 = np.asarray(th2)
    th = np.sqrt(th2)
    small = th < _SMALL
    if small.all():
        return np.asarray(1.0 - th2 / 6.0 + th2 * th2 / 120.0), np.asarray(0.5 - th2 / 24.0 + th2 * th2 / 720.0)
    some = bool(small.any())
    th_safe = np.where(small, 1.0, th) if some else th
    A = np.sin(th_safe) / th_safe
    B = (1.0 - np.cos(th_safe)) / (th_safe * th_safe)
    if some:
        A = np.where(small, 1.0 - th2 / 6.0 + th2 * th2 / 120.0, A)
        B = np.where(small, 0.5 - th2 / 24.0 + th2 * th2 / 720.0, B)
    return np.asarray(A), np.asarray(B)


def skew_columns(x: Array) -> Array:
    """:func:`skew` with the batch axis last: ``x`` of shape ``(3, n)`` → ``S(x)`` of shape ``(3, 3, n)`` (exact).

    Parameters
    ----------
    x : ndarray, shape (3, n)
        Vectors, one per column.

    Returns
    -------
    ndarray, shape (3, 3, n)
    """
    return (_S9 @ x).reshape(3, 3, -1)


def exp_so3_columns(phi: Array) -> Array:
    r"""Rodrigues' formula of :func:`exp_so3` with the batch axis **last**: ``φ`` of shape ``(3, n)`` →
    ``(3, 3, n)`` (row, column, member).

    The same coefficients ``A = sin θ/θ``, ``B = (1 − cos θ)/θ²`` (Taylor series below ``θ = 1e-3``),
    with ``S(φ)² = φφᵀ − θ² I`` written out: ``exp(S(φ)) = (1 − Bθ²) I + A S(φ) + B φφᵀ``. Equal to
    ``exp_so3(φ.T).transpose(1, 2, 0)`` to rounding (tested). No shape checks (an inner-loop helper).

    Parameters
    ----------
    phi : ndarray, shape (3, n)
        Rotation vectors [rad] (axis times angle), one per column.

    Returns
    -------
    ndarray, shape (3, 3, n)
    """
    th2 = np.einsum("in,in->n", phi, phi)
    A, B = _rodrigues_coefficients(th2)
    return skew_columns(A * phi) + phi[:, None] * (B * phi)[None, :] + _I33 * (1.0 - B * th2)


def quat_from_R(R: ArrayLike) -> Array:
    """Unit quaternion ``[w, x, y, z]`` (scalar first, ``w ≥ 0``) of a rotation matrix.

    Shepperd's method: the largest of ``(tr R, R11, R22, R33)`` selects the
    well-conditioned formula, so the result is accurate for every angle in
    ``[0, π]``. Same rotation as ``R`` (body→Earth): ``v_earth = q ⊗ v_body ⊗ q*``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 4)
    """
    R = _mat3("quat_from_R: R", R)
    r00, r11, r22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    tr = r00 + r11 + r22
    # The four candidate (un-normalised) quaternions, each times 4·q_i.
    c0 = np.stack([1.0 + tr, R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    c1 = np.stack([R[..., 2, 1] - R[..., 1, 2], 1.0 + r00 - r11 - r22, R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0]], -1)
    c2 = np.stack([R[..., 0, 2] - R[..., 2, 0], R[..., 0, 1] + R[..., 1, 0], 1.0 - r00 + r11 - r22, R[..., 1, 2] + R[..., 2, 1]], -1)
    c3 = np.stack([R[..., 1, 0] - R[..., 0, 1], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1], 1.0 - r00 - r11 + r22], -1)
    cands = np.stack([c0, c1, c2, c3], axis=-2)  # (..., 4, 4)
    which = np.argmax(np.stack([tr, r00, r11, r22], axis=-1), axis=-1)
    q = np.take_along_axis(cands, which[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q)


def log_so3(R: ArrayLike) -> Array:
    """Rotation vector ``φ`` with ``exp_so3(φ) = R``, ``‖φ‖ ∈ [0, π]``; stable near 0 and π.

    Computed from the quaternion (:func:`quat_from_R`): ``φ = 2 atan2(‖q_v‖, q_w) q_v/‖q_v‖``,
    with the small-angle limit ``φ ≈ 2 q_v / q_w``. At exactly ``π`` the sign of
    the axis is arbitrary (both represent the same rotation).

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices (a near-rotation gives the log of its quaternion fit).

    Returns
    -------
    ndarray, shape (..., 3)
    """
    q = quat_from_R(R)
    w = q[..., 0]
    qv = q[..., 1:]
    n = np.linalg.norm(qv, axis=-1)
    small = n < 1e-8
    n_safe = np.where(small, 1.0, n)
    w_safe = np.where(small, np.maximum(w, 1e-300), w)
    scale = np.where(small, 2.0 / w_safe, 2.0 * np.arctan2(n_safe, w) / n_safe)
    return scale[..., None] * qv


def project_so3(M: ArrayLike) -> Array:
    """The rotation nearest ``M`` in the Frobenius norm (orthogonal polar factor, ``det = +1``).

    ``M = U Σ Vᵀ`` → ``R = U diag(1, 1, det(U Vᵀ)) Vᵀ``. Used to post-orthogonalise
    the ``R̂`` of observer (24) (Grip, Saberi & Johansen, Sec. 5.2), which is not a rotation in general.

    Parameters
    ----------
    M : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    M = _mat3("project_so3: M", M)
    U, _, Vt = np.linalg.svd(M)
    d = np.sign(np.linalg.det(U @ Vt))
    d = np.where(d == 0, 1.0, d)
    U = U.copy()
    U[..., :, 2] *= d[..., None]
    return U @ Vt


def rot_x(angle: ArrayLike) -> Array:
    """Rotation about the x axis by ``angle`` [rad]: ``[[1,0,0],[0,c,-s],[0,s,c]]``; shape ``(...) → (..., 3, 3)``.

    Parameters
    ----------
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(angle: ArrayLike) -> Array:
    """Rotation about the y axis by ``angle`` [rad]: ``[[c,0,s],[0,1,0],[-s,0,c]]``; shape ``(...) → (..., 3, 3)``.

    Parameters
    ----------
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def rot_z(angle: ArrayLike) -> Array:
    """Rotation about the z axis by ``angle`` [rad]: ``[[c,-s,0],[s,c,0],[0,0,1]]``; shape ``(...) → (..., 3, 3)``.

    Parameters
    ----------
    angle : array_like, shape (...)
        Rotation angle [rad].

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def R_from_euler(rpy: ArrayLike) -> Array:
    """Body→Earth rotation from ZYX Euler angles: ``R = Rz(yaw) Ry(pitch) Rx(roll)``.

    Parameters
    ----------
    rpy : array_like, shape (..., 3)
        ``[roll, pitch, yaw]`` [rad].

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    rpy = _vec3("R_from_euler: rpy", rpy)
    return rot_z(rpy[..., 2]) @ rot_y(rpy[..., 1]) @ rot_x(rpy[..., 0])


def euler_from_R(R: ArrayLike) -> Array:
    """ZYX Euler angles ``[roll, pitch, yaw]`` [rad] of a body→Earth rotation.

    ``roll = atan2(R32, R33)``, ``pitch = atan2(−R31, hypot(R11, R21))``,
    ``yaw = atan2(R21, R11)``; roll and yaw in ``(−π, π]``, pitch in ``[−π/2, π/2]``.
    At ``pitch = ±π/2`` (gimbal lock) only ``yaw ∓ roll`` is defined; the split
    returned there is arbitrary.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3)
    """
    R = _mat3("euler_from_R: R", R)
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    pitch = np.arctan2(-R[..., 2, 0], np.hypot(R[..., 0, 0], R[..., 1, 0]))
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    return np.stack([roll, pitch, yaw], axis=-1)


def angle_between(R1: ArrayLike, R2: ArrayLike) -> Array:
    """Geodesic angle ``‖log(R1ᵀ R2)‖`` [rad] in ``[0, π]`` between two rotations (batched, broadcast).

    Parameters
    ----------
    R1, R2 : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (...)
    """
    R1 = _mat3("angle_between: R1", R1)
    R2 = _mat3("angle_between: R2", R2)
    q = quat_from_R(np.swapaxes(R1, -1, -2) @ R2)
    return 2.0 * np.arctan2(np.linalg.norm(q[..., 1:], axis=-1), q[..., 0])
