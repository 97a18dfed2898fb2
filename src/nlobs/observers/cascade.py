r"""Observers for cascade and feedback-interconnected nonlinear/linear systems (seed 001, Secs. 2–4).

Grip, Saberi & Johansen consider a nonlinear subsystem whose output ``z`` is not
measured but drives a linear subsystem that is (partially) measured:

.. math::

    Σ_1:\ \dot x = f(u, x),\ z = h(u, x) \qquad (1a)
    \qquad
    Σ_2:\ \dot w = A w + B_u u + B_z z,\ y = C w + D_u u + D_z z \qquad (1b)

or, in the feedback interconnection, ``Σ₁*: ẋ = f(u, w, x), z = h(u, w, x)`` (2).
Given an observer ``x̂̇ = f(u, x̂) + g(u, x̂, z)`` (3) (``f(u, w, x̂) + g(u, x̂, w, z)``
(16)) for the nonlinear part, the complete observer is, in the cascade case,

.. math::

    \dot{\hat w} &= A\hat w + B_u u + B_z\hat z + K_w\,\tilde y, \qquad (9a) \\
    \dot\xi &= -\partial_x h(u, \hat x)\, g(u, \hat x, \hat z) + K_z\,\tilde y, \qquad (9b) \\
    \hat z &= h(u, \hat x) + \xi, \qquad (9c) \\
    \dot{\hat x} &= f(u, \hat x) + g(u, \hat x, \hat z), \qquad (10)

with ``ỹ = y − C ŵ − D_u u − D_z ẑ``, and in the feedback case (17)–(18):
``h``, ``f`` and ``g`` also take ``ŵ`` and (17b) gains the term
``−∂_w h(u, ŵ, x̂) K_w ỹ``. With ``K = [K_w; K_z]`` the error of
``w_e = [w; z]`` obeys (12a)/(20a), ``w̃̇_e = (𝔄 − Kℭ) w̃_e + 𝔅_d d̃``, and
Theorem 1 (1') gives global exponential stability when ``𝔄 − Kℭ`` is Hurwitz
and ``‖H‖∞ < γ``, ``H(s) = (sI − 𝔄 + Kℭ)⁻¹𝔅_d`` (13).

**No ``u̇`` is needed.** The function ``d`` of Assumption 3 contains
``∂_u h · u̇``, but the observer never evaluates ``d``: ``ẑ = h(u, x̂) + ξ`` (9c)
is evaluated with the current ``u(t)``, so its time derivative picks up
``∂_u h · u̇`` by itself and ``ẑ̇ = d(u, u̇, x̂) + K_z ỹ`` (11) holds exactly for a
differentiable ``u``. (With a piecewise-constant ``u`` both ``z`` and ``ẑ`` jump
together with ``h``; the jump of the error is ``h(u⁺,x) − h(u⁺,x̂) − h(u⁻,x) + h(u⁻,x̂)``.)
``u̇`` only enters the analysis through ``L₂`` (Assumption 3 needs it bounded).

Contents
--------
* :class:`NonlinearSubsystem` — Σ₁ or Σ₁* with the injection ``g``, from SymPy
  expressions (compiled once, Jacobians ``∂h/∂x``, ``∂h/∂w`` alongside) or from
  batched NumPy callables.
* :class:`LinearSubsystem` — Σ₂ ``(A, B_u, B_z, C, D_u, D_z)``.
* :class:`CascadeObserver` — the observer (9)–(10) / (17)–(18), an
  :class:`~nlobs.observers.base.Observer`; :func:`interconnected_plant` — the
  plant Σ₁ → Σ₂ (or the feedback loop) as a :class:`~nlobs.systems.base.PlantModel`.
* :func:`design_cascade_gain` (LMIs (14)–(15) after checking Assumption 4),
  :func:`place_cascade_gain` (pole placement scaled until ``‖H‖∞ < γ``, for
  the very small ``γ`` of Theorem 1 that the LMIs cannot reach numerically) and
  :func:`gamma_sweep` (Sec. 3.2: start with a large ``γ`` and decrease it).
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import scipy.optimize
import scipy.signal
import sympy as sp
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_batch, as_matrix, as_square, check_names, default_names, positive
from nlobs.errors import (
    DesignError,
    DimensionError,
    InvalidArgumentError,
    ModelError,
    NonFiniteError,
)
from nlobs.linear import hinf_norm
from nlobs.observers.cascade_assumptions import Assumption4Report, require_assumption4
from nlobs.synthesis import (
    Check,
    CheckKind,
    GainBound,
    Objective,
    ObserverGainCertificate,
    PoleRegion,
    design_observer_gain,
    extended_system,
)
from nlobs.synthesis.lmi import Solver
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.expressions import as_sympy_matrix
from nlobs.systems.timebase import CONTINUOUS, TimeBase

Array = NDArray[np.float64]
BatchedCallable = Callable[..., Array]

__all__ = [
    "CascadeObserver",
    "GammaSweep",
    "GammaSweepRow",
    "InterconnectedPlant",
    "LinearSubsystem",
    "NonlinearSubsystem",
    "design_cascade_gain",
    "gamma_sweep",
    "interconnected_plant",
    "place_cascade_gain",
]


def _readonly(a: ArrayLike) -> Array:
    out = np.array(a, dtype=float)
    out.setflags(write=False)
    return out


# --------------------------------------------------------------------------- Σ1 / Σ1*


def _real(mat: sp.MatrixBase) -> sp.ImmutableMatrix:
    return sp.ImmutableMatrix(mat.xreplace({s: sp.Symbol(s.name, real=True) for s in mat.free_symbols}))


def _sym_column(name: str, value: Any, rows: int, known: Mapping[str, sp.Symbol]) -> sp.ImmutableMatrix:
    mat = as_sympy_matrix(name, value, known)
    if mat.shape[0] == 1 and mat.shape[1] != 1:
        mat = mat.T
    if mat.shape != (rows, 1):
        raise DimensionError(f"{name}: expected {rows} entries, got shape {mat.shape}")
    return _real(mat)


@dataclass(frozen=True, eq=False)
class NonlinearSubsystem:
    r"""Σ₁ (1a) or Σ₁* (2) together with the injection term ``g`` of its observer (3)/(16).

    Build with :meth:`symbolic` or :meth:`numeric`. All callables are batched:
    arguments of shapes ``(..., m)``, ``(..., n_w)``, ``(..., n_x)``, ``(..., p_z)``.

    Attributes
    ----------
    states, inputs, outputs : tuple of str
        Names of ``x``, ``u`` and ``z``.
    linear_states : tuple of str
        Names of the ``w`` symbols Σ₁* uses (empty in the cascade case).
    feedback : bool
        ``True`` for Σ₁* (``f, h, g`` depend on ``w``).
    name : str
    """

    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    linear_states: tuple[str, ...]
    feedback: bool
    _f: BatchedCallable = field(repr=False)
    _h: BatchedCallable = field(repr=False)
    _g: BatchedCallable = field(repr=False)
    _h_x: BatchedCallable = field(repr=False)
    _h_w: BatchedCallable | None = field(repr=False)
    name: str = "sigma1"

    # ------------------------------------------------------------------ sizes
    @property
    def n_x(self) -> int:
        """Dimension of ``x``."""
        return len(self.states)

    @property
    def m(self) -> int:
        """Dimension of ``u``."""
        return len(self.inputs)

    @property
    def p_z(self) -> int:
        """Dimension of ``z``."""
        return len(self.outputs)

    @property
    def n_w(self) -> int:
        """Dimension of ``w`` seen by Σ₁* (0 in the cascade case)."""
        return len(self.linear_states)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def symbolic(
        cls,
        *,
        states: Sequence[str],
        outputs: Sequence[str],
        f: Any,
        h: Any,
        g: Any,
        inputs: Sequence[str] = (),
        linear_states: Sequence[str] | None = None,
        parameters: Mapping[str, float] | None = None,
        name: str = "sigma1",
    ) -> NonlinearSubsystem:
        r"""Σ₁/Σ₁* and ``g`` from SymPy expressions, compiled once to NumPy.

        Parameters
        ----------
        states, outputs : sequence of str
            Names of ``x`` and ``z``. In ``g`` the state symbols stand for
            ``x̂`` and the output symbols for the ``z`` argument (``ẑ`` when the
            observer runs).
        f, h, g : sequence of sympy expressions or strings, or sympy.Matrix
            ``f`` (``n_x`` entries), ``h`` (``p_z`` entries), ``g`` (``n_x``
            entries), in ``sympy.Symbol(name)`` of the states, inputs,
            linear states and parameters (and outputs, in ``g`` only). A
            string entry is parsed by
            :func:`~nlobs.systems.expressions.parse_expression` over these
            names, never evaluated.
        inputs : sequence of str
            Names of ``u`` (may be empty).
        linear_states : sequence of str, optional
            Names of ``w`` for the feedback interconnection Σ₁* (2); in ``g``
            they stand for ``ŵ``. ``None`` (default): cascade, ``f, h, g`` must
            not use them.
        parameters : mapping of str to float, optional
            Named constants substituted before compilation.
        name : str

        Returns
        -------
        NonlinearSubsystem
            ``f``, ``h``, ``g``, ``∂h/∂x`` and (feedback) ``∂h/∂w`` compiled with
            :func:`nlobs.systems.codegen.compile_matrix`.

        Raises
        ------
        ModelError
            Duplicate names, undeclared symbols, ``f``/``h`` using ``z``.
        ExpressionError
            A string entry that does not parse.
        InvalidArgumentError
            An entry that is neither a SymPy expression, a number nor a string.
        DimensionError
            Wrong number of entries.
        """
        st = check_names("state", states)
        outs = check_names("output", outputs)
        ins = check_names("input", inputs)
        lin = check_names("linear state", linear_states or ())
        params = dict(parameters or {})
        check_names("parameter", list(params))
        allnames = [*st, *outs, *ins, *lin, *params]
        dup = sorted({s for s in allnames if allnames.count(s) > 1})
        if dup:
            raise ModelError(f"{name}: names used twice (state/output/input/linear state/parameter): {', '.join(dup)}")
        if not st:
            raise DimensionError(f"{name}: Σ1 needs at least one state")
        if not outs:
            raise DimensionError(f"{name}: Σ1 needs at least one output z")
        X = tuple(sp.Symbol(s, real=True) for s in st)
        Z = tuple(sp.Symbol(s, real=True) for s in outs)
        U = tuple(sp.Symbol(s, real=True) for s in ins)
        W = tuple(sp.Symbol(s, real=True) for s in lin)
        subs = {}
        for k, v in params.items():
            try:
                val = float(v)
            except (TypeError, ValueError):
                raise ModelError(f"{name}: parameter {k!r}: expected a number, got {v!r}") from None
            if not math.isfinite(val):
                raise NonFiniteError(f"{name}: parameter {k!r} is not finite ({val!r})")
            subs[sp.Symbol(k, real=True)] = val
        n, pz = len(X), len(Z)
        known = {s.name: s for s in (*X, *Z, *U, *W, *subs)}
        f_ = _sym_column("f", f, n, known).subs(subs)
        h_ = _sym_column("h", h, pz, known).subs(subs)
        g_ = _sym_column("g", g, n, known).subs(subs)
        base = set(X) | set(U) | set(W)
        for what, mat, allowed in (("f", f_, base), ("h", h_, base), ("g", g_, base | set(Z))):
            stray = mat.free_symbols - allowed
            if stray:
                hint = " (z may appear only in g)" if stray & set(Z) else ""
                raise ModelError(f"{name}: {what} uses undeclared symbols {sorted(map(str, stray))}{hint}")
        feedback = linear_states is not None
        grp = (U, W, X) if feedback else (U, X)
        ggrp = (U, X, W, Z) if feedback else (U, X, Z)
        Xm = sp.Matrix(X)
        h_w = None
        if feedback:
            h_w = compile_matrix(h_.jacobian(sp.Matrix(W)) if W else sp.zeros(pz, 0), grp, what=f"{name}.dh/dw")
        return cls(
            states=st,
            inputs=ins,
            outputs=outs,
            linear_states=lin,
            feedback=feedback,
            _f=compile_matrix(f_, grp, vector=True, what=f"{name}.f"),
            _h=compile_matrix(h_, grp, vector=True, what=f"{name}.h"),
            _g=compile_matrix(g_, ggrp, vector=True, what=f"{name}.g"),
            _h_x=compile_matrix(h_.jacobian(Xm), grp, what=f"{name}.dh/dx"),
            _h_w=h_w,
            name=str(name),
        )

    @classmethod
    def numeric(
        cls,
        *,
        n_x: int,
        p_z: int,
        f: BatchedCallable,
        h: BatchedCallable,
        g: BatchedCallable,
        h_x: BatchedCallable,
        m: int = 0,
        n_w: int | None = None,
        h_w: BatchedCallable | None = None,
        states: Sequence[str] | None = None,
        inputs: Sequence[str] | None = None,
        outputs: Sequence[str] | None = None,
        name: str = "sigma1",
    ) -> NonlinearSubsystem:
        r"""Σ₁/Σ₁* and ``g`` from batched NumPy callables.

        Cascade (``n_w=None``): ``f(u, x)``, ``h(u, x)``, ``g(u, x̂, z)``,
        ``h_x(u, x)``. Feedback (``n_w`` given): ``f(u, w, x)``, ``h(u, w, x)``,
        ``g(u, x̂, w, z)``, ``h_x(u, w, x)``, ``h_w(u, w, x)`` (required).
        Each takes arrays with a common leading batch shape and returns
        ``(..., n_x)``, ``(..., p_z)``, ``(..., n_x)``, ``(..., p_z, n_x)``,
        ``(..., p_z, n_w)``.

        The shapes are checked once here by evaluating every callable at zero
        (single point and a batch of 2).

        Raises
        ------
        DimensionError
            A callable returns the wrong shape, or names do not match the sizes.
        InvalidArgumentError
            ``h_w`` missing in the feedback case (or given in the cascade case).
        """
        nx = _count("n_x", n_x, 1)
        pz = _count("p_z", p_z, 1)
        mm = _count("m", m, 0)
        feedback = n_w is not None
        nw = _count("n_w", n_w, 0) if feedback else 0
        if feedback and h_w is None:
            raise InvalidArgumentError("h_w: the feedback case needs ∂h/∂w (a callable h_w(u, w, x))")
        if not feedback and h_w is not None:
            raise InvalidArgumentError("h_w: given without n_w; pass n_w for the feedback interconnection Σ1*")
        st = default_names("state", "x", states, nx)
        ins = default_names("input", "u", inputs, mm)
        outs = default_names("output", "z", outputs, pz)
        lin = tuple(f"w{i + 1}" for i in range(nw))
        obj = cls(st, ins, outs, lin, feedback, f, h, g, h_x, h_w, str(name))
        for batch in ((), (2,)):
            u0, w0, x0, z0 = (np.zeros((*batch, k)) for k in (mm, nw, nx, pz))
            probes: tuple[tuple[str, Callable[..., Array], tuple[Array, ...], tuple[int, ...]], ...] = (
                ("f", obj.f, (u0, w0, x0), (*batch, nx)),
                ("h", obj.h, (u0, w0, x0), (*batch, pz)),
                ("g", obj.g, (u0, x0, w0, z0), (*batch, nx)),
                ("h_x", obj.h_x, (u0, w0, x0), (*batch, pz, nx)),
                ("h_w", obj.h_w, (u0, w0, x0), (*batch, pz, nw)),
            )
            for what, fn, args, want in probes:
                try:
                    got = np.shape(fn(*args))
                except DimensionError:
                    raise
                except Exception as exc:
                    raise DimensionError(f"{name}.{what}: evaluation at zero with batch {batch} failed: {exc}") from exc
                if got != want:
                    raise DimensionError(f"{name}.{what}: returned shape {got} for batch {batch}, expected {want}")
        return obj

    # ------------------------------------------------------------------ evaluation (uniform signatures)
    def f(self, u: Array, w: Array, x: Array) -> Array:
        """``f(u, x)`` (cascade; ``w`` ignored) or ``f(u, w, x)``, shape ``(..., n_x)``."""
        return np.asarray(self._f(u, w, x) if self.feedback else self._f(u, x), dtype=float)

    def h(self, u: Array, w: Array, x: Array) -> Array:
        """``h(u, x)`` or ``h(u, w, x)``, shape ``(..., p_z)``."""
        return np.asarray(self._h(u, w, x) if self.feedback else self._h(u, x), dtype=float)

    def g(self, u: Array, x_hat: Array, w: Array, z: Array) -> Array:
        """``g(u, x̂, z)`` or ``g(u, x̂, ŵ, z)``, shape ``(..., n_x)``."""
        return np.asarray(self._g(u, x_hat, w, z) if self.feedback else self._g(u, x_hat, z), dtype=float)

    def h_x(self, u: Array, w: Array, x: Array) -> Array:
        """``∂h/∂x``, shape ``(..., p_z, n_x)``."""
        return np.asarray(self._h_x(u, w, x) if self.feedback else self._h_x(u, x), dtype=float)

    def h_w(self, u: Array, w: Array, x: Array) -> Array:
        """``∂h/∂w``, shape ``(..., p_z, n_w)`` (zero columns in the cascade case)."""
        if not self.feedback or self._h_w is None:
            batch = np.broadcast_shapes(np.shape(u)[:-1], np.shape(x)[:-1])
            return np.zeros((*batch, self.p_z, 0))
        return np.asarray(self._h_w(u, w, x), dtype=float)


def _count(name: str, value: Any, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise InvalidArgumentError(f"{name}: expected an integer ≥ {minimum}, got {value!r}")
    return int(value)


# --------------------------------------------------------------------------- Σ2


@dataclass(frozen=True, eq=False, init=False)
class LinearSubsystem:
    r"""Σ₂ (1b): ``ẇ = A w + B_u u + B_z z``, ``y = C w + D_u u + D_z z``.

    Parameters
    ----------
    A : array_like, shape (n_w, n_w)
    B_z : array_like, shape (n_w, p_z)
    C : array_like, shape (p_y, n_w)
    D_z : array_like, shape (p_y, p_z), optional
        Zero when omitted.
    B_u : array_like, shape (n_w, m), optional
    D_u : array_like, shape (p_y, m), optional
        Zero when omitted (both must have the same ``m`` when given).
    states, outputs : sequence of str, optional
        Names of ``w`` (default ``w1..``) and ``y`` (default ``y1..``).
    """

    A: Array
    B_z: Array
    C: Array
    D_z: Array
    B_u: Array | None
    D_u: Array | None
    states: tuple[str, ...]
    outputs: tuple[str, ...]

    def __init__(
        self,
        A: ArrayLike,
        B_z: ArrayLike,
        C: ArrayLike,
        D_z: ArrayLike | None = None,
        *,
        B_u: ArrayLike | None = None,
        D_u: ArrayLike | None = None,
        states: Sequence[str] | None = None,
        outputs: Sequence[str] | None = None,
    ) -> None:
        A_ = as_square("A", A)
        n = A_.shape[0]
        if n == 0:
            raise DimensionError("A: Σ2 needs at least one state")
        Bz = as_matrix("B_z", B_z, (n, None))
        C_ = as_matrix("C", C, (None, n))
        pz, py = Bz.shape[1], C_.shape[0]
        if pz == 0 or py == 0:
            raise DimensionError(f"Σ2 needs p_z ≥ 1 and p_y ≥ 1 (got B_z {Bz.shape}, C {C_.shape})")
        Dz = np.zeros((py, pz)) if D_z is None else as_matrix("D_z", D_z, (py, pz))
        Bu = None if B_u is None else as_matrix("B_u", B_u, (n, None))
        Du = None if D_u is None else as_matrix("D_u", D_u, (py, None))
        if Bu is not None and Du is not None and Bu.shape[1] != Du.shape[1]:
            raise DimensionError(f"B_u has {Bu.shape[1]} columns but D_u has {Du.shape[1]}")
        object.__setattr__(self, "A", _readonly(A_))
        object.__setattr__(self, "B_z", _readonly(Bz))
        object.__setattr__(self, "C", _readonly(C_))
        object.__setattr__(self, "D_z", _readonly(Dz))
        object.__setattr__(self, "B_u", None if Bu is None else _readonly(Bu))
        object.__setattr__(self, "D_u", None if Du is None else _readonly(Du))
        object.__setattr__(self, "states", default_names("state", "w", states, n))
        object.__setattr__(self, "outputs", default_names("output", "y", outputs, py))

    @property
    def n_w(self) -> int:
        return int(self.A.shape[0])

    @property
    def p_z(self) -> int:
        return int(self.B_z.shape[1])

    @property
    def p_y(self) -> int:
        return int(self.C.shape[0])

    @property
    def m(self) -> int | None:
        """Columns of ``B_u``/``D_u`` (``None`` when both are omitted, i.e. zero)."""
        for M in (self.B_u, self.D_u):
            if M is not None:
                return int(M.shape[1])
        return None

    def input_matrices(self, m: int) -> tuple[Array, Array]:
        """``(B_u, D_u)`` for ``m`` inputs (zeros where omitted)."""
        if self.m is not None and self.m != m:
            raise DimensionError(f"Σ2: B_u/D_u have {self.m} columns but Σ1 has m = {m} inputs")
        Bu = np.zeros((self.n_w, m)) if self.B_u is None else self.B_u
        Du = np.zeros((self.p_y, m)) if self.D_u is None else self.D_u
        return Bu, Du

    def assumption4(self) -> Assumption4Report:
        """:func:`~nlobs.observers.cascade_assumptions.check_assumption4` on ``(A, B_z, C, D_z)``."""
        from nlobs.observers.cascade_assumptions import check_assumption4

        return check_assumption4(self.A, self.B_z, self.C, self.D_z)


def _as_sigma2(sigma2: LinearSubsystem | Sequence[ArrayLike]) -> LinearSubsystem:
    if isinstance(sigma2, LinearSubsystem):
        return sigma2
    if isinstance(sigma2, (tuple, list)) and len(sigma2) in (3, 4):
        return LinearSubsystem(*sigma2)
    raise InvalidArgumentError(
        f"sigma2: expected a LinearSubsystem or a tuple (A, B_z, C[, D_z]), got {type(sigma2).__name__}"
    )


def check_interconnection(sigma1: NonlinearSubsystem, sigma2: LinearSubsystem) -> None:
    """Check that Σ₁ and Σ₂ fit together (``p_z``, ``n_w``, ``m``).

    Raises
    ------
    DimensionError
        ``h`` has ``p_z`` entries but ``B_z``/``D_z`` have another number of
        columns; Σ₁* uses ``n_w`` linear states but ``A`` has another size;
        ``B_u``/``D_u`` columns differ from Σ₁'s inputs.
    InvalidArgumentError
        Wrong types.
    """
    if not isinstance(sigma1, NonlinearSubsystem):
        raise InvalidArgumentError(f"sigma1: expected a NonlinearSubsystem, got {type(sigma1).__name__}")
    if not isinstance(sigma2, LinearSubsystem):
        raise InvalidArgumentError(f"sigma2: expected a LinearSubsystem, got {type(sigma2).__name__}")
    if sigma1.p_z != sigma2.p_z:
        raise DimensionError(
            f"p_z mismatch: h of Σ1 has {sigma1.p_z} outputs z but B_z/D_z of Σ2 have {sigma2.p_z} columns"
        )
    if sigma1.feedback and sigma1.n_w != sigma2.n_w:
        raise DimensionError(
            f"n_w mismatch: Σ1* uses {sigma1.n_w} linear states {sigma1.linear_states} but A of Σ2 is "
            f"{sigma2.n_w}×{sigma2.n_w}"
        )
    sigma2.input_matrices(sigma1.m)


# --------------------------------------------------------------------------- the plant


@dataclass(frozen=True, eq=False)
class InterconnectedPlant:
    r"""The interconnection Σ₁ → Σ₂ (Fig. 1) or the feedback loop Σ₁* ⇄ Σ₂ (Fig. 2) as a plant.

    State ``[x, w]``, input ``u``, output ``y`` (1b); satisfies
    :class:`~nlobs.systems.base.PlantModel`. Build with :func:`interconnected_plant`.
    """

    sigma1: NonlinearSubsystem
    sigma2: LinearSubsystem
    time: TimeBase = field(default=CONTINUOUS, init=False)
    states: tuple[str, ...] = field(default=(), init=False)
    inputs: tuple[str, ...] = field(default=(), init=False)
    outputs: tuple[str, ...] = field(default=(), init=False)

    def __post_init__(self) -> None:
        check_interconnection(self.sigma1, self.sigma2)
        names = (*self.sigma1.states, *self.sigma2.states)
        check_names("plant state", names)
        object.__setattr__(self, "states", names)
        object.__setattr__(self, "inputs", self.sigma1.inputs)
        object.__setattr__(self, "outputs", self.sigma2.outputs)
        Bu, Du = self.sigma2.input_matrices(self.sigma1.m)
        object.__setattr__(self, "_BuT", np.ascontiguousarray(Bu.T))
        object.__setattr__(self, "_DuT", np.ascontiguousarray(Du.T))

    @property
    def n(self) -> int:
        return self.sigma1.n_x + self.sigma2.n_w

    @property
    def m(self) -> int:
        return self.sigma1.m

    @property
    def p(self) -> int:
        return self.sigma2.p_y

    def _split(self, s: Array) -> tuple[Array, Array]:
        nx = self.sigma1.n_x
        return s[..., :nx], s[..., nx:]

    def z(self, t: float, s: Array, u: Array) -> Array:
        """The unmeasured interconnection signal ``z = h(u, [w,] x)``, shape ``(..., p_z)``."""
        x, w = self._split(np.asarray(s, dtype=float))
        return self.sigma1.h(u, w, x)

    def rhs(self, t: float, s: Array, u: Array) -> Array:
        """``[f(u, [w,] x), A w + B_u u + B_z z]``, shape ``(..., n_x + n_w)``."""
        x, w = self._split(np.asarray(s, dtype=float))
        s2 = self.sigma2
        z = self.sigma1.h(u, w, x)
        dx = self.sigma1.f(u, w, x)
        dw = w @ s2.A.T + u @ self._BuT + z @ s2.B_z.T  # type: ignore[attr-defined]
        batch = np.broadcast_shapes(dx.shape[:-1], dw.shape[:-1])
        return np.concatenate([np.broadcast_to(a, (*batch, a.shape[-1])) for a in (dx, dw)], axis=-1)

    def output(self, t: float, s: Array, u: Array) -> Array:
        """``y = C w + D_u u + D_z z``, shape ``(..., p_y)``."""
        x, w = self._split(np.asarray(s, dtype=float))
        z = self.sigma1.h(u, w, x)
        s2 = self.sigma2
        return w @ s2.C.T + u @ self._DuT + z @ s2.D_z.T  # type: ignore[attr-defined]


def interconnected_plant(sigma1: NonlinearSubsystem, sigma2: LinearSubsystem) -> InterconnectedPlant:
    """The plant (1) (cascade) or (2)+(1b) (feedback) for :func:`nlobs.simulate.simulate`.

    Raises
    ------
    DimensionError
        Σ₁ and Σ₂ do not fit (see :func:`check_interconnection`).
    """
    return InterconnectedPlant(sigma1, sigma2)


# --------------------------------------------------------------------------- the observer


@dataclass(frozen=True, eq=False)
class CascadeObserver:
    r"""The observer (9)–(10) (cascade) or (17)–(18) (feedback) of seed 001.

    Observer state ``[x̂, ŵ, ξ]`` (``n_x + n_w + p_z``); :meth:`estimate` returns
    ``[x̂, ŵ]`` (the plant state of :func:`interconnected_plant`), :meth:`z_hat`
    returns ``ẑ = h(u, [ŵ,] x̂) + ξ`` (9c)/(17d). Satisfies
    :class:`~nlobs.observers.base.Observer`.

    Parameters
    ----------
    sigma1 : NonlinearSubsystem
        Σ₁ (or Σ₁*) with the injection ``g`` of its existing observer.
    sigma2 : LinearSubsystem
        Σ₂.
    K : array_like, shape (n_w + p_z, p_y)
        ``[K_w; K_z]``, e.g. ``design_cascade_gain(...).gain``. It is not required to
        be certified here, but ``𝔄 − Kℭ`` must be Hurwitz (checked).

    Attributes
    ----------
    K_w, K_z : ndarray
        The blocks of ``K``.
    time : Continuous
    state_names : tuple of str
        ``x̂``/``ŵ`` names with ``_hat`` and ``xi_<z>`` for ``ξ``.
    """

    sigma1: NonlinearSubsystem
    sigma2: LinearSubsystem
    K: Array
    time: TimeBase = field(default=CONTINUOUS, init=False)
    state_names: tuple[str, ...] = field(default=(), init=False)

    def __post_init__(self) -> None:
        check_interconnection(self.sigma1, self.sigma2)
        s2 = self.sigma2
        K = as_matrix("K", self.K, (s2.n_w + s2.p_z, s2.p_y))
        object.__setattr__(self, "K", _readonly(K))
        ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
        eig = np.linalg.eigvals(ext.A - K @ ext.C)
        if np.max(eig.real) >= 0:
            raise InvalidArgumentError(
                f"K: 𝔄 − Kℭ is not Hurwitz (max Re λ = {np.max(eig.real):.6g}); design K with design_cascade_gain"
            )
        names = (
            *(f"{s}_hat" for s in self.sigma1.states),
            *(f"{s}_hat" for s in s2.states),
            *(f"xi_{s}" for s in self.sigma1.outputs),
        )
        object.__setattr__(self, "state_names", names)
        Bu, Du = s2.input_matrices(self.sigma1.m)
        object.__setattr__(self, "_BuT", np.ascontiguousarray(Bu.T))
        object.__setattr__(self, "_DuT", np.ascontiguousarray(Du.T))

    @classmethod
    def from_certificate(
        cls, sigma1: NonlinearSubsystem, sigma2: LinearSubsystem, certificate: ObserverGainCertificate
    ) -> CascadeObserver:
        """Build the observer with a certified gain (refuses a failed certificate)."""
        if not certificate.verified:
            raise InvalidArgumentError(
                "certificate: not verified (failed: " + ", ".join(c.name for c in certificate.failed_checks) + ")"
            )
        return cls(sigma1, sigma2, certificate.gain)

    # ------------------------------------------------------------------ sizes
    @property
    def n_x(self) -> int:
        """Size of the estimate ``[x̂, ŵ]``."""
        return self.sigma1.n_x + self.sigma2.n_w

    @property
    def n_z(self) -> int:
        """Size of the observer state ``[x̂, ŵ, ξ]``."""
        return self.sigma1.n_x + self.sigma2.n_w + self.sigma2.p_z

    @property
    def K_w(self) -> Array:
        """``K_w`` (first ``n_w`` rows of ``K``)."""
        return self.K[: self.sigma2.n_w]

    @property
    def K_z(self) -> Array:
        """``K_z`` (last ``p_z`` rows of ``K``)."""
        return self.K[self.sigma2.n_w :]

    @property
    def error_matrix(self) -> Array:
        """``𝔄 − Kℭ`` of (12a)/(20a)."""
        s2 = self.sigma2
        ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
        return ext.A - self.K @ ext.C

    # ------------------------------------------------------------------ state
    def _split(self, z: Array) -> tuple[Array, Array, Array]:
        nx, nw = self.sigma1.n_x, self.sigma2.n_w
        return z[..., :nx], z[..., nx : nx + nw], z[..., nx + nw :]

    def init(self, x_hat0: ArrayLike) -> Array:
        """Observer state from ``[x̂₀, ŵ₀]`` with ``ξ₀ = 0`` (so ``ẑ₀ = h(u₀, [ŵ₀,] x̂₀)``)."""
        xw = np.array(as_batch("x_hat0", x_hat0, self.n_x), dtype=float)
        return np.concatenate([xw, np.zeros((*xw.shape[:-1], self.sigma2.p_z))], axis=-1)

    def init_state(self, x_hat0: ArrayLike, w_hat0: ArrayLike, z_hat0: ArrayLike, u0: ArrayLike | None = None) -> Array:
        """Observer state with a chosen initial ``ẑ₀``: ``ξ₀ = ẑ₀ − h(u₀, [ŵ₀,] x̂₀)``."""
        xh = as_batch("x_hat0", x_hat0, self.sigma1.n_x)
        wh = as_batch("w_hat0", w_hat0, self.sigma2.n_w)
        zh = as_batch("z_hat0", z_hat0, self.sigma2.p_z)
        uu = np.zeros(self.sigma1.m) if u0 is None else as_batch("u0", u0, self.sigma1.m)
        xi = zh - self.sigma1.h(uu, wh, xh)
        batch = np.broadcast_shapes(xh.shape[:-1], wh.shape[:-1], xi.shape[:-1])
        return np.concatenate(
            [np.broadcast_to(a, (*batch, a.shape[-1])) for a in (xh, wh, xi)], axis=-1
        )

    def estimate(self, z: Array) -> Array:
        """``[x̂, ŵ]``, shape ``(..., n_x + n_w)``."""
        return z[..., : self.n_x]

    def z_hat(self, z: Array, u: ArrayLike | None = None) -> Array:
        """``ẑ = h(u, [ŵ,] x̂) + ξ`` (9c)/(17d); ``u`` defaults to zero (needed only if ``h`` uses ``u``)."""
        z = np.asarray(z, dtype=float)
        xh, wh, xi = self._split(z)
        uu = np.zeros((*z.shape[:-1], self.sigma1.m)) if u is None else np.asarray(u, dtype=float)
        return self.sigma1.h(uu, wh, xh) + xi

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``[x̂̇, ŵ̇, ξ̇]`` of (9)–(10) or (17)–(18) for batches."""
        s1, s2 = self.sigma1, self.sigma2
        xh, wh, xi = self._split(np.asarray(z, dtype=float))
        zh = s1.h(u, wh, xh) + xi  # (9c) / (17d)
        ytil = y - wh @ s2.C.T - u @ self._DuT - zh @ s2.D_z.T  # type: ignore[attr-defined]
        gg = s1.g(u, xh, wh, zh)
        dxh = s1.f(u, wh, xh) + gg  # (10) / (18)
        dwh = wh @ s2.A.T + u @ self._BuT + zh @ s2.B_z.T + ytil @ self.K_w.T  # (9a) / (17a)
        dxi = -np.einsum("...ij,...j->...i", s1.h_x(u, wh, xh), gg) + ytil @ self.K_z.T  # (9b) / (17b)
        if s1.feedback:
            dxi = dxi - np.einsum("...ij,...j->...i", s1.h_w(u, wh, xh), ytil @ self.K_w.T)  # (17b)
        batch = np.broadcast_shapes(dxh.shape[:-1], dwh.shape[:-1], dxi.shape[:-1])
        return np.concatenate([np.broadcast_to(a, (*batch, a.shape[-1])) for a in (dxh, dwh, dxi)], axis=-1)


