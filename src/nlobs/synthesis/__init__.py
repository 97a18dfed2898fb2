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

from typing import TYPE_CHECKING

from nlobs._lazy import lazy_exports

if TYPE_CHECKING:  # the names as static tools (type checkers, the API reference) see them
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

#: Each public name and the module that holds it: imported on first use (importing a synthesis module, e.g. for
#: a constant, does not load every other one; CVXPY is loaded by the first LMI).
_EXPORTS = {
    "AbstractionBound": "nlobs.synthesis.affine_abstraction",
    "AffineAbstraction": "nlobs.synthesis.affine_abstraction",
    "Certificate": "nlobs.synthesis.certificate",
    "CertificateMixin": "nlobs.synthesis.certificate",
    "CertificateStatus": "nlobs.synthesis.certificate",
    "Check": "nlobs.synthesis.certificate",
    "CheckKind": "nlobs.synthesis.certificate",
    "DiscreteLipschitzCertificate": "nlobs.synthesis.discrete_lipschitz",
    "Disk": "nlobs.synthesis.regions",
    "DriftGainCertificate": "nlobs.synthesis.drift_gain",
    "ErrorBoundConstants": "nlobs.synthesis.drift_bounds",
    "ErrorDynamics": "nlobs.synthesis.setvalued",
    "ExtendedSystem": "nlobs.synthesis.observer_gain",
    "GainBound": "nlobs.synthesis.observer_gain",
    "HalfPlane": "nlobs.synthesis.regions",
    "HighGain": "nlobs.synthesis.pinv_gain",
    "LmiRegion": "nlobs.synthesis.regions",
    "MixedH2Certificate": "nlobs.synthesis.mixed_h2",
    "NoiseModel": "nlobs.synthesis.mixed_h2",
    "Objective": "nlobs.synthesis.certificate",
    "ObserverGainCertificate": "nlobs.synthesis.certificate",
    "PoleRegion": "nlobs.synthesis.regions",
    "QuadraticLyapunov": "nlobs.synthesis.cascade_bounds",
    "RiccatiConstants": "nlobs.synthesis.drift_gain",
    "Sector": "nlobs.synthesis.regions",
    "SetValuedDesign": "nlobs.synthesis.setvalued",
    "SetValuedObjective": "nlobs.synthesis.setvalued",
    "SolveResult": "nlobs.synthesis.lmi",
    "SolveStatus": "nlobs.synthesis.lmi",
    "Solver": "nlobs.synthesis.lmi",
    "SynthesisMethod": "nlobs.synthesis.certificate",
    "brunovsky_triple": "nlobs.synthesis.drift_gain",
    "companion_error_matrix": "nlobs.synthesis.pinv_gain",
    "design_cascade_gain": "nlobs.synthesis.cascade_gain",
    "design_discrete_lipschitz_gain": "nlobs.synthesis.discrete_lipschitz",
    "design_drift_gain": "nlobs.synthesis.drift_gain",
    "design_drift_gain_sdp": "nlobs.synthesis.drift_gain",
    "design_h2_gain": "nlobs.synthesis.mixed_h2",
    "design_observer_gain": "nlobs.synthesis.observer_gain",
    "design_setvalued": "nlobs.synthesis.setvalued",
    "error_bound_constants": "nlobs.synthesis.drift_bounds",
    "error_covariance": "nlobs.synthesis.mixed_h2",
    "error_dynamics": "nlobs.synthesis.setvalued",
    "extended_system": "nlobs.synthesis.observer_gain",
    "h2_error_norm": "nlobs.synthesis.mixed_h2",
    "high_gain_coefficients": "nlobs.synthesis.pinv_gain",
    "high_gain_roots": "nlobs.synthesis.pinv_gain",
    "kalman_bucy_gain": "nlobs.synthesis.mixed_h2",
    "place_cascade_gain": "nlobs.synthesis.cascade_gain",
    "quadratic_lyapunov_constants": "nlobs.synthesis.cascade_bounds",
    "sampled_intensity": "nlobs.synthesis.mixed_h2",
    "smallest_w": "nlobs.synthesis.drift_gain",
    "theorem1_gamma_bound": "nlobs.synthesis.cascade_bounds",
    "theorem1_optimal_scaling": "nlobs.synthesis.cascade_bounds",
    "theorem1_prime_gamma_bound": "nlobs.synthesis.cascade_bounds",
    "vandermonde_gain": "nlobs.synthesis.drift_gain",
    "verify_discrete_lipschitz_gain": "nlobs.synthesis.discrete_lipschitz",
    "verify_drift_gain": "nlobs.synthesis.drift_gain",
    "verify_h2_gain": "nlobs.synthesis.mixed_h2",
    "verify_observer_gain": "nlobs.synthesis.observer_gain",
    "verify_setvalued": "nlobs.synthesis.setvalued",
}

__all__ = sorted([*_EXPORTS, "affine_abstraction"])

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

# a function named like its module: imported now, so that the package attribute is the function (importing the
# submodule later would otherwise leave the module there, and the lazy lookup would never run)
from nlobs.synthesis.affine_abstraction import affine_abstraction  # noqa: E402
