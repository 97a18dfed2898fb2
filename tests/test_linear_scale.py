"""The fast paths of linear analysis at scale agree with the reference algorithms and with SLICOT.

* observability: the default (``method="auto"``: a one-output staircase whose verdict
  "observable" is taken only when it is well conditioned, else the batched PBH test) against the
  per-cluster PBH reference
  (``method="pbh"``) and against systems built with a known unobservable part (a Kalman
  decomposition hidden by a similarity, so the expected unobservable eigenvalues are known
  exactly): random, badly scaled (``diag(10^k)``, ``|k| ≤ 6``), clustered, repeated and
  defective eigenvalues, shared between the observable and the unobservable part;
* H∞: nlobs's own iteration (``method="bruinsma-steinbuch"``) against ``slycot.ab13dd`` to
  ``1e−9`` relative, against the reference pencil iteration, against a dense frequency grid
  (a lower bound), and the slycot fast path against nlobs's own.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError
from nlobs.linear import hinf_norm, is_detectable, is_observable, unobservable_modes
from nlobs.linear import norms as norms_mod
from nlobs.linear import observability as obs_mod

slycot = pytest.importorskip("slycot")


def _same_multiset(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    a, b = np.sort_complex(np.asarray(a, complex)), np.sort_complex(np.asarray(b, complex))
    if a.size != b.size:
        return False
    if a.size == 0:
        return True
    from scipy.optimize import linear_sum_assignment

    cost = np.abs(a[:, None] - b[None, :])
    r, c = linear_sum_assignment(cost)
    return bool(np.max(cost[r, c]) <= tol * max(1.0, float(np.max(np.abs(b)))))


def _hidden(rng, n: int, p: int, Auo: np.ndarray, *, similarity: str = "orthogonal", ao_eigs=None):
    """``(T⁻¹ [[Ao, 0], [A21, Auo]] T, [Co, 0] T)``: the unobservable modes are exactly ``eig(Auo)``."""
    nu = Auo.shape[0]
    no = n - nu
    if ao_eigs is None:
        Ao = rng.normal(size=(no, no)) / math.sqrt(max(no, 1))
    else:  # observable part with prescribed (possibly shared) eigenvalues: a companion-like chain
        Ao = np.diag(np.asarray(ao_eigs, float)) + np.diag(np.ones(no - 1), 1)
    A = np.zeros((n, n))
    A[:no, :no] = Ao
    A[no:, :no] = rng.normal(size=(nu, no))
    A[no:, no:] = Auo
    C = np.zeros((p, n))
    C[:, :no] = rng.normal(size=(p, no))
    if ao_eigs is not None:
        C[0, :no] = 0.0
        C[0, 0] = 1.0  # the chain is observable from its first state
    if similarity == "general":
        T = rng.normal(size=(n, n)) + 3.0 * np.eye(n)
        return np.linalg.solve(T, A @ T), C @ T
    Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
    A, C = Q.T @ A @ Q, C @ Q
    if similarity == "scaled":  # then diag(10^k), |k| ≤ 6, entrywise (no inverse of an ill-conditioned T)
        d = 10.0 ** rng.uniform(-6.0, 6.0, size=n)
        A, C = A * d[None, :] / d[:, None], C * d[None, :]
    return A, C


def _random(n: int, p: int, seed: int):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n, n)) / math.sqrt(n), rng.normal(size=(p, n))


# --------------------------------------------------------------------------- observability


@pytest.mark.slow
@pytest.mark.parametrize("n, p", [(3, 1), (8, 2), (30, 1), (60, 3), (120, 2)])
def test_random_pairs_auto_agrees_with_pbh(n: int, p: int) -> None:
    A, C = _random(n, p, seed=n * 10 + p)
    auto = unobservable_modes(A, C)
    assert auto.size == 0 and unobservable_modes(A, C, method="pbh").size == 0
    assert is_observable(A, C) and is_observable(A, C, method="pbh")


@pytest.mark.parametrize("similarity", ["orthogonal", "general", "scaled"])
@pytest.mark.parametrize("n, p, nu", [(6, 1, 2), (20, 2, 5), (40, 2, 10), (80, 3, 30)])
def test_hidden_modes_are_found_exactly(n: int, p: int, nu: int, similarity: str) -> None:
    rng = np.random.default_rng(n + 7 * nu + len(similarity))
    Auo = rng.normal(size=(nu, nu)) / math.sqrt(nu) - 0.5 * np.eye(nu)
    expected = np.linalg.eigvals(Auo)
    A, C = _hidden(rng, n, p, Auo, similarity=similarity)
    tol = 1e-9 if similarity == "orthogonal" else 1e-6
    got = unobservable_modes(A, C)
    assert _same_multiset(got, expected, tol), (got, expected)
    if n <= 40:
        assert _same_multiset(got, unobservable_modes(A, C, method="pbh"), tol)
    assert not is_observable(A, C)
    assert is_detectable(A, C) == bool(np.all(expected.real < 0))


def test_minus_identity_hides_exactly_n_minus_p_modes() -> None:
    # −I with p < n outputs: exactly n − p copies of −1 are hidden (PBH, geometric multiplicity)
    n, p = 12, 3
    A, C = -np.eye(n), np.random.default_rng(1).normal(size=(p, n))
    np.testing.assert_allclose(unobservable_modes(A, C), -np.ones(n - p), atol=1e-10)
    np.testing.assert_allclose(unobservable_modes(A, C, method="pbh"), -np.ones(n - p), atol=1e-10)


def test_clustered_observable_modes() -> None:
    # eigenvalues 1e−7 apart (one cluster), all observable through one output
    n = 30
    rng = np.random.default_rng(11)
    Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
    lam = -1.0 + 1e-7 * np.arange(n)
    A = Q @ (np.diag(lam) + np.diag(np.ones(n - 1), 1)) @ Q.T
    C = np.zeros((1, n))
    C[0, 0] = 1.0
    C = C @ Q.T
    assert is_observable(A, C)
    assert is_observable(A, C, method="pbh")


def test_badly_scaled_observable_chain_through_the_fast_path() -> None:
    n = 9
    a = np.logspace(-8, 8, n - 1)
    A = np.diag(a, 1) - np.eye(n)
    C = np.zeros((1, n))
    C[0, 0] = 1.0
    assert is_observable(A, C) and unobservable_modes(A, C).size == 0


def test_generic_pairs_need_no_schur_form_per_cluster(monkeypatch) -> None:
    # the batched test decides a generic pair (isolated eigenvalues) without the O(n⁴) loop
    def boom(*_a, **_k):
        raise AssertionError("per-cluster Schur form used")

    monkeypatch.setattr(obs_mod, "_cluster_modes", boom)
    for n, p in [(10, 1), (50, 2), (150, 3)]:
        A, C = _random(n, p, seed=n)
        assert is_observable(A, C)
    with pytest.raises(AssertionError, match="per-cluster"):
        is_observable(*_random(10, 1, seed=10), method="pbh")


def test_generic_pairs_are_decided_by_the_staircase(monkeypatch) -> None:
    # a random pair is observable through one output combination with well-conditioned steps:
    # two Hessenberg reductions decide it, no eigenvalue is computed
    def boom(*_a, **_k):
        raise AssertionError("eigenvalue-based test used")

    monkeypatch.setattr(obs_mod, "_batched_pbh", boom)
    for n, p in [(5, 2), (50, 2), (150, 3)]:
        A, C = _random(n, p, seed=n + 1)
        assert is_observable(A, C) and unobservable_modes(A, C).size == 0


def _weak_chain(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A bidiagonal chain observed at its head: every staircase step is 0.3, yet the eigenvector of the
    last eigenvalue decays along the chain (``‖C v‖ ≈ ∏ 0.3/|λₙ − λₖ|``)."""
    A = np.diag(np.linspace(-1.0, 1.0, n)) + 0.3 * np.diag(np.ones(n - 1), 1)
    C = np.zeros((1, n))
    C[0, 0] = 1.0
    return A, C


