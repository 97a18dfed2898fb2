"""Röbenack (2008), Section 5: Example (21), the Moore–Penrose gain (26) against the Byrnes–Isidori gain (24).

Model (21) (Isidori, p. 146; shipped as ``isidori-146.toml`` with ``k = 2``)::

    ẋ = (x1 x2 − x1³, x1, −x3, x1² + x2)ᵀ + (0, 2 + 2 x3, 1, 0)ᵀ u,   y = x4.

:func:`symbolic_findings` recomputes every symbolic statement of Section 5 with
:mod:`nlobs.geometry` and :mod:`nlobs.observers` and compares it with the
printed formula (``simplify(a − b) == 0`` plus a numeric spot check at random
points); :func:`simulate_scenarios` runs both observers (7) on bounded inputs
``u = a + sin t`` along trajectories that cross ``x3 = −1``; :func:`plot_scenario`
draws them; :func:`rows` is ``nlobs reproduce robenack2008``. Measured results
are in ``docs/pinv.md``.

Two findings that differ from the paper as printed:

* The text gives ``φ4(x) = x4`` but the Jacobian (23) has last row ``(1 0 0 0)``,
  i.e. ``φ4 = x1`` (``φ4 = x4 = h`` would make ``Φ'`` singular everywhere).
* ``(Φ')⁻¹ [k; 0]`` with (23) is ``(0, k2, k2/(2 + 2x3), k1)ᵀ``; (24) as printed
  reads ``(0, k2, k2, (2 + 2x3)/k1)ᵀ`` (its entries 3–4 are garbled: the fraction
  ``k2/(2+2x3)`` and ``k1``). The pole at ``x3 = −1`` the paper states holds for the
  derived gain (the printed one has no pole).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sp

from nlobs._io import save_figure
from nlobs._typing import Array
from nlobs.errors import ModelError, SimulationDiverged
from nlobs.geometry import (
    AffineFields,
    Box,
    gain_symbols,
    lie_bracket,
    lie_derivative,
    observability_rank,
)
from nlobs.observers import ByrnesIsidoriObserver, PinvObserver
from nlobs.papers.reproduce import ReproRow
from nlobs.simulate import SimulationResult, simulate
from nlobs.synthesis import HighGain
from nlobs.systems import SymbolicModel, load_model
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.expressions import as_sympy_matrix

if TYPE_CHECKING:
    from matplotlib.figure import Figure


#: High-gain parameter of the example's runs: roots −θ, −θ² of (10), k = (12, 27).
THETA = 3.0
#: Simulation horizon and RK4 step of the example's runs (seconds).
DURATION = 10.0
DT = 1e-3
#: ‖l(x̂)‖ above this counts as "the gain blows up".
GAIN_BLOWUP = 1e3


def model() -> SymbolicModel:
    """Model (21) from the shipped ``isidori-146.toml`` (parameter ``k = 2``: ``g2 = 2 + 2 x3``)."""
    path = resources.files("nlobs") / "data" / "models" / "isidori-146.toml"
    m = load_model(Path(str(path)))
    if not isinstance(m, SymbolicModel):  # pragma: no cover - the shipped file is nonlinear
        raise ModelError(f"{path}: expected a nonlinear model")
    return m


def paper_formulas(F: AffineFields) -> dict[str, Any]:
    """The printed formulas of Section 5 in the model's symbols (``k1, k2`` as in :func:`gain_symbols`)."""
    x1, x2, x3, x4 = F.x
    k1, k2 = gain_symbols((2,))
    d = 4 * x1**2 + 1
    return {
        "Q+ (25)": sp.Matrix([[0, 2 * x1 / d], [0, 1 / d], [0, 0], [1, 0]]),
        "l (26)": sp.Matrix([2 * k2 * x1 / d, k2 / d, 0, k1]),
        "l (24) printed": sp.Matrix([0, k2, k2, (2 + 2 * x3) / k1]),
        "l (24) derived": sp.Matrix([0, k2, k2 / (2 + 2 * x3), k1]),
        "Phi' (23)": sp.Matrix([[0, 0, 0, 1], [2 * x1, 1, 0, 0], [0, 1, -2 - 2 * x3, 0], [1, 0, 0, 0]]),
        "phi BI": (x2 - 2 * x3 - x3**2, x1),  # (22); φ4 = x1 per (23), the text says x4
        "phi BI text": (x2 - 2 * x3 - x3**2, x4),
        "phi orthogonal": (x3, x1 * sp.exp(-2 * x2)),  # nlobs: integrals of Δ = span{τ1, τ2}, (20)
    }


