"""Monte Carlo on Dask: identical numbers, speed-up of a 2-worker LocalCluster, flat memory, resume.

Measured in one run, on this machine:

1. **Bitwise identity.** The set-valued study of Khajenejad & Yong (Example 6.1, 2000 runs × 300 steps)
   and the GNSS/INS study (observer (24) of Grip, Saberi & Johansen with the demo's noise-optimal gain and
   scheduled Γ(t), 100 flights × 20 s, initial attitude errors up to 90°) in this
   process with the default chunk, with chunks of 1 batch, of 7 runs (not a multiple of a batch) and
   of 3 batches, and on 1 and 2 LocalCluster workers: every per-run summary compared bit for bit.
2. **Speed-up.** ``--runs`` (default 10⁴) set-valued runs × 300 steps and ``--flights`` (default 2000)
   GNSS/INS flights × 60 s, in this process against a 2-worker LocalCluster started before the clock
   (its start-up time is printed too). Target ≥ 1.6×.
3. **Memory.** Peak resident memory (``ru_maxrss`` of a child process that loads the study designed here,
   so that the design's own peak does not hide the runs') for 10³ and 10⁵ set-valued runs × 100 steps,
   summaries only. Target: 10⁵ ≤ 1.5 × 10³.
4. **Resume.** A run of 3000 set-valued runs into a folder killed with SIGKILL after 3 chunk files,
   started again: chunks read back, and every chunk file equal to an uninterrupted run's.

Run ``python benchmarks/scale_out.py [--runs N] [--flights N] [--json]`` (a few minutes).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

SRC = str(Path(__file__).resolve().parents[1] / "src")

HERE = str(Path(__file__).resolve().parent)


def setvalued(steps: int):
    """The set-valued study of Example 6.1 (its sound design), ``steps`` steps per run."""
    from nlobs.simulate.setvalued import SetValuedStudy
    from nlobs.methods.setvalued import class_check_box, design_setvalued_observer
    from nlobs.methods.setvalued import load_setvalued_model as _load

    m = _load("khajenejad-6-1")
    return SetValuedStudy(m.system, design_setvalued_observer(m).design, m.signals["bounded"], steps, "bounded",
                          box=class_check_box(m))


def gnss(duration: float):
    from nlobs.navigation.montecarlo import GnssInsStudy
    from nlobs.workflows.demo import DEMO_NOISE

    # the demo's default: noise-optimal K, Γ(t) scheduled; the gain solved here once, re-verified per worker
    return GnssInsStudy(noise=DEMO_NOISE, duration=duration, gains="scheduled").solved()


def same(a, b) -> bool:
    from nlobs.simulate.montecarlo import same_results

    return same_results(a, b)


def child(code: str, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True, check=True)


_RSS = textwrap.dedent("""
    import pickle, resource, sys
    from nlobs.simulate.montecarlo import monte_carlo
    with open(sys.argv[2], "rb") as fh:
        study = pickle.load(fh)  # designed in the parent: the peak below is the imports and the runs
    monte_carlo(study, int(sys.argv[1]), seed=1)
    print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
""")

_RESUME = textwrap.dedent("""
    import sys
    from nlobs.simulate.montecarlo import monte_carlo
    sys.path.insert(0, sys.argv[2])
    from scale_out import setvalued
    r = monte_carlo(setvalued(400), 3000, seed=2, batch=100, chunk=100, out=sys.argv[1])
    print(r.resumed_chunks)
