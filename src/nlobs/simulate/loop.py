"""The simulation loop: a plant and its observer integrated together on one time grid.

Time grid and order of operations
---------------------------------
Times are ``t_k = t0 + k dt`` for ``k = 0 .. N`` with ``N = ceil(duration / dt)``
(so the last time is at or just after ``t0 + duration``). At each ``t_k``:

1. every measurement group due at step ``k`` (``k`` a multiple of its stride
   ``1 / (rate dt)``) reads ``y = h(t_k, x_k, u(t_k))`` plus noise into the
   held measurement; every input sensor due reads ``u(t_k)`` plus noise into
   the held input;
2. a :class:`~nlobs.observers.base.CorrectingObserver` makes its correction
   ``z ← correct(t_k, z, u_obs, y_held, fresh)`` if any group sampled;
3. the state, the estimate and the held measurement are saved (every
   ``save_every``-th step and the last one);
4. plant and observer advance to ``t_{k+1}``:

   * continuous plant and observer: one joint RK4 step of ``(x, z)``; the
     plant is driven by the true ``u(t)`` at each stage (by ``u(t_k)`` for the
     whole step when ``u`` is a zero-order-hold :class:`SampledSignal`, so that
     breakpoints on the grid are integrated exactly), the observer by the
     held measurement (or, with ``measurements=None``, by the exact output
     ``h(t, x, u)`` of the same stage) and by ``u_obs(t)`` — the true input,
     with the channels of input sensors replaced by their held readings;
   * discrete plant: ``x_{k+1} = f(t_k, x_k, u_k)``; continuous plant with a
     discrete observer: one RK4 step of the plant;
   * discrete observer: ``z_{k+1} = g(t_k, z_k, u_obs(t_k), y_k)``;
   * with ``process_noise``, the plant's new state gets its noise increment
     (``√dt · L ξ`` in continuous time, ``L ξ`` in discrete time).

A measurement group in an outage window (``MeasurementGroup.outages``) takes no
sample: its last reading stays held and no correction is made with it.

After every step (and every correction) the plant and observer states are
checked for non-finite entries; the first one seen stops the run with
:class:`~nlobs.errors.SimulationDiverged` at that grid time. NumPy
floating-point warnings (overflow, invalid) are silenced inside the loop
because this check reports them.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._progress import Progress
from nlobs._typing import Array
from nlobs._validate import as_batch, as_covariance, as_finite_array, positive
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError, SimulationDiverged
from nlobs.observers.base import CorrectingObserver, DeferredEstimate, Diagnosing, Observer, SelfStepping
from nlobs.simulate.integrators import RK4, Integrator, SolveIVP, rk4_step, solve_ivp_batch
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.state import first_nonfinite
from nlobs.simulate.sampling import (
    InputSensor,
    MeasurementGroup,
    ScheduledGroup,
    sample_into,
    schedule_inputs,
    schedule_measurements,
)
from nlobs.simulate.signals import InputFunction, InputLike, SampledSignal, as_input_function
from nlobs.systems.base import PlantModel
from nlobs.systems.sensors import covariance_factor
from nlobs.systems.timebase import Continuous, Discrete, TimeBase

#: Relative tolerance when comparing the step sizes of discrete models and ``dt``.
DT_RTOL = 1e-9

#: Most steps ``N = ceil(duration / dt)`` one :func:`simulate` call runs: a longer grid (e.g. ``dt = 1e-300``)
#: is refused up front, naming the step count, instead of failing later for memory or running for days.
MAX_STEPS = 100_000_000

#: The step must be at least this many units in the last place of the largest time ``|t0| + duration``:
#: a smaller one is not resolved by the float times ``t0 + k dt`` (they would repeat or jump).
MIN_STEP_ULPS = 1000.0


class _NullObserver:
    """Stand-in when only the plant is simulated: no state, no estimate."""

    def __init__(self, time: TimeBase) -> None:
        self.time = time

    n_z = 0
    n_x = 0

    def init(self, x_hat0: Array) -> Array:
        return np.zeros((*x_hat0.shape[:-1], 0))

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        return z

    def estimate(self, z: Array) -> Array:
        return z


class _HeldInput:
    """The input of a closed loop: the value the control law last applied, held (the loop sets :attr:`value`)."""

    def __init__(self, batch: tuple[int, ...], m: int) -> None:
        self.value = np.zeros((*batch, m))

    def __call__(self, t: float) -> Array:
        return self.value


def _apply_control(s: _Setup, k: int, t: float, x: Array, z: Any) -> None:
    """At a sample of the control law, its new input from the fed-back state (the estimate, or the truth)."""
    if k % s.control_every:
        return
    fed = x if s.feedback_state else _estimate(s, z)
    u = np.asarray(s.controller(t, fed), dtype=float)
    try:
        s.held.value = np.broadcast_to(u, s.held.value.shape).copy()
    except ValueError:
        raise DimensionError(f"controller: returned shape {u.shape}, expected {s.held.value.shape}") from None
    if not s.keep and not np.isfinite(s.held.value).all():
        raise SimulationDiverged(t, "observer", "controller input")


@dataclass(frozen=True)
class Samples:
    """What the sensors of a plant run read, by step: the held measurement after the step's samples with the
    outputs sampled (``y``), and the held input after the step's input samples (``u``): all an observer
    sees of the plant on a sampled run."""

    y: dict[int, tuple[Array, NDArray[np.bool_]]]
    u: dict[int, Array]


@dataclass(frozen=True)
class _Setup:
    """Everything the two loops share, validated once."""

    plant: PlantModel
    observer: Any
    has_observer: bool
    correcting: bool
    plant_discrete: bool
    observer_discrete: bool
    dt: float
    t0: float
    n_steps: int
    batch: tuple[int, ...]
    x0: Array
    z0: Array
    n_x: int
    u_fn: InputFunction
    u_hold: bool  # piecewise-constant input: RK4 uses u(t_k) for the whole step
    groups: tuple[ScheduledGroup, ...] | None  # None: exact continuous measurement
    sensors: tuple[ScheduledGroup, ...]
    sensed: NDArray[np.bool_]  # (m,) inputs read by a sensor
    rng: np.random.Generator | None
    save_steps: NDArray[np.intp]
    plant_names: tuple[str, ...]
    observer_names: tuple[str, ...] | None
    estimate_names: tuple[str, ...]
    self_step: bool  # a continuous observer advanced by its own step() (SelfStepping)
    array_state: bool  # z is an ndarray (else a tree of arrays: RK4 stages by tree_map)
    diagnose: bool  # the observer's diagnostics() are recorded as extras
    deferred: bool  # raw estimates recorded, finished once at the end (DeferredEstimate)
    q_factor: Array | None = None  # L with L Lᵀ = Q: process noise added to the plant after each step
    keep: bool = False  # divergence="keep": a non-finite observer state is recorded, not raised
    stages: bool = False  # its own step is RK4 with an input per stage (step_stages: generated C), u not held
    tape: Samples | None = None  # a plant run: its samples are written here for observers to replay
    truth: Samples | None = None  # an observer on a recorded plant run: its samples are read from here
    clock: list[float] = dataclasses.field(default_factory=lambda: [0.0, math.nan])  # observer seconds, diverged at
    controller: Any = None  # a feedback law u = k(t, x̂ or x): the loop is closed (its input held in `held`)
    feedback_state: bool = False  # the law is fed the true state (the reference loop), not the estimate
    control_every: int = 1  # steps between two samples of the law
    held: Any = None  # _HeldInput: the input the law last applied

    def t(self, k: int) -> float:
        return self.t0 + k * self.dt


class _State:
    """The loop's mutable working state (held readings), private to one run."""

    def __init__(self, s: _Setup) -> None:
        p, m = s.plant.p, s.plant.m
        self.y_held = np.full((*s.batch, p), np.nan)
        self.u_held = np.full((*s.batch, m), np.nan)
        self.y_view = self.y_held.view()
        self.y_view.flags.writeable = False
        self.u_view = self.u_held.view()
        self.u_view.flags.writeable = False
        self.fresh = np.zeros(p, dtype=bool)
        self.all_fresh = np.ones(p, dtype=bool)
        self.all_sensed = bool(s.sensed.all()) and s.sensed.size > 0

    def u_obs(self, s: _Setup, u: Array) -> Array:
        """Input seen by the observer: true ``u`` with sensed channels replaced by held readings."""
        if not s.sensors:
            return u
        if self.all_sensed:
            return self.u_view
        return np.where(s.sensed, self.u_held, u)


