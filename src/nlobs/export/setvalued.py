r"""Algorithm 1 of Khajenejad & Yong (:class:`~nlobs.observers.setvalued.SetValuedObserver`) as C99.

The observer is a discrete correcting observer, and the C is its two halves operation for operation:

* ``P_correct_`` — the measurement part of a step: ``z₁ = U₁ᵀy``, ``z₂ = U₂ᵀy``; at step 0 only (10),
  else (11) ``d̂₂``, (12) ``d̂``, (14) ``x̂⋆``, (15) ``x̂_{k|k}``, then (10) ``d̂₁``;
* ``P_rhs_`` (``z⁺``) — the time update (13) ``x̂_{k+1|k} = A x̂ + φ(x̂) + B u + G₁ d̂₁`` with ``φ`` printed
  from the model's SymPy expressions, and the radii of step ``k + 1``: the sound recursion
  (:meth:`~nlobs.observers.setvalued.RadiusRecursion.advance`, its sixteen constants as literals, the same
  products, sums, square roots and minima in the same order, Python's ``min(a, b)`` as ``b < a ? b : a``),
  or the given radii (:class:`~nlobs.observers.setvalued.Radii`, as constant tables), or none.

Every matrix (the transformation's ``U, C, D, M, V, G``, the gain ``L̃``, ``A``, ``B``) is a constant array;
each product ``v @ Mᵀ`` is one sum over the row of ``M`` in index order, each difference as the Python
writes it, so the compiled centres equal the Python ones to rounding and the radii exactly (they do not
depend on the data). The Python observer uses plain floating point (no outward rounding), so does the C.

State layout (``n_z = n + p₁ + p + 9`` values of one run, :func:`codec`): ``x̂`` (``n``), ``d̂₁`` (``p₁``),
``d̂`` (``p``), then ``k``, ``corrected``, ``δˣ``, ``δᵈ``, ``V̄`` and four flags saying whether ``d̂``,
``δˣ``, ``δᵈ``, ``V̄`` are defined (the Python state holds NaN there before the first step, or without
radii; the flat state holds 0 and the flag, so the C's finiteness checks see only real overflows). An
infinite radius (a bound that does not converge, e.g. a printed one) is 0 with flag 2: it is a value.

Errors. What the Python observer raises, the C cannot: a non-finite or missing sample, a correction of
an already corrected step, a time update before the correction, or a run longer than the given radii
make the centre NaN and return ``P_NONFINITE``; the loops then report the divergence at that time.

Not exported (:class:`~nlobs.errors.InvalidArgumentError`): run-time LPV weights (``lpv_weights=True``)
and a nonlinear part ``φ`` that is a plain Python callable (no expressions to print).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from nlobs.errors import InvalidArgumentError
from nlobs.export.cprint import c_double
from nlobs.export.pieces import matrix_note, require_source, static_array, static_function
from nlobs.export.program import CProgram, StateCodec

__all__ = ["codec", "generate_setvalued"]

#: Offsets of the scalars after the vectors (``x̂``, ``d̂₁``, ``d̂``) of one run.
_K, _CORR, _RAD, _RADIN, _V, _DDEF, _RDEF, _RIDEF, _VDEF = range(9)
_N_SCALARS = 9


def _lit(v: float) -> str:
    """A C constant of ``v``, infinities and NaN included (``<math.h>``'s ``INFINITY``, ``NAN``)."""
    v = float(v)
    if math.isnan(v):
        return "NAN"
    if math.isinf(v):
        return "INFINITY" if v > 0 else "(-INFINITY)"
    return c_double(v)


def _encode(v: float) -> tuple[float, float]:
    """A radius or ``V̄`` as (value, flag): finite (v, 1); NaN (0, 0); +inf (0, 2); -inf (0, 3)."""
    if math.isfinite(v):
        return v, 1.0
    return 0.0, 0.0 if math.isnan(v) else (2.0 if v > 0 else 3.0)


def _decode(v: float, flag: float) -> float:
    return v if flag == 1.0 else {2.0: math.inf, 3.0: -math.inf}.get(flag, math.nan)


def codec(n: int, p1: int, p: int) -> StateCodec:
    """Pack :class:`~nlobs.observers.setvalued.SetValuedState` to the flat ``(..., n_z)`` layout and back.

    Parameters
    ----------
    n, p1, p : int
        Sizes of ``x̂``, ``d̂₁`` and ``d̂``.
    """
    from nlobs.observers.setvalued import SetValuedState

    off = n + p1 + p

    def _flag(a: Any) -> tuple[Any, Any]:
        ok = np.all(np.isfinite(a), axis=-1, keepdims=True)
        return np.where(ok, a, 0.0), ok.astype(float)

    def pack(z: SetValuedState) -> Any:
        x = np.asarray(z.x, dtype=float)
        batch = x.shape[:-1]
        d, d_ok = _flag(np.broadcast_to(np.asarray(z.d, dtype=float), (*batch, p)))
        if p == 0:
            d_ok = np.ones((*batch, 1))
        enc = [_encode(float(v)) for v in (z.radius, z.radius_input, z.V)]
        scal, flags = [v for v, _ in enc], [f for _, f in enc]
        tail = np.broadcast_to(np.array([float(z.k), float(bool(z.corrected)), *scal, 0.0, *flags]),
                               (*batch, _N_SCALARS)).copy()
        tail[..., _DDEF] = d_ok[..., 0]
        return np.concatenate([x, np.broadcast_to(np.asarray(z.d1, dtype=float), (*batch, p1)), d, tail], axis=-1)

    def unpack(flat: Any) -> SetValuedState:
        f = np.asarray(flat, dtype=float)
        x, d1, d = f[..., :n], f[..., n:n + p1], f[..., n + p1:off]
        first = f.reshape(-1, f.shape[-1])[0, off:]
        d_ok = f[..., off + _DDEF:off + _DDEF + 1] != 0.0
        d = np.where(d_ok, d, np.nan)

        def scalar(i: int, flag: int) -> float:
            return _decode(float(first[i]), float(first[flag]))

        return SetValuedState(x=np.array(x), d1=np.array(d1), d=d, k=int(first[_K]), corrected=bool(first[_CORR]),
                              radius=scalar(_RAD, _RDEF), radius_input=scalar(_RADIN, _RIDEF), V=scalar(_V, _VDEF))

    return StateCodec(pack=pack, unpack=unpack)


def _matvec(out: str, mat: str, rows: int, cols: int, vec: str, *, indent: str = "    ") -> str:
    """``out[i] = Σ_j vec[j] M[i, j]`` (NumPy's ``vec @ Mᵀ``), the sum in index order from 0."""
    return (f"{indent}for (i = 0; i < {rows}; ++i) {{\n"
            f"{indent}    double acc = 0.0;\n"
            f"{indent}    for (j = 0; j < {cols}; ++j) {{\n"
            f"{indent}        acc += {vec}[j] * {mat}[i * {max(cols, 1)} + j];\n"
            f"{indent}    }}\n"
            f"{indent}    {out}[i] = acc;\n"
            f"{indent}}}\n")


def _vecmat(out: str, mat: str, rows: int, cols: int, vec: str, *, indent: str = "    ") -> str:
    """``out[j] = Σ_i vec[i] M[i, j]`` (NumPy's ``vec @ M``, ``M`` of ``rows × cols``)."""
    return (f"{indent}for (j = 0; j < {cols}; ++j) {{\n"
            f"{indent}    double acc = 0.0;\n"
            f"{indent}    for (i = 0; i < {rows}; ++i) {{\n"
            f"{indent}        acc += {vec}[i] * {mat}[i * {max(cols, 1)} + j];\n"
            f"{indent}    }}\n"
            f"{indent}    {out}[j] = acc;\n"
            f"{indent}}}\n")


def _residual(out: str, z: str, C: str, D: str, rows: int, n: int, m: int, x: str, *,
              indent: str = "    ") -> str:
    """``out = (z − x Cᵀ) − u Dᵀ``, each product a full sum first (the Python's ``z - x @ C.T - u @ D.T``)."""
    return (f"{indent}for (i = 0; i < {rows}; ++i) {{\n"
            f"{indent}    double cx = 0.0, du = 0.0;\n"
            f"{indent}    for (j = 0; j < {n}; ++j) {{\n"
            f"{indent}        cx += {x}[j] * {C}[i * {n} + j];\n"
            f"{indent}    }}\n"
            f"{indent}    for (j = 0; j < {m}; ++j) {{\n"
            f"{indent}        du += u[j] * {D}[i * {max(m, 1)} + j];\n"
            f"{indent}    }}\n"
            f"{indent}    {out}[i] = ({z}[i] - cx) - du;\n"
            f"{indent}}}\n")


def _radii_c(obs: Any, P: str, up: str, O: str) -> tuple[str, str, list[tuple[str, str]]]:
    """The C constants and the statements of the radius update of ``rhs``, and their header notes."""
    rec, radii = obs._rec, obs.radii
    notes: list[tuple[str, str]] = []
    if rec is not None:
        names = ("th", "r", "eta", "thd", "rd", "alpha", "nA", "nFz", "thp", "rp", "thdp", "rdp", "lam_eff", "c",
                 "lmin", "lmax")
        consts = "".join(f"static const double {P}_{k} = {_lit(getattr(rec, k))};\n" for k in names)
        code = f"""\
    {{
        /* RadiusRecursion.advance: (dd, dx, V) from (radius, V), Python's min(a, b) = (b < a ? b : a) */
        const double dx = {P}_get(z, {_RAD}, {_RDEF}), V = {P}_get(z, {_V}, {_VDEF});
        const double sv = sqrt(V);
        double a, b, dd, tri, Vn, q, dxn, Vc;
        a = {P}_thd * dx + {P}_rd;
        b = {P}_nFz * sv + {P}_thdp * dx + {P}_rdp;
        dd = (b < a ? b : a) + {P}_alpha;
        a = {P}_th * dx + {P}_r;
        b = {P}_nA * sv + {P}_thp * dx + {P}_rp;
        tri = (b < a ? b : a) + {P}_eta;
        Vn = {P}_lam_eff * V + {P}_c;
        q = sqrt(Vn / {P}_lmin);
        dxn = (tri < q ? tri : q);
        Vc = {P}_lmax * (dxn * dxn);
        {P}_set(dz, {_RADIN}, {_RIDEF}, dd);
        {P}_set(dz, {_RAD}, {_RDEF}, dxn);
        {P}_set(dz, {_V}, {_VDEF}, Vc < Vn ? Vc : Vn);
    }}
"""
        notes.append(("radii", "sound recursion (RadiusRecursion): V_k = min(lam_eff V_k-1 + c, lmax dx_k^2), "
                               "dx_k = min(sqrt(V_k/lmin), min(th dx + r, nA sqrt(V) + thp dx + rp) + eta), "
                               "dd = min(thd dx + rd, nFz sqrt(V) + thdp dx + rdp) + alpha"))
        notes.append(("radius constants", ", ".join(f"{k} = {getattr(rec, k):.17g}" for k in names)))
        ssx, ssd = rec.steady()
        notes.append(("steady radii", f"state {ssx:.17g}, input {ssd:.17g}"))
        return consts, code, notes
    if radii is not None:
        ns, ni = int(radii.state.size), int(radii.input.size)
        consts = (f"static const double {P}_rad_state[{max(ns, 1)}] = "
                  + ("{" + ", ".join(_lit(v) for v in radii.state) + "}" if ns else "{0.0}") + ";\n"
                  + f"static const double {P}_rad_input[{max(ni, 1)}] = "
                  + ("{" + ", ".join(_lit(v) for v in radii.input) + "}" if ni else "{0.0}") + ";\n")
        code = f"""\
    {{
        /* the given radii (a table): a run longer than the table fails, as in Python */
        const long k1 = (long)z[{O} + {_K}] + 1;
        if (k1 >= {ns} || k1 - 1 >= {ni}) {{
            for (i = 0; i < {up}_NX; ++i) {{
                dz[i] = NAN;
            }}
            return {up}_NONFINITE;
        }}
        {P}_set(dz, {_RADIN}, {_RIDEF}, {P}_rad_input[k1 - 1]);
        {P}_set(dz, {_RAD}, {_RDEF}, {P}_rad_state[k1]);
        {P}_set(dz, {_V}, {_VDEF}, NAN);
    }}
"""
        notes.append(("radii", f"given ({radii.label}): {ns} state and {ni} input radii as tables; "
                               f"steady {radii.state_steady:.6g} (state), {radii.input_steady:.6g} (input)"))
        return consts, code, notes
    code = f"""\
    {P}_set(dz, {_RAD}, {_RDEF}, NAN);
    {P}_set(dz, {_RADIN}, {_RIDEF}, NAN);
    {P}_set(dz, {_V}, {_VDEF}, NAN);
"""
    notes.append(("radii", "none (a given gain without radii: the radii are undefined, NaN in Python)"))
    return "", code, notes


def generate_setvalued(observer: Any, prefix: str) -> CProgram:
    """The :class:`CProgram` of a :class:`~nlobs.observers.setvalued.SetValuedObserver` (module docstring).

    Parameters
    ----------
    observer : SetValuedObserver
        Algorithm 1 with a certified design or a given gain.
    prefix : str
        A C identifier.

    Raises
    ------
    InvalidArgumentError
        Run-time LPV weights, or a nonlinear part without expressions (a plain Python callable).
    ModelError
        An expression of ``φ`` has no C99 form.
    """
    from nlobs.synthesis.setvalued import SetValuedDesign

    s = observer.system
    P, up = prefix, prefix.upper()
    O = f"{up}_OFF"
    if observer.lpv_weights:
        raise InvalidArgumentError(f"{s.name}: Algorithm 1 with run-time LPV weights (lpv_weights=True) is not "
                                   "exported; export the design with the Lipschitz multiplier (lpv='lipschitz')")
    phi = None
    if s.phi is not None:
        phi = require_source(s.phi, f"{s.name}: the nonlinear part phi (a Python callable; build the system with "
                                     "DiscreteUISystem.from_symbolic or from a model file)")
        if len(phi.arguments) != 1 or len(phi.arguments[0]) != s.n or len(phi.expressions) != s.n:
            raise InvalidArgumentError(f"{s.name}: phi's compiled function is not one map of the {s.n} states")
    tr, Lt = observer.design.transform, np.asarray(observer.design.gain, dtype=float)
    n, m, l, p = s.n, s.m, s.l, s.p
    l1, l2 = tr.U1.shape[1], tr.U2.shape[1]
    p1, p2 = tr.M1.shape[0], tr.M2.shape[0]
    off = n + p1 + p
    n_z = off + _N_SCALARS
    mats = {"U1": tr.U1, "U2": tr.U2, "C1": tr.C1, "C2": tr.C2, "D1": tr.D1, "D2": tr.D2, "M1": tr.M1,
            "M2": tr.M2, "V1": tr.V1, "V2": tr.V2, "G1": tr.G1, "G2": tr.G2, "Lt": Lt, "A": s.A, "B": s.B}
    body = "".join(static_array(f"{P}_{k}", v) for k, v in mats.items())
    body += f"#define {O} {off}   /* the scalars after x_hat, d1_hat, d_hat */\n\n"
    if phi is not None:
        body += static_function(f"{P}_phi", phi, ("z",), f"{s.name}: phi") + "\n"
    rconsts, rcode, rnotes = _radii_c(observer, P, up, O)
    body += rconsts + "\n"
    getter = (f"""\
/* a radius or V: stored finite with flag 1; NaN (undefined), +inf, -inf as 0 with flag 0, 2, 3 */
static double {P}_get(const double *z, int i, int flag)
{{
    const double f = z[{O} + flag];
    return f == 1.0 ? z[{O} + i] : (f == 2.0 ? INFINITY : (f == 3.0 ? -INFINITY : NAN));
}}

""" if f"{P}_get(" in rcode else "")
    phi_add = f"    {P}_phi(z, ph);\n    for (i = 0; i < {n}; ++i) {{\n        fx[i] = fx[i] + ph[i];\n    }}\n" \
        if phi is not None else ""
    body += f"""\
{getter}static void {P}_set(double *z, int i, int flag, double v)
{{
    if (v - v == 0.0) {{
        z[{O} + i] = v;
        z[{O} + flag] = 1.0;
    }} else {{
        z[{O} + i] = 0.0;
        z[{O} + flag] = v > 0.0 ? 2.0 : (v < 0.0 ? 3.0 : 0.0);
    }}
}}

/* make the centre NaN: what the Python observer raises on (module docstring) */
static int {P}_fail(double *z)
{{
    int i;
    for (i = 0; i < {up}_NX; ++i) {{
        z[i] = NAN;
    }}
    return {up}_NONFINITE;
}}

/* time update (13): x_hat_k+1|k = f(x_hat_k|k) + B u_k + G1 d1_hat_k, f(x) = A x + phi(x); the radii of k + 1 */
static int {P}_rhs_(double t, const double *z, const double *u, const double *y, double *dz)
{{
    double fx[{n}], ph[{n}];
    int i, j;
    (void)t;
    (void)y;
    (void)ph;
    for (i = 0; i < {up}_NZ; ++i) {{
        dz[i] = z[i];
    }}
    if (z[{O} + {_CORR}] == 0.0) {{
        return {P}_fail(dz);  /* Algorithm 1 needs the measurement of every step */
    }}
{_matvec("fx", f"{P}_A", n, n, "z")}{phi_add}    for (i = 0; i < {n}; ++i) {{
        double bu = 0.0, gd = 0.0;
        for (j = 0; j < {m}; ++j) {{
            bu += u[j] * {P}_B[i * {max(m, 1)} + j];
        }}
        for (j = 0; j < {p1}; ++j) {{
            gd += z[{n} + j] * {P}_G1[i * {max(p1, 1)} + j];
        }}
        dz[i] = (fx[i] + bu) + gd;
    }}
{rcode}    dz[{O} + {_K}] = z[{O} + {_K}] + 1.0;
    dz[{O} + {_CORR}] = 0.0;
    return {up}_OK;
}}

/* the measurement part: (11), (12), (14), (15) from x_hat_k|k-1, then (10); at step 0 only (10) */
static int {P}_correct_(double t, double *z, const double *u, const double *y, const unsigned char *fresh)
{{
    double z1[{max(l1, 1)}], z2[{max(l2, 1)}], e1[{max(l1, 1)}], e2[{max(l2, 1)}], d2[{max(p2, 1)}];
    double xs[{n}], xh[{n}];
    int i, j;
    (void)t;
    for (j = 0; j < {l}; ++j) {{
        if (!fresh[j] || !(y[j] - y[j] == 0.0)) {{
            return {P}_fail(z);  /* Algorithm 1 needs every output, finite, at every step */
        }}
    }}
{_vecmat("z1", f"{P}_U1", l, l1, "y")}{_vecmat("z2", f"{P}_U2", l, l2, "y")}    if (z[{O} + {_K}] < 0.0) {{
        /* step 0: x_hat_0|0 is given, only (10) */
{_residual("e1", "z1", f"{P}_C1", f"{P}_D1", l1, n, m, "z", indent="        ")}\
{_matvec(f"(z + {n})", f"{P}_M1", p1, l1, "e1", indent="        ")}\
        z[{O} + {_K}] = 0.0;
        z[{O} + {_CORR}] = 1.0;
        return {up}_OK;
    }}
    if (z[{O} + {_CORR}] != 0.0) {{
        return {P}_fail(z);  /* this step was already corrected */
    }}
    /* (11) d2_hat = M2 (z2 - C2 x_p - D2 u) */
{_residual("e2", "z2", f"{P}_C2", f"{P}_D2", l2, n, m, "z")}{_matvec("d2", f"{P}_M2", p2, l2, "e2")}\
    /* (12) d_hat = V1 d1_hat + V2 d2_hat */
    for (i = 0; i < {p}; ++i) {{
        double a = 0.0, b = 0.0;
        for (j = 0; j < {p1}; ++j) {{
            a += z[{n} + j] * {P}_V1[i * {max(p1, 1)} + j];
        }}
        for (j = 0; j < {p2}; ++j) {{
            b += d2[j] * {P}_V2[i * {max(p2, 1)} + j];
        }}
        z[{n + p1} + i] = a + b;
    }}
    z[{O} + {_DDEF}] = 1.0;
    /* (14) x_star = x_p + G2 d2_hat */
    for (i = 0; i < {n}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {p2}; ++j) {{
            acc += d2[j] * {P}_G2[i * {max(p2, 1)} + j];
        }}
        xs[i] = z[i] + acc;
    }}
    /* (15) x_hat_k|k = x_star + L~ (z2 - C2 x_star - D2 u) */
{_residual("e2", "z2", f"{P}_C2", f"{P}_D2", l2, n, m, "xs")}    for (i = 0; i < {n}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {l2}; ++j) {{
            acc += e2[j] * {P}_Lt[i * {max(l2, 1)} + j];
        }}
        xh[i] = xs[i] + acc;
    }}
    for (i = 0; i < {n}; ++i) {{
        z[i] = xh[i];
    }}
    /* (10) d1_hat = M1 (z1 - C1 x_hat - D1 u) */
{_residual("e1", "z1", f"{P}_C1", f"{P}_D1", l1, n, m, "z")}{_matvec(f"(z + {n})", f"{P}_M1", p1, l1, "e1")}\
    z[{O} + {_CORR}] = 1.0;
    return {up}_OK;
}}

/* x_hat_0|0 = x_hat0, radius delta_0 (d_hat and the input radius undefined before the first step) */
static int {P}_init_(const double *xhat0, double *z)
{{
    int i;
    for (i = 0; i < {up}_NZ; ++i) {{
        z[i] = 0.0;
    }}
    for (i = 0; i < {n}; ++i) {{
        z[i] = xhat0[i];
    }}
    z[{O} + {_K}] = -1.0;
{_init_radii(observer, P)}    return {P}_finite(z, {up}_NZ) ? {up}_OK : {up}_NONFINITE;
}}

#undef {O}
"""
    design = observer.design
    notes: list[tuple[str, str]] = [
        ("model", f"{s.name}: n = {n} states, l = {l} outputs, p = {p} unknown inputs, m = {m} known inputs, "
                  f"dt = {s.time.dt:.17g}"),
        ("observer", "Algorithm 1 of Khajenejad & Yong, (10)-(15): centres and radii; x_hat = z[0:n]"),
        ("phi", "printed from the model's expressions" if phi is not None else "none (phi = 0)"),
        ("function class", f"{s.function_class.label}, gamma = {s.function_class.gamma:.17g}"),
        ("noise bounds", f"eta_w = {s.eta_w:.17g}, eta_v = {s.eta_v:.17g}, delta_0 = {s.delta0:.17g}"),
        ("gain L~", matrix_note(Lt)),
        ("state layout", f"x_hat[{n}], d1_hat[{p1}], d_hat[{p}], k, corrected, radius, radius_input, V, "
                         "and the flags d_hat, radius, radius_input, V defined"),
        ("arithmetic", "plain IEEE double, as the Python observer (no outward rounding)"),
    ]
    if isinstance(design, SetValuedDesign):
        vals = ", ".join(f"{k} = {_num(getattr(design, k, None))}" for k in ("rho", "lam", "lam_eff", "c", "kappa"))
        objective = getattr(design.objective, "value", design.objective)
        notes += [("design", f"objective {objective}, verified {design.verified}, {vals}"),
                  ("steady radius", f"{_num(design.steady_radius)} (of the design)"),
                  ("P", matrix_note(design.P))]
    else:
        notes.append(("design", "a given gain L~ (not designed by nlobs, no certificate)"))
    notes += rnotes
    return CProgram(prefix=P, title=f"Set-valued input and state observer (Khajenejad & Yong) of {s.name}",
                    n_z=n_z, n_x=n, n_u=observer.m, n_y=l, discrete=True, body=body, correcting=True,
                    own_init=True, own_estimate=False, notes=tuple(notes), codec=codec(n, p1, p),
                    dt=float(s.time.dt))


def _num(v: Any) -> str:
    """A number of the header (``-`` where the design has none)."""
    return "-" if v is None else f"{float(v):.17g}"


def _init_radii(observer: Any, observer_prefix: str) -> str:
    """The initial radius and ``V̄_0`` of :meth:`SetValuedObserver.init` (computed in Python: a constant)."""
    z0 = observer.init(np.zeros(observer.system.n))
    lines = []
    if not math.isnan(z0.radius):
        lines.append(f"    {observer_prefix}_set(z, {_RAD}, {_RDEF}, {_lit(z0.radius)});")
    if not math.isnan(z0.V):
        lines.append(f"    {observer_prefix}_set(z, {_V}, {_VDEF}, {_lit(z0.V)});")
    return "".join(ln + "\n" for ln in lines)