def _equal(a: sp.MatrixBase, b: sp.MatrixBase) -> bool:
    A, B = as_sympy_matrix("a", a), as_sympy_matrix("b", b)
    return A.shape == B.shape and all(sp.simplify(e) == 0 for e in (A - B))


def _spot(a: sp.MatrixBase, b: sp.MatrixBase, syms: Sequence[sp.Symbol], seed: int = 0, count: int = 200) -> float:
    """Largest |a − b| at ``count`` random points of ``[−3, 3]`` (every symbol, gains included)."""
    s = tuple(syms)
    pts = np.random.default_rng(seed).uniform(-3.0, 3.0, size=(count, len(s)))
    with np.errstate(all="ignore"):
        diff = compile_matrix(a, (s,))(pts) - compile_matrix(b, (s,))(pts)
    return float(np.nanmax(np.abs(diff)))


@dataclass(frozen=True)
class SymbolicFindings:
    """Section 5 recomputed. Every ``*_equals_*`` flag is ``simplify(a − b) == 0``; ``*_spot`` the numeric check.

    Attributes
    ----------
    lg_h, lg_lf_h, lg_lf2_h : sympy.Expr
        ``L_g h``, ``L_g L_f h``, ``L_g L_f² h``.
    r : int
        Observation relative degree (A1).
    observability_rank : int
        Generic rank of ``span{dh, dL_f h, dL_f² h, dL_f³ h}`` (3: one unobservable direction, ``x3``).
    Qp, gain : sympy.Matrix
        nlobs's ``Q⁺`` and ``Q⁺ k``.
    bracket : sympy.Matrix
        ``[τ1, τ2]``.
    bi_gain, bi_det : sympy.Matrix, sympy.Expr
        ``(Φ')⁻¹ [k; 0]`` and ``det Φ'`` for ``φ3 = x2 − 2x3 − x3², φ4 = x1``.
    bi_pole : tuple of str
        Where ``det Φ' = 0``.
    text_phi4_det : sympy.Expr
        ``det Φ'`` with the text's ``φ4 = x4`` (``0``).
    orthogonal_rq : sympy.Matrix
        ``R Qᵀ`` (16) for nlobs's ``φ3 = x3, φ4 = x1 e^{−2x2}`` (``0``).
    orthogonal_gain_equals_26 : bool
        ``(Φ')⁻¹[k; 0]`` with those ``φ`` equals (26) (Theorem 4.1 made explicit).
    bi_map_folds : bool
        ``Φ`` of (23) satisfies ``Φ(x1, x2, x3, x4) = Φ(x1, x2, −2 − x3, x4)``: not injective (A2 fails).
    """

    lg_h: sp.Expr
    lg_lf_h: sp.Expr
    lg_lf2_h: sp.Expr
    r: int
    observability_rank: int
    Qp: sp.Matrix
    Qp_equals_25: bool
    Qp_spot: float
    gain: sp.Matrix
    gain_equals_26: bool
    gain_spot: float
    bracket: sp.Matrix
    bracket_zero: bool
    involutive: bool
    bi_gain: sp.Matrix
    bi_det: sp.Expr
    bi_pole: tuple[str, ...]
    bi_equals_24_printed: bool
    bi_equals_24_derived: bool
    bi_spot_derived: float
    bi_jacobian_equals_23: bool
    text_phi4_det: sp.Expr
    orthogonal_rq: sp.Matrix
    orthogonal_gain_equals_26: bool
    bi_map_folds: bool
    pinv_denominator: sp.Expr

    @property
    def pinv_pole_free(self) -> bool:
        """The denominators of (26) are ``4 x1² + 1 ≥ 1``: no pole anywhere."""
        x1 = sorted(self.pinv_denominator.free_symbols, key=str)[0]
        return bool(sp.simplify(self.pinv_denominator - (4 * x1**2 + 1)) == 0)


