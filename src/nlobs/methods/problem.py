r"""What every design reads from a model file, by one rule: the :class:`Problem`.

Every command that designs an observer (``nlobs advise``, ``design``, ``export``, ``simulate``) builds
one :class:`Problem` from the model file and the options given, and hands it to a method
(:mod:`nlobs.methods.registry`). Each default is taken from the file by the same rule, and each value
keeps where it came from (:attr:`Problem.sources`), so a report can say "μ = 10.31 from
[input_signals] over [0, 10]":

* the **region** of the designs: the given box, else the file's ``[simulation] box``, else
  ``[−1, 1]ⁿ``;
* the **initial state** ``x0`` (the point of a linearisation): the given one, else
  ``[simulation] x0``, else zeros;
* the **horizon** ``T``: the given duration, else ``[simulation] duration``, else 10;
* the **known input** ``u(t)``: the given signals, else the file's ``[input_signals]``, else zero;
  ``u0 = u(0)``;
* the **input bound** ``μ`` of (2.17) of Dalla Mora, Germani & Manes: the largest ``‖u(t)‖`` of
  that input at :data:`INPUT_BOUND_SAMPLES` instants of ``[0, T]`` (:func:`input_bound`).

The module also holds the plain-value inputs the designs share (a box from numbers, a nonlinear
model from a file or a name, how messages name a model); :mod:`nlobs.workflows.inputs` re-exports
them. It loads no solver, observer or simulation.
"""

from __future__ import annotations

import math

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import readonly
from nlobs.errors import DimensionError, InvalidArgumentError, ModelError, NlobsError, NonFiniteError
from nlobs.geometry.region import Box
from nlobs.systems.linear import LinearSystem
from nlobs.systems.modelfile import load_model
from nlobs.systems.scenario import Scenario
from nlobs.systems.sensors import MeasurementGroup
from nlobs.systems.symbolic import SymbolicModel

__all__ = [
    "DEFAULT_DURATION",
    "INPUT_BOUND_SAMPLES",
    "MAX_SIMULATION_STEPS",
    "BoxError",
    "Problem",
    "as_region",
    "box_from_numbers",
    "input_bound",
    "input_range",
    "model_label",
    "problem",
    "symbolic_model",
]

#: The horizon ``T`` without ``[simulation] duration`` or a given duration.
DEFAULT_DURATION = 10.0
#: Instants of ``[0, T]`` at which ``‖u(t)‖`` is evaluated for the input bound ``μ``.
INPUT_BOUND_SAMPLES = 4001
#: Most RK4 steps one simulation of a design may take (``ceil(duration / dt)``); beyond it the loop would run for hours.
MAX_SIMULATION_STEPS = 10_000_000


class BoxError(InvalidArgumentError):
    """A region given as numbers is malformed (the message does not name the parameter: its caller prefixes it).

    Examples
    --------
    Three numbers make no box of ``ℝ²`` (2 or 4 are needed); the error is an ``InvalidArgumentError``:

    >>> try:
    ...     box_from_numbers([0, 1, 2], 2)
    ... except BoxError as exc:
    ...     print(type(exc).__name__, isinstance(exc, InvalidArgumentError), "|", exc)
    BoxError True | expected 'lo,hi' or 4 numbers lo1,hi1,...; got 3 numbers
    """


#: The largest bound of a region given as numbers (``--box``): beyond it the sampled rank and Lipschitz checks,
#: which scale each state by the region's size, lose every digit (a box of ±1e300 called A1 failed with det Q = 1).
MAX_BOX_BOUND = 1e100


