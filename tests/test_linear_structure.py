"""Stability and observability (nlobs.linear.stability / .observability).

Independent references:
* stability: the Lyapunov characterisation (A Hurwitz ⇔ the solution of
  AᵀP + PA = −I is positive definite; A Schur ⇔ AᵀPA − P = −I has P ≻ 0),
  solved with python-control's ``lyap``/``dlyap`` (SLICOT SB03MD);
* observability matrix: ``control.obsv``;
* observability / unobservable modes: systems *constructed* with a known
  unobservable block (Kalman decomposition in hidden coordinates), and the
  rank of ``control.obsv`` on well-conditioned (orthogonally transformed)
  draws. On badly conditioned draws the Kalman-matrix rank is known to be
  unreliable, which is why the library uses a staircase reduction instead.
"""

from __future__ import annotations

import math

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment

from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.linear import (
    eigenvalues,
    is_detectable,
    is_observable,
    is_stable,
    observability_matrix,
    spectral_abscissa,
    spectral_radius,
    stability_margin,
    unobservable_modes,
)

SETTINGS = settings(max_examples=50, deadline=None, derandomize=True)


def _same_multiset(a, b, tol: float = 1e-7) -> bool:
    a, b = np.asarray(a, complex), np.asarray(b, complex)
    if a.shape != b.shape:
        return False
    if a.size == 0:
        return True
    cost = np.abs(a[:, None] - b[None, :])
    r, c = linear_sum_assignment(cost)
    return bool(np.all(cost[r, c] <= tol * (1 + np.abs(a[r]))))


# ---------------------------------------------------------------- stability


@pytest.mark.parametrize("discrete", [False, True])
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_stability_agrees_with_lyapunov(discrete: bool, seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 7))
    A = rng.normal(size=(n, n))
    # keep the worst eigenvalue at a clear distance from the boundary
    if discrete:
        A *= rng.choice([rng.uniform(0.3, 0.95), rng.uniform(1.05, 2.0)]) / max(abs(np.linalg.eigvals(A)))
    else:
        A -= (max(np.linalg.eigvals(A).real) + rng.choice([-1, 1]) * rng.uniform(0.05, 1.0)) * np.eye(n)
    stable = is_stable(A, discrete=discrete)
    if stable:
        P = control.dlyap(A.T, np.eye(n)) if discrete else control.lyap(A.T, np.eye(n))
        assert np.min(np.linalg.eigvalsh(0.5 * (P + P.T))) > 0
    else:
        # an unstable eigenvector v gives a growing/nondecaying mode: check
        # with the matrix exponential / powers (no eigen-solver involved)
        if discrete:
            growth = np.linalg.norm(np.linalg.matrix_power(A, 60), 2)
        else:
            growth = np.linalg.norm(_expm(A * 60.0), 2)
        assert growth > 1.0
    assert stable == (stability_margin(A, discrete=discrete) > 0)


def _expm(M):
    import scipy.linalg

    return scipy.linalg.expm(M)


def test_stability_hand_cases() -> None:
    A = [[0.0, 1.0], [-2.0, -3.0]]  # eigenvalues -1, -2
    np.testing.assert_allclose(eigenvalues(A), [-2.0, -1.0])
    assert is_stable(A)
    assert spectral_abscissa(A) == pytest.approx(-1.0)
    assert spectral_radius(A) == pytest.approx(2.0)
    assert stability_margin(A) == pytest.approx(1.0)
    assert is_stable(A, tol=0.5) and not is_stable(A, tol=1.5)
    assert not is_stable(A, discrete=True)
    assert stability_margin([[0.5, 0.0], [0.0, -0.8]], discrete=True) == pytest.approx(0.2)
    # marginal cases are not strictly stable
    assert not is_stable([[0.0, 1.0], [-1.0, 0.0]])
    assert not is_stable([[1.0]], discrete=True)
    assert not is_stable([[-1.0]], discrete=True)
    # n = 0
    assert eigenvalues(np.zeros((0, 0))).shape == (0,)
    assert is_stable(np.zeros((0, 0)))


