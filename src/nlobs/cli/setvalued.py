"""``nlobs design setvalued`` and ``nlobs simulate setvalued``: the set-valued observer of seed 004.

Both read a model file with unknown inputs (:func:`nlobs.systems.modelfile.load_discrete_ui_model`), run
the structural checks first (Lemma 5.1's rank, strong detectability of every linear member of the class,
Corollary 5.8 / Lemma 5.7) and exit with status 3 when no stable observer of the structure (10)-(15)
exists, printing the evidence. ``design`` prints the sampled check of the function class, the design
(:func:`nlobs.synthesis.setvalued.design_setvalued`) and its independent verification; ``simulate`` runs
Algorithm 1 in Monte Carlo (:func:`nlobs.papers.khajenejad_yong.monte_carlo`) with the point baselines
of ``docs/baselines.md`` on the same runs.
"""

from __future__ import annotations

import math
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer

from nlobs.cli.common import (
    EXIT_BAD_INPUT,
    EXIT_FAILURE,
    EXIT_NO_OBSERVER,
    console,
    design_app,
    emit_json,
    fail,
    shipped_models,
    simulate_app,
)
from nlobs.errors import AssumptionViolated, CertificateError, DesignInfeasible, ModelFileError, NlobsError
from nlobs.systems.modelfile import DiscreteUIModel, load_discrete_ui_model

if TYPE_CHECKING:  # the solver stack is imported when a command runs, so that `nlobs` starts fast
    from nlobs.linear.transform_ui import StructuralReport
    from nlobs.synthesis.setvalued import SetValuedDesign
    from nlobs.checks import Check


class Objective(str, Enum):
    radius = "radius"
    hinf = "hinf"


class UnknownInput(str, Enum):
    bounded = "bounded"
    growing = "growing"


def _load(model: str) -> DiscreteUIModel:
    try:
        return load_discrete_ui_model(model)
    except ModelFileError as exc:
        fail(str(exc))


def _structure(m: DiscreteUIModel) -> tuple[StructuralReport | None, str]:
    """The structural check, or ``None`` with the reason when Lemma 5.1's rank condition fails."""
    from nlobs.linear.transform_ui import structural_check

    s = m.system
    try:
        return structural_check(s.A, s.G, s.C, s.H, members=s.function_class.linear_members()), ""
    except AssumptionViolated as exc:
        return None, str(exc)


def _structure_dict(st: StructuralReport | None, why: str) -> dict[str, Any]:
    if st is None:
        return {"exists": False, "lemma_5_1_rank": False, "evidence": why}
    return {"exists": st.exists, "lemma_5_1_rank": True, **st.to_dict()}


def _box(m: DiscreteUIModel) -> tuple[np.ndarray, np.ndarray]:
    if m.box is not None:
        return m.box
    s = m.system
    half = max(10.0 * s.delta0, 1.0)
    return s.x0 - half, s.x0 + half


def _class_check(m: DiscreteUIModel, samples: int, seed: int) -> Check:
    from nlobs.systems.discrete_ui import check_function_class

    lo, hi = _box(m)
    return check_function_class(m.system.nonlinear, m.system.function_class, lo, hi, n_pairs=samples, seed=seed)


def _no_observer(model: str, data: dict[str, Any], as_json: bool) -> None:
    """Report that no stable observer of this structure exists and exit with status 3."""
    st = data["structure"]
    if as_json:
        emit_json(data)
    else:
        con = console()
        con.print(f"{model}: NO stable observer of the structure (10)-(15) exists", markup=False)
        con.print(st["evidence"], markup=False)
    fail(f"{model}: no stable observer of this structure exists (a linear member of the class is not strongly "
         "detectable, or Lemma 5.1's rank condition fails); evidence printed above", EXIT_NO_OBSERVER)


