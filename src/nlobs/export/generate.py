r"""Observer → :class:`~nlobs.export.program.CProgram`: one generator per observer class.

* :class:`~nlobs.observers.luenberger.LuenbergerObserver` — ``ż = (A − LC) z + (B − LD) u + L y``
  (or ``z⁺``) with the three matrices as constant arrays;
* :class:`~nlobs.observers.luenberger.ConstantGainObserver` — ``ż = f(z, u) + L (y − h(z, u))``, the
  plant's own expressions (a compiled :class:`~nlobs.systems.symbolic.SymbolicModel`, or a linear system);
* :class:`~nlobs.observers.pinv.PinvObserver` (``pinv="symbolic"``) and
  :class:`~nlobs.observers.pinv.ByrnesIsidoriObserver` — Röbenack's (7), ``x̂̇ = f + g u + l(x̂)(y − h)``
  with the gain field ``Q⁺(x̂) K`` (17) or ``(Φ')⁻¹ [K; 0]`` (8) printed from the expressions the
  observer compiled; with a saturation box, Khalil's form outside it;
* :class:`~nlobs.observers.drift.DriftObserver` — Dalla Mora, Germani & Manes (3.1), ``f, g, h, Q_s``
  printed, ``Q_s(x̂)⁻¹ K ỹ`` by an LU solve with partial pivoting (LAPACK's ``getrf`` choice), the same
  singularity test (exact zero pivot, or the lower bound ``‖Q_s‖_F ‖c‖ / (√n ‖b‖)`` on ``cond(Q_s)``
  above ``cond_limit``), the Tikhonov form and the saturated form;
* :class:`~nlobs.observers.cascade.CascadeObserver` — Grip, Saberi & Johansen (9)–(10) / (17)–(18), in
  :mod:`nlobs.export.cascade`.
* :class:`~nlobs.observers.sampled.OutputPredictor` — any of the continuous observers above run on sampled
  outputs through the inter-sample output predictor of Karafyllis & Kravaris (2009), in
  :mod:`nlobs.export.predictor`.
* :class:`~nlobs.observers.impulsive.ImpulsiveObserver` — Raff & Allgöwer's impulsive observer, the model
  ``F(x̂, u)`` between samples and the jump ``x̂ ← x̂ + L_J (y_J − h_J(x̂))`` at each (a correcting module), in
  :mod:`nlobs.export.impulsive`.
* :class:`~nlobs.observers.ekf.EKF` — the extended Kalman filter of any plant with expressions (Jazwinski's
  continuous-discrete form, or the discrete one) and its Joseph-form update, in :mod:`nlobs.export.kalman`.

Every symbolic part goes through :func:`nlobs.export.cprint.emit_assignments` (SymPy's C99 printer
with common subexpressions); the fixed parts (RK4, the solve, the saturated forms) are this module's
own C, in which no user text appears.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import sympy as sp

from nlobs.errors import InvalidArgumentError
from nlobs.export.cprint import c_double, c_identifier, emit_assignments
from nlobs.export.pieces import abscissa, matrix_note, require_source, static_array, static_function, symbol_inputs
from nlobs.export.program import CProgram
from nlobs.systems.timebase import Discrete

__all__ = ["default_prefix", "generate", "supported"]


_RHS_SIG = "(double t, const double *z, const double *u, const double *y, double *dz)"
_UNUSED = "    (void)t;\n    (void)z;\n    (void)u;\n    (void)y;\n"


# ----------------------------------------------------------------------------- linear and constant gain
def _luenberger(obs: Any, P: str) -> dict[str, Any]:
    s = obs.system
    n, m, p = s.n, s.m, s.p
    A, B, C, D, L = (np.asarray(M, dtype=float) for M in (s.A, s.B, s.C, s.D, obs.L))
    Fz, Fu = A - L @ C, B - L @ D
    body = (static_array(f"{P}_Fz", Fz) + static_array(f"{P}_Fu", Fu) + static_array(f"{P}_L", L)
            + f"""
