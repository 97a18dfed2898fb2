r"""Dalla Mora, Germani & Manes (IEEE TAC 45(8), 2000): the drift-observability observer (3.1).

The paper has no numerical example. nlobs exercises its results on models of its own
(``src/nlobs/data/models``), each a function returning a frozen result:

* :func:`run_siso` — the Van der Pol oscillator in Liénard coordinates
  (``vanderpol-lienard.toml``): ``y = x₁``, ``s = r = (2)``, ``Φ_s`` nonlinear with
  ``det Q_s = 1``; a bounded input ``u = 0.5 sin 1.3t``. The gain is designed twice:
  with the constants of (2.17) estimated on the region the trajectory visits (the
  theory's ``w*``, Remark 2.11) and with a ``w`` tuned by simulation (the paper's
  advice in Sec. IV); both are simulated, beside the bound (3.2)/(3.17).
* :func:`run_mimo` — a Duffing oscillator behind an actuator, coupled to a measured
  first-order state (``duffing-actuator.toml``): two outputs, ``s = r = (3, 1)``.
* :func:`w_sweep` — the high-gain trade-off: final RMS error against ``w`` with
  measurement noise.
* :func:`rows` (also :func:`reproduce`) — ``nlobs reproduce dallamora2000``: what the
  paper states beside what nlobs computes.

Designs and simulations go through the workflow behind ``nlobs design drift``
(:func:`nlobs.workflows.design_drift.design_drift_report`,
:func:`nlobs.workflows.design_drift.simulate_drift`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from nlobs._io import save_figure
from nlobs._typing import Array
from nlobs.errors import CertificateError, DesignInfeasible
from nlobs.geometry import AffineFields, Box, input_gain_structure, observability_jacobian, observation_relative_degree
from nlobs.observers import DriftObserver
from nlobs.papers.reproduce import ReproRow
from nlobs.simulate import MeasurementGroup, simulate
from nlobs.synthesis import (
    DriftGainCertificate,
    RiccatiConstants,
    brunovsky_triple,
    design_drift_gain_sdp,
    error_bound_constants,
    smallest_w,
    vandermonde_gain,
)
from nlobs.systems import SymbolicModel, load_model
from nlobs.systems.codegen import compile_matrix
from nlobs.workflows.design_drift import DriftDesignReport, DriftSimulation, design_drift_report, simulate_drift


__all__ = [
    "DriftExample",
    "WSweep",
    "example_model",
    "lipschitz_oscillator_model",
    "plot_example",
    "plot_w_sweep",
    "reproduce",
    "rows",
    "run_mimo",
    "run_siso",
    "w_sweep",
]

MODELS = Path(__file__).resolve().parents[1] / "data" / "models"

SISO_X0 = (2.0, 0.0)
SISO_XHAT0 = (0.0, 1.0)
SISO_REGION = Box([-2.5, -3.0], [2.5, 3.0])
"""Contains the SISO trajectory (|x₁| ≤ 2.17, |x₂| ≤ 2.61 over 20 s) and the estimate's."""
SISO_MU = 0.5
SISO_W_TUNED = 5.0

MIMO_X0 = (1.0, 0.0, 0.0, 0.5)
MIMO_XHAT0 = (0.0, 0.5, 0.3, 0.0)
MIMO_REGION = Box([-1.5, -1.5, -1.0, -0.6], [1.5, 1.5, 1.0, 0.8])
"""Contains the MIMO trajectory (over 30 s) and the estimate's."""
MIMO_MU = 0.6
MIMO_W_TUNED = 3.0


def _u_siso(t: float) -> Array:
    return np.array([0.5 * math.sin(1.3 * t)])  # ‖u‖ ≤ 0.5 = μ


def _u_mimo(t: float) -> Array:
    return np.array([0.5 * math.sin(t), 0.3 * math.cos(0.7 * t)])  # ‖u‖ ≤ √(0.25 + 0.09) < 0.6 = μ


def example_model(name: str) -> SymbolicModel:
    """``"vanderpol-lienard"`` or ``"duffing-actuator"`` from the bundled model files."""
    m = load_model(MODELS / f"{name}.toml")
    assert isinstance(m, SymbolicModel)
    return m


