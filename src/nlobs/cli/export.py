"""``nlobs export MODEL --observer NAME --lang c --out DIR``: a designed observer's step as C99.

Parses the options, calls :func:`nlobs.workflows.export.export_model_observer`, prints its
``summary()`` (or ``to_dict()`` with ``--json``) and exits by its verdict (0 certified, 1 written but
not certified; bad input or a failed compilation 2, one line).
"""

# No ``from __future__ import annotations``: typer reads the annotations of every command's parameters when the
# app starts, and evaluated ones spare it compiling and evaluating each string again (twice per command).

from pathlib import Path
from typing import Annotated

import typer

from nlobs.cli.common import (
    complete_model,
    EXIT_FAILURE,
    EXIT_NO_OBSERVER,
    box_numbers,
    console,
    emit_json,
    fail,
    finish,
    parse_floats,
)
from nlobs.cli.choices import ExportMethod, Exported, Lang, OnOff, Placement
from nlobs.cli.choices import value as plain
from nlobs.errors import AssumptionViolated, DesignError, ModelFileError, NlobsError
from nlobs.methods.registry import REGISTRY


def export_cmd(
    model: Annotated[str, typer.Argument(
        metavar="MODEL", autocompletion=complete_model, help="A model file (.toml), or the name of a shipped model.")],
    observer: Annotated[Exported, typer.Option(
        "--observer", help="Which design to export (MODEL is gnss-ins for gnss-ins; MODEL gnss-ins with ekf: the "
                           "navigation EKF of the demo, the baseline of observer (24)): "
                           + "; ".join(f"{e.name}: {e.help}" for e in REGISTRY if e.exported) + ".")],
    out: Annotated[Path, typer.Option("--out", help="Folder for the header and the source (created).")],
    lang: Annotated[Lang, typer.Option("--lang", help="Target language (c: C99, math.h only, no heap).")] = Lang.c,
    box: Annotated[str | None, typer.Option(
        "--box", help="Region of the design: 'lo,hi' or 2n numbers (default: the model file's [simulation] box, "
                      "else -1,1).")] = None,
    saturation: Annotated[OnOff | None, typer.Option(
        "--saturation", help="'on': Khalil's saturated form outside the region; 'off': as printed (default: as "
                             "nlobs design).")] = None,
    prefix: Annotated[str | None, typer.Option(
        "--prefix", help="C prefix of every name and of the two files (default: <model>_<observer>).")] = None,
    s: Annotated[str | None, typer.Option("--s", help="drift: multi-index, e.g. '3,1'.")] = None,
    alpha: Annotated[float | None, typer.Option(
        help="drift: decay rate α of (2.17); luenberger: poles left of −alpha (default 1).")] = None,
    mu: Annotated[float | None, typer.Option(
        help="drift: input bound μ of (2.17) (default: the largest ‖u(t)‖ of the file's [input_signals] over "
             "its [simulation] duration).")] = None,
    gamma: Annotated[float | None, typer.Option(
        help="drift: γ of (2.17) (default: estimated on the region); cascade: ‖H‖∞ < γ (default: the file's).")] = None,
    method: Annotated[ExportMethod | None, typer.Option(
        help="drift: 'vandermonde' or 'sdp'; cascade: 'lmi', 'placement' or 'h2' (as nlobs design).")] = None,
    w: Annotated[float | None, typer.Option(help="drift: check and use K(w).")] = None,
    w_max: Annotated[float | None, typer.Option("--w-max", help="drift: largest w the search tries.")] = None,
    theta: Annotated[float | None, typer.Option(help="pinv: high-gain parameter θ of the roots of (10).")] = None,
    placement: Annotated[Placement | None, typer.Option(help="pinv: 'powers' or 'multiple'.")] = None,
    k: Annotated[str | None, typer.Option("--k", help="pinv: gain vector k (Σ r_j numbers), instead of θ.")] = None,
    gain_bound: Annotated[float | None, typer.Option("--gain-bound", help="cascade: ‖K‖ bound.")] = None,
    option: Annotated[list[str] | None, typer.Option(
        "--option", metavar="KEY=VALUE", help="Any other design option of the method, KEY=VALUE, repeatable (a number, numbers "
                         "separated by commas, or a word).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print a machine-readable JSON report.")] = False,
) -> None:
    """Design an observer for a model and write its step as dependency-free C99 (header carries the certificate)."""
    from nlobs.cli.common import on_off
    from nlobs.workflows.export import export_model_observer
    from nlobs.workflows.inputs import BoxError

    observer, lang, method, placement = plain(observer), plain(lang), plain(method), plain(placement)
    sat = None if saturation is None else on_off("--saturation", plain(saturation))
    ints = parse_floats("--s", s)
    if ints is not None and any(v != int(v) for v in ints):
        fail(f"--s: expected integers, got {s!r}")
    given = {"s": None if ints is None else [int(v) for v in ints], "alpha": alpha, "mu": mu, "gamma": gamma,
             "gain_method": method, "w": w, "w_max": w_max, "theta": theta, "placement": placement,
             "k": parse_floats("--k", k), "gain_bound": gain_bound}
    options = {name: value for name, value in given.items() if value is not None}
    from nlobs.cli.compare import design_options

    for key, value in (design_options([f"{observer}.{o}" for o in option or ()]) or {}).get(observer, {}).items():
        if key in ("saturation", "prefix", "box", "lang", "out", "observer", "model"):
            fail(f"--option {key}: give it as --{key}")
        if key in options:
            fail(f"--option {key}: given twice (also as its own flag)")
        options[key] = value
    try:
        report = export_model_observer(model, observer=observer, out=out, lang=lang, box=box_numbers("--box", box),
                                       saturation=sat, prefix=prefix, **options)
    except ModelFileError as exc:
        fail(str(exc))
    except BoxError as exc:
        fail(f"--box: {exc}")
    except AssumptionViolated as exc:
        fail(f"{model}: {exc}", EXIT_NO_OBSERVER)
    except DesignError as exc:
        fail(f"{model}: design failed: {exc}", EXIT_FAILURE)
    except NlobsError as exc:
        fail(f"{model}: {exc}")  # its backticked parameters are this command's flags (fail)
    if as_json:
        emit_json(report.to_dict())
    else:
        console().print(report.summary(), markup=False)
    finish(report, as_json)
