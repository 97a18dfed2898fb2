r"""The interconnected plant of Grip, Saberi & Johansen: Σ₁, Σ₂, and Σ₁ → Σ₂ (or Σ₁* ⇄ Σ₂).

A nonlinear subsystem whose output ``z`` is not measured drives a linear subsystem that is
(partially) measured (Grip, Saberi & Johansen, Sec. 2):

.. math::

    Σ_1:\ \dot x = f(u, x),\ z = h(u, x) \qquad (1a)
    \qquad
    Σ_2:\ \dot w = A w + B_u u + B_z z,\ y = C w + D_u u + D_z z \qquad (1b)

or, in the feedback interconnection, ``Σ₁*: ẋ = f(u, w, x), z = h(u, w, x)`` (2). Σ₁ is stored
together with the injection term ``g`` of its existing observer ``x̂̇ = f(u, x̂) + g(u, x̂, z)`` (3)
(``f(u, w, x̂) + g(u, x̂, w, z)`` (16)), which the complete observer
(:class:`nlobs.observers.cascade.CascadeObserver`, (9)–(10) / (17)–(18)) reuses.

Contents
--------
* :class:`NonlinearSubsystem` — Σ₁ or Σ₁* with ``g``, from SymPy expressions (compiled once,
  Jacobians ``∂h/∂x``, ``∂h/∂w`` alongside) or from batched NumPy callables.
* :class:`LinearSubsystem` — Σ₂ ``(A, B_u, B_z, C, D_u, D_z)``; its Assumption 4 is checked by
  :func:`nlobs.linear.assumption4.check_assumption4` (the structural test is linear algebra and
  lives in :mod:`nlobs.linear`).
* :func:`check_interconnection` — that Σ₁ and Σ₂ fit together.
* :class:`InterconnectedPlant`, :func:`interconnected_plant` — the plant (1) (Fig. 1) or (2)+(1b)
  (Fig. 2) as a :class:`~nlobs.systems.base.PlantModel` for :func:`nlobs.simulate.simulate`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_matrix, as_square, check_names, default_names, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, ModelError, NonFiniteError
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.expressions import as_sympy_matrix
from nlobs.systems.timebase import CONTINUOUS, TimeBase

BatchedCallable = Callable[..., Array]

__all__ = [
    "InterconnectedPlant",
    "LinearSubsystem",
    "NonlinearSubsystem",
    "as_linear_subsystem",
    "check_interconnection",
    "interconnected_plant",
]


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

    Examples
    --------
    Σ₁ of Example 1 of Grip, Saberi & Johansen, ``ẋ1 = x2``, ``ẋ2 = x1 − x2 + 0.4 sin x1``, ``z = x2``, with the
    injection term of Rajamani's observer (3), ``g = L (z − x̂2)``, ``L = [69.6, 11.6]``; evaluated at
    ``x = (1, 2)`` (no input, no ``w`` in the cascade case):

    >>> import math
    >>> import numpy as np
    >>> sigma1 = NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=["x2", "x1 - x2 + 0.4*sin(x1)"],
    ...                                      h=["x2"], g=["69.6*(z - x2)", "11.6*(z - x2)"])
    >>> sigma1.states, sigma1.outputs, sigma1.feedback, (sigma1.n_x, sigma1.m, sigma1.p_z)
    (('x1', 'x2'), ('z',), False, (2, 0, 1))
    >>> u, w, x = np.zeros(0), np.zeros(0), np.array([1.0, 2.0])
    >>> bool(np.allclose(sigma1.f(u, w, x), [2.0, 1.0 - 2.0 + 0.4 * math.sin(1.0)]))
    True
    >>> sigma1.h(u, w, x).tolist(), sigma1.h_x(u, w, x).tolist()
    ([2.0], [[0.0, 1.0]])
    >>> np.round(sigma1.g(u, np.array([1.0, 1.5]), w, np.array([2.0])), 6).tolist()  # L (z − x̂2), z − x̂2 = 0.5
    [34.8, 5.8]
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

    Examples
    --------
    The filter Σ₂ = 1/(s² + s + 1) of Example 1 of Grip, Saberi & Johansen, driven by ``z``, its output
    ``y = w1`` measured; ``D_z`` is zero when omitted, and the DC gain ``C (−A)⁻¹ B_z`` is 1:

    >>> import numpy as np
    >>> sigma2 = LinearSubsystem([[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> sigma2.states, sigma2.outputs, (sigma2.n_w, sigma2.p_z, sigma2.p_y), sigma2.D_z.tolist()
    (('w1', 'w2'), ('y1',), (2, 1, 1), [[0.0]])
    >>> (sigma2.C @ np.linalg.solve(-sigma2.A, sigma2.B_z)).tolist()
    [[1.0]]
    >>> [M.shape for M in sigma2.input_matrices(1)]  # B_u, D_u: zero when omitted
    [(2, 1), (1, 1)]
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
        object.__setattr__(self, "A", readonly(A_))
        object.__setattr__(self, "B_z", readonly(Bz))
        object.__setattr__(self, "C", readonly(C_))
        object.__setattr__(self, "D_z", readonly(Dz))
        object.__setattr__(self, "B_u", None if Bu is None else readonly(Bu))
        object.__setattr__(self, "D_u", None if Du is None else readonly(Du))
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


def as_linear_subsystem(sigma2: LinearSubsystem | Sequence[ArrayLike]) -> LinearSubsystem:
    """``sigma2`` itself, or a :class:`LinearSubsystem` built from a tuple ``(A, B_z, C[, D_z])``.

    Parameters
    ----------
    sigma2 : LinearSubsystem or sequence of array_like
        Σ₂, or its matrices ``(A, B_z, C)`` or ``(A, B_z, C, D_z)`` as a tuple or list.

    Returns
    -------
    LinearSubsystem

    Raises
    ------
    InvalidArgumentError
        Neither.
    DimensionError
        Inconsistent shapes.
    """
    if isinstance(sigma2, LinearSubsystem):
        return sigma2
    if isinstance(sigma2, (tuple, list)) and len(sigma2) in (3, 4):
        return LinearSubsystem(*sigma2)
    raise InvalidArgumentError(
        f"sigma2: expected a LinearSubsystem or a tuple (A, B_z, C[, D_z]), got {type(sigma2).__name__}"
    )


def check_interconnection(sigma1: NonlinearSubsystem, sigma2: LinearSubsystem) -> None:
    """Check that Σ₁ and Σ₂ fit together (``p_z``, ``n_w``, ``m``).

    Parameters
    ----------
    sigma1 : NonlinearSubsystem
        Σ₁ (1a) or Σ₁* (2).
    sigma2 : LinearSubsystem
        Σ₂ (1b).

    Raises
    ------
    DimensionError
        ``h`` has ``p_z`` entries but ``B_z``/``D_z`` have another number of
        columns; Σ₁* uses ``n_w`` linear states but ``A`` has another size;
        ``B_u``/``D_u`` columns differ from Σ₁'s inputs.
    InvalidArgumentError
        Wrong types.

    Examples
    --------
    Σ₁ and Σ₂ of Example 1 of Grip, Saberi & Johansen fit (one ``z``); a Σ₂ driven by two ``z`` does not:

    >>> sigma1 = NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=["x2", "x1 - x2 + 0.4*sin(x1)"],
    ...                                      h=["x2"], g=["69.6*(z - x2)", "11.6*(z - x2)"])
    >>> sigma2 = LinearSubsystem([[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> check_interconnection(sigma1, sigma2) is None
    True
    >>> try:
    ...     check_interconnection(sigma1, LinearSubsystem([[-1.0]], [[1.0, 1.0]], [[1.0]]))
    ... except DimensionError as exc:
    ...     print(type(exc).__name__, "-", exc)
    DimensionError - p_z mismatch: h of Σ1 has 1 outputs z but B_z/D_z of Σ2 have 2 columns
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

    Parameters
    ----------
    sigma1 : NonlinearSubsystem
        Σ₁ (1a) or Σ₁* (2).
    sigma2 : LinearSubsystem
        Σ₂ (1b).

    Examples
    --------
    The cascade of Example 1 of Grip, Saberi & Johansen (Fig. 1) is a :class:`~nlobs.systems.base.PlantModel`
    of state ``[x1, x2, w1, w2]``; its right-hand side takes a batch of states, and ``z`` is available for
    comparisons although only ``y`` is measured:

    >>> import numpy as np
    >>> from nlobs.systems.base import PlantModel
    >>> sigma1 = NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=["x2", "x1 - x2 + 0.4*sin(x1)"],
    ...                                      h=["x2"], g=["69.6*(z - x2)", "11.6*(z - x2)"])
    >>> sigma2 = LinearSubsystem([[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> plant = InterconnectedPlant(sigma1, sigma2)
    >>> isinstance(plant, PlantModel), plant.states, (plant.n, plant.m, plant.p)
    (True, ('x1', 'x2', 'w1', 'w2'), (4, 0, 1))
    >>> batch = np.array([[1.0, 2.0, 0.5, -1.0], [0.0, 0.0, 0.0, 0.0]])
    >>> plant.rhs(0.0, batch, np.zeros((2, 0))).shape
    (2, 4)
    >>> plant.z(0.0, batch, np.zeros((2, 0))).tolist(), plant.output(0.0, batch, np.zeros((2, 0))).tolist()
    ([[2.0], [0.0]], [[0.5], [0.0]])
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

    Parameters
    ----------
    sigma1 : NonlinearSubsystem
        Σ₁ (1a) or Σ₁* (2).
    sigma2 : LinearSubsystem
        Σ₂ (1b).

    Returns
    -------
    InterconnectedPlant

    Raises
    ------
    DimensionError
        Σ₁ and Σ₂ do not fit (see :func:`check_interconnection`).

    Examples
    --------
    The plant (1) of Example 1 of Grip, Saberi & Johansen at ``[x1, x2, w1, w2] = [1, 2, 0.5, −1]``:
    ``ẋ = (x2, x1 − x2 + 0.4 sin x1)``, ``ẇ = (w2, −w1 − w2 + z)`` with ``z = x2``, and ``y = w1``:

    >>> import math
    >>> import numpy as np
    >>> sigma1 = NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=["x2", "x1 - x2 + 0.4*sin(x1)"],
    ...                                      h=["x2"], g=["69.6*(z - x2)", "11.6*(z - x2)"])
    >>> sigma2 = LinearSubsystem([[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> plant = interconnected_plant(sigma1, sigma2)
    >>> s, u = np.array([1.0, 2.0, 0.5, -1.0]), np.zeros(0)
    >>> bool(np.allclose(plant.rhs(0.0, s, u), [2.0, -1.0 + 0.4 * math.sin(1.0), -1.0, -0.5 + 1.0 + 2.0]))
    True
    >>> plant.output(0.0, s, u).tolist(), plant.outputs
    ([0.5], ('y1',))
    """
    return InterconnectedPlant(sigma1, sigma2)
