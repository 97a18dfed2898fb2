r"""The observer *method*: how an observer kind is chosen, checked and designed (:class:`Method`, :class:`Design`).

The observer protocol (:mod:`nlobs.observers.base`) says how an observer runs. A :class:`Method` says
how one kind of observer is made for a model: whether it applies (:meth:`Method.applies`, a reason
when it does not) and its design (:meth:`Method.design`), which returns one :class:`Design`: the
observer, its certificate (or ``None``), the premises of its theorem as :class:`~nlobs.checks.Check`
objects, the premises nobody checked, the parameters actually used with their sources, and a
description. Every command that designs (``nlobs advise``, ``design``, ``export``, ``simulate``) calls
the method of the one registry (:mod:`nlobs.methods.registry`), so the same model file and options
give the same design everywhere, and :meth:`Design.to_dict` is the same ``design`` object in every
command's JSON.

Verdicts. A design is *usable* when nothing it checked failed (its gain exists and was re-verified,
its checked premises hold); it is *certified* only when it is usable, has a certificate, and every
premise of its theorem was checked: a premise that was not checked makes it not certified, listed
in :attr:`Design.unchecked`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from nlobs._schema import ANY, BOOLEAN, NUMBER, OBJECT, STRING, Record, array, mapping, nullable, one_of
from nlobs.checks import CHECK_JSON, Check
from nlobs.methods.problem import Problem

__all__ = ["Design", "Method"]


def _plain(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


@dataclass(frozen=True, eq=False)
class Design:
    """One method's design for one model: the observer and everything it rests on.

    Attributes
    ----------
    method : str
        The method's name in the registry (``"drift"``, ``"luenberger"``, …).
    observer : Observer
        The observer, ready to run (:mod:`nlobs.observers`).
    certificate : Certificate or None
        The gain's certificate, re-verified without the solver (``None``: the method has none).
    premises : tuple of Check
        The premises of the method's theorem that were checked, passed or failed.
    unchecked : tuple of str
        The premises nobody checked (each makes the design not certified).
    parameters : mapping of str to value
        The parameters actually used (``mu``, ``alpha``, ``w``, ``theta``, ``gamma``, ``region``, …).
    sources : mapping of str to str
        Where each parameter that came from a default was taken from (``"mu": "max ‖u(t)‖ of
        [input_signals] over [0, 10]"``).
    description : str
        What was designed, in one line.
    gain : ndarray or None
        The gain (``K``, ``L``, the coefficients ``k``…; ``None`` for a filter without one).
    failed : tuple of str
        Why the design is not usable (empty when it is).
    hypotheses : tuple
        What a run must stay inside to be covered (:mod:`nlobs.simulate.coverage`), for the
        simulation of this problem's sensors and noise.
    coverage_extras : mapping
        Values reported beside the coverage of a run (e.g. the region and ``μ``).
    report : Any
        The method's full design report (what ``nlobs design`` prints), when it has one.
    warnings : tuple of str
        What a user should know before trusting a run (e.g. states a filter cannot see).
    theorem : str
        What the certificate rests on, with the paper and its numbers (``"Dalla Mora, Germani & Manes,
        Theorem 3.1 on [-1, 1] × [-1, 1]"``); empty for a method without one.
    details : tuple of str
        More lines for a generated module's header (a bound's constants, the gain's notes).
    bound : SampledDataBound or None
        What the certificate guarantees under the problem's sensors and noise: the sampling budget and the
        mean-square error bound (:mod:`nlobs.synthesis.sampled_data`); ``None`` when the method states none.

    Examples
    --------
    The drift observer (3.1) of Dalla Mora, Germani & Manes for the shipped pendulum (``y = θ``) on
    the default region ``[−1, 1]²``: both checked premises of Theorem 3.1 hold and the gain of (2.17)
    was re-verified, so the design is certified; ``γ`` is the sampled Lipschitz constant
    ``√(g² + c²)`` of ``θ̈ = −g sin θ − c θ̇``:

    >>> from nlobs.methods.problem import problem
    >>> from nlobs.methods.registry import get
    >>> d = get("drift").design(problem("pendulum"), samples=200)
    >>> d.method, d.status, d.usable, d.verified, d.unchecked
    ('drift', 'certified', True, True, ())
    >>> [(p.name, p.passed) for p in d.premises]
    [('drift-observability', True), ('input bound μ of (2.17) covers the known input', True)]
    >>> d.parameters["s"], round(d.parameters["gamma"], 3), round((9.81**2 + 0.2**2) ** 0.5, 3), d.gain.shape
    ([2], 9.812, 9.812, (2, 1))
    >>> d.sources["mu"], d.to_dict()["certified"]
    ('no [input_signals]: zero input', True)

    A ``γ`` given below that constant leaves a gain, but not a usable design:

    >>> bad = get("drift").design(problem("pendulum"), gamma=1.0, samples=200)
    >>> bad.usable, bad.certified, bad.status
    (False, False, 'not usable: γ = 1 (given) is below the sampled √(γ_L² + γ_H²) = 9.812 on the region: ...')
    """

    method: str
    observer: Any
    certificate: Any
    premises: tuple[Check, ...]
    unchecked: tuple[str, ...]
    parameters: Mapping[str, Any]
    sources: Mapping[str, str]
    description: str
    gain: Any = None
    failed: tuple[str, ...] = ()
    hypotheses: tuple[Any, ...] = ()
    coverage_extras: Mapping[str, Any] = field(default_factory=dict)
    report: Any = field(default=None, repr=False)
    warnings: tuple[str, ...] = ()
    theorem: str = ""
    details: tuple[str, ...] = ()
    bound: Any = None

    @property
    def usable(self) -> bool:
        """Nothing that was checked failed (the gain exists and was re-verified, the checked premises hold)."""
        return not self.failed

    @property
    def verified(self) -> bool:
        """The certificate exists and was re-verified."""
        return self.certificate is not None and bool(self.certificate.verified)

    @property
    def certified(self) -> bool:
        """Usable, with a verified certificate, and every premise of the theorem checked and holding."""
        return self.usable and self.verified and not self.unchecked and all(p.passed for p in self.premises)

    @property
    def status(self) -> str:
        """``"certified"``, ``"not certified: …"`` with the unchecked premises, or ``"not usable: …"``."""
        if not self.usable:
            return "not usable: " + "; ".join(self.failed)
        if self.certified:
            return "certified"
        why = [f"{p.name} fails ({p.evidence})" for p in self.premises if not p.passed]
        if self.unchecked:
            why.append(f"{', '.join(self.unchecked)} not checked")
        if self.certificate is None:
            why.append("the method has no certificate")
        elif not self.verified:
            why.append("the certificate failed its re-verification")
        return "not certified: " + "; ".join(why)

    def to_dict(self) -> dict[str, Any]:
        """The ``design`` object of every command's JSON (the README's JSON section)."""
        return DESIGN_JSON.emit({
            "method": self.method,
            "parameters": {k: _plain(v) for k, v in self.parameters.items()},
            "sources": dict(self.sources),
            "gain": None if self.gain is None else _plain(np.asarray(self.gain, dtype=float)),
            "certified": self.certified,
            "usable": self.usable,
            "status": self.status,
            "premises": [p.to_dict() for p in self.premises],
            "unchecked": list(self.unchecked),
            "failed": list(self.failed),
            "warnings": list(self.warnings),
            "description": self.description,
            "sampled": None if self.bound is None else self.bound.to_dict(),
        })

    def defaults_text(self) -> str:
        """The parameters that have a source, each with it: ``"μ = 10.3 (max ‖u(t)‖ of [input_signals] over [0,
        10]); region = [-2, 2] × [-3, 3] ([simulation] box)"`` (empty when none has one)."""
        return "; ".join(f"{_symbol(k)} = {_fmt_param(k, self.parameters[k])} ({src})"
                         for k, src in self.sources.items() if k in self.parameters)

    def summary(self) -> str:
        """The parameters with their sources, and the verdict, as text."""
        params = ", ".join(f"{k} = {_fmt(v)}" + (f" ({self.sources[k]})" if k in self.sources else "")
                           for k, v in self.parameters.items())
        return "\n".join([f"{self.method}: {self.description}", f"  parameters: {params}", f"  {self.status}",
                          *(f"  warning: {w}" for w in self.warnings)])


