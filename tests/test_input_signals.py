"""Known input signals u(t) (``nlobs.systems.signals``): closed forms, CSV files, the command-line and
table forms, and a simulation driven by them."""

from __future__ import annotations

import json
import math
import os
import pickle
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import nlobs.systems.signals as signals_module
from nlobs.errors import InvalidArgumentError, ModelFileError, NonFiniteError, SignalFileError, UnknownNameError
from nlobs.systems import (
    Chirp,
    Constant,
    Expression,
    InputSignals,
    LinearSystem,
    Piecewise,
    Signal,
    Sine,
    Step,
    parse_signal_spec,
    read_signal_csv,
    signal_from_table,
)
from nlobs.systems.expressions import ExpressionError

T = np.linspace(-3.0, 25.0, 2801)
finite = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False)
times = st.floats(min_value=-50.0, max_value=50.0, allow_nan=False)


# ------------------------------------------------------------------ closed forms
@settings(max_examples=60, deadline=None)
@given(amplitude=finite, frequency=st.floats(min_value=1e-3, max_value=50.0), phase=finite, offset=finite, t=times)
def test_sine_is_its_formula(amplitude: float, frequency: float, phase: float, offset: float, t: float) -> None:
    s = Sine(amplitude, frequency, phase, offset)
    want = amplitude * np.sin(2 * np.pi * frequency * t + phase) + offset
    assert isinstance(s(t), float)
    assert s(t) == pytest.approx(want, rel=1e-12, abs=1e-9)
    grid = s(T)
    assert grid.shape == T.shape
    np.testing.assert_allclose(grid, amplitude * np.sin(2 * np.pi * frequency * T + phase) + offset,
                               rtol=1e-12, atol=1e-9)


def test_sine_describes_itself_in_one_line() -> None:
    assert Sine(0.5, 0.2, offset=1.0).describe() == "sine 0.5 sin(2π·0.2 t + 0) + 1"
    assert Sine(0.5, 0.2, offset=1.0).to_dict() == {"kind": "sine", "amplitude": 0.5, "frequency": 0.2,
                                                    "phase": 0.0, "offset": 1.0}


def _chirp_formula(c: Chirp, t: np.ndarray) -> np.ndarray:
    """The chirp of the docstring written out piece by piece."""
    f0, f1, d = c.f0, c.f1, c.duration
    inside = 2 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2 * d))
    at_end = 2 * np.pi * (f0 * d + (f1 - f0) * d / 2)
    phase = np.where(t < 0, 2 * np.pi * f0 * t, np.where(t <= d, inside, at_end + 2 * np.pi * f1 * (t - d)))
    return c.amplitude * np.sin(phase) + c.offset


@settings(max_examples=60, deadline=None)
@given(amplitude=finite, f0=st.floats(min_value=0.0, max_value=5.0), f1=st.floats(min_value=0.0, max_value=5.0),
       duration=st.floats(min_value=0.1, max_value=20.0), offset=finite)
def test_chirp_is_its_formula(amplitude: float, f0: float, f1: float, duration: float, offset: float) -> None:
    c = Chirp(amplitude, f0, f1, duration, offset)
    want = _chirp_formula(c, T)
    np.testing.assert_allclose(c(T), want, rtol=1e-9, atol=1e-9 * (1 + abs(amplitude)))
    for t in (-1.0, 0.0, 0.3 * duration, duration, duration + 2.5):
        assert c(t) == pytest.approx(float(_chirp_formula(c, np.array(t))), rel=1e-9, abs=1e-9 * (1 + abs(amplitude)))


