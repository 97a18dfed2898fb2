"""nlobs.synthesis — every gain and its certificate.

* Grip, Saberi & Johansen: the LMIs (14) and (15) with Chilali–Gahinet pole regions, well-posed
  objectives and an independent re-verification of every answer (:mod:`~nlobs.synthesis.observer_gain`,
  ``docs/synthesis.md``); the noise-optimal gain, smallest noise-to-error H2 norm under LMI (14)
  (:mod:`~nlobs.synthesis.mixed_h2`, ``docs/noise_optimal.md``); the cascade gain on the extended system (8c) by those LMIs or by pole
  placement (:mod:`~nlobs.synthesis.cascade_gain`); the bounds of Theorem 1 / 1' and the quadratic
  Lyapunov constants of Assumption 1 (:mod:`~nlobs.synthesis.cascade_bounds`).
* Dalla Mora, Germani & Manes: the pair ``(K, P)`` of (2.17) (:mod:`~nlobs.synthesis.drift_gain`) and
  the constants ``κ₁``, ``κ₂`` of (3.17) (:mod:`~nlobs.synthesis.drift_bounds`).
* Röbenack: the high-gain vector ``k`` of (10) (:mod:`~nlobs.synthesis.pinv_gain`).
* Khajenejad & Yong: the sound set-valued design (``docs/setvalued.md``), the discrete Lipschitz observer
  gain (``docs/baselines.md``) and the affine abstraction of Proposition 2.18 (``docs/affine_abstraction.md``).
  Theorem 5.10 and Propositions 5.6 and 5.16 as printed are in the reading room,
  :mod:`nlobs.papers.khajenejad_yong_printed`.

Every design returns a :class:`Certificate` (``gain``, ``P``, ``checks``, ``verified``,
``failed_checks``, ``solver``, ``summary()``, ``to_dict()``).
"""

from nlobs.synthesis.affine_abstraction import AbstractionBound, AffineAbstraction, affine_abstraction
from nlobs.synthesis.cascade_bounds import (
    QuadraticLyapunov,
    quadratic_lyapunov_constants,
    theorem1_gamma_bound,
    theorem1_optimal_scaling,
    theorem1_prime_gamma_bound,
)
from nlobs.synthesis.cascade_gain import design_cascade_gain, place_cascade_gain
from nlobs.synthesis.certificate import (
    Certificate,
    CertificateMixin,
    CertificateStatus,
    Check,
    CheckKind,
    Objective,
    ObserverGainCertificate,
    SynthesisMethod,
)
from nlobs.synthesis.discrete_lipschitz import (
    DiscreteLipschitzCertificate,
    design_discrete_lipschitz_gain,
    verify_discrete_lipschitz_gain,
)
from nlobs.synthesis.drift_bounds import ErrorBoundConstants, error_bound_constants
from nlobs.synthesis.drift_gain import (
    DriftGainCertificate,
    RiccatiConstants,
    brunovsky_triple,
    design_drift_gain,
    design_drift_gain_sdp,
    smallest_w,
    vandermonde_gain,
    verify_drift_gain,
)
from nlobs.synthesis.lmi import Solver, SolveResult, SolveStatus
from nlobs.synthesis.mixed_h2 import (
    MixedH2Certificate,
    NoiseModel,
    design_h2_gain,
    error_covariance,
    h2_error_norm,
    kalman_bucy_gain,
    sampled_intensity,
    verify_h2_gain,
)
from nlobs.synthesis.observer_gain import (
    ExtendedSystem,
    GainBound,
    design_observer_gain,
    extended_system,
    verify_observer_gain,
)
from nlobs.synthesis.pinv_gain import HighGain, companion_error_matrix, high_gain_coefficients, high_gain_roots
from nlobs.synthesis.regions import Disk, HalfPlane, LmiRegion, PoleRegion, Sector
from nlobs.synthesis.setvalued import (
    ErrorDynamics,
    SetValuedDesign,
    SetValuedObjective,
    design_setvalued,
    error_dynamics,
    verify_setvalued,
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
    "DriftGainCertificate",
    "ErrorBoundConstants",
    "ErrorDynamics",
    "ExtendedSystem",
    "GainBound",
    "HalfPlane",
    "HighGain",
    "LmiRegion",
    "MixedH2Certificate",
    "NoiseModel",
    "Objective",
    "ObserverGainCertificate",
    "PoleRegion",
    "QuadraticLyapunov",
    "RiccatiConstants",
    "Sector",
    "SetValuedDesign",
    "SetValuedObjective",
    "SolveResult",
    "SolveStatus",
    "Solver",
    "SynthesisMethod",
    "affine_abstraction",
    "brunovsky_triple",
    "companion_error_matrix",
    "design_cascade_gain",
    "design_discrete_lipschitz_gain",
    "design_drift_gain",
    "design_drift_gain_sdp",
    "design_h2_gain",
    "design_observer_gain",
    "design_setvalued",
    "error_bound_constants",
    "error_covariance",
    "error_dynamics",
    "extended_system",
    "h2_error_norm",
    "high_gain_coefficients",
    "high_gain_roots",
    "kalman_bucy_gain",
    "place_cascade_gain",
    "quadratic_lyapunov_constants",
    "sampled_intensity",
    "smallest_w",
    "theorem1_gamma_bound",
    "theorem1_optimal_scaling",
    "theorem1_prime_gamma_bound",
    "vandermonde_gain",
    "verify_discrete_lipschitz_gain",
    "verify_drift_gain",
    "verify_h2_gain",
    "verify_observer_gain",
    "verify_setvalued",
]
