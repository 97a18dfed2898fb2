"""What every reader of a model file shares: the bounded read, TOML with its checks, error locations, the
top-level keys, and the common entries (names, time base, parameters, constant expressions).

:mod:`nlobs.systems.modelfile` (the model, its unknown inputs and its scenario) and
:mod:`nlobs.systems.cascade_file` (the ``[cascade]`` table) read a file through these functions; the format
and its limits are described in :mod:`nlobs.systems.modelfile`. Every error is a
:class:`~nlobs.errors.ModelFileError` naming the file, the line and the offending text.
"""

from __future__ import annotations

import os
import re
import tomllib
from collections import Counter
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import math

import numpy as np

from nlobs._schema import STRING, Record, array
from nlobs._io import read_regular_text
from nlobs._validate import escape_unsafe, name_problem, unsafe_character
from nlobs.errors import ModelFileError
from nlobs.systems.expressions import ExpressionError, parse_expression
from nlobs.systems.timebase import CONTINUOUS, Discrete, TimeBase

if TYPE_CHECKING:
    import sympy as sp

__all__ = ["COMMAND_TABLES", "MAX_FILE_BYTES", "MAX_NAMES", "MAX_STRINGS", "SCENARIO_TABLES", "TOP_KEYS", "UI_TABLES",
           "Source", "check_header", "read_constant", "read_constant_matrix", "read_names", "read_parameters",
           "read_string", "read_text", "read_time", "read_toml", "resolve_model", "shipped_models"]

#: The tables of a discrete-time model with unknown inputs (Khajenejad & Yong (8)).
UI_TABLES = ("unknown_inputs", "noise", "initial", "function_class")
#: The tables of a scenario (sensors, known inputs, process noise, units, run defaults, a feedback law, state bounds).
SCENARIO_TABLES = ("units", "sensors", "input_signals", "process_noise", "simulation", "controller", "constraints")
#: Tables of a command besides the model (``[cascade]``: the interconnection of ``nlobs design cascade``, from
#: which the reader also builds the plant [x, w]).
COMMAND_TABLES = ("cascade",)
#: Every key a model file may have at its top level.
TOP_KEYS = {"name", "description", "time", "dt", "states", "inputs", "outputs", "parameters", "dynamics", "linear",
            *UI_TABLES, *SCENARIO_TABLES, *COMMAND_TABLES}
#: Largest model file read, in bytes (1 MiB).
MAX_FILE_BYTES = 1 << 20
#: Most names of each kind (states, inputs, outputs, parameters) in a model file.
MAX_NAMES = 1000
#: Most strings (names, expressions, ...) in a model file: each expression costs a parse.
MAX_STRINGS = 20_000
_MAX_INT_BITS = 996  # TOML integers below 2**996 (about 10**300): every one is a finite double


