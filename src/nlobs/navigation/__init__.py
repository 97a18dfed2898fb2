"""GNSS/INS navigation (Grip, Saberi & Johansen, Sec. 5): SO(3) utilities, flight and sensor generation,
the interconnected observer (22)/(24) and the EKF baseline (both correcting observers of
:mod:`nlobs.observers.base`), ``run_navigation`` (a thin call of :func:`nlobs.simulate.run_observer`),
the navigation metrics of its :class:`~nlobs.simulate.SimulationResult`, and plots.

Conventions and channel layouts are stated in :mod:`nlobs.navigation.base`.
"""
