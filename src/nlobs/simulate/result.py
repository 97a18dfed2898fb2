"""The one result of every run of an observer: trajectories, extras, metrics, a plot and an ``.npz`` round trip.

Both loops return it: :func:`nlobs.simulate.simulate` (plant and observer together) and
:func:`nlobs.simulate.run_observer` (an observer on recorded data). Domain quantities are kept
as *extras* (time series recorded beside the estimate: the set-valued observer's radii, the
GNSS/INS observer's raw ``R̂``, a filter's covariance diagonal) and *info* (numbers about the
run: the cost per step, skipped samples); domain metrics are functions of the result
(e.g. :mod:`nlobs.navigation.metrics`).
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from nlobs._frozen import FrozenMapping
from nlobs._io import atomic_write, save_figure
from nlobs._typing import Array, BoolArray
from nlobs._validate import readonly
from nlobs.errors import DimensionError, InvalidArgumentError, UnknownNameError
from nlobs.simulate import metrics as _metrics

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Version of the ``.npz`` layout written by :meth:`SimulationResult.save` (version 1 files still load).
FORMAT_VERSION = 2

_EMPTY: Mapping[str, Any] = FrozenMapping({})


def _frozen_map(m: Mapping[str, Any] | None, arrays: bool) -> Mapping[str, Any]:
    if not m:
        return _EMPTY
    out: dict[str, Any] = {}
    for k, v in m.items():
        if not isinstance(k, str):
            raise InvalidArgumentError(f"SimulationResult: extra/info keys must be strings, got {k!r}")
        if arrays or isinstance(v, np.ndarray):
            out[k] = readonly(v, dtype=None)
        else:
            out[k] = v
    return FrozenMapping(out)


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """Trajectories of a plant (or recorded truth) and an observer on the saved time grid.

    Attributes
    ----------
    t : ndarray, shape (K,)
        Saved times.
    x : ndarray, shape (*batch, K, n) or None
        True plant state (a batch shape that broadcasts to the estimate's, e.g. one flight's
        truth for many noise realisations); ``None`` for recorded data without truth.
    x_hat : ndarray, shape (*batch, K, n_x)
        Observer estimate (after the correction, at a sample instant).
    y : ndarray, shape (*batch, K, p) or None
        Measurement the observer held at each saved time (sampled, noisy); the exact output when
        measurements were continuous; ``None`` when not recorded (:func:`run_observer`).
    sampled : ndarray of bool, shape (K, p) or None
        ``sampled[k, j]`` is True where output ``j`` was sampled exactly at ``t[k]``.
    states, outputs, estimates : tuple of str
        Names of the columns of ``x``, ``y`` and ``x_hat``.
    dt : float
        Integration step (saved times are multiples of it from ``t[0]``); for recorded data on a
        non-uniform grid, the mean step.
    method : str
        Integrator used (``"rk4"``, ``"discrete"``, ``"solve_ivp:DOP853"``, ``"observer step"``...).
    observer : str
        Label of the observer (its ``name``, else its class name; ``""`` for a plant alone).
    extras : mapping of str to ndarray
        Time series recorded beside the estimate, each ``(*batch, K, ...)`` (or ``(K, ...)`` when
        the same for every run): the observer's ``diagnostics`` and what ``finish_estimates`` keeps.
    info : mapping of str to object
        Numbers about the run: ``wall_s`` and ``observer_s`` (seconds), ``cost_per_step_us``
        (observer time per step per batch member), and what the caller adds (per-run arrays
        such as ``skipped``).

    All arrays are read-only.

    Examples
    --------
    Two runs of a Luenberger observer (error poles −2 and −3) from two initial states, every 10th RK4 step
    kept; the error metrics are per run, and the result survives a round trip through a file:

    >>> import os
    >>> import tempfile
    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import simulate
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.LuenbergerObserver(system, [[4.5], [1.75]])
    >>> res = simulate(system, observer, [[1.0, 0.0], [0.0, 2.0]], [0.0, 0.0], duration=5.0, dt=1e-3, u=0.0,
    ...                save_every=10)
    >>> res.batch_shape, res.t.shape, res.x_hat.shape, res.states, res.outputs, res.method
    ((2,), (501,), (2, 501, 2), ('x1', 'x2'), ('y1',), 'rk4')
    >>> res.error_norm[:, 0].tolist(), res.time_to_tolerance(1e-2).round(2).tolist()
    ([1.0, 2.0], [2.98, 3.13])
    >>> rate = res.decay_rate()  # fitted to ‖x̂ − x‖; the slowest error pole is −2
    >>> bool(np.all((1.5 < rate) & (rate < 2.1)))
    True
    >>> back = SimulationResult.load(res.save(os.path.join(tempfile.mkdtemp(), "run.npz")))
    >>> bool(np.array_equal(back.x_hat, res.x_hat)), back.observer
    (True, 'LuenbergerObserver')
    """

    t: Array
    x: Array | None
    x_hat: Array
    y: Array | None
    sampled: BoolArray | None
    states: tuple[str, ...]
    outputs: tuple[str, ...]
    estimates: tuple[str, ...]
    dt: float
    method: str
    observer: str = ""
    extras: Mapping[str, Array] = field(default_factory=dict)
    info: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "t", readonly(self.t))
        object.__setattr__(self, "x_hat", readonly(self.x_hat))
        if self.x is not None:
            object.__setattr__(self, "x", readonly(self.x))
        if self.y is not None:
            object.__setattr__(self, "y", readonly(self.y))
        if self.sampled is not None:
            object.__setattr__(self, "sampled", readonly(self.sampled, dtype=bool))
        for name in ("states", "outputs", "estimates"):
            object.__setattr__(self, name, tuple(str(s) for s in getattr(self, name)))
        object.__setattr__(self, "extras", _frozen_map(self.extras, arrays=True))
        object.__setattr__(self, "info", _frozen_map(self.info, arrays=False))
        K = self.t.shape[0]
        if self.t.ndim != 1:
            raise DimensionError(f"SimulationResult.t: expected shape (K,), got {self.t.shape}")
        checks = [("x_hat", self.x_hat, len(self.estimates))]
        if self.x is not None:
            checks.append(("x", self.x, len(self.states)))
        if self.y is not None:
            checks.append(("y", self.y, len(self.outputs)))
        for name, arr, width in checks:
            if arr.ndim < 2 or arr.shape[-2] != K or arr.shape[-1] != width:
                raise DimensionError(f"SimulationResult.{name}: expected shape (*batch, {K}, {width}), got {arr.shape}")
        if self.x is not None:
            try:
                np.broadcast_shapes(self.x.shape[:-2], self.x_hat.shape[:-2])
            except ValueError:
                raise DimensionError(f"SimulationResult.x: batch {self.x.shape[:-2]} does not broadcast to the "
                                     f"estimate's {self.x_hat.shape[:-2]}") from None
        if self.sampled is not None and self.sampled.shape != (K, len(self.outputs)):
            raise DimensionError(f"SimulationResult.sampled: expected shape ({K}, {len(self.outputs)}), got {self.sampled.shape}")

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        """Pickled as its fields and made again by the constructor where it is unpickled (its arrays read-only
        there too)."""
        return (type(self), tuple(getattr(self, f.name) for f in dataclasses.fields(self)))

    # ------------------------------------------------------------------ shapes
    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading batch shape (``()`` for a single trajectory)."""
        return tuple(self.x_hat.shape[:-2])

    @property
    def n_runs(self) -> int:
        """Number of trajectories in the batch."""
        return int(np.prod(self.batch_shape, dtype=int))

    def _truth(self) -> Array:
        if self.x is None:
            raise InvalidArgumentError("this result has no truth (x is None): the error x_hat - x is undefined")
        return self.x

    @property
    def error(self) -> Array:
        """Estimation error ``x̂ − x``, shape ``(*batch, K, n)``.

        Raises
        ------
        DimensionError
            The observer estimates a different number of states than the plant has.
        InvalidArgumentError
            There is no truth (recorded data).
        """
        x = self._truth()
        if self.x_hat.shape[-1] != x.shape[-1]:
            raise DimensionError(
                f"the estimate has {self.x_hat.shape[-1]} components and the plant {x.shape[-1]} states: "
                "the error x_hat - x is undefined"
            )
        return self.x_hat - x

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
        self, path: str | os.PathLike[str] | None = None, states: Sequence[int | str] | None = None, *,
        max_trajectories: int = 5, title: str | None = None, units: Mapping[str, str] | None = None,
    ) -> Figure:
        """Plot true vs estimated states and the error norm on a log axis (atomically saved to ``path``).

        See :func:`plot_result`.
        """
        return plot_result(self, path=path, states=states, max_trajectories=max_trajectories, title=title,
                           units=units)

    # --------------------------------------------------------------- save/load
    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the result to an ``.npz`` file atomically and return its path.

        The data go to a temporary file in the target's directory, which is flushed, synced and
        then renamed over ``path`` (:func:`os.replace`), so a reader never sees a half-written
        file and a failure leaves any existing file untouched. The file is written exactly at
        ``path`` (no suffix is added). Extras are stored as arrays, info as JSON (its arrays as
        arrays).
        """
        data: dict[str, Any] = {
            "format_version": np.array(FORMAT_VERSION),
            "t": self.t,
            "x_hat": self.x_hat,
            "states": np.array(self.states, dtype=str),
            "outputs": np.array(self.outputs, dtype=str),
            "estimates": np.array(self.estimates, dtype=str),
            "dt": np.array(self.dt),
            "method": np.array(self.method),
            "observer": np.array(self.observer),
        }
        for name in ("x", "y", "sampled"):
            val = getattr(self, name)
            if val is not None:
                data[name] = val
        for k, v in self.extras.items():
            data[f"extra__{k}"] = v
        plain: dict[str, Any] = {}
        for k, v in self.info.items():
            if isinstance(v, np.ndarray):
                data[f"info__{k}"] = v
            else:
                plain[k] = v.item() if isinstance(v, np.generic) else v
        try:
            data["info_json"] = np.array(json.dumps(plain, allow_nan=True))
        except TypeError as exc:
            raise InvalidArgumentError(f"SimulationResult.save: info is not JSON-serialisable ({exc})") from None
        return atomic_write(path, lambda fh: np.savez(fh, **data))

    # ------------------------------------------------------------- export
    def to_dict(self) -> dict[str, Any]:
        """Plain Python (lists, floats, strings; non-finite numbers as ``None``): every field, for JSON.

        Keys: ``t``, ``x``, ``x_hat``, ``y``, ``sampled`` (arrays as nested lists, batch axes first;
        ``None`` when absent), ``states``, ``outputs``, ``estimates``, ``dt``, ``method``,
        ``observer``, ``extras`` and ``info``.
        """
        from nlobs._io import jsonable

        return jsonable({
            "t": self.t, "x": self.x, "x_hat": self.x_hat, "y": self.y, "sampled": self.sampled,
            "states": list(self.states), "outputs": list(self.outputs), "estimates": list(self.estimates),
            "dt": self.dt, "method": self.method, "observer": self.observer,
            "extras": dict(self.extras), "info": dict(self.info),
        })

    def to_csv(self, path: str | os.PathLike[str], run: int | tuple[int, ...] = 0) -> Path:
        """Write one run as CSV, atomically: ``t``, the true states, the estimates (``<name>_hat``), the outputs.

        Outputs are empty where nothing was sampled (multi-rate sensors); non-finite values are
        empty cells. ``run`` picks the run of a batch (default the first).

        Raises
        ------
        InvalidArgumentError
            ``run`` out of range for the batch.
        """
        import csv
        import io

        idx = run if isinstance(run, tuple) else ((run,) if self.batch_shape else ())
        try:
            xh = self.x_hat[idx] if idx else self.x_hat
            x = None if self.x is None else (np.broadcast_to(self.x, self.x_hat.shape[:-1] + self.x.shape[-1:])[idx]
                                             if idx else self.x)
            y = None if self.y is None else (self.y[idx] if idx and self.y.ndim > 2 else self.y)
            smp = None if self.sampled is None else (self.sampled[idx] if idx and self.sampled.ndim > 2 else
                                                     self.sampled)
        except IndexError:
            raise InvalidArgumentError(f"run: {run} is out of range for the batch shape {self.batch_shape}") from None
        head = ["t", *self.states[: 0 if x is None else len(self.states)], *(f"{e}_hat" for e in self.estimates),
                *(self.outputs if y is not None else ())]
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(head)

        def cell(v: float) -> str:
            return repr(float(v)) if np.isfinite(v) else ""

        for k in range(self.t.size):
            row = [cell(self.t[k])]
            if x is not None:
                row += [cell(v) for v in x[k]]
            row += [cell(v) for v in xh[k]]
            if y is not None:
                row += [cell(v) if smp is None or smp[k, j] else "" for j, v in enumerate(y[k])]
            w.writerow(row)
        from nlobs._io import atomic_write_text

        return atomic_write_text(path, buf.getvalue())

    def to_xarray(self) -> Any:
        """The result as an ``xarray.Dataset`` (needs xarray).

        Dimensions: the batch axes ``run0, run1, …``, ``time`` (its coordinate: ``t``), ``state``,
        ``estimate`` and ``output`` (coordinates: the names). Variables ``x``, ``x_hat``, ``y``,
        ``sampled`` and the extras (their trailing axes named ``<extra>_dim<i>``); attributes ``dt``,
        ``method``, ``observer``.

        Raises
        ------
        InvalidArgumentError
            xarray is not installed.
        """
        try:
            import xarray as xr
        except ImportError:
            raise InvalidArgumentError("to_xarray: xarray is not installed (pip install xarray)") from None
        batch = [f"run{i}" for i in range(len(self.batch_shape))]
        data: dict[str, Any] = {"x_hat": ([*batch, "time", "estimate"], np.asarray(self.x_hat))}
        if self.x is not None:
            xb = len(self.x.shape) - 2
            data["x"] = ([*batch[len(batch) - xb:], "time", "state"], np.asarray(self.x))
        if self.y is not None:
            yb = len(self.y.shape) - 2
            data["y"] = ([*batch[len(batch) - yb:], "time", "output"], np.asarray(self.y))
        if self.sampled is not None:
            data["sampled"] = ([*batch[len(batch) - (self.sampled.ndim - 2):], "time", "output"],
                               np.asarray(self.sampled))
        for k, v in self.extras.items():
            v = np.asarray(v)
            lead = batch + ["time"] if v.ndim >= len(batch) + 1 and v.shape[len(batch)] == self.t.size else batch
            lead = lead[: min(len(lead), v.ndim)]
            data[f"extra_{k}"] = ([*lead, *(f"{k}_dim{i}" for i in range(v.ndim - len(lead)))], v)
        coords = {"time": np.asarray(self.t), "estimate": list(self.estimates)}
        if self.x is not None:
            coords["state"] = list(self.states)
        if self.y is not None or self.sampled is not None:
            coords["output"] = list(self.outputs)
        return xr.Dataset(data, coords=coords, attrs={"dt": self.dt, "method": self.method,
                                                      "observer": self.observer})

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SimulationResult:
        """Read a result written by :meth:`save` (format 1 or 2).

        Raises
        ------
        InvalidArgumentError
            The file is not a simulation result of a known format version.
        """
        with np.load(path, allow_pickle=False) as data:
            version = int(data["format_version"]) if "format_version" in data.files else None
            if version not in (1, FORMAT_VERSION):
                raise InvalidArgumentError(f"{path}: not an nlobs simulation result of format {FORMAT_VERSION} (found {version})")
            files = set(data.files)
            extras = {k.removeprefix("extra__"): data[k] for k in files if k.startswith("extra__")}
            info: dict[str, Any] = json.loads(str(data["info_json"])) if "info_json" in files else {}
            info.update({k.removeprefix("info__"): data[k] for k in files if k.startswith("info__")})
            return cls(
                t=data["t"],
                x=data["x"] if "x" in files else None,
                x_hat=data["x_hat"],
                y=data["y"] if "y" in files else None,
                sampled=data["sampled"] if "sampled" in files else None,
                states=tuple(data["states"].tolist()),
                outputs=tuple(data["outputs"].tolist()),
                estimates=tuple(data["estimates"].tolist()),
                dt=float(data["dt"]),
                method=str(data["method"]),
                observer=str(data["observer"]) if "observer" in files else "",
                extras=extras,
                info=info,
            )


# ------------------------------------------------------------------------ plot
def with_run_axis(result: SimulationResult) -> SimulationResult:
    """A single run's result as a batch of one run: ``x``, ``x_hat``, ``y`` and the extras get a leading axis of 1.

    Parameters
    ----------
    result : SimulationResult
        A result without a batch axis (``x_hat`` of shape ``(K, n)``).

    Returns
    -------
    SimulationResult
        The same values, ``x_hat`` of shape ``(1, K, n)`` (views, no copy).
    """
    if result.batch_shape != ():
        raise DimensionError(f"with_run_axis: the result already has the batch shape {result.batch_shape}")
    return dataclasses.replace(
        result, x=None if result.x is None else result.x[None], x_hat=result.x_hat[None],
        y=None if result.y is None else result.y[None], extras={k: v[None] for k, v in result.extras.items()})


def _state_indices(result: SimulationResult, states: Sequence[int | str] | None) -> list[int]:
    n = len(result.states)
    if states is None:
        return list(range(n))
    out = []
    for s in states:
        if isinstance(s, str):
            if s not in result.states:
                raise UnknownNameError(f"plot: unknown state {s!r}; the states are {list(result.states)}")
            out.append(result.states.index(s))
        else:
            i = int(s)
            if not 0 <= i < n:
                raise DimensionError(f"plot: state index {i} out of range for {n} states")
            out.append(i)
    return out


def plot_result(
    result: SimulationResult,
    path: str | os.PathLike[str] | None = None,
    states: Sequence[int | str] | None = None,
    *,
    max_trajectories: int = 5,
    title: str | None = None,
    units: Mapping[str, str] | None = None,
) -> Figure:
    """Plot each selected state (true: solid, estimate: dashed) and ``‖x̂ − x‖`` on a log axis.

    Parameters
    ----------
    result : SimulationResult
        What to plot.
    path : path-like, optional
        If given, the figure is also saved there (format from the suffix).
    states : sequence of int or str, optional
        States to show (default: all).
    max_trajectories : int
        For a batch, at most this many trajectories (the first ones) are drawn.
    title : str, optional
        Figure title (default: what is drawn, with the observer's label).
    units : mapping of str to str, optional
        Units by name, as in a model file's ``units`` table: ``units["t"]`` labels the time axis
        (default ``"s"``), a state's unit its axis (``"X [g/L]"``), and the error axis when all
        the shown states share one.

    Returns
    -------
    matplotlib.figure.Figure
        A figure not registered with pyplot (no GUI backend is touched).
    """
    from matplotlib.figure import Figure

    u = {str(k): str(v) for k, v in (units or {}).items()}
    if max_trajectories < 1:
        raise InvalidArgumentError(f"max_trajectories: must be at least 1, got {max_trajectories}")
    idx = _state_indices(result, states)
    if result.x is None:
        raise InvalidArgumentError("plot: this result has no truth (x is None); plot its x_hat directly")
    same = result.x_hat.shape[-1] == result.x.shape[-1]
    t = result.t
    x = np.broadcast_to(result.x, (*result.batch_shape, t.size, result.x.shape[-1])).reshape(-1, t.size, result.x.shape[-1])[:max_trajectories]
    xh = result.x_hat.reshape(-1, t.size, result.x_hat.shape[-1])[:max_trajectories]
    ntraj = x.shape[0]
    nrows = len(idx) + (1 if same else 0)
    fig = Figure(figsize=(8.0, 1.9 * nrows + 0.8), layout="constrained")
    axes = fig.subplots(nrows, 1, sharex=True, squeeze=False)[:, 0]
    colors = [f"C{i % 10}" for i in range(ntraj)]
    alpha = 1.0 if ntraj == 1 else 0.7
    for row, i in enumerate(idx):
        ax = axes[row]
        for b in range(ntraj):
            ax.plot(t, x[b, :, i], color=colors[b], lw=1.4, alpha=alpha, label="true" if b == 0 else None)
            if same:
                ax.plot(t, xh[b, :, i], color=colors[b], lw=1.4, ls="--", alpha=alpha, label="estimate" if b == 0 else None)
        ax.set_ylabel(f"{result.states[i]} [{u[result.states[i]]}]" if u.get(result.states[i]) else result.states[i])
        ax.grid(True, alpha=0.3)
        if row == 0:
            ax.legend(loc="best", fontsize="small")
    if same:
        ax = axes[-1]
        en = np.linalg.norm(xh - x, axis=-1)
        for b in range(ntraj):
            ax.semilogy(t, np.where(en[b] > 0, en[b], np.nan), color=colors[b], lw=1.2, alpha=alpha)
        shared = {u.get(result.states[i], "") for i in idx}
        ax.set_ylabel("‖x̂ − x‖" + (f" [{shared.pop()}]" if len(shared) == 1 and "" not in shared else ""))
        ax.grid(True, which="both", alpha=0.3)
    axes[-1].set_xlabel(f"time [{u.get('t') or 's'}]")
    shown = f" (first {ntraj} of {int(np.prod(result.batch_shape))} trajectories)" if result.batch_shape else ""
    head = title if title is not None else (
        f"{result.observer + ': ' if result.observer else ''}true (solid) vs estimated (dashed) states{shown}")
    fig.suptitle(head, fontsize="medium")
    if path is not None:
        save_figure(fig, path, dpi=110)
    return fig
