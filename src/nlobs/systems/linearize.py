"""Jacobian linearisation of a symbolic model at an operating point (a LinearSystem)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from nlobs._validate import as_vector
from nlobs.errors import NonFiniteError
from nlobs.systems.linear import LinearSystem
from nlobs.systems.symbolic import SymbolicModel

__all__ = ["linearize"]


def linearize(model: SymbolicModel, x0: ArrayLike | None = None, u0: ArrayLike | None = None) -> LinearSystem:
    """Jacobian linearisation ``(∂F/∂x, ∂F/∂u, ∂h/∂x, ∂h/∂u)`` at ``(x0, u0)`` (default: the origin).

    Parameters
    ----------
    model : SymbolicModel
        The model to linearise.
    x0 : array_like, shape (n,), optional
        Operating state; zero when omitted.
    u0 : array_like, shape (m,), optional
        Operating input; zero when omitted.

    Returns
    -------
    LinearSystem
        ``(A, B, C, D)`` with the model's time base and state, input and output names.

    Raises
    ------
    NonFiniteError
        If a Jacobian is not finite at the point (e.g. ``log(x1)`` at ``x1 = 0``).
    """
    x = np.zeros(model.n) if x0 is None else as_vector("x0", x0, model.n)
    u = np.zeros(model.m) if u0 is None else as_vector("u0", u0, model.m)
    c = model.compile()
    with np.errstate(all="ignore"):
        mats = {
            "A": c.rhs_jacobian_x(0.0, x, u),
            "B": c.rhs_jacobian_u(0.0, x, u),
            "C": c.output_jacobian_x(0.0, x, u),
            "D": c.output_jacobian_u(0.0, x, u),
        }
    for k, v in mats.items():
        if not np.all(np.isfinite(v)):
            raise NonFiniteError(f"{model.name}: Jacobian {k} is not finite at x0={x.tolist()}, u0={u.tolist()}")
    return LinearSystem(mats["A"], mats["B"], mats["C"], mats["D"], time=model.time, states=model.states,
                        inputs=model.inputs, outputs=model.outputs, name=f"{model.name} (linearised)")