static int {P}_rhs_{_RHS_SIG}
{{
    int i, j;
{_UNUSED}    for (i = 0; i < {n}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {n}; ++j) {{
            acc += {P}_Fz[i * {n} + j] * z[j];
        }}
        for (j = 0; j < {m}; ++j) {{
            acc += {P}_Fu[i * {max(m, 1)} + j] * u[j];
        }}
        for (j = 0; j < {p}; ++j) {{
            acc += {P}_L[i * {max(p, 1)} + j] * y[j];
        }}
        dz[i] = acc;
    }}
    return 0;
}}
""")
    notes = (("system", f"{n} states, {m} inputs, {p} outputs ({s.time})"),
             ("observer", "z' = (A - L C) z + (B - L D) u + L y, x_hat = z"),
             ("gain L", matrix_note(L)),
             ("A - L C", f"spectral abscissa {abscissa(Fz, isinstance(s.time, Discrete)):.6g}"))
    return dict(n_z=n, n_x=n, n_u=m, n_y=p, body=body, notes=notes, title=f"Luenberger observer ({n} states)")


def _constant_gain(obs: Any, P: str) -> dict[str, Any]:
    plant = obs.plant
    n, p = len(plant.states), len(plant.outputs)
    m = len(plant.inputs)
    if hasattr(plant, "A") and hasattr(plant, "C") and not hasattr(plant, "_rhs"):
        from nlobs.observers.luenberger import LuenbergerObserver

        return _luenberger(LuenbergerObserver(plant, obs.L), P)
    rhs = require_source(getattr(plant, "_rhs", None), f"{plant.name}.rhs")
    h = require_source(getattr(plant, "_h", None), f"{plant.name}.h")
    L = np.asarray(obs.L, dtype=float)
    ys = tuple(sp.Symbol(f"_y{j}", real=True) for j in range(p))
    xs, us = rhs.arguments
    hx = [e.xreplace(dict(zip(h.arguments[0] + h.arguments[1], xs + us))) for e in h.expressions]
    exprs = [rhs.expressions[i] + sum((sp.Float(L[i, j]) * (ys[j] - hx[j]) for j in range(p)), sp.Integer(0))
             for i in range(n)]
    inputs = symbol_inputs((xs, us, ys), ("z", "u", "y"))
    body = f"static int {P}_rhs_{_RHS_SIG}\n{{\n{_UNUSED}" + emit_assignments(
        exprs, inputs, [f"dz[{i}]" for i in range(n)], what=f"{plant.name}: observer") + "    return 0;\n}\n"
    notes = (("model", f"{plant.name}: states {', '.join(plant.states)}; outputs {', '.join(plant.outputs)}"),
             ("observer", "z' = f(z, u) + L (y - h(z, u)), x_hat = z (constant output injection)"),
             ("gain L", matrix_note(L)))
    return dict(n_z=n, n_x=n, n_u=m, n_y=p, body=body, notes=notes,
                title=f"Constant-gain observer of {plant.name}")


# ----------------------------------------------------------------------------- dense helpers (fixed C)
def _solve_c(P: str) -> str:
    return f"""\
/* A x = b in place (A n-by-n row-major, overwritten; b becomes x): LU with partial pivoting, the pivot
   choice of LAPACK's getrf; an exactly zero pivot is a singular matrix (1) */
static int {P}_solve(int n, double *A, double *b)
{{
    int i, j, k, p;
    for (k = 0; k < n; ++k) {{
        double best = fabs(A[k * n + k]);
        p = k;
        for (i = k + 1; i < n; ++i) {{
            if (fabs(A[i * n + k]) > best) {{
                best = fabs(A[i * n + k]);
                p = i;
            }}
        }}
        if (A[p * n + k] == 0.0) {{
            return 1;
        }}
        if (p != k) {{
            double tmp;
            for (j = 0; j < n; ++j) {{
                tmp = A[k * n + j];
                A[k * n + j] = A[p * n + j];
                A[p * n + j] = tmp;
            }}
            tmp = b[k];
            b[k] = b[p];
            b[p] = tmp;
        }}
        for (i = k + 1; i < n; ++i) {{
            const double l = A[i * n + k] / A[k * n + k];
            A[i * n + k] = l;
            for (j = k + 1; j < n; ++j) {{
                A[i * n + j] -= l * A[k * n + j];
            }}
            b[i] -= l * b[k];
        }}
    }}
    for (i = n - 1; i >= 0; --i) {{
        double acc = b[i];
        for (j = i + 1; j < n; ++j) {{
            acc -= A[i * n + j] * b[j];
        }}
        b[i] = acc / A[i * n + i];
    }}
    return 0;
}}
"""


def _sat_c(P: str, lower: Any, upper: Any) -> str:
    return (static_array(f"{P}_lo", lower) + static_array(f"{P}_hi", upper) + f"""\
