"""A controller in the loop and bounds on the state: the ``[controller]`` and ``[constraints]`` tables, the loop's
``controller`` argument, and what ``nlobs simulate`` reports of them."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.linalg import expm

import nlobs
from nlobs.errors import DimensionError, InvalidArgumentError, ModelFileError
from nlobs.systems.constraints import StateBounds
from nlobs.systems.controller import ControlLaw
from nlobs.systems.expressions import ExpressionError
from nlobs.systems.modelfile import parse_scenario, shipped_models

A = np.array([[0.0, 1.0], [0.0, 0.0]])
B = np.array([[0.0], [1.0]])
C = np.array([[1.0, 0.0]])
K = np.array([[4.0, 2.0]])


def _double_integrator() -> nlobs.LinearSystem:
    return nlobs.LinearSystem(A, B, C)


def _zoh(dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The exact discretisation of ẋ = A x + B u with u held over dt."""
    M = expm(np.block([[A, B], [np.zeros((1, 3))]]) * dt)
    return M[:2, :2], M[:2, 2:]


# ----------------------------------------------------------------------------- the law
def test_control_law_evaluates_saturates_and_refuses_what_is_not_an_expression() -> None:
    k = ControlLaw(["p", "v"], ["F"], ["-kp*p - kd*v + sin(t)"], parameters={"kp": 4.0, "kd": 2.0}, saturation=[-1, 1])
    x = np.array([[0.1, 0.2], [2.0, 0.0]])
    np.testing.assert_allclose(k.unsaturated(0.5, x)[:, 0], -4 * x[:, 0] - 2 * x[:, 1] + np.sin(0.5))
    np.testing.assert_allclose(k(0.5, x)[:, 0], np.clip(-4 * x[:, 0] - 2 * x[:, 1] + np.sin(0.5), -1, 1))
    assert k(0.0, np.array([0.0, 0.0])).shape == (1,)
    with pytest.raises(ExpressionError):
        ControlLaw(["p", "v"], ["F"], ["__import__('os').system('true')"])
    with pytest.raises(ExpressionError, match="q"):
        ControlLaw(["p", "v"], ["F"], ["-q"])
    with pytest.raises(DimensionError, match="one per input"):
        ControlLaw(["p", "v"], ["F"], ["-p", "-v"])
    with pytest.raises(InvalidArgumentError, match="'t'"):
        ControlLaw(["t", "v"], ["F"], ["-v"])
    with pytest.raises(InvalidArgumentError, match="lo < hi"):
        ControlLaw(["p", "v"], ["F"], ["-p"], saturation=[1, -1])
    with pytest.raises(InvalidArgumentError, match="positive"):
        ControlLaw(["p", "v"], ["F"], ["-p"], rate=0.0)


def test_reference_loop_is_the_sampled_data_closed_form() -> None:
    """Fed the true state and held over each step (or each controller period), the loop is x⁺ = (Φ − Γ K) x exactly,
    with Φ, Γ the zero-order-hold discretisation of the plant: RK4 on a linear plant with a held input is exact to
    its truncation error (dt⁵)."""
    plant = _double_integrator()
    x0 = np.array([[1.0, 0.0], [0.5, -0.3]])
    for rate, dt, every in ((None, 1e-3, 1), (50.0, 1e-3, 20)):
        law = ControlLaw(["p", "v"], ["F"], ["-4*p - 2*v"], rate=rate)
        res = nlobs.simulate(plant, None, x0, duration=2.0, dt=dt, controller=law, feedback="state")
        Phi, Gam = _zoh(dt * every)
        x = x0.copy()
        for _ in range(int(round(2.0 / (dt * every)))):
            x = x @ (Phi - Gam @ K).T
        np.testing.assert_allclose(res.x[:, -1], x, atol=1e-9)
        u = res.extras["u"]
        assert u.shape == (2, res.t.size, 1)
        if rate is not None:  # held between the controller's samples: 20 equal values in a row
            assert np.all(u[0, 1:20, 0] == u[0, 0, 0]) and u[0, 20, 0] != u[0, 0, 0]


