r"""The unscented Kalman filter for any plant: continuous-discrete (Särkkä 2007) or discrete.

A :class:`~nlobs.observers.base.CorrectingObserver` whose state is a
:class:`~nlobs.observers.gaussian.FilterState`; it needs only the plant's ``rhs`` and ``output``.

Sigma points (Julier & Uhlmann 1997; the scaled form of Wan & van der Merwe 2000): with
``λ = α²(n + κ) − n`` and ``P = S Sᵀ``,

.. math:: \mathcal X_0 = m,\quad \mathcal X_{\pm i} = m \pm \sqrt{n + λ}\, S_{:, i},\qquad
          w^m_0 = \frac{λ}{n + λ},\ w^c_0 = w^m_0 + 1 − α² + β,\ w_{\pm i} = \frac{1}{2 (n + λ)}.

``S`` is the Cholesky factor of the symmetrised ``P``; where rounding has made ``P`` slightly
indefinite (Cholesky fails) it is ``V diag(√max(λᵢ, 0))`` from the eigen-decomposition ``P = V Λ Vᵀ``.

Continuous-time plant: ``rhs`` is the right-hand side of the moment ODEs of Särkkä (2007, "On unscented
Kalman filtering for state estimation of continuous-time nonlinear systems", IEEE TAC 52(9)),

.. math:: \dot m = f(\mathcal X) w_m,\qquad
          \dot P = \mathcal X W f(\mathcal X)^\top + f(\mathcal X) W \mathcal X^\top + Q,

with the sigma points regenerated from ``(m, P)`` at every evaluation, ``W = (I − w_m 1ᵀ) diag(w_c)
(I − w_m 1ᵀ)ᵀ``, i.e. ``Ṗ = Σᵢ w^c_i (𝒳ᵢ − m)(fᵢ − f̄)ᵀ + (…)ᵀ + Q``. Discrete-time plant: ``rhs``
is the unscented transform of ``f`` plus ``Q``.

Correction (sigma points of the prior): ``𝒴 = h(𝒳)``, ``ŷ = 𝒴 w_m``, ``P_yy``, ``P_xy``,
``S = P_yy + R``, ``K = P_xy S⁻¹``, ``m⁺ = m + K (y − ŷ)``. The covariance ``P − K S Kᵀ`` is written in
Joseph form with the statistical linearisation ``H = P_xyᵀ P⁺`` (``P⁺`` the pseudo-inverse) and the
effective noise ``R_eff = R + (P_yy − H P Hᵀ)``: then ``H P Hᵀ + R_eff = S``, the Joseph gain
``P Hᵀ S⁻¹`` is ``K`` and ``(I − KH) P (I − KH)ᵀ + K R_eff Kᵀ = P − K S Kᵀ`` exactly, while the form
keeps ``P`` positive semi-definite under rounding. ``P_yy − H P Hᵀ = P_yy − P_xyᵀ P⁺ P_xy`` is the Schur
complement of the sigma points' joint covariance of ``(x, y)``, so positive semi-definite for
non-negative weights ``w^c``: the linearisation error, added to the measurement noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nlobs._typing import Array
from nlobs._validate import in_range, positive
from nlobs.errors import InvalidArgumentError
from nlobs.observers.gaussian import ZERO_RATE, FilterState, GaussianFilterBase, symmetrised
from nlobs.observers.kalman import joseph_update

__all__ = ["UKF", "psd_sqrt", "sigma_weights"]


def sigma_weights(n: int, alpha: float, beta: float, kappa: float) -> tuple[Array, Array, float]:
    """Mean and covariance weights ``(w_m, w_c)`` of the ``2n + 1`` scaled sigma points, and ``n + λ``.

    ``λ = α²(n + κ) − n`` (Wan & van der Merwe 2000); the order is ``[0, +1 .. +n, −1 .. −n]``.

    Parameters
    ----------
    n : int
        State dimension.
    alpha, beta, kappa : float
        Sigma-point parameters: spread ``α``, prior knowledge ``β``, secondary scaling ``κ``.

    Returns
    -------
    w_m, w_c : ndarray, shape (2n + 1,)
        Mean and covariance weights.
    c : float
        ``n + λ = α²(n + κ)``.
    """
    lam = alpha**2 * (n + kappa) - n
    c = n + lam
    wm = np.full(2 * n + 1, 0.5 / c)
    wc = wm.copy()
    wm[0] = lam / c
    wc[0] = lam / c + 1.0 - alpha**2 + beta
    return wm, wc, c


def psd_sqrt(P: Array) -> Array:
    """``S`` with ``S Sᵀ = P`` for symmetric ``P`` ``(..., n, n)``: Cholesky, or eigen-decomposition per member.

    A member whose Cholesky factorisation fails (``P`` singular or made slightly indefinite by rounding)
    gets ``V diag(√max(λ, 0))`` from ``P = V Λ Vᵀ``; the others keep their Cholesky factor.

    Parameters
    ----------
    P : ndarray, shape (..., n, n)
        Symmetric positive semi-definite matrices.

    Returns
    -------
    ndarray, shape (..., n, n)
        ``S`` with ``S Sᵀ = P`` (lower triangular where the Cholesky factorisation succeeds).
    """
    try:
        return np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        pass
    n = P.shape[-1]
    flat = P.reshape(-1, n, n)
    out = np.empty_like(flat)
    for i, Pi in enumerate(flat):  # the rare path: only where a batch holds a failing member
        try:
            out[i] = np.linalg.cholesky(Pi)
        except np.linalg.LinAlgError:
            lam, V = np.linalg.eigh(Pi)
            out[i] = V * np.sqrt(np.maximum(lam, 0.0))
    return out.reshape(P.shape)


@dataclass(frozen=True, eq=False)
class UKF(GaussianFilterBase):
    r"""Unscented Kalman filter (continuous-discrete of Särkkä (2007) for a continuous plant, discrete otherwise).

    Parameters
    ----------
    plant : PlantModel
        The model (``rhs`` and ``output``, batched; no Jacobians needed).
    Q : array_like, shape (n, n)
        Symmetric positive semi-definite process noise: spectral density (continuous plant) or
        covariance of ``w_k`` (discrete plant).
    R : array_like, shape (p, p)
        Symmetric positive definite covariance of the noise on all outputs.
    P0 : array_like, shape (n, n)
        Symmetric positive semi-definite initial covariance.
    alpha, beta, kappa : float
        Sigma-point parameters (Julier & Uhlmann; Wan & van der Merwe): spread ``α > 0``, prior
        knowledge ``β ≥ 0`` (2 for a Gaussian), ``κ`` with ``n + λ = α²(n + κ) > 0``. The defaults
        ``α = 1, β = 2, κ = 0`` (``λ = 0``) are Särkkä's and keep every covariance weight
        non-negative.
    name : str
        Label in results.
    record_covariance : bool
        Also record the full ``P`` among the diagnostics.
    bounds : StateBounds, optional
        Bounds on the state: the mean is projected onto them after each correction (Simon 2010).

    Notes
    -----
    The moment ODEs, the sigma points and the Joseph form of the correction are in the module
    docstring (Särkkä 2007; Julier & Uhlmann 1997; Wan & van der Merwe 2000).

    Raises
    ------
    InvalidArgumentError
        A covariance that is not positive (semi-)definite, ``α ≤ 0``, ``β < 0`` or ``n + λ ≤ 0``.
    DimensionError, NonFiniteError, NotSymmetricError
        For ``Q``, ``R``, ``P0`` of the wrong shape, with a non-finite entry, not symmetric.

    Examples
    --------
    The Van der Pol oscillator in Liénard form (a shipped model; the UKF uses no Jacobian) with ``x1`` sampled
    at 10 Hz, started 2 off in ``x1`` and 1 in ``x2``: the first sample corrects ``x1`` at once, ``x2``
    follows:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup
    >>> plant = nlobs.load_model("vanderpol-lienard").compile()
    >>> ukf = nlobs.UKF(plant, Q=1e-4 * np.eye(2), R=[[1e-4]], P0=np.eye(2))
    >>> res = nlobs.simulate(plant, ukf, [2.0, 0.0], [0.0, 1.0], duration=3.0, dt=1e-2, u=0.0,
    ...                      measurements=MeasurementGroup("position", ["y"], rate=10.0))
    >>> np.abs(res.error[0]).round(3), bool(res.error_norm[-1] < 1e-4)
    (array([0., 1.]), True)
    >>> np.sqrt(res.extras["P_diag"][-1]).round(3)  # standard deviations of x1 and x2
    array([0.004, 0.012])
    """

    alpha: float = field(default=1.0, kw_only=True)
    beta: float = field(default=2.0, kw_only=True)
    kappa: float = field(default=0.0, kw_only=True)
    name: str = field(default="UKF", kw_only=True)
    wm: Array = field(init=False, repr=False)
    wc: Array = field(init=False, repr=False)
    spread: float = field(init=False, repr=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        alpha = positive("alpha", self.alpha)
        beta = positive("beta", self.beta, allow_zero=True)
        kappa = in_range("kappa", self.kappa, -np.inf, np.inf, lo_open=True, hi_open=True)
        n = self.n
        if alpha**2 * (n + kappa) <= 0:
            raise InvalidArgumentError(f"kappa: n + λ = α²(n + κ) = {alpha**2 * (n + kappa):g} must be positive "
                                       f"(n = {n}, α = {alpha:g}, κ = {kappa:g})")
        wm, wc, c = sigma_weights(n, alpha, beta, kappa)
        for name, val in (("alpha", alpha), ("beta", beta), ("kappa", kappa), ("spread", np.sqrt(c))):
            object.__setattr__(self, name, float(val))
        wm.setflags(write=False)
        wc.setflags(write=False)
        object.__setattr__(self, "wm", wm)
        object.__setattr__(self, "wc", wc)

    def sigma_points(self, x: Array, P: Array) -> Array:
        """The ``2n + 1`` sigma points of ``(x, P)``, shape ``(..., 2n + 1, n)`` (module docstring)."""
        if x.ndim == 1 and P.ndim == 2:  # one run: the same operations without broadcasting
            # (concatenated, not written into np.empty: the layout it gives decides the BLAS product downstream)
            D = self.spread * psd_sqrt(0.5 * (P + P.T)).T
            return np.concatenate((x[None, :], x + D, x - D))
        S = psd_sqrt(symmetrised(P))
        D = self.spread * np.swapaxes(S, -1, -2)  # rows: the scaled columns of S
        m = x[..., None, :]
        batch = np.broadcast_shapes(x.shape[:-1], P.shape[:-2])
        return np.concatenate([np.broadcast_to(m, batch + (1, self.n)), m + D, m - D], axis=-2)

    @staticmethod
    def _with_points(u: Array, X: Array) -> Array:
        u = np.asarray(u, dtype=float)
        return np.broadcast_to(u[..., None, :], X.shape[:-1] + u.shape[-1:])

    def rhs(self, t: float, z: FilterState, u: Array, y: Array) -> FilterState:
        """Särkkä's moment ODEs (continuous plant) or the unscented prediction (discrete plant)."""
        X = self.sigma_points(z.x, z.P)
        if X.ndim == 2 and not self.discrete and np.ndim(u) == 1:  # one run, continuous plant
            uu = np.asarray(u, dtype=float)
            FX = self.plant.rhs(t, X, np.broadcast_to(uu, (X.shape[0], uu.shape[0])))  # u for each sigma point
            m = np.einsum("l,ln->n", self.wm, FX)
            dF = FX - m
            A = ((X - z.x) * self.wc[:, None]).T.dot(dF)
            return FilterState(m, A + A.T + self.Q, ZERO_RATE if np.ndim(z.nis) == 0 else np.zeros(np.shape(z.nis)))
        FX = self.plant.rhs(t, X, self._with_points(u, X))
        m = np.einsum("l,...ln->...n", self.wm, FX)
        dF = FX - m[..., None, :]
        if self.discrete:
            P = np.swapaxes(dF * self.wc[:, None], -1, -2) @ dF + self.Q
            return FilterState(x=m, P=symmetrised(P), nis=z.nis)
        A = np.swapaxes((X - z.x[..., None, :]) * self.wc[:, None], -1, -2) @ dF  # Σ w_c (𝒳 − m)(f − f̄)ᵀ
        return FilterState(x=m, P=A + np.swapaxes(A, -1, -2) + self.Q, nis=np.zeros(np.shape(z.nis)))

    def _update(self, t: float, x: Array, P: Array, u: Array, y: Array, rows: Any) -> tuple[Array, Array, Array]:
        X = self.sigma_points(x, P)
        Y = self.plant.output(t, X, self._with_points(u, X))
        if rows is not None:
            Y = Y[..., rows]
        y_hat = np.einsum("l,...lp->...p", self.wm, Y)
        dY = Y - y_hat[..., None, :]
        dXw = np.swapaxes((X - x[..., None, :]) * self.wc[:, None], -1, -2)  # (..., n, L)
        Pxy = dXw @ dY
        Pyy = np.swapaxes(dY * self.wc[:, None], -1, -2) @ dY
        Ps = symmetrised(P)
        H = np.swapaxes(np.linalg.pinv(Ps, hermitian=True) @ Pxy, -1, -2)  # Pxyᵀ P⁺ (P symmetric)
        R_eff = symmetrised(self._R_rows(rows) + Pyy - H @ Ps @ np.swapaxes(H, -1, -2))
        dx, P_new, nis = joseph_update(Ps, H, R_eff, y - y_hat, nis=True)
        return x + dx, P_new, nis
