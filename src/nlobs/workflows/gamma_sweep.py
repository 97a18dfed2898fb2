r"""Sec. 3.2 of Grip, Saberi & Johansen: start with a large ``γ`` and decrease it, designing and simulating each step.

Why here (and not in :mod:`nlobs.synthesis`): each step designs a gain (synthesis), builds the
observer (:class:`nlobs.observers.cascade.CascadeObserver`, a layer above synthesis) and runs a
simulation, so the sweep sits in the layer that may use all three. The simulation is passed in as a
callable (``simulate(observer) -> SimulationResult``), so the caller chooses the plant, the initial
conditions and the horizon; without it the sweep is design-only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import positive
from nlobs.errors import DesignError, InvalidArgumentError
from nlobs.linear.assumption4 import require_assumption4
from nlobs.observers.cascade import CascadeObserver
from nlobs.synthesis.cascade_gain import design_cascade_gain, place_cascade_gain
from nlobs.synthesis.certificate import Objective
from nlobs.synthesis.observer_gain import GainBound
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
    rows = []
    for g in gs:
        try:
            if method == "lmi":
                cert = design_cascade_gain(sigma2, gamma=g, N=N, gamma_n=gamma_n, region=region,
                                           gain_bound=gain_bound, objective=objective, check_assumptions=False)
            else:
                cert = place_cascade_gain(sigma2, gamma=g, poles=poles, check_assumptions=False)
        except DesignError as exc:
            rows.append(GammaSweepRow(gamma=g, status=type(exc).__name__, message=str(exc)))
            continue
        eig = np.asarray(cert.eigenvalues)
        row: dict[str, Any] = {
            "gamma": g, "status": "ok", "hinf_H": float(cert.hinf_H),
            "hinf_G": float(cert.hinf_G) if cert.hinf_G is not None else math.nan,
            "gain_norm": cert.gain_norm, "slowest_pole": float(np.max(eig.real)),
            "fastest_pole": float(np.min(eig.real)),
            "K": tuple(tuple(float(v) for v in r) for r in cert.gain),
        }
        if simulate is not None:
            obs = CascadeObserver(sigma1, sigma2, cert.gain)
            try:
                res = simulate(obs)
            except ArithmeticError as exc:  # SimulationDiverged
                row.update(status=type(exc).__name__, message=str(exc))
            else:
                en = np.asarray(res.error_norm)
                row.update(
                    initial_error=float(np.max(en[..., 0])),
                    final_error=float(np.max(en[..., -1])),
                    decay_rate=float(np.min(np.asarray(res.decay_rate()))),
                )
        rows.append(GammaSweepRow(**row))
    label = "LMI (14)" + (", (15)" if gamma_n is not None else "") if method == "lmi" else "pole placement"
    return GammaSweep(rows=tuple(rows), design=label)