# ------------------------------------------------------------ observability


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_observability_matrix_matches_control(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, p = int(rng.integers(1, 7)), int(rng.integers(1, 4))
    A, C = rng.normal(size=(n, n)), rng.normal(size=(p, n))
    np.testing.assert_allclose(observability_matrix(A, C), control.obsv(A, C), rtol=1e-12, atol=1e-12)


def _kalman_form(rng, n: int, p: int, nu: int, *, orthogonal: bool, auo=None):
    """(A, C, eig(A_uo)) with a known unobservable block of size nu, hidden by a change of basis."""
    no = n - nu
    Auo = rng.normal(size=(nu, nu)) if auo is None else np.asarray(auo, float)
    A = np.block([[Auo, rng.normal(size=(nu, no))], [np.zeros((no, nu)), rng.normal(size=(no, no))]])
    C = np.hstack([np.zeros((p, nu)), rng.normal(size=(p, no))])
    T = np.linalg.qr(rng.normal(size=(n, n)))[0] if orthogonal else rng.normal(size=(n, n)) + 2 * np.eye(n)
    Ti = np.linalg.inv(T)
    return Ti @ A @ T, C @ T, np.linalg.eigvals(Auo) if nu else np.zeros(0)


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_unobservable_modes_of_constructed_systems(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 7))
    p = int(rng.integers(1, 4))
    nu = int(rng.integers(0, n + 1))
    A, C, expected = _kalman_form(rng, n, p, nu, orthogonal=seed % 2 == 0)
    got = unobservable_modes(A, C)
    assert _same_multiset(got, expected, tol=1e-6), (got, expected)
    assert is_observable(A, C) == (nu == 0)
    stable_uo = bool(np.all(expected.real < 0))
    assert is_detectable(A, C) == stable_uo
    # PBH check of every reported mode, independent of the staircase
    for lam in got:
        sv = np.linalg.svd(np.vstack([lam * np.eye(n) - A, C]), compute_uv=False)
        assert sv[-1] <= 1e-7 * max(1.0, sv[0])


