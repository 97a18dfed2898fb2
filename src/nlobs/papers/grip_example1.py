r"""Grip, Saberi & Johansen, Example 1 of Section 4, reproduced numerically.

Σ₁: ``ẋ = A₁ x + Φ(x)``, ``z = C₁ x`` with ``A₁ = [[0, 1], [1, −1]]``, ``C₁ = [0, 1]``,
and Rajamani's observer ``x̂̇ = A₁x̂ + Φ(x̂) + L(z − C₁x̂)``, ``L = [69.6, 11.6]ᵀ``,
i.e. ``g(u, x̂, z) = L(z − C₁x̂)``. Σ₂ = 1/(s² + s + 1):
``ẇ = [[0, 1], [−1, −1]] w + [0; 1] z``, ``y = [1, 0] w``.

**The paper does not give Φ; we choose** (documented in ``docs/cascade.md``)

* cascade: ``Φ(x) = [0, 0.4 sin x₁]ᵀ`` — globally Lipschitz in ``x`` with constant
  exactly 0.4 (``|sin a − sin b| ≤ |a − b|``, attained as ``a → b`` at ``a = 0``);
* feedback (Φ also depends on ``w``, Sec. 4): ``Φ(x, w) = [0, 0.4 sin(x₁ + w₁)]ᵀ`` —
  Lipschitz constant 0.4 in ``x`` for fixed ``w`` (Assumption 1) and 0.4 in ``w``
  for fixed ``x`` (enters ``L₁`` of Assumption 2'); jointly ``0.4√2`` in ``(x₁, w₁)``.

Constants (derived in the docstrings of :func:`lipschitz_constants`):

* Assumption 1: ``V = x̃ᵀP₁x̃`` from the S-procedure SDP
  (:func:`~nlobs.synthesis.cascade_bounds.quadratic_lyapunov_constants`);
* Assumption 2 (2'): ``L₁ = ‖L‖`` (``√(‖L‖² + 0.4²)``);
* Assumption 3 (3'): ``d = C₁(A₁x + Φ) = x₁ − x₂ + 0.4 sin(x₁ [+ w₁])`` so
  ``L₂ = sup‖∇d‖ = √(1.4² + 1)`` (``√(1.4² + 1 + 0.4²)``).

:func:`run_example1` checks every assumption, computes Theorem 1's (1') bound on
``γ``, designs a ``K`` meeting it (pole placement, certified by ``‖H‖∞``
recomputed), simulates plant + observer from a wrong initial estimate, fits the
decay rate and compares it with the linearised prediction, and (optionally)
runs the γ sweep of Sec. 3.2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp
from numpy.typing import NDArray

from nlobs._io import save_figure
from nlobs._typing import Array
from nlobs.linear import Assumption4Report, check_assumption4, hinf_norm
from nlobs.observers import CascadeObserver
from nlobs.simulate import SimulationResult, simulate
from nlobs.synthesis import (
    ObserverGainCertificate,
    QuadraticLyapunov,
    place_cascade_gain,
    quadratic_lyapunov_constants,
    theorem1_gamma_bound,
    theorem1_optimal_scaling,
    theorem1_prime_gamma_bound,
)
from nlobs.systems import LinearSubsystem, NonlinearSubsystem, interconnected_plant
from nlobs.workflows import GammaSweep, gamma_sweep


__all__ = [
    "A1",
    "A2",
    "B2",
    "C1",
    "C2",
    "L_RAJAMANI",
    "PHI_LIPSCHITZ",
    "Example1Result",
    "example1_sigma1",
    "example1_sigma2",
    "linearised_error_matrix",
    "lipschitz_constants",
    "predicted_decay_range",
    "run_example1",
]

A1 = np.array([[0.0, 1.0], [1.0, -1.0]])
C1 = np.array([[0.0, 1.0]])
L_RAJAMANI = np.array([[69.6], [11.6]])
A2 = np.array([[0.0, 1.0], [-1.0, -1.0]])
B2 = np.array([[0.0], [1.0]])
C2 = np.array([[1.0, 0.0]])
PHI_LIPSCHITZ = 0.4
"""Lipschitz constant of our Φ in ``x`` (and, in the feedback case, in ``w``)."""

X0 = np.array([1.0, -0.5, 0.2, 0.0])
"""Initial plant state ``[x₁, x₂, w₁, w₂]`` of the simulations."""
X_HAT0 = np.zeros(4)
"""Initial estimate ``[x̂, ŵ]`` (wrong on purpose)."""
SWEEP_GAMMAS = (1.0, 0.3, 0.1, 0.03, 0.01)


def example1_sigma1(feedback: bool = False) -> NonlinearSubsystem:
    """Σ₁ (or Σ₁*) of Example 1 with Rajamani's injection ``g = L(z − x̂₂)``, compiled from SymPy."""
    x1, x2, w1, z = sp.symbols("x1 x2 w1 z", real=True)
    arg = x1 + w1 if feedback else x1
    f = [x2, x1 - x2 + PHI_LIPSCHITZ * sp.sin(arg)]
    g = [float(L_RAJAMANI[0, 0]) * (z - x2), float(L_RAJAMANI[1, 0]) * (z - x2)]
    return NonlinearSubsystem.symbolic(
        states=["x1", "x2"], outputs=["z"], f=f, h=[x2], g=g,
        linear_states=["w1", "w2"] if feedback else None,
        name="example1_sigma1_feedback" if feedback else "example1_sigma1",
    )


