r"""C for the inter-sample output predictor (:class:`~nlobs.observers.sampled.OutputPredictor`).

Karafyllis & Kravaris (IEEE TAC 54(9), 2009, Sec. III) run a continuous-time observer on sampled outputs
by feeding it, in place of the held sample, a prediction ``w`` of the output that follows the estimate
between samples and is reset to each sample:

.. math::

    \dot w = \frac{\partial h}{\partial x}(\hat x)\, F(\hat x, u) \quad (t_k \le t < t_{k+1}),
    \qquad w(t_k) = y_k .

The generated module's state is ``[z, w]`` (``n_inner + p`` values of one run): the wrapped observer's
state, then one predicted output per model output. It is a *correcting* module (:mod:`nlobs.export.program`):

* ``P_rhs_`` — the wrapped observer's right-hand side (its own generator's C, under the prefix
  ``P_inner``) with ``w`` where it reads ``y``, then ``ẇ = ∂h/∂x(x̂) F(x̂, u)`` with ``x̂`` the wrapped
  observer's estimate; the ``y`` argument is not read;
* ``P_correct_`` — ``w_j ← y_j`` for every output ``j`` with ``fresh[j]`` set and a finite ``y_j``
  (a missing, non-finite sample leaves the prediction running);
* ``P_init_`` — the wrapped observer's initial state, and ``w = h(x̂0, 0)``
  (:meth:`OutputPredictor.init <nlobs.observers.sampled.OutputPredictor.init>`);
* ``P_estimate_`` — the wrapped observer's estimate.

``F``, ``h`` and ``∂h/∂x`` are printed from the expressions the model was compiled from (a compiled
:class:`~nlobs.systems.symbolic.SymbolicModel`), or are the constant matrices of a linear system
(``F = A x + B u``, ``∂h/∂x = C``). The wrapped observer is any kind :func:`nlobs.export.generate.generate`
exports as a continuous, non-correcting module with a flat state and the common RK4 step (constant-gain,
Luenberger, Moore–Penrose, drift, cascade); anything else is refused with
:class:`~nlobs.errors.InvalidArgumentError`.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from nlobs.errors import InvalidArgumentError
from nlobs.export.pieces import require_source, static_array, static_function
from nlobs.export.program import CProgram

__all__ = ["generate_predictor"]

_RHS_SIG = "(double t, const double *z, const double *u, const double *y, double *dz)"

#: The macros of ``P.h`` an inner body may use (``P_NZ``…); defined again under the inner prefix.
_MACROS = ("NZ1", "NU1", "NY1", "NZ", "NX", "NU", "NY", "DISCRETE", "OK", "SINGULAR", "NONFINITE")


def _inner_program(obs: Any, prefix: str) -> CProgram:
    """The wrapped observer's :class:`CProgram` under ``prefix``, or why it cannot be wrapped in C."""
    from nlobs.export.generate import generate

    kind = type(obs).__name__
    try:
        prog = generate(obs, prefix)
    except InvalidArgumentError as exc:
        raise InvalidArgumentError(f"OutputPredictor: the wrapped {kind} has no C export ({exc})") from exc
    why = ("it is discrete-time" if prog.discrete else "it corrects at samples itself" if prog.correcting
           else "it has its own discretisation (P_step_)" if prog.own_step
           else "its state is not a flat array" if prog.codec is not None else None)
    if why is not None:
        raise InvalidArgumentError(f"OutputPredictor: no C export of the predictor around {kind}: {why}")
    return prog


def _shims(inner: CProgram, outer_prefix: str) -> str:
    """What the inner body takes from ``P.h`` and the common helpers, under the inner prefix."""
    Pi, upi = inner.prefix, inner.prefix.upper()
    out = []
    values = {"NZ": inner.n_z, "NX": inner.n_x, "NU": inner.n_u, "NY": inner.n_y, "DISCRETE": 0, "OK": 0,
              "SINGULAR": 1, "NONFINITE": 2}
    for name in _MACROS:
        if re.search(rf"\b{upi}_{name}\b", inner.body):
            if name.endswith("1"):
                base = values[name[:-1]]
                out.append(f"#define {upi}_{name} {max(int(base), 1)}")
            else:
                out.append(f"#define {upi}_{name} {values[name]}")
    text = "\n".join(out) + ("\n" if out else "")
    if f"{Pi}_finite(" in inner.body:
        text += (f"static int {Pi}_finite(const double *v, int n)\n{{\n"
                 f"    return {outer_prefix}_finite(v, n);\n}}\n")
    return text