def lipschitz_oscillator_model() -> SymbolicModel:
    """``ẋ₁ = x₂``, ``ẋ₂ = −x₁ − x₂ + ½ sin x₁ + (1 + ½ sin x₁) u``, ``y = x₁``.

    ``Φ_s`` is the identity (``s = r = 2``), ``L_s`` has Lipschitz constant ``√(1.5² + 1)``
    and ``H`` has ``½``, globally: Theorem 3.1 applies with exact constants.
    """
    x1, x2 = sp.symbols("x1 x2", real=True)
    return SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2, -x1 - x2 + sp.sin(x1) / 2],
                                      g=[[0], [1 + sp.sin(x1) / 2]], h=[x1], name="lipschitz-oscillator")


# --------------------------------------------------------------------------- examples


@dataclass(frozen=True, eq=False)
class DriftExample:
    """One example: the theory's designs (Vandermonde and SDP) and their simulations, and a tuned ``w``.

    Attributes
    ----------
    name : str
    report : DriftDesignReport
        The Vandermonde design: ``w*`` the smallest ``w`` solving (2.17) for the constants
        estimated on the region (Remark 2.11).
    theory : DriftSimulation or None
        ``K(w*)`` simulated (``None`` when ``w*`` is too stiff for a run of reasonable length).
    sdp : DriftGainCertificate or str
        The SDP design for the same constants (scaled, see
        :func:`~nlobs.synthesis.drift_gain.design_drift_gain_sdp`), or why it failed.
    sdp_run : DriftSimulation or None
        The SDP gain simulated (with its own ``κ₁``).
    tuned : DriftSimulation
        Gain ``K(w)`` with a ``w`` tuned by simulation (not certified by (2.17)).
    """

    name: str
    report: DriftDesignReport
    theory: DriftSimulation | None
    sdp: DriftGainCertificate | str
    sdp_run: DriftSimulation | None
    tuned: DriftSimulation


def _sdp_design(model: SymbolicModel, mu: float, region: Box) -> tuple[DriftDesignReport | None, DriftGainCertificate | str]:
    try:
        rep = design_drift_report(model, alpha=1.0, mu=mu, region=region, method="sdp")
    except (DesignInfeasible, CertificateError) as exc:
        return None, f"{exc}"
    return rep, rep.certificate


def run_siso(*, duration: float = 8.0, simulate_theory: bool = True) -> DriftExample:
    """Van der Pol (Liénard): theory's ``w*`` and SDP gain (estimated ``γ``, α = 1, μ = 0.5), and ``w = 5`` tuned."""
    model = example_model("vanderpol-lienard")
    rep = design_drift_report(model, alpha=1.0, mu=SISO_MU, region=SISO_REGION)
    wstar = rep.certificate.w or 1.0
    theory = None
    if simulate_theory:
        dt = min(1e-3, 0.5 / (2.0 * wstar))  # RK4: |λ_max dt| ≤ 1 with λ_max = −2w
        theory = simulate_drift(model, SISO_X0, SISO_XHAT0, min(duration, 0.5), dt=dt, u=_u_siso, report=rep,
                               saturation=False)  # the paper's (3.1)
    rep_sdp, sdp = _sdp_design(model, SISO_MU, SISO_REGION)
    sdp_run = None
    if rep_sdp is not None:
        sdp_run = simulate_drift(model, SISO_X0, SISO_XHAT0, duration, dt=_dt_for(rep_sdp.certificate), u=_u_siso,
                                 report=rep_sdp, saturation=False)
    tuned = simulate_drift(model, SISO_X0, SISO_XHAT0, duration, dt=1e-3, u=_u_siso, report=rep, w=SISO_W_TUNED,
                           saturation=False)
    return DriftExample("vanderpol-lienard", rep, theory, sdp, sdp_run, tuned)


def _dt_for(cert: DriftGainCertificate) -> float:
    """RK4 step for the linear part: ``|λ| dt ≤ 0.5`` for every ``λ ∈ eig(A_s − KC_s)``, at most 1 ms."""
    return min(1e-3, 0.5 / float(np.max(np.abs(cert.eigenvalues))))


