"""No text is ever run as code: every public entry that takes expressions parses strings or refuses them.

SymPy's constructors evaluate strings (``sympy.Matrix(["__import__('os')..."])``,
``sympy.diff("...", x)``, ``sympy.S("...")`` all end in ``eval``). The first
half of this file passes code-carrying strings through each public entry and
checks that a typed error comes back and the code did not run (a marker file
stays absent); the second half is a source rule over ``src/nlobs`` that flags
the calls which would let a string reach SymPy, and a test that the rule
catches such snippets.
"""

from __future__ import annotations

import ast
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import sympy as sp

from nlobs.errors import InvalidArgumentError, NlobsError
from nlobs.geometry.checks import check_full_rank, check_involutive
from nlobs.geometry.lie import (
    covector_lie_derivative,
    gradient,
    lie_bracket,
    lie_derivative,
    lie_derivative_along_columns,
    lie_derivatives,
    simplify_bounded,
    tidy,
)
from nlobs.geometry.observability import AffineFields
from nlobs.geometry.pinv import block_gain, pinv_gain_field, symbolic_pinv
from nlobs.geometry.region import Box, vanishes_on
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.expressions import ExpressionError, as_sympy_expr, as_sympy_matrix, as_symbols
from nlobs.systems.interconnected import NonlinearSubsystem
from nlobs.systems.symbolic import SymbolicModel

SRC = Path(__file__).resolve().parents[1] / "src" / "nlobs"
X1, X2 = sp.symbols("x1 x2", real=True)


def _payloads(marker: Path) -> list[str]:
    return [
        f"__import__('os').system('touch {marker}')",
        f"exec(\"open('{marker}', 'w').close()\")",
        f"eval(\"__import__('os').system('touch {marker}')\")",
        "lambda: 1",
        "x1.__class__",
        "x1.__class__.__mro__[1].__subclasses__()",
    ]


def _fields() -> AffineFields:
    model = SymbolicModel.input_affine(["x1", "x2", "x3"], ["u"], ["y1", "y2"], f=[X2, sp.Symbol("x3", real=True), 0],
                                       g=[[0], [0], [1]], h=[X1, X2])
    return AffineFields.from_model(model)


