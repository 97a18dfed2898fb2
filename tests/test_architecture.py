"""The layering of docs/architecture.md, and the no-eval rule, checked on the source."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "nlobs"

CORE = {"errors", "_validate", "_io", "_typing", "_progress", "checks", "__init__"}
# layer -> nlobs top-level names it may import (besides itself)
ALLOWED: dict[str, set[str]] = {
    "core": CORE,
    "systems": CORE,
    "geometry": CORE | {"systems"},
    "linear": CORE | {"systems"},
    "synthesis": CORE | {"systems", "linear"},
    "observers": CORE | {"systems", "linear", "synthesis", "geometry"},
    "simulate": CORE | {"systems", "linear", "synthesis", "geometry", "observers"},
    "analysis": CORE | {"systems", "linear", "geometry"},
    "navigation": CORE | {"systems", "linear", "synthesis", "observers", "simulate"},
    "workflows": CORE | {"systems", "linear", "synthesis", "observers", "simulate", "geometry", "navigation", "analysis"},
    "papers": CORE | {"systems", "linear", "synthesis", "observers", "simulate", "geometry", "navigation", "analysis",
                      "workflows"},
}


def _layer(path: Path) -> str:
    rel = path.relative_to(SRC)
    top = rel.parts[0].removesuffix(".py")
    if top in CORE:
        return "core"
    return top


def _nlobs_imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("nlobs"):
            parts = node.module.split(".")
            if len(parts) > 1:
                out.add(parts[1])
            else:
                out.update(a.name for a in node.names)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("nlobs."):
                    out.add(a.name.split(".")[1])
    return out


MODULES = sorted(p for p in SRC.rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(SRC)))
def test_layer_imports_only_lower_layers(path: Path) -> None:
    layer = _layer(path)
    if layer == "cli":
        return
    assert layer in ALLOWED, f"{path.relative_to(SRC)}: layer {layer!r} is not in docs/architecture.md"
    bad = _nlobs_imports(path) - ALLOWED[layer] - {layer}
    assert not bad, f"{path.relative_to(SRC)} (layer {layer}) imports {sorted(bad)}"


FORBIDDEN_CALLS = {"eval", "exec", "sympify", "parse_expr", "S"}


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(SRC)))
def test_no_eval_exec_or_sympify_of_text(path: Path) -> None:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""
            assert name not in FORBIDDEN_CALLS, f"{path.relative_to(SRC)}:{node.lineno} calls {name}()"


def test_the_checker_catches_a_violation(tmp_path: Path) -> None:
    bad = tmp_path / "m.py"
    bad.write_text("from nlobs.cli import app\nimport nlobs.simulate.loop\nx = eval('1')\n")
    assert _nlobs_imports(bad) == {"cli", "simulate"}
