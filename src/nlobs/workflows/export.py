"""``nlobs export``: design an observer for a model and write its step as dependency-free C99.

:func:`export_model_observer` runs the design the matching ``nlobs design`` command runs (the same
defaults, the model file's region), takes the observer that design built and writes it with
:func:`nlobs.export.export_observer`. The header's comment block carries what the certificate says:
the verdict, the region it was verified on, the certificate's own summary (its checks and margins).
A design that is not usable is still written, with that in the header, and the report's verdict is
``FAILED`` (exit status 1): the code exists, the guarantee does not.
"""

from __future__ import annotations

import dataclasses

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from nlobs._io import with_schema
from nlobs._schema import BOOLEAN, STRING, Record, array, nullable
from nlobs.checks import VERDICT_JSON
from nlobs.export.write import EXPORTED_MODULE_JSON
from nlobs.methods.base import DESIGN_JSON
from nlobs.errors import InvalidArgumentError, NlobsError
from nlobs.methods.registry import names
from nlobs.workflows.verdict import Verdict

__all__ = ["EXPORTABLE", "ExportReport", "export_model_observer"]

#: The ``observer`` values of :func:`export_model_observer` (``nlobs export``): the registry's methods with a C
#: generator.
EXPORTABLE: tuple[str, ...] = names(exported=True)
LANGUAGES: tuple[str, ...] = ("c",)


#: ``nlobs export``.
EXPORT_JSON = Record("Export", {
    "model": STRING, "observer": STRING, "certified": BOOLEAN,
    "certificate": STRING.about("what the header's comment says the design rests on"),
    "files": array(STRING), "module": EXPORTED_MODULE_JSON, "verdict": VERDICT_JSON, "message": STRING,
    "design": nullable(DESIGN_JSON),
}, description="An observer's design written as dependency-free C99, its certificate in the header.")


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
    design : Design or None
        The method's design (:class:`nlobs.methods.base.Design`; ``None`` for ``setvalued`` and
        ``gnss-ins``); ``to_dict()`` is the ``design`` key.
    """

    model: str
    observer: str
    certified: bool
    certificate: str
    files: tuple[Path, ...]
    exported: Any = field(repr=False)
    verdict: Verdict = Verdict.OK
    message: str = ""
    design: Any = field(default=None, repr=False)

    def summary(self) -> str:
        """What was written, and on which certificate."""
        ex = self.exported
        lines = [f"{self.model}: {ex.program.title} written as C99",
                 *(f"  {p}" for p in self.files),
                 f"  compiled with -Wall -Wextra -Werror -std=c99 -pedantic by {ex.checked_with}" if ex.checked_with
                 else "  not compiled: no C compiler was found (pip install 'nlobs[codegen]')",
                 "  certificate: " + ("verified" if self.certified else "none (a Kalman filter carries no convergence "
                                      "guarantee)" if self.verdict is Verdict.OK else "NOT certified")]
        lines += ["    " + ln for ln in self.certificate.splitlines()]
        return "\n".join(lines)  # the message, when FAILED, is the command's one line

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready view (``schema_version`` first)."""
        return with_schema(EXPORT_JSON.emit({
            "model": self.model, "observer": self.observer, "certified": self.certified,
            "certificate": self.certificate, "files": [str(p) for p in self.files],
            "module": self.exported.to_dict(), "verdict": self.verdict.value, "message": self.message,
            "design": None if self.design is None else self.design.to_dict()}))


def _certificate_text(design: Any, title: str) -> str:
    """What the header's comment block says the design rests on: the method, its certificate, its premises."""
    lines = [title, design.description]
    if design.defaults_text():
        lines.append(f"defaults: {design.defaults_text()}")
    if design.certificate is not None:
        lines.append(design.certificate.summary())
    lines += [f"{p.name}: {'passed' if p.passed else 'FAILED'}: {p.evidence}" for p in design.premises]
    lines += [f"{u}: not checked" for u in design.unchecked]
    return "\n".join([*lines, *design.details])


def _method_design(method: Any, pb: Any, options: dict[str, Any], saturation: bool | None) -> tuple[Any, bool, str, str, Any]:
    """The registry method's design for the export: observer, certified, header text, why not, the Design."""
    from nlobs.errors import AssumptionViolated

    why = method.applies(pb)
    if why is not None:
        raise AssumptionViolated(f"{method.name}: {why}")
    if "saturation" in method.options:
        # the design commands' defaults: the drift observer saturated on its region; pinv when a region was given
        given_region = pb.sources.get("region") in ("given", "[simulation] box")
        options = {**options, "saturation": (True if method.name == "drift" else given_region)
                   if saturation is None else saturation}
    elif saturation is not None:
        raise InvalidArgumentError(f"`saturation` does not apply to the {method.name} observer")
    design = method.design(pb, **options)
    title = design.theorem or method.title
    why_not = "" if design.certified else design.status
    text, obs = _certificate_text(design, title), design.observer
    if getattr(obs, "bounds", None) is not None:  # the generated C has no projection onto the model's bounds
        obs = dataclasses.replace(obs, bounds=None)
        text += ("\nnot in this C: the projection of the mean onto the model file's [constraints] after each "
                 "correction (clip the estimate to them in the calling code)")
    return obs, design.certified, text, why_not, design


