"""Simulation of plants and observers: multi-rate sampled measurements, noise, batches, metrics.

The entry point is :func:`simulate`; it returns an immutable :class:`SimulationResult`
with error metrics, a plot and an ``.npz`` round trip.
"""

from __future__ import annotations

from nlobs.simulate.integrators import RK4, SolveIVP, rk4_integrate, rk4_step, rk4_step_joint, solve_ivp_batch
from nlobs.simulate.loop import simulate
from nlobs.simulate.metrics import ErrorMetrics
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.sampling import InputSensor, MeasurementGroup
from nlobs.simulate.signals import SampledSignal

__all__ = [
    "RK4",
    "ErrorMetrics",
    "InputSensor",
    "MeasurementGroup",
    "SampledSignal",
    "SimulationResult",
    "SolveIVP",
    "rk4_integrate",
    "rk4_step",
    "rk4_step_joint",
    "simulate",
    "solve_ivp_batch",
]
