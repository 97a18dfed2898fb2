r"""The one observer protocol of nlobs: explicit state in, explicit state out.

An observer is a dynamical system driven by the plant's known input ``u`` and the
measurement ``y``. It never stores its state: the loop (:func:`nlobs.simulate.simulate`
for plant and observer together, :func:`nlobs.simulate.run_observer` on recorded data)
passes the observer state ``z`` in and receives the new one back. The protocol is generic
in the type ``Z`` of that state: an array for most observers, a frozen dataclass of arrays
for the Kalman filters (mean and covariance), the set-valued observer (centres and radii)
and the GNSS/INS observer (``p̂, v̂, ξ, R̂`` and the held fix).

Every array carries leading batch axes (Monte Carlo runs): ``u`` of shape ``(..., m)``,
``y`` of shape ``(..., p)``, estimates of shape ``(..., n_x)``.

The protocol
------------
:class:`Observer` — ``time``, ``n_x``, ``init``, ``rhs``, ``estimate``:

* continuous time (``time = Continuous()``): ``rhs(t, z, u, y)`` is ``ż``, a value of the
  same type as ``z`` (the loop integrates it with RK4 when ``z`` is an array);
* discrete time (``time = Discrete(dt)``): ``rhs(t_k, z_k, u_k, y_k)`` is ``z_{k+1}``.

:class:`CorrectingObserver` adds ``correct(t, z, u, y, fresh)``: a discrete update made at an
instant where at least one output was sampled (``fresh[j]`` is True for a new sample of output
``j``), before the estimate at that instant is recorded (an EKF update at a GNSS fix). A
non-finite entry of ``y`` at a sampled output is a missing sample *for that batch member*: a
correcting observer skips it there (it keeps its previous information), or, when skipping would
void what it guarantees, refuses it with a typed error naming the time (the set-valued observer of
Khajenejad & Yong: Algorithm 1 and its radii need every output at every step).

Optional capabilities
---------------------
The loops look for these methods and use them when present (each is a small protocol below):

* :class:`SelfStepping` — ``step(t, z, u, y, h)``: the observer's own advance over ``[t, t + h]``
  with ``u`` and ``y`` held: its discretisation of the continuous dynamics (an exact or split
  integrator, e.g. the Strang split of the GNSS/INS observer and its fused single-flight kernel)
  and, for a filter, the fusion of input-rate channels that ``rhs`` leaves out (the navigation
  EKF fuses the magnetometer, an input channel, after its prediction). A continuous observer
  that has it is advanced by it instead of by RK4 on ``rhs``.
* :class:`Diagnosing` — ``diagnostics(z, u)``: named arrays recorded at every saved step as
  extras of the result (radii, covariance diagonals, raw attitude...).
* :class:`DeferredEstimate` — ``raw_estimate(z)`` and ``finish_estimates(raw)``: the loop records
  the cheap raw estimate at every step and turns the whole record into estimates (and extras) in
  one call at the end (the GNSS/INS observer projects ``R̂`` onto SO(3) once per run instead of
  once per step).
* :class:`RecordRunning` — ``run_records(t, z0, u, y, sampled)``: every run over a whole record in
  one call (an observer whose step is compiled code: no Python per step); :func:`~nlobs.simulate.run_observer`
  uses it for an observer without diagnostics, and takes the step-by-step loop when it returns ``None``.
* ``state_names`` — names used in divergence reports (default ``z[i]``, or a dataclass field).
* ``name`` — a short label (results and progress bars).

Every observer class of nlobs also has :meth:`ToControl.to_control` (python-control interop).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol, TypeVar, runtime_checkable

from nlobs._typing import Array, BoolArray
from nlobs.errors import InvalidArgumentError
from nlobs.systems.timebase import TimeBase

Z = TypeVar("Z")

__all__ = ["CorrectingObserver", "DeferredEstimate", "Diagnosing", "Observer", "RecordRunning", "SelfStepping",
           "ToControl", "Z", "to_control"]


class ToControl:
    """Gives an observer ``to_control()``: itself as a python-control input/output system.

    A mix-in of every nlobs observer (no state, no fields); see :func:`to_control`.
    """

    __slots__ = ()

    def to_control(self, *, inputs: Any = None, outputs: Any = None, name: str | None = None) -> Any:
        """This observer as a ``control.NonlinearIOSystem``: inputs ``[u, y]``, state ``z``, outputs ``x̂``.

        See :func:`to_control` (python-control is an optional extra).

        Raises
        ------
        InvalidArgumentError
            python-control is missing, or the observer is a correcting observer or has a
            structured state (python-control cannot represent either).
        """
        return to_control(self, inputs=inputs, outputs=outputs, name=name)


@runtime_checkable
class Observer(Protocol[Z]):
    """Protocol of every estimator in nlobs (module docstring).

    Attributes
    ----------
    time : Continuous or Discrete
        Time base of the observer dynamics.
    n_x : int
        Dimension of the plant-state estimate returned by :meth:`estimate`.

    Examples
    --------
    Any class with these five members is an observer: here a hand-written discrete-time observer of the
    scalar plant ``x⁺ = 0.5 x``, ``y = x``, whose error obeys ``e⁺ = (0.5 − 0.3) e``, run by the one loop:

    >>> import numpy as np
    >>> import nlobs
    >>> class Copy:
    ...     time = nlobs.Discrete(1.0)
    ...     n_x = 1
    ...     def init(self, x_hat0):
    ...         return np.array(x_hat0, dtype=float)
    ...     def rhs(self, t, z, u, y):
    ...         return 0.5 * z + 0.3 * (y - z)
    ...     def estimate(self, z):
    ...         return z
    >>> isinstance(Copy(), nlobs.Observer), isinstance(Copy(), nlobs.CorrectingObserver)
    (True, False)
    >>> plant = nlobs.LinearSystem([[0.5]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
    >>> res = nlobs.simulate(plant, Copy(), [1.0], [0.0], duration=3.0)
    >>> (res.x - res.x_hat)[:, 0].round(6)
    array([1.   , 0.2  , 0.04 , 0.008])
    """

    time: TimeBase

    @property
    def n_x(self) -> int: ...

    def init(self, x_hat0: Array) -> Z:
        """Observer state from an initial estimate ``x̂0`` of shape ``(..., n_x)``.

        Parameters
        ----------
        x_hat0 : ndarray, shape (..., n_x)
            The initial estimate (leading axes: a batch of runs).

        Returns
        -------
        Z
            The observer state (an array, or a frozen dataclass of arrays).
        """
        ...

    def rhs(self, t: float, z: Z, u: Array, y: Array) -> Z:
        """``ż`` (continuous) or ``z⁺`` (discrete), given the input ``u`` and the (held) measurement ``y``.

        Parameters
        ----------
        t : float
            Time.
        z : Z
            The observer state.
        u : ndarray, shape (..., m)
            The plant's known input.
        y : ndarray, shape (..., p)
            The measurement (held since its last sample).

        Returns
        -------
        Z
            ``ż`` or ``z⁺``, of the type of ``z``.
        """
        ...

    def estimate(self, z: Z) -> Array:
        """The plant-state estimate ``x̂``, shape ``(..., n_x)``.

        Parameters
        ----------
        z : Z
            The observer state.

        Returns
        -------
        ndarray, shape (..., n_x)
        """
        ...


@runtime_checkable
class CorrectingObserver(Observer[Z], Protocol[Z]):
    """An observer that also makes a discrete correction when a sample arrives (module docstring).

    Examples
    --------
    The impulsive observer is a correcting one: a fresh sample of its output moves the estimate by
    ``L (y − h(x̂))``; a missing (non-finite) sample is skipped, and an output that was not sampled is not used:

    >>> import numpy as np
    >>> import nlobs
    >>> plant = nlobs.LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.ImpulsiveObserver(plant, [[1.0], [0.5]])
    >>> isinstance(observer, nlobs.CorrectingObserver)
    True
    >>> z, u, fresh = observer.init([0.0, 0.0]), np.zeros(1), np.array([True])
    >>> observer.correct(0.0, z, u, np.array([2.0]), fresh)
    array([2., 1.])
    >>> observer.correct(0.0, z, u, np.array([np.nan]), fresh)
    array([0., 0.])
    >>> observer.correct(0.0, z, u, np.array([2.0]), np.array([False]))
    array([0., 0.])
    """

    def correct(self, t: float, z: Z, u: Array, y: Array, fresh: BoolArray) -> Z:
        """The corrected state; ``fresh[j]`` is True where output ``j`` was just sampled.

        Parameters
        ----------
        t : float
            The sample instant.
        z : Z
            The observer state before the correction.
        u : ndarray, shape (..., m)
            The known input.
        y : ndarray, shape (..., p)
            The measurement; a non-finite entry at a sampled output is a missing sample for that
            batch member (skipped, or refused with a typed error where skipping would void a guarantee).
        fresh : ndarray of bool, shape (p,)
            Which outputs were sampled at ``t``.

        Returns
        -------
        Z
            The corrected state.
        """
        ...


@runtime_checkable
class SelfStepping(Protocol[Z]):
    """A continuous-time observer with its own advance over one held step (module docstring).

    Examples
    --------
    The observer ``x̂' = 2 (y − x̂)`` of a constant plant ``x = 1`` has, with ``y`` held over a step, the exact
    advance ``x̂ + (y − x̂)(1 − e^{−2h})``. Given as ``step``, the loop uses it instead of RK4 on ``rhs``, and the
    estimate is ``1 − e^{−2t}`` at every grid time, even with the coarse step ``h = 0.5`` where RK4 is off:

    >>> import numpy as np
    >>> import nlobs
    >>> class Exact:
    ...     time = nlobs.Continuous()
    ...     n_x = 1
    ...     def init(self, x_hat0):
    ...         return np.array(x_hat0, dtype=float)
    ...     def rhs(self, t, z, u, y):
    ...         return 2.0 * (y - z)
    ...     def estimate(self, z):
    ...         return z
    ...     def step(self, t, z, u, y, h):
    ...         return z + (y - z) * (1.0 - np.exp(-2.0 * h))
    >>> class ByRK4(Exact):
    ...     step = None  # no step of its own: RK4 on rhs
    >>> isinstance(Exact(), SelfStepping), isinstance(ByRK4(), SelfStepping)
    (True, False)
    >>> plant = nlobs.LinearSystem([[0.0]], np.zeros((1, 0)), [[1.0]])
    >>> own = nlobs.simulate(plant, Exact(), [1.0], [0.0], duration=2.0, dt=0.5)
    >>> rk4 = nlobs.simulate(plant, ByRK4(), [1.0], [0.0], duration=2.0, dt=0.5)
    >>> own.method, rk4.method
    ('rk4+observer step', 'rk4')
    >>> bool(np.allclose(own.x_hat[:, 0], 1.0 - np.exp(-2.0 * own.t)))
    True
    >>> round(float(own.x_hat[-1, 0]), 4), round(float(rk4.x_hat[-1, 0]), 4)  # 1 − e^{−4} = 0.9817 at t = 2
    (0.9817, 0.9802)
    """

    def step(self, t: float, z: Z, u: Array, y: Array, h: float) -> Z:
        """The state at ``t + h`` from the state at ``t``, ``u`` and ``y`` held over the step."""
        ...


@runtime_checkable
class Diagnosing(Protocol[Z]):
    """An observer with named internal quantities worth recording (extras of the result).

    Examples
    --------
    A scalar Kalman filter for a constant ``x⁺ = x`` measured as ``y = x + v`` (``R = 1``, no process noise)
    keeps its variance ``P`` in its state ``[x̂, P]``; ``diagnostics`` names it, and the loop records it at every
    saved step in ``extras``: ``P_k = P₀ / (1 + k P₀)``, and the estimate is the running mean of the samples:

    >>> import numpy as np
    >>> import nlobs
    >>> class ScalarKalman:
    ...     time = nlobs.Discrete(1.0)
    ...     n_x = 1
    ...     def init(self, x_hat0):
    ...         return np.concatenate([np.array(x_hat0, dtype=float), [1.0]])  # P0 = 1
    ...     def rhs(self, t, z, u, y):
    ...         x, P = z[..., :1], z[..., 1:]
    ...         K = P / (P + 1.0)
    ...         return np.concatenate([x + K * (y - x), P - K * P], axis=-1)
    ...     def estimate(self, z):
    ...         return z[..., :1]
    ...     def diagnostics(self, z, u):
    ...         return {"P": z[..., 1]}
    >>> isinstance(ScalarKalman(), Diagnosing)
    True
    >>> plant = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
    >>> res = nlobs.simulate(plant, ScalarKalman(), [1.0], [0.0], duration=3.0)
    >>> np.round(res.extras["P"], 4).tolist(), np.round(res.x_hat[:, 0], 4).tolist()
    ([1.0, 0.5, 0.3333, 0.25], [0.0, 0.5, 0.6667, 0.75])
    """

    def diagnostics(self, z: Z, u: Array) -> Mapping[str, Array]:
        """Named arrays of shape ``(..., *item_shape)`` at the current state."""
        ...


@runtime_checkable
class DeferredEstimate(Protocol[Z]):
    """An observer whose estimate is a costly map of a cheap raw one, applied once to the record.

    Examples
    --------
    An observer of a point on the unit circle whose raw estimate (a plain average with the measurement) leaves the
    circle; its estimate is the projection back onto it, which ``finish_estimates`` makes once for the whole record
    and returns with the raw norms as an extra:

    >>> import numpy as np
    >>> import nlobs
    >>> class OnCircle:
    ...     time = nlobs.Discrete(1.0)
    ...     n_x = 2
    ...     def init(self, x_hat0):
    ...         return np.array(x_hat0, dtype=float)
    ...     def rhs(self, t, z, u, y):
    ...         return 0.5 * (z + y)
    ...     def estimate(self, z):
    ...         return z / np.linalg.norm(z, axis=-1, keepdims=True)
    ...     def raw_estimate(self, z):
    ...         return z
    ...     def finish_estimates(self, raw):
    ...         norm = np.linalg.norm(raw, axis=-1, keepdims=True)
    ...         return raw / norm, {"raw_norm": norm[..., 0]}
    >>> isinstance(OnCircle(), DeferredEstimate)
    True
    >>> plant = nlobs.LinearSystem(np.eye(2), np.zeros((2, 0)), np.eye(2), time=nlobs.Discrete(1.0))
    >>> res = nlobs.simulate(plant, OnCircle(), [1.0, 0.0], [0.0, 2.0], duration=3.0)
    >>> np.round(res.extras["raw_norm"], 3).tolist()
    [2.0, 1.118, 0.901, 0.91]
    >>> bool(np.allclose(np.linalg.norm(res.x_hat, axis=-1), 1.0)), np.round(res.x_hat[-1], 3).tolist()
    (True, [0.962, 0.275])
    """

    def raw_estimate(self, z: Z) -> Array:
        """The raw estimate, shape ``(..., n_x)``."""
        ...

    def finish_estimates(self, raw: Array) -> tuple[Array, Mapping[str, Array]]:
        """Estimates ``(..., K, n_x)`` from the recorded raw ones ``(..., K, n_x)``, and extras to keep.

        ``raw`` may be the loop's own record, handed over writable: the observer may then write the
        estimates into it and return it (extras must not be views of what it overwrites).
        """
        ...


@runtime_checkable
class RecordRunning(Protocol[Z]):
    """An observer that runs whole records in one call (module docstring)."""

    def run_records(self, t: Array, z0: Z, u: Array, y: Array, sampled: BoolArray) -> Array | None:
        """The estimates (raw ones for a :class:`DeferredEstimate`) of every run at every instant of ``t``.

        Parameters
        ----------
        t : ndarray, shape (K,)
            The time grid.
        z0 : Z
            The initial state of every run (leading batch axes).
        u : ndarray, shape (*batch, K, m)
            The known input at each instant, held over the step after it.
        y : ndarray, shape (*batch, K, p)
            The measurement at each instant where ``sampled`` (anything elsewhere).
        sampled : ndarray of bool, shape (K, p)
            Which outputs were sampled at each instant.

        Returns
        -------
        ndarray, shape (*batch, K, n_x), or None
            ``None`` where the record cannot be run in one call (the loop then steps it, and reports
            what went wrong the way it always does).
        """
        ...


# ------------------------------------------------------------------ python-control
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
    import numpy as np

    if isinstance(given, (int, np.integer)) and not isinstance(given, bool):
        if given < 0:
            raise InvalidArgumentError(f"{what}: must be >= 0, got {given}")
        return [f"{prefix}[{i}]" for i in range(int(given))]
    return [str(s) for s in given]


def to_control(observer: Any, *, inputs: int | Sequence[str] | None = None,
               outputs: int | Sequence[str] | None = None, name: str | None = None) -> Any:
    """``observer`` as a ``control.NonlinearIOSystem``: the adapter behind :meth:`ToControl.to_control`.

    python-control (an optional extra, ``pip install 'nlobs[control]'``) interconnects systems by
    signal names (``control.interconnect``) and simulates them (``control.input_output_response``).
    It wraps an observer of the one protocol whose state is an array as a ``control.NonlinearIOSystem``:

    * inputs ``[u, y]``: the plant's known input, then its measured output (names ``u[i]``/``y[j]``
      or the plant's own names when the observer knows them);
    * state: the observer's state ``z`` (``observer.init(x̂0)`` is its initial value);
    * outputs: the estimate ``x̂ = observer.estimate(z)`` (names ``<state>_hat``);
    * ``updfcn = observer.rhs`` (continuous: ``ż``; discrete, ``dt = Discrete.dt``: ``z⁺``).

    A correcting observer (an EKF updated at sample instants, the GNSS/INS observer) is a
    continuous-discrete system that python-control cannot represent, and one with a structured state
    (a covariance, set-valued radii) has no flat state vector: both are refused with a typed error.

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
    import numpy as np

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
