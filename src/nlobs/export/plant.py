"""A plant's right-hand side as C: the simulation's plant stepped by its generated RK4.

:func:`generate_plant` prints a model's ``f`` (a compiled symbolic model's expressions, or a linear system's
matrices) as a module of the one C interface (:mod:`nlobs.export.program`) whose "observer state" is the plant
state: ``P_rhs`` is ``f(x, u)`` (``ẋ``, or ``x⁺`` for a discrete plant), ``P_step_stages`` the classical RK4
step with the input at its stage times, stage for stage as :func:`nlobs.simulate.integrators.rk4_step`.
:func:`compile_plant` compiles it into a :class:`CompiledPlant`, a plant model the loops take unchanged; the
loop of :func:`nlobs.simulate.simulate` steps it with one C call per step for every run of the batch (the
outputs, sensors, process noise and events stay the loop's own, so the random draws are the same and a
compiled plant's run equals the Python plant's to rounding).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nlobs._typing import Array
from nlobs.errors import InvalidArgumentError
from nlobs.export.compiled import CompiledObserver, load_library
from nlobs.export.compiler import Compiler
from nlobs.export.generate import default_prefix
from nlobs.export.kalman import model_c
from nlobs.export.program import CProgram
from nlobs.systems.codegen import BatchedFunction
from nlobs.systems.timebase import TimeBase

__all__ = ["CompiledPlant", "compile_plant", "generate_plant", "has_plant_generator"]


def has_plant_generator(plant: Any) -> bool:
    """Whether :func:`generate_plant` can print ``plant`` (a compiled symbolic model, or a linear system).

    Parameters
    ----------
    plant : PlantModel

    Returns
    -------
    bool
    """
    if hasattr(plant, "A") and hasattr(plant, "C") and not hasattr(plant, "_rhs"):
        return True
    return all(isinstance(fn, BatchedFunction) and bool(fn.arguments)
               for fn in (getattr(plant, "_rhs", None), getattr(plant, "_h", None)))


def generate_plant(plant: Any, prefix: str) -> CProgram:
    """The plant's ``f`` as a C module: ``P_rhs(t, x, u, y, dx)`` is ``f(x, u)`` (``y`` unused, ``n_y = 0``).

    Parameters
    ----------
    plant : SymbolicModel or linear system
        A compiled symbolic model (its expressions are printed) or a system with matrices ``A, B, C, D``.
    prefix : str
        A C identifier.

    Returns
    -------
    CProgram
        ``P_step`` (and ``P_step_stages`` for a continuous plant) is one classical RK4 step of ``f``; a discrete
        plant's ``P_step`` is ``x ← f(x, u)``.

    Raises
    ------
    InvalidArgumentError
        The plant has no expressions to print.
    ModelError
        An expression has no C99 form.
    """
    P = prefix
    n, m, p = int(plant.n), int(plant.m), int(plant.p)
    defs, note = model_c(plant, P, n, m, p, jacobians=False)
    discrete = bool(plant.time.is_discrete)
    body = defs + f"""
