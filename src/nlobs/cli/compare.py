"""``nlobs simulate MODEL`` (also ``nlobs simulate compare MODEL``): every chosen observer on the same noisy,
multi-rate Monte Carlo runs of a model, against EKF and UKF baselines.

Parse, call :func:`nlobs.workflows.compare.compare_observers`, print its table (or ``--json``) and
exit by its verdict: 0 when an observer ran, 3 when none applies, 1 when every run diverged; bad
input (a model file, a sensor rate that is not positive or does not fit ``--dt``, a covariance that
is not symmetric positive semidefinite, an input CSV with non-monotone time or NaN, an unknown
observer name) is one line and exit 2.
"""

# No ``from __future__ import annotations``: typer reads the annotations of every command's parameters when the
# app starts, and evaluated ones spare it compiling and evaluating each string again (twice per command).

from pathlib import Path
from typing import Annotated

import typer

from nlobs.cli.common import (
    complete_model,
    EXIT_FAILURE,
    Progress_,
    box_numbers,
    console,
    emit_json,
    fail,
    finish,
    parse_floats,
    simulate_app,
)
from nlobs.cli.choices import Backend, value
from nlobs.errors import ModelFileError, NlobsError, OutputError, StudyFailed
from nlobs.methods.registry import REGISTRY, names

#: The observers ``nlobs simulate MODEL`` runs: the methods' registry (its order).
_KNOWN = ",".join(names(simulated=True, default=True))
_HELP = "; ".join(f"{e.name}: {e.help}" for e in REGISTRY if e.simulated)


def _inputs(values: list[str] | None) -> dict[str, str] | None:
    if not values:
        return None
    out: dict[str, str] = {}
    for v in values:
        name, sep, spec = v.partition("=")
        if not sep or not name.strip() or not spec.strip():
            fail(f"--input: expected NAME=SPEC (e.g. tau=sine:0.5,0.2 or tau=csv:u.csv:tau), got {v!r}")
        if name.strip() in out:
            fail(f"--input: {name.strip()!r} given twice")
        out[name.strip()] = spec.strip()
    return out


def _value(text: str) -> object:
    """A design option's value: a number, numbers separated by commas, or a word (``sdp``, ``powers``)."""
    word = text.strip().lower()
    if word in ("on", "true", "yes", "off", "false", "no"):
        return word in ("on", "true", "yes")
    parts = [p.strip() for p in text.split(",")]
    try:
        nums: list[float | int] = [int(p) if p.lstrip("+-").isdigit() else float(p) for p in parts]
    except ValueError:
        return text.strip()
    return nums[0] if len(nums) == 1 else nums


def design_options(values: list[str] | None) -> dict[str, dict[str, object]] | None:
    """``--option METHOD.KEY=VALUE`` (repeatable) as ``{method: {key: value}}``; a malformed one is exit 2."""
    if not values:
        return None
    out: dict[str, dict[str, object]] = {}
    for v in values:
        lhs, sep, rhs = v.partition("=")
        method, dot, key = lhs.strip().partition(".")
        if not sep or not dot or not method or not key or not rhs.strip():
            fail(f"--option: expected METHOD.KEY=VALUE (e.g. drift.mu=2 or pinv.theta=3), got {v!r}")
        if key.strip().replace("-", "_") in out.get(method.strip(), {}):
            fail(f"--option: {lhs.strip()!r} given twice")
        out.setdefault(method.strip(), {})[key.strip().replace("-", "_")] = _value(rhs)
    return out


def estimator_options(opts: dict[str, dict[str, object]] | None, chosen: list[str], particles: int | None,
                      horizon: int | None) -> dict[str, dict[str, object]] | None:
    """``--particles`` and ``--horizon`` as the design options ``pf.particles`` and ``mhe.horizon``; either without
    its estimator among ``chosen`` is exit 2."""
    for flag, method, key, val in (("--particles", "pf", "particles", particles), ("--horizon", "mhe", "horizon",
                                                                                      horizon)):
        if val is None:
            continue
        if method not in chosen:
            fail(f"{flag}: applies to the {'particle filter' if method == 'pf' else 'moving-horizon estimator'} "
                 f"(--observer {method})")
        if key in (opts or {}).get(method, {}):
            fail(f"{flag}: given twice (also --option {method}.{key})")
        opts = {**(opts or {}), method: {**(opts or {}).get(method, {}), key: val}}
    return opts


def _one_or_many(option: str, text: str | None) -> list[float] | float | None:
    vals = parse_floats(option, text)
    if vals is None:
        return None
    return vals[0] if len(vals) == 1 else vals


