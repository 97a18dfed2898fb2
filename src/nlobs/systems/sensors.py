"""Sensors: which outputs (or inputs) are read, how often, and how badly.

A :class:`MeasurementGroup` is a set of plant outputs read by one sensor at one rate, e.g. an
IMU at 100 Hz and a GNSS receiver at 5 Hz; an :class:`InputSensor` is the same for plant inputs
(the plant is driven by the true ``u(t)``, the observer receives the sampled, noisy reading).
Each has a required rate, additive zero-mean Gaussian noise (a standard deviation per channel or
a full covariance), an optional constant bias, and optional outage windows in which the sensor
delivers nothing. These are descriptions only; the simulation loop
(:mod:`nlobs.simulate.sampling`) schedules and draws them. Model files describe them in a
``[sensors]`` table (:mod:`nlobs.systems.modelfile`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_covariance, as_finite_array, positive, readonly
from nlobs.errors import DimensionError, InvalidArgumentError

__all__ = ["InputSensor", "MeasurementGroup", "covariance_factor"]


def _check_std(owner: str, noise_std: float | Sequence[float] | ArrayLike, count: int) -> Array:
    std = as_finite_array(f"{owner}: noise_std", noise_std)
    if std.ndim == 0:
        std = np.full(count, float(std))
    if std.shape != (count,):
        raise DimensionError(f"{owner}: noise_std must be a scalar or have one entry per channel ({count}), got shape {std.shape}")
    if np.any(std < 0):
        raise InvalidArgumentError(f"{owner}: noise_std must be non-negative, got {std.tolist()}")
    std.setflags(write=False)
    return std


def _check_bias(owner: str, bias: Any, count: int) -> Array:
    b = as_finite_array(f"{owner}: bias", bias)
    if b.ndim == 0:
        b = np.full(count, float(b))
    if b.shape != (count,):
        raise DimensionError(f"{owner}: bias must be a scalar or have one entry per channel ({count}), got shape {b.shape}")
    return readonly(b, owned=True)


def _check_outages(owner: str, outages: Any) -> tuple[tuple[float, float], ...]:
    if outages is None:
        return ()
    try:
        arr = as_finite_array(f"{owner}: outages", outages)
    except DimensionError:
        raise
    if arr.size == 0:
        return ()
    if arr.ndim == 1 and arr.size == 2:
        arr = arr.reshape(1, 2)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise DimensionError(f"{owner}: outages must be a list of [start, end] windows in seconds, got shape {arr.shape}")
    for start, end in arr:
        if not end > start:
            raise InvalidArgumentError(f"{owner}: outage window [{start:g}, {end:g}] must have end > start")
    return tuple((float(a), float(b)) for a, b in arr)


def _check_channels(owner: str, what: str, channels: Sequence[int | str]) -> tuple[int | str, ...]:
    if isinstance(channels, (str, int)):
        channels = (channels,)
    out = tuple(channels)
    if not out:
        raise InvalidArgumentError(f"{owner}: at least one {what} is required")
    for c in out:
        if not isinstance(c, (str, int, np.integer)) or isinstance(c, bool):
            raise InvalidArgumentError(f"{owner}: {what} {c!r} is neither an index nor a name")
    if len(set(out)) != len(out):
        raise InvalidArgumentError(f"{owner}: repeated {what} in {out}")
    return out


def covariance_factor(cov: Array) -> Array:
    """A matrix ``L`` with ``L Lᵀ = cov`` for a symmetric positive semidefinite ``cov``.

    Cholesky when ``cov`` is positive definite; otherwise from the eigen-decomposition
    (``V √max(λ, 0)``), so a singular covariance (perfectly correlated channels) is allowed.

    Parameters
    ----------
    cov : ndarray, shape (k, k)
        Symmetric positive semidefinite covariance matrix.

    Returns
    -------
    ndarray, shape (k, k)
        The factor ``L`` (lower triangular when from Cholesky).
    """
    c = np.asarray(cov, dtype=float)
    if c.size == 0:
        return c.copy()
    try:
        return np.linalg.cholesky(c)
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(c)
        return V * np.sqrt(np.clip(w, 0.0, None))


class _Noisy:
    """The noise, bias and outages shared by measurement groups and input sensors."""

    noise_std: Array
    noise_cov: Array | None
    bias: Array
    outages: tuple[tuple[float, float], ...]

    def _setup(self, owner: str, count: int) -> None:
        if self.noise_cov is not None:
            if np.any(np.asarray(self.noise_std, dtype=float) != 0):
                raise InvalidArgumentError(f"{owner}: give noise_std or noise_cov, not both")
            cov = as_covariance(f"{owner}: noise_cov", self.noise_cov, count)
            object.__setattr__(self, "noise_cov", readonly(cov, owned=True))
            std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
            std.setflags(write=False)
            object.__setattr__(self, "noise_std", std)
        else:
            object.__setattr__(self, "noise_std", _check_std(owner, self.noise_std, count))
        object.__setattr__(self, "bias", _check_bias(owner, self.bias, count))
        object.__setattr__(self, "outages", _check_outages(owner, self.outages))

    @property
    def covariance(self) -> Array:
        """The noise covariance of the channels (``diag(noise_std²)`` unless ``noise_cov`` was given)."""
        if self.noise_cov is not None:
            return np.array(self.noise_cov)
        return np.diag(np.asarray(self.noise_std) ** 2)


@dataclass(frozen=True)
class MeasurementGroup(_Noisy):
    """Plant outputs read together by one sensor at one rate.

    Parameters
    ----------
    name : str
        Label used in error messages (e.g. ``"gnss"``).
    outputs : sequence of int or str
        Output indices or output names of the plant.
    rate : float
        Sampling rate in Hz. Required: there is no default rate.
    noise_std : float or sequence of float
        Standard deviation of the additive Gaussian noise, one value for the
        group or one per output; ``0`` (default) for exact readings.
    noise_cov : array_like, shape (c, c), optional
        Full noise covariance of the group's ``c`` outputs (symmetric positive semidefinite),
        instead of ``noise_std``; ``noise_std`` then holds the square roots of its diagonal.
    bias : float or sequence of float
        Constant offset added to every reading (default 0). Filters are not told about it.
    outages : sequence of (start, end), optional
        Windows ``[start, end)`` in seconds in which the sensor delivers no sample (the last
        reading stays held; a correcting observer makes no correction with this group).

    Examples
    --------
    Two accelerometer outputs read at 100 Hz, each with noise of standard deviation 0.02, and a GNSS receiver
    at 5 Hz that delivers nothing between 10 s and 20 s:

    >>> import numpy as np
    >>> imu = MeasurementGroup("imu", ["ax", "ay"], rate=100.0, noise_std=0.02)
    >>> imu.outputs, imu.noise_std.tolist(), np.round(imu.covariance, 6).tolist()
    (('ax', 'ay'), [0.02, 0.02], [[0.0004, 0.0], [0.0, 0.0004]])
    >>> gnss = MeasurementGroup("gnss", [0], rate=5.0, noise_std=1.5, outages=[[10.0, 20.0]])
    >>> gnss.rate, gnss.outages
    (5.0, ((10.0, 20.0),))
    >>> try:
    ...     MeasurementGroup("imu", ["ax"], rate=0.0)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, "-", exc)
    InvalidArgumentError - measurement group 'imu': rate (Hz): must be positive, got 0.0
    """

    name: str
    outputs: tuple[int | str, ...]
    rate: float = field(kw_only=True)
    noise_std: Array = field(kw_only=True, default=0.0)  # type: ignore[assignment]
    noise_cov: Array | None = field(kw_only=True, default=None)
    bias: Array = field(kw_only=True, default=0.0)  # type: ignore[assignment]
    outages: tuple[tuple[float, float], ...] = field(kw_only=True, default=())

    def __post_init__(self) -> None:
        owner = f"measurement group {self.name!r}"
        object.__setattr__(self, "outputs", _check_channels(owner, "output", self.outputs))
        object.__setattr__(self, "rate", positive(f"{owner}: rate (Hz)", self.rate))
        self._setup(owner, len(self.outputs))


@dataclass(frozen=True)
class InputSensor(_Noisy):
    """Plant inputs that the observer receives sampled, held and noisy.

    The plant is always driven by the true input; inputs not covered by any
    sensor reach the observer exactly, evaluated at every integration stage.

    Parameters
    ----------
    name : str
        Label used in error messages (e.g. ``"imu"``).
    inputs : sequence of int or str
        Input indices or input names of the plant.
    rate : float
        Sampling rate in Hz. Required: there is no default rate.
    noise_std : float or sequence of float
        Standard deviation of the additive Gaussian noise (scalar or per input).
    noise_cov, bias, outages
        As for :class:`MeasurementGroup`.

    Examples
    --------
    A torque sensor read at 50 Hz with noise of standard deviation 0.1 and a bias of 0.02:

    >>> import numpy as np
    >>> import nlobs
    >>> torque = InputSensor("torque", ["tau"], rate=50.0, noise_std=0.1, bias=0.02)
    >>> torque.inputs, torque.rate, torque.bias.tolist(), np.round(torque.covariance, 6).tolist()
    (('tau',), 50.0, [0.02], [[0.01]])

    A Luenberger observer of an oscillator driven by ``u = sin 5t``, its input read at 10 Hz: the plant
    runs exactly as without the sensor, the observer sees the held reading and its estimate departs from
    the exact-input one by a small amount, of the order of the sampling period:

    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.LuenbergerObserver(system, [[4.5], [1.75]])
    >>> run = dict(duration=2.0, dt=0.01, u=lambda t: np.array([np.sin(5.0 * t)]))
    >>> exact = nlobs.simulate(system, observer, [1.0, 0.0], [0.0, 0.0], **run)
    >>> held = nlobs.simulate(system, observer, [1.0, 0.0], [0.0, 0.0], **run,
    ...                       input_sensors=InputSensor("u", [0], rate=10.0))
    >>> gap = float(np.max(np.abs(held.x_hat - exact.x_hat)))
    >>> bool(np.array_equal(held.x, exact.x)), bool(1e-3 < gap < 0.1)
    (True, True)
    """

    name: str
    inputs: tuple[int | str, ...]
    rate: float = field(kw_only=True)
    noise_std: Array = field(kw_only=True, default=0.0)  # type: ignore[assignment]
    noise_cov: Array | None = field(kw_only=True, default=None)
    bias: Array = field(kw_only=True, default=0.0)  # type: ignore[assignment]
    outages: tuple[tuple[float, float], ...] = field(kw_only=True, default=())

    def __post_init__(self) -> None:
        owner = f"input sensor {self.name!r}"
        object.__setattr__(self, "inputs", _check_channels(owner, "input", self.inputs))
        object.__setattr__(self, "rate", positive(f"{owner}: rate (Hz)", self.rate))
        self._setup(owner, len(self.inputs))
