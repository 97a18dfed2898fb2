"""Library messages name Python parameters; the command line spells them as its flags.

Below ``nlobs.cli`` a message names the parameter it is about between single backticks, the keyword of
the function the user called (``"`runs`: expected an integer ≥ 1, got 0"``), never a flag. The command
line maps each backticked name to its flag in :func:`nlobs.cli.common.flags` (``noise_std`` →
``--noise-std``, the exceptions of ``FLAG_EXCEPTIONS``, a command's own ``extra``), and does it in
every line it prints: ``fail`` (the one-line errors), the console (reports) and ``emit_json``.

* the mapping on examples: the default rule, the exceptions, a command's ``extra``, names the command
  has no flag for, several names in one message, text that is not a backticked identifier;
* a library call raises with the backticked parameter, the same call from the command line prints the flag;
* every output of a command (error line, text, JSON) goes through the mapping;
* no flag spelling (``"--runs"``, ``(--box``) is left in a library source file outside the allow-list.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.cli.common import FLAG_EXCEPTIONS, console, emit_json, fail, flags
from nlobs.errors import InvalidArgumentError

SRC = Path(__file__).resolve().parents[1] / "src" / "nlobs"
runner = CliRunner()


# ----------------------------------------------------------------------------- the mapping


def test_default_rule_is_dashes_and_underscores_as_hyphens() -> None:
    everything = None  # outside a command every name is spelled as a flag
    assert flags("`runs`: expected a positive integer, got 0", options=everything) == \
        "--runs: expected a positive integer, got 0"
    assert flags("`noise_std`: expected 2 numbers", options=["--noise-std"]) == "--noise-std: expected 2 numbers"
    assert flags("`initial_error_std` and `w_max`", options=["--initial-error-std", "--w-max"]) == \
        "--initial-error-std and --w-max"


def test_exceptions_table_and_a_commands_extra() -> None:
    assert FLAG_EXCEPTIONS["x_hat0"] == "--xhat0" and FLAG_EXCEPTIONS["gain_method"] == "--method"
    assert flags("`x_hat0`: expected 2 numbers", options=["--xhat0"]) == "--xhat0: expected 2 numbers"
    assert flags("`gain_method`: expected 'lmi'", options=["--method"]) == "--method: expected 'lmi'"
    assert flags("`region` is empty", options=["--box"]) == "--box is empty"
    assert flags("`design_options`: bogus", options=["--option"]) == "--option: bogus"
    # a command's own spelling wins over the table and the default rule
    assert flags("`x_hat0` and `runs`", {"x_hat0": "--estimate", "runs": "--n"}, options=["--estimate", "--n"]) == \
        "--estimate and --n"


def test_a_name_the_command_has_no_flag_for_stays_without_backticks() -> None:
    assert flags("`workers` and `scheduler` (or an `executor`): give one", options=["--workers", "--scheduler"]) == \
        "--workers and --scheduler (or an executor): give one"
    assert flags("`samples`: must be positive", options=["--alpha"]) == "samples: must be positive"
    assert flags("`alpha`: must be positive", options=()) == "alpha: must be positive"


def test_several_names_and_repeated_names_in_one_message() -> None:
    msg = "`duration` 10 / `dt` 1e-07 is 1e+08 steps; at most 1e+07 (raise `dt` or shorten `duration`)"
    assert flags(msg, options=["--duration", "--dt"]) == \
        "--duration 10 / --dt 1e-07 is 1e+08 steps; at most 1e+07 (raise --dt or shorten --duration)"
    assert flags("lower α, μ or γ (`alpha`, `mu`, `gamma`; γ also by a smaller region, `region`)",
                 options=["--alpha", "--mu", "--gamma", "--box"]) == \
        "lower α, μ or γ (--alpha, --mu, --gamma; γ also by a smaller region, --box)"


def test_text_that_is_not_a_backticked_identifier_is_left_alone() -> None:
    for text in ("runs: plain names are not touched", "``runs`` is RST", "`2 x`: not an identifier", "a ` lone tick",
                 "--runs: already a flag", "`runs-x`"):
        assert flags(text, options=["--runs"]) == text
    mapped = flags("`runs`: bad, `out`: bad", options=["--runs", "--out"])
    assert flags(mapped, options=["--runs", "--out"]) == mapped  # idempotent: a mapped message maps to itself


# ----------------------------------------------------------------------------- library and command line


def test_a_library_call_names_the_parameter_not_the_flag() -> None:
    from nlobs.workflows import gnss_ins_monte_carlo
    from nlobs.workflows.inputs import SimulationRequest

    with pytest.raises(InvalidArgumentError) as info:
        gnss_ins_monte_carlo(flights=0)
    assert "`flights`" in str(info.value) and "--" not in str(info.value)
    with pytest.raises(InvalidArgumentError) as info:
        SimulationRequest([0.0], duration=10.0, dt=1e-7)
    assert str(info.value).startswith("`duration` 10 / `dt` 1e-07 is 1e+08 RK4 steps")
    assert "(raise `dt` or shorten `duration`)" in str(info.value) and "--" not in str(info.value)


def test_the_command_line_prints_the_flag() -> None:
    res = runner.invoke(app, ["simulate", "gnss-ins", "--flights", "0", "--no-progress"])
    assert res.exit_code == 2, res.output
    assert res.stderr == "nlobs: error: gnss-ins: --flights: expected an integer ≥ 1, got 0\n"
    res = runner.invoke(app, ["design", "pinv", "pendulum", "--simulate", "--x0", "1,0", "--dt", "1e-7"])
    assert res.exit_code == 2 and res.stderr.count("\n") == 1 and "`" not in res.stderr, res.output
    assert "--duration 10 / --dt 1e-07 is 1e+08 RK4 steps" in res.stderr and "(raise --dt or shorten --duration)" in \
        res.stderr


# methods/comparison.py is converted after this mechanism (its `runs` check still says plain "runs"): these two
# pass, and must then lose their marker, once it names `runs` in backticks.


def test_compare_observers_names_runs() -> None:
    from nlobs.workflows.compare import compare_observers

    with pytest.raises(InvalidArgumentError) as info:
        compare_observers("pendulum", runs=0)
    assert "`runs`" in str(info.value) and "--runs" not in str(info.value)


def test_simulate_prints_runs_as_its_flag() -> None:
    res = runner.invoke(app, ["simulate", "pendulum", "--runs", "0"])
    assert res.exit_code == 2 and res.stderr.count("\n") == 1 and "`" not in res.stderr, res.output
    assert "--runs" in res.stderr


def test_every_output_of_a_command_maps_the_parameters() -> None:
    """The error line (``fail``), the text report (the console) and the JSON report (``emit_json``)."""
    demo = typer.Typer()

    @demo.command()
    def run(noise_std: str = "0", xhat0: str = "0", mode: str = "text") -> None:
        message = "`noise_std` and `x_hat0`: bad; `executor`: not an option here"
        if mode == "json":
            emit_json({"note": message, "nested": [{"why": "raise `noise_std`"}]})
        elif mode == "text":
            console().print(message, markup=False)
        else:
            fail(message)

    want = "--noise-std and --xhat0: bad; executor: not an option here"
    res = runner.invoke(demo, ["--mode", "text"])
    assert res.exit_code == 0 and res.stdout.strip() == want
    res = runner.invoke(demo, ["--mode", "json"])
    data = json.loads(res.stdout)
    assert data["note"] == want and data["nested"] == [{"why": "raise --noise-std"}]
    res = runner.invoke(demo, ["--mode", "fail"])
    assert res.exit_code == 2 and res.stderr == f"nlobs: error: {want}\n"


# ----------------------------------------------------------------------------- no flag below the CLI

#: A flag spelling as ``grep -rhoE "[\"'( ]--[a-z][a-z0-9-]+" src/nlobs --include='*.py' --exclude-dir=cli``
#: counts it: after a quote, a parenthesis or a space (an RST literal, ``--json``, is not counted).
FLAG = re.compile(r"[\"'( ]--[a-z][a-z0-9-]+")

#: Where a flag spelling may stay below ``nlobs/cli``: path (relative to ``src/nlobs``) → the snippets of the
#: lines that may hold one (a line is allowed when it contains one of them), or ``ALL`` for a whole file.
ALL = ("",)
ALLOWED: dict[str, tuple[str, ...]] = {
    # Product output meant to be typed as a command keeps its flags: the command lines nlobs advise prints.
    "methods/advice.py": ('return f"--box=', 'return "--box="', 'cmd = f"nlobs design drift {target}',
                          'cmd = f"nlobs design pinv {target}', 'f"nlobs simulate {target} --observer'),
}


def _flag_spellings() -> list[tuple[str, int, str, str]]:
    found = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel.startswith("cli/"):
            continue
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            found += [(rel, lineno, m.group(0).lstrip("\"'( "), line) for m in FLAG.finditer(line)]
    return found


def test_no_flag_spelling_below_the_cli() -> None:
    bad = [f"{rel}:{lineno}: {flag}: {line.strip()}" for rel, lineno, flag, line in _flag_spellings()
           if not any(snippet in line for snippet in ALLOWED.get(rel, ()))]
    assert not bad, ("library text names command-line flags; name the Python parameter in backticks instead "
                     "(`noise_std`, nlobs.cli.common.flags spells it --noise-std), or allow-list product output:\n"
                     + "\n".join(bad))


def test_the_allow_list_has_no_stale_entries() -> None:
    found = _flag_spellings()
    for rel, snippets in ALLOWED.items():
        assert (SRC / rel).is_file(), rel
        for snippet in snippets:
            assert any(r == rel and snippet in line for r, _, _, line in found), (rel, snippet)
