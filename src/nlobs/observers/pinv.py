r"""Röbenack's observer (7) with a Moore–Penrose gain field (17), and the Byrnes–Isidori gain (8).

For an input-affine model ``ẋ = f(x) + g(x) u``, ``y = h(x)`` with observation
relative degree ``r`` (A1), both observers have the form (7)::

    x̂̇ = f(x̂) + g(x̂) u + l(x̂) (y − h(x̂))

and differ in the gain vector field ``l``:

* :class:`PinvObserver` — ``l(x) = Q⁺(x) k`` (17), ``Q = [dh; …; dL_f^{r−1} h]``
  the reduced observability matrix (13) and ``Q⁺ = Qᵀ(QQᵀ)⁻¹`` its Moore–Penrose
  inverse (25). Theorem 4.1: under A1, A5 (the columns ``τ_i`` of ``Q⁺`` span an
  involutive distribution) and A6 (the ``τ_i`` are complete) this is the gain
  (15) of a global change of coordinates (2) whose last rows are orthogonal to
  ``Q`` (16). It needs no ``φ_{r+1}, …, φ_n``.
* :class:`ByrnesIsidoriObserver` — ``l(x) = (Φ'(x))⁻¹ [k; 0]`` (8)/(15) for
  user-supplied ``φ_{r+1}, …, φ_n`` (for the Byrnes–Isidori normal form they
  satisfy ``L_g φ_i ≡ 0`` (5)); the gain has a pole wherever ``det Φ' = 0``.

``k`` is a high-gain vector: the coefficients of ``(10)``,
``det(λI − (A − kcᵀ)) = λ^r + k_1 λ^{r−1} + … + k_r``, for roots ``−θ^i``
(``i = 1..r``; Dalla Mora–Germani–Manes [9, 10]) or a multiple root ``−θ``
(Gauthier–Hammouri–Othman [13]) — :class:`~nlobs.synthesis.pinv_gain.HighGain`
(:mod:`nlobs.synthesis.pinv_gain`). With several outputs the vectors are stacked (one
block of ``r_j`` entries per output) and the gain is ``Q⁺ K`` with
``K = blockdiag(k¹, …, k^q)``.

Saturation: the peaking remedy
------------------------------
A high-gain ``k`` makes the estimate peak (the error of ``ξ = Φ_r(x̂) = (h, …, L_f^{r−1} h)`` grows by
a factor of order ``θ^{r−1}`` before it decays) and can take ``x̂`` out of the region ``B`` where A1 and
A5 were checked. :class:`PinvObserver` with ``saturation = B`` applies Khalil's remedy (as
:mod:`nlobs.observers.drift` does for Dalla Mora, Germani & Manes (3.1)): keep the linear high-gain part
of the error dynamics in the coordinates ``ξ`` of the first ``r`` outputs' observability map and
evaluate only the nonlinear terms at ``σ = sat(x̂)`` (the component-wise projection onto ``B``, the hard
saturation of Grip, Saberi & Johansen, App. A). Along (7), ``ξ̇ = Q(x̂) x̂̇ = A_r ξ + B_r L_f^r h(x̂) +
Q(x̂) g(x̂) u + K (y − C_r ξ)`` (``Q Q⁺ = I``, ``Q f = A_r ξ + B_r L_f^r h``, ``A_r, B_r, C_r`` the
Brunovsky blocks of ``r``). The saturated observer is

.. math:: \dot{\hat x} = \big(I − Q^+(\hat x) Q(\hat x)\big) F(σ)
          + Q^+(\hat x)\big[A_r (Φ_r(\hat x) − Φ_r(σ)) + Q(σ) F(σ) + K (y − h(\hat x))\big],
          \qquad F = f + g u,

so that ``ξ̇ = A_r ξ + B_r L_f^r h(σ) + Q(σ) g(σ) u + K (y − C_r ξ)`` (Khalil's form), and the
directions along ``ker Q(x̂)`` (the coordinates ``φ_{r+1}, …, φ_n`` of Theorem 4.1, orthogonal to
``Q`` (16), never formed) follow ``F(σ)``. With ``Σ r_j = n`` (``Q`` square) the first term vanishes and
it is the drift observer's saturated form with ``s = r``.

Why it keeps what the analysis gives inside the region. For ``x̂ ∈ B``, ``σ = x̂``: the bracket is
``Q(x̂) F(x̂) + K ỹ`` and the right-hand side is ``(I − Q⁺Q) F + Q⁺ Q F + Q⁺ K ỹ = F + Q⁺ K ỹ`` — (7)
itself; the implementation evaluates (7) there, so it is the same to the last bit (tested at sampled
points of ``B``). A1 and A5 are verified on ``B`` only, and the run's coverage (the state and the
estimate in ``B``) is what the workflow monitors: every run, or stretch of a run, inside ``B`` is the
paper's observer unchanged. Outside ``B`` (where nothing was checked), with the state ``x ∈ B`` the
error ``e_ξ = Φ_r(x) − ξ`` obeys ``ė_ξ = (A_r − K C_r) e_ξ + B_r (L_f^r h(x) − L_f^r h(σ)) +
(Q(x) g(x) − Q(σ) g(σ)) u``: a Hurwitz linear system driven by a perturbation bounded by constants of
``B`` (``x, σ ∈ B``, compact) — the nonlinearity no longer feeds the peak. The zero-dynamics part is
driven by ``F(σ)``, bounded, but its decay is A4's (not checked), as for (7). What it does not remove
is the peak of the linear part itself; its effect is measured, not proved (``benchmarks/peaking.py``,
``docs/pinv.md``). :meth:`PinvObserver.saturated_estimate` gives ``sat(x̂)``; the estimate stays
``x̂``, so the coverage monitor sees it leave ``B``. The workflow :mod:`nlobs.workflows.design_pinv`
(``saturation=True``, its default with a region; ``nlobs design pinv``) switches it on; the observer has it off
(``saturation=None``, the paper's (7)).

Everything symbolic happens at construction (SymPy); the run-time right-hand side
is one NumPy function compiled with :func:`nlobs.systems.codegen.compile_matrix`.
The report behind ``nlobs design pinv`` is :mod:`nlobs.workflows.design_pinv`. See
``docs/pinv.md``.
"""

