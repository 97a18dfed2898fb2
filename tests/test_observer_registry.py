"""Every estimator of nlobs satisfies the one observer protocol and runs through the one loop.

What this file guarantees
-------------------------
* Registry: every class whose name ends in ``Observer``, ``Filter``, ``Predictor``, ``EKF`` or ``UKF`` (the protocol
  classes ``Observer``, ``CorrectingObserver``, ``SelfStepping``, ``Diagnosing``,
  ``DeferredEstimate`` excepted) exported by :mod:`nlobs.observers` or one of its modules, by a
  module of :mod:`nlobs.navigation` or by the top level :mod:`nlobs` has a case in ``CASES``, and
  each case's class is exported from the top level. An estimator added without a case fails
  :func:`test_every_estimator_has_a_case`.
* Protocol: each case builds a real instance with public constructors and checks that it is an
  :class:`~nlobs.observers.base.Observer`, a :class:`~nlobs.observers.base.CorrectingObserver`
  exactly when it has ``correct``, has exactly the optional capabilities it is meant to have,
  that ``estimate(init(x̂0)) = x̂0`` for the batch shapes it accepts, and that one step of a batch
  (``correct``, then ``rhs``/``step``/RK4 on ``rhs``) equals the same step of each member alone.
* Loop: each case runs through :func:`nlobs.simulate.simulate` (with its plant) or
  :func:`nlobs.simulate.run_observer` (on recorded data) and checks a fact known independently
  of the observer's code: a closed-form error (matrix exponential, matrix power, a Kalman filter
  written out here), a guaranteed bound (the set-valued radii), or a decrease of the estimation
  error by a stated factor. Where there is a plant, ``run_observer`` on the data recorded by
  ``simulate`` reproduces ``simulate``'s estimates.
"""

from __future__ import annotations

import importlib
import math
import pkgutil
import re
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pytest
import scipy.linalg as sla
import sympy as sp
from scipy.signal import place_poles

import nlobs
import nlobs.navigation
import nlobs.observers
from nlobs import (
    ByrnesIsidoriObserver,
    CascadeObserver,
    ConstantGainObserver,
    ImpulsiveObserver,
    OutputPredictor,
    Continuous,
    CorrectingObserver,
    Discrete,
    DiscreteLipschitzObserver,
    DriftObserver,
    EKF,
    ExtendedKalmanFilter,
    GnssInsObserver,
    LinearSystem,
    LuenbergerObserver,
    Observer,
    PinvObserver,
    ScheduledGnssInsObserver,
    SetValuedObserver,
    UKF,
    UnknownInputEKF,
    design_discrete_lipschitz_gain,
    design_setvalued,
    load_model,
)
from nlobs.navigation import metrics as nav_metrics
from nlobs.navigation.base import NAV_STATES, nav_vector
from nlobs.navigation.ekf import EkfConfig
from nlobs.navigation.sensors import SensorNoise, generate_sensors
from nlobs.navigation.so3 import rot_z
from nlobs.navigation.trajectory import traffic_pattern
from nlobs.observers.base import DeferredEstimate, Diagnosing, SelfStepping
from nlobs.papers.khajenejad_yong import example_61
from nlobs.simulate import MeasurementGroup, SimulationResult, rk4_step, run_observer, simulate
from nlobs.simulate.setvalued import ball_samples
from nlobs.synthesis import extended_system
from nlobs.synthesis.drift_gain import vandermonde_gain
from nlobs.synthesis.pinv_gain import HighGain
from nlobs.systems.interconnected import LinearSubsystem, NonlinearSubsystem, interconnected_plant

#: Names of the protocol classes (not estimators).
PROTOCOLS = frozenset({"Observer", "CorrectingObserver", "SelfStepping", "Diagnosing", "DeferredEstimate"})
#: What counts as an estimator class by its name.
ESTIMATOR_NAME = re.compile(r"(Observer|Filter|Predictor|EKF|UKF)$")
CAPABILITIES = (SelfStepping, Diagnosing, DeferredEstimate)
BATCHES: tuple[tuple[int, ...], ...] = ((), (2,), (2, 3))