def example1_sigma2() -> LinearSubsystem:
    """Σ₂ = 1/(s² + s + 1) of Example 1."""
    return LinearSubsystem(A2, B2, C2, states=["w1", "w2"], outputs=["y"])


def lipschitz_constants(feedback: bool = False) -> tuple[float, float]:
    r"""``(L₁, L₂)`` of Assumptions 2–3 (2'–3') for our Φ.

    Cascade: ``g(x̂, z) − g(x̂, ẑ) = L(z − ẑ)`` so ``L₁ = ‖L‖``;
    ``d(x) = x₁ − x₂ + 0.4 sin x₁`` has ``∇d = [1 + 0.4 cos x₁, −1]``, whose
    largest norm (at ``cos x₁ = 1``) is ``L₂ = √(1.4² + 1)``.

    Feedback: the difference in Assumption 2' is
    ``[0, 0.4(sin(x̂₁ + w₁) − sin(x̂₁ + ŵ₁))] + L(z − ẑ)``, bounded by
    ``0.4|w̃₁| + ‖L‖|z̃| ≤ √(0.4² + ‖L‖²)‖[w̃; z̃]‖``; ``h = x₂`` does not depend on
    ``w``, so ``d = x₁ − x₂ + 0.4 sin(x₁ + w₁)`` with gradient (in ``w, z, x``)
    ``[0.4c, 0, 0, 1 + 0.4c, −1]`` and ``L₂ = √(0.4² + 1.4² + 1)``.
    """
    nL = float(np.linalg.norm(L_RAJAMANI))
    ell = PHI_LIPSCHITZ
    if feedback:
        return math.sqrt(nL**2 + ell**2), math.sqrt(ell**2 + (1 + ell) ** 2 + 1)
    return nL, math.sqrt((1 + ell) ** 2 + 1)


def linearised_error_matrix(K: Array, delta: float, feedback: bool = False) -> Array:
    r"""The error matrix of the complete observer with Φ frozen at slope ``δ = 0.4 cos(·)``.

    With ``Φ`` replaced by its linearisation ``[0, δ x₁ (+ δ w₁)]`` the system is
    linear and the errors ``[x̃; w̃; z̃]`` obey ``ė = M e`` with (``F = A₁ + [[0, 0], [δ, 0]]``,
    ``E = [[0, 0], [δ, 0]]`` in the feedback case, else 0, ``H = C₁``)

    ``M = [[F − LH, E, L], [0, A − K_w C, B_z], [HF, HE − K_z C, 0]]``.
    """
    Kw, Kz = K[:2], K[2:]
    D = np.array([[0.0, 0.0], [delta, 0.0]])
    F = A1 + D
    E = D if feedback else np.zeros((2, 2))
    return np.block([
        [F - L_RAJAMANI @ C1, E, L_RAJAMANI],
        [np.zeros((2, 2)), A2 - Kw @ C2, B2],
        [C1 @ F, C1 @ E - Kz @ C2, np.zeros((1, 1))],
    ])


