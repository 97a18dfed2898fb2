r"""The navigation EKF (:class:`~nlobs.navigation.ekf.ExtendedKalmanFilter`) as C: the baseline of observer (24), compiled.

Grip, Saberi & Johansen (Sec. 5) motivate observer (24) by its lower cost than the EKF a navigation
engineer would use. With both in generated C, that claim is measured compiled against compiled
(``benchmarks/gnss_ins_compiled.py``). The module is the filter of :mod:`nlobs.navigation.ekf` one flight
at a time, as a textbook implementation writes it: the covariance products are dense 9 × 9 loops.

* ``P_step`` — :meth:`~nlobs.navigation.ekf.ExtendedKalmanFilter.step` of one flight over ``h`` with
  the IMU sample ``u = [ω^b, a^b, m^b]`` held: the nominal state (``R̂⁺ = R̂ exp(S(ω h))``, Rodrigues'
  formula as :func:`~nlobs.navigation.split_kernel.exp_so3_scalar`), ``Φ = I + F h + ½ (F h)²`` written
  out as the Python single-flight path writes it, ``P⁺ = Φ P Φᵀ + Q`` symmetrised, then the
  magnetometer update (``H = [0, 0, S(R̂ᵀmⁿ)]``, ``S⁻¹`` by its adjugate, Joseph form, the error
  injected into the nominal state). ``h`` not positive and finite, or a singular ``S``: status 1.
* ``P_correct`` — the GNSS update (:meth:`~nlobs.navigation.ekf.ExtendedKalmanFilter.correct`): a fix
  with a non-finite entry is skipped and counted (the last entry of the state), else ``y = [p, v]``
  (or ``p``) is fused in Joseph form, ``S⁻¹`` by Gauss–Jordan elimination with partial pivoting.
* ``P_rhs`` — the continuous-time mean and covariance propagation of
  :meth:`~nlobs.navigation.ekf.ExtendedKalmanFilter.rhs` (no magnetometer; the counter's derivative is 0).
* ``P_init`` — ``[p̂, v̂, R̂]`` from ``x̂0`` and the filter's initial covariance; ``P_estimate`` — ``[p̂, v̂, R̂]``.

The flat state of one flight (:func:`nav_ekf_codec`) is ``[p̂, v̂, R̂ (row-major), P (9 × 9, row-major),
skipped]``: 97 values. The scalar parts repeat the Python single-flight path operation for operation; the
matrix products sum in index order where NumPy calls BLAS, so the two agree to rounding (about 1e-12
along a noisy flight, ``tests/test_export_nav_ekf.py``), not bit for bit.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nlobs.errors import InvalidArgumentError
from nlobs.export.cprint import c_double
from nlobs.export.pieces import invert_c, matrix_note, static_array
from nlobs.export.program import CProgram, StateCodec
from nlobs.export.rotations import expso3_c, mat3_c

__all__ = ["generate_nav_ekf", "nav_ekf_codec"]

#: The size of one flight's flat state: p̂, v̂, R̂, P and the skipped-fix counter.
N_Z = 3 + 3 + 9 + 81 + 1


def nav_ekf_codec() -> StateCodec:
    """``EkfState`` ↔ the flat ``[p̂, v̂, R̂, P, skipped]`` (97 values per flight) of the C module.

    Returns
    -------
    StateCodec
    """
    from nlobs.navigation.ekf import EkfState

    def pack(st: Any) -> Any:
        parts = [np.asarray(st.p, dtype=float), np.asarray(st.v, dtype=float)]
        R = np.asarray(st.R, dtype=float)
        P = np.asarray(st.P, dtype=float)
        parts += [R.reshape(*R.shape[:-2], 9), P.reshape(*P.shape[:-2], 81)]
        batch = np.broadcast_shapes(*(x.shape[:-1] for x in parts), np.shape(st.skipped))
        parts = [np.broadcast_to(x, (*batch, x.shape[-1])) for x in parts]
        parts.append(np.broadcast_to(np.asarray(st.skipped, dtype=float), batch)[..., None])
        return np.concatenate(parts, axis=-1)

    def unpack(flat: Any) -> Any:
        X = np.array(flat, dtype=float)
        b = X.shape[:-1]
        return EkfState(p=X[..., 0:3], v=X[..., 3:6], R=X[..., 6:15].reshape(*b, 3, 3),
                        P=X[..., 15:96].reshape(*b, 9, 9), skipped=np.rint(X[..., 96]).astype(np.int64))

    return StateCodec(pack=pack, unpack=unpack)


class _Products:
    """The dense products a module calls, each written once for its fixed sizes (the compiler unrolls them).

    ``mul(A, B, C, n, k, m)`` is the C call of ``C = A B`` (``A`` ``n × k``, ``B`` ``k × m``), ``mulT`` of
    ``C = A Bᵀ`` (``B`` ``m × k``); :meth:`definitions` the static functions called, summed in index order.
    """

    def __init__(self, P: str) -> None:
        self.P = P
        self.used: dict[str, tuple[bool, int, int, int]] = {}

    def _call(self, transposed: bool, A: str, B: str, C: str, n: int, k: int, m: int) -> str:
        name = f"{self.P}_mul{'T' if transposed else ''}_{n}_{k}_{m}"
        self.used[name] = (transposed, n, k, m)
        return f"{name}({A}, {B}, {C})"

    def mul(self, A: str, B: str, C: str, n: int, k: int, m: int) -> str:
        return self._call(False, A, B, C, n, k, m)

    def mulT(self, A: str, B: str, C: str, n: int, k: int, m: int) -> str:
        return self._call(True, A, B, C, n, k, m)

    def definitions(self) -> str:
        out = ["\n/* dense products, row-major, C distinct from A and B: mul_n_k_m is C = A B (A n x k, B k x m), "
               "mulT_n_k_m is C = A B' (B m x k) */\n"]
        for name, (tr, n, k, m) in sorted(self.used.items()):
            b = f"B[j * {k} + l]" if tr else f"B[l * {m} + j]"
            out.append(f"""static void {name}(const double *A, const double *B, double *C)
{{
    int i, j, l;
    for (i = 0; i < {n}; ++i) {{
        for (j = 0; j < {m}; ++j) {{
            double acc = 0.0;
            for (l = 0; l < {k}; ++l) {{
                acc += A[i * {k} + l] * {b};
            }}
            C[i * {m} + j] = acc;
        }}
    }}
}}
""")
        return "\n".join(out)


def _sym_c(P: str) -> str:
    """``P_sym``: ``Pm = (M + Mᵀ)/2`` of a 9 × 9 matrix (the Python filter's ``P += P.T; P *= 0.5``)."""
    return f"""
/* Pm <- (M + M') / 2 (9 x 9) */
static void {P}_sym(const double *M, double *Pm)
{{
    int i, j;
    for (i = 0; i < 9; ++i) {{
        for (j = 0; j < 9; ++j) {{
            Pm[i * 9 + j] = (M[i * 9 + j] + M[j * 9 + i]) * 0.5;
        }}
    }}
}}
"""


def _joseph_c(P: str, name: str, q: int, mul: _Products, scalar: bool) -> str:
    """``P_name``: ``(I − KH) P (I − KH)ᵀ + K R Kᵀ`` symmetrised, then the injection of ``δx = K ν``.

    ``q`` outputs; ``R = var·I`` when ``scalar`` (the magnetometer), else the matrix ``Rq`` (a GNSS fix).
    """
    krk = (f"""    {mul.mulT("K", "K", "KRK", 9, q, 9)};
    for (i = 0; i < 81; ++i) {{
        KRK[i] *= var;
    }}""" if scalar else f"""    {mul.mul("K", "Rq", "KR", 9, q, q)};
    {mul.mulT("KR", "K", "KRK", 9, q, 9)};""")
    noise = "double var" if scalar else "const double *Rq"
    return f"""
/* the Joseph-form update of the flight in z with {q} outputs: H ({q} x 9), gain K (9 x {q}), noise covariance
   {"var I" if scalar else f"Rq ({q} x {q})"}, innovation nu; then the error K nu injected into p, v and R exp(S(dtheta)) */
static void {P}_{name}(double *z, const double *H, const double *K, {noise}, const double *nu)
{{
    double IKH[81], A[81], M[81], KRK[81], dx[9], E[9], Rn[9];{"" if scalar else f" double KR[{9 * q}];"}
    double *Pm = z + 15;
    int i, j, k;
    {mul.mul("K", "H", "A", 9, q, 9)};
    for (i = 0; i < 9; ++i) {{
        for (j = 0; j < 9; ++j) {{
            IKH[i * 9 + j] = (i == j ? 1.0 : 0.0) - A[i * 9 + j];
        }}
    }}
{krk}
    {mul.mul("IKH", "Pm", "A", 9, 9, 9)};
    {mul.mulT("A", "IKH", "M", 9, 9, 9)};
    for (i = 0; i < 81; ++i) {{
        M[i] += KRK[i];
    }}
    {P}_sym(M, Pm);
    for (i = 0; i < 9; ++i) {{ /* dx = K nu */
        double acc = 0.0;
        for (k = 0; k < {q}; ++k) {{
            acc += K[i * {q} + k] * nu[k];
        }}
        dx[i] = acc;
    }}
    for (i = 0; i < 6; ++i) {{
        z[i] = z[i] + dx[i];
    }}
    {P}_expso3(dx[6], dx[7], dx[8], E);
    {P}_mm(z + 6, E, Rn);
    for (i = 0; i < 9; ++i) {{
        z[6 + i] = Rn[i];
    }}
}}
"""


def generate_nav_ekf(observer: Any, prefix: str) -> CProgram:
    """The :class:`~nlobs.export.program.CProgram` of the navigation EKF (module docstring).

    Parameters
    ----------
    observer : ExtendedKalmanFilter
        The filter of :mod:`nlobs.navigation.ekf` (its configuration, ``m_n``, ``g_n``, receiver and
        magnetometer flag).
    prefix : str
        C identifier of the module.

    Returns
    -------
    CProgram

    Raises
    ------
    InvalidArgumentError
        Another observer class.
    """
    if type(observer).__name__ != "ExtendedKalmanFilter":
        raise InvalidArgumentError(f"generate_nav_ekf: expected an ExtendedKalmanFilter, got {type(observer).__name__}")
    P = prefix
    c = observer.config
    po = bool(observer.position_only)
    mag = bool(observer.use_magnetometer)
    ny = 3 if po else 6
    d = np.r_[np.full(3, c.p0_std**2), np.full(3, c.v0_std**2),
              np.deg2rad([c.tilt0_std_deg, c.tilt0_std_deg, c.yaw0_std_deg]) ** 2]  # as init_state
    P0 = np.diag(d)
    Rg = np.r_[np.full(3, c.gnss_p_std**2), np.full(3, c.gnss_v_std**2)][:ny]
    k = observer._k
    mul = _Products(P)
    joseph = (_joseph_c(P, "joseph_mag", 3, mul, True) if mag else "") + _joseph_c(P, "joseph_gnss", ny, mul, False)
    qa, qg = c.accel_std**2 * c.sample_period_s, c.gyro_std**2 * c.sample_period_s  # Q̇'s diagonal, as rhs
    magnetometer = f"""
    /* the magnetometer: H = [0, 0, S(q)], q = R' m^n; S^-1 by its adjugate */
    {{
        const double *R = z + 6;
        const double q0 = R[0] * {P}_mn[0] + R[3] * {P}_mn[1] + R[6] * {P}_mn[2];
        const double q1 = R[1] * {P}_mn[0] + R[4] * {P}_mn[1] + R[7] * {P}_mn[2];
        const double q2 = R[2] * {P}_mn[0] + R[5] * {P}_mn[1] + R[8] * {P}_mn[2];
        double H[27], PHt[27], S[9], Si[9], K[27], nu[3];
        double a, b, cc, dd, e, f, g, hh, ii, A, B, C, det, r;
        for (i = 0; i < 27; ++i) {{
            H[i] = 0.0;
        }}
        H[7] = -q2;
        H[8] = q1;
        H[15] = q2;
        H[17] = -q0;
        H[24] = -q1;
        H[25] = q0;
        {mul.mulT("z + 15", "H", "PHt", 9, 9, 3)};
        {mul.mul("H", "PHt", "S", 3, 9, 3)};
        a = S[0] + {P}_var_m;
        b = S[1];
        cc = S[2];
        dd = S[3];
        e = S[4] + {P}_var_m;
        f = S[5];
        g = S[6];
        hh = S[7];
        ii = S[8] + {P}_var_m;
        A = e * ii - f * hh;
        B = f * g - dd * ii;
        C = dd * hh - e * g;
        det = a * A + b * B + cc * C;
        if (det == 0.0 || det - det != 0.0) {{
            return 1;
        }}
        r = 1.0 / det;
        Si[0] = A * r;
        Si[1] = (cc * hh - b * ii) * r;
        Si[2] = (b * f - cc * e) * r;
        Si[3] = B * r;
        Si[4] = (a * ii - cc * g) * r;
        Si[5] = (cc * dd - a * f) * r;
        Si[6] = C * r;
        Si[7] = (b * g - a * hh) * r;
        Si[8] = (a * e - b * dd) * r;
        {mul.mul("PHt", "Si", "K", 9, 3, 3)};
        nu[0] = u[6] - q0;
        nu[1] = u[7] - q1;
        nu[2] = u[8] - q2;
        {P}_joseph_mag(z, H, K, {P}_var_m, nu);
    }}
""" if mag else ""
    body = "".join([
        f"/* {'m^n, ' if mag else ''}g^n; the initial covariance (diagonal); the GNSS noise variances (p{'' if po else ', v'}) */\n",
        static_array(f"{P}_mn", k.m_n) if mag else "", static_array(f"{P}_gn", k.g_n), static_array(f"{P}_P0", P0),
        static_array(f"{P}_Rg", np.diag(Rg)),
        "/* per-sample variances of the accelerometer, the gyro and the magnetometer; Q-dot's diagonal (rhs) */\n",
        f"static const double {P}_var_a = {c_double(k.var_a)};\n",
        f"static const double {P}_var_g = {c_double(k.var_g)};\n",
        f"static const double {P}_var_m = {c_double(k.var_m)};\n" if mag else "",
        f"static const double {P}_qa = {c_double(qa)};\n",
        f"static const double {P}_qg = {c_double(qg)};\n",
        mat3_c(P, ("mm",)), expso3_c(P), _sym_c(P), "{products}", joseph, invert_c(P, ny),
        f"""
static int {P}_init_(const double *xhat0, double *z)
{{
    int i;
    for (i = 0; i < 15; ++i) {{
        z[i] = xhat0[i];
    }}
    for (i = 0; i < 81; ++i) {{
        z[15 + i] = {P}_P0[i];
    }}
    z[96] = 0.0;
    return {P}_finite(z, 96) ? 0 : 2;
}}

/* the prediction over h with the IMU sample held (nlobs.navigation.ekf, ExtendedKalmanFilter._step_one){
        ", then the magnetometer update" if mag else ""} */
static int {P}_step_(double t, double *z, const double *u, const double *y, double h)
{{
    const double w0 = u[0], w1 = u[1], w2 = u[2], a0 = u[3], a1 = u[4], a2 = u[5];
    double Phi[81], M[81], Pn[81], E[9], Rn[9], A[9], col[27];
    double f0, f1, f2, h2, ww, x0, x1, x2, qa, qg;
    double *R = z + 6;
    int i, j;
    (void)t;
    (void)y;
    if (!(h > 0.0) || h - h != 0.0) {{
        return 1;
    }}
    f0 = R[0] * a0 + R[1] * a1 + R[2] * a2 + {P}_gn[0];
    f1 = R[3] * a0 + R[4] * a1 + R[5] * a2 + {P}_gn[1];
    f2 = R[6] * a0 + R[7] * a1 + R[8] * a2 + {P}_gn[2];
    h2 = 0.5 * h * h;
    z[0] = z[0] + z[3] * h + f0 * h2;
    z[1] = z[1] + z[4] * h + f1 * h2;
    z[2] = z[2] + z[5] * h + f2 * h2;
    z[3] = z[3] + f0 * h;
    z[4] = z[4] + f1 * h;
    z[5] = z[5] + f2 * h;
    /* Phi's last block column: A = -R S(a) (row i: a x r_i), W = -S(w), A W, W^2 = w w' - |w|^2 I */
    A[0] = R[2] * a1 - R[1] * a2;
    A[1] = R[0] * a2 - R[2] * a0;
    A[2] = R[1] * a0 - R[0] * a1;
    A[3] = R[5] * a1 - R[4] * a2;
    A[4] = R[3] * a2 - R[5] * a0;
    A[5] = R[4] * a0 - R[3] * a1;
    A[6] = R[8] * a1 - R[7] * a2;
    A[7] = R[6] * a2 - R[8] * a0;
    A[8] = R[7] * a0 - R[6] * a1;
    {P}_expso3(w0 * h, w1 * h, w2 * h, E);
    {P}_mm(R, E, Rn);
    for (i = 0; i < 9; ++i) {{
        R[i] = Rn[i];
    }}
    ww = w0 * w0 + w1 * w1 + w2 * w2;
    for (i = 0; i < 9; ++i) {{
        col[i] = h2 * A[i];
    }}
    for (i = 0; i < 9; i += 3) {{
        x0 = A[i];
        x1 = A[i + 1];
        x2 = A[i + 2];
        col[9 + i] = h * x0 + h2 * (x2 * w1 - x1 * w2);
        col[10 + i] = h * x1 + h2 * (x0 * w2 - x2 * w0);
        col[11 + i] = h * x2 + h2 * (x1 * w0 - x0 * w1);
    }}
    col[18] = 1.0 + h2 * (w0 * w0 - ww);
    col[19] = h * w2 + h2 * w0 * w1;
    col[20] = -h * w1 + h2 * w0 * w2;
    col[21] = -h * w2 + h2 * w1 * w0;
    col[22] = 1.0 + h2 * (w1 * w1 - ww);
    col[23] = h * w0 + h2 * w1 * w2;
    col[24] = h * w1 + h2 * w2 * w0;
    col[25] = -h * w0 + h2 * w2 * w1;
    col[26] = 1.0 + h2 * (w2 * w2 - ww);
    for (i = 0; i < 9; ++i) {{
        for (j = 0; j < 9; ++j) {{
            Phi[i * 9 + j] = i == j ? 1.0 : 0.0;
        }}
        Phi[i * 9 + 6] = col[3 * i];
        Phi[i * 9 + 7] = col[3 * i + 1];
        Phi[i * 9 + 8] = col[3 * i + 2];
    }}
    Phi[3] = h;
    Phi[13] = h;
    Phi[23] = h;
    /* P+ = Phi P Phi' + Q, Q = diag(0, var_a I, var_g I) h^2, symmetrised */
    {mul.mul("Phi", "z + 15", "M", 9, 9, 9)};
    {mul.mulT("M", "Phi", "Pn", 9, 9, 9)};
    qa = {P}_var_a * (h * h);
    qg = {P}_var_g * (h * h);
    for (i = 3; i < 6; ++i) {{
        Pn[i * 9 + i] += qa;
        Pn[(i + 3) * 9 + i + 3] += qg;
    }}
    {P}_sym(Pn, z + 15);
{magnetometer}    return 0;
}}

/* at a GNSS fix: the update with y = [p{'' if po else ', v'}] in Joseph form; a fix with a non-finite entry is skipped
   and counted */
static int {P}_correct_(double t, double *z, const double *u, const double *y, const unsigned char *fresh)
{{
    double H[{ny * 9}], PHt[{ny * 9}], S[{ny * ny}], Si[{ny * ny}], K[{ny * 9}], nu[{ny}];
    int i, j;
    (void)t;
    (void)u;
    (void)fresh;
    for (i = 0; i < {ny}; ++i) {{
        if (!(y[i] - y[i] == 0.0)) {{
            z[96] += 1.0;
            return 0;
        }}
    }}
    for (i = 0; i < {ny}; ++i) {{
        for (j = 0; j < 9; ++j) {{
            H[i * 9 + j] = i == j ? 1.0 : 0.0;
        }}
        nu[i] = y[i] - z[i];
    }}
    {mul.mulT("z + 15", "H", "PHt", 9, 9, ny)};
    {mul.mul("H", "PHt", "S", ny, 9, ny)};
    for (i = 0; i < {ny * ny}; ++i) {{
        S[i] += {P}_Rg[i];
    }}
    if ({P}_invert(S, Si, {ny})) {{
        return 1;
    }}
    {mul.mul("PHt", "Si", "K", 9, ny, ny)};
    {P}_joseph_gnss(z, H, K, {P}_Rg, nu);
    return 0;
}}

/* the continuous-time mean and covariance propagation (ExtendedKalmanFilter.rhs): p' = v, v' = R a + g,
   R' = R S(w), P' = F P + (F P)' + G diag(qa I, qg I) G'; no magnetometer; the counter's derivative is 0 */
static int {P}_rhs_(double t, const double *z, const double *u, const double *y, double *dz)
{{
    const double *R = z + 6;
    double Sw[9], Sa[9], RSa[9], F[81], FP[81];
    int i, j, k;
    (void)t;
    (void)y;
    Sw[0] = 0.0; Sw[1] = -u[2]; Sw[2] = u[1];
    Sw[3] = u[2]; Sw[4] = 0.0; Sw[5] = -u[0];
    Sw[6] = -u[1]; Sw[7] = u[0]; Sw[8] = 0.0;
    Sa[0] = 0.0; Sa[1] = -u[5]; Sa[2] = u[4];
    Sa[3] = u[5]; Sa[4] = 0.0; Sa[5] = -u[3];
    Sa[6] = -u[4]; Sa[7] = u[3]; Sa[8] = 0.0;
    for (i = 0; i < 3; ++i) {{
        dz[i] = z[3 + i];
        dz[3 + i] = R[3 * i] * u[3] + R[3 * i + 1] * u[4] + R[3 * i + 2] * u[5] + {P}_gn[i];
    }}
    {P}_mm(R, Sw, dz + 6);
    {P}_mm(R, Sa, RSa);
    for (i = 0; i < 81; ++i) {{
        F[i] = 0.0;
    }}
    for (i = 0; i < 3; ++i) {{
        F[i * 9 + 3 + i] = 1.0;
        for (j = 0; j < 3; ++j) {{
            F[(3 + i) * 9 + 6 + j] = -RSa[3 * i + j];
            F[(6 + i) * 9 + 6 + j] = -Sw[3 * i + j];
        }}
    }}
    {mul.mul("F", "z + 15", "FP", 9, 9, 9)};
    for (i = 0; i < 9; ++i) {{
        for (j = 0; j < 9; ++j) {{
            dz[15 + i * 9 + j] = FP[i * 9 + j] + FP[j * 9 + i];
        }}
    }}
    for (i = 0; i < 3; ++i) {{ /* G diag(qa I, qg I) G' = diag(0, qa R R', qg I) */
        for (j = 0; j < 3; ++j) {{
            double acc = 0.0;
            for (k = 0; k < 3; ++k) {{
                acc += R[3 * i + k] * {P}_qa * R[3 * j + k];
            }}
            dz[15 + (3 + i) * 9 + 3 + j] += acc;
        }}
        dz[15 + (6 + i) * 9 + 6 + i] += {P}_qg;
    }}
    dz[96] = 0.0;
    return 0;
}}
"""])
    body = body.replace("{products}", mul.definitions(), 1)  # every product the body calls, known once written
    notes = (
        ("observer", "the navigation EKF (error state [dp, dv, dtheta], multiplicative attitude R = R_hat exp(S(dtheta)));"
                     "\nthe baseline of observer (24) of Grip, Saberi & Johansen (Sec. 5)"),
        ("state", "[p, v, R (row-major), P (9 x 9, row-major), skipped fixes]"),
        ("input u", "[omega_b, a_b, m_b] (IMU" + (" and magnetometer" if mag else "") + ", held over the step)"),
        ("output y", "GNSS fix [p]" if po else "GNSS fix [p, v]"),
        ("estimate", "[p, v, R]"),
        ("step", "Phi = I + F h + (F h)^2 / 2, P+ = Phi P Phi' + Q symmetrised"
                 + (", then the magnetometer update (Joseph form)" if mag else "")),
        ("correct", "the GNSS update in Joseph form; a fix with a non-finite entry is skipped and counted"),
        ("P0 (diagonal)", matrix_note(d)),
        ("noise", f"accel {c.accel_std!r}, gyro {c.gyro_std!r}, mag {c.mag_std!r} per sample; GNSS p "
                  f"{c.gnss_p_std!r}" + ("" if po else f", v {c.gnss_v_std!r}")),
        ("m_n", matrix_note(observer.m_n)),
        ("g_n", matrix_note(observer.g_n)),
    )
    return CProgram(prefix=P, title="Navigation EKF (the baseline of observer (24) of Grip, Saberi & Johansen)",
                    n_z=N_Z, n_x=15, n_u=9, n_y=ny, discrete=False, body=body, correcting=True, own_step=True,
                    own_init=True, notes=notes, codec=nav_ekf_codec(),
                    status1="a singular innovation covariance, or a step h that is not positive and finite")
