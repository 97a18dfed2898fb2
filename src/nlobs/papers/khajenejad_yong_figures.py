r"""Khajenejad & Yong, Sec. 6: figures like the paper's Figs. 2-7, each runner a function returning a frozen result.

* :func:`fig_61_states` (Fig. 2): Example 6.1, states ``x₁..x₄`` and the unknown input ``d`` with their
  set-valued estimates (Class II with Lemma 2.14's ``γ``, and nlobs's structured Class 0 multiplier) and
  the balls (drawn per component as ``x̂ᵢ ± δ``).
* :func:`fig_61_errors` (Fig. 3): errors against the radii for both designs (the printed Class I and the
  printed Class 0 multiplier have no certified design, ``docs/setvalued.md``).
* :func:`fig_unbounded_input` (Figs. 4-7 and the Sec. 6.2 claim): on the same runs with a bounded and a
  growing unknown input, the set-valued observer against the Lipschitz LMI point observer and the EKF that
  models ``d`` as noise (``docs/baselines.md``): states and estimates of one run, and box plots of the
  errors over 50 random initial conditions with the radii ``δˣ_k``, ``δᵈ_k``. Example 6.2 *as printed*
  admits no stable observer of this structure (invariant zero −1.3431), so the runs use
  :func:`example_62_variant` — **nlobs's variant, not the paper's example** — and Example 6.1.
* :func:`fig_affine_output`: a nonlinear observation function turned into the form (6) by the affine
  abstraction of Proposition 2.18 (its residual joins the measurement noise, (7)) and run through
  Algorithm 1.

:func:`make_figures` writes them all as ``setvalued_*.png``. No example was tuned to look like the
paper's figures; the choices not given by the paper are stated where they are made.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nlobs._typing import Array
from nlobs.papers.khajenejad_yong import PaperExample, example_61
from nlobs.simulate.setvalued import ContainmentResult, ball_samples, containment_of, simulate_batch
from nlobs.simulate.setvalued_plots import plot_errors_vs_radii, save_figure
from nlobs.workflows.setvalued import MonteCarloStudy, monte_carlo, point_baselines
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.setvalued import (
    input_containment,
    input_estimates,
    radii_of,
    run_setvalued,
    state_containment,
)
from nlobs.synthesis.affine_abstraction import affine_abstraction
from nlobs.synthesis.setvalued import SetValuedDesign, design_setvalued
from nlobs.systems.discrete_ui import DiscreteUISystem, Lipschitz
from nlobs.systems.timebase import Discrete

__all__ = [
    "FigureResult",
    "UnboundedInputResult",
    "AffineOutputResult",
    "example_62_variant",
    "fig_61_states",
    "fig_61_errors",
    "fig_unbounded_input",
    "fig_affine_output",
    "make_figures",
]


@dataclass(frozen=True)
class FigureResult:
    """A written figure and the numbers behind it.

    Attributes
    ----------
    path : Path
    numbers : mapping of str to float
        What the figure shows, measured (containment rates, final radii, errors).
    """

    path: Path
    numbers: Mapping[str, float]


def example_62_variant() -> PaperExample:
    """**nlobs's variant** of the Sec. 6.2 benchmark that admits a stable observer (not the paper's example).

    Two changes to the printed data: ``G = [1, +0.65]ᵀ`` (printed ``[1, −0.65]ᵀ``), which moves the
    invariant zero of ``(A, G, C)`` from ``−1.3431`` to ``−0.42 + 0.6/0.65 = 0.5031``, and
    ``φ = [0, −0.25 tanh x₁]`` (printed ``−1.25 tanh x₁``): with ``1.25`` the error obeys
    ``x̃₁,k = 0.5031 x̃₁,k−1 + 1.923 (Δ tanh)`` in the noise-free case, whose slope reaches 2.43 > 1, and
    the LMI (⋆) is infeasible for every ``λ < 1`` (measured for ``c = 1.25`` and ``0.5``). Everything else
    is printed: ``A``, ``C = [0 1]``, ``W = I``, ``η_w = 0.2``, ``η_v = 0.1``; initial ball radius 0.5
    (not in the paper). Class I with ``L = 0.25``. Unknown input: ``0.2 sin k`` (bounded).
    """
    def phi(x: Array) -> Array:
        return np.stack([np.zeros(x.shape[:-1]), -0.25 * np.tanh(x[..., 0])], axis=-1)

    system = DiscreteUISystem(
        np.array([[-0.42, 1.0], [-0.6, 0.0]]), np.array([[1.0], [0.65]]), np.array([[0.0, 1.0]]), phi=phi,
        function_class=Lipschitz(0.25, 2), eta_w=0.2, eta_v=0.1, x0=np.zeros(2), delta0=0.5, time=Discrete(1.0),
        name="nlobs variant of khajenejad-yong 6.2 (G = [1, 0.65], phi = -0.25 tanh x1)",
    )
    return PaperExample(system, {}, lambda t: (0.2 * np.sin(t))[:, None],
                        "nlobs's variant of Sec. 6.2 (G2 = +0.65, nonlinearity 0.25): NOT the paper's example")


def _d61_growing(t: Array) -> Array:
    return (50.0 * t**2 + 20.0 * np.exp(t))[:, None]


def _d62_growing(t: Array) -> Array:
    return (0.1 * t)[:, None]


# --------------------------------------------------------------------------- Figs. 2 and 3


def _state_panels(fig: object, batch: SimulationResult, others: Mapping[str, tuple[Array, Array | None]], run: int,
                  ball_label: str, title: str) -> None:
    """States and inputs of one run: truth, set-valued centre and ball, other estimates."""
    x, xh, rad = batch.x[run], batch.x_hat[run], radii_of(batch)
    d_all, dh_all = batch.extras["d"], input_estimates(batch)
    n, p = x.shape[1], d_all.shape[2]
    t = batch.t
    cols = ("C3", "C2", "C4", "C5")
    for i in range(n):
        ax = fig.add_subplot(n + p, 1, i + 1)  # type: ignore[attr-defined]
        if rad is not None:
            ax.fill_between(t, xh[:, i] - rad.state, xh[:, i] + rad.state, color="C0", alpha=0.12,
                            label=f"{ball_label}: x̂ᵢ ± δˣ")
        ax.plot(t, x[:, i], "k", lw=1.3, label=f"x{i + 1}")
        ax.plot(t, xh[:, i], "C0--", lw=1.0, label=f"{ball_label} estimate")
        series = [x[:, i], xh[:, i]]
        for (name, (xo, _)), c in zip(others.items(), cols):
            ax.plot(t, xo[run, :, i], color=c, lw=0.9, ls=":", label=name)
            series.append(xo[run, :, i])
        ax.set_ylim(*_limits(x[:, i], xh[:, i]))
        ax.legend(fontsize=6, loc="upper left", ncol=2)
        if i == 0:
            ax.set_title(title, fontsize=9)
    for j in range(p):
        ax = fig.add_subplot(n + p, 1, n + j + 1)  # type: ignore[attr-defined]
        dh = dh_all[run, :, j]
        if rad is not None:
            ax.fill_between(t[:-1], dh - rad.input, dh + rad.input, color="C1", alpha=0.12,
                            label=f"{ball_label}: d̂ ± δᵈ")
        ax.plot(t[:-1], d_all[run, :-1, j], "k", lw=1.3, label=f"d{j + 1}")
        ax.plot(t[:-1], dh, "C1--", lw=1.0, label=f"{ball_label} estimate of d")
        for (name, (_, do)), c in zip(others.items(), cols):
            if do is not None:
                ax.plot(t[:-1], do[run, :, j], color=c, lw=0.9, ls=":", label=name)
        ax.set_ylim(*_limits(d_all[run, :-1, j], dh))
        ax.legend(fontsize=6, loc="upper left", ncol=2)
        ax.set_xlabel("t [s]" if batch.t[1] != 1.0 else "step k")


def _limits(*series: Array) -> tuple[float, float]:
    lo = min(float(np.min(s)) for s in series)
    hi = max(float(np.max(s)) for s in series)
    pad = 0.5 * max(hi - lo, 1e-3)
    return lo - pad, hi + pad


def fig_61_states(out: str | Path, *, steps: int = 300, seed: int = 0) -> FigureResult:
    """Fig. 2 analogue: Example 6.1, one run, Class II (ball drawn) and nlobs's structured Class 0 estimates."""
    from matplotlib.figure import Figure

    ex = example_61("II")
    d2 = design_setvalued(ex.system)
    b = simulate_batch(ex.system, d2, ex.unknown_input, runs=1, steps=steps, seed=seed)
    ex0 = example_61("0-structured")
    d0 = design_setvalued(ex0.system)
    r0 = run_setvalued(ex0.system, d0, b.y)
    fig = Figure(figsize=(9.0, 11.0), layout="constrained")
    _state_panels(fig, b, {"Class 0 (nlobs's structured multiplier) estimate": (r0.x_hat, input_estimates(r0))}, 0,
                  "Class II (sound)", "Example 6.1 as printed: states, d, set-valued estimates and balls "
                  "(Class II, Lemma 2.14 γ); d = 5 sin 2t + 2·1[t ≥ 1] is nlobs's choice")
    path = save_figure(fig, Path(out))
    c = containment_of(b, system=ex.system, gain=d2)
    r0_radii = radii_of(r0)
    assert r0_radii is not None  # a design's run carries its sound radii
    return FigureResult(path, {"rate_state": c.rate_state, "rate_input": c.rate_input,
                               "final_radius_state_II": c.final_radius_state,
                               "final_radius_state_0_structured": float(r0_radii.state[-1])})


