"""Luenberger observer for a linear system ``(A, B, C, D)`` with output-injection gain ``L``.

Continuous time:

.. math:: \\dot z = A z + B u + L\\,(y - C z - D u), \\qquad \\hat x = z,

so that the error ``e = z − x`` obeys ``ė = (A − L C) e``.

Discrete time (predictor form, the same ``dt`` as the plant):

.. math:: z^+ = A z + B u + L\\,(y - C z - D u), \\qquad e^+ = (A − L C)\\, e .

The observer converges iff ``A − L C`` is Hurwitz (continuous) or Schur
(discrete); :attr:`LuenbergerObserver.error_matrix` gives it for checking.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_batch, as_matrix
from nlobs.errors import InvalidArgumentError
from nlobs.systems.linear import LinearSystem, as_linear_system
from nlobs.systems.timebase import TimeBase
from nlobs.observers.base import ToControl


@dataclass(frozen=True, eq=False)
class LuenbergerObserver(ToControl):
    """Full-order Luenberger observer ``ż = A z + B u + L (y − C z − D u)`` (or ``z⁺ = …``).

    Parameters
    ----------
    system : LinearSystem
        The model the observer copies; its time base is the observer's.
    L : array_like, shape (n, p)
        Output-injection gain.

    Attributes
    ----------
    time : Continuous or Discrete
        The system's time base.
    state_names : tuple of str
        ``"<state>_hat"`` for each state (used in divergence reports).

    Notes
    -----
    The observer holds no state: :meth:`rhs` maps ``(t, z, u, y)`` to ``ż`` or
    ``z⁺`` for batches ``z`` of shape ``(..., n)``.

    Examples
    --------
    A deadbeat design for a sampled double integrator (discrete time): ``L`` puts both eigenvalues of
    ``A − L C`` at 0, so the error ``e_k = (A − L C)ᵏ e_0`` vanishes after ``n = 2`` steps:

    >>> import numpy as np
    >>> import nlobs
    >>> T = 0.1
    >>> plant = nlobs.LinearSystem([[1.0, T], [0.0, 1.0]], [[0.5 * T**2], [T]], [[1.0, 0.0]], time=nlobs.Discrete(T))
    >>> observer = nlobs.LuenbergerObserver(plant, [[2.0], [1.0 / T]])
    >>> bool(np.allclose(np.linalg.matrix_power(observer.error_matrix, 2), 0.0))
    True
    >>> res = nlobs.simulate(plant, observer, [1.0, -0.5], [0.0, 0.0], duration=1.0, u=1.0)
    >>> e = np.abs(res.x - res.x_hat).max(axis=-1)
    >>> round(float(e[0]), 6), round(float(e[1]), 6), bool(e[2:].max() < 1e-12)
    (1.0, 10.5, True)
    """

    system: LinearSystem
    L: Array
    time: TimeBase = field(init=False)
    state_names: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "system", as_linear_system(self.system, "system"))  # python-control systems too
        gain = as_matrix("L", self.L, (self.system.n, self.system.p))
        gain.setflags(write=False)
        object.__setattr__(self, "L", gain)
        object.__setattr__(self, "time", self.system.time)
        object.__setattr__(self, "state_names", tuple(f"{s}_hat" for s in self.system.states))
        # Precomputed transposes for row-vector batches: ż = z (A − LC)ᵀ + u (B − LD)ᵀ + y Lᵀ.
        A, B, C, D = self.system.A, self.system.B, self.system.C, self.system.D
        object.__setattr__(self, "_FzT", np.ascontiguousarray((A - gain @ C).T))
        object.__setattr__(self, "_FuT", np.ascontiguousarray((B - gain @ D).T))
        object.__setattr__(self, "_LT", np.ascontiguousarray(gain.T))

    @property
    def n_z(self) -> int:
        """Observer state dimension (``n``)."""
        return self.system.n

    @property
    def n_x(self) -> int:
        """Estimate dimension (``n``)."""
        return self.system.n

    @property
    def error_matrix(self) -> Array:
        """``A − L C``, the matrix of the error dynamics."""
        return self.system.A - self.L @ self.system.C

    def init(self, x_hat0: ArrayLike) -> Array:
        """Observer state from the initial estimate (``z0 = x̂0``), shape ``(..., n)``."""
        return np.array(as_batch("x_hat0", x_hat0, self.system.n), dtype=float)

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``ż`` (continuous) or ``z⁺`` (discrete) for batches, shape ``(..., n)``."""
        return z @ self._FzT + u @ self._FuT + y @ self._LT  # type: ignore[attr-defined]

    def estimate(self, z: Array) -> Array:
        """The estimate is the observer state, ``x̂ = z``."""
        return z


