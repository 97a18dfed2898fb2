"""A generated observer as C: :class:`CProgram` and the one C interface every module has.

Every generated module with prefix ``P`` (a C identifier) has these functions (``P.h``); arrays
are plain ``double`` arrays of one run, no heap, no global state, nothing beyond ``<math.h>``:

* ``int P_init(const double *xhat0, double *z)`` — the observer state from an initial estimate;
* ``int P_rhs(double t, const double *z, const double *u, const double *y, double *dz)`` — ``ż``
  (continuous) or ``z⁺`` (discrete);
* ``int P_step(double t, double *z, const double *u, const double *y, double h)`` — in place, the
  state at ``t + h`` with ``u`` and ``y`` held over the step: one classical RK4 step of ``P_rhs``
  (the integrator of :func:`nlobs.simulate.integrators.rk4_step`, stage for stage), the observer's
  own discretisation where it has one, or ``z ← z⁺`` for a discrete observer (``h`` unused);
* ``int P_step_stages(double t, double *z, const double *u0, const double *uh, const double *u1,
  const double *y, double h)`` — only where ``P_step`` is the common RK4 step: the same step with the input
  ``u0`` at ``t``, ``uh`` at the two stages at ``t + h/2`` and ``u1`` at ``t + h`` (a known input that varies
  within the step, as :func:`nlobs.simulate.simulate` evaluates it; ``P_step`` is ``u0 = uh = u1 = u``), and
  ``P_step_stages_batch``;
* ``int P_correct(double t, double *z, const double *u, const double *y, const unsigned char *fresh)``
  — only for observers that correct at samples (``fresh[j]`` non-zero where output ``j`` was just
  sampled; a non-finite sampled value is a missing sample, skipped);
* ``void P_estimate(const double *z, double *xhat)`` (and ``P_estimate_batch(long n, …)``);
* ``long P_rhs_batch(…, double *dz, int *status)``, ``long P_step_batch(long n, double t, double *z,
  const double *u, const double *y, double h, int *status)`` (and ``P_correct_batch``) — the same for
  ``n`` runs stored one after the other, every run advanced whatever the others did: the status of
  run ``r`` in ``status[r]`` (``status`` may be ``NULL``), the number of failing runs returned;
* ``long P_run(long K, const double *t, double *z, const double *u, const double *y,
  const unsigned char *sampled, double *xhat)`` — one run over a record of ``K`` instants, the loop
  of :func:`nlobs.simulate.run_observer`: at ``t[k]`` a correcting observer corrects where
  ``sampled[k][j]`` (``NULL``: every output at every instant), any other takes the samples into its
  held measurement; ``xhat[k]`` is recorded; the observer advances to ``t[k+1]``;
* ``long P_run_batch(long n, long K, …, int *status)`` — ``n`` such runs (their states, inputs,
  measurements and estimates one after the other; ``sampled`` shared), each going on through a
  non-finite state (its estimates are then NaN) and stopping only at a singular matrix (``status[r]``).

Every ``int`` function returns ``P_OK`` (0), ``P_SINGULAR`` (1: a matrix the observer inverts is
singular, e.g. ``Q_s(x̂)`` of Dalla Mora, Germani & Manes (3.1)) or ``P_NONFINITE`` (2: the new state
is not finite: the state holds the non-finite values, never the previous state); ``P_run`` returns 0
or one plus the index of the instant whose step or correction failed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from nlobs.export.cprint import PRELUDE, c_double, comment

__all__ = ["CProgram", "StateCodec", "nlobs_version", "render"]


def nlobs_version() -> str:
    """The installed nlobs's version (written into every generated header)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("nlobs")
    except PackageNotFoundError:  # a source tree that was never installed
        return "0+unknown"


@dataclass(frozen=True)
class StateCodec:
    """How an observer's state maps to the flat ``double`` array of the C module (one run: ``n_z`` values).

    Attributes
    ----------
    pack : callable
        ``pack(z) -> ndarray (..., n_z)``.
    unpack : callable
        ``unpack(flat) -> z`` (the observer's own state type).
    """

    pack: Callable[[Any], Any]
    unpack: Callable[[Any], Any]


