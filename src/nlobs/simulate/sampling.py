"""Multi-rate sampled measurements: groups with their own (required) rates, hold and noise.

A *measurement group* is a set of plant outputs read by one sensor at one rate,
e.g. an IMU at 100 Hz and a GNSS receiver at 5 Hz. An *input sensor* is the
same for plant inputs: the plant is driven by the true ``u(t)`` while the
observer receives the sampled, held, noisy reading (an IMU used as an input).

Between samples the last reading is held (zero-order hold). A group samples
at step ``k`` of the integration grid ``t_k = t0 + k dt`` when ``k`` is a
multiple of its stride ``1 / (rate dt)``, which must be an integer: sample
instants always fall on the grid, and rates are never defaulted.

Noise is additive, Gaussian, zero-mean with the group's standard deviation
(or its full covariance ``noise_cov``: the draw is ``L ξ`` with ``L Lᵀ`` the covariance),
drawn from a seeded :class:`numpy.random.Generator` at each sample instant,
groups in the order given (measurement groups first, then input sensors); a
group's constant ``bias`` is added to every reading. In an outage window a
group takes no sample (and draws no noise): the last reading stays held.

The sensors themselves (:class:`MeasurementGroup`, :class:`InputSensor`) are
descriptions in :mod:`nlobs.systems.sensors`, re-exported here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nlobs._typing import Array
from nlobs.errors import DimensionError, InvalidArgumentError, UnknownNameError
from nlobs.systems.sensors import InputSensor, MeasurementGroup, covariance_factor

__all__ = ["InputSensor", "MeasurementGroup", "ScheduledGroup", "sample_into", "sample_stride", "schedule_inputs",
           "schedule_measurements"]


#: Relative tolerance on ``1 / (rate dt)`` being an integer.
STRIDE_RTOL = 1e-6


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
    factor : ndarray or None
        ``L`` with ``L Lᵀ`` the noise covariance, for a group given by a full covariance
        (``None``: independent channels, ``noise_std`` each).
    bias : ndarray or None
        Constant offset per channel (``None``: none).
    outages : tuple of (start, end)
        Windows ``[start, end)`` without samples.
    """

    label: str
    index: NDArray[np.intp]
    stride: int
    noise_std: Array
    factor: Array | None = None
    bias: Array | None = None
    outages: tuple[tuple[float, float], ...] = ()

    @property
    def noisy(self) -> bool:
        """Whether any channel has non-zero noise."""
        return bool(np.any(self.noise_std > 0))

    def due(self, k: int, t: float | None = None) -> bool:
        """Whether the group samples at step ``k`` (at time ``t``: not in an outage)."""
        if k % self.stride:
            return False
        return t is None or not self.outages or not any(a <= t < b for a, b in self.outages)


def _scheduled(label: str, idx: NDArray[np.intp], stride: int, sensor: MeasurementGroup | InputSensor) -> ScheduledGroup:
    factor = None if sensor.noise_cov is None else covariance_factor(sensor.noise_cov)
    bias = sensor.bias if np.any(sensor.bias != 0) else None
    return ScheduledGroup(label, idx, stride, sensor.noise_std, factor, bias, sensor.outages)


def sample_stride(label: str, rate: float, dt: float) -> int:
    """Number of integration steps between samples, ``1 / (rate dt)``, checked to be an integer.

    Parameters
    ----------
    label : str
        Name of the group, used in error messages.
    rate : float
        Sample rate, in Hz.
    dt : float
        Integration step, in seconds.

    Returns
    -------
    int
        The stride (``>= 1``).

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

    Parameters
    ----------
    groups : sequence of MeasurementGroup
        The measurement groups, each with its outputs (names or indices) and rate.
    outputs : sequence of str
        The plant's output names.
    dt : float
        Integration step, in seconds.

    Returns
    -------
    tuple of ScheduledGroup
        One per group, in the order given.

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
        out.append(_scheduled(label, idx, sample_stride(label, g.rate, dt), g))
    missing = [outputs[i] for i in range(len(outputs)) if i not in owner]
    if missing:
        raise InvalidArgumentError(
            f"outputs {missing} belong to no measurement group; give each output a group with its rate "
            "(or pass measurements=None for exact continuous measurements of every output)"
        )
    return tuple(out)


def schedule_inputs(sensors: Sequence[InputSensor], inputs: Sequence[str], dt: float) -> tuple[ScheduledGroup, ...]:
    """Resolve input sensors against the plant inputs and the step ``dt``.

    Parameters
    ----------
    sensors : sequence of InputSensor
        The input sensors, each with its inputs (names or indices) and rate.
    inputs : sequence of str
        The plant's input names.
    dt : float
        Integration step, in seconds.

    Returns
    -------
    tuple of ScheduledGroup
        One per sensor, in the order given.

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
        out.append(_scheduled(label, idx, sample_stride(label, s.rate, dt), s))
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
    if group.bias is not None:
        value = value + group.bias
    if group.noisy:
        if rng is None:  # guarded by simulate(); kept as a typed error, not an assert
            raise InvalidArgumentError(f"{group.label}: noise requested but no random generator given")
        xi = rng.standard_normal(value.shape)
        value = value + (xi * group.noise_std if group.factor is None else xi @ group.factor.T)
    held[..., group.index] = value
