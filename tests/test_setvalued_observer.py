"""Algorithm 1 under the one observer protocol: SetValuedObserver against a direct transcription of (10)-(15)."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError, NonFiniteError
from nlobs.observers.base import CorrectingObserver, Diagnosing
from nlobs.observers.setvalued import SetValuedObserver, sound_radii
from nlobs.papers.khajenejad_yong import example_61
from nlobs.simulate.setvalued import ball_samples
from nlobs.simulate import run_observer
from nlobs.simulate.setvalued import input_estimates, radii_of, run_setvalued
from nlobs.synthesis.setvalued import design_setvalued


def _algorithm1(system, design, y):  # type: ignore[no-untyped-def]
    """Khajenejad & Yong's Algorithm 1 written out as one loop over (10)-(15) (the reference)."""
    tr, Lt = design.transform, design.gain
    B, K1, _ = y.shape
    xh = np.broadcast_to(system.x0, (B, system.n)).copy()
    X, D = np.empty((B, K1, system.n)), np.empty((B, K1 - 1, system.p))
    X[:, 0] = xh
    d1 = (y[:, 0] @ tr.U1 - xh @ tr.C1.T) @ tr.M1.T  # (10) at k = 0
    for k in range(1, K1):
        xp = system.f(xh) + d1 @ tr.G1.T  # (13)
        z2 = y[:, k] @ tr.U2
        d2 = (z2 - xp @ tr.C2.T) @ tr.M2.T  # (11)
        D[:, k - 1] = d1 @ tr.V1.T + d2 @ tr.V2.T  # (12)
        xs = xp + d2 @ tr.G2.T  # (14)
        xh = xs + (z2 - xs @ tr.C2.T) @ Lt.T  # (15)
        X[:, k] = xh
        d1 = (y[:, k] @ tr.U1 - xh @ tr.C1.T) @ tr.M1.T  # (10)
    return X, D


@pytest.fixture(scope="module")
def case():  # type: ignore[no-untyped-def]
    ex = example_61("II")
    s = ex.system
    design = design_setvalued(s)
    rng = np.random.default_rng(4)
    K, R = 120, 7
    x0 = s.x0 + ball_samples(rng, (R,), s.delta0, s.n)
    d = np.broadcast_to(ex.unknown_input(np.arange(K + 1) * s.time.dt)[None], (R, K + 1, s.p))
    x, y = s.simulate(x0, d, ball_samples(rng, (R, K), s.eta_w, s.n_w), ball_samples(rng, (R, K + 1), s.eta_v, s.l))
    return s, design, x, y, d


def test_observer_equals_the_transcribed_algorithm(case) -> None:  # type: ignore[no-untyped-def]
    s, design, x, y, d = case
    obs = SetValuedObserver(s, design)
    assert isinstance(obs, CorrectingObserver) and isinstance(obs, Diagnosing)
    X, D = _algorithm1(s, design, y)
    res = run_observer(obs, np.arange(y.shape[1]) * s.time.dt, x_hat0=np.broadcast_to(s.x0, (y.shape[0], s.n)), y=y)
    np.testing.assert_allclose(res.x_hat, X, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(res.extras["d_hat"][:, 1:], D, rtol=1e-13, atol=1e-13)
    assert np.isnan(res.extras["d_hat"][:, 0]).all()
    rad = sound_radii(s, design, y.shape[1] - 1)  # the observer's state carries the same recursion
    np.testing.assert_array_equal(res.extras["radius_state"], rad.state)
    np.testing.assert_array_equal(res.extras["radius_input"][1:], rad.input)


def test_run_setvalued_is_the_observer_on_the_loop(case) -> None:  # type: ignore[no-untyped-def]
    s, design, x, y, d = case
    res = run_setvalued(s, design, y, truth=x)
    X, D = _algorithm1(s, design, y)
    np.testing.assert_allclose(res.x_hat, X, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(input_estimates(res), D, rtol=1e-13, atol=1e-13)
    rad = radii_of(res)
    assert rad is not None and rad.label == "sound"
    ref = sound_radii(s, design, y.shape[1] - 1)
    assert rad.state_steady == ref.state_steady and rad.input_steady == ref.input_steady
    assert np.all(np.linalg.norm(x - res.x_hat, axis=-1) <= rad.state * (1 + 1e-9) + 1e-9)


def test_algorithm1_needs_every_measurement(case) -> None:  # type: ignore[no-untyped-def]
    s, design, x, y, d = case
    obs = SetValuedObserver(s, design)
    t = np.arange(y.shape[1]) * s.time.dt
    with pytest.raises(InvalidArgumentError, match="every step"):
        run_observer(obs, t, x_hat0=np.broadcast_to(s.x0, (2, s.n)), y=y[:2, ::2], y_times=t[::2])
    bad = y[:2].copy()
    bad[1, 5, 0] = np.nan
    with pytest.raises(NonFiniteError, match="needs every sample"):
        run_observer(obs, t, x_hat0=np.broadcast_to(s.x0, (2, s.n)), y=bad)
