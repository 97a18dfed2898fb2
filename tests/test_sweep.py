"""Design sweeps over a parameter grid (``nlobs.simulate.sweep``), here, on threads and on a 2-worker Dask cluster,
and the γ sweep of Grip, Saberi & Johansen (Sec. 3.2) on top of it."""

from __future__ import annotations

import collections
import concurrent.futures as cf
import itertools
import math
import os
import time
import uuid
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

from nlobs.errors import DesignError, DesignInfeasible, InvalidArgumentError, UnknownNameError
from nlobs.linear import hinf_norm
from nlobs.papers.grip_example1 import X0, X_HAT0, example1_sigma1, example1_sigma2
from nlobs.simulate import simulate
from nlobs.simulate.executors import cluster
from nlobs.simulate.sweep import SweepProblem, SweepResult, prepared, sweep
from nlobs.synthesis.cascade_gain import design_cascade_gain, place_cascade_gain
from nlobs.systems.interconnected import interconnected_plant
from nlobs.observers.cascade import CascadeObserver
from nlobs.workflows.gamma_sweep import GammaSweep, GammaSweepRow, _GammaProblem, gamma_sweep

#: prepare() calls in this process, per problem key (a worker process has its own)
PREPARES: collections.Counter[str] = collections.Counter()


@dataclass(frozen=True)
class FirstOrder:
    """``G(s) = c b / (s − a) + d`` at the point ``(a, d)``: ‖G‖∞ by ``hinf_norm``; ``a ≥ 0`` is infeasible.

    ``a = 99`` raises a ZeroDivisionError (a bug, not a failed point); ``delay`` sleeps ``delay · (9 − a)`` s
    so later points finish first on a pool of threads.
    """

    tag: str
    b: float = 2.0
    c: float = 1.5
    delay: float = 0.0
    name: str = "first order"

    def key(self) -> str:
        return f"test_sweep.FirstOrder:{self.tag}"

    def prepare(self) -> dict[str, Any]:
        PREPARES[self.key()] += 1
        return {"B": np.array([[self.b]]), "C": np.array([[self.c]]), "pid": os.getpid()}

    def evaluate(self, prep: dict[str, Any], point: dict[str, float]) -> dict[str, Any]:
        a, d = point["a"], point.get("d", 0.0)
        if self.delay:
            time.sleep(self.delay * (9.0 - a))
        if a == 99.0:
            raise ZeroDivisionError("a bug in the problem")
        if a >= 0:
            raise DesignInfeasible(f"pole a = {a:g} is not in the open left half-plane", constraint="a < 0")
        hinf = hinf_norm(np.array([[a]]), prep["B"], prep["C"], np.array([[d]]))
        return {"hinf": float(hinf), "stable": True, "pid": os.getpid(), "prepares": PREPARES[self.key()],
                "prep_pid": prep["pid"], "done_at": time.perf_counter(), "label": f"a={a:g}"}


def closed_form(a: float, d: float, b: float = 2.0, c: float = 1.5) -> float:
    # |G(jω)|² = d² + (2 d c b (−a) + (c b)²)/(ω² + a²) is monotone in ω: the peak is at ω = 0 or ω → ∞
    return max(abs(d - c * b / a), abs(d))


def _problem(**kw: Any) -> FirstOrder:
    return FirstOrder(tag=uuid.uuid4().hex, **kw)


@pytest.fixture(scope="module")
def client() -> Any:
    pytest.importorskip("distributed")
    with cluster(workers=2) as c:
        yield c


# ------------------------------------------------------------------------------------------------ the grid
def test_cartesian_product_in_row_major_order() -> None:
    res = sweep(_problem(), {"a": [-1, -2, -3], "d": [0.0, 0.5]}, progress=False)
    assert isinstance(res, SweepResult) and res.names == ("a", "d")
    assert [tuple(p.values()) for p in res.points] == list(itertools.product([-1.0, -2.0, -3.0], [0.0, 0.5]))
    assert all(isinstance(v, float) for p in res.points for v in p.values())
    assert res.executor == "in-process" and res.workers == 1 and res.failed == 0 and len(res) == 6


def test_points_given_as_a_sequence_keep_their_order() -> None:
    pts = [{"a": -3.0, "d": 1.0}, {"a": -1.0, "d": 0.0}, {"d": 2.0, "a": -2.0}]
    res = sweep(_problem(), pts, chunk=2, progress=False)
    assert res.points == ({"a": -3.0, "d": 1.0}, {"a": -1.0, "d": 0.0}, {"a": -2.0, "d": 2.0})
    assert res.chunk == 2