def symbolic_findings(theta: float = THETA) -> SymbolicFindings:
    """Recompute Section 5 of Röbenack (2008) (see :class:`SymbolicFindings`)."""
    m = model()
    F = AffineFields.from_model(m)
    x = F.x
    x1, x2, x3, x4 = x
    k1, k2 = gain_symbols((2,))
    paper = paper_formulas(F)
    h = F.h[0, 0]
    g = F.g[:, 0]
    lf = [h] + [lie_derivative(h, F.f, x, i) for i in (1, 2)]
    lg = [sp.factor(lie_derivative(e, g, x)) for e in lf]
    obs = PinvObserver(F, k=HighGain(theta), region=Box.around(np.zeros(4), 3.0))
    Qp, gain = sp.Matrix(obs.Qp), sp.Matrix(obs.gain_symbolic)
    bracket = lie_bracket(Qp[:, 0], Qp[:, 1], x)
    bi = ByrnesIsidoriObserver(F, paper["phi BI"], k=HighGain(theta), region=Box.around(np.zeros(4), 3.0))
    syms = (*x, k1, k2)
    # the text's φ4 = x4
    J_text = sp.Matrix([h, lf[1], *paper["phi BI text"]]).jacobian(sp.Matrix(x))
    # nlobs's orthogonal completion (20): R Qᵀ = 0 and (Φ')⁻¹ [k; 0] = Q⁺ k
    R = sp.Matrix(list(paper["phi orthogonal"])).jacobian(sp.Matrix(x))
    J_orth = sp.Matrix.vstack(sp.Matrix(obs.Q), R)
    orth_gain = J_orth.LUsolve(sp.Matrix([k1, k2, 0, 0])).applyfunc(sp.simplify)
    phi_bi_map = sp.Matrix([h, lf[1], *paper["phi BI"]])
    folded = phi_bi_map.xreplace({x3: -2 - x3})
    den = sp.denom(sp.together(gain[1, 0]))
    return SymbolicFindings(
        lg_h=lg[0], lg_lf_h=lg[1], lg_lf2_h=lg[2], r=obs.r[0],
        observability_rank=observability_rank(F, Box.around(np.zeros(4), 3.0)),
        Qp=Qp, Qp_equals_25=_equal(Qp, paper["Q+ (25)"]), Qp_spot=_spot(Qp, paper["Q+ (25)"], syms),
        gain=gain, gain_equals_26=_equal(gain, paper["l (26)"]), gain_spot=_spot(gain, paper["l (26)"], syms),
        bracket=bracket, bracket_zero=all(sp.simplify(e) == 0 for e in bracket), involutive=obs.checks[1].passed,
        bi_gain=sp.Matrix(bi.gain_symbolic), bi_det=bi.det, bi_pole=bi.singular_set,
        bi_equals_24_printed=_equal(bi.gain_symbolic, paper["l (24) printed"]),
        bi_equals_24_derived=_equal(bi.gain_symbolic, paper["l (24) derived"]),
        bi_spot_derived=_spot(bi.gain_symbolic, paper["l (24) derived"], syms),
        bi_jacobian_equals_23=_equal(bi.jacobian, paper["Phi' (23)"]),
        text_phi4_det=sp.simplify(J_text.det()),
        orthogonal_rq=(R * sp.Matrix(obs.Q).T).applyfunc(sp.simplify),
        orthogonal_gain_equals_26=_equal(orth_gain, paper["l (26)"]),
        bi_map_folds=_equal(folded, phi_bi_map),
        pinv_denominator=den,
    )


# ----------------------------------------------------------------------------- simulations
@dataclass(frozen=True)
class SineInput:
    """The bounded input ``u(t) = offset + amplitude · sin t``."""

    offset: float = 0.0
    amplitude: float = 1.0

    def __call__(self, t: float) -> Array:
        return np.array([self.offset + self.amplitude * np.sin(t)])

    def describe(self) -> str:
        if self.offset == 0.0:
            return "sin t" if self.amplitude == 1.0 else f"{self.amplitude:g} sin t"
        amp = "" if self.amplitude == 1.0 else f"{abs(self.amplitude):g} "
        return f"{self.offset:g} {'+' if self.amplitude >= 0 else '−'} {amp}sin t".replace("-", "−")


@dataclass(frozen=True)
class Scenario:
    """A plant initial state, an initial estimate and an input."""

    slug: str
    title: str
    x0: tuple[float, ...]
    x_hat0: tuple[float, ...]
    u: SineInput