# ----------------------------------------------------------------------------- shared checks
def check_protocol(obs: Any, x_hat0: Sequence[float], u: Sequence[float], y: Sequence[float], *, time: type,
                   correcting: bool, capabilities: tuple[type, ...] = (),
                   batches: tuple[tuple[int, ...], ...] = BATCHES) -> None:
    """The protocol of ``nlobs.observers.base`` for ``obs``, with a typical input ``u`` and measurement ``y``.

    Membership (a correcting observer exactly when it has ``correct``; exactly the optional
    capabilities listed), the time base, ``n_x``, ``estimate(init(x̂0)) = x̂0`` for each batch shape,
    and batch independence: one step (``correct`` if correcting, then ``rhs`` for a discrete observer,
    ``step`` for a self-stepping one, else one RK4 step of ``rhs``) on the largest batch, with different
    ``u`` and ``y`` per member, equals the same step of each member alone.
    """
    assert isinstance(obs, Observer)
    assert isinstance(obs, CorrectingObserver) is correcting
    assert callable(getattr(obs, "correct", None)) is correcting
    for cap in CAPABILITIES:
        assert isinstance(obs, cap) is (cap in capabilities), cap.__name__
    assert isinstance(obs.time, time)
    xh = np.asarray(x_hat0, dtype=float)
    assert isinstance(obs.n_x, int) and xh.shape == (obs.n_x,)
    estimate = obs.raw_estimate if isinstance(obs, DeferredEstimate) else obs.estimate
    for batch in batches:
        want = np.broadcast_to(xh, (*batch, obs.n_x))
        np.testing.assert_allclose(estimate(obs.init(want.copy())), want, rtol=0, atol=1e-12)

    h = obs.time.dt if obs.time.is_discrete else 0.01

    def one_step(x: np.ndarray, uu: np.ndarray, yy: np.ndarray) -> np.ndarray:
        z = obs.init(x)
        if correcting:
            z = obs.correct(0.0, z, uu, yy, np.ones(yy.shape[-1], dtype=bool))
        if obs.time.is_discrete:
            z = obs.rhs(0.0, z, uu, yy)
        elif isinstance(obs, SelfStepping):
            z = obs.step(0.0, z, uu, yy, h)
        else:
            z = rk4_step(lambda t, zz: obs.rhs(t, zz, uu, yy), 0.0, z, h)
        return np.asarray(estimate(z))

    batch = batches[-1]
    rng = np.random.default_rng(0)
    uu = np.asarray(u, dtype=float) + 0.01 * rng.standard_normal((*batch, len(u)))
    yy = np.asarray(y, dtype=float) + 0.01 * rng.standard_normal((*batch, len(y)))
    xb = np.broadcast_to(xh, (*batch, obs.n_x)).copy()
    together = one_step(xb, uu, yy)
    assert together.shape == (*batch, obs.n_x) and np.isfinite(together).all()
    for idx in np.ndindex(*batch):
        member = tuple(slice(i, i + 1) for i in idx)  # a batch of one (keeps the batch axes)
        np.testing.assert_allclose(together[member], one_step(xb[member], uu[member], yy[member]),
                                   rtol=1e-10, atol=1e-10)


def check_result(res: SimulationResult, batch: tuple[int, ...], K: int, n_x: int) -> None:
    """A result of ``K`` saved instants with finite estimates of shape ``(*batch, K, n_x)``."""
    assert res.t.shape == (K,)
    assert res.x_hat.shape == (*batch, K, n_x)
    assert np.isfinite(res.x_hat).all()