def box_from_numbers(values: Sequence[float], n: int) -> Box:
    """A box from ``lo, hi`` (the same interval for every state) or ``2n`` numbers ``lo1, hi1, lo2, hi2, ...``.

    Parameters
    ----------
    values : sequence of float
        ``2`` or ``2n`` numbers.
    n : int
        Number of states.

    Returns
    -------
    Box

    Raises
    ------
    BoxError
        Not 2 or ``2n`` numbers, or an invalid box (non-finite, ``lo > hi``, a bound above
        :data:`MAX_BOX_BOUND` in magnitude).

    Examples
    --------
    The same interval for both states, or one interval per state:

    >>> box_from_numbers([-1, 1], 2).describe()
    '[-1, 1] × [-1, 1]'
    >>> b = box_from_numbers([-1, 1, 0, 2], 2)
    >>> b.lower.tolist(), b.upper.tolist()
    ([-1.0, 0.0], [1.0, 2.0])
    >>> try:
    ...     box_from_numbers([1, 0], 2)
    ... except BoxError as exc:
    ...     print(type(exc).__name__, exc)
    BoxError Box: upper[0] = 0 must exceed lower[0] = 1
    """
    vals = [float(v) for v in values]
    big = [v for v in vals if math.isfinite(v) and abs(v) > MAX_BOX_BOUND]
    if big:  # the sampled checks scale by the region: such a box has no meaning and no digits left
        raise BoxError(f"a bound {big[0]:g} is larger than {MAX_BOX_BOUND:g} in magnitude; give the region the states "
                       "really visit")
    if len(vals) == 2:
        vals = vals * n
    if len(vals) != 2 * n:
        raise BoxError(f"expected 'lo,hi' or {2 * n} numbers lo1,hi1,...; got {len(values)} numbers")
    try:
        return Box(np.array(vals[0::2]), np.array(vals[1::2]))
    except NlobsError as exc:
        raise BoxError(str(exc)) from exc


def as_region(box: Sequence[float] | Box | None, n: int) -> Box | None:
    """``None``, a given :class:`~nlobs.geometry.region.Box` (its dimension checked), or :func:`box_from_numbers`.

    Parameters
    ----------
    box : sequence of float, Box or None
        The region, as numbers (see :func:`box_from_numbers`) or a box.
    n : int
        Number of states.

    Returns
    -------
    Box or None
        ``None`` when ``box`` is ``None``.

    Raises
    ------
    BoxError
        Numbers that do not make a box of ``ℝⁿ``, or a box of another dimension.
    """
    if box is None:
        return None
    if isinstance(box, Box):
        if box.n != n:
            raise BoxError(f"the region has dimension {box.n}, the model has n = {n}")
        return box
    return box_from_numbers(box, n)


def symbolic_model(model: str | Path | SymbolicModel) -> SymbolicModel:
    """The nonlinear model behind ``model``: a model file, a shipped model name, or a loaded model.

    Parameters
    ----------
    model : str, Path or SymbolicModel
        A model file, a shipped model name or a loaded model.

    Returns
    -------
    SymbolicModel

    Raises
    ------
    ModelFileError
        The file cannot be found, read or validated (the message names the file and line).
    ModelError
        The model is linear (``"a nonlinear (symbolic) model is needed; this one is linear"``).
    InvalidArgumentError
        ``model`` is neither a path, a name nor a model.

    Examples
    --------
    >>> m = symbolic_model("pendulum")
    >>> type(m).__name__, m.name, m.states, m.outputs
    ('SymbolicModel', 'pendulum', ('theta', 'omega'), ('y',))
    >>> try:
    ...     symbolic_model("gnss-ins-axis")
    ... except ModelError as exc:
    ...     print(type(exc).__name__, exc)
    ModelError a nonlinear (symbolic) model is needed; this one is linear
    """
    m = load_model(model) if isinstance(model, (str, Path)) else model
    if isinstance(m, SymbolicModel):
        return m
    if isinstance(m, LinearSystem):
        raise ModelError("a nonlinear (symbolic) model is needed; this one is linear")
    raise InvalidArgumentError(f"model: expected a model file, a shipped model name or a model, got {type(model).__name__}")


def model_label(model: str | Path | Any) -> str:
    """How messages name ``model``: a path or shipped name as given, else the model's ``name``.

    Parameters
    ----------
    model : str, Path or model
        A path, a shipped model name or a loaded model.

    Returns
    -------
    str
    """
    if isinstance(model, (str, Path)):
        return str(model)
    return str(getattr(model, "name", type(model).__name__))


