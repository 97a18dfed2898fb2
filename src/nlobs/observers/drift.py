r"""The drift-observability observer of Dalla Mora, Germani & Manes (seed 002).

For an input-affine model ``ẋ = f(x) + g(x) u``, ``y = h(x)`` (1.1) that is
drift-observable with multi-index ``s`` (Def. 2.3: ``Φ_s`` a diffeomorphism,
``Q_s = ∂Φ_s/∂x`` nonsingular), the observer is (3.1)

.. math:: \dot{\hat x} = f(\hat x) + g(\hat x) u + Q_s(\hat x)^{-1} K (y − h(\hat x)).

In ``z = Φ_s(x)`` coordinates it is the high-gain observer (3.4) of the Brunovsky
form (2.15), and the error obeys (3.5). With ``(K, P)`` solving (2.17)
(:mod:`nlobs.synthesis.drift_gain`) and ``‖u‖ ≤ μ``, Theorem 3.1 gives (3.2)

.. math:: ‖x(t) − \hat x(t)‖ ≤ κ_1 e^{−αt} ‖x(0) − \hat x(0)‖ + κ_2 \sqrt{b_L² + b_H²},

with (3.17), read from the proof (3.15)–(3.16) (the scan drops the square root):
``κ₁ = γ_Φ γ_{Φ⁻¹} √cn(P)`` and ``κ₂ = γ_{Φ⁻¹} √(‖P‖ / (2α))``, where ``γ_Φ`` and
``γ_{Φ⁻¹}`` are the Lipschitz constants of ``Φ_s`` and ``Φ_s⁻¹`` (3.3).

Implementation
--------------
* ``f``, ``g``, ``h`` and ``Q_s`` are compiled once into one batched NumPy callable
  (:func:`nlobs.systems.codegen.compile_matrix`, with common subexpressions shared);
  the observer never calls SymPy while it runs.
* ``Q_s(x̂)⁻¹ K (y − h(x̂))`` is a batched linear solve (:func:`numpy.linalg.solve`),
  never a symbolic inverse.
* Singular ``Q_s``: :meth:`DriftObserver.init` checks ``σ_min(Q_s)/σ_max(Q_s)`` at
  the initial estimate; :meth:`DriftObserver.rhs` raises when the solve fails or
  when the cheap lower bound ``‖Q_s‖_F ‖c‖ / (√n ‖b‖) ≤ cond(Q_s)`` (``c`` the
  solution of ``Q_s c = b``, ``b = K ỹ``) exceeds ``cond_limit`` — it is large exactly
  when the solve amplified the correction, and costs two norms instead of an SVD.
  Both raise :class:`SingularObservabilityError` naming the model, ``Q_s``, the
  point and the time — unless the user switches on the Tikhonov regularisation
  ``regularization = ε > 0``, which replaces ``Q_s⁻¹`` by
  ``(Q_sᵀQ_s + ε² I)⁻¹ Q_sᵀ`` everywhere (a smooth vector field; it equals
  ``Q_s⁻¹`` up to a relative ``ε²/σ_min²`` where ``Q_s`` is well conditioned, and
  stays bounded by ``1/(2ε)`` where it is singular; the convergence theorems do
  not cover it there).

Error-bound constants: :func:`lipschitz_estimates` samples ``‖Q_s‖₂`` and
``‖Q_s⁻¹‖₂`` on a region (their maxima estimate ``γ_Φ`` on a convex region and
``γ_{Φ⁻¹}`` on ``Φ_s`` of it — estimates from below of the suprema, and the second
needs ``Φ_s(region)`` convex or a path argument), and the Lipschitz constants
``γ_L``, ``γ_H`` of ``L_s∘Φ_s⁻¹`` and ``H_{s,r}∘Φ_s⁻¹`` from their ``z``-Jacobians
``(∂L_s/∂x) Q_s⁻¹``; :func:`error_bound_constants` turns them into ``κ₁``, ``κ₂``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_batch, as_matrix, positive
from nlobs.errors import InvalidArgumentError, NlobsError, NonFiniteError
from nlobs.geometry import (
    AffineFields,
    Box,
    Check,
    check_drift_observability,
    check_s_le_r,
    default_multi_index,
    input_gain_structure,
    observability_jacobian,
    observation_relative_degree,
    output_derivative_terms,
)
from nlobs.geometry.observability import check_multi_index
from nlobs.synthesis.drift_gain import DriftGainCertificate, RiccatiConstants, design_drift_gain
from nlobs.systems.codegen import BatchedFunction, compile_matrix
from nlobs.systems.symbolic import SymbolicModel
from nlobs.systems.timebase import CONTINUOUS, TimeBase

Array = NDArray[np.float64]

__all__ = [
    "DriftDesignReport",
    "DriftObserver",
    "ErrorBoundConstants",
    "LipschitzEstimates",
    "SingularObservabilityError",
    "design_drift_report",
    "error_bound_constants",
    "lipschitz_estimates",
]

#: Default largest accepted condition number of ``Q_s`` (above it ``Q_s`` counts as singular).
COND_LIMIT = 1e10
#: A given ``γ`` counts as below the sampled estimate when smaller by more than this relative amount.
_GAMMA_RTOL = 1e-9


class SingularObservabilityError(NlobsError, ValueError):
    """``Q_s`` is singular (or too ill-conditioned to invert) where the observer needs it.

    Attributes
    ----------
    model : str
    quantity : str
        ``"Q_s"`` with the multi-index.
    point : tuple of float
        The estimate ``x̂`` at which it happened.
    time : float or None
        Simulation time (``None`` at the initial estimate).
    condition : float
        ``cond(Q_s)`` there (or the lower bound that tripped; ``inf`` when exactly singular).
    """

    def __init__(self, model: str, quantity: str, point: Sequence[float], time: float | None, condition: float,
                 names: Sequence[str] | None = None) -> None:
        self.model = model
        self.quantity = quantity
        self.point = tuple(float(v) for v in point)
        self.time = time
        self.condition = float(condition)
        labels = names if names is not None and len(names) == len(self.point) else [f"x{i + 1}" for i in range(len(self.point))]
        pt = ", ".join(f"{k}={v:.6g}" for k, v in zip(labels, self.point))
        when = "at the initial estimate" if time is None else f"at t={time:g}"
        super().__init__(
            f"{model}: {quantity} is singular {when}, x̂ = ({pt}) (cond = {self.condition:.3g}); "
            "the drift-observability observer (3.1) needs Q_s(x̂) invertible: start the estimate where "
            "Φ_s is a local diffeomorphism, choose another multi-index s, or switch on "
            "regularization=ε (Tikhonov, documented in nlobs.observers.drift)"
        )


def _condition(Qf: Array) -> Array:
    """``σ_max/σ_min`` of each matrix of a stack ``(k, n, n)`` by SVD; ``inf`` where singular or not finite."""
    finite = np.all(np.isfinite(Qf), axis=(-2, -1))
    with np.errstate(all="ignore"):
        sv = np.linalg.svd(np.where(finite[:, None, None], Qf, 0.0), compute_uv=False)
    smin = sv[:, -1]
    return np.where(finite & (smin > 0), sv[:, 0] / np.where(smin > 0, smin, 1.0), np.inf)


# --------------------------------------------------------------------------- observer


@dataclass(frozen=True, eq=False)
class DriftObserver:
    """Observer (3.1) ``x̂' = f(x̂) + g(x̂) u + Q_s(x̂)⁻¹ K (y − h(x̂))``; satisfies :class:`~nlobs.observers.base.Observer`.

    Build with :meth:`from_model` (or :meth:`from_fields`). The observer holds no state.

    Attributes
    ----------
    name : str
        The model's name (used in error messages).
    s : tuple of int
        Multi-index (``Σ s_j = n``).
    K : ndarray, shape (n, q)
        Output-injection gain in ``z``-coordinates (e.g. from
        :func:`nlobs.synthesis.drift_gain.design_drift_gain`).
    regularization : float
        Tikhonov ``ε`` (0: exact solve, errors where ``Q_s`` is singular).
    cond_limit : float
        ``cond(Q_s)`` above which ``Q_s`` counts as singular (without regularisation).
    states : tuple of str
    state_names : tuple of str
        ``"<state>_hat"``.
    time : Continuous
    """

    name: str
    s: tuple[int, ...]
    K: Array
    states: tuple[str, ...]
    n_inputs: int
    n_outputs: int
    _fn: BatchedFunction
    regularization: float = 0.0
    cond_limit: float = COND_LIMIT
    time: TimeBase = field(default=CONTINUOUS)
    state_names: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        n, q = len(self.states), self.n_outputs
        if sum(self.s) != n or len(self.s) != q:
            raise InvalidArgumentError(f"{self.name}: multi-index s={list(self.s)} must have {q} entries summing to n = {n}")
        K = as_matrix("K", self.K, (n, q)).copy()
        K.setflags(write=False)
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "regularization", positive("regularization", self.regularization, allow_zero=True))
        object.__setattr__(self, "cond_limit", positive("cond_limit", self.cond_limit))
        object.__setattr__(self, "state_names", tuple(f"{x}_hat" for x in self.states))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_fields(cls, fields: AffineFields, s: Sequence[int], K: ArrayLike, *, regularization: float = 0.0,
                    cond_limit: float = COND_LIMIT) -> DriftObserver:
        """Compile ``f, g, h, Q_s`` of ``fields`` once and build the observer."""
        s_ = check_multi_index(s, fields.q, fields.n)
        Q = observability_jacobian(fields, s_)
        m, q = fields.m, fields.q
        entries = list(fields.f) + list(fields.g) + list(fields.h) + list(Q)
        fn = compile_matrix(sp.Matrix(entries) if entries else sp.zeros(0, 1), (fields.x,), vector=True,
                            what=f"{fields.name}: f, g, h, Q_s")
        return cls(fields.name, s_, np.asarray(K, dtype=float), fields.states, m, q, fn,
                   regularization=regularization, cond_limit=cond_limit)

    @classmethod
    def from_model(cls, model: SymbolicModel, K: ArrayLike, s: Sequence[int] | None = None, *,
                   parameters: Mapping[str, float] | None = None, regularization: float = 0.0,
                   cond_limit: float = COND_LIMIT, region: Box | None = None) -> DriftObserver:
        """Observer (3.1) for an input-affine :class:`SymbolicModel` (``s`` defaults to the observability indices).

        Raises
        ------
        ModelError
            The model is not input-affine (or is discrete-time, or ``h`` depends on ``u``).
        InvalidArgumentError
            ``s`` does not sum to ``n``.
        """
        fields = AffineFields.from_model(model, parameters)
        s_ = default_multi_index(fields, region) if s is None else s
        return cls.from_fields(fields, s_, K, regularization=regularization, cond_limit=cond_limit)

    # ------------------------------------------------------------------ protocol
    @property
    def n_z(self) -> int:
        return len(self.states)

    @property
    def n_x(self) -> int:
        return len(self.states)

    def _parts(self, x: Array) -> tuple[Array, Array, Array, Array]:
        n, m, q = self.n_x, self.n_inputs, self.n_outputs
        v = self._fn(x)
        i = 0
        f = v[..., i : i + n]
        i += n
        g = v[..., i : i + n * m].reshape(*v.shape[:-1], n, m)
        i += n * m
        h = v[..., i : i + q]
        i += q
        Q = v[..., i : i + n * n].reshape(*v.shape[:-1], n, n)
        return f, g, h, Q

    def jacobian_Q(self, x_hat: ArrayLike) -> Array:
        """``Q_s(x̂)``, shape ``(..., n, n)`` (compiled)."""
        return self._parts(as_batch("x_hat", x_hat, self.n_x))[3]

    def _singular(self, Q: Array, x: Array, t: float | None, cond: Array | None = None) -> SingularObservabilityError:
        xf = x.reshape(-1, self.n_x)
        if cond is None:
            cond = _condition(Q.reshape(-1, self.n_x, self.n_x))
        cond = np.asarray(cond).reshape(-1)
        i = int(np.argmax(cond))
        return SingularObservabilityError(self.name, f"Q_s (s = {list(self.s)})", xf[i], t, float(cond[i]), self.states)

    def init(self, x_hat0: ArrayLike) -> Array:
        """Observer state ``x̂(0)``, shape ``(..., n)``; checks ``Q_s(x̂(0))`` is invertible.

        Raises
        ------
        SingularObservabilityError
            ``cond(Q_s(x̂(0))) > cond_limit`` (or not finite) and no regularisation is on.
        """
        x = np.array(as_batch("x_hat0", x_hat0, self.n_x), dtype=float)
        if self.regularization == 0.0:
            Q = self._parts(x)[3]
            cond = _condition(Q.reshape(-1, self.n_x, self.n_x))
            if np.any(cond > self.cond_limit):
                raise self._singular(Q, x, None, cond)
        return x

    def correction(self, t: float, x_hat: Array, innovation: Array, Q: Array) -> Array:
        """``Q_s(x̂)⁻¹ K ỹ`` (or its Tikhonov-regularised form) by a batched linear solve."""
        b = innovation @ self.K.T  # (..., n)
        eps = self.regularization
        if eps > 0.0:
            Qt = np.swapaxes(Q, -1, -2)
            A = Qt @ Q + (eps * eps) * np.eye(self.n_x)
            return np.linalg.solve(A, (Qt @ b[..., None]))[..., 0]
        try:
            c = np.linalg.solve(Q, b[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise self._singular(Q, x_hat, t) from None
        # cond(Q) ≥ ‖Q‖₂‖c‖/‖b‖ ≥ ‖Q‖_F ‖c‖ / (√n ‖b‖): a cheap lower bound, large only when the solve amplified
        nb = np.linalg.norm(b, axis=-1)
        lower = np.linalg.norm(Q, axis=(-2, -1)) * np.linalg.norm(c, axis=-1) / (math.sqrt(self.n_x) * np.maximum(nb, 1e-300))
        bad = ~np.isfinite(c).all(axis=-1) | ((lower > self.cond_limit) & (nb > 0))
        if np.any(bad):
            raise self._singular(Q, x_hat, t)
        return c

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``x̂' = f(x̂) + g(x̂) u + Q_s(x̂)⁻¹ K (y − h(x̂))`` (3.1) for batches ``(..., n)``."""
        f, g, h, Q = self._parts(z)
        drift = f if self.n_inputs == 0 else f + np.einsum("...ij,...j->...i", g, np.asarray(u, dtype=float))
        return drift + self.correction(t, z, np.asarray(y, dtype=float) - h, Q)

    def estimate(self, z: Array) -> Array:
        """The estimate is the observer state, ``x̂ = z``."""
        return z


