"""Time integrators: fixed-step classical Runge–Kutta (RK4) over batches, and ``solve_ivp``.

Options are small frozen objects passed to :func:`nlobs.simulate.simulate`:

* :class:`RK4` — the classical fourth-order method on the fixed grid
  ``t_k = t0 + k dt``; every stage is one vectorised call over the whole batch,

  .. math::

     k_1 = f(t, y),\\; k_2 = f(t + h/2, y + h k_1/2),\\; k_3 = f(t + h/2, y + h k_2/2),\\;
     k_4 = f(t + h, y + h k_3),\\quad y^+ = y + h (k_1 + 2k_2 + 2k_3 + k_4)/6 .

* :class:`SolveIVP` — :func:`scipy.integrate.solve_ivp` (adaptive), with the
  batch flattened into one long state vector; the solution is reported on
  the same fixed grid. It is meant for checking RK4 (and for stiff plants with
  an implicit method), not for throughput.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
import scipy

from nlobs._typing import Array
from nlobs._validate import as_finite_array, positive
from nlobs.errors import DimensionError, InvalidArgumentError
from nlobs.simulate.state import flat_fields, tree_map

VectorField = Callable[[float, Array], Array]
JointField = Callable[[float, tuple[Array, ...]], tuple[Array, ...]]

_IVP_METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")

#: RK4 is stable for ``h λ`` on the negative real axis down to ``−2.785`` (the root of
#: ``1 + z + z²/2 + z³/6 + z⁴/24 = ±1``): a linear mode with ``h |λ|`` above it blows up at step ``h``.
RK4_REAL_LIMIT = 2.785


@dataclass(frozen=True)
class RK4:
    """Fixed-step classical Runge–Kutta of order 4 (the default integrator).

    Examples
    --------
    ``ẋ = −x`` with a Luenberger observer of gain 3 (so ``ė = −4 e``) from ``x = 1``, ``x̂ = 0``: with
    ``dt = 0.1`` the state and the estimate ``e^{−t} − e^{−4t}`` at ``t = 1`` are within ``O(dt⁴)``:

    >>> import numpy as np
    >>> import nlobs
    >>> plant = nlobs.LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
    >>> observer = nlobs.LuenbergerObserver(plant, [[3.0]])
    >>> res = nlobs.simulate(plant, observer, [1.0], [0.0], duration=1.0, dt=0.1, integrator=RK4())
    >>> RK4().name, res.method, res.t.size
    ('rk4', 'rk4', 11)
    >>> exact = np.exp(-1.0), np.exp(-1.0) - np.exp(-4.0)
    >>> bool(abs(res.x[-1, 0] - exact[0]) < 1e-6), bool(abs(res.x_hat[-1, 0] - exact[1]) < 1e-4)
    (True, True)
    """

    @property
    def name(self) -> str:
        return "rk4"


@dataclass(frozen=True)
class SolveIVP:
    """Adaptive integration with :func:`scipy.integrate.solve_ivp`.

    Parameters
    ----------
    method : str
        One of ``"RK45"``, ``"RK23"``, ``"DOP853"``, ``"Radau"``, ``"BDF"``, ``"LSODA"``.
    rtol, atol : float
        Tolerances passed to ``solve_ivp``.
    max_step : float
        Largest step ``solve_ivp`` may take (``inf``: no limit).

    Examples
    --------
    ``ẋ = −x`` with a Luenberger observer of gain 3 (``ė = −4 e``), integrated adaptively and reported on the
    grid of ``dt``: at ``t = 1`` the state is ``e^{−1}`` and the estimate ``e^{−1} − e^{−4}`` to the tolerances
    (RK4 with the same ``dt = 0.1`` is off by about ``3e−7``):

    >>> import numpy as np
    >>> import nlobs
    >>> plant = nlobs.LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
    >>> observer = nlobs.LuenbergerObserver(plant, [[3.0]])
    >>> res = nlobs.simulate(plant, observer, [1.0], [0.0], duration=1.0, dt=0.1, integrator=SolveIVP())
    >>> res.method, res.t.size
    ('solve_ivp:DOP853', 11)
    >>> exact = np.exp(-1.0), np.exp(-1.0) - np.exp(-4.0)
    >>> bool(abs(res.x[-1, 0] - exact[0]) < 1e-10), bool(abs(res.x_hat[-1, 0] - exact[1]) < 1e-10)
    (True, True)
    >>> SolveIVP("Radau", rtol=1e-6).options()
    {'method': 'Radau', 'rtol': 1e-06, 'atol': 1e-12, 'max_step': inf}
    >>> try:
    ...     SolveIVP("Euler")
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError SolveIVP.method: expected one of ('RK45', 'RK23', 'DOP853', 'Radau', 'BDF', 'LSODA'),
    got 'Euler'
    """

    method: str = "DOP853"
    rtol: float = 1e-10
    atol: float = 1e-12
    max_step: float = np.inf

    def __post_init__(self) -> None:
        if self.method not in _IVP_METHODS:
            raise InvalidArgumentError(f"SolveIVP.method: expected one of {_IVP_METHODS}, got {self.method!r}")
        object.__setattr__(self, "rtol", positive("SolveIVP.rtol", self.rtol))
        object.__setattr__(self, "atol", positive("SolveIVP.atol", self.atol))
        if not float(self.max_step) > 0:
            raise InvalidArgumentError(f"SolveIVP.max_step: must be positive, got {self.max_step!r}")

    @property
    def name(self) -> str:
        return f"solve_ivp:{self.method}"

    def options(self) -> dict[str, Any]:
        """Keyword arguments for :func:`scipy.integrate.solve_ivp`."""
        return {"method": self.method, "rtol": self.rtol, "atol": self.atol, "max_step": float(self.max_step)}


Integrator = RK4 | SolveIVP


def _rk4_sum(a: Array, b1: Array, b2: Array, b3: Array, b4: Array, h: float) -> Array:
    """``a + (h/6)(b1 + 2 b2 + 2 b3 + b4)`` with the operations of the general case in its order (so its rounding),
    accumulated in place when no operand broadcasts."""
    if not (a.shape == b1.shape == b2.shape == b3.shape == b4.shape):
        return a + (h / 6.0) * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
    acc = 2.0 * b2
    acc += b1
    acc += 2.0 * b3
    acc += b4
    acc *= h / 6.0
    acc += a
    return acc


def _rk4_record(f: Callable[[float, Any], Any], t: float, y: Any, names: tuple[str, ...], idx: tuple[int, ...],
                h: float) -> Any:
    """:func:`rk4_step` of a flat record (:func:`~nlobs.simulate.state.flat_fields`): its float arrays (fields
    ``idx``) combined in the order of the general case (so the same rounding), its scalars carried over, each
    stage built positionally."""
    cls = type(y)
    y0 = [getattr(y, name) for name in names]
    arrays = [(i, names[i], y0[i]) for i in idx]
    half = 0.5 * h

    def stage(c: float, k: Any) -> tuple[Any, list[Any]]:
        rates = [getattr(k, name) for _, name, _ in arrays]
        vals = y0.copy()
        for (i, _, a), b in zip(arrays, rates):
            vals[i] = a + c * b
        return cls(*vals), rates

    z2, k1 = stage(half, f(t, y))
    z3, k2 = stage(half, f(t + half, z2))
    z4, k3 = stage(h, f(t + half, z3))
    k4 = f(t + h, z4)
    out = y0.copy()
    for (i, name, a), b1, b2, b3 in zip(arrays, k1, k2, k3):
        out[i] = _rk4_sum(a, b1, b2, b3, getattr(k4, name), h)
    return cls(*out)


def _combine(y: tuple[Any, ...], members: list[Any], c: float, k: tuple[Any, ...]) -> tuple[Any, ...]:
    """``y + c k`` member by member: arrays directly, flat records field by field (their scalars carried)."""
    out = []
    for a, b, rec in zip(y, k, members):
        if rec is None:
            out.append(a + c * b)
            continue
        names, idx = rec
        vals = [getattr(a, name) for name in names]
        for i in idx:
            vals[i] = vals[i] + c * getattr(b, names[i])
        out.append(type(a)(*vals))
    return tuple(out)


def _rk4_members(f: Callable[[float, Any], Any], t: float, y: tuple[Any, ...], members: list[Any], h: float) -> Any:
    """:func:`rk4_step` of a tuple of arrays and flat records, with the general case's operations in its order."""
    k1 = f(t, y)
    k2 = f(t + 0.5 * h, _combine(y, members, 0.5 * h, k1))
    k3 = f(t + 0.5 * h, _combine(y, members, 0.5 * h, k2))
    k4 = f(t + h, _combine(y, members, h, k3))
    out = []
    for j, (a, rec) in enumerate(zip(y, members)):
        b1, b2, b3, b4 = k1[j], k2[j], k3[j], k4[j]
        if rec is None:
            out.append(_rk4_sum(a, b1, b2, b3, b4, h))
            continue
        names, idx = rec
        vals = [getattr(a, name) for name in names]
        for i in idx:
            name = names[i]
            vals[i] = _rk4_sum(vals[i], getattr(b1, name), getattr(b2, name), getattr(b3, name), getattr(b4, name), h)
        out.append(type(a)(*vals))
    return tuple(out)


