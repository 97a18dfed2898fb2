"""MkDocs hook: the pages generated from the code and the README, so that they cannot drift from them.

* ``reference/cli.md`` — the ``--help`` of every command, rendered from the typer app;
* ``reference/model-files.md`` and ``reference/json.md`` — the README's sections on model files and on
  the JSON reports (the README stays the one source);
* ``reference/api.md`` — every public name of :mod:`nlobs`, linked to ``reference/api/PACKAGE.md``, one page per
  package with mkdocstrings directives for what it exports (the docstrings' Sphinx roles become links:
  ``docs/griffe_roles.py``);
* ``reference/schemas.md`` and ``reference/schemas/*.schema.json`` — the JSON Schema of every ``--json`` output;
* ``tutorials/NAME.md`` — ``docs/_tutorials/NAME.md`` executed: every Python block runs, its output and figures
  are made by the build;
* ``changelog.md`` — ``CHANGELOG.md``.
"""

from __future__ import annotations

import re
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parent.parent


def _section(text: str, start: str, stop: str) -> str:
    i = text.index(start)
    j = text.index(stop, i + len(start))
    return text[i:j].strip() + "\n"


def _cli_reference() -> str:
    from typer.main import get_command

    from nlobs.cli import app

    out = ["# Command line", "",
           "Every command of `nlobs`, with the help it prints (`nlobs COMMAND --help`). Exit statuses: 0 success, "
           "1 a design or simulation failure, 2 bad input (one line naming the file, line and text), 3 no observer "
           "of the requested structure exists.", ""]

    def context(cmd, name, parent=None):  # noqa: ANN001, ANN202 - click's (or typer's vendored click's) types
        return cmd.context_class(cmd, info_name=name, parent=parent, terminal_width=100, max_content_width=100)

    def walk(cmd, ctx) -> None:  # noqa: ANN001
        out.extend([f"## `{ctx.command_path}`", "", "```text", cmd.get_help(ctx).rstrip(), "```", ""])
        if hasattr(cmd, "list_commands"):
            for name in cmd.list_commands(ctx):
                sub = cmd.get_command(ctx, name)
                if sub is not None and not getattr(sub, "hidden", False):
                    walk(sub, context(sub, name, ctx))

    root = get_command(app)
    walk(root, context(root, "nlobs"))
    return "\n".join(out) + "\n"


#: The API reference's pages: each package of the public API, what it holds (the nav's order).
API_PAGES: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("systems", "Plants and models", ("nlobs.systems",)),
    ("observers", "Observers", ("nlobs.observers",)),
    ("synthesis", "Gains and certificates", ("nlobs.synthesis",)),
    ("simulate", "Simulation and Monte Carlo", ("nlobs.simulate", "nlobs.simulate.sweep")),
    ("methods", "Methods: one design per plant", ("nlobs.methods", "nlobs.methods.estimation")),
    ("workflows", "Workflows: one call per command", ("nlobs.workflows",)),
    ("export", "Generated C", ("nlobs.export",)),
    ("navigation", "GNSS/INS navigation", ("nlobs.navigation",)),
    ("linear", "Linear analysis", ("nlobs.linear",)),
    ("geometry", "Differential geometry", ("nlobs.geometry",)),
    ("core", "Checks and errors", ("nlobs.checks", "nlobs.errors")),
)


def _documented(obj: object) -> bool:
    import inspect

    return (inspect.isclass(obj) or inspect.isfunction(obj)) and getattr(obj, "__module__", "").startswith("nlobs")


