"""``nlobs analyze`` takes its region and operating point from the model file, and says so.

The region: ``--box``, else ``[simulation] box``, else ``[−1, 1]ⁿ``; ``x0``: ``--x0``, else
``[simulation] x0``, else zeros; ``u0``: ``--u0``, else ``[input_signals]`` at ``t = 0``, else zero
(as ``nlobs simulate`` starts its runs). A point where the model is not finite is named, not analysed.

The CSTR: ``Ċ = q (Cin − C) − k(T) C``, ``Ṫ = q (Tin − T) + J k(T) C + u``, ``y = T``,
``k(T) = k0 exp(−E/T)``. Its expected numbers are computed here from that closed form, not by nlobs:
``A = [[−q − k, −C k E/T²], [J k, −q + J C k E/T²]]``, ``B = e2``, ``C = e2ᵀ`` (so the transfer function
``(s − a11) / det(sI − A)`` has its one zero at ``a11``), and ``Q_s = [dh; dL_f h] = [[0, 1], [J k, a22]]``,
``det Q_s = −J k0 exp(−E/T)``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from nlobs.cli import app
from nlobs.workflows.advise import advise_model
from nlobs.workflows.analyze import analyze_model

runner = CliRunner()

Q, CIN, TIN, K0, E, J = 1.0, 1.0, 350.0, 7.2e10, 8750.0, 20.0

CSTR = f"""
name = "cstr"
time = "continuous"
states = ["C", "T"]
inputs = ["u"]
outputs = ["T_meas"]
parameters = {{ q = {Q}, Cin = {CIN}, Tin = {TIN}, k0 = {K0}, E = {E}, J = {J} }}

[dynamics]
f = ["q*(Cin - C) - k0*exp(-E/T)*C", "q*(Tin - T) + J*k0*exp(-E/T)*C"]
g = [["0"], ["1"]]
h = ["T"]

