"""One-call structural report of a :class:`~nlobs.systems.linear.LinearSystem`.

:func:`analyze_linear` gathers stability, observability/detectability,
invariant zeros (Rosenbrock system matrix), left invertibility, minimum phase,
strong detectability (seed paper, Khajenejad & Yong, Definition 2.1 /
Remark 2.2, reading ``(A, B, C, D)`` as ``(A, G, C, H)``) and the H∞/H2 norms
into a frozen :class:`LinearReport`, which serialises to JSON-ready data with
a stable set of keys (:meth:`LinearReport.to_dict`) and to plain text
(:meth:`LinearReport.summary`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nlobs._schema import BOOLEAN, INTEGER, NUMBER, STRING, Record, array, enum
from nlobs.errors import InvalidArgumentError
from nlobs.linear.norms import h2_norm, hinf_norm
from nlobs.linear.observability import unobservable_modes
from nlobs.linear.stability import eigenvalues, is_stable, require_magnitude, strictly_inside
from nlobs.linear.zeros import invariant_zeros, minimum_phase
from nlobs.systems.linear import LinearSystem, as_linear_system

__all__ = ["LinearReport", "analyze_linear", "REPORT_KEYS"]

REPORT_KEYS: tuple[str, ...] = (
    "name",
    "time",
    "dt",
    "n",
    "m",
    "p",
    "eigenvalues",
    "stable",
    "observable",
    "detectable",
    "left_invertible",
    "minimum_phase",
    "strongly_detectable",
    "invariant_zeros",
    "normal_rank",
    "hinf_norm",
    "h2_norm",
)
"""The top-level keys of :meth:`LinearReport.to_dict`, in order (a stable interface)."""


def _pairs(z: NDArray[np.complex128]) -> list[list[float]]:
    return [[float(v.real), float(v.imag)] for v in np.asarray(z, dtype=complex)]


def _fmt_c(v: complex) -> str:
    v = complex(v)
    if v.imag == 0.0:
        return f"{v.real:.6g}"
    sign = "+" if v.imag >= 0 else "-"
    return f"{v.real:.6g}{sign}{abs(v.imag):.6g}j"


def _fmt_list(z: NDArray[np.complex128]) -> str:
    return "none" if len(z) == 0 else ", ".join(_fmt_c(v) for v in z)


#: A complex number as ``[re, im]``.
_COMPLEX = array(NUMBER)

#: The JSON of a :class:`LinearReport` (``nlobs analyze`` of a linear model; ``linearization``).
LINEAR_REPORT_JSON = Record("LinearReport", {
    "name": STRING,
    "time": enum("continuous", "discrete"),
    "dt": NUMBER.about("the sampling period of a discrete model (null: continuous)"),
    "n": INTEGER.about("states"),
    "m": INTEGER.about("inputs"),
    "p": INTEGER.about("outputs"),
    "eigenvalues": array(_COMPLEX, "eigenvalues of A as [re, im]"),
    "stable": BOOLEAN,
    "observable": BOOLEAN.about("PBH test on (A, C)"),
    "detectable": BOOLEAN,
    "left_invertible": BOOLEAN.about("normal rank of the Rosenbrock matrix = n + m"),
    "minimum_phase": BOOLEAN,
    "strongly_detectable": BOOLEAN.about("Khajenejad & Yong Def. 2.1 with B, D as the unknown-input matrices"),
    "invariant_zeros": array(_COMPLEX, "finite invariant zeros of (A, B, C, D) as [re, im]"),
    "normal_rank": INTEGER,
    "hinf_norm": NUMBER.about("H-infinity norm of u -> y; null when unstable"),
    "h2_norm": NUMBER.about("H2 norm; null when unstable or infinite"),
}, description="Structural properties and norms of a linear system.")


@dataclass(frozen=True)
class LinearReport:
    """Structural properties of a linear system (see :func:`analyze_linear`).

    Attributes
    ----------
    name : str
    time : {"continuous", "discrete"}
    dt : float or None
        Sampling period (discrete time only).
    n, m, p : int
        Numbers of states, inputs, outputs.
    eigenvalues : ndarray of complex
        Eigenvalues of ``A`` (the poles), sorted.
    stable : bool
        ``A`` Hurwitz (continuous) or Schur (discrete).
    observable, detectable : bool
        Of the pair ``(A, C)``.
    unobservable_modes : ndarray of complex
    invariant_zeros : ndarray of complex
        Finite invariant zeros of ``R(s) = [[sI − A, −B], [C, D]]``.
    normal_rank : int
        Normal rank of ``R(s)``.
    left_invertible : bool
        ``normal_rank == n + m``.
    minimum_phase : bool
        Left invertible and every finite invariant zero strictly stable.
    minimum_phase_reason : str
    strongly_detectable : bool
        Strong detectability of ``(A, G, C, H) = (A, B, C, D)``, i.e. ``B``
        read as the unknown-input matrix (seed paper, Def. 2.1).
    hinf_norm : float or None
        ``None`` when the system is not stable.
    h2_norm : float or None
        ``None`` when unstable, or infinite (continuous time with ``D ≠ 0``).

    Examples
    --------
    Two stable modes of which the output sees only one: detectable, not observable, and the hidden
    mode ``−2`` shows as an invariant zero; ``G(s) = 1/(s + 1)`` has ``‖G‖∞ = 1`` and ``‖G‖₂ = 1/√2``:

    >>> from nlobs.systems.linear import LinearSystem
    >>> rep = analyze_linear(LinearSystem([[-1, 0], [0, -2]], [[1], [1]], [[1, 0]], name="two-modes"))
    >>> rep.stable, rep.observable, rep.detectable, rep.unobservable_modes.real.tolist()
    (True, False, True, [-2.0])
    >>> rep.invariant_zeros.real.round(9).tolist(), rep.left_invertible, rep.minimum_phase
    ([-2.0], True, True)
    >>> round(rep.hinf_norm, 9), round(rep.h2_norm, 9)
    (1.0, 0.707106781)
    >>> d = rep.to_dict()
    >>> tuple(d) == REPORT_KEYS, d["eigenvalues"]
    (True, [[-2.0, 0.0], [-1.0, 0.0]])
    """

    name: str
    time: str
    dt: float | None
    n: int
    m: int
    p: int
    eigenvalues: NDArray[np.complex128]
    stable: bool
    observable: bool
    detectable: bool
    unobservable_modes: NDArray[np.complex128]
    invariant_zeros: NDArray[np.complex128]
    normal_rank: int
    left_invertible: bool
    minimum_phase: bool
    strongly_detectable: bool
    hinf_norm: float | None
    h2_norm: float | None
    minimum_phase_reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable data with exactly the keys :data:`REPORT_KEYS`.

        Complex numbers are ``[re, im]`` pairs; booleans, ints and floats are
        plain Python types; a missing norm is ``None`` (JSON ``null``).
        """
        return LINEAR_REPORT_JSON.emit({
            "name": str(self.name),
            "time": str(self.time),
            "dt": None if self.dt is None else float(self.dt),
            "n": int(self.n),
            "m": int(self.m),
            "p": int(self.p),
            "eigenvalues": _pairs(self.eigenvalues),
            "stable": bool(self.stable),
            "observable": bool(self.observable),
            "detectable": bool(self.detectable),
            "left_invertible": bool(self.left_invertible),
            "minimum_phase": bool(self.minimum_phase),
            "strongly_detectable": bool(self.strongly_detectable),
            "invariant_zeros": _pairs(self.invariant_zeros),
            "normal_rank": int(self.normal_rank),
            "hinf_norm": None if self.hinf_norm is None else float(self.hinf_norm),
            "h2_norm": None if self.h2_norm is None else float(self.h2_norm),
        })

    def summary(self) -> str:
        """A short human-readable multi-line report (plain text)."""

        def yn(b: bool) -> str:
            return "yes" if b else "no"

        time = self.time if self.dt is None else f"{self.time} (dt={self.dt:g})"
        lines = [
            f"Linear system '{self.name}': {time}, n={self.n}, m={self.m}, p={self.p}",
            f"  poles:               {_fmt_list(self.eigenvalues)}",
            f"  stable:              {yn(self.stable)}",
            f"  observable:          {yn(self.observable)}",
            f"  detectable:          {yn(self.detectable)}"
            + ("" if self.observable else f" (unobservable modes: {_fmt_list(self.unobservable_modes)})"),
            f"  invariant zeros:     {_fmt_list(self.invariant_zeros)}",
            f"  normal rank:         {self.normal_rank} (n + m = {self.n + self.m})",
            f"  left invertible:     {yn(self.left_invertible)}",
            f"  minimum phase:       {yn(self.minimum_phase)}"
            + ("" if self.minimum_phase or not self.minimum_phase_reason else f" ({self.minimum_phase_reason})"),
            f"  strongly detectable: {yn(self.strongly_detectable)} (B read as unknown-input matrix)",
            f"  H-infinity norm:     {'n/a (unstable)' if self.hinf_norm is None else f'{self.hinf_norm:.6g}'}",
            f"  H2 norm:             {_h2_text(self)}",
        ]
        return "\n".join(lines)


