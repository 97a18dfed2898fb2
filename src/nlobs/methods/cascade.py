r"""The cascade/feedback observer of Grip, Saberi & Johansen as a method: the design and its :class:`Method`.

A model file with a ``[cascade]`` table (:mod:`nlobs.systems.cascade_file`) describes a nonlinear
subsystem Σ₁ (1a) (or Σ₁* (2)) whose output ``z`` is not measured, driving a linear Σ₂ (1b), and the
injection ``g`` of an observer for Σ₁ (3)/(16). :func:`design_cascade`

1. checks Assumption 4 item by item (:func:`nlobs.linear.assumption4.check_assumption4`); when a
   required item fails no gain exists;
2. designs ``K = [K_w; K_z]`` with LMI (14) (:func:`nlobs.synthesis.cascade_gain.design_cascade_gain`,
   ``‖H‖∞ < γ`` for ``H(s) = (sI − 𝔄 + Kℭ)⁻¹𝔅_d`` (13) of the extended system (8c)), or by pole
   placement (:func:`~nlobs.synthesis.cascade_gain.place_cascade_gain`) for the very small ``γ`` of
   Theorem 1, or (``method="h2"``) as the gain with the smallest noise-to-error H2 norm under LMI (14)
   (:func:`nlobs.synthesis.mixed_h2.design_h2_gain`) for the noise the file declares
   (:func:`cascade_noise_model`: its ``[sensors.NAME]`` tables and ``[process_noise]``);
3. re-verifies the gain independently of the design: the spectrum of ``𝔄 − Kℭ`` and ``‖H‖∞`` by
   :func:`nlobs.linear.hinf_norm` with the grid safeguard;
4. with ``[cascade.lyapunov]`` (``α₃, α₄, L₁, L₂`` of Assumptions 1–3) compares ``‖H‖∞`` with
   Theorem 1's ``γ = 4α₃/(4L₂² + α₄²L₁²)`` (best scaling of ``V``: ``α₃/(α₄L₁L₂)``), or Theorem 1'
   in the feedback case; without it the gain is only "H∞ gain verified", not certified by Theorem 1.

:data:`CASCADE` is the method of the registry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from nlobs._schema import BOOLEAN, MATRIX, NUMBER, OBJECT, STRING, Record, array, nullable
from nlobs._validate import positive
from nlobs.checks import CHECK_JSON, Check, CheckKind
from nlobs.errors import AssumptionViolated, DesignError, DesignInfeasible, InvalidArgumentError, NlobsError
from nlobs.linear.assumption4 import Assumption4Report, check_assumption4, extended_system
from nlobs.linear.norms import hinf_norm
from nlobs.methods.base import Design
from nlobs.methods.problem import Problem
from nlobs.methods.sensor_design import on_samples, sampling_form
from nlobs.observers.cascade import CascadeObserver
from nlobs.simulate.coverage import Premise
from nlobs.synthesis.cascade_bounds import (
    theorem1_gamma_bound,
    theorem1_optimal_scaling,
    theorem1_prime_gamma_bound,
)
from nlobs.synthesis.cascade_gain import design_cascade_gain, place_cascade_gain
from nlobs.synthesis.certificate import ObserverGainCertificate
from nlobs.synthesis.mixed_h2 import MixedH2Certificate, NoiseModel, design_h2_gain, sampled_intensity
from nlobs.systems.cascade_file import CascadeModel
from nlobs.systems.scenario import Scenario

__all__ = [
    "CASCADE",
    "DEFAULT_GAIN_BOUND",
    "DEFAULT_GAMMA",
    "METHODS",
    "CascadeDesign",
    "CascadeMethod",
    "Theorem1Check",
    "SENSOR_METHODS",
    "default_gain_method",
    "gain_for_sensors",
    "cascade_design",
    "cascade_noise_model",
    "design_cascade",
]

#: The gain designs: LMI (14) (analytic centre with a gain bound), pole placement scaled until ‖H‖∞ < γ, and
#: the smallest noise-to-error H2 norm under LMI (14) for the file's declared noise.
METHODS: tuple[str, ...] = ("lmi", "placement", "h2")
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
    method : {"lmi", "placement", "h2"}
    gamma : float
        The ``γ`` of ``‖H‖∞ < γ`` asked of the design.
    certificate : ObserverGainCertificate or MixedH2Certificate or None
        ``None`` when Assumption 4 fails or the design is infeasible (:attr:`failure` says why);
        a :class:`~nlobs.synthesis.mixed_h2.MixedH2Certificate` for ``method="h2"``.
    checks : tuple of Check
        The independent re-verification: ``max Re λ(𝔄 − Kℭ) < 0`` and ``‖H‖∞ < γ``
        (:func:`nlobs.linear.hinf_norm` with ``grid=True``).
    theorem1 : Theorem1Check or None
    failure : str
        Empty, or why there is no gain.
    noise_notes : tuple of str
        How the noise model of ``method="h2"`` was obtained (empty otherwise).
    """

    cascade: CascadeModel
    assumption4: Assumption4Report
    method: str
    gamma: float
    certificate: ObserverGainCertificate | MixedH2Certificate | None
    checks: tuple[Check, ...]
    theorem1: Theorem1Check | None
    failure: str
    noise_notes: tuple[str, ...] = ()

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
        how = {"lmi": "LMI (14), analytic centre with ‖K‖ ≤ gain bound",
               "h2": "the smallest noise-to-error H2 norm under LMI (14)"}.get(self.method,
                                                                              f"pole placement ({cert.solver_status})")
        lines.append(f"  gain K = [K_w; K_z] by {how}, γ = {self.gamma:g}:")
        lines.append("    K = " + np.array2string(cert.gain, precision=5, separator=", ").replace("\n", "\n        "))
        lines += [f"    noise model: {ln}" for ln in self.noise_notes]
        lines += [f"    certificate: {ln}" for ln in cert.summary().splitlines()]
        lines += [f"    re-verified: [{'ok' if k.passed else 'FAILS'}] {k.name}: {k.evidence}" for k in self.checks]
        t1 = self.theorem1
        assert t1 is not None
        lines.append(f"  {t1.theorem}: {t1.reason}")
        lines.append(f"  status: {self.status}")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        c = self.cascade
        return CASCADE_DESIGN_JSON.emit({
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
            "noise_notes": list(self.noise_notes),
            "lyapunov": None if c.lyapunov is None else c.lyapunov.to_dict(),
            "status": self.status,
            "failure": self.failure,
        })


