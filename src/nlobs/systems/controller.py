r"""A feedback law for the loop: ``u = k(x̂, t)``, one expression per input, optionally sampled and saturated.

A model file's ``[controller]`` table::

    [controller]
    law = ["-k1*th - k2*w", "0"]     # one expression per input, over the state names, t and parameters
    rate = 100.0                     # optional: a sampled controller (Hz), its output held between samples
    saturation = [[-2.0, 2.0]]       # optional: per input [lo, hi] (or one pair for all; inf allowed)

The names of the states in ``law`` mean the values fed back: the observer's estimate ``x̂`` when the loop is
closed around an observer, the true state for the reference loop (:func:`nlobs.simulate.simulate` with a
``controller``). The expressions are parsed by the same whitelisted parser as the model
(:func:`~nlobs.systems.expressions.parse_expression`) and compiled once to batched NumPy code.

Saturating the control is what Khalil's high-gain observers need in closed loop (Esfandiari & Khalil 1992;
Khalil & Praly 2014, §3): the estimate's peaking during the observer's fast transient then cannot drive the
plant out of the region where the state feedback works.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.systems.codegen import BatchedFunction, compile_matrix
from nlobs.systems.expressions import parse_expression

__all__ = ["ControlLaw", "control_period_steps"]


def _limits(saturation: Any, m: int) -> tuple[Array, Array] | None:
    """``(lo, hi)`` per input from ``None``, one pair for all inputs, or ``m`` pairs."""
    if saturation is None:
        return None
    try:
        arr = np.array(saturation, dtype=float)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"saturation: expected [lo, hi] pairs (numbers, inf allowed), got "
                                   f"{saturation!r}"[:200]) from None
    if arr.shape == (2,):
        arr = np.tile(arr, (m, 1))
    if arr.shape != (m, 2):
        raise DimensionError(f"saturation: expected one [lo, hi] pair or {m} (one per input), got shape {arr.shape}")
    if np.isnan(arr).any() or np.any(arr[:, 0] >= arr[:, 1]):
        raise InvalidArgumentError(f"saturation: every pair is [lo, hi] with lo < hi, got {arr.tolist()}")
    lo, hi = arr[:, 0].copy(), arr[:, 1].copy()
    lo.flags.writeable = hi.flags.writeable = False
    return lo, hi


@dataclass(frozen=True, eq=False)
class ControlLaw:
    """``u = sat(k(x, t))``: a state-feedback law over the model's state names (module docstring).

    Parameters
    ----------
    states : sequence of str
        The model's state names (in order): the names ``law`` may use, bound to the fed-back state.
    inputs : sequence of str
        The model's input names: one expression of ``law`` per input.
    law : sequence of str
        The expressions, in the whitelisted expression language of model files, over the states, ``t`` and
        the parameters.
    parameters : Mapping of str to float
        Named constants the expressions may use (a model file's ``parameters``).
    rate : float, optional
        A sampled controller: its output is computed at this rate (per time unit) and held between samples;
        ``None``: at every step of the simulation (held over the step).
    saturation : array_like, optional
        ``[lo, hi]`` per input (or one pair for all inputs), ``±inf`` allowed: the applied input is clipped to it.

    Raises
    ------
    ExpressionError
        An expression outside the whitelist or with an undeclared name (the message names it).
    InvalidArgumentError, DimensionError
        A state named ``t``, a count of expressions other than the inputs', a rate that is not positive, a
        saturation that is not ``lo < hi`` pairs.

    Examples
    --------
    A PD law on a double integrator, saturated at ±1, evaluated for a batch of two states:

    >>> import numpy as np
    >>> k = ControlLaw(["p", "v"], ["F"], ["-kp*p - kd*v"], parameters={"kp": 4.0, "kd": 2.0},
    ...                saturation=[-1.0, 1.0])
    >>> k(0.0, np.array([[0.1, 0.0], [1.0, 0.5]]))
    array([[-0.4],
           [-1. ]])
    >>> k.text
    ('-kp*p - kd*v',)
    >>> try:
    ...     ControlLaw(["p", "v"], ["F"], ["-kp*p + __import__('os')"], parameters={"kp": 1.0})
    ... except Exception as exc:
    ...     print(type(exc).__name__)
    ExpressionError
    """

    states: tuple[str, ...]
    inputs: tuple[str, ...]
    law: tuple[str, ...]
    parameters: Mapping[str, float] = field(default_factory=dict)
    rate: float | None = None
    saturation: tuple[Array, Array] | None = None
    _compiled: BatchedFunction = field(init=False, repr=False)

    def __post_init__(self) -> None:
        states = tuple(str(s) for s in self.states)
        inputs = tuple(str(s) for s in self.inputs)
        if isinstance(self.law, str) or not isinstance(self.law, Sequence):
            raise InvalidArgumentError("law: expected a list of expression strings, one per input")
        law = tuple(self.law)
        if len(law) != len(inputs):
            raise DimensionError(f"law: {len(law)} expression{'s' if len(law) != 1 else ''} for {len(inputs)} "
                                 f"input{'s' if len(inputs) != 1 else ''} ({', '.join(inputs) or 'none'}): one per input")
        if "t" in states or "t" in self.parameters:
            raise InvalidArgumentError("law: 't' is the time in a control law; rename the state or parameter 't'")
        params = {str(k): float(v) for k, v in self.parameters.items()}
        symbols = {s: sp.Symbol(s, real=True) for s in (*states, *params)}
        t = sp.Symbol("t", real=True)
        symbols["t"] = t
        exprs = []
        for e in law:
            if isinstance(e, bool) or not isinstance(e, (str, int, float)):
                raise InvalidArgumentError(f"law: entries must be expression strings, got {e!r}"[:200])
            expr = parse_expression(str(e), symbols)
            exprs.append(expr.subs({symbols[k]: v for k, v in params.items()}))
        rate = self.rate
        if rate is not None:
            rate = float(rate)
            if not (math.isfinite(rate) and rate > 0):
                raise InvalidArgumentError(f"rate: a sampled controller's rate must be positive and finite, got {rate!r}")
        compiled = compile_matrix(sp.Matrix(exprs) if exprs else sp.zeros(0, 1),
                                  [[symbols[s] for s in states], [t]], vector=True, what="controller law")
        object.__setattr__(self, "states", states)
        object.__setattr__(self, "inputs", inputs)
        object.__setattr__(self, "law", tuple(str(e) for e in law))
        object.__setattr__(self, "parameters", params)
        object.__setattr__(self, "rate", rate)
        object.__setattr__(self, "saturation", _limits(self.saturation, len(inputs)))
        object.__setattr__(self, "_compiled", compiled)

    @property
    def text(self) -> tuple[str, ...]:
        """The expressions as written."""
        return self.law

    @property
    def m(self) -> int:
        """Number of inputs."""
        return len(self.inputs)

    def unsaturated(self, t: float, x: ArrayLike) -> Array:
        """``k(x, t)`` without the saturation, shape ``(..., m)``.

        Parameters
        ----------
        t : float
            Time.
        x : array_like, shape (..., n)
            The fed-back state (estimate or truth).

        Returns
        -------
        ndarray, shape (..., m)
        """
        xa = np.asarray(x, dtype=float)
        if xa.ndim == 0 or xa.shape[-1] != len(self.states):
            raise DimensionError(f"controller: expected a state of shape (..., {len(self.states)}), got {xa.shape}")
        if self.m == 0:
            return np.zeros(xa.shape[:-1] + (0,))
        return self._compiled(xa, np.full(xa.shape[:-1] + (1,), float(t)))

    def __call__(self, t: float, x: ArrayLike) -> Array:
        """The applied input ``sat(k(x, t))``, shape ``(..., m)`` (see :meth:`unsaturated`)."""
        u = self.unsaturated(t, x)
        if self.saturation is not None:
            u = np.clip(u, self.saturation[0], self.saturation[1])
        return u

    def describe(self) -> str:
        """One line: the law, its rate and its saturation."""
        parts = [", ".join(f"{i} = {e}" for i, e in zip(self.inputs, self.law)) or "no inputs"]
        parts.append(f"sampled at {self.rate:g} Hz, held" if self.rate is not None else "at every step")
        if self.saturation is not None:
            parts.append("saturated to " + ", ".join(f"{i} ∈ [{lo:g}, {hi:g}]" for i, lo, hi in
                                                      zip(self.inputs, *self.saturation)))
        return "; ".join(parts)


def control_period_steps(rate: float | None, dt: float) -> int:
    """Steps of the simulation between two samples of a controller at ``rate`` (1 at every step).

    Parameters
    ----------
    rate : float or None
        The controller's rate (``None``: every step).
    dt : float
        The simulation step.

    Returns
    -------
    int

    Raises
    ------
    InvalidArgumentError
        ``1/rate`` is not a whole multiple of ``dt`` (to 1e-6).

    Examples
    --------
    >>> control_period_steps(100.0, 1e-3), control_period_steps(None, 1e-3)
    (10, 1)
    """
    if rate is None:
        return 1
    ratio = 1.0 / (rate * dt)
    k = round(ratio)
    if k < 1 or abs(ratio - k) > 1e-6 * max(1.0, ratio):
        raise InvalidArgumentError(f"controller rate {rate:g}: its period 1/{rate:g} is not a whole multiple of the "
                                   f"step dt = {dt:g}")
    return int(k)