static int {P}_rhs_(double t, const double *z, const double *u, const double *y, double *dz)
{{
    (void)t;
    (void)y;
    {P}_f(z, u, dz);
    return {P.upper()}_OK;
}}
"""
    name = getattr(plant, "name", type(plant).__name__)
    what = "x+ = f(x, u)" if discrete else "dx/dt = f(x, u), one classical RK4 step per P_step"
    return CProgram(prefix=P, title=f"the plant {name}: {what}", n_z=n, n_x=n, n_u=m, n_y=0, discrete=discrete,
                    body=body, notes=(("model", note),),
                    dt=float(plant.time.dt) if discrete else None)


@dataclass(frozen=True, eq=False)
class CompiledPlant:
    """A plant model whose ``f`` runs in its generated C (module docstring); satisfies the plant protocol.

    Build it with :func:`compile_plant`. ``rhs`` and :meth:`step_stages` are the C module's; ``output`` and
    every name are the Python plant's.

    Attributes
    ----------
    plant : PlantModel
        The plant it was generated from.
    stepper : CompiledObserver
        The loaded module (its state is the plant state).
    """

    plant: Any
    stepper: CompiledObserver = field(repr=False)
    time: TimeBase = field(init=False)
    states: tuple[str, ...] = field(init=False)
    inputs: tuple[str, ...] = field(init=False)
    outputs: tuple[str, ...] = field(init=False)
    name: str = field(init=False)

    def __post_init__(self) -> None:
        for key in ("time", "states", "inputs", "outputs"):
            object.__setattr__(self, key, getattr(self.plant, key))
        label = getattr(self.plant, "name", None) or type(self.plant).__name__
        object.__setattr__(self, "name", f"{label} [C]")
        object.__setattr__(self, "_no_y", np.zeros(0))

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        """Pickled as the Python plant and the module's prefix; compiled again where it is unpickled."""
        return (_recompile_plant, (self.plant, self.stepper.program.prefix))

    @property
    def n(self) -> int:
        """States."""
        return len(self.states)

    @property
    def m(self) -> int:
        """Inputs."""
        return len(self.inputs)

    @property
    def p(self) -> int:
        """Outputs."""
        return len(self.outputs)

    def rhs(self, t: float, x: Array, u: Array) -> Array:
        """``f(x, u)`` of every run (``x⁺`` for a discrete plant), computed in C."""
        return self.stepper.rhs(t, x, u, self._no_y)  # type: ignore[attr-defined]

    def output(self, t: float, x: Array, u: Array) -> Array:
        """The Python plant's output ``h``."""
        return self.plant.output(t, x, u)  # type: ignore[no-any-return]

    def step_stages(self, t: float, x: Array, u0: Array, uh: Array, u1: Array, h: float) -> Array:
        """The state of every run at ``t + h``: one classical RK4 step of ``f`` with the input ``u0`` at ``t``,
        ``uh`` at ``t + h/2`` and ``u1`` at ``t + h`` (one C call for the batch).

        Parameters
        ----------
        t, h : float
            Start and length of the step.
        x : ndarray, shape (..., n)
            The state of every run.
        u0, uh, u1 : ndarray, shape (..., m)
            The input at the stage times.

        Returns
        -------
        ndarray, shape (..., n)
        """
        return self.stepper.step_stages(t, x, u0, uh, u1, self._no_y, h)  # type: ignore[attr-defined]


def compile_plant(plant: Any, *, prefix: str | None = None, compiler: Compiler | None = None) -> CompiledPlant:
    """``plant`` with its ``f`` in generated, compiled C (module docstring).

    Parameters
    ----------
    plant : SymbolicModel or linear system
        See :func:`generate_plant`.
    prefix : str, optional
        C prefix (default ``nlobs_plant_<class>``).
    compiler : Compiler, optional
        Default :func:`nlobs.export.compiler.find_compiler`.

    Returns
    -------
    CompiledPlant

    Raises
    ------
    InvalidArgumentError
        The plant has no expressions to print.
    CompilerError
        No C compiler, or it failed.
    """
    if hasattr(plant, "compile") and not hasattr(plant, "_rhs"):  # a symbolic model: its compiled form
        plant = plant.compile()
    if not has_plant_generator(plant):
        raise InvalidArgumentError(f"{getattr(plant, 'name', type(plant).__name__)}: a plant without expressions "
                                   "or matrices has no C generator")
    P = default_prefix(plant, prefix or f"nlobs_plant_{type(plant).__name__.lower()}")
    program = generate_plant(plant, P)
    return CompiledPlant(plant, CompiledObserver(plant, program, load_library(program, compiler=compiler)))


def _recompile_plant(plant: Any, prefix: str) -> CompiledPlant:
    """Unpickle a :class:`CompiledPlant`: :func:`compile_plant` once more (the library cache answers)."""
    return compile_plant(plant, prefix=prefix)
