"""The one list of observer methods: every command, its choices and its help read it.

:data:`REGISTRY` names each method with its module and one line of help, so that the command line
can list and validate names without importing a numerical library; :func:`get` imports the method
on first use. The observers of ``nlobs simulate``, ``nlobs export``, ``nlobs advise`` and ``nlobs design``
(and of their workflows) all take their names from here: a new observer is a module in
:mod:`nlobs.observers`, a :class:`~nlobs.methods.base.Method` in its own module here and one
:class:`Entry` below.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from nlobs.errors import UnknownNameError

__all__ = ["REGISTRY", "Entry", "entry", "get", "names"]


@dataclass(frozen=True)
class Entry:
    """One method of the registry.

    Attributes
    ----------
    name : str
        The name every command uses.
    module : str
        The module that holds the method (imported on first use).
    attribute : str
        The method object's name in that module.
    help : str
        One line for the command line's help: the method with its paper and equation numbers.
    simulated : bool
        ``nlobs simulate MODEL`` runs it.
    exported : bool
        ``nlobs export`` writes its C.
    default : bool
        ``nlobs simulate`` and ``nlobs estimate`` run it without being asked (the particle filter and moving-horizon
        estimation, orders of magnitude costlier per step, only when named).
    """

    name: str
    module: str
    attribute: str
    help: str
    simulated: bool = True
    exported: bool = True
    default: bool = True


#: Every method, in the order ``nlobs simulate`` reports them.
REGISTRY: tuple[Entry, ...] = (
    Entry("drift", "nlobs.methods.drift", "DRIFT", "Dalla Mora, Germani & Manes (3.1), gain of (2.17)"),
    Entry("pinv", "nlobs.methods.pinv", "PINV", "Röbenack (7) with the Moore–Penrose gain (17)"),
    Entry("luenberger", "nlobs.methods.luenberger", "LUENBERGER",
          "gain of LMIs (14), (15) (Grip, Saberi & Johansen); a nonlinear model: its linearisation at x0"),
    Entry("cascade", "nlobs.methods.cascade", "CASCADE",
          "Grip, Saberi & Johansen (9)–(10) / (17)–(18), the file's [cascade] table"),
    Entry("ekf", "nlobs.methods.kalman", "EKF", "extended Kalman filter (no certificate)"),
    Entry("ukf", "nlobs.methods.kalman", "UKF", "unscented Kalman filter (no certificate)"),
    Entry("pf", "nlobs.methods.estimators", "PF",
          "bootstrap particle filter, Gordon, Salmond & Smith (no certificate; run when named)", exported=False,
          default=False),
    Entry("mhe", "nlobs.methods.estimators", "MHE",
          "moving-horizon estimation, IPOPT via CasADi (no certificate; run when named; extra nlobs[mhe])",
          exported=False, default=False),
    Entry("setvalued", "nlobs.methods.setvalued", "SETVALUED",
          "Khajenejad & Yong (10)–(15), Algorithm 1, a discrete model with [unknown_inputs]", simulated=False),
    Entry("gnss-ins", "nlobs.methods.gnss_ins", "GNSS_INS",
          "Grip, Saberi & Johansen (24), the demo's flight (MODEL is gnss-ins)", simulated=False),
)


def names(*, simulated: bool | None = None, exported: bool | None = None,
          default: bool | None = None) -> tuple[str, ...]:
    """The methods' names, optionally only those ``nlobs simulate`` runs or ``nlobs export`` writes.

    Parameters
    ----------
    simulated, exported, default : bool, optional
        Keep only the methods with this flag (``None``: all).

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> names()
    ('drift', 'pinv', 'luenberger', 'cascade', 'ekf', 'ukf', 'pf', 'mhe', 'setvalued', 'gnss-ins')
    >>> names(simulated=False)  # not run by ``nlobs simulate MODEL``
    ('setvalued', 'gnss-ins')
    >>> names(simulated=True, default=True)  # run by ``nlobs simulate MODEL`` unless told otherwise
    ('drift', 'pinv', 'luenberger', 'cascade', 'ekf', 'ukf')
    """
    return tuple(e.name for e in REGISTRY
                 if (simulated is None or e.simulated == simulated) and (exported is None or e.exported == exported)
                 and (default is None or e.default == default))


def entry(name: str) -> Entry:
    """The registry's entry of ``name``.

    Parameters
    ----------
    name : str
        A method's name.

    Returns
    -------
    Entry

    Raises
    ------
    UnknownNameError
        No method of that name (the message lists the known ones).
    """
    for e in REGISTRY:
        if e.name == name:
            return e
    raise UnknownNameError(f"observer: unknown method {name!r} (known: {', '.join(names())})")


def get(name: str) -> Any:
    """The :class:`~nlobs.methods.base.Method` of ``name`` (its module imported on first use).

    Parameters
    ----------
    name : str
        A method's name.

    Returns
    -------
    Method

    Raises
    ------
    UnknownNameError
        No method of that name (the message lists the known ones).

    Examples
    --------
    >>> m = get("pinv")
    >>> m.name, m.title
    ('pinv', 'Moore–Penrose observer (Röbenack (7), (17))')
    >>> try:
    ...     get("kalman")
    ... except UnknownNameError as exc:
    ...     print(type(exc).__name__, exc)
    UnknownNameError observer: unknown method 'kalman' (known: drift, pinv, luenberger, cascade, ekf, ukf, ...)
    """
    e = entry(name)
    return getattr(importlib.import_module(e.module), e.attribute)
