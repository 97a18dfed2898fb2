"""The methods layer: one rule for the defaults, one design per method, the same ``design`` object in every command.

The plant is a thrust-driven vertical axis of a quadrotor with drag, whose thrust is about 10 N
(``ż = v``, ``v̇ = −g − c v + T/m``; ``y = z``): the known input ``T(t) = 10 + 0.3 sin(2π · 0.25 t)`` has
the closed-form bound ``max |T| = 10.3`` on ``[0, 10]``, attained at ``t = 1`` (a sampled instant of
the rule's grid, so the sampled bound equals it to rounding).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs.cli import app

AXIS = """
name = "thrust-axis"
states = ["z", "v"]
inputs = ["T"]
outputs = ["y"]
parameters = { grav = 9.81, c = 0.4, mass = 1.0 }
units = { z = "m", v = "m/s", T = "N", y = "m" }

[dynamics]
f = ["v", "-grav - c*v"]
g = [["0"], ["1/mass"]]
h = ["z"]

[input_signals]
T = "10 + 0.3*sin(2*pi*0.25*t)"

[simulation]
x0 = [0.5, 0.0]
box = [[-2, 2], [-3, 3]]
duration = 10.0
runs = 2
"""

MU = 10.3  # max |10 + 0.3 sin(π t / 2)| on [0, 10], at t = 1


@pytest.fixture()
def axis(tmp_path):
    p = tmp_path / "thrust-axis.toml"
    p.write_text(AXIS)
    return p


def _json(args):
    r = CliRunner().invoke(app, args)
    out = r.output.lstrip()
    return r.exit_code, (json.JSONDecoder().raw_decode(out)[0] if out.startswith("{") else r.output)


def test_problem_takes_every_default_from_the_file_with_its_source(axis) -> None:
    from nlobs.methods.problem import problem

    pb = problem(axis)
    assert pb.mu == pytest.approx(MU, rel=1e-12)
    assert pb.sources["mu"] == "max ‖u(t)‖ of [input_signals] over [0, 10]"
    assert np.allclose(pb.region.lower, [-2, -3]) and np.allclose(pb.region.upper, [2, 3])
    assert pb.sources["region"] == "[simulation] box" and pb.sources["x0"] == "[simulation] x0"
    assert pb.x0.tolist() == [0.5, 0.0] and pb.u0.tolist() == pytest.approx([10.0])
    assert problem(axis, box=[-1, 1], duration=0.5).sources["region"] == "given"
    # over [0, 0.5] the sine has not reached its peak: 10 + 0.3 sin(π/4)
    assert problem(axis, duration=0.5).mu == pytest.approx(10 + 0.3 * np.sin(np.pi / 4), rel=1e-12)


@pytest.mark.slow
def test_the_same_drift_design_from_design_export_simulate_and_advise(axis, tmp_path) -> None:
    code_d, d = _json(["design", "drift", str(axis), "--json"])
    code_e, e = _json(["export", str(axis), "--observer", "drift", "--out", str(tmp_path / "c"), "--json"])
    code_s, s = _json(["simulate", str(axis), "--observer", "drift", "--runs", "2", "--duration", "10", "--json"])
    assert code_d == 0 and code_e == 0 and code_s == 0, (d, e, s)
    dd, de, ds = d["design"], e["design"], s["observers"]["drift"]["design"]
    for key in ("method", "parameters", "sources", "certified", "premises", "unchecked", "description"):
        assert dd[key] == de[key] == ds[key], key
    assert np.array_equal(np.array(dd["gain"]), np.array(de["gain"])) and dd["gain"] == ds["gain"]
    assert dd["parameters"]["mu"] == pytest.approx(MU, rel=1e-12)
    assert dd["sources"]["mu"] == "max ‖u(t)‖ of [input_signals] over [0, 10]"
    assert dd["parameters"]["region"] == [[-2.0, 2.0], [-3.0, 3.0]] and dd["certified"] is True
    # the export's header states the μ the certificate is for
    header = (tmp_path / "c" / "thrust_axis_drift.h").read_text()
    assert "μ = 10.3" in header
    # advise starts from the same μ
    code_a, a = _json(["advise", str(axis), "--json"])
    assert code_a == 0, a
    drift = a["methods"]["drift"]
    assert drift["parameters"]["mu"] == pytest.approx(MU, rel=1e-12)
    assert a["recommended"] == "drift"
    for key in ("method", "parameters", "sources", "certified", "premises", "unchecked", "description", "gain"):
        assert a["design"][key] == dd[key], key


def test_a_given_mu_below_the_input_is_not_certified_anywhere(axis, tmp_path) -> None:
    code, e = _json(["export", str(axis), "--observer", "drift", "--mu", "1", "--out", str(tmp_path / "c"), "--json"])
    assert code == 1 and e["certified"] is False
    assert any(p["key"] == "input_bound" and not p["passed"] for p in e["design"]["premises"])
    # a design for inputs up to μ = 1 exists (nlobs design reports it, exit 0) but is not certified for this file
    code, d = _json(["design", "drift", str(axis), "--mu", "1", "--json"])
    assert code == 0 and d["design"]["usable"] is True and d["design"]["certified"] is False
    assert "input bound μ of (2.17) covers the known input fails" in d["design"]["status"]


def test_certified_only_when_every_premise_is_checked(tmp_path) -> None:
    from nlobs.methods.problem import problem
    from nlobs.methods.registry import get

    pinv = get("pinv").design(problem("isidori-146"))
    assert pinv.usable and not pinv.certified and set(pinv.unchecked) == {"A2", "A3", "A4", "A6"}
    code, e = _json(["export", "isidori-146", "--observer", "pinv", "--out", str(tmp_path / "p"), "--json"])
    assert code == 1 and e["certified"] is False and e["design"]["unchecked"] == ["A2", "A3", "A4", "A6"]
    lin = get("luenberger").design(problem("gnss-ins-axis"))
    assert lin.certified and lin.verified
    nonlinear = get("luenberger").design(problem("pendulum"))
    assert nonlinear.usable and not nonlinear.certified
    assert any(p.key == "linear" and not p.passed for p in nonlinear.premises)


def test_the_registry_is_the_one_list_of_the_commands() -> None:
    from nlobs.methods.registry import REGISTRY, get, names
    from nlobs.workflows.compare import OBSERVERS
    from nlobs.workflows.export import EXPORTABLE

    assert OBSERVERS == names(simulated=True) == tuple(e.name for e in REGISTRY if e.simulated)
    assert EXPORTABLE == names(exported=True) == ("drift", "pinv", "luenberger", "cascade", "ekf", "ukf", "setvalued",
                                                        "gnss-ins")
    for n in names():
        m = get(n)
        assert m.name == n and isinstance(m.options, frozenset)
    from nlobs.errors import UnknownNameError

    with pytest.raises(UnknownNameError, match="known: drift, pinv"):
        get("bogus")


def test_a_method_that_does_not_apply_exits_3_from_export_and_is_skipped_by_simulate(tmp_path) -> None:
    code, out = _json(["export", "double-integrator-discrete", "--observer", "luenberger", "--out", str(tmp_path)])
    assert code == 3 and "continuous time" in out
    code, s = _json(["simulate", "double-integrator-discrete", "--observer", "luenberger,ekf", "--runs", "2",
                     "--duration", "1", "--json"])
    assert "continuous time" in s["observers"]["luenberger"]["skipped"]


SIR = """
name = "sir"
states = ["S", "I", "R"]
inputs = []
outputs = ["y"]
parameters = { beta = 0.3, gamma = 0.1 }

