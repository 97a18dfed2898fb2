"""Eigenvalue-based stability tests for ``ẋ = A x`` and ``x⁺ = A x``.

Continuous time is (Hurwitz) stable when every eigenvalue of ``A`` has a
negative real part; discrete time is (Schur) stable when every eigenvalue lies
strictly inside the unit circle.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_square, in_range
from nlobs.errors import NumericalError
from nlobs.systems.linear import takes_system

__all__ = ["BOUNDARY_TOL", "strictly_inside", "eigenvalues", "is_stable", "spectral_abscissa", "spectral_radius", "stability_margin"]


MAGNITUDE_LIMIT = 1e130
"""Largest entry magnitude the linear analyses accept (:func:`require_magnitude`).

LAPACK's eigenvalue drivers rescale a matrix whose largest entry exceeds
``eps / sqrt(safe_min) ≈ 1.5e138``; through SciPy this was measured to return wrong
eigenvalues (``[[a, a], [−a, a]]`` with ``a = 1e140`` gave ``1.49e138 (1 ± j)`` instead of
``1e140 (1 ± j)``), and Frobenius norms, Gramians and Hamiltonian pencils of such data
overflow. Below this limit they are computed in range."""


def require_magnitude(name: str, M: NDArray[np.float64]) -> None:
    """Raise :class:`~nlobs.errors.NumericalError` naming ``name`` when ``max |M_ij| > MAGNITUDE_LIMIT``."""
    if M.size == 0:
        return
    big = float(np.max(np.abs(M)))
    if big > MAGNITUDE_LIMIT:
        raise NumericalError(
            f"{name}: entries up to {big:.3g} in magnitude exceed {MAGNITUDE_LIMIT:.0e}; eigenvalues, "
            "norms and Gramians of such data overflow or lose all accuracy in double precision "
            "(rescale the model's units)")


def _eigs(A: NDArray[np.float64]) -> NDArray[np.complex128]:
    """Eigenvalues, computed from ``2^k A`` with ``max |2^k A_ij| ≈ 1`` (exact scaling).

    The power-of-2 scaling changes no digit of a well-scaled matrix's eigenvalues and keeps
    LAPACK's own (here unreliable) rescaling of huge or tiny matrices from triggering.
    """
    if A.shape[0] == 0:
        return np.zeros(0, dtype=complex)
    big = float(np.max(np.abs(A)))
    if big == 0.0:
        return np.zeros(A.shape[0], dtype=complex)
    k = -int(np.frexp(big)[1])
    lam = np.asarray(scipy.linalg.eigvals(np.ldexp(A, k)), dtype=complex)
    with np.errstate(over="ignore"):
        lam = np.ldexp(lam.real, -k) + 1j * np.ldexp(lam.imag, -k)
    if not np.all(np.isfinite(lam)):
        raise NumericalError(f"A: eigenvalues overflow double precision (largest entry {big:.3g})")
    return lam


BOUNDARY_TOL = 1e-9
"""Default margin of :func:`strictly_inside`: computed zeros/modes closer than
this (relatively) to the stability boundary are treated as *on* it."""


def strictly_inside(points: ArrayLike, *, discrete: bool = False, tol: float = BOUNDARY_TOL) -> NDArray[np.bool_]:
    """Elementwise test that complex points lie strictly in the stability region.

    Parameters
    ----------
    points : array_like of complex
        Eigenvalues, unobservable modes or invariant zeros.
    discrete : bool
        Region ``|z| < 1`` instead of ``Re z < 0``.
    tol : float, default 1e-9
        Safety margin for computed quantities: ``Re z < −tol·max(1, |z|)``,
        resp. ``|z| < 1 − tol``. A zero exactly on the boundary (``s = 0``,
        ``z = −1``) is computed only to rounding accuracy, so without a margin
        its classification would be decided by the sign of a rounding error.

    Returns
    -------
    ndarray of bool

    Examples
    --------
    The boundary itself is outside (``s = 0``, ``s = j``), and so is a point within ``tol`` of it:

    >>> strictly_inside([-1, 0, 1j, -1 + 2j, -1e-12]).tolist()
    [True, False, False, True, False]
    >>> strictly_inside([0.5, -1, 0.99j], discrete=True).tolist()
    [True, False, True]
    """
    z = np.asarray(points, dtype=complex)
    t = in_range("tol", tol, 0.0, np.inf)
    if discrete:
        return np.abs(z) < 1.0 - t
    return z.real < -t * np.maximum(1.0, np.abs(z))


@takes_system(A="A")
def eigenvalues(A: ArrayLike) -> NDArray[np.complex128]:
    """Eigenvalues of a square matrix, sorted by real part then imaginary part.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Finite square matrix.

    Returns
    -------
    ndarray of complex, shape (n,)
        The eigenvalues (LAPACK ``geev`` via :func:`scipy.linalg.eigvals`).

    Raises
    ------
    DimensionError
        ``A`` is not a square 2-d matrix.
    NonFiniteError
        ``A`` has NaN or infinite entries.

    Examples
    --------
    The companion matrix of ``s² + 2s + 2`` has the roots ``−1 ± j``; real eigenvalues come sorted:

    >>> import numpy as np
    >>> np.round(eigenvalues([[0, 1], [-2, -2]]), 9).tolist()
    [(-1-1j), (-1+1j)]
    >>> eigenvalues([[3, 0], [0, -1]]).real.tolist()
    [-1.0, 3.0]
    """
    lam = _eigs(as_square("A", A))
    return lam[np.lexsort((lam.imag, lam.real))]


@takes_system(A="A")
def spectral_abscissa(A: ArrayLike) -> float:
    """Largest real part of the eigenvalues of ``A`` (``-inf`` when ``n = 0``).

    ``ẋ = A x`` is asymptotically stable iff the spectral abscissa is negative.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Finite square matrix.

    Returns
    -------
    float

    Examples
    --------
    The eigenvalues ``−1 ± j`` of ``s² + 2s + 2``: the largest real part is ``−1``:

    >>> round(spectral_abscissa([[0, 1], [-2, -2]]), 9)
    -1.0
    """
    lam = _eigs(as_square("A", A))
    return float(np.max(lam.real, initial=-np.inf))


@takes_system(A="A")
def spectral_radius(A: ArrayLike) -> float:
    """Largest modulus of the eigenvalues of ``A`` (``0`` when ``n = 0``).

    ``x⁺ = A x`` is asymptotically stable iff the spectral radius is below one.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Finite square matrix.

    Returns
    -------
    float

    Examples
    --------
    A triangular matrix has its diagonal as eigenvalues: ``max(|0.5|, |−0.8|) = 0.8``; ``−1 ± j`` have
    modulus ``√2``:

    >>> round(spectral_radius([[0.5, 1], [0, -0.8]]), 9)
    0.8
    >>> round(spectral_radius([[0, 1], [-2, -2]]), 9) == round(2**0.5, 9)
    True
    """
    lam = _eigs(as_square("A", A))
    return float(np.max(np.abs(lam), initial=0.0))


@takes_system(A="A")
def stability_margin(A: ArrayLike, *, discrete: bool = False) -> float:
    """Distance of the worst eigenvalue to the stability boundary.

    Parameters
    ----------
    A : array_like, shape (n, n)
        System matrix.
    discrete : bool
        ``False``: the boundary is the imaginary axis and the margin is
        ``-max Re λ``. ``True``: the boundary is the unit circle and the margin
        is ``1 - max |λ|``.

    Returns
    -------
    float
        Positive when ``A`` is strictly stable, zero on the boundary, negative
        when unstable; ``+inf`` for ``n = 0`` in continuous time (no eigenvalue)
        and ``1`` in discrete time.

    Examples
    --------
    ``−1 ± j`` are at distance 1 from the imaginary axis; ``0.5`` and ``−0.8`` at distance
    ``1 − 0.8 = 0.2`` from the unit circle; the double integrator sits on the boundary:

    >>> round(stability_margin([[0, 1], [-2, -2]]), 9)
    1.0
    >>> round(stability_margin([[0.5, 1], [0, -0.8]], discrete=True), 9)
    0.2
    >>> stability_margin([[0, 1], [0, 0]]) == 0
    True
    """
    if discrete:
        return 1.0 - spectral_radius(A)
    return -spectral_abscissa(A)


@takes_system(A="A")
def is_stable(A: ArrayLike, *, discrete: bool = False, tol: float = 0.0) -> bool:
    """Whether ``A`` is strictly (asymptotically) stable, with a safety margin.

    Parameters
    ----------
    A : array_like, shape (n, n)
        System matrix.
    discrete : bool
        Schur (``|λ| < 1``) instead of Hurwitz (``Re λ < 0``) stability.
    tol : float, default 0
        Required margin: the test is ``stability_margin(A) > tol``, i.e.
        ``max Re λ < -tol`` or ``max |λ| < 1 - tol``.

    Returns
    -------
    bool

    Examples
    --------
    ``−1 ± j`` are Hurwitz, but not with a margin of 1.5; the double integrator is not
    asymptotically stable; ``0.5`` and ``−0.8`` are Schur:

    >>> is_stable([[0, 1], [-2, -2]]), is_stable([[0, 1], [-2, -2]], tol=1.5), is_stable([[0, 1], [0, 0]])
    (True, False, False)
    >>> is_stable([[0.5, 1], [0, -0.8]], discrete=True)
    True
    """
    t = in_range("tol", tol, -np.inf, np.inf)
    return bool(stability_margin(A, discrete=discrete) > t)