class _Recorder:
    """Preallocated output arrays and the mapping from steps to saved rows.

    The buffers are time-major, ``(K, *batch, n)``, so that each saved step is
    one contiguous write; :meth:`arrays` hands them out as read-only
    ``(*batch, K, n)`` views without copying.
    """

    def __init__(self, s: _Setup, plant_rows: tuple[Array, Array, NDArray[np.bool_]] | None = None) -> None:
        K = s.save_steps.size
        self.t = s.t0 + s.save_steps * s.dt
        self.x_hat = np.empty((K, *s.batch, s.n_x))
        self.replay = plant_rows is not None  # the plant's rows (time-major x, y, sampled) come from its recorded run
        if plant_rows is None:
            self.x = np.empty((K, *s.batch, s.plant.n))
            self.y = np.empty((K, *s.batch, s.plant.p))
            self.sampled = np.zeros((K, s.plant.p), dtype=bool)
        else:
            self.x, self.y, self.sampled = plant_rows
        self.row_of = {int(k): j for j, k in enumerate(s.save_steps)}
        self.extras: dict[str, Array] = {}
        self.K = K

    def save(self, s: _Setup, k: int, x: Array, z: Any, y: Array, fresh: NDArray[np.bool_], u: Array) -> None:
        j = self.row_of.get(k)
        if j is None:
            return
        if not self.replay:
            self.x[j] = x
            self.y[j] = y
            self.sampled[j] = fresh
        self.x_hat[j] = _estimate(s, z)
        if s.diagnose:
            record_diagnostics(self.extras, s.observer.diagnostics(z, u), j, self.K)

    def arrays(self, s: _Setup) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for name in ("t", "x", "x_hat", "y", "sampled"):
            buf = getattr(self, name)
            buf.flags.writeable = False
            out[name] = buf if name in ("t", "sampled") else np.moveaxis(buf, 0, -2)
        extras = time_major_extras(self.extras, len(s.batch))
        if s.deferred:
            out["x_hat"], more = finish(s.observer, out["x_hat"], s.n_x)
            extras.update(more)
        out["extras"] = extras
        return out


def record_diagnostics(store: dict[str, Array], diag: Mapping[str, Any], row: int, rows: int) -> None:
    """Write an observer's ``diagnostics`` into time-major buffers ``(K, ...)``, allocated on first use."""
    for name, val in diag.items():
        buf = store.get(name)
        if buf is None:
            arr = np.asarray(val)
            buf = store[name] = np.full((rows, *arr.shape), np.nan, dtype=np.result_type(arr.dtype, np.float64))
        buf[row] = val


def time_major_extras(store: dict[str, Array], n_batch: int) -> dict[str, Array]:
    """The recorded extras as read-only ``(*batch, K, ...)`` views (``(K, ...)`` when not batched)."""
    out = {}
    for name, buf in store.items():
        buf.flags.writeable = False
        lead = min(n_batch, buf.ndim - 1)
        out[name] = np.moveaxis(buf, 0, lead) if lead else buf
    return out


def finish(observer: Any, raw: Array, n_x: int) -> tuple[Array, dict[str, Array]]:
    """Apply a :class:`~nlobs.observers.base.DeferredEstimate` observer's ``finish_estimates`` to a record."""
    est, more = observer.finish_estimates(raw)
    est = np.asarray(est, dtype=float)
    if est.shape != raw.shape:
        raise DimensionError(f"observer.finish_estimates returned shape {est.shape}, expected {raw.shape}")
    return est, {str(k): np.asarray(v) for k, v in more.items()}


def _estimate(s: _Setup, z: Any) -> Array:
    if not s.has_observer:
        return np.empty((*s.batch, 0))
    return s.observer.raw_estimate(z) if s.deferred else s.observer.estimate(z)


def _first_bad(arr: Array, names: tuple[str, ...]) -> str:
    bad = ~np.isfinite(arr).reshape(-1, arr.shape[-1]).all(axis=0)
    return names[int(np.flatnonzero(bad)[0])]


def _check_z(s: _Setup, t: float, z: Any) -> None:
    if s.keep:  # divergence="keep": the first time is recorded, the run goes on
        if math.isnan(s.clock[1]) and first_nonfinite(z, s.observer_names) is not None:
            s.clock[1] = t
        return
    if s.array_state:
        if not np.isfinite(z).all():
            raise SimulationDiverged(t, "observer", first_nonfinite(z, s.observer_names) or "z")
        return
    bad = first_nonfinite(z, s.observer_names)
    if bad is not None:
        raise SimulationDiverged(t, "observer", bad)


def _check_finite(s: _Setup, t: float, x: Array, z: Any) -> None:
    if not np.isfinite(x).all():
        if s.keep and s.controller is not None:  # a closed loop the estimate drove away: that run's failure
            if math.isnan(s.clock[1]):
                s.clock[1] = t
        else:
            raise SimulationDiverged(t, "plant", _first_bad(x, s.plant_names))
    _check_z(s, t, z)


def _events(s: _Setup, st: _State, k: int, t: float, x: Array, z: Array) -> tuple[Array, NDArray[np.bool_]]:
    """Sampling and correction at step ``k``; returns the (corrected) ``z`` and the fresh mask.

    Replaying a recorded plant run (``s.truth``), the readings are the ones the plant's run took at this step."""
    fresh, u = st.fresh, None
    if s.truth is not None:
        got = s.truth.y.get(k)
        held_u = s.truth.u.get(k)
        if held_u is not None:
            st.u_held[...] = held_u
        if got is None:
            return z, fresh
        st.y_held[...], fresh = got
        due = True
    else:
        due_y = [g for g in s.groups if g.due(k, t)] if s.groups else []
        due_u = [g for g in s.sensors if g.due(k, t)]
        if not (due_y or due_u or (s.groups is None and s.correcting)):
            return z, fresh
        u = s.u_fn(t)
        if due_y:
            y = s.plant.output(t, x, u)
            fresh = np.zeros_like(st.fresh)
            for g in due_y:
                sample_into(st.y_held, y, g, s.rng)
                fresh[g.index] = True
        for g in due_u:
            sample_into(st.u_held, u, g, s.rng)
        if s.tape is not None:  # a plant run recorded for observers to replay
            if due_y:
                s.tape.y[k] = (st.y_held.copy(), fresh)
            if due_u:
                s.tape.u[k] = st.u_held.copy()
        due = bool(due_y)
    if s.correcting:
        exact = s.groups is None  # discrete observer with exact measurements: every step is a sample
        if u is None:
            u = s.u_fn(t)
        y_obs = s.plant.output(t, x, u) if exact else st.y_view
        tic = _time.perf_counter()
        if exact:
            z = s.observer.correct(t, z, st.u_obs(s, u), y_obs, st.all_fresh)
            fresh = st.all_fresh
        elif due:
            z = s.observer.correct(t, z, st.u_obs(s, u), y_obs, fresh)
        s.clock[0] += _time.perf_counter() - tic
        _check_z(s, t, z)
    return z, fresh


