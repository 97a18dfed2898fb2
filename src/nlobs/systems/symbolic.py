"""Symbolic (SymPy) nonlinear models and their compilation to NumPy.

Two forms are supported:

* input-affine: ``ẋ = f(x) + g(x) u`` (or ``x⁺ = ...``), ``y = h(x, u)``;
* general: ``ẋ = F(x, u)``, ``y = h(x, u)``.

Named parameters are substituted by their numeric values at :meth:`SymbolicModel.compile`
time. The compiled :class:`CompiledModel` satisfies :class:`~nlobs.systems.base.PlantModel`
and never touches SymPy when it is evaluated.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from nlobs._typing import Array
from nlobs._validate import check_names
from nlobs.errors import DimensionError, ModelError, NonFiniteError, UnknownNameError
from nlobs.systems.codegen import BatchedFunction, compile_matrix, evaluate_together
from nlobs.systems.expressions import as_sympy_matrix
from nlobs.systems.timebase import CONTINUOUS, TimeBase


def _canonical(mat: sp.MatrixBase, known: Mapping[str, sp.Symbol]) -> sp.ImmutableMatrix:
    """Replace every symbol by the real symbol of the same name (the model's convention).

    ``known`` maps the model's names to their symbols; entries already built on
    them (every parsed string) are left untouched, so large models stay linear-time.
    """
    rule = {}
    for s in mat.free_symbols:
        want = known.get(s.name) if isinstance(s, sp.Symbol) else None
        if want is None:
            want = sp.Symbol(s.name, real=True) if isinstance(s, sp.Symbol) else s
        if want != s:  # equal symbols need no replacement (SymPy's cache may hold two equal objects)
            rule[s] = want
    return sp.ImmutableMatrix(mat.xreplace(rule) if rule else mat)


def _column(name: str, value: sp.Matrix | Sequence[sp.Expr | str], rows: int,
            known: Mapping[str, sp.Symbol]) -> sp.Matrix:
    mat = _canonical(as_sympy_matrix(name, value, known), known)
    if mat.shape[1] != 1 and mat.shape[0] == 1:
        mat = mat.T
    if mat.shape != (rows, 1):
        raise DimensionError(f"{name}: expected {rows} entries, got shape {mat.shape}")
    return sp.ImmutableMatrix(mat)


@dataclass(frozen=True)
class SymbolicModel:
    """A nonlinear model held as SymPy expressions.

    Use :meth:`input_affine` or :meth:`general` to build one.

    Attributes
    ----------
    x, u : tuple of sympy.Symbol
        State and input symbols (their names are the model's names).
    outputs : tuple of str
        Output names.
    drift : sympy.ImmutableMatrix or None
        ``f(x)`` (n × 1) of the input-affine form, ``None`` for a general model.
    input_matrix : sympy.ImmutableMatrix or None
        ``g(x)`` (n × m) of the input-affine form.
    rhs : sympy.ImmutableMatrix
        ``F(x, u)`` (n × 1), equal to ``f(x) + g(x) u`` for input-affine models.
    h : sympy.ImmutableMatrix
        Output map (p × 1), may depend on ``u``.
    parameters : mapping of str to float
        Named constants, substituted at compile time.
    time : Continuous or Discrete
        Time base.
    name : str

    Examples
    --------
    A pendulum ``θ̇ = ω``, ``ω̇ = −(g/l) sin θ + τ``, ``y = θ``, written as text over its names (parsed, never
    evaluated); the input-affine parts and the whole right-hand side are SymPy matrices:

    >>> m = SymbolicModel.input_affine(["theta", "omega"], ["tau"], ["y"], f=["omega", "-(g/l)*sin(theta)"],
    ...                                g=[["0"], ["1"]], h=["theta"], parameters={"g": 9.81, "l": 1.0},
    ...                                name="pendulum")
    >>> m.states, m.inputs, m.outputs, (m.n, m.m, m.p), m.is_input_affine
    (('theta', 'omega'), ('tau',), ('y',), (2, 1, 1), True)
    >>> m.drift.T, m.input_matrix.T, m.rhs.T
    (Matrix([[omega, -g*sin(theta)/l]]), Matrix([[0, 1]]), Matrix([[omega, -g*sin(theta)/l + tau]]))

    The general form ``ẋ = F(x, u)`` has no input-affine parts; a name the model does not declare is refused:

    >>> cubic = SymbolicModel.general(["x"], ["u"], ["y"], rhs=["-x**3 + u"], h=["x"])
    >>> cubic.is_input_affine, cubic.drift is None
    (False, True)
    >>> from nlobs.systems.expressions import ExpressionError
    >>> try:
    ...     SymbolicModel.general(["x"], [], ["y"], rhs=["-k*x"], h=["x"])
    ... except ExpressionError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ExpressionError - rhs[0]: undeclared name: 'k' in expression '-k*x'
    """

    x: tuple[sp.Symbol, ...]
    u: tuple[sp.Symbol, ...]
    outputs: tuple[str, ...]
    drift: sp.ImmutableMatrix | None
    input_matrix: sp.ImmutableMatrix | None
    rhs: sp.ImmutableMatrix
    h: sp.ImmutableMatrix
    parameters: Mapping[str, float] = field(default_factory=dict)
    time: TimeBase = CONTINUOUS
    name: str = "model"

    # ------------------------------------------------------------------ constructors
    @classmethod
    def input_affine(
        cls,
        states: Sequence[str],
        inputs: Sequence[str],
        outputs: Sequence[str],
        f: Sequence[sp.Expr | str] | sp.Matrix,
        g: Sequence[Sequence[sp.Expr | str]] | sp.Matrix | None,
        h: Sequence[sp.Expr | str] | sp.Matrix,
        *,
        parameters: Mapping[str, float] | None = None,
        time: TimeBase = CONTINUOUS,
        name: str = "model",
    ) -> SymbolicModel:
        """Build ``ẋ = f(x) + g(x) u``, ``y = h(x, u)``.

        Expressions may use ``sympy.Symbol(name)`` for every state, input and
        parameter name, or be strings such as ``"-k*sin(x1)"``, which are parsed
        by :func:`~nlobs.systems.expressions.parse_expression` over the declared
        names (never evaluated). ``f`` and ``g`` must not depend on the inputs.

        Raises
        ------
        ExpressionError
            If a string entry does not parse.
        InvalidArgumentError
            If an entry is neither a SymPy expression, a number nor a string.
        ModelError, DimensionError
            For invalid names, shapes or stray symbols.
        """
        x, u, outs, params = cls._symbols(states, inputs, outputs, parameters)
        known = cls._known(x, u, params)
        n, m = len(x), len(u)
        f_ = _column("f", f, n, known)
        if g is None:
            g_ = sp.ImmutableMatrix(sp.zeros(n, m))
        else:
            g_ = _canonical(as_sympy_matrix("g", g, known), known)
            if m == 0 and g_.shape[0] in (0, n):
                g_ = sp.ImmutableMatrix(sp.zeros(n, 0))
            if g_.shape != (n, m):
                raise DimensionError(f"g: expected shape ({n}, {m}), got {g_.shape}")
        bad = (f_.free_symbols | g_.free_symbols) & set(u)
        if bad:
            raise ModelError(f"f and g of an input-affine model must not depend on inputs: {sorted(map(str, bad))}")
        rhs = sp.ImmutableMatrix(f_ + g_ * sp.Matrix(u)) if m else f_
        model = cls(x, u, outs, f_, g_, rhs, _column("h", h, len(outs), known), dict(params), time, name)
        model._check_symbols()
        return model

    @classmethod
    def general(
        cls,
        states: Sequence[str],
        inputs: Sequence[str],
        outputs: Sequence[str],
        rhs: Sequence[sp.Expr | str] | sp.Matrix,
        h: Sequence[sp.Expr | str] | sp.Matrix,
        *,
        parameters: Mapping[str, float] | None = None,
        time: TimeBase = CONTINUOUS,
        name: str = "model",
    ) -> SymbolicModel:
        """Build ``ẋ = F(x, u)``, ``y = h(x, u)``.

        Entries are SymPy expressions or strings, as in :meth:`input_affine`.
        """
        x, u, outs, params = cls._symbols(states, inputs, outputs, parameters)
        known = cls._known(x, u, params)
        rhs_ = _column("rhs", rhs, len(x), known)
        model = cls(x, u, outs, None, None, rhs_, _column("h", h, len(outs), known), dict(params), time, name)
        model._check_symbols()
        return model

    @staticmethod
    def _symbols(
        states: Sequence[str],
        inputs: Sequence[str],
        outputs: Sequence[str],
        parameters: Mapping[str, float] | None,
    ) -> tuple[tuple[sp.Symbol, ...], tuple[sp.Symbol, ...], tuple[str, ...], dict[str, float]]:
        st = check_names("state", states)
        ins = check_names("input", inputs)
        outs = check_names("output", outputs)
        params = dict(parameters or {})
        check_names("parameter", list(params))
        clash = sorted((set(st) & set(ins)) | ((set(st) | set(ins)) & set(params)))
        if clash:
            raise ModelError(f"names used twice (state/input/parameter): {', '.join(clash)}")
        if not st:
            raise DimensionError("a model needs at least one state")
        for k, v in params.items():
            try:
                val = float(v)
            except (TypeError, ValueError):
                raise ModelError(f"parameter {k!r}: expected a number, got {v!r}") from None
            if not np.isfinite(val):
                raise NonFiniteError(f"parameter {k!r} is not finite ({val!r})")
            params[k] = val
        return (
            tuple(sp.Symbol(s, real=True) for s in st),
            tuple(sp.Symbol(s, real=True) for s in ins),
            outs,
            params,
        )

    @staticmethod
    def _known(x: Sequence[sp.Symbol], u: Sequence[sp.Symbol], params: Mapping[str, float]) -> dict[str, sp.Symbol]:
        """The model's names and their symbols (what a string entry may use)."""
        return {**{s.name: s for s in (*x, *u)}, **{k: sp.Symbol(k, real=True) for k in params}}

    def _check_symbols(self) -> None:
        allowed = set(self.x) | set(self.u) | {sp.Symbol(p, real=True) for p in self.parameters}
        for what, mat in (("rhs", self.rhs), ("h", self.h)):
            stray = mat.free_symbols - allowed
            if stray:
                raise ModelError(f"{self.name}: {what} uses undeclared symbols {sorted(map(str, stray))}")

    # ------------------------------------------------------------------ properties
    @property
    def states(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.x)

    @property
    def inputs(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.u)

    @property
    def n(self) -> int:
        return len(self.x)

    @property
    def m(self) -> int:
        return len(self.u)

    @property
    def p(self) -> int:
        return len(self.outputs)

    @property
    def is_input_affine(self) -> bool:
        return self.drift is not None

    def symbol(self, name: str) -> sp.Symbol:
        """The SymPy symbol of a state, input or parameter name."""
        for s in (*self.x, *self.u):
            if s.name == name:
                return s
        if name in self.parameters:
            return sp.Symbol(name, real=True)
        raise UnknownNameError(f"{self.name}: no state, input or parameter named {name!r}")

    def substituted(self, parameters: Mapping[str, float] | None = None) -> dict[sp.Symbol, float]:
        """Substitution map of parameter symbols to values (``parameters`` override the model's)."""
        values = dict(self.parameters)
        for k, v in (parameters or {}).items():
            if k not in values:
                raise UnknownNameError(f"{self.name}: no parameter named {k!r} (known: {sorted(values)})")
            values[k] = float(v)
        return {sp.Symbol(k, real=True): v for k, v in values.items()}

    def compile(self, parameters: Mapping[str, float] | None = None) -> CompiledModel:
        """Compile to NumPy: the model, its output and their Jacobians.

        Parameters
        ----------
        parameters : mapping, optional
            Override values of named parameters.
        """
        subs = self.substituted(parameters)
        rhs = self.rhs.subs(subs)
        h = self.h.subs(subs)
        grp = (self.x, self.u)
        X, U = sp.Matrix(self.x), sp.Matrix(self.u)
        return CompiledModel(
            time=self.time,
            states=self.states,
            inputs=self.inputs,
            outputs=self.outputs,
            name=self.name,
            _rhs=compile_matrix(rhs, grp, vector=True, what=f"{self.name}.rhs"),
            _h=compile_matrix(h, grp, vector=True, what=f"{self.name}.h"),
            _rhs_x=compile_matrix(rhs.jacobian(X), grp, what=f"{self.name}.drhs/dx"),
            _rhs_u=compile_matrix(rhs.jacobian(U) if self.m else sp.zeros(self.n, 0), grp, what="drhs/du"),
            _h_x=compile_matrix(h.jacobian(X), grp, what=f"{self.name}.dh/dx"),
            _h_u=compile_matrix(h.jacobian(U) if self.m else sp.zeros(self.p, 0), grp, what="dh/du"),
            _origin=(self, None if parameters is None else dict(parameters)),
        )


def _recompile(model: SymbolicModel, parameters: Mapping[str, float] | None) -> CompiledModel:
    """Unpickle a :class:`CompiledModel`: compile its symbolic model again."""
    return model.compile(parameters)


@dataclass(frozen=True)
class CompiledModel:
    """A :class:`SymbolicModel` compiled to batched NumPy callables.

    Satisfies :class:`~nlobs.systems.base.PlantModel`. Every method accepts
    ``x`` of shape ``(..., n)`` and ``u`` of shape ``(..., m)``.

    It pickles (process pools, Dask): the symbolic model it was compiled from travels instead of
    the generated functions, and is compiled again on the other side.

    Examples
    --------
    The shipped pendulum, ``θ̇ = ω``, ``ω̇ = −(g/l) sin θ − c ω + τ/(m l²)``, compiled with ``l = 2``: its
    right-hand side and Jacobian agree with the closed forms, a batch of states is evaluated in one call,
    and a pickled copy computes the same:

    >>> import math
    >>> import pickle
    >>> import numpy as np
    >>> import nlobs
    >>> plant = nlobs.load_model("pendulum").compile({"l": 2.0})
    >>> g, l, c, mass = 9.81, 2.0, 0.2, 0.5
    >>> x, u = np.array([math.pi / 6, 0.5]), np.array([1.0])
    >>> bool(np.allclose(plant.rhs(0.0, x, u), [0.5, -(g / l) * 0.5 - c * 0.5 + 1.0 / (mass * l**2)]))
    True
    >>> bool(np.allclose(plant.rhs_jacobian_x(0.0, x, u), [[0.0, 1.0], [-(g / l) * math.cos(math.pi / 6), -c]]))
    True
    >>> plant.output(0.0, np.zeros((4, 2)), np.zeros((4, 1))).shape, plant.rhs_jacobian_u(0.0, x, u).tolist()
    ((4, 1), [[0.0], [0.5]])
    >>> copy = pickle.loads(pickle.dumps(plant))
    >>> bool(np.array_equal(copy.rhs(0.0, x, u), plant.rhs(0.0, x, u)))
    True
    """

    time: TimeBase
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    name: str
    _rhs: BatchedFunction
    _h: BatchedFunction
    _rhs_x: BatchedFunction
    _rhs_u: BatchedFunction
    _h_x: BatchedFunction
    _h_u: BatchedFunction
    _origin: tuple[Any, Mapping[str, float] | None] | None = field(default=None, repr=False, compare=False)

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        if self._origin is None:
            raise TypeError(f"CompiledModel {self.name!r}: built without its SymbolicModel, so it cannot be pickled; "
                            "pickle the SymbolicModel and compile it where it is needed")
        model, parameters = self._origin
        return (_recompile, (model, parameters))

    @property
    def n(self) -> int:
        return len(self.states)

    @property
    def m(self) -> int:
        return len(self.inputs)

    @property
    def p(self) -> int:
        return len(self.outputs)

    def rhs(self, t: float, x: Array, u: Array) -> Array:
        """``F(x, u)``: ``ẋ`` or ``x⁺``, shape ``(..., n)``."""
        return self._rhs(x, u)

    def output(self, t: float, x: Array, u: Array) -> Array:
        """``h(x, u)``, shape ``(..., p)``."""
        return self._h(x, u)

    def rhs_jacobian_x(self, t: float, x: Array, u: Array) -> Array:
        """``∂F/∂x``, shape ``(..., n, n)``."""
        return self._rhs_x(x, u)

    def rhs_and_jacobian_x(self, t: float, x: Array, u: Array) -> tuple[Array, Array]:
        """``(F(x, u), ∂F/∂x)`` in one call (the EKF's prediction), each exactly as :meth:`rhs` and
        :meth:`rhs_jacobian_x` return it."""
        return evaluate_together((self._rhs, self._rhs_x), x, u)  # type: ignore[return-value]

    def output_and_jacobian_x(self, t: float, x: Array, u: Array) -> tuple[Array, Array]:
        """``(h(x, u), ∂h/∂x)`` in one call (the EKF's correction), each exactly as :meth:`output` and
        :meth:`output_jacobian_x` return it."""
        return evaluate_together((self._h, self._h_x), x, u)  # type: ignore[return-value]

    def rhs_jacobian_u(self, t: float, x: Array, u: Array) -> Array:
        """``∂F/∂u``, shape ``(..., n, m)``."""
        return self._rhs_u(x, u)

    def output_jacobian_x(self, t: float, x: Array, u: Array) -> Array:
        """``∂h/∂x``, shape ``(..., p, n)``."""
        return self._h_x(x, u)

    def output_jacobian_u(self, t: float, x: Array, u: Array) -> Array:
        """``∂h/∂u``, shape ``(..., p, m)``."""
        return self._h_u(x, u)
