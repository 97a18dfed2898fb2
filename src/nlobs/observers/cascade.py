r"""The observer of Grip, Saberi & Johansen for cascade and feedback-interconnected systems (Secs. 2–4).

A nonlinear subsystem Σ₁ (1a) (or Σ₁* (2)) whose output ``z`` is not measured drives a linear
subsystem Σ₂ (1b) that is (partially) measured (:mod:`nlobs.systems.interconnected`). Given an
observer ``x̂̇ = f(u, x̂) + g(u, x̂, z)`` (3) (``f(u, w, x̂) + g(u, x̂, w, z)`` (16)) for the
nonlinear part, the complete observer is, in the cascade case,

.. math::

    \dot{\hat w} &= A\hat w + B_u u + B_z\hat z + K_w\,\tilde y, \qquad (9a) \\
    \dot\xi &= -\partial_x h(u, \hat x)\, g(u, \hat x, \hat z) + K_z\,\tilde y, \qquad (9b) \\
    \hat z &= h(u, \hat x) + \xi, \qquad (9c) \\
    \dot{\hat x} &= f(u, \hat x) + g(u, \hat x, \hat z), \qquad (10)

with ``ỹ = y − C ŵ − D_u u − D_z ẑ``, and in the feedback case (17)–(18):
``h``, ``f`` and ``g`` also take ``ŵ`` and (17b) gains the term
``−∂_w h(u, ŵ, x̂) K_w ỹ``. With ``K = [K_w; K_z]`` the error of
``w_e = [w; z]`` obeys (12a)/(20a), ``w̃̇_e = (𝔄 − Kℭ) w̃_e + 𝔅_d d̃``, and
Theorem 1 (1') gives global exponential stability when ``𝔄 − Kℭ`` is Hurwitz
and ``‖H‖∞ < γ``, ``H(s) = (sI − 𝔄 + Kℭ)⁻¹𝔅_d`` (13).

**No ``u̇`` is needed.** The function ``d`` of Assumption 3 contains
``∂_u h · u̇``, but the observer never evaluates ``d``: ``ẑ = h(u, x̂) + ξ`` (9c)
is evaluated with the current ``u(t)``, so its time derivative picks up
``∂_u h · u̇`` by itself and ``ẑ̇ = d(u, u̇, x̂) + K_z ỹ`` (11) holds exactly for a
differentiable ``u``. (With a piecewise-constant ``u`` both ``z`` and ``ẑ`` jump
together with ``h``; the jump of the error is ``h(u⁺,x) − h(u⁺,x̂) − h(u⁻,x) + h(u⁻,x̂)``.)
``u̇`` only enters the analysis through ``L₂`` (Assumption 3 needs it bounded).

Where the rest lives
--------------------
* the plant: :mod:`nlobs.systems.interconnected` (:class:`~nlobs.systems.interconnected.NonlinearSubsystem`,
  :class:`~nlobs.systems.interconnected.LinearSubsystem`, :func:`~nlobs.systems.interconnected.interconnected_plant`);
* Assumption 4 and the extended system (8c): :mod:`nlobs.linear.assumption4`;
* the gain: :mod:`nlobs.synthesis.cascade_gain` (LMIs (14)–(15), pole placement) and the bounds of
  Theorem 1 / 1' and Assumption 1: :mod:`nlobs.synthesis.cascade_bounds`;
* Sec. 3.2's γ sweep (design and simulate for decreasing ``γ``): :mod:`nlobs.workflows.gamma_sweep`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_batch, as_matrix, readonly
from nlobs.errors import InvalidArgumentError
from nlobs.linear.assumption4 import extended_system
from nlobs.synthesis.certificate import ObserverGainCertificate
from nlobs.systems.interconnected import LinearSubsystem, NonlinearSubsystem, check_interconnection
from nlobs.systems.timebase import CONTINUOUS, TimeBase
from nlobs.observers.base import ToControl

__all__ = ["CascadeObserver"]


@dataclass(frozen=True, eq=False)
class CascadeObserver(ToControl):
    r"""The observer (9)–(10) (cascade) or (17)–(18) (feedback) of Grip, Saberi & Johansen.

    Observer state ``[x̂, ŵ, ξ]`` (``n_x + n_w + p_z``); :meth:`estimate` returns
    ``[x̂, ŵ]`` (the plant state of :func:`~nlobs.systems.interconnected.interconnected_plant`), :meth:`z_hat`
    returns ``ẑ = h(u, [ŵ,] x̂) + ξ`` (9c)/(17d). Satisfies
    :class:`~nlobs.observers.base.Observer`.

    Parameters
    ----------
    sigma1 : NonlinearSubsystem
        Σ₁ (or Σ₁*) with the injection ``g`` of its existing observer.
    sigma2 : LinearSubsystem
        Σ₂.
    K : array_like, shape (n_w + p_z, p_y)
        ``[K_w; K_z]``, e.g. ``nlobs.synthesis.cascade_gain.design_cascade_gain(...).gain``. It is not required to
        be certified here, but ``𝔄 − Kℭ`` must be Hurwitz (checked).

    Attributes
    ----------
    K_w, K_z : ndarray
        The blocks of ``K``.
    time : Continuous
    state_names : tuple of str
        ``x̂``/``ŵ`` names with ``_hat`` and ``xi_<z>`` for ``ξ``.

    Examples
    --------
    Example 1 of Grip, Saberi & Johansen: the output ``z = x2`` of Σ₁, ``ẋ1 = x2``, ``ẋ2 = x1 − x2 + 0.4 sin x1``,
    is not measured; it drives the filter Σ₂ = 1/(s² + s + 1), whose output ``y = w1`` is. The observer (3) of
    Σ₁ is Rajamani's, ``g = L (z − x̂2)`` with ``L = [69.6, 11.6]``; ``K`` places the eigenvalues of
    ``𝔄 − Kℭ`` (12a) at −20 and ``−10 ± 10√3 j`` (characteristic polynomial ``s³ + 40 s² + 800 s + 8000``),
    which makes ``‖H‖∞`` of (13) about 0.1:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.linear import hinf_norm
    >>> from nlobs.synthesis import extended_system
    >>> from nlobs.systems import LinearSubsystem, NonlinearSubsystem, interconnected_plant
    >>> sigma1 = NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=["x2", "x1 - x2 + 0.4*sin(x1)"],
    ...                                      h=["x2"], g=["69.6*(z - x2)", "11.6*(z - x2)"])
    >>> sigma2 = LinearSubsystem([[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.CascadeObserver(sigma1, sigma2, [[39.0], [760.0], [8000.0]])
    >>> np.poly(observer.error_matrix).round(6).tolist()
    [1.0, 40.0, 800.0, 8000.0]
    >>> ext = extended_system(sigma2.A, sigma2.B_z, sigma2.C, sigma2.D_z)
    >>> round(hinf_norm(observer.error_matrix, ext.Bd, np.eye(3)), 2)
    0.1
    >>> plant = interconnected_plant(sigma1, sigma2)  # state [x1, x2, w1, w2], output y
    >>> res = nlobs.simulate(plant, observer, [1.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], duration=4.0, dt=1e-2)
    >>> e = res.error_norm
    >>> round(float(e[0]), 3), bool(e[-1] < 1e-3 * e[0])
    (1.414, True)
    """

    sigma1: NonlinearSubsystem
    sigma2: LinearSubsystem
    K: Array
    time: TimeBase = field(default=CONTINUOUS, init=False)
    state_names: tuple[str, ...] = field(default=(), init=False)

    def __post_init__(self) -> None:
        check_interconnection(self.sigma1, self.sigma2)
        s2 = self.sigma2
        K = as_matrix("K", self.K, (s2.n_w + s2.p_z, s2.p_y))
        object.__setattr__(self, "K", readonly(K))
        ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
        eig = np.linalg.eigvals(ext.A - K @ ext.C)
        if np.max(eig.real) >= 0:
            raise InvalidArgumentError(
                f"K: 𝔄 − Kℭ is not Hurwitz (max Re λ = {np.max(eig.real):.6g}); design K with design_cascade_gain"
            )
        names = (
            *(f"{s}_hat" for s in self.sigma1.states),
            *(f"{s}_hat" for s in s2.states),
            *(f"xi_{s}" for s in self.sigma1.outputs),
        )
        object.__setattr__(self, "state_names", names)
        Bu, Du = s2.input_matrices(self.sigma1.m)
        object.__setattr__(self, "_BuT", np.ascontiguousarray(Bu.T))
        object.__setattr__(self, "_DuT", np.ascontiguousarray(Du.T))

    @classmethod
    def from_certificate(
        cls, sigma1: NonlinearSubsystem, sigma2: LinearSubsystem, certificate: ObserverGainCertificate
    ) -> CascadeObserver:
        """Build the observer with a certified gain (refuses a failed certificate)."""
        if not certificate.verified:
            raise InvalidArgumentError(
                "certificate: not verified (failed: " + ", ".join(c.name for c in certificate.failed_checks) + ")"
            )
        return cls(sigma1, sigma2, certificate.gain)

    # ------------------------------------------------------------------ sizes
    @property
    def n_x(self) -> int:
        """Size of the estimate ``[x̂, ŵ]``."""
        return self.sigma1.n_x + self.sigma2.n_w

    @property
    def n_z(self) -> int:
        """Size of the observer state ``[x̂, ŵ, ξ]``."""
        return self.sigma1.n_x + self.sigma2.n_w + self.sigma2.p_z

    @property
    def K_w(self) -> Array:
        """``K_w`` (first ``n_w`` rows of ``K``)."""
        return self.K[: self.sigma2.n_w]

    @property
    def K_z(self) -> Array:
        """``K_z`` (last ``p_z`` rows of ``K``)."""
        return self.K[self.sigma2.n_w :]

    @property
    def error_matrix(self) -> Array:
        """``𝔄 − Kℭ`` of (12a)/(20a)."""
        s2 = self.sigma2
        ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
        return ext.A - self.K @ ext.C

    # ------------------------------------------------------------------ state
    def _split(self, z: Array) -> tuple[Array, Array, Array]:
        nx, nw = self.sigma1.n_x, self.sigma2.n_w
        return z[..., :nx], z[..., nx : nx + nw], z[..., nx + nw :]

    def init(self, x_hat0: ArrayLike) -> Array:
        """Observer state from ``[x̂₀, ŵ₀]`` with ``ξ₀ = 0`` (so ``ẑ₀ = h(u₀, [ŵ₀,] x̂₀)``)."""
        xw = np.array(as_batch("x_hat0", x_hat0, self.n_x), dtype=float)
        return np.concatenate([xw, np.zeros((*xw.shape[:-1], self.sigma2.p_z))], axis=-1)

    def init_state(self, x_hat0: ArrayLike, w_hat0: ArrayLike, z_hat0: ArrayLike, u0: ArrayLike | None = None) -> Array:
        """Observer state with a chosen initial ``ẑ₀``: ``ξ₀ = ẑ₀ − h(u₀, [ŵ₀,] x̂₀)``."""
        xh = as_batch("x_hat0", x_hat0, self.sigma1.n_x)
        wh = as_batch("w_hat0", w_hat0, self.sigma2.n_w)
        zh = as_batch("z_hat0", z_hat0, self.sigma2.p_z)
        uu = np.zeros(self.sigma1.m) if u0 is None else as_batch("u0", u0, self.sigma1.m)
        xi = zh - self.sigma1.h(uu, wh, xh)
        batch = np.broadcast_shapes(xh.shape[:-1], wh.shape[:-1], xi.shape[:-1])
        return np.concatenate(
            [np.broadcast_to(a, (*batch, a.shape[-1])) for a in (xh, wh, xi)], axis=-1
        )

    def estimate(self, z: Array) -> Array:
        """``[x̂, ŵ]``, shape ``(..., n_x + n_w)``."""
        return z[..., : self.n_x]

    def z_hat(self, z: Array, u: ArrayLike | None = None) -> Array:
        """``ẑ = h(u, [ŵ,] x̂) + ξ`` (9c)/(17d); ``u`` defaults to zero (needed only if ``h`` uses ``u``)."""
        z = np.asarray(z, dtype=float)
        xh, wh, xi = self._split(z)
        uu = np.zeros((*z.shape[:-1], self.sigma1.m)) if u is None else np.asarray(u, dtype=float)
        return self.sigma1.h(uu, wh, xh) + xi

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``[x̂̇, ŵ̇, ξ̇]`` of (9)–(10) or (17)–(18) for batches."""
        s1, s2 = self.sigma1, self.sigma2
        xh, wh, xi = self._split(np.asarray(z, dtype=float))
        zh = s1.h(u, wh, xh) + xi  # (9c) / (17d)
        ytil = y - wh @ s2.C.T - u @ self._DuT - zh @ s2.D_z.T  # type: ignore[attr-defined]
        gg = s1.g(u, xh, wh, zh)
        dxh = s1.f(u, wh, xh) + gg  # (10) / (18)
        dwh = wh @ s2.A.T + u @ self._BuT + zh @ s2.B_z.T + ytil @ self.K_w.T  # (9a) / (17a)
        dxi = -np.einsum("...ij,...j->...i", s1.h_x(u, wh, xh), gg) + ytil @ self.K_z.T  # (9b) / (17b)
        if s1.feedback:
            dxi = dxi - np.einsum("...ij,...j->...i", s1.h_w(u, wh, xh), ytil @ self.K_w.T)  # (17b)
        batch = np.broadcast_shapes(dxh.shape[:-1], dwh.shape[:-1], dxi.shape[:-1])
        return np.concatenate([np.broadcast_to(a, (*batch, a.shape[-1])) for a in (dxh, dwh, dxi)], axis=-1)
