"""The peaking remedy (saturation of the drift observer) and the local verdicts of design pinv."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.geometry import Box
from nlobs.systems.modelfile import load_model
from nlobs.workflows.design_drift import design_drift_report
from nlobs.workflows.design_pinv import design_pinv_observer, design_pinv_report
from nlobs.workflows.inputs import SimulationRequest

ROOT = Path(__file__).resolve().parents[1]
A, B_, C = 0.2, 0.2, 5.7  # Rössler's parameters


def _bench():
    spec = importlib.util.spec_from_file_location("peaking_bench", ROOT / "benchmarks" / "peaking.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def rossler():
    bench = _bench()
    return bench, design_drift_report(load_model("rossler"), mu=0.0, region=bench.REGION)


@pytest.mark.slow
def test_rossler_large_error_diverges_without_saturation_and_converges_with_it(rossler):
    bench, _ = rossler
    _, rows = bench.run(sizes=(0.5,), runs=20)
    (_, off_sat, off_conv, _, off_bad, _), (_, on_sat, on_conv, on_max, on_bad, on_fin) = rows
    assert (off_sat, on_sat) == (False, True)
    assert off_bad >= 3 and off_conv <= 0.85          # measured: 6 of 20 runs become non-finite
    assert on_bad == 0 and on_conv == 1.0 and on_fin < 1e-8


def _phi_q(x):
    """Φ_s and Q_s of Rössler by hand (h = x, s = 3)."""
    x1, x2, x3 = x[..., 0], x[..., 1], x[..., 2]
    phi = np.stack([x1, -x2 - x3, -x1 - A * x2 - B_ - x3 * (x1 - C)], axis=-1)
    z, o = np.zeros_like(x1), np.ones_like(x1)
    Q = np.stack([np.stack([o, z, z], -1), np.stack([z, -o, -o], -1), np.stack([-1 - x3, -A * o, -(x1 - C)], -1)], -2)
    return phi, Q


def _f(x):
    return np.stack([-x[..., 1] - x[..., 2], x[..., 0] + A * x[..., 1], B_ + x[..., 2] * (x[..., 0] - C)], axis=-1)


def test_saturated_equals_unsaturated_inside_and_is_khalils_form_outside(rossler):
    bench, rep = rossler
    box = bench.REGION
    plain, sat = rep.observer(), rep.observer(saturation=True)
    rng = np.random.default_rng(1)
    inside = box.sample(200, seed=3)
    y = inside[:, :1] + 0.1 * rng.normal(size=(200, 1))
    assert np.array_equal(plain.rhs(0.0, inside, np.zeros((200, 0)), y), sat.rhs(0.0, inside, np.zeros((200, 0)), y))
    # outside: Q_s(x̂) x̂' = A_s (Φ(x̂) − Φ(σ)) + Q_s(σ) f(σ) + K (y − x̂1), computed here by hand
    out = inside + np.array([0.0, 9.0, 0.0])
    sig = np.clip(out, box.lower, box.upper)
    v = sat.rhs(0.0, out, np.zeros((200, 0)), y)
    phi_o, Q_o = _phi_q(out)
    phi_s, Q_s = _phi_q(sig)
    shift = np.diag([1.0, 1.0], 1)
    rhs = (phi_o - phi_s) @ shift.T + np.einsum("kij,kj->ki", Q_s, _f(sig)) + (y - out[:, :1]) @ rep.certificate.gain.T
    expect = np.linalg.solve(Q_o, rhs[..., None])[..., 0]
    np.testing.assert_allclose(v, expect, rtol=1e-9, atol=1e-9 * np.abs(expect).max())
    assert np.max(np.abs(v - plain.rhs(0.0, out, np.zeros((200, 0)), y))) > 1.0  # the nonlinear terms differ there
    s_hat = sat.saturated_estimate(out)
    assert np.all((s_hat >= box.lower) & (s_hat <= box.upper))


def test_saturation_keeps_a_run_that_stays_in_the_region(rossler):
    from nlobs.simulate import simulate

    bench, rep = rossler
    plant = load_model("rossler").compile()
    x0 = bench.X0
    xh0 = x0 + np.array([1e-9, -1e-9, 1e-9])  # tiny: with its peak (×6e6) every RK4 stage stays inside
    runs = [simulate(plant, rep.observer(saturation=s), x0, xh0, duration=0.05, dt=5e-5) for s in (False, True)]
    box = bench.REGION
    assert np.all((runs[1].x_hat >= box.lower) & (runs[1].x_hat <= box.upper))
    assert np.array_equal(runs[0].x_hat, runs[1].x_hat)


def test_cartpole_pinv_is_local_and_names_the_missing_hypotheses():
    m = load_model("cartpole")
    box = Box([-20.0, -5.0, 2.0, -5.0], [20.0, 5.0, 4.3, 5.0])
    rep = design_pinv_report(m, region=box)
    assert rep.usable_scope.startswith("local, on the region")
    assert {"A3", "A4", "A6"} <= set(rep.missing)
    d = rep.to_dict()
    assert d["usable_scope"] == rep.usable_scope and "A3" in d["missing_hypotheses"]
    assert "usable: yes" not in rep.summary() and "local only" in rep.summary()


def test_readme_pinv_tour_error_decreases_and_reports_coverage(tmp_path):
    req = SimulationRequest([0.5, 0, 0, 0.5], [0.3, 0.3, -0.3, 0], [0.0], duration=10.0, dt=1e-3)
    rep = design_pinv_observer("isidori-146", simulate=req)
    e = rep.simulation.error_norm
    assert e[-1] < 0.5 * e[0]                          # measured 0.69 → 0.31
    d = rep.to_dict()["simulation"]
    assert d["certificate_covers_run"] is False and d["certificate_covered_fraction"] == 0.0
    assert "certificate_violations" in d
    assert "isidori-146 --simulate --x0 0.5,0,0,0.5 --xhat0 0.3,0.3,-0.3,0" in (ROOT / "README.md").read_text()


def test_cli_saturation_option():
    r = CliRunner().invoke(app, ["design", "drift", "rossler", "--saturation", "maybe"])
    assert r.exit_code == 2 and "--saturation" in r.output and "Traceback" not in r.output


def test_cli_divergence_names_the_rk4_step_not_a_blind_dt_advice():
    r = CliRunner().invoke(app, ["design", "drift", "rossler", "--box", "-1,1", "--simulate", "--x0", "1,0.5,0.5",
                                 "--xhat0", "0,0,0",
                                 "--dt", "1e-3", "--duration", "0.1", "--saturation", "off"])
    assert r.exit_code == 1
    assert "RK4 is unstable at this step" in r.output and "0.00059" in r.output
    assert "try a smaller --dt" not in r.output


# ----------------------------------------------------------------------------- the Moore–Penrose observer saturated
K_ISIDORI = 2.0  # isidori-146's parameter k


@pytest.fixture(scope="module")
def pinv146():
    import warnings

    from nlobs.observers.pinv import PinvObserver
    from nlobs.synthesis.pinv_gain import HighGain

    bench = _bench()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = PinvObserver.from_model(load_model("isidori-146"), k=HighGain(bench.PINV_THETA), region=bench.PINV_BOX,
                                        require_a5=False)
    return bench, plain, plain.with_saturation(bench.PINV_BOX)


def _isidori(x, u):
    """f + g u, h, Φ_r = (h, L_f h) and Q of isidori-146 by hand (h = x4, r = 2)."""
    x1, x2, x3, x4 = (x[..., i] for i in range(4))
    F = np.stack([x1 * x2 - x1**3, x1 + (K_ISIDORI + 2 * x3) * u, -x3 + u, x1**2 + x2], -1)
    phi = np.stack([x4, x1**2 + x2], -1)
    z, o = np.zeros_like(x1), np.ones_like(x1)
    Q = np.stack([np.stack([z, z, z, o], -1), np.stack([2 * x1, o, z, z], -1)], -2)
    return F, x4[..., None], phi, Q


def test_pinv_saturated_equals_unsaturated_inside_the_box(pinv146):
    bench, plain, sat = pinv146
    rng = np.random.default_rng(5)
    x = bench.PINV_BOX.sample(300, seed=4)
    u, y = rng.normal(size=(300, 1)), rng.normal(size=(300, 1))
    assert np.array_equal(plain.rhs(0.0, x, u, y), sat.rhs(0.0, x, u, y))
    # and (7) is f + g u + Q⁺ K (y − h) there (Q⁺ by NumPy's SVD, not the observer's closed form)
    F, h, _, Q = _isidori(x, u[:, 0])
    expect = F + np.einsum("kij,kj->ki", np.linalg.pinv(Q) @ plain._K, y - h)
    np.testing.assert_allclose(plain.rhs(0.0, x, u, y), expect, rtol=1e-10, atol=1e-8)


def test_pinv_saturated_is_khalils_form_in_the_coordinates_of_phi_r_outside(pinv146):
    bench, plain, sat = pinv146
    box = bench.PINV_BOX
    rng = np.random.default_rng(6)
    x = box.sample(200, seed=7) + np.array([3.0, -2.5, 0.0, 4.0])  # x1, x2, x4 outside [-2, 2]
    u, y = rng.normal(size=(200, 1)), rng.normal(size=(200, 1))
    v = sat.rhs(0.0, x, u, y)
    sig = np.clip(x, box.lower, box.upper)
    F, h, phi, Q = _isidori(x, u[:, 0])
    Fs, _, phis, Qs = _isidori(sig, u[:, 0])
    K = np.array(plain._K)
    shift = np.array([[0.0, 1.0], [0.0, 0.0]])
    xi_dot = (phi - phis) @ shift.T + np.einsum("kij,kj->ki", Qs, Fs) + (y - h) @ K.T
    # ξ = Φ_r(x̂) moves by Khalil's form: Q(x̂) x̂' = A_r (Φ_r(x̂) − Φ_r(σ)) + Q(σ) F(σ) + K (y − h(x̂))
    np.testing.assert_allclose(np.einsum("kij,kj->ki", Q, v), xi_dot, rtol=1e-9, atol=1e-9 * np.abs(xi_dot).max())
    # and along ker Q(x̂) it follows F(σ): (I − Q⁺Q) x̂' = (I − Q⁺Q) F(σ)
    P = np.eye(4) - np.linalg.pinv(Q) @ Q
    np.testing.assert_allclose(np.einsum("kij,kj->ki", P, v), np.einsum("kij,kj->ki", P, Fs), rtol=1e-9, atol=1e-8)
    assert np.max(np.abs(v - plain.rhs(0.0, x, u, y))) > 1.0  # the nonlinear terms differ there
    assert np.all(sat.saturated_estimate(x) == sig)


def test_pinv_saturation_option_checks_the_box(pinv146):
    from nlobs.errors import DimensionError, InvalidArgumentError

    _, plain, _ = pinv146
    with pytest.raises(DimensionError, match="saturation"):
        plain.with_saturation(Box([-1.0] * 3, [1.0] * 3))
    with pytest.raises(InvalidArgumentError, match="saturation"):
        plain.with_saturation([-1.0, 1.0])
    assert plain.saturation is None and plain.with_saturation(None).saturation is None


def test_cli_pinv_saturation_option():
    r = CliRunner().invoke(app, ["design", "pinv", "isidori-146", "--saturation", "maybe"])
    assert r.exit_code == 2 and "--saturation" in r.output and "Traceback" not in r.output
    assert len(r.output.strip().splitlines()) == 1


@pytest.mark.slow
def test_pinv_saturation_defaults_on_only_with_a_box_because_the_state_must_stay_in_it():
    req = SimulationRequest([0.5, 0, 0, 0.5], [0.3, 0.3, -0.3, 0], [0.0], duration=10.0, dt=1e-3)
    off = design_pinv_observer("isidori-146", simulate=req)  # no box: off, the README's run
    on = design_pinv_observer("isidori-146", simulate=req, saturation=True)  # saturated on [-1, 1]⁴
    assert off.simulation.x_hat.shape == on.simulation.x_hat.shape
    assert off.simulation.error_norm[-1] < 0.5                 # measured 0.31
    assert on.simulation.error_norm[-1] > 5.0                  # measured 13.8: the state (x4) leaves the box
    assert np.max(np.abs(on.simulation.x[..., 3])) > 1.0
