"""Typed exceptions raised by nlobs.

Every exception derives from :class:`NlobsError`; those about bad arguments also
derive from :class:`ValueError` so that generic callers can catch them as such.
Messages always name the offending quantity (and, where there is one, the file,
line, time or constraint) so a user can act on them without a debugger.
"""

from __future__ import annotations


class NlobsError(Exception):
    """Base class of every error nlobs raises on purpose."""


class DimensionError(NlobsError, ValueError):
    """An array has the wrong shape or two arrays disagree in size."""


class NonFiniteError(NlobsError, ValueError):
    """An array holds NaN or infinite entries where finite numbers are required."""


class NotSymmetricError(NlobsError, ValueError):
    """A matrix that must be symmetric is not (beyond a relative tolerance)."""


class InvalidArgumentError(NlobsError, ValueError):
    """An argument has an invalid value (negative bound, unknown option, ...)."""


class UnknownNameError(NlobsError, ValueError):
    """A name (state, input, parameter, option, example) is not known."""


class ModelError(NlobsError, ValueError):
    """A model is inconsistent (duplicate names, free symbols, wrong time base...)."""


class ModelFileError(ModelError):
    """A model file cannot be parsed or validated.

    Attributes
    ----------
    path : str
        The file.
    line : int or None
        1-based line number of the offending text, when known.
    text : str
        The offending text (an expression, a key), possibly empty.
    """

    def __init__(self, path: str, line: int | None, text: str, reason: str) -> None:
        self.path = path
        self.line = line
        self.text = text
        self.reason = reason
        where = f"{path}:{line}" if line is not None else path
        shown = f": {text!r}" if text else ""
        super().__init__(f"{where}: {reason}{shown}")


class SignalFileError(ModelFileError):
    """A file of sampled input signals (CSV) cannot be read or validated.

    The message is one line, ``FILE:LINE: reason``, where the reason quotes the offending text
    (e.g. ``u.csv:7: column 'tau': 'nan' is not a finite number``); the attributes are those of
    :class:`ModelFileError`.
    """

    def __init__(self, path: str, line: int | None, text: str, reason: str) -> None:
        super().__init__(path, line, "", reason)
        self.text = text


class DesignError(NlobsError):
    """Base class of gain-synthesis failures."""


class DesignInfeasible(DesignError):
    """The design problem has no solution, or the solver could not find one.

    Attributes
    ----------
    constraint : str
        Name of the constraint (LMI block) that fails, when it can be identified.
    violation : float or None
        By how much it fails (e.g. the largest eigenvalue of a block that must
        be negative definite), when known.
    """

    def __init__(self, message: str, *, constraint: str = "", violation: float | None = None) -> None:
        self.constraint = constraint
        self.violation = violation
        super().__init__(message)


class DesignUnbounded(DesignError):
    """The requested optimum is not attained: the gains grow without bound.

    Raised instead of returning a huge gain that merely reflects the solver's
    strictness margin (see ``docs/synthesis.md``).
    """


class CertificateError(DesignError):
    """A solver answer failed the independent re-verification of its certificate."""


class SimulationDiverged(NlobsError, ArithmeticError):
    """A simulated state became non-finite.

    Attributes
    ----------
    time : float
        Simulation time at which the non-finite value was first seen.
    which : str
        ``"plant"`` or ``"observer"``.
    state : str
        Name of the first non-finite state component.
    detail : str
        What is known about the cause (e.g. the RK4 stability of the step for the gain, peaking).
    """

    def __init__(self, time: float, which: str, state: str, detail: str = "") -> None:
        self.time = time
        self.which = which
        self.state = state
        self.detail = detail
        super().__init__(f"simulation diverged at t={time:g}: {which} state {state!r} is not finite"
                         + (f"; {detail}" if detail else ""))


class AssumptionViolated(DesignError):
    """A structural assumption of a design method fails (e.g. Assumption 4 of Grip, Saberi & Johansen).

    Attributes
    ----------
    item : str
        Key of the failed item (e.g. ``"no_zero_at_origin"``).
    evidence : str
        The numbers behind the verdict.
    """

    def __init__(self, message: str, *, item: str = "", evidence: str = "") -> None:
        self.item = item
        self.evidence = evidence
        super().__init__(message)


class OutputError(NlobsError, OSError):
    """An output file or folder cannot be written (an existing file where a folder is needed, read-only, full disk).

    Nothing is left half-written: every output of nlobs is written atomically.
    """


class StudyFailed(NlobsError):
    """A simulation study a workflow ran (one simulation or Monte Carlo runs) could not be completed.

    The cause is chained and named in the message. A divergence of a single simulation is
    :class:`SimulationDiverged` instead.
    """


class NumericalError(NlobsError, ArithmeticError):
    """A result cannot be trusted in double precision: it failed its a-posteriori accuracy check.

    Raised instead of returning a number that is known to be wrong (a Gramian whose Lyapunov
    residual is not small, data whose magnitude overflows the computation). The message names
    the quantity and the measured residual or magnitude.
    """


class ExpressionTooLarge(NlobsError, ValueError):
    """A symbolic computation would build an expression beyond nlobs's size budget.

    Raised *before* SymPy differentiates, simplifies or compiles it (a short model text, such as
    ``sin(sin(…sin(x)…))`` nested 99 deep, has Lie derivatives of millions of terms, whose
    construction would run for minutes). The message names the quantity and the limit
    (:data:`nlobs.geometry.lie.MAX_DERIVATIVE_NODES`).
    """


class ProblemTooLarge(InvalidArgumentError):
    """A numerical problem (an SDP) would exceed nlobs's memory budget; refused *before* it is built.

    The message names the problem's size (variables, semidefinite cones, the estimated memory of the
    interior-point solver), the limit, and what to change (e.g. drop a pole region or gain bound so
    that the Riccati path applies, or reduce the model). A subclass of
    :class:`InvalidArgumentError`, so the command line reports it in one line with exit 2.
    """


class CompilerError(NlobsError, RuntimeError):
    """Generated C could not be compiled or loaded: no C compiler was found, or the compiler failed.

    The message names the compiler tried (or the ones looked for) and the first lines of its
    diagnostics. Install the ``codegen`` extra (``pip install nlobs[codegen]``, a C compiler from the
    package index), put ``cc`` on the ``PATH``, or name one with the ``NLOBS_CC`` environment variable.
    """