# --------------------------------------------------------------------------- constants


@dataclass(frozen=True)
class LipschitzEstimates:
    """Sampled estimates of the constants of (3.3) and Assumption H1 on a region.

    All are maxima over ``samples`` seeded points of the region (estimates from below
    of the suprema; the mean-value argument needs a convex region, and ``Φ_s(region)``
    convex for the ``z``-side constants).

    Attributes
    ----------
    gamma_phi : float
        ``max ‖Q_s(x)‖₂`` — Lipschitz constant of ``Φ_s`` (``‖e_z‖ ≤ γ_Φ ‖e_x‖``).
    gamma_phi_inv : float
        ``max ‖Q_s(x)⁻¹‖₂`` — Lipschitz constant of ``Φ_s⁻¹`` (``‖e_x‖ ≤ γ_{Φ⁻¹} ‖e_z‖``).
    gamma_L : float
        ``max ‖(∂L_s/∂x) Q_s⁻¹‖₂`` — Lipschitz constant of ``L_s∘Φ_s⁻¹`` (2.14).
    gamma_H : float
        ``max (Σ_entries ‖(∂H_{ik}/∂x) Q_s⁻¹‖²)^{1/2}`` — Lipschitz constant of
        ``H_{s,r}∘Φ_s⁻¹`` in the operator norm (Frobenius bound); 0 when ``H`` is constant.
    region : Box
    samples : int
    worst_Q_inv : tuple of float
        Where ``‖Q_s⁻¹‖`` is largest.
    """

    gamma_phi: float
    gamma_phi_inv: float
    gamma_L: float
    gamma_H: float
    region: Box
    samples: int
    worst_Q_inv: tuple[float, ...]

    @property
    def gamma(self) -> float:
        """``√(γ_L² + γ_H²)``, the ``γ`` of (2.17)."""
        return math.hypot(self.gamma_L, self.gamma_H)

    def to_dict(self) -> dict[str, Any]:
        return {"gamma_phi": self.gamma_phi, "gamma_phi_inv": self.gamma_phi_inv, "gamma_L": self.gamma_L,
                "gamma_H": self.gamma_H, "gamma": self.gamma, "region": [self.region.lower.tolist(), self.region.upper.tolist()],
                "samples": self.samples, "worst_Q_inv": list(self.worst_Q_inv), "estimated": True}