from __future__ import annotations

import copy
import dataclasses
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import sympy as sp
from numpy.typing import ArrayLike

from nlobs._typing import Array
from nlobs._validate import as_batch
from nlobs.checks import Check, CheckKind
from nlobs.errors import AssumptionViolated, DimensionError, InvalidArgumentError, ModelError
from nlobs.geometry.checks import check_a1, check_full_rank, check_involutive
from nlobs.geometry.lie import lie_derivative, simplify_bounded, tidy
from nlobs.geometry.observability import (
    AffineFields,
    RelativeDegree,
    observation_relative_degree,
    lie_map,
    reduced_observability_matrix,
)
from nlobs.geometry.pinv import block_gain, gain_symbols, pinv_gain_field, symbolic_pinv
from nlobs.geometry.region import Box
from nlobs.synthesis.pinv_gain import HighGain, companion_error_matrix, resolve_gain
from nlobs.systems.brunovsky import brunovsky
from nlobs.systems.codegen import BatchedFunction, compile_matrix
from nlobs.systems.expressions import as_sympy_expr, as_sympy_matrix, as_symbols
from nlobs.systems.symbolic import SymbolicModel
from nlobs.observers.base import ToControl
from nlobs.systems.timebase import Continuous, TimeBase

__all__ = ["AssumptionWarning", "ByrnesIsidoriObserver", "PinvObserver"]


class AssumptionWarning(UserWarning):
    """A design assumption that the observer does not need in order to run fails (its guarantee is lost).

    Examples
    --------
    The gain (8) of :class:`ByrnesIsidoriObserver` for the four-state example of Röbenack (``isidori-146``, a
    shipped model) with ``φ3 = x3`` and ``φ4 = x1``: ``L_g x3 = 1 ≠ 0``, so these coordinates are not the
    Byrnes–Isidori normal form (5). The observer is built all the same, and the warning says what is lost:

    >>> import warnings
    >>> import sympy as sp
    >>> import nlobs
    >>> x1, x3 = sp.symbols("x1 x3", real=True)
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     observer = nlobs.ByrnesIsidoriObserver.from_model(nlobs.load_model("isidori-146"), [x3, x1])
    >>> [(w.category.__name__, str(w.message)) for w in caught]
    [('AssumptionWarning', "isidori-146: L_g φ ≠ 0 for ['1']: not the Byrnes–Isidori form (gain (8) still valid)")]
    >>> issubclass(AssumptionWarning, UserWarning), observer.checks[1].name, observer.checks[1].passed
    (True, '(5) L_g φ_i ≡ 0', False)
    """


# ----------------------------------------------------------------------------- helpers
def _number(v: float) -> sp.Expr:
    return sp.Integer(int(v)) if float(v).is_integer() and abs(v) < 2**53 else sp.Float(v)


def _substitute_k(gain_symbolic: sp.MatrixBase, r: Sequence[int], kv: Array) -> sp.ImmutableMatrix:
    """The gain field with the numeric ``k`` in place of ``k1, k2, …``."""
    return sp.ImmutableMatrix(gain_symbolic.xreplace({s: _number(v) for s, v in zip(gain_symbols(r), kv)}))


