"""The certificate protocol of every gain design, and the certificate of the observer-gain LMIs.

:class:`Certificate` is what every design in :mod:`nlobs.synthesis` returns: the gain (``gain``),
the Lyapunov matrix that proves it (``P``), the independent re-verification (``checks``, a tuple of
:class:`~nlobs.checks.Check`), the verdict (``verified``, ``failed_checks``), the solver, and the two
verbs ``summary()`` (text) and ``to_dict()`` (data). :class:`CertificateMixin` writes ``verified`` and
``failed_checks`` once, from ``checks``. The implementations:

* :class:`ObserverGainCertificate` — LMIs (14), (15) of Grip–Saberi–Johansen with Chilali–Gahinet
  pole regions (this module);
* :class:`~nlobs.synthesis.drift_gain.DriftGainCertificate` — (2.17) of Dalla Mora–Germani–Manes;
* :class:`~nlobs.synthesis.discrete_lipschitz.DiscreteLipschitzCertificate` — the discrete
  Lipschitz observer baseline;
* :class:`~nlobs.synthesis.setvalued.SetValuedDesign` — the sound design of the set-valued observer
  of Khajenejad–Yong;
* outside the library, in the reading room: :class:`~nlobs.papers.khajenejad_yong_printed.PrintedDesign`
  and :class:`~nlobs.papers.khajenejad_yong_printed.Prop516Design` — Khajenejad–Yong's Theorem 5.10 and
  Proposition 5.16 as printed, whose checks (the exact condition (A.16), the spectral radius) fail
  for the paper's examples.

The observer-gain certificate records a gain ``K`` (its ``gain``), the Lyapunov matrix ``P`` that
proves the LMIs, the bounds it was designed for and the result of an *independent*
re-verification: every LMI block is re-evaluated in NumPy with the returned
``P`` and ``X = P K`` recomputed from the returned ``K``, the closed-loop
eigenvalues of ``A − K C`` are recomputed, and ``‖H‖∞``, ``‖G‖∞`` are
recomputed with :func:`nlobs.linear.norms.hinf_norm`. A solver's "optimal"
is never trusted on its own.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from enum import Enum
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from nlobs.checks import Check, CheckKind
from nlobs.synthesis.lmi import Solver

__all__ = [
    "Certificate",
    "CertificateMixin",
    "CertificateStatus",
    "CheckKind",
    "Check",
    "Objective",
    "ObserverGainCertificate",
    "SynthesisMethod",
    "failed_of",
    "verified_of",
]


def verified_of(checks: Iterable[Check]) -> bool:
    """Whether every check passed (the verdict of a certificate).

    Parameters
    ----------
    checks : iterable of Check
        The checks of a certificate.

    Returns
    -------
    bool
        ``True`` when every check passed (also for no checks).
    """
    return all(c.passed for c in checks)


def failed_of(checks: Iterable[Check]) -> tuple[Check, ...]:
    """The checks that failed (empty when verified).

    Parameters
    ----------
    checks : iterable of Check
        The checks of a certificate.

    Returns
    -------
    tuple of Check
        The checks whose ``passed`` is false, in their order.
    """
    return tuple(c for c in checks if not c.passed)


@runtime_checkable
class Certificate(Protocol):
    """What every gain design returns: the gain, its proof, and the independent re-verification.

    Attributes
    ----------
    gain : ndarray
        The gain (the paper's ``K``, ``L`` or ``L̃``).
    P : ndarray or None
        The Lyapunov matrix that proves it (``None`` when none exists for a given gain).
    checks : tuple of Check
        Every re-verification check, recomputed without the solver.
    verified : bool
        Whether every check passed.
    failed_checks : tuple of Check
        The checks that failed (empty when verified).
    solver : Solver or None
        The solver that produced the answer (``None`` for a construction without one).

    Examples
    --------
    Two designs, one protocol: the observer gain of LMIs (14), (15) (Grip, Saberi & Johansen) and the
    Vandermonde gain of Remark 2.11 (Dalla Mora, Germani & Manes), each re-verified without a solver:

    >>> import numpy as np
    >>> from nlobs.synthesis.drift_gain import RiccatiConstants, design_drift_gain
    >>> from nlobs.synthesis.observer_gain import design_observer_gain
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> certs = [design_observer_gain(A, C, Bd, gamma=10.0, gamma_n=10.0),
    ...          design_drift_gain(RiccatiConstants((2,), [[0.0], [1.0]], alpha=1.0, mu=1.0, gamma=1.0))]
    >>> [(isinstance(c, Certificate), c.verified, c.failed_checks, c.solver) for c in certs]
    [(True, True, (), None), (True, True, (), None)]
    >>> [c.name for c in certs[0].checks]
    ['P ≻ 0', 'LMI (14)', 'LMI (15)', 'A − K C Hurwitz (max Re λ)', '‖H‖∞ < γ', '‖G‖∞ ≤ γn']
    >>> certs[0].summary().splitlines()[0], certs[1].to_dict()["verified"]
    ('observer gain certificate: verified', True)
    """

    @property
    def gain(self) -> NDArray[np.float64]: ...

    @property
    def P(self) -> NDArray[np.float64] | None: ...  # noqa: N802 - the paper's symbol

    @property
    def checks(self) -> tuple[Check, ...]: ...

    @property
    def verified(self) -> bool: ...

    @property
    def failed_checks(self) -> tuple[Check, ...]: ...

    @property
    def solver(self) -> Solver | None: ...

    def summary(self) -> str:
        """A multi-line human-readable report: the design and every check with its margin."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view (JSON types once non-finite floats are sanitised)."""
        ...


class CertificateMixin:
    """``verified`` and ``failed_checks`` of a :class:`Certificate`, computed from its ``checks``.

    Examples
    --------
    A minimal certificate: a frozen dataclass with ``checks`` gets its verdict from the mixin:

    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Bound(CertificateMixin):
    ...     checks: tuple
    >>> ok = Check.compare("‖H‖∞ < γ", 0.5, 1.0, kind=CheckKind.NORM)
    >>> bad = Check.compare("max Re λ < 0", 0.2, 0.0, kind=CheckKind.SPECTRUM)
    >>> Bound((ok,)).verified, Bound((ok,)).failed_checks, Bound((ok, bad)).verified
    (True, (), False)
    >>> [c.summary() for c in Bound((ok, bad)).failed_checks]
    ['max Re λ < 0: 0.2 < 0 (FAILED by 0.2)']
    """

    __slots__ = ()
    checks: tuple[Check, ...]

    @property
    def verified(self) -> bool:
        """Whether every check passed."""
        return verified_of(self.checks)

    @property
    def failed_checks(self) -> tuple[Check, ...]:
        """The checks that failed (empty when verified)."""
        return failed_of(self.checks)


def checks_dict(checks: Iterable[Check]) -> list[dict[str, Any]]:
    """``[c.to_dict() for c in checks]`` (the ``"checks"`` entry of every certificate's ``to_dict()``)."""
    return [c.to_dict() for c in checks]


def complex_pairs(z: Iterable[complex]) -> list[list[float]]:
    """``[[re, im], …]`` for JSON."""
    return [[float(v.real), float(v.imag)] for v in z]


class Objective(Enum):
    """What the synthesis optimises over the LMI-feasible set.

    Examples
    --------
    The smallest ``γ`` of LMI (14) (Grip, Saberi & Johansen) for a damped oscillator, with ``‖K‖₂ ≤ 5``
    making the minimum attained; without a gain bound, minimising ``γn`` is refused as unattained:

    >>> import numpy as np
    >>> from nlobs.synthesis import GainBound, design_observer_gain
    >>> from nlobs.errors import DesignUnbounded
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> [o.value for o in Objective]
    ['central', 'min_gamma_n', 'min_gamma']
    >>> cert = design_observer_gain(A, C, Bd, objective=Objective.MIN_GAMMA, gain_bound=GainBound(5.0))
    >>> cert.objective, cert.verified, bool(cert.hinf_H < cert.gamma < 1.0), bool(cert.gain_norm <= 5.0)
    (<Objective.MIN_GAMMA: 'min_gamma'>, True, True, True)
    >>> try:
    ...     design_observer_gain(A, C, Bd, gamma=10.0, objective="min_gamma_n")
    ... except DesignUnbounded as exc:
    ...     print(type(exc).__name__, exc)
    DesignUnbounded minimising γn² subject to LMIs (14), (15) has no minimum here: ...
    """

    CENTRAL = "central"
    """Maximise ``log det P + Σ log det(−F_i)`` over the LMI blocks ``F_i ≺ 0``
    (the analytic centre): a finite, well-conditioned gain deep inside the set.
    Needs a bounded set (``gamma_n`` with LMI (15), or a gain bound)."""
    MIN_GAMMA_N = "min_gamma_n"
    """Minimise ``γn²`` subject to (14), (15) (Grip, Saberi & Johansen, Sec. 3.2) — raises
    :class:`~nlobs.errors.DesignUnbounded` when the minimum is not attained."""
    MIN_GAMMA = "min_gamma"
    """Minimise ``γ²`` subject to (14) (and the other constraints) — same detection."""


class SynthesisMethod(Enum):
    """How :func:`~nlobs.synthesis.design_observer_gain` computes the gain (``docs/synthesis.md``, "Riccati path").

    Examples
    --------
    The central design with ``γ`` and ``γn`` has a Riccati form, so ``"auto"`` takes it; forcing the SDP gives
    another gain, re-verified by the same checks:

    >>> import numpy as np
    >>> from nlobs.synthesis import design_observer_gain
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> ric = design_observer_gain(A, C, Bd, gamma=10.0, gamma_n=10.0)
    >>> sdp = design_observer_gain(A, C, Bd, gamma=10.0, gamma_n=10.0, method=SynthesisMethod.SDP)
    >>> (ric.method.value, ric.solver), (sdp.method.value, sdp.solver.value)
    (('riccati', None), ('sdp', 'CLARABEL'))
    >>> ric.verified, sdp.verified, [c.name for c in ric.checks] == [c.name for c in sdp.checks]
    (True, True, True)
    """

    AUTO = "auto"
    """Choose: :attr:`RICCATI` when the problem has a Riccati form (objective ``CENTRAL`` with ``γ`` and
    ``γn``, no pole region, no gain bound, ``N Nᵀ ≻ 0``), else :attr:`SDP`. Never the method of a certificate."""
    RICCATI = "riccati"
    """The stabilising solution of the H∞ filter Riccati equation (:mod:`nlobs.synthesis.riccati`)."""
    SDP = "sdp"
    """The LMIs solved by an interior-point SDP solver (Clarabel or SCS)."""


class CertificateStatus(Enum):
    """Outcome of the independent re-verification.

    Examples
    --------
    A given gain is re-verified by :func:`~nlobs.synthesis.observer_gain.verify_observer_gain`: ``K = [1, 1]ᵀ``
    places ``A − K C`` in the left half-plane, ``K = [−5, 0]ᵀ`` does not (``strict=False`` returns the failed
    certificate instead of raising):

    >>> import numpy as np
    >>> from nlobs.synthesis import verify_observer_gain
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> good = verify_observer_gain(A, C, Bd, [[1.0], [1.0]], gamma=10.0)
    >>> bad = verify_observer_gain(A, C, Bd, [[-5.0], [0.0]], gamma=10.0, strict=False)
    >>> good.status, bad.status
    (<CertificateStatus.VERIFIED: 'verified'>, <CertificateStatus.FAILED: 'failed'>)
    >>> bad.verified, bad.hinf_H, "‖H‖∞ < γ" in [c.name for c in bad.failed_checks]
    (False, inf, True)
    """

    VERIFIED = "verified"
    """Every check passed."""
    FAILED = "failed"
    """At least one check failed (see :attr:`ObserverGainCertificate.failed_checks`)."""


@dataclass(frozen=True, eq=False)
class ObserverGainCertificate(CertificateMixin):
    """A verified (or, from :func:`verify_observer_gain` with ``strict=False``, failed) observer gain.

    Error dynamics ``ẇ = (A − K C) w + B_d d − K N n`` (Grip, Saberi & Johansen, (12a)),
    ``H(s) = (sI − A + K C)⁻¹ B_d`` (13), ``G(s) = −(sI − A + K C)⁻¹ K N``.

    A :class:`Certificate`; :attr:`status` (``VERIFIED`` or ``FAILED``) follows from the checks.

    Attributes
    ----------
    gain : ndarray, shape (n, p)
        Observer gain ``K`` of (12a).
    P : ndarray, shape (n, n), or None
        Common Lyapunov matrix of LMIs (14), (15) and the region LMIs
        (``None`` when none was found for a given gain).
    gamma : float
        Bound ``γ`` of LMI (14): ``‖H‖∞ < γ``.
    gamma_n : float or None
        Bound ``γn`` of LMI (15): ``‖G‖∞ ≤ γn`` (``None`` without noise channel).
    hinf_H : float
        ``‖H‖∞`` recomputed from ``K`` (``inf`` if ``A − K C`` is not Hurwitz).
    hinf_G : float or None
        ``‖G‖∞`` recomputed from ``K`` (``None`` without noise channel).
    eigenvalues : ndarray of complex
        Closed-loop eigenvalues of ``A − K C`` (sorted by real part).
    checks : tuple of Check
        Every re-verification check (LMI blocks, ``P ≻ 0``, spectrum, regions, norms, gain).
    objective : Objective or None
        The design objective (``None`` for a verified given gain).
    solver : Solver or None
        The SDP solver that produced ``P`` (and ``K``); ``None`` on the Riccati path.
    solver_status : str
        The solver's own status string (not trusted on its own).
    margin : float
        Strictness margin ``ε`` used in the LMIs (``F ⪯ −ε I``, ``P ⪰ ε I``).
    seconds : float
        Wall-clock time of the whole design/verification.
    method : SynthesisMethod
        The path that produced ``K`` and ``P``: :attr:`~SynthesisMethod.SDP` (the LMIs solved by
        ``solver``) or :attr:`~SynthesisMethod.RICCATI` (the H∞ filter Riccati equation). The checks are
        the same either way.

    Examples
    --------
    A damped oscillator measured in position, the disturbance entering the velocity (LMIs (14), (15) at
    ``γ = γn = 10``):

    >>> import numpy as np
    >>> from nlobs.synthesis import design_observer_gain
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> cert = design_observer_gain(A, C, Bd, gamma=10.0, gamma_n=10.0)
    >>> cert.status.value, cert.gain.shape, cert.P.shape, [c.name for c in cert.lmi_checks]
    ('verified', (2, 1), (2, 2), ['LMI (14)', 'LMI (15)'])
    >>> bool(cert.hinf_ratio < 1 and cert.noise_ratio <= 1)  # ‖H‖∞ < γ and ‖G‖∞ ≤ γn, recomputed
    True
    >>> bool(np.isclose(cert.decay_rate, -np.linalg.eigvals(A - cert.gain @ C).real.max()))
    True
    >>> cert.to_dict()["verified"], cert.summary().splitlines()[0]
    (True, 'observer gain certificate: verified')
    """

    gain: NDArray[np.float64]
    P: NDArray[np.float64] | None
    gamma: float
    gamma_n: float | None
    hinf_H: float
    hinf_G: float | None
    eigenvalues: NDArray[np.complex128]
    checks: tuple[Check, ...]
    objective: Objective | None
    solver: Solver | None
    solver_status: str
    margin: float
    seconds: float = 0.0
    method: SynthesisMethod = SynthesisMethod.SDP

    @property
    def status(self) -> CertificateStatus:
        """``VERIFIED`` when every check passed, else ``FAILED``."""
        return CertificateStatus.VERIFIED if self.verified else CertificateStatus.FAILED

    @property
    def lmi_checks(self) -> tuple[Check, ...]:
        """The per-LMI-block checks (largest eigenvalue of each symmetrised block)."""
        return tuple(c for c in self.checks if c.kind is CheckKind.LMI)

    @property
    def gain_norm(self) -> float:
        """``‖K‖₂``."""
        return float(np.linalg.norm(self.gain, 2))

    @property
    def hinf_ratio(self) -> float:
        """``‖H‖∞ / γ`` (< 1 when verified)."""
        return float(self.hinf_H / self.gamma)

    @property
    def noise_ratio(self) -> float | None:
        """``‖G‖∞ / γn`` (≤ 1 when verified), or ``None``."""
        if self.hinf_G is None or self.gamma_n is None:
            return None
        return float(self.hinf_G / self.gamma_n)

    @property
    def decay_rate(self) -> float:
        """``−max Re λ(A − K C)``."""
        return float(-np.max(self.eigenvalues.real))

    def summary(self) -> str:
        """A multi-line human-readable report."""
        lines = [
            f"observer gain certificate: {self.status.value}",
            f"  objective={self.objective.value if self.objective else 'given gain'}, method={self.method.value}, "
            f"solver={self.solver.value if self.solver else '-'} ({self.solver_status}), margin={self.margin:g}",
            f"  ‖K‖₂={self.gain_norm:.6g}, ‖H‖∞={self.hinf_H:.6g} (γ={self.gamma:g})"
            + (f", ‖G‖∞={self.hinf_G:.6g} (γn={self.gamma_n:g})" if self.hinf_G is not None else ""),
            "  eig(A−KC) = " + ", ".join(f"{z:.4g}" for z in self.eigenvalues),
        ]
        lines += ["  " + c.summary() for c in self.checks]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view: the gain, ``P``, the bounds, the recomputed norms and eigenvalues, every check."""
        return {
            "status": self.status.value,
            "verified": self.verified,
            "gain": self.gain.tolist(),
            "P": None if self.P is None else self.P.tolist(),
            "gamma": self.gamma,
            "gamma_n": self.gamma_n,
            "hinf_H": self.hinf_H,
            "hinf_G": self.hinf_G,
            "gain_norm": self.gain_norm,
            "decay_rate": self.decay_rate,
            "eigenvalues": complex_pairs(self.eigenvalues),
            "checks": checks_dict(self.checks),
            "objective": None if self.objective is None else self.objective.value,
            "solver": None if self.solver is None else self.solver.value,
            "solver_status": self.solver_status,
            "margin": self.margin,
            "seconds": self.seconds,
            "method": self.method.value,
        }