# entry point -> (call with the payload, the error it must raise)
ParsingEntry = Callable[[str], object]
ENTRIES: dict[str, tuple[ParsingEntry, type[NlobsError]]] = {
    "SymbolicModel.general rhs": (
        lambda p: SymbolicModel.general(["x1", "x2"], [], ["y"], rhs=["x2", p], h=["x1"]), ExpressionError),
    "SymbolicModel.general h": (
        lambda p: SymbolicModel.general(["x1", "x2"], [], ["y"], rhs=[X2, -X1], h=[p]), ExpressionError),
    "SymbolicModel.input_affine f": (
        lambda p: SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[p, "x1"], g=[[0], [1]], h=["x1"]),
        ExpressionError),
    "SymbolicModel.input_affine g": (
        lambda p: SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[X2, X1], g=[["0"], [p]], h=[X1]),
        ExpressionError),
    "NonlinearSubsystem.symbolic f": (
        lambda p: NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=[p, X1], h=[X1], g=[0, 0]),
        ExpressionError),
    "NonlinearSubsystem.symbolic g": (
        lambda p: NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=[X2, -X1], h=[X1], g=[p, 0]),
        ExpressionError),
    "lie_derivative phi": (lambda p: lie_derivative(p, [X2, -X1], [X1, X2]), InvalidArgumentError),
    "lie_derivative f": (lambda p: lie_derivative(X1, [p, -X1], [X1, X2]), InvalidArgumentError),
    "lie_derivative x": (lambda p: lie_derivative(X1, [X2, -X1], [p, X2]), InvalidArgumentError),
    "lie_derivatives phi": (lambda p: lie_derivatives(p, [X2, -X1], [X1, X2], 3), InvalidArgumentError),
    "lie_derivative_along_columns g": (
        lambda p: lie_derivative_along_columns(X1, [[p], [1]], [X1, X2]), InvalidArgumentError),
    "lie_bracket g": (lambda p: lie_bracket([X2, -X1], [p, 0], [X1, X2]), InvalidArgumentError),
    "covector_lie_derivative omega": (
        lambda p: covector_lie_derivative([[p, 0]], [X2, -X1], [X1, X2]), InvalidArgumentError),
    "gradient phi": (lambda p: gradient(p, [X1, X2]), InvalidArgumentError),
    "gradient x": (lambda p: gradient(X1 * X2, [X1, p]), InvalidArgumentError),
    "tidy": (lambda p: tidy(p), InvalidArgumentError),  # type: ignore[arg-type]
    "simplify_bounded": (lambda p: simplify_bounded(p), InvalidArgumentError),  # type: ignore[arg-type]
    "compile_matrix expr": (lambda p: compile_matrix([X1, p], ((X1, X2),)), InvalidArgumentError),
    "compile_matrix groups": (lambda p: compile_matrix([X1], ((X1, p),)), InvalidArgumentError),
    "symbolic_pinv": (lambda p: symbolic_pinv([[p, 1]]), InvalidArgumentError),  # type: ignore[arg-type]
    "pinv_gain_field Qp": (lambda p: pinv_gain_field([[p], [1]], [1]), InvalidArgumentError),  # type: ignore[arg-type]
    "block_gain k": (lambda p: block_gain([1], [p]), InvalidArgumentError),
    "vanishes_on": (lambda p: vanishes_on(p, [X1], Box.unit(1)), InvalidArgumentError),  # type: ignore[arg-type]
    "AffineFields f": (
        lambda p: AffineFields("m", (X1,), [p], sp.zeros(1, 0), [X1], ("x1",), ("y",)), InvalidArgumentError),
    "check_full_rank M": (
        lambda p: check_full_rank("rank", "M", [[p]], _fields(), Box.unit(3), samples=4), InvalidArgumentError),
    "check_involutive Qp": (
        lambda p: check_involutive(_fields(), (1, 1), Qp=[[p, 0], [0, 1], [0, 0]]), InvalidArgumentError),
}


@pytest.mark.parametrize("entry", sorted(ENTRIES))
def test_code_in_a_string_raises_a_typed_error_and_does_not_run(entry: str, tmp_path: Path) -> None:
    call, error = ENTRIES[entry]
    marker = tmp_path / "PWNED"
    for payload in _payloads(marker):
        with pytest.raises(error) as info:
            call(payload)
        assert isinstance(info.value, ValueError), type(info.value)
        assert not marker.exists(), f"{entry}: {payload!r} ran"


def test_strings_are_parsed_over_the_declared_names_and_sympy_objects_still_work() -> None:
    k = sp.Symbol("k", real=True)
    text = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=["x2", "-k*sin(x1)"], g=[["0"], ["1"]],
                                      h=["x1"], parameters={"k": 2.0})
    objs = SymbolicModel.input_affine(["x1", "x2"], ["u"], ["y"], f=[X2, -k * sp.sin(X1)], g=[[0], [1]], h=[X1],
                                      parameters={"k": 2.0})
    assert text.rhs == objs.rhs and text.h == objs.h and text.input_matrix == objs.input_matrix
    # symbols created without real=True still become the model's (real) symbols, as before
    plain = SymbolicModel.general(["x1"], [], ["y"], rhs=[-sp.Symbol("x1")], h=[sp.Symbol("x1")])
    assert plain.rhs[0] == -X1
    with pytest.raises(ExpressionError, match=r"rhs\[0\]: undeclared name: 'z'"):
        SymbolicModel.general(["x1"], [], ["y"], rhs=["z"], h=["x1"])
    sub = NonlinearSubsystem.symbolic(states=["x1", "x2"], outputs=["z"], f=["x2", "-x1"], h=["x1"], g=["0", "z"])
    assert sub.n_x == 2