[dynamics]
f = ["-beta*S*I", "beta*S*I - gamma*I", "gamma*I"]
h = ["I"]

[sensors.count]
outputs = ["y"]
rate = 10.0
noise_std = 0.001

[simulation]
x0 = [0.9, 0.1, 0.0]
box = [[0.5, 1.0], [0.01, 0.5], [0.0, 0.5]]
duration = 5.0
dt = 0.01
runs = 2
"""


def test_an_unobservable_model_skips_the_designs_that_need_observability_and_warns_the_filters(tmp_path) -> None:
    """SIR with R kept: R enters no equation, so y = I never sees it (the kernel of dh, dL_f h, dL_f² h is e_R)."""
    from nlobs.methods.problem import problem

    p = tmp_path / "sir.toml"
    p.write_text(SIR)
    u = problem(p).observability
    assert (u.rank, u.n, u.states) == (2, 3, ("R",))
    code, s = _json(["simulate", str(p), "--json"])
    assert code == 0, s
    obs = s["observers"]
    assert s["unobservable"] == ["R"]
    assert "unobservable direction: R" in obs["drift"]["skipped"]
    # Röbenack's observer needs A1 (a defined relative degree), not observability: its zero dynamics are unobservable
    assert "relative degree" in obs["pinv"]["skipped"]
    assert "not detectable" in obs["luenberger"]["skipped"]
    for name in ("ekf", "ukf"):
        assert obs[name]["skipped"] is None
        assert any("runs open loop" in w for w in obs[name]["design"]["warnings"])
        # the observable states converge, R keeps its initial error (no measurement corrects it)
        rms = obs[name]["rms_error"]
        assert rms[0] < 0.01 and rms[1] < 0.01 and rms[2] > 0.03
    # R does not decay (λ = 0 in the linearisation): advise recommends no filter, and says which direction it cannot see
    code, a = _json(["advise", str(p), "--json"])
    assert code == 3 and a["methods"]["ekf-ukf"]["applicable"] == "no"
    assert "unobservable direction: R" in a["methods"]["ekf-ukf"]["reason"]


def test_the_unobservable_directions_of_a_linear_model_are_named() -> None:
    from nlobs.geometry.unobservable import linear_unobservable_directions

    # x1' = x2, x2' = 0, x3' = -x3 + x1, y = x1 + x3: observable; drop x3 from y and from x1's equation: not
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    u = linear_unobservable_directions(A, np.array([[1.0, 0.0, 0.0]]), ("p", "v", "z"))
    assert (u.rank, u.directions) == (2, ("z",))
    u = linear_unobservable_directions(A, np.array([[1.0, 0.0, 1.0]]), ("p", "v", "z"))
    assert u.observable and u.directions == ()
    # a direction that is not a state axis: y = x1 - x2 with x1' = x2' = 0 sees x1 - x2 only
    u = linear_unobservable_directions(np.zeros((2, 2)), np.array([[1.0, -1.0]]), ("a", "b"))
    assert u.rank == 1 and u.directions == ("a + b",)


@pytest.mark.slow
def test_design_options_reach_the_method_from_simulate_and_export(axis, tmp_path) -> None:
    # μ = 12 given to the drift method through nlobs simulate's --option: the same design as nlobs design --mu 12
    code, s = _json(["simulate", str(axis), "--observer", "drift", "--option", "drift.mu=12", "--runs", "2",
                     "--duration", "10", "--json"])
    code_d, d = _json(["design", "drift", str(axis), "--mu", "12", "--json"])
    assert code == 0 and code_d == 0
    assert s["observers"]["drift"]["design"]["parameters"] == d["design"]["parameters"]
    assert d["design"]["parameters"]["mu"] == 12 and d["design"]["sources"]["mu"] == "given"
    code, out = _json(["simulate", str(axis), "--observer", "drift", "--option", "drift.bogus=1"])
    assert code == 2 and "bogus is not an option of drift" in out
    code, out = _json(["simulate", str(axis), "--option", "mu=1"])
    assert code == 2 and "METHOD.KEY=VALUE" in out
    code, e = _json(["export", str(axis), "--observer", "drift", "--option", "w_max=1e6", "--out", str(tmp_path),
                     "--json"])
    assert code == 0 and e["design"]["parameters"]["mu"] == pytest.approx(MU, rel=1e-12)


@pytest.mark.slow
def test_the_same_cascade_design_from_design_export_and_simulate(tmp_path) -> None:
    code_d, d = _json(["design", "cascade", "chemostat-analyser", "--json"])
    code_e, e = _json(["export", "chemostat-analyser", "--observer", "cascade", "--out", str(tmp_path), "--json"])
    code_s, s = _json(["simulate", "chemostat-analyser", "--observer", "cascade", "--runs", "2", "--duration", "2",
                       "--json"])
    assert code_d == 0 and code_e == 1 and code_s == 0  # no [cascade.lyapunov]: verified gain, not certified
    ds = s["observers"]["cascade"]["design"]
    for key in ("parameters", "sources", "gain", "certified", "premises", "unchecked", "description"):
        assert d["design"][key] == e["design"][key] == ds[key], key
    assert d["design"]["method"] == "placement" and e["design"]["method"] == ds["method"] == "cascade"
    assert d["design"]["certified"] is False and d["design"]["unchecked"][0].startswith("Theorem 1")
