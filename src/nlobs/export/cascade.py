r"""C for the cascade/feedback observer of Grip, Saberi & Johansen (:class:`~nlobs.observers.cascade.CascadeObserver`).

The observer state is ``z = [x̂, ŵ, ξ]`` (``n_x + n_w + p_z`` values), the estimate ``[x̂, ŵ]``.
``P_rhs_`` is (9)–(10) or, in the feedback case, (17)–(18), in the order of
:meth:`CascadeObserver.rhs <nlobs.observers.cascade.CascadeObserver.rhs>`:

* ``ẑ = h(u, [ŵ,] x̂) + ξ`` (9c)/(17d), ``ỹ = y − C ŵ − D_u u − D_z ẑ``;
* ``x̂̇ = f(u, [ŵ,] x̂) + g(u, x̂, [ŵ,] ẑ)`` (10)/(18);
* ``ŵ̇ = A ŵ + B_u u + B_z ẑ + K_w ỹ`` (9a)/(17a);
* ``ξ̇ = −∂_x h · g + K_z ỹ`` (9b), minus ``∂_w h · K_w ỹ`` in the feedback case (17b).

``P_step`` is the common RK4 with ``u`` and ``y`` held (the observer has no discretisation of its
own); ``P_init`` sets ``ξ₀ = 0`` (:meth:`CascadeObserver.init`), ``P_estimate`` returns
``[x̂, ŵ]``.

Σ₁'s ``f``, ``h``, ``g``, ``∂h/∂x`` (and ``∂h/∂w``) are printed from the SymPy expressions
:meth:`NonlinearSubsystem.symbolic <nlobs.systems.interconnected.NonlinearSubsystem.symbolic>`
compiled (every model file's ``[cascade]`` table builds it so); a Σ₁ built from NumPy callables
(:meth:`~nlobs.systems.interconnected.NonlinearSubsystem.numeric`) has no expressions and is not
exported. Σ₂'s matrices and the gain ``K = [K_w; K_z]`` are constant arrays.

Saturations. The observer itself saturates nothing; the saturations of Appendix A (the hard
``sat(ẑ)`` in ``g``, the smooth ``sat*`` of the design model ``f(u, sat*(x))``) are part of Σ₁'s
expressions when they are written there in SymPy (``Min``/``Max`` print as C99's ``fmin``/``fmax``,
``Piecewise`` as a conditional expression) and are exported with them; a saturation applied by a
NumPy callable (:class:`~nlobs.systems.saturation.Saturation`) is in a numeric Σ₁, which is refused.
(``fmin``/``fmax`` return the other argument where one is NaN, NumPy's ``minimum``/``maximum`` NaN.)

The header notes Σ₁/Σ₂, the gain and what this ``K`` gives the error (12a)/(20a): the spectral
abscissa of ``𝔄 − Kℭ`` and ``‖H‖∞`` of (13), recomputed from the observer (it holds ``K``, not the
certificate). :func:`design_notes` turns a :class:`~nlobs.workflows.design_cascade.CascadeDesign`
into the certificate lines (``γ``, ``‖H‖∞``, verified, Theorem 1) for ``generate(..., notes=...)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nlobs.errors import InvalidArgumentError
from nlobs.export.pieces import abscissa, matrix_note, require_source, static_array, static_function
from nlobs.export.program import CProgram

__all__ = ["design_notes", "generate_cascade"]

_RHS_SIG = "(double t, const double *z, const double *u, const double *y, double *dz)"


def _mv(P: str) -> str:
    return f"""\
/* out = M v, M r-by-c row-major, each entry summed left to right from 0 */
static void {P}_mv(int r, int c, const double *M, const double *v, double *out)
{{
    int i, j;
    for (i = 0; i < r; ++i) {{
        double acc = 0.0;
        for (j = 0; j < c; ++j) {{
            acc += M[i * c + j] * v[j];
        }}
        out[i] = acc;
    }}
}}
"""


def _hinf_note(obs: Any) -> str:
    """``‖H‖∞`` of (13) for the observer's ``K`` (grid safeguard), or why it is not given."""
    from nlobs.linear.assumption4 import extended_system
    from nlobs.linear.norms import hinf_norm

    s2 = obs.sigma2
    ext = extended_system(s2.A, s2.B_z, s2.C, s2.D_z)
    F = ext.A - np.asarray(obs.K, dtype=float) @ ext.C
    try:
        value = float(hinf_norm(F, ext.Bd, np.eye(F.shape[0]), np.zeros((F.shape[0], ext.Bd.shape[1])), grid=True))
    except Exception as exc:  # a note must not stop the export
        return f"not computed ({type(exc).__name__})"
    return f"{value:.6g} (H(s) = (sI - A_e + K C_e)^-1 B_d, (13); recomputed for this K)"


