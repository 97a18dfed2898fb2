"""Observability maps, observation relative degrees and the Brunovsky form (Dalla Mora, Germani & Manes; Röbenack).

For an input-affine model ``ẋ = f(x) + g(x) u``, ``y = h(x)`` with ``q`` outputs
(Dalla Mora, Germani & Manes (1.1), Röbenack (1)):

* Observability map of a multi-index ``s = (s_1, …, s_q)`` with ``Σ s_j = n``
  (002 (2.2)–(2.3))::

      Φ_s^j(x) = [h_j, L_f h_j, …, L_f^{s_j−1} h_j]ᵀ,   Φ_s = [Φ_s^1ᵀ … Φ_s^qᵀ]ᵀ

  and its Jacobian ``Q_s = ∂Φ_s/∂x`` (2.5). With ``s = r`` and ``Σ r_j < n`` the
  same construction gives Röbenack's reduced observability matrix ``Q`` (13).
* Observation relative degree ``r_j`` (002 Def. 2.5, 003 A1): the smallest
  integer with ``L_g L_f^{r_j−1} h_j ≢ 0`` on the region (``None`` when
  ``L_g L_f^k h_j`` vanishes for every ``k`` up to ``max_order``).
* ``Q_s g = F_{s,r} H_{s,r}`` (2.13) with ``H_j = [L_g L_f^{r_j−1} h_j; …;
  L_g L_f^{s_j−1} h_j]`` (2.11) for the outputs with ``s_j ≥ r_j``
  (``d_j = s_j − r_j + 1`` rows) and the 0/1 matrix ``F_{s,r}`` (2.12). nlobs keeps
  the outputs in the model's order (the paper reorders them so that those with
  ``s_j ≥ r_j`` come first); the identity (2.13) holds either way and is tested.
* ``L_s = [L_f^{s_1} h_1, …, L_f^{s_q} h_q]ᵀ`` (before (2.14)) and the Brunovsky
  triple ``(A_s, B_s, C_s)`` (2.16), so that ``ż = A_s z + B_s L_s + F_{s,r} H_{s,r} u``
  (2.15) in the coordinates ``z = Φ_s(x)``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from nlobs._typing import Array
from nlobs.errors import DimensionError, InvalidArgumentError, ModelError
from nlobs.geometry.lie import PolynomialFields, lie_derivative_along_columns, lie_derivatives, tidy
from nlobs.geometry.region import Box, ZeroTest, polynomial_vanishes_on, vanishes_on
from nlobs.systems.brunovsky import brunovsky
from nlobs.systems.expressions import as_sympy_matrix, as_symbols
from nlobs.systems.symbolic import SymbolicModel
from nlobs.systems.timebase import Continuous


__all__ = [
    "AffineFields", "RelativeDegree", "brunovsky", "check_multi_index", "input_gain_structure", "lie_map",
    "observability_jacobian", "observability_map", "observation_relative_degree", "output_derivative_terms",
    "reduced_observability_matrix",
]


def _exact(value: float) -> sp.Rational:
    """A parameter value as an exact rational (``9.81 → 981/100``), so symbolic zero tests are exact."""
    return sp.Rational(repr(float(value)))


#: The last few fields built by :meth:`AffineFields.from_model` (their Lie derivatives are cached on them).
_RECENT_FIELDS: dict[Any, AffineFields] = {}
_RECENT_FIELDS_MAX = 4


@dataclass(frozen=True)
class AffineFields:
    """The vector fields ``f``, ``g`` and the output map ``h`` of an input-affine model.

    Parameters are substituted by exact rationals of their values. Build with
    :meth:`from_model`.

    Attributes
    ----------
    name : str
    x : tuple of sympy.Symbol
        State coordinates.
    f : sympy.ImmutableMatrix, (n, 1)
    g : sympy.ImmutableMatrix, (n, m)
    h : sympy.ImmutableMatrix, (q, 1)
    states, outputs : tuple of str

    Examples
    --------
    The shipped pendulum, its parameters substituted by exact rationals (``g/l = 9.81 → 981/100``):

    >>> import nlobs
    >>> fields = AffineFields.from_model(nlobs.load_model("pendulum"))
    >>> fields.x, fields.n, fields.m, fields.q
    ((theta, omega), 2, 1, 1)
    >>> fields.f.T, fields.g.T, fields.h
    (Matrix([[omega, -omega/5 - 981*sin(theta)/100]]), Matrix([[0, 2]]), Matrix([[theta]]))

    A discrete-time model has no Lie derivatives:

    >>> try:
    ...     AffineFields.from_model(nlobs.load_model("khajenejad-6-1"))
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    ModelError khajenejad-6-1: Lie derivatives need a continuous-time model, got discrete (dt=0.01)
    """

    name: str
    x: tuple[sp.Symbol, ...]
    f: sp.ImmutableMatrix
    g: sp.ImmutableMatrix
    h: sp.ImmutableMatrix
    states: tuple[str, ...]
    outputs: tuple[str, ...]
    _memo: dict[Any, Any] = field(default_factory=dict, init=False, repr=False, compare=False)

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without the memo of derivatives (it holds SymPy polynomial rings, which do not pickle)."""
        return {**self.__dict__, "_memo": {}}

    def __post_init__(self) -> None:
        # built directly (not by from_model), the fields may hold anything: no string may reach SymPy
        object.__setattr__(self, "x", as_symbols("x", self.x))
        for key in ("f", "g", "h"):
            object.__setattr__(self, key, as_sympy_matrix(key, getattr(self, key)))

    @classmethod
    def from_model(cls, model: SymbolicModel, parameters: Mapping[str, float] | None = None) -> AffineFields:
        """Take ``f, g, h`` from a continuous-time input-affine :class:`SymbolicModel`.

        Raises
        ------
        ModelError
            If the model is not input-affine, is discrete-time, or its output depends on the input.
        """
        if not isinstance(model.time, Continuous):
            raise ModelError(f"{model.name}: Lie derivatives need a continuous-time model, got {model.time}")
        if not model.is_input_affine:
            raise ModelError(
                f"{model.name}: the method needs an input-affine model ẋ = f(x) + g(x) u "
                "(give [dynamics] f and g in the model file, not rhs)"
            )
        uses_u = model.h.free_symbols & set(model.u)
        if uses_u:
            raise ModelError(f"{model.name}: the output h must not depend on inputs {sorted(map(str, uses_u))}")
        subs = {s: _exact(v) for s, v in model.substituted(parameters).items()}
        assert model.drift is not None and model.input_matrix is not None
        out = cls(
            name=model.name,
            x=model.x,
            f=sp.ImmutableMatrix(model.drift.xreplace(subs)),
            g=sp.ImmutableMatrix(model.input_matrix.xreplace(subs)),
            h=sp.ImmutableMatrix(model.h.xreplace(subs)),
            states=model.states,
            outputs=model.outputs,
        )
        # the same fields (analyze, then the advisor) share one instance and so its Lie derivatives
        key = (out.name, out.x, out.f, out.g, out.h, out.states, out.outputs)
        hit = _RECENT_FIELDS.get(key)
        if hit is not None:
            return hit
        _RECENT_FIELDS[key] = out
        while len(_RECENT_FIELDS) > _RECENT_FIELDS_MAX:
            _RECENT_FIELDS.pop(next(iter(_RECENT_FIELDS)))
        return out

    @property
    def n(self) -> int:
        return len(self.x)

    @property
    def m(self) -> int:
        return int(self.g.shape[1])

    @property
    def q(self) -> int:
        return int(self.h.shape[0])

    def _polynomial(self) -> PolynomialFields | None:
        if "poly" not in self._memo:
            self._memo["poly"] = PolynomialFields.build(self.x, self.f, self.g, self.h)
        return self._memo["poly"]

    def _ring_chain(self, j: int, count: int) -> list[Any]:
        """``h_j, …, L_f^{count−1} h_j`` in the polynomial ring (cached, extended on demand), each checked
        against :data:`~nlobs.geometry.lie.MAX_DERIVATIVE_NODES` as :func:`lie_derivatives` does."""
        P = self._polynomial()
        assert P is not None
        chain = self._memo.setdefault(("ring", j), [])
        name = f"h of output {self.outputs[j]!r}"
        while len(chain) < count:
            k = len(chain)
            p = P.h[j] if k == 0 else P.lie(chain[-1])
            P.require_terms(p, f"L_f^{k} {name}" if k else name)
            chain.append(p)
        return chain[:count]

    def _chain_expr(self, j: int, k: int) -> sp.Expr:
        exprs = self._memo.setdefault(("expr", j), {})
        if k not in exprs:
            exprs[k] = self._polynomial().expr(self._ring_chain(j, k + 1)[k])  # type: ignore[union-attr]
        return exprs[k]

    def lie_chain(self, j: int, count: int) -> tuple[sp.Expr, ...]:
        """``(h_j, L_f h_j, …, L_f^{count−1} h_j)`` (computed once per model and output)."""
        if self._polynomial() is not None:
            self._ring_chain(j, count)
            return tuple(self._chain_expr(j, k) for k in range(count))
        key = ("chain", j)
        have = self._memo.get(key, ())
        if len(have) < count:
            have = lie_derivatives(self.h[j, 0], self.f, self.x, count, name=f"h of output {self.outputs[j]!r}")
            self._memo[key] = have
        return tuple(have[:count])

    def chain_gradient(self, j: int, k: int, *, tidied: bool = True) -> tuple[sp.Expr, ...]:
        """``d L_f^k h_j`` (``n`` entries; ``tidied``: each entry :func:`tidy`-ed), computed once."""
        key = ("grad", j, k, tidied or self._polynomial() is not None)
        if key not in self._memo:
            P = self._polynomial()
            if P is not None:
                n = self.n
                row = self.ring_codistribution([k + 1 if i == j else 0 for i in range(self.q)])[k * n:(k + 1) * n]  # type: ignore[index]
                self._memo[key] = tuple(P.expr(d) for d in row)
            else:
                phi = self.lie_chain(j, k + 1)[k]
                row = [sp.diff(phi, xi) for xi in self.x]
                self._memo[key] = tuple(tidy(e) for e in row) if tidied else tuple(row)
        return self._memo[key]

    def ring_chain_along_g(self, j: int, k: int) -> list[Any] | None:
        """``L_g L_f^k h_j`` (``m`` entries) as sparse polynomials, ``None`` for a model that is not polynomial."""
        P = self._polynomial()
        if P is None:
            return None
        key = ("ringg", j, k)
        if key not in self._memo:
            self._memo[key] = P.along_g(self._ring_chain(j, k + 1)[k])
        return self._memo[key]

    def chain_along_g(self, j: int, k: int) -> sp.Matrix:
        """``L_g L_f^k h_j`` (1 × m), as :func:`~nlobs.geometry.lie.lie_derivative_along_columns`."""
        P = self._polynomial()
        if P is None or self.m == 0:
            return lie_derivative_along_columns(self.lie_chain(j, k + 1)[k], self.g, self.x)
        return sp.Matrix([[P.expr(v) for v in self.ring_chain_along_g(j, k)]])  # type: ignore[union-attr]

    def ring_codistribution(self, s: Sequence[int]) -> list[Any] | None:
        """The rows ``d L_f^k h_j`` of :meth:`codistribution` as sparse polynomials (row-major), ``None``
        for a model that is not polynomial."""
        P = self._polynomial()
        if P is None:
            return None
        s_ = check_multi_index(s, self.q)
        out: list[Any] = []
        for j, sj in enumerate(s_):
            chain = self._ring_chain(j, sj)
            for k in range(sj):
                key = ("ringgrad", j, k)
                if key not in self._memo:
                    self._memo[key] = P.grad(chain[k])
                out.extend(self._memo[key])
        return out

    def codistribution(self, s: Sequence[int], *, tidied: bool = True) -> sp.ImmutableMatrix:
        """The Jacobian of the stacked ``[h_j, …, L_f^{s_j−1} h_j]`` (rows ``d L_f^k h_j``), computed once per row."""
        s_ = check_multi_index(s, self.q)
        rows = [self.chain_gradient(j, k, tidied=tidied) for j, sj in enumerate(s_) for k in range(sj)]
        return sp.ImmutableMatrix(rows) if rows else sp.ImmutableMatrix(sp.zeros(0, self.n))