def run_mimo(*, duration: float = 12.0) -> DriftExample:
    """Duffing + actuator, ``s = (3, 1)``: theory's ``w*`` (too stiff to simulate), SDP gain and ``w = 3`` simulated."""
    model = example_model("duffing-actuator")
    rep = design_drift_report(model, alpha=1.0, mu=MIMO_MU, region=MIMO_REGION)
    rep_sdp, sdp = _sdp_design(model, MIMO_MU, MIMO_REGION)
    sdp_run = None
    if rep_sdp is not None:
        sdp_run = simulate_drift(model, MIMO_X0, MIMO_XHAT0, duration, dt=_dt_for(rep_sdp.certificate), u=_u_mimo,
                                 report=rep_sdp, saturation=False)
    tuned = simulate_drift(model, MIMO_X0, MIMO_XHAT0, duration, dt=1e-3, u=_u_mimo, report=rep, w=MIMO_W_TUNED,
                           saturation=False)
    return DriftExample("duffing-actuator", rep, None, sdp, sdp_run, tuned)


@dataclass(frozen=True, eq=False)
class WSweep:
    """Final RMS error against ``w`` with measurement noise (the high-gain trade-off).

    Attributes
    ----------
    w : ndarray
    rms : ndarray
        RMS of ``‖x̂ − x‖`` over ``t ≥ after`` (noise-dominated for large ``w``,
        transient-dominated for small ``w``).
    rms_noise_free : ndarray
        The same without noise.
    noise_std : float
    after : float
    best_w : float
        ``w`` with the smallest noisy RMS.
    """

    w: Array
    rms: Array
    rms_noise_free: Array
    noise_std: float
    after: float
    best_w: float

    def to_dict(self) -> dict[str, Any]:
        return {"w": self.w.tolist(), "rms": self.rms.tolist(), "rms_noise_free": self.rms_noise_free.tolist(),
                "noise_std": self.noise_std, "after": self.after, "best_w": self.best_w}


def w_sweep(ws: Sequence[float] = (0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0), *, noise_std: float = 0.02,
            duration: float = 10.0, after: float = 5.0, dt: float = 1e-3, seed: int = 0) -> WSweep:
    """Van der Pol (Liénard) with noisy ``y`` (std ``noise_std`` at ``1/dt``): final RMS error against ``w``."""
    model = example_model("vanderpol-lienard")
    fields = AffineFields.from_model(model)
    plant = model.compile()
    meas = MeasurementGroup("y", ["y"], rate=1.0 / dt, noise_std=noise_std)
    rms, clean = [], []
    for w in ws:
        obs = DriftObserver.from_fields(fields, (2,), vandermonde_gain((2,), w).K)
        for noisy, out in ((True, rms), (False, clean)):
            res = simulate(plant, obs, x0=SISO_X0, x_hat0=SISO_XHAT0, duration=duration, dt=dt, u=_u_siso,
                           measurements=meas if noisy else None, seed=seed if noisy else None, save_every=10)
            sel = res.t >= after
            out.append(float(np.sqrt(np.mean(res.error_norm[sel] ** 2))))
    w_arr, r_arr = np.array(ws, dtype=float), np.array(rms)
    return WSweep(w_arr, r_arr, np.array(clean), float(noise_std), float(after), float(w_arr[int(np.argmin(r_arr))]))


# --------------------------------------------------------------------------- plots