def _measurement(s: _Setup, st: _State, t: float, x: Array, u: Array) -> Array:
    return s.plant.output(t, x, u) if s.groups is None else st.y_view


def _run_fixed(s: _Setup, rec: _Recorder, progress: Progress) -> None:
    """RK4 (continuous) or map iteration (discrete), one vectorised call per stage."""
    st = _State(s)
    x, z = s.x0, s.z0
    plant, obs = s.plant, s.observer
    exact_y = s.groups is None

    u_step = s.u_fn(s.t0)  # u(t_k), used at every stage for a piecewise-constant input

    clock = s.clock
    perf = _time.perf_counter

    def joint(t: float, xz: tuple[Any, ...]) -> tuple[Any, ...]:
        xs, zs = xz
        u = u_step if s.u_hold else s.u_fn(t)
        y = plant.output(t, xs, u) if exact_y else st.y_view
        dx = plant.rhs(t, xs, u)
        uo = st.u_obs(s, u)
        tic = perf()
        dz = obs.rhs(t, zs, uo, y)
        clock[0] += perf() - tic
        return dx, dz

    def plant_only(t: float, xs: Array) -> Array:
        return plant.rhs(t, xs, u_step if s.u_hold else s.u_fn(t))

    if s.truth is not None:
        _replay_fixed(s, st, rec, progress)
        return
    _check_finite(s, s.t0, x, z)
    for k in range(s.n_steps + 1):
        t = s.t(k)
        z, fresh = _events(s, st, k, t, x, z)
        if s.controller is not None:
            _apply_control(s, k, t, x, z)
            if k in rec.row_of:
                record_diagnostics(rec.extras, {"u": s.held.value}, rec.row_of[k], rec.K)
        if k in rec.row_of:
            u_k = s.u_fn(t)
            y_rec = plant.output(t, x, u_k) if exact_y else st.y_view
            rec.save(s, k, x, z, y_rec, st.all_fresh if exact_y else fresh, st.u_obs(s, u_k))
        if k == s.n_steps:
            break
        if s.u_hold:
            u_step = s.u_fn(t)
        if s.observer_discrete or s.plant_discrete or s.self_step:
            u = s.u_fn(t)
            uo, yo = st.u_obs(s, u), _measurement(s, st, t, x, u)
            tic = perf()
            if s.observer_discrete:
                z = obs.rhs(t, z, uo, yo)
            elif s.self_step:  # the observer's own discretisation, u and y held over the step
                z = _own_step(s, st, t, z, uo, yo)
            clock[0] += perf() - tic
            x = plant.rhs(t, x, u) if s.plant_discrete else _plant_step(s, plant_only, t, x, u_step)
        elif s.has_observer:
            x, z = rk4_step(joint, t, (x, z), s.dt)
        else:
            x = _plant_step(s, plant_only, t, x, u_step)
        if s.q_factor is not None:
            x = x + _process_noise(s, x.shape)
        _check_finite(s, s.t(k + 1), x, z)
        progress.update(k + 1)


def _plant_step(s: _Setup, plant_only: Callable[[float, Array], Array], t: float, x: Array, u_step: Array) -> Array:
    """The continuous plant's RK4 step from ``t``: its own ``step_stages`` where it has one (a compiled plant: the
    same stages, the input at RK4's stage times unless it is held), else :func:`rk4_step` of ``plant_only``."""
    step = getattr(s.plant, "step_stages", None)
    if step is None:
        return rk4_step(plant_only, t, x, s.dt)  # type: ignore[no-any-return]
    h = s.dt
    if s.u_hold:
        return step(t, x, u_step, u_step, u_step, h)  # type: ignore[no-any-return]
    return step(t, x, s.u_fn(t), s.u_fn(t + 0.5 * h), s.u_fn(t + h), h)  # type: ignore[no-any-return]


def _own_step(s: _Setup, st: _State, t: float, z: Any, uo: Array, y: Array) -> Any:
    """A self-stepping observer's step from ``t`` over ``dt`` with ``y`` held; a generated RK4 step
    (``step_stages``) reads the input at RK4's stage times, as the joint RK4 gives an observer's ``rhs``,
    unless the input is held over the step (``uo`` is the observer's input at ``t``)."""
    if s.stages and not s.u_hold:
        h = s.dt
        return s.observer.step_stages(t, z, uo, st.u_obs(s, s.u_fn(t + 0.5 * h)), st.u_obs(s, s.u_fn(t + h)), y, h)
    return s.observer.step(t, z, uo, y, s.dt)


def _replay_fixed(s: _Setup, st: _State, rec: _Recorder, progress: Progress) -> None:
    """:func:`_run_fixed` for an observer on a recorded plant run: the same operations on ``z`` in the same order
    (so the same numbers, bit for bit), the plant's samples read back instead of the plant integrated."""
    z, obs, clock, perf = s.z0, s.observer, s.clock, _time.perf_counter
    u_step = s.u_fn(s.t0)

    def observer_only(t: float, zs: Any) -> Any:
        uo = st.u_obs(s, u_step if s.u_hold else s.u_fn(t))
        tic = perf()
        dz = obs.rhs(t, zs, uo, st.y_view)
        clock[0] += perf() - tic
        return dz

    _check_z(s, s.t0, z)
    for k in range(s.n_steps + 1):
        t = s.t(k)
        z, fresh = _events(s, st, k, t, s.x0, z)
        if k in rec.row_of:
            rec.save(s, k, s.x0, z, st.y_view, fresh, st.u_obs(s, s.u_fn(t)))
        if k == s.n_steps:
            break
        if s.u_hold:
            u_step = s.u_fn(t)
        if s.observer_discrete or s.self_step:
            uo = st.u_obs(s, s.u_fn(t))
            tic = perf()
            z = obs.rhs(t, z, uo, st.y_view) if s.observer_discrete else _own_step(s, st, t, z, uo, st.y_view)
            clock[0] += perf() - tic
        else:
            z = rk4_step(observer_only, t, z, s.dt)
        _check_z(s, s.t(k + 1), z)
        progress.update(k + 1)


def _process_noise(s: _Setup, shape: tuple[int, ...]) -> Array:
    """One step's process noise: ``√dt · L ξ`` (continuous plant, ``Q`` a spectral density), ``L ξ`` (discrete)."""
    assert s.rng is not None and s.q_factor is not None  # guarded by simulate()
    w = s.rng.standard_normal(shape) @ s.q_factor.T
    return w if s.plant_discrete else math.sqrt(s.dt) * w


