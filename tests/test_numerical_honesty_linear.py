"""Silently wrong results of the linear layer: badly scaled, huge or stiff data.

Each case is data on which a naive computation returns a wrong number (or verdict) without complaint;
each test compares with a closed form or an independent algorithm (SciPy's Lyapunov solver on a
hand-scaled realisation, python-control's ``linfnorm``).
"""

from __future__ import annotations

import math
import re

import control
import numpy as np
import pytest
import scipy.linalg
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.errors import DesignInfeasible, NumericalError
from nlobs.linear import analyze_linear
from nlobs.linear.norms import h2_norm
from nlobs.linear.observability import is_observable, unobservable_modes
from nlobs.linear.stability import eigenvalues
from nlobs.linear.zeros import invariant_zeros
from nlobs.synthesis.observer_gain import design_observer_gain
from nlobs.systems.linear import LinearSystem
from nlobs.workflows.analyze import analyze_model
from nlobs.workflows.inputs import BoxError

runner = CliRunner()


# --------------------------------------------------------------------------- 1. H2 norm, bad scaling


def test_h2_norm_of_a_badly_scaled_oscillator_matches_the_closed_form() -> None:
    # ẋ1 = 1e12 x2, ẋ2 = −1e−12 x1 − 1e−6 x2 + u, y = x1:  G(s) = 1e12 / (s² + 1e−6 s + 1).
    # For G = k/(s² + a s + 1) the controllability Gramian has P11 = 1/(2a), so ‖G‖₂ = k/√(2a).
    A = np.array([[0.0, 1e12], [-1e-12, -1e-6]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[1.0, 0.0]])
    exact = 1e12 / math.sqrt(2e-6)  # 7.0710678118654755e14
    # independent: SciPy's solver on the similar realisation T⁻¹AT, T = diag(1e12, 1)
    As, Bs, Cs = np.array([[0.0, 1.0], [-1.0, -1e-6]]), B, C * np.array([[1e12, 1.0]])
    P = scipy.linalg.solve_continuous_lyapunov(As, -(Bs @ Bs.T))
    assert math.sqrt(float(np.trace(Cs @ P @ Cs.T))) == pytest.approx(exact, rel=1e-9)
    # was 0.0 (a Gramian of the wrong sign, clipped)
    assert h2_norm(A, B, C, None) == pytest.approx(exact, rel=1e-9)
    # the observability-Gramian branch (m > p) and the transposed system give the same norm
    assert h2_norm(A, np.hstack([B, np.zeros((2, 1))]), C, None) == pytest.approx(exact, rel=1e-9)
    assert h2_norm(A.T, C.T, B.T, None) == pytest.approx(exact, rel=1e-9)


# --------------------------------------------------------------------------- 3. observability, bad scaling


@pytest.mark.parametrize("n, lo, hi", [(5, -6, 6), (7, -6, 6), (9, -8, 8)])
def test_badly_scaled_chain_is_observable(n: int, lo: int, hi: int) -> None:
    # ẋ_i = a_i x_{i+1}, y = x_1: the Kalman matrix is upper triangular with diagonal
    # (1, a_1, a_1 a_2, …), all nonzero, so the chain is observable for any nonzero a_i.
    a = np.logspace(lo, hi, n - 1)
    C = np.zeros((1, n))
    C[0, 0] = 1.0
    diag = np.cumprod(np.concatenate([[1.0], a]))
    assert np.all(diag != 0.0)
    for A in (np.diag(a, 1), np.diag(a[::-1], 1), np.diag(a, 1) - np.eye(n)):
        assert is_observable(A, C)  # was False, with n − 1 or n "unobservable modes"
        assert unobservable_modes(A, C).size == 0
    # a broken link (a_3 = 0) leaves x_4 … x_n unobservable: n − 3 modes at 0 (resp. −1)
    a0 = a.copy()
    a0[2] = 0.0
    A0 = np.diag(a0, 1) - np.eye(n)
    modes = unobservable_modes(A0, C)
    assert modes.size == n - 3
    assert np.allclose(modes, -1.0, atol=1e-6)


def test_output_scale_does_not_change_observability() -> None:
    # [[a, a], [−a, a]], C = [1, 0]: det [C; CA] = a ≠ 0 (observable), G(s) = a/((s − a)² + a²)
    # has no finite zero, so the Rosenbrock matrix has normal rank n + 1 = 3.
    a = 1e100
    A = np.array([[a, a], [-a, a]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[1.0, 0.0]])
    assert is_observable(A, C)  # was False (‖C‖ ≪ ‖A‖ swamped the rank decision)
    iz = invariant_zeros(A, B, C, np.zeros((1, 1)))
    assert iz.zeros.size == 0 and iz.normal_rank == 3  # were a (1 ± j), normal rank 2
    # python-control (SLICOT ab08nd) on A/a, whose zeros are those of A divided by a: none
    assert control.ss(A / a, B, C, 0).zeros().size == 0


