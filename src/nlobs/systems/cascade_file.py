r"""The ``[cascade]`` table of a model file: an interconnection of Grip, Saberi & Johansen.

A model file with a top-level ``[cascade]`` table describes a nonlinear subsystem Σ₁ whose output
``z`` is **not measured** and drives a linear subsystem Σ₂ that is measured (Grip, Saberi &
Johansen, (1a)/(1b)), or the feedback interconnection Σ₁* ⇄ Σ₂ (2), together with the injection
``g`` of an existing observer for Σ₁ (3)/(16)::

    name = "chemostat-analyser"
    inputs = ["D"]
    outputs = ["y"]                     # the measured outputs y of Σ2 (one per row of C)
    parameters = { mu_max = 0.5, tau = 0.5 }
    # states = ["X", "S", "w"]          # optional: Σ1's states, then Σ2's (the plant state [x, w])

    [cascade]
    form = "cascade"                    # or "feedback" (f, h, g may use the linear states w)
    states = ["X", "S"]                 # x of Σ1
    outputs = ["z"]                     # the unmeasured z of Σ1
    f = ["...", "..."]                  # ẋ = f(u, x) (1a)  /  f(u, w, x) (2)
    h = ["X"]                           # z = h(u, x)       /  h(u, w, x)
    g = ["l1*(z - X)", "l2*(z - X)"]    # x̂̇ = f(u, x̂) + g(u, x̂, z) (3): in g the states mean x̂,
                                        # the z names ẑ and (feedback) the linear states ŵ
    method = "placement"                # optional: how the gain is designed by default, "lmi" (LMI (14),
    gamma = 1.0                         # the default), "placement" or "h2" (the smallest noise-to-error
                                        # H2 norm for the file's [sensors.*] and [process_noise]), and
                                        # its γ (‖H‖∞ < γ; default 1)

    [cascade.linear]                    # Σ2 (1b): ẇ = A w + B_u u + B_z z, y = C w + D_u u + D_z z
    states = ["w"]
    A = [["-1/tau"]]                    # numbers or constant expressions of the parameters
    B_z = [["1/tau"]]
    C = [[1.0]]
    # B_u, D_u (n_w × m, p_y × m) and D_z (p_y × p_z) are zero when omitted

    [cascade.lyapunov]                  # optional: Assumptions 1–3, for Theorem 1's γ
    alpha3 = 0.19                       # (6)
    alpha4 = 2.0                        # (7)
    L1 = 70.6                           # Assumption 2 (‖g(·, z₁) − g(·, z₂)‖ ≤ L₁‖z₁ − z₂‖)
    L2 = 1.72                           # Assumption 3 (the Lipschitz constant of d)

The file then needs no ``[dynamics]``: :func:`nlobs.systems.modelfile.load_model` returns the
interconnected plant ``[x, w]`` as a :class:`~nlobs.systems.symbolic.SymbolicModel`
(``ẋ = f``, ``ẇ = A w + B_u u + B_z h``, ``y = C w + D_u u + D_z h``), so the file's
``[sensors.NAME]``, ``[input_signals]``, ``[process_noise]``, ``units`` and ``[simulation]``
tables refer to these states and outputs as in any model file. :func:`load_cascade` returns
the parts (:class:`CascadeModel`: Σ₁ with ``g``, Σ₂, the constants).

Expressions are parsed by :mod:`nlobs.systems.expressions` (a whitelisted AST), never
evaluated. Every error is a :class:`~nlobs.errors.ModelFileError` naming the file, the line
and the offending text.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from nlobs._typing import Array
from nlobs._validate import name_problem
from nlobs.errors import ModelFileError, NlobsError
from nlobs.systems.expressions import ExpressionError, as_sympy_matrix, parse_expression
from nlobs.systems.interconnected import LinearSubsystem, NonlinearSubsystem, check_interconnection
from nlobs.systems.modelfile_common import (
    Source,
    check_header,
    read_constant,
    read_constant_matrix,
    read_names,
    read_parameters,
    read_text,
    read_toml,
    resolve_model,
)
from nlobs.systems.symbolic import SymbolicModel
from nlobs.systems.timebase import TimeBase

__all__ = ["FORMS", "CascadeModel", "LyapunovData", "has_cascade", "load_cascade", "parse_cascade"]

#: The interconnections a ``[cascade]`` table describes: (1a)+(1b) and (2)+(1b).
FORMS: tuple[str, ...] = ("cascade", "feedback")
_KEYS = {"form", "states", "outputs", "f", "h", "g", "linear", "lyapunov", "method", "gamma"}
_LIN_KEYS = {"states", "A", "B_u", "B_z", "C", "D_u", "D_z"}
_LYAP_KEYS = {"alpha3", "alpha4", "L1", "L2"}
_T, _TL, _TY = "cascade", "cascade.linear", "cascade.lyapunov"


@dataclass(frozen=True)
class LyapunovData:
    r"""The constants of Assumptions 1–3 given in ``[cascade.lyapunov]``.

    ``α₃`` (6), ``α₄`` (7) of a Lyapunov function of Σ₁'s observer error, ``L₁`` (Assumption 2,
    the Lipschitz constant of ``g`` in ``z``) and ``L₂`` (Assumption 3, of ``d``); Theorem 1 then
    gives ``γ = 4α₃/(4L₂² + α₄²L₁²)``.

    Attributes
    ----------
    alpha3 : float
        ``α₃`` of (6) (positive).
    alpha4 : float
        ``α₄`` of (7) (positive).
    L1 : float
        ``L₁`` of Assumption 2, the Lipschitz constant of ``g`` in ``z`` (positive).
    L2 : float
        ``L₂`` of Assumption 3, the Lipschitz constant of ``d`` (positive).
    """

    alpha3: float
    alpha4: float
    L1: float
    L2: float

    def to_dict(self) -> dict[str, float]:
        return {"alpha3": self.alpha3, "alpha4": self.alpha4, "L1": self.L1, "L2": self.L2}


@dataclass(frozen=True, eq=False)
class CascadeModel:
    """What a ``[cascade]`` table describes (module docstring).

    Attributes
    ----------
    name : str
    form : {"cascade", "feedback"}
    sigma1 : NonlinearSubsystem
        Σ₁ (1a) or Σ₁* (2) with the injection ``g`` of its observer (3)/(16).
    sigma2 : LinearSubsystem
        Σ₂ (1b), with the file's linear state and output names.
    plant : SymbolicModel
        The interconnected plant ``[x, w]`` (what :func:`nlobs.systems.modelfile.load_model` returns).
    lyapunov : LyapunovData or None
        ``[cascade.lyapunov]``, when given.
    method : str or None
        The file's default gain design (``"lmi"``, ``"placement"`` or ``"h2"``), ``None`` when not given.
    gamma : float or None
        The file's default ``γ`` (``‖H‖∞ < γ``), ``None`` when not given.
    parameters : mapping of str to float
    path : str
    expressions : tuple of (tuple of sympy.Expr) or None
        Σ₁'s ``f``, ``h`` and ``g`` as parsed (over the symbols of the states, ``z``, inputs and parameters,
        each ``sympy.Symbol(name, real=True)``); ``None`` for a model built otherwise.
    """

    name: str
    form: str
    sigma1: NonlinearSubsystem
    sigma2: LinearSubsystem
    plant: SymbolicModel
    lyapunov: LyapunovData | None
    parameters: Mapping[str, float]
    path: str = ""
    method: str | None = None
    gamma: float | None = None
    expressions: tuple[tuple[Any, ...], tuple[Any, ...], tuple[Any, ...]] | None = field(
        default=None, repr=False, compare=False)

    @property
    def feedback(self) -> bool:
        return self.form == "feedback"


def has_cascade(path: str | Path) -> bool:
    """Whether the model file (or shipped model) has a top-level ``[cascade]`` table (it is parsed).

    Parameters
    ----------
    path : str or Path
        A model file, or the name of a shipped model.

    Returns
    -------
    bool

    Raises
    ------
    ModelFileError
        No such file or shipped model, the file cannot be read, or it is not valid TOML.
    """
    p = resolve_model(path)
    text = read_text(p)
    src = Source(str(p), text)
    return "cascade" in read_toml(src, text)


def load_cascade(path: str | Path) -> CascadeModel:
    """Read the ``[cascade]`` table of a model file, or of a shipped model by name.

    Parameters
    ----------
    path : str or Path
        A model file, or the name of a shipped model.

    Returns
    -------
    CascadeModel

    Raises
    ------
    ModelFileError
        The file has no ``[cascade]`` table, or any of its entries is invalid (the message names
        the file, the line and the offending text).
    """
    p = resolve_model(path)
    return parse_cascade(read_text(p), source=str(p))


def parse_cascade(text: str, *, source: str = "<string>") -> CascadeModel:
    """Parse model-file text with a ``[cascade]`` table (see :func:`load_cascade`).

    Parameters
    ----------
    text : str
        The model file's TOML text.
    source : str, default "<string>"
        Where the text comes from, named in error messages; its stem names the model when the text gives no ``name``.

    Returns
    -------
    CascadeModel

    Raises
    ------
    ModelFileError
        The text has no ``[cascade]`` table, or any of its entries is invalid.
    """
    src = Source(source, text)
    data = read_toml(src, text)
    if "cascade" not in data:
        raise ModelFileError(source, None, "", "no [cascade] table (an interconnection of a nonlinear Σ1 and a "
                             "linear Σ2, Grip–Saberi–Johansen (1)); see the model-file format in docs/cascade.md")
    time = check_header(src, data)[1]  # every top-level check of the file, as the model reader makes them
    name = data.get("name", Path(source).stem)
    try:
        return build_cascade(src, data, str(name), time)
    except ModelFileError:
        raise
    except NlobsError as exc:  # as the model reader reports it
        raise src.error(f"[cascade]: {exc}", key="cascade") from None


def build_cascade(src: Any, data: Mapping[str, Any], name: str, time: TimeBase) -> CascadeModel:
    """The :class:`CascadeModel` of parsed TOML ``data`` (``src`` locates errors); used by the model-file reader."""
    if time.is_discrete:
        raise src.error("[cascade]: the observer of Grip, Saberi & Johansen is for continuous time; remove "
                        "time = \"discrete\"", key="time", text="time")
    for other in ("dynamics", "linear"):
        if other in data:
            raise src.error(f"a file with [cascade] describes its plant there (Σ1 and Σ2): remove [{other}]",
                            key=other, text=other)
    tab = data["cascade"]
    if not isinstance(tab, dict):
        raise src.error("'cascade' must be a table", key="cascade", text="cascade")
    unknown = sorted(set(tab) - _KEYS)
    if unknown:
        raise src.table_error(_T, unknown[0], f"unknown key in [cascade] (allowed: {', '.join(sorted(_KEYS))})",
                              unknown[0])
    form = tab.get("form", "cascade")
    if form not in FORMS:
        raise src.table_error(_T, "form", "[cascade].form must be \"cascade\" (1a) or \"feedback\" (2)", repr(form))
    feedback = form == "feedback"
    for need in ("states", "outputs", "f", "h", "g", "linear"):
        if need not in tab:
            what = "[cascade.linear] (Σ2)" if need == "linear" else f"'{need}'"
            raise src.table_error(_T, None, f"[cascade] needs {what}", need)
    lin = tab["linear"]
    if not isinstance(lin, dict):
        raise src.table_error(_T, "linear", "[cascade].linear must be a table (Σ2: A, B_z, C, ...)", "linear")
    unknown = sorted(set(lin) - _LIN_KEYS)
    if unknown:
        raise src.table_error(_TL, unknown[0], f"unknown key in [cascade.linear] (allowed: "
                              f"{', '.join(sorted(_LIN_KEYS))})", unknown[0])
    x_names = _names(src, _T, tab, "states")
    z_names = _names(src, _T, tab, "outputs")
    w_names = _names(src, _TL, lin, "states") if "states" in lin else []
    inputs = read_names(src, data, "inputs", required=False) or []
    y_names = read_names(src, data, "outputs", required=True) or []
    params = read_parameters(src, data)
    psyms = {k: sp.Symbol(k, real=True) for k in params}
    for k in ("A", "B_z", "C"):
        if k not in lin:
            raise src.table_error(_TL, None, f"[cascade.linear] needs '{k}'", k)
    A = read_constant_matrix(src, _TL, "A", lin["A"], params, psyms)
    n_w = A.shape[0]
    if A.shape != (n_w, n_w) or n_w == 0:
        raise src.table_error(_TL, "A", f"[cascade.linear].A has shape {A.shape}, expected a non-empty square matrix",
                              "A")
    if not w_names:
        w_names = [f"w{i + 1}" for i in range(n_w)]
    elif len(w_names) != n_w:
        raise src.table_error(_TL, "states", f"[cascade.linear].states has {len(w_names)} names but A is "
                              f"{n_w}×{n_w}", "states")
    p_z, p_y, m = len(z_names), len(y_names), len(inputs)
    Bz = read_constant_matrix(src, _TL, "B_z", lin["B_z"], params, psyms, rows=n_w, cols=p_z)
    C = read_constant_matrix(src, _TL, "C", lin["C"], params, psyms, rows=p_y, cols=n_w)
    Dz = (read_constant_matrix(src, _TL, "D_z", lin["D_z"], params, psyms, rows=p_y, cols=p_z) if "D_z" in lin
          else np.zeros((p_y, p_z)))
    Bu = (read_constant_matrix(src, _TL, "B_u", lin["B_u"], params, psyms, rows=n_w, cols=m) if "B_u" in lin
          else np.zeros((n_w, m)))
    Du = (read_constant_matrix(src, _TL, "D_u", lin["D_u"], params, psyms, rows=p_y, cols=m) if "D_u" in lin
          else np.zeros((p_y, m)))
    every = [*x_names, *w_names, *z_names, *inputs, *y_names, *params]
    dup = sorted({s for s in every if every.count(s) > 1})
    if dup:
        raise src.error("[cascade]: a name is used twice (Σ1 states, linear states, z, inputs, outputs, "
                        "parameters)", string=dup[0], text=dup[0])
    states = data.get("states")
    if states is not None:
        read_names(src, data, "states", required=False)
        if list(states) != [*x_names, *w_names]:
            raise src.error(f"'states' must be Σ1's states then Σ2's, {[*x_names, *w_names]} (the plant state "
                            "[x, w] of (1)), or be left out", key="states", text=repr(states)[:80])
    sx = {s: sp.Symbol(s, real=True) for s in x_names}
    sw = {s: sp.Symbol(s, real=True) for s in w_names}
    sz = {s: sp.Symbol(s, real=True) for s in z_names}
    su = {s: sp.Symbol(s, real=True) for s in inputs}
    base = {**sx, **su, **psyms, **(sw if feedback else {})}
    hint = "" if feedback else " (only form = \"feedback\" may use the linear states)"
    f = _exprs(src, "f", tab["f"], len(x_names), "Σ1 states", base, {**sw, **sz}, hint)
    h = _exprs(src, "h", tab["h"], p_z, "outputs z", base, {**sw, **sz}, hint)
    g = _exprs(src, "g", tab["g"], len(x_names), "Σ1 states", {**base, **sz}, sw, hint)
    try:
        sigma1 = NonlinearSubsystem.symbolic(states=x_names, outputs=z_names, f=f, h=h, g=g, inputs=inputs,
                                             linear_states=w_names if feedback else None, parameters=params,
                                             name="Σ1")
        sigma2 = LinearSubsystem(A, Bz, C, Dz, B_u=Bu if m else None, D_u=Du if m else None, states=w_names,
                                 outputs=y_names)
        check_interconnection(sigma1, sigma2)
    except ModelFileError:
        raise
    except NlobsError as exc:
        raise src.table_error(_T, None, f"[cascade]: {exc}") from None
    lyap = _lyapunov(src, tab, params, psyms) if "lyapunov" in tab else None
    method = tab.get("method")
    if method is not None and method not in ("lmi", "placement", "h2"):
        raise src.table_error(_T, "method", "[cascade].method must be \"lmi\" (LMI (14)), \"placement\" or \"h2\"",
                              repr(method))
    gamma = read_constant(src, _T, "gamma", tab["gamma"], params, psyms) if "gamma" in tab else None
    if gamma is not None and gamma <= 0:
        raise src.table_error(_T, "gamma", "[cascade].gamma must be positive (‖H‖∞ < γ)", repr(tab["gamma"]))
    plant = _plant(x_names, w_names, inputs, y_names, f, h, A, Bu, Bz, C, Du, Dz, params, time, name)
    return CascadeModel(name, str(form), sigma1, sigma2, plant, lyap, dict(params), src.path, method, gamma,
                        expressions=(tuple(f), tuple(h), tuple(g)))


def _names(src: Any, table: str, tab: Mapping[str, Any], key: str) -> list[str]:
    v = tab[key]
    if not isinstance(v, list) or not v or not all(isinstance(s, str) for s in v):
        raise src.table_error(table, key, f"[{table}].{key} must be a non-empty list of names", repr(v)[:80])
    for s in v:
        why = name_problem(s)
        if why is not None:
            raise src.table_error(table, key, f"[{table}].{key}: {s!r} is not a valid name ({why})", s)
    dup = sorted({s for s in v if v.count(s) > 1})
    if dup:
        raise src.table_error(table, key, f"[{table}].{key}: duplicate names", ", ".join(dup))
    return list(v)


def _exprs(src: Any, key: str, v: Any, want: int, what: str, symbols: Mapping[str, sp.Symbol],
           refused: Mapping[str, sp.Symbol], hint: str) -> list[sp.Expr]:
    if not isinstance(v, list):
        raise src.table_error(_T, key, f"[cascade].{key} must be a list of expression strings", repr(v)[:80])
    if len(v) != want:
        raise src.table_error(_T, key, f"[cascade].{key} has {len(v)} entries but there are {want} {what}", key)
    out = []
    for e in v:
        if isinstance(e, bool) or not isinstance(e, (str, int, float)):
            raise src.table_error(_T, key, f"[cascade].{key}: entries must be expression strings", repr(e))
        text = str(e)
        try:
            out.append(parse_expression(text, {**symbols, **refused}))
        except ExpressionError as exc:
            raise src.table_error(_T, key, f"[cascade].{key}: {exc.reason}", exc.offending) from None
        stray = sorted(s.name for s in out[-1].free_symbols if s.name in refused and s.name not in symbols)
        if stray:
            z_hint = " (z may appear only in g)" if key != "g" else ""
            raise src.table_error(_T, key, f"[cascade].{key}: {text!r} uses {', '.join(stray)}{z_hint}{hint}", text)
    return out


def _lyapunov(src: Any, tab: Mapping[str, Any], params: Mapping[str, float],
              psyms: Mapping[str, sp.Symbol]) -> LyapunovData:
    ly = tab["lyapunov"]
    if not isinstance(ly, dict):
        raise src.table_error(_T, "lyapunov", "[cascade].lyapunov must be a table (alpha3, alpha4, L1, L2)",
                              "lyapunov")
    unknown = sorted(set(ly) - _LYAP_KEYS)
    if unknown:
        raise src.table_error(_TY, unknown[0], f"unknown key in [cascade.lyapunov] (allowed: "
                              f"{', '.join(sorted(_LYAP_KEYS))})", unknown[0])
    vals = {}
    for k in ("alpha3", "alpha4", "L1", "L2"):
        if k not in ly:
            raise src.table_error(_TY, None, f"[cascade.lyapunov] needs '{k}' (Assumptions 1–3 of Grip, Saberi & "
                                  "Johansen)", k)
        val = read_constant(src, _TY, k, ly[k], params, psyms)
        if val <= 0:
            raise src.table_error(_TY, k, f"[cascade.lyapunov].{k} must be positive", repr(ly[k]))
        vals[k] = val
    return LyapunovData(**vals)


def _plant(x: Sequence[str], w: Sequence[str], u: Sequence[str], y: Sequence[str], f: Sequence[sp.Expr],
           h: Sequence[sp.Expr], A: Array, Bu: Array, Bz: Array, C: Array, Du: Array, Dz: Array,
           params: Mapping[str, float], time: TimeBase, name: str) -> SymbolicModel:
    """The plant (1) or (2)+(1b) with state ``[x, w]`` as one symbolic model."""
    W = sp.Matrix([sp.Symbol(s, real=True) for s in w])
    U = sp.Matrix([sp.Symbol(s, real=True) for s in u]) if u else sp.zeros(0, 1)
    known = {str(v): v for e in h for v in e.free_symbols}
    Z = as_sympy_matrix("h", list(h), known)
    if Z.shape != (len(h), 1):
        Z = Z.T

    def mat(M: Array) -> sp.Matrix:
        return sp.Matrix(M.shape[0], M.shape[1], [sp.Float(float(v)) if v != int(v) else sp.Integer(int(v))
                                                  for v in np.asarray(M).ravel()])

    dw = mat(A) * W + mat(Bz) * Z + (mat(Bu) * U if u else sp.zeros(len(w), 1))
    yy = mat(C) * W + mat(Dz) * Z + (mat(Du) * U if u else sp.zeros(len(y), 1))
    return SymbolicModel.general([*x, *w], list(u), list(y), [*f, *dw], list(yy), parameters=dict(params),
                                 time=time, name=name)

