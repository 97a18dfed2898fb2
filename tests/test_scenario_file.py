"""Model files with sensors, known input signals, process noise, units and run defaults.

Every bad table is a ``ModelFileError`` naming the file and the line, and ``nlobs simulate`` prints it
as one line with exit status 2 (no traceback).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.errors import ModelFileError
from nlobs.systems.modelfile import load_model, load_scenario, parse_scenario

runner = CliRunner()

HEAD = '''name = "pend"
states = ["theta", "omega"]
inputs = ["tau"]
outputs = ["y"]
parameters = { g0 = 9.81, sigma = 0.01 }
[dynamics]
f = ["omega", "-g0*sin(theta)"]
g = [["0"], ["1"]]
h = ["theta"]
'''

FULL = 'units = { t = "s", theta = "rad", omega = "rad/s", y = "rad", tau = "N m" }\n' + HEAD + '''[sensors.encoder]
outputs = ["y"]
rate = 100.0
noise_std = "sigma"
bias = 0.002
outages = [[1.0, 1.5], [3.0, 3.2]]
[input_signals]
tau = { kind = "sine", amplitude = 0.5, frequency = 0.2 }
[process_noise]
covariance = [[0.0, 0.0], [0.0, 1e-4]]
[simulation]
x0 = [0.5, 0.0]
initial_error_std = 0.2
duration = 12.0
dt = 0.002
settle = 3.0
runs = 7
box = [-3, 3]
'''


def test_every_table_is_read() -> None:
    s = parse_scenario(FULL, source="pend.toml")
    (g,) = s.sensors
    assert (g.name, g.outputs, g.rate) == ("encoder", ("y",), 100.0)
    np.testing.assert_allclose(g.noise_std, [0.01])
    np.testing.assert_allclose(g.bias, [0.002])
    assert g.outages == ((1.0, 1.5), (3.0, 3.2))
    assert s.input_signals(2.5)[0] == pytest.approx(0.5 * np.sin(2 * np.pi * 0.2 * 2.5))
    np.testing.assert_allclose(s.process_noise, [[0.0, 0.0], [0.0, 1e-4]])
    d = s.defaults
    np.testing.assert_allclose(d.x0, [0.5, 0.0])
    np.testing.assert_allclose(d.initial_error_std, [0.2, 0.2])
    assert (d.duration, d.dt, d.settle, d.runs) == (12.0, 0.002, 3.0, 7)
    np.testing.assert_allclose(d.box[0], [-3, -3])
    assert s.label("omega") == "omega [rad/s]" and s.time_unit == "s" and s.unit("x") == ""


def test_a_top_level_key_after_a_table_gets_a_hint() -> None:
    with pytest.raises(ModelFileError, match="belongs before the first"):
        parse_scenario(HEAD + 'units = { y = "rad" }\n')


def test_a_file_without_the_tables_keeps_todays_behaviour() -> None:
    s = parse_scenario(HEAD)
    assert s.sensors == () and s.input_signals is None and s.process_noise is None and s.units == {}
    assert s.defaults.x0 is None
    # the shipped models still load, and load_model ignores the tables of a full file
    for name in ("pendulum", "isidori-146", "khajenejad-6-1"):
        assert load_scenario(name).sensors == ()
    assert load_model("pendulum").states == ("theta", "omega")


def test_csv_input_signal_relative_to_the_model_file(tmp_path: Path) -> None:
    (tmp_path / "u.csv").write_text("t,tau\n0,0\n1,2\n2,-1\n")
    (tmp_path / "m.toml").write_text(HEAD + '[input_signals]\ntau = { kind = "csv", file = "u.csv", column = "tau" }\n')
    s = load_scenario(tmp_path / "m.toml")
    assert [s.input_signals(t)[0] for t in (0.5, 1.0, 1.7, 5.0)] == [0.0, 2.0, 2.0, -1.0]


BAD = [
    ('[sensors.a]\noutputs = ["y"]\nrate = 0\n', "rate"),
    ('[sensors.a]\noutputs = ["y"]\nrate = -10\n', "rate"),
    ('[sensors.a]\noutputs = ["y"]\n', "needs 'rate'"),
    ('[sensors.a]\noutputs = ["q"]\nrate = 10\n', "not an output"),
    ('[sensors.a]\noutputs = ["y"]\nrate = 10\n[sensors.b]\noutputs = ["y"]\nrate = 5\n', "in both"),
    ('[sensors.a]\noutputs = ["y"]\nrate = 10\nnoise_cov = [[-1.0]]\n', "positive semidefinite"),
    ('[sensors.a]\noutputs = ["y"]\nrate = 10\nspeed = 3\n', "unknown key"),
    ('[sensors.a]\noutputs = ["y"]\nrate = 10\noutages = [[2, 1]]\n', "end > start"),
    ('[process_noise]\ncovariance = [[1, 2], [2, 1]]\n', "positive semidefinite"),
    ('[process_noise]\ncovariance = [[1, 2], [0, 1]]\n', "not symmetric"),
    ('[process_noise]\nstd = [1, -1]\n', "non-negative"),
    ('[process_noise]\nstd = [1]\ncovariance = [[1, 0], [0, 1]]\n', "exactly one"),
    ('[input_signals]\nforce = 1.0\n', "not an input"),
    ('[input_signals]\ntau = { kind = "square", amplitude = 1 }\n', "kind"),
    ('[input_signals]\ntau = "__import__(1)"\n', "tau"),
    ('units = { speed = "m/s" }\n', "not a state"),
    ('[simulation]\nx0 = [1, 2, 3]\n', "x0"),
    ('[simulation]\ndt = 0\n', "positive"),
    ('[simulation]\nruns = 0\n', "positive integer"),
    ('[simulation]\nbox = [[1, 0], [0, 1]]\n', "lo < hi"),
]


@pytest.mark.parametrize(("table", "text"), BAD)
def test_bad_tables_name_the_file_and_line(table: str, text: str) -> None:
    src = (HEAD + table) if not table.startswith("units") else table + HEAD
    with pytest.raises(ModelFileError, match=text) as info:
        parse_scenario(src, source="bad.toml")
    assert info.value.path == "bad.toml"
    assert info.value.line is not None


@pytest.mark.parametrize(("table", "text"), BAD[:3] + BAD[5:6] + BAD[8:9])
def test_bad_tables_are_one_line_exit_2(tmp_path: Path, table: str, text: str) -> None:
    f = tmp_path / "bad.toml"
    f.write_text(HEAD + table)
    res = runner.invoke(app, ["simulate", str(f), "--observer", "luenberger", "--runs", "2", "--duration", "1"])
    assert res.exit_code == 2, res.output
    err = res.stderr.strip()
    assert err.startswith("nlobs: error:") and "\n" not in err and text in err and "Traceback" not in res.output


@pytest.mark.parametrize(("csv", "text"), [
    ("t,tau\n0,1\n0.5,2\n0.5,3\n", "not after"),
    ("t,tau\n0,1\n0.5,nan\n", "finite"),
    ("t,tau\n0,1\n0.5,inf\n", "finite"),
    ("time,tau\n1,1\n0.5,2\n", "not after"),
])
def test_bad_input_csv_is_one_line_exit_2(tmp_path: Path, csv: str, text: str) -> None:
    (tmp_path / "u.csv").write_text(csv)
    f = tmp_path / "m.toml"
    f.write_text(HEAD + '[input_signals]\ntau = { kind = "csv", file = "u.csv" }\n')
    res = runner.invoke(app, ["simulate", str(f), "--observer", "luenberger", "--runs", "2", "--duration", "1"])
    assert res.exit_code == 2, res.output
    err = res.stderr.strip()
    assert "\n" not in err and text in err and "u.csv" in err
    # the same file given on the command line
    res = runner.invoke(app, ["simulate", "pendulum", "--input", f"tau=csv:{tmp_path / 'u.csv'}:tau", "--runs", "2"])
    assert res.exit_code == 2 and text in res.stderr


@pytest.mark.parametrize(("args", "text"), [
    (["--observer", "kalman"], "unknown observer 'kalman'"),
    (["--observer", "ekf,ekf"], "twice"),
    (["--rate", "0"], "rate"),
    (["--rate", "-1", "--noise-std", "0.1"], "rate"),
    (["--rate", "300", "--dt", "0.01"], "faster than"),
    (["--rate", "30", "--dt", "0.01"], "does not fit"),
    (["--x0", "1,2,3"], "x0"),
    (["--input", "tau=sine:1"], "sine"),
    (["--input", "force=1"], "not an input"),
    (["--input", "tau"], "NAME=SPEC"),
    (["--process-noise", "1,-1"], "non-negative"),
    (["--runs", "0"], "runs"),
    (["--settle", "20", "--duration", "10"], "settle"),
])
def test_bad_options_are_one_line_exit_2(args: list[str], text: str) -> None:
    res = runner.invoke(app, ["simulate", "pendulum", "--observer", "luenberger", "--runs", "2", "--duration", "1",
                              *args] if "--observer" not in args else ["simulate", "pendulum", *args])
    assert res.exit_code == 2, res.output
    err = res.stderr.strip()
    assert err.startswith("nlobs: error:") and "\n" not in err and text in err, err
