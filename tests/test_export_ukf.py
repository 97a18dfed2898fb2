"""The unscented Kalman filter as C (``nlobs export MODEL --observer ukf``): the Python filter's numbers, its sensors.

The generated module (:mod:`nlobs.export.ukf`) draws the sigma points from a Cholesky factor (an eigen square root
where it fails), integrates Särkkä's moment equations with the common RK4 step, and corrects by the statistical
linearisation in Joseph form; against :class:`nlobs.UKF` run by :func:`nlobs.simulate.run_observer` on the same data
it must give the same estimates, covariance diagonals and NIS to rounding, with multi-rate outputs and missing
samples, for a continuous nonlinear plant, a discrete nonlinear plant, a discrete linear system and a singular
initial covariance.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs import UKF, Discrete
from nlobs.cli import app
from nlobs.export import compile_observer, find_compiler
from nlobs.export.compiler import compile_object
from nlobs.export.program import render
from nlobs.export.ukf import generate_ukf
from nlobs.simulate import run_observer
from nlobs.systems.symbolic import SymbolicModel

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))


def _compare(flt, t, u, y, sampled, x_hat0):  # type: ignore[no-untyped-def]
    a = run_observer(flt, t, x_hat0=x_hat0, u=u, y=y, sampled=sampled, progress=False)
    b = run_observer(compile_observer(flt), t, x_hat0=x_hat0, u=u, y=y, sampled=sampled, progress=False)
    scale = np.max(np.abs(a.x_hat))
    assert np.max(np.abs(a.x_hat - b.x_hat)) <= 1e-11 * scale
    np.testing.assert_allclose(b.extras["P_diag"], a.extras["P_diag"], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(b.extras["nis"], a.extras["nis"], rtol=1e-8, atol=1e-12)
    return a


def test_continuous_nonlinear_plant_multi_rate_with_missing_samples() -> None:
    from filter_single_run import data, flexible_joint

    plant = flexible_joint()
    t, u, x, y = data(plant)
    y = y.copy()
    y[5::7, 1] = np.nan  # missing samples of the second output
    sampled = np.ones((len(t), 2), dtype=bool)
    sampled[::3, 0] = False  # the first output at two thirds of the instants
    flt = UKF(plant, np.diag([1e-6, 1e-4, 1e-6, 1e-4]), np.diag([1e-6, 1e-4]), np.eye(4) * 0.1)
    a = _compare(flt, t, u, y, sampled, np.zeros(4))
    assert np.sqrt(np.mean((a.x_hat[1000:] - x[1000:]) ** 2)) < 5e-3  # and the filter works: it tracks


def _discrete_pendulum():  # type: ignore[no-untyped-def]
    m = SymbolicModel.general(["p", "q"], ["u"], ["y"], ["p + 0.1*q", "q - 0.1*sin(p) + 0.1*u"], ["sin(p)"],
                              time=Discrete(0.1), name="discrete-pendulum").compile()
    rng = np.random.default_rng(2)
    K = 300
    x = np.zeros((K, 2))
    x[0] = [1.0, 0.0]
    u = 0.2 * np.sin(0.05 * np.arange(K))[:, None]
    for k in range(K - 1):
        x[k + 1] = m.rhs(0.0, x[k], u[k])
    y = np.sin(x[:, :1]) + rng.normal(0.0, 0.05, (K, 1))
    return m, 0.1 * np.arange(K), u, y


def test_discrete_nonlinear_plant() -> None:
    m, t, u, y = _discrete_pendulum()
    _compare(UKF(m, np.eye(2) * 1e-4, np.eye(1) * 0.0025, np.eye(2), alpha=0.5, kappa=1.0), t, u, y, None,
             np.zeros(2))


def test_singular_initial_covariance_takes_the_eigen_square_root() -> None:
    """P0 = diag(1, 0): the Cholesky factorisation fails at the first step, in C as in NumPy."""
    m, t, u, y = _discrete_pendulum()
    _compare(UKF(m, np.eye(2) * 1e-4, np.eye(1) * 0.0025, np.diag([1.0, 0.0])), t, u, y, None, np.zeros(2))


def test_discrete_linear_system() -> None:
    from nlobs import LinearSystem

    s = LinearSystem([[1.0, 0.1], [0.0, 1.0]], [[0.0], [0.1]], [[1.0, 0.0]], time=Discrete(0.1))
    rng = np.random.default_rng(3)
    K = 200
    u = rng.normal(size=(K, 1))
    x = np.zeros((K, 2))
    for k in range(K - 1):
        x[k + 1] = s.rhs(0.0, x[k], u[k])
    y = x[:, :1] + rng.normal(0.0, 0.1, (K, 1))
    _compare(UKF(s, np.eye(2) * 1e-3, np.eye(1) * 0.01, np.eye(2)), 0.1 * np.arange(K), u, y, None, np.ones(2))


def test_the_eigen_square_root_of_a_full_singular_covariance() -> None:
    """Sigma points of a rank-deficient, non-diagonal P: the C's Jacobi square root S satisfies S Sᵀ = P."""
    from filter_single_run import flexible_joint

    flt = UKF(flexible_joint(), np.eye(4) * 1e-6, np.eye(2) * 1e-4, np.eye(4))
    cobs = compile_observer(flt)
    rng = np.random.default_rng(5)
    A = rng.normal(size=(4, 2))
    P = A @ A.T  # rank 2
    z = np.concatenate([rng.normal(size=4), P.ravel(), [0.0]])
    dz = cobs.rhs(0.0, z, np.zeros(cobs.program.n_u), np.zeros(2))
    from nlobs.observers.gaussian import FilterState

    want = flt.rhs(0.0, FilterState(z[:4], P, np.zeros(())), np.zeros(cobs.program.n_u), np.zeros(2))
    # with distinct nonzero eigenvalues the sigma-point set is unique (up to signs and order): the same moments
    np.testing.assert_allclose(dz[:4], want.x, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(dz[4:20].reshape(4, 4), want.P, rtol=1e-9, atol=1e-10)


def test_generated_c_compiles_strictly_and_says_what_it_is() -> None:
    from filter_single_run import flexible_joint

    program = generate_ukf(UKF(flexible_joint(), np.eye(4) * 1e-6, np.eye(2) * 1e-4, np.eye(4)), "fj_ukf")
    header, source = render(program, "test")
    compile_object(source, strict=True, headers={program.header_name: header})
    assert program.n_z == 4 + 16 + 1 and program.correcting
    assert "Sarkka" in header and re.search(r"sigma points +: 9 \(alpha 1.0, beta 2.0, kappa 0.0", header)


def test_cli_exports_the_ukf_of_a_model_file_without_claiming_a_certificate(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["export", "cartpole", "--observer", "ukf", "--out", str(tmp_path), "--json"])
    assert res.exit_code == 0, res.output
    report = json.loads(res.stdout)
    assert report["observer"] == "ukf" and report["certified"] is False and report["verdict"] == "ok"
    header = (tmp_path / "cartpole_ukf.h").read_text(encoding="utf-8")
    assert "none: a Kalman filter carries no convergence guarantee" in header and "CARTPOLE_UKF_NZ 21" in header


@pytest.mark.parametrize("kind", ["ekf", "ukf"])
def test_simulate_gives_a_compiled_filter_the_input_at_each_rk4_stage(kind: str) -> None:
    """A live input that varies within a step: the generated RK4 step reads it at the stage times, as the joint RK4
    gives the Python filter (it held u(t_k) before: 1e-3 apart on the cart-pole's sine input)."""
    from filter_single_run import flexible_joint

    from nlobs import EKF
    from nlobs.simulate import MeasurementGroup, simulate

    plant = flexible_joint()
    flt = (EKF if kind == "ekf" else UKF)(plant, np.eye(4) * 1e-4, np.eye(2) * 1e-4, np.eye(4) * 0.1)
    cobs = compile_observer(flt)
    assert cobs.program.staged
    groups = [MeasurementGroup("encoders", list(plant.outputs), rate=100.0, noise_std=0.01)]
    runs = {}
    for name, obs in (("python", flt), ("c", cobs)):
        runs[name] = simulate(plant, obs, np.array([[0.3, 0.0, 0.2, 0.0], [-0.2, 0.1, 0.0, 0.0]]), np.zeros(4),
                              duration=1.0, dt=1e-3, u=lambda t: np.array([2.0 * np.sin(20.0 * t)]),
                              measurements=groups, seed=3, progress=False)
    a, b = runs["python"].x_hat, runs["c"].x_hat
    assert np.max(np.abs(a - b)) <= 1e-11 * np.max(np.abs(a))
    held = cobs.step(0.0, cobs.init(np.ones(4)), np.zeros(1), np.zeros(2), 0.1)
    staged = cobs.step_stages(0.0, cobs.init(np.ones(4)), np.zeros(1), np.ones(1), np.ones(1), np.zeros(2), 0.1)
    assert not np.allclose(held[:4], staged[:4])  # the stage inputs reach the C