def fig_61_errors(out: str | Path, *, runs: int = 200, steps: int = 300, seed: int = 0) -> FigureResult:
    """Fig. 3 analogue: errors against the sound radii for Class II and nlobs's structured Class 0."""
    res: list[ContainmentResult] = []
    for cls, label in (("II", "Class II (Lemma 2.14 γ)"), ("0-structured", "Class 0, nlobs's structured M")):
        ex = example_61(cls)
        dsg = design_setvalued(ex.system)
        b = simulate_batch(ex.system, dsg, ex.unknown_input, runs=runs, steps=steps, seed=seed)
        res.append(containment_of(b, label, system=ex.system, gain=dsg))
    path = plot_errors_vs_radii(tuple(res), Path(out), title=f"Example 6.1: errors and sound radii, {runs} runs\n"
                                "(printed Class I / Class 0 multipliers: no certified design)",
                                dt=0.01, log=True)
    nums: dict[str, float] = {}
    for r, key in zip(res, ("II", "0s")):
        nums.update({f"rate_state_{key}": r.rate_state, f"rate_input_{key}": r.rate_input,
                     f"final_radius_{key}": r.final_radius_state,
                     f"max_error_over_radius_{key}": r.max_error_over_radius})
    return FigureResult(Path(path), nums)


# --------------------------------------------------------------------------- Figs. 4-7, Sec. 6.2 claim


