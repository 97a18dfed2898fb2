r"""The set-valued input-and-state observer of Khajenejad & Yong as a method (observer (10)–(15), Algorithm 1).

For a discrete-time model with unknown inputs (a model file with ``[unknown_inputs]``,
:func:`nlobs.systems.modelfile.load_discrete_ui_model`): the structural checks (Lemma 5.1's rank
condition, strong detectability of every linear member of the class), the sampled function-class
check, and nlobs's sound design of the gain with its certificate (:func:`nlobs.synthesis.setvalued.design_setvalued`),
as a :class:`SetValuedDesignReport` (:func:`design_setvalued_observer`, ``nlobs design setvalued``).
:data:`SETVALUED` is the method of the registry.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nlobs._typing import Array
from nlobs._schema import BOOLEAN, INTEGER, MATRIX, NUMBER, OBJECT, STRING, Record, array, nullable
from nlobs.checks import CHECK_JSON, Verdict
from nlobs.errors import AssumptionViolated, ModelError
from nlobs.linear.transform_ui import StructuralReport, structural_check
from nlobs.methods.base import Design
from nlobs.methods.problem import Problem
from nlobs.synthesis.setvalued import SetValuedDesign, design_setvalued
from nlobs.systems.discrete_ui import DiscreteUISystem, check_function_class
from nlobs.systems.modelfile import DiscreteUIModel, load_discrete_ui_model

__all__ = ["SETVALUED", "SetValuedDesignReport", "SetValuedMethod", "class_check_box", "design_setvalued_observer",
           "load_setvalued_model"]


def _structure(s: DiscreteUISystem) -> tuple[StructuralReport | None, str]:
    """The structural check, or ``None`` with the reason when Lemma 5.1's rank condition fails."""
    try:
        return structural_check(s.A, s.G, s.C, s.H, members=s.function_class.linear_members()), ""
    except AssumptionViolated as exc:
        return None, str(exc)


def _structure_dict(st: StructuralReport | None, why: str) -> dict[str, Any]:
    if st is None:
        return {"exists": False, "lemma_5_1_rank": False, "evidence": why}
    return {"exists": st.exists, "lemma_5_1_rank": True, **st.to_dict()}


def class_check_box(m: DiscreteUIModel) -> tuple[Array, Array]:
    """Where the function class is checked: the file's ``box``, else ``x0 ± max(10 δ0, 1)``.

    Parameters
    ----------
    m : DiscreteUIModel
        A loaded set-valued model file.

    Returns
    -------
    lo, hi : ndarray
        The corners of the box.
    """
    if m.box is not None:
        return m.box
    s = m.system
    half = max(10.0 * s.delta0, 1.0)
    return s.x0 - half, s.x0 + half


def load_setvalued_model(model: str | Path | DiscreteUIModel) -> DiscreteUIModel:
    """A set-valued model: loaded (a file or a shipped name) or as given.

    Parameters
    ----------
    model : str, Path or DiscreteUIModel
        A model file with unknown inputs, a shipped name, or a loaded model.

    Returns
    -------
    DiscreteUIModel
    """
    return model if isinstance(model, DiscreteUIModel) else load_discrete_ui_model(model)


_NO_OBSERVER = ("no stable observer of this structure exists (a linear member of the class is not strongly "
                "detectable, or Lemma 5.1's rank condition fails); evidence printed above")


#: ``structure`` of the set-valued reports: Lemma 5.1 and strong detectability.
STRUCTURE_JSON = Record("SetValuedStructure", {
    "exists": BOOLEAN.about("a stable observer of the structure (10)-(15) exists"),
    "lemma_5_1_rank": BOOLEAN, "strongly_detectable": array(BOOLEAN),
    "reasons": array(STRING), "unstable_error_modes": array(array(array(NUMBER))), "evidence": STRING,
    "checks": array(CHECK_JSON)})

#: ``class_check`` of the set-valued reports: the function class sampled on the box.
CLASS_CHECK_JSON = Record("FunctionClassCheck", {
    "holds": BOOLEAN, "worst_margin": NUMBER, "x1": nullable(array(NUMBER)), "x2": nullable(array(NUMBER)),
    "pairs": INTEGER, "box": MATRIX, "text": STRING})

