"""The one observer protocol and the two loops: run_observer on recorded data against simulate and closed forms."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError, SimulationDiverged
from nlobs.observers.base import CorrectingObserver, DeferredEstimate, Diagnosing, Observer, SelfStepping
from nlobs.observers.luenberger import LuenbergerObserver
from nlobs.simulate import MeasurementGroup, SimulationResult, run_observer, simulate
from nlobs.systems.linear import LinearSystem
from nlobs.systems.timebase import Continuous, Discrete

A = np.array([[0.0, 1.0], [-2.0, -0.5]])
B = np.array([[0.0], [1.0]])
C = np.array([[1.0, 0.0]])


def test_discrete_replay_equals_simulate_exactly() -> None:
    plant = LinearSystem(np.eye(2) + 0.01 * A, 0.01 * B, C, time=Discrete(0.01))
    obs = LuenbergerObserver(plant, np.array([[0.3], [0.2]]))
    sim = simulate(plant, obs, x0=[[1.0, 0.0], [0.5, 0.2]], x_hat0=[0.0, 0.0], duration=2.0, u=[0.3])
    rep = run_observer(obs, sim.t, x_hat0=[0.0, 0.0], u=np.full((sim.t.size, 1), 0.3), y=sim.y, truth=sim.x,
                       states=plant.states)
    np.testing.assert_array_equal(rep.x_hat, sim.x_hat)
    np.testing.assert_array_equal(rep.error_norm, sim.error_norm)
    assert rep.method == "discrete" and rep.observer == "LuenbergerObserver"
    assert rep.info["cost_per_step_us"] > 0 and rep.info["samples"] == sim.t.size


def test_sampled_continuous_replay_equals_simulate_to_rounding() -> None:
    """simulate holds the sampled measurement over RK4 steps; run_observer does the same on the samples."""
    plant = LinearSystem(A, B, C, time=Continuous())
    obs = LuenbergerObserver(plant, np.array([[3.0], [2.0]]))
    sim = simulate(plant, obs, x0=[1.0, 0.0], x_hat0=[0.0, 0.0], duration=2.0, dt=0.01, u=[0.3],
                   measurements=[MeasurementGroup("y", [0], rate=20.0, noise_std=0.01)], seed=1)
    sel = sim.sampled[:, 0]
    rep = run_observer(obs, sim.t, x_hat0=[0.0, 0.0], u=np.full((sim.t.size, 1), 0.3), y=sim.y[sel],
                       y_times=sim.t[sel], truth=sim.x)
    np.testing.assert_allclose(rep.x_hat, sim.x_hat, rtol=0, atol=1e-14)
    assert rep.method == "rk4"


@dataclass(frozen=True)
class Gauss:
    """Mean and variance of a scalar Kalman filter (a state that is not one array)."""

    m: np.ndarray
    P: np.ndarray


@dataclass(frozen=True)
class ConstantKalman:
    """Kalman filter for a constant ``x`` measured as ``y = x + v``, ``v ~ N(0, r)``."""

    r: float
    P0: float
    time: Continuous = Continuous()
    n_x: int = 1

    def init(self, x_hat0: np.ndarray) -> Gauss:
        return Gauss(np.array(x_hat0, dtype=float), np.full(x_hat0.shape, self.P0))

    def rhs(self, t: float, z: Gauss, u: np.ndarray, y: np.ndarray) -> Gauss:
        return Gauss(np.zeros_like(z.m), np.zeros_like(z.P))

    def correct(self, t: float, z: Gauss, u: np.ndarray, y: np.ndarray, fresh: np.ndarray) -> Gauss:
        ok = np.isfinite(y)
        k = np.where(ok, z.P / (z.P + self.r), 0.0)
        return Gauss(z.m + k * np.where(ok, y - z.m, 0.0), (1 - k) * z.P)

    def estimate(self, z: Gauss) -> np.ndarray:
        return z.m

    def diagnostics(self, z: Gauss, u: np.ndarray) -> dict[str, np.ndarray]:
        return {"P": z.P[..., 0]}


def test_correcting_observer_with_a_dataclass_state_matches_the_closed_form() -> None:
    kf = ConstantKalman(r=0.25, P0=4.0)
    assert isinstance(kf, CorrectingObserver) and isinstance(kf, Diagnosing)
    rng = np.random.default_rng(3)
    t = np.arange(201) * 0.01
    y_times = t[::10]
    y = 1.5 + 0.5 * rng.standard_normal((3, y_times.size, 1))
    y[1, 4, 0] = np.nan  # a missing sample of run 1, skipped and counted
    res = run_observer(kf, t, x_hat0=[0.0], y=y, y_times=y_times)
    # posterior after n samples: (m0/P0 + Σ y/r) / (1/P0 + n/r)
    yy = np.where(np.isfinite(y[..., 0]), y[..., 0], 0.0)
    n = np.cumsum(np.isfinite(y[..., 0]), axis=-1)
    m_closed = (np.cumsum(yy, axis=-1) / kf.r) / (1 / kf.P0 + n / kf.r)
    np.testing.assert_allclose(res.x_hat[:, ::10, 0], m_closed, rtol=1e-12)
    np.testing.assert_allclose(res.extras["P"][:, ::10], 1 / (1 / kf.P0 + n / kf.r), rtol=1e-12)
    assert res.extras["P"].shape == (3, t.size)
    np.testing.assert_array_equal(res.info["missing"], [0, 1, 0])
    with pytest.raises(InvalidArgumentError, match="no truth"):
        _ = res.error


@dataclass(frozen=True)
class Decay:
    """``ż = −a (z − y)`` with an exact step ``z(t+h) = y + e^{−ah}(z − y)`` (a self-stepping observer)."""

    a: float
    time: Continuous = Continuous()
    n_x: int = 1
    calls: list[str] | None = None

    def init(self, x_hat0: np.ndarray) -> np.ndarray:
        return np.array(x_hat0, dtype=float)

    def rhs(self, t: float, z: np.ndarray, u: np.ndarray, y: np.ndarray) -> np.ndarray:
        return -self.a * (z - y)

    def step(self, t: float, z: np.ndarray, u: np.ndarray, y: np.ndarray, h: float) -> np.ndarray:
        return y + np.exp(-self.a * h) * (z - y)

    def estimate(self, z: np.ndarray) -> np.ndarray:
        return z


def test_self_stepping_observer_is_advanced_by_its_own_step_exactly() -> None:
    obs = Decay(a=50.0)  # h·a = 5: RK4 would diverge, the exact step does not
    assert isinstance(obs, SelfStepping)
    t = np.arange(41) * 0.1
    res = run_observer(obs, t, x_hat0=[0.0], y=np.ones((t.size, 1)))
    np.testing.assert_allclose(res.x_hat[:, 0], 1 - np.exp(-obs.a * t), rtol=1e-13, atol=1e-15)
    assert res.method == "observer step"
    plant = LinearSystem(np.zeros((1, 1)), np.zeros((1, 1)), np.eye(1), time=Continuous())
    sim = simulate(plant, obs, x0=[1.0], x_hat0=[0.0], duration=4.0, dt=0.1, u=[0.0])
    np.testing.assert_allclose(sim.x_hat[:, 0], 1 - np.exp(-obs.a * sim.t), rtol=1e-13, atol=1e-15)
    assert sim.method == "rk4+observer step"


@dataclass(frozen=True)
class Split:
    """The Luenberger observer of ``(A, C)`` with its state as two separate arrays (a tree)."""

    L: np.ndarray
    time: Continuous = Continuous()
    n_x: int = 2

    def init(self, x_hat0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return (x_hat0[..., :1].copy(), x_hat0[..., 1:].copy())

    def rhs(self, t: float, z: tuple[np.ndarray, np.ndarray], u: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, ...]:
        x = np.concatenate(z, axis=-1)
        d = x @ (A - self.L @ C).T + u @ B.T + y @ self.L.T
        return d[..., :1], d[..., 1:]

    def estimate(self, z: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        return np.concatenate(z, axis=-1)


def test_a_tree_state_is_integrated_like_the_packed_array() -> None:
    plant = LinearSystem(A, B, C, time=Continuous())
    L = np.array([[3.0], [2.0]])
    ref = simulate(plant, LuenbergerObserver(plant, L), x0=[[1.0, 0.0], [0.2, 0.1]], x_hat0=[0.0, 0.0],
                   duration=1.0, dt=0.01, u=[0.3])
    tree = simulate(plant, Split(L), x0=[[1.0, 0.0], [0.2, 0.1]], x_hat0=[0.0, 0.0], duration=1.0, dt=0.01, u=[0.3])
    np.testing.assert_allclose(tree.x_hat, ref.x_hat, rtol=0, atol=1e-14)
    rep = run_observer(Split(L), ref.t, x_hat0=[0.0, 0.0], u=np.full((ref.t.size, 1), 0.3), y=ref.y[0, ::10],
                       y_times=ref.t[::10])
    rep_ref = run_observer(LuenbergerObserver(plant, L), ref.t, x_hat0=[0.0, 0.0], u=np.full((ref.t.size, 1), 0.3),
                           y=ref.y[0, ::10], y_times=ref.t[::10])
    np.testing.assert_allclose(rep.x_hat, rep_ref.x_hat, rtol=0, atol=1e-14)


@dataclass(frozen=True)
class Squared:
    """Estimates ``x`` but records the cheap raw ``√x``; the record is squared once at the end."""

    time: Discrete = Discrete(1.0)
    n_x: int = 1
    calls: list[int] | None = None

    def init(self, x_hat0: np.ndarray) -> np.ndarray:
        return np.sqrt(np.array(x_hat0, dtype=float))

    def rhs(self, t: float, z: np.ndarray, u: np.ndarray, y: np.ndarray) -> np.ndarray:
        return z + 1.0

    def estimate(self, z: np.ndarray) -> np.ndarray:
        return z**2

    def raw_estimate(self, z: np.ndarray) -> np.ndarray:
        return z

    def finish_estimates(self, raw: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        if self.calls is not None:
            self.calls.append(raw.shape[-2])
        return raw**2, {"root": raw[..., 0]}


def test_deferred_estimates_are_finished_once_on_the_whole_record() -> None:
    calls: list[int] = []
    obs = Squared(calls=calls)
    assert isinstance(obs, DeferredEstimate) and isinstance(obs, Observer)
    res = run_observer(obs, np.arange(6.0), x_hat0=[[4.0], [9.0]], y=np.zeros((6, 1)), save_every=2)
    np.testing.assert_array_equal(res.t, [0.0, 2.0, 4.0, 5.0])
    np.testing.assert_array_equal(res.x_hat[..., 0], [[4.0, 16.0, 36.0, 49.0], [9.0, 25.0, 49.0, 64.0]])
    np.testing.assert_array_equal(res.extras["root"], [[2.0, 4.0, 6.0, 7.0], [3.0, 5.0, 7.0, 8.0]])
    assert calls == [4]


@dataclass(frozen=True)
class SquaredInPlace(Squared):
    """Finishes on the loop's own record, in place (as the GNSS/INS observer projects R̂)."""

    def finish_estimates(self, raw: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        assert raw.flags.writeable  # the loop hands its record over writable
        root = raw[..., 0].copy()
        np.square(raw, out=raw)
        return raw, {"root": root}


def test_a_deferred_observer_may_finish_in_place_and_the_record_is_kept_without_a_copy() -> None:
    res = run_observer(SquaredInPlace(), np.arange(6.0), x_hat0=[[4.0], [9.0]], y=np.zeros((6, 1)), save_every=2)
    np.testing.assert_array_equal(res.x_hat[..., 0], [[4.0, 16.0, 36.0, 49.0], [9.0, 25.0, 49.0, 64.0]])
    np.testing.assert_array_equal(res.extras["root"], [[2.0, 4.0, 6.0, 7.0], [3.0, 5.0, 7.0, 8.0]])
    assert not res.x_hat.flags.writeable and not res.x_hat.flags.owndata  # the loop's record itself
    plain = run_observer(Decay(a=2.0), np.arange(11) * 0.1, x_hat0=[[1.0], [2.0]], y=np.zeros((11, 1)))
    assert not plain.x_hat.flags.writeable and not plain.x_hat.flags.owndata


def test_divergence_names_the_time_and_the_component() -> None:
    obs = Decay(a=-50.0)  # e^{50 t} overflows near t = 14.2
    t = np.arange(2001) * 0.01
    with pytest.raises(SimulationDiverged) as info:
        run_observer(obs, t, x_hat0=[1.0], y=np.zeros((t.size, 1)))
    assert info.value.which == "Decay" and 14.0 < info.value.time < 16.0 and info.value.state == "x_hat[0]"


def test_bad_recorded_data_is_refused_with_a_typed_error() -> None:
    plant = LinearSystem(np.eye(2) + 0.01 * A, 0.01 * B, C, time=Discrete(0.01))
    obs = LuenbergerObserver(plant, np.array([[0.3], [0.2]]))
    t = np.arange(11) * 0.01
    u = np.zeros((11, 1))
    y = np.zeros((11, 1))
    with pytest.raises(InvalidArgumentError, match="uniform grid"):
        run_observer(obs, t * 1.5, x_hat0=[0.0, 0.0], u=u, y=y)
    with pytest.raises(InvalidArgumentError, match="not on the time grid"):
        run_observer(obs, t, x_hat0=[0.0, 0.0], u=u, y=y[:2], y_times=[0.0, 0.015])
    with pytest.raises(InvalidArgumentError, match="strictly increasing"):
        run_observer(obs, t[::-1], x_hat0=[0.0, 0.0], u=u, y=y)
    bad_u = u.copy()
    bad_u[3] = np.inf
    with pytest.raises(NonFiniteError, match="t = 0.03"):
        run_observer(obs, t, x_hat0=[0.0, 0.0], u=bad_u, y=y)
    bad_y = y.copy()
    bad_y[2] = np.nan
    with pytest.raises(NonFiniteError, match="cannot skip a missing sample"):
        run_observer(obs, t, x_hat0=[0.0, 0.0], u=u, y=bad_y)
    with pytest.raises(InvalidArgumentError, match="sample of every output at t\\[0\\]"):
        run_observer(obs, t, x_hat0=[0.0, 0.0], u=u, y=y[1:], y_times=t[1:])
    with pytest.raises(DimensionError):
        run_observer(obs, t, x_hat0=[0.0, 0.0, 0.0], u=u, y=y)
    with pytest.raises(DimensionError):
        run_observer(obs, t, x_hat0=[0.0, 0.0], u=u[:5], y=y)


def test_extras_and_info_survive_save_and_load(tmp_path) -> None:  # type: ignore[no-untyped-def]
    kf = ConstantKalman(r=0.25, P0=4.0)
    t = np.arange(11) * 0.1
    res = run_observer(kf, t, x_hat0=[[0.0], [1.0]], y=np.ones((2, 11, 1)), truth=np.ones((11, 1)))
    back = SimulationResult.load(res.save(tmp_path / "r.npz"))
    np.testing.assert_array_equal(back.extras["P"], res.extras["P"])
    np.testing.assert_array_equal(back.info["missing"], res.info["missing"])
    assert back.info["cost_per_step_us"] == res.info["cost_per_step_us"] and back.observer == "ConstantKalman"
    assert back.y is None and back.sampled is None and back.x.shape == (11, 1)
    np.testing.assert_array_equal(back.error_norm, res.error_norm)