[simulation]
{{x0}}box = [[0.0, 1.0], [300.0, 400.0]]
"""


def _cstr(tmp_path: Path, x0: str | None = "[0.5, 350.0]", name: str = "cstr") -> str:
    p = tmp_path / f"{name}.toml"
    p.write_text(CSTR.replace("{x0}", "" if x0 is None else f"x0 = {x0}\n"), encoding="utf-8")
    return str(p)


def _hand_A(c: float, t: float) -> np.ndarray:
    k = K0 * math.exp(-E / t)
    dk = k * E / t**2  # dk/dT
    return np.array([[-Q - k, -c * dk], [J * k, -Q + J * c * dk]])


def _json(*args: str) -> dict:
    res = runner.invoke(app, [*args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_cstr_uses_the_files_box_and_x0_and_agrees_with_advise(tmp_path: Path) -> None:
    path = _cstr(tmp_path)
    d = _json("analyze", path)
    assert d["region"] == {"lower": [0.0, 300.0], "upper": [1.0, 400.0]} and d["region_source"] == "[simulation] box"
    assert d["operating_point"] == {"x0": [0.5, 350.0], "u0": [0.0], "x0_source": "[simulation] x0",
                                    "u0_source": "default zero"}
    lin = d["linearization"]
    assert lin is not None and d["linearization_error"] is None and d["linearization_nonfinite"] is None
    assert lin["x0"] == [0.5, 350.0]
    A = _hand_A(0.5, 350.0)
    got = sorted(complex(*e).real for e in lin["eigenvalues"])
    np.testing.assert_allclose(got, sorted(np.linalg.eigvals(A).real), rtol=1e-10)
    assert [complex(*z) for z in lin["invariant_zeros"]] == pytest.approx([A[0, 0]], rel=1e-10)
    assert lin["observable"] is True and lin["stable"] is True
    # the geometry on the file's box: rank 2, drift-observable; the smallest σ(Q_s) at (C, T) = (0, 300)
    assert d["observability_rank"] == 2 and d["drift_observable"] is True
    k300 = K0 * math.exp(-E / 300.0)
    qs = np.array([[0.0, 1.0], [J * k300, -Q]])
    assert d["drift_observability"]["worst_point"] == [0.0, 300.0]
    assert d["drift_observability"]["value"] == pytest.approx(np.linalg.svd(qs, compute_uv=False)[-1], rel=1e-9)
    assert abs(np.linalg.det(qs)) == pytest.approx(J * K0 * math.exp(-E / 300.0), rel=1e-12)  # −J k0 exp(−E/T)
    # `nlobs advise` on the same file says the same
    adv = advise_model(path).to_dict()
    assert adv["box"] == d["region"] and adv["box_source"] == "file [simulation] box"
    assert "generic rank of the observability codistribution: 2 of n = 2" in adv["methods"]["ekf-ukf"]["evidence"]
    assert adv["methods"]["drift"]["applicable"] in ("yes", "local")
    assert d["advice"]["box"] == adv["box"]


def test_cstr_text_report_names_the_sources(tmp_path: Path) -> None:
    res = runner.invoke(app, ["analyze", _cstr(tmp_path)])
    assert res.exit_code == 0, res.output
    out = res.stdout
    assert "region       [0, 1] × [300, 400] from [simulation] box" in out
    assert "linearised at x0 = [0.5, 350] from [simulation] x0, u0 = [0] default zero — local properties only:" in out
    assert "differential geometry on [0, 1] × [300, 400]" in out
    assert "generic rank 2 of n = 2" in out and "drift-observable (Φ_s local diffeomorphism): yes" in out
    assert "generic rank 1" not in out


def test_cstr_without_x0_explains_the_singular_origin(tmp_path: Path) -> None:
    path = _cstr(tmp_path, x0=None, name="cstr-nox0")
    # by hand at T = 0: k0 E/T² exp(−E/T) is 0·∞, undefined; ∂f_C/∂T and ∂f_T/∂T involve it, nothing else does
    with np.errstate(all="ignore"):
        dk0 = K0 * E / np.float64(0.0) ** 2 * np.exp(-E / np.float64(0.0))
    assert not np.isfinite(dk0)
    d = _json("analyze", path)
    assert d["linearization"] is None
    assert d["operating_point"]["x0"] == [0.0, 0.0] and d["operating_point"]["x0_source"] == "default zeros"
    assert d["linearization_nonfinite"] == [{"quantity": "A", "label": "∂f/∂x", "entries": [[0, 1], [1, 1]],
                                             "names": ["∂f_C/∂T", "∂f_T/∂T"]}]
    err = d["linearization_error"]
    assert err.startswith("∂f/∂x (entries (0,1) ∂f_C/∂T, (1,1) ∂f_T/∂T) is not finite at x0=[0.0, 0.0], u0=[0.0]")
    assert "not defined or not differentiable there" in err and "give --x0 or [simulation] x0" in err
    # the region still comes from the file, and the geometry is not the default box's rank 1
    assert d["region_source"] == "[simulation] box" and d["observability_rank"] == 2
    res = runner.invoke(app, ["analyze", path])
    assert res.exit_code == 0, res.output
    line = next(ln for ln in res.stdout.splitlines() if ln.startswith("linearised at"))
    assert line.startswith("linearised at x0 = [0, 0] default zeros, u0 = [0] default zero: skipped — ∂f/∂x")
    assert "poles:" not in res.stdout and "observable:" not in res.stdout  # no linear report from NaNs


def test_given_options_override_the_file(tmp_path: Path) -> None:
    path = _cstr(tmp_path)
    d = _json("analyze", path, "--x0", "0.2,320", "--u0", "1", "--box", "0,1,330,380")
    assert d["operating_point"] == {"x0": [0.2, 320.0], "u0": [1.0], "x0_source": "given", "u0_source": "given"}
    assert d["region"] == {"lower": [0.0, 330.0], "upper": [1.0, 380.0]} and d["region_source"] == "given"
    A = _hand_A(0.2, 320.0)
    got = sorted(complex(*e).real for e in d["linearization"]["eigenvalues"])
    np.testing.assert_allclose(got, sorted(np.linalg.eigvals(A).real), rtol=1e-10)
    # a given point outside the physical domain: at T = −1, exp(−E/T) = exp(8750) overflows, so F itself and
    # its Jacobian are infinite; reported with the hint for --x0
    d = _json("analyze", path, "--x0", "0.5,-1")
    kinds = [b["quantity"] for b in d["linearization_nonfinite"]]
    assert "F" in kinds and "A" in kinds and "choose --x0 inside the model's domain" in d["linearization_error"]


@pytest.mark.slow
def test_u0_is_the_files_input_at_t0_as_simulate_starts(tmp_path: Path) -> None:
    # the shipped chemostat: x0 = (1.5, 0.5), D = step 0.3 → 0.2 at t = 25 h, so u0 = D(0) = 0.3.
    # By hand, μ = μmax S/(Ks + S), μ' = μmax Ks/(Ks + S)²: A = [[μ − D, μ' X], [−μ/Y, −D − μ' X/Y]]
    d = _json("analyze", "chemostat")
    assert d["operating_point"] == {"x0": [1.5, 0.5], "u0": [0.3], "x0_source": "[simulation] x0",
                                    "u0_source": "[input_signals] at t = 0"}
    mu_max, ks, y, x, s, dd = 0.5, 0.2, 0.5, 1.5, 0.5, 0.3
    mu, dmu = mu_max * s / (ks + s), mu_max * ks / (ks + s) ** 2
    A = np.array([[mu - dd, dmu * x], [-mu / y, -dd - dmu * x / y]])
    got = sorted(complex(*e).real for e in d["linearization"]["eigenvalues"])
    np.testing.assert_allclose(got, sorted(np.linalg.eigvals(A).real), rtol=1e-10)
    assert d["region_source"] == "[simulation] box" and d["region"] == {"lower": [0.05, 0.01], "upper": [4.0, 4.0]}


def test_model_without_simulation_table_keeps_the_defaults() -> None:
    d = _json("analyze", "pendulum")
    assert d["operating_point"] == {"x0": [0.0, 0.0], "u0": [0.0], "x0_source": "default zeros",
                                    "u0_source": "default zero"}
    assert d["region"] == {"lower": [-1.0, -1.0], "upper": [1.0, 1.0]} and d["region_source"] == "default [-1, 1]^n"


def test_a_files_box_that_overflows_is_bad_input_naming_the_file(tmp_path: Path) -> None:
    p = tmp_path / "wide.toml"
    p.write_text(CSTR.replace("{x0}", "").replace("box = [[0.0, 1.0], [300.0, 400.0]]",
                                                   "box = [[-1e308, 1e308], [300.0, 400.0]]"), encoding="utf-8")
    res = runner.invoke(app, ["analyze", str(p)])
    assert res.exit_code == 2 and res.stdout == ""
    line = res.stderr.strip()
    assert "\n" not in line and line.startswith(f"nlobs: error: {p}: [simulation] box: ") and "overflows" in line
