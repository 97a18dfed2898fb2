r"""The GNSS/INS observer (24) of Grip, Saberi & Johansen as C: the fused split step, ported.

:func:`generate_gnss_ins` makes the :class:`~nlobs.export.program.CProgram` of a
:class:`~nlobs.navigation.gnss_ins.GnssInsObserver` or a
:class:`~nlobs.navigation.schedule.ScheduledGnssInsObserver`:

* ``P_step`` is the Strang step ``C(h/2) A(h/2) B(h) A(h/2) C(h/2)`` of
  :func:`nlobs.navigation.split_kernel.split_step`, operation for operation (the same sums in the
  same order, ``sin``, ``sqrt`` and ``expm1`` of ``<math.h>``);
* ``P_correct`` takes a GNSS fix into the held measurement as
  :meth:`~nlobs.navigation.gnss_ins.GnssInsObserver.correct` does: a fix with a non-finite value
  (or one that does not carry all its channels) is skipped and counted;
* ``P_rhs`` is the right-hand side of (24a)–(24d) and of the measurement predictor
  (:meth:`~nlobs.navigation.gnss_ins.GnssInsObserver.rhs`); the two entries of the flag and the
  counter have derivative 0;
* ``P_estimate`` is the raw estimate ``[p̂, v̂, R̂]`` of
  :meth:`~nlobs.navigation.gnss_ins.GnssInsObserver.raw_estimate` (``R̂`` row-major, not projected:
  the Python side projects the record once, ``finish_estimates``).

The flat state of one flight (:func:`gnss_ins_codec`) is
``[p̂, v̂, ξ, R̂ (row-major), y_p, (y_v), has_fix, skipped]``: 26 values, 23 for a position-only receiver.

The IMU period. The linear sub-flow ``C(h/2)`` is ``L ← Φ L + d`` with ``Φ = expm(F h/2)``, which the
Python observer computes (SciPy) once per distinct ``h``. The C is generated for a nominal period
``h₀`` (argument ``imu_period``, else the observer's ``imu_period`` attribute if it has one, else the
paper's 100 Hz): it holds ``Φ(h₀/2)``, ``F Φ(h₀/2)`` and ``F² Φ(h₀/2)/2`` and evaluates
``Φ(h₀/2 + δ) = Φ₀ + δ F Φ₀ + δ² F² Φ₀ / 2`` (the matrices commute), which is exact to rounding for
the periods a uniform IMU grid ``t_k = k/f`` produces (``|h − h₀| ≤ 10⁻⁶ h₀``, the loops' uniformity
rule: the first neglected term is ``(ρ δ)³/6 < 10⁻²⁰``). ``P_step`` returns status 1 for any other
``h`` (generate the module again for that period): through :func:`compile_observer` that reads as the
"singular matrix" error of the compiled observer.

Refused (:class:`~nlobs.errors.InvalidArgumentError`): ``integrator="rk4"`` (the C is the split
step) and a gain ``K`` that couples the three axes (not of the form ``kron(K3, I3)``: the Python
kernel falls back to a dense NumPy product there).

The schedule. For a :class:`~nlobs.navigation.schedule.ScheduledGnssInsObserver` the per-mode
constants (the eigenvalues ``γ_i`` and, for a non-diagonal ``Γ_k``, the eigenvectors ``V``) are static
arrays, and the mode in force at ``t`` is the number of switch times ``τ ≤ t + 10⁻⁹`` (the Python rule,
:meth:`~nlobs.navigation.schedule.AttitudeGainSchedule.index`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from nlobs.errors import InvalidArgumentError
from nlobs.export.cprint import c_double, comment, matrix_literal
from nlobs.export.pieces import matrix_note
from nlobs.export.program import CProgram, StateCodec
from nlobs.export.rotations import expso3_c, mat3_c

__all__ = ["DEFAULT_IMU_PERIOD", "IMU_PERIOD_RTOL", "generate_gnss_ins", "gnss_ins_codec"]

#: The nominal IMU period when neither the call nor the observer gives one: the paper's 100 Hz.
DEFAULT_IMU_PERIOD = 0.01
#: Relative deviation of ``h`` from the nominal period that ``P_step`` accepts (the loops' uniformity rule).
IMU_PERIOD_RTOL = 1e-6
#: Switch times are compared with ``t + 1e-9`` (the schedule's own tolerance).
_SWITCH_TOL_S = 1e-9


def _parts(observer: Any) -> tuple[Any, tuple[Any, ...], tuple[float, ...]]:
    """The base observer, its modes (one for a constant Γ) and the switch times."""
    kind = type(observer).__name__
    if kind == "ScheduledGnssInsObserver":
        return observer.base, tuple(observer.modes), tuple(float(t) for t in observer.switch_times)
    if kind == "GnssInsObserver":
        return observer, (observer,), ()
    raise InvalidArgumentError(f"generate_gnss_ins: expected a GnssInsObserver or ScheduledGnssInsObserver, got {kind}")


def gnss_ins_codec(position_only: bool) -> StateCodec:
    """The flat layout ``[p̂, v̂, ξ, R̂, y_p, (y_v), has_fix, skipped]`` of a ``GnssInsState`` and back.

    Parameters
    ----------
    position_only : bool
        No ``y_v`` (23 values instead of 26).
    """
    from nlobs.navigation.gnss_ins import GnssInsState

    ny = 3 if position_only else 6

    def pack(st: Any) -> Any:
        R = np.asarray(st.R, dtype=float)
        parts = [st.p, st.v, st.xi, R.reshape(*R.shape[:-2], 9), st.y_p]
        if not position_only:
            parts.append(st.y_v)
        parts = [np.asarray(x, dtype=float) for x in parts]
        batch = np.broadcast_shapes(*(x.shape[:-1] for x in parts), np.shape(st.has_fix), np.shape(st.skipped))
        parts = [np.broadcast_to(x, (*batch, x.shape[-1])) for x in parts]
        parts.append(np.broadcast_to(np.asarray(st.has_fix, dtype=float), batch)[..., None])
        parts.append(np.broadcast_to(np.asarray(st.skipped, dtype=float), batch)[..., None])
        return np.concatenate(parts, axis=-1)

    def unpack(flat: Any) -> Any:
        X = np.array(flat, dtype=float)
        b = X.shape[:-1]
        return GnssInsState(p=X[..., 0:3], v=X[..., 3:6], xi=X[..., 6:9], R=X[..., 9:18].reshape(*b, 3, 3),
                            y_p=X[..., 18:21], y_v=None if position_only else X[..., 21:24],
                            has_fix=X[..., 18 + ny] != 0.0,
                            skipped=np.rint(X[..., 19 + ny]).astype(np.int64))

    return StateCodec(pack=pack, unpack=unpack)


def _axis_blocks(M: Any, n: int, what: str) -> list[list[float]]:
    """Per axis ``a``: the ``nb × nb`` block ``M[3i + a, 3j + a]`` (row-major) and the offsets ``M[3i + a, n]``."""
    nb = n // 3
    axis = np.arange(n) % 3
    if np.any(M[:n, :n][axis[:, None] != axis[None, :]] != 0.0):
        raise InvalidArgumentError(f"{what}: the gain K couples the three axes (not kron(K3, I3)); the C export "
                                   "needs the per-axis structure of the linear sub-flow (the Python kernel's "
                                   "general-K fallback is a dense NumPy product, not exported)")
    out = []
    for a in range(3):
        idx = np.arange(a, n, 3)
        out.append([float(x) for x in M[np.ix_(idx, idx)].ravel()] + [float(x) for x in M[idx, n]])
    assert all(len(row) == nb * nb + nb for row in out)
    return out


def _flow_constants(base: Any, h0: float) -> tuple[list[float], list[float], list[float]]:
    """``Φ₀``, ``F Φ₀``, ``F² Φ₀ / 2`` over ``h₀/2`` per flow (0: before the first fix, 1: with it) and axis."""
    from scipy.linalg import expm

    from nlobs.navigation.split_kernel import ScalarFlow

    dt = 0.5 * h0
    P1, d1, P0, d0 = base._transitions(dt)
    flows = (ScalarFlow.from_transition(P0, d0), ScalarFlow.from_transition(P1, d1))
    if any(f.dense is not None for f in flows):
        raise InvalidArgumentError("GnssInsObserver: the gain K couples the three axes (not kron(K3, I3)); the C "
                                   "export needs the per-axis structure of the linear sub-flow (the Python "
                                   "kernel's general-K fallback is a dense NumPy product, not exported)")
    n = base._F[0].shape[0] - 1
    phi: list[float] = []
    t1: list[float] = []
    t2: list[float] = []
    for flow, F in zip(flows, (base._F[1], base._F[0])):
        for a in range(3):
            phi += list(flow.per_axis[a])       # the Python kernel's own numbers
        E = expm(F * dt)
        for blk in _axis_blocks(F @ E, n, "F Φ"):
            t1 += blk
        for blk in _axis_blocks(0.5 * (F @ (F @ E)), n, "F² Φ"):
            t2 += blk
    return phi, t1, t2


def static_array(name: str, values: Any, kind: str = "double") -> str:
    arr = np.asarray(values, dtype=float).reshape(-1)
    if kind == "int":
        lit = "{" + ", ".join(str(int(v)) for v in arr) + "}" if arr.size else "{0}"
        return f"static const int {name}[{max(arr.size, 1)}] = {lit};\n"
    return f"static const double {name}[{max(arr.size, 1)}] = {matrix_literal(arr)};\n"


def _flow_c(P: str, nb: int) -> str:
    """``L ← Φ L + d`` per axis, unrolled (the order of ``ScalarFlow.apply``)."""
    nc = nb * nb + nb
    lines = []
    xs = ", ".join(f"x{i}" for i in range(nb))
    for a in range(3):
        lines.append(f"    f = c + {a * nc};")
        lines.append("    " + " ".join(f"x{i} = L[{3 * i + a}];" for i in range(nb)))
        for i in range(nb):
            terms = " + ".join(f"f[{i * nb + j}] * x{j}" for j in range(nb))
            lines.append(f"    L[{3 * i + a}] = {terms} + f[{nb * nb + i}];")
    body = "\n".join(lines)
    return f"""\
