"""``nlobs design drift``, ``nlobs design pinv`` and ``nlobs design cascade``.

* ``drift`` — observer (3.1) of Dalla Mora, Germani & Manes: the gain of Remark 2.11 (smallest
  ``w`` solving (2.17)) or the SDP design, verified by the eigenvalues of the left side of (2.17),
  with the bound constants of (3.17).
* ``pinv`` — observer (7) with Röbenack's Moore–Penrose gain ``l(x) = Q⁺(x) k`` (17), after
  checking A1 and A5.
* ``cascade`` — the cascade/feedback observer (9)–(10) / (17)–(18) of Grip, Saberi & Johansen for a
  model file with a ``[cascade]`` table: Assumption 4 item by item, the gain of LMI (14) (or pole
  placement) re-verified, Theorem 1's γ when the file gives the constants of Assumptions 1–3.

Both can simulate the design from given initial conditions (``--simulate``) and write a plot and
the trajectories (``--out``). Each command parses its options, calls one workflow
(:func:`nlobs.workflows.design_drift.design_drift_observer`,
:func:`nlobs.workflows.design_pinv.design_pinv_observer`), prints the report's ``summary()`` or
its ``to_dict()`` as JSON, and exits by the report's verdict.
"""

# No ``from __future__ import annotations``: typer reads the annotations of every command's parameters when the
# app starts, and evaluated ones spare it compiling and evaluating each string again (twice per command).

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, NoReturn

import typer

from nlobs.cli.common import (
    complete_model,
    EXIT_FAILURE,
    EXIT_NO_OBSERVER,
    box_numbers,
    console,
    design_app,
    emit_json,
    fail,
    finish,
    on_off,
    parse_floats,
)
from nlobs.cli.choices import CascadeMethod, DriftMethod, OnOff, Placement, value
from nlobs.errors import (
    AssumptionViolated,
    DesignError,
    ModelFileError,
    NlobsError,
    OutputError,
    SimulationDiverged,
    StudyFailed,
)

if TYPE_CHECKING:  # the workflows' inputs load SymPy and SciPy: imported inside the commands
    from nlobs.workflows.inputs import SimulationRequest

# Options shared by both commands (one definition each).
Box_ = Annotated[str | None, typer.Option(
    "--box", help="Region: 'lo,hi' or 2n numbers (default: the model file's [simulation] box, else -1,1).")]
Json_ = Annotated[bool, typer.Option("--json", help="Print JSON.")]
Simulate_ = Annotated[bool, typer.Option("--simulate", help="Simulate the design.")]
X0_ = Annotated[str | None, typer.Option("--x0", help="Initial plant state for --simulate, e.g. '1,0'.")]
Xhat0_ = Annotated[str | None, typer.Option("--xhat0", help="Initial estimate for --simulate (default: zeros).")]
U_ = Annotated[str | None, typer.Option("--u", help="Constant input for --simulate.")]
Duration_ = Annotated[float, typer.Option("--duration", help="Simulated time [s].")]
Dt_ = Annotated[float, typer.Option("--dt", help="RK4 step [s]; it must resolve the gain's fastest pole.")]
Out_ = Annotated[Path | None, typer.Option("--out", help="Folder for the plot (.png) and trajectories (.npz).")]
Saturation_ = Annotated[OnOff, typer.Option(
    "--saturation", help="'on' (default): the simulated observer is saturated outside the region (peaking remedy; "
    "the same observer while the estimate is in the region); 'off': as printed in the paper.")]


def _ints(option: str, text: str | None) -> list[int] | None:
    vals = parse_floats(option, text)
    if vals is None:
        return None
    if any(v != int(v) for v in vals):
        fail(f"{option}: expected integers, got {text!r}")
    return [int(v) for v in vals]


