r"""Discrete-time systems with unknown inputs and their function classes (Khajenejad & Yong, Secs. 2-3).

The model (Khajenejad & Yong, (8)) is

.. math::

    x_{k+1} = A x_k + \varphi(x_k) + B u_k + G d_k + W w_k, \qquad
    y_k = C x_k + D u_k + H d_k + v_k,

with ``f(x) = A x + φ(x)`` split into a known linear part ``A`` and a nonlinear
part ``φ`` (a batched NumPy callable, or compiled once from a SymPy model with
:meth:`DiscreteUISystem.from_symbolic`), unknown inputs ``d`` (no bound
assumed), bounded noises ``‖w_k‖ ≤ η_w``, ``‖v_k‖ ≤ η_v`` and a known initial
ball ``‖x_0 − x̂_0‖ ≤ δ_0``.

**The function class describes the nonlinear part φ**, not ``f``: every
increment pair ``(Δφ, Δx) = (φ(x₂) − φ(x₁), x₂ − x₁)`` satisfies the quadratic
constraint (2) ``[Δφ; Δx]ᵀ M [Δφ; Δx] ≥ γ``. (The paper states the classes for
``f`` but uses the constants of the nonlinear part in its examples, see
``docs/setvalued.md``; to put the class on the whole ``f`` pass ``A = 0``.)

* :class:`QuadraticConstraint` — Class 0, ``(M, γ)``-QC (Definition 2.6);
* :class:`Lipschitz` — Class I (Definition 2.3, multiplier of Proposition 2.8);
* :class:`QCStar` — Class II, ``(𝒜, γ)``-QC* (Definition 2.11; Lemma 2.14 for an
  affine-plus-bounded split);
* :class:`LPV` — Class III (Definition 2.4), constituent matrices ``A_i``.

:func:`estimate_lipschitz` estimates a Lipschitz constant on a box from samples
(a *lower* estimate of the true constant, reported as such) and
:func:`check_function_class` searches sampled pairs for one that violates a
claimed class.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_batch, as_matrix, as_square, as_symmetric, as_vector, positive, readonly, real_scalar
from nlobs.checks import Check, CheckKind
from nlobs.errors import DimensionError, InvalidArgumentError, ModelError, NonFiniteError
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.symbolic import SymbolicModel
from nlobs.systems.timebase import Discrete

__all__ = [
    "FunctionClass",
    "QuadraticConstraint",
    "Lipschitz",
    "QCStar",
    "LPV",
    "qcstar_from_bounded_split",
    "DiscreteUISystem",
    "LipschitzEstimate",
    "estimate_lipschitz",
    "check_function_class",
    "class_margins",
    "qc_member_min_eig",
    "qc_member_tolerance",
    "qc_linear_members",
]

NonlinearPart = Callable[[Array], Array]



# --------------------------------------------------------------------------- function classes


@dataclass(frozen=True)
class QuadraticConstraint:
    r"""Class 0: ``φ`` is ``(M, γ)``-QC (Khajenejad & Yong, Definition 2.6, (2)).

    ``[Δφ; Δx]ᵀ M [Δφ; Δx] ≥ γ`` for all ``x₁, x₂`` (``Δφ`` first, as in the paper).

    Parameters
    ----------
    M : array_like, shape (2n, 2n)
        Symmetric multiplier ``[[M11, M12], [M12ᵀ, M22]]``.
    gamma : float
        The constant ``γ`` (finite; may be negative, e.g. Lemma 2.14).
    """

    M: Array
    gamma: float = 0.0

    def __post_init__(self) -> None:
        M = as_symmetric("M", self.M)
        if M.shape[0] % 2:
            raise DimensionError(f"M: expected an even size 2n, got shape {M.shape}")
        object.__setattr__(self, "M", readonly(M))
        g = float(real_scalar("gamma", self.gamma))
        if not math.isfinite(g):
            raise InvalidArgumentError(f"gamma: must be finite, got {self.gamma!r}")
        if g > 0:
            raise InvalidArgumentError(
                f"gamma: an (M, gamma)-QC class with gamma > 0 is empty (the pair x1 = x2 gives QC = 0 < gamma), "
                f"got {g!r}")
        object.__setattr__(self, "gamma", g)

    @property
    def n(self) -> int:
        """Dimension of ``x`` (and of ``φ(x)``)."""
        return self.M.shape[0] // 2

    @property
    def label(self) -> str:
        return "Class 0 ((M, γ)-QC)"

    def multiplier(self) -> tuple[Array, float]:
        """``(M, γ)`` of (2), ``Δφ`` block first."""
        return self.M, self.gamma

    def qc_value(self, dphi: Array, dx: Array) -> Array:
        """``[Δφ; Δx]ᵀ M [Δφ; Δx]`` for batches of shape ``(..., n)``."""
        z = np.concatenate([dphi, dx], axis=-1)
        return np.einsum("...i,ij,...j->...", z, self.M, z)

    def linear_members(self) -> tuple[Array, ...]:
        """Linear maps ``K`` known to satisfy the constraint (``φ(x) = K x``), by :func:`qc_linear_members`.

        ``K = 0`` when ``M22 ⪰ 0``, and ``K* = −M11⁻¹M12`` when ``M11 ≺ 0`` (the ``Δφ`` that maximises the
        form for each ``Δx``), each accepted when ``[K; I]ᵀ M [K; I] ⪰ 0`` (then the QC value is ``≥ 0 ≥ γ``);
        empty when neither is known to be in the class.
        """
        return qc_linear_members(self.M)

    def increment_bound(self, Acl: Array, Bcl: Array) -> tuple[float, float]:
        r"""``(θ, r)`` with ``‖Acl Δx + Bcl Δφ‖ ≤ θ ‖Δx‖ + r`` for every admissible pair.

        From (2) with ``M11 ≺ 0`` (``m = λ_min(−M11)``, ``a = ‖M12‖``,
        ``c = max(λ_max(M22), 0)``): ``m ‖Δφ‖² ≤ 2a ‖Δφ‖‖Δx‖ + c ‖Δx‖² − γ``, hence
        ``‖Δφ‖ ≤ ((a + √(a² + m c)) ‖Δx‖ + √(m max(−γ, 0))) / m``. ``θ = inf`` when
        ``M11`` is not negative definite (no bound on ``Δφ`` follows).
        """
        n = self.n
        M11, M12, M22 = self.M[:n, :n], self.M[:n, n:], self.M[n:, n:]
        m = float(-np.linalg.eigvalsh(M11)[-1])
        if m <= 0:
            return math.inf, math.inf
        a = float(np.linalg.norm(M12, 2))
        c = max(float(np.linalg.eigvalsh(M22)[-1]), 0.0)
        k = (a + math.sqrt(a * a + m * c)) / m
        off = math.sqrt(m * max(-self.gamma, 0.0)) / m
        nb = float(np.linalg.norm(Bcl, 2))
        return float(np.linalg.norm(Acl, 2)) + nb * k, nb * off


def qc_member_min_eig(M: ArrayLike, K: ArrayLike) -> float:
    """``λ_min([K; I]ᵀ M [K; I])``: ``φ(x) = K x`` satisfies (2) with ``γ = 0`` iff it is ``≥ 0`` (``Δφ`` block first).

    Parameters
    ----------
    M : array_like, shape (2n, 2n)
        Multiplier of (2), ``Δφ`` block first.
    K : array_like, shape (n, n)
        The linear map ``φ(x) = K x``.

    Returns
    -------
    float
    """
    M_ = np.asarray(M, dtype=float)
    K_ = np.asarray(K, dtype=float)
    n = K_.shape[0]
    M11, M12, M22 = M_[:n, :n], M_[:n, n:], M_[n:, n:]
    Q = K_.T @ M11 @ K_ + K_.T @ M12 + M12.T @ K_ + M22
    return float(np.linalg.eigvalsh(0.5 * (Q + Q.T))[0])


def qc_member_tolerance(M: ArrayLike, K: ArrayLike) -> float:
    """Round-off allowance of :func:`qc_member_min_eig`: ``1e-9 max(1, max|M|) max(1, ‖K‖²)``.

    Parameters
    ----------
    M : array_like, shape (2n, 2n)
        Multiplier of (2), ``Δφ`` block first.
    K : array_like, shape (n, n)
        The linear map ``φ(x) = K x``.

    Returns
    -------
    float
    """
    scale = max(1.0, float(np.max(np.abs(np.asarray(M, dtype=float)))))
    return 1e-9 * scale * max(1.0, float(np.linalg.norm(np.asarray(K, dtype=float), 2)) ** 2)


def qc_linear_members(M: ArrayLike, candidates: tuple[ArrayLike, ...] = ()) -> tuple[Array, ...]:
    """Linear members ``K`` of the ``(M, 0)``-QC class among ``candidates``, ``0`` and ``K* = −M11⁻¹M12`` (``M11 ≺ 0``).

    A candidate is accepted when ``[K; I]ᵀ M [K; I] ⪰ −tol`` (:func:`qc_member_min_eig`,
    :func:`qc_member_tolerance`); duplicates are dropped. Shared by :class:`QuadraticConstraint` and the
    printed formulations of the reading room (:mod:`nlobs.papers.khajenejad_yong_printed`).

    Parameters
    ----------
    M : array_like, shape (2n, 2n)
        Multiplier of (2), ``Δφ`` block first.
    candidates : tuple of array_like, each (n, n)
        Further linear maps to test, before ``0`` and ``K*``.

    Returns
    -------
    tuple of ndarray, each (n, n)
        The accepted members, in the order tested.
    """
    M_ = np.asarray(M, dtype=float)
    n = M_.shape[0] // 2
    M11, M12 = M_[:n, :n], M_[:n, n:]
    cands = [np.asarray(K, dtype=float) for K in candidates] + [np.zeros((n, n))]
    if float(np.linalg.eigvalsh(M11)[-1]) < 0:
        cands.append(-np.linalg.solve(M11, M12))
    out: list[Array] = []
    for K in cands:
        if qc_member_min_eig(M_, K) >= -qc_member_tolerance(M_, K) and not any(
                np.allclose(K, k, rtol=1e-12, atol=1e-12) for k in out):
            out.append(K)
    return tuple(out)


@dataclass(frozen=True)
class Lipschitz:
    r"""Class I: ``‖φ(x₂) − φ(x₁)‖ ≤ L ‖x₂ − x₁‖`` (Definition 2.3).

    Multiplier (Proposition 2.8, (20)): ``M = [[−I, 0], [0, L² I]]``, ``γ = 0``.

    Parameters
    ----------
    L : float
        Lipschitz constant (``≥ 0``).
    n : int
        Dimension of ``x``.
    """

    L: float
    n: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "L", positive("L", self.L, allow_zero=True))
        if int(self.n) < 1:
            raise DimensionError(f"n: must be at least 1, got {self.n!r}")
        object.__setattr__(self, "n", int(self.n))

    @property
    def gamma(self) -> float:
        return 0.0

    @property
    def label(self) -> str:
        return "Class I (Lipschitz)"

    def multiplier(self) -> tuple[Array, float]:
        n = self.n
        M = np.block([[-np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), self.L**2 * np.eye(n)]])
        return M, 0.0

    def qc_value(self, dphi: Array, dx: Array) -> Array:
        return -np.sum(dphi * dphi, axis=-1) + self.L**2 * np.sum(dx * dx, axis=-1)

    def linear_members(self) -> tuple[Array, ...]:
        """``K = 0`` (``φ = 0`` is ``L``-Lipschitz)."""
        return (np.zeros((self.n, self.n)),)

    def increment_bound(self, Acl: Array, Bcl: Array) -> tuple[float, float]:
        """``θ = ‖Acl‖ + L ‖Bcl‖``, ``r = 0``."""
        return float(np.linalg.norm(Acl, 2) + self.L * np.linalg.norm(Bcl, 2)), 0.0


@dataclass(frozen=True)
class QCStar:
    r"""Class II: ``φ`` is ``(𝒜, γ)``-QC* (Definition 2.11).

    ``−‖Δφ − 𝒜 Δx‖² ≥ γ``, i.e. multiplier (21) ``M = [[−I, 𝒜], [𝒜ᵀ, −𝒜ᵀ𝒜]]``.
    With ``γ ≤ 0`` this says ``Δφ = 𝒜 Δx + e`` with ``‖e‖ ≤ √(−γ)`` (Lemma 2.14:
    ``φ = 𝒜 x + h + g(x)``, ``‖g‖ ≤ r`` gives ``γ = −(2r)²``); with ``γ > 0`` the
    class is empty.

    Parameters
    ----------
    A_aux : array_like, shape (n, n)
        The auxiliary multiplier matrix ``𝒜``.
    gamma : float
        ``γ ≤ 0``.
    """

    A_aux: Array
    gamma: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "A_aux", readonly(as_square("A_aux", self.A_aux)))
        g = float(self.gamma)
        if not math.isfinite(g):
            raise InvalidArgumentError(f"gamma: must be finite, got {self.gamma!r}")
        if g > 0:
            raise InvalidArgumentError(
                f"gamma: an (A, gamma)-QC* function needs gamma <= 0 (-‖Δφ − AΔx‖² ≥ γ > 0 is impossible), got {g!r}"
            )
        object.__setattr__(self, "gamma", g)

    @property
    def n(self) -> int:
        return self.A_aux.shape[0]

    @property
    def label(self) -> str:
        return "Class II ((A, γ)-QC*)"

    def multiplier(self) -> tuple[Array, float]:
        A = self.A_aux
        n = self.n
        return np.block([[-np.eye(n), A], [A.T, -A.T @ A]]), self.gamma

    def qc_value(self, dphi: Array, dx: Array) -> Array:
        e = dphi - dx @ self.A_aux.T
        return -np.sum(e * e, axis=-1)

    def linear_members(self) -> tuple[Array, ...]:
        """``K = 𝒜``."""
        return (np.array(self.A_aux),)

    def increment_bound(self, Acl: Array, Bcl: Array) -> tuple[float, float]:
        """``θ = ‖Acl + Bcl 𝒜‖``, ``r = ‖Bcl‖ √(−γ)``."""
        return (float(np.linalg.norm(Acl + Bcl @ self.A_aux, 2)),
                float(np.linalg.norm(Bcl, 2)) * math.sqrt(-self.gamma))


@dataclass(frozen=True)
class LPV:
    r"""Class III: ``φ_k(x) = Σᵢ λ_{i,k} Aᵢ x`` with ``λ`` in the simplex (Definition 2.4).

    As a multiplier the paper uses the Lipschitz constant ``σ̃ = maxᵢ ‖Aᵢ‖``
    (Proposition 2.16, (22)); :meth:`linear_members` returns the vertices, for
    which a polytopic design needs no multiplier.

    Parameters
    ----------
    constituents : sequence of array_like, each (n, n)
    """

    constituents: tuple[Array, ...]

    def __post_init__(self) -> None:
        mats = tuple(readonly(as_square(f"constituents[{i}]", a)) for i, a in enumerate(self.constituents))
        if not mats:
            raise DimensionError("constituents: at least one matrix is needed")
        n = mats[0].shape[0]
        for i, a in enumerate(mats):
            if a.shape != (n, n):
                raise DimensionError(f"constituents[{i}]: expected shape ({n}, {n}), got {a.shape}")
        object.__setattr__(self, "constituents", mats)

    @property
    def n(self) -> int:
        return self.constituents[0].shape[0]

    @property
    def gamma(self) -> float:
        return 0.0

    @property
    def label(self) -> str:
        return "Class III (LPV)"

    @property
    def sigma(self) -> float:
        """``σ̃ = maxᵢ ‖Aᵢ‖`` (Proposition 2.16)."""
        return max(float(np.linalg.norm(a, 2)) for a in self.constituents)

    def multiplier(self) -> tuple[Array, float]:
        return Lipschitz(self.sigma, self.n).multiplier()

    def qc_value(self, dphi: Array, dx: Array) -> Array:
        return Lipschitz(self.sigma, self.n).qc_value(dphi, dx)

    def linear_members(self) -> tuple[Array, ...]:
        return tuple(np.array(a) for a in self.constituents)

    def polytope_gap(self, dphi: Array, dx: Array) -> Array:
        r"""Distance of ``Δφ`` from the polytope ``{Σᵢ λᵢ Aᵢ Δx : λ ∈ simplex}``, for batches ``(..., n)``.

        ``0`` (to round-off) exactly when the difference quotient of the pair is a member of the class,
        which is what the vertex design of :mod:`nlobs.synthesis.setvalued` assumes of ``π``. One or
        two vertices: the exact projection; more: a non-negative least-squares solve with a heavily
        weighted row ``Σλᵢ = 1``, its ``λ`` renormalised onto the simplex (so the distance returned is
        attained by a feasible ``λ``: never below the true distance).
        """
        from scipy.optimize import nnls

        dphi_ = np.asarray(dphi, dtype=float)
        dx_ = np.asarray(dx, dtype=float)
        V = np.einsum("ijk,...k->...ji", np.stack(self.constituents), dx_)  # (..., n, N): columns Aᵢ Δx
        N = V.shape[-1]
        if N == 1:
            return np.linalg.norm(dphi_ - V[..., 0], axis=-1)
        if N == 2:
            a, b = V[..., 0], V[..., 1]
            ab = a - b
            den = np.sum(ab * ab, axis=-1)
            t = np.clip(np.sum((dphi_ - b) * ab, axis=-1) / np.where(den > 0, den, 1.0), 0.0, 1.0)
            t = np.where(den > 0, t, 1.0)
            return np.linalg.norm(dphi_ - (b + t[..., None] * ab), axis=-1)
        flatV = V.reshape(-1, V.shape[-2], N)
        flatp = dphi_.reshape(-1, dphi_.shape[-1])
        out = np.empty(flatV.shape[0])
        for i in range(flatV.shape[0]):
            Vi, pi = flatV[i], flatp[i]
            w = 1e4 * (float(np.abs(Vi).max(initial=0.0)) + float(np.abs(pi).max(initial=0.0)) + 1e-300)
            lam, _ = nnls(np.vstack([Vi, w * np.ones((1, N))]), np.concatenate([pi, [w]]))
            lam = lam / lam.sum() if lam.sum() > 0 else np.full(N, 1.0 / N)
            out[i] = float(np.linalg.norm(pi - Vi @ lam))
        return out.reshape(dphi_.shape[:-1])

    def increment_bound(self, Acl: Array, Bcl: Array) -> tuple[float, float]:
        """``θ = maxᵢ ‖Acl + Bcl Aᵢ‖`` (convexity of the norm), ``r = 0``."""
        return max(float(np.linalg.norm(Acl + Bcl @ a, 2)) for a in self.constituents), 0.0


FunctionClass = QuadraticConstraint | Lipschitz | QCStar | LPV


def qcstar_from_bounded_split(A_aux: ArrayLike, r: float) -> QCStar:
    """Lemma 2.14: ``φ(x) = 𝒜 x + h + g(x)`` with ``‖g(x)‖ ≤ r`` is ``(𝒜, −(2r)²)``-QC*.

    (The paper uses ``γ = 0`` in Example 6.1, which would make ``φ`` affine.)

    Parameters
    ----------
    A_aux : array_like, shape (n, n)
        The linear part ``𝒜``.
    r : float
        Bound ``r ≥ 0`` on ``‖g(x)‖``.

    Returns
    -------
    QCStar
        With ``γ = −(2r)²``.
    """
    rr = positive("r", r, allow_zero=True)
    return QCStar(as_square("A_aux", A_aux), -((2.0 * rr) ** 2))


# --------------------------------------------------------------------------- the system


@dataclass(frozen=True)
class DiscreteUISystem:
    r"""``x⁺ = A x + φ(x) + B u + G d + W w``, ``y = C x + D u + H d + v`` (Khajenejad & Yong, (8)).

    Parameters
    ----------
    A : array_like, shape (n, n)
        Linear part of ``f``.
    G : array_like, shape (n, p)
        Unknown-input matrix (``p ≥ 0``).
    C : array_like, shape (l, n)
    H : array_like, shape (l, p), optional
        Unknown-input feed-through (zero when omitted).
    B, D : array_like, optional
        Known-input matrices, shapes ``(n, m)``, ``(l, m)`` (``m = 0`` when omitted).
    W : array_like, shape (n, n_w), optional
        Process-noise matrix (identity when omitted).
    phi : callable, optional
        Nonlinear part, ``(..., n) → (..., n)``; zero when omitted.
    function_class : FunctionClass, optional
        The class of ``φ`` with its constants (``Lipschitz(0, n)`` for ``φ = 0``).
    eta_w, eta_v : float
        Noise bounds ``‖w_k‖ ≤ η_w``, ``‖v_k‖ ≤ η_v`` (finite, ``≥ 0``).
    x0 : array_like, shape (n,)
        Centre ``x̂_0`` of the initial ball.
    delta0 : float
        Radius ``δ_0`` of the initial ball.
    time : Discrete
        Time base (required: the sampling period is never defaulted).
    name : str

    Examples
    --------
    The Sec. 6.2 benchmark of Khajenejad & Yong: ``f(x) = A x + φ(x)`` with ``φ = [0, −1.25 tanh x₁]``
    (Class I, ``L = 1.25``), one unknown input, ``y = x₂``:

    >>> import numpy as np
    >>> from nlobs.systems.timebase import Discrete
    >>> phi = lambda x: np.stack([np.zeros(x.shape[:-1]), -1.25 * np.tanh(x[..., 0])], axis=-1)
    >>> system = DiscreteUISystem([[-0.42, 1.0], [-0.6, 0.0]], [[1.0], [-0.65]], [[0.0, 1.0]], phi=phi,
    ...                           function_class=Lipschitz(1.25, 2), eta_w=0.2, eta_v=0.1, time=Discrete(1.0))
    >>> (system.n, system.p, system.l, system.n_w), system.H.tolist(), system.function_class.label
    ((2, 1, 1, 2), [[0.0]], 'Class I (Lipschitz)')
    >>> np.round(system.f(np.array([1.0, 0.0])), 4).tolist()  # A x + φ(x)
    [-0.42, -1.552]

    Three runs of ten steps from ``x₀ = 0`` with ``d = 1`` and no noise:

    >>> x, y = system.simulate(np.zeros((3, 2)), np.ones((3, 11, 1)), np.zeros((3, 10, 2)), np.zeros((3, 11, 1)))
    >>> x.shape, y.shape, x[0, 1].tolist()  # x₁ = G d₀
    ((3, 11, 2), (3, 11, 1), [1.0, -0.65])
    """

    A: Array
    G: Array
    C: Array
    H: Array
    B: Array
    D: Array
    W: Array
    phi: NonlinearPart | None
    function_class: FunctionClass
    eta_w: float
    eta_v: float
    x0: Array
    delta0: float
    time: Discrete
    name: str

    def __init__(
        self,
        A: ArrayLike,
        G: ArrayLike,
        C: ArrayLike,
        H: ArrayLike | None = None,
        *,
        B: ArrayLike | None = None,
        D: ArrayLike | None = None,
        W: ArrayLike | None = None,
        phi: NonlinearPart | None = None,
        function_class: FunctionClass | None = None,
        eta_w: float = 0.0,
        eta_v: float = 0.0,
        x0: ArrayLike | None = None,
        delta0: float = 0.0,
        time: Discrete,
        name: str = "system",
    ) -> None:
        A_ = as_square("A", A)
        n = A_.shape[0]
        if n == 0:
            raise DimensionError("A: the state dimension must be at least 1")
        G_ = as_matrix("G", G, (n, None))
        p = G_.shape[1]
        C_ = as_matrix("C", C, (None, n))
        l = C_.shape[0]
        if l == 0:
            raise DimensionError("C: at least one measurement is needed")
        H_ = np.zeros((l, p)) if H is None else as_matrix("H", H, (l, p))
        B_ = np.zeros((n, 0)) if B is None else as_matrix("B", B, (n, None))
        m = B_.shape[1]
        D_ = np.zeros((l, m)) if D is None else as_matrix("D", D, (l, m))
        W_ = np.eye(n) if W is None else as_matrix("W", W, (n, None))
        if not isinstance(time, Discrete):
            raise ModelError(f"time: a DiscreteUISystem needs a Discrete time base, got {time!r}")
        fc: FunctionClass = Lipschitz(0.0, n) if function_class is None else function_class
        if fc.n != n:
            raise DimensionError(f"function_class: built for n = {fc.n}, the system has n = {n}")
        if phi is not None and not callable(phi):
            raise InvalidArgumentError(f"phi: expected a callable (..., n) -> (..., n), got {type(phi).__name__}")
        x0_ = np.zeros(n) if x0 is None else as_vector("x0", x0, n)
        for k, v in (("A", A_), ("G", G_), ("C", C_), ("H", H_), ("B", B_), ("D", D_), ("W", W_), ("x0", x0_)):
            object.__setattr__(self, k, readonly(v))
        object.__setattr__(self, "phi", phi)
        object.__setattr__(self, "function_class", fc)
        object.__setattr__(self, "eta_w", positive("eta_w", eta_w, allow_zero=True))
        object.__setattr__(self, "eta_v", positive("eta_v", eta_v, allow_zero=True))
        object.__setattr__(self, "delta0", positive("delta0", delta0, allow_zero=True))
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "name", str(name))
        if phi is not None:
            probe = np.asarray(phi(np.zeros((2, n))), dtype=float)
            if probe.shape != (2, n):
                raise DimensionError(f"phi: must map (..., {n}) to (..., {n}); a (2, {n}) batch gave {probe.shape}")

    # ------------------------------------------------------------------ sizes
    @property
    def n(self) -> int:
        return self.A.shape[0]

    @property
    def p(self) -> int:
        """Number of unknown inputs."""
        return self.G.shape[1]

    @property
    def l(self) -> int:  # noqa: E743 - the paper's name
        """Number of measurements."""
        return self.C.shape[0]

    @property
    def m(self) -> int:
        return self.B.shape[1]

    @property
    def n_w(self) -> int:
        return self.W.shape[1]

    # ------------------------------------------------------------------ evaluation
    def f(self, x: ArrayLike, weights: ArrayLike | None = None) -> Array:
        """``f(x) = A x + φ(x)`` for a batch ``(..., n)``.

        With ``weights`` (shape ``(..., N)``, Class III only) ``φ`` is the LPV map
        ``Σᵢ λᵢ Aᵢ x`` of Definition 2.4 with these run-time weights instead of ``phi``.
        """
        x_ = np.asarray(x, dtype=float)
        out = x_ @ self.A.T
        if weights is not None:
            return out + np.einsum("...i,ijk,...k->...j", self.lpv_weights(weights), self._vertices(), x_)
        if self.phi is not None:
            out = out + np.asarray(self.phi(x_), dtype=float)
        return out

    def _vertices(self) -> Array:
        fc = self.function_class
        if not isinstance(fc, LPV):
            raise InvalidArgumentError(f"weights: run-time LPV weights need a Class III (LPV) system, not {fc.label}")
        return np.stack(fc.constituents)

    def lpv_weights(self, weights: ArrayLike, tol: float = 1e-9) -> Array:
        """Validated LPV weights: shape ``(..., N)``, entries in ``[0, 1]`` summing to 1 (Definition 2.4)."""
        N = self._vertices().shape[0]
        w = as_batch("weights", weights, N)
        if np.any(w < -tol) or np.any(np.abs(w.sum(axis=-1) - 1.0) > tol * N):
            raise InvalidArgumentError("weights: LPV weights must be non-negative and sum to 1 (Definition 2.4)")
        return w

    def nonlinear(self, x: ArrayLike) -> Array:
        """``φ(x)`` (zeros when there is none)."""
        x_ = np.asarray(x, dtype=float)
        if self.phi is None:
            return np.zeros_like(x_)
        return np.asarray(self.phi(x_), dtype=float)

    def step(self, x: Array, u: Array, d: Array, w: Array, weights: Array | None = None) -> Array:
        """``x⁺`` for batches (``u (..., m)``, ``d (..., p)``, ``w (..., n_w)``; LPV ``weights (..., N)``)."""
        return self.f(x, weights) + u @ self.B.T + d @ self.G.T + w @ self.W.T

    def output(self, x: Array, u: Array, d: Array, v: Array) -> Array:
        """``y = C x + D u + H d + v`` for batches."""
        return x @ self.C.T + u @ self.D.T + d @ self.H.T + v

    def simulate(self, x0: ArrayLike, d: ArrayLike, w: ArrayLike, v: ArrayLike,
                 u: ArrayLike | None = None, weights: ArrayLike | None = None) -> tuple[Array, Array]:
        """Simulate ``K`` steps for a batch: returns ``x`` of shape ``(B, K + 1, n)`` and ``y`` of ``(B, K + 1, l)``.

        ``x0``: ``(B, n)``; ``d``: ``(B, K + 1, p)``; ``w``: ``(B, K, n_w)``;
        ``v``: ``(B, K + 1, l)``; ``u``: ``(B, K + 1, m)`` (zero when omitted); ``weights``:
        LPV weights ``(B, K + 1, N)`` or ``(K + 1, N)`` (Class III only).
        """
        x0_ = as_batch("x0", x0, self.n)
        d_ = as_batch("d", d, self.p) if self.p else np.zeros(np.shape(d)[:-1] + (0,))
        B, K1 = d_.shape[0], d_.shape[1]
        w_ = as_batch("w", w, self.n_w)
        v_ = as_batch("v", v, self.l)
        u_ = np.zeros((B, K1, self.m)) if u is None else as_batch("u", u, self.m)
        if x0_.shape != (B, self.n) or w_.shape[:2] != (B, K1 - 1) or v_.shape[:2] != (B, K1) or u_.shape[:2] != (B, K1):
            raise DimensionError(f"simulate: inconsistent batch/time shapes x0 {x0_.shape}, d {d_.shape}, "
                                 f"w {w_.shape}, v {v_.shape}, u {u_.shape}")
        lam = None if weights is None else np.broadcast_to(self.lpv_weights(weights), (B, K1, self._vertices().shape[0]))
        x = np.empty((B, K1, self.n))
        x[:, 0] = x0_
        for k in range(1, K1):
            x[:, k] = self.step(x[:, k - 1], u_[:, k - 1], d_[:, k - 1], w_[:, k - 1],
                                None if lam is None else lam[:, k - 1])
        y = self.output(x, u_, d_, v_)
        return x, y

    # ------------------------------------------------------------------ from SymPy
    @classmethod
    def from_symbolic(
        cls,
        model: SymbolicModel,
        *,
        G: ArrayLike,
        C: ArrayLike,
        H: ArrayLike | None = None,
        A: ArrayLike | None = None,
        parameters: Mapping[str, float] | None = None,
        **kwargs: Any,
    ) -> DiscreteUISystem:
        """Build from a discrete :class:`~nlobs.systems.symbolic.SymbolicModel` (input-affine).

        ``f`` is the model's drift, compiled once; ``φ(x) = f(x) − A x`` with ``A``
        the given linear part (the Jacobian of ``f`` at ``x = 0`` when omitted).
        ``B`` is the model's (constant) input matrix. The model's own output map
        is not used: ``C``, ``H`` (and ``D``) are given here.
        """
        if not isinstance(model.time, Discrete):
            raise ModelError(f"{model.name}: needs a Discrete time base, got {model.time}")
        if model.drift is None or model.input_matrix is None:
            raise ModelError(f"{model.name}: needs an input-affine model x⁺ = f(x) + g u")
        subs = model.substituted(parameters)
        f = sp.Matrix(model.drift.subs(subs))
        g = sp.Matrix(model.input_matrix.subs(subs))
        if g.free_symbols:
            raise ModelError(f"{model.name}: the input matrix g must be constant, it depends on {sorted(map(str, g.free_symbols))}")
        X = sp.Matrix(model.x)
        zero = {s: 0.0 for s in model.x}
        A_ = (np.array(f.jacobian(X).subs(zero), dtype=float) if A is None else as_square("A", A))
        phi_expr = f - sp.Matrix(A_.tolist()) * X
        fn = compile_matrix(phi_expr, (model.x,), vector=True, what=f"{model.name}.phi")
        B_ = np.array(g, dtype=float) if model.m else np.zeros((model.n, 0))
        kwargs.setdefault("time", model.time)
        kwargs.setdefault("name", model.name)
        return cls(A_, G, C, H, B=B_, phi=fn, **kwargs)


# --------------------------------------------------------------------------- sampling tools


@dataclass(frozen=True)
class LipschitzEstimate:
    """A sampled estimate of a Lipschitz constant on a box (a lower bound of the true constant).

    Attributes
    ----------
    value : float
        ``max ‖φ(x₂) − φ(x₁)‖ / ‖x₂ − x₁‖`` over the sampled pairs.
    x1, x2 : ndarray
        The pair attaining it.
    n_pairs : int
        How many pairs were sampled.
    """

    value: float
    x1: Array
    x2: Array
    n_pairs: int

    @property
    def is_estimate(self) -> bool:
        """Always ``True``: sampling only ever gives a lower bound of the constant."""
        return True


def _box(lo: ArrayLike, hi: ArrayLike) -> tuple[Array, Array]:
    lo_ = as_vector("lo", lo)
    hi_ = as_vector("hi", hi, lo_.shape[0])
    if np.any(hi_ < lo_):
        raise InvalidArgumentError("hi: every upper bound must be >= the lower bound")
    return lo_, hi_


def _sample_pairs(lo: Array, hi: Array, n_pairs: int, seed: int, local_scale: float) -> tuple[Array, Array]:
    """Half the pairs uniform in the box, half close pairs (relative distance ``local_scale``)."""
    rng = np.random.default_rng(seed)
    n = lo.shape[0]
    k = n_pairs // 2
    x1 = lo + (hi - lo) * rng.random((n_pairs, n))
    x2 = lo + (hi - lo) * rng.random((n_pairs, n))
    step = local_scale * np.maximum(hi - lo, 1e-12) * rng.standard_normal((n_pairs - k, n))
    x2[k:] = np.clip(x1[k:] + step, lo, hi)
    return x1, x2


def estimate_lipschitz(phi: NonlinearPart, lo: ArrayLike, hi: ArrayLike, *, n_pairs: int = 20_000,
                       seed: int = 0, local_scale: float = 1e-4) -> LipschitzEstimate:
    """Estimate the Lipschitz constant of ``phi`` on the box ``[lo, hi]`` by sampling.

    Parameters
    ----------
    phi : callable
        Batched map ``(..., n) → (..., q)``.
    lo, hi : array_like, shape (n,)
        The box.
    n_pairs : int
        Number of sampled pairs: half uniform in the box, half close pairs
        (which approach the largest Jacobian norm).
    seed : int
        Seed of the random generator.
    local_scale : float
        Relative size of the close pairs.

    Returns
    -------
    LipschitzEstimate
        A *lower* estimate of the true constant on the box; sampling cannot give an
        upper bound. Use it to check a claimed constant, not as a certificate.
    """
    lo_, hi_ = _box(lo, hi)
    if int(n_pairs) < 2:
        raise InvalidArgumentError(f"n_pairs: must be at least 2, got {n_pairs!r}")
    x1, x2 = _sample_pairs(lo_, hi_, int(n_pairs), seed, positive("local_scale", local_scale))
    with np.errstate(invalid="ignore", over="ignore"):
        f1, f2 = np.asarray(phi(x1), dtype=float), np.asarray(phi(x2), dtype=float)
    for xs, fs in ((x1, f1), (x2, f2)):
        nf = ~np.all(np.isfinite(fs), axis=-1)
        if np.any(nf):
            i = int(np.argmax(nf))
            raise NonFiniteError(f"phi: not finite at x = {np.array2string(xs[i], precision=4)} in the box "
                                 f"(phi = {np.array2string(fs[i], precision=4)}); no Lipschitz constant can be estimated")
    df = f2 - f1
    dx = np.linalg.norm(x2 - x1, axis=-1)
    ok = dx > 0
    ratio = np.where(ok, np.linalg.norm(df, axis=-1) / np.where(ok, dx, 1.0), 0.0)
    i = int(np.argmax(ratio))
    return LipschitzEstimate(float(ratio[i]), readonly(x1[i]), readonly(x2[i]), int(n_pairs))


def check_function_class(phi: NonlinearPart, function_class: FunctionClass, lo: ArrayLike, hi: ArrayLike, *,
                         n_pairs: int = 20_000, seed: int = 0, rtol: float = 1e-9) -> Check:
    """Search sampled pairs in ``[lo, hi]`` for one that violates the claimed class of ``phi``.

    The margin of a pair is ``[Δφ; Δx]ᵀ M [Δφ; Δx] − γ`` (Khajenejad & Yong, (2)); a
    margin below ``−rtol (‖Δφ‖² + ‖Δx‖²) − rtol`` counts as a violation. For
    :class:`LPV` the margin is ``−d²``, ``d`` the distance of ``Δφ`` from the polytope
    ``{Σλᵢ Aᵢ Δx}`` (:meth:`LPV.polytope_gap`): the difference quotient of every pair must be a
    member of the class (which implies the Lipschitz bound ``σ̃ = maxᵢ ‖Aᵢ‖`` of Proposition 2.16).
    A non-finite ``φ`` value is a violation (margin ``-inf``).

    Parameters
    ----------
    phi : callable
        Batched map ``(..., n) → (..., n)``, the nonlinear part ``φ``.
    function_class : FunctionClass
        The claimed class (:class:`QuadraticConstraint`, :class:`Lipschitz`, :class:`QCStar` or :class:`LPV`).
    lo, hi : array_like, shape (n,)
        The box the pairs are sampled in.
    n_pairs : int, default 20000
        Number of sampled pairs: half uniform in the box, half close pairs.
    seed : int, default 0
        Seed of the random generator.
    rtol : float, default 1e-9
        Relative tolerance of the violation test.

    Returns
    -------
    Check
        ``passed``: no sampled pair violated the class (evidence, not proof); ``value``: the worst
        margin ``min (QC value − γ)`` (negative when violated; read against ``limit = 0``);
        ``evidence``: one line with the class, the verdict, the worst margin and its pair;
        ``values``: ``worst_margin``, the pair ``x1``, ``x2`` (read-only arrays), ``n_pairs`` and
        the class ``label``.
    """
    lo_, hi_ = _box(lo, hi)
    if lo_.shape[0] != function_class.n:
        raise DimensionError(f"lo: the box has dimension {lo_.shape[0]}, the class n = {function_class.n}")
    x1, x2 = _sample_pairs(lo_, hi_, int(n_pairs), seed, 1e-3)
    margin, rel = class_margins(phi, function_class, x1, x2, rtol=rtol)
    i = int(np.argmin(rel))
    holds, worst, label = bool(rel[i] >= 0), float(margin[i]), function_class.label
    what = "−(distance of Δφ from conv{AᵢΔx})²" if "LPV" in label else "QC − γ"
    ev = (f"{label}: {'no violation found' if holds else 'VIOLATED'} in {int(n_pairs)} sampled pairs; worst {what} = "
          f"{worst:.4g} at x1 = {np.array2string(x1[i], precision=4)}, x2 = {np.array2string(x2[i], precision=4)}")
    return Check.verdict(f"function class {label}", holds, ev, kind=CheckKind.FUNCTION_CLASS, method="sampled",
                         value=worst, limit=0.0,
                         values={"worst_margin": worst, "x1": readonly(x1[i]), "x2": readonly(x2[i]),
                                 "n_pairs": int(n_pairs), "label": label})


def class_margins(phi: NonlinearPart, function_class: FunctionClass, x1: ArrayLike, x2: ArrayLike, *,
                  rtol: float = 1e-9) -> tuple[Array, Array]:
    """Margins of the class condition at given pairs (batches ``(..., n)``), and the tolerance-adjusted margins.

    ``margin = [Δφ; Δx]ᵀ M [Δφ; Δx] − γ`` (``−d²`` for :class:`LPV`, ``d`` from :meth:`LPV.polytope_gap`;
    ``−inf`` where ``φ`` is not finite); a pair violates the class when the adjusted margin
    ``margin + rtol (‖Δφ‖² + ‖Δx‖² + 1)`` is negative. Shared by :func:`check_function_class` (sampled pairs)
    and the Monte Carlo runners (the pairs ``(x_k, x̂_k)`` the runs visit).

    Parameters
    ----------
    phi : callable
        Batched map ``(..., n) → (..., n)``, the nonlinear part ``φ``.
    function_class : FunctionClass
        The class whose condition is evaluated.
    x1, x2 : array_like, shape (..., n)
        The pairs (``Δx = x2 − x1``, ``Δφ = φ(x2) − φ(x1)``).
    rtol : float, default 1e-9
        Relative tolerance of the adjusted margin.

    Returns
    -------
    margin : ndarray, shape (...)
        The margins of the class condition.
    adjusted : ndarray, shape (...)
        ``margin + rtol (‖Δφ‖² + ‖Δx‖² + 1)``; negative where the pair violates the class.
    """
    x1_ = np.asarray(x1, dtype=float)
    x2_ = np.asarray(x2, dtype=float)
    with np.errstate(invalid="ignore", over="ignore"):
        dphi = np.asarray(phi(x2_), dtype=float) - np.asarray(phi(x1_), dtype=float)
        dx = x2_ - x1_
    bad = ~(np.all(np.isfinite(dphi), axis=-1) & np.all(np.isfinite(dx), axis=-1))
    dphi = np.where(bad[..., None], 0.0, dphi)
    dx = np.where(bad[..., None], 0.0, dx)
    if isinstance(function_class, LPV):
        margin = -function_class.polytope_gap(dphi, dx) ** 2
    else:
        margin = function_class.qc_value(dphi, dx) - function_class.gamma
    margin = np.where(bad, -np.inf, margin)
    scale = np.sum(dphi * dphi, axis=-1) + np.sum(dx * dx, axis=-1)
    return margin, margin + rtol * (scale + 1.0)
