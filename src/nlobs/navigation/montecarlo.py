"""Monte Carlo flights of the GNSS/INS observer (24) of Grip, Saberi & Johansen: a study for ``monte_carlo``.

A study of :func:`nlobs.simulate.monte_carlo`.

:class:`GnssInsStudy` is a small recipe (plain values). :meth:`GnssInsStudy.prepare` builds, once per
process, the flight (the demo's traffic pattern, :func:`~nlobs.navigation.trajectory.traffic_pattern`,
sampled at the IMU rate), the gains and the observer (24): the paper's ``K`` and
``Γ = diag(20, 0.2, 0.2)`` (Sec. 5.2), or the noise-optimal ``K`` (the smallest noise-to-error H2 norm
under LMI (14) at ``γ = 50``, :func:`~nlobs.navigation.gains.noise_optimal_gains`, refused unless its
certificate is verified) with ``Γ = 0.5 I`` or with the scheduled ``Γ(t)`` of
:func:`~nlobs.navigation.schedule.noise_scheduled_gain`. An SDP solver's answer may differ in its last bits from one
process to another (BLAS threads, CPU), so :meth:`GnssInsStudy.solved` solves the noise-optimal gain
once, where the study is made, and puts it in the recipe (``axis_gain``); :meth:`~GnssInsStudy.prepare`
then only re-verifies it (:func:`~nlobs.synthesis.verify_h2_gain`), and every worker flies the same gain.
:meth:`GnssInsStudy.run` computes one batch of flights, every random number from the batch's generator, in this order:

1. the sensor noise of every flight, :func:`~nlobs.navigation.sensors.generate_sensors` with
   ``seed=rng, batch=runs``;
2. the initial attitude error: a unit axis ``rng.normal(size=(runs, 3))`` normalised, an angle
   ``rng.uniform(0, attitude_error_deg, size=(runs, 1))`` (degrees), ``R̂₀ = exp(S(axis·angle)) R₀``;
3. the initial position error: a direction ``rng.normal(size=(runs, 3))`` normalised (drawn also when
   ``position_error_m`` is 0), ``p̂₀ = p₀ + position_error_m · direction``;

the initial velocity estimate is each flight's first GNSS velocity fix (as in the demo). The flights
run through :func:`~nlobs.navigation.run.run_navigation`, all of a batch on its batch axis.

No certificate monitor exists for observer (24) (its guarantee, Theorems 1–3 with Lemma 1, is global:
no region or input bound to check along a run), so the summaries carry no ``covered`` flag.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from nlobs._typing import Array
from nlobs._validate import as_count, as_finite_array, in_range, positive
from nlobs.errors import DesignInfeasible, InvalidArgumentError, SimulationDiverged
from nlobs.navigation.base import GNSS_OUTPUTS, GNSS_OUTPUTS_P, NAV_STATES, SensorData, nav_vector
from nlobs.navigation.gains import (
    NOISE_OPTIMAL_GAMMA,
    PAPER_GAMMA,
    PAPER_GAMMA_HINF,
    axis_gain,
    axis_noise_model,
    axis_system,
    kron_gain,
    noise_optimal_gains,
    paper_gains,
)
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation import metrics
from nlobs.navigation.run import run_navigation
from nlobs.navigation.schedule import ScheduledGnssInsObserver, noise_scheduled_gain
from nlobs.navigation.sensors import SensorNoise, generate_sensors
from nlobs.navigation.so3 import exp_so3
from nlobs.navigation.trajectory import Trajectory, traffic_pattern
from nlobs.simulate.replay import run_observer
from nlobs.simulate.result import SimulationResult

__all__ = ["GAINS", "GnssInsStudy", "PreparedFlight", "SUMMARIES"]

#: The gain choices: the paper's ``K`` and Γ; the noise-optimal ``K`` with Γ = 0.5 I; the same with Γ(t) scheduled.
GAINS = ("paper", "noise-optimal", "scheduled")

#: The per-flight summaries of a batch, each of shape ``(runs,)``.
SUMMARIES = ("final_attitude_error_deg", "converged", "converge_s", "rms_position_m", "rms_velocity_mps",
             "rms_attitude_deg", "diverged")

#: The longest flight, in IMU samples (a batch holds ``runs ×`` this many samples of ~50 numbers each).
MAX_IMU_SAMPLES = 2e6


@dataclass(frozen=True)
class PreparedFlight:
    """What :meth:`GnssInsStudy.prepare` builds once per process: the sampled flight and the observer.

    Attributes
    ----------
    traj : Trajectory
        The flight on the IMU grid (the truth of every run).
    observer : GnssInsObserver or ScheduledGnssInsObserver
        Observer (24) with the study's gains.
    gain_description : str
        The gains in words (``K`` and Γ).
    """

    traj: Trajectory
    observer: GnssInsObserver | ScheduledGnssInsObserver
    gain_description: str


@dataclass(frozen=True)
class GnssInsStudy:
    """Monte Carlo flights of observer (24) (Grip, Saberi & Johansen) on the demo's traffic pattern.

    A :class:`~nlobs.simulate.montecarlo.Study` for :func:`~nlobs.simulate.monte_carlo`: every flight
    of a batch flies the same trajectory with its own sensor noise and its own initial errors, drawn
    from the batch's generator (module docstring).

    Parameters
    ----------
    noise : SensorNoise
        The sensors' error model (``nlobs.workflows.demo.DEMO_NOISE`` in the workflow).
    duration : float
        Flight length [s] (the traffic pattern cut there; default 60).
    flight_seed : int
        Seed of :func:`~nlobs.navigation.trajectory.traffic_pattern` (the same flight in every run).
    imu_rate_hz, gnss_rate_hz : float
        Sensor rates [Hz] (the paper's 100 and 5; their ratio an integer).
    gains : {"paper", "noise-optimal", "scheduled"}
        The paper's ``K`` and ``Γ = diag(20, 0.2, 0.2)``; the noise-optimal ``K`` with ``Γ = 0.5 I``;
        the noise-optimal ``K`` with ``Γ(t)`` scheduled from ``0.5 I`` (as ``benchmarks/gnss_ins_global.py``).
    attitude_error_deg : float
        Largest initial attitude error [deg], in ``[0, 180]``: a rotation about a uniformly random axis
        by an angle uniform in ``[0, attitude_error_deg]``.
    position_error_m : float
        Initial position error [m] (``>= 0``), in a uniformly random direction.
    converge_deg : float
        Attitude-error threshold [deg] of convergence (:func:`~nlobs.navigation.metrics.converge_s`).
    tail_s : float, optional
        The RMS errors are taken over the last ``tail_s`` seconds (default ``min(30, duration / 2)``).
    trajectory_every : int
        With trajectories, every ``trajectory_every``-th IMU sample is kept (default 10: 10 Hz at 100 Hz),
        so that a record is ``(runs, ⌈K / trajectory_every⌉, 15)``; the times are ``t[::trajectory_every]``.
    default_batch : int
        Flights computed together (and drawn from one generator) unless :func:`monte_carlo` is told otherwise.
    axis_gain : tuple of tuple of float, optional
        The per-axis noise-optimal gain ``K3`` (3×2: rows ``p, v, z``, columns ``p, v``; ``K = kron(K3, I3)``)
        for ``gains`` ``"noise-optimal"`` and ``"scheduled"``; ``None``: :meth:`prepare` solves it. An SDP
        solver's answer can differ in its last bits between processes (the BLAS threads, the CPU), so
        for numbers that are the same on every worker solve it once where the study is made,
        :meth:`solved`, and send it with the recipe; :meth:`prepare` re-verifies a given gain.

    Raises
    ------
    InvalidArgumentError
        A value out of range, or an unknown ``gains``.

    Examples
    --------
    Four flights of the first 5 s of the traffic pattern with the paper's gains, each from an attitude error
    up to 60° about a random axis and a 10 m position error. :meth:`prepare` builds the flight and the
    observer, :meth:`initial_errors` draws the errors (a rotation by exactly the drawn angle), and
    :func:`~nlobs.simulate.monte_carlo` flies the batch and returns one summary per flight:

    >>> import numpy as np
    >>> from nlobs.navigation.so3 import angle_between
    >>> from nlobs.simulate import monte_carlo
    >>> noise = SensorNoise(gyro_std=0.002, accel_std=0.05, mag_std=0.01, gnss_p_std=1.5, gnss_v_std=0.1)
    >>> study = GnssInsStudy(noise, duration=5.0, gains="paper", attitude_error_deg=60.0, position_error_m=10.0)
    >>> study.name, study.tail
    ('GNSS/INS observer (24), paper gains', 2.5)
    >>> prepared = study.prepare()
    >>> prepared.traj.t.shape, prepared.gain_description
    ((501,), "the paper's K and Γ = diag(20, 0.2, 0.2)")
    >>> R0, p0, angle = study.initial_errors(np.random.default_rng(0), 4, prepared.traj)
    >>> bool(np.all(angle <= 60.0)), bool(np.allclose(np.degrees(angle_between(R0, prepared.traj.R[0])), angle))
    (True, True)
    >>> np.round(np.linalg.norm(p0 - prepared.traj.p[0], axis=-1), 9).tolist()
    [10.0, 10.0, 10.0, 10.0]
    >>> result = monte_carlo(study, 4, seed=0, batch=4, progress=False)
    >>> sorted(result.summaries) == sorted(SUMMARIES), result.summaries["final_attitude_error_deg"].shape
    (True, (4,))
    >>> bool(result.summaries["diverged"].any())
    False
    """

    noise: SensorNoise
    duration: float = 60.0
    flight_seed: int = 0
    imu_rate_hz: float = 100.0
    gnss_rate_hz: float = 5.0
    gains: str = "scheduled"
    attitude_error_deg: float = 90.0
    position_error_m: float = 0.0
    converge_deg: float = 5.0
    tail_s: float | None = None
    trajectory_every: int = 10
    default_batch: int = 100
    axis_gain: tuple[tuple[float, ...], ...] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.noise, SensorNoise):
            raise InvalidArgumentError(f"noise: expected a SensorNoise, got {type(self.noise).__name__}")
        d = positive("`duration`", self.duration)
        rate = positive("imu_rate_hz", self.imu_rate_hz)
        positive("gnss_rate_hz", self.gnss_rate_hz)
        if d * rate > MAX_IMU_SAMPLES:
            raise InvalidArgumentError(f"`duration`: {d:g} s at {rate:g} Hz is {d * rate:.3g} IMU samples; "
                                       f"at most {MAX_IMU_SAMPLES:.0e}")
        as_count("flight_seed", self.flight_seed)
        if self.gains not in GAINS:
            raise InvalidArgumentError(f"`gains`: expected one of {', '.join(map(repr, GAINS))}, got {self.gains!r}")
        in_range("`attitude_error_deg`", self.attitude_error_deg, 0.0, 180.0, hi_open=False)
        positive("`position_error_m`", self.position_error_m, allow_zero=True)
        if not math.isfinite(self.position_error_m):
            raise InvalidArgumentError(f"`position_error_m`: must be finite, got {self.position_error_m!r}")
        positive("converge_deg", self.converge_deg)
        if self.tail_s is not None:
            tail = positive("tail_s", self.tail_s)
            if tail > d:
                raise InvalidArgumentError(f"tail_s: {tail:g} s is longer than the flight ({d:g} s)")
        as_count("trajectory_every", self.trajectory_every, minimum=1)
        as_count("default_batch", self.default_batch, minimum=1)
        if self.axis_gain is not None:
            if self.gains == "paper":
                raise InvalidArgumentError("axis_gain: the paper's gains are fixed (Sec. 5.2); give it with "
                                           "gains 'noise-optimal' or 'scheduled'")
            K3 = as_finite_array("axis_gain", self.axis_gain, ndim=2)
            if K3.shape != (3, 2):
                raise InvalidArgumentError(f"axis_gain: expected a 3×2 per-axis gain, got shape {K3.shape}")
            object.__setattr__(self, "axis_gain", tuple(tuple(float(v) for v in row) for row in K3))

    # ------------------------------------------------------------------ Study protocol
    @property
    def name(self) -> str:
        """``"GNSS/INS observer (24), <gains> gains"``."""
        return f"GNSS/INS observer (24), {self.gains} gains"

    @property
    def tail(self) -> float:
        """The window of the RMS errors [s]: ``tail_s``, or ``min(30, duration / 2)``."""
        return float(self.tail_s) if self.tail_s is not None else min(30.0, float(self.duration) / 2.0)

    def key(self) -> str:
        """Every recipe field (the noise model's too), as text."""
        parts = []
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "noise":
                value = ",".join(f"{g.name}={getattr(value, g.name)!r}" for g in fields(value))
            elif f.name == "tail_s":
                value = repr(self.tail)
            else:
                value = repr(value)
            parts.append(f"{f.name}={value}")
        return "gnss-ins|" + "|".join(parts)

    def solved(self) -> GnssInsStudy:
        """This recipe with the noise-optimal per-axis gain solved (and verified) here, in ``axis_gain``.

        The paper's gains, or a gain already given: the recipe itself.

        Raises
        ------
        DesignInfeasible
            The noise-optimal gain failed its certificate.
        """
        if self.gains == "paper" or self.axis_gain is not None:
            return self
        K = self._noise_optimal()
        return replace(self, axis_gain=tuple(tuple(float(v) for v in row) for row in axis_gain(K)))

    def _noise_optimal(self) -> Array:
        """``K = kron(K3, I3)`` of the noise-optimal gain: ``axis_gain`` re-verified, or solved; certified."""
        rates = {"imu_rate_hz": float(self.imu_rate_hz), "gnss_rate_hz": float(self.gnss_rate_hz)}
        if self.axis_gain is None:
            K, cert = noise_optimal_gains(self.noise, **rates)
        else:
            from nlobs.synthesis import verify_h2_gain

            A, Bd, C = axis_system(False)
            K3 = np.array(self.axis_gain, dtype=float)
            cert = verify_h2_gain(A, C, Bd, K3, gamma=PAPER_GAMMA_HINF, noise=axis_noise_model(self.noise, **rates))
            K = kron_gain(K3)
        if not cert.verified:  # never run an uncertified gain under this name
            raise DesignInfeasible("the noise-optimal gain failed its certificate: "
                                   + ", ".join(ch.name for ch in cert.failed_checks), constraint="certificate")
        return K

    def prepare(self) -> PreparedFlight:
        """The flight on the IMU grid and observer (24) with the study's gains (deterministic given ``axis_gain``).

        Raises
        ------
        DesignInfeasible
            The noise-optimal gain (solved, or given in ``axis_gain``) failed its certificate.
        """
        flight = traffic_pattern(seed=int(self.flight_seed), duration=float(self.duration))
        traj = flight.sample(float(self.imu_rate_hz))
        observer: GnssInsObserver | ScheduledGnssInsObserver
        if self.gains == "paper":
            observer = GnssInsObserver(paper_gains(), PAPER_GAMMA, flight.m_n, flight.g_n)
            what = "the paper's K and Γ = diag(20, 0.2, 0.2)"
        else:
            K = self._noise_optimal()
            observer = GnssInsObserver(K, NOISE_OPTIMAL_GAMMA, flight.m_n, flight.g_n)
            what = "the noise-optimal K (certified) and Γ = 0.5 I"
            if self.gains == "scheduled":
                schedule = noise_scheduled_gain(self.noise, flight.m_n, flight.g_n,
                                                initial=float(NOISE_OPTIMAL_GAMMA[0, 0]), start_s=float(traj.t[0]))
                observer = ScheduledGnssInsObserver(observer, schedule)
                what = f"the noise-optimal K (certified) and {schedule.describe()}"
        return PreparedFlight(traj, observer, what)

    def initial_errors(self, rng: np.random.Generator, runs: int, traj: Trajectory) -> tuple[Array, Array, Array]:
        """``(R̂₀, p̂₀, angle_deg)`` of ``runs`` flights from ``rng`` (steps 2 and 3 of the module docstring)."""
        axis = rng.normal(size=(runs, 3))
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        angle = rng.uniform(0.0, float(self.attitude_error_deg), size=(runs, 1))
        R0 = exp_so3(axis * np.deg2rad(angle)) @ traj.R[0]
        d = rng.normal(size=(runs, 3))
        p0 = traj.p[0] + float(self.position_error_m) * d / np.linalg.norm(d, axis=-1, keepdims=True)
        return R0, p0, angle[:, 0]

    def run(self, prepared: PreparedFlight, rng: np.random.Generator, runs: int, trajectories: bool) -> Any:
        """``runs`` flights, every random number from ``rng``: the summaries of :data:`SUMMARIES` per flight.

        With ``trajectories``: ``x_hat`` (the estimate ``[p̂, v̂, R̂]``) and ``x`` (the truth, the same
        flight in every run), each ``(runs, ⌈K / trajectory_every⌉, 15)``.
        """
        from nlobs.simulate.montecarlo import RunBatch

        traj = prepared.traj
        data = generate_sensors(traj, imu_rate_hz=float(self.imu_rate_hz), gnss_rate_hz=float(self.gnss_rate_hz),
                                noise=self.noise, seed=rng, batch=runs)
        R0, p0, _ = self.initial_errors(rng, runs, traj)
        v0 = data.v_gnss[:, 0]  # type: ignore[index]
        res = _fly(prepared.observer, data, p0, v0, R0)
        summ = self.summaries(res)
        traj_out: dict[str, Array] = {}
        if trajectories:
            every = int(self.trajectory_every)
            truth = np.asarray(res.x)[::every]
            traj_out = {"x_hat": np.ascontiguousarray(res.x_hat[:, ::every]),
                        "x": np.ascontiguousarray(np.broadcast_to(truth, (runs, *truth.shape)))}
        return RunBatch(summ, traj_out)

    def summaries(self, res: SimulationResult) -> dict[str, Array]:
        """The per-flight summaries of a navigation run of a batch of flights (:data:`SUMMARIES`)."""
        diverged = ~np.isfinite(res.x_hat).all(axis=(-2, -1))
        err = metrics.attitude_error_deg(res)
        conv = metrics.converge_s(res, float(self.converge_deg))
        conv = np.where(diverged, np.nan, conv)  # a NaN error is never below the threshold
        after = float(res.t[-1]) - self.tail
        return {
            "final_attitude_error_deg": np.asarray(err[..., -1], dtype=float),
            "converged": np.isfinite(conv),
            "converge_s": np.asarray(conv, dtype=float),
            "rms_position_m": np.asarray(metrics.position_rms_m(res, after=after), dtype=float),
            "rms_velocity_mps": np.asarray(metrics.velocity_rms_mps(res, after=after), dtype=float),
            "rms_attitude_deg": np.asarray(metrics.attitude_rms_deg(res, after=after), dtype=float),
            "diverged": diverged,
        }


def _fly(observer: Any, data: SensorData, p0: Array, v0: Array, R0: Array) -> SimulationResult:
    """:func:`run_navigation`; if a flight diverges, the same run again keeping the non-finite values.

    A divergence stops :func:`run_navigation`; the study then reruns the batch through
    :func:`~nlobs.simulate.run_observer` with ``divergence="keep"`` (the same call as
    :func:`run_navigation` makes), so that a diverged flight is counted, not fatal.
    """
    try:
        return run_navigation(observer, data, p0, v0, R0)
    except SimulationDiverged:
        t = np.asarray(data.t_imu, dtype=float)
        gidx = np.rint((np.asarray(data.t_gnss) - t[0]) * float(data.imu_rate_hz)).astype(np.intp)
        return run_observer(observer, t, x_hat0=nav_vector(p0, v0, R0), u=data.imu_input(), y=data.gnss_output(),
                            y_times=t[gidx], truth=data.truth(), states=NAV_STATES, estimates=NAV_STATES,
                            outputs=GNSS_OUTPUTS_P if data.v_gnss is None else GNSS_OUTPUTS, progress=False,
                            divergence="keep")
