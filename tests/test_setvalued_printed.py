"""Khajenejad & Yong Theorem 5.10 as printed: the SDP runs, and what it accepts is not a stable observer."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import DesignInfeasible
from nlobs.papers.khajenejad_yong import example_61, example_62
from nlobs.linear.transform_ui import ui_transform
from nlobs.papers.khajenejad_yong_printed import design_printed, exact_condition_a16


def _lipschitz_M(L: float, n: int) -> np.ndarray:
    return np.block([[-np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), L**2 * np.eye(n)]])


def test_printed_class_II_accepts_a_destabilising_gain() -> None:
    ex = example_61("II")
    A = ex.system.A
    M = np.block([[-np.eye(4), A], [A.T, -A.T @ A]])  # (21) with the paper's auxiliary matrix A = A
    d = design_printed(ex.system, M, alphas=[0.95], eps_grid=(0.05, 0.1), refine=0)
    print(f"\nprinted Thm 5.10, 6.1 class II: rho* = {d.rho:.4g}, L~ = {np.round(d.gain.ravel(), 4)}, "
          f"(A.16) min eig = {d.exact_min_eig:.3g}, spectral radius = {d.spectral_radius:.4g}")
    assert d.spectral_radius > 1.0  # the accepted gain destabilises the error dynamics (16)
    assert d.exact_min_eig < 0.0  # and violates the exact S-procedure condition (A.16) it was derived from
    assert d.verified is False and "NOT certified" in d.summary()
    tr = ui_transform(ex.system.G, ex.system.C, ex.system.H)
    Phi, Psi, C2 = tr.Phi, tr.Psi, tr.C2
    assert exact_condition_a16(M, Phi, Psi, C2, d.gain, d.P, d.kappa, d.alpha) == pytest.approx(d.exact_min_eig)


@pytest.mark.parametrize("case", ["6.1 I", "6.2 I"])
def test_printed_class_I_is_infeasible(case: str) -> None:
    if case == "6.1 I":
        s, M = example_61("I").system, _lipschitz_M(3.33 * 0.01, 4)
    else:
        s, M = example_62().system, _lipschitz_M(1.1171, 2)
    with pytest.raises(DesignInfeasible, match="as printed"):
        design_printed(s, M, alphas=[0.5, 0.9], eps_grid=(0.1, 1.0), refine=0)


@pytest.mark.slow
def test_alpha_line_search_is_no_worse_than_the_alpha_grid_and_solves_at_its_point() -> None:
    # A second algorithm: the α grid 0.05, …, 0.95 on the same problem. The line search (bisection +
    # golden section over α ∈ [0, 1], Theorem 5.4's range) must reach a ρ at least as small, with fewer
    # solves than the grid's 19 α values × 5 ε would cost, and its point must be feasible when re-solved alone.
    ex = example_61("II")
    A = ex.system.A
    M = np.block([[-np.eye(4), A], [A.T, -A.T @ A]])
    line = design_printed(ex.system, M, refine=0)
    grid = design_printed(ex.system, M, alphas=[0.05 * i for i in range(1, 20)], refine=0)
    assert 0.0 <= line.alpha <= 1.0
    assert line.rho <= grid.rho * (1 + 1e-6)
    assert line.solves < 19 * 5
    alone = design_printed(ex.system, M, alphas=[line.alpha], eps_grid=(line.eps1,), refine=0)
    assert alone.rho == pytest.approx(line.rho, rel=1e-5)
