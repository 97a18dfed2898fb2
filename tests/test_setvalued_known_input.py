"""Known inputs ``B u`` in the set-valued observer: read from ``[input_signals]``, given to plant, observer, baselines.

Before, a model file with an input failed the study with "u: expected shape (..., 1), got (20, 0)".
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from nlobs.simulate.setvalued import containment_of, run_setvalued, simulate_batch
from nlobs.systems.modelfile import load_discrete_ui_model, shipped_models
from nlobs.workflows.setvalued import design_setvalued_observer, simulate_setvalued_observer


def _with_input(tmp_path: Path, signal: str | None) -> Path:
    text = shipped_models()["khajenejad-6-1"].read_text()
    text = text.replace('outputs = ["y1", "y2"]', 'inputs = ["tau"]\noutputs = ["y1", "y2"]')
    text = text.replace('h = ["x1", "x2"]', 'g = [["0"], ["Ts"], ["0"], ["0"]]\nh = ["x1", "x2"]')
    if signal is not None:
        text += f"\n[input_signals]\ntau = {signal}\n"
    p = tmp_path / "k61u.toml"
    p.write_text(text)
    return p


def test_the_study_runs_with_a_known_input_and_the_balls_contain_the_truth(tmp_path: Path) -> None:
    path = _with_input(tmp_path, '{ kind = "sine", amplitude = 20.0, frequency = 0.5 }')
    m = load_discrete_ui_model(path)
    assert m.system.m == 1 and m.known_input is not None
    rep = simulate_setvalued_observer(path, runs=50, steps=200, seed=3)
    c = rep.study.containment
    assert c.rate_state == 1.0 and c.rate_input == 1.0
    u = rep.study.batch.extras["u"]
    np.testing.assert_allclose(u[0, :, 0], 20.0 * np.sin(2 * np.pi * 0.5 * np.arange(201) * 0.01))


def test_the_input_drives_the_plant_and_an_observer_not_told_of_it_loses_the_truth(tmp_path: Path) -> None:
    m = load_discrete_ui_model(_with_input(tmp_path, "200.0"))
    design = design_setvalued_observer(m).design
    told = simulate_batch(m.system, design, m.signals["bounded"], runs=30, steps=150, seed=1,
                          known_input=m.known_input)
    zero = simulate_batch(m.system, design, m.signals["bounded"], runs=30, steps=150, seed=1)
    assert not np.allclose(told.x, zero.x)  # the plant felt the input
    assert containment_of(told, system=m.system, gain=design).rate_state == 1.0
    blind = run_setvalued(m.system, design, told.y, truth=told.x)  # the same data, u = 0 for the observer
    blind = dataclasses.replace(blind, y=told.y, extras={**blind.extras, "d": told.extras["d"]})
    assert containment_of(blind, system=m.system, gain=design).rate_state < 1.0


def test_a_model_with_an_input_and_no_signal_runs_with_zero_input(tmp_path: Path) -> None:
    rep = simulate_setvalued_observer(_with_input(tmp_path, None), runs=20, steps=50, seed=0)
    assert rep.study.containment.rate_state == 1.0
    assert not rep.study.batch.extras["u"].any()
