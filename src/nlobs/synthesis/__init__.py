"""nlobs.synthesis — certified LMI synthesis of observer gains.

Implements the LMIs (14) and (15) of Grip, Saberi & Johansen (seed 001) with
Chilali–Gahinet pole regions, well-posed objectives, and an independent
re-verification of every answer. See ``docs/synthesis.md``.
"""

from nlobs.synthesis.certificate import CertificateStatus, Check, CheckKind, Objective, ObserverGainCertificate
from nlobs.synthesis.lmi import Solver, SolveResult, SolveStatus
from nlobs.synthesis.observer_gain import (
    ExtendedSystem,
    GainBound,
    design_observer_gain,
    extended_system,
    verify_observer_gain,
)
from nlobs.synthesis.regions import Disk, HalfPlane, LmiRegion, PoleRegion, Sector

__all__ = [
    "CertificateStatus",
    "Check",
    "CheckKind",
    "Disk",
    "ExtendedSystem",
    "GainBound",
    "HalfPlane",
    "LmiRegion",
    "Objective",
    "ObserverGainCertificate",
    "PoleRegion",
    "Sector",
    "SolveResult",
    "SolveStatus",
    "Solver",
    "design_observer_gain",
    "extended_system",
    "verify_observer_gain",
]
