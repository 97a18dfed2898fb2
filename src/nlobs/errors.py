"""Typed exceptions raised by nlobs.

Every exception derives from :class:`NlobsError`; those about bad arguments also
derive from :class:`ValueError` so that generic callers can catch them as such.
Messages always name the offending quantity (and, where there is one, the file,
line, time or constraint) so a user can act on them without a debugger.
"""

from __future__ import annotations


class NlobsError(Exception):
    """Base class of every error nlobs raises on purpose.

    Examples
    --------
    One ``except`` clause catches every deliberate refusal, whatever its kind; the errors about bad
    arguments are also :class:`ValueError`, a divergence an :class:`ArithmeticError`:

    >>> import nlobs
    >>> from nlobs.systems.modelfile import load_model
    >>> for bad in (lambda: load_model("no-such-model"),
    ...             lambda: nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0, 0.0]])):
    ...     try:
    ...         bad()
    ...     except NlobsError as exc:
    ...         print(type(exc).__name__, isinstance(exc, ValueError))
    ModelFileError True
    DimensionError True
    >>> issubclass(SimulationDiverged, ArithmeticError), issubclass(DesignInfeasible, ValueError)
    (True, False)
    """


class DimensionError(NlobsError, ValueError):
    """An array has the wrong shape or two arrays disagree in size.

    Examples
    --------
    A measurement matrix ``C`` with three columns for a system of two states:

    >>> import nlobs
    >>> try:
    ...     nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0, 0.0]])
    ... except DimensionError as exc:
    ...     print(type(exc).__name__, "-", exc)
    DimensionError - C: expected shape (?, 2), got (1, 3)
    """


class NonFiniteError(NlobsError, ValueError):
    """An array holds NaN or infinite entries where finite numbers are required.

    Examples
    --------
    A NaN in the system matrix; the message names the entry:

    >>> import numpy as np
    >>> import nlobs
    >>> try:
    ...     nlobs.LinearSystem([[0.0, 1.0], [-2.0, np.nan]], [[0.0], [1.0]], [[1.0, 0.0]])
    ... except NonFiniteError as exc:
    ...     print(type(exc).__name__, "-", exc)
    NonFiniteError - A: entry (1, 1) is ...nan...; all entries must be finite
    """


class NotSymmetricError(NlobsError, ValueError):
    """A matrix that must be symmetric is not (beyond a relative tolerance).

    Examples
    --------
    A noise covariance of two channels written with one off-diagonal entry only; the message names the
    sensor, the argument and the asymmetry:

    >>> from nlobs.systems.sensors import MeasurementGroup
    >>> try:
    ...     MeasurementGroup("gnss", ["y1", "y2"], rate=5.0, noise_cov=[[1.0, 0.5], [0.0, 1.0]])
    ... except NotSymmetricError as exc:
    ...     print(type(exc).__name__, "-", exc)
    NotSymmetricError - measurement group 'gnss': noise_cov: not symmetric (max |M - M^T| = 0.5)
    """


class InvalidArgumentError(NlobsError, ValueError):
    """An argument has an invalid value (negative bound, unknown option, ...).

    Examples
    --------
    A sine input of frequency zero; like every error about a bad argument it is also a :class:`ValueError`:

    >>> from nlobs.systems.signals import Sine
    >>> try:
    ...     Sine(amplitude=1.0, frequency=0.0)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(isinstance(exc, ValueError))
    InvalidArgumentError - Sine.frequency: must be positive (in Hz), got 0.0
    True
    """


class UnknownNameError(NlobsError, ValueError):
    """A name (state, input, parameter, option, example) is not known.

    Examples
    --------
    A misspelt parameter of the shipped pendulum; the message lists the known ones:

    >>> from nlobs.systems.modelfile import load_model
    >>> try:
    ...     load_model("pendulum").compile({"mas": 0.5})
    ... except UnknownNameError as exc:
    ...     print(type(exc).__name__, "-", exc)
    UnknownNameError - pendulum: no parameter named 'mas' (known: ['c', 'g', 'l', 'mass'])
    """