def lipschitz_estimates(fields: AffineFields, s: Sequence[int], r: Sequence[int | None], region: Box, *,
                        samples: int = 2000, seed: int = 0) -> LipschitzEstimates:
    """Estimate ``γ_Φ``, ``γ_{Φ⁻¹}``, ``γ_L``, ``γ_H`` by sampling ``region`` (see :class:`LipschitzEstimates`).

    Points where any of the sampled quantities is not finite are left out (``samples`` counts the rest).

    Raises
    ------
    NonFiniteError
        Not one sampled point gives finite values (the model is not defined on the region).
    """
    s_ = check_multi_index(s, fields.q, fields.n)
    Q = observability_jacobian(fields, s_)
    X = sp.Matrix(fields.x)
    dL = output_derivative_terms(fields, s_).jacobian(X)
    H, _ = input_gain_structure(fields, s_, r)
    dH = sp.Matrix(list(H)).jacobian(X) if H.shape[0] * H.shape[1] else sp.zeros(0, fields.n)
    n = fields.n
    fn = compile_matrix(sp.Matrix(list(Q) + list(dL) + list(dH)), (fields.x,), vector=True, what="Lipschitz estimates")
    pts = region.sample(samples, seed)
    with np.errstate(all="ignore"):
        v = fn(pts)
    Qv = v[:, : n * n].reshape(-1, n, n)
    dLv = v[:, n * n : n * n + dL.shape[0] * n].reshape(len(v), dL.shape[0], n)
    dHv = v[:, n * n + dL.shape[0] * n :].reshape(len(v), dH.shape[0], n)
    ok = np.all(np.isfinite(v), axis=-1)
    if not np.any(ok):
        raise NonFiniteError(
            f"{fields.name}: Q_s (s = {list(s_)}) and the z-Jacobians of L_s and H_s,r are not finite at any of the "
            f"{len(pts)} sampled points of the region {region.describe()}: the model is not defined there "
            "(choose a region where it is, e.g. --box)")
    sv = np.linalg.svd(Qv[ok], compute_uv=False)
    inv_norm = np.where(sv[:, -1] > 0, 1.0 / np.where(sv[:, -1] > 0, sv[:, -1], 1.0), np.inf)
    Qinv = np.linalg.pinv(Qv[ok])
    gL = np.linalg.norm(dLv[ok] @ Qinv, ord=2, axis=(-2, -1)) if dL.shape[0] else np.zeros(1)
    gH = np.linalg.norm(dHv[ok] @ Qinv, axis=(-2, -1)) if dH.shape[0] else np.zeros(1)
    i = int(np.argmax(inv_norm))
    return LipschitzEstimates(float(sv[:, 0].max()), float(inv_norm[i]), float(np.max(gL)), float(np.max(gH)),
                              region, int(ok.sum()), tuple(float(a) for a in pts[ok][i]))


