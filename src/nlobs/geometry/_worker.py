"""The child process of :func:`nlobs.geometry.budget.run_bounded`: one allowed step, pickled in and out."""

from __future__ import annotations

import importlib
import math
import pickle
import sys


def main() -> int:
    module, name, args, seconds = pickle.loads(sys.stdin.buffer.read())  # noqa: S301 - from the parent process
    from nlobs.geometry.budget import ALLOWED_STEPS

    if (module, name) not in ALLOWED_STEPS:
        return 2
    try:  # end by itself even if the parent is gone (a SIGKILL of the parent cannot kill it)
        import resource

        cpu = int(math.ceil(seconds)) + 2
        resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))
    except (ImportError, ValueError, OSError):
        pass
    try:
        result = (True, getattr(importlib.import_module(module), name)(*args))
    except Exception as exc:  # reported to the parent as "not finished"
        result = (False, f"{type(exc).__name__}: {exc}")
    sys.stdout.buffer.write(pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL))
    sys.stdout.buffer.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