def _request(simulate: bool, x0: str | None, xhat0: str | None, u: str | None, duration: float,
             dt: float, out: Path | None) -> "SimulationRequest | None":
    """The simulation asked for by ``--simulate`` (``None`` without it); the workflow checks its vectors against
    the model it reads (the model file is read once, by the workflow)."""
    if not simulate:
        return None
    from nlobs.workflows.inputs import SimulationRequest

    if x0 is None:
        fail("--simulate needs --x0 (the initial plant state)")
    x0v = parse_floats("--x0", x0)
    xh = parse_floats("--xhat0", xhat0) if xhat0 is not None else None
    uv = parse_floats("--u", u) if u is not None else None
    try:
        return SimulationRequest(x0v, xh, uv, duration=duration, dt=dt, out=out)  # type: ignore[arg-type]
    except NlobsError as exc:
        fail(str(exc))


def _print(report: Any, as_json: bool) -> None:
    """Print a workflow report (JSON or text), then exit by its verdict with its message."""
    if as_json:
        emit_json(report.to_dict())
    else:
        console().print(report.summary(), markup=False)
    finish(report, as_json)  # the report is the evidence; the last line says why there is no observer


def _errors(model: str, exc: NlobsError) -> NoReturn:
    """The one-line error and exit status of a workflow's typed error (the design's are mapped by the caller)."""
    from nlobs.workflows.inputs import BoxError

    if isinstance(exc, BoxError):
        fail(f"--box: {exc}")
    if isinstance(exc, SimulationDiverged):
        fail(f"{model}: {exc}", EXIT_FAILURE)  # the workflow says what is known (RK4 step, peaking)
    if isinstance(exc, StudyFailed):
        fail(f"{model}: {exc}", EXIT_FAILURE)
    if isinstance(exc, OutputError):
        fail(f"--out {exc}")
    fail(f"{model}: {exc}")