def check_multi_index(s: Sequence[int], q: int, n: int | None = None, *, name: str = "s") -> tuple[int, ...]:
    """Validate a multi-index: ``q`` non-negative integers, summing to ``n`` when given.

    Parameters
    ----------
    s : sequence of int
        The multi-index to check.
    q : int
        Number of entries required (one per output).
    n : int, optional
        Required sum of the entries; not checked when ``None``.
    name : str, default "s"
        Name used in error messages.

    Returns
    -------
    tuple of int

    Raises
    ------
    InvalidArgumentError
        An entry is not an integer or is negative, or the entries do not sum to ``n``.
    DimensionError
        ``s`` does not have ``q`` entries.
    """
    try:
        out = tuple(int(v) for v in s)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"{name}: expected a sequence of integers, got {s!r}") from None
    if any(float(a) != b for a, b in zip(s, out)):
        raise InvalidArgumentError(f"{name}: entries must be integers, got {list(s)}")
    if len(out) != q:
        raise DimensionError(f"{name}: expected {q} entries (one per output), got {len(out)}")
    if any(v < 0 for v in out):
        raise InvalidArgumentError(f"{name}: entries must be non-negative, got {list(out)}")
    if n is not None and sum(out) != n:
        raise InvalidArgumentError(f"multi-index {name}={list(out)} sums to {sum(out)}; it must sum to n = {n}")
    return out