@dataclass(frozen=True)
class UnboundedInputResult:
    """Set-valued observer vs point baselines, the same runs with a bounded and a growing ``d``.

    Attributes
    ----------
    label : str
    bounded, growing : MonteCarloStudy
    early, late : int
        Steps at which the growth of the errors is measured.
    paths : tuple of Path
        Figures written.
    """

    label: str
    bounded: MonteCarloStudy = field(repr=False)
    growing: MonteCarloStudy = field(repr=False)
    early: int
    late: int
    paths: tuple[Path, ...]

    def growth(self, which: str) -> tuple[float, float]:
        """``max_runs error[late] / max_runs error[early]`` for ``which`` in {"setvalued", "lipschitz", "ekf"},
        under (bounded, growing) ``d``."""
        out = []
        for st in (self.bounded, self.growing):
            e = {"setvalued": st.containment.errors, "lipschitz": st.baseline_lipschitz_errors,
                 "ekf": st.baseline_ekf_errors}[which]
            if e is None:
                out.append(math.nan)
            else:
                out.append(float(np.max(e[:, self.late]) / np.max(e[:, self.early])))
        return out[0], out[1]

    def first_step_above_radius(self, which: str, growing: bool = True) -> int | None:
        """First step at which some run's error of ``which`` ("lipschitz", "ekf", "setvalued") exceeds the
        set-valued radius ``δˣ_k`` (``None``: never)."""
        st = self.growing if growing else self.bounded
        e = {"setvalued": st.containment.errors, "lipschitz": st.baseline_lipschitz_errors,
             "ekf": st.baseline_ekf_errors}[which]
        if e is None:
            return None
        above = np.flatnonzero(np.any(e > st.containment.radii.state, axis=0))
        return int(above[0]) if above.size else None