_NO_GUARANTEE = "none: a Kalman filter carries no convergence guarantee"


def _navigation_ekf(out: str | Path, prefix: str | None, box: Any, saturation: bool | None,
                    options: dict[str, Any]) -> ExportReport:
    """The demo's navigation EKF, the baseline of observer (24), as C.

    ``export_model_observer("gnss-ins", observer="ekf")``.
    """
    from nlobs.export import export_observer
    from nlobs.methods.gnss_ins import DemoConfig, demo_ekf
    from nlobs.navigation.trajectory import traffic_pattern

    given = [f"`{k}`" for k, v in (("box", box), ("saturation", saturation), *options.items()) if v is not None]
    if given:
        raise InvalidArgumentError(f"{', '.join(given)}: not an option of the navigation EKF (it takes none)")
    config = DemoConfig()
    ekf = demo_ekf(config, traffic_pattern(seed=config.seed))
    text = ("navigation EKF of the GNSS/INS demo (error state, multiplicative attitude), tuned to the demo's sensor "
            "noise: the baseline of observer (24) of Grip, Saberi & Johansen (Sec. 5)")
    res = export_observer(ekf, out, prefix=prefix or "gnss_ins_ekf",
                          notes=(("certificate", _NO_GUARANTEE), ("rests on", text)))
    return ExportReport("gnss-ins", "ekf", False, text, (res.header, res.source), res, Verdict.OK, "", None)


def export_model_observer(model: Any, *, observer: str, out: str | Path, lang: str = "c",
                          box: Sequence[float] | Any | None = None, saturation: bool | None = None,
                          prefix: str | None = None, **options: Any) -> ExportReport:
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
    **options
        Design options of the method, as ``nlobs design`` takes them (``mu``, ``alpha``, ``theta``,
        ``gamma``, …; :mod:`nlobs.methods`); an option the method does not take is refused.

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
    from nlobs.methods.problem import problem
    from nlobs.methods.registry import get

    if lang not in LANGUAGES:
        raise InvalidArgumentError(f"`lang`: expected one of {', '.join(LANGUAGES)}, got {lang!r}")
    if observer not in EXPORTABLE:
        raise InvalidArgumentError(f"`observer`: expected one of {', '.join(EXPORTABLE)}, got {observer!r}")
    method = get(observer)
    unknown = sorted(set(options) - set(method.options))
    if unknown:
        named = ", ".join(f"`{u}`" for u in unknown)  # the keywords given: the command line's flags where it has them
        raise InvalidArgumentError(f"{named}: not a design option of the {observer} observer "
                                   f"(it takes {', '.join(sorted(method.options)) or 'none'})")
    if str(model) == "gnss-ins" and observer == "ekf":
        return _navigation_ekf(out, prefix, box, saturation, options)
    if box is not None and not method.uses_region:
        raise InvalidArgumentError(f"`box` does not apply to the {observer} observer")
    if observer == "gnss-ins":  # the demo's flight, not a model file
        pb: Any = str(model)
        name = "gnss-ins"
    else:
        pb = problem(model, box=box)
        name = pb.model.name
    try:
        obs, certified, text, why, design = _method_design(method, pb, dict(options), saturation)
    except NlobsError:
        raise
    except (TypeError, ValueError) as exc:  # a given option's value the method could not read
        if not options:
            raise
        raise InvalidArgumentError(f"{', '.join(sorted(options))}: {exc}") from exc
    from nlobs.methods.kalman import KalmanMethod

    filter_ = isinstance(method, KalmanMethod)  # a Kalman filter claims no certificate: none is missing
    notes = (("certificate", _NO_GUARANTEE if filter_ else
              ("verified" if certified else "NOT CERTIFIED") + (f" ({why})" if why else "")),
             ("certified on" if certified else "rests on", text))
    c_options = {"imu_period": design.parameters["imu_period"]} if observer == "gnss-ins" else None
    res = export_observer(obs, out, prefix=prefix or f"{name}_{observer}", notes=notes, options=c_options)
    verdict = Verdict.OK if certified or filter_ else Verdict.FAILED
    msg = "" if certified or filter_ else f"{name}: the {observer} design is not certified ({why}); the code was " \
                                          "written with that in its header"
    return ExportReport(name, observer, certified, text, (res.header, res.source), res, verdict, msg, design)
