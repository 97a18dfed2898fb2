"""The commands people run all day on a small shipped model, in CPU time, against the import floor.

The floor is a fresh interpreter importing what every such command needs, ``import numpy, scipy.linalg,
sympy``. Each command runs as the console script runs it (``from nlobs.cli import app; app()``) in a fresh
interpreter; its CPU time (user + system, of the child, from ``getrusage(RUSAGE_CHILDREN)``) is measured,
so a busy machine slows it far less than the wall clock. The commands take turns, ``ROUNDS`` times each
(floor, analyze, advise, design, export, then again); the best CPU time of each is set against the
floor's best. Target (everyday speed): each ≤ 2× the floor. CVXPY, Matplotlib and Dask are imported
only by a command that uses them; the line ``imports`` says which of them each command loaded.

Each command must also print the same answer every round: the symbolic budget of ``nlobs analyze`` counts
work, not the clock, so nothing in the output may depend on the machine's load (the line ``same
answer`` says whether the outputs of all rounds were equal).

Run: ``PYTHONPATH=src python benchmarks/command_cost.py`` (about a minute).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cli_startup import _cpu_children  # noqa: E402  (the CPU time of the children, the one way both scripts read it)
from cli_startup import _environment as cli_environment  # noqa: E402

ROUNDS = 5
TARGET = 2.0
MODEL = "pendulum"

#: What the console script ``nlobs = "nlobs.cli:app"`` runs, and a report of the heavy modules it loaded (stderr).
LAUNCHER = ("import sys\nfrom nlobs.cli import app\nsys.argv[0] = 'nlobs'\n"
            "try:\n    app()\nexcept SystemExit as exc:\n    code = exc.code\nelse:\n    code = 0\n"
            "heavy = [m for m in ('cvxpy', 'matplotlib', 'dask') if m in sys.modules]\n"
            "sys.stderr.write('LOADED ' + ','.join(heavy) + '\\n')\nsys.exit(code)\n")


def _environment() -> dict[str, str]:
    """``cli_startup``'s environment of the runs (``PYTHONPATH`` to this nlobs, bytecode written), one BLAS thread."""
    env = cli_environment()
    env.update(COLUMNS="100", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    return env


def _once(args: list[str], env: dict[str, str]) -> tuple[float, str, str]:
    before = _cpu_children()
    proc = subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True, check=False)
    cpu = _cpu_children() - before
    if proc.returncode != 0:
        raise SystemExit(f"command_cost: {args[2:]!r} exited {proc.returncode}: {proc.stderr[-500:]}")
    loaded = next((ln[7:] for ln in proc.stderr.splitlines() if ln.startswith("LOADED ")), "")
    return cpu, proc.stdout, loaded


def main() -> None:
    env = _environment()
    out = Path(tempfile.mkdtemp(prefix="nlobs-command-cost-"))
    commands: dict[str, list[str]] = {
        "import numpy, scipy.linalg, sympy": ["-c", "import numpy, scipy.linalg, sympy"],
        f"nlobs analyze {MODEL}": ["-c", LAUNCHER, "analyze", MODEL],
        f"nlobs advise {MODEL}": ["-c", LAUNCHER, "advise", MODEL],
        f"nlobs design drift {MODEL}": ["-c", LAUNCHER, "design", "drift", MODEL],
        f"nlobs export {MODEL} --observer drift": ["-c", LAUNCHER, "export", MODEL, "--observer", "drift",
                                                   "--out", str(out / "c")],
    }
    cpu: dict[str, list[float]] = {name: [] for name in commands}
    outputs: dict[str, set[str]] = {name: set() for name in commands}
    loaded: dict[str, str] = {}
    for args in commands.values():  # one warm-up each (file-system caches, .pyc files)
        _once(args, env)
    for _ in range(ROUNDS):
        for name, args in commands.items():
            t, text, heavy = _once(args, env)
            cpu[name].append(t)
            outputs[name].add(text.replace(str(out), "OUT"))
            loaded[name] = heavy
    floor = min(cpu["import numpy, scipy.linalg, sympy"])
    print(f"CPU time of a fresh interpreter per command, best and median of {ROUNDS} interleaved rounds "
          f"(model {MODEL}; {sys.executable})")
    print(f"{'command':<44} {'best [s]':>9} {'median':>7} {'× floor':>8}  same answer  imports")
    verdicts = []
    for name in commands:
        best, med = min(cpu[name]), statistics.median(cpu[name])
        ratio = best / floor
        same = "yes" if len(outputs[name]) == 1 else f"NO ({len(outputs[name])} different)"
        if name.startswith("nlobs"):
            verdicts.append(ratio <= TARGET and len(outputs[name]) == 1)
        print(f"{name:<44} {best:>9.3f} {med:>7.3f} {ratio:>7.2f}×  {same:<11}  {loaded[name] or '-'}")
    print(f"target: every command ≤ {TARGET:g}× the import floor, the same answer every round: "
          + ("met" if all(verdicts) else "MISSED"))


if __name__ == "__main__":
    main()
