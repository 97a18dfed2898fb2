r"""``nlobs design pinv``: Röbenack's Moore–Penrose observer (7), (17), its report and a simulation.

The design and its report are :data:`nlobs.methods.pinv.PINV` and
:func:`nlobs.methods.pinv.design_pinv_report` (the method every command uses). This module adds
:func:`simulate_pinv` (a model simulated with that observer) and :func:`design_pinv_observer`, the
command ``nlobs design pinv``: one call, one frozen :class:`PinvWorkflowReport` whose ``to_dict()`` is
the JSON report and ``summary()`` what the text output prints; the simulation uses the design's own
observer.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from nlobs.errors import InvalidArgumentError
from nlobs.geometry.region import Box
from nlobs.simulate.coverage import COVERAGE_JSON, Coverage, InRegion, Premise, monitor
from nlobs.simulate.loop import simulate
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.sampling import MeasurementGroup
from nlobs.simulate.signals import InputLike
from nlobs.synthesis.pinv_gain import DEFAULT_THETA, PLACEMENTS, Placement
from nlobs.systems.symbolic import SymbolicModel
from nlobs._schema import Record
from nlobs.methods.base import Design, joined_design_json
from nlobs.methods.pinv import PINV, PINV_DESIGN_JSON, PinvDesignReport, build_pinv_observer, design_pinv_report
from nlobs.methods.problem import problem
from nlobs.workflows._results import ERROR_SUMMARY_JSON, checked_request, error_line, error_summary, run_study, write_result
from nlobs.workflows.inputs import SimulationRequest, model_units, symbolic_model
from nlobs.workflows.verdict import Verdict

__all__ = [
    "PLACEMENTS",
    "PinvDesignReport",
    "PinvWorkflowReport",
    "design_pinv_observer",
    "design_pinv_report",
    "simulate_pinv",
]


# ----------------------------------------------------------------------------- simulation
def simulate_pinv(
    model: SymbolicModel,
    x0: ArrayLike,
    x_hat0: ArrayLike,
    duration: float,
    *,
    dt: float = 1e-3,
    u: InputLike = None,
    k: ArrayLike | None = None,
    theta: float = DEFAULT_THETA,
    placement: Placement = "powers",
    region: Box | None = None,
    pinv: Literal["symbolic", "numeric"] = "symbolic",
    parameters: Mapping[str, float] | None = None,
    measurements: MeasurementGroup | Sequence[MeasurementGroup] | None = None,
    seed: int | None = None,
    report: PinvDesignReport | None = None,
    saturation: bool = False,
) -> SimulationResult:
    """Simulate ``model`` with its Moore–Penrose observer (7)/(17).

    With ``report`` the simulation uses :attr:`PinvDesignReport.observer` (the observer the
    report describes; ``k``, ``theta``, ``placement``, ``region`` and ``pinv`` are then not used).
    Without it the observer is built as :func:`design_pinv_report` builds it (``k`` overrides
    ``(theta, placement)``; A5 failing only warns). The plant is ``model.compile(parameters)``;
    ``u``, ``measurements``, ``seed`` are passed to :func:`nlobs.simulate.simulate`
    (``u=None`` for a plant without inputs). ``saturation``: the observer saturated on its region outside it
    (:meth:`~nlobs.observers.pinv.PinvObserver.with_saturation`, Khalil's form of
    :mod:`nlobs.observers.pinv`; the same as (7) while the estimate is in the region); ``False``
    (default here): (7) as printed.

    Parameters
    ----------
    model : SymbolicModel
        The plant, and the model the observer is built for.
    x0 : array_like, shape (n,) or (*batch, n)
        Initial plant state(s).
    x_hat0 : array_like, shape (n,) or (*batch, n)
        Initial estimate(s).
    duration : float
        Simulated time span (seconds).
    dt : float
        Integration step.
    u : None, array_like, callable or SampledSignal
        Known input (``None`` for a plant without inputs).
    k, theta, placement, region, pinv : optional
        As in :func:`design_pinv_report` (not used with ``report``).
    parameters : mapping of str to float, optional
        Override values of the model's named parameters (plant, and observer without ``report``).
    measurements : MeasurementGroup or sequence of them, optional
        Sampled sensors (``None``: exact outputs).
    seed : int, optional
        State of the random generator of the measurement noise.
    report : PinvDesignReport, optional
        A design whose observer is used.
    saturation : bool
        Saturate the observer on its region outside it.

    Returns
    -------
    SimulationResult

    Examples
    --------
    The shipped pendulum (``Φ`` the identity, so ``Q⁺ = Q⁻¹ = I``) with a constant torque, two runs from rest
    estimates: ``θ = 3`` (``powers`` placement) is the gain ``k = [12, 27]`` of the roots ``−3, −9`` of (10),
    and the numeric pseudo-inverse gives the symbolic one's estimates to rounding:

    >>> import numpy as np
    >>> import nlobs
    >>> model = nlobs.load_model("pendulum")
    >>> x0 = [[0.5, 0.0], [1.0, 0.5]]
    >>> res = simulate_pinv(model, x0, [0.0, 0.0], 2.0, dt=1e-2, u=[0.3], theta=3.0)
    >>> res.x_hat.shape, np.round(res.error_norm[:, 0], 4).tolist(), bool(np.all(res.error_norm[:, -1] < 1e-3))
    ((2, 201, 2), [0.5, 1.118], True)
    >>> by_k = simulate_pinv(model, x0, [0.0, 0.0], 2.0, dt=1e-2, u=[0.3], k=[12.0, 27.0])
    >>> numeric = simulate_pinv(model, x0, [0.0, 0.0], 2.0, dt=1e-2, u=[0.3], theta=3.0, pinv="numeric")
    >>> bool(np.array_equal(by_k.x_hat, res.x_hat)), bool(np.allclose(numeric.x_hat, res.x_hat, atol=1e-12))
    (True, True)
    """
    obs = report.observer if report is not None else build_pinv_observer(model, k, theta, placement, region, parameters,
                                                                      pinv)
    if saturation:
        obs = obs.with_saturation(obs.region)
    return simulate(model.compile(parameters), obs, x0, x_hat0, duration=duration, dt=dt, u=u,
                    measurements=measurements, seed=seed)


# ----------------------------------------------------------------------------- the command
#: ``design`` of ``nlobs design pinv``.
PINV_COMMAND_DESIGN_JSON = joined_design_json("PinvCommandDesign", PINV_DESIGN_JSON)
#: ``simulation`` of ``nlobs design pinv`` with a simulation.
PINV_SIMULATION_JSON = ERROR_SUMMARY_JSON.extend("PinvSimulation", {
    **COVERAGE_JSON.fields,
}, optional=set(COVERAGE_JSON.fields))
#: ``nlobs design pinv``.
DESIGN_PINV_JSON = Record("DesignPinv", {
    "design": PINV_COMMAND_DESIGN_JSON,
    "simulation": PINV_SIMULATION_JSON,
}, optional={"simulation"}, description="Röbenack's Moore-Penrose observer (7), (17): design, the checks of A1-A6 "
                                        "and, when asked, a run checked against them.")


@dataclass(frozen=True, eq=False)
class PinvWorkflowReport:
    """What ``nlobs design pinv`` reports: the design, its simulation if asked for, the files written.

    Attributes
    ----------
    design : PinvDesignReport
        With the observer it built (:attr:`PinvDesignReport.observer`).
    simulation : SimulationResult or None
        That observer simulated against the model (``None`` without a request).
    request : SimulationRequest or None
    files : tuple of Path
        The plot (``pinv.png``) and trajectories (``pinv.npz``) written to ``request.out``.
    coverage : Coverage or None
        The hypotheses of Corollary 4.1 checked along the run (:func:`nlobs.simulate.coverage.monitor`):
        the state and the estimate in the region where A1 and A5 were verified, and the premise that the
        global A2–A4, A6 hold — not checked, so no run is covered (``certificate_covers_run`` false) and
        ``certificate_violations`` says where a run left the region.
    verdict : Verdict
        ``OK`` whenever the observer was built (A1 failing raises instead): A5 failing
        (``design.usable`` false) loses the guarantee of Theorem 4.1 but not the observer, and is
        reported in the design, not as a failure.
    message : str
        Empty.
    method_design : Design or None
        The method's :class:`~nlobs.methods.base.Design` (its ``to_dict()`` keys join ``design`` in
        :meth:`to_dict`).

    Examples
    --------
    The pendulum's observer simulated for 2 s: it converges, but no theorem covers the run (the global A2–A4,
    A6 are not checked, and the state leaves the region where A1 and A5 were verified), and the report says
    where:

    >>> from nlobs.workflows.inputs import SimulationRequest
    >>> rep = design_pinv_observer("pendulum", theta=3.0, simulate=SimulationRequest([0.5, 0.0], duration=2.0, dt=1e-2))
    >>> rep.verdict.value, rep.message, rep.simulation.x_hat.shape, rep.files
    ('ok', '', (201, 2), ())
    >>> sim = rep.to_dict()["simulation"]
    >>> sim["initial_error_norm"], bool(sim["final_error_norm"] < 1e-4), sim["certificate_covers_run"]
    (0.5, True, False)
    >>> sim["certificate_failed_premises"], sim["certificate_violations"][0]["hypothesis"]
    (['A2, A3, A4, A6 of Corollary 4.1: not checked (global conditions)'], 'state in the region [-1, 1] × [-1, 1]')
    """

    design: PinvDesignReport
    simulation: SimulationResult | None
    request: SimulationRequest | None
    files: tuple[Path, ...]
    verdict: Verdict = Verdict.OK
    message: str = ""
    coverage: Coverage | None = None
    method_design: Design | None = None

    def _simulation_dict(self) -> dict[str, Any]:
        assert self.simulation is not None
        out = error_summary(self.simulation, self.files)
        if self.coverage is not None:
            out.update(self.coverage.to_dict())
        return out

    def to_dict(self) -> dict[str, Any]:
        """``{"design": …, "simulation": …}``: the JSON report of ``nlobs design pinv``.

        ``simulation`` (present only when one ran) has ``final_error_norm``,
        ``initial_error_norm``, ``max_error_norm`` (largest over a batch), ``files`` and the monitor's
        ``certificate_covers_run``, ``certificate_covered_fraction``, ``certificate_violations`` (first per run:
        hypothesis, time, detail), ``certificate_failed_premises``, ``certificate_hypotheses``.
        """
        data: dict[str, Any] = {"design": PINV_COMMAND_DESIGN_JSON.emit({**self.design.to_dict(), **(
            {} if self.method_design is None else self.method_design.to_dict())})}
        if self.simulation is not None:
            data["simulation"] = PINV_SIMULATION_JSON.emit(self._simulation_dict())
        return DESIGN_PINV_JSON.emit(data)

    def summary(self) -> str:
        """The design report, where its defaults came from, then the simulation line and a ``wrote <file>`` line per file."""
        lines = [self.design.summary()]
        if self.method_design is not None:
            lines.append(f"  from the model file: {self.method_design.defaults_text() or 'nothing (every value given)'}; "
                         f"{self.method_design.status}")
        if self.simulation is not None and self.request is not None:
            line = error_line(error_summary(self.simulation, self.files), self.request.duration, self.request.dt)
            if self.coverage is not None:
                line += " (no theorem covers this run: " + "; ".join(self.coverage.reasons) + ")"
            lines.append(line)
            lines += [f"wrote {f}" for f in self.files]
        return "\n".join(lines)


def design_pinv_observer(
    model: str | Path | SymbolicModel,
    *,
    k: Sequence[float] | None = None,
    theta: float = DEFAULT_THETA,
    placement: Placement = "powers",
    box: Sequence[float] | Box | None = None,
    simulate: SimulationRequest | None = None,
    saturation: bool | None = None,
) -> PinvWorkflowReport:
    """Design the Moore–Penrose observer (7), (17), check A1 and A5, and simulate it if asked: ``nlobs design pinv``.

    Parameters
    ----------
    model : str, Path or SymbolicModel
        A model file, a shipped model name (:func:`nlobs.systems.modelfile.load_model`) or a
        loaded continuous-time input-affine model.
    k : sequence of float, optional
        The stacked gain vector (``Σ r_j`` numbers), instead of the high-gain design.
    theta, placement
        The high-gain design of the roots of (10) (:class:`~nlobs.synthesis.pinv_gain.HighGain`).
    box : sequence of float, or Box, optional
        Where A1 and A5 are checked: ``lo, hi`` for every state or ``lo1, hi1, …``; default
        ``[−1, 1]ⁿ``.
    simulate : SimulationRequest, optional
        Simulate the observer the design built (the same object, :attr:`PinvDesignReport.observer`)
        and write the plot and trajectories to ``simulate.out``.
    saturation : bool, optional
        Simulate the observer saturated on the region (``True``; the same as (7) while the
        estimate is in the region) or (7) as printed (``False``). Default: on when ``box`` is
        given, off on the default ``[−1, 1]ⁿ`` — the saturated form is right only while the *state* is in
        the region (Khalil's argument, :mod:`nlobs.observers.pinv`), which a region nobody chose need not
        hold: the README's ``isidori-146`` run leaves ``[−1, 1]⁴`` (``x4``) and ends with ‖e‖ = 13.8
        saturated against 0.31 as printed.

    Returns
    -------
    PinvWorkflowReport

    Raises
    ------
    ModelFileError, ModelError
        The model cannot be loaded, is linear, or is not input-affine.
    InvalidArgumentError, NonFiniteError, DimensionError
        A bad option (``placement``, ``k``, the sizes of the simulation's vectors).
    BoxError
        ``box`` does not make a box of the state space.
    AssumptionViolated
        A1 fails (no ``Q⁺`` exists on the region).
    OutputError
        ``simulate.out`` or a file in it cannot be written.
    SimulationDiverged
        The simulation diverged.
    StudyFailed
        The simulation stopped with another nlobs error; the cause is chained.

    Examples
    --------
    Röbenack's Example (21) (``isidori-146``): ``y = x4`` has relative degree 2 < n = 4, so ``Q`` is not
    square and the gain field (17) uses its Moore–Penrose inverse; A1 and A5 hold on
    ``[−1, 1]⁴`` and ``θ = 2`` places the roots of (10) at −4 and −2:

    >>> rep = design_pinv_observer("isidori-146")
    >>> d = rep.to_dict()["design"]
    >>> d["observability_rank"], [c["holds"] for c in d["checks"]], d["k"], d["roots"]
    (3, [True, True], [6.0, 8.0], [-4.0, -2.0])
    >>> d["pinv_gain"]  # l(x) = Q⁺(x) k, one entry per state: (26) of the paper
    [['2*k2*x1/(4*x1**2 + 1)'], ['k2/(4*x1**2 + 1)'], ['0'], ['k1']]

    Simulated (observer (7) as printed) on the pendulum, from a 0.5 rad initial error:

    >>> from nlobs.workflows.inputs import SimulationRequest
    >>> rep = design_pinv_observer("pendulum", theta=3.0, simulate=SimulationRequest([0.5, 0.0], duration=2.0))
    >>> sim = rep.to_dict()["simulation"]
    >>> sim["initial_error_norm"], bool(sim["final_error_norm"] < 1e-4)
    (0.5, True)
    """
    if placement not in PLACEMENTS:
        raise InvalidArgumentError(f"`placement`: expected 'powers' or 'multiple', got {placement!r}")
    pb = problem(model, box=box)  # the model file is read once, here
    m = symbolic_model(pb.model)
    # the simulation's vectors, size and output folder are checked before the design (which can take long)
    resolved = checked_request(simulate, m)
    design = PINV.design(pb, k=None if k is None else [float(v) for v in k], theta=theta, placement=placement)
    rep = design.report
    region_given = pb.sources.get("region") in ("given", "[simulation] box")
    if simulate is None:
        return PinvWorkflowReport(rep, None, None, (), method_design=design)
    assert resolved is not None
    x0, x_hat0, u = resolved
    res = run_study(lambda: simulate_pinv(m, x0, x_hat0, simulate.duration, dt=simulate.dt, u=u, report=rep,
                                          saturation=region_given if saturation is None else saturation))
    files = write_result(res, simulate.out, "pinv", model_units(model))
    box = rep.observer.region
    assert box is not None
    where = box.describe()
    missing = [h["name"] for h in rep.hypotheses if h["status"] == "not checked"]
    hyps: list[Any] = [InRegion(box.lower, box.upper, "state", where), InRegion(box.lower, box.upper, "estimate", where),
                       Premise(f"{', '.join(missing)} of Corollary 4.1", False, "not checked (global conditions)")]
    coverage = monitor(res, hyps, u=np.asarray(u, dtype=float), verified=rep.usable)
    return PinvWorkflowReport(rep, res, simulate, files, coverage=coverage, method_design=design)