def rk4_step(f: Callable[[float, Any], Any], t: float, y: Any, h: float) -> Any:
    """One classical RK4 step of ``ẏ = f(t, y)`` from ``t`` to ``t + h`` — the one RK4 of nlobs.

    ``y`` is an array with any leading batch axes (``f`` must accept and return them), or a tree of
    arrays (a tuple such as ``(plant state, observer state)``, or a dataclass of arrays: an observer
    state) whose float-array leaves are combined stage by stage (:func:`nlobs.simulate.state.tree_map`);
    ``f`` returns a tree of the same structure. Integrating the parts of a tuple together keeps them
    coupled at every stage (the observer sees the plant output of the same stage).

    Parameters
    ----------
    f : callable
        ``f(t, y)``, returning ``ẏ`` of the structure of ``y``.
    t : float
        Start of the step.
    y : ndarray or tree of arrays
        The state at ``t``.
    h : float
        Step size.

    Returns
    -------
    ndarray or tree of arrays
        The state at ``t + h``, of the structure of ``y``.

    Examples
    --------
    One step of ``ẏ = −y`` from ``y = 1`` is the Taylor polynomial of ``e^{−h}`` to degree 4, and a batch of
    initial values takes the step at once:

    >>> import numpy as np
    >>> h = 0.1
    >>> y1 = rk4_step(lambda t, y: -y, 0.0, np.array([1.0, 2.0]), h)
    >>> bool(np.allclose(y1, np.array([1.0, 2.0]) * (1 - h + h**2 / 2 - h**3 / 6 + h**4 / 24), rtol=1e-15))
    True

    A tuple ``(x, z)`` is integrated as one coupled state: here ``ẋ = −x`` and ``ż = x − z``, whose exact
    solution from ``(1, 0)`` is ``(e^{−t}, t e^{−t})``:

    >>> x, z = rk4_step(lambda t, s: (-s[0], s[0] - s[1]), 0.0, (np.array([1.0]), np.array([0.0])), h)
    >>> bool(np.allclose(x, np.exp(-h), atol=1e-6)), bool(np.allclose(z, h * np.exp(-h), atol=1e-6))
    (True, True)
    """
    if isinstance(y, np.ndarray):
        k1 = f(t, y)
        k2 = f(t + 0.5 * h, y + (0.5 * h) * k1)
        k3 = f(t + 0.5 * h, y + (0.5 * h) * k2)
        k4 = f(t + h, y + h * k3)
        return y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    if isinstance(y, tuple) and all(isinstance(a, np.ndarray) for a in y):  # (x, z) of arrays: no tree walk
        k1 = f(t, y)
        k2 = f(t + 0.5 * h, tuple(a + (0.5 * h) * b for a, b in zip(y, k1, strict=True)))
        k3 = f(t + 0.5 * h, tuple(a + (0.5 * h) * b for a, b in zip(y, k2, strict=True)))
        k4 = f(t + h, tuple(a + h * b for a, b in zip(y, k3, strict=True)))
        return tuple(a + (h / 6.0) * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
                     for a, b1, b2, b3, b4 in zip(y, k1, k2, k3, k4, strict=True))
    record = flat_fields(y)
    if record is not None:  # a flat record of floats (a Kalman filter's mean and covariance): no tree walk per stage
        return _rk4_record(f, t, y, *record, h)
    if isinstance(y, tuple):  # (plant state, a filter's state): arrays and flat records, no tree walk per stage
        members = [None if isinstance(m, np.ndarray) else flat_fields(m) for m in y]
        if all(r is not None for m, r in zip(y, members) if not isinstance(m, np.ndarray)):
            return _rk4_members(f, t, y, members, h)
    k1 = f(t, y)
    k2 = f(t + 0.5 * h, tree_map(lambda a, b: a + (0.5 * h) * b, y, k1))
    k3 = f(t + 0.5 * h, tree_map(lambda a, b: a + (0.5 * h) * b, y, k2))
    k4 = f(t + h, tree_map(lambda a, b: a + h * b, y, k3))
    return tree_map(lambda a, b1, b2, b3, b4: a + (h / 6.0) * (b1 + 2.0 * b2 + 2.0 * b3 + b4), y, k1, k2, k3, k4)


