"""Linear structural analysis: stability, observability, zeros, norms (with the H∞ grid safeguard), reports,
and Σ₂'s structure in the cascade observer of Grip, Saberi & Johansen (the extended system (8c), Assumption 4).

All functions take plain arrays (validated on entry, raising
:class:`~nlobs.errors.DimensionError` / :class:`~nlobs.errors.NonFiniteError`)
and a keyword ``discrete`` selecting the time base where it matters.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from nlobs._lazy import lazy_exports
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

if TYPE_CHECKING:
    from nlobs.linear.assumption4 import (
        ASSUMPTION4_ITEMS,
        Assumption4Report,
        ExtendedSystem,
        check_assumption4,
        extended_system,
        require_assumption4,
    )

#: Names imported on first use (the command line imports this package at start-up and needs none of them).
_LAZY: dict[str, str] = dict.fromkeys(
    ("ASSUMPTION4_ITEMS", "Assumption4Report", "ExtendedSystem", "check_assumption4", "extended_system",
     "require_assumption4"), "nlobs.linear.assumption4")

__all__ = [
    "ASSUMPTION4_ITEMS",
    "Assumption4Report",
    "BOUNDARY_TOL",
    "ExtendedSystem",
    "REPORT_KEYS",
    "InvariantZeros",
    "LinearReport",
    "analyze_linear",
    "check_assumption4",
    "eigenvalues",
    "extended_system",
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
    "require_assumption4",
    "spectral_abscissa",
    "spectral_radius",
    "stability_margin",
    "strictly_inside",
    "unobservable_modes",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