def test_chirp_instantaneous_frequency_by_finite_differences() -> None:
    c = Chirp(2.0, 0.5, 3.0, 8.0, offset=-1.0)
    h = 1e-5
    t = np.linspace(0.01, 7.99, 400)
    freq = (c.phase(t + h) - c.phase(t - h)) / (2 * h) / (2 * np.pi)
    np.testing.assert_allclose(freq, 0.5 + (3.0 - 0.5) * t / 8.0, rtol=0, atol=1e-6)
    np.testing.assert_allclose(c.frequency(t), 0.5 + (3.0 - 0.5) * t / 8.0, rtol=1e-14)
    # after the sweep: on at f1, and the phase (so the signal) is continuous at the end of the sweep
    t_after = np.linspace(8.01, 20.0, 50)
    freq_after = (c.phase(t_after + h) - c.phase(t_after - h)) / (2 * h) / (2 * np.pi)
    np.testing.assert_allclose(freq_after, 3.0, atol=1e-6)
    assert c.phase(8.0 + 1e-12) == pytest.approx(c.phase(8.0), abs=1e-9)
    assert c(8.0 + 1e-12) == pytest.approx(c(8.0), abs=1e-9)
    # before 0: on at f0
    assert c.phase(-2.0) == pytest.approx(2 * np.pi * 0.5 * -2.0)


def test_step_at_and_around_its_time() -> None:
    s = Step(-1.0, 2.5, 3.0)
    assert s(3.0) == 2.5 and s(np.nextafter(3.0, -np.inf)) == -1.0 and s(-100.0) == -1.0 and s(1e9) == 2.5
    np.testing.assert_array_equal(s(np.array([2.0, 2.999999, 3.0, 3.000001])), [-1.0, -1.0, 2.5, 2.5])
    assert s.piecewise_constant and s.describe() == "step -1 → 2.5 at t = 3"
    c = Constant(1.5)
    assert c(7.0) == 1.5 and c(np.zeros((2, 3))).shape == (2, 3) and c.piecewise_constant
    assert c.describe() == "constant 1.5"


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(min_value=-100, max_value=100), finite), min_size=1, max_size=30,
                unique_by=lambda p: p[0]))
def test_piecewise_against_numpy(samples: list[tuple[float, float]]) -> None:
    samples.sort()
    t = np.array([p[0] for p in samples])
    v = np.array([p[1] for p in samples])
    grid = np.concatenate([np.linspace(-120, 120, 301), t])
    lin = Piecewise(t, v, "linear")
    np.testing.assert_allclose(lin(grid), np.interp(grid, t, v), rtol=0, atol=0)
    hold = Piecewise(t, v, "hold")
    k = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, None)
    np.testing.assert_array_equal(hold(grid), v[k])
    for tq in grid[::37]:
        assert lin(float(tq)) == np.interp(tq, t, v)
        assert isinstance(hold(float(tq)), float)
    assert hold.piecewise_constant and not lin.piecewise_constant


def test_piecewise_hold_holds_the_ends() -> None:
    p = Piecewise([1.0, 2.0, 4.0], [10.0, 20.0, 40.0])
    assert p(0.0) == 10.0 and p(1.0) == 10.0 and p(1.999) == 10.0 and p(2.0) == 20.0 and p(100.0) == 40.0
    assert p == Piecewise(np.array([1.0, 2.0, 4.0]), [10, 20, 40]) and hash(p) == hash(Piecewise([1, 2, 4], [10, 20, 40]))
    assert p != Piecewise([1.0, 2.0, 4.0], [10.0, 20.0, 40.0], "linear")
    assert not p.times.flags.writeable and not p.values.flags.writeable
    assert p.describe() == "piecewise zero-order hold, 3 samples over t ∈ [1, 4], values in [10, 40]"


def test_expression_against_numpy() -> None:
    e = Expression("a*sin(w*t) + exp(-t**2) - pi", {"a": 0.5, "w": 2.0, "unused": 7.0})
    f = lambda t: 0.5 * np.sin(2.0 * t) + np.exp(-t**2) - np.pi  # noqa: E731
    np.testing.assert_allclose(e(T), f(T), rtol=1e-14, atol=1e-14)
    assert isinstance(e(0.7), float) and e(0.7) == pytest.approx(f(0.7), rel=1e-14)
    assert e(np.zeros((2, 3))).shape == (2, 3)
    assert dict(e.parameters) == {"a": 0.5, "w": 2.0}  # the unused parameter is dropped
    with pytest.raises(TypeError):
        e.parameters["a"] = 1.0  # type: ignore[index]
    assert e.describe() == "expression a*sin(w*t) + exp(-t**2) - pi with a = 0.5, w = 2"
    assert pickle.loads(pickle.dumps(e)) == e and pickle.loads(pickle.dumps(e))(0.7) == e(0.7)
    assert Expression("3")(np.arange(4.0)).tolist() == [3.0, 3.0, 3.0, 3.0]