def test_values_match_the_closed_form_hinf_norm() -> None:
    poles, ds = [-0.1, -0.5, -1.0, -4.0, -25.0], [0.0, 0.3, -2.0]
    res = sweep(_problem(), {"a": poles, "d": ds}, progress=False)
    want = [closed_form(a, d) for a, d in itertools.product(poles, ds)]
    np.testing.assert_allclose(res.column("hinf"), want, rtol=1e-7)
    np.testing.assert_array_equal(res.column("a"), [a for a, _ in itertools.product(poles, ds)])
    assert res.column("hinf")[0] == pytest.approx(30.0, rel=1e-7)  # c b / |a| = 3 / 0.1


def test_failed_points_are_recorded_with_their_reason() -> None:
    res = sweep(_problem(), {"a": [-1.0, 0.0, 2.0, -2.0]}, progress=False)
    assert res.ok == (True, False, False, True) and res.failed == 2
    assert res.values[1] is None and res.values[2] is None
    assert res.errors[0] is None
    assert res.errors[2] == "DesignInfeasible: pole a = 2 is not in the open left half-plane"
    h = res.column("hinf")
    assert np.isnan(h[1]) and np.isnan(h[2]) and h[3] == pytest.approx(1.5)
    np.testing.assert_array_equal(res.column("stable"), [1.0, np.nan, np.nan, 1.0])
    rows = res.table()
    assert rows[1] == {"a": 0.0, "hinf": None, "stable": None, "pid": None, "prepares": None, "prep_pid": None,
                       "done_at": None, "label": None, "error": res.errors[1]}
    d = res.to_dict()
    assert d["failed"] == 2 and d["points"] == 4 and d["rows"][2]["error"].startswith("DesignInfeasible")
    txt = res.summary()
    assert "4 points on in-process (1 worker), 2 failed" in txt and "a = 2: DesignInfeasible: pole a = 2" in txt
    with pytest.raises(InvalidArgumentError, match="label"):
        res.column("label")
    with pytest.raises(UnknownNameError, match="nope"):
        res.column("nope")


def test_other_exceptions_propagate_and_record_can_be_narrowed() -> None:
    with pytest.raises(ZeroDivisionError, match="a bug"):
        sweep(_problem(), {"a": [-1.0, 99.0]}, progress=False)
    with pytest.raises(DesignInfeasible):
        sweep(_problem(), {"a": [-1.0, 1.0]}, record=(), progress=False)
    res = sweep(_problem(), {"a": [1.0]}, record=DesignError, progress=False)
    assert res.errors[0].startswith("DesignInfeasible:")


def test_results_in_grid_order_whatever_the_completion_order() -> None:
    prob = _problem(delay=0.01)
    grid = {"a": [-8.0, -7.0, -6.0, -5.0, -4.0, -3.0, -2.0, -1.0]}
    with cf.ThreadPoolExecutor(max_workers=4) as pool:
        res = sweep(prob, grid, executor=pool, chunk=1, progress=False)
    assert res.executor == "executor" and res.workers == 4
    assert [p["a"] for p in res.points] == grid["a"]
    assert [v["label"] for v in res.values] == [f"a={a:g}" for a in grid["a"]]
    done = res.column("done_at")
    assert not np.all(np.diff(done) > 0)  # the later (shorter) points finished first
    np.testing.assert_allclose(res.column("hinf"), [closed_form(a, 0.0) for a in grid["a"]], rtol=1e-7)


def test_prepare_runs_once_per_process() -> None:
    prob = _problem()
    first = sweep(prob, {"a": [-1.0, -2.0, -3.0]}, chunk=1, progress=False)
    again = sweep(prob, {"a": [-4.0]}, progress=False)
    assert PREPARES[prob.key()] == 1
    assert set(first.column("prepares")) == {1.0} and again.values[0]["prepares"] == 1
    assert prepared(prob) is prepared(prob)
    assert isinstance(prob, SweepProblem)


