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

    Examples
    --------
    A block of size 3 with ``θ = 2``: the Dalla Mora–Germani–Manes roots ``−θ^i`` and the
    Gauthier–Hammouri–Othman triple root ``−θ``:

    >>> high_gain_roots(3, 2.0).tolist()
    [-2.0, -4.0, -8.0]
    >>> high_gain_roots(3, 2.0, "multiple").tolist()
    [-2.0, -2.0, -2.0]
    >>> try:
    ...     high_gain_roots(3, 2.0, "random")
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError `placement`: expected one of ['powers', 'multiple'], got 'random'
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

    Raises
    ------
    InvalidArgumentError
        ``θ`` so large that a coefficient exceeds double precision; ``θ ≤ 0``, ``r`` not a positive
        integer or an unknown ``placement``.
    NonFiniteError
        ``θ`` is not finite.

    Examples
    --------
    For ``r = 3``, ``θ = 2``: ``(λ + 2)(λ + 4)(λ + 8) = λ³ + 14λ² + 56λ + 64`` and the binomial
    coefficients ``C(3, i) 2^i`` of ``(λ + 2)³``; both agree with the polynomial of the roots:

    >>> import numpy as np
    >>> k = high_gain_coefficients(3, 2.0)
    >>> k.tolist(), bool(np.allclose(np.poly(high_gain_roots(3, 2.0))[1:], k))
    ([14.0, 56.0, 64.0], True)
    >>> high_gain_coefficients(3, 2.0, "multiple").tolist()
    [6.0, 12.0, 8.0]
    >>> try:
    ...     high_gain_coefficients(30, 1e3)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError `theta`: θ = 1000 makes the gain coefficients of (10) about 10^1395 ... below about 4.42
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

    Examples
    --------
    Two outputs with block sizes ``r = (2, 1)`` and ``θ = 2``: ``(λ + 2)(λ + 4) = λ² + 6λ + 8`` for
    the first block and ``λ + 2`` for the second, stacked:

    >>> design = HighGain(theta=2.0)
    >>> design.vector([2, 1]).tolist(), design.roots([2, 1]).tolist()
    ([6.0, 8.0, 2.0], [-2.0, -4.0, -2.0])
    >>> HighGain(theta=2.0, placement="multiple").vector([2, 1]).tolist()  # (λ + 2)², λ + 2
    [4.0, 4.0, 2.0]
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

    Examples
    --------
    ``k = (6, 8)`` places the roots of ``λ² + 6λ + 8`` at ``−2, −4`` (:class:`HighGain` with ``θ = 2``):

    >>> import numpy as np
    >>> M = companion_error_matrix([6.0, 8.0])
    >>> M.tolist()
    [[-6.0, 1.0], [-8.0, 0.0]]
    >>> np.sort(np.linalg.eigvals(M).real).tolist()
    [-4.0, -2.0]
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