class Source:
    """The raw text of a model file, to map keys and strings back to line numbers.

    Every reader keeps one next to the parsed TOML, and builds its
    :class:`~nlobs.errors.ModelFileError` through :meth:`error` or :meth:`table_error`, so that an error
    names the file and, when it can be found, the line of the offending key or string.

    Parameters
    ----------
    path : str
        The file's name as shown in errors (the path read, or the ``source`` given to a parser of text).
    text : str
        The file's text.

    Attributes
    ----------
    path : str
        As given.
    lines : list of str
        The lines of ``text`` (line ``i`` is ``lines[i - 1]``).
    """

    def __init__(self, path: str, text: str) -> None:
        self.path = path
        self.lines = text.splitlines()

    def line_of_string(self, s: str) -> int | None:
        """The first line holding ``s`` quoted, else the first holding it as a whole bare name (``None``: none)."""
        for quoted in (f'"{s}"', f"'{s}'"):
            for i, line in enumerate(self.lines, start=1):
                if quoted in line:
                    return i
        bare = re.compile(rf"(?<![A-Za-z0-9_]){re.escape(s)}(?![A-Za-z0-9_])")  # a whole name, not part of one
        for i, line in enumerate(self.lines, start=1):
            if bare.search(line):
                return i
        return None

    def line_of_key(self, key: str) -> int | None:
        """The line of ``[key]`` or ``key = …``, also written ``"key" =``, ``table.key =`` or inside an inline table."""
        k = re.escape(key)
        pats = (re.compile(rf"^\s*(\[\s*{k}\s*\]|{k}\s*=|([\"']){k}\2\s*=|[\w.\"'-]+\.\s*{k}\s*=)"),
                re.compile(rf"[{{,]\s*([\"']?){k}\1\s*="))
        for pat in pats:
            for i, line in enumerate(self.lines, start=1):
                if pat.search(line):
                    return i
        return None

    def line_of_pattern(self, pattern: str) -> int | None:
        """The first line matching the regular expression ``pattern``."""
        pat = re.compile(pattern)
        return next((i for i, line in enumerate(self.lines, start=1) if pat.search(line)), None)

    def deepest_line(self) -> int | None:
        """The line with the most opening brackets (where a too deeply nested value starts)."""
        counts = [line.count("[") + line.count("{") for line in self.lines]
        return counts.index(max(counts)) + 1 if counts and max(counts) else None

    def line_in_table(self, table: str, key: str | None) -> int | None:
        """The line of ``key = ...`` inside ``[table]`` (the header's line when ``key`` is ``None`` or absent)."""
        head = re.compile(rf"^\s*\[\s*{re.escape(table)}\s*\]")
        start = next((i for i, line in enumerate(self.lines, start=1) if head.search(line)), None)
        if start is None or key is None:
            return start
        pat = re.compile(rf"^\s*{re.escape(key)}\s*=")
        for i in range(start, len(self.lines)):
            line = self.lines[i]
            if re.match(r"^\s*\[", line):
                break
            if pat.search(line):
                return i + 1
        return start

    def table_error(self, table: str, key: str | None, reason: str, text: str = "") -> ModelFileError:
        """An error located at ``key`` inside ``[table]``."""
        return ModelFileError(self.path, self.line_in_table(table, key), text, reason)

    def error(self, reason: str, *, key: str | None = None, text: str = "", string: str | None = None) -> ModelFileError:
        """An error on the line of ``string`` (see :meth:`line_of_string`), else of ``key`` (:meth:`line_of_key`)."""
        line = None
        if string is not None:
            line = self.line_of_string(string)
        if line is None and key is not None:
            line = self.line_of_key(key)
        return ModelFileError(self.path, line, text, reason)


#: One entry of ``nlobs models``.
SHIPPED_MODEL_JSON = Record("ShippedModel", {"name": STRING.about("the name nlobs commands accept"),
                                             "path": STRING.about("the model file")})
#: ``nlobs models``: a list (no ``schema_version``).
MODELS_JSON = array(SHIPPED_MODEL_JSON, "the model files shipped with nlobs, by name")


def shipped_models() -> dict[str, Path]:
    """The model files shipped with nlobs, by name (the file stem), e.g. ``"pendulum"``.

    Examples
    --------
    >>> models = shipped_models()
    >>> "pendulum" in models, models["pendulum"].name
    (True, 'pendulum.toml')
    >>> all(p.suffix == ".toml" and p.is_file() for p in models.values())
    True
    >>> from nlobs.systems.modelfile import load_model
    >>> load_model(models["pendulum"]).states  # the same model as load_model("pendulum")
    ('theta', 'omega')
    """
    from importlib import resources

    root = resources.files("nlobs") / "data" / "models"
    return {Path(str(p)).stem: Path(str(p)) for p in root.iterdir() if str(p).endswith(".toml")}