/* sigma = sat(x) onto the box; returns whether any component was clipped */
static int {P}_sat(int n, const double *x, double *sig)
{{
    int i, out = 0;
    for (i = 0; i < n; ++i) {{
        double v = x[i] < {P}_lo[i] ? {P}_lo[i] : x[i];
        v = v > {P}_hi[i] ? {P}_hi[i] : v;
        sig[i] = v;
        out = out || (v != x[i]);
    }}
    return out;
}}
""")


# ----------------------------------------------------------------------------- Röbenack (7)
def _injection(obs: Any, P: str) -> dict[str, Any]:
    F = obs.fields
    n, m, q = F.n, F.m, F.q
    if getattr(obs, "pinv", "symbolic") != "symbolic":
        raise InvalidArgumentError(f"{F.name}: a Moore–Penrose observer with pinv='numeric' evaluates Q⁺ by an SVD "
                                   "at every step and is not exported; build it with pinv='symbolic'")
    rhs = require_source(obs._rhs, f"{F.name}: observer (7)")
    body = static_function(f"{P}_base", rhs, ("z", "u", "y"), f"{F.name}: observer (7)")
    B = getattr(obs, "saturation", None)
    if B is None:
        body += f"\nstatic int {P}_rhs_{_RHS_SIG}\n{{\n    (void)t;\n    {P}_base(z, u, y, dz);\n    return 0;\n}}\n"
    else:
        nr = sum(obs.r)
        sat = require_source(obs._sat_fn, f"{F.name}: saturated form")
        parts = static_function(f"{P}_parts", sat, ("z",), f"{F.name}: f, g, h, Φ_r, Q, Q⁺")
        K = np.asarray(obs._K, dtype=float)  # (nr, q)
        off_g, off_h = n, n + n * m
        off_phi = off_h + q
        off_Q = off_phi + nr
        off_Qp = off_Q + nr * n
        size = off_Qp + n * nr
        body += parts + _sat_c(P, B.lower, B.upper) + static_array(f"{P}_A", obs._A) + static_array(f"{P}_K", K) + f"""
/* Khalil's form outside the box (Röbenack (7) saturated): xi' = A_r (Phi_r(x) - Phi_r(sig)) + Q(sig) F(sig)
   + K (y - h(x)); x' = (I - Q+ Q)(x) F(sig) + Q+(x) xi', F = f + g u */