@pytest.mark.parametrize("n", [10, 20, 40])
def test_large_but_ill_conditioned_steps_are_not_trusted(n: int) -> None:
    # n = 40: within 1e−10 of unobservable (PBH), though no step is below 0.06 ‖[A; C]‖: the
    # staircase alone would call it observable; its condition estimate hands it to PBH
    A, C = _weak_chain(n)
    As, Cs, _, tol, scale = obs_mod._prepare(A, C, obs_mod.DEFAULT_RTOL, fast=True)
    rtol = tol / scale
    steps = obs_mod._steps(obs_mod._staircase_matrix(As, Cs))
    assert float(np.min(steps)) > 0.05 * scale
    ref = is_observable(A, C, method="pbh")
    assert ref == (n < 40)
    assert is_observable(A, C) == ref
    if n >= 20:
        assert not obs_mod._observable_by_staircase(As, Cs, rtol)


@pytest.mark.parametrize("p, no, nu", [(2, 30, 10), (1, 60, 5), (3, 100, 20), (1, 120, 1)])
def test_hidden_modes_behind_long_chains_are_not_called_observable(p: int, no: int, nu: int) -> None:
    # the computed steps of an exactly unobservable pair are amplified rounding (up to 1e−2 of the
    # data's norm measured): the condition estimate must refuse every one of them
    rng = np.random.default_rng(no + nu + p)
    Auo = rng.normal(size=(nu, nu)) / math.sqrt(nu)
    A, C = _hidden(rng, no + nu, p, Auo)
    As, Cs, _, tol, scale = obs_mod._prepare(A, C, obs_mod.DEFAULT_RTOL, fast=True)
    rtol = tol / scale
    assert not obs_mod._observable_by_staircase(As, Cs, rtol)
    assert not is_observable(A, C)
    assert _same_multiset(unobservable_modes(A, C), np.linalg.eigvals(Auo), 1e-8)


