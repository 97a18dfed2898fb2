"""Generated C of an observer step: equal to the Python step, strict C99, safe with any names.

The oracle is the Python observer itself on the same recorded, noisy measurements
(:func:`nlobs.simulate.run_observer`): the compiled observer must give the same estimates to 1e-12
(norm-wise relative) over the whole run, for a batch of runs, and in one C call over the record.
Where the observer is high-gain, rounding differences of the rhs (relative 1e-15 of a term of size
``K ỹ``) are amplified along the run; there the test compares teacher-forced single steps from the
Python trajectory instead, which is what "the C step equals the Python step" means.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import sympy as sp

from nlobs.errors import CompilerError, InvalidArgumentError, OutputError
from nlobs.export import compile_observer, export_observer, find_compiler, generate, render
from nlobs.export.compiler import compile_object
from nlobs.export.cprint import c_double, c_identifier, comment
from nlobs.geometry import Box
from nlobs.observers.drift import DriftObserver, SingularObservabilityError
from nlobs.observers.luenberger import ConstantGainObserver, LuenbergerObserver
from nlobs.observers.pinv import PinvObserver
from nlobs.simulate import run_observer, simulate
from nlobs.simulate.integrators import rk4_step
from nlobs.synthesis.drift_gain import vandermonde_gain
from nlobs.synthesis.pinv_gain import HighGain
from nlobs.systems.linear import LinearSystem
from nlobs.systems.modelfile import load_model
from nlobs.systems.symbolic import SymbolicModel
from nlobs.systems.timebase import Discrete

try:
    find_compiler()
except CompilerError:  # pragma: no cover - make test installs the codegen extra (a compiler)
    pytest.skip("no C compiler", allow_module_level=True)


def rel(a: np.ndarray, b: np.ndarray) -> float:
    """Norm-wise relative difference ``max|a − b| / max|b|``."""
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300))


def _record(plant, x0, K: int, dt: float, u, noise: float, seed: int = 0):
    """A noisy recorded run of ``plant`` (RK4 truth, Gaussian output noise at every instant)."""
    t = dt * np.arange(K)
    m = len(plant.inputs)
    U = np.broadcast_to(np.asarray(u, dtype=float).reshape(1, m) if m else np.zeros((1, 0)), (K, m)).copy()
    xs = [np.asarray(x0, dtype=float)]
    for k in range(K - 1):
        xs.append(rk4_step(lambda tt, xx, uk=U[k]: plant.rhs(tt, xx, uk), t[k], xs[-1], dt))
    X = np.array(xs)
    Y = plant.output(0.0, X, U) + noise * np.random.default_rng(seed).standard_normal((K, len(plant.outputs)))
    return t, U, Y, X


def _agree(obs, t, U, Y, xh0, tol: float = 1e-12):
    """The compiled observer equals the Python one on the record: whole run (batch) and the one-call C loop."""
    co = compile_observer(obs)
    B = xh0.shape[0]
    yb = np.broadcast_to(Y, (B, *Y.shape))
    ub = np.broadcast_to(U, (B, *U.shape))
    py = run_observer(obs, t, x_hat0=xh0, u=ub, y=yb)
    cc = run_observer(co, t, x_hat0=xh0, u=ub, y=yb)
    assert rel(cc.x_hat, py.x_hat) < tol
    one = co.run_record(t, xh0[0], u=U, y=Y)
    assert rel(one, py.x_hat[0]) < tol
    return co, py, cc


# ----------------------------------------------------------------------------- linear
def _linear(discrete: bool = False) -> LinearSystem:
    A = np.array([[0.0, 1.0, 0.0], [-2.0, -0.5, 1.0], [0.0, 0.0, -1.0]])
    B = np.array([[0.0], [1.0], [0.5]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    D = np.array([[0.0], [0.1]])
    if discrete:
        from scipy.linalg import expm

        return LinearSystem(expm(A * 0.1), B * 0.1, C, D, time=Discrete(0.1))
    return LinearSystem(A, B, C, D)


def test_luenberger_continuous_and_discrete_equal_python_along_noisy_runs() -> None:
    L = np.array([[3.0, 0.1], [4.0, 0.2], [0.0, 1.5]])
    for discrete in (False, True):
        sys = _linear(discrete)
        obs = LuenbergerObserver(sys, L * (0.1 if discrete else 1.0))
        K = 3000
        t = (0.1 if discrete else 0.01) * np.arange(K)
        rng = np.random.default_rng(1)
        U = np.sin(0.3 * t)[:, None]
        Y = rng.standard_normal((K, 2))
        xh0 = rng.standard_normal((3, 3))
        co, py, _ = _agree(obs, t, U, Y, xh0)
        assert np.all(np.isfinite(py.x_hat)) and np.max(np.abs(py.x_hat)) > 0.1


def test_constant_gain_pendulum_equals_python_and_simulate_with_sensors() -> None:
    model = load_model("pendulum")
    plant = model.compile()
    obs = ConstantGainObserver(plant, np.array([[4.0], [6.0]]))
    t, U, Y, X = _record(plant, [1.0, 0.0], 4000, 0.005, [0.3], 0.01)
    _agree(obs, t, U, Y, np.array([[0.0, 0.0], [0.5, -1.0], [2.0, 1.0]]))
    # in simulate with sampled (held) measurements the Python observer's RK4 and the C step coincide
    from nlobs.systems.sensors import MeasurementGroup

    sens = (MeasurementGroup("y", ("y",), rate=50.0, noise_std=0.01),)
    kw = dict(duration=5.0, dt=0.005, u=[0.3], measurements=sens, seed=3)
    x0 = [[1.0, 0.0], [1.0, 0.0]]
    a = simulate(plant, obs, x0, [[0.0, 0.0], [0.5, 0.5]], **kw)
    b = simulate(plant, compile_observer(obs), x0, [[0.0, 0.0], [0.5, 0.5]], **kw)
    assert rel(b.x_hat, a.x_hat) < 1e-12 and rel(b.x, a.x) == 0.0
    assert b.observer.endswith("[C]")


# ----------------------------------------------------------------------------- Röbenack (7)
def test_pinv_observer_equals_python_with_and_without_saturation() -> None:
    model = load_model("isidori-146")
    plant = model.compile()
    for sat in (None, Box.around(np.zeros(4), 1.5)):
        obs = PinvObserver.from_model(model, k=HighGain(3.0), saturation=sat)
        t, U, Y, X = _record(plant, [0.2, -0.1, 0.1, 0.0], 3000, 0.002, [0.1] * len(plant.inputs), 0.001)
        xh0 = np.array([[0.0, 0.0, 0.0, 0.0], [1.4, -1.2, 0.9, 0.5], [3.0, 0.0, -2.0, 1.0]])
        co, py, cc = _agree(obs, t, U, Y, xh0, tol=1e-12)
        if sat is not None:  # the saturated form really ran (an estimate left the box)
            assert np.any(np.abs(py.x_hat) > 1.5)
        _teacher_forced(obs, co, py, t, U, Y)


def _teacher_forced(obs, co, py, t, U, Y, tol: float = 1e-12) -> None:
    """One C step from each Python state of the run equals the Python step there (relative to the state)."""
    Z = py.x_hat[:, :-1, :].reshape(-1, obs.n_x)
    B = py.x_hat.shape[0]
    Ys = np.broadcast_to(Y[:-1], (B, *Y[:-1].shape)).reshape(Z.shape[0], -1)
    Us = np.broadcast_to(U[:-1], (B, *U[:-1].shape)).reshape(Z.shape[0], -1)
    h = float(t[1] - t[0])
    with np.errstate(all="ignore"):
        a = rk4_step(lambda tt, zz: obs.rhs(tt, zz, Us, Ys), 0.0, Z, h)
    b = co.step(0.0, Z, Us, Ys, h)
    scale = np.maximum(np.abs(a).max(axis=1), 1.0)
    assert float(np.max(np.abs(a - b).max(axis=1) / scale)) < tol


# ----------------------------------------------------------------------------- Dalla Mora, Germani & Manes (3.1)
@pytest.mark.slow
def test_drift_observer_equals_python_plain_saturated_and_regularised() -> None:
    model = load_model("duffing-actuator")
    plant = model.compile()
    K = vandermonde_gain((3, 1), 3.0).K
    box = Box.around(np.zeros(4), 1.0)
    t, U, Y, X = _record(plant, [0.3, 0.0, 0.1, 0.2], 3000, 0.002, [0.2, -0.1], 0.001)
    xh0 = np.array([[0.0, 0.0, 0.0, 0.0], [0.9, -0.8, 0.5, 0.1], [2.0, 1.0, -1.0, 0.5]])
    for kw in ({}, {"saturation": box}, {"regularization": 1e-3}):
        obs = DriftObserver.from_model(model, K, **kw)
        co, py, cc = _agree(obs, t, U, Y, xh0, tol=1e-12)
        _teacher_forced(obs, co, py, t, U, Y)
        if "saturation" in kw:
            assert np.any(np.abs(py.x_hat) > 1.0)


def test_drift_singular_Q_s_raises_the_python_error_or_nan() -> None:
    x1, x2 = sp.symbols("x1 x2", real=True)
    model = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2, -x1], g=[[0], [1]], h=[x1**2],
                                       name="square-sensor")
    K = vandermonde_gain((2,), 2.0).K
    co = compile_observer(DriftObserver.from_model(model, K))
    with pytest.raises(SingularObservabilityError, match=r"singular at t=1.5, x̂ = \(x1=0, x2=0.5\)"):
        co.step(1.5, np.array([[1.0, 0.5], [0.0, 0.5]]), np.array([0.0]), np.array([1.0]), 0.01)
    nan = compile_observer(dataclasses.replace(DriftObserver.from_model(model, K), on_singular="nan"))
    z = nan.step(1.5, np.array([[1.0, 0.5], [0.0, 0.5]]), np.array([0.0]), np.array([1.0]), 0.01)
    assert np.all(np.isfinite(z[0])) and np.all(np.isnan(z[1]))


# ----------------------------------------------------------------------------- C text
def test_every_generated_module_compiles_strictly() -> None:
    model = load_model("duffing-actuator")
    observers = [
        LuenbergerObserver(_linear(), np.ones((3, 2))),
        LuenbergerObserver(_linear(True), 0.1 * np.ones((3, 2))),
        ConstantGainObserver(load_model("pendulum").compile(), np.array([[4.0], [6.0]])),
        PinvObserver.from_model(load_model("isidori-146"), k=HighGain(3.0), saturation=Box.around(np.zeros(4), 1.5)),
        DriftObserver.from_model(model, vandermonde_gain((3, 1), 3.0).K, saturation=Box.around(np.zeros(4), 1.0)),
        DriftObserver.from_model(model, vandermonde_gain((3, 1), 3.0).K, regularization=1e-3),
    ]
    import shutil

    from nlobs.export import Compiler

    compilers = [find_compiler()] + [Compiler((p,), "PATH") for p in map(shutil.which, ("gcc", "clang")) if p]
    for obs in observers:
        prog = generate(obs, "m")
        header, source = render(prog, "test")
        for cc in compilers:  # the one nlobs uses, and GCC and Clang where installed (their warnings differ)
            compile_object(source, strict=True, headers={prog.header_name: header}, compiler=cc)


def test_names_that_are_c_keywords_or_odd_still_compile_and_run() -> None:
    names = ["int", "double", "θ_1"]
    s = {n: sp.Symbol(n, real=True) for n in names}
    model = SymbolicModel.general(names, ["return_"], ["y"],
                                  rhs=[s["double"], -sp.sin(s["int"]) + s["θ_1"], -s["θ_1"] + sp.Symbol("return_", real=True)],
                                  h=[s["int"] + sp.sign(s["θ_1"]) * 0], parameters={}, name="my model */ ??/ \x01")
    obs = ConstantGainObserver(model.compile(), np.array([[2.0], [1.0], [0.0]]))
    res = export_observer(obs, "/tmp/exp/kw", prefix="int")
    text = res.header.read_text() + res.source.read_text()
    assert res.checked_with is not None and "*/ ??" not in text.split("*/", 1)[1] and "\x01" not in text
    assert res.program.prefix == "nlobs_int" and c_identifier("3 model") == "nlobs_3_model"
    t, U, Y, X = _record(model.compile(), [0.1, 0.0, 0.2], 500, 0.01, [0.5], 0.01)
    _agree(obs, t, U, Y, np.zeros((2, 3)))


def test_cprint_helpers() -> None:
    for v in (0.1, -1e-300, 1.0, 2.0**-1074, 1.7976931348623157e308, -0.0):
        text = c_double(v)
        assert float(text.strip("()")) == v
    with pytest.raises(Exception, match="non-finite"):
        c_double(float("nan"))
    assert "*/" not in comment("a */ b /* c ??/ d") and "??" not in comment("??=??")


def test_export_writes_files_with_header_and_refuses_bad_input(tmp_path) -> None:
    obs = DriftObserver.from_model(load_model("duffing-actuator"), vandermonde_gain((3, 1), 3.0).K)
    res = export_observer(obs, tmp_path / "out", notes=(("certificate", "LMI (2.17) verified, margin 0.25"),))
    h = res.header.read_text()
    assert "Dalla Mora, Germani & Manes (3.1)" in h and "LMI (2.17) verified, margin 0.25" in h
    assert "Generated by nlobs" in h and "int nlobs_driftobserver_step(" in h
    assert res.to_dict()["n_x"] == 4 and res.to_dict()["n_y"] == 2
    with pytest.raises(InvalidArgumentError, match="no C export for"):
        export_observer(object(), tmp_path / "x")
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(OutputError):
        export_observer(obs, blocker)
    with pytest.raises(InvalidArgumentError, match="pinv='numeric'"):
        generate(PinvObserver.from_model(load_model("isidori-146"), k=HighGain(3.0), pinv="numeric"), "p")


def test_compiler_failure_is_a_typed_error(monkeypatch) -> None:
    monkeypatch.setenv("NLOBS_CC", "no-such-compiler-xyz")
    with pytest.raises(CompilerError, match="NLOBS_CC"):
        find_compiler()
    monkeypatch.delenv("NLOBS_CC")
    with pytest.raises(CompilerError, match="failed"):
        compile_object("int f(void) { return x; }\n", strict=True)


# ----------------------------------------------------------------------------- workflow, command line
def test_cli_export_writes_certified_module_and_refuses_bad_options(tmp_path) -> None:
    import json

    from typer.testing import CliRunner

    from nlobs.cli import app

    runner = CliRunner()
    r = runner.invoke(app, ["export", "duffing-actuator", "--observer", "drift", "--out", str(tmp_path / "d"), "--json"])
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert d["schema_version"] == 1 and d["certified"] is True and d["module"]["n_x"] == 4
    # the keys the README documents ("nlobs export --json keys")
    assert set(d) == {"schema_version", "model", "observer", "certified", "certificate", "files", "module", "verdict",
                      "message", "design"}
    assert d["design"]["method"] == "drift" and d["design"]["certified"] is True
    assert set(d["module"]) == {"prefix", "title", "header", "source", "n_z", "n_x", "n_u", "n_y", "discrete",
                                "correcting", "checked_with"}
    header = (tmp_path / "d" / "duffing_actuator_drift.h").read_text()
    assert "certificate" in header and "verified" in header and "(2.17) scaled" in header
    assert "Theorem 3.1 on [-1, 1]" in header
    # Röbenack's Corollary 4.1 rests on A2, A3, A4, A6, which nobody checks: written, not certified (exit 1)
    r = runner.invoke(app, ["export", "isidori-146", "--observer", "pinv", "--out", str(tmp_path / "p")])
    assert r.exit_code == 1 and "A2: not checked" in r.output and "not certified" in r.output
    for args, text in ((["--observer", "bogus"], "'bogus' is not one of 'drift'"),
                       (["--observer", "drift", "--lang", "fortran"], "'fortran' is not one of 'c'"),
                       (["--observer", "drift", "--saturation", "maybe"], "'maybe' is not one of 'on', 'off'")):
        r = runner.invoke(app, ["export", "duffing-actuator", *args, "--out", str(tmp_path / "x")])
        assert r.exit_code == 2 and text in r.output and "Traceback" not in r.output
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    r = runner.invoke(app, ["export", "duffing-actuator", "--observer", "drift", "--out", str(blocker)])
    assert r.exit_code == 2 and "cannot write" in r.output


@pytest.mark.slow
def test_compare_backend_c_gives_the_python_numbers() -> None:
    from nlobs.workflows.compare import compare_observers

    kw = dict(observers=["drift", "luenberger"], runs=3, duration=3.0, dt=1e-3, rate=100.0, noise_std=0.01)
    a = compare_observers("pendulum", **kw)
    b = compare_observers("pendulum", backend="c", **kw)
    for name in kw["observers"]:
        oa, ob = a.observers[name], b.observers[name]
        assert oa.skipped is None and ob.skipped is None
        assert np.allclose(ob.rms_error_all, oa.rms_error_all, rtol=1e-9, atol=0) and "generated C" in ob.description
        assert np.allclose(ob.result.x_hat, oa.result.x_hat, rtol=0, atol=1e-11 * np.abs(oa.result.x_hat).max())
    with pytest.raises(InvalidArgumentError, match="`backend`"):
        compare_observers("pendulum", backend="fortran", **kw)


@pytest.mark.slow
def test_cli_export_cascade_and_gnss_ins_carry_their_certificates(tmp_path) -> None:
    from typer.testing import CliRunner

    from nlobs.cli import app

    runner = CliRunner()
    # no [cascade.lyapunov] constants: Theorem 1 is not checked, so the gain is written but not certified (exit 1)
    r = runner.invoke(app, ["export", "chemostat-analyser", "--observer", "cascade", "--out", str(tmp_path / "c")])
    assert r.exit_code == 1 and "Theorem 1 (no [cascade.lyapunov] constants" in r.output, r.output
    header = (tmp_path / "c" / "chemostat_analyser_cascade.h").read_text()
    assert "‖H‖∞ < γ (13)" in header and "status: H∞ gain verified" in header
    r = runner.invoke(app, ["export", "gnss-ins", "--observer", "gnss-ins", "--out", str(tmp_path / "g")])
    assert r.exit_code == 0, r.output
    header = (tmp_path / "g" / "gnss_ins_gnss_ins.h").read_text()
    assert "LMI (14)" in header and "‖H‖∞ = 49.995 < γ = 50" in header and "h0 = 0.01 s" in header
    r = runner.invoke(app, ["export", "pendulum", "--observer", "gnss-ins", "--out", str(tmp_path / "x")])
    assert r.exit_code == 3 and "named gnss-ins" in r.output
    r = runner.invoke(app, ["export", "chemostat-analyser", "--observer", "cascade", "--box", "0,1",
                            "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "--box does not apply to the cascade observer" in r.output


def test_cli_export_setvalued(tmp_path) -> None:
    from typer.testing import CliRunner

    from nlobs.cli import app

    r = CliRunner().invoke(app, ["export", "khajenejad-6-1", "--observer", "setvalued", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    header = (tmp_path / "khajenejad_6_1_setvalued.h").read_text()
    assert "S-procedure condition" in header and "steady radius" in header


def test_run_observer_takes_the_whole_record_in_c_and_falls_back_to_the_step_loop() -> None:
    from nlobs.errors import SimulationDiverged

    model = load_model("duffing-actuator")
    obs = DriftObserver.from_model(model, vandermonde_gain((3, 1), 3.0).K)
    co = compile_observer(obs)
    t, U, Y, X = _record(model.compile(), [0.3, 0.0, 0.1, 0.2], 800, 0.002, [0.2, -0.1], 0.001)
    xh0 = np.array([[0.0, 0.0, 0.0, 0.0], [0.5, -0.5, 0.2, 0.1]])
    kw = dict(u=np.broadcast_to(U, (2, *U.shape)), y=np.broadcast_to(Y, (2, *Y.shape)))
    a, b = run_observer(obs, t, x_hat0=xh0, **kw), run_observer(co, t, x_hat0=xh0, save_every=7, **kw)
    assert b.method.endswith("whole record in one call") and b.t.size == a.t[::7].size + 1
    assert rel(b.x_hat, a.x_hat[:, np.r_[0:800:7, 799]]) < 1e-12
    # a measurement that makes one run non-finite: raised (with its time) or kept, the other run unchanged
    lin = LuenbergerObserver(_linear(), np.array([[3.0, 0.1], [4.0, 0.2], [0.0, 1.5]]))
    cl = compile_observer(lin)
    tl = 0.01 * np.arange(600)
    Yl = np.random.default_rng(4).standard_normal((2, 600, 2))
    Yl[1, 300:] = 1e308
    Ul = np.zeros((2, 600, 1))
    ref = run_observer(lin, tl, x_hat0=np.zeros((2, 3)), u=Ul, y=Yl, divergence="keep")
    with pytest.raises(SimulationDiverged):
        run_observer(cl, tl, x_hat0=np.zeros((2, 3)), u=Ul, y=Yl)
    kept = run_observer(cl, tl, x_hat0=np.zeros((2, 3)), u=Ul, y=Yl, divergence="keep")
    assert kept.method.endswith("whole record in one call")
    assert np.all(np.isfinite(kept.x_hat[0])) and not np.all(np.isfinite(kept.x_hat[1]))
    assert rel(kept.x_hat[0], ref.x_hat[0]) < 1e-12 and kept.info["diverged_at"] == ref.info["diverged_at"] > tl[299]
    # a singular Q_s: the C gives the record back (None), and the step loop raises the Python observer's error
    x1, x2 = sp.symbols("x1 x2", real=True)
    sq = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[x2, -x1], g=[[0], [1]], h=[x1**2], name="sq")
    cs = compile_observer(DriftObserver.from_model(sq, vandermonde_gain((2,), 2.0).K))
    tt = 0.01 * np.arange(30)
    sampled = np.ones((30, 1), dtype=bool)
    assert cs.run_records(tt, np.array([[0.0, 0.5]]), np.zeros((1, 30, 1)), np.ones((1, 30, 1)), sampled) is None
    ok = cs.run_records(tt, np.array([[1.0, 0.5]]), np.zeros((1, 30, 1)), np.ones((1, 30, 1)), sampled)
    assert ok is not None and ok.shape == (1, 30, 2) and np.all(np.isfinite(ok))


MAIN_C = r"""
#include <stdio.h>
#include <stdlib.h>
#include "PFX.h"

