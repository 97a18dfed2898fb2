"""``nlobs design drift`` and ``nlobs design pinv``: the differential-geometric observers.

* ``drift`` — observer (3.1) of Dalla Mora, Germani & Manes: the gain of
  Remark 2.11 (smallest ``w`` solving (2.17)) or the SDP design, verified by the
  eigenvalues of the left side of (2.17), with the bound constants of (3.17).
* ``pinv`` — observer (7) with Röbenack's Moore–Penrose gain ``l(x) = Q⁺(x) k`` (17),
  after checking A1 and A5.

Both can simulate the design from given initial conditions (``--simulate``) and write
a plot and the trajectories (``--out``).
"""

from __future__ import annotations

from pathlib import Path
from collections.abc import Callable
from typing import Annotated, Any, TypeVar

import numpy as np
import typer

from nlobs.cli.common import (
    EXIT_FAILURE,
    EXIT_NO_OBSERVER,
    console,
    design_app,
    emit_json,
    fail,
    load_model_arg,
    parse_box,
    parse_floats,
)
from nlobs.errors import AssumptionViolated, DesignError, NlobsError, SimulationDiverged
from nlobs.systems.symbolic import SymbolicModel

# Options shared by both commands (one definition each).
Box_ = Annotated[str | None, typer.Option("--box", help="Region: 'lo,hi' or 2n numbers (default -1,1).")]
Json_ = Annotated[bool, typer.Option("--json", help="Print JSON.")]
Simulate_ = Annotated[bool, typer.Option("--simulate", help="Simulate the design.")]
X0_ = Annotated[str | None, typer.Option("--x0", help="Initial plant state for --simulate, e.g. '1,0'.")]
Xhat0_ = Annotated[str | None, typer.Option("--xhat0", help="Initial estimate for --simulate (default: zeros).")]
U_ = Annotated[str | None, typer.Option("--u", help="Constant input for --simulate.")]
Duration_ = Annotated[float, typer.Option("--duration", help="Simulated time [s].")]
Dt_ = Annotated[float, typer.Option("--dt", help="RK4 step [s]; it must resolve the gain's fastest pole.")]
Out_ = Annotated[Path | None, typer.Option("--out", help="Folder for the plot (.png) and trajectories (.npz).")]


def _symbolic(model: str) -> SymbolicModel:
    m = load_model_arg(model)
    if not isinstance(m, SymbolicModel):
        fail(f"{model}: a nonlinear (symbolic) model is needed; this one is linear")
    return m


def _ints(option: str, text: str | None) -> list[int] | None:
    vals = parse_floats(option, text)
    if vals is None:
        return None
    if any(v != int(v) for v in vals):
        fail(f"{option}: expected integers, got {text!r}")
    return [int(v) for v in vals]


def _sim_inputs(m: SymbolicModel, x0: str | None, xhat0: str | None, u: str | None) -> tuple[Any, Any, Any]:
    if x0 is None:
        fail("--simulate needs --x0 (the initial plant state)")
    x0v = parse_floats("--x0", x0)
    xh = parse_floats("--xhat0", xhat0) if xhat0 is not None else [0.0] * m.n
    uv = parse_floats("--u", u) if u is not None else [0.0] * m.m
    for name, v, size in (("--x0", x0v, m.n), ("--xhat0", xh, m.n), ("--u", uv, m.m)):
        if v is None or len(v) != size:
            fail(f"{name}: expected {size} numbers for model {m.name}, got {0 if v is None else len(v)}")
    return np.array(x0v), np.array(xh), np.array(uv)


T = TypeVar("T")


def _run(model: str, simulate: Callable[[], T]) -> T:
    """Run a simulation; a divergence or another nlobs failure is a one-line error with status 1."""
    try:
        return simulate()
    except SimulationDiverged as exc:
        fail(f"{model}: simulation diverged: {exc} (try a smaller --dt)", EXIT_FAILURE)
    except NlobsError as exc:
        fail(f"{model}: {exc}", EXIT_FAILURE)


def _report_simulation(result: Any, out: Path | None, stem: str, duration: float, dt: float) -> tuple[dict[str, Any], list[str]]:
    """Error-norm summary of a simulation, with the plot and trajectories written to ``out`` (if given)."""
    e = result.error_norm
    summ: dict[str, Any] = {"final_error_norm": float(np.max(e[..., -1])), "initial_error_norm": float(np.max(e[..., 0])),
                            "max_error_norm": float(np.max(e))}
    files: list[Path] = []
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        png = out / f"{stem}.png"
        result.plot(png)
        files = [png, result.save(out / f"{stem}.npz")]
    summ["files"] = [str(f) for f in files]
    lines = [f"simulation ({duration:g} s, dt = {dt:g}): ‖e(0)‖ = {summ['initial_error_norm']:.4g}, "
             f"‖e(T)‖ = {summ['final_error_norm']:.4g}, max ‖e‖ = {summ['max_error_norm']:.4g}"]
    return summ, lines + [f"wrote {f}" for f in files]


