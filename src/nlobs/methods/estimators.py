r"""The particle filter and moving-horizon estimation as methods (:data:`PF`, :data:`MHE`): tuned from the model file.

The estimators users compare a certified observer against, besides the EKF and UKF
(:mod:`nlobs.methods.kalman`), tuned by the same rule (:func:`~nlobs.methods.kalman.filter_tuning`: ``R`` from the
sensors, ``Q`` the process noise, ``P0 = diag(p0_std²)``) and given the file's ``[constraints]``:

* ``pf`` — the bootstrap particle filter (Gordon, Salmond & Smith 1993) with systematic resampling (Kitagawa
  1996) and roughening, its particles kept inside the bounds (:class:`nlobs.observers.particle.ParticleFilter`);
* ``mhe`` — moving-horizon estimation over the last samples with an arrival cost from an EKF covariance (Rao,
  Rawlings & Mayne 2003), the bounds as constraints of its program, solved by IPOPT through CasADi (the optional
  extra ``nlobs[mhe]``; :class:`nlobs.observers.mhe.MHE`).

Like the Kalman filters they carry no certificate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._validate import as_count, positive
from nlobs.errors import ModelError, NlobsError
from nlobs.methods.base import Design
from nlobs.methods.kalman import EKF as EKF_METHOD
from nlobs.methods.kalman import filter_tuning
from nlobs.methods.problem import Problem
from nlobs.systems.symbolic import SymbolicModel

__all__ = ["MHE", "PF", "MovingHorizonMethod", "ParticleMethod"]

#: Particles of the particle filter unless given.
DEFAULT_PARTICLES = 1000
#: Samples in the moving horizon unless given.
DEFAULT_HORIZON = 10


def _bounds(problem: Problem) -> dict[str, Any]:
    b = problem.scenario.constraints
    return {} if b is None else {"lower": b.lower, "upper": b.upper}


def _text(std: Any) -> str:
    return str([float(f"{v:.4g}") for v in np.asarray(std)])


@dataclass(frozen=True)
class ParticleMethod:
    """The bootstrap particle filter tuned from the problem (module docstring).

    Attributes
    ----------
    name : str
        ``"pf"``.
    title : str
    uses_region : bool
    options : frozenset of str
        ``filter_q``, ``p0_std``, ``particles``, ``seed`` (of its own draws), ``roughening``.

    Examples
    --------
    >>> from nlobs.methods.problem import problem
    >>> d = PF.design(problem("cartpole"), particles=200)
    >>> d.observer.particles, d.certificate is None, d.description.split(",")[0]
    (200, True, 'continuous-discrete bootstrap particle filter')
    """

    name: str = "pf"
    title: str = "bootstrap particle filter (Gordon, Salmond & Smith; systematic resampling, roughening)"
    uses_region: bool = False
    options: frozenset[str] = frozenset({"filter_q", "p0_std", "particles", "seed", "roughening"})

    def applies(self, problem: Problem) -> str | None:
        """Why the filter does not apply (no noisy sensors), else ``None``."""
        why = EKF_METHOD.applies(problem)
        return None if why is None else why.replace("a Kalman filter", "a particle filter")

    def design(self, problem: Problem, *, filter_q: ArrayLike | None = None, p0_std: ArrayLike | None = None,
               particles: int = DEFAULT_PARTICLES, seed: int = 0, roughening: float = 0.2) -> Design:
        """The particle filter for the problem's sensors and noise.

        Parameters
        ----------
        problem : Problem
        filter_q, p0_std : array_like, optional
            As the Kalman filters' (:func:`~nlobs.methods.kalman.filter_tuning`).
        particles : int
            Particles per run.
        seed : int
            Seed of the filter's own draws (propagation noise, resampling, roughening).
        roughening : float
            Roughening constant (Gordon, Salmond & Smith 1993, §IV).

        Returns
        -------
        Design

        Raises
        ------
        ModelError
            No sensors, or a singular ``R``.
        InvalidArgumentError
            A bad option.
        """
        from nlobs.observers.particle import ParticleFilter

        why = self.applies(problem)
        if why is not None:
            raise ModelError(why)
        Q, q_text, R, std = filter_tuning(problem, filter_q, p0_std)
        count = as_count("`particles`", particles, minimum=2)
        model = problem.model
        plant = model.compile() if isinstance(model, SymbolicModel) else model
        try:
            obs = ParticleFilter(plant, Q, R, np.diag(std**2), particles=count, seed=int(seed),
                                 roughening=positive("`roughening`", roughening, allow_zero=True), name="PF",
                                 **_bounds(problem))
        except NlobsError as exc:
            raise ModelError(str(exc)) from None
        mode = "discrete" if model.time.is_discrete else "continuous-discrete"
        desc = (f"{mode} bootstrap particle filter, {count} particles, systematic resampling below half the "
                f"particles effective, roughening {roughening:g}, Q = {q_text}, R from the sensors, P0 = "
                f"diag({_text(std)}²)")
        if problem.scenario.constraints is not None:
            desc += "; particles kept inside the [constraints]"
        return Design(self.name, obs, None, (), (), {"Q": Q, "R": R, "p0_std": std, "particles": count},
                      {"Q": q_text, "R": "[sensors]"}, desc)


@dataclass(frozen=True)
class MovingHorizonMethod:
    """Moving-horizon estimation tuned from the problem (module docstring).

    Attributes
    ----------
    name : str
        ``"mhe"``.
    title : str
    uses_region : bool
    options : frozenset of str
        ``filter_q``, ``p0_std``, ``horizon`` (samples in the window), ``substeps`` (RK4 steps per interval).

    Examples
    --------
    >>> from nlobs.methods.problem import problem
    >>> d = MHE.design(problem("cartpole"), horizon=5)
    >>> d.observer.horizon, d.description.split(",")[0]
    (5, 'moving-horizon estimation over the last 5 samples')
    """

    name: str = "mhe"
    title: str = "moving-horizon estimation (Rao, Rawlings & Mayne; IPOPT through CasADi)"
    uses_region: bool = False
    options: frozenset[str] = frozenset({"filter_q", "p0_std", "horizon", "substeps"})

    def applies(self, problem: Problem) -> str | None:
        """Why the estimator does not apply (no noisy sensors, or CasADi missing), else ``None``."""
        why = EKF_METHOD.applies(problem)
        if why is not None:
            return why.replace("a Kalman filter", "moving-horizon estimation")
        try:
            import casadi  # noqa: F401
        except ImportError:
            return "moving-horizon estimation needs CasADi with IPOPT: install the extra nlobs[mhe]"
        return None

    def design(self, problem: Problem, *, filter_q: ArrayLike | None = None, p0_std: ArrayLike | None = None,
               horizon: int = DEFAULT_HORIZON, substeps: int = 1) -> Design:
        """The moving-horizon estimator for the problem's sensors and noise.

        Parameters
        ----------
        problem : Problem
        filter_q, p0_std : array_like, optional
            As the Kalman filters' (:func:`~nlobs.methods.kalman.filter_tuning`).
        horizon : int
            Samples in the window.
        substeps : int
            RK4 steps of the model between two samples in the program.

        Returns
        -------
        Design

        Raises
        ------
        ModelError
            No sensors, a singular ``R``, or CasADi missing.
        InvalidArgumentError
            A bad option.
        """
        from nlobs.observers.mhe import MHE as MHEObserver

        why = self.applies(problem)
        if why is not None:
            raise ModelError(why)
        Q, q_text, R, std = filter_tuning(problem, filter_q, p0_std)
        W = as_count("`horizon`", horizon, minimum=1)
        model = problem.model
        try:
            obs = MHEObserver(model, Q, R, np.diag(std**2), horizon=W,
                              substeps=as_count("`substeps`", substeps, minimum=1), name="MHE", **_bounds(problem))
        except NlobsError as exc:
            raise ModelError(str(exc)) from None
        desc = (f"moving-horizon estimation over the last {W} samples, arrival cost from an EKF covariance, IPOPT "
                f"through CasADi, Q = {q_text}, R from the sensors, P0 = diag({_text(std)}²)")
        if problem.scenario.constraints is not None:
            desc += "; the [constraints] in its program"
        return Design(self.name, obs, None, (), (), {"Q": Q, "R": R, "p0_std": std, "horizon": W},
                      {"Q": q_text, "R": "[sensors]"}, desc)


#: The particle filter of the registry.
PF = ParticleMethod()
#: Moving-horizon estimation of the registry.
MHE = MovingHorizonMethod()
