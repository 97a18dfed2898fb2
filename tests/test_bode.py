"""The error dynamics' frequency response (``bode.png``): against the closed form of a first-order error, against
the certificate's ‖H‖∞ (a second algorithm: the Hamiltonian bisection of ``hinf_norm``), and in the cascade design's
output folder."""

from __future__ import annotations

import numpy as np
import pytest

from nlobs.errors import InvalidArgumentError
from nlobs.linear import hinf_norm
from nlobs.linear.frequency import bode_figure, error_response, frequency_grid


def test_a_second_order_error_against_its_closed_form() -> None:
    # ë + 2ζω₀ ė + ω₀² e = w: |H(jω)| = 1 / √((ω₀² − ω²)² + (2ζω₀ω)²)
    w0, zeta = 3.0, 0.1
    F = np.array([[0.0, 1.0], [-w0**2, -2 * zeta * w0]])
    B = np.array([[0.0], [1.0]])
    w = frequency_grid(F, 2000)
    assert w[0] < 0.05 * w0 and w[-1] > 50 * w0
    g = error_response(F, B @ np.array([[1.0]]), w)
    # σ_max of the 2-vector (1, jω)ᵀ/den: √(1 + ω²)/|den|
    den = np.abs(w0**2 - w**2 + 2j * zeta * w0 * w)
    assert np.allclose(g, np.sqrt(1.0 + w**2) / den, rtol=1e-10)
    peak = float(hinf_norm(F, B, np.eye(2), np.zeros((2, 1))))
    assert abs(g.max() - peak) < 1e-3 * peak  # the grid finds the resonance


def test_an_unstable_error_has_no_figure() -> None:
    with pytest.raises(InvalidArgumentError, match="not Hurwitz"):
        bode_figure([[1.0]], [[1.0]])


def test_the_cascade_design_writes_bode_png_with_its_certified_peak(tmp_path) -> None:
    from typer.testing import CliRunner

    from nlobs.cli import app
    from nlobs.linear.assumption4 import extended_system
    from nlobs.methods.cascade import design_cascade
    from nlobs.systems.cascade_file import load_cascade

    res = CliRunner().invoke(app, ["design", "cascade", "chemostat-analyser", "--simulate", "--x0", "1,1,1",
                                   "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    png = tmp_path / "bode.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    d = design_cascade(load_cascade("chemostat-analyser"))
    s2 = d.cascade.sigma2
    ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
    F = ext.A - d.certificate.gain @ ext.C
    fig = bode_figure(F, ext.Bd, gamma=d.gamma, KN=d.certificate.gain)
    h_line = fig.axes[0].get_lines()[0]
    assert abs(float(np.max(h_line.get_ydata())) - d.certificate.hinf_H) < 1e-3 * d.certificate.hinf_H
    assert np.max(h_line.get_ydata()) < d.gamma


def test_a_linear_models_comparison_draws_the_luenberger_error_dynamics(tmp_path) -> None:
    from nlobs.workflows.compare import compare_observers

    rep = compare_observers("gnss-ins-axis", observers=["luenberger"], runs=2, duration=2.0, out=tmp_path)
    assert (tmp_path / "bode.png").stat().st_size > 10_000 and tmp_path / "bode.png" in rep.files
    cert = rep.observers["luenberger"].design.certificate
    assert cert.hinf_H < cert.gamma  # what the figure's peak shows against its γ line
    assert "bode.png" not in {p.name for p in compare_observers(
        "pendulum", observers=["luenberger"], runs=2, duration=1.0, out=tmp_path / "nl").files}  # nonlinear: none