#: ``design`` of the set-valued reports: the gain of Algorithm 1 (Khajenejad & Yong) with its certificate.
SETVALUED_GAIN_JSON = Record("SetValuedGain", {
    "objective": STRING, "L_tilde": MATRIX, "gain": MATRIX, "P": MATRIX, "lambda": NUMBER, "lambda_eff": NUMBER,
    "kappa": NUMBER, "q": NUMBER, "c": NUMBER, "theta": array(NUMBER), "rho": NUMBER, "steady_radius": NUMBER,
    "spectral_radii": array(NUMBER), "hinf_linear": array(NUMBER), "solver": nullable(STRING),
    "solver_status": nullable(STRING), "margin": NUMBER, "solves": INTEGER, "seconds": NUMBER,
    "function_class_used": STRING, "lpv_design": nullable(OBJECT), "checks": array(CHECK_JSON),
    "verified": BOOLEAN})

#: ``nlobs design setvalued``.
SETVALUED_DESIGN_REPORT_JSON = Record("DesignSetValued", {
    "model": STRING, "n": INTEGER, "p": INTEGER.about("unknown inputs"), "l": INTEGER.about("measurements"),
    "function_class": STRING, "gamma": NUMBER, "eta_w": NUMBER, "eta_v": NUMBER, "delta0": NUMBER,
    "structure": STRUCTURE_JSON, "class_check": CLASS_CHECK_JSON,
    "design": SETVALUED_GAIN_JSON.about("absent when no stable observer of the structure exists"),
}, optional={"design"}, description="The set-valued input and state observer of Khajenejad & Yong (10)-(15): "
                                    "structural checks, the function class, the gain and its certificate.")


@dataclass(frozen=True, eq=False)
class SetValuedDesignReport:
    """What ``nlobs design setvalued`` prints: structure, sampled class check, design and verification.

    Attributes
    ----------
    model : str
        The model as the user named it (for messages).
    data : dict
        The JSON report (``to_dict()``).
    design : SetValuedDesign or None
        ``None`` when no stable observer of the structure exists.
    structure : StructuralReport or None
        ``None`` when Lemma 5.1's rank condition fails.
    verdict : Verdict
        ``OK`` or ``NO_OBSERVER``.
    message : str
        The line printed after the report when the verdict is not ``OK``.

    Examples
    --------
    Khajenejad & Yong's Sec. 6.2 example, as printed, has a linear member with an invariant zero outside
    the unit circle, so it is not strongly detectable (their Definition 2.1): the report says so and holds no
    design (their Sec. 6.1 example gets one, see :func:`design_setvalued_observer`):

    >>> rep = design_setvalued_observer("khajenejad-6-2", samples=500)
    >>> rep.verdict.value, rep.design is None, type(rep.structure).__name__
    ('no observer', True, 'StructuralReport')
    >>> d = rep.to_dict()
    >>> (d["n"], d["p"], d["l"]), d["structure"]["exists"], "design" in d
    ((2, 1, 1), False, False)
    >>> print(rep.summary())
    khajenejad-6-2: NO stable observer of the structure (10)-(15) exists
    member 0: strongly detectable=False (invariant zero(s) with |z| >= 1: -1.34308+0j); ...
    >>> print(rep.message)
    khajenejad-6-2: no stable observer of this structure exists (a linear member of the class is not strongly ...
    """

    model: str
    data: dict[str, Any]
    design: SetValuedDesign | None
    structure: StructuralReport | None
    verdict: Verdict
    message: str

    def to_dict(self) -> dict[str, Any]:
        """The JSON report."""
        return SETVALUED_DESIGN_REPORT_JSON.emit(copy.deepcopy(self.data))

    def head(self) -> str:
        """The model, structure and class-check lines (shared with the simulation report)."""
        d = self.data
        st = d["structure"]
        return "\n".join([
            f"model {d['model']}: n = {d['n']}, unknown inputs p = {d['p']}, measurements l = {d['l']}; "
            f"{d['function_class']} (γ = {d['gamma']:.4g}); η_w = {d['eta_w']:g}, η_v = {d['eta_v']:g}, "
            f"δ0 = {d['delta0']:g}",
            "structural checks: Lemma 5.1 rank ok; stable observer of this structure exists: "
            f"{'yes' if st['exists'] else 'NO'}",
            "  " + st["evidence"].replace("\n", "\n  "),
            "function class (sampled): " + d["class_check"]["text"],
        ])

    def summary(self) -> str:
        """The text report."""
        if self.design is None:
            return f"{self.model}: NO stable observer of the structure (10)-(15) exists\n" + \
                self.data["structure"]["evidence"]
        return self.head() + "\n" + self.design.summary()


