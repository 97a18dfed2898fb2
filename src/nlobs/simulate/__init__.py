"""Simulation of plants and observers: the one loop, multi-rate sampled measurements, noise, batches, metrics.

Two entry points, one result: :func:`simulate` runs a plant and an observer together (or
:func:`simulate_plant` runs the plant once and :func:`observe` replays it to each of many observers, with the
same numbers), :func:`run_observer` runs any observer on recorded data; both return an immutable
:class:`SimulationResult` with error metrics, extras, a plot and an ``.npz`` round trip.
:func:`monte_carlo` runs a study (:class:`PlantStudy`, :class:`SetValuedStudy`, the GNSS/INS flights)
in chunks, here or on Dask, with the same numbers however it is split; :func:`nlobs.simulate.sweep.sweep` evaluates a design
problem over a grid in the same way.

The package is callable: ``nlobs.simulate(plant, observer, x0, ...)`` is
``nlobs.simulate.simulate(plant, observer, x0, ...)`` (same signature), so the top-level name
``nlobs.simulate`` is both this package and its loop.
"""

from __future__ import annotations

import inspect
import sys
import types
from typing import Any

from nlobs.simulate.integrators import RK4, SolveIVP, rk4_integrate, rk4_step, rk4_step_joint, solve_ivp_batch
from nlobs.simulate.loop import PlantRun, observe, simulate, simulate_plant
from nlobs._lazy import lazy_exports
from nlobs.simulate.metrics import ErrorMetrics
from nlobs.simulate.montecarlo import MonteCarloResult, RunBatch, Study, monte_carlo
from nlobs.simulate.plant_study import PlantStudy
from nlobs.simulate.replay import run_observer
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.sampling import InputSensor, MeasurementGroup
from nlobs.simulate.signals import SampledSignal

__all__ = [
    "RK4",
    "ErrorMetrics",
    "InputSensor",
    "MeasurementGroup",
    "MonteCarloResult",
    "PlantRun",
    "PlantStudy",
    "RunBatch",
    "SetValuedStudy",
    "SampledSignal",
    "SimulationResult",
    "SolveIVP",
    "Study",
    "monte_carlo",
    "observe",
    "rk4_integrate",
    "rk4_step",
    "rk4_step_joint",
    "run_observer",
    "simulate",
    "simulate_plant",
    "solve_ivp_batch",
]


class _CallablePackage(types.ModuleType):
    """The ``nlobs.simulate`` package, which called is its loop :func:`simulate`."""

    def __call__(self, *args: Any, **kwargs: Any) -> SimulationResult:
        return simulate(*args, **kwargs)


sys.modules[__name__].__class__ = _CallablePackage
#: Imported on first use: the set-valued study needs the synthesis layer's solvers.
__getattr__, _lazy_dir = lazy_exports(__name__, {"SetValuedStudy": "nlobs.simulate.setvalued"})
__signature__ = inspect.signature(simulate)