def lie_map(fields: AffineFields, s: Sequence[int]) -> sp.ImmutableMatrix:
    """Stacked ``[h_j, …, L_f^{s_j−1} h_j]`` over the outputs (no constraint on ``Σ s_j``).

    Parameters
    ----------
    fields : AffineFields
        The input-affine model's ``f``, ``g``, ``h``.
    s : sequence of int
        Number of Lie derivatives ``s_j`` per output (non-negative).

    Returns
    -------
    sympy.ImmutableMatrix, (Σ s_j, 1)
    """
    s_ = check_multi_index(s, fields.q)
    rows: list[sp.Expr] = []
    for j, sj in enumerate(s_):
        rows.extend(fields.lie_chain(j, sj))
    return sp.ImmutableMatrix(sp.Matrix(rows) if rows else sp.zeros(0, 1))


def observability_map(fields: AffineFields, s: Sequence[int]) -> sp.ImmutableMatrix:
    """``Φ_s(x)`` of Dalla Mora, Germani & Manes (2.2)–(2.3); ``s`` must sum to ``n``.

    Parameters
    ----------
    fields : AffineFields
        The input-affine model's ``f``, ``g``, ``h``.
    s : sequence of int
        Multi-index, one entry per output, summing to ``n``.

    Returns
    -------
    sympy.ImmutableMatrix, (n, 1)

    Examples
    --------
    The Van der Pol oscillator in Liénard form (``ẋ1 = x1 − x1³/3 + x2``, ``ẋ2 = −x1``, ``y = x1``):
    ``Φ = [h, L_f h]``.

    >>> import nlobs
    >>> fields = AffineFields.from_model(nlobs.load_model("vanderpol-lienard"))
    >>> observability_map(fields, (2,)).T
    Matrix([[x1, -x1**3/3 + x1 + x2]])
    >>> try:
    ...     observability_map(fields, (1,))
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError multi-index s=[1] sums to 1; it must sum to n = 2
    """
    return lie_map(fields, check_multi_index(s, fields.q, fields.n))


