r"""Continuous-discrete implementation of a continuous-time observer: the inter-sample output predictor.

Every continuous-time observer of nlobs injects the output ``y(t)``: the Luenberger/Thau observer
``x̂̇ = f(x̂, u) + L (y − h(x̂))``, the drift observer (3.1) of Dalla Mora, Germani & Manes, the
Moore–Penrose observer (7) of Röbenack, the cascade observer (9)–(10) of Grip, Saberi & Johansen.
Real sensors deliver samples ``y_k = y(t_k) + v_k``. Holding the last sample (zero-order hold) feeds the
observer ``y(t_k)`` where the plant's output is already ``y(t)``: an error of order ``T·|ẏ|`` that does
not vanish when the estimate is exact, and that a high gain amplifies.

Karafyllis & Kravaris (IEEE TAC 54(9), 2009, "From continuous-time design to sampled-data design of
observers", Sec. III) replace the held sample by an *inter-sample predictor* ``w`` of the output, run with
the observer's own estimate:

.. math::

    \dot w(t) = \frac{\partial h}{\partial x}(\hat x)\, F(\hat x, u) \quad (t_k \le t < t_{k+1}),
    \qquad w(t_k) = y_k ,

and feed ``w`` to the continuous observer in place of ``y``. With exact samples,
``w(t) − y(t) = ∫_{t_k}^{t} (L_F h(x̂) − L_F h(x)) ds``, which is bounded by ``(t − t_k) ℓ max |x̂ − x|``
(``ℓ`` a Lipschitz constant of ``L_F h`` on the region): the discrepancy vanishes with the error, and the
continuous design's convergence survives every sampling period below an explicit bound
(:mod:`nlobs.synthesis.sampled_data`; Nadri, Hammouri & Grajales, IEEE TAC 58(3), 2013, and Farza et al.,
IEEE TAC 59(4), 2014, give the same structure for high-gain observers).

:class:`OutputPredictor` wraps any continuous observer of the one protocol whose state is an array: its
state is ``[z, w]``; ``rhs`` runs the wrapped observer with ``w`` and the predictor; ``correct`` (at a sample
instant) resets ``w_j = y_j`` for every output ``j`` just sampled (multi-rate groups each at their own
instants). A missing sample (non-finite ``y_j``) or an outage leaves the prediction running. Without
sensors (``measurements=None``) the loop corrects at every step, and the observer is the continuous one.
The held-sample form stays available: it is the wrapped observer itself.

A feedthrough ``h(x, u)``: the predictor follows ``∂h/∂x · F`` and not the jumps of ``u`` between samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray
from nlobs.errors import InvalidArgumentError
from nlobs.observers.base import ToControl
from nlobs.systems.timebase import TimeBase

__all__ = ["OutputPredictor", "with_predictor"]


@dataclass(frozen=True, eq=False)
class OutputPredictor(ToControl):
    r"""A continuous observer run on sampled outputs through the predictor of Karafyllis & Kravaris (module docstring).

    Parameters
    ----------
    observer : Observer
        A continuous-time observer of the one protocol whose state is an array and that reads ``y`` in
        ``rhs`` (Luenberger/Thau, drift, Moore–Penrose, cascade).
    plant : PlantModel
        The model whose output is predicted: ``rhs`` (``F``), ``output`` (``h``) and ``output_jacobian_x``
        (a compiled symbolic model or a linear system).
    name : str
        Label in results (default: the wrapped observer's, with ``+ predictor``).

    Attributes
    ----------
    time : Continuous
        The wrapped observer's time base.
    n_inner : int
        Size of the wrapped observer's state.
    state_names : tuple of str
        The wrapped observer's state names, then ``w[<output>]``.

    Examples
    --------
    An undamped oscillator whose position is sampled every 0.25 s, and one Luenberger observer fed either the
    held sample or the prediction ``w``: holding leaves an error of the order of ``T |ẏ|``, with the predictor
    the error vanishes:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup
    >>> plant = nlobs.LinearSystem([[0.0, 1.0], [-1.0, 0.0]], np.zeros((2, 1)), [[1.0, 0.0]])
    >>> luenberger = nlobs.LuenbergerObserver(plant, [[2.0], [2.0]])
    >>> sensor = MeasurementGroup("position", [0], rate=4.0)
    >>> def final_error(observer):
    ...     res = nlobs.simulate(plant, observer, [1.0, 0.0], [0.0, 0.0], duration=12.0, dt=1e-2, u=0.0,
    ...                          measurements=sensor)
    ...     return float(res.error_norm[-1])
    >>> held, predicted = final_error(luenberger), final_error(nlobs.OutputPredictor(luenberger, plant))
    >>> round(held, 2), bool(predicted < 1e-3)
    (0.12, True)
    """

    observer: Any
    plant: Any
    name: str = ""
    time: TimeBase = field(init=False)
    n_inner: int = field(init=False)
    state_names: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        obs = self.observer
        for attr in ("init", "rhs", "estimate", "time", "n_x"):
            if not hasattr(obs, attr):
                raise InvalidArgumentError(f"observer: {type(obs).__name__} is not an observer (no {attr!r})")
        if obs.time.is_discrete:
            raise InvalidArgumentError(f"observer: {type(obs).__name__} is discrete-time; the output predictor is "
                                       "for a continuous-time observer")
        if hasattr(obs, "correct"):
            raise InvalidArgumentError(f"observer: {type(obs).__name__} corrects at samples itself (a filter); "
                                       "it needs no output predictor")
        for attr in ("rhs", "output", "output_jacobian_x", "outputs", "states"):
            if not hasattr(self.plant, attr):
                raise InvalidArgumentError(f"plant: expected a PlantModel with {attr!r}; "
                                           f"{type(self.plant).__name__} has none")
        if len(self.plant.states) != int(obs.n_x):
            raise InvalidArgumentError(f"plant: {len(self.plant.states)} states, the observer estimates {obs.n_x}")
        size = getattr(obs, "n_z", None)
        if not isinstance(size, (int, np.integer)):  # no declared size: the state of an initial estimate
            z0 = obs.init(np.zeros(int(obs.n_x)))
            if not isinstance(z0, np.ndarray) or z0.ndim != 1:
                raise InvalidArgumentError(f"observer: the state of {type(obs).__name__} is not an array; the output "
                                           "predictor wraps observers whose state is an array")
            size = z0.size
        size = int(size)
        inner = getattr(obs, "state_names", None)
        names = tuple(inner) if inner is not None and len(inner) == size else tuple(f"z[{i}]" for i in range(size))
        object.__setattr__(self, "time", obs.time)
        object.__setattr__(self, "n_inner", size)
        object.__setattr__(self, "state_names", names + tuple(f"w[{o}]" for o in self.plant.outputs))
        if not self.name:
            object.__setattr__(self, "name", f"{getattr(obs, 'name', type(obs).__name__)} + predictor")

    @property
    def n_x(self) -> int:
        """Dimension of the estimate (the wrapped observer's)."""
        return int(self.observer.n_x)

    @property
    def n_z(self) -> int:
        """Size of the state ``[z, w]``."""
        return self.n_inner + self.p

    @property
    def p(self) -> int:
        """Number of predicted outputs."""
        return len(self.plant.outputs)

    def init(self, x_hat0: ArrayLike) -> Array:
        """``[z0, h(x̂0)]``: the wrapped observer's initial state and the output of the initial estimate.

        The first sample (at the start of a run every group samples) replaces ``h(x̂0)`` by ``y_0``.
        """
        z0 = np.asarray(self.observer.init(x_hat0), dtype=float)
        x_hat = np.asarray(self.observer.estimate(z0), dtype=float)
        u0 = np.zeros((*x_hat.shape[:-1], len(getattr(self.plant, "inputs", ()))))
        w0 = np.asarray(self.plant.output(0.0, x_hat, u0), dtype=float)
        return np.concatenate([z0, w0], axis=-1)

    def _split(self, s: Array) -> tuple[Array, Array]:
        return s[..., : self.n_inner], s[..., self.n_inner:]

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``[ż, ẇ]``: the wrapped observer driven by the prediction ``w``, and ``ẇ = ∂h/∂x(x̂) F(x̂, u)``.

        Parameters
        ----------
        t : float
            Time.
        z : ndarray, shape (..., n_inner + p)
            ``[z, w]``.
        u : ndarray, shape (..., m)
            The known input.
        y : ndarray, shape (..., p)
            The held measurement (not used: ``w`` replaces it; the samples enter in :meth:`correct`).
        """
        inner, w = self._split(z)
        x_hat = self.observer.estimate(inner)
        dz = np.asarray(self.observer.rhs(t, inner, u, w), dtype=float)
        jac = self.plant.output_jacobian_x(t, x_hat, u)
        dw = np.einsum("...ij,...j->...i", jac, self.plant.rhs(t, x_hat, u))
        dw = np.broadcast_to(dw, (*dz.shape[:-1], self.p))
        return np.concatenate([dz, dw], axis=-1)

    def correct(self, t: float, z: Array, u: Array, y: Array, fresh: BoolArray) -> Array:
        """``w_j ← y_j`` for every output ``j`` sampled at ``t`` (a non-finite sample is missing: ``w_j`` runs on).

        Parameters
        ----------
        t : float
            The sample instant.
        z : ndarray, shape (..., n_inner + p)
            ``[z, w]`` before the sample.
        u : ndarray, shape (..., m)
            The known input.
        y : ndarray, shape (..., p)
            The samples.
        fresh : ndarray of bool, shape (p,)
            Which outputs were sampled at ``t``.
        """
        fresh = np.asarray(fresh, dtype=bool)
        if not fresh.any():
            return z
        y = np.asarray(y, dtype=float)
        inner, w = self._split(z)
        take = fresh & np.isfinite(y)
        w_new = np.where(take, y, np.broadcast_to(w, np.broadcast_shapes(w.shape, y.shape)))
        inner = np.broadcast_to(inner, (*w_new.shape[:-1], inner.shape[-1]))
        return np.concatenate([inner, w_new], axis=-1)

    def estimate(self, z: Array) -> Array:
        """The wrapped observer's estimate ``x̂``, shape ``(..., n_x)``."""
        return self.observer.estimate(z[..., : self.n_inner])

    def prediction(self, z: Array) -> Array:
        """The predicted output ``w``, shape ``(..., p)``."""
        return z[..., self.n_inner:]


def with_predictor(observer: Any, plant: Any, sampled: bool) -> Any:
    """``observer`` wrapped in :class:`OutputPredictor` when the outputs are ``sampled``, else itself.

    Parameters
    ----------
    observer : Observer
        A continuous-time observer with an array state.
    plant : PlantModel
        The model whose output is predicted.
    sampled : bool
        Whether the observer runs on sampled outputs (a model file with ``[sensors]``).

    Returns
    -------
    Observer
        An :class:`OutputPredictor` around ``observer`` (``sampled``), else ``observer`` itself.

    Examples
    --------
    A Luenberger observer of an oscillator whose position is measured: on exact outputs it is used as it is;
    on sampled ones it is wrapped, its state extended by the prediction ``w`` of the output, which
    ``init`` starts at ``h(x̂0)``:

    >>> import numpy as np
    >>> import nlobs
    >>> plant = nlobs.LinearSystem([[0.0, 1.0], [-1.0, 0.0]], np.zeros((2, 1)), [[1.0, 0.0]])
    >>> luenberger = nlobs.LuenbergerObserver(plant, [[2.0], [2.0]])
    >>> with_predictor(luenberger, plant, sampled=False) is luenberger
    True
    >>> wrapped = with_predictor(luenberger, plant, sampled=True)
    >>> type(wrapped).__name__, wrapped.n_x, wrapped.n_z, wrapped.state_names[-1]
    ('OutputPredictor', 2, 3, 'w[y1]')
    >>> wrapped.init([0.5, -1.0]).tolist()
    [0.5, -1.0, 0.5]
    """
    return OutputPredictor(observer, plant) if sampled else observer
