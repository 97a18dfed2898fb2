"""Algorithm 1 of Khajenejad & Yong on recorded measurements, and the containment of the truth in its balls.

:func:`run_setvalued` is a thin call of :func:`nlobs.simulate.run_observer` with
:class:`~nlobs.observers.setvalued.SetValuedObserver`; the functions below read its result.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray
from nlobs._validate import as_finite_array, as_vector
from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.observers.setvalued import GivenGain, Radii, SetValuedObserver
from nlobs.simulate.replay import run_observer
from nlobs.simulate.result import SimulationResult
from nlobs.synthesis.setvalued import SetValuedDesign
from nlobs.systems.discrete_ui import DiscreteUISystem

__all__ = ["input_containment", "input_estimates", "radii_of", "run_setvalued", "state_containment"]


def run_setvalued(system: DiscreteUISystem, design: SetValuedDesign | GivenGain, y: ArrayLike, *,
                  u: ArrayLike | None = None, x0_hat: ArrayLike | None = None,
                  radii: Radii | None = None, weights: ArrayLike | None = None, truth: ArrayLike | None = None,
                  progress: bool | None = None) -> SimulationResult:
    """Run Algorithm 1 on measurements ``y`` of shape ``(B, K + 1, l)`` (``y_0..y_K``), batched over ``B``.

    A thin call of :func:`nlobs.simulate.run_observer` with :class:`SetValuedObserver`.

    Parameters
    ----------
    system : DiscreteUISystem
    design : SetValuedDesign or GivenGain
        Gains from :func:`nlobs.synthesis.setvalued.design_setvalued` (or a given ``L̃``).
    y : array_like, shape (B, K + 1, l)
        Measurements (finite; NaN raises :class:`~nlobs.errors.NonFiniteError`).
    u : array_like, shape (B, K + 1, m), optional
        Known inputs (zero when omitted).
    x0_hat : array_like, shape (n,) or (B, n), optional
        Initial centre (``system.x0`` when omitted).
    radii : Radii, optional
        Radii to report (default: the sound recursion for a design, none for a :class:`GivenGain`).
    weights : array_like, shape (B, K + 1, N) or (K + 1, N), optional
        Run-time LPV weights ``λ_{i,k}`` (Class III, Definition 2.4): (13) uses ``f_{k−1}``. Required
        for a design certified at the LPV vertices (``lpv="vertices"``).
    truth : array_like, shape (B, K + 1, n), optional
        The true states, kept as the result's ``x``.
    progress : bool, optional
        Progress bar (see :func:`~nlobs.simulate.run_observer`).

    Returns
    -------
    SimulationResult
        ``x_hat`` the centres ``x̂_{k|k}`` ``(B, K + 1, n)``; extras ``d_hat`` ``(B, K + 1, p)`` (row ``k``
        holds ``d̂_{k−1}``, NaN at ``k = 0``), ``radius_state`` ``(K + 1,)``, ``radius_input`` ``(K + 1,)``
        (NaN at ``k = 0``); info ``radius_state_steady``, ``radius_input_steady``, ``radii`` (the label).
        See :func:`state_containment`, :func:`input_containment`, :func:`input_estimates`, :func:`radii_of`.

    Raises
    ------
    InvalidArgumentError
        ``design`` was certified for another system (:class:`~nlobs.synthesis.setvalued.CertifiedFor`),
        or is a vertex design run without ``weights``.
    """
    if isinstance(design, SetValuedDesign):
        design.certified_for.require(system, weights_given=weights is not None)
    y_ = as_finite_array("y", y)
    if y_.ndim != 3 or y_.shape[-1] != system.l or y_.shape[1] < 1:
        raise DimensionError(f"y: expected shape (B, K + 1, {system.l}), got {y_.shape}")
    Bn, K1, _ = y_.shape
    if radii is not None and radii.state.shape != (K1,):
        raise DimensionError(f"radii: expected {K1} state radii, got {radii.state.shape}")
    if u is None:
        u_ = np.zeros((Bn, K1, system.m))
    else:
        u_ = as_finite_array("u", u)
        if u_.shape != (Bn, K1, system.m):
            raise DimensionError(f"u: expected shape {(Bn, K1, system.m)}, got {u_.shape}")
    if weights is not None:
        lw = system.lpv_weights(weights)
        u_ = np.concatenate([u_, np.broadcast_to(lw, (Bn, K1, lw.shape[-1]))], axis=-1)
    if x0_hat is None:
        xh = np.broadcast_to(system.x0, (Bn, system.n)).copy()
    else:
        x0a = as_finite_array("x0_hat", x0_hat)
        if x0a.ndim == 1:
            x0a = as_vector("x0_hat", x0a, system.n)
        xh = np.broadcast_to(x0a, (Bn, system.n)).copy()
    obs = SetValuedObserver(system, design, radii=radii, lpv_weights=weights is not None)
    t = np.arange(K1) * system.time.dt
    names = tuple(f"x{i + 1}" for i in range(system.n))
    res = run_observer(obs, t, x_hat0=xh, u=u_, y=y_, truth=truth, states=names, estimates=names,
                       outputs=tuple(f"y{i + 1}" for i in range(system.l)), progress=progress)
    rad = radii if radii is not None else (
        None if obs._rec is None else Radii(res.extras["radius_state"], res.extras["radius_input"][1:],
                                            *obs._rec.steady(), "sound"))
    info = dict(res.info)
    if rad is not None:
        info.update(radius_state_steady=rad.state_steady, radius_input_steady=rad.input_steady, radii=rad.label)
    extras = dict(res.extras)
    if rad is None:
        extras.pop("radius_state", None)
        extras.pop("radius_input", None)
    return dataclasses.replace(res, info=info, extras=extras)


def radii_of(result: SimulationResult) -> Radii | None:
    """The :class:`Radii` of a :func:`run_setvalued` result (``None`` when it has none)."""
    if "radius_state" not in result.extras:
        return None
    info = result.info
    return Radii(result.extras["radius_state"], result.extras["radius_input"][1:],
                 float(info.get("radius_state_steady", math.nan)), float(info.get("radius_input_steady", math.nan)),
                 str(info.get("radii", "")))


def input_estimates(result: SimulationResult) -> Array:
    """Centres ``d̂_{k−1}`` of the input balls, ``k = 1..K``, shape ``(B, K, p)`` (index ``j`` holds ``d̂_j``)."""
    return result.extras["d_hat"][:, 1:]


def _radii_or_fail(result: SimulationResult, what: str) -> Radii:
    rad = radii_of(result)
    if rad is None:
        raise InvalidArgumentError(f"{what}: this run has no radii")
    return rad


def state_containment(result: SimulationResult, x_true: ArrayLike | None = None, rtol: float = 1e-9) -> BoolArray:
    """``(B, K + 1)``: ``‖x_k − x̂_{k|k}‖ ≤ δˣ_k`` (with a relative round-off allowance); truth default ``result.x``."""
    rad = _radii_or_fail(result, "state_containment")
    x = result.x if x_true is None else np.asarray(x_true)
    if x is None:
        raise InvalidArgumentError("state_containment: no truth given")
    e = np.linalg.norm(np.asarray(x) - result.x_hat, axis=-1)
    return e <= rad.state * (1 + rtol) + rtol


def input_containment(result: SimulationResult, d_true: ArrayLike, rtol: float = 1e-9) -> BoolArray:
    """``(B, K)``: ``‖d_{k−1} − d̂_{k−1}‖ ≤ δᵈ_{k−1}`` for ``d_true`` of shape ``(B, K, p)`` (``d_0..d_{K−1}``)."""
    rad = _radii_or_fail(result, "input_containment")
    e = np.linalg.norm(np.asarray(d_true) - input_estimates(result), axis=-1)
    return e <= rad.input * (1 + rtol) + rtol
