"""``nlobs export``: design an observer for a model and write its step as dependency-free C99.

:func:`export_model_observer` runs the design the matching ``nlobs design`` command runs (the same
defaults, the model file's region), takes the observer that design built and writes it with
:func:`nlobs.export.export_observer`. The header's comment block carries what the certificate says:
the verdict, the region it was verified on, the certificate's own summary (its checks and margins).
A design that is not usable is still written, with that in the header, and the report's verdict is
``FAILED`` (exit status 1): the code exists, the guarantee does not.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from nlobs._io import with_schema
from nlobs.errors import InvalidArgumentError
from nlobs.workflows.verdict import Verdict

__all__ = ["EXPORTABLE", "ExportReport", "export_model_observer"]

#: The observers ``nlobs export --observer`` designs and writes.
EXPORTABLE: tuple[str, ...] = ("luenberger", "drift", "pinv", "cascade", "setvalued", "gnss-ins")
#: The Luenberger gain of ``nlobs export --observer luenberger``: LMIs (14), (15) with Re λ < −1 at γ = γn.
LUENBERGER_ALPHA, LUENBERGER_GAMMA = 1.0, 1000.0
LANGUAGES: tuple[str, ...] = ("c",)


@dataclass(frozen=True)
class ExportReport:
    """What :func:`export_model_observer` designed and wrote.

    Attributes
    ----------
    model : str
        The model's name.
    observer : str
        One of :data:`EXPORTABLE`.
    certified : bool
        The design is usable (its certificate verified and its premises checked on the region).
    certificate : str
        The certificate's summary, as written into the header.
    files : tuple of Path
        The header and the source.
    exported : Any
        The :class:`nlobs.export.ExportResult`.
    verdict : Verdict
        ``OK`` when certified, else ``FAILED``.
    message : str
        Why not, when ``FAILED``.
    """

    model: str
    observer: str
    certified: bool
    certificate: str
    files: tuple[Path, ...]
    exported: Any = field(repr=False)
    verdict: Verdict = Verdict.OK
    message: str = ""

    def summary(self) -> str:
        """What was written, and on which certificate."""
        ex = self.exported
        lines = [f"{self.model}: {ex.program.title} written as C99",
                 *(f"  {p}" for p in self.files),
                 f"  compiled with -Wall -Wextra -Werror -std=c99 -pedantic by {ex.checked_with}" if ex.checked_with
                 else "  not compiled: no C compiler was found (pip install 'nlobs[codegen]')",
                 f"  certificate: {'verified' if self.certified else 'NOT usable'}"]
        lines += ["    " + ln for ln in self.certificate.splitlines()]
        return "\n".join(lines)  # the message, when FAILED, is the command's one line

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready view (``schema_version`` first)."""
        return with_schema({"model": self.model, "observer": self.observer, "certified": self.certified,
                            "certificate": self.certificate, "files": [str(p) for p in self.files],
                            "module": self.exported.to_dict(), "verdict": self.verdict.value,
                            "message": self.message})


def _luenberger(model: Any, box: Any, saturation: bool | None, x0: Any = None) -> tuple[Any, bool, str, str]:
    """A linear model: the Luenberger observer of the certified gain. A nonlinear one: the constant-gain copy
    of the plant with the gain certified for its linearisation at the file's x0 (not for the plant)."""
    import numpy as np

    from nlobs.observers.luenberger import ConstantGainObserver, LuenbergerObserver
    from nlobs.synthesis.observer_gain import design_observer_gain
    from nlobs.synthesis.regions import HalfPlane
    from nlobs.systems.linear import LinearSystem
    from nlobs.systems.linearize import linearize

    if box is not None or saturation is not None:
        raise InvalidArgumentError("--box and --saturation do not apply to the Luenberger observer")
    if model.time.is_discrete:
        raise InvalidArgumentError("the certified gain of LMIs (14), (15) is for continuous time: a discrete "
                                   "model's observer is exported from Python (export_observer)")
    linear = isinstance(model, LinearSystem)
    x0 = np.zeros(model.n) if x0 is None else np.asarray(x0, dtype=float)
    u0 = np.zeros(model.m)
    lin = model if linear else linearize(model, x0, u0)
    cert = design_observer_gain(lin.A, lin.C, np.eye(model.n), gamma=LUENBERGER_GAMMA, gamma_n=LUENBERGER_GAMMA,
                                region=HalfPlane(LUENBERGER_ALPHA))
    obs = LuenbergerObserver(lin, cert.gain) if linear else ConstantGainObserver(model.compile(), cert.gain)
    where = "the linear model" if linear else f"the linearisation at x0 = {x0.tolist()}, u = {u0.tolist()}"
    text = (f"Grip, Saberi & Johansen, LMIs (14), (15) for {where} (Re λ < −{LUENBERGER_ALPHA:g}, "
            f"γ = γn = {LUENBERGER_GAMMA:g})\n{cert.summary()}")
    why = "" if cert.verified and linear else (
        "the gain's certificate failed" if not cert.verified else
        f"the certificate is for {where}, not for the nonlinear plant")
    return obs, bool(cert.verified) and linear, text, why


