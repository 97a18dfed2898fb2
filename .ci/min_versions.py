#!/usr/bin/env python3
"""Install the declared minimum version of every dependency and run the CLI against them.

``pyproject.toml`` declares floors (``numpy>=1.26``, ...). This script makes them true: it creates a
separate virtual environment (default ``.venv-min``), installs nlobs there with every runtime
dependency pinned to its floor (``pip install -c``: transitive dependencies resolve freely), then

1. runs ``nlobs --help``, ``nlobs version`` and one command of each family (``models``,
   ``analyze``, ``design cascade --method h2``, a short ``demo gnss-ins``) and requires exit 0;
2. runs ``nlobs reproduce PAPER --json`` for every paper in both environments and requires the
   same rows with every numeric value within ``--rtol`` (default 5 %, norm-wise per row: the SDP
   optimisers are not unique and move with the solvers' versions, measured up to 3 %; the printed
   verdicts and notes are text and are not compared). The rows of :data:`NON_UNIQUE` hold an optimiser
   that is not unique at all (Khajenejad & Yong's ``P*`` of Theorem 5.10 as printed: measured 8 %
   apart while the ``Y*``, ``L̃*`` and ``ρ*`` it gives agree to 1e-4); their difference is printed,
   not compared, and the quantities they certify are compared as every other row.

``python .ci/min_versions.py [--venv DIR] [--reference PYTHON] [--rtol R]`` (``make test-min``);
exit 0 when everything agrees, 1 with the first difference otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAPERS = ("grip2013", "dallamora2000", "robenack2008", "khajenejad-yong")
SMOKE = (
    ["--help"],
    ["version"],
    ["models"],
    ["analyze", "pendulum"],
    ["design", "cascade", "chemostat-analyser", "--method", "h2"],
    ["demo", "gnss-ins", "--duration", "20", "--out", "{tmp}/demo"],
)


def floors(pyproject: Path) -> list[str]:
    """``name==floor`` for every runtime dependency declared as ``name>=floor``."""
    deps = tomllib.loads(pyproject.read_text())["project"]["dependencies"]
    out = []
    for d in deps:
        m = re.fullmatch(r"\s*([A-Za-z0-9_.\-]+)\s*>=\s*([0-9][A-Za-z0-9_.\-]*)\s*", d)
        if not m:
            raise SystemExit(f"pyproject.toml: dependency {d!r} has no plain '>=' floor to test")
        out.append(f"{m.group(1)}=={m.group(2)}")
    return out


def _norm(v: str | None) -> tuple[str, ...]:
    """A version without trailing ``.0`` release segments (``1.26.0`` is ``1.26``)."""
    parts = (v or "").lower().split(".")
    while len(parts) > 1 and parts[-1] == "0":
        parts.pop()
    return tuple(parts)


def run(cmd: list[str], **kw) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, text=True, capture_output=True, **kw)


def _flat(v) -> list[float] | None:
    """The numbers of a JSON value (a number or nested lists of numbers), else ``None``."""
    if isinstance(v, bool) or v is None or isinstance(v, str):
        return None
    if isinstance(v, (int, float)):
        return [float(v)]
    if isinstance(v, list):
        out: list[float] = []
        for x in v:
            f = _flat(x)
            if f is None:
                return None
            out += f
        return out
    return None


#: Quantities (ends of row names) whose value is a non-unique optimiser: reported, not compared.
NON_UNIQUE: tuple[str, ...] = ("P* (Thm 5.10 as printed)",)


def compare_rows(a: list[dict], b: list[dict], loose: list[str] | None = None) -> tuple[str | None, float, str]:
    """Compare two ``nlobs reproduce --json`` outputs row by row.

    The rows must name the same quantities in the same order. Each row's ``nlobs`` value, when it is
    numeric, is compared norm-wise: ``‖a − b‖ / max(‖a‖, ‖b‖)`` (the SDP optimisers nlobs reports are
    not unique, so their entries move with the solver's version while the matrix as a whole does
    not). Rows of :data:`NON_UNIQUE` are left out of the largest difference and described in
    ``loose`` (when given). Returns ``(a structural difference or None, the largest relative
    difference, its row)``.
    """
    if [r.get("quantity") for r in a] != [r.get("quantity") for r in b]:
        return "the rows differ", math.inf, ""
    worst, where = 0.0, ""
    for ra, rb in zip(a, b):
        fa, fb = _flat(ra.get("nlobs")), _flat(rb.get("nlobs"))
        if (fa is None) != (fb is None) or (fa is not None and len(fa) != len(fb)):
            return f"row {ra.get('quantity')!r}: values of different kinds", math.inf, ""
        if fa is None:
            continue
        if any(math.isnan(x) for x in fa) or any(math.isnan(x) for x in fb):
            if [math.isnan(x) for x in fa] != [math.isnan(x) for x in fb]:
                return f"row {ra.get('quantity')!r}: NaN in one environment only", math.inf, ""
            continue
        na, nb = math.hypot(*fa), math.hypot(*fb)
        d = math.hypot(*(x - y for x, y in zip(fa, fb))) / max(na, nb, 1e-300)
        if str(ra.get("quantity")).endswith(NON_UNIQUE):
            if loose is not None:
                loose.append(f"{ra.get('quantity')!r} {d:.2g} (a non-unique optimiser: not compared)")
            continue
        if d > worst:
            worst, where = d, str(ra.get("quantity"))
    return None, worst, where


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--venv", type=Path, default=ROOT / ".venv-min")
    ap.add_argument("--reference", type=Path, default=ROOT / ".venv" / "bin" / "python")
    ap.add_argument("--rtol", type=float, default=0.05)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    pins = floors(ROOT / "pyproject.toml")
    py = args.venv / "bin" / "python"
    if not py.exists():
        r = run([sys.executable, "-m", "venv", str(args.venv)])
        if r.returncode:
            print(r.stderr, file=sys.stderr)
            return 1
    cons = args.venv / "constraints.txt"
    cons.write_text("\n".join(pins) + "\n")
    print("minimum versions: " + ", ".join(pins), flush=True)
    r = run([str(py), "-m", "pip", "install", "--quiet", "-c", str(cons), "-e", str(ROOT)])
    if r.returncode:
        print(r.stdout[-3000:], r.stderr[-3000:], file=sys.stderr)
        print("FAIL: the declared minimum versions do not install together", file=sys.stderr)
        return 1
    got = run([str(py), "-m", "pip", "list", "--format", "json"])
    have = {p["name"].lower(): p["version"] for p in json.loads(got.stdout)}
    for pin in pins:
        name, ver = pin.split("==")
        if _norm(have.get(name.lower())) != _norm(ver):
            print(f"FAIL: {name} installed as {have.get(name.lower())}, not its floor {ver}", file=sys.stderr)
            return 1
    print(f"installed in {time.perf_counter() - t0:.0f} s (click {have.get('click')}, rich {have.get('rich')})",
          flush=True)
    tmp = args.venv / "out"
    env_cmd = [str(py), "-m", "nlobs"]
    for cmd in SMOKE:
        full = [c.format(tmp=tmp) for c in cmd]
        r = run(env_cmd + full, cwd=ROOT)
        if r.returncode:
            print(f"FAIL: nlobs {' '.join(full)} exited {r.returncode}\n{r.stderr[-3000:]}", file=sys.stderr)
            return 1
        print(f"ok   nlobs {' '.join(full)}", flush=True)
    for paper in PAPERS:
        outs = []
        for interp in (py, args.reference):
            r = run([str(interp), "-m", "nlobs", "reproduce", paper, "--json"], cwd=ROOT)
            if r.returncode:
                print(f"FAIL: {interp}: nlobs reproduce {paper} exited {r.returncode}\n{r.stderr[-3000:]}",
                      file=sys.stderr)
                return 1
            outs.append(json.loads(r.stdout))
        loose: list[str] = []
        why, worst, where = compare_rows(outs[0], outs[1], loose)
        if why or worst > args.rtol:
            print(f"FAIL: nlobs reproduce {paper}: minimum versions and the reference differ: "
                  f"{why or f'relative difference {worst:.3g} > {args.rtol:g} at {where!r}'}", file=sys.stderr)
            return 1
        print(f"ok   nlobs reproduce {paper}: the same rows; largest relative difference {worst:.2g}"
              + (f" ({where[:60]})" if where else ""), flush=True)
        for text in loose:
            print(f"     {text}", flush=True)
    print(f"minimum versions: all checks pass ({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
