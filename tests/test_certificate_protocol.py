"""One certificate protocol for every gain design, and one ``Check`` for every verdict.

Every certificate class is built by its real design function on a small real problem: the LMIs (14),
(15) of Grip–Saberi–Johansen on one axis of the GNSS/INS model, (2.17) of Dalla Mora–Germani–Manes on
a shipped model, the discrete Lipschitz baseline, and Khajenejad–Yong's sound design, Theorem 5.10 and
Proposition 5.16 as printed on Example 6.1, Class II.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable
from importlib import resources
from typing import Any

import numpy as np
import pytest

from nlobs.checks import Check, CheckKind
from nlobs.cli.common import jsonable
from nlobs.errors import InvalidArgumentError
from nlobs.linear.transform_ui import structural_check, ui_transform
from nlobs.papers.khajenejad_yong import example_61
from nlobs.papers.khajenejad_yong_printed import design_printed, design_prop516
from nlobs.synthesis import (
    Certificate,
    CertificateStatus,
    design_discrete_lipschitz_gain,
    design_observer_gain,
    design_setvalued,
    extended_system,
    verify_observer_gain,
)
from nlobs.synthesis.drift_gain import RiccatiConstants, design_drift_gain, smallest_w, verify_drift_gain
from nlobs.systems.modelfile import load_model
from nlobs.workflows.design_drift import design_drift_report

AXIS = extended_system([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2))
K_PAPER = np.array([[128.9, 17.5], [15.7, 2.4], [1.3, 0.2]])  # Grip–Saberi–Johansen, Sec. 5.2 (one axis)

A62 = np.array([[0.9, 0.1], [0.0, 0.8]])
C62 = np.array([[1.0, 0.0]])

_PRINTED_GRID: dict[str, Any] = {"alphas": [0.95], "eps_grid": (0.05, 0.1), "refine": 0}


def _class_ii() -> tuple[Any, np.ndarray]:
    ex = example_61("II")
    A = ex.system.A
    return ex.system, np.block([[-np.eye(4), A], [A.T, -A.T @ A]])  # (21) with the auxiliary matrix A


def _update_width(system: Any) -> int:
    return ui_transform(system.G, system.C, system.H, system.D).C2.shape[0]


def _observer_gain() -> tuple[Any, tuple[int, int]]:
    cert = design_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, gamma=50.0, gamma_n=1.0019)
    return cert, (3, 2)


def _observer_gain_given() -> tuple[Any, tuple[int, int]]:
    return verify_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, K_PAPER, gamma=50.0), (3, 2)


def _drift() -> tuple[Any, tuple[int, int]]:
    path = resources.files("nlobs") / "data" / "models" / "duffing-actuator.toml"
    rep = design_drift_report(load_model(path), samples=200)  # type: ignore[arg-type]
    n, q = rep.fields.n, rep.fields.q
    return rep.certificate, (n, q)


def _drift_sdp() -> tuple[Any, tuple[int, int]]:
    c = RiccatiConstants((2,), np.eye(2), alpha=1.0, mu=0.1, gamma=1.0)
    return design_drift_gain(c, "sdp"), (2, 1)


def _discrete_lipschitz() -> tuple[Any, tuple[int, int]]:
    return design_discrete_lipschitz_gain(A62, C62, lipschitz=0.05), (2, 1)


def _setvalued() -> tuple[Any, tuple[int, int]]:
    s = example_61("II").system
    return design_setvalued(s), (s.n, _update_width(s))


def _printed() -> tuple[Any, tuple[int, int]]:
    s, M = _class_ii()
    return design_printed(s, M, **_PRINTED_GRID), (s.n, _update_width(s))


def _prop516() -> tuple[Any, tuple[int, int]]:
    s, M = _class_ii()
    return design_prop516(s, M, **_PRINTED_GRID), (s.n, _update_width(s))


BUILDERS: dict[str, Callable[[], tuple[Any, tuple[int, int]]]] = {
    "ObserverGainCertificate (design)": _observer_gain,
    "ObserverGainCertificate (given gain)": _observer_gain_given,
    "DriftGainCertificate (Vandermonde, shipped model)": _drift,
    "DriftGainCertificate (SDP)": _drift_sdp,
    "DiscreteLipschitzCertificate": _discrete_lipschitz,
    "SetValuedDesign": _setvalued,
    "PrintedDesign": _printed,
    "Prop516Design": _prop516,
}


@pytest.fixture(scope="module", params=list(BUILDERS), ids=list(BUILDERS))
def built(request: pytest.FixtureRequest) -> tuple[Any, tuple[int, int]]:
    return BUILDERS[request.param]()


# --------------------------------------------------------------------------- the protocol


def test_every_design_returns_a_certificate(built: tuple[Any, tuple[int, int]]) -> None:
    cert, shape = built
    assert isinstance(cert, Certificate)
    assert isinstance(cert.gain, np.ndarray) and cert.gain.shape == shape
    assert cert.P is None or cert.P.shape == (shape[0], shape[0])
    assert cert.checks and all(isinstance(c, Check) for c in cert.checks)
    assert cert.verified == (not cert.failed_checks) == all(c.passed for c in cert.checks)
    assert cert.failed_checks == tuple(c for c in cert.checks if not c.passed)
    text = cert.summary()
    assert isinstance(text, str) and text
    for c in cert.checks:  # every check is reported in the summary
        assert c.summary() in text


def test_to_dict_is_json_after_the_cli_sanitising(built: tuple[Any, tuple[int, int]]) -> None:
    cert, shape = built
    d = cert.to_dict()
    out = json.loads(json.dumps(jsonable(d), allow_nan=False))
    assert out["verified"] is cert.verified
    assert np.asarray(out["gain"]).shape == shape
    np.testing.assert_array_equal(np.asarray(out["gain"], dtype=float), cert.gain)
    assert [c["name"] for c in out["checks"]] == [c.name for c in cert.checks]
    assert [c["passed"] for c in out["checks"]] == [c.passed for c in cert.checks]


def test_printed_designs_fail_their_own_checks_on_example_61_class_ii() -> None:
    for build in (_printed, _prop516):
        cert, _ = build()
        assert not cert.verified
        names = {c.name for c in cert.failed_checks}
        assert "exact condition (A.16): −min eig ≤ 0" in names
        assert "spectral radius of (I − L̃C₂)Φ(A − Ψ) < 1" in names
    d, _ = _prop516()
    assert next(c for c in d.checks if "(32)" in c.name).passed  # θ₁ < 1 holds; stability does not


def test_a_destabilising_gain_is_a_failed_certificate_naming_the_check() -> None:
    cert = verify_observer_gain(AXIS.A, AXIS.C, AXIS.Bd, -K_PAPER, gamma=50.0, strict=False)
    assert isinstance(cert, Certificate)
    assert cert.verified is False and cert.status is CertificateStatus.FAILED
    failed = {c.name: c for c in cert.failed_checks}
    assert "A − K C Hurwitz (max Re λ)" in failed
    assert failed["A − K C Hurwitz (max Re λ)"].margin < 0
    d = json.loads(json.dumps(jsonable(cert.to_dict()), allow_nan=False))
    assert d["verified"] is False and d["status"] == "failed"
    assert {c["name"] for c in d["checks"] if not c["passed"]} == set(failed)


def test_a_tampered_lyapunov_matrix_fails_positivity() -> None:
    c = RiccatiConstants((3, 1), None, alpha=1.0, mu=0.5, gamma=1.0)
    good = smallest_w(c).certificate
    bad = verify_drift_gain(c, good.gain, -good.P)  # −P is negative definite
    assert good.verified
    assert not bad.verified and any(k.name.startswith("P ≻ 0") for k in bad.failed_checks)
    assert bad.summary().splitlines()[0].endswith("NOT verified")


def test_a_non_certificate_is_not_a_certificate() -> None:
    st = structural_check(np.eye(2) * 0.5, [[1.0], [0.0]], np.eye(2))
    assert not isinstance(st, Certificate)
    assert not isinstance(Check.verdict("x", True, "", kind=CheckKind.STRUCTURAL), Certificate)


# --------------------------------------------------------------------------- Check


def test_compare_strict_and_non_strict_at_equality() -> None:
    strict = Check.compare("a < b", 1.0, 1.0, kind=CheckKind.NORM)
    loose = Check.compare("a ≤ b", 1.0, 1.0, kind=CheckKind.NORM, strict=False)
    assert not strict.passed and loose.passed
    assert strict.margin == 0.0 == loose.margin
    assert strict.summary() == "a < b: 1 < 1 (FAILED by -0)"
    assert loose.summary() == "a ≤ b: 1 ≤ 1 (ok)"
    assert Check.compare("x", -0.5, 0.0, kind=CheckKind.LMI).summary() == "x: -0.5 < 0 (ok)"
    assert Check.compare("x", 2.0, 0.5, kind=CheckKind.LMI).summary() == "x: 2 < 0.5 (FAILED by 1.5)"


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("strict", [True, False])
def test_compare_non_finite_value_never_passes(value: float, strict: bool) -> None:
    c = Check.compare("‖H‖∞ < γ", value, 10.0, kind=CheckKind.NORM, strict=strict)
    assert not c.passed
    assert c.is_comparison and c.relation == ("<" if strict else "≤")
    d = json.loads(json.dumps(jsonable(c.to_dict()), allow_nan=False))
    assert d["passed"] is False and d["value"] is None


def test_verdict_summary_margin_and_dict() -> None:
    v = Check.verdict("A5 (involutive)", False, "[τ_1, τ_2] leaves span{τ}", kind=CheckKind.STRUCTURAL,
                      method="numeric", value=0.3, worst_point=(np.float64(1.0), 2), values={"pair": (1, 2)})
    assert v.summary() == "A5 (involutive): FAILS — [τ_1, τ_2] leaves span{τ}"
    assert math.isnan(v.margin) and not v.is_comparison and v.relation == ""
    assert v.worst_point == (1.0, 2.0) and v.values["pair"] == (1, 2)
    d = json.loads(json.dumps(v.to_dict(), allow_nan=False))
    assert d["passed"] is d["holds"] is False and d["kind"] == "structural" and d["values"] == {"pair": [1, 2]}
    assert d["strict"] is None and d["limit"] is None and d["worst_point"] == [1.0, 2.0]
    ok = Check.verdict("s ≤ r", True, "", kind=CheckKind.STRUCTURAL)
    assert ok.summary() == "s ≤ r: holds"


def test_check_is_frozen_and_its_values_read_only() -> None:
    c = Check.verdict("x", True, "e", kind=CheckKind.RANK, values={"rank": 2, "zeros": (1 + 2j,)})
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.passed = False  # type: ignore[misc]
    with pytest.raises(TypeError):
        c.values["rank"] = 3  # type: ignore[index]
    assert c.to_dict()["values"] == {"rank": 2, "zeros": [[1.0, 2.0]]}


def test_a_comparison_cannot_contradict_its_numbers() -> None:
    with pytest.raises(InvalidArgumentError, match="contradicts"):
        Check("x", True, kind=CheckKind.LMI, value=1.0, limit=0.0, strict=True)
    with pytest.raises(InvalidArgumentError, match="needs a value and a limit"):
        Check("x", True, kind=CheckKind.LMI, strict=True)
    with pytest.raises(InvalidArgumentError, match="kind"):
        Check("x", True, kind="lmi")  # type: ignore[arg-type]
    assert dataclasses.replace(Check.compare("x", 1.0, 2.0, kind=CheckKind.LMI), evidence="e").passed
