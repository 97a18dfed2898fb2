"""Known input signals ``u(t)``: constants, callables and sampled arrays.

Every signal is turned by :func:`as_input_function` into a callable
``t ↦ u(t)`` returning an array of shape ``(*batch, m)`` (or a shape that
broadcasts to it). The loop calls it at every RK4 stage, so a signal must be
cheap to evaluate and must not hold hidden state.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_finite_array, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError

InputFunction = Callable[[float], Array]


@dataclass(frozen=True)
class SampledSignal:
    """An input given by samples ``values[..., k, :]`` at increasing times ``times[k]``.

    Parameters
    ----------
    times : array_like, shape (K,)
        Strictly increasing sample times (seconds).
    values : array_like, shape (K, m) or (*batch, K, m)
        Input values; a leading batch shape gives each trajectory its own input.
    kind : {"hold", "linear"}
        ``"hold"``: zero-order hold, ``u(t) = values[k]`` for ``times[k] <= t < times[k+1]``;
        ``"linear"``: linear interpolation between samples.

    Notes
    -----
    Before ``times[0]`` the signal is undefined (:func:`simulate` rejects a
    start time earlier than ``times[0]``); after ``times[-1]`` the last value is held.

    Examples
    --------
    A step from 0 to 1 at ``t = 1``, held or interpolated; after the last sample the last value is held:

    >>> import numpy as np
    >>> import nlobs
    >>> step = SampledSignal([0.0, 1.0], [[0.0], [1.0]])
    >>> ramp = SampledSignal([0.0, 1.0], [[0.0], [1.0]], kind="linear")
    >>> step.m, step(0.5).tolist(), step(1.0).tolist(), ramp(0.5).tolist(), ramp(3.0).tolist()
    (1, [0.0], [1.0], [0.5], [1.0])

    Driving the integrator ``ẋ = u`` for 2 s: the held step gives ``x(2) = 1`` (the loop integrates a held
    input exactly), the ramp ``x(2) = 1/2 + 1``:

    >>> plant = nlobs.LinearSystem([[0.0]], [[1.0]], [[1.0]])
    >>> [round(float(nlobs.simulate(plant, None, [0.0], duration=2.0, dt=0.1, u=sig).x[-1, 0]), 9)
    ...  for sig in (step, ramp)]
    [1.0, 1.5]

    A leading batch axis gives each run its own input (here a step and a constant 2):

    >>> both = SampledSignal([0.0, 1.0], [[[0.0], [1.0]], [[2.0], [2.0]]])
    >>> res = nlobs.simulate(plant, None, [[0.0], [0.0]], duration=2.0, dt=0.1, u=both)
    >>> both(0.5).tolist(), res.x[:, -1, 0].round(9).tolist()
    ([[0.0], [2.0]], [1.0, 4.0])
    >>> try:
    ...     SampledSignal([0.0, 0.0], [[0.0], [1.0]])
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError SampledSignal.times: must be strictly increasing
    """

    times: Array
    values: Array
    kind: Literal["hold", "linear"] = "hold"

    def __post_init__(self) -> None:
        t = as_finite_array("SampledSignal.times", self.times, ndim=1)
        v = as_finite_array("SampledSignal.values", self.values)
        if t.size == 0:
            raise DimensionError("SampledSignal.times: at least one sample is required")
        if np.any(np.diff(t) <= 0):
            raise InvalidArgumentError("SampledSignal.times: must be strictly increasing")
        if v.ndim < 2 or v.shape[-2] != t.size:
            raise DimensionError(
                f"SampledSignal.values: expected shape ({t.size}, m) or (*batch, {t.size}, m), got {v.shape}"
            )
        if self.kind not in ("hold", "linear"):
            raise InvalidArgumentError(f"SampledSignal.kind: expected 'hold' or 'linear', got {self.kind!r}")
        object.__setattr__(self, "times", readonly(t))
        object.__setattr__(self, "values", readonly(v))

    @property
    def m(self) -> int:
        """Number of input channels."""
        return int(self.values.shape[-1])

    def __call__(self, t: float) -> Array:
        """Value at time ``t``, shape ``(*batch, m)``."""
        times = self.times
        k = int(np.searchsorted(times, t, side="right")) - 1
        k = min(max(k, 0), times.size - 1)
        if self.kind == "hold" or k == times.size - 1 or t <= times[0]:
            return self.values[..., k, :]
        w = (t - times[k]) / (times[k + 1] - times[k])
        return (1.0 - w) * self.values[..., k, :] + w * self.values[..., k + 1, :]


InputLike = None | ArrayLike | Callable[[float], ArrayLike] | SampledSignal


def as_input_function(u: InputLike, m: int, batch_shape: tuple[int, ...], t0: float) -> InputFunction:
    """Turn an input specification into a callable ``t ↦ u(t)`` of shape ``(*batch, m)``.

    Parameters
    ----------
    u : None, array_like, callable or SampledSignal
        ``None`` is allowed only when the plant has no inputs (``m = 0``).
        An array is a constant input of shape ``(m,)`` or ``(*batch, m)``.
        A callable ``u(t)`` returns an array of shape ``(m,)`` or ``(*batch, m)``.
    m : int
        Number of plant inputs.
    batch_shape : tuple of int
        Leading batch shape of the simulation.
    t0 : float
        Start time; the signal is evaluated once there to check its shape and finiteness.

    Returns
    -------
    callable
        ``t ↦ u(t)``, returning an array broadcast to ``(*batch, m)``.

    Raises
    ------
    DimensionError
        The signal does not broadcast to ``(*batch, m)``.
    NonFiniteError
        The signal is not finite at ``t0``.
    InvalidArgumentError
        ``u`` is missing although the plant has inputs, or a sampled signal starts after ``t0``.
    """
    full = (*batch_shape, m)
    if u is None:
        if m != 0:
            raise InvalidArgumentError(f"u: the plant has {m} input(s); pass a constant, a callable u(t) or a SampledSignal")
        zeros = np.zeros(full)
        zeros.setflags(write=False)
        return lambda t: zeros
    if isinstance(u, SampledSignal):
        if u.times[0] > t0:
            raise InvalidArgumentError(f"u: the sampled signal starts at t={u.times[0]:g}, after the start time t0={t0:g}")
        fn: Callable[[float], ArrayLike] = u
    elif callable(u):
        fn = u
    else:
        const = np.array(_check_shape("u", as_finite_array("u", u), full))
        const.setflags(write=False)
        return lambda t: const
    raw = np.asarray(fn(t0), dtype=float)
    first = _check_shape("u", raw, full)
    if not np.all(np.isfinite(first)):
        raise NonFiniteError(f"u: the input is not finite at t0={t0:g}")
    memo = _last_two if isinstance(u, SampledSignal) or _is_input_signals(u) else (lambda f: f)
    if raw.shape == full:
        return memo(lambda t: np.asarray(fn(t), dtype=float))
    return memo(lambda t: np.broadcast_to(np.asarray(fn(t), dtype=float), full))


def _is_input_signals(u: object) -> bool:
    """Whether ``u`` is a model file's :class:`~nlobs.systems.signals.InputSignals` (that module not imported for it:
    if it is not loaded, no object can be one)."""
    module = sys.modules.get("nlobs.systems.signals")
    return module is not None and isinstance(u, module.InputSignals)


def _last_two(fn: InputFunction) -> InputFunction:
    """``fn`` remembering its last two times: an RK4 step asks ``u`` at ``t``, twice at ``t + h/2`` and at ``t + h``
    (the next step's ``t``), and the loop asks again at each sample and saved step. For nlobs's own signals (a
    :class:`SampledSignal`, a model file's :class:`~nlobs.systems.signals.InputSignals`): each call returns a new
    array or a read-only view and depends on ``t`` alone, so the value at a time is the value. A caller's own
    callable is called every time (it may reuse its output buffer)."""
    times: list[float | None] = [None, None]
    values: list[Array | None] = [None, None]

    def call(t: float) -> Array:
        if t == times[1]:
            return values[1]  # type: ignore[return-value]
        if t == times[0]:
            return values[0]  # type: ignore[return-value]
        v = fn(t)
        times[0], values[0], times[1], values[1] = times[1], values[1], t, v
        return v

    return call


def _check_shape(name: str, value: Array, full: tuple[int, ...]) -> Array:
    try:
        return np.broadcast_to(value, full)
    except ValueError:
        raise DimensionError(f"{name}: shape {np.shape(value)} does not broadcast to (*batch, m) = {full}") from None
