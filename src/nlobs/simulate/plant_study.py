"""A Monte Carlo study of any plant and observer through :func:`nlobs.simulate.simulate`.

Each batch draws the observers' initial estimates ``x̂₀ + N(0, diag(σ²))`` and then, from the same
generator, every sensor and process noise sample of :func:`~nlobs.simulate.simulate`; the truth starts at
``x0`` in every run. Per run it returns the RMS error of each state after ``after``, the final error norm,
the time to ``tol`` (when given) and whether the observer diverged (``divergence="keep"``: the run is
recorded as NaN from its first non-finite value, the others go on).
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_vector
from nlobs.errors import InvalidArgumentError
from nlobs.observers.base import Observer
from nlobs.simulate.loop import simulate
from nlobs.simulate.montecarlo import RunBatch
from nlobs.simulate.sampling import InputSensor, MeasurementGroup


def _digest(*values: Any) -> str:
    h = hashlib.sha256()
    for v in values:
        h.update(repr(np.asarray(v, dtype=float).tolist()).encode() if v is not None else b"None")
    return h.hexdigest()[:16]


@dataclass(frozen=True, eq=False)
class PlantStudy:
    """Monte Carlo runs of a plant and an observer with real sensors, for :func:`~nlobs.simulate.monte_carlo`.

    Parameters
    ----------
    label : str
        Names the plant, the observer and their settings in :meth:`key` (objects with compiled functions
        cannot be compared across processes): change it when they change.
    plant, observer
        As for :func:`~nlobs.simulate.simulate`.
    x0 : array_like, shape (n,)
        The truth's initial state (the same in every run).
    x_hat0 : array_like, shape (n,)
        Mean of the observers' initial estimates.
    initial_error_std : float or array_like, shape (n,)
        Standard deviation of each run's initial estimate about ``x_hat0``.
    duration, dt, u, measurements, input_sensors, process_noise, save_every
        As for :func:`~nlobs.simulate.simulate` (the noise is drawn from the batch's generator).
    after : float
        RMS errors are over the saved times ``t ≥ after``.
    tol : float, optional
        Also return ``time_to_tolerance`` (first time after which ``‖x̂ − x‖ < tol`` for good; NaN if never).
    default_batch : int
        Runs per batch unless :func:`~nlobs.simulate.monte_carlo` is told otherwise.

    Examples
    --------
    ``ẋ = −x`` observed with the Luenberger gain 3 (``ė = −4 e``) from estimates drawn about the truth with
    standard deviation 0.5: each run's error falls below ``tol = 0.01`` at the first grid time after
    ``ln(|e₀|/tol)/4`` (at once if it starts below). A batch run by hand with the generator of batch 0 gives what
    :func:`~nlobs.simulate.monte_carlo` computes for it:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate.montecarlo import batch_rng
    >>> plant = nlobs.LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
    >>> study = PlantStudy("scalar, L = 3", plant, nlobs.LuenbergerObserver(plant, [[3.0]]), [1.0], [1.0], 0.5,
    ...                    duration=2.0, dt=1e-2, tol=0.01)
    >>> study.name, study.key().split("|")[:2]
    ('scalar, L = 3', ['plant', 'scalar, L = 3'])
    >>> out = study.run(study.prepare(), batch_rng(0, 0), 4, trajectories=True)
    >>> sorted(out.summaries)
    ['diverged', 'final_error', 'rms_error', 'time_to_tolerance']
    >>> e0 = np.abs(out.trajectories["x_hat"][:, 0, 0] - 1.0)
    >>> expected = np.maximum(np.ceil(np.log(e0 / 0.01) / 4 / 1e-2), 0) * 1e-2  # on the grid; 0 if below at once
    >>> np.round(expected, 2).tolist()
    [1.07, 0.96, 0.91, 0.0]
    >>> bool(np.allclose(out.summaries["time_to_tolerance"], expected)), bool(out.summaries["diverged"].any())
    (True, False)
    >>> res = nlobs.monte_carlo(study, 4, batch=4, seed=0)
    >>> bool(np.array_equal(res.summaries["final_error"], out.summaries["final_error"]))
    True
    """

    label: str
    plant: Any
    observer: Observer
    x0: ArrayLike
    x_hat0: ArrayLike
    initial_error_std: float | ArrayLike
    duration: float
    dt: float | None = None
    u: Any = None
    measurements: MeasurementGroup | Sequence[MeasurementGroup] | None = None
    input_sensors: InputSensor | Sequence[InputSensor] | None = None
    process_noise: ArrayLike | None = None
    save_every: int = 1
    after: float = 0.0
    tol: float | None = None
    default_batch: int = 64

    def __post_init__(self) -> None:
        if not isinstance(self.label, str) or not self.label:
            raise InvalidArgumentError("label: expected a non-empty text naming the plant and the observer")

    @property
    def name(self) -> str:
        return self.label

    def key(self) -> str:
        return (f"plant|{self.label}|{_digest(self.x0, self.x_hat0, self.initial_error_std, self.process_noise)}|"
                f"{self.duration!r}|{self.dt!r}|{self.save_every}|{self.after!r}|{self.tol!r}")

    def prepare(self) -> None:
        return None

    def run(self, prepared: Any, rng: np.random.Generator, runs: int, trajectories: bool) -> RunBatch:
        n = int(self.observer.n_x)
        mean = as_vector("x_hat0", self.x_hat0, n)
        std = np.broadcast_to(np.asarray(self.initial_error_std, dtype=float), (n,))
        x_hat0 = mean + rng.standard_normal((runs, n)) * std
        x0 = np.broadcast_to(as_vector("x0", self.x0, n), (runs, n))
        with np.errstate(over="ignore", invalid="ignore"):
            res = simulate(self.plant, self.observer, x0, x_hat0, duration=self.duration, dt=self.dt, u=self.u,
                           measurements=self.measurements, input_sensors=self.input_sensors,
                           process_noise=self.process_noise, seed=rng, save_every=self.save_every,
                           divergence="keep")
            diverged = ~np.isfinite(res.x_hat).all(axis=(-2, -1))
            out: dict[str, Array] = {"rms_error": res.rmse(self.after), "final_error": res.error_norm[:, -1],
                                     "diverged": diverged}
            if self.tol is not None:
                out["time_to_tolerance"] = res.time_to_tolerance(float(self.tol))
        traj = {"x": np.asarray(res.x), "x_hat": np.asarray(res.x_hat)} if trajectories else {}
        return RunBatch(out, traj)
