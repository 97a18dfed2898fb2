"""Every JSON report nlobs prints or writes carries ``schema_version`` first; ``jsonable`` turns NumPy values
(NaN and infinities included) into plain JSON."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs._io import SCHEMA_VERSION, jsonable, with_schema
from nlobs.cli import app

COMMANDS = (
    ["analyze", "pendulum", "--json"],
    ["advise", "two-tank", "--json"],
    ["design", "cascade", "chemostat-analyser", "--json"],
    ["design", "drift", "pendulum", "--json"],
    ["simulate", "pendulum", "--observer", "luenberger", "--runs", "2", "--duration", "1", "--json"],
    ["demo", "gnss-ins", "--duration", "5", "--no-ekf", "--json"],
)


@pytest.mark.slow
@pytest.mark.parametrize("args", COMMANDS, ids=lambda a: " ".join(a[:2]))
def test_every_json_report_starts_with_schema_version(args: list[str], tmp_path: Path) -> None:
    extra = ["--out", str(tmp_path)] if args[0] == "demo" else []
    res = CliRunner().invoke(app, args + extra)
    assert res.exit_code in (0, 1, 3), res.output
    d = json.loads(res.stdout)
    assert next(iter(d)) == "schema_version" and d["schema_version"] == SCHEMA_VERSION == 1
    if args[0] == "demo":
        written = json.loads((tmp_path / "results.json").read_text())
        assert written == d


def test_list_outputs_stay_lists() -> None:
    res = CliRunner().invoke(app, ["models", "--json"])
    assert res.exit_code == 0 and isinstance(json.loads(res.stdout), list)


def test_jsonable_turns_numpy_values_and_non_finite_floats_into_json() -> None:
    data = {"a": np.array([1.0, np.nan, np.inf]), "b": np.float32(2.5), "c": np.int64(3), "d": (np.bool_(True),),
            "e": np.array([[1, 2], [3, 4]], dtype=np.int32), 5: -np.inf, "f": [np.float64("nan")]}
    out = jsonable(data)
    text = json.dumps(out, allow_nan=False)
    assert json.loads(text) == {"a": [1.0, None, None], "b": 2.5, "c": 3, "d": [True], "e": [[1, 2], [3, 4]],
                                "5": None, "f": [None]}
    assert with_schema({"x": 1, "schema_version": 7}) == {"schema_version": SCHEMA_VERSION, "x": 1}
    assert with_schema([1, 2]) == [1, 2]