def check_replay(plant: Any, obs: Any, x0: Any, x_hat0: Any, *, u: Sequence[float], dt: float, steps: int,
                 sim: SimulationResult | None = None) -> None:
    """``run_observer`` on the measurements recorded by ``simulate`` reproduces ``simulate``'s estimates.

    A continuous observer is simulated with every output sampled at every step (held over the RK4
    step, as ``run_observer`` holds it); a discrete one reads the exact output at every step.
    """
    u_arr = np.asarray(u, dtype=float)
    if sim is None:
        meas = None if obs.time.is_discrete else MeasurementGroup("all", list(range(plant.p)), rate=1.0 / dt)
        sim = simulate(plant, obs, x0, x_hat0, duration=steps * dt, dt=dt, u=u_arr, measurements=meas)
    K = sim.t.size
    u_grid = u_arr if u_arr.ndim == 2 else np.broadcast_to(u_arr, (K, u_arr.size))
    rep = run_observer(obs, sim.t, x_hat0=x_hat0, u=u_grid, y=sim.y, truth=sim.x)
    check_result(rep, sim.batch_shape, K, obs.n_x)
    np.testing.assert_allclose(rep.x_hat, sim.x_hat, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(rep.error_norm, sim.error_norm, rtol=1e-10, atol=1e-12)


# ----------------------------------------------------------------------------- linear data
A2 = np.array([[0.0, 1.0], [-2.0, -0.5]])
B2 = np.array([[0.0], [1.0]])
C2 = np.array([[1.0, 0.0]])
L2 = np.array([[3.0], [2.0]])

DT = Discrete(0.1)
A3 = np.array([[1.0, 0.1, 0.0], [-0.3, 0.95, 0.1], [0.0, -0.2, 0.9]])
B3 = np.array([[0.0], [0.1], [0.05]])
C3 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
D3 = np.array([[0.0], [0.2]])


def _u_sine(t: float) -> np.ndarray:
    return np.array([np.sin(2.0 * t)])


def _on_grid(u: Callable[[float], np.ndarray], t: np.ndarray) -> np.ndarray:
    return np.stack([u(float(tk)) for tk in t])


# ----------------------------------------------------------------------------- cases
def case_luenberger() -> Any:
    """Continuous Luenberger observer: the error is exactly ``expm((A − LC) t) e0`` (RK4 at h = 2e-3)."""
    plant = LinearSystem(A2, B2, C2)
    obs = LuenbergerObserver(plant, L2)
    check_protocol(obs, [0.1, -0.2], [0.3], [0.5], time=Continuous, correcting=False)
    x0 = np.array([[1.0, 0.0], [-0.5, 2.0]])
    x_hat0 = np.zeros(2)
    sim = simulate(plant, obs, x0, x_hat0, duration=4.0, dt=2e-3, u=_u_sine, save_every=10)
    check_result(sim, (2,), 201, 2)
    F = A2 - L2 @ C2
    want = np.einsum("kij,bj->bki", sla.expm(sim.t[:, None, None] * F), x_hat0 - x0)
    np.testing.assert_allclose(sim.error, want, rtol=0, atol=1e-9)
    check_replay(plant, obs, x0, x_hat0, u=[0.3], dt=0.01, steps=100)
    return obs


def _sigma1_linear() -> NonlinearSubsystem:
    x = sp.Matrix(sp.symbols("x1 x2", real=True))
    u = sp.Matrix([sp.Symbol("u", real=True)])
    z = sp.Matrix([sp.Symbol("z", real=True)])
    f = sp.Matrix([[0, 1], [-2, -1]]) * x + sp.Matrix([[0], [1]]) * u
    h = sp.Matrix([[1, sp.Rational(1, 2)]]) * x + sp.Matrix([[sp.Rational(3, 10)]]) * u
    g = sp.Matrix([[1], [2]]) * (z - h)
    return NonlinearSubsystem.symbolic(states=["x1", "x2"], inputs=["u"], outputs=["z"], f=f, h=h, g=g)


def case_cascade() -> Any:
    """Cascade observer (9)–(10) on a linear Σ1: the error ``[x̃; w̃; z̃]`` is ``expm(M t)`` of it at t = 0.

    With ``f = F x + G u``, ``h = H x + J u``, ``g = L (z − h)`` the error system is
    ``x̃' = (F − LH) x̃ + L z̃``, ``w̃' = (A − K_w C) w̃ + (B_z − K_w D_z) z̃``,
    ``z̃' = H F x̃ − K_z C w̃ − K_z D_z z̃`` (derived from (1), (2), (9), (10); ``x̃ = x − x̂``).
    """
    F, H, L = np.array([[0.0, 1.0], [-2.0, -1.0]]), np.array([[1.0, 0.5]]), np.array([[1.0], [2.0]])
    A, Bz, C, Dz = np.array([[0.0, 1.0], [-1.0, -1.0]]), np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]]), np.array(
        [[0.2]])
    sigma1 = _sigma1_linear()
    sigma2 = LinearSubsystem(A, Bz, C, Dz, B_u=[[0.1], [0.0]], D_u=[[0.5]])
    ext = extended_system(sigma2.A, sigma2.B_z, sigma2.C, sigma2.D_z)  # 𝔄, ℭ of (8c): K places 𝔄 − Kℭ at −2, −3, −4
    K = place_poles(ext.A.T, ext.C.T, [-2.0, -3.0, -4.0]).gain_matrix.T
    Kw, Kz = K[:2], K[2:]
    obs = CascadeObserver(sigma1, sigma2, K)
    plant = interconnected_plant(sigma1, sigma2)
    check_protocol(obs, [0.1, -0.2, 0.3, 0.4], [0.3], [0.5], time=Continuous, correcting=False)
    M = np.block([[F - L @ H, np.zeros((2, 2)), L], [np.zeros((2, 2)), A - Kw @ C, Bz - Kw @ Dz],
                  [H @ F, -Kz @ C, -Kz @ Dz]])
    assert np.max(np.linalg.eigvals(M).real) < 0
    x0, x_hat0 = np.array([1.0, -0.5, 0.3, 0.2]), np.array([-0.5, 0.7, -0.4, 0.6])
    sim = simulate(plant, obs, x0, x_hat0, duration=3.0, dt=5e-3, u=_u_sine, save_every=10)
    check_result(sim, (), 61, 4)
    e0 = x0 - x_hat0
    full0 = np.concatenate([e0, H @ e0[:2]])  # ξ0 = 0: ẑ0 = h(u0, x̂0), so z̃0 = H x̃0
    want = (sla.expm(sim.t[:, None, None] * M) @ full0)[:, :4]
    np.testing.assert_allclose(-sim.error, want, rtol=0, atol=1e-7)  # RK4 at h = 5e-3: measured 8.6e-9
    assert sim.error_norm[-1] < 0.2 * sim.error_norm[0]
    check_replay(plant, obs, np.stack([x0, -x0]), x_hat0, u=[0.3], dt=0.01, steps=50)
    return obs