def test_the_conversion_helpers_refuse_strings_without_declared_names() -> None:
    with pytest.raises(InvalidArgumentError, match="phi: expected a SymPy expression, got the string"):
        as_sympy_expr("phi", "x1")
    with pytest.raises(InvalidArgumentError, match=r"f\[1\]\[0\]"):
        as_sympy_matrix("f", [[X1], ["x1"]])
    with pytest.raises(InvalidArgumentError, match="or a number, got True"):
        as_sympy_matrix("f", [True])
    with pytest.raises(InvalidArgumentError, match="expected a sympy.Symbol"):
        as_symbols("x", [X1, "x2"])
    with pytest.raises(InvalidArgumentError, match="expected a sequence of sympy.Symbol"):
        as_symbols("x", "x1")
    assert as_sympy_matrix("f", [[1, 2.5], [X1, sp.pi]]).shape == (2, 2)
    assert as_sympy_expr("e", "x1**2", {"x1": X1}) == X1**2


# ------------------------------------------------------------------ the source rule
#: Calls that evaluate or sympify text, whatever their argument.
FORBIDDEN = {"eval", "exec", "sympify", "_sympify", "S", "parse_expr", "parse_latex", "compile", "__import__"}
#: Constructors that sympify their entries.
MATRICES = {"Matrix", "ImmutableMatrix", "MutableDenseMatrix", "ImmutableDenseMatrix", "SparseMatrix",
            "MutableSparseMatrix", "ImmutableSparseMatrix", "Array", "ImmutableDenseNDimArray"}
#: SymPy callables whose string argument is a name or a number, not an expression (no eval).
STRING_OK = {"Symbol", "symbols", "Dummy", "Wild", "Function", "Rational", "Float", "Integer"}
#: Methods of SymPy objects that sympify their arguments.
SYMPIFYING_METHODS = {"subs", "xreplace", "diff", "jacobian", "has", "coeff", "equals", "applyfunc"}
SYMPY_ALIASES = {"sp", "sympy"}


def _func_name(f: ast.expr) -> str:
    return f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""


def _root(f: ast.expr) -> str:
    while isinstance(f, (ast.Attribute, ast.Call, ast.Subscript)):
        f = f.func if isinstance(f, ast.Call) else f.value
    return f.id if isinstance(f, ast.Name) else ""


def _mentions_str(annotation: ast.expr | None) -> bool:
    return annotation is not None and any(isinstance(n, ast.Name) and n.id == "str" for n in ast.walk(annotation))


class _Scope:
    """Names a function (or the module) annotates as ``str`` or assigns a string to, and its parameters."""

    def __init__(self, node: ast.AST) -> None:
        self.strs: set[str] = set()
        self.params: set[str] = set()
        self.rebound: dict[str, int] = {}  # name -> first line assigning it
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            a = node.args
            for arg in (*a.posonlyargs, *a.args, *a.kwonlyargs, *(x for x in (a.vararg, a.kwarg) if x)):
                if _mentions_str(arg.annotation):
                    self.strs.add(arg.arg)
                self.params.add(arg.arg)
            self.params -= {"self", "cls"}
        for sub in ast.walk(node):
            if isinstance(sub, (ast.Assign, ast.AugAssign, ast.AnnAssign, ast.NamedExpr)):
                targets = sub.targets if isinstance(sub, ast.Assign) else [sub.target]
                for t in targets:
                    for n in ast.walk(t):
                        if isinstance(n, ast.Name):
                            self.rebound[n.id] = min(self.rebound.get(n.id, sub.lineno), sub.lineno)
        for sub in ast.walk(node):
            if isinstance(sub, ast.AnnAssign) and isinstance(sub.target, ast.Name) and _mentions_str(sub.annotation):
                self.strs.add(sub.target.id)
        changed = True
        while changed:  # assignments of strings, to a fixed point (``b = a`` after ``a = "..."``)
            changed = False
            for sub in ast.walk(node):
                if isinstance(sub, ast.Assign) and self.stringy(sub.value):
                    for t in sub.targets:
                        if isinstance(t, ast.Name) and t.id not in self.strs:
                            self.strs.add(t.id)
                            changed = True

    def raw_parameter(self, e: ast.expr, line: int) -> str | None:
        """The parameter ``e`` hands on unchecked (itself, in a list/tuple display or ``list()``), if any.

        A parameter counts as checked once the function rebinds it (``x = as_symbols("x", x)``) before ``line``.
        """
        if isinstance(e, ast.Name):
            ok = e.id not in self.params or self.rebound.get(e.id, line) < line
            return None if ok else e.id
        if isinstance(e, (ast.List, ast.Tuple)):
            return next((p for x in e.elts if (p := self.raw_parameter(x, line))), None)
        if isinstance(e, ast.Call) and _func_name(e.func) in {"list", "tuple"} and e.args:
            return self.raw_parameter(e.args[0], line)
        return None

    def stringy(self, e: ast.expr) -> bool:
        """Whether ``e`` is, or obviously may be, a string or a container of strings."""
        if isinstance(e, ast.Constant):
            return isinstance(e.value, str)
        if isinstance(e, ast.JoinedStr):
            return True
        if isinstance(e, ast.Name):
            return e.id in self.strs
        if isinstance(e, (ast.List, ast.Tuple, ast.Set)):
            return any(self.stringy(x) for x in e.elts)
        if isinstance(e, ast.Dict):
            return any(k is not None and self.stringy(k) for k in e.keys) or any(self.stringy(v) for v in e.values)
        if isinstance(e, (ast.ListComp, ast.GeneratorExp, ast.SetComp)):
            return self.stringy(e.elt)
        if isinstance(e, ast.Starred):
            return self.stringy(e.value)
        if isinstance(e, ast.Call):
            name = _func_name(e.func)
            if name in {"str", "repr", "format", "join", "read_text", "input", "strip", "lower", "upper"}:
                return True
            if name in {"list", "tuple"} and e.args:
                return self.stringy(e.args[0])
        if isinstance(e, ast.BinOp) and isinstance(e.op, (ast.Add, ast.Mod)):
            return self.stringy(e.left) or self.stringy(e.right)
        if isinstance(e, ast.IfExp):
            return self.stringy(e.body) or self.stringy(e.orelse)
        return False


