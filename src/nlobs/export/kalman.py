r"""C for the extended Kalman filter of any plant (:class:`~nlobs.observers.ekf.EKF`).

The generated module's state is the filter's ``(x̂, P, NIS)``: ``n + n² + 1`` values of one run, ``P`` row-major.
It is a *correcting* module (:mod:`nlobs.export.program`) with the equations of :mod:`nlobs.observers.ekf`:

* ``P_rhs_`` — a continuous plant: Jazwinski's moment equations ``x̂' = f(x̂, u)``, ``P' = F P + (F P)ᵀ + Q``
  with ``F = ∂f/∂x(x̂, u)`` (the NIS is constant between samples), integrated by the common RK4 step, stage for
  stage as :func:`~nlobs.simulate.integrators.rk4_step`; a discrete plant: the prediction ``x̂⁺ = f(x̂, u)``,
  ``P⁺ = (F P Fᵀ + Q)`` symmetrised;
* ``P_correct_`` — the outputs ``J`` with ``fresh[j]`` set and a finite sample (a missing sample is skipped, as
  the Python filter does for that run): ``ν = y_J − h_J(x̂, u)``, ``S = H_J P H_Jᵀ + R_JJ``, ``K = P H_Jᵀ S⁻¹``,
  ``x̂ ← x̂ + K ν``, ``P ← (I − K H_J) P (I − K H_J)ᵀ + K R_JJ Kᵀ`` symmetrised (Joseph form), ``NIS = νᵀ S⁻¹ ν``;
  ``S`` is inverted by Gauss–Jordan elimination with partial pivoting (an exact zero pivot, or a non-finite ``S``,
  is ``P_SINGULAR``: the Python filter reports it as a diverged filter);
* ``P_init_`` — ``x̂ = x̂0``, ``P = P0`` (the filter's), ``NIS = 0``; ``P_estimate_`` — ``x̂``.

``f``, ``h`` and their Jacobians are printed from the expressions the model was compiled from (a compiled
:class:`~nlobs.systems.symbolic.SymbolicModel`), or are the constant matrices of a linear system; any other plant is
refused with :class:`~nlobs.errors.InvalidArgumentError`. No user text reaches the C but through SymPy's printer.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nlobs.errors import InvalidArgumentError
from nlobs.export.pieces import affine_function, invert_c, matrix_note, require_source, static_array, static_function
from nlobs.export.program import CProgram, StateCodec

__all__ = ["filter_codec", "filter_init_c", "generate_ekf", "joseph_c", "model_c"]


def _constant(name: str, M: np.ndarray) -> str:
    """``static void name(x, u, out)``: the constant matrix ``M`` (a linear system's Jacobian), row-major."""
    flat = np.asarray(M, dtype=float).ravel()
    return static_array(f"{name}_K", flat.reshape(1, -1)) + f"""\
static void {name}(const double *x, const double *u, double *out)
{{
    int i;
    (void)x;
    (void)u;
    for (i = 0; i < {flat.size}; ++i) {{
        out[i] = {name}_K[i];
    }}
}}
"""


def model_c(plant: Any, P: str, n: int, m: int, p: int, *, jacobians: bool = True) -> tuple[str, str]:
    """``P_f``, ``P_h`` and, with ``jacobians``, ``P_F`` (``∂f/∂x``) and ``P_H`` (``∂h/∂x``) as static C functions.

    Parameters
    ----------
    plant : SymbolicModel or linear system
        A compiled symbolic model (its expressions are printed) or a system with matrices ``A, B, C, D``.
    P : str
        The module's C prefix.
    n, m, p : int
        States, inputs, outputs.
    jacobians : bool
        Also the Jacobians (the EKF; the UKF needs ``f`` and ``h`` only).

    Returns
    -------
    (str, str)
        The C definitions (each ``static void name(const double *x, const double *u, double *out)``) and the
        model's line of the header.

    Raises
    ------
    InvalidArgumentError
        The plant has no expressions to print, or its matrices have the wrong shapes.
    """
    if hasattr(plant, "A") and hasattr(plant, "C") and not hasattr(plant, "_rhs"):
        A, B, C, D = (np.asarray(M, dtype=float) for M in (plant.A, plant.B, plant.C, plant.D))
        if A.shape != (n, n) or C.shape != (p, n) or B.shape != (n, m) or D.shape != (p, m):
            raise InvalidArgumentError(f"A, B, C, D of shapes {A.shape}, {B.shape}, {C.shape}, {D.shape}; "
                                       f"expected {(n, n)}, {(n, m)}, {(p, n)}, {(p, m)}")
        defs = affine_function(f"{P}_f", A, B, n, n, m) + affine_function(f"{P}_h", C, D, p, n, m)
        if not jacobians:
            return defs, "linear: f = A x + B u, h = C x + D u (the model's matrices)"
        defs += _constant(f"{P}_F", A) + _constant(f"{P}_H", C)
        return defs, "linear: f = A x + B u, h = C x + D u, F = A, H = C (the model's matrices)"
    name = getattr(plant, "name", type(plant).__name__)
    wanted = (("f", "_rhs", "rhs"), ("F", "_rhs_x", "drhs/dx"), ("h", "_h", "h"), ("H", "_h_x", "dh/dx"))
    parts = {key: require_source(getattr(plant, attr, None), f"{name}.{what}")
             for key, attr, what in wanted if jacobians or key in ("f", "h")}
    sizes = {"f": n, "F": n * n, "h": p, "H": p * n}
    for key, fn in parts.items():
        if len(fn.expressions) != sizes[key]:
            raise InvalidArgumentError(f"{name}: {key} has {len(fn.expressions)} entries, expected {sizes[key]}")
    defs = "".join(static_function(f"{P}_{key}", fn, ("x", "u"), f"{name}.{key}") for key, fn in parts.items())
    return defs, (f"{name}: states {', '.join(plant.states)}; outputs {', '.join(plant.outputs)}; f, h"
                  + (" and their Jacobians" if jacobians else "") + " printed from the model's expressions")


def filter_codec(n: int) -> StateCodec:
    """``FilterState(x, P, nis)`` ↔ the flat ``[x, P (row-major), nis]`` of the C module.

    Parameters
    ----------
    n : int
        The plant's states.

    Returns
    -------
    StateCodec
    """
    from nlobs.observers.gaussian import FilterState

    def pack(z: Any) -> Any:
        x = np.asarray(z.x, dtype=float)
        batch = x.shape[:-1]
        P = np.broadcast_to(np.asarray(z.P, dtype=float), (*batch, n, n)).reshape(*batch, n * n)
        nis = np.broadcast_to(np.asarray(z.nis, dtype=float), batch)[..., None]
        return np.concatenate([x, P, nis], axis=-1)

    def unpack(flat: Any) -> Any:
        f = np.asarray(flat, dtype=float)
        nis = f[..., n + n * n]
        return FilterState(np.array(f[..., :n]), np.array(f[..., n:n + n * n]).reshape(*f.shape[:-1], n, n),
                           np.float64(nis) if nis.ndim == 0 else np.array(nis))

    return StateCodec(pack=pack, unpack=unpack)


def filter_init_c(P: str, n: int) -> str:
    """``static int P_init_(xhat0, z)``: ``x̂ = x̂0``, ``P = P0`` (the static array ``P_P0``), ``NIS = 0``.

    Parameters
    ----------
    P : str
        The module's C prefix.
    n : int
        The plant's states.

    Returns
    -------
    str
        The static C function (after a blank line).
    """
    N2 = n * n
    return f"""
static int {P}_init_(const double *xhat0, double *z)
{{
    int i;
    for (i = 0; i < {n}; ++i) {{
        z[i] = xhat0[i];
    }}
    for (i = 0; i < {N2}; ++i) {{
        z[{n} + i] = {P}_P0[i];
    }}
    z[{n + N2}] = 0.0;
    return 0;
}}
"""


def joseph_c(P: str, n: int, p: int) -> str:
    """``static int P_joseph(z, H, nu, Rq, q)``: the Joseph-form update of ``(x̂, P, NIS)`` in ``z`` (module docstring).

    Parameters
    ----------
    P : str
        The module's C prefix.
    n, p : int
        States, and the most outputs an update takes.

    Returns
    -------
    str
        ``P_invert`` and ``P_joseph`` (0, or 1 for a singular ``S``, 2 for a non-finite NIS).
    """
    N2, pp = n * n, max(p, 1)
    return invert_c(P, p) + f"""
/* the Joseph-form update of (x, P, NIS) in z with q outputs: H (q x n), innovation nu, noise covariance Rq (q x q);
   S = H P H' + Rq is inverted by Gauss-Jordan elimination with partial pivoting (1: S singular or not finite) */
static int {P}_joseph(double *z, const double *H, const double *nu, const double *Rq, int q)
{{
    double S[{pp * pp}], Si[{pp * pp}], PHt[{n * pp}], K[{n * pp}];
    double IKH[{N2}], A[{N2}], Pn[{N2}], w[{pp}], nis = 0.0;
    int i, j, k, r;
    double *Pm = z + {n};
    for (i = 0; i < {n}; ++i) {{ /* P H' */
        for (j = 0; j < q; ++j) {{
            double acc = 0.0;
            for (k = 0; k < {n}; ++k) {{
                acc += Pm[i * {n} + k] * H[j * {n} + k];
            }}
            PHt[i * q + j] = acc;
        }}
    }}
    for (i = 0; i < q; ++i) {{ /* S = H P H' + R_JJ, and the identity beside it */
        for (j = 0; j < q; ++j) {{
            double acc = 0.0;
            for (k = 0; k < {n}; ++k) {{
                acc += H[i * {n} + k] * PHt[k * q + j];
            }}
            S[i * q + j] = acc + Rq[i * q + j];
        }}
    }}
    if ({P}_invert(S, Si, q)) {{ /* S^-1 in Si */
        return 1;
    }}
    for (i = 0; i < {n}; ++i) {{ /* K = P H' S^-1 */
        for (j = 0; j < q; ++j) {{
            double acc = 0.0;
            for (k = 0; k < q; ++k) {{
                acc += PHt[i * q + k] * Si[k * q + j];
            }}
            K[i * q + j] = acc;
        }}
    }}
    for (i = 0; i < q; ++i) {{ /* w = S^-1 nu, NIS = nu' w */
        double acc = 0.0;
        for (k = 0; k < q; ++k) {{
            acc += Si[i * q + k] * nu[k];
        }}
        w[i] = acc;
        nis += nu[i] * acc;
    }}
    for (i = 0; i < {n}; ++i) {{ /* I - K H */
        for (j = 0; j < {n}; ++j) {{
            double acc = 0.0;
            for (k = 0; k < q; ++k) {{
                acc += K[i * q + k] * H[k * {n} + j];
            }}
            IKH[i * {n} + j] = (i == j ? 1.0 : 0.0) - acc;
        }}
    }}
    for (i = 0; i < {n}; ++i) {{ /* A = (I - K H) P */
        for (j = 0; j < {n}; ++j) {{
            double acc = 0.0;
            for (k = 0; k < {n}; ++k) {{
                acc += IKH[i * {n} + k] * Pm[k * {n} + j];
            }}
            A[i * {n} + j] = acc;
        }}
    }}
    for (i = 0; i < {n}; ++i) {{ /* x += P H' w */
        double acc = 0.0;
        for (k = 0; k < q; ++k) {{
            acc += PHt[i * q + k] * w[k];
        }}
        z[i] += acc;
    }}
    for (i = 0; i < {n}; ++i) {{ /* P = A (I - K H)' + (K R_JJ) K', then symmetrised */
        for (j = 0; j < {n}; ++j) {{
            double acc = 0.0, kr = 0.0;
            for (k = 0; k < {n}; ++k) {{
                acc += A[i * {n} + k] * IKH[j * {n} + k];
            }}
            for (k = 0; k < q; ++k) {{
                double krk = 0.0;
                for (r = 0; r < q; ++r) {{
                    krk += K[i * q + r] * Rq[r * q + k];
                }}
                kr += krk * K[j * q + k];
            }}
            Pn[i * {n} + j] = acc + kr;
        }}
    }}
    for (i = 0; i < {n}; ++i) {{
        for (j = 0; j < {n}; ++j) {{
            Pm[i * {n} + j] = (Pn[i * {n} + j] + Pn[j * {n} + i]) * 0.5;
        }}
    }}
    z[{n + N2}] = nis;
    return nis - nis == 0.0 ? 0 : 2;
}}
"""


def generate_ekf(obs: Any, prefix: str) -> CProgram:
    """The :class:`CProgram` of an :class:`~nlobs.observers.ekf.EKF` (module docstring).

    Parameters
    ----------
    obs : EKF
        The filter, of a continuous or a discrete plant.
    prefix : str
        A C identifier.

    Returns
    -------
    CProgram

    Raises
    ------
    InvalidArgumentError
        The plant has no expressions to print (neither a compiled symbolic model nor a linear system).
    ModelError
        An expression has no C99 form.
    """
    P = prefix
    plant = obs.plant
    n, p = int(obs.n), int(obs.p)
    m = len(getattr(plant, "inputs", ()))
    Q, R, P0 = (np.asarray(M, dtype=float) for M in (obs.Q, obs.R, obs.P0))
    defs, model_note = model_c(plant, P, n, m, p)
    N2 = n * n
    fp = f"""
/* F P, both n x n row-major */
static void {P}_FP(const double *F, const double *Pm, double *FP)
{{
    int i, j, k;
    for (i = 0; i < {n}; ++i) {{
        for (j = 0; j < {n}; ++j) {{
            double acc = 0.0;
            for (k = 0; k < {n}; ++k) {{
                acc += F[i * {n} + k] * Pm[k * {n} + j];
            }}
            FP[i * {n} + j] = acc;
        }}
    }}
}}
"""
    if obs.discrete:
        what = "the prediction of a discrete plant: x+ = f(x, u), P+ = (F P F' + Q) symmetrised; the NIS is kept"
        covariance = f"""    for (i = 0; i < {n}; ++i) {{
        for (j = 0; j < {n}; ++j) {{
            double acc = 0.0;
            for (k = 0; k < {n}; ++k) {{
                acc += FP[i * {n} + k] * F[j * {n} + k];
            }}
            M[i * {n} + j] = acc + {P}_Q[i * {n} + j];
        }}
    }}
    for (i = 0; i < {n}; ++i) {{
        for (j = 0; j < {n}; ++j) {{
            dz[{n} + i * {n} + j] = (M[i * {n} + j] + M[j * {n} + i]) * 0.5;
        }}
    }}
    dz[{n + N2}] = z[{n + N2}];"""
        locals_ = f"double F[{N2}], FP[{N2}], M[{N2}];\n    int i, j, k;"
    else:
        what = ("the moment equations of a continuous plant (Jazwinski, section 8.3): x' = f(x, u),\n"
                "   P' = F P + (F P)' + Q, F = df/dx(x, u); the NIS is constant between samples")
        covariance = f"""    for (i = 0; i < {n}; ++i) {{
        for (j = 0; j < {n}; ++j) {{
            dz[{n} + i * {n} + j] = FP[i * {n} + j] + FP[j * {n} + i] + {P}_Q[i * {n} + j];
        }}
    }}
    dz[{n + N2}] = 0.0;"""
        locals_ = f"double F[{N2}], FP[{N2}];\n    int i, j;"
    predict = fp + f"""
/* {what} */
static int {P}_rhs_(double t, const double *z, const double *u, const double *y, double *dz)
{{
    {locals_}
    (void)t;
    (void)y;
    {P}_f(z, u, dz);
    {P}_F(z, u, F);
    {P}_FP(F, z + {n}, FP);
{covariance}
    return 0;
}}
"""
    pp = max(p, 1)
    body = (static_array(f"{P}_Q", Q) + static_array(f"{P}_R", R) + static_array(f"{P}_P0", P0) + defs + predict
            + joseph_c(P, n, p) + filter_init_c(P, n) + f"""
static void {P}_estimate_(const double *z, double *xhat)
{{
    int i;
    for (i = 0; i < {n}; ++i) {{
        xhat[i] = z[i];
    }}
}}

/* at a sample: the Joseph-form update with the outputs J (fresh and finite) */
static int {P}_correct_(double t, double *z, const double *u, const double *y, const unsigned char *fresh)
{{
    double hx[{pp}], Hx[{pp * n}], H[{pp * n}], nu[{pp}], Rq[{pp * pp}];
    int rows[{pp}], q = 0, i, j, k;
    (void)t;
    {P}_h(z, u, hx);
    {P}_H(z, u, Hx);
    for (j = 0; j < {p}; ++j) {{
        if (fresh[j] && y[j] - y[j] == 0.0) {{
            rows[q] = j;
            nu[q] = y[j] - hx[j];
            for (k = 0; k < {n}; ++k) {{
                H[q * {n} + k] = Hx[j * {n} + k];
            }}
            ++q;
        }}
    }}
    if (q == 0) {{
        return 0;
    }}
    for (i = 0; i < q; ++i) {{
        for (j = 0; j < q; ++j) {{
            Rq[i * q + j] = {P}_R[rows[i] * {p} + rows[j]];
        }}
    }}
    return {P}_joseph(z, H, nu, Rq, q);
}}
""")
    names = ", ".join(obs.plant.states) if hasattr(obs.plant, "states") else f"{n} states"
    notes = (
        ("observer", "the extended Kalman filter: " + ("the prediction x+ = f(x, u), P+ = F P F' + Q of a discrete "
                     "plant" if obs.discrete else "Jazwinski's continuous-discrete EKF, x' = f(x, u),\n"
                     "P' = F P + (F P)' + Q between samples (RK4)") + ",\nand the Joseph-form update at each sample"),
        ("at each sample", f"call {P}_correct(t_k, z, u, y, fresh) with fresh[j] = 1 for every output j sampled\n"
                           "at t_k (a non-finite y_j is a missing sample: skipped), then "
                           f"{P}_step(t_k, z, u, y, h)"),
        ("state", f"[x_hat ({names}), P ({n} x {n}, row-major), NIS of the last update]"),
        ("model", model_note),
        ("Q", matrix_note(Q)),
        ("R", matrix_note(R)),
        ("P0", matrix_note(P0)),
    )
    name = getattr(plant, "name", None) or type(plant).__name__
    tb = obs.time
    return CProgram(prefix=P, title=f"Extended Kalman filter of {name}", n_z=n + N2 + 1, n_x=n, n_u=m, n_y=p,
                    discrete=bool(obs.discrete), body=body, correcting=True, own_init=True, own_estimate=True,
                    notes=notes, codec=filter_codec(n), dt=float(tb.dt) if obs.discrete else None,
                    status1="a singular innovation covariance S")