@dataclass(frozen=True)
class ErrorBoundConstants:
    """``κ₁ = γ_Φ γ_{Φ⁻¹} √cn(P)``, ``κ₂ = γ_{Φ⁻¹} √(‖P‖/(2α))`` of (3.17), from (3.15)–(3.16).

    Valid (Theorem 3.1 / 3.8) when ``(K, P)`` solves (2.17) with ``γ ≥ √(γ_L² + γ_H²)``,
    ``‖u‖ ≤ μ``, and the trajectories stay where the Lipschitz constants hold; with
    sampled constants the bound is an estimate.
    """

    gamma_phi: float
    gamma_phi_inv: float
    cond_P: float
    norm_P: float
    alpha: float
    kappa1: float
    kappa2: float
    estimated: bool

    def bound(self, t: ArrayLike, e0_norm: float | ArrayLike, b: float = 0.0) -> Array:
        """``κ₁ e^{−αt} ‖e(0)‖ + κ₂ b`` (3.2), with ``b = √(b_L² + b_H²)`` (0 under H1)."""
        tt = np.asarray(t, dtype=float)
        return self.kappa1 * np.exp(-self.alpha * tt) * np.asarray(e0_norm, dtype=float)[..., None] + self.kappa2 * b

    def describe(self) -> str:
        src = "estimated by sampling" if self.estimated else "given"
        return (f"κ₁ = γ_Φ γ_Φ⁻¹ √cn(P) = {self.gamma_phi:.4g} · {self.gamma_phi_inv:.4g} · √{self.cond_P:.4g} = {self.kappa1:.4g}; "
                f"κ₂ = γ_Φ⁻¹ √(‖P‖/2α) = {self.kappa2:.4g} (Lipschitz constants {src})")

    def to_dict(self) -> dict[str, Any]:
        return {"gamma_phi": self.gamma_phi, "gamma_phi_inv": self.gamma_phi_inv, "cond_P": self.cond_P,
                "norm_P": self.norm_P, "alpha": self.alpha, "kappa1": self.kappa1, "kappa2": self.kappa2,
                "estimated": self.estimated}


