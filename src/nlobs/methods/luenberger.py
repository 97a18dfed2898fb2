r"""The Luenberger observer with the gain of LMIs (14), (15) of Grip, Saberi & Johansen, as a method.

For a linear model ``ẋ = Ax + Bu``, ``y = Cx`` the observer is the Luenberger observer
``x̂̇ = Ax̂ + Bu + L(y − Cx̂)`` (:class:`nlobs.observers.luenberger.LuenbergerObserver`); for a nonlinear
model, the copy of the plant with constant output injection ``x̂̇ = f(x̂, u) + L(y − h(x̂))``
(:class:`~nlobs.observers.luenberger.ConstantGainObserver`) with the gain certified for its
linearisation at the problem's ``x0`` and ``u(0)``, which certifies nothing about the nonlinear plant.
``L`` is the analytic centre of LMIs (14), (15) with the poles of ``A − LC`` left of ``−α`` at
``γ = γn =`` :data:`LUENBERGER_GAMMA` (:func:`nlobs.synthesis.observer_gain.design_observer_gain`),
re-verified in NumPy whichever solver found it (Clarabel, then SCS). This is ``tuning="decay"``, the default
without ``[sensors]``.

With ``[sensors]`` the default is ``tuning="sensors"``: the Thau observer (the same copy of the plant) with the
gain of the vertex LMIs of the Jacobian box on the region (:mod:`nlobs.synthesis.thau_gain`), which certify
the nonlinear error on the region itself, at the decay rate whose certified RMS bound under the file's sensor
periods and noise is smallest (:mod:`nlobs.methods.sensor_design`, :mod:`nlobs.synthesis.sampled_data`). The
observer then runs on the samples through the inter-sample output predictor of Karafyllis & Kravaris
(``sampling="predictor"``, :mod:`nlobs.observers.sampled`), or is the impulsive observer of Raff & Allgöwer that
jumps at each sample (``"impulsive"``, :mod:`nlobs.observers.impulsive`, for sensors slow against the plant);
by default the one with the smaller certified bound. ``sampling="hold"`` injects the held sample (zero-order
hold, which no sampling certificate covers).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from nlobs._validate import one_of, positive
from nlobs.checks import Check, CheckKind
from nlobs.errors import DesignError, DesignInfeasible, InvalidArgumentError
from nlobs.methods.base import Design
from nlobs.methods.problem import Problem
from nlobs.simulate.coverage import Premise
from nlobs.systems.linear import LinearSystem

__all__ = ["DEFAULT_ALPHA", "LUENBERGER", "LUENBERGER_GAMMA", "LuenbergerMethod"]

#: ``γ`` and ``γn`` of LMIs (14), (15) for the Luenberger gain (the analytic centre of the region's LMIs at these).
LUENBERGER_GAMMA = 1e3
#: Decay rate of the region ``Re λ < −α`` unless given.
DEFAULT_ALPHA = 1.0


@dataclass(frozen=True)
class LuenbergerMethod:
    """The Luenberger observer (a linear model) or the constant-gain copy of a nonlinear plant (module docstring).

    Attributes
    ----------
    name : str
        The name in the registry.
    title : str
        The method with its paper and equation numbers.
    uses_region : bool
        Whether the design reads the problem's region.
    options : frozenset of str
        The options :meth:`design` takes.
    """

    name: str = "luenberger"
    title: str = "Luenberger gain of LMIs (14), (15) (Grip, Saberi & Johansen)"
    uses_region: bool = True  # the design for the sensors (the vertex LMIs) is made on the region
    options: frozenset[str] = frozenset({"alpha", "tuning", "sampling"})

    def applies(self, problem: Problem) -> str | None:
        if problem.model.time.is_discrete:
            return ("the certified gain of LMIs (14), (15) is for continuous time; use ekf or ukf for a discrete "
                    "model")
        return None

    def design(self, problem: Problem, *, alpha: float | None = None, tuning: str | None = None,
               sampling: str | None = None) -> Design:
        """The gain for the sensors (``tuning="sensors"``) or of LMIs (14), (15) (``"decay"``) (module docstring).

        Parameters
        ----------
        problem : Problem
            The model, its region, sensors and noise.
        alpha : float, optional
            The decay rate (default: chosen for the sensors; ``1`` with ``tuning="decay"``).
        tuning : {"sensors", "decay"}, optional
            Default ``"sensors"`` when the problem has sensors, else ``"decay"``.
        sampling : {"auto", "predictor", "impulsive", "hold"}, optional
            How a sampled output enters the observer: through the inter-sample output predictor, by the jumps of
            the impulsive observer (``tuning="sensors"``, one sensor group), or held; default ``"auto"``: the
            smaller certified bound of the first two (the predictor with ``tuning="decay"``).

        Raises
        ------
        ModelError
            A discrete-time model.
        DesignInfeasible
            No gain from either solver (the message says why).
        """
        tuning_ = one_of("`tuning`", tuning, ("sensors", "decay"), "sensors" if problem.sensors else "decay")
        sampling_ = one_of("`sampling`", sampling, ("auto", "predictor", "impulsive", "hold"), "auto")
        why = self.applies(problem)
        if why is not None:
            from nlobs.errors import ModelError

            raise ModelError(why)
        if sampling_ == "impulsive" and tuning_ != "sensors":
            raise InvalidArgumentError("`sampling`: the impulsive observer has its own gain: use it with "
                                       "tuning=sensors")
        if tuning_ == "sensors":
            try:
                return self._for_sensors(problem, alpha, sampling_)
            except DesignInfeasible as exc:
                d = self._decay(problem, alpha, sampling_)
                note = f"no gain certified under the sensors: {exc}"
                return dataclasses.replace(
                    d, warnings=(*d.warnings, note),
                    hypotheses=(*d.hypotheses, Premise("certified under the sensors", False, str(exc))),
                    parameters={**d.parameters, "tuning": "decay"},
                    sources={**d.sources, "tuning": "the design for the sensors failed"})
        return self._decay(problem, alpha, sampling_)

    def _for_sensors(self, problem: Problem, alpha: float | None, sampling: str) -> Design:
        """The Thau gain of the vertex LMIs chosen for the sensors (module docstring)."""
        from nlobs.methods.sensor_design import sampling_hypotheses, tune_thau
        from nlobs.observers.impulsive import ImpulsiveObserver
        from nlobs.observers.luenberger import ConstantGainObserver, LuenbergerObserver
        from nlobs.observers.sampled import with_predictor

        a = None if alpha is None else positive("`alpha`", alpha)
        tuned = tune_thau(problem, alpha=a, sampling={"auto": None, "hold": "predictor"}.get(sampling, sampling))
        impulsive = tuned.sampling == "impulsive"
        cert = tuned.certificate
        bound = cert if impulsive else cert.bound
        model = problem.model
        linear = isinstance(model, LinearSystem)
        plant = model if linear else model.compile()
        L = cert.gain
        predicted = not impulsive and sampling != "hold" and bool(problem.sensors)
        if impulsive:
            obs = ImpulsiveObserver(plant, L)
        else:
            inner = LuenbergerObserver(model, L) if linear else ConstantGainObserver(plant, L)
            obs = with_predictor(inner, plant, predicted)
        box = tuned.box
        premises = (
            Check.verdict("Jacobian bounds on the region", True,
                          f"∂F/∂x, ∂h/∂x sampled at {box.samples} points of {problem.region.describe()} and the "
                          f"input range, each varying entry widened 5 %: {len(box.varying)} varying entries, "
                          f"{box.n_vertices} vertices", kind=CheckKind.FUNCTION_CLASS, method="sampled",
                          key="jacobian_box"),
            *bound.checks)
        hyps = sampling_hypotheses(problem, bound if impulsive or predicted or not problem.sensors else None,
                                   what="a held sample (sampling=hold)")
        tmax = {g.name: t for g, t in zip(bound.groups, bound.t_max)}
        rms = bound.rms_after(problem.settle)
        if impulsive:
            desc = ("impulsive Thau observer (Raff & Allgöwer): copy of the plant between samples, x̂ += L (y − h(x̂)) "
                    f"at each sample, L and P(τ) of the clock-dependent LMIs on the region ({box.n_vertices} "
                    f"vertices) at α = {tuned.alpha:.4g}, chosen for the sensors")
        else:
            desc = (("Luenberger observer" if linear else "Thau observer: copy of the plant + L (y − h(x̂))")
                    + f", L of the vertex LMIs on the region ({box.n_vertices} vertices) at α = {tuned.alpha:.4g}, "
                    "chosen for the sensors" + (" (output predictor between samples)" if predicted else
                                                " (held samples)" if problem.sensors else ""))
        desc += f"; certified RMS ≤ {rms:.4g} after t = {problem.settle:g}"
        decay = cert.alpha if impulsive else cert.continuous.decay
        parameters: dict[str, Any] = {"alpha": tuned.alpha, "decay": decay, "tuning": "sensors",
                                      "sampling": "impulsive" if impulsive else ("hold" if sampling == "hold" else
                                                                                 "predictor"),
                                      "T_max": tmax, "rms_bound": rms}
        sources = {"alpha": "given" if alpha is not None else
                   f"the smallest certified RMS bound of {len({a for a, _ in tuned.candidates})} decay rates",
                   "tuning": "default with [sensors]" if problem.sensors else "given",
                   "sampling": "given" if sampling != "auto" else "the smaller certified bound of the output "
                                                                   "predictor and the impulsive observer"}
        return Design(self.name, obs, cert, premises, (), parameters, sources, desc, gain=L,
                      failed=() if cert.verified else tuple(c.summary() for c in cert.failed_checks),
                      hypotheses=hyps, report=cert, bound=bound,
                      theorem=("clock-dependent LMIs of the impulsive observer's hybrid error system (Raff & "
                               "Allgöwer 2007; Briat 2013) on the Jacobian box" if impulsive else
                               "vertex LMIs of the Jacobian box (Zemouche, Boutayeb & Bara 2008) with the sampled-"
                               "data bound of the inter-sample predictor (Karafyllis & Kravaris 2009; Fridman 2014; "
                               "Briat 2013)"),
                      details=tuple(bound.summary().splitlines()))

    def _decay(self, problem: Problem, alpha: float | None, sampling: str) -> Design:
        """The gain of LMIs (14), (15) for the model (linear) or its linearisation at ``x0``, ``u(0)``."""
        from nlobs.observers.luenberger import ConstantGainObserver, LuenbergerObserver
        from nlobs.observers.sampled import with_predictor
        from nlobs.synthesis.observer_gain import design_observer_gain
        from nlobs.synthesis.regions import HalfPlane
        from nlobs.systems.linearize import linearize

        a = DEFAULT_ALPHA if alpha is None else positive("`alpha`", alpha)
        model = problem.model
        linear = isinstance(model, LinearSystem)
        x0, u0 = np.asarray(problem.x0, dtype=float), problem.u0
        lin = model if linear else linearize(model, x0, u0)
        cert, failure = None, None
        for solver in ("clarabel", "scs"):  # the certificate is re-verified in NumPy whichever solver found it
            try:
                cert = design_observer_gain(lin.A, lin.C, np.eye(model.n), gamma=LUENBERGER_GAMMA,
                                            gamma_n=LUENBERGER_GAMMA, region=HalfPlane(a), solver=solver)
                break
            except DesignError as exc:
                failure = exc
        if cert is None:
            where = "the model" if linear else f"the linearisation at x0 = {x0.tolist()}"
            raise DesignInfeasible(f"no gain of LMIs (14), (15) with Re λ < −{a:g} for {where}: {failure}")
        L = cert.gain
        plant = model if linear else model.compile()
        predicted = sampling != "hold" and bool(problem.sensors)  # the impulsive form needs its own gain
        obs = with_predictor(LuenbergerObserver(lin, L) if linear else ConstantGainObserver(plant, L), plant,
                             predicted)
        poles = np.linalg.eigvals(lin.A - L @ lin.C)
        where = "the linear model" if linear else f"the linearisation at x0 = {x0.tolist()}, u = {u0.tolist()}"
        premises = (Check.verdict("the plant is the linear model the certificate is for", linear,
                                  "linear model" if linear else f"the certificate is for {where}; the plant is "
                                  "nonlinear", kind=CheckKind.STRUCTURAL, key="linear"),)
        failed = () if cert.verified else ("the gain's certificate failed: "
                                           + "; ".join(k.summary() for k in cert.failed_checks),)
        exact, what = problem.exact
        hyps = (Premise("the plant is the linear model the certificate is for", linear,
                        f"the certificate is for {where}; the plant is nonlinear"),
                Premise("continuous measurement", not problem.sensors,
                        "the output is sampled (the certificate assumes a continuous output; tuning=sensors "
                        "states one for sampled outputs)"),
                Premise("exact measurement and model", exact,
                        f"{what} (the certificate bounds the decay of the error, not its noise floor)"))
        desc = (("Luenberger observer" if linear else "copy of the plant + L (y − h(x̂))")
                + f", L of LMIs (14), (15) for {'the model' if linear else 'the linearisation at x0'} "
                f"(Re λ < −{a:g}, analytic centre at γ = γn = {LUENBERGER_GAMMA:g}); poles of A − LC: "
                + ", ".join(f"{complex(p).real:.3g}{complex(p).imag:+.3g}j" for p in poles))
        if predicted:
            desc += "; output predictor between samples"
        parameters: dict[str, Any] = {"alpha": a, "gamma": LUENBERGER_GAMMA, "x0": x0.tolist(), "u0": u0.tolist()}
        if problem.sensors:
            parameters.update(tuning="decay", sampling="predictor" if predicted else "hold")
        sources = {"alpha": "given" if alpha is not None else "default", "x0": problem.sources.get("x0", "given")}
        return Design(self.name, obs, cert, premises, (), parameters, sources, desc, gain=L, failed=failed,
                      hypotheses=hyps, report=cert, theorem="Grip, Saberi & Johansen, LMIs (14), (15)")


#: The Luenberger method of the registry.
LUENBERGER = LuenbergerMethod()