def test_expression_is_compiled_once_never_sympified_per_call(monkeypatch: pytest.MonkeyPatch) -> None:
    import sympy

    e = Expression("sin(t)")

    def boom(*args: object, **kwargs: object) -> None:
        raise AssertionError("SymPy used at call time")

    monkeypatch.setattr(sympy, "lambdify", boom)
    monkeypatch.setattr(sympy, "sympify", boom)
    monkeypatch.setattr(sympy.Basic, "subs", boom)
    assert e(1.0) == pytest.approx(math.sin(1.0))


@pytest.mark.parametrize("text", ["__import__('os').system('true')", "t.real", "x + t", "lambda: 1", "t if t else 1",
                                  "open('f')", ""])
def test_expression_refuses_code(text: str) -> None:
    with pytest.raises(ExpressionError):
        Expression(text)


@pytest.mark.parametrize(("make", "error", "field"), [
    (lambda: Sine(1.0, 0.0), InvalidArgumentError, "Sine.frequency"),
    (lambda: Sine(1.0, -1.0), InvalidArgumentError, "Sine.frequency"),
    (lambda: Sine(math.nan, 1.0), NonFiniteError, "Sine.amplitude"),
    (lambda: Sine(1.0, 1.0, offset=math.inf), NonFiniteError, "Sine.offset"),
    (lambda: Sine("1", 1.0), InvalidArgumentError, "Sine.amplitude"),
    (lambda: Sine(True, 1.0), InvalidArgumentError, "Sine.amplitude"),
    (lambda: Sine(1 + 2j, 1.0), InvalidArgumentError, "Sine.amplitude"),
    (lambda: Chirp(1.0, 0.1, 1.0, 0.0), InvalidArgumentError, "Chirp.duration"),
    (lambda: Chirp(1.0, -0.1, 1.0, 1.0), InvalidArgumentError, "Chirp.f0"),
    (lambda: Chirp(1.0, 0.1, math.nan, 1.0), NonFiniteError, "Chirp.f1"),
    (lambda: Step(0.0, 1.0, math.inf), NonFiniteError, "Step.at"),
    (lambda: Constant(math.nan), NonFiniteError, "Constant.value"),
    (lambda: Piecewise([], []), InvalidArgumentError, "Piecewise.times"),
    (lambda: Piecewise([0.0, 0.0], [1.0, 2.0]), InvalidArgumentError, "Piecewise.times"),
    (lambda: Piecewise([1.0, 0.0], [1.0, 2.0]), InvalidArgumentError, "Piecewise.times"),
    (lambda: Piecewise([0.0, math.nan], [1.0, 2.0]), NonFiniteError, "Piecewise.times"),
    (lambda: Piecewise([0.0, 1.0], [1.0, math.inf]), NonFiniteError, "Piecewise.values"),
    (lambda: Piecewise([0.0, 1.0], [1.0]), InvalidArgumentError, "Piecewise.values"),
    (lambda: Piecewise([0.0, 1.0], [1.0, 2.0], "cubic"), InvalidArgumentError, "Piecewise.kind"),
    (lambda: Expression("k*t", {"k": math.nan}), NonFiniteError, "Expression.parameters"),
    (lambda: Expression("t", {"t": 1.0}), InvalidArgumentError, "Expression.parameters"),
    (lambda: Expression("t", {"a b": 1.0}), InvalidArgumentError, "Expression.parameters"),
    (lambda: InputSignals(("u", "u"), (Constant(1), Constant(2))), InvalidArgumentError, "duplicate"),
    (lambda: InputSignals(("u",), (Constant(1), Constant(2))), InvalidArgumentError, "1 names for 2 signals"),
    (lambda: InputSignals(("u",), (lambda t: 1.0,)), InvalidArgumentError, "not a Signal"),
    (lambda: InputSignals(("1u",), (Constant(1),)), InvalidArgumentError, "InputSignals.names"),
])
def test_invalid_signals_raise_typed_errors_naming_the_field(make, error, field) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(error, match=field.replace(".", r"\.").replace("[", r"\[")):
        make()