def plot_example(ex: DriftExample, path: str | Path) -> Path:
    """Error norm with the bound (3.2) for the tuned ``w`` (and, zoomed on its short transient, the
    theory's ``w*``), and the states with their estimates; saved as PNG."""
    from matplotlib.figure import Figure  # the object API: the user's backend and pyplot state are left alone

    panels = [("tuned", ex.tuned)] + ([("theory", ex.theory)] if ex.theory is not None else []) \
        + ([("sdp", ex.sdp_run)] if ex.sdp_run is not None else [])
    fig = Figure(figsize=(5 * (len(panels) + 1), 4.2), layout="tight")
    axes = fig.subplots(1, len(panels) + 1)
    alpha = ex.report.certificate.constants.alpha
    for ax, (label, sim) in zip(axes, panels):
        res = sim.result
        t = res.t
        if label == "theory":  # the transient lasts a few 1/w*: zoom on it
            keep = t <= t[0] + 25.0 / max(sim.w or 1.0, 1.0)
            t = t[keep]
            err, bnd = res.error_norm[keep], sim.bound[keep]
        else:
            err, bnd = res.error_norm, sim.bound
        ax.semilogy(t, np.maximum(err, 1e-16), label="‖x − x̂‖")
        if sim.gain_certified:
            ax.semilogy(t, bnd, "--", label=f"κ₁e^(−αt)‖e(0)‖, κ₁ = {sim.constants.kappa1:.3g} (sampled constants)")
        ax.semilogy(t, err[0] * np.exp(-alpha * (t - t[0])), ":", color="gray", label=f"‖e(0)‖e^(−αt), α = {alpha:g}")
        ax.set_ylim(1e-12, None)
        ax.set_xlabel("t [s]")
        if label == "sdp":
            title = f"SDP gain, ‖K‖ = {sim.report.certificate.gain_norm:.3g} (certified by (2.17))"
        else:
            title = f"w = {sim.w:.4g} ({'certified by (2.17)' if sim.gain_certified else 'tuned, fails (2.17)'})"
        ax.set_title(f"{ex.name}, s = {ex.report.s}: {title}", fontsize=9)
        ax.legend(fontsize=7)
    ax = axes[-1]
    res = ex.tuned.result
    for i in range(res.x.shape[-1]):
        line = ax.plot(res.t, res.x[:, i], label=res.states[i])[0]
        ax.plot(res.t, res.x_hat[:, i], "--", color=line.get_color())
    ax.set_xlabel("t [s]")
    ax.set_title(f"states (solid) and estimates (dashed), w = {ex.tuned.w:.3g}", fontsize=9)
    ax.legend(fontsize=8)
    out = save_figure(fig, path, dpi=110)
    return out


def plot_w_sweep(sw: WSweep, path: str | Path) -> Path:
    """RMS error against ``w`` (log–log), with and without noise."""
    from matplotlib.figure import Figure  # the object API: the user's backend and pyplot state are left alone

    fig = Figure(figsize=(6, 4.2), layout="tight")
    ax = fig.subplots()
    ax.loglog(sw.w, sw.rms, "o-", label=f"noise std {sw.noise_std:g} on y")
    ax.loglog(sw.w, np.maximum(sw.rms_noise_free, 1e-16), "s--", label="no noise")
    ax.axvline(sw.best_w, color="gray", ls=":", label=f"best w = {sw.best_w:g}")
    ax.set_xlabel("w (eigenvalues −w, −2w)")
    ax.set_ylabel(f"RMS ‖x − x̂‖ over t ≥ {sw.after:g} s")
    ax.set_title("Van der Pol (Liénard): the high-gain trade-off")
    ax.legend(fontsize=8)
    out = save_figure(fig, path, dpi=110)
    return out


# --------------------------------------------------------------------------- reproduction


def _r(x: float, d: int = 4) -> float:
    return float(f"{x:.{d}g}")


def _largest_mu(s: tuple[int, ...], F: Array, alpha: float, gamma: float, *, sdp: bool) -> float:
    """Largest μ for which (2.17) is solvable (Vandermonde search or SDP), by bisection on [0, 10]."""

    def ok(mu: float) -> bool:
        c = RiccatiConstants(s, F, alpha, mu, gamma)
        try:
            (design_drift_gain_sdp(c, kappa_max=1e6, scaling=None) if sdp else smallest_w(c, w_max=1e4))
        except (DesignInfeasible, CertificateError):  # no certified solution at this μ
            return False
        return True

    lo, hi = 0.0, 10.0
    if ok(hi):
        return hi
    for _ in range(14):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def _structure_residual(model: SymbolicModel, s: tuple[int, ...], region: Box) -> float:
    """``max |Q_s g − F_{s,r} H_{s,r}|`` at 200 points of the region ((2.13))."""
    fields = AffineFields.from_model(model)
    r = observation_relative_degree(fields, region).r
    H, F = input_gain_structure(fields, s, r)
    Q = observability_jacobian(fields, s)
    M = sp.Matrix(Q) * sp.Matrix(fields.g)
    fn = compile_matrix(sp.Matrix.vstack(M, sp.Matrix(H)), (fields.x,))
    v = fn(region.sample(200, 1))
    n = fields.n
    return float(np.max(np.abs(v[:, :n, :] - F @ v[:, n:, :])))