def _scopes(tree: ast.Module) -> Iterator[tuple[_Scope, list[ast.Call]]]:
    """Each function (and the module body) with the calls directly in it (nested functions have their own scope)."""
    todo: list[ast.AST] = [tree]
    while todo:
        node = todo.pop()
        calls: list[ast.Call] = []
        stack = list(ast.iter_child_nodes(node))
        while stack:
            sub = stack.pop()
            if isinstance(sub, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                todo.append(sub)
                continue
            if isinstance(sub, ast.Call):
                calls.append(sub)
            stack.extend(ast.iter_child_nodes(sub))
        yield _Scope(node), calls


def find_text_evaluation(source: str, filename: str = "<module>") -> list[str]:
    """Every place in ``source`` where text may be evaluated or sympified, as ``file:line: reason``."""
    tree = ast.parse(source, filename=filename)
    out: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "sympy":
            for a in node.names:
                if a.name in FORBIDDEN:
                    out.append(f"{filename}:{node.lineno}: imports {a.name} from {node.module}")
    for scope, calls in _scopes(tree):
        for call in calls:
            name, root = _func_name(call.func), _root(call.func)
            args = [*call.args, *(k.value for k in call.keywords if k.arg is None)]
            where = f"{filename}:{call.lineno}"
            if name in FORBIDDEN and not (name == "compile" and root not in {"", "builtins"}):
                out.append(f"{where}: calls {name}()")
            elif name == "getattr" and len(call.args) >= 2 and isinstance(call.args[1], ast.Constant) \
                    and call.args[1].value in FORBIDDEN:
                out.append(f"{where}: getattr(..., {call.args[1].value!r})")
            elif (name in MATRICES or (root in SYMPY_ALIASES and name not in STRING_OK)) and \
                    (param := next((p for a in args if (p := scope.raw_parameter(a, call.lineno))), None)):
                out.append(f"{where}: {name}() of the parameter {param!r}, unchecked (a caller may pass a string; "
                           "convert it with as_sympy_matrix / as_sympy_expr / as_symbols first)")
            elif any(scope.stringy(a) for a in args):
                if name in MATRICES:
                    out.append(f"{where}: {name}() of a string or strings")
                elif root in SYMPY_ALIASES and name not in STRING_OK:
                    out.append(f"{where}: {root}.{name}() of a string (SymPy sympifies it)")
                elif isinstance(call.func, ast.Attribute) and name in SYMPIFYING_METHODS and root not in {"np", "re"}:
                    out.append(f"{where}: .{name}() of a string (SymPy sympifies it)")
    return out


MODULES = sorted(SRC.rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(SRC)))
def test_no_module_evaluates_or_sympifies_text(path: Path) -> None:
    found = find_text_evaluation(path.read_text(encoding="utf-8"), str(path.relative_to(SRC)))
    assert not found, "\n".join(found)


