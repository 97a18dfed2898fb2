"""Figures of a navigation run in the style of Grip, Saberi & Johansen, Figs. 4–6.

* :func:`plot_ground_track` (Fig. 4): true position (markers) and estimate (solid)
  in local north–east coordinates, with the altitude ``−p_d`` against time;
* :func:`plot_velocity_error` (Fig. 5): velocity estimation error ``v − v̂`` (solid,
  left axis) and the true velocity (dashed, right axis) in N, E, D;
* :func:`plot_euler_error` (Fig. 6): Euler-angle error ``true − estimate`` (solid,
  left axis; yaw wrapped to ±180°) and the true Euler angles (dashed, right axis).
  The estimate's angles come from the projected ``R̂`` by inverse trigonometry.

Each takes the :class:`~nlobs.simulate.SimulationResult` of a navigation run
(:func:`nlobs.navigation.run.run_navigation`; quantities read by :mod:`nlobs.navigation.metrics`)
and optionally a second one (``compare``, e.g. the EKF on the same data) drawn in another
colour; ``index`` picks a flight of a batch. With ``path`` the figure is saved atomically as a
PNG (dpi 100). Matplotlib is imported lazily and only its object API is used (no pyplot state).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from nlobs._io import save_figure
from nlobs._typing import Array
from nlobs.errors import InvalidArgumentError
from nlobs.navigation import metrics as navm
from nlobs.navigation.so3 import euler_from_R
from nlobs.simulate.result import SimulationResult

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["euler_error_deg", "plot_euler_error", "plot_ground_track", "plot_navigation", "plot_velocity_error"]

_COLOURS = ("tab:blue", "tab:red")
_AXES = ("North", "East", "Down")
_ANGLES = ("roll", "pitch", "yaw")


def _pick(result: SimulationResult, arr: Array, index: int | tuple[int, ...], tail: int) -> Array:
    """Flight ``index`` of a batched estimate array (``tail`` trailing axes beyond time)."""
    batch = arr.shape[: arr.ndim - 1 - tail]
    if not batch:
        return arr
    idx = index if isinstance(index, tuple) else (index,)
    try:
        return arr[idx]
    except IndexError:
        raise InvalidArgumentError(f"index: {index} is out of range for the batch shape {batch}") from None


def _runs(result: SimulationResult, compare: SimulationResult | None) -> list[SimulationResult]:
    runs = [result] if compare is None else [result, compare]
    for r in runs[1:]:
        if r.t.shape != result.t.shape or not np.allclose(r.t, result.t):
            raise InvalidArgumentError("compare: must be a run on the same time grid as result")
    return runs


def _labels(runs: list[SimulationResult], labels: tuple[str, ...] | None) -> list[str]:
    if labels is None:
        return [r.observer for r in runs]
    if len(labels) != len(runs):
        raise InvalidArgumentError(f"labels: expected {len(runs)} labels, got {len(labels)}")
    return [str(x) for x in labels]


def _finish(fig: Figure, path: str | os.PathLike[str] | None) -> Figure:
    fig.tight_layout()
    if path is not None:
        target = Path(path)
        target.parent.mkdir(parents=True, exist_ok=True)
        save_figure(fig, target, dpi=100)
    return fig


def _new(figsize: tuple[float, float]) -> Figure:
    from matplotlib.figure import Figure

    return Figure(figsize=figsize)


def plot_ground_track(result: SimulationResult, *, compare: SimulationResult | None = None, index: int | tuple[int, ...] = 0,
                      marker_every_s: float = 5.0, labels: tuple[str, ...] | None = None,
                      path: str | os.PathLike[str] | None = None) -> Figure:
    """Fig. 4: true position (markers every ``marker_every_s``) and estimated position (solid)."""
    runs = _runs(result, compare)
    names = _labels(runs, labels)
    fig = _new((11.0, 5.0))
    ax, ax_h = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.3, 1.0]})
    t = result.t
    rate = float(result.info.get("imu_rate_hz", 1.0 / result.dt if result.dt > 0 else 1.0))
    every = max(1, round(marker_every_s * rate))
    p = navm.p(result)
    ax.plot(p[::every, 1], p[::every, 0], "o", ms=3.5, mfc="none", color="0.35", label="true")
    ax_h.plot(t[::every], -p[::every, 2], "o", ms=3.5, mfc="none", color="0.35", label="true")
    for j, (r, c, nm) in enumerate(zip(runs, _COLOURS, names)):
        ph = _pick(r, navm.p_hat(r), index, 1)
        z = 3 - j  # the main result on top
        ax.plot(ph[:, 1], ph[:, 0], "-", color=c, lw=1.3, label=f"{nm} estimate", zorder=z)
        ax_h.plot(t, -ph[:, 2], "-", color=c, lw=1.3, label=f"{nm} estimate", zorder=z)
    ax.plot(p[0, 1], p[0, 0], "k^", ms=8, label="start")
    ax.set_xlabel("East p_e [m]")
    ax.set_ylabel("North p_n [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title("Ground track: true (markers) and estimated (solid)")
    ax_h.set_xlabel("t [s]")
    ax_h.set_ylabel("altitude −p_d [m]")
    ax_h.grid(True, alpha=0.3)
    ax_h.set_title("Altitude")
    return _finish(fig, path)


def _error_figure(result: SimulationResult, runs: list[SimulationResult], labels: list[str], err: list[Array], truth: Array,
                  names: tuple[str, ...],
                  unit_err: str, unit_true: str, title: str, ylim: tuple[float, float] | None,
                  path: str | os.PathLike[str] | None) -> Figure:
    fig = _new((10.0, 8.0))
    axes = fig.subplots(3, 1, sharex=True)
    t = result.t
    for i, ax in enumerate(axes):
        twin = ax.twinx()
        twin.plot(t, truth[:, i], "--", color="0.45", lw=1.0, label="true")
        twin.set_ylabel(f"true {names[i]} [{unit_true}]", color="0.35")
        twin.tick_params(axis="y", colors="0.35")
        for j, (nm, e, c) in enumerate(zip(labels, err, _COLOURS)):
            ax.plot(t, e[:, i], "-", color=c, lw=1.1, label=f"{nm} error", zorder=3 - j)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(f"{names[i]} error [{unit_err}]")
        if ylim is not None:
            ax.set_ylim(*ylim)
        ax.set_zorder(twin.get_zorder() + 1)
        ax.patch.set_visible(False)
        ax.grid(True, alpha=0.3)
        if i == 0:
            h1, l1 = ax.get_legend_handles_labels()
            h2, l2 = twin.get_legend_handles_labels()
            ax.legend(h1 + h2, l1 + l2, loc="upper right", fontsize=8, ncol=3)
    axes[0].set_title(title)
    axes[-1].set_xlabel("t [s]")
    return _finish(fig, path)


def plot_velocity_error(result: SimulationResult, *, compare: SimulationResult | None = None, index: int | tuple[int, ...] = 0,
                        ylim: tuple[float, float] | None = None, labels: tuple[str, ...] | None = None,
                        path: str | os.PathLike[str] | None = None) -> Figure:
    """Fig. 5: velocity estimation error ``v − v̂`` (solid) and true velocity (dashed), N/E/D."""
    runs = _runs(result, compare)
    v = navm.v(result)
    err = [v - _pick(r, navm.v_hat(r), index, 1) for r in runs]
    return _error_figure(result, runs, _labels(runs, labels), err, v, _AXES, "m/s", "m/s",
                         "Velocity estimation error (solid) and true velocity (dashed)", ylim, path)


def euler_error_deg(result: SimulationResult, index: int | tuple[int, ...] = 0) -> Array:
    """``true − estimated`` ZYX Euler angles [deg] of flight ``index``, yaw wrapped to ±180°, shape (K, 3)."""
    est = np.degrees(euler_from_R(_pick(result, navm.R_hat(result), index, 2)))
    true = np.degrees(euler_from_R(navm.R(result)))
    return (true - est + 180.0) % 360.0 - 180.0


def plot_euler_error(result: SimulationResult, *, compare: SimulationResult | None = None, index: int | tuple[int, ...] = 0,
                     ylim: tuple[float, float] | None = None, labels: tuple[str, ...] | None = None,
                     path: str | os.PathLike[str] | None = None) -> Figure:
    """Fig. 6: Euler-angle error ``true − estimate`` (solid) and true Euler angles (dashed), degrees."""
    runs = _runs(result, compare)
    err = [euler_error_deg(r, index) for r in runs]
    true = np.degrees(euler_from_R(navm.R(result)))
    true[:, 2] = np.degrees(np.unwrap(np.radians(true[:, 2])))
    return _error_figure(result, runs, _labels(runs, labels), err, true, _ANGLES, "deg", "deg",
                         "Euler angle error (solid) and true Euler angles (dashed)", ylim, path)


def plot_navigation(result: SimulationResult, directory: str | os.PathLike[str], *,
                    compare: SimulationResult | None = None,
                    index: int | tuple[int, ...] = 0, prefix: str = "nav",
                    velocity_ylim: tuple[float, float] | None = None,
                    euler_ylim: tuple[float, float] | None = None,
                    labels: tuple[str, ...] | None = None) -> dict[str, Path]:
    """Save the three figures as ``{prefix}_ground_track.png``, ``_velocity_error.png``, ``_euler_error.png``."""
    out = Path(directory)
    paths = {
        "ground_track": out / f"{prefix}_ground_track.png",
        "velocity_error": out / f"{prefix}_velocity_error.png",
        "euler_error": out / f"{prefix}_euler_error.png",
    }
    plot_ground_track(result, compare=compare, index=index, labels=labels, path=paths["ground_track"])
    plot_velocity_error(result, compare=compare, index=index, ylim=velocity_ylim, labels=labels,
                        path=paths["velocity_error"])
    plot_euler_error(result, compare=compare, index=index, ylim=euler_ylim, labels=labels, path=paths["euler_error"])
    return paths