def rows() -> list[ReproRow]:
    """``nlobs reproduce dallamora2000``: the paper's statements beside nlobs's numbers."""
    out: list[ReproRow] = []
    s31 = (3, 1)
    F31 = brunovsky_triple(s31)[1]
    triples = [(1.0, 1.0, 1.0), (3.0, 0.5, 2.0), (0.5, 5.0, 0.5), (2.0, 2.0, 4.0)]
    ws = [smallest_w(RiccatiConstants(s31, F31, *tr)) for tr in triples]
    out.append(ReproRow(
        "Thm 2.9: s ≤ r ⇒ (2.17) has a stabilising pair for every (α, μ, γ); s = r = (3, 1), "
        f"(α, μ, γ) ∈ {triples}: smallest w (Remark 2.11)",
        "exists", [_r(x.w) for x in ws],
        "every pair verified by eig of the scaled left side D L D of (2.17), P ≻ 0, A_s − KC_s Hurwitz; "
        f"(2.17) still holds at 2w, 4w, 10w: {all(x.monotone for x in ws)}"))
    c1 = RiccatiConstants((2,), brunovsky_triple((2,))[1], 1.0, 1.0, 1.0)
    w1 = smallest_w(c1)
    out.append(ReproRow("Remark 2.11: P(w) = (V_sᵀV_s)⁻¹ solves (2.17) for w large; s = (2), α = μ = γ = 1: smallest w",
                        "w large enough", _r(w1.w),
                        f"bracket ({w1.bracket[0]:.5g}, {w1.bracket[1]:.5g}); λ_max(D L D) = {w1.certificate.lhs_max_eig_scaled:.3g}, "
                        f"cn(P) = {w1.certificate.cond_P:.4g}, ‖K‖ = {w1.certificate.gain_norm:.4g}; the eigenvalues "
                        "−i·w (i = 1 … s_j), nlobs's reading of the remark's text (the other reading, −wⁱ, gives 3.14)"))
    sdp1 = design_drift_gain_sdp(c1)
    out.append(ReproRow("SDP design (LMI in S = P⁻¹, Y = SK), same constants: ‖K‖, cn(P)", None,
                        [_r(sdp1.gain_norm), _r(sdp1.cond_P)],
                        f"derived; verified by eig of (2.17) scaled: λ_max(D L D) = {sdp1.lhs_max_eig_scaled:.3g}; Vandermonde at w*: "
                        f"‖K‖ = {w1.certificate.gain_norm:.4g}, cn(P) = {w1.certificate.cond_P:.4g}"))
    alphas = [1.0, 10.0, 100.0]
    ratios = []
    for a in alphas:
        cert = smallest_w(RiccatiConstants((2,), brunovsky_triple((2,))[1], a, 1.0, 1.0)).certificate
        ratios.append(_r(cert.norm_P / a))
    out.append(ReproRow(f"Thm 2.10: s ≤ r ⇒ ‖P‖/α ≤ ε reachable; s = (2), μ = γ = 1, α = {alphas}: ‖P(w*)‖/α",
                        "→ 0", ratios, "decreasing like 1/α (‖P(w)‖ → 5 for s = 2)"))
    mu_v = _largest_mu((2,), np.eye(2), 1.0, 1.0, sdp=False)
    mu_s = _largest_mu((2,), np.eye(2), 1.0, 1.0, sdp=True)
    out.append(ReproRow("Thm 2.7: s ≰ r (s = 2, r = 1, F = I₂), α = γ = 1: (2.17) solvable for μ below a bound μ̄ > 0",
                        "μ̄ > 0 exists", [_r(mu_v, 3), _r(mu_s, 3)],
                        "largest μ found by bisection: [Vandermonde (w ≤ 1e4), SDP under nlobs's gain bound ‖K̃‖ ≤ 1e6]; "
                        "with ‖K̃‖ ≤ 1e8 (2.17) still holds at μ = 0.99 (cn(P) = 4.9e4); neither works at μ = 1"))
    mimo = example_model("duffing-actuator")
    out.append(ReproRow("(2.13) Q_s g = F_{s,r} H_{s,r} (duffing-actuator, s = (3, 1))", "identity",
                        _r(_structure_residual(mimo, s31, MIMO_REGION), 3), "max |residual| at 200 sampled points"))
    siso = run_siso(duration=4.0)
    th = siso.theory
    assert th is not None
    out.append(ReproRow(
        "Thm 3.1 (H1): decay rate of ‖x − x̂‖ ≥ α = 1, Van der Pol (Liénard), K(w*) for γ estimated on the region",
        "≥ α", _r(th.decay_rate),
        f"w* = {th.w:.5g} for γ = {siso.report.gamma:.4g} (sampled, {siso.report.region.describe()}), μ = {SISO_MU}"))
    out.append(ReproRow("(3.2): max_t ‖e(t)‖ / (κ₁e^(−αt)‖e(0)‖), same run", "≤ 1", _r(th.bound_ratio, 3),
                        f"κ₁ = {th.report.bound.kappa1:.4g} from sampled γ_Φ = {th.report.lipschitz.gamma_phi:.4g}, "
                        f"γ_Φ⁻¹ = {th.report.lipschitz.gamma_phi_inv:.4g}, cn(P) = {th.report.bound.cond_P:.4g}: "
                        "conservative; " + ("Theorem 3.1 covers the run" if th.certified else
                                            "held, but Theorem 3.1 does not cover the run: "
                                            + "; ".join(th.coverage.reasons))))
    out.append(ReproRow("Sec. IV: w tuned by simulation (w = 5, not certified by (2.17)), same plant: decay rate", None,
                        _r(siso.tuned.decay_rate), "derived: converges although the theory asks for w ≥ w*"))
    lip = lipschitz_oscillator_model()
    cl = RiccatiConstants((2,), brunovsky_triple((2,))[1], 1.0, 1.0, math.hypot(math.hypot(1.5, 1.0), 0.5))
    cert = smallest_w(cl).certificate
    obs = DriftObserver.from_model(lip, cert.gain)
    res = simulate(lip.compile(), obs, x0=[1.0, 0.0], x_hat0=[-1.0, 1.0], duration=6.0, dt=2e-3,
                   u=lambda t: np.array([0.8 * math.sin(2.0 * t)]))
    b = error_bound_constants(cert, 1.0, 1.0, estimated=False)
    ratio = float(np.max(res.error_norm / b.bound(res.t, res.error_norm[0])))
    out.append(ReproRow("(3.2) with exact constants (Φ_s = id, γ_L = √3.25, γ_H = 0.5, μ = 1): max ‖e‖/(κ₁e^(−αt)‖e(0)‖)",
                        "≤ 1", _r(ratio, 3), f"κ₁ = √cn(P) = {b.kappa1:.4g}; measured decay rate {_r(float(res.decay_rate(floor=1e-10)), 4)}"))
    mim = run_mimo(duration=5.0)
    out.append(ReproRow("MIMO s = (3, 1): decay rate with w = 3 (duffing-actuator, μ = 0.6)", None, _r(mim.tuned.decay_rate),
                        f"theory's w* = {mim.report.certificate.w:.5g} for the sampled γ = {mim.report.gamma:.4g} "
                        f"(‖K(w*)‖ = {mim.report.certificate.gain_norm:.3g}): conservative"))
    if mim.sdp_run is not None:
        sr = mim.sdp_run
        out.append(ReproRow("MIMO, SDP gain for the same constants (scaled LMI): decay rate; max ‖e‖/(κ₁e^(−αt)‖e(0)‖)",
                            "≥ α; ≤ 1", [_r(sr.decay_rate), _r(sr.bound_ratio, 3)],
                            f"‖K‖ = {sr.report.certificate.gain_norm:.4g} (θ = {sr.report.certificate.scaling:.4g}) "
                            f"against {mim.report.certificate.gain_norm:.3g} for K(w*); κ₁ = {sr.report.bound.kappa1:.4g}"))
    out.append(ReproRow("(3.17) κ₁, κ₂", "γ_Φ γ_Φ⁻¹ √cn(P), γ_Φ⁻¹ √(‖P‖/2α)", "γ_Φ γ_Φ⁻¹ √cn(P), γ_Φ⁻¹ √(‖P‖/2α)",
                        "re-derived from (3.15)–(3.16) (squared norms); the text extraction of the paper drops the "
                        "radical signs in (3.2), (3.17), (3.20)"))
    return out


def reproduce() -> list[ReproRow]:
    """Alias of :func:`rows` for :mod:`nlobs.papers.reproduce`."""
    return rows()