#: The example's runs: plant and estimate crossing ``x3 = −1``, and one where A4 fails.
SCENARIOS: tuple[Scenario, ...] = (
    Scenario("plant_crosses", "the plant's x3 crosses −1 (x̂3 does not)",
             (0.5, -2.0, -2.0, 0.0), (0.3, -1.5, 0.0, 0.5), SineInput()),
    Scenario("estimate_crosses", "the estimate x̂3 starts at −2.5 and crosses −1",
             (0.5, -2.0, -2.0, 0.0), (0.3, -1.5, -2.5, 0.5), SineInput()),
    Scenario("oscillates", "x3 and x̂3 oscillate about −1",
             (0.5, -2.0, -2.0, 0.0), (0.3, -1.5, -2.5, 0.5), SineInput(-1.0, 1.0)),
    Scenario("x1_zero", "x1 ≡ 0 in the plant, x̂1(0) = 0.2: the zero dynamics are unstable (A4 fails)",
             (0.0, -1.0, -1.0, 0.0), (0.2, -0.5, 0.5, 0.5), SineInput()),
)


@dataclass(frozen=True)
class ObserverRun:
    """One observer on one scenario.

    Attributes
    ----------
    observer : str
        ``"pinv"`` (gain (26)) or ``"bi"`` (gain (24)).
    result : SimulationResult or None
        ``None`` if the run diverged (``diverged`` says where).
    final_error : tuple of float
        ``x̂ − x`` at the end.
    max_gain : float
        Largest ``‖l(x̂(t))‖`` along the run (``inf`` at a pole).
    max_gain_time : float
    crossings : tuple of float
        Saved times at which ``x̂3 + 1`` changed sign.
    gain_norm : ndarray or None
        ``‖l(x̂(t))‖`` at the saved times.
    diverged : str
        Empty, or the :class:`SimulationDiverged` message.
    """

    observer: str
    result: SimulationResult | None
    final_error: tuple[float, ...]
    max_gain: float
    max_gain_time: float
    crossings: tuple[float, ...]
    gain_norm: Array | None = None
    diverged: str = ""

    @property
    def final_error_norm(self) -> float:
        return float(np.linalg.norm(self.final_error))

    @property
    def gain_blew_up(self) -> bool:
        return bool(self.max_gain > GAIN_BLOWUP) or bool(self.diverged)

    def summary(self) -> str:
        if self.diverged:
            return f"diverged: {self.diverged}"
        e = ", ".join(f"{v:.2g}" for v in self.final_error)
        cross = (f"; x̂3 crosses −1 {len(self.crossings)}× (first at t = {self.crossings[0]:.3g})"
                 if self.crossings else "")
        return f"x̂ − x at end = ({e}); max ‖l(x̂)‖ = {self.max_gain:.3g} at t = {self.max_gain_time:.3g}{cross}"


@dataclass(frozen=True)
class ScenarioResult:
    scenario: Scenario
    pinv: ObserverRun
    bi: ObserverRun


def _run(plant: Any, obs: PinvObserver | ByrnesIsidoriObserver, name: str, sc: Scenario, duration: float,
         dt: float) -> ObserverRun:
    try:
        res = simulate(plant, obs, sc.x0, sc.x_hat0, duration=duration, dt=dt, u=sc.u)
    except SimulationDiverged as exc:
        return ObserverRun(name, None, (float("nan"),) * 4, float("inf"), exc.time, (), None, str(exc))
    with np.errstate(all="ignore"):
        G = np.linalg.norm(obs.gain_at(res.x_hat)[..., 0], axis=-1)
    G = np.where(np.isfinite(G), G, np.inf)
    i = int(np.argmax(G))
    w = res.x_hat[:, 2] + 1.0
    cross = np.nonzero(np.sign(w[1:]) * np.sign(w[:-1]) < 0)[0]
    return ObserverRun(name, res, tuple(float(v) for v in res.error[-1]), float(G[i]), float(res.t[i]),
                       tuple(float(res.t[j + 1]) for j in cross), G)


