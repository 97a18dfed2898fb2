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

An interconnection of a nonlinear Σ1 with unmeasured output ``z`` and a linear Σ2 (Grip, Saberi &
Johansen, (1) or (2)) replaces ``[dynamics]`` by a ``[cascade]`` table (:mod:`nlobs.systems.cascade_file`);
the model is then the plant ``[x, w]``.

A linear model replaces ``[dynamics]`` by ``[linear]`` with numeric ``A``,
``B``, ``C`` and optional ``D`` (names are then optional).

A discrete-time model with **unknown inputs** (Khajenejad & Yong, (8)) adds the tables
``[unknown_inputs]``, ``[noise]``, ``[initial]`` and ``[function_class]``; they
are read by :func:`load_discrete_ui`, which returns a
:class:`~nlobs.systems.discrete_ui.DiscreteUISystem` (``load_model`` reads the
nominal model of the same file, ``d = w = v = 0``)::

    time = "discrete"
    dt = 1.0
    states = ["x1", "x2"]
    outputs = ["y"]
    [dynamics]
    f = ["-0.42*x1 + x2", "-0.6*x1 - 1.25*tanh(x1)"]
    h = ["x2"]                          # linear in x (and u): C, D read off exactly
    [unknown_inputs]
    G = [[1.0], [-0.65]]                # n x p
    H = [[0.0]]                         # l x p (zero when omitted)
    bounded = ["0.2*sin(t)"]            # optional signals d(t) for simulations
    growing = ["0.1*t"]
    [noise]
    W = [[1, 0], [0, 1]]                # n x n_w (identity when omitted)
    eta_w = 0.2                         # ||w_k|| <= eta_w
    eta_v = 0.1                         # ||v_k|| <= eta_v
    [initial]
    centre = [0.0, 0.0]                 # zeros when omitted
    radius = 0.5                        # ||x_0 - centre|| <= radius
    [function_class]                    # the class of phi(x) = f(x) - linear_part x
    kind = "I"                          # "0" | "I" | "II" | "III"
    linear_part = [[-0.42, 1], [-0.6, 0]]
    L = 1.25                            # I: Lipschitz constant of phi
    # "0": M = 2n x 2n, gamma;  "II": A_aux = n x n and gamma or bound (Lemma 2.14:
    # gamma = -(2 bound)^2);  "III": constituents = [A_1, A_2, ...]
    box = [[-3, 3], [-3, 3]]            # optional: where the CLI samples the class

Matrix entries are numbers or constant expressions of the parameters
(``"5*Ts"``); signals are expressions of ``t`` (seconds) and the parameters.

Expressions are parsed by :mod:`nlobs.systems.expressions` (a whitelisted AST),
never evaluated. Every error is a :class:`~nlobs.errors.ModelFileError` that
names the file, the line and the offending text.

Limits, so that a small or hostile file cannot hang nlobs or garble a terminal:

* only a regular file is read (never a directory, a FIFO or a device such as
  ``/dev/zero``; checked before and after opening, without blocking), and at
  most :data:`MAX_FILE_BYTES` (1 MiB) of it;
* at most :data:`MAX_NAMES` (1000) states, inputs, outputs and parameters
  each, and at most :data:`MAX_STRINGS` (20 000) strings in the whole file
  (names and expressions: a 1 MiB file of ``"0"`` entries would otherwise take
  20 s to parse);
* names are Python identifiers in Unicode NFKC normal form that are not
  keywords (:func:`nlobs._validate.name_problem`: a fullwidth ``ｘ`` is refused
  because expressions read it as ``x``);
* no string in the file (``name``, ``description``, names, expressions) holds a
  control character (``ESC`` among them) or a bidirectional override, and
  ``name`` is one line; integers are below ``10**300``;
* expressions obey the bounds of :mod:`nlobs.systems.expressions` (length,
  nesting, size of numbers and exponents).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp
from numpy.typing import NDArray

from nlobs._validate import unsafe_character
from nlobs.errors import InvalidArgumentError, ModelError, ModelFileError, NlobsError
from nlobs.systems.codegen import compile_matrix
from nlobs.systems.discrete_ui import (
    LPV,
    DiscreteUISystem,
    FunctionClass,
    Lipschitz,
    QCStar,
    QuadraticConstraint,
    qcstar_from_bounded_split,
)
from nlobs.systems.expressions import ExpressionError, parse_expression
from nlobs.systems.linear import LinearSystem
# MAX_FILE_BYTES, MAX_NAMES, MAX_STRINGS, resolve_model and shipped_models are also this module's (re-exported)
from nlobs.systems.modelfile_common import (
    MAX_FILE_BYTES,
    MAX_NAMES,
    MAX_STRINGS,
    SCENARIO_TABLES,
    TOP_KEYS,
    Source,
    check_header,
    read_constant,
    read_constant_matrix,
    read_names,
    read_parameters,
    read_text,
    read_toml,
    resolve_model,
    MODELS_JSON,
    SHIPPED_MODEL_JSON,
    shipped_models,
)
from nlobs.systems.scenario import RunDefaults, Scenario
from nlobs.systems.sensors import MeasurementGroup
from nlobs.systems.symbolic import SymbolicModel
from nlobs.systems.timebase import Discrete, TimeBase

Model = SymbolicModel | LinearSystem

_DYN_KEYS = {"f", "g", "rhs", "h"}
_LIN_KEYS = {"A", "B", "C", "D"}


