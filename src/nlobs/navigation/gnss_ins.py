r"""The GNSS/INS observer of Grip, Saberi & Johansen (seed 001, Sec. 5).

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
(post-orthogonalisation, Sec. 5.2), :meth:`GnssInsObserver.diagnostics` the
raw ``R̂`` and ``ẑ``.

Sampled-data implementation
---------------------------
The observer is a continuous-time system; the data are sampled (IMU at, e.g.,
100 Hz, GNSS at 5 Hz). :meth:`~GnssInsObserver.propagate` integrates (24) over
one IMU period with classical RK4 (``substeps`` steps), the IMU sample held
constant. GNSS fixes enter through a *held measurement* ``(y_p, y_v)`` stored in
the state by :meth:`~GnssInsObserver.update`; between fixes it is either

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

RK4 step size. The stiffest rates of (24) over one step are ``ρ(𝔄 − Kℭ)`` (the
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

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_batch, as_matrix, as_symmetric, as_vector
from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.navigation.base import GnssSample, ImuSample, NavEstimate
from nlobs.navigation.so3 import project_so3

Array = NDArray[np.float64]

__all__ = ["GnssInsObserver", "GnssInsState", "triad_J", "triad_matrix"]

#: RK4's stability interval on the negative real axis.
RK4_STABILITY = 2.785
#: Largest ``h·ρ`` the automatic sub-stepping allows (inside the stability interval, with margin).
RK4_AUTO = 2.0


def _cross(a: Array, b: Array) -> Array:
    """Batched cross product of ``(..., 3)`` arrays (cheaper than ``np.cross`` for small batches)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def triad_matrix(m: ArrayLike, a: ArrayLike) -> Array:
    """``A = [m, m × a, m × (m × a)]`` (columns), shape ``(..., 3, 3)`` (seed 001, (22)).

    The columns are mutually orthogonal, so ``A Aᵀ`` has eigenvalues
    ``|m|², |m × a|², |m|² |m × a|²``.
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
    """
    Ab = triad_matrix(m_b, a_b)
    An = triad_matrix(m_n, a_n)
    AbT = np.swapaxes(Ab, -1, -2)
    return An @ AbT - np.asarray(R_hat, dtype=float) @ (Ab @ AbT)