#: The JSON of a :class:`CascadeDesign` (joined to the method's ``design`` object by ``nlobs design cascade``).
CASCADE_DESIGN_JSON = Record("CascadeDesign", {
    "model": STRING,
    "form": STRING.about("cascade or feedback"),
    "sigma1": Record("CascadeSigma1", {"states": array(STRING), "z": array(STRING), "inputs": array(STRING)}),
    "sigma2": Record("CascadeSigma2", {"states": array(STRING), "outputs": array(STRING), "A": MATRIX,
                                       "B_z": MATRIX, "C": MATRIX, "D_z": MATRIX}),
    "assumption4": OBJECT.about("Assumption 4 of Grip, Saberi & Johansen, item by item"),
    "method": STRING.about("the gain method: lmi, placement or h2"),
    "gamma": NUMBER,
    "certificate": nullable(OBJECT, "the gain's certificate, re-verified"),
    "checks": array(CHECK_JSON),
    "verified": BOOLEAN,
    "theorem1": nullable(Record("Theorem1", {
        "theorem": STRING, "bound": NUMBER, "bound_as_given": NUMBER, "hinf_H": NUMBER, "holds": BOOLEAN,
        "reason": STRING})),
    "noise_notes": array(STRING),
    "lyapunov": nullable(OBJECT, "the file's [cascade.lyapunov] constants"),
    "status": STRING,
    "failure": nullable(STRING),
})


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
                  f"use `method` placement with `gamma` {0.9 * bound:.3g}")
    return Theorem1Check(name, float(bound), float(as_given), hinf_H, holds, reason)