#: :func:`rk4_step` on a tuple state (the plant and observer integrated together); the same function.
rk4_step_joint = rk4_step


def rk4_integrate(f: VectorField, y0: ArrayLike, t: ArrayLike) -> Array:
    """Integrate ``ẏ = f(t, y)`` with RK4 on the given time grid.

    Parameters
    ----------
    f : callable
        ``f(t, y)`` with ``y`` of shape ``(..., n)``.
    y0 : array_like, shape (..., n)
        Initial state at ``t[0]``.
    t : array_like, shape (K,)
        Increasing time grid (need not be uniform).

    Returns
    -------
    ndarray, shape (..., K, n)
        The state at every grid time.

    Raises
    ------
    DimensionError, NonFiniteError
        ``y0`` is a scalar; ``y0`` or ``t`` is not finite.
    InvalidArgumentError
        ``t`` is empty or not strictly increasing.

    Examples
    --------
    The harmonic oscillator ``ẏ₁ = y₂``, ``ẏ₂ = −y₁`` from two initial states at once, over one period with
    100 steps: the first is ``(cos t, −sin t)``, and both come back to where they started:

    >>> import numpy as np
    >>> t = np.linspace(0.0, 2 * np.pi, 101)
    >>> Y = rk4_integrate(lambda t, y: np.stack([y[..., 1], -y[..., 0]], axis=-1), [[1.0, 0.0], [0.0, 2.0]], t)
    >>> Y.shape
    (2, 101, 2)
    >>> bool(np.allclose(Y[0], np.stack([np.cos(t), -np.sin(t)], axis=-1), atol=1e-5))
    True
    >>> bool(np.allclose(Y[:, -1], Y[:, 0], atol=1e-5))
    True
    """
    y = as_finite_array("y0", y0)
    grid = as_finite_array("t", t, ndim=1)
    if y.ndim == 0:
        raise DimensionError("y0: expected shape (..., n), got a scalar")
    if grid.size == 0 or np.any(np.diff(grid) <= 0):
        raise InvalidArgumentError("t: must be a non-empty, strictly increasing grid")
    out = np.empty((*y.shape[:-1], grid.size, y.shape[-1]))
    out[..., 0, :] = y
    for k in range(grid.size - 1):
        y = rk4_step(f, float(grid[k]), y, float(grid[k + 1] - grid[k]))
        out[..., k + 1, :] = y
    return out