def test_signals_are_frozen_and_hashable() -> None:
    s = Sine(1.0, 2.0)
    with pytest.raises(AttributeError):
        s.amplitude = 2.0  # type: ignore[misc]
    assert len({Sine(1, 2), Sine(1.0, 2.0), Step(0, 1, 2), Expression("t"), Expression("t")}) == 3
    assert all(isinstance(x, Signal) for x in (s, Constant(0), Step(0, 1, 2), Chirp(1, 0, 1, 1), Expression("t")))


def test_to_dict_is_json_and_reads_back_to_an_equal_signal() -> None:
    for s in (Constant(1.5), Step(0.0, 1.0, 2.0), Sine(0.5, 0.2, 0.1, 1.0), Chirp(1.0, 0.1, 2.0, 10.0, 0.5),
              Piecewise([0.0, 1.0, 3.0], [1.0, -1.0, 2.0], "linear"), Expression("k*sin(t)", {"k": 2.0})):
        d = json.loads(json.dumps(s.to_dict(), allow_nan=False))
        assert d["kind"] == s.to_dict()["kind"]
        back = signal_from_table(d)
        assert back == s and type(back) is type(s)
        np.testing.assert_array_equal(back(T), s(T))


def test_input_signals_stack_the_channels() -> None:
    u = InputSignals(("tau", "F"), (Sine(1.0, 0.5), Step(0.0, 2.0, 1.0)))
    assert u.m == 2 and not u.piecewise_constant
    assert u(1.0).shape == (2,) and u(1.0)[1] == 2.0 and u(1.0)[0] == pytest.approx(math.sin(math.pi))
    grid = u(T)
    assert grid.shape == (*T.shape, 2)
    np.testing.assert_array_equal(grid[..., 1], Step(0.0, 2.0, 1.0)(T))
    assert u.describe() == "tau: sine 1 sin(2π·0.5 t + 0) + 0\nF: step 0 → 2 at t = 1"
    held = InputSignals(["a", "b"], [Constant(1), Piecewise([0, 1], [0, 1])])
    assert held.piecewise_constant and held.names == ("a", "b")
    assert json.dumps(u.to_dict())


# ------------------------------------------------------------------ a simulation
def _integrator_run(dt: float, u: InputSignals, duration: float) -> tuple[np.ndarray, np.ndarray]:
    from nlobs.simulate import simulate

    plant = LinearSystem(np.zeros((1, 1)), np.ones((1, 1)), np.ones((1, 1)))  # ẋ = u
    res = simulate(plant, None, np.zeros(1), duration=duration, dt=dt, u=u)
    return res.t, res.x[:, 0]


def test_simulation_of_an_integrator_matches_the_closed_form_integral() -> None:
    a, f, phi, c = 1.3, 0.5, 0.3, 0.2
    u = InputSignals(("u1",), (Sine(a, f, phi, c),))
    w = 2 * np.pi * f

    def exact(t: np.ndarray) -> np.ndarray:
        return c * t + a / w * (np.cos(phi) - np.cos(w * t + phi))

    t, x = _integrator_run(0.01, u, 10.0)
    err = np.max(np.abs(x - exact(t)))
    # RK4 on ẋ = u(t) is Simpson's rule on each step: the error is at most
    # duration · dt⁴ / 2880 · max|u''''| = 10 · 1e-8 / 2880 · 1.3 · π⁴ ≈ 4.4e-9
    assert err <= 10 * 0.01**4 / 2880 * a * w**4 * 1.01
    assert err < 1e-8
    # fourth order: halving the step divides the error by about 16
    t2, x2 = _integrator_run(0.02, u, 10.0)
    err2 = np.max(np.abs(x2 - exact(t2)))
    assert 10 < err2 / err < 22