def _symbol(name: str) -> str:
    return {"mu": "μ", "alpha": "α", "gamma": "γ", "theta": "θ"}.get(name, name)


def _fmt_param(name: str, v: Any) -> str:
    v = _plain(v)
    if name == "region" and isinstance(v, list) and all(isinstance(p, list) and len(p) == 2 for p in v):
        return " × ".join(f"[{a:g}, {b:g}]" for a, b in v)
    return _fmt(v)


def _fmt(v: Any) -> str:
    v = _plain(v)
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


#: The ``design`` object of every command that designs (``nlobs simulate``, ``advise``, ``export``, ``design``).
DESIGN_JSON = Record("Design", {
    "method": STRING.about("the method: drift, pinv, luenberger, cascade, ekf, ukf, setvalued"),
    "parameters": mapping(ANY, "the parameters actually used (they depend on the method)"),
    "sources": mapping(STRING, "where each default came from"),
    "gain": nullable(one_of(NUMBER, array(one_of(NUMBER, array(NUMBER)))), "the gain (a constant gain's entries)"),
    "certified": BOOLEAN.about("usable, with a verified certificate and every premise checked and holding"),
    "usable": BOOLEAN.about("nothing that was checked failed"),
    "status": STRING.about("'certified', 'not certified: …' or 'not usable: …'"),
    "premises": array(CHECK_JSON, "the theorem's premises, each checked"),
    "unchecked": array(STRING, "premises not checked"),
    "failed": array(STRING, "what failed"),
    "warnings": array(STRING),
    "description": STRING,
    "sampled": nullable(OBJECT, "the bound under the file's sensors (sampling periods, noise), when computed"),
}, description="A method's design with its certificate's verdict (nlobs.methods.Design).")