def observers(theta: float = THETA) -> tuple[PinvObserver, ByrnesIsidoriObserver]:
    """The two observers of Section 5 with roots ``−θ, −θ²``: gain (26) and gain (24) (``φ3 = x2 − 2x3 − x3², φ4 = x1``)."""
    F = AffineFields.from_model(model())
    region = Box.around(np.zeros(4), 3.0)
    pinv = PinvObserver(F, k=HighGain(theta), region=region)
    bi = ByrnesIsidoriObserver(F, paper_formulas(F)["phi BI"], k=HighGain(theta), region=region)
    return pinv, bi


def simulate_scenarios(
    scenarios: Sequence[Scenario] = SCENARIOS, *, theta: float = THETA, duration: float = DURATION, dt: float = DT
) -> tuple[ScenarioResult, ...]:
    """Run both observers on each scenario (exact continuous measurement of ``y``, RK4)."""
    plant = model().compile()
    pinv, bi = observers(theta)
    return tuple(ScenarioResult(sc, _run(plant, pinv, "pinv", sc, duration, dt), _run(plant, bi, "bi", sc, duration, dt))
                 for sc in scenarios)


def plot_scenario(sr: ScenarioResult, path: str | os.PathLike[str] | None = None) -> Figure:
    """Four panels: ``x3`` and both ``x̂3`` (with ``x3 = −1``), ``x1`` and both ``x̂1``, ``‖l(x̂)‖`` and ``‖x̂ − x‖`` (log)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 8.6), layout="constrained")
    axes = fig.subplots(4, 1, sharex=True)
    runs = [(r, lab, c) for r, lab, c in ((sr.pinv, "Moore–Penrose gain (26)", "C0"),
                                            (sr.bi, "Byrnes–Isidori gain (24)", "C3")) if r.result is not None]
    ref = runs[0][0].result if runs else None
    if ref is not None:
        for ax, i, name in ((axes[0], 2, "x3"), (axes[1], 0, "x1")):
            ax.plot(ref.t, ref.x[:, i], color="k", lw=1.6, label=f"{name} (plant)")
            for r, lab, c in runs:
                assert r.result is not None
                ax.plot(r.result.t, r.result.x_hat[:, i], color=c, lw=1.1, ls="--", label=f"{name[0]}̂{name[1:]}, {lab}")
            ax.set_ylabel(name)
            ax.legend(loc="best", fontsize=7)
        axes[0].axhline(-1.0, color="grey", lw=0.8, ls=":")
        lo, hi = np.percentile(np.concatenate([ref.x[:, 2]] + [r.result.x_hat[:, 2] for r, _, _ in runs if r.result is not None]), [0.5, 99.5])
        axes[0].set_ylim(lo - 0.5, hi + 0.5)
    for r, lab, c in runs:
        assert r.result is not None
        obs_gain = r.max_gain
        G = np.where(np.isfinite(r.gain_norm), r.gain_norm, np.nan)
        axes[2].semilogy(r.result.t, G, color=c, lw=1.1, label=f"{lab} (max {obs_gain:.3g})")
        axes[3].semilogy(r.result.t, np.maximum(r.result.error_norm, 1e-12), color=c, lw=1.1, label=lab)
    axes[2].set_ylabel("‖l(x̂)‖")
    axes[3].set_ylabel("‖x̂ − x‖")
    axes[3].set_xlabel("t")
    for ax in axes[2:]:
        ax.legend(loc="best", fontsize=7)
    fig.suptitle(f"Example (21), u = {sr.scenario.u.describe()}: {sr.scenario.title}", fontsize=10)
    if path is not None:
        save_figure(fig, path, dpi=90)
    return fig


def write_figures(directory: str | os.PathLike[str], results: Sequence[ScenarioResult] | None = None) -> list[Path]:
    """``pinv_<scenario>.png`` for every scenario in ``directory``."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for sr in results if results is not None else simulate_scenarios():
        p = out / f"pinv_{sr.scenario.slug}.png"
        plot_scenario(sr, p)
        paths.append(p)
    return paths


def bi_step_dependence(scenario: Scenario, dts: Sequence[float] = (1e-3, 1e-4), *, theta: float = THETA,
                       duration: float = DURATION) -> list[tuple[float, float, tuple[float, ...]]]:
    """``(dt, max ‖l‖, final x̂ − x)`` of the BI observer for several steps: past a pole the result depends on ``dt``."""
    plant = model().compile()
    _, bi = observers(theta)
    out = []
    for dt in dts:
        r = _run(plant, bi, "bi", scenario, duration, dt)
        out.append((dt, r.max_gain, r.final_error))
    return out