class ModelError(NlobsError, ValueError):
    """A model is inconsistent (duplicate names, free symbols, wrong time base...).

    Examples
    --------
    The drift observer (3.1) of Dalla Mora, Germani & Manes needs a nonlinear model; the shipped
    ``grip-example1-filter`` is linear:

    >>> from nlobs.workflows.design_drift import design_drift_observer
    >>> try:
    ...     design_drift_observer("grip-example1-filter")
    ... except ModelError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ModelError - a nonlinear (symbolic) model is needed; this one is linear
    >>> issubclass(ModelFileError, ModelError)  # an invalid file is an invalid model
    True
    """


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

    Examples
    --------
    A model file whose ``f`` uses a name it never declares; the error names the file, the line and the text:

    >>> from nlobs.systems.modelfile import load_model, parse_model
    >>> text = '''name = "bad"
    ... time = "continuous"
    ... states = ["x"]
    ... outputs = ["y"]
    ... [dynamics]
    ... f = ["-x + k"]
    ... h = ["x"]
    ... '''
    >>> try:
    ...     parse_model(text, source="bad.toml")
    ... except ModelFileError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(exc.path, exc.line, repr(exc.text))
    ModelFileError - bad.toml:6: [dynamics].f: undeclared name: 'k'
    bad.toml 6 'k'
    >>> try:
    ...     load_model("no-such-model")
    ... except ModelFileError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ModelFileError - no-such-model: no such file (shipped models: ball-and-beam, cartpole, ...)
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

    Examples
    --------
    A CSV file of a torque input whose second sample is not a number:

    >>> import shutil
    >>> import tempfile
    >>> from pathlib import Path
    >>> from nlobs.systems.signals import read_signal_csv
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "u.csv").write_text("t,tau\\n0.0,0.0\\n0.5,nan\\n", encoding="utf-8")
    >>> try:
    ...     read_signal_csv(folder / "u.csv")
    ... except SignalFileError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(Path(exc.path).name, exc.line, repr(exc.text))
    SignalFileError - ...u.csv:3: column 'tau': 'nan' is not a finite number
    u.csv 3 'nan'
    >>> shutil.rmtree(folder)
    """

    def __init__(self, path: str, line: int | None, text: str, reason: str) -> None:
        super().__init__(path, line, "", reason)
        self.text = text


class DesignError(NlobsError):
    """Base class of gain-synthesis failures.

    Examples
    --------
    Whatever the reason a design fails (no solution, a failed certificate, a broken assumption), one
    ``except DesignError`` catches it; here a given gain that makes ``A − K C`` unstable:

    >>> import numpy as np
    >>> from nlobs.synthesis.observer_gain import verify_observer_gain
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> try:
    ...     verify_observer_gain(A, C, Bd, [[-1.0], [0.0]], gamma=10.0)
    ... except DesignError as exc:
    ...     print(type(exc).__name__)
    CertificateError
    >>> [issubclass(e, DesignError) for e in (DesignInfeasible, DesignUnbounded, CertificateError, AssumptionViolated)]
    [True, True, True, True]
    """


class DesignInfeasible(DesignError):
    """The design problem has no solution, or the solver could not find one.

    Attributes
    ----------
    constraint : str
        Name of the constraint (LMI block) that fails, when it can be identified.
    violation : float or None
        By how much it fails (e.g. the largest eigenvalue of a block that must
        be negative definite), when known.

    Examples
    --------
    LMIs (14), (15) of Grip, Saberi & Johansen asked of a pair ``(A, C)`` with an unmeasured unstable mode:
    no gain exists for any ``γ``, and the error says why:

    >>> import numpy as np
    >>> from nlobs.synthesis.observer_gain import design_observer_gain
    >>> A, C, Bd = np.eye(2), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> try:
    ...     design_observer_gain(A, C, Bd, gamma=10.0, gamma_n=10.0)
    ... except DesignInfeasible as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(exc.constraint, exc.violation)
    DesignInfeasible - (A, C) is not detectable: the mode λ = 1+0j (Re λ ≥ 0) is unobservable ...
    detectability 1.0
    """

    def __init__(self, message: str, *, constraint: str = "", violation: float | None = None) -> None:
        self.constraint = constraint
        self.violation = violation
        super().__init__(message)


class DesignUnbounded(DesignError):
    """The requested optimum is not attained: the gains grow without bound.

    Raised instead of returning a huge gain that merely reflects the solver's
    strictness margin (see ``docs/synthesis.md``).

    Examples
    --------
    The smallest ``γ`` of LMI (14) of Grip, Saberi & Johansen for a pair without invariant zeros: the
    infimum ``γ* = 0`` is approached only as the gain grows without bound, so no minimum exists and no
    gain is returned; the message gives the numbers at two strictness margins and what to ask instead:

    >>> import numpy as np
    >>> from nlobs.synthesis.observer_gain import design_observer_gain
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> try:
    ...     design_observer_gain(A, C, Bd, objective="min_gamma")
    ... except DesignUnbounded as exc:
    ...     print(type(exc).__name__, "-", exc)
    DesignUnbounded - minimising γ² subject to LMIs (14) has no minimum here: the optimum is set by the strictness
    margin ε, not by the problem. ... or pass gain_bound=GainBound(κ) so that the minimum is attained.
    """


class CertificateError(DesignError):
    """A solver answer failed the independent re-verification of its certificate.

    Examples
    --------
    A given gain checked against LMI (14) of Grip, Saberi & Johansen: ``A − K C`` has an eigenvalue at
    0.25, so no certificate holds, and the message lists the failed checks:

    >>> import numpy as np
    >>> from nlobs.synthesis.observer_gain import verify_observer_gain
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> try:
    ...     verify_observer_gain(A, C, Bd, [[-1.0], [0.0]], gamma=10.0)
    ... except CertificateError as exc:
    ...     print(type(exc).__name__, "-", exc)
    CertificateError - the given gain K failed verification: A − K C Hurwitz (max Re λ): 0.25 < 0 ...
    """


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

    Examples
    --------
    A Luenberger gain far too stiff for RK4 steps of 0.1 s: the estimate grows by orders of magnitude
    each step until it overflows, and the error names the time and the component:

    >>> import nlobs
    >>> from nlobs.simulate import simulate
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.LuenbergerObserver(system, [[450.0], [175.0]])
    >>> try:
    ...     simulate(system, observer, [1.0, 0.0], [0.0, 0.0], duration=10.0, dt=0.1, u=0.0)
    ... except SimulationDiverged as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(exc.time, exc.which, exc.state)
    SimulationDiverged - simulation diverged at t=6: observer state 'x1_hat' is not finite
    6.0 observer x1_hat
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

    Examples
    --------
    The Moore–Penrose observer of Röbenack needs A1, independent rows of ``Q`` (13); the ball and beam
    has relative degrees ``r = (3, 2)``, more rows than its four states:

    >>> from nlobs.workflows.design_pinv import design_pinv_observer
    >>> try:
    ...     design_pinv_observer("ball-and-beam")
    ... except AssumptionViolated as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(exc.item)
    AssumptionViolated - ball-and-beam: A1 fails: Σ r_j = 5 > n = 4 for r = (3, 2); the rows of Q (13) ...
    A1
    """

    def __init__(self, message: str, *, item: str = "", evidence: str = "") -> None:
        self.item = item
        self.evidence = evidence
        super().__init__(message)


