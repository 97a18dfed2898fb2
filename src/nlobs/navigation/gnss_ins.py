r"""The GNSS/INS observer of Grip, Saberi & Johansen, Sec. 5, as a correcting observer of :mod:`nlobs.observers.base`.

Dynamics (21), conventions of :mod:`nlobs.navigation.base` (NED, ``R`` body→Earth,
``gⁿ = [0, 0, +g]``, ``aⁿ = R a^b`` the proper acceleration, ``a^b`` the measured
specific force)::

    Ṙ = R S(ω^b),   ṗⁿ = vⁿ,   v̇ⁿ = aⁿ + gⁿ                                   (21)

Attitude observer (22), with the TRIAD-inspired injection ``J``::

    dR̂/dt = R̂ S(ω^b) + Γ J(m^b, mⁿ, a^b, aⁿ, R̂)                               (22)
    J = A_n A_bᵀ − R̂ A_b A_bᵀ,
    A_b = [m^b, m^b × a^b, m^b × (m^b × a^b)],  A_n likewise with mⁿ, aⁿ.

``aⁿ`` is not measured, so the complete observer (24) estimates it as
``ẑ = R̂ a^b + ξ`` from the linear subsystem ``ṗ = v, v̇ = z + gⁿ`` (Σ2)::

    dp̂/dt = v̂ + K_pp (p − p̂) + K_pv (v − v̂)                                (24a)
    dv̂/dt = R̂ a^b + ξ + gⁿ + K_vp (p − p̂) + K_vv (v − v̂)                     (24b)
    dξ/dt = −Γ J(m^b, mⁿ, a^b, R̂ a^b + ξ, R̂) a^b + K_zp (p − p̂) + K_zv (v − v̂) (24c)
    dR̂/dt = R̂ S(ω^b) + Γ J(m^b, mⁿ, a^b, R̂ a^b + ξ, R̂)                      (24d)

With ``K`` of the form ``kron(K3, I3)`` (see :mod:`nlobs.navigation.gains`) the
estimation error ``(p − p̂, v − v̂, z − ẑ)`` obeys the linear system
``(𝔄 − Kℭ) w̃ + 𝔅_d d̃`` with ``d̃ = (R − R̂)(ω^b × a^b + ȧ^b)`` (20a): the ``ΓJ``
terms cancel in ``dẑ/dt``. For the position-only receiver (Sec. 5.2,
``C = [I 0]``) the ``K_·v`` columns are absent and ``K`` is 9×3.

``R̂`` is **not** a rotation matrix in general (it converges to one);
:meth:`GnssInsObserver.estimate` returns its projection onto SO(3)
(post-orthogonalisation, Sec. 5.2); the recorded-data loop keeps the raw ``R̂``
(extra ``R_raw``, :meth:`GnssInsObserver.finish_estimates`) and ``ẑ`` (extra
``z_hat``, :meth:`GnssInsObserver.diagnostics`).

The observer protocol
---------------------
:class:`GnssInsObserver` is a :class:`~nlobs.observers.base.CorrectingObserver` with the
capabilities ``SelfStepping``, ``Diagnosing`` and ``DeferredEstimate``; the IMU is its input
``u = [ω^b, a^b, m^b]`` (9 channels) and a GNSS fix its sampled measurement ``y = [p, v]``
(6, or 3 for a position-only receiver), see :mod:`nlobs.navigation.base`. ``rhs`` is the
right-hand side of (24a)–(24d) with the measurement predictor, ``step`` its discretisation
over one IMU period, ``correct`` takes a fix, ``estimate`` is ``[p̂, v̂, R̂ projected]``.
``propagate`` and ``update`` are the same steps on the domain types
(:class:`~nlobs.navigation.base.ImuSample`, :class:`~nlobs.navigation.base.GnssSample`).

Sampled-data implementation
---------------------------
The observer is a continuous-time system; the data are sampled (IMU at, e.g.,
100 Hz, GNSS at 5 Hz). :meth:`~GnssInsObserver.step` integrates (24) over
one IMU period, the IMU sample held constant, with ``integrator="split"``
(default: one exponential Strang-splitting step, see :class:`GnssInsObserver`)
or ``integrator="rk4"`` (classical RK4, ``substeps`` steps). GNSS fixes enter through a *held measurement* ``(y_p, y_v)`` stored in
the state by :meth:`~GnssInsObserver.correct`; between fixes it is either

* ``intersample="hold"`` — held constant (zero-order hold, the literal reading
  of (24) with sampled ``p, v``), or
* ``intersample="predict"`` (default) — extrapolated with the model of Σ2 from
  the last fix: ``ẏ_p = y_v`` (``= v̂`` for a position-only receiver),
  ``ẏ_v = ẑ + gⁿ`` (an inter-sample output predictor in the spirit of
  Karafyllis & Kravaris). On exact data with exact estimates the predicted
  measurement equals the true one, so the observer stays at the truth; with
  the zero-order hold it does not: a held position lags the aircraft by up to
  ``v·Δt_gnss`` (10 m at 50 m/s and 5 Hz) and the large ``K_pp`` pulls ``p̂``
  back towards it. Measured on the exact traffic-pattern flight (100 Hz IMU,
  5 Hz fixes, t ≥ 120 s): position/velocity/attitude RMS 0.0006 m, 0.005 m/s,
  0.025° with the predictor; 4.2 m, 0.30 m/s, 0.34° with the zero-order hold.
  With ``K`` of the form ``kron(K3, I3)`` and constant ``aⁿ`` the predictor's
  error system is linear (``η = y_pred − ℭw``: ``w̃' = (𝔄 − Kℭ)w̃ − Kη``,
  ``η_p' = η_v``, ``η_v' = −z̃``, ``η = 0`` at each exact fix); the tests compare
  the observer with ``expm`` of it.

**Before the first valid fix** (per batch member) there is no injection: the
``K`` terms are zero and (24) runs open loop on the IMU. Invalid fixes
(``GnssSample.valid`` False) are skipped per batch member and counted in the
state (``skipped``).

RK4 step size (``integrator="rk4"``). The stiffest rates of (24) over one step are ``ρ(𝔄 − Kℭ)`` (the
linear part, ≈ 131 s⁻¹ for the paper's ``K``) and ``λmax(Γ) · λmax(A_b A_bᵀ)``
(the attitude loop: with ``ẑ`` frozen, ``R̂ ↦ −Γ R̂ A_b A_bᵀ`` has eigenvalues
``γ_i μ_j``, and ``μ = |m|², |m × a|², |m|² |m × a|²`` because the columns of
``A_b`` are orthogonal). The second depends on the data and on the units of
``m``: with a unit-norm magnetometer and ``|a| ≈ g`` it reaches ≈ 20 · 30 = 600 s⁻¹
for ``Γ = diag(20, 0.2, 0.2)``, beyond RK4's stability limit (``h ρ ≤ 2.785``)
at 100 Hz — a single RK4 step per IMU period then diverges (measured). With
``substeps=None`` (default) each IMU period is split into the fewest RK4 steps
with ``h ρ ≤ 2``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._typing import Array, BoolArray
from nlobs._validate import as_batch, as_matrix, as_symmetric, as_vector, readonly
from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.navigation.base import (
    GNSS_P,
    GNSS_V,
    IMU_ACCEL,
    IMU_MAG,
    IMU_OMEGA,
    NAV_R,
    GnssSample,
    ImuSample,
    nav_vector,
    split_nav,
)
from nlobs.navigation.polar import nearest_rotation
from nlobs.navigation.so3 import exp_so3, exp_so3_columns, project_so3, skew, skew_columns
from nlobs.simulate.integrators import rk4_step
from nlobs.navigation.split_kernel import ScalarFlow, SplitConstants, split_step
from nlobs.systems.timebase import CONTINUOUS, TimeBase
from nlobs.observers.base import ToControl

_INF = float("inf")

__all__ = ["GnssInsObserver", "GnssInsState", "triad_J", "triad_matrix"]

#: RK4's stability interval on the negative real axis.
RK4_STABILITY = 2.785
#: Largest ``h·ρ`` the automatic sub-stepping allows (inside the stability interval, with margin).
RK4_AUTO = 2.0
#: The most RK4 substeps the automatic rule takes in one IMU period (a longer period is refused, not run).
MAX_AUTO_SUBSTEPS = 100_000


def _cross(a: Array, b: Array) -> Array:
    """Batched cross product of ``(..., 3)`` arrays (cheaper than ``np.cross`` for small batches)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def triad_matrix(m: ArrayLike, a: ArrayLike) -> Array:
    """``A = [m, m × a, m × (m × a)]`` (columns), shape ``(..., 3, 3)`` (Grip, Saberi & Johansen, (22)).

    The columns are mutually orthogonal, so ``A Aᵀ`` has eigenvalues
    ``|m|², |m × a|², |m|² |m × a|²``.

    Parameters
    ----------
    m, a : array_like, shape (..., 3)
        Magnetic field and acceleration in one frame (``m^b, a^b`` or ``mⁿ, aⁿ``); batch shapes broadcast.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    m_ = np.asarray(m, dtype=float)
    a_ = np.asarray(a, dtype=float)
    ma = _cross(*np.broadcast_arrays(m_, a_))
    mma = _cross(np.broadcast_to(m_, ma.shape), ma)
    return np.stack([np.broadcast_to(m_, ma.shape), ma, mma], axis=-1)


def triad_J(m_b: ArrayLike, m_n: ArrayLike, a_b: ArrayLike, a_n: ArrayLike, R_hat: ArrayLike) -> Array:
    """The injection ``J = A_n A_bᵀ − R̂ A_b A_bᵀ`` of the attitude observer (22), batched.

    ``J = (R − R̂) A_b A_bᵀ`` when ``m_n = R m_b`` and ``a_n = R a_b``: it vanishes
    at the true attitude.

    Parameters
    ----------
    m_b : array_like, shape (..., 3)
        Measured magnetic field in body axes.
    m_n : array_like, shape (..., 3)
        Earth magnetic field in NED.
    a_b : array_like, shape (..., 3)
        Measured specific force [m/s²] in body axes.
    a_n : array_like, shape (..., 3)
        Acceleration ``aⁿ`` [m/s²] in NED (observer (24) uses its estimate ``ẑ``).
    R_hat : array_like, shape (..., 3, 3)
        Attitude estimate ``R̂`` (body → NED).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    Ab = triad_matrix(m_b, a_b)
    An = triad_matrix(m_n, a_n)
    AbT = np.swapaxes(Ab, -1, -2)
    return An @ AbT - np.asarray(R_hat, dtype=float) @ (Ab @ AbT)



