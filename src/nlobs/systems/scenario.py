"""An experiment on a model: its sensors, known input signals, process noise, units and run defaults.

A model file may carry, besides the model, the tables that say how it is measured and driven
(all optional; a file without them behaves as before: exact, continuous measurement of every
output, zero input, no process noise)::

    units = { theta = "rad", omega = "rad/s", tau = "N m", y = "rad" }   # t = "h": time unit (default s)

    [sensors.encoder]            # one table per measurement group
    outputs = ["y"]              # every output in exactly one group
    rate = 100.0                 # Hz (positive; 1/rate a whole multiple of the step dt)
    noise_std = 0.01             # per output, or noise_cov = [[...]] (symmetric PSD)
    bias = 0.0                   # optional constant offset
    outages = [[4.0, 4.5]]       # optional windows [start, end) without samples (s)

    [input_signals]              # known inputs u(t), by input name (missing: 0)
    tau = { kind = "sine", amplitude = 0.5, frequency = 0.2 }
    # also kind = "constant" | "step" | "chirp" | "csv" | "expression", a number, or an
    # expression string of t such as "0.5*sin(2*t)"

    [process_noise]              # w in dx/dt = f(x, u) + w (continuous: spectral density per s)
    std = [0.0, 0.01]            # per state, or covariance = [[...]] (symmetric PSD)

    [simulation]                 # defaults of `nlobs simulate`
    x0 = [0.5, 0.0]
    initial_error_std = [0.2, 0.2]
    duration = 20.0
    dt = 0.001
    settle = 5.0                 # RMS errors are reported after this time (and overall)
    runs = 20
    box = [[-3, 3], [-5, 5]]     # region of the designs (per state [lo, hi])

    [controller]                 # optional feedback u = k(x̂, t): `nlobs simulate` closes the loop
    law = ["-2*theta - omega"]   # one expression per input over the states, t and parameters
    rate = 100.0                 # optional: sampled (Hz), held between samples
    saturation = [[-1, 1]]       # optional: [lo, hi] per input

    [constraints]                # optional bounds per state (inf for none)
    lower = [-inf, -inf]
    upper = [inf, inf]

The table of known inputs is ``[input_signals]`` because ``inputs`` already names the inputs.
:func:`nlobs.systems.modelfile.load_scenario` reads a file into a :class:`Scenario`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from nlobs._typing import Array
from nlobs.systems.linear import LinearSystem
from nlobs.systems.sensors import MeasurementGroup
from nlobs.systems.symbolic import SymbolicModel

__all__ = ["RunDefaults", "Scenario"]


@dataclass(frozen=True, eq=False)
class RunDefaults:
    """The ``[simulation]`` table: defaults of a comparison run (each ``None`` when not given).

    Attributes
    ----------
    x0 : ndarray, shape (n,) or None
        Initial plant state.
    initial_error_std : ndarray, shape (n,) or None
        Standard deviation of the initial estimation error, per state (Monte Carlo runs draw
        ``x̂0 = x0 + e``, ``e ~ N(0, diag(std²))``).
    duration, dt, settle : float or None
        Simulated time, integration step and settling time (s).
    runs : int or None
        Monte Carlo runs.
    box : tuple of ndarray or None
        ``(lo, hi)``: the region of the designs.
    """

    x0: Array | None = None
    initial_error_std: Array | None = None
    duration: float | None = None
    dt: float | None = None
    settle: float | None = None
    runs: int | None = None
    box: tuple[Array, Array] | None = None


@dataclass(frozen=True, eq=False)
class Scenario:
    """A model with how it is measured and driven (module docstring).

    Attributes
    ----------
    model : SymbolicModel or LinearSystem
    sensors : tuple of MeasurementGroup
        Empty: exact, continuous measurement of every output (the behaviour without ``[sensors]``).
    input_signals : InputSignals or None
        The known input ``u(t)`` (``None``: zero, or no inputs).
    process_noise : ndarray, shape (n, n) or None
        Covariance (continuous time: spectral density) of the process noise.
    units : mapping of str to str
        Units of states, inputs and outputs by name (``""`` where not given).
    defaults : RunDefaults
    path : str
    tables : frozenset of str
        The model file's top-level tables and keys (``"cascade"``, ``"unknown_inputs"``, …; empty for a
        model given in Python), so that a command asks the file once.
    cascade : CascadeModel or None
        The file's ``[cascade]`` table, read with the rest (:mod:`nlobs.systems.cascade_file`).
    controller : ControlLaw or None
        The file's ``[controller]`` table: a feedback law ``u = k(x̂, t)`` (:mod:`nlobs.systems.controller`).
    constraints : StateBounds or None
        The file's ``[constraints]`` table: bounds per state (:mod:`nlobs.systems.constraints`).
    """

    model: SymbolicModel | LinearSystem
    sensors: tuple[MeasurementGroup, ...] = ()
    input_signals: Any = None
    process_noise: Array | None = None
    units: Mapping[str, str] = field(default_factory=dict)
    defaults: RunDefaults = field(default_factory=RunDefaults)
    path: str = ""
    tables: frozenset[str] = frozenset()
    cascade: Any = None
    controller: Any = None
    constraints: Any = None

    @property
    def time_unit(self) -> str:
        """The unit of time (``units.t``; ``"s"`` when not given). Rates are per this unit."""
        return str(self.units.get("t", "s")) or "s"

    def unit(self, name: str) -> str:
        """The unit of a state, input or output (``""`` when the file gives none)."""
        return str(self.units.get(name, ""))

    def label(self, name: str) -> str:
        """``"name [unit]"`` (or ``name`` without a unit), for axis labels."""
        u = self.unit(name)
        return f"{name} [{u}]" if u else name
