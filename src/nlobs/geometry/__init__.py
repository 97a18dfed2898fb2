"""Differential geometry of input-affine models (Dalla Mora–Germani–Manes and Röbenack).

Lie derivatives and brackets (:mod:`~nlobs.geometry.lie`), observability maps,
observation relative degrees and the Brunovsky form
(:mod:`~nlobs.geometry.observability`), the Moore–Penrose gain field
(:mod:`~nlobs.geometry.pinv`), the checks with their evidence
(:mod:`~nlobs.geometry.checks`) on regions (:mod:`~nlobs.geometry.region`), and the sampled
Lipschitz constants of ``Φ_s`` behind the error bound (3.2) (:mod:`~nlobs.geometry.lipschitz`).
SymPy lives here; everything an observer evaluates at run time is compiled once
with :func:`nlobs.systems.codegen.compile_matrix`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from nlobs._lazy import lazy_exports
from nlobs.geometry.checks import (
    Check,
    RankEvidence,
    check_a1,
    check_drift_observability,
    check_involutive,
    check_s_le_r,
    default_multi_index,
    observability_rank,
    observability_rank_evidence,
)
from nlobs.geometry.lie import covector_lie_derivative, gradient, lie_bracket, lie_derivative, lie_derivatives
from nlobs.geometry.observability import (
    AffineFields,
    RelativeDegree,
    brunovsky,
    input_gain_structure,
    observability_jacobian,
    observability_map,
    observation_relative_degree,
    output_derivative_terms,
    reduced_observability_matrix,
)
from nlobs.geometry.pinv import block_gain, gain_symbols, pinv_gain_field, symbolic_pinv
from nlobs.geometry.region import Box, ZeroTest, vanishes_on

if TYPE_CHECKING:
    from nlobs.geometry.lipschitz import LipschitzEstimates, lipschitz_estimates

#: Names imported on first use (the command line imports this package at start-up and needs none of them).
_LAZY: dict[str, str] = dict.fromkeys(("LipschitzEstimates", "lipschitz_estimates"), "nlobs.geometry.lipschitz")

__all__ = [
    "AffineFields", "Box", "Check", "LipschitzEstimates", "RankEvidence", "RelativeDegree", "ZeroTest", "block_gain",
    "brunovsky", "check_a1", "check_drift_observability", "check_involutive", "check_s_le_r",
    "covector_lie_derivative", "default_multi_index", "gain_symbols", "gradient", "input_gain_structure",
    "lie_bracket", "lie_derivative", "lie_derivatives", "lipschitz_estimates", "observability_jacobian",
    "observability_map", "observability_rank", "observability_rank_evidence", "observation_relative_degree",
    "output_derivative_terms",
    "pinv_gain_field", "reduced_observability_matrix", "symbolic_pinv", "vanishes_on",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
