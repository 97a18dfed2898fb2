"""The layering of docs/architecture.md and the no-eval rule, checked on the source (every module, the CLI included).

The rules:

* a layer imports only the layers below it (``ALLOWED``), at module level or inside functions;
* the CLI imports only the workflows, the reproduce entry (``nlobs.papers.reproduce``), the model-file
  loader (``nlobs.systems.modelfile``) and the errors (plus its own modules);
* the papers (the reading room) are imported only by the reproduce entry and by themselves;
* nothing calls ``eval``, ``exec``, ``sympify``, ``parse_expr`` or ``S``.

The checker is tested on modules written to a temporary folder, so the rules can fail.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "nlobs"

CORE = {"errors", "_validate", "_io", "_typing", "_progress", "_lazy", "checks"}
BELOW_WORKFLOWS = CORE | {"systems", "geometry", "linear", "synthesis", "observers", "simulate", "navigation", "export"}
# layer -> nlobs top-level names it may import (besides itself)
ALLOWED: dict[str, set[str]] = {
    "core": CORE,
    "systems": CORE,
    "geometry": CORE | {"systems"},
    "linear": CORE | {"systems"},
    "synthesis": CORE | {"systems", "geometry", "linear"},
    "observers": CORE | {"systems", "geometry", "linear", "synthesis"},
    "simulate": CORE | {"systems", "geometry", "linear", "synthesis", "observers"},
    "navigation": CORE | {"systems", "linear", "synthesis", "observers", "simulate"},
    "export": CORE | {"systems", "geometry", "linear", "synthesis", "observers", "simulate", "navigation"},
    "workflows": BELOW_WORKFLOWS,
    "papers": BELOW_WORKFLOWS | {"workflows", "api"},
    "api": BELOW_WORKFLOWS | {"workflows"},
}
#: What the CLI may import: dotted module prefixes.
CLI_ALLOWED = ("nlobs.workflows", "nlobs.papers.reproduce", "nlobs.systems.modelfile", "nlobs.errors", "nlobs.cli")


def layer_of(rel: Path) -> str:
    """The layer of a module, from its path relative to ``src/nlobs``."""
    top = rel.parts[0].removesuffix(".py")
    if top == "__init__" and len(rel.parts) == 1:
        return "api"
    if top == "__main__" and len(rel.parts) == 1:
        return "cli"  # ``python -m nlobs``: the command line
    if top in CORE:
        return "core"
    return top


def imports_of(tree: ast.AST) -> set[str]:
    """Every ``nlobs`` module a module imports (dotted names), at module level or inside functions."""
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 and (
                node.module == "nlobs" or node.module.startswith("nlobs.")):
            if node.module == "nlobs":
                out.update(f"nlobs.{a.name}" for a in node.names)
            else:
                out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name == "nlobs" or a.name.startswith("nlobs."))
    return out


def violations(path: Path, rel: Path) -> list[str]:
    """The rule violations of one module (empty when it obeys every rule)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    layer = layer_of(rel)
    mods = imports_of(tree)
    out = []
    if layer == "cli":
        out += [f"the CLI imports {m}" for m in sorted(mods) if not m.startswith(CLI_ALLOWED)]
    else:
        if layer not in ALLOWED:
            return [f"layer {layer!r} is not in docs/architecture.md"]
        for m in sorted(mods):
            parts = m.split(".")
            top = parts[1] if len(parts) > 1 else "api"
            if top == "__init__":
                top = "api"
            if top != layer and top not in ALLOWED[layer]:
                out.append(f"layer {layer} imports {m}")
    if layer not in ("papers", "cli"):
        out += [f"imports the reading room: {m}" for m in sorted(mods) if m.startswith("nlobs.papers")]
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""
            if name in FORBIDDEN_CALLS:
                out.append(f"line {node.lineno} calls {name}()")
    return out


FORBIDDEN_CALLS = {"eval", "exec", "sympify", "parse_expr", "S"}
MODULES = sorted(p for p in SRC.rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(SRC)))
def test_module_obeys_the_layering(path: Path) -> None:
    assert not violations(path, path.relative_to(SRC)), violations(path, path.relative_to(SRC))


@pytest.mark.parametrize(("rel", "text", "expected"), [
    ("cli/bad.py", "from nlobs.simulate.loop import simulate\n", "the CLI imports nlobs.simulate.loop"),
    ("cli/bad.py", "def f():\n    from nlobs.papers.khajenejad_yong import monte_carlo\n",
     "the CLI imports nlobs.papers.khajenejad_yong"),
    ("cli/bad.py", "import nlobs.observers.setvalued\n", "the CLI imports nlobs.observers.setvalued"),
    ("systems/bad.py", "from nlobs.simulate import simulate\n", "layer systems imports nlobs.simulate"),
    ("synthesis/bad.py", "def f():\n    from nlobs.observers.luenberger import LuenbergerObserver\n",
     "layer synthesis imports nlobs.observers.luenberger"),
    ("workflows/bad.py", "from nlobs.papers.dallamora2000 import simulate_drift\n",
     "imports the reading room: nlobs.papers.dallamora2000"),
    ("workflows/bad.py", "from nlobs.cli.common import fail\n", "layer workflows imports nlobs.cli.common"),
    ("observers/bad.py", "x = eval('1')\n", "line 1 calls eval()"),
    ("linear/bad.py", "import sympy as sp\nx = sp.sympify('x')\n", "line 2 calls sympify()"),
    ("newroom/bad.py", "x = 1\n", "layer 'newroom' is not in docs/architecture.md"),
])
def test_the_checker_catches_a_violation(tmp_path: Path, rel: str, text: str, expected: str) -> None:
    bad = tmp_path / rel
    bad.parent.mkdir(parents=True)
    bad.write_text(text)
    assert expected in violations(bad, Path(rel))


@pytest.mark.parametrize("rel", ["cli/ok.py", "papers/ok.py"])
def test_the_checker_accepts_what_the_rules_allow(tmp_path: Path, rel: str) -> None:
    ok = tmp_path / rel
    ok.parent.mkdir(parents=True)
    ok.write_text("from nlobs.workflows import analyze\nfrom nlobs.errors import NlobsError\n"
                  + ("from nlobs.papers.reproduce import PAPERS\nfrom nlobs.systems.modelfile import load_model\n"
                     if rel.startswith("cli") else "from nlobs.simulate import simulate\n"))
    assert violations(ok, Path(rel)) == []
