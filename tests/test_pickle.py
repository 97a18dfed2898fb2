"""Standard pickle of what nlobs returns: results, certificates, designs, compiled models and compiled observers.

Each object is made in a fresh worker process (a ``spawn`` :class:`~concurrent.futures.ProcessPoolExecutor`: nothing
inherited, every byte through :mod:`pickle`) and compared in this process with the same object made here: the same
report, the same certificate (re-verified here), an observer or a model that computes the same bits, a result whose
arrays stay read-only.
"""

from __future__ import annotations

import json
import multiprocessing
import pickle
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np
import pytest

import nlobs
from nlobs.methods.problem import problem
from nlobs.methods.registry import get

#: One design of every method of the registry, on a shipped model it applies to.
DESIGNS = [("drift", "pendulum"), ("pinv", "isidori-146"), ("luenberger", "gnss-ins-axis"), ("luenberger", "pendulum"),
           ("cascade", "chemostat-analyser"), ("ekf", "cartpole"), ("ukf", "cartpole"), ("setvalued", "khajenejad-6-1"),
           ("gnss-ins", "gnss-ins")]


@pytest.fixture(scope="module")
def pool():  # type: ignore[no-untyped-def]
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as ex:
        yield ex


def _design(method: str, model: str) -> Any:
    return get(method).design(model if method == "gnss-ins" else problem(model))


def _simulate(model: str) -> Any:
    m = nlobs.load_model(model).compile()
    return nlobs.simulate(m, None, np.array([1.0, 0.0]), duration=0.5, dt=0.01, u=np.zeros(m.m))


def _compare(model: str) -> Any:
    from nlobs.workflows.compare import compare_observers

    return compare_observers(model, observers=["drift", "ekf"], runs=2, duration=1.0, rate=50.0, noise_std=0.01,
                             seed=3, progress=False)


def _compiled(method: str, model: str) -> Any:
    return nlobs.compile_observer(_design(method, model).observer)


def _untimed(v: Any) -> Any:
    """``v`` without the clock's readings (a solver's seconds, a run's wall time): the rest must be equal."""
    if isinstance(v, dict):
        return {k: _untimed(x) for k, x in v.items() if not k.endswith(("seconds", "wall_s", "_us"))}
    if isinstance(v, (list, tuple)):
        return [_untimed(x) for x in v]
    return v


def _plain(d: dict[str, Any]) -> str:
    return json.dumps(_untimed(d), sort_keys=True, default=str)


@pytest.mark.slow
@pytest.mark.parametrize(("method", "model"), DESIGNS)
def test_a_design_comes_back_from_a_worker_with_its_certificate(pool, method: str, model: str) -> None:
    theirs = pool.submit(_design, method, model).result()
    ours = _design(method, model)
    assert type(theirs) is type(ours) and type(theirs.observer) is type(ours.observer)
    assert _plain(theirs.to_dict()) == _plain(ours.to_dict())
    assert theirs.description == ours.description and theirs.usable
    if ours.certificate is not None:
        assert _plain(theirs.certificate.to_dict()) == _plain(ours.certificate.to_dict())
        assert theirs.certificate.verified and theirs.verified
        assert all(c.passed == d.passed and c.value == d.value
                   for c, d in zip(theirs.certificate.checks, ours.certificate.checks, strict=True))
    if method != "gnss-ins":  # the observer computes the same bits (its compiled functions made again there)
        m = ours.observer
        pb = problem(model)
        x0 = np.asarray(pb.x0, dtype=float)
        plant = pb.model.compile() if hasattr(pb.model, "compile") else pb.model
        u = np.full(plant.m, 0.1)
        y = plant.output(0.0, x0, u)
        z_ours, z_theirs = m.init(x0 + 0.01), theirs.observer.init(x0 + 0.01)
        if hasattr(m, "correct"):  # a correcting observer takes the sample first
            fresh = np.ones(plant.p, dtype=bool)
            z_ours, z_theirs = m.correct(0.0, z_ours, u, y, fresh), theirs.observer.correct(0.0, z_theirs, u, y, fresh)
        a, b = m.rhs(0.0, z_ours, u, y), theirs.observer.rhs(0.0, z_theirs, u, y)
        flat = [np.asarray(v, dtype=float) for v in (vars(a).values() if hasattr(a, "__dict__") else (a,))]
        flat_b = [np.asarray(v, dtype=float) for v in (vars(b).values() if hasattr(b, "__dict__") else (b,))]
        assert all(np.array_equal(p, q, equal_nan=True) for p, q in zip(flat, flat_b, strict=True))