def solve_ivp_batch(
    f: VectorField, y0: ArrayLike, t_span: tuple[float, float], t_eval: ArrayLike, options: Mapping[str, Any]
) -> tuple[Array, Any]:
    """Integrate a batched ``ẏ = f(t, y)`` with ``solve_ivp`` by flattening the batch.

    Parameters
    ----------
    f : callable
        ``f(t, y)`` with ``y`` of shape ``y0.shape``.
    y0 : array_like, shape (..., n)
        Initial state (any batch shape).
    t_span : (float, float)
        Integration interval.
    t_eval : array_like, shape (K,)
        Increasing times inside ``t_span`` at which the solution is returned
        (from the solver's dense output).
    options : mapping
        Extra keyword arguments for :func:`scipy.integrate.solve_ivp`.

    Returns
    -------
    y : ndarray, shape (K', ..., n)
        The solution at the first ``K'`` times of ``t_eval``: all of them
        (``K' = K``) unless the solver stopped early.
    sol : OdeResult
        The raw solver answer; when it failed (``sol.status != 0``),
        ``sol.t[-1]`` and ``sol.y[:, -1]`` are the last accepted time and state.

    Examples
    --------
    Two decays ``ẏ = −a y`` (``a = 1, 2``) of shape ``(2, 1)``, as one ODE: the solution at ``t = 0.5`` and
    ``t = 1`` comes back as ``(2, 2, 1)``, ``e^{−a t}``:

    >>> import numpy as np
    >>> a = np.array([[1.0], [2.0]])
    >>> ys, sol = solve_ivp_batch(lambda t, y: -a * y, np.ones((2, 1)), (0.0, 1.0), [0.5, 1.0],
    ...                           {"rtol": 1e-10, "atol": 1e-12})
    >>> ys.shape, sol.status
    ((2, 2, 1), 0)
    >>> bool(np.allclose(ys[..., 0], np.exp(-np.outer([0.5, 1.0], [1.0, 2.0]))))
    True

    ``ẏ = y²`` from ``y = 1`` escapes at ``t = 1``: the solver stops there, and only the times before it come back:

    >>> ys, sol = solve_ivp_batch(lambda t, y: y**2, np.ones(1), (0.0, 2.0), [0.5, 0.9, 1.5, 2.0], {})
    >>> ys.shape, sol.status, bool(sol.t[-1] < 1.0)
    ((2, 1), -1, True)
    >>> np.round(ys[:, 0], 1).tolist()  # 1 / (1 − t)
    [2.0, 10.0]
    """
    y0 = np.asarray(y0, dtype=float)
    shape = y0.shape

    def fun(t: float, flat: Array) -> Array:
        return np.asarray(f(t, flat.reshape(shape)), dtype=float).ravel()

    te = np.asarray(t_eval, dtype=float)
    sol = scipy.integrate.solve_ivp(fun, t_span, y0.ravel(), dense_output=True, **dict(options))
    reached = te[: int(np.searchsorted(te, sol.t[-1], side="right"))] if sol.status != 0 else te
    if reached.size == 0:
        return np.empty((0, *shape)), sol
    ys = np.asarray(sol.sol(reached), dtype=float)
    return np.moveaxis(ys, -1, 0).reshape((reached.size, *shape)), sol