/* C(h/2): L <- Phi L + d on L = [p, v, z, y_p, (y_v)], per axis (c: 3 axes x ({nb}x{nb} Phi, {nb} d)) */
static void {P}_flow(const double *c, double *L)
{{
    const double *f;
    double {xs};
{body}
}}
"""


def generate_gnss_ins(observer: Any, prefix: str, *, imu_period: float | None = None) -> CProgram:
    """The :class:`~nlobs.export.program.CProgram` of observer (24) (module docstring).

    Parameters
    ----------
    observer : GnssInsObserver or ScheduledGnssInsObserver
        With ``integrator="split"`` and a per-axis gain ``K = kron(K3, I3)``.
    prefix : str
        C identifier of the module.
    imu_period : float, optional
        The nominal IMU period ``h₀`` [s] (default: the observer's ``imu_period`` attribute, else
        :data:`DEFAULT_IMU_PERIOD`). ``P_step`` accepts ``|h − h₀| ≤ 10⁻⁶ h₀`` and returns status 1 otherwise.

    Raises
    ------
    InvalidArgumentError
        Another observer class, ``integrator="rk4"``, a gain that couples the axes, or a bad ``imu_period``.
    """
    base, modes, times = _parts(observer)
    if base.integrator != "split":
        raise InvalidArgumentError("GnssInsObserver: only integrator='split' is exported (the C is the fused split "
                                   f"step); got integrator={base.integrator!r}")
    if imu_period is None:
        imu_period = getattr(observer, "imu_period", None) or getattr(base, "imu_period", None) or DEFAULT_IMU_PERIOD
    h0 = float(imu_period)
    if not 0.0 < h0 < float("inf"):
        raise InvalidArgumentError(f"imu_period: must be positive and finite, got {imu_period!r}")
    P, up = prefix, prefix.upper()
    po = bool(base.position_only)
    predict = base.intersample == "predict"
    nb = 4 if po else 5
    nl = 3 * nb
    ny = 3 if po else 6
    has, skip = 18 + ny, 19 + ny
    nz = skip + 1
    nc = nb * nb + nb
    gains: list[Any] = []          # the distinct gains K of the modes, in order of first use
    kmode: list[int] = []
    for m in modes:
        j = next((i for i, G in enumerate(gains) if np.array_equal(G.K, m.K)), None)
        if j is None:
            gains.append(m)
            j = len(gains) - 1
        kmode.append(j)
    phi, t1, t2 = [], [], []
    for m in gains:
        f0, f1, f2 = _flow_constants(m, h0)
        phi += f0
        t1 += f1
        t2 += f2
    N = len(modes)
    gam, Vs, hasV, Gam = [], [], [], []
    for m in modes:
        k = m._scalar
        gam += list(k.gamma)
        hasV.append(0 if k.V is None else 1)
        Vs += list(np.eye(3).ravel()) if k.V is None else list(k.V)
        Gam += [float(x) for x in np.asarray(m.Gamma, dtype=float).ravel()]
    k0 = base._scalar
    K = np.concatenate([np.asarray(m.K, dtype=float).ravel() for m in gains])
    body = "".join([
        "/* nominal IMU period h0 and the accepted deviation |h - h0| */\n",
        f"static const double {P}_h0 = {c_double(h0)};\n",
        f"static const double {P}_htol = {c_double(IMU_PERIOD_RTOL * h0)};\n",
        f"/* linear sub-flow over h0/2, per gain K: [flow 0 (no fix yet), flow 1 (with a fix)] x 3 axes x "
        f"({nb}x{nb} Phi, {nb} d); and F Phi, F^2 Phi / 2 */\n",
        static_array(f"{P}_phi", phi), static_array(f"{P}_t1", t1), static_array(f"{P}_t2", t2),
        f"/* m^n, S(m^n), S(m^n)^2, g^n, the gains K (row-major, 9 x {ny} each) */\n",
        static_array(f"{P}_mn", k0.m_n), static_array(f"{P}_Sn", k0.Sn), static_array(f"{P}_Sn2", k0.Sn2),
        static_array(f"{P}_gn", base.g_n), static_array(f"{P}_K", K),
        "/* attitude gain per mode: eigenvalues, eigenvectors V (row-major; unused where hasV is 0: "
        "Gamma diagonal), Gamma itself; switch times */\n",
        f"#define {up}_NMODES {N}\n",
        static_array(f"{P}_gam", gam), static_array(f"{P}_V", Vs), static_array(f"{P}_hasV", hasV, "int"), static_array(f"{P}_Gam", Gam),
        static_array(f"{P}_switch", times if times else [0.0]),
        "/* the gain K of each mode (an index into K and the flows) */\n",
        static_array(f"{P}_kmode", kmode, "int"),
        f"""