def generate_cascade(obs: Any, prefix: str) -> CProgram:
    """The :class:`CProgram` of a :class:`~nlobs.observers.cascade.CascadeObserver` (module docstring).

    Parameters
    ----------
    obs : CascadeObserver
        The observer (cascade or feedback form).
    prefix : str
        A C identifier.

    Raises
    ------
    InvalidArgumentError
        Σ₁ was built from NumPy callables (no expressions to print).
    ModelError
        An expression of Σ₁ has no C99 form.
    """
    s1, s2 = obs.sigma1, obs.sigma2
    P = prefix
    fb = bool(s1.feedback)
    nx, nw, pz, py, m = s1.n_x, s2.n_w, s2.p_z, s2.p_y, s1.m
    why = "a Σ1 built from NumPy callables (NonlinearSubsystem.numeric); build it with NonlinearSubsystem.symbolic"
    f = require_source(s1._f, f"{s1.name}.f: {why}")
    h = require_source(s1._h, f"{s1.name}.h: {why}")
    g = require_source(s1._g, f"{s1.name}.g: {why}")
    hx = require_source(s1._h_x, f"{s1.name}.dh/dx: {why}")
    hw = require_source(s1._h_w, f"{s1.name}.dh/dw: {why}") if fb else None
    grp = ("u", "w", "x") if fb else ("u", "x")
    body = "".join([
        static_function(f"{P}_f", f, grp, f"{s1.name}.f"),
        static_function(f"{P}_h", h, grp, f"{s1.name}.h"),
        static_function(f"{P}_g", g, ("u", "x", "w", "zh") if fb else ("u", "x", "zh"), f"{s1.name}.g"),
        static_function(f"{P}_hx", hx, grp, f"{s1.name}.dh/dx"),
        static_function(f"{P}_hw", hw, grp, f"{s1.name}.dh/dw") if hw is not None else "",
    ])
    Bu, Du = s2.input_matrices(m)
    K = np.asarray(obs.K, dtype=float)
    mats = {"A": s2.A, "Bu": Bu, "Bz": s2.B_z, "C": s2.C, "Du": Du, "Dz": s2.D_z, "Kw": K[:nw], "Kz": K[nw:]}
    if m == 0:  # no input: B_u u and D_u u are empty sums, left out (adding 0.0 changes nothing)
        del mats["Bu"], mats["Du"]
    body += "".join(static_array(f"{P}_{k}", v) for k, v in mats.items()) + "\n" + _mv(P)

    args = "u, wh, xh" if fb else "u, xh"
    uterm = m > 0
    lines = [
        f"    const double *xh = z, *wh = z + {nx}, *xi = z + {nx + nw};",
        f"    double zh[{pz}], yt[{py}], gg[{nx}], hx[{pz * nx}], a[{max(nw, pz, py)}], b[{max(nw, pz, py)}];",
        f"    double kwy[{nw}]{f', hw[{pz * nw}]' if fb else ''};",
        "    int i;",
        "    (void)t;",
        "    /* z_hat = h(u, [w_hat,] x_hat) + xi  (9c)/(17d) */",
        f"    {P}_h({args}, zh);",
        f"    for (i = 0; i < {pz}; ++i) {{\n        zh[i] = zh[i] + xi[i];\n    }}",
        "    /* y_tilde = ((y - C w_hat) - D_u u) - D_z z_hat */",
        f"    {P}_mv({py}, {nw}, {P}_C, wh, a);",
        f"    for (i = 0; i < {py}; ++i) {{\n        yt[i] = y[i] - a[i];\n    }}",
    ]
    if uterm:
        lines += [f"    {P}_mv({py}, {m}, {P}_Du, u, a);",
                  f"    for (i = 0; i < {py}; ++i) {{\n        yt[i] = yt[i] - a[i];\n    }}"]
    lines += [
        f"    {P}_mv({py}, {pz}, {P}_Dz, zh, a);",
        f"    for (i = 0; i < {py}; ++i) {{\n        yt[i] = yt[i] - a[i];\n    }}",
        "    /* x_hat' = f + g(u, x_hat, [w_hat,] z_hat)  (10)/(18) */",
        f"    {P}_g(u, xh, {'wh, ' if fb else ''}zh, gg);",
        f"    {P}_f({args}, dz);",
        f"    for (i = 0; i < {nx}; ++i) {{\n        dz[i] = dz[i] + gg[i];\n    }}",
        "    /* w_hat' = ((A w_hat + B_u u) + B_z z_hat) + K_w y_tilde  (9a)/(17a) */",
        f"    {P}_mv({nw}, {nw}, {P}_A, wh, dz + {nx});",
    ]
    if uterm:
        lines += [f"    {P}_mv({nw}, {m}, {P}_Bu, u, a);",
                  f"    for (i = 0; i < {nw}; ++i) {{\n        dz[{nx} + i] = dz[{nx} + i] + a[i];\n    }}"]
    lines += [
        f"    {P}_mv({nw}, {pz}, {P}_Bz, zh, a);",
        f"    {P}_mv({nw}, {py}, {P}_Kw, yt, kwy);",
        f"    for (i = 0; i < {nw}; ++i) {{\n        dz[{nx} + i] = (dz[{nx} + i] + a[i]) + kwy[i];\n    }}",
        "    /* xi' = -(dh/dx g) + K_z y_tilde  (9b); feedback: - dh/dw (K_w y_tilde)  (17b) */",
        f"    {P}_hx({args}, hx);",
        f"    {P}_mv({pz}, {nx}, hx, gg, a);",
        f"    {P}_mv({pz}, {py}, {P}_Kz, yt, b);",
        f"    for (i = 0; i < {pz}; ++i) {{\n        dz[{nx + nw} + i] = -a[i] + b[i];\n    }}",
    ]
    if fb:
        lines += [
            f"    {P}_hw({args}, hw);",
            f"    {P}_mv({pz}, {nw}, hw, kwy, a);",
            f"    for (i = 0; i < {pz}; ++i) {{\n        dz[{nx + nw} + i] = dz[{nx + nw} + i] - a[i];\n    }}",
        ]
    lines.append("    return 0;")
    body += f"\nstatic int {P}_rhs_{_RHS_SIG}\n{{\n" + "\n".join(lines) + "\n}\n"
    nxe = nx + nw
    body += f"""
/* xi_0 = 0: z_hat_0 = h(u_0, [w_hat_0,] x_hat_0) */
static int {P}_init_(const double *xhat0, double *z)
{{
    int i;
    for (i = 0; i < {nxe}; ++i) {{
        z[i] = xhat0[i];
    }}
    for (i = {nxe}; i < {nxe + pz}; ++i) {{
        z[i] = 0.0;
    }}
    return {P}_finite(z, {nxe + pz}) ? 0 : 2;
}}

static void {P}_estimate_(const double *z, double *xhat)
{{
    int i;
    for (i = 0; i < {nxe}; ++i) {{
        xhat[i] = z[i];
    }}
}}
"""
    form = "feedback Sigma1* <-> Sigma2, (17)-(18)" if fb else "cascade Sigma1 -> Sigma2, (9)-(10)"
    notes = (
        ("model", f"{s1.name}: {form}"),
        ("Sigma1", f"x = [{', '.join(s1.states)}], u = [{', '.join(s1.inputs)}], "
                   f"z = [{', '.join(s1.outputs)}] (not measured)"),
        ("Sigma2", f"w = [{', '.join(s2.states)}], y = [{', '.join(s2.outputs)}]"),
        ("state", f"[{', '.join(obs.state_names)}]; estimate the first {nxe}"),
        ("observer", "z_hat = h + xi, y~ = y - C w_hat - D_u u - D_z z_hat, x_hat' = f + g(z_hat), "
                     "w_hat' = A w_hat + B_u u + B_z z_hat + K_w y~, xi' = -dh/dx g + K_z y~"
                     + (" - dh/dw K_w y~" if fb else "")),
        ("gain K = [K_w; K_z]", matrix_note(K)),
        ("A_e - K C_e", f"spectral abscissa {abscissa(obs.error_matrix, False):.6g}"),
        ("||H||inf", _hinf_note(obs)),
    )
    return CProgram(prefix=P, title=f"Cascade observer (Grip, Saberi & Johansen) of {s1.name}",
                    n_z=nxe + pz, n_x=nxe, n_u=m, n_y=py, discrete=False, body=body, own_init=True,
                    own_estimate=True, notes=notes)