def test_simulation_with_a_chirp_and_an_expression() -> None:
    u = InputSignals(("u1",), (Expression("cos(t)"),))
    t, x = _integrator_run(0.01, u, 5.0)
    np.testing.assert_allclose(x, np.sin(t), atol=1e-9)


# ------------------------------------------------------------------ CSV files
def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def test_csv_round_trip(tmp_path: Path) -> None:
    t = np.linspace(0.0, 2.0, 21)
    tau, force = np.sin(t), np.round(np.cos(3 * t), 3)
    lines = ["t,tau,F"] + [f"{float(a)!r},{float(b)!r},{float(c)!r}" for a, b, c in zip(t, tau, force)]
    path = _write(tmp_path / "u.csv", "\n".join(lines) + "\n")
    got = read_signal_csv(path)
    assert list(got) == ["tau", "F"]
    np.testing.assert_array_equal(got["tau"].times, t)
    np.testing.assert_array_equal(got["tau"].values, tau)
    np.testing.assert_array_equal(got["F"].values, force)
    assert got["tau"].kind == "hold" and got["tau"].piecewise_constant
    only = read_signal_csv(str(path), columns=["F"], kind="linear")
    assert list(only) == ["F"] and only["F"].kind == "linear"
    np.testing.assert_array_equal(only["F"](t[:-1] + 0.05), np.interp(t[:-1] + 0.05, t, force))
    assert "u.csv: F" in only["F"].describe()


def test_csv_with_a_time_header_spaces_bom_crlf_and_blank_lines(tmp_path: Path) -> None:
    path = tmp_path / "u.csv"
    path.write_bytes("\ufeffTime , u\r\n0, 1\r\n\r\n 1 ,2\r\n".encode())
    got = read_signal_csv(path)
    np.testing.assert_array_equal(got["u"].times, [0.0, 1.0])
    np.testing.assert_array_equal(got["u"].values, [1.0, 2.0])


def test_csv_unknown_column_lists_the_available_ones(tmp_path: Path) -> None:
    path = _write(tmp_path / "u.csv", "t,tau,F\n0,1,2\n")
    with pytest.raises(UnknownNameError, match=r"no column 'x'; the columns are: tau, F"):
        read_signal_csv(path, columns=["x"])


@pytest.mark.parametrize(("text", "line", "message"), [
    ("", None, "file is empty"),
    ("\n\n", None, "file is empty"),
    ("0,1\n1,2\n", 1, "no header row"),
    ("x,u\n0,1\n", 1, "the first column must be the time, named t or time, not 'x'"),
    ("t\n0\n", 1, "no signal columns"),
    ("t,u,u\n0,1,2\n", 1, "column 'u' appears twice"),
    ("t,u,\n0,1,2\n", 1, "column 3 has no name"),
    ("t,u\n", 1, "no data rows"),
    ("t,u\n0,1\n1,2,3\n", 3, "3 fields, but the header has 2"),
    ("t,u\n0,1\n1\n", 3, "1 fields, but the header has 2"),
    ("t,u\n0,1\n1,abc\n", 3, "column 'u': 'abc' is not a number"),
    ("t,u\n0,1\n1,\n", 3, "column 'u': an empty field is not a number"),
    ("t,u\n0,1\n1,1+1\n", 3, "column 'u': '1\\+1' is not a number"),
    ("t,u\n0,1\n1,2\n2,3\n3,4\n4,5\n5,6\n6,nan\n", 8, "column 'u': 'nan' is not a finite number"),
    ("t,u\n0,inf\n", 2, "column 'u': 'inf' is not a finite number"),
    ("t,u\n-Infinity,0\n", 2, "column 't': '-Infinity' is not a finite number"),
    ("t,u\n0.1,0\n0.2,0\n0.3,0\n0.3,1\n", 5, "time 0.3 is not after the previous time 0.3"),
    ("t,u\n0.1,0\n0.0,0\n", 3, "time 0 is not after the previous time 0.1"),
    ('t,u\n0,"1\n', 2, "not valid CSV"),
])
def test_csv_errors_name_the_file_and_the_line(tmp_path: Path, text: str, line: int | None, message: str) -> None:
    path = _write(tmp_path / "bad.csv", text)
    with pytest.raises(SignalFileError, match=message) as info:
        read_signal_csv(path)
    exc = info.value
    assert isinstance(exc, ModelFileError) and exc.path == str(path) and exc.line == line
    msg = str(exc)
    assert "\n" not in msg
    assert msg.startswith(f"{path}:{line}: " if line is not None else f"{path}: ")