@simulate_app.command("compare")
def compare_cmd(
    model: Annotated[str, typer.Argument(
        metavar="MODEL", autocompletion=complete_model, help="A model file (.toml) with optional [sensors], [input_signals], "
                                              "[process_noise], units and [simulation] tables, or a shipped model.")],
    observer: Annotated[str, typer.Option("--observer", metavar="NAME,...", help=f"Comma-separated observers (default: all but pf and mhe). {_HELP}.")] = _KNOWN,
    particles: Annotated[int | None, typer.Option(min=2, help="Particles of the particle filter (default 1000).")]
    = None,
    horizon: Annotated[int | None, typer.Option(min=1, help="Samples in the moving horizon (default 10).")] = None,
    runs: Annotated[int | None, typer.Option(help="Monte Carlo runs (default: [simulation].runs, else 20).")] = None,
    duration: Annotated[float | None, typer.Option(help="Simulated time [s] (default: [simulation], else 10).")] = None,
    dt: Annotated[float | None, typer.Option(help="RK4 step [s] (default: [simulation], else 1e-3).")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the initial errors and of all noise.")] = 0,
    x0: Annotated[str | None, typer.Option("--x0", help="Initial plant state (default: [simulation].x0, else 0).")] = None,
    xhat0: Annotated[str | None, typer.Option("--xhat0", help="One initial estimate for every run.")] = None,
    initial_error_std: Annotated[str | None, typer.Option(
        "--initial-error-std", help="Std of the initial estimation error, one or per state (x̂0 = x0 + N(0, std²)).")] = None,
    box: Annotated[str | None, typer.Option("--box", help="Region of the designs: 'lo,hi' or 2n numbers.")] = None,
    settle: Annotated[float | None, typer.Option(help="RMS errors after this time [s] (default: a quarter).")] = None,
    rate: Annotated[float | None, typer.Option(help="One sensor for all outputs at this rate [Hz] (replaces [sensors]).")] = None,
    noise_std: Annotated[str | None, typer.Option("--noise-std", help="Its noise std, one or per output.")] = None,
    input_: Annotated[list[str] | None, typer.Option(
        "--input", metavar="NAME=SPEC", help="Known input NAME=SPEC, repeatable: constant:1, step:0,1,2, sine:A,f[,phase,offset], "
                        "chirp:A,f0,f1,T, csv:FILE[:COLUMN], expr:0.5*sin(2*t).")] = None,
    process_noise: Annotated[str | None, typer.Option(
        "--process-noise", help="Process-noise std per state [unit/√s] (replaces [process_noise]).")] = None,
    filter_q: Annotated[str | None, typer.Option(
        "--filter-q", help="EKF/UKF process-noise std per state (default: the process noise).")] = None,
    alpha: Annotated[float | None, typer.Option(help="Luenberger gain: poles left of −alpha (default 1).")] = None,
    option: Annotated[list[str] | None, typer.Option(
        "--option", metavar="METHOD.KEY=VALUE", help="A method's design option, METHOD.KEY=VALUE, repeatable (e.g. drift.mu=2, drift.alpha=0.5, "
                         "pinv.theta=3, cascade.gamma=0.5, ekf.filter_q=0.01,0.01): the options of nlobs design and "
                         "nlobs export.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the report as JSON.")] = False,
    out: Annotated[Path | None, typer.Option("--out", help="Folder for compare.json, plots, .npz and .csv.")] = None,
    backend: Annotated[Backend, typer.Option(
        "--backend", help="'python' (default) or 'c': the plant and the observers with a C generator run as "
                          "generated, compiled C (the EKF and the UKF too).")] = Backend.python,
    workers: Annotated[int | None, typer.Option(min=1, help="Run the observers, one task each, on a local Dask "
                                                "cluster of N worker processes (the same numbers; needs nlobs[dask]).")]
    = None,
    scheduler: Annotated[str | None, typer.Option(help="Run the observers on the Dask scheduler at this address "
                                                  "(tcp://host:8786).")] = None,
    progress: Progress_ = None,
) -> None:
    """Compare observers (drift, pinv, luenberger, cascade) with an EKF and a UKF (a particle filter and moving-horizon
    estimation when named) on the same noisy runs; with a [controller], in closed loop."""
    from nlobs.workflows.compare import compare_observers

    names = [o.strip() for o in observer.split(",") if o.strip()]
    if not names:
        fail("--observer: give at least one of " + ",".join(names(simulated=True)))
    options = estimator_options(design_options(option), names, particles, horizon)
    pn = parse_floats("--process-noise", process_noise)
    fq = parse_floats("--filter-q", filter_q)
    try:
        report = compare_observers(
            model, observers=names, runs=runs, duration=duration, dt=dt, seed=seed, x0=parse_floats("--x0", x0),
            x_hat0=parse_floats("--xhat0", xhat0), initial_error_std=_one_or_many("--initial-error-std", initial_error_std),
            box=box_numbers("--box", box), settle=settle, rate=rate, noise_std=_one_or_many("--noise-std", noise_std),
            inputs=_inputs(input_), process_noise=pn, filter_q=fq, alpha=alpha,
            design_options=options, out=out, progress=progress,
            name=model, backend=value(backend), workers=workers, scheduler=scheduler)
    except ModelFileError as exc:
        fail(str(exc))
    except OutputError as exc:
        fail(f"--out {exc}")
    except StudyFailed as exc:
        fail(f"{model}: {exc}", EXIT_FAILURE)
    except NlobsError as exc:
        fail(f"{model}: {exc}")
    if as_json:
        emit_json(report.to_dict())
    else:
        console().print(report.summary(), markup=False)  # plain text: a narrow terminal wraps it, never truncates
    finish(report, as_json)
