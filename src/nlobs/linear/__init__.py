"""Linear structural analysis: stability, observability, zeros, norms (with the H∞ grid safeguard), reports.

All functions take plain arrays (validated on entry, raising
:class:`~nlobs.errors.DimensionError` / :class:`~nlobs.errors.NonFiniteError`)
and a keyword ``discrete`` selecting the time base where it matters.
"""

from nlobs.linear.norms import h2_norm, hinf_grid_peak, hinf_norm
from nlobs.linear.observability import (
    is_detectable,
    is_observable,
    observability_matrix,
    unobservable_modes,
)
from nlobs.linear.report import REPORT_KEYS, LinearReport, analyze_linear
from nlobs.linear.stability import (
    BOUNDARY_TOL,
    eigenvalues,
    is_stable,
    spectral_abscissa,
    spectral_radius,
    stability_margin,
    strictly_inside,
)
from nlobs.linear.zeros import (
    InvariantZeros,
    invariant_zeros,
    is_left_invertible,
    is_minimum_phase,
    is_strongly_detectable,
    minimum_phase,
)

__all__ = [
    "BOUNDARY_TOL",
    "REPORT_KEYS",
    "InvariantZeros",
    "LinearReport",
    "analyze_linear",
    "eigenvalues",
    "h2_norm",
    "hinf_grid_peak",
    "hinf_norm",
    "invariant_zeros",
    "is_detectable",
    "is_left_invertible",
    "is_minimum_phase",
    "is_observable",
    "is_stable",
    "is_strongly_detectable",
    "minimum_phase",
    "observability_matrix",
    "spectral_abscissa",
    "spectral_radius",
    "stability_margin",
    "strictly_inside",
    "unobservable_modes",
]