def _model_c(plant: Any, P: str, n: int, m: int, p: int) -> tuple[bool, str, str, str, str]:
    """The C of ``F``, ``∂h/∂x`` and ``h`` of the predicted model: (linear, definitions, ``ẇ`` statements,
    ``w0`` statements, a description for the header); ``{NI}`` in the statements stands for ``n_inner``."""
    linear = hasattr(plant, "A") and hasattr(plant, "C") and not hasattr(plant, "_rhs")
    if linear:
        A, B, C = (np.asarray(M, dtype=float) for M in (plant.A, plant.B, plant.C))
        defs = static_array(f"{P}_A", A) + (static_array(f"{P}_B", B) if m else "") + static_array(f"{P}_C", C)
        bu = (f"""
        for (j = 0; j < {m}; ++j) {{
            acc += {P}_B[i * {m} + j] * u[j];
        }}""" if m else "")
        dw = f"""\
    /* F = A x_hat + B u */
    for (i = 0; i < {n}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {n}; ++j) {{
            acc += {P}_A[i * {n} + j] * xh[j];
        }}{bu}
        F[i] = acc;
    }}
    /* w' = C F */
    for (i = 0; i < {p}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {n}; ++j) {{
            acc += {P}_C[i * {n} + j] * F[j];
        }}
        dz[{{NI}} + i] = acc;
    }}
"""
        w0 = f"""\
    /* w0 = h(x_hat0, 0) = C x_hat0 */
    for (i = 0; i < {p}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {n}; ++j) {{
            acc += {P}_C[i * {n} + j] * xh[j];
        }}
        z[{{NI}} + i] = acc;
    }}
"""
        return True, defs, dw, w0, "linear: F = A x + B u, dh/dx = C (the model's matrices)"
    name = getattr(plant, "name", type(plant).__name__)
    rhs = require_source(getattr(plant, "_rhs", None), f"{name}.rhs")
    hx = require_source(getattr(plant, "_h_x", None), f"{name}.dh/dx")
    h = require_source(getattr(plant, "_h", None), f"{name}.h")
    if len(rhs.expressions) != n or len(hx.expressions) != p * n or len(h.expressions) != p:
        raise InvalidArgumentError(f"{name}: F, h, dh/dx of {len(rhs.expressions)}, {len(h.expressions)}, "
                                   f"{len(hx.expressions)} entries; expected {n}, {p}, {p * n}")
    defs = (static_function(f"{P}_F", rhs, ("x", "u"), f"{name}.rhs")
            + static_function(f"{P}_hx", hx, ("x", "u"), f"{name}.dh/dx")
            + static_function(f"{P}_h", h, ("x", "u"), f"{name}.h"))
    dw = f"""\
    /* w' = dh/dx(x_hat, u) F(x_hat, u) */
    {P}_F(xh, u, F);
    {P}_hx(xh, u, J);
    for (i = 0; i < {p}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {n}; ++j) {{
            acc += J[i * {n} + j] * F[j];
        }}
        dz[{{NI}} + i] = acc;
    }}
"""
    w0 = f"""\
    /* w0 = h(x_hat0, 0) */
    for (j = 0; j < {max(m, 1)}; ++j) {{
        u0[j] = 0.0;
    }}
    {P}_h(xh, u0, z + {{NI}});
"""
    return False, defs, dw, w0, f"{name}: F, h and dh/dx printed from the model's expressions"


