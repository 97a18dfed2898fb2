"""H∞ and H2 norms (nlobs.linear.norms) against python-control/slycot and closed forms.

Independent references:
* ``control.linfnorm`` (SLICOT AB13DD, a different implementation of the
  Bruinsma–Steinbuch / Boyd–Balakrishnan iteration with structure-preserving
  eigensolvers). AB13DD returns the L∞ norm for unstable systems too, so it is
  compared on stable draws only. Note: with ``tol`` ≤ 1e-12 AB13DD was seen to
  stop at a non-peak value; ``tol=1e-10`` is used.
* a dense frequency grid, which gives a lower bound (our value must not be
  below it) — this check does not depend on any library.
* ``control.norm(sys, p=2, method="slycot")`` (SLICOT Lyapunov solvers) for H2.
* hand-derived closed forms.
"""

from __future__ import annotations

import math

import control
import numpy as np
import scipy.linalg
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError
from nlobs.linear import h2_norm, hinf_grid_peak, hinf_norm

SETTINGS = settings(max_examples=40, deadline=None, derandomize=True)


def _random_system(seed: int, *, discrete: bool, stable: bool = True, feedthrough: bool = True):
    rng = np.random.default_rng(seed)
    n, m, p = (int(v) for v in rng.integers(1, [7, 4, 4]))
    A = rng.normal(size=(n, n))
    if discrete:
        rho = max(abs(np.linalg.eigvals(A)))
        target = rng.uniform(0.2, 0.97) if stable else rng.uniform(1.05, 2.0)
        A = A * (target / rho)
    else:
        shift = max(np.linalg.eigvals(A).real)
        margin = rng.uniform(0.05, 1.0)
        A = A - (shift + margin) * np.eye(n) if stable else A - (shift - margin) * np.eye(n)
    B = rng.normal(size=(n, m))
    C = rng.normal(size=(p, n))
    D = rng.normal(size=(p, m)) if feedthrough else np.zeros((p, m))
    return A, B, C, D


def _grid_peak(A, B, C, D, *, discrete: bool) -> float:
    """σ_max on a dense grid (a lower bound of the H∞ norm), no library involved."""
    n = A.shape[0]
    if discrete:
        pts = np.exp(1j * np.linspace(0.0, np.pi, 2001))
    else:
        lam = np.abs(np.linalg.eigvals(A))
        w = np.concatenate([[0.0], np.logspace(-3, 3, 2000) * max(lam.max(), 1e-3)])
        pts = 1j * w
    best = float(np.linalg.norm(D, 2))
    for s in pts:
        G = C @ np.linalg.solve(s * np.eye(n) - A, B) + D
        best = max(best, float(np.linalg.norm(G, 2)))
    return best


@pytest.mark.slow
@pytest.mark.parametrize("discrete", [False, True])
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_hinf_matches_slycot_on_stable_systems(discrete: bool, seed: int) -> None:
    A, B, C, D = _random_system(seed, discrete=discrete, feedthrough=seed % 3 != 0)
    ours = hinf_norm(A, B, C, D, discrete=discrete)
    sysc = control.ss(A, B, C, D, dt=1.0 if discrete else 0)
    ref = float(control.linfnorm(sysc, tol=1e-10)[0])
    assert ours == pytest.approx(ref, rel=1e-7)
    # Documented guarantee (rtol = 1e-9): γ ≤ ‖G‖∞ < (1 + 2 rtol) γ, so our
    # value is never more than 2e-9 (relative) below any grid sample.
    assert ours >= _grid_peak(A, B, C, D, discrete=discrete) * (1 - 2.5e-9)


@pytest.mark.parametrize("discrete", [False, True])
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_norms_are_infinite_for_unstable_systems(discrete: bool, seed: int) -> None:
    A, B, C, D = _random_system(seed, discrete=discrete, stable=False)
    assert hinf_norm(A, B, C, D, discrete=discrete) == math.inf
    assert h2_norm(A, B, C, D, discrete=discrete) == math.inf


@pytest.mark.parametrize("discrete", [False, True])
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_h2_matches_slycot(discrete: bool, seed: int) -> None:
    A, B, C, D = _random_system(seed, discrete=discrete, feedthrough=discrete)
    ours = h2_norm(A, B, C, D, discrete=discrete)
    sysc = control.ss(A, B, C, D, dt=1.0 if discrete else 0)
    ref = float(control.norm(sysc, p=2, method="slycot", print_warning=False))
    assert ours == pytest.approx(ref, rel=1e-8)


