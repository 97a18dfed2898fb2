"""Every LMI/SDP design estimates its problem size and refuses one above ``MAX_LMI_SIZE`` before CVXPY builds it.

A refused problem must never reach CVXPY: ``cvxpy.Problem`` is replaced by a stub that fails the test
when it is constructed or solved. The estimates are compared with the problems the builders make at a
small size, so a refusal is about the problem that would have been solved.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cvxpy as cp
import numpy as np
import pytest
from cvxpy.constraints import PSD

from nlobs.errors import InvalidArgumentError, ModelFileError
from nlobs.papers import khajenejad_yong_printed as sp
from nlobs.synthesis import discrete_lipschitz as dl
from nlobs.synthesis import drift_gain as dg
from nlobs.synthesis import setvalued as sv
from nlobs.synthesis.lmi import MAX_LMI_SIZE, lmi_problem_size
from nlobs.systems.discrete_ui import LPV, DiscreteUISystem, Lipschitz
from nlobs.systems.modelfile import load_model
from nlobs.systems.timebase import Discrete


@pytest.fixture
def no_cvxpy(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Fail when any CVXPY problem is built or solved; returns the list of attempts."""
    calls: list[str] = []

    def refuse(*_a: Any, **_k: Any) -> None:
        calls.append("cvxpy")
        raise AssertionError("a CVXPY problem was built or solved for a refused size")

    monkeypatch.setattr(cp.Problem, "__init__", refuse)
    monkeypatch.setattr(cp.Problem, "solve", refuse)
    return calls


def _count(prob: cp.Problem) -> tuple[int, tuple[int, ...]]:
    """Scalar variables (a symmetric k×k variable counts k(k+1)/2) and sorted PSD block sizes of a built problem."""
    nv = 0
    for v in prob.variables():
        k = v.shape[0] if v.ndim == 2 else 0
        nv += k * (k + 1) // 2 if v.attributes.get("symmetric") else v.size
    return nv, tuple(sorted(c.args[0].shape[0] for c in prob.constraints if isinstance(c, PSD)))


def _sorted(size: tuple[int, tuple[int, ...]]) -> tuple[int, tuple[int, ...]]:
    return size[0], tuple(sorted(size[1]))


def _refusal(exc: pytest.ExceptionInfo[InvalidArgumentError], what: str) -> str:
    msg = str(exc.value)
    assert msg.startswith(f"{what} too large: "), msg
    assert "scalar variables and semidefinite blocks of sizes" in msg and f"at most {MAX_LMI_SIZE}" in msg, msg
    assert "\n" not in msg
    return msg


# --------------------------------------------------------------------------- the shared size


def test_the_size_is_variables_plus_block_entries() -> None:
    assert lmi_problem_size(3, (2, 4)) == 3 + 3 + 10


# --------------------------------------------------------------------------- observer gain (verify)


def test_verify_observer_gain_at_n_130_is_refused_before_cvxpy(no_cvxpy: list[str]) -> None:
    from nlobs.synthesis.observer_gain import verify_observer_gain

    n = 130  # K given: P is the only matrix variable, so n = 100 (size 20709) is still solved
    A = -np.eye(n)
    C = np.eye(2, n)
    with pytest.raises(InvalidArgumentError) as exc:
        verify_observer_gain(A, C, np.eye(n, 3), np.zeros((n, 2)), gamma=10.0, gamma_n=2.0)
    msg = _refusal(exc, "LMI problem")
    assert "n = 130 states give 8515 scalar variables" in msg and "blocks of sizes 130, 133, 132 (size 34719)" in msg
    assert not no_cvxpy


# --------------------------------------------------------------------------- drift SDP


@pytest.mark.parametrize("objective, gain_bound", [("min_gain", None), ("min_condition", None), ("min_condition", 2.0)])
def test_drift_sdp_size_matches_the_built_problem(objective: str, gain_bound: float | None) -> None:
    c = dg.RiccatiConstants((2, 3), np.ones((5, 2)), 1.0, 1.0, 1.0)
    obj = dg.DriftObjective(objective)
    assert _count(dg._build_sdp(c, obj, 1e-6, gain_bound).problem) == _sorted(dg.sdp_size(c, obj, gain_bound))


