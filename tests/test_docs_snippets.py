"""Every Python snippet of the README and of ``docs/`` runs as printed, from a folder outside the checkout.

A snippet is a fenced ``python`` block; it runs in a fresh interpreter whose working directory is a
temporary folder, so a snippet that names a file of the source tree instead of a shipped model, or
imports a module that moved, fails here.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def snippets() -> list[tuple[str, str]]:
    out = []
    for page in PAGES:
        for i, m in enumerate(BLOCK.finditer(page.read_text(encoding="utf-8"))):
            out.append((f"{page.relative_to(ROOT)}[{i}]", m.group(1)))
    return out


SNIPPETS = snippets()


def test_the_pages_have_snippets() -> None:
    assert len(SNIPPETS) >= 9, [name for name, _ in SNIPPETS]


@pytest.mark.slow
@pytest.mark.parametrize(("name", "code"), SNIPPETS, ids=[name for name, _ in SNIPPETS])
def test_snippet_runs(tmp_path: Path, name: str, code: str) -> None:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, f"{name} failed:\n{done.stderr[-3000:]}"