/* the mode in force at t: the number of switch times <= t + 1e-9 */
static int {P}_mode(double t)
{{
    int k = 0;
    while (k < {up}_NMODES - 1 && {P}_switch[k] <= t + {c_double(_SWITCH_TOL_S)}) {{
        ++k;
    }}
    return k;
}}

""",
        mat3_c(P), "\n", _flow_c(P, nb),
        expso3_c(P),
        f"""
/* max(s, 1e-300) as Python's max (NaN stays NaN) */
static double {P}_floor(double s)
{{
    return 1e-300 > s ? 1e-300 : s;
}}

/* one Strang step C(h/2) A(h/2) B(h) A(h/2) C(h/2) of observer (24), nlobs.navigation.split_kernel.split_step */
static int {P}_step_(double t, double *z, const double *u, const double *y, double h)
{{
    double c[{3 * nc}], L[{nl}], R[9], E[9], RE[9], U[9], An[9], T[9], W[9], X[9], R1[9], R2[9], tmp[9];
    const double *fl, *g, *V;
    const double a0 = u[3], a1 = u[4], a2 = u[5], m0 = u[6], m1 = u[7], m2 = u[8];
    const double hh = 0.5 * h;
    double z0, z1, z2, c0, c1, c2, e0, e1, e2, mm, q, n0, n1, n2, s0, s1, s2, r0, r1, r2, Ra0, Ra1, Ra2;
    double xi0, xi1, xi2, dl;
    int i, mode;
    (void)y;
    /* the transition of the linear sub-flow is held for the nominal period h0 only (module header):
       another period is refused with status 1 (generate the module again for it) */
    if (!(fabs(h - {P}_h0) <= {P}_htol)) {{
        return {up}_SINGULAR;
    }}
    mode = {P}_mode(t);
    g = {P}_gam + 3 * mode;
    V = {P}_V + 9 * mode;
    i = 2 * {P}_kmode[mode] + (z[{has}] != 0.0 ? 1 : 0);
    fl = {P}_phi + {3 * nc} * i;
    dl = hh - 0.5 * {P}_h0;
    if (dl != 0.0) {{
        /* Phi(h0/2 + dl) = Phi0 + dl F Phi0 + dl^2 F^2 Phi0 / 2 */
        const double *p1 = {P}_t1 + {3 * nc} * i, *p2 = {P}_t2 + {3 * nc} * i;
        const double dl2 = dl * dl;
        int k;
        for (k = 0; k < {3 * nc}; ++k) {{
            c[k] = fl[k] + dl * p1[k] + dl2 * p2[k];
        }}
        fl = c;
    }}
    for (i = 0; i < 9; ++i) {{
        R[i] = z[9 + i];
    }}
    for (i = 0; i < 6; ++i) {{
        L[i] = z[i];
    }}
    L[6] = R[0] * a0 + R[1] * a1 + R[2] * a2 + z[6];     /* z_hat = R a^b + xi */
    L[7] = R[3] * a0 + R[4] * a1 + R[5] * a2 + z[7];
    L[8] = R[6] * a0 + R[7] * a1 + R[8] * a2 + z[8];
    for (i = 9; i < {nl}; ++i) {{
        L[i] = z[i + 9];
    }}
    {P}_flow(fl, L);                                     /* C(h/2) */
    {P}_expso3(u[0] * hh, u[1] * hh, u[2] * hh, E);     /* A(h/2) */
    {P}_mm(R, E, RE);
    for (i = 0; i < 9; ++i) {{
        tmp[i] = RE[i] - R[i];
    }}
    z0 = L[6] + (tmp[0] * a0 + tmp[1] * a1 + tmp[2] * a2);
    z1 = L[7] + (tmp[3] * a0 + tmp[4] * a1 + tmp[5] * a2);
    z2 = L[8] + (tmp[6] * a0 + tmp[7] * a1 + tmp[8] * a2);
    /* B(h): A_b's columns m, c = m x a, m x c (orthogonal), normalised into U */
    c0 = m1 * a2 - m2 * a1;
    c1 = m2 * a0 - m0 * a2;
    c2 = m0 * a1 - m1 * a0;
    mm = m0 * m0 + m1 * m1 + m2 * m2;
    q = c0 * c0 + c1 * c1 + c2 * c2;
    if (!(q > 1e-18 * mm * (a0 * a0 + a1 * a1 + a2 * a2))) {{
        /* m^b parallel to a^b: mu_2 = mu_3 = 0, any orthonormal completion of U will do */
        if (fabs(m0) < 0.9 * sqrt(mm)) {{
            c0 = 0.0;
            c1 = m2;
            c2 = -m1;
        }} else {{
            c0 = -m2;
            c1 = 0.0;
            c2 = m0;
        }}
    }}
    e0 = m1 * c2 - m2 * c1;
    e1 = m2 * c0 - m0 * c2;
    e2 = m0 * c1 - m1 * c0;
    n0 = sqrt(m0 * m0 + m1 * m1 + m2 * m2);
    n1 = sqrt(c0 * c0 + c1 * c1 + c2 * c2);
    n2 = sqrt(e0 * e0 + e1 * e1 + e2 * e2);
    U[0] = m0 / n0; U[1] = c0 / n1; U[2] = e0 / n2;
    U[3] = m1 / n0; U[4] = c1 / n1; U[5] = e1 / n2;
    U[6] = m2 / n0; U[7] = c2 / n1; U[8] = e2 / n2;
    s0 = mm;
    s1 = q;
    s2 = mm * q;
    for (i = 0; i < 3; ++i) {{
        An[3 * i] = {P}_mn[i];
        An[3 * i + 1] = {P}_Sn[3 * i] * z0 + {P}_Sn[3 * i + 1] * z1 + {P}_Sn[3 * i + 2] * z2;
        An[3 * i + 2] = {P}_Sn2[3 * i] * z0 + {P}_Sn2[3 * i + 1] * z1 + {P}_Sn2[3 * i + 2] * z2;
    }}
    r0 = -sqrt({P}_floor(s0));
    r1 = -sqrt({P}_floor(s1));
    r2 = -sqrt({P}_floor(s2));
    if ({P}_hasV[mode]) {{
        {P}_mTm(V, RE, tmp);
        {P}_mm(tmp, U, T);
        {P}_mTm(V, An, W);
    }} else {{
        {P}_mm(RE, U, T);
        for (i = 0; i < 9; ++i) {{
            W[i] = An[i];
        }}
    }}
    for (i = 0; i < 3; ++i) {{
        const double gi = -h * g[i];
        const double x0 = expm1(gi * s0), x1 = expm1(gi * s1), x2 = expm1(gi * s2);
        X[3 * i] = (1.0 + x0) * T[3 * i] + x0 / r0 * W[3 * i];
        X[3 * i + 1] = (1.0 + x1) * T[3 * i + 1] + x1 / r1 * W[3 * i + 1];
        X[3 * i + 2] = (1.0 + x2) * T[3 * i + 2] + x2 / r2 * W[3 * i + 2];
    }}
    if ({P}_hasV[mode]) {{
        {P}_mm(V, X, tmp);
        {P}_mmT(tmp, U, R1);
    }} else {{
        {P}_mmT(X, U, R1);
    }}
    xi0 = z0 - (R1[0] * a0 + R1[1] * a1 + R1[2] * a2);
    xi1 = z1 - (R1[3] * a0 + R1[4] * a1 + R1[5] * a2);
    xi2 = z2 - (R1[6] * a0 + R1[7] * a1 + R1[8] * a2);
    {P}_mm(R1, E, R2);                                  /* A(h/2) */
    Ra0 = R2[0] * a0 + R2[1] * a1 + R2[2] * a2;
    Ra1 = R2[3] * a0 + R2[4] * a1 + R2[5] * a2;
    Ra2 = R2[6] * a0 + R2[7] * a1 + R2[8] * a2;
    L[6] = xi0 + Ra0;
    L[7] = xi1 + Ra1;
    L[8] = xi2 + Ra2;
    {P}_flow(fl, L);                                     /* C(h/2) */
    for (i = 0; i < 6; ++i) {{
        z[i] = L[i];
    }}
    z[6] = L[6] - Ra0;
    z[7] = L[7] - Ra1;
    z[8] = L[8] - Ra2;
    for (i = 0; i < 9; ++i) {{
        z[9 + i] = R2[i];
    }}
    for (i = 9; i < {nl}; ++i) {{
        z[i + 9] = L[i];
    }}
    return {up}_OK;
}}

