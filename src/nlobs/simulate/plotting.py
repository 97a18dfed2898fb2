"""Plots of simulation results (matplotlib, without pyplot: safe on headless machines)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from nlobs._io import save_figure
from nlobs.errors import DimensionError, InvalidArgumentError, UnknownNameError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from nlobs.simulate.result import SimulationResult


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