def cascade_noise_model(cascade: CascadeModel, scenario: Scenario) -> tuple[NoiseModel, tuple[str, ...]]:
    """The white-noise model of the error (12a) declared by a model file, for ``method="h2"``.

    On the extended system (8c), states ``[w, z]``, outputs ``y``:

    * **measurement** ``V``: each ``[sensors.NAME]`` group's noise covariance divided by its rate
      (:func:`~nlobs.synthesis.mixed_h2.sampled_intensity`), block-diagonal in the order of the
      outputs;
    * **process noise** from ``[process_noise]`` (spectral density on the plant state ``[x, w]``):
      its ``w`` block enters ``ẇ`` directly; its ``x`` block reaches ``ż = ∂h/∂x ẋ + …`` as
      ``∂h/∂x Q_xx ∂h/∂xᵀ`` (``∂h/∂x`` at ``[simulation].x0``, or at the origin without one; a note
      says when it is not constant);
    * **error weight** the identity: the variance of the errors of ``ŵ`` and ``ẑ`` together.

    Parameters
    ----------
    cascade : CascadeModel
        The cascade form of the model.
    scenario : Scenario
        The model file, with its ``[sensors.NAME]``, ``[process_noise]`` and ``[simulation]`` tables.

    Returns
    -------
    noise : NoiseModel
    notes : tuple of str
        How each part was obtained (printed with the design).

    Raises
    ------
    InvalidArgumentError
        The file declares no sensors (no measurement noise: the H2 design has nothing to trade).
    """
    s2, s1 = cascade.sigma2, cascade.sigma1
    names = list(s2.outputs)
    if not scenario.sensors:
        raise InvalidArgumentError(
            "`method` h2 needs the measurement noise: give the outputs a [sensors.NAME] table with rate and "
            "noise_std (or noise_cov)")
    p, n_w, p_z, n_x = len(names), s2.n_w, s1.p_z, s1.n_x
    V = np.zeros((p, p))
    notes = []
    for g in scenario.sensors:
        idx = [o if isinstance(o, int) else names.index(o) for o in g.outputs]
        V[np.ix_(idx, idx)] = sampled_intensity(1.0, g.rate) * g.covariance
        notes.append(f"[sensors.{g.name}]: {', '.join(names[i] for i in idx)} at {g.rate:g} Hz → intensity "
                     + ", ".join(f"{V[i, i]:.3g}" for i in idx))
    Bw = W = None
    Q = scenario.process_noise
    if Q is not None and np.any(Q):
        x0 = scenario.defaults.x0
        xs = np.zeros(n_x) if x0 is None else np.asarray(x0, dtype=float)[:n_x]
        ws = np.zeros(n_w) if x0 is None else np.asarray(x0, dtype=float)[n_x:]
        u0 = np.zeros(s1.m)
        Hx = s1.h_x(u0, ws, xs)
        other = s1.h_x(u0, ws + 0.37, xs * 1.3 + 0.21)  # a second, arbitrary point: is ∂h/∂x constant?
        Wz = Hx @ Q[:n_x, :n_x] @ Hx.T
        Bw = np.eye(n_w + p_z)
        W = np.zeros((n_w + p_z, n_w + p_z))
        W[:n_w, :n_w] = Q[n_x:, n_x:]
        W[n_w:, n_w:] = Wz
        where = "" if np.allclose(Hx, other, rtol=1e-12, atol=0.0) else (
            " (∂h/∂x is not constant: taken at [simulation].x0" if x0 is not None else
            " (∂h/∂x is not constant: taken at the origin; give [simulation].x0") + ")"
        notes.append(f"[process_noise]: on w {np.diag(W)[:n_w].round(12).tolist()}, on z through ∂h/∂x "
                     f"{np.diag(Wz).round(12).tolist()}{where}")
    else:
        notes.append("no [process_noise]: the design trades the measurement noise against LMI (14) alone")
    notes.append("error weight: the identity on [w, z]")
    return NoiseModel(V, Bw, W), tuple(notes)