def load_model(path: str | Path) -> Model:
    """Read a model file, or a shipped model by name.

    Parameters
    ----------
    path : str or Path
        A ``.toml`` file in the format described in the module docstring, or the name of a shipped model
        (:func:`shipped_models`, e.g. ``"pendulum"``).

    Returns
    -------
    SymbolicModel or LinearSystem

    Raises
    ------
    ModelFileError
        If the file cannot be found or read, is not valid TOML, or any key, name,
        expression or matrix is invalid; the message names the file, the line
        and the offending text.

    Examples
    --------
    >>> import numpy as np
    >>> model = load_model("pendulum")
    >>> model.states, model.inputs, model.outputs
    (('theta', 'omega'), ('tau',), ('y',))
    >>> plant = model.compile()  # NumPy callables, batch axes first
    >>> plant.rhs(0.0, np.array([[0.1, 0.0], [0.0, 1.0]]), np.zeros((2, 1))).shape
    (2, 2)
    """
    p = resolve_model(path)
    return parse_model(read_text(p), source=str(p))


def model_file_tables(path: str | Path) -> frozenset[str]:
    """The top-level keys and tables of a model file (or a shipped model), read as TOML and not interpreted.

    What ``nlobs advise`` asks before choosing a method: whether the file has a ``[cascade]`` table
    or the unknown-input tables of Khajenejad & Yong; their contents are not parsed here.

    Raises
    ------
    ModelFileError
        The file cannot be found or read, or is not valid TOML.
    """
    p = resolve_model(path)
    text = read_text(p)
    return frozenset(read_toml(Source(str(p), text), text))


def parse_model(text: str, *, source: str = "<string>") -> Model:
    """Parse model-file text (see :func:`load_model`); ``source`` is used in messages."""
    src = Source(source, text)
    return _model(src, read_toml(src, text))


def _model(src: Source, data: Mapping[str, Any]) -> Model:
    """The model of a parsed model file (the TOML is read once per file by its caller)."""
    return _model_and_cascade(src, data)[0]


def _model_and_cascade(src: Source, data: Mapping[str, Any]) -> tuple[Model, Any]:
    """The model of a parsed model file and, for a ``[cascade]`` table, its :class:`CascadeModel` (else ``None``)."""
    name, time = check_header(src, data)
    has_dyn, has_lin = "dynamics" in data, "linear" in data
    if "cascade" in data:  # the interconnection of Grip, Saberi & Johansen: the plant [x, w] of (1) / (2)+(1b)
        from nlobs.systems.cascade_file import build_cascade

        try:
            cm = build_cascade(src, data, name, time)
        except ModelFileError:
            raise
        except NlobsError as exc:
            raise src.error(f"[cascade]: {exc}", key="cascade") from None
        return cm.plant, cm
    if has_dyn == has_lin:
        raise src.error("a model needs exactly one of the tables [dynamics] or [linear]", key="dynamics" if has_dyn else None)
    try:
        if has_lin:
            return _linear(src, data, name, time), None
        return _nonlinear(src, data, name, time), None
    except ModelFileError:
        raise
    except NlobsError as exc:  # a validation error from the model constructors: on the line of the key it names
        raise src.error(str(exc), key=_key_named(str(exc))) from None


# ---------------------------------------------------------------------- pieces
_MATRIX_KEYS = ("A", "B", "C", "D", "f", "g", "h", "rhs")


def _key_named(message: str) -> str | None:
    """The key a constructor's message is about: ``"h: …"`` → ``h``; "state(s)" → ``states`` (also inputs, outputs)."""
    head = re.match(r"([A-Za-z_]\w*):", message)
    if head and head.group(1) in _MATRIX_KEYS:
        return head.group(1)
    return next((k for k in ("states", "inputs", "outputs") if re.search(rf"\b{k[:-1]}s?\b", message)), None)


def _expr_list(src: Source, table: Mapping[str, Any], key: str, symbols: Mapping[str, sp.Symbol]) -> list[sp.Expr]:
    v = table[key]
    if not isinstance(v, list):
        raise src.error(f"[dynamics].{key} must be a list of expression strings", key=key, text=repr(v))
    return [_expr(src, key, e, symbols) for e in v]


def _expr(src: Source, key: str, e: Any, symbols: Mapping[str, sp.Symbol]) -> sp.Expr:
    if isinstance(e, bool) or not isinstance(e, (str, int, float)):
        raise src.error(f"[dynamics].{key}: entries must be expression strings", key=key, text=repr(e))
    text = str(e)
    try:
        return parse_expression(text, symbols)
    except ExpressionError as exc:
        raise src.error(f"[dynamics].{key}: {exc.reason}", key=key, string=text if isinstance(e, str) else None,
                        text=exc.offending) from None


def _nonlinear(src: Source, data: Mapping[str, Any], name: str, time: TimeBase) -> SymbolicModel:
    states = read_names(src, data, "states", required=True) or []
    inputs = read_names(src, data, "inputs", required=False) or []
    outputs = read_names(src, data, "outputs", required=True) or []
    if not outputs:
        raise src.error("'outputs' is empty: a model needs at least one output (an observer estimates the state "
                        "from measurements); list the measured names, e.g. outputs = [\"y\"], with one entry of "
                        "[dynamics].h each", key="outputs", text="outputs")
    params = read_parameters(src, data)
    clash = sorted((set(states) & set(inputs)) | ((set(states) | set(inputs)) & set(params)))
    if clash:
        raise src.error("name declared twice (states, inputs, parameters)", string=clash[0], text=clash[0])
    dyn = data["dynamics"]
    if not isinstance(dyn, dict):
        raise src.error("[dynamics] must be a table", key="dynamics")
    unknown = sorted(set(dyn) - _DYN_KEYS)
    if unknown:
        hint = (f"; '{unknown[0]}' belongs before the first [table] (TOML puts a key after [dynamics] inside it)"
                if unknown[0] in TOP_KEYS else "")
        raise src.error(f"unknown key in [dynamics] (allowed: {', '.join(sorted(_DYN_KEYS))}){hint}", key=unknown[0],
                        text=unknown[0])
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