def api_objects() -> dict[str, list[tuple[str, str]]]:
    """Per page of :data:`API_PAGES`: ``(defining module, dotted path)`` of each class and function it renders,
    each object on the first page whose packages export it (``__all__``; ``nlobs.checks`` and ``nlobs.errors``
    every public name), and every name ``import nlobs`` offers somewhere."""
    import importlib

    import nlobs

    seen: set[str] = set()
    pages: dict[str, list[tuple[str, str]]] = {}
    for slug, _title, packages in API_PAGES:
        rows = pages.setdefault(slug, [])
        for package in packages:
            mod = importlib.import_module(package)
            names = getattr(mod, "__all__", None) or [n for n in vars(mod) if not n.startswith("_")]
            for name in names:
                obj = getattr(mod, name, None)
                if not _documented(obj):
                    continue
                path = f"{obj.__module__}.{obj.__qualname__}"
                if path not in seen:
                    seen.add(path)
                    rows.append((obj.__module__, path))
    for name, module in sorted(nlobs._LAZY.items()):
        obj = getattr(importlib.import_module(module), name)
        if _documented(obj) and f"{obj.__module__}.{obj.__qualname__}" not in seen:
            raise RuntimeError(f"nlobs.{name} is on no API page: add its package to API_PAGES")
    return pages


def _api_pages() -> dict[str, str]:
    """``reference/api.md`` (every name ``import nlobs`` offers, linked) and one page per package."""
    import importlib
    import inspect

    import nlobs

    pages = api_objects()
    out: dict[str, str] = {}
    index = ["# Python API", "",
             "Every name `import nlobs` offers, with the first line of its documentation; the pages below hold the "
             "whole reference, one per package, grouped by the module that defines each name. The papers' equation "
             "numbers are in the docstrings, and every name shows its use in an example that the test suite runs.",
             "", "| name | what it is |", "|---|---|"]
    for name, module in sorted(nlobs._LAZY.items(), key=lambda kv: kv[0].lower()):
        obj = getattr(importlib.import_module(module), name)
        if not _documented(obj):
            continue
        first = (inspect.getdoc(obj) or "").strip().split("\n\n", 1)[0].replace("\n", " ").replace("|", "\\|")
        first = re.sub(r":(?:py:)?[a-z]+:`~?([^`]+)`", lambda m: f"`{m[1].rsplit('.', 1)[-1]}`", first)
        index.append(f"| [`{name}`][{obj.__module__}.{obj.__qualname__}] | {first} |")
    index += ["", "## By package", ""]
    for slug, title, packages in API_PAGES:
        index.append(f"- [{title}](api/{slug}.md): " + ", ".join(f"`{p}`" for p in packages))
    out["reference/api.md"] = "\n".join(index) + "\n"
    for slug, title, packages in API_PAGES:
        lines = [f"# {title}", ""]
        for package in packages:
            lines += [f"::: {package}", "    options:", "      members: false", "      show_root_heading: false", ""]
        current = None
        for module, path in pages[slug]:
            if module != current:
                lines += [f"## `{module}`", ""]
                current = module
            lines += [f"::: {path}", "    options:", "      heading_level: 3", ""]
        out[f"reference/api/{slug}.md"] = "\n".join(lines) + "\n"
    return out


def _schemas() -> dict[str, str | bytes]:
    """``reference/schemas.md`` and, beside it, every command's schema as a file (``nlobs schema COMMAND``)."""
    from nlobs.cli.schema import COMMANDS, command_schema, file_name, schema_text

    out: dict[str, str | bytes] = {}
    lines = ["# JSON Schemas", "",
             "Every command that prints JSON (`--json`) has a JSON Schema (draft 2020-12) of its output, built from "
             "the same declarations its report is written through: `nlobs schema COMMAND` prints it, "
             "`nlobs schema --out DIR` writes them all, and the package ships them "
             "(`nlobs/data/schemas/COMMAND.schema.json`, e.g. `importlib.resources.files('nlobs') / "
             "'data/schemas/analyze.schema.json'`). The test suite validates every command's output against "
             "its schema. Objects whose keys the README calls stable are closed (`additionalProperties: false`); "
             "the parts whose keys depend on the method (a design's `parameters`, a certificate's numbers) are open.",
             "", "```python", "import json, subprocess", "from jsonschema import Draft202012Validator",
             "schema = json.loads(subprocess.run(['nlobs', 'schema', 'analyze'], capture_output=True).stdout)",
             "report = json.loads(subprocess.run(['nlobs', 'analyze', 'pendulum', '--json'], "
             "capture_output=True).stdout)",
             "Draft202012Validator(schema).validate(report)", "```", ""]
    for command, (what, *_rest) in COMMANDS.items():
        name = file_name(command)
        out[f"reference/schemas/{name}"] = schema_text(command)
        schema = command_schema(command)
        lines += [f"## `nlobs {command}`", "", f"{what[0].upper()}{what[1:]}: [{name}](schemas/{name}).", ""]
        props = schema.get("properties") or {}
        if props:
            lines += ["| key | schema | meaning |", "|---|---|---|"]
            for key, sub in props.items():
                kind = sub.get("$ref", "").rsplit("/", 1)[-1] or sub.get("type") or (
                    "any of " + ", ".join(a.get("$ref", "").rsplit("/", 1)[-1] or str(a.get("type"))
                                          for a in sub.get("anyOf", [])) if "anyOf" in sub else "") or sub.get(
                    "const", "")
                if isinstance(kind, list):
                    kind = " or ".join(kind)
                desc = str(sub.get("description", "")).replace("|", "\\|")
                lines.append(f"| `{key}` | {kind} | {desc} |")
            lines.append("")
    out["reference/schemas.md"] = "\n".join(lines) + "\n"
    return out


