r"""``nlobs design cascade``: the cascade/feedback observer of Grip, Saberi & Johansen for a model file.

A model file with a ``[cascade]`` table (:mod:`nlobs.systems.cascade_file`) describes a nonlinear
subsystem Σ₁ (1a) (or Σ₁* (2)) whose output ``z`` is not measured, driving a linear Σ₂ (1b), and the
injection ``g`` of an observer for Σ₁ (3)/(16). This workflow

1. checks Assumption 4 item by item (:func:`nlobs.linear.assumption4.check_assumption4`); when a
   required item fails no gain exists (verdict ``NO_OBSERVER``);
2. designs ``K = [K_w; K_z]`` with LMI (14) (:func:`nlobs.synthesis.cascade_gain.design_cascade_gain`,
   ``‖H‖∞ < γ`` for ``H(s) = (sI − 𝔄 + Kℭ)⁻¹𝔅_d`` (13) of the extended system (8c)), or by pole
   placement (:func:`~nlobs.synthesis.cascade_gain.place_cascade_gain`) for the very small ``γ`` of
   Theorem 1;
3. re-verifies the gain independently of the design: the spectrum of ``𝔄 − Kℭ`` and ``‖H‖∞`` by
   :func:`nlobs.linear.hinf_norm` with the grid safeguard;
4. with ``[cascade.lyapunov]`` (``α₃, α₄, L₁, L₂`` of Assumptions 1–3) compares ``‖H‖∞`` with
   Theorem 1's ``γ = 4α₃/(4L₂² + α₄²L₁²)`` (best scaling of ``V``: ``α₃/(α₄L₁L₂)``), or Theorem 1'
   in the feedback case; without it the gain is only "H∞ gain verified", not certified by Theorem 1;
5. optionally simulates the plant (1) with the observer (9)–(10) / (17)–(18) and reports the error
   and the certificate monitor's coverage (:func:`nlobs.simulate.coverage.monitor`): a run is
   ``certified`` only when Theorem 1 holds for the gain *and* the monitor covers the run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nlobs._typing import Array
from nlobs._validate import positive
from nlobs.checks import Check, CheckKind
from nlobs.errors import DesignError, InvalidArgumentError
from nlobs.linear.assumption4 import Assumption4Report, check_assumption4, extended_system
from nlobs.linear.norms import hinf_norm
from nlobs.observers.cascade import CascadeObserver
from nlobs.simulate.coverage import Coverage, Premise, monitor
from nlobs.simulate.loop import simulate as run_simulation
from nlobs.simulate.result import SimulationResult
from nlobs.synthesis.cascade_bounds import (
    theorem1_gamma_bound,
    theorem1_optimal_scaling,
    theorem1_prime_gamma_bound,
)
from nlobs.synthesis.cascade_gain import design_cascade_gain, place_cascade_gain
from nlobs.synthesis.certificate import ObserverGainCertificate
from nlobs.systems.cascade_file import CascadeModel, load_cascade
from nlobs.systems.interconnected import interconnected_plant
from nlobs.workflows._results import checked_request, error_line, error_summary, run_study, write_result
from nlobs.workflows.inputs import SimulationRequest, model_label
from nlobs.workflows.verdict import Verdict

__all__ = [
    "DEFAULT_GAIN_BOUND",
    "DEFAULT_GAMMA",
    "METHODS",
    "CascadeDesign",
    "CascadeSimulation",
    "CascadeWorkflowReport",
    "Theorem1Check",
    "design_cascade",
    "design_cascade_observer",
]

#: The gain designs: LMI (14) (analytic centre with a gain bound) and pole placement scaled until ‖H‖∞ < γ.
METHODS: tuple[str, ...] = ("lmi", "placement")
#: ``γ`` of LMI (14) when none is given.
DEFAULT_GAMMA = 1.0
#: ``‖K‖`` bound of the central LMI design (``GainBound``) when none is given.
DEFAULT_GAIN_BOUND = 1e4


@dataclass(frozen=True)
class Theorem1Check:
    """Theorem 1 (cascade) or 1' (feedback) of Grip, Saberi & Johansen for a designed gain.

    Attributes
    ----------
    theorem : str
        ``"Theorem 1"`` or ``"Theorem 1'"``.
    bound : float or None
        The largest ``γ`` the theorem allows with the file's constants, the scaling of ``V``
        optimised (``None`` without ``[cascade.lyapunov]``).
    bound_as_given : float or None
        The same with the constants as given (no scaling).
    hinf_H : float
        ``‖H‖∞`` of the gain (re-verified).
    holds : bool
        ``𝔄 − Kℭ`` Hurwitz and ``‖H‖∞ < bound``: the error (12)/(20) is globally exponentially
        stable, given that the file's constants are true (they are not checked here).
    reason : str
        What holds, or what is missing.
    """

    theorem: str
    bound: float | None
    bound_as_given: float | None
    hinf_H: float
    holds: bool
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return {"theorem": self.theorem, "bound": self.bound, "bound_as_given": self.bound_as_given,
                "hinf_H": self.hinf_H, "holds": self.holds, "reason": self.reason}


@dataclass(frozen=True, eq=False)
class CascadeDesign:
    """The design part of ``nlobs design cascade``: Assumption 4, the gain, its re-verification, Theorem 1.

    Attributes
    ----------
    cascade : CascadeModel
    assumption4 : Assumption4Report
    method : {"lmi", "placement"}
    gamma : float
        The ``γ`` of ``‖H‖∞ < γ`` asked of the design.
    certificate : ObserverGainCertificate or None
        ``None`` when Assumption 4 fails or the design is infeasible (:attr:`failure` says why).
    checks : tuple of Check
        The independent re-verification: ``max Re λ(𝔄 − Kℭ) < 0`` and ``‖H‖∞ < γ``
        (:func:`nlobs.linear.hinf_norm` with ``grid=True``).
    theorem1 : Theorem1Check or None
    failure : str
        Empty, or why there is no gain.
    """

    cascade: CascadeModel
    assumption4: Assumption4Report
    method: str
    gamma: float
    certificate: ObserverGainCertificate | None
    checks: tuple[Check, ...]
    theorem1: Theorem1Check | None
    failure: str

    @property
    def verified(self) -> bool:
        """A gain exists, its certificate holds and the independent checks pass."""
        return self.certificate is not None and self.certificate.verified and all(c.passed for c in self.checks)

    @property
    def status(self) -> str:
        """``"certified (Theorem 1)"``, ``"H∞ gain verified"`` or ``"no gain"``."""
        if not self.verified:
            return "no gain"
        assert self.theorem1 is not None
        return f"certified ({self.theorem1.theorem})" if self.theorem1.holds else "H∞ gain verified"

    def observer(self) -> CascadeObserver:
        """The observer (9)–(10) / (17)–(18) with the certified gain."""
        if self.certificate is None:
            raise InvalidArgumentError(f"no gain: {self.failure}")
        return CascadeObserver.from_certificate(self.cascade.sigma1, self.cascade.sigma2, self.certificate)

    def summary(self) -> str:
        c = self.cascade
        form = "feedback Σ1* ⇄ Σ2 (2)" if c.feedback else "cascade Σ1 → Σ2 (1)"
        s1, s2 = c.sigma1, c.sigma2
        lines = [f"cascade observer (Grip–Saberi–Johansen) for {c.name}: {form}",
                 f"  Σ1: x = [{', '.join(s1.states)}], z = [{', '.join(s1.outputs)}] (not measured); "
                 f"Σ2: w = [{', '.join(s2.states)}], y = [{', '.join(s2.outputs)}]"]
        lines += ["  " + ln for ln in self.assumption4.summary().splitlines()]
        if self.certificate is None:
            lines.append(f"  no gain: {self.failure}")
            return "\n".join(lines)
        cert = self.certificate
        how = ("LMI (14), analytic centre with ‖K‖ ≤ gain bound" if self.method == "lmi"
               else f"pole placement ({cert.solver_status})")
        lines.append(f"  gain K = [K_w; K_z] by {how}, γ = {self.gamma:g}:")
        lines.append("    K = " + np.array2string(cert.gain, precision=5, separator=", ").replace("\n", "\n        "))
        lines += [f"    certificate: {ln}" for ln in cert.summary().splitlines()]
        lines += [f"    re-verified: [{'ok' if k.passed else 'FAILS'}] {k.name}: {k.evidence}" for k in self.checks]
        t1 = self.theorem1
        assert t1 is not None
        lines.append(f"  {t1.theorem}: {t1.reason}")
        lines.append(f"  status: {self.status}")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        c = self.cascade
        return {
            "model": c.name, "form": c.form,
            "sigma1": {"states": list(c.sigma1.states), "z": list(c.sigma1.outputs), "inputs": list(c.sigma1.inputs)},
            "sigma2": {"states": list(c.sigma2.states), "outputs": list(c.sigma2.outputs),
                       "A": c.sigma2.A.tolist(), "B_z": c.sigma2.B_z.tolist(), "C": c.sigma2.C.tolist(),
                       "D_z": c.sigma2.D_z.tolist()},
            "assumption4": self.assumption4.to_dict(),
            "method": self.method, "gamma": self.gamma,
            "certificate": None if self.certificate is None else self.certificate.to_dict(),
            "checks": [k.to_dict() for k in self.checks],
            "verified": self.verified,
            "theorem1": None if self.theorem1 is None else self.theorem1.to_dict(),
            "lyapunov": None if c.lyapunov is None else c.lyapunov.to_dict(),
            "status": self.status,
            "failure": self.failure,
        }


def _theorem1(cm: CascadeModel, hinf_H: float, hurwitz: bool) -> Theorem1Check:
    name = "Theorem 1'" if cm.feedback else "Theorem 1"
    ly = cm.lyapunov
    if ly is None:
        return Theorem1Check(name, None, None, hinf_H, False,
                             "not applicable: the file gives no [cascade.lyapunov] (alpha3, alpha4 of Assumption 1, "
                             "L1, L2 of Assumptions 2–3), so Theorem 1's γ is unknown; the gain is H∞-verified "
                             "(‖H‖∞ < γ asked), not certified by Theorem 1")
    if cm.feedback:
        bound = theorem1_prime_gamma_bound(ly.alpha3, ly.alpha4, ly.L1, ly.L2, optimise_scaling=True)
        as_given = theorem1_prime_gamma_bound(ly.alpha3, ly.alpha4, ly.L1, ly.L2, optimise_scaling=False)
    else:
        bound = theorem1_optimal_scaling(ly.alpha3, ly.alpha4, ly.L1, ly.L2)[1]
        as_given = theorem1_gamma_bound(ly.alpha3, ly.alpha4, ly.L1, ly.L2)
    holds = bool(hurwitz and hinf_H < bound)
    if holds:
        reason = (f"‖H‖∞ = {hinf_H:.4g} < γ = {bound:.4g} (best scaling of V; {as_given:.4g} as given) and 𝔄 − Kℭ "
                  "Hurwitz: the error is globally exponentially stable, given the file's constants")
    else:
        reason = (f"‖H‖∞ = {hinf_H:.4g} is not below γ = {bound:.4g} (best scaling of V; {as_given:.4g} as given): "
                  f"{name} does not cover this gain (it is sufficient and conservative); for a certified gain "
                  f"use --method placement --gamma {0.9 * bound:.3g}")
    return Theorem1Check(name, float(bound), float(as_given), hinf_H, holds, reason)


def design_cascade(cascade: CascadeModel, *, gamma: float | None = None, method: str | None = None,
                   gain_bound: float | None = None) -> CascadeDesign:
    """Assumption 4, the gain of LMI (14) (or pole placement), its re-verification and Theorem 1.

    Parameters
    ----------
    cascade : CascadeModel
        From :func:`nlobs.systems.cascade_file.load_cascade`.
    gamma : float, optional
        ``‖H‖∞ < γ`` (default: the file's ``[cascade].gamma``, else :data:`DEFAULT_GAMMA`).
    method : {"lmi", "placement"}, optional
        Default: the file's ``[cascade].method``, else ``"lmi"``.
    gain_bound : float, optional
        ``‖K‖`` bound of the central LMI design (default :data:`DEFAULT_GAIN_BOUND`).

    Returns
    -------
    CascadeDesign
        Also when Assumption 4 fails or the design is infeasible (then ``certificate`` is ``None``
        and ``failure`` names the assumption item or the LMI and the option to change).
    """
    method = method or cascade.method or "lmi"
    if method not in METHODS:
        raise InvalidArgumentError(f"method: expected 'lmi' or 'placement', got {method!r}")
    gamma = gamma if gamma is not None else cascade.gamma
    g = positive("--gamma", DEFAULT_GAMMA if gamma is None else gamma)
    gb = positive("--gain-bound", DEFAULT_GAIN_BOUND if gain_bound is None else gain_bound)
    s2 = cascade.sigma2
    a4 = check_assumption4(s2.A, s2.B_z, s2.C, s2.D_z)
    if not a4.holds:
        why = "; ".join(f"{it.name} [{it.key}]: {it.evidence}" for it in a4.failed)
        return CascadeDesign(cascade, a4, method, g, None, (), None,
                             f"Assumption 4 (Grip–Saberi–Johansen) fails: {why}; no gain K makes 𝔄 − Kℭ Hurwitz with "
                             "‖H‖∞ small (Theorem 2): change Σ2 or the measured outputs y")
    try:
        if method == "lmi":
            cert = design_cascade_gain(s2, gamma=g, gain_bound=gb)
        else:
            cert = place_cascade_gain(s2, gamma=g)
    except DesignError as exc:
        hint = ("raise --gamma or --gain-bound, or use --method placement for a small γ" if method == "lmi"
                else "raise --gamma, or use --method lmi")
        what = "LMI (14) (‖H‖∞ < γ)" if method == "lmi" else "pole placement (‖H‖∞ < γ)"
        return CascadeDesign(cascade, a4, method, g, None, (), None,
                             f"{what} has no solution for γ = {g:g}: {exc}; {hint}")
    ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
    F = ext.A - cert.gain @ ext.C
    abscissa = float(np.max(np.linalg.eigvals(F).real))
    hH = float(hinf_norm(F, ext.Bd, np.eye(F.shape[0]), np.zeros((F.shape[0], ext.Bd.shape[1])), grid=True)) \
        if abscissa < 0 else math.inf
    checks = (Check.compare("max Re λ(𝔄 − Kℭ) < 0", abscissa, 0.0, kind=CheckKind.SPECTRUM),
              Check.compare("‖H‖∞ < γ (13), grid safeguard", hH, g, kind=CheckKind.NORM))
    return CascadeDesign(cascade, a4, method, g, cert, checks, _theorem1(cascade, hH, abscissa < 0), "")


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
        constants, exact measurement (a ``--simulate`` run is noise-free).
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


@dataclass(frozen=True, eq=False)
class CascadeWorkflowReport:
    """What ``nlobs design cascade`` reports.

    Attributes
    ----------
    design : CascadeDesign
    simulation : CascadeSimulation or None
    request : SimulationRequest or None
    files : tuple of Path
        ``cascade.png`` and ``cascade.npz`` written to ``request.out``.
    verdict : Verdict
        ``OK`` with a verified gain; ``NO_OBSERVER`` when Assumption 4 fails (no gain can exist);
        ``FAILED`` when the design is infeasible for the options given.
    message : str
    """

    design: CascadeDesign
    simulation: CascadeSimulation | None
    request: SimulationRequest | None
    files: tuple[Path, ...]
    verdict: Verdict
    message: str

    def _simulation_dict(self) -> dict[str, Any]:
        sim = self.simulation
        assert sim is not None
        out = error_summary(sim.result, self.files)
        out.update(sim.to_dict())
        return out

    def to_dict(self) -> dict[str, Any]:
        """``{"design": …, "simulation": …}``: what ``nlobs design cascade --json`` prints.

        ``simulation`` (present only when one ran) has ``final_error_norm``, ``initial_error_norm``,
        ``max_error_norm``, ``files``, ``states``, ``final_error`` and ``rms_error_second_half`` (per
        state), ``certified`` (Theorem 1 holds for the gain *and* the monitor
        covers the run), and the monitor's ``certificate_covers_run``, ``certificate_covered_fraction``,
        ``certificate_violations``, ``certificate_failed_premises``, ``certificate_hypotheses``.
        """
        data: dict[str, Any] = {"design": self.design.to_dict()}
        if self.simulation is not None:
            data["simulation"] = self._simulation_dict()
        return data

    def summary(self) -> str:
        lines = [self.design.summary()]
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
    design = design_cascade(cm, gamma=gamma, method=method, gain_bound=gain_bound)
    if design.certificate is None:
        verdict = Verdict.NO_OBSERVER if not design.assumption4.holds else Verdict.FAILED
        return CascadeWorkflowReport(design, None, simulate, (), verdict, f"{label}: no gain: {design.failure}")
    if not design.verified:
        return CascadeWorkflowReport(design, None, simulate, (), Verdict.FAILED,
                                     f"{label}: the gain fails its re-verification: "
                                     + "; ".join(k.summary() for k in design.checks if not k.passed))
    if simulate is None:
        return CascadeWorkflowReport(design, None, None, (), Verdict.OK, "")
    assert resolved is not None
    x0, x_hat0, u = resolved
    sim = run_study(lambda: _simulate(design, simulate, x0, x_hat0, u))
    files = write_result(sim.result, simulate.out, "cascade")
    return CascadeWorkflowReport(design, sim, simulate, files, Verdict.OK, "")