def test_loop_around_an_observer_deviates_from_the_reference_as_the_separation_closed_form() -> None:
    """A linear plant, a Luenberger observer, no noise: x − x_ref and e obey [d; e]' = [[A − BK, −BK], [0, A − LC]]
    [d; e] (with e = x̂ − x: the law fed x̂ = x + e adds −BK e); held inputs over 1 ms make it O(dt)."""
    plant = _double_integrator()
    L = np.array([[9.0], [20.0]])
    obs = nlobs.LuenbergerObserver(plant, L)
    law = ControlLaw(["p", "v"], ["F"], ["-4*p - 2*v"])
    x0, e0 = np.array([1.0, 0.0]), np.array([0.2, -0.5])
    res = nlobs.simulate(plant, obs, x0, x0 + e0, duration=2.0, dt=1e-3, controller=law)
    ref = nlobs.simulate(plant, None, x0, duration=2.0, dt=1e-3, controller=law, feedback="state")
    big = np.block([[A - B @ K, -B @ K], [np.zeros((2, 2)), A - L @ C]])
    for k in (500, 1000, 2000):
        want = expm(big * res.t[k]) @ np.concatenate([np.zeros(2), e0])
        np.testing.assert_allclose(res.x[k] - ref.x[k], want[:2], atol=5e-3 * np.abs(want[:2]).max() + 1e-6)
        np.testing.assert_allclose(res.x_hat[k] - res.x[k], want[2:], atol=1e-6)
    # started at the truth, the loop around the observer is the reference loop
    same = nlobs.simulate(plant, obs, x0, x0, duration=1.0, dt=1e-3, controller=law)
    np.testing.assert_allclose(same.x, ref.x[: same.t.size], atol=1e-12)


def test_loop_arguments_are_checked() -> None:
    plant = _double_integrator()
    obs = nlobs.LuenbergerObserver(plant, [[9.0], [20.0]])
    law = ControlLaw(["p", "v"], ["F"], ["-p"])
    with pytest.raises(InvalidArgumentError, match="u=None"):
        nlobs.simulate(plant, obs, [1.0, 0.0], [0.0, 0.0], duration=1.0, dt=1e-3, u=0.0, controller=law)
    with pytest.raises(InvalidArgumentError, match="needs an observer"):
        nlobs.simulate(plant, None, [1.0, 0.0], duration=1.0, dt=1e-3, controller=law)
    with pytest.raises(InvalidArgumentError, match="whole multiple"):
        nlobs.simulate(plant, obs, [1.0, 0.0], [0.0, 0.0], duration=1.0, dt=1e-3,
                       controller=ControlLaw(["p", "v"], ["F"], ["-p"], rate=300.0))
    with pytest.raises(InvalidArgumentError, match="closed loop"):
        nlobs.simulate(plant, obs, [1.0, 0.0], [0.0, 0.0], duration=1.0, dt=1e-3, u=0.0, feedback="state")


# ----------------------------------------------------------------------------- model files
_BASE = '''name = "di"
states = ["p", "v"]
inputs = ["F"]
outputs = ["y"]
parameters = { kp = 4.0 }
[dynamics]
f = ["v", "0"]
g = [["0"], ["1"]]
h = ["p"]
'''


def test_model_file_tables_are_read_and_their_errors_name_the_line() -> None:
    s = parse_scenario(_BASE + '[controller]\nlaw = ["-kp*p - 2*v"]\nrate = 100\nsaturation = [[-1, inf]]\n'
                       '[constraints]\nlower = [-inf, -2]\nupper = [5, inf]\n')
    assert s.controller.law == ("-kp*p - 2*v",) and s.controller.rate == 100.0
    np.testing.assert_array_equal(s.controller.saturation[1], [np.inf])
    assert float(s.controller(0.0, np.array([1.0, 1.0]))[0]) == -1.0
    np.testing.assert_array_equal(s.constraints.lower, [-np.inf, -2.0])
    cases = [
        ('[controller]\nlaw = ["-k*p"]\n', "undeclared name"),
        ('[controller]\nlaw = ["-p", "-v"]\n', "one per input"),
        ('[controller]\ngain = 1\n', "unknown key in \\[controller\\]"),
        ('[controller]\nrate = 10\n', "needs 'law'"),
        ('[controller]\nlaw = ["-p"]\nsaturation = [[1, 0]]\n', "lo < hi"),
        ('[constraints]\nlower = [0, 0, 0]\n', "2 numbers"),
        ('[constraints]\nlower = [0, 1]\nupper = [1, 1]\n', "not below upper"),
        ('[constraints]\nlower = [nan, 0]\n', "non-finite"),
    ]
    for extra, match in cases:
        with pytest.raises(ModelFileError, match=match) as info:
            parse_scenario(_BASE + extra)
        assert info.value.line is not None and info.value.line > 9, extra