static int {P}_rhs_{_RHS_SIG}
{{
    double sig[{n}], vx[{size}], vs[{size}], Fs[{n}], xi[{nr}], Qf[{nr}];
    int i, j;
    (void)t;
    {P}_base(z, u, y, dz);
    if (!{P}_sat({n}, z, sig)) {{
        return 0;
    }}
    {P}_parts(z, vx);
    {P}_parts(sig, vs);
    for (i = 0; i < {n}; ++i) {{
        double acc = vs[i];
        for (j = 0; j < {m}; ++j) {{
            acc += vs[{off_g} + i * {max(m, 1)} + j] * u[j];
        }}
        Fs[i] = acc;
    }}
    for (i = 0; i < {nr}; ++i) {{
        double acc = 0.0, qs = 0.0, qx = 0.0, ky = 0.0;
        for (j = 0; j < {nr}; ++j) {{
            acc += (vx[{off_phi} + j] - vs[{off_phi} + j]) * {P}_A[i * {nr} + j];
        }}
        for (j = 0; j < {n}; ++j) {{
            qs += vs[{off_Q} + i * {n} + j] * Fs[j];
            qx += vx[{off_Q} + i * {n} + j] * Fs[j];
        }}
        for (j = 0; j < {q}; ++j) {{
            ky += (y[j] - vx[{off_h} + j]) * {P}_K[i * {q} + j];
        }}
        xi[i] = acc + qs + ky;
        Qf[i] = qx;
    }}
    for (i = 0; i < {n}; ++i) {{
        double a = 0.0, b = 0.0;
        for (j = 0; j < {nr}; ++j) {{
            a += vx[{off_Qp} + i * {nr} + j] * Qf[j];
            b += vx[{off_Qp} + i * {nr} + j] * xi[j];
        }}
        dz[i] = (Fs[i] - a) + b;
    }}
    return 0;
}}
"""
    kind = type(obs).__name__
    law = ("l(x) = Q+(x) K, Röbenack (17)" if kind == "PinvObserver" else "l(x) = (Phi'(x))^-1 [K; 0], (8)")
    notes = [("model", f"{F.name}: states {', '.join(F.states)}; outputs {', '.join(F.outputs)}"),
             ("observer", "x_hat' = f(x_hat) + g(x_hat) u + l(x_hat) (y - h(x_hat)), Röbenack (7)"),
             ("gain field", law),
             ("k", ", ".join(f"{v:.17g}" for v in np.asarray(obs.k_vector, dtype=float)))]
    checks = getattr(obs, "checks", ())
    for c in checks:
        notes.append((f"check {c.name}", f"{'passed' if c.passed else 'FAILED'}: {c.evidence}"))
    if B is not None:
        notes.append(("saturation", f"Khalil's form outside the box {B.describe()}"))
    return dict(n_z=n, n_x=n, n_u=m, n_y=q, body=body, notes=tuple(notes),
                title=f"{'Moore–Penrose' if kind == 'PinvObserver' else 'Byrnes–Isidori'} observer of {F.name}")


# ----------------------------------------------------------------------------- Dalla Mora, Germani & Manes (3.1)
def _drift(obs: Any, P: str) -> dict[str, Any]:
    n, m, q = obs.n_x, obs.n_inputs, obs.n_outputs
    fn = require_source(obs._fn, f"{obs.name}: f, g, h, Q_s")
    K = np.asarray(obs.K, dtype=float)
    off_g, off_h, off_Q = n, n + n * m, n + n * m + q
    size = off_Q + n * n
    eps = float(obs.regularization)
    body = static_function(f"{P}_parts", fn, ("z",), f"{obs.name}: f, g, h, Q_s") + _solve_c(P) + static_array(f"{P}_K", K)
    if eps > 0.0:
        solve = f"""\
    /* Tikhonov: (Q^T Q + eps^2 I) c = Q^T b */
    for (i = 0; i < {n}; ++i) {{
        double acc = 0.0;
        for (k = 0; k < {n}; ++k) {{
            acc += Q[k * {n} + i] * b[k];
        }}
        c[i] = acc;
        for (j = 0; j < {n}; ++j) {{
            double s = 0.0;
            for (k = 0; k < {n}; ++k) {{
                s += Q[k * {n} + i] * Q[k * {n} + j];
            }}
            M[i * {n} + j] = s + (i == j ? {c_double(eps * eps)} : 0.0);
        }}
    }}
    if ({P}_solve({n}, M, c) != 0) {{
        return 1;
    }}"""
    else:
        solve = f"""\
    for (i = 0; i < {n * n}; ++i) {{
        M[i] = Q[i];
    }}
    for (i = 0; i < {n}; ++i) {{
        c[i] = b[i];
    }}
    if ({P}_solve({n}, M, c) != 0) {{
        return 1;
    }}
    {{
        /* cond(Q) >= |Q|_F |c| / (sqrt(n) |b|): the observer's cheap singularity test */
        double nb = 0.0, nc = 0.0, nq = 0.0, lower;
        for (i = 0; i < {n}; ++i) {{
            nb += b[i] * b[i];
            nc += c[i] * c[i];
        }}
        for (i = 0; i < {n * n}; ++i) {{
            nq += Q[i] * Q[i];
        }}
        nb = sqrt(nb);
        lower = sqrt(nq) * sqrt(nc) / ({c_double(math.sqrt(n))} * (nb > 1e-300 ? nb : 1e-300));
        if (!{P}_finite(c, {n}) || (lower > {c_double(obs.cond_limit)} && nb > 0.0)) {{
            return 1;
        }}
    }}"""
    correction = f"""\
/* c = Q_s(x)^-1 K (y - h(x)), (3.1); Q and h from the parts at x */
static int {P}_correction(const double *v, const double *y, double *c)
{{
    const double *Q = v + {off_Q};
    double b[{n}], M[{n * n}];
    int i, j, k;
    (void)k;
    for (i = 0; i < {n}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {q}; ++j) {{
            acc += (y[j] - v[{off_h} + j]) * {P}_K[i * {q} + j];
        }}
        b[i] = acc;
    }}
{solve}
    return 0;
}}

static void {P}_drift(const double *v, const double *u, double *d)
{{
    int i, j;
    (void)u;
    for (i = 0; i < {n}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {m}; ++j) {{
            acc += v[{off_g} + i * {max(m, 1)} + j] * u[j];
        }}
        d[i] = {"v[i] + acc" if m else "v[i]"};
    }}
}}
"""
    body += correction + f"""