def test_drift_sdp_at_n_120_is_refused_before_cvxpy(no_cvxpy: list[str]) -> None:
    c = dg.RiccatiConstants((60, 60), None, 1.0, 0.0, 1.0)
    with pytest.raises(InvalidArgumentError) as exc:
        dg.design_drift_gain_sdp(c)
    msg = _refusal(exc, "drift-observability SDP")
    assert "n = 120 states (s = (60, 60)) with 2 outputs give 7502 scalar variables" in msg
    assert "blocks of sizes 122, 120, 122 (size 29768)" in msg and "method 'vandermonde'" in msg
    with pytest.raises(InvalidArgumentError, match="drift-observability SDP too large"):
        dg.design_drift_gain(c, "sdp")
    assert not no_cvxpy


CHAIN = "name = \"chain\"\nstates = [{states}]\noutputs = [\"y\"]\n[dynamics]\nf = [{f}]\nh = [\"x0\"]\n"


@pytest.mark.slow
def test_cli_design_drift_sdp_at_n_120_is_one_line_exit_2(tmp_path: Path, no_cvxpy: list[str]) -> None:
    from typer.testing import CliRunner

    from nlobs.cli import app

    n = 120
    names = [f"x{i}" for i in range(n)]
    f = [f"x{i + 1}" for i in range(n - 1)] + ["-x0"]
    path = tmp_path / "chain.toml"
    path.write_text(CHAIN.format(states=", ".join(f'"{s}"' for s in names), f=", ".join(f'"{e}"' for e in f)))
    res = CliRunner().invoke(app, ["design", "drift", str(path), "--method", "sdp", "--s", str(n)])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1, res.output
    assert "drift-observability SDP too large: n = 120 states (s = (120,)) with 1 output give" in lines[0]
    assert "Traceback" not in res.output and not no_cvxpy


# --------------------------------------------------------------------------- set-valued (sound design)


def _ui(n: int, lpv: bool = False) -> DiscreteUISystem:
    A = 0.5 * np.eye(n) + 0.1 * np.eye(n, k=1)
    G = np.zeros((n, 1))
    G[0, 0], G[-1, 0] = 1.0, 0.5
    C = np.zeros((2, n))
    C[0, 0], C[1, -1] = 1.0, 1.0
    H = np.array([[0.0], [0.2]])
    fc = LPV((0.1 * np.eye(n), -0.1 * np.eye(n))) if lpv else Lipschitz(0.01, n)
    return DiscreteUISystem(A, G, C, H, function_class=fc, eta_w=0.05, eta_v=0.02, delta0=1.0, time=Discrete(1.0))


@pytest.mark.parametrize("lpv", [False, True])
@pytest.mark.parametrize("objective", ["radius", "hinf"])
def test_setvalued_size_matches_the_built_problem(lpv: bool, objective: str) -> None:
    s = _ui(3, lpv)
    tr = sv.ui_transform(s.G, s.C, s.H, s.D)
    pb = sv._build(s, sv.error_dynamics(s, tr), sv.SetValuedObjective(objective), 1e-7)
    assert _count(pb.prob) == _sorted(sv.lmi_size(s, tr))


def test_setvalued_at_n_80_is_refused_before_cvxpy(no_cvxpy: list[str]) -> None:
    with pytest.raises(InvalidArgumentError) as exc:
        sv.design_setvalued(_ui(80))
    msg = _refusal(exc, "set-valued LMI (⋆)")
    assert "n = 80 states, l = 2 outputs, n_w = 80 noise inputs give 3324 scalar variables" in msg
    assert "blocks of sizes 80, 324" in msg
    assert not no_cvxpy


# --------------------------------------------------------------------------- set-valued (as printed)


def _lipschitz_M(L: float, n: int) -> np.ndarray:
    return np.block([[-np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), L**2 * np.eye(n)]])


@pytest.mark.parametrize("branch", [None, sp.Prop516Branch.A])
@pytest.mark.parametrize("relax", [False, True])
def test_printed_size_matches_the_built_problem(branch: sp.Prop516Branch | None, relax: bool) -> None:
    s = _ui(3)
    _, M11, M12, M22 = sp._split_M(_lipschitz_M(0.01, 3), 3)
    tr = sp._transform_for_printed(s, "test")
    pb = sp._build_thm510(s, M11, M12, M22, tr, 1e-7, branch, 1e-5, relax)
    assert _count(pb.prob) == _sorted(sp.thm510_size(s, tr, branch, relax))


@pytest.mark.parametrize("design, who", [(sp.design_printed, "design_printed"), (sp.design_prop516, "design_prop516")])
def test_printed_at_n_60_is_refused_before_cvxpy(design: Any, who: str, no_cvxpy: list[str]) -> None:
    with pytest.raises(InvalidArgumentError) as exc:
        design(_ui(60), _lipschitz_M(0.01, 60))
    msg = _refusal(exc, f"{who}: the SDP of Theorem 5.10")
    assert "n = 60 states, q = 1 transformed outputs give" in msg and "design_setvalued" in msg
    assert not no_cvxpy