def _check_len(src: Source, key: str, v: Sequence[Any], want: int, what: str) -> None:
    if len(v) != want:
        raise src.error(f"[dynamics].{key} has {len(v)} entries but there are {want} {what}", key=key, text=key)


def _matrix(src: Source, lin: Mapping[str, Any], key: str) -> np.ndarray:
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


def _linear(src: Source, data: Mapping[str, Any], name: str, time: TimeBase) -> LinearSystem:
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
    if C.size == 0:
        raise src.error("[linear].C is empty: a model needs at least one output (a row of C)", key="C", text="C")
    if data.get("outputs") == []:
        raise src.error("'outputs' is empty: a model needs at least one output (one name per row of [linear].C)",
                        key="outputs", text="outputs")
    inputs = read_names(src, data, "inputs", required=False)
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
        return LinearSystem(A, B, C, D, time=time, states=read_names(src, data, "states", required=False),
                            inputs=inputs, outputs=read_names(src, data, "outputs", required=False), name=name)
    except (ModelError, ValueError) as exc:
        raise src.error(str(exc), key="linear") from None


# ------------------------------------------------------------- unknown-input models (Khajenejad & Yong)
_UI_INPUT_KEYS = {"G", "H", "bounded", "growing"}
_UI_NOISE_KEYS = {"W", "eta_w", "eta_v"}
_UI_INITIAL_KEYS = {"centre", "radius"}
_UI_CLASS_KEYS = {"kind", "linear_part", "L", "M", "gamma", "A_aux", "bound", "constituents", "box"}
_UI_CLASS_CONSTANTS = {"0": {"M", "gamma"}, "I": {"L"}, "II": {"A_aux", "gamma", "bound"}, "III": {"constituents"}}


@dataclass(frozen=True)
class DiscreteUIModel:
    """A model file with unknown inputs, as read by :func:`load_discrete_ui_model`.

    Attributes
    ----------
    system : DiscreteUISystem
        The model (8) of Khajenejad & Yong with its noise bounds, initial ball and function class.
    signals : mapping of str to callable
        Unknown-input signals for simulations, ``"bounded"`` and ``"growing"``:
        ``t`` of shape ``(K + 1,)`` (seconds) → ``d`` of shape ``(K + 1, p)``; the
        file's, or the defaults ``sin(t)`` and ``t**2`` in every component.
    box : tuple of ndarray or None
        ``(lo, hi)`` of ``[function_class].box``, where the class of ``φ`` is
        checked by sampling (``None`` when the file gives none).
    path : str
    known_input : InputSignals or None
        The known input ``u(t)`` of ``B u``, ``D u`` from ``[input_signals]`` (``None``: zero).
    """

    system: DiscreteUISystem
    signals: Mapping[str, Callable[[NDArray[np.float64]], NDArray[np.float64]]]
    box: tuple[NDArray[np.float64], NDArray[np.float64]] | None
    path: str
    known_input: Any = None


def load_discrete_ui(path: str | Path) -> DiscreteUISystem:
    """Read a model file with unknown inputs into a :class:`~nlobs.systems.discrete_ui.DiscreteUISystem`.

    The file is an ordinary discrete-time model file (``[dynamics]`` with an
    input-affine ``f`` and an ``h`` linear in the states and inputs, or
    ``[linear]``) with the tables ``[unknown_inputs]`` (``G``, ``H``),
    ``[noise]`` (``W``, ``eta_w``, ``eta_v``), ``[initial]`` (``centre``,
    ``radius``) and ``[function_class]`` (``kind`` with its constants and the
    ``linear_part`` ``A`` of the split ``f(x) = A x + φ(x)``); see the module
    docstring and ``docs/setvalued.md``.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    DiscreteUISystem
        ``x⁺ = A x + φ(x) + B u + G d + W w``, ``y = C x + D u + H d + v`` (Khajenejad & Yong, (8)).

    Raises
    ------
    ModelFileError
        As :func:`load_model`, and when a table is missing, a matrix has the
        wrong shape, a noise bound or radius is negative or not finite, ``h`` is
        not linear, or the class constants are missing or invalid; the message
        names the file, the line and the offending text.
    """
    return load_discrete_ui_model(path).system


def load_discrete_ui_model(path: str | Path) -> DiscreteUIModel:
    """:func:`load_discrete_ui` with the file's simulation signals and class-check box.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    DiscreteUIModel

    Raises
    ------
    ModelFileError
        As :func:`load_discrete_ui`.
    """
    p = resolve_model(path)
    text = read_text(p)
    return parse_discrete_ui(text, source=str(p), base_dir=p.parent)