""")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=10_000)
    ap.add_argument("--flights", type=int, default=2000)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    from nlobs.simulate.executors import cluster
    from nlobs.simulate.montecarlo import chunk_path, monte_carlo

    out: dict = {}
    sv300, sv_short = setvalued(300), gnss(20.0)
    t0 = time.perf_counter()
    with cluster(workers=2) as two:
        out["cluster_start_s"] = time.perf_counter() - t0
        with cluster(workers=1) as one:
            checks = {}
            for label, st, runs in (("setvalued", sv300, 2000), ("gnss_ins", sv_short, 100)):
                ref = monte_carlo(st, runs, seed=4)
                b = ref.batch
                checks[label] = {
                    "chunk=batch": same(ref, monte_carlo(st, runs, seed=4, chunk=b)),
                    "chunk=7": same(ref, monte_carlo(st, runs, seed=4, chunk=7)),
                    "chunk=3 batches": same(ref, monte_carlo(st, runs, seed=4, chunk=3 * b)),
                    "1 worker": same(ref, monte_carlo(st, runs, seed=4, executor=one)),
                    "2 workers": same(ref, monte_carlo(st, runs, seed=4, executor=two)),
                    "2 workers, chunk=7": same(ref, monte_carlo(st, runs, seed=4, chunk=7, executor=two)),
                }
            out["bitwise_identical"] = checks
        speed = {}
        for label, st, runs in (("setvalued 300 steps", sv300, args.runs), ("gnss_ins 60 s", gnss(60.0), args.flights)):
            monte_carlo(st, 2 * st.default_batch, seed=9, executor=two)  # each worker prepares the study once
            monte_carlo(st, st.default_batch, seed=9)
            t = time.perf_counter()
            a = monte_carlo(st, runs, seed=0)
            t_in = time.perf_counter() - t
            t = time.perf_counter()
            b = monte_carlo(st, runs, seed=0, executor=two)
            t_two = time.perf_counter() - t
            speed[label] = {"runs": runs, "in_process_s": t_in, "two_workers_s": t_two, "speedup": t_in / t_two,
                            "identical": same(a, b), "target": 1.6, "met": t_in / t_two >= 1.6}
        out["speedup"] = speed
    import cloudpickle

    with tempfile.TemporaryDirectory() as tmp:
        blob = Path(tmp) / "study.pkl"
        blob.write_bytes(cloudpickle.dumps(setvalued(100)))
        rss = {n: int(child(_RSS, str(n), str(blob)).stdout.split()[-1]) for n in (1000, 100_000)}
    out["peak_rss_kib"] = {"runs_1e3": rss[1000], "runs_1e5": rss[100_000], "ratio": rss[100_000] / rss[1000],
                           "target": 1.5, "met": rss[100_000] / rss[1000] <= 1.5}
    with tempfile.TemporaryDirectory() as tmp:
        killed, fresh = Path(tmp) / "killed", Path(tmp) / "fresh"
        code = _RESUME
        env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
        proc = subprocess.Popen([sys.executable, "-c", code, str(killed), HERE], env=env, stdout=subprocess.PIPE)
        while len(list((killed / "chunks").glob("chunk-*.npz"))) < 3 and proc.poll() is None:
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        at_kill = len(list((killed / "chunks").glob("chunk-*.npz")))
        resumed = int(child(code, str(killed), HERE).stdout.split()[-1])
        child(code, str(fresh), HERE)
        equal = True
        for c in range(30):
            with np.load(chunk_path(killed, c)) as x, np.load(chunk_path(fresh, c)) as y:
                equal &= x.files == y.files and all(np.array_equal(x[k], y[k], equal_nan=x[k].dtype.kind == "f")
                                                    for k in x.files)
        out["resume"] = {"chunks_at_kill": at_kill, "chunks_resumed": resumed, "chunks": 30, "identical": bool(equal)}
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"LocalCluster of 2 workers started in {out['cluster_start_s']:.2f} s (not in the timings below)")
    for label, c in out["bitwise_identical"].items():
        print(f"bitwise identical, {label}: " + ", ".join(f"{k} {'yes' if v else 'NO'}" for k, v in c.items()))
    for label, s in out["speedup"].items():
        print(f"{label}: {s['runs']} runs, in-process {s['in_process_s']:.2f} s, 2 workers {s['two_workers_s']:.2f} s,"
              f" speed-up {s['speedup']:.2f}x (target >= 1.6: {'met' if s['met'] else 'NOT met'}), identical "
              f"{'yes' if s['identical'] else 'NO'}")
    r = out["peak_rss_kib"]
    print(f"peak RSS, summaries only: 1e3 runs {r['runs_1e3'] / 1024:.0f} MiB, 1e5 runs {r['runs_1e5'] / 1024:.0f} MiB,"
          f" ratio {r['ratio']:.2f} (target <= 1.5: {'met' if r['met'] else 'NOT met'})")
    s = out["resume"]
    print(f"SIGKILL after {s['chunks_at_kill']} of {s['chunks']} chunks; the restart read {s['chunks_resumed']} back; "
          f"every chunk identical to an uninterrupted run: {'yes' if s['identical'] else 'NO'}")


if __name__ == "__main__":
    main()
