r"""The gain vector ``k`` of Röbenack's observers (7): high-gain root placement for (10).

Both the Moore–Penrose gain ``l(x) = Q⁺(x) K`` (17) and the Byrnes–Isidori gain
``l(x) = (Φ'(x))⁻¹ [K; 0]`` (8)/(15) (:mod:`nlobs.observers.pinv`) take ``K = blockdiag(k¹, …, k^q)``,
one block of ``r_j`` entries per output. Each block makes ``A − k cᵀ`` (9a) Hurwitz: its
characteristic polynomial (10) is ``det(λI − (A − kcᵀ)) = λ^r + k_1 λ^{r−1} + … + k_r``. A
:class:`HighGain` places the roots at ``−θ^i`` (``i = 1..r``; Dalla Mora–Germani–Manes [9, 10])
or at ``−θ`` with multiplicity ``r`` (Gauthier–Hammouri–Othman [13]).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_vector, positive
from nlobs.errors import DimensionError, InvalidArgumentError

__all__ = [
    "DEFAULT_THETA",
    "PLACEMENTS",
    "HighGain",
    "Placement",
    "companion_error_matrix",
    "high_gain_coefficients",
    "high_gain_roots",
    "resolve_gain",
]

#: Default high-gain parameter θ.
DEFAULT_THETA = 2.0

Placement = Literal["powers", "multiple"]
PLACEMENTS: tuple[str, ...] = ("powers", "multiple")


def _check_placement(placement: str) -> str:
    p = str(placement).lower()
    if p not in PLACEMENTS:
        raise InvalidArgumentError(f"`placement`: expected one of {list(PLACEMENTS)}, got {placement!r}")
    return p


def _check_order(r: int, name: str = "r") -> int:
    if isinstance(r, bool) or not isinstance(r, (int, np.integer)) or r < 1:
        raise InvalidArgumentError(f"{name}: expected a positive integer, got {r!r}")
    return int(r)


def high_gain_roots(r: int, theta: float, placement: Placement = "powers") -> Array:
    """Roots of (10): ``−θ, −θ², …, −θ^r`` (``"powers"``, [9, 10]) or ``−θ`` ``r`` times (``"multiple"``, [13]).

    Parameters
    ----------
    r : int
        Block size (relative degree, positive).
    theta : float
        ``θ > 0``.
    placement : {"powers", "multiple"}
        Where the roots go.

    Returns
    -------
    ndarray, shape (r,)
    """
    r_ = _check_order(r)
    th = positive("`theta`", theta)
    if _check_placement(placement) == "powers":
        return -(th ** np.arange(1, r_ + 1, dtype=float))
    return -np.full(r_, th)


def high_gain_coefficients(r: int, theta: float, placement: Placement = "powers") -> Array:
    """``k = (k_1, …, k_r)`` with ``λ^r + k_1 λ^{r−1} + … + k_r = Π (λ − λ_i)`` (10).

    Closed forms: ``k_i = C(r, i) θ^i`` for the multiple root; for the roots
    ``−θ^i``, ``k_i = e_i(θ, θ², …, θ^r)`` (elementary symmetric polynomials,
    ``= θ^{i(i+1)/2}`` times the Gaussian binomial ``[r choose i]_θ``), computed
    by expanding the product.

    Parameters
    ----------
    r : int
        Block size (relative degree, positive).
    theta : float
        ``θ > 0``.
    placement : {"powers", "multiple"}
        Root placement, as in :func:`high_gain_roots`.

    Returns
    -------
    ndarray, shape (r,)
    """
    r_ = _check_order(r)
    th = positive("`theta`", theta)
    multiple = _check_placement(placement) == "multiple"
    # the largest coefficient: C(r, r/2) θ^r (multiple root) or θ^{r(r+1)/2} (roots −θ^i), beyond doubles above 1e300
    top = r_ * math.log10(th) + math.log10(math.comb(r_, r_ // 2)) if multiple else r_ * (r_ + 1) / 2 * math.log10(th)
    if top > 300:
        limit = 10 ** (300 / r_ if multiple else 600 / (r_ * (r_ + 1)))
        raise InvalidArgumentError(f"`theta`: θ = {th:g} makes the gain coefficients of (10) about 10^{top:.0f} for a "
                                   f"block of size {r_} (beyond double precision); take θ below about {limit:.3g}")
    if multiple:
        return np.array([math.comb(r_, i) * th**i for i in range(1, r_ + 1)])
    coeffs = [1.0]
    for i in range(1, r_ + 1):  # multiply by (λ + θ^i)
        p = th**i
        coeffs = [a + p * b for a, b in zip(coeffs + [0.0], [0.0] + coeffs)]
    return np.array(coeffs[1:])


@dataclass(frozen=True)
class HighGain:
    """A high-gain design for ``k``: roots ``−θ^i`` (``"powers"``) or ``−θ`` (``"multiple"``) per output block.

    Parameters
    ----------
    theta : float
        ``θ > 0``; larger is faster (and amplifies noise).
    placement : {"powers", "multiple"}
    """

    theta: float = DEFAULT_THETA
    placement: Placement = "powers"

    def __post_init__(self) -> None:
        object.__setattr__(self, "theta", positive("`theta`", self.theta))
        object.__setattr__(self, "placement", _check_placement(self.placement))

    def roots(self, r: Sequence[int]) -> Array:
        """Stacked roots of (10), one block per output."""
        return np.concatenate([high_gain_roots(_check_order(v), self.theta, self.placement) for v in r])

    def vector(self, r: Sequence[int]) -> Array:
        """Stacked ``k = (k¹, …, k^q)``, ``Σ r_j`` entries."""
        return np.concatenate([high_gain_coefficients(_check_order(v), self.theta, self.placement) for v in r])


def companion_error_matrix(k: ArrayLike) -> Array:
    """``A − k cᵀ`` of (9a) for one block (Brunovsky ``A``, ``c = e_1``); its eigenvalues are the roots of (10).

    Parameters
    ----------
    k : array_like, shape (r,)
        The gain of one block.

    Returns
    -------
    ndarray, shape (r, r)
    """
    kv = as_vector("k", k)
    r = kv.size
    M = np.diag(np.ones(r - 1), 1)
    M[:, 0] -= kv
    return M


def resolve_gain(k: ArrayLike | HighGain, r: Sequence[int]) -> tuple[Array, HighGain | None]:
    """The stacked numeric ``k`` (``Σ r_j`` entries) and the :class:`HighGain` it came from (``None`` if given).

    Parameters
    ----------
    k : array_like or HighGain
        A numeric gain vector or a high-gain design.
    r : sequence of int
        Block sizes ``r_j``, one per output.

    Returns
    -------
    k : ndarray, shape (Σ r_j,)
    design : HighGain or None

    Raises
    ------
    DimensionError
        A given ``k`` has not ``Σ r_j`` entries.
    """
    if isinstance(k, HighGain):
        return k.vector(r), k
    kv = as_vector("`k`", k)
    if kv.size != sum(r):
        raise DimensionError(f"`k`: expected {sum(r)} entries (Σ r_j for r = {tuple(r)}), got {kv.size}")
    return kv, None