def design_cascade(cascade: CascadeModel, *, gamma: float | None = None, method: str | None = None,
                   gain_bound: float | None = None, noise: NoiseModel | None = None,
                   noise_notes: tuple[str, ...] = ()) -> CascadeDesign:
    """Assumption 4, the gain of LMI (14) (or pole placement, or the H2-optimal gain), its re-verification and Theorem 1.

    Parameters
    ----------
    cascade : CascadeModel
        From :func:`nlobs.systems.cascade_file.load_cascade`.
    gamma : float, optional
        ``‖H‖∞ < γ`` (default: the file's ``[cascade].gamma``, else :data:`DEFAULT_GAMMA`).
    method : {"lmi", "placement", "h2"}, optional
        Default: the file's ``[cascade].method``, else ``"lmi"``.
    gain_bound : float, optional
        ``‖K‖`` bound of the LMI and H2 designs (default :data:`DEFAULT_GAIN_BOUND`).
    noise : NoiseModel, optional
        The noise of the extended system (8c) for ``method="h2"`` (required there;
        :func:`cascade_noise_model` builds it from a model file).
    noise_notes : tuple of str
        How ``noise`` was obtained (shown with the design).

    Returns
    -------
    CascadeDesign
        Also when Assumption 4 fails or the design is infeasible (then ``certificate`` is ``None``
        and ``failure`` names the assumption item or the LMI and the option to change).

    Raises
    ------
    InvalidArgumentError
        An unknown method, or ``method="h2"`` without ``noise``.
    """
    method = method or cascade.method or "lmi"
    if method not in METHODS:
        raise InvalidArgumentError(f"`method`: expected one of {', '.join(map(repr, METHODS))}, got {method!r}")
    if method == "h2" and noise is None:
        raise InvalidArgumentError("`method` 'h2': needs a noise model (cascade_noise_model builds it from the file)")
    gamma = gamma if gamma is not None else cascade.gamma
    g = positive("`gamma`", DEFAULT_GAMMA if gamma is None else gamma)
    gb = positive("`gain_bound`", DEFAULT_GAIN_BOUND if gain_bound is None else gain_bound)
    s2 = cascade.sigma2
    a4 = check_assumption4(s2.A, s2.B_z, s2.C, s2.D_z)
    notes = tuple(noise_notes) if method == "h2" else ()
    if not a4.holds:
        why = "; ".join(f"{it.name} [{it.key}]: {it.evidence}" for it in a4.failed)
        return CascadeDesign(cascade, a4, method, g, None, (), None,
                             f"Assumption 4 (Grip–Saberi–Johansen) fails: {why}; no gain K makes 𝔄 − Kℭ Hurwitz with "
                             "‖H‖∞ small (Theorem 2): change Σ2 or the measured outputs y", notes)
    ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
    cert: ObserverGainCertificate | MixedH2Certificate
    try:
        if method == "lmi":
            cert = design_cascade_gain(s2, gamma=g, gain_bound=gb)
        elif method == "h2":
            assert noise is not None
            cert = design_h2_gain(ext.A, ext.C, ext.Bd, gamma=g, noise=noise, gain_bound=gb)
        else:
            cert = place_cascade_gain(s2, gamma=g)
    except DesignError as exc:
        hint = {"lmi": "raise `gamma` or `gain_bound`, or use `method` placement for a small γ",
                "h2": "raise `gamma` or `gain_bound`"}.get(method, "raise `gamma`, or use `method` lmi")
        what = {"lmi": "LMI (14) (‖H‖∞ < γ)", "h2": "the H2 design under LMI (14) (‖H‖∞ < γ)"}.get(
            method, "pole placement (‖H‖∞ < γ)")
        return CascadeDesign(cascade, a4, method, g, None, (), None,
                             f"{what} has no solution for γ = {g:g}: {exc}; {hint}", notes)
    F = ext.A - cert.gain @ ext.C
    abscissa = float(np.max(np.linalg.eigvals(F).real))
    hH = float(hinf_norm(F, ext.Bd, np.eye(F.shape[0]), np.zeros((F.shape[0], ext.Bd.shape[1])), grid=True)) \
        if abscissa < 0 else math.inf
    checks = (Check.compare("max Re λ(𝔄 − Kℭ) < 0", abscissa, 0.0, kind=CheckKind.SPECTRUM),
              Check.compare("‖H‖∞ < γ (13), grid safeguard", hH, g, kind=CheckKind.NORM))
    return CascadeDesign(cascade, a4, method, g, cert, checks, _theorem1(cascade, hH, abscissa < 0), "", notes)