@pytest.mark.parametrize(("grid", "match"), [
    ({}, "grid: no parameters"),
    ([], "grid: no points"),
    ({"a": []}, r"grid\['a'\]: no values"),
    ({"a": [1.0, math.nan]}, r"grid\['a'\]\[1\]: must be finite"),
    ({"a": [1.0, math.inf]}, "must be finite"),
    ({"a": [1.0, "2"]}, r"grid\['a'\]\[1\]: expected a real number"),
    ({"a": [True]}, "expected a real number"),
    ({"a": [1j]}, "expected a real number"),
    ({"a": 3.0}, r"grid\['a'\]: expected a sequence"),
    ({"a": "123"}, r"grid\['a'\]: expected a sequence"),
    ({"a": np.zeros((2, 2))}, "1-D"),
    ({"": [1.0]}, "non-empty text"),
    ({1: [1.0]}, "non-empty text"),
    ([{"a": 1.0}, {"b": 2.0}], r"grid\[1\]: every point needs the keys of the first, \['a'\]; missing \['a'\]"),
    ([{"a": 1.0}, {"a": 2.0, "b": 1.0}], r"grid\[1\].*unexpected \['b'\]"),
    ([{"a": 1.0}, 2.0], r"grid\[1\]: expected a mapping"),
    ([{}], r"grid\[0\]: expected a non-empty mapping"),
    ([{"a": math.nan}], r"grid\[0\]\['a'\]: must be finite"),
    ("abc", "grid: expected a mapping"),
    (3, "grid: expected a mapping"),
    ({"a": range(1001), "b": range(1001)}, "1002001 points; at most 1000000"),
])
def test_bad_grids_are_refused_naming_the_argument(grid: Any, match: str) -> None:
    with pytest.raises(InvalidArgumentError, match=match):
        sweep(_problem(), grid, progress=False)


def test_bad_problem_chunk_and_values_are_refused() -> None:
    with pytest.raises(InvalidArgumentError, match="problem: expected a SweepProblem"):
        sweep(object(), {"a": [1.0]})  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="chunk"):
        sweep(_problem(), {"a": [-1.0]}, chunk=0)
    with pytest.raises(InvalidArgumentError, match="record"):
        sweep(_problem(), {"a": [-1.0]}, record=ValueError("x"))  # type: ignore[arg-type]

    @dataclass(frozen=True)
    class Bad:
        out: Any
        name: str = "bad"

        def key(self) -> str:
            return "test_sweep.Bad"

        def prepare(self) -> None:
            return None

        def evaluate(self, prep: None, point: dict[str, float]) -> Any:
            return self.out

    for out, match in (([1.0], "returned a list"), ({"v": np.ones(2)}, "value 'v'.*ndarray"),
                       ({"a": 1.0}, "value name 'a' is a grid parameter"), ({"v": 1j}, "value 'v'.*complex"),
                       ({"v": np.complex128(1j)}, "value 'v'.*complex")):
        with pytest.raises(InvalidArgumentError, match=match):
            sweep(Bad(out), {"a": [1.0]}, progress=False)
    ok = sweep(Bad({"i": np.int64(3), "f": np.float32(0.5), "b": np.bool_(True), "n": None}), {"a": [1.0]})
    assert ok.values[0] == {"i": 3, "f": 0.5, "b": True, "n": None}
    assert type(ok.values[0]["i"]) is int and type(ok.values[0]["b"]) is bool


def test_summary_elides_long_tables_and_escapes_text() -> None:
    res = sweep(_problem(), {"a": -np.arange(1.0, 81.0)}, progress=False)
    lines = res.summary().splitlines()
    assert "  … 30 points …" in lines and len(lines) == 2 + 50 + 1
    fake = SweepResult("p\x1b[31m", ("a",), ({"a": 1.0},), (None,), ("Err: bad\nline",), "in-process", 1, 0.0)
    txt = fake.summary()
    assert "\x1b" not in txt and "\\x1b" in txt and "bad\\x0aline" in txt


# ------------------------------------------------------------------------------------------------ on Dask
def test_two_worker_cluster_gives_the_in_process_values(client: Any) -> None:
    grid = {"a": [-0.2, -1.0, -3.0, 0.5, -7.0, -11.0], "d": [0.0, 1.0]}
    here = sweep(_problem(), grid, progress=False)
    prob = _problem()
    there = sweep(prob, grid, executor=client, chunk=2, progress=False)
    assert there.executor == "dask" and there.workers == 2
    assert there.points == here.points and there.errors == here.errors
    for name in ("hinf", "stable", "label"):
        assert [None if v is None else v[name] for v in there.values] == \
               [None if v is None else v[name] for v in here.values]
    # prepare() once per worker process: every point saw one prepare in its process, made in that process
    pids = {v["pid"] for v in there.values if v is not None}
    assert os.getpid() not in pids and 1 <= len(pids) <= 2
    assert all(v["prepares"] == 1 and v["prep_pid"] == v["pid"] for v in there.values if v is not None)
    assert PREPARES[prob.key()] == 0  # never prepared here
    again = sweep(prob, grid, executor=client, chunk=1, progress=False)
    assert all(v["prepares"] == 1 for v in again.values if v is not None)  # kept per worker between sweeps


# ------------------------------------------------------------------------------------------------ γ sweep
S1 = example1_sigma1()
S2 = example1_sigma2()
PLANT = interconnected_plant(S1, S2)


