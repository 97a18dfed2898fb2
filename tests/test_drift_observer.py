"""The drift-observability observer (3.1) of Dalla Mora, Germani & Manes: convergence, the bound (3.2)/(3.17), bad input."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from nlobs.errors import InvalidArgumentError, ModelError, NonFiniteError
from nlobs.geometry import AffineFields, Box
from nlobs.observers.base import Observer
from nlobs.geometry.lipschitz import lipschitz_estimates
from nlobs.observers.drift import DriftObserver, SingularObservabilityError
from nlobs.simulate import simulate
from nlobs.synthesis.drift_bounds import error_bound_constants
from nlobs.synthesis.drift_gain import RiccatiConstants, smallest_w, vandermonde_gain
from nlobs.systems.modelfile import load_model
from nlobs.systems.symbolic import SymbolicModel
from nlobs.workflows.design_drift import design_drift_report, simulate_drift

MODELS = Path(__file__).resolve().parents[1] / "src" / "nlobs" / "data" / "models"
x1, x2 = sp.symbols("x1 x2", real=True)

# Φ_s = identity (y = x1, s = r = 2); L_s = −x1 − x2 + 0.5 sin x1 has Lipschitz constant √(1.5² + 1) (attained at
# cos x1 = −1) and H = 1 + 0.5 sin x1 has 0.5, globally: Theorem 3.1's constants are exact.
GAMMA_L = math.hypot(1.5, 1.0)
GAMMA_H = 0.5


def _lipschitz_model() -> SymbolicModel:
    return SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2, -x1 - x2 + sp.sin(x1) / 2],
                                      g=[[0], [1 + sp.sin(x1) / 2]], h=[x1], name="lipschitz-oscillator")


def _u(t: float) -> np.ndarray:
    return np.array([0.8 * math.sin(2.0 * t)])  # ‖u‖ ≤ μ = 1


def test_lipschitz_estimates_match_the_exact_constants() -> None:
    fields = AffineFields.from_model(_lipschitz_model())
    est = lipschitz_estimates(fields, (2,), (2,), Box([-math.pi, -3.0], [math.pi, 3.0]), samples=4000)
    assert est.gamma_phi == pytest.approx(1.0) and est.gamma_phi_inv == pytest.approx(1.0)
    assert est.gamma_L == pytest.approx(GAMMA_L, rel=1e-3) and est.gamma_L <= GAMMA_L + 1e-12
    assert est.gamma_H == pytest.approx(GAMMA_H, rel=1e-3) and est.gamma_H <= GAMMA_H + 1e-12


def test_theorem_3_1_bound_holds_and_decay_rate_at_least_alpha() -> None:
    model = _lipschitz_model()
    alpha = 1.0
    c = RiccatiConstants((2,), [[0.0], [1.0]], alpha=alpha, mu=1.0, gamma=math.hypot(GAMMA_L, GAMMA_H))
    cert = smallest_w(c).certificate
    obs = DriftObserver.from_model(model, cert.gain)
    assert isinstance(obs, Observer)
    bound = error_bound_constants(cert, 1.0, 1.0, estimated=False)  # Φ_s = identity: γ_Φ = γ_Φ⁻¹ = 1
    assert bound.kappa1 == pytest.approx(math.sqrt(cert.cond_P))
    x0 = np.array([[1.0, 0.0], [-2.0, 1.5], [0.5, -1.0]])
    res = simulate(model.compile(), obs, x0=x0, x_hat0=[-1.0, 1.0], duration=6.0, dt=2e-3, u=_u)
    e = res.error_norm
    env = bound.bound(res.t, e[:, 0])
    assert np.all(e <= env * (1 + 1e-6) + 1e-12)
    # measured rate over the run: ‖e(t)‖ ≤ C e^{−αt}, and the log-slope after the transient is ≤ −α
    late = (res.t >= 1.0) & (e[0] > 1e-10)
    slope = np.polyfit(res.t[late], np.log(e[0][late]), 1)[0]
    assert -slope >= alpha
    assert np.all(res.decay_rate(floor=1e-10) >= alpha)


def test_vanderpol_with_nonconstant_Q_s_converges_and_matches_z_error_dynamics() -> None:
    model = load_model(MODELS / "vanderpol-lienard.toml")
    w = 4.0
    obs = DriftObserver.from_model(model, vandermonde_gain((2,), w).K)
    Q = obs.jacobian_Q([[1.5, 0.3]])
    np.testing.assert_allclose(Q[0], [[1.0, 0.0], [-(1.5**2 - 1.0), 1.0]])  # Φ = (x1, x2 − (x1³/3 − x1))
    res = simulate(model.compile(), obs, x0=[2.0, 0.0], x_hat0=[0.0, 1.0], duration=8.0, dt=2e-3, u=_u)
    assert res.error_norm[-1] < 1e-6 * res.error_norm[0]
    assert res.decay_rate(floor=1e-10)[()] >= 1.0


def test_rhs_batched_equals_rowwise_and_regularisation_is_close() -> None:
    model = load_model(MODELS / "duffing-actuator.toml")
    K = vandermonde_gain((3, 1), 3.0).K
    obs = DriftObserver.from_model(model, K)
    assert obs.s == (3, 1)
    rng = np.random.default_rng(0)
    z = rng.normal(size=(5, 4))
    u = rng.normal(size=(5, 2))
    y = rng.normal(size=(5, 2))
    batched = obs.rhs(0.0, z, u, y)
    for i in range(5):
        np.testing.assert_allclose(obs.rhs(0.0, z[i], u[i], y[i]), batched[i], rtol=1e-12)
    reg = DriftObserver.from_model(model, K, regularization=1e-6)
    np.testing.assert_allclose(reg.rhs(0.0, z, u, y), batched, rtol=1e-6, atol=1e-8)


def _singular_model() -> SymbolicModel:
    # h = x1²: Q_s = [[2x1, 0], [2x2, 2x1]] is singular on x1 = 0
    return SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2, -x1], g=[[0], [1]], h=[x1**2], name="square-sensor")


def test_singular_Q_s_at_initial_estimate_is_a_clear_error() -> None:
    obs = DriftObserver.from_model(_singular_model(), vandermonde_gain((2,), 2.0).K)
    with pytest.raises(SingularObservabilityError, match=r"square-sensor: Q_s \(s = \[2\]\) is singular at the initial "
                                                         r"estimate, x̂ = \(x1=0, x2=1\).*`x_hat0`.*`s`.*`region`") as ei:
        obs.init([0.0, 1.0])
    assert ei.value.point == (0.0, 1.0) and ei.value.time is None
    with pytest.raises(SingularObservabilityError, match=r"singular at t=1.5, x̂ = \(x1=0, x2=0.5\)"):
        obs.rhs(1.5, np.array([0.0, 0.5]), np.array([0.0]), np.array([1.0]))
    reg = DriftObserver.from_model(_singular_model(), vandermonde_gain((2,), 2.0).K, regularization=1e-3)
    assert np.all(np.isfinite(reg.rhs(1.5, reg.init([0.0, 0.5]), np.array([0.0]), np.array([1.0]))))


def test_multi_index_must_sum_to_n_and_model_must_be_input_affine() -> None:
    K = np.ones((1, 1))
    with pytest.raises(InvalidArgumentError, match=r"multi-index s=\[1\] sums to 1; it must sum to n = 2"):
        DriftObserver.from_model(_lipschitz_model(), K, s=(1,))
    general = SymbolicModel.general(["x1", "x2"], ["u"], ["y"], rhs=[x2, -x1 + sp.Symbol("u", real=True) ** 3], h=[x1],
                                    name="cubic-input")
    with pytest.raises(ModelError, match=r"cubic-input: the method needs an input-affine model"):
        DriftObserver.from_model(general, vandermonde_gain((2,), 1.0).K)
    with pytest.raises(ModelError, match="input-affine"):
        design_drift_report(general)


def test_design_report_text_and_dict() -> None:
    model = load_model(MODELS / "duffing-actuator.toml")
    rep = design_drift_report(model, alpha=1.0, mu=1.0, gamma=2.0, region=Box.around(np.zeros(4), 1.0), samples=200)
    assert rep.s == (3, 1) and rep.r == (3, 1)
    assert rep.certificate.verified and rep.gamma_source == "given"
    d = rep.to_dict()
    assert d["s"] == [3, 1] and d["certificate"]["verified"] is True and d["bound"]["kappa1"] > 1
    txt = rep.summary()
    assert "s = (3, 1)" in txt and "(2.17)" in txt and "κ₁" in txt
    assert rep.observer().s == (3, 1)
    # the given γ = 2 is below what sampling the unit box finds: the gain is verified, the design not usable
    assert rep.lipschitz.gamma > 2.0 and not rep.usable and d["usable"] is False
    assert d["warnings"] == list(rep.warnings) and "below the sampled" in rep.warnings[0] and "usable: NO" in txt


def test_model_without_inputs_and_s_not_le_r_report() -> None:
    free = SymbolicModel.input_affine(["x1", "x2"], [], ["y"], f=[x2, -x1 - x1**3], g=None, h=[x1], name="no-input")
    rep = design_drift_report(free, alpha=1.0, mu=0.0, samples=200)
    assert rep.r == (None,) and rep.F.shape == (2, 0) and rep.certificate.verified
    obs = rep.observer()
    assert obs.rhs(0.0, np.array([0.5, 0.1]), np.zeros(0), np.array([0.4])).shape == (2,)
    early = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2, -x1], g=[[1], [0]], h=[x1], name="early-input")
    rep = design_drift_report(early, alpha=1.0, mu=0.2, gamma=1.0, samples=200)
    assert rep.r == (1,) and not rep.checks[1].passed and rep.certificate.verified
    np.testing.assert_array_equal(rep.F, np.eye(2))  # d = s − r + 1 = 2: F = I₂ (2.12)


def test_report_is_not_usable_when_drift_observability_fails() -> None:
    # Φ_s = (x1, x2³): det Q_s = 3 x2² vanishes on x2 = 0; the gain for the given γ is still verified
    sing = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2**3, -x1], g=[[0], [1]], h=[x1], name="sing")
    rep = design_drift_report(sing, gamma=1.0, samples=200)
    assert not rep.drift_check.passed and rep.certificate.verified
    assert not rep.usable and rep.to_dict()["usable"] is False
    assert rep.reasons[0].startswith("drift-observability fails on the region") and "3*x2**2" in rep.reasons[0]
    assert rep.summary().splitlines()[-1].startswith("  usable: NO — drift-observability fails")


def test_given_gamma_below_the_estimate_is_warned_and_simulations_are_not_certified() -> None:
    model = _lipschitz_model()
    region = Box([-math.pi, -3.0], [math.pi, 3.0])
    rep = design_drift_report(model, alpha=1.0, mu=1.0, gamma=0.5, region=region, samples=500)
    assert rep.certificate.verified and rep.lipschitz.gamma > 1.5  # true γ = √(3.25 + 0.25) ≈ 1.87
    assert len(rep.warnings) == 1 and "γ = 0.5 (given) is below the sampled" in rep.warnings[0]
    assert not rep.usable and rep.to_dict()["warnings"] == list(rep.warnings)
    sim = simulate_drift(model, [1.0, 0.0], [-1.0, 1.0], 1.0, dt=2e-3, report=rep, u=_u)
    assert not sim.certified and math.isnan(sim.bound_ratio)
    ok = design_drift_report(model, alpha=1.0, mu=1.0, gamma=2.0, region=region, samples=500)
    assert ok.usable and ok.warnings == () and ok.reasons == ()


def test_lipschitz_estimates_on_a_region_where_the_model_is_undefined() -> None:
    sq = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2, sp.sqrt(x1 - 2)], g=[[0], [1]], h=[x1],
                                    name="sqrtf")
    fields = AffineFields.from_model(sq)
    with pytest.raises(NonFiniteError, match=r"sqrtf: Q_s \(s = \[2\]\) .* not finite at any of the 200 sampled points "
                                             r"of the region \[-1, 1\] × \[-1, 1\]"):
        lipschitz_estimates(fields, (2,), (2,), Box.unit(2), samples=200)
    est = lipschitz_estimates(fields, (2,), (2,), Box([2.5, -1.0], [3.0, 1.0]), samples=200)  # defined there
    assert est.samples == 200 and np.isfinite(est.gamma_L)


@pytest.mark.parametrize("on_singular", ["raise", "nan"])
def test_unit_q_shortcut_gives_the_solves_numbers_bit_for_bit(on_singular: str) -> None:
    """Φ_s the identity (y = x1, s = 2): Q_s ≡ I, so the correction is K ỹ without a solve; against the general
    path (the same observer told otherwise): the same bits for a batch and one run, and the same answer where the
    innovation is not finite."""
    model = _lipschitz_model()
    K = vandermonde_gain((2,), 3.0).K
    fast = dataclasses.replace(DriftObserver.from_model(model, K), on_singular=on_singular)
    slow = dataclasses.replace(fast)
    object.__setattr__(slow, "_unit_q", False)
    assert fast._unit_q and not DriftObserver.from_model(load_model(MODELS / "duffing-actuator.toml"),
                                                         vandermonde_gain((3, 1), 3.0).K)._unit_q
    assert not DriftObserver.from_model(model, K, cond_limit=1.5)._unit_q  # the bound ≈ 1 must stay below it
    rng = np.random.default_rng(3)
    z, u, y = rng.normal(size=(6, 2)), rng.normal(size=(6, 1)), 1e3 * rng.normal(size=(6, 1))
    np.testing.assert_array_equal(fast.rhs(0.0, z, u, y), slow.rhs(0.0, z, u, y))
    for i in range(6):
        np.testing.assert_array_equal(fast.rhs(0.0, z[i], u[i], y[i]), slow.rhs(0.0, z[i], u[i], y[i]))
    y[2, 0] = np.nan
    with np.errstate(invalid="ignore"):
        if on_singular == "raise":
            with pytest.raises(SingularObservabilityError):
                fast.rhs(0.0, z, u, y)
            with pytest.raises(SingularObservabilityError):
                slow.rhs(0.0, z, u, y)
        else:
            np.testing.assert_array_equal(fast.rhs(0.0, z, u, y), slow.rhs(0.0, z, u, y))
