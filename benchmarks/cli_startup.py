"""Start-up time of the ``nlobs`` command line: ``nlobs version`` and ``nlobs --help`` against a bare interpreter.

Each command runs in a fresh interpreter, as the installed console script runs it (``from nlobs.cli
import app; sys.exit(app())``), with the ``nlobs`` package this script itself would import (the
checkout under ``PYTHONPATH=src``, else the installed one). The three commands take turns
(``python -c pass``, a bare typer app, ``nlobs version``, ``nlobs --help``, then again), ``RUNS`` times
each, so a busy machine slows all of them alike; the median CPU time of each (the child's user + system time,
from ``getrusage``, which load changes far less than the wall clock) is printed beside the
target (≤ 0.3 s) and its ratio to the bare interpreter's start. The bare typer app (one command that
prints a line) is the floor no typer command line goes below.

The command line imports NumPy, SciPy, SymPy, Matplotlib and CVXPY only inside the command that needs
them (``tests/test_cli_startup.py`` checks that none is loaded by these two commands); what is left
is typer (which builds every command's parameters and, to run one, imports pydantic) and rich (which
renders the help).

Run: ``PYTHONPATH=src python benchmarks/cli_startup.py`` (15–30 s).
"""

from __future__ import annotations

import importlib.util
import os
import resource
import statistics
import subprocess
import sys
from pathlib import Path

RUNS = 15
TARGET_S = 0.3

#: What the console script ``nlobs = "nlobs.cli:app"`` runs.
LAUNCHER = "import sys\nfrom nlobs.cli import app\nsys.argv[0] = 'nlobs'\nsys.exit(app())\n"

#: The floor set by typer itself: an app with one command that prints a line (typer builds the command tree and
#: coerces the parameters of every invocation, which imports pydantic in typer ≥ 0.2x).
TYPER_APP = ("import sys\nimport typer\napp = typer.Typer(add_completion=False)\n"
             "@app.command()\ndef version() -> None:\n    print('0')\n"
             "@app.command()\ndef other(a: str = '') -> None:\n    pass\n"
             "sys.argv[0] = 'nlobs'\napp()\n")

COMMANDS: dict[str, list[str]] = {
    "python -c pass": ["-c", "pass"],
    "bare typer app": ["-c", TYPER_APP, "version"],
    "nlobs version": ["-c", LAUNCHER, "version"],
    "nlobs --help": ["-c", LAUNCHER, "--help"],
}


def _environment() -> dict[str, str]:
    """The environment of the runs: ``PYTHONPATH`` starts with the folder that holds the ``nlobs`` imported here."""
    spec = importlib.util.find_spec("nlobs")  # finds the package without importing it
    if spec is None or spec.origin is None:
        raise SystemExit("cli_startup: nlobs is not importable (run with PYTHONPATH=src)")
    root = str(Path(spec.origin).resolve().parent.parent)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([root, *filter(None, [env.get("PYTHONPATH")])])
    env.setdefault("COLUMNS", "100")
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as installed: nlobs with its bytecode, written by the warm-up runs
    return env


def _cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _once(args: list[str], env: dict[str, str]) -> float:
    t0 = _cpu_children()
    proc = subprocess.run([sys.executable, *args], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          check=False)
    elapsed = _cpu_children() - t0
    if proc.returncode != 0:
        raise SystemExit(f"cli_startup: {args[-1]!r} exited {proc.returncode}: {proc.stderr.decode()[-500:]}")
    return elapsed


def main() -> None:
    env = _environment()
    times: dict[str, list[float]] = {name: [] for name in COMMANDS}
    for args in COMMANDS.values():  # one warm-up each (file-system caches, .pyc files)
        _once(args, env)
    for _ in range(RUNS):
        for name, args in COMMANDS.items():
            times[name].append(_once(args, env))
    base = statistics.median(times["python -c pass"])
    print(f"nlobs CLI start-up: median CPU time (user + system) of {RUNS} interleaved runs each ({sys.executable})")
    print(f"{'command':16s} {'median [s]':>10s} {'target [s]':>10s} {'× python':>9s}")
    for name, ts in times.items():
        med = statistics.median(ts)
        target = "" if not name.startswith("nlobs") else f"≤ {TARGET_S:.1f}"
        verdict = "" if not target else ("  ok" if med <= TARGET_S else "  above the target")
        print(f"{name:16s} {med:10.3f} {target:>10s} {med / base:9.1f}{verdict}")


if __name__ == "__main__":
    main()