@dataclass(frozen=True)
class GnssInsState:
    """State of :class:`GnssInsObserver` for a batch of flights (leading axes ``...``).

    Attributes
    ----------
    p, v, xi : (..., 3)
        ``p̂ⁿ``, ``v̂ⁿ`` and ``ξ`` of (24a)–(24c).
    R : (..., 3, 3)
        ``R̂`` of (24d) (not a rotation matrix in general).
    y_p : (..., 3)
        Held (or predicted) GNSS position.
    y_v : (..., 3) or None
        Held (or predicted) GNSS velocity (``None`` for a position-only observer).
    has_fix : (...) bool
        Whether a valid fix has arrived yet (no injection before).
    skipped : (...) int
        Number of invalid fixes skipped so far.

    Examples
    --------
    Two flights at rest at the origin, the paper's gains. A fix ``p = [1, 2, 3]``, ``v = [4, 5, 6]`` reaches
    the first, a non-finite fix the second: the correction only stores the fix (the observer injects it
    through ``K`` as it integrates), the second flight counts a skipped fix and keeps waiting. One IMU period
    later (level, at rest: ``R̂ a^b + gⁿ = 0``) only the first flight has moved: more than halfway to its fix:

    >>> import numpy as np
    >>> from nlobs.navigation.base import nav_vector
    >>> from nlobs.navigation.trajectory import M_N_DEFAULT
    >>> observer = GnssInsObserver.paper(M_N_DEFAULT, [0.0, 0.0, 9.80665])
    >>> state = observer.init(nav_vector(np.zeros((2, 3)), np.zeros(3), np.eye(3)))
    >>> state.batch_shape, state.has_fix.tolist(), state.xi.tolist()
    ((2,), [False, False], [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    >>> fixes = np.array([[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], [np.nan, 0.0, 0.0, 0.0, 0.0, 0.0]])
    >>> held = observer.correct(0.0, state, np.zeros(9), fixes, True)
    >>> held.has_fix.tolist(), held.skipped.tolist(), held.y_p[0].tolist(), held.y_v[0].tolist()
    ([True, False], [0, 1], [1.0, 2.0, 3.0], [4.0, 5.0, 6.0])
    >>> bool(np.array_equal(held.p, state.p))  # the estimate itself is not reset
    True
    >>> at_rest = np.r_[0.0, 0.0, 0.0, 0.0, 0.0, -9.80665, M_N_DEFAULT]  # [ω^b, a^b, m^b]
    >>> later = observer.step(0.0, held, at_rest, fixes, 0.01)
    >>> fix = np.array([1.0, 2.0, 3.0])
    >>> bool(np.linalg.norm(later.p[0] - fix) < 0.5 * np.linalg.norm(fix)), later.p[1].tolist()
    (True, [0.0, 0.0, 0.0])
    """

    p: Array
    v: Array
    xi: Array
    R: Array
    y_p: Array
    y_v: Array | None
    has_fix: NDArray[np.bool_]
    skipped: NDArray[np.int64]
    #: The floats ``[p̂, v̂, ξ, R̂ (row-major), y_p, (y_v)]`` of a state made by the fused single-flight
    #: kernel (whose arrays are then read-only views of them), else ``None``; never set by hand
    #: (``dataclasses.replace`` and the loops' arithmetic reset it).
    _flat: list[float] | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """The leading (batch) shape."""
        return tuple(self.p.shape[:-1])


