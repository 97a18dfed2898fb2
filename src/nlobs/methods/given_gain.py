r"""A given gain (or gain field) certified under the problem's sensors: the vertex LMIs (V) and the sampled-data bound.

The Thau design of :mod:`nlobs.methods.sensor_design` chooses its gain; the cascade observer
(:mod:`nlobs.methods.cascade_sampling`) and the Moore–Penrose observer (:mod:`nlobs.methods.pinv_sampling`) come
with theirs. For an error ``ė = (J̄ − L(x̂) J̄_h) e`` whose matrices lie in the convex hull of vertices ``M_v``
(``J̄`` in a Jacobian box, ``L(x̂)`` in a box of the gain field's values, ``J̄_h = C`` constant), a Lyapunov
matrix ``P`` with ``M_vᵀP + P M_v + 2αP ⪯ 0`` at every vertex (:func:`~nlobs.synthesis.thau_gain.certify_thau_gain`
with the vertices ``(M_v, C)`` and a zero gain) proves ``V̇ ≤ −2αV``; through the output predictor the sampled
output adds ``L(x̂) δ``, bounded by ``κ_j = max_w ‖P^{1/2} L_w[:, j]‖`` over the gain's vertices (a norm is
convex: its maximum over the box is at a vertex). :func:`effective_gain` builds, per sensor group, a gain whose
``κ_j`` and noise terms are those maxima, so :func:`~nlobs.synthesis.sampled_data.sampled_data_bound` states the
bound for every gain of the box. :func:`certify_given_gain` tries the decay rates of a grid (up to the first
infeasible one after a feasible one: (V) feasible at ``α`` is feasible below it) and keeps the smallest certified
RMS bound after the settling time.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from nlobs._typing import Array
from nlobs.errors import DesignInfeasible, NlobsError
from nlobs.geometry.jacobian_box import JacobianBox
from nlobs.methods.sensor_design import output_indices, sensor_groups
from nlobs.synthesis.lmi import psd_sqrt
from nlobs.synthesis.sampled_data import SampledDesignCertificate, sampled_data_bound

__all__ = ["certify_given_gain", "effective_gain"]


def effective_gain(P: Array, gains: Sequence[Array], problem: Any) -> Array:
    """One gain whose noise terms bound those of every gain in ``gains``, per sensor group.

    For each group ``j`` (columns ``idx``) the vertex with the largest ``‖P^{1/2} L_w[:, idx]‖₂`` is taken, its
    columns scaled up so that ``tr(L_jᵀ P L_j R_j)`` and the bias term also reach their largest value over the
    vertices (both are quadratic in ``L_j``; the scale is 1 for a one-output group).

    Parameters
    ----------
    P : ndarray, shape (n, n)
        The Lyapunov matrix.
    gains : sequence of ndarray, each (n, p)
        The vertices of the gain's box.
    problem : Problem
        Its sensors (their outputs, noise covariance and bias).

    Returns
    -------
    ndarray, shape (n, p)
    """
    S = psd_sqrt(P)
    K = np.array(gains[0], dtype=float, copy=True)
    for g in problem.sensors:
        idx = list(output_indices(problem, g.outputs))
        R = np.asarray(g.covariance, dtype=float)
        bias = np.broadcast_to(np.asarray(g.bias, dtype=float), (len(idx),))

        def noise(L: Array) -> float:
            M = L[:, idx].T @ P @ L[:, idx]
            return float(np.trace(M @ R) + bias @ M @ bias)

        w = max(range(len(gains)), key=lambda i: float(np.linalg.norm(S @ gains[i][:, idx], 2)))
        top = max(noise(L) for L in gains)
        here = noise(gains[w])
        scale = math.sqrt(top / here) if here > 0 and top > here else 1.0
        K[:, idx] = scale * np.asarray(gains[w], dtype=float)[:, idx]
    return K


def certify_given_gain(view: Any, pairs: Sequence[tuple[Array, Array]], box: JacobianBox, rate: JacobianBox,
                       plant: Any, *, gain: Array, grid: Sequence[float], settle: float, R: Array | None,
                       process: Array | None, p0: Array | None,
                       effective: Callable[[Array], Array] | None = None) -> tuple[SampledDesignCertificate | None, str]:
    """The given gain's certificate under the sensors at the decay rate with the smallest certified RMS bound.

    Parameters
    ----------
    view : Problem or a view of one
        What :func:`~nlobs.methods.sensor_design.sensor_groups` reads: ``model`` (``n``, ``outputs``), ``sensors``,
        ``process_noise``, ``region``, ``input_range``.
    pairs : sequence of (ndarray, ndarray)
        The vertices ``(A_v, C_v)`` of (V) (with a gain field: ``(A_v − L_w C, C)`` and ``gain`` zero).
    box, rate : JacobianBox
        The error box (its output rows) and the predictor's output-rate box.
    plant : PlantModel
        The compiled model of ``view``.
    gain : ndarray, shape (n, p)
        ``L`` of (V).
    grid : sequence of float
        Decay rates, increasing.
    settle : float
        The time after which the RMS is bounded.
    R, process, p0 : ndarray or None
        The measurement covariance (for ``P``'s objective), ``W Wᵀ`` and the initial error's covariance.
    effective : callable, optional
        ``P ↦`` the gain of the bound's noise terms (default: ``gain``; a gain field: :func:`effective_gain`).

    Returns
    -------
    (certificate or None, why)
        The continuous certificate with its bound (``certificate.bound``), or ``None`` and why none.
    """
    from nlobs.synthesis.thau_gain import certify_thau_gain

    n = pairs[0][0].shape[0]
    worst = max(float(np.max(np.linalg.eigvals(A - gain @ C).real)) for A, C in pairs)
    why = (f"the vertex LMIs (V) on the region ({len(pairs)} vertices) have no Lyapunov matrix for the gain at any "
           f"decay rate tried (α = {grid[0]:.3g} … {grid[-1]:.3g})"
           + (f"; at a vertex the error matrix has an eigenvalue with real part {worst:.3g} > 0: give a smaller region"
              if worst >= 0 else ""))
    best: tuple[float, SampledDesignCertificate] | None = None
    closest: tuple[float, str] | None = None
    feasible = False
    for a in grid:
        try:
            cert = certify_thau_gain(pairs, gain, a, R=R, process=process)
        except (DesignInfeasible, NlobsError):
            if feasible:  # the frontier is passed
                break
            continue
        feasible = True
        if not cert.verified:
            why = "(V) failed its re-verification: " + "; ".join(c.summary() for c in cert.failed_checks)
            continue
        K = gain if effective is None else effective(cert.P)
        groups = sensor_groups(view, cert.P, K, box, rate, plant)
        bound = sampled_data_bound(cert.P, K, cert.decay, groups, process=process, p0=p0)
        if not bound.verified:
            if closest is None or bound.budget < closest[0]:
                closest = (bound.budget, bound.violation() or "the sampled-data bound failed")
            continue
        value = bound.rms_after(settle)
        if math.isfinite(value) and (best is None or value < best[0]):
            best = (value, SampledDesignCertificate(cert, bound))
    if best is None:
        return None, closest[1] if closest is not None else why
    assert n == best[1].P.shape[0]
    return best[1], ""
