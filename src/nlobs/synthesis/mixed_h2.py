r"""Noise-optimal certified observer gains: the smallest noise-to-error H2 norm under LMI (14).

Grip, Saberi & Johansen's design (Sec. 3.2) certifies the interconnection with LMI (14),
``‖H‖∞ < γ`` for ``H(s) = (sI − A + K C)⁻¹ B_d`` (13), and bounds a *worst-case* noise gain with
LMI (15); nothing in it asks for a small error *variance*. With white noise on the
measurements and on the modelled part of the dynamics, the error of observer (9) obeys

.. math:: \dot e = (A − K C) e + B_w w − K v,\qquad z = L_z e,

with ``v`` of intensity ``V`` (``E v(t) v(s)ᵀ = V δ(t − s)``), ``w`` of intensity ``W``, and the
steady-state variance of the weighted error ``z`` is the squared H2 norm of the map
``(w, v) ↦ z``, ``T(s) = L_z (sI − A + K C)⁻¹ [B_w W^{1/2}, −K V^{1/2}]``. This module minimises
it over ``K`` subject to LMI (14) at the given ``γ`` (the condition Theorems 1 and 2 need),
optional pole regions (Chilali & Gahinet 1996) and a gain bound:

1. **The convex design** (a common Lyapunov matrix, Scherer, Gahinet & Chilali 1997, Sec. IV):
   with ``X = P K`` the conditions

   * ``P A − X C + (P A − X C)ᵀ + L_zᵀ L_z ≺ 0`` — ``P`` exceeds the observability Gramian of
     ``(A − K C, L_z)``,
   * ``[[Z, (P B̂)ᵀ], [P B̂, P]] ⪰ 0`` with ``P B̂ = [P B_w W^{1/2}, −X V^{1/2}]`` — ``Z ⪰ B̂ᵀ P B̂``,
   * LMI (14), the region LMIs and the gain bound with the same ``P``,

   are linear in ``(P, X, Z)`` and ``‖T‖₂² ≤ trace B̂ᵀ P B̂ ≤ trace Z``; minimising ``trace Z``
   gives a gain and an upper bound. Sharing ``P`` between (14) and the H2 conditions is
   conservative.
2. **The refinement** (``refine=True``): a local minimisation of the *exact* ``‖T‖₂²`` (from the
   Gramian) over the entries of ``K``, started at the convex gain, with ``‖H‖∞ ≤ (1 − 10⁻⁴) γ``
   (:func:`nlobs.linear.norms.hinf_norm`), the pole regions and the gain bound as constraints
   (SciPy's SLSQP). Kept only when it lowers the norm and passes the certificate.

Every returned gain is certified without trusting any solver
(:class:`MixedH2Certificate`): LMI (14) by a Lyapunov matrix found for the *fixed* gain
(:func:`~nlobs.synthesis.observer_gain.verify_observer_gain`, every block re-evaluated in
NumPy), ``‖H‖∞`` by :func:`~nlobs.linear.norms.hinf_norm`, the closed-loop eigenvalues, and the H2
norm from both Gramians (which must agree). The certificate also reports what limits the result:
the H2 norm of the Kalman–Bucy filter of the same noise model (the unconstrained optimum, which
ignores (14)) and its ``‖H‖∞``.

References
----------
C. Scherer, P. Gahinet and M. Chilali, "Multiobjective output-feedback control via LMI
optimization", IEEE Trans. Automat. Control 42 (1997) 896–911.

P. P. Khargonekar and M. A. Rotea, "Mixed H2/H∞ control: a convex optimization approach", IEEE
Trans. Automat. Control 36 (1991) 824–837.

H. Kwakernaak and R. Sivan, *Linear Optimal Control Systems*, Wiley 1972, §4.3 (the
Kalman–Bucy filter as the unconstrained minimum of the error variance).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from nlobs._lazy import LazyModule
from nlobs._validate import as_matrix, as_square, as_symmetric, positive, readonly
from nlobs.checks import Check, CheckKind
from nlobs.errors import DesignInfeasible, DimensionError, InvalidArgumentError, NumericalError
from nlobs.linear.norms import h2_norm, hinf_norm
from nlobs.synthesis.certificate import CertificateMixin, checks_dict, complex_pairs
from nlobs.synthesis.lmi import Solver, as_solver, bmat, psd_sqrt, solve, symmetrise
from nlobs.synthesis.observer_gain import (
    GainBound,
    RegionArg,
    _check_size,
    _formulate,
    _require_detectable,
    _validate_data,
    verify_observer_gain,
)
from nlobs.systems.linear import takes_system

cp = LazyModule("cvxpy")  # imported by the first problem built (see nlobs._lazy)

__all__ = [
    "MixedH2Certificate",
    "NoiseModel",
    "design_h2_gain",
    "error_covariance",
    "h2_error_norm",
    "kalman_bucy_gain",
    "sampled_intensity",
    "verify_h2_gain",
]

_HINF_BACKOFF = 1e-4  # the refinement keeps ‖H‖∞ ≤ (1 − this) γ, so that (14) holds strictly
_REFINE_MAX_VARS = 64  # entries of K above which the refinement is skipped (finite-difference gradients)
_GRAMIAN_AGREE = 1e-7  # the two Gramians' H2 norms must agree to this (relative)


def sampled_intensity(std: float, rate_hz: float) -> float:
    """Continuous-time intensity of a sampled white sequence of standard deviation ``std`` at ``rate_hz``.

    A zero-order-held white sequence with variance ``σ²`` and period ``T = 1/rate`` has the
    low-frequency power spectral density ``σ² T``; this is the white-noise intensity that gives
    the same error variance in a filter whose bandwidth is well below the rate (the usual
    continuous-time model of a sampled sensor).

    Parameters
    ----------
    std : float
        Standard deviation of one sample (units of the signal).
    rate_hz : float
        Sample rate [Hz].

    Returns
    -------
    float
        ``std² / rate_hz`` (units² · s).

    Examples
    --------
    A GNSS position at 5 Hz with ``σ = 1.5`` m: ``2.25 m² × 0.2 s``:

    >>> round(sampled_intensity(1.5, 5.0), 6)
    0.45

    A first-order filter of bandwidth ``k = 1`` rad/s, well below a 100 Hz rate: its variance under the
    sampled sequence (``x⁺ = (1 − kT) x + kT v``) and under white noise of this intensity
    (``ẋ = −k x + k v``, variance ``kV/2``) agree to ``kT/2``:

    >>> std, rate, k = 0.1, 100.0, 1.0
    >>> T = 1 / rate
    >>> sampled = (k * T) ** 2 * std**2 / (1 - (1 - k * T) ** 2)
    >>> round(sampled / (k * sampled_intensity(std, rate) / 2), 4)
    1.005
    """
    s = float(std)
    if not (math.isfinite(s) and s >= 0.0):
        raise InvalidArgumentError(f"std: expected a finite number >= 0, got {std!r}")
    return s * s / positive("rate_hz", rate_hz)


@dataclass(frozen=True)
class NoiseModel:
    """White-noise inputs of the error dynamics ``ė = (A − K C) e + B_w w − K v`` and the error to minimise.

    Parameters
    ----------
    measurement : array_like, shape (p, p)
        Intensity ``V ⪰ 0`` of the measurement noise ``v`` (continuous time, units² · s; see
        :func:`sampled_intensity` for a sampled sensor).
    process_input : array_like, shape (n, q), optional
        ``B_w``: where process noise enters the error (e.g. an accelerometer's noise in the
        velocity equation). ``None``: no process noise.
    process : array_like, shape (q, q), optional
        Intensity ``W ⪰ 0`` of ``w`` (required with ``process_input``).
    error_weight : array_like, shape (r, n), optional
        ``L_z``: the error combination whose variance is minimised, ``z = L_z e`` (default: the
        whole error, ``I``). Weighting by ``1/σ`` of each channel minimises the error relative
        to what each sensor gives.

    Examples
    --------
    A position sensor (``V = 0.25``) on a double integrator whose acceleration is white noise of intensity
    ``W = 4`` entering the velocity equation:

    >>> import numpy as np
    >>> noise = NoiseModel([[0.25]], process_input=[[0.0], [1.0]], process=[[4.0]])
    >>> noise.inputs(np.array([[2.0], [4.0]])).tolist()  # B̂(K) = [B_w W^{1/2}, −K V^{1/2}]
    [[0.0, -1.0], [2.0, -2.0]]
    >>> noise.weight(2).tolist(), noise.to_dict()["process"]
    ([[1.0, 0.0], [0.0, 1.0]], [[4.0]])
    >>> try:
    ...     NoiseModel([[0.25]], process_input=[[0.0], [1.0]])
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError process_input and process: give both or neither
    """

    measurement: NDArray[np.float64]
    process_input: NDArray[np.float64] | None = None
    process: NDArray[np.float64] | None = None
    error_weight: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        V = as_symmetric("measurement", self.measurement)
        _require_psd("measurement", V)
        object.__setattr__(self, "measurement", readonly(V))
        if (self.process_input is None) != (self.process is None):
            raise InvalidArgumentError("process_input and process: give both or neither")
        if self.process_input is not None:
            Bw = as_matrix("process_input", self.process_input, (None, None))
            W = as_symmetric("process", self.process)
            if W.shape[0] != Bw.shape[1]:
                raise DimensionError(f"process: expected shape ({Bw.shape[1]}, {Bw.shape[1]}) to match "
                                     f"process_input's {Bw.shape[1]} columns, got {W.shape}")
            _require_psd("process", W)
            object.__setattr__(self, "process_input", readonly(Bw))
            object.__setattr__(self, "process", readonly(W))
        if self.error_weight is not None:
            object.__setattr__(self, "error_weight",
                               readonly(as_matrix("error_weight", self.error_weight, (None, None))))

    def check_against(self, n: int, p: int) -> None:
        """Raise :class:`~nlobs.errors.DimensionError` unless the shapes fit ``n`` states and ``p`` outputs."""
        if self.measurement.shape != (p, p):
            raise DimensionError(f"noise.measurement: expected shape ({p}, {p}) for {p} outputs, "
                                 f"got {self.measurement.shape}")
        if self.process_input is not None and self.process_input.shape[0] != n:
            raise DimensionError(f"noise.process_input: expected {n} rows (states), got {self.process_input.shape[0]}")
        if self.error_weight is not None and self.error_weight.shape[1] != n:
            raise DimensionError(f"noise.error_weight: expected {n} columns (states), "
                                 f"got {self.error_weight.shape[1]}")

    def weight(self, n: int) -> NDArray[np.float64]:
        """``L_z`` (the identity when not given)."""
        return np.eye(n) if self.error_weight is None else np.asarray(self.error_weight)

    def inputs(self, K: NDArray[np.float64]) -> NDArray[np.float64]:
        """``B̂(K) = [B_w W^{1/2}, −K V^{1/2}]``: the noise input matrix of the error dynamics."""
        cols = [-K @ psd_sqrt(self.measurement)]
        if self.process_input is not None and self.process is not None:
            cols.insert(0, self.process_input @ psd_sqrt(self.process))
        return np.hstack(cols)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view."""
        return {
            "measurement": self.measurement.tolist(),
            "process_input": None if self.process_input is None else self.process_input.tolist(),
            "process": None if self.process is None else self.process.tolist(),
            "error_weight": None if self.error_weight is None else self.error_weight.tolist(),
        }


