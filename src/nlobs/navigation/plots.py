"""Figures of a navigation run in the style of Grip, Saberi & Johansen, Figs. 4–6.

* :func:`plot_ground_track` (Fig. 4): true position (markers) and estimate (solid)
  in local north–east coordinates, with the altitude ``−p_d`` against time;
* :func:`plot_velocity_error` (Fig. 5): velocity estimation error ``v − v̂`` in N, E, D (one
  panel each) and the true velocity below;
* :func:`plot_euler_error` (Fig. 6): Euler-angle error ``true − estimate`` (yaw wrapped to
  ±180°; one panel each) and the true Euler angles below. The estimate's angles come from the
  projected ``R̂`` by inverse trigonometry.

The error panels are symmetric-logarithmic (linear within the steady-state band, shaded), so the
initial transient and the steady-state error are both visible; the comparison run is drawn on top
with a thinner line.

Each takes the :class:`~nlobs.simulate.SimulationResult` of a navigation run
(:func:`nlobs.navigation.run.run_navigation`; quantities read by :mod:`nlobs.navigation.metrics`)
and optionally a second one (``compare``, e.g. the EKF on the same data) drawn in another
colour; ``index`` picks a flight of a batch. With ``path`` the figure is saved atomically as a
PNG (dpi 100). Matplotlib is imported lazily and only its object API is used (no pyplot state).
"""

from __future__ import annotations

from collections.abc import Sequence

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

_COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange")

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


def _runs(result: SimulationResult, compare: SimulationResult | Sequence[SimulationResult] | None
          ) -> list[SimulationResult]:
    others = [] if compare is None else [compare] if isinstance(compare, SimulationResult) else list(compare)
    if len(others) + 1 > len(_COLOURS):
        raise InvalidArgumentError(f"compare: at most {len(_COLOURS) - 1} runs beside the result, got {len(others)}")
    runs = [result, *others]
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