@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_is_observable_matches_kalman_rank_when_well_conditioned(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, p = int(rng.integers(1, 6)), int(rng.integers(1, 3))
    nu = int(rng.integers(0, n + 1)) if seed % 2 else 0
    A, C, _ = _kalman_form(rng, n, p, nu, orthogonal=True)
    A /= max(1.0, np.linalg.norm(A, 2))  # keep ‖Aᵏ‖ moderate so the Kalman rank is reliable
    O = control.obsv(A, C)
    assert is_observable(A, C) == (np.linalg.matrix_rank(O, tol=1e-9 * np.linalg.norm(O, 2)) == n)


def test_detectable_but_not_observable() -> None:
    # x2 is decoupled from y and decays: detectable, not observable
    A = [[-1.0, 0.0], [0.0, -3.0]]
    C = [[1.0, 0.0]]
    np.testing.assert_allclose(unobservable_modes(A, C), [-3.0])
    assert not is_observable(A, C)
    assert is_detectable(A, C)
    # same structure, unstable hidden mode
    A = [[-1.0, 0.0], [1.0, 2.0]]  # x1 drives x2, y = x1: x2 unobservable, eigenvalue 2
    np.testing.assert_allclose(unobservable_modes(A, C), [2.0])
    assert not is_detectable(A, C)
    # discrete: hidden mode 0.5 is stable, 1.5 is not
    assert is_detectable([[0.9, 0.0], [0.0, 0.5]], C, discrete=True)
    assert not is_detectable([[0.9, 0.0], [0.0, 1.5]], C, discrete=True)
    assert not is_detectable([[0.9, 0.0], [0.0, 0.5]], C)  # 0.5 > 0 in continuous time


def test_observable_oscillator_and_double_integrator() -> None:
    assert is_observable([[0.0, 1.0], [-1.0, -1.0]], [[1.0, 0.0]])
    assert is_observable([[0.0, 1.0], [0.0, 0.0]], [[1.0, 0.0]])  # position observes velocity
    assert not is_observable([[0.0, 1.0], [0.0, 0.0]], [[0.0, 1.0]])  # velocity does not give position
    np.testing.assert_allclose(unobservable_modes([[0.0, 1.0], [0.0, 0.0]], [[0.0, 1.0]]), [0.0], atol=1e-12)
    # repeated eigenvalue with two independent modes needs two outputs (PBH)
    assert not is_observable(-np.eye(2), [[1.0, 1.0]])
    assert is_observable(-np.eye(2), np.eye(2))


def test_multiplicities_of_unobservable_modes() -> None:
    # Jordan block at −1 hidden from y = x3: both copies are unobservable,
    # although rank [λI − A; C] drops by one only (geometric multiplicity 1)
    A = [[-1.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -2.0]]
    np.testing.assert_allclose(unobservable_modes(A, [[0.0, 0.0, 1.0]]), [-1.0, -1.0], atol=1e-7)
    # y = x1 + x3 sees the end of the chain (x2 drives x1) and x3: observable
    assert is_observable(A, [[1.0, 0.0, 1.0]])
    np.testing.assert_allclose(unobservable_modes(A, [[1.0, 0.0, 0.0]]), [-2.0])
    # y = x2 + x3 misses x1 (nothing depends on it): one copy of −1 is hidden
    np.testing.assert_allclose(unobservable_modes(A, [[0.0, 1.0, 1.0]]), [-1.0], atol=1e-10)
    # −I₂ with one output: exactly one copy of −1 is unobservable
    np.testing.assert_allclose(unobservable_modes(-np.eye(2), [[1.0, 1.0]]), [-1.0])


def test_weakly_observable_large_system() -> None:
    # n = 40, p = 2: the observable part needs 15 steps of a staircase and is
    # within ~1e-8 of unobservability; the 10 hidden modes are still found
    # exactly (a whole-space recursion loses them, and so does the Kalman rank).
    rng = np.random.default_rng(3)
    n, p, nu = 40, 2, 10
    A, C, expected = _kalman_form(rng, n, p, nu, orthogonal=True)
    A = A / np.sqrt(n)
    expected = expected / np.sqrt(n)
    assert _same_multiset(unobservable_modes(A, C), expected, tol=1e-9)
    assert not is_observable(A, C)


def test_edge_dimensions() -> None:
    A = [[-1.0, 0.0], [0.0, 2.0]]
    C0 = np.zeros((0, 2))
    np.testing.assert_allclose(unobservable_modes(A, C0), [-1.0, 2.0])
    assert not is_observable(A, C0) and not is_detectable(A, C0)
    assert is_observable(np.zeros((0, 0)), np.zeros((1, 0)))
    assert observability_matrix(A, C0).shape == (0, 2)
    assert observability_matrix(A, [[1.0, 0.0]]).shape == (2, 2)


def test_bad_input() -> None:
    with pytest.raises(DimensionError, match="A: expected a square matrix"):
        is_stable([[1.0, 2.0]])
    with pytest.raises(DimensionError, match="2-d"):
        eigenvalues([1.0, 2.0])
    with pytest.raises(NonFiniteError, match="A: entry"):
        spectral_radius([[math.nan]])
    with pytest.raises(DimensionError, match=r"C: expected shape \(\?, 2\)"):
        is_observable(np.eye(2), [[1.0, 0.0, 0.0]])
    with pytest.raises(NonFiniteError, match="C: entry"):
        unobservable_modes(np.eye(2), [[1.0, math.inf]])
    with pytest.raises(DimensionError, match="A: expected a square matrix"):
        is_detectable(np.ones((2, 3)), np.ones((1, 3)))
    with pytest.raises(NonFiniteError, match="tol"):
        is_stable([[1.0]], tol=math.nan)
    with pytest.raises(InvalidArgumentError, match="rtol"):
        is_observable(np.eye(2), np.eye(2), rtol=-1.0)
