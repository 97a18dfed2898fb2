"""The chunked Monte Carlo engine: numbers independent of chunking and workers, streaming, resuming.

Oracles: a direct :func:`simulate_batch` of the same batch generator (the study's numbers are the
loop's), Theorem 5.10 of Khajenejad & Yong (every certified ball holds the truth), and the
uninterrupted run itself for a run killed with SIGKILL and started again.
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError, OutputError
from nlobs.simulate.montecarlo import MonteCarloResult, RunBatch, batch_rng, chunk_path, monte_carlo, same_results
from nlobs.simulate.setvalued import SetValuedStudy, simulate_batch
from nlobs.methods.setvalued import class_check_box, design_setvalued_observer
from nlobs.methods.setvalued import load_setvalued_model as _load

SRC = str(Path(__file__).resolve().parents[1] / "src")


@pytest.fixture(scope="module")
def study() -> SetValuedStudy:
    m = _load("khajenejad-6-1")
    rep = design_setvalued_observer(m, samples=2000)
    return SetValuedStudy(m.system, rep.design, m.signals["bounded"], 40, "bounded", box=class_check_box(m),
                          default_batch=50)


def _same(a: MonteCarloResult, b: MonteCarloResult) -> None:
    assert a.summaries.keys() == b.summaries.keys()
    assert same_results(a, b)


def test_numbers_are_the_loops_and_independent_of_chunks(study: SetValuedStudy) -> None:
    ref = monte_carlo(study, 130, seed=7)
    assert ref.batch == 50 and ref.chunks == 3
    # batch 1 by hand: its own generator, the same loop
    direct = simulate_batch(study.system, study.design, study.unknown_input, runs=50, steps=40, seed=batch_rng(7, 1))
    e = np.linalg.norm(direct.x[:, -1] - direct.x_hat[:, -1], axis=-1)
    assert np.array_equal(ref.summaries["final_error"][50:100], e)
    # Theorem 5.10: the certified balls contain the truth, and the certificate covers every run
    assert ref.summaries["contained"].all() and ref.summaries["input_contained"].all()
    assert ref.summaries["covered"].all()
    assert ref.summaries["max_error_over_radius"].max() <= 1.0 + 1e-9
    for chunk in (1, 17, 50, 64, 130):
        _same(ref, monte_carlo(study, 130, seed=7, chunk=chunk))
    # another seed, other numbers; more runs keep the first ones
    assert not np.array_equal(monte_carlo(study, 130, seed=8).summaries["final_error"], ref.summaries["final_error"])
    more = monte_carlo(study, 200, seed=7)
    for k in ref.summaries:
        assert np.array_equal(more.summaries[k][:130], ref.summaries[k], equal_nan=ref.summaries[k].dtype.kind == "f")
    st = ref.statistics()
    assert st["contained"]["mean"] == 1.0 and st["final_error"]["max"] == float(ref.summaries["final_error"].max())
    assert "130 runs" in ref.summary() and ref.to_dict()["chunks"] == 3


def test_a_process_pool_gives_the_same_bits(study: SetValuedStudy) -> None:
    ref = monte_carlo(study, 100, seed=3)
    with cf.ProcessPoolExecutor(2) as pool:
        got = monte_carlo(study, 100, seed=3, chunk=30, executor=pool)
    assert got.executor == "executor" and got.workers == 2
    _same(ref, got)


@pytest.mark.slow
def test_a_two_worker_local_cluster_gives_the_same_bits(study: SetValuedStudy, tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    from nlobs.simulate.executors import cluster

    ref = monte_carlo(study, 150, seed=11)
    with cluster(workers=2) as client:
        got = monte_carlo(study, 150, seed=11, chunk=20, executor=client)
        assert got.executor == "dask" and got.workers == 2
        _same(ref, got)
        one = monte_carlo(study, 150, seed=11, batch=50, chunk=150, executor=client.scheduler.address)
        _same(ref, one)
        # streamed to disk by the client as chunks finish
        tr = monte_carlo(study, 150, seed=11, chunk=40, executor=client, out=tmp_path / "mc", trajectories=True)
        _same(ref, tr)
    assert len(list((tmp_path / "mc" / "chunks").glob("chunk-*.npz"))) == 4
    x = tr.trajectories("x", slice(35, 45))
    direct = simulate_batch(study.system, study.design, study.unknown_input, runs=50, steps=40, seed=batch_rng(11, 0))
    assert np.array_equal(x, direct.x[35:45])
    assert tr.trajectories("x_hat").shape == (150, 41, study.system.n)


def test_resume_skips_finished_chunks_and_refuses_another_study(study: SetValuedStudy, tmp_path: Path) -> None:
    out = tmp_path / "mc"
    ref = monte_carlo(study, 120, seed=5, chunk=30, out=out)
    assert ref.resumed_chunks == 0 and json.loads((out / "montecarlo.json").read_text())["chunk"] == 30
    chunk_path(out, 2).unlink()
    again = monte_carlo(study, 120, seed=5, chunk=30, out=out)
    assert again.resumed_chunks == 3
    _same(ref, again)
    with pytest.raises(InvalidArgumentError, match="another seed"):
        monte_carlo(study, 120, seed=6, chunk=30, out=out)
    with pytest.raises(InvalidArgumentError, match="another chunk"):
        monte_carlo(study, 120, seed=5, chunk=40, out=out)
    other = SetValuedStudy(study.system, study.design, study.unknown_input, 41, "bounded", default_batch=50)
    with pytest.raises(InvalidArgumentError, match="another the study"):
        monte_carlo(other, 120, seed=5, chunk=30, out=out)
    with pytest.raises(InvalidArgumentError, match="already holds"):
        monte_carlo(study, 120, seed=5, chunk=30, out=out, resume=False)


def test_damaged_chunks_are_computed_again(study: SetValuedStudy, tmp_path: Path) -> None:
    # before: a truncated, empty or garbage chunk ended in a BadZipFile traceback, a chunk missing a key in a
    # KeyError, and a chunk with the right `runs` field and 10 of its 30 rows was accepted as all of them
    out = tmp_path / "mc"
    ref = monte_carlo(study, 120, seed=5, chunk=30, out=out)
    good = chunk_path(out, 1).read_bytes()

    def damaged(kind: str) -> bytes:
        with np.load(chunk_path(out, 1)) as f:
            data = {k: f[k] for k in f.files}
        if kind == "short":  # 10 of 30 rows, the rest of the file consistent
            data = {k: (v[:10] if k.startswith("summary__") else v) for k, v in data.items()}
        elif kind == "missing":
            data.pop(next(k for k in data if k.startswith("summary__")))
        elif kind == "altered":
            k = next(k for k in data if k.startswith("summary__") and data[k].dtype.kind == "f")
            data[k] = data[k] + 1.0
        import io

        buf = io.BytesIO()
        np.savez(buf, **data)
        return buf.getvalue()

    for content in (good[: len(good) // 2], b"", b"not a zip file at all", damaged("short"), damaged("missing"),
                    damaged("altered")):
        chunk_path(out, 1).write_bytes(content)
        again = monte_carlo(study, 120, seed=5, chunk=30, out=out)
        assert again.resumed_chunks == 3  # the damaged one is computed again
        _same(ref, again)
        assert chunk_path(out, 1).read_bytes() == good  # and written anew, bit for bit


def test_bad_arguments(study: SetValuedStudy, tmp_path: Path) -> None:
    with pytest.raises(InvalidArgumentError, match="runs"):
        monte_carlo(study, 0)
    with pytest.raises(InvalidArgumentError, match="chunk"):
        monte_carlo(study, 10, chunk=0)
    with pytest.raises(InvalidArgumentError, match="trajectories"):
        monte_carlo(study, 10, trajectories=True)
    with pytest.raises(InvalidArgumentError, match="Study"):
        monte_carlo(object(), 10)  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="executor"):
        monte_carlo(study, 10, executor=42)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(OutputError):
        monte_carlo(study, 10, out=blocker / "sub")

    class Wrong:
        name = "wrong"
        default_batch = 4

        def key(self) -> str:
            return "wrong"

        def prepare(self) -> None:
            return None

        def run(self, prepared: object, rng: np.random.Generator, runs: int, trajectories: bool) -> RunBatch:
            return RunBatch({"v": rng.random(runs + 1)})

    with pytest.raises(InvalidArgumentError, match=r"shape \(5,\), expected \(4, \.\.\.\)"):
        monte_carlo(Wrong(), 8)


_SCRIPT = textwrap.dedent("""
    import sys
    from nlobs.simulate.montecarlo import monte_carlo
    from nlobs.simulate.setvalued import SetValuedStudy
    from nlobs.methods.setvalued import class_check_box, design_setvalued_observer
    from nlobs.methods.setvalued import load_setvalued_model as _load

    m = _load("khajenejad-6-1")
    rep = design_setvalued_observer(m, samples=2000)
    study = SetValuedStudy(m.system, rep.design, m.signals["bounded"], 400, "bounded", box=class_check_box(m),
                           default_batch=100)
    r = monte_carlo(study, 3000, seed=2, chunk=100, out=sys.argv[1])
    print("resumed", r.resumed_chunks)