def design_setvalued_observer(model: str | Path | DiscreteUIModel, *, objective: str = "radius",
                              samples: int = 20_000, seed: int = 0) -> SetValuedDesignReport:
    """Structural checks, the sampled function-class check and the certified design of Algorithm 1's gain.

    Parameters
    ----------
    model : str, Path or DiscreteUIModel
        A model file with unknown inputs, the name of a shipped one, or a loaded model.
    objective : {"radius", "hinf"}
        The design objective of :func:`nlobs.synthesis.setvalued.design_setvalued`.
    samples : int
        Sampled pairs for the function-class check (in :func:`class_check_box`).
    seed : int
        Seed of that sampling.

    Returns
    -------
    SetValuedDesignReport
        Verdict ``NO_OBSERVER`` (with the evidence) when no stable observer of the structure (10)-(15) exists.

    Raises
    ------
    ModelFileError
        The model file cannot be read or is invalid.
    ModelError
        The nonlinear part violates its stated class on the sampled pairs (no certificate would hold).
    DesignInfeasible, CertificateError
        The design failed (the message says which LMI and by how much) or failed its re-verification.

    Examples
    --------
    The flexible-joint robot of Khajenejad & Yong, Sec. 6.1: a stable observer of the structure exists
    (Corollary 5.8), the sampled Class II check holds, and the certified gain ``L̃`` of (15) contracts
    the Lyapunov function of (⋆) by ``λ < 1`` per step:

    >>> rep = design_setvalued_observer("khajenejad-6-1", samples=2000)
    >>> d = rep.to_dict()
    >>> rep.verdict.value, d["structure"]["exists"], d["class_check"]["holds"], d["design"]["verified"]
    ('ok', True, True, True)
    >>> rep.design.gain.shape, round(d["design"]["lambda"], 3)
    ((4, 1), 0.969)

    Their Sec. 6.2 example, as printed, has an invariant zero outside the unit circle: no observer, with
    the evidence:

    >>> rep = design_setvalued_observer("khajenejad-6-2", samples=2000)
    >>> rep.verdict.value, rep.design, rep.to_dict()["structure"]["reasons"]
    ('no observer', None, ['invariant zero(s) with |z| >= 1: -1.34308+0j'])
    """
    m = load_setvalued_model(model)
    label = str(model) if not isinstance(model, DiscreteUIModel) else m.system.name
    s = m.system
    st, why = _structure(s)
    lo, hi = class_check_box(m)
    chk = check_function_class(s.nonlinear, s.function_class, lo, hi, n_pairs=samples, seed=seed)
    data: dict[str, Any] = {
        "model": s.name, "n": s.n, "p": s.p, "l": s.l, "function_class": s.function_class.label,
        "gamma": s.function_class.gamma, "eta_w": s.eta_w, "eta_v": s.eta_v, "delta0": s.delta0,
        "structure": _structure_dict(st, why),
        "class_check": {"holds": chk.passed, "worst_margin": chk.value, "x1": chk.values["x1"].tolist(),
                        "x2": chk.values["x2"].tolist(), "pairs": chk.values["n_pairs"],
                        "box": [lo.tolist(), hi.tolist()], "text": chk.evidence},
    }
    if st is None or not st.exists:
        return SetValuedDesignReport(label, data, None, st, Verdict.NO_OBSERVER, f"{label}: {_NO_OBSERVER}")
    if not chk.passed:
        raise ModelError(f"the nonlinear part violates its stated class, so no certificate would hold: {chk.evidence}")
    try:
        # the observer runs on the plant's own φ (no run-time LPV weights): a Class III file is designed with
        # the σ̃ Lipschitz multiplier, not at the vertices (docs/setvalued.md, "Soundness conditions")
        d = design_setvalued(s, objective=objective, lpv="lipschitz", structure=st)
    except AssumptionViolated as exc:  # pragma: no cover - the structural check above catches these first
        data["structure"]["evidence"] = exc.evidence or str(exc)
        return SetValuedDesignReport(label, data, None, st, Verdict.NO_OBSERVER, f"{label}: {_NO_OBSERVER}")
    data["design"] = d.to_dict()
    return SetValuedDesignReport(label, data, d, st, Verdict.OK, "")


