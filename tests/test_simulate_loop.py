"""simulate(): batches, divergence, validation, time bases, save_every, progress."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError, SimulationDiverged
from nlobs.observers.luenberger import LuenbergerObserver
from nlobs.simulate import InputSensor, MeasurementGroup, SolveIVP, simulate
from nlobs.systems.linear import LinearSystem
from nlobs.systems.timebase import CONTINUOUS, Discrete


class Pendulum:
    """Damped pendulum with a torque input; outputs the angle (batched numpy)."""

    time = CONTINUOUS
    states = ("theta", "omega")
    inputs = ("torque",)
    outputs = ("angle",)
    n, m, p = 2, 1, 1

    def rhs(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return np.stack([x[..., 1], -9.81 * np.sin(x[..., 0]) - 0.2 * x[..., 1] + u[..., 0]], axis=-1)

    def output(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return x[..., :1]


class PendulumObserver:
    """Copy of the pendulum plus output injection."""

    time = CONTINUOUS
    n_z = 2
    n_x = 2

    def init(self, x_hat0: np.ndarray) -> np.ndarray:
        return np.array(x_hat0, dtype=float)

    def rhs(self, t: float, z: np.ndarray, u: np.ndarray, y: np.ndarray) -> np.ndarray:
        innov = y[..., 0] - z[..., 0]
        return Pendulum().rhs(t, z, u) + np.stack([4.0 * innov, 6.0 * innov], axis=-1)

    def estimate(self, z: np.ndarray) -> np.ndarray:
        return z


class Square:
    """ẋ = x², which from x(0) = 1 blows up at t = 1."""

    time = CONTINUOUS
    states = ("blowup",)
    inputs = ()
    outputs = ("y",)
    n, m, p = 1, 0, 1

    def rhs(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return x**2

    def output(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return x


def _u(t: float) -> np.ndarray:
    return np.array([0.5 * np.sin(2.0 * t)])


def test_batch_equals_separate_runs() -> None:
    rng = np.random.default_rng(42)
    x0 = rng.uniform(-1.0, 1.0, size=(6, 2))
    xh0 = rng.uniform(-1.0, 1.0, size=(6, 2))
    kw = dict(
        duration=2.0,
        dt=1e-3,
        u=_u,
        measurements=[MeasurementGroup("enc", ["angle"], rate=50.0)],
        input_sensors=[InputSensor("torque", [0], rate=100.0)],
    )
    batch = simulate(Pendulum(), PendulumObserver(), x0, xh0, **kw)
    assert batch.x.shape == (6, 2001, 2) and batch.batch_shape == (6,)
    for b in range(6):
        one = simulate(Pendulum(), PendulumObserver(), x0[b], xh0[b], **kw)
        assert one.x.shape == (2001, 2)
        np.testing.assert_allclose(batch.x[b], one.x, rtol=0, atol=1e-12)
        np.testing.assert_allclose(batch.x_hat[b], one.x_hat, rtol=0, atol=1e-12)
        np.testing.assert_allclose(batch.y[b], one.y, rtol=0, atol=1e-12)


def test_two_dimensional_batch_and_broadcast_initial_estimate() -> None:
    x0 = np.zeros((2, 3, 2)) + np.array([0.1, 0.0])
    res = simulate(Pendulum(), PendulumObserver(), x0, [0.0, 0.0], duration=0.1, dt=1e-2, u=0.0)
    assert res.x.shape == (2, 3, 11, 2) and res.x_hat.shape == (2, 3, 11, 2) and res.y.shape == (2, 3, 11, 1)
    np.testing.assert_array_equal(res.x_hat[..., 0, :], 0.0)


def test_divergence_names_the_state_and_a_time_just_after_the_blowup() -> None:
    with pytest.raises(SimulationDiverged, match="blowup") as info:
        simulate(Square(), None, [1.0], duration=2.0, dt=1e-3)
    assert info.value.which == "plant" and info.value.state == "blowup"
    assert 1.0 < info.value.time < 1.01
    # In a batch, only one member blowing up is enough; the time is the same.
    with pytest.raises(SimulationDiverged) as info2:
        simulate(Square(), None, [[0.1], [1.0], [0.2]], duration=2.0, dt=1e-3)
    assert info2.value.time == pytest.approx(info.value.time)


def test_divergence_with_solve_ivp_is_reported_at_the_blowup() -> None:
    with pytest.raises(SimulationDiverged, match="blowup") as info:
        simulate(Square(), None, [1.0], duration=2.0, dt=1e-2, integrator=SolveIVP())
    assert info.value.time == pytest.approx(1.0, abs=1e-3)


def test_observer_divergence_uses_observer_state_names() -> None:
    sys_ = LinearSystem([[0.0]], np.zeros((1, 0)), [[1.0]], states=("pos",))
    bad = LuenbergerObserver(sys_, [[-1000.0]])  # A - LC = +1000: e(t) = e0 exp(1000 t) overflows near t = 0.71
    with pytest.raises(SimulationDiverged, match="pos_hat") as info:
        simulate(sys_, bad, [0.0], [1.0], duration=1.0, dt=1e-4)
    assert info.value.which == "observer"
    # Overflow happens once e0 exp(1000 t) times the RK4 stage factor (~6000) passes the largest double.
    t_overflow = np.log(np.finfo(float).max) / 1000.0
    assert t_overflow - np.log(1e4) / 1000.0 < info.value.time <= t_overflow + 1e-3

    class Nameless(PendulumObserver):
        def rhs(self, t: float, z: np.ndarray, u: np.ndarray, y: np.ndarray) -> np.ndarray:
            d = np.zeros_like(z)
            d[..., 1] = np.inf if t > 0.05 else 0.0
            return d

    with pytest.raises(SimulationDiverged, match=r"z\[1\]"):
        simulate(Pendulum(), Nameless(), [0.0, 0.0], [0.0, 0.0], duration=1.0, dt=1e-2, u=0.0)


@pytest.mark.parametrize(
    ("kwargs", "error", "pattern"),
    [
        (dict(x0=[0.0, 0.0, 0.0]), DimensionError, "x0"),
        (dict(x0=[np.nan, 0.0]), NonFiniteError, "x0"),
        (dict(x_hat0=[0.0]), DimensionError, "x_hat0"),
        (dict(x_hat0=np.zeros((4, 2))), DimensionError, "x_hat0"),
        (dict(dt=0.0), InvalidArgumentError, "dt"),
        (dict(dt=-1e-3), InvalidArgumentError, "dt"),
        (dict(dt=None), InvalidArgumentError, "dt: required"),
        (dict(duration=0.0), InvalidArgumentError, "duration"),
        (dict(duration=-1.0), InvalidArgumentError, "duration"),
        (dict(save_every=0), InvalidArgumentError, "save_every"),
        (dict(u=np.zeros(3)), DimensionError, "u"),
        (dict(u=None), InvalidArgumentError, "u: the plant has 1 input"),
        (dict(x_hat0=None), InvalidArgumentError, "x_hat0"),
        (dict(seed="abc"), InvalidArgumentError, "seed"),
    ],
)
def test_invalid_arguments(kwargs: dict, error: type[Exception], pattern: str) -> None:
    args = dict(x0=np.zeros((3, 2)), x_hat0=[0.0, 0.0], duration=1.0, dt=1e-2, u=0.0)
    args.update(kwargs)
    x0, xh0 = args.pop("x0"), args.pop("x_hat0")
    with pytest.raises(error, match=pattern):
        simulate(Pendulum(), PendulumObserver(), x0, xh0, **args)


def test_discrete_time_steps_must_agree() -> None:
    plant = LinearSystem([[0.9]], [[1.0]], [[1.0]], time=Discrete(0.1))
    obs_other = LuenbergerObserver(LinearSystem([[0.9]], [[1.0]], [[1.0]], time=Discrete(0.2)), [[0.5]])
    obs_same = LuenbergerObserver(plant, [[0.5]])
    with pytest.raises(InvalidArgumentError, match=r"plant has dt=0\.1 but observer has dt=0\.2"):
        simulate(plant, obs_other, [1.0], [0.0], duration=1.0, u=0.0)
    with pytest.raises(InvalidArgumentError, match=r"dt=0\.1 but dt argument has dt=0\.05"):
        simulate(plant, obs_same, [1.0], [0.0], duration=1.0, dt=0.05, u=0.0)
    cont = LuenbergerObserver(LinearSystem([[0.9]], [[1.0]], [[1.0]]), [[0.5]])
    with pytest.raises(InvalidArgumentError, match="discrete-time observer"):
        simulate(plant, cont, [1.0], [0.0], duration=1.0, u=0.0)
    res = simulate(plant, obs_same, [1.0], [0.0], duration=1.0, dt=0.1, u=0.0)
    assert res.t.size == 11 and res.dt == 0.1
    alone = simulate(plant, None, [1.0], duration=1.0, u=0.0)  # the plant alone is iterated too
    np.testing.assert_allclose(alone.x[:, 0], 0.9 ** np.arange(11), rtol=1e-14)


def test_discrete_observer_on_a_continuous_plant() -> None:
    # Sampled-data observer: the plant's exact discretisation (A_d = e^{A dt}) with a discrete
    # Luenberger gain; the error obeys e_{k+1} = (A_d - L C) e_k up to RK4's error on the plant.
    A = np.array([[0.0, 1.0], [-1.0, -0.1]])
    C = np.array([[1.0, 0.0]])
    dt = 0.05
    plant = LinearSystem(A, np.zeros((2, 0)), C)
    Ad = sla.expm(A * dt)
    Ld = np.array([[0.8], [0.6]])
    obs = LuenbergerObserver(LinearSystem(Ad, np.zeros((2, 0)), C, time=Discrete(dt)), Ld)
    res = simulate(plant, obs, [1.0, 0.0], [0.0, 0.0], duration=3.0)
    assert res.dt == dt and res.method == "rk4+discrete observer"
    F = Ad - Ld @ C
    e = np.array([-1.0, 0.0])
    for k in range(res.t.size):
        np.testing.assert_allclose(res.error[k], e, rtol=0, atol=1e-6)
        e = F @ e


def test_save_every_keeps_the_grid_points_and_the_last_step() -> None:
    full = simulate(Pendulum(), PendulumObserver(), [0.3, 0.0], [0.0, 0.0], duration=1.0, dt=1e-3, u=_u)
    thin = simulate(Pendulum(), PendulumObserver(), [0.3, 0.0], [0.0, 0.0], duration=1.0, dt=1e-3, u=_u, save_every=300)
    np.testing.assert_allclose(thin.t, [0.0, 0.3, 0.6, 0.9, 1.0], atol=1e-12)
    idx = [0, 300, 600, 900, 1000]
    np.testing.assert_array_equal(thin.x, full.x[idx])
    np.testing.assert_array_equal(thin.x_hat, full.x_hat[idx])


def test_duration_not_a_multiple_of_dt_ends_at_the_next_grid_point() -> None:
    res = simulate(Pendulum(), None, [0.3, 0.0], duration=0.105, dt=0.01, u=0.0)
    assert res.t[-1] == pytest.approx(0.11)
    assert res.x_hat.shape == (12, 0)


def test_progress_bar_does_not_break_non_tty_output(capfd: pytest.CaptureFixture[str]) -> None:
    res = simulate(Pendulum(), PendulumObserver(), [0.3, 0.0], [0.0, 0.0], duration=0.5, dt=1e-3, u=0.0, progress=True)
    assert res.t.size == 501
    out, err = capfd.readouterr()
    assert "simulating" in err and out == ""
    simulate(Pendulum(), PendulumObserver(), [0.3, 0.0], [0.0, 0.0], duration=0.5, dt=1e-3, u=0.0)
    out, err = capfd.readouterr()
    assert out == "" and err == ""  # automatic mode: short run, no bar
