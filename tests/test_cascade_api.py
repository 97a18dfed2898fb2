"""Symbolic and numeric Σ1 give the same observer; plant/observer protocol details."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError
from nlobs.papers.grip_example1 import L_RAJAMANI, example1_sigma1, example1_sigma2
from nlobs.observers.cascade import CascadeObserver
from nlobs.synthesis.cascade_gain import place_cascade_gain
from nlobs.systems.interconnected import NonlinearSubsystem, interconnected_plant


def _numeric(feedback: bool) -> NonlinearSubsystem:
    Lr = L_RAJAMANI[:, 0]

    def f(u, *a):  # type: ignore[no-untyped-def]
        x = a[-1]
        arg = x[..., 0] + (a[0][..., 0] if feedback else 0.0)
        return np.stack([x[..., 1], x[..., 0] - x[..., 1] + 0.4 * np.sin(arg)], axis=-1)

    def h(u, *a):  # type: ignore[no-untyped-def]
        return a[-1][..., 1:2]

    def g(u, xh, *a):  # type: ignore[no-untyped-def]
        z = a[-1]
        return (z - xh[..., 1:2]) * Lr

    def h_x(u, *a):  # type: ignore[no-untyped-def]
        return np.broadcast_to(np.array([[0.0, 1.0]]), (*a[-1].shape[:-1], 1, 2))

    def h_w(u, w, x):  # type: ignore[no-untyped-def]
        return np.zeros((*x.shape[:-1], 1, 2))

    if feedback:
        return NonlinearSubsystem.numeric(n_x=2, p_z=1, n_w=2, f=f, h=h, g=g, h_x=h_x, h_w=h_w)
    return NonlinearSubsystem.numeric(n_x=2, p_z=1, f=f, h=h, g=g, h_x=h_x)


@pytest.mark.parametrize("feedback", [False, True], ids=["cascade", "feedback"])
def test_symbolic_and_numeric_sigma1_agree(feedback: bool) -> None:
    s2 = example1_sigma2()
    K = place_cascade_gain(s2, gamma=0.1).gain
    sym = CascadeObserver(example1_sigma1(feedback), s2, K)
    num = CascadeObserver(_numeric(feedback), s2, K)
    rng = np.random.default_rng(3)
    Z = rng.normal(size=(4, 7, 5))
    U = np.zeros((4, 7, 0))
    Y = rng.normal(size=(4, 7, 1))
    np.testing.assert_allclose(sym.rhs(0.0, Z, U, Y), num.rhs(0.0, Z, U, Y), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(sym.z_hat(Z), num.z_hat(Z), rtol=1e-14)
    ps, pn = interconnected_plant(sym.sigma1, s2), interconnected_plant(num.sigma1, s2)
    X = rng.normal(size=(3, 4))
    np.testing.assert_allclose(ps.rhs(0.0, X, np.zeros((3, 0))), pn.rhs(0.0, X, np.zeros((3, 0))), rtol=1e-13)
    assert ps.states == ("x1", "x2", "w1", "w2") and ps.outputs == ("y",) and ps.n == 4 and ps.p == 1


def test_observer_refuses_a_non_hurwitz_gain_and_init() -> None:
    s2 = example1_sigma2()
    with pytest.raises(InvalidArgumentError, match="not Hurwitz"):
        CascadeObserver(example1_sigma1(), s2, np.zeros((3, 1)))
    obs = CascadeObserver(example1_sigma1(), s2, place_cascade_gain(s2, gamma=0.1).gain)
    z0 = obs.init(np.ones((2, 4)))
    assert z0.shape == (2, 5) and np.all(z0[:, 4] == 0)
    np.testing.assert_allclose(obs.z_hat(z0), [[1.0], [1.0]])  # ẑ0 = h(x̂0) = x̂2
    z1 = obs.init_state([1.0, 2.0], [0.0, 0.0], [5.0])
    np.testing.assert_allclose(obs.z_hat(z1), [5.0])
    assert obs.K_w.shape == (2, 1) and obs.K_z.shape == (1, 1)