def _boxplots(study: MonteCarloStudy, path: Path, title: str, marks: list[int]) -> Path:
    from matplotlib.figure import Figure

    res = study.containment
    fig = Figure(figsize=(10.0, 6.5), layout="constrained")
    ax, axd = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2)
    groups = [("set-valued", res.errors, "C0"), ("Lipschitz LMI", study.baseline_lipschitz_errors, "C3"),
              ("EKF, d as noise", study.baseline_ekf_errors, "C2")]
    groups = [g for g in groups if g[1] is not None]
    width = 0.8 / len(groups)
    for gi, (name, e, col) in enumerate(groups):
        pos = np.arange(len(marks)) + (gi - (len(groups) - 1) / 2) * width
        bp = ax.boxplot([np.maximum(e[:, k], 1e-12) for k in marks], positions=pos, widths=width * 0.9,
                        patch_artist=True, showfliers=True)
        for box in bp["boxes"]:
            box.set_facecolor(col)
            box.set_alpha(0.5)
        ax.plot([], [], color=col, lw=6, alpha=0.5, label=name)
    ax.plot(np.arange(len(marks)), [res.radii.state[k] for k in marks], "C0_", ms=18, mew=2.5,
            label="radius δˣ_k (set-valued)")
    ax.set_xticks(np.arange(len(marks)), [str(k) for k in marks])
    ax.set_yscale("log")
    ax.set_ylabel("‖x_k − x̂_k‖")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper left")
    b = study.batch
    de = np.linalg.norm(b.extras["d"][:, :-1] - input_estimates(b), axis=-1)
    dm = [max(k - 1, 0) for k in marks]
    axd.boxplot([np.maximum(de[:, k], 1e-12) for k in dm], positions=np.arange(len(marks)), widths=0.4)
    axd.plot(np.arange(len(marks)), [res.radii.input[k] for k in dm], "C1_", ms=18, mew=2.5,
             label="radius δᵈ_k (set-valued)")
    axd.set_xticks(np.arange(len(marks)), [str(k) for k in dm])
    axd.set_yscale("log")
    axd.set_xlabel("step k")
    axd.set_ylabel("‖d_k − d̂_k‖ (set-valued)")
    axd.legend(fontsize=7, loc="upper left")
    return save_figure(fig, path)