# --------------------------------------------------------------------------- gain design


def design_cascade_gain(
    sigma2: LinearSubsystem | Sequence[ArrayLike],
    *,
    gamma: float,
    N: ArrayLike | None = None,
    gamma_n: float | None = None,
    region: PoleRegion | Sequence[PoleRegion] | None = None,
    gain_bound: GainBound | float | None = None,
    objective: Objective | str = Objective.CENTRAL,
    solver: Solver | str = Solver.CLARABEL,
    margin: float = 1e-6,
    check_assumptions: bool = True,
) -> ObserverGainCertificate:
    r"""Design ``K = [K_w; K_z]`` for the extended system (8c) from LMIs (14)–(15), certified.

    Checks Assumption 4 first (:func:`~nlobs.observers.cascade_assumptions.require_assumption4`),
    then calls :func:`nlobs.synthesis.design_observer_gain` on ``(𝔄, ℭ, 𝔅_d)``.

    Parameters
    ----------
    sigma2 : LinearSubsystem or tuple (A, B_z, C[, D_z])
    gamma : float
        ``‖H‖∞ < γ`` (Theorem 1; see :func:`~nlobs.observers.cascade_assumptions.theorem1_gamma_bound`).
    N, gamma_n, region, gain_bound, objective, solver, margin
        As in :func:`nlobs.synthesis.design_observer_gain`. The default
        ``Objective.CENTRAL`` needs ``gamma_n`` or ``gain_bound`` (a well-posed
        problem, see ``docs/synthesis.md``).
    check_assumptions : bool
        Raise :class:`~nlobs.errors.AssumptionViolated` if Assumption 4 fails
        (default). ``False`` skips the check (the LMIs may still succeed, e.g.
        for an invariant zero at the origin that is not unobservable).

    Returns
    -------
    ObserverGainCertificate

    Raises
    ------
    AssumptionViolated
        Assumption 4 fails (the item is named).
    DesignInfeasible, DesignUnbounded, CertificateError
        From the LMI design.
    """
    s2 = _as_sigma2(sigma2)
    if check_assumptions:
        require_assumption4(s2.A, s2.B_z, s2.C, s2.D_z)
    ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
    return design_observer_gain(
        ext.A, ext.C, ext.Bd, gamma=gamma, N=N, gamma_n=gamma_n, region=region, gain_bound=gain_bound,
        objective=objective, solver=solver, margin=margin,
    )