def _h2_text(r: LinearReport) -> str:
    if r.h2_norm is not None:
        return f"{r.h2_norm:.6g}"
    return "n/a (unstable)" if not r.stable else "infinite (D != 0)"


def analyze_linear(sys: LinearSystem | Any) -> LinearReport:
    """Structural analysis of a linear system.

    Parameters
    ----------
    sys : LinearSystem or python-control StateSpace / TransferFunction
        The model; its time base selects continuous- or discrete-time tests.

    Returns
    -------
    LinearReport

    Raises
    ------
    InvalidArgumentError
        ``sys`` is not a :class:`~nlobs.systems.linear.LinearSystem`.
    NumericalError
        An entry of ``A, B, C`` or ``D`` exceeds
        :data:`~nlobs.linear.stability.MAGNITUDE_LIMIT` in magnitude (the analyses would
        overflow or return wrong numbers).

    Notes
    -----
    Uses :func:`~nlobs.linear.stability.is_stable`,
    :func:`~nlobs.linear.observability.unobservable_modes` (PBH per spectral cluster),
    :func:`~nlobs.linear.zeros.invariant_zeros` (Emami-Naeini & Van Dooren
    1982), :func:`~nlobs.linear.norms.hinf_norm` (Bruinsma & Steinbuch 1990)
    and :func:`~nlobs.linear.norms.h2_norm` (Gramians).

    Examples
    --------
    The shipped filter ``1/(s² + s + 1)`` of Grip, Saberi & Johansen's Example 1: poles
    ``−1/2 ± j√3/2``, ``‖G‖∞ = 2/√3`` (the peak at ``ω = 1/√2``) and ``‖G‖₂ = 1/√2``:

    >>> import nlobs
    >>> print(analyze_linear(nlobs.load_model("grip-example1-filter")).summary())
    Linear system 'grip-example1-filter': continuous, n=2, m=1, p=1
      poles:               -0.5-0.866025j, -0.5+0.866025j
      stable:              yes
      observable:          yes
      detectable:          yes
      invariant zeros:     none
      normal rank:         3 (n + m = 3)
      left invertible:     yes
      minimum phase:       yes
      strongly detectable: yes (B read as unknown-input matrix)
      H-infinity norm:     1.1547
      H2 norm:             0.707107

    The discrete double integrator (zero-order hold, ``dt = 0.1``) is unstable, and its sampling zero
    at ``z = −1`` makes it non-minimum phase:

    >>> rep = analyze_linear(nlobs.load_model("double-integrator-discrete"))
    >>> rep.time, rep.dt, rep.stable, rep.hinf_norm, rep.invariant_zeros.real.round(9).tolist()
    ('discrete', 0.1, False, None, [-1.0])
    >>> rep.minimum_phase_reason
    'invariant zero(s) with |z| >= 1: -1+0j'
    """
    sys = as_linear_system(sys)
    A, B, C, D = (np.asarray(M, dtype=float) for M in (sys.A, sys.B, sys.C, sys.D))
    for name, M in zip("ABCD", (A, B, C, D)):
        require_magnitude(name, M)
    disc = bool(sys.is_discrete)
    dt = float(sys.time.dt) if disc else None  # type: ignore[union-attr]
    eig = eigenvalues(A)
    stable = is_stable(A, discrete=disc)
    uo = unobservable_modes(A, C, discrete=disc)
    detectable = bool(np.all(strictly_inside(uo, discrete=disc)))
    iz = invariant_zeros(A, B, C, D)
    mp = minimum_phase(A, B, C, D, discrete=disc)
    hinf = hinf_norm(A, B, C, D, discrete=disc) if stable else math.inf
    h2 = h2_norm(A, B, C, D, discrete=disc) if stable else math.inf
    return LinearReport(
        name=sys.name,
        time="discrete" if disc else "continuous",
        dt=dt,
        n=sys.n,
        m=sys.m,
        p=sys.p,
        eigenvalues=eig,
        stable=stable,
        observable=uo.size == 0,
        detectable=detectable,
        unobservable_modes=uo,
        invariant_zeros=iz.zeros,
        normal_rank=iz.normal_rank,
        left_invertible=iz.left_invertible,
        minimum_phase=mp.passed,
        strongly_detectable=mp.passed,
        hinf_norm=hinf if math.isfinite(hinf) else None,
        h2_norm=h2 if math.isfinite(h2) else None,
        minimum_phase_reason=mp.evidence,
    )