def error_bound_constants(cert: DriftGainCertificate, gamma_phi: float, gamma_phi_inv: float, *,
                          estimated: bool = True) -> ErrorBoundConstants:
    """``κ₁``, ``κ₂`` of (3.17) for a verified pair and the Lipschitz constants of ``Φ_s``, ``Φ_s⁻¹``."""
    gp = positive("gamma_phi", gamma_phi)
    gpi = positive("gamma_phi_inv", gamma_phi_inv)
    cn, nP, a = cert.cond_P, cert.norm_P, cert.constants.alpha
    return ErrorBoundConstants(gp, gpi, cn, nP, a, gp * gpi * math.sqrt(cn), gpi * math.sqrt(nP / (2.0 * a)), estimated)


# --------------------------------------------------------------------------- report for the CLI


@dataclass(frozen=True, eq=False)
class DriftDesignReport:
    """Everything ``nlobs design drift`` prints: structure, checks, gain, verification, bound constants.

    Attributes
    ----------
    fields : AffineFields
    s, r : tuple
        Multi-index and observation relative degrees (``None``: undefined on the region).
    checks : tuple of Check
        Drift-observability on the region and ``s ≤ r``.
    F : ndarray
        ``F_{s,r}`` (2.12).
    H : str
        ``H_{s,r}(x)`` (2.11), as text.
    gamma : float
        ``γ`` used in (2.17).
    gamma_source : str
        ``"given"`` or ``"estimated"`` (``√(γ_L² + γ_H²)`` from :attr:`lipschitz`).
    certificate : DriftGainCertificate
    lipschitz : LipschitzEstimates
    bound : ErrorBoundConstants
    region : Box

    The verdict (:attr:`usable`, with :attr:`reasons`) collects the premises of Theorem 3.1
    that the report can check: drift-observability on the region, the certificate of
    (2.17), and ``γ`` not below the sampled ``√(γ_L² + γ_H²)`` (the sampled values are
    attained, so a ``γ`` below them is too small for the region: :attr:`warnings`). The
    gain's own certificate may be verified while the design is not usable.
    """

    fields: AffineFields
    s: tuple[int, ...]
    r: tuple[int | None, ...]
    checks: tuple[Check, ...]
    F: Array
    H: str
    gamma: float
    gamma_source: str
    certificate: DriftGainCertificate
    lipschitz: LipschitzEstimates
    bound: ErrorBoundConstants
    region: Box

    @property
    def model(self) -> str:
        return self.fields.name

    @property
    def drift_check(self) -> Check:
        """The drift-observability check on the region (Def. 2.3: ``Q_s`` nonsingular)."""
        return next(k for k in self.checks if k.name == "drift-observability")

    @property
    def warnings(self) -> tuple[str, ...]:
        """A given ``γ`` below the sampled estimate on the region (the certificate does not cover the model there)."""
        est = self.lipschitz.gamma
        if self.gamma < est * (1.0 - _GAMMA_RTOL):
            return (f"γ = {self.gamma:.4g} ({self.gamma_source}) is below the sampled √(γ_L² + γ_H²) = {est:.4g} on the "
                    "region: the certificate of (2.17) does not cover the model there (raise γ or shrink the region)",)
        return ()

    @property
    def reasons(self) -> tuple[str, ...]:
        """Why the design is not usable (empty when it is): failed premises, a failed certificate, :attr:`warnings`."""
        out = []
        drift = self.drift_check
        if not drift.passed:
            out.append(f"drift-observability fails on the region ({drift.evidence}): Theorem 3.1 does not apply")
        if not self.certificate.verified:
            out.append("the gain certificate of (2.17) failed: "
                       + "; ".join(k.summary() for k in self.certificate.failed_checks))
        return (*out, *self.warnings)

    @property
    def usable(self) -> bool:
        """Drift-observable on the region, (2.17) verified, and ``γ`` covering the sampled estimate."""
        return not self.reasons

    def observer(self, *, regularization: float = 0.0, cond_limit: float = COND_LIMIT) -> DriftObserver:
        """The observer (3.1) with this report's ``s`` and ``K``."""
        return DriftObserver.from_fields(self.fields, self.s, self.certificate.gain, regularization=regularization,
                                         cond_limit=cond_limit)

    def summary(self) -> str:
        c = self.certificate.constants
        r_txt = ", ".join("∞" if v is None else str(v) for v in self.r)
        lines = [
            f"drift-observability observer (Dalla Mora–Germani–Manes) for {self.model}",
            f"  multi-index s = ({', '.join(map(str, self.s))}), observation relative degree r = ({r_txt})",
            f"  region {self.region.describe()}",
        ]
        lines += [f"  [{'ok' if k.passed else 'FAILS'}] {k.name}: {k.evidence}" for k in self.checks]
        lines.append(f"  H_s,r(x) = {self.H}")
        L = self.lipschitz
        lines.append(f"  sampled on the region ({L.samples} points): γ_Φ ≈ {L.gamma_phi:.4g}, γ_Φ⁻¹ ≈ {L.gamma_phi_inv:.4g}, "
                     f"γ_L ≈ {L.gamma_L:.4g}, γ_H ≈ {L.gamma_H:.4g}")
        lines.append(f"  (2.17) with α = {c.alpha:g}, μ = {c.mu:g}, γ = {self.gamma:.4g} ({self.gamma_source})")
        lines += ["  " + ln for ln in self.certificate.summary().splitlines()]
        lines.append("  K = " + np.array2string(self.certificate.gain, precision=5, separator=", ").replace("\n", "\n      "))
        lines.append("  " + self.bound.describe())
        lines += [f"  warning: {m}" for m in self.warnings]
        lines.append("  usable: yes (drift-observable on the region, (2.17) verified, γ covers the sampled estimate)"
                     if self.usable else "  usable: NO — " + "; ".join(self.reasons))
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "s": list(self.s),
            "r": list(self.r),
            "checks": [k.to_dict() for k in self.checks],
            "F": self.F.tolist(),
            "H": self.H,
            "gamma": self.gamma,
            "gamma_source": self.gamma_source,
            "certificate": self.certificate.to_dict(),
            "lipschitz": self.lipschitz.to_dict(),
            "bound": self.bound.to_dict(),
            "usable": self.usable,
            "reasons": list(self.reasons),
            "warnings": list(self.warnings),
        }