def test_staircase_verdict_is_reproducible() -> None:
    # the condition estimate's perturbation is seeded: the same pair gets the same answer every time
    A, C = _random(40, 2, seed=3)
    As, Cs, _, tol, scale = obs_mod._prepare(A, C, obs_mod.DEFAULT_RTOL, fast=True)
    rtol = tol / scale
    assert len({obs_mod._observable_by_staircase(As, Cs, rtol) for _ in range(5)}) == 1


def test_staircase_against_slycot_on_hidden_parts() -> None:
    rng = np.random.default_rng(8)
    Auo = rng.normal(size=(6, 6)) / 3.0
    A, C = _hidden(rng, 30, 2, Auo)
    n, p = A.shape[0], C.shape[0]
    Ac, _, ncont, *_ = slycot.ab01nd(n, p, A.T.copy(), C.T.copy())
    assert n - ncont == 6
    assert _same_multiset(unobservable_modes(A, C), np.linalg.eigvals(Ac[ncont:, ncont:]), 1e-8)


def test_method_is_validated() -> None:
    with pytest.raises(InvalidArgumentError, match="method"):
        is_observable([[-1.0]], [[1.0]], method="staircase")
    with pytest.raises(InvalidArgumentError, match="method"):
        hinf_norm([[-1.0]], [[1.0]], [[1.0]], [[0.0]], method="fast")


# --------------------------------------------------------------------------- H∞


def _stable(n: int, m: int, p: int, seed: int, *, discrete: bool = False, feedthrough: bool = False):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n)) / math.sqrt(n)
    if discrete:
        A *= rng.uniform(0.3, 0.95) / max(abs(np.linalg.eigvals(A)))
    else:
        A -= (max(np.linalg.eigvals(A).real) + rng.uniform(0.05, 0.5)) * np.eye(n)
    D = rng.normal(size=(p, m)) if feedthrough else np.zeros((p, m))
    return A, rng.normal(size=(n, m)), rng.normal(size=(p, n)), D


def _ab13dd(A, B, C, D, discrete: bool) -> float:
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    g, _ = slycot.ab13dd("D" if discrete else "C", "I", "S", "D", n, m, p, A, np.eye(n), B, C, D, tol=1e-12)
    return float(g)


def _grid_lower_bound(A, B, C, D, discrete: bool) -> float:
    n = A.shape[0]
    if discrete:
        pts = np.exp(1j * np.linspace(0.0, np.pi, 1500))
    else:
        lam = np.abs(np.linalg.eigvals(A))
        pts = 1j * np.concatenate([[0.0], np.logspace(-3, 3, 1500) * max(lam.max(), 1e-3)])
    return max(float(np.linalg.norm(C @ np.linalg.solve(s * np.eye(n) - A, B) + D, 2)) for s in pts)