def _default_poles(n: int) -> Array:
    """Unit-radius Butterworth pattern, ``exp(j(π/2 + (2k + 1)π/(2n)))``, distinct."""
    out: list[complex] = []
    for k in range(n // 2):
        theta = np.pi / 2 + (2 * k + 1) * np.pi / (2 * n)
        c, s = math.cos(theta), math.sin(theta)
        out += [complex(c, s), complex(c, -s)]
    if n % 2:
        out.append(complex(-1.0, 0.0))
    return np.array(out, dtype=complex)


def _sigma_H(F: Array, Bd: Array, omega: float) -> float:
    n = F.shape[0]
    X = np.linalg.solve(1j * omega * np.eye(n) - F, Bd.astype(complex))
    return float(np.linalg.norm(X, 2))


def _grid_peak(F: Array, Bd: Array) -> float:
    """Largest ``σ_max(H(jω))`` on a log grid spanning the closed-loop poles, refined (a lower bound)."""
    lam = np.abs(np.linalg.eigvals(F))
    lo = max(float(np.min(lam)), 1e-6) * 1e-3
    hi = max(float(np.max(lam)), 1e-6) * 1e3
    ws = np.concatenate([[0.0], np.logspace(np.log10(lo), np.log10(hi), 600)])
    vals = np.array([_sigma_H(F, Bd, w) for w in ws])
    i = int(np.argmax(vals))
    best = float(vals[i])
    if 0 < i < ws.size - 1:
        a, b = math.log(ws[max(i - 1, 1)]), math.log(ws[i + 1])
        res = scipy.optimize.minimize_scalar(lambda lw: -_sigma_H(F, Bd, math.exp(lw)), bounds=(a, b),
                                             method="bounded", options={"xatol": 1e-10})
        best = max(best, -float(res.fun))
    return best


def _hinf_H(Ae: Array, Ce: Array, Bd: Array, K: Array) -> float:
    """``‖H‖∞`` for ``F = 𝔄 − Kℭ``: the larger of Bruinsma–Steinbuch and a refined frequency grid.

    The grid is a safeguard: for very large gains (‖K‖ ~ 10⁷–10¹⁰) the Hamiltonian
    iteration of :func:`nlobs.linear.hinf_norm` was measured to under-estimate the
    peak by 0.1 % (Example 1; checked in 50-digit arithmetic and with
    ``control.linfnorm``).
    """
    F = Ae - K @ Ce
    if np.max(np.linalg.eigvals(F).real) >= 0:
        return math.inf
    bs = float(hinf_norm(F, Bd, np.eye(F.shape[0]), np.zeros((F.shape[0], Bd.shape[1]))))
    return max(bs, _grid_peak(F, Bd))


def place_cascade_gain(
    sigma2: LinearSubsystem | Sequence[ArrayLike],
    *,
    gamma: float,
    poles: ArrayLike | None = None,
    omega_max: float = 1e6,
    check_assumptions: bool = True,
) -> ObserverGainCertificate:
    r"""A gain with ``‖H‖∞ < γ`` by pole placement at ``ω·p₀``, ``ω`` found by search.

    For the very small ``γ`` of Theorem 1 (often ``< 10⁻³``) the LMI (14) cannot
    be solved reliably: with the strictness margin ``ε`` its smallest
    achievable ``γ`` is about ``ε^{1/4}`` (measured: 0.031 for ``ε = 10⁻⁶`` on
    Example 1). Theorem 1 itself only needs ``𝔄 − Kℭ`` Hurwitz and
    ``‖H‖∞ < γ``, which this function checks directly: it places the
    eigenvalues of ``𝔄 − Kℭ`` at ``ω p₀`` (:func:`scipy.signal.place_poles` on
    the dual pair) and doubles ``ω`` until ``‖H‖∞ < γ`` (Bruinsma–Steinbuch,
    :func:`nlobs.linear.hinf_norm`), then bisects ``ω`` down to the smallest
    value found that still satisfies it.

    When Σ₂ is minimum phase and left-invertible with all infinite zeros of the
    same order (e.g. SISO), ``‖H‖∞ → 0`` as ``ω → ∞``; otherwise the search may
    fail, and the function says so.

    Parameters
    ----------
    sigma2 : LinearSubsystem or tuple (A, B_z, C[, D_z])
    gamma : float
    poles : array_like of complex, shape (n_w + p_z,), optional
        Pattern ``p₀`` (conjugate-closed, in the open left half-plane);
        default: unit Butterworth.
    omega_max : float
        Largest scale tried.
    check_assumptions : bool
        Check Assumption 4 first.

    Returns
    -------
    ObserverGainCertificate
        ``P = None``; checks: Hurwitz spectrum and ``‖H‖∞ < γ``;
        ``solver_status`` records ``ω``.

    Raises
    ------
    AssumptionViolated
        Assumption 4 fails.
    DesignError
        No ``ω ≤ omega_max`` gives ``‖H‖∞ < γ``, or placement fails (e.g. an
        unobservable extended pair).
    """
    t0 = _time.perf_counter()
    s2 = _as_sigma2(sigma2)
    g = positive("gamma", gamma)
    if check_assumptions:
        require_assumption4(s2.A, s2.B_z, s2.C, s2.D_z)
    ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
    ne = ext.A.shape[0]
    p0 = _default_poles(ne) if poles is None else np.asarray(poles, dtype=complex).ravel()
    if p0.shape != (ne,):
        raise DimensionError(f"poles: expected {ne} poles, got {p0.shape[0]}")
    if np.any(p0.real >= 0):
        raise InvalidArgumentError("poles: every pole of the pattern must have a negative real part")

    def gain(om: float) -> Array:
        try:
            res = scipy.signal.place_poles(ext.A.T, ext.C.T, om * p0)
        except (ValueError, np.linalg.LinAlgError) as exc:
            raise DesignError(f"pole placement failed at ω = {om:g}: {exc}") from exc
        return np.asarray(res.gain_matrix, dtype=float).T

    om, K = 1.0, gain(1.0)
    hH = _hinf_H(ext.A, ext.C, ext.Bd, K)
    lo = 0.0
    while not hH < g:
        lo = om
        om *= 2.0
        if om > omega_max:
            raise DesignError(
                f"no pole scale ω ≤ {omega_max:g} gives ‖H‖∞ < γ = {g:g} (last: ‖H‖∞ = {hH:.4g} at ω = {lo:g}); "
                "Σ2 may not be minimum phase (Theorem 2: γ* > 0), or try another pole pattern"
            )
        K = gain(om)
        hH = _hinf_H(ext.A, ext.C, ext.Bd, K)
    hi = om
    for _ in range(40):  # bisection on the smallest ω that meets the bound
        if hi - lo <= 1e-3 * hi:
            break
        mid = 0.5 * (lo + hi)
        Km = gain(mid)
        hm = _hinf_H(ext.A, ext.C, ext.Bd, Km)
        if hm < g:
            hi, K, hH = mid, Km, hm
        else:
            lo = mid
    eig = np.linalg.eigvals(ext.A - K @ ext.C)
    eig = eig[np.lexsort((eig.imag, eig.real))]
    checks = (
        Check.compare("max Re λ(𝔄 − Kℭ) < 0", float(np.max(eig.real)), 0.0, kind=CheckKind.SPECTRUM),
        Check.compare("‖H‖∞ < γ", float(hH), g, kind=CheckKind.NORM),
    )
    ok = all(c.passed for c in checks)
    cert = ObserverGainCertificate(
        gain=_readonly(K), P=None, gamma=g, gamma_n=None, hinf_H=float(hH), hinf_G=None,
        eigenvalues=_readonly_c(eig), checks=checks, objective=None, solver=None,
        solver_status=f"pole placement at ω = {hi:.6g} × pattern", margin=0.0,
        seconds=_time.perf_counter() - t0,
    )
    if not ok:
        raise DesignError("pole placement: " + "; ".join(c.summary() for c in cert.failed_checks))
    return cert


def _readonly_c(a: ArrayLike) -> NDArray[np.complex128]:
    out = np.array(a, dtype=complex)
    out.setflags(write=False)
    return out


# --------------------------------------------------------------------------- γ sweep


class _SimulationLike(Protocol):
    t: Array

    @property
    def error_norm(self) -> Array: ...

    def decay_rate(self) -> Array: ...


@dataclass(frozen=True)
class GammaSweepRow:
    """One step of :func:`gamma_sweep`.

    Attributes
    ----------
    gamma : float
    status : str
        ``"ok"``, or the exception class name when the design failed.
    message : str
        Empty, or why the design failed.
    hinf_H, hinf_G : float
        Achieved ``‖H‖∞`` and ``‖G‖∞`` (NaN when not applicable).
    gain_norm : float
        ``‖K‖₂``.
    slowest_pole : float
        ``max Re λ(𝔄 − Kℭ)`` (negative).
    fastest_pole : float
        ``min Re λ(𝔄 − Kℭ)``.
    initial_error, final_error : float
        Largest ``‖[x̂ − x, ŵ − w]‖`` over the batch at the first and last saved time (NaN without simulation).
    decay_rate : float
        Smallest fitted decay rate over the batch (NaN without simulation).
    K : tuple of tuple of float
    """

    gamma: float
    status: str
    message: str = ""
    hinf_H: float = math.nan
    hinf_G: float = math.nan
    gain_norm: float = math.nan
    slowest_pole: float = math.nan
    fastest_pole: float = math.nan
    initial_error: float = math.nan
    final_error: float = math.nan
    decay_rate: float = math.nan
    K: tuple[tuple[float, ...], ...] = ()

    @property
    def ok(self) -> bool:
        return self.status == "ok"


_COLUMNS = (
    ("gamma", "γ", "{:.4g}"),
    ("hinf_H", "‖H‖∞", "{:.4g}"),
    ("hinf_G", "‖G‖∞", "{:.4g}"),
    ("gain_norm", "‖K‖₂", "{:.4g}"),
    ("slowest_pole", "max Re λ", "{:.4g}"),
    ("final_error", "final ‖e‖", "{:.3g}"),
    ("decay_rate", "decay rate", "{:.4g}"),
    ("status", "status", "{}"),
)


@dataclass(frozen=True)
class GammaSweep:
    """Result of :func:`gamma_sweep`: one :class:`GammaSweepRow` per ``γ``, largest first."""

    rows: tuple[GammaSweepRow, ...]
    design: str

    def to_rows(self) -> list[dict[str, Any]]:
        """Plain dicts, one per row (``K`` as nested lists)."""
        out = []
        for r in self.rows:
            d = {k: getattr(r, k) for k in GammaSweepRow.__dataclass_fields__}
            d["K"] = [list(row) for row in r.K]
            out.append(d)
        return out

    def summary(self) -> str:
        """A plain-text table (no rich markup)."""
        head = [c[1] for c in _COLUMNS]
        body = []
        for r in self.rows:
            cells = []
            for key, _, fmt in _COLUMNS:
                v = getattr(r, key)
                cells.append("-" if isinstance(v, float) and math.isnan(v) else fmt.format(v))
            body.append(cells)
        widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(head)]
        lines = [f"γ sweep ({self.design})", "  ".join(h.rjust(w) for h, w in zip(head, widths))]
        lines += ["  ".join(c.rjust(w) for c, w in zip(b, widths)) for b in body]
        fails = [r for r in self.rows if not r.ok]
        lines += [f"  γ = {r.gamma:.4g}: {r.message}" for r in fails]
        return "\n".join(lines)


