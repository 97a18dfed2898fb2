"""One verdict type for every check nlobs makes: :class:`Check`, with its :class:`CheckKind`.

A :class:`Check` is a single verdict with the evidence behind it. Two kinds of verdict exist:

* a **comparison** — a recomputed number against its bound, ``value < limit`` (``strict``) or
  ``value ≤ limit``, built by :meth:`Check.compare`; ``passed`` follows from the numbers
  (a non-finite ``value`` never passes), :attr:`Check.margin` says by how much;
* a **verdict** — a decision reached otherwise (a symbolic proof, a rank at sampled points, a
  structural count), built by :meth:`Check.verdict` with the evidence a user can read.

Reports that aggregate several verdicts (an assumption item by item, a design report) stay their
own frozen classes and *hold* ``Check`` objects. Certificates of gain designs expose their checks
through :class:`nlobs.synthesis.certificate.Certificate`.

This module is part of the core layer: it imports only NumPy, the standard library and
:mod:`nlobs.errors`, so that every layer (``systems``, ``geometry``, ``linear``, ``synthesis``, …)
returns the same type.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np

from nlobs._frozen import FrozenMapping
from nlobs._schema import ANY, BOOLEAN, NUMBER, STRING, Record, array, enum, mapping, nullable
from nlobs.errors import InvalidArgumentError

__all__ = ["CheckKind", "Check", "Verdict"]


class CheckKind(Enum):
    """What a :class:`Check` verifies (how it was decided is :attr:`Check.method`).

    Examples
    --------
    A spectrum check: the closed-loop matrix ``A`` with eigenvalues −1 and −2 is Hurwitz, by a margin of 1;
    the kind is written to JSON by its value, and read back from it:

    >>> import numpy as np
    >>> A = np.array([[0.0, 1.0], [-2.0, -3.0]])
    >>> c = Check.compare("A Hurwitz (max Re λ)", max(np.linalg.eigvals(A).real), 0.0, kind=CheckKind.SPECTRUM)
    >>> c.passed, round(c.margin, 6), c.to_dict()["kind"]
    (True, 1.0, 'spectrum')
    >>> CheckKind("spectrum") is CheckKind.SPECTRUM, [k.value for k in CheckKind][:4]
    (True, ['lmi', 'positivity', 'spectrum', 'region'])
    """

    LMI = "lmi"
    """Largest eigenvalue of a symmetrised LMI block against its bound (``< 0`` or ``< −ε``)."""
    POSITIVITY = "positivity"
    """``−λ_min(P) < 0``: a Lyapunov matrix is positive definite."""
    SPECTRUM = "spectrum"
    """Closed-loop eigenvalues: ``max Re λ < 0`` (Hurwitz) or a spectral radius below its bound."""
    REGION = "region"
    """``−margin`` of the closed-loop eigenvalues to a pole region, ``< 0``."""
    NORM = "norm"
    """An H∞ norm recomputed from the gain against its bound."""
    GAIN = "gain"
    """``‖gain‖₂`` against a gain bound."""
    RANK = "rank"
    """Full rank (nonsingularity) of a matrix: ``Q_s``, ``Q``, a Rosenbrock pencil, a rank condition."""
    STRUCTURAL = "structural"
    """A structural property: detectability, invariant zeros, involutivity, a multi-index condition."""
    FUNCTION_CLASS = "function_class"
    """A nonlinearity against its stated class (Lipschitz, quadratic constraint, LPV), on sampled pairs."""


def _plain(v: Any) -> Any:
    """``v`` as plain Python (JSON types): arrays and tuples as lists, complex as ``[re, im]``."""
    if isinstance(v, Mapping):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, np.ndarray):
        return [_plain(x) for x in v.tolist()]
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return _plain(v.item())
    if isinstance(v, complex):
        return [float(v.real), float(v.imag)]
    return v


def _holds(value: float, limit: float, strict: bool) -> bool:
    if not math.isfinite(value):
        return False
    return value < limit if strict else value <= limit


_EMPTY: Mapping[str, Any] = FrozenMapping({})


@dataclass(frozen=True, eq=False)
class Check:
    """A single verdict with its evidence.

    Build one with :meth:`compare` (a number against a bound) or :meth:`verdict` (a decision with
    its evidence); the fields below are what both record.

    Attributes
    ----------
    name : str
        What is checked, with the paper's equation or assumption where there is one
        (e.g. ``"LMI (14)"``, ``"A5 (involutive)"``, ``"‖H‖∞ < γ"``).
    passed : bool
        The verdict. For a comparison it is ``value < limit`` (``strict``) or ``value ≤ limit``,
        and ``False`` for a non-finite ``value``.
    evidence : str
        One line a user can read: the numbers behind the verdict. A comparison without one gets
        ``"value < limit"``.
    kind : CheckKind
        What is verified.
    method : str
        How it was decided: ``"symbolic"``, ``"numeric"``, ``"structural"``, ``"sampled"``,
        ``"intermediate value"``, …
    value : float or None
        The recomputed or measured quantity (a largest eigenvalue, a norm, a smallest singular
        value, a worst margin).
    limit : float or None
        Its bound (for a comparison), or the threshold it is read against.
    strict : bool or None
        Whether the comparison is strict; ``None`` for a verdict that is not a comparison.
    required : bool
        ``False`` for an informational item that does not decide the aggregate verdict.
    key : str
        Machine name (e.g. an assumption item's ``"rank_Bz_Dz"``); empty when there is none.
    values : Mapping
        The numbers behind the verdict in machine-readable form (read-only).
    worst_point : tuple of float or None
        The sampled point where the condition is closest to failing (or fails).
    symbolic : str or None
        A symbolic certificate where one was computed (e.g. ``det Q_s``).

    Notes
    -----
    The class is frozen; equality is identity (``values`` is a read-only mapping, not hashable).

    Examples
    --------
    A comparison: a recomputed norm against its bound (Grip, Saberi & Johansen, (14)); the verdict,
    the margin and the evidence follow from the numbers:

    >>> c = Check.compare("‖H‖∞ < γ", 0.8, 1.0, kind=CheckKind.NORM)
    >>> c.passed, round(c.margin, 3), c.evidence
    (True, 0.2, '0.8 < 1')
    >>> Check.compare("LMI (14)", 1e-3, 0.0, kind=CheckKind.LMI).summary()
    'LMI (14): 0.001 < 0 (FAILED by 0.001)'

    A verdict reached otherwise, with the evidence a user reads (no margin):

    >>> v = Check.verdict("A5 (involutive)", True, "[τ₁, τ₂] ∈ span{τ₁, τ₂}", kind=CheckKind.STRUCTURAL,
    ...                   method="symbolic")
    >>> v.summary(), v.is_comparison, v.method
    ('A5 (involutive): holds — [τ₁, τ₂] ∈ span{τ₁, τ₂}', False, 'symbolic')
    """

    name: str
    passed: bool
    evidence: str = ""
    kind: CheckKind = CheckKind.STRUCTURAL
    method: str = "numeric"
    value: float | None = None
    limit: float | None = None
    strict: bool | None = None
    required: bool = True
    key: str = ""
    values: Mapping[str, Any] = field(default_factory=lambda: _EMPTY)
    worst_point: tuple[float, ...] | None = None
    symbolic: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.kind, CheckKind):
            raise InvalidArgumentError(f"kind: expected a CheckKind, got {self.kind!r}")
        set_ = object.__setattr__
        set_(self, "passed", bool(self.passed))
        if self.value is not None:
            set_(self, "value", float(self.value))
        if self.limit is not None:
            set_(self, "limit", float(self.limit))
        set_(self, "values", FrozenMapping(dict(self.values)))
        if self.worst_point is not None:
            set_(self, "worst_point", tuple(float(v) for v in self.worst_point))
        if self.strict is not None:
            if self.value is None or self.limit is None:
                raise InvalidArgumentError(f"{self.name}: a comparison (strict={self.strict}) needs a value and a limit")
            set_(self, "strict", bool(self.strict))
            if self.passed != _holds(self.value, self.limit, self.strict):
                raise InvalidArgumentError(
                    f"{self.name}: passed={self.passed} contradicts {self.value:.6g} {self.relation} {self.limit:.6g}")
            if not self.evidence:
                set_(self, "evidence", f"{self.value:.6g} {self.relation} {self.limit:.6g}")

    # ------------------------------------------------------------------ constructors

    @classmethod
    def compare(cls, name: str, value: float, limit: float, *, kind: CheckKind, strict: bool = True,
                evidence: str = "", method: str = "numeric", required: bool = True, key: str = "",
                values: Mapping[str, Any] | None = None, worst_point: tuple[float, ...] | None = None,
                symbolic: str | None = None) -> Check:
        """A comparison: passes when ``value`` is finite and ``value < limit`` (``strict``) or ``value ≤ limit``.

        Parameters
        ----------
        name : str
            What is checked.
        value, limit : float
            The recomputed quantity and its bound.
        kind : CheckKind
        strict : bool
            Strict (``<``, default) or non-strict (``≤``) inequality.
        evidence, method, required, key, values, worst_point, symbolic
            As the attributes of :class:`Check`.

        Returns
        -------
        Check
        """
        v, lim = float(value), float(limit)
        return cls(name, _holds(v, lim, bool(strict)), evidence, kind, method, v, lim, bool(strict), required, key,
                   _EMPTY if values is None else values, worst_point, symbolic)

    @classmethod
    def verdict(cls, name: str, passed: bool, evidence: str, *, kind: CheckKind, method: str = "numeric",
                value: float | None = None, limit: float | None = None, required: bool = True, key: str = "",
                values: Mapping[str, Any] | None = None, worst_point: tuple[float, ...] | None = None,
                symbolic: str | None = None) -> Check:
        """A verdict reached otherwise than by one comparison, with its evidence.

        Parameters
        ----------
        name : str
            What is checked.
        passed : bool
            The verdict.
        evidence : str
            One line a user can read.
        kind : CheckKind
        method, value, limit, required, key, values, worst_point, symbolic
            As the attributes of :class:`Check` (``value``/``limit`` are informational here).

        Returns
        -------
        Check
        """
        return cls(name, bool(passed), evidence, kind, method, value, limit, None, required, key,
                   _EMPTY if values is None else values, worst_point, symbolic)

    # ------------------------------------------------------------------ derived

    @property
    def is_comparison(self) -> bool:
        """Whether the check is a comparison ``value < limit`` / ``value ≤ limit``."""
        return self.strict is not None

    @property
    def relation(self) -> str:
        """``"<"``, ``"≤"``, or ``""`` for a verdict that is not a comparison."""
        if self.strict is None:
            return ""
        return "<" if self.strict else "≤"

    @property
    def margin(self) -> float:
        """``limit − value`` (positive when a comparison passes: by how much); NaN for a verdict."""
        if self.strict is None or self.value is None or self.limit is None:
            return math.nan
        return float(self.limit - self.value)

    # ------------------------------------------------------------------ text and data

    def summary(self) -> str:
        """One line: ``"name: value < limit (ok | FAILED by x)"`` or ``"name: holds/FAILS — evidence"``."""
        if self.is_comparison:
            verdict = "ok" if self.passed else f"FAILED by {-self.margin:.3g}"
            return f"{self.name}: {self.value:.6g} {self.relation} {self.limit:.6g} ({verdict})"
        head = f"{self.name}: {'holds' if self.passed else 'FAILS'}"
        return f"{head} — {self.evidence}" if self.evidence else head

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view (JSON types; a non-finite ``value`` stays a float for the caller to sanitise).

        ``"holds"`` repeats ``"passed"``: it is the key that the geometric and assumption reports
        have always written.
        """
        return CHECK_JSON.emit({
            "name": self.name,
            "passed": self.passed,
            "holds": self.passed,
            "kind": self.kind.value,
            "method": self.method,
            "evidence": self.evidence,
            "value": self.value,
            "limit": self.limit,
            "strict": self.strict,
            "required": self.required,
            "key": self.key,
            "values": _plain(self.values),
            "worst_point": None if self.worst_point is None else list(self.worst_point),
            "symbolic": self.symbolic,
        })


#: The JSON of a :class:`Check` (``premises``, ``a1``, ``class_check`` … of the reports).
CHECK_JSON = Record("Check", {
    "name": STRING.about("what is checked, e.g. 'LMI (14)'"),
    "passed": BOOLEAN,
    "holds": BOOLEAN.about("the same as passed"),
    "kind": enum(*(k.value for k in CheckKind)),
    "method": STRING.about("how it was decided"),
    "evidence": STRING,
    "value": NUMBER.about("the measured quantity (null: none, or not finite)"),
    "limit": NUMBER.about("the bound it is compared with (null: none)"),
    "strict": nullable(BOOLEAN),
    "required": BOOLEAN,
    "key": STRING,
    "values": mapping(ANY, "further named values of the check"),
    "worst_point": nullable(array(NUMBER)),
    "symbolic": nullable(STRING),
}, description="One verdict with its evidence (nlobs.checks.Check).")


class Verdict(Enum):
    """What a report concluded, in the words the CLI turns into exit statuses (``OK`` 0, ``FAILED`` 1, ``NO_OBSERVER`` 3).

    Examples
    --------
    The drift observer (3.1) of Dalla Mora, Germani & Manes exists for the shipped pendulum; for the shipped
    ``khajenejad-6-2`` no set-valued observer of the requested structure exists, and the report says why:

    >>> from nlobs.methods.setvalued import design_setvalued_observer
    >>> from nlobs.workflows.design_drift import design_drift_observer
    >>> design_drift_observer("pendulum").verdict
    <Verdict.OK: 'ok'>
    >>> rep = design_setvalued_observer("khajenejad-6-2", samples=2000)
    >>> rep.verdict, rep.verdict.value
    (<Verdict.NO_OBSERVER: 'no observer'>, 'no observer')
    >>> print(rep.message)
    khajenejad-6-2: no stable observer of this structure exists (a linear member of the class is not ...
    >>> Verdict("failed") is Verdict.FAILED
    True
    """

    OK = "ok"
    """Everything asked for was done and holds (a design is usable, a guarantee held)."""
    FAILED = "failed"
    """A design is not usable, a certificate failed, or a guarantee was violated (exit status 1)."""
    NO_OBSERVER = "no observer"
    """No observer of the requested structure exists for this model (exit status 3)."""


#: The JSON of a :class:`Verdict` (the reports' ``verdict``).
VERDICT_JSON = enum(*(v.value for v in Verdict))