/* the right-hand side of (24a)-(24d) and of the measurement predictor, Gamma = Gamma(t) */
static int {P}_rhs_(double t, const double *z, const double *u, const double *y, double *dz)
{{
    const int mode = {P}_mode(t);
    const double *G = {P}_Gam + 9 * mode;
    const double *Km = {P}_K + {9 * ny} * {P}_kmode[mode];
    const double *R = z + 9;
    const double w0 = u[0], w1 = u[1], w2 = u[2], a0 = u[3], a1 = u[4], a2 = u[5], m0 = u[6], m1 = u[7], m2 = u[8];
    const double act = z[{has}] != 0.0 ? 1.0 : 0.0;
    double zh[3], c2[3], c3[3], Sz[3], Sz2[3], Gm[3], J[9], GJ[9], e[{ny}], inj[9];
    int i, j, k;
    (void)y;
    for (i = 0; i < 3; ++i) {{
        zh[i] = R[3 * i] * a0 + R[3 * i + 1] * a1 + R[3 * i + 2] * a2 + z[6 + i];
    }}
    c2[0] = m1 * a2 - m2 * a1;                           /* m^b x a^b */
    c2[1] = m2 * a0 - m0 * a2;
    c2[2] = m0 * a1 - m1 * a0;
    c3[0] = m1 * c2[2] - m2 * c2[1];                     /* m^b x (m^b x a^b) */
    c3[1] = m2 * c2[0] - m0 * c2[2];
    c3[2] = m0 * c2[1] - m1 * c2[0];
    for (i = 0; i < 3; ++i) {{
        Sz[i] = {P}_Sn[3 * i] * zh[0] + {P}_Sn[3 * i + 1] * zh[1] + {P}_Sn[3 * i + 2] * zh[2];
        Sz2[i] = {P}_Sn2[3 * i] * zh[0] + {P}_Sn2[3 * i + 1] * zh[1] + {P}_Sn2[3 * i + 2] * zh[2];
        Gm[i] = G[3 * i] * {P}_mn[0] + G[3 * i + 1] * {P}_mn[1] + G[3 * i + 2] * {P}_mn[2];
    }}
    /* J' = [S(m^n) z, S(m^n)^2 z] [c2; c3] - R A_b A_b^T, A_b A_b^T = m m^T + c2 c2^T + c3 c3^T */
    for (i = 0; i < 3; ++i) {{
        for (k = 0; k < 3; ++k) {{
            double acc = 0.0;
            for (j = 0; j < 3; ++j) {{
                acc += R[3 * i + j] * ((u[6 + j] * u[6 + k] + c2[j] * c2[k]) + c3[j] * c3[k]);
            }}
            J[3 * i + k] = Sz[i] * c2[k] + Sz2[i] * c3[k] - acc;
        }}
    }}
    /* Gamma J = Gamma m^n m^bT + Gamma J' */
    for (i = 0; i < 3; ++i) {{
        for (k = 0; k < 3; ++k) {{
            GJ[3 * i + k] = Gm[i] * u[6 + k] + (G[3 * i] * J[k] + G[3 * i + 1] * J[3 + k] + G[3 * i + 2] * J[6 + k]);
        }}
    }}
    for (i = 0; i < 3; ++i) {{
        e[i] = (z[18 + i] - z[i]) * act;
    }}
""" + ("" if po else """\
    for (i = 0; i < 3; ++i) {
        e[3 + i] = (z[21 + i] - z[3 + i]) * act;
    }
""") + f"""\
    for (i = 0; i < 9; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {ny}; ++j) {{
            acc += e[j] * Km[{ny} * i + j];
        }}
        inj[i] = acc;
    }}
    for (i = 0; i < 3; ++i) {{
        const double Rw0 = R[3 * i + 1] * w2 - R[3 * i + 2] * w1;   /* (R S(w))[i, :] */
        const double Rw1 = R[3 * i + 2] * w0 - R[3 * i] * w2;
        const double Rw2 = R[3 * i] * w1 - R[3 * i + 1] * w0;
        dz[i] = z[3 + i] + inj[i];                                   /* (24a) */
        dz[3 + i] = zh[i] + {P}_gn[i] + inj[3 + i];                  /* (24b) */
        dz[6 + i] = inj[6 + i] - (GJ[3 * i] * a0 + GJ[3 * i + 1] * a1 + GJ[3 * i + 2] * a2);  /* (24c) */
        dz[9 + 3 * i] = Rw0 + GJ[3 * i];                             /* (24d) */
        dz[10 + 3 * i] = Rw1 + GJ[3 * i + 1];
        dz[11 + 3 * i] = Rw2 + GJ[3 * i + 2];
""" + (
            ("        dz[18 + i] = z[3 + i];                                       /* y_p' = v_hat */\n" if po else
             f"        dz[18 + i] = z[21 + i];                                      /* y_p' = y_v */\n"
             f"        dz[21 + i] = zh[i] + {P}_gn[i];                               /* y_v' = z_hat + g^n */\n")
            if predict else
            "".join(f"        dz[{18 + 3 * b} + i] = 0.0;                                        /* held fix */\n"
                    for b in range(ny // 3))) + f"""\
    }}
    dz[{has}] = 0.0;
    dz[{skip}] = 0.0;
    return {up}_OK;
}}