def gamma_sweep(
    sigma1: NonlinearSubsystem,
    sigma2: LinearSubsystem,
    gammas: Sequence[float],
    *,
    simulate: Callable[[CascadeObserver], _SimulationLike] | None = None,
    method: str = "lmi",
    N: ArrayLike | None = None,
    gamma_n: float | None = None,
    region: PoleRegion | Sequence[PoleRegion] | None = None,
    gain_bound: GainBound | float | None = None,
    objective: Objective | str = Objective.CENTRAL,
    poles: ArrayLike | None = None,
) -> GammaSweep:
    r"""Sec. 3.2's tuning: start with a large ``γ`` and decrease it, designing and simulating each step.

    Parameters
    ----------
    sigma1, sigma2 : NonlinearSubsystem, LinearSubsystem
    gammas : sequence of float
        Values to try; sorted largest first.
    simulate : callable, optional
        ``simulate(observer) -> SimulationResult`` (anything with ``t``,
        ``error_norm`` and ``decay_rate()``), typically
        ``lambda obs: nlobs.simulate.simulate(plant, obs, x0, x_hat0, duration=…, dt=…)``.
        (The observers layer does not import :mod:`nlobs.simulate`, so the
        simulation is passed in.) ``None``: design only.
    method : {"lmi", "placement"}
        :func:`design_cascade_gain` (with ``N, gamma_n, region, gain_bound,
        objective``) or :func:`place_cascade_gain` (with ``poles``).

    Returns
    -------
    GammaSweep
        A failed design (infeasible, unbounded, …) or a diverged simulation
        gives a row with that status and message instead of an exception, so
        the sweep shows where decreasing ``γ`` stops working.

    Raises
    ------
    AssumptionViolated
        Assumption 4 fails (before any design).
    """
    check_interconnection(sigma1, sigma2)
    require_assumption4(sigma2.A, sigma2.B_z, sigma2.C, sigma2.D_z)
    if method not in ("lmi", "placement"):
        raise InvalidArgumentError(f"method: expected 'lmi' or 'placement', got {method!r}")
    gs = sorted((positive("gammas", g) for g in gammas), reverse=True)
    if not gs:
        raise InvalidArgumentError("gammas: at least one value is required")
    rows = []
    for g in gs:
        try:
            if method == "lmi":
                cert = design_cascade_gain(sigma2, gamma=g, N=N, gamma_n=gamma_n, region=region,
                                           gain_bound=gain_bound, objective=objective, check_assumptions=False)
            else:
                cert = place_cascade_gain(sigma2, gamma=g, poles=poles, check_assumptions=False)
        except DesignError as exc:
            rows.append(GammaSweepRow(gamma=g, status=type(exc).__name__, message=str(exc)))
            continue
        eig = np.asarray(cert.eigenvalues)
        row: dict[str, Any] = {
            "gamma": g, "status": "ok", "hinf_H": float(cert.hinf_H),
            "hinf_G": float(cert.hinf_G) if cert.hinf_G is not None else math.nan,
            "gain_norm": cert.gain_norm, "slowest_pole": float(np.max(eig.real)),
            "fastest_pole": float(np.min(eig.real)),
            "K": tuple(tuple(float(v) for v in r) for r in cert.gain),
        }
        if simulate is not None:
            obs = CascadeObserver(sigma1, sigma2, cert.gain)
            try:
                res = simulate(obs)
            except ArithmeticError as exc:  # SimulationDiverged
                row.update(status=type(exc).__name__, message=str(exc))
            else:
                en = np.asarray(res.error_norm)
                row.update(
                    initial_error=float(np.max(en[..., 0])),
                    final_error=float(np.max(en[..., -1])),
                    decay_rate=float(np.min(np.asarray(res.decay_rate()))),
                )
        rows.append(GammaSweepRow(**row))
    label = "LMI (14)" + (", (15)" if gamma_n is not None else "") if method == "lmi" else "pole placement"
    return GammaSweep(rows=tuple(rows), design=label)