def generate_predictor(obs: Any, prefix: str) -> CProgram:
    """The :class:`CProgram` of an :class:`~nlobs.observers.sampled.OutputPredictor` (module docstring).

    Parameters
    ----------
    obs : OutputPredictor
        A continuous observer wrapped with the inter-sample output predictor.
    prefix : str
        A C identifier.

    Raises
    ------
    InvalidArgumentError
        The wrapped observer has no C export, or not as a continuous, non-correcting module with a flat
        state; or the model has no expressions to print (a plant that is neither a compiled symbolic
        model nor a linear system).
    ModelError
        An expression has no C99 form.
    """
    P = prefix
    plant = obs.plant
    inner = _inner_program(obs.observer, f"{P}_inner")
    Pi = inner.prefix
    n, p = int(obs.n_x), int(obs.p)
    m = len(getattr(plant, "inputs", ()))
    ni = int(obs.n_inner)
    if inner.n_z != ni or inner.n_x != n:
        raise InvalidArgumentError(f"OutputPredictor: the C of the wrapped {type(obs.observer).__name__} has "
                                   f"{inner.n_z} states and {inner.n_x} estimates; the Python one {ni} and {n}")
    if inner.n_y != p or inner.n_u != m:
        raise InvalidArgumentError(f"OutputPredictor: the wrapped observer reads {inner.n_y} outputs and "
                                   f"{inner.n_u} inputs; the model has {p} and {m}")
    linear, defs, dw, w0, model_note = _model_c(plant, P, n, m, p)
    dw, w0 = dw.replace("{NI}", str(ni)), w0.replace("{NI}", str(ni))
    est = (f"    {Pi}_estimate_(z, xh);\n" if inner.own_estimate else
           f"    int i;\n    for (i = 0; i < {n}; ++i) {{\n        xh[i] = z[i];\n    }}\n")
    if inner.own_init:
        init_inner = f"    if ({Pi}_init_(xhat0, z) == 1) {{\n        return 1;\n    }}\n"
    else:
        init_inner = f"    for (i = 0; i < {ni}; ++i) {{\n        z[i] = xhat0[i];\n    }}\n"
    init_vars = ", ".join(v for v, used in (("i", linear or not inner.own_init), ("j", True)) if used)
    body = (_shims(inner, P) + inner.body.rstrip() + "\n\n" + defs + f"""
/* the wrapped observer's estimate x_hat of [z, w] */
static void {P}_estimate_(const double *z, double *xh)
{{
{est}}}

/* Karafyllis & Kravaris (2009): the wrapped observer driven by the prediction w = z[{ni}..], and
   w' = dh/dx(x_hat) F(x_hat, u); y (the held sample) is not read: the samples enter in P_correct */
static int {P}_rhs_{_RHS_SIG}
{{
    double xh[{n}], F[{n}]{"" if linear else f", J[{p * n}]"};
    int i, j, s;
    (void)y;
    s = {Pi}_rhs_(t, z, u, z + {ni}, dz);
    if (s != 0) {{
        return s;
    }}
    {P}_estimate_(z, xh);
{dw}    return 0;
}}

/* at a sample instant: w_j <- y_j for every output j with fresh[j] and a finite y_j (a missing sample:
   the prediction runs on) */
static int {P}_correct_(double t, double *z, const double *u, const double *y, const unsigned char *fresh)
{{
    int j;
    (void)t;
    (void)u;
    for (j = 0; j < {p}; ++j) {{
        if (fresh[j] && y[j] - y[j] == 0.0) {{
            z[{ni} + j] = y[j];
        }}
    }}
    return 0;
}}

/* [z0, h(x_hat0, 0)]: the wrapped observer's initial state and the output of the initial estimate */
static int {P}_init_(const double *xhat0, double *z)
{{
    double xh[{n}]{"" if linear else f", u0[{max(m, 1)}]"};
    int {init_vars};
{init_inner}    {P}_estimate_(z, xh);
{w0}    return {P}_finite(z, {ni + p}) ? 0 : 2;
}}
""")
    names = ", ".join(obs.state_names)
    notes = (
        ("predictor", "the inter-sample output predictor of Karafyllis & Kravaris, IEEE TAC 54(9), 2009,\n"
                      "\"From continuous-time design to sampled-data design of observers\" (Sec. III):\n"
                      "the continuous observer reads a prediction w of the output in place of the held sample;\n"
                      "w' = dh/dx(x_hat) F(x_hat, u) between samples, w_j = y_j at a sample of output j"),
        ("at each sample", f"call {P}_correct(t_k, z, u, y, fresh) with fresh[j] = 1 for every output j sampled\n"
                           "at t_k (w_j <- y_j; a non-finite y_j is a missing sample: w_j runs on), then\n"
                           f"{P}_step(t_k, z, u, y, t_k1 - t_k); y is not read between samples"),
        ("state", f"[{names}] (the wrapped observer's {ni}, then w, {p} values)"),
        ("model", model_note),
        ("wrapped observer", inner.title),
        *((f"inner {k}" if k in ("observer", "model", "state") else k, v) for k, v in inner.notes),
    )
    return CProgram(prefix=P, title=f"{inner.title} with the inter-sample output predictor (Karafyllis & Kravaris "
                                    "2009)", n_z=ni + p, n_x=n, n_u=m, n_y=p, discrete=False, body=body,
                    correcting=True, own_init=True, own_estimate=True, notes=notes, status1=inner.status1)