def test_csv_file_errors(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(SignalFileError, match="cannot read file"):
        read_signal_csv(tmp_path / "missing.csv")
    with pytest.raises(SignalFileError, match=r"not a regular file \(a directory\)"):
        read_signal_csv(tmp_path)
    if hasattr(os, "mkfifo"):
        fifo = tmp_path / "pipe.csv"
        os.mkfifo(fifo)
        with pytest.raises(SignalFileError, match=r"not a regular file \(a FIFO\)"):
            read_signal_csv(fifo)  # never opened: would otherwise block
    if os.path.exists("/dev/zero"):
        with pytest.raises(SignalFileError, match=r"not a regular file \(a device\)"):
            read_signal_csv("/dev/zero")
    latin = tmp_path / "latin.csv"
    latin.write_bytes(b"t,u\n0,1\n1,\xe9\n")
    with pytest.raises(SignalFileError, match=r"not UTF-8 text \(byte 10\)"):
        read_signal_csv(latin)
    big = _write(tmp_path / "big.csv", "t,u\n" + "".join(f"{k},0\n" for k in range(100)))
    monkeypatch.setattr(signals_module, "MAX_CSV_BYTES", 64)
    with pytest.raises(SignalFileError, match="file larger than 64 bytes"):
        read_signal_csv(big)
    assert signals_module.MAX_CSV_BYTES == 64 and (16 << 20) == 16 * 1024 * 1024


def test_csv_text_in_messages_is_escaped(tmp_path: Path) -> None:
    path = _write(tmp_path / "u.csv", "t,u\n0,\x1b[31mred\n")
    with pytest.raises(SignalFileError) as info:
        read_signal_csv(path)
    assert "\x1b" not in str(info.value) and "\\x1b" in str(info.value)


# ------------------------------------------------------------------ the command-line form
@pytest.mark.parametrize(("spec", "want"), [
    ("1.5", Constant(1.5)),
    ("  -2 ", Constant(-2.0)),
    ("constant:1.5", Constant(1.5)),
    ("step:0,1,2", Step(0.0, 1.0, 2.0)),
    ("step: 0 , 1 , 2.5", Step(0.0, 1.0, 2.5)),
    ("sine:1,0.5", Sine(1.0, 0.5)),
    ("sine:1,0.5,0.1", Sine(1.0, 0.5, 0.1)),
    ("sine:1,0.5,pi/2,3", Sine(1.0, 0.5, math.pi / 2, 3.0)),
    ("SINE:1,0.5", Sine(1.0, 0.5)),
    ("chirp:1,0.1,2,10", Chirp(1.0, 0.1, 2.0, 10.0)),
    ("chirp:1,0.1,2,10,0.5", Chirp(1.0, 0.1, 2.0, 10.0, 0.5)),
    ("expr:0.5*sin(2*t)", Expression("0.5*sin(2*t)")),
    ("expression:atan2(t, 1)", Expression("atan2(t, 1)")),
])
def test_spec_forms(spec: str, want: Signal) -> None:
    got = parse_signal_spec(spec)
    assert got == want and type(got) is type(want)


def test_spec_numbers_and_expressions_use_the_parameters() -> None:
    assert parse_signal_spec("sine:A,w/2", parameters={"A": 2.0, "w": 3.0}) == Sine(2.0, 1.5)
    e = parse_signal_spec("expr:A*t", parameters={"A": 2.0})
    assert e(3.0) == 6.0


def test_spec_csv(tmp_path: Path) -> None:
    _write(tmp_path / "u.csv", "t,tau,F\n0,1,10\n1,2,20\n")
    _write(tmp_path / "one.csv", "time,u\n0,1\n1,3\n")
    got = parse_signal_spec("csv:u.csv:F", base_dir=tmp_path)
    assert got == Piecewise([0, 1], [10, 20], "hold")
    assert parse_signal_spec(f"csv:{tmp_path / 'u.csv'}:tau:linear") == Piecewise([0, 1], [1, 2], "linear")
    assert parse_signal_spec("csv:one.csv", base_dir=tmp_path) == Piecewise([0, 1], [1, 3])
    assert parse_signal_spec("csv:one.csv:linear", base_dir=str(tmp_path))(0.5) == 2.0
    with pytest.raises(InvalidArgumentError, match=r"has 2 signal columns \(tau, F\); name the one to use"):
        parse_signal_spec("csv:u.csv", base_dir=tmp_path)
    with pytest.raises(UnknownNameError, match="no column 'x'; the columns are: tau, F"):
        parse_signal_spec("csv:u.csv:x", base_dir=tmp_path)
    with pytest.raises(SignalFileError, match="cannot read file"):
        parse_signal_spec("csv:nope.csv", base_dir=tmp_path)


@pytest.mark.parametrize(("spec", "error", "message"), [
    ("", InvalidArgumentError, "empty; expected one of: NUMBER, constant:VALUE"),
    ("abc", InvalidArgumentError, "not a number or a known form; expected one of"),
    ("foo:1", InvalidArgumentError, "unknown kind 'foo'; expected one of"),
    ("sine:1", InvalidArgumentError, r"expected sine:AMPLITUDE,FREQUENCY\[,PHASE\[,OFFSET\]\]"),
    ("sine:1,2,3,4,5", InvalidArgumentError, "expected sine:AMPLITUDE,FREQUENCY"),
    ("sine:1,,2", InvalidArgumentError, "expected sine:AMPLITUDE,FREQUENCY"),
    ("sine:1,0", InvalidArgumentError, "'sine:1,0': Sine.frequency: must be positive"),
    ("sine:1,x", InvalidArgumentError, "FREQUENCY: 'x' is not a number or a constant expression"),
    ("sine:1,nan", NonFiniteError, "FREQUENCY: must be finite"),
    ("step:1,2", InvalidArgumentError, "expected step:BEFORE,AFTER,AT"),
    ("chirp:1,2,3", InvalidArgumentError, r"expected chirp:AMPLITUDE,F0,F1,DURATION\[,OFFSET\]"),
    ("constant:", InvalidArgumentError, "expected constant:VALUE"),
    ("csv:", InvalidArgumentError, r"expected csv:PATH\[:COLUMN\]\[:linear\]"),
    ("expr:", InvalidArgumentError, "empty expression"),
    ("expr:__import__('os')", InvalidArgumentError, "function is not in the whitelist"),
    ("expr:x*t", InvalidArgumentError, "undeclared name"),
    ("1\n2", InvalidArgumentError, "not a number"),
])
def test_bad_specs_say_the_expected_form(spec: str, error: type[Exception], message: str) -> None:
    with pytest.raises(error, match=message) as info:
        parse_signal_spec(spec)
    assert "\n" not in str(info.value)


# ------------------------------------------------------------------ tables
def test_tables(tmp_path: Path) -> None:
    _write(tmp_path / "u.csv", "t,tau\n0,1\n1,2\n")
    assert signal_from_table({"kind": "sine", "amplitude": 1, "frequency": 0.5}) == Sine(1.0, 0.5)
    assert signal_from_table({"kind": "step", "before": 0, "after": 1, "at": 2}) == Step(0, 1, 2)
    assert signal_from_table({"kind": "constant", "value": 1}) == Constant(1.0)
    assert signal_from_table({"kind": "chirp", "amplitude": 1, "f0": 0, "f1": 2, "duration": 4}) == Chirp(1, 0, 2, 4)
    assert signal_from_table({"kind": "expression", "expression": "sin(t)"}) == Expression("sin(t)")
    e = signal_from_table({"kind": "expression", "expression": "k*t"}, parameters={"k": 3.0})
    assert e(2.0) == 6.0
    got = signal_from_table({"kind": "csv", "file": "u.csv", "column": "tau", "interpolation": "linear"},
                            base_dir=tmp_path)
    assert got == Piecewise([0, 1], [1, 2], "linear")
    assert signal_from_table({"kind": "csv", "file": str(tmp_path / "u.csv")}) == Piecewise([0, 1], [1, 2])
    assert signal_from_table({"kind": "sine", "amplitude": "2*k", "frequency": 1, "phase": "pi"},
                             parameters={"k": 1.5}) == Sine(3.0, 1.0, math.pi)


def test_tables_from_toml() -> None:
    import tomllib

    data = tomllib.loads('u = {kind = "sine", amplitude = 1, frequency = 0.5}\n'
                         'v = {kind = "step", before = 0, after = 1, at = 2}\n')
    u = InputSignals(tuple(data), tuple(signal_from_table(v) for v in data.values()))
    assert u.describe() == "u: sine 1 sin(2π·0.5 t + 0) + 0\nv: step 0 → 1 at t = 2"


@pytest.mark.parametrize(("table", "message"), [
    ({"amplitude": 1}, "'kind' is missing; allowed kinds: constant, step, sine, chirp, csv, piecewise, expression"),
    ({"kind": "square"}, "'kind' is 'square'; allowed kinds"),
    ({"kind": "sine", "amplitude": 1, "freq": 2}, "unknown key 'freq'; allowed keys: kind, amplitude, frequency, "
                                                  "phase, offset"),
    ({"kind": "sine", "amplitude": 1}, "missing key 'frequency'; allowed keys: kind, amplitude, frequency"),
    ({"kind": "step", "before": 0, "after": 1}, "missing key 'at'"),
    ({"kind": "csv", "column": "u"}, "missing key 'file'; allowed keys: kind, file, column, interpolation"),
    ({"kind": "csv", "file": "u.csv", "interpolation": "cubic"}, "'interpolation' must be 'hold' or 'linear'"),
    ({"kind": "expression", "expression": 3}, "'expression' must be a string"),
    ({"kind": "expression", "expression": "y"}, "undeclared name"),
    ({"kind": "constant", "value": True}, "expected a number"),
    ({"kind": "constant", "value": [1]}, "expected a number"),
    ({"kind": "constant", "value": "acos(2)"}, "'acos\\(2\\)' is not a number .*non-real constant"),
    ({"kind": "sine", "amplitude": 1, "frequency": -1}, "Sine.frequency: must be positive"),
    ({"kind": "piecewise", "times": [0, 0], "values": [1, 2]}, "strictly increasing"),
    ({"kind": "piecewise", "times": "0,1", "values": [1, 2]}, "expected a list of numbers"),
])
def test_bad_tables_name_the_key(table: dict, message: str) -> None:  # type: ignore[type-arg]
    with pytest.raises(InvalidArgumentError, match=message):
        signal_from_table(table)


def test_huge_and_infinite_numbers_are_not_finite() -> None:
    for value in (10**400, 10**5000, "1e400", "-inf", 1e308 * 10):
        with pytest.raises(NonFiniteError, match="value: must be finite"):
            signal_from_table({"kind": "constant", "value": value})


def test_describe_is_one_line() -> None:
    for s in (Expression("sin(\n t)"), Sine(1, 2), Chirp(1, 0, 1, 2), Step(0, 1, 2), Constant(3),
              Piecewise([0, 1], [2, 3], "linear")):
        assert "\n" not in s.describe()
    assert Expression("sin(\n t)").describe() == "expression sin( t)"


def test_signal_text_is_never_evaluated(tmp_path: Path) -> None:
    marker = tmp_path / "marker"
    attacks = [f"expr:__import__('os').system('touch {marker}')", f"sine:1,__import__('os').system('touch {marker}')",
               f"constant:open('{marker}', 'w')"]
    for spec in attacks:
        with pytest.raises(InvalidArgumentError):
            parse_signal_spec(spec)
    path = _write(tmp_path / "u.csv", f"t,u\n0,__import__('os').system('touch {marker}')\n")
    with pytest.raises(SignalFileError):
        read_signal_csv(path)
    assert not marker.exists()