BAD_SNIPPETS = [
    "import sympy as sp\ndef f(t):\n    return sp.sympify(t)\n",
    "from sympy import sympify\n",
    "from sympy.parsing.sympy_parser import parse_expr\nparse_expr('x')\n",
    "import sympy as sp\nx = sp.S('x + 1')\n",
    "x = eval('1 + 1')\n",
    "exec('import os')\n",
    "import sympy as sp\nm = sp.Matrix('x')\n",
    "import sympy as sp\nm = sp.Matrix(['x1', 'x2'])\n",
    "import sympy as sp\nm = sp.ImmutableMatrix([['x1'], [f'{1}']])\n",
    "import sympy as sp\ndef col(name: str):\n    return sp.Matrix([name])\n",
    "import sympy as sp\ndef col(rows: list[str]):\n    return sp.Matrix(rows)\n",
    "import sympy as sp\ndef col():\n    t = 'x'\n    u = t\n    return sp.Matrix([u])\n",
    "import sympy as sp\ndef col(v):\n    return sp.Matrix([str(e) for e in v])\n",
    "import sympy as sp\nx = sp.Symbol('x')\nd = sp.diff('x**2', x)\n",
    "import sympy as sp\ne = sp.sin('x')\n",
    "import sympy as sp\ndef sub(e, name: str):\n    return e.subs(name, 1)\n",
    "import sympy as sp\ndef sub(e):\n    return e.subs({'x': 1})\n",
    "import sympy\nsympy.Matrix(['1'])\n",
    "from sympy import Matrix\nMatrix(['1'])\n",
    "import sympy as sp\nf = getattr(sp, 'sympify')\n",
    # the patterns removed from nlobs: a caller's argument handed straight to SymPy
    "import sympy as sp\ndef _column(name, v, n):\n    return sp.Matrix(v)\n",
    "import sympy as sp\ndef _sym_column(name, value, rows):\n    return sp.Matrix(list(value))\n",
    "import sympy as sp\ndef gradient(phi, x):\n    return sp.Matrix([[sp.diff(phi, xi) for xi in x]])\n",
    "import sympy as sp\ndef check(M, det):\n    return sp.Matrix([det]), sp.Matrix(M)\n",
    "import sympy as sp\ndef f(det):\n    return sp.factor_list(det)\n",
]


@pytest.mark.parametrize("snippet", BAD_SNIPPETS)
def test_the_rule_catches_a_forbidden_snippet(snippet: str, tmp_path: Path) -> None:
    bad = tmp_path / "bad_module.py"
    bad.write_text(snippet, encoding="utf-8")
    found = find_text_evaluation(bad.read_text(encoding="utf-8"), str(bad))
    assert found, f"not flagged:\n{snippet}"
    assert all(s.startswith(f"{bad}:") for s in found)


def test_the_rule_lets_sympy_objects_names_and_numbers_through(tmp_path: Path) -> None:
    good = tmp_path / "good_module.py"
    good.write_text(
        "import sympy as sp\nimport numpy as np\nfrom nlobs.systems.expressions import as_symbols\n"
        "def f(name: str, value, x):\n"
        "    s = sp.Symbol(name, real=True)\n"
        "    k = sp.Rational('981/100') + sp.Float('1.5')\n"
        "    m = sp.Matrix([s, k])\n"
        "    x = as_symbols('x', x)\n"
        "    j = m.jacobian(sp.Matrix(x))\n"
        "    a = np.array(value, dtype=float)\n"
        "    return j.subs({s: 1}), sp.lambdify([s], m, modules='numpy'), a, name.replace('x', 'y')\n",
        encoding="utf-8")
    assert find_text_evaluation(good.read_text(encoding="utf-8"), str(good)) == []