def observability_jacobian(fields: AffineFields, s: Sequence[int]) -> sp.ImmutableMatrix:
    """``Q_s(x) = ∂Φ_s/∂x`` of Dalla Mora, Germani & Manes (2.5); ``s`` must sum to ``n``.

    Parameters
    ----------
    fields : AffineFields
        The input-affine model's ``f``, ``g``, ``h``.
    s : sequence of int
        Multi-index, one entry per output, summing to ``n``.

    Returns
    -------
    sympy.ImmutableMatrix, (n, n)

    Examples
    --------
    The Van der Pol oscillator in Liénard form, ``y = x1``: ``det Q_s = 1``, so ``Φ_s`` is a global
    diffeomorphism (Def. 2.3).

    >>> import nlobs
    >>> fields = AffineFields.from_model(nlobs.load_model("vanderpol-lienard"))
    >>> Q = observability_jacobian(fields, (2,))
    >>> Q
    Matrix([
    [        1, 0],
    [1 - x1**2, 1]])
    >>> Q == observability_map(fields, (2,)).jacobian(fields.x), Q.det()
    (True, 1)
    """
    return fields.codistribution(check_multi_index(s, fields.q, fields.n))


def reduced_observability_matrix(fields: AffineFields, r: Sequence[int]) -> sp.ImmutableMatrix:
    """``Q(x) = [dh; dL_f h; …; dL_f^{r−1} h]`` of Röbenack (13), stacked over outputs.

    Parameters
    ----------
    fields : AffineFields
        The input-affine model's ``f``, ``g``, ``h``.
    r : sequence of int
        Observation relative degrees, one per output (no constraint on their sum).

    Returns
    -------
    sympy.ImmutableMatrix, (Σ r_j, n)

    Examples
    --------
    The shipped Isidori example (``n = 4``, ``y = x4``, ``r = 2``): ``Q = [dh; dL_f h]`` has two rows
    of rank 2.

    >>> import nlobs
    >>> fields = AffineFields.from_model(nlobs.load_model("isidori-146"))
    >>> r = observation_relative_degree(fields).r
    >>> Q = reduced_observability_matrix(fields, r)
    >>> r, Q
    ((2,), Matrix([
    [   0, 0, 0, 1],
    [2*x1, 1, 0, 0]]))
    >>> Q.rank()
    2
    """
    return fields.codistribution(r)