/* reads K, then K records (t, u[NU], y[NY]) as doubles from stdin; prints x_hat at every instant */
int main(void)
{
    long K, k;
    int j;
    double z[UP_NZ], xhat[UP_NX], xhat0[UP_NX] = {0};
    double *rec;
    if (fread(&K, sizeof K, 1, stdin) != 1) return 3;
    rec = malloc(sizeof(double) * (size_t)K * (1 + UP_NU + UP_NY));
    if (rec == NULL || fread(rec, sizeof(double), (size_t)K * (1 + UP_NU + UP_NY), stdin)
            != (size_t)K * (1 + UP_NU + UP_NY)) return 4;
    if (PFX_init(xhat0, z) != 0) return 5;
    for (k = 0; k < K; ++k) {
        double *r = rec + k * (1 + UP_NU + UP_NY);
        PFX_estimate(z, xhat);
        for (j = 0; j < UP_NX; ++j) printf("%.17g ", xhat[j]);
        printf("\n");
        if (k + 1 < K && PFX_step(r[0], z, r + 1, r + 1 + UP_NU, r[1 + UP_NU + UP_NY] - r[0]) != 0) return 6;
    }
    free(rec);
    return 0;
}
"""


def test_exported_files_build_a_standalone_program_that_matches_python(tmp_path) -> None:
    """The two written files and a plain main() (no nlobs, no Python) give the Python observer's estimates."""
    import subprocess

    model = load_model("pendulum")
    plant = model.compile()
    obs = ConstantGainObserver(plant, np.array([[4.0], [6.0]]))
    res = export_observer(obs, tmp_path, prefix="pend")
    P, up = res.program.prefix, res.program.prefix.upper()
    main = MAIN_C.replace("PFX", P).replace("UP_", f"{up}_")
    (tmp_path / "main.c").write_text(main)
    cc = find_compiler()
    exe = tmp_path / "observer"
    subprocess.run([*cc.command, "-std=c99", "-O2", "-ffp-contract=off", str(tmp_path / "main.c"),
                    str(res.source), "-I", str(tmp_path), "-lm", "-o", str(exe)], check=True, capture_output=True)
    t, U, Y, X = _record(plant, [1.0, 0.0], 2000, 0.005, [0.3], 0.01)
    data = np.int64(t.size).tobytes() + np.column_stack([t, U, Y]).astype(np.float64).tobytes()
    out = subprocess.run([str(exe)], input=data, capture_output=True, check=True).stdout.decode()
    got = np.array([[float(v) for v in line.split()] for line in out.splitlines()])
    ref = run_observer(obs, t, x_hat0=[0.0, 0.0], u=U, y=Y).x_hat
    assert got.shape == ref.shape and rel(got, ref) < 1e-12