def fig_unbounded_input(out_dir: str | Path, *, example: str = "62-variant", runs: int = 50, steps: int = 100,
                        seed: int = 0, prefix: str = "setvalued") -> UnboundedInputResult:
    """Figs. 4-7 and the Sec. 6.2 claim on ``example`` ("62-variant" or "61"), bounded and growing ``d``.

    The same seeded initial states (``runs`` of them, drawn in the initial ball) and noises are used
    for both inputs and for all three observers. The point baselines are set up once
    (:func:`~nlobs.papers.khajenejad_yong.point_baselines`) with the EKF's ``Q_d`` the mean square of the
    *bounded* signal — the tuning a user has before the input grows. Growing inputs: ``d_k = 0.1 k``
    (6.2 variant, as in ``docs/baselines.md``) and ``50t² + 20eᵗ`` (6.1).
    """
    if example == "62-variant":
        ex, grow, tag = example_62_variant(), _d62_growing, "62v"
    elif example == "61":
        ex, grow, tag = example_61("II"), _d61_growing, "61"
    else:
        from nlobs.errors import InvalidArgumentError
        raise InvalidArgumentError(f"example: expected '62-variant' or '61', got {example!r}")
    s = ex.system
    design: SetValuedDesign = design_setvalued(s)
    t = np.arange(steps + 1) * s.time.dt
    pb = point_baselines(s, q_d=float(np.mean(ex.unknown_input(t) ** 2)), seed=seed)
    studies = {}
    for kind, dfun in (("bounded", ex.unknown_input), ("growing", grow)):
        studies[kind] = monte_carlo(s, design, dfun, runs=runs, steps=steps, seed=seed, baselines=pb, label=kind)
    out = Path(out_dir)
    paths = []
    marks = sorted({int(round(f * steps)) for f in (0.0, 0.1, 0.25, 0.5, 0.75, 1.0)})
    for kind, st in studies.items():
        from matplotlib.figure import Figure

        fig = Figure(figsize=(9.0, 7.5), layout="constrained")
        others = {}
        if st.baseline_lipschitz_x_hat is not None:
            others["Lipschitz LMI observer"] = (st.baseline_lipschitz_x_hat, None)
        if st.baseline_ekf_x_hat is not None:
            others["EKF (d as noise)"] = (st.baseline_ekf_x_hat, None)
        _state_panels(fig, st.batch, others, 0, "set-valued",
                      f"{s.name}: {kind} unknown input, run 0 of {runs}")
        paths.append(save_figure(fig, out / f"{prefix}_{tag}_{kind}_states.png"))
        paths.append(_boxplots(st, out / f"{prefix}_{tag}_{kind}_boxplots.png",
                               f"{s.name}: {kind} d, errors over {runs} random initial conditions "
                               f"(containment {st.containment.rate_state:.2f} / {st.containment.rate_input:.2f})",
                               marks))
    return UnboundedInputResult(s.name, studies["bounded"], studies["growing"], max(1, steps // 10), steps,
                                tuple(paths))


# --------------------------------------------------------------------------- affine abstraction


@dataclass(frozen=True)
class AffineOutputResult:
    """Algorithm 1 on a plant with a nonlinear observation function, through Prop. 2.18.

    Attributes
    ----------
    eta_abstraction : tuple of float
        Certified residual bound ``η`` per output on the box.
    eta_v_total : float
        ``η_v + ‖η‖₂``, the noise bound (7) the observer is designed with.
    rate_state, rate_input : float
        Containment over the runs.
    inside_box : float
        Fraction of runs whose state stayed in the abstraction's box at every step (the guarantee
        needs 1.0).
    final_radius_state : float
    path : Path
    """

    eta_abstraction: tuple[float, ...]
    eta_v_total: float
    rate_state: float
    rate_input: float
    inside_box: float
    final_radius_state: float
    path: Path


def _mu(x: Array) -> Array:
    return np.stack([np.sin(x[..., 0]) + 0.2 * x[..., 1], x[..., 1] + 0.05 * x[..., 1] ** 2], axis=-1)


def fig_affine_output(out: str | Path, *, runs: int = 200, steps: int = 150, seed: int = 0) -> AffineOutputResult:
    r"""A nonlinear observation ``y = μ(x) + v`` on the box ``[−1.5, 1.5]²``, abstracted (Prop. 2.18) and observed.

    Plant (nlobs's example, not in the paper): ``x⁺ = A x + φ(x) + G d + w`` with
    ``A = [[0.5, 0.2], [−0.1, 0.6]]``, ``φ = [0, 0.1 sin x₁]`` (Lipschitz 0.1), ``G = [0, 1]ᵀ``,
    ``d_k = 0.3 sin(0.2k)``, ``η_w = 0.05``, ``η_v = 0.02``, initial ball radius 0.3; output
    ``μ(x) = [sin x₁ + 0.2x₂, x₂ + 0.05x₂²]`` (gradient-Lipschitz constants 1 and 0.1). The LP (3) on a
    21-point grid gives ``μ(x) = C x + e + vᵃ``, ``|vᵃᵢ| ≤ ηᵢ`` on the box, so the observer sees
    ``y − e = C x + (v + vᵃ)`` with ``‖v + vᵃ‖ ≤ η_v + ‖η‖₂`` ((7)). The guarantee needs the state to stay in
    the box; the result reports whether it did.
    """
    from matplotlib.figure import Figure

    lo, hi = np.array([-1.5, -1.5]), np.array([1.5, 1.5])
    ab = affine_abstraction(_mu, lo, hi, gradient_lipschitz=[1.0, 0.1], points_per_axis=21, seed=seed)
    eta_v = 0.02
    s = DiscreteUISystem(
        np.array([[0.5, 0.2], [-0.1, 0.6]]), np.array([[0.0], [1.0]]), ab.A,
        phi=lambda x: np.stack([np.zeros(x.shape[:-1]), 0.1 * np.sin(x[..., 0])], axis=-1),
        function_class=Lipschitz(0.1, 2), eta_w=0.05, eta_v=ab.noise_bound(eta_v), x0=np.zeros(2), delta0=0.3,
        time=Discrete(1.0), name="nonlinear output through Prop. 2.18 (nlobs example)",
    )
    design = design_setvalued(s)
    rng = np.random.default_rng(seed)
    K = int(steps)
    x0 = s.x0 + ball_samples(rng, (runs,), s.delta0, 2)
    t = np.arange(K + 1, dtype=float)
    d = np.broadcast_to((0.3 * np.sin(0.2 * t))[None, :, None], (runs, K + 1, 1))
    w = ball_samples(rng, (runs, K), s.eta_w, 2)
    v = ball_samples(rng, (runs, K + 1), eta_v, 2)
    x, _ = s.simulate(x0, d, w, np.zeros((runs, K + 1, 2)))
    y = _mu(x) + v - ab.e  # the true nonlinear measurement, shifted by the abstraction's offset
    run = run_setvalued(s, design, y)
    inside = state_containment(run, x).all(axis=1)
    inside_d = input_containment(run, d[:, :-1]).all(axis=1)
    run_radii = radii_of(run)
    assert run_radii is not None
    in_box = np.all((x >= lo) & (x <= hi), axis=(1, 2))
    err = np.linalg.norm(x - run.x_hat, axis=-1)
    fig = Figure(figsize=(8.0, 6.0), layout="constrained")
    ax = fig.add_subplot(2, 1, 1)
    ax.fill_between(t, err.min(axis=0), err.max(axis=0), color="C0", alpha=0.25, label=f"error range, {runs} runs")
    ax.plot(t, run_radii.state, "C0--", lw=2, label="radius δˣ_k (η_v + ‖η‖ from Prop. 2.18)")
    ax.set_yscale("log")
    ax.set_ylabel("‖x_k − x̂_k‖")
    ax.set_title(f"{s.name}: η = {np.array2string(ab.residual_bound, precision=4)}, "
                 f"containment {inside.mean():.2f}, state in box {in_box.mean():.2f}", fontsize=9)
    ax.legend(fontsize=7)
    ax2 = fig.add_subplot(2, 1, 2)
    z = np.linspace(-1.5, 1.5, 200)
    grid = np.stack([z, 0.5 * z], axis=-1)
    ax2.plot(z, _mu(grid)[:, 0], "k", label="μ₁(x₁, x₂ = x₁/2)")
    ax2.plot(z, ab(grid)[:, 0], "C0--", label="C₁x + e₁")
    ax2.fill_between(z, ab(grid)[:, 0] - ab.residual_bound[0], ab(grid)[:, 0] + ab.residual_bound[0], color="C0",
                     alpha=0.15, label="± η₁ (certified on the box)")
    ax2.set_xlabel("x₁")
    ax2.legend(fontsize=7)
    path = save_figure(fig, Path(out))
    return AffineOutputResult(tuple(float(v) for v in ab.residual_bound), float(s.eta_v), float(inside.mean()),
                              float(inside_d.mean()), float(in_box.mean()), float(run_radii.state[-1]), path)


def make_figures(out_dir: str | Path) -> dict[str, object]:
    """Write every figure as ``setvalued_*.png`` into ``out_dir``; returns the results by name."""
    out = Path(out_dir)
    return {
        "fig2": fig_61_states(out / "setvalued_fig2_61_states.png"),
        "fig3": fig_61_errors(out / "setvalued_fig3_61_errors.png"),
        "figs4-7_62v": fig_unbounded_input(out, example="62-variant", runs=50, steps=300),
        "claim_61": fig_unbounded_input(out, example="61", runs=50, steps=300),
        "affine": fig_affine_output(out / "setvalued_affine_output.png"),
    }

