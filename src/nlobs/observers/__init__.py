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
* :class:`ParticleFilter` — the bootstrap particle filter (Gordon, Salmond & Smith 1993; systematic resampling,
  Kitagawa 1996) for any plant, batched over runs and particles (``particle.py``);
* :class:`MHE` — moving-horizon estimation (Rao, Rawlings & Mayne 2003) with an arrival cost from an EKF
  covariance and bounds on the state, solved by IPOPT through CasADi (the extra ``nlobs[mhe]``) (``mhe.py``);
* :func:`rts_smooth`, :func:`smooth_run`, :class:`Smoothed` — the Rauch–Tung–Striebel smoother of the EKF and the
  UKF on a recorded run (Rauch, Tung & Striebel 1965; the unscented one of Särkkä 2008) (``smoother.py``);
* :class:`OutputPredictor` — any continuous observer on sampled outputs, with the inter-sample output
  predictor of Karafyllis & Kravaris (2009) (``sampled.py``);
* :class:`ImpulsiveObserver` — the copy of the plant corrected by a jump at each sample (Raff & Allgöwer
  2007) (``impulsive.py``).
"""

from typing import TYPE_CHECKING

from nlobs._lazy import lazy_exports

if TYPE_CHECKING:  # the names as static tools (type checkers, the API reference) see them
    from nlobs.observers.base import CorrectingObserver, DeferredEstimate, Diagnosing, Observer, SelfStepping
    from nlobs.observers.cascade import CascadeObserver
    from nlobs.observers.drift import DriftObserver, SingularObservabilityError
    from nlobs.observers.ekf import EKF
    from nlobs.observers.gaussian import FilterState
    from nlobs.observers.impulsive import ImpulsiveObserver
    from nlobs.observers.kalman import GaussianState, UnknownInputEKF, joseph_update
    from nlobs.observers.lipschitz import DiscreteLipschitzObserver
    from nlobs.observers.luenberger import ConstantGainObserver, LuenbergerObserver
    from nlobs.observers.mhe import MHE, MHEState
    from nlobs.observers.particle import ParticleFilter, ParticleState, systematic_resample
    from nlobs.observers.pinv import AssumptionWarning, ByrnesIsidoriObserver, PinvObserver
    from nlobs.observers.sampled import OutputPredictor, with_predictor
    from nlobs.observers.smoother import Smoothed, rts_smooth, smooth_run
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

#: Each public name and the module that holds it, imported on first use (a loop that needs the protocols of
#: ``base.py`` does not load every observer).
_EXPORTS = {
    "AssumptionWarning": "nlobs.observers.pinv",
    "ByrnesIsidoriObserver": "nlobs.observers.pinv",
    "CascadeObserver": "nlobs.observers.cascade",
    "ConstantGainObserver": "nlobs.observers.luenberger",
    "CorrectingObserver": "nlobs.observers.base",
    "DeferredEstimate": "nlobs.observers.base",
    "Diagnosing": "nlobs.observers.base",
    "DiscreteLipschitzObserver": "nlobs.observers.lipschitz",
    "DriftObserver": "nlobs.observers.drift",
    "EKF": "nlobs.observers.ekf",
    "FilterState": "nlobs.observers.gaussian",
    "GaussianState": "nlobs.observers.kalman",
    "GivenGain": "nlobs.observers.setvalued",
    "ImpulsiveObserver": "nlobs.observers.impulsive",
    "LuenbergerObserver": "nlobs.observers.luenberger",
    "MHE": "nlobs.observers.mhe",
    "MHEState": "nlobs.observers.mhe",
    "Observer": "nlobs.observers.base",
    "ParticleFilter": "nlobs.observers.particle",
    "ParticleState": "nlobs.observers.particle",
    "OutputPredictor": "nlobs.observers.sampled",
    "PinvObserver": "nlobs.observers.pinv",
    "Radii": "nlobs.observers.setvalued",
    "RadiusRecursion": "nlobs.observers.setvalued",
    "SelfStepping": "nlobs.observers.base",
    "SetValuedObserver": "nlobs.observers.setvalued",
    "SetValuedState": "nlobs.observers.setvalued",
    "SingularObservabilityError": "nlobs.observers.drift",
    "Smoothed": "nlobs.observers.smoother",
    "UKF": "nlobs.observers.ukf",
    "UnknownInputEKF": "nlobs.observers.kalman",
    "input_error_map": "nlobs.observers.setvalued",
    "joseph_update": "nlobs.observers.kalman",
    "rts_smooth": "nlobs.observers.smoother",
    "smooth_run": "nlobs.observers.smoother",
    "sound_radii": "nlobs.observers.setvalued",
    "systematic_resample": "nlobs.observers.particle",
    "with_predictor": "nlobs.observers.sampled",
}

__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