def case_constant_gain() -> Any:
    """Constant-gain copy of a nonlinear plant: on a linear plant the error is exactly ``expm((A − LC) t) e0``;
    on the pendulum with the gain of its linearisation, ‖e‖ drops by 10³ in 8 s from a 0.3 rad error."""
    lin = LinearSystem(A2, B2, C2)
    obs = ConstantGainObserver(lin, L2)
    check_protocol(obs, [0.1, -0.2], [0.3], [0.5], time=Continuous, correcting=False)
    x0 = np.array([[1.0, 0.0], [-0.5, 2.0]])
    sim = simulate(lin, obs, x0, np.zeros(2), duration=4.0, dt=2e-3, u=_u_sine, save_every=10)
    F = A2 - L2 @ C2
    want = np.einsum("kij,bj->bki", sla.expm(sim.t[:, None, None] * F), -x0)
    np.testing.assert_allclose(sim.error, want, rtol=0, atol=1e-9)
    plant = load_model("pendulum").compile()
    pend = ConstantGainObserver(plant, [[4.0], [4.0]])  # A − LC of the linearisation at 0: poles −2.1 ± 3.19j
    sim = simulate(plant, pend, [[0.5, 0.0]], [0.2, 0.3], duration=8.0, dt=2e-3, u=_u_sine, save_every=10)
    assert np.all(sim.error_norm[:, -1] < 1e-3 * sim.error_norm[:, 0])
    check_replay(plant, pend, [[0.5, 0.0]], [0.2, 0.3], u=[0.3], dt=0.01, steps=100)
    return pend


def case_impulsive() -> Any:
    """Impulsive observer on a linear plant sampled every 0.5: at the samples the error follows the exact jump map
    ``(I − LC) e^{AT}``; on the pendulum sampled at 20 Hz ‖e‖ drops by 10³ in 8 s."""
    lin = LinearSystem(A2, B2, C2)
    Lj = np.array([[0.8], [0.6]])
    obs = ImpulsiveObserver(lin, Lj)
    check_protocol(obs, [0.1, -0.2], [0.3], [0.5], time=Continuous, correcting=True)
    T, dt = 0.5, 1e-3
    group = [MeasurementGroup("s", outputs=[0], rate=1 / T, noise_std=0.0)]
    x0 = np.array([[1.0, 0.0], [-0.5, 2.0]])
    sim = simulate(lin, obs, x0, np.zeros(2), duration=2.0, dt=dt, u=_u_sine, measurements=group)
    M = (np.eye(2) - Lj @ C2) @ sla.expm(A2 * T)
    k = int(round(T / dt))
    for j in range(1, 3):  # the estimate recorded at a sample is after its jump; u enters e only through x̂ − x
        np.testing.assert_allclose(sim.error[:, (j + 1) * k], sim.error[:, j * k] @ M.T, rtol=0, atol=1e-9)
    plant = load_model("pendulum").compile()
    pend = ImpulsiveObserver(plant, [[0.3], [0.4]])
    sim = simulate(plant, pend, [[0.5, 0.0]], [0.2, 0.3], duration=8.0, dt=2e-3, u=_u_sine, save_every=10,
                   measurements=[MeasurementGroup("enc", outputs=[0], rate=20.0, noise_std=0.0)])
    assert np.all(sim.error_norm[:, -1] < 1e-3 * sim.error_norm[:, 0])
    return pend


def case_output_predictor() -> Any:
    """A Luenberger observer through the output predictor, sampled every 0.2 on a linear plant without input: the
    error at the samples follows the exact one-period map of the hybrid system ``ė = (A − LC)e + Lδ, δ̇ = CAe``."""
    lin = LinearSystem(A2, B2, C2)
    obs = OutputPredictor(LuenbergerObserver(lin, L2), lin)
    check_protocol(obs, [0.1, -0.2], [0.3], [0.5], time=Continuous, correcting=True)
    T, dt = 0.2, 1e-3
    sim = simulate(lin, obs, np.array([[1.0, 0.0], [-0.5, 2.0]]), np.zeros(2), duration=6.0, dt=dt,
                   u=np.zeros(1), measurements=[MeasurementGroup("s", outputs=[0], rate=1 / T, noise_std=0.0)])
    big = np.block([[A2 - L2 @ C2, L2], [C2 @ A2, np.zeros((1, 1))]])
    M = sla.expm(big * T)[:2, :2]
    k = int(round(T / dt))
    for j in range(3):
        np.testing.assert_allclose(sim.error[:, (j + 1) * k], sim.error[:, j * k] @ M.T, rtol=0, atol=1e-9)
    assert np.all(sim.error_norm[:, -1] < 0.05 * sim.error_norm[:, 0])
    return obs


def case_drift() -> Any:
    """Drift observer (3.1) on the Van der Pol model (Φ_s a global diffeomorphism): ‖e‖ drops by 10⁴ in 3 s."""
    model = load_model("vanderpol-lienard")
    obs = DriftObserver.from_model(model, vandermonde_gain((2,), 4.0).K)
    plant = model.compile()
    check_protocol(obs, [0.5, 1.0], [0.3], [0.7], time=Continuous, correcting=False)
    x0 = np.array([[2.0, 0.0], [-1.0, 1.5]])
    sim = simulate(plant, obs, x0, [0.0, 1.0], duration=3.0, dt=5e-3, u=_u_sine, save_every=10)
    check_result(sim, (2,), 61, 2)
    assert np.all(sim.error_norm[:, -1] < 1e-4 * sim.error_norm[:, 0])
    check_replay(plant, obs, x0, [0.0, 1.0], u=[0.3], dt=0.01, steps=50)
    return obs


