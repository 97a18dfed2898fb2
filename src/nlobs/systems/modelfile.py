"""Model files: the TOML format users write by hand and the CLI reads.

A nonlinear model::

    name = "isidori-146"
    time = "continuous"                 # or "discrete", with dt = 0.01
    states = ["x1", "x2", "x3", "x4"]
    inputs = ["u"]
    outputs = ["y"]
    parameters = { k = 2.0 }            # optional named constants
    [dynamics]
    f = ["x1*x2 - x1**3", "x1", "-x3", "x1**2 + x2"]
    g = [["0"], ["k + 2*x3"], ["1"], ["0"]]   # n x m, optional: input-affine form
    # rhs = ["...", ...]                # alternative: general F(x, u)
    h = ["x4"]

A linear model replaces ``[dynamics]`` by ``[linear]`` with numeric ``A``,
``B``, ``C`` and optional ``D`` (names are then optional).

Expressions are parsed by :mod:`nlobs.systems.expressions` (a whitelisted AST),
never evaluated. Every error is a :class:`~nlobs.errors.ModelFileError` that
names the file, the line and the offending text.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from nlobs.errors import ModelError, ModelFileError, NlobsError
from nlobs.systems.expressions import ExpressionError, parse_expression
from nlobs.systems.linear import LinearSystem
from nlobs.systems.symbolic import SymbolicModel
from nlobs.systems.timebase import CONTINUOUS, Discrete, TimeBase

Model = SymbolicModel | LinearSystem

_TOP_KEYS = {"name", "description", "time", "dt", "states", "inputs", "outputs", "parameters", "dynamics", "linear"}
_DYN_KEYS = {"f", "g", "rhs", "h"}
_LIN_KEYS = {"A", "B", "C", "D"}
_MAX_BYTES = 5_000_000


class _Source:
    """The raw text of a model file, to map keys and strings back to line numbers."""

    def __init__(self, path: str, text: str) -> None:
        self.path = path
        self.lines = text.splitlines()

    def line_of_string(self, s: str) -> int | None:
        for quoted in (f'"{s}"', f"'{s}'", s):
            for i, line in enumerate(self.lines, start=1):
                if quoted in line:
                    return i
        return None

    def line_of_key(self, key: str) -> int | None:
        pat = re.compile(rf"^\s*(\[\s*{re.escape(key)}\s*\]|{re.escape(key)}\s*=)")
        for i, line in enumerate(self.lines, start=1):
            if pat.search(line):
                return i
        return None

    def error(self, reason: str, *, key: str | None = None, text: str = "", string: str | None = None) -> ModelFileError:
        line = None
        if string is not None:
            line = self.line_of_string(string)
        if line is None and key is not None:
            line = self.line_of_key(key)
        return ModelFileError(self.path, line, text, reason)


def load_model(path: str | Path) -> Model:
    """Read a model file.

    Parameters
    ----------
    path : str or Path
        A ``.toml`` file in the format described in the module docstring.

    Returns
    -------
    SymbolicModel or LinearSystem

    Raises
    ------
    ModelFileError
        If the file cannot be read, is not valid TOML, or any key, name,
        expression or matrix is invalid; the message names the file, the line
        and the offending text.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise ModelFileError(str(p), None, "", f"cannot read file ({exc.strerror})") from None
    if len(raw) > _MAX_BYTES:
        raise ModelFileError(str(p), None, "", f"file larger than {_MAX_BYTES} bytes")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ModelFileError(str(p), None, "", "file is not UTF-8 text") from None
    return parse_model(text, source=str(p))


def parse_model(text: str, *, source: str = "<string>") -> Model:
    """Parse model-file text (see :func:`load_model`); ``source`` is used in messages."""
    src = _Source(source, text)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"at line (\d+)", msg)
        line = int(m.group(1)) if m else None
        offending = src.lines[line - 1].strip() if line and line <= len(src.lines) else ""
        reason = re.sub(r" \(at .*\)$", "", msg)
        raise ModelFileError(source, line, offending, f"invalid TOML ({reason})") from None
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise src.error(f"unknown key (allowed: {', '.join(sorted(_TOP_KEYS))})", key=unknown[0], text=unknown[0])
    name = _string(src, data, "name", default=Path(source).stem)
    time = _time(src, data)
    has_dyn, has_lin = "dynamics" in data, "linear" in data
    if has_dyn == has_lin:
        raise src.error("a model needs exactly one of the tables [dynamics] or [linear]", key="dynamics" if has_dyn else None)
    try:
        if has_lin:
            return _linear(src, data, name, time)
        return _nonlinear(src, data, name, time)
    except ModelFileError:
        raise
    except NlobsError as exc:  # a validation error from the model constructors
        raise src.error(str(exc)) from None


