r"""The drift-observability observer (3.1) of Dalla Mora, Germani & Manes.

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

Saturation: the peaking remedy
------------------------------
A high-gain observer peaks: from an initial error of order 1 the estimate of (3.1) overshoots by
up to ``κ₁ ‖e(0)‖`` (``κ₁`` of (3.17) grows with the gain) and leaves the region ``B`` the design was
verified on; there ``f`` may grow fast enough for a finite escape and ``Q_s`` may be singular
(Rössler: ``det Q_s = x − 5.9``). In ``z = Φ_s(x̂)`` coordinates (3.1) is ``ż = A_s z + B_s L_s(x̂) +
F H(x̂) u + K (y − C_s z)`` (3.4), with ``A_s z + B_s L_s = Q_s f`` and ``F H = Q_s g`` (2.13). Khalil's
remedy for high-gain observers saturates the *nonlinear* terms outside the region where the plant
lives and keeps the linear part: with ``saturation = B`` and ``σ = sat(x̂)`` (the component-wise
projection onto ``B``, the hard saturation of Grip, Saberi & Johansen, App. A,
:class:`~nlobs.systems.saturation.Saturation`)

.. math:: Q_s(\hat x)\,\dot{\hat x} = A_s\big(Φ_s(\hat x) − Φ_s(σ)\big) + Q_s(σ)\big(f(σ) + g(σ) u\big)
          + K\big(y − h(\hat x)\big),

i.e. ``ż = A_s z + B_s L_s(σ) + F H(σ) u + K (y − C_s z)``.

Why it keeps the certificate. For ``x̂ ∈ B``, ``σ = x̂`` and the right-hand side is (3.1) — the
implementation evaluates (3.1) itself there, so it is the same to the last bit. The certificate of
(2.17) (``γ``, ``γ_Φ``, ``γ_{Φ⁻¹}`` sampled on ``B``) covers a run only while the state and the estimate
stay in ``B`` (the hypotheses the coverage monitor checks): on every run, or start of a run, that it
covers, the two observers coincide. Outside ``B`` (where the certificate says nothing) Khalil's argument
applies: with the state ``x ∈ B`` the error ``e = Φ_s(x) − z`` obeys ``ė = (A_s − K C_s) e +
B_s (L_s(x) − L_s(σ)) + F (H(x) − H(σ)) u``, a Hurwitz linear system driven by a perturbation that is
bounded on all of ℝⁿ (``x, σ ∈ B``, compact) and, ``σ`` and ``x`` both in ``B``, bounded by the constants
sampled there — the nonlinearity can no longer feed the peak, so ``e`` stays bounded (input-to-state: its
size is set by that perturbation, reached at the rate of ``A_s − K C_s``) until ``x̂`` re-enters ``B``; the
argument shows boundedness, not decay, outside ``B``. What it does not remove is the peak of the linear
part itself, nor a crossing of the set where ``Q_s(x̂)`` is singular during the transient (reported as
for (3.1)); its effect is measured, not proved: ``benchmarks/peaking.py``, ``docs/drift.md``.
:meth:`DriftObserver.saturated_estimate` gives ``sat(x̂)`` (in ``B``); the estimate stays ``x̂`` so that
the coverage monitor sees it leave ``B``. The workflows (:mod:`nlobs.workflows.design_drift`,
``saturation=True``; ``nlobs design drift``) switch it on by default; the observer itself has it off
(``saturation=None``, the paper's (3.1)).

Where the rest lives
--------------------
* the gain ``(K, P)`` of (2.17): :mod:`nlobs.synthesis.drift_gain`; the constants ``κ₁``, ``κ₂``
  of (3.17): :mod:`nlobs.synthesis.drift_bounds`;
* the sampled Lipschitz constants ``γ_Φ``, ``γ_{Φ⁻¹}``, ``γ_L``, ``γ_H``:
  :mod:`nlobs.geometry.lipschitz`;
* design, verify and simulate a model (``nlobs design drift``): :mod:`nlobs.workflows.design_drift`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any
from dataclasses import dataclass, field

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_batch, as_matrix, positive
from nlobs.errors import InvalidArgumentError, NlobsError
from nlobs.geometry.checks import default_multi_index
from nlobs.geometry.observability import AffineFields, check_multi_index, observability_jacobian, observability_map
from nlobs.geometry.region import Box
from nlobs.systems.codegen import BatchedFunction, compile_matrix
from nlobs.systems.brunovsky import brunovsky
from nlobs.systems.symbolic import SymbolicModel
from nlobs.systems.timebase import CONTINUOUS, TimeBase
from nlobs.observers.base import ToControl

__all__ = ["COND_LIMIT", "DriftObserver", "SingularObservabilityError"]

#: Default largest accepted condition number of ``Q_s`` (above it ``Q_s`` counts as singular).
COND_LIMIT = 1e10


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

    Examples
    --------
    The Rössler system (a shipped model) measured through ``x`` has ``det Q_s = x − 5.9`` for ``s = (3)``
    (module docstring): an observer started on that plane is refused, with the point, and so is a
    right-hand side evaluated there during a run, with the time:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.synthesis.drift_gain import vandermonde_gain
    >>> observer = nlobs.DriftObserver.from_model(nlobs.load_model("rossler"), vandermonde_gain((3,), 2.0).K)
    >>> try:
    ...     observer.init([5.9, 0.0, 1.0])
    ... except SingularObservabilityError as exc:
    ...     print(type(exc).__name__, exc.quantity, exc.point, exc.time, exc.condition > COND_LIMIT)
    SingularObservabilityError Q_s (s = [3]) (5.9, 0.0, 1.0) None True
    >>> try:
    ...     observer.rhs(1.5, np.array([5.9, 0.0, 1.0]), np.zeros(0), np.array([1.0]))
    ... except SingularObservabilityError as exc:
    ...     print(exc)
    rossler: Q_s (s = [3]) is singular at t=1.5, x̂ = (x=5.9, y=0, z=1) (cond = ...); the drift-observability ...
    >>> observer.init([1.0, 0.0, 1.0]).tolist()  # off the plane x = 5.9
    [1.0, 0.0, 1.0]
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
            "Φ_s is a local diffeomorphism (`x_hat0`), choose another multi-index (`s`), or a region where Q_s is "
            "nonsingular (`region`; a Tikhonov-regularised observer is in nlobs.observers.drift)"
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
class DriftObserver(ToControl):
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
    on_singular : {"raise", "nan"}
        Where ``Q_s(x̂)`` is singular: ``"raise"`` (default) :class:`SingularObservabilityError`;
        ``"nan"``: that batch member's correction is NaN (its estimate is lost, the other Monte
        Carlo runs go on; for ``simulate(..., divergence="keep")``).
    saturation : Box or None
        ``None`` (default): (3.1) as printed. A box ``B`` (the region of the design): the nonlinear
        terms of (3.4) evaluated at ``sat(x̂)`` (module docstring: identical to (3.1) while ``x̂`` is
        inside ``B``).
    states : tuple of str
    n_inputs, n_outputs : int
        Sizes of the plant's input ``u`` and output ``y``.
    state_names : tuple of str
        ``"<state>_hat"``.
    time : Continuous

    Examples
    --------
    The Van der Pol oscillator in Liénard form (a shipped model) is drift-observable with ``s = (2)``, ``Φ_s`` a
    global diffeomorphism (``det Q_s = 1``); the gain of Remark 2.11 (Dalla Mora, Germani & Manes) with
    ``w = 4`` places the eigenvalues of ``A_s − K C_s`` at −4 and −8:

    >>> import nlobs
    >>> from nlobs.synthesis.drift_gain import vandermonde_gain
    >>> model = nlobs.load_model("vanderpol-lienard")
    >>> observer = nlobs.DriftObserver.from_model(model, vandermonde_gain((2,), 4.0).K)
    >>> observer.s, observer.K.ravel().tolist()
    ((2,), [12.0, 32.0])
    >>> res = nlobs.simulate(model.compile(), observer, [2.0, 0.0], [0.0, 1.0], duration=3.0, dt=1e-2, u=0.0)
    >>> e = res.error_norm  # ‖x̂ − x‖ at each step
    >>> round(float(e[0]), 3), bool(e[-1] < 1e-4 * e[0])
    (2.236, True)
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
    on_singular: str = "raise"
    saturation: Box | None = None
    _phi: BatchedFunction | None = field(default=None, repr=False)
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
        if self.on_singular not in ("raise", "nan"):
            raise InvalidArgumentError(f"on_singular: expected 'raise' or 'nan', got {self.on_singular!r}")
        if self.saturation is not None:
            if not isinstance(self.saturation, Box):
                raise InvalidArgumentError(f"saturation: expected a Box or None, got {type(self.saturation).__name__}")
            if self.saturation.n != n:
                raise InvalidArgumentError(f"saturation: the box has dimension {self.saturation.n}, the model has n = {n}")
            if self._phi is None:
                raise InvalidArgumentError("saturation: needs Φ_s compiled; build the observer with from_fields or from_model")
        object.__setattr__(self, "_A", brunovsky(self.s)[0])
        object.__setattr__(self, "state_names", tuple(f"{x}_hat" for x in self.states))
        # Q_s ≡ I: the correction is K ỹ itself, bit for bit (an LU solve with I is exact; its bound ‖Q‖_F‖c‖/(√n‖b‖)
        # is 1 to rounding, under any cond_limit ≥ 2)
        object.__setattr__(self, "_unit_q", self.cond_limit >= 2.0 and _is_identity(
            self._fn.expressions[-n * n:] if n else (), n))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_fields(cls, fields: AffineFields, s: Sequence[int], K: ArrayLike, *, regularization: float = 0.0,
                    cond_limit: float = COND_LIMIT, on_singular: str = "raise",
                    saturation: Box | None = None) -> DriftObserver:
        """Compile ``f, g, h, Q_s`` of ``fields`` once and build the observer (``saturation``: see the class)."""
        s_ = check_multi_index(s, fields.q, fields.n)
        Q = observability_jacobian(fields, s_)
        m, q = fields.m, fields.q
        entries = list(fields.f) + list(fields.g) + list(fields.h) + list(Q)
        fn = compile_matrix(sp.Matrix(entries) if entries else sp.zeros(0, 1), (fields.x,), vector=True,
                            what=f"{fields.name}: f, g, h, Q_s")
        phi = None if saturation is None else compile_matrix(
            sp.Matrix(observability_map(fields, s_)), (fields.x,), vector=True, what=f"{fields.name}: Φ_s")
        return cls(fields.name, s_, np.asarray(K, dtype=float), fields.states, m, q, fn,
                   regularization=regularization, cond_limit=cond_limit, on_singular=on_singular,
                   saturation=saturation, _phi=phi)

    @classmethod
    def from_model(cls, model: SymbolicModel, K: ArrayLike, s: Sequence[int] | None = None, *,
                   parameters: Mapping[str, float] | None = None, regularization: float = 0.0,
                   cond_limit: float = COND_LIMIT, region: Box | None = None,
                   saturation: Box | None = None) -> DriftObserver:
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
        return cls.from_fields(fields, s_, K, regularization=regularization, cond_limit=cond_limit,
                               saturation=saturation)

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
            if np.any(cond > self.cond_limit) and self.on_singular == "raise":
                raise self._singular(Q, x, None, cond)
        return x

    def _sat(self, x: Array) -> Array:
        """``sat(x)`` onto :attr:`saturation` (``x`` itself without one)."""
        B = self.saturation
        return x if B is None else np.clip(x, B.lower, B.upper)

    def correction(self, t: float, x_hat: Array, innovation: Array, Q: Array) -> Array:
        """``Q_s(x̂)⁻¹ K ỹ`` (or its Tikhonov-regularised form) by a batched linear solve."""
        b = innovation @ self.K.T  # (..., n)
        eps = self.regularization
        if self._unit_q and eps == 0.0 and np.isfinite(b).all():  # type: ignore[attr-defined]
            return b  # Q_s ≡ I (the outputs and their derivatives are the states): I⁻¹ b, and cond(I) = 1
        if eps > 0.0:
            Qt = np.swapaxes(Q, -1, -2)
            A = Qt @ Q + (eps * eps) * np.eye(self.n_x)
            return np.linalg.solve(A, (Qt @ b[..., None]))[..., 0]
        c = self._solve(t, x_hat, Q, b)
        if c.ndim == 1 and self._clearly_conditioned(Q, b, c):  # one run, clearly fine: the test's answer
            return c
        # cond(Q) ≥ ‖Q‖₂‖c‖/‖b‖ ≥ ‖Q‖_F ‖c‖ / (√n ‖b‖): a cheap lower bound, large only when the solve amplified
        # the 2-norms and the Frobenius norm as np.linalg.norm computes them (its operations, without its checks)
        nb = np.sqrt(np.add.reduce(b * b, axis=-1))
        nQ = np.sqrt(np.add.reduce(Q * Q, axis=(-2, -1)))
        lower = nQ * np.sqrt(np.add.reduce(c * c, axis=-1)) / (math.sqrt(self.n_x) * np.maximum(nb, 1e-300))
        bad = ~np.isfinite(c).all(axis=-1) | ((lower > self.cond_limit) & (nb > 0))
        if np.any(bad):
            if self.on_singular == "raise":
                raise self._singular(Q, x_hat, t)
            c = np.where(bad[..., None], np.nan, c)
        return c

    def _clearly_conditioned(self, Q: Array, b: Array, c: Array) -> bool:
        """One run: ``c`` finite and the bound ``‖Q‖_F ‖c‖ / (√n ‖b‖)`` below :attr:`cond_limit` by a margin that
        no rounding reaches, in Python floats. ``True`` is the batched test's answer; ``False`` leaves the
        decision to the batched test's own operations."""
        nc2 = sum(v * v for v in c.tolist())
        if not math.isfinite(nc2):
            return False
        nb2 = sum(v * v for v in b.tolist())
        if nb2 == 0.0:
            return True  # no correction to amplify: the batched test passes any finite c
        nq2 = sum(v * v for v in Q.ravel().tolist())
        return nq2 * nc2 < (1.0 - 1e-9) * self.cond_limit**2 * self.n_x * nb2

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``x̂' = f(x̂) + g(x̂) u + Q_s(x̂)⁻¹ K (y − h(x̂))`` (3.1) for batches ``(..., n)``.

        With :attr:`saturation`, where ``x̂`` is outside the box the nonlinear terms are evaluated at
        ``sat(x̂)`` (Khalil's form, module docstring); inside it the result is (3.1)'s, bit for bit.
        """
        f, g, h, Q = self._parts(z)
        uu = np.asarray(u, dtype=float)
        if self.n_inputs == 0:
            drift = f
        elif self.n_inputs == 1 and uu.ndim == 1 and g.ndim == 2:  # one run, one input: einsum's one product
            drift = f + g[:, 0] * uu[0]
        else:
            drift = f + np.einsum("...ij,...j->...i", g, uu)
        B = self.saturation
        if B is None:
            return drift + self.correction(t, z, np.asarray(y, dtype=float) - h, Q)
        sig = self._sat(z)
        outside = np.any(sig != z, axis=-1)
        if not np.any(outside):
            return drift + self.correction(t, z, np.asarray(y, dtype=float) - h, Q)
        fs, gs, _, Qs = self._parts(sig)
        drift_s = fs if self.n_inputs == 0 else fs + np.einsum("...ij,...j->...i", gs, uu)
        assert self._phi is not None
        lin = (self._phi(z) - self._phi(sig)) @ self._A.T  # type: ignore[attr-defined]
        # Q_s(x̂) x̂' = A_s (Φ(x̂) − Φ(σ)) + Q_s(σ)(f(σ) + g(σ)u) + K ỹ; the K ỹ term goes through correction()
        rest = np.einsum("...ij,...j->...i", Qs, drift_s) + lin
        corr = self.correction(t, z, np.asarray(y, dtype=float) - h, Q)
        with np.errstate(all="ignore"):
            out = self._solve(t, z, Q, rest)
        return np.where(outside[..., None], out + corr, drift + corr)

    def _solve(self, t: float, x_hat: Array, Q: Array, b: Array) -> Array:
        """``Q⁻¹ b`` (NaN or :class:`SingularObservabilityError` by :attr:`on_singular` where it fails)."""
        try:
            return np.linalg.solve(Q, b[..., None])[..., 0]
        except np.linalg.LinAlgError:
            if self.on_singular == "raise":
                raise self._singular(Q, x_hat, t) from None
            return _solve_each(Q, b)

    def estimate(self, z: Array) -> Array:
        """The estimate is the observer state, ``x̂ = z`` (also with :attr:`saturation`)."""
        return z

    def saturated_estimate(self, x_hat: ArrayLike) -> Array:
        """``sat(x̂)`` onto :attr:`saturation` (``x̂`` itself without one): the estimate to hand on, in the box."""
        return self._sat(np.asarray(x_hat, dtype=float))


def _is_identity(entries: Sequence[Any], n: int) -> bool:
    """Whether the ``n × n`` entries (row-major, SymPy) are the identity matrix's numbers, whatever ``x``."""
    if n == 0 or len(entries) != n * n:
        return False
    return all(getattr(e, "is_Number", False) and e == (1 if i % (n + 1) == 0 else 0) for i, e in enumerate(entries))


def _solve_each(Q: Array, b: Array) -> Array:
    """``Q⁻¹ b`` member by member, NaN where ``Q`` is singular (the rare path after a batched solve failed)."""
    Qf = Q.reshape(-1, Q.shape[-2], Q.shape[-1])
    bf = b.reshape(-1, b.shape[-1])
    out = np.full(bf.shape, np.nan)
    for i in range(Qf.shape[0]):
        try:
            out[i] = np.linalg.solve(Qf[i], bf[i])
        except np.linalg.LinAlgError:
            pass
    return out.reshape(b.shape)
