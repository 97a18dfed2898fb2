"""Every command's ``--json`` output validates against the JSON Schema that ``nlobs schema COMMAND`` prints
(draft 2020-12, checked by ``jsonschema``, an implementation independent of nlobs); the schemas are strict
(``additionalProperties: false`` where the README calls the keys stable), so a key added or renamed in a report
without its declaration fails here, and the copies shipped in the package are the ones the code builds."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator
from typer.testing import CliRunner

from nlobs._schema import NUMBER, STRING, Record, ReportSchemaError, array, document_schema
from nlobs.cli import app
from nlobs.cli.schema import COMMANDS, command_schema, file_name, schema_text

SHIPPED = Path(__file__).resolve().parents[1] / "src" / "nlobs" / "data" / "schemas"


def _validator(command: str) -> Draft202012Validator:
    schema = command_schema(command)
    Draft202012Validator.check_schema(schema)
    return Draft202012Validator(schema)


def _errors(command: str, data: object) -> list[str]:
    out = []
    for e in _validator(command).iter_errors(data):
        inner = [f"{list(c.absolute_path)}: {c.message[:160]}" for c in (e.context or [])][:6]
        out.append(f"{list(e.absolute_path)}: {e.message[:160]}" + ("; " + "; ".join(inner) if inner else ""))
    return out


@pytest.mark.parametrize("command", list(COMMANDS))
def test_each_schema_is_a_valid_draft_2020_12_document(command: str) -> None:
    schema = command_schema(command)
    Draft202012Validator.check_schema(schema)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert schema["title"] == f"nlobs {command}: JSON output"


@pytest.mark.parametrize("command", list(COMMANDS))
def test_the_shipped_schema_is_the_one_the_code_builds(command: str) -> None:
    """``src/nlobs/data/schemas`` is written by ``nlobs schema --out``: a change of a report's declaration without
    writing them again fails here."""
    assert (SHIPPED / file_name(command)).read_text(encoding="utf-8") == schema_text(command), (
        f"run: nlobs schema --out src/nlobs/data/schemas ({command})")


CASES = [
    ("analyze", ["analyze", "pendulum", "--json"]),
    ("analyze", ["analyze", "grip-example1-filter", "--json"]),
    ("analyze", ["analyze", "khajenejad-6-1", "--json"]),
    ("advise", ["advise", "two-tank", "--json"]),
    ("design drift", ["design", "drift", "pendulum", "--json"]),
    ("design pinv", ["design", "pinv", "isidori-146", "--json"]),
    ("design cascade", ["design", "cascade", "chemostat-analyser", "--json"]),
    ("design setvalued", ["design", "setvalued", "khajenejad-6-1", "--json"]),
    ("design setvalued", ["design", "setvalued", "khajenejad-6-2", "--json"]),
    ("export", ["export", "pendulum", "--observer", "luenberger", "--json"]),
    ("export", ["export", "cartpole", "--observer", "ukf", "--json"]),
    ("simulate", ["simulate", "cartpole", "--observer", "luenberger,ekf,ukf,pinv,drift", "--runs", "2",
                  "--duration", "1", "--json"]),
    ("simulate", ["simulate", "double-integrator-discrete", "--runs", "2", "--duration", "2", "--json"]),
    ("simulate", ["simulate", "chemostat-analyser", "--observer", "cascade,ekf", "--runs", "2", "--duration", "2",
                  "--json"]),
    ("simulate setvalued", ["simulate", "setvalued", "khajenejad-6-1", "--runs", "4", "--json"]),
    ("simulate setvalued", ["simulate", "setvalued", "khajenejad-6-2", "--json"]),
    ("simulate gnss-ins", ["simulate", "gnss-ins", "--flights", "2", "--duration", "5", "--json"]),
    ("demo gnss-ins", ["demo", "gnss-ins", "--duration", "5", "--no-ekf", "--gains", "paper", "--json"]),
    ("demo gnss-ins", ["demo", "gnss-ins", "--duration", "8", "--gains", "paper", "--json"]),
    ("models", ["models", "--json"]),
]


@pytest.mark.slow
@pytest.mark.parametrize(("command", "args"), CASES, ids=[" ".join(a[:3]) for _, a in CASES])
def test_the_commands_output_validates_against_its_schema(command: str, args: list[str], tmp_path: Path) -> None:
    if args[0] in ("export", "demo") or args[:2] in (["simulate", "setvalued"], ["simulate", "gnss-ins"]):
        args = [*args, "--out", str(tmp_path / "out")]
    res = CliRunner().invoke(app, args)
    assert res.exit_code in (0, 1, 3), res.output
    data = json.loads(res.stdout)
    assert _errors(command, data) == []


def test_the_reproduce_schema_describes_its_rows() -> None:
    from nlobs.papers.reproduce import ReproRow

    rows = [ReproRow("K_pp of (9)", 128.9, 128.93, "rounded in the paper").to_dict(),
            ReproRow("Σ2 minimum phase", True, True, "").to_dict(),
            ReproRow("eigenvalues", None, [[-6.3, 5.377], [-6.3, -5.377]], "").to_dict()]
    assert _errors("reproduce", rows) == []
    assert _errors("reproduce", [{**rows[0], "extra": 1}])  # a key the rows do not have


def _simulate_report() -> dict:
    res = CliRunner().invoke(app, ["simulate", "cartpole", "--observer", "luenberger,ekf", "--runs", "2",
                                   "--duration", "1", "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


@pytest.mark.slow
def test_the_schema_is_strict_where_the_keys_are_stable() -> None:
    data = _simulate_report()
    assert _errors("simulate", data) == []
    for change in (
        lambda d: d.update(extra_top_level_key=1),                              # an undeclared key at the top
        lambda d: d.pop("observers"),                                           # a required key missing
        lambda d: d["observers"]["luenberger"].update(rms=1.0),                 # an undeclared key in an outcome
        lambda d: d["observers"]["ekf"]["consistency"].update(nees_inside="x"),  # a wrong type, one level deeper
        lambda d: d["observers"]["luenberger"]["design"].pop("status"),         # the design object's keys
        lambda d: d.update(schema_version=2),                                   # another schema version
        lambda d: d["observers"]["luenberger"]["design"]["premises"][0].update(holds="yes"),  # a Check's type
    ):
        broken = copy.deepcopy(data)
        change(broken)
        assert _errors("simulate", broken), "the schema accepted a report it should refuse"


def test_a_report_cannot_write_a_key_its_schema_does_not_declare() -> None:
    rec = Record("R", {"a": NUMBER, "b": array(STRING)}, optional={"b"})
    assert rec.emit({"a": 1.0}) == {"a": 1.0}
    with pytest.raises(ReportSchemaError, match=r"keys not declared in its schema: \['c'\]"):
        rec.emit({"a": 1.0, "c": 2})
    with pytest.raises(ReportSchemaError, match=r"declared keys missing from the report: \['a'\]"):
        rec.emit({"b": []})
    doc = document_schema(rec, "r")
    assert doc["required"] == ["schema_version", "a"] and doc["additionalProperties"] is False
    assert Draft202012Validator(doc).is_valid({"schema_version": 1, "a": None, "b": ["x"]})  # non-finite: null
    assert not Draft202012Validator(doc).is_valid({"schema_version": 1, "a": "1"})


def test_the_schema_command() -> None:
    r = CliRunner()
    listed = r.invoke(app, ["schema"])
    assert listed.exit_code == 0 and all(name in listed.stdout for name in COMMANDS)
    one = r.invoke(app, ["schema", "design", "drift"])
    assert one.exit_code == 0 and json.loads(one.stdout) == command_schema("design drift")
    assert r.invoke(app, ["schema", "design drift"]).stdout == one.stdout
    bad = r.invoke(app, ["schema", "nope"])
    assert bad.exit_code == 2 and "no JSON output is described for 'nope'" in bad.stderr


def test_the_schema_command_writes_every_schema(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["schema", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(file_name(c) for c in COMMANDS)
    blocked = tmp_path / "file"
    blocked.write_text("x")
    res = CliRunner().invoke(app, ["schema", "--out", str(blocked / "sub")])
    assert res.exit_code == 2 and "cannot write the schemas" in res.stderr
