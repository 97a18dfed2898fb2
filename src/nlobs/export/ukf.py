r"""C for the unscented Kalman filter of any plant (:class:`~nlobs.observers.ukf.UKF`).

The module's state is the filter's ``(x̂, P, NIS)``, ``n + n² + 1`` values of one run as for the EKF
(:mod:`nlobs.export.kalman`), with the equations of :mod:`nlobs.observers.ukf`:

* the sigma points ``𝒳₀ = m``, ``𝒳_{±i} = m ± √(n + λ) S_{:, i}`` (Julier & Uhlmann; the scaled form of Wan &
  van der Merwe), ``S`` the Cholesky factor of the symmetrised ``P``; where the factorisation fails (``P``
  singular, or made slightly indefinite by rounding) ``S = V diag(√max(λᵢ, 0))`` from ``P = V Λ Vᵀ``
  (cyclic Jacobi rotations);
* ``P_rhs_`` — a continuous plant: Särkkä's moment equations ``ṁ = f(𝒳) w_m``,
  ``Ṗ = Σᵢ w^c_i (𝒳ᵢ − m)(fᵢ − f̄)ᵀ + (…)ᵀ + Q``, the sigma points drawn again at every stage of the common RK4
  step; a discrete plant: the unscented transform of ``f`` plus ``Q``, symmetrised;
* ``P_correct_`` — the outputs ``J`` with ``fresh[j]`` set and a finite sample: ``𝒴 = h_J(𝒳)``, ``ŷ``,
  ``P_xy``, ``P_yy``; the statistical linearisation ``H = P_xyᵀ P⁺`` (``P⁺`` the pseudo-inverse of the
  symmetrised ``P``, eigenvalues below ``10⁻¹⁵`` of the largest dropped, as NumPy's ``pinv``) and the effective
  noise ``R_eff = R_JJ + P_yy − H P Hᵀ`` symmetrised; then the Joseph-form update of the EKF's module
  (:func:`nlobs.export.kalman.joseph_c`), ``S`` inverted by Gauss–Jordan elimination (a singular or non-finite
  ``S`` is ``P_SINGULAR``: the Python filter reports it as a diverged filter).

The products sum in index order where NumPy calls BLAS and LAPACK (Cholesky, ``eigh``, ``inv``), so the module
equals the Python filter to rounding, not bit for bit. One case can differ by more: a singular ``P`` whose
nonzero eigenvalues repeat (a degenerate eigenspace has no preferred basis, and Jacobi rotations and LAPACK
pick different ones: different, equally valid sigma points). A diagonal ``P`` gives both the same.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nlobs.export.cprint import c_double
from nlobs.export.kalman import filter_codec, filter_init_c, joseph_c, model_c
from nlobs.export.pieces import matrix_note, static_array
from nlobs.export.program import CProgram

__all__ = ["generate_ukf"]


def _linalg_c(P: str, n: int) -> str:
    """``P_eigh`` (cyclic Jacobi), ``P_sqrt`` (Cholesky, else the eigen square root) and ``P_sigma``."""
    L = 2 * n + 1
    return f"""
/* the eigen-decomposition A = V diag(lam) V' of a symmetric n x n matrix by cyclic Jacobi rotations (A is
   overwritten; the columns of V are the eigenvectors) */
