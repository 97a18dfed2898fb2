"""The drift-observability observer (3.1) under sampled outputs: its sampling budget from (2.17)'s own (K, P).

Independent sources: the exact one-period map of the linear error system with the output predictor (a matrix
exponential, SciPy), and the premise the coverage monitor checks against the run's sensors.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sl

from nlobs.methods.problem import problem
from nlobs.methods.registry import get
from nlobs.methods.sensor_design import drift_sampling_bound
from nlobs.synthesis.sampled_data import verify_sampled_data_bound

OSC = """
name = "osc"
time = "continuous"
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]

[dynamics]
f = ["x2", "-x1 - 0.5*x2"]
g = [["0"], ["1"]]
h = ["x1"]

[sensors.enc]
outputs = ["y"]
rate = {rate}
noise_std = 0.001

[input_signals]
u = {{ kind = "sine", amplitude = 0.5, frequency = 0.2 }}

[simulation]
x0 = [1.0, 0.0]
initial_error_std = [0.1, 0.1]
duration = 4.0
dt = 0.001
box = [[-3, 3], [-3, 3]]
"""
A = np.array([[0.0, 1.0], [-1.0, -0.5]])
C = np.array([[1.0, 0.0]])


def _osc(tmp_path: Path, rate: float) -> str:
    f = tmp_path / f"osc-{rate:g}.toml"
    f.write_text(OSC.format(rate=rate))
    return str(f)


def _exact_limit(K: np.ndarray) -> float:
    """The first period at which the predictor's exact one-period map of ė = (A − KC)e + Kδ, δ̇ = CAe stops
    contracting (here z = x: Φ = (h, L_f h) = (x1, x2))."""
    big = np.block([[A - K @ C, K], [C @ A, np.zeros((1, 1))]])
    for T in np.linspace(1e-4, 3.0, 6000):
        if max(abs(np.linalg.eigvals(sl.expm(big * T)[:2, :2]))) >= 1:
            return float(T)
    return math.inf


def test_the_drift_budget_is_below_the_exact_limit_and_recomputes(tmp_path: Path) -> None:
    pb = problem(_osc(tmp_path, 1000.0))
    d = get("drift").design(pb)
    bound = drift_sampling_bound(pb, d.report)
    assert bound is not None and bound.verified
    K = np.asarray(d.report.certificate.gain)
    t_max = bound.t_max[0]
    assert 0 < t_max < _exact_limit(K)
    # the closed form ℓ = ‖C_s A_s P^{1/2}‖ (s = r = 2: ẏ = z₂) and κ = ‖P^{-1/2} K‖
    P = np.asarray(d.report.certificate.P)
    w, V = np.linalg.eigh(P)
    ell = np.linalg.norm(np.array([[0.0, 1.0]]) @ (V * np.sqrt(w)) @ V.T, 2)
    kappa = np.linalg.norm((V / np.sqrt(w)) @ V.T @ K, 2)
    assert t_max == pytest.approx(d.report.certificate.constants.alpha / (kappa * ell), rel=1e-9)
    assert verify_sampled_data_bound(bound).verified
    # (1) itself: the bound's Lyapunov matrix (P⁻¹ of (2.17)) makes V decay at 2α along the exact error system of
    # this linear plant in z = x, ė = (A_s − K C_s + B_s ℓᵀ) e, ℓ = (−1, −0.5) (P itself does not: λ_max > 0)
    Acl = np.array([[0.0, 1.0], [0.0, 0.0]]) - K @ C + np.array([[0.0], [1.0]]) @ np.array([[-1.0, -0.5]])
    alpha = d.report.certificate.constants.alpha
    lyap = bound.P @ Acl + Acl.T @ bound.P + 2 * alpha * bound.P
    assert np.linalg.eigvalsh(lyap)[-1] < 0
    assert np.linalg.eigvalsh(P @ Acl + Acl.T @ P + 2 * alpha * P)[-1] > 0


def test_a_fast_sensor_makes_the_predictor_the_certified_default(tmp_path: Path) -> None:
    pb = problem(_osc(tmp_path, 1000.0))
    d = get("drift").design(pb)
    assert d.parameters["sampling"] == "predictor" and d.parameters["T_max"]["enc"] > 0.001
    premise = next(h for h in d.hypotheses if getattr(h, "name", "").startswith("sampled with period"))
    assert premise.holds and "enc: T = 0.001 ≤ T_max" in premise.name


def test_a_slow_sensor_says_by_how_much_and_keeps_the_held_sample(tmp_path: Path) -> None:
    pb = problem(_osc(tmp_path, 10.0))
    d = get("drift").design(pb)
    assert d.parameters["sampling"] == "hold"
    premise = next(h for h in d.hypotheses if getattr(h, "name", "").startswith("sampled with period"))
    assert not premise.holds and "enc: T = 0.1 > T_max = " in premise.reason
    forced = get("drift").design(pb, sampling="predictor")
    premise = next(h for h in forced.hypotheses if getattr(h, "name", "").startswith("sampled with period"))
    assert not premise.holds and "T = 0.1 > T_max" in premise.reason


def test_the_cartpole_drift_gain_needs_a_period_far_below_its_encoders() -> None:
    """w = 707 (the smallest w solving (2.17) on the file's region): T_max is orders of magnitude below 20 ms,
    which is why the drift observer is not certified (and not recommended) under the cart-pole's encoders."""
    pb = problem("cartpole")
    d = get("drift").design(pb)
    bound = drift_sampling_bound(pb, d.report)
    assert bound is not None and not bound.verified
    assert bound.t_max[0] < 1e-4
    assert "encoders: T = 0.02 > T_max" in (bound.violation() or "")


def test_a_diverged_run_names_the_causes_it_shows(tmp_path: Path) -> None:
    """Samples every 0.4 s held into a drift gain with poles −4.2 and −8.5, integrated at dt = 0.4: the runs blow
    up, and the report names what it saw before: the estimate leaving the region, T above T_max and dt·λ outside
    RK4's stability region (−8.46 · 0.4 = −3.38 < −2.785 on the real axis)."""
    from nlobs.methods.comparison import compare_observers

    f = tmp_path / "osc-slow.toml"
    f.write_text(OSC.format(rate=2.5).replace("dt = 0.001", "dt = 0.4").replace("duration = 4.0", "duration = 40.0"))
    rep = compare_observers(str(f), observers=["drift"], runs=2, progress=False)
    o = rep.observers["drift"]
    assert len(o.diverged_runs) == 2
    causes = " | ".join(o.diverged_runs[0].causes)
    assert "the estimate left the region" in causes
    assert "enc: T = 0.4 > T_max" in causes
    lam = min(v.real for v in get("drift").design(problem(str(f))).certificate.eigenvalues)  # −2w, real
    assert f"dt·λ = {0.4 * lam:.3g} is outside RK4's stability region" in causes
    assert f"`dt` below {2.785 / abs(lam):.3g}" in causes  # the real-axis limit, found by bisection of |R| = 1
    assert o.to_dict()["diverged_runs"][0]["causes"] == list(o.diverged_runs[0].causes)
    assert "seen before run" in rep.summary()


def test_rk4_stability_region_against_its_closed_form_edges() -> None:
    """RK4's stability region meets the negative real axis at −2.7853 and the imaginary axis at ±2√2 (the roots of
    |R(z)| = 1 there): a complex pole is judged by |R(dt·λ)|, not by dt·|λ| against the real-axis limit."""
    from nlobs.methods.comparison import _rk4_growth, _stable_step

    assert _rk4_growth(np.array(-2.784)) < 1 < _rk4_growth(np.array(-2.786))
    r = 2 * math.sqrt(2)
    assert _rk4_growth(np.array(1j * (r - 1e-3))) <= 1 < _rk4_growth(np.array(1j * (r + 1e-3)))
    assert _stable_step(-1.0 + 0j, 10.0) == pytest.approx(2.78529, abs=1e-5)
    assert _stable_step(1j, 10.0) == pytest.approx(r, abs=1e-6)  # 2.83 > 2.785: the real-axis rule would be wrong


def test_design_drift_prints_the_budget_under_the_files_sensors(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from nlobs.cli import app

    res = CliRunner().invoke(app, ["design", "drift", _osc(tmp_path, 1000.0)])
    assert res.exit_code == 0, res.output
    line = next(ln for ln in res.output.splitlines() if "under the file's sensors" in ln)
    assert "(predictor)" in line and "enc: T = 0.001, T_max = " in line
    res = CliRunner().invoke(app, ["design", "drift", _osc(tmp_path, 10.0)])
    line = next(ln for ln in res.output.splitlines() if "under the file's sensors" in ln)
    assert "(hold)" in line and "enc: T = 0.1 > T_max" in line


def test_the_drift_bounded_noise_bound_in_x_is_above_the_exact_worst_case(tmp_path: Path,
                                                                          predictor_worst_case) -> None:
    # the oscillator in z = x (Φ = (h, L_f h) = (x1, x2)): the exact hybrid error system of the predictor,
    # ė = (A − K C) e − K δ, δ̇ = −C A e, δ(t_k) = v_k, against the certificate's limsup |e| ≤ iss_gain · v̄
    pb = problem(_osc(tmp_path, 1000.0))
    d = get("drift").design(pb)
    b = d.bound
    assert b is not None and b.verified and not b.process_noise
    K = np.asarray(d.report.certificate.gain)
    assert b.gamma_phi_inv >= 1.0 - 1e-9  # the identity map, estimated by sampling the region
    assert b.iss_gain == pytest.approx(b.gamma_phi_inv * b.inner.iss_gain, rel=1e-12)
    worst = predictor_worst_case(A, C, K, 0.001)
    assert worst <= b.iss_gain < 1e4 * worst
    assert b.ultimate_bound(0.25) == pytest.approx(0.25 * b.iss_gain, rel=1e-6)
    # the mean-square bound from an initial second moment in x: λmax(P) γ_Φ² trace(p0) in z
    p0 = np.diag([0.01, 0.02])
    inner = b.inner
    v0 = np.linalg.eigvalsh(inner.P)[-1] * b.gamma_phi**2 * 0.03
    ms = (math.exp(-inner.sigma * 2.0) * v0 + inner.N / inner.sigma) / inner.lam_min
    assert b.rms_after(2.0, p0) == pytest.approx(b.gamma_phi_inv * math.sqrt(ms), rel=1e-12)
    assert d.to_dict()["sampled"]["iss_gain"] == pytest.approx(b.iss_gain)
    assert any("limsup |e| ≤" in line and "in x" in line for line in d.details)


@pytest.mark.slow
def test_with_process_noise_the_drift_bound_counts_it_and_its_runs_stay_below(tmp_path: Path) -> None:
    from nlobs.methods.comparison import compare_observers
    from nlobs.methods.sensor_design import drift_process_noise

    f = tmp_path / "osc-q.toml"
    f.write_text(OSC.format(rate=1000.0) + '\n[process_noise]\nstd = [0.0, 0.01]\n')
    pb = problem(str(f))
    d = get("drift").design(pb)
    assert d.bound is not None and d.bound.verified and not d.bound.process_noise
    # z = x here (Φ = (x1, x2)): Q_s = I, no Itô drift, and the intensity is W itself: c = λ_max(W) = 1e-4
    c, beta, _ = drift_process_noise(pb, d.report)
    assert c == pytest.approx(1e-4 * 1.05, rel=1e-9) and beta == 0.0
    quiet = get("drift").design(problem(_osc(tmp_path, 1000.0)))
    assert d.bound.rms_after(1.0) > quiet.bound.rms_after(1.0)
    assert any("the file's noise: RMS ≤" in line for line in d.details)
    rep = compare_observers(str(f), observers=["drift"], runs=6, progress=False)
    o = rep.observers["drift"]
    assert o.certificate["verified"] and o.certificate["covered_fraction"] == 1.0
    assert o.rms_error_norm <= o.certificate["rms_bound"]
    # held samples: the budget is the predictor's, no bound is read in x
    held = get("drift").design(pb, sampling="hold")
    assert held.bound is None


def test_the_ito_drift_of_a_nonlinear_observability_map_is_bounded(tmp_path: Path) -> None:
    # y = x1 + 0.2 x1³: Φ = (h, L_f h), ∂²h/∂x1² = 1.2 x1, so d_1 = ½ · 1.2 x1 · W_11 (|x1| ≤ 3: 1.8 W_11)
    from nlobs.methods.sensor_design import drift_process_noise

    text = OSC.format(rate=1000.0).replace('h = ["x1"]', 'h = ["x1 + 0.2*x1**3"]')
    f = tmp_path / "osc-cubic.toml"
    f.write_text(text + '\n[process_noise]\nstd = [0.01, 0.0]\n')
    pb = problem(str(f))
    d = get("drift").design(pb)
    c, beta, per = drift_process_noise(pb, d.report)
    assert per[0] == pytest.approx(0.5 * 1.2 * 3.0 * 1e-4 * 1.05, rel=1e-6)
    assert beta >= per[0]


def test_a_mapped_bound_refuses_bad_constants(tmp_path: Path) -> None:
    from nlobs.errors import InvalidArgumentError, NonFiniteError
    from nlobs.synthesis.mapped_bound import MappedBound

    d = get("drift").design(problem(_osc(tmp_path, 1000.0)))
    inner = d.bound.inner
    for bad in (0.0, -1.0, math.inf, math.nan):
        with pytest.raises((InvalidArgumentError, NonFiniteError)):
            MappedBound(inner, bad, 1.0, False)
        with pytest.raises((InvalidArgumentError, NonFiniteError)):
            MappedBound(inner, 1.0, bad, False)
    with pytest.raises(InvalidArgumentError, match="SampledDataBound"):
        MappedBound("bound", 1.0, 1.0, False)  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="p0"):
        d.bound.rms_after(1.0, np.full((2, 2), math.nan))
