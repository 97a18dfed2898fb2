"""Small shared helpers for LMI synthesis with CVXPY.

* :func:`symmetrise` and :func:`bmat` build LMI blocks that work both on CVXPY
  expressions (inside a problem) and on NumPy arrays (for the independent
  re-verification of a certificate), so each LMI is written only once.
* :func:`solve` runs a problem with Clarabel (default) or SCS, catches solver
  failures and maps CVXPY's status strings to :class:`SolveStatus`.
* :func:`max_eig` is the largest eigenvalue of the symmetric part of a numeric
  block: an LMI ``F ≺ 0`` holds iff ``max_eig(F) < 0``.

CVXPY has no strict matrix inequalities, so every ``F ≺ 0`` is imposed as
``F ⪯ −ε I`` with an explicit margin ``ε > 0`` and re-checked afterwards.
"""

from __future__ import annotations

import sys
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from nlobs._lazy import LazyModule
from nlobs.errors import InvalidArgumentError

cp = LazyModule("cvxpy")  # imported by the first problem built (see nlobs._lazy)

__all__ = [
    "psd_sqrt",
    "Solver",
    "SolveStatus",
    "SolveResult",
    "symmetrise",
    "bmat",
    "is_expression",
    "max_eig",
    "solve",
    "as_solver",
    "MAX_LMI_SIZE",
    "lmi_problem_size",
    "require_lmi_size",
]


E = TypeVar("E", bound=Enum)

#: Largest LMI problem a design of nlobs builds, as the number of scalar decision variables plus the
#: entries ``k(k+1)/2`` of every semidefinite block of size ``k`` (:func:`lmi_problem_size`). The
#: interior-point solver's KKT system grows with the square of this size. Measured with Clarabel on a
#: shared 2-core, 24 GiB machine (load about 8, so wall ≫ CPU time): ``design_observer_gain`` on dense
#: data at ``n = 50`` (about 2·10⁴) took 272 s, at ``n = 100`` (about 8·10⁴) grew past 12 GB and was
#: killed; below the bound, size 7688 (drift SDP, ``n = 60``, one solve) 27 s CPU / 0.59 GB, 8714
#: (``design_setvalued``, ``n = 30``) 54 s CPU / 0.73 GB, 9802 (discrete Lipschitz, ``n = 40``) 123 s
#: CPU / 2.6 GB; just below it, one drift SDP solve at ``n = 100`` (20808, idle machine) 308 s CPU /
#: 3.2 GB, and the others (sizes 2.3–2.5·10⁴) were still running when stopped after 400–420 s wall, at
#: 2.2–7.7 GB (the discrete Lipschitz LMI at ``n = 64`` extrapolates to about 17 GB). Details:
#: ``docs/synthesis.md`` ("Problem size").
MAX_LMI_SIZE = 25_000


class Solver(str, Enum):
    """Conic solvers nlobs uses for LMIs (both ship as plain wheels).

    Examples
    --------
    A member or its name in any case (:func:`as_solver`); both solve the same problem, ``min x`` subject to
    ``x ≥ 1``:

    >>> import cvxpy as cp
    >>> [s.value for s in Solver], as_solver("clarabel") is Solver.CLARABEL, Solver("SCS") is Solver.SCS
    (['CLARABEL', 'SCS'], True, True)
    >>> x = cp.Variable()
    >>> [round(solve(cp.Problem(cp.Minimize(x), [x >= 1.0]), s).value, 4) for s in Solver]
    [1.0, 1.0]
    """

    CLARABEL = "CLARABEL"
    """Interior-point solver; accurate, supports the exponential cone (log-det). Default."""
    SCS = "SCS"
    """First-order splitting solver; less accurate (run with tightened tolerances)."""


class SolveStatus(Enum):
    """Outcome of a solver run, as reported by the solver (not yet verified).

    Examples
    --------
    :func:`solve` maps CVXPY's status string to a member; only an optimal status carries a solution:

    >>> import cvxpy as cp
    >>> x = cp.Variable()
    >>> for cons in ([x >= 1.0], [x >= 1.0, x <= 0.0], []):
    ...     st = solve(cp.Problem(cp.Minimize(x), cons)).status
    ...     print(st.value, st.has_solution, st.is_infeasible)
    optimal True False
    infeasible False True
    unbounded False False
    """

    OPTIMAL = "optimal"
    OPTIMAL_INACCURATE = "optimal_inaccurate"
    INFEASIBLE = "infeasible"
    INFEASIBLE_INACCURATE = "infeasible_inaccurate"
    UNBOUNDED = "unbounded"
    UNBOUNDED_INACCURATE = "unbounded_inaccurate"
    SOLVER_ERROR = "solver_error"

    @property
    def has_solution(self) -> bool:
        """Whether the solver returned primal values worth verifying."""
        return self in (SolveStatus.OPTIMAL, SolveStatus.OPTIMAL_INACCURATE)

    @property
    def is_infeasible(self) -> bool:
        """Whether the solver claims primal infeasibility (exactly or inaccurately)."""
        return self in (SolveStatus.INFEASIBLE, SolveStatus.INFEASIBLE_INACCURATE)


