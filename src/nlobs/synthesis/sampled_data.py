r"""What a continuous-time observer certificate still guarantees under sampled, noisy sensors.

The setting (``docs/sampled-data.md``)
--------------------------------------
A continuous design certifies, on a region, a quadratic Lyapunov function ``V = eᵀPe`` of the estimation
error with

.. math:: \dot V \le -2\alpha V + 2 e^\top P K \delta \qquad (1)

where ``δ = w − y`` is what the output fed to the observer differs from the plant's output by (``δ = 0``
for a continuous exact output) and ``K`` the observer's output-injection gain (``L`` of a Luenberger or Thau
observer). The sensors are groups ``j`` of outputs sampled with period ``T_j``, ``y_{j,k} = h_j(x(t_k)) + v_{j,k}``
with ``v_{j,k}`` of covariance ``R_j``, and the plant has process noise ``dx = F dt + W dβ``. Run through the
inter-sample output predictor of Karafyllis & Kravaris (2009) (:mod:`nlobs.observers.sampled`), group ``j``'s
discrepancy is

.. math:: \delta_j(t) = v_{j,k} + \int_{t_k}^{t} \big(L_F h_j(\hat x) - L_F h_j(x)\big)\,ds
          - \int_{t_k}^{t} \frac{\partial h_j}{\partial x} W\, d\beta ,

and ``|L_F h_j(x̂) − L_F h_j(x)| ≤ ℓ_j |e|_P`` on the region (``|e|_P = √V``; ``ℓ_j`` the largest
``‖J_j(ξ) P^{-1/2}‖₂``, ``J_j`` the Jacobian of ``L_F h_j``).

The bound
---------
With ``κ_j = ‖P^{1/2} K_j‖₂`` (``K_j``: the columns of ``K`` for group ``j``), Young's inequality on each
term of (1), Itô's formula and the Lyapunov–Krasovskii functional of the input-delay approach to sampled-data
systems (Fridman, *Introduction to Time-Delay Systems*, 2014, Sec. 7.1; Fridman, Automatica 46, 2010)

.. math:: \mathcal W = V + \sum_j c_j \int_{t-T_j}^{t} (s - t + T_j)\, V(e(s))\, ds,
          \qquad c_j = \frac{(1+\eta)\,\kappa_j^2 \ell_j^2 T_j}{\beta_j},

give ``E 𝒲̇ ≤ −σ E𝒲 + N`` with

.. math::

    a = 2\alpha - 2\sqrt{1+\eta}\,\sum_j \kappa_j \ell_j T_j - \sum_j \varepsilon_j, \qquad
    \sigma = \min\Big(a,\ \frac{\eta}{(1+\eta)\max_j T_j}\Big), \\
    N = \sum_j \frac{\operatorname{tr}(K_j^\top P K_j R_j) + |P^{1/2}K_j b_j|^2 + T_j\, q_j}{\varepsilon_j}
        + \operatorname{tr}(W^\top P W),

``q_j`` the largest ``‖P^{1/2}K_j (∂h_j/∂x) W‖_F²`` on the region and ``b_j`` a sensor bias. An error that
also carries a bounded drift ``d`` (``|d| ≤ β``: the Itô term of a change of coordinates, the drift observer's
``½ tr(∇²Φ_s W Wᵀ)``) adds ``2eᵀPd ≤ ε_d V + λ_max(P) β² / ε_d``: one more ``ε`` in ``a`` and one more term in ``N``,
chosen with the others (the ``drift`` argument). Hence, while the state and the estimate stay in the region,

.. math:: E|e(t)|^2 \le \frac{e^{-\sigma t}\,\operatorname{tr}(P\Sigma_0) + N/\sigma}{\lambda_{\min}(P)} . \qquad (2)

Without noise (``N = 0``) the error decays to zero whenever ``a > 0`` for some ``η``, i.e. whenever

.. math:: \sum_j T_j / T_{\max,j} < 1, \qquad T_{\max,j} = \frac{\alpha}{\kappa_j \ell_j}, \qquad (3)

the *sampling budget*: ``T_{max,j}`` is the longest period group ``j`` may have when every other output is
continuous. A held sample (zero-order hold) instead leaves ``δ_j = y(t_k) − y(t)``, which does not vanish with the
error: no convergence, and (3) does not apply.

:func:`sampled_data_bound` computes ``T_{max,j}``, the budget, and the mean-square bound (2) with ``η`` and
``ε_j`` chosen to make it smallest (``ε_j ∝`` the square root of group ``j``'s noise term, a one-dimensional
search for their sum, a grid in ``η``); for sample noise bounded by ``v̄_j`` and no process noise the same steps with
``|P^{1/2}K_j v_j|² ≤ κ_j² v̄_j²`` give the ultimate bound ``limsup |e|² ≤ N_v/(σ λ_min(P))`` (input-to-state,
:meth:`SampledDataBound.ultimate_bound`); :func:`verify_sampled_data_bound` recomputes every number from the
stored matrices with NumPy (no solver is involved at all; the continuous certificate behind ``α`` is the
design's own, re-verified there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs.checks import Check, CheckKind
from nlobs.errors import InvalidArgumentError
from nlobs.synthesis.certificate import CertificateMixin, checks_dict
from nlobs.synthesis.lmi import psd_sqrt

__all__ = ["GroupNoise", "SampledDataBound", "SampledDesignCertificate", "as_noise_bounds", "sampled_data_bound",
           "verify_sampled_data_bound"]

#: The grid of ``η`` searched for the smallest bound (2).
ETA_GRID = tuple(float(v) for v in np.geomspace(1e-3, 1e3, 61))


def as_noise_bounds(value: float | Sequence[float], groups: int) -> Array:
    """``v̄_j`` of the bounded-noise (input-to-state) bounds, one per sensor group: non-negative and finite.

    Parameters
    ----------
    value : float or sequence of float
        One bound per group, or one for every group.
    groups : int
        How many groups.
    """
    try:
        v = np.broadcast_to(np.asarray(value, dtype=float), (groups,))
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"`noise_bounds`: expected {groups} non-negative numbers, got {value!r}") from None
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise InvalidArgumentError(f"`noise_bounds`: expected non-negative finite numbers, got {value!r}")
    return v


def _finite_positive(name: str, value: float, *, zero: bool = False) -> float:
    v = float(value)
    if not math.isfinite(v) or v < 0 or (v == 0 and not zero):
        raise InvalidArgumentError(f"{name}: expected a {'non-negative' if zero else 'positive'} finite number, "
                                   f"got {value!r}")
    return v


def _psd(name: str, value: ArrayLike, size: int) -> Array:
    M = np.asarray(value, dtype=float)
    if M.shape != (size, size):
        raise InvalidArgumentError(f"{name}: expected shape ({size}, {size}), got {M.shape}")
    if not np.all(np.isfinite(M)):
        raise InvalidArgumentError(f"{name}: non-finite entries")
    M = (M + M.T) / 2
    if size and np.linalg.eigvalsh(M)[0] < -1e-12 * max(1.0, float(np.abs(M).max())):
        raise InvalidArgumentError(f"{name}: not positive semidefinite")
    return M


@dataclass(frozen=True)
class GroupNoise:
    """One sensor group as the bound (2) sees it.

    Attributes
    ----------
    name : str
        The group's name.
    index : tuple of int
        The outputs it samples (columns of ``K``).
    period : float
        Its sample period ``T_j`` (``0``: a continuous output).
    R : ndarray, shape (p_j, p_j)
        Covariance of one sample's noise.
    ell : float
        ``ℓ_j``: a Lipschitz constant of ``L_F h_j`` from ``|e|_P`` (module docstring).
    q : float
        ``q_j``: the largest ``‖P^{1/2} K_j (∂h_j/∂x) W‖_F²`` on the region (process noise seen between samples).
    bias : ndarray, shape (p_j,)
        A constant offset of every sample (zeros: none).
    """

    name: str
    index: tuple[int, ...]
    period: float
    R: Array
    ell: float
    q: float = 0.0
    bias: Array = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        p = len(self.index)
        _finite_positive(f"sensor group {self.name!r}: period", self.period, zero=True)
        _finite_positive(f"sensor group {self.name!r}: ell", self.ell, zero=True)
        _finite_positive(f"sensor group {self.name!r}: q", self.q, zero=True)
        object.__setattr__(self, "index", tuple(int(i) for i in self.index))
        object.__setattr__(self, "R", _psd(f"sensor group {self.name!r}: R", self.R, p))
        b = np.zeros(p) if np.asarray(self.bias).size == 0 else np.asarray(self.bias, dtype=float).reshape(p)
        if not np.all(np.isfinite(b)):
            raise InvalidArgumentError(f"sensor group {self.name!r}: bias: non-finite entries")
        object.__setattr__(self, "bias", b)

    @property
    def gap(self) -> float:
        """The longest time between two samples (the ``period`` of the bound)."""
        return self.period


@dataclass(frozen=True, eq=False)
class SampledDataBound(CertificateMixin):
    """The sampling budget (3) and the mean-square bound (2) of a design under its sensors (module docstring).

    Attributes
    ----------
    P : ndarray, shape (n, n)
        The Lyapunov matrix of the continuous certificate.
    gain : ndarray, shape (n, p)
        The output-injection gain ``K``.
    alpha : float
        The decay rate ``α`` of (1).
    groups : tuple of GroupNoise
        The sensor groups.
    process : ndarray, shape (n, n)
        ``W Wᵀ``, the process-noise intensity (per unit time).
    p0 : ndarray, shape (n, n) or None
        Covariance of the initial error (``None``: the bound is the ultimate one only).
    eta : float
        The ``η`` of the functional.
    eps : tuple of float
        The ``ε_j`` of Young's inequality on the noise terms.
    kappa : tuple of float
        ``κ_j = ‖P^{1/2} K_j‖₂``.
    t_max : tuple of float
        ``T_{max,j} = α / (κ_j ℓ_j)`` (``inf`` when ``κ_j ℓ_j = 0``).
    budget : float
        ``Σ_j T_j / T_{max,j}``: below 1, the convergence survives the sampling.
    a : float
        The decay of ``V`` in ``E𝒲̇``.
    sigma : float
        The decay ``σ`` of (2).
    N : float
        The noise term ``N`` of (2).
    lam_min : float
        ``λ_min(P)``.
    v0 : float
        ``tr(P Σ0)`` (0 without ``p0``).
    checks : tuple of Check
        ``P ≻ 0``, the budget (3) ``< 1``, ``σ > 0``, each recomputed in NumPy.
    drift : float
        ``β``: a bound of the error's drift ``|d|`` (module docstring; 0 for none). ``eps`` then has one more
        entry, its ``ε_d``.
    """

    P: Array
    gain: Array
    alpha: float
    groups: tuple[GroupNoise, ...]
    process: Array
    p0: Array | None
    eta: float
    eps: tuple[float, ...]
    kappa: tuple[float, ...]
    t_max: tuple[float, ...]
    budget: float
    a: float
    sigma: float
    N: float
    lam_min: float
    v0: float
    checks: tuple[Check, ...]
    drift: float = 0.0

    @property
    def solver(self) -> None:
        """No solver: every number is a closed form of the stored matrices."""
        return None

    @property
    def ultimate_ms(self) -> float:
        """``limsup E|e|² ≤ N / (σ λ_min(P))`` (``inf`` when the budget is spent)."""
        if not (self.sigma > 0 and self.lam_min > 0):
            return math.inf
        return self.N / (self.sigma * self.lam_min)

    def ultimate_bound(self, noise_bounds: float | Sequence[float]) -> float:
        """``limsup |e|`` when every sample of group ``j`` has noise (bias included) of norm ``≤ v̄_j`` and there is
        no process noise: (2) with ``|P^{1/2}K_j v_j|² ≤ κ_j² v̄_j²`` for the noise terms, ``η`` and ``ε_j``
        chosen anew for them (input-to-state; ``inf`` when the budget is spent).

        Parameters
        ----------
        noise_bounds : float or sequence of float
            ``v̄_j`` per group (one number: every group).
        """
        v = as_noise_bounds(noise_bounds, len(self.groups))
        if not self.verified:
            return math.inf
        noise = np.array([k * k * float(b) ** 2 for k, b in zip(self.kappa, v)])
        if not np.any(noise):
            return 0.0
        eta, eps = _best(self.alpha, self.kappa, self.groups, noise, 0.0)
        _, sigma, N = _terms(self.alpha, self.kappa, self.groups, noise, 0.0, eta, eps)
        return math.sqrt(N / (sigma * self.lam_min)) if sigma > 0 else math.inf

    @property
    def iss_gain(self) -> float:
        """``γ`` with ``limsup |e| ≤ γ v̄`` when every group's sample noise is bounded by ``v̄``
        (:meth:`ultimate_bound` at ``v̄ = 1``; the bound is linear in a common ``v̄``)."""
        return self.ultimate_bound(1.0)

    def ms_bound(self, t: float | ArrayLike) -> Array:
        """The bound (2) on ``E|e(t)|²`` at the times ``t`` (``inf`` when not verified).

        Parameters
        ----------
        t : float or array_like
            Times from the start of the run.
        """
        tt = np.asarray(t, dtype=float)
        if not self.verified:
            return np.full(tt.shape, math.inf)
        return (np.exp(-self.sigma * tt) * self.v0 + self.N / self.sigma) / self.lam_min

    def rms_bound(self, settle: float = math.inf) -> float:
        """The bound on the RMS error ``√E|e(t)|²`` for every ``t ≥ settle`` (default: the ultimate bound).

        Parameters
        ----------
        settle : float
            The time after which the RMS is taken.
        """
        if not self.verified:
            return math.inf
        return math.sqrt(self.ultimate_ms) if math.isinf(settle) else math.sqrt(float(self.ms_bound(settle)))

    def rms_after(self, settle: float, p0: ArrayLike | None = None) -> float:
        """The bound on ``√E|e(t)|²`` for ``t ≥ settle`` when the initial error has covariance ``p0``.

        Parameters
        ----------
        settle : float
            The time after which the RMS is taken.
        p0 : array_like, shape (n, n), optional
            Covariance (or second moment ``e0 e0ᵀ``) of the initial error (default: the bound's own).
        """
        if not self.verified:
            return math.inf
        v0 = self.v0 if p0 is None else float(np.trace(self.P @ _psd("p0", p0, self.P.shape[0])))
        return self.rms_from(settle, v0)

    def rms_from(self, settle: float, v0: float) -> float:
        """The bound (2) on ``√E|e(t)|²`` for ``t ≥ settle`` from the initial ``E V(e0) ≤ v0`` (``inf`` when not verified).

        Parameters
        ----------
        settle : float
            The time after which the RMS is taken.
        v0 : float
            A bound of ``E e0ᵀ P e0``.
        """
        if not self.verified:
            return math.inf
        return math.sqrt((math.exp(-self.sigma * max(float(settle), 0.0)) * v0 + self.N / self.sigma) / self.lam_min)

    def summary(self) -> str:
        """The budget per group, the decay and the noise floor, with every check."""
        lines = [f"sampled-data bound: α = {self.alpha:.4g}, λ_min(P) = {self.lam_min:.4g}, η = {self.eta:.3g}"]
        for g, k, tm in zip(self.groups, self.kappa, self.t_max):
            lines.append(f"  {g.name}: T = {g.period:.4g}, T_max = {tm:.4g} (κ = {k:.4g}, ℓ = {g.ell:.4g})")
        lines.append(f"  budget Σ T/T_max = {self.budget:.4g}; σ = {self.sigma:.4g}; N = {self.N:.4g}; "
                     f"ultimate RMS bound {math.sqrt(self.ultimate_ms) if self.verified else math.inf:.4g}; bounded "
                     f"noise |v| ≤ v̄: limsup |e| ≤ {self.iss_gain:.4g} v̄")
        lines += [f"  [{'ok' if c.passed else 'FAIL'}] {c.name}: {c.evidence}" for c in self.checks]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view: every number of (2) and (3), the groups and the checks."""
        return {"alpha": self.alpha, "eta": self.eta, "lam_min": self.lam_min, "budget": self.budget,
                "a": self.a, "sigma": self.sigma, "N": self.N, "v0": self.v0,
                "ultimate_rms_bound": math.sqrt(self.ultimate_ms) if self.verified else None,
                "iss_gain": self.iss_gain if self.verified else None,
                "groups": [{"name": g.name, "period": g.period, "T_max": tm, "kappa": k, "ell": g.ell, "q": g.q,
                            "eps": e} for g, tm, k, e in zip(self.groups, self.t_max, self.kappa, self.eps)],
                "verified": self.verified, "checks": checks_dict(self.checks)}

    def violation(self) -> str | None:
        """Which hypothesis of the bound fails, with the numbers (``None`` when verified)."""
        if self.verified:
            return None
        if not self.lam_min > 0:
            return "P is not positive definite"
        if self.budget >= 1:
            worst = max(range(len(self.groups)), key=lambda j: self.groups[j].period / self.t_max[j]
                        if self.t_max[j] > 0 else math.inf)
            g = self.groups[worst]
            if len(self.groups) == 1:
                return f"{g.name}: T = {g.period:.4g} > T_max = {self.t_max[worst]:.4g}"
            return (f"the sampling budget Σ T_j/T_max,j = {self.budget:.3g} ≥ 1 (largest: {g.name}, "
                    f"T = {g.period:.4g}, T_max = {self.t_max[worst]:.4g})")
        return "; ".join(f"{c.name}: {c.evidence}" for c in self.failed_checks)


def _numbers(P: Array, K: Array, alpha: float, groups: Sequence[GroupNoise], process: Array,
             p0: Array | None, drift: float = 0.0) -> tuple[float, Array, list[float], list[float], float, Array,
                                                             float, float]:
    """λ_min, √P, κ_j, T_max,j, the budget, the noise terms q̃_j (and ``λ_max(P) β²`` of a drift), ``tr(WᵀPW)``,
    ``v0``."""
    lam = float(np.linalg.eigvalsh(P)[0]) if P.size else math.inf
    S = psd_sqrt(P)
    kappa, tmax, noise = [], [], []
    for g in groups:
        Kj = K[:, list(g.index)]
        k = float(np.linalg.norm(S @ Kj, 2)) if Kj.size else 0.0
        kappa.append(k)
        tmax.append(alpha / (k * g.ell) if k * g.ell > 0 else math.inf)
        M = Kj.T @ P @ Kj
        noise.append(float(np.trace(M @ g.R)) + float(g.bias @ M @ g.bias) + g.period * g.q)
    budget = sum(g.period / tm for g, tm in zip(groups, tmax) if math.isfinite(tm))
    if drift > 0:  # 2eᵀPd ≤ ε_d V + λ_max(P) β² / ε_d: one more Young term
        noise.append(float(np.linalg.eigvalsh(P)[-1]) * drift * drift)
    proc = float(np.trace(P @ process))
    v0 = float(np.trace(P @ p0)) if p0 is not None else 0.0
    return lam, S, kappa, tmax, budget, np.asarray(noise), proc, v0


def _terms(alpha: float, kappa: Sequence[float], groups: Sequence[GroupNoise], noise: Array, proc: float,
           eta: float, eps: Sequence[float]) -> tuple[float, float, float]:
    """``a``, ``σ`` and ``N`` of (2) for given ``η`` and ``ε_j``."""
    s = sum(k * g.ell * g.period for k, g in zip(kappa, groups))
    a = 2 * alpha - 2 * math.sqrt(1 + eta) * s - float(sum(eps))
    tbar = max((g.period for g in groups), default=0.0)
    sigma = a if tbar == 0 else min(a, eta / ((1 + eta) * tbar))
    N = float(sum((q / e if e > 0 else math.inf) for q, e in zip(noise, eps) if q > 0)) + proc
    return a, sigma, N


def _best(alpha: float, kappa: Sequence[float], groups: Sequence[GroupNoise], noise: Array,
          proc: float) -> tuple[float, tuple[float, ...]]:
    """``η`` and ``ε_j`` making ``N/σ`` smallest (``ε_j ∝ √q̃_j``; module docstring)."""
    from scipy.optimize import minimize_scalar

    roots = np.sqrt(np.clip(noise, 0, None))
    total = float(roots.sum())
    weights = roots / total if total > 0 else np.zeros_like(roots)
    best: tuple[float, float, tuple[float, ...]] = (math.inf, ETA_GRID[0], tuple(0.0 for _ in noise))
    s = sum(k * g.ell * g.period for k, g in zip(kappa, groups))
    for eta in ETA_GRID:
        c = 2 * alpha - 2 * math.sqrt(1 + eta) * s
        if c <= 0:
            continue

        def ratio(E: float, eta: float = eta) -> float:
            a, sigma, N = _terms(alpha, kappa, groups, noise, proc, eta, tuple(E * weights))
            return N / sigma if sigma > 0 else math.inf

        if total > 0:
            res = minimize_scalar(ratio, bounds=(1e-12 * c, c * (1 - 1e-9)), method="bounded",
                                  options={"xatol": 1e-10 * c})
            E = float(res.x)
        else:
            E = 0.0
        value = ratio(E)
        if value < best[0]:
            best = (value, eta, tuple(float(E * w) for w in weights))
    return best[1], best[2]


def _checks(lam: float, budget: float, a: float, sigma: float, groups: Sequence[GroupNoise],
            tmax: Sequence[float]) -> tuple[Check, ...]:
    per = ", ".join(f"{g.name}: {g.period:.4g}/{tm:.4g}" for g, tm in zip(groups, tmax))
    return (Check.compare("P ≻ 0", -lam, 0.0, kind=CheckKind.POSITIVITY, evidence=f"λ_min(P) = {lam:.4g}"),
            Check.compare("sampling budget Σ T_j/T_max,j < 1 (3)", budget, 1.0, kind=CheckKind.STRUCTURAL,
                          evidence=f"{budget:.4g} < 1 ({per or 'continuous outputs'})",
                          values={"t_max": list(tmax), "periods": [g.period for g in groups]}),
            Check.compare("decay σ of (2) > 0", -sigma, 0.0, kind=CheckKind.SPECTRUM,
                          evidence=f"σ = {sigma:.4g} (a = {a:.4g})"))


def sampled_data_bound(P: ArrayLike, K: ArrayLike, alpha: float, groups: Sequence[GroupNoise], *,
                       process: ArrayLike | None = None, p0: ArrayLike | None = None,
                       drift: float = 0.0) -> SampledDataBound:
    """The sampling budget (3) and the mean-square bound (2) for a design's ``P``, ``K`` and ``α``.

    Parameters
    ----------
    P : array_like, shape (n, n)
        The Lyapunov matrix of the continuous certificate (1).
    K : array_like, shape (n, p)
        The output-injection gain.
    alpha : float
        The decay rate of (1), ``> 0``.
    groups : sequence of GroupNoise
        The sensor groups (every output in at most one).
    process : array_like, shape (n, n), optional
        ``W Wᵀ`` (default: no process noise).
    p0 : array_like, shape (n, n), optional
        Covariance of the initial error, for the transient of (2).
    drift : float, optional
        ``β ≥ 0``, a bound of a drift ``d`` of the error (module docstring; default 0: none).

    Returns
    -------
    SampledDataBound
        Verified when ``P ≻ 0``, the budget is below 1 and ``σ > 0``; otherwise :meth:`SampledDataBound.violation`
        says which fails and by how much.

    Raises
    ------
    InvalidArgumentError
        Non-finite or wrongly shaped matrices, ``α ≤ 0``, an output in two groups or out of range.
    """
    Pm = np.asarray(P, dtype=float)
    n = Pm.shape[0] if Pm.ndim == 2 else -1
    Pm = _psd("P", Pm, n)
    Km = np.asarray(K, dtype=float)
    if Km.ndim != 2 or Km.shape[0] != n or not np.all(np.isfinite(Km)):
        raise InvalidArgumentError(f"K: expected a finite array of shape ({n}, p), got {Km.shape}")
    a0 = _finite_positive("alpha", alpha)
    seen: set[int] = set()
    for g in groups:
        if not isinstance(g, GroupNoise):
            raise InvalidArgumentError(f"groups: expected GroupNoise objects, got {type(g).__name__}")
        bad = [i for i in g.index if not 0 <= i < Km.shape[1] or i in seen]
        if bad:
            raise InvalidArgumentError(f"sensor group {g.name!r}: output {bad[0]} out of range or in two groups")
        seen.update(g.index)
    W = np.zeros((n, n)) if process is None else _psd("process", process, n)
    S0 = None if p0 is None else _psd("p0", p0, n)
    beta = float(drift)
    if not (math.isfinite(beta) and beta >= 0):
        raise InvalidArgumentError(f"drift: expected a finite bound ≥ 0, got {drift!r}")
    lam, _, kappa, tmax, budget, noise, proc, v0 = _numbers(Pm, Km, a0, groups, W, S0, beta)
    eta, eps = _best(a0, kappa, groups, noise, proc) if budget < 1 and lam > 0 else (ETA_GRID[0], (0.0,) * len(noise))
    a, sigma, N = _terms(a0, kappa, groups, noise, proc, eta, eps)
    return SampledDataBound(Pm, Km, a0, tuple(groups), W, S0, eta, eps, tuple(kappa), tuple(tmax), budget, a, sigma,
                            N, lam, v0, _checks(lam, budget, a, sigma, groups, tmax), beta)


def verify_sampled_data_bound(bound: SampledDataBound) -> SampledDataBound:
    """Recompute every number of ``bound`` from its stored matrices, ``η`` and ``ε_j`` (NumPy only).

    Parameters
    ----------
    bound : SampledDataBound
        A bound from :func:`sampled_data_bound` (or one built by hand).

    Returns
    -------
    SampledDataBound
        The same inputs with the recomputed ``κ_j``, ``T_{max,j}``, budget, ``a``, ``σ``, ``N`` and checks.
    """
    lam, _, kappa, tmax, budget, noise, proc, v0 = _numbers(bound.P, bound.gain, bound.alpha, bound.groups,
                                                            bound.process, bound.p0, bound.drift)
    a, sigma, N = _terms(bound.alpha, kappa, bound.groups, noise, proc, bound.eta, bound.eps)
    return SampledDataBound(bound.P, bound.gain, bound.alpha, bound.groups, bound.process, bound.p0, bound.eta,
                            bound.eps, tuple(kappa), tuple(tmax), budget, a, sigma, N, lam, v0,
                            _checks(lam, budget, a, sigma, bound.groups, tmax), bound.drift)


@dataclass(frozen=True, eq=False)
class SampledDesignCertificate(CertificateMixin):
    """A continuous certificate of (1) and what it guarantees under the sensors: its checks and the bound's.

    Attributes
    ----------
    continuous : Certificate
        The design's certificate of (1) (its ``P``, ``gain`` and decay).
    bound : SampledDataBound
        The sampling budget (3) and the mean-square bound (2) under the sensors.
    """

    continuous: Any
    bound: SampledDataBound

    @property
    def gain(self) -> Array:
        """The continuous design's gain."""
        return np.asarray(self.continuous.gain)

    @property
    def P(self) -> Array:  # noqa: N802 - the paper's symbol
        """The continuous design's Lyapunov matrix."""
        return np.asarray(self.continuous.P)

    @property
    def solver(self) -> Any:
        """The continuous design's solver."""
        return self.continuous.solver

    @property
    def checks(self) -> tuple[Check, ...]:
        """The continuous certificate's checks, then the bound's."""
        return tuple(self.continuous.checks) + tuple(self.bound.checks)

    def summary(self) -> str:
        """Both summaries."""
        return self.continuous.summary() + "\n" + self.bound.summary()

    def to_dict(self) -> dict[str, Any]:
        """The continuous certificate's view with the bound's under ``"sampled"``."""
        return {**self.continuous.to_dict(), "sampled": self.bound.to_dict(), "verified": self.verified}
