r"""Σ₂'s structure in the cascade observer of Grip, Saberi & Johansen: the extended system (8c) and Assumption 4.

* :func:`extended_system` — (8c): ``w_e = [w; z]``, ``𝔄 = [[A, B_z], [0, 0]]``,
  ``𝔅_d = [[0], [I]]``, ``ℭ = [C, D_z]``; the gain designs of :mod:`nlobs.synthesis` work on it.
* :func:`check_assumption4` — Assumption 4 item by item (detectability of ``(A, C)``;
  left-invertibility of ``(A, B_z, C, D_z)``; no invariant zero at the origin; the rank conditions
  on ``[B_z; D_z]`` and ``[C, D_z]`` of Sec. 2), plus the minimum-phase property that decides
  ``γ* = 0`` in Theorem 2, as a readable :class:`Assumption4Report`. :func:`require_assumption4`
  raises :class:`~nlobs.errors.AssumptionViolated` naming the first failed item.

The Theorem 1 / 1' bounds on ``γ`` and the quadratic Lyapunov constants of Assumption 1 are in
:mod:`nlobs.synthesis.cascade_bounds`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._typing import Array
from nlobs._validate import as_matrix, as_square, readonly
from nlobs.checks import Check, CheckKind
from nlobs.errors import AssumptionViolated, DimensionError, InvalidArgumentError
from nlobs.linear.observability import is_detectable, unobservable_modes
from nlobs.linear.stability import BOUNDARY_TOL
from nlobs.linear.zeros import invariant_zeros, minimum_phase
from nlobs.systems.linear import takes_system

__all__ = [
    "ASSUMPTION4_ITEMS",
    "Assumption4Report",
    "ExtendedSystem",
    "check_assumption4",
    "extended_system",
    "require_assumption4",
]

#: Keys of the items that make up Assumption 4 (in the order they are checked).
ASSUMPTION4_ITEMS: tuple[str, ...] = (
    "rank_Bz_Dz",
    "rank_C_Dz",
    "detectable",
    "left_invertible",
    "no_zero_at_origin",
)


class ExtendedSystem(NamedTuple):
    """Extended system (8c) of Grip, Saberi & Johansen: state ``w_e = [w; z]``.

    Attributes
    ----------
    A : ndarray, shape (n_w + p_z, n_w + p_z)
        ``𝔄 = [[A, B_z], [0, 0]]``.
    Bd : ndarray, shape (n_w + p_z, p_z)
        ``𝔅_d = [[0], [I]]``.
    C : ndarray, shape (p_y, n_w + p_z)
        ``ℭ = [C, D_z]``.

    Examples
    --------
    The per-axis GNSS/INS model (Grip, Saberi & Johansen, Sec. 5), position measured and the
    acceleration ``z`` unknown: (8c) makes ``z`` a third state, driven by ``𝔅_d``:

    >>> A, Bd, C = extended_system([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> A.tolist()
    [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]
    >>> Bd.ravel().tolist(), C.tolist()
    ([0.0, 0.0, 1.0], [[1.0, 0.0, 0.0]])
    """

    A: NDArray[np.float64]
    """``𝔄 = [[A, B_z], [0, 0]]``."""
    Bd: NDArray[np.float64]
    """``𝔅_d = [[0], [I]]``."""
    C: NDArray[np.float64]
    """``ℭ = [C, D_z]``."""


@takes_system(time="continuous", A="A", B_z="B", C="C", D_z="D")
def extended_system(A: ArrayLike, B_z: ArrayLike, C: ArrayLike, D_z: ArrayLike | None = None) -> ExtendedSystem:
    r"""Extended system (8c) of Grip, Saberi & Johansen that includes ``z`` as a state.

    Parameters
    ----------
    A : array_like, shape (n_w, n_w)
    B_z : array_like, shape (n_w, p_z)
    C : array_like, shape (p_y, n_w)
    D_z : array_like, shape (p_y, p_z), optional
        Zero when omitted.

    Returns
    -------
    ExtendedSystem
        ``𝔄 = [[A, B_z], [0, 0]]``, ``𝔅_d = [[0], [I_{p_z}]]``, ``ℭ = [C, D_z]``.

    Examples
    --------
    Per-axis GNSS/INS model (Grip, Saberi & Johansen, Sec. 5): position and velocity with
    acceleration ``z`` as input, both measured:

    >>> ext = extended_system([[0, 1], [0, 0]], [[0], [1]], [[1, 0], [0, 1]])
    >>> ext.A.shape, ext.Bd.shape, ext.C.shape
    ((3, 3), (3, 1), (2, 3))
    """
    A_ = as_square("A", A)
    n = A_.shape[0]
    Bz = as_matrix("B_z", B_z, (n, None))
    C_ = as_matrix("C", C, (None, n))
    pz, py = Bz.shape[1], C_.shape[0]
    Dz = np.zeros((py, pz)) if D_z is None else as_matrix("D_z", D_z, (py, pz))
    Ae = np.block([[A_, Bz], [np.zeros((pz, n)), np.zeros((pz, pz))]])
    Bde = np.vstack([np.zeros((n, pz)), np.eye(pz)])
    Ce = np.hstack([C_, Dz])
    return ExtendedSystem(Ae, Bde, Ce)


_EPS = float(np.finfo(float).eps)


def _fmt_c(z: complex) -> str:
    z = complex(z)
    if abs(z.imag) < 1e-12 * max(1.0, abs(z)):
        return f"{z.real:.6g}"
    return f"{z.real:.6g}{'+' if z.imag >= 0 else '-'}{abs(z.imag):.6g}j"


def _fmt_list(z: NDArray[Any]) -> str:
    return "[" + ", ".join(_fmt_c(v) for v in z) + "]" if len(z) else "none"


def _item(key: str, title: str, holds: bool, evidence: str, required: bool, values: dict[str, Any],
          kind: CheckKind = CheckKind.STRUCTURAL) -> Check:
    """One item of Assumption 4 as a :class:`~nlobs.checks.Check` (``key`` its machine name, ``title`` its name)."""
    return Check.verdict(title, holds, evidence, kind=kind, method="numeric", required=required, key=key, values=values)


@dataclass(frozen=True)
class Assumption4Report:
    """Assumption 4 of Grip, Saberi & Johansen, item by item, for ``(A, B_z, C, D_z)``.

    Attributes
    ----------
    items : tuple of Check
        Every item, required ones first (:data:`ASSUMPTION4_ITEMS`), then the
        informational ``"minimum_phase"`` and ``"extended_detectable"``
        (``required=False``). Each item's ``key`` is its machine name, ``name`` says
        what is checked, ``evidence`` and ``values`` give the numbers.
    n_w, p_z, p_y : int
        Dimensions of ``w``, ``z`` and ``y``.
    zeros : ndarray of complex
        Finite invariant zeros of ``(A, B_z, C, D_z)``.
    normal_rank : int
        Normal rank of the Rosenbrock matrix (``n_w + p_z`` iff left-invertible).

    Examples
    --------
    ``G(s) = (1 − s)/((s + 1)(s + 2))``: Assumption 4 holds, but the zero at ``s = 1`` makes
    ``(A, B_z, C, D_z)`` non-minimum phase, so Theorem 2 does not give ``γ* = 0``:

    >>> rep = check_assumption4([[-1, 0], [0, -2]], [[1], [1]], [[1, -1.5]])
    >>> rep.holds, rep.minimum_phase, rep.gamma_star_zero
    (True, False, False)
    >>> np.round(rep.zeros, 6).tolist(), rep.normal_rank
    ([(1+0j)], 3)
    >>> rep.item("minimum_phase").evidence
    'invariant zero(s) with Re z >= 0: 1+0j'
    >>> rep.to_dict()["items"][0]["key"], rep.summary().splitlines()[0]
    ('rank_Bz_Dz', 'Assumption 4 (Grip–Saberi–Johansen) for Σ2 with n_w=2, p_z=1, p_y=1: HOLDS')
    """

    items: tuple[Check, ...]
    n_w: int
    p_z: int
    p_y: int
    zeros: NDArray[np.complex128]
    normal_rank: int

    @property
    def holds(self) -> bool:
        """Whether every required item holds (Assumption 4 with the rank conditions)."""
        return all(it.passed for it in self.items if it.required)

    @property
    def failed(self) -> tuple[Check, ...]:
        """The required items that fail."""
        return tuple(it for it in self.items if it.required and not it.passed)

    @property
    def minimum_phase(self) -> bool:
        """Whether ``(A, B_z, C, D_z)`` is minimum phase: then ``γ* = 0`` (Theorem 2)."""
        return self.item("minimum_phase").passed

    @property
    def gamma_star_zero(self) -> bool:
        """Theorem 2: ``‖H‖∞`` can be made arbitrarily small iff this is True (sufficient)."""
        return self.holds and self.minimum_phase

    def item(self, key: str) -> Check:
        """The item named ``key``."""
        for it in self.items:
            if it.key == key:
                return it
        raise InvalidArgumentError(f"key: no item {key!r} (known: {[it.key for it in self.items]})")

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python view (JSON-serialisable)."""
        return {
            "holds": self.holds,
            "minimum_phase": self.minimum_phase,
            "gamma_star_zero": self.gamma_star_zero,
            "n_w": self.n_w,
            "p_z": self.p_z,
            "p_y": self.p_y,
            "normal_rank": self.normal_rank,
            "zeros": [[float(z.real), float(z.imag)] for z in self.zeros],
            "items": [{**it.to_dict(), "title": it.name} for it in self.items],
        }

    def summary(self) -> str:
        """A plain-text report, one line per item (no rich markup)."""
        lines = [
            f"Assumption 4 (Grip–Saberi–Johansen) for Σ2 with n_w={self.n_w}, p_z={self.p_z}, p_y={self.p_y}: "
            + ("HOLDS" if self.holds else "FAILS (" + ", ".join(it.key for it in self.failed) + ")")
        ]
        for it in self.items:
            tag = ("ok  " if it.passed else "FAIL") if it.required else ("yes " if it.passed else "no  ")
            kind = "" if it.required else " [info]"
            lines.append(f"  [{tag}] {it.name}{kind}: {it.evidence}")
        if self.holds:
            lines.append(
                "  => γ* = 0 (Theorem 2): ‖H‖∞ < γ is achievable for every γ > 0"
                if self.minimum_phase
                else "  => γ* > 0 possible (not minimum phase): Theorem 1 may not be satisfiable"
            )
        return "\n".join(lines)


def _rank_item(key: str, title: str, M: Array, want: int, what: str) -> Check:
    s = np.linalg.svd(M, compute_uv=False) if M.size else np.zeros(0)
    tol = max(M.shape, default=1) * _EPS * (float(s[0]) if s.size else 0.0) * 10.0
    r = int(np.sum(s > tol)) if s.size else 0
    smin = float(s[want - 1]) if s.size >= want > 0 else 0.0
    ok = r == want
    ev = f"rank {what} = {r} (need {want}); σ_min = {smin:.3g}" + ("" if ok else " — redundant components: redefine them")
    return _item(key, title, ok, ev, True, {"rank": r, "required_rank": want, "sigma_min": smin,
                                            "singular_values": [float(v) for v in s]}, CheckKind.RANK)


@takes_system(time="continuous", A="A", B_z="B", C="C", D_z="D")
def check_assumption4(
    A: ArrayLike,
    B_z: ArrayLike,
    C: ArrayLike,
    D_z: ArrayLike | None = None,
    *,
    tol: float = BOUNDARY_TOL,
) -> Assumption4Report:
    r"""Check Assumption 4 of Grip, Saberi & Johansen item by item, with the rank conditions of Sec. 2.

    Parameters
    ----------
    A : array_like, shape (n_w, n_w)
    B_z : array_like, shape (n_w, p_z)
    C : array_like, shape (p_y, n_w)
    D_z : array_like, shape (p_y, p_z), optional
        Zero when omitted.
    tol : float
        Distance from the imaginary axis (and from the origin, for zeros) below
        which a mode or zero counts as on it.

    Returns
    -------
    Assumption4Report
        Items (required): ``rank_Bz_Dz`` — ``rank [B_z; D_z] = p_z``;
        ``rank_C_Dz`` — ``rank [C, D_z] = p_y``; ``detectable`` — ``(A, C)``
        detectable (PBH, unobservable modes listed); ``left_invertible`` —
        normal rank of ``[[sI − A, −B_z], [C, D_z]]`` equal to ``n_w + p_z``;
        ``no_zero_at_origin`` — no finite invariant zero with ``|z| ≤ tol``.
        Informational: ``minimum_phase`` (Theorem 2: ``γ* = 0``) and
        ``extended_detectable`` — ``(𝔄, ℭ)`` of (8c) detectable, which
        Assumption 4 implies (proof of Theorem 2).

    Raises
    ------
    DimensionError
        Inconsistent shapes.

    Examples
    --------
    The per-axis GNSS/INS model (Grip, Saberi & Johansen, Sec. 5): position measured, the
    acceleration ``z`` enters the velocity. A double integrator has no finite zero, so every item
    holds and ``γ* = 0`` (Theorem 2):

    >>> rep = check_assumption4([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> rep.holds, rep.gamma_star_zero, rep.zeros.size
    (True, True, 0)
    >>> [(it.key, it.passed) for it in rep.items if it.required]
    [('rank_Bz_Dz', True), ('rank_C_Dz', True), ('detectable', True), ('left_invertible', True),
     ('no_zero_at_origin', True)]

    With ``z`` entering the position instead, ``z`` no longer drives the velocity mode at ``s = 0``
    (``G(s) = 1/s``): an invariant zero at the origin, which Assumption 4 excludes:

    >>> bad = check_assumption4([[0, 1], [0, 0]], [[1], [0]], [[1, 0]])
    >>> bad.holds, [it.key for it in bad.failed]
    (False, ['no_zero_at_origin'])
    """
    A_ = as_square("A", A)
    n = A_.shape[0]
    Bz = as_matrix("B_z", B_z, (n, None))
    C_ = as_matrix("C", C, (None, n))
    pz, py = Bz.shape[1], C_.shape[0]
    Dz = np.zeros((py, pz)) if D_z is None else as_matrix("D_z", D_z, (py, pz))
    if pz == 0:
        raise DimensionError("B_z: Σ2 needs at least one input z (p_z ≥ 1)")
    if py == 0:
        raise DimensionError("C: Σ2 needs at least one measurement y (p_y ≥ 1)")
    items: list[Check] = [
        _rank_item("rank_Bz_Dz", "rank [B_z; D_z] = p_z (no redundant z)", np.vstack([Bz, Dz]), pz, "[B_z; D_z]"),
        _rank_item("rank_C_Dz", "rank [C, D_z] = p_y (independent y)", np.hstack([C_, Dz]), py, "[C, D_z]"),
    ]
    # detectability of (A, C)
    unobs = unobservable_modes(A_, C_)
    det = is_detectable(A_, C_, tol=tol)
    bad_modes = unobs[unobs.real >= -tol] if unobs.size else unobs
    ev = f"unobservable modes {_fmt_list(unobs)}"
    ev += "; all strictly stable" if det else f"; not strictly stable: {_fmt_list(bad_modes)}"
    items.append(_item("detectable", "(A, C) detectable", det, ev, True,
                       {"unobservable_modes": [[float(z.real), float(z.imag)] for z in unobs]}))
    # left-invertibility and zeros
    iz = invariant_zeros(A_, Bz, C_, Dz)
    want = n + pz
    li = iz.normal_rank == want
    items.append(_item(
        "left_invertible", "(A, B_z, C, D_z) left-invertible", li,
        f"normal rank of the Rosenbrock matrix = {iz.normal_rank} (n_w + p_z = {want})", True,
        {"normal_rank": iz.normal_rank, "required": want}, CheckKind.RANK,
    ))
    zeros = iz.zeros
    at0 = zeros[np.abs(zeros) <= tol] if zeros.size else zeros
    dist = float(np.min(np.abs(zeros))) if zeros.size else math.inf
    ok0 = at0.size == 0
    ev0 = f"finite invariant zeros {_fmt_list(zeros)}"
    ev0 += f"; closest to the origin at distance {dist:.3g}" if zeros.size else " (no finite zeros)"
    if not ok0:
        ev0 += f"; {at0.size} zero(s) at s = 0"
    items.append(_item("no_zero_at_origin", "no invariant zero at the origin", ok0, ev0, True,
                       {"zeros": [[float(z.real), float(z.imag)] for z in zeros], "min_abs_zero": dist}))
    # informational
    mp = minimum_phase(A_, Bz, C_, Dz, tol=tol)
    items.append(_item(
        "minimum_phase", "(A, B_z, C, D_z) minimum phase (Theorem 2: γ* = 0)", mp.passed, mp.evidence, False,
        {"unstable_zeros": [[float(z.real), float(z.imag)] for z in mp.values["unstable_zeros"]]},
    ))
    ext = extended_system(A_, Bz, C_, Dz)
    edet = is_detectable(ext.A, ext.C, tol=tol)
    eun = unobservable_modes(ext.A, ext.C)
    items.append(_item(
        "extended_detectable", "(𝔄, ℭ) of (8c) detectable (implied by Assumption 4)", edet,
        f"unobservable modes of the extended pair {_fmt_list(eun)}", False,
        {"unobservable_modes": [[float(z.real), float(z.imag)] for z in eun]},
    ))
    return Assumption4Report(tuple(items), n, pz, py, readonly(zeros, complex), int(iz.normal_rank))


@takes_system(time="continuous", A="A", B_z="B", C="C", D_z="D")
def require_assumption4(
    A: ArrayLike, B_z: ArrayLike, C: ArrayLike, D_z: ArrayLike | None = None, *, tol: float = BOUNDARY_TOL
) -> Assumption4Report:
    """Like :func:`check_assumption4`, but raise if a required item fails.

    Parameters
    ----------
    A : array_like, shape (n_w, n_w)
    B_z : array_like, shape (n_w, p_z)
    C : array_like, shape (p_y, n_w)
    D_z : array_like, shape (p_y, p_z), optional
        Zero when omitted.
    tol : float, default 1e-9
        Distance from the imaginary axis (and from the origin, for zeros) below
        which a mode or zero counts as on it.

    Returns
    -------
    Assumption4Report
        The report of :func:`check_assumption4`, when every required item holds.

    Raises
    ------
    AssumptionViolated
        Naming the first failed item (``.item``) with its evidence, e.g.
        ``"Assumption 4 fails: no invariant zero at the origin — finite invariant zeros [0] ..."``.

    Examples
    --------
    Measuring the position of a double integrator driven by ``z`` satisfies Assumption 4; measuring only
    the velocity leaves the position unobserved, an integrator, so ``(A, C)`` is not detectable:

    >>> require_assumption4([[0, 1], [0, 0]], [[0], [1]], [[1, 0]]).holds
    True
    >>> try:
    ...     require_assumption4([[0, 1], [0, 0]], [[0], [1]], [[0, 1]])
    ... except AssumptionViolated as exc:
    ...     print(type(exc).__name__, exc.item)
    ...     print(exc)
    AssumptionViolated detectable
    Assumption 4 (Grip–Saberi–Johansen) fails: (A, C) detectable [detectable] — unobservable modes [0]; ...
    """
    rep = check_assumption4(A, B_z, C, D_z, tol=tol)
    if not rep.holds:
        it = rep.failed[0]
        more = f" (also failing: {', '.join(f.key for f in rep.failed[1:])})" if len(rep.failed) > 1 else ""
        raise AssumptionViolated(
            f"Assumption 4 (Grip–Saberi–Johansen) fails: {it.name} [{it.key}] — {it.evidence}{more}",
            item=it.key,
            evidence=it.evidence,
        )
    return rep