def _require_a1(fields: AffineFields, region: Box, samples: int, seed: int) -> tuple[RelativeDegree, tuple[int, ...], Check]:
    """A1: the observation relative degree is defined and ``dh, …, dL_f^{r−1}h`` are independent on the region."""
    rd = observation_relative_degree(fields, region, seed=seed)
    for out, rj in zip(fields.outputs, rd.r):
        if rj is None:
            raise AssumptionViolated(
                f"{fields.name}: A1 fails: the observation relative degree of output {out!r} is not defined on "
                f"{region.describe()} (L_g L_f^k h ≡ 0 there for every k < {rd.max_order})",
                item="A1", evidence=f"r = {rd.r}")
    r = rd.require(fields.outputs)
    if sum(r) > fields.n:
        raise AssumptionViolated(
            f"{fields.name}: A1 fails: Σ r_j = {sum(r)} > n = {fields.n} for r = {r}; the rows of Q (13) cannot be "
            "independent", item="A1", evidence=f"r = {r}")
    chk = check_a1(fields, r, region, samples=samples, seed=seed)
    if not chk.passed:
        raise AssumptionViolated(f"{fields.name}: A1 fails on {region.describe()}: {chk.evidence}",
                                 item="A1", evidence=chk.evidence)
    return rd, r, chk


def _as_x_expr(fields: AffineFields, e: Any, what: str) -> sp.Expr:
    """A SymPy expression in the model's state names (symbols matched by name) — never text."""
    if isinstance(e, str) or not isinstance(e, (sp.Basic, int, float)):
        raise InvalidArgumentError(f"{what}: expected a SymPy expression in the states {list(fields.states)}, got {e!r}")
    expr = e if isinstance(e, sp.Basic) else (sp.Float(e) if isinstance(e, float) else sp.Integer(e))
    by_name = {s.name: s for s in fields.x}
    unknown = sorted(str(s) for s in expr.free_symbols if str(s) not in by_name)
    if unknown:
        raise ModelError(f"{fields.name}: {what} uses symbols that are not states: {', '.join(unknown)}")
    return expr.xreplace({s: by_name[str(s)] for s in expr.free_symbols})


