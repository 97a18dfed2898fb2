"""Gains of the drift-observability observer (Dalla Mora, Germani & Manes): Remark 2.11, (2.17) and its LMI."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

from nlobs.errors import CertificateError, DesignInfeasible, InvalidArgumentError
from nlobs.geometry import brunovsky
from nlobs.synthesis.drift_gain import (
    RiccatiConstants,
    brunovsky_triple,
    design_drift_gain,
    design_drift_gain_sdp,
    riccati_lhs,
    smallest_w,
    vandermonde_gain,
    verify_drift_gain,
)


def _F_ends(s: tuple[int, ...]) -> np.ndarray:
    """F_{s,r} when s = r: one column per output, a 1 at the end of its chain (= B_s)."""
    return brunovsky_triple(s)[1]


@pytest.mark.parametrize("s", [(1,), (2,), (3,), (3, 1), (2, 3), (1, 1, 2)])
def test_brunovsky_transfer_matrix_is_diag_of_integrators(s: tuple[int, ...]) -> None:
    # Closed form: C_s (zI − A_s)⁻¹ B_s = diag(z^{−s_j}) (a chain of s_j integrators per output).
    A, B, C = brunovsky_triple(s)
    assert brunovsky_triple is brunovsky  # one implementation, shared with the geometry layer
    for z in (0.7, -1.3, 2.0 + 0.5j):
        T = C @ np.linalg.solve(z * np.eye(A.shape[0]) - A, B)
        np.testing.assert_allclose(T, np.diag([z ** (-sj) for sj in s]), rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("s", [(2,), (3,), (3, 1), (2, 3), (4, 1)])
@pytest.mark.parametrize("w", [0.7, 3.0, 25.0])
def test_vandermonde_assigns_the_closed_form_eigenvalues_and_diagonalises(s: tuple[int, ...], w: float) -> None:
    A, _, C = brunovsky_triple(s)
    g = vandermonde_gain(s, w)
    Acl = A - g.K @ C
    expected = np.concatenate([-w * np.arange(1, sj + 1) for sj in s])
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(Acl).real), np.sort(expected), rtol=1e-7)
    np.testing.assert_allclose(np.linalg.eigvals(Acl).imag, 0.0, atol=1e-6 * w)
    # V_s (A_s − K C_s) V_s⁻¹ = Λ and (A − KC)P + P(A − KC)ᵀ = 2 V⁻¹ Λ V⁻ᵀ with P = (VᵀV)⁻¹
    Vi = np.linalg.inv(g.V)
    np.testing.assert_allclose(g.V @ Acl @ Vi, np.diag(g.eigenvalues), atol=1e-8 * max(1.0, w) ** max(s))
    np.testing.assert_allclose(g.P, np.linalg.inv(g.V.T @ g.V), rtol=1e-6, atol=1e-12)
    lyap = Acl @ g.P + g.P @ Acl.T
    np.testing.assert_allclose(lyap, 2 * Vi @ np.diag(g.eigenvalues) @ Vi.T, rtol=1e-6, atol=1e-9)


def test_vandermonde_gain_is_the_characteristic_polynomial() -> None:
    w = 2.0
    np.testing.assert_allclose(vandermonde_gain((2,), w).K[:, 0], [3 * w, 2 * w**2])
    np.testing.assert_allclose(vandermonde_gain((3,), w).K[:, 0], [6 * w, 11 * w**2, 6 * w**3])
    K = vandermonde_gain((2, 1), w).K
    np.testing.assert_allclose(K, [[3 * w, 0], [2 * w**2, 0], [0, w]])


def test_riccati_lhs_is_the_formula() -> None:
    s = (2, 1)
    A, B, C = brunovsky_triple(s)
    F = _F_ends(s)
    c = RiccatiConstants(s, F, alpha=0.7, mu=1.3, gamma=0.4)
    rng = np.random.default_rng(1)
    K = rng.normal(size=(3, 2))
    R = rng.normal(size=(3, 3))
    P = R @ R.T + np.eye(3)
    Acl = A - K @ C
    ref = Acl @ P + P @ Acl.T + B @ B.T + 1.3**2 * F @ F.T + 2 * 0.7 * P + 0.4**2 * P @ P
    np.testing.assert_allclose(riccati_lhs(c, K, P), ref, rtol=1e-12)


@pytest.mark.parametrize("triple", [(1.0, 1.0, 1.0), (3.0, 0.5, 2.0), (0.5, 5.0, 0.5), (2.0, 2.0, 4.0)])
def test_theorem_2_9_smallest_w_exists_for_s_le_r(triple: tuple[float, float, float]) -> None:
    alpha, mu, gamma = triple
    s = (3, 1)
    c = RiccatiConstants(s, _F_ends(s), alpha, mu, gamma)
    ws = smallest_w(c, rtol=1e-3)
    cert = ws.certificate
    assert cert.verified and cert.w == ws.w
    # verified independently: eigenvalues of the left side, P ≻ 0, Hurwitz
    g = vandermonde_gain(s, ws.w)
    assert np.linalg.eigvalsh(riccati_lhs(c, g.K, g.P))[-1] < 0
    assert np.linalg.eigvalsh(g.P)[0] > 0
    # bracket: (2.17) fails just below w
    lo = ws.bracket[0]
    g_lo = vandermonde_gain(s, lo)
    assert np.linalg.eigvalsh(riccati_lhs(c, g_lo.K, g_lo.P))[-1] >= 0
    assert ws.bracket[1] / lo <= 1.0 + 1.1e-3
    assert ws.monotone
    assert cert.spectral_abscissa < -alpha  # (2.17) with γ > 0 implies abscissa < −α


def test_smallest_w_reports_failure_with_violation_when_s_not_le_r() -> None:
    # SISO, s = 2 > r = 1: F = I₂ (input enters at the top of the chain), μ too large
    c = RiccatiConstants((2,), np.eye(2), alpha=1.0, mu=1.0, gamma=1.0)
    with pytest.raises(DesignInfeasible, match=r"no Vandermonde solution.*w ≤ 1000.*smallest λ_max.*s ≰ r") as ei:
        smallest_w(c, w_max=1000.0)
    assert ei.value.violation is not None and ei.value.violation > 0
    assert "(2.17)" in ei.value.constraint
    # Theorem 2.7: a small enough μ works
    ok = smallest_w(RiccatiConstants((2,), np.eye(2), alpha=1.0, mu=0.1, gamma=1.0))
    assert ok.certificate.verified


@pytest.mark.parametrize("objective", ["min_gain", "min_condition"])
def test_sdp_design_is_verified_independently(objective: str) -> None:
    s = (3, 1)
    c = RiccatiConstants(s, _F_ends(s), alpha=1.0, mu=2.0, gamma=1.0)
    cert = design_drift_gain_sdp(c, objective=objective, gain_bound=1e4 if objective == "min_condition" else None)
    assert cert.verified
    lhs = riccati_lhs(c, cert.gain, cert.P)
    assert np.linalg.eigvalsh(lhs)[-1] < 0
    assert np.linalg.eigvalsh(cert.P)[0] > 0
    A, _, C = brunovsky_triple(s)
    assert np.max(np.linalg.eigvals(A - cert.gain @ C).real) < -c.alpha
    again = verify_drift_gain(c, cert.gain, cert.P)
    assert again.verified and again.lhs_max_eig == pytest.approx(cert.lhs_max_eig)


def test_sdp_min_gain_beats_vandermonde_on_gain_and_condition() -> None:
    s = (2,)
    c = RiccatiConstants(s, _F_ends(s), alpha=1.0, mu=1.0, gamma=1.0)
    sdp = design_drift_gain_sdp(c)
    vdm = smallest_w(c).certificate
    assert sdp.gain_norm < vdm.gain_norm
    assert sdp.cond_P < vdm.cond_P


def test_scaled_sdp_solves_high_gain_cases_the_unscaled_lmi_cannot() -> None:
    s = (3, 1)
    c = RiccatiConstants(s, _F_ends(s), alpha=1.0, mu=1.0, gamma=29.0)
    with pytest.raises(DesignInfeasible, match=r"Theorem 2.9 says \(2.17\) is solvable.*scaling='auto'"):
        design_drift_gain_sdp(c, scaling=None)
    cert = design_drift_gain_sdp(c)  # scaling="auto"
    assert cert.verified and cert.scaling > 1.0
    assert np.linalg.eigvalsh(riccati_lhs(c, cert.gain, cert.P))[-1] < 0
    assert cert.gain_norm < smallest_w(c).certificate.gain_norm


def test_sdp_infeasible_names_constraint_and_margin() -> None:
    c = RiccatiConstants((2,), np.eye(2), alpha=1.0, mu=1.0, gamma=1.0)
    with pytest.raises(DesignInfeasible, match=r"LMI in \(S, Y\) is infeasible.*slack is t = .*s ≰ r") as ei:
        design_drift_gain_sdp(c, kappa_max=1e4)
    assert ei.value.violation is not None and ei.value.violation > 0
    assert "S = P⁻¹" in ei.value.constraint


def test_given_w_that_fails_raises_and_bad_arguments() -> None:
    c = RiccatiConstants((2,), _F_ends((2,)), alpha=1.0, mu=1.0, gamma=1.0)
    with pytest.raises(DesignInfeasible, match=r"w = 1.5 does not solve \(2.17\)"):
        design_drift_gain(c, "vandermonde", w=1.5)
    assert design_drift_gain(c, "vandermonde", w=50.0).verified
    with pytest.raises(InvalidArgumentError, match="method"):
        design_drift_gain(c, "riccati")
    with pytest.raises(InvalidArgumentError, match="alpha"):
        RiccatiConstants((2,), None, alpha=0.0, mu=1.0, gamma=1.0)
    with pytest.raises(InvalidArgumentError, match="s: every entry"):
        vandermonde_gain((2, 0), 1.0)


def _mp_riccati(c: RiccatiConstants, K: np.ndarray, P: np.ndarray) -> tuple[float, float, float]:
    """In mpmath (the current precision): λ_max of the unscaled left side of (2.17), λ_min(P), cn(P).

    An independent source: the float entries of K, P are converted exactly and the formula is written out.
    """
    A, B, C = (mpmath.matrix(M.tolist()) for M in brunovsky_triple(c.s))
    Km, Pm = mpmath.matrix(K.tolist()), mpmath.matrix(P.tolist())
    F = mpmath.matrix(c.F.tolist()) if c.F.size else None
    Acl = A - Km * C
    L = Acl * Pm + Pm * Acl.T + B * B.T + 2 * mpmath.mpf(c.alpha) * Pm + mpmath.mpf(c.gamma) ** 2 * (Pm * Pm)
    if F is not None:
        L += mpmath.mpf(c.mu) ** 2 * (F * F.T)
    L = (L + L.T) / 2
    evL = mpmath.eigsy(L, eigvals_only=True)
    evP = mpmath.eigsy((Pm + Pm.T) / 2, eigvals_only=True)
    return float(max(evL)), float(min(evP)), float(max(evP) / min(evP))


@pytest.mark.parametrize(("s", "digits"), [((5,), 50), ((6,), 60), ((8,), 100)])
def test_long_chains_get_a_verified_w_confirmed_in_high_precision(s: tuple[int, ...], digits: int) -> None:
    # Theorem 2.9 (s = r): a solution exists for every (α, μ, γ). Unscaled, λ_max(L) at (K(w), P(w)) is below the
    # rounding level of its own computation (P spans w^(−2(s−1))): the verification must be done on D L D.
    c = RiccatiConstants(s, _F_ends(s), 1.0, 1.0, 1.0)
    ws = smallest_w(c)
    cert = ws.certificate
    assert cert.verified and ws.monotone
    assert cert.lhs_max_eig_scaled < -cert.lhs_tolerance < 0
    assert abs(cert.lhs_max_eig) < cert.lhs_rounding  # the double-precision unscaled sign means nothing here
    # the claim checked independently: (2.17) at the returned floats, in `digits` significant digits
    with mpmath.workdps(digits):
        lam, pmin, cond = _mp_riccati(c, np.asarray(cert.gain), np.asarray(cert.P))
    assert lam < 0 and pmin > 0
    assert cert.cond_P == pytest.approx(cond, rel=1e-5)  # cn(P) from the scaled P̃, against the exact spectrum
    assert cert.spectral_abscissa < -c.alpha


def test_verification_margin_rejects_a_pair_that_fails_by_less_than_rounding() -> None:
    # s = (5,): below w* (2.17) fails; the old unscaled check was decided by rounding either way.
    c = RiccatiConstants((5,), _F_ends((5,)), 1.0, 1.0, 1.0)
    w_star = smallest_w(c).w
    g = vandermonde_gain((5,), 0.9 * w_star)
    cert = verify_drift_gain(c, g.K, g.P)
    with mpmath.workdps(50):
        lam, _, _ = _mp_riccati(c, np.asarray(g.K), np.asarray(g.P))
    assert lam > 0 and not cert.verified
    assert not cert.checks[0].passed and cert.lhs_max_eig_scaled > 0


def test_chains_beyond_double_precision_say_so() -> None:
    c = RiccatiConstants((9,), _F_ends((9,)), 1.0, 1.0, 1.0)
    with pytest.raises(DesignInfeasible, match=r"negative but not below the rounding tolerance.*double precision"):
        smallest_w(c)


def test_decay_margin_of_an_indefinite_P_is_nan_with_a_reason() -> None:
    c = RiccatiConstants((2,), _F_ends((2,)), 1.0, 1.0, 1.0)
    cert = verify_drift_gain(c, vandermonde_gain((2,), 5.0).K, -np.eye(2))  # RuntimeWarnings are errors (pyproject)
    assert not cert.verified and np.isnan(cert.decay_margin)
    assert "not positive definite" in cert.decay_margin_note
    assert "decay margin undefined" in cert.summary() and cert.cond_P == np.inf


def test_scaled_sdp_falls_back_to_theta_1_when_the_w_search_fails_verification(monkeypatch: pytest.MonkeyPatch) -> None:
    import nlobs.synthesis.drift_gain as dg

    def broken(*args: object, **kwargs: object) -> None:
        raise CertificateError("Vandermonde pair failed")

    monkeypatch.setattr(dg, "smallest_w", broken)
    c = RiccatiConstants((2,), _F_ends((2,)), 1.0, 1.0, 1.0)
    cert = design_drift_gain_sdp(c)  # scaling="auto": θ = 1 is still tried
    assert cert.verified and cert.scaling == 1.0


def test_the_largest_mu_row_is_the_gain_bounds_and_the_other_reading_of_remark_2_11() -> None:
    # reproduce dallamora2000: "largest μ (SDP) = 0.976" is under ‖K̃‖ ≤ 1e6; (2.17) still holds at μ = 0.99
    # with a larger gain bound. Remark 2.11's eigenvalues −i·w give the smallest w 4.03; the other reading, −wⁱ, 3.14
    from nlobs.papers.dallamora2000 import brunovsky_triple
    from nlobs.synthesis.drift_gain import RiccatiConstants, design_drift_gain_sdp, riccati_lhs, smallest_w

    c = RiccatiConstants((2,), np.eye(2), 1.0, 0.99, 1.0)
    with pytest.raises(DesignInfeasible):
        design_drift_gain_sdp(c, kappa_max=1e6, scaling=None)
    assert design_drift_gain_sdp(c, kappa_max=1e8, scaling=None).verified
    c1 = RiccatiConstants((2,), brunovsky_triple((2,))[1], 1.0, 1.0, 1.0)
    assert smallest_w(c1).w == pytest.approx(4.03, abs=0.01)

    def holds(w: float) -> bool:  # the pair of eigenvalues −w, −w², P = (VᵀV)⁻¹, checked with NumPy's eigvalsh
        lam = np.array([-w, -w * w])
        K = np.array([[-lam.sum()], [lam.prod()]])
        V = np.array([[x, 1.0] for x in lam])
        L = riccati_lhs(c1, K, np.linalg.inv(V.T @ V))
        return bool(np.linalg.eigvalsh((L + L.T) / 2)[-1] < 0)

    ws = np.geomspace(1.05, 100.0, 20000)
    first = next(w for w in ws if holds(w))
    assert first == pytest.approx(3.14, abs=0.01)
