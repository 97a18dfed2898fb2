r"""The GNSS/INS observer (24) of Grip, Saberi & Johansen (Sec. 5) as a method: the demo's configuration and observer.

:class:`DemoConfig` holds the options of the GNSS/INS example (gains, attitude gain, sensor rates and
noise); :func:`demo_observer` builds its observer (24) — by default with the certified gain of the
smallest noise-to-error H2 norm under LMI (14) at γ = 50, reached through the Kalman–Bucy levels of
the first seconds (:func:`~nlobs.navigation.translation_schedule.kalman_scheduled_gain`, every level
certified by LMI (14)), and the attitude gain Γ(t) scheduled from the sensor noise
(:func:`~nlobs.navigation.schedule.noise_scheduled_gain`). :data:`GNSS_INS` is the
method of the registry: the demo's observer, exported as ``observer="gnss-ins"`` (``nlobs export``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nlobs._validate import in_range, positive
from nlobs.errors import DesignInfeasible, InvalidArgumentError
from nlobs.navigation.gains import NOISE_OPTIMAL_GAMMA, PAPER_GAMMA, design_gains, noise_optimal_gains, paper_gains
from nlobs.navigation.gnss_ins import GnssInsObserver
from nlobs.navigation.schedule import AttitudeGainSchedule, ScheduledGnssInsObserver, noise_scheduled_gain
from nlobs.navigation.sensors import SensorNoise
from nlobs.navigation.translation_schedule import GainScheduleCertificate, certify_gain_schedule, kalman_scheduled_gain
from nlobs.synthesis.mixed_h2 import MixedH2Certificate

__all__ = ["ATTITUDE_GAINS", "BACKENDS", "DEMO_NOISE", "GAINS", "GNSS_INS", "MAX_IMU_SAMPLES", "TRANSLATION_GAINS",
           "DemoConfig", "GnssInsMethod", "demo_ekf", "demo_observer"]


#: Sensor noise of the demo: a consumer-grade IMU and a standalone GNSS receiver.
DEMO_NOISE = SensorNoise(
    gyro_std=0.002,  # rad/s
    accel_std=0.05,  # m/s²
    mag_std=0.01,  # normalised field units
    gnss_p_std=1.5,  # m
    gnss_v_std=0.1,  # m/s
)


#: The demo's gain choices (:attr:`DemoConfig.gains`).
GAINS = ("noise-optimal", "paper", "designed")

#: The attitude-gain choices of the noise-optimal observer (:attr:`DemoConfig.attitude_gain`).
ATTITUDE_GAINS = ("scheduled", "constant")
#: The translational-gain choices of the noise-optimal observer (:attr:`DemoConfig.translation_gain`).
TRANSLATION_GAINS = ("scheduled", "constant")
#: Where the observers (24) run: NumPy/Python floats, or their generated C.
BACKENDS = ("python", "c")

#: The longest flight the demo simulates, in IMU samples (a flight is held in memory: ~1 kB per sample).
MAX_IMU_SAMPLES = 2e6


@dataclass(frozen=True)
class DemoConfig:
    """Options of the GNSS/INS demo.

    Attributes
    ----------
    seed : int
        Seed of the flight and of the sensor noise.
    duration : float or None
        Length of the flight [s]; ``None`` for the whole traffic pattern.
    imu_rate_hz, gnss_rate_hz : float
        Sensor rates (the paper's 100 Hz and 5 Hz).
    yaw_error_deg : float
        Initial attitude error, a rotation about the down axis.
    converge_deg : float
        Attitude-error threshold that defines convergence.
    gains : str
        ``"noise-optimal"`` (default: the certified gain with the smallest noise-to-error H2 norm
        under LMI (14) at γ = 50 and Γ = 0.5 I, :func:`~nlobs.navigation.gains.noise_optimal_gains`;
        the paper's gains run beside it for comparison), ``"paper"`` (Sec. 5.2's K and Γ) or
        ``"designed"`` (nlobs's central LMI design with the paper's Γ).
    attitude_gain : str or None
        The attitude gain of the noise-optimal observer: ``"scheduled"`` (its default: ``Γ(t)`` of
        :func:`~nlobs.navigation.schedule.noise_scheduled_gain`) or ``"constant"``
        (:data:`~nlobs.navigation.gains.NOISE_OPTIMAL_GAMMA` throughout). ``None``: the default of
        ``gains``; the paper's and the designed gains use the paper's constant Γ, so only ``None`` is
        accepted with them.
    translation_gain : str or None
        The gain ``K`` of (24a)–(24c) of the noise-optimal observer: ``"scheduled"`` (its default: the
        Kalman–Bucy levels from the first fix's uncertainty down to the noise-optimal ``K``,
        :func:`~nlobs.navigation.translation_schedule.kalman_scheduled_gain`) or ``"constant"`` (the
        noise-optimal ``K`` throughout). ``None``: the default of ``gains``; only ``None`` with the
        paper's and the designed gains.
    position_only : bool
        GNSS position only (Sec. 5.2, C = [I 0]); the gain is then designed by nlobs.
    ekf : bool
        Also run the EKF baseline.
    backend : str
        ``"python"`` (default) or ``"c"``: the observers (24) and the EKF run as their generated, compiled C
        (:func:`nlobs.export.compile_observer`, the same estimates to rounding).
    noise : SensorNoise
        The sensors' error model (default :data:`DEMO_NOISE`).

    Examples
    --------
    The default is the paper's sensor rates (Grip, Saberi & Johansen, Sec. 5: IMU at 100 Hz, GNSS at
    5 Hz) with the noise-optimal observer, whose attitude gain and ``K`` are both scheduled; the paper's
    gains are constant:

    >>> cfg = DemoConfig(duration=60.0)
    >>> cfg.imu_rate_hz, cfg.gnss_rate_hz, cfg.gains, cfg.scheduled, cfg.translation_scheduled
    (100.0, 5.0, 'noise-optimal', True, True)
    >>> cfg.noise.gnss_p_std, cfg.noise.gyro_std
    (1.5, 0.002)
    >>> DemoConfig(gains="paper").scheduled
    False

    Options that do not fit are refused when the configuration is made:

    >>> try:
    ...     DemoConfig(gains="paper", attitude_gain="constant")
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError `attitude_gain`: applies to `gains` 'noise-optimal' (the 'paper' gains use the paper's Γ)
    """

    seed: int = 0
    duration: float | None = None
    imu_rate_hz: float = 100.0
    gnss_rate_hz: float = 5.0
    yaw_error_deg: float = 60.0
    converge_deg: float = 5.0
    gains: str = "noise-optimal"
    attitude_gain: str | None = None
    translation_gain: str | None = None
    position_only: bool = False
    ekf: bool = True
    backend: str = "python"
    noise: SensorNoise = field(default_factory=lambda: DEMO_NOISE)

    def __post_init__(self) -> None:
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise InvalidArgumentError(f"`seed`: expected an integer >= 0, got {self.seed!r}")
        if self.duration is not None:
            positive("`duration`", self.duration)
            if self.duration * self.imu_rate_hz > MAX_IMU_SAMPLES:
                raise InvalidArgumentError(
                    f"`duration`: {self.duration:g} s at {self.imu_rate_hz:g} Hz is {self.duration * self.imu_rate_hz:.3g} "
                    f"IMU samples; at most {MAX_IMU_SAMPLES:.0e} fit in memory")
        positive("imu_rate_hz", self.imu_rate_hz)
        positive("gnss_rate_hz", self.gnss_rate_hz)
        in_range("`yaw_error_deg`", self.yaw_error_deg, -180.0, 180.0, hi_open=False)
        positive("converge_deg", self.converge_deg)
        if self.gains not in GAINS:
            raise InvalidArgumentError(f"`gains`: expected one of {', '.join(map(repr, GAINS))}, got {self.gains!r}")
        if self.backend not in BACKENDS:
            raise InvalidArgumentError(f"`backend`: expected one of {', '.join(map(repr, BACKENDS))}, got {self.backend!r}")
        self._noise_optimal_option("attitude_gain", ATTITUDE_GAINS, "use the paper's Γ")
        self._noise_optimal_option("translation_gain", TRANSLATION_GAINS, "are constant")

    def _noise_optimal_option(self, name: str, allowed: tuple[str, ...], others: str) -> None:
        """An option of the noise-optimal observer only: one of ``allowed``, or ``None``."""
        value = getattr(self, name)
        if value is None:
            return
        if value not in allowed:
            raise InvalidArgumentError(f"`{name}`: expected one of {', '.join(map(repr, allowed))}, got {value!r}")
        if self.gains != "noise-optimal":
            raise InvalidArgumentError(f"`{name}`: applies to `gains` 'noise-optimal' (the {self.gains!r} gains {others})")

    @property
    def scheduled(self) -> bool:
        """Whether the observer's attitude gain is scheduled (the noise-optimal default)."""
        return self.gains == "noise-optimal" and self.attitude_gain in (None, "scheduled")

    @property
    def translation_scheduled(self) -> bool:
        """Whether the observer's gain ``K`` is scheduled (the noise-optimal default)."""
        return self.gains == "noise-optimal" and self.translation_gain in (None, "scheduled")


def paper_observer(config: DemoConfig, flight: Any) -> GnssInsObserver:
    """Observer (24) with the paper's gains (or, for a position-only receiver, the paper's recipe) and Γ.

    Parameters
    ----------
    config : DemoConfig
        Its ``position_only``.
    flight : Flight
        The flight (its ``m_n``, ``g_n``).

    Returns
    -------
    GnssInsObserver
    """
    K = paper_gains(position_only=config.position_only)  # position-only: the paper's recipe, designed once and cached
    return GnssInsObserver(K, PAPER_GAMMA, flight.m_n, flight.g_n, position_only=config.position_only)


def demo_ekf(config: DemoConfig, flight: Any) -> Any:
    """The EKF baseline of the demo (:class:`~nlobs.navigation.ekf.ExtendedKalmanFilter`), tuned to its sensors.

    The filter's noise is the configuration's sensor noise (:meth:`~nlobs.navigation.ekf.EkfConfig.for_noise`),
    its initial yaw standard deviation the initial yaw error (at least 30°), its sample period the IMU's.

    Parameters
    ----------
    config : DemoConfig
        Its ``noise``, ``yaw_error_deg``, ``imu_rate_hz`` and ``position_only``.
    flight : Flight
        The flight (its ``m_n``, ``g_n``).

    Returns
    -------
    ExtendedKalmanFilter
    """
    from nlobs.navigation.ekf import EkfConfig, ExtendedKalmanFilter

    return ExtendedKalmanFilter(EkfConfig.for_noise(config.noise, yaw_std_deg=max(30.0, abs(config.yaw_error_deg)),
                                                    sample_period_s=1.0 / config.imu_rate_hz),
                                flight.m_n, flight.g_n, position_only=config.position_only)


def demo_observer(config: DemoConfig, flight: Any, start_s: float = 0.0) -> tuple[
        GnssInsObserver | ScheduledGnssInsObserver, MixedH2Certificate | None, AttitudeGainSchedule | None,
        GainScheduleCertificate | None]:
    """The demo's observer (24) for ``config`` and ``flight``: the noise-optimal gain's certificate, Γ(t) and K(t).

    Parameters
    ----------
    config : DemoConfig
        Gains, attitude gain, receiver, rates and noise.
    flight : Flight
        The flight (its ``m_n``, ``g_n``).
    start_s : float
        The first time stamp of the data (the schedules of Γ and K start there).

    Returns
    -------
    (observer, certificate or None, schedule or None, gain-schedule certificate or None)
        The noise-optimal gain's certificate, the attitude gain's schedule, and the certificate of
        the translational gain's schedule (:func:`~nlobs.navigation.translation_schedule.certify_gain_schedule`;
        its modes' gains are ``observer.gain_schedule``).

    Raises
    ------
    DesignInfeasible
        The noise-optimal gain, or a mode of the translational gain's schedule, failed its certificate.
    """
    cert: MixedH2Certificate | None = None
    schedule: AttitudeGainSchedule | None = None
    gain_cert: GainScheduleCertificate | None = None
    observer: GnssInsObserver | ScheduledGnssInsObserver
    if config.gains == "noise-optimal":
        K, cert = noise_optimal_gains(config.noise, imu_rate_hz=config.imu_rate_hz, gnss_rate_hz=config.gnss_rate_hz,
                                      position_only=config.position_only)
        if not cert.verified:  # never run an uncertified gain under this name
            raise DesignInfeasible("the noise-optimal gain failed its certificate: "
                                   + ", ".join(ch.name for ch in cert.failed_checks), constraint="certificate")
        observer = GnssInsObserver(K, NOISE_OPTIMAL_GAMMA, flight.m_n, flight.g_n, position_only=config.position_only)
        if config.scheduled:
            schedule = noise_scheduled_gain(config.noise, flight.m_n, flight.g_n, initial=NOISE_OPTIMAL_GAMMA[0, 0],
                                            start_s=start_s)
        if config.translation_scheduled:
            ks = kalman_scheduled_gain(config.noise, cert.gain, imu_rate_hz=config.imu_rate_hz,
                                       gnss_rate_hz=config.gnss_rate_hz, position_only=config.position_only,
                                       start_s=start_s)
            gain_cert = certify_gain_schedule(ks, gamma=cert.gamma)
            if not gain_cert.verified:  # never run an uncertified mode
                raise DesignInfeasible("the translational gain schedule failed its certificate: "
                                       + "; ".join(ch.summary() for ch in gain_cert.failed_checks),
                                       constraint="certificate")
            observer = ScheduledGnssInsObserver(observer, schedule or AttitudeGainSchedule.constant(NOISE_OPTIMAL_GAMMA),
                                                gain_schedule=ks)
        elif schedule is not None:
            observer = ScheduledGnssInsObserver(observer, schedule)
    elif config.gains == "paper":
        observer = paper_observer(config, flight)
    else:
        K, _ = design_gains(position_only=config.position_only)
        observer = GnssInsObserver(K, PAPER_GAMMA, flight.m_n, flight.g_n, position_only=config.position_only)
    return observer, cert, schedule, gain_cert


@dataclass(frozen=True)
class GnssInsMethod:
    """The GNSS/INS observer (24) of Grip, Saberi & Johansen on the demo's flight, with its certified gains.

    Its "model" is the demo's traffic-pattern flight, named ``gnss-ins`` (not a model file): the
    problem is not read. The design is :func:`demo_observer` for :class:`DemoConfig`'s defaults: the
    noise-optimal gain, certified by LMI (14) and its H2 bound, and Γ(t) scheduled from the noise.

    Attributes
    ----------
    name : str
        The name in the registry.
    title : str
        The method with its paper and equation numbers.
    uses_region : bool
        Whether the design reads the problem's region (no).
    options : frozenset of str
        The options :meth:`design` takes (none).
    """

    name: str = "gnss-ins"
    title: str = "GNSS/INS observer (Grip, Saberi & Johansen (24)), the demo's certified gains"
    uses_region: bool = False
    options: frozenset[str] = frozenset()

    def applies(self, problem: Any) -> str | None:
        label = getattr(problem, "label", problem)
        if str(label) != "gnss-ins":
            return f"the GNSS/INS observer's model is the demo's flight, named gnss-ins (got {label!r})"
        return None

    def design(self, problem: Any) -> Any:
        """The demo's observer (24) and its certificate (``problem``: the name ``"gnss-ins"``).

        Raises
        ------
        AssumptionViolated
            ``problem`` is not the demo's flight.
        DesignInfeasible
            The noise-optimal gain failed its certificate.
        """
        from nlobs.errors import AssumptionViolated
        from nlobs.methods.base import Design
        from nlobs.navigation.trajectory import traffic_pattern

        why = self.applies(problem)
        if why is not None:
            raise AssumptionViolated(why)
        config = DemoConfig()
        obs, cert, schedule, gain_cert = demo_observer(config, traffic_pattern(seed=config.seed))
        assert cert is not None
        ks = getattr(obs, "gain_schedule", None)
        desc = "observer (24) with the demo's noise-optimal certified gains" + (
            f"; attitude gain {schedule.describe()}" if schedule is not None else "") + (
            f"; translational gain {ks.describe()}" if ks is not None else "")
        parameters = {"gamma": cert.gamma, "imu_period": 1.0 / config.imu_rate_hz,
                      "gnss_period": 1.0 / config.gnss_rate_hz}
        details = ((f"attitude gain: {schedule.describe()}",) if schedule is not None else ()) + (
            (f"translational gain K_pp: {ks.describe()} (every mode LMI (14), switching growth of W "
             f"≤ {gain_cert.growth:.3g})",) if ks is not None and gain_cert is not None else ()) + (
            f"IMU period {parameters['imu_period']:g} s (the module refuses another step length)",)
        return Design(self.name, obs, cert, tuple(cert.checks), (), parameters, {"gamma": "default"}, desc,
                      gain=cert.gain, failed=() if cert.verified else ("the gain's certificate failed",),
                      report=schedule, theorem="Grip, Saberi & Johansen (24), the demo's noise-optimal "
                                               "certified gains", details=details)


#: The GNSS/INS method of the registry.
GNSS_INS = GnssInsMethod()