/* take a GNSS fix into the held measurement; a fix with a non-finite (or unsampled) channel is skipped */
static int {P}_correct_(double t, double *z, const double *u, const double *y, const unsigned char *fresh)
{{
    int j, ok = 1;
    (void)t;
    (void)u;
    for (j = 0; j < {ny}; ++j) {{
        if (!fresh[j] || !(y[j] - y[j] == 0.0)) {{
            ok = 0;
        }}
    }}
    if (ok) {{
        for (j = 0; j < {ny}; ++j) {{
            z[18 + j] = y[j];
        }}
        z[{has}] = 1.0;
    }} else {{
        z[{skip}] += 1.0;
    }}
    return {up}_OK;
}}

/* x_hat0 = [p, v, R] -> [p, v, xi = 0, R, y = 0, has_fix = 0, skipped = 0] */
static int {P}_init_(const double *xhat0, double *z)
{{
    int i;
    for (i = 0; i < {nz}; ++i) {{
        z[i] = 0.0;
    }}
    for (i = 0; i < 6; ++i) {{
        z[i] = xhat0[i];
    }}
    for (i = 0; i < 9; ++i) {{
        z[9 + i] = xhat0[6 + i];
    }}
    return {P}_finite(z, {nz}) ? {up}_OK : {up}_NONFINITE;
}}