def output_derivative_terms(fields: AffineFields, s: Sequence[int]) -> sp.ImmutableMatrix:
    """``L_s(x) = [L_f^{s_1} h_1, …, L_f^{s_q} h_q]ᵀ`` (Dalla Mora, Germani & Manes, before (2.14)).

    Parameters
    ----------
    fields : AffineFields
        The input-affine model's ``f``, ``g``, ``h``.
    s : sequence of int
        Multi-index, one entry per output.

    Returns
    -------
    sympy.ImmutableMatrix, (q, 1)

    Examples
    --------
    The Van der Pol oscillator in Liénard form, ``s = (2,)``: ``L_s = L_f² h``, the entry the Brunovsky
    form (2.15) feeds back through ``B_s``.

    >>> import nlobs
    >>> from nlobs.geometry.lie import lie_derivative
    >>> fields = AffineFields.from_model(nlobs.load_model("vanderpol-lienard"))
    >>> L = output_derivative_terms(fields, (2,))
    >>> L
    Matrix([[x1**5/3 - 4*x1**3/3 - x1**2*x2 + x2]])
    >>> L[0] == lie_derivative(fields.h[0], fields.f, fields.x, order=2)
    True
    """
    s_ = check_multi_index(s, fields.q)
    return sp.ImmutableMatrix([fields.lie_chain(j, sj + 1)[-1] for j, sj in enumerate(s_)])