class _InjectionObserver(ToControl):
    """Shared run-time part of observer (7): ``x̂̇ = f(x̂) + g(x̂) u + l(x̂) (y − h(x̂))``; ``z = x̂``."""

    fields: AffineFields

    @property
    def n_z(self) -> int:
        """Observer state dimension (``n``)."""
        return self.fields.n

    @property
    def n_x(self) -> int:
        """Estimate dimension (``n``)."""
        return self.fields.n

    def init(self, x_hat0: ArrayLike) -> Array:
        """Observer state from the initial estimate (``z0 = x̂0``), shape ``(..., n)``."""
        return np.array(as_batch("x_hat0", x_hat0, self.fields.n), dtype=float)

    def estimate(self, z: Array) -> Array:
        """The estimate is the observer state, ``x̂ = z``."""
        return z

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``x̂̇`` of (7) for batches: ``z`` ``(..., n)``, ``u`` ``(..., m)``, ``y`` ``(..., q)``."""
        return self._rhs(z, u, y)  # type: ignore[attr-defined, no-any-return]


def _compile_injection(fields: AffineFields, gain: sp.MatrixBase) -> BatchedFunction:
    """``f + g u + l (y − h)`` compiled as one function of ``(x, u, y)`` (cse over all terms)."""
    u = sp.symbols(f"_u0:{fields.m}", real=True) if fields.m else ()
    y = sp.symbols(f"_y0:{fields.q}", real=True)
    expr = sp.Matrix(fields.f) + (sp.Matrix(fields.g) * sp.Matrix(u) if fields.m else sp.zeros(fields.n, 1))
    expr += as_sympy_matrix("gain", gain) * (sp.Matrix(y) - sp.Matrix(fields.h))
    return compile_matrix(expr, (fields.x, tuple(u), tuple(y)), vector=True, what=f"{fields.name}: observer (7)")


# ----------------------------------------------------------------------------- Moore–Penrose observer
@dataclass(frozen=True, eq=False)
class PinvObserver(_InjectionObserver):
    """Observer (7) with the Moore–Penrose gain ``l(x) = Q⁺(x) K`` (17) of Röbenack.

    Construction checks A1 (relative degree defined on the region, rows of ``Q``
    independent at every sampled point) and refuses with
    :class:`~nlobs.errors.AssumptionViolated` otherwise; it checks A5
    (involutivity of ``span{τ_1, …, τ_r}``) and refuses, or only warns with
    :class:`AssumptionWarning` when ``require_a5=False`` (the observer runs, but
    Theorem 4.1 and Corollary 4.1 no longer apply).

    Parameters
    ----------
    fields : AffineFields
        The model (see :meth:`from_model`).
    k : array_like or HighGain
        The stacked high-gain vector (``Σ r_j`` entries), or a :class:`HighGain`
        design (default ``HighGain()``: roots ``−θ^i`` with ``θ = 2``).
    region : Box, optional
        Where A1/A5 are checked (default ``[−1, 1]ⁿ``).
    pinv : {"symbolic", "numeric"}
        ``"symbolic"``: ``Q⁺`` from the simplified closed form (compiled);
        ``"numeric"``: ``np.linalg.pinv`` of the compiled ``Q`` at every evaluation.
    require_a5 : bool
        Refuse (default) or warn when A5 fails.
    samples, seed : int
        Sampling of the region for the checks.
    saturation : Box, optional
        ``None`` (default): (7) as printed. A box ``B`` (the design's region): outside it the nonlinear
        terms in the coordinates ``Φ_r`` are evaluated at ``sat(x̂)`` (Khalil's form, module docstring;
        inside ``B`` the observer is (7), bit for bit).

    Attributes
    ----------
    r : tuple of int
        Observation relative degrees.
    relative_degree : RelativeDegree
        With the zero tests behind ``r``.
    Q, Qp : sympy.ImmutableMatrix
        ``Q`` (13) and ``Q⁺`` (25); the columns of ``Qp`` are ``τ_1, …, τ_r`` (18).
    gain_symbolic : sympy.ImmutableMatrix
        ``l(x) = Q⁺(x) K`` with the symbols ``k1, k2, …`` (n × q).
    gain : sympy.ImmutableMatrix
        The same with the numeric ``k``.
    k_vector : ndarray
        The numeric stacked ``k``.
    high_gain : HighGain or None
        The design ``k`` came from (``None`` when given numerically).
    checks : tuple of Check
        A1 and A5 with their evidence.

    Examples
    --------
    The four-state example of Röbenack (``isidori-146``, a shipped model) has ``r = 2``; ``HighGain(3.0)`` gives
    ``k`` with the roots −3 and −9 in (10). The gain (26) has no pole and no component along ``x3``
    (``l3 ≡ 0``): the error of ``x3`` decays as ``e^{−t}``, with the zero dynamics (A4):

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.synthesis.pinv_gain import HighGain
    >>> model = nlobs.load_model("isidori-146")
    >>> observer = nlobs.PinvObserver.from_model(model, k=HighGain(3.0))
    >>> observer.r, observer.k_vector.tolist()
    ((2,), [12.0, 27.0])
    >>> observer.gain_at([0.3, 0.1, -1.0, 0.0])[:, 0].round(3)
    array([11.912, 19.853,  0.   , 12.   ])
    >>> res = nlobs.simulate(model.compile(), observer, [0.5, -2.0, -2.0, 0.0], [0.3, -1.5, 0.0, 0.5],
    ...                      duration=3.0, dt=1e-2, u=0.0)
    >>> e = res.error  # x̂ − x
    >>> bool(np.allclose(e[:, 2], e[0, 2] * np.exp(-res.t), rtol=0, atol=1e-8))
    True
    >>> bool(res.error_norm[-1] < 0.1 * res.error_norm[0])
    True
    """

    fields: AffineFields
    k: ArrayLike | HighGain = field(default_factory=HighGain)
    region: Box | None = None
    pinv: Literal["symbolic", "numeric"] = "symbolic"
    require_a5: bool = True
    samples: int = 256
    seed: int = 0
    saturation: Box | None = None
    r: tuple[int, ...] = field(init=False)
    relative_degree: RelativeDegree = field(init=False, repr=False)
    Q: sp.ImmutableMatrix = field(init=False, repr=False)
    Qp: sp.ImmutableMatrix = field(init=False, repr=False)
    gain_symbolic: sp.ImmutableMatrix = field(init=False, repr=False)
    gain: sp.ImmutableMatrix = field(init=False, repr=False)
    k_vector: Array = field(init=False)
    high_gain: HighGain | None = field(init=False)
    checks: tuple[Check, ...] = field(init=False, repr=False)
    time: TimeBase = field(init=False, repr=False)
    state_names: tuple[str, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        F = self.fields
        if not isinstance(F, AffineFields):
            raise InvalidArgumentError(f"fields: expected AffineFields (use PinvObserver.from_model), got {type(F).__name__}")
        if self.pinv not in ("symbolic", "numeric"):
            raise InvalidArgumentError(f"pinv: expected 'symbolic' or 'numeric', got {self.pinv!r}")
        region = self.region or Box.unit(F.n)
        if region.n != F.n:
            raise DimensionError(f"region: has dimension {region.n}, the model {F.name!r} has n = {F.n}")
        rd, r, a1 = _require_a1(F, region, self.samples, self.seed)
        kv, hg = resolve_gain(self.k, r)
        Q = reduced_observability_matrix(F, r)
        Qp = symbolic_pinv(Q)
        a5 = check_involutive(F, r, region, Qp=Qp, samples=min(self.samples, 128), seed=self.seed)
        if not a5.passed:
            msg = f"{F.name}: A5 fails on {region.describe()}: {a5.evidence}"
            if self.require_a5:
                raise AssumptionViolated(msg + " (pass require_a5=False to build the observer anyway, without the "
                                         "guarantee of Theorem 4.1)", item="A5", evidence=a5.evidence)
            warnings.warn(AssumptionWarning(msg + ": Theorem 4.1 does not apply to this gain"), stacklevel=3)
        gain_sym = pinv_gain_field(Qp, r)
        gain = _substitute_k(gain_sym, r, kv)
        kv.setflags(write=False)
        for name, value in (("region", region), ("r", r), ("relative_degree", rd), ("Q", Q), ("Qp", Qp),
                            ("gain_symbolic", gain_sym), ("gain", gain), ("k_vector", kv), ("high_gain", hg),
                            ("checks", (a1, a5)), ("time", Continuous()),
                            ("state_names", tuple(f"{s}_hat" for s in F.states))):
            object.__setattr__(self, name, value)
        Knum = np.asarray(np.array(block_gain(r, list(kv)), dtype=float))
        object.__setattr__(self, "_K", Knum)
        if self.pinv == "symbolic":
            object.__setattr__(self, "_rhs", _compile_injection(F, gain))
            object.__setattr__(self, "_gain_fn", compile_matrix(gain, (F.x,), what=f"{F.name}: Q⁺K"))
        else:
            u = sp.symbols(f"_u0:{F.m}", real=True) if F.m else ()
            drift = sp.Matrix(F.f) + (sp.Matrix(F.g) * sp.Matrix(u) if F.m else sp.zeros(F.n, 1))
            object.__setattr__(self, "_drift", compile_matrix(drift, (F.x, tuple(u)), vector=True, what=f"{F.name}: f + g u"))
            object.__setattr__(self, "_h", compile_matrix(F.h, (F.x,), vector=True, what=f"{F.name}: h"))
            object.__setattr__(self, "_Q", compile_matrix(Q, (F.x,), what=f"{F.name}: Q (13)"))
            object.__setattr__(self, "_rhs", self._numeric_rhs)
            object.__setattr__(self, "_gain_fn", self._numeric_gain)
        self._compile_saturation()

    def _compile_saturation(self) -> None:
        """Check :attr:`saturation` and compile what its form needs (nothing without one)."""
        F, B = self.fields, self.saturation
        if B is None:
            return
        if not isinstance(B, Box):
            raise InvalidArgumentError(f"saturation: expected a Box or None, got {type(B).__name__}")
        if B.n != F.n:
            raise DimensionError(f"saturation: the box has dimension {B.n}, the model {F.name!r} has n = {F.n}")
        # f, g, h, Φ_r (the first r rows of the observability map), Q (13) and, symbolic, Q⁺ (25): one function
        entries = list(F.f) + list(F.g) + list(F.h) + list(lie_map(F, self.r)) + list(self.Q)
        if self.pinv == "symbolic":
            entries += list(self.Qp)
        object.__setattr__(self, "_sat_fn", compile_matrix(sp.Matrix(entries), (F.x,), vector=True,
                                                           what=f"{F.name}: f, g, h, Φ_r, Q, Q⁺"))
        object.__setattr__(self, "_A", brunovsky(self.r)[0])

    def with_saturation(self, saturation: Box | None) -> PinvObserver:
        """The same observer (same checks, gain and compiled (7)) with :attr:`saturation` set; no re-design."""
        new = copy.copy(self)
        object.__setattr__(new, "saturation", saturation)
        new._compile_saturation()
        return new

    @classmethod
    def from_model(
        cls, model: SymbolicModel, *, parameters: Mapping[str, float] | None = None, **kwargs: Any
    ) -> PinvObserver:
        """Build from a continuous-time input-affine :class:`SymbolicModel` (keyword arguments as the class)."""
        return cls(AffineFields.from_model(model, parameters), **kwargs)

    # -- numeric Moore–Penrose inverse (pinv="numeric")
    def _numeric_gain(self, x: Array) -> Array:
        return np.linalg.pinv(self._Q(x)) @ self._K  # type: ignore[attr-defined, no-any-return]

    def _numeric_rhs(self, x: Array, u: Array, y: Array) -> Array:
        innov = y - self._h(x)  # type: ignore[attr-defined]
        return self._drift(x, u) + (self._numeric_gain(x) @ innov[..., None])[..., 0]  # type: ignore[attr-defined, no-any-return]

    def _sat_parts(self, x: Array) -> tuple[Array, Array, Array, Array, Array, Array]:
        """``f, g, h, Φ_r, Q, Q⁺`` at a batch ``(..., n)`` (for the saturated form)."""
        F = self.fields
        n, m, q, nr = F.n, F.m, F.q, sum(self.r)
        v = self._sat_fn(x)  # type: ignore[attr-defined]
        sizes = (n, n * m, q, nr, nr * n)
        parts, i = [], 0
        for sz in sizes:
            parts.append(v[..., i : i + sz])
            i += sz
        f, g, h, phi, Q = parts
        g = g.reshape(*v.shape[:-1], n, m)
        Q = Q.reshape(*v.shape[:-1], nr, n)
        Qp = v[..., i : i + n * nr].reshape(*v.shape[:-1], n, nr) if self.pinv == "symbolic" else np.linalg.pinv(Q)
        return f, g, h, phi, Q, Qp

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``x̂̇`` of (7) for batches; with :attr:`saturation`, Khalil's form outside the box (module docstring).

        Inside the box (every component of ``x̂`` within its bounds) the result is (7)'s, bit for bit.
        """
        base = self._rhs(z, u, y)  # type: ignore[attr-defined]
        B = self.saturation
        if B is None:
            return base  # type: ignore[no-any-return]
        sig = np.clip(z, B.lower, B.upper)
        outside = np.any(sig != z, axis=-1)
        if not np.any(outside):
            return base  # type: ignore[no-any-return]
        uu = np.asarray(u, dtype=float)
        with np.errstate(all="ignore"):
            _, _, h, phi, Q, Qp = self._sat_parts(z)
            fs, gs, _, phis, Qs, _ = self._sat_parts(sig)
            drift_s = fs if self.fields.m == 0 else fs + np.einsum("...ij,...j->...i", gs, uu)
            innov = np.asarray(y, dtype=float) - h
            # ξ̇ = A_r ξ + B_r L_f^r h(σ) + Q(σ) g(σ) u + K (y − h(x̂)) in ξ = Φ_r(x̂), lifted by Q⁺(x̂);
            # along ker Q(x̂) (the zero dynamics) the estimate follows f(σ) + g(σ) u
            xi_dot = ((phi - phis) @ self._A.T + np.einsum("...ij,...j->...i", Qs, drift_s)  # type: ignore[attr-defined]
                      + innov @ self._K.T)  # type: ignore[attr-defined]
            along = drift_s - np.einsum("...ij,...j->...i", Qp, np.einsum("...ij,...j->...i", Q, drift_s))
            sat = along + np.einsum("...ij,...j->...i", Qp, xi_dot)
        return np.where(outside[..., None], sat, base)  # type: ignore[no-any-return]

    def saturated_estimate(self, x_hat: ArrayLike) -> Array:
        """``sat(x̂)`` onto :attr:`saturation` (``x̂`` itself without one): the estimate to hand on, in the box."""
        x = np.asarray(x_hat, dtype=float)
        B = self.saturation
        return x if B is None else np.clip(x, B.lower, B.upper)

    def gain_at(self, x: ArrayLike) -> Array:
        """``l(x) = Q⁺(x) K`` at a batch of points, shape ``(..., n, q)``."""
        return self._gain_fn(as_batch("x", x, self.fields.n))  # type: ignore[attr-defined, no-any-return]

    @property
    def error_matrices(self) -> tuple[Array, ...]:
        """Per output, ``A − k cᵀ`` of (9a) (its eigenvalues are the placed roots)."""
        out, i = [], 0
        for rj in self.r:
            out.append(companion_error_matrix(self.k_vector[i : i + rj]))
            i += rj
        return tuple(out)


# ----------------------------------------------------------------------------- Byrnes–Isidori gain
@dataclass(frozen=True, eq=False)
class ByrnesIsidoriObserver(_InjectionObserver):
    """Observer (7) with the gain ``l(x) = (Φ'(x))⁻¹ [K; 0]`` ((8)/(15) of Röbenack) for given ``φ_{r+1}, …, φ_n``.

    ``Φ = (h, L_f h, …, L_f^{r−1} h, φ_{r+1}, …, φ_n)`` (2). The Byrnes–Isidori
    normal form needs ``L_g φ_i ≡ 0`` (5); when that fails the observer is still
    (8) for the coordinates given, and an :class:`AssumptionWarning` says so.
    ``det Φ'`` must not vanish identically (else :class:`AssumptionViolated`);
    where it vanishes the gain has a pole (:attr:`singular_set`,
    :attr:`checks`) — the paper's point against this gain.

    Parameters
    ----------
    fields : AffineFields
    phi : sequence of sympy.Expr
        ``n − Σ r_j`` functions of the states (symbols matched by name).
    k : array_like or HighGain
    region : Box, optional
        Where A1 and ``det Φ' ≠ 0`` are checked (default ``[−1, 1]ⁿ``).
    samples, seed : int
        Sampling of the region for the checks.

    Attributes
    ----------
    r : tuple of int
    Phi : sympy.ImmutableMatrix
        The map (2).
    jacobian : sympy.ImmutableMatrix
        ``Φ'`` (23).
    det : sympy.Expr
        ``det Φ'``, factored.
    gain_symbolic, gain : sympy.ImmutableMatrix
        ``(Φ')⁻¹ [K; 0]`` with the symbols ``k1, …`` and with the numeric ``k``.
    k_vector : ndarray
    checks : tuple of Check
        A1, (5) and ``det Φ' ≠ 0`` on the region (with the point of smallest ``|det Φ'|``).

    Examples
    --------
    The four-state example of Röbenack (``isidori-146``, a shipped model) with ``φ3 = x2 − 2 x3 − x3²`` and
    ``φ4 = x1`` (both with ``L_g φ ≡ 0``): ``det Φ' = 2 (x3 + 1)``, so the gain has a pole at ``x3 = −1``
    (the Moore–Penrose gain of :class:`PinvObserver` has none). From an estimate that stays off the pole the
    error still converges:

    >>> import sympy as sp
    >>> import nlobs
    >>> from nlobs.synthesis.pinv_gain import HighGain
    >>> x1, x2, x3 = sp.symbols("x1 x2 x3", real=True)
    >>> model = nlobs.load_model("isidori-146")
    >>> observer = nlobs.ByrnesIsidoriObserver.from_model(model, [x2 - 2 * x3 - x3**2, x1], k=HighGain(3.0))
    >>> observer.det, observer.singular_set
    (2*(x3 + 1), ('x3 = -1',))
    >>> bool(abs(observer.gain_at([0.3, 0.1, -1.0 + 1e-6, 0.0])[2, 0]) > 1e6)  # next to the pole
    True
    >>> res = nlobs.simulate(model.compile(), observer, [0.5, -2.0, -2.0, 0.0], [0.3, -1.5, 0.0, 0.5],
    ...                      duration=3.0, dt=1e-2, u=0.0)
    >>> bool(res.x_hat[:, 2].min() > -1.0), bool(res.error_norm[-1] < 0.05 * res.error_norm[0])
    (True, True)
    """

    fields: AffineFields
    phi: Sequence[sp.Expr]
    k: ArrayLike | HighGain = field(default_factory=HighGain)
    region: Box | None = None
    samples: int = 256
    seed: int = 0
    r: tuple[int, ...] = field(init=False)
    Phi: sp.ImmutableMatrix = field(init=False, repr=False)
    jacobian: sp.ImmutableMatrix = field(init=False, repr=False)
    det: sp.Expr = field(init=False, repr=False)
    gain_symbolic: sp.ImmutableMatrix = field(init=False, repr=False)
    gain: sp.ImmutableMatrix = field(init=False, repr=False)
    k_vector: Array = field(init=False)
    high_gain: HighGain | None = field(init=False)
    checks: tuple[Check, ...] = field(init=False, repr=False)
    time: TimeBase = field(init=False, repr=False)
    state_names: tuple[str, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        F = self.fields
        if not isinstance(F, AffineFields):
            raise InvalidArgumentError(f"fields: expected AffineFields, got {type(F).__name__}")
        region = self.region or Box.unit(F.n)
        if region.n != F.n:
            raise DimensionError(f"region: has dimension {region.n}, the model {F.name!r} has n = {F.n}")
        _, r, a1 = _require_a1(F, region, self.samples, self.seed)
        if isinstance(self.phi, (str, sp.Basic)) or not isinstance(self.phi, Sequence):
            raise InvalidArgumentError(f"phi: expected a sequence of {F.n - sum(r)} SymPy expressions, got {self.phi!r}")
        phis = tuple(_as_x_expr(F, e, f"phi[{i}]") for i, e in enumerate(self.phi))
        if len(phis) != F.n - sum(r):
            raise DimensionError(f"phi: expected n − Σ r_j = {F.n - sum(r)} functions for r = {r}, got {len(phis)}")
        kv, hg = resolve_gain(self.k, r)
        chains = [e for j, rj in enumerate(r) for e in F.lie_chain(j, rj)]
        Phi = sp.ImmutableMatrix(chains + list(phis))
        J = sp.ImmutableMatrix(Phi.jacobian(sp.Matrix(F.x)).applyfunc(tidy))
        det = sp.factor(tidy(J.det(method="berkowitz")))
        if det == 0:
            raise AssumptionViolated(f"{F.name}: det Φ' ≡ 0: the gradients of (h, …, L_f^(r−1) h, φ) are dependent "
                                     "everywhere; choose other φ", item="det Φ'", evidence="det Φ' = 0")
        # (5): L_g φ_i ≡ 0
        lg = [sp.simplify(lie_derivative(p, F.g[:, c], F.x)) for p in phis for c in range(F.m)]
        bad = [i for i, e in enumerate(lg) if e != 0]
        c5 = Check.verdict("(5) L_g φ_i ≡ 0", not bad,
                           "L_g φ_i ≡ 0 for every φ: Byrnes–Isidori normal form" if not bad
                           else f"L_g φ ≠ 0 for {[str(lg[i]) for i in bad]}: not the Byrnes–Isidori form (gain (8) still "
                           "valid)", kind=CheckKind.STRUCTURAL, method="symbolic")
        if bad:
            warnings.warn(AssumptionWarning(f"{F.name}: {c5.evidence}"), stacklevel=3)
        # det Φ' on the region: the pole of the gain (a sign change or a rank loss inside the region)
        sing = self.singular_set_of(det, F.x)
        full = check_full_rank("det Φ' ≠ 0", "Φ'", J, F, region, self.samples, self.seed, det=det)
        cdet = dataclasses.replace(
            full, symbolic=str(det),
            evidence=full.evidence + (f"; det Φ' vanishes on {', '.join(sing)} (the gain has a pole there"
                                      f"{'' if not full.passed else ', outside the region'})" if sing else ""))
        ks = gain_symbols(r)
        rhs_sym = sp.Matrix.vstack(block_gain(r, list(ks)), sp.zeros(F.n - sum(r), len(r)))
        gsym = sp.ImmutableMatrix(sp.Matrix(J).LUsolve(rhs_sym).applyfunc(simplify_bounded))
        gain = _substitute_k(gsym, r, kv)
        kv.setflags(write=False)
        for name, value in (("region", region), ("phi", phis), ("r", r), ("Phi", Phi), ("jacobian", J), ("det", det),
                            ("gain_symbolic", gsym), ("gain", gain), ("k_vector", kv), ("high_gain", hg),
                            ("checks", (a1, c5, cdet)), ("time", Continuous()),
                            ("state_names", tuple(f"{s}_hat" for s in F.states))):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "_rhs", _compile_injection(F, gain))
        object.__setattr__(self, "_gain_fn", compile_matrix(gain, (F.x,), what=f"{F.name}: (Φ')⁻¹[K; 0]"))

    @staticmethod
    def singular_set_of(det: sp.Expr, x: Sequence[sp.Symbol]) -> tuple[str, ...]:
        """The factors of ``det Φ'`` that can vanish, as equations (``"x3 = -1"`` where SymPy solves them)."""
        det, x = as_sympy_expr("det", det), as_symbols("x", x)
        out: list[str] = []
        for fac, _ in sp.factor_list(det)[1]:
            syms = [s for s in x if s in fac.free_symbols]
            sol = sp.solve(fac, syms[0], dict=False) if len(syms) == 1 else None
            if sol:
                out.extend(f"{syms[0]} = {v}" for v in sol if v.is_real is not False)
            elif syms:
                out.append(f"{fac} = 0")
        return tuple(out)

    @property
    def singular_set(self) -> tuple[str, ...]:
        """Where ``det Φ' = 0`` (the poles of the gain)."""
        return self.singular_set_of(self.det, self.fields.x)

    @classmethod
    def from_model(
        cls, model: SymbolicModel, phi: Sequence[sp.Expr], *, parameters: Mapping[str, float] | None = None, **kwargs: Any
    ) -> ByrnesIsidoriObserver:
        """Build from a :class:`SymbolicModel` (keyword arguments as the class)."""
        return cls(AffineFields.from_model(model, parameters), phi, **kwargs)

    def gain_at(self, x: ArrayLike) -> Array:
        """``l(x)`` at a batch of points, shape ``(..., n, q)`` (``inf``/``nan`` on the singular set)."""
        with np.errstate(all="ignore"):
            return self._gain_fn(as_batch("x", x, self.fields.n))  # type: ignore[attr-defined, no-any-return]