def plot_ground_track(result: SimulationResult, *, compare: SimulationResult | Sequence[SimulationResult] | None = None,
                      index: int | tuple[int, ...] = 0,
                      marker_every_s: float = 5.0, labels: tuple[str, ...] | None = None,
                      path: str | os.PathLike[str] | None = None) -> Figure:
    """Fig. 4: true position (markers every ``marker_every_s``) and estimated position (solid).

    Parameters
    ----------
    result : SimulationResult
        The navigation run (its truth is drawn).
    compare : SimulationResult or sequence of them, optional
        Other runs on the same time grid (e.g. the EKF and the paper's gains on the same data), each drawn in
        another colour (at most four).
    index : int or tuple of int, optional
        The flight of a batch to draw (default 0; ignored for a single flight).
    marker_every_s : float, optional
        Time between the true-position markers [s] (default 5).
    labels : tuple of str, optional
        Legend names, one per run (default: each run's observer name).
    path : str or path-like, optional
        Save the figure there as a PNG (dpi 100; parent folders are created).

    Returns
    -------
    Figure

    Raises
    ------
    InvalidArgumentError
        ``compare`` is on another time grid, ``index`` is out of range, or ``labels`` has the wrong length.
    """
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
    """One error panel per axis and, below, the true values in one panel (no twin axes).

    The error axes are symmetric-logarithmic, linear within the steady-state band (the 99th
    percentile of every run's ``|error|`` over the second half of the flight), so a large initial
    transient and a small steady-state error are both readable, up to the largest error (the initial one). The
    first comparison run is drawn on top with a thinner line, so neither hides the other; further runs lie below,
    lighter.
    """
    from matplotlib.ticker import NullLocator

    fig = _new((10.0, 9.0))
    axes = fig.subplots(4, 1, sharex=True, gridspec_kw={"height_ratios": [1.0, 1.0, 1.0, 0.8]})
    t = result.t
    half = t >= t[0] + 0.5 * (t[-1] - t[0])
    band = max(float(np.nanpercentile(np.abs(e[half]), 99)) for e in err) if np.any(half) else 1.0
    band = band if np.isfinite(band) and band > 0 else 1.0
    styles = ({"lw": 1.4, "alpha": 0.9}, {"lw": 0.8, "alpha": 0.95}, {"lw": 0.7, "alpha": 0.45})
    for i, ax in enumerate(axes[:3]):
        for j, (nm, e, c) in enumerate(zip(labels, err, _COLOURS)):
            style = {"ls": "-", **styles[min(j, 2)]}
            ax.plot(t, e[:, i], color=c, label=f"{nm}", zorder=2 + j if j < 2 else 1, **style)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(f"{names[i]} error [{unit_err}]")
        if ylim is not None:
            ax.set_ylim(*ylim)
        else:
            ax.set_yscale("symlog", linthresh=band, linscale=1.5)
            ax.axhspan(-band, band, color="0.92", zorder=0, lw=0)
            top = max(float(np.nanmax(np.abs(e[:, i]))) for e in err)
            top = top if np.isfinite(top) else band
            ticks = [0.0, band] + [10.0 ** k for k in range(int(np.ceil(np.log10(band * 1.5))),
                                                            int(np.floor(np.log10(max(top, band)))) + 1)]
            if top > 1.5 * max(ticks):  # the largest error (the initial one) gets its own tick
                ticks.append(float(f"{top:.2g}"))
            ticks = sorted({x for x in ticks} | {-x for x in ticks})
            ax.set_yticks(ticks, [f"{x:.2g}" for x in ticks])
            lim = 1.25 * max(top, band)  # every error whole, the initial transient included
            ax.set_ylim(-lim, lim)
            ax.yaxis.set_minor_locator(NullLocator())
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8, ncol=2)
    axes[0].set_title(f"{title} (linear within ±{band:.2g} {unit_err}, shaded; logarithmic outside)", fontsize=10)
    ax = axes[3]
    for i, (nm, ls) in enumerate(zip(names, ("-", "--", ":"))):
        ax.plot(t, truth[:, i], ls, color="0.3", lw=1.1, label=f"true {nm}")
    ax.set_ylabel(f"true [{unit_true}]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8, ncol=3)
    ax.set_xlabel("t [s]")
    return _finish(fig, path)


def plot_velocity_error(result: SimulationResult, *, compare: SimulationResult | Sequence[SimulationResult] | None = None,
                        index: int | tuple[int, ...] = 0,
                        ylim: tuple[float, float] | None = None, labels: tuple[str, ...] | None = None,
                        path: str | os.PathLike[str] | None = None) -> Figure:
    """Fig. 5: velocity estimation error ``v − v̂`` (solid) and true velocity (dashed), N/E/D.

    Parameters
    ----------
    result : SimulationResult
        The navigation run (its truth is drawn).
    compare : SimulationResult or sequence of them, optional
        Other runs on the same time grid (e.g. the EKF and the paper's gains on the same data), each drawn in
        another colour (at most four).
    index : int or tuple of int, optional
        The flight of a batch to draw (default 0; ignored for a single flight).
    ylim : (float, float), optional
        Limits of the error panels [m/s]; default: symmetric-logarithmic, linear within the steady-state band.
    labels : tuple of str, optional
        Legend names, one per run (default: each run's observer name).
    path : str or path-like, optional
        Save the figure there as a PNG (dpi 100; parent folders are created).

    Returns
    -------
    Figure

    Raises
    ------
    InvalidArgumentError
        ``compare`` is on another time grid, ``index`` is out of range, or ``labels`` has the wrong length.
    """
    runs = _runs(result, compare)
    v = navm.v(result)
    err = [v - _pick(r, navm.v_hat(r), index, 1) for r in runs]
    return _error_figure(result, runs, _labels(runs, labels), err, v, _AXES, "m/s", "m/s",
                         "Velocity estimation error v − v̂", ylim, path)


def euler_error_deg(result: SimulationResult, index: int | tuple[int, ...] = 0) -> Array:
    """``true − estimated`` ZYX Euler angles [deg] of flight ``index``, yaw wrapped to ±180°, shape (K, 3).

    Parameters
    ----------
    result : SimulationResult
        A navigation run (with its truth).
    index : int or tuple of int, optional
        The flight of a batch (default 0; ignored for a single flight).

    Returns
    -------
    ndarray, shape (K, 3)
        ``[roll, pitch, yaw]`` errors [deg].
    """
    est = np.degrees(euler_from_R(_pick(result, navm.R_hat(result), index, 2)))
    true = np.degrees(euler_from_R(navm.R(result)))
    return (true - est + 180.0) % 360.0 - 180.0


def plot_euler_error(result: SimulationResult, *, compare: SimulationResult | Sequence[SimulationResult] | None = None,
                     index: int | tuple[int, ...] = 0,
                     ylim: tuple[float, float] | None = None, labels: tuple[str, ...] | None = None,
                     path: str | os.PathLike[str] | None = None) -> Figure:
    """Fig. 6: Euler-angle error ``true − estimate`` (solid) and true Euler angles (dashed), degrees.

    Parameters
    ----------
    result : SimulationResult
        The navigation run (its truth is drawn).
    compare : SimulationResult or sequence of them, optional
        Other runs on the same time grid (e.g. the EKF and the paper's gains on the same data), each drawn in
        another colour (at most four).
    index : int or tuple of int, optional
        The flight of a batch to draw (default 0; ignored for a single flight).
    ylim : (float, float), optional
        Limits of the error panels [deg]; default: symmetric-logarithmic, linear within the steady-state band.
    labels : tuple of str, optional
        Legend names, one per run (default: each run's observer name).
    path : str or path-like, optional
        Save the figure there as a PNG (dpi 100; parent folders are created).

    Returns
    -------
    Figure

    Raises
    ------
    InvalidArgumentError
        ``compare`` is on another time grid, ``index`` is out of range, or ``labels`` has the wrong length.
    """
    runs = _runs(result, compare)
    err = [euler_error_deg(r, index) for r in runs]
    true = np.degrees(euler_from_R(navm.R(result)))
    true[:, 2] = np.degrees(np.unwrap(np.radians(true[:, 2])))
    return _error_figure(result, runs, _labels(runs, labels), err, true, _ANGLES, "deg", "deg",
                         "Euler angle error, true − estimate", ylim, path)


def plot_navigation(result: SimulationResult, directory: str | os.PathLike[str], *,
                    compare: SimulationResult | Sequence[SimulationResult] | None = None,
                    index: int | tuple[int, ...] = 0, prefix: str = "nav",
                    velocity_ylim: tuple[float, float] | None = None,
                    euler_ylim: tuple[float, float] | None = None,
                    labels: tuple[str, ...] | None = None) -> dict[str, Path]:
    """Save the three figures as ``{prefix}_ground_track.png``, ``_velocity_error.png``, ``_euler_error.png``.

    Parameters
    ----------
    result : SimulationResult
        The navigation run (its truth is drawn).
    directory : str or path-like
        Folder of the PNG files (created if needed).
    compare : SimulationResult or sequence of them, optional
        Other runs on the same time grid, each drawn in another colour (at most four).
    index : int or tuple of int, optional
        The flight of a batch to draw (default 0; ignored for a single flight).
    prefix : str, optional
        File-name prefix (default ``"nav"``).
    velocity_ylim, euler_ylim : (float, float), optional
        The ``ylim`` of :func:`plot_velocity_error` [m/s] and :func:`plot_euler_error` [deg].
    labels : tuple of str, optional
        Legend names, one per run (default: each run's observer name).

    Returns
    -------
    dict of str to Path
        The files written, by key ``"ground_track"``, ``"velocity_error"``, ``"euler_error"``.

    Examples
    --------
    Figs. 4–6 of Grip, Saberi & Johansen for the first 5 s of the traffic pattern, observer (24) with the
    paper's gains started 30° off in yaw, written to a fresh folder:

    >>> import math
    >>> import tempfile
    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.navigation import nav_vector, traffic_pattern
    >>> from nlobs.navigation.so3 import rot_z
    >>> traj = traffic_pattern(seed=0, duration=5.0).sample(50.0)
    >>> u, fixes = np.hstack([traj.omega_b, traj.a_b, traj.m_b]), slice(None, None, 10)  # IMU 50 Hz, GNSS 5 Hz
    >>> x_hat0 = nav_vector(traj.p[0], traj.v[0], rot_z(math.radians(30.0)) @ traj.R[0])
    >>> res = nlobs.run_observer(nlobs.GnssInsObserver.paper(traj.m_n, traj.g_n), traj.t, x_hat0=x_hat0, u=u,
    ...                          y=np.hstack([traj.p, traj.v])[fixes], y_times=traj.t[fixes],
    ...                          truth=nav_vector(traj.p, traj.v, traj.R))
    >>> files = plot_navigation(res, tempfile.mkdtemp(), prefix="takeoff")
    >>> {key: path.name for key, path in files.items()}
    {'ground_track': 'takeoff_ground_track.png', 'velocity_error': 'takeoff_velocity_error.png',
     'euler_error': 'takeoff_euler_error.png'}
    >>> all(path.read_bytes()[1:4] == b"PNG" for path in files.values())  # the PNG signature
    True
    """
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
