"""A logged run read for a model (``nlobs.systems.recorded``): multi-rate outputs with empty fields, inputs held,
and every bad file refused with one line naming the file and the line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nlobs.errors import NlobsError, SignalFileError, UnknownNameError
from nlobs.simulate import run_observer, simulate
from nlobs.systems.linear import LinearSystem
from nlobs.systems.recorded import read_log
from nlobs.observers import LuenbergerObserver


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "log.csv"
    p.write_text(text, encoding="utf-8")
    return p


def test_a_multi_rate_log_holds_the_inputs_and_leaves_missing_samples_nan(tmp_path: Path) -> None:
    p = _write(tmp_path, "time,y2,u,y1\n0,,2.0,1.0\n0.1,5,,1.1\n0.2,,,\n0.3,6,-1,1.3\n")
    log = read_log(p, inputs=["u"], outputs=["y1", "y2"])
    assert log.t.tolist() == [0.0, 0.1, 0.2, 0.3]
    assert log.u[:, 0].tolist() == [2.0, 2.0, 2.0, -1.0]
    np.testing.assert_array_equal(log.y, [[1.0, np.nan], [1.1, 5.0], [np.nan, np.nan], [1.3, 6.0]])
    assert log.samples == {"y1": 3, "y2": 2} and log.y_rows.tolist() == [0, 1, 3]
    assert not log.u.flags.writeable and not log.y.flags.writeable
    only = read_log(_write(tmp_path, "t,u,y1\n0,1,0.5\n"), inputs=["u"], outputs=["y1", "y2"])  # y2 never logged
    assert np.isnan(only.y[:, 1]).all()


def test_the_log_replays_a_simulated_run(tmp_path: Path) -> None:
    """A run of a plant written as a log and read back gives run_observer the same estimate as the samples did."""
    plant = LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    obs = LuenbergerObserver(plant, [[4.5], [1.75]])
    t = np.arange(0.0, 2.0 + 1e-9, 0.01)
    u = np.sin(t)[:, None]
    sim = simulate(plant, obs, [1.0, 0.0], [0.0, 0.0], duration=2.0, dt=0.01, u=lambda s: np.array([np.sin(s)]))
    lines = ["t,u,y"] + [f"{float(a)!r},{float(b)!r},{float(c)!r}" for a, b, c in zip(t, u[:, 0], sim.x[:, 0])]
    log = read_log(_write(tmp_path, "\n".join(lines) + "\n"), inputs=["u"], outputs=["y"])
    np.testing.assert_array_equal(log.y[:, 0], sim.x[:, 0])
    rep = run_observer(obs, log.t, x_hat0=[0.0, 0.0], u=log.u, y=log.y, y_times=log.t)
    direct = run_observer(obs, t, x_hat0=[0.0, 0.0], u=u, y=sim.x[:, :1], y_times=t)
    np.testing.assert_allclose(rep.x_hat, direct.x_hat, rtol=0.0, atol=1e-12)


@pytest.mark.parametrize(("text", "error", "message"), [
    ("t,u,y\n0,1,1\n0,1,2\n", SignalFileError, ":3: time 0 is not after the previous time 0"),
    ("t,u,y\n0,1,1\n0.1,1,nan\n", SignalFileError, ":3: column 'y': 'nan' is not a finite number"),
    ("t,u,y\n0,1,1\n,1,2\n", SignalFileError, ":3: column 't': an empty field is not a number"),
    ("t,u,y,z\n0,1,1,2\n", UnknownNameError, "column 'z' is not an input or an output of the model"),
    ("t,y\n0,1\n", SignalFileError, "no column for the input 'u'"),
    ("t,u,y\n0,,1\n0.1,1,1\n", SignalFileError, ":2: the input 'u' has no value on the first row"),
    ("t,u,y\n0,1,\n0.1,1,\n", SignalFileError, "no sample of any output"),
    ("t,u,y\n0,1,1,7\n", SignalFileError, ":2: 4 fields, but the header has 3"),
    ("u,t,y\n1,0,1\n", SignalFileError, "the first column must be the time"),
    ("t,u,y\n", SignalFileError, "no data rows after the header"),
])
def test_a_bad_log_is_refused_with_one_line(tmp_path: Path, text: str, error: type, message: str) -> None:
    with pytest.raises(error) as info:
        read_log(_write(tmp_path, text), inputs=["u"], outputs=["y"])
    assert isinstance(info.value, NlobsError) and message in str(info.value) and "\n" not in str(info.value)


def test_a_log_too_large_or_missing_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import nlobs.systems.signals as signals

    monkeypatch.setattr(signals, "MAX_CSV_BYTES", 64)
    big = _write(tmp_path, "t,u,y\n" + "".join(f"{k},1,1\n" for k in range(20)))
    with pytest.raises(SignalFileError, match="larger than|too large|bytes"):
        read_log(big, inputs=["u"], outputs=["y"])
    with pytest.raises(SignalFileError):
        read_log(tmp_path / "missing.csv", inputs=["u"], outputs=["y"])
