"""What a Dask worker costs before it does useful work: its CPU time at start and after its first task.

A fresh 2-worker LocalCluster (:func:`nlobs.simulate.executors.cluster`, the one ``--workers`` starts) is asked,
on each worker, for the CPU time (user + system, ``getrusage`` of the worker process) it has used: once when it is
up, once after it has run its first chunk of a study (the worker imports what the chunk needs and unpickles the
study), for the set-valued study of Khajenejad & Yong (Example 6.1, one batch × 300 steps) and the GNSS/INS flights
(observer (24) of Grip, Saberi & Johansen, one batch × 20 s), each on its own fresh cluster. The libraries each worker
holds then are listed: CVXPY and Matplotlib are the parent's business (the design, the figures), not a worker's.

Run: ``PYTHONPATH=src python benchmarks/worker_startup.py`` (about a minute).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from scale_out import gnss, setvalued  # noqa: E402  (the studies of the scale-out benchmark)

HEAVY = ("cvxpy", "matplotlib", "sympy", "scipy", "numpy", "nlobs")


def probe() -> tuple[float, list[str]]:
    """In a worker: its CPU seconds so far and the heavy libraries it has imported."""
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime, sorted({m.split(".")[0] for m in sys.modules} & set(HEAVY))


def main() -> None:
    from nlobs.simulate.executors import cluster
    from nlobs.simulate.montecarlo import monte_carlo

    print("CPU seconds of each of 2 Dask workers (getrusage), at start and after its first chunk")
    print(f"{'study':<12} {'at start':>9} {'after 1st chunk':>16}  libraries a worker holds")
    for label, build in (("set-valued", lambda: setvalued(300)), ("GNSS/INS", lambda: gnss(20.0))):
        study = build()
        with cluster(workers=2) as client:
            start = client.run(probe)
            monte_carlo(study, 2 * study.default_batch, seed=1, executor=client)
            after = client.run(probe)
        s0 = max(v[0] for v in start.values())
        s1 = max(v[0] for v in after.values())
        libs = sorted(set().union(*(v[1] for v in after.values())))
        print(f"{label:<12} {s0:>9.2f} {s1:>16.2f}  {', '.join(libs)}")


if __name__ == "__main__":
    main()
