r"""Sec. 3.2 of Grip, Saberi & Johansen: start with a large ``γ`` and decrease it, designing and simulating each step.

Why here (and not in :mod:`nlobs.synthesis`): each step designs a gain (synthesis), builds the
observer (:class:`nlobs.observers.cascade.CascadeObserver`, a layer above synthesis) and runs a
simulation, so the sweep sits in the layer that may use all three. The simulation is passed in as a
callable (``simulate(observer) -> SimulationResult``), so the caller chooses the plant, the initial
conditions and the horizon; without it the sweep is design-only.

The γ values are the points of a :func:`nlobs.simulate.sweep.sweep` of one parameter, ``gamma``, so
``executor=`` runs them on Dask (or any executor) with the same rows as in this process. The sweep's
problem prepares, once per process, what every γ shares: the extended system (8c) of Σ₂ on which
LMI (14) (and (15)) is written. The LMI itself is built and solved per γ by
:func:`nlobs.synthesis.observer_gain.design_observer_gain`, exactly as in one design: that function
chooses its path by γ (the Riccati form, the SDP, the diagnosis of an infeasible γ), so one CVXPY
problem with γ as a parameter would not give the same numbers.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import positive
from nlobs.errors import DesignError, InvalidArgumentError
from nlobs.linear.assumption4 import ExtendedSystem, extended_system, require_assumption4
from nlobs.observers.cascade import CascadeObserver
from nlobs.simulate.sweep import sweep
from nlobs.synthesis.cascade_gain import place_cascade_gain
from nlobs.synthesis.certificate import Objective
from nlobs.synthesis.observer_gain import GainBound, design_observer_gain
from nlobs.synthesis.regions import PoleRegion
from nlobs.systems.interconnected import LinearSubsystem, NonlinearSubsystem, check_interconnection

__all__ = ["GammaSweep", "GammaSweepRow", "gamma_sweep"]


class _SimulationLike(Protocol):
    t: Array

    @property
    def error_norm(self) -> Array: ...

    def decay_rate(self) -> Array: ...


@dataclass(frozen=True)
class GammaSweepRow:
    """One step of :func:`gamma_sweep`.

    Attributes
    ----------
    gamma : float
    status : str
        ``"ok"``, or the exception class name when the design failed.
    message : str
        Empty, or why the design failed.
    hinf_H, hinf_G : float
        Achieved ``‖H‖∞`` and ``‖G‖∞`` (NaN when not applicable).
    gain_norm : float
        ``‖K‖₂``.
    slowest_pole : float
        ``max Re λ(𝔄 − Kℭ)`` (negative).
    fastest_pole : float
        ``min Re λ(𝔄 − Kℭ)``.
    initial_error, final_error : float
        Largest ``‖[x̂ − x, ŵ − w]‖`` over the batch at the first and last saved time (NaN without simulation).
    decay_rate : float
        Smallest fitted decay rate over the batch (NaN without simulation).
    K : tuple of tuple of float

    Examples
    --------
    Example 1 of Grip, Saberi & Johansen with the gain bound ``‖K‖₂ ≤ 10⁴``: at ``γ = 10`` LMI (14) has a
    solution, at ``γ = 0.1`` it has none within the bound, and that row says why instead of raising:

    >>> import math
    >>> from nlobs.papers.grip_example1 import example1_sigma1, example1_sigma2
    >>> big, small = gamma_sweep(example1_sigma1(), example1_sigma2(), [0.1, 10.0], gain_bound=1e4).rows
    >>> big.gamma, big.ok, bool(big.hinf_H < big.gamma), len(big.K), math.isnan(big.final_error)  # design only
    (10.0, True, True, 3, True)
    >>> small.gamma, small.ok, small.status, math.isnan(small.gain_norm), small.K
    (0.1, False, 'DesignInfeasible', True, ())
    >>> small.message
    'the gain bound ‖K‖₂ ≤ κ = 10000 is infeasible together with LMI (14): the smallest feasible gain bound ...'
    """

    gamma: float
    status: str
    message: str = ""
    hinf_H: float = math.nan
    hinf_G: float = math.nan
    gain_norm: float = math.nan
    slowest_pole: float = math.nan
    fastest_pole: float = math.nan
    initial_error: float = math.nan
    final_error: float = math.nan
    decay_rate: float = math.nan
    K: tuple[tuple[float, ...], ...] = ()

    @property
    def ok(self) -> bool:
        return self.status == "ok"


_COLUMNS = (
    ("gamma", "γ", "{:.4g}"),
    ("hinf_H", "‖H‖∞", "{:.4g}"),
    ("hinf_G", "‖G‖∞", "{:.4g}"),
    ("gain_norm", "‖K‖₂", "{:.4g}"),
    ("slowest_pole", "max Re λ", "{:.4g}"),
    ("final_error", "final ‖e‖", "{:.3g}"),
    ("decay_rate", "decay rate", "{:.4g}"),
    ("status", "status", "{}"),
)


@dataclass(frozen=True)
class GammaSweep:
    """Result of :func:`gamma_sweep`: one :class:`GammaSweepRow` per ``γ``, largest first.

    Attributes
    ----------
    rows : tuple of GammaSweepRow
        One per ``γ``, largest first.
    design : str
        The design used: ``"LMI (14)"``, ``"LMI (14), (15)"`` or ``"pole placement"``.

    Examples
    --------
    Sec. 3.2's tuning on Example 1 of Grip, Saberi & Johansen, design only, the central solution of LMI (14)
    with ``‖K‖₂ ≤ 10⁴``: the rows come largest ``γ`` first, each achieves ``‖H‖∞ < γ``, and the gain grows as
    ``γ`` decreases:

    >>> from nlobs.papers.grip_example1 import example1_sigma1, example1_sigma2
    >>> sweep = gamma_sweep(example1_sigma1(), example1_sigma2(), [0.3, 10.0, 1.0, 3.0], gain_bound=1e4)
    >>> sweep.design, [row.gamma for row in sweep.rows], all(row.ok for row in sweep.rows)
    ('LMI (14)', [10.0, 3.0, 1.0, 0.3], True)
    >>> [bool(row.hinf_H < row.gamma) for row in sweep.rows], [round(row.gain_norm) for row in sweep.rows]
    ([True, True, True, True], [156, 384, 450, 561])
    >>> print(sweep.summary().splitlines()[1])
      γ    ‖H‖∞  ‖G‖∞   ‖K‖₂  max Re λ  final ‖e‖  decay rate  status
    >>> sweep.to_rows()[0]["K"] == [list(k) for k in sweep.rows[0].K]
    True
    """

    rows: tuple[GammaSweepRow, ...]
    design: str

    def to_rows(self) -> list[dict[str, Any]]:
        """Plain dicts, one per row (``K`` as nested lists)."""
        out = []
        for r in self.rows:
            d = {k: getattr(r, k) for k in GammaSweepRow.__dataclass_fields__}
            d["K"] = [list(row) for row in r.K]
            out.append(d)
        return out

    def summary(self) -> str:
        """A plain-text table (no rich markup)."""
        head = [c[1] for c in _COLUMNS]
        body = []
        for r in self.rows:
            cells = []
            for key, _, fmt in _COLUMNS:
                v = getattr(r, key)
                cells.append("-" if isinstance(v, float) and math.isnan(v) else fmt.format(v))
            body.append(cells)
        widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(head)]
        lines = [f"γ sweep ({self.design})", "  ".join(h.rjust(w) for h, w in zip(head, widths))]
        lines += ["  ".join(c.rjust(w) for c, w in zip(b, widths)) for b in body]
        fails = [r for r in self.rows if not r.ok]
        lines += [f"  γ = {r.gamma:.4g}: {r.message}" for r in fails]
        return "\n".join(lines)


#: The flat values of one row (``K`` as ``K_rows``, ``K_cols`` and ``K[i,j]``), as a sweep point returns them.
_FLOATS = ("hinf_H", "hinf_G", "gain_norm", "slowest_pole", "fastest_pole", "initial_error", "final_error",
           "decay_rate")


@dataclass(frozen=True)
class _GammaProblem:
    """One γ of :func:`gamma_sweep` as a point of :func:`nlobs.simulate.sweep.sweep` (picklable with cloudpickle)."""

    sigma1: NonlinearSubsystem
    sigma2: LinearSubsystem
    method: str
    N: ArrayLike | None
    gamma_n: float | None
    region: PoleRegion | Sequence[PoleRegion] | None
    gain_bound: GainBound | float | None
    objective: Objective | str
    poles: ArrayLike | None
    simulate: Callable[[CascadeObserver], _SimulationLike] | None
    name: str = "γ sweep"

    def key(self) -> str:
        # what prepare() builds depends on Σ₂'s matrices only
        h = hashlib.sha256()
        for a in (self.sigma2.A, self.sigma2.B_z, self.sigma2.C, self.sigma2.D_z):
            arr = np.ascontiguousarray(a, dtype=float)
            h.update(repr(arr.shape).encode())
            h.update(arr.tobytes())
        return "nlobs.workflows.gamma_sweep:" + h.hexdigest()

    def prepare(self) -> ExtendedSystem:
        s2 = self.sigma2
        return extended_system(s2.A, s2.B_z, s2.C, s2.D_z)

    def evaluate(self, ext: ExtendedSystem, point: Mapping[str, float]) -> dict[str, Any]:
        g = point["gamma"]
        try:
            if self.method == "lmi":  # design_cascade_gain(check_assumptions=False) on the prepared (8c)
                cert = design_observer_gain(ext.A, ext.C, ext.Bd, gamma=g, N=self.N, gamma_n=self.gamma_n,
                                            region=self.region, gain_bound=self.gain_bound, objective=self.objective)
            else:
                cert = place_cascade_gain(self.sigma2, gamma=g, poles=self.poles, check_assumptions=False)
        except DesignError as exc:
            return _flat(GammaSweepRow(gamma=g, status=type(exc).__name__, message=str(exc)))
        eig = np.asarray(cert.eigenvalues)
        row: dict[str, Any] = {
            "gamma": g, "status": "ok", "hinf_H": float(cert.hinf_H),
            "hinf_G": float(cert.hinf_G) if cert.hinf_G is not None else math.nan,
            "gain_norm": cert.gain_norm, "slowest_pole": float(np.max(eig.real)),
            "fastest_pole": float(np.min(eig.real)),
            "K": tuple(tuple(float(v) for v in r) for r in cert.gain),
        }
        if self.simulate is not None:
            obs = CascadeObserver(self.sigma1, self.sigma2, cert.gain)
            try:
                res = self.simulate(obs)
            except ArithmeticError as exc:  # SimulationDiverged
                row.update(status=type(exc).__name__, message=str(exc))
            else:
                en = np.asarray(res.error_norm)
                row.update(
                    initial_error=float(np.max(en[..., 0])),
                    final_error=float(np.max(en[..., -1])),
                    decay_rate=float(np.min(np.asarray(res.decay_rate()))),
                )
        return _flat(GammaSweepRow(**row))


def _flat(row: GammaSweepRow) -> dict[str, Any]:
    out: dict[str, Any] = {"status": row.status, "message": row.message}
    out.update({k: float(getattr(row, k)) for k in _FLOATS})
    out["K_rows"], out["K_cols"] = len(row.K), len(row.K[0]) if row.K else 0
    out.update({f"K[{i},{j}]": v for i, r in enumerate(row.K) for j, v in enumerate(r)})
    return out


def _row(gamma: float, v: Mapping[str, Any]) -> GammaSweepRow:
    K = tuple(tuple(float(v[f"K[{i},{j}]"]) for j in range(int(v["K_cols"]))) for i in range(int(v["K_rows"])))
    return GammaSweepRow(gamma=gamma, status=str(v["status"]), message=str(v["message"]),
                         **{k: float(v[k]) for k in _FLOATS}, K=K)


def gamma_sweep(
    sigma1: NonlinearSubsystem,
    sigma2: LinearSubsystem,
    gammas: Sequence[float],
    *,
    simulate: Callable[[CascadeObserver], _SimulationLike] | None = None,
    method: str = "lmi",
    N: ArrayLike | None = None,
    gamma_n: float | None = None,
    region: PoleRegion | Sequence[PoleRegion] | None = None,
    gain_bound: GainBound | float | None = None,
    objective: Objective | str = Objective.CENTRAL,
    poles: ArrayLike | None = None,
    executor: Any = None,
    progress: bool | None = False,
) -> GammaSweep:
    r"""Sec. 3.2's tuning: start with a large ``γ`` and decrease it, designing and simulating each step.

    Parameters
    ----------
    sigma1, sigma2 : NonlinearSubsystem, LinearSubsystem
    gammas : sequence of float
        Values to try; sorted largest first.
    simulate : callable, optional
        ``simulate(observer) -> SimulationResult`` (anything with ``t``,
        ``error_norm`` and ``decay_rate()``), typically
        ``lambda obs: nlobs.simulate.simulate(plant, obs, x0, x_hat0, duration=…, dt=…)``.
        ``None``: design only.
    method : {"lmi", "placement"}
        :func:`~nlobs.synthesis.cascade_gain.design_cascade_gain` (with ``N, gamma_n, region,
        gain_bound, objective``) or :func:`~nlobs.synthesis.cascade_gain.place_cascade_gain`
        (with ``poles``).
    N : array_like, optional
        ``"lmi"``: noise input matrix of LMI (15).
    gamma_n : float, optional
        ``"lmi"``: ``γn`` of LMI (15); given, it adds that LMI.
    region : PoleRegion or sequence of PoleRegion, optional
        ``"lmi"``: pole region(s) for ``𝔄 − Kℭ``.
    gain_bound : GainBound or float, optional
        ``"lmi"``: ``‖K‖₂ ≤ κ``.
    objective : Objective or str
        ``"lmi"``: the objective of the design.
    poles : array_like of complex, optional
        ``"placement"``: pole pattern (default: unit Butterworth).
    executor : None, dask.distributed.Client, str or concurrent.futures.Executor
        Where the γ values are designed (and simulated): ``None`` in this process, else on the workers of
        a Dask client or scheduler address (:func:`nlobs.simulate.executors.cluster`), through
        :func:`nlobs.simulate.sweep.sweep`; the rows are the same either way. On Dask, ``simulate`` and
        Σ₁ travel with cloudpickle.
    progress : bool, optional
        A progress bar over the γ values (``None``: automatic; default none).

    Returns
    -------
    GammaSweep
        A failed design (infeasible, unbounded, …) or a diverged simulation
        gives a row with that status and message instead of an exception, so
        the sweep shows where decreasing ``γ`` stops working.

    Raises
    ------
    AssumptionViolated
        Assumption 4 fails (before any design).
    """
    check_interconnection(sigma1, sigma2)
    require_assumption4(sigma2.A, sigma2.B_z, sigma2.C, sigma2.D_z)
    if method not in ("lmi", "placement"):
        raise InvalidArgumentError(f"method: expected 'lmi' or 'placement', got {method!r}")
    gs = sorted((positive("gammas", g) for g in gammas), reverse=True)
    if not gs:
        raise InvalidArgumentError("gammas: at least one value is required")
    problem = _GammaProblem(sigma1, sigma2, method, N, gamma_n, region, gain_bound, objective, poles, simulate)
    # record=(): the problem records a failed design in its row itself (status, message), as Sec. 3.2's tuning
    # shows where decreasing γ stops working; anything else (a bad option) propagates as from one design
    res = sweep(problem, {"gamma": gs}, executor=executor, progress=progress, record=())
    rows = [_row(p["gamma"], v) for p, v in zip(res.points, res.values)]  # type: ignore[arg-type]
    label = "LMI (14)" + (", (15)" if gamma_n is not None else "") if method == "lmi" else "pole placement"
    return GammaSweep(rows=tuple(rows), design=label)