ISIDORI_X0 = np.array([0.5, -2.0, -2.0, 0.0])
ISIDORI_XHAT0 = np.array([0.3, -1.5, 0.0, 0.5])


def case_pinv() -> Any:
    """Moore–Penrose observer (7)/(17) on isidori-146: l3 ≡ 0 by (26), so x̂3 − x3 = e3(0) e^{−t} exactly (A4)."""
    model = load_model("isidori-146")
    obs = PinvObserver.from_model(model, k=HighGain(3.0))
    plant = model.compile()
    check_protocol(obs, ISIDORI_XHAT0, [0.3], [0.7], time=Continuous, correcting=False)
    sim = simulate(plant, obs, ISIDORI_X0, ISIDORI_XHAT0, duration=3.0, dt=2e-3, u=_u_sine, save_every=25)
    check_result(sim, (), 61, 4)
    e = sim.error
    np.testing.assert_allclose(e[:, 2], e[0, 2] * np.exp(-sim.t), rtol=0, atol=1e-9)
    assert sim.error_norm[-1] < 0.1 * sim.error_norm[0]
    check_replay(plant, obs, ISIDORI_X0, ISIDORI_XHAT0, u=[0.0], dt=0.01, steps=50)
    return obs


def case_byrnes_isidori() -> Any:
    """Byrnes–Isidori observer (8)/(24) on isidori-146, x̂3 kept off its pole −1: ‖e‖ drops by 20 in 3 s."""
    model = load_model("isidori-146")
    x1, x2, x3 = sp.symbols("x1 x2 x3", real=True)
    obs = ByrnesIsidoriObserver.from_model(model, [x2 - 2 * x3 - x3**2, x1], k=HighGain(3.0))
    plant = model.compile()
    check_protocol(obs, ISIDORI_XHAT0, [0.3], [0.7], time=Continuous, correcting=False)
    x0 = ISIDORI_X0  # the plant's x3 crosses −1, the estimate's does not
    sim = simulate(plant, obs, x0, ISIDORI_XHAT0, duration=3.0, dt=2e-3, u=_u_sine, save_every=25)
    check_result(sim, (), 61, 4)
    assert np.all(sim.x_hat[:, 2] > -1.0)
    assert sim.error_norm[-1] < 0.05 * sim.error_norm[0]
    check_replay(plant, obs, x0, ISIDORI_XHAT0, u=[0.0], dt=0.01, steps=50)
    return obs


def case_setvalued() -> Any:
    """Algorithm 1 (Khajenejad & Yong) on Sec. 6.1 (Class II): the true state and input stay in the balls (Thm.)."""
    ex = example_61("II")
    s = ex.system
    obs = SetValuedObserver(s, design_setvalued(s))
    check_protocol(obs, s.x0, np.zeros(s.m), [0.1, -0.1], time=Discrete, correcting=True, capabilities=(Diagnosing,))
    rng = np.random.default_rng(4)
    runs, steps = 5, 60
    t = np.arange(steps + 1) * s.time.dt
    d = np.broadcast_to(ex.unknown_input(t)[None], (runs, steps + 1, s.p))
    x0 = s.x0 + ball_samples(rng, (runs,), s.delta0, s.n)
    x, y = s.simulate(x0, d, ball_samples(rng, (runs, steps), s.eta_w, s.n_w),
                      ball_samples(rng, (runs, steps + 1), s.eta_v, s.l))
    res = run_observer(obs, t, x_hat0=np.broadcast_to(s.x0, (runs, s.n)), y=y, truth=x)
    check_result(res, (runs,), steps + 1, s.n)
    radius = res.extras["radius_state"]
    assert radius.shape == (steps + 1,) and np.isfinite(radius).all()
    assert np.all(np.linalg.norm(x - res.x_hat, axis=-1) <= radius * (1 + 1e-9) + 1e-12)
    d_err = np.linalg.norm(d[:, :-1] - res.extras["d_hat"][:, 1:], axis=-1)  # d̂_{k−1} recorded at k
    assert np.all(d_err <= res.extras["radius_input"][1:] * (1 + 1e-9) + 1e-12)
    return obs


def case_discrete_lipschitz() -> Any:
    """Discrete Lipschitz observer on an LTI plant (γ = 0): the error is exactly ``(A − LC)^k e0``."""
    cert = design_discrete_lipschitz_gain(A3, C3, lipschitz=0.0)
    obs = DiscreteLipschitzObserver(A3, C3, cert.gain, DT, B=B3, D=D3)
    plant = LinearSystem(A3, B3, C3, D3, time=DT)
    check_protocol(obs, [0.1, -0.2, 0.3], [0.3], [0.5, -0.5], time=Discrete, correcting=False)
    x0 = np.array([[1.0, -2.0, 0.5], [0.0, 1.0, -1.0]])
    x_hat0 = np.zeros(3)
    sim = simulate(plant, obs, x0, x_hat0, duration=3.0, u=_u_sine)
    check_result(sim, (2,), 31, 3)
    F = A3 - cert.gain @ C3
    want = np.stack([[np.linalg.matrix_power(F, k) @ (x_hat0 - x0[b]) for k in range(31)] for b in range(2)])
    np.testing.assert_allclose(sim.error, want, rtol=0, atol=1e-12)
    assert np.all(sim.error_norm[:, -1] < 0.01 * sim.error_norm[:, 0])
    check_replay(plant, obs, x0, x_hat0, u=_on_grid(_u_sine, sim.t), dt=DT.dt, steps=30, sim=sim)
    return obs