@design_app.command("drift")
def drift_cmd(
    model: Annotated[str, typer.Argument(help="A model file (.toml) or a shipped model name.")],
    s: Annotated[str | None, typer.Option("--s", help="Multi-index, e.g. '3,1' (default: observability indices).")] = None,
    alpha: Annotated[float, typer.Option(help="Decay rate α of (2.17).")] = 1.0,
    mu: Annotated[float, typer.Option(help="Input bound μ of (2.17).")] = 1.0,
    gamma: Annotated[float | None, typer.Option(help="γ of (2.17) (default: estimated on the region).")] = None,
    method: Annotated[str, typer.Option(help="'vandermonde' (Remark 2.11) or 'sdp' (LMI in S = P⁻¹, Y = S K).")] = "vandermonde",
    w: Annotated[float | None, typer.Option(help="Check and use K(w) instead of searching the smallest w.")] = None,
    box: Box_ = None,
    as_json: Json_ = False,
    simulate: Simulate_ = False,
    x0: X0_ = None,
    xhat0: Xhat0_ = None,
    u: U_ = None,
    duration: Duration_ = 10.0,
    dt: Dt_ = 1e-3,
    out: Out_ = None,
) -> None:
    """Design (and verify) the drift-observability observer (3.1) of Dalla Mora, Germani & Manes.

    After the report, exit status 3 when drift-observability fails on the region (no observer of
    this structure there), 1 when the design is not usable otherwise (a given --gamma below the
    sampled estimate, a failed certificate).
    """
    from nlobs.workflows.design_drift import design_drift_report, simulate_drift

    m = _symbolic(model)
    if method not in ("vandermonde", "sdp"):
        fail(f"--method: expected 'vandermonde' or 'sdp', got {method!r}")
    region = parse_box("--box", box, m.n) if box is not None else None
    try:
        rep = design_drift_report(m, _ints("--s", s), alpha=alpha, mu=mu, gamma=gamma, method=method, region=region,
                                  w=w)
    except AssumptionViolated as exc:
        fail(f"{model}: {exc}", EXIT_NO_OBSERVER)
    except DesignError as exc:
        fail(f"{model}: design failed: {exc}", EXIT_FAILURE)
    except NlobsError as exc:
        fail(f"{model}: {exc}")
    data: dict[str, Any] = {"design": rep.to_dict()}
    text = [rep.summary()]
    if not rep.usable:  # the report is the evidence; the last line says why there is no observer
        if as_json:
            emit_json(data)
        else:
            console().print("\n".join(text), markup=False)
        status = EXIT_NO_OBSERVER if not rep.drift_check.passed else EXIT_FAILURE
        fail(f"{model}: no usable observer: " + "; ".join(rep.reasons), status)
    if simulate:
        x0v, xh, uv = _sim_inputs(m, x0, xhat0, u)
        sim = _run(model, lambda: simulate_drift(m, x0v, xh, duration, dt=dt, u=uv, w=w, report=rep))
        summ, lines = _report_simulation(sim.result, out, "drift", duration, dt)
        summ.update(decay_rate=sim.decay_rate, bound_ratio=sim.bound_ratio, certified=sim.certified)
        data["simulation"] = summ
        lines[0] += (f", fitted decay rate {sim.decay_rate:.4g} (α = {alpha:g}), max ‖e‖/bound(3.2) = "
                     f"{sim.bound_ratio:.3g}" + ("" if sim.certified else " (gain not certified)"))
        text += lines
    if as_json:
        emit_json(data)
    else:
        console().print("\n".join(text), markup=False)


@design_app.command("pinv")
def pinv_cmd(
    model: Annotated[str, typer.Argument(help="A model file (.toml) or a shipped model name.")],
    theta: Annotated[float, typer.Option(help="High-gain parameter θ of the roots of (10).")] = 2.0,
    placement: Annotated[str, typer.Option(help="'powers' (roots −θ^i) or 'multiple' (root −θ, multiplicity r).")] = "powers",
    k: Annotated[str | None, typer.Option("--k", help="Gain vector k (Σ r_j numbers), instead of θ.")] = None,
    box: Box_ = None,
    as_json: Json_ = False,
    simulate: Simulate_ = False,
    x0: X0_ = None,
    xhat0: Xhat0_ = None,
    u: U_ = None,
    duration: Duration_ = 10.0,
    dt: Dt_ = 1e-3,
    out: Out_ = None,
) -> None:
    """Design Röbenack's Moore–Penrose observer (7), (17) and check A1, A5."""
    from nlobs.workflows.design_pinv import design_pinv_report, simulate_pinv

    m = _symbolic(model)
    if placement not in ("powers", "multiple"):
        fail(f"--placement: expected 'powers' or 'multiple', got {placement!r}")
    region = parse_box("--box", box, m.n) if box is not None else None
    kv = parse_floats("--k", k)
    try:
        rep = design_pinv_report(m, kv, theta, placement, region)  # type: ignore[arg-type]
    except AssumptionViolated as exc:
        fail(f"{model}: {exc}", EXIT_NO_OBSERVER)
    except NlobsError as exc:
        fail(f"{model}: {exc}")
    data: dict[str, Any] = {"design": rep.to_dict()}
    text = [rep.summary()]
    if simulate:
        x0v, xh, uv = _sim_inputs(m, x0, xhat0, u)
        res = _run(model, lambda: simulate_pinv(m, x0v, xh, duration, dt=dt, u=uv, report=rep))
        data["simulation"], lines = _report_simulation(res, out, "pinv", duration, dt)
        text += lines
    if as_json:
        emit_json(data)
    else:
        console().print("\n".join(text), markup=False)
