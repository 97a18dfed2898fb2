"""A wall-clock budget for the optional symbolic steps of the geometric analysis.

Some exact results are worth having only when SymPy finds them quickly: the Moore–Penrose gain
field ``l(x) = Q⁺(x) k`` of Röbenack (17) of a 9-state polynomial chain has entries of tens of
thousands of terms, and one ``factor`` or ``simplify`` call cannot be interrupted from Python (a
thread cannot be stopped). :func:`run_bounded` therefore runs such a step in a child Python process
(``python -m nlobs.geometry._worker``, arguments and result pickled through its pipes) and kills it
when its time is up; the child also limits its own CPU time, so it ends even when this process is
killed first. A step predicted small runs in this process (no start-up cost, identical results).
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: Default seconds, in all, of the optional symbolic steps of ``nlobs analyze`` (its ``symbolic_budget``).
DEFAULT_SYMBOLIC_BUDGET = 5.0

#: The functions a child process may run (module, name): nothing else is imported there.
ALLOWED_STEPS = frozenset({("nlobs.geometry.pinv", "gain_job")})


@dataclass
class SymbolicBudget:
    """Seconds left for optional symbolic steps (``None``: unlimited, every step in this process)."""

    seconds: float | None = DEFAULT_SYMBOLIC_BUDGET
    start: float = field(default_factory=time.monotonic)

    def remaining(self) -> float | None:
        if self.seconds is None:
            return None
        return max(0.0, float(self.seconds) - (time.monotonic() - self.start))


def run_bounded(module: str, name: str, args: tuple[Any, ...], budget: SymbolicBudget, *,
                in_process: bool = False) -> tuple[bool, Any]:
    """``(True, result)`` of ``module.name(*args)``, or ``(False, reason)`` when the budget ran out first.

    ``in_process`` (a step predicted small) or an unlimited budget runs it here; otherwise in a child
    process that is killed at the deadline. An error in the child counts as not finished (its reason
    says so); this process's state is never touched by the child.
    """
    if (module, name) not in ALLOWED_STEPS:
        raise ValueError(f"run_bounded: {module}.{name} is not an allowed step")
    left = budget.remaining()
    if in_process or left is None:
        import importlib

        return True, getattr(importlib.import_module(module), name)(*args)
    if left < 0.05:
        return False, "no time left in the symbolic budget"
    src = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ)
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    payload = pickle.dumps((module, name, args, left), protocol=pickle.HIGHEST_PROTOCOL)
    proc = subprocess.Popen([sys.executable, "-m", "nlobs.geometry._worker"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env)
    try:
        out, _ = proc.communicate(payload, timeout=left)
    except subprocess.TimeoutExpired:
        return False, f"did not finish within the symbolic budget ({budget.seconds:g} s)"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    if proc.returncode != 0:
        return False, f"the symbolic step failed (exit status {proc.returncode})"
    ok, value = pickle.loads(out)  # noqa: S301 - written by our own child process
    return (True, value) if ok else (False, f"the symbolic step failed: {value}")