def _input_samples(u: Any, duration: float, m: int) -> Array:
    """``u(t)`` at :data:`INPUT_BOUND_SAMPLES` evenly spaced instants of ``[0, T]`` and as many of the golden-ratio
    sequence (a periodic input cannot alias to ~0 on both), shape ``(2 INPUT_BOUND_SAMPLES − 1, m)``."""
    k = np.arange(INPUT_BOUND_SAMPLES - 1)
    ts = np.concatenate([np.linspace(0.0, float(duration), INPUT_BOUND_SAMPLES),
                         float(duration) * np.mod(0.5 + k * 0.6180339887498949, 1.0)])
    return np.stack([np.asarray(u(float(t)), dtype=float).reshape(m) for t in ts])


def input_bound(u: Any, duration: float, m: int) -> float:
    """``μ`` of (2.17): the largest ``‖u(t)‖`` at :data:`INPUT_BOUND_SAMPLES` instants of ``[0, duration]``.

    Parameters
    ----------
    u : callable, array_like or None
        The known input: a signal ``u(t)`` (an :class:`~nlobs.systems.signals.InputSignals` or any
        callable), a constant vector, or ``None`` (zero).
    duration : float
        The horizon ``T``.
    m : int
        Number of inputs (``0``: ``μ = 0``).

    Returns
    -------
    float
    """
    if not m or u is None:
        return 0.0
    if not callable(u):
        return float(np.linalg.norm(np.asarray(u, dtype=float)))
    values = _input_samples(u, duration, m)
    return float(np.max(np.linalg.norm(values, axis=-1)))


def input_range(u: Any, duration: float, m: int) -> tuple[Array, Array]:
    """The smallest and largest value of each input channel at the instants of :func:`input_bound`.

    Parameters
    ----------
    u : callable, array_like or None
        The known input (as :func:`input_bound`).
    duration : float
        The horizon ``T``.
    m : int
        Number of inputs.

    Returns
    -------
    lower, upper : ndarray, shape (m,)
    """
    if not m or u is None:
        return np.zeros(m), np.zeros(m)
    if not callable(u):
        v = np.asarray(u, dtype=float).reshape(m)
        return v.copy(), v.copy()
    values = _input_samples(u, duration, m)
    return values.min(axis=0), values.max(axis=0)


def _vector(name: str, value: ArrayLike, n: int) -> Array:
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.shape != (n,):
        raise DimensionError(f"{name}: expected {n} numbers (one per state), got {v.size}")
    if not np.all(np.isfinite(v)):
        raise NonFiniteError(f"{name}: values must be finite, got {v.tolist()}")
    return v