def _require_psd(name: str, M: NDArray[np.float64]) -> None:
    lam = float(np.linalg.eigvalsh(M)[0]) if M.size else 0.0
    if lam < -1e-12 * max(1.0, float(np.max(np.abs(M)))):
        raise InvalidArgumentError(f"{name}: an intensity must be positive semidefinite (smallest eigenvalue {lam:.3g})")


@takes_system(time="continuous", A="A", C="C")
def h2_error_norm(A: ArrayLike, C: ArrayLike, K: ArrayLike, noise: NoiseModel) -> float:
    """``‖T‖₂``: the RMS of the weighted error ``z = L_z e`` of observer gain ``K`` under ``noise``.

    ``T(s) = L_z (sI − A + K C)⁻¹ B̂(K)`` (module docstring), by :func:`nlobs.linear.norms.h2_norm`
    (a Gramian); ``inf`` when ``A − K C`` is not Hurwitz.

    Parameters
    ----------
    A, C : array_like
        The system matrices, ``(n, n)`` and ``(p, n)``.
    K : array_like, shape (n, p)
        The observer gain.
    noise : NoiseModel
        Noise intensities and the error weight ``L_z``.

    Returns
    -------
    float

    Examples
    --------
    The scalar observer ``ė = −k e + w − k v`` (``A = 0``, ``C = 1``): ``‖T‖₂² = (W + k²V)/(2k)``, smallest at
    the Kalman–Bucy gain ``k = √(W/V)``; a gain that destabilises the error gives ``inf``:

    >>> import math
    >>> noise = NoiseModel([[1.0]], process_input=[[1.0]], process=[[1.0]])  # V = W = 1
    >>> [round(h2_error_norm([[0.0]], [[1.0]], [[k]], noise), 4) for k in (0.5, 1.0, 2.0)]
    [1.118, 1.0, 1.118]
    >>> round(math.sqrt((1 + 2.0**2) / (2 * 2.0)), 4), h2_error_norm([[0.0]], [[1.0]], [[-1.0]], noise)
    (1.118, inf)
    """
    A_, C_, K_ = _acK(A, C, K)
    noise.check_against(A_.shape[0], C_.shape[0])
    return _h2(A_, C_, K_, noise)