@dataclass(frozen=True)
class RelativeDegree:
    """Observation relative degrees of every output (Dalla Mora, Germani & Manes Def. 2.5, Röbenack A1).

    Attributes
    ----------
    r : tuple of int or None
        ``r_j``, or ``None`` where ``L_g L_f^k h_j`` vanished on the region for every
        ``k < max_order`` (not defined there: infinite for an input-free model).
    tests : tuple of tuple of ZeroTest
        Per output, the zero tests of ``L_g L_f^k h_j`` (all inputs' columns
        together, the largest in magnitude) for ``k = 0, …, r_j − 1``.
    region : Box
    max_order : int

    Examples
    --------
    The shipped Isidori example: ``L_g h ≡ 0`` (proven symbolically), ``L_g L_f h ≢ 0``, so ``r = 2``.

    >>> import nlobs
    >>> fields = AffineFields.from_model(nlobs.load_model("isidori-146"))
    >>> rd = observation_relative_degree(fields)
    >>> rd.r, rd.max_order, [(t.zero, t.method) for t in rd.tests[0]]
    ((2,), 4, [(True, 'symbolic'), (False, 'symbolic')])
    >>> rd.require(fields.outputs)
    (2,)

    Without inputs no ``L_g L_f^k h`` is nonzero, and :meth:`require` names the output:

    >>> rossler = AffineFields.from_model(nlobs.load_model("rossler"))
    >>> rd = observation_relative_degree(rossler)
    >>> rd.r
    (None,)
    >>> try:
    ...     rd.require(rossler.outputs)
    ... except Exception as exc:
    ...     print(type(exc).__name__, exc)
    ModelError observation relative degree of output(s) ['x_meas'] is not defined on [-1, 1] × [-1, 1] × [-1, 1]: ...
    """

    r: tuple[int | None, ...]
    tests: tuple[tuple[ZeroTest, ...], ...]
    region: Box
    max_order: int

    def require(self, outputs: Sequence[str]) -> tuple[int, ...]:
        """All ``r_j`` as integers; raise :class:`ModelError` naming an output whose degree is undefined."""
        bad = [o for o, rj in zip(outputs, self.r) if rj is None]
        if bad:
            raise ModelError(
                f"observation relative degree of output(s) {bad} is not defined on {self.region.describe()}: "
                f"L_g L_f^k h vanishes there for every k < {self.max_order}"
            )
        return tuple(int(v) for v in self.r)  # type: ignore[arg-type]


def observation_relative_degree(
    fields: AffineFields,
    region: Box | None = None,
    *,
    max_order: int | None = None,
    samples: int = 64,
    seed: int = 0,
) -> RelativeDegree:
    """Observation relative degree vector ``r`` on a region (default ``[−1, 1]ⁿ``).

    ``r_j`` is the smallest integer with ``L_g L_f^{r_j−1} h_j ≢ 0`` on the region
    (Dalla Mora, Germani & Manes (2.8)). Each zero test is symbolic where SymPy proves it and numeric
    (``samples`` seeded random points) otherwise; see :func:`vanishes_on`.

    Parameters
    ----------
    fields : AffineFields
        The input-affine model's ``f``, ``g``, ``h``.
    region : Box, optional
        Region of the zero tests; ``[−1, 1]ⁿ`` when ``None``.
    max_order : int, optional
        ``L_g L_f^k h_j`` is tested for ``k < max_order``; ``n`` when ``None``.
    samples : int, default 64
        Number of random points of each numeric zero test.
    seed : int, default 0
        Base seed of the random points of the numeric zero tests.

    Returns
    -------
    RelativeDegree

    Examples
    --------
    The shipped pendulum (the input acts on ``ω̇``, ``y = θ``) has ``r = 2``; by hand,
    ``L_g h = 0`` and ``L_g L_f h = 2``.

    >>> import nlobs
    >>> from nlobs.geometry.region import Box
    >>> fields = AffineFields.from_model(nlobs.load_model("pendulum"))
    >>> observation_relative_degree(fields).r
    (2,)

    The degree is decided on the region: ``y = x1`` with the input gain ``x1 + |x1|`` in ``ẋ1`` has
    ``r = 1`` where ``x1 > 0`` and ``r = 2`` where ``x1 < 0``.

    >>> from nlobs.systems.symbolic import SymbolicModel
    >>> m = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=["x2", "-x1"], g=[["x1 + abs(x1)"], [1]],
    ...                                h=["x1"])
    >>> fields = AffineFields.from_model(m)
    >>> observation_relative_degree(fields, Box([1.0, -1.0], [2.0, 1.0])).r
    (1,)
    >>> observation_relative_degree(fields, Box([-2.0, -1.0], [-1.0, 1.0])).r
    (2,)
    """
    reg = region or Box.unit(fields.n)
    kmax = fields.n if max_order is None else int(max_order)
    rs: list[int | None] = []
    all_tests: list[tuple[ZeroTest, ...]] = []
    polynomial = fields._polynomial() is not None
    for j in range(fields.q):
        # a polynomial model is tested on its sparse polynomials (no expression is built)
        chain = fields._ring_chain(j, kmax) if polynomial else fields.lie_chain(j, kmax)
        tests: list[ZeroTest] = []
        rj: int | None = None
        for k in range(len(chain)):
            sd = seed + 7919 * k + j
            if polynomial and fields.m:
                per_input = [polynomial_vanishes_on(p, fields.n, reg, samples=samples, seed=sd)
                             for p in fields.ring_chain_along_g(j, k)]  # type: ignore[union-attr]
            else:
                row = fields.chain_along_g(j, k) if fields.m else sp.zeros(1, 0)
                per_input = [vanishes_on(e, fields.x, reg, samples=samples, seed=sd) for e in row]
            nonzero = [t for t in per_input if not t.zero]
            if nonzero:
                tests.append(max(nonzero, key=lambda t: abs(t.value or 0.0)))
                rj = k + 1
                break
            tests.append(per_input[0] if per_input else ZeroTest(True, "symbolic", 0, None, None))
        rs.append(rj)
        all_tests.append(tuple(tests))
    return RelativeDegree(tuple(rs), tuple(all_tests), reg, kmax)