@design_app.command("drift")
def drift_cmd(
    model: Annotated[str, typer.Argument(
        metavar="MODEL", autocompletion=complete_model, help="A model file (.toml) or a shipped model name.")],
    s: Annotated[str | None, typer.Option("--s", help="Multi-index, e.g. '3,1' (default: observability indices).")] = None,
    alpha: Annotated[float | None, typer.Option(help="Decay rate α of (2.17) (default 1).")] = None,
    mu: Annotated[float | None, typer.Option(
        help="Input bound μ of (2.17) (default: the largest ‖u(t)‖ of the file's [input_signals] over its "
             "[simulation] duration, else 0).")] = None,
    gamma: Annotated[float | None, typer.Option(help="γ of (2.17) (default: estimated on the region).")] = None,
    method: Annotated[DriftMethod, typer.Option(help="'vandermonde' (Remark 2.11) or 'sdp' (LMI in S = P⁻¹, Y = S K).")
                      ] = DriftMethod.vandermonde,
    w: Annotated[float | None, typer.Option(help="Check and use K(w) instead of searching the smallest w.")] = None,
    w_max: Annotated[float, typer.Option("--w-max", help="Largest w the search for the smallest w tries.")] = 1e5,
    box: Box_ = None,
    saturation: Saturation_ = OnOff.on,
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
    from nlobs.workflows.design_drift import design_drift_observer

    method = value(method)
    region = box_numbers("--box", box)
    sat = on_off("--saturation", value(saturation))
    multi_index = _ints("--s", s)
    request = _request(simulate, x0, xhat0, u, duration, dt, out)
    try:
        report = design_drift_observer(model, s=multi_index, alpha=alpha, mu=mu, gamma=gamma, method=method, w=w,
                                       box=region, simulate=request, name=model, w_max=w_max,
                                       saturation=sat)
    except AssumptionViolated as exc:
        fail(f"{model}: {exc}", EXIT_NO_OBSERVER)
    except DesignError as exc:
        fail(f"{model}: design failed: {exc}", EXIT_FAILURE)
    except NlobsError as exc:
        _errors(model, exc)
    _print(report, as_json)


@design_app.command("pinv")
def pinv_cmd(
    model: Annotated[str, typer.Argument(
        metavar="MODEL", autocompletion=complete_model, help="A model file (.toml) or a shipped model name.")],
    theta: Annotated[float, typer.Option(help="High-gain parameter θ of the roots of (10).")] = 2.0,
    placement: Annotated[Placement, typer.Option(help="'powers' (roots −θ^i) or 'multiple' (root −θ, multiplicity r).")
                         ] = Placement.powers,
    k: Annotated[str | None, typer.Option("--k", help="Gain vector k (Σ r_j numbers), instead of θ.")] = None,
    box: Box_ = None,
    saturation: Annotated[OnOff | None, typer.Option(
        "--saturation", help="'on': the simulated observer is saturated outside the region (peaking remedy; the "
        "same observer while the estimate is in the region); 'off': as printed in the paper. Default: on with "
        "a region (--box, or the model file's [simulation] box), off without (the default region -1,1 need not "
        "hold the state).")] = None,
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
    from nlobs.workflows.design_pinv import design_pinv_observer

    placement = value(placement)
    region = box_numbers("--box", box)
    sat = None if saturation is None else on_off("--saturation", value(saturation))
    kv = parse_floats("--k", k)
    request = _request(simulate, x0, xhat0, u, duration, dt, out)
    try:
        report = design_pinv_observer(model, k=kv, theta=theta, placement=placement, box=region,  # type: ignore[arg-type]
                                      simulate=request, saturation=sat)
    except AssumptionViolated as exc:
        fail(f"{model}: {exc}", EXIT_NO_OBSERVER)
    except NlobsError as exc:
        _errors(model, exc)
    _print(report, as_json)


@design_app.command("cascade")
def cascade_cmd(
    model: Annotated[str, typer.Argument(
        metavar="MODEL", autocompletion=complete_model, help="A model file (.toml) with a [cascade] table, or a shipped model name.")],
    gamma: Annotated[float | None, typer.Option(help="‖H‖∞ < γ asked of the gain (default: the file's "
                                                     "[cascade].gamma, else 1).")] = None,
    method: Annotated[CascadeMethod | None, typer.Option(help="'lmi' (LMI (14), analytic centre), 'placement' (poles "
                                                    "scaled until ‖H‖∞ < γ, for Theorem 1's small γ) or 'h2' "
                                                    "(the smallest noise-to-error H2 norm under LMI (14) for the "
                                                    "file's [sensors.*] and [process_noise]); default: "
                                                    "the file's [cascade].method, else 'lmi'.")] = None,
    gain_bound: Annotated[float | None, typer.Option("--gain-bound", help="‖K‖ bound of the LMI and H2 designs "
                                                                          "(default 1e4).")] = None,
    as_json: Json_ = False,
    simulate: Simulate_ = False,
    x0: Annotated[str | None, typer.Option("--x0", help="Initial plant state [x, w] for --simulate.")] = None,
    xhat0: Annotated[str | None, typer.Option("--xhat0", help="Initial estimate [x̂, ŵ] (default: zeros).")] = None,
    u: U_ = None,
    duration: Duration_ = 10.0,
    dt: Dt_ = 1e-3,
    out: Out_ = None,
) -> None:
    """Design (and verify) the cascade/feedback observer of Grip, Saberi & Johansen from a [cascade] table.

    After the report, exit status 3 when Assumption 4 fails (no gain can exist), 1 when the design is
    infeasible for the options given (the message names the option to change).
    """
    from nlobs.workflows.design_cascade import design_cascade_observer

    method = value(method)
    request = _request(simulate, x0, xhat0, u, duration, dt, out)
    try:
        report = design_cascade_observer(model, gamma=gamma, method=method, gain_bound=gain_bound, simulate=request,
                                         name=model)
    except ModelFileError as exc:
        fail(str(exc))
    except NlobsError as exc:
        _errors(model, exc)
    _print(report, as_json)
