"""``nlobs design setvalued`` and ``nlobs simulate setvalued``: the set-valued observer of Khajenejad & Yong.

Both read a model file with unknown inputs (:func:`nlobs.systems.modelfile.load_discrete_ui_model`), run
the structural checks first (Lemma 5.1's rank, strong detectability of every linear member of the class,
Corollary 5.8 / Lemma 5.7) and conclude :attr:`~nlobs.workflows.verdict.Verdict.NO_OBSERVER` when no stable
observer of the structure (10)-(15) exists, with the evidence. :func:`design_setvalued_observer` adds the
sampled check of the function class, the design (:func:`nlobs.synthesis.setvalued.design_setvalued`) and its
independent verification; :func:`simulate_setvalued_observer` runs Algorithm 1 in Monte Carlo with the point
baselines of ``docs/baselines.md`` on the same runs (:func:`monte_carlo`).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._io import prepare_output_dir
from nlobs._schema import BOOLEAN, INTEGER, NUMBER, STRING, Node, Record, array, nullable
from nlobs.simulate.coverage import COVERAGE_JSON

from nlobs._typing import Array
from nlobs.errors import (
    InvalidArgumentError,
    NlobsError,
    OutputError,
    SimulationDiverged,
    StudyFailed,
)
from nlobs.observers.kalman import UnknownInputEKF
from nlobs.observers.lipschitz import DiscreteLipschitzObserver
from nlobs.simulate.replay import run_observer
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.setvalued import DETAIL_BYTES, ContainmentResult, containment_of, input_estimates, simulate_batch
from nlobs.simulate.setvalued_plots import plot_trajectories, save_figure
from nlobs.synthesis.setvalued import SetValuedDesign
from nlobs.systems.discrete_ui import DiscreteUISystem, Lipschitz
from nlobs.systems.modelfile import DiscreteUIModel
from nlobs.methods.setvalued import (
    SETVALUED_DESIGN_REPORT_JSON,
    SetValuedDesignReport,
    class_check_box,
    design_setvalued_observer,
    load_setvalued_model,
)
from nlobs.workflows.verdict import Verdict

__all__ = [
    "MAX_BATCH",
    "MonteCarloStudy",
    "PointBaselines",
    "SetValuedDesignReport",
    "SetValuedStudyReport",
    "class_check_box",
    "design_setvalued_observer",
    "monte_carlo",
    "plot_study",
    "point_baselines",
    "run_baselines",
    "simulate_setvalued_observer",
]


@dataclass(frozen=True)
class PointBaselines:
    """The two point observers of ``docs/baselines.md`` set up for a :class:`DiscreteUISystem`.

    Attributes
    ----------
    lipschitz : DiscreteLipschitzObserver or None
        Lipschitz LMI observer (ignores ``d``); ``None`` when its LMI is infeasible.
    lipschitz_note : str
        The constant and structure it was designed for, or why it could not be designed.
    ekf : UnknownInputEKF or None
        EKF modelling ``d`` as white noise of covariance ``Q_d`` (``None`` when it cannot be set up, e.g. a
        non-finite ``Q_d``; ``ekf_note`` says why).
    ekf_P0 : ndarray
        Its initial covariance.
    ekf_note : str
    """

    lipschitz: DiscreteLipschitzObserver | None
    lipschitz_note: str
    ekf: UnknownInputEKF | None
    ekf_P0: Array
    ekf_note: str


def _jacobian_fd(phi: Callable[[Array], Array], n: int) -> Callable[[Array], Array]:
    """Central-difference Jacobian of a batched map (used by the EKF baseline only)."""
    def jac(x: Array) -> Array:
        x = np.asarray(x, dtype=float)
        h = 1e-6 * np.maximum(1.0, np.abs(x))
        cols = []
        for j in range(n):
            e = np.zeros(n)
            e[j] = 1.0
            hj = h[..., j:j + 1]
            cols.append((np.asarray(phi(x + hj * e)) - np.asarray(phi(x - hj * e))) / (2 * hj))
        return np.stack(cols, axis=-1)
    return jac


def _sparsity(phi: Callable[[Array], Array], lo: Array, hi: Array, n: int, seed: int) -> tuple[Array, Array]:
    """``E``, ``F`` of ``φ = E ψ(F x) + const`` from sampled Jacobians (rows that vary, states it depends on)."""
    x = lo + (hi - lo) * np.random.default_rng(seed).random((256, n))
    J = np.abs(_jacobian_fd(phi, n)(x)).max(axis=0)
    tol = 1e-7 * max(1.0, float(J.max()))
    rows = np.flatnonzero(J.max(axis=1) > tol)
    cols = np.flatnonzero(J.max(axis=0) > tol)
    eye = np.eye(n)
    return eye[:, rows], eye[cols, :]


def point_baselines(system: DiscreteUISystem, *, q_d: float, box: tuple[ArrayLike, ArrayLike] | None = None,
                    seed: int = 0) -> PointBaselines:
    r"""Design the Lipschitz LMI observer and set up the EKF for ``system`` (``docs/baselines.md``).

    Lipschitz observer, designed by :func:`~nlobs.synthesis.discrete_lipschitz.design_discrete_lipschitz_gain`
    for ``f = A_b x + φ_b``: Class I ``(A, L)``; Class III ``(A, σ̃)``; Class 0 ``(A, k)`` with ``k`` the increment
    bound of (2) when ``M11 ≺ 0``; Class II ``(A + 𝒜, 0)``, the bounded remainder of Lemma 2.14 acting as a
    disturbance. When the constant is positive the structured bound ``φ = Eψ(Fx)`` is used, with the rows
    that vary and the states ``φ`` depends on read from Jacobians sampled in ``box`` (a sampled structure:
    evidence, not proof). EKF: ``Q_w = η_w²/(n_w + 2) I``, ``R_v = η_v²/(l + 2) I`` (covariances of the
    uniform distribution in the noise balls), ``Q_d = q_d I``, ``P₀ = δ₀²/(n + 2) I``, Jacobian of ``φ`` by
    central differences.

    Parameters
    ----------
    system : DiscreteUISystem
        The system with unknown inputs.
    q_d : float
        Intensity of the EKF's white-noise model of the unknown input ``d`` (``Q_d = q_d I``).
    box : tuple of (array_like, array_like), optional
        ``(lo, hi)`` where the Jacobians of ``φ`` are sampled; default ``x0 ± max(10 δ₀, 1)``.
    seed : int
        State of the random generator of the sampled Jacobians.

    Returns
    -------
    PointBaselines
        The Lipschitz observer and the EKF (each ``None`` when not set up), with notes saying why.
    """
    from nlobs.errors import CertificateError, DesignInfeasible
    from nlobs.synthesis.discrete_lipschitz import design_discrete_lipschitz_gain
    from nlobs.systems.discrete_ui import LPV, QCStar

    n, fc = system.n, system.function_class
    phi = system.nonlinear
    if box is None:
        half = max(10.0 * system.delta0, 1.0)
        lo, hi = system.x0 - half, system.x0 + half
    else:
        lo, hi = np.asarray(box[0], dtype=float), np.asarray(box[1], dtype=float)
    A_b, L_b = system.A, math.nan
    if isinstance(fc, Lipschitz):
        L_b = fc.L
    elif isinstance(fc, LPV):
        L_b = fc.sigma
    elif isinstance(fc, QCStar):
        A_b, L_b = system.A + fc.A_aux, 0.0
    else:
        L_b = fc.increment_bound(np.zeros((n, n)), np.eye(n))[0]
    lip: DiscreteLipschitzObserver | None = None
    if not math.isfinite(L_b):
        note = f"not designed: {fc.label} gives no Lipschitz bound (M11 is not negative definite)"
    else:
        E, F = (None, None) if L_b == 0 else _sparsity(phi, lo, hi, n, seed)
        try:
            cert = design_discrete_lipschitz_gain(A_b, system.C, lipschitz=L_b, E=E, F=F)
            lip = DiscreteLipschitzObserver(system.A, system.C, cert.gain, system.time, phi=system.nonlinear,
                                            B=system.B, D=system.D)
            note = (f"designed for γ = {L_b:.4g}" + ("" if E is None else f", φ = Eψ(Fx) with {E.shape[1]} rows "
                    f"and {F.shape[0]} states") + f": ρ = {cert.rho:.4g}, spectral radius {cert.spectral_radius:.4g}")
        except (DesignInfeasible, CertificateError) as exc:  # a baseline that cannot be certified is left out
            note = f"not designed: {exc}"
    from nlobs.errors import NlobsError

    ekf: UnknownInputEKF | None
    P0 = max(system.delta0, 1e-6) ** 2 / (n + 2) * np.eye(n)
    try:
        ekf = UnknownInputEKF(system.A, system.C, system.time,
                              Q_w=system.eta_w**2 / (system.n_w + 2) * np.eye(system.n_w),
                              R_v=max(system.eta_v, 1e-6) ** 2 / (system.l + 2) * np.eye(system.l),
                              Q_d=max(float(q_d), 1e-12) * np.eye(system.p), phi=phi,
                              phi_jacobian=_jacobian_fd(phi, n), B=system.B, D=system.D, G=system.G, H=system.H,
                              W=system.W, P0=P0)
        ekf_note = f"Q_d = {q_d:.4g} I (d modelled as white noise)"
    except NlobsError as exc:
        ekf, ekf_note = None, f"EKF diverged before its first step (not set up): {exc}"
    return PointBaselines(lip, note, ekf, P0, ekf_note)


def run_baselines(baselines: PointBaselines, system: DiscreteUISystem, y: Array,
                  u: Array | None = None) -> tuple[Array | None, Array]:
    """Run both point baselines on measurements ``y`` of shape ``(B, K + 1, l)``, from ``system.x0``.

    Parameters
    ----------
    baselines : PointBaselines
    system : DiscreteUISystem
    y : ndarray, shape (B, K + 1, l)
    u : ndarray, shape (B, K + 1, m), optional
        The known input (zeros when omitted).

    Returns
    -------
    lipschitz : ndarray of shape (B, K + 1, n), or None
        Estimates ``x̂_k`` of the Lipschitz observer (a predictor: ``x̂_k`` uses ``y_0..y_{k−1}``);
        ``None`` when it could not be designed.
    ekf : ndarray of shape (B, K + 1, n), or None
        The EKF's priors ``x̂_{k|k−1}``; ``None`` when it was not set up.

    Raises
    ------
    SimulationDiverged
        The EKF diverged (its innovation covariance became singular or non-finite: ``LinAlgError``).
    """
    B, K1, _ = y.shape
    x0 = np.broadcast_to(system.x0, (B, system.n))
    t = np.arange(K1) * system.time.dt
    uu = np.zeros((B, K1, system.m)) if u is None else u
    lip = None
    if baselines.lipschitz is not None:
        lip = run_observer(baselines.lipschitz, t, x_hat0=x0, u=uu, y=y, divergence="keep").x_hat
    if baselines.ekf is None:
        return lip, None
    return lip, run_observer(baselines.ekf, t, x_hat0=x0, u=uu, y=y, divergence="keep").x_hat


@dataclass(frozen=True)
class MonteCarloStudy:
    """Algorithm 1 and the point baselines on the same Monte Carlo runs.

    Attributes
    ----------
    containment : ContainmentResult
    batch : SimulationResult
        The runs themselves (of :func:`simulate_batch`, for plots).
    final_error_state : float
        ``max_runs ‖x_K − x̂_{K|K}‖`` of the set-valued observer.
    baseline_lipschitz_final_error, baseline_ekf_final_error : float or None
        ``max_runs ‖x_K − x̂_K‖`` of the baselines (``None`` when not designed / not run).
    baseline_lipschitz_errors, baseline_ekf_errors : ndarray or None, shape (B, K + 1)
    baselines : PointBaselines or None
    baseline_lipschitz_x_hat, baseline_ekf_x_hat : ndarray or None, shape (B, K + 1, n)
        The baselines' estimates (for plots).
    baseline_ekf_failure : str or None
        Why the EKF produced no estimates on these runs (e.g. "EKF diverged at step …").

    Examples
    --------
    A 2-state system with ``φ(x) = [0, 0.1 x₁³]`` (0.3-Lipschitz on ``|x₁| ≤ 1``) and one unknown input
    ``d = 0.2 sin t``: 40 runs of 60 steps of Algorithm 1 of Khajenejad & Yong and, on the same runs, the
    point baselines. The certified balls contain the truth in every run, and the centre's final error is
    below the final radius and below both baselines':

    >>> import numpy as np
    >>> from nlobs.synthesis.setvalued import design_setvalued
    >>> from nlobs.systems.discrete_ui import DiscreteUISystem, Lipschitz
    >>> from nlobs.systems.timebase import Discrete
    >>> system = DiscreteUISystem([[0.5, 0.2], [0.0, 0.3]], [[1.0], [0.0]], [[1.0, 0.0], [0.0, 0.0]], [[0.0], [1.0]],
    ...                           phi=lambda x: np.stack([0 * x[..., 0], 0.1 * x[..., 0] ** 3], axis=-1),
    ...                           function_class=Lipschitz(0.3, 2), eta_w=0.01, eta_v=0.01, delta0=0.5,
    ...                           time=Discrete(1.0))
    >>> box = (np.array([-1.0, -1.0]), np.array([1.0, 1.0]))
    >>> study = monte_carlo(system, design_setvalued(system), lambda t: (0.2 * np.sin(t))[:, None], runs=40,
    ...                     steps=60, box=box)
    >>> study.batch.x.shape, study.containment.rate_state, study.containment.guarantee_held
    ((40, 61, 2), 1.0, True)
    >>> bool(study.final_error_state < study.containment.final_radius_state), study.baseline_ekf_failure
    (True, None)
    >>> bool(study.final_error_state < study.baseline_ekf_final_error < study.baseline_lipschitz_final_error)
    True
    """

    containment: ContainmentResult
    batch: SimulationResult = field(repr=False)
    final_error_state: float
    baseline_lipschitz_final_error: float | None
    baseline_ekf_final_error: float | None
    baseline_lipschitz_errors: Array | None = field(repr=False)
    baseline_ekf_errors: Array | None = field(repr=False)
    baselines: PointBaselines | None = field(repr=False)
    baseline_lipschitz_x_hat: Array | None = field(default=None, repr=False)
    baseline_ekf_x_hat: Array | None = field(default=None, repr=False)
    baseline_ekf_failure: str | None = None


def monte_carlo(system: DiscreteUISystem, design: SetValuedDesign, unknown_input: Callable[[Array], Array], *,
                runs: int, steps: int, seed: int = 0, baselines: bool | PointBaselines = True,
                q_d: float | None = None, box: tuple[ArrayLike, ArrayLike] | None = None,
                label: str = "sound", known_input: Callable[[float], Any] | None = None) -> MonteCarloStudy:
    """Containment of Algorithm 1 and, on the same runs, the errors of the point baselines.

    Parameters
    ----------
    system : DiscreteUISystem
    design : SetValuedDesign
        A verified design (its sound radii are used).
    unknown_input : callable
        ``t`` ``(K + 1,)`` → ``d`` ``(K + 1, p)``, the same in every run.
    runs, steps : int
    seed : int
        Seed of the initial states and noises (:func:`simulate_batch`).
    baselines : bool or PointBaselines
        ``True``: set them up with :func:`point_baselines`; ``False``: Algorithm 1 only.
    q_d : float, optional
        The EKF's ``Q_d = q_d I``; by default the mean square of ``unknown_input`` over the horizon (pass
        the bounded signal's to see how a filter tuned for a bounded ``d`` copes with a growing one).
    box : (lo, hi), optional
        Where the class was checked: the baselines' structure is sampled there, and runs whose states leave
        it are counted (``ContainmentResult.left_box_runs``).
    label : str
    known_input : callable, optional
        ``t ↦ u(t)`` ``(m,)``: the known input of ``B u``, ``D u`` (zero when omitted), given to the
        plant, Algorithm 1 and the baselines alike.

    Returns
    -------
    MonteCarloStudy

    Examples
    --------
    ``φ(x) = [0, 0.1 x₁³]`` is 0.3-Lipschitz only on ``|x₁| ≤ 1``, the box where the class is checked. Under
    ``d = 0.2 sin t`` the runs stay there and the guarantee of Algorithm 1 (Khajenejad & Yong) holds; under
    ``d = 0.8 + 0.2 sin t`` they leave the box, the class is violated along them, and the result names that
    likely cause instead of claiming the guarantee:

    >>> import numpy as np
    >>> from nlobs.synthesis.setvalued import design_setvalued
    >>> from nlobs.systems.discrete_ui import DiscreteUISystem, Lipschitz
    >>> from nlobs.systems.timebase import Discrete
    >>> system = DiscreteUISystem([[0.5, 0.2], [0.0, 0.3]], [[1.0], [0.0]], [[1.0, 0.0], [0.0, 0.0]], [[0.0], [1.0]],
    ...                           phi=lambda x: np.stack([0 * x[..., 0], 0.1 * x[..., 0] ** 3], axis=-1),
    ...                           function_class=Lipschitz(0.3, 2), eta_w=0.01, eta_v=0.01, delta0=0.5,
    ...                           time=Discrete(1.0))
    >>> design = design_setvalued(system)
    >>> box = (np.array([-1.0, -1.0]), np.array([1.0, 1.0]))
    >>> inside = monte_carlo(system, design, lambda t: (0.2 * np.sin(t))[:, None], runs=40, steps=60,
    ...                      baselines=False, box=box).containment
    >>> inside.guarantee_held, inside.rate_state, inside.left_box_runs, inside.coverage.covers_run
    (True, 1.0, 0, True)
    >>> outside = monte_carlo(system, design, lambda t: (0.8 + 0.2 * np.sin(t))[:, None], runs=40, steps=60,
    ...                       baselines=False, box=box).containment
    >>> outside.guarantee_held, outside.left_box_runs, outside.class_violated_in_runs
    (False, 40, 40)
    >>> outside.likely_causes()[1]
    'the state or its estimate left the box where the class was checked in 40 of 40 runs'
    """
    batch = simulate_batch(system, design, unknown_input, runs=runs, steps=steps, seed=seed, known_input=known_input)
    u_grid = batch.extras["u"]
    res = containment_of(batch, label, system=system, gain=design, box=box)
    fe = float(res.errors[:, -1].max())
    if baselines is False:
        return MonteCarloStudy(res, batch, fe, None, None, None, None, None)
    pb = baselines if isinstance(baselines, PointBaselines) else point_baselines(
        system, q_d=(float(np.mean(batch.extras["d"][0] ** 2)) if system.p else 0.0) if q_d is None else q_d, box=box,
        seed=seed)
    failure = None if pb.ekf is not None else pb.ekf_note
    with np.errstate(over="ignore", invalid="ignore"):
        try:
            lip, ekf = run_baselines(pb, system, batch.y, u_grid)
        except SimulationDiverged as exc:  # the EKF's covariance broke down: report it, keep the other results
            failure = str(exc)
            lip, ekf = run_baselines(dataclasses.replace(pb, ekf=None), system, batch.y, u_grid)
        el = None if lip is None else np.linalg.norm(batch.x - lip, axis=-1)
        ee = None if ekf is None else np.linalg.norm(batch.x - ekf, axis=-1)
    if ee is not None and not np.all(np.isfinite(ee[:, -1])) and failure is None:
        failure = "EKF diverged (non-finite estimates)"

    def final(e: Array | None) -> float | None:
        if e is None:
            return None
        v = float(np.max(e[:, -1]))
        return v if math.isfinite(v) else math.inf

    return MonteCarloStudy(res, batch, fe, final(el), final(ee), el, ee, pb, lip, ekf, failure)


def plot_study(study: MonteCarloStudy, path: str | Path, *, title: str = "", dt: float = 1.0) -> Path:
    """Errors of Algorithm 1 against its radii, and the baselines' errors on the same runs (log scale).

    Parameters
    ----------
    study : MonteCarloStudy
        The study to plot.
    path : str or Path
        Where the figure is saved.
    title : str
        Title of the upper panel.
    dt : float
        Time step; ``1.0`` labels the axis by step ``k``.

    Returns
    -------
    Path
        The file written.
    """
    from matplotlib.figure import Figure

    res = study.containment
    t = np.arange(res.steps + 1) * dt
    fig = Figure(figsize=(8.0, 6.0), layout="constrained")
    ax, axd = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2)
    ax.fill_between(t, np.min(res.errors, axis=0), np.max(res.errors, axis=0), color="C0", alpha=0.25,
                    label=f"set-valued: error range ({res.runs} runs)")
    ax.plot(t, res.radii.state, "C0--", lw=2, label="set-valued: radius δˣ_k")
    for errs, col, name in ((study.baseline_lipschitz_errors, "C3", "Lipschitz LMI observer"),
                            (study.baseline_ekf_errors, "C2", "EKF, d as noise")):
        if errs is not None:
            ax.fill_between(t, np.min(errs, axis=0), np.max(errs, axis=0), color=col, alpha=0.2)
            ax.plot(t, np.median(errs, axis=0), color=col, lw=1.2, label=f"{name}: median error (band: range)")
    ax.set_yscale("log")
    ax.set_ylabel("‖x_k − x̂_k‖")
    ax.set_title(title)
    ax.legend(fontsize=7)
    b = study.batch
    de = np.linalg.norm(b.extras["d"][:, :-1] - input_estimates(b), axis=-1)
    axd.fill_between(t[:-1], de.min(axis=0), de.max(axis=0), color="C0", alpha=0.25, label="input error range")
    axd.plot(t[:-1], res.radii.input, "C0--", lw=2, label="input radius δᵈ_{k−1}")
    axd.set_yscale("log")
    axd.set_xlabel("t [s]" if dt != 1.0 else "step k")
    axd.set_ylabel("‖d_{k−1} − d̂_{k−1}‖")
    axd.legend(fontsize=7)
    return save_figure(fig, path)


# --------------------------------------------------------------------------- the two commands


@dataclass(frozen=True, eq=False)
class SetValuedBaselineStudy:
    """Algorithm 1 and the point baselines on the same runs, a batch at a time (:func:`nlobs.simulate.monte_carlo`).

    A batch is :func:`monte_carlo` on the batch's generator; its per-run values are
    :func:`nlobs.simulate.setvalued.run_summaries` and the baselines' final errors
    (``baseline_lipschitz_final_error``, ``baseline_ekf_final_error``; ``inf`` where an estimate is not
    finite, NaN where a baseline was not run) with ``baseline_ekf_failure`` (why the EKF gave none, else empty).
    """

    system: DiscreteUISystem
    design: SetValuedDesign
    unknown_input: Callable[[Array], Array]
    unknown_input_label: str
    steps: int
    baselines: PointBaselines | None
    q_d: float | None
    box: tuple[ArrayLike, ArrayLike] | None
    known_input: Callable[[float], Any] | None = None
    default_batch: int = 1000

    @property
    def name(self) -> str:
        return f"set-valued {self.system.name}"

    def key(self) -> str:
        from nlobs.simulate.setvalued import SetValuedStudy

        inner = SetValuedStudy(self.system, self.design, self.unknown_input, self.steps, self.unknown_input_label,
                               box=self.box).key()
        return f"{inner}|baselines={self.baselines is not None}|q_d={self.q_d!r}"

    def prepare(self) -> None:
        return None

    def batch_study(self, rng: np.random.Generator, runs: int) -> MonteCarloStudy:
        """The whole :class:`MonteCarloStudy` of one batch (the figures use the first)."""
        with np.errstate(over="ignore", invalid="ignore"):
            return monte_carlo(self.system, self.design, self.unknown_input, runs=runs, steps=self.steps, seed=rng,
                               baselines=self.baselines if self.baselines is not None else False, q_d=self.q_d,
                               box=self.box, known_input=self.known_input)

    def run(self, prepared: Any, rng: np.random.Generator, runs: int, trajectories: bool) -> Any:
        from nlobs.simulate.montecarlo import RunBatch
        from nlobs.simulate.setvalued import run_summaries

        st = self.batch_study(rng, runs)
        out = run_summaries(st.batch, self.system, self.design, self.box, containment=st.containment)

        def final(e: Array | None) -> Array:
            if e is None:
                return np.full(runs, np.nan)
            return np.where(np.isfinite(e[:, -1]), e[:, -1], np.inf)

        out["baseline_lipschitz_final_error"] = final(st.baseline_lipschitz_errors)
        out["baseline_ekf_final_error"] = final(st.baseline_ekf_errors)
        out["baseline_ekf_failure"] = np.full(runs, (st.baseline_ekf_failure or "").encode("utf-8")[:DETAIL_BYTES])
        traj = {} if not trajectories else {"x": st.batch.x, "x_hat": st.batch.x_hat}
        return RunBatch(out, traj)


#: The largest Monte Carlo batch, runs · (steps + 1) · n (one batch is held in memory).
MAX_BATCH = 5e8
#: Bytes the study holds per element of the batch: about 8 float64 arrays of runs · (steps + 1) · n
#: (truth, centres, radii, errors and their temporaries; measured: 1.0 GB at 20000 runs × 201 × 4).
STUDY_BYTES_PER_ELEMENT = 64
#: Bytes of per-run summaries a chunked study keeps in memory (about 20 values and two short texts).
SUMMARY_BYTES_PER_RUN = 400
#: Most memory a Monte Carlo study may take; a larger one is refused before the design.
MAX_STUDY_BYTES = 4 * 1024**3


_STUDY_KEYS: dict[str, Node] = {
    "runs": INTEGER, "steps": INTEGER, "seed": INTEGER, "unknown_input": STRING, "objective": STRING,
    "rho": NUMBER.about("the certified l2 gain with the hinf objective; null for the radius design"),
    "rho_meaning": STRING, "contraction_factor": NUMBER,
    "containment_rate_state": NUMBER.about("fraction of runs whose truth stayed inside the ball at every step"),
    "containment_rate_input": NUMBER, "first_violation_step": nullable(INTEGER),
    "final_radius_state": NUMBER, "final_radius_input": NUMBER, "steady_radius_state": NUMBER,
    "max_error_over_radius": NUMBER, "max_error_over_radius_after_step_0": NUMBER, "final_error_state": NUMBER,
    "baseline_lipschitz_final_error": NUMBER, "baseline_ekf_final_error": NUMBER,
    "baseline_lipschitz_note": STRING, "baseline_ekf_note": STRING, "baseline_ekf_failure": nullable(STRING),
    "guarantee_held": BOOLEAN, "likely_causes": array(STRING), "class_violated_in_runs": INTEGER,
    "class_worst_margin_in_runs": NUMBER, "left_box_runs": INTEGER, "roundoff_runs": INTEGER,
    "roundoff_over_radius": NUMBER, "max_abs_unknown_input": NUMBER, "warnings": array(STRING),
    **COVERAGE_JSON.fields,
    "seconds": NUMBER,
    "monte_carlo": Record("MonteCarloSplit", {
        "batch": INTEGER, "chunk": INTEGER, "chunks": INTEGER, "resumed_chunks": INTEGER, "executor": STRING,
        "workers": INTEGER, "out": nullable(STRING), "trajectories": array(STRING)},
        description="how the runs were split and where they ran"),
    "figures": array(STRING),
}

#: ``nlobs simulate setvalued`` when an observer exists (else the design's report,
#: :data:`~nlobs.methods.setvalued.SETVALUED_DESIGN_REPORT_JSON`).
SETVALUED_STUDY_JSON = Record("SimulateSetValued", {
    "model": STRING, **_STUDY_KEYS,
    **{k: SETVALUED_DESIGN_REPORT_JSON.fields[k] for k in ("design", "structure", "class_check")},
}, description="Algorithm 1 of Khajenejad & Yong in Monte Carlo: containment of the truth in the certified balls, "
               "the baselines and the certificate checked along every run.")


@dataclass(frozen=True, eq=False)
class SetValuedStudyReport:
    """What ``nlobs simulate setvalued`` prints: the design report, then the Monte Carlo study.

    Attributes
    ----------
    design : SetValuedDesignReport
    study : MonteCarloStudy or None
        ``None`` when there is no observer (the design report's verdict). Its ``containment`` covers every
        run; its runs (``batch``, errors, baselines' estimates) are the first batch's, those of the figures.
    data : dict
        The JSON report (``to_dict()``).
    figures : tuple of Path
    warnings : tuple of str
    verdict : Verdict
        ``OK`` when the certified balls contained the truth in every run, ``FAILED`` (GUARANTEE VIOLATED)
        otherwise, ``NO_OBSERVER`` from the design.
    message : str
    violated : str
        Empty, or the whole ``GUARANTEE VIOLATED`` verdict with its likely cause.

    Examples
    --------
    Ten runs of 20 steps of Khajenejad & Yong's Sec. 6.1 robot without the baselines: the design report, then
    the containment of every run in the certified balls:

    >>> rep = simulate_setvalued_observer("khajenejad-6-1", runs=10, steps=20, samples=500, baselines=False)
    >>> type(rep).__name__, rep.verdict.value, rep.violated, rep.figures, type(rep.study).__name__
    ('SetValuedStudyReport', 'ok', '', (), 'MonteCarloStudy')
    >>> d = rep.to_dict()
    >>> d["runs"], d["steps"], d["containment_rate_state"], d["guarantee_held"], d["baseline_ekf_final_error"]
    (10, 20, 1.0, True, None)
    >>> print(rep.summary().splitlines()[0])
    model khajenejad-6-1: n = 4, unknown inputs p = 1, measurements l = 2; Class II ((A, γ)-QC*) (γ = -0.004436); ...
    """

    design: SetValuedDesignReport
    study: MonteCarloStudy | None
    data: dict[str, Any]
    figures: tuple[Path, ...]
    warnings: tuple[str, ...]
    verdict: Verdict
    message: str
    violated: str = ""

    def to_dict(self) -> dict[str, Any]:
        """The JSON report."""
        data = copy.deepcopy(self.data)
        return (SETVALUED_DESIGN_REPORT_JSON if self.study is None else SETVALUED_STUDY_JSON).emit(data)

    @property
    def json_message(self) -> str:
        """The line after the JSON report: the whole verdict with the likely cause."""
        return f"{self.design.model}: {self.violated}" if self.violated else self.message

    def summary(self) -> str:
        """The text report."""
        if self.study is None:
            return self.design.summary()
        d = self.design.design
        assert d is not None
        res, study, data = self.study.containment, self.study, self.data

        def num(v: float | None) -> str:
            return "n/a" if v is None else f"{v:.4g}"

        lines = [self.design.head(), d.summary(),
                 f"Monte Carlo: {data['runs']} runs x {data['steps']} steps, {data['unknown_input']} unknown input, "
                 f"seed {data['seed']} ({res.seconds:.2f} s)",
                 f"  containment (truth inside the ball at every step): state {res.rate_state:.4f}, "
                 f"input {res.rate_input:.4f}",
                 f"  final radius: state {res.final_radius_state:.4g}, input {res.final_radius_input:.4g}; "
                 f"max error/radius {res.max_error_over_radius:.4g} (after step 0: "
                 f"{data['max_error_over_radius_after_step_0']:.4g}); max final error "
                 f"{study.final_error_state:.4g}",
                 f"  baselines, max final error: Lipschitz LMI observer {num(study.baseline_lipschitz_final_error)}, "
                 f"EKF (d as noise) {num(study.baseline_ekf_final_error)}"]
        if study.baselines is not None:
            lines.append(f"    Lipschitz: {study.baselines.lipschitz_note}; EKF: "
                         f"{study.baseline_ekf_failure or study.baselines.ekf_note}")
        cov = res.coverage
        if cov is not None:
            lines.append(f"  certificate covers {cov.covered_runs} of {cov.runs} runs (hypotheses checked along "
                         "every run: " + "; ".join(cov.hypotheses) + ")")
        lines += [f"wrote {f}" for f in self.figures]
        lines += [f"warning: {w}" for w in self.warnings]
        if self.violated:
            lines.append(self.violated)
        return "\n".join(lines)


def _aggregate(first: ContainmentResult, v: dict[str, Array], seconds: float,
               box: tuple[ArrayLike, ArrayLike] | None) -> ContainmentResult:
    """The containment of every run from the per-run values of a chunked study (``first``: batch 0's, for the
    radii, the hypotheses checked and the failed premises, the same in every batch)."""
    from nlobs.simulate.coverage import Coverage, Violation

    R = int(v["contained"].shape[0])
    fv = v["first_violation_step"]
    cov = first.coverage
    coverage = None
    if cov is not None:
        runs_v = np.flatnonzero(v["violation_hypothesis"] >= 0)
        names = [*cov.hypotheses, "another hypothesis"]
        coverage = Coverage(cov.hypotheses, cov.failed_premises, tuple(
            Violation(int(i), names[int(v["violation_hypothesis"][i])], float(v["violation_time"][i]),
                      bytes(v["violation_detail"][i]).decode("utf-8", "ignore")) for i in runs_v), R, cov.verified)
    margins = v["class_margin"]
    return dataclasses.replace(
        first, runs=R, rate_state=float(v["contained"].mean()), rate_input=float(v["input_contained"].mean()),
        max_error_over_radius=float(np.max(v["max_error_over_radius"])),
        first_violation_step=int(fv[fv >= 0].min()) if np.any(fv >= 0) else None, seconds=seconds,
        class_violated_in_runs=(int(np.sum(v["class_violated"])) if first.class_violated_in_runs is not None
                                else None),
        class_worst_margin=(float(np.min(margins)) if first.class_worst_margin is not None else None),
        left_box_runs=int(np.sum(v["left_box"])) if box is not None and "left_box" in v else first.left_box_runs,
        roundoff_runs=int(np.sum(v["roundoff"])) if first.roundoff_runs is not None else None,
        roundoff_ratio=float(np.max(v["roundoff_ratio"])) if first.roundoff_ratio is not None else None,
        coverage=coverage)


def simulate_setvalued_observer(model: str | Path | DiscreteUIModel, *, runs: int = 1000, steps: int = 200,
                                unknown_input: str = "bounded", seed: int = 0, objective: str = "radius",
                                baselines: bool = True, samples: int = 20_000,
                                out: str | Path | None = None, batch: int | None = None, chunk: int | None = None,
                                executor: Any = None, workers: int | None = None, scheduler: str | None = None,
                                trajectories: bool = False, progress: bool | None = None) -> SetValuedStudyReport:
    """Design Algorithm 1's gain (:func:`design_setvalued_observer`) and run it in Monte Carlo with the baselines.

    The runs go through :func:`nlobs.simulate.monte_carlo` (batches of ``batch`` runs, each from its own
    seed stream), here or on Dask: the numbers do not depend on ``chunk`` or on how many workers ran them.

    Parameters
    ----------
    model : str, Path or DiscreteUIModel
        A model file with unknown inputs, a shipped name, or a loaded model.
    runs, steps : int
        Monte Carlo runs and steps per run (one batch: ``batch·(steps + 1)·n ≤`` :data:`MAX_BATCH`, and about
        :data:`STUDY_BYTES_PER_ELEMENT` bytes each at most :data:`MAX_STUDY_BYTES`).
    unknown_input : {"bounded", "growing"}
        The file's signal ``d(t)``.
    seed : int
        Seed of the initial states and noises (the root of every batch's seed stream).
    objective : str
        The design objective.
    baselines : bool
        Also run the Lipschitz LMI observer and the EKF on the same runs.
    samples : int
        Sampled pairs for the function-class check.
    out : str or Path, optional
        Folder for the figures (written atomically) and, in ``out/runs``, the chunk files: a run on the
        same folder resumes where it stopped.
    batch, chunk : int, optional
        Runs per batch (default ``min(runs, 1000)``) and per chunk (default one batch).
    executor : optional
        Where the chunks run (:func:`nlobs.simulate.monte_carlo`); at most one of it, ``workers`` and ``scheduler``.
    workers : int, optional
        Run the chunks on a Dask LocalCluster of this many single-threaded worker processes.
    scheduler : str, optional
        Run the chunks on the Dask scheduler at this address.
    trajectories : bool
        Save every run's truth and centres in the chunk files (needs ``out``).
    progress : bool, optional
        A progress bar over runs.

    Returns
    -------
    SetValuedStudyReport
        Verdict ``FAILED`` (GUARANTEE VIOLATED, with the likely cause) when a certified ball missed the truth.

    Raises
    ------
    InvalidArgumentError
        The batch is too large, or a bad scale-out option.
    StudyFailed
        The runs could not be completed (e.g. the plant overflows); the cause is chained.
    OutputError
        ``out`` cannot be written.

    Examples
    --------
    Twenty runs of 30 steps of Khajenejad & Yong's Sec. 6.1 robot under the file's bounded unknown input:
    the certified balls of Algorithm 1 contain the true state and input at every step of every run, and the
    certificate's hypotheses held along all of them:

    >>> rep = simulate_setvalued_observer("khajenejad-6-1", runs=20, steps=30, samples=2000)
    >>> d = rep.to_dict()
    >>> rep.verdict.value, d["guarantee_held"], d["containment_rate_state"], d["containment_rate_input"]
    ('ok', True, 1.0, 1.0)
    >>> d["certificate_covers_run"], bool(d["final_error_state"] < d["final_radius_state"] <= d["steady_radius_state"])
    (True, True)
    """
    from nlobs.simulate.executors import cluster
    from nlobs.simulate.montecarlo import batch_rng
    from nlobs.simulate.montecarlo import monte_carlo as run_chunks

    m = load_setvalued_model(model)
    if sum(x is not None for x in (executor, workers, scheduler)) > 1:
        raise InvalidArgumentError("`workers` and `scheduler` (or an `executor`): give one (workers start a local "
                                   "cluster, a scheduler address uses a running one)")
    if trajectories and out is None:
        raise InvalidArgumentError("`trajectories`: saving them needs an output folder (`out`)")
    width = min(SetValuedBaselineStudy.default_batch if batch is None else max(int(batch), 1), max(int(runs), 1))
    elements = width * (steps + 1) * m.system.n
    need = STUDY_BYTES_PER_ELEMENT * elements
    if elements > MAX_BATCH or need > MAX_STUDY_BYTES:
        raise InvalidArgumentError(
            f"`batch` {width} x `steps` {steps}: too large for one batch: about {need / 1024**3:.3g} GiB "
            f"({STUDY_BYTES_PER_ELEMENT} bytes per run, step and state, n = {m.system.n}); at most "
            f"{MAX_STUDY_BYTES / 1024**3:g} GiB (lower `batch` or `steps`; `runs` may be any number)")
    if int(runs) * SUMMARY_BYTES_PER_RUN > MAX_STUDY_BYTES:
        raise InvalidArgumentError(
            f"`runs` {runs}: the per-run summaries alone would take about "
            f"{int(runs) * SUMMARY_BYTES_PER_RUN / 1024**3:.3g} GiB ({SUMMARY_BYTES_PER_RUN} bytes per run); at most "
            f"{MAX_STUDY_BYTES / 1024**3:g} GiB (split the study: the same `seed` and `batch` with more runs keep "
            "the first runs' numbers)")
    if out is not None:
        try:
            prepare_output_dir(out)
        except OSError as exc:
            raise OutputError(f"`out` {out}: {exc.strerror or exc}") from exc
    rep = design_setvalued_observer(m, objective=objective, samples=samples, seed=0)
    rep = dataclasses.replace(rep, model=str(model) if not isinstance(model, DiscreteUIModel) else rep.model,
                              message=rep.message.replace(rep.model, str(model), 1)
                              if not isinstance(model, DiscreteUIModel) else rep.message)
    if rep.design is None:
        return SetValuedStudyReport(rep, None, rep.to_dict(), (), (), rep.verdict, rep.message)
    d = rep.design
    s = m.system
    box = class_check_box(m)
    t = np.arange(steps + 1) * s.time.dt
    with np.errstate(over="ignore", invalid="ignore"):  # a non-finite Q_d is reported by the EKF's note
        q_d = float(np.mean(m.signals["bounded"](t) ** 2)) if s.p else 0.0
    try:
        pb = point_baselines(s, q_d=q_d, box=box, seed=seed) if baselines else None
        recipe = SetValuedBaselineStudy(s, d, m.signals[unknown_input], unknown_input, steps, pb, q_d, box,
                                        m.known_input)
        # overflow in the runs is not silent: the plant's raises SimulationDiverged, the observer's and the
        # round-off it causes are measured (ContainmentResult.roundoff_runs) and reported below
        with cluster(workers, scheduler) as client:
            mc = run_chunks(recipe, runs, seed=seed, batch=width, chunk=chunk,
                            executor=executor if executor is not None else client,
                            out=None if out is None else Path(out) / "runs", trajectories=trajectories,
                            progress=progress)
        study = recipe.batch_study(batch_rng(mc.seed, 0), mc.batch)  # the first batch: figures, the radii
    except (InvalidArgumentError, OutputError):
        raise
    except NlobsError as exc:
        raise StudyFailed(str(exc)) from exc
    res = _aggregate(study.containment, mc.summaries, mc.seconds, box)
    v = mc.summaries
    causes = res.likely_causes()
    held = res.guarantee_held
    warnings = []
    if res.class_violated_in_runs:
        warnings.append(f"the function class is violated along the trajectories in {res.class_violated_in_runs} "
                        f"of {runs} runs (worst QC − γ = {res.class_worst_margin:.4g}): the certificate does not "
                        "apply to these runs")
    if res.left_box_runs:
        warnings.append(f"the state or its estimate left the box where the class was checked ({box[0].tolist()} "
                        f"to {box[1].tolist()}) in {res.left_box_runs} of {runs} runs; on the visited pairs the "
                        "class condition " + ("is VIOLATED" if res.class_violated_in_runs else "holds"))
    if res.roundoff_runs:
        warnings.append(f"floating-point round-off reaches {res.roundoff_ratio:.3g} × the radius in "
                        f"{res.roundoff_runs} of {runs} runs (|d| = {res.max_abs_input:.4g}): containment may be "
                        "lost to round-off (docs/setvalued.md, 'Soundness conditions')")

    def worst(name: str) -> float | None:
        e = v[name]
        if np.all(np.isnan(e)):
            return None
        m_ = float(np.nanmax(e))
        return m_ if math.isfinite(m_) else math.inf

    fails = [f.decode("utf-8", "ignore") for f in dict.fromkeys(v["baseline_ekf_failure"].tolist()) if f]
    ekf_failure = fails[0] if fails else None
    if ekf_failure is None and pb is not None and pb.ekf is not None and not np.all(
            np.isfinite(v["baseline_ekf_final_error"])):
        ekf_failure = "EKF diverged (non-finite estimates)"
    study = dataclasses.replace(study, baseline_ekf_failure=ekf_failure, baseline_lipschitz_final_error=worst(
        "baseline_lipschitz_final_error"), baseline_ekf_final_error=worst("baseline_ekf_final_error"),
        final_error_state=float(np.max(v["final_error"])))
    after0 = v["max_error_over_radius_after_step_0"]
    data = rep.data
    out_data = {
        "model": s.name, "runs": runs, "steps": steps, "seed": seed, "unknown_input": unknown_input,
        "objective": d.objective.value,
        "rho": d.rho,
        "rho_meaning": ("ℓ2 gain bound ρ of Definition 5.9 (hinf design)" if d.rho is not None else
                        "null: the radius design certifies no ℓ2 gain (the hinf objective gives one, needs γ ≥ 0)"),
        "contraction_factor": math.sqrt(d.lam_eff),
        "containment_rate_state": res.rate_state, "containment_rate_input": res.rate_input,
        "first_violation_step": res.first_violation_step,
        "final_radius_state": res.final_radius_state, "final_radius_input": res.final_radius_input,
        "steady_radius_state": d.steady_radius,
        "max_error_over_radius": res.max_error_over_radius,
        "max_error_over_radius_after_step_0": float(np.max(after0)) if steps >= 1 else None,
        "final_error_state": study.final_error_state,
        "baseline_lipschitz_final_error": study.baseline_lipschitz_final_error,
        "baseline_ekf_final_error": study.baseline_ekf_final_error,
        "baseline_lipschitz_note": pb.lipschitz_note if pb else None,
        "baseline_ekf_note": pb.ekf_note if pb else None,
        "baseline_ekf_failure": ekf_failure,
        "guarantee_held": held,
        "likely_causes": causes if not held else [],
        "class_violated_in_runs": res.class_violated_in_runs,
        "class_worst_margin_in_runs": res.class_worst_margin,
        "left_box_runs": res.left_box_runs,
        "roundoff_runs": res.roundoff_runs,
        "roundoff_over_radius": res.roundoff_ratio,
        "max_abs_unknown_input": res.max_abs_input,
        "warnings": warnings,
        **(res.coverage.to_dict() if res.coverage is not None else {}),
        "seconds": res.seconds, "design": data["design"], "structure": data["structure"],
        "class_check": data["class_check"],
        "monte_carlo": {k: mc.to_dict()[k] for k in ("batch", "chunk", "chunks", "resumed_chunks", "executor",
                                                     "workers", "out", "trajectories")},
    }
    violated = ("GUARANTEE VIOLATED: the certified balls did not contain the truth in every run (state "
                f"{res.rate_state:.4f}, input {res.rate_input:.4f}); likely cause: "
                + ("; ".join(causes) if causes else "none found (class held on the visited pairs, states stayed in "
                   "the box, no round-off flagged): please report it"))
    figures: list[Path] = []
    if out is not None:
        folder = Path(out)
        first = f"first {mc.batch} of " if mc.batch < runs else ""
        try:
            figures.append(plot_study(study, folder / f"{s.name}-{unknown_input}-errors.png",
                                      title=f"{s.name}, {unknown_input} d, {first}{runs} runs", dt=s.time.dt))
            figures.append(plot_trajectories(study.batch, folder / f"{s.name}-{unknown_input}-run0.png",
                                             title=f"{s.name}, {unknown_input} d, run 0"))
        except OSError as exc:
            raise OutputError(f"`out` {out}: {exc}") from exc
    out_data["figures"] = [str(f) for f in figures]
    # the report's study: every run's containment; its trajectories and errors are the first batch's
    study = dataclasses.replace(study, containment=res)
    label = rep.model
    if held:
        return SetValuedStudyReport(rep, study, out_data, tuple(figures), tuple(warnings), Verdict.OK, "")
    return SetValuedStudyReport(rep, study, out_data, tuple(figures), tuple(warnings), Verdict.FAILED,
                                f"{label}: GUARANTEE VIOLATED (containment state {res.rate_state:.4f}, input "
                                f"{res.rate_input:.4f})", violated=violated)