@dataclass(frozen=True)
class CProgram:
    """An observer's step as C99 source, with what the Python side needs to call it.

    Attributes
    ----------
    prefix : str
        The C identifier in front of every public name.
    title : str
        One line: which observer, of which model.
    n_z, n_x, n_u, n_y : int
        Sizes of one run's state, estimate, input and measurement.
    discrete : bool
        ``P_rhs`` is ``z⁺`` (else ``ż``).
    correcting : bool
        The body defines ``P_correct_``.
    own_step : bool
        The body defines ``P_step_`` (else ``P_step`` is RK4 on ``P_rhs_``, or ``z ← z⁺``).
    own_init : bool
        The body defines ``P_init_`` (else ``z = x̂0``).
    own_estimate : bool
        The body defines ``P_estimate_`` (else ``x̂ = z``).
    body : str
        Static C definitions: ``int P_rhs_(double t, const double *z, const double *u,
        const double *y, double *dz)`` and the optional ones above.
    notes : tuple of (str, str)
        The header's comment block: model, gain, certificate summary…
    codec : StateCodec or None
        For a structured observer state (``None``: the state is the flat array).
    dt : float or None
        A discrete observer's period.
    status1 : str
        What status 1 (``P_SINGULAR``) means for this module (messages).

    Examples
    --------
    The smallest module by hand: a first-order filter ``ż = 2 (y − z)`` (one state, no input, one output).
    The body defines ``P_rhs_`` only, so ``P_step`` is the common RK4 step; built and loaded, one step of
    ``h = 0.1`` from ``z = 0`` towards ``y = 1`` gives ``1 − e^{−0.2}`` to RK4's accuracy (its polynomial, exactly):

    >>> import ctypes
    >>> import math
    >>> from nlobs.export.compiled import load_library
    >>> body = '''static int low_rhs_(double t, const double *z, const double *u, const double *y, double *dz)
    ... {
    ...     (void)t;
    ...     (void)u;
    ...     dz[0] = 2.0 * (y[0] - z[0]);
    ...     return 0;
    ... }
    ... '''
    >>> program = CProgram(prefix="low", title="first-order filter", n_z=1, n_x=1, n_u=0, n_y=1, discrete=False,
    ...                    body=body, notes=(("pole", "-2"),))
    >>> program.header_name, program.source_name, program.staged
    ('low.h', 'low.c', True)
    >>> lib = load_library(program)
    >>> z, y = (ctypes.c_double * 1)(0.0), (ctypes.c_double * 1)(1.0)
    >>> lib.low_step(0.0, ctypes.addressof(z), None, ctypes.addressof(y), 0.1)  # P_OK
    0
    >>> a = 0.2  # RK4 on ż = 2 (y − z) is the Taylor polynomial of e^{−2h} to fourth order
    >>> rk4 = 1.0 - (1 - a + a**2 / 2 - a**3 / 6 + a**4 / 24)
    >>> round(z[0], 6), round(1.0 - math.exp(-a), 6), abs(z[0] - rk4) < 1e-15
    (0.181267, 0.181269, True)
    """

    prefix: str
    title: str
    n_z: int
    n_x: int
    n_u: int
    n_y: int
    discrete: bool
    body: str
    correcting: bool = False
    own_step: bool = False
    own_init: bool = False
    own_estimate: bool = False
    notes: tuple[tuple[str, str], ...] = ()
    codec: StateCodec | None = field(default=None, repr=False, compare=False)
    dt: float | None = None
    status1: str = "a singular matrix, e.g. a pivot at rounding level"

    @property
    def staged(self) -> bool:
        """``P_step`` is the common RK4 of ``P_rhs``: the module also has ``P_step_stages`` (an input per stage)."""
        return not self.own_step and not self.discrete

    @property
    def header_name(self) -> str:
        """``P.h``."""
        return f"{self.prefix}.h"

    @property
    def source_name(self) -> str:
        """``P.c``."""
        return f"{self.prefix}.c"


