"""``nlobs advise``: which of nlobs's observers applies to a model, with the evidence and the first command.

The analysis is :func:`nlobs.methods.advice.advise_model` (the methods layer decides which method
applies); this module is the command's entry, and keeps the names it has always offered.
"""

from __future__ import annotations

from nlobs.methods.advice import (
    ADVICE_JSON,
    CHECK_RMS_FACTOR,
    METHODS,
    AdviceReport,
    CascadeStructure,
    MethodAdvice,
    SensorCheck,
    Singularity,
    advise_model,
    cascade_structure,
    singularities,
)

__all__ = ["CHECK_RMS_FACTOR", "METHODS", "AdviceReport", "CascadeStructure", "MethodAdvice", "SensorCheck",
           "Singularity", "advise_model", "cascade_structure", "singularities"]
