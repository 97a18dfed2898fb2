r"""The bootstrap particle filter for any plant: continuous-discrete or discrete, batched over runs and particles.

A :class:`~nlobs.observers.base.CorrectingObserver` whose state is a :class:`ParticleState`: ``N`` weighted
samples of the plant state for each run of a batch. It needs only the plant's ``rhs`` and ``output``, called
once per stage on all particles of all runs (an array of shape ``(..., N, n)``, the input as ``(..., 1, m)``).

The bootstrap filter (Gordon, Salmond & Smith 1993, "Novel approach to nonlinear/non-Gaussian Bayesian state
estimation", IEE Proceedings F 140(2)), with the noise conventions of the EKF and the UKF of nlobs
(:mod:`nlobs.observers.gaussian`):

* **Prediction.** Each particle follows the plant's model: for a continuous-time plant
  ``ẋ = f(x, u) + w`` (``w`` white of spectral density ``Q``) one RK4 step of ``f`` with ``u`` held over
  the step, plus the increment ``√h · L ξ`` (``L Lᵀ = Q``, ``ξ ~ N(0, I)``: Euler–Maruyama on the noise);
  for a discrete-time plant ``x⁺ = f(x, u) + L ξ`` (``Q`` the covariance of ``w_k``). With bounds the new
  particles are clipped into ``[lower, upper]``: the constraints as the proposal respects them.
* **Correction.** At a sample of the outputs ``J`` each weight is multiplied by the Gaussian likelihood
  ``exp(−½ (y_J − h_J(xᵢ))ᵀ R_JJ⁻¹ (y_J − h_J(xᵢ)))``, in logarithms, and normalised by log-sum-exp.
  A non-finite ``y`` at a sampled output is a missing sample of that run: that row is left out for that run.
* **Resampling.** Where the effective sample size ``ESS = 1 / Σ wᵢ²`` falls below
  ``resample_threshold · N`` (the criterion of Doucet & Johansen 2009, "A tutorial on particle filtering
  and smoothing: fifteen years later"), that run is resampled systematically (Kitagawa 1996, "Monte Carlo
  filter and smoother for non-Gaussian nonlinear state space models", J. Comput. Graph. Stat. 5(1);
  :func:`systematic_resample`) and roughened as Gordon, Salmond & Smith (1993, §IV) propose: every state
  ``j`` of every particle gets a jitter ``N(0, σⱼ²)``, ``σⱼ = K Eⱼ N^(−1/n)``, ``Eⱼ`` the range of state
  ``j`` over the resampled particles and ``K = roughening``; then the weights are equal again.

The estimate is the weighted mean. The diagnostics are the weighted variances, the effective sample size of
the last correction (after the reweighting, before any resampling) and its normalised innovation squared
``νᵀ S⁻¹ ν`` from the Gaussian approximation of the predicted output (before the reweighting):
``ν = y − Σ wᵢ h(xᵢ)``, ``S = Σ wᵢ (h(xᵢ) − ȳ)(h(xᵢ) − ȳ)ᵀ + R``.

Randomness without a hidden generator
-------------------------------------
The filter object holds no generator, and the state only an integer ``counter`` (one more after every call
that may draw). Each draw comes from ``np.random.default_rng([seed, counter, purpose])`` (``purpose`` 0: the
initial cloud, 1: the process noise, 2: the resampling offsets, 3: the roughening), one draw for the whole
batch: the same calls on the same data give the same numbers, bit for bit, and the runs of a batch draw
independent numbers. Run ``i`` of a batch takes the ``i``-th block of each draw, so its numbers depend on its
position in the batch but not on the batch's size (run 0 of a batch is the run made alone).

If every particle's updated weight of a run underflows to zero (the sample is incompatible with the whole
cloud), the correction raises :class:`~nlobs.errors.SimulationDiverged` naming the time, instead of
returning weights that are ``0 / 0``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray, IntArray
from nlobs._validate import as_batch, as_count, as_real_array, in_range, positive, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError, SimulationDiverged
from nlobs.observers.base import ToControl
from nlobs.observers.gaussian import checked_covariance, checked_plant
from nlobs.systems.base import PlantModel
from nlobs.systems.sensors import covariance_factor
from nlobs.systems.timebase import TimeBase

__all__ = ["ParticleFilter", "ParticleState", "systematic_resample"]

#: The purposes of the draws (the third key of each generator, module docstring).
_INIT, _PROCESS, _RESAMPLE, _ROUGHEN = 0, 1, 2, 3

#: The logarithm of a zero weight, kept finite: the loops read a non-finite state as a divergence.
LOG_ZERO = -1e300


@dataclass(frozen=True)
class ParticleState:
    """State of :class:`ParticleFilter`: the weighted particles of each run (leading axes: the runs).

    Attributes
    ----------
    particles : ndarray, shape (..., N, n)
        The particles.
    log_weights : ndarray, shape (..., N)
        Their normalised log weights (``Σ exp = 1`` for each run; a zero weight is kept as
        :data:`LOG_ZERO`, finite).
    counter : int
        The key of the next draw (the second key of the generators, module docstring): 1 after :meth:`init`,
        one more after each prediction, step and correction (a correction with nothing sampled keeps it).
    nis : ndarray, shape (...)
        Normalised innovation squared of the last correction of each run (0 before the first one; kept
        by a run that skipped a missing sample).
    ess : ndarray, shape (...)
        Effective sample size ``1 / Σ wᵢ²`` of the last correction (after the reweighting, before any
        resampling; ``N`` before the first correction).

    Examples
    --------
    A filter of a scalar random walk with 100 particles, for a batch of 3 runs: the state carries the runs'
    axis in every field, the weights are equal after :meth:`ParticleFilter.init`, and one sample reweights
    them (the effective sample size drops below ``N``):

    >>> import numpy as np
    >>> import nlobs
    >>> plant = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
    >>> from nlobs.observers.particle import ParticleFilter
    >>> pf = ParticleFilter(plant, [[0.01]], [[0.1]], [[1.0]], particles=100)
    >>> z = pf.init(np.zeros((3, 1)))
    >>> z.particles.shape, z.log_weights.shape, z.nis.shape, z.ess.tolist(), z.counter
    ((3, 100, 1), (3, 100), (3,), [100.0, 100.0, 100.0], 1)
    >>> bool(np.allclose(np.exp(z.log_weights), 0.01))
    True
    >>> z1 = pf.correct(0.0, z, np.zeros((3, 0)), np.full((3, 1), 0.5), np.array([True]))
    >>> bool(np.all(z1.ess < 100)), bool(np.allclose(np.exp(z1.log_weights).sum(axis=-1), 1.0)), z1.counter
    (True, True, 2)
    """

    particles: Array
    log_weights: Array
    counter: int
    nis: Array
    ess: Array


def systematic_resample(weights: ArrayLike, offsets: ArrayLike) -> IntArray:
    """Ancestor indices of systematic resampling (Kitagawa 1996), for each row of weights at once.

    With the cumulative weights ``cᵢ = (w₀ + … + wᵢ) / Σ w`` (``c₋₁ = 0``, ``c_{N−1} = 1``) and the offset
    ``u ∈ [0, 1)`` of the row, the ``N`` positions ``(u + j) / N`` are sorted into the intervals
    ``[c_{i−1}, cᵢ)``: particle ``i`` is copied once for each ``j`` with ``N c_{i−1} − u ≤ j < N cᵢ − u``,
    i.e. ``⌊N wᵢ⌋`` or ``⌈N wᵢ⌉`` times (``N`` copies in all). The copies are counted in one pass over every
    row (no search, no loop over rows).

    Parameters
    ----------
    weights : array_like, shape (..., N)
        Non-negative finite weights of each row, not all zero (normalised here).
    offsets : array_like, shape (...)
        The offset ``u`` of each row, in ``[0, 1)`` (uniform draws make the scheme unbiased).

    Returns
    -------
    ndarray of int, shape (..., N)
        For each row the indices of the particles to keep, in non-decreasing order.

    Raises
    ------
    DimensionError
        ``weights`` has no axis, or ``offsets`` is not of shape ``weights.shape[:-1]``.
    NonFiniteError
        A weight or an offset is not finite.
    InvalidArgumentError
        A negative weight, a row of zeros, an offset outside ``[0, 1)``.

    Examples
    --------
    Weights ``(0.1, 0.2, 0.3, 0.4)``: with the offset ``0.5`` the positions ``0.125, 0.375, 0.625, 0.875``
    fall in the intervals of particles 1, 2, 3, 3; two rows are resampled together:

    >>> systematic_resample([0.1, 0.2, 0.3, 0.4], 0.5)
    array([1, 2, 3, 3])
    >>> systematic_resample([[1.0, 1.0, 0.0, 2.0], [0.0, 0.0, 5.0, 0.0]], [0.0, 0.99])
    array([[0, 1, 3, 3],
           [2, 2, 2, 2]])
    """
    w = as_real_array("weights", weights)
    u = as_real_array("offsets", offsets)
    if w.ndim == 0 or w.shape[-1] == 0:
        raise DimensionError(f"weights: expected shape (..., N) with N ≥ 1, got {w.shape}")
    if u.shape != w.shape[:-1]:
        raise DimensionError(f"offsets: expected shape {w.shape[:-1]} (one per row of weights), got {u.shape}")
    if not (np.isfinite(w).all() and np.isfinite(u).all()):
        raise NonFiniteError("systematic_resample: weights and offsets must be finite")
    if np.any(w < 0):
        raise InvalidArgumentError("weights: must be non-negative")
    if np.any((u < 0) | (u >= 1)):
        raise InvalidArgumentError("offsets: must lie in [0, 1)")
    c = np.cumsum(w, axis=-1)
    if np.any(c[..., -1] <= 0):
        raise InvalidArgumentError("weights: a row sums to zero")
    return _systematic(c, u)


def _systematic(c: Array, u: Array) -> IntArray:
    """:func:`systematic_resample` of unnormalised cumulative weights ``c`` ``(..., N)`` (positive totals)."""
    n_part = c.shape[-1]
    c = c / c[..., -1:]
    c[..., -1] = 1.0  # the total, exactly: every row gets N copies
    edges = np.ceil(n_part * c - u[..., None]).astype(np.intp)  # copies of particles 0..i: ≥ 0, ends at N
    counts = np.diff(edges, axis=-1, prepend=0)
    rows = int(np.prod(c.shape[:-1], dtype=np.intp))
    local = np.tile(np.arange(n_part, dtype=np.intp), rows)
    return np.repeat(local, counts.reshape(-1)).reshape(c.shape)


def _bounds(lower: ArrayLike | None, upper: ArrayLike | None, n: int) -> tuple[Array, Array] | None:
    """``(lower, upper)`` as read-only ``(n,)`` arrays (``∓inf`` where one is not given), or ``None`` without bounds."""
    if lower is None and upper is None:
        return None
    out = []
    for name, value, default in (("lower", lower, -np.inf), ("upper", upper, np.inf)):
        arr = np.full(n, default) if value is None else as_real_array(name, value)
        if arr.shape != (n,):
            raise DimensionError(f"{name}: expected shape ({n},) (one bound per state), got {arr.shape}")
        if np.isnan(arr).any():
            raise NonFiniteError(f"{name}: entry {int(np.flatnonzero(np.isnan(arr))[0])} is nan "
                                 "(a bound may be ±inf, not NaN)")
        out.append(arr)
    lo, hi = out
    bad = np.flatnonzero(~(lo < hi))
    if bad.size:
        i = int(bad[0])
        raise InvalidArgumentError(f"lower, upper: state {i} has lower = {float(lo[i])!r} ≥ upper = {float(hi[i])!r}; "
                                   "each lower bound must be below its upper bound")
    return readonly(lo), readonly(hi)


@dataclass(frozen=True, eq=False)
class ParticleFilter(ToControl):
    r"""Bootstrap particle filter (module docstring): continuous-discrete for a continuous plant, discrete otherwise.

    Parameters
    ----------
    plant : PlantModel
        The model (``rhs`` and ``output``, batched over leading axes; no Jacobians needed), with a
        :class:`~nlobs.systems.timebase.Continuous` or :class:`~nlobs.systems.timebase.Discrete` time base.
    Q : array_like, shape (n, n)
        Symmetric positive semi-definite process noise: the spectral density of ``w`` in
        ``ẋ = f(x, u) + w`` (continuous plant), the covariance of ``w_k`` in ``x⁺ = f(x, u) + w_k``
        (discrete plant).
    R : array_like, shape (p, p)
        Symmetric positive definite covariance of the noise on all outputs.
    P0 : array_like, shape (n, n)
        Symmetric positive semi-definite covariance of the initial cloud about ``x̂0`` (:meth:`init`).
    particles : int
        Number ``N ≥ 2`` of particles of each run.
    seed : int
        Non-negative seed of every draw (module docstring): the same seed gives the same numbers.
    roughening : float
        The constant ``K ≥ 0`` of the roughening after a resampling (Gordon, Salmond & Smith 1993, §IV);
        0 turns it off.
    resample_threshold : float
        A run is resampled when its effective sample size falls below ``resample_threshold · N``; in
        ``(0, 1]`` (1: at nearly every sample).
    lower, upper : array_like, shape (n,), optional
        Bounds of the states (``±inf`` for none on a state): every particle is clipped into them after
        each draw. Each lower bound must lie below its upper bound.
    name : str
        Label in results.

    Attributes
    ----------
    time : Continuous or Discrete
        The plant's time base.
    n, p : int
        Numbers of states and outputs.

    Raises
    ------
    InvalidArgumentError
        ``plant`` is not a :class:`~nlobs.systems.base.PlantModel` with a continuous or discrete time base,
        a covariance that is not positive (semi-)definite, ``particles`` not an integer ≥ 2, ``seed`` not
        an integer ≥ 0, a negative ``roughening``, ``resample_threshold`` outside ``(0, 1]``, a lower
        bound not below its upper bound, ``name`` not a string.
    DimensionError, NonFiniteError, NotSymmetricError
        For ``Q``, ``R``, ``P0`` or the bounds of the wrong shape or with a non-finite (bounds: NaN)
        entry; a covariance that is not symmetric.

    Notes
    -----
    The cost of a step is linear in ``N`` and in the number of runs: one call of the plant's ``rhs`` per
    RK4 stage and one of ``output`` per correction, on all particles of all runs at once.

    Examples
    --------
    The pendulum (a shipped model) with its angle sampled at 10 Hz, started 1 rad/s off in the unmeasured
    velocity, as in the example of :class:`~nlobs.observers.ekf.EKF`: the first sample pulls the angle onto
    the measurement, the velocity follows:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import MeasurementGroup
    >>> from nlobs.observers.particle import ParticleFilter
    >>> plant = nlobs.load_model("pendulum").compile()
    >>> pf = ParticleFilter(plant, Q=1e-4 * np.eye(2), R=[[1e-4]], P0=np.eye(2), particles=500, seed=1)
    >>> res = nlobs.simulate(plant, pf, [1.0, 0.0], [0.0, 1.0], duration=3.0, dt=1e-2, u=0.0,
    ...                      measurements=MeasurementGroup("encoder", ["y"], rate=10.0))
    >>> bool(abs(res.error[0, 0]) < 0.02), bool(res.error_norm[-1] < 0.05)
    (True, True)
    >>> sorted(res.extras), res.extras["ess"].shape
    (['P_diag', 'ess', 'nis'], (301,))

    Bad arguments are refused with one line naming them:

    >>> try:
    ...     ParticleFilter(plant, np.eye(2), [[1.0]], np.eye(2), particles=1)
    ... except nlobs.errors.InvalidArgumentError as exc:
    ...     print(exc)
    particles: expected an integer ≥ 2, got 1
    """

    plant: PlantModel
    Q: Array
    R: Array
    P0: Array
    particles: int = field(default=1000, kw_only=True)
    seed: int = field(default=0, kw_only=True)
    roughening: float = field(default=0.2, kw_only=True)
    resample_threshold: float = field(default=0.5, kw_only=True)
    lower: Array | None = field(default=None, kw_only=True)
    upper: Array | None = field(default=None, kw_only=True)
    name: str = field(default="PF", kw_only=True)
    time: TimeBase = field(init=False)
    n: int = field(init=False)
    p: int = field(init=False)
    discrete: bool = field(init=False, repr=False)
    q_factor: Array | None = field(init=False, repr=False)
    p0_factor: Array = field(init=False, repr=False)

    def __post_init__(self) -> None:
        plant = self.plant
        n, p = checked_plant(plant)
        set_ = object.__setattr__
        set_(self, "time", plant.time)
        set_(self, "n", n)
        set_(self, "p", p)
        set_(self, "discrete", bool(plant.time.is_discrete))
        set_(self, "Q", checked_covariance("Q", self.Q, n, definite=False))
        set_(self, "R", checked_covariance("R", self.R, p, definite=True))
        set_(self, "P0", checked_covariance("P0", self.P0, n, definite=False))
        set_(self, "particles", as_count("particles", self.particles, minimum=2))
        set_(self, "seed", as_count("seed", self.seed, minimum=0))
        set_(self, "roughening", positive("roughening", self.roughening, allow_zero=True))
        set_(self, "resample_threshold", in_range("resample_threshold", self.resample_threshold, 0.0, 1.0,
                                                  lo_open=True, hi_open=False))
        bounds = _bounds(self.lower, self.upper, n)
        set_(self, "lower", None if bounds is None else bounds[0])
        set_(self, "upper", None if bounds is None else bounds[1])
        if not isinstance(self.name, str):
            raise InvalidArgumentError(f"name: expected a string, got {type(self.name).__name__}")
        set_(self, "q_factor", readonly(covariance_factor(self.Q)) if np.any(self.Q) else None)
        set_(self, "p0_factor", readonly(covariance_factor(self.P0)))

    @property
    def n_x(self) -> int:
        """Estimate dimension (the plant's ``n``)."""
        return self.n

    # ------------------------------------------------------------------ helpers
    def _rng(self, counter: int, purpose: int) -> np.random.Generator:
        """``np.random.default_rng([seed, counter, purpose])``, built without the dispatch of ``default_rng``."""
        return np.random.Generator(np.random.PCG64(np.random.SeedSequence([self.seed, int(counter), purpose])))

    def _clip(self, X: Array) -> Array:
        if self.lower is None or self.upper is None:
            return X
        return np.clip(X, self.lower, self.upper, out=X)

    @staticmethod
    def _per_particle(u: Array) -> Array:
        """``u`` ``(..., m)`` as ``(..., 1, m)``: the same input for every particle of a run."""
        return np.asarray(u, dtype=float)[..., None, :]

    def _with_noise(self, X: Array, counter: int, scale: float) -> Array:
        """``X + scale · L ξ`` (``L Lᵀ = Q``), clipped; ``X`` is a fresh array of this call (written in place)."""
        if self.q_factor is not None:
            xi = self._rng(counter, _PROCESS).standard_normal(X.shape)
            X += scale * (xi @ self.q_factor.T)
        return self._clip(X)

    def _diverged(self, t: float, what: str) -> SimulationDiverged:
        err = SimulationDiverged(float(t), "observer", f"{self.name} weights")
        err.args = (f"{self.name} diverged at t = {float(t):g}: {what}",)
        return err

    # ------------------------------------------------------------------ the protocol
    def init(self, x_hat0: ArrayLike) -> ParticleState:
        """The initial cloud about ``x_hat0``: ``N`` particles drawn from ``N(x̂0, P0)``, equal weights.

        The draws are centred on their own mean before ``P0``'s factor is applied, so the weighted mean is
        ``x̂0`` (to rounding) unless the bounds clip particles.

        Parameters
        ----------
        x_hat0 : array_like, shape (..., n)
            The initial estimate of each run (leading axes: the runs).

        Returns
        -------
        ParticleState
            Particles ``(..., N, n)`` clipped into the bounds, log weights ``−log N``, ``counter`` 1,
            NIS 0, ESS ``N``.

        Raises
        ------
        DimensionError, NonFiniteError
            ``x_hat0`` is not of shape ``(..., n)`` or not finite.

        Examples
        --------
        >>> import numpy as np
        >>> import nlobs
        >>> from nlobs.observers.particle import ParticleFilter
        >>> plant = nlobs.LinearSystem(np.eye(2), np.zeros((2, 0)), [[1.0, 0.0]], time=nlobs.Discrete(1.0))
        >>> pf = ParticleFilter(plant, np.zeros((2, 2)), [[1.0]], np.diag([1.0, 4.0]), particles=20000)
        >>> z = pf.init([1.0, -1.0])
        >>> z.particles.shape, pf.estimate(z).round(12).tolist()
        ((20000, 2), [1.0, -1.0])
        >>> np.sqrt(pf.diagnostics(z, np.zeros(0))["P_diag"]).round(1).tolist()  # standard deviations 1 and 2
        [1.0, 2.0]
        """
        x = as_batch("x_hat0", x_hat0, self.n)
        batch = x.shape[:-1]
        N = self.particles
        xi = self._rng(0, _INIT).standard_normal((*batch, N, self.n))
        xi -= xi.mean(axis=-2, keepdims=True)
        X = self._clip(x[..., None, :] + xi @ self.p0_factor.T)
        return ParticleState(particles=X, log_weights=np.full((*batch, N), -math.log(N)), counter=1,
                             nis=np.zeros(batch), ess=np.full(batch, float(N)))

    def rhs(self, t: float, z: ParticleState, u: Array, y: Array) -> ParticleState:
        """The prediction (discrete plant) or the particles' drift (continuous plant).

        Discrete plant: every particle becomes ``f(xᵢ, u) + wᵢ``, ``wᵢ ~ N(0, Q)``, clipped into the bounds
        (``counter`` one more). Continuous plant: the rates ``(f(xᵢ, u), 0, 0, 0)`` of the particles, the
        log weights, the NIS and the ESS (the loop advances a continuous filter by :meth:`step`, which adds
        the process noise; ``rhs`` is the drift alone).

        Parameters
        ----------
        t : float
            Time.
        z : ParticleState
            The filter state.
        u : ndarray, shape (..., m)
            The known input of each run.
        y : ndarray, shape (..., p)
            The held measurement (not used: the filter corrects in :meth:`correct`).

        Returns
        -------
        ParticleState
            The predicted state (discrete) or its time derivative (continuous).

        Examples
        --------
        A discrete random walk without process noise keeps its particles; the continuous scalar decay
        ``ẋ = −x`` gives the drift ``−xᵢ`` of every particle:

        >>> import numpy as np
        >>> import nlobs
        >>> from nlobs.observers.particle import ParticleFilter
        >>> walk = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
        >>> pf = ParticleFilter(walk, [[0.0]], [[1.0]], [[1.0]], particles=4)
        >>> z = pf.init([0.0])
        >>> z1 = pf.rhs(0.0, z, np.zeros(0), np.zeros(1))
        >>> bool(np.array_equal(z1.particles, z.particles)), z1.counter
        (True, 2)
        >>> decay = nlobs.LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
        >>> pf = ParticleFilter(decay, [[0.0]], [[1.0]], [[1.0]], particles=4)
        >>> z = pf.init([0.0])
        >>> bool(np.array_equal(pf.rhs(0.0, z, np.zeros(0), np.zeros(1)).particles, -z.particles))
        True
        """
        X = z.particles
        f = self.plant.rhs(t, X, self._per_particle(u))
        if self.discrete:
            X_new = self._with_noise(np.array(f, dtype=float), z.counter, 1.0)
            return ParticleState(X_new, z.log_weights, z.counter + 1, z.nis, z.ess)
        return ParticleState(np.asarray(f, dtype=float), np.zeros(np.shape(z.log_weights)), z.counter,
                             np.zeros(np.shape(z.nis)), np.zeros(np.shape(z.ess)))

    def step(self, t: float, z: ParticleState, u: Array, y: Array, h: float) -> ParticleState:
        """The particles at ``t + h`` (continuous plant): one RK4 step of ``f`` with ``u`` held, plus process noise.

        Each particle gets ``RK4(xᵢ) + √h · L ξᵢ`` (``L Lᵀ = Q``, Euler–Maruyama on the noise), clipped into
        the bounds; the weights, NIS and ESS are kept; ``counter`` one more.

        Parameters
        ----------
        t : float
            Start of the step.
        z : ParticleState
            The filter state at ``t``.
        u : ndarray, shape (..., m)
            The known input, held over the step.
        y : ndarray, shape (..., p)
            The held measurement (not used between samples).
        h : float
            The step.

        Returns
        -------
        ParticleState
            The state at ``t + h``.

        Raises
        ------
        InvalidArgumentError
            The plant is discrete-time (a discrete filter is advanced by :meth:`rhs`).

        Examples
        --------
        Without process noise the particles of ``ẋ = −x`` decay by RK4's ``1 − h + h²/2 − h³/6 + h⁴/24``:

        >>> import numpy as np
        >>> import nlobs
        >>> from nlobs.observers.particle import ParticleFilter
        >>> decay = nlobs.LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]])
        >>> pf = ParticleFilter(decay, [[0.0]], [[1.0]], [[1.0]], particles=5)
        >>> z = pf.init([1.0])
        >>> z1 = pf.step(0.0, z, np.zeros(0), np.zeros(1), 0.1)
        >>> bool(np.allclose(z1.particles, z.particles * (1 - 0.1 + 0.1**2 / 2 - 0.1**3 / 6 + 0.1**4 / 24)))
        True
        """
        if self.discrete:
            raise InvalidArgumentError(f"{self.name}: step() advances a continuous-time plant; this plant is "
                                       f"{self.time}, advanced by rhs()")
        f, U, X = self.plant.rhs, self._per_particle(u), z.particles
        half = 0.5 * h
        k1 = f(t, X, U)
        k2 = f(t + half, X + half * k1, U)
        k3 = f(t + half, X + half * k2, U)
        k4 = f(t + h, X + h * k3, U)
        X_new = X + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
        return ParticleState(self._with_noise(X_new, z.counter, math.sqrt(h)), z.log_weights, z.counter + 1,
                             z.nis, z.ess)

    def estimate(self, z: ParticleState) -> Array:
        """The weighted mean of the particles.

        Parameters
        ----------
        z : ParticleState
            The filter state.

        Returns
        -------
        ndarray, shape (..., n)
            ``Σ wᵢ xᵢ`` for each run.

        Examples
        --------
        >>> import numpy as np
        >>> import nlobs
        >>> from nlobs.observers.particle import ParticleFilter, ParticleState
        >>> plant = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
        >>> pf = ParticleFilter(plant, [[0.0]], [[1.0]], [[1.0]], particles=2)
        >>> z = ParticleState(np.array([[0.0], [4.0]]), np.log([0.75, 0.25]), 1, np.zeros(()), np.zeros(()))
        >>> pf.estimate(z)
        array([1.])
        """
        return _weighted_mean(np.exp(z.log_weights), z.particles)

    def diagnostics(self, z: ParticleState, u: Array) -> dict[str, Array]:
        """The weighted variances ``P_diag`` ``(..., n)``, ``nis`` ``(...)`` and ``ess`` ``(...)``.

        Parameters
        ----------
        z : ParticleState
            The filter state.
        u : ndarray, shape (..., m)
            The known input (not used).

        Returns
        -------
        dict of str to ndarray
            ``P_diag = Σ wᵢ (xᵢ − x̂)²``, and the NIS and effective sample size of the last correction.

        Examples
        --------
        >>> import numpy as np
        >>> import nlobs
        >>> from nlobs.observers.particle import ParticleFilter, ParticleState
        >>> plant = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
        >>> pf = ParticleFilter(plant, [[0.0]], [[1.0]], [[1.0]], particles=2)
        >>> z = ParticleState(np.array([[0.0], [4.0]]), np.log([0.75, 0.25]), 1, np.zeros(()), np.full((), 1.6))
        >>> {k: v.tolist() for k, v in pf.diagnostics(z, np.zeros(0)).items()}  # 0.75·1² + 0.25·3² = 3
        {'P_diag': [3.0], 'nis': 0.0, 'ess': 1.6}
        """
        w = np.exp(z.log_weights)
        dev = z.particles - _weighted_mean(w, z.particles)[..., None, :]
        return {"P_diag": _weighted_mean(w, dev * dev), "nis": z.nis, "ess": z.ess}

    # ------------------------------------------------------------------ correction
    def correct(self, t: float, z: ParticleState, u: Array, y: Array, fresh: BoolArray) -> ParticleState:
        """Reweighting by the sampled outputs where ``fresh`` is True, then resampling where the ESS is low.

        ``R`` is restricted to the rows and columns of those outputs. A non-finite ``y`` at a fresh row is a
        missing sample of that run: the row is left out for that run only (a run left with no row keeps its
        state). A run whose effective sample size falls below ``resample_threshold · N`` is resampled
        systematically and roughened (module docstring); ``counter`` one more.

        Parameters
        ----------
        t : float
            The sample instant.
        z : ParticleState
            The state before the correction.
        u : ndarray, shape (..., m)
            The known input.
        y : ndarray, shape (..., p)
            The measurement of each run.
        fresh : ndarray of bool, shape (p,)
            Which outputs were sampled at ``t``.

        Returns
        -------
        ParticleState
            The corrected state, with the NIS and ESS of this correction.

        Raises
        ------
        DimensionError
            ``fresh`` is not of shape ``(p,)``.
        SimulationDiverged
            The predicted output of a particle, or its log likelihood, is not finite (the message names the time
            and the run). A sample far from every particle is not an error: the weights are kept as logarithms,
            the nearest particle takes the weight and resampling with roughening spreads the cloud again (the
            effective sample size of the correction, ``ess``, is then about 1).

        Examples
        --------
        A scalar ``y = x + v`` (``R = 1``) from the cloud ``N(0, 1)``: the sample ``y = 2`` moves the
        weighted mean to about the Kalman filter's ``1``; the NIS is ``ν²/S = 4/2``; a missing sample
        (NaN) leaves the state as it was:

        >>> import numpy as np
        >>> import nlobs
        >>> from nlobs.observers.particle import ParticleFilter
        >>> plant = nlobs.LinearSystem([[1.0]], np.zeros((1, 0)), [[1.0]], time=nlobs.Discrete(1.0))
        >>> pf = ParticleFilter(plant, [[0.0]], [[1.0]], [[1.0]], particles=100000, roughening=0.0)
        >>> z = pf.init([0.0])
        >>> z1 = pf.correct(0.0, z, np.zeros(0), np.array([2.0]), np.array([True]))
        >>> pf.estimate(z1).round(1), float(z1.nis.round(1))
        (array([1.]), 2.0)
        >>> pf.correct(0.0, z, np.zeros(0), np.array([np.nan]), np.array([True])).particles is z.particles
        True
        """
        mask = fresh if type(fresh) is np.ndarray and fresh.dtype == np.bool_ else np.asarray(fresh, dtype=bool)
        if mask.shape != (self.p,):
            raise DimensionError(f"fresh: expected shape ({self.p},), got {mask.shape}")
        rows = np.flatnonzero(mask)
        if rows.size == 0:
            return z
        u = np.asarray(u, dtype=float)
        y = np.asarray(y, dtype=float)
        N, n = self.particles, self.n
        batch = np.broadcast_shapes(z.particles.shape[:-2], y.shape[:-1], u.shape[:-1])
        B = math.prod(batch)
        ys = np.broadcast_to(y[..., rows], (*batch, rows.size)).reshape(B, rows.size)
        ok = np.isfinite(ys)
        if not ok.any():  # every sampled row missing in every run
            return z
        X = np.broadcast_to(z.particles, (*batch, N, n))
        with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
            Y = np.asarray(self.plant.output(t, X, self._per_particle(u)), dtype=float)[..., rows]
            Y = np.broadcast_to(Y, (*batch, N, rows.size)).reshape(B, N, rows.size)
            if not np.isfinite(Y).all():
                raise self._diverged(t, "the predicted output h(x) of a particle is not finite")
            LW = np.broadcast_to(z.log_weights, (*batch, N)).reshape(B, N)
            nis = np.array(np.broadcast_to(z.nis, batch), dtype=float).reshape(B)
            ess = np.array(np.broadcast_to(z.ess, batch), dtype=float).reshape(B)
            if ok.all():
                groups: list[tuple[Any, BoolArray]] = [(slice(None), np.ones(rows.size, dtype=bool))]
                members = np.arange(B)
            else:
                patterns, which = np.unique(ok, axis=0, return_inverse=True)
                which = np.asarray(which).reshape(-1)
                groups = [(np.flatnonzero(which == j), keep) for j, keep in enumerate(patterns) if keep.any()]
                members = np.flatnonzero(ok.any(axis=1))
            lw_new = LW.copy()
            for idx, keep in groups:
                Rq = self.R[np.ix_(rows[keep], rows[keep])]
                lw_new[idx], nis[idx] = _reweigh(Y[idx][..., keep], LW[idx], ys[idx][:, keep], Rq)
            top = lw_new[members].max(axis=-1)
            # log weights: a sample far from every particle (a likelihood below the smallest double) still ranks
            # them; the cloud collapses onto the nearest (ESS ≈ 1) and resampling with roughening spreads it again
            dead = ~np.isfinite(top)
            if dead.any():
                b = int(members[np.flatnonzero(dead)[0]])
                where = f" in run {tuple(int(i) for i in np.unravel_index(b, batch))}" if batch else ""
                raise self._diverged(t, f"the particles' log likelihoods of the sample are not finite{where}")
            shifted = lw_new[members] - top[:, None]
            lse = top + np.log(np.exp(shifted).sum(axis=-1))
            lw_new[members] = np.maximum(lw_new[members] - lse[:, None], LOG_ZERO)
            w = np.exp(lw_new[members])
            ess[members] = 1.0 / np.einsum("bi,bi->b", w, w)
            low = members[ess[members] < self.resample_threshold * N]
            X_new = X.reshape(B, N, n)
            if low.size:
                X_new = self._resample(X_new, lw_new, low, z.counter)
                lw_new[low] = -math.log(N)
        return ParticleState(X_new.reshape(*batch, N, n), lw_new.reshape(*batch, N), z.counter + 1,
                             nis.reshape(batch), ess.reshape(batch))

    def _resample(self, X: Array, LW: Array, runs: IntArray, counter: int) -> Array:
        """``X`` ``(B, N, n)`` with the runs ``runs`` resampled systematically and roughened (a new array)."""
        B, N, n = X.shape
        offsets = self._rng(counter, _RESAMPLE).random((B,))[runs]  # one draw for all runs: run i's own number
        ancestors = _systematic(np.cumsum(np.exp(LW[runs]), axis=-1), offsets)
        picked = np.take_along_axis(X[runs], ancestors[..., None], axis=1)
        if self.roughening > 0.0:
            by_state = np.ascontiguousarray(np.swapaxes(picked, 1, 2))  # (R, n, N): reductions along memory
            spread = by_state.max(axis=-1) - by_state.min(axis=-1)  # E: the range of each state, (R, n)
            sigma = self.roughening * spread * N ** (-1.0 / n)
            jitter = self._rng(counter, _ROUGHEN).standard_normal((B, N, n))[runs]
            picked += sigma[:, None, :] * jitter
        out = np.array(X, dtype=float)
        out[runs] = self._clip(picked)
        return out


def _reweigh(Y: Array, LW: Array, y: Array, R: Array) -> tuple[Array, Array]:
    """Unnormalised log weights ``log wᵢ − ½ rᵢᵀ R⁻¹ rᵢ`` and the NIS of the Gaussian approximation, per run.

    ``Y`` ``(G, N, q)`` the particles' predicted outputs, ``LW`` ``(G, N)`` their normalised log weights,
    ``y`` ``(G, q)`` the samples, ``R`` ``(q, q)``.
    """
    w = np.exp(LW)
    y_bar = _weighted_mean(w, Y)
    dY = Y - y_bar[:, None, :]
    S = np.swapaxes(dY * w[..., None], -1, -2) @ dY + R
    nu = y - y_bar
    nis = np.einsum("gp,gp->g", nu, np.linalg.solve(S, nu[..., None])[..., 0])
    L_inv = np.linalg.inv(np.linalg.cholesky(R))
    A = (y[:, None, :] - Y) @ L_inv.T
    return LW - 0.5 * (A * A).sum(axis=-1), nis


def _weighted_mean(w: Array, X: Array) -> Array:
    """``Σᵢ wᵢ Xᵢ`` over the particles, ``w`` ``(..., N)`` and ``X`` ``(..., N, k)``, as one matrix product."""
    out: Array = (w[..., None, :] @ X)[..., 0, :]
    return out