def parse_discrete_ui(text: str, *, source: str = "<string>", base_dir: str | Path | None = None) -> DiscreteUIModel:
    """Parse the text of a model file with unknown inputs (see :func:`load_discrete_ui`)."""
    src = Source(source, text)
    data = read_toml(src, text)  # once: the model and the unknown-input tables come from the same parse
    model = _model(src, data)
    if not isinstance(model.time, Discrete):
        raise src.error("a model with unknown inputs needs time = \"discrete\"", key="time", text="time")
    for key in ("unknown_inputs", "noise", "initial", "function_class"):
        if key not in data:
            raise src.error(f"a model with unknown inputs needs the table [{key}]", text=key)
        if not isinstance(data[key], dict):
            raise src.error(f"[{key}] must be a table", key=key, text=key)
    for key, allowed in (("unknown_inputs", _UI_INPUT_KEYS), ("noise", _UI_NOISE_KEYS),
                         ("initial", _UI_INITIAL_KEYS), ("function_class", _UI_CLASS_KEYS)):
        unknown = sorted(set(data[key]) - allowed)
        if unknown:
            raise src.table_error(key, unknown[0], f"unknown key in [{key}] (allowed: {', '.join(sorted(allowed))})",
                                  text=unknown[0])
    params = read_parameters(src, data) if isinstance(model, SymbolicModel) else {}
    psyms = {k: sp.Symbol(k, real=True) for k in params}
    n = model.n
    if isinstance(model, SymbolicModel):
        C, D = _linear_output(src, model, params)
    else:
        C, D = model.C, model.D
    l = C.shape[0]  # noqa: E741 - the paper's name
    ui, noise, init, fc = data["unknown_inputs"], data["noise"], data["initial"], data["function_class"]
    if "G" not in ui:
        raise src.table_error("unknown_inputs", None, "[unknown_inputs] needs 'G' (n x p)", text="G")
    G = read_constant_matrix(src, "unknown_inputs", "G", ui["G"], params, psyms, rows=n)
    p = G.shape[1]
    H = read_constant_matrix(src, "unknown_inputs", "H", ui["H"], params, psyms, rows=l, cols=p) if "H" in ui else None
    W = read_constant_matrix(src, "noise", "W", noise["W"], params, psyms, rows=n) if "W" in noise else None
    eta_w = _bound(src, "noise", "eta_w", noise, params, psyms)
    eta_v = _bound(src, "noise", "eta_v", noise, params, psyms)
    radius = _bound(src, "initial", "radius", init, params, psyms)
    centre = (_const_vector(src, "initial", "centre", init["centre"], params, psyms, n) if "centre" in init
              else np.zeros(n))
    function_class, A_lin = _function_class(src, fc, model, params, psyms)
    box = _box_of(src, fc, params, psyms, n) if "box" in fc else None
    try:
        if isinstance(model, SymbolicModel):
            system = DiscreteUISystem.from_symbolic(
                model, G=G, C=C, H=H, A=A_lin, D=D, W=W, function_class=function_class, eta_w=eta_w, eta_v=eta_v,
                x0=centre, delta0=radius, name=model.name)
        else:
            K = model.A - A_lin
            phi = None if not np.any(K) else _LinearPhi(K)
            system = DiscreteUISystem(A_lin, G, C, H, B=model.B, D=D, W=W, phi=phi, function_class=function_class,
                                      eta_w=eta_w, eta_v=eta_v, x0=centre, delta0=radius, time=model.time,
                                      name=model.name)
    except ModelFileError:
        raise
    except NlobsError as exc:
        raise src.table_error("unknown_inputs", None, str(exc)) from None
    signals = {kind: _signal(src, ui, kind, params, p) for kind in ("bounded", "growing")}
    known = _input_signals(src, data, model, params, base_dir)
    return DiscreteUIModel(system, signals, box, source, known)


@dataclass(frozen=True)
class _LinearPhi:
    """``φ(x) = K x`` for a ``[linear]`` model whose class is stated for a different linear part."""

    K: NDArray[np.float64]

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(x, dtype=float) @ self.K.T


