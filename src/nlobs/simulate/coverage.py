"""Does a certificate cover a run? The hypotheses it rests on, checked along every run of a simulation.

A certificate (a verified gain, a bound) is a statement *under hypotheses*: the state and its estimate
stay in the region the design was verified on, the input stays within its bound, the output is
measured exactly and continuously, the model is exact. A run that leaves any of them is not covered,
however well it went. :func:`monitor` checks a list of hypotheses along the saved trajectory of every
run and returns a :class:`Coverage`: per run the first violated hypothesis and its time, the fraction
of covered runs, and the hypotheses the whole set-up violates (noise, sampling), which no run escapes.

The hypotheses:

* :class:`InRegion` — the state (``which="state"``) or the estimate (``"estimate"``) inside a box;
* :class:`InputBound` — ``‖u(t)‖ ≤ μ``;
* :class:`InputRange` — each input channel within ``[lower, upper]`` (the input range a Jacobian box was
  estimated on);
* :class:`Condition` — a condition evaluated at every saved instant of every run as a margin
  (``≥ 0``: holds), e.g. the function class of a set-valued design on the pairs ``(x_k, x̂_k)`` the
  runs visit (Khajenejad & Yong, Definition 2.6), or a floating-point round-off bound;
* :class:`Premise` — a hypothesis the set-up as a whole satisfies or not (``holds=False`` with the
  reason: measurement noise, process noise, sampled instead of continuous measurement, a certificate
  of the linearisation used on a nonlinear plant).

A run is checked at the saved instants of the result (a state that leaves the region and returns
between two of them is not seen: save every step for a strict check).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from nlobs._schema import BOOLEAN, INTEGER, NUMBER, STRING, Record, array
from nlobs._typing import Array
from nlobs.errors import InvalidArgumentError
from nlobs.simulate.result import SimulationResult

__all__ = ["Condition", "Coverage", "InRegion", "InputBound", "InputRange", "Premise", "Violation", "monitor"]


@dataclass(frozen=True)
class Violation:
    """The first hypothesis a run violates: which, when, and how.

    Attributes
    ----------
    run : int
        Index of the run (along the batch axis).
    hypothesis : str
        Name of the violated hypothesis.
    time : float
        First saved instant at which it is violated.
    detail : str
        How it is violated (e.g. the component outside the region).
    """

    run: int
    hypothesis: str
    time: float
    detail: str

    def to_dict(self) -> dict[str, Any]:
        return VIOLATION_JSON.emit({"run": self.run, "hypothesis": self.hypothesis, "time": self.time,
                                    "detail": self.detail})

    def describe(self, time_unit: str = "s") -> str:
        return f"run {self.run}: {self.hypothesis} violated at t = {self.time:.4g} {time_unit} ({self.detail})"


@dataclass(frozen=True)
class InRegion:
    """The state or the estimate stays in the box ``[lower, upper]`` (where the certificate was verified).

    Parameters
    ----------
    lower, upper : array, shape (n,)
        Bounds of the box, per component (a NaN value counts as outside).
    which : str
        ``"state"`` checks the truth ``x``, any other value the estimate ``x_hat``.
    region : str
        Name of the region, appended to the hypothesis' name.
    """

    lower: Array
    upper: Array
    which: str = "state"
    region: str = ""

    @property
    def name(self) -> str:
        return f"{self.which} in the region {self.region}".rstrip()

    def first(self, result: SimulationResult, u: Array | None) -> tuple[Array, list[str]]:
        arr = result.x if self.which == "state" else result.x_hat
        if arr is None:
            raise InvalidArgumentError("InRegion: the result has no truth (x is None)")
        lo, hi = np.asarray(self.lower, dtype=float), np.asarray(self.upper, dtype=float)
        with np.errstate(invalid="ignore"):
            out = ~((arr >= lo) & (arr <= hi)).all(axis=-1)  # (runs, K); NaN counts as outside
        runs = out.reshape(-1, out.shape[-1])
        flat = arr.reshape(-1, arr.shape[-2], arr.shape[-1])
        times = np.full(runs.shape[0], math.nan)
        details = [""] * runs.shape[0]
        names = result.states if self.which == "state" else result.estimates
        for i in np.flatnonzero(runs.any(axis=-1)):
            k = int(np.argmax(runs[i]))
            times[i] = result.t[k]
            v = flat[i, k]
            with np.errstate(invalid="ignore"):
                bad = np.flatnonzero(~((v >= lo) & (v <= hi)))
            j = int(bad[0]) if bad.size else 0
            details[i] = f"{names[j] if j < len(names) else j} = {v[j]:.4g} outside [{lo[j]:.4g}, {hi[j]:.4g}]"
        return times, details


@dataclass(frozen=True)
class InputBound:
    """``‖u(t)‖₂ ≤ mu`` (the input bound of a design, e.g. μ of (2.17)).

    Parameters
    ----------
    mu : float
        The bound ``μ`` on the Euclidean norm of the known input.
    rtol : float
        Relative tolerance: a violation is ``‖u‖ > μ (1 + rtol)``.
    """

    mu: float
    rtol: float = 1e-9

    @property
    def name(self) -> str:
        return f"‖u‖ ≤ μ = {self.mu:g}"

    def first(self, result: SimulationResult, u: Array | None) -> tuple[Array, list[str]]:
        nruns = max(1, result.n_runs)
        times = np.full(nruns, math.nan)
        details = [""] * nruns
        if u is None or u.size == 0:
            return times, details
        norm = np.linalg.norm(u, axis=-1)  # (K,) or (runs, K)
        norm = np.broadcast_to(norm, (nruns, result.t.size)) if norm.ndim == 1 else norm.reshape(nruns, -1)
        over = norm > self.mu * (1.0 + self.rtol)
        for i in np.flatnonzero(over.any(axis=-1)):
            k = int(np.argmax(over[i]))
            times[i] = result.t[k]
            details[i] = f"‖u‖ = {norm[i, k]:.4g} > {self.mu:g}"
        return times, details


@dataclass(frozen=True)
class InputRange:
    """Each channel of the known input within ``[lower, upper]`` (where a design's Jacobian bounds hold).

    Parameters
    ----------
    lower, upper : array, shape (m,)
        The range per channel.
    names : tuple of str
        The input names (for the detail of a violation).
    rtol : float
        Relative tolerance (of the range's scale).
    """

    lower: Array
    upper: Array
    names: tuple[str, ...] = ()
    rtol: float = 1e-9

    @property
    def name(self) -> str:
        return "input in the range " + " × ".join(f"[{a:.4g}, {b:.4g}]" for a, b in zip(self.lower, self.upper))

    def first(self, result: SimulationResult, u: Array | None) -> tuple[Array, list[str]]:
        nruns = max(1, result.n_runs)
        times = np.full(nruns, math.nan)
        details = [""] * nruns
        lo, hi = np.asarray(self.lower, dtype=float), np.asarray(self.upper, dtype=float)
        if u is None or u.size == 0 or lo.size == 0:
            return times, details
        tol = self.rtol * np.maximum(1.0, np.maximum(np.abs(lo), np.abs(hi)))
        uu = u if u.ndim == 3 else np.broadcast_to(u, (nruns, *u.shape[-2:]))
        out = ((uu < lo - tol) | (uu > hi + tol)).any(axis=-1)
        for i in np.flatnonzero(out.any(axis=-1)):
            k = int(np.argmax(out[i]))
            j = int(np.argmax((uu[i, k] < lo - tol) | (uu[i, k] > hi + tol)))
            name = self.names[j] if j < len(self.names) else f"u[{j}]"
            times[i] = result.t[k]
            details[i] = f"{name} = {uu[i, k, j]:.4g} outside [{lo[j]:.4g}, {hi[j]:.4g}]"
        return times, details


@dataclass(frozen=True)
class Premise:
    """A hypothesis the whole set-up satisfies or not (``holds=False``: every run violates it, from t0).

    Parameters
    ----------
    name : str
        What the hypothesis is.
    holds : bool
        Whether the set-up satisfies it.
    reason : str
        Why it fails (shown with the name among the failed premises).
    """

    name: str
    holds: bool
    reason: str = ""


@dataclass(frozen=True, eq=False)
class Condition:
    """A condition along every run, given by its margin at the saved instants (``margin ≥ 0``: it holds).

    Parameters
    ----------
    name : str
        What the condition is (``"function class (M, γ)-QC on the visited pairs"``).
    margin : array, shape (runs, K') or (K',)
        The margin at the first ``K' ≤ K`` saved instants (a condition on the step from ``t_k`` to
        ``t_{k+1}`` has ``K' = K − 1``); NaN counts as violated.
    quantity : str
        How the margin is shown in a violation's detail.
    """

    name: str
    margin: Array
    quantity: str = "margin"

    def first(self, result: SimulationResult, u: Array | None) -> tuple[Array, list[str]]:
        nruns = max(1, result.n_runs)
        m = np.asarray(self.margin, dtype=float)
        m = np.broadcast_to(m, (nruns, m.shape[-1])) if m.ndim == 1 else m.reshape(nruns, -1)
        if m.shape[-1] > result.t.size:
            raise InvalidArgumentError(f"Condition {self.name!r}: margin has {m.shape[-1]} instants, the result "
                                       f"{result.t.size}")
        with np.errstate(invalid="ignore"):
            bad = ~(m >= 0.0)
        times = np.full(nruns, math.nan)
        details = [""] * nruns
        for i in np.flatnonzero(bad.any(axis=-1)):
            k = int(np.argmax(bad[i]))
            times[i] = result.t[k]
            details[i] = f"{self.quantity} = {m[i, k]:.4g} < 0"
        return times, details


Hypothesis = InRegion | InputBound | InputRange | Condition | Premise


@dataclass(frozen=True, eq=False)
class Coverage:
    """Which runs a certificate covers (:func:`monitor`).

    Attributes
    ----------
    hypotheses : tuple of str
        Every hypothesis checked.
    failed_premises : tuple of str
        Hypotheses the set-up violates (with their reasons): then no run is covered.
    violations : tuple of Violation
        The first violation of each run that left a checked hypothesis (runs without one are covered
        unless a premise failed).
    runs : int
    verified : bool
        Whether the certificate itself was verified (a run is never covered by a failed certificate).
    """

    hypotheses: tuple[str, ...]
    failed_premises: tuple[str, ...]
    violations: tuple[Violation, ...]
    runs: int
    verified: bool = True

    @property
    def covered_runs(self) -> int:
        """Runs that stayed inside every hypothesis (0 when a premise failed or the certificate did)."""
        if self.failed_premises or not self.verified:
            return 0
        return self.runs - len(self.violations)

    @property
    def covered_fraction(self) -> float:
        return self.covered_runs / self.runs if self.runs else 0.0

    @property
    def covers_run(self) -> bool:
        """Every run covered: what "certified" means for a simulation."""
        return self.runs > 0 and self.covered_runs == self.runs

    @property
    def reasons(self) -> tuple[str, ...]:
        """Why runs are not covered: failed premises, then per violated hypothesis how many runs and the first."""
        out = list(self.failed_premises)
        if not self.verified:
            out.insert(0, "the certificate was not verified")
        by: dict[str, list[Violation]] = {}
        for v in self.violations:
            by.setdefault(v.hypothesis, []).append(v)
        for h, vs in by.items():
            first = min(vs, key=lambda v: v.time)
            out.append(f"{h} violated in {len(vs)} of {self.runs} runs (first: run {first.run} at "
                       f"t = {first.time:.4g}, {first.detail})")
        return tuple(out)

    def to_dict(self) -> dict[str, Any]:
        """``certificate_covers_run``, ``certificate_covered_fraction``, ``certificate_violations`` (first per run),
        ``certificate_failed_premises`` and ``certificate_hypotheses``."""
        return COVERAGE_JSON.emit({
            "certificate_covers_run": self.covers_run, "certificate_covered_fraction": self.covered_fraction,
            "certificate_violations": [v.to_dict() for v in self.violations],
            "certificate_failed_premises": list(self.failed_premises),
            "certificate_hypotheses": list(self.hypotheses)})


#: The first violation of a hypothesis in one run.
VIOLATION_JSON = Record("Violation", {"run": INTEGER, "hypothesis": STRING, "time": NUMBER, "detail": STRING})

#: The keys a :class:`Coverage` adds to a report (the certificate's hypotheses checked along every run).
COVERAGE_JSON = Record("Coverage", {
    "certificate_covers_run": BOOLEAN.about("every run inside every hypothesis"),
    "certificate_covered_fraction": NUMBER,
    "certificate_violations": array(VIOLATION_JSON, "per run not covered, the first"),
    "certificate_failed_premises": array(STRING),
    "certificate_hypotheses": array(STRING),
})


def monitor(result: SimulationResult, hypotheses: Sequence[Hypothesis], *,
            u: Array | Callable[[float], Any] | None = None, verified: bool = True) -> Coverage:
    """Check each hypothesis along every run of ``result`` (module docstring).

    Parameters
    ----------
    result : SimulationResult
        With the truth ``x`` (runs along the batch axis).
    hypotheses : sequence of InRegion, InputBound, Condition, Premise
    u : array or callable, optional
        The known input: a constant ``(m,)``, its values on the saved grid ``(K, m)`` or
        ``(runs, K, m)``, or a callable ``u(t)`` (evaluated on the saved grid); ``None``: zero.
        Needed by :class:`InputBound`.
    verified : bool
        Whether the certificate was verified.

    Returns
    -------
    Coverage
    """
    if callable(u):
        u_arr: Array | None = np.stack([np.asarray(u(float(t)), dtype=float).reshape(-1) for t in result.t])
    else:
        u_arr = None if u is None else np.asarray(u, dtype=float)
        if u_arr is not None and u_arr.ndim == 1:  # a constant input
            u_arr = np.broadcast_to(u_arr, (result.t.size, u_arr.size))
    runs = max(1, result.n_runs)
    first_t = np.full(runs, math.inf)
    first: list[Violation | None] = [None] * runs
    failed = []
    for h in hypotheses:
        if isinstance(h, Premise):
            if not h.holds:
                failed.append(f"{h.name}: {h.reason}" if h.reason else h.name)
            continue
        if not isinstance(h, (InRegion, InputBound, InputRange, Condition)):
            raise InvalidArgumentError(
                f"hypotheses: expected InRegion, InputBound, InputRange, Condition or Premise, got {type(h).__name__}")
        times, details = h.first(result, u_arr)
        for i in np.flatnonzero(np.isfinite(times)):
            if times[i] < first_t[i]:
                first_t[i] = times[i]
                first[i] = Violation(int(i), h.name, float(times[i]), details[i])
    return Coverage(tuple(h.name for h in hypotheses), tuple(failed), tuple(v for v in first if v is not None),
                    runs, verified)
