"""Differential geometry of input-affine models (seeds 002 and 003).

Lie derivatives and brackets (:mod:`~nlobs.geometry.lie`), observability maps,
observation relative degrees and the Brunovsky form
(:mod:`~nlobs.geometry.observability`), the Moore–Penrose gain field
(:mod:`~nlobs.geometry.pinv`), and the checks with their evidence
(:mod:`~nlobs.geometry.checks`) on regions (:mod:`~nlobs.geometry.region`).
SymPy lives here; everything an observer evaluates at run time is compiled once
with :func:`nlobs.systems.codegen.compile_matrix`.
"""

from nlobs.geometry.checks import (
    Check,
    check_a1,
    check_drift_observability,
    check_involutive,
    check_s_le_r,
    default_multi_index,
    observability_rank,
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

__all__ = [
    "AffineFields", "Box", "Check", "RelativeDegree", "ZeroTest", "block_gain", "brunovsky", "check_a1",
    "check_drift_observability", "check_involutive", "check_s_le_r", "covector_lie_derivative",
    "default_multi_index", "gain_symbols", "gradient", "input_gain_structure", "lie_bracket", "lie_derivative",
    "lie_derivatives", "observability_jacobian", "observability_map", "observability_rank",
    "observation_relative_degree", "output_derivative_terms", "pinv_gain_field", "reduced_observability_matrix",
    "symbolic_pinv", "vanishes_on",
]