# ---------------------------------------------------------------------- pieces
def _string(src: _Source, data: Mapping[str, Any], key: str, *, default: str) -> str:
    v = data.get(key, default)
    if not isinstance(v, str):
        raise src.error(f"'{key}' must be a string", key=key, text=repr(v))
    return v


def _names(src: _Source, data: Mapping[str, Any], key: str, *, required: bool) -> list[str] | None:
    if key not in data:
        if required:
            raise src.error(f"missing key '{key}' (a list of names)", text=key)
        return None
    v = data[key]
    if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
        raise src.error(f"'{key}' must be a list of strings", key=key, text=repr(v))
    for s in v:
        if not s.isidentifier():
            raise src.error(f"'{key}': {s!r} is not a valid name", key=key, string=s, text=s)
    dup = sorted({s for s in v if v.count(s) > 1})
    if dup:
        raise src.error(f"'{key}': duplicate names", key=key, text=", ".join(dup))
    return v


def _time(src: _Source, data: Mapping[str, Any]) -> TimeBase:
    kind = data.get("time", "continuous")
    if kind not in ("continuous", "discrete"):
        raise src.error("'time' must be \"continuous\" or \"discrete\"", key="time", text=repr(kind))
    dt = data.get("dt")
    if kind == "continuous":
        if dt is not None:
            raise src.error("'dt' is only allowed with time = \"discrete\"", key="dt", text=repr(dt))
        return CONTINUOUS
    if dt is None:
        raise src.error("a discrete-time model needs 'dt' (the sampling period in seconds)", key="time", text="dt")
    if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not np.isfinite(dt) or dt <= 0:
        raise src.error("'dt' must be a positive finite number", key="dt", text=repr(dt))
    return Discrete(float(dt))


def _parameters(src: _Source, data: Mapping[str, Any]) -> dict[str, float]:
    params = data.get("parameters", {})
    if not isinstance(params, dict):
        raise src.error("'parameters' must be a table of numbers", key="parameters", text=repr(params))
    out: dict[str, float] = {}
    for k, v in params.items():
        if not k.isidentifier():
            raise src.error("parameter name is not a valid name", key="parameters", text=k)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
            raise src.error(f"parameter '{k}' must be a finite number", key="parameters", string=k, text=repr(v))
        out[k] = float(v)
    return out


def _expr_list(src: _Source, table: Mapping[str, Any], key: str, symbols: Mapping[str, sp.Symbol]) -> list[sp.Expr]:
    v = table[key]
    if not isinstance(v, list):
        raise src.error(f"[dynamics].{key} must be a list of expression strings", key=key, text=repr(v))
    return [_expr(src, key, e, symbols) for e in v]


def _expr(src: _Source, key: str, e: Any, symbols: Mapping[str, sp.Symbol]) -> sp.Expr:
    if isinstance(e, bool) or not isinstance(e, (str, int, float)):
        raise src.error(f"[dynamics].{key}: entries must be expression strings", key=key, text=repr(e))
    text = str(e)
    try:
        return parse_expression(text, symbols)
    except ExpressionError as exc:
        raise src.error(f"[dynamics].{key}: {exc.reason}", key=key, string=text if isinstance(e, str) else None,
                        text=exc.offending) from None