def joined_design_json(title: str, own: Record) -> Record:
    """The ``design`` object of ``nlobs design drift|pinv|cascade``: the report's own keys joined to the method's
    :data:`DESIGN_JSON` (whose keys are absent when the method's design was not made).

    Parameters
    ----------
    title : str
        The record's name.
    own : Record
        The report's own design keys.

    Returns
    -------
    Record
    """
    return Record(title, {**DESIGN_JSON.fields, **own.fields},
                  optional=(set(DESIGN_JSON.fields) - set(own.fields)) | own.optional,
                  description=f"{own.description or own.title}, joined to the method's design object")


@runtime_checkable
class Method(Protocol):
    """One kind of observer: whether it applies to a problem, and its design.

    Attributes
    ----------
    name : str
        The name every command and workflow uses (``observers=[NAME]`` of
        :func:`~nlobs.workflows.compare.compare_observers`, ``observer=NAME`` of
        :func:`~nlobs.workflows.export.export_model_observer`).
    title : str
        The method with its paper and equation numbers, for help and reports.
    options : frozenset of str
        The design options :meth:`design` accepts (an option a method does not take is refused by the
        commands with its name).
    uses_region : bool
        The design reads the problem's region (a box given to a method that does not is refused).

    Examples
    --------
    Every method of the registry satisfies the protocol; :meth:`applies` says why a method does not
    fit a model before any design is tried:

    >>> from nlobs.methods.problem import problem
    >>> from nlobs.methods.registry import get
    >>> drift = get("drift")
    >>> isinstance(drift, Method), drift.name, drift.uses_region, "mu" in drift.options
    (True, 'drift', True, True)
    >>> drift.applies(problem("pendulum")) is None
    True
    >>> drift.applies(problem("gnss-ins-axis"))
    '(3.1) of Dalla Mora, Germani & Manes is for nonlinear input-affine models; this one is linear'
    """

    name: str
    title: str
    uses_region: bool
    options: frozenset[str]

    def applies(self, problem: Problem) -> str | None:
        """``None`` when the method applies to the problem, else why not (one line)."""
        ...

    def design(self, problem: Problem, **options: Any) -> Design:
        """The design for the problem (raises :class:`~nlobs.errors.DesignError` when no gain exists)."""
        ...
