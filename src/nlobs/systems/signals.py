"""Known input signals ``u(t)``: constants, steps, sines, chirps, sampled tables, expressions of ``t``.

Each signal is a frozen dataclass of one scalar channel, a :class:`Signal`:

* ``s(t)`` is its value at time ``t`` (seconds): a ``float`` for a number, an array of the same
  shape for an array of times. It is cheap (the simulation loop calls it at every RK4 stage) and
  holds no state;
* ``s.describe()`` is one line (``"sine 0.5 sin(2π·0.2 t + 0) + 1"``);
* ``s.to_dict()`` is a JSON-able dict with a ``"kind"`` key, in the form :func:`signal_from_table`
  reads back (a piecewise signal is written as its samples);
* ``s.piecewise_constant`` tells whether the signal is constant between the instants at which it
  jumps (a constant, a step, a zero-order hold).

:class:`InputSignals` stacks named channels into the vector ``u(t)`` of shape ``(m,)``, a callable
that :func:`nlobs.simulate.simulate` accepts as ``u=``.

Text becomes a signal in three ways, none of which evaluates it as Python: the compact command-line
form of :func:`parse_signal_spec` (``sine:1,0.5``), a TOML table read by :func:`signal_from_table`
(``{kind = "sine", amplitude = 1, frequency = 0.5}``) and a CSV file read by :func:`read_signal_csv`
(the :mod:`csv` module and ``float()``). Expressions of ``t`` are parsed by the whitelisted
:func:`~nlobs.systems.expressions.parse_expression` and compiled once by
:func:`~nlobs.systems.codegen.compile_matrix`.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from nlobs._frozen import FrozenMapping
from nlobs._io import read_regular_text
from nlobs._typing import Array
from nlobs._validate import as_finite_array, escape_unsafe, name_problem, readonly, real_scalar
from nlobs.errors import InvalidArgumentError, NonFiniteError, SignalFileError, UnknownNameError
from nlobs.systems.codegen import BatchedFunction, compile_matrix
from nlobs.systems.expressions import CONSTANTS, ExpressionError, parse_expression

#: Largest CSV file of signals read, in bytes (16 MiB).
MAX_CSV_BYTES = 16 << 20
#: The names the first (time) column of a CSV file of signals may have.
TIME_COLUMNS = ("t", "time")

_TWO_PI = 2.0 * math.pi
_SHOWN = 80  # characters of a user's text quoted in a message


def _fmt(x: float) -> str:
    """``x`` written shortest, without a trailing ``.0`` (``1``, ``0.5``, ``1e-05``)."""
    r = repr(float(x))
    return r[:-2] if r.endswith(".0") else r


def _shown(text: str) -> str:
    """``text`` quoted for a one-line message (control characters escaped, long text cut)."""
    return repr(text if len(text) <= _SHOWN else text[:_SHOWN] + "...")


def _finite(name: str, value: Any) -> float:
    """``value`` as a finite real float, or a typed error naming ``name``."""
    if isinstance(value, (bool, np.bool_, str, bytes)):  # text is read by parse_signal_spec, not float()
        raise InvalidArgumentError(f"{name}: expected a number, got {value!r}")
    try:
        v = float(real_scalar(name, value))
    except OverflowError:  # an integer beyond the range of a double
        raise NonFiniteError(f"{name}: must be finite, got an integer beyond the range of a double") from None
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InvalidArgumentError):
            raise
        raise InvalidArgumentError(f"{name}: expected a number, got {_shown(str(value))}") from None
    if not math.isfinite(v):
        raise NonFiniteError(f"{name}: must be finite, got {v!r}")
    return v


class Signal:
    """Base class of the scalar known-input signals of this module (see the module docstring).

    Examples
    --------
    Every kind of signal is called at a time (or an array of times), describes itself in one line, and says
    whether it is constant between jumps:

    >>> import numpy as np
    >>> signals = [Constant(1.5), Step(0.0, 2.0, at=1.0), Sine(0.5, 0.25, offset=1.0), Expression("exp(-t)")]
    >>> all(isinstance(sig, Signal) for sig in signals)
    True
    >>> for sig in signals:
    ...     print(f"{sig.describe()} | u(1) = {round(sig(1.0), 4)} | piecewise constant: {sig.piecewise_constant}")
    constant 1.5 | u(1) = 1.5 | piecewise constant: True
    step 0 → 2 at t = 1 | u(1) = 2.0 | piecewise constant: True
    sine 0.5 sin(2π·0.25 t + 0) + 1 | u(1) = 1.5 | piecewise constant: False
    expression exp(-t) | u(1) = 0.3679 | piecewise constant: False
    >>> [sig(np.array([0.0, 0.5, 2.0])).shape for sig in signals]
    [(3,), (3,), (3,), (3,)]
    """

    __slots__ = ()

    @property
    def piecewise_constant(self) -> bool:
        """Whether the signal is constant between its jumps (a constant, a step, a zero-order hold)."""
        return False

    def __call__(self, t: Any) -> Any:  # pragma: no cover - every signal defines it
        raise NotImplementedError

    def describe(self) -> str:  # pragma: no cover - every signal defines it
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:  # pragma: no cover - every signal defines it
        raise NotImplementedError


@dataclass(frozen=True)
class Constant(Signal):
    """The constant signal ``u(t) = value``.

    Examples
    --------
    >>> import numpy as np
    >>> c = Constant(1.5)
    >>> c(7.0), c(np.array([0.0, 1.0, 2.0])).tolist(), c.describe()
    (1.5, [1.5, 1.5, 1.5], 'constant 1.5')
    >>> c.to_dict(), signal_from_table(c.to_dict()) == c
    ({'kind': 'constant', 'value': 1.5}, True)
    """

    value: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "value", _finite("Constant.value", self.value))

    @property
    def piecewise_constant(self) -> bool:
        return True

    def __call__(self, t: Any) -> Any:
        if isinstance(t, np.ndarray):
            return np.full(t.shape, self.value)
        return self.value

    def describe(self) -> str:
        return f"constant {_fmt(self.value)}"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "constant", "value": self.value}


@dataclass(frozen=True)
class Step(Signal):
    """A step: ``before`` for ``t < at``, ``after`` from ``t >= at`` on.

    Examples
    --------
    A torque switched from 0 to 2 at ``t = 1`` s; the new value holds from the instant of the step on:

    >>> import numpy as np
    >>> step = Step(before=0.0, after=2.0, at=1.0)
    >>> step(0.999), step(1.0), step(np.array([0.0, 0.5, 1.0, 1.5])).tolist()
    (0.0, 2.0, [0.0, 0.0, 2.0, 2.0])
    >>> step.describe(), step.piecewise_constant
    ('step 0 → 2 at t = 1', True)
    """

    before: float
    after: float
    at: float

    def __post_init__(self) -> None:
        for name in ("before", "after", "at"):
            object.__setattr__(self, name, _finite(f"Step.{name}", getattr(self, name)))

    @property
    def piecewise_constant(self) -> bool:
        return True

    def __call__(self, t: Any) -> Any:
        if isinstance(t, np.ndarray):
            return np.where(t < self.at, self.before, self.after).astype(float)
        return self.before if t < self.at else self.after

    def describe(self) -> str:
        return f"step {_fmt(self.before)} → {_fmt(self.after)} at t = {_fmt(self.at)}"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "step", "before": self.before, "after": self.after, "at": self.at}


@dataclass(frozen=True)
class Sine(Signal):
    """``u(t) = amplitude · sin(2π · frequency · t + phase) + offset``.

    Parameters
    ----------
    amplitude : float
        Any finite number (a negative one flips the sign).
    frequency : float
        In hertz, positive.
    phase : float
        In radians.
    offset : float
        Added to the sine.

    Examples
    --------
    ``2 sin(2π·0.25 t) + 1``: a period of 4 s, its maximum 3 at ``t = 1``:

    >>> import math
    >>> import numpy as np
    >>> sine = Sine(amplitude=2.0, frequency=0.25, offset=1.0)
    >>> round(sine(1.0), 12), sine.describe()
    (3.0, 'sine 2 sin(2π·0.25 t + 0) + 1')
    >>> t = np.linspace(0.0, 8.0, 33)
    >>> bool(np.allclose(sine(t), 2.0 * np.sin(0.5 * math.pi * t) + 1.0)), bool(np.allclose(sine(t + 4.0), sine(t)))
    (True, True)
    """

    amplitude: float
    frequency: float
    phase: float = 0.0
    offset: float = 0.0

    def __post_init__(self) -> None:
        for name in ("amplitude", "frequency", "phase", "offset"):
            object.__setattr__(self, name, _finite(f"Sine.{name}", getattr(self, name)))
        if self.frequency <= 0:
            raise InvalidArgumentError(f"Sine.frequency: must be positive (in Hz), got {self.frequency!r}")

    def __call__(self, t: Any) -> Any:
        if isinstance(t, np.ndarray):
            return self.amplitude * np.sin(_TWO_PI * self.frequency * t + self.phase) + self.offset
        return self.amplitude * math.sin(_TWO_PI * self.frequency * t + self.phase) + self.offset

    def describe(self) -> str:
        return (f"sine {_fmt(self.amplitude)} sin(2π·{_fmt(self.frequency)} t + {_fmt(self.phase)}) "
                f"+ {_fmt(self.offset)}")

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "sine", "amplitude": self.amplitude, "frequency": self.frequency, "phase": self.phase,
                "offset": self.offset}


@dataclass(frozen=True)
class Chirp(Signal):
    """A linear chirp ``u(t) = amplitude · sin(φ(t)) + offset`` sweeping from ``f0`` to ``f1`` Hz.

    On ``[0, duration]`` the phase is ``φ(t) = 2π (f0 t + (f1 − f0) t² / (2 duration))``, so the
    instantaneous frequency ``φ′(t) / 2π`` grows linearly from ``f0`` to ``f1``. After ``duration``
    the signal goes on at the constant frequency ``f1``, ``φ(t) = φ(duration) + 2π f1 (t − duration)``,
    and before ``0`` at ``f0``, ``φ(t) = 2π f0 t``: the phase is continuous (and differentiable)
    everywhere, the signal never jumps.

    Parameters
    ----------
    amplitude : float
        Any finite number.
    f0, f1 : float
        Start and end frequency in hertz, non-negative (``f1 < f0`` sweeps down).
    duration : float
        Length of the sweep in seconds, positive.
    offset : float
        Added to the sine.

    Examples
    --------
    A sweep from 0.5 to 2.5 Hz over 4 s: the instantaneous frequency grows linearly, then stays at ``f1``;
    it is the derivative of the phase over 2π (checked here by a central difference):

    >>> import math
    >>> chirp = Chirp(amplitude=1.0, f0=0.5, f1=2.5, duration=4.0)
    >>> [chirp.frequency(t) for t in (0.0, 2.0, 4.0, 10.0)]
    [0.5, 1.5, 2.5, 2.5]
    >>> h = 1e-6
    >>> [round((chirp.phase(t + h) - chirp.phase(t - h)) / (2 * h) / (2 * math.pi), 6) for t in (1.0, 6.0)]
    [1.0, 2.5]
    >>> chirp.describe()
    'chirp 1 sin(φ(t)) + 0, 0.5 → 2.5 Hz linearly over [0, 4] s, then 2.5 Hz'
    """

    amplitude: float
    f0: float
    f1: float
    duration: float
    offset: float = 0.0

    def __post_init__(self) -> None:
        for name in ("amplitude", "f0", "f1", "duration", "offset"):
            object.__setattr__(self, name, _finite(f"Chirp.{name}", getattr(self, name)))
        for name in ("f0", "f1"):
            if getattr(self, name) < 0:
                raise InvalidArgumentError(f"Chirp.{name}: must be non-negative (in Hz), got {getattr(self, name)!r}")
        if self.duration <= 0:
            raise InvalidArgumentError(f"Chirp.duration: must be positive (in seconds), got {self.duration!r}")

    def phase(self, t: Any) -> Any:
        """The phase ``φ(t)`` in radians (a float, or an array like ``t``)."""
        f0, f1, d = self.f0, self.f1, self.duration
        if isinstance(t, np.ndarray):
            tc = np.clip(t, 0.0, d)
            return _TWO_PI * (f0 * tc + (f1 - f0) * tc * tc / (2.0 * d)
                              + f0 * np.minimum(t, 0.0) + f1 * np.maximum(t - d, 0.0))
        if t < 0:
            return _TWO_PI * f0 * t
        if t <= d:
            return _TWO_PI * (f0 * t + (f1 - f0) * t * t / (2.0 * d))
        return _TWO_PI * (0.5 * (f0 + f1) * d + f1 * (t - d))

    def frequency(self, t: Any) -> Any:
        """The instantaneous frequency ``φ′(t) / 2π`` in hertz."""
        f0, f1, d = self.f0, self.f1, self.duration
        if isinstance(t, np.ndarray):
            return f0 + (f1 - f0) * np.clip(t, 0.0, d) / d
        return f0 + (f1 - f0) * min(max(t, 0.0), d) / d

    def __call__(self, t: Any) -> Any:
        if isinstance(t, np.ndarray):
            return self.amplitude * np.sin(self.phase(t)) + self.offset
        return self.amplitude * math.sin(self.phase(t)) + self.offset

    def describe(self) -> str:
        return (f"chirp {_fmt(self.amplitude)} sin(φ(t)) + {_fmt(self.offset)}, {_fmt(self.f0)} → {_fmt(self.f1)} Hz "
                f"linearly over [0, {_fmt(self.duration)}] s, then {_fmt(self.f1)} Hz")

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "chirp", "amplitude": self.amplitude, "f0": self.f0, "f1": self.f1,
                "duration": self.duration, "offset": self.offset}


@dataclass(frozen=True, eq=False)
class Piecewise(Signal):
    """A signal given by samples ``values[k]`` at strictly increasing ``times[k]``.

    Parameters
    ----------
    times : array_like, shape (K,)
        Finite, strictly increasing sample times (seconds), at least one.
    values : array_like, shape (K,)
        Finite values.
    kind : {"hold", "linear"}
        ``"hold"``: zero-order hold, ``u(t) = values[k]`` for ``times[k] <= t < times[k+1]``;
        ``"linear"``: linear interpolation between the samples (as :func:`numpy.interp`).
    source : str
        Where the samples came from (``"u.csv: tau"``), for :meth:`describe`; not compared.

    Notes
    -----
    Before ``times[0]`` the signal holds ``values[0]``, after ``times[-1]`` it holds ``values[-1]``.
    Two piecewise signals are equal when their kinds, times and values are.

    Examples
    --------
    Three samples, held or interpolated; outside the samples the first and last values hold:

    >>> import numpy as np
    >>> hold = Piecewise([0.0, 1.0, 2.0], [0.0, 10.0, 5.0])
    >>> linear = Piecewise([0.0, 1.0, 2.0], [0.0, 10.0, 5.0], kind="linear")
    >>> t = np.array([-1.0, 0.5, 1.0, 1.5, 3.0])
    >>> hold(t).tolist(), linear(t).tolist()
    ([0.0, 0.0, 10.0, 10.0, 5.0], [0.0, 5.0, 10.0, 7.5, 5.0])
    >>> hold.piecewise_constant, linear.piecewise_constant, hold.describe()
    (True, False, 'piecewise zero-order hold, 3 samples over t ∈ [0, 2], values in [0, 10]')
    >>> try:
    ...     Piecewise([0.0, 1.0, 1.0], [0.0, 1.0, 2.0])
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, "-", exc)
    InvalidArgumentError - Piecewise.times: must be strictly increasing; times[2] = 1.0 is not after times[1] = 1.0
    """

    times: Array
    values: Array
    kind: Literal["hold", "linear"] = "hold"
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        t = as_finite_array("Piecewise.times", self.times, ndim=1)
        v = as_finite_array("Piecewise.values", self.values, ndim=1)
        if t.size == 0:
            raise InvalidArgumentError("Piecewise.times: at least one sample is required")
        if v.size != t.size:
            raise InvalidArgumentError(f"Piecewise.values: {v.size} values for {t.size} times")
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            k = int(bad[0]) + 1
            raise InvalidArgumentError(f"Piecewise.times: must be strictly increasing; times[{k}] = {float(t[k])!r} "
                                       f"is not after times[{k - 1}] = {float(t[k - 1])!r}")
        if self.kind not in ("hold", "linear"):
            raise InvalidArgumentError(f"Piecewise.kind: expected 'hold' or 'linear', got {self.kind!r}")
        if not isinstance(self.source, str):
            raise InvalidArgumentError(f"Piecewise.source: expected a string, got {self.source!r}")
        object.__setattr__(self, "times", readonly(t, owned=True))
        object.__setattr__(self, "values", readonly(v, owned=True))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Piecewise):
            return NotImplemented
        return (self.kind == other.kind and np.array_equal(self.times, other.times)
                and np.array_equal(self.values, other.values))

    def __hash__(self) -> int:
        return hash((self.kind, self.times.tobytes(), self.values.tobytes()))

    @property
    def piecewise_constant(self) -> bool:
        return self.kind == "hold"

    def __call__(self, t: Any) -> Any:
        times, values = self.times, self.values
        if isinstance(t, np.ndarray):
            if self.kind == "linear":
                return np.interp(t, times, values)
            return values[np.maximum(times.searchsorted(t, side="right") - 1, 0)]
        k = int(times.searchsorted(t, side="right"))  # times[k - 1] <= t < times[k]
        if k == 0:
            return float(values[0])
        if self.kind == "hold" or k == times.size or t == times[k - 1]:
            return float(values[k - 1])
        t0, v0 = float(times[k - 1]), float(values[k - 1])  # numpy.interp's formula, without its overhead
        return (float(values[k]) - v0) / (float(times[k]) - t0) * (t - t0) + v0

    def describe(self) -> str:
        t, v = self.times, self.values
        where = f" from {self.source}" if self.source else ""
        return (f"piecewise {'zero-order hold' if self.kind == 'hold' else 'linear'}{where}, {t.size} sample"
                f"{'' if t.size == 1 else 's'} over t ∈ [{_fmt(t[0])}, {_fmt(t[-1])}], values in "
                f"[{_fmt(v.min())}, {_fmt(v.max())}]")

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "piecewise", "interpolation": self.kind, "times": self.times.tolist(),
                "values": self.values.tolist()}


@dataclass(frozen=True, eq=False)
class Expression(Signal):
    """A signal given by an expression of ``t`` (seconds) and named parameters, e.g. ``"a*sin(w*t)"``.

    The text is parsed by the whitelisted :func:`~nlobs.systems.expressions.parse_expression` (never
    evaluated), the parameters are substituted, and the result is compiled once to NumPy
    (:func:`~nlobs.systems.codegen.compile_matrix`); a call runs the compiled code only.

    Parameters
    ----------
    text : str
        The expression; it may use ``t``, the parameters, ``pi`` and the whitelisted functions.
    parameters : mapping of str to float
        Named constants. Those the text does not use are dropped; ``t`` and ``pi`` cannot be parameters.

    Raises
    ------
    ExpressionError
        The text is not an allowed expression of ``t`` and the parameters.
    InvalidArgumentError, NonFiniteError
        A parameter name or value is not allowed.

    Examples
    --------
    ``a sin(w t)`` with ``a = 2``, ``w = 3``: the value is that of the closed form, the unused parameter is
    dropped, and text that is not a whitelisted expression is refused without being run:

    >>> import math
    >>> import numpy as np
    >>> e = Expression("a*sin(w*t)", {"a": 2.0, "w": 3.0, "unused": 1.0})
    >>> bool(np.isclose(e(0.5), 2.0 * math.sin(1.5))), e(np.array([0.0, 1.0])).shape
    (True, (2,))
    >>> dict(e.parameters), e.describe()
    ({'a': 2.0, 'w': 3.0}, 'expression a*sin(w*t) with a = 2, w = 3')
    >>> from nlobs.systems.expressions import ExpressionError
    >>> try:
    ...     Expression('__import__("os")')
    ... except ExpressionError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ExpressionError - function is not in the whitelist abs, acos, ...: '__import__' in expression ...
    """

    text: str
    parameters: Mapping[str, float] = field(default_factory=dict)
    _fn: BatchedFunction = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.text, str):
            raise InvalidArgumentError(f"Expression.text: expected a string, got {type(self.text).__name__}")
        if not isinstance(self.parameters, Mapping):
            raise InvalidArgumentError(f"Expression.parameters: expected a mapping of names to numbers, got "
                                       f"{type(self.parameters).__name__}")
        params: dict[str, float] = {}
        for k, v in self.parameters.items():
            why = name_problem(k)
            if why is not None:
                raise InvalidArgumentError(f"Expression.parameters: the name {k!r} is {why}")
            if k == "t" or k in CONSTANTS:
                raise InvalidArgumentError(f"Expression.parameters: {k!r} cannot be a parameter (it is "
                                           f"{'the time' if k == 't' else 'a constant'} of every expression)")
            params[k] = _finite(f"Expression.parameters[{k!r}]", v)
        t = sp.Symbol("t", real=True)
        psyms = {k: sp.Symbol(k, real=True) for k in params}
        expr = parse_expression(self.text, {"t": t, **psyms})
        used = {k: params[k] for k in sorted(params) if psyms[k] in expr.free_symbols}
        expr = expr.subs({psyms[k]: sp.Float(v) for k, v in used.items()})
        object.__setattr__(self, "parameters", FrozenMapping(used))
        object.__setattr__(self, "_fn", compile_matrix([expr], ((t,),), vector=True, what="Expression"))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Expression):
            return NotImplemented
        return self.text == other.text and dict(self.parameters) == dict(other.parameters)

    def __hash__(self) -> int:
        return hash((self.text, tuple(sorted(self.parameters.items()))))

    def __reduce__(self) -> tuple[Any, ...]:
        return (Expression, (self.text, dict(self.parameters)))  # the compiled code is rebuilt, not pickled

    def __call__(self, t: Any) -> Any:
        if isinstance(t, np.ndarray):
            return self._fn(np.asarray(t, dtype=float)[..., None])[..., 0]
        return float(self._fn(np.array([t], dtype=float))[0])

    def describe(self) -> str:
        params = ", ".join(f"{k} = {_fmt(v)}" for k, v in self.parameters.items())
        return f"expression {' '.join(self.text.split())}" + (f" with {params}" if params else "")

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "expression", "expression": self.text, "parameters": dict(self.parameters)}


@dataclass(frozen=True)
class InputSignals:
    """The known input vector ``u(t) = (s₁(t), …, s_m(t))`` of named scalar signals.

    A callable accepted by :func:`nlobs.simulate.simulate` as ``u=``: ``u(t)`` has shape ``(m,)`` for
    a number ``t`` and ``(*t.shape, m)`` for an array of times.

    Parameters
    ----------
    names : sequence of str
        The input names (unique identifiers), in the order of the plant's inputs.
    signals : sequence of Signal
        One signal per name.

    Examples
    --------
    Two inputs: ``u(t)`` is a vector of two entries, or one row per time of an array of times:

    >>> import numpy as np
    >>> u = InputSignals(("tau", "F"), (Sine(1.0, 0.25), Step(0.0, 5.0, at=2.0)))
    >>> u.m, np.round(u(1.0), 6).tolist(), u(np.linspace(0.0, 3.0, 4)).shape
    (2, [1.0, 0.0], (4, 2))
    >>> print(u.describe())
    tau: sine 1 sin(2π·0.25 t + 0) + 0
    F: step 0 → 5 at t = 2
    >>> u.piecewise_constant, InputSignals(("F",), (Step(0.0, 5.0, at=2.0),)).piecewise_constant
    (False, True)
    """

    names: tuple[str, ...]
    signals: tuple[Signal, ...]

    def __post_init__(self) -> None:
        if isinstance(self.names, str) or not isinstance(self.names, Sequence):
            raise InvalidArgumentError(f"InputSignals.names: expected a sequence of names, got {self.names!r}")
        if isinstance(self.signals, Signal) or not isinstance(self.signals, Sequence):
            raise InvalidArgumentError("InputSignals.signals: expected a sequence of signals, one per name")
        names, signals = tuple(self.names), tuple(self.signals)
        if len(names) != len(signals):
            raise InvalidArgumentError(f"InputSignals: {len(names)} names for {len(signals)} signals")
        for nm in names:
            why = name_problem(nm)
            if why is not None:
                raise InvalidArgumentError(f"InputSignals.names: {nm!r} is {why}")
        dup = sorted({nm for nm in names if names.count(nm) > 1})
        if dup:
            raise InvalidArgumentError(f"InputSignals.names: duplicate names: {', '.join(dup)}")
        for nm, s in zip(names, signals):
            if not isinstance(s, Signal):
                raise InvalidArgumentError(f"InputSignals.signals: the signal of {nm!r} is a "
                                           f"{type(s).__name__}, not a Signal")
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "signals", signals)

    @property
    def m(self) -> int:
        """Number of input channels."""
        return len(self.signals)

    @property
    def piecewise_constant(self) -> bool:
        """Whether every channel is piecewise constant."""
        return all(s.piecewise_constant for s in self.signals)

    def __call__(self, t: Any) -> Array:
        if isinstance(t, np.ndarray):
            out = np.empty((*t.shape, len(self.signals)))
            for j, s in enumerate(self.signals):
                out[..., j] = s(t)
            return out
        return np.array([s(t) for s in self.signals], dtype=float)

    def describe(self) -> str:
        """One line per channel, ``"name: description"``."""
        return "\n".join(f"{nm}: {s.describe()}" for nm, s in zip(self.names, self.signals))

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "inputs", "names": list(self.names), "signals": [s.to_dict() for s in self.signals]}


# ---------------------------------------------------------------------- CSV files
def read_signal_csv(path: str | Path, *, columns: Sequence[str] | None = None,
                    kind: Literal["hold", "linear"] = "hold") -> dict[str, Piecewise]:
    """Read sampled signals from a CSV file with a header row.

    The first column is the time (named ``t`` or ``time``, any case), strictly increasing; every other
    column is a signal named by its header. Blank lines are skipped; a UTF-8 byte-order mark is
    allowed. The numbers are read by ``float()`` (never evaluated) and must be finite::

        t,tau,F
        0.0,0.0,1.5
        0.5,0.2,1.5

    Parameters
    ----------
    path : str or Path
        A regular file of at most :data:`MAX_CSV_BYTES` bytes, UTF-8.
    columns : sequence of str, optional
        The columns to return (all but the time by default).
    kind : {"hold", "linear"}
        The interpolation of the returned :class:`Piecewise` signals.

    Returns
    -------
    dict of str to Piecewise
        One signal per column, in the order of ``columns`` (else of the file).

    Raises
    ------
    SignalFileError
        The file is missing, not a regular file, too large, not UTF-8 or empty, has no header or a
        first column that is not ``t``/``time``, a row with another number of fields than the header,
        a field that is not a finite number, a time not after the previous one, or no data row. The
        message is one line naming the file and the line.
    UnknownNameError
        A name in ``columns`` is not a column of the file (the message lists those that are).

    Examples
    --------
    Two sampled inputs, held (default) or interpolated linearly; a column not in the file is refused with
    the list of those that are:

    >>> import shutil
    >>> import tempfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "u.csv").write_text("t,tau,F\\n0.0,0.0,1.5\\n0.5,0.2,1.5\\n1.0,0.4,0.0\\n", encoding="utf-8")
    >>> signals = read_signal_csv(folder / "u.csv")
    >>> list(signals), signals["tau"](0.75), signals["F"](2.0)
    (['tau', 'F'], 0.2, 0.0)
    >>> round(read_signal_csv(folder / "u.csv", columns=["tau"], kind="linear")["tau"](0.75), 6)
    0.3
    >>> try:
    ...     read_signal_csv(folder / "u.csv", columns=["torque"])
    ... except UnknownNameError as exc:
    ...     print(type(exc).__name__, "-", exc)
    UnknownNameError - ...u.csv: no column 'torque'; the columns are: tau, F
    >>> shutil.rmtree(folder)
    """
    p = str(path)
    if kind not in ("hold", "linear"):
        raise InvalidArgumentError(f"kind: expected 'hold' or 'linear', got {kind!r}")
    table = read_csv_table(path)
    available = list(table.columns)
    if columns is None:
        wanted = available
    else:
        if isinstance(columns, str):
            columns = [columns]
        wanted = list(columns)
        unknown = [c for c in wanted if c not in available]
        if unknown:
            raise UnknownNameError(f"{p}: no column {_shown(str(unknown[0]))}; the columns are: "
                                   f"{', '.join(escape_unsafe(c, one_line=True) for c in available)}")
    return {c: Piecewise(table.t, table.columns[c], kind, source=f"{p}: {escape_unsafe(c, one_line=True)}")
            for c in wanted}


@dataclass(frozen=True)
class CsvTable:
    """A CSV file of samples as :func:`read_csv_table` reads it.

    Attributes
    ----------
    path : str
        The file.
    t : ndarray, shape (K,)
        The strictly increasing times.
    columns : Mapping[str, ndarray]
        Every other column by its header, shape ``(K,)`` each, in the file's order (NaN for an empty field where
        they are allowed).
    lines : ndarray of int, shape (K,)
        The line of the file of each row (for messages).
    """

    path: str
    t: Array
    columns: Mapping[str, Array]
    lines: Array


def read_csv_table(path: str | Path, *, empty_fields: bool = False) -> CsvTable:
    """Read a CSV file of samples with a header row: the time first (``t`` or ``time``, any case, strictly
    increasing), then named columns; the one reader of nlobs's CSV inputs (:func:`read_signal_csv`, recorded logs).

    Blank lines are skipped and a UTF-8 byte-order mark is allowed. Numbers are read by ``float()`` (never
    evaluated) and must be finite; with ``empty_fields`` an empty field is NaN (a sensor that gave no sample in a
    multi-rate log), never the time.

    Parameters
    ----------
    path : str or Path
        A regular file of at most :data:`MAX_CSV_BYTES` bytes, UTF-8.
    empty_fields : bool
        Allow empty fields outside the time column (read as NaN).

    Returns
    -------
    CsvTable

    Raises
    ------
    SignalFileError
        The file is missing, not a regular file, too large, not UTF-8 or empty, has no header, a first column that
        is not ``t``/``time``, an unnamed or repeated column, a row with another number of fields than the header,
        a field that is not a finite number (or empty, unless allowed), a time not after the previous one, or no
        data row. The message is one line naming the file and the line.

    Examples
    --------
    A two-rate log: ``y`` sampled at every row, ``z`` at every other (empty fields allowed):

    >>> import shutil
    >>> import tempfile
    >>> from pathlib import Path
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "log.csv").write_text("t,y,z\\n0,1.0,5\\n0.5,1.5,\\n1.0,2.0,6\\n", encoding="utf-8")
    >>> table = read_csv_table(folder / "log.csv", empty_fields=True)
    >>> table.t.tolist(), table.columns["z"].tolist(), table.lines.tolist()
    ([0.0, 0.5, 1.0], [5.0, nan, 6.0], [2, 3, 4])
    >>> try:
    ...     read_csv_table(folder / "log.csv")
    ... except SignalFileError as exc:
    ...     print(str(exc).split("log.csv")[1])
    :3: column 'z': an empty field is not a number
    >>> shutil.rmtree(folder)
    """
    p = str(path)
    text = read_regular_text(path, MAX_CSV_BYTES, lambda reason: SignalFileError(p, None, "", reason))
    if text.startswith("\ufeff"):
        text = text[1:]
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)

    def rows() -> Any:
        try:
            for row in reader:
                if row and any(f.strip() for f in row):
                    yield reader.line_num, row
        except csv.Error as exc:
            raise SignalFileError(p, reader.line_num, "", f"not valid CSV ({exc})") from None

    it = rows()
    first = next(it, None)
    if first is None:
        raise SignalFileError(p, None, "", "file is empty (a header row naming the columns, t first, is required)")
    line, header = first
    names = [h.strip() for h in header]
    if all(_is_number(h) for h in names):
        raise SignalFileError(p, line, "", "no header row: the first line holds numbers; it must name the columns, "
                              "t (or time) first")
    if names[0].lower() not in TIME_COLUMNS:
        raise SignalFileError(p, line, names[0], f"the first column must be the time, named t or time, not "
                              f"{_shown(names[0])}")
    if len(names) < 2:
        raise SignalFileError(p, line, "", "no signal columns: the header names only the time")
    for j, nm in enumerate(names[1:], start=2):
        if not nm:
            raise SignalFileError(p, line, "", f"column {j} has no name")
    dup = sorted({nm for nm in names if names.count(nm) > 1})
    if dup:
        raise SignalFileError(p, line, dup[0], f"column {_shown(dup[0])} appears twice in the header")
    width = len(names)
    times: list[float] = []
    lines: list[int] = []
    data: list[list[float]] = [[] for _ in names[1:]]
    previous = -math.inf
    header_line = line
    for line, row in it:
        if len(row) != width:
            raise SignalFileError(p, line, "", f"{len(row)} fields, but the header has {width}")
        # every field is checked: a file with a bad number is a bad file
        t = _csv_number(p, line, names[0], row[0])
        if not t > previous:
            raise SignalFileError(p, line, row[0].strip(),
                                  f"time {_fmt(t)} is not after the previous time {_fmt(previous)}")
        previous = t
        times.append(t)
        lines.append(line)
        for out, nm, f in zip(data, names[1:], row[1:]):
            out.append(math.nan if empty_fields and not f.strip() else _csv_number(p, line, nm, f))
    if not times:
        raise SignalFileError(p, header_line, "", "no data rows after the header (at least one is required)")
    return CsvTable(p, np.array(times), FrozenMapping({nm: np.array(v) for nm, v in zip(names[1:], data)}),
                    np.array(lines, dtype=np.int64))


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _csv_number(path: str, line: int, column: str, text: str) -> float:
    s = text.strip()
    try:
        v = float(s)
    except ValueError:
        what = "an empty field" if not s else _shown(s)
        raise SignalFileError(path, line, s, f"column {_shown(column)}: {what} is not a number") from None
    if not math.isfinite(v):
        raise SignalFileError(path, line, s, f"column {_shown(column)}: {_shown(s)} is not a finite number")
    return v


# ---------------------------------------------------------------------- the command-line form and TOML tables
#: The command-line forms of :func:`parse_signal_spec`, for messages.
SPEC_FORMS = ("NUMBER", "constant:VALUE", "step:BEFORE,AFTER,AT", "sine:AMPLITUDE,FREQUENCY[,PHASE[,OFFSET]]",
              "chirp:AMPLITUDE,F0,F1,DURATION[,OFFSET]", "csv:PATH[:COLUMN][:linear]", "expr:EXPRESSION")

_SPEC_FIELDS: Mapping[str, tuple[tuple[str, ...], tuple[str, ...]]] = {  # required, optional
    "constant": (("value",), ()),
    "step": (("before", "after", "at"), ()),
    "sine": (("amplitude", "frequency"), ("phase", "offset")),
    "chirp": (("amplitude", "f0", "f1", "duration"), ("offset",)),
}


def _spec_error(text: str, reason: str) -> InvalidArgumentError:
    return InvalidArgumentError(f"input signal {_shown(text)}: {reason}; expected one of: {', '.join(SPEC_FORMS)}")


def _number(name: str, value: Any, parameters: Mapping[str, float]) -> float:
    """A number of a spec or table: a number, or text of a constant expression of the parameters (``pi/2``)."""
    if isinstance(value, str):
        s = value.strip()
        try:
            plain = float(s)
        except ValueError:
            pass
        else:
            return _finite(name, plain)
        psyms = {k: sp.Symbol(k, real=True) for k in parameters}
        try:
            expr = parse_expression(s, psyms)
        except ExpressionError as exc:
            raise InvalidArgumentError(f"{name}: {_shown(s)} is not a number or a constant expression of the "
                                       f"parameters ({exc.reason}: {_shown(exc.offending)})") from None
        expr = expr.subs({psyms[k]: sp.Float(float(v)) for k, v in parameters.items()})
        if not expr.is_number:
            raise InvalidArgumentError(f"{name}: {_shown(s)} is not a number")
        return _finite(name, expr)  # e.g. acos(2) has no real value: refused
    return _finite(name, value)


def _checked_parameters(parameters: Mapping[str, float] | None) -> dict[str, float]:
    if parameters is None:
        return {}
    if not isinstance(parameters, Mapping):
        raise InvalidArgumentError(f"parameters: expected a mapping of names to numbers, got "
                                   f"{type(parameters).__name__}")
    out: dict[str, float] = {}
    for k, v in parameters.items():
        why = name_problem(k)
        if why is not None:
            raise InvalidArgumentError(f"parameters: the name {k!r} is {why}")
        out[k] = _finite(f"parameters[{k!r}]", v)
    return out


def _resolve(file: str, base_dir: str | Path | None) -> Path:
    p = Path(file)
    return p if base_dir is None or p.is_absolute() else Path(base_dir) / p


def _csv_signal(file: str, column: str | None, interpolation: str, base_dir: str | Path | None,
                what: str) -> Piecewise:
    if interpolation not in ("hold", "linear"):
        raise InvalidArgumentError(f"{what}: interpolation must be 'hold' or 'linear', got {interpolation!r}")
    path = _resolve(file, base_dir)
    if column is None:
        found = read_signal_csv(path, kind=interpolation)  # type: ignore[arg-type]
        if len(found) != 1:
            raise InvalidArgumentError(f"{what}: {path} has {len(found)} signal columns ({', '.join(found)}); "
                                       "name the one to use")
        return next(iter(found.values()))
    return read_signal_csv(path, columns=[column], kind=interpolation)[column]  # type: ignore[arg-type]


def _expression(text: str, parameters: Mapping[str, float], what: str) -> Expression:
    try:
        return Expression(text, parameters)
    except ExpressionError as exc:
        raise InvalidArgumentError(f"{what}: {exc.reason}: {_shown(exc.offending)} in expression "
                                   f"{_shown(exc.expression)}") from None


def parse_signal_spec(text: str, *, parameters: Mapping[str, float] | None = None,
                      base_dir: str | Path | None = None) -> Signal:
    """The signal of one input written in the compact command-line form.

    ===============================================  =======================================
    ``1.5`` or ``constant:1.5``                       :class:`Constant`
    ``step:BEFORE,AFTER,AT``                          :class:`Step`
    ``sine:AMPLITUDE,FREQUENCY[,PHASE[,OFFSET]]``     :class:`Sine` (Hz, rad)
    ``chirp:AMPLITUDE,F0,F1,DURATION[,OFFSET]``       :class:`Chirp`
    ``csv:PATH[:COLUMN][:linear]``                    :class:`Piecewise` (:func:`read_signal_csv`;
                                                      ``COLUMN`` may be left out when the file
                                                      has one signal; zero-order hold unless
                                                      ``:linear``)
    ``expr:0.5*sin(2*t)``                             :class:`Expression`
    ===============================================  =======================================

    Every number may also be a constant expression of the parameters (``sine:1,0.5,pi/2``).

    Parameters
    ----------
    text : str
        The specification.
    parameters : mapping of str to float, optional
        Named constants expressions may use.
    base_dir : str or Path, optional
        The folder a relative CSV path is relative to (the current folder by default).

    Raises
    ------
    InvalidArgumentError
        The text is not one of the forms above (the message, one line, lists them), or a value is
        not allowed.
    SignalFileError, UnknownNameError
        As :func:`read_signal_csv`.

    Examples
    --------
    >>> parse_signal_spec("1.5")
    Constant(value=1.5)
    >>> parse_signal_spec("step:0,1,2").describe()
    'step 0 → 1 at t = 2'
    >>> sine = parse_signal_spec("sine:1,w,pi/2", parameters={"w": 2.0})  # sin(2π·2 t + π/2) = cos(4π t)
    >>> sine.frequency, round(sine(0.25), 12)
    (2.0, -1.0)
    >>> parse_signal_spec("expr:0.5*sin(2*t)").describe()
    'expression 0.5*sin(2*t)'
    >>> try:
    ...     parse_signal_spec("sin:1,0.5")
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, "-", exc)
    InvalidArgumentError - input signal 'sin:1,0.5': unknown kind 'sin'; expected one of: NUMBER, constant:VALUE, ...
    """
    if not isinstance(text, str):
        raise InvalidArgumentError(f"input signal: expected a string, got {type(text).__name__}")
    params = _checked_parameters(parameters)
    s = text.strip()
    if not s:
        raise _spec_error(text, "empty")
    kind, sep, rest = s.partition(":")
    if not sep:
        try:
            return Constant(_number("constant", s, params))
        except InvalidArgumentError:
            raise _spec_error(text, "not a number or a known form") from None
    kind = kind.strip().lower()
    if kind in ("expr", "expression"):
        return _expression(rest, params, f"input signal {_shown(text)}")
    if kind == "csv":
        pieces = rest.split(":")
        interpolation = "hold"
        if len(pieces) > 1 and pieces[-1].strip().lower() in ("hold", "linear"):
            interpolation = pieces.pop().strip().lower()
        column = None
        if len(pieces) > 1 and not any(c in pieces[-1] for c in "/\\"):
            column = pieces.pop().strip()
        file = ":".join(pieces).strip()
        if not file or column == "":
            raise _spec_error(text, "expected csv:PATH[:COLUMN][:linear]")
        return _csv_signal(file, column, interpolation, base_dir, f"input signal {_shown(text)}")
    if kind not in _SPEC_FIELDS:
        raise _spec_error(text, f"unknown kind {_shown(kind)}")
    required, optional = _SPEC_FIELDS[kind]
    fields = [f.strip() for f in rest.split(",")]
    form = next(f for f in SPEC_FORMS if f.startswith(kind + ":"))
    if not (len(required) <= len(fields) <= len(required) + len(optional)) or not all(fields):
        raise InvalidArgumentError(f"input signal {_shown(text)}: expected {form}")
    values = {nm: _number(f"input signal {_shown(text)}: {nm.upper()}", v, params)
              for nm, v in zip(required + optional, fields)}
    return _build(kind, values, f"input signal {_shown(text)}")


def _build(kind: str, values: Mapping[str, float], what: str) -> Signal:
    cls = {"constant": Constant, "step": Step, "sine": Sine, "chirp": Chirp}[kind]
    try:
        return cls(**values)  # type: ignore[no-any-return]
    except (InvalidArgumentError, NonFiniteError) as exc:
        raise type(exc)(f"{what}: {exc}") from None


_TABLE_KEYS: Mapping[str, tuple[tuple[str, ...], tuple[str, ...]]] = {  # required, optional (besides "kind")
    **_SPEC_FIELDS,
    "csv": (("file",), ("column", "interpolation")),
    "piecewise": (("times", "values"), ("interpolation",)),
    "expression": (("expression",), ("parameters",)),
}


def signal_from_table(table: Mapping[str, Any], *, parameters: Mapping[str, float] | None = None,
                      base_dir: str | Path | None = None) -> Signal:
    """The signal of one input described by a table (a TOML inline table, a JSON object).

    ``kind`` is one of ``constant`` (``value``), ``step`` (``before``, ``after``, ``at``), ``sine``
    (``amplitude``, ``frequency``; ``phase``, ``offset``), ``chirp`` (``amplitude``, ``f0``, ``f1``,
    ``duration``; ``offset``), ``csv`` (``file``; ``column``, ``interpolation = "hold" | "linear"``),
    ``piecewise`` (``times``, ``values``; ``interpolation``) and ``expression`` (``expression``;
    ``parameters``, added to ``parameters``)::

        {kind = "sine", amplitude = 1, frequency = 0.5}
        {kind = "csv", file = "u.csv", column = "tau", interpolation = "hold"}
        {kind = "expression", expression = "sin(t)"}

    A number may also be a string holding a constant expression of the parameters (``"pi/2"``).
    ``Signal.to_dict()`` is read back to an equal signal.

    Raises
    ------
    InvalidArgumentError
        An unknown ``kind``, a missing or unknown key (the message names it and the allowed keys), or
        a value that is not allowed.
    SignalFileError, UnknownNameError
        As :func:`read_signal_csv`.

    Examples
    --------
    A table as a model file writes it, a number given as an expression of a parameter, and the round trip
    of a signal through its ``to_dict()``:

    >>> sine = signal_from_table({"kind": "sine", "amplitude": 1, "frequency": "w/2"}, parameters={"w": 1.0})
    >>> sine.describe()
    'sine 1 sin(2π·0.5 t + 0) + 0'
    >>> chirp = Chirp(1.0, 0.5, 2.5, duration=4.0)
    >>> signal_from_table(chirp.to_dict()) == chirp
    True
    >>> signal_from_table({"kind": "piecewise", "times": [0, 1], "values": [0, 2], "interpolation": "linear"})(0.25)
    0.5
    >>> try:
    ...     signal_from_table({"kind": "sine", "amplitude": 1, "freq": 0.5})
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, "-", exc)
    InvalidArgumentError - input signal of kind 'sine': unknown key 'freq'; allowed keys: kind, amplitude, frequency,
    phase, offset
    """
    if not isinstance(table, Mapping):
        raise InvalidArgumentError(f"input signal: expected a table with a 'kind' key, got {type(table).__name__}")
    params = _checked_parameters(parameters)
    kind = table.get("kind")
    if not isinstance(kind, str) or kind not in _TABLE_KEYS:
        shown = "missing" if kind is None else _shown(str(kind))
        raise InvalidArgumentError(f"input signal: 'kind' is {shown}; allowed kinds: {', '.join(_TABLE_KEYS)}")
    required, optional = _TABLE_KEYS[kind]
    allowed = ", ".join(("kind", *required, *optional))
    for key in table:
        if key != "kind" and key not in required and key not in optional:
            raise InvalidArgumentError(f"input signal of kind {kind!r}: unknown key {_shown(str(key))}; "
                                       f"allowed keys: {allowed}")
    for key in required:
        if key not in table:
            raise InvalidArgumentError(f"input signal of kind {kind!r}: missing key {key!r}; allowed keys: {allowed}")
    what = f"input signal of kind {kind!r}"
    if kind in _SPEC_FIELDS:
        return _build(kind, {k: _number(f"{what}: {k}", table[k], params) for k in (*required, *optional)
                             if k in table}, what)
    if kind == "expression":
        text = table["expression"]
        if not isinstance(text, str):
            raise InvalidArgumentError(f"{what}: 'expression' must be a string, got {text!r}")
        own = table.get("parameters", {})
        if not isinstance(own, Mapping):
            raise InvalidArgumentError(f"{what}: 'parameters' must be a table of numbers, got {own!r}")
        return _expression(text, {**params, **_checked_parameters(own)}, what)
    interpolation = table.get("interpolation", "hold")
    if interpolation not in ("hold", "linear"):
        raise InvalidArgumentError(f"{what}: 'interpolation' must be 'hold' or 'linear', got {interpolation!r}")
    if kind == "piecewise":
        return Piecewise(_numbers(f"{what}: times", table["times"]), _numbers(f"{what}: values", table["values"]),
                         interpolation)
    file, column = table["file"], table.get("column")
    if not isinstance(file, str) or not file:
        raise InvalidArgumentError(f"{what}: 'file' must be a path, got {file!r}")
    if column is not None and not isinstance(column, str):
        raise InvalidArgumentError(f"{what}: 'column' must be a column name, got {column!r}")
    return _csv_signal(file, column, interpolation, base_dir, what)


def _numbers(name: str, value: Any) -> ArrayLike:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence | np.ndarray):
        raise InvalidArgumentError(f"{name}: expected a list of numbers, got {value!r}")
    return [_finite(f"{name}[{k}]", v) for k, v in enumerate(value)]