def _kalman(A, B, C, D, Q, R, S, x0, P0, us, ys):  # type: ignore[no-untyped-def]
    """Predictor-form Kalman filter with correlated noises (Anderson & Moore), plain NumPy: priors x_{k|k−1}."""
    x, P, xs = x0.copy(), P0.copy(), [x0.copy()]
    for u, y in zip(us, ys, strict=True):
        Sig = C @ P @ C.T + R
        K = (A @ P @ C.T + S) @ np.linalg.inv(Sig)
        x = A @ x + B @ u + K @ (y - C @ x - D @ u)
        P = A @ P @ A.T + Q - K @ Sig @ K.T
        xs.append(x.copy())
    return np.array(xs)


def case_unknown_input_ekf() -> Any:
    """The unknown-input EKF on an LTI plant is the Kalman filter with correlated noises (written out here)."""
    G, H = np.array([[0.1], [1.0], [0.0]]), np.array([[0.0], [0.5]])
    Q_w, R_v, Q_d, P0 = 0.01 * np.eye(3), np.diag([0.02, 0.03]), np.array([[0.3]]), np.eye(3)
    ekf = UnknownInputEKF(A3, C3, DT, Q_w=Q_w, R_v=R_v, Q_d=Q_d, B=B3, D=D3, G=G, H=H, P0=P0)
    plant = LinearSystem(A3, B3, C3, D3, time=DT)
    check_protocol(ekf, [0.1, -0.2, 0.3], [0.3], [0.5, -0.5], time=Discrete, correcting=False)
    x0 = np.array([[1.0, -2.0, 0.5], [0.0, 1.0, -1.0]])
    x_hat0 = np.zeros(3)
    sim = simulate(plant, ekf, x0, x_hat0, duration=3.0, u=_u_sine)
    check_result(sim, (2,), 31, 3)
    us = _on_grid(_u_sine, sim.t)
    Q, R, S = Q_w + G @ Q_d @ G.T, R_v + H @ Q_d @ H.T, G @ Q_d @ H.T
    for b in range(2):
        want = _kalman(A3, B3, C3, D3, Q, R, S, x_hat0, P0, us[:-1], sim.y[b, :-1])
        np.testing.assert_allclose(sim.x_hat[b], want, rtol=1e-10, atol=1e-12)
    assert np.all(sim.error_norm[:, -1] < 0.05 * sim.error_norm[:, 0])
    check_replay(plant, ekf, x0, x_hat0, u=us, dt=DT.dt, steps=30, sim=sim)
    return ekf


def _check_gaussian_filter(cls: type) -> Any:
    """EKF or UKF on an LTI plant: the Kalman filter (written out here), one step behind (posteriors vs priors).

    The filter records the posterior ``x̂_{k|k}`` (correct, then record, then predict); :func:`_kalman`
    returns the priors, ``x̂_{k+1|k} = A x̂_{k|k} + B u_k``.
    """
    Q, R, P0 = 0.01 * np.eye(3), np.diag([0.02, 0.03]), np.eye(3)
    plant = LinearSystem(A3, B3, C3, D3, time=DT)
    filt = cls(plant, Q, R, P0)
    check_protocol(filt, [0.1, -0.2, 0.3], [0.3], [0.5, -0.5], time=Discrete, correcting=True,
                   capabilities=(Diagnosing,))
    x0 = np.array([[1.0, -2.0, 0.5], [0.0, 1.0, -1.0]])
    x_hat0 = np.zeros(3)
    sim = simulate(plant, filt, x0, x_hat0, duration=3.0, u=_u_sine)
    check_result(sim, (2,), 31, 3)
    us = _on_grid(_u_sine, sim.t)
    for b in range(2):
        want = _kalman(A3, B3, C3, D3, Q, R, np.zeros((3, 2)), x_hat0, P0, us[:-1], sim.y[b, :-1])
        np.testing.assert_allclose(sim.x_hat[b, :-1] @ A3.T + us[:-1] @ B3.T, want[1:], rtol=1e-10, atol=1e-12)
    assert np.all(sim.error_norm[:, -1] < 0.05 * sim.error_norm[:, 0])
    check_replay(plant, filt, x0, x_hat0, u=us, dt=DT.dt, steps=30, sim=sim)
    return filt


def case_ekf() -> Any:
    """The EKF of any plant on an LTI plant is the Kalman filter (see :func:`_check_gaussian_filter`)."""
    return _check_gaussian_filter(EKF)


def case_ukf() -> Any:
    """The UKF on an LTI plant is the Kalman filter too (the unscented transform is exact for linear maps)."""
    return _check_gaussian_filter(UKF)