#: A fenced Python block of a tutorial.
_BLOCK = re.compile(r"^```python\n(.*?)^```\n", flags=re.S | re.M)


def _tutorials() -> dict[str, str | bytes]:
    """Every ``docs/_tutorials/NAME.md`` run as it is built: its Python blocks execute in order, in one fresh
    interpreter in an empty folder, each followed on the page by what it printed; the figures the blocks save
    there are published beside the page (``tutorials/NAME/FILE.png``). A block that fails fails the build."""
    import os
    import subprocess
    import sys
    import tempfile

    out: dict[str, str | bytes] = {}
    for src in sorted((ROOT / "docs" / "_tutorials").glob("*.md")):
        text = src.read_text(encoding="utf-8")
        blocks = _BLOCK.findall(text)
        marker = "\u241e-block-end-\u241e"
        script = "".join(f"{b}\nprint({marker!r}, flush=True)\n" for b in blocks)
        with tempfile.TemporaryDirectory(prefix=f"nlobs-tutorial-{src.stem}-") as tmp:
            env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONHASHSEED": "0"}
            run = subprocess.run([sys.executable, "-c", script], cwd=tmp, capture_output=True, text=True, env=env,
                                 timeout=600)
            if run.returncode != 0:
                raise RuntimeError(f"tutorial {src.name} failed:\n{run.stderr[-3000:]}")
            printed = run.stdout.split(marker + "\n")
            for png in sorted(Path(tmp).glob("*.png")):
                out[f"tutorials/{src.stem}/{png.name}"] = png.read_bytes()
        pieces = iter(printed)

        def with_output(m: re.Match[str]) -> str:
            shown = next(pieces, "").rstrip()
            return m.group(0) + (f"\n```text\n{shown}\n```\n" if shown else "")

        out[f"tutorials/{src.stem}.md"] = _BLOCK.sub(with_output, text).replace("](figures/", f"]({src.stem}/")
    return out


def on_files(files, config):  # noqa: ANN001, ANN201 - the MkDocs hook signature
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    pages = {
        "reference/cli.md": _cli_reference(),
        "reference/model-files.md": "# Model files\n\n" + re.sub(
            r"^### Model files\n", "", _section(readme, "### Model files", "## Command line"), flags=re.M),
        "reference/json.md": "# JSON reports\n\n" + _section(readme, "Every JSON report", "## Documentation")
        .replace("### ", "## "),
        **_api_pages(),
        "changelog.md": (ROOT / "CHANGELOG.md").read_text(encoding="utf-8"),
    }
    pages.update(_schemas())
    pages.update(_tutorials())
    for uri, content in pages.items():
        source = files.get_file_from_path(uri)  # a tutorial's source, excluded from the site: the run replaces it
        if source is not None:
            files.remove(source)
        files.append(File.generated(config, uri, content=content))
    return files