@pytest.mark.parametrize("discrete", [False, True])
@pytest.mark.parametrize("n, m, p, seed", [(3, 1, 1, 1), (12, 2, 3, 2), (40, 2, 2, 3), (90, 3, 2, 4)])
def test_hinf_own_iteration_matches_ab13dd(n: int, m: int, p: int, seed: int, discrete: bool) -> None:
    A, B, C, D = _stable(n, m, p, seed, discrete=discrete, feedthrough=seed % 2 == 0)
    ours = hinf_norm(A, B, C, D, discrete=discrete, method="bruinsma-steinbuch")
    ref = _ab13dd(A, B, C, D, discrete)
    assert ours == pytest.approx(ref, rel=1e-9)
    assert ours >= _grid_lower_bound(A, B, C, D, discrete) * (1 - 2e-9)
    assert hinf_norm(A, B, C, D, discrete=discrete, method="slycot") == pytest.approx(ours, rel=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_hinf_fast_iteration_matches_the_reference_pencil_iteration(seed: int) -> None:
    A, B, C, D = _stable(int(4 + 5 * seed), 2, 2, 100 + seed, feedthrough=seed % 2 == 1)
    fast = norms_mod._hinf_continuous(A, B, C, D, 1e-9)
    ref = norms_mod._hinf_continuous_pencil(A, B, C, D, 1e-9)
    assert fast == pytest.approx(ref, rel=2e-9)


@pytest.mark.parametrize("discrete", [False, True])
@pytest.mark.parametrize("seed", range(4))
def test_hinf_badly_scaled_realisations(seed: int, discrete: bool) -> None:
    A, B, C, D = _stable(15, 2, 2, 200 + seed, discrete=discrete, feedthrough=seed % 2 == 0)
    t = 10.0 ** np.random.default_rng(seed).uniform(-6.0, 6.0, size=15)
    As, Bs, Cs = t[:, None] * A / t[None, :], t[:, None] * B, C / t[None, :]
    ref = _ab13dd(A, B, C, D, discrete)  # the well-scaled realisation
    for method in ("bruinsma-steinbuch", "slycot"):
        assert hinf_norm(As, Bs, Cs, D, discrete=discrete, method=method) == pytest.approx(ref, rel=1e-9), method


def test_hinf_peak_near_infinity_uses_the_pencil() -> None:
    # σ_max(G(jω)) increases to σ_max(D) as ω → ∞ except for a small bump: γ near σ_max(D)
    A, B, C = np.array([[-1.0]]), np.array([[1.0]]), np.array([[1e-3]])
    D = np.array([[1.0]])
    ours = hinf_norm(A, B, C, D, method="bruinsma-steinbuch")
    assert ours == pytest.approx(_ab13dd(A, B, C, D, False), rel=1e-9)


def test_no_slycot_environment_forces_the_own_iteration(monkeypatch) -> None:
    A, B, C, D = _stable(10, 1, 1, 9)

    def boom(*_a, **_k):
        raise AssertionError("slycot path used")

    monkeypatch.setattr(norms_mod, "_hinf_slycot", boom)
    monkeypatch.setenv("NLOBS_NO_SLYCOT", "1")
    hinf_norm(A, B, C, D)
    monkeypatch.delenv("NLOBS_NO_SLYCOT")
    with pytest.raises(AssertionError, match="slycot path used"):
        hinf_norm(A, B, C, D)


def test_slycot_answer_that_does_not_reproduce_is_rejected(monkeypatch) -> None:
    A, B, C, D = _stable(10, 2, 2, 12)
    own = hinf_norm(A, B, C, D, method="bruinsma-steinbuch")

    class Fake:
        @staticmethod
        def ab13dd(*_a, **_k):
            return 0.5 * own, 0.123  # a wrong peak: σ_max at 0.123 is not 0.5 ‖G‖∞

    monkeypatch.setattr(norms_mod, "_slycot_module", lambda: Fake)
    assert hinf_norm(A, B, C, D, method="slycot") == pytest.approx(own, rel=1e-12)


@pytest.mark.parametrize(("A", "C", "hidden"), [
    (np.diag([-1e6, -1e-6]), np.array([[1.0, 1.0]]), []),  # was called unobservable: xGEBAL shrank C's column
    (np.diag([-1e6, -1e-6, -3.0]), np.array([[1.0, 1.0, 0.0]]), [-3.0]),
])
def test_widely_scaled_modes_are_judged_as_the_reference_does(A, C, hidden) -> None:  # type: ignore[no-untyped-def]
    from nlobs.linear.observability import unobservable_modes

    # PBH by hand: rank [λI − A; C] = n at every eigenvalue except the hidden ones (C's entry there is 0)
    for lam in np.diag(A):
        s = np.linalg.svd(np.vstack([lam * np.eye(A.shape[0]) - A, C]), compute_uv=False)
        assert (s[-1] < 1e-12) == (lam in hidden)
    np.testing.assert_allclose(np.sort(unobservable_modes(A, C).real), hidden)
    np.testing.assert_allclose(np.sort(unobservable_modes(A, C, method="pbh").real), hidden)
    assert is_observable(A, C) == (not hidden)
