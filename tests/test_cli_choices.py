"""CLI conventions: choices as enums (help and completion list them, the library accepts exactly them), shell
completion of commands, choices and model names, clean help, one progress option on every long command."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.cli import choices as C


def _values(enum) -> tuple[str, ...]:  # type: ignore[no-untyped-def]
    return tuple(m.value for m in enum)


def test_each_choice_is_the_set_the_library_accepts() -> None:
    from nlobs.methods import cascade, comparison, drift, gnss_ins
    from nlobs.navigation import montecarlo
    from nlobs.papers.reproduce import PAPERS
    from nlobs.synthesis.pinv_gain import PLACEMENTS
    from nlobs.workflows.export import EXPORTABLE

    assert _values(C.Backend) == comparison.BACKENDS == gnss_ins.BACKENDS
    assert _values(C.Paper) == tuple(PAPERS)
    assert _values(C.DemoGains) == gnss_ins.GAINS
    assert _values(C.Schedule) == gnss_ins.ATTITUDE_GAINS == gnss_ins.TRANSLATION_GAINS
    assert set(_values(C.StudyGains)) == set(montecarlo.GAINS)
    assert _values(C.DriftMethod) == drift.METHODS and _values(C.CascadeMethod) == cascade.METHODS
    assert _values(C.ExportMethod) == drift.METHODS + cascade.METHODS
    assert _values(C.Placement) == PLACEMENTS
    assert _values(C.Exported) == EXPORTABLE
    assert C.value(C.Backend.c) == "c" and C.value(None) is None and C.value("x") == "x"


def _commands(group, path=()):  # type: ignore[no-untyped-def]
    import typer.main

    cmd = typer.main.get_command(group) if not hasattr(group, "commands") else group
    for name, sub in getattr(cmd, "commands", {}).items():
        if hasattr(sub, "commands"):
            yield from _commands(sub, (*path, name))
        else:
            yield (*path, name)


COMMANDS = sorted(_commands(app))


@pytest.mark.parametrize("path", COMMANDS, ids=" ".join)
def test_help_is_clean(path: tuple[str, ...]) -> None:
    res = CliRunner().invoke(app, [*path, "--help"], terminal_width=100)
    assert res.exit_code == 0, res.output
    text = res.output
    assert "list[" not in text and "{model}" not in text and "MODEL <str>" not in text, text


LONG = [("demo",), ("simulate", "compare"), ("simulate", "gnss-ins"), ("simulate", "setvalued"), ("advise",)]


@pytest.mark.parametrize("path", LONG, ids=" ".join)
def test_every_long_command_takes_the_one_progress_option(path: tuple[str, ...]) -> None:
    text = CliRunner().invoke(app, [*path, "--help"], terminal_width=200).output
    assert "--progress / --no-progress" in text and "on a terminal" in text


def _complete(words: str) -> list[str]:
    exe = Path(sys.executable).parent / "nlobs"
    if not exe.exists():
        pytest.skip("the nlobs entry point is not installed beside this Python")
    env = {**os.environ, "_NLOBS_COMPLETE": "complete_bash", "COMP_WORDS": words,
           "COMP_CWORD": str(len(words.split(" ")) - 1)}
    out = subprocess.run([str(exe)], env=env, capture_output=True, text=True, timeout=60, cwd="/")
    return [w for w in out.stdout.split() if w]


def test_shell_completion_lists_commands_choices_and_models() -> None:
    assert {"analyze", "simulate", "design", "export"} <= set(_complete("nlobs "))
    assert _complete("nlobs simulate compare pend") == ["pendulum"]
    assert _complete("nlobs simulate compare pendulum --backend ") == ["python", "c"]
    assert _complete("nlobs reproduce ") == list(_values(C.Paper))
    res = CliRunner().invoke(app, ["--help"])
    assert "--install-completion" in res.output and "--show-completion" in res.output
