r"""LMI pole regions of Chilali & Gahinet (1996) for the observer error dynamics.

An *LMI region* is ``D = {z ∈ ℂ : f_D(z) = L + M z + Mᵀ z̄ ≺ 0}`` with real
symmetric ``L``. Chilali & Gahinet (1996, Thm. 2.2) show that all eigenvalues
of a real matrix ``F`` lie in ``D`` iff there is ``P ≻ 0`` with

.. math:: M_D(F, P) = L ⊗ P + M ⊗ (P F) + Mᵀ ⊗ (P F)ᵀ ≺ 0 .

(They write it with ``F X``, ``X = P⁻¹``; for the observer we apply it to ``Fᵀ``,
which has the same eigenvalues, and every region here is symmetric about the
real axis.) For ``F = A − K C`` and ``X = P K`` (Grip, Saberi & Johansen, LMI (14)) the product
``P F = P A − X C`` is affine in ``(P, X)``, so a region constraint with the
*same* ``P`` as LMIs (14)/(15) is again an LMI — this is the "common Lyapunov
matrix" multi-objective design the paper mentions in Sec. 3.2.

Each region is a frozen dataclass with

* ``lmi(P, PF)`` — the block ``M_D`` (symmetrised) for a CVXPY variable ``P``
  and expression ``PF = P A − X C``, or for numeric arrays (verification);
* ``margin(eigenvalues)`` — the smallest signed distance-like margin of the
  eigenvalues to the region boundary (positive inside);
* ``contains(eigenvalues)`` — ``margin > 0``.

References
----------
M. Chilali and P. Gahinet, "H∞ design with pole placement constraints: an LMI
approach", IEEE Trans. Automatic Control 41(3) (1996) 358–367.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_matrix, as_symmetric, positive
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.synthesis.lmi import bmat, symmetrise

__all__ = ["PoleRegion", "HalfPlane", "Disk", "Sector", "LmiRegion"]


def _eigs(eigenvalues: ArrayLike) -> NDArray[np.complex128]:
    lam = np.atleast_1d(np.asarray(eigenvalues, dtype=complex)).ravel()
    if not np.all(np.isfinite(lam)):
        raise NonFiniteError("eigenvalues: all entries must be finite")
    return lam


def _finite(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise DimensionError(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(v):
        raise NonFiniteError(f"{name}: must be finite, got {v!r}")
    return v


class PoleRegion(ABC):
    """An LMI region ``D`` of the complex plane (Chilali & Gahinet 1996).

    Examples
    --------
    Several regions passed to a design are intersected: each adds its LMI with the ``P`` of LMI (14)
    (Grip, Saberi & Johansen) and an eigenvalue check to the certificate:

    >>> import numpy as np
    >>> from nlobs.synthesis import design_observer_gain
    >>> A, C, Bd = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> regions = [HalfPlane(1.0), Sector.from_damping(0.7)]
    >>> cert = design_observer_gain(A, C, Bd, gamma=10.0, gamma_n=10.0, region=regions)
    >>> cert.verified, [r.contains(cert.eigenvalues) for r in regions]
    (True, [True, True])
    >>> [c.name for c in cert.checks if c.name.startswith("region")]
    ['region: half-plane Re λ < -1', 'region: sector |arg(−λ)| < 45.573°']
    >>> all(issubclass(cls, PoleRegion) for cls in (HalfPlane, Disk, Sector, LmiRegion))
    True
    """

    @abstractmethod
    def lmi(self, P: Any, PF: Any) -> Any:
        """The block ``M_D(F, P)`` that must be ``≺ 0`` (symmetrised).

        Parameters
        ----------
        P : cvxpy.Variable or ndarray
            The common Lyapunov matrix, ``n × n`` symmetric.
        PF : cvxpy.Expression or ndarray
            ``P F = P A − X C`` for ``F = A − K C`` (``X = P K``).
        """

    @abstractmethod
    def margin(self, eigenvalues: ArrayLike) -> float:
        """Smallest margin of the eigenvalues inside the region (``> 0`` strictly inside)."""

    def contains(self, eigenvalues: ArrayLike) -> bool:
        """Whether every eigenvalue lies strictly inside the region."""
        return self.margin(eigenvalues) > 0.0

    @property
    @abstractmethod
    def description(self) -> str:
        """Human-readable description used in messages and check names."""


@dataclass(frozen=True)
class HalfPlane(PoleRegion):
    r"""α-stability region ``Re λ < −α`` (decay rate at least ``α``).

    LMI (Chilali & Gahinet 1996, eq. (11) with ``L = 2α``, ``M = 1``):
    ``P F + Fᵀ P + 2 α P ≺ 0``.

    Parameters
    ----------
    alpha : float
        Required decay rate; any finite real (``α < 0`` allows slow unstable
        poles in the region itself, but LMI (14) still forces Hurwitz).

    Examples
    --------
    ``F`` with eigenvalues ``−2 ± j`` decays at rate 2: inside ``Re λ < −1`` (margin 1), outside
    ``Re λ < −2.5``. ``F`` is normal, so ``P = I`` proves it, and the LMI's largest eigenvalue is
    ``2(α − 2)``:

    >>> import numpy as np
    >>> F = np.array([[-2.0, 1.0], [-1.0, -2.0]])
    >>> lam = np.linalg.eigvals(F)
    >>> HalfPlane(1.0).description, round(HalfPlane(1.0).margin(lam), 6), HalfPlane(2.5).contains(lam)
    ('half-plane Re λ < -1', 1.0, False)
    >>> [round(float(np.linalg.eigvalsh(HalfPlane(a).lmi(np.eye(2), F)).max()), 6) for a in (1.0, 2.5)]
    [-2.0, 1.0]
    """

    alpha: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "alpha", _finite("alpha", self.alpha))

    def lmi(self, P: Any, PF: Any) -> Any:
        return symmetrise(PF + PF.T + 2.0 * self.alpha * P)

    def margin(self, eigenvalues: ArrayLike) -> float:
        lam = _eigs(eigenvalues)
        return float(np.min(-self.alpha - lam.real))

    @property
    def description(self) -> str:
        return f"half-plane Re λ < {-self.alpha:g}"


@dataclass(frozen=True)
class Disk(PoleRegion):
    r"""Disk ``|λ − c| < r`` with real centre ``c`` and radius ``r > 0``.

    LMI (Chilali & Gahinet 1996, eq. (12), centre ``−q = c``):
    ``[[−r P, (P F − c P)ᵀ], [P F − c P, −r P]] ≺ 0``, which by a Schur
    complement is ``(F − cI)ᵀ P (F − cI) ≺ r² P``.

    Parameters
    ----------
    center : float
        Real centre ``c`` (e.g. ``−10``).
    radius : float
        Radius ``r > 0``.

    Examples
    --------
    The eigenvalues ``−2 ± j`` lie at distance 1 from ``c = −2``: inside ``r = 1.5`` (margin 0.5), outside
    ``r = 0.5``. With ``P = I`` (``F`` is normal) the LMI's largest eigenvalue is ``‖F − cI‖ − r = 1 − r``:

    >>> import numpy as np
    >>> F = np.array([[-2.0, 1.0], [-1.0, -2.0]])
    >>> lam = np.linalg.eigvals(F)
    >>> Disk(-2.0, 1.5).description, round(Disk(-2.0, 1.5).margin(lam), 6), Disk(-2.0, 0.5).contains(lam)
    ('disk |λ − (-2)| < 1.5', 0.5, False)
    >>> [round(float(np.linalg.eigvalsh(Disk(-2.0, r).lmi(np.eye(2), F)).max()), 6) for r in (1.5, 0.5)]
    [-0.5, 0.5]
    """

    center: float
    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _finite("center", self.center))
        object.__setattr__(self, "radius", positive("radius", self.radius))

    def lmi(self, P: Any, PF: Any) -> Any:
        S = PF - self.center * P
        return symmetrise(bmat([[-self.radius * P, S.T], [S, -self.radius * P]]))

    def margin(self, eigenvalues: ArrayLike) -> float:
        lam = _eigs(eigenvalues)
        return float(self.radius - np.max(np.abs(lam - self.center)))

    @property
    def description(self) -> str:
        return f"disk |λ − ({self.center:g})| < {self.radius:g}"


@dataclass(frozen=True)
class Sector(PoleRegion):
    r"""Conic sector ``|arg(−λ)| < θ`` around the negative real axis.

    Equivalently ``|Im λ| < tan θ · (−Re λ)``; poles in it have damping ratio
    ``ζ > cos θ``. LMI (Chilali & Gahinet 1996, eq. (13)):
    ``[[sin θ (PF + (PF)ᵀ), cos θ (PF − (PF)ᵀ)], [cos θ ((PF)ᵀ − PF), sin θ (PF + (PF)ᵀ)]] ≺ 0``.

    Parameters
    ----------
    half_angle : float
        ``θ`` in radians, ``0 < θ < π/2``.

    Examples
    --------
    The eigenvalues ``−2 ± j`` have damping ratio ``2/√5 ≈ 0.894``: inside the sector of ``ζ > 0.7``,
    outside that of ``ζ > 0.95``, and the LMI with ``P = I`` (``F`` is normal) agrees:

    >>> import numpy as np
    >>> F = np.array([[-2.0, 1.0], [-1.0, -2.0]])
    >>> lam = np.linalg.eigvals(F)
    >>> s = Sector.from_damping(0.7)
    >>> s.description, round(s.half_angle, 4), s.contains(lam), Sector.from_damping(0.95).contains(lam)
    ('sector |arg(−λ)| < 45.573°', 0.7954, True, False)
    >>> [bool(np.linalg.eigvalsh(Sector.from_damping(z).lmi(np.eye(2), F)).max() < 0) for z in (0.7, 0.95)]
    [True, False]
    >>> try:
    ...     Sector(2.0)
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError half_angle: must lie in (0, π/2) radians, got 2.0
    """

    half_angle: float

    def __post_init__(self) -> None:
        th = _finite("half_angle", self.half_angle)
        if not 0.0 < th < math.pi / 2:
            raise InvalidArgumentError(f"half_angle: must lie in (0, π/2) radians, got {th!r}")
        object.__setattr__(self, "half_angle", th)

    @classmethod
    def from_damping(cls, zeta: float) -> Sector:
        """The sector of poles with damping ratio greater than ``ζ ∈ (0, 1)``: ``θ = arccos ζ``."""
        z = _finite("zeta", zeta)
        if not 0.0 < z < 1.0:
            raise InvalidArgumentError(f"zeta: must lie in (0, 1), got {z!r}")
        return cls(math.acos(z))

    def lmi(self, P: Any, PF: Any) -> Any:
        s, c = math.sin(self.half_angle), math.cos(self.half_angle)
        Sy = PF + PF.T
        Sk = PF - PF.T
        return symmetrise(bmat([[s * Sy, c * Sk], [-c * Sk, s * Sy]]))

    def margin(self, eigenvalues: ArrayLike) -> float:
        lam = _eigs(eigenvalues)
        s, c = math.sin(self.half_angle), math.cos(self.half_angle)
        # distance of λ to the boundary rays, positive inside (for Re λ < 0)
        return float(np.min(-lam.real * s - np.abs(lam.imag) * c))

    @property
    def description(self) -> str:
        return f"sector |arg(−λ)| < {math.degrees(self.half_angle):g}°"


@dataclass(frozen=True, eq=False)
class LmiRegion(PoleRegion):
    r"""A general LMI region ``{z : L + M z + Mᵀ z̄ ≺ 0}`` (Chilali & Gahinet 1996, Def. 2.1).

    LMI: ``L ⊗ P + M ⊗ (P F)ᵀ + Mᵀ ⊗ (P F) ≺ 0`` (Thm. 2.2 applied to ``Fᵀ``).

    Parameters
    ----------
    L : array_like
        Real symmetric ``d × d``.
    M : array_like
        Real ``d × d``.
    name : str
        Label for messages.

    Examples
    --------
    ``Re z < −1`` as ``L = [2]``, ``M = [1]`` (``f = 2 + z + z̄``), and the disk ``|z + 2| < 1.5`` as
    ``L = [[−1.5, 2], [2, −1.5]]``, ``M = [[0, 1], [0, 0]]``: their LMIs are those of :class:`HalfPlane` and
    :class:`Disk` for any ``P``:

    >>> import numpy as np
    >>> F, P = np.array([[-2.0, 1.0], [-1.0, -2.0]]), np.array([[2.0, 0.5], [0.5, 1.0]])
    >>> hp = LmiRegion([[2.0]], [[1.0]], name="Re z < -1")
    >>> dk = LmiRegion([[-1.5, 2.0], [2.0, -1.5]], [[0.0, 1.0], [0.0, 0.0]], name="|z + 2| < 1.5")
    >>> bool(np.allclose(hp.lmi(P, P @ F), HalfPlane(1.0).lmi(P, P @ F)))
    True
    >>> bool(np.allclose(dk.lmi(P, P @ F), Disk(-2.0, 1.5).lmi(P, P @ F)))
    True
    >>> lam = np.linalg.eigvals(F)  # −2 ± j
    >>> hp.contains(lam), dk.contains(lam), dk.contains([-3.6]), dk.description
    (True, True, False, '|z + 2| < 1.5')
    """

    L: NDArray[np.float64]
    M: NDArray[np.float64]
    name: str = "LMI region"

    def __post_init__(self) -> None:
        L = as_symmetric("L", self.L)
        M = as_matrix("M", self.M, (L.shape[0], L.shape[0]))
        L.setflags(write=False)
        M = np.array(M)
        M.setflags(write=False)
        object.__setattr__(self, "L", L)
        object.__setattr__(self, "M", M)

    def lmi(self, P: Any, PF: Any) -> Any:
        d = self.L.shape[0]
        rows = [
            [self.L[i, j] * P + self.M[i, j] * PF.T + self.M[j, i] * PF for j in range(d)] for i in range(d)
        ]
        return symmetrise(bmat(rows))

    def margin(self, eigenvalues: ArrayLike) -> float:
        lam = _eigs(eigenvalues)
        worst = -math.inf
        for z in lam:
            f = self.L + self.M * z + self.M.T * np.conj(z)
            worst = max(worst, float(np.linalg.eigvalsh(0.5 * (f + f.conj().T))[-1]))
        return -worst

    @property
    def description(self) -> str:
        return self.name


def as_regions(region: PoleRegion | tuple[PoleRegion, ...] | list[PoleRegion] | None) -> tuple[PoleRegion, ...]:
    """Normalise ``None``, one region or a sequence of regions (intersection) to a tuple."""
    if region is None:
        return ()
    if isinstance(region, PoleRegion):
        return (region,)
    if isinstance(region, (tuple, list)):
        out = tuple(region)
        for r in out:
            if not isinstance(r, PoleRegion):
                raise InvalidArgumentError(f"region: expected PoleRegion instances, got {type(r).__name__}")
        return out
    raise InvalidArgumentError(f"region: expected a PoleRegion or a sequence of them, got {type(region).__name__}")