# --------------------------------------------------------------------------- discrete Lipschitz


@pytest.mark.parametrize("max_gamma", [False, True])
def test_discrete_lipschitz_size_matches_the_built_problem(max_gamma: bool) -> None:
    A, C, E, F = np.diag([0.5, 0.6, 0.7]), np.ones((2, 3)), np.ones((3, 1)), np.ones((1, 3))
    nv, blocks = _count(dl._Problem(A, C, E, F, 1e-7, max_gamma=max_gamma).problem)
    want_nv, want_blocks = _sorted(dl.lmi_size(3, 2, 1))
    if max_gamma:  # the auxiliary problem: γ² for (t, ε) and no P ⪯ tI, so never larger
        assert nv <= want_nv and len(blocks) == len(want_blocks) - 1
    else:
        assert (nv, blocks) == (want_nv, want_blocks)


def test_discrete_lipschitz_at_n_100_is_refused_before_cvxpy(no_cvxpy: list[str]) -> None:
    n = 100
    with pytest.raises(InvalidArgumentError) as exc:
        dl.design_discrete_lipschitz_gain(0.5 * np.eye(n), np.eye(2, n), lipschitz=0.01)
    msg = _refusal(exc, "discrete Lipschitz LMI")
    assert "n = 100 states, l = 2 outputs, q = 100 nonlinear channels give 5252 scalar variables" in msg
    assert "blocks of sizes 100, 100, 300 (size 60502)" in msg
    assert not no_cvxpy


# --------------------------------------------------------------------------- a model without outputs


def test_model_file_without_outputs_says_so_with_the_line(tmp_path: Path) -> None:
    p = tmp_path / "m.toml"
    p.write_text('name = "m"\nstates = ["x"]\noutputs = []\n[dynamics]\nf = ["-x"]\nh = []\n')
    with pytest.raises(ModelFileError) as exc:
        load_model(p)
    assert exc.value.line == 3
    assert "a model needs at least one output" in str(exc.value) and "expected 0 entries" not in str(exc.value)


def test_linear_model_file_without_outputs_says_so_with_the_line(tmp_path: Path) -> None:
    p = tmp_path / "l.toml"
    p.write_text('name = "l"\n[linear]\nA = [[-1.0]]\nC = []\n')
    with pytest.raises(ModelFileError) as exc:
        load_model(p)
    assert exc.value.line == 4 and "a model needs at least one output" in str(exc.value)


# --------------------------------------------------------------------------- observer gain (design): the SDP estimate


def _og_data(n: int, p: int, m: int, **kw: Any) -> Any:
    from nlobs.synthesis import observer_gain as og

    rng = np.random.default_rng(n)
    return og._validate_data(rng.standard_normal((n, n)), rng.standard_normal((p, n)), rng.standard_normal((n, m)),
                             kw.get("N"), kw.get("need_noise", True), kw.get("region"), kw.get("gain_bound"))


@pytest.mark.parametrize("objective, region, gain_bound", [
    ("central", None, None), ("central", "half", None), ("central", None, 50.0), ("min_gamma_n", None, None)])