/* the raw estimate [p, v, R] (R row-major, not projected onto SO(3)) */
static void {P}_estimate_(const double *z, double *xhat)
{{
    int i;
    for (i = 0; i < 6; ++i) {{
        xhat[i] = z[i];
    }}
    for (i = 0; i < 9; ++i) {{
        xhat[6 + i] = z[9 + i];
    }}
}}
"""])
    notes = _notes(observer, base, modes, times, h0, po)
    title = ("Scheduled GNSS/INS observer (24)" if times or type(observer).__name__ == "ScheduledGnssInsObserver"
             else "GNSS/INS observer (24)") + " of Grip, Saberi & Johansen, split step"
    return CProgram(prefix=P, title=title, n_z=nz, n_x=15, n_u=9, n_y=ny, discrete=False, body=body,
                    correcting=True, own_step=True, own_init=True, own_estimate=True, notes=notes,
                    codec=gnss_ins_codec(po),
                    status1=f"a step other than the module's IMU period h0 = {h0:.17g} s: generate it for that "
                            "period (imu_period=)")


def _notes(observer: Any, base: Any, modes: tuple[Any, ...], times: tuple[float, ...], h0: float,
           po: bool) -> tuple[tuple[str, str], ...]:
    notes: list[tuple[str, str]] = [
        ("observer", "(24): p' = v + K_p e, v' = R a + xi + g + K_v e, xi' = -Gamma J a + K_z e, "
                     "R' = R S(w) + Gamma J; J = A_n A_b^T - R A_b A_b^T (TRIAD)"),
        ("state", f"[p, v, xi, R (row-major), y_p{'' if po else ', y_v'}, has_fix, skipped]"),
        ("input u", "[omega_b, a_b, m_b] (IMU, held over the step)"),
        ("output y", "GNSS fix [p]" if po else "GNSS fix [p, v]"),
        ("estimate", "[p, v, R] raw (project R onto SO(3) afterwards)"),
        ("step", "Strang split C(h/2) A(h/2) B(h) A(h/2) C(h/2), exact sub-flows"),
        ("IMU period", f"h0 = {h0:.17g} s; |h - h0| <= {IMU_PERIOD_RTOL:g} h0, else status 1"),
        ("intersample", str(base.intersample)),
        ("gain K", matrix_note(modes[-1].K)),
        ("rho(A - K C)", f"{modes[-1]._rho:.6g} 1/s"),
        ("m_n", matrix_note(base.m_n)),
        ("g_n", matrix_note(base.g_n)),
    ]
    if type(observer).__name__ == "ScheduledGnssInsObserver":
        notes.append(("Gamma(t)", comment(observer.schedule.describe())))
        sch = observer.schedule
        notes.append(("Gamma bounds", f"min lambda_min = {sch.smallest_eigenvalue:.17g}, "
                                      f"max lambda_max = {sch.largest_eigenvalue:.17g}"))
        notes.append(("switch times", ", ".join(f"{t:.17g}" for t in times) + " s (mode = number of "
                                      "switch times <= t + 1e-9)"))
        if observer.gain_schedule is not None:
            notes.append(("K(t)", comment(observer.gain_schedule.describe() + " (per axis; gain K above is the last)")))
    else:
        notes.append(("Gamma", matrix_note(base.Gamma)))
        lam = np.linalg.eigvalsh(np.asarray(base.Gamma, dtype=float))
        notes.append(("Gamma eigenvalues", ", ".join(f"{v:.17g}" for v in lam)))
    return tuple(notes)
