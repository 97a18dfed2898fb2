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

from collections.abc import Mapping
from typing import Any, Protocol, TypeVar, runtime_checkable

from nlobs._typing import Array, BoolArray
from nlobs.systems.timebase import TimeBase

Z = TypeVar("Z")

__all__ = ["CorrectingObserver", "DeferredEstimate", "Diagnosing", "Observer", "RecordRunning", "SelfStepping",
           "ToControl", "Z"]


class ToControl:
    """Gives an observer ``to_control()``: itself as a python-control input/output system.

    A mix-in of every nlobs observer (no state, no fields); see :func:`nlobs.observers.control_io.to_control`.
    """

    __slots__ = ()

    def to_control(self, *, inputs: Any = None, outputs: Any = None, name: str | None = None) -> Any:
        """This observer as a ``control.NonlinearIOSystem``: inputs ``[u, y]``, state ``z``, outputs ``x̂``.

        See :func:`nlobs.observers.control_io.to_control` (python-control is an optional extra).

        Raises
        ------
        InvalidArgumentError
            python-control is missing, or the observer is a correcting observer or has a
            structured state (python-control cannot represent either).
        """
        from nlobs.observers.control_io import to_control

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
    """An observer that also makes a discrete correction when a sample arrives (module docstring)."""

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
    """A continuous-time observer with its own advance over one held step (module docstring)."""

    def step(self, t: float, z: Z, u: Array, y: Array, h: float) -> Z:
        """The state at ``t + h`` from the state at ``t``, ``u`` and ``y`` held over the step."""
        ...


@runtime_checkable
class Diagnosing(Protocol[Z]):
    """An observer with named internal quantities worth recording (extras of the result)."""

    def diagnostics(self, z: Z, u: Array) -> Mapping[str, Array]:
        """Named arrays of shape ``(..., *item_shape)`` at the current state."""
        ...


@runtime_checkable
class DeferredEstimate(Protocol[Z]):
    """An observer whose estimate is a costly map of a cheap raw one, applied once to the record."""

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