def _drift(model: Any, box: Any, saturation: bool | None) -> tuple[Any, bool, str, str]:
    from nlobs.workflows.design_drift import design_drift_report
    from nlobs.workflows.inputs import as_region

    region = None if box is None else as_region(box, model.n)
    rep = design_drift_report(model, region=region)
    sat = True if saturation is None else saturation
    obs = rep.observer(saturation=sat)
    text = "\n".join([f"Dalla Mora, Germani & Manes, Theorem 3.1 on {rep.region.describe()}",
                      rep.certificate.summary(),
                      f"bound (3.2): {rep.bound.describe()}"])
    why = "" if rep.usable else "; ".join(rep.reasons)
    return obs, rep.usable, text, why


def _pinv(model: Any, box: Any, saturation: bool | None) -> tuple[Any, bool, str, str]:
    from nlobs.workflows.design_pinv import design_pinv_report
    from nlobs.workflows.inputs import as_region

    region = None if box is None else as_region(box, model.n)
    rep = design_pinv_report(model, None, region=region)
    obs = rep.observer
    sat = (box is not None) if saturation is None else saturation
    if sat:
        obs = obs.with_saturation(obs.region)
    lines = [f"Röbenack, Theorem 4.1 / Corollary 4.1 on {obs.region.describe()}"]
    lines += [f"{c.name}: {'passed' if c.passed else 'FAILED'}: {c.evidence}" for c in rep.checks]
    lines += [f"{h['name']}: {h['status']}" for h in rep.hypotheses]
    why = "" if rep.usable else "the design is not usable: " + "; ".join(rep.missing or ("a check failed",))
    return obs, rep.usable, "\n".join(lines), why


def _cascade(model: Any, box: Any, saturation: bool | None) -> tuple[Any, bool, str, str]:
    from nlobs.export.cascade import design_notes
    from nlobs.systems.cascade_file import load_cascade
    from nlobs.workflows.design_cascade import design_cascade

    if box is not None or saturation is not None:
        raise InvalidArgumentError("--box and --saturation do not apply to the cascade observer (its region and "
                                   "saturations are the file's [cascade] table)")
    design = design_cascade(load_cascade(model))
    if design.certificate is None:
        raise InvalidArgumentError(f"no gain to export: {design.failure}")
    text = "\n".join(f"{k}: {v}" for k, v in design_notes(design))
    why = "" if design.verified else f"status {design.status}: {design.failure or 'a check failed'}"
    return design.observer(), design.verified, f"Grip, Saberi & Johansen, LMI (14) and Theorem 1\n{text}", why


def _setvalued(model: Any, box: Any, saturation: bool | None) -> tuple[Any, bool, str, str]:
    from nlobs.observers.setvalued import SetValuedObserver
    from nlobs.systems.modelfile import load_discrete_ui_model
    from nlobs.workflows.setvalued import design_setvalued_observer

    if box is not None or saturation is not None:
        raise InvalidArgumentError("--box and --saturation do not apply to the set-valued observer (its class box "
                                   "is the file's)")
    m = load_discrete_ui_model(model)
    rep = design_setvalued_observer(m)
    if rep.design is None:
        raise InvalidArgumentError(f"no gain to export: {rep.message}")
    d = rep.design
    verified = all(c.passed for c in d.checks)
    lines = [f"Khajenejad & Yong, observer (10)-(15), Algorithm 1, with nlobs's sound design and radius recursion "
             f"(objective {d.objective.value})",
             f"rho = {d.rho}, lambda_eff = {d.lam_eff:.6g}, c = {d.c:.6g}, steady radius = {d.steady_radius:.6g}"]
    lines += [f"{c.name}: {'passed' if c.passed else 'FAILED'}: {c.evidence}" for c in d.checks]
    why = "" if verified and rep.verdict is Verdict.OK else (rep.message or "a check failed")
    return SetValuedObserver(m.system, d), verified and rep.verdict is Verdict.OK, "\n".join(lines), why