def _run_ivp(s: _Setup, rec: _Recorder, progress: Progress, options: dict[str, Any]) -> None:
    """``solve_ivp`` between consecutive event steps (samples, discrete observer steps)."""
    st = _State(s)
    x, z = s.x0, s.z0
    plant, obs = s.plant, s.observer
    n, exact_y = plant.n, s.groups is None
    joint_z = s.has_observer and not s.observer_discrete

    events: set[int] = {0, s.n_steps}
    if s.observer_discrete:
        events.update(range(s.n_steps + 1))
    for g in (*(s.groups or ()), *s.sensors):
        events.update(range(0, s.n_steps + 1, g.stride))
    ev = sorted(events)

    def f(t: float, xz: Array) -> Array:
        xs, zs = xz[..., :n], xz[..., n:]
        u = s.u_fn(t)
        dx = plant.rhs(t, xs, u)
        if not joint_z:
            return dx
        y = plant.output(t, xs, u) if exact_y else st.y_view
        return np.concatenate([dx, obs.rhs(t, zs, st.u_obs(s, u), y)], axis=-1)

    _check_finite(s, s.t0, x, z)
    for i, k in enumerate(ev):
        t = s.t(k)
        z, fresh = _events(s, st, k, t, x, z)
        saved_fresh = st.all_fresh if exact_y else fresh
        u = s.u_fn(t)
        rec.save(s, k, x, z, _measurement(s, st, t, x, u), saved_fresh, st.u_obs(s, u))
        if k == s.n_steps:
            break
        k_next = ev[i + 1]
        inner = [j for j in range(k + 1, k_next) if j in rec.row_of]
        steps = [*inner, k_next]
        y0 = np.concatenate([x, z], axis=-1) if joint_z else x
        ys, sol = solve_ivp_batch(f, y0, (t, s.t(k_next)), [s.t(j) for j in steps], options)
        for row, j in enumerate(steps[: ys.shape[0]]):
            xj = ys[row][..., :n]
            zj = ys[row][..., n:] if joint_z else z
            _check_finite(s, s.t(j), xj, zj)
            if j != k_next:
                uj = s.u_fn(s.t(j))
                rec.save(s, j, xj, zj, _measurement(s, st, s.t(j), xj, uj), st.all_fresh if exact_y else st.fresh,
                         st.u_obs(s, uj))
        if sol.status != 0:
            _raise_ivp_failure(s, sol, y0.shape, joint_z)
        x_new = ys[-1][..., :n]
        if s.observer_discrete and s.has_observer:
            z = obs.rhs(t, z, st.u_obs(s, u), _measurement(s, st, t, x, u))
        elif joint_z:
            z = ys[-1][..., n:]
        x = x_new
        _check_finite(s, s.t(k_next), x, z)
        progress.update(k_next)


def _raise_ivp_failure(s: _Setup, sol: Any, shape: tuple[int, ...], joint_z: bool) -> None:
    """Report a ``solve_ivp`` failure (step size collapsed) as divergence of the largest component.

    The last accepted state is usually finite but huge; the component with the
    largest magnitude (non-finite first) is named, with the solver's message as cause.
    """
    n = s.plant.n
    last = np.asarray(sol.y[:, -1]).reshape(shape)
    mag = np.where(np.isfinite(last), np.abs(last), np.inf)
    which, names, part = "plant", s.plant_names, mag[..., :n]
    if joint_z and np.max(mag[..., n:], initial=0.0) > np.max(part, initial=0.0):
        part = mag[..., n:]
        which, names = "observer", s.observer_names or tuple(f"z[{i}]" for i in range(part.shape[-1]))
    worst = int(np.argmax(part.reshape(-1, part.shape[-1]).max(axis=0)))
    raise SimulationDiverged(float(sol.t[-1]), which, names[worst]) from RuntimeError(str(sol.message))


def _timebases(
    plant: PlantModel, observer: Any, has_observer: bool, dt: float | None
) -> tuple[float, bool, bool]:
    """Resolve the step ``dt`` and check the time bases agree."""
    pt, ot = plant.time, observer.time
    for who, tb in (("plant", pt), ("observer", ot)):
        if not isinstance(tb, (Continuous, Discrete)):
            raise InvalidArgumentError(f"{who}.time: expected Continuous or Discrete, got {tb!r}")
    if pt.is_discrete and not ot.is_discrete:
        raise InvalidArgumentError("a discrete-time plant needs a discrete-time observer (got a continuous-time observer)")
    fixed = [(who, tb.dt) for who, tb in (("plant", pt), ("observer", ot)) if isinstance(tb, Discrete)]
    if not has_observer:
        fixed = [f for f in fixed if f[0] == "plant"]
    if dt is not None:
        dt = positive("dt", dt)
        fixed.append(("dt argument", dt))
    if not fixed:
        raise InvalidArgumentError("dt: required for a continuous-time simulation (there is no default step)")
    ref_who, ref = fixed[0]
    for who, val in fixed[1:]:
        if abs(val - ref) > DT_RTOL * max(val, ref):
            raise InvalidArgumentError(f"time step mismatch: {ref_who} has dt={ref:g} but {who} has dt={val:g}")
    return ref, pt.is_discrete, bool(has_observer and ot.is_discrete)


def _as_tuple(value: Any, kind: type, name: str) -> tuple[Any, ...]:
    if value is None:
        return ()
    if isinstance(value, kind):
        return (value,)
    if isinstance(value, Sequence) and not isinstance(value, str):
        return tuple(value)
    raise InvalidArgumentError(f"{name}: expected a {kind.__name__} or a sequence of them, got {type(value).__name__}")


