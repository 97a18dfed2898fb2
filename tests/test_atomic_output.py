"""Output files survive kills: SIGTERM / Ctrl-C clean up, SIGKILL leftovers are removed later, runs may overlap.

Every run is a subprocess of the real command line; the timeouts are guards against a hang, not
measurements of speed.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

# Runs the CLI; with NLOBS_TEST_SIGNAL set, the first figure write sends that signal to the process
# after half a PNG went into the temporary file (so the signal lands inside an atomic write).
CLI = """
import os, sys, time
if os.environ.get("NLOBS_TEST_SIGNAL"):
    import matplotlib.figure
    def savefig(self, fh, *args, **kwargs):
        fh.write(b"\\x89PNG\\r\\n\\x1a\\n half a figure")
        fh.flush()
        os.kill(os.getpid(), int(os.environ["NLOBS_TEST_SIGNAL"]))
        time.sleep(60)
    matplotlib.figure.Figure.savefig = savefig
from nlobs.cli import app
app(sys.argv[1:], prog_name="nlobs")
"""

PINV = ["design", "pinv", "isidori-146", "--simulate", "--x0", "1,0,0,0.5", "--duration", "1"]


def _env(sig: int | None = None) -> dict[str, str]:
    env = {**os.environ, "PYTHONPATH": str(SRC), "MPLBACKEND": "Agg"}
    env.pop("NLOBS_TEST_SIGNAL", None)
    if sig is not None:
        env["NLOBS_TEST_SIGNAL"] = str(int(sig))
    return env


def _run(args: list[str], sig: int | None = None, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    try:
        return subprocess.run([sys.executable, "-c", CLI, *args], capture_output=True, text=True,
                              timeout=timeout, env=_env(sig))
    except subprocess.TimeoutExpired:
        pytest.fail(f"nlobs {' '.join(args)} did not finish within {timeout} s")


def _temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def _decodable(folder: Path) -> None:
    import matplotlib.image

    for png in folder.glob("*.png"):
        img = matplotlib.image.imread(png)
        assert img.ndim == 3 and img.shape[0] > 10, png
    for npz in folder.glob("*.npz"):
        with np.load(npz) as data:
            assert len(data.files) > 0, npz


def _one_line(stderr: str) -> str:
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr
    return lines[0]


@pytest.mark.slow
@pytest.mark.parametrize(("sig", "status"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_inside_a_figure_write_keeps_the_previous_files_and_leaves_no_temporary(
    sig: signal.Signals, status: int, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    good = _run([*PINV, "--out", str(out)])
    assert good.returncode == 0, good.stderr
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(before) == {"pinv.png", "pinv.npz"}

    res = _run([*PINV, "--out", str(out)], sig=sig)
    assert res.returncode == status, (res.returncode, res.stderr)
    assert f"interrupted by {sig.name}" in _one_line(res.stderr)
    assert _temporaries(out) == []
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    _decodable(out)


def _wait_for(path: Path, proc: subprocess.Popen[str], timeout: float = 120) -> None:
    end = time.monotonic() + timeout
    while not path.exists():
        if proc.poll() is not None or time.monotonic() > end:
            proc.kill()
            pytest.fail(f"{path} was not created (exit {proc.returncode})")
        time.sleep(0.005)


@pytest.mark.parametrize(("sig", "status"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_demo_signalled_after_it_created_its_folder_exits_with_one_line(
    sig: signal.Signals, status: int, tmp_path: Path
) -> None:
    out = tmp_path / "gnss"
    proc = subprocess.Popen([sys.executable, "-c", CLI, "demo", "gnss-ins", "--duration", "30", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    _wait_for(out, proc)
    proc.send_signal(sig)
    try:
        _, stderr = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail(f"{sig.name} did not end the demo within 60 s")
    assert proc.returncode == status, (proc.returncode, stderr)
    assert f"interrupted by {sig.name}" in _one_line(stderr)
    assert _temporaries(out) == []
    _decodable(out)


@pytest.mark.slow
def test_the_temporary_of_a_run_killed_with_sigkill_is_removed_by_the_next_run(tmp_path: Path) -> None:
    out = tmp_path / "out"
    killed = _run([*PINV, "--out", str(out)], sig=signal.SIGKILL)
    assert killed.returncode == -signal.SIGKILL
    left = _temporaries(out)
    assert len(left) == 1 and left[0].startswith(".pinv.png.")  # nothing can clean up at SIGKILL

    again = _run([*PINV, "--out", str(out)])
    assert again.returncode == 0, again.stderr
    assert _temporaries(out) == []
    assert sorted(p.name for p in out.iterdir()) == ["pinv.npz", "pinv.png"]
    _decodable(out)


def _dead_pid() -> int:
    proc = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True,
                          timeout=60, check=True)
    return int(proc.stdout)


def test_only_the_temporaries_of_dead_processes_of_the_same_target_are_removed(tmp_path: Path) -> None:
    from nlobs._io import atomic_write_text, remove_stale_temporaries

    dead = _dead_pid()
    stale = tmp_path / f".a.json.{dead}.k3j_x9q2.tmp"
    live = tmp_path / f".a.json.{os.getpid()}.abcd1234.tmp"  # a run writing the same file right now
    other = tmp_path / f".b.json.{dead}.k3j_x9q2.tmp"  # another target's: removed when that one is written
    foreign = tmp_path / ".a.json.notapid.tmp"
    for p in (stale, live, other, foreign):
        p.write_text("partial")
    atomic_write_text(tmp_path / "a.json", "{}\n")
    assert not stale.exists()
    assert live.exists() and other.exists() and foreign.exists()
    assert (tmp_path / "a.json").read_text() == "{}\n"
    assert remove_stale_temporaries(tmp_path / "b.json") == [other]


@pytest.mark.slow
def test_two_runs_writing_one_folder_at_once_leave_decodable_files_and_no_temporary(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    dead = _dead_pid()
    for name in ("pinv.png", "pinv.npz"):  # left by an earlier run killed with SIGKILL
        (out / f".{name}.{dead}.zz9_zz9z.tmp").write_bytes(b"\x89PNG half")
    procs = [subprocess.Popen([sys.executable, "-c", CLI, *PINV, "--out", str(out)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=_env()) for _ in range(2)]
    for proc in procs:
        try:
            _, stderr = proc.communicate(timeout=180)
        except subprocess.TimeoutExpired:
            proc.kill()
            pytest.fail("a concurrent run did not finish within 180 s")
        assert proc.returncode == 0, stderr  # neither run removed the other's live temporary
    assert _temporaries(out) == []
    assert sorted(p.name for p in out.iterdir()) == ["pinv.npz", "pinv.png"]
    _decodable(out)
