r"""Moving-horizon estimation: a nonlinear least-squares problem over the last samples, solved at each sample.

A :class:`~nlobs.observers.base.CorrectingObserver` (Rao, Rawlings & Mayne 2003, "Constrained state
estimation for nonlinear discrete-time systems: stability and moving horizon approximations", IEEE
TAC 48(2); Rawlings, Mayne & Diehl 2017, *Model Predictive Control: Theory, Computation, and Design*,
ch. 4). Its state is a :class:`MHEState`.

The problem
-----------
At a sample instant the window holds the last ``N ≤ horizon`` sample instants ``t_0 < … < t_{N−1}``
(the newest is the current one) with their inputs ``u_j`` and outputs ``y_j``. The decision variables
are the states ``x_0 … x_{N−1}`` at the samples and the process noise ``w_0 … w_{N−2}`` of the
intervals; the estimator minimises

.. math:: \|x_0 − \bar x_0\|^2_{P_{\rm arr}^{-1}} + \sum_{j=0}^{N-2} \|w_j\|^2_{Q_j^{-1}}
          + \sum_{j=0}^{N-1} \|y_j − h(x_j, u_j)\|^2_{R_j^{-1}}

subject to ``x_{j+1} = F(x_j, u_j, Δt_j) + w_j`` and ``lower ≤ x_j ≤ upper``, and the estimate is
``x_{N−1}``. Only the outputs sampled at ``t_j`` with a finite value enter the ``j``-th output term
(``R_j`` is ``R`` restricted to them): a missing sample of one run is left out of that run's problem.

* Continuous-time plant ``ẋ = f(x, u) + w`` (``w`` of spectral density ``Q``): ``F`` is ``substeps``
  classical RK4 steps of ``f`` over ``Δt_j = t_{j+1} − t_j`` with ``u`` held at ``u_j``, and
  ``Q_j = Q Δt_j`` (the covariance that white noise of density ``Q`` accumulates over ``Δt_j``, to first
  order).
* Discrete-time plant ``x⁺ = f(x, u) + w_k`` (``w_k`` of covariance ``Q``): ``F = f`` and ``Q_j = Q``
  when a sample comes at every step. Samples ``k_j > 1`` steps apart give ``F = f^{k_j}`` (``u`` held)
  and ``Q_j = k_j Q`` (exact for ``f`` the identity; otherwise an approximation).

A singular ``Q`` or ``P_arr`` is allowed: the noise is written ``w_j = √Q_j ξ_j`` and the first state
``x_0 = x̄_0 + √P_arr η``, with the costs ``‖ξ_j‖²`` and ``‖η‖²`` (the same problem where the inverses
exist).

Arrival cost
------------
Before the window is full, ``x̄_0`` and ``P_arr`` are the estimate and covariance at the first sample:
the initial ``x̂0``, ``P0`` carried there by the prediction below. When the window slides, the dropped
sample's information goes into the arrival cost by one extended-Kalman-filter step (the filtering
update of the arrival cost, Rao, Rawlings & Mayne 2003; Rawlings, Mayne & Diehl 2017, ch. 4): an update of ``(x̄_0, P_arr)`` with the dropped sample's outputs and a
prediction over its interval, linearised at the window's estimate of the dropped state, with the same
``F`` and ``Q_j`` as the problem. For a linear discrete-time plant with Gaussian noise, no bounds and
this arrival cost, the estimate equals the Kalman filter's posterior and the window's states the
Rauch–Tung–Striebel smoother's (the moving-horizon problem is then the full-information one); for a linear
continuous-time plant, those of the Kalman filter of the sampled model ``F``, ``Q_j``.

Between samples
---------------
The estimate is the last solution's newest state carried forward by the model: a continuous plant's
``rhs`` is ``f(x̂, u)`` for the estimate, the EKF's ``F P + P Fᵀ + Q`` for the covariance ``P`` (a
diagnostic: the filtered covariance of the window, propagated) and zero for every other field; a discrete
plant's ``rhs`` is the prediction ``x̂⁺ = f(x̂, u)``, ``P⁺ = F P Fᵀ + Q``. With bounds, :meth:`MHE.estimate`
is that state clipped to ``[lower, upper]`` (at a sample, the solution's newest state, clipped only against
IPOPT's relaxation of the bounds, about 1e-8).

Solving
-------
The nonlinear program is built with CasADi (an optional extra: ``pip install 'nlobs[mhe]'``) once per
window length (and, for a discrete plant, per pattern of steps between samples), with the data as
parameters, and solved by IPOPT with exact derivatives, its primal start the previous solution
shifted by one sample (the new sample's state from the prediction). A batch of runs is solved one
run after the other (one IPOPT call per run and sample). A solve that does not end in IPOPT's
``Solve_Succeeded`` or ``Solved_To_Acceptable_Level`` raises
:class:`~nlobs.errors.SimulationDiverged` naming the time (never a silent fallback).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._frozen import FrozenMapping
from nlobs._typing import Array, BoolArray
from nlobs._validate import as_batch, as_count, as_real_array, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError, SimulationDiverged
from nlobs.observers.base import ToControl
from nlobs.observers.gaussian import ZERO_RATE, checked_covariance, symmetrised
from nlobs.observers.kalman import joseph_update
from nlobs.systems.casadi_expr import casadi_model, import_casadi
from nlobs.systems.linear import LinearSystem
from nlobs.systems.symbolic import CompiledModel, SymbolicModel
from nlobs.systems.timebase import Continuous, Discrete, TimeBase

__all__ = ["MHE", "MHEState"]

#: IPOPT's return statuses taken as a solution.
SOLVED = frozenset({"Solve_Succeeded", "Solved_To_Acceptable_Level"})
#: Options given to CasADi's ``nlpsol`` unless ``ipopt_options`` overrides them: IPOPT quiet.
DEFAULT_OPTIONS: Mapping[str, Any] = FrozenMapping({"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"})

_BUILD_LOCK = threading.RLock()  # builds nest (a problem needs the model and F)


@dataclass(frozen=True)
class MHEState:
    """State of :class:`MHE`: the estimate, the window of samples, the arrival cost and the last solution.

    Every field but ``times`` and ``count`` has the leading batch axes ``(...)`` of the runs. The window
    buffers hold ``horizon`` slots, of which the first ``count`` are in use, oldest first.

    Attributes
    ----------
    x : ndarray, shape (..., n)
        The current estimate (before clipping to the bounds, :meth:`MHE.estimate`).
    P : ndarray, shape (..., n, n)
        Covariance of the estimate: after a sample, the extended Kalman filter's covariance of the
        window's newest state (from the arrival covariance, linearised along the solution); between
        samples, propagated like the EKF's.
    nis : ndarray, shape (...)
        Normalised innovation squared ``νᵀ S⁻¹ ν`` of the newest sample against the prediction:
        ``ν = y − h(x̂⁻)``, ``S = H P⁻ Hᵀ + R`` over the sample's finite outputs (0 before the first one;
        kept by a run whose sample was missing).
    cost : ndarray, shape (...)
        The minimised cost of the last solve.
    iterations : ndarray of int, shape (...)
        IPOPT's iteration count of the last solve.
    times : ndarray, shape (horizon,)
        The window's sample instants (shared by the runs; unused slots 0).
    count : ndarray of int, shape ()
        Number of samples in the window.
    u : ndarray, shape (..., horizon, m)
        The input at each sample instant.
    y : ndarray, shape (..., horizon, p)
        The outputs at each sample instant: a value where ``mask`` is True, 0 elsewhere (not NaN: the
        loops check every float field of a state for finiteness).
    mask : ndarray of bool, shape (..., horizon, p)
        Which outputs enter the problem: sampled at that instant and finite.
    x_arrival, P_arrival : ndarray, shapes (..., n) and (..., n, n)
        The arrival cost's mean ``x̄_0`` and covariance ``P_arr`` at the window's first sample.
    X : ndarray, shape (..., horizon, n)
        The last solution's states at the window's samples (warm start of the next solve).
    w : ndarray, shape (..., horizon − 1, n)
        The last solution's process noise over the window's intervals.

    Examples
    --------
    A random walk ``x⁺ = x + w`` measured directly (``Q = R = P0 = 1``), a batch of four runs and a window of three
    samples; the second run's sample is missing (NaN): it is left out of its problem (its estimate stays the
    prior's), the others get the Kalman posterior ``y/2``:

    >>> import numpy as np
    >>> from nlobs.systems.linear import LinearSystem
    >>> from nlobs.systems.timebase import Discrete
    >>> walk = LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=Discrete(1.0))
    >>> mhe = MHE(walk, [[1.0]], [[1.0]], [[1.0]], horizon=3)
    >>> z = mhe.init(np.zeros((4, 1)))
    >>> z.x.shape, z.X.shape, z.w.shape, z.times.shape, int(z.count)
    ((4, 1), (4, 3, 1), (4, 2, 1), (3,), 0)
    >>> y = np.array([[1.0], [np.nan], [2.0], [-1.0]])
    >>> z = mhe.correct(0.0, z, np.zeros(0), y, np.array([True]))
    >>> int(z.count), z.mask[:, 0, 0].tolist(), z.y[:, 0, 0].tolist()
    (1, [True, False, True, True], [1.0, 0.0, 2.0, -1.0])
    >>> z.x[:, 0].round(6).tolist(), z.P[:, 0, 0].round(6).tolist()
    ([0.5, 0.0, 1.0, -0.5], [0.5, 1.0, 0.5, 0.5])
    """

    x: Array
    P: Array
    nis: Array
    cost: Array
    iterations: Array
    times: Array
    count: Array
    u: Array
    y: Array
    mask: Array
    x_arrival: Array
    P_arrival: Array
    X: Array
    w: Array


def _bounds(lower: Any, upper: Any, n: int) -> tuple[Array, Array]:
    out = []
    for name, value, default in (("lower", lower, -math.inf), ("upper", upper, math.inf)):
        if value is None:
            out.append(readonly(np.full(n, default)))
            continue
        arr = as_real_array(name, value)
        if arr.shape != (n,):
            raise DimensionError(f"{name}: expected shape ({n},), got {arr.shape}")
        if np.isnan(arr).any():
            raise NonFiniteError(f"{name}: entry {int(np.flatnonzero(np.isnan(arr))[0])} is NaN "
                                 "(use -inf or inf for no bound)")
        out.append(readonly(arr))
    lo, hi = out
    bad = np.flatnonzero(lo >= hi)
    if bad.size:
        i = int(bad[0])
        raise InvalidArgumentError(f"lower, upper: lower[{i}] = {float(lo[i])!r} is not below "
                                   f"upper[{i}] = {float(hi[i])!r}")
    return lo, hi


def _options(value: Any) -> FrozenMapping[str, Any]:
    if value is None:
        return FrozenMapping()
    if not isinstance(value, Mapping):
        raise InvalidArgumentError(f"ipopt_options: expected a mapping of option names to values, got "
                                   f"{type(value).__name__}")
    for key, v in value.items():
        if not isinstance(key, str):
            raise InvalidArgumentError(f"ipopt_options: option names are strings, got {key!r}")
        if not isinstance(v, (bool, int, float, str)):
            raise InvalidArgumentError(f"ipopt_options[{key!r}]: expected a number, a bool or a string, got "
                                       f"{type(v).__name__}")
    return FrozenMapping(value)


def _sqrt_psd(M: Array) -> Array:
    """A square ``S`` with ``S Sᵀ = M`` for symmetric positive semi-definite ``M`` (eigenvalues below 0 cut)."""
    lam, V = np.linalg.eigh(symmetrised(M))
    return V * np.sqrt(np.clip(lam, 0.0, None))  # type: ignore[no-any-return]


def _column(v: Any) -> Array:
    return np.asarray(v, dtype=float).reshape(-1)


@dataclass(frozen=True, eq=False)
class MHE(ToControl):
    r"""Moving-horizon estimator (module docstring), for a symbolic or linear plant.

    Parameters
    ----------
    plant : SymbolicModel, CompiledModel or LinearSystem
        The model, continuous or discrete time: a symbolic model, one compiled from a symbolic model
        (its expressions are translated to CasADi, :mod:`nlobs.systems.casadi_expr`), or a linear system.
    Q : array_like, shape (n, n)
        Symmetric positive semi-definite process noise: the spectral density of ``w`` in
        ``ẋ = f(x, u) + w`` (continuous plant), the covariance of ``w_k`` in ``x⁺ = f(x, u) + w_k``
        (discrete plant).
    R : array_like, shape (p, p)
        Symmetric positive definite covariance of the noise on all outputs.
    P0 : array_like, shape (n, n)
        Symmetric positive semi-definite covariance of the initial estimate (the arrival cost until the
        window is full).
    horizon : int
        Number of sample instants in the window (at least 1; 1 makes each solve an iterated EKF update).
    lower, upper : array_like, shape (n,), optional
        Bounds on the state at every sample of the window, with ``lower < upper`` (``-inf``/``inf`` for
        none, the default). Stored as arrays.
    substeps : int
        RK4 steps per sampling interval in the model ``F`` of a continuous plant (unused for a discrete one).
    name : str
        Label in results.
    ipopt_options : mapping, optional
        Options of CasADi's ``nlpsol``, IPOPT's own under ``"ipopt.<name>"`` (``{"ipopt.max_iter": 50}``),
        over :data:`DEFAULT_OPTIONS` (which silence IPOPT).

    Notes
    -----
    The state is a :class:`MHEState`; ``diagnostics`` records ``P_diag`` (the variances of ``P``), ``nis``,
    ``cost`` and ``iterations``. One IPOPT solve per run of a batch at each sample. The object pickles
    (the CasADi problems are built again where it is unpickled, on first use). Rao, Rawlings & Mayne
    (2003); Rawlings, Mayne & Diehl (2017), ch. 4.

    Raises
    ------
    InvalidArgumentError
        CasADi is missing (install ``nlobs[mhe]``); ``plant`` is not a symbolic model, one compiled
        from a symbolic model, or a linear system, or its time base is neither continuous nor discrete;
        ``horizon`` or ``substeps`` is not an integer ≥ 1; ``lower`` is not below ``upper``; a covariance is
        not positive (semi-)definite; ``ipopt_options`` is not a mapping of names to numbers, bools or
        strings, or CasADi refuses one of them.
    DimensionError, NonFiniteError, NotSymmetricError
        ``Q``, ``R``, ``P0``, ``lower`` or ``upper`` of the wrong shape or with a non-finite entry (a
        bound may be infinite, not NaN); a covariance that is not symmetric.
    ModelError
        An expression of the plant has no CasADi form.

    Examples
    --------
    A random walk ``x⁺ = x + w`` (``Q = 1``) measured as ``y = x + v`` (``R = 1``), from ``x̂0 = 0``, ``P0 = 1``.
    The Kalman filter's posteriors for ``y = 1, 2, 0`` are ``1/2``, ``0.5 + 0.6 · 1.5 = 1.4`` and
    ``1.4 − (1.6/2.6) · 1.4 = 0.538462``; the moving-horizon estimate with a window of two samples is the same:

    >>> import numpy as np
    >>> import nlobs
    >>> walk = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
    >>> mhe = MHE(walk, Q=[[1.0]], R=[[1.0]], P0=[[1.0]], horizon=2)
    >>> z, u, fresh = mhe.init([0.0]), np.zeros(0), np.array([True])
    >>> for k, y in enumerate([1.0, 2.0, 0.0]):
    ...     z = mhe.correct(float(k), z, u, np.array([y]), fresh)
    ...     print(k, round(float(z.x[0]), 6), int(z.count), round(float(z.P[0, 0]), 6))
    ...     z = mhe.rhs(float(k), z, u, np.array([y]))  # the prediction to the next step
    0 0.5 1 0.5
    1 1.4 2 0.6
    2 0.538462 2 0.615385

    The shipped pendulum with its angle sampled at 10 Hz (noise 0.01 rad), started 1 rad/s off in the
    unmeasured velocity, the angle bounded to ``[−π, π]``: the error falls from 1 to the noise level, like the
    EKF's on the same samples:

    >>> from nlobs.simulate import MeasurementGroup
    >>> plant = nlobs.load_model("pendulum").compile()
    >>> Q, R, P0 = 1e-4 * np.eye(2), [[1e-4]], np.eye(2)
    >>> mhe = MHE(plant, Q, R, P0, horizon=10, lower=[-np.pi, -np.inf], upper=[np.pi, np.inf])
    >>> run = dict(duration=3.0, dt=1e-2, u=0.0, seed=1,
    ...            measurements=MeasurementGroup("encoder", ["y"], rate=10.0, noise_std=0.01))
    >>> res = nlobs.simulate(plant, mhe, [1.0, 0.0], [0.0, 1.0], **run)
    >>> ekf = nlobs.simulate(plant, nlobs.EKF(plant, Q, R, P0), [1.0, 0.0], [0.0, 1.0], **run)
    >>> [round(float(r.error_norm[0]), 2) for r in (res, ekf)], [round(float(r.error_norm[-1]), 2) for r in (res, ekf)]
    ([1.0, 1.0], [0.02, 0.02])
    >>> sorted(res.extras)
    ['P_diag', 'cost', 'iterations', 'nis']
    """

    plant: Any
    Q: Array
    R: Array
    P0: Array
    horizon: int = field(default=10, kw_only=True)
    lower: Array | None = field(default=None, kw_only=True)
    upper: Array | None = field(default=None, kw_only=True)
    substeps: int = field(default=1, kw_only=True)
    name: str = field(default="MHE", kw_only=True)
    ipopt_options: Mapping[str, Any] | None = field(default=None, kw_only=True)
    time: TimeBase = field(init=False)
    n: int = field(init=False)
    m: int = field(init=False)
    p: int = field(init=False)
    discrete: bool = field(init=False, repr=False)
    _numeric: Any = field(init=False, repr=False)
    _G: Array = field(init=False, repr=False)
    _bounded: bool = field(init=False, repr=False)
    _cache: dict[Any, Any] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        import_casadi("MHE")
        plant = self.plant
        numeric = plant.compile() if isinstance(plant, SymbolicModel) else plant
        if not isinstance(numeric, (CompiledModel, LinearSystem)):
            raise InvalidArgumentError(
                f"plant: expected a SymbolicModel, a model compiled from one or a LinearSystem, got "
                f"{type(plant).__name__} (the estimator needs the equations as expressions)")
        if not isinstance(numeric.time, (Continuous, Discrete)):
            raise InvalidArgumentError(f"plant.time: expected Continuous or Discrete, got {numeric.time!r}")
        n, m, p = int(numeric.n), int(numeric.m), int(numeric.p)
        set_ = object.__setattr__
        set_(self, "time", numeric.time)
        set_(self, "n", n)
        set_(self, "m", m)
        set_(self, "p", p)
        set_(self, "discrete", bool(numeric.time.is_discrete))
        set_(self, "_numeric", numeric)
        set_(self, "Q", checked_covariance("Q", self.Q, n, definite=False))
        set_(self, "R", checked_covariance("R", self.R, p, definite=True))
        set_(self, "P0", checked_covariance("P0", self.P0, n, definite=False))
        set_(self, "horizon", as_count("horizon", self.horizon, minimum=1))
        set_(self, "substeps", as_count("substeps", self.substeps, minimum=1))
        lo, hi = _bounds(self.lower, self.upper, n)
        set_(self, "lower", lo)
        set_(self, "upper", hi)
        set_(self, "_bounded", bool(np.isfinite(lo).any() or np.isfinite(hi).any()))
        if not isinstance(self.name, str):
            raise InvalidArgumentError(f"name: expected a string, got {type(self.name).__name__}")
        set_(self, "ipopt_options", _options(self.ipopt_options))
        lam, V = np.linalg.eigh(self.Q)
        keep = lam > 1e-12 * max(1.0, float(np.max(np.abs(lam), initial=0.0)))
        set_(self, "_G", readonly(V[:, keep] * np.sqrt(lam[keep])))
        set_(self, "_cache", {})
        self._solver(1, ())  # built now: an expression without a CasADi form or a refused option fails here

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_cache"] = {}  # CasADi functions are built again where the object is unpickled
        return state

    def __setstate__(self, state: Mapping[str, Any]) -> None:
        for key, value in state.items():
            object.__setattr__(self, key, value)

    # ------------------------------------------------------------------ CasADi functions
    def _cached(self, key: Any, build: Any) -> Any:
        cache = self._cache
        value = cache.get(key)
        if value is None:
            with _BUILD_LOCK:
                value = cache.get(key)
                if value is None:
                    value = cache[key] = build()
        return value

    def _model(self) -> Any:
        return self._cached("model", lambda: casadi_model(self.plant if isinstance(self.plant, SymbolicModel)
                                                           else self._numeric))

    def _step(self, k: int | None) -> Any:
        """``F(x, u, Δt)``: RK4 substeps of ``f`` (continuous, ``k = None``) or ``f`` applied ``k`` times."""
        def build() -> Any:
            ca = import_casadi("MHE")
            f = self._model().f
            x, u, dt = ca.SX.sym("x", self.n), ca.SX.sym("u", self.m), ca.SX.sym("dt")
            xe = x
            if k is None:
                h = dt / self.substeps
                for _ in range(self.substeps):
                    k1 = f(xe, u)
                    k2 = f(xe + 0.5 * h * k1, u)
                    k3 = f(xe + 0.5 * h * k2, u)
                    k4 = f(xe + h * k3, u)
                    xe = xe + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            else:
                for _ in range(k):
                    xe = f(xe, u)
            return ca.Function("F", [x, u, dt], [xe, ca.jacobian(xe, x)])
        return self._cached(("step", k), build)

    def _out(self) -> Any:
        """``(h, ∂h/∂x)`` of ``(x, u)``."""
        def build() -> Any:
            ca = import_casadi("MHE")
            x, u = ca.SX.sym("x", self.n), ca.SX.sym("u", self.m)
            hx = self._model().h(x, u)
            return ca.Function("H", [x, u], [hx, ca.jacobian(hx, x)])
        return self._cached("out", build)

    def _solver(self, N: int, ks: tuple[int | None, ...]) -> Any:
        """The IPOPT solver of a window of ``N`` samples (``ks``: the step key of each interval)."""
        return self._cached(("nlp", N, ks), lambda: self._build(N, ks))

    def _build(self, N: int, ks: tuple[int | None, ...]) -> Any:
        ca = import_casadi("MHE")
        n, m, p = self.n, self.m, self.p
        r = self._G.shape[1]
        X = ca.SX.sym("X", n, N)
        eta = ca.SX.sym("eta", n)
        xi = ca.SX.sym("xi", r, N - 1)
        x_bar, L = ca.SX.sym("x_bar", n), ca.SX.sym("L", n, n)
        U, Y, M = ca.SX.sym("U", m, N), ca.SX.sym("Y", p, N), ca.SX.sym("M", p, p * N)
        dt, s = ca.SX.sym("dt", N - 1), ca.SX.sym("s", N - 1)
        G = ca.DM(np.asarray(self._G))
        h = self._model().h
        cost = ca.sumsqr(eta) + ca.sumsqr(xi)
        g = [X[:, 0] - x_bar - ca.mtimes(L, eta)]
        for j in range(N):
            cost += ca.sumsqr(ca.mtimes(M[:, j * p:(j + 1) * p], Y[:, j] - h(X[:, j], U[:, j])))
            if j < N - 1:
                nxt = self._step(ks[j])(X[:, j], U[:, j], dt[j])[0]
                if r:
                    nxt = nxt + s[j] * ca.mtimes(G, xi[:, j])
                g.append(X[:, j + 1] - nxt)
        nlp = {"x": ca.vertcat(ca.vec(X), eta, ca.vec(xi)), "f": cost, "g": ca.vertcat(*g),
               "p": ca.vertcat(x_bar, ca.vec(L), ca.vec(U), ca.vec(Y), ca.vec(M), dt, s)}
        options = {**DEFAULT_OPTIONS, **self.ipopt_options}
        try:
            return ca.nlpsol(f"mhe_{N}", "ipopt", nlp, options)
        except RuntimeError as exc:
            lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
            raise InvalidArgumentError(f"ipopt_options: CasADi refused the options ({lines[-1] if lines else exc})") \
                from None

    def _weight(self, ok: BoolArray) -> Array:
        """``M`` with ``Mᵀ M`` equal to ``R`` restricted to the outputs ``ok``, inverted (zero elsewhere)."""
        key = ("weight", ok.tobytes())
        cached = self._cache.get(key)
        if cached is not None:
            return cached  # type: ignore[no-any-return]
        rows = np.flatnonzero(ok)
        W = np.zeros((self.p, self.p))
        if rows.size:
            chol = np.linalg.cholesky(self.R[np.ix_(rows, rows)])
            W[:rows.size, rows] = np.linalg.inv(chol)
        self._cache[key] = W
        return W

    # ------------------------------------------------------------------ protocol
    @property
    def n_x(self) -> int:
        """Estimate dimension (the plant's ``n``)."""
        return self.n

    def init(self, x_hat0: ArrayLike) -> MHEState:
        """The state with the estimate ``x_hat0`` ``(..., n)``, covariance :attr:`P0` and an empty window.

        Parameters
        ----------
        x_hat0 : array_like, shape (..., n)
            The initial estimate (leading axes: a batch of runs).

        Returns
        -------
        MHEState
        """
        x = np.array(as_batch("x_hat0", x_hat0, self.n), dtype=float)
        batch = x.shape[:-1]
        n, H = self.n, self.horizon
        P = np.broadcast_to(self.P0, batch + (n, n)).copy()
        return MHEState(x=x, P=P, nis=np.zeros(batch), cost=np.zeros(batch),
                        iterations=np.zeros(batch, dtype=np.int64), times=np.zeros(H),
                        count=np.zeros((), dtype=np.int64), u=np.zeros(batch + (H, self.m)),
                        y=np.zeros(batch + (H, self.p)), mask=np.zeros(batch + (H, self.p), dtype=bool),
                        x_arrival=x.copy(), P_arrival=P.copy(), X=np.zeros(batch + (H, n)),
                        w=np.zeros(batch + (H - 1, n)))

    def estimate(self, z: MHEState) -> Array:
        """The estimate ``z.x``, clipped to ``[lower, upper]`` where bounds are given.

        Parameters
        ----------
        z : MHEState
            The observer state.

        Returns
        -------
        ndarray, shape (..., n)
        """
        return np.clip(z.x, self.lower, self.upper) if self._bounded else z.x

    def diagnostics(self, z: MHEState, u: Array) -> dict[str, Array]:
        """``P_diag`` (the variances ``(..., n)``), ``nis``, ``cost`` and ``iterations`` ``(...)``.

        Parameters
        ----------
        z : MHEState
            The observer state.
        u : ndarray, shape (..., m)
            The input (unused).

        Returns
        -------
        dict of str to ndarray
        """
        return {"P_diag": z.P.diagonal(0, -2, -1), "nis": z.nis, "cost": z.cost, "iterations": z.iterations}

    def rhs(self, t: float, z: MHEState, u: Array, y: Array) -> MHEState:
        """Between samples: the rates (continuous plant) or the prediction (discrete plant), module docstring.

        Parameters
        ----------
        t : float
            Time.
        z : MHEState
            The observer state.
        u : ndarray, shape (..., m)
            The input.
        y : ndarray, shape (..., p)
            The held measurement (unused: measurements enter at :meth:`correct`).

        Returns
        -------
        MHEState
            ``ż`` (``f(x̂, u)``, ``F P + P Fᵀ + Q``, zero for the other float fields) or ``z⁺``.
        """
        plant = self._numeric
        both = getattr(plant, "rhs_and_jacobian_x", None)
        f, F = both(t, z.x, u) if both is not None else (plant.rhs(t, z.x, u), plant.rhs_jacobian_x(t, z.x, u))
        FP = F @ z.P
        if self.discrete:
            P = symmetrised(FP @ np.swapaxes(F, -1, -2) + self.Q)
            return MHEState(f, P, z.nis, z.cost, z.iterations, z.times, z.count, z.u, z.y, z.mask,
                            z.x_arrival, z.P_arrival, z.X, z.w)
        zero = ZERO_RATE
        return MHEState(f, FP + np.swapaxes(FP, -1, -2) + self.Q, zero, zero, z.iterations, zero, z.count, zero,
                        zero, z.mask, zero, zero, zero, zero)

    def correct(self, t: float, z: MHEState, u: Array, y: Array, fresh: BoolArray) -> MHEState:
        """Add the sample at ``t`` to the window and solve the moving-horizon problem (module docstring).

        Parameters
        ----------
        t : float
            The sample instant (not before the window's newest).
        z : MHEState
            The state before the sample.
        u : ndarray, shape (..., m)
            The input at ``t``.
        y : ndarray, shape (..., p)
            The measurement; a non-finite value at a sampled output is a missing sample of that run,
            left out of its problem.
        fresh : ndarray of bool, shape (p,)
            Which outputs were sampled at ``t`` (none: ``z`` is returned unchanged).

        Returns
        -------
        MHEState
            The state with the new estimate.

        Raises
        ------
        DimensionError
            ``fresh`` is not of shape ``(p,)``.
        InvalidArgumentError
            ``t`` is before the window's newest sample, or IPOPT refused an option.
        SimulationDiverged
            IPOPT did not solve a run's problem (its status is named) or an innovation covariance is singular.
        """
        mask = np.asarray(fresh, dtype=bool)
        if mask.shape != (self.p,):
            raise DimensionError(f"fresh: expected shape ({self.p},), got {mask.shape}")
        if not mask.any():
            return z
        t = float(t)
        n, m, p, H = self.n, self.m, self.p, self.horizon
        y = np.asarray(y, dtype=float)
        u = np.asarray(u, dtype=float)
        batch = np.broadcast_shapes(z.x.shape[:-1], y.shape[:-1], u.shape[:-1], z.nis.shape)
        B = math.prod(batch)

        def flat(a: Array, tail: tuple[int, ...]) -> Array:
            return np.broadcast_to(a, batch + tail).reshape((B,) + tail).copy()

        x_now, P_now, nis = flat(z.x, (n,)), flat(z.P, (n, n)), flat(z.nis, ())
        ub, yb, mb = flat(z.u, (H, m)), flat(z.y, (H, p)), flat(z.mask, (H, p))
        xa, Pa = flat(z.x_arrival, (n,)), flat(z.P_arrival, (n, n))
        Xs, Ws = flat(z.X, (H, n)), flat(z.w, (H - 1, n))
        Yn, Un = flat(y, (p,)), flat(u, (m,))
        times = np.array(z.times, dtype=float)
        c = int(z.count)
        if c and t < times[c - 1]:
            raise InvalidArgumentError(f"{self.name}: a sample at t = {t:g} before the window's newest, "
                                       f"t = {times[c - 1]:g}")
        ok = mask & np.isfinite(Yn)
        try:
            for b in np.flatnonzero(ok.any(axis=-1)):
                nis[b] = self._nis(x_now[b], P_now[b], Un[b], Yn[b], ok[b])
            if c == 0:
                xa, Pa = x_now.copy(), P_now.copy()
            elif c == H:  # slide: the oldest sample goes into the arrival cost
                key, dt0, s0 = self._interval(times[0], times[1] if H > 1 else t)
                for b in range(B):
                    xa[b], Pa[b] = self._arrival(xa[b], Pa[b], Xs[b, 0], ub[b, 0], yb[b, 0], mb[b, 0], key, dt0, s0)
                for buf in (ub, yb, mb, Xs):
                    buf[:, :-1] = buf[:, 1:]
                Ws[:, :-1] = Ws[:, 1:]
                times[:-1] = times[1:]
                c = H - 1
        except np.linalg.LinAlgError as exc:
            raise self._failed(t, f"an innovation covariance is singular ({exc})") from None
        N = c + 1
        times[c] = t
        ub[:, c], yb[:, c], mb[:, c] = Un, np.where(ok, Yn, 0.0), ok
        intervals = [self._interval(times[j], times[j + 1]) for j in range(N - 1)]
        keys = tuple(iv[0] for iv in intervals)
        dts = np.array([iv[1] for iv in intervals])
        ss = np.array([iv[2] for iv in intervals])
        x_out, P_out = np.empty((B, n)), np.empty((B, n, n))
        cost, iters = np.empty(B), np.empty(B, dtype=np.int64)
        for b in range(B):
            X0 = np.concatenate([Xs[b, :c], x_now[b][None]], axis=0)
            W0 = np.concatenate([Ws[b, :c - 1], np.zeros((1, n))], axis=0) if N > 1 else np.zeros((0, n))
            run = f" (run {b})" if B > 1 else ""
            X, W, cost[b], iters[b] = self._solve(t, run, N, keys, dts, ss, xa[b], Pa[b], ub[b, :N], yb[b, :N],
                                                  mb[b, :N], X0, W0)
            Xs[b, :N], Ws[b, :N - 1] = X, W
            try:
                P_out[b] = self._filtered_covariance(Pa[b], X, ub[b, :N], mb[b, :N], keys, dts, ss)
            except np.linalg.LinAlgError as exc:
                raise self._failed(t, f"an innovation covariance is singular ({exc})") from None
            x_out[b] = X[N - 1]
        if self._bounded:
            np.clip(x_out, self.lower, self.upper, out=x_out)
        times[N:] = 0.0

        def back(a: Array, tail: tuple[int, ...]) -> Array:
            return a.reshape(batch + tail)

        return MHEState(x=back(x_out, (n,)), P=back(P_out, (n, n)), nis=back(nis, ()), cost=back(cost, ()),
                        iterations=back(iters, ()), times=times, count=np.array(N, dtype=np.int64),
                        u=back(ub, (H, m)), y=back(yb, (H, p)), mask=back(mb, (H, p)),
                        x_arrival=back(xa, (n,)), P_arrival=back(Pa, (n, n)), X=back(Xs, (H, n)),
                        w=back(Ws, (H - 1, n)))

    # ------------------------------------------------------------------ the pieces of a correction
    def _interval(self, t0: float, t1: float) -> tuple[int | None, float, float]:
        """``(step key, Δt, √(Q_j/Q))`` of the interval from ``t0`` to ``t1``."""
        dt = float(t1 - t0)
        if not self.discrete:
            return None, dt, math.sqrt(max(dt, 0.0))
        assert isinstance(self.time, Discrete)
        k = max(int(round(dt / self.time.dt)), 0)
        return k, dt, math.sqrt(k)

    def _failed(self, t: float, what: str) -> SimulationDiverged:
        err = SimulationDiverged(float(t), "observer", f"{self.name} solution")
        err.args = (f"{self.name} failed at t = {float(t):g}: {what}",)
        return err

    def _nis(self, x: Array, P: Array, u: Array, y: Array, ok: BoolArray) -> float:
        h, Hx = (np.asarray(v, dtype=float) for v in self._out()(x, u))
        rows = np.flatnonzero(ok)
        Hr = Hx[rows]
        nu = y[rows] - h.reshape(-1)[rows]
        S = Hr @ P @ Hr.T + self.R[np.ix_(rows, rows)]
        return float(nu @ np.linalg.solve(S, nu))

    def _predict(self, key: int | None, x: Array, u: Array, dt: float) -> tuple[Array, Array]:
        F, A = self._step(key)(x, u, dt)
        return _column(F), np.asarray(A, dtype=float).reshape(self.n, self.n)

    def _arrival(self, xa: Array, Pa: Array, x0: Array, u0: Array, y0: Array, ok0: BoolArray,
                 key: int | None, dt: float, s: float) -> tuple[Array, Array]:
        """The EKF step of the arrival cost over the dropped sample, linearised at its estimate ``x0``."""
        rows = np.flatnonzero(ok0)
        xp, Pp = xa, Pa
        if rows.size:
            h, Hx = (np.asarray(v, dtype=float) for v in self._out()(x0, u0))
            Hr = Hx.reshape(self.p, self.n)[rows]
            nu = y0[rows] - h.reshape(-1)[rows] - Hr @ (xa - x0)
            dx, Pp = joseph_update(Pa, Hr, self.R[np.ix_(rows, rows)], nu)
            xp = xa + dx
        F, A = self._predict(key, x0, u0, dt)
        return F + A @ (xp - x0), symmetrised(A @ Pp @ A.T + (s * s) * self.Q)

    def _linearised(self, N: int, ks: tuple[int | None, ...]) -> Any:
        """``(∂h/∂x at every sample (p, n N), ∂F/∂x over every interval (n, n (N − 1)))`` of ``(X, U, Δt)``:
        the Jacobians along a window's solution in one call."""
        def build() -> Any:
            ca = import_casadi("MHE")
            n, m = self.n, self.m
            X, U, dt = ca.SX.sym("X", n, N), ca.SX.sym("U", m, N), ca.SX.sym("dt", N - 1)
            Hs = [self._out()(X[:, j], U[:, j])[1] for j in range(N)]
            As = [self._step(ks[j])(X[:, j], U[:, j], dt[j])[1] for j in range(N - 1)]
            return ca.Function("lin", [X, U, dt], [ca.horzcat(*Hs), ca.horzcat(*As) if As else ca.SX(n, 0)])
        return self._cached(("lin", N, ks), build)

    def _filtered_covariance(self, Pa: Array, X: Array, U: Array, ok: BoolArray, keys: tuple[int | None, ...],
                             dts: Array, ss: Array) -> Array:
        """The EKF covariance of the window's newest state: from ``P_arr`` through the window, along ``X``."""
        n, p = self.n, self.p
        N = X.shape[0]
        Hs, As = self._linearised(N, keys)(X.T, U.T, dts)
        Hs, As = np.asarray(Hs, dtype=float), np.asarray(As, dtype=float)
        P = Pa
        for j in range(N):
            rows = np.flatnonzero(ok[j])
            if rows.size:
                Hr = Hs.reshape(p, N * n)[rows, j * n:(j + 1) * n]
                P = joseph_update(P, Hr, self.R[np.ix_(rows, rows)], np.zeros(rows.size))[1]
            if j < N - 1:
                Aj = As[:, j * n:(j + 1) * n]
                P = symmetrised(Aj @ P @ Aj.T + (ss[j] * ss[j]) * self.Q)
        return P

    def _solve(self, t: float, run: str, N: int, keys: tuple[int | None, ...], dts: Array, ss: Array, xa: Array,
               Pa: Array, U: Array, Y: Array, ok: BoolArray, X0: Array, W0: Array) -> tuple[Array, Array, float, int]:
        """One IPOPT solve of one run: ``(states (N, n), noise (N − 1, n), cost, iterations)``."""
        n, r = self.n, self._G.shape[1]
        solver = self._solver(N, keys)
        L = _sqrt_psd(Pa)
        weights = np.concatenate([self._weight(ok[j]).ravel(order="F") for j in range(N)])
        params = np.concatenate([xa, L.ravel(order="F"), U.ravel(), Y.ravel(), weights, dts, ss])
        if self._bounded:
            X0 = np.clip(X0, self.lower, self.upper)
        eta0 = np.linalg.lstsq(L, X0[0] - xa, rcond=None)[0]
        if r and N > 1:
            Gp = np.linalg.pinv(np.asarray(self._G))
            xi0 = np.array([Gp @ W0[j] / ss[j] if ss[j] > 0 else np.zeros(r) for j in range(N - 1)])
        else:
            xi0 = np.zeros((N - 1, r))
        inf = np.full(n + r * (N - 1), np.inf)
        lbx = np.concatenate([np.tile(self.lower, N), -inf])
        ubx = np.concatenate([np.tile(self.upper, N), inf])
        sol = solver(x0=np.concatenate([X0.ravel(), eta0, xi0.ravel()]), p=params, lbx=lbx, ubx=ubx, lbg=0.0,
                     ubg=0.0)
        stats = solver.stats()
        status = str(stats.get("return_status", "unknown"))
        if status not in SOLVED:
            if status == "Invalid_Option":
                raise InvalidArgumentError(f"ipopt_options: IPOPT refused an option ({dict(self.ipopt_options)})")
            raise self._failed(t, f"IPOPT returned {status}{run} after {int(stats.get('iter_count', 0))} "
                                  "iterations")
        v = _column(sol["x"])
        X = v[:N * n].reshape(N, n)
        xi = v[N * n + n:].reshape(N - 1, r)
        W = (ss[:, None] * (xi @ np.asarray(self._G).T)) if r else np.zeros((N - 1, n))
        return X, W, float(sol["f"]), int(stats.get("iter_count", 0))
