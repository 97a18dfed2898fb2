"""An nlobs observer as a python-control input/output system (``observer.to_control()``).

python-control (an optional extra, ``pip install 'nlobs[control]'``) interconnects systems by
signal names (``control.interconnect``) and simulates them (``control.input_output_response``).
:func:`to_control` wraps an observer of the one protocol (:mod:`nlobs.observers.base`) whose state
is an array as a ``control.NonlinearIOSystem``:

* inputs ``[u, y]``: the plant's known input, then its measured output (names ``u[i]``/``y[j]``
  or the plant's own names when the observer knows them);
* state: the observer's state ``z`` (``observer.init(x̂0)`` is its initial value);
* outputs: the estimate ``x̂ = observer.estimate(z)`` (names ``<state>_hat``);
* ``updfcn = observer.rhs`` (continuous: ``ż``; discrete, ``dt = Discrete.dt``: ``z⁺``).

A correcting observer (an EKF updated at sample instants, the GNSS/INS observer) is a
continuous-discrete system that python-control cannot represent, and one with a structured state
(a covariance, set-valued radii) has no flat state vector: both are refused with a typed error.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from nlobs.errors import InvalidArgumentError

__all__ = ["to_control"]


def _names_of(obj: Any, attr: str) -> tuple[str, ...] | None:
    names = getattr(obj, attr, None)
    return tuple(str(s) for s in names) if names is not None else None


def _io_names(observer: Any) -> tuple[tuple[str, ...] | None, tuple[str, ...] | None, tuple[str, ...] | None]:
    """(input names, output names, state names) of the plant the observer is for, where it says."""
    for attr in ("system", "plant", "model"):
        plant = getattr(observer, attr, None)
        if plant is not None and hasattr(plant, "outputs"):
            return _names_of(plant, "inputs"), _names_of(plant, "outputs"), _names_of(plant, "states")
    s1, s2 = getattr(observer, "sigma1", None), getattr(observer, "sigma2", None)
    if s1 is not None and s2 is not None:
        return _names_of(s1, "inputs"), _names_of(s2, "outputs"), (*s1.states, *s2.states)
    return None, None, None


def _labels(given: int | Sequence[str] | None, found: tuple[str, ...] | None, prefix: str, what: str,
            observer: Any) -> list[str]:
    if given is None:
        if found is None:
            raise InvalidArgumentError(
                f"to_control: {type(observer).__name__} does not say how many plant {what} it takes; "
                f"give {what}=<count or names>")
        return list(found)
    if isinstance(given, (int, np.integer)) and not isinstance(given, bool):
        if given < 0:
            raise InvalidArgumentError(f"{what}: must be >= 0, got {given}")
        return [f"{prefix}[{i}]" for i in range(int(given))]
    return [str(s) for s in given]


def to_control(observer: Any, *, inputs: int | Sequence[str] | None = None,
               outputs: int | Sequence[str] | None = None, name: str | None = None) -> Any:
    """``observer`` as a ``control.NonlinearIOSystem`` (module docstring).

    Parameters
    ----------
    observer : Observer
        An observer of the one protocol with an array state (not a correcting observer).
    inputs, outputs : int or sequence of str, optional
        The plant's known inputs ``u`` and measured outputs ``y`` (a count or names); default:
        the names of the plant the observer was built for.
    name : str, optional
        The system's name (default: the observer's ``name``, else ``"observer"``).

    Returns
    -------
    control.NonlinearIOSystem
        Inputs ``[*inputs, *outputs]``, outputs the estimate, ``states`` the size of ``z``.

    Raises
    ------
    InvalidArgumentError
        python-control is not installed; a correcting observer or one whose state is not an array;
        unknown numbers of inputs or outputs.
    """
    from nlobs.observers.base import CorrectingObserver, Observer

    try:
        import control
    except ImportError:
        raise InvalidArgumentError("to_control: python-control is not installed: pip install 'nlobs[control]'") \
            from None
    if not isinstance(observer, Observer):
        raise InvalidArgumentError(f"to_control: {type(observer).__name__} is not an nlobs observer")
    if isinstance(observer, CorrectingObserver):
        raise InvalidArgumentError(
            f"to_control: {type(observer).__name__} corrects at sample instants (a continuous-discrete system), "
            "which python-control's input/output systems cannot represent")
    n = int(observer.n_x)
    z0 = observer.init(np.zeros(n))
    if not isinstance(z0, np.ndarray):
        raise InvalidArgumentError(
            f"to_control: the state of {type(observer).__name__} is a {type(z0).__name__}, not an array")
    found_u, found_y, found_x = _io_names(observer)
    u_names = _labels(inputs, found_u, "u", "inputs", observer)
    y_names = _labels(outputs, found_y, "y", "outputs", observer)
    m = len(u_names)
    x_names = [f"{s}_hat" for s in found_x] if found_x is not None and len(found_x) == n else \
        [f"xhat[{i}]" for i in range(n)]
    nz = int(z0.size)

    def updfcn(t: float, z: Any, uy: Any, params: Any) -> Any:
        uy = np.asarray(uy, dtype=float).reshape(-1)
        return np.asarray(observer.rhs(float(t), np.asarray(z, dtype=float), uy[:m], uy[m:]), dtype=float)

    def outfcn(t: float, z: Any, uy: Any, params: Any) -> Any:
        return np.asarray(observer.estimate(np.asarray(z, dtype=float)), dtype=float)

    time = observer.time
    dt = float(time.dt) if time.is_discrete else 0
    label = name if name is not None else str(getattr(observer, "name", "") or "observer")
    return control.nlsys(updfcn, outfcn, inputs=[*u_names, *y_names], outputs=x_names, states=nz, dt=dt,
                         name=label)