def _ro(a: Array) -> Array:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


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
    """

    p: Array
    v: Array
    xi: Array
    R: Array
    y_p: Array
    y_v: Array | None
    has_fix: NDArray[np.bool_]
    skipped: NDArray[np.int64]

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """The leading (batch) shape."""
        return tuple(self.p.shape[:-1])


@dataclass(frozen=True)
class GnssInsObserver:
    """The complete GNSS/INS observer (24) of seed 001 (Sec. 5), implementing ``NavFilter``.

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
        RK4 steps per IMU period; ``None`` (default) chooses, per IMU period, the
        fewest steps with ``h · ρ ≤ 2`` where ``ρ`` is the stiffest rate of the
        step: ``max(ρ(𝔄 − Kℭ), λmax(Γ) · λmax(A_b A_bᵀ))``. With a fixed number,
        ``propagate`` raises when ``h · ρ`` exceeds RK4's stability limit 2.785.
    name : str
        ``"observer"``.

    Raises
    ------
    DimensionError
        Wrong shape of ``K``, ``Gamma``, ``m_n`` or ``g_n``.
    NotSymmetricError
        ``Gamma`` is not symmetric.
    InvalidArgumentError
        ``Gamma`` is not positive definite, ``mⁿ`` is zero, bad ``intersample`` or ``substeps``.
    """

    K: Array
    Gamma: Array
    m_n: Array
    g_n: Array
    position_only: bool = False
    intersample: Literal["hold", "predict"] = "predict"
    substeps: int | None = None
    name: str = "observer"
    _rho: float = field(init=False, repr=False, compare=False)
    _gamma_max: float = field(init=False, repr=False, compare=False)
    _SmPowers: Array = field(init=False, repr=False, compare=False)

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
        for nm, val in (("K", K), ("Gamma", G), ("m_n", m_n), ("g_n", g_n)):
            object.__setattr__(self, nm, _ro(val))
        object.__setattr__(self, "_gamma_max", float(lam[-1]))
        Sm = _skew(m_n)
        object.__setattr__(self, "_SmPowers", _ro(np.stack([Sm, Sm @ Sm])))
        # spectral radius of the linear error dynamics 𝔄 − Kℭ (9 states), for the RK4 step check
        I3, Z3 = np.eye(3), np.zeros((3, 3))
        A = np.block([[Z3, I3, Z3], [Z3, Z3, I3], [Z3, Z3, Z3]])
        C = np.hstack([I3, Z3, Z3]) if self.position_only else np.hstack([np.eye(6), np.zeros((6, 3))])
        object.__setattr__(self, "_rho", float(np.max(np.abs(np.linalg.eigvals(A - K @ C)))))

    # ----------------------------------------------------------------- factory
    @classmethod
    def paper(cls, m_n: ArrayLike, g_n: ArrayLike, *, position_only: bool = False,
              intersample: Literal["hold", "predict"] = "predict", substeps: int | None = None) -> GnssInsObserver:
        """The observer with the paper's gains: ``Γ = diag(20, 0.2, 0.2)`` and ``K`` of Sec. 5.2.

        For ``position_only`` the paper gives no ``K``; the one designed by
        :func:`nlobs.navigation.gains.design_gains` with the paper's recipe is used.
        """
        from nlobs.navigation.gains import PAPER_GAMMA, paper_gains

        return cls(paper_gains(position_only), PAPER_GAMMA, m_n, g_n, position_only=position_only,
                   intersample=intersample, substeps=substeps)

    # ---------------------------------------------------------------- protocol
    def init(self, p0: ArrayLike, v0: ArrayLike, R0: ArrayLike, xi0: ArrayLike | None = None) -> GnssInsState:
        """Initial state: ``p̂ = p0``, ``v̂ = v0``, ``R̂ = R0``, ``ξ = xi0`` (default 0, i.e. ``ẑ = R̂ a^b``).

        The inputs are broadcast to a common batch shape. No fix is held yet.
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

    def update(self, state: GnssInsState, gnss: GnssSample) -> GnssInsState:
        """Store a GNSS fix as the held measurement, per batch member where ``gnss.valid``.

        Invalid members keep their previous held measurement (or stay without
        injection if none has arrived) and their ``skipped`` count grows by one.
        A position-only observer ignores ``gnss.v``.

        Raises
        ------
        InvalidArgumentError
            ``gnss.v`` is ``None`` but the observer needs velocity fixes.
        DimensionError
            Shapes do not broadcast to the state's batch shape.
        """
        batch = state.batch_shape
        valid = np.asarray(gnss.valid, dtype=bool)
        try:
            valid = np.broadcast_to(valid, batch)
            yp = np.where(valid[..., None], np.broadcast_to(gnss.p, (*batch, 3)), state.y_p)
            yv = state.y_v
            if not self.position_only:
                if gnss.v is None:
                    raise InvalidArgumentError(
                        "gnss.v: the fix has no velocity but the observer expects p and v (use position_only=True)")
                yv = np.where(valid[..., None], np.broadcast_to(gnss.v, (*batch, 3)), state.y_v)
        except ValueError as exc:
            if isinstance(exc, InvalidArgumentError):
                raise
            raise DimensionError(f"gnss: shapes do not match the state's batch shape {batch} ({exc})") from None
        return GnssInsState(p=state.p, v=state.v, xi=state.xi, R=state.R, y_p=yp, y_v=yv,
                            has_fix=state.has_fix | valid, skipped=state.skipped + (~valid).astype(np.int64))

    def propagate(self, state: GnssInsState, imu: ImuSample, dt: float) -> GnssInsState:
        """Integrate (24a)–(24d) over ``[t, t + dt]`` with RK4, the IMU sample held.

        Raises
        ------
        InvalidArgumentError
            ``dt`` is not positive, or too large for RK4 on the linear part
            (``(dt/substeps)·ρ(𝔄 − Kℭ) > 2.78``).
        """
        dt = float(dt)
        if not dt > 0:
            raise InvalidArgumentError(f"dt: must be positive, got {dt!r}")
        w = np.asarray(imu.omega_b, dtype=float)
        a = np.asarray(imu.a_b, dtype=float)
        m = np.asarray(imu.m_b, dtype=float)
        # IMU-only quantities are constant over the step: precompute them once
        Ab = triad_matrix(m, a)
        AbT = np.swapaxes(Ab, -1, -2)
        M = Ab @ AbT  # A_b A_bᵀ, eigenvalues = squared column norms of A_b
        rho_att = self._gamma_max * float(np.max(np.sum(Ab * Ab, axis=-2)))
        rho = max(self._rho, rho_att)
        if self.substeps is None:
            n = max(1, int(np.ceil(dt * rho / RK4_AUTO)))
        else:
            n = self.substeps
            if dt / n * rho > RK4_STABILITY:
                raise InvalidArgumentError(
                    f"dt: RK4 step {dt / n:g} s is unstable here (stiffest rate {rho:.4g} 1/s: "
                    f"ρ(𝔄 − Kℭ) = {self._rho:.4g}, λmax(Γ)·λmax(A_b A_bᵀ) = {rho_att:.4g}; "
                    f"h·ρ = {dt / n * rho:.3g} > {RK4_STABILITY}); increase substeps or use substeps=None")
        h = dt / n
        # per-step constants of (24): A_n A_bᵀ = mⁿ m^bᵀ + (S(mⁿ) ẑ) c₂ᵀ + (S(mⁿ)² ẑ) c₃ᵀ, c_j the columns of A_b
        c = _Step(
            a=a[..., None],
            GM0=np.einsum("ij,j,...k->...ik", self.Gamma, self.m_n, m),  # Γ mⁿ m^bᵀ
            C23=AbT[..., 1:, :],                                         # rows c₂ᵀ, c₃ᵀ
            M=M,
            Sw=_skew(w),
            act=np.asarray(state.has_fix, dtype=float)[..., None],
        )
        X = self._pack(state)
        for _ in range(n):
            k1 = self._rhs(X, c)
            k2 = self._rhs(X + (0.5 * h) * k1, c)
            k3 = self._rhs(X + (0.5 * h) * k2, c)
            k4 = self._rhs(X + h * k3, c)
            X = X + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
        return self._unpack(X, state)

    def estimate(self, state: GnssInsState) -> NavEstimate:
        """``p̂``, ``v̂`` and ``R̂`` projected onto SO(3) (post-orthogonalisation, Sec. 5.2)."""
        return NavEstimate(p=state.p, v=state.v, R=project_so3(state.R))

    def diagnostics(self, state: GnssInsState, imu: ImuSample | None = None) -> dict[str, Array]:
        """Raw quantities: ``R_raw`` (``R̂`` of (24d)), ``xi``, and ``z_hat = R̂ a^b + ξ`` when ``imu`` is given."""
        out = {"R_raw": state.R, "xi": state.xi}
        if imu is not None:
            out["z_hat"] = np.einsum("...ij,...j->...i", state.R, np.asarray(imu.a_b, dtype=float)) + state.xi
        return out

    # ----------------------------------------------------------------- private
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
    Sw: Array    # S(ω^b), (..., 3, 3)
    act: Array   # 1.0 once a fix has arrived, else 0.0, (..., 1)


def _skew(w: Array) -> Array:
    Z = np.zeros(w.shape[:-1])
    w0, w1, w2 = w[..., 0], w[..., 1], w[..., 2]
    return np.stack([np.stack([Z, -w2, w1], -1), np.stack([w2, Z, -w0], -1), np.stack([-w1, w0, Z], -1)], -2)


