"""MkDocs hook: the pages generated from the code and the README, so that they cannot drift from them.

* ``reference/cli.md`` — the ``--help`` of every command, rendered from the typer app;
* ``reference/model-files.md`` and ``reference/json.md`` — the README's sections on model files and on
  the JSON reports (the README stays the one source);
* ``reference/api.md`` — mkdocstrings directives for every public name of :mod:`nlobs`;
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


def _api_reference() -> str:
    import nlobs

    groups: dict[str, list[str]] = {}
    for name, module in sorted(nlobs._LAZY.items(), key=lambda kv: (kv[1], kv[0])):
        groups.setdefault(module, []).append(name)
    out = ["# Python API", "",
           "The names `import nlobs` offers, grouped by the module that holds them (generated from the "
           "docstrings; the papers' equation numbers are in them).", ""]
    for module, names in groups.items():
        out += [f"## `{module}`", ""]
        for name in names:
            if name == "simulate" and module == "nlobs.simulate":
                continue
            out += [f"::: {module}.{name}", "    options:", "      heading_level: 3", ""]
    return "\n".join(out) + "\n"


def on_files(files, config):  # noqa: ANN001, ANN201 - the MkDocs hook signature
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    pages = {
        "reference/cli.md": _cli_reference(),
        "reference/model-files.md": "# Model files\n\n" + re.sub(
            r"^### Model files\n", "", _section(readme, "### Model files", "## Command line"), flags=re.M),
        "reference/json.md": "# JSON reports\n\n" + _section(readme, "Every JSON report", "## Documentation")
        .replace("### ", "## "),
        "reference/api.md": _api_reference(),
        "changelog.md": (ROOT / "CHANGELOG.md").read_text(encoding="utf-8"),
    }
    for uri, content in pages.items():
        files.append(File.generated(config, uri, content=content))
    return files