def test_hinf_second_order_lowpass_closed_form() -> None:
    # G = 1/(s² + s + 1): |G(jω)|⁻² = (1 − ω²)² + ω², minimal (= 3/4) at ω² = 1/2.
    A, B, C, D = [[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]]
    assert hinf_norm(A, B, C, D) == pytest.approx(2.0 / math.sqrt(3.0), rel=1e-9)
    # H2: for 1/(s² + a₁ s + a₀), ‖G‖₂² = 1/(2 a₁ a₀) = 1/2
    assert h2_norm(A, B, C, D) == pytest.approx(math.sqrt(0.5), rel=1e-12)


def test_hinf_peak_at_dc_and_with_feedthrough() -> None:
    # G = 2/(s + 4) + 0.5 = (0.5 s + 4)/(s + 4): |G| decreases from 1 (ω=0) to 0.5.
    assert hinf_norm([[-4.0]], [[1.0]], [[2.0]], [[0.5]]) == pytest.approx(1.0, rel=1e-9)
    # G = −3/(s + 1) + 2 = (2s − 1)/(s + 1): |G| increases from 1 to 2 at ω = ∞.
    assert hinf_norm([[-1.0]], [[1.0]], [[-3.0]], [[2.0]]) == pytest.approx(2.0, rel=1e-9)
    # H2 is infinite in continuous time with D ≠ 0
    assert h2_norm([[-1.0]], [[1.0]], [[-3.0]], [[2.0]]) == math.inf


def test_lightly_damped_resonance() -> None:
    # G = ω₀²/(s² + 2ζω₀ s + ω₀²): peak 1/(2ζ√(1 − ζ²)) for ζ < 1/√2.
    z, w0 = 0.01, 10.0
    A = [[0.0, 1.0], [-(w0**2), -2 * z * w0]]
    got = hinf_norm(A, [[0.0], [w0**2]], [[1.0, 0.0]], [[0.0]])
    assert got == pytest.approx(1 / (2 * z * math.sqrt(1 - z**2)), rel=1e-9)


@pytest.mark.parametrize("a", [0.5, 0.9, -0.5, -0.999, 0.999])
def test_discrete_first_order_closed_form(a: float) -> None:
    # G = 1/(z − a): peak 1/(1 − |a|) at z = sign(a); impulse response a^(k−1), k ≥ 1.
    assert hinf_norm([[a]], [[1.0]], [[1.0]], [[0.0]], discrete=True) == pytest.approx(1 / (1 - abs(a)), rel=1e-9)
    assert h2_norm([[a]], [[1.0]], [[1.0]], [[0.0]], discrete=True) == pytest.approx(
        math.sqrt(1 / (1 - a * a)), rel=1e-12
    )
    # with feedthrough d: ‖G‖₂² = d² + 1/(1 − a²)
    assert h2_norm([[a]], [[1.0]], [[1.0]], [[0.3]], discrete=True) == pytest.approx(
        math.sqrt(0.09 + 1 / (1 - a * a)), rel=1e-12
    )


def test_marginally_stable_is_infinite() -> None:
    assert hinf_norm([[0.0]], [[1.0]], [[1.0]], [[0.0]]) == math.inf  # integrator
    assert hinf_norm([[1.0]], [[1.0]], [[1.0]], [[0.0]], discrete=True) == math.inf
    assert h2_norm([[0.0, 1.0], [-1.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]]) == math.inf


def test_empty_dimensions() -> None:
    A = [[-1.0]]
    assert hinf_norm(A, np.zeros((1, 0)), [[1.0]], np.zeros((1, 0))) == 0.0
    assert hinf_norm(A, [[1.0]], np.zeros((0, 1)), np.zeros((0, 1))) == 0.0
    assert h2_norm(A, np.zeros((1, 0)), [[1.0]], np.zeros((1, 0))) == 0.0
    # n = 0: a static gain
    assert hinf_norm(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), [[3.0, 4.0]]) == pytest.approx(5.0)
    assert h2_norm(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), [[3.0, 4.0]], discrete=True) == 5.0
    # G ≡ 0 (pole-zero cancellation of the whole transfer function)
    assert hinf_norm([[-1.0, 0.0], [0.0, -1.0]], [[1.0], [1.0]], [[1.0, -1.0]], [[0.0]]) == 0.0


