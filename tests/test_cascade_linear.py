"""The cascade observer (9)–(10) and the feedback observer (17)–(18) on LINEAR Σ1.

With f, h linear and g = L(z − h(u, [ŵ,] x̂)) the overall error dynamics is exactly linear and
autonomous (u and u̇ drop out). The composite matrices below are derived by hand in this file
(not by the library), directly from (1), (2), (9), (10), (17), (18):

cascade, errors e = [x̃; w̃; z̃] (x̃ = x − x̂, ...):
    x̃̇ = (F − L H) x̃ + L z̃
    w̃̇ = (A − K_w C) w̃ + (B_z − K_w D_z) z̃
    z̃̇ = H F x̃ − K_z C w̃ − K_z D_z z̃

feedback (f = F x + E w + G u, h = H x + M w + J u, g = L(z − H x̂ − M ŵ − J u)):
    x̃̇ = (F − L H) x̃ + (E − L M) w̃ + L z̃
    w̃̇ = (A − K_w C) w̃ + (B_z − K_w D_z) z̃
    z̃̇ = H F x̃ + (H E + M A − K_z C) w̃ + (M B_z − K_z D_z) z̃

The simulated errors must follow expm(M t) e(0).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
import sympy as sp

from nlobs.observers import Observer
from nlobs.observers.cascade import CascadeObserver
from nlobs.synthesis.cascade_gain import place_cascade_gain
from nlobs.systems.interconnected import LinearSubsystem, NonlinearSubsystem, interconnected_plant
from nlobs.simulate import simulate
from nlobs.systems.base import PlantModel

F = np.array([[0.0, 1.0], [-2.0, -1.0]])
G = np.array([[0.0], [1.0]])
H = np.array([[1.0, 0.5]])
J = np.array([[0.3]])
L = np.array([[1.0], [2.0]])
A = np.array([[0.0, 1.0], [-1.0, -1.0]])
Bz = np.array([[0.0], [1.0]])
C = np.array([[1.0, 0.0]])
Dz = np.array([[0.2]])
Bu = np.array([[0.1], [0.0]])
Du = np.array([[0.5]])
E = np.array([[0.0, 0.0], [0.3, -0.2]])
M = np.array([[0.4, 0.1]])


def u_of_t(t: float) -> np.ndarray:
    return np.array([np.sin(2.0 * t) + 0.5 * np.cos(0.7 * t)])


def _sym(expr_mat: np.ndarray, syms: list[sp.Symbol]) -> sp.Matrix:
    return sp.Matrix(expr_mat) * sp.Matrix(syms)


def sigma1(feedback: bool) -> NonlinearSubsystem:
    x = [sp.Symbol("x1"), sp.Symbol("x2")]
    u = [sp.Symbol("u")]
    z = sp.Symbol("z")
    w = [sp.Symbol("w1"), sp.Symbol("w2")]
    f = _sym(F, x) + _sym(G, u)
    h = _sym(H, x) + _sym(J, u)
    if feedback:
        f = f + _sym(E, w)
        h = h + _sym(M, w)
    g = sp.Matrix(L) * (sp.Matrix([z]) - h)
    return NonlinearSubsystem.symbolic(
        states=["x1", "x2"], inputs=["u"], outputs=["z"], f=f, h=h, g=g,
        linear_states=["w1", "w2"] if feedback else None,
    )


SIGMA2 = LinearSubsystem(A, Bz, C, Dz, B_u=Bu, D_u=Du)
K = np.asarray(place_cascade_gain(SIGMA2, gamma=0.5).gain)
Kw, Kz = K[:2], K[2:]


def composite(feedback: bool) -> np.ndarray:
    if not feedback:
        return np.block([
            [F - L @ H, np.zeros((2, 2)), L],
            [np.zeros((2, 2)), A - Kw @ C, Bz - Kw @ Dz],
            [H @ F, -Kz @ C, -Kz @ Dz],
        ])
    return np.block([
        [F - L @ H, E - L @ M, L],
        [np.zeros((2, 2)), A - Kw @ C, Bz - Kw @ Dz],
        [H @ F, H @ E + M @ A - Kz @ C, M @ Bz - Kz @ Dz],
    ])


@pytest.mark.parametrize("feedback", [False, True], ids=["cascade", "feedback"])
def test_error_follows_expm_of_composite_matrix(feedback: bool) -> None:
    s1 = sigma1(feedback)
    plant = interconnected_plant(s1, SIGMA2)
    obs = CascadeObserver(s1, SIGMA2, K)
    assert isinstance(plant, PlantModel) and isinstance(obs, Observer)
    Mc = composite(feedback)
    assert np.max(np.linalg.eigvals(Mc).real) < 0  # the example is a converging one
    x0 = np.array([1.0, -0.5, 0.3, 0.2])
    xh0 = np.array([-0.5, 0.7, -0.4, 0.6])
    res = simulate(plant, obs, x0, xh0, duration=3.0, dt=1e-3, u=u_of_t, save_every=50)
    # initial z̃: ξ0 = 0 so ẑ0 = h(u0, [ŵ0,] x̂0) and z̃0 = H x̃0 (+ M w̃0)
    e0 = x0 - xh0
    zt0 = H @ e0[:2] + (M @ e0[2:] if feedback else 0.0)
    full0 = np.concatenate([e0, zt0])
    pred = np.array([scipy.linalg.expm(Mc * t) @ full0 for t in res.t])
    err = -np.asarray(res.error)  # library convention x̂ − x; here x − x̂
    scale = np.max(np.abs(full0))
    np.testing.assert_allclose(err, pred[:, :4], atol=1e-9 * scale, rtol=0)
    assert np.linalg.norm(err[-1]) < 0.2 * np.linalg.norm(e0)


@pytest.mark.parametrize("feedback", [False, True], ids=["cascade", "feedback"])
def test_z_hat_error_follows_composite_matrix(feedback: bool) -> None:
    """z̃ = z − ẑ from an adaptive integration of plant + observer, against expm."""
    s1 = sigma1(feedback)
    plant = interconnected_plant(s1, SIGMA2)
    obs = CascadeObserver(s1, SIGMA2, K)
    x0 = np.array([0.5, 0.5, -0.3, 0.1])
    z0 = obs.init_state([0.0, 0.0], [0.0, 0.0], [0.7], u0=u_of_t(0.0))

    def rhs(t: float, s: np.ndarray) -> np.ndarray:
        x, zz = s[:4], s[4:]
        u = u_of_t(t)
        return np.concatenate([plant.rhs(t, x, u), obs.rhs(t, zz, u, plant.output(t, x, u))])

    ts = np.linspace(0.0, 2.0, 9)
    sol = scipy.integrate.solve_ivp(rhs, (0, 2.0), np.concatenate([x0, z0]), t_eval=ts, rtol=1e-11, atol=1e-13)
    x, zz = sol.y[:4].T, sol.y[4:].T
    u = np.array([u_of_t(t) for t in ts])
    ztil = plant.z(0.0, x, u) - obs.z_hat(zz, u)
    e = np.concatenate([x - obs.estimate(zz), ztil], axis=-1)
    Mc = composite(feedback)
    pred = np.array([scipy.linalg.expm(Mc * t) @ e[0] for t in ts])
    assert e[0, 4] == pytest.approx(plant.z(0.0, x0, u_of_t(0.0))[0] - 0.7)
    np.testing.assert_allclose(e, pred, atol=1e-8, rtol=0)


def test_batched_evaluation_matches_loop() -> None:
    s1 = sigma1(True)
    obs = CascadeObserver(s1, SIGMA2, K)
    rng = np.random.default_rng(0)
    Z = rng.normal(size=(5, 3, obs.n_z))
    U = rng.normal(size=(5, 3, 1))
    Y = rng.normal(size=(5, 3, 1))
    batched = obs.rhs(0.0, Z, U, Y)
    for i in range(5):
        for j in range(3):
            np.testing.assert_allclose(batched[i, j], obs.rhs(0.0, Z[i, j], U[i, j], Y[i, j]), rtol=1e-13)
    assert obs.state_names == ("x1_hat", "x2_hat", "w1_hat", "w2_hat", "xi_z")
    assert obs.n_x == 4 and obs.n_z == 5
