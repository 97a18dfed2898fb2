"""A smooth, exactly differentiable light-aircraft flight around an airport traffic pattern.

The flight mirrors the test case of Grip, Saberi & Johansen, Sec. 5.2 (a Cessna 172 flying a
traffic pattern from take-off to landing), but is generated analytically so that
the inertial signals are **exact**, not finite-differenced:

* speed ``V(t)``, flight-path angle ``γ(t)``, angle of attack ``α(t)`` and turn
  rate ``ψ̇(t)`` are sums of C³ polynomial smooth steps
  ``s(x) = 35x⁴ − 84x⁵ + 70x⁶ − 20x⁷`` (``s, s', s'', s'''`` vanish at both ends);
* heading ``ψ`` is the exact integral of ``ψ̇``;
* velocity ``vⁿ = V [cos γ cos ψ, cos γ sin ψ, −sin γ]`` (no wind: heading = track);
* attitude ``R = Rz(ψ) Ry(θ) Rx(φ)`` with pitch ``θ = γ + α`` and the coordinated-turn
  bank ``φ = atan(V cos γ · ψ̇ / g)``;
* body rate from the ZYX Euler-rate kinematics (equal to ``unskew(Rᵀ Ṙ)``)
  ``ω^b = [φ̇ − ψ̇ sin θ, θ̇ cos φ + ψ̇ cos θ sin φ, −θ̇ sin φ + ψ̇ cos θ cos φ]``;
* specific force ``a^b = Rᵀ(v̇ⁿ − gⁿ)`` with ``v̇ⁿ`` differentiated analytically;
* position ``pⁿ = ∫ vⁿ dt`` by 8-point Gauss–Legendre quadrature on intervals
  that contain no profile breakpoint (the integrand is analytic there), i.e. to
  rounding error.

``ω^b`` is C², ``a^b`` is C² (so ``ȧ^b`` is continuous and bounded, as Grip, Saberi & Johansen,
Sec. 5.1 assumes). The magnetic field is a fixed unit NED vector
(:data:`M_N_DEFAULT`, inclination 70°, declination 2°).

The pattern geometry is closed by a small root solve so that the aircraft
reaches the pattern altitude, and lands back on the runway centre line at ground
level: the unknowns are the climb and descent flight-path angles and the
downwind and base leg durations.

The runway heading is ``45° + k·90°`` (±8° jitter, ``k`` from the seed). That
choice keeps the TRIAD condition ``‖m^b × a^b‖ ≥ c_obs > 0`` (Grip, Saberi & Johansen, Sec. 5.1)
comfortably satisfied: the specific force tilts away from the turn centre by the
bank angle and ``mⁿ`` tilts 20° from the vertical toward magnetic north, so the
two would become parallel during a turn whose bank is ≈20° while its centre
lies magnetic south; with this runway heading that direction is crossed at
mid-turn, at full bank (25–29°), never at 20°.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike
import scipy

from nlobs._typing import Array
from nlobs._validate import as_vector, positive
from nlobs.errors import DesignInfeasible, InvalidArgumentError
from nlobs.navigation.base import G0
from nlobs.navigation.so3 import R_from_euler


__all__ = [
    "M_N_DEFAULT",
    "Trajectory",
    "Flight",
    "traffic_pattern",
    "triad_margin",
]

_DEG = np.pi / 180.0


def _unit_field(inclination_deg: float, declination_deg: float) -> Array:
    inc, dec = inclination_deg * _DEG, declination_deg * _DEG
    return np.array([np.cos(inc) * np.cos(dec), np.cos(inc) * np.sin(dec), np.sin(inc)])


#: Earth magnetic field in NED, normalised: inclination 70° (down), declination 2° (east).
#: Typical of northern Europe; only the direction matters to the observers.
M_N_DEFAULT: Array = _unit_field(70.0, 2.0)

# 8-point Gauss–Legendre rule on [0, 1].
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_GL_X = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W


# ---------------------------------------------------------------------------
# smooth steps


def _s_inner(x: Array, order: int) -> Array:
    """The C³ step ``s(x)`` (order 0), its derivatives (1..3) and integral ``∫₀ˣ s`` (order −1) for ``0 ≤ x ≤ 1``."""
    if order == -1:
        return x**5 * (7.0 + x * (-14.0 + x * (10.0 - 2.5 * x)))
    if order == 0:
        return x**4 * (35.0 + x * (-84.0 + x * (70.0 - 20.0 * x)))
    if order == 1:
        return x**3 * (140.0 + x * (-420.0 + x * (420.0 - 140.0 * x)))
    if order == 2:
        return x**2 * (420.0 + x * (-1680.0 + x * (2100.0 - 840.0 * x)))
    if order == 3:
        return x * (840.0 + x * (-5040.0 + x * (8400.0 - 4200.0 * x)))
    raise InvalidArgumentError(f"smooth step: order must be in -1..3, got {order}")


@dataclass(frozen=True)
class _Profile:
    """``f(t) = base + Σ amp_i s((t − t0_i)/τ_i)``; order −1 gives ``∫₀ᵗ (f − base)``.

    Each step is evaluated only inside its window ``0 < x < 1``; beyond it the
    step is constant (``s = 1``, derivatives 0, ``∫₀ˣ s = x − 1/2``).
    """

    base: float
    t0: tuple[float, ...]
    tau: tuple[float, ...]
    amp: tuple[float, ...]

    def __call__(self, t: Array, order: int = 0) -> Array:
        tf = np.ravel(t)
        out = np.full(tf.shape, self.base if order == 0 else 0.0)
        for t0, tau, amp in zip(self.t0, self.tau, self.amp):
            x = (tf - t0) / tau
            inside = np.flatnonzero((x > 0.0) & (x < 1.0))
            after = x >= 1.0
            if order == -1:
                out[after] += amp * tau * (x[after] - 0.5)
                out[inside] += amp * tau * _s_inner(x[inside], -1)
            else:
                if order == 0:
                    out[after] += amp
                out[inside] += amp * _s_inner(x[inside], order) / tau**order
        return out.reshape(np.shape(t))

    def breakpoints(self) -> list[float]:
        return [b for t0, tau in zip(self.t0, self.tau) for b in (t0, t0 + tau)]


class _Builder:
    def __init__(self) -> None:
        self.steps: list[tuple[float, float, float]] = []

    def step(self, t0: float, tau: float, amp: float) -> None:
        self.steps.append((float(t0), float(tau), float(amp)))

    def build(self, base: float = 0.0) -> _Profile:
        if not self.steps:
            return _Profile(base, (), (), ())
        t0, tau, amp = zip(*self.steps)
        return _Profile(base, t0, tau, amp)


# ---------------------------------------------------------------------------
# flight plan


@dataclass(frozen=True)
class _Params:
    heading: float  # runway heading [rad]
    side: int  # −1 left-hand pattern, +1 right-hand
    h_pattern: float
    v_rot: float
    v_climb: float
    v_pattern: float
    v_approach: float
    v_touchdown: float
    bank: float
    t_roll: float
    t_upwind: float
    t_crosswind: float
    t_final: float
    t_brake: float
    touchdown_along: float


@dataclass(frozen=True)
class _Plan:
    V: _Profile
    rate: _Profile  # ψ̇
    gamma: _Profile
    alpha: _Profile
    heading0: float
    t_level: float  # end of the level-off
    t_touchdown: float
    t_end: float
    phases: tuple[tuple[str, float], ...]


def _plan(p: _Params, unknowns: Array, g: float) -> _Plan:
    gam_c, gam_d, t_dw, t_base = (float(u) for u in unknowns)
    V, R, Gm, Al = _Builder(), _Builder(), _Builder(), _Builder()
    tau_turn = 4.0
    phases: list[tuple[str, float]] = []

    def turn(t0: float, speed: float, gamma: float) -> float:
        r = g * np.tan(p.bank) / (speed * np.cos(gamma))
        length = (np.pi / 2) / r  # ∫ψ̇ = r·length = 90°
        R.step(t0, tau_turn, p.side * r)
        R.step(t0 + length, tau_turn, -p.side * r)
        return t0 + length + tau_turn

    a_rot, a_climb, a_cruise, a_app, a_flare = 8 * _DEG, 5 * _DEG, 2 * _DEG, 4 * _DEG, 4 * _DEG
    t = 2.0
    phases.append(("take-off roll", t))
    V.step(t, p.t_roll, p.v_rot)
    t_rot = t + p.t_roll - 2.0
    phases.append(("rotation", t_rot))
    Al.step(t_rot, 3.0, a_rot)
    t_lo = t_rot + 2.0
    phases.append(("climb", t_lo))
    Gm.step(t_lo, 5.0, gam_c)
    Al.step(t_lo + 2.0, 6.0, a_climb - a_rot)
    V.step(t_lo + 3.0, 10.0, p.v_climb - p.v_rot)
    t = max(t_lo + p.t_upwind, t_lo + 14.0)
    phases.append(("crosswind turn", t))
    t = turn(t, p.v_climb, gam_c)
    t_lvl = t + p.t_crosswind
    phases.append(("level-off", t_lvl))
    Gm.step(t_lvl, 8.0, -gam_c)
    Al.step(t_lvl, 8.0, a_cruise - a_climb)
    V.step(t_lvl + 2.0, 10.0, p.v_pattern - p.v_climb)
    t = t_lvl + 14.0
    phases.append(("downwind turn", t))
    t = turn(t, p.v_pattern, 0.0)
    t_ab = t + t_dw
    phases.append(("descent", t_ab))
    V.step(t_ab, 10.0, p.v_approach - p.v_pattern)
    Al.step(t_ab, 8.0, a_app - a_cruise)
    Gm.step(t_ab + 4.0, 6.0, -gam_d)
    t = t_ab + 14.0
    phases.append(("base turn", t))
    t = turn(t, p.v_approach, gam_d)
    t = t + t_base
    phases.append(("final turn", t))
    t = turn(t, p.v_approach, gam_d)
    t_flare = t + p.t_final
    phases.append(("flare", t_flare))
    Gm.step(t_flare, 5.0, gam_d)
    Al.step(t_flare, 5.0, a_flare)
    V.step(t_flare - 3.0, 8.0, p.v_touchdown - p.v_approach)
    t_td = t_flare + 5.0
    phases.append(("touchdown", t_td))
    Al.step(t_td + 1.0, 3.0, -(a_app + a_flare))
    V.step(t_td + 2.0, p.t_brake, -p.v_touchdown)
    t_end = t_td + 2.0 + p.t_brake + 3.0
    phases.append(("stopped", t_end - 3.0))
    return _Plan(V.build(), R.build(), Gm.build(), Al.build(), p.heading, t_lvl + 8.0, t_td, t_end, tuple(phases))


def _random_params(seed: int) -> _Params:
    rng = np.random.default_rng(seed)
    u = rng.uniform
    return _Params(
        heading=float((45.0 + 90.0 * rng.integers(4) + u(-8.0, 8.0)) * _DEG),
        side=int(rng.choice([-1, 1])),
        h_pattern=u(280.0, 320.0),
        v_rot=u(28.0, 30.0),
        v_climb=u(34.0, 37.0),
        v_pattern=u(42.0, 46.0),
        v_approach=u(32.0, 35.0),
        v_touchdown=u(27.0, 29.0),
        bank=u(25.0, 29.0) * _DEG,
        t_roll=u(22.0, 26.0),
        t_upwind=u(38.0, 48.0),
        t_crosswind=u(12.0, 18.0),
        t_final=u(50.0, 60.0),
        t_brake=u(18.0, 24.0),
        touchdown_along=u(200.0, 300.0),
    )


# ---------------------------------------------------------------------------
# kinematics


def _kinematics(plan: _Plan, t: Array, g: float) -> dict[str, Array]:
    V, Vd = plan.V(t), plan.V(t, 1)
    gam, gamd = plan.gamma(t), plan.gamma(t, 1)
    al, ald = plan.alpha(t), plan.alpha(t, 1)
    psi = plan.heading0 + plan.rate(t, -1)
    psid, psidd = plan.rate(t), plan.rate(t, 1)
    cg, sg, cp, sp = np.cos(gam), np.sin(gam), np.cos(psi), np.sin(psi)
    v = V[:, None] * np.stack([cg * cp, cg * sp, -sg], -1)
    vdot = (
        Vd[:, None] * np.stack([cg * cp, cg * sp, -sg], -1)
        + (V * gamd)[:, None] * np.stack([-sg * cp, -sg * sp, -cg], -1)
        + (V * psid * cg)[:, None] * np.stack([-sp, cp, np.zeros_like(sp)], -1)
    )
    u = V * cg * psid / g
    ud = (Vd * cg * psid - V * sg * gamd * psid + V * cg * psidd) / g
    phi, phid = np.arctan(u), ud / (1.0 + u * u)
    th, thd = gam + al, gamd + ald
    rpy = np.stack([phi, th, psi], -1)
    cf, sf, ct, st = np.cos(phi), np.sin(phi), np.cos(th), np.sin(th)
    omega = np.stack([phid - psid * st, thd * cf + psid * ct * sf, -thd * sf + psid * ct * cf], -1)
    return {"v": v, "vdot": vdot, "rpy": rpy, "omega_b": omega}


def _velocity(plan: _Plan, t: Array) -> Array:
    V, gam = plan.V(t), plan.gamma(t)
    psi = plan.heading0 + plan.rate(t, -1)
    cg = np.cos(gam)
    return V[..., None] * np.stack([cg * np.cos(psi), cg * np.sin(psi), -np.sin(gam)], -1)


def _knots(plan: _Plan, t_end: float, h: float) -> Array:
    bps = plan.V.breakpoints() + plan.rate.breakpoints() + plan.gamma.breakpoints() + plan.alpha.breakpoints()
    pts = np.concatenate([np.arange(0.0, t_end, h), [t_end], np.array(bps, dtype=float)])
    pts = np.unique(pts[(pts >= 0.0) & (pts <= t_end)])
    keep = np.concatenate([[True], np.diff(pts) > 1e-9])
    return pts[keep]


def _integrate_on(plan: _Plan, a: Array, b: Array) -> Array:
    """``∫ₐᵇ vⁿ dt`` for intervals free of breakpoints, 8-point Gauss–Legendre, shape (N, 3)."""
    nodes = a[:, None] + (b - a)[:, None] * _GL_X[None, :]
    vals = _velocity(plan, nodes)  # (N, 8, 3)
    return (b - a)[:, None] * np.einsum("k,nkc->nc", _GL_W, vals)


@dataclass(frozen=True)
class _Positions:
    knots: Array
    p_knots: Array

    @classmethod
    def build(cls, plan: _Plan, t_end: float, h: float = 2.0) -> _Positions:
        knots = _knots(plan, t_end, h)
        inc = _integrate_on(plan, knots[:-1], knots[1:])
        return cls(knots, np.concatenate([np.zeros((1, 3)), np.cumsum(inc, axis=0)]))

    def at(self, plan: _Plan, t: Array) -> Array:
        k = np.clip(np.searchsorted(self.knots, t, side="right") - 1, 0, len(self.knots) - 1)
        return self.p_knots[k] + _integrate_on(plan, self.knots[k], t)


def _solve(p: _Params, g: float) -> tuple[_Plan, _Positions]:
    ax = np.array([np.cos(p.heading), np.sin(p.heading)])
    cross = np.array([-ax[1], ax[0]])

    def residual(x: Array) -> Array:
        plan = _plan(p, x, g)
        pos = _Positions.build(plan, plan.t_touchdown, h=4.0)
        p_lvl = pos.at(plan, np.array([plan.t_level]))[0]
        p_td = pos.p_knots[-1]
        return np.array(
            [
                (-p_lvl[2] - p.h_pattern) / 100.0,
                p_td[2] / 100.0,
                (p_td[:2] @ cross) / 1000.0,
                (p_td[:2] @ ax - p.touchdown_along) / 1000.0,
            ]
        )

    x0 = np.array([0.1, 0.06, 80.0, 25.0])
    x, info, ier, msg = scipy.optimize.fsolve(residual, x0, full_output=True, xtol=1e-13)
    res = residual(x)
    if ier != 1 and float(np.max(np.abs(res))) > 1e-9:
        raise DesignInfeasible(f"traffic pattern: the geometry could not be closed ({msg.strip()}); residual {res}")
    if not (0.0 < x[0] < 0.3 and 0.0 < x[1] < 0.2 and x[2] > 5.0 and x[3] > 5.0):
        raise DesignInfeasible(
            f"traffic pattern: implausible closure (climb γ={x[0]:.3g} rad, descent γ={x[1]:.3g} rad, "
            f"downwind {x[2]:.3g} s, base {x[3]:.3g} s)"
        )
    plan = _plan(p, x, g)
    return plan, _Positions.build(plan, plan.t_end)


# ---------------------------------------------------------------------------
# public API


@dataclass(frozen=True)
class Trajectory:
    """True flight states and exact inertial signals sampled at times ``t``.

    Attributes
    ----------
    t : (K,) times [s].
    p, v, vdot : (K, 3) NED position [m], velocity [m/s], acceleration ``v̇ⁿ`` [m/s²].
    R : (K, 3, 3) attitude, body→NED.
    rpy : (K, 3) ZYX Euler angles [roll, pitch, yaw] [rad]; yaw is unwrapped (continuous).
    omega_b : (K, 3) body rate ``ω^b`` [rad/s], with ``Ṙ = R S(ω^b)``.
    a_b : (K, 3) specific force ``a^b = Rᵀ(v̇ⁿ − gⁿ)`` [m/s²].
    m_b : (K, 3) magnetic field in body axes ``m^b = Rᵀ mⁿ``.
    m_n, g_n : (3,) magnetic field and gravity in NED.

    Examples
    --------
    The traffic pattern sampled at 10 Hz: level at the pattern altitude on downwind, back on the runway
    and stopped at the end; the signals are exact, so ``Ṙ = R S(ω^b)`` holds to the accuracy of a central
    difference, and the TRIAD margin ``min ‖m^b × a^b‖`` stays well away from zero:

    >>> import numpy as np
    >>> from nlobs.navigation.so3 import skew
    >>> flight = traffic_pattern(seed=0)
    >>> traj = flight.sample(10.0)
    >>> traj.t.shape, traj.R.shape, round(float(traj.altitude.max()), 1), round(flight.pattern_altitude, 1)
    ((3689,), (3689, 3, 3), 281.6, 281.6)
    >>> round(float(traj.speed.max()), 1), float(traj.speed[-1]), bool(abs(traj.altitude[-1]) < 1e-6)
    (45.7, 0.0, True)
    >>> Rdot = (traj.R[2:] - traj.R[:-2]) / 0.2  # central difference
    >>> bool(np.max(np.abs(Rdot - traj.R[1:-1] @ skew(traj.omega_b[1:-1]))) < 1e-3)
    True
    >>> round(float(triad_margin(traj).min()), 2)  # c_obs of Sec. 5.1 [m/s²]
    1.38
    """

    t: Array
    p: Array
    v: Array
    vdot: Array
    R: Array
    rpy: Array
    omega_b: Array
    a_b: Array
    m_b: Array
    m_n: Array
    g_n: Array

    @property
    def altitude(self) -> Array:
        """Height above the runway, ``−p_d`` [m]."""
        return -self.p[:, 2]

    @property
    def speed(self) -> Array:
        """Ground speed ``‖vⁿ‖`` [m/s]."""
        return np.linalg.norm(self.v, axis=-1)


@dataclass(frozen=True)
class Flight:
    """A generated flight, evaluable at any time in ``[0, duration]`` (call it with times).

    Build with :func:`traffic_pattern`. Beyond the natural end of the pattern the
    aircraft stands still on the runway.

    Attributes
    ----------
    duration : float
        Length of the flight [s].
    m_n, g_n : (3,) ndarray
        Earth magnetic field (unit, NED) and gravity ``[0, 0, g]``.
    runway_heading : float
        [rad], from north toward east.
    pattern_altitude : float
        [m] above the runway.
    side : int
        −1 for a left-hand pattern, +1 for a right-hand one.
    phases : tuple of (str, float)
        Named phases and their start times [s].

    Examples
    --------
    The first 100 s of a pattern, evaluated at any times in ``[0, 100]``: the specific force is
    ``a^b = Rᵀ(v̇ⁿ − gⁿ)``, and the position is the integral of the velocity (a central difference of ``p``
    gives ``v``):

    >>> import numpy as np
    >>> flight = traffic_pattern(seed=0, duration=100.0)
    >>> flight.duration, [name for name, _ in flight.phases]
    (100.0, ['take-off roll', 'rotation', 'climb', 'crosswind turn'])
    >>> at = flight([0.0, 60.0])  # a Trajectory of two samples
    >>> float(np.linalg.norm(at.v[0])), (np.round(at.a_b[0], 5) + 0.0).tolist()  # standing still, level
    (0.0, [0.0, 0.0, -9.80665])
    >>> bool(np.allclose(np.einsum("kji,kj->ki", at.R, at.vdot - at.g_n), at.a_b))
    True
    >>> near = flight([60.0 - 1e-3, 60.0 + 1e-3])
    >>> bool(np.allclose((near.p[1] - near.p[0]) / 2e-3, at.v[1], atol=1e-6))
    True
    >>> try:
    ...     flight([120.0])
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError t: times must lie in [0, 100] s, got [120, 120]
    """

    duration: float
    m_n: Array
    g_n: Array
    runway_heading: float
    pattern_altitude: float
    side: int
    phases: tuple[tuple[str, float], ...]
    _plan: _Plan = field(repr=False)
    _pos: _Positions = field(repr=False)

    def __call__(self, t: ArrayLike) -> Trajectory:
        """Evaluate the flight at times ``t`` (1-d, within ``[0, duration]``)."""
        tt = as_vector("t", np.atleast_1d(np.asarray(t, dtype=float)))
        if tt.size and (tt.min() < 0.0 or tt.max() > self.duration * (1 + 1e-12) + 1e-12):
            raise InvalidArgumentError(
                f"t: times must lie in [0, {self.duration:g}] s, got [{tt.min():g}, {tt.max():g}]"
            )
        g = float(self.g_n[2])
        kin = _kinematics(self._plan, tt, g)
        R = R_from_euler(kin["rpy"])
        Rt = np.swapaxes(R, -1, -2)
        a_b = np.einsum("kij,kj->ki", Rt, kin["vdot"] - self.g_n)
        m_b = np.einsum("kij,j->ki", Rt, self.m_n)
        return Trajectory(
            t=tt,
            p=self._pos.at(self._plan, np.minimum(tt, self._plan.t_end)),
            v=kin["v"],
            vdot=kin["vdot"],
            R=R,
            rpy=kin["rpy"],
            omega_b=kin["omega_b"],
            a_b=a_b,
            m_b=m_b,
            m_n=self.m_n.copy(),
            g_n=self.g_n.copy(),
        )

    def sample(self, rate_hz: float) -> Trajectory:
        """Evaluate on the uniform grid ``t_k = k / rate_hz``, ``0 ≤ t_k ≤ duration``."""
        rate = positive("rate_hz", rate_hz)
        n = int(np.floor(self.duration * rate + 1e-9)) + 1
        return self(np.arange(n) / rate)


def traffic_pattern(
    *,
    seed: int = 0,
    duration: float | None = None,
    m_n: ArrayLike | None = None,
    g: float = G0,
) -> Flight:
    """A light-aircraft flight around a rectangular traffic pattern (Grip, Saberi & Johansen, Sec. 5.2).

    Take-off roll, rotation, climb straight out, crosswind turn (climbing),
    level-off, downwind, power reduction and descent abeam the runway, base and
    final turns (coordinated, bank 25–29°), final approach, flare, touchdown
    and braking to a stop on the runway — about 6 minutes. Deterministic given
    ``seed``: the seed draws the runway heading (45° + k·90°, ±8°), the pattern
    side, pattern altitude (280–320 m), speeds (rotation 28–30 m/s, pattern
    42–46 m/s), bank and leg timing; the geometry is then closed by a root solve
    so that the aircraft lands back on the runway centre line.

    Parameters
    ----------
    seed : int
        Seed of the pattern's random parameters.
    duration : float, optional
        Truncate the flight to ``[0, duration]`` s; a duration beyond the natural
        end keeps the aircraft standing on the runway. Default: the natural end.
    m_n : array_like (3,), optional
        Earth magnetic field in NED (normalised to unit length); default
        :data:`M_N_DEFAULT`.
    g : float
        Gravity [m/s²]; ``gⁿ = [0, 0, g]``.

    Returns
    -------
    Flight
        Call it with times, or ``.sample(rate_hz)``, to get a :class:`Trajectory`.

    Raises
    ------
    DesignInfeasible
        If the pattern geometry cannot be closed (not expected for any seed).

    Examples
    --------
    The pattern of seed 0: a right-hand pattern at 281.6 m from a runway heading 311°, about six minutes
    from the take-off roll to the stop, ending back on the runway centre line at ground level:

    >>> import numpy as np
    >>> flight = traffic_pattern(seed=0)
    >>> round(flight.duration, 1), round(float(np.degrees(flight.runway_heading)), 1), flight.side
    (368.9, 311.3, 1)
    >>> [name for name, _ in flight.phases]
    ['take-off roll', 'rotation', 'climb', 'crosswind turn', 'level-off', 'downwind turn', 'descent', 'base turn',
     'final turn', 'flare', 'touchdown', 'stopped']
    >>> end = flight([flight.duration])
    >>> heading = np.array([np.cos(flight.runway_heading), np.sin(flight.runway_heading)])
    >>> off_centre_line = end.p[0, :2] @ np.array([-heading[1], heading[0]])
    >>> bool(abs(end.altitude[0]) < 1e-6), bool(abs(off_centre_line) < 1e-6), float(end.speed[0])
    (True, True, 0.0)
    >>> flight.g_n.tolist(), round(float(np.linalg.norm(flight.m_n)), 12)  # gravity and the unit field
    ([0.0, 0.0, 9.80665], 1.0)
    """
    g = positive("g", g)
    mn = M_N_DEFAULT.copy() if m_n is None else as_vector("m_n", m_n, 3)
    nrm = float(np.linalg.norm(mn))
    if nrm == 0.0:
        raise InvalidArgumentError("m_n: the magnetic field must be non-zero")
    mn = mn / nrm
    params = _random_params(int(seed))
    plan, pos = _solve(params, g)
    dur = plan.t_end if duration is None else positive("duration", duration)
    return Flight(
        duration=float(dur),
        m_n=mn,
        g_n=np.array([0.0, 0.0, g]),
        runway_heading=params.heading,
        pattern_altitude=params.h_pattern,
        side=params.side,
        phases=tuple((name, float(t0)) for name, t0 in plan.phases if t0 <= dur),
        _plan=plan,
        _pos=pos,
    )


def triad_margin(traj: Trajectory) -> Array:
    """``‖m^b × a^b‖`` at each sample: the TRIAD observability margin of Grip, Saberi & Johansen, Sec. 5.1.

    The attitude observer (22) needs ``‖m^b × a^b‖ ≥ c_obs > 0``; ``min`` of this
    array is the ``c_obs`` of the flight [m/s², with a unit ``m``].

    Parameters
    ----------
    traj : Trajectory
        The flight (its ``m_b`` and ``a_b`` are used).

    Returns
    -------
    ndarray, shape (K,)
    """
    return np.linalg.norm(np.cross(traj.m_b, traj.a_b), axis=-1)