/* (3.1) itself from the parts v at x: dz = f + g u + Q_s^-1 K (y - h) */
static int {P}_plain(const double *v, const double *u, const double *y, double *dz)
{{
    double c[{n}];
    int i;
    {P}_drift(v, u, dz);
    if ({P}_correction(v, y, c) != 0) {{
        return 1;
    }}
    for (i = 0; i < {n}; ++i) {{
        dz[i] = dz[i] + c[i];
    }}
    return 0;
}}
"""
    B = obs.saturation
    if B is None:
        body += f"""
static int {P}_rhs_{_RHS_SIG}
{{
    double v[{size}];
    (void)t;
    {P}_parts(z, v);
    return {P}_plain(v, u, y, dz);
}}
"""
    else:
        phi = require_source(obs._phi, f"{obs.name}: Φ_s")
        body += (static_function(f"{P}_phi", phi, ("z",), f"{obs.name}: Φ_s") + _sat_c(P, B.lower, B.upper)
                 + static_array(f"{P}_A", obs._A) + f"""
/* Khalil's form outside the box: Q_s(x) x' = A_s (Phi(x) - Phi(sig)) + Q_s(sig)(f(sig) + g(sig) u) + K (y - h(x)) */
static int {P}_rhs_{_RHS_SIG}
{{
    double v[{size}], vs[{size}], c[{n}], sig[{n}], ds[{n}], px[{n}], ps[{n}], rest[{n}], M[{n * n}];
    int i, j;
    (void)t;
    {P}_parts(z, v);
    if (!{P}_sat({n}, z, sig)) {{
        return {P}_plain(v, u, y, dz);  /* inside the box: (3.1) itself, bit for bit */
    }}
    {P}_parts(sig, vs);
    {P}_drift(vs, u, ds);
    {P}_phi(z, px);
    {P}_phi(sig, ps);
    for (i = 0; i < {n}; ++i) {{
        double lin = 0.0, qd = 0.0;
        for (j = 0; j < {n}; ++j) {{
            lin += (px[j] - ps[j]) * {P}_A[i * {n} + j];
            qd += vs[{off_Q} + i * {n} + j] * ds[j];
        }}
        rest[i] = qd + lin;
    }}
    if ({P}_correction(v, y, c) != 0) {{
        return 1;
    }}
    for (i = 0; i < {n * n}; ++i) {{
        M[i] = v[{off_Q} + i];
    }}
    if ({P}_solve({n}, M, rest) != 0) {{
        return 1;
    }}
    for (i = 0; i < {n}; ++i) {{
        dz[i] = rest[i] + c[i];
    }}
    return 0;
}}
""")
    notes = [("model", f"{obs.name}: states {', '.join(obs.states)}"),
             ("observer", "x_hat' = f(x_hat) + g(x_hat) u + Q_s(x_hat)^-1 K (y - h(x_hat)), "
                          "Dalla Mora, Germani & Manes (3.1)"),
             ("multi-index s", ", ".join(str(v) for v in obs.s)),
             ("gain K", matrix_note(K)),
             ("singular Q_s", f"status 1 where a pivot is zero or cond(Q_s) > {obs.cond_limit:g} (lower bound)"
              if eps == 0.0 else f"Tikhonov-regularised, eps = {eps:.17g}")]
    if B is not None:
        notes.append(("saturation", f"Khalil's form outside the box {B.describe()}"))
    return dict(n_z=n, n_x=n, n_u=m, n_y=q, body=body, notes=tuple(notes),
                title=f"Drift-observability observer of {obs.name}")


# ----------------------------------------------------------------------------- dispatch
def _lazy(module: str, name: str) -> Any:
    def gen(obs: Any, prefix: str, **options: Any) -> Any:
        import importlib

        return getattr(importlib.import_module(module), name)(obs, prefix, **options)

    return gen


def _generators() -> dict[str, Any]:
    return {"LuenbergerObserver": _luenberger, "ConstantGainObserver": _constant_gain,
            "PinvObserver": _injection, "ByrnesIsidoriObserver": _injection, "DriftObserver": _drift,
            "GnssInsObserver": _lazy("nlobs.export.gnss_ins", "generate_gnss_ins"),
            "ScheduledGnssInsObserver": _lazy("nlobs.export.gnss_ins", "generate_gnss_ins"),
            "SetValuedObserver": _lazy("nlobs.export.setvalued", "generate_setvalued"),
            "CascadeObserver": _lazy("nlobs.export.cascade", "generate_cascade"),
            "OutputPredictor": _lazy("nlobs.export.predictor", "generate_predictor"),
            "ImpulsiveObserver": _lazy("nlobs.export.impulsive", "generate_impulsive"),
            "EKF": _lazy("nlobs.export.kalman", "generate_ekf"),
            "UKF": _lazy("nlobs.export.ukf", "generate_ukf"),
            "ExtendedKalmanFilter": _lazy("nlobs.export.nav_ekf", "generate_nav_ekf")}


#: Observer classes whose generator takes options (``generate(..., options=)``).
_TAKES_OPTIONS = frozenset({"GnssInsObserver", "ScheduledGnssInsObserver"})


def default_prefix(observer: Any, prefix: str | None = None) -> str:
    """The C prefix of an observer's module: ``prefix`` made a C identifier, else ``nlobs_<class>``.

    Parameters
    ----------
    observer : Observer
        The observer.
    prefix : str, optional
        A name the caller chose.
    """
    return c_identifier(prefix or f"nlobs_{type(observer).__name__.lower()}")


def supported() -> tuple[str, ...]:
    """Names of the observer classes this module generates C for.

    Examples
    --------
    >>> names = supported()
    >>> names[:5]
    ('LuenbergerObserver', 'ConstantGainObserver', 'PinvObserver', 'ByrnesIsidoriObserver', 'DriftObserver')
    >>> "GnssInsObserver" in names, "ExtendedKalmanFilter" in names
    (True, True)
    >>> "DiscreteLipschitzObserver" in names  # no C generator: the export refuses it
    False
    """
    return tuple(_generators())


def generate(observer: Any, prefix: str, *, notes: tuple[tuple[str, str], ...] = (),
             options: dict[str, Any] | None = None) -> CProgram:
    """The :class:`CProgram` of ``observer``.

    Parameters
    ----------
    observer : Observer
        One of :func:`supported`.
    prefix : str
        A C identifier (:func:`nlobs.export.cprint.c_identifier`).
    notes : tuple of (str, str)
        More lines for the header (the certificate summary of a design).
    options : dict, optional
        Keyword arguments of the observer's generator (the GNSS/INS observer: ``imu_period``).

    Raises
    ------
    InvalidArgumentError
        The observer's class has no C generator, or this configuration of it is not exported.
    ModelError
        An expression has no C99 form.

    Examples
    --------
    The module of a Luenberger observer holds ``A − L C``, ``B − L D`` and ``L`` as constant arrays (row-major);
    the header notes say what was generated:

    >>> import nlobs
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> program = generate(nlobs.LuenbergerObserver(system, [[4.5], [1.75]]), "osc")
    >>> program.title, (program.n_z, program.n_x, program.n_u, program.n_y), program.discrete, program.correcting
    ('Luenberger observer (2 states)', (2, 2, 1, 1), False, False)
    >>> print(program.body.splitlines()[0])  # A − L C = [[-4.5, 1], [-3.75, -0.5]]
    static const double osc_Fz[4] = {(-4.5), 1.0, (-3.75), (-0.5)};
    >>> dict(program.notes)["A - L C"]
    'spectral abscissa -2'
    >>> try:
    ...     generate(object(), "x")
    ... except InvalidArgumentError as exc:
    ...     print(type(exc).__name__, exc)
    InvalidArgumentError no C export for object; exported: LuenbergerObserver, ...
    """
    kind = type(observer).__name__
    gen = _generators().get(kind)
    if gen is None:
        raise InvalidArgumentError(f"no C export for {kind}; exported: {', '.join(supported())}")
    if options and kind not in _TAKES_OPTIONS:
        raise InvalidArgumentError(f"options: the C generator of {kind} takes none, got {', '.join(sorted(options))}")
    parts = gen(observer, prefix, **options) if options else gen(observer, prefix)
    if isinstance(parts, CProgram):  # a generator that sets the optional parts itself (own step, correction…)
        return dataclasses.replace(parts, notes=parts.notes + tuple(notes))
    tb = observer.time
    discrete = isinstance(tb, Discrete)
    return CProgram(prefix=prefix, title=parts["title"], n_z=parts["n_z"], n_x=parts["n_x"], n_u=parts["n_u"],
                    n_y=parts["n_y"], discrete=discrete, body=parts["body"], notes=parts["notes"] + tuple(notes),
                    dt=float(tb.dt) if discrete else None)