# --------------------------------------------------------------------------- 4. huge entries, boxes


@pytest.mark.parametrize("a", [1e140, 1e200, 1e308, 1e-300])
def test_eigenvalues_of_huge_or_tiny_matrices(a: float) -> None:
    # eig [[a, a], [−a, a]] = a (1 ± j); LAPACK through SciPy returned 1.49e138 (1 ± j) for a ≥ 1e140
    lam = eigenvalues(np.array([[a, a], [-a, a]]))
    assert np.allclose(lam / a, [1 - 1j, 1 + 1j], rtol=1e-14, atol=0)


def test_analysis_refuses_entries_that_overflow(tmp_path) -> None:
    A = np.array([[1e308, 1e308], [-1e308, 1e308]])
    sys = LinearSystem(A, np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]]), name="big")
    with pytest.raises(NumericalError, match=r"^A: entries up to 1e\+308"):
        analyze_linear(sys)
    model = tmp_path / "big.toml"
    model.write_text('name = "big"\ntime = "continuous"\nstates = ["a", "b"]\ninputs = ["u"]\noutputs = ["y"]\n'
                     "[linear]\nA = [[1e308, 1e308], [-1e308, 1e308]]\nB = [[0.0], [1.0]]\nC = [[1.0, 0.0]]\n")
    res = runner.invoke(app, ["analyze", str(model), "--json"])
    assert res.exit_code == 2  # was 0 with poles 1.49e138 (1 ± j)
    assert res.stdout == ""
    line = res.stderr.strip()
    assert "\n" not in line and "A: entries up to 1e+308" in line
    with pytest.raises(NumericalError, match="^A: "):
        design_observer_gain(A, [[1.0, 0.0]], [[0.0], [1.0]], gamma=2.0, gain_bound=10.0)


def test_analyze_refuses_boxes_that_overflow() -> None:
    # the Liénard form of van der Pol with y = x1: dh = (1, 0), d L_f h = (0, 1), rank 2 = n
    assert analyze_model("vanderpol-lienard", box=[-2.0, 2.0]).to_dict()["observability_rank"] == 2
    # a bound beyond 1e100 is refused before anything is evaluated (the second hardening round)
    with pytest.raises(BoxError, match="larger than 1e\\+100"):
        analyze_model("vanderpol-lienard", box=[-1e308, 1e308])  # was rank 0
    with pytest.raises(BoxError, match="larger than 1e\\+100"):
        analyze_model("vanderpol-lienard", box=[-1e200, 1e200])  # was rank 0
    res = runner.invoke(app, ["analyze", "pendulum", "--box=-1e308,1e308"])
    assert res.exit_code == 2
    assert res.stderr.strip().startswith("nlobs: error: --box: ") and "\n" not in res.stderr.strip()


# --------------------------------------------------------------------------- 5. stiff design


def test_stiff_infeasible_gain_bound_quotes_a_bound_that_works() -> None:
    # eigenvalues 1e−3, −1, −1e4; ‖H‖∞ < γ = 1 needs a large gain. The diagnosis said "the smallest
    # feasible gain bound is above 1e9" although κ = 1e6 designs and verifies: its slack problems
    # failed in the solver at every κ and a failure was read as infeasibility.
    A = np.array([[1e-3, 1.0, 0.0], [0.0, -1.0, 1.0], [0.0, 0.0, -1e4]])
    C = np.array([[1.0, 0.0, 0.0]])
    Bd = np.array([[0.0], [0.0], [1e4]])
    gamma = 1.0
    with pytest.raises(DesignInfeasible) as info:
        design_observer_gain(A, C, Bd, gamma=gamma, gain_bound=1e3)
    msg = str(info.value)
    assert "above 1e9" not in msg
    found = re.search(r"smallest feasible gain bound with these constraints is ≈ ([0-9.]+e[+-][0-9]+|[0-9.]+[0-9])", msg)
    assert found is not None, msg
    kmin = float(found.group(1))
    assert info.value.violation == pytest.approx(kmin - 1e3, rel=1e-3)
    # the quoted bound (rounded up in its 4th digit) designs a verified gain, checked independently
    cert = design_observer_gain(A, C, Bd, gamma=gamma, gain_bound=kmin * 1.001)
    assert cert.verified
    K = np.asarray(cert.gain)
    assert np.linalg.norm(K, 2) <= kmin * 1.001
    peak = control.linfnorm(control.ss(A - K @ C, Bd, np.eye(3), np.zeros((3, 1))), tol=1e-10)[0]
    assert peak < gamma