def test_cli_export_luenberger_is_certified_for_a_linear_model_only(tmp_path) -> None:
    from typer.testing import CliRunner

    from nlobs.cli import app

    runner = CliRunner()
    r = runner.invoke(app, ["export", "gnss-ins-axis", "--observer", "luenberger", "--out", str(tmp_path / "a")])
    assert r.exit_code == 0, r.output
    header = (tmp_path / "a" / "gnss_ins_axis_luenberger.h").read_text()
    assert "LMI (14)" in header and "certificate  : verified" in header and "Use, one run" in header
    r = runner.invoke(app, ["export", "pendulum", "--observer", "luenberger", "--out", str(tmp_path / "p")])
    assert r.exit_code == 1 and "the plant is nonlinear" in r.output
    assert "NOT CERTIFIED" in (tmp_path / "p" / "pendulum_luenberger.h").read_text()
    # the method does not apply to a discrete model: no observer of this kind (exit 3, as nlobs design)
    r = runner.invoke(app, ["export", "double-integrator-discrete", "--observer", "luenberger", "--out", str(tmp_path)])
    assert r.exit_code == 3 and "continuous time" in r.output


def test_wrong_widths_are_refused_and_a_failed_discrete_step_does_not_keep_the_old_state() -> None:
    from nlobs.errors import DimensionError

    obs = LuenbergerObserver(_linear(), np.array([[3.0, 0.1], [4.0, 0.2], [0.0, 1.5]]))
    co = compile_observer(obs)
    z = co.init(np.zeros((2, 3)))
    with pytest.raises(DimensionError, match=r"y of shape \(2, 1\), expected \(\.\.\., 2\)"):
        co.step(0.0, z, np.zeros((2, 1)), np.zeros((2, 1)), 0.01)  # one column would broadcast onto two outputs
    with pytest.raises(DimensionError, match="u of shape"):
        co.run_record(0.01 * np.arange(5), np.zeros(3), y=np.zeros((5, 2)))
    t = 0.01 * np.arange(50)
    with pytest.raises(DimensionError):
        run_observer(co, t, x_hat0=np.zeros(3), u=np.zeros((50, 1)), y=np.zeros((50, 1)))
    # the C of a discrete step whose right-hand side reports a non-finite value: it takes z+, not the old state
    from nlobs.export.compiled import load_library

    prog = generate(LuenbergerObserver(_linear(True), 0.1 * np.ones((3, 2))), "dzbad")
    assert prog.body.count("    return 0;\n}") == 1
    body = prog.body.replace("    return 0;\n}", "    return 2;\n}")  # P_rhs_ reports non-finite
    broken = load_library(dataclasses.replace(prog, body=body))
    zz = np.ones(3)
    status = broken.dzbad_step(0.0, zz.ctypes.data, np.zeros(1).ctypes.data, np.zeros(2).ctypes.data, 0.1)
    assert status == 2 and not np.allclose(zz, 1.0)  # z+ as the right-hand side left it, not the old state