def predicted_decay_range(K: Array, feedback: bool = False, n: int = 41) -> tuple[float, float]:
    """Range of ``−max Re λ(M(δ))`` over frozen slopes ``δ ∈ [−0.4, 0.4]`` (a heuristic prediction)."""
    rates = [-float(np.max(np.linalg.eigvals(linearised_error_matrix(K, d, feedback)).real))
             for d in np.linspace(-PHI_LIPSCHITZ, PHI_LIPSCHITZ, n)]
    return min(rates), max(rates)


@dataclass(frozen=True, eq=False)
class Example1Result:
    """Numbers of Example 1 (cascade or feedback), see :func:`run_example1`.

    Attributes
    ----------
    feedback : bool
    phi : str
        The Φ we chose.
    observer_eigenvalues : ndarray of complex
        ``eig(A₁ − L C₁)`` (≈ −6.3 ± 5.38j).
    lipschitz_margin : float
        ``1/‖(sI − A₁ + LC₁)⁻¹‖∞`` (≈ 0.98 > 0.4: Rajamani's necessary condition).
    lyapunov : QuadraticLyapunov
        ``P₁`` and ``α₁ … α₄`` of Assumption 1.
    L1, L2 : float
        Assumptions 2–3 (2'–3').
    assumption4 : Assumption4Report
    gamma_bound : float
        Theorem 1 (1') bound, with the best scaling of ``V``.
    gamma_bound_unscaled : float
        The bound with ``V = x̃ᵀP₁x̃`` as computed (``λ_max(P₁) = 1``).
    gamma_design : float
        ``γ`` used for the design (``0.9 ×`` the bound).
    certificate : ObserverGainCertificate
        ``K`` (pole placement), ``‖H‖∞ < γ`` and the closed-loop eigenvalues.
    initial_error, final_error : float
        ``‖[x̂ − x, ŵ − w]‖`` at ``t = 0`` and at the end.
    decay_rate : float
        Fitted exponential decay rate of the error norm.
    predicted_decay : tuple of float
        :func:`predicted_decay_range` for the designed ``K``.
    duration, dt : float
    sweep : GammaSweep or None
        γ sweep (pole placement, simulated), when requested.
    figures : tuple of Path
        PNG files written (empty when ``out_dir`` is None).
    simulation : SimulationResult
    """

    feedback: bool
    phi: str
    observer_eigenvalues: NDArray[np.complex128]
    lipschitz_margin: float
    lyapunov: QuadraticLyapunov
    L1: float
    L2: float
    assumption4: Assumption4Report
    gamma_bound: float
    gamma_bound_unscaled: float
    gamma_design: float
    certificate: ObserverGainCertificate
    initial_error: float
    final_error: float
    decay_rate: float
    predicted_decay: tuple[float, float]
    duration: float
    dt: float
    simulation: SimulationResult = field(repr=False)
    sweep: GammaSweep | None = None
    figures: tuple[Path, ...] = ()

    @property
    def K(self) -> Array:
        """The designed ``[K_w; K_z]``."""
        return np.asarray(self.certificate.gain)

    def to_dict(self) -> dict[str, Any]:
        """The numbers as plain Python (JSON-serialisable)."""
        q = self.lyapunov
        return {
            "feedback": self.feedback,
            "phi": self.phi,
            "observer_eigenvalues": [[float(z.real), float(z.imag)] for z in self.observer_eigenvalues],
            "lipschitz_margin": self.lipschitz_margin,
            "P1": np.asarray(q.P).tolist(),
            "alpha": [q.alpha1, q.alpha2, q.alpha3, q.alpha4],
            "L1": self.L1,
            "L2": self.L2,
            "assumption4": self.assumption4.to_dict(),
            "gamma_bound": self.gamma_bound,
            "gamma_bound_unscaled": self.gamma_bound_unscaled,
            "gamma_design": self.gamma_design,
            "K": self.K.tolist(),
            "hinf_H": self.certificate.hinf_H,
            "closed_loop_eigenvalues": [[float(z.real), float(z.imag)] for z in self.certificate.eigenvalues],
            "initial_error": self.initial_error,
            "final_error": self.final_error,
            "decay_rate": self.decay_rate,
            "predicted_decay": list(self.predicted_decay),
            "duration": self.duration,
            "dt": self.dt,
            "sweep": None if self.sweep is None else self.sweep.to_rows(),
            "figures": [str(p) for p in self.figures],
        }

    def summary(self) -> str:
        """A plain-text summary."""
        q = self.lyapunov
        eig = ", ".join(f"{z.real:.4g}{z.imag:+.4g}j" for z in self.observer_eigenvalues)
        ceig = ", ".join(f"{z.real:.4g}{z.imag:+.4g}j" for z in self.certificate.eigenvalues)
        lines = [
            f"Grip–Saberi–Johansen, Example 1 ({'feedback, Φ(x, w)' if self.feedback else 'cascade, Φ(x)'}): {self.phi}",
            f"  eig(A1 − L C1) = {eig};  1/‖(sI − A1 + L C1)⁻¹‖∞ = {self.lipschitz_margin:.4f} > 0.4",
            (f"  Assumption 1: α1={q.alpha1:.4g}, α2={q.alpha2:.4g}, α3={q.alpha3:.4g}, α4={q.alpha4:.4g} "
            f"(α3/α4 = {q.ratio:.4g})"),
            (f"  Assumption 2{chr(39) if self.feedback else ''}: L1 = {self.L1:.5g};  "
            f"Assumption 3{chr(39) if self.feedback else ''}: L2 = {self.L2:.5g}"),
            *("  " + ln for ln in self.assumption4.summary().splitlines()),
            (f"  Theorem 1{chr(39) if self.feedback else ''}: γ < {self.gamma_bound:.4g} (best scaling of V; "
            f"{self.gamma_bound_unscaled:.4g} with λ_max(P1) = 1)"),
            (f"  design at γ = {self.gamma_design:.4g}: K = {np.array2string(self.K.ravel(), precision=5)}, "
            f"‖H‖∞ = {self.certificate.hinf_H:.4g}, eig(𝔄 − Kℭ) = {ceig}"),
            (f"  simulation ({self.duration:g} s, dt = {self.dt:g}): ‖e(0)‖ = {self.initial_error:.4g}, "
            f"‖e(T)‖ = {self.final_error:.3g}, fitted decay rate {self.decay_rate:.4g} "
            f"(linearised prediction {self.predicted_decay[0]:.4g}–{self.predicted_decay[1]:.4g})"),
        ]
        if self.sweep is not None:
            lines += ["  " + ln for ln in self.sweep.summary().splitlines()]
        if self.figures:
            lines.append("  figures: " + ", ".join(str(p) for p in self.figures))
        return "\n".join(lines)