def input_gain_structure(
    fields: AffineFields, s: Sequence[int], r: Sequence[int | None]
) -> tuple[sp.ImmutableMatrix, Array]:
    """``(H_{s,r}(x), F_{s,r})`` of Dalla Mora, Germani & Manes (2.11)–(2.13), with ``Q_s g = F_{s,r} H_{s,r}``.

    ``r_j = None`` (undefined relative degree) counts as ``s_j < r_j``: the output
    contributes no rows to ``H`` and zero rows to ``F``.

    Parameters
    ----------
    fields : AffineFields
        The input-affine model's ``f``, ``g``, ``h``.
    s : sequence of int
        Multi-index, one entry per output, summing to ``n``.
    r : sequence of int or None
        Observation relative degrees, one per output (``None`` where undefined).

    Returns
    -------
    H : sympy.ImmutableMatrix, (d, m)
        ``H_{s,r}(x)``, with ``d = Σ d_j`` over the outputs with ``s_j ≥ r_j``.
    F : ndarray, (n, d)
        The 0/1 matrix ``F_{s,r}``.

    Raises
    ------
    DimensionError
        ``r`` does not have ``q`` entries.

    Examples
    --------
    The shipped Duffing oscillator driven through an actuator (``n = 4``, outputs ``x1`` and ``x4``, two
    inputs): ``r = (3, 1)``; with ``s = r`` each output contributes one row to ``H``, and ``Q_s g = F H``.

    >>> import nlobs
    >>> import sympy as sp
    >>> fields = AffineFields.from_model(nlobs.load_model("duffing-actuator"))
    >>> r = observation_relative_degree(fields).r
    >>> H, F = input_gain_structure(fields, (3, 1), r)
    >>> r, H, F.astype(int).tolist()
    ((3, 1), Matrix([
    [1, 0],
    [0, 1]]), [[0, 0], [0, 0], [1, 0], [0, 1]])
    >>> observability_jacobian(fields, (3, 1)) * fields.g == sp.Matrix(F.astype(int)) * H
    True
    """
    s_ = check_multi_index(s, fields.q, fields.n)
    if len(r) != fields.q:
        raise DimensionError(f"r: expected {fields.q} entries, got {len(r)}")
    h_blocks: list[sp.Matrix] = []
    d_sizes: list[int] = []
    for j, (sj, rj) in enumerate(zip(s_, r)):
        if rj is None or sj < rj:
            d_sizes.append(0)
            continue
        chain = fields.lie_chain(j, sj)
        h_blocks.append(sp.Matrix.vstack(*[lie_derivative_along_columns(chain[k], fields.g, fields.x) for k in range(rj - 1, sj)]))
        d_sizes.append(sj - rj + 1)
    d = sum(d_sizes)
    H = sp.ImmutableMatrix(sp.Matrix.vstack(*h_blocks) if h_blocks else sp.zeros(0, fields.m))
    F = np.zeros((fields.n, d))
    row = col = 0
    for sj, dj in zip(s_, d_sizes):
        if dj:
            F[row + sj - dj : row + sj, col : col + dj] = np.eye(dj)  # S_j = [0_{(r_j−1)×d_j}; I_{d_j}]
        row += sj
        col += dj
    return H, F
