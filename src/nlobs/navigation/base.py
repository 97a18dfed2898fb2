"""Shared navigation data types, the channel layouts of the observer protocol, and conventions.

Conventions (Grip, Saberi & Johansen, Sec. 5; tested in ``tests/test_navigation_conventions.py``):

* Earth-fixed frame: local **NED** (north, east, down), treated as inertial.
* ``R`` maps **body to Earth** (NED) coordinates: ``vⁿ = R v^b``; ``Ṙ = R S(ω^b)``
  with ``ω^b`` the body angular rate in body axes and ``S(a) b = a × b``.
* Gravity ``gⁿ = [0, 0, +g]`` (down is positive in NED), ``v̇ⁿ = aⁿ + gⁿ`` where
  ``aⁿ = R a^b`` is the proper acceleration; the accelerometer reads the
  **specific force** ``a^b = Rᵀ(v̇ⁿ − gⁿ)`` (a level aircraft at rest reads
  ``a^b = [0, 0, −g]``).
* Magnetometer: ``m^b = Rᵀ mⁿ`` with ``mⁿ`` the known Earth field in NED.
* Euler angles: ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (aerospace ZYX), angles in radians.
* ``vec`` stacks the **columns** of a matrix (the paper's ``x = vec R``); the navigation
  vector below stores ``R`` **row-major** (``R.reshape(9)``) instead.

Channel layouts
---------------
The navigation filters are observers of :mod:`nlobs.observers.base` run by
:func:`nlobs.simulate.run_observer` (through :func:`nlobs.navigation.run.run_navigation`):

* input ``u`` (the IMU, at every step), 9 channels :data:`IMU_INPUTS`:
  ``[ω^b (3) rad/s, a^b (3) m/s², m^b (3)]`` (slices :data:`IMU_OMEGA`, :data:`IMU_ACCEL`,
  :data:`IMU_MAG`);
* output ``y`` (a GNSS fix, at its instants), 6 channels :data:`GNSS_OUTPUTS`:
  ``[p (3) m, v (3) m/s]`` in NED, or 3 (:data:`GNSS_OUTPUTS_P`) for a position-only receiver
  (Sec. 5.2, ``C = [I 0]``); a non-finite entry makes the fix missing for that flight;
* state / estimate ``x``, 15 components :data:`NAV_STATES`: ``[p (3), v (3), R (9, row-major)]``
  (:func:`nav_vector`, :func:`split_nav`).

:class:`SensorData` gives these arrays for a recorded flight (:meth:`SensorData.imu_input`,
:meth:`SensorData.gnss_output`, :meth:`SensorData.truth`).

Arrays carry a leading batch axis (Monte Carlo flights) where noted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import as_strided
from numpy.typing import ArrayLike, NDArray

from nlobs._typing import Array, BoolArray
from nlobs.errors import DimensionError

__all__ = [
    "G0", "GNSS_OUTPUTS", "GNSS_OUTPUTS_P", "GNSS_P", "GNSS_V", "IMU_ACCEL", "IMU_INPUTS", "IMU_MAG", "IMU_OMEGA",
    "NAV_P", "NAV_R", "NAV_STATES", "NAV_V", "GnssSample", "ImuSample", "NavEstimate", "SensorData", "nav_vector",
    "split_nav",
]

#: Standard gravity used by the generators, m/s².
G0 = 9.80665

#: Names of the IMU input channels ``u = [ω^b, a^b, m^b]`` (body axes x, y, z).
IMU_INPUTS = ("omega_x", "omega_y", "omega_z", "a_x", "a_y", "a_z", "m_x", "m_y", "m_z")
#: Slices of ``u``: body rate [rad/s], specific force [m/s²], magnetic field [field units].
IMU_OMEGA, IMU_ACCEL, IMU_MAG = slice(0, 3), slice(3, 6), slice(6, 9)

#: Names of the GNSS output channels ``y = [p, v]`` (NED).
GNSS_OUTPUTS = ("gnss_p_n", "gnss_p_e", "gnss_p_d", "gnss_v_n", "gnss_v_e", "gnss_v_d")
#: Names of the output channels of a position-only receiver, ``y = p``.
GNSS_OUTPUTS_P = GNSS_OUTPUTS[:3]
#: Slices of ``y``: position [m], velocity [m/s].
GNSS_P, GNSS_V = slice(0, 3), slice(3, 6)

#: Names of the navigation state/estimate ``x = [p, v, R]``, ``R`` row-major.
NAV_STATES = ("p_n", "p_e", "p_d", "v_n", "v_e", "v_d",
              "R11", "R12", "R13", "R21", "R22", "R23", "R31", "R32", "R33")
#: Slices of ``x``: position [m], velocity [m/s], attitude (row-major 3×3).
NAV_P, NAV_V, NAV_R = slice(0, 3), slice(3, 6), slice(6, 15)


def nav_vector(p: ArrayLike, v: ArrayLike, R: ArrayLike) -> Array:
    """The navigation vector ``[p, v, R.reshape(9)]``, shape ``(..., 15)`` (batch shapes broadcast).

    Parameters
    ----------
    p, v : array_like, shape (..., 3)
        Position [m] and velocity [m/s] in NED.
    R : array_like, shape (..., 3, 3)
        Attitude (body → NED), stored row-major.

    Returns
    -------
    ndarray, shape (..., 15)
        A new array.

    Raises
    ------
    DimensionError
        Wrong trailing shapes, or batch shapes that do not broadcast.

    Examples
    --------
    A level aircraft heading east (``R = Rz(90°)``) at 40 m/s, 300 m up: ``R`` follows ``p`` and ``v`` row by
    row, and one attitude broadcasts over a batch of two positions:

    >>> import numpy as np
    >>> R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    >>> x = nav_vector([0.0, 0.0, -300.0], [0.0, 40.0, 0.0], R)
    >>> x.shape, x[:6].tolist()
    ((15,), [0.0, 0.0, -300.0, 0.0, 40.0, 0.0])
    >>> bool(np.array_equal(x[NAV_R], R.reshape(9))), float(dict(zip(NAV_STATES, x))["R12"])
    (True, -1.0)
    >>> nav_vector([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]], np.zeros(3), R).shape
    (2, 15)
    >>> try:
    ...     nav_vector(np.zeros(3), np.zeros(3), np.eye(2))
    ... except DimensionError as exc:
    ...     print(type(exc).__name__, exc)
    DimensionError nav_vector: expected p, v of shape (..., 3) and R of shape (..., 3, 3), got (3,), (3,), (2, 2)
    """
    p_, v_, R_ = (np.asarray(a, dtype=float) for a in (p, v, R))
    if p_.shape[-1:] != (3,) or v_.shape[-1:] != (3,) or R_.shape[-2:] != (3, 3):
        raise DimensionError(f"nav_vector: expected p, v of shape (..., 3) and R of shape (..., 3, 3), got "
                             f"{p_.shape}, {v_.shape}, {R_.shape}")
    try:
        batch = np.broadcast_shapes(p_.shape[:-1], v_.shape[:-1], R_.shape[:-2])
    except ValueError:
        raise DimensionError(f"nav_vector: batch shapes {p_.shape[:-1]}, {v_.shape[:-1]}, {R_.shape[:-2]} "
                             "do not broadcast") from None
    out = np.empty((*batch, 15))
    out[..., NAV_P] = p_
    out[..., NAV_V] = v_
    out[..., NAV_R] = R_.reshape(*R_.shape[:-2], 9)
    return out


def split_nav(x: ArrayLike) -> tuple[Array, Array, Array]:
    """``(p, v, R)`` of navigation vectors ``x`` of shape ``(..., 15)`` (views where possible).

    Parameters
    ----------
    x : array_like, shape (..., 15)
        Navigation vectors ``[p, v, R]`` (:func:`nav_vector`, ``R`` row-major).

    Returns
    -------
    p, v : ndarray, shape (..., 3)
    R : ndarray, shape (..., 3, 3)

    Raises
    ------
    DimensionError
        ``x`` is not of shape ``(..., 15)``.

    Examples
    --------
    The inverse of :func:`nav_vector`, for one vector or a batch (``R`` is read row-major):

    >>> import numpy as np
    >>> R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    >>> p, v, R_back = split_nav(nav_vector([1.0, 2.0, -3.0], [0.0, 40.0, 0.0], R))
    >>> p.tolist(), v.tolist(), bool(np.array_equal(R_back, R))
    ([1.0, 2.0, -3.0], [0.0, 40.0, 0.0], True)
    >>> [a.shape for a in split_nav(np.zeros((4, 100, 15)))]  # 4 flights of 100 samples
    [(4, 100, 3), (4, 100, 3), (4, 100, 3, 3)]
    >>> try:
    ...     split_nav(np.zeros(9))
    ... except DimensionError as exc:
    ...     print(type(exc).__name__, exc)
    DimensionError split_nav: expected shape (..., 15), got (9,)
    """
    a = np.asarray(x, dtype=float)
    if a.shape[-1:] != (15,):
        raise DimensionError(f"split_nav: expected shape (..., 15), got {a.shape}")
    return a[..., NAV_P], a[..., NAV_V], a[..., NAV_R].reshape(*a.shape[:-1], 3, 3)


def _side_by_side(parts: tuple[object, ...]) -> Array | None:
    """The ``(..., 3k)`` array whose column blocks are ``parts`` when they already lie side by side in one
    buffer (equal shapes and strides, contiguous 3-blocks at consecutive offsets), as a read-only view; else None."""
    first = parts[0]
    if not all(isinstance(q, np.ndarray) and q.dtype == np.float64 for q in parts):
        return None
    arrs: list[np.ndarray] = list(parts)  # type: ignore[arg-type]
    base = first.base if isinstance(first, np.ndarray) else None
    if base is None or any(q.base is not base or q.shape != first.shape or q.strides != first.strides
                           for q in arrs):
        return None
    item = first.itemsize
    if first.ndim < 1 or first.shape[-1] != 3 or first.strides[-1] != item:
        return None
    start = first.__array_interface__["data"][0]
    if any(q.__array_interface__["data"][0] != start + 3 * i * item for i, q in enumerate(arrs)):
        return None
    return as_strided(first, shape=(*first.shape[:-1], 3 * len(arrs)), strides=first.strides, writeable=False)


@dataclass(frozen=True)
class ImuSample:
    """One IMU (+ magnetometer) sample, each of shape ``(..., 3)``: body rate [rad/s],
    specific force [m/s²], magnetic field in body axes [normalised units].

    Attributes
    ----------
    omega_b : ndarray, shape (..., 3)
        Body angular rate ``ω^b`` [rad/s].
    a_b : ndarray, shape (..., 3)
        Specific force ``a^b`` [m/s²].
    m_b : ndarray, shape (..., 3)
        Magnetic field in body axes ``m^b`` [normalised units].
    """

    omega_b: Array
    a_b: Array
    m_b: Array


@dataclass(frozen=True)
class GnssSample:
    """One GNSS fix: position [m] and velocity [m/s] in NED, each ``(..., 3)``.

    ``valid`` (shape ``(...)``, bool) is False where the fix is missing or has a
    non-finite entry; filters must skip invalid fixes (per batch member).
    ``v`` is ``None`` for a position-only receiver (Grip, Saberi & Johansen, Sec. 5.2, C = [I 0]).

    Attributes
    ----------
    p : ndarray, shape (..., 3)
        Measured position [m] in NED.
    v : ndarray, shape (..., 3), or None
        Measured velocity [m/s] in NED; ``None`` for a position-only receiver.
    valid : ndarray of bool, shape (...)
        True where the fix is present and finite.
    """

    p: Array
    v: Array | None
    valid: NDArray[np.bool_]


@dataclass(frozen=True)
class NavEstimate:
    """A navigation estimate: ``p``, ``v`` of shape ``(..., 3)``, ``R`` of shape ``(..., 3, 3)``.

    ``R`` is the filter's attitude estimate projected onto SO(3) (the ``R̂`` of observer (24)
    of Grip, Saberi & Johansen is not a rotation matrix in general; see their Sec. 5.2).

    Attributes
    ----------
    p, v : ndarray, shape (..., 3)
        Estimated position [m] and velocity [m/s] in NED.
    R : ndarray, shape (..., 3, 3)
        Estimated attitude (body → NED), projected onto SO(3).
    """

    p: Array
    v: Array
    R: Array


@dataclass(frozen=True)
class SensorData:
    """Sampled sensor streams of one flight, possibly for a batch of noise realisations.

    Attributes
    ----------
    t_imu : ndarray, shape (K,)
        IMU sample times [s] (uniform, ``imu_rate_hz``).
    omega_b, a_b, m_b : ndarray, shape (..., K, 3)
        Measured body rate [rad/s], specific force [m/s²], magnetic field.
    t_gnss : ndarray, shape (G,)
        GNSS fix times [s]; each is (to rounding) one of ``t_imu``.
    p_gnss : ndarray, shape (..., G, 3)
        Measured position [m]; may contain NaN for a missing fix.
    v_gnss : ndarray, shape (..., G, 3), or None
        Measured velocity [m/s], or None for a position-only receiver.
    m_n, g_n : ndarray, shape (3,)
        Earth magnetic field and gravity in NED.
    p, v : ndarray, shape (K, 3)
        True position [m] and velocity [m/s] at ``t_imu``.
    R : ndarray, shape (K, 3, 3)
        True attitude.
    imu_rate_hz, gnss_rate_hz : float
        The rates [Hz] (required, never defaulted).

    :meth:`imu_input`, :meth:`gnss_output` and :meth:`truth` give the arrays
    :func:`nlobs.simulate.run_observer` takes (channel layouts of the module docstring).

    Examples
    --------
    Two seconds of an aircraft standing level on the runway, heading north, sampled without noise by
    :func:`~nlobs.navigation.sensors.generate_sensors` (IMU at 10 Hz, GNSS at 1 Hz): the accelerometer
    reads the specific force ``a^b = [0, 0, −g]`` and the magnetometer ``m^b = mⁿ``:

    >>> import numpy as np
    >>> from nlobs.navigation.sensors import SensorNoise, generate_sensors
    >>> from nlobs.navigation.trajectory import M_N_DEFAULT, Trajectory
    >>> t = np.arange(21) / 10.0
    >>> still, level = np.zeros((21, 3)), np.broadcast_to(np.eye(3), (21, 3, 3))
    >>> g_n = np.array([0.0, 0.0, G0])
    >>> traj = Trajectory(t=t, p=still, v=still, vdot=still, R=level, rpy=still, omega_b=still,
    ...                   a_b=np.tile(-g_n, (21, 1)), m_b=np.tile(M_N_DEFAULT, (21, 1)), m_n=M_N_DEFAULT, g_n=g_n)
    >>> data = generate_sensors(traj, imu_rate_hz=10.0, gnss_rate_hz=1.0, noise=SensorNoise(), seed=0)
    >>> data.t_gnss.tolist(), data.imu_input().shape, data.gnss_output().shape, data.truth().shape
    ([0.0, 1.0, 2.0], (21, 9), (3, 6), (21, 15))
    >>> np.round(data.imu_input()[0, IMU_ACCEL], 5).tolist(), bool(np.allclose(data.m_b, M_N_DEFAULT))
    ([0.0, 0.0, -9.80665], True)
    >>> t_rec, u, y, sampled = data.record()  # the fixes on the IMU grid, as a compiled observer reads them
    >>> np.flatnonzero(sampled[:, 0]).tolist(), y.shape
    ([0, 10, 20], (21, 6))
    """

    t_imu: Array
    omega_b: Array
    a_b: Array
    m_b: Array
    t_gnss: Array
    p_gnss: Array
    v_gnss: Array | None
    m_n: Array
    g_n: Array
    p: Array
    v: Array
    R: Array
    imu_rate_hz: float
    gnss_rate_hz: float

    def imu_input(self) -> Array:
        """The IMU as the observers' input ``u = [ω^b, a^b, m^b]``, shape ``(..., K, 9)``.

        No copy when the three streams already lie side by side in one buffer (as
        :func:`~nlobs.navigation.sensors.generate_sensors` stores them, also for a flight
        sliced out of a batch): a read-only view of it. Otherwise one concatenation of the
        streams broadcast to a common batch shape.

        Raises
        ------
        DimensionError
            The streams are not of shape ``(..., K, 3)`` or their batch shapes do not broadcast.
        """
        fused = _side_by_side((self.omega_b, self.a_b, self.m_b))
        if fused is not None:
            return fused
        parts = [np.asarray(a, dtype=float) for a in (self.omega_b, self.a_b, self.m_b)]
        try:
            parts = list(np.broadcast_arrays(*parts))
        except ValueError:
            raise DimensionError(f"data: IMU shapes {[a.shape for a in parts]} do not broadcast") from None
        return np.concatenate(parts, axis=-1)

    def gnss_output(self) -> Array:
        """The GNSS fixes as the observers' output ``y = [p, v]``, shape ``(..., G, 6)``, or ``p``,
        ``(..., G, 3)``, for a position-only receiver (``v_gnss`` is None); NaN marks a missing fix.

        Raises
        ------
        DimensionError
            The batch shapes of ``p_gnss`` and ``v_gnss`` do not broadcast.
        """
        p = np.asarray(self.p_gnss, dtype=float)
        if self.v_gnss is None:
            return p
        fused = _side_by_side((self.p_gnss, self.v_gnss))
        if fused is not None:
            return fused
        v = np.asarray(self.v_gnss, dtype=float)
        try:
            return np.concatenate(np.broadcast_arrays(p, v), axis=-1)
        except ValueError:
            raise DimensionError(f"data: GNSS shapes {p.shape}, {v.shape} do not broadcast") from None

    def record(self) -> tuple[Array, Array, Array, BoolArray]:
        """The flight as one record on the IMU grid, as a compiled observer's ``run_record`` takes it.

        Returns
        -------
        t : ndarray, shape (K,)
            The IMU instants.
        u : ndarray, shape (..., K, 9)
            :meth:`imu_input`.
        y : ndarray, shape (..., K, 6) or (..., K, 3)
            Each fix of :meth:`gnss_output` at the IMU instant nearest its time, zeros elsewhere.
        sampled : ndarray of bool, shape (K, 6) or (K, 3)
            Where a fix was taken.
        """
        t = np.ascontiguousarray(self.t_imu, dtype=float)
        fixes = self.gnss_output()
        k = np.rint((np.asarray(self.t_gnss, dtype=float) - t[0]) * float(self.imu_rate_hz)).astype(np.intp)
        y = np.zeros((*fixes.shape[:-2], t.size, fixes.shape[-1]))
        y[..., k, :] = fixes
        sampled = np.zeros((t.size, fixes.shape[-1]), dtype=bool)
        sampled[k] = True
        return t, np.ascontiguousarray(self.imu_input()), y, sampled

    def truth(self) -> Array:
        """The true navigation vector ``[p, v, R]`` on the IMU grid, shape ``(K, 15)`` (:func:`nav_vector`)."""
        return nav_vector(self.p, self.v, self.R)
