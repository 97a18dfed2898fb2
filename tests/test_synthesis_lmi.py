"""Shared LMI helpers: block assembly, symmetrisation, solver wrapper and status mapping."""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError
from nlobs.synthesis.lmi import Solver, SolveStatus, as_solver, bmat, max_eig, solve, symmetrise


def test_bmat_and_symmetrise_numeric_and_cvxpy_agree():
    rng = np.random.default_rng(1)
    A, B = rng.normal(size=(2, 2)), rng.normal(size=(2, 1))
    num = symmetrise(bmat([[A, B], [B.T, -np.eye(1)]]))
    np.testing.assert_array_equal(num, num.T)
    P = cp.Variable((2, 2), symmetric=True)
    expr = symmetrise(bmat([[P @ A, B], [B.T, -np.eye(1)]]))
    P.value = np.eye(2)
    np.testing.assert_allclose(expr.value, num)
    # max_eig uses the symmetric part only
    M = np.array([[0.0, 2.0], [0.0, 0.0]])
    assert max_eig(M) == pytest.approx(1.0)


def test_solve_maps_statuses():
    x = cp.Variable()
    ok = solve(cp.Problem(cp.Minimize(x), [x >= 1]))
    assert ok.status is SolveStatus.OPTIMAL and ok.status.has_solution
    assert ok.value == pytest.approx(1.0) and ok.solver is Solver.CLARABEL and ok.seconds >= 0
    bad = solve(cp.Problem(cp.Minimize(x), [x >= 1, x <= 0]), "scs")
    assert bad.status.is_infeasible and bad.solver is Solver.SCS and bad.value is None
    unb = solve(cp.Problem(cp.Minimize(x), [x <= 0]))
    assert unb.status in (SolveStatus.UNBOUNDED, SolveStatus.UNBOUNDED_INACCURATE)


def test_as_solver():
    assert as_solver("clarabel") is Solver.CLARABEL
    with pytest.raises(InvalidArgumentError, match="solver: unknown"):
        as_solver("cvxopt-ish")


def test_solve_status_values_are_cvxpys_status_strings() -> None:
    """The solver's raw status maps onto :class:`SolveStatus` by value; CVXPY's constants must be those values."""
    import cvxpy as cp

    from nlobs.synthesis.lmi import SolveStatus

    for name in ("OPTIMAL", "OPTIMAL_INACCURATE", "INFEASIBLE", "INFEASIBLE_INACCURATE", "UNBOUNDED",
                 "UNBOUNDED_INACCURATE"):
        assert SolveStatus[name].value == getattr(cp, name)


def test_a_numeric_certificate_check_does_not_load_cvxpy() -> None:
    """Re-verifying a gain (what a Dask worker does before its first chunk) is numeric: CVXPY stays unloaded."""
    import subprocess
    import sys

    code = ("import sys, numpy as np\n"
            "from nlobs.synthesis.lmi import bmat, is_expression\n"
            "M = bmat([[np.eye(2), np.zeros((2, 1))], [np.zeros((1, 2)), np.eye(1)]])\n"
            "assert M.shape == (3, 3) and not is_expression(M)\n"
            "print('cvxpy' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