class OutputError(NlobsError, OSError):
    """An output file or folder cannot be written (an existing file where a folder is needed, read-only, full disk).

    Nothing is left half-written: every output of nlobs is written atomically.

    Examples
    --------
    The C code of a Luenberger observer exported to a path that is an existing file, not a folder; the file is
    left as it was, and the error is also an :class:`OSError`:

    >>> import shutil
    >>> import tempfile
    >>> from pathlib import Path
    >>> import nlobs
    >>> from nlobs.export import export_observer
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.LuenbergerObserver(system, [[4.5], [1.75]])
    >>> folder = Path(tempfile.mkdtemp())
    >>> taken = folder / "taken"
    >>> _ = taken.write_text("not a folder", encoding="utf-8")
    >>> try:
    ...     export_observer(observer, taken, check=False)
    ... except OutputError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(isinstance(exc, OSError), taken.read_text(encoding="utf-8"))
    OutputError - ...taken: cannot write the generated C (exists and is not a folder)
    True not a folder
    >>> shutil.rmtree(folder)
    """


class StudyFailed(NlobsError):
    """A simulation study a workflow ran (one simulation or Monte Carlo runs) could not be completed.

    The cause is chained and named in the message. A divergence of a single simulation is
    :class:`SimulationDiverged` instead.

    Examples
    --------
    The drift observer (3.1) of Dalla Mora, Germani & Manes for the shipped pendulum, simulated with a step
    of 1 s, far too long for its gain: the estimate explodes until ``Q_s`` is singular, and the study stops
    with the reason:

    >>> from nlobs.workflows import SimulationRequest
    >>> from nlobs.workflows.design_drift import design_drift_observer
    >>> try:
    ...     design_drift_observer("pendulum", simulate=SimulationRequest([0.5, 0.0], duration=50.0, dt=1.0))
    ... except StudyFailed as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(exc.__cause__ is not None)
    StudyFailed - pendulum: Q_s (s = [2]) is singular at t=... the drift-observability observer (3.1) needs
    Q_s(x̂) invertible: ...
    True
    """