def _acK(A: ArrayLike, C: ArrayLike, K: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
    A_ = as_square("A", A)
    n = A_.shape[0]
    C_ = as_matrix("C", C, (None, n))
    K_ = as_matrix("K", K, (n, C_.shape[0]))
    return A_, C_, K_


def _h2(A: NDArray, C: NDArray, K: NDArray, noise: NoiseModel) -> float:
    n = A.shape[0]
    Lz = noise.weight(n)
    B = noise.inputs(K)
    return float(h2_norm(A - K @ C, B, Lz, np.zeros((Lz.shape[0], B.shape[1]))))


@takes_system(time="continuous", A="A", C="C")
def error_covariance(A: ArrayLike, C: ArrayLike, K: ArrayLike, noise: NoiseModel) -> NDArray[np.float64]:
    """Steady-state covariance ``Σ`` of the error ``e`` (not weighted): ``(A − KC) Σ + Σ (A − KC)ᵀ + B̂ B̂ᵀ = 0``.

    Parameters
    ----------
    A, C : array_like
        The system matrices, ``(n, n)`` and ``(p, n)``.
    K : array_like, shape (n, p)
        The observer gain.
    noise : NoiseModel
        Noise intensities (its error weight is not used).

    Returns
    -------
    ndarray, shape (n, n)
        ``Σ`` (read-only).

    Raises
    ------
    DesignInfeasible
        ``A − K C`` is not Hurwitz (no steady state).

    Examples
    --------
    A double integrator with a position sensor (``V = 0.25``) and white acceleration (``W = 4``): with the
    Kalman–Bucy gain ``K = [2√2, 4]ᵀ`` the covariance is the filter's Riccati solution, ``K = Σ Cᵀ V⁻¹``:

    >>> import numpy as np
    >>> A, C = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[1.0, 0.0]])
    >>> noise = NoiseModel([[0.25]], process_input=[[0.0], [1.0]], process=[[4.0]])
    >>> K = np.array([[2 * np.sqrt(2)], [4.0]])
    >>> S = error_covariance(A, C, K, noise)
    >>> np.round(S, 4).tolist(), bool(np.allclose(S @ C.T / 0.25, K))
    ([[0.7071, 1.0], [1.0, 2.8284]], True)
    >>> try:
    ...     error_covariance(A, C, np.array([[-1.0], [0.0]]), noise)
    ... except DesignInfeasible as exc:
    ...     print(type(exc).__name__, exc)
    DesignInfeasible A − K C is not Hurwitz: the error has no steady-state covariance
    """
    A_, C_, K_ = _acK(A, C, K)
    noise.check_against(A_.shape[0], C_.shape[0])
    Acl = A_ - K_ @ C_
    if not float(np.max(np.linalg.eigvals(Acl).real)) < 0.0:
        raise DesignInfeasible("A − K C is not Hurwitz: the error has no steady-state covariance",
                               constraint="stability")
    return readonly(_covariance(Acl, noise.inputs(K_)))


def _covariance(Acl: NDArray, B: NDArray) -> NDArray:
    """The controllability Gramian ``Σ`` of ``(Acl, B)``, symmetrised (``Acl`` Hurwitz)."""
    S = scipy.linalg.solve_continuous_lyapunov(Acl, -B @ B.T)
    return 0.5 * (S + S.T)


@takes_system(time="continuous", A="A", C="C")
def kalman_bucy_gain(A: ArrayLike, C: ArrayLike, noise: NoiseModel, *,
                     regularise: float = 1e-9) -> tuple[NDArray[np.float64], bool]:
    """The Kalman–Bucy gain of the noise model: the unconstrained minimum of the error variance.

    ``K = Σ Cᵀ V⁻¹`` with the stabilising solution of ``A Σ + Σ Aᵀ − Σ Cᵀ V⁻¹ C Σ + B_w W B_wᵀ = 0``
    (Kwakernaak & Sivan 1972, §4.3). A mode with no process noise on it (``(A, B_w W^{1/2})`` not
    stabilisable on the imaginary axis — e.g. an integrator whose input is unmodelled) has no
    stabilising solution; the process noise is then regularised by ``regularise · ‖·‖ · I`` and
    the flag says so: the gain approaches the infimum, which is not attained.

    Parameters
    ----------
    A, C : array_like
        The system matrices, ``(n, n)`` and ``(p, n)``.
    noise : NoiseModel
        Noise intensities ``V`` (must be positive definite) and ``B_w``, ``W``.
    regularise : float
        Relative size of the process noise added when no stabilising solution exists without it.

    Returns
    -------
    K : ndarray, shape (n, p)
    regularised : bool
        Whether the regularisation was needed.

    Raises
    ------
    DesignInfeasible
        ``V`` is singular (the filter is not defined) or no stabilising solution exists even
        regularised.

    Examples
    --------
    The double integrator with a position sensor of intensity ``r`` and white acceleration of intensity ``q``
    has ``K = [√2 (q/r)^{1/4}, (q/r)^{1/2}]ᵀ``; for ``q/r = 16``, ``K = [2√2, 4]ᵀ``:

    >>> import numpy as np
    >>> A, C = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[1.0, 0.0]])
    >>> K, regularised = kalman_bucy_gain(A, C, NoiseModel([[0.25]], process_input=[[0.0], [1.0]], process=[[4.0]]))
    >>> np.round(K.ravel(), 6).tolist(), round(2 * 2**0.5, 6), regularised
    ([2.828427, 4.0], 2.828427, False)

    An integrator with no process noise has no stabilising solution: the regularised gain is tiny (the
    infimum ``k → 0`` is not attained):

    >>> K, regularised = kalman_bucy_gain([[0.0]], [[1.0]], NoiseModel([[1.0]]))
    >>> regularised, bool(0 < K[0, 0] < 1e-3)
    (True, True)
    """
    A_ = as_square("A", A)
    n = A_.shape[0]
    C_ = as_matrix("C", C, (None, n))
    noise.check_against(n, C_.shape[0])
    V = np.asarray(noise.measurement)
    if float(np.linalg.eigvalsh(V)[0]) <= 0.0:
        raise DesignInfeasible("the measurement noise intensity V is singular: the Kalman–Bucy filter is not defined",
                               constraint="V ≻ 0")
    Qw = np.zeros((n, n))
    if noise.process_input is not None and noise.process is not None:
        Qw = noise.process_input @ noise.process @ noise.process_input.T
    # a closed-loop eigenvalue this close to the axis is a mode the filter does not stabilise
    # (rounding moved it off the axis): not a stabilising solution
    axis = 1e-8 * max(1.0, float(np.linalg.norm(A_, 1)))
    for reg in (0.0, regularise):
        Q = Qw + reg * max(1.0, float(np.max(np.abs(Qw)))) * np.eye(n)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                S = scipy.linalg.solve_continuous_are(A_.T, C_.T, Q, V)
        except (np.linalg.LinAlgError, ValueError):
            continue
        K = S @ C_.T @ np.linalg.inv(V)
        if np.all(np.isfinite(K)) and float(np.max(np.linalg.eigvals(A_ - K @ C_).real)) < -axis:
            return readonly(K), reg > 0.0
    raise DesignInfeasible("no stabilising Kalman–Bucy gain exists for this noise model "
                           "((A, C) detectable and (A, B_w) stabilisable are needed)", constraint="Kalman–Bucy")


def _kalman_infimum(A: NDArray[np.float64], C: NDArray[np.float64], noise: NoiseModel, h2_first: float,
                    K_first: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
    """The infimum of ``‖T‖₂`` over gains when the Kalman–Bucy filter needs a regularisation (not attained).

    The regularised filter's norm at relative regularisations ``ρ = 1e−10, 1e−12, 1e−14`` falls like ``√ρ`` (the
    slow mode's gain is ``√(ρ/V)``: its variance term ``ρ/(2k)`` and its noise term ``k V/2`` both scale so);
    Richardson's step with ratio ``√100 = 10`` on the last two gives the limit. Falls back to the first value
    when a smaller regularisation has no stabilising solution.
    """
    values, gain = [], K_first
    for rho in (1e-10, 1e-12, 1e-14):
        try:
            K, _ = kalman_bucy_gain(A, C, noise, regularise=rho)
        except DesignInfeasible:
            break
        values.append(_h2(A, C, K, noise))
        gain = K
    if len(values) < 2 or not all(math.isfinite(v) for v in values):
        return h2_first, K_first
    a, b = values[-2], values[-1]
    return max(b - (a - b) / 9.0, 0.0), gain


# --------------------------------------------------------------------------- certificate


@dataclass(frozen=True)
class MixedH2Certificate(CertificateMixin):
    """A gain minimising the noise-to-error H2 norm subject to LMI (14), with its re-verification.

    A :class:`~nlobs.synthesis.certificate.Certificate`. ``P`` proves LMI (14) for the returned
    ``gain`` (found for the fixed gain, every block re-evaluated in NumPy); ``checks`` holds those
    checks and the H2 checks.

    Attributes
    ----------
    gain : ndarray, shape (n, p)
    P : ndarray, shape (n, n), or None
        Lyapunov matrix of LMI (14) (and the region LMIs) for ``gain``.
    gamma : float
        ``γ`` of LMI (14).
    h2 : float
        ``‖T‖₂`` recomputed from the gain (Gramian): the RMS of ``z = L_z e``.
    h2_bound : float or None
        ``√trace Z`` of the convex design (an upper bound on its own gain's H2 norm).
    h2_convex : float
        ``‖T‖₂`` of the convex design's gain (before refinement).
    refined : bool
        Whether the returned gain is the refined one.
    h2_kalman : float
        ``‖T‖₂`` of the Kalman–Bucy gain (:func:`kalman_bucy_gain`): the unconstrained infimum (when the filter
        needs a regularisation, the limit as it vanishes, :func:`_kalman_infimum`; approached, not attained).
    hinf_kalman : float
        ``‖H‖∞`` of the Kalman–Bucy gain: the ``γ`` that gain would need in (14) (``inf`` if
        its closed loop is not Hurwitz).
    kalman_regularised : bool
        The Kalman–Bucy gain needed regularised process noise (its norm is then an infimum).
    hinf_H : float
        ``‖H‖∞`` of the returned gain.
    eigenvalues : ndarray of complex
        Closed-loop eigenvalues of ``A − K C``.
    error_std : ndarray
        ``√diag(L_z Σ L_zᵀ)``: the steady-state RMS of each weighted error channel.
    noise : NoiseModel
    checks : tuple of Check
    solver : Solver or None
    solver_status : str
    margin : float
    seconds : float

    Examples
    --------
    The scalar observer ``ė = −k e + w − k v`` with ``W = 0.01``, ``V = 1``: the Kalman–Bucy gain
    ``k = √(W/V) = 0.1`` has ``‖H‖∞ = 1/k = 10``, so at ``γ = 2`` LMI (14) binds and the optimum is the
    boundary gain ``k = 1/γ``, with ``‖T‖₂ = √((W + k²V)/(2k))`` above the Kalman–Bucy ``(WV)^{1/4}``:

    >>> import math
    >>> noise = NoiseModel([[1.0]], process_input=[[1.0]], process=[[0.01]])
    >>> cert = design_h2_gain([[0.0]], [[1.0]], [[1.0]], gamma=2.0, noise=noise)
    >>> cert.verified, cert.refined, round(float(cert.gain[0, 0]), 3), bool(cert.hinf_H < 2.0)
    (True, True, 0.5, True)
    >>> round(cert.h2, 3), round(math.sqrt((0.01 + 0.25) / 1.0), 3)
    (0.51, 0.51)
    >>> round(cert.h2_kalman, 4), round(cert.hinf_kalman, 3)  # (WV)^{1/4} and 1/√(W/V)
    (0.3162, 10.0)
    >>> round(cert.h2_ratio_to_kalman, 2), cert.error_std.shape, cert.summary().splitlines()[0]
    (1.61, (1,), 'noise-optimal gain certificate (mixed H2/H∞): verified')
    """

    gain: NDArray[np.float64]
    P: NDArray[np.float64] | None
    gamma: float
    h2: float
    h2_bound: float | None
    h2_convex: float
    refined: bool
    h2_kalman: float
    hinf_kalman: float
    kalman_regularised: bool
    hinf_H: float
    eigenvalues: NDArray[np.complex128]
    error_std: NDArray[np.float64]
    noise: NoiseModel
    checks: tuple[Check, ...]
    solver: Solver | None
    solver_status: str
    margin: float
    seconds: float = 0.0

    @property
    def gain_norm(self) -> float:
        """``‖K‖₂``."""
        return float(np.linalg.norm(self.gain, 2))

    @property
    def h2_ratio_to_kalman(self) -> float:
        """``‖T‖₂ / ‖T_Kalman‖₂`` (≥ 1): what LMI (14) at ``γ`` costs in noise."""
        return float(self.h2 / self.h2_kalman) if self.h2_kalman > 0 else math.inf

    def summary(self) -> str:
        """A multi-line human-readable report."""
        st = "verified" if self.verified else "FAILED"
        lines = [
            f"noise-optimal gain certificate (mixed H2/H∞): {st}",
            f"  ‖T‖₂ = {self.h2:.6g} (convex design {self.h2_convex:.6g}"
            + (f", its bound {self.h2_bound:.6g}" if self.h2_bound is not None else "")
            + f"; {'refined' if self.refined else 'not refined'})",
            f"  ‖H‖∞ = {self.hinf_H:.6g} < γ = {self.gamma:g}; ‖K‖₂ = {self.gain_norm:.6g}",
            f"  Kalman–Bucy (ignores (14)): ‖T‖₂ = {self.h2_kalman:.6g}, its ‖H‖∞ = {self.hinf_kalman:.6g}"
            + (" (regularised: an infimum)" if self.kalman_regularised else ""),
            "  eig(A−KC) = " + ", ".join(f"{z:.4g}" for z in self.eigenvalues),
        ]
        lines += ["  " + c.summary() for c in self.checks]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view."""
        return {
            "verified": self.verified,
            "gain": self.gain.tolist(),
            "P": None if self.P is None else self.P.tolist(),
            "gamma": self.gamma,
            "h2": self.h2,
            "h2_bound": self.h2_bound,
            "h2_convex": self.h2_convex,
            "refined": self.refined,
            "h2_kalman": self.h2_kalman,
            "hinf_kalman": self.hinf_kalman,
            "kalman_regularised": self.kalman_regularised,
            "hinf_H": self.hinf_H,
            "gain_norm": self.gain_norm,
            "eigenvalues": complex_pairs(self.eigenvalues),
            "error_std": self.error_std.tolist(),
            "noise": self.noise.to_dict(),
            "checks": checks_dict(self.checks),
            "solver": None if self.solver is None else self.solver.value,
            "solver_status": self.solver_status,
            "margin": self.margin,
            "seconds": self.seconds,
        }


# --------------------------------------------------------------------------- design


def _convex_design(d: Any, noise: NoiseModel, gamma: float, margin: float, solver: Solver,
                   options: Mapping[str, Any] | None) -> tuple[NDArray[np.float64], float, str]:
    """Stage 1: minimise ``trace Z`` over the common-``P`` LMIs (module docstring). Returns ``(K, √trace Z, status)``."""
    n = d.n
    f = _formulate(d, margin=margin, gamma2=gamma**2, gamma_n2=1.0, with15=False, regions=d.regions,
                   gain_bound=d.gain_bound)
    P, X = f.P, f.X
    Lz = noise.weight(n)
    PF = P @ d.A - X @ d.C
    cons = list(f.constraints)
    cons.append(symmetrise(PF + PF.T + Lz.T @ Lz) << -margin * np.eye(n))
    cols = [-X @ psd_sqrt(noise.measurement)]
    if noise.process_input is not None and noise.process is not None:
        cols.insert(0, P @ (noise.process_input @ psd_sqrt(noise.process)))
    PB = cp.hstack(cols)
    q = PB.shape[1]
    Z = cp.Variable((q, q), symmetric=True, name="Z")
    cons.append(symmetrise(bmat([[Z, PB.T], [PB, P]])) >> 0)
    prob = cp.Problem(cp.Minimize(cp.trace(Z)), cons)
    res = solve(prob, solver, options)
    if not res.status.has_solution or P.value is None or X.value is None:
        raise DesignInfeasible(
            f"the mixed H2/H∞ LMIs have no solution at γ = {gamma:g} (solver: {res.raw_status}); LMI (14) "
            "with the H2 conditions on a common P is infeasible — raise γ, or check (14) alone with "
            "design_observer_gain", constraint="LMI (14) + H2", violation=math.nan)
    Pv = 0.5 * (P.value + P.value.T)
    K = np.linalg.solve(Pv, X.value)
    bound = math.sqrt(max(float(np.trace(Z.value)), 0.0))
    return K, bound, res.raw_status


def _refine(d: Any, noise: NoiseModel, K0: NDArray[np.float64], gamma: float) -> NDArray[np.float64] | None:
    """Stage 2: local minimisation of the exact ``‖T‖₂²`` over ``K`` (SLSQP), constraints as in the module docstring."""
    n, p = d.n, d.C.shape[0]
    scale = np.maximum(np.abs(K0), 1e-3 * max(float(np.max(np.abs(K0))), 1e-12))
    eye = np.eye(n)
    zero = np.zeros((n, d.Bd.shape[1]))

    def gain(x: NDArray) -> NDArray:
        return (x.reshape(n, p)) * scale

    def obj(x: NDArray) -> float:
        v = _h2(d.A, d.C, gain(x), noise)
        return v * v if math.isfinite(v) else 1e30

    def c_hinf(x: NDArray) -> float:
        K = gain(x)
        h = hinf_norm(d.A - K @ d.C, d.Bd, eye, zero)
        return 1.0 - _HINF_BACKOFF - h / gamma if math.isfinite(h) else -1.0

    def c_stable(x: NDArray) -> float:
        return -float(np.max(np.linalg.eigvals(d.A - gain(x) @ d.C).real))

    cons: list[dict[str, Any]] = [{"type": "ineq", "fun": c_stable}, {"type": "ineq", "fun": c_hinf}]
    for r in d.regions:
        cons.append({"type": "ineq",
                     "fun": lambda x, r=r: float(r.margin(np.linalg.eigvals(d.A - gain(x) @ d.C)))})
    if d.gain_bound is not None:
        kap = d.gain_bound.kappa
        cons.append({"type": "ineq", "fun": lambda x: kap - float(np.linalg.norm(gain(x), 2))})
    x0 = (K0 / scale).ravel()
    f0 = obj(x0)
    try:
        res = scipy.optimize.minimize(obj, x0, method="SLSQP", constraints=cons,
                                      options={"maxiter": 300, "ftol": 1e-12 * max(f0, 1e-300)})
    except (ValueError, np.linalg.LinAlgError, NumericalError):  # pragma: no cover - defensive
        return None
    x = np.asarray(res.x, dtype=float)
    if not np.all(np.isfinite(x)):
        return None

    def feasible(y: NDArray) -> bool:
        return all(c["fun"](y) >= 0.0 for c in cons)

    if not feasible(x):
        # SLSQP meets active constraints only to its tolerance: step back towards the feasible start
        # (bisection on the segment) to the last point that satisfies them exactly
        lo, hi = 0.0, 1.0
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if feasible(x0 + mid * (x - x0)):
                lo = mid
            else:
                hi = mid
        x = x0 + lo * (x - x0)
        if lo == 0.0 or not feasible(x):
            return None
    if not (obj(x) < f0):
        return None
    return gain(x)


@takes_system(time="continuous", A="A", C="C", Bd="B")
def design_h2_gain(
    A: ArrayLike,
    C: ArrayLike,
    Bd: ArrayLike,
    *,
    gamma: float,
    noise: NoiseModel,
    region: RegionArg = None,
    gain_bound: GainBound | float | None = None,
    refine: bool = True,
    solver: Solver | str = Solver.CLARABEL,
    margin: float = 1e-6,
    solver_options: Mapping[str, Any] | None = None,
) -> MixedH2Certificate:
    """Minimise the noise-to-error H2 norm over observer gains ``K`` subject to LMI (14) at ``γ``.

    Grip, Saberi & Johansen's error dynamics (12a) with the white-noise model of ``noise``
    (module docstring): the convex common-Lyapunov design (Scherer, Gahinet & Chilali 1997),
    then, with ``refine``, a local minimisation of the exact norm under ``‖H‖∞ < γ``. The result
    is certified independently of the solvers.

    Parameters
    ----------
    A, C, Bd : array_like
        The extended system (8) as in :func:`~nlobs.synthesis.design_observer_gain`: ``(n, n)``,
        ``(p, n)``, ``(n, m)``.
    gamma : float
        ``γ`` of LMI (14), ``‖H‖∞ < γ`` (the interconnection condition of Theorems 1 and 2).
    noise : NoiseModel
        Noise intensities and the error weight.
    region : PoleRegion or sequence of PoleRegion, optional
        Chilali–Gahinet pole regions for ``A − K C`` (same ``P`` in the convex stage; eigenvalue
        margins in the refinement).
    gain_bound : GainBound or float, optional
        ``‖K‖₂ ≤ κ``.
    refine : bool
        Run the local refinement (skipped above 64 gain entries).
    solver : Solver or str
        SDP solver of the convex stage.
    margin : float
        Strictness margin of the LMIs.
    solver_options : mapping, optional
        Passed to the solver.

    Returns
    -------
    MixedH2Certificate

    Raises
    ------
    DesignInfeasible
        ``(A, C)`` not detectable, or the LMIs infeasible at ``γ`` (the message says which).
    CertificateError
        No gain passed the independent re-verification.

    Examples
    --------
    A double integrator with a position sensor (``V = 0.25``) and white acceleration (``W = 4``), the
    disturbance entering the velocity. At a loose ``γ = 2`` the Kalman–Bucy gain ``[2√2, 4]ᵀ``
    (``‖H‖∞ ≈ 0.77``) satisfies LMI (14) and is found (:class:`MixedH2Certificate` shows a binding ``γ``):

    >>> import numpy as np
    >>> A, C, Bd = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[1.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> noise = NoiseModel([[0.25]], process_input=[[0.0], [1.0]], process=[[4.0]])
    >>> loose = design_h2_gain(A, C, Bd, gamma=2.0, noise=noise)
    >>> loose.verified, np.round(loose.gain.ravel(), 3).tolist(), round(loose.h2 / loose.h2_kalman, 6)
    (True, [2.828, 4.0], 1.0)
    >>> bool(loose.hinf_H < 2.0), round(loose.hinf_kalman, 2)
    (True, 0.77)
    """
    t0 = time.perf_counter()
    g = positive("gamma", gamma)
    if not isinstance(noise, NoiseModel):
        raise InvalidArgumentError(f"noise: expected a NoiseModel, got {type(noise).__name__}")
    d = _validate_data(A, C, Bd, None, False, region, gain_bound)
    n, p = d.n, d.C.shape[0]
    noise.check_against(n, p)
    slv = as_solver(solver)
    _require_detectable(d.A, d.C)
    _check_size(d)
    K_convex, bound, status = _convex_design(d, noise, g, margin, slv, solver_options)
    h2_convex = _h2(d.A, d.C, K_convex, noise)
    K, refined = K_convex, False
    if refine and n * p <= _REFINE_MAX_VARS:
        K_ref = _refine(d, noise, K_convex, g)  # returned only when it lowers the exact norm
        if K_ref is not None:
            K, refined = K_ref, True
    return _certificate(d, noise, K, g, bound=bound, h2_convex=h2_convex, refined=refined, solver=slv,
                        status=status, margin=margin, seconds=time.perf_counter() - t0,
                        fallback=None if not refined else K_convex)


def _certificate(d: Any, noise: NoiseModel, K: NDArray[np.float64], gamma: float, *, bound: float | None,
                 h2_convex: float, refined: bool, solver: Solver | None, status: str, margin: float, seconds: float,
                 fallback: NDArray[np.float64] | None) -> MixedH2Certificate:
    n = d.n
    cert14 = verify_observer_gain(d.A, d.C, d.Bd, K, gamma=gamma, region=d.regions or None,
                                  gain_bound=d.gain_bound, margin=margin, strict=False)
    if not cert14.verified and fallback is not None:  # the refined gain did not certify: keep the convex one
        return _certificate(d, noise, fallback, gamma, bound=bound, h2_convex=h2_convex, refined=False,
                            solver=solver, status=status, margin=margin, seconds=seconds, fallback=None)
    checks = list(cert14.checks)
    Lz = noise.weight(n)
    Acl = d.A - K @ d.C
    B = noise.inputs(K)
    h2c = _h2(d.A, d.C, K, noise)
    # the other Gramian: ‖T‖₂² = trace(B̂ᵀ Q B̂) with Aᵀ Q + Q A + L_zᵀ L_z = 0
    try:
        Q = scipy.linalg.solve_continuous_lyapunov(Acl.T, -Lz.T @ Lz)
        h2o = math.sqrt(max(float(np.trace(B.T @ Q @ B)), 0.0))
    except (np.linalg.LinAlgError, ValueError):
        h2o = math.nan
    rel = abs(h2c - h2o) / max(h2c, 1e-300) if math.isfinite(h2c) else math.inf
    checks.append(Check.compare("‖T‖₂ by the two Gramians agree (relative difference)", rel, _GRAMIAN_AGREE,
                                kind=CheckKind.NORM, strict=False,
                                evidence=f"controllability Gramian {h2c:.12g}, observability Gramian {h2o:.12g}"))
    if bound is not None and not refined:
        checks.append(Check.compare("‖T‖₂ ≤ √trace Z (the convex design's bound)", h2c, bound * (1 + 1e-6),
                                    kind=CheckKind.NORM, strict=False))
    if refined:
        checks.append(Check.compare("‖T‖₂ below the convex design's", h2c, h2_convex, kind=CheckKind.NORM,
                                    strict=False))
    try:
        Kk, reg = kalman_bucy_gain(d.A, d.C, noise)
        h2k = _h2(d.A, d.C, Kk, noise)
        if reg:  # the infimum is not attained: its limit as the regularisation vanishes
            h2k, Kk = _kalman_infimum(d.A, d.C, noise, h2k, Kk)
        hk = float(hinf_norm(d.A - Kk @ d.C, d.Bd, np.eye(n), np.zeros((n, d.Bd.shape[1]))))
    except DesignInfeasible:
        h2k, hk, reg = math.nan, math.nan, False
    std = np.sqrt(np.clip(np.diag(Lz @ _covariance(Acl, B) @ Lz.T), 0.0, None))
    return MixedH2Certificate(
        gain=readonly(np.array(K)), P=cert14.P, gamma=gamma, h2=h2c, h2_bound=bound, h2_convex=h2_convex,
        refined=refined, h2_kalman=h2k, hinf_kalman=hk, kalman_regularised=reg, hinf_H=cert14.hinf_H,
        eigenvalues=cert14.eigenvalues, error_std=readonly(std), noise=noise, checks=tuple(checks), solver=solver,
        solver_status=status, margin=margin, seconds=seconds)


@takes_system(time="continuous", A="A", C="C", Bd="B")
def verify_h2_gain(A: ArrayLike, C: ArrayLike, Bd: ArrayLike, K: ArrayLike, *, gamma: float, noise: NoiseModel,
                   region: RegionArg = None, gain_bound: GainBound | float | None = None,
                   margin: float = 1e-6) -> MixedH2Certificate:
    """Certify a *given* gain (e.g. the paper's) against LMI (14) and report its noise-to-error H2 norm.

    The same checks as :func:`design_h2_gain`'s certificate (``h2_bound`` and ``h2_convex`` are
    the gain's own norm; nothing was solved for it but ``P``).

    Parameters
    ----------
    A, C, Bd : array_like
        The extended system (8): ``(n, n)``, ``(p, n)``, ``(n, m)``.
    K : array_like, shape (n, p)
        The gain to certify.
    gamma : float
        ``γ`` of LMI (14), ``‖H‖∞ < γ``.
    noise : NoiseModel
        Noise intensities and the error weight.
    region : PoleRegion or sequence of PoleRegion, optional
        Chilali–Gahinet pole regions ``A − K C`` must lie in.
    gain_bound : GainBound or float, optional
        ``‖K‖₂ ≤ κ``.
    margin : float
        Strictness margin of the LMIs.

    Returns
    -------
    MixedH2Certificate

    Examples
    --------
    The scalar observer ``ė = −k e + w − k v`` (``V = W = 1``) with the given ``k = 2``:
    ``‖T‖₂ = √((W + k²V)/(2k)) = √1.25`` and ``‖H‖∞ = 1/k = 0.5``; ``k = 0.5`` has ``‖H‖∞ = 2`` and fails
    LMI (14) at ``γ = 1``:

    >>> import math
    >>> noise = NoiseModel([[1.0]], process_input=[[1.0]], process=[[1.0]])
    >>> cert = verify_h2_gain([[0.0]], [[1.0]], [[1.0]], [[2.0]], gamma=1.0, noise=noise)
    >>> cert.verified, round(cert.h2, 4), round(math.sqrt(1.25), 4), round(cert.hinf_H, 4), cert.refined
    (True, 1.118, 1.118, 0.5, False)
    >>> slow = verify_h2_gain([[0.0]], [[1.0]], [[1.0]], [[0.5]], gamma=1.0, noise=noise)
    >>> slow.verified, round(slow.hinf_H, 4), "‖H‖∞ < γ" in [c.name for c in slow.failed_checks]
    (False, 2.0, True)
    """
    g = positive("gamma", gamma)
    if not isinstance(noise, NoiseModel):
        raise InvalidArgumentError(f"noise: expected a NoiseModel, got {type(noise).__name__}")
    d = _validate_data(A, C, Bd, None, False, region, gain_bound)
    noise.check_against(d.n, d.C.shape[0])
    K_ = as_matrix("K", K, (d.n, d.C.shape[0]))
    t0 = time.perf_counter()
    h2 = _h2(d.A, d.C, K_, noise)
    return _certificate(d, noise, K_, g, bound=None, h2_convex=h2, refined=False, solver=None, status="given gain",
                        margin=margin, seconds=time.perf_counter() - t0, fallback=None)

