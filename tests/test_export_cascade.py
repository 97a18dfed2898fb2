"""The generated C of the cascade/feedback observer of Grip, Saberi & Johansen equals the Python observer.

Observers: the shipped chemostat-analyser built as ``nlobs design cascade`` builds it (its file's
placement design, and LMI (14)), Example 1 of the paper (cascade and feedback, the certified
high-gain design of :func:`nlobs.papers.grip_example1.run_example1`), a model file whose names are
C keywords or not ASCII, with ``B_u``, ``D_u`` and ``D_z`` present, and Appendix A's saturations
written into Σ₁'s expressions.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from nlobs.errors import CompilerError, InvalidArgumentError
from nlobs.export.cascade import design_notes, generate_cascade
from nlobs.export.compiled import compile_observer
from nlobs.export.compiler import compile_object, find_compiler
from nlobs.export.generate import generate
from nlobs.export.program import render
from nlobs.observers.cascade import CascadeObserver
from nlobs.simulate import run_observer, simulate
from nlobs.simulate.integrators import rk4_step
from nlobs.systems.cascade_file import load_cascade, parse_cascade
from nlobs.systems.interconnected import NonlinearSubsystem, interconnected_plant
from nlobs.workflows.design_cascade import design_cascade

RTOL = 1e-12


@pytest.fixture(scope="module", autouse=True)
def _compiler_and_cache(tmp_path_factory: pytest.TempPathFactory):
    try:
        find_compiler()
    except CompilerError as exc:
        pytest.skip(f"no C compiler: {exc}")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("NLOBS_CACHE", str(tmp_path_factory.mktemp("nlobs-c")))
        yield


def _rel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.linalg.norm(a - b) / max(np.linalg.norm(b), 1e-300))


# --------------------------------------------------------------------------- observers
def _chemostat(method: str | None = None):
    design = design_cascade(load_cascade("chemostat-analyser"), method=method)
    assert design.verified
    return design.observer(), design


def _example1(feedback: bool) -> CascadeObserver:
    """Example 1's observer as :func:`~nlobs.papers.grip_example1.run_example1` designs it (γ = 0.9 × Theorem 1's)."""
    from nlobs.papers import grip_example1 as ex
    from nlobs.synthesis import (place_cascade_gain, quadratic_lyapunov_constants, theorem1_optimal_scaling,
                                 theorem1_prime_gamma_bound)

    s1, s2 = ex.example1_sigma1(feedback), ex.example1_sigma2()
    q = quadratic_lyapunov_constants(ex.A1 - ex.L_RAJAMANI @ ex.C1, ex.PHI_LIPSCHITZ)
    L1, L2 = ex.lipschitz_constants(feedback)
    bound = (theorem1_prime_gamma_bound(q.alpha3, q.alpha4, L1, L2) if feedback
             else theorem1_optimal_scaling(q.alpha3, q.alpha4, L1, L2)[1])
    return CascadeObserver.from_certificate(s1, s2, place_cascade_gain(s2, gamma=0.9 * bound))


# Names that are C keywords (int, double, unsigned, static, float, sizeof, main, char), that the generated
# code uses itself (zh, xi, a0, w0, dz, yt), and that are not ASCII (θ, μ); a model name that tries to close
# the header's comment. B_u, D_u and D_z are present, so every term of (9) is exercised.
ODD_MODEL = """
name = "odd */ names ??= here"
inputs = ["unsigned"]
outputs = ["θ", "yt"]
parameters = { sizeof = 0.5, main = 2.0, "μ" = 0.3, char = 1.5 }

[cascade]
form = "{form}"
states = ["int", "a0"]
outputs = ["zh"]
f = ["a0", "-main*int - sizeof*a0 + μ*sin(int{wterm}) + unsigned"]
h = ["a0 + 0.1*sin(int)"]
g = ["char*(zh - a0 - 0.1*sin(int))", "main*(zh - a0 - 0.1*sin(int))"]
method = "placement"
gamma = 1.0

