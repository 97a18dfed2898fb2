r"""``nlobs design cascade``: the cascade/feedback observer of Grip, Saberi & Johansen for a model file, simulated.

The design — Assumption 4 item by item, the gain of LMI (14), pole placement or the smallest
noise-to-error H2 norm, its re-verification, Theorem 1 with the file's ``[cascade.lyapunov]`` — is
:func:`nlobs.methods.cascade.design_cascade` (the method every command uses). This command adds the
verdict (``NO_OBSERVER`` when Assumption 4 fails, ``FAILED`` when the design is infeasible), the
``design`` object of :func:`nlobs.methods.cascade.cascade_design`, and optionally a simulation of the
plant (1) with the observer (9)–(10) / (17)–(18), with the error and the certificate monitor's coverage
(:func:`nlobs.simulate.coverage.monitor`): a run is ``certified`` only when Theorem 1 holds for the gain
*and* the monitor covers the run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nlobs._typing import Array
from nlobs.errors import InvalidArgumentError
from nlobs.simulate.coverage import COVERAGE_JSON, Coverage, Premise, monitor
from nlobs.simulate.loop import simulate as run_simulation
from nlobs.simulate.result import SimulationResult
from nlobs.synthesis.mixed_h2 import NoiseModel
from nlobs.systems.cascade_file import CascadeModel, load_cascade
from nlobs.systems.interconnected import interconnected_plant
from nlobs._schema import BOOLEAN, NUMBER, STRING, Record, array
from nlobs.methods.base import Design, joined_design_json
from nlobs.methods.cascade import (
    DEFAULT_GAIN_BOUND,
    DEFAULT_GAMMA,
    METHODS,
    CASCADE_DESIGN_JSON,
    CascadeDesign,
    Theorem1Check,
    cascade_design,
    cascade_noise_model,
    default_gain_method,
    design_cascade,
    gain_for_sensors,
)
from nlobs.workflows._results import (
    ERROR_SUMMARY_JSON,
    checked_request,
    error_line,
    error_summary,
    run_study,
    write_result,
)
from nlobs.workflows.inputs import SimulationRequest, model_label, model_units
from nlobs.workflows.verdict import Verdict

__all__ = [
    "DEFAULT_GAIN_BOUND",
    "DEFAULT_GAMMA",
    "METHODS",
    "CascadeDesign",
    "CascadeSimulation",
    "CascadeWorkflowReport",
    "Theorem1Check",
    "cascade_noise_model",
    "design_cascade",
    "design_cascade_observer",
]

# --------------------------------------------------------------------------- simulate


@dataclass(frozen=True, eq=False)
class CascadeSimulation:
    """The plant (1) (or (2)+(1b)) simulated with the observer (9)–(10) (or (17)–(18)).

    Attributes
    ----------
    result : SimulationResult
        State ``[x, w]`` and estimate ``[x̂, ŵ]``.
    coverage : Coverage
        The hypotheses of Theorem 1 checked along the run: the gain satisfies it with the file's
        constants, exact measurement (a ``simulate`` run is noise-free).
    certified : bool
        Theorem 1 holds for the gain *and* the coverage covers the run.
    """

    result: SimulationResult
    coverage: Coverage
    certified: bool

    def to_dict(self) -> dict[str, Any]:
        res = self.result
        e = res.error
        half = e[e.shape[0] // 2:]
        return {"states": list(res.states), "final_error": [float(v) for v in e[-1]],
                "rms_error_second_half": [float(v) for v in np.sqrt(np.mean(half**2, axis=0))],
                "certified": self.certified, **self.coverage.to_dict()}


def _simulate(design: CascadeDesign, request: SimulationRequest, x0: Array, x_hat0: Array, u: Array
              ) -> CascadeSimulation:
    cm = design.cascade
    obs = design.observer()
    plant = interconnected_plant(cm.sigma1, cm.sigma2)
    res = run_simulation(plant, obs, x0=x0, x_hat0=x_hat0, duration=request.duration, dt=request.dt,
                         u=u if cm.sigma1.m else None)
    t1 = design.theorem1
    assert t1 is not None
    short = ("no [cascade.lyapunov] constants" if t1.bound is None
             else f"‖H‖∞ = {t1.hinf_H:.4g} ≥ γ = {t1.bound:.4g}")
    hyps = [Premise(f"{t1.theorem}: ‖H‖∞ below its γ", t1.holds, short),
            Premise("Assumptions 1–3 hold with the file's constants", cm.lyapunov is not None,
                    "no [cascade.lyapunov] in the file")]
    cov = monitor(res, hyps, u=np.asarray(u, dtype=float) if cm.sigma1.m else None, verified=design.verified)
    return CascadeSimulation(res, cov, bool(t1.holds and cov.covers_run))


# --------------------------------------------------------------------------- the command


#: ``design`` of ``nlobs design cascade``.
CASCADE_COMMAND_DESIGN_JSON = joined_design_json("CascadeCommandDesign", CASCADE_DESIGN_JSON)
#: ``simulation`` of ``nlobs design cascade`` with a simulation.
CASCADE_SIMULATION_JSON = ERROR_SUMMARY_JSON.extend("CascadeSimulation", {
    "states": array(STRING),
    "final_error": array(NUMBER),
    "rms_error_second_half": array(NUMBER),
    "certified": BOOLEAN.about("Theorem 1 holds for the gain and the monitor covers the run"),
    **COVERAGE_JSON.fields,
})
#: ``nlobs design cascade``.
DESIGN_CASCADE_JSON = Record("DesignCascade", {
    "design": CASCADE_COMMAND_DESIGN_JSON,
    "simulation": CASCADE_SIMULATION_JSON,
}, optional={"simulation"}, description="The cascade/feedback observer of Grip, Saberi & Johansen, designed and "
                                        "verified (and simulated, when asked).")


@dataclass(frozen=True, eq=False)
class CascadeWorkflowReport:
    """What ``nlobs design cascade`` reports.

    Attributes
    ----------
    design : CascadeDesign
    simulation : CascadeSimulation or None
    request : SimulationRequest or None
    files : tuple of Path
        ``cascade.png``, ``cascade.npz`` and ``bode.png`` (the error dynamics' frequency response) written to
        ``request.out``.
    verdict : Verdict
        ``OK`` with a verified gain; ``NO_OBSERVER`` when Assumption 4 fails (no gain can exist);
        ``FAILED`` when the design is infeasible for the options given.
    message : str
    method_design : Design or None
        The method's :class:`~nlobs.methods.base.Design` (its keys join ``design`` in :meth:`to_dict`, the
        report's own ``method`` — the gain method — and ``status`` kept).
    """

    design: CascadeDesign
    simulation: CascadeSimulation | None
    request: SimulationRequest | None
    files: tuple[Path, ...]
    verdict: Verdict
    message: str
    method_design: Design | None = None

    def _simulation_dict(self) -> dict[str, Any]:
        sim = self.simulation
        assert sim is not None
        out = error_summary(sim.result, self.files)
        out.update(sim.to_dict())
        return out


    def to_dict(self) -> dict[str, Any]:
        """``{"design": …, "simulation": …}``: the JSON report of ``nlobs design cascade``.

        ``simulation`` (present only when one ran) has ``final_error_norm``, ``initial_error_norm``,
        ``max_error_norm``, ``files``, ``states``, ``final_error`` and ``rms_error_second_half`` (per
        state), ``certified`` (Theorem 1 holds for the gain *and* the monitor
        covers the run), and the monitor's ``certificate_covers_run``, ``certificate_covered_fraction``,
        ``certificate_violations``, ``certificate_failed_premises``, ``certificate_hypotheses``.
        """
        unified = {} if self.method_design is None else self.method_design.to_dict()
        data: dict[str, Any] = {"design": CASCADE_COMMAND_DESIGN_JSON.emit(
            {**unified, **self.design.to_dict()})}  # the report's own keys first
        if self.simulation is not None:
            data["simulation"] = CASCADE_SIMULATION_JSON.emit(self._simulation_dict())
        return DESIGN_CASCADE_JSON.emit(data)

    def summary(self) -> str:
        lines = [self.design.summary()]
        if self.method_design is not None:
            md = self.method_design
            lines.append(f"  from the model file: {md.defaults_text() or 'nothing (every value given)'}; "
                         f"{md.status}")
            if md.bound is not None:
                p = md.parameters
                lines.append(f"  under the file's sensors ({p.get('sampling')}): certified on the region, "
                             f"RMS ≤ {p.get('rms_bound', math.nan):.4g} after the settling time; " + "; ".join(
                                 f"{g.name}: T = {g.gap:.4g} ≤ T_max = {t:.4g}"
                                 for g, t in zip(md.bound.groups, md.bound.t_max)))
            else:
                why = next((d for d in md.details if d.startswith("no certificate under the sensors")), None)
                if why:
                    lines.append(f"  {why}")
        sim, req = self.simulation, self.request
        if sim is not None and req is not None:
            d = self._simulation_dict()
            lines.append(error_line(d, req.duration, req.dt))
            names = sim.result.states
            lines.append("  final error per state: " + ", ".join(f"{s} {v:.4g}" for s, v in zip(names,
                                                                                           d["final_error"])))
            lines.append("  RMS error over the second half: " + ", ".join(
                f"{s} {v:.4g}" for s, v in zip(names, d["rms_error_second_half"])))
            lines.append("  certified run: " + ("yes" if sim.certified else
                                                "no (" + "; ".join(sim.coverage.reasons) + ")"))
            lines += [f"wrote {f}" for f in self.files]
        return "\n".join(lines)


def design_cascade_observer(
    model: str | Path | CascadeModel,
    *,
    gamma: float | None = None,
    method: str | None = None,
    gain_bound: float | None = None,
    simulate: SimulationRequest | None = None,
    name: str | None = None,
    noise: NoiseModel | None = None,
) -> CascadeWorkflowReport:
    """Check Assumption 4, design and re-verify the gain, Theorem 1, and simulate: ``nlobs design cascade``.

    Parameters
    ----------
    model : str, Path or CascadeModel
        A model file with a ``[cascade]`` table, or a shipped model name.
    gamma, method, gain_bound
        As in :func:`design_cascade`.
    simulate : SimulationRequest, optional
        Simulate plant + observer from ``[x0, w0]`` and ``[x̂0, ŵ0]`` (``ξ0 = 0``) with a constant
        input; only when a gain exists.
    name : str, optional
        How the message names the model.
    noise : NoiseModel, optional
        For ``method="h2"``: the noise of the extended system (8c); default: the file's
        (:func:`cascade_noise_model`).

    Returns
    -------
    CascadeWorkflowReport

    Raises
    ------
    ModelFileError
        The file cannot be read, has no ``[cascade]`` table or an invalid entry.
    InvalidArgumentError, DimensionError, NonFiniteError
        A bad option.
    OutputError
        ``simulate.out`` cannot be written.
    SimulationDiverged, StudyFailed
        The simulation diverged or stopped.
    """
    cm = model if isinstance(model, CascadeModel) else load_cascade(model)
    label = (model_label(model) if not isinstance(model, CascadeModel) else cm.name) if name is None else str(name)
    resolved = checked_request(simulate, cm.plant)
    notes: tuple[str, ...] = ()
    scenario = None
    if cm.path:  # the file's sensors choose the default gain and give the certificate under them
        from nlobs.errors import ModelFileError
        from nlobs.systems.modelfile import load_scenario

        try:
            scenario = load_scenario(cm.path)
        except ModelFileError:  # a cascade parsed from text: no file to read sensors from
            scenario = None
    pb = None
    if scenario is not None and scenario.sensors:  # the certificate under the file's sensors, as every command's
        from nlobs.methods.problem import problem

        pb = problem(scenario)
    chosen = None
    if method is None and cm.method is None and pb is not None and noise is None:  # the rule of every command
        chosen = gain_for_sensors(cm, pb, gamma=gamma, gain_bound=gain_bound)
    kind = method or default_gain_method(cm, bool(scenario is not None and scenario.sensors))
    if chosen is not None:
        design = chosen[0]
    else:
        if kind == "h2" and noise is None:
            if scenario is None:
                raise InvalidArgumentError("`method` 'h2': give the `noise` model (the cascade was not read from a "
                                           "file)")
            noise, notes = cascade_noise_model(cm, scenario)
        design = design_cascade(cm, gamma=gamma, method=kind, gain_bound=gain_bound, noise=noise, noise_notes=notes)
    if design.certificate is None:
        verdict = Verdict.NO_OBSERVER if not design.assumption4.holds else Verdict.FAILED
        return CascadeWorkflowReport(design, None, simulate, (), verdict, f"{label}: no gain: {design.failure}")
    if not design.verified:
        return CascadeWorkflowReport(design, None, simulate, (), Verdict.FAILED,
                                     f"{label}: the gain fails its re-verification: "
                                     + "; ".join(k.summary() for k in design.checks if not k.passed))
    unified = cascade_design(design, pb, gamma_given=gamma is not None, gain_method_given=method is not None,
                             chosen=None if chosen is None else chosen[1])
    if simulate is None:
        return CascadeWorkflowReport(design, None, None, (), Verdict.OK, "", unified)
    assert resolved is not None
    x0, x_hat0, u = resolved
    sim = run_study(lambda: _simulate(design, simulate, x0, x_hat0, u))
    files = write_result(sim.result, simulate.out, "cascade", model_units(cm.path) if cm.path else None)
    if simulate.out is not None:
        unit = (model_units(cm.path) if cm.path else {}).get("t", "s")
        files = (*files, _bode(design, simulate.out / "bode.png", label, unit))
    return CascadeWorkflowReport(design, sim, simulate, files, Verdict.OK, "", unified)


def _bode(design: CascadeDesign, path: Path, label: str, time_unit: str) -> Path:
    """``bode.png``: ``‖H(jω)‖`` (13) with γ and ``‖G(jω)‖`` (noise on every output, ``N = I``) with γn where the
    gain was designed with one (:func:`nlobs.linear.frequency.bode_figure`)."""
    from nlobs.errors import OutputError
    from nlobs.linear.assumption4 import extended_system
    from nlobs.linear.frequency import bode_figure

    s2 = design.cascade.sigma2
    ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
    cert = design.certificate
    assert cert is not None
    K = np.asarray(cert.gain, dtype=float)
    gamma_n = getattr(cert, "gamma_n", None)
    try:
        bode_figure(ext.A - K @ ext.C, ext.Bd, gamma=design.gamma, KN=K, gamma_n=gamma_n, time_unit=time_unit,
                    title=f"{label}: error dynamics of Σ2's observer (gain: {design.method})", path=path)
    except OSError as exc:
        raise OutputError(f"{path}: {exc.strerror or exc}") from exc
    return path
