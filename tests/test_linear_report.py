"""analyze_linear / LinearReport (nlobs.linear.report).

The report must agree with the individual functions and with independent
hand-derived facts; its ``to_dict`` keys are a stable interface.
"""

from __future__ import annotations

import json
import math

import control
import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError
from nlobs.linear import REPORT_KEYS, LinearReport, analyze_linear
from nlobs.systems.linear import LinearSystem
from nlobs.systems.timebase import Discrete

EXPECTED_KEYS = [
    "name",
    "time",
    "dt",
    "n",
    "m",
    "p",
    "eigenvalues",
    "stable",
    "observable",
    "detectable",
    "left_invertible",
    "minimum_phase",
    "strongly_detectable",
    "invariant_zeros",
    "normal_rank",
    "hinf_norm",
    "h2_norm",
]


def _lowpass() -> LinearSystem:
    return LinearSystem([[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]], name="lowpass")


def test_keys_are_stable_and_json_serialisable() -> None:
    d = analyze_linear(_lowpass()).to_dict()
    assert list(d) == EXPECTED_KEYS == list(REPORT_KEYS)
    back = json.loads(json.dumps(d, allow_nan=False))
    assert back == d
    for key in ("stable", "observable", "detectable", "left_invertible", "minimum_phase", "strongly_detectable"):
        assert type(d[key]) is bool
    assert type(d["normal_rank"]) is int and type(d["n"]) is int


def test_lowpass_report_values() -> None:
    r = analyze_linear(_lowpass())
    assert isinstance(r, LinearReport)
    d = r.to_dict()
    assert d["name"] == "lowpass" and d["time"] == "continuous" and d["dt"] is None
    assert (d["n"], d["m"], d["p"]) == (2, 1, 1)
    np.testing.assert_allclose(sorted(map(tuple, d["eigenvalues"])), [(-0.5, -math.sqrt(3) / 2), (-0.5, math.sqrt(3) / 2)])
    assert d["stable"] and d["observable"] and d["detectable"]
    assert d["left_invertible"] and d["minimum_phase"] and d["strongly_detectable"]
    assert d["invariant_zeros"] == [] and d["normal_rank"] == 3
    assert d["hinf_norm"] == pytest.approx(2 / math.sqrt(3), rel=1e-9)
    assert d["h2_norm"] == pytest.approx(math.sqrt(0.5), rel=1e-12)
    with pytest.raises(AttributeError):
        r.stable = False  # type: ignore[misc]


def test_discrete_unstable_unobservable() -> None:
    # x1⁺ = 1.5 x1 + u (seen), x2⁺ = 0.2 x2 + u (hidden): unstable, detectable, zero at 0.2
    sys = LinearSystem([[1.5, 0.0], [0.0, 0.2]], [[1.0], [1.0]], [[1.0, 0.0]], time=Discrete(0.1), name="d")
    r = analyze_linear(sys)
    d = r.to_dict()
    assert d["time"] == "discrete" and d["dt"] == 0.1
    assert not d["stable"] and not d["observable"] and d["detectable"]
    np.testing.assert_allclose(r.unobservable_modes, [0.2])
    np.testing.assert_allclose(np.array(d["invariant_zeros"]), [[0.2, 0.0]], atol=1e-12)
    assert d["minimum_phase"] and d["strongly_detectable"]
    assert d["hinf_norm"] is None and d["h2_norm"] is None


def test_continuous_feedthrough_and_nonminimum_phase() -> None:
    # (s − 1)/(s + 2) = 1 − 3/(s + 2): H∞ = max(|G(0)|, |G(∞)|) = 1, H2 infinite (D ≠ 0)
    sys = LinearSystem([[-2.0]], [[1.0]], [[-3.0]], [[1.0]])
    r = analyze_linear(sys)
    assert r.stable and r.hinf_norm == pytest.approx(1.0, rel=1e-9)
    assert r.h2_norm is None
    np.testing.assert_allclose(r.invariant_zeros, [1.0])
    assert not r.minimum_phase and not r.strongly_detectable
    assert "Re z >= 0" in r.minimum_phase_reason
    text = r.summary()
    assert "minimum phase:       no" in text and "infinite (D != 0)" in text


def test_report_matches_python_control_on_a_mimo_example() -> None:
    rng = np.random.default_rng(7)
    A = rng.normal(size=(4, 4))
    A -= (max(np.linalg.eigvals(A).real) + 0.5) * np.eye(4)
    B, C = rng.normal(size=(4, 2)), rng.normal(size=(3, 4))
    r = analyze_linear(LinearSystem(A, B, C))
    ref = control.ss(A, B, C, np.zeros((3, 2)))
    assert r.hinf_norm == pytest.approx(float(control.linfnorm(ref, tol=1e-10)[0]), rel=1e-7)
    assert r.h2_norm == pytest.approx(float(control.norm(ref, p=2, method="slycot", print_warning=False)), rel=1e-8)
    assert r.observable == (np.linalg.matrix_rank(control.obsv(A, C)) == 4)
    assert r.left_invertible and r.normal_rank == 6


def test_text_report() -> None:
    text = analyze_linear(_lowpass()).summary()
    lines = text.splitlines()
    assert lines[0].startswith("Linear system 'lowpass': continuous, n=2, m=1, p=1")
    assert any(line.strip().startswith("H-infinity norm:") and "1.1547" in line for line in lines)
    assert "invariant zeros:     none" in text


def test_requires_a_linear_system() -> None:
    with pytest.raises(InvalidArgumentError, match="LinearSystem"):
        analyze_linear(np.eye(2))  # type: ignore[arg-type]