def design_drift_report(
    model: SymbolicModel,
    s: Sequence[int] | None = None,
    *,
    alpha: float = 1.0,
    mu: float = 1.0,
    gamma: float | None = None,
    method: str = "vandermonde",
    region: Box | None = None,
    parameters: Mapping[str, float] | None = None,
    w: float | None = None,
    w_max: float = 1e5,
    objective: str = "min_gain",
    samples: int = 2000,
    seed: int = 0,
) -> DriftDesignReport:
    """Design and verify the gain of observer (3.1) for a model; the function behind ``nlobs design drift``.

    Parameters
    ----------
    model : SymbolicModel
        Continuous-time, input-affine, ``h`` independent of ``u``.
    s : sequence of int, optional
        Multi-index; default: the observability indices on the region.
    alpha, mu : float
        Decay rate ``α`` and input bound ``μ`` of (2.17).
    gamma : float, optional
        ``γ = √(γ_L² + γ_H²)``; default: estimated by sampling the region
        (:func:`lipschitz_estimates`).
    method : {"vandermonde", "sdp"}
        Remark 2.11 (smallest ``w``, or the given ``w`` checked) or the LMI design.
    region : Box, optional
        Where the checks and constants are evaluated (default ``[−1, 1]ⁿ``).
    objective : {"min_gain", "min_condition"}
        SDP objective.

    Returns
    -------
    DriftDesignReport
        Also when drift-observability fails on the region or a given ``γ`` is below the
        sampled estimate: then :attr:`DriftDesignReport.usable` is false and
        :attr:`~DriftDesignReport.reasons` says why.

    Raises
    ------
    ModelError
        Not input-affine / not continuous-time.
    InvalidArgumentError
        ``s`` does not sum to ``n``.
    NonFiniteError
        The model is not finite at any sampled point of the region.
    DesignInfeasible
        No gain satisfies (2.17) (the message names the constraint and by how much).
    """
    fields = AffineFields.from_model(model, parameters)
    reg = region or Box.unit(fields.n)
    s_ = check_multi_index(default_multi_index(fields, reg) if s is None else s, fields.q, fields.n)
    rd = observation_relative_degree(fields, reg)
    checks = (check_drift_observability(fields, s_, reg, seed=seed), check_s_le_r(s_, rd.r))
    H, F = input_gain_structure(fields, s_, rd.r)
    lip = lipschitz_estimates(fields, s_, rd.r, reg, samples=samples, seed=seed)
    g = lip.gamma if gamma is None else positive("gamma", gamma, allow_zero=True)
    c = RiccatiConstants(s_, F, alpha, mu, g)
    kw: dict[str, Any] = {"objective": objective} if str(method).lower() == "sdp" else {}
    cert = design_drift_gain(c, method, w=w, w_max=w_max, **kw)
    bound = error_bound_constants(cert, lip.gamma_phi, lip.gamma_phi_inv)
    F_ = np.array(F, dtype=float)
    F_.setflags(write=False)
    return DriftDesignReport(fields, s_, rd.r, checks, F_, str(H.tolist()), float(g),
                             "estimated" if gamma is None else "given", cert, lip, bound, reg)
