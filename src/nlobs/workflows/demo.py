"""The main job: ``nlobs demo gnss-ins`` (Grip, Saberi & Johansen, Sec. 5).

Simulates a light-aircraft traffic-pattern flight with exact inertial signals,
samples the IMU (+ magnetometer) at 100 Hz and GNSS position/velocity at 5 Hz
with noise, runs the interconnected observer (24) — by default with the noise-optimal gains
(the certified K with the smallest noise-to-error H2 norm under LMI (14) at γ = 50, reached through
the certified Kalman–Bucy levels of the first seconds, :func:`~nlobs.navigation.translation_schedule.kalman_scheduled_gain`,
and the attitude gain Γ(t) = γ(t) I scheduled from 0.5 I down to the steady-state gain set by the gyro and
magnetometer noise, :func:`~nlobs.navigation.schedule.noise_scheduled_gain`) and beside it with the paper's gains and Γ = diag(20, 0.2, 0.2) — and the EKF
baseline on the same data from the same wrong initial attitude (60° in yaw by default), and
reports accuracy after convergence, convergence time and cost per step, with figures like the
paper's Figs. 4–6.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from nlobs._io import atomic_write_json, prepare_output_dir, save_figure, with_schema
from nlobs._schema import BOOLEAN, INTEGER, MATRIX, NUMBER, STRING, Record, array, enum, mapping, nullable
from nlobs.errors import InvalidArgumentError, OutputError
from nlobs.navigation.gains import NOISE_OPTIMAL_GAMMA
from nlobs.navigation.metrics import navigation_consistency, summary_dict
from nlobs.simulate.consistency import CONSISTENCY_JSON, Consistency
from nlobs.navigation.plots import plot_navigation
from nlobs.navigation.run import run_navigation
from nlobs.navigation.schedule import AttitudeGainSchedule
from nlobs.navigation.translation_schedule import GainScheduleCertificate, TranslationGainSchedule
from nlobs.navigation.sensors import generate_sensors
from nlobs.navigation.so3 import rot_z
from nlobs.navigation.trajectory import traffic_pattern
from nlobs.methods.gnss_ins import (
    ATTITUDE_GAINS,
    BACKENDS,
    DEMO_NOISE,
    GAINS,
    MAX_IMU_SAMPLES,
    DemoConfig,
    demo_ekf,
    demo_observer,
    paper_observer,
)
from nlobs.workflows.verdict import Verdict
from nlobs.simulate.result import SimulationResult
from nlobs.synthesis.mixed_h2 import MixedH2Certificate

#: What the demo's command uses, and the configuration and observer of :mod:`nlobs.methods.gnss_ins` it re-exports.
__all__ = ["ATTITUDE_GAINS", "BACKENDS", "DEMO_NOISE", "GAINS", "MAX_IMU_SAMPLES", "DemoConfig", "DemoReport",
           "demo_observer", "gnss_ins_demo"]

#: One filter's row of the demo (``observer``, ``observer_paper``, ``ekf``).
NAV_METRICS_JSON = Record("NavigationMetrics", {
    "filter": STRING, "position_rms_m": NUMBER, "velocity_rms_mps": NUMBER, "attitude_rms_deg": NUMBER,
    "converge_s": NUMBER.about("first time after which the attitude error stays below threshold_deg"),
    "cost_per_step_us": NUMBER, "skipped_fixes": INTEGER, "n_fixes": INTEGER,
    "after": NUMBER.about("the start of the RMS window when one was given (null: converge_s)"),
    "threshold_deg": NUMBER,
    "consistency": nullable(CONSISTENCY_JSON, "the EKF's NEES (its 9-dimensional error state) and the NIS of its "
                                              "GNSS fixes against the 95 % chi-square band; null for observer (24)"),
}, description="RMS errors from the filter's convergence time on (RMS over the run from converge_s).")

#: ``nlobs demo gnss-ins`` (and its ``results.json``).
DEMO_JSON = Record("DemoGnssIns", {
    "scenario": Record("DemoScenario", {
        "seed": INTEGER, "duration_s": NUMBER, "imu_rate_hz": NUMBER, "gnss_rate_hz": NUMBER,
        "yaw_error_deg": NUMBER, "converge_deg": NUMBER, "gains": STRING,
        "attitude_gain": enum("scheduled", "constant"), "translation_gain": enum("scheduled", "constant"),
        "position_only": BOOLEAN, "backend": enum("python", "c")}),
    "observer": NAV_METRICS_JSON.about("the run with the gains asked for"),
    "observer_paper": nullable(NAV_METRICS_JSON, "the paper's gains, run beside the noise-optimal gains"),
    "ekf": nullable(NAV_METRICS_JSON, "the navigation EKF (null when not run)"),
    "gain_certificate": nullable(Record("NoiseOptimalGainCertificate", {
        "verified": BOOLEAN, "gamma": NUMBER, "hinf_H": NUMBER, "h2": NUMBER.about("noise-to-error H2 norm"),
        "h2_kalman": NUMBER.about("the Kalman-Bucy infimum"), "gain_per_axis": MATRIX,
        "attitude_gain": array(NUMBER, "the diagonal of Gamma (the first one when scheduled)"),
        "attitude_gain_schedule": nullable(Record("AttitudeGainSchedule", {
            "gains": array(MATRIX, "the 3x3 Gamma of every mode"), "times_s": array(NUMBER)})),
        "translation_gain_schedule": nullable(Record("TranslationGainSchedule", {
            "gains_per_axis": array(MATRIX), "times_s": array(NUMBER), "verified": BOOLEAN, "growth": NUMBER,
            "modes_hinf_H": array(NUMBER)})),
        "failed_checks": array(STRING),
    }), "for the noise-optimal gains, per axis"),
    "figures": mapping(STRING, "the figures written, by name"),
}, description="The GNSS/INS demo: observer (24) of Grip, Saberi & Johansen against the navigation EKF.")


@dataclass(frozen=True)
class DemoResult:
    """What the demo computed: one :class:`~nlobs.simulate.SimulationResult` per filter, and the figures.

    Their navigation metrics are the functions of :mod:`nlobs.navigation.metrics`; ``ekf_consistency`` is the
    EKF's NEES and NIS (:func:`~nlobs.navigation.metrics.navigation_consistency`, ``None`` without the EKF).
    """

    config: DemoConfig
    observer: SimulationResult
    ekf: SimulationResult | None
    figures: dict[str, Path]
    flight_duration: float
    observer_paper: SimulationResult | None = None
    certificate: MixedH2Certificate | None = None
    schedule: AttitudeGainSchedule | None = None
    gain_schedule: GainScheduleCertificate | None = None
    observer_gain_schedule: TranslationGainSchedule | None = None
    ekf_consistency: Consistency | None = None

    def metrics(self, which: str) -> dict[str, Any]:
        """The table row of ``"observer"``, ``"observer_paper"`` or ``"ekf"`` (RMS after that filter's own
        convergence; the EKF's with its NEES and NIS, :func:`~nlobs.navigation.metrics.navigation_consistency`)."""
        res = {"observer": self.observer, "observer_paper": self.observer_paper, "ekf": self.ekf}.get(which)
        if res is None:
            raise InvalidArgumentError(f"no result for {which!r}")
        cons = self.ekf_consistency if which == "ekf" else None
        return NAV_METRICS_JSON.emit({**summary_dict(res, threshold_deg=self.config.converge_deg),
                                      "consistency": None if cons is None else cons.to_dict()})

    def to_dict(self) -> dict[str, Any]:
        """Stable JSON form: ``observer`` and ``ekf`` objects (see the README) plus the setup."""
        c = self.config
        return DEMO_JSON.emit({
            "scenario": {
                "seed": c.seed,
                "duration_s": self.flight_duration,
                "imu_rate_hz": c.imu_rate_hz,
                "gnss_rate_hz": c.gnss_rate_hz,
                "yaw_error_deg": c.yaw_error_deg,
                "converge_deg": c.converge_deg,
                "gains": c.gains,
                "attitude_gain": "scheduled" if c.scheduled else "constant",
                "translation_gain": "scheduled" if c.translation_scheduled else "constant",
                "position_only": c.position_only,
                "backend": c.backend,
            },
            "observer": self.metrics("observer"),
            "observer_paper": None if self.observer_paper is None else self.metrics("observer_paper"),
            "ekf": None if self.ekf is None else self.metrics("ekf"),
            "gain_certificate": None if self.certificate is None else _certificate_dict(
                self.certificate, self.schedule, self.observer_gain_schedule, self.gain_schedule),
            "figures": {k: str(v) for k, v in self.figures.items()},
        })


def _certificate_dict(c: MixedH2Certificate, schedule: AttitudeGainSchedule | None,
                      ks: TranslationGainSchedule | None, ks_cert: GainScheduleCertificate | None) -> dict[str, Any]:
    """The JSON summary of the noise-optimal gain's certificate (per axis) and of its attitude and translational gains.

    ``attitude_gain`` is the diagonal of the (first) Γ; ``attitude_gain_schedule`` the whole
    schedule (``None`` for a constant Γ); ``translation_gain_schedule`` the per-axis ``K`` of each
    mode with its switch times, the modes' LMI (14) verdicts and the switching growth (``None`` for a
    constant ``K``).
    """
    kd: dict[str, Any] | None = None
    if ks is not None and ks_cert is not None:
        kd = {**ks.to_dict(), "verified": ks_cert.verified, "growth": ks_cert.growth,
              "modes_hinf_H": [m.hinf_H for m in ks_cert.modes]}
    G0 = NOISE_OPTIMAL_GAMMA if schedule is None else schedule.gains[0]
    return {"verified": c.verified, "gamma": c.gamma, "hinf_H": c.hinf_H, "h2": c.h2, "h2_kalman": c.h2_kalman,
            "gain_per_axis": np.asarray(c.gain).tolist(), "attitude_gain": np.diag(G0).tolist(),
            "attitude_gain_schedule": None if schedule is None else schedule.to_dict(),
            "translation_gain_schedule": kd,
            "failed_checks": [ch.name for ch in c.failed_checks]}


def run_demo(config: DemoConfig = DemoConfig(), out_dir: str | Path | None = None, *,
             progress: bool = False) -> DemoResult:
    """Run the GNSS/INS demo (see the module docstring) and write figures into ``out_dir``."""
    flight = traffic_pattern(seed=config.seed, duration=config.duration)
    traj = flight.sample(config.imu_rate_hz)
    data = generate_sensors(traj, imu_rate_hz=config.imu_rate_hz, gnss_rate_hz=config.gnss_rate_hz,
                            noise=config.noise, seed=config.seed, position_only=config.position_only)
    observer, cert, schedule, gain_cert = demo_observer(config, flight, float(traj.t[0]))
    R0 = rot_z(np.deg2rad(config.yaw_error_deg)) @ traj.R[0]
    p0 = data.p_gnss[0] if np.all(np.isfinite(data.p_gnss[0])) else traj.p[0]
    v0 = data.v_gnss[0] if data.v_gnss is not None and np.all(np.isfinite(data.v_gnss[0])) else np.zeros(3)
    run = _backend(config)
    obs_res = run_navigation(run(observer), data, p0, v0, R0, progress=progress)
    paper_res = None
    if config.gains == "noise-optimal":
        paper_res = run_navigation(run(paper_observer(config, flight)), data, p0, v0, R0, progress=progress)
    ekf_res, ekf_cons = None, None
    if config.ekf:
        # P for the NEES in Python; the generated C keeps its one call per record (its state carries no NIS)
        ekf = dataclasses.replace(demo_ekf(config, flight), record_covariance=config.backend == "python")
        ekf_res = run_navigation(ekf if config.backend == "python" else _compiled(ekf), data, p0, v0, R0,
                                 progress=progress)
        ekf_cons = navigation_consistency(ekf_res, data)
        ekf_res = dataclasses.replace(ekf_res, extras={k: v for k, v in ekf_res.extras.items() if k != "P"})
    figures: dict[str, Path] = {}
    if out_dir is not None:
        others = [(r, name) for r, name in ((ekf_res, "EKF"), (paper_res, "observer, the paper's gains"))
                  if r is not None]
        figures = plot_navigation(obs_res, Path(out_dir), compare=[r for r, _ in others], prefix="gnss_ins",
                                  labels=(_label(config), *(name for _, name in others)))
        if ekf_cons is not None and ekf_cons.runs:
            from nlobs.workflows.compare_output import consistency_plot

            fig = consistency_plot({"EKF": ekf_cons}, title="GNSS/INS demo, the navigation EKF: consistency",
                                   time_unit="s", styles={"EKF": {"color": "C2"}})
            figures["consistency"] = save_figure(fig, Path(out_dir) / "gnss_ins_consistency.png")
    return DemoResult(config, obs_res, ekf_res, figures, float(traj.t[-1]), observer_paper=paper_res,
                      certificate=cert, schedule=schedule, gain_schedule=gain_cert,
                      observer_gain_schedule=getattr(observer, "gain_schedule", None), ekf_consistency=ekf_cons)


def _backend(config: DemoConfig) -> Any:
    """The observer as it runs: itself, or its generated C for the demo's IMU period (``backend="c"``)."""
    if config.backend == "python":
        return lambda obs: obs
    from nlobs.export import compile_observer

    return lambda obs: compile_observer(obs, options={"imu_period": 1.0 / config.imu_rate_hz})


def _compiled(ekf: Any) -> Any:
    """The EKF baseline as its generated, compiled C (``backend="c"``)."""
    from nlobs.export import compile_observer

    return compile_observer(ekf)


_LABELS = {"noise-optimal": "observer, noise-optimal gains", "paper": "observer, paper's gains",
           "designed": "observer, central LMI gains"}


def _label(config: DemoConfig) -> str:
    """The observer's label in the table and the figures."""
    constant = [w for w, sched in (("Γ", config.scheduled), ("K", config.translation_scheduled)) if not sched]
    if config.gains == "noise-optimal" and constant:
        return "observer, noise-optimal gains, constant " + " and ".join(constant)
    return _LABELS[config.gains]


def write_json(result: DemoResult, path: str | Path) -> Path:
    """Write ``result.to_dict()`` as JSON (NaN metrics as ``null``), atomically."""
    return atomic_write_json(path, with_schema(result.to_dict()))


#: The rows of the comparison table: label, key of :func:`~nlobs.navigation.metrics.summary_dict`, format.
TABLE_ROWS = (("position RMS after convergence [m]", "position_rms_m", "{:.3f}"),
              ("velocity RMS after convergence [m/s]", "velocity_rms_mps", "{:.3f}"),
              ("attitude RMS after convergence [deg]", "attitude_rms_deg", "{:.3f}"),
              ("time to converge below {converge_deg:g}° [s]", "converge_s", "{:.2f}"),
              ("cost per step [µs]", "cost_per_step_us", "{:.1f}"))


@dataclass(frozen=True, eq=False)
class DemoReport:
    """What ``nlobs demo gnss-ins`` prints: the comparison table and the files it wrote.

    Attributes
    ----------
    result : DemoResult
    files : tuple of Path
        The figures and ``results.json``.
    verdict : Verdict
        Always ``OK`` (the demo reports what it measured).
    message : str

    Examples
    --------
    A 5 s demo with the paper's gains and the EKF beside it, without files: the comparison table (its title,
    columns and the row of the times to converge; the cost row is a measured time), and the JSON report:

    >>> rep = gnss_ins_demo(DemoConfig(duration=5.0, gains="paper", ekf=True), out=None)
    >>> title, heads, rows = rep.table()
    >>> title
    'GNSS/INS, 5 s flight, 60° initial yaw error, IMU 100 Hz, GNSS 5 Hz, seed 0'
    >>> heads, rows[3]
    (('quantity', "observer, paper's gains", 'EKF'), ('time to converge below 5° [s]', '3.41', '2.40'))
    >>> rep.verdict.value, rep.files, rep.consistency_line().startswith("EKF consistency: NEES inside")
    ('ok', (), True)
    >>> data = rep.to_dict()
    >>> data["scenario"]["gains"], data["ekf"]["filter"], data["ekf"]["n_fixes"], data["observer_paper"]
    ('paper', 'ekf', 26, None)
    """

    result: DemoResult
    files: tuple[Path, ...]
    verdict: Verdict = Verdict.OK
    message: str = ""

    def to_dict(self) -> dict[str, Any]:
        """The JSON report (the same as ``results.json``)."""
        return self.result.to_dict()

    def table(self) -> tuple[str, tuple[str, ...], tuple[tuple[str, ...], ...]]:
        """``(title, column headers, rows)`` of the comparison table."""
        r, c = self.result, self.result.config
        filters = (["observer"] + (["observer_paper"] if r.observer_paper is not None else [])
                   + (["ekf"] if r.ekf is not None else []))
        title = (f"GNSS/INS, {r.flight_duration:.0f} s flight, {c.yaw_error_deg:g}° initial yaw error, IMU "
                 f"{c.imu_rate_hz:g} Hz, GNSS {c.gnss_rate_hz:g} Hz, seed {c.seed}")
        names = {"observer": _label(c), "observer_paper": _LABELS["paper"], "ekf": "EKF"}
        heads = ("quantity", *(names[f] for f in filters))
        metrics = {f: r.metrics(f) for f in filters}
        rows = tuple((label.format(converge_deg=c.converge_deg), *(fmt.format(metrics[f][key]) for f in filters))
                     for label, key, fmt in TABLE_ROWS)
        return title, heads, rows

    def summary(self) -> str:
        """The table as plain text, then the files written."""
        title, heads, rows = self.table()
        widths = [max(len(h), *(len(row[i]) for row in rows)) for i, h in enumerate(heads)]
        lines = [title, "  ".join(h.ljust(w) if i == 0 else h.rjust(w) for i, (h, w) in enumerate(zip(heads, widths)))]
        lines += ["  ".join(v.ljust(w) if i == 0 else v.rjust(w) for i, (v, w) in enumerate(zip(row, widths)))
                  for row in rows]
        consistency = self.consistency_line()
        return "\n".join(lines + ([consistency] if consistency else []) + [f"wrote {f}" for f in self.files])

    def consistency_line(self) -> str:
        """One line on the EKF's consistency (its NEES and NIS against the 95 % χ² band), or ``""``."""
        c = self.result.ekf_consistency
        if c is None or not c.runs:
            return ""
        d = c.to_dict()
        nees = ("" if d["nees_inside"] is None else
                f"NEES inside the {c.level:.0%} χ² band {d['nees_inside']:.0%} of the time (mean {d['nees_mean']:.2f})")
        nis = ("" if d["nis_inside"] is None else
               f"NIS at the GNSS fixes {d['nis_inside']:.0%} (mean {d['nis_mean']:.2f})")
        return "EKF consistency: " + ", ".join(p for p in (nees, nis) if p) + " (about 95 % and 1 when its " \
               "covariance describes its error)"


def gnss_ins_demo(config: DemoConfig = DemoConfig(), out: str | Path | None = Path("out/gnss-ins"), *,
                  progress: bool | None = None) -> DemoReport:
    """The workflow of ``nlobs demo gnss-ins``: :func:`run_demo`, then the figures and ``results.json`` in ``out``.

    Parameters
    ----------
    config : DemoConfig
        The flight, sensors, gains and options.
    out : str or Path, optional
        Folder for the figures and ``results.json`` (``None``: none written).
    progress : bool, optional
        Progress bars on stderr.

    Returns
    -------
    DemoReport
        The comparison table and the files written.

    Raises
    ------
    OutputError
        ``out`` cannot be written (an existing file, read-only, a full disk); nothing is left half-written.
    NlobsError
        A typed error of the simulation or the design.

    Examples
    --------
    Five seconds of the flight with the gains of Grip, Saberi & Johansen, Sec. 5.2, in observer (24), without
    the EKF and without files (give a folder as ``out`` for the figures and ``results.json``): the 60° initial
    yaw error falls below 5° after about 3.4 s, from the 26 GNSS fixes of the flight:

    >>> rep = gnss_ins_demo(DemoConfig(duration=5.0, gains="paper", ekf=False), out=None)
    >>> rep.files, rep.table()[1]
    ((), ('quantity', "observer, paper's gains"))
    >>> obs = rep.to_dict()["observer"]
    >>> round(obs["converge_s"], 1), obs["n_fixes"]
    (3.4, 26)
    >>> rep.result.observer.x_hat.shape  # one SimulationResult per filter, on the IMU's 100 Hz grid
    (501, 15)
    """
    folder = None if out is None else Path(out)
    if folder is not None:
        try:
            prepare_output_dir(folder)
        except OSError as exc:
            raise OutputError(f"`out` {folder}: {exc.strerror or exc}") from exc
    try:
        result = run_demo(config, folder, progress=bool(progress))
        files = list(result.figures.values())
        if folder is not None:
            files.append(write_json(result, folder / "results.json"))
    except OSError as exc:
        raise OutputError(f"`out` {folder}: {exc.strerror or exc}") from exc
    return DemoReport(result, tuple(files))
