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

from nlobs.cli.common import box_numbers, console, emit_json, fail, finish
from nlobs.errors import ModelFileError, NlobsError


def export_cmd(
    model: Annotated[str, typer.Argument(help="A model file (.toml), or the name of a shipped model.")],
    observer: Annotated[str, typer.Option(
        "--observer", help="Which design to export: luenberger (the gain of LMIs (14), (15); for a nonlinear model "
                           "the copy of the plant with the gain of its linearisation at x0), drift (Dalla Mora, "
                           "Germani & Manes (3.1)), pinv "
                           "(Röbenack (7), (17)), cascade (Grip, Saberi & Johansen, the file's [cascade] table), setvalued "
                           "(Khajenejad & Yong, Algorithm 1) or "
                           "gnss-ins (the demo's observer (24); MODEL is gnss-ins).")],
    out: Annotated[Path, typer.Option("--out", help="Folder for the header and the source (created).")],
    lang: Annotated[str, typer.Option("--lang", help="Target language (c: C99, math.h only, no heap).")] = "c",
    box: Annotated[str | None, typer.Option(
        "--box", help="Region of the design: 'lo,hi' or 2n numbers (default: the model file's [simulation] box, "
                      "else -1,1).")] = None,
    saturation: Annotated[str | None, typer.Option(
        "--saturation", help="'on': Khalil's saturated form outside the region; 'off': as printed (default: as "
                             "nlobs design).")] = None,
    prefix: Annotated[str | None, typer.Option(
        "--prefix", help="C prefix of every name and of the two files (default: <model>_<observer>).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print a machine-readable JSON report.")] = False,
) -> None:
    """Design an observer for a model and write its step as dependency-free C99 (header carries the certificate)."""
    from nlobs.cli.design import _on_off, _region
    from nlobs.workflows.export import export_model_observer
    from nlobs.workflows.inputs import BoxError

    sat = None if saturation is None else _on_off("--saturation", saturation)
    try:
        region = _region(model, box) if observer in ("drift", "pinv") else box_numbers("--box", box)
        report = export_model_observer(model, observer=observer, out=out, lang=lang, box=region,
                                       saturation=sat, prefix=prefix)
    except ModelFileError as exc:
        fail(str(exc))
    except BoxError as exc:
        fail(f"--box: {exc}")
    except NlobsError as exc:
        fail(f"{model}: {exc}")
    if as_json:
        emit_json(report.to_dict())
    else:
        console().print(report.summary(), markup=False)
    finish(report, as_json)
