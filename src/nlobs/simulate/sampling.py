"""Multi-rate sampled measurements: groups with their own (required) rates, hold and noise.

A *measurement group* is a set of plant outputs read by one sensor at one rate,
e.g. an IMU at 100 Hz and a GNSS receiver at 5 Hz. An *input sensor* is the
same for plant inputs: the plant is driven by the true ``u(t)`` while the
observer receives the sampled, held, noisy reading (an IMU used as an input).

Between samples the last reading is held (zero-order hold). A group samples
at step ``k`` of the integration grid ``t_k = t0 + k dt`` when ``k`` is a
multiple of its stride ``1 / (rate dt)``, which must be an integer: sample
instants always fall on the grid, and rates are never defaulted.

Noise is additive, Gaussian, zero-mean with the group's standard deviation,
drawn from a seeded :class:`numpy.random.Generator` at each sample instant,
groups in the order given (measurement groups first, then input sensors).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._typing import Array
from nlobs._validate import as_finite_array, positive
from nlobs.errors import DimensionError, InvalidArgumentError, UnknownNameError


#: Relative tolerance on ``1 / (rate dt)`` being an integer.
STRIDE_RTOL = 1e-6


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


@dataclass(frozen=True)
class MeasurementGroup:
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

    Examples
    --------
    >>> imu = MeasurementGroup("imu", ["ax", "ay"], rate=100.0, noise_std=0.02)  # doctest: +SKIP
    """

    name: str
    outputs: tuple[int | str, ...]
    rate: float = field(kw_only=True)
    noise_std: Array = field(kw_only=True, default=0.0)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        owner = f"measurement group {self.name!r}"
        object.__setattr__(self, "outputs", _check_channels(owner, "output", self.outputs))
        object.__setattr__(self, "rate", positive(f"{owner}: rate (Hz)", self.rate))
        object.__setattr__(self, "noise_std", _check_std(owner, self.noise_std, len(self.outputs)))


