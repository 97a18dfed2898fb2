"""``nlobs schema COMMAND``: the JSON Schema (draft 2020-12) of a command's ``--json`` output.

Each schema is built from the declarations that the command's report writes through (:class:`nlobs._schema.Record`,
beside each report's ``to_dict``), so it describes exactly the keys the command prints. The same documents ship
in the package (``nlobs/data/schemas/*.schema.json``) and in the documentation.
"""

from __future__ import annotations

import importlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer

from nlobs.cli.common import console, fail

#: command -> (what it prints, the module and names of its shapes, whether it starts with ``schema_version``)
COMMANDS: dict[str, tuple[str, str, tuple[str, ...], bool]] = {
    "analyze": ("a model's dimensions, structural properties and norms (a linear or a nonlinear report)",
                "nlobs.workflows.analyze", ("ANALYZE_LINEAR_JSON", "ANALYZE_NONLINEAR_JSON"), True),
    "advise": ("which observer applies to a model, with the evidence", "nlobs.workflows.advise",
               ("ADVICE_JSON",), True),
    "design drift": ("the drift-observability observer's design and verification", "nlobs.workflows.design_drift",
                     ("DESIGN_DRIFT_JSON",), True),
    "design pinv": ("the Moore–Penrose observer's design and checks", "nlobs.workflows.design_pinv",
                    ("DESIGN_PINV_JSON",), True),
    "design cascade": ("the cascade/feedback observer's design and verification", "nlobs.workflows.design_cascade",
                       ("DESIGN_CASCADE_JSON",), True),
    "design setvalued": ("the set-valued observer's structural checks, gain and certificate",
                         "nlobs.workflows.setvalued", ("SETVALUED_DESIGN_REPORT_JSON",), True),
    "export": ("the C99 module written, with the design it rests on", "nlobs.workflows.export", ("EXPORT_JSON",),
               True),
    "simulate": ("observers compared on the same noisy Monte Carlo runs (nlobs simulate MODEL)",
                 "nlobs.workflows.compare", ("COMPARISON_JSON",), True),
    "simulate setvalued": ("the set-valued observer in Monte Carlo (the design's report when no observer exists)",
                           "nlobs.workflows.setvalued", ("SETVALUED_STUDY_JSON", "SETVALUED_DESIGN_REPORT_JSON"),
                           True),
    "simulate gnss-ins": ("Monte Carlo flights of the GNSS/INS observer", "nlobs.workflows.gnss_ins_study",
                          ("GNSS_INS_STUDY_JSON",), True),
    "demo gnss-ins": ("the GNSS/INS demo (and its results.json)", "nlobs.workflows.demo", ("DEMO_JSON",), True),
    "estimate": ("observers on a logged run: residuals at the samples, a filter's NIS", "nlobs.workflows.estimate",
                 ("ESTIMATE_JSON",), True),
    "reproduce": ("each number a paper reports beside the value nlobs computes (a list)", "nlobs.papers.reproduce",
                  ("REPRODUCE_JSON",), False),
    "models": ("the model files shipped with nlobs (a list)", "nlobs.systems.modelfile", ("MODELS_JSON",), False),
}

#: The modules above, imported by literal name (the command line's allowed imports).
_IMPORT: dict[str, Callable[[], Any]] = {
    "nlobs.workflows.analyze": lambda: importlib.import_module("nlobs.workflows.analyze"),
    "nlobs.workflows.advise": lambda: importlib.import_module("nlobs.workflows.advise"),
    "nlobs.workflows.design_drift": lambda: importlib.import_module("nlobs.workflows.design_drift"),
    "nlobs.workflows.design_pinv": lambda: importlib.import_module("nlobs.workflows.design_pinv"),
    "nlobs.workflows.design_cascade": lambda: importlib.import_module("nlobs.workflows.design_cascade"),
    "nlobs.workflows.setvalued": lambda: importlib.import_module("nlobs.workflows.setvalued"),
    "nlobs.workflows.export": lambda: importlib.import_module("nlobs.workflows.export"),
    "nlobs.workflows.compare": lambda: importlib.import_module("nlobs.workflows.compare"),
    "nlobs.workflows.gnss_ins_study": lambda: importlib.import_module("nlobs.workflows.gnss_ins_study"),
    "nlobs.workflows.demo": lambda: importlib.import_module("nlobs.workflows.demo"),
    "nlobs.workflows.estimate": lambda: importlib.import_module("nlobs.workflows.estimate"),
    "nlobs.papers.reproduce": lambda: importlib.import_module("nlobs.papers.reproduce"),
    "nlobs.systems.modelfile": lambda: importlib.import_module("nlobs.systems.modelfile"),
}


def command_schema(command: str) -> dict[str, Any]:
    """The JSON Schema document of ``nlobs COMMAND --json``.

    Parameters
    ----------
    command : str
        A key of :data:`COMMANDS` (``"analyze"``, ``"design drift"``, ...).

    Returns
    -------
    dict
        The schema (draft 2020-12).

    Raises
    ------
    KeyError
        An unknown command.
    """
    from nlobs.workflows import document_schema, one_of

    what, module, names, versioned = COMMANDS[command]
    mod = _IMPORT[module]()
    nodes = [getattr(mod, n) for n in names]
    node = nodes[0] if len(nodes) == 1 else one_of(*nodes)
    return document_schema(node, command, versioned=versioned, description=f"The JSON output of nlobs {command} (--json): {what}.")


def file_name(command: str) -> str:
    """``design-drift.schema.json`` for ``"design drift"``."""
    return command.replace(" ", "-") + ".schema.json"


def schema_text(command: str) -> str:
    """The schema as the command prints it (indented JSON, a final newline)."""
    return json.dumps(command_schema(command), indent=2, ensure_ascii=False) + "\n"


def schema_cmd(
    command: Annotated[list[str] | None, typer.Argument(
        metavar="COMMAND", help="The command whose --json output to describe, e.g. analyze, 'design drift' or "
                                "design drift; none: list the commands.", show_default=False)] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", metavar="DIR", help="Write every command's schema into DIR as COMMAND.schema.json.")] = None,
) -> None:
    """Print the JSON Schema (draft 2020-12) of a command's --json output."""
    if out is not None:
        from nlobs.workflows import atomic_write_text

        try:
            out.mkdir(parents=True, exist_ok=True)
            for name in COMMANDS:
                atomic_write_text(out / file_name(name), schema_text(name))
        except OSError as e:
            fail(f"cannot write the schemas into {out}: {e.strerror or e}")
        console().print(f"wrote {len(COMMANDS)} schemas into {out}", markup=False)
        return
    if not command:
        con = console()
        for name, (what, *_rest) in COMMANDS.items():
            con.print(f"{name:20s} {what}", markup=False)
        return
    name = " ".join(command).strip()
    if name not in COMMANDS:
        fail(f"no JSON output is described for {name!r}; one of: {', '.join(COMMANDS)}")
    typer.echo(schema_text(name), nl=False)
