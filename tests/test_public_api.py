"""The curated top-level API: every advertised name resolves to the object of its home module, and
``import nlobs`` stays light (no NumPy, SymPy, CVXPY or matplotlib until a name is used)."""

from __future__ import annotations

import importlib
import inspect
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

import pytest

import nlobs

HEAVY = ("numpy", "sympy", "cvxpy", "scipy", "matplotlib")


def test_import_nlobs_loads_no_numerical_library() -> None:
    code = ("import sys, nlobs, nlobs.workflows, nlobs.systems; "
            f"print([m for m in {HEAVY!r} if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


@pytest.mark.parametrize("name", [n for n in nlobs.__all__ if n != "__version__"])
def test_every_public_name_is_its_home_modules_object(name: str) -> None:
    obj = getattr(nlobs, name)
    home = importlib.import_module(nlobs._LAZY[name])
    assert obj is (home if home.__name__ == f"nlobs.{name}" else getattr(home, name))
    assert obj.__doc__, f"nlobs.{name} has no docstring"


def test_the_public_names_cover_each_method_and_the_one_house() -> None:
    expected = {"load_model", "simulate", "run_observer", "SimulationResult", "Observer", "CorrectingObserver",
                "Certificate", "Check", "NlobsError", "CascadeObserver", "DriftObserver", "PinvObserver",
                "SetValuedObserver", "GnssInsObserver", "ExtendedKalmanFilter", "analyze_model"}
    assert expected <= set(nlobs.__all__)
    assert nlobs.__all__ == sorted(nlobs.__all__)
    assert set(dir(nlobs)) >= set(nlobs.__all__)
    # a public name that is also a subpackage is the subpackage itself (importing it sets that attribute), and
    # only ``simulate`` is one: the package is callable as its loop, with the loop's signature
    subpackages = {p.name for p in Path(nlobs.__file__).parent.iterdir() if (p / "__init__.py").exists()}
    assert subpackages & set(nlobs.__all__) == {"simulate"}
    assert nlobs.simulate is sys.modules["nlobs.simulate"]
    assert inspect.signature(nlobs.simulate) == inspect.signature(nlobs.simulate.simulate)


def test_an_unknown_name_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no attribute 'eval'"):
        nlobs.eval  # noqa: B018


def test_the_version_is_the_installed_distributions_and_the_clis() -> None:
    from typer.testing import CliRunner

    from nlobs.cli import app

    assert nlobs.__version__ == version("nlobs")
    out = CliRunner().invoke(app, ["version"])
    assert out.exit_code == 0 and out.stdout.strip() == nlobs.__version__


def test_the_top_level_objects_work_together() -> None:
    import numpy as np

    model = nlobs.load_model("pendulum")
    assert model.n == 2 and nlobs.load_model(nlobs.shipped_models()["pendulum"]).n == 2
    system = nlobs.LinearSystem(np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]]),
                                np.array([[1.0, 0.0]]))
    obs = nlobs.LuenbergerObserver(system, np.array([[3.0], [2.0]]))  # poles of A − LC: −1, −2
    assert isinstance(obs, nlobs.Observer)
    res = nlobs.simulate(system, obs, np.array([1.0, 0.0]), np.zeros(2), duration=8.0, dt=0.01, u=0.0)
    assert isinstance(res, nlobs.SimulationResult)
    same = nlobs.simulate.simulate(system, obs, np.array([1.0, 0.0]), np.zeros(2), duration=8.0, dt=0.01, u=0.0)
    np.testing.assert_array_equal(res.x_hat, same.x_hat)
    # error e(t) = exp((A − LC) t) e0 with e0 = (1, 0): e1'' + 3e1' + 2e1 = 0, e1(0) = 1, e1'(0) = −3,
    # so e1(t) = −e^{−t} + 2e^{−2t}
    e1 = res.x[:, 0] - res.x_hat[:, 0]
    for k in (100, 400, 800):
        t = res.t[k]
        assert e1[k] == pytest.approx(-np.exp(-t) + 2 * np.exp(-2 * t), abs=1e-9)


SUBPACKAGES = ("systems", "geometry", "linear", "synthesis", "observers", "simulate", "navigation", "workflows")


@pytest.mark.parametrize("package", SUBPACKAGES)
def test_every_subpackage_name_resolves(package: str) -> None:
    mod = importlib.import_module(f"nlobs.{package}")
    assert mod.__all__, f"nlobs.{package} exports nothing"
    missing = [n for n in mod.__all__ if not hasattr(mod, n)]
    assert not missing, missing
    with pytest.raises(AttributeError):
        getattr(mod, "no_such_name")


@pytest.mark.parametrize("package", ["nlobs.synthesis", "nlobs.observers"])
def test_a_lazy_package_names_what_its_static_imports_name(package: str) -> None:
    """``nlobs.synthesis`` and ``nlobs.observers`` import a module on first use of one of its names; the imports
    under ``TYPE_CHECKING`` (what type checkers and the API reference read) must name the same modules, and each
    name must be its home module's object."""
    import ast

    pkg = importlib.import_module(package)
    tree = ast.parse(Path(pkg.__file__).read_text(encoding="utf-8"))
    static: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            for imp in node.body:
                assert isinstance(imp, ast.ImportFrom)
                static.update({a.name: str(imp.module) for a in imp.names})
    eager = {name: static[name] for name in static if name not in pkg._EXPORTS}  # bound when the package loads
    assert set(eager) <= {"affine_abstraction"}  # a function named like its module (see the package's source)
    assert {**pkg._EXPORTS, **eager} == static
    assert sorted(pkg.__all__) == sorted(static)
    for name, module in static.items():
        assert getattr(pkg, name) is getattr(importlib.import_module(module), name)
