r"""Any observer on recorded data: ``run_observer(observer, t, u=..., y=...)``.

The recorded-data loop of nlobs (python-control's ``input_output_response(estimator, T, [Y, U])``
for nonlinear, batched, sampled data). The data are a time grid ``t`` (``K`` instants), the known
input on that grid, and measurement samples at instants of the grid (``y_times``, each within
``grid_rtol`` of a step of a grid time), possibly only some outputs at a time (``sampled``). At
each grid time ``t_k``:

1. if a sample is time-stamped ``t_k``: a :class:`~nlobs.observers.base.CorrectingObserver` makes
   its correction ``z ← correct(t_k, z, u_k, y, fresh)`` (``fresh`` the sampled outputs; a
   non-finite entry is a missing sample of that batch member, which the observer skips); any
   other observer takes the sample into its held measurement (a zero-order hold);
2. the estimate at ``t_k`` is recorded (after the correction), with the observer's diagnostics;
3. the observer advances to ``t_{k+1}`` with ``u_k`` and the held measurement constant over the
   step: ``z ← rhs(t_k, z, u_k, y)`` for a discrete observer (the grid must be uniform at its
   ``dt``), ``z ← step(t_k, z, u_k, y, h_k)`` for a continuous observer with its own step
   (:class:`~nlobs.observers.base.SelfStepping`), else one RK4 step of ``rhs`` with
   ``h_k = t_{k+1} − t_k``.

Compiled observers (:class:`~nlobs.observers.base.RecordRunning`, e.g. :func:`nlobs.export.compile_observer`)
without diagnostics run the whole record, every run of the batch, in one call instead of the loop
above; the result is the same (``method`` ends with ``"whole record in one call"``). Where that call
gives the record back (``None``: a singular matrix), the loop steps it as above.

Timing: ``info["cost_per_step_us"]`` is the wall time spent inside the observer's ``correct``,
``rhs`` and ``step`` (not ``estimate``, not recording) divided by the number of grid instants and
by the number of batch members: the cost of one step of one run, amortised over the batch.

Divergence: the recorded estimates are checked for non-finite entries every few steps; the first
one stops the run with :class:`~nlobs.errors.SimulationDiverged` naming its time and component.

Deferred estimates (:class:`~nlobs.observers.base.DeferredEstimate`): the record of raw estimates
is the loop's own buffer and is handed to ``finish_estimates`` writable, so an observer may write
its estimates into it and return it (the GNSS/INS observer projects ``R̂`` in place: no second copy
of a 1000-flight record); the loop makes it read-only afterwards.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from nlobs._progress import Progress
from nlobs._typing import Array, IntArray
from nlobs._validate import as_finite_array, as_real_array
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError, SimulationDiverged
from nlobs.observers.base import CorrectingObserver, DeferredEstimate, Diagnosing, Observer, RecordRunning, SelfStepping
from nlobs.simulate.loop import finish, initial_state, observer_label, record_diagnostics, time_major_extras
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.integrators import rk4_step
from nlobs.systems.timebase import Continuous, Discrete

__all__ = ["run_observer"]


def _grid(t: ArrayLike) -> Array:
    grid = as_finite_array("t", t, ndim=1)
    if grid.size < 1:
        raise DimensionError("t: at least one time is required")
    if grid.size > 1 and np.any(np.diff(grid) <= 0):
        k = int(np.argmax(np.diff(grid) <= 0)) + 1
        raise InvalidArgumentError(f"t: not strictly increasing at index {k} (t = {grid[k]:.9g})")
    return grid


def _on_grid(t: Array, y_times: Array, rtol: float) -> IntArray:
    """Index into ``t`` of each sample time (within ``rtol`` of the local step), checked."""
    if y_times.size > 1 and np.any(np.diff(y_times) <= 0):
        i = int(np.argmax(np.diff(y_times) <= 0)) + 1
        raise InvalidArgumentError(f"y_times: sample {i} at t = {y_times[i]:.9g} is out of order "
                                   f"(previous sample at {y_times[i - 1]:.9g})")
    idx = np.clip(np.searchsorted(t, y_times), 0, t.size - 1)
    left = np.clip(idx - 1, 0, t.size - 1)
    idx = np.where(np.abs(t[left] - y_times) < np.abs(t[idx] - y_times), left, idx)
    step = np.diff(t).min() if t.size > 1 else 1.0
    off = np.abs(t[idx] - y_times) > rtol * step
    if np.any(off):
        i = int(np.argmax(off))
        raise InvalidArgumentError(f"y_times: sample {i} at t = {y_times[i]:.9g} is not on the time grid "
                                   f"(nearest grid time {t[idx[i]]:.9g}); samples must coincide with grid times")
    if np.unique(idx).size != idx.size:
        raise InvalidArgumentError("y_times: two samples fall on the same grid time")
    return idx.astype(np.intp)


def run_observer(
    observer: Observer[Any],
    t: ArrayLike,
    *,
    x_hat0: ArrayLike,
    u: ArrayLike | None = None,
    y: ArrayLike | None = None,
    y_times: ArrayLike | None = None,
    sampled: ArrayLike | None = None,
    truth: ArrayLike | None = None,
    states: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    estimates: Sequence[str] | None = None,
    save_every: int = 1,
    progress: bool | None = None,
    grid_rtol: float = 1e-6,
    divergence: Literal["raise", "keep"] = "raise",
) -> SimulationResult:
    """Run an observer on recorded data (module docstring), for one or a batch of runs.

    Parameters
    ----------
    observer : Observer
        Any observer of nlobs (continuous or discrete, correcting or not).
    t : array_like, shape (K,)
        Strictly increasing time grid (uniform at ``observer.time.dt`` for a discrete observer).
    x_hat0 : array_like, shape (n_x,) or (*batch, n_x)
        Initial estimate(s), passed to ``observer.init``.
    u : array_like, shape (K, m) or (*batch, K, m), optional
        Known input on the grid (``None``: no inputs, ``m = 0``); held over each step.
    y : array_like, shape (G, p) or (*batch, G, p), optional
        Measurement samples at ``y_times`` (``None``: no measurement at all).
    y_times : array_like, shape (G,), optional
        Times of the samples, each a grid time (default: ``t`` itself, ``G = K``).
    sampled : array_like of bool, shape (G, p) or (p,), optional
        Which outputs each sample carries (default: all). A non-finite value of a sampled output
        is a missing sample of that run: a correcting observer skips it; for any other observer it
        is an error.
    truth : array_like, shape (K, n) or (*batch, K, n), optional
        The true state on the grid, kept as the result's ``x`` (for metrics).
    states, outputs, estimates : sequence of str, optional
        Column names (defaults ``x1..``, ``y1..``, the state names or ``x_hat[i]``).
    save_every : int
        Keep every ``save_every``-th grid time (and always the last one).
    progress : bool, optional
        Progress bar on stderr: ``True`` always, ``False`` never, ``None`` automatically for long runs.
    grid_rtol : float
        Tolerance, relative to the grid step, for sample times and for a discrete observer's ``dt``.
    divergence : {"raise", "keep"}
        ``"raise"`` (default): a non-finite estimate stops the run with
        :class:`~nlobs.errors.SimulationDiverged`; ``"keep"``: the run goes on and the non-finite
        values are kept (a baseline in a Monte Carlo comparison that may blow up);
        ``info["diverged_at"]`` is then the first time with a non-finite estimate (NaN if none).

    Returns
    -------
    SimulationResult
        With ``y = None``; ``info`` holds ``cost_per_step_us``, ``observer_s``, ``wall_s`` and
        ``missing`` (per run, sample instants with a non-finite sampled value).

    Raises
    ------
    DimensionError
        Shapes that do not match ``t``, the observer or each other.
    NonFiniteError
        A non-finite input or initial estimate (the message names its time), or a missing sample
        given to an observer that cannot skip it.
    InvalidArgumentError
        A grid that is not increasing, samples off the grid, a discrete observer whose ``dt``
        does not match the grid, or a non-correcting observer without a sample at ``t[0]``.
    SimulationDiverged
        The estimate became non-finite (the time and component are named).

    Examples
    --------
    Record a run of a plant whose output is sampled at 20 Hz (:func:`~nlobs.simulate.simulate`, RK4 steps of
    10 ms), then run the same observer on the recorded samples alone: it reproduces the estimates to rounding.

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup, simulate
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.LuenbergerObserver(system, [[4.5], [1.75]])
    >>> sim = simulate(system, observer, [1.0, 0.0], [0.0, 0.0], duration=2.0, dt=0.01, u=[0.3],
    ...                measurements=[MeasurementGroup("y", [0], rate=20.0)])
    >>> got = sim.sampled[:, 0]  # the grid instants that carry a sample
    >>> int(got.sum()), sim.t.size
    (41, 201)
    >>> rep = run_observer(observer, sim.t, x_hat0=[0.0, 0.0], u=np.full((sim.t.size, 1), 0.3), y=sim.y[got],
    ...                    y_times=sim.t[got], truth=sim.x)
    >>> rep.method, rep.info["samples"], bool(np.allclose(rep.x_hat, sim.x_hat, rtol=0.0, atol=1e-12))
    ('rk4', 41, True)
    >>> float(rep.error_norm[0]), bool(rep.error_norm[-1] < 0.05)
    (1.0, True)
    """
    if not isinstance(observer, Observer):
        raise InvalidArgumentError(f"observer: expected an Observer (time, n_x, init, rhs, estimate), got "
                                   f"{type(observer).__name__}")
    tb = observer.time
    if not isinstance(tb, (Continuous, Discrete)):
        raise InvalidArgumentError(f"observer.time: expected Continuous or Discrete, got {tb!r}")
    grid = _grid(t)
    K = grid.size
    if isinstance(save_every, bool) or not isinstance(save_every, (int, np.integer)) or save_every < 1:
        raise InvalidArgumentError(f"save_every: expected a positive integer, got {save_every!r}")
    h = np.diff(grid)
    if isinstance(tb, Discrete) and K > 1 and np.any(np.abs(h - tb.dt) > grid_rtol * tb.dt):
        k = int(np.argmax(np.abs(h - tb.dt) > grid_rtol * tb.dt))
        raise InvalidArgumentError(f"t: a discrete observer with dt = {tb.dt:g} needs a uniform grid at that step; "
                                   f"step {h[k]:.9g} before t = {grid[k + 1]:.9g}")
    n_x = int(observer.n_x)
    xh = as_finite_array("x_hat0", x_hat0)
    if xh.ndim == 0 or xh.shape[-1] != n_x:
        raise DimensionError(f"x_hat0: expected shape (..., {n_x}), got {xh.shape}")
    batches = [xh.shape[:-1]]

    u_arr: Array | None = None
    if u is not None:
        u_arr = as_real_array("u", u)
        if u_arr.ndim < 2 or u_arr.shape[-2] != K:
            raise DimensionError(f"u: expected shape (..., {K}, m) on the time grid, got {u_arr.shape}")
        finite = np.isfinite(u_arr).all(axis=-1)
        if not finite.all():
            k = int(np.argmax(~finite.reshape(-1, K).all(axis=0)))
            raise NonFiniteError(f"u: the input at t = {grid[k]:.6g} s (index {k}) is not finite")
        batches.append(u_arr.shape[:-2])

    correcting = isinstance(observer, CorrectingObserver)
    if y is None:
        p, G = 0, 0
        y_arr = np.zeros((0, 0))
        fix_at = np.full(K, -1, dtype=np.intp)
        rows = np.zeros((0, 0), dtype=bool)
    else:
        y_arr = as_real_array("y", y)
        if y_arr.ndim < 2:
            raise DimensionError(f"y: expected shape (..., G, p), got {y_arr.shape}")
        G, p = y_arr.shape[-2:]
        ts = grid if y_times is None else as_finite_array("y_times", y_times, ndim=1)
        if ts.size != G:
            raise DimensionError(f"y: {G} samples but {ts.size} sample times")
        idx = np.arange(K, dtype=np.intp) if y_times is None else _on_grid(grid, ts, grid_rtol)
        fix_at = np.full(K, -1, dtype=np.intp)
        fix_at[idx] = np.arange(G)
        if sampled is None:
            rows = np.ones((G, p), dtype=bool)
        else:
            rows = np.asarray(sampled, dtype=bool)
            rows = np.broadcast_to(rows, (G, p)) if rows.shape in ((p,), (G, p)) else rows
            if rows.shape != (G, p):
                raise DimensionError(f"sampled: expected shape ({G}, {p}) or ({p},), got {np.shape(sampled)}")
        batches.append(y_arr.shape[:-2])
    try:
        batch = tuple(np.broadcast_shapes(*batches))
    except ValueError:
        raise DimensionError(f"batch shapes do not broadcast: x_hat0 {batches[0]}, "
                             + ", ".join(str(b) for b in batches[1:])) from None
    n_runs = int(np.prod(batch, dtype=int))
    missing_run = np.zeros(batch, dtype=np.int64)
    if G:
        bad = ~np.isfinite(y_arr) & rows  # (*by, G, p)
        if bad.any():
            if not correcting:
                i = np.argwhere(bad.reshape(-1, G, p).any(axis=0))[0]
                raise NonFiniteError(f"y: sample {int(i[0])} (output {int(i[1])}) is not finite, and "
                                     f"{observer_label(observer)} cannot skip a missing sample")
            missing_run = np.broadcast_to(bad.any(axis=-1).sum(axis=-1), batch).astype(np.int64)
        if not correcting and (fix_at[0] < 0 or not rows[fix_at[0]].all()):
            raise InvalidArgumentError("y: an observer that holds its measurement needs a sample of every output at t[0]")

    xh = np.broadcast_to(xh, (*batch, n_x)).copy()
    z = initial_state(observer, xh, batch, n_x)
    deferred = isinstance(observer, DeferredEstimate)
    estimate = observer.raw_estimate if deferred else observer.estimate  # type: ignore[attr-defined]
    diagnose = isinstance(observer, Diagnosing)
    discrete = isinstance(tb, Discrete)
    self_step = not discrete and isinstance(observer, SelfStepping)
    save_steps = np.arange(0, K, int(save_every), dtype=np.intp)
    if save_steps[-1] != K - 1:
        save_steps = np.append(save_steps, K - 1)
    Ks = save_steps.size
    row_of = np.full(K, -1, dtype=np.intp)
    row_of[save_steps] = np.arange(Ks)
    rec = np.empty((Ks, *batch, n_x))
    extras: dict[str, Array] = {}
    y_held = np.full((*batch, p), np.nan)
    u0 = np.zeros((*batch, 0))
    label = observer_label(observer)
    names = tuple(estimates) if estimates is not None else tuple(states) if states is not None and \
        len(states) == n_x else tuple(f"x_hat[{i}]" for i in range(n_x))
    check_every = max(1, min(100, Ks // 20))
    checked = 0
    busy = 0.0
    perf = _time.perf_counter
    wall = perf()

    # per-step lookups on Python lists (cheaper than NumPy scalars in the loop; the same values)
    t_list: list[float] = grid.tolist()
    h_list: list[float] = h.tolist()
    fix_list: list[int] = fix_at.tolist()
    row_list: list[int] = row_of.tolist()

    def advance(k: int, z: Any, u_k: Array) -> Any:
        tk = t_list[k]
        if discrete:
            return observer.rhs(tk, z, u_k, y_held)
        hk = h_list[k]
        if self_step:
            return observer.step(tk, z, u_k, y_held, hk)  # type: ignore[attr-defined]
        return rk4_step(lambda tt, zz: observer.rhs(tt, zz, u_k, y_held), tk, z, hk)

    if divergence not in ("raise", "keep"):
        raise InvalidArgumentError(f"divergence: expected 'raise' or 'keep', got {divergence!r}")
    diverged_at = math.nan

    def check(upto: int) -> None:
        nonlocal checked, diverged_at
        if upto < checked:
            return
        block = rec[checked:upto + 1]
        ok = np.isfinite(block).reshape(block.shape[0], -1, n_x).all(axis=1)  # (rows, n_x)
        if not ok.all():
            r = int(np.argmin(ok.all(axis=1)))
            j = int(np.argmin(ok[r]))
            when = float(grid[save_steps[checked + r]])
            if divergence == "raise":
                raise SimulationDiverged(when, label, names[j] if j < len(names) else str(j))
            if math.isnan(diverged_at):
                diverged_at = when
        checked = upto + 1

    whole = None
    if isinstance(observer, RecordRunning) and not diagnose:  # compiled code: the whole record in one call
        u_grid = u_arr if u_arr is not None else np.zeros((*batch, K, 0))
        y_grid = np.full((*batch, K, p), np.nan)
        s_grid = np.zeros((K, p), dtype=bool)
        at = np.flatnonzero(fix_at >= 0)
        if at.size:
            y_grid[..., at, :] = y_arr[..., fix_at[at], :]
            s_grid[at] = rows[fix_at[at]]
        t0 = perf()
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            whole = observer.run_records(grid, z, np.broadcast_to(u_grid, (*batch, K, u_grid.shape[-1])), y_grid, s_grid)
        busy = perf() - t0
    if whole is not None:
        rec[...] = np.moveaxis(whole[..., save_steps, :], -2, 0)
        with np.errstate(invalid="ignore"):
            check(Ks - 1)
    else:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"), Progress(K, progress, label) as bar:
            # the rows of each step as a list of views (one run: cheaper than indexing the array at every step)
            u_rows = list(np.moveaxis(u_arr, -2, 0)) if u_arr is not None else [u0] * K
            y_rows = list(np.moveaxis(y_arr, -2, 0)) if G else []
            fresh_rows = list(rows)
            for k in range(K):
                u_k = u_rows[k]
                g = fix_list[k]
                if g >= 0:
                    y_g = y_rows[g]
                    fresh = fresh_rows[g]
                    if correcting:
                        t0 = perf()
                        z = observer.correct(t_list[k], z, u_k, y_g, fresh)  # type: ignore[attr-defined]
                        busy += perf() - t0
                    else:
                        y_held[..., fresh] = y_g[..., fresh]
                j = row_list[k]
                if j >= 0:
                    rec[j] = estimate(z)
                    if diagnose:
                        record_diagnostics(extras, observer.diagnostics(z, u_k), j, Ks)  # type: ignore[attr-defined]
                    if j - checked + 1 >= check_every:
                        check(j)
                if k < K - 1:
                    t0 = perf()
                    z = advance(k, z, u_k)
                    busy += perf() - t0
                bar.update(k + 1)
            check(Ks - 1)

    x_hat = np.moveaxis(rec, 0, -2)
    out_extras = time_major_extras(extras, len(batch))
    if deferred:  # the record is the loop's own buffer: handed over writable (the observer may finish in place)
        x_hat, more = finish(observer, x_hat, n_x)
        out_extras.update(more)
    rec.flags.writeable = False
    if x_hat.base is rec:  # a view made while the record was writable: the result keeps it without a copy
        x_hat.flags.writeable = False
    truth_arr = None
    n_states = len(states) if states is not None else n_x
    if truth is not None:
        tr = as_finite_array("truth", truth)
        if tr.ndim < 2 or tr.shape[-2] != K:
            raise DimensionError(f"truth: expected shape (..., {K}, n) on the time grid, got {tr.shape}")
        tr.setflags(write=False)
        truth_arr = tr[..., save_steps, :] if Ks != K else tr
        n_states = tr.shape[-1]
    state_labels = tuple(states) if states is not None else tuple(f"x{i + 1}" for i in range(n_states))
    if truth_arr is not None and len(state_labels) != truth_arr.shape[-1]:
        raise DimensionError(f"states: {len(state_labels)} names for a truth of {truth_arr.shape[-1]} states")
    observer_s = busy
    dt = float(np.mean(h)) if K > 1 else (tb.dt if isinstance(tb, Discrete) else 0.0)
    method = "discrete" if discrete else ("observer step" if self_step else "rk4")
    if whole is not None:
        method += ", whole record in one call"
    return SimulationResult(
        t=grid[save_steps] if Ks != K else grid,
        x=truth_arr,
        x_hat=x_hat,
        y=None,
        sampled=None,
        states=state_labels,
        outputs=tuple(outputs) if outputs is not None else tuple(f"y{i + 1}" for i in range(p)),
        estimates=names,
        dt=dt,
        method=method,
        observer=label,
        extras=out_extras,
        info={"cost_per_step_us": observer_s / K / max(n_runs, 1) * 1e6, "observer_s": observer_s,
              "wall_s": perf() - wall, "missing": missing_run, "samples": int(G), "diverged_at": diverged_at},
    )