[cascade.linear]
states = ["double", "w0"]
A = [[0.0, 1.0], [-1.0, -1.0]]
B_z = [[0.0], [1.0]]
B_u = [[0.2], [0.0]]
C = [[1.0, 0.0], [0.0, 1.0]]
D_u = [[0.0], [0.3]]
D_z = [[0.0], [0.25]]
"""


def _odd(feedback: bool):
    text = ODD_MODEL.replace("{form}", "feedback" if feedback else "cascade").replace(
        "{wterm}", " + 0.5*w0" if feedback else "")
    design = design_cascade(parse_cascade(text, source="odd.toml"))
    assert design.certificate is not None, design.failure
    return design.observer(), design


def _saturated() -> CascadeObserver:
    """Example 1's Σ₁ with Appendix A's saturations in its expressions: ``g(x̂, sat(ẑ))`` with the hard
    saturation, ``f(sat*(x))`` with the smooth one (identity on [-1, 1], transition width 0.5)."""
    from nlobs.papers import grip_example1 as ex

    x1, x2, z = sp.symbols("x1 x2 z", real=True)
    lo, hi, d = -1.0, 1.0, 0.5

    def smooth(x):  # sat* of nlobs.systems.saturation.SmoothSaturation, as a Piecewise
        up, dn = (x - hi) / d, (lo - x) / d
        return sp.Piecewise((hi + d / 2, up >= 1), (hi + d * (up - up**3 + up**4 / 2), x > hi),
                            (lo - d / 2, dn >= 1), (lo - d * (dn - dn**3 + dn**4 / 2), x < lo), (x, True))

    sat = sp.Min(sp.Max(z, -2.0), 2.0)
    L = ex.L_RAJAMANI[:, 0]
    s1 = NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], h=[x2],
                                     f=[x2, x1 - x2 + ex.PHI_LIPSCHITZ * sp.sin(smooth(x1))],
                                     g=[float(L[0]) * (sat - x2), float(L[1]) * (sat - x2)], name="saturated")
    return CascadeObserver(s1, ex.example1_sigma2(), _example1(False).K)


CASES = {
    "chemostat-placement": lambda: _chemostat()[0],
    "chemostat-lmi": lambda: _chemostat("lmi")[0],
    "example1-cascade": lambda: _example1(False),
    "example1-feedback": lambda: _example1(True),
    "odd-cascade": lambda: _odd(False)[0],
    "odd-feedback": lambda: _odd(True)[0],
    "saturated": _saturated,
}

# grid, initial plant state and estimate error of each model; Example 1's measurement noise is small because its
# certified gain is high (K_z ~ 1e9 differentiates the noise into z_hat)
RUNS = {
    "chemostat": dict(dt=0.01, K=1500, x0=[1.5, 0.5, 1.5], err=[0.3, 0.05, 0.05], noise=0.01),
    "example1": dict(dt=2.5e-4, K=2000, x0=[1.0, -0.5, 0.2, 0.0], err=[0.5, 0.5, 0.1, 0.1], noise=1e-7),
    "odd": dict(dt=0.01, K=800, x0=[0.5, -0.3, 0.1, 0.0], err=[0.3, 0.3, 0.1, 0.1], noise=1e-2),
    "saturated": dict(dt=2.5e-4, K=2000, x0=[1.8, -0.5, 0.2, 0.0], err=[1.5, 0.5, 0.1, 0.1], noise=1e-7),
}


def _record(obs: CascadeObserver, case: str, batch: int = 3):
    """A noisy run of the plant: grid, input, measurements and initial estimates of ``batch`` runs."""
    cfg = RUNS[case.split("-")[0]]
    rng = np.random.default_rng(7)
    plant = interconnected_plant(obs.sigma1, obs.sigma2)
    x0 = np.asarray(cfg["x0"]) * (1.0 + 0.1 * rng.standard_normal((batch, len(cfg["x0"]))))
    m = obs.sigma1.m

    def u_of(t):
        return np.full(m, 0.3 + 0.1 * np.sin(0.5 * t)) if m else np.zeros(0)

    dt, K = cfg["dt"], cfg["K"]
    res = simulate(plant, None, x0, duration=dt * (K - 1), dt=dt, u=u_of if m else None)
    t = res.t
    assert t.size == K
    y = res.y + cfg["noise"] * rng.standard_normal(res.y.shape)
    u = np.stack([u_of(tk) for tk in t]) if m else None
    x_hat0 = x0 + np.asarray(cfg["err"]) * rng.standard_normal(x0.shape)
    return t, u, y, x_hat0


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    obs = CASES[request.param]()
    return request.param, obs, compile_observer(obs)


# --------------------------------------------------------------------------- strict compilation, header
@pytest.mark.parametrize("name", sorted(CASES))
def test_strict_compilation(name):
    obs = CASES[name]()
    program = generate(obs, "casc")
    header, source = render(program, "test")
    compile_object(source, strict=True, headers={program.header_name: header})
    assert program.n_z == obs.n_z and program.n_x == obs.n_x and not program.discrete
    assert program.own_init and program.own_estimate and not program.own_step and not program.correcting


def test_odd_names_stay_in_comments():
    obs, design = _odd(True)
    program = generate(obs, "odd", notes=design_notes(design))
    header, source = render(program, "test")
    compile_object(source, strict=True, headers={program.header_name: header})
    code = "\n".join(ln for ln in source.splitlines() if not ln.lstrip().startswith(("*", "/*")))
    assert code.isascii()
    for name in ("sizeof", "main"):
        assert name not in code, name
    assert "*/ names" not in header and "??=" not in header
    assert "odd * / names ? ?= here" in header  # the model name, made safe


def test_header_notes_chemostat():
    obs, design = _chemostat()
    program = generate(obs, "chemo", notes=design_notes(design))
    header, _ = render(program, "test")
    K = np.asarray(obs.K)
    for v in K[:, 0]:
        assert f"{v:.17g}" in header
    for text in ("spectral abscissa", "||H||inf", "gamma = 1", "certificate", "verified", "Theorem 1",
                 "status", "chemostat-analyser", "X_hat, S_hat, w_hat, xi_z"):
        assert text in header, text


def test_export_observer_writes_the_module(tmp_path):
    from nlobs.export import export_observer

    obs, design = _chemostat()
    res = export_observer(obs, tmp_path, prefix="chemostat", notes=design_notes(design))
    header = (tmp_path / "chemostat.h").read_text(encoding="utf-8")
    assert "#define CHEMOSTAT_NZ 4" in header and "#define CHEMOSTAT_NX 3" in header
    assert (tmp_path / "chemostat.c").is_file() and res is not None


def test_numeric_sigma1_is_refused():
    from nlobs.papers import grip_example1 as ex

    s1 = NonlinearSubsystem.numeric(
        n_x=2, p_z=1, f=lambda u, x: x @ ex.A1.T, h=lambda u, x: x[..., 1:],
        g=lambda u, x, z: (z - x[..., 1:]) @ ex.L_RAJAMANI.T,
        h_x=lambda u, x: np.broadcast_to(ex.C1, (*np.shape(x)[:-1], 1, 2)))
    obs = CascadeObserver(s1, ex.example1_sigma2(), _example1(False).K)
    with pytest.raises(InvalidArgumentError, match="NumPy callables"):
        generate_cascade(obs, "num")
    with pytest.raises(InvalidArgumentError, match="NumPy callables"):
        compile_observer(obs)


def test_design_notes_without_gain():
    class NoGain:
        certificate = None
        failure = "Assumption 4 fails"

    with pytest.raises(InvalidArgumentError, match="Assumption 4"):
        design_notes(NoGain())


# --------------------------------------------------------------------------- the C equals the Python observer
def test_rhs_equals_python(case):
    name, obs, cobs = case
    t, u, y, x_hat0 = _record(obs, name)
    rng = np.random.default_rng(3)
    z = obs.init(x_hat0) + 0.1 * rng.standard_normal((3, obs.n_z))
    uk = u[5] if u is not None else np.zeros(0)
    assert _rel(cobs.rhs(0.0, z, uk, y[:, 5]), obs.rhs(0.0, z, uk, y[:, 5])) <= RTOL
    np.testing.assert_array_equal(cobs.init(x_hat0), obs.init(x_hat0))


def test_c_init_and_estimate(case):
    name, obs, cobs = case
    lib, P = cobs.library, cobs.program.prefix
    import ctypes

    D = ctypes.POINTER(ctypes.c_double)
    xh0 = np.arange(1.0, obs.n_x + 1.0)
    z = np.full(obs.n_z, np.nan)
    assert lib[f"{P}_init"](xh0.ctypes.data_as(D), z.ctypes.data_as(D)) == 0
    np.testing.assert_array_equal(z, obs.init(xh0))
    out = np.empty(obs.n_x)
    lib[f"{P}_estimate"](z.ctypes.data_as(D), out.ctypes.data_as(D))
    np.testing.assert_array_equal(out, obs.estimate(z))


def test_whole_run_batch_equals_python(case):
    """Three noisy runs at once through run_observer: the compiled observer equals the Python one.

    Example 1's certified design has poles near −2600 (the step is ``h λ ≈ −0.65``); the error system
    contracts, so rounding differences of single steps do not grow along the run and the whole-run
    comparison is well conditioned. The teacher-forced test below also checks the steps one by one.
    """
    name, obs, cobs = case
    t, u, y, x_hat0 = _record(obs, name)
    ref = run_observer(obs, t, x_hat0=x_hat0, u=u, y=y)
    got = run_observer(cobs, t, x_hat0=x_hat0, u=u, y=y)
    assert got.x_hat.shape == ref.x_hat.shape == (3, t.size, obs.n_x)
    assert np.all(np.isfinite(ref.x_hat))
    assert _rel(got.x_hat, ref.x_hat) <= RTOL
    for r in range(3):
        assert _rel(got.x_hat[r], ref.x_hat[r]) <= RTOL
        rec = cobs.run_record(t, x_hat0[r], u=u, y=y[r])
        assert _rel(rec, ref.x_hat[r]) <= RTOL


def test_teacher_forced_steps(case):
    """One RK4 step in C from every state of the Python trajectory equals the Python step there."""
    name, obs, cobs = case
    t, u, y, x_hat0 = _record(obs, name, batch=1)
    K = min(t.size, 400)
    um = u if u is not None else np.zeros((t.size, 0))
    Z = np.empty((K, obs.n_z))
    Z[0] = obs.init(x_hat0[0])
    for k in range(K - 1):
        h = t[k + 1] - t[k]
        Z[k + 1] = rk4_step(lambda tt, zz, uk=um[k], yk=y[0, k]: obs.rhs(tt, zz, uk, yk), t[k], Z[k], h)
    # every step at once: the C advances the K - 1 states as a batch, each with its own u, y and h equal
    h = float(t[1] - t[0])
    assert np.allclose(np.diff(t[:K]), h, rtol=1e-12, atol=0.0)
    ref = np.stack([rk4_step(lambda tt, zz, uk=um[k], yk=y[0, k]: obs.rhs(tt, zz, uk, yk), t[k], Z[k], h) for k in range(K - 1)])
    got = cobs.step(0.0, Z[:-1], um[: K - 1], y[0, : K - 1], h)
    worst = max(_rel(got[k], ref[k]) for k in range(K - 1))
    assert worst <= RTOL
    assert math.isfinite(worst)
    if name == "saturated":  # both saturations clip along these steps (every branch: test_saturation_branches)
        assert np.any(np.abs(obs.z_hat(Z)) > 2.0) and np.any(np.abs(Z[:, 0]) > 1.5)


def test_saturation_branches():
    """Every branch of sat(z_hat) and sat*(x_hat_1): inside, the smooth transition and beyond it, on both sides."""
    obs = _saturated()
    cobs = compile_observer(obs)
    x1, zt = np.meshgrid(np.linspace(-2.0, 2.0, 41), np.linspace(-3.0, 3.0, 31), indexing="ij")
    z = np.zeros((*x1.shape, obs.n_z))
    z[..., 0], z[..., 1] = x1, 0.3
    z[..., -1] = zt - 0.3  # xi: z_hat = h + xi = x_hat_2 + xi
    y = np.full((*x1.shape, 1), 0.2)
    zero = np.zeros((*x1.shape, 0))
    assert _rel(cobs.rhs(0.0, z, zero, y), obs.rhs(0.0, z, zero, y)) <= RTOL
    assert np.any(np.abs(x1 - 1.25) < 0.2) and np.any(np.abs(obs.z_hat(z)) > 2.0)


def test_an_uncertified_cascade_header_does_not_say_certified_on_theorem_1(tmp_path) -> None:  # type: ignore[no-untyped-def]
    # before: "certified on: Grip, Saberi & Johansen, LMI (14) and Theorem 1" for a pole placement without
    # [cascade.lyapunov], whose status is "H∞ gain verified"
    from nlobs.workflows.export import export_model_observer

    rep = export_model_observer("chemostat-analyser", observer="cascade", out=tmp_path)
    header = rep.files[0].read_text(encoding="utf-8")
    assert not rep.certified and "NOT CERTIFIED" in header
    assert "certified on" not in header and "and Theorem 1" not in header
    assert "rests on" in header and "LMI (14) only" in header