def design_notes(design: Any) -> tuple[tuple[str, str], ...]:
    """Header lines for the certificate of a :class:`~nlobs.methods.cascade.CascadeDesign`.

    Parameters
    ----------
    design : CascadeDesign
        What :func:`nlobs.workflows.design_cascade.design_cascade` returned (with a gain).

    Returns
    -------
    tuple of (str, str)
        ``γ`` and the method, the certificate's verdict, the re-verification checks, Theorem 1 and
        the status, for :func:`nlobs.export.generate.generate`'s ``notes``.

    Raises
    ------
    InvalidArgumentError
        The design has no gain.
    """
    cert = getattr(design, "certificate", None)
    if cert is None:
        raise InvalidArgumentError(f"no gain to export: {getattr(design, 'failure', '')}")
    cascade = getattr(design, "cascade", None)
    out = [("design model", str(getattr(cascade, "name", "?"))),
           ("design", f"method {design.method}, ||H||inf < gamma = {design.gamma:.17g}"),
           ("certificate", f"{'verified' if cert.verified else 'NOT verified'}")]
    out += [(f"check {c.name}", f"{'passed' if c.passed else 'FAILED'}: {c.evidence}") for c in design.checks]
    t1 = design.theorem1
    if t1 is not None:
        out.append((t1.theorem, t1.reason))
    out.append(("status", design.status))
    return tuple(out)