def test_fresh_broadcasts_like_python_and_a_damaged_cache_file_is_rebuilt(tmp_path, monkeypatch) -> None:
    from nlobs.errors import DimensionError
    from nlobs.export.compiled import _LOADED, load_library
    from nlobs.export.compiler import build_shared
    from nlobs.export.program import nlobs_version
    from nlobs.observers.setvalued import SetValuedObserver
    from nlobs.systems.modelfile import load_discrete_ui_model
    from nlobs.workflows.setvalued import design_setvalued_observer

    m = load_discrete_ui_model("khajenejad-6-1")
    obs = SetValuedObserver(m.system, design_setvalued_observer(m, samples=500).design)
    co = compile_observer(obs)
    z0 = np.broadcast_to(m.system.x0, (2, m.system.n))
    y = np.zeros((2, co.program.n_y))
    a = co.correct(0.0, co.init(z0), np.zeros((2, 0)), y, True)  # one flag for every output, as in Python
    b = co.correct(0.0, co.init(z0), np.zeros((2, 0)), y, np.ones(co.program.n_y, dtype=bool))
    assert np.array_equal(a, b)
    with pytest.raises(DimensionError, match="fresh"):
        co.correct(0.0, co.init(z0), np.zeros((2, 0)), y, np.ones(co.program.n_y + 1, dtype=bool))
    # a damaged library in the cache is built again, not loaded (or reported as a bare OSError)
    monkeypatch.setenv("NLOBS_CACHE", str(tmp_path))
    prog = generate(LuenbergerObserver(_linear(), np.ones((3, 2))), "dmg")
    header, source = render(prog, nlobs_version())
    path = build_shared(source, headers={prog.header_name: header})
    path.write_bytes(b"not a library")
    _LOADED.pop(str(path), None)
    lib = load_library(prog)
    assert lib.dmg_estimate is not None and path.stat().st_size > 100
    monkeypatch.setenv("NLOBS_CC", "'unclosed")
    with pytest.raises(CompilerError, match="NLOBS_CC"):
        find_compiler()