@dataclass(frozen=True)
class GnssInsObserver(ToControl):
    """The complete GNSS/INS observer (24) of Grip, Saberi & Johansen (Sec. 5), a correcting observer.

    ``time = Continuous()``, ``n_x = 15`` (the estimate ``[p̂, v̂, R̂]``, module docstring).

    Parameters
    ----------
    K : array_like, shape (9, 6), or (9, 3) when ``position_only``
        Gain of (24a)–(24c): state order ``[p, v, z]``, measurement order
        ``[p, v]`` (``kron(K3, I3)`` for a per-axis design; see
        :mod:`nlobs.navigation.gains`). A general 9×6 matrix is accepted.
    Gamma : array_like, shape (3, 3)
        Symmetric positive-definite attitude gain ``Γ`` of (22)/(24c, d).
    m_n : array_like, shape (3,)
        Known Earth magnetic field ``mⁿ`` (NED, the magnetometer's units).
    g_n : array_like, shape (3,)
        Gravity ``gⁿ`` (NED, ``[0, 0, +g]``).
    position_only : bool
        Position-only receiver (Sec. 5.2, ``C = [I 0]``); fixes' velocities are ignored.
    intersample : {"hold", "predict"}
        How the GNSS measurement is carried between fixes (see the module docstring).
    substeps : int or None
        ``integrator="rk4"`` only (ignored by ``"split"``): RK4 steps per IMU period; ``None`` (default) chooses, per IMU period, the
        fewest steps with ``h · ρ ≤ 2`` where ``ρ`` is the stiffest rate of the
        step: ``max(ρ(𝔄 − Kℭ), λmax(Γ) · λmax(A_b A_bᵀ))``. With a fixed number,
        ``step`` raises when ``h · ρ`` exceeds RK4's stability limit 2.785.
    integrator : {"split", "rk4"}
        Discretisation of (24) over one IMU period ``h`` (see Notes). ``"split"``
        (default): one Strang step of exactly solved sub-flows, unconditionally
        stable on the stiff parts, ~4× cheaper than ``"rk4"`` with automatic substeps.
    kernel : {"auto", "batched", "scalar"}
        How ``integrator="split"`` evaluates a step. ``"batched"``: NumPy, vectorised
        over the batch axis. ``"scalar"``: the fused single-flight kernel of
        :mod:`nlobs.navigation.split_kernel` (plain-Python floats, no NumPy call in
        the arithmetic; about 3.5× cheaper than ``"batched"`` for one flight, same
        results to rounding); it needs a single flight (batch size 1). ``"auto"``
        (default): ``"scalar"`` for a single flight, ``"batched"`` otherwise.
        Ignored by ``integrator="rk4"`` (always batched) unless ``"scalar"``, which
        is refused there.
    name : str
        ``"observer"``.

    Raises
    ------
    DimensionError
        Wrong shape of ``K``, ``Gamma``, ``m_n`` or ``g_n``.
    NotSymmetricError
        ``Gamma`` is not symmetric.
    InvalidArgumentError
        ``Gamma`` is not positive definite, ``mⁿ`` is zero, bad ``intersample``,
        ``substeps``, ``integrator`` or ``kernel``.

    Notes
    -----
    **The split integrator.** With the IMU sample held, the right-hand side of
    (24a)–(24d) (plus the measurement predictor) is the sum of three vector fields,
    each solved exactly over a step:

    * ``C`` — the linear part (24a)–(24c) without ``ΓJ``, with ``R̂`` frozen.
      In ``L = [p̂, v̂, ẑ, y_p, (y_v)]``, ``ẑ = R̂ a^b + ξ``, it is linear with
      constant coefficients: ``ṗ = v̂ + K_p e``, ``v̇ = ẑ + gⁿ + K_v e``,
      ``ż = K_z e`` (``e = y − ℭ[p̂, v̂]``, ``K = 0`` before the first fix) and the
      predictor ``ẏ_p = y_v`` (or ``v̂``), ``ẏ_v = ẑ + gⁿ``. Its exact transition
      ``expm(F h)`` (augmented with the constant ``gⁿ``) is computed once per ``h``
      and cached, so the stiff ``ρ(𝔄 − Kℭ) ≈ 131 s⁻¹`` costs one matrix product.
    * ``A`` — the rotation ``dR̂/dt = R̂ S(ω^b)`` (ξ fixed): ``R̂ ← R̂ exp(S(ω^b) t)``.
    * ``B`` — the injection ``dR̂/dt = ΓJ``, ``dξ/dt = −ΓJ a^b`` of (24c, d). It leaves
      ``ẑ = R̂ a^b + ξ`` invariant, so ``A_n`` is constant and it is the affine ODE
      ``dR̂/dt = Γ(A_n A_bᵀ − R̂ M)``, ``M = A_b A_bᵀ``. The columns ``c_j`` of ``A_b``
      are orthogonal, so ``M = U diag(μ) Uᵀ`` with ``U = [c_j/|c_j|]``,
      ``μ = (|m|², |m × a|², |m|² |m × a|²)``, and ``A_n A_bᵀ U = A_n diag(|c_j|)``.
      With ``Γ = V diag(γ) Vᵀ`` (``V = I`` for a diagonal ``Γ``) the ODE decouples
      elementwise in ``R̃ = Vᵀ R̂ U``::

          R̃_ij(h) = e^{−γ_i μ_j h} R̃_ij(0) + (1 − e^{−γ_i μ_j h}) (Vᵀ A_n)_ij / |c_j|

      (``expm1``; the term vanishes as ``μ_j → 0``), then ``ξ = ẑ − R̂ a^b``. If
      ``m^b ∥ a^b`` (TRIAD condition violated) ``U`` is completed by any orthonormal
      pair: ``μ₂ = μ₃ = 0`` there, so the choice does not matter.

    One IMU period is ``C(h/2) A(h/2) B(h) A(h/2) C(h/2)`` (Strang; ``R̂ ↦ ẑ`` and
    ``ẑ ↦ ξ`` are the couplings). Every sub-flow is exact, so the step is stable for
    any ``h`` and ``Γ`` (the stiff parts contract exactly as the ODE does) and
    consistent; it is exact for the linear part alone (the expm test of the
    predictor's error system holds to 1e-12). On the paper's gains and a noisy
    traffic pattern (100 Hz) it stays within 2e-4 m and 0.04° of an RK4 reference
    with 10 substeps (RK4 with automatic substeps: 0.05 m, 0.23°); the error drops
    by 2–4× per halving of ``h``.

    **Cost.** Vectorised over a batch (``kernel="batched"``) a step is about 40
    NumPy calls on ``(..., 3, 3)`` arrays for a small batch, and about 40
    ``einsum``/elementwise calls on rows of length ``n`` with the batch axis last
    from :data:`BATCH_LAST_MIN` flights on; for one flight the fixed per-call
    overhead dominates, so ``kernel="auto"`` evaluates the same formulas on Python
    floats instead (:mod:`nlobs.navigation.split_kernel`, no NumPy call in the
    arithmetic). The three evaluations agree to rounding (tested to 1e-12).

    Examples
    --------
    The take-off of the traffic pattern of Grip, Saberi & Johansen (Sec. 5.2) with exact sensors (IMU at
    100 Hz, GNSS at 5 Hz), the paper's gains, the estimate started 30° off in yaw and 3.7 m off in position:

    >>> import math
    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.navigation import metrics, nav_vector, traffic_pattern
    >>> from nlobs.navigation.so3 import rot_z
    >>> traj = traffic_pattern(duration=10.0).sample(100.0)  # the first 10 s of the flight of Sec. 5.2, 100 Hz
    >>> u = np.hstack([traj.omega_b, traj.a_b, traj.m_b])  # exact IMU samples [ω^b, a^b, m^b]
    >>> fixes = slice(None, None, 20)  # exact GNSS fixes [p, v] at 5 Hz
    >>> y, truth = np.hstack([traj.p, traj.v])[fixes], nav_vector(traj.p, traj.v, traj.R)
    >>> x_hat0 = nav_vector(traj.p[0] + [3.0, -2.0, 1.0], traj.v[0], rot_z(math.radians(30.0)) @ traj.R[0])
    >>> observer = nlobs.GnssInsObserver.paper(traj.m_n, traj.g_n)
    >>> res = nlobs.run_observer(observer, traj.t, x_hat0=x_hat0, u=u, y=y, y_times=traj.t[fixes], truth=truth)
    >>> attitude, position = metrics.attitude_error_deg(res), metrics.position_error_m(res)
    >>> round(float(attitude[0]), 3), round(float(position[0]), 3)
    (30.0, 3.742)
    >>> bool(attitude[-1] < 1.0), bool(position[-1] < 0.05)
    (True, True)
    """

    K: Array
    Gamma: Array
    m_n: Array
    g_n: Array
    position_only: bool = False
    intersample: Literal["hold", "predict"] = "predict"
    substeps: int | None = None
    integrator: Literal["split", "rk4"] = "split"
    kernel: Literal["auto", "batched", "scalar"] = "auto"
    name: str = "observer"
    time: TimeBase = field(default=CONTINUOUS, init=False)
    _rho: float = field(init=False, repr=False, compare=False)
    _gamma: Array = field(init=False, repr=False, compare=False)
    _V: Array | None = field(init=False, repr=False, compare=False)
    _F: tuple[Array, Array] = field(init=False, repr=False, compare=False)
    _cache: dict = field(init=False, repr=False, compare=False)
    _gamma_max: float = field(init=False, repr=False, compare=False)
    _SmPowers: Array = field(init=False, repr=False, compare=False)
    _SmP: Array = field(init=False, repr=False, compare=False)
    _An0: Array = field(init=False, repr=False, compare=False)
    _m_n_col: Array = field(init=False, repr=False, compare=False)
    _gamma_col: Array = field(init=False, repr=False, compare=False)
    _scalar: SplitConstants = field(init=False, repr=False, compare=False)
    _scalar_cache: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        p = 3 if self.position_only else 6
        K = as_matrix("K", self.K)
        if K.shape != (9, p):
            want = "(9, 3) for a position-only observer" if self.position_only else "(9, 6) (p and v measured)"
            raise DimensionError(f"K: expected shape {want}, got {K.shape}")
        G = as_symmetric("Gamma", self.Gamma, 3)
        lam = np.linalg.eigvalsh(G)
        if lam[0] <= 0:
            raise InvalidArgumentError(f"Gamma: must be positive definite (smallest eigenvalue {lam[0]:.3g})")
        m_n = as_vector("m_n", self.m_n, 3)
        if not np.any(m_n):
            raise InvalidArgumentError("m_n: the Earth magnetic field must be non-zero")
        g_n = as_vector("g_n", self.g_n, 3)
        if self.intersample not in ("hold", "predict"):
            raise InvalidArgumentError(f"intersample: expected 'hold' or 'predict', got {self.intersample!r}")
        if self.substeps is not None:
            if not isinstance(self.substeps, (int, np.integer)) or isinstance(self.substeps, bool) or self.substeps < 1:
                raise InvalidArgumentError(f"substeps: expected a positive integer or None, got {self.substeps!r}")
            object.__setattr__(self, "substeps", int(self.substeps))
        if self.integrator not in ("split", "rk4"):
            raise InvalidArgumentError(f"integrator: expected 'split' or 'rk4', got {self.integrator!r}")
        if self.kernel not in ("auto", "batched", "scalar"):
            raise InvalidArgumentError(f"kernel: expected 'auto', 'batched' or 'scalar', got {self.kernel!r}")
        if self.kernel == "scalar" and self.integrator != "split":
            raise InvalidArgumentError("kernel: 'scalar' is the fused kernel of integrator='split', not of 'rk4'")
        for nm, val in (("K", K), ("Gamma", G), ("m_n", m_n), ("g_n", g_n)):
            object.__setattr__(self, nm, readonly(val))
        object.__setattr__(self, "_gamma_max", float(lam[-1]))
        Sm = skew(m_n)
        object.__setattr__(self, "_SmPowers", readonly(np.stack([Sm, Sm @ Sm])))
        # spectral radius of the linear error dynamics 𝔄 − Kℭ (9 states), for the RK4 step check
        I3, Z3 = np.eye(3), np.zeros((3, 3))
        A = np.block([[Z3, I3, Z3], [Z3, Z3, I3], [Z3, Z3, Z3]])
        C = np.hstack([I3, Z3, Z3]) if self.position_only else np.hstack([np.eye(6), np.zeros((6, 3))])
        object.__setattr__(self, "_rho", float(np.max(np.abs(np.linalg.eigvals(A - K @ C)))))
        # split integrator: Γ = V diag(γ) Vᵀ (V = None when Γ is diagonal) and the generators of the
        # linear sub-flow on L = [p̂, v̂, ẑ, y_p, (y_v)] augmented with a constant 1 (with / without a fix)
        if np.count_nonzero(G - np.diag(np.diag(G))) == 0:
            object.__setattr__(self, "_gamma", readonly(np.diag(G)))
            object.__setattr__(self, "_V", None)
        else:
            gam, V = np.linalg.eigh(G)
            object.__setattr__(self, "_gamma", readonly(gam))
            object.__setattr__(self, "_V", readonly(V))
        object.__setattr__(self, "_F", (readonly(self._linear_generator(K)), readonly(self._linear_generator(0.0 * K))))
        object.__setattr__(self, "_cache", {})
        Sm_n = self._SmPowers  # A_n = [mⁿ, S(mⁿ) ẑ, S(mⁿ)² ẑ] = (ẑ @ _SmP).reshape(3, 3) + _An0 (batch first)
        object.__setattr__(self, "_SmP", readonly(np.stack([np.zeros((3, 3)), Sm_n[0], Sm_n[1]], axis=-1)
                                             .transpose(1, 0, 2).reshape(3, 9)))
        object.__setattr__(self, "_An0", readonly(np.outer(m_n, [1.0, 0.0, 0.0])))
        object.__setattr__(self, "_m_n_col", readonly(m_n[:, None, None]))       # batch last
        object.__setattr__(self, "_gamma_col", readonly(self._gamma[:, None, None]))
        object.__setattr__(self, "_scalar", SplitConstants.build(self._gamma, self._V, m_n, self._SmPowers))
        object.__setattr__(self, "_scalar_cache", {})

    # ----------------------------------------------------------------- factory
    @classmethod
    def paper(cls, m_n: ArrayLike, g_n: ArrayLike, *, position_only: bool = False,
              intersample: Literal["hold", "predict"] = "predict", substeps: int | None = None,
              integrator: Literal["split", "rk4"] = "split",
              kernel: Literal["auto", "batched", "scalar"] = "auto") -> GnssInsObserver:
        """The observer with the paper's gains: ``Γ = diag(20, 0.2, 0.2)`` and ``K`` of Sec. 5.2.

        For ``position_only`` the paper gives no ``K``; the one designed by
        :func:`nlobs.navigation.gains.design_gains` with the paper's recipe is used.
        """
        from nlobs.navigation.gains import PAPER_GAMMA, paper_gains

        return cls(paper_gains(position_only), PAPER_GAMMA, m_n, g_n, position_only=position_only,
                   intersample=intersample, substeps=substeps, integrator=integrator, kernel=kernel)

    # ---------------------------------------------------------------- protocol
    @property
    def n_x(self) -> int:
        """15: the estimate is the navigation vector ``[p̂, v̂, R̂]`` (:data:`~nlobs.navigation.base.NAV_STATES`)."""
        return 15

    def init(self, x_hat0: ArrayLike) -> GnssInsState:
        """Initial state from a navigation vector ``x̂0 = [p̂, v̂, R̂]`` of shape ``(..., 15)`` (``ξ = 0``).

        See :meth:`init_state` (the same from ``p0, v0, R0`` and an optional ``ξ0``).
        """
        p, v, R = split_nav(x_hat0)
        return self.init_state(p, v, R)

    def init_state(self, p0: ArrayLike, v0: ArrayLike, R0: ArrayLike, xi0: ArrayLike | None = None) -> GnssInsState:
        """Initial state: ``p̂ = p0``, ``v̂ = v0``, ``R̂ = R0``, ``ξ = xi0`` (default 0, i.e. ``ẑ = R̂ a^b``).

        The inputs are broadcast to a common batch shape. No fix is held yet.

        Raises
        ------
        DimensionError
            Wrong trailing shapes or batch shapes that do not broadcast.
        NonFiniteError
            A non-finite entry.
        """
        p = as_batch("p0", p0, 3)
        v = as_batch("v0", v0, 3)
        R = as_batch("R0", R0, 3)
        if R.ndim < 2 or R.shape[-2] != 3:
            raise DimensionError(f"R0: expected shape (..., 3, 3), got {R.shape}")
        xi = np.zeros(3) if xi0 is None else as_batch("xi0", xi0, 3)
        try:
            batch = np.broadcast_shapes(p.shape[:-1], v.shape[:-1], R.shape[:-2], xi.shape[:-1])
        except ValueError:
            raise DimensionError(
                f"p0, v0, R0, xi0: batch shapes {p.shape[:-1]}, {v.shape[:-1]}, {R.shape[:-2]}, "
                f"{xi.shape[:-1]} do not broadcast") from None
        b3 = (*batch, 3)
        return GnssInsState(
            p=np.broadcast_to(p, b3).copy(), v=np.broadcast_to(v, b3).copy(),
            xi=np.broadcast_to(xi, b3).copy(), R=np.broadcast_to(R, (*batch, 3, 3)).copy(),
            y_p=np.zeros(b3), y_v=None if self.position_only else np.zeros(b3),
            has_fix=np.zeros(batch, dtype=bool), skipped=np.zeros(batch, dtype=np.int64),
        )

    def rhs(self, t: float, z: GnssInsState, u: Array, y: Array) -> GnssInsState:
        """The right-hand side of (24a)–(24d) and of the measurement predictor, with the IMU ``u`` held.

        Parameters
        ----------
        t : float
            Time (unused: (24) is time-invariant).
        z : GnssInsState
        u : ndarray, shape (..., 9)
            ``[ω^b, a^b, m^b]`` (:data:`~nlobs.navigation.base.IMU_INPUTS`).
        y : ndarray
            Unused: the observer holds (or predicts) the last fix in its state (``y_p``, ``y_v``,
            taken by :meth:`correct`), and ``ẏ_p``, ``ẏ_v`` are part of the returned derivative.

        Returns
        -------
        GnssInsState
            The time derivatives ``dp̂/dt, dv̂/dt, dξ/dt, dR̂/dt, ẏ_p, ẏ_v`` (zero for
            ``intersample="hold"``); ``has_fix`` and ``skipped`` carried over from ``z``.
            :meth:`step` is its discretisation (split or RK4).
        """
        u_ = np.asarray(u, dtype=float)
        c = self._step_constants(u_[..., IMU_OMEGA], u_[..., IMU_ACCEL], u_[..., IMU_MAG], z.has_fix)
        return self._unpack(self._rhs(self._pack(z), c), z)

    def step(self, t: float, z: GnssInsState, u: Array, y: Array, h: float) -> GnssInsState:
        """The state at ``t + h``: (24) integrated over one IMU period with ``u`` held (``integrator``, ``kernel``).

        The discretisation of :meth:`rhs` (class docstring: the Strang split, by the fused
        single-flight kernel for one flight under ``kernel="auto"``, or RK4). ``y`` is unused
        (the held fix is in the state). Same as :meth:`propagate` with the IMU as a 9-channel input.

        The IMU sample is not checked here (this is the measured speed path): the loops check the
        whole record once up front — :func:`~nlobs.navigation.run.run_navigation` and
        :func:`~nlobs.simulate.run_observer` raise :class:`~nlobs.errors.NonFiniteError` naming the
        sample's index and time. A non-finite sample passed here directly gives a non-finite state.

        Raises
        ------
        InvalidArgumentError
            ``h`` is not positive and finite, or (RK4 with fixed ``substeps``) too large for RK4's stability.
        DimensionError
            ``kernel="scalar"`` for more than one flight.
        """
        if self.integrator == "split" and self.kernel != "batched" and z.p.size == 3 and u.size == 9 \
                and (u.ndim == 1 or u.shape[:-1] == z.p.shape[:-1]):
            h = float(h)
            if not 0.0 < h < _INF:
                raise InvalidArgumentError(f"dt: must be positive and finite, got {h!r}")
            f = u.ravel().tolist()
            return self._propagate_scalar(z, f, h)
        u_ = np.asarray(u, dtype=float)
        return self._advance(z, u_[..., IMU_OMEGA], u_[..., IMU_ACCEL], u_[..., IMU_MAG], h)

    def correct(self, t: float, z: GnssInsState, u: Array, y: Array, fresh: BoolArray) -> GnssInsState:
        """Take a GNSS fix ``y = [p, v]`` (or ``p``) as the held measurement: :meth:`update` with
        ``valid`` = every entry of the fix finite, per batch member (a missing fix is skipped there).

        Raises
        ------
        DimensionError
            ``y`` has neither 3 nor 6 channels.
        InvalidArgumentError
            A fix that carries only some of its channels (``fresh`` not all True), or a
            position-only fix for an observer that needs velocity.
        """
        y_ = np.asarray(y, dtype=float)
        if y_.ndim == 0 or y_.shape[-1] not in (3, 6):
            raise DimensionError(f"y: expected a GNSS fix of shape (..., 6) or (..., 3), got {y_.shape}")
        if not np.all(fresh):
            raise InvalidArgumentError("fresh: a GNSS fix carries all its channels at once")
        valid = np.isfinite(y_).all(axis=-1)
        return self._store(z, y_[..., GNSS_P], y_[..., GNSS_V] if y_.shape[-1] == 6 else None, valid)

    def estimate(self, z: GnssInsState) -> Array:
        """``[p̂, v̂, R̂ projected onto SO(3)]`` (post-orthogonalisation, Sec. 5.2; SVD), shape ``(..., 15)``."""
        return nav_vector(z.p, z.v, project_so3(z.R))

    def raw_estimate(self, z: GnssInsState) -> Array:
        """``[p̂, v̂, R̂]`` with the raw ``R̂`` of (24d) (row-major), shape ``(..., 15)``.

        :func:`~nlobs.simulate.run_observer` records these at every step and hands the whole
        record to :meth:`finish_estimates` once (one projection per run instead of per step).
        """
        b = z.p.shape[:-1]
        if z._flat is not None and not b:  # a state of the fused kernel: its floats, no NumPy concatenation
            f = z._flat
            return np.array(f[0:6] + f[9:18])
        return np.concatenate([z.p, z.v, z.R.reshape(*b, 9)], axis=-1)

    def finish_estimates(self, raw: Array) -> tuple[Array, dict[str, Array]]:
        """The recorded raw estimates with ``R̂`` projected onto SO(3), and the raw ``R̂`` as an extra.

        Newton's polar iteration (:func:`nlobs.navigation.polar.nearest_rotation`), equal to the
        SVD projection of :meth:`estimate` to rounding and about 20× cheaper per matrix in bulk,
        applied once to the whole record, in the record's memory order.

        Parameters
        ----------
        raw : ndarray, shape (..., K, 15)
            :meth:`raw_estimate` at every saved step. When it is writable (the loop hands over its
            own record) the projection is written into it **in place** and ``raw`` itself is
            returned, so a large record exists once (plus the raw ``R̂`` kept as the extra); a
            read-only ``raw`` is left untouched.

        Returns
        -------
        estimates : ndarray, shape (..., K, 15)
            ``raw`` (writable input) or a new read-only array.
        extras : dict
            ``{"R_raw": (..., K, 3, 3)}``, read-only (a copy of the raw ``R̂`` when ``raw`` was
            overwritten, else a view of it).
        """
        raw = np.asarray(raw, dtype=float)
        if raw.ndim < 2 or raw.shape[-1] != 15:
            raise DimensionError(f"raw: expected shape (..., K, 15), got {raw.shape}")
        tm = np.moveaxis(raw, -2, 0)                       # (K, ..., 15): the loop's record is contiguous so
        mats = (*tm.shape[:-1], 3, 3)
        if raw.flags.writeable:
            R_tm = readonly(tm[..., NAV_R].copy(), owned=True).reshape(mats)
            dest = tm[..., NAV_R].view()
            dest.shape = mats                              # a view into raw (splitting the last axis)
            nearest_rotation(R_tm, out=dest)
            return raw, {"R_raw": np.moveaxis(R_tm, 0, -3)}
        out = np.empty_like(tm)                            # same memory order as the record
        out[..., 0:6] = tm[..., 0:6]
        dest = out[..., NAV_R].view()
        dest.shape = mats
        nearest_rotation(tm[..., NAV_R].reshape(mats), out=dest)
        return np.moveaxis(readonly(out, owned=True), 0, -2), {"R_raw": raw[..., NAV_R].reshape(*raw.shape[:-1], 3, 3)}

    def diagnostics(self, z: GnssInsState, u: Array) -> dict[str, Array]:
        """``{"z_hat": ẑ = R̂ a^b + ξ}``, the estimate of ``aⁿ`` of (24b)–(24c), shape ``(..., 3)``."""
        a = np.asarray(u, dtype=float)[..., IMU_ACCEL]
        return {"z_hat": np.einsum("...ij,...j->...i", z.R, a) + z.xi}

    # ------------------------------------------------------ functional form (domain types)
    def update(self, state: GnssInsState, gnss: GnssSample) -> GnssInsState:
        """Store a GNSS fix as the held measurement, per batch member where ``gnss.valid`` and the fix is finite.

        Invalid members keep their previous held measurement (or stay without
        injection if none has arrived) and their ``skipped`` count grows by one.
        A member whose fix has a non-finite entry (of ``p``, or of ``v`` when the
        observer uses it) counts as invalid even when ``gnss.valid`` says otherwise:
        it is a missing fix for that flight (the protocol of :mod:`nlobs.observers.base`).
        A position-only observer ignores ``gnss.v``.

        Raises
        ------
        InvalidArgumentError
            ``gnss.v`` is ``None`` but the observer needs velocity fixes.
        DimensionError
            Shapes do not broadcast to the state's batch shape.
        """
        p = np.asarray(gnss.p, dtype=float)
        v = None if gnss.v is None else np.asarray(gnss.v, dtype=float)
        finite = np.isfinite(p).all(axis=-1)
        if v is not None and not self.position_only:
            finite = finite & np.isfinite(v).all(axis=-1)
        return self._store(state, p, v, np.asarray(gnss.valid, dtype=bool) & finite)

    def _store(self, state: GnssInsState, p: Array, v: Array | None, valid: BoolArray) -> GnssInsState:
        """:meth:`update` with ``valid`` already false wherever the fix is not finite."""
        batch = state.batch_shape
        try:
            valid = np.broadcast_to(valid, batch)
            yp = np.where(valid[..., None], np.broadcast_to(p, (*batch, 3)), state.y_p)
            yv = state.y_v
            if not self.position_only:
                if v is None:
                    raise InvalidArgumentError(
                        "gnss.v: the fix has no velocity but the observer expects p and v (use position_only=True)")
                yv = np.where(valid[..., None], np.broadcast_to(v, (*batch, 3)), state.y_v)
        except ValueError as exc:
            if isinstance(exc, InvalidArgumentError):
                raise
            raise DimensionError(f"gnss: shapes do not match the state's batch shape {batch} ({exc})") from None
        return GnssInsState(p=state.p, v=state.v, xi=state.xi, R=state.R, y_p=yp, y_v=yv,
                            has_fix=state.has_fix | valid, skipped=state.skipped + (~valid).astype(np.int64))

    def propagate(self, state: GnssInsState, imu: ImuSample, dt: float) -> GnssInsState:
        """Integrate (24a)–(24d) over ``[t, t + dt]``, the IMU sample held (``integrator``: split or RK4).

        The functional form of :meth:`step` on an :class:`~nlobs.navigation.base.ImuSample`.

        Raises
        ------
        InvalidArgumentError
            ``dt`` is not positive and finite, or (RK4 with fixed ``substeps``) too large for
            RK4's stability (``(dt/substeps)·ρ > 2.785``). The IMU sample is not checked (see :meth:`step`).
        """
        if self.integrator == "split" and self.kernel != "batched":
            scalar = _single(state, imu)
            if scalar is not None:
                dt = float(dt)
                if not 0.0 < dt < _INF:
                    raise InvalidArgumentError(f"dt: must be positive and finite, got {dt!r}")
                return self._propagate_scalar(state, scalar, dt)
        return self._advance(state, np.asarray(imu.omega_b, dtype=float), np.asarray(imu.a_b, dtype=float),
                             np.asarray(imu.m_b, dtype=float), dt)

    # ----------------------------------------------------------------- private
    def _advance(self, state: GnssInsState, w: Array, a: Array, m: Array, dt: float) -> GnssInsState:
        """One IMU period by the batched split step or RK4 (``w``, ``a``, ``m`` of shape ``(..., 3)``)."""
        dt = float(dt)
        if not 0.0 < dt < _INF:
            raise InvalidArgumentError(f"dt: must be positive and finite, got {dt!r}")
        if self.integrator == "split":
            if self.kernel == "scalar":
                raise DimensionError(
                    f"kernel='scalar' needs a single flight: state batch {state.batch_shape}, IMU shapes "
                    f"{w.shape}, {a.shape}, {m.shape}")
            return self._propagate_split(state, w, a, m, dt)
        # IMU-only quantities are constant over the step: precompute them once
        c = self._step_constants(w, a, m, state.has_fix)
        rho_att = self._gamma_max * float(np.max(c.mu))
        rho = max(self._rho, rho_att)
        if self.substeps is None:
            need = dt * rho / RK4_AUTO
            if not need <= MAX_AUTO_SUBSTEPS:
                raise InvalidArgumentError(
                    f"dt: {dt:g} s needs {need:.3g} RK4 substeps at the stiffest rate {rho:.4g} 1/s, more than "
                    f"{MAX_AUTO_SUBSTEPS:,}; shorten the IMU period (the observer runs at the IMU rate)")
            n = max(1, math.ceil(need))
        else:
            n = self.substeps
            if dt / n * rho > RK4_STABILITY:
                raise InvalidArgumentError(
                    f"dt: RK4 step {dt / n:g} s is unstable here (stiffest rate {rho:.4g} 1/s: "
                    f"ρ(𝔄 − Kℭ) = {self._rho:.4g}, λmax(Γ)·λmax(A_b A_bᵀ) = {rho_att:.4g}; "
                    f"h·ρ = {dt / n * rho:.3g} > {RK4_STABILITY}); increase substeps or use substeps=None")
        h = dt / n
        X = self._pack(state)
        def f(_t: float, X: Array) -> Array:
            return self._rhs(X, c)

        for _ in range(n):
            X = rk4_step(f, 0.0, X, h)
        return self._unpack(X, state)

    def _step_constants(self, w: Array, a: Array, m: Array, has_fix: BoolArray) -> _Step:
        """The quantities of (24) that are constant over one IMU period (the held IMU sample)."""
        Ab = triad_matrix(m, a)
        AbT = np.swapaxes(Ab, -1, -2)
        # per-step constants of (24): A_n A_bᵀ = mⁿ m^bᵀ + (S(mⁿ) ẑ) c₂ᵀ + (S(mⁿ)² ẑ) c₃ᵀ, c_j the columns of A_b
        return _Step(
            a=a[..., None],
            GM0=np.einsum("ij,j,...k->...ik", self.Gamma, self.m_n, m),  # Γ mⁿ m^bᵀ
            C23=AbT[..., 1:, :],                                         # rows c₂ᵀ, c₃ᵀ
            M=Ab @ AbT,                                                  # A_b A_bᵀ, eigenvalues |c_j|²
            mu=np.sum(Ab * Ab, axis=-2),                                 # |c_j|² (the columns are orthogonal)
            Sw=skew(w),
            act=np.asarray(has_fix, dtype=float)[..., None],
        )

    def _linear_generator(self, K: Array) -> Array:
        """Generator of the linear sub-flow (R̂ frozen): ``L' = F L`` on ``L = [p̂, v̂, ẑ, y_p, (y_v), 1]``."""
        po, pred = self.position_only, self.intersample == "predict"
        n = 12 if po else 15
        F = np.zeros((n + 1, n + 1))
        I3 = np.eye(3)
        F[0:3, 3:6] = I3                       # ṗ = v̂ + …
        F[3:6, 6:9] = I3                       # v̇ = ẑ + gⁿ + …
        F[3:6, n] = self.g_n
        q = 3 if po else 6
        F[0:9, 9:9 + q] += K                   # + K y
        F[0:9, 0:q] -= K                       # − K ℭ [p̂, v̂]
        if pred:
            if po:
                F[9:12, 3:6] = I3              # ẏ_p = v̂
            else:
                F[9:12, 12:15] = I3            # ẏ_p = y_v
                F[12:15, 6:9] = I3             # ẏ_v = ẑ + gⁿ
                F[12:15, n] = self.g_n
        return F

    def _transitions(self, dt: float) -> tuple[Array, Array, Array, Array]:
        """``(Φᵀ, d)`` of the exact linear sub-flow over ``dt``, with and without injection (cached by ``dt``)."""
        out = self._cache.get(dt)
        if out is None:
            from scipy.linalg import expm

            n = self._F[0].shape[0] - 1
            E1, E0 = expm(self._F[0] * dt), expm(self._F[1] * dt)
            out = (readonly(E1[:n, :n].T), readonly(E1[:n, n]), readonly(E0[:n, :n].T), readonly(E0[:n, n]))
            if len(self._cache) > 16:
                self._cache.clear()
            self._cache[dt] = out
        return out

    def _scalar_flows(self, dt: float) -> tuple[ScalarFlow, ScalarFlow]:
        """The linear sub-flow over ``dt`` with and without injection, for the scalar kernel (cached by ``dt``)."""
        out = self._scalar_cache.get(dt)
        if out is None:
            P1, d1, P0, d0 = self._transitions(dt)
            out = (ScalarFlow.from_transition(P1, d1), ScalarFlow.from_transition(P0, d0))
            if len(self._scalar_cache) > 16:
                self._scalar_cache.clear()
            self._scalar_cache[dt] = out
        return out

    def _propagate_scalar(self, state: GnssInsState, u: list[float], h: float) -> GnssInsState:
        """The split step of one flight by the fused kernel (:func:`nlobs.navigation.split_kernel.split_step`);
        ``u`` is the IMU sample ``[ω^b, a^b, m^b]`` as 9 floats.

        The new state's arrays are read-only views of one array, and the state keeps its floats
        (:attr:`GnssInsState._flat`) so that the next scalar step needs no conversion.
        """
        w, a, m = u[0:3], u[3:6], u[6:9]
        flow1, flow0 = self._scalar_flows(0.5 * h)
        flat = state._flat
        if flat is None:  # [p̂, v̂, ξ, R̂ (row-major), y_p, (y_v)]
            flat = state.p.ravel().tolist() + state.v.ravel().tolist() + state.xi.ravel().tolist() \
                + state.R.ravel().tolist() + state.y_p.ravel().tolist()
            if state.y_v is not None:
                flat += state.y_v.ravel().tolist()
        R = flat[9:18]
        a0, a1, a2 = a
        z = [R[0] * a0 + R[1] * a1 + R[2] * a2 + flat[6], R[3] * a0 + R[4] * a1 + R[5] * a2 + flat[7],
             R[6] * a0 + R[7] * a1 + R[8] * a2 + flat[8]]                # ẑ = R̂ a^b + ξ
        L, R2, Ra = split_step(self._scalar, flow1 if state.has_fix else flow0, h, flat[0:6] + z + flat[18:], R,
                               w, a, m)
        out = L[0:6] + [L[6] - Ra[0], L[7] - Ra[1], L[8] - Ra[2]] + list(R2) + L[9:]
        X = readonly(np.array(out), owned=True)
        batch = state.batch_shape
        if batch:
            X = X.reshape(*batch, X.shape[0])
        new = GnssInsState(p=X[..., 0:3], v=X[..., 3:6], xi=X[..., 6:9], R=X[..., 9:18].reshape(*batch, 3, 3),
                           y_p=X[..., 18:21], y_v=None if state.y_v is None else X[..., 21:24],
                           has_fix=state.has_fix, skipped=state.skipped)
        object.__setattr__(new, "_flat", out)
        return new

    def _propagate_split(self, state: GnssInsState, w: Array, a: Array, m: Array, h: float) -> GnssInsState:
        """One Strang step ``C(h/2) A(h/2) B(h) A(h/2) C(h/2)`` of exactly solved sub-flows (class docstring).

        Vectorised over the batch in one of two layouts, the same arithmetic: up to
        :data:`BATCH_LAST_MIN` flights, the batch axis first and ``(..., 3, 3)`` matrices
        (:meth:`_split_rows`, the fewest NumPy calls); from there on, the batch axis **last**
        (:meth:`_split_columns`: every 3×3 product an ``einsum`` over contiguous rows of length
        ``n``; NumPy's stacked ``matmul`` on ``(n, 3, 3)`` and its reductions over small axes
        cost several times more per flight).
        """
        shapes = (w.shape, a.shape, m.shape)
        try:
            batch = np.broadcast_shapes(state.batch_shape, *(sh[:-1] for sh in shapes))
        except ValueError:
            raise DimensionError(f"imu: shapes {shapes} do not match the state's batch shape {state.batch_shape}") \
                from None
        if batch != state.batch_shape:  # an IMU batch wider than the state: widen the state first
            b3 = (*batch, 3)
            state = GnssInsState(
                p=np.broadcast_to(state.p, b3), v=np.broadcast_to(state.v, b3), xi=np.broadcast_to(state.xi, b3),
                R=np.broadcast_to(state.R, (*batch, 3, 3)), y_p=np.broadcast_to(state.y_p, b3),
                y_v=None if state.y_v is None else np.broadcast_to(state.y_v, b3),
                has_fix=np.broadcast_to(state.has_fix, batch).copy(), skipped=np.broadcast_to(state.skipped, batch).copy())
        n = 1
        for d in batch:
            n *= d
        if n < BATCH_LAST_MIN:
            return self._split_rows(state, w, a, m, h)
        return self._split_columns(state, w, a, m, h)

    def _split_columns(self, state: GnssInsState, w: Array, a: Array, m: Array, h: float) -> GnssInsState:
        """The split step with the batch axis last: 3-vectors ``(3, n)``, 3×3 matrices ``(3, 3, n)``."""
        batch = np.broadcast_shapes(state.batch_shape, w.shape[:-1], a.shape[:-1], m.shape[:-1])
        n = int(np.prod(batch, dtype=int))
        b3 = (*batch, 3)

        def rows(x: Array) -> Array:  # (..., 3) → (n, 3)
            return (x if x.shape == b3 else np.broadcast_to(x, b3)).reshape(n, 3)

        w, a, m = rows(w).T, rows(a).T, rows(m).T                    # (3, n)
        Rb = state.R if state.R.shape == (*batch, 3, 3) else np.broadcast_to(state.R, (*batch, 3, 3))
        R = Rb.reshape(n, 3, 3).transpose(1, 2, 0)                   # (3, 3, n)
        P1, d1, P0, d0 = self._transitions(0.5 * h)
        has = np.broadcast_to(state.has_fix, batch).reshape(n)
        sel = 1 if has.all() else (0 if not has.any() else -1)

        def lin(L: Array) -> Array:  # C(h/2): p̂, v̂, ẑ, y linear with R̂ frozen, exact; L is (n, 12 or 15)
            if sel == 1:
                return L @ P1 + d1
            if sel == 0:
                return L @ P0 + d0
            return np.where(has[:, None], L @ P1 + d1, L @ P0 + d0)

        parts = [rows(state.p), rows(state.v), (_mv_t(R, a) + rows(state.xi).T).T, rows(state.y_p)]
        if state.y_v is not None:
            parts.append(rows(state.y_v))
        L = lin(np.concatenate(parts, axis=-1))                      # L = [p̂, v̂, ẑ, y_p, (y_v)], ẑ = R̂ a^b + ξ
        E = exp_so3_columns(w * (0.5 * h))                           # A(h/2): R̂ ← R̂ exp(S(ω^b) h/2), ξ fixed
        RE = _mm_t(R, E)
        z = L[:, 6:9].T + _mv_t(RE - R, a)                           # ẑ after A(h/2)
        # B(h): Ṙ̂ = Γ J, ξ̇ = −Γ J a^b with ẑ exactly invariant: elementwise in R̃ = Vᵀ R̂ U, U = [c_j/|c_j|]
        Sm = skew_columns(m)                                         # S(m^b)
        c2 = _mv_t(Sm, a)                                            # m^b × a^b
        m2 = np.einsum("in,in->n", m, m)
        q = np.einsum("in,in->n", c2, c2)                            # |m^b × a^b|²
        ok = q > 1e-18 * m2 * np.einsum("in,in->n", a, a)
        if not ok.all():
            # m^b ∥ a^b (TRIAD condition violated): μ₂ = μ₃ = 0, any orthonormal completion of U will do
            e1 = np.abs(m[0]) < 0.9 * np.sqrt(m2)                    # m × e₁ = (0, m₃, −m₂), else m × e₂
            alt = np.stack([np.where(e1, 0.0, -m[2]), np.where(e1, m[2], 0.0), np.where(e1, -m[1], m[0])])
            c2 = np.where(ok, c2, alt)
        c3 = _mv_t(Sm, c2)
        Ub = np.stack([m, c2, c3], axis=1)                           # columns ∥ A_b's (orthogonal)
        U = Ub / np.sqrt(np.einsum("ijn,ijn->jn", Ub, Ub))
        s2 = np.stack([m2, q, m2 * q])                               # μ_j = |c_j|²
        An = np.concatenate([np.broadcast_to(self._m_n_col, (3, 1, n)), _const_mm_t(self._SmPowers, z)], axis=1)
        x = np.expm1(self._gamma_col * (-h * s2))                    # e^{−γ_i μ_j h} − 1
        f = x / -np.sqrt(np.maximum(s2, 1e-300))                     # (1 − e)/|c_j| (→ 0 as μ_j → 0)
        V = self._V
        if V is None:
            R1 = _mmT_t((1.0 + x) * _mm_t(RE, U) + f * An, U)       # C̃/μ = A_n diag(1/|c|)
        else:
            Vt = V.T
            inner = (1.0 + x) * _mm_t(_const_mm_t(Vt, RE), U) + f * _const_mm_t(Vt, An)
            R1 = _mmT_t(_const_mm_t(V, inner), U)
        xi = z - _mv_t(R1, a)
        R2 = _mm_t(R1, E)                                            # A(h/2) again, ξ fixed
        Ra = _mv_t(R2, a)
        L[:, 6:9] = (xi + Ra).T
        L = lin(L)                                                   # C(h/2)
        return GnssInsState(p=L[:, 0:3].reshape(b3), v=L[:, 3:6].reshape(b3),
                            xi=(L[:, 6:9] - Ra.T).reshape(b3), R=R2.transpose(2, 0, 1).reshape(*batch, 3, 3),
                            y_p=L[:, 9:12].reshape(b3), y_v=None if state.y_v is None else L[:, 12:15].reshape(b3),
                            has_fix=state.has_fix, skipped=state.skipped)

    def _split_rows(self, state: GnssInsState, w: Array, a: Array, m: Array, h: float) -> GnssInsState:
        """The split step for a small batch: batch axis first, ``(..., 3, 3)`` matrices (fewest NumPy calls)."""
        a_col = a[..., None]
        R = state.R
        P1, d1, P0, d0 = self._transitions(0.5 * h)
        has = state.has_fix
        sel = 1 if has.all() else (0 if not has.any() else -1)

        def lin(L: Array) -> Array:  # C(h/2): p̂, v̂, ẑ, y linear with R̂ frozen, exact
            if sel == 1:
                return L @ P1 + d1
            if sel == 0:
                return L @ P0 + d0
            return np.where(has[..., None], L @ P1 + d1, L @ P0 + d0)

        parts = [state.p, state.v, (R @ a_col)[..., 0] + state.xi, state.y_p]
        if state.y_v is not None:
            parts.append(state.y_v)
        L = lin(np.concatenate(parts, axis=-1))                      # L = [p̂, v̂, ẑ, y_p, (y_v)]
        E = exp_so3(w * (0.5 * h))                                   # A(h/2): R̂ ← R̂ exp(S(ω^b) h/2), ξ fixed
        RE = R @ E
        z = L[..., 6:9] + ((RE - R) @ a_col)[..., 0]                # ẑ after A(h/2)
        # B(h): Ṙ̂ = Γ J, ξ̇ = −Γ J a^b with ẑ exactly invariant: elementwise in R̃ = Vᵀ R̂ U, U = [c_j/|c_j|]
        Sm = (m @ _EPS).reshape(*m.shape[:-1], 3, 3)                 # S(m^b)
        c2 = Sm @ a_col                                              # m^b × a^b
        m2 = np.sum(m * m, axis=-1)[..., None]
        q = np.sum(c2 * c2, axis=-2)                                 # |m^b × a^b|²
        if not np.all(q > 1e-18 * m2 * np.sum(a * a, axis=-1)[..., None]):
            # m^b ∥ a^b (TRIAD condition violated): μ₂ = μ₃ = 0, any orthonormal completion of U will do
            alt = Sm @ np.where(np.abs(m[..., :1]) < 0.9 * np.sqrt(m2), [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])[..., None]
            c2 = np.where(q[..., None] > 1e-18 * m2[..., None] * np.sum(a * a, axis=-1)[..., None, None], c2, alt)
        Ub = np.concatenate([m[..., None], c2, Sm @ c2], axis=-1)   # columns ∥ A_b's (orthogonal)
        U = Ub / np.sqrt(np.sum(Ub * Ub, axis=-2, keepdims=True))
        s2 = np.concatenate([m2, q, m2 * q], axis=-1)                # μ_j = |c_j|²
        An = (z @ self._SmP).reshape(*z.shape[:-1], 3, 3) + self._An0  # A_n = [mⁿ, mⁿ × ẑ, mⁿ × (mⁿ × ẑ)]
        x = np.expm1((-h * self._gamma[:, None]) * s2[..., None, :])  # e^{−γ_i μ_j h} − 1
        f = x / -np.sqrt(np.maximum(s2, 1e-300))[..., None, :]        # (1 − e)/|c_j| (→ 0 as μ_j → 0)
        V = self._V
        if V is None:
            R1 = ((1.0 + x) * (RE @ U) + f * An) @ np.swapaxes(U, -1, -2)  # C̃/μ = A_n diag(1/|c|)
        else:
            R1 = V @ ((1.0 + x) * (V.T @ RE @ U) + f * (V.T @ An)) @ np.swapaxes(U, -1, -2)
        xi = z - (R1 @ a_col)[..., 0]
        R2 = R1 @ E                                                  # A(h/2) again, ξ fixed
        L[..., 6:9] = xi + (R2 @ a_col)[..., 0]
        L = lin(L)                                                   # C(h/2)
        return GnssInsState(p=L[..., 0:3], v=L[..., 3:6], xi=L[..., 6:9] - (R2 @ a_col)[..., 0], R=R2,
                            y_p=L[..., 9:12], y_v=None if state.y_v is None else L[..., 12:15],
                            has_fix=state.has_fix, skipped=state.skipped)

    # Packed state X = [p̂, v̂, ξ, vec_row(R̂), y_p, (y_v)] of shape (..., 21) or (..., 24).
    def _pack(self, st: GnssInsState) -> Array:
        parts = [st.p, st.v, st.xi, st.R.reshape(*st.R.shape[:-2], 9), st.y_p]
        if st.y_v is not None:
            parts.append(st.y_v)
        return np.concatenate(parts, axis=-1)

    def _unpack(self, X: Array, st: GnssInsState) -> GnssInsState:
        return GnssInsState(p=X[..., 0:3], v=X[..., 3:6], xi=X[..., 6:9], R=X[..., 9:18].reshape(*X.shape[:-1], 3, 3),
                            y_p=X[..., 18:21], y_v=None if self.position_only else X[..., 21:24],
                            has_fix=st.has_fix, skipped=st.skipped)

    def _rhs(self, X: Array, c: _Step) -> Array:
        """Right-hand side of (24a)–(24d) (and of the measurement predictor) on the packed state."""
        p, v, xi = X[..., 0:3], X[..., 3:6], X[..., 6:9]
        R = X[..., 9:18].reshape(*X.shape[:-1], 3, 3)
        z = (R @ c.a)[..., 0] + xi                                  # ẑ = R̂ a^b + ξ
        U = np.einsum("kij,...j->...ik", self._SmPowers, z)          # [S(mⁿ) ẑ, S(mⁿ)² ẑ]
        GJ = c.GM0 + self.Gamma @ (U @ c.C23 - R @ c.M)              # Γ J(m^b, mⁿ, a^b, ẑ, R̂)
        yp = X[..., 18:21]
        e = yp - p if self.position_only else np.concatenate([yp - p, X[..., 21:24] - v], axis=-1)
        inj = (e * c.act) @ self.K.T                                 # no injection before the first fix
        out = np.empty_like(X)
        out[..., 0:3] = v + inj[..., 0:3]                            # (24a)
        out[..., 3:6] = z + self.g_n + inj[..., 3:6]                 # (24b)
        out[..., 6:9] = inj[..., 6:9] - (GJ @ c.a)[..., 0]           # (24c)
        out[..., 9:18] = (R @ c.Sw + GJ).reshape(*X.shape[:-1], 9)   # (24d)
        if self.intersample == "predict":                            # ẏ_p = y_v (or v̂), ẏ_v = ẑ + gⁿ
            if self.position_only:
                out[..., 18:21] = v
            else:
                out[..., 18:21] = X[..., 21:24]
                out[..., 21:24] = z + self.g_n
        else:
            out[..., 18:] = 0.0
        return out


