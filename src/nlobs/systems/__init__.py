"""nlobs.systems — plants: models, time bases, model files, and the interconnected plant.

* :class:`~nlobs.systems.base.PlantModel` (the protocol every plant satisfies), the time bases
  :class:`Continuous` / :class:`Discrete`;
* :class:`SymbolicModel` (SymPy, compiled once), :class:`LinearSystem`, :class:`DiscreteUISystem`
  (the discrete-time model with unknown inputs of Khajenejad & Yong);
* model files: :func:`load_model` (a ``.toml`` file or a shipped name), :func:`shipped_models`;
* known input signals ``u(t)``: :class:`Constant`, :class:`Step`, :class:`Sine`, :class:`Chirp`,
  :class:`Piecewise`, :class:`Expression`, stacked by :class:`InputSignals`; read from text by
  :func:`parse_signal_spec`, :func:`signal_from_table` and :func:`read_signal_csv`;
* the plant of Grip, Saberi & Johansen: :class:`NonlinearSubsystem` (Σ₁ / Σ₁*),
  :class:`LinearSubsystem` (Σ₂), :class:`InterconnectedPlant` (:func:`interconnected_plant`).

Every module of nlobs imports from this package, the command line at start-up too, so the names
are imported on first use (PEP 562): ``import nlobs.systems.modelfile`` loads only what the
model files need.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from nlobs._lazy import lazy_exports

if TYPE_CHECKING:
    from nlobs.systems.base import PlantModel
    from nlobs.systems.constraints import StateBounds
    from nlobs.systems.controller import ControlLaw
    from nlobs.systems.discrete_ui import DiscreteUISystem
    from nlobs.systems.interconnected import (
        InterconnectedPlant,
        LinearSubsystem,
        NonlinearSubsystem,
        check_interconnection,
        interconnected_plant,
    )
    from nlobs.systems.linear import LinearSystem
    from nlobs.systems.modelfile import load_model, resolve_model, shipped_models
    from nlobs.systems.signals import (
        Chirp,
        Constant,
        Expression,
        InputSignals,
        Piecewise,
        Signal,
        Sine,
        Step,
        parse_signal_spec,
        read_signal_csv,
        signal_from_table,
    )
    from nlobs.systems.symbolic import CompiledModel, SymbolicModel
    from nlobs.systems.timebase import Continuous, Discrete, TimeBase

#: Names imported on first use, and the module that holds each.
_LAZY: dict[str, str] = {
    "PlantModel": "nlobs.systems.base",
    "StateBounds": "nlobs.systems.constraints",
    "ControlLaw": "nlobs.systems.controller",
    "DiscreteUISystem": "nlobs.systems.discrete_ui",
    **dict.fromkeys(("InterconnectedPlant", "LinearSubsystem", "NonlinearSubsystem", "check_interconnection",
                     "interconnected_plant"), "nlobs.systems.interconnected"),
    "LinearSystem": "nlobs.systems.linear",
    **dict.fromkeys(("load_model", "resolve_model", "shipped_models"), "nlobs.systems.modelfile"),
    **dict.fromkeys(("Chirp", "Constant", "Expression", "InputSignals", "Piecewise", "Signal", "Sine", "Step",
                     "parse_signal_spec", "read_signal_csv", "signal_from_table"), "nlobs.systems.signals"),
    **dict.fromkeys(("CompiledModel", "SymbolicModel"), "nlobs.systems.symbolic"),
    **dict.fromkeys(("Continuous", "Discrete", "TimeBase"), "nlobs.systems.timebase"),
}

__all__ = [
    "Chirp",
    "CompiledModel",
    "Constant",
    "Continuous",
    "ControlLaw",
    "Discrete",
    "DiscreteUISystem",
    "Expression",
    "InputSignals",
    "InterconnectedPlant",
    "LinearSubsystem",
    "LinearSystem",
    "NonlinearSubsystem",
    "Piecewise",
    "PlantModel",
    "Signal",
    "Sine",
    "StateBounds",
    "Step",
    "SymbolicModel",
    "TimeBase",
    "check_interconnection",
    "interconnected_plant",
    "load_model",
    "parse_signal_spec",
    "read_signal_csv",
    "resolve_model",
    "shipped_models",
    "signal_from_table",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
