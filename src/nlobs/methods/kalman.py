r"""The extended and unscented Kalman filters as methods (:data:`EKF`, :data:`UKF`): tuned from the model file.

Continuous-discrete filters for a continuous model, discrete ones for a discrete model
(:class:`nlobs.observers.EKF`, :class:`nlobs.observers.UKF`), tuned from the problem's noise: ``R``
from the sensors, ``Q`` the process noise (or :data:`DEFAULT_FILTER_Q` per second without one, or a
given ``filter_q``), ``P0 = diag(p0_std²)``. They carry no certificate: a Kalman filter is the
baseline an engineer would otherwise use, not a guarantee.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_covariance
from nlobs.errors import InvalidArgumentError, ModelError, NlobsError
from nlobs.methods.base import Design
from nlobs.methods.problem import Problem
from nlobs.systems.sensors import MeasurementGroup
from nlobs.systems.symbolic import SymbolicModel

__all__ = ["DEFAULT_FILTER_Q", "EKF", "UKF", "KalmanMethod", "filter_tuning", "measurement_covariance",
           "noise_matrix"]

#: Process-noise spectral density a Kalman filter assumes per state when the model has no ``[process_noise]``.
DEFAULT_FILTER_Q = 1e-6


def noise_matrix(name: str, value: ArrayLike, n: int) -> Array:
    """A covariance from standard deviations per state (``diag(std²)``) or an ``(n, n)`` symmetric PSD matrix.

    Parameters
    ----------
    name : str
        How messages name the value.
    value : array_like
        ``n`` standard deviations or an ``(n, n)`` covariance.
    n : int
        Number of states.

    Returns
    -------
    ndarray, shape (n, n)
    """
    q = np.asarray(value, dtype=float)
    if q.ndim == 1:
        if q.shape != (n,) or not np.all(np.isfinite(q)) or np.any(q < 0):
            raise InvalidArgumentError(f"{name}: expected {n} finite, non-negative standard deviations (one per "
                                       f"state), got {q.tolist()}")
        return np.diag(q**2)
    return as_covariance(name, q, n)


def measurement_covariance(model: Any, sensors: Sequence[MeasurementGroup]) -> Array:
    """``R``: the block-diagonal covariance of the sensors' noise, in the order of the model's outputs.

    Parameters
    ----------
    model : model
        Its ``outputs`` give the order.
    sensors : sequence of MeasurementGroup
        The measurement groups.

    Returns
    -------
    ndarray, shape (p, p)
    """
    p = len(model.outputs)
    R = np.zeros((p, p))
    for g in sensors:
        idx = [model.outputs.index(o) if isinstance(o, str) else int(o) for o in g.outputs]
        R[np.ix_(idx, idx)] = g.covariance
    return R


def filter_tuning(problem: Problem, filter_q: ArrayLike | None, p0_std: ArrayLike | None) -> tuple[Array, str, Array,
                                                                                                Array]:
    """The tuning every stochastic estimator of a problem shares (EKF, UKF, particle filter, moving horizon).

    Parameters
    ----------
    problem : Problem
        With sensors.
    filter_q : array_like or None
        ``Q`` given (std per state or a covariance); else the process noise, else :data:`DEFAULT_FILTER_Q` ``I``.
    p0_std : array_like or None
        Standard deviations of the initial error (default the file's ``initial_error_std``, else
        ``0.1 max(1, |x0|)``).

    Returns
    -------
    Q : ndarray, shape (n, n)
    q_text : str
        Where ``Q`` came from.
    R : ndarray, shape (p, p)
        From the sensors (:func:`measurement_covariance`).
    p0_std : ndarray, shape (n,)

    Raises
    ------
    InvalidArgumentError
        A ``filter_q`` or ``p0_std`` that is not numbers of the right size, finite and positive.

    Examples
    --------
    >>> from nlobs.methods.problem import problem
    >>> Q, q_text, R, std = filter_tuning(problem("cartpole"), None, None)
    >>> q_text, R.diagonal().tolist(), std.tolist()
    ('the process noise', [1e-06, 2.5e-05], [0.05, 0.1, 0.1, 0.2])
    """
    model = problem.model
    n = model.n
    R = measurement_covariance(model, problem.sensors)
    if filter_q is not None:
        try:
            Q, q_text = noise_matrix("`filter_q`", np.asarray(filter_q, dtype=float), n), "given"
        except (TypeError, ValueError) as exc:
            if isinstance(exc, NlobsError):
                raise
            raise InvalidArgumentError(f"`filter_q`: expected numbers, got {filter_q!r}") from None
    elif problem.process_noise is not None and np.any(problem.process_noise):
        Q, q_text = np.asarray(problem.process_noise, dtype=float), "the process noise"
    else:
        Q, q_text = DEFAULT_FILTER_Q * np.eye(n), f"{DEFAULT_FILTER_Q:g} I (no process noise given)"
    file_std = problem.scenario.defaults.initial_error_std
    default_std = np.asarray(file_std, dtype=float) if file_std is not None else 0.1 * np.maximum(
        1.0, np.abs(problem.x0))
    try:
        std = default_std if p0_std is None else np.broadcast_to(np.asarray(p0_std, dtype=float), (n,))
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"`p0_std`: expected {n} standard deviations (or one), got {p0_std!r}") from None
    if not np.all(np.isfinite(std)) or np.any(std <= 0):
        raise InvalidArgumentError(f"`p0_std`: expected {n} finite, positive standard deviations, got {std.tolist()}")
    return Q, q_text, R, np.asarray(std, dtype=float)


@dataclass(frozen=True)
class KalmanMethod:
    """An extended (``name="ekf"``) or unscented (``"ukf"``) Kalman filter tuned from the problem (module docstring).

    Attributes
    ----------
    name : str
        The name in the registry.
    title : str
        The method with its paper and equation numbers.
    uses_region : bool
        Whether the design reads the problem's region.
    options : frozenset of str
        The options :meth:`design` takes.
    """

    name: str
    title: str
    uses_region: bool = False
    options: frozenset[str] = frozenset({"filter_q", "p0_std"})

    def applies(self, problem: Problem) -> str | None:
        if not problem.sensors:
            return ("a Kalman filter needs sampled, noisy measurements: add [sensors] to the model file, or give "
                    "a rate and a noise std")
        R = measurement_covariance(problem.model, problem.sensors)
        if np.linalg.eigvalsh(R)[0] <= 0:
            zero = [g.name for g in problem.sensors if np.any(np.asarray(g.noise_std) == 0)]
            return (f"the measurement covariance R is singular (sensor {', '.join(zero) or '?'} has zero noise); "
                    "a Kalman filter needs R positive definite")
        return None

    def design(self, problem: Problem, *, filter_q: ArrayLike | None = None,
               p0_std: ArrayLike | None = None) -> Design:
        """The filter for the problem's sensors and noise.

        Parameters
        ----------
        problem : Problem
        filter_q : array_like, optional
            ``Q`` (std per state or a covariance), instead of the process noise.
        p0_std : array_like, optional
            Standard deviation of the initial error per state (``P0 = diag(p0_std²)``; default
            ``0.1 max(1, |x0|)``).

        Raises
        ------
        ModelError
            No sensors, or a singular ``R``.
        """
        from nlobs.observers import EKF as EKFObserver
        from nlobs.observers import UKF as UKFObserver

        why = self.applies(problem)
        if why is not None:
            raise ModelError(why)
        model = problem.model
        Q, q_text, R, std = filter_tuning(problem, filter_q, p0_std)
        P0 = np.diag(std**2)
        cls = EKFObserver if self.name == "ekf" else UKFObserver
        plant = model.compile() if isinstance(model, SymbolicModel) else model
        try:
            obs = cls(plant, Q, R, P0, name=self.name.upper(), bounds=problem.scenario.constraints)
        except NlobsError as exc:
            raise ModelError(str(exc)) from None
        mode = "discrete" if model.time.is_discrete else "continuous-discrete"
        desc = (f"{mode} {'extended' if self.name == 'ekf' else 'unscented'} Kalman filter, Q = {q_text}, R from the "
                f"sensors, P0 = diag({[float(f'{v:.4g}') for v in std]}²)")
        if problem.scenario.constraints is not None:
            desc += "; mean projected onto the [constraints] after each correction"
        parameters = {"Q": Q, "R": R, "p0_std": std}
        sources = {"Q": q_text, "R": "[sensors]"}
        u = problem.observability
        warnings: tuple[str, ...] = ()
        if u is not None and u.rank is not None and not u.observable:
            warnings = (f"the model is {u.describe()}: the filter's estimate along "
                        f"{'it' if len(u.directions) == 1 else 'them'} runs open loop (no measurement corrects it; its "
                        "covariance does not shrink)",)
        return Design(self.name, obs, None, (), (), parameters, sources, desc, warnings=warnings)


#: The extended Kalman filter of the registry.
EKF = KalmanMethod("ekf", "extended Kalman filter (continuous-discrete, Joseph update)")
#: The unscented Kalman filter of the registry.
UKF = KalmanMethod("ukf", "unscented Kalman filter (continuous-discrete)")
