"""Plots of simulation results (matplotlib, without pyplot: safe on headless machines).

:func:`plot_result` lives with :class:`~nlobs.simulate.result.SimulationResult`, whose
:meth:`~nlobs.simulate.result.SimulationResult.plot` it is (:mod:`nlobs.simulate.result`); it is importable from
here as well.
"""

from __future__ import annotations

from nlobs.simulate.result import plot_result

__all__ = ["plot_result"]