static void {P}_eigh(double *A, double *lam, double *V)
{{
    int i, j, k, sweep;
    for (i = 0; i < {n}; ++i) {{
        for (j = 0; j < {n}; ++j) {{
            V[i * {n} + j] = i == j ? 1.0 : 0.0;
        }}
    }}
    for (sweep = 0; sweep < 100; ++sweep) {{
        double off = 0.0;
        for (i = 0; i < {n}; ++i) {{
            for (j = i + 1; j < {n}; ++j) {{
                off += A[i * {n} + j] * A[i * {n} + j];
            }}
        }}
        if (!(off > 0.0)) {{
            break;
        }}
        for (i = 0; i < {n}; ++i) {{
            for (j = i + 1; j < {n}; ++j) {{
                double apq = A[i * {n} + j], g = 100.0 * fabs(apq), theta, tt, c, s;
                if (apq == 0.0) {{
                    continue;
                }}
                if (sweep > 3 && fabs(A[i * {n} + i]) + g == fabs(A[i * {n} + i])
                        && fabs(A[j * {n} + j]) + g == fabs(A[j * {n} + j])) {{ /* below rounding of both */
                    A[i * {n} + j] = 0.0;
                    A[j * {n} + i] = 0.0;
                    continue;
                }}
                theta = (A[j * {n} + j] - A[i * {n} + i]) / (2.0 * apq);
                tt = (theta >= 0.0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                c = 1.0 / sqrt(tt * tt + 1.0);
                s = tt * c;
                for (k = 0; k < {n}; ++k) {{ /* A <- A J (columns i, j) */
                    double aki = A[k * {n} + i], akj = A[k * {n} + j];
                    A[k * {n} + i] = c * aki - s * akj;
                    A[k * {n} + j] = s * aki + c * akj;
                }}
                for (k = 0; k < {n}; ++k) {{ /* A <- J' A (rows i, j) */
                    double aik = A[i * {n} + k], ajk = A[j * {n} + k];
                    A[i * {n} + k] = c * aik - s * ajk;
                    A[j * {n} + k] = s * aik + c * ajk;
                }}
                A[i * {n} + j] = 0.0;
                A[j * {n} + i] = 0.0;
                for (k = 0; k < {n}; ++k) {{ /* V <- V J */
                    double vki = V[k * {n} + i], vkj = V[k * {n} + j];
                    V[k * {n} + i] = c * vki - s * vkj;
                    V[k * {n} + j] = s * vki + c * vkj;
                }}
            }}
        }}
    }}
    for (i = 0; i < {n}; ++i) {{
        lam[i] = A[i * {n} + i];
    }}
}}

/* S with S S' = Ps (Ps symmetric, n x n, row-major): the lower Cholesky factor, or, where a pivot is not positive,
   V diag(sqrt(max(lam, 0))) from Ps = V diag(lam) V' */
static void {P}_sqrt(const double *Ps, double *S)
{{
    double A[{n * n}], lam[{n}], V[{n * n}];
    int i, j, k, ok = 1;
    for (j = 0; j < {n} && ok; ++j) {{
        double d = Ps[j * {n} + j];
        for (k = 0; k < j; ++k) {{
            d -= S[j * {n} + k] * S[j * {n} + k];
        }}
        if (!(d > 0.0)) {{
            ok = 0;
            break;
        }}
        d = sqrt(d);
        S[j * {n} + j] = d;
        for (i = j + 1; i < {n}; ++i) {{
            double a = Ps[i * {n} + j];
            for (k = 0; k < j; ++k) {{
                a -= S[i * {n} + k] * S[j * {n} + k];
            }}
            S[i * {n} + j] = a / d;
        }}
        for (i = 0; i < j; ++i) {{
            S[i * {n} + j] = 0.0;
        }}
    }}
    if (ok) {{
        return;
    }}
    for (i = 0; i < {n * n}; ++i) {{
        A[i] = Ps[i];
    }}
    {P}_eigh(A, lam, V);
    for (j = 0; j < {n}; ++j) {{
        double r = lam[j] > 0.0 ? sqrt(lam[j]) : 0.0;
        for (i = 0; i < {n}; ++i) {{
            S[i * {n} + j] = V[i * {n} + j] * r;
        }}
    }}
}}

/* the {L} sigma points of (x, P), one per row of X: x, x + spread S(:, i), x - spread S(:, i); Ps = (P + P') / 2 */
static void {P}_sigma(const double *x, const double *Pm, double *X, double *Ps)
{{
    double S[{n * n}];
    int i, j;
    for (i = 0; i < {n}; ++i) {{
        for (j = 0; j < {n}; ++j) {{
            Ps[i * {n} + j] = (Pm[i * {n} + j] + Pm[j * {n} + i]) * 0.5;
        }}
    }}
    {P}_sqrt(Ps, S);
    for (j = 0; j < {n}; ++j) {{
        X[j] = x[j];
    }}
    for (i = 0; i < {n}; ++i) {{
        for (j = 0; j < {n}; ++j) {{
            const double d = {P}_spread * S[j * {n} + i];
            X[(1 + i) * {n} + j] = x[j] + d;
            X[(1 + {n} + i) * {n} + j] = x[j] - d;
        }}
    }}
}}
"""


def generate_ukf(obs: Any, prefix: str) -> CProgram:
    """The :class:`~nlobs.export.program.CProgram` of a :class:`~nlobs.observers.ukf.UKF` (module docstring).

    Parameters
    ----------
    obs : UKF
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
    L, N2, pp = 2 * n + 1, n * n, max(p, 1)
    Q, R, P0 = (np.asarray(M, dtype=float) for M in (obs.Q, obs.R, obs.P0))
    defs, model_note = model_c(plant, P, n, m, p, jacobians=False)
    uses = f"""    double X[{L * n}], FX[{L * n}], Ps[{N2}], mean[{n}];
    int j, k, l;
    (void)t;
    (void)y;
    {P}_sigma(z, z + {n}, X, Ps);
    for (l = 0; l < {L}; ++l) {{
        {P}_f(X + l * {n}, u, FX + l * {n});
    }}
    for (j = 0; j < {n}; ++j) {{ /* the mean: sum of w_m f(X) */
        double acc = 0.0;
        for (l = 0; l < {L}; ++l) {{
            acc += {P}_wm[l] * FX[l * {n} + j];
        }}
        mean[j] = acc;
    }}
    for (l = 0; l < {L}; ++l) {{
        for (j = 0; j < {n}; ++j) {{
            FX[l * {n} + j] -= mean[j];
        }}
    }}
"""
    if obs.discrete:
        what = "the unscented transform of a discrete plant: x+ = f(X) w_m, P+ = (sum w_c df df' + Q) symmetrised"
        tail = f"""    for (j = 0; j < {n}; ++j) {{
        dz[j] = mean[j];
        for (k = 0; k < {n}; ++k) {{
            double acc = 0.0;
            for (l = 0; l < {L}; ++l) {{
                acc += FX[l * {n} + j] * {P}_wc[l] * FX[l * {n} + k];
            }}
            Ps[j * {n} + k] = acc + {P}_Q[j * {n} + k];
        }}
    }}
    for (j = 0; j < {n}; ++j) {{
        for (k = 0; k < {n}; ++k) {{
            dz[{n} + j * {n} + k] = (Ps[j * {n} + k] + Ps[k * {n} + j]) * 0.5;
        }}
    }}
    dz[{n + N2}] = z[{n + N2}];
    return 0;"""
    else:
        what = ("Sarkka's moment equations of a continuous plant: m' = f(X) w_m,\n"
                "   P' = sum w_c (X - m)(f - fbar)' + (...)' + Q; the NIS is constant between samples")
        tail = f"""    for (j = 0; j < {n}; ++j) {{ /* A = sum w_c (X - x)(f - fbar)', into Ps */
        dz[j] = mean[j];
        for (k = 0; k < {n}; ++k) {{
            double acc = 0.0;
            for (l = 0; l < {L}; ++l) {{
                acc += (X[l * {n} + j] - z[j]) * {P}_wc[l] * FX[l * {n} + k];
            }}
            Ps[j * {n} + k] = acc;
        }}
    }}
    for (j = 0; j < {n}; ++j) {{
        for (k = 0; k < {n}; ++k) {{
            dz[{n} + j * {n} + k] = Ps[j * {n} + k] + Ps[k * {n} + j] + {P}_Q[j * {n} + k];
        }}
    }}
    dz[{n + N2}] = 0.0;
    return 0;"""
    predict = f"""
/* {what} */
static int {P}_rhs_(double t, const double *z, const double *u, const double *y, double *dz)
{{
{uses}{tail}
}}
"""
    correct = f"""
/* at a sample: the outputs J (fresh and finite); the sigma points' statistics, H = Pxy' pinv(Ps),
   R_eff = (R_JJ + Pyy - H Ps H') symmetrised; then the Joseph-form update with Ps as the prior */
static int {P}_correct_(double t, double *z, const double *u, const double *y, const unsigned char *fresh)
{{
    double X[{L * n}], Y[{L * pp}], Ps[{N2}], A[{N2}], lam[{n}], V[{N2}], Pi[{N2}], yh[{pp}], hx[{pp}];
    double Pxy[{n * pp}], Pyy[{pp * pp}], H[{pp * n}], HP[{pp * n}], Re[{pp * pp}], nu[{pp}], big = 0.0;
    int rows[{pp}], q = 0, i, j, k, l;
    (void)t;
    for (j = 0; j < {p}; ++j) {{
        if (fresh[j] && y[j] - y[j] == 0.0) {{
            rows[q++] = j;
        }}
    }}
    if (q == 0) {{
        return 0;
    }}
    {P}_sigma(z, z + {n}, X, Ps);
    for (l = 0; l < {L}; ++l) {{
        {P}_h(X + l * {n}, u, hx);
        for (i = 0; i < q; ++i) {{
            Y[l * q + i] = hx[rows[i]];
        }}
    }}
    for (i = 0; i < q; ++i) {{ /* y_hat = sum w_m Y, the innovation, Y - y_hat */
        double acc = 0.0;
        for (l = 0; l < {L}; ++l) {{
            acc += {P}_wm[l] * Y[l * q + i];
        }}
        yh[i] = acc;
        nu[i] = y[rows[i]] - acc;
    }}
    for (l = 0; l < {L}; ++l) {{
        for (i = 0; i < q; ++i) {{
            Y[l * q + i] -= yh[i];
        }}
    }}
    for (j = 0; j < {n}; ++j) {{ /* Pxy = sum w_c (X - x)(Y - y_hat)' */
        for (i = 0; i < q; ++i) {{
            double acc = 0.0;
            for (l = 0; l < {L}; ++l) {{
                acc += (X[l * {n} + j] - z[j]) * {P}_wc[l] * Y[l * q + i];
            }}
            Pxy[j * q + i] = acc;
        }}
    }}
    for (i = 0; i < q; ++i) {{ /* Pyy = sum w_c (Y - y_hat)(Y - y_hat)' */
        for (k = 0; k < q; ++k) {{
            double acc = 0.0;
            for (l = 0; l < {L}; ++l) {{
                acc += Y[l * q + i] * {P}_wc[l] * Y[l * q + k];
            }}
            Pyy[i * q + k] = acc;
        }}
    }}
    for (i = 0; i < {N2}; ++i) {{ /* pinv(Ps) from its eigen-decomposition, |lam| <= 1e-15 max |lam| dropped */
        A[i] = Ps[i];
    }}
    {P}_eigh(A, lam, V);
    for (k = 0; k < {n}; ++k) {{
        big = fabs(lam[k]) > big ? fabs(lam[k]) : big;
    }}
    for (i = 0; i < {n}; ++i) {{
        for (j = 0; j < {n}; ++j) {{
            double acc = 0.0;
            for (k = 0; k < {n}; ++k) {{
                if (fabs(lam[k]) > 1e-15 * big) {{
                    acc += V[i * {n} + k] * (1.0 / lam[k]) * V[j * {n} + k];
                }}
            }}
            Pi[i * {n} + j] = acc;
        }}
    }}
    for (i = 0; i < q; ++i) {{ /* H = (pinv(Ps) Pxy)' */
        for (j = 0; j < {n}; ++j) {{
            double acc = 0.0;
            for (k = 0; k < {n}; ++k) {{
                acc += Pi[j * {n} + k] * Pxy[k * q + i];
            }}
            H[i * {n} + j] = acc;
        }}
    }}
    for (i = 0; i < q; ++i) {{ /* H Ps */
        for (j = 0; j < {n}; ++j) {{
            double acc = 0.0;
            for (k = 0; k < {n}; ++k) {{
                acc += H[i * {n} + k] * Ps[k * {n} + j];
            }}
            HP[i * {n} + j] = acc;
        }}
    }}
    for (i = 0; i < q; ++i) {{ /* R_JJ + Pyy - H Ps H' */
        for (k = 0; k < q; ++k) {{
            double acc = 0.0;
            for (j = 0; j < {n}; ++j) {{
                acc += HP[i * {n} + j] * H[k * {n} + j];
            }}
            Re[i * q + k] = {P}_R[rows[i] * {p} + rows[k]] + Pyy[i * q + k] - acc;
        }}
    }}
    for (i = 0; i < q; ++i) {{
        for (k = 0; k < q; ++k) {{
            Pyy[i * q + k] = (Re[i * q + k] + Re[k * q + i]) * 0.5;
        }}
    }}
    for (i = 0; i < {N2}; ++i) {{ /* the prior is the symmetrised P */
        z[{n} + i] = Ps[i];
    }}
    return {P}_joseph(z, H, nu, Pyy, q);
}}
"""
    body = (static_array(f"{P}_Q", Q) + static_array(f"{P}_R", R) + static_array(f"{P}_P0", P0)
            + "/* the sigma points' mean and covariance weights, and their spread sqrt(n + lambda) */\n"
            + static_array(f"{P}_wm", obs.wm) + static_array(f"{P}_wc", obs.wc)
            + f"static const double {P}_spread = {c_double(obs.spread)};\n"
            + defs + _linalg_c(P, n) + predict + joseph_c(P, n, p) + correct + filter_init_c(P, n))
    names = ", ".join(plant.states) if hasattr(plant, "states") else f"{n} states"
    notes = (
        ("observer", "the unscented Kalman filter: " + ("the unscented transform of a discrete plant" if obs.discrete
                     else "Sarkka's continuous-discrete UKF, the moment equations between samples (RK4)")
                     + ",\nthe statistical linearisation and the Joseph-form update at each sample"),
        ("sigma points", f"{L} (alpha {obs.alpha!r}, beta {obs.beta!r}, kappa {obs.kappa!r}; spread "
                         f"sqrt(n + lambda) = {obs.spread!r})"),
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
    return CProgram(prefix=P, title=f"Unscented Kalman filter of {name}", n_z=n + N2 + 1, n_x=n, n_u=m, n_y=p,
                    discrete=bool(obs.discrete), body=body, correcting=True, own_init=True, notes=notes,
                    codec=filter_codec(n), dt=float(tb.dt) if obs.discrete else None,
                    status1="a singular innovation covariance S")