def simulate(
    plant: PlantModel,
    observer: Observer | None,
    x0: ArrayLike,
    x_hat0: ArrayLike | None = None,
    *,
    duration: float,
    dt: float | None = None,
    u: InputLike = None,
    measurements: MeasurementGroup | Sequence[MeasurementGroup] | None = None,
    input_sensors: InputSensor | Sequence[InputSensor] | None = None,
    process_noise: ArrayLike | None = None,
    seed: int | np.random.Generator | None = None,
    integrator: Integrator = RK4(),
    save_every: int = 1,
    t0: float = 0.0,
    progress: bool | None = None,
    divergence: Literal["raise", "keep"] = "raise",
    controller: Callable[[float, Array], ArrayLike] | None = None,
    feedback: Literal["estimate", "state"] = "estimate",
) -> SimulationResult:
    """Simulate a plant and an observer together, for one or many initial conditions.

    Parameters
    ----------
    plant : PlantModel
        The true system (continuous or discrete time).
    observer : Observer or None
        The observer (``None`` simulates the plant alone). A
        :class:`~nlobs.observers.base.CorrectingObserver` is corrected at each
        sample instant. If it has a ``state_names`` attribute (``n_z``
        strings), divergence reports use it; otherwise ``z[i]``.
    x0 : array_like, shape (n,) or (*batch, n)
        Initial plant state(s); a batch shape runs many trajectories at once.
    x_hat0 : array_like, shape (n_x,) or (*batch, n_x)
        Initial estimate(s), passed to ``observer.init``; broadcast over the batch.
        Required when there is an observer.
    duration : float
        Simulated time span (seconds); the run stops at the first grid time at
        or after ``t0 + duration``.
    dt : float, optional
        Integration step. Required for continuous time; for a discrete plant
        or observer it defaults to, and must agree with, the model's ``dt``.
    u : None, array_like, callable or SampledSignal
        Known input: a constant of shape ``(m,)`` or ``(*batch, m)``, a callable
        ``u(t)`` returning such an array, or a :class:`SampledSignal`.
    measurements : MeasurementGroup or sequence of them, optional
        Sampled sensors, each with its own required rate and noise; together
        they must cover every plant output. ``None`` means exact measurement
        of every output, evaluated at every RK4 stage (every step in discrete time).
    input_sensors : InputSensor or sequence of them, optional
        Inputs the observer receives sampled, held and noisy (the plant always
        gets the true ``u``).
    process_noise : array_like, shape (n, n) or (n,), optional
        Process noise of the plant: a covariance ``Q`` (symmetric positive semidefinite) or the
        standard deviations of independent components (``Q = diag(std²)``). Continuous time:
        ``ẋ = f(x, u) + w`` with white ``w`` of spectral density ``Q``; each RK4 step adds
        ``√dt · L ξ`` (``L Lᵀ = Q``, ``ξ`` standard normal): the additive-noise Euler–Maruyama
        increment, exact for the noise, RK4 for the drift. Discrete time: ``x⁺ = f(x, u) + w_k``,
        ``w_k ~ N(0, Q)``. Drawn after the step's measurement noise. ``None``: none.
    seed : int or numpy.random.Generator, optional
        Noise source; required when any sensor has non-zero noise or there is process noise.
        A Generator is used (and advanced) as given.
    integrator : RK4 or SolveIVP
        ``RK4()`` (fixed step, default) or ``SolveIVP(...)`` (adaptive,
        continuous-time plants only; the batch is flattened into one ODE).
    save_every : int
        Keep every ``save_every``-th step (and always the last one).
    t0 : float
        Start time.
    progress : bool, optional
        ``True``: always show a progress bar (on stderr); ``False``: never;
        ``None`` (default): show one only when the run has already taken a
        couple of seconds and stderr is a terminal.
    divergence : {"raise", "keep"}
        ``"raise"`` (default): a non-finite plant or observer state stops the run with
        :class:`~nlobs.errors.SimulationDiverged`. ``"keep"``: a non-finite *observer* state is
        carried on (the batch members concerned have NaN or inf estimates from then on, the
        others are unaffected) and ``info["diverged_at"]`` is the first such time (NaN if none);
        a non-finite plant state still raises (in a closed loop it is kept too: the estimate drove that run away).
    controller : callable, optional
        A feedback law ``controller(t, x) -> u`` (``(..., n) -> (..., m)``, e.g. a
        :class:`~nlobs.systems.controller.ControlLaw`): the loop is closed, the plant's input is the law's output
        evaluated after the step's correction and held over the step, or over ``1/controller.rate`` when the
        law has a ``rate`` (a sampled controller). ``u`` must then be ``None`` and there are no input sensors;
        the applied input is recorded as ``extras["u"]``.
    feedback : {"estimate", "state"}
        What the law is fed: the observer's estimate (default), or the true state (the reference loop of
        separation: run without an observer, on the same noise).

    Returns
    -------
    SimulationResult
        ``info`` holds ``wall_s``, ``cost_per_step_us`` (the wall time spent inside the
        observer's ``rhs``, ``correct`` and ``step``, divided by the number of grid instants and
        of batch members: the cost of one step of one run, as :func:`run_observer` measures it)
        and, with ``divergence="keep"``, ``diverged_at``.

    Raises
    ------
    DimensionError
        ``x0``, ``x_hat0``, ``u`` or the observer's ``init``/``estimate`` have the wrong shape.
    NonFiniteError
        ``x0``, ``x_hat0``, ``u(t0)``, ``dt``, ``duration`` or ``t0`` is not finite (a complex ``x0`` or
        ``x_hat0`` is :class:`~nlobs.errors.InvalidArgumentError`).
    InvalidArgumentError
        Non-positive ``dt`` or ``duration``, a grid of more than :data:`MAX_STEPS` steps or with a ``dt``
        the float times cannot resolve (:data:`MIN_STEP_ULPS`), a missing ``dt``, a ``dt`` that
        disagrees with a discrete model, a sensor rate that does not fit ``dt``,
        outputs without a measurement group, or noise without a seed.
    SimulationDiverged
        A plant or observer state became non-finite (the time and the first
        such state are named).

    Examples
    --------
    A linear plant and a Luenberger observer whose error dynamics ``A − L C`` has its poles at −2 and −3:

    >>> import numpy as np
    >>> import nlobs
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.LuenbergerObserver(system, [[4.5], [1.75]])
    >>> res = simulate(system, observer, [1.0, 0.0], [0.0, 0.0], duration=5.0, dt=1e-3, u=0.0)
    >>> res.x_hat.shape
    (5001, 2)
    >>> e = np.abs(res.x - res.x_hat).max(axis=-1)  # from 1 at t = 0, about as e^(−2t)
    >>> bool(0.2 < e[1000] < 0.5 and e[-1] < 1e-3)
    True

    The same loop closed by the state feedback ``u = −2 x1 − x2`` on the estimate, beside the loop fed the true
    state: the estimate's initial error moves the plant away from the reference only while it decays:

    >>> law = nlobs.ControlLaw(system.states, system.inputs, ["-2*x1 - x2"])
    >>> loop = simulate(system, observer, [1.0, 0.0], [0.0, 0.0], duration=10.0, dt=1e-3, controller=law)
    >>> ref = simulate(system, None, [1.0, 0.0], duration=10.0, dt=1e-3, controller=law, feedback="state")
    >>> loop.extras["u"].shape, float(loop.extras["u"][0, 0]), float(ref.extras["u"][0, 0])  # u = −2 x̂1 − x̂2
    ((10001, 1), -0.0, -2.0)
    >>> d = np.linalg.norm(loop.x - ref.x, axis=-1)
    >>> bool(d.max() > 0.1 and d[-1] < 0.05 * d.max())
    True
    """
    u_given = u if controller is None or u is not None else np.zeros(int(getattr(plant, "m", 0) or 0))
    setup = _prepare(plant, observer, x0, x_hat0, duration=duration, dt=dt, u=u_given, measurements=measurements,
                     input_sensors=input_sensors, process_noise=process_noise, seed=seed, integrator=integrator,
                     save_every=save_every, t0=t0, divergence=divergence)
    if controller is not None:
        setup = _closed_loop(setup, controller, feedback, u, integrator)
    elif feedback != "estimate":
        raise InvalidArgumentError("feedback: applies to a closed loop (give a controller)")
    return _execute(setup, integrator, observer, progress)


def _closed_loop(setup: _Setup, controller: Any, feedback: str, u: Any, integrator: Integrator) -> _Setup:
    """The setup with its input replaced by the control law's held output (:func:`simulate`'s ``controller``)."""
    from nlobs.systems.controller import control_period_steps

    if not callable(controller):
        raise InvalidArgumentError(f"controller: expected a callable controller(t, x) -> u, got {type(controller).__name__}")
    if feedback not in ("estimate", "state"):
        raise InvalidArgumentError(f"feedback: expected 'estimate' or 'state', got {feedback!r}")
    if feedback == "estimate" and not setup.has_observer:
        raise InvalidArgumentError("feedback: 'estimate' needs an observer; without one, feed the state "
                                   "(feedback='state')")
    if feedback == "estimate" and setup.n_x != setup.plant.n:
        raise InvalidArgumentError(f"controller: the observer estimates {setup.n_x} values, the plant has "
                                   f"{setup.plant.n} states")
    if u is not None and setup.plant.m:
        raise InvalidArgumentError("u: a closed loop's input is the controller's; give u=None")
    if setup.sensors:
        raise InvalidArgumentError("input_sensors: a closed loop's input is the controller's own, known exactly")
    if isinstance(integrator, SolveIVP):
        raise InvalidArgumentError("integrator: a closed loop is simulated with RK4() (the input is held per step)")
    every = control_period_steps(getattr(controller, "rate", None), setup.dt)
    held = _HeldInput(setup.batch, setup.plant.m)
    return dataclasses.replace(setup, controller=controller, feedback_state=feedback == "state", control_every=every,
                               held=held, u_fn=held, u_hold=True)


