"""The wheel a user installs: built from this tree, it carries the license, the type marker and every
shipped model, declares the same dependency floors as ``pyproject.toml``, and leaves the tests out."""

from __future__ import annotations

import subprocess
import sys
import tomllib
import zipfile
from email.parser import Parser
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    res = subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(out), str(ROOT)],
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    (whl,) = out.glob("nlobs-*.whl")
    return whl


def test_wheel_carries_license_type_marker_and_models(wheel: Path) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "nlobs/py.typed" in names
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    shipped = {p.name for p in (ROOT / "src" / "nlobs" / "data" / "models").glob("*.toml")}
    assert shipped and {n.rsplit("/", 1)[-1] for n in names if n.startswith("nlobs/data/models/")} >= shipped
    schemas = {p.name for p in (ROOT / "src" / "nlobs" / "data" / "schemas").glob("*.schema.json")}
    assert len(schemas) == 14 and {n.rsplit("/", 1)[-1] for n in names if n.startswith("nlobs/data/schemas/")} == schemas
    assert not any(n.startswith("tests/") or "/tests/" in n for n in names)
    assert "nlobs/__main__.py" in names


def test_wheel_metadata_matches_pyproject(wheel: Path) -> None:
    z = zipfile.ZipFile(wheel)
    (meta_name,) = [n for n in z.namelist() if n.endswith(".dist-info/METADATA")]
    meta = Parser().parsestr(z.read(meta_name).decode())
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert meta["Version"] == project["version"] and meta["License"] == "MIT"
    runtime = sorted(d for d in meta.get_all("Requires-Dist") if "extra ==" not in d)
    assert runtime == sorted(d.replace(" ", "") for d in project["dependencies"])
    assert "Typing :: Typed" in meta.get_all("Classifier")
    # the classifiers claim only the Python versions CI runs the tests on (3.11: the only one on its machines)
    claimed = [c.rsplit(" ", 1)[-1] for c in meta.get_all("Classifier") if c.startswith("Programming Language :: Python :: 3.")]
    assert claimed == ["3.11"] and meta["Requires-Python"] == ">=3.11"


@pytest.mark.slow
def test_docs_build_fails_on_a_broken_link(tmp_path: Path) -> None:
    # the site's strictness: a page with a link to a missing page aborts the build (make docs)
    pytest.importorskip("mkdocs")
    import shutil

    site = tmp_path / "tree"
    shutil.copytree(ROOT / "docs", site / "docs")
    for f in ("mkdocs.yml", "README.md", "CHANGELOG.md"):
        shutil.copy(ROOT / f, site / f)
    shutil.copytree(ROOT / "src", site / "src")
    (site / "docs" / "drift.md").write_text((site / "docs" / "drift.md").read_text() + "\nSee [x](missing.md).\n")
    env = {**__import__("os").environ, "NO_MKDOCS_2_WARNING": "1"}
    res = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(site / "mkdocs.yml")],
                         capture_output=True, text=True, timeout=600, env=env)
    assert res.returncode != 0 and "missing.md" in res.stderr