def resolve_model(model: str | os.PathLike[str]) -> Path:
    """The file behind a model argument: a path to a ``.toml`` file, or the name of a shipped model.

    The one lookup of shipped names (the CLI and :func:`load_model` use it). A ``Path``, or a string with
    a folder separator or the ``.toml`` suffix, is a path (the reader says why it cannot be read); a bare
    name is looked up among the shipped models, and one that is both a shipped model and a file in the
    working directory is refused as ambiguous instead of silently taking the local file.

    Parameters
    ----------
    model : str or os.PathLike
        A path, or the name of a shipped model (a key of :func:`shipped_models`, e.g. ``"pendulum"``).

    Returns
    -------
    Path
        The file to read; not checked beyond its existence (a path object is returned as it is).

    Raises
    ------
    ModelFileError
        No such file and no shipped model of that name (the message lists the shipped names), or the
        name is ambiguous.

    Examples
    --------
    A bare name is a shipped model, a ``Path`` is returned as it is, and a misspelt name is refused with
    the names that exist:

    >>> from pathlib import Path
    >>> from nlobs.errors import ModelFileError
    >>> found = resolve_model("pendulum")
    >>> found.name, found == shipped_models()["pendulum"], found.is_file()
    ('pendulum.toml', True, True)
    >>> resolve_model(Path("models") / "plant.toml").as_posix()
    'models/plant.toml'
    >>> try:
    ...     resolve_model("pendulm")
    ... except ModelFileError as exc:
    ...     print(type(exc).__name__, "-", exc)
    ModelFileError - pendulm: no such file (shipped models: ball-and-beam, cartpole, ..., pendulum, ...)
    """
    if not isinstance(model, str):  # a path object is a path: the reader says why it cannot be read
        return Path(model)
    text = model
    path = Path(text)
    bare = os.sep not in text and "/" not in text and not text.endswith(".toml")
    shipped = shipped_models()
    if not bare:  # a path
        if os.path.lexists(path):
            return path  # the reader says why it cannot be read, if it cannot
        raise ModelFileError(text, None, "", f"no such file (cannot read file; shipped models: "
                             f"{', '.join(sorted(shipped))})")
    if os.path.lexists(path):
        if text in shipped:
            raise ModelFileError(text, None, "", f"ambiguous: both a file in the working directory and the shipped "
                                 f"model {text!r}; write ./{text} for the file or rename it")
        return path
    if text in shipped:
        return shipped[text]
    raise ModelFileError(text, None, "", f"no such file (shipped models: {', '.join(sorted(shipped))})")