@dataclass(frozen=True, eq=False)
class _PlantCopy(ToControl):
    """What a copy of a plant with an output-injection gain ``L`` shares: its state is the estimate (``x̂ = z``), the
    plant and ``L`` are checked once, the time base is the plant's (:class:`ConstantGainObserver`,
    :class:`~nlobs.observers.impulsive.ImpulsiveObserver`)."""

    plant: Any
    L: Array
    name: str = ""
    time: TimeBase = field(init=False)
    state_names: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        for attr in ("rhs", "output", "states", "outputs", "time"):
            if not hasattr(self.plant, attr):
                raise InvalidArgumentError(f"plant: expected a PlantModel (time, states, outputs, rhs, output); "
                                           f"{type(self.plant).__name__} has no {attr!r}")
        n, p = len(self.plant.states), len(self.plant.outputs)
        gain = as_matrix("L", self.L, (n, p))
        gain.setflags(write=False)
        object.__setattr__(self, "L", gain)
        object.__setattr__(self, "time", self.plant.time)
        object.__setattr__(self, "state_names", tuple(f"{s}_hat" for s in self.plant.states))

    @property
    def n_z(self) -> int:
        """Observer state dimension (``n``)."""
        return int(self.L.shape[0])

    @property
    def n_x(self) -> int:
        """Estimate dimension (``n``)."""
        return int(self.L.shape[0])

    def init(self, x_hat0: ArrayLike) -> Array:
        """Observer state from the initial estimate (``z0 = x̂0``), shape ``(..., n)``."""
        return np.array(as_batch("x_hat0", x_hat0, self.n_x), dtype=float)

    def estimate(self, z: Array) -> Array:
        """The estimate is the observer state, ``x̂ = z``."""
        return z


@dataclass(frozen=True, eq=False)
class ConstantGainObserver(_PlantCopy):
    r"""A copy of a nonlinear plant with constant output injection (Thau, 1973):

    .. math:: \dot z = f(z, u) + L\,(y - h(z, u)), \qquad \hat x = z

    (``z⁺ = f(z, u) + L (y − h(z, u))`` for a discrete plant). With ``L`` designed for the
    linearisation ``(A, C)`` at an operating point (``A − L C`` Hurwitz / Schur) the error
    converges near that point; how far from it the gain still works is what a simulation shows
    (a certificate of the linearisation does not cover the nonlinear plant).

    Parameters
    ----------
    plant : PlantModel
        The model the observer copies (a compiled symbolic model or a linear system); its time
        base is the observer's.
    L : array_like, shape (n, p)
        Output-injection gain.
    name : str
        Label in results.

    Examples
    --------
    The pendulum (a shipped model) with the gain of its linearisation at the origin (``A − L C`` has its
    eigenvalues at about ``−2.1 ± 3.2j``), started 0.3 rad and 0.3 rad/s off:

    >>> import nlobs
    >>> plant = nlobs.load_model("pendulum").compile()
    >>> observer = nlobs.ConstantGainObserver(plant, [[4.0], [4.0]])
    >>> res = nlobs.simulate(plant, observer, [0.5, 0.0], [0.2, 0.3], duration=5.0, dt=1e-2, u=0.0)
    >>> e = res.error_norm  # ‖x̂ − x‖ at each step
    >>> round(float(e[0]), 3), bool(e[-1] < 1e-3 * e[0])
    (0.424, True)
    """

    plant: Any
    L: Array
    name: str = "Luenberger (constant gain)"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "_LT", np.ascontiguousarray(self.L.T))

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``ż`` (continuous) or ``z⁺`` (discrete) for batches, shape ``(..., n)``."""
        return self.plant.rhs(t, z, u) + (y - self.plant.output(t, z, u)) @ self._LT  # type: ignore[attr-defined]