def case_particle_filter() -> Any:
    """The bootstrap particle filter on the LTI plant of the Kalman filters: with 20 000 particles its mean follows the
    Kalman filter (written out here) within the Monte Carlo error (measured 0.03 at most; 0.1 asserted, a tenth of
    the initial error). Its draws depend on a run's place in the batch (run 0 alone is run 0 of a batch), so batch
    independence is checked on the shapes where every member is run 0."""
    Q, R, P0 = 0.01 * np.eye(3), np.diag([0.02, 0.03]), np.eye(3)
    plant = LinearSystem(A3, B3, C3, D3, time=DT)
    pf = nlobs.ParticleFilter(plant, Q, R, P0, particles=20000, seed=0)
    check_protocol(pf, [0.1, -0.2, 0.3], [0.3], [0.5, -0.5], time=Discrete, correcting=True,
                   capabilities=(SelfStepping, Diagnosing), batches=((), (1,), (1, 1)))
    x0 = np.array([[1.0, -2.0, 0.5], [0.0, 1.0, -1.0]])
    x_hat0 = np.zeros(3)
    sim = simulate(plant, pf, x0, x_hat0, duration=3.0, u=_u_sine)
    check_result(sim, (2,), 31, 3)
    us = _on_grid(_u_sine, sim.t)
    for b in range(2):
        want = _kalman(A3, B3, C3, D3, Q, R, np.zeros((3, 2)), x_hat0, P0, us[:-1], sim.y[b, :-1])
        np.testing.assert_allclose(sim.x_hat[b, :-1] @ A3.T + us[:-1] @ B3.T, want[1:], rtol=0, atol=0.1)
    assert np.all(sim.error_norm[:, -1] < 0.1 * sim.error_norm[:, 0])
    check_replay(plant, pf, x0, x_hat0, u=us, dt=DT.dt, steps=30, sim=sim)
    return pf


YAW_ERROR_DEG = 30.0
P_OFFSET = np.array([3.0, -2.0, 1.0])


def _flight_run(filt: Any, duration: float = 20.0) -> SimulationResult:
    """``filt`` by ``run_observer`` on noise-free sensors of a traffic pattern (100 Hz IMU, 5 Hz GNSS).

    The estimate starts :data:`YAW_ERROR_DEG` off in yaw and :data:`P_OFFSET` off in position. Two
    flights in a batch; flight 1 misses fix 5 (NaN, at t = 1 s): a correcting observer must skip it
    there only, so both flights agree exactly before it and differ after it.
    """
    traj = traffic_pattern(seed=0, duration=duration).sample(100.0)
    data = generate_sensors(traj, imu_rate_hz=100.0, gnss_rate_hz=5.0, noise=SensorNoise(), seed=0)
    y = np.stack([data.gnss_output(), data.gnss_output()])
    y[1, 5] = np.nan
    x_hat0 = nav_vector(traj.p[0] + P_OFFSET, traj.v[0] + [0.5, 0.0, 0.0],
                        rot_z(math.radians(YAW_ERROR_DEG)) @ traj.R[0])
    res = run_observer(filt, data.t_imu, x_hat0=x_hat0, u=data.imu_input(), y=y, y_times=data.t_gnss,
                       truth=data.truth(), states=NAV_STATES)
    check_result(res, (2,), data.t_imu.size, 15)
    np.testing.assert_array_equal(res.info["missing"], [0, 1])
    k5 = int(np.flatnonzero(np.isclose(data.t_imu, data.t_gnss[5]))[0])
    np.testing.assert_array_equal(res.x_hat[0, :k5], res.x_hat[1, :k5])
    assert not np.array_equal(res.x_hat[0, k5:k5 + 10], res.x_hat[1, k5:k5 + 10])
    att = nav_metrics.attitude_error_deg(res)
    np.testing.assert_allclose(att[:, 0], YAW_ERROR_DEG, rtol=0, atol=0.5)
    return res


def _check_navigation_converged(res: SimulationResult) -> None:
    """Attitude error below 1 % of the initial 30° and position error below 1 % of the initial offset, at the end."""
    att, pos = nav_metrics.attitude_error_deg(res), nav_metrics.position_error_m(res)
    assert np.all(att[:, -1] < 0.01 * YAW_ERROR_DEG)
    assert np.all(pos[:, -1] < 0.01 * np.linalg.norm(P_OFFSET))


def _nav_x_hat0() -> np.ndarray:
    return nav_vector([1.0, 2.0, -300.0], [40.0, 5.0, -1.0], rot_z(0.4))


#: A typical IMU sample ``[ω^b, a^b, m^b]`` and GNSS fix ``[p, v]`` near :func:`_nav_x_hat0`.
NAV_U = [0.01, 0.02, 0.03, 0.1, 0.2, -9.8, 0.3, 0.1, 0.9]
NAV_Y = [1.5, 2.5, -300.2, 40.1, 5.1, -1.1]


