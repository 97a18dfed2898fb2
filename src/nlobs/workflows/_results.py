"""Shared pieces of the design workflows: the output folder, the simulation summary and its files."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from nlobs._io import prepare_output_dir
from nlobs._schema import NUMBER, STRING, Record, array
from nlobs._typing import Array
from nlobs.errors import NlobsError, OutputError, SimulationDiverged, StudyFailed
from nlobs.simulate.result import SimulationResult
from nlobs.simulate.integrators import RK4_REAL_LIMIT

if TYPE_CHECKING:
    from nlobs.systems.symbolic import SymbolicModel
    from nlobs.workflows.inputs import SimulationRequest

T = TypeVar("T")


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def prepare_out(out: Path | None) -> None:
    """Create the output folder (and its parents) and check a file can be written in it, before any design.

    Raises
    ------
    OutputError
        The folder cannot be created or written (a file of that name, no permission, a read-only
        file system, a full disk); nothing in it is touched.
    """
    if out is None:
        return
    try:
        existed = out.is_dir()
    except OSError:  # a name too long for the file system: is_dir() raises instead of answering
        existed = False
    try:
        prepare_output_dir(out)
    except OSError as exc:
        what = "write in" if existed else "create"
        raise OutputError(f"{out}: cannot {what} the folder ({_reason(exc)})") from exc


def checked_request(request: SimulationRequest | None, model: SymbolicModel) -> tuple[Array, Array, Array] | None:
    """The simulation's ``(x0, x_hat0, u)`` checked against ``model`` and its output folder prepared,
    before any design (which can take long); ``None`` without a request."""
    if request is None:
        return None
    resolved = request.resolved(model.n, model.m, model.name, model.p)
    prepare_out(request.out)
    return resolved


def run_study(run: Callable[[], T]) -> T:
    """``run()``, a simulation of a designed observer: a divergence stays :class:`SimulationDiverged`,
    any other typed error becomes :class:`StudyFailed` (the design was fine, its simulation was not)."""
    try:
        return run()
    except SimulationDiverged:
        raise
    except NlobsError as exc:
        raise StudyFailed(str(exc)) from exc




def explain_divergence(exc: SimulationDiverged | StudyFailed, fastest: float, dt: float,
                       saturation: bool) -> SimulationDiverged | StudyFailed:
    """``exc`` with what is known about its cause: whether ``dt`` resolves the gain's fastest pole, and peaking.

    ``fastest`` is ``max |λ|`` over the observer's error dynamics (``A_s − K C_s`` of (3.5), ``A − k cᵀ``
    of (9a)). A smaller step is advised only where ``dt |λ|`` exceeds the RK4 stability limit (then it
    is known to be needed); otherwise the message says that the step resolves the gain and the cause is
    the high-gain transient (peaking) taking the estimate out of the region, and names
    ``saturation`` when the run had it off.
    """
    ratio = dt * fastest
    if ratio > RK4_REAL_LIMIT:
        detail = (f"dt·|λ|max = {ratio:.3g} > {RK4_REAL_LIMIT} for the gain's fastest pole |λ| = {fastest:.4g}: RK4 is "
                  f"unstable at this step, use `dt` below {RK4_REAL_LIMIT / fastest:.3g}")
    else:
        detail = (f"the step resolves the gain (dt·|λ|max = {ratio:.3g} ≤ {RK4_REAL_LIMIT}), so a smaller `dt` is not "
                  "known to help; the high-gain transient (peaking) took the estimate out of the region where the "
                  "design was checked" + ("" if saturation else " (`saturation` is off; with it on, the observer is "
                                                                "saturated outside the region)"))
    if isinstance(exc, SimulationDiverged):
        return SimulationDiverged(exc.time, exc.which, exc.state, detail)
    return StudyFailed(f"{exc}; {detail}")


def write_result(result: SimulationResult, out: Path | None, stem: str,
                 units: Mapping[str, str] | None = None) -> tuple[Path, ...]:
    """Write ``<stem>.png`` (the plot, axes labelled with ``units``, a model file's ``units`` table) and
    ``<stem>.npz`` (the trajectories) to ``out``, each atomically.

    Returns the paths written (empty when ``out`` is ``None``).

    Raises
    ------
    OutputError
        A file cannot be written (a file that was there before is left as it was).
    """
    if out is None:
        return ()
    prepare_out(out)
    png, npz = out / f"{stem}.png", out / f"{stem}.npz"
    try:
        result.plot(png, units=units)
    except OSError as exc:
        raise OutputError(f"{png}: {_reason(exc)}") from exc
    try:
        saved = result.save(npz)
    except OSError as exc:
        raise OutputError(f"{npz}: {_reason(exc)}") from exc
    return (png, saved)


#: The keys of :func:`error_summary`.
ERROR_SUMMARY_JSON = Record("ErrorSummary", {
    "final_error_norm": NUMBER, "initial_error_norm": NUMBER, "max_error_norm": NUMBER.about("largest over a batch"),
    "files": array(STRING)})


def error_summary(result: SimulationResult, files: tuple[Path, ...]) -> dict[str, Any]:
    """``final_error_norm``, ``initial_error_norm``, ``max_error_norm`` (largest over a batch) and ``files``."""
    e = result.error_norm
    return ERROR_SUMMARY_JSON.emit({
        "final_error_norm": float(np.max(e[..., -1])), "initial_error_norm": float(np.max(e[..., 0])),
        "max_error_norm": float(np.max(e)), "files": [str(f) for f in files]})


def error_line(summary: dict[str, Any], duration: float, dt: float) -> str:
    """The first line the CLI prints about a simulation."""
    return (f"simulation ({duration:g} s, dt = {dt:g}): ‖e(0)‖ = {summary['initial_error_norm']:.4g}, "
            f"‖e(T)‖ = {summary['final_error_norm']:.4g}, max ‖e‖ = {summary['max_error_norm']:.4g}")
