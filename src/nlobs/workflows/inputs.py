"""Inputs of the workflows given as plain values (what a command line or a script has).

* :func:`box_from_numbers` — a region (:class:`~nlobs.geometry.region.Box`) from ``lo, hi`` (every
  state) or ``lo1, hi1, …, lon, hin``; :func:`as_region` — the same, or a given box checked;
* :func:`symbolic_model` — a nonlinear model from a model file, a shipped name
  (:func:`nlobs.systems.modelfile.load_model`) or an already loaded model;
* :class:`SimulationRequest` — initial plant state and estimate, constant input, horizon, step,
  and the folder for the plot and trajectories;
* :func:`escape_unsafe` — text with control characters escaped (for anything that reaches a
  terminal).

The command line imports this module when it starts: it loads no solver, observer or simulation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import escape_unsafe, positive, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, NlobsError, NonFiniteError
from nlobs.geometry.region import Box
from nlobs.methods.problem import MAX_SIMULATION_STEPS, BoxError, as_region, box_from_numbers, model_label, symbolic_model
from nlobs.systems.symbolic import SymbolicModel

__all__ = [
    "Box",
    "BoxError",
    "MAX_SIMULATION_BYTES",
    "MAX_SIMULATION_STEPS",
    "SimulationRequest",
    "SymbolicModel",
    "as_region",
    "box_from_numbers",
    "escape_unsafe",
    "model_label",
    "symbolic_model",
]


#: Most bytes the trajectories of one :class:`SimulationRequest` may hold (time, state, estimate, output, sample flags).
MAX_SIMULATION_BYTES = 2 * 1024**3


def model_units(model: str | Path | Any) -> dict[str, str]:
    """The ``units`` table of the model file behind ``model`` (``{}`` for a loaded model or a file without one).

    For axis labels only: a file that does not parse as a scenario gives ``{}`` (its errors are
    reported by whatever loads it as a model).
    """
    if not isinstance(model, (str, Path)):
        return {}
    from nlobs.systems.modelfile import load_scenario

    try:
        return dict(load_scenario(model).units)
    except NlobsError:
        return {}


def _finite_vector(name: str, value: ArrayLike | None) -> Array | None:
    if value is None:
        return None
    v = np.asarray(value, dtype=float)
    if v.ndim != 1:
        raise DimensionError(f"{name}: expected a list of numbers, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise NonFiniteError(f"{name}: values must be finite, got {v.tolist()}")
    return readonly(v, owned=True)


def _option(name: str, value: float) -> float:
    """A positive, finite ``duration`` / ``dt`` (the message names the parameter, ``name``)."""
    try:
        return positive(name, value)
    except NlobsError as exc:
        raise type(exc)(f"{exc} (a positive number of seconds)") from None


@dataclass(frozen=True, eq=False)
class SimulationRequest:
    """A simulation of a designed observer against its plant (the ``simulate`` of the design workflows).

    Parameters
    ----------
    x0 : array_like, shape (n,)
        Initial plant state.
    x_hat0 : array_like, shape (n,), optional
        Initial estimate (default: zeros).
    u : array_like, shape (m,), optional
        Constant input (default: zeros).
    duration : float
        Simulated time [s], positive and finite.
    dt : float
        RK4 step [s], positive and finite; it must resolve the gain's fastest pole. At most
        :data:`MAX_SIMULATION_STEPS` steps ``ceil(duration / dt)``.
    out : path, optional
        Folder for the plot (``<stem>.png``) and the trajectories (``<stem>.npz``); created if
        missing. ``None``: nothing is written.

    Examples
    --------
    Two seconds of a 2-state, 1-input model at ``dt = 0.01``: 200 RK4 steps (and 0.3 s at 0.1 s is 3 steps,
    although ``0.3 / 0.1`` is ``3.0000000000000004`` in floating point); the defaults are filled in against
    the model's sizes, which also catch a vector of the wrong length:

    >>> req = SimulationRequest([0.5, 0.0], duration=2.0, dt=0.01)
    >>> req.steps, req.x_hat0, req.u, req.out, SimulationRequest([1.0], duration=0.3, dt=0.1).steps
    (200, None, None, None, 3)
    >>> [v.tolist() for v in req.resolved(2, 1, "pendulum")]  # x0, x̂0 = 0, u = 0
    [[0.5, 0.0], [0.0, 0.0], [0.0]]
    >>> try:
    ...     req.resolved(3, 1, "a 3-state model")
    ... except DimensionError as exc:
    ...     print(type(exc).__name__, exc)
    DimensionError `x0`: expected 3 numbers for model a 3-state model, got 2
    >>> try:
    ...     SimulationRequest([0.5, 0.0], duration=1.0, dt=2.0)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError `dt` 2 is longer than `duration` 1: the one step would end past the run ...
    """

    x0: Array
    x_hat0: Array | None = None
    u: Array | None = None
    duration: float = 10.0
    dt: float = 1e-3
    out: Path | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "x0", _finite_vector("`x0`", self.x0))
        object.__setattr__(self, "x_hat0", _finite_vector("`x_hat0`", self.x_hat0))
        object.__setattr__(self, "u", _finite_vector("`u`", self.u))
        object.__setattr__(self, "duration", _option("`duration`", self.duration))
        object.__setattr__(self, "dt", _option("`dt`", self.dt))
        if self.dt > self.duration * (1 + 1e-12):
            raise InvalidArgumentError(f"`dt` {self.dt:g} is longer than `duration` {self.duration:g}: the one step would "
                                       "end past the run (take `dt` at most `duration`)")
        steps = self.steps
        if steps > MAX_SIMULATION_STEPS:
            raise InvalidArgumentError(
                f"`duration` {self.duration:g} / `dt` {self.dt:g} is {steps:.3g} RK4 steps; at most "
                f"{MAX_SIMULATION_STEPS:.0e} are simulated (raise `dt` or shorten `duration`)")
        if self.out is not None:
            object.__setattr__(self, "out", Path(self.out))

    @property
    def steps(self) -> int:
        """The RK4 steps of the simulation, ``ceil(duration / dt)`` (as :func:`nlobs.simulate.simulate` counts them)."""
        ratio = self.duration / self.dt
        return max(1, math.ceil(ratio - 1e-9)) if math.isfinite(ratio) else math.inf  # type: ignore[return-value]

    def memory_bytes(self, n: int, p: int) -> int:
        """Bytes of the saved trajectories: per step ``t``, ``x`` and ``x̂`` (``n`` each), ``y`` (``p``), float64, and ``p`` flags."""
        return (self.steps + 1) * (8 * (1 + 2 * n + p) + p)

    def resolved(self, n: int, m: int, model: str, p: int = 0) -> tuple[Array, Array, Array]:
        """``(x0, x_hat0, u)`` with the defaults filled in, checked against the model's ``n`` and ``m``.

        Raises
        ------
        DimensionError
            A vector of the wrong length (the message names it and the model).
        InvalidArgumentError
            The trajectories would hold more than :data:`MAX_SIMULATION_BYTES` (``p`` outputs).
        """
        size = self.memory_bytes(n, p)
        if size > MAX_SIMULATION_BYTES:
            raise InvalidArgumentError(
                f"`duration` {self.duration:g} / `dt` {self.dt:g}: {self.steps} steps of model {model} need about "
                f"{size / 1024**3:.3g} GiB of trajectories; at most {MAX_SIMULATION_BYTES / 1024**3:g} GiB "
                "(raise `dt` or shorten `duration`)")
        x_hat0 = np.zeros(n) if self.x_hat0 is None else self.x_hat0
        u = np.zeros(m) if self.u is None else self.u
        for name, v, size in (("`x0`", self.x0, n), ("`x_hat0`", x_hat0, n), ("`u`", u, m)):
            if v.size != size:
                raise DimensionError(f"{name}: expected {size} numbers for model {model}, got {v.size}")
        return self.x0, x_hat0, u
