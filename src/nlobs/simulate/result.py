"""The immutable result of a simulation, with error metrics, a plot and an ``.npz`` round trip."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from nlobs._io import atomic_write
from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.simulate import metrics as _metrics

if TYPE_CHECKING:
    from matplotlib.figure import Figure

Array = NDArray[np.float64]

#: Version of the ``.npz`` layout written by :meth:`SimulationResult.save`.
FORMAT_VERSION = 1

_ARRAYS = ("t", "x", "x_hat", "y", "sampled")


def _readonly(a: NDArray) -> NDArray:
    """``a`` itself if no one can write to it (it and every base are read-only), else a read-only copy."""
    if isinstance(a, np.ndarray) and type(a) is np.ndarray:
        b: object = a
        while isinstance(b, np.ndarray):
            if b.flags.writeable:
                break
            b = b.base
        else:
            return a
    a = np.array(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class SimulationResult:
    """Trajectories of a plant and its observer on the saved time grid.

    Attributes
    ----------
    t : ndarray, shape (K,)
        Saved times.
    x : ndarray, shape (*batch, K, n)
        True plant state.
    x_hat : ndarray, shape (*batch, K, n_x)
        Observer estimate (after the correction, at a sample instant).
    y : ndarray, shape (*batch, K, p)
        Measurement the observer held at each saved time (sampled, noisy);
        the exact output when measurements were continuous.
    sampled : ndarray of bool, shape (K, p)
        ``sampled[k, j]`` is True where output ``j`` was sampled exactly at ``t[k]``.
    states, outputs, estimates : tuple of str
        Names of the columns of ``x``, ``y`` and ``x_hat``.
    dt : float
        Integration step (saved times are multiples of it from ``t[0]``).
    method : str
        Integrator used (``"rk4"``, ``"discrete"``, ``"solve_ivp:DOP853"``...).

    All arrays are read-only.
    """

    t: Array
    x: Array
    x_hat: Array
    y: Array
    sampled: NDArray[np.bool_]
    states: tuple[str, ...]
    outputs: tuple[str, ...]
    estimates: tuple[str, ...]
    dt: float
    method: str

    def __post_init__(self) -> None:
        for name in _ARRAYS:
            object.__setattr__(self, name, _readonly(getattr(self, name)))
        for name in ("states", "outputs", "estimates"):
            object.__setattr__(self, name, tuple(str(s) for s in getattr(self, name)))
        K = self.t.shape[0]
        checks = (("x", self.x, len(self.states)), ("x_hat", self.x_hat, len(self.estimates)), ("y", self.y, len(self.outputs)))
        for name, arr, width in checks:
            if arr.ndim < 2 or arr.shape[-2] != K or arr.shape[-1] != width:
                raise DimensionError(f"SimulationResult.{name}: expected shape (*batch, {K}, {width}), got {arr.shape}")
        if self.sampled.shape != (K, len(self.outputs)):
            raise DimensionError(f"SimulationResult.sampled: expected shape ({K}, {len(self.outputs)}), got {self.sampled.shape}")

    # ------------------------------------------------------------------ shapes
    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading batch shape (``()`` for a single trajectory)."""
        return tuple(self.x.shape[:-2])

    @property
    def error(self) -> Array:
        """Estimation error ``x̂ − x``, shape ``(*batch, K, n)``.

        Raises
        ------
        DimensionError
            The observer estimates a different number of states than the plant has.
        """
        if self.x_hat.shape[-1] != self.x.shape[-1]:
            raise DimensionError(
                f"the estimate has {self.x_hat.shape[-1]} components and the plant {self.x.shape[-1]} states: "
                "the error x_hat - x is undefined"
            )
        return self.x_hat - self.x

    @property
    def error_norm(self) -> Array:
        """Euclidean norm of the error, shape ``(*batch, K)``."""
        return np.linalg.norm(self.error, axis=-1)

    # ----------------------------------------------------------------- metrics
    def rmse(self, after: float | None = None) -> Array:
        """RMSE of each state over the saved samples with ``t >= after``, shape ``(*batch, n)``."""
        return _metrics.rmse(self.t, self.error, -np.inf if after is None else float(after))

    def final_error(self) -> Array:
        """Signed error at the final time, shape ``(*batch, n)``."""
        return self.error[..., -1, :]

    def time_to_tolerance(self, tol: float) -> Array:
        """First time after which ``‖x̂ − x‖ < tol`` for good; NaN if never, shape ``(*batch,)``."""
        return _metrics.time_to_tolerance(self.t, self.error_norm, tol)

    def decay_rate(self, *, floor: float | None = None, t_min: float = -np.inf, t_max: float = np.inf) -> Array:
        """Fitted exponential decay rate ``λ`` of ``‖x̂ − x‖`` (see :func:`nlobs.simulate.metrics.decay_rate`)."""
        return _metrics.decay_rate(self.t, self.error_norm, floor=floor, t_min=t_min, t_max=t_max)

    def metrics(self, *, tol: float | None = None, after: float | None = None, floor: float | None = None) -> _metrics.ErrorMetrics:
        """All error metrics at once.

        Parameters
        ----------
        tol : float, optional
            Tolerance for :attr:`ErrorMetrics.time_to_tolerance` (NaN if not given).
        after : float, optional
            Start of the RMSE window (default: the whole run).
        floor : float, optional
            Floor for the decay-rate fit (default: relative, see :func:`~nlobs.simulate.metrics.decay_rate`).
        """
        enorm = self.error_norm
        ttt = (
            _metrics.time_to_tolerance(self.t, enorm, tol)
            if tol is not None
            else np.full(self.batch_shape, np.nan)
        )
        return _metrics.ErrorMetrics(
            rmse=self.rmse(after),
            final_error=self.final_error(),
            final_error_norm=enorm[..., -1],
            time_to_tolerance=ttt,
            decay_rate=_metrics.decay_rate(self.t, enorm, floor=floor),
            after=-np.inf if after is None else float(after),
            tol=tol,
        )

    # -------------------------------------------------------------------- plot
    def plot(
        self, path: str | os.PathLike[str] | None = None, states: Sequence[int | str] | None = None, *, max_trajectories: int = 5
    ) -> Figure:
        """Plot true vs estimated states and the error norm on a log axis.

        See :func:`nlobs.simulate.plotting.plot_result`.
        """
        from nlobs.simulate.plotting import plot_result

        return plot_result(self, path=path, states=states, max_trajectories=max_trajectories)

    # --------------------------------------------------------------- save/load
    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the result to an ``.npz`` file atomically and return its path.

        The data go to a temporary file in the target's directory, which is
        flushed, synced and then renamed over ``path`` (:func:`os.replace`), so
        a reader never sees a half-written file and a failure leaves any
        existing file untouched. The file is written exactly at ``path`` (no
        suffix is added).
        """
        data = {
            "format_version": np.array(FORMAT_VERSION),
            "t": self.t,
            "x": self.x,
            "x_hat": self.x_hat,
            "y": self.y,
            "sampled": self.sampled,
            "states": np.array(self.states, dtype=str),
            "outputs": np.array(self.outputs, dtype=str),
            "estimates": np.array(self.estimates, dtype=str),
            "dt": np.array(self.dt),
            "method": np.array(self.method),
        }
        return atomic_write(path, lambda fh: np.savez(fh, **data))

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SimulationResult:
        """Read a result written by :meth:`save`.

        Raises
        ------
        InvalidArgumentError
            The file is not a simulation result of a known format version.
        """
        with np.load(path, allow_pickle=False) as data:
            version = int(data["format_version"]) if "format_version" in data.files else None
            if version != FORMAT_VERSION:
                raise InvalidArgumentError(f"{path}: not an nlobs simulation result of format {FORMAT_VERSION} (found {version})")
            return cls(
                t=data["t"],
                x=data["x"],
                x_hat=data["x_hat"],
                y=data["y"],
                sampled=data["sampled"],
                states=tuple(data["states"].tolist()),
                outputs=tuple(data["outputs"].tolist()),
                estimates=tuple(data["estimates"].tolist()),
                dt=float(data["dt"]),
                method=str(data["method"]),
            )