def test_a_simulation_result_comes_back_read_only(pool) -> None:
    theirs = pool.submit(_simulate, "pendulum").result()
    ours = _simulate("pendulum")
    for key in ("t", "x", "x_hat", "y"):
        assert np.array_equal(getattr(theirs, key), getattr(ours, key))
        assert not getattr(theirs, key).flags.writeable
    assert theirs.states == ours.states and _untimed(dict(theirs.info)) == _untimed(dict(ours.info))
    with pytest.raises(TypeError):
        theirs.info["x"] = 1  # type: ignore[index]


@pytest.mark.slow
def test_a_comparison_report_comes_back_from_a_worker(pool) -> None:
    theirs = pool.submit(_compare, "pendulum").result()
    ours = _compare("pendulum")
    assert _plain(theirs.to_dict()) == _plain(ours.to_dict())
    assert np.array_equal(theirs.observers["ekf"].result.x_hat, ours.observers["ekf"].result.x_hat)


def test_compiled_models_pickle_and_compute_the_same_bits() -> None:
    m = nlobs.load_model("cartpole").compile()
    back = pickle.loads(pickle.dumps(m))
    x, u = np.array([[0.1, 0.2, 3.0, -0.4], [0.0, 1.0, 2.5, 0.3]]), np.array([[0.5], [-1.0]])
    assert np.array_equal(back.rhs(0.0, x, u), m.rhs(0.0, x, u))
    assert np.array_equal(back.rhs_jacobian_x(0.0, x, u), m.rhs_jacobian_x(0.0, x, u))
    fn = pickle.loads(pickle.dumps(m._rhs))  # a compiled function alone: compiled again from its expressions
    assert np.array_equal(fn(x, u), m._rhs(x, u))


@pytest.mark.slow
def test_a_compiled_observer_comes_back_from_a_worker(pool) -> None:
    from nlobs.export import find_compiler

    if find_compiler() is None:
        pytest.skip("no C compiler")
    theirs = pool.submit(_compiled, "drift", "pendulum").result()
    ours = _compiled("drift", "pendulum")
    assert theirs.name == ours.name and theirs.program.prefix == ours.program.prefix
    z = ours.init(np.array([[0.3, 0.1], [1.0, -0.5]]))
    u, y = np.zeros((2, 1)), np.array([[0.2], [0.9]])
    assert np.array_equal(theirs.step(0.0, z, u, y, 0.01), ours.step(0.0, z, u, y, 0.01))


def test_a_compiled_plant_pickles() -> None:
    from nlobs.export import find_compiler
    from nlobs.export.plant import compile_plant

    if find_compiler() is None:
        pytest.skip("no C compiler")
    p = compile_plant(nlobs.load_model("pendulum"))
    back = pickle.loads(pickle.dumps(p))
    x, u = np.array([[0.3, 0.1]]), np.array([[0.2]])
    assert np.array_equal(back.rhs(0.0, x, u), p.rhs(0.0, x, u)) and back.name == p.name


def test_a_frozen_mapping_is_read_only_and_pickles() -> None:
    from nlobs._frozen import FrozenMapping

    m = FrozenMapping({"a": 1.0, "b": (2, 3)})
    back = pickle.loads(pickle.dumps(m))
    assert back == m == {"a": 1.0, "b": (2, 3)} and type(back) is FrozenMapping and len(back) == 2
    with pytest.raises(TypeError):
        m["a"] = 2.0  # type: ignore[index]
    with pytest.raises(AttributeError):
        m._data = {}  # type: ignore[misc]
