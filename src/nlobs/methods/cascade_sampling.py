r"""The cascade observer (9)–(10) of Grip, Saberi & Johansen certified under sampled, noisy outputs.

Theorem 1 certifies the cascade observer for a continuous, exact output through a small-gain argument
(LMI (14), ``‖H‖∞ < γ``, and Assumptions 1–3 of Σ₁'s observer). Under sensors nlobs certifies the same
observer another way, on the region, where the file's Σ₁ allows it.

**The augmented plant.** In the coordinates ``(x̂, ŵ, ẑ)``, ``ẑ = h(x̂) + ξ`` (9c), the observer reads
(with ``ξ̇`` of (9b), ``ẑ̇ = ∂h/∂x (f + g) + ξ̇ = L_f h(x̂) + K_z ỹ`` for an ``h`` of ``x`` alone)

.. math::

    \dot{\hat x} = f(\hat x, u) + g(\hat x, \hat z, u), \quad
    \dot{\hat w} = A\hat w + B_u u + B_z \hat z + K_w \tilde y, \quad
    \dot{\hat z} = L_f h(\hat x, u) + K_z \tilde y,

``ỹ = y − Cŵ − D_z ẑ − D_u u``: the copy of the *augmented plant* ``χ = (x, w, z)``,

.. math:: F_a(\chi, u) = \big(f(x, u) + g(x, z, u),\ A w + B_u u + B_z z,\ L_f h(x, u)\big),
          \qquad y = C w + D_z z + D_u u,

with the constant output injection ``L = [0; K_w; K_z]``. On the plant's own trajectories ``z = h(x)``,
``g(x, h(x), u) = 0`` (the injection vanishes at the truth), and ``F_a`` is the plant's motion: the cascade
observer *is* a Thau observer of ``F_a``. Its error obeys the vertex LMIs (V) of
:mod:`nlobs.synthesis.thau_gain` on the Jacobian box of ``F_a`` (:mod:`nlobs.geometry.jacobian_box`), and the
sampled-data bound of :mod:`nlobs.synthesis.sampled_data` applies through the output predictor. The
predictor the observer runs integrates the *plant's* output rate at ``(x̂, ŵ)``, so its discrepancy grows at
``L_F y(x̂, ŵ) − L_F y(x, w)``: ``ℓ_j`` is the plant's output-rate Lipschitz constant, with no ``z̃`` term.

**What it needs** (else no bound, and the premise says why): the cascade form (not the feedback form (2));
``h`` linear in ``x`` and free of ``u`` (then ``z̃₀ = ∂h/∂x x̃₀`` and the process noise reaches ``z`` as
``∂h/∂x`` times ``x``'s); ``g`` affine in ``z`` (the Jacobian of ``F_a`` does not depend on ``z``, so the box
holds wherever ``ẑ`` is, and the monitor's region of ``(x̂, ŵ)`` is all the certificate needs).

The gain ``K`` is the cascade design's (LMI (14), pole placement or the H2 gain); :func:`cascade_sampling_bound`
finds the Lyapunov matrix of (V) for it (:func:`~nlobs.synthesis.thau_gain.certify_thau_gain`) on a grid of
decay rates and keeps the smallest certified RMS bound after the settling time.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from nlobs._typing import Array
from nlobs.errors import DesignInfeasible, NonFiniteError
from nlobs.geometry.jacobian_box import JacobianBox, jacobian_box
from nlobs.geometry.region import Box
from nlobs.methods.problem import Problem
from nlobs.methods.sensor_design import alpha_grid, error_box, input_range, rate_jacobian, sensor_groups
from nlobs.synthesis.sampled_data import SampledDesignCertificate
from nlobs.systems.symbolic import SymbolicModel

__all__ = ["AugmentedCascade", "augmented_cascade", "cascade_sampling_bound", "plant_map"]


@dataclass(frozen=True, eq=False)
class AugmentedCascade:
    """The augmented plant ``χ = (x, w, z)`` of a cascade model and the view of the problem the bound reads.

    Attributes
    ----------
    model : SymbolicModel
        ``χ̇ = F_a(χ, u)``, ``y = C w + D_z z + D_u u`` (module docstring).
    region : Box
        The problem's region of ``(x, w)`` and the range of ``h`` on it for ``z``.
    gain : ndarray, shape (n_x + n_w + p_z, p)
        ``L = [0; K_w; K_z]``.
    process_noise : ndarray or None
        ``M Q Mᵀ``, ``M = [[I, 0], [0, I], [∂h/∂x, 0]]``.
    p0 : ndarray or None
        ``M P₀ Mᵀ`` of the file's initial error.
    sensors : tuple
        The problem's measurement groups (the outputs are the plant's).
    input_range : tuple of ndarray
        The problem's input range.
    """

    model: SymbolicModel
    region: Box
    gain: Array
    process_noise: Array | None
    p0: Array | None
    sensors: tuple[Any, ...]
    input_range: tuple[Array, Array]


def augmented_cascade(problem: Problem, design: Any) -> AugmentedCascade:
    """The augmented plant of the problem's cascade model and the design's gain (module docstring).

    Parameters
    ----------
    problem : Problem
        The model file's problem (its region, input, sensors, noise, initial error).
    design : CascadeDesign
        The cascade design with a gain.

    Returns
    -------
    AugmentedCascade

    Raises
    ------
    DesignInfeasible
        The file's Σ₁ is outside what the construction covers: the feedback form, an ``h`` that is not linear
        in ``x`` or depends on ``u``, a ``g`` that is not affine in ``z`` (the message says which).
    """
    cm = design.cascade
    if cm.feedback:
        raise DesignInfeasible("the feedback form (2) is not covered (h, f, g depend on w)", constraint="cascade form")
    if cm.expressions is None or design.certificate is None:
        raise DesignInfeasible("the cascade model has no symbolic Σ₁ or the design no gain", constraint="cascade form")
    f, h, g = (sp.Matrix(list(e)) for e in cm.expressions)
    s1, s2 = cm.sigma1, cm.sigma2
    X = sp.Matrix([sp.Symbol(n, real=True) for n in s1.states])
    Z = sp.Matrix([sp.Symbol(n, real=True) for n in s1.outputs])
    U = [sp.Symbol(n, real=True) for n in s1.inputs]
    W = sp.Matrix([sp.Symbol(n, real=True) for n in s2.states])
    params = {sp.Symbol(k, real=True): v for k, v in cm.parameters.items()}
    Hx = h.jacobian(X)
    moving = set(X) | set(U)
    if any(e.free_symbols & moving for e in Hx) or (U and any(e != 0 for e in h.jacobian(sp.Matrix(U)))):
        raise DesignInfeasible("h is not linear in x, or depends on u: the augmented plant's noise and initial error "
                               "are not constant maps of the plant's", constraint="h linear")
    Gz = g.jacobian(Z)
    if any(e.free_symbols & set(Z) for e in Gz):
        raise DesignInfeasible("g is not affine in z: the Jacobian box of the augmented plant would depend on ẑ, "
                               "which the region does not bound", constraint="g affine in z")

    def mat(M: Any) -> sp.Matrix:
        M = np.asarray(M, dtype=float)
        return sp.Matrix(M.shape[0], M.shape[1], [sp.Float(float(v)) for v in M.ravel()])

    Uv = sp.Matrix(U) if U else sp.zeros(0, 1)
    Bu = mat(s2.B_u) if s2.B_u is not None and U else sp.zeros(W.shape[0], len(U))
    Du = mat(s2.D_u) if s2.D_u is not None and U else sp.zeros(mat(s2.C).shape[0], len(U))
    rhs = [*(f + g), *(mat(s2.A) * W + mat(s2.B_z) * Z + (Bu * Uv if U else sp.zeros(W.shape[0], 1))),
           *(Hx * f)]
    out = list(mat(s2.C) * W + mat(s2.D_z) * Z + (Du * Uv if U else sp.zeros(mat(s2.C).shape[0], 1)))
    names = [*s1.states, *s2.states, *s1.outputs]
    model = SymbolicModel.general(names, list(s1.inputs), list(problem.model.outputs), rhs, out,
                                  parameters=dict(cm.parameters), name=f"{cm.name} (augmented)")
    Hn = _h_matrix(cm)
    h0 = np.array(h.subs({**params, **{x: 0 for x in X}}), dtype=float).reshape(-1)
    nx, nw, pz = len(s1.states), len(s2.states), len(s1.outputs)
    lo, hi = problem.region.lower[:nx], problem.region.upper[:nx]
    zlo = h0 + np.minimum(Hn * lo, Hn * hi).sum(axis=1)
    zhi = h0 + np.maximum(Hn * lo, Hn * hi).sum(axis=1)
    pad = 1e-6 * np.maximum(1.0, np.abs(zhi - zlo))
    region = Box(np.concatenate([problem.region.lower, zlo - pad]), np.concatenate([problem.region.upper, zhi + pad]))
    M = plant_map(design)
    K = np.asarray(design.certificate.gain, dtype=float)
    L = np.vstack([np.zeros((nx, K.shape[1])), K])
    Q = problem.process_noise
    p0 = problem.p0
    return AugmentedCascade(model, region, L, None if Q is None else M @ np.asarray(Q, dtype=float) @ M.T,
                            None if p0 is None else M @ p0 @ M.T, tuple(problem.sensors), problem.input_range)


def _h_matrix(cm: Any) -> Array:
    """``∂h/∂x`` of a cascade with ``h`` linear in ``x`` (its parameters substituted)."""
    _, h, _ = (sp.Matrix(list(e)) for e in cm.expressions)
    X = sp.Matrix([sp.Symbol(n, real=True) for n in cm.sigma1.states])
    params = {sp.Symbol(k, real=True): v for k, v in cm.parameters.items()}
    return np.array(h.jacobian(X).subs(params), dtype=float)


def plant_map(design: Any) -> Array:
    """``M = [[I, 0], [0, I], [∂h/∂x, 0]]``: the plant's error ``(x̃, w̃)`` into the augmented ``(x̃, w̃, z̃)``.

    Parameters
    ----------
    design : CascadeDesign
        Of a cascade whose ``h`` is linear in ``x`` (:func:`augmented_cascade` checks it).

    Returns
    -------
    ndarray, shape (n_x + n_w + p_z, n_x + n_w)
    """
    cm = design.cascade
    nx, nw, pz = len(cm.sigma1.states), len(cm.sigma2.states), len(cm.sigma1.outputs)
    M = np.zeros((nx + nw + pz, nx + nw))
    M[: nx + nw, : nx + nw] = np.eye(nx + nw)
    M[nx + nw:, :nx] = _h_matrix(cm)
    return M


@dataclass(frozen=True, eq=False)
class _View:
    """What :func:`~nlobs.methods.sensor_design.sensor_groups` and the boxes read of a problem, augmented."""

    model: Any
    region: Box
    sensors: tuple[Any, ...]
    process_noise: Array | None
    input_range: tuple[Array, Array]


def _rate_box(problem: Problem, aug: AugmentedCascade) -> JacobianBox:
    """The Jacobian of the predictor's rate ``L_F y(x̂, ŵ)`` (the plant's) over the augmented region, ``z`` columns 0."""
    plant = problem.model.compile()
    n, p = problem.model.n, problem.model.p
    nz = aug.model.n - n
    linear_h = True  # y = C w + D_z h(x) + D_u u with h linear in x
    rate = rate_jacobian(plant, n, p, linear_h)

    def jac(chi: Array, u: Array) -> Array:
        J = rate(np.ascontiguousarray(chi[:, :n]), u)
        return np.concatenate([J, np.zeros((J.shape[0], p, nz))], axis=2)

    lo, hi = input_range(problem)
    return jacobian_box(jac, aug.region, lo, hi)


def cascade_sampling_bound(problem: Problem, design: Any) -> tuple[SampledDesignCertificate | None, str]:
    """The cascade design's certificate under the problem's sensors, through the predictor (module docstring).

    Parameters
    ----------
    problem : Problem
        With ``[sensors]``.
    design : CascadeDesign
        With a verified gain.

    Returns
    -------
    (certificate or None, why)
        The Thau certificate of the augmented plant at the decay rate with the smallest certified RMS bound
        after the settling time, with its sampled-data bound (``certificate.bound``); ``None`` and the reason
        when the construction does not apply or no decay rate gives a verified bound.
    """
    from nlobs.methods.given_gain import certify_given_gain
    from nlobs.methods.kalman import measurement_covariance

    if not problem.sensors:
        return None, "no [sensors]"
    try:
        aug = augmented_cascade(problem, design)
        view = _View(aug.model, aug.region, aug.sensors, aug.process_noise, aug.input_range)
        plant = aug.model.compile()
        box = error_box(view, plant)  # type: ignore[arg-type]
        rate = _rate_box(problem, aug)
    except DesignInfeasible as exc:
        return None, str(exc)
    except NonFiniteError as exc:
        return None, f"a Jacobian of the augmented plant is not finite on the region: {exc}"
    if box.n_vertices > 1024:
        return None, (f"the augmented plant's Jacobian varies in {len(box.varying)} entries on the region: "
                      f"2^{len(box.varying)} vertices exceed the vertex LMIs' limit of 1024")
    n = aug.model.n
    pairs = [(V[:n], V[n:]) for V in box.vertices()]
    return certify_given_gain(view, pairs, box, rate, plant, gain=aug.gain, grid=alpha_grid(box, n, problem),
                              settle=problem.settle, R=measurement_covariance(problem.model, problem.sensors),
                              process=aug.process_noise, p0=aug.p0)
