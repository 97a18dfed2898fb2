"""python-control interoperability: its linear systems wherever nlobs takes one, and nlobs observers inside
``control.interconnect`` matching nlobs's own simulation."""

from __future__ import annotations

import numpy as np
import pytest

control = pytest.importorskip("control")

from nlobs import ConstantGainObserver, EKF, LinearSystem, LuenbergerObserver, load_model  # noqa: E402
from nlobs.errors import InvalidArgumentError  # noqa: E402
from nlobs.linear import h2_norm, hinf_norm  # noqa: E402
from nlobs.linear.report import analyze_linear  # noqa: E402
from nlobs.simulate import simulate  # noqa: E402
from nlobs.systems.timebase import Discrete  # noqa: E402

A, B, C = np.array([[0.0, 1.0], [-2.0, -0.4]]), np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]])


def test_state_space_and_transfer_function_are_accepted_wherever_a_linear_system_is():
    ss = control.ss(A, B, C, 0, states=["pos", "vel"], inputs=["f"], outputs=["meas"], name="spring")
    sys = LinearSystem(ss)
    np.testing.assert_array_equal(sys.A, A)
    assert (sys.states, sys.inputs, sys.outputs, sys.name) == (("pos", "vel"), ("f",), ("meas",), "spring")
    assert LinearSystem(control.ss(A, B, C, 0)).states == ("x1", "x2")  # python-control's default names → nlobs's
    # the norms against python-control's own (an independent implementation)
    assert hinf_norm(ss) == pytest.approx(float(control.linfnorm(ss)[0]), rel=1e-6)
    assert h2_norm(ss) == pytest.approx(float(control.system_norm(ss, p=2)), rel=1e-9)
    tf = control.tf([1.0], [1.0, 0.4, 2.0])  # the same input-output map
    assert hinf_norm(tf) == pytest.approx(hinf_norm(ss), rel=1e-9)
    rep = analyze_linear(ss)
    assert rep.to_dict()["observable"] is True
    d = LinearSystem(control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt=0.1))
    assert d.time == Discrete(0.1)
    with pytest.raises(InvalidArgumentError, match="unspecified sample time"):
        LinearSystem(control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt=True))
    with pytest.raises(InvalidArgumentError, match="give A, B, C"):
        LinearSystem(A)
    back = sys.to_control()
    np.testing.assert_array_equal(back.A, A)
    assert list(back.state_labels) == ["pos", "vel"] and back.name == "spring"


def _ivp(sys, T, U, X0):
    return control.input_output_response(sys, T, U, X0, solve_ivp_method="DOP853",
                                         solve_ivp_kwargs={"rtol": 1e-12, "atol": 1e-13})


def test_luenberger_observer_interconnected_in_python_control_matches_nlobs():
    plant_n = LinearSystem(A, B, C, inputs=["u"], outputs=["y"], states=["x1", "x2"])
    L = np.array([[3.0], [4.0]])
    obs = LuenbergerObserver(plant_n, L)
    closed = control.interconnect([plant_n.to_control(), obs.to_control(name="obs")], inputs=["u"],
                                  outputs=["y", "x1_hat", "x2_hat"])
    T = np.linspace(0.0, 5.0, 501)
    x0, xh0 = np.array([1.0, -0.5]), np.array([0.0, 0.0])
    out = _ivp(closed, T, 0.5 * np.ones_like(T), np.concatenate([x0, obs.init(xh0)]))
    res = simulate(plant_n, obs, x0, xh0, duration=5.0, dt=1e-3, u=0.5)
    np.testing.assert_allclose(res.x_hat[::10], out.outputs[1:].T, rtol=0, atol=1e-8)


def test_nonlinear_observer_on_a_nonlinear_plant_matches_nlobs():
    # the pendulum written out here for python-control (independent of nlobs's compiled model)
    model = load_model("pendulum")
    plant = model.compile()

    def f(t, x, u, params):
        return np.asarray(plant.rhs(t, np.asarray(x), np.asarray(u, dtype=float).reshape(-1)), dtype=float)

    def h(t, x, u, params):
        return np.asarray(plant.output(t, np.asarray(x), np.asarray(u, dtype=float).reshape(-1)), dtype=float)

    pend = control.nlsys(f, h, inputs=list(model.inputs) or None, outputs=list(model.outputs),
                         states=list(model.states), name="pendulum")
    L = np.array([[4.0], [5.0]])[: model.n, : model.p]
    obs = ConstantGainObserver(plant, L)
    io = obs.to_control(name="obs")
    assert list(io.input_labels) == [*model.inputs, *model.outputs]
    closed = control.interconnect([pend, io], inputs=list(model.inputs) or None,
                                  outputs=[f"{s}_hat" for s in model.states])
    T = np.linspace(0.0, 4.0, 401)
    x0, xh0 = np.array([0.8, 0.0]), np.array([0.3, 0.2])
    U = np.zeros((model.m, T.size)) if model.m else None
    out = _ivp(closed, T, U if U is not None else 0, np.concatenate([x0, obs.init(xh0)]))
    res = simulate(plant, obs, x0, xh0, duration=4.0, dt=1e-3, u=np.zeros(model.m) if model.m else None)
    np.testing.assert_allclose(res.x_hat[::10], np.atleast_2d(out.outputs).T, rtol=0, atol=1e-8)


def test_correcting_observers_are_refused_with_the_reason():
    sys = LinearSystem(A, B, C)
    model = load_model("pendulum")
    ekf = EKF(model.compile(), Q=np.eye(2) * 1e-3, R=np.eye(model.p) * 1e-2, P0=np.eye(2))
    with pytest.raises(InvalidArgumentError, match="continuous-discrete"):
        ekf.to_control()
    assert LuenbergerObserver(sys, [[1.0], [1.0]]).to_control(inputs=1, outputs=["yy"]).ninputs == 2


def test_compiled_model_pickles_and_runs_in_a_process_pool():
    import pickle
    from concurrent.futures import ProcessPoolExecutor

    model = load_model("pendulum")
    c = model.compile({"l": 2.0})
    back = pickle.loads(pickle.dumps(c))
    x, u = np.array([[0.3, -0.1], [1.0, 0.5]]), np.zeros((2, model.m))
    np.testing.assert_array_equal(back.rhs(0.0, x, u), c.rhs(0.0, x, u))
    np.testing.assert_array_equal(back.rhs_jacobian_x(0.0, x, u), c.rhs_jacobian_x(0.0, x, u))
    assert not np.array_equal(back.rhs(0.0, x, u), model.compile().rhs(0.0, x, u))  # the override travelled
    with ProcessPoolExecutor(max_workers=1) as pool:
        got = pool.submit(_rhs_in_worker, c, x, u).result(timeout=120)
    np.testing.assert_array_equal(got, c.rhs(0.0, x, u))


def _rhs_in_worker(c, x, u):
    return c.rhs(0.0, x, u)