@dataclass(frozen=True)
class _Step:
    """Quantities of (24) that are constant over one IMU period (the held IMU sample)."""

    a: Array     # a^b as a column, (..., 3, 1)
    GM0: Array   # Γ mⁿ m^bᵀ, (..., 3, 3)
    C23: Array   # [c₂ᵀ; c₃ᵀ] of A_b, (..., 2, 3)
    M: Array     # A_b A_bᵀ, (..., 3, 3)
    mu: Array    # |c_j|², the eigenvalues of M, (..., 3)
    Sw: Array    # S(ω^b), (..., 3, 3)
    act: Array   # 1.0 once a fix has arrived, else 0.0, (..., 1)


def _single(state: GnssInsState, imu: ImuSample) -> list[float] | None:
    """The IMU sample as 9 floats ``[ω^b, a^b, m^b]`` when ``state`` and ``imu`` are one flight (size 1), else ``None``."""
    shape = state.p.shape
    if state.p.size != 3:
        return None
    w, a, m = (np.asarray(x, dtype=float) for x in (imu.omega_b, imu.a_b, imu.m_b))
    for x in (w, a, m):
        if x.shape != shape and x.shape != (3,):
            return None
    return w.ravel().tolist() + a.ravel().tolist() + m.ravel().tolist()