def _simulate(plant: Any, obs: CascadeObserver, duration: float, dt: float) -> SimulationResult:
    return simulate(plant, obs, X0, X_HAT0, duration=duration, dt=dt, save_every=max(1, round(0.01 / dt)))


def run_example1(
    out_dir: Path | None = None,
    feedback: bool = False,
    *,
    duration: float = 3.0,
    dt: float = 2.5e-4,
    sweep: bool = False,
    sweep_duration: float = 4.0,
) -> Example1Result:
    r"""Run Example 1 of Grip, Saberi & Johansen (cascade or feedback) end to end.

    Parameters
    ----------
    out_dir : Path, optional
        Where to write the figures (PNG, dpi 90): ``example1_<case>_error.png``
        and, with ``sweep``, ``example1_<case>_sweep.png``. ``None``: no figures.
    feedback : bool
        ``False``: cascade, ``Φ(x)``, observer (9)–(10), Theorem 1.
        ``True``: feedback, ``Φ(x, w)``, observer (17)–(18), Theorem 1'.
    duration, dt : float
        Simulation of the certified design (its fastest pole is ≈ −2600, so
        RK4 needs ``dt ≲ 5·10⁻⁴``).
    sweep : bool
        Also run the γ sweep of Sec. 3.2 (pole placement, ``γ`` from 1 down to
        the design value, each simulated for ``sweep_duration`` s).

    Returns
    -------
    Example1Result
    """
    s1 = example1_sigma1(feedback)
    s2 = example1_sigma2()
    F = A1 - L_RAJAMANI @ C1
    eig = np.linalg.eigvals(F)
    eig = eig[np.lexsort((eig.imag, eig.real))]
    margin = 1.0 / hinf_norm(F, np.eye(2), np.eye(2), np.zeros((2, 2)))
    q = quadratic_lyapunov_constants(F, PHI_LIPSCHITZ)
    L1, L2 = lipschitz_constants(feedback)
    a4 = check_assumption4(A2, B2, C2)
    if feedback:
        bound = theorem1_prime_gamma_bound(q.alpha3, q.alpha4, L1, L2)
        bound_raw = theorem1_prime_gamma_bound(q.alpha3, q.alpha4, L1, L2, optimise_scaling=False)
    else:
        bound = theorem1_optimal_scaling(q.alpha3, q.alpha4, L1, L2)[1]
        bound_raw = theorem1_gamma_bound(q.alpha3, q.alpha4, L1, L2)
    g_design = 0.9 * bound
    cert = place_cascade_gain(s2, gamma=g_design)
    plant = interconnected_plant(s1, s2)
    obs = CascadeObserver.from_certificate(s1, s2, cert)
    res = _simulate(plant, obs, duration, dt)
    en = np.asarray(res.error_norm)
    e0 = float(en[0])
    rate = float(res.decay_rate(floor=1e-7 * e0))
    pred = predicted_decay_range(np.asarray(cert.gain), feedback)
    sw = None
    if sweep:
        gammas = [g for g in SWEEP_GAMMAS if g > g_design] + [g_design]
        sw = gamma_sweep(s1, s2, gammas, method="placement",
                         simulate=lambda o: _simulate(plant, o, sweep_duration, dt))
    phi = "Φ(x, w) = [0, 0.4 sin(x1 + w1)]ᵀ" if feedback else "Φ(x) = [0, 0.4 sin(x1)]ᵀ"
    figs: tuple[Path, ...] = ()
    if out_dir is not None:
        figs = _figures(Path(out_dir), feedback, res, rate, pred, bound, g_design, sw, sweep_duration)
    eig.setflags(write=False)
    return Example1Result(
        feedback=feedback, phi=phi, observer_eigenvalues=eig, lipschitz_margin=float(margin), lyapunov=q,
        L1=L1, L2=L2, assumption4=a4, gamma_bound=float(bound), gamma_bound_unscaled=float(bound_raw),
        gamma_design=float(g_design), certificate=cert, initial_error=e0, final_error=float(en[-1]),
        decay_rate=rate, predicted_decay=pred, duration=float(duration), dt=float(dt), simulation=res,
        sweep=sw, figures=figs,
    )