def _design(model: str, m: DiscreteUIModel, objective: str, samples: int, seed: int,
            as_json: bool) -> tuple[SetValuedDesign, dict[str, Any]]:
    """Structure, class check and design, shared by both commands (exits on failure)."""
    from nlobs.synthesis.setvalued import design_setvalued

    s = m.system
    st, why = _structure(m)
    chk = _class_check(m, samples, seed)
    lo, hi = _box(m)
    data: dict[str, Any] = {
        "model": s.name, "n": s.n, "p": s.p, "l": s.l, "function_class": s.function_class.label,
        "gamma": s.function_class.gamma, "eta_w": s.eta_w, "eta_v": s.eta_v, "delta0": s.delta0,
        "structure": _structure_dict(st, why),
        "class_check": {"holds": chk.passed, "worst_margin": chk.value, "x1": chk.values["x1"].tolist(),
                        "x2": chk.values["x2"].tolist(), "pairs": chk.values["n_pairs"], "box": [lo.tolist(), hi.tolist()],
                        "text": chk.evidence},
    }
    if st is None or not st.exists:
        _no_observer(model, data, as_json)
    if not chk.passed:
        fail(f"{model}: the nonlinear part violates its stated class, so no certificate would hold: {chk.evidence}")
    try:
        # the CLI runs the observer on the plant's own φ (no run-time LPV weights): a Class III file is designed
        # with the σ̃ Lipschitz multiplier, not at the vertices (docs/setvalued.md, "Soundness conditions")
        d = design_setvalued(s, objective=objective, lpv="lipschitz")
    except AssumptionViolated as exc:  # pragma: no cover - the structural check above catches these first
        data["structure"]["evidence"] = exc.evidence or str(exc)
        _no_observer(model, data, as_json)
    except DesignInfeasible as exc:
        fail(f"{model}: design infeasible: {exc}", EXIT_FAILURE)
    except CertificateError as exc:
        fail(f"{model}: the solver's answer failed the independent verification: {exc}", EXIT_FAILURE)
    except NlobsError as exc:
        fail(f"{model}: {exc}")
    data["design"] = d.to_dict()
    return d, data


def _print_head(data: dict[str, Any]) -> None:
    con = console()
    st = data["structure"]
    con.print(f"model {data['model']}: n = {data['n']}, unknown inputs p = {data['p']}, measurements l = "
              f"{data['l']}; {data['function_class']} (γ = {data['gamma']:.4g}); η_w = {data['eta_w']:g}, "
              f"η_v = {data['eta_v']:g}, δ0 = {data['delta0']:g}", markup=False)
    con.print("structural checks: Lemma 5.1 rank ok; stable observer of this structure exists: "
              f"{'yes' if st['exists'] else 'NO'}", markup=False)
    con.print("  " + st["evidence"].replace("\n", "\n  "), markup=False)
    con.print("function class (sampled): " + data["class_check"]["text"], markup=False)


@design_app.command("setvalued")
def design_setvalued_cmd(
    model: Annotated[str, typer.Argument(help="A model file with unknown inputs (.toml), or a shipped model name.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print a machine-readable JSON report.")] = False,
    objective: Annotated[Objective, typer.Option(help="radius: smallest steady radius bound; hinf: ℓ2 gain ρ.")]
    = Objective.radius,
    samples: Annotated[int, typer.Option(min=2, help="Sampled pairs for the function-class check.")] = 20_000,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the function-class sampling (>= 0).")] = 0,
) -> None:
    """Set-valued observer (seed 004): structural checks, the design and its independent verification."""
    m = _load(model)
    d, data = _design(model, m, objective.value, samples, seed, as_json)
    if as_json:
        emit_json(data)
        return
    _print_head(data)
    console().print(d.summary(), markup=False)