# --- badly scaled realisations (regression) ----------------------------------
# Observer error dynamics A − KC for a chain-of-integrators-like plant with very
# large gains K: entries of A span ~1e10. The unscaled Hamiltonian pencil then
# lost its imaginary eigenvalues in QZ and hinf_norm returned e.g. 6.8258e-4
# instead of 6.8340e-4 (0.12 % low: an unsound certificate).
_A3 = np.array([[0.0, 1.0, 0.0], [-1.0, -1.0, 1.0], [0.0, 0.0, 0.0]])
_C3 = np.array([[1.0, 0.0, 0.0]])
_BD3 = np.array([[0.0], [0.0], [1.0]])
_LARGE_GAINS = [
    [5.859e3, 1.716e7, 2.515e10],  # was 6.8258e-4, true 6.83400530779985e-4
    [5.707e3, 1.628e7, 2.325e10],  # was 7.0051e-4, true 7.01450740920063e-4
    [2e3, 2e6, 1e9],  # was 2.00200e-3, true 2.00333665951807e-3
    [2e4, 2e8, 1e12],  # was 2.00027e-4, true 2.00240266204461e-4
    [4e2, 8e4, 8e6],
]


def _refined_grid_peak(A, B, C, D, w_hint: float) -> float:
    """Grid lower bound (log grid, then a fine linear grid around its best point)."""
    n = A.shape[0]

    def sig(w: float) -> float:
        return float(np.linalg.norm(C @ np.linalg.solve(1j * w * np.eye(n) - A, B) + D, 2))

    lam = np.abs(np.linalg.eigvals(A))
    ws = np.concatenate([[0.0], np.logspace(-3, 3, 3000) * lam.max(), [w_hint]])
    vals = [sig(w) for w in ws]
    k = int(np.argmax(vals))
    best = max(vals)
    for lo, hi in ((ws[max(k - 1, 0)], ws[min(k + 1, len(ws) - 1)]), (0.999 * w_hint, 1.001 * w_hint)):
        best = max(best, max(sig(w) for w in np.linspace(lo, hi, 2001)))
    return best


@pytest.mark.parametrize("gain", _LARGE_GAINS)
def test_hinf_large_observer_gain_not_underestimated(gain) -> None:
    K = np.array(gain).reshape(3, 1)
    A, B, C, D = _A3 - K @ _C3, _BD3, np.eye(3), np.zeros((3, 1))
    ours = hinf_norm(A, B, C, D)
    ref, w_peak = control.linfnorm(control.ss(A, B, C, D), tol=1e-10)
    assert ours == pytest.approx(float(ref), rel=1e-8)
    # independent of any library: the grid peak is a lower bound of ‖G‖∞, and
    # ours may be at most 2·rtol (relative) below ‖G‖∞.
    grid = _refined_grid_peak(A, B, C, D, float(w_peak))
    assert ours >= grid * (1 - 2.5e-9)
    assert grid >= ours * (1 - 1e-6)  # the grid does get close to the peak
    # and the same system, scaled back to moderate entries, gives the same value
    t = np.array([1.0, abs(K[0, 0]), abs(K[1, 0])])
    assert hinf_norm(A * t[None, :] / t[:, None], B / t[:, None], C * t[None, :], D) == pytest.approx(ours, rel=1e-9)


@settings(max_examples=30, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), discrete=st.booleans(), with_d=st.booleans())
def test_hinf_invariant_under_bad_diagonal_similarity(seed: int, discrete: bool, with_d: bool) -> None:
    # G is invariant under (T A T⁻¹, T B, C T⁻¹); T = diag(10^k), k ∈ [−6, 6],
    # makes the realisation badly scaled (entries spanning up to 1e24).
    A, B, C, D = _random_system(seed, discrete=discrete, feedthrough=with_d)
    k = np.random.default_rng(seed ^ 0x5EED).uniform(-6.0, 6.0, size=A.shape[0])
    t = 10.0**k
    As, Bs, Cs = t[:, None] * A / t[None, :], t[:, None] * B, C / t[None, :]
    ref = hinf_norm(A, B, C, D, discrete=discrete)
    got = hinf_norm(As, Bs, Cs, D, discrete=discrete)
    assert got == pytest.approx(ref, rel=1e-7)
    assert got >= _grid_peak(A, B, C, D, discrete=discrete) * (1 - 2.5e-9)