# ----------------------------------------------------------------------------- reproduction table
def _mat(M: sp.MatrixBase) -> str:
    return str(as_sympy_matrix("M", M).tolist())


def rows(*, duration: float = DURATION, dt: float = DT) -> list[ReproRow]:
    """``nlobs reproduce robenack2008``: Section 5's statements beside nlobs's results."""
    s = symbolic_findings()
    paper = paper_formulas(AffineFields.from_model(model()))
    out = [
        ReproRow("L_g h (Sec. 5)", "0", str(s.lg_h)),
        ReproRow("L_g L_f h (Sec. 5)", "2(1 + x3)", str(s.lg_lf_h),
                 "vanishes at x3 = −1: the relative degree is not uniform there"),
        ReproRow("L_g L_f² h", None, str(s.lg_lf2_h), "derived by hand: 4x1²(x3+1)"),
        ReproRow("observation relative degree r (A1)", 2, s.r),
        ReproRow("generic rank of span{dL_f^k h}", None, s.observability_rank,
                 "derived: 3 < n = 4; x3 is unobservable and x̂3 converges only through ẋ3 = −x3 + u (A4)"),
        ReproRow("Q⁺ (25)", _mat(paper["Q+ (25)"]), _mat(s.Qp),
                 f"equal: simplify(a − b) = 0 is {s.Qp_equals_25}, max spot difference {s.Qp_spot:.1e}"),
        ReproRow("[τ1, τ2] (A5)", "≡ 0", _mat(s.bracket), "involutive" if s.involutive else "A5 fails"),
        ReproRow("l(x) = Q⁺(x) k (26)", _mat(paper["l (26)"]), _mat(s.gain),
                 f"equal: {s.gain_equals_26}, max spot difference {s.gain_spot:.1e}; denominator "
                 f"{s.pinv_denominator} ≥ 1: no pole"),
        ReproRow("φ4 in (22)-(23)", "x4 (text); row (1 0 0 0) of (23)", "x1",
                 f"typo in the text: φ4 = x4 = h gives det Φ' = {s.text_phi4_det}; Φ' with φ4 = x1 equals (23): "
                 f"{s.bi_jacobian_equals_23}"),
        ReproRow("BI gain (24) = (Φ')⁻¹ [k; 0]", _mat(paper["l (24) printed"]), _mat(s.bi_gain),
                 f"the extracted text of (24) is not (Φ')⁻¹[k; 0] (equal: {s.bi_equals_24_printed}): its rows 3-4 "
                 "look like the fraction k2/(2 + 2x3) and k1 flattened by the PDF extraction; the derived gain has "
                 f"k2/(2 + 2x3) in row 3 and k1 in row 4 (equal to that: {s.bi_equals_24_derived}), and only it "
                 "has the pole at x3 = −1 that the paper states"),
        ReproRow("pole of the BI gain", "x3 = −1", ", ".join(s.bi_pole), f"det Φ' = {s.bi_det}"),
        ReproRow("pole of (26)", "none", "none" if s.pinv_pole_free else "?", "4 x1² + 1 ≥ 1"),
        ReproRow("Theorem 4.1: φ with R Qᵀ = 0 (16)", None, "φ3 = x3, φ4 = x1·exp(−2 x2)",
                 f"derived: R Qᵀ = {_mat(s.orthogonal_rq)}; (Φ')⁻¹[k; 0] = (26): {s.orthogonal_gain_equals_26}"),
        ReproRow("Φ of (23) injective (A2)", None, not s.bi_map_folds,
                 "derived: φ3 = x2 + 1 − (x3 + 1)², so Φ(x3) = Φ(−2 − x3); x3 = −1 is the fold"),
    ]
    for sr in simulate_scenarios(duration=duration, dt=dt):
        out.append(ReproRow(f"simulation, u = {sr.scenario.u.describe()}: {sr.scenario.title}",
                            "behave similarly" if sr.scenario.slug == "plant_crosses" else None,
                            f"(26): {sr.pinv.summary()} | (24): {sr.bi.summary()}",
                            f"θ = {THETA:g}, RK4 dt = {dt:g}, {duration:g} s"))
    return out


#: The registry entry point (``nlobs.papers.reproduce.PAPERS``).
reproduce = rows
