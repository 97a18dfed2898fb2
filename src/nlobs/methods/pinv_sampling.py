r"""Röbenack's Moore–Penrose observer (7), (17) certified on the region, under sampled, noisy outputs.

Corollary 4.1 proves the observer convergent under global conditions (A2–A4, A6) nlobs does not check, for a
continuous, exact output. On the region, the observer ``x̂̇ = F(x̂, u) + l(x̂)(y − h(x̂))`` with the gain field
``l(x̂) = Q⁺(x̂) k`` (17) is a copy of the plant with a *state-dependent* output injection, and for an output
linear in ``x`` (``∂h/∂x = C``) its error obeys

.. math:: \dot e = \big(\bar J - l(\hat x)\, C\big) e ,

``J̄`` the mean-value Jacobian of ``F`` on the segment from ``x`` to ``x̂`` (:mod:`nlobs.geometry.jacobian_box`).
The matrix is affine in the entries of ``J̄`` and of ``l(x̂)`` separately, so with ``J̄`` in the Jacobian box and
``l(x̂)`` in a box of the gain field's values on the region, it lies in the convex hull of the matrices
``A_v − L_w C`` at the vertices of both boxes: the vertex LMIs (V) there prove ``V̇ ≤ −2αV`` while the state and
the estimate stay in the region, and the sampled-data bound of the output predictor follows with
``κ_j = max_w ‖P^{1/2} L_w[:, j]‖`` (:mod:`nlobs.methods.given_gain`). This is a *local* certificate of its own
(the vertex LMIs on the region), not Corollary 4.1.

It needs an output linear in ``x`` (else the product ``l(x̂) ∂h/∂x`` is not affine in the boxes' entries) and the
observer without saturation; otherwise, or when (V) or the sampling budget fails, the premise "sampled with
period ≤ T_max" says which and by how much.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from nlobs._typing import Array
from nlobs.checks import Check, CheckKind
from nlobs.errors import NonFiniteError
from nlobs.geometry.jacobian_box import jacobian_box
from nlobs.methods.problem import Problem
from nlobs.methods.sensor_design import error_box, input_range, output_rate_box
from nlobs.synthesis.certificate import CertificateMixin, checks_dict
from nlobs.synthesis.sampled_data import SampledDesignCertificate

__all__ = ["GainFieldCertificate", "pinv_sampling_bound"]

#: Most vertex matrices ``A_v − L_w C`` the LMIs (V) are written at.
MAX_PAIRS = 1024


@dataclass(frozen=True)
class GainFieldCertificate(CertificateMixin):
    """(V) for a state-dependent gain ``l(x̂)`` in a box: the Lyapunov matrix at every ``A_v − L_w C``.

    Attributes
    ----------
    continuous : ThauGainCertificate
        (V) at the vertex matrices ``(A_v − L_w C, C)`` with a zero gain (its ``decay``, ``P``, checks).
    gains : tuple of ndarray
        The vertices ``L_w`` of the gain field's box.
    gain : ndarray
        The box's centre (what is shown; the certificate holds for every gain of the box).
    """

    continuous: Any
    gains: tuple[Array, ...]
    gain: Array

    @property
    def P(self) -> Array:  # noqa: N802 - the paper's symbol
        """The Lyapunov matrix of (V)."""
        return np.asarray(self.continuous.P)

    @property
    def decay(self) -> float:
        """The decay rate ``P`` certifies, recomputed in NumPy."""
        return float(self.continuous.decay)

    @property
    def vertices(self) -> tuple[Any, ...]:
        """The vertex matrices ``(A_v − L_w C, C)``."""
        return tuple(self.continuous.vertices)

    @property
    def solver(self) -> Any:
        """The solver that found ``P``."""
        return self.continuous.solver

    @property
    def checks(self) -> tuple[Check, ...]:
        """(V)'s checks, recomputed."""
        return tuple(self.continuous.checks)

    def summary(self) -> str:
        """The gain box, the decay and the checks."""
        return (f"gain field l(x̂) in a box of {len(self.gains)} vertices (centre "
                f"{np.round(self.gain, 6).tolist()}); " + self.continuous.summary())

    def to_dict(self) -> dict[str, Any]:
        """The centre of the gain box, its vertices, ``P``, the decay and the checks."""
        return {"gain": np.asarray(self.gain).tolist(), "gain_vertices": [np.asarray(L).tolist() for L in self.gains],
                "P": self.P.tolist(), "decay": self.decay, "vertices": len(self.vertices),
                "verified": self.verified, "checks": checks_dict(self.checks)}