def _usage(program: CProgram) -> list[str]:
    P, up = program.prefix, program.prefix.upper()
    sizes = f"double z[{up}_NZ], u[{up}_NU], y[{up}_NY], xhat[{up}_NX]"
    lines = ["Use, one run (every function returns 0, or 1 singular matrix, 2 non-finite state):",
             f"  {sizes};",
             f"  {P}_init(xhat0, z);",
             "  at every instant t_k:"]
    if program.correcting:
        lines.append(f"    where a sample arrived: {P}_correct(t_k, z, u, y, fresh);  (fresh[j] = 1 for output j)")
    else:
        lines.append("    where a sample arrived: copy it into y (held until the next one);")
    lines += [f"    {P}_estimate(z, xhat);",
              f"    {P}_step(t_k, z, u, y, t_k1 - t_k);  (u{'' if program.correcting else ' and y'} held over the step)"]
    if program.discrete:
        lines[-1] = f"    {P}_step(t_k, z, u, y, 0.0);  (z <- z+, every {up}_DT)"
    return lines


def _banner(program: CProgram, version: str, usage: bool = False) -> str:
    lines = [program.title, "", f"Generated by nlobs {version}. Do not edit: generate it again from the design.", ""]
    if usage:
        lines += _usage(program) + [""]
    width = max((len(k) for k, _ in program.notes), default=0)
    for key, value in program.notes:
        text = str(value).splitlines() or [""]
        lines.append(f"{key.ljust(width)} : {text[0]}")
        lines.extend(f"{' ' * width}   {more}" for more in text[1:])
    body = "\n".join(f" * {comment(ln)}".rstrip() for ln in lines)
    return f"/*\n{body}\n */\n"


def render(program: CProgram, version: str) -> tuple[str, str]:
    """The header and the source of ``program`` (module docstring for the interface).

    Parameters
    ----------
    program : CProgram
        What the observer-specific generator produced.
    version : str
        nlobs's version, written into the comment block.

    Returns
    -------
    (str, str)
        ``P.h`` and ``P.c``.

    Examples
    --------
    The two files of a Luenberger observer's module: the header declares the interface of the module
    docstring with the sizes as macros; the source includes it and compiles with every warning an error:

    >>> import nlobs
    >>> from nlobs.export.compiler import compile_object
    >>> from nlobs.export.generate import generate
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> program = generate(nlobs.LuenbergerObserver(system, [[4.5], [1.75]]), "osc")
    >>> header, source = render(program, "1.0")
    >>> [line.split()[1:3] for line in header.splitlines() if line.startswith("#define OSC_N")]
    [['OSC_NZ', '2'], ['OSC_NX', '2'], ['OSC_NU', '1'], ['OSC_NY', '1'], ['OSC_NONFINITE', '2']]
    >>> "int osc_step(double t, double *z, const double *u, const double *y, double h);" in header
    True
    >>> "Generated by nlobs 1.0." in source, '#include "osc.h"' in source
    (True, True)
    >>> compile_object(source, strict=True, headers={program.header_name: header}) is None
    True
    """
    P, up = program.prefix, program.prefix.upper()
    guard = f"{up}_H"
    api = [
        f"int {P}_init(const double *xhat0, double *z);",
        f"int {P}_rhs(double t, const double *z, const double *u, const double *y, double *dz);",
        f"int {P}_step(double t, double *z, const double *u, const double *y, double h);",
        f"void {P}_estimate(const double *z, double *xhat);",
        f"void {P}_estimate_batch(long n, const double *z, double *xhat);",
        f"long {P}_rhs_batch(long n, double t, const double *z, const double *u, const double *y, double *dz,\n"
        f"                   int *status);",
        f"long {P}_step_batch(long n, double t, double *z, const double *u, const double *y, double h,\n"
        f"                    int *status);",
        f"long {P}_run(long K, const double *t, double *z, const double *u, const double *y,\n"
        f"             const unsigned char *sampled, double *xhat);",
        f"long {P}_run_batch(long n, long K, const double *t, double *z, const double *u, const double *y,\n"
        f"                   const unsigned char *sampled, double *xhat, int *status);",
    ]
    if program.staged:
        api.insert(3, f"int {P}_step_stages(double t, double *z, const double *u0, const double *uh, const double *u1,\n"
                      f"                  const double *y, double h);")
        api.append(f"long {P}_step_stages_batch(long n, double t, double *z, const double *u0, const double *uh,\n"
                   f"                          const double *u1, const double *y, double h, int *status);")
    if program.correcting:
        api.insert(3, f"int {P}_correct(double t, double *z, const double *u, const double *y, "
                      "const unsigned char *fresh);")
        api.append(f"long {P}_correct_batch(long n, double t, double *z, const double *u, const double *y,\n"
                   f"                      const unsigned char *fresh, int *status);")
    defines = [
        f"#define {up}_NZ {program.n_z}   /* observer state, per run */",
        f"#define {up}_NX {program.n_x}   /* estimate */",
        f"#define {up}_NU {program.n_u}   /* known input */",
        f"#define {up}_NY {program.n_y}   /* measurement */",
        f"#define {up}_DISCRETE {int(program.discrete)}",
    ]
    if program.dt is not None:
        defines.append(f"#define {up}_DT {c_double(program.dt)}")
    defines += [f"#define {up}_OK 0", f"#define {up}_SINGULAR 1", f"#define {up}_NONFINITE 2"]
    header = (_banner(program, version, usage=True) + f"#ifndef {guard}\n#define {guard}\n\n" + "\n".join(defines) + "\n\n"
              + "\n".join(api) + f"\n\n#endif /* {guard} */\n")
    prelude = "".join(text for name, text in PRELUDE.items() if f"{name}(" in program.body)
    src = [_banner(program, version), "#include <math.h>", f'#include "{program.header_name}"', "",
           prelude, _nz_helpers(P, up), program.body.rstrip() + "\n", _public(program)]
    return header, "\n".join(src)