@dataclass(frozen=True)
class SetValuedMethod:
    """Khajenejad & Yong's observer (10)–(15) with nlobs's sound design and radius recursion (module docstring).

    Applies to a discrete-time model file with ``[unknown_inputs]``. Premises checked: the
    structural conditions, the function class on sampled pairs of :func:`class_check_box`, and every
    block of the design's certificate; the class is checked by sampling the file's box.

    Attributes
    ----------
    name : str
        The name in the registry.
    title : str
        The method with its paper and equation numbers.
    uses_region : bool
        Whether the design reads the problem's region (no: the class box is the file's).
    options : frozenset of str
        The options :meth:`design` takes.
    """

    name: str = "setvalued"
    title: str = "set-valued observer (Khajenejad & Yong (10)–(15), Algorithm 1)"
    uses_region: bool = False
    options: frozenset[str] = frozenset({"objective", "samples", "seed"})

    def applies(self, problem: Problem) -> str | None:
        from nlobs.systems.modelfile import model_file_tables

        path = problem.path
        tables = problem.scenario.tables or (model_file_tables(path) if path is not None else frozenset())
        if path is None or "unknown_inputs" not in tables:
            return ("Khajenejad & Yong's observer is for a discrete-time model with unknown inputs: this model file has "
                    "no [unknown_inputs] table")
        return None

    def design(self, problem: Problem, *, objective: str = "radius", samples: int = 20_000, seed: int = 0) -> Design:
        """The design of :func:`design_setvalued_observer` for the problem's model file.

        Raises
        ------
        AssumptionViolated
            The model file has no ``[unknown_inputs]``, or no stable observer of the structure exists.
        ModelError
            The nonlinear part violates its stated class on the sampled pairs.
        DesignInfeasible, CertificateError
            As :func:`design_setvalued_observer`.
        """
        from nlobs.observers.setvalued import SetValuedObserver

        why = self.applies(problem)
        if why is not None:
            raise AssumptionViolated(why)
        assert problem.path is not None
        m = load_setvalued_model(problem.path)
        rep = design_setvalued_observer(m, objective=objective, samples=samples, seed=seed)
        if rep.design is None:
            raise AssumptionViolated(rep.message or _NO_OBSERVER)
        d = rep.design
        description = (f"observer (10)-(15), Algorithm 1, sound design (objective {d.objective.value}): rho = {d.rho}, "
                       f"lambda_eff = {d.lam_eff:.6g}, c = {d.c:.6g}, steady radius = {d.steady_radius:.6g}")
        failed = tuple(f"{c.name} fails: {c.evidence}" for c in d.checks if not c.passed)
        parameters = {"objective": d.objective.value, "rho": d.rho, "lam_eff": d.lam_eff, "c": d.c,
                      "steady_radius": d.steady_radius}
        return Design(self.name, SetValuedObserver(m.system, d), d, tuple(d.checks), (), parameters,
                      {"objective": "given" if objective != "radius" else "default"}, description,
                      gain=d.gain, failed=failed, report=rep,
                      theorem="Khajenejad & Yong, observer (10)-(15), Algorithm 1, with nlobs's sound design and radius "
                              "recursion")


#: The set-valued method of the registry.
SETVALUED = SetValuedMethod()
