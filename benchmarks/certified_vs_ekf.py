"""Certified observers against the EKF on the shipped textbook plants: accuracy, and whether the certificate covers the run.

For each plant, ``nlobs simulate compare PLANT --json`` (every observer the command knows: drift, pinv,
luenberger, cascade, EKF, UKF; the model file's sensors, inputs, process noise and ``[simulation]``
defaults, seed 0) is run in a subprocess with ``sys.executable -m nlobs``, so that ``PYTHONPATH``
decides which source tree is measured. A plant is a shipped model's name or a path to a model file
(``.toml``), so that a tree without a model can still be measured on it.

Printed, one row per plant × observer: the EKF's RMS ‖e‖ (after the file's ``settle``), the observer's,
their ratio (below 1: the observer is more accurate than the EKF), the diverged runs, whether the
observer's certificate was verified, the fraction of runs it covers (every hypothesis held along the
run: ``certificate.covered_fraction``), and, when the report has them, the certificate's
``rms_bound`` and per sensor group its ``T_max`` against the sampling period (``ok`` when the period is
at most ``T_max``); "—" where a value is absent, and the reason where an observer was skipped.
Then, per plant, the most accurate observer whose certificate is verified and covers at least 90 % of
the runs, with its ratio to the EKF, and at the end the number of plants where such a covering
certificate is within 2× the EKF's RMS error. A plant whose command fails is reported in one line and
the others go on.

Run ``PYTHONPATH=src python benchmarks/certified_vs_ekf.py [--runs N] [--plants a,b,path.toml]
[--json rows.json]`` (with the files' 20–50 runs, several minutes per plant on a small machine).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

PLANTS = ("cartpole", "chemostat", "two-tank", "chemostat-analyser", "flexible-joint", "haldane-bioreactor",
          "ball-and-beam", "dc-motor-load", "vanderpol-circuit", "cstr")
COVER = 0.9  # a certificate "covers" the runs when it holds along at least this fraction of them
WITHIN = 2.0  # ... and is "competitive" when its RMS error is within this factor of the EKF's
DASH = "—"


def label(plant: str) -> str:
    """The name a plant is shown under: a shipped model's name, or a file's stem."""
    return Path(plant).stem if plant.endswith(".toml") or os.sep in plant else plant


def run_compare(plant: str, runs: int | None, seed: int, timeout: float | None) -> tuple[dict[str, Any] | None, str]:
    """The JSON report of ``nlobs simulate compare`` on one plant, or ``None`` and a one-line error."""
    cmd = [sys.executable, "-m", "nlobs", "simulate", "compare", plant, "--json", "--seed", str(seed)]
    if runs is not None:
        cmd += ["--runs", str(runs)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return None, f"timed out after {timeout:g} s"
    if proc.returncode != 0:
        lines = [ln.strip() for ln in proc.stderr.splitlines() if ln.strip()]
        err = next((ln for ln in lines if "error" in ln.lower()), lines[-1] if lines else "")
        return None, f"exit {proc.returncode}: {err or 'no message'}"
    try:
        return json.loads(proc.stdout), ""
    except json.JSONDecodeError as exc:
        return None, f"the output is not JSON ({exc})"


def _num(v: Any) -> float | None:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) else None


def rows_of(plant: str, report: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per observer of the report (the EKF's RMS error repeated on each, for the ratio)."""
    observers = report.get("observers", {})
    runs = report.get("runs")
    ekf = _num((observers.get("ekf") or {}).get("rms_error_norm"))
    rows = []
    for name, obs in observers.items():
        cert = obs.get("certificate") or None
        rms = None if obs.get("skipped") else _num(obs.get("rms_error_norm"))
        sampling = (cert or {}).get("sampling")
        groups = sampling.get("groups") if isinstance(sampling, dict) else None
        rows.append({
            "plant": plant,
            "observer": name,
            "runs": runs,
            "ekf_rms": ekf,
            "rms": rms,
            "ratio": rms / ekf if rms is not None and ekf else None,
            "diverged": None if obs.get("skipped") else len(obs.get("diverged_runs") or []),
            "skipped": obs.get("skipped") or None,
            "certificate": cert is not None,
            "verified": None if cert is None else bool(cert.get("verified")),
            "covers_run": None if cert is None else bool(cert.get("covers_run")),
            "covered_fraction": None if cert is None else _num(cert.get("covered_fraction")),
            "rms_bound": None if cert is None else _num(cert.get("rms_bound")),
            "sampling": [{"name": g.get("name"), "period": _num(g.get("period")), "T_max": _num(g.get("T_max"))}
                         for g in groups if isinstance(g, dict)] if isinstance(groups, list) else None,
        })
    return rows