def _figures(out: Path, feedback: bool, res: SimulationResult, rate: float, pred: tuple[float, float],
             bound: float, g_design: float, sw: GammaSweep | None, sw_duration: float) -> tuple[Path, ...]:
    from matplotlib.figure import Figure  # the object API: the user's backend and pyplot state are left alone

    out.mkdir(parents=True, exist_ok=True)
    case = "feedback" if feedback else "cascade"
    paths = []
    t = res.t
    err = np.asarray(res.error)
    fig = Figure(figsize=(9.0, 3.4), layout="tight")
    (ax0, ax1) = fig.subplots(1, 2)
    ax0.plot(t, np.asarray(res.x)[:, 0], "k-", lw=1.2, label=r"$x_1$")
    ax0.plot(t, np.asarray(res.x_hat)[:, 0], "C0--", lw=1.2, label=r"$\hat x_1$")
    ax0.plot(t, np.asarray(res.x)[:, 2], "0.5", lw=1.2, label=r"$w_1 = y$")
    ax0.plot(t, np.asarray(res.x_hat)[:, 2], "C1--", lw=1.2, label=r"$\hat w_1$")
    xs = np.asarray(res.x)[:, [0, 2]]
    span = float(np.max(xs) - np.min(xs)) + 1.0
    ax0.set_ylim(float(np.min(xs)) - 0.5 * span, float(np.max(xs)) + 0.5 * span)
    xh1 = np.asarray(res.x_hat)[:, 0]
    k = int(np.argmax(np.abs(xh1 - np.asarray(res.x)[:, 0])))
    ax0.annotate(f"peaking: $\\hat x_1$ = {xh1[k]:.3g} at t = {t[k]:.3f} s (off scale)",
                 xy=(0.98, 0.04), xycoords="axes fraction", ha="right", fontsize=8)
    ax0.set_xlabel("t [s]")
    ax0.set_title("states (solid) and estimates (dashed)", fontsize=9)
    ax0.legend(fontsize=8, loc="upper left")
    ax0.grid(alpha=0.3)
    nx = np.linalg.norm(err[:, :2], axis=-1)
    nw = np.linalg.norm(err[:, 2:], axis=-1)
    ax1.semilogy(t, nx, "C0", label=r"$\|\hat x - x\|$")
    ax1.semilogy(t, nw, "C1", label=r"$\|\hat w - w\|$")
    e0 = float(np.linalg.norm(err[0]))
    ax1.semilogy(t, e0 * np.exp(-pred[0] * t), "k:", lw=1, label=rf"$\|e(0)\|\,e^{{-{pred[0]:.2f}\,t}}$ (linearised)")
    ax1.set_xlabel("t [s]")
    ax1.set_title(f"estimation errors, fitted decay rate {rate:.2f} 1/s", fontsize=9)
    both = np.r_[nx, nw]
    ax1.set_ylim(max(1e-11, float(np.min(both[both > 0]))) / 3, 3 * float(np.max(both)))
    ax1.legend(fontsize=8, loc="upper right")
    ax1.grid(alpha=0.3, which="both")
    fig.suptitle(
        f"Grip–Saberi–Johansen, Example 1 ({case}): certified K at γ = {g_design:.2e} < Theorem 1{'′' if feedback else ''} "
        f"bound {bound:.2e}", fontsize=10)
    p = out / f"example1_{case}_error.png"
    save_figure(fig, p, dpi=90)
    paths.append(p)
    if sw is not None:
        rows = [r for r in sw.rows if not math.isnan(r.final_error)]
        fig = Figure(figsize=(9.0, 3.2), layout="tight")
        (a0, a1) = fig.subplots(1, 2)
        g = np.array([r.gamma for r in rows])
        fe = np.array([r.final_error for r in rows])
        conv = np.array([r.decay_rate > 0 for r in rows])
        a0.loglog(g, fe, "k-", lw=0.8)
        a0.loglog(g[conv], fe[conv], "o", color="C2", label="error decays")
        a0.loglog(g[~conv], fe[~conv], "x", color="C3", ms=8, label="error grows")
        a0.axvline(bound, color="C0", ls="--", lw=1, label=f"Theorem 1{'′' if feedback else ''} bound")
        a0.set_xlabel("γ")
        a0.set_ylabel(f"‖e‖ at t = {sw_duration:g} s")
        a0.legend(fontsize=8)
        a0.grid(alpha=0.3, which="both")
        a1.loglog(g, [r.gain_norm for r in rows], "s-", color="C4", label=r"$\|K\|_2$")
        a1.loglog(g, [-r.slowest_pole for r in rows], "^-", color="C5", label=r"$-\max\,\mathrm{Re}\,\lambda(\mathfrak{A} - K\mathfrak{C})$")
        a1.set_xlabel("γ")
        a1.legend(fontsize=8)
        a1.grid(alpha=0.3, which="both")
        fig.suptitle(f"γ sweep ({case}, pole placement, {sw.rows[0].gamma:g} → {sw.rows[-1].gamma:.2e})",
                     fontsize=10)
        p = out / f"example1_{case}_sweep.png"
        save_figure(fig, p, dpi=90)
        paths.append(p)
    return tuple(paths)