def _linear_output(src: Source, model: SymbolicModel, params: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """``h(x, u) = C x + D u`` read off exactly; a nonlinear or offset ``h`` is an error (model (8))."""
    subs = {sp.Symbol(k, real=True): v for k, v in params.items()}
    h = sp.Matrix(model.h).subs(subs)
    X, U = sp.Matrix(model.x), sp.Matrix(model.u)
    Cs = h.jacobian(X)
    Ds = h.jacobian(U) if model.m else sp.zeros(h.shape[0], 0)
    rest = sp.simplify(h - Cs * X - (Ds * U if model.m else sp.zeros(h.shape[0], 1)))
    for i in range(h.shape[0]):
        if Cs[i, :].free_symbols or (model.m and Ds[i, :].free_symbols) or rest[i] != 0:
            raise src.error("[dynamics].h must be linear in the states and inputs (y = C x + D u + H d + v, "
                            "Khajenejad & Yong (8)); put a nonlinear output through an affine abstraction first",
                            key="h", string=str(model.h[i]), text=str(model.h[i]))
    return np.array(Cs, dtype=float).reshape(h.shape[0], model.n), np.array(Ds, dtype=float).reshape(h.shape[0], model.m)


def _const_vector(src: Source, table: str, key: str, v: Any, params: Mapping[str, float],
                  psyms: Mapping[str, sp.Symbol], n: int) -> np.ndarray:
    if not isinstance(v, list) or len(v) != n:
        raise src.table_error(table, key, f"[{table}].{key} must be a list of {n} numbers", repr(v)[:80])
    return np.array([read_constant(src, table, key, e, params, psyms) for e in v], dtype=float)


def _bound(src: Source, table: str, key: str, tab: Mapping[str, Any], params: Mapping[str, float],
           psyms: Mapping[str, sp.Symbol]) -> float:
    if key not in tab:
        raise src.table_error(table, None, f"[{table}] needs '{key}' (a bound >= 0)", key)
    val = read_constant(src, table, key, tab[key], params, psyms)
    if val < 0:
        raise src.table_error(table, key, f"[{table}].{key} must be >= 0", repr(tab[key]))
    return val


def _function_class(src: Source, fc: Mapping[str, Any], model: Model, params: Mapping[str, float],
                    psyms: Mapping[str, sp.Symbol]) -> tuple[FunctionClass, np.ndarray]:
    n = model.n
    kind = fc.get("kind")
    if kind not in _UI_CLASS_CONSTANTS:
        raise src.table_error("function_class", "kind",
                              "[function_class].kind must be \"0\", \"I\", \"II\" or \"III\" (Khajenejad & Yong, Classes 0-III)",
                              repr(kind))
    extra = sorted(set(fc) & (set().union(*_UI_CLASS_CONSTANTS.values()) - _UI_CLASS_CONSTANTS[kind]))
    if extra:
        raise src.table_error("function_class", extra[0], f"[function_class]: '{extra[0]}' does not belong to class "
                              f"{kind} (it takes {', '.join(sorted(_UI_CLASS_CONSTANTS[kind]))})", extra[0])
    if "linear_part" in fc:
        A_lin = read_constant_matrix(src, "function_class", "linear_part", fc["linear_part"], params, psyms, rows=n, cols=n)
    elif isinstance(model, LinearSystem):
        A_lin = np.array(model.A)
    else:
        raise src.table_error("function_class", None, "[function_class] needs 'linear_part' (the A of "
                              "f(x) = A x + phi(x); the class describes phi)", "linear_part")

    def need(key: str) -> Any:
        if key not in fc:
            raise src.table_error("function_class", None, f"[function_class]: class {kind} needs '{key}'", key)
        return fc[key]

    try:
        if kind == "I":
            return Lipschitz(read_constant(src, "function_class", "L", need("L"), params, psyms), n), A_lin
        if kind == "0":
            M = read_constant_matrix(src, "function_class", "M", need("M"), params, psyms, rows=2 * n, cols=2 * n)
            return QuadraticConstraint(M, read_constant(src, "function_class", "gamma", need("gamma"), params, psyms)), A_lin
        if kind == "II":
            A_aux = read_constant_matrix(src, "function_class", "A_aux", need("A_aux"), params, psyms, rows=n, cols=n)
            if ("gamma" in fc) == ("bound" in fc):
                raise src.table_error("function_class", None, "[function_class]: class II needs exactly one of 'gamma' "
                                      "or 'bound' (Lemma 2.14: gamma = -(2 bound)^2)", "gamma")
            if "bound" in fc:
                r = read_constant(src, "function_class", "bound", fc["bound"], params, psyms)
                if r < 0:
                    raise src.table_error("function_class", "bound", "[function_class].bound must be >= 0", repr(fc["bound"]))
                return qcstar_from_bounded_split(A_aux, r), A_lin
            return QCStar(A_aux, read_constant(src, "function_class", "gamma", fc["gamma"], params, psyms)), A_lin
        mats = need("constituents")
        if not isinstance(mats, list) or not mats:
            raise src.table_error("function_class", "constituents",
                                  "[function_class].constituents must be a list of n x n matrices", repr(mats)[:80])
        return LPV(tuple(read_constant_matrix(src, "function_class", "constituents", m, params, psyms, rows=n, cols=n)
                         for m in mats)), A_lin
    except ModelFileError:
        raise
    except NlobsError as exc:
        k = _first_key(fc)
        raise src.table_error("function_class", k, f"[function_class]: {exc}",
                              f"{k} = {fc[k]!r}" if k else str(kind)) from None


def _first_key(fc: Mapping[str, Any]) -> str | None:
    """The first constant of the class present in the table (where a constructor's complaint points)."""
    return next((k for k in ("L", "M", "gamma", "A_aux", "bound", "constituents") if k in fc), None)


def _box_of(src: Source, fc: Mapping[str, Any], params: Mapping[str, float], psyms: Mapping[str, sp.Symbol],
            n: int) -> tuple[np.ndarray, np.ndarray]:
    b = read_constant_matrix(src, "function_class", "box", fc["box"], params, psyms, rows=n, cols=2)
    if np.any(b[:, 1] < b[:, 0]):
        raise src.table_error("function_class", "box", "[function_class].box: every row is [lo, hi] with lo <= hi", "box")
    return b[:, 0].copy(), b[:, 1].copy()


def _signal(src: Source, ui: Mapping[str, Any], kind: str, params: Mapping[str, float],
            p: int) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    t = sp.Symbol("t", real=True)
    if kind not in ui:
        exprs: list[sp.Expr] = [sp.sin(t) if kind == "bounded" else t**2] * p
    else:
        v = ui[kind]
        if not isinstance(v, list) or len(v) != p:
            raise src.table_error("unknown_inputs", kind, f"[unknown_inputs].{kind} must be a list of {p} expressions of t",
                                  repr(v)[:80])
        syms = {"t": t, **{k: sp.Symbol(k, real=True) for k in params}}
        exprs = []
        for e in v:
            if isinstance(e, bool) or not isinstance(e, (str, int, float)):
                raise src.table_error("unknown_inputs", kind, f"[unknown_inputs].{kind}: entries must be expressions of t",
                                      repr(e))
            try:
                ex = parse_expression(str(e), syms)
            except ExpressionError as exc:
                raise src.table_error("unknown_inputs", kind, f"[unknown_inputs].{kind}: {exc.reason}",
                                      exc.offending) from None
            exprs.append(ex.subs({sp.Symbol(k, real=True): val for k, val in params.items()}))
    fn = compile_matrix(sp.Matrix(exprs), ((t,),), vector=True, what=f"[unknown_inputs].{kind}")
    return _Signal(fn, p)


@dataclass(frozen=True)
class _Signal:
    fn: Callable[..., Any]
    p: int

    def __call__(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        tt = np.asarray(t, dtype=float).reshape(-1, 1)
        out = np.asarray(self.fn(tt), dtype=float)
        return np.broadcast_to(out, (tt.shape[0], self.p)).copy()



# ------------------------------------------------------------- experiments: sensors, inputs, noise, units
_SENSOR_KEYS = {"outputs", "rate", "noise_std", "noise_cov", "bias", "outages"}
_PROCESS_KEYS = {"std", "covariance"}
_CONTROLLER_KEYS = {"law", "rate", "saturation"}
_CONSTRAINT_KEYS = {"lower", "upper"}
_SIMULATION_KEYS = {"x0", "initial_error_std", "duration", "dt", "settle", "runs", "box"}
#: Longest unit string (``"m/s^2"``, ``"mmol/L"``).
MAX_UNIT_LENGTH = 40


def load_scenario(path: str | Path) -> Scenario:
    """Read a model file with its sensors, input signals, process noise, units and run defaults.

    The tables are described in :mod:`nlobs.systems.scenario`; a file without them gives a
    :class:`~nlobs.systems.scenario.Scenario` with exact continuous measurement, zero input and
    no process noise. A CSV input signal's path is relative to the model file's folder.

    Raises
    ------
    ModelFileError
        As :func:`load_model`, and for any invalid sensor (a rate that is not positive, a
        covariance that is not symmetric positive semidefinite, an output in two groups or in
        none), input signal, process noise, unit or run default; the message names the file,
        the line and the offending text.
    """
    p = resolve_model(path)
    return parse_scenario(read_text(p), source=str(p), base_dir=p.parent)


def parse_scenario(text: str, *, source: str = "<string>", base_dir: str | Path | None = None) -> Scenario:
    """Parse model-file text into a :class:`~nlobs.systems.scenario.Scenario` (see :func:`load_scenario`)."""
    src = Source(source, text)
    data = read_toml(src, text)  # once: the model and the scenario's tables come from the same parse
    model, cascade = _model_and_cascade(src, data)
    params = read_parameters(src, data) if isinstance(model, SymbolicModel) else {}
    psyms = {k: sp.Symbol(k, real=True) for k in params}
    for key in SCENARIO_TABLES:
        if key in data and not isinstance(data[key], dict):
            raise src.error(f"'{key}' must be a table", key=key, text=key)
    units = _units(src, data.get("units", {}), model)
    sensors = _sensors(src, data.get("sensors", {}), model, params, psyms)
    signals = _input_signals(src, data, model, params, base_dir)
    q = _process_noise(src, data["process_noise"], model.n, params, psyms) if "process_noise" in data else None
    defaults = _run_defaults(src, data.get("simulation", {}), model.n, params, psyms)
    controller = _controller(src, data["controller"], model, params, psyms) if "controller" in data else None
    bounds = _constraints(src, data["constraints"], model, params, psyms) if "constraints" in data else None
    return Scenario(model, sensors, signals, q, units, defaults, source, frozenset(data), cascade,
                    controller=controller, constraints=bounds)


def _units(src: Source, table: Mapping[str, Any], model: Model) -> dict[str, str]:
    names = {*model.states, *model.inputs, *model.outputs}
    out = {}
    for k, v in table.items():
        if k not in names and k != "t":
            raise src.error(f"units: {k!r} is not a state, input or output of the model, nor t "
                            f"(time) (known: {', '.join(sorted(names))})", key=k, text=k)
        if not isinstance(v, str) or len(v) > MAX_UNIT_LENGTH or unsafe_character(v, one_line=True):
            raise src.error(f"units.{k} must be one line of text of at most {MAX_UNIT_LENGTH} characters", key=k,
                            text=repr(v)[:80])
        out[k] = v
    return out


def _number_or_list(src: Source, table: str, key: str, v: Any, params: Mapping[str, float],
                    psyms: Mapping[str, sp.Symbol]) -> np.ndarray:
    if isinstance(v, list):
        return np.array([read_constant(src, table, key, e, params, psyms) for e in v], dtype=float)
    return np.array(read_constant(src, table, key, v, params, psyms), dtype=float)


def _sensors(src: Source, table: Mapping[str, Any], model: Model, params: Mapping[str, float],
             psyms: Mapping[str, sp.Symbol]) -> tuple[MeasurementGroup, ...]:
    groups = []
    owner: dict[str, str] = {}
    for gname, spec in table.items():
        where = f"sensors.{gname}"
        if not isinstance(spec, dict):
            raise src.error(f"[{where}] must be a table (outputs, rate, noise_std, ...)", key=gname, text=gname)
        unknown = sorted(set(spec) - _SENSOR_KEYS)
        if unknown:
            raise src.table_error(where, unknown[0], f"unknown key in [{where}] (allowed: "
                                  f"{', '.join(sorted(_SENSOR_KEYS))})", unknown[0])
        for need in ("outputs", "rate"):
            if need not in spec:
                raise src.table_error(where, None, f"[{where}] needs '{need}'", need)
        outs = spec["outputs"]
        if isinstance(outs, str):
            outs = [outs]
        if not isinstance(outs, list) or not outs or not all(isinstance(o, str) for o in outs):
            raise src.table_error(where, "outputs", f"[{where}].outputs must be a list of output names",
                                  repr(outs)[:80])
        for o in outs:
            if o not in model.outputs:
                raise src.table_error(where, "outputs", f"[{where}]: {o!r} is not an output of the model (outputs: "
                                      f"{', '.join(model.outputs)})", o)
            if o in owner:
                raise src.table_error(where, "outputs", f"output {o!r} is in both [{owner[o]}] and [{where}]", o)
            owner[o] = where
        kw: dict[str, Any] = {"rate": read_constant(src, where, "rate", spec["rate"], params, psyms)}
        if "noise_std" in spec:
            kw["noise_std"] = _number_or_list(src, where, "noise_std", spec["noise_std"], params, psyms)
        if "noise_cov" in spec:
            if "noise_std" in spec:
                raise src.table_error(where, "noise_cov", f"[{where}]: give noise_std or noise_cov, not both",
                                      "noise_cov")
            kw["noise_cov"] = read_constant_matrix(src, where, "noise_cov", spec["noise_cov"], params, psyms,
                                            rows=len(outs), cols=len(outs))
        if "bias" in spec:
            kw["bias"] = _number_or_list(src, where, "bias", spec["bias"], params, psyms)
        if "outages" in spec:
            kw["outages"] = read_constant_matrix(src, where, "outages", spec["outages"], params, psyms, cols=2)
        try:
            groups.append(MeasurementGroup(gname, tuple(outs), **kw))
        except NlobsError as exc:
            key = _sensor_key(str(exc))
            raise src.table_error(where, key, str(exc).replace(f"measurement group {gname!r}: ", f"[{where}]."),
                                  key or "") from None
    if groups:
        missing = [o for o in model.outputs if o not in owner]
        if missing:
            raise src.error(f"outputs {', '.join(missing)} belong to no [sensors.*] group: with sensors, every "
                            "output needs one (its rate and noise)", key="sensors", text=missing[0])
    return tuple(groups)


def _sensor_key(message: str) -> str | None:
    for key in ("rate", "noise_std", "noise_cov", "bias", "outages"):
        if key in message:
            return key
    return None


def _input_signals(src: Source, data: Mapping[str, Any], model: Model, params: Mapping[str, float],
                   base_dir: str | Path | None) -> Any:
    table = data.get("input_signals")
    if table is None:
        return None
    from nlobs.systems.signals import Constant, InputSignals, parse_signal_spec, signal_from_table

    if not model.inputs:
        raise src.error("[input_signals]: the model has no inputs", key="input_signals", text="input_signals")
    for k in table:
        if k not in model.inputs:
            raise src.table_error("input_signals", k, f"[input_signals]: {k!r} is not an input of the model "
                                  f"(inputs: {', '.join(model.inputs)})", k)
    sigs = []
    for name in model.inputs:
        v = table.get(name, 0.0)
        try:
            if isinstance(v, dict):
                sig = signal_from_table(v, parameters=params, base_dir=base_dir)
            elif isinstance(v, bool) or not isinstance(v, (int, float, str)):
                raise InvalidArgumentError("expected a number, an expression of t or a table with 'kind'")
            elif isinstance(v, str):
                sig = parse_signal_spec(f"expr:{v}", parameters=params, base_dir=base_dir)
            else:
                sig = Constant(float(v))
        except ModelFileError as exc:  # a CSV file's own error names that file and its line
            raise exc from None
        except NlobsError as exc:
            raise src.table_error("input_signals", name, f"[input_signals].{name}: {exc}", repr(v)[:80]) from None
        sigs.append(sig)
    return InputSignals(tuple(model.inputs), tuple(sigs))


def _process_noise(src: Source, table: Mapping[str, Any], n: int, params: Mapping[str, float],
                   psyms: Mapping[str, sp.Symbol]) -> np.ndarray:
    from nlobs._validate import as_covariance

    unknown = sorted(set(table) - _PROCESS_KEYS)
    if unknown:
        raise src.table_error("process_noise", unknown[0], "unknown key in [process_noise] (allowed: covariance, std)",
                              unknown[0])
    if ("std" in table) == ("covariance" in table):
        raise src.table_error("process_noise", None, "[process_noise] needs exactly one of 'std' (per state) or "
                              "'covariance' (n x n)", "std")
    if "std" in table:
        return np.diag(_per_state_std(src, "process_noise", "std", table["std"], n, params, psyms) ** 2)
    cov = read_constant_matrix(src, "process_noise", "covariance", table["covariance"], params, psyms, rows=n, cols=n)
    try:
        return as_covariance("[process_noise].covariance", cov, n)
    except NlobsError as exc:
        raise src.table_error("process_noise", "covariance", str(exc), "covariance") from None


def _per_state_std(src: Source, table: str, key: str, v: Any, n: int, params: Mapping[str, float],
                   psyms: Mapping[str, sp.Symbol]) -> np.ndarray:
    """Standard deviations: one number for every state, or ``n`` non-negative numbers."""
    std = _number_or_list(src, table, key, v, params, psyms)
    if std.ndim == 0:
        std = np.full(n, float(std))
    if std.shape != (n,) or np.any(std < 0):
        raise src.table_error(table, key, f"[{table}].{key} must be {n} non-negative numbers (one per state) or one "
                              "for all", repr(v)[:80])
    return std


def _run_defaults(src: Source, table: Mapping[str, Any], n: int, params: Mapping[str, float],
                  psyms: Mapping[str, sp.Symbol]) -> RunDefaults:
    unknown = sorted(set(table) - _SIMULATION_KEYS)
    if unknown:
        raise src.table_error("simulation", unknown[0], f"unknown key in [simulation] (allowed: "
                              f"{', '.join(sorted(_SIMULATION_KEYS))})", unknown[0])
    kw: dict[str, Any] = {}
    if "x0" in table:
        kw["x0"] = _const_vector(src, "simulation", "x0", table["x0"], params, psyms, n)
    if "initial_error_std" in table:
        kw["initial_error_std"] = _per_state_std(src, "simulation", "initial_error_std", table["initial_error_std"], n,
                                                 params, psyms)
    for key in ("duration", "dt", "settle"):
        if key in table:
            val = read_constant(src, "simulation", key, table[key], params, psyms)
            if val < 0 or (val == 0 and key != "settle"):
                raise src.table_error("simulation", key, f"[simulation].{key} must be "
                                      f"{'non-negative' if key == 'settle' else 'positive'} (seconds)", repr(table[key]))
            kw[key] = val
    if "runs" in table:
        r = table["runs"]
        if isinstance(r, bool) or not isinstance(r, int) or r < 1:
            raise src.table_error("simulation", "runs", "[simulation].runs must be a positive integer", repr(r))
        kw["runs"] = r
    if "box" in table:
        b = table["box"]
        if isinstance(b, list) and len(b) == 2 and not any(isinstance(e, list) for e in b):
            b = [b] * n
        arr = read_constant_matrix(src, "simulation", "box", b, params, psyms, rows=n, cols=2)
        if np.any(arr[:, 1] <= arr[:, 0]):
            raise src.table_error("simulation", "box", "[simulation].box: every row is [lo, hi] with lo < hi", "box")
        kw["box"] = (arr[:, 0].copy(), arr[:, 1].copy())
    return RunDefaults(**kw)


def _controller(src: Source, table: Mapping[str, Any], model: Model, params: Mapping[str, float],
                psyms: Mapping[str, sp.Symbol]) -> Any:
    """``[controller]``: the feedback law (:class:`~nlobs.systems.controller.ControlLaw`)."""
    from nlobs.systems.controller import ControlLaw

    unknown = sorted(set(table) - _CONTROLLER_KEYS)
    if unknown:
        raise src.table_error("controller", unknown[0], "unknown key in [controller] (allowed: "
                              f"{', '.join(sorted(_CONTROLLER_KEYS))})", unknown[0])
    if "law" not in table:
        raise src.table_error("controller", None, "[controller] needs 'law' (one expression per input)", "controller")
    if not model.inputs:
        raise src.table_error("controller", "law", "[controller]: the model has no inputs to control", "law")
    law = table["law"]
    if isinstance(law, str):
        law = [law]
    if not isinstance(law, list) or not all(isinstance(e, (str, int, float)) and not isinstance(e, bool) for e in law):
        raise src.table_error("controller", "law", "[controller].law must be a list of expression strings, one per "
                              "input", repr(law)[:80])
    rate = read_constant(src, "controller", "rate", table["rate"], params, psyms) if "rate" in table else None
    sat = None
    if "saturation" in table:
        sat = _bounds_list(src, "controller", "saturation", table["saturation"], params, psyms)
    try:
        return ControlLaw(tuple(model.states), tuple(model.inputs), tuple(str(e) for e in law),
                          parameters=dict(params), rate=rate, saturation=sat)
    except ExpressionError as exc:
        raise src.table_error("controller", "law", f"[controller].law: {exc.reason}", exc.offending or "law") from None
    except NlobsError as exc:
        key = next((k for k in ("saturation", "rate", "law") if str(exc).startswith(k)), "law")
        raise src.table_error("controller", key, f"[controller].{exc}", key) from None


def _bounds_list(src: Source, table: str, key: str, v: Any, params: Mapping[str, float],
                 psyms: Mapping[str, sp.Symbol]) -> Any:
    """A (nested) list of numbers where TOML's ``inf`` and ``-inf`` are allowed, finite entries as constants."""
    if isinstance(v, list):
        return [_bounds_list(src, table, key, e, params, psyms) for e in v]
    if isinstance(v, float) and math.isinf(v):
        return v
    return read_constant(src, table, key, v, params, psyms)


def _constraints(src: Source, table: Mapping[str, Any], model: Model, params: Mapping[str, float],
                 psyms: Mapping[str, sp.Symbol]) -> Any:
    """``[constraints]``: per-state bounds (:class:`~nlobs.systems.constraints.StateBounds`)."""
    from nlobs.systems.constraints import StateBounds

    unknown = sorted(set(table) - _CONSTRAINT_KEYS)
    if unknown:
        raise src.table_error("constraints", unknown[0], "unknown key in [constraints] (allowed: lower, upper)",
                              unknown[0])
    n = model.n
    vals = {}
    for key, default in (("lower", -math.inf), ("upper", math.inf)):
        if key not in table:
            vals[key] = [default] * n
            continue
        v = table[key]
        if not isinstance(v, list):
            v = [v] * n
        if len(v) != n or any(isinstance(e, list) for e in v):
            raise src.table_error("constraints", key, f"[constraints].{key} must be {n} numbers (one per state; inf "
                                  "or -inf for none)", repr(table[key])[:80])
        vals[key] = _bounds_list(src, "constraints", key, v, params, psyms)
    try:
        return StateBounds(vals["lower"], vals["upper"])
    except NlobsError as exc:
        raise src.table_error("constraints", "lower", f"[{exc}".replace("[constraints:", "[constraints]:"),
                              "lower") from None
