r"""C for the impulsive observer (:class:`~nlobs.observers.impulsive.ImpulsiveObserver`).

Raff & Allgöwer ("Observers with impulsive dynamical behavior for linear and nonlinear continuous-time
systems", IEEE CDC 2007) run a copy of the model between samples and correct the estimate by a jump at
each sample:

.. math::

    \dot{\hat x} = F(\hat x, u) \quad (t_k \le t < t_{k+1}), \qquad
    \hat x(t_k^+) = \hat x(t_k^-) + L_J\,\big(y_J(t_k) - h_J(\hat x(t_k^-), u)\big),

``J`` the outputs sampled at ``t_k``. The generated module's state is the estimate ``x̂`` (``n`` values of
one run). It is a *correcting* module (:mod:`nlobs.export.program`):

* ``P_rhs_`` — ``F(x̂, u)``; the ``y`` argument (the held sample) is not read;
* ``P_correct_`` — ``x̂ ← x̂ + Σ_j L[:, j] (y_j − h_j(x̂, u))`` over the outputs ``j`` with ``fresh[j]``
  set and a finite innovation (a missing, non-finite sample is not corrected), as
  :meth:`ImpulsiveObserver.correct <nlobs.observers.impulsive.ImpulsiveObserver.correct>`;
* ``P_init`` and ``P_estimate`` — the common ones (``z = x̂0``, ``x̂ = z``).

``F`` and ``h`` are printed from the expressions the model was compiled from (a compiled
:class:`~nlobs.systems.symbolic.SymbolicModel`), or are the constant matrices of a linear system
(``F = A x + B u``, ``h = C x + D u``); any other plant is refused with
:class:`~nlobs.errors.InvalidArgumentError`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nlobs.errors import InvalidArgumentError
from nlobs.export.pieces import affine_function, matrix_note, require_source, static_array, static_function
from nlobs.export.program import CProgram

__all__ = ["generate_impulsive"]

_RHS_SIG = "(double t, const double *z, const double *u, const double *y, double *dz)"


def _model_c(plant: Any, P: str, n: int, m: int, p: int) -> tuple[str, str]:
    """The C of ``P_F(x, u, out)`` and ``P_h(x, u, out)``, and a description of the model for the header."""
    if hasattr(plant, "A") and hasattr(plant, "C") and not hasattr(plant, "_rhs"):
        A, B, C, D = (np.asarray(M, dtype=float) for M in (plant.A, plant.B, plant.C, plant.D))
        if A.shape != (n, n) or C.shape != (p, n) or B.shape != (n, m) or D.shape != (p, m):
            raise InvalidArgumentError(f"ImpulsiveObserver: A, B, C, D of shapes {A.shape}, {B.shape}, {C.shape}, "
                                       f"{D.shape}; expected {(n, n)}, {(n, m)}, {(p, n)}, {(p, m)}")
        defs = affine_function(f"{P}_F", A, B, n, n, m) + affine_function(f"{P}_h", C, D, p, n, m)
        return defs, "linear: F = A x + B u, h = C x + D u (the model's matrices)"
    name = getattr(plant, "name", type(plant).__name__)
    rhs = require_source(getattr(plant, "_rhs", None), f"{name}.rhs")
    h = require_source(getattr(plant, "_h", None), f"{name}.h")
    if len(rhs.expressions) != n or len(h.expressions) != p:
        raise InvalidArgumentError(f"{name}: F and h of {len(rhs.expressions)} and {len(h.expressions)} entries; "
                                   f"expected {n} and {p}")
    defs = (static_function(f"{P}_F", rhs, ("x", "u"), f"{name}.rhs")
            + static_function(f"{P}_h", h, ("x", "u"), f"{name}.h"))
    states, outputs = ", ".join(plant.states), ", ".join(plant.outputs)
    return defs, f"{name}: states {states}; outputs {outputs}; F and h printed from the model's expressions"


def generate_impulsive(obs: Any, prefix: str) -> CProgram:
    """The :class:`CProgram` of an :class:`~nlobs.observers.impulsive.ImpulsiveObserver` (module docstring).

    Parameters
    ----------
    obs : ImpulsiveObserver
        The impulsive observer of a continuous-time model.
    prefix : str
        A C identifier.

    Raises
    ------
    InvalidArgumentError
        The model has no expressions to print (a plant that is neither a compiled symbolic model nor a
        linear system).
    ModelError
        An expression has no C99 form.
    """
    P = prefix
    plant = obs.plant
    L = np.asarray(obs.L, dtype=float)
    n, p = L.shape
    m = len(getattr(plant, "inputs", ()))
    defs, model_note = _model_c(plant, P, n, m, p)
    body = static_array(f"{P}_L", L) + defs + f"""
/* between samples: the model, x_hat' = F(x_hat, u); y (the held sample) is not read: the samples
   enter in P_correct */
static int {P}_rhs_{_RHS_SIG}
{{
    (void)t;
    (void)y;
    {P}_F(z, u, dz);
    return 0;
}}

/* at a sample instant: x_hat <- x_hat + L_J (y_J - h_J(x_hat, u)) over the outputs j with fresh[j] and a
   finite innovation (a missing, non-finite sample is not corrected) */
static int {P}_correct_(double t, double *z, const double *u, const double *y, const unsigned char *fresh)
{{
    double hx[{max(p, 1)}], d[{max(p, 1)}];
    int i, j, any = 0;
    (void)t;
    for (j = 0; j < {p}; ++j) {{
        any = any || fresh[j];
    }}
    if (!any) {{
        return 0;
    }}
    {P}_h(z, u, hx);
    for (j = 0; j < {p}; ++j) {{
        d[j] = y[j] - hx[j];
        if (!fresh[j] || !(d[j] - d[j] == 0.0)) {{
            d[j] = 0.0;
        }}
    }}
    for (i = 0; i < {n}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {p}; ++j) {{
            acc += d[j] * {P}_L[i * {p} + j];
        }}
        z[i] = z[i] + acc;
    }}
    return 0;
}}
"""
    names = ", ".join(obs.state_names)
    notes = (
        ("observer", "the impulsive observer of Raff & Allgöwer, IEEE CDC 2007, \"Observers with impulsive\n"
                     "dynamical behavior for linear and nonlinear continuous-time systems\":\n"
                     "the model between samples, x_hat' = F(x_hat, u), and a jump at each sample,\n"
                     "x_hat+ = x_hat + L_J (y_J - h_J(x_hat, u)), J the outputs sampled then"),
        ("at each sample", f"call {P}_correct(t_k, z, u, y, fresh) with fresh[j] = 1 for every output j sampled\n"
                           "at t_k (a non-finite y_j is a missing sample: not corrected), then\n"
                           f"{P}_step(t_k, z, u, y, t_k1 - t_k); y is not read between samples"),
        ("state", f"[{names}] (the estimate)"),
        ("model", model_note),
        ("gain L", matrix_note(L)),
    )
    name = getattr(plant, "name", None) or type(plant).__name__
    return CProgram(prefix=P, title=f"Impulsive observer of {name} (Raff & Allgöwer 2007)", n_z=n, n_x=n, n_u=m,
                    n_y=p, discrete=False, body=body, correcting=True, notes=notes)
