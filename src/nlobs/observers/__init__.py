"""Observers: one module per method, every estimator satisfying :class:`nlobs.observers.base.Observer`.

* :class:`CascadeObserver` — Grip, Saberi & Johansen, (9)–(10) / (17)–(18) (``cascade.py``);
* :class:`DriftObserver` — Dalla Mora, Germani & Manes, (3.1) (``drift.py``);
* :class:`PinvObserver`, :class:`ByrnesIsidoriObserver` — Röbenack, (7) with the gains (17) and (8)
  (``pinv.py``);
* :class:`LuenbergerObserver`, :class:`ConstantGainObserver` (a nonlinear copy with constant gain),
  :class:`DiscreteLipschitzObserver`, :class:`UnknownInputEKF` and the
  set-valued observer of Khajenejad & Yong (``luenberger.py``, ``lipschitz.py``, ``kalman.py``,
  ``setvalued.py``);
* :class:`EKF` and :class:`UKF` — the extended (Jazwinski) and unscented (Särkkä; Julier & Uhlmann)
  Kalman filters for any plant, continuous-discrete or discrete (``ekf.py``, ``ukf.py``, their shared
  state and correction in ``gaussian.py``);
* :class:`OutputPredictor` — any continuous observer on sampled outputs, with the inter-sample output
  predictor of Karafyllis & Kravaris (2009) (``sampled.py``);
* :class:`ImpulsiveObserver` — the copy of the plant corrected by a jump at each sample (Raff & Allgöwer
  2007) (``impulsive.py``).
"""

from nlobs.observers.base import CorrectingObserver, DeferredEstimate, Diagnosing, Observer, SelfStepping
from nlobs.observers.cascade import CascadeObserver
from nlobs.observers.drift import DriftObserver, SingularObservabilityError
from nlobs.observers.ekf import EKF
from nlobs.observers.gaussian import FilterState
from nlobs.observers.impulsive import ImpulsiveObserver
from nlobs.observers.kalman import GaussianState, UnknownInputEKF, joseph_update
from nlobs.observers.lipschitz import DiscreteLipschitzObserver
from nlobs.observers.luenberger import ConstantGainObserver, LuenbergerObserver
from nlobs.observers.pinv import AssumptionWarning, ByrnesIsidoriObserver, PinvObserver
from nlobs.observers.sampled import OutputPredictor, with_predictor
from nlobs.observers.setvalued import (
    GivenGain,
    Radii,
    RadiusRecursion,
    SetValuedObserver,
    SetValuedState,
    input_error_map,
    sound_radii,
)
from nlobs.observers.ukf import UKF

__all__ = [
    "AssumptionWarning",
    "ByrnesIsidoriObserver",
    "CascadeObserver",
    "ConstantGainObserver",
    "CorrectingObserver",
    "DeferredEstimate",
    "Diagnosing",
    "DiscreteLipschitzObserver",
    "DriftObserver",
    "EKF",
    "FilterState",
    "GaussianState",
    "GivenGain",
    "ImpulsiveObserver",
    "LuenbergerObserver",
    "Observer",
    "OutputPredictor",
    "PinvObserver",
    "Radii",
    "RadiusRecursion",
    "SelfStepping",
    "SetValuedObserver",
    "SetValuedState",
    "SingularObservabilityError",
    "UKF",
    "UnknownInputEKF",
    "input_error_map",
    "joseph_update",
    "sound_radii",
    "with_predictor",
]
