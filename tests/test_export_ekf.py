"""The extended Kalman filter as C (``nlobs export MODEL --observer ekf``): the Python filter's numbers, its sensors.

The generated module integrates Jazwinski's moment equations with the common RK4 step and updates in Joseph form
(:mod:`nlobs.export.kalman`); against :class:`nlobs.EKF` run by :func:`nlobs.simulate.run_observer` on the same
data it must give the same estimates, covariance diagonals and NIS to rounding, with multi-rate outputs and
missing samples, for a continuous nonlinear plant, a discrete nonlinear plant and a discrete linear system.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs import EKF, Discrete
from nlobs.cli import app
from nlobs.export import compile_observer, find_compiler
from nlobs.simulate import run_observer
from nlobs.systems.symbolic import SymbolicModel

pytestmark = pytest.mark.skipif(find_compiler() is None, reason="no C compiler")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))


def _compare(flt, t, u, y, sampled, x_hat0):  # type: ignore[no-untyped-def]
    a = run_observer(flt, t, x_hat0=x_hat0, u=u, y=y, sampled=sampled, progress=False)
    b = run_observer(compile_observer(flt), t, x_hat0=x_hat0, u=u, y=y, sampled=sampled, progress=False)
    scale = np.max(np.abs(a.x_hat))
    assert np.max(np.abs(a.x_hat - b.x_hat)) <= 1e-12 * scale
    np.testing.assert_allclose(b.extras["P_diag"], a.extras["P_diag"], rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(b.extras["nis"], a.extras["nis"], rtol=1e-9, atol=1e-12)
    return a


def test_continuous_nonlinear_plant_multi_rate_with_missing_samples() -> None:
    from filter_single_run import data, flexible_joint

    plant = flexible_joint()
    t, u, x, y = data(plant)
    y = y.copy()
    y[5::7, 1] = np.nan  # missing samples of the second output
    sampled = np.ones((len(t), 2), dtype=bool)
    sampled[::3, 0] = False  # the first output at two thirds of the instants
    flt = EKF(plant, np.diag([1e-6, 1e-4, 1e-6, 1e-4]), np.diag([1e-6, 1e-4]), np.eye(4) * 0.1)
    a = _compare(flt, t, u, y, sampled, np.zeros(4))
    assert np.sqrt(np.mean((a.x_hat[1000:] - x[1000:]) ** 2)) < 5e-3  # and the filter works: it tracks


def test_discrete_nonlinear_plant() -> None:
    m = SymbolicModel.general(["p", "q"], ["u"], ["y"], ["p + 0.1*q", "q - 0.1*sin(p) + 0.1*u"], ["p"],
                              time=Discrete(0.1), name="discrete-pendulum").compile()
    rng = np.random.default_rng(2)
    K = 300
    x = np.zeros((K, 2))
    x[0] = [1.0, 0.0]
    u = 0.2 * np.sin(0.05 * np.arange(K))[:, None]
    for k in range(K - 1):
        x[k + 1] = m.rhs(0.0, x[k], u[k])
    y = x[:, :1] + rng.normal(0.0, 0.05, (K, 1))
    flt = EKF(m, np.eye(2) * 1e-4, np.eye(1) * 0.0025, np.eye(2))
    _compare(flt, 0.1 * np.arange(K), u, y, None, np.zeros(2))


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
    _compare(EKF(s, np.eye(2) * 1e-3, np.eye(1) * 0.01, np.eye(2)), 0.1 * np.arange(K), u, y, None, np.ones(2))


def test_cli_exports_the_ekf_of_a_model_file_without_claiming_a_certificate(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["export", "cartpole", "--observer", "ekf", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    header = (tmp_path / "cartpole_ekf.h").read_text(encoding="utf-8")
    assert "none: a Kalman filter carries no convergence guarantee" in header
    assert "Joseph-form update" in header and "CARTPOLE_EKF_NZ 21" in header  # x (4), P (16), NIS
    assert "certificate: none" in res.stdout