def read_toml(src: Source, text: str) -> dict[str, Any]:
    """Parse the text of a model file as TOML, then check its values.

    ``tomllib.loads`` with every failure a :class:`~nlobs.errors.ModelFileError` (on the line ``tomllib``
    names, when it does), then the checks of the whole document: at most :data:`MAX_NAMES` names of each
    kind, at most :data:`MAX_STRINGS` strings, no integer of 2**996 or more, and no control character or
    bidirectional override in any key or string.

    Parameters
    ----------
    src : Source
        The same text, to locate errors.
    text : str
        The file's text.

    Returns
    -------
    dict
        The TOML document.

    Raises
    ------
    ModelFileError
        Invalid TOML (a syntax error, an integer literal beyond Python's digit limit, nesting too deep), or a
        value the checks refuse.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"at line (\d+)", msg)
        line = int(m.group(1)) if m else None
        offending = src.lines[line - 1].strip() if line and line <= len(src.lines) else ""
        reason = re.sub(r" \(at .*\)$", "", msg)
        raise ModelFileError(src.path, line, offending, f"invalid TOML ({reason})") from None
    except ValueError as exc:  # an integer literal beyond Python's digit limit for int()
        line = src.line_of_pattern(r"[0-9_]{4000,}")
        raise ModelFileError(src.path, line, "", f"invalid TOML ({str(exc).split(':')[0]})") from None
    except (RecursionError, MemoryError):
        raise ModelFileError(src.path, src.deepest_line(), "", "invalid TOML (arrays or tables nested too deeply)") from None
    _check_values(src, data)
    return data


def _check_values(src: Source, data: Mapping[str, Any]) -> None:
    """Refuse too many names or strings, huge integers, and control characters or bidirectional overrides anywhere.

    The walk is iterative: a file nests at most as deep as ``tomllib`` could
    read, but nothing here recurses on it.
    """
    for key in ("states", "inputs", "outputs", "parameters"):
        v = data.get(key)
        if isinstance(v, (list, dict)) and len(v) > MAX_NAMES:
            raise src.error(f"'{key}': {len(v)} names, more than the limit of {MAX_NAMES}", key=key, text=key)
    stack: list[tuple[tuple[str, ...], Any]] = [((), data)]
    strings = 0
    while stack:
        keys, v = stack.pop()
        if isinstance(v, str):
            strings += 1
            if strings > MAX_STRINGS:
                raise _at(src, keys, f"more than {MAX_STRINGS} strings (names and expressions) in the file",
                          ".".join(keys))
            _check_string(src, keys, v)
        elif isinstance(v, bool):
            continue
        elif isinstance(v, int):
            if abs(v).bit_length() > _MAX_INT_BITS:
                raise _at(src, keys, "integer too large (at most about 10**300)", ".".join(keys))
        elif isinstance(v, dict):
            for kk, vv in v.items():
                _check_string(src, (*keys, kk), kk)
                stack.append(((*keys, kk), vv))
        elif isinstance(v, list):
            stack.extend((keys, vv) for vv in v)


def _check_string(src: Source, keys: tuple[str, ...], s: str) -> None:
    bad = unsafe_character(s)
    if bad is not None:
        raise _at(src, keys, f"control character or bidirectional override U+{ord(bad):04X} in a string", s[:80])


def _at(src: Source, keys: tuple[str, ...], reason: str, text: str) -> ModelFileError:
    """An error on the line of the innermost of ``keys`` that can be found in the text."""
    line = next((ln for k in reversed(keys) if (ln := src.line_of_key(k)) is not None), None)
    return ModelFileError(src.path, line, text, reason)


def read_text(p: Path) -> str:
    """The text of a regular file of at most :data:`MAX_FILE_BYTES`, read without ever blocking.

    ``os.stat`` first (a FIFO is never opened, a device never read), then the
    file is opened with ``O_NONBLOCK`` and checked again with ``fstat`` (it may
    have been replaced in between), and at most one byte more than the limit is read
    (:func:`nlobs._io.read_regular_text`).

    Parameters
    ----------
    p : Path
        The model file.

    Returns
    -------
    str
        Its UTF-8 text.

    Raises
    ------
    ModelFileError
        Not a regular file (a directory, a FIFO, a device...), larger than :data:`MAX_FILE_BYTES`, not
        UTF-8 text, or unreadable.
    """
    return read_regular_text(p, MAX_FILE_BYTES, lambda reason: ModelFileError(str(p), None, "", reason))


def read_string(src: Source, data: Mapping[str, Any], key: str, *, default: str) -> str:
    """The string ``key`` of the top level (``default`` when absent).

    Parameters
    ----------
    src : Source
        The file's text, to locate errors.
    data : mapping
        The TOML document.
    key : str
        The top-level key (``"name"``, ``"description"``).
    default : str
        Returned when ``key`` is absent.

    Returns
    -------
    str

    Raises
    ------
    ModelFileError
        The value is not a string.
    """
    v = data.get(key, default)
    if not isinstance(v, str):
        raise src.error(f"'{key}' must be a string", key=key, text=repr(v))
    return v


def read_names(src: Source, data: Mapping[str, Any], key: str, *, required: bool) -> list[str] | None:
    """The list of names ``key`` of the top level (valid, distinct; ``None`` when absent and not required).

    Parameters
    ----------
    src : Source
        The file's text, to locate errors.
    data : mapping
        The TOML document.
    key : str
        The top-level key (``"states"``, ``"inputs"``, ``"outputs"``).
    required : bool
        Whether a missing ``key`` is an error (else ``None`` is returned).

    Returns
    -------
    list of str or None
        The names, in the file's order.

    Raises
    ------
    ModelFileError
        ``key`` missing though required, not a list of strings, a name that is not valid
        (:func:`nlobs._validate.name_problem`), or a name given twice.
    """
    if key not in data:
        if required:
            raise src.error(f"missing key '{key}' (a list of names)", text=key)
        return None
    v = data[key]
    if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
        raise src.error(f"'{key}' must be a list of strings", key=key, text=repr(v)[:80])
    for s in v:
        why = name_problem(s)
        if why is not None:
            raise src.error(f"'{key}': {s!r} is not a valid name ({why})", key=key, string=s, text=s)
    dup = sorted(s for s, c in Counter(v).items() if c > 1)
    if dup:
        raise src.error(f"'{key}': duplicate names", key=key, text=", ".join(dup))
    return v


def read_time(src: Source, data: Mapping[str, Any]) -> TimeBase:
    """The time base: ``time = \"continuous\"`` (the default), or ``\"discrete\"`` with its ``dt``.

    Parameters
    ----------
    src : Source
        The file's text, to locate errors.
    data : mapping
        The TOML document (its keys ``time`` and ``dt``).

    Returns
    -------
    TimeBase
        :data:`~nlobs.systems.timebase.CONTINUOUS`, or :class:`~nlobs.systems.timebase.Discrete` with the
        sampling period ``dt`` in seconds.

    Raises
    ------
    ModelFileError
        ``time`` is neither ``"continuous"`` nor ``"discrete"``, ``dt`` is given in continuous time or missing
        in discrete time, or ``dt`` is not a positive finite number.
    """
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


def read_parameters(src: Source, data: Mapping[str, Any]) -> dict[str, float]:
    """The table ``parameters``: named finite numbers.

    Parameters
    ----------
    src : Source
        The file's text, to locate errors.
    data : mapping
        The TOML document.

    Returns
    -------
    dict of str to float
        Each parameter's value, in the file's order (empty when the table is absent).

    Raises
    ------
    ModelFileError
        ``parameters`` is not a table, a name is not valid, or a value is not a finite number (booleans
        included).
    """
    params = data.get("parameters", {})
    if not isinstance(params, dict):
        raise src.error("'parameters' must be a table of numbers", key="parameters", text=repr(params))
    out: dict[str, float] = {}
    for k, v in params.items():
        why = name_problem(k)
        if why is not None:
            raise src.error(f"parameter name is not a valid name ({why})", key="parameters", text=k)
        try:  # an integer beyond a double (or beyond int64, which NumPy refuses) is not a finite number
            f = float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan
        except OverflowError:
            f = math.inf
        if not math.isfinite(f):
            raise src.error(f"parameter '{k}' must be a finite number", key="parameters", string=k,
                            text=repr(v)[:60])
        out[k] = f
    return out


def read_constant(src: Source, table: str, key: str, e: Any, params: Mapping[str, float],
                  psyms: Mapping[str, sp.Symbol]) -> float:
    """The number ``[table].key``: a number or a constant expression of the parameters.

    Parameters
    ----------
    src : Source
        The file's text, to locate errors (on the line of ``key`` inside ``[table]``).
    table : str
        The table the entry is in (``"unknown_inputs"``, ``"cascade.linear"``...), named in errors.
    key : str
        The entry's key, named in errors.
    e : int, float or str
        The value read: a number, or an expression (:func:`~nlobs.systems.expressions.parse_expression`)
        of the parameters only.
    params : mapping of str to float
        The parameters' values (:func:`read_parameters`).
    psyms : mapping of str to sympy.Symbol
        The parameters' symbols, by name: the only names an expression may use.

    Returns
    -------
    float
        The value, finite.

    Raises
    ------
    ModelFileError
        ``e`` is neither a number nor a string (booleans included), the expression cannot be parsed or is
        not a constant, or the value is not finite.
    """
    if isinstance(e, bool) or not isinstance(e, (int, float, str)):
        raise src.table_error(table, key, f"[{table}].{key}: entries must be numbers or constant expressions", repr(e))
    if isinstance(e, str):
        try:
            ex = parse_expression(e, psyms)
        except ExpressionError as exc:
            raise src.table_error(table, key, f"[{table}].{key}: {exc.reason}", exc.offending) from None
        val = ex.subs({psyms[k]: v for k, v in params.items()})
        try:
            out = float(val)
        except (TypeError, ValueError):
            raise src.table_error(table, key, f"[{table}].{key}: not a constant", e) from None
    else:
        out = float(e)
    if not np.isfinite(out):
        raise src.table_error(table, key, f"[{table}].{key} has non-finite entries", repr(e))
    return out


def read_constant_matrix(src: Source, table: str, key: str, v: Any, params: Mapping[str, float],
                         psyms: Mapping[str, sp.Symbol], *, rows: int | None = None,
                         cols: int | None = None) -> np.ndarray:
    """The matrix ``[table].key`` (a list of rows of constants, see :func:`read_constant`), of the shape asked.

    Parameters
    ----------
    src : Source
        The file's text, to locate errors (on the line of ``key`` inside ``[table]``).
    table : str
        The table the entry is in, named in errors.
    key : str
        The entry's key, named in errors.
    v : list of lists
        The value read: rows of numbers or constant expressions of the parameters (``[]`` is a 0 x 0 matrix).
    params : mapping of str to float
        The parameters' values (:func:`read_parameters`).
    psyms : mapping of str to sympy.Symbol
        The parameters' symbols, by name.
    rows, cols : int or None
        The number of rows and of columns required (``None``: any).

    Returns
    -------
    numpy.ndarray
        The matrix, of floats, shape ``(rows, cols)``.

    Raises
    ------
    ModelFileError
        ``v`` is not a list of rows, the rows differ in length, an entry is refused by :func:`read_constant`,
        or the shape is not the one asked.
    """
    if not isinstance(v, list) or not all(isinstance(r, list) for r in v):
        raise src.table_error(table, key, f"[{table}].{key} must be a list of rows", repr(v)[:80])
    widths = {len(r) for r in v}
    if len(widths) > 1:
        raise src.table_error(table, key, f"[{table}].{key}: rows have different lengths {sorted(widths)}", key)
    arr = np.array([[read_constant(src, table, key, e, params, psyms) for e in r] for r in v], dtype=float)
    arr = arr.reshape(len(v), widths.pop() if widths else 0)
    if (rows is not None and arr.shape[0] != rows) or (cols is not None and arr.shape[1] != cols):
        want = (rows if rows is not None else "any", cols if cols is not None else "any")
        raise src.table_error(table, key, f"[{table}].{key} has shape {arr.shape}, expected {want}", key)
    return arr


def check_header(src: Source, data: Mapping[str, Any]) -> tuple[str, TimeBase]:
    """The checks of a model file's top level: no unknown key, a one-line ``name`` (default: the file's stem),
    the time base, and the unknown-input tables only in discrete time.

    Parameters
    ----------
    src : Source
        The file's text, to locate errors; its path gives the default name.
    data : mapping
        The TOML document.

    Returns
    -------
    tuple of str and TimeBase
        The model's name and time base (:func:`read_time`).

    Raises
    ------
    ModelFileError
        A top-level key not in :data:`TOP_KEYS`, a ``name`` that is not a one-line string free of control
        characters and bidirectional overrides, a time base :func:`read_time` refuses, or a table of
        :data:`UI_TABLES` in a continuous-time file.
    """
    unknown = sorted(set(data) - TOP_KEYS)
    if unknown:
        raise src.error(f"unknown key (allowed: {', '.join(sorted(TOP_KEYS))})", key=unknown[0], text=unknown[0])
    name = read_string(src, data, "name", default=escape_unsafe(Path(src.path).stem, one_line=True))
    if unsafe_character(name, one_line=True):
        raise src.error("'name' must be one line without control characters or bidirectional overrides",
                        key="name", text=name)
    time = read_time(src, data)
    ui = [k for k in UI_TABLES if k in data]
    if ui and not isinstance(time, Discrete):
        raise src.error(f"the table [{ui[0]}] describes a discrete-time model with unknown inputs: it needs "
                        "time = \"discrete\"", key=ui[0], text=ui[0])
    return name, time
