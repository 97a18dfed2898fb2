"""The command line starts without the numeric stack: importing the app, ``nlobs version`` and every ``--help``
load none of NumPy, SciPy, SymPy, Matplotlib and CVXPY (each command imports them when it runs).

Structural, not timed: each check runs in a fresh interpreter and reads ``sys.modules`` when it exits
(``benchmarks/cli_startup.py`` measures the time).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
NUMERIC = ("numpy", "scipy", "sympy", "matplotlib", "cvxpy")

#: Runs the app as the console script does, then prints the numeric modules loaded at exit to stderr, last line.
_RUN = f"""
import atexit, json, sys

def _report():
    loaded = sorted(m for m in sys.modules if m.split('.')[0] in {set(NUMERIC)!r})
    sys.stderr.write('\\n' + json.dumps(loaded) + '\\n')

atexit.register(_report)
from nlobs.cli import app
sys.argv[0] = 'nlobs'
sys.exit(app())
"""


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), *filter(None, [env.get("PYTHONPATH")])])
    env["COLUMNS"] = "100"
    return env


def _numeric_modules_after(*args: str) -> tuple[int, list[str]]:
    proc = subprocess.run([sys.executable, "-c", _RUN, *args], env=_env(), capture_output=True, text=True,
                          timeout=120, check=False)
    return proc.returncode, json.loads(proc.stderr.strip().splitlines()[-1])


def test_importing_the_cli_loads_no_numeric_library() -> None:
    code = ("import json, sys, nlobs.cli; print(json.dumps(sorted(m for m in sys.modules "
            f"if m.split('.')[0] in {set(NUMERIC)!r})))")
    proc = subprocess.run([sys.executable, "-c", code], env=_env(), capture_output=True, text=True, timeout=120,
                          check=True)
    assert json.loads(proc.stdout) == []


@pytest.mark.parametrize("args", [
    ["version"],
    ["--help"],
    [],
    ["analyze", "--help"],
    ["advise", "--help"],
    ["demo", "--help"],
    ["design", "--help"],
    ["design", "drift", "--help"],
    ["design", "pinv", "--help"],
    ["design", "cascade", "--help"],
    ["design", "setvalued", "--help"],
    ["simulate", "--help"],
    ["simulate", "compare", "--help"],
    ["simulate", "setvalued", "--help"],
], ids=lambda a: " ".join(a) or "no-arguments")
def test_version_and_help_load_no_numeric_library(args: list[str]) -> None:
    status, loaded = _numeric_modules_after(*args)
    assert status in (0, 2)  # no arguments prints the help and exits 2 (no_args_is_help)
    assert loaded == [], f"nlobs {' '.join(args)} imported {sorted({m.split('.')[0] for m in loaded})}"


def test_the_check_sees_a_command_that_loads_the_numeric_stack() -> None:
    """The probe itself works: a command that needs NumPy (``nlobs models`` reads the model files) shows it."""
    status, loaded = _numeric_modules_after("models", "--json")
    assert status == 0 and "numpy" in loaded


@pytest.mark.parametrize("args", [
    ["analyze", "pendulum"],
    ["advise", "pendulum"],
    ["design", "drift", "pendulum"],
], ids=" ".join)
def test_everyday_commands_load_no_solver_or_plotting_library(args: list[str]) -> None:
    """CVXPY, Matplotlib and Dask are imported only by a command that solves an LMI, draws or scales out:
    ``analyze``, ``advise`` and the drift design on a small model use none of them."""
    status, loaded = _numeric_modules_after(*args)
    assert status == 0
    heavy = sorted({m.split(".")[0] for m in loaded} & {"cvxpy", "matplotlib"})
    assert heavy == [], f"nlobs {' '.join(args)} imported {heavy}"
    assert "sympy" in {m.split(".")[0] for m in loaded}  # the probe sees what the command does load