@dataclass(frozen=True)
class PlantRun:
    """A plant simulated alone with its sensors, kept for observers to replay (:func:`simulate_plant`).

    ``result`` is the plant's :class:`SimulationResult` (no estimates); the rest is the loop's setup and the readings
    of every sensor at every step it sampled: everything an observer on this run sees.

    Attributes
    ----------
    result : SimulationResult
        The plant's run: ``x``, ``y``, ``sampled``; ``x_hat`` has no columns.
    setup : object
        The loop's checked arguments (grid, sensors, input), reused by :func:`observe`.
    samples : object
        The held readings by step: ``samples.y`` (measurements, with the outputs sampled) and ``samples.u``
        (input sensors).
    rows : tuple of ndarray
        The time-major buffers of ``x``, ``y`` and the sampled mask behind ``result``.

    Examples
    --------
    An oscillator whose position is sampled at 10 Hz with noise, over 5 s: 51 readings are kept for the observers
    that :func:`observe` runs on it:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup
    >>> plant = nlobs.LinearSystem([[0.0, 1.0], [-1.0, 0.0]], np.zeros((2, 1)), [[1.0, 0.0]])
    >>> sensor = MeasurementGroup("position", [0], rate=10.0, noise_std=0.01)
    >>> run = simulate_plant(plant, [1.0, 0.0], duration=5.0, dt=1e-2, u=0.0, measurements=sensor, seed=1)
    >>> isinstance(run, PlantRun), run.result.x.shape, run.result.x_hat.shape
    (True, (501, 2), (501, 0))
    >>> len(run.samples.y), int(run.result.sampled.sum()), run.setup.dt
    (51, 51, 0.01)
    >>> bool(np.allclose(run.result.x[:, 0], np.cos(run.result.t), atol=1e-8))
    True
    """

    result: SimulationResult
    setup: _Setup
    samples: Samples
    rows: tuple[Array, Array, NDArray[np.bool_]]  # time-major x, y and the sampled mask, the result's buffers


def simulate_plant(
    plant: PlantModel,
    x0: ArrayLike,
    *,
    duration: float,
    dt: float | None = None,
    u: InputLike = None,
    measurements: MeasurementGroup | Sequence[MeasurementGroup],
    input_sensors: InputSensor | Sequence[InputSensor] | None = None,
    process_noise: ArrayLike | None = None,
    seed: int | np.random.Generator | None = None,
    save_every: int = 1,
    t0: float = 0.0,
    progress: bool | None = None,
) -> PlantRun:
    """Simulate a plant with its sensors once, for any number of observers (:func:`observe`).

    ``observe(simulate_plant(plant, x0, **args), observer, x_hat0)`` is ``simulate(plant, observer, x0, x_hat0,
    **args)``, bit for bit: the plant does not depend on the observer, and an observer on sampled measurements
    sees the plant only through the held readings and the known input. So a comparison of N observers integrates
    the plant once, not N times. The arguments are :func:`simulate`'s (RK4 for a continuous plant).

    Parameters
    ----------
    plant : PlantModel
        The true system.
    x0 : array_like, shape (n,) or (*batch, n)
        Initial plant state(s).
    duration, dt, u, input_sensors, process_noise, seed, save_every, t0, progress
        As for :func:`simulate`.
    measurements : MeasurementGroup or sequence of them
        The sampled sensors (required: with exact outputs an observer reads the plant at every RK4 stage, so it
        must be integrated with it, by :func:`simulate`).

    Returns
    -------
    PlantRun

    Raises
    ------
    InvalidArgumentError, DimensionError, NonFiniteError
        As for :func:`simulate`; ``measurements`` missing.
    SimulationDiverged
        The plant's state became non-finite.

    Examples
    --------
    One noisy sampled run of an oscillator, and two Luenberger observers on it (the plant is integrated once):
    each gives the same numbers, bit for bit, as :func:`simulate` of the plant with it, and the faster gain ends
    with the smaller error:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup
    >>> plant = nlobs.LinearSystem([[0.0, 1.0], [-1.0, 0.0]], np.zeros((2, 1)), [[1.0, 0.0]])
    >>> sensor = MeasurementGroup("position", [0], rate=10.0, noise_std=0.01)
    >>> args = dict(duration=5.0, dt=1e-2, u=0.0, measurements=sensor, seed=1)
    >>> run = simulate_plant(plant, [1.0, 0.0], **args)
    >>> slow, fast = nlobs.LuenbergerObserver(plant, [[1.0], [0.5]]), nlobs.LuenbergerObserver(plant, [[4.0], [4.0]])
    >>> results = [observe(run, observer, [0.0, 0.0]) for observer in (slow, fast)]
    >>> alone = simulate(plant, fast, [1.0, 0.0], [0.0, 0.0], **args)
    >>> bool(np.array_equal(results[1].x_hat, alone.x_hat) and np.array_equal(results[1].x, alone.x))
    True
    >>> [round(float(r.error_norm[-1]), 2) for r in results]
    [0.15, 0.05]

    Without sampled sensors there is nothing to replay (an observer on exact outputs reads every RK4 stage):

    >>> try:
    ...     simulate_plant(plant, [1.0, 0.0], duration=5.0, dt=1e-2, u=0.0, measurements=None)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError measurements: a plant run for observers to replay needs sampled measurement groups ...
    """
    if measurements is None:
        raise InvalidArgumentError("measurements: a plant run for observers to replay needs sampled measurement "
                                   "groups (with exact outputs the observer reads every RK4 stage: use simulate)")
    setup = _prepare(plant, None, x0, None, duration=duration, dt=dt, u=u, measurements=measurements,
                     input_sensors=input_sensors, process_noise=process_noise, seed=seed, integrator=RK4(),
                     save_every=save_every, t0=t0, divergence="raise")
    setup = dataclasses.replace(setup, tape=Samples({}, {}))
    result = _execute(setup, RK4(), None, progress)
    rows = (np.moveaxis(result.x, -2, 0), np.moveaxis(result.y, -2, 0), result.sampled)
    return PlantRun(result, dataclasses.replace(setup, tape=None, rng=None), setup.tape, rows)