def best_covering(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The most accurate observer whose certificate is verified and covers at least ``COVER`` of the runs."""
    ok = [r for r in rows if r["verified"] and (r["covered_fraction"] or 0.0) >= COVER and r["rms"] is not None]
    return min(ok, key=lambda r: r["rms"]) if ok else None


def _g(v: float | None, fmt: str = ".3g") -> str:
    return DASH if v is None else format(v, fmt)


def _sampling(groups: list[dict[str, Any]] | None) -> str:
    if not groups:
        return DASH
    out = []
    for g in groups:
        T, Tmax = g["period"], g["T_max"]
        verdict = "" if T is None or Tmax is None else (" ok" if T <= Tmax else " too slow")
        out.append(f"{g['name']}: {_g(Tmax)} vs {_g(T)}{verdict}")
    return "; ".join(out)


def _short(text: str, width: int = 70) -> str:
    text = " ".join(text.split())
    return text if len(text) <= width else text[: width - 1] + "…"


def print_rows(rows: list[dict[str, Any]]) -> None:
    print("| plant | observer | EKF RMS ‖e‖ | RMS ‖e‖ | ratio | diverged | verified | covered | rms_bound | "
          "T_max vs period | note |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        div = DASH if r["diverged"] is None else f"{r['diverged']}/{r['runs']}"
        ver = DASH if r["verified"] is None else ("yes" if r["verified"] else "no")
        cov = DASH if r["covered_fraction"] is None else f"{100 * r['covered_fraction']:.0f} %"
        note = f"skipped: {_short(r['skipped'])}" if r["skipped"] else ""
        print(f"| {r['plant']} | {r['observer']} | {_g(r['ekf_rms'], '.4g')} | {_g(r['rms'], '.4g')} | "
              f"{_g(r['ratio'], '.2f')} | {div} | {ver} | {cov} | {_g(r['rms_bound'], '.3g')} | "
              f"{_sampling(r['sampling'])} | {note} |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", default=",".join(PLANTS),
                    help="comma-separated shipped model names or model-file paths (default: %(default)s)")
    ap.add_argument("--runs", type=int, default=None, help="Monte Carlo runs per plant (default: the file's)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the runs (default: %(default)s)")
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds per plant before it counts as failed")
    ap.add_argument("--json", metavar="PATH", help="write every row, the per-plant summaries and the errors here")
    args = ap.parse_args(argv)
    plants = [p.strip() for p in args.plants.split(",") if p.strip()]

    print(f"certified observers vs EKF: nlobs simulate compare --json, seed {args.seed}, runs "
          f"{args.runs if args.runs is not None else 'from each file'} ({sys.executable}; PYTHONPATH="
          f"{os.environ.get('PYTHONPATH', '')})")
    all_rows: list[dict[str, Any]] = []
    summaries: list[dict[str, Any]] = []
    errors: dict[str, str] = {}
    for plant in plants:
        name = label(plant)
        t0 = time.perf_counter()
        report, err = run_compare(plant, args.runs, args.seed, args.timeout)
        wall = time.perf_counter() - t0
        if report is None:
            print(f"{name}: FAILED ({wall:.0f} s): {_short(err, 300)}", flush=True)
            errors[name] = err
            continue
        rows = rows_of(name, report)
        all_rows.extend(rows)
        best = best_covering(rows)
        ekf = rows[0]["ekf_rms"] if rows else None
        summaries.append({"plant": name, "runs": report.get("runs"), "wall_s": wall, "ekf_rms": ekf,
                          "best": None if best is None else best["observer"],
                          "best_rms": None if best is None else best["rms"],
                          "best_ratio": None if best is None else best["ratio"]})
        print(f"{name}: {report.get('runs')} runs, {wall:.0f} s", flush=True)

    print()
    print_rows(all_rows)
    print()
    within = 0
    for s in summaries:
        if s["best"] is None:
            print(f"{s['plant']}: no observer with a verified certificate covering ≥ {100 * COVER:.0f} % of the runs "
                  f"(EKF RMS ‖e‖ {_g(s['ekf_rms'], '.4g')})")
            continue
        ratio = s["best_ratio"]
        within += ratio is not None and ratio <= WITHIN
        print(f"{s['plant']}: best covering certificate: {s['best']}, RMS ‖e‖ {_g(s['best_rms'], '.4g')}, "
              f"{_g(ratio, '.2f')} × the EKF's {_g(s['ekf_rms'], '.4g')}")
    for name, err in errors.items():
        print(f"{name}: failed: {_short(err, 300)}")
    print(f"plants where a covering certificate is within {WITHIN:g}× the EKF: {within} of {len(summaries)}"
          + (f" ({len(errors)} more failed)" if errors else ""))
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": all_rows, "plants": summaries, "errors": errors,
                                               "within": within, "cover": COVER, "factor": WITHIN}, indent=2) + "\n")
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
