r"""What a comparison reports of a closed loop and of state bounds: deviations from the reference loop, inputs,
and how often the truth and each estimate leave the model file's ``[constraints]``.

A model file with a ``[controller]`` makes ``nlobs simulate`` close the loop ``u = k(x̂, t)`` around each observer
and, as the reference, around the true state on the same noise (:func:`nlobs.simulate.simulate` with
``feedback="state"``). Separation does not hold for nonlinear plants: the reference is what the law does with
perfect state knowledge, and each observer's ``rms_deviation`` is the RMS of ``‖x − x_ref‖`` over the runs after
the settling time — the price of estimating (Khalil & Praly 2014 discuss the peaking of high-gain observers that
makes it large, and the saturation that bounds it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from nlobs._schema import INTEGER, NUMBER, STRING, Record, array, nullable
from nlobs._typing import Array

__all__ = ["CLOSED_LOOP_JSON", "CLOSED_LOOP_SETUP_JSON", "CONSTRAINTS_JSON", "ESTIMATE_BOUNDS_JSON",
           "bounds_report", "closed_loop_metrics", "estimate_bounds", "loop_setup"]

#: A run of a closed loop diverged when ``‖x − x_ref‖`` exceeds this many times ``1 + max‖x_ref‖`` (or is not finite).
LOOP_BLOWUP = 1e6

#: One observer's closed loop (``observers.<name>.closed_loop`` of ``nlobs simulate MODEL``).
CLOSED_LOOP_JSON = Record("ClosedLoop", {
    "rms_deviation": NUMBER.about("RMS of ‖x − x_ref‖ after the settling time over the runs that did not diverge: "
                                  "the loop around this observer against the loop around the true state"),
    "rms_deviation_states": array(NUMBER, "per state, the same RMS of x − x_ref"),
    "peak_input": array(NUMBER, "per input, the largest |u| over the runs and the whole time"),
    "rms_input": array(NUMBER, "per input, RMS of u over the runs that did not diverge, whole run"),
    "diverged_runs": INTEGER.about("runs whose plant or estimate blew up in closed loop"),
})

#: The reference loop (``closed_loop.reference``).
REFERENCE_LOOP_JSON = Record("ReferenceLoop", {
    "rms_state": array(NUMBER, "per state, RMS of x after the settling time"),
    "rms_input": array(NUMBER, "per input, RMS of u over the whole run"),
    "peak_input": array(NUMBER, "per input, the largest |u|"),
    "diverged_runs": INTEGER,
})

#: The closed loop of a comparison (top-level ``closed_loop`` of ``nlobs simulate MODEL``).
CLOSED_LOOP_SETUP_JSON = Record("ClosedLoopSetup", {
    "law": array(STRING, "per input, the expression of the [controller] table"),
    "inputs": array(STRING),
    "rate": NUMBER.about("the controller's rate (null: at every step)"),
    "saturation": nullable(array(array(NUMBER), "per input [lo, hi]")),
    "reference": REFERENCE_LOOP_JSON.about("the law fed the true state, on the same noise"),
})

#: How often one observer's estimate left the bounds (``observers.<name>.constraints``).
ESTIMATE_BOUNDS_JSON = Record("EstimateBounds", {
    "outside_fraction": NUMBER.about("fraction of the saved instants of all runs whose estimate was outside"),
    "runs_outside": INTEGER.about("runs whose estimate left the bounds at least once"),
    "states_outside": array(NUMBER, "per state, the fraction of instants outside its own bounds"),
})

#: The bounds of a comparison (top-level ``constraints`` of ``nlobs simulate MODEL``).
CONSTRAINTS_JSON = Record("Constraints", {
    "lower": array(NUMBER, "per state (null: -inf)"),
    "upper": array(NUMBER, "per state (null: inf)"),
    "truth_runs_outside": INTEGER.about("runs whose true state left the bounds at least once"),
    "truth_outside_fraction": NUMBER,
    "box_runs_outside": nullable(INTEGER.about("runs whose true state left the [simulation] box (null: no box)")),
})


def _rms(a: Array, axis: Any) -> Any:
    with np.errstate(all="ignore"):
        return np.sqrt(np.mean(a * a, axis=axis)) if a.size else np.full(a.shape[-1], math.nan)


def _floats(v: Any) -> list[float]:
    return [float(e) for e in np.asarray(v, dtype=float).reshape(-1)]


def _loop_diverged(x: Array, x_ref: Array) -> Array:
    """Per run: the plant left the reference by more than :data:`LOOP_BLOWUP` (1 + max‖x_ref‖), or is not finite."""
    with np.errstate(all="ignore"):
        dev = np.linalg.norm(x - x_ref, axis=-1)
        scale = 1.0 + np.nanmax(np.linalg.norm(x_ref, axis=-1), axis=-1)
        return ~np.isfinite(dev).all(axis=-1) | (np.nanmax(np.where(np.isfinite(dev), dev, 0.0), axis=-1)
                                                > LOOP_BLOWUP * scale)


def closed_loop_metrics(x: Array, u: Array, x_hat: Array, x_ref: Array, t: Array, settle: float) -> dict[str, Any]:
    """One observer's closed loop against the reference loop (:data:`CLOSED_LOOP_JSON`).

    Parameters
    ----------
    x, x_hat : ndarray, shape (runs, K, n)
        The plant and the estimate of the loop around the observer.
    u : ndarray, shape (runs, K, m)
        The input it applied.
    x_ref : ndarray, shape (runs, K, n)
        The plant of the reference loop (the law fed the true state) on the same noise.
    t : ndarray, shape (K,)
    settle : float
        Deviations are averaged for ``t ≥ settle``.

    Returns
    -------
    dict
        ``rms_deviation``, ``rms_deviation_states``, ``peak_input``, ``rms_input``, ``diverged_runs``.

    Examples
    --------
    Two runs whose loops sit 0.1 and 0.3 away from the reference after the settling time:

    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 11)
    >>> x_ref = np.zeros((2, 11, 1))
    >>> x = x_ref + np.array([0.1, 0.3])[:, None, None]
    >>> u = np.ones((2, 11, 1))
    >>> m = closed_loop_metrics(x, u, x, x_ref, t, 0.5)
    >>> round(m["rms_deviation"], 6), m["peak_input"], m["diverged_runs"]  # √((0.01 + 0.09)/2)
    (0.223607, [1.0], 0)
    """
    bad = _loop_diverged(x, x_ref) | ~np.isfinite(x_hat).all(axis=(-1, -2))
    ok = ~bad
    after = t >= settle - 1e-12
    d = (x - x_ref)[ok][:, after]
    with np.errstate(all="ignore"):
        norm = float(np.sqrt(np.mean(np.sum(d * d, axis=-1)))) if d.size else math.nan
        peak = np.nanmax(np.abs(np.where(np.isfinite(u), u, np.nan)), axis=(0, 1)) if u.size and np.isfinite(u).any() \
            else np.full(u.shape[-1], math.nan)
    return CLOSED_LOOP_JSON.emit({
        "rms_deviation": norm,
        "rms_deviation_states": _floats(_rms(d, (0, 1))),
        "peak_input": _floats(peak),
        "rms_input": _floats(_rms(u[ok], (0, 1))),
        "diverged_runs": int(bad.sum()),
    })


def loop_setup(controller: Any, x_ref: Array, u_ref: Array, t: Array, settle: float) -> dict[str, Any]:
    """The comparison's top-level ``closed_loop``: the law and the reference loop (:data:`CLOSED_LOOP_SETUP_JSON`).

    Parameters
    ----------
    controller : ControlLaw
        The model file's law.
    x_ref : ndarray, shape (runs, K, n)
        The reference loop's plant.
    u_ref : ndarray, shape (runs, K, m)
        Its input.
    t : ndarray, shape (K,)
    settle : float

    Returns
    -------
    dict

    Examples
    --------
    >>> import numpy as np
    >>> from nlobs.systems.controller import ControlLaw
    >>> k = ControlLaw(["p", "v"], ["F"], ["-p - v"], saturation=[-1, 1])
    >>> t = np.linspace(0.0, 1.0, 3)
    >>> out = loop_setup(k, np.ones((1, 3, 2)), -np.ones((1, 3, 1)), t, 0.0)
    >>> out["law"], out["saturation"], out["reference"]["rms_state"], out["reference"]["peak_input"]
    (['-p - v'], [[-1.0, 1.0]], [1.0, 1.0], [1.0])
    """
    sat = getattr(controller, "saturation", None)
    after = t >= settle - 1e-12
    bad = ~np.isfinite(x_ref).all(axis=(-1, -2))
    ok = ~bad
    with np.errstate(all="ignore"):
        peak = np.nanmax(np.abs(u_ref[ok]), axis=(0, 1)) if u_ref[ok].size else np.full(u_ref.shape[-1], math.nan)
    return CLOSED_LOOP_SETUP_JSON.emit({
        "law": list(getattr(controller, "law", ())),
        "inputs": list(getattr(controller, "inputs", ())),
        "rate": getattr(controller, "rate", None),
        "saturation": None if sat is None else [[float(lo), float(hi)] for lo, hi in zip(*sat)],
        "reference": REFERENCE_LOOP_JSON.emit({
            "rms_state": _floats(_rms(x_ref[ok][:, after], (0, 1))),
            "rms_input": _floats(_rms(u_ref[ok], (0, 1))),
            "peak_input": _floats(peak),
            "diverged_runs": int(bad.sum()),
        }),
    })


def estimate_bounds(bounds: Any, x_hat: Array) -> dict[str, Any]:
    """How often an estimate ``(runs, K, n)`` left the bounds (:data:`ESTIMATE_BOUNDS_JSON`).

    Parameters
    ----------
    bounds : StateBounds
    x_hat : ndarray, shape (runs, K, n)

    Returns
    -------
    dict

    Examples
    --------
    >>> import numpy as np
    >>> from nlobs.systems.constraints import StateBounds
    >>> b = StateBounds([0.0, 0.0], [1.0, 1.0])
    >>> xh = np.array([[[0.5, 0.5], [1.5, 0.5]], [[0.5, 0.5], [0.5, 0.5]]])  # run 0 leaves at its second instant
    >>> estimate_bounds(b, xh)
    {'outside_fraction': 0.25, 'runs_outside': 1, 'states_outside': [0.25, 0.0]}
    """
    xh = np.asarray(x_hat, dtype=float)
    with np.errstate(invalid="ignore"):
        per_state = ((xh < bounds.lower) | (xh > bounds.upper)) & np.isfinite(xh)
    outside = per_state.any(axis=-1)
    return ESTIMATE_BOUNDS_JSON.emit({
        "outside_fraction": float(outside.mean()) if outside.size else math.nan,
        "runs_outside": int(outside.any(axis=-1).sum()),
        "states_outside": _floats(per_state.mean(axis=(0, 1))) if per_state.size else [math.nan] * xh.shape[-1],
    })


def bounds_report(bounds: Any, x: Array, box: tuple[Array, Array] | None) -> dict[str, Any]:
    """The comparison's top-level ``constraints``: the bounds and how often the truth left them (and the box).

    Parameters
    ----------
    bounds : StateBounds
    x : ndarray, shape (runs, K, n)
        The true states.
    box : tuple of ndarray or None
        The ``[simulation] box`` ``(lo, hi)``.

    Returns
    -------
    dict

    Examples
    --------
    >>> import numpy as np
    >>> from nlobs.systems.constraints import StateBounds
    >>> b = StateBounds([0.0], [np.inf])
    >>> out = bounds_report(b, np.array([[[0.5], [-0.1]], [[0.2], [0.3]]]), (np.array([0.0]), np.array([0.4])))
    >>> out["upper"], out["truth_runs_outside"], out["truth_outside_fraction"], out["box_runs_outside"]
    ([None], 1, 0.25, 1)
    """
    xa = np.asarray(x, dtype=float)
    outside = ~bounds.inside(xa) & np.isfinite(xa).all(axis=-1)
    box_runs = None
    if box is not None:
        lo, hi = box
        box_out = (np.any((xa < lo) | (xa > hi), axis=-1)) & np.isfinite(xa).all(axis=-1)
        box_runs = int(box_out.any(axis=-1).sum())
    return CONSTRAINTS_JSON.emit({
        "lower": [None if math.isinf(v) else float(v) for v in bounds.lower.tolist()],
        "upper": [None if math.isinf(v) else float(v) for v in bounds.upper.tolist()],
        "truth_runs_outside": int(outside.any(axis=-1).sum()),
        "truth_outside_fraction": float(outside.mean()) if outside.size else math.nan,
        "box_runs_outside": box_runs,
    })


def warnings_of(bounds_json: Mapping[str, Any] | None, runs: int) -> list[str]:
    """The summary's warnings about the truth leaving the bounds or the box (one line each)."""
    if not bounds_json:
        return []
    out = []
    if bounds_json["truth_runs_outside"]:
        out.append(f"the true state left the [constraints] in {bounds_json['truth_runs_outside']}/{runs} runs "
                   f"({100 * bounds_json['truth_outside_fraction']:.3g} % of the instants): the model or its noise "
                   "breaks its own bounds")
    if bounds_json.get("box_runs_outside"):
        out.append(f"the true state left the [simulation] box in {bounds_json['box_runs_outside']}/{runs} runs: "
                   "the designs' region does not hold the runs")
    return out