def observe(run: PlantRun, observer: Observer, x_hat0: ArrayLike, *, progress: bool | None = None,
            divergence: Literal["raise", "keep"] = "raise") -> SimulationResult:
    """An observer on a recorded plant run: :func:`simulate` with the run's arguments, the plant not integrated again.

    Parameters
    ----------
    run : PlantRun
        From :func:`simulate_plant`.
    observer : Observer
        The observer; its time base must agree with the run's step.
    x_hat0 : array_like, shape (n_x,) or (*batch, n_x)
        Initial estimate(s), broadcast over the run's batch.
    progress, divergence
        As for :func:`simulate`.

    Returns
    -------
    SimulationResult
        The same numbers as :func:`simulate` (the plant's ``x``, ``y`` and ``sampled`` are the run's own arrays).

    Raises
    ------
    InvalidArgumentError, DimensionError
        Not a :class:`PlantRun`, not an observer, a time base that disagrees with the run, a bad ``x_hat0``.
    SimulationDiverged
        The observer's state became non-finite (``divergence="raise"``).

    Examples
    --------
    An observer on a recorded noisy run of an oscillator (position sampled at 10 Hz) gives what :func:`simulate`
    gives for the plant and the observer together, bit for bit, and the run's own ``x`` and ``y``:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup
    >>> plant = nlobs.LinearSystem([[0.0, 1.0], [-1.0, 0.0]], np.zeros((2, 1)), [[1.0, 0.0]])
    >>> sensor = MeasurementGroup("position", [0], rate=10.0, noise_std=0.01)
    >>> run = simulate_plant(plant, [1.0, 0.0], duration=5.0, dt=1e-2, u=0.0, measurements=sensor, seed=1)
    >>> observer = nlobs.LuenbergerObserver(plant, [[4.0], [4.0]])
    >>> res = observe(run, observer, [0.0, 0.0])
    >>> same = simulate(plant, observer, [1.0, 0.0], [0.0, 0.0], duration=5.0, dt=1e-2, u=0.0, measurements=sensor,
    ...                 seed=1)
    >>> bool(np.array_equal(res.x_hat, same.x_hat)), bool(np.array_equal(res.y, run.result.y)), res.x_hat.shape
    (True, True, (501, 2))
    >>> try:
    ...     observe(run, observer, [0.0, 0.0, 0.0])
    ... except DimensionError as exc:
    ...     print(type(exc).__name__, exc)
    DimensionError x_hat0: expected shape (..., 2), got (3,)
    """
    if not isinstance(run, PlantRun):
        raise InvalidArgumentError(f"run: expected a PlantRun from simulate_plant, got {type(run).__name__}")
    base = run.setup
    obs = _checked_observer(base.plant, observer, x_hat0)
    _, _, observer_discrete = _timebases(base.plant, obs, True, base.dt)
    setup = dataclasses.replace(base, truth=run.samples, **_observer_part(
        base.plant, obs, True, x_hat0, base.batch, base.groups, observer_discrete, divergence))
    return _execute(setup, RK4(), observer, progress, run.rows)


def _prepare(plant: PlantModel, observer: Observer | None, x0: ArrayLike, x_hat0: ArrayLike | None, *,
             duration: float, dt: float | None, u: InputLike, measurements: Any, input_sensors: Any,
             process_noise: ArrayLike | None, seed: Any, integrator: Integrator, save_every: int, t0: float,
             divergence: str) -> _Setup:
    """:func:`simulate`'s arguments checked and resolved into the loop's setup."""
    if not isinstance(plant, PlantModel):
        raise InvalidArgumentError(f"plant: expected a PlantModel (time, states, inputs, outputs, rhs, output), got {type(plant).__name__}")
    obs = _checked_observer(plant, observer, x_hat0)
    has_observer = observer is not None
    if not isinstance(integrator, (RK4, SolveIVP)):
        raise InvalidArgumentError(f"integrator: expected RK4() or SolveIVP(...), got {integrator!r}")
    step, plant_discrete, observer_discrete = _timebases(plant, obs, has_observer, dt)
    if isinstance(integrator, SolveIVP) and plant_discrete:
        raise InvalidArgumentError("integrator: SolveIVP applies to continuous-time plants only; a discrete plant is iterated")
    duration = positive("duration", duration)
    try:
        t0 = float(t0)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"t0: expected a number, got {t0!r}") from None
    if not math.isfinite(t0):
        raise NonFiniteError(f"t0: must be finite, got {t0!r}")
    if isinstance(save_every, bool) or not isinstance(save_every, (int, np.integer)) or save_every < 1:
        raise InvalidArgumentError(f"save_every: expected a positive integer, got {save_every!r}")
    steps_needed = duration / step
    if step > duration * (1 + 1e-12):  # one step past the end: a result at t0 + dt > t0 + duration
        raise InvalidArgumentError(f"dt: {step:g} s is longer than the duration {duration:g} s (the one step would end "
                                   "past the run); take dt at most the duration")
    if not steps_needed <= MAX_STEPS:  # also an overflow to inf
        raise InvalidArgumentError(
            f"dt: duration={duration:g} s with dt={step:g} s needs {steps_needed:.4g} steps, more than "
            f"MAX_STEPS = {MAX_STEPS:,}; use a larger dt or a shorter duration")
    t_end = abs(t0) + duration
    if step < MIN_STEP_ULPS * math.ulp(t_end):
        raise InvalidArgumentError(
            f"dt: {step:g} s is below the resolution of the times up to {t_end:g} s (one unit in the last place "
            f"is {math.ulp(t_end):.3g} s; dt must be at least {MIN_STEP_ULPS:g} of them); shift t0 or use a larger dt")
    n_steps = max(1, math.ceil(steps_needed - 1e-9))

    n = plant.n
    x0a = as_batch("x0", x0, n)
    batch = tuple(x0a.shape[:-1])
    u_fn = as_input_function(u, plant.m, batch, t0)
    groups_in = _as_tuple(measurements, MeasurementGroup, "measurements")
    groups = None if measurements is None else schedule_measurements(groups_in, plant.outputs, step)
    sensors = schedule_inputs(_as_tuple(input_sensors, InputSensor, "input_sensors"), plant.inputs, step)
    sensed = np.zeros(plant.m, dtype=bool)
    for g in sensors:
        sensed[g.index] = True
    noisy = [g.label for g in (*(groups or ()), *sensors) if g.noisy]
    q_factor = _process_factor(process_noise, n)
    if q_factor is not None:
        if isinstance(integrator, SolveIVP):
            raise InvalidArgumentError("process_noise: the adaptive SolveIVP integrator takes no process noise; use RK4()")
        noisy.append("process_noise")
    if isinstance(seed, np.random.Generator):
        rng: np.random.Generator | None = seed
    elif seed is None:
        if noisy:
            raise InvalidArgumentError(f"seed: {', '.join(noisy)} add noise; pass seed=<int> or a numpy Generator")
        rng = None
    elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
        rng = np.random.default_rng(int(seed))
    else:
        raise InvalidArgumentError(f"seed: expected an int or a numpy Generator, got {type(seed).__name__}")

    save_steps = np.arange(0, n_steps + 1, int(save_every), dtype=np.intp)
    if save_steps[-1] != n_steps:
        save_steps = np.append(save_steps, n_steps)
    setup = _Setup(
        plant=plant,
        plant_discrete=plant_discrete,
        dt=step,
        t0=t0,
        n_steps=n_steps,
        batch=batch,
        x0=x0a,
        u_fn=u_fn,
        u_hold=isinstance(u, SampledSignal) and u.kind == "hold",
        groups=groups,
        sensors=sensors,
        sensed=sensed,
        rng=rng,
        save_steps=save_steps,
        plant_names=tuple(plant.states),
        q_factor=q_factor,
        **_observer_part(plant, obs, has_observer, x_hat0, batch, groups, observer_discrete, divergence),
    )
    if isinstance(integrator, SolveIVP) and has_observer and not observer_discrete and (
            setup.self_step or not setup.array_state):
        raise InvalidArgumentError("integrator: SolveIVP integrates an observer whose state is one array and that has "
                                   "no step() of its own; use RK4() for this observer")
    return setup


