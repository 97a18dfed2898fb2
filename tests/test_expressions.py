"""The whitelisted expression parser: accepted constructs and every rejection."""

from __future__ import annotations

import math

import pytest
import sympy as sp

from nlobs.errors import ModelError
from nlobs.systems.expressions import ExpressionError, parse_expression

SYMS = {n: sp.Symbol(n, real=True) for n in ("x1", "x2", "u", "k")}


def _num(text: str, **vals: float) -> float:
    expr = parse_expression(text, SYMS)
    return float(expr.subs({SYMS[k]: v for k, v in vals.items()}))


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("x1*x2 - x1**3", 0.5 * 2.0 - 0.5**3),
        ("-x1 + +x2 / 4", -0.5 + 0.5),
        ("sin(x1) + cos(x2) * exp(u)", math.sin(0.5) + math.cos(2.0) * math.exp(-1.0)),
        ("atan2(x1, x2) + sqrt(x2) + abs(u) + tanh(k)", math.atan2(0.5, 2.0) + math.sqrt(2.0) + 1.0 + math.tanh(3.0)),
        ("log(x2) + pi + 2e-3 + sign(u)", math.log(2.0) + math.pi + 2e-3 - 1.0),
        ("(k + 2*x1)**2", (3.0 + 1.0) ** 2),
    ],
)
def test_accepted_expressions_evaluate_like_python_math(text: str, expected: float) -> None:
    assert _num(text, x1=0.5, x2=2.0, u=-1.0, k=3.0) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("__import__('os').system('ls')", "only calls of whitelisted functions"),
        ("__import__('os')", "not in the whitelist"),
        ("x1.real", "Attribute is not allowed"),
        ("(lambda: 1)()", "only calls of whitelisted functions"),
        ("lambda: 1", "Lambda is not allowed"),
        ("z + 1", "undeclared name: 'z'"),
        ("x1 ^ 2", r"use \*\* for powers"),
        ("sin(x1, x2)", "sin takes 1 argument"),
        ("sin(x=x1)", "keyword arguments"),
        ("sin", "function used without a call"),
        ("[x1]", "List is not allowed"),
        ("x1 if x2 else 1", "IfExp is not allowed"),
        ("x1 < x2", "Compare is not allowed"),
        ("'abc'", "only real numbers"),
        ("True", "only real numbers"),
        ("1j", "only real numbers"),
        ("x1[0]", "Subscript is not allowed"),
        ("x1 +", "syntax error"),
        ("", "empty expression"),
        ("9**9**9**9", "exponent larger than"),
        ("1/0", "non-finite constant"),
        ("x1 % 2", "Mod is not allowed"),
    ],
)
def test_rejected_constructs_name_the_offending_text(text: str, match: str) -> None:
    with pytest.raises(ExpressionError, match=match):
        parse_expression(text, SYMS)


def test_expression_error_is_a_model_error_and_value_error() -> None:
    with pytest.raises(ModelError):
        parse_expression("os.getcwd()", SYMS)
    with pytest.raises(ValueError):
        parse_expression("os.getcwd()", SYMS)


def test_non_string_is_rejected() -> None:
    with pytest.raises(ExpressionError, match="must be a string"):
        parse_expression(3, SYMS)  # type: ignore[arg-type]


@pytest.fixture()
def deadline():
    """Fail, rather than hang, when a parse runs past 10 s (the old parser took minutes on nested powers)."""
    import signal

    def boom(signum, frame):  # type: ignore[no-untyped-def]
        raise TimeoutError("parse ran past 10 s")

    old = signal.signal(signal.SIGALRM, boom)
    signal.alarm(10)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


@pytest.mark.parametrize(("text", "match"), [
    ("(((3*x1)**999)**999)**999", r"power out of range \(about 10\^477"),  # SymPy writes (3x)**999 as 3**999 x**999
    ("(10*x1)**400", r"power out of range \(about 10\^400"),
    ("(2**299*x1)**999", "power out of range"),
    ("pi**999*x1", r"power out of range \(about 10\^497"),
    ("exp(1000)*x1", r"constant out of range \(about 10\^434"),
    ("exp(exp(10))", r"constant out of range \(about 10\^9566"),
    ("1e200*1e200*x1", "product of numbers out of range"),
])
def test_constants_are_bounded_before_sympy_makes_them(text: str, match: str, deadline: None) -> None:
    with pytest.raises(ExpressionError, match=match):
        parse_expression(text, SYMS)


@pytest.mark.parametrize("text", ["asin(2)*x1", "acos(-2)", "(-8)**(1/3)*x1", "(-2)**0.5", "sqrt(-1)", "log(-1)"])
def test_non_real_constants_are_refused(text: str) -> None:
    # before: accepted, and (-8)**(1/3)*x1 evaluated to 1.0 at x1 = 1 (the imaginary part dropped)
    with pytest.raises(ExpressionError, match="non-real constant"):
        parse_expression(text, SYMS)


@pytest.mark.parametrize(("text", "value"), [
    ("-(8**(1/3))*x1", -2.0), ("(-8)**3*x1", -512.0), ("exp(690)*x1", math.exp(690)), ("pi**200*pi**200*x1", math.pi**400),
    ("(x1 + x2)**3", 8.0), ("x1**999", 1.0),
])
def test_large_but_representable_constants_still_parse(text: str, value: float) -> None:
    got = float(parse_expression(text, SYMS).subs({SYMS["x1"]: 1.0, SYMS["x2"]: 1.0}))
    assert got == pytest.approx(value, rel=1e-12)