#: CVXPY's status strings are the values of :class:`SolveStatus` (``tests/test_lmi.py`` checks them).
_STATUS_MAP = {s.value: s for s in SolveStatus}

# SCS's defaults (eps 1e-4) are too loose for certificates: one "optimal" SCS
# answer on the Grip–Saberi–Johansen example had a non-Hurwitz closed loop. Tighter
# tolerances with an iteration cap (~1 s on small problems); SCS answers are
# re-verified like any other and often end "optimal_inaccurate" on log-det
# (exponential-cone) objectives.
_DEFAULT_OPTIONS: dict[Solver, dict[str, Any]] = {
    Solver.CLARABEL: {},
    Solver.SCS: {"eps_abs": 1e-7, "eps_rel": 1e-7, "max_iters": 20_000},
}


@dataclass(frozen=True)
class SolveResult:
    """What one solver run returned.

    Attributes
    ----------
    status : SolveStatus
        Mapped status.
    raw_status : str
        CVXPY's status string (or the solver error message).
    solver : Solver
        Which solver ran.
    value : float or None
        Optimal objective value, when there is one.
    seconds : float
        Wall-clock time of compile + solve.

    Examples
    --------
    The smallest ``trace P`` with ``AᵀP + PA ⪯ −I`` is attained at the solution of the Lyapunov equation
    ``AᵀP + PA = −I``, here ``P = [[1.25, 0.25], [0.25, 0.25]]`` (trace 1.5):

    >>> import cvxpy as cp
    >>> import numpy as np
    >>> A = np.array([[0.0, 1.0], [-2.0, -3.0]])
    >>> P = cp.Variable((2, 2), symmetric=True)
    >>> res = solve(cp.Problem(cp.Minimize(cp.trace(P)), [symmetrise(A.T @ P + P @ A) << -np.eye(2)]))
    >>> res.status, res.raw_status, res.solver, round(res.value, 4)
    (<SolveStatus.OPTIMAL: 'optimal'>, 'optimal', <Solver.CLARABEL: 'CLARABEL'>, 1.5)
    >>> np.round(P.value, 3).tolist(), max_eig(A.T @ P.value + P.value @ A) <= -1 + 1e-6
    ([[1.25, 0.25], [0.25, 0.25]], True)
    """

    status: SolveStatus
    raw_status: str
    solver: Solver
    value: float | None
    seconds: float


def as_enum(kind: str, cls: type[E], value: E | str) -> E:
    """Return ``value`` as a member of the string enum ``cls`` (case-insensitive), or raise naming ``kind``."""
    if isinstance(value, cls):
        return value
    if isinstance(value, str):
        for candidate in (value, value.upper(), value.lower()):
            try:
                return cls(candidate)
            except ValueError:
                pass
    known = ", ".join(str(m.value) for m in cls)
    raise InvalidArgumentError(f"{kind}: unknown {kind} {value!r}; expected one of {known}")


def as_solver(solver: Solver | str) -> Solver:
    """Return ``solver`` as a :class:`Solver` (accepts ``"clarabel"``, ``"SCS"``...).

    Parameters
    ----------
    solver : Solver or str
        A member or its name, in any case.

    Returns
    -------
    Solver

    Raises
    ------
    InvalidArgumentError
        ``solver`` names no known solver.
    """
    return as_enum("solver", Solver, solver)


def is_expression(x: object) -> bool:
    """Whether ``x`` is a CVXPY expression (as opposed to a numeric array).

    Parameters
    ----------
    x : object
        Any value.

    Returns
    -------
    bool
    """
    cvxpy = sys.modules.get("cvxpy")  # no CVXPY loaded, no CVXPY expression: a numeric check does not load it
    return cvxpy is not None and isinstance(x, cvxpy.Expression)


def symmetrise(M: Any) -> Any:
    """Return ``(M + Mᵀ)/2`` for a CVXPY expression or a NumPy array.

    Every LMI block is symmetrised explicitly before it enters a constraint:
    CVXPY's ``<<`` only constrains the symmetric part anyway, and making it
    explicit keeps the verified block identical to the constrained one.

    Parameters
    ----------
    M : cvxpy.Expression or ndarray
        A square matrix.

    Returns
    -------
    cvxpy.Expression or ndarray
        Of the same kind as ``M``.
    """
    return (M + M.T) / 2