def pinv_sampling_bound(problem: Problem, observer: Any) -> tuple[SampledDesignCertificate | None, str, Check | None]:
    """The Moore–Penrose observer's certificate under the problem's sensors (module docstring).

    Parameters
    ----------
    problem : Problem
        With ``[sensors]``.
    observer : PinvObserver
        Its gain field ``gain_at(x)``.

    Returns
    -------
    (certificate or None, why, box check or None)
        The certificate (:class:`GainFieldCertificate` with the sampled-data bound) at the decay rate with the
        smallest certified RMS bound after the settling time, or ``None`` and why; and the premise stating the
        boxes it rests on.
    """
    from nlobs.methods.given_gain import certify_given_gain, effective_gain
    from nlobs.methods.kalman import measurement_covariance
    from nlobs.methods.sensor_design import alpha_grid

    if not problem.sensors:
        return None, "no [sensors]", None
    if getattr(observer, "saturation", None) is not None:
        return None, "the observer saturates its estimate (the certificate is for the plain observer (7))", None
    plant = problem.model.compile()
    n = problem.model.n
    lo, hi = input_range(problem)
    try:
        box = error_box(problem, plant)
        gbox = jacobian_box(lambda x, u: observer.gain_at(x), problem.region, lo, hi)
    except NonFiniteError as exc:
        return None, f"a Jacobian or the gain field is not finite on the region: {exc}", None
    if np.any(box.upper[n:] > box.lower[n:]):
        return None, ("h is not linear in x: the product of the gain field and ∂h/∂x is not affine in the boxes' "
                      "entries"), None
    C = box.center[n:]
    gains = tuple(np.asarray(L, dtype=float) for L in gbox.vertices())
    pairs = [(V[:n] - L @ C, C) for V in box.vertices() for L in gains]
    if len(pairs) > MAX_PAIRS:
        return None, (f"{box.n_vertices} Jacobian vertices × {len(gains)} gain vertices exceed the vertex LMIs' "
                      f"limit of {MAX_PAIRS}: give a smaller region"), None
    premise = Check.verdict("Jacobian and gain-field bounds on the region", True,
                            f"∂F/∂x and l(x̂) = Q⁺(x̂) k sampled at {box.samples} points of "
                            f"{problem.region.describe()} and the input range, each varying entry widened 5 %: "
                            f"{box.n_vertices} × {len(gains)} vertices", kind=CheckKind.FUNCTION_CLASS,
                            method="sampled", key="jacobian_box")
    grid = alpha_grid(box, n, problem)
    grid = tuple(float(a) for a in np.geomspace(grid[0] / 100, grid[-1], len(grid) + 4))  # slow decays too
    cert, why = certify_given_gain(problem, pairs, box, output_rate_box(problem, box, plant), plant,
                                   gain=np.zeros((n, problem.model.p)), grid=grid, settle=problem.settle,
                                   R=measurement_covariance(problem.model, problem.sensors),
                                   process=problem.process_noise, p0=problem.p0,
                                   effective=lambda P: effective_gain(P, gains, problem))
    if cert is None:
        return None, why, premise
    field = GainFieldCertificate(cert.continuous, gains, np.asarray(gbox.center, dtype=float))
    return SampledDesignCertificate(field, cert.bound), "", premise