def test_bad_input() -> None:
    A, B, C, D = [[-1.0]], [[1.0]], [[1.0]], [[0.0]]
    with pytest.raises(DimensionError, match="A: expected a square matrix"):
        hinf_norm([[1.0, 2.0]], B, C, D)
    with pytest.raises(DimensionError, match=r"B: expected shape \(1, \?\)"):
        hinf_norm(A, [[1.0], [2.0]], C, D)
    with pytest.raises(DimensionError, match="C: expected shape"):
        h2_norm(A, B, [[1.0, 2.0]], D)
    with pytest.raises(DimensionError, match="D: expected shape"):
        h2_norm(A, B, C, [[0.0, 1.0]])
    with pytest.raises(DimensionError, match="2-d"):
        hinf_norm([1.0], B, C, D)
    with pytest.raises(NonFiniteError, match="A: entry"):
        hinf_norm([[math.nan]], B, C, D)
    with pytest.raises(NonFiniteError, match="D: entry"):
        h2_norm(A, B, C, [[math.inf]])
    with pytest.raises(InvalidArgumentError, match="rtol"):
        hinf_norm(A, B, C, D, rtol=0.0)


# --- the H∞ grid safeguard (hinf_grid_peak, hinf_norm(grid=True)) -------------


@pytest.mark.parametrize("discrete", [False, True])
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_grid_safeguard_is_a_lower_bound_close_to_hinf_norm(discrete: bool, seed: int) -> None:
    A, B, C, D = _random_system(seed, discrete=discrete, feedthrough=seed % 3 != 0)
    bs = hinf_norm(A, B, C, D, discrete=discrete)
    grid = hinf_grid_peak(A, B, C, D, discrete=discrete)
    # both are attained values σ_max(G(jω)): the grid never exceeds the norm (beyond its 2·rtol) ...
    assert grid <= bs * (1 + 2.5e-9)
    # ... and on these systems the refined grid finds the peak
    assert grid >= bs * (1 - 1e-6)
    # grid=True returns the larger of the two
    assert hinf_norm(A, B, C, D, discrete=discrete, grid=True) == max(bs, grid)


@pytest.mark.parametrize("gain", _LARGE_GAINS)
def test_grid_safeguard_agrees_with_hinf_norm_for_large_observer_gains(gain) -> None:
    # The case the safeguard was written for (Grip–Saberi–Johansen, Example 1 with gains ~1e7–1e10):
    # before the balancing of hinf_norm, Bruinsma–Steinbuch was 0.12 % low here; now both agree.
    K = np.array(gain).reshape(3, 1)
    A, B, C, D = _A3 - K @ _C3, _BD3, np.eye(3), np.zeros((3, 1))
    bs, grid = hinf_norm(A, B, C, D), hinf_grid_peak(A, B, C, D)
    assert grid == pytest.approx(bs, rel=1e-9)
    assert hinf_norm(A, B, C, D, grid=True) == pytest.approx(bs, rel=1e-9)


def test_grid_safeguard_edge_cases() -> None:
    assert hinf_grid_peak([[1.0]], [[1.0]], [[1.0]], [[0.0]]) == math.inf  # unstable
    assert hinf_grid_peak([[-1.0]], np.zeros((1, 0)), [[1.0]], np.zeros((1, 0))) == 0.0  # no input
    assert hinf_grid_peak(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((2, 0)), [[3.0], [4.0]]) == 5.0  # static
    # G = 1/(s + 1): peak 1 at ω = 0, the first grid point
    assert hinf_grid_peak([[-1.0]], [[1.0]], [[1.0]], [[0.0]]) == pytest.approx(1.0, rel=1e-12)
    assert hinf_grid_peak([[0.5]], [[1.0]], [[1.0]], [[0.0]], discrete=True) == pytest.approx(2.0, rel=1e-9)
    with pytest.raises(InvalidArgumentError, match="points: expected an integer ≥ 2"):
        hinf_grid_peak([[-1.0]], [[1.0]], [[1.0]], [[0.0]], points=1)


@pytest.mark.parametrize("s", [1e-150, 1e-75, 1e100, 1e150])
def test_h2_norm_of_a_scaled_system_scales_exactly(s: float) -> None:
    # before: 0 for the 1e-150-scaled system (its Gramian underflowed); ‖G‖₂ scales with the product of B's and C's
    from nlobs.linear.norms import h2_norm

    A = np.array([[-1.0, 0.5], [0.0, -2.0]])
    B = np.array([[1.0], [2.0]])
    C = np.array([[1.0, 3.0]])
    ref = h2_norm(A, B, C, np.zeros((1, 1)))
    X = scipy.linalg.solve_continuous_lyapunov(A, -B @ B.T)  # the controllability Gramian, SciPy
    assert ref == pytest.approx(float(np.sqrt(np.trace(C @ X @ C.T))), rel=1e-12)
    assert h2_norm(A, B * s, C * s, np.zeros((1, 1))) == pytest.approx(ref * s * s, rel=1e-12)
