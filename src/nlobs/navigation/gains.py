"""Gains of the GNSS/INS observer (24): the paper's, and certified nlobs designs.

Grip, Saberi & Johansen, Sec. 5. The linear part Σ2 of (21) is, on each NED axis, a double
integrator ``ṗ = v``, ``v̇ = z + g`` driven by ``z = aⁿ`` (the unmeasured input),
with ``p, v`` measured (``C = [I 0; 0 I]``) or only ``p`` (Sec. 5.2,
``C = [I 0]``). The extended system (8c) therefore decouples into three
identical 3-state problems (states ``p, v, z`` of one axis; measurements ``p, v``
or ``p``). A per-axis gain ``K3`` (3×2 or 3×1, rows ``p, v, z``) gives the
9-state gain of (24) as ``K9 = kron(K3, I3)``:

* state ordering ``[p(3), v(3), z(3)]`` (N, E, D inside each block),
* measurement ordering ``[p(3), v(3)]`` (or ``[p(3)]``),

so the block ``K9[3i:3i+3, 3j:3j+3] = K3[i, j] I3`` is ``K_pp, K_pv`` (i = 0),
``K_vp, K_vv`` (i = 1), ``K_zp, K_zv`` (i = 2) of (24a)–(24c). Designing the
9-state problem directly gives the same gain (checked in the tests), 2–5× slower.

The noise matrix ``N`` of LMI (15) is given *per axis* (2×2 or 1×1); the 9-state
``N`` is ``kron(N, I3)``.

Noise-optimal gains (:func:`noise_optimal_gains`): the per-axis gain minimising the noise-to-error
H2 norm under LMI (14) at the paper's ``γ = 50`` (:func:`nlobs.synthesis.design_h2_gain`), for the
declared sensor noise (:func:`axis_noise_model`); with the attitude gain
:data:`NOISE_OPTIMAL_GAMMA` (chosen by measurement, see its comment and ``docs/noise_optimal.md``).

Position-only gains: the paper prints none. :func:`design_gains` with
``position_only=True`` designs one with the paper's recipe (``γ = 50``,
``N = I``, central solution). For ``C = [I 0]`` the smallest achievable ``γn``
with LMI (14) at ``γ = 50`` is ≈ 1.0225 (measured; an infimum approached only as
the gain grows); the default ``γn = 1.05`` gives
``K3 ≈ [25.75, 5.92, 0.719]ᵀ``, poles ≈ −25.5, −0.116 ± 0.122j,
``‖H‖∞ ≈ 36.9``, ``‖G‖∞ ≈ 1.038``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_matrix, positive
from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.navigation.sensors import SensorNoise
from nlobs.synthesis import (
    ExtendedSystem,
    MixedH2Certificate,
    NoiseModel,
    design_h2_gain,
    sampled_intensity,
    GainBound,
    Objective,
    ObserverGainCertificate,
    PoleRegion,
    Solver,
    design_observer_gain,
    extended_system,
    verify_observer_gain,
)


__all__ = [
    "DEFAULT_GAMMA_N",
    "DEFAULT_GAMMA_N_POSITION_ONLY",
    "PAPER_GAMMA",
    "PAPER_K3",
    "NOISE_OPTIMAL_GAMMA",
    "axis_gain",
    "axis_noise_model",
    "axis_system",
    "design_gains",
    "full_system",
    "kron_gain",
    "noise_optimal_gains",
    "paper_gains",
    "verify_paper_gains",
]

#: The paper's per-axis gain (Sec. 5.2), rows ``p, v, z``, columns ``p, v`` measured:
#: ``K_pp ≈ 128.9, K_pv ≈ 17.5, K_vp ≈ 15.7, K_vv ≈ 2.4, K_zp ≈ 1.3, K_zv ≈ 0.2`` (× I3).
PAPER_K3: Array = np.array([[128.9, 17.5], [15.7, 2.4], [1.3, 0.2]])
PAPER_K3.setflags(write=False)

#: The paper's attitude gain Γ = diag(20, 0.2, 0.2) of (22)/(24c, d) (Sec. 5.2).
PAPER_GAMMA: Array = np.diag([20.0, 0.2, 0.2])
PAPER_GAMMA.setflags(write=False)

#: γ of LMI (14) used in the paper (Sec. 5.2).
PAPER_GAMMA_HINF = 50.0

#: Attitude gain Γ of (22)/(24c, d) used with the noise-optimal ``K`` (``nlobs demo gnss-ins``'s default):
#: ``0.5 I``. Chosen by measurement on the demo flight and sensors (seed 0, 60° yaw error; the RMS
#: after convergence below 5°, ``docs/noise_optimal.md``): over the 64 diagonal Γ with entries in
#: {0.1, 0.2, 0.5, 1} the attitude RMS ranges 0.48°–0.67°, and 0.5 I is within 1 % of the best
#: (0.4768° against 0.4948° for the best non-uniform one) with a fast convergence (1.4 s). A smaller Γ
#: filters the magnetometer better (steady-state 0.30° at 0.1 I against 0.43°) but converges too slowly
#: (6.8 s, and a long tail below 5°); the paper's diag(20, 0.2, 0.2) puts the magnetometer's noise into
#: yaw (0.9°).
NOISE_OPTIMAL_GAMMA: Array = 0.5 * np.eye(3)
NOISE_OPTIMAL_GAMMA.setflags(write=False)

#: Default γn (LMI (15), ``N = I``) for ``p, v`` measured: slightly above the infimum 1
#: (docs/synthesis.md: central gain within ~11 % of the paper's).
DEFAULT_GAMMA_N = 1.0019

#: Default γn for the position-only receiver (infimum ≈ 1.0225 at γ = 50, measured).
DEFAULT_GAMMA_N_POSITION_ONLY = 1.05


def axis_system(position_only: bool = False) -> ExtendedSystem:
    """The per-axis extended system (8c) of Σ2 (Grip, Saberi & Johansen, Sec. 5).

    States ``p, v, z`` of one NED axis, ``𝔄 = [[0,1,0],[0,0,1],[0,0,0]]``,
    ``𝔅_d = [0,0,1]ᵀ``, ``ℭ = [[1,0,0],[0,1,0]]`` (or ``[[1,0,0]]`` when
    ``position_only``).

    Parameters
    ----------
    position_only : bool, optional
        Only ``p`` measured (``C = [I 0]``, Sec. 5.2); default False: ``p`` and ``v``.

    Returns
    -------
    ExtendedSystem
        ``(𝔄, 𝔅_d, ℭ)`` of the 3-state axis problem.
    """
    C = np.array([[1.0, 0.0]]) if position_only else np.eye(2)
    return extended_system([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], C, np.zeros((C.shape[0], 1)))


def full_system(position_only: bool = False) -> ExtendedSystem:
    """The 9-state extended system (8c) with ``A = [[0, I],[0, 0]]``, ``B_z = [0; I]``, ``C`` as in Sec. 5.

    State ordering ``[p(3), v(3), z(3)]``; equal to ``kron`` of :func:`axis_system` with ``I3``.

    Parameters
    ----------
    position_only : bool, optional
        ``C = [I 0]`` (3 outputs) instead of ``C = I6`` (default False).

    Returns
    -------
    ExtendedSystem
        ``(𝔄, 𝔅_d, ℭ)`` of the 9-state problem.
    """
    I3, Z3 = np.eye(3), np.zeros((3, 3))
    A = np.block([[Z3, I3], [Z3, Z3]])
    Bz = np.vstack([Z3, I3])
    C = np.hstack([I3, Z3]) if position_only else np.eye(6)
    return extended_system(A, Bz, C, np.zeros((C.shape[0], 3)))


def kron_gain(K3: ArrayLike) -> Array:
    """The 9-state gain ``kron(K3, I3)`` of a per-axis gain ``K3`` (3×2 or 3×1).

    Parameters
    ----------
    K3 : array_like, shape (3, 2) or (3, 1)
        Per-axis gain, rows ``p, v, z``, columns the measured ``p, v`` (or ``p``).

    Returns
    -------
    ndarray, shape (9, 6) or (9, 3)

    Raises
    ------
    DimensionError
        ``K3`` is not 3×2 or 3×1.
    """
    K = as_matrix("K3", K3)
    if K.shape not in ((3, 2), (3, 1)):
        raise DimensionError(f"K3: expected shape (3, 2) or (3, 1), got {K.shape}")
    return np.kron(K, np.eye(3))


def axis_gain(K9: ArrayLike, *, rtol: float = 1e-9) -> Array:
    """The per-axis gain ``K3`` of a 9-state gain of the form ``kron(K3, I3)``.

    Parameters
    ----------
    K9 : array_like, shape (9, 6) or (9, 3)
        9-state gain, state order ``[p, v, z]``, measurement order ``[p, v]`` (or ``[p]``).
    rtol : float, optional
        Tolerance of the ``kron(K3, I3)`` check, relative to ``max(1, max |K9|)`` (default 1e-9).

    Returns
    -------
    ndarray, shape (3, 2) or (3, 1)
        ``K9[::3, ::3]``.

    Raises
    ------
    DimensionError
        ``K9`` is not 9×6 or 9×3.
    InvalidArgumentError
        ``K9`` is not of the form ``kron(K3, I3)`` (to ``rtol`` relative to its largest entry).
    """
    K = as_matrix("K9", K9)
    if K.shape not in ((9, 6), (9, 3)):
        raise DimensionError(f"K9: expected shape (9, 6) or (9, 3), got {K.shape}")
    K3 = K[::3, ::3].copy()
    dev = float(np.max(np.abs(K - np.kron(K3, np.eye(3)))))
    if dev > rtol * max(1.0, float(np.max(np.abs(K)))):
        raise InvalidArgumentError(f"K9: not of the form kron(K3, I3) (max deviation {dev:.3g})")
    return K3


def paper_gains(position_only: bool = False) -> Array:
    """The 9-state gain ``K`` of (24) used in the paper (Sec. 5.2): ``kron(PAPER_K3, I3)``, 9×6.

    Parameters
    ----------
    position_only : bool
        The paper prints no gain for the position-only receiver ``C = [I 0]``.
        With ``True`` this returns the gain designed by the paper's recipe
        (``γ = 50``, ``N = I``, central solution at
        ``γn = DEFAULT_GAMMA_N_POSITION_ONLY``), 9×3, computed once by
        :func:`design_gains` (certified) and cached.

    Examples
    --------
    The 9×6 gain of Sec. 5.2 is ``kron(PAPER_K3, I3)``: each NED axis has the same per-axis gain, and the axes do
    not couple (``K_pp = 128.9 I``, ``K_pv = 17.5 I``, …):

    >>> import numpy as np
    >>> K = paper_gains()
    >>> K.shape, bool(np.array_equal(K, np.kron(PAPER_K3, np.eye(3))))
    ((9, 6), True)
    >>> K[0:3, 0:3].tolist()  # K_pp
    [[128.9, 0.0, 0.0], [0.0, 128.9, 0.0], [0.0, 0.0, 128.9]]
    >>> K_p = paper_gains(position_only=True)  # designed by the paper's recipe (the paper prints none)
    >>> K_p.shape, np.round(axis_gain(K_p).ravel(), 2).tolist()
    ((9, 3), [25.75, 5.92, 0.72])
    """
    if position_only:
        return _position_only_gain().copy()
    return kron_gain(PAPER_K3)


@lru_cache(maxsize=1)
def _position_only_gain() -> Array:
    K9, _ = design_gains(position_only=True)
    K9.setflags(write=False)
    return K9


def verify_paper_gains(*, gamma: float = PAPER_GAMMA_HINF, gamma_n: float | None = 1.01,
                       N: ArrayLike | None = None) -> ObserverGainCertificate:
    """Certificate of the paper's per-axis gain :data:`PAPER_K3` (Grip, Saberi & Johansen, Theorem 3, LMIs (14), (15)).

    Measured: ``‖H‖∞ ≈ 32.18 < 50``, ``‖G‖∞ ≈ 1.0021`` (``N = I``), poles
    ≈ −130.9, −0.257, −0.129. The paper's gain has ``‖G‖∞ > 1.0019``, so the
    default ``γn`` is 1.01. The certificate holds for the 9-state ``kron(K3, I3)``
    as well (same transfer functions, each axis decoupled).

    Parameters
    ----------
    gamma : float, optional
        ``γ`` of LMI (14) (``‖H‖∞ < γ``); default the paper's 50.
    gamma_n : float or None, optional
        ``γn`` of LMI (15) (``‖G‖∞ ≤ γn``), default 1.01; ``None`` leaves LMI (15) out.
    N : array_like, shape (2, 2), optional
        Per-axis noise matrix of LMI (15) (``I`` when not given; needs ``gamma_n``).

    Returns
    -------
    ObserverGainCertificate
        The certificate of the per-axis problem.

    Raises
    ------
    CertificateError
        If the gain does not satisfy the requested bounds.

    Examples
    --------
    The paper's gain satisfies LMI (14) at ``γ = 50`` and LMI (15) at ``γn = 1.01``, with the poles quoted
    above; it does not satisfy ``‖H‖∞ < 20``:

    >>> import numpy as np
    >>> from nlobs.errors import CertificateError
    >>> cert = verify_paper_gains()
    >>> cert.verified, round(cert.hinf_H, 2), round(cert.hinf_G, 4)
    (True, 32.18, 1.0021)
    >>> np.round(np.sort(cert.eigenvalues.real), 3).tolist()
    [-130.914, -0.257, -0.129]
    >>> try:
    ...     verify_paper_gains(gamma=20.0)
    ... except CertificateError as exc:
    ...     print(type(exc).__name__, exc)
    CertificateError the given gain K failed verification: ... ‖H‖∞ < γ: 32.1826 < 20 (FAILED by 12.2)
    """
    A, Bd, C = axis_system(False)
    return verify_observer_gain(A, C, Bd, PAPER_K3, gamma=gamma, gamma_n=gamma_n, N=N)


def design_gains(
    gamma: float = PAPER_GAMMA_HINF,
    gamma_n: float | None = None,
    *,
    position_only: bool = False,
    N: ArrayLike | None = None,
    region: PoleRegion | Sequence[PoleRegion] | None = None,
    gain_bound: GainBound | float | None = None,
    objective: Objective | str = Objective.CENTRAL,
    solver: Solver | str = Solver.CLARABEL,
    margin: float = 1e-6,
    per_axis: bool = True,
    solver_options: Mapping[str, Any] | None = None,
    method: str = "sdp",
) -> tuple[Array, ObserverGainCertificate]:
    """Design a certified gain ``K`` of (24) with :func:`nlobs.synthesis.design_observer_gain`.

    Parameters
    ----------
    gamma : float
        ``γ`` of LMI (14) (``‖H‖∞ < γ``); the paper uses 50.
    gamma_n : float, optional
        ``γn`` of LMI (15) (``‖G‖∞ ≤ γn``, ``N = I`` by default). ``None`` picks
        :data:`DEFAULT_GAMMA_N` (1.0019) or, for ``position_only``,
        :data:`DEFAULT_GAMMA_N_POSITION_ONLY` (1.05) when the objective is
        ``CENTRAL`` and no gain bound is given; otherwise LMI (15) is left out
        unless ``objective`` is ``MIN_GAMMA_N``.
    position_only : bool
        ``C = [I 0]`` (Sec. 5.2): ``K`` is 9×3 instead of 9×6.
    N : array_like, optional
        Per-axis noise matrix (2×2, or 1×1 for position-only).
    region, gain_bound, objective, solver, margin, solver_options
        Passed to :func:`~nlobs.synthesis.design_observer_gain` (see ``docs/synthesis.md``).
    per_axis : bool
        Design the 3-state axis problem and return ``kron(K3, I3)`` (default), or
        the 9-state problem directly (same answer, slower; ``N`` then is
        ``kron(N, I3)``).
    method : str
        ``"sdp"`` (default: the analytic centre of (14)–(15), the gain compared with the paper's in
        ``nlobs reproduce grip2013``), ``"riccati"`` or ``"auto"`` (see
        :func:`~nlobs.synthesis.design_observer_gain`; the Riccati gain at ``γn = 1.0019`` is a
        different, smaller point of the feasible set).

    Returns
    -------
    K9 : ndarray, shape (9, 6) or (9, 3)
        The gain of (24), state order ``[p, v, z]``, measurement order ``[p, v]``.
    certificate : ObserverGainCertificate
        The certificate of the problem solved (the per-axis one when ``per_axis``).

    Raises
    ------
    DesignInfeasible, DesignUnbounded, CertificateError
        As :func:`~nlobs.synthesis.design_observer_gain`.

    Examples
    --------
    The central gain at the paper's ``γ = 50`` and the default ``γn = 1.0019`` is within 12 % of the paper's
    :data:`PAPER_K3`, entry by entry, and certified:

    >>> import numpy as np
    >>> K, cert = design_gains()
    >>> K3 = axis_gain(K)
    >>> K.shape, np.round(K3, 1).tolist()
    ((9, 6), [[126.6, 16.1], [15.6, 2.4], [1.2, 0.2]])
    >>> bool(np.max(np.abs(K3 - PAPER_K3) / PAPER_K3) < 0.12)
    True
    >>> cert.verified, round(cert.hinf_H, 1), bool(cert.hinf_G <= 1.0019)
    (True, 21.7, True)
    """
    g = positive("gamma", gamma)
    try:
        obj = Objective(objective)
    except ValueError:
        raise InvalidArgumentError(
            f"objective: unknown {objective!r}; expected one of {[o.value for o in Objective]}") from None
    if gamma_n is None and obj is Objective.CENTRAL and gain_bound is None:
        gamma_n = DEFAULT_GAMMA_N_POSITION_ONLY if position_only else DEFAULT_GAMMA_N
    p = 1 if position_only else 2
    N3 = None if N is None else as_matrix("N", N, (p, None))
    kw: dict[str, Any] = {"gamma": g, "gamma_n": gamma_n, "region": region, "gain_bound": gain_bound,
                              "objective": obj, "solver": solver, "margin": margin, "solver_options": solver_options,
                          "method": method}
    if per_axis:
        A, Bd, C = axis_system(position_only)
        cert = design_observer_gain(A, C, Bd, N=N3, **kw)
        return kron_gain(cert.gain), cert
    A, Bd, C = full_system(position_only)
    N9 = None if N3 is None else np.kron(N3, np.eye(3))
    cert = design_observer_gain(A, C, Bd, N=N9, **kw)
    return np.array(cert.gain), cert


def axis_noise_model(noise: SensorNoise, *, imu_rate_hz: float, gnss_rate_hz: float, position_only: bool = False,
                     floor: float = 1e-4) -> NoiseModel:
    """The white-noise model of one NED axis of Σ2's error dynamics under the sensors ``noise``.

    * measurement noise ``v``: the GNSS position and velocity errors, sampled at ``gnss_rate_hz``
      (intensities ``σ_p² / f_gnss``, ``σ_v² / f_gnss``, :func:`~nlobs.synthesis.sampled_intensity`;
      the observer extrapolates the fix between fixes, so each fix's error persists for one period);
    * process noise ``w``: the accelerometer error in ``ẑ = R̂ a^b + ξ`` enters the velocity equation
      (24b) directly, ``B_w = [0, 1, 0]ᵀ``, intensity ``σ_a² / f_imu``;
    * the error to minimise: position [m] and velocity [m/s], ``L_z = diag(1, 1, 0)`` (``z``
      unweighted). Measured on the demo flight, this weighting gives a smaller velocity error than
      ``diag(1/σ_p, 1/σ_v, 0)`` (0.072 against 0.081 m/s RMS, position 0.35 m both): the velocity
      error the linear model leaves out — the attitude error coupled in through ``R̂ a^b`` — dominates.

    Standard deviations below ``floor`` are raised to it (a noise-free sensor would make the problem
    degenerate).

    Parameters
    ----------
    noise : SensorNoise
        The sensors' error model (``gnss_p_std``, ``gnss_v_std`` and ``accel_std`` are used).
    imu_rate_hz, gnss_rate_hz : float
        IMU and GNSS sample rates [Hz] (positive).
    position_only : bool, optional
        Position-only receiver (``C = [I 0]``): measurement noise of ``p`` only, ``L_z = diag(1, 0, 0)``.
    floor : float, optional
        Smallest standard deviation used (default 1e-4).

    Returns
    -------
    NoiseModel
        Measurement intensity ``V`` (2×2 or 1×1), ``B_w``, process intensity and ``L_z``.

    Raises
    ------
    InvalidArgumentError
        ``noise`` is not a :class:`SensorNoise`, or a rate or ``floor`` is not positive.
    """
    if not isinstance(noise, SensorNoise):
        raise InvalidArgumentError(f"noise: expected a SensorNoise, got {type(noise).__name__}")
    f_imu, f_gnss = positive("imu_rate_hz", imu_rate_hz), positive("gnss_rate_hz", gnss_rate_hz)
    fl = positive("floor", floor)
    sp, sv, sa = (max(fl, x) for x in (noise.gnss_p_std, noise.gnss_v_std, noise.accel_std))
    if position_only:
        V = np.array([[sampled_intensity(sp, f_gnss)]])
        Lz = np.diag([1.0, 0.0, 0.0])
    else:
        V = np.diag([sampled_intensity(sp, f_gnss), sampled_intensity(sv, f_gnss)])
        Lz = np.diag([1.0, 1.0, 0.0])
    return NoiseModel(V, np.array([[0.0], [1.0], [0.0]]), np.array([[sampled_intensity(sa, f_imu)]]), Lz)


def noise_optimal_gains(noise: SensorNoise, *, imu_rate_hz: float, gnss_rate_hz: float,
                        gamma: float = PAPER_GAMMA_HINF, position_only: bool = False,
                        refine: bool = True) -> tuple[Array, MixedH2Certificate]:
    """The certified gain ``K`` of (24) with the smallest noise-to-error H2 norm under LMI (14) at ``γ``.

    The per-axis problem of :func:`axis_system` with the noise model of :func:`axis_noise_model`,
    solved by :func:`nlobs.synthesis.design_h2_gain` (a common-Lyapunov SDP, then a local
    refinement of the exact norm under ``‖H‖∞ < γ``), and ``kron(K3, I3)``.

    Parameters
    ----------
    noise : SensorNoise
        The sensors' error model (its standard deviations; biases are not modelled).
    imu_rate_hz, gnss_rate_hz : float
        Sample rates [Hz].
    gamma : float
        ``γ`` of LMI (14) (the paper's 50).
    position_only : bool
        ``C = [I 0]``.
    refine : bool
        Passed to :func:`~nlobs.synthesis.design_h2_gain`.

    Returns
    -------
    K9 : ndarray, shape (9, 6) or (9, 3)
    certificate : MixedH2Certificate
        Of the per-axis problem (LMI (14) by a Lyapunov matrix for the gain, ``‖H‖∞``, both Gramians).
    """
    A, Bd, C = axis_system(position_only)
    model = axis_noise_model(noise, imu_rate_hz=imu_rate_hz, gnss_rate_hz=gnss_rate_hz, position_only=position_only)
    cert = design_h2_gain(A, C, Bd, gamma=positive("gamma", gamma), noise=model, refine=refine)
    return kron_gain(cert.gain), cert