def _nz_helpers(P: str, up: str) -> str:
    return f"""\
/* n is at least 1 in every array below: C has no zero-length arrays */
#define {up}_NZ1 ({up}_NZ > 0 ? {up}_NZ : 1)
#define {up}_NU1 ({up}_NU > 0 ? {up}_NU : 1)
#define {up}_NY1 ({up}_NY > 0 ? {up}_NY : 1)

static int {P}_finite(const double *v, int n)
{{
    int i;
    for (i = 0; i < n; ++i) {{
        if (!(v[i] - v[i] == 0.0)) {{
            return 0;
        }}
    }}
    return 1;
}}
"""


def _public(program: CProgram) -> str:
    P, up = program.prefix, program.prefix.upper()
    init = (f"    return {P}_init_(xhat0, z);" if program.own_init else
            f"    int i;\n    for (i = 0; i < {up}_NZ; ++i) {{\n        z[i] = xhat0[i];\n    }}\n"
            f"    return {P}_finite(z, {up}_NZ) ? {up}_OK : {up}_NONFINITE;")
    estimate = (f"    {P}_estimate_(z, xhat);" if program.own_estimate else
                f"    int i;\n    for (i = 0; i < {up}_NX; ++i) {{\n        xhat[i] = z[i];\n    }}")
    void = ""
    if program.own_step:
        step = f"    int s = {P}_step_(t, z, u, y, h);\n    if (s != {up}_OK) {{\n        return s;\n    }}"
    elif program.discrete:
        step = (f"    double zn[{up}_NZ1];\n    int i, s;\n    (void)h;\n"
                f"    s = {P}_rhs_(t, z, u, y, zn);\n    if (s == {up}_SINGULAR) {{\n        return s;\n    }}\n"
                f"    /* non-finite: z+ as the right-hand side left it (NaN where it failed), never the old state */\n"
                f"    for (i = 0; i < {up}_NZ; ++i) {{\n        z[i] = zn[i];\n    }}\n"
                f"    if (s != {up}_OK) {{\n        return s;\n    }}")
    else:
        void = f"""\
/* an RK4 stage reported non-finite: the run's state becomes NaN (it must not keep its previous value) */
static void {P}_void(double *z)
{{
    int i;
    for (i = 0; i < {up}_NZ; ++i) {{
        z[i] = NAN;
    }}
}}

"""
        stages = f"""\
    double k1[{up}_NZ1], k2[{up}_NZ1], k3[{up}_NZ1], k4[{up}_NZ1], w[{up}_NZ1];
    const double hh = 0.5 * h, h6 = h / 6.0;
    int i, s;
    /* classical RK4 with y held and the input u0 at t, uh at t + h/2, u1 at t + h, stage for stage as
       nlobs.simulate.integrators.rk4_step */
    if ((s = {P}_rhs_(t, z, u0, y, k1)) != {up}_OK) {{
        if (s == {up}_NONFINITE) {{
            {P}_void(z);
        }}
        return s;
    }}
    for (i = 0; i < {up}_NZ; ++i) {{
        w[i] = z[i] + hh * k1[i];
    }}
    if ((s = {P}_rhs_(t + hh, w, uh, y, k2)) != {up}_OK) {{
        if (s == {up}_NONFINITE) {{
            {P}_void(z);
        }}
        return s;
    }}
    for (i = 0; i < {up}_NZ; ++i) {{
        w[i] = z[i] + hh * k2[i];
    }}
    if ((s = {P}_rhs_(t + hh, w, uh, y, k3)) != {up}_OK) {{
        if (s == {up}_NONFINITE) {{
            {P}_void(z);
        }}
        return s;
    }}
    for (i = 0; i < {up}_NZ; ++i) {{
        w[i] = z[i] + h * k3[i];
    }}
    if ((s = {P}_rhs_(t + h, w, u1, y, k4)) != {up}_OK) {{
        if (s == {up}_NONFINITE) {{
            {P}_void(z);
        }}
        return s;
    }}
    for (i = 0; i < {up}_NZ; ++i) {{
        z[i] = z[i] + h6 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }}
    return {P}_finite(z, {up}_NZ) ? {up}_OK : {up}_NONFINITE;"""
        void += f"""\
int {P}_step_stages(double t, double *z, const double *u0, const double *uh, const double *u1, const double *y,
                    double h)
{{
{stages}
}}

long {P}_step_stages_batch(long n, double t, double *z, const double *u0, const double *uh, const double *u1,
                          const double *y, double h, int *status)
{{
    long r, bad = 0;
    for (r = 0; r < n; ++r) {{
        int s = {P}_step_stages(t, z + r * {up}_NZ, u0 + r * {up}_NU, uh + r * {up}_NU, u1 + r * {up}_NU,
                                y + r * {up}_NY, h);
        bad += (s != {up}_OK);
        if (status != 0) {{
            status[r] = s;
        }}
    }}
    return bad;
}}

"""
        step = f"    return {P}_step_stages(t, z, u, u, u, y, h);"
    finish = "" if program.staged else f"\n    return {P}_finite(z, {up}_NZ) ? {up}_OK : {up}_NONFINITE;"
    out = [void + f"""\
int {P}_init(const double *xhat0, double *z)
{{
{init}
}}

int {P}_rhs(double t, const double *z, const double *u, const double *y, double *dz)
{{
    int s = {P}_rhs_(t, z, u, y, dz);
    if (s != {up}_OK) {{
        return s;
    }}
    return {P}_finite(dz, {up}_NZ) ? {up}_OK : {up}_NONFINITE;
}}

int {P}_step(double t, double *z, const double *u, const double *y, double h)
{{
{step}{finish}
}}

void {P}_estimate(const double *z, double *xhat)
{{
{estimate}
}}

void {P}_estimate_batch(long n, const double *z, double *xhat)
{{
    long r;
    for (r = 0; r < n; ++r) {{
        {P}_estimate(z + r * {up}_NZ, xhat + r * {up}_NX);
    }}
}}

long {P}_rhs_batch(long n, double t, const double *z, const double *u, const double *y, double *dz, int *status)
{{
    long r, bad = 0;
    for (r = 0; r < n; ++r) {{
        int s = {P}_rhs(t, z + r * {up}_NZ, u + r * {up}_NU, y + r * {up}_NY, dz + r * {up}_NZ);
        bad += (s != {up}_OK);
        if (status != 0) {{
            status[r] = s;
        }}
    }}
    return bad;
}}

long {P}_step_batch(long n, double t, double *z, const double *u, const double *y, double h, int *status)
{{
    long r, bad = 0;
    for (r = 0; r < n; ++r) {{
        int s = {P}_step(t, z + r * {up}_NZ, u + r * {up}_NU, y + r * {up}_NY, h);
        bad += (s != {up}_OK);
        if (status != 0) {{
            status[r] = s;
        }}
    }}
    return bad;
}}
"""]
    if program.correcting:
        out.append(f"""\
int {P}_correct(double t, double *z, const double *u, const double *y, const unsigned char *fresh)
{{
    int s = {P}_correct_(t, z, u, y, fresh);
    if (s != {up}_OK) {{
        return s;
    }}
    return {P}_finite(z, {up}_NZ) ? {up}_OK : {up}_NONFINITE;
}}

long {P}_correct_batch(long n, double t, double *z, const double *u, const double *y,
                      const unsigned char *fresh, int *status)
{{
    long r, bad = 0;
    for (r = 0; r < n; ++r) {{
        int s = {P}_correct(t, z + r * {up}_NZ, u + r * {up}_NU, y + r * {up}_NY, fresh);
        bad += (s != {up}_OK);
        if (status != 0) {{
            status[r] = s;
        }}
    }}
    return bad;
}}
""")
    if program.correcting:
        sample = f"""\
            s = {P}_correct(t[k], z, uk, y + k * {up}_NY, fresh);
            if (s != {up}_OK && !(s == {up}_NONFINITE && keep)) {{
                *status = s;
                return k + 1;
            }}"""
    else:
        sample = f"""\
            for (j = 0; j < {up}_NY; ++j) {{
                if (fresh[j]) {{
                    held[j] = y[k * {up}_NY + j];
                }}
            }}"""
    out.append(f"""\
/* one run over K instants (the loop of run_observer); keep: go on through non-finite states */
static long {P}_run_one(long K, const double *t, double *z, const double *u, const double *y,
                        const unsigned char *sampled, double *xhat, int keep, int *status)
{{
    double held[{up}_NY1];
    unsigned char fresh[{up}_NY1];
    long k;
    int j, any, s;
    *status = {up}_OK;
    for (j = 0; j < {up}_NY1; ++j) {{
        held[j] = NAN;
    }}
    for (k = 0; k < K; ++k) {{
        const double *uk = u + k * {up}_NU;
        any = 0;
        for (j = 0; j < {up}_NY; ++j) {{
            fresh[j] = (unsigned char)(sampled == 0 ? 1 : (sampled[k * {up}_NY + j] != 0));
            any = any || fresh[j];
        }}
        if (any) {{
{sample}
        }}
        {P}_estimate(z, xhat + k * {up}_NX);
        if (k + 1 < K) {{
            s = {P}_step(t[k], z, uk, held, t[k + 1] - t[k]);
            if (s != {up}_OK && !(s == {up}_NONFINITE && keep)) {{
                *status = s;
                return k + 1;
            }}
        }}
    }}
    return 0;
}}

long {P}_run(long K, const double *t, double *z, const double *u, const double *y,
             const unsigned char *sampled, double *xhat)
{{
    int s;
    return {P}_run_one(K, t, z, u, y, sampled, xhat, 0, &s);
}}

long {P}_run_batch(long n, long K, const double *t, double *z, const double *u, const double *y,
                   const unsigned char *sampled, double *xhat, int *status)
{{
    long r, bad = 0;
    for (r = 0; r < n; ++r) {{
        int s;
        {P}_run_one(K, t, z + r * {up}_NZ, u + r * K * {up}_NU, y + r * K * {up}_NY, sampled,
                    xhat + r * K * {up}_NX, 1, &s);
        bad += (s != {up}_OK);
        if (status != 0) {{
            status[r] = s;
        }}
    }}
    return bad;
}}
""")
    return "\n".join(out)