@dataclass(frozen=True)
class CascadeMethod:
    """The cascade/feedback observer (9)–(10) / (17)–(18) of Grip, Saberi & Johansen, from a ``[cascade]`` table.

    Defaults: the file's ``[cascade]`` ``gamma`` and ``method`` (else ``γ = 1``, and the gain chosen for the
    file's sensors when it has ``[sensors]``: ``method = "h2"``, the smallest noise-to-error H2 norm under
    LMI (14); LMI (14) alone without sensors); for ``method = "h2"`` the noise of the file's ``[sensors]`` and ``[process_noise]``
    (:func:`cascade_noise_model`). Premises: Assumption 4 and the re-verified gain (``𝔄 − Kℭ``
    Hurwitz, ``‖H‖∞ < γ``); Theorem 1 (or 1') with the file's ``[cascade.lyapunov]`` constants, not
    checked without them.

    Attributes
    ----------
    name : str
        The name in the registry.
    title : str
        The method with its paper and equation numbers.
    uses_region : bool
        Whether the design reads the problem's region.
    options : frozenset of str
        The options :meth:`design` takes.
    """

    name: str = "cascade"
    title: str = "cascade/feedback observer (Grip, Saberi & Johansen (9)–(10), (17)–(18))"
    uses_region: bool = False
    options: frozenset[str] = frozenset({"gamma", "gain_method", "gain_bound", "sampling"})

    def applies(self, problem: Problem) -> str | None:
        from nlobs.systems.cascade_file import has_cascade

        path = problem.path
        tables = problem.scenario.tables
        if path is None or not ("cascade" in tables if tables else has_cascade(path)):
            return ("the observer (9)–(10) of Grip, Saberi & Johansen needs a nonlinear subsystem Σ₁ whose "
                    "unmeasured output drives a linear Σ₂ ((1a), (1b)); this model file has no [cascade] table "
                    "describing one: add it, or build the interconnection with nlobs.CascadeObserver")
        return None

    def design(self, problem: Problem, *, gamma: float | None = None, gain_method: str | None = None,
               gain_bound: float | None = None, sampling: str | None = None) -> Design:
        """The design of :func:`design_cascade` for the problem's ``[cascade]`` table.

        Raises
        ------
        AssumptionViolated
            Assumption 4 fails (no gain exists).
        DesignInfeasible
            The gain's LMI has no solution for these options (the message names the option to change).
        """
        from nlobs.systems.cascade_file import load_cascade

        form = sampling_form(sampling)
        why = self.applies(problem)
        if why is not None:
            raise AssumptionViolated(why)
        assert problem.path is not None
        cm = problem.scenario.cascade or load_cascade(problem.path)  # read with the file, when it was
        chosen = None
        if gain_method is None and cm.method is None and problem.sensors and form == "predictor":
            chosen = gain_for_sensors(cm, problem, gamma=gamma, gain_bound=gain_bound)
        if chosen is not None:
            d = chosen[0]
        else:
            kind = gain_method or default_gain_method(cm, bool(problem.sensors))
            d = _design_with(cm, problem, kind, gamma, gain_bound)
        if d.certificate is None:
            if not d.assumption4.holds:
                raise AssumptionViolated(d.failure)
            raise DesignInfeasible(d.failure)
        return cascade_design(d, problem, gamma_given=gamma is not None, gain_method_given=gain_method is not None,
                              sampling=form, chosen=None if chosen is None else chosen[1])


def _design_with(cm: CascadeModel, problem: Problem, kind: str, gamma: float | None,
                 gain_bound: float | None) -> CascadeDesign:
    """:func:`design_cascade` with ``kind``; the H2 gain with the file's own sensors and process noise."""
    if kind == "h2":
        noise, notes = cascade_noise_model(cm, problem.scenario)
        return design_cascade(cm, gamma=gamma, method=kind, gain_bound=gain_bound, noise=noise, noise_notes=notes)
    return design_cascade(cm, gamma=gamma, method=kind, gain_bound=gain_bound)


def gain_for_sensors(cm: CascadeModel, problem: Problem, *, gamma: float | None = None,
                     gain_bound: float | None = None) -> tuple[CascadeDesign, Any] | None:
    """The cascade gain with the smallest certified RMS bound under the problem's sensors, or ``None``.

    Each gain method of :data:`SENSOR_METHODS` is designed at ``γ`` and certified through the predictor
    (:func:`~nlobs.methods.cascade_sampling.cascade_sampling_bound`); the smallest bound after the settling time
    wins. ``None`` when no method's gain is certified (the caller keeps :func:`default_gain_method`'s).

    Parameters
    ----------
    cm : CascadeModel
        The file's cascade.
    problem : Problem
        Its sensors, noise, region and settling time.
    gamma, gain_bound : float, optional
        As :func:`design_cascade`.

    Returns
    -------
    (CascadeDesign, SampledDesignCertificate) or None
        The design and its certificate under the sensors (for :func:`cascade_design`'s ``chosen``).
    """
    from nlobs.methods.cascade_sampling import cascade_sampling_bound

    best: tuple[float, CascadeDesign, Any] | None = None
    for kind in SENSOR_METHODS:
        try:
            d = _design_with(cm, problem, kind, gamma, gain_bound)
        except NlobsError:
            continue
        if d.certificate is None or not d.verified:
            continue
        cert, _ = cascade_sampling_bound(problem, d)
        if cert is None:
            continue
        value = cert.bound.rms_after(problem.settle)
        if math.isfinite(value) and (best is None or value < best[0]):
            best = (value, d, cert)
    return None if best is None else (best[1], best[2])