def test_state_bounds_project_and_count() -> None:
    b = StateBounds([0.0, -np.inf], [1.0, 2.0])
    x = np.array([[[0.5, 0.0], [1.5, 0.0], [0.5, 3.0], [np.nan, 0.0]]])
    np.testing.assert_array_equal(b.project(x)[0, :3], [[0.5, 0.0], [1.0, 0.0], [0.5, 2.0]])
    assert b.fraction_outside(x) == pytest.approx(2 / 3)  # the NaN point is not counted
    with pytest.raises(InvalidArgumentError, match="every bound is infinite"):
        StateBounds([-np.inf], [np.inf])


def test_filters_project_their_mean_onto_the_bounds() -> None:
    """A random walk near 0 measured noisily: without bounds the EKF's mean goes negative, with them never, and where
    the bound is inactive the two filters are the same."""
    plant = nlobs.LinearSystem([[0.0]], np.zeros((1, 0)), [[1.0]])
    from nlobs.simulate import MeasurementGroup

    meas = MeasurementGroup("s", ["y1"], rate=10.0, noise_std=0.05)
    kw = dict(Q=[[1e-4]], R=[[0.0025]], P0=[[0.01]])
    free = nlobs.EKF(plant, **kw)
    bounded = nlobs.EKF(plant, **kw, bounds=StateBounds([0.0], [np.inf]))
    x0 = np.full((20, 1), 0.02)
    args = dict(duration=5.0, dt=0.01, measurements=meas, seed=4, process_noise=[[1e-6]])
    r_free = nlobs.simulate(plant, free, x0, x0, **args)
    r_bnd = nlobs.simulate(plant, bounded, x0, x0, **args)
    assert (r_free.x_hat < 0).mean() > 0.05
    assert (r_bnd.x_hat >= 0).all()
    with pytest.raises(DimensionError, match="2 bounds"):
        nlobs.EKF(plant, **kw, bounds=StateBounds([0.0, 0.0], [1.0, 1.0]))


# ----------------------------------------------------------------------------- nlobs simulate
def _pendulum_file(tmp_path, saturation: bool):  # type: ignore[no-untyped-def]
    text = shipped_models()["inverted-pendulum"].read_text()
    if not saturation:
        text = text.replace("saturation = [[-10, 10]]\n", "")
    text = text.replace("runs = 20", "runs = 6").replace("duration = 5.0", "duration = 3.0")
    p = tmp_path / f"pend{int(saturation)}.toml"
    p.write_text(text)
    return p


@pytest.mark.slow
def test_simulate_closes_the_loop_around_each_observer_and_the_saturation_bounds_the_peaking(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from nlobs.methods.comparison import compare_observers

    out = {}
    for sat in (False, True):
        out[sat] = compare_observers(_pendulum_file(tmp_path, sat), observers=["drift", "luenberger", "ekf"])
    free, capped = out[False], out[True]
    ref = free.closed_loop["reference"]
    assert free.closed_loop["law"] == ["-kp*theta - kd*omega"] and free.closed_loop["saturation"] is None
    assert ref["diverged_runs"] == 0 and ref["peak_input"][0] == pytest.approx(20 * 0.3, rel=1e-6)  # kp·θ0 at t = 0
    for name in ("drift", "luenberger", "ekf"):
        c = free.observers[name].closed_loop
        assert c["diverged_runs"] == 0 and np.isfinite(c["rms_deviation"])
        assert capped.observers[name].closed_loop["peak_input"][0] <= 10.0 + 1e-12
    # the drift observer (high gain, w ≈ 218) peaks: its unsaturated input is many times the reference's
    assert free.observers["drift"].closed_loop["peak_input"][0] > 5 * ref["peak_input"][0]
    assert free.observers["ekf"].closed_loop["peak_input"][0] < free.observers["drift"].closed_loop["peak_input"][0]
    d = free.to_dict()
    assert set(d["observers"]["ekf"]["closed_loop"]) == {"rms_deviation", "rms_deviation_states", "peak_input",
                                                         "rms_input", "diverged_runs"}
    assert "closed loop" in free.summary() and "closed loop" in d["setup"]["inputs"]


@pytest.mark.slow
def test_simulate_reports_the_bounds_of_the_sir_model() -> None:
    from nlobs.methods.comparison import compare_observers

    rep = compare_observers("sir", observers=["luenberger", "ekf"], runs=4, duration=60.0)
    c = rep.constraints
    assert c["lower"] == [0.0, 0.0] and c["upper"] == [1.0, 1.0] and c["truth_runs_outside"] == 0
    assert rep.observers["ekf"].bounds["outside_fraction"] == 0.0
    assert rep.observers["luenberger"].bounds["runs_outside"] >= 1
    assert "estimate outside the [constraints]" in rep.summary()
    json.dumps(rep.to_dict())