@dataclass(frozen=True, eq=False)
class Problem:
    """A model with everything a design reads from its file, each value with its source.

    Build it with :func:`problem` (from a file, a shipped name or a model) or, inside a command
    that has already read the file, with the constructor.

    Attributes
    ----------
    scenario : Scenario
        The model file's tables (:mod:`nlobs.systems.scenario`).
    label : str
        How messages name the model (the path or name as given).
    region : Box
        The region of the designs.
    x0 : ndarray, shape (n,)
        The initial plant state; the point of a linearisation.
    u : callable, ndarray or None
        The known input ``u(t)`` (a signal), a constant vector, or ``None`` (no inputs).
    duration : float
        The horizon ``T`` (of the input bound, and of a simulation unless one says otherwise).
    mu : float
        The largest ``‖u(t)‖`` on ``[0, T]`` (:func:`input_bound`).
    sensors : tuple of MeasurementGroup
        The measurement groups (the file's ``[sensors]``, or those a command was given).
    process_noise : ndarray or None
        The process-noise covariance (spectral density).
    sources : mapping of str to str
        Where ``region``, ``x0``, ``duration``, ``mu`` came from.

    Examples
    --------
    The shipped DC motor drives its voltage with ``V(t) = 6 + 2 sin(2π t)``: over the file's
    ``duration = 3`` its largest value, ``μ = 8``, is the input bound of (2.17) of Dalla Mora,
    Germani & Manes; the region and ``x0`` come from its ``[simulation]`` table:

    >>> pb = problem("dc-motor-load")
    >>> pb.label, pb.duration, round(pb.mu, 6), pb.u0.tolist()
    ('dc-motor-load', 3.0, 8.0, [6.0])
    >>> pb.describe("mu")
    'μ = 8 (max ‖u(t)‖ of [input_signals] over [0, 3])'
    >>> pb.region.describe(), pb.sources["region"], pb.x0.tolist()
    ('[-2, 4] × [20, 200] × [-0.1, 0.15]', '[simulation] box', [0.84, 103.2, 0.02])
    >>> pb.exact
    (False, 'measurement noise or bias and process noise')

    A value given to :func:`problem` wins, and says so; over ``[0, 1/8]`` the sine rises only to
    ``sin(π/4)``, so ``μ = 6 + √2``:

    >>> pb = problem("dc-motor-load", box=[-1, 1], duration=0.125)
    >>> pb.sources["region"], pb.sources["duration"], round(pb.mu, 6), round(6 + 2**0.5, 6)
    ('given', 'given', 7.414214, 7.414214)
    """

    scenario: Scenario
    label: str
    region: Box
    x0: Array
    u: Any
    duration: float
    mu: float
    sensors: tuple[MeasurementGroup, ...] = ()
    process_noise: Array | None = None
    sources: Mapping[str, str] = field(default_factory=dict)

    @property
    def model(self) -> SymbolicModel | LinearSystem:
        """The model of the file."""
        return self.scenario.model

    @property
    def path(self) -> Path | None:
        """The model file, or ``None`` (a shipped name's text, a model given in Python)."""
        p = self.scenario.path
        return Path(p) if p and Path(p).is_file() else None

    @property
    def u0(self) -> Array:
        """``u(0)`` (zeros for a model without inputs)."""
        m = self.model.m
        if not m or self.u is None:
            return np.zeros(m)
        return np.asarray(self.u(0.0) if callable(self.u) else self.u, dtype=float).reshape(m)

    @property
    def exact(self) -> tuple[bool, str]:
        """Whether the output and the model are exact, and if not what makes them inexact."""
        noisy = any(np.any(np.asarray(g.noise_std) > 0) or np.any(g.bias != 0) for g in self.sensors)
        q = self.process_noise is not None and bool(np.any(self.process_noise))
        what = [w for w, on in (("measurement noise or bias", noisy), ("process noise", q)) if on]
        return not what, " and ".join(what)

    @cached_property
    def input_range(self) -> tuple[Array, Array]:
        """Per input channel, the smallest and largest ``u(t)`` on ``[0, T]`` (:func:`input_range`)."""
        return input_range(self.u, self.duration, self.model.m)

    @property
    def p0(self) -> Array | None:
        """``diag(initial_error_std²)`` of the file's ``[simulation]`` (``None`` without one)."""
        std = self.scenario.defaults.initial_error_std
        if std is None:
            return None
        s = np.broadcast_to(np.asarray(std, dtype=float).reshape(-1), (self.model.n,))
        return np.diag(s**2)

    @property
    def settle(self) -> float:
        """The time after which errors are reported: ``[simulation] settle``, else a quarter of the horizon."""
        s = self.scenario.defaults.settle
        return float(s) if s is not None else self.duration / 4

    @cached_property
    def observability(self) -> Any:
        """The :class:`~nlobs.geometry.unobservable.Unobservability` of the model on the region, or ``None``.

        The generic rank of the observability codistribution on :attr:`region` and its kernel, named
        (a continuous-time input-affine model); the rank of the observability matrix (a linear model);
        ``None`` when neither applies or the model cannot be evaluated there. Computed once.
        """
        from nlobs.geometry.observability import AffineFields
        from nlobs.geometry.unobservable import linear_unobservable_directions, unobservable_directions

        model = self.model
        try:
            if isinstance(model, LinearSystem):
                return linear_unobservable_directions(model.A, model.C, model.states)
            if model.time.is_discrete:
                return None
            return unobservable_directions(AffineFields.from_model(model), self.region)
        except NlobsError:
            return None

    def not_observable(self) -> str | None:
        """``None`` when the model is observable from its outputs (or that is unknown), else the evidence."""
        u = self.observability
        if u is None or u.rank is None or u.observable:
            return None
        return f"the model is {u.describe()}"

    def describe(self, name: str) -> str:
        """``"μ = 10.31 (max ‖u(t)‖ of [input_signals] over [0, 10])"`` for ``name`` in :attr:`sources`."""
        value = {"region": self.region.describe(), "x0": str(self.x0.tolist()), "duration": f"{self.duration:g}",
                 "mu": f"{self.mu:.4g}"}[name]
        return f"{'μ' if name == 'mu' else name} = {value} ({self.sources.get(name, 'given')})"