def _checked_observer(plant: PlantModel, observer: Observer | None, x_hat0: ArrayLike | None) -> Any:
    """The observer to run (a stand-in without one), with ``x_hat0`` given exactly when there is one."""
    if observer is None:
        if x_hat0 is not None:
            raise InvalidArgumentError("x_hat0: given without an observer")
        return _NullObserver(plant.time)
    if not isinstance(observer, Observer):
        raise InvalidArgumentError(f"observer: expected an Observer (time, n_x, init, rhs, estimate), got {type(observer).__name__}")
    if x_hat0 is None:
        raise InvalidArgumentError("x_hat0: the initial estimate is required when an observer is simulated")
    return observer


def _observer_part(plant: PlantModel, obs: Any, has_observer: bool, x_hat0: ArrayLike | None,
                   batch: tuple[int, ...], groups: tuple[ScheduledGroup, ...] | None, observer_discrete: bool,
                   divergence: str) -> dict[str, Any]:
    """The setup's fields that belong to the observer: its initial state, names and kind, checked."""
    n_x = int(obs.n_x)
    if has_observer:
        xh = as_batch("x_hat0", x_hat0, n_x)
        try:
            xh = np.broadcast_to(xh, (*batch, n_x)).copy()
        except ValueError:
            raise DimensionError(f"x_hat0: shape {xh.shape} does not broadcast to the batch of x0, {(*batch, n_x)}") from None
        z0 = initial_state(obs, xh, batch, n_x)
    else:
        z0 = np.zeros((*batch, 0))
    correcting = has_observer and isinstance(obs, CorrectingObserver)
    if correcting and groups is None and not observer_discrete:
        raise InvalidArgumentError(
            "measurements: a correcting observer in continuous time needs measurement groups with explicit rates"
        )
    if divergence not in ("raise", "keep"):
        raise InvalidArgumentError(f"divergence: expected 'raise' or 'keep', got {divergence!r}")
    return {
        "observer": obs,
        "has_observer": has_observer,
        "correcting": correcting,
        "observer_discrete": observer_discrete,
        "z0": z0,
        "n_x": n_x,
        "observer_names": state_names(obs, z0),
        "estimate_names": tuple(plant.states) if n_x == plant.n else tuple(f"x_hat[{i}]" for i in range(n_x)),
        "self_step": has_observer and not observer_discrete and isinstance(obs, SelfStepping),
        "stages": has_observer and not observer_discrete and isinstance(obs, SelfStepping)
        and bool(getattr(getattr(obs, "program", None), "staged", False)) and hasattr(obs, "step_stages"),
        "array_state": isinstance(z0, np.ndarray),
        "diagnose": has_observer and isinstance(obs, Diagnosing),
        "deferred": has_observer and isinstance(obs, DeferredEstimate),
        "keep": divergence == "keep",
        "clock": [0.0, math.nan],
    }


def _execute(setup: _Setup, integrator: Integrator, observer: Observer | None, progress: bool | None,
             plant_rows: tuple[Array, Array, NDArray[np.bool_]] | None = None) -> SimulationResult:
    """Run the loop of a prepared setup and gather its result."""
    rec = _Recorder(setup, plant_rows)
    has_observer, batch, n_steps, plant = setup.has_observer, setup.batch, setup.n_steps, setup.plant
    wall = _time.perf_counter()
    runs = math.prod(batch)
    label = "simulating" + (f" {observer_label(observer)}" if has_observer else "") + (f", {runs} runs" if batch else "")
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"), Progress(n_steps, progress, label) as bar:
        if isinstance(integrator, SolveIVP):
            _run_ivp(setup, rec, bar, integrator.options())
        else:
            _run_fixed(setup, rec, bar)
    if setup.plant_discrete:
        method = "discrete"
    elif setup.observer_discrete:
        method = f"{integrator.name}+discrete observer"
    elif setup.self_step:
        method = f"{integrator.name}+observer step"
    else:
        method = integrator.name
    return SimulationResult(
        **rec.arrays(setup),
        states=tuple(plant.states),
        outputs=tuple(plant.outputs),
        estimates=setup.estimate_names,
        dt=setup.dt,
        method=method,
        observer=observer_label(observer) if has_observer else "",
        info={"wall_s": _time.perf_counter() - wall,
              "cost_per_step_us": 1e6 * setup.clock[0] / ((n_steps + 1) * max(1, math.prod(batch))),
              **({"diverged_at": setup.clock[1]} if setup.keep else {})},
    )


def _process_factor(process_noise: ArrayLike | None, n: int) -> Array | None:
    """``L`` with ``L Lᵀ = Q`` for the ``process_noise`` argument (``None`` when absent or zero)."""
    if process_noise is None:
        return None
    q = as_finite_array("process_noise", process_noise)
    if q.ndim == 1:
        if q.shape != (n,):
            raise DimensionError(f"process_noise: expected {n} standard deviations or an ({n}, {n}) covariance, "
                                 f"got shape {q.shape}")
        if np.any(q < 0):
            raise InvalidArgumentError(f"process_noise: standard deviations must be non-negative, got {q.tolist()}")
        q = np.diag(q**2)
    q = as_covariance("process_noise", q, n)
    if not np.any(q):
        return None
    return covariance_factor(q)


def observer_label(observer: Any) -> str:
    """An observer's ``name`` attribute when it is a string, else its class name."""
    name = getattr(observer, "name", None)
    return name if isinstance(name, str) and name else type(observer).__name__


def state_names(observer: Any, z0: Any) -> tuple[str, ...] | None:
    """The observer's ``state_names`` when they name the columns of an array state, else ``None``."""
    names = getattr(observer, "state_names", None)
    if isinstance(z0, np.ndarray) and isinstance(names, (tuple, list)) and z0.ndim >= 1 \
            and len(names) == z0.shape[-1] and all(isinstance(v, str) for v in names):
        return tuple(names)
    return None


def initial_state(obs: Any, x_hat0: Array, batch: tuple[int, ...], n_x: int) -> Any:
    """``obs.init(x_hat0)``, checked: an array state carries the batch shape, the estimate has shape ``(*batch, n_x)``."""
    z0 = obs.init(x_hat0)
    if isinstance(z0, np.ndarray) or isinstance(z0, (list, float, int)):
        z0 = np.array(z0, dtype=float)
        if z0.ndim < 1 or tuple(z0.shape[:-1]) != batch:
            raise DimensionError(f"observer.init returned shape {z0.shape}, expected {(*batch, '...')} (the batch first)")
        n_z = getattr(obs, "n_z", None)
        if isinstance(n_z, (int, np.integer)) and z0.shape[-1] != n_z:
            raise DimensionError(f"observer.init returned shape {z0.shape}, expected {(*batch, int(n_z))}")
    raw = getattr(obs, "raw_estimate", None) if isinstance(obs, DeferredEstimate) else None
    xh_check = np.asarray(raw(z0) if raw is not None else obs.estimate(z0))
    if xh_check.shape != (*batch, n_x):
        raise DimensionError(f"observer.estimate returned shape {xh_check.shape}, expected {(*batch, n_x)}")
    return z0