def bmat(rows: Sequence[Sequence[Any]]) -> Any:
    """Assemble a block matrix from CVXPY expressions and/or NumPy arrays.

    Uses :func:`cvxpy.bmat` when any block is an expression, else
    :func:`numpy.block`.

    Parameters
    ----------
    rows : sequence of sequence
        Rows of blocks (CVXPY expressions, arrays or array_likes) with compatible shapes.

    Returns
    -------
    cvxpy.Expression or ndarray
        An expression when any block is one, else a float array.
    """
    if any(is_expression(b) for row in rows for b in row):
        return cp.bmat([list(row) for row in rows])
    return np.block([[np.asarray(b, dtype=float) for b in row] for row in rows])


def psd_sqrt(M: NDArray[np.float64]) -> NDArray[np.float64]:
    """The symmetric square root of a positive semidefinite matrix (its symmetric part; eigenvalues clipped at 0).

    Parameters
    ----------
    M : array_like, shape (k, k)
        A numeric square matrix.

    Returns
    -------
    ndarray, shape (k, k)
        ``S = Sᵀ ⪰ 0`` with ``S S = (M + Mᵀ)/2`` where that is positive semidefinite.
    """
    A = np.asarray(M, dtype=float)
    w, V = np.linalg.eigh((A + A.T) / 2)
    return (V * np.sqrt(np.clip(w, 0, None))) @ V.T


def max_eig(M: NDArray[np.float64]) -> float:
    """Largest eigenvalue of the symmetric part of a numeric matrix.

    Parameters
    ----------
    M : array_like, shape (k, k)
        A numeric square matrix.

    Returns
    -------
    float
        ``λ_max((M + Mᵀ)/2)``.
    """
    S = 0.5 * (np.asarray(M, dtype=float) + np.asarray(M, dtype=float).T)
    return float(np.linalg.eigvalsh(S)[-1])


def solve(problem: cp.Problem, solver: Solver | str = Solver.CLARABEL, options: Mapping[str, Any] | None = None) -> SolveResult:
    """Solve ``problem`` and map the outcome; never raises on solver failure.

    Parameters
    ----------
    problem : cvxpy.Problem
    solver : Solver or str
        :attr:`Solver.CLARABEL` (default) or :attr:`Solver.SCS`.
    options : mapping, optional
        Solver keyword options; override nlobs's defaults (SCS runs with
        ``eps_abs = eps_rel = 1e-7``, ``max_iters = 20000``).

    Returns
    -------
    SolveResult
        A solver exception becomes :attr:`SolveStatus.SOLVER_ERROR` with the
        message in ``raw_status``.
    """
    s = as_solver(solver)
    opts = dict(_DEFAULT_OPTIONS[s])
    if options:
        opts.update(options)
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            # "Solution may be inaccurate": reported through the status instead
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=s.value, **opts)
    except (cp.SolverError, ArithmeticError, ValueError) as exc:
        return SolveResult(SolveStatus.SOLVER_ERROR, f"solver error: {exc}", s, None, time.perf_counter() - t0)
    seconds = time.perf_counter() - t0
    raw = str(problem.status)
    status = _STATUS_MAP.get(raw, SolveStatus.SOLVER_ERROR)
    value = problem.value if status.has_solution else None
    val = float(value) if value is not None and np.isfinite(value) else None
    return SolveResult(status, raw, s, val, seconds)


def lmi_problem_size(n_variables: int, blocks: Sequence[int]) -> int:
    """The size :data:`MAX_LMI_SIZE` bounds: ``n_variables + Σ k(k+1)/2`` over the semidefinite blocks.

    Parameters
    ----------
    n_variables : int
        Scalar decision variables.
    blocks : sequence of int
        Sizes of the semidefinite blocks.

    Returns
    -------
    int
    """
    return int(n_variables) + sum(int(k) * (int(k) + 1) // 2 for k in blocks)


def require_lmi_size(what: str, dims: str, n_variables: int, blocks: Sequence[int], advice: str) -> None:
    """Refuse an LMI problem above :data:`MAX_LMI_SIZE` before CVXPY builds it (it would exhaust memory or run for hours).

    Parameters
    ----------
    what : str
        The problem, e.g. ``"LMI problem"`` or ``"drift-observability SDP"``.
    dims : str
        The dimensions it was counted from, e.g. ``"n = 100 states"``.
    n_variables : int
        Scalar decision variables.
    blocks : sequence of int
        Sizes of the semidefinite blocks.
    advice : str
        What to do instead (one sentence, no final period).

    Raises
    ------
    InvalidArgumentError
        Stating the variables, the block sizes, the size and the bound.
    """
    size = lmi_problem_size(n_variables, blocks)
    if size > MAX_LMI_SIZE:
        raise InvalidArgumentError(
            f"{what} too large: {dims} give {int(n_variables)} scalar variables and semidefinite blocks of sizes "
            f"{', '.join(str(int(k)) for k in blocks)} (size {size}); at most {MAX_LMI_SIZE} is solved: the "
            f"solver's memory grows with the square of the size; {advice}")