@simulate_app.command("setvalued")
def simulate_setvalued_cmd(
    model: Annotated[str, typer.Argument(help="A model file with unknown inputs (.toml), or a shipped model name.")],
    runs: Annotated[int, typer.Option(min=1, help="Monte Carlo runs.")] = 1000,
    steps: Annotated[int, typer.Option(min=1, help="Steps per run.")] = 200,
    unknown_input: Annotated[UnknownInput, typer.Option(
        "--unknown-input", help="The file's bounded or growing signal d(t) (defaults sin t and t²).")]
    = UnknownInput.bounded,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the initial states and noises (>= 0).")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print a machine-readable JSON report.")] = False,
    out: Annotated[Path | None, typer.Option(help="Folder for the figures.")] = None,
    objective: Annotated[Objective, typer.Option(help="Design objective (see design setvalued).")] = Objective.radius,
    baselines: Annotated[bool, typer.Option(help="Also run the Lipschitz LMI observer and the EKF.")] = True,
    samples: Annotated[int, typer.Option(min=2, help="Sampled pairs for the function-class check.")] = 20_000,
) -> None:
    """Run Algorithm 1 (seed 004) in Monte Carlo: containment rates, radii and the point baselines."""
    from nlobs.papers.khajenejad_yong import monte_carlo, plot_study, plot_trajectories

    m = _load(model)
    if runs * (steps + 1) * m.system.n > 5e8:
        fail(f"--runs {runs} x --steps {steps}: too large for one batch (runs·steps·n > 5e8)")
    d, data = _design(model, m, objective.value, samples, 0, as_json)
    s = m.system
    t = np.arange(steps + 1) * s.time.dt
    with np.errstate(over="ignore", invalid="ignore"):  # a non-finite Q_d is reported by the EKF's note
        q_d = float(np.mean(m.signals["bounded"](t) ** 2)) if s.p else 0.0
    try:
        # overflow in the runs is not silent: the plant's raises SimulationDiverged, the observer's and the
        # round-off it causes are measured (ContainmentResult.roundoff_runs) and reported below
        with np.errstate(over="ignore", invalid="ignore"):
            study = monte_carlo(s, d, m.signals[unknown_input.value], runs=runs, steps=steps, seed=seed,
                                baselines=baselines, q_d=q_d, box=_box(m))
    except NlobsError as exc:
        fail(f"{model}: {exc}", EXIT_FAILURE)
    res = study.containment
    causes = res.likely_causes()
    held = res.guarantee_held
    warnings = []
    if res.class_violated_in_runs:
        warnings.append(f"the function class is violated along the trajectories in {res.class_violated_in_runs} "
                        f"of {runs} runs (worst QC − γ = {res.class_worst_margin:.4g}): the certificate does not "
                        "apply to these runs")
    if res.left_box_runs:
        warnings.append(f"the state or its estimate left the box where the class was checked ({_box(m)[0].tolist()} "
                        f"to {_box(m)[1].tolist()}) in {res.left_box_runs} of {runs} runs; on the visited pairs the "
                        "class condition " + ("is VIOLATED" if res.class_violated_in_runs else "holds"))
    if res.roundoff_runs:
        warnings.append(f"floating-point round-off reaches {res.roundoff_ratio:.3g} × the radius in "
                        f"{res.roundoff_runs} of {runs} runs (|d| = {res.max_abs_input:.4g}): containment may be "
                        "lost to round-off (docs/setvalued.md, 'Soundness conditions')")
    out_data = {
        "model": s.name, "runs": runs, "steps": steps, "seed": seed, "unknown_input": unknown_input.value,
        "objective": d.objective.value,
        "rho": d.rho,
        "rho_meaning": ("ℓ2 gain bound ρ of Definition 5.9 (hinf design)" if d.rho is not None else
                        "null: the radius design certifies no ℓ2 gain (use --objective hinf, needs γ ≥ 0)"),
        "contraction_factor": math.sqrt(d.lam_eff),
        "containment_rate_state": res.rate_state, "containment_rate_input": res.rate_input,
        "first_violation_step": res.first_violation_step,
        "final_radius_state": res.final_radius_state, "final_radius_input": res.final_radius_input,
        "steady_radius_state": d.steady_radius,
        "max_error_over_radius": res.max_error_over_radius,
        "max_error_over_radius_after_step_0": (float(np.max(res.errors[:, 1:] / res.radii.state[1:]))
                                               if steps >= 1 else None),
        "final_error_state": study.final_error_state,
        "baseline_lipschitz_final_error": study.baseline_lipschitz_final_error,
        "baseline_ekf_final_error": study.baseline_ekf_final_error,
        "baseline_lipschitz_note": study.baselines.lipschitz_note if study.baselines else None,
        "baseline_ekf_note": study.baselines.ekf_note if study.baselines else None,
        "baseline_ekf_failure": study.baseline_ekf_failure,
        "guarantee_held": held,
        "likely_causes": causes if not held else [],
        "class_violated_in_runs": res.class_violated_in_runs,
        "class_worst_margin_in_runs": res.class_worst_margin,
        "left_box_runs": res.left_box_runs,
        "roundoff_runs": res.roundoff_runs,
        "roundoff_over_radius": res.roundoff_ratio,
        "max_abs_unknown_input": res.max_abs_input,
        "warnings": warnings,
        "seconds": res.seconds, "design": data["design"], "structure": data["structure"],
        "class_check": data["class_check"],
    }
    violated = ("GUARANTEE VIOLATED: the certified balls did not contain the truth in every run (state "
                f"{res.rate_state:.4f}, input {res.rate_input:.4f}); likely cause: "
                + ("; ".join(causes) if causes else "none found (class held on the visited pairs, states stayed in "
                   "the box, no round-off flagged): please report it"))
    figures: list[str] = []
    if out is not None:
        try:
            figures.append(str(plot_study(study, out / f"{s.name}-{unknown_input.value}-errors.png",
                                          title=f"{s.name}, {unknown_input.value} d, {runs} runs", dt=s.time.dt)))
            figures.append(str(plot_trajectories(study.batch, out / f"{s.name}-{unknown_input.value}-run0.png",
                                                 title=f"{s.name}, {unknown_input.value} d, run 0")))
        except OSError as exc:
            fail(f"--out {out}: {exc}", EXIT_BAD_INPUT)
    out_data["figures"] = figures
    if as_json:
        emit_json(out_data)
        if not held:
            fail(f"{model}: {violated}", EXIT_FAILURE)
        return
    _print_head(data)
    con = console()
    con.print(d.summary(), markup=False)

    def num(v: float | None) -> str:
        return "n/a" if v is None else f"{v:.4g}"

    con.print(f"Monte Carlo: {runs} runs x {steps} steps, {unknown_input.value} unknown input, seed {seed} "
              f"({res.seconds:.2f} s)", markup=False)
    con.print(f"  containment (truth inside the ball at every step): state {res.rate_state:.4f}, "
              f"input {res.rate_input:.4f}", markup=False)
    con.print(f"  final radius: state {res.final_radius_state:.4g}, input {res.final_radius_input:.4g}; "
              f"max error/radius {res.max_error_over_radius:.4g} (after step 0: "
              f"{float(np.max(res.errors[:, 1:] / res.radii.state[1:])):.4g}); max final error "
              f"{study.final_error_state:.4g}",
              markup=False)
    con.print(f"  baselines, max final error: Lipschitz LMI observer {num(study.baseline_lipschitz_final_error)}, "
              f"EKF (d as noise) {num(study.baseline_ekf_final_error)}", markup=False)
    if study.baselines is not None:
        con.print(f"    Lipschitz: {study.baselines.lipschitz_note}; EKF: "
                  f"{study.baseline_ekf_failure or study.baselines.ekf_note}", markup=False)
    for f in figures:
        con.print(f"wrote {f}", markup=False)
    for w in warnings:
        con.print(f"warning: {w}", markup=False)
    if not held:
        con.print(violated, markup=False)
        fail(f"{model}: GUARANTEE VIOLATED (containment state {res.rate_state:.4f}, input {res.rate_input:.4f})",
             EXIT_FAILURE)