#: The gain methods compared under the file's sensors (:func:`gain_for_sensors`).
SENSOR_METHODS = ("h2", "placement", "lmi")


def default_gain_method(cm: CascadeModel, sensors: bool) -> str:
    """The gain method a cascade file gets when none is given: its ``[cascade] method``, else the H2 gain for its
    sensors (``"h2"``) when it has ``[sensors]``, else LMI (14) (``"lmi"``). Every command uses this rule.

    Parameters
    ----------
    cm : CascadeModel
        The file's cascade (its ``method``).
    sensors : bool
        Whether the file has ``[sensors]``.

    Returns
    -------
    str
    """
    return cm.method or ("h2" if sensors else "lmi")


def cascade_design(d: CascadeDesign, problem: Problem | None = None, *, gamma_given: bool = False,
                   gain_method_given: bool = False, sampling: str = "predictor", chosen: Any = None) -> Design:
    """The :class:`~nlobs.methods.base.Design` of a cascade design that has a gain (what every command reports).

    Parameters
    ----------
    d : CascadeDesign
        From :func:`design_cascade` (with a certificate).
    problem : Problem, optional
        The model file's problem: its sensors and noise make the run-time hypotheses (``None``: the
        exact, continuous measurement of Theorem 1).
    gamma_given, gain_method_given : bool
        Whether ``γ`` and the gain method were given (else they are the file's, or the defaults).
    sampling : {"predictor", "hold"}
        With sensors, how the sampled output enters the observer (:func:`~nlobs.methods.sensor_design.on_samples`).
    chosen : SampledDesignCertificate, optional
        The certificate under the sensors :func:`gain_for_sensors` chose ``d`` by (not computed again; the
        gain method's source says so).

    Returns
    -------
    Design
    """
    cm = d.cascade
    assert d.certificate is not None
    t1 = d.theorem1
    assert t1 is not None
    premises = (*(it for it in d.assumption4.items if it.required), *d.checks)
    unchecked: tuple[str, ...] = ()
    if t1.bound is None:
        unchecked = (f"{t1.theorem} (no [cascade.lyapunov] constants α₃, α₄, L₁, L₂ of Assumptions 1–3)",)
    else:
        premises = (*premises, Check.verdict(f"{t1.theorem}: ‖H‖∞ below its γ", t1.holds, t1.reason,
                                             kind=CheckKind.NORM, value=t1.hinf_H, limit=t1.bound))
    failed = () if d.verified else (d.failure or "the gain fails its re-verification: "
                                    + "; ".join(k.summary() for k in d.checks if not k.passed),)
    exact, what = problem.exact if problem is not None else (True, "")
    sensors = problem.sensors if problem is not None else ()
    hyps: tuple[Any, ...] = (
        Premise(f"{t1.theorem}: ‖H‖∞ below its γ", t1.holds,
                "no [cascade.lyapunov] constants" if t1.bound is None else
                f"‖H‖∞ = {t1.hinf_H:.4g} ≥ γ = {t1.bound:.4g}"),
        Premise("exact measurement and model", exact, f"{what} (Theorem 1 is for an exact output and model)"))
    obs = d.observer()
    theorem = ("Grip, Saberi & Johansen, LMI (14) and Theorem 1" if t1.bound is not None else
               "Grip, Saberi & Johansen, LMI (14) only (‖H‖∞ < γ verified; Theorem 1 needs the [cascade.lyapunov] "
               "constants)")
    sampled, why_not = None, ""
    if problem is not None and sensors:
        if sampling == "predictor" and d.verified:
            from nlobs.methods.cascade_sampling import cascade_sampling_bound

            sampled, why_not = (chosen, "") if chosen is not None else cascade_sampling_bound(problem, d)
        if sampled is not None:  # the augmented plant's certificate replaces Theorem 1 on the region, under the sensors
            from nlobs.methods.sensor_design import sampling_hypotheses

            obs, _ = on_samples(obs, problem, sampling, "Theorem 1")
            premises = (*premises, Check.verdict(
                "Jacobian bounds of the augmented plant on the region", True,
                f"∂F_a/∂χ, ∂y/∂χ sampled on {problem.region.describe()} and the input range, each varying entry "
                f"widened 5 %: {len(sampled.continuous.vertices)} vertices", kind=CheckKind.FUNCTION_CLASS,
                method="sampled", key="jacobian_box"), *sampled.checks)
            unchecked = ()
            hyps = sampling_hypotheses(problem, sampled.bound)
            theorem = ("the cascade observer as the Thau observer of its augmented plant (x, w, z): vertex LMIs of "
                       "the Jacobian box (Zemouche, Boutayeb & Bara 2008) with the sampled-data bound of the "
                       "inter-sample predictor (Karafyllis & Kravaris 2009)")
        else:
            obs, lacking = on_samples(obs, problem, sampling, "Theorem 1", reason=why_not)
            hyps += lacking
    K = d.certificate.gain
    how = {"lmi": "LMI (14)", "h2": "the smallest noise-to-error H2 norm under LMI (14)"}.get(d.method,
                                                                                              "pole placement")
    desc = (f"{'(17)–(18)' if cm.feedback else '(9)–(10)'} with Σ1's injection g of the file, K = "
            f"{[round(float(v), 5) for v in np.asarray(K).ravel()]} by {how} (‖H‖∞ = {t1.hinf_H:.4g} < γ = "
            f"{d.gamma:g}); {d.status}")
    parameters: dict[str, Any] = {"gamma": d.gamma, "gain_method": d.method, "theorem1_gamma": t1.bound,
                                  "hinf_H": t1.hinf_H}
    bound = None
    if sampled is not None and problem is not None:
        from nlobs.methods.cascade_sampling import plant_map
        from nlobs.synthesis.mapped_bound import MappedBound

        M = plant_map(d)  # χ̃₀ = M x̃₀; the plant's error is a part of the augmented one
        bound = MappedBound(sampled.bound, float(np.linalg.norm(M, 2)), 1.0, False, into=M)
        rms = bound.rms_after(problem.settle, problem.p0) if problem.p0 is not None else \
            sampled.bound.rms_after(problem.settle)
        parameters.update({"sampling": sampling, "decay": sampled.continuous.decay,
                           "T_max": {g.name: t for g, t in zip(bound.groups, bound.t_max)},
                           "rms_bound": rms if math.isfinite(rms) else None})
        desc += (f"; certified under the sensors through the predictor (augmented plant, decay "
                 f"{sampled.continuous.decay:.4g}): RMS ≤ {rms:.4g} after t = {problem.settle:g}")
    elif sensors:
        parameters["sampling"] = sampling
    sources = {"gamma": "given" if gamma_given else ("[cascade] gamma" if cm.gamma is not None else "default"),
               "gain_method": "given" if gain_method_given else ("[cascade] method" if cm.method else
                                                                 "default with [sensors]" if sensors else "default")}
    if chosen is not None and bound is not None:
        sources["gain_method"] = ("the smallest certified RMS bound under the file's sensors of "
                                  + ", ".join(SENSOR_METHODS))
    from nlobs.export.cascade import design_notes

    details = tuple(f"{k}: {v}" for k, v in design_notes(d))
    if bound is not None:
        details += tuple(bound.summary().splitlines())
    elif why_not and sensors:
        details += (f"no certificate under the sensors: {why_not}",)
    return Design("cascade", obs, d.certificate, tuple(premises), unchecked, parameters, sources, desc,
                  gain=K, failed=failed, hypotheses=hyps,
                  coverage_extras={"hinf_H": t1.hinf_H, "theorem1_gamma": t1.bound}, report=d,
                  theorem=theorem, details=details, bound=bound)


#: The cascade method of the registry.
CASCADE = CascadeMethod()