def case_gnss_ins() -> Any:
    """GNSS/INS observer (22)/(24) with the paper's gains: the 30° yaw error falls below 0.3° in 20 s."""
    traj0 = traffic_pattern(seed=0, duration=1.0)
    obs = GnssInsObserver.paper(traj0.m_n, traj0.g_n)
    check_protocol(obs, _nav_x_hat0(), NAV_U, NAV_Y, time=Continuous, correcting=True,
                   capabilities=(SelfStepping, Diagnosing, DeferredEstimate))
    _check_navigation_converged(_flight_run(obs))
    return obs


def case_scheduled_gnss_ins() -> Any:
    """Observer (24) with the paper's K and Γ switched from the paper's to 0.5 I at 5 s, then 0.1 I at 12 s:
    the 30° yaw error falls below 0.3° in 20 s."""
    from nlobs.navigation.gains import PAPER_GAMMA
    from nlobs.navigation.schedule import AttitudeGainSchedule

    traj0 = traffic_pattern(seed=0, duration=1.0)
    obs = ScheduledGnssInsObserver(GnssInsObserver.paper(traj0.m_n, traj0.g_n),
                                   AttitudeGainSchedule((PAPER_GAMMA, 0.5, 0.1), (5.0, 12.0)))
    check_protocol(obs, _nav_x_hat0(), NAV_U, NAV_Y, time=Continuous, correcting=True,
                   capabilities=(SelfStepping, Diagnosing, DeferredEstimate))
    _check_navigation_converged(_flight_run(obs))
    return obs


def case_navigation_ekf() -> Any:
    """Error-state EKF baseline (tuned for a typical sensor set): the 30° yaw error falls below 0.3° in 20 s."""
    traj0 = traffic_pattern(seed=0, duration=1.0)
    tuning = SensorNoise(gyro_std=0.002, accel_std=0.05, mag_std=0.01, gnss_p_std=1.5, gnss_v_std=0.1)
    ekf = ExtendedKalmanFilter(EkfConfig.for_noise(tuning, yaw_std_deg=60.0), traj0.m_n, traj0.g_n)
    check_protocol(ekf, _nav_x_hat0(), NAV_U, NAV_Y, time=Continuous, correcting=True, capabilities=(SelfStepping, Diagnosing))
    _check_navigation_converged(_flight_run(ekf))
    return ekf


#: One constructed case per estimator class: builds it, checks the protocol, runs it through a loop.
CASES: dict[type, Callable[[], Any]] = {
    LuenbergerObserver: case_luenberger,
    ConstantGainObserver: case_constant_gain,
    ImpulsiveObserver: case_impulsive,
    OutputPredictor: case_output_predictor,
    CascadeObserver: case_cascade,
    DriftObserver: case_drift,
    PinvObserver: case_pinv,
    ByrnesIsidoriObserver: case_byrnes_isidori,
    SetValuedObserver: case_setvalued,
    DiscreteLipschitzObserver: case_discrete_lipschitz,
    UnknownInputEKF: case_unknown_input_ekf,
    EKF: case_ekf,
    UKF: case_ukf,
    nlobs.ParticleFilter: case_particle_filter,
    GnssInsObserver: case_gnss_ins,
    ScheduledGnssInsObserver: case_scheduled_gnss_ins,
    ExtendedKalmanFilter: case_navigation_ekf,
}


# ----------------------------------------------------------------------------- registry
def _estimator_classes(module: Any) -> set[type]:
    names = getattr(module, "__all__", None)
    if names is None:
        names = [n for n in vars(module) if not n.startswith("_")]
    found = set()
    for name in names:
        if name.startswith("_") or name in PROTOCOLS or not ESTIMATOR_NAME.search(name):
            continue
        obj = getattr(module, name)
        if isinstance(obj, type) and obj.__module__.split(".")[0] == "nlobs":
            found.add(obj)
    return found


def discovered_estimators() -> set[type]:
    """Estimator classes exported by ``nlobs``, ``nlobs.observers`` (and its modules) and ``nlobs.navigation.*``."""
    modules: list[Any] = [nlobs, nlobs.observers, nlobs.navigation]
    for pkg in (nlobs.observers, nlobs.navigation):
        for info in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + "."):
            modules.append(importlib.import_module(info.name))
    found: set[type] = set()
    for module in modules:
        found |= _estimator_classes(module)
    return found


def _names(classes: set[type]) -> list[str]:
    return sorted(f"{c.__module__}.{c.__qualname__}" for c in classes)


def test_every_estimator_has_a_case() -> None:
    found = discovered_estimators()
    missing, stale = found - set(CASES), set(CASES) - found
    assert not missing, f"estimators without a case in CASES: {_names(missing)}"
    assert not stale, f"cases whose class the registry does not find: {_names(stale)}"
    for cls in CASES:
        assert getattr(nlobs, cls.__name__) is cls, f"{cls.__name__} is not exported from the top level of nlobs"
        assert callable(getattr(cls, "to_control", None)), f"{cls.__name__} has no to_control()"
        assert cls.__name__ in nlobs.__all__


@pytest.mark.parametrize("cls", list(CASES), ids=lambda c: c.__name__)
def test_estimator_satisfies_the_protocol_and_runs_through_the_loop(cls: type) -> None:
    obs = CASES[cls]()
    assert type(obs) is cls