def _nonlinear(src: _Source, data: Mapping[str, Any], name: str, time: TimeBase) -> SymbolicModel:
    states = _names(src, data, "states", required=True) or []
    inputs = _names(src, data, "inputs", required=False) or []
    outputs = _names(src, data, "outputs", required=True) or []
    params = _parameters(src, data)
    clash = sorted((set(states) & set(inputs)) | ((set(states) | set(inputs)) & set(params)))
    if clash:
        raise src.error("name declared twice (states, inputs, parameters)", string=clash[0], text=clash[0])
    dyn = data["dynamics"]
    if not isinstance(dyn, dict):
        raise src.error("[dynamics] must be a table", key="dynamics")
    unknown = sorted(set(dyn) - _DYN_KEYS)
    if unknown:
        raise src.error(f"unknown key in [dynamics] (allowed: {', '.join(sorted(_DYN_KEYS))})", key=unknown[0], text=unknown[0])
    if ("f" in dyn) == ("rhs" in dyn):
        raise src.error("[dynamics] needs exactly one of 'f' (input-affine, with optional 'g') or 'rhs' (general)", key="dynamics")
    if "h" not in dyn:
        raise src.error("[dynamics] needs 'h' (the output map)", key="dynamics", text="h")
    sx = {s: sp.Symbol(s, real=True) for s in states}
    su = {s: sp.Symbol(s, real=True) for s in inputs}
    sp_ = {s: sp.Symbol(s, real=True) for s in params}
    all_syms = {**sx, **su, **sp_}
    no_inputs = {**sx, **sp_}
    h = _expr_list(src, dyn, "h", all_syms)
    _check_len(src, "h", h, len(outputs), "outputs")
    if "rhs" in dyn:
        rhs = _expr_list(src, dyn, "rhs", all_syms)
        _check_len(src, "rhs", rhs, len(states), "states")
        return SymbolicModel.general(states, inputs, outputs, rhs, h, parameters=params, time=time, name=name)
    f = _expr_list(src, dyn, "f", no_inputs)
    _check_len(src, "f", f, len(states), "states")
    g = None
    if "g" in dyn:
        rows = dyn["g"]
        if not isinstance(rows, list) or len(rows) != len(states) or not all(isinstance(r, list) for r in rows):
            raise src.error(f"[dynamics].g must be a list of {len(states)} rows (one per state) of {len(inputs)} expressions",
                            key="g", text=repr(rows)[:80])
        g = []
        for r in rows:
            if len(r) != len(inputs):
                raise src.error(f"[dynamics].g: each row needs {len(inputs)} entries (one per input)", key="g", text=repr(r))
            g.append([_expr(src, "g", e, no_inputs) for e in r])
    elif inputs:
        raise src.error("an input-affine model with inputs needs 'g' (or use 'rhs')", key="dynamics", text="g")
    return SymbolicModel.input_affine(states, inputs, outputs, f, g, h, parameters=params, time=time, name=name)


def _check_len(src: _Source, key: str, v: Sequence[Any], want: int, what: str) -> None:
    if len(v) != want:
        raise src.error(f"[dynamics].{key} has {len(v)} entries but there are {want} {what}", key=key, text=key)


def _matrix(src: _Source, lin: Mapping[str, Any], key: str) -> np.ndarray:
    v = lin[key]
    ok = isinstance(v, list) and all(isinstance(r, list) for r in v)
    if ok:
        ok = all(not isinstance(e, bool) and isinstance(e, (int, float)) for r in v for e in r)
    if not ok:
        raise src.error(f"[linear].{key} must be a list of rows of numbers", key=key, text=repr(v)[:80])
    widths = {len(r) for r in v}
    if len(widths) > 1:
        raise src.error(f"[linear].{key}: rows have different lengths {sorted(widths)}", key=key, text=key)
    arr = np.array(v, dtype=float).reshape(len(v), widths.pop() if widths else 0)
    if not np.all(np.isfinite(arr)):
        raise src.error(f"[linear].{key} has non-finite entries", key=key, text=key)
    return arr


def _linear(src: _Source, data: Mapping[str, Any], name: str, time: TimeBase) -> LinearSystem:
    lin = data["linear"]
    if not isinstance(lin, dict):
        raise src.error("[linear] must be a table", key="linear")
    unknown = sorted(set(lin) - _LIN_KEYS)
    if unknown:
        raise src.error("unknown key in [linear] (allowed: A, B, C, D)", key=unknown[0], text=unknown[0])
    for k in ("A", "C"):
        if k not in lin:
            raise src.error(f"[linear] needs '{k}'", key="linear", text=k)
    if "parameters" in data:
        raise src.error("'parameters' is not used by a [linear] model", key="parameters", text="parameters")
    A = _matrix(src, lin, "A")
    n = A.shape[0]
    C = _matrix(src, lin, "C")
    inputs = _names(src, data, "inputs", required=False)
    m = len(inputs) if inputs is not None else (_matrix(src, lin, "B").shape[1] if "B" in lin else 0)
    B = _matrix(src, lin, "B") if "B" in lin else np.zeros((n, m))
    D = _matrix(src, lin, "D") if "D" in lin else None
    if B.size == 0:
        B = B.reshape(n, m)
    if D is not None and D.size == 0:
        D = D.reshape(C.shape[0], m)
    for key, mat, want in (("A", A, (n, n)), ("B", B, (n, m)), ("C", C, (C.shape[0], n))):
        if mat.shape != want:
            raise src.error(f"[linear].{key} has shape {mat.shape}, expected {want}", key=key, text=key)
    if D is not None and D.shape != (C.shape[0], m):
        raise src.error(f"[linear].D has shape {D.shape}, expected {(C.shape[0], m)}", key="D", text="D")
    try:
        return LinearSystem(A, B, C, D, time=time, states=_names(src, data, "states", required=False),
                            inputs=inputs, outputs=_names(src, data, "outputs", required=False), name=name)
    except (ModelError, ValueError) as exc:
        raise src.error(str(exc), key="linear") from None
