r"""The Luenberger observer with the gain of LMIs (14), (15) of Grip, Saberi & Johansen, as a method.

For a linear model ``ẋ = Ax + Bu``, ``y = Cx`` the observer is the Luenberger observer
``x̂̇ = Ax̂ + Bu + L(y − Cx̂)`` (:class:`nlobs.observers.luenberger.LuenbergerObserver`); for a nonlinear
model, the copy of the plant with constant output injection ``x̂̇ = f(x̂, u) + L(y − h(x̂))``
(:class:`~nlobs.observers.luenberger.ConstantGainObserver`) with the gain certified for its
linearisation at the problem's ``x0`` and ``u(0)``, which certifies nothing about the nonlinear plant.
``L`` is the analytic centre of LMIs (14), (15) with the poles of ``A − LC`` left of ``−α`` at
``γ = γn =`` :data:`LUENBERGER_GAMMA` (:func:`nlobs.synthesis.observer_gain.design_observer_gain`),
re-verified in NumPy whichever solver found it (Clarabel, then SCS).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from nlobs._validate import positive
from nlobs.checks import Check, CheckKind
from nlobs.errors import DesignError, DesignInfeasible
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
    uses_region: bool = False
    options: frozenset[str] = frozenset({"alpha"})

    def applies(self, problem: Problem) -> str | None:
        if problem.model.time.is_discrete:
            return ("the certified gain of LMIs (14), (15) is for continuous time; use ekf or ukf for a discrete "
                    "model")
        return None

    def design(self, problem: Problem, *, alpha: float | None = None) -> Design:
        """The gain of LMIs (14), (15) for the model (linear) or its linearisation at ``x0``, ``u(0)``.

        Raises
        ------
        ModelError
            A discrete-time model.
        DesignInfeasible
            No gain from either solver (the message says why).
        """
        from nlobs.errors import ModelError
        from nlobs.observers.luenberger import ConstantGainObserver, LuenbergerObserver
        from nlobs.synthesis.observer_gain import design_observer_gain
        from nlobs.synthesis.regions import HalfPlane
        from nlobs.systems.linearize import linearize

        why = self.applies(problem)
        if why is not None:
            raise ModelError(why)
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
        obs = LuenbergerObserver(lin, L) if linear else ConstantGainObserver(plant, L)
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
                        "the output is sampled and held (the certificate assumes a continuous output)"),
                Premise("exact measurement and model", exact,
                        f"{what} (the certificate bounds the decay of the error, not its noise floor)"))
        desc = (("Luenberger observer" if linear else "copy of the plant + L (y − h(x̂))")
                + f", L of LMIs (14), (15) for {'the model' if linear else 'the linearisation at x0'} "
                f"(Re λ < −{a:g}, analytic centre at γ = γn = {LUENBERGER_GAMMA:g}); poles of A − LC: "
                + ", ".join(f"{complex(p).real:.3g}{complex(p).imag:+.3g}j" for p in poles))
        parameters: dict[str, Any] = {"alpha": a, "gamma": LUENBERGER_GAMMA, "x0": x0.tolist(), "u0": u0.tolist()}
        sources = {"alpha": "given" if alpha is not None else "default", "x0": problem.sources.get("x0", "given")}
        return Design(self.name, obs, cert, premises, (), parameters, sources, desc, gain=L, failed=failed,
                      hypotheses=hyps, report=cert, theorem="Grip, Saberi & Johansen, LMIs (14), (15)")


#: The Luenberger method of the registry.
LUENBERGER = LuenbergerMethod()
