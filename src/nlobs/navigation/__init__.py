"""GNSS/INS navigation (Grip, Saberi & Johansen, Sec. 5): SO(3) utilities, flight and sensor generation,
the interconnected observer (22)/(24) (with a constant or a scheduled attitude gain) and the EKF baseline (both correcting observers of
:mod:`nlobs.observers.base`), ``run_navigation`` (a thin call of :func:`nlobs.simulate.run_observer`),
the navigation metrics of its :class:`~nlobs.simulate.SimulationResult`, plots, and the Monte Carlo
study of the observer's flights (:class:`GnssInsStudy`, for :func:`nlobs.simulate.monte_carlo`).

Conventions and channel layouts are stated in :mod:`nlobs.navigation.base`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from nlobs._lazy import lazy_exports

if TYPE_CHECKING:
    from nlobs.navigation.base import SensorData, nav_vector, split_nav
    from nlobs.navigation.ekf import EkfConfig, EkfState, ExtendedKalmanFilter
    from nlobs.navigation.gains import design_gains, paper_gains, verify_paper_gains
    from nlobs.navigation.gnss_ins import GnssInsObserver, GnssInsState
    from nlobs.navigation.metrics import summary_dict
    from nlobs.navigation.montecarlo import GnssInsStudy
    from nlobs.navigation.plots import plot_navigation
    from nlobs.navigation.run import run_navigation
    from nlobs.navigation.schedule import AttitudeGainSchedule, ScheduledGnssInsObserver, noise_scheduled_gain
    from nlobs.navigation.sensors import SensorNoise, drop_fixes, generate_sensors
    from nlobs.navigation.trajectory import Flight, Trajectory, traffic_pattern

#: Names imported on first use (PEP 562), and the module that holds each.
_LAZY: dict[str, str] = {
    **dict.fromkeys(("SensorData", "nav_vector", "split_nav"), "nlobs.navigation.base"),
    **dict.fromkeys(("EkfConfig", "EkfState", "ExtendedKalmanFilter"), "nlobs.navigation.ekf"),
    **dict.fromkeys(("design_gains", "paper_gains", "verify_paper_gains"), "nlobs.navigation.gains"),
    **dict.fromkeys(("GnssInsObserver", "GnssInsState"), "nlobs.navigation.gnss_ins"),
    "summary_dict": "nlobs.navigation.metrics",
    "GnssInsStudy": "nlobs.navigation.montecarlo",
    "plot_navigation": "nlobs.navigation.plots",
    "run_navigation": "nlobs.navigation.run",
    **dict.fromkeys(("AttitudeGainSchedule", "ScheduledGnssInsObserver", "noise_scheduled_gain"),
                    "nlobs.navigation.schedule"),
    **dict.fromkeys(("SensorNoise", "drop_fixes", "generate_sensors"), "nlobs.navigation.sensors"),
    **dict.fromkeys(("Flight", "Trajectory", "traffic_pattern"), "nlobs.navigation.trajectory"),
}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
