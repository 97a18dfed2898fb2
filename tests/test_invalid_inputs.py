"""Invalid numbers are refused with a typed error naming the argument, never silently turned into a result.

Complex matrices (whose imaginary part a float conversion would drop), out-of-range or non-finite
scalars of the set-valued design of Khajenejad & Yong, overflow inside its Algorithm 1, non-finite
sensor data of the GNSS/INS observer of Grip, Saberi & Johansen, and simulation grids that cannot
be run.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError, NonFiniteError

A2 = np.array([[0.0, 1.0], [-2.0, -3.0]])
C2 = np.array([[1.0, 0.0]])
BD2 = np.array([[0.0], [1.0]])
AD2 = np.array([[0.5, 0.1], [0.0, 0.6]])


def _lti():
    from nlobs.systems.discrete_ui import DiscreteUISystem, Lipschitz
    from nlobs.systems.timebase import Discrete

    A = np.array([[0.9, 0.2, 0.0], [0.0, 0.8, 0.3], [0.1, 0.0, 1.05]])
    G = np.array([[1.0], [0.0], [0.5]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    H = np.array([[0.0], [0.2]])
    return DiscreteUISystem(A, G, C, H, function_class=Lipschitz(0.0, 3), eta_w=0.05, eta_v=0.02, delta0=1.0,
                            time=Discrete(1.0))


@pytest.fixture(scope="module")
def lti_design():
    from nlobs.synthesis.setvalued import design_setvalued

    sysm = _lti()
    return sysm, design_setvalued(sysm)


# ----------------------------------------------------------------------------- complex input


def _complex_cases():
    from nlobs.linear.norms import hinf_norm
    from nlobs.synthesis.discrete_lipschitz import design_discrete_lipschitz_gain, verify_discrete_lipschitz_gain
    from nlobs.synthesis.observer_gain import design_observer_gain, verify_observer_gain
    from nlobs.systems.linear import LinearSystem

    K = np.array([[1.0], [1.0]])
    return {
        # before: a verified certificate for the real part of A
        "design_observer_gain": ("A", lambda: design_observer_gain(A2 + 1j, C2, BD2, gamma=10.0, gain_bound=100.0)),
        "verify_observer_gain": ("K", lambda: verify_observer_gain(A2, C2, BD2, K + [[1j], [0]], gamma=10.0)),
        "LinearSystem": ("B", lambda: LinearSystem(A2, BD2 + 2j, C2)),
        "design_discrete_lipschitz_gain": ("A", lambda: design_discrete_lipschitz_gain(AD2 + 0.5j, C2, lipschitz=0.1)),
        "discrete_lipschitz_constant": ("lipschitz", lambda: design_discrete_lipschitz_gain(
            AD2, C2, lipschitz=np.complex128(0.1 + 1j))),
        "verify_discrete_lipschitz_gain": ("P", lambda: verify_discrete_lipschitz_gain(
            AD2, C2, np.zeros((2, 1)), np.eye(2) * (1 + 1e-3j), lipschitz=0.1)),
        "hinf_norm": ("C", lambda: hinf_norm(A2, BD2, C2 * (1 + 1j), np.zeros((1, 1)))),
        "DiscreteUISystem": ("G", lambda: _lti_with(G=np.array([[1.0], [0.0], [0.5j]]))),
        "nested list": ("A", lambda: LinearSystem([[0.0, 1.0], [-2.0, complex(-3, 1e-9)]], BD2, C2)),
        "NaN imaginary part": ("C", lambda: LinearSystem(A2, BD2, np.array([[1.0, complex(0, math.nan)]]))),
    }


def _lti_with(**kw):
    from nlobs.systems.discrete_ui import DiscreteUISystem, Lipschitz
    from nlobs.systems.timebase import Discrete

    s = _lti()
    d = {"A": s.A, "G": s.G, "C": s.C, "H": s.H}
    d.update(kw)
    return DiscreteUISystem(d["A"], d["G"], d["C"], d["H"], function_class=Lipschitz(0.0, 3), eta_w=0.05,
                            eta_v=0.02, delta0=1.0, time=Discrete(1.0))


@pytest.mark.parametrize("case", list(_complex_cases()))
def test_complex_input_is_refused_naming_the_argument(case):
    name, call = _complex_cases()[case]
    with pytest.raises(InvalidArgumentError, match=rf"^{name}: .*complex"):
        call()


def test_complex_setvalued_arguments_are_refused(lti_design):
    from nlobs.synthesis.setvalued import design_setvalued, verify_setvalued

    sysm, des = lti_design
    with pytest.raises(InvalidArgumentError, match=r"^P: .*complex"):
        verify_setvalued(sysm, des.gain, des.P * (1 + 1j), kappa=des.kappa, lam=des.lam, theta=des.theta)
    with pytest.raises(InvalidArgumentError, match=r"^L_tilde: .*complex"):
        verify_setvalued(sysm, des.gain + 1j, des.P, kappa=des.kappa, lam=des.lam, theta=des.theta)
    with pytest.raises(InvalidArgumentError, match=r"^lam: .*complex"):
        design_setvalued(sysm, lam=np.complex128(0.8 + 0.1j))


def test_complex_with_zero_imaginary_part_is_its_real_value():
    from nlobs._validate import as_matrix, positive
    from nlobs.systems.linear import LinearSystem

    sys_c = LinearSystem(A2 + 0j, BD2, C2)
    assert sys_c.A.dtype == np.float64 and np.array_equal(sys_c.A, A2)
    assert as_matrix("M", [[1 + 0j, 2]]).tolist() == [[1.0, 2.0]]
    assert positive("x", np.complex128(2.5)) == 2.5


# ----------------------------------------------------------------------------- set-valued scalars


@pytest.mark.parametrize(("kw", "err", "name"), [
    ({"lam": 1.5}, InvalidArgumentError, "lam"),       # before: passed (3 checks, no contraction certified)
    ({"lam": 1.0}, InvalidArgumentError, "lam"),       # λ = 1 with q = 0: no contraction
    ({"lam": 0.0}, InvalidArgumentError, "lam"),
    ({"lam": math.nan}, NonFiniteError, "lam"),        # before: LinAlgError
    ({"kappa": -1.0}, InvalidArgumentError, "kappa"),  # before: CertificateError by chance
    ({"kappa": math.inf}, NonFiniteError, "kappa"),
    ({"q": -1.0}, InvalidArgumentError, "q"),          # before: passed
    ({"theta": (math.inf, 1.0, 1.0)}, NonFiniteError, "theta"),
    ({"theta": (-1.0, 1.0, 1.0)}, InvalidArgumentError, "theta"),
    ({"theta": (1.0, 1.0)}, InvalidArgumentError, "theta"),
    ({"rho": -1.0}, InvalidArgumentError, "rho"),
    ({"rho": math.nan}, NonFiniteError, "rho"),
])
def test_verify_setvalued_refuses_bad_scalars(lti_design, kw, err, name):
    from nlobs.synthesis.setvalued import verify_setvalued

    sysm, des = lti_design
    args = {"kappa": des.kappa, "lam": des.lam, "theta": des.theta}
    args.update(kw)
    with pytest.raises(err, match=rf"^{name}: "):
        verify_setvalued(sysm, des.gain, des.P, strict=False, **args)


def test_verify_setvalued_refuses_non_finite_gain(lti_design):
    from nlobs.synthesis.setvalued import verify_setvalued

    sysm, des = lti_design
    with pytest.raises(NonFiniteError, match=r"^L_tilde: "):  # before: LinAlgError
        verify_setvalued(sysm, des.gain * np.nan, des.P, kappa=des.kappa, lam=des.lam, theta=des.theta, strict=False)


def test_lambda_one_needs_q_positive(lti_design):
    """λ = 1 certifies a contraction only through q > 0 (the H∞ form): the H∞ design re-verifies with its
    own (λ = 1, q = 1), the same λ with q = 0 is refused; the radius design (λ < 1, q = 0) re-verifies."""
    from nlobs.synthesis.setvalued import design_setvalued, verify_setvalued

    sysm, des = lti_design
    assert all(c.passed for c in verify_setvalued(sysm, des.gain, des.P, kappa=des.kappa, lam=des.lam,
                                                  theta=des.theta))
    h = design_setvalued(sysm, objective="hinf")
    assert h.lam == 1.0 and h.q == 1.0
    checks = verify_setvalued(sysm, h.gain, h.P, kappa=h.kappa, lam=h.lam, q=h.q, theta=h.theta, rho=h.rho)
    assert all(c.passed for c in checks)
    with pytest.raises(InvalidArgumentError, match=r"^lam: must lie in \(0, 1\)"):
        verify_setvalued(sysm, h.gain, h.P, kappa=h.kappa, lam=h.lam, q=0.0, theta=h.theta, strict=False)


@pytest.mark.parametrize(("kw", "err", "name"), [
    ({"rtol": -1.0}, InvalidArgumentError, "rtol"),            # before: ran, stopping at once
    ({"rtol": math.nan}, NonFiniteError, "rtol"),
    ({"bisection_steps": -3}, InvalidArgumentError, "bisection_steps"),  # before: λ = 0.999999, no search
    ({"golden_steps": 2.5}, InvalidArgumentError, "golden_steps"),
    ({"objective": "hinf", "lam": 0.5}, InvalidArgumentError, "lam"),     # before: lam silently ignored
])
def test_design_setvalued_refuses_bad_search_settings(kw, err, name):
    from nlobs.synthesis.setvalued import design_setvalued

    with pytest.raises(err, match=rf"^{name}: "):
        design_setvalued(_lti(), **kw)


def test_verify_drift_gain_refuses_non_finite_w():
    from nlobs.synthesis.drift_gain import RiccatiConstants, vandermonde_gain, verify_drift_gain

    c = RiccatiConstants((2,), None, 1.0, 0.0, 0.0)
    g = vandermonde_gain((2,), 5.0)
    assert verify_drift_gain(c, g.K, g.P, method="vandermonde", w=5.0).w == 5.0
    for w, err in ((math.nan, NonFiniteError), (-5.0, InvalidArgumentError)):  # before: recorded as given
        with pytest.raises(err, match=r"^`w`: "):
            verify_drift_gain(c, g.K, g.P, method="vandermonde", w=w)


# ----------------------------------------------------------------------------- Algorithm 1 overflow


@pytest.fixture(scope="module")
def ex61():
    from nlobs.papers.khajenejad_yong import example_61
    from nlobs.synthesis.setvalued import design_setvalued

    sysm = example_61("II").system
    return sysm, design_setvalued(sysm)


def test_setvalued_observer_overflow_raises_naming_the_step(ex61):
    """y = 1e308 is finite, but (10) overflows: before, correct returned a state whose d̂₁ was ±inf."""
    from nlobs.errors import SimulationDiverged
    from nlobs.observers.setvalued import SetValuedObserver

    sysm, des = ex61
    obs = SetValuedObserver(sysm, des)
    u, fresh = np.zeros((1, sysm.m)), np.ones(sysm.l, dtype=bool)
    z = obs.correct(0.0, obs.init(np.zeros((1, sysm.n))), u, np.zeros((1, sysm.l)), fresh)
    z = obs.rhs(0.0, z, u, np.zeros((1, sysm.l)))
    with np.errstate(over="ignore", invalid="ignore"), \
            pytest.raises(SimulationDiverged, match=r"step 1: overflow.*d1_hat\[0\]") as exc:
        obs.correct(sysm.time.dt, z, u, np.full((1, sysm.l), 1e308), fresh)
    assert exc.value.time == sysm.time.dt


def test_run_setvalued_overflow_names_the_step(ex61):
    from nlobs.errors import SimulationDiverged
    from nlobs.simulate.setvalued import run_setvalued

    sysm, des = ex61
    y = np.zeros((2, 6, sysm.l))
    y[1, 3, 0] = -1e308
    with pytest.raises(SimulationDiverged, match=r"Algorithm 1, step 3: overflow"):
        run_setvalued(sysm, des, y)


# ----------------------------------------------------------------------------- GNSS/INS observer and EKF


@pytest.fixture(scope="module")
def nav():
    from test_gnss_ins_synthetic import G_N, M_N, turn_data

    from nlobs.navigation.ekf import EkfConfig, ExtendedKalmanFilter
    from nlobs.navigation.gnss_ins import GnssInsObserver
    from nlobs.navigation.sensors import SensorNoise

    data = turn_data(2.0)
    filters = {
        "observer": GnssInsObserver.paper(M_N, G_N),
        "observer-batched": GnssInsObserver.paper(M_N, G_N, kernel="batched"),
        "observer-rk4": GnssInsObserver.paper(M_N, G_N, integrator="rk4"),
        "ekf": ExtendedKalmanFilter(EkfConfig.for_noise(SensorNoise(0.01, 0.1, 0.01, 1.0, 0.1)), M_N, G_N),
    }
    return data, filters


NAV_FILTERS = ["observer", "observer-batched", "observer-rk4", "ekf"]


def _imu(data, k=0):
    return np.r_[data.omega_b[k], data.a_b[k], data.m_b[k]]


@pytest.mark.parametrize(("which", "dt"), [
    *((w, math.inf) for w in NAV_FILTERS), ("ekf", math.nan), ("ekf", -0.01), ("ekf", 0.0)])
def test_nav_step_refuses_non_finite_or_non_positive_dt(nav, which, dt):
    """Before: dt = inf returned a NaN state (split kernels, EKF) or an OverflowError (RK4); the EKF took any dt
    (the observer already refused NaN and non-positive steps)."""
    from nlobs.navigation.base import ImuSample

    data, filters = nav
    f = filters[which]
    z = f.init_state(data.p[0], data.v[0], data.R[0])
    with pytest.raises(InvalidArgumentError, match=r"^dt: must be positive and finite"):
        f.step(0.0, z, _imu(data), None, dt)
    with pytest.raises(InvalidArgumentError, match=r"^dt: must be positive and finite"):
        f.propagate(z, ImuSample(data.omega_b[0], data.a_b[0], data.m_b[0]), dt)


@pytest.mark.parametrize("which", NAV_FILTERS)
def test_non_finite_fix_marked_valid_is_a_missing_fix(nav, which):
    """update(GnssSample(valid=True)) with a NaN entry: skipped and counted for that flight only, like a
    fix flagged invalid (before: the observer held the NaN and returned NaN; the EKF fused it as a zero
    innovation, shrinking its covariance)."""
    from nlobs.navigation.base import GnssSample

    data, filters = nav
    f = filters[which]
    z = f.init_state(np.stack([data.p[0]] * 2), data.v[0], data.R[0])
    p = np.stack([data.p[0] + 1.0, data.p[0] + 1.0])
    p[1, 2] = np.nan
    v = np.stack([data.v[0], data.v[0]])
    got = f.update(z, GnssSample(p, v, np.array([True, True])))
    flagged = f.update(z, GnssSample(p, v, np.array([True, False])))
    assert got.skipped.tolist() == [0, 1]
    for name in ("p", "v", "R"):
        np.testing.assert_array_equal(getattr(got, name), getattr(flagged, name))
    if which == "ekf":
        np.testing.assert_array_equal(got.P[1], z.P[1])
    else:
        assert got.has_fix.tolist() == [True, False]
        np.testing.assert_array_equal(got.y_p, flagged.y_p)
    z1 = f.step(0.0, got, np.stack([_imu(data)] * 2), None, 0.01)
    assert np.isfinite(f.estimate(z1)).all()


def test_ekf_init_refuses_non_finite_initial_estimate(nav):
    data, filters = nav
    with pytest.raises(NonFiniteError, match=r"^p0: "):  # before: a NaN state
        filters["ekf"].init_state([np.nan, 0.0, 0.0], data.v[0], data.R[0])


# ----------------------------------------------------------------------------- simulate grid


def _plant():
    from nlobs.systems.linear import LinearSystem

    return LinearSystem(A2, BD2, C2)


@pytest.mark.parametrize(("kw", "steps"), [
    ({"duration": 1.0, "dt": 1e-300}, "1e+300"),      # before: ValueError "Maximum allowed size exceeded"
    ({"duration": 1e4, "dt": 1e-12}, "1e+16"),        # before: MemoryError (71 PiB)
    ({"duration": 1e308, "dt": 1e-10}, "inf"),        # before: OverflowError
])
def test_simulate_refuses_a_grid_too_long_naming_the_step_count(kw, steps):
    from nlobs.simulate import loop

    with pytest.raises(InvalidArgumentError, match=rf"^dt: .*needs {re.escape(steps)} steps, more than MAX_STEPS = ") as exc:
        loop.simulate(_plant(), None, [1.0, 0.0], u=0.0, **kw)
    assert f"MAX_STEPS = {loop.MAX_STEPS:,};" in str(exc.value)


def test_simulate_refuses_a_step_the_float_times_cannot_resolve():
    """Before: t0 = 1e12 with dt = 1e-6 ran, its 1001 times quantised to steps of 1.2e-4 s (0 or 122 dt)."""
    from nlobs.simulate.loop import simulate

    with pytest.raises(InvalidArgumentError, match=r"^dt: 1e-06 s is below the resolution"):
        simulate(_plant(), None, [1.0, 0.0], u=0.0, duration=1e-3, dt=1e-6, t0=1e12)
    res = simulate(_plant(), None, [1.0, 0.0], u=0.0, duration=1e-3, dt=1e-6, t0=1e3)  # resolvable: runs
    assert res.t.shape == (1001,) and np.allclose(np.diff(res.t), 1e-6, rtol=1e-6)


def test_simulate_refuses_complex_initial_states():
    from nlobs.observers.luenberger import LuenbergerObserver
    from nlobs.simulate.loop import simulate

    plant = _plant()
    with pytest.raises(InvalidArgumentError, match=r"^x0: .*complex"):  # before: ran from the real part (a list
        # holding a Python complex was a DimensionError "cannot be read as a numeric array")
        simulate(plant, None, np.array([1.0 + 1j, 0.0]), u=0.0, duration=0.1, dt=0.05)
    obs = LuenbergerObserver(plant, np.array([[2.0], [1.0]]))
    with pytest.raises(InvalidArgumentError, match=r"^x_hat0: .*complex"):
        simulate(plant, obs, [1.0, 0.0], np.array([0.0, 2j]), u=0.0, duration=0.1, dt=0.05)


# ----------------------------------------------------------------------------- recorded data


def test_run_observer_refuses_complex_recorded_data():
    """Before: u and y were read with np.asarray(..., dtype=float), the imaginary parts dropped."""
    from nlobs.observers.luenberger import LuenbergerObserver
    from nlobs.simulate import run_observer

    obs = LuenbergerObserver(_plant(), np.array([[2.0], [1.0]]))
    t = np.linspace(0.0, 0.1, 11)
    u, y = np.zeros((11, 1)), np.zeros((11, 1))
    with pytest.raises(InvalidArgumentError, match=r"^u: entry \(3, 0\) is complex"):
        run_observer(obs, t, x_hat0=[0.0, 0.0], u=u + np.where(np.arange(11)[:, None] == 3, 1j, 0), y=y)
    with pytest.raises(InvalidArgumentError, match=r"^y: .*complex"):
        run_observer(obs, t, x_hat0=[0.0, 0.0], u=u, y=y + 0.5j)
    y_missing = y.copy()
    y_missing[4] = np.nan  # a NaN is still a missing sample, handled by the observer's rule (this one refuses it)
    with pytest.raises(NonFiniteError, match=r"^y: sample 4 \(output 0\) is not finite"):
        run_observer(obs, t, x_hat0=[0.0, 0.0], u=u, y=y_missing)


def test_run_navigation_refuses_complex_sensor_data(nav):
    import dataclasses

    from nlobs.navigation.run import run_navigation

    data, filters = nav
    bad = dataclasses.replace(data, a_b=data.a_b + 1e-3j)
    with pytest.raises(InvalidArgumentError, match=r"^data.a_b: .*complex"):
        run_navigation(filters["observer"], bad, data.p[0], data.v[0], data.R[0])
    bad = dataclasses.replace(data, p_gnss=data.p_gnss * (1 + 1j))
    with pytest.raises(InvalidArgumentError, match=r"^data.p_gnss: .*complex"):
        run_navigation(filters["observer"], bad, data.p[0], data.v[0], data.R[0])


def test_quadratic_constraint_refuses_a_complex_gamma():
    from nlobs.systems.discrete_ui import Lipschitz, QuadraticConstraint

    M = Lipschitz(0.33, 2).multiplier()[0]
    with pytest.raises(InvalidArgumentError, match=r"^gamma: .*complex"):  # before: γ = its real part
        QuadraticConstraint(M, np.complex128(-0.1 + 0.2j))


def test_a_huge_finite_imu_period_is_refused_not_run_for_ever() -> None:
    """RK4 with automatic substeps: dt = 1e300 would need ~1e302 substeps (it ran for ever); dt = 1e6 ~1e6."""
    from nlobs.navigation.base import G0, ImuSample
    from nlobs.navigation.gains import paper_gains
    from nlobs.navigation.gnss_ins import MAX_AUTO_SUBSTEPS, GnssInsObserver
    from nlobs.navigation.trajectory import M_N_DEFAULT

    obs = GnssInsObserver(paper_gains(), np.eye(3), M_N_DEFAULT, np.array([0.0, 0.0, G0]), integrator="rk4")
    z = obs.init(np.r_[np.zeros(6), np.eye(3).ravel()])
    imu = ImuSample(np.zeros(3), np.array([0.0, 0.0, -G0]), np.asarray(M_N_DEFAULT, dtype=float))
    z1 = obs.propagate(z, imu, 0.01)  # an ordinary IMU period runs
    assert np.all(np.isfinite(obs.estimate(z1)))
    for dt in (1e300, 1e6):  # before: OverflowError for 1e300; 1e6 ran ~1e6 substeps per call
        with pytest.raises(InvalidArgumentError, match=f"more than {MAX_AUTO_SUBSTEPS:,}"):
            obs.propagate(z, imu, dt)
