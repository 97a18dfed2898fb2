r"""What the outputs cannot see: the generic rank of the observability codistribution and its kernel, named.

A model whose codistribution ``span{dL_f^k h_j : k < n}`` has generic rank ``ρ < n`` on a region is not
observable there: along the ``n − ρ`` directions of its kernel no output, and no derivative of one,
changes to first order. An observer that needs observability (drift-observability of Dalla Mora,
Germani & Manes, Röbenack's A1) does not exist there, and a Kalman filter's estimate of those
directions runs open loop (its covariance does not shrink along them). :func:`unobservable_directions`
decides the rank (:func:`nlobs.geometry.checks.observability_rank_evidence`, with its rounding-error
rule) and names a basis of the kernel at the point of that evidence: the basis is brought to reduced
row-echelon form, so a kernel along a state axis is named by the state (``"R"``), any other direction
by its components (``"0.707 S − 0.707 I"``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from nlobs.geometry.checks import observability_rank_evidence
from nlobs.geometry.observability import AffineFields
from nlobs.geometry.region import Box
from nlobs.systems.codegen import compile_matrix

__all__ = ["Unobservability", "linear_unobservable_directions", "unobservable_directions"]

#: A component of a kernel vector below this (after normalising its largest to 1) is taken as zero.
COMPONENT_TOL = 1e-6


@dataclass(frozen=True)
class Unobservability:
    """The generic rank of the observability codistribution on a region and the directions it misses.

    Attributes
    ----------
    rank : int or None
        The generic rank (``None``: undecided within the rounding error).
    n : int
        The number of states.
    directions : tuple of str
        A basis of the kernel at :attr:`point`, each named (empty when the rank is ``n`` or undecided).
    states : tuple of str
        The states that are unobservable on their own (a kernel direction along one state axis).
    point : tuple of float or None
        Where the kernel was computed.
    """

    rank: int | None
    n: int
    directions: tuple[str, ...] = ()
    states: tuple[str, ...] = ()
    point: tuple[float, ...] | None = None

    @property
    def observable(self) -> bool:
        """The generic rank is ``n`` (``False`` also when it is undecided)."""
        return self.rank == self.n

    def describe(self) -> str:
        """``"not observable from its outputs (generic rank 2 of n = 3); unobservable direction: R"``, or why."""
        if self.rank is None:
            return "the observability of the model from its outputs is undecided within the rounding error"
        if self.observable:
            return f"observable from its outputs (generic rank {self.rank} of n = {self.n})"
        what = "direction" if len(self.directions) == 1 else "directions"
        return (f"not observable from its outputs (generic rank {self.rank} of n = {self.n}); unobservable {what}: "
                + "; ".join(self.directions))


def _name(v: np.ndarray, states: Sequence[str]) -> str:
    terms = [(c, s) for c, s in zip(v, states) if abs(c) > COMPONENT_TOL]
    if len(terms) == 1:
        return terms[0][1]
    out = ""
    for c, s in terms:
        sign = "−" if c < 0 else "+"
        coef = "" if abs(abs(c) - 1.0) <= COMPONENT_TOL else f"{abs(c):.3g} "
        out += (f"{'-' if c < 0 else ''}" if not out else f" {sign} ") + f"{coef}{s}"
    return out


def _echelon(K: np.ndarray) -> np.ndarray:
    """Reduced row-echelon form of the rows of ``K`` (a kernel basis), each row scaled to largest entry 1."""
    A = np.array(K, dtype=float)
    rows, cols = A.shape
    r = 0
    for c in range(cols):
        if r >= rows:
            break
        p = r + int(np.argmax(np.abs(A[r:, c])))
        if abs(A[p, c]) <= COMPONENT_TOL:
            continue
        A[[r, p]] = A[[p, r]]
        A[r] /= A[r, c]
        for i in range(rows):
            if i != r:
                A[i] -= A[i, c] * A[r]
        r += 1
    A[np.abs(A) <= COMPONENT_TOL] = 0.0
    return A[:r]


def unobservable_directions(fields: AffineFields, region: Box | None = None, *, samples: int = 32,
                            seed: int = 0) -> Unobservability:
    """The generic rank of the observability codistribution on ``region`` and, when it is below ``n``, its kernel.

    Parameters
    ----------
    fields : AffineFields
        The model's ``f``, ``g``, ``h`` (:meth:`~nlobs.geometry.observability.AffineFields.from_model`).
    region : Box, optional
        Where the rank is decided (default ``[−1, 1]ⁿ``).
    samples, seed : int
        The sampled points of the rank's evidence.

    Returns
    -------
    Unobservability
    """
    ev = observability_rank_evidence(fields, region, samples=samples, seed=seed)
    n = fields.n
    if ev.rank is None or ev.rank >= n or ev.point is None:
        return Unobservability(ev.rank, n, point=ev.point)
    M = fields.codistribution([n] * fields.q, tidied=False)
    fn = compile_matrix(M, (tuple(fields.x),), what="the observability codistribution")
    x = np.asarray(ev.point, dtype=float)
    with np.errstate(all="ignore"):
        J = np.asarray(fn(x[None, :]), dtype=float)[0].reshape(M.shape)
    scales = np.asarray(ev.state_scales, dtype=float)
    scales = np.where(scales > 0, scales, 1.0)
    Js = np.where(np.isfinite(J), J, 0.0) * scales[None, :]
    norms = np.linalg.norm(Js, axis=1)
    Js = Js[norms > 0] / norms[norms > 0, None] if np.any(norms > 0) else np.zeros((1, n))
    _, _, vt = np.linalg.svd(Js if Js.shape[0] else np.zeros((1, n)))
    kernel = vt[ev.rank:] * scales[None, :]  # back from the scaled coordinates
    basis = _echelon(kernel / np.max(np.abs(kernel), axis=1, keepdims=True))
    names = tuple(_name(v / v[np.argmax(np.abs(v))], fields.states) for v in basis)
    single = tuple(nm for nm in names if nm in fields.states)
    return Unobservability(ev.rank, n, names, single, tuple(map(float, x)))


def linear_unobservable_directions(A: np.ndarray, C: np.ndarray, states: Sequence[str]) -> Unobservability:
    """The rank of the observability matrix ``[C; CA; …; CA^{n−1}]`` of a linear model and its kernel, named.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        The state matrix.
    C : ndarray, shape (p, n)
        The output matrix.
    states : sequence of str
        The state names.

    Returns
    -------
    Unobservability
        The rank decided with the tolerance ``max(shape) · ε · σ₁`` on the row-normalised matrix.
    """
    A = np.asarray(A, dtype=float)
    C = np.asarray(C, dtype=float)
    n = A.shape[0]
    rows, M = [], C
    for _ in range(n):
        rows.append(M)
        M = M @ A
    O = np.vstack(rows)
    norms = np.linalg.norm(O, axis=1)
    O = O[norms > 0] / norms[norms > 0, None] if np.any(norms > 0) else np.zeros((1, n))
    _, sv, vt = np.linalg.svd(O)
    tol = max(O.shape) * np.finfo(float).eps * (sv[0] if sv.size else 0.0)
    rank = int(np.sum(sv > tol))
    if rank >= n:
        return Unobservability(rank, n)
    basis = _echelon(vt[rank:] / np.max(np.abs(vt[rank:]), axis=1, keepdims=True))
    names = tuple(_name(v / v[np.argmax(np.abs(v))], states) for v in basis)
    return Unobservability(rank, n, names, tuple(nm for nm in names if nm in states), None)
