r"""The rotation nearest a 3×3 matrix, for many matrices at once: Newton's polar iteration.

:func:`nlobs.navigation.so3.project_so3` computes the rotation nearest ``M`` in the
Frobenius norm from an SVD, ``M = U Σ Vᵀ → U diag(1, 1, det(UVᵀ)) Vᵀ``. NumPy runs
one LAPACK call per matrix (about 2 µs for a 3×3), which dominates a Monte Carlo
run that projects the observer's ``R̂`` of every flight at every IMU step.

For ``det M > 0`` that rotation is the orthogonal factor of the polar decomposition
``M = Q H`` (``H`` symmetric positive definite), the limit of Newton's iteration
(Higham, *Functions of Matrices*, Sec. 8.3)::

    X₀ = M,   X_{k+1} = ½ (γ_k X_k + γ_k⁻¹ X_k⁻ᵀ),   γ_k = (‖X_k⁻¹‖_F / ‖X_k‖_F)^{1/2}

with ``X⁻ᵀ = cof(X) / det X`` in closed form. It converges quadratically (the
scaling ``γ_k`` speeds up the first steps from far away; it is dropped, ``γ = 1``,
once every matrix is within 10⁻² of its limit). The iteration stops after a step
that changes no entry by more than 10⁻⁹: by quadratic convergence that step's
result is then within about 10⁻¹⁸ of the limit, i.e. accurate to rounding, and it
agrees with :func:`~nlobs.navigation.so3.project_so3` to about 1e-15 on
well-conditioned matrices. Everything is elementwise on the nine entries, laid
out as nine contiguous arrays, in chunks that fit the cache.

Matrices for which the iteration is not the right tool — ``det M ≤ 10⁻⁶ (‖M‖_F/√3)³``
(reflections, near-singular matrices), non-finite ones, or no convergence within
``max_iter`` steps — are passed to :func:`~nlobs.navigation.so3.project_so3`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs.errors import DimensionError
from nlobs.navigation.so3 import project_so3


__all__ = ["nearest_rotation"]

#: Matrices per chunk (nine arrays of this length stay in the cache).
_CHUNK = 8192
#: Largest entrywise change of a step after which one more step is exact to rounding (quadratic convergence).
_TOL = 1e-9
#: Below this relative determinant a matrix goes to the SVD.
_DET_MIN = 1e-6


def nearest_rotation(M: ArrayLike, *, max_iter: int = 30, out: Array | None = None) -> Array:
    """The rotation nearest ``M`` in the Frobenius norm, batched (module docstring).

    Parameters
    ----------
    M : array_like, shape (..., 3, 3)
    max_iter : int
        Newton steps before a matrix is handed to the SVD.
    out : ndarray, shape (..., 3, 3), optional
        Where to write the result (e.g. a view into a larger record); a new array by default.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Equal to :func:`nlobs.navigation.so3.project_so3` of ``M`` to rounding (``out`` when given).

    Raises
    ------
    DimensionError
        ``M`` is not of shape ``(..., 3, 3)``, or ``out`` not of ``M``'s shape.
    """
    A = np.asarray(M, dtype=float)
    if A.ndim < 2 or A.shape[-2:] != (3, 3):
        raise DimensionError(f"nearest_rotation: M: expected shape (..., 3, 3), got {A.shape}")
    if out is None:
        out = np.empty(A.shape)
    elif out.shape != A.shape or out.dtype != np.float64:
        raise DimensionError(f"nearest_rotation: out: expected a float array of shape {A.shape}, got {out.shape}")
    flat = A.reshape(-1, 9)
    out_flat = out.view()
    try:
        out_flat.shape = (-1, 9)   # a view of out (no copy), or AttributeError
    except AttributeError:
        out_flat = None
    for s in range(0, flat.shape[0], _CHUNK):
        block = _chunk(flat[s:s + _CHUNK], max_iter)
        if out_flat is not None:
            out_flat[s:s + _CHUNK] = block
        else:  # an ``out`` whose matrices cannot be flattened in place: by index
            out[np.unravel_index(np.arange(s, s + block.shape[0]), A.shape[:-2])] = block.reshape(-1, 3, 3)
    return out


def _cofactors(X: Array) -> Array:
    """Cofactor matrices of the columns of ``X`` (``(9, n)``, row-major entries): ``cof(X) = det(X) X⁻ᵀ``."""
    x0, x1, x2, x3, x4, x5, x6, x7, x8 = X
    return np.stack([x4 * x8 - x5 * x7, x5 * x6 - x3 * x8, x3 * x7 - x4 * x6,
                     x2 * x7 - x1 * x8, x0 * x8 - x2 * x6, x1 * x6 - x0 * x7,
                     x1 * x5 - x2 * x4, x2 * x3 - x0 * x5, x0 * x4 - x1 * x3])


def _chunk(F: Array, max_iter: int) -> Array:
    """Newton's iteration on ``F`` (``(n, 9)``); members it does not suit go to the SVD."""
    X = F.T.copy()                                               # (9, n), never a view of the input
    with np.errstate(all="ignore"):
        C = _cofactors(X)
        det = X[0] * C[0] + X[1] * C[1] + X[2] * C[2]
        scale = np.sum(X * X, axis=0) / 3.0
        good = np.isfinite(det) & (det > _DET_MIN * scale * np.sqrt(scale))
    if not good.all():
        X[:, ~good] = np.eye(3).reshape(9, 1)                    # iterate on the identity, replaced below
        C[:, ~good] = X[:, ~good]
        det[~good] = 1.0
    scaled = True
    done = False
    for _ in range(max_iter):
        if scaled:
            g = np.sqrt(np.sqrt(np.sum(C * C, axis=0) / np.sum(X * X, axis=0)) / det)  # γ = (‖X⁻¹‖/‖X‖)^½
            Xn = 0.5 * (g * X + C / (g * det))
        else:
            Xn = 0.5 * (X + C / det)
        change = float(np.max(np.abs(Xn - X)))
        X = Xn
        if change <= _TOL:
            done = True
            break
        scaled = change > 1e-2
        C = _cofactors(X)
        det = X[0] * C[0] + X[1] * C[1] + X[2] * C[2]
    out = X.T.copy()
    redo = ~good if done else np.ones(good.shape, dtype=bool)
    if redo.any():
        out[redo] = project_so3(F[redo].reshape(-1, 3, 3)).reshape(-1, 9)
    return out