""")


@pytest.mark.slow
def test_a_killed_run_finishes_from_its_last_chunk_with_identical_results(tmp_path: Path) -> None:
    script = tmp_path / "run.py"
    script.write_text(_SCRIPT)
    out = tmp_path / "mc"
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen([sys.executable, str(script), str(out)], env=env)
    deadline = time.monotonic() + 120
    while len(list((out / "chunks").glob("chunk-*.npz"))) < 3 and time.monotonic() < deadline:
        assert proc.poll() is None, "the run ended before it could be killed"
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    written = len(list((out / "chunks").glob("chunk-*.npz")))
    assert 3 <= written < 30
    done = subprocess.run([sys.executable, str(script), str(out)], env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert int(done.stdout.split()[-1]) >= written
    assert not list((out / "chunks").glob(".*.tmp"))
    fresh = subprocess.run([sys.executable, str(script), str(tmp_path / "fresh")], env=env, capture_output=True,
                           text=True, timeout=300)
    assert fresh.returncode == 0 and fresh.stdout.split()[-1] == "0"
    for c in range(30):
        with np.load(chunk_path(out, c)) as a, np.load(chunk_path(tmp_path / "fresh", c)) as b:
            assert a.files == b.files
            for k in a.files:
                assert np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f"), (c, k)


def test_plant_study_is_the_loop_and_its_closed_form() -> None:
    from nlobs.observers.luenberger import LuenbergerObserver
    from nlobs.simulate.plant_study import PlantStudy
    from nlobs.simulate.sampling import MeasurementGroup
    from nlobs.systems.linear import LinearSystem

    sys_ = LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]], states=("pos",))
    obs = LuenbergerObserver(sys_, [[3.0]])  # error dynamics ė = −4 e without noise
    exact = PlantStudy("scalar, L = 3", sys_, obs, [1.0], [1.0], 0.5, duration=1.0, dt=1e-3, default_batch=8)
    r = monte_carlo(exact, 20, seed=4)
    e0 = batch_rng(4, 1).standard_normal((8, 1))[:, 0] * 0.5  # batch 1 holds runs 8..15
    np.testing.assert_allclose(r.summaries["final_error"][8:16], np.abs(e0) * np.exp(-4.0), rtol=1e-9)
    assert not r.summaries["diverged"].any()
    noisy = PlantStudy("scalar, L = 3, noisy", sys_, obs, [1.0], [1.0], 0.5, duration=1.0, dt=1e-3,
                       measurements=[MeasurementGroup("pos", [0], rate=100.0, noise_std=0.01)], after=0.5,
                       tol=0.05, default_batch=8)
    ref = monte_carlo(noisy, 20, seed=4)
    _same(ref, monte_carlo(noisy, 20, seed=4, chunk=3))
    with cf.ProcessPoolExecutor(2) as pool:
        _same(ref, monte_carlo(noisy, 20, seed=4, chunk=5, executor=pool))
    e0 = np.concatenate([batch_rng(4, k).standard_normal((8, 1))[:, 0] * 0.5 for k in range(3)])[:20]
    # after 0.5 s the initial error has decayed to |e0| e^{-2}; the sensor noise (σ = 0.01) adds little
    assert ref.summaries["rms_error"].shape == (20, 1)
    assert np.all(ref.summaries["rms_error"][:, 0] <= np.abs(e0) * np.exp(-2.0) + 0.02)
    with pytest.raises(InvalidArgumentError, match="label"):
        PlantStudy("", sys_, obs, [1.0], [1.0], 0.5, duration=1.0)


@pytest.mark.slow
def test_compare_runs_its_observers_as_tasks_with_the_same_numbers() -> None:
    from nlobs.workflows.compare import compare_observers

    kw = {"observers": ["luenberger", "ekf"], "runs": 4, "duration": 1.0, "rate": 50.0, "noise_std": 0.01}
    here = compare_observers("pendulum", **kw)
    with cf.ProcessPoolExecutor(2) as pool:
        there = compare_observers("pendulum", executor=pool, **kw)
    for name in kw["observers"]:
        a, b = here.observers[name], there.observers[name]
        assert a.skipped is None and a.rms_error == b.rms_error and a.final_error_norm == b.final_error_norm
        assert np.array_equal(a.convergence_time, b.convergence_time, equal_nan=True)
        assert np.array_equal(a.result.x_hat, b.result.x_hat)
        assert np.array_equal(a.run_rms, b.run_rms, equal_nan=True)
    with pytest.raises(InvalidArgumentError, match="give one"):
        compare_observers("pendulum", workers=1, scheduler="tcp://127.0.0.1:1", **kw)