def _simulate(obs: CascadeObserver) -> Any:
    return simulate(PLANT, obs, X0, X_HAT0, duration=1.0, dt=1e-3, save_every=10)


def _reference_gamma_sweep(gammas: list[float], *, method: str = "lmi", simulate: Any = None,
                           **kw: Any) -> GammaSweep:
    """The loop gamma_sweep ran before it ran on simulate.sweep, word for word (one design call per γ)."""
    rows = []
    for g in sorted((float(x) for x in gammas), reverse=True):
        try:
            if method == "lmi":
                cert = design_cascade_gain(S2, gamma=g, check_assumptions=False, **kw)
            else:
                cert = place_cascade_gain(S2, gamma=g, check_assumptions=False, **kw)
        except DesignError as exc:
            rows.append(GammaSweepRow(gamma=g, status=type(exc).__name__, message=str(exc)))
            continue
        eig = np.asarray(cert.eigenvalues)
        row: dict[str, Any] = {
            "gamma": g, "status": "ok", "hinf_H": float(cert.hinf_H),
            "hinf_G": float(cert.hinf_G) if cert.hinf_G is not None else math.nan,
            "gain_norm": cert.gain_norm, "slowest_pole": float(np.max(eig.real)),
            "fastest_pole": float(np.min(eig.real)), "K": tuple(tuple(float(v) for v in r) for r in cert.gain),
        }
        if simulate is not None:
            try:
                res = simulate(CascadeObserver(S1, S2, cert.gain))
            except ArithmeticError as exc:
                row.update(status=type(exc).__name__, message=str(exc))
            else:
                en = np.asarray(res.error_norm)
                row.update(initial_error=float(np.max(en[..., 0])), final_error=float(np.max(en[..., -1])),
                           decay_rate=float(np.min(np.asarray(res.decay_rate()))))
        rows.append(GammaSweepRow(**row))
    label = "LMI (14)" + (", (15)" if kw.get("gamma_n") is not None else "") if method == "lmi" else "pole placement"
    return GammaSweep(rows=tuple(rows), design=label)


def _assert_same_rows(a: GammaSweep, b: GammaSweep) -> None:
    assert a.design == b.design and len(a.rows) == len(b.rows)
    for ra, rb in zip(a.to_rows(), b.to_rows()):
        assert ra.keys() == rb.keys()
        for k, va in ra.items():
            vb = rb[k]
            if isinstance(va, float) and math.isnan(va):
                assert isinstance(vb, float) and math.isnan(vb), (ra["gamma"], k)
            else:
                assert va == vb, (ra["gamma"], k, va, vb)  # deterministic: bit for bit


LMI_CASE = ([0.3, 10.0, 1.0, 3.0, 0.1], {"gain_bound": 1e4})
PLACEMENT_CASE = ([0.3, 0.01], {"method": "placement", "simulate": _simulate})


@pytest.mark.slow
@pytest.mark.parametrize(("gammas", "kw"), [LMI_CASE, ([10.0, 1.0, 0.3], {"gamma_n": 5.0}), PLACEMENT_CASE],
                         ids=["lmi-gain-bound", "lmi-riccati-gamma-n", "placement-simulated"])
def test_gamma_sweep_rows_unchanged(gammas: list[float], kw: dict[str, Any]) -> None:
    new = gamma_sweep(S1, S2, gammas, **kw)
    _assert_same_rows(new, _reference_gamma_sweep(gammas, **kw))
    assert any(r.ok for r in new.rows)


@pytest.mark.slow
def test_gamma_sweep_on_two_workers_equals_in_process(client: Any) -> None:
    for gammas, kw in (LMI_CASE, PLACEMENT_CASE):
        here = gamma_sweep(S1, S2, gammas, **kw)
        there = gamma_sweep(S1, S2, gammas, executor=client, **kw)
        _assert_same_rows(here, there)
    assert [r.status for r in here.rows] == ["ok", "ok"] and not math.isnan(there.rows[1].decay_rate)


def test_gamma_problem_prepares_the_extended_system_once() -> None:
    p = _GammaProblem(S1, S2, "lmi", None, None, None, 1e4, "central", None, None)
    q = _GammaProblem(S1, S2, "placement", None, None, None, None, "central", None, _simulate)
    assert isinstance(p, SweepProblem) and p.key() == q.key()  # what prepare() builds depends on Σ₂ only
    ext = prepared(p)
    assert prepared(q) is ext and ext.A.shape == (3, 3)
    with pytest.raises(InvalidArgumentError, match="method"):
        gamma_sweep(S1, S2, [1.0], method="nope")