#: Batches of at least this many flights use the batch-last layout of the split step
#: (:meth:`GnssInsObserver._propagate_split`); the crossover measured in the runner lies
#: between 8 and 64 flights (a shared machine). Both layouts give the same numbers (tested).
BATCH_LAST_MIN = 16

#: ``S(x) = (x @ _EPS).reshape(3, 3)`` (minus the Levi-Civita symbol, flattened), batch first.
_EPS = np.zeros((3, 9))
_EPS[2, 1], _EPS[1, 2], _EPS[2, 3], _EPS[0, 5], _EPS[1, 6], _EPS[0, 7] = -1.0, 1.0, 1.0, -1.0, -1.0, 1.0
_EPS = readonly(_EPS, owned=True)
# 3×3 algebra with the batch axis last: vectors (3, n), matrices (3, 3, n) (row, column, flight).
def _mm_t(A: Array, B: Array) -> Array:
    """``A @ B`` per flight."""
    return np.einsum("ijn,jkn->ikn", A, B)


def _mmT_t(A: Array, B: Array) -> Array:
    """``A @ Bᵀ`` per flight."""
    return np.einsum("ijn,kjn->ikn", A, B)


def _mv_t(A: Array, x: Array) -> Array:
    """``A @ x`` per flight."""
    return np.einsum("ijn,jn->in", A, x)


def _const_mm_t(C: Array, B: Array) -> Array:
    """``C @ B`` per flight for a constant ``C`` (``(3, 3)``, or ``(k, 3, 3)`` stacked: ``(3, k, n)`` columns)."""
    if C.ndim == 2:
        return (C @ B.reshape(3, -1)).reshape(B.shape)
    return np.einsum("kij,jn->ikn", C, B)
