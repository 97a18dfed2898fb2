"""Röbenack's Moore–Penrose observer certified on the region under sampled, noisy outputs (vertex LMIs of its gain field).

Independent sources: the Van der Pol circuit's Jacobian written out by hand at the exact ends of its range, and a
Monte Carlo simulation whose RMS error must stay below the certified bound.
"""

from __future__ import annotations

import pytest

from pathlib import Path

import numpy as np

from nlobs.methods.comparison import compare_observers
from nlobs.methods.problem import problem
from nlobs.methods.registry import get
from nlobs.systems.modelfile import resolve_model


def _fast_vdp(tmp_path: Path) -> str:
    """The shipped circuit with its ADC at 1 MHz (1000 per ms), a shorter horizon and a finer step."""
    text = resolve_model("vanderpol-circuit").read_text()
    text = text.replace("rate = 20.0 ", "rate = 1000.0 ").replace("duration = 30.0 ", "duration = 8.0 ")
    text = text.replace("dt = 0.005 ", "dt = 0.0005 ").replace("settle = 10.0", "settle = 4.0")
    f = tmp_path / "vdp-fast.toml"
    f.write_text(text)
    return str(f)


@pytest.mark.slow
def test_a_fast_adc_certifies_the_pinv_observer_and_its_runs_stay_below_the_bound(tmp_path: Path) -> None:
    path = _fast_vdp(tmp_path)
    d = get("pinv").design(problem(path))
    assert d.certified, d.status
    assert d.sources["theta"].startswith("the smallest certified RMS bound of 8 values of θ")
    b = d.bound
    assert b.verified and d.parameters["T_max"]["adc"] > 0.001
    # (V) at the exact vertices of the hand-written Jacobian: ∂f/∂x = [[(a − 3b v²)/C, −1/C], [1/L, 0]], v ∈ [−3.5, 3.5],
    # and the gain field l(x̂) = Q⁺ k = [k, 0]ᵀ (Q = ∂h/∂x = [1, 0])
    P, alpha = b.P, d.certificate.continuous.decay
    k = float(d.gain[0])
    l = np.array([[k], [0.0]])
    np.testing.assert_allclose(d.certificate.continuous.gain, l, atol=1e-12)  # the gain field is constant here
    C = np.array([[1.0, 0.0]])
    for a11 in (1.0 - 3 * (1 / 3) * 3.5**2, 1.0):
        M = np.array([[a11, -1.0], [1.0, 0.0]]) - l @ C
        lmi = M.T @ P + P @ M + 2 * alpha * P
        assert np.linalg.eigvalsh((lmi + lmi.T) / 2)[-1] <= 1e-9
    rep = compare_observers(path, observers=["pinv"], runs=4, progress=False)
    o = rep.observers["pinv"]
    c = o.certificate
    assert c["verified"] and c["covered_fraction"] == 1.0
    assert o.rms_error_norm <= c["rms_bound"]


@pytest.mark.slow
def test_where_no_certificate_covers_the_sensors_the_design_says_why() -> None:
    d = get("pinv").design(problem("vanderpol-circuit"))  # the shipped ADC at 20 kHz
    premise = next(h for h in d.hypotheses if getattr(h, "name", "").startswith("sampled with period"))
    assert not d.certified and not premise.holds and "adc: T = 0.05 > T_max = " in premise.reason
    assert d.parameters["theta"] == 2.0 and d.sources["theta"].startswith("default (no θ of 0.25 … 8")
    d = get("pinv").design(problem("chemostat"))
    premise = next(h for h in d.hypotheses if getattr(h, "name", "").startswith("sampled with period"))
    assert not premise.holds and "eigenvalue with real part" in premise.reason
    held = get("pinv").design(problem("vanderpol-circuit"), sampling="hold")
    assert held.bound is None and not held.certified
