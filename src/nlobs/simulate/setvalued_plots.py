"""Figures of Algorithm 1 runs (Khajenejad & Yong): errors against the radii, and one run's states and balls.

matplotlib's object API only (no pyplot: safe on headless machines); every figure is written
atomically (:func:`nlobs._io.save_figure`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from nlobs._io import save_figure as _save
from nlobs._typing import Array
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.setvalued import ContainmentResult, input_estimates, radii_of

__all__ = ["plot_errors_vs_radii", "plot_trajectories", "save_figure"]


def save_figure(fig: Any, path: str | Path) -> Path:
    """Save a matplotlib figure as PNG atomically (:func:`nlobs._io.save_figure`, 120 dpi); returns the path.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or Path
        Output file; the format follows its suffix (PNG when it has none).

    Returns
    -------
    Path
        The file written.
    """
    return _save(fig, path, dpi=120)


def plot_errors_vs_radii(results: tuple[ContainmentResult, ...], path: str | Path, *, title: str = "",
                         dt: float = 1.0, log: bool = False) -> Path:
    """Save a figure of the error norms over the runs (range, median) against each result's state radius.

    Uses matplotlib's object API (no pyplot). Returns ``path``.

    Parameters
    ----------
    results : tuple of ContainmentResult
        The results to compare (e.g. sound and printed radii); up to four are drawn.
    path : str or Path
        Output file.
    title : str
        Figure title.
    dt : float
        Step length for the time axis (``1``: the axis is the step ``k``).
    log : bool
        Logarithmic vertical axis.

    Returns
    -------
    Path
        The file written.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    colours = ("C0", "C3", "C2", "C1")
    for res, col in zip(results, colours):
        t = np.arange(res.steps + 1) * dt
        ax.fill_between(t, np.min(res.errors, axis=0), np.max(res.errors, axis=0), color=col, alpha=0.2,
                        label=f"{res.label}: error range over {res.runs} runs")
        ax.plot(t, np.median(res.errors, axis=0), color=col, lw=1.0, label=f"{res.label}: median error")
        ax.plot(t, res.radii.state, color=col, lw=2.0, ls="--", label=f"{res.label}: radius δˣ_k")
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("t [s]" if dt != 1.0 else "step k")
    ax.set_ylabel("‖x_k − x̂_k|k‖")
    ax.set_title(title)
    ax.legend(fontsize=7)
    return save_figure(fig, path)


def plot_trajectories(batch: SimulationResult, path: str | Path, *, run: int = 0, title: str = "") -> Path:
    """States, unknown inputs, their estimates and the balls over time for one run (like Khajenejad & Yong, Figs. 2-5).

    The ball ``‖x − x̂‖ ≤ δˣ`` is drawn per component as the interval ``x̂ᵢ ± δˣ`` (a projection of the ball).

    Parameters
    ----------
    batch : SimulationResult
        A :func:`~nlobs.simulate.setvalued.simulate_batch` result (truth ``x`` and extra ``d``).
    path : str or Path
        Output file.
    run : int
        Index of the run to draw.
    title : str
        Title of the top panel.

    Returns
    -------
    Path
        The file written.
    """
    from matplotlib.figure import Figure

    x, xh, rad = batch.x[run], batch.x_hat[run], radii_of(batch)
    d_all, dh_all = batch.extras["d"], input_estimates(batch)
    n, p = x.shape[1], d_all.shape[2]
    t = batch.t
    fig = Figure(figsize=(9.0, 2.0 * (n + p) + 0.5), layout="constrained")
    for i in range(n):
        ax = fig.add_subplot(n + p, 1, i + 1)
        if rad is not None:
            ax.fill_between(t, xh[:, i] - rad.state, xh[:, i] + rad.state, color="C0", alpha=0.15,
                            label="x̂ᵢ ± δˣ_k")
        ax.plot(t, x[:, i], "k", lw=1.2, label=f"x{i + 1}")
        ax.plot(t, xh[:, i], "C0--", lw=1.0, label=f"x̂{i + 1}")
        if rad is not None:
            ax.set_ylim(*_limits(x[:, i], xh[:, i]))
        ax.legend(fontsize=7, loc="upper right")
        if i == 0:
            ax.set_title(title)
    for j in range(p):
        ax = fig.add_subplot(n + p, 1, n + j + 1)
        dh = dh_all[run, :, j]
        if rad is not None:
            ax.fill_between(t[:-1], dh - rad.input, dh + rad.input, color="C1", alpha=0.15, label="d̂ ± δᵈ")
        ax.plot(t[:-1], d_all[run, :-1, j], "k", lw=1.2, label=f"d{j + 1}")
        ax.plot(t[:-1], dh, "C1--", lw=1.0, label=f"d̂{j + 1}")
        ax.set_ylim(*_limits(d_all[run, :-1, j], dh))
        ax.legend(fontsize=7, loc="upper right")
    ax.set_xlabel("t [s]")
    return save_figure(fig, path)


def _limits(*series: Array) -> tuple[float, float]:
    """y-limits showing the signals (the balls may be much wider early on)."""
    lo = min(float(np.min(s)) for s in series)
    hi = max(float(np.max(s)) for s in series)
    pad = 0.6 * max(hi - lo, 1e-3)
    return lo - pad, hi + pad