def test_observer_gain_sdp_estimate_matches_the_compiled_problem(objective: str, region: str | None,
                                                                  gain_bound: float | None) -> None:
    from nlobs.synthesis import observer_gain as og
    from nlobs.synthesis.certificate import Objective
    from nlobs.synthesis.regions import HalfPlane

    d = _og_data(5, 2, 1, region=HalfPlane(0.1) if region else None, gain_bound=gain_bound)
    obj = Objective(objective)
    est = og.sdp_estimate(d.A, d.C, d.Bd, gamma_n=None if obj is Objective.MIN_GAMMA_N else 10.0, region=d.regions,
                          gain_bound=d.gain_bound, objective=obj)
    g2 = cp.Variable(nonneg=True) if obj is Objective.MIN_GAMMA_N else None
    f = og._formulate(d, margin=1e-6, gamma2=100.0, gamma_n2=g2 if g2 is not None else 100.0, with15=True,
                      regions=d.regions, gain_bound=d.gain_bound)
    prob = cp.Problem(og._central_objective(f) if g2 is None else cp.Minimize(g2), f.constraints)
    data, _, _ = prob.get_problem_data(solver="CLARABEL")
    dims = data["dims"]
    assert sorted(dims.psd) == sorted(est.cones)
    assert data["A"].shape[0] == est.rows + dims.nonneg  # the nonnegativity of γn², μ is not counted in rows
    assert est.kkt_dense == sum((k * (k + 1) // 2) ** 2 for k in est.cones)


def test_observer_gain_sdp_at_n_60_with_a_region_is_refused_by_its_memory_estimate(no_cvxpy: list[str]) -> None:
    from nlobs.errors import ProblemTooLarge
    from nlobs.synthesis.observer_gain import MAX_SDP_MEMORY, design_observer_gain
    from nlobs.synthesis.regions import HalfPlane

    n = 60  # within MAX_LMI_SIZE (size 12418), but the log-det cones need ≈ 10 GB
    A = -np.eye(n) + np.eye(n, k=1)
    C = np.eye(20, n)
    with pytest.raises(ProblemTooLarge) as exc:
        design_observer_gain(A, C, np.eye(n, 10), gamma=40.0, gamma_n=40.0, region=HalfPlane(0.1))
    msg = str(exc.value)
    assert msg.startswith("observer-gain SDP too large: n = 60 states, 20 outputs give ") and "\n" not in msg
    assert "semidefinite cones of sizes 60, 70, 80, 60, 120, 140, 160, 120" in msg
    assert f"the limit is {MAX_SDP_MEMORY / 2**30:.2g} GiB" in msg and "GiB and ~" in msg
    assert "because a pole region is asked" in msg and "method='riccati'" in msg
    assert isinstance(exc.value, InvalidArgumentError)  # the CLI's one line, exit 2
    assert not no_cvxpy


def test_observer_gain_central_design_takes_the_riccati_path_without_cvxpy(no_cvxpy: list[str]) -> None:
    from nlobs.synthesis import SynthesisMethod
    from nlobs.synthesis.observer_gain import design_observer_gain

    n = 30  # the central design with γ, γn needs no SDP: nothing is built (n = 100 runs in the benchmark)
    rng = np.random.default_rng(0)
    A = rng.standard_normal((n, n)) / np.sqrt(n)
    C = 2.0 * rng.standard_normal((6, n)) / np.sqrt(n)
    cert = design_observer_gain(A, C, rng.standard_normal((n, 3)) / np.sqrt(3), gamma=40.0, gamma_n=40.0)
    assert cert.verified and cert.method is SynthesisMethod.RICCATI
    assert not no_cvxpy


def test_observer_gain_riccati_failure_with_an_sdp_too_large_is_one_typed_error(no_cvxpy: list[str]) -> None:
    from nlobs.errors import DesignInfeasible
    from nlobs.synthesis.observer_gain import design_observer_gain

    n = 70  # unstable, one output with γn tiny: no stabilising solution, and the SDP does not fit
    A = 0.5 * np.eye(n) + np.eye(n, k=1)
    C = np.eye(1, n)
    with pytest.raises(DesignInfeasible) as exc:
        design_observer_gain(A, C, np.eye(n, 1), gamma=1.0, gamma_n=0.01)
    msg = str(exc.value)
    assert exc.value.constraint == "Riccati equation" and "that SDP is too large here" in msg and "GiB" in msg
    assert not no_cvxpy


def test_verify_observer_gain_at_n_100_is_refused_by_its_memory_estimate(no_cvxpy: list[str]) -> None:
    from nlobs.errors import ProblemTooLarge
    from nlobs.synthesis.observer_gain import verify_observer_gain

    n = 100  # within MAX_LMI_SIZE (size 20709), but the log-det cones of the analytic centre need ≈ 34 GiB
    with pytest.raises(ProblemTooLarge) as exc:
        verify_observer_gain(-np.eye(n), np.eye(2, n), np.eye(n, 3), np.zeros((n, 2)), gamma=10.0, gamma_n=2.0)
    msg = str(exc.value)
    assert msg.startswith("observer-gain verification SDP too large: n = 100 states, 2 outputs give "), msg
    assert "semidefinite cones of sizes 100, 103, 102, 200, 206, 204" in msg and "hinf_norm" in msg
    assert not no_cvxpy


def test_observer_gain_sdp_above_max_lmi_size_names_the_riccati_path(no_cvxpy: list[str]) -> None:
    from nlobs.synthesis.observer_gain import design_observer_gain
    from nlobs.synthesis.regions import HalfPlane

    n = 100
    with pytest.raises(InvalidArgumentError) as exc:
        design_observer_gain(-np.eye(n), np.eye(20, n), np.eye(n, 10), gamma=40.0, gamma_n=40.0, region=HalfPlane(0.1))
    msg = _refusal(exc, "LMI problem")
    assert "the Riccati path (method='riccati'" in msg
    assert not no_cvxpy