class NumericalError(NlobsError, ArithmeticError):
    """A result cannot be trusted in double precision: it failed its a-posteriori accuracy check.

    Raised instead of returning a number that is known to be wrong (a Gramian whose Lyapunov
    residual is not small, data whose magnitude overflows the computation). The message names
    the quantity and the measured residual or magnitude.

    Examples
    --------
    A system matrix with entries of 1e308, whose eigenvalues LAPACK cannot compute in range; it is an
    :class:`ArithmeticError`, like a divergence:

    >>> import nlobs
    >>> from nlobs.linear import analyze_linear
    >>> system = nlobs.LinearSystem([[1e308, 1e308], [-1e308, 1e308]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> try:
    ...     analyze_linear(system)
    ... except NumericalError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(isinstance(exc, ArithmeticError))
    NumericalError - A: entries up to 1e+308 in magnitude exceed 1e+130; eigenvalues, norms and Gramians of such
    data overflow or lose all accuracy in double precision (rescale the model's units)
    True
    """


class ExpressionTooLarge(NlobsError, ValueError):
    """A symbolic computation would build an expression beyond nlobs's size budget.

    Raised *before* SymPy differentiates, simplifies or compiles it (a short model text, such as
    ``sin(sin(…sin(x)…))`` nested 99 deep, has Lie derivatives of millions of terms, whose
    construction would run for minutes). The message names the quantity and the limit
    (:data:`nlobs.geometry.lie.MAX_DERIVATIVE_NODES`).

    Examples
    --------
    A chain of 51 integrators, ``ẋ_i = x_{i+1}``, ``ẋ_51 = −x1``, ``y = x1``: the symbolic analyses of
    Dalla Mora, Germani & Manes and Röbenack are refused above
    :data:`~nlobs.geometry.report.MAX_GEOMETRY_STATES` states, before the first Lie derivative is built:

    >>> from nlobs.geometry.report import geometry_report
    >>> from nlobs.systems.symbolic import SymbolicModel
    >>> states = [f"x{i}" for i in range(1, 52)]
    >>> chain = SymbolicModel.input_affine(states, [], ["y"], f=[*states[1:], "-x1"], g=None, h=["x1"])
    >>> try:
    ...     geometry_report(chain)
    ... except ExpressionTooLarge as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(isinstance(exc, ValueError))
    ExpressionTooLarge - 51 states: the Lie-derivative analysis is done up to 50 states (the size of L_f^k h grows
    with every k)
    True
    """


class ProblemTooLarge(InvalidArgumentError):
    """A numerical problem (an SDP) would exceed nlobs's memory budget; refused *before* it is built.

    The message names the problem's size (variables, semidefinite cones, the estimated memory of the
    interior-point solver), the limit, and what to change (e.g. drop a pole region or gain bound so
    that the Riccati path applies, or reduce the model). A subclass of
    :class:`InvalidArgumentError`, so the command line reports it in one line with exit 2.

    Examples
    --------
    An observer gain for 60 states and 20 outputs with a pole region (Chilali–Gahinet LMIs): the SDP would
    need about 10 GiB, so it is refused at once, before any solver is called:

    >>> import numpy as np
    >>> from nlobs.synthesis.observer_gain import design_observer_gain
    >>> from nlobs.synthesis.regions import HalfPlane
    >>> n = 60
    >>> A = -np.eye(n) + np.eye(n, k=1)
    >>> try:
    ...     design_observer_gain(A, np.eye(20, n), np.eye(n, 10), gamma=40.0, gamma_n=40.0, region=HalfPlane(0.1))
    ... except ProblemTooLarge as exc:
    ...     print(type(exc).__name__, "-", exc)
    ...     print(isinstance(exc, InvalidArgumentError))
    ProblemTooLarge - observer-gain SDP too large: n = 60 states, 20 outputs give ... the limit is 4 GiB ...
    True
    """


class CompilerError(NlobsError, RuntimeError):
    """Generated C could not be compiled or loaded: no C compiler was found, or the compiler failed.

    The message names the compiler tried (or the ones looked for) and the first lines of its
    diagnostics. Install the ``codegen`` extra (``pip install nlobs[codegen]``, a C compiler from the
    package index), put ``cc`` on the ``PATH``, or name one with the ``NLOBS_CC`` environment variable.

    Examples
    --------
    ``NLOBS_CC`` naming a compiler that is not installed (set here for the one call):

    >>> import os
    >>> from unittest import mock
    >>> from nlobs.export.compiler import find_compiler
    >>> with mock.patch.dict(os.environ, {"NLOBS_CC": "no-such-compiler-xyz"}):
    ...     try:
    ...         find_compiler()
    ...     except CompilerError as exc:
    ...         print(type(exc).__name__, "-", exc)
    CompilerError - NLOBS_CC='no-such-compiler-xyz': no such compiler command
    """