def _gnss_ins(model: Any, box: Any, saturation: bool | None) -> tuple[Any, bool, str, str]:
    from nlobs.navigation.trajectory import traffic_pattern
    from nlobs.workflows.demo import DemoConfig, demo_observer

    if box is not None or saturation is not None:
        raise InvalidArgumentError("--box and --saturation do not apply to the GNSS/INS observer")
    config = DemoConfig()
    obs, cert, schedule = demo_observer(config, traffic_pattern(seed=config.seed))
    assert cert is not None
    lines = ["Grip, Fossen, Johansen & Saberi (24), the demo's noise-optimal certified gains",
             cert.summary()]
    if schedule is not None:
        lines.append(f"attitude gain: {schedule.describe()}")
    lines.append(f"IMU period {1.0 / config.imu_rate_hz:g} s (the module refuses another step length)")
    return obs, bool(cert.verified), "\n".join(lines), "" if cert.verified else "the gain's certificate failed"


def export_model_observer(model: Any, *, observer: str, out: str | Path, lang: str = "c",
                          box: Sequence[float] | Any | None = None, saturation: bool | None = None,
                          prefix: str | None = None) -> ExportReport:
    """Design ``observer`` for ``model`` and write its C module to ``out`` (``nlobs export``).

    Parameters
    ----------
    model : str, Path or SymbolicModel
        A model file or shipped model name.
    observer : str
        One of :data:`EXPORTABLE`.
    out : str or Path
        The folder of ``P.h`` and ``P.c``.
    lang : str
        ``"c"`` (the only language).
    box : sequence of float or Box, optional
        The design's region (as for ``nlobs design``).
    saturation : bool, optional
        Khalil's saturated form outside the region (default: the design command's default).
    prefix : str, optional
        The C prefix (default from the model's name).

    Returns
    -------
    ExportReport

    Raises
    ------
    InvalidArgumentError
        Unknown observer or language.
    CompilerError
        The strict compilation of the generated module failed (nothing is written).
    OutputError
        ``out`` cannot be written.
    """
    from nlobs.export import export_observer
    from nlobs.workflows.inputs import symbolic_model

    if lang not in LANGUAGES:
        raise InvalidArgumentError(f"--lang: expected one of {', '.join(LANGUAGES)}, got {lang!r}")
    makers = {"luenberger": _luenberger, "drift": _drift, "pinv": _pinv, "cascade": _cascade, "setvalued": _setvalued, "gnss-ins": _gnss_ins}
    if observer not in makers:
        raise InvalidArgumentError(f"--observer: expected one of {', '.join(EXPORTABLE)}, got {observer!r}")
    if observer == "gnss-ins":
        if str(model) != "gnss-ins":
            raise InvalidArgumentError(f"--observer gnss-ins: the model is the demo's flight, named gnss-ins (got {model!r})")
        name = "gnss-ins"
        obs, certified, text, why = _gnss_ins(None, box, saturation)
    elif observer == "luenberger":
        from nlobs.errors import NlobsError
        from nlobs.systems.modelfile import load_model, load_scenario

        m = load_model(model) if isinstance(model, (str, Path)) else model
        name = m.name
        try:
            x0 = load_scenario(model).defaults.x0 if isinstance(model, (str, Path)) else None
        except NlobsError:
            x0 = None
        obs, certified, text, why = _luenberger(m, box, saturation, x0)
    elif observer in ("cascade", "setvalued"):
        name = Path(str(model)).stem
        obs, certified, text, why = makers[observer](model, box, saturation)
    else:
        m = symbolic_model(model)
        name = m.name
        obs, certified, text, why = makers[observer](m, box, saturation)
    notes = (("certificate", ("verified" if certified else "NOT USABLE") + (f" ({why})" if why else "")),
             ("certified on", text))
    if observer == "gnss-ins":
        from nlobs.workflows.demo import DemoConfig

        options: dict[str, Any] | None = {"imu_period": 1.0 / DemoConfig().imu_rate_hz}
    else:
        options = None
    res = export_observer(obs, out, prefix=prefix or f"{name}_{observer}", notes=notes, options=options)
    verdict = Verdict.OK if certified else Verdict.FAILED
    msg = "" if certified else f"{name}: the {observer} design is not certified ({why}); the code was written " \
                               "with that in its header"
    return ExportReport(name, observer, certified, text, (res.header, res.source), res, verdict, msg)