def _from_defaults(scenario: Scenario, box: Sequence[float] | Box | None, x0: ArrayLike | None,
                   duration: float | None) -> tuple[Box, str, Array, str, float, str]:
    model, d = scenario.model, scenario.defaults
    n = model.n
    region = as_region(box, n)
    if region is not None:
        region_src = "given"
    elif d.box is not None:
        region, region_src = Box(np.asarray(d.box[0], dtype=float), np.asarray(d.box[1], dtype=float)), \
            "[simulation] box"
    else:
        region, region_src = Box.unit(n), "default [-1, 1] per state"
    if x0 is not None:
        x, x_src = _vector("x0", x0, n), "given"
    elif d.x0 is not None:
        x, x_src = np.asarray(d.x0, dtype=float).reshape(n), "[simulation] x0"
    else:
        x, x_src = np.zeros(n), "default zeros"
    if duration is not None:
        T, T_src = float(duration), "given"
    elif d.duration is not None:
        T, T_src = float(d.duration), "[simulation] duration"
    else:
        T, T_src = DEFAULT_DURATION, f"default {DEFAULT_DURATION:g}"
    if not (np.isfinite(T) and T > 0):
        raise InvalidArgumentError(f"duration: must be positive and finite, got {T!r}")
    return region, region_src, x, x_src, T, T_src


def problem(model: str | Path | Scenario | SymbolicModel | LinearSystem, *, box: Sequence[float] | Box | None = None,
            x0: ArrayLike | None = None, duration: float | None = None, u: Any = None, u_source: str | None = None,
            sensors: Sequence[MeasurementGroup] | None = None, process_noise: ArrayLike | None = None,
            label: str | None = None) -> Problem:
    """The :class:`Problem` of a model file (read once) and the options given (module docstring for the rules).

    Parameters
    ----------
    model : str, Path, Scenario, SymbolicModel or LinearSystem
        A model file, a shipped model name, a file already read, or a model.
    box : sequence of float or Box, optional
        The region (``lo, hi`` or ``lo1, hi1, …``).
    x0 : array_like, optional
        The initial state.
    duration : float, optional
        The horizon ``T``.
    u : callable or array_like, optional
        The known input, instead of the file's ``[input_signals]``.
    u_source : str, optional
        How to name a given ``u`` in :attr:`Problem.sources` (default ``"the given input"``).
    sensors : sequence of MeasurementGroup, optional
        Instead of the file's ``[sensors]``.
    process_noise : array_like, optional
        A covariance, instead of the file's ``[process_noise]``.
    label : str, optional
        How messages name the model.

    Returns
    -------
    Problem

    Raises
    ------
    ModelFileError
        The file cannot be read.
    BoxError, DimensionError, NonFiniteError, InvalidArgumentError
        A malformed option.
    """
    from nlobs.systems.modelfile import load_scenario

    if isinstance(model, Scenario):
        scenario = model
    elif isinstance(model, (str, Path)):
        scenario = load_scenario(model)
    else:
        scenario = Scenario(model)
    name = label if label is not None else model_label(model if not isinstance(model, Scenario) else scenario.model)
    region, region_src, x, x_src, T, T_src = _from_defaults(scenario, box, x0, duration)
    m = scenario.model.m
    if u is not None:
        sig, sig_src = u, u_source or "the given input"
    elif scenario.input_signals is not None:
        sig, sig_src = scenario.input_signals, "[input_signals]"
    else:
        sig, sig_src = (np.zeros(m) if m else None), "no [input_signals]: zero input"
    mu = input_bound(sig, T, m)
    if not m:
        mu_src = "the model has no inputs"
    elif callable(sig):
        mu_src = f"max ‖u(t)‖ of {sig_src} over [0, {T:g}]"
    else:
        mu_src = sig_src if u is None else f"‖u‖ of {sig_src}"
    q = scenario.process_noise if process_noise is None else np.asarray(process_noise, dtype=float)
    return Problem(scenario, name, region, readonly(x), sig, T, mu,
                   tuple(scenario.sensors if sensors is None else sensors), q,
                   {"region": region_src, "x0": x_src, "duration": T_src, "mu": mu_src})