@dataclass(frozen=True)
class InputSensor:
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
    """

    name: str
    inputs: tuple[int | str, ...]
    rate: float = field(kw_only=True)
    noise_std: Array = field(kw_only=True, default=0.0)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        owner = f"input sensor {self.name!r}"
        object.__setattr__(self, "inputs", _check_channels(owner, "input", self.inputs))
        object.__setattr__(self, "rate", positive(f"{owner}: rate (Hz)", self.rate))
        object.__setattr__(self, "noise_std", _check_std(owner, self.noise_std, len(self.inputs)))


@dataclass(frozen=True)
class ScheduledGroup:
    """A group resolved against a model and an integration step.

    Attributes
    ----------
    label : str
        ``"measurement group 'gnss'"`` or ``"input sensor 'imu'"``.
    index : ndarray of int
        Channel indices (outputs or inputs) in the model.
    stride : int
        Samples are taken at steps ``k`` with ``k % stride == 0``.
    noise_std : ndarray
        Noise standard deviation per channel.
    """

    label: str
    index: NDArray[np.intp]
    stride: int
    noise_std: Array

    @property
    def noisy(self) -> bool:
        """Whether any channel has non-zero noise."""
        return bool(np.any(self.noise_std > 0))

    def due(self, k: int) -> bool:
        """Whether the group samples at step ``k``."""
        return k % self.stride == 0


def sample_stride(label: str, rate: float, dt: float) -> int:
    """Number of integration steps between samples, ``1 / (rate dt)``, checked to be an integer.

    Raises
    ------
    InvalidArgumentError
        The sample period ``1 / rate`` is not a whole multiple of ``dt`` (relative
        tolerance :data:`STRIDE_RTOL`), or the rate is faster than ``1 / dt``.
    """
    ratio = 1.0 / (rate * dt)
    stride = round(ratio)
    if stride < 1:
        raise InvalidArgumentError(
            f"{label}: rate {rate:g} Hz is faster than the integration step dt={dt:g} s allows "
            f"(at most {1.0 / dt:g} Hz); decrease dt"
        )
    if abs(ratio - stride) > STRIDE_RTOL * stride:
        raise InvalidArgumentError(
            f"{label}: rate {rate:g} Hz does not fit the integration step dt={dt:g} s: "
            f"1/(rate*dt) = {ratio:.6g} is not an integer; choose dt so that the sample period "
            f"{1.0 / rate:g} s is a whole multiple of it"
        )
    return int(stride)


def _resolve_channels(label: str, what: str, channels: Sequence[int | str], names: Sequence[str]) -> NDArray[np.intp]:
    idx = []
    for c in channels:
        if isinstance(c, str):
            if c not in names:
                raise UnknownNameError(f"{label}: unknown {what} {c!r}; the model's {what}s are {list(names)}")
            idx.append(list(names).index(c))
        else:
            i = int(c)
            if not 0 <= i < len(names):
                raise DimensionError(f"{label}: {what} index {i} out of range for {len(names)} {what}s")
            idx.append(i)
    if len(set(idx)) != len(idx):
        raise InvalidArgumentError(f"{label}: the same {what} is listed twice (by index and by name)")
    out = np.array(idx, dtype=np.intp)
    out.setflags(write=False)
    return out


def schedule_measurements(
    groups: Sequence[MeasurementGroup], outputs: Sequence[str], dt: float
) -> tuple[ScheduledGroup, ...]:
    """Resolve measurement groups against the plant outputs and the step ``dt``.

    Every output must belong to exactly one group: an output the observer
    never receives would otherwise have to be invented.

    Raises
    ------
    InvalidArgumentError
        Incommensurate rate, an output in two groups, or an output in no group.
    UnknownNameError, DimensionError
        An output name or index that the plant does not have.
    """
    out = []
    owner: dict[int, str] = {}
    for g in groups:
        if not isinstance(g, MeasurementGroup):
            raise InvalidArgumentError(f"measurements: expected MeasurementGroup objects, got {type(g).__name__}")
        label = f"measurement group {g.name!r}"
        idx = _resolve_channels(label, "output", g.outputs, outputs)
        for i in idx:
            if int(i) in owner:
                raise InvalidArgumentError(f"output {outputs[i]!r} is in both {owner[int(i)]} and {label}")
            owner[int(i)] = label
        out.append(ScheduledGroup(label, idx, sample_stride(label, g.rate, dt), g.noise_std))
    missing = [outputs[i] for i in range(len(outputs)) if i not in owner]
    if missing:
        raise InvalidArgumentError(
            f"outputs {missing} belong to no measurement group; give each output a group with its rate "
            "(or pass measurements=None for exact continuous measurements of every output)"
        )
    return tuple(out)


def schedule_inputs(sensors: Sequence[InputSensor], inputs: Sequence[str], dt: float) -> tuple[ScheduledGroup, ...]:
    """Resolve input sensors against the plant inputs and the step ``dt``.

    Raises
    ------
    InvalidArgumentError
        Incommensurate rate or an input read by two sensors.
    """
    out = []
    owner: dict[int, str] = {}
    for s in sensors:
        if not isinstance(s, InputSensor):
            raise InvalidArgumentError(f"input_sensors: expected InputSensor objects, got {type(s).__name__}")
        label = f"input sensor {s.name!r}"
        idx = _resolve_channels(label, "input", s.inputs, inputs)
        for i in idx:
            if int(i) in owner:
                raise InvalidArgumentError(f"input {inputs[i]!r} is read by both {owner[int(i)]} and {label}")
            owner[int(i)] = label
        out.append(ScheduledGroup(label, idx, sample_stride(label, s.rate, dt), s.noise_std))
    return tuple(out)


def sample_into(
    held: Array, exact: Array, group: ScheduledGroup, rng: np.random.Generator | None
) -> None:
    """Overwrite the group's channels of ``held`` with a fresh, noisy reading of ``exact``.

    Parameters
    ----------
    held : ndarray, shape (*batch, c)
        Held readings (updated in place; owned by the simulation loop).
    exact : ndarray, shape (*batch, c)
        Exact values of all channels at the sample instant.
    group : ScheduledGroup
        The group that samples.
    rng : numpy.random.Generator or None
        Noise source; may be ``None`` only for a noise-free group.
    """
    value = exact[..., group.index]
    if group.noisy:
        if rng is None:  # guarded by simulate(); kept as a typed error, not an assert
            raise InvalidArgumentError(f"{group.label}: noise requested but no random generator given")
        value = value + rng.standard_normal(value.shape) * group.noise_std
    held[..., group.index] = value
