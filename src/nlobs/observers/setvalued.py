r"""Simultaneous input and state set-valued observer (Khajenejad & Yong, Algorithm 1), batched.

:class:`SetValuedObserver` is Algorithm 1 under the one observer protocol (a discrete-time
:class:`~nlobs.observers.base.CorrectingObserver`): its state holds the centres and the radii,
``correct`` is the measurement part of one step (11), (12), (14), (15), (10) and ``rhs`` the time
update (13) with the radius recursion; :func:`run_setvalued` is a thin call of
:func:`nlobs.simulate.run_observer`. The centres follow the three-step recursion (10)-(15):

* UIE: ``d̂₁,k = M₁(z₁,k − C₁x̂_{k|k} − D₁u_k)`` (10), ``d̂₂,k−1 = M₂(z₂,k − C₂x̂_{k|k−1} − D₂u_k)`` (11),
  ``d̂_{k−1} = V₁d̂₁,k−1 + V₂d̂₂,k−1`` (12);
* TU: ``x̂_{k|k−1} = f(x̂_{k−1|k−1}) + Bu_{k−1} + G₁d̂₁,k−1`` (13), ``x̂⋆ = x̂_{k|k−1} + G₂d̂₂,k−1`` (14);
* MU: ``x̂_{k|k} = x̂⋆ + L̃(z₂,k − C₂x̂⋆ − D₂u_k)`` (15).

The radii do not depend on the data; :func:`sound_radii` computes them from
re-derived bounds (``docs/setvalued.md``), each step taking the smaller of

1. the Lyapunov bound: ``V̄_k = λ_eff V̄_{k−1} + c``, ``δ_k ≤ √(V̄_k/λ_min(P))``
   (from the certified condition (⋆) of :mod:`nlobs.synthesis.setvalued`), and
2. the triangle bound: ``δ_k ≤ θ δ_{k−1} + r + η`` with ``‖𝒜ζ + ℬπ‖ ≤ θ‖ζ‖ + r``
   from the class (e.g. ``θ = ‖𝒜‖ + L‖ℬ‖`` for Lipschitz ``φ``) and
   ``η ≥ ‖ℰω‖`` (which *includes* the ``(I − L̃C₂)ΦW w`` term the printed
   ``η`` of Theorem 5.13 omits),

and ``V̄_k ← min(V̄_k, λ_max(P) δ_k²)``. The input radius is
``δᵈ_{k−1} = θ_d δ_{k−1} + r_d + α`` with ``d̃_{k−1} = F_ζζ + F_ππ + F_ωω``.

Any other radius table (:class:`Radii`) can be given to the observer instead, e.g. Theorem 5.13 exactly
as printed (``printed_radii`` of the reading room, :mod:`nlobs.papers.khajenejad_yong_printed`), which
is not safe (measured in ``docs/setvalued.md``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray
from nlobs._validate import as_finite_array, positive, readonly
from nlobs.errors import DimensionError, InvalidArgumentError, NonFiniteError, SimulationDiverged
from nlobs.linear.transform_ui import UITransform, ui_transform
from nlobs.synthesis.setvalued import SetValuedDesign
from nlobs.systems.discrete_ui import DiscreteUISystem
from nlobs.systems.timebase import Discrete
from nlobs.observers.base import ToControl

__all__ = [
    "GivenGain",
    "Radii",
    "RadiusRecursion",
    "SetValuedObserver",
    "SetValuedState",
    "input_error_map",
    "sound_radii",
]


@dataclass(frozen=True)
class Radii:
    """Radius sequences of the state and (one-step-delayed) input balls.

    Attributes
    ----------
    state : ndarray, shape (K + 1,)
        ``δˣ_k`` for ``k = 0..K`` (``δˣ_0 = δ_0``).
    input : ndarray, shape (K,)
        ``δᵈ_{k−1}`` for ``k = 1..K`` (the ball of ``d_{k−1}``).
    state_steady, input_steady : float
        Limits of the bounds (``inf`` when they do not converge).
    label : str
        ``"sound"`` or ``"printed"``.

    Examples
    --------
    The sound radii (:func:`sound_radii`) of a design for the flexible-joint robot of Khajenejad & Yong, Sec. 6.1
    (a shipped model file), over 100 steps: ``K + 1`` state radii starting at ``δ₀``, ``K`` input radii, all
    below their limits:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.systems.modelfile import load_discrete_ui_model
    >>> system = load_discrete_ui_model("khajenejad-6-1").system
    >>> design = nlobs.design_setvalued(system, lam=0.98)
    >>> radii = sound_radii(system, design, 100)
    >>> radii.label, radii.state.shape, radii.input.shape, float(radii.state[0]) == system.delta0
    ('sound', (101,), (100,), True)
    >>> bool(np.all(radii.state <= radii.state_steady) and np.all(radii.input <= radii.input_steady))
    True

    Any other table can be reported by the observer instead (here constant radii, without a guarantee):

    >>> table = Radii(np.full(101, 25.0), np.full(100, 1000.0), 25.0, 1000.0, "constant")
    >>> observer = SetValuedObserver(system, design, radii=table)
    >>> z = observer.rhs(0.0, observer.correct(0.0, observer.init(system.x0), np.zeros(0), np.zeros(2), [True, True]),
    ...                  np.zeros(0), np.zeros(2))
    >>> z.radius, z.radius_input
    (25.0, 1000.0)
    """

    state: Array
    input: Array
    state_steady: float
    input_steady: float
    label: str


def _require_finite(t: float, k: int, parts: tuple[tuple[str, Array], ...]) -> None:
    """Raise :class:`~nlobs.errors.SimulationDiverged` naming step ``k`` when a quantity of Algorithm 1 overflowed.

    Finite but huge measurements (e.g. ``y = 1e308``) can overflow (10)–(15); the centres and the input
    estimate would then be NaN or ±inf, which no radius bounds.
    """
    for label, a in parts:
        ok = np.isfinite(a)
        if not ok.all():
            j = int(np.argmin(ok.reshape(-1, a.shape[-1]).all(axis=0)))
            raise SimulationDiverged(t, f"set-valued observer (Algorithm 1, step {k}: overflow from the measurement)",
                                     f"{label}[{j}]")


def _nrm(M: Array) -> float:
    """Spectral norm, ``0`` for an empty matrix."""
    return float(np.linalg.norm(M, 2)) if M.size else 0.0


def _noise_norm(blocks: tuple[Array, Array, Array], eta_v: float, eta_w: float) -> float:
    """A bound on ``‖E₁v_{k−1} + E_w w + E₂v_k‖`` over the noise balls (the smaller of two sound bounds)."""
    E1, Ew, E2 = blocks
    a = _nrm(E1) * eta_v + _nrm(Ew) * eta_w + _nrm(E2) * eta_v
    b = _nrm(np.hstack([E1, Ew, E2])) * math.sqrt(2 * eta_v**2 + eta_w**2)
    return min(a, b)


def input_error_map(system: DiscreteUISystem, design: SetValuedDesign) -> tuple[Array, Array, tuple[Array, Array, Array]]:
    r"""``(F_ζ, F_π, (F_{v,k−1}, F_w, F_{v,k}))`` with ``d̃_{k−1} = F_ζζ + F_ππ + F_ωω``.

    From (A.2), (A.7), (A.8) with ``Δf = Aζ + π``:
    ``F_ζ = −(V₁M₁C₁ + V₂M₂C₂(A − Ψ))``, ``F_π = −V₂M₂C₂``,
    ``F_ω = [(V₂M₂C₂G₁ − V₁)M₁T₁, −V₂M₂C₂W, −V₂M₂T₂]``.

    Raises :class:`~nlobs.errors.InvalidArgumentError` when ``design`` was certified for another system.

    Parameters
    ----------
    system : DiscreteUISystem
        The plant (8).
    design : SetValuedDesign
        A design certified for ``system``.

    Returns
    -------
    F_zeta : ndarray, shape (p, n)
        ``F_ζ``.
    F_pi : ndarray, shape (p, n)
        ``F_π``, the map of the nonlinearity's increment ``π``.
    F_omega : tuple of ndarray
        ``(F_{v,k−1}, F_w, F_{v,k})``, the maps of the noise ``v_{k−1}``, ``w`` and ``v_k``.

    Examples
    --------
    The flexible-joint robot of Khajenejad & Yong, Sec. 6.1 (a shipped model file; ``n = 4``, one unknown input,
    two outputs). Without noise, the input error of the first step of Algorithm 1 is ``F_ζ ζ + F_π π`` with
    ``ζ = x₀ − x̂_{0|0}`` and ``π = φ(x₀) − φ(x̂_{0|0})``:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.systems.modelfile import load_discrete_ui_model
    >>> system = load_discrete_ui_model("khajenejad-6-1").system
    >>> design = nlobs.design_setvalued(system, lam=0.98)
    >>> F_zeta, F_pi, F_omega = input_error_map(system, design)
    >>> F_zeta.shape, F_pi.shape, [F.shape for F in F_omega]
    ((1, 4), (1, 4), [(1, 2), (1, 4), (1, 2)])
    >>> d = np.array([[[0.5], [0.0]]])  # d₀ = 0.5
    >>> x, y = system.simulate([[0.3, -0.2, 0.4, 0.1]], d, np.zeros((1, 1, 4)), np.zeros((1, 2, 2)))
    >>> observer = SetValuedObserver(system, design)
    >>> u, fresh = np.zeros(0), np.array([True, True])
    >>> z0 = observer.correct(0.0, observer.init(system.x0), u, y[0, 0], fresh)
    >>> z1 = observer.correct(0.01, observer.rhs(0.0, z0, u, y[0, 0]), u, y[0, 1], fresh)
    >>> zeta = x[0, 0] - z0.x
    >>> pi = system.f(x[0, 0]) - system.f(z0.x) - system.A @ zeta
    >>> bool(np.allclose(0.5 - z1.d, F_zeta @ zeta + F_pi @ pi))
    True
    """
    design.certified_for.require(system)
    tr = design.transform
    V2M2C2 = tr.V2 @ tr.M2 @ tr.C2
    Fz = -(tr.V1 @ tr.M1 @ tr.C1 + V2M2C2 @ (system.A - tr.Psi))
    Fp = -V2M2C2
    Fw = ((V2M2C2 @ tr.G1 - tr.V1) @ tr.M1 @ tr.T1, -V2M2C2 @ system.W, -tr.V2 @ tr.M2 @ tr.T2)
    return Fz, Fp, Fw


@dataclass(frozen=True)
class RadiusRecursion:
    """The sound radius bounds of the module docstring as a one-step recursion (the observer's radii).

    ``advance(δˣ_{k−1}, V̄_{k−1})`` returns ``(δᵈ_{k−1}, δˣ_k, V̄_k)``; :func:`sound_radii` iterates it.
    Build it with :meth:`of`.

    Attributes
    ----------
    th, r : float
        Triangle bound ``‖𝒜ζ + ℬπ‖ ≤ θ‖ζ‖ + r`` of the closed loop (from the function class).
    eta : float
        Bound ``η ≥ ‖ℰω‖`` on the noise term of the error dynamics.
    thd, rd : float
        The same bound ``‖F_ζζ + F_ππ‖ ≤ θ_d‖ζ‖ + r_d`` for the input error (:func:`input_error_map`).
    alpha : float
        Bound ``α ≥ ‖F_ωω‖`` on the noise term of the input error.
    nA, nFz : float
        ``‖𝒜 P^{-1/2}‖`` and ``‖F_ζ P^{-1/2}‖``: the ellipsoidal bounds of the ``ζ`` parts from ``√V̄``.
    thp, rp : float
        Class bound of the ``ℬπ`` part alone (used with ``nA``).
    thdp, rdp : float
        Class bound of the ``F_ππ`` part alone (used with ``nFz``).
    lam_eff, c : float
        Contraction and offset of the Lyapunov bound ``V̄_k = λ_eff V̄_{k−1} + c`` (the design's).
    lmin, lmax : float
        Smallest and largest eigenvalues of the design's ``P``.

    Examples
    --------
    The recursion of a design for the flexible-joint robot of Khajenejad & Yong, Sec. 6.1 (a shipped model
    file), iterated by hand from ``δ₀``: the same radii as :func:`sound_radii`, and its Lyapunov bound contracts
    by the design's ``λ``:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.systems.modelfile import load_discrete_ui_model
    >>> system = load_discrete_ui_model("khajenejad-6-1").system
    >>> design = nlobs.design_setvalued(system, lam=0.98)
    >>> rec = RadiusRecursion.of(system, design)
    >>> rec.lam_eff, bool(rec.lmin <= rec.lmax)
    (0.98, True)
    >>> dx, V, state, inputs = system.delta0, rec.start(system.delta0), [system.delta0], []
    >>> for k in range(20):
    ...     dd, dx, V = rec.advance(dx, V)
    ...     state.append(dx)
    ...     inputs.append(dd)
    >>> radii = sound_radii(system, design, 20)
    >>> bool(np.allclose(state, radii.state) and np.allclose(inputs, radii.input))
    True
    >>> rec.steady() == (radii.state_steady, radii.input_steady)
    True
    """

    th: float
    r: float
    eta: float
    thd: float
    rd: float
    alpha: float
    nA: float
    nFz: float
    thp: float
    rp: float
    thdp: float
    rdp: float
    lam_eff: float
    c: float
    lmin: float
    lmax: float

    @classmethod
    def of(cls, system: DiscreteUISystem, design: SetValuedDesign) -> RadiusRecursion:
        """The constants of the recursion for a design certified for ``system``."""
        design.certified_for.require(system)
        fc = design.function_class
        evP = np.linalg.eigvalsh(design.P)
        Acl, Bcl, E = design.dynamics.split(design.gain)
        l, nw = system.l, system.n_w
        Eb = (E[:, :l], E[:, l:l + nw], E[:, l + nw:])
        eta = _noise_norm(Eb, system.eta_v, system.eta_w)
        th, r = fc.increment_bound(Acl, Bcl)
        Fz, Fp, Fw = input_error_map(system, design)
        thd, rd = fc.increment_bound(Fz, Fp)
        alpha = _noise_norm(Fw, system.eta_v, system.eta_w)
        # ellipsoidal variants: ‖F ζ‖ ≤ ‖F P^{-1/2}‖ √V̄ for the ζ part, the class bound for the π part
        w, Q = np.linalg.eigh(design.P)
        Pmh = Q @ np.diag(w ** -0.5) @ Q.T
        nA, nFz = float(np.linalg.norm(Acl @ Pmh, 2)), float(np.linalg.norm(Fz @ Pmh, 2))
        thp, rp = fc.increment_bound(np.zeros_like(Acl), Bcl)
        thdp, rdp = fc.increment_bound(np.zeros_like(Fz), Fp)
        return cls(th=th, r=r, eta=eta, thd=thd, rd=rd, alpha=alpha, nA=nA, nFz=nFz, thp=thp, rp=rp, thdp=thdp,
                   rdp=rdp, lam_eff=design.lam_eff, c=design.c, lmin=float(evP[0]), lmax=float(evP[-1]))

    def start(self, delta0: float) -> float:
        """``V̄_0 = λ_max(P) δ₀²``."""
        return self.lmax * delta0**2

    def advance(self, dx: float, V: float) -> tuple[float, float, float]:
        """``(δᵈ_{k−1}, δˣ_k, V̄_k)`` from ``(δˣ_{k−1}, V̄_{k−1})`` (module docstring)."""
        sv = math.sqrt(V)
        dd = min(self.thd * dx + self.rd, self.nFz * sv + self.thdp * dx + self.rdp) + self.alpha
        tri = min(self.th * dx + self.r, self.nA * sv + self.thp * dx + self.rp) + self.eta
        V = self.lam_eff * V + self.c
        dx_new = min(math.sqrt(V / self.lmin), tri)
        return dd, dx_new, min(V, self.lmax * dx_new**2)

    def steady(self) -> tuple[float, float]:
        """Limits of the state and input bounds (``inf`` when they do not converge)."""
        ss_lyap = math.sqrt(self.c / ((1 - self.lam_eff) * self.lmin)) if self.lam_eff < 1 else math.inf
        ss_tri = (self.r + self.eta) / (1 - self.th) if self.th < 1 else math.inf
        ssx = min(ss_lyap, ss_tri)
        return ssx, self.thd * ssx + self.rd + self.alpha


def sound_radii(system: DiscreteUISystem, design: SetValuedDesign, steps: int, *,
                delta0: float | None = None) -> Radii:
    """Re-derived radius bounds (module docstring; ``docs/setvalued.md``) for ``k = 0..steps``.

    Raises :class:`~nlobs.errors.InvalidArgumentError` when ``design`` was certified for another system
    (other matrices, class or constants, or larger noise bounds: :class:`~nlobs.synthesis.setvalued.CertifiedFor`).

    Parameters
    ----------
    system : DiscreteUISystem
        The plant (8).
    design : SetValuedDesign
        A design certified for ``system``.
    steps : int
        Number of steps ``K`` (``>= 0``).
    delta0 : float, optional
        Initial state radius ``δ₀ >= 0``; default ``system.delta0``.

    Returns
    -------
    Radii
        ``K + 1`` state radii, ``K`` input radii and their limits, labelled ``"sound"``.

    Examples
    --------
    A design for the flexible-joint robot of Khajenejad & Yong, Sec. 6.1 (a shipped model file): the state radius
    grows from ``δ₀ = 1`` towards its limit (the noise and the unknown input keep it away from zero); from an
    exactly known initial state (``delta0=0``) every radius is smaller, with the same limit:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.systems.modelfile import load_discrete_ui_model
    >>> system = load_discrete_ui_model("khajenejad-6-1").system
    >>> design = nlobs.design_setvalued(system, lam=0.98)
    >>> radii = sound_radii(system, design, 100)
    >>> exact = sound_radii(system, design, 100, delta0=0.0)
    >>> bool(np.all(np.diff(radii.state) >= 0)), bool(np.all(radii.state <= radii.state_steady))
    (True, True)
    >>> float(exact.state[0]), bool(np.all(exact.state <= radii.state)), exact.state_steady == radii.state_steady
    (0.0, True, True)
    >>> try:
    ...     sound_radii(system, design, -1)
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError steps: must be >= 0, got -1
    """
    rec = RadiusRecursion.of(system, design)
    K = int(steps)
    if K < 0:
        raise InvalidArgumentError(f"steps: must be >= 0, got {steps!r}")
    d0 = system.delta0 if delta0 is None else positive("delta0", delta0, allow_zero=True)
    dx = np.empty(K + 1)
    dd = np.empty(K)
    dx[0] = d0
    V = rec.start(d0)
    for k in range(1, K + 1):
        dd[k - 1], dx[k], V = rec.advance(dx[k - 1], V)
    ssx, ssd = rec.steady()
    return Radii(readonly(dx), readonly(dd), ssx, ssd, "sound")


@dataclass(frozen=True)
class GivenGain:
    """A gain ``L̃`` (``gain``) that was not designed by nlobs (e.g. a published one), with its transformation.

    Runs Algorithm 1's centres without a certificate; radii must then be supplied.

    Parameters
    ----------
    gain : ndarray, shape (n, l − p_H)
        The gain ``L̃`` of (15).
    transform : UITransform
        The transformation of the system (:meth:`for_system` builds both).

    Examples
    --------
    The flexible-joint robot of Khajenejad & Yong, Sec. 6.1 (a shipped model file) has ``l = 2`` outputs and
    ``p_H = 1``, so ``L̃`` is ``4 × 1``; given as a flat list (as a paper prints it; here the one nlobs designs),
    it drives the same centres as the certified design, but without radii:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.systems.modelfile import load_discrete_ui_model
    >>> model = load_discrete_ui_model("khajenejad-6-1")
    >>> system = model.system
    >>> design = nlobs.design_setvalued(system, lam=0.98)
    >>> given = GivenGain.for_system(system, design.gain.ravel().tolist())
    >>> given.gain.shape, given.transform.p_H
    ((4, 1), 1)
    >>> t = np.arange(51) * system.time.dt
    >>> d = model.signals["bounded"](t)
    >>> x, y = system.simulate([[0.3, -0.2, 0.4, 0.1]], d[None], np.zeros((1, 50, 4)), np.zeros((1, 51, 2)))
    >>> certified = nlobs.run_observer(SetValuedObserver(system, design), t, x_hat0=system.x0, y=y[0])
    >>> uncertified = nlobs.run_observer(SetValuedObserver(system, given), t, x_hat0=system.x0, y=y[0])
    >>> bool(np.array_equal(certified.x_hat, uncertified.x_hat))
    True
    >>> bool(np.isnan(uncertified.extras["radius_state"]).all())  # no certificate, no radii
    True
    """

    gain: Array
    transform: UITransform

    @classmethod
    def for_system(cls, system: DiscreteUISystem, L_tilde: ArrayLike) -> GivenGain:
        """``L̃`` (reshaped to ``(n, l − p_H)``) with the transformation of ``system``."""
        tr = ui_transform(system.G, system.C, system.H, system.D)
        L = as_finite_array("L_tilde", L_tilde).reshape(system.n, tr.C2.shape[0])
        return cls(readonly(L), tr)



@dataclass(frozen=True)
class SetValuedState:
    """State of :class:`SetValuedObserver` for a batch of runs (leading batch axes).

    Attributes
    ----------
    x : ndarray, shape (..., n)
        After :meth:`SetValuedObserver.correct` at step ``k``: the centre ``x̂_{k|k}``; after
        :meth:`SetValuedObserver.rhs`: the time update ``x̂_{k+1|k}`` of (13).
    d1 : ndarray, shape (..., p₁)
        ``d̂₁,k`` of (10), from the last measurement.
    d : ndarray, shape (..., p)
        ``d̂_{k−1}`` of (12), the centre of the input ball (NaN before the first step).
    k : int
        The step of the last measurement (``−1`` before the first one).
    corrected : bool
        Whether the measurement of step ``k`` has been taken (``x`` is ``x̂_{k|k}``).
    radius : float
        ``δˣ_k``.
    radius_input : float
        ``δᵈ_{k−1}`` (NaN before the first step).
    V : float
        The Lyapunov bound ``V̄_k`` of the sound recursion (NaN with given radii).

    Examples
    --------
    One step of Algorithm 1 by hand on the flexible-joint robot of Khajenejad & Yong, Sec. 6.1 (a shipped model
    file): ``init`` gives step ``−1``, the measurement of step 0 only computes ``d̂₁,0``, the time update moves
    to step 1 with the radii of step 1, and its measurement gives the first input estimate ``d̂₀``:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.systems.modelfile import load_discrete_ui_model
    >>> system = load_discrete_ui_model("khajenejad-6-1").system
    >>> observer = SetValuedObserver(system, nlobs.design_setvalued(system, lam=0.98))
    >>> u, y, fresh = np.zeros(0), np.zeros(2), np.array([True, True])
    >>> z = observer.init(system.x0)
    >>> z.k, z.corrected, z.radius, z.d.tolist()
    (-1, False, 1.0, [nan])
    >>> z = observer.correct(0.0, z, u, y, fresh)
    >>> z.k, z.corrected, z.x.shape, z.d1.shape
    (0, True, (4,), (1,))
    >>> z = observer.rhs(0.0, z, u, y)
    >>> z.k, z.corrected, bool(z.radius > system.delta0), bool(np.isfinite(z.radius_input))
    (1, False, True, True)
    >>> z = observer.correct(0.01, z, u, y, fresh)
    >>> z.k, z.corrected, z.d.tolist()  # all zero: the plant at rest with d = 0
    (1, True, [0.0])
    """

    x: Array
    d1: Array
    d: Array
    k: int
    corrected: bool
    radius: float
    radius_input: float
    V: float


@dataclass(frozen=True, eq=False)
class SetValuedObserver(ToControl):
    r"""Algorithm 1 (Khajenejad & Yong) as a discrete-time correcting observer: centres and radii.

    One step of Algorithm 1 is ``rhs`` (the time update (13) from ``k`` to ``k + 1``, with the
    radius recursion) followed by ``correct`` at the measurement of step ``k + 1`` ((11), (12), (14),
    (15), then (10)); at step 0 ``correct`` only computes ``d̂₁,0`` (10) from ``x̂_{0|0} = x̂0``. The
    estimate is the state centre; :meth:`diagnostics` records ``d_hat`` (``d̂_{k−1}``), ``radius_state``
    (``δˣ_k``) and ``radius_input`` (``δᵈ_{k−1}``).

    Parameters
    ----------
    system : DiscreteUISystem
        The plant (8).
    design : SetValuedDesign or GivenGain
        A design certified for ``system`` (:func:`nlobs.synthesis.setvalued.design_setvalued`), or a
        given ``L̃`` without certificate (then ``radii`` must be given for radii to be reported).
    radii : Radii, optional
        Radius sequences to report instead of the sound recursion (any table, e.g. the printed radii of
        ``nlobs.papers.khajenejad_yong_printed``); the run may not be longer than they are.
    lpv_weights : bool
        The input ``u`` carries the run-time LPV weights ``λ_k`` after the known inputs (Class III,
        Definition 2.4: (13) uses ``Σλᵢ Aᵢ``): required for a design certified at the vertices.
    name : str
        Label of the results.

    Notes
    -----
    The input is ``u_k = [u_k (m), λ_k (N, with lpv_weights)]``; the measurement is ``y_k`` (``l``),
    at every step (Algorithm 1 has no missing samples: a non-finite ``y`` raises).

    Examples
    --------
    The flexible-joint robot of Khajenejad & Yong, Sec. 6.1 (a shipped model file, with its unknown input
    ``d(t) = 5 sin 2t + 1 + sign(t − 1)``), over 100 steps without noise: the true state stays in the ball of
    radius ``δˣ_k`` around the estimate, the true input in the ball of radius ``δᵈ_{k−1}`` around ``d̂_{k−1}``
    (the design fixes ``λ`` instead of searching it, to keep the example short):

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.systems.modelfile import load_discrete_ui_model
    >>> model = load_discrete_ui_model("khajenejad-6-1")
    >>> system = model.system
    >>> observer = nlobs.SetValuedObserver(system, nlobs.design_setvalued(system, lam=0.98))
    >>> t = np.arange(101) * system.time.dt
    >>> d = model.signals["bounded"](t)
    >>> no_w, no_v = np.zeros((1, 100, system.n_w)), np.zeros((1, 101, system.l))
    >>> x, y = system.simulate([[0.3, -0.2, 0.4, 0.1]], d[None], no_w, no_v)
    >>> res = nlobs.run_observer(observer, t, x_hat0=system.x0, y=y[0], truth=x[0])
    >>> bool(np.all(res.error_norm <= res.extras["radius_state"]))
    True
    >>> d_error = np.linalg.norm(d[:-1] - res.extras["d_hat"][1:], axis=-1)  # d̂_{k−1} is recorded at k
    >>> bool(np.all(d_error <= res.extras["radius_input"][1:]))
    True
    """

    system: DiscreteUISystem
    design: SetValuedDesign | GivenGain
    radii: Radii | None = None
    lpv_weights: bool = False
    name: str = "set-valued observer"
    time: Discrete = field(init=False)
    _rec: RadiusRecursion | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.system, DiscreteUISystem):
            raise InvalidArgumentError(f"system: expected a DiscreteUISystem, got {type(self.system).__name__}")
        if isinstance(self.design, SetValuedDesign):
            self.design.certified_for.require(self.system, weights_given=self.lpv_weights)
        elif not isinstance(self.design, GivenGain):
            raise InvalidArgumentError(f"design: expected a SetValuedDesign or a GivenGain, got {type(self.design).__name__}")
        object.__setattr__(self, "time", self.system.time)
        rec = RadiusRecursion.of(self.system, self.design) if (
            self.radii is None and isinstance(self.design, SetValuedDesign)) else None
        object.__setattr__(self, "_rec", rec)

    @property
    def n_x(self) -> int:
        """The plant's state dimension."""
        return self.system.n

    @property
    def m(self) -> int:
        """Input channels: the known inputs, then the LPV weights when used."""
        return self.system.m + (self.system.function_class.vertices().shape[0] if self.lpv_weights else 0)

    def init(self, x_hat0: Array) -> SetValuedState:
        """The initial centre ``x̂_{0|0} = x̂0`` with radius ``δ₀`` (``system.delta0``)."""
        x = np.array(x_hat0, dtype=float)
        if x.ndim < 1 or x.shape[-1] != self.system.n:
            raise DimensionError(f"x_hat0: expected shape (..., {self.system.n}), got {x.shape}")
        B = x.shape[:-1]
        tr = self.design.transform
        d0 = float(self.system.delta0)
        if self.radii is not None:
            d0 = float(self.radii.state[0])
        V = self._rec.start(d0) if self._rec is not None else math.nan
        radius = d0 if (self._rec is not None or self.radii is not None) else math.nan
        return SetValuedState(x=x, d1=np.zeros((*B, tr.M1.shape[0])), d=np.full((*B, self.system.p), np.nan), k=-1,
                              corrected=False, radius=radius, radius_input=math.nan, V=V)

    def _split_u(self, u: Array) -> tuple[Array, Array | None]:
        m = self.system.m
        if self.lpv_weights:
            return u[..., :m], u[..., m:]
        return u[..., :m], None

    def correct(self, t: float, z: SetValuedState, u: Array, y: Array, fresh: BoolArray) -> SetValuedState:
        """The measurement part of a step: (11), (12), (14), (15) from ``x̂_{k|k−1}``, then (10)."""
        if not np.all(np.isfinite(y)):
            raise NonFiniteError(f"y: the measurement at t = {t:g} is not finite (Algorithm 1 needs every sample)")
        if not np.all(fresh):
            raise InvalidArgumentError("Algorithm 1 needs every output at every step")
        tr, Lt = self.design.transform, self.design.gain
        uk, _ = self._split_u(u)
        z1, z2 = y @ tr.U1, y @ tr.U2
        if z.k < 0:  # step 0: x̂_{0|0} is given, only (10)
            d1 = (z1 - z.x @ tr.C1.T - uk @ tr.D1.T) @ tr.M1.T
            _require_finite(t, 0, (("d1_hat", d1),))
            return SetValuedState(x=z.x, d1=d1, d=z.d, k=0, corrected=True, radius=z.radius,
                                  radius_input=z.radius_input, V=z.V)
        if z.corrected:
            raise InvalidArgumentError(f"correct at t = {t:g}: step {z.k} was already corrected (call rhs in between)")
        xp = z.x
        d2 = (z2 - xp @ tr.C2.T - uk @ tr.D2.T) @ tr.M2.T  # (11)
        d = z.d1 @ tr.V1.T + d2 @ tr.V2.T  # (12)
        xs = xp + d2 @ tr.G2.T  # (14)
        xh = xs + (z2 - xs @ tr.C2.T - uk @ tr.D2.T) @ Lt.T  # (15)
        d1 = (z1 - xh @ tr.C1.T - uk @ tr.D1.T) @ tr.M1.T  # (10)
        _require_finite(t, z.k, (("x_hat", xh), ("d_hat", d), ("d1_hat", d1)))
        return SetValuedState(x=xh, d1=d1, d=d, k=z.k, corrected=True, radius=z.radius,
                              radius_input=z.radius_input, V=z.V)

    def rhs(self, t: float, z: SetValuedState, u: Array, y: Array) -> SetValuedState:
        """The time update (13) ``x̂_{k+1|k} = f(x̂_{k|k}) + B u_k + G₁ d̂₁,k`` and the radii of step ``k + 1``."""
        if not z.corrected:
            raise InvalidArgumentError(f"rhs at t = {t:g}: Algorithm 1 needs the measurement of every step "
                                       "(correct before each time update)")
        tr = self.design.transform
        uk, lam = self._split_u(u)
        lam_b = None if lam is None else np.broadcast_to(lam, (*z.x.shape[:-1], lam.shape[-1]))
        xp = self.system.f(z.x, lam_b) + uk @ self.system.B.T + z.d1 @ tr.G1.T  # (13)
        k1 = z.k + 1
        if self._rec is not None:
            dd, dx, V = self._rec.advance(z.radius, z.V)
        elif self.radii is not None:
            if k1 >= self.radii.state.size:
                raise InvalidArgumentError(f"radii: {self.radii.state.size} state radii given, the run is longer")
            dd, dx, V = float(self.radii.input[k1 - 1]), float(self.radii.state[k1]), math.nan
        else:
            dd = dx = V = math.nan
        return SetValuedState(x=xp, d1=z.d1, d=z.d, k=k1, corrected=False, radius=dx, radius_input=dd, V=V)

    def estimate(self, z: SetValuedState) -> Array:
        """The centre of the state ball (``x̂_{k|k}`` after the correction)."""
        return z.x

    def diagnostics(self, z: SetValuedState, u: Array) -> Mapping[str, Any]:
        """``d_hat`` ``(B, p)``, ``radius_state`` and ``radius_input`` (scalars: the same for every run)."""
        return {"d_hat": z.d, "radius_state": np.float64(z.radius), "radius_input": np.float64(z.radius_input)}
