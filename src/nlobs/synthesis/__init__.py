"""nlobs.synthesis — certified LMI synthesis of observer gains.

Implements the LMIs (14) and (15) of Grip, Saberi & Johansen (seed 001) with
Chilali–Gahinet pole regions, well-posed objectives, and an independent
re-verification of every answer; every design returns a :class:`Certificate` (``gain``, ``P``,
``checks``, ``verified``, ``failed_checks``, ``solver``, ``summary()``, ``to_dict()``). See ``docs/synthesis.md``. Seed 004: the sound
set-valued design (``docs/setvalued.md``), Theorem 5.10 and Propositions 5.6 and 5.16 as printed, the discrete
Lipschitz observer gain (``docs/baselines.md``) and the affine abstraction of
Proposition 2.18 (``docs/affine_abstraction.md``).
"""

from nlobs.synthesis.affine_abstraction import AbstractionBound, AffineAbstraction, affine_abstraction
from nlobs.synthesis.certificate import (
    Certificate,
    CertificateMixin,
    CertificateStatus,
    Check,
    CheckKind,
    Objective,
    ObserverGainCertificate,
)
from nlobs.synthesis.discrete_lipschitz import (
    DiscreteLipschitzCertificate,
    design_discrete_lipschitz_gain,
    verify_discrete_lipschitz_gain,
)
from nlobs.synthesis.lmi import Solver, SolveResult, SolveStatus
from nlobs.synthesis.observer_gain import (
    ExtendedSystem,
    GainBound,
    design_observer_gain,
    extended_system,
    verify_observer_gain,
)
from nlobs.synthesis.regions import Disk, HalfPlane, LmiRegion, PoleRegion, Sector
from nlobs.synthesis.setvalued import (
    ErrorDynamics,
    SetValuedDesign,
    SetValuedObjective,
    design_setvalued,
    error_dynamics,
    verify_setvalued,
)
from nlobs.synthesis.setvalued_printed import (
    NecessaryConditionPrinted,
    PrintedDesign,
    Prop56Verdict,
    Prop516Branch,
    Prop516Design,
    design_printed,
    design_prop516,
    necessary_condition_printed,
)

__all__ = [
    "AbstractionBound",
    "AffineAbstraction",
    "Certificate",
    "CertificateMixin",
    "CertificateStatus",
    "Check",
    "CheckKind",
    "DiscreteLipschitzCertificate",
    "Disk",
    "ErrorDynamics",
    "ExtendedSystem",
    "GainBound",
    "HalfPlane",
    "LmiRegion",
    "NecessaryConditionPrinted",
    "Objective",
    "ObserverGainCertificate",
    "PoleRegion",
    "PrintedDesign",
    "Prop516Branch",
    "Prop516Design",
    "Prop56Verdict",
    "Sector",
    "SetValuedDesign",
    "SetValuedObjective",
    "SolveResult",
    "SolveStatus",
    "Solver",
    "affine_abstraction",
    "design_discrete_lipschitz_gain",
    "design_observer_gain",
    "design_printed",
    "design_prop516",
    "design_setvalued",
    "error_dynamics",
    "extended_system",
    "necessary_condition_printed",
    "verify_discrete_lipschitz_gain",
    "verify_observer_gain",
    "verify_setvalued",
]
