"""Argument validation shared by every layer (shapes, finiteness, symmetry).

Private helpers: public functions call them on entry so that bad input fails
early with a typed error naming the argument.
"""

from __future__ import annotations

import keyword
import re
import unicodedata
from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from nlobs.errors import DimensionError, InvalidArgumentError, ModelError, NonFiniteError, NotSymmetricError


def _nobody_writes(a: np.ndarray) -> bool:
    """Whether neither ``a`` nor any array it is a view of can be written through."""
    b: object = a
    while isinstance(b, np.ndarray):
        if b.flags.writeable:
            return False
        b = b.base
    return True


def readonly(a: ArrayLike, dtype: DTypeLike | None = np.float64, *, owned: bool = False) -> NDArray[Any]:
    """``a`` as an array that cannot be written to (the one helper for the fields of frozen objects).

    Parameters
    ----------
    a : array_like
        The data.
    dtype : dtype or None
        The dtype of the result (default float64); ``None`` keeps ``a``'s (bool masks, complex
        eigenvalues, integer counts).
    owned : bool
        ``a`` is a fresh array the caller will not use for writing again: it is frozen in place
        (no copy) when it owns its memory.

    Returns
    -------
    ndarray
        ``a`` itself when it is a plain ndarray of that dtype that nobody can write to (it and every
        array it is a view of are read-only, e.g. a broadcast view of a read-only array: no copy);
        else a read-only copy.
    """
    if isinstance(a, np.ndarray) and type(a) is np.ndarray and (dtype is None or a.dtype == np.dtype(dtype)):
        if owned and a.flags.owndata:
            a.setflags(write=False)
            return a
        if _nobody_writes(a):
            return a
    out = np.array(a, dtype=dtype)
    out.setflags(write=False)
    return out


def _refuse_complex(name: str, raw: NDArray[Any]) -> NDArray[Any]:
    """``raw`` itself, or its real part when ``raw`` is complex with every imaginary part zero.

    A complex entry with a non-zero (or NaN) imaginary part raises
    :class:`~nlobs.errors.InvalidArgumentError` naming the argument and the entry: converting
    it to float would keep the real part only (NumPy's ``ComplexWarning``), a silently different
    number.
    """
    if raw.dtype.kind != "c":
        return raw
    nonzero = raw.imag != 0  # a NaN imaginary part counts as non-zero
    if np.any(nonzero):
        bad = tuple(int(i) for i in np.argwhere(nonzero)[0]) if raw.ndim else ()
        where = f"entry {bad}" if raw.ndim else "the value"
        raise InvalidArgumentError(f"{name}: {where} is complex ({complex(raw[bad])}); a real number is required "
                                   "(nlobs never drops an imaginary part)")
    return raw.real


def real_scalar(name: str, value: Any) -> Any:
    """``value`` unchanged, or the real part of a complex scalar whose imaginary part is zero.

    A complex scalar (Python ``complex``, a NumPy complex scalar or 0-d array) with a non-zero
    imaginary part raises :class:`~nlobs.errors.InvalidArgumentError` naming ``name``
    (``float(np.complex128(1 + 2j))`` would silently give ``1.0``).
    """
    if isinstance(value, (complex, np.complexfloating, np.ndarray)) and np.iscomplexobj(value):
        return _refuse_complex(name, np.asarray(value))[()]
    return value


def as_real_array(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """Return ``value`` as a float64 array (a copy), NaN and ±inf allowed (e.g. missing samples).

    Complex input with a non-zero imaginary part is refused (:class:`~nlobs.errors.InvalidArgumentError`),
    never cut to its real part; unreadable input is :class:`~nlobs.errors.DimensionError`.
    """
    try:
        raw = value if isinstance(value, np.ndarray) else np.asarray(value)
        return np.array(_refuse_complex(name, raw), dtype=float)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InvalidArgumentError):
            raise
        raise DimensionError(f"{name}: cannot be read as a numeric array ({exc})") from None


def as_finite_array(name: str, value: ArrayLike, ndim: int | None = None) -> NDArray[np.float64]:
    """Return ``value`` as a float64 array, checking finiteness and (optionally) ``ndim``.

    Complex input with a non-zero imaginary part is refused (:class:`~nlobs.errors.InvalidArgumentError`),
    never cut to its real part (:func:`as_real_array`).
    """
    arr = as_real_array(name, value)
    if ndim is not None and arr.ndim != ndim:
        raise DimensionError(f"{name}: expected a {ndim}-d array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
        raise NonFiniteError(f"{name}: entry {bad} is {arr[bad]!r}; all entries must be finite")
    return arr


def as_matrix(name: str, value: ArrayLike, shape: tuple[int | None, int | None] | None = None) -> NDArray[np.float64]:
    """Return ``value`` as a finite 2-d float array of the given shape.

    ``None`` in ``shape`` leaves that dimension free. A 0-d or 1-d input is
    *not* silently reshaped: row/column ambiguity is an error.
    """
    arr = as_finite_array(name, value)
    if arr.ndim != 2:
        raise DimensionError(f"{name}: expected a 2-d matrix, got shape {arr.shape}")
    if shape is not None:
        for axis, want in enumerate(shape):
            if want is not None and arr.shape[axis] != want:
                raise DimensionError(f"{name}: expected shape {_fmt_shape(shape)}, got {arr.shape}")
    return arr


def as_square(name: str, value: ArrayLike, n: int | None = None) -> NDArray[np.float64]:
    """Return a finite square matrix (of size ``n`` when given)."""
    arr = as_matrix(name, value)
    if arr.shape[0] != arr.shape[1]:
        raise DimensionError(f"{name}: expected a square matrix, got shape {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise DimensionError(f"{name}: expected shape ({n}, {n}), got {arr.shape}")
    return arr


def as_symmetric(name: str, value: ArrayLike, n: int | None = None, rtol: float = 1e-9) -> NDArray[np.float64]:
    """Return a finite symmetric matrix; raise if it is not symmetric to ``rtol``.

    The returned matrix is exactly symmetrised, ``(M + M.T) / 2``.
    """
    arr = as_square(name, value, n)
    asym = float(np.max(np.abs(arr - arr.T), initial=0.0))
    scale = max(1.0, float(np.max(np.abs(arr), initial=0.0)))
    if asym > rtol * scale:
        raise NotSymmetricError(f"{name}: not symmetric (max |M - M^T| = {asym:.3g})")
    return 0.5 * (arr + arr.T)


def as_covariance(name: str, value: ArrayLike, n: int | None = None, *, definite: bool = False,
                  rtol: float = 1e-9) -> NDArray[np.float64]:
    """Return a finite, exactly symmetrised covariance matrix: symmetric and positive semidefinite
    (positive definite with ``definite=True``).

    Rounding is allowed for: an eigenvalue down to ``-rtol · max|M|`` counts as zero.

    Raises
    ------
    DimensionError, NonFiniteError, NotSymmetricError
        Not square (of size ``n``), not finite, not symmetric to ``rtol``.
    InvalidArgumentError
        Not positive semidefinite (definite), naming the smallest eigenvalue.
    """
    arr = as_symmetric(name, value, n, rtol=rtol)
    if arr.size == 0:
        return arr
    low = float(np.linalg.eigvalsh(arr)[0])
    scale = float(np.max(np.abs(arr)))
    what = "positive definite" if definite else "positive semidefinite"
    if (low <= 0.0 if definite else low < -rtol * scale):
        raise InvalidArgumentError(f"{name}: not symmetric {what} (smallest eigenvalue {low:.6g})")
    return arr


def as_vector(name: str, value: ArrayLike, n: int | None = None) -> NDArray[np.float64]:
    """Return a finite 1-d float array (of length ``n`` when given)."""
    arr = as_finite_array(name, value)
    if arr.ndim != 1:
        raise DimensionError(f"{name}: expected a 1-d vector, got shape {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise DimensionError(f"{name}: expected length {n}, got {arr.shape[0]}")
    return arr


def as_batch(name: str, value: ArrayLike, n: int) -> NDArray[np.float64]:
    """Return a finite array of shape ``(..., n)`` (a batch of n-vectors)."""
    arr = as_finite_array(name, value)
    if arr.ndim == 0 or arr.shape[-1] != n:
        raise DimensionError(f"{name}: expected shape (..., {n}), got {arr.shape}")
    return arr


def positive(name: str, value: float, *, allow_zero: bool = False) -> float:
    """Return ``value`` as a float, checking it is finite and positive (and real: see :func:`real_scalar`)."""
    try:
        v = float(real_scalar(name, value))
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InvalidArgumentError):
            raise
        raise DimensionError(f"{name}: expected a number, got {value!r}") from None
    if not np.isfinite(v):
        raise NonFiniteError(f"{name}: must be finite, got {v!r}")
    if v < 0 or (v == 0 and not allow_zero):
        raise InvalidArgumentError(f"{name}: must be {'non-negative' if allow_zero else 'positive'}, got {v!r}")
    return v


def one_of(name: str, value: Any, allowed: Sequence[str], default: str | None = None) -> str:
    """``value`` as one of the words ``allowed`` (stripped, lower case); ``default`` when ``value`` is ``None``.

    Raises :class:`~nlobs.errors.InvalidArgumentError` naming ``name`` and every allowed word.
    """
    if value is None and default is not None:
        return default
    v = str(value).strip().lower()
    if v not in allowed:
        raise InvalidArgumentError(f"{name}: expected one of {', '.join(allowed)}, got {value!r}")
    return v


def in_range(name: str, value: float, lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = True) -> float:
    """Return ``value`` as a finite float in the interval from ``lo`` to ``hi``.

    ``lo_open``/``hi_open`` make the bounds exclusive. Raises
    :class:`~nlobs.errors.NonFiniteError` or :class:`~nlobs.errors.InvalidArgumentError` (also for a
    complex value, see :func:`real_scalar`).
    """
    try:
        v = float(real_scalar(name, value))
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InvalidArgumentError):
            raise
        raise InvalidArgumentError(f"{name}: expected a number, got {value!r}") from None
    if not np.isfinite(v):
        raise NonFiniteError(f"{name}: must be finite, got {v!r}")
    if (v < lo or (lo_open and v == lo)) or (v > hi or (hi_open and v == hi)):
        interval = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
        raise InvalidArgumentError(f"{name}: must lie in {interval}, got {v!r}")
    return v


def as_count(name: str, value: Any, *, minimum: int = 0) -> int:
    """Return ``value`` as an ``int`` of at least ``minimum`` (an integer type, not ``bool``, not a float).

    Raises :class:`~nlobs.errors.InvalidArgumentError` naming ``name`` otherwise (a negative or
    fractional iteration count would silently change what is computed).
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise InvalidArgumentError(f"{name}: expected an integer ≥ {minimum}, got {value!r}")
    return int(value)


#: Characters that must not reach a terminal from a file: C0 controls but tab and
#: newline (``ESC`` among them), ``DEL``, C1 controls, and the Unicode bidirectional
#: marks, embeddings, overrides and isolates (U+061C, U+200E/F, U+202A–U+202E,
#: U+2066–U+2069) and the line/paragraph separators U+2028/U+2029.
_UNSAFE_TEXT = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028\u2029\u202a-\u202e\u2066-\u2069]")
_UNSAFE_LINE = re.compile("[\t\n]|" + _UNSAFE_TEXT.pattern)


def unsafe_character(text: str, *, one_line: bool = False) -> str | None:
    """The first character of ``text`` that must not be printed raw (see :func:`escape_unsafe`), or ``None``.

    With ``one_line``, tab and newline count as unsafe too.
    """
    m = (_UNSAFE_LINE if one_line else _UNSAFE_TEXT).search(text)
    return m.group() if m else None


def escape_unsafe(text: str, *, one_line: bool = False) -> str:
    """``text`` with every control or bidirectional-override character written as ``\\xNN`` / ``\\uNNNN``.

    What remains cannot move the cursor, change colours, set a terminal title or
    reorder the displayed text. With ``one_line`` tab and newline are escaped too.

    Examples
    --------
    A name read from a file that would set the terminal's title (``ESC ] 0 ; … BEL``) and reverse the
    text after it (U+202E) is printed harmless:

    >>> name = "tau" + chr(0x1b) + "]0;pwned" + chr(7) + chr(0x202e) + "x"
    >>> print(escape_unsafe(name))
    tau\\x1b]0;pwned\\x07\\u202ex

    Tab and newline are kept, unless the text must stay on one line:

    >>> escape_unsafe("a\\tb\\nc") == "a\\tb\\nc"
    True
    >>> print(escape_unsafe("a\\tb\\nc", one_line=True))
    a\\x09b\\x0ac
    """
    return (_UNSAFE_LINE if one_line else _UNSAFE_TEXT).sub(_escape_char, text)


def _escape_char(m: re.Match[str]) -> str:
    c = ord(m.group())
    return f"\\x{c:02x}" if c < 0x100 else f"\\u{c:04x}"


def name_problem(name: object) -> str | None:
    """Why ``name`` cannot name a state, input, output or parameter, e.g. ``"a Python keyword"`` (``None`` when it can).

    A name is a Python identifier that is not a keyword and is in Unicode NFKC
    normal form. The last condition matters because Python's parser (and so the
    expression parser) reads an identifier through NFKC: the fullwidth ``ｘ``
    *is* ``x`` in an expression, so a model declaring both would have a state no
    expression can reach. Identifiers exclude control characters, ``ESC`` and
    bidirectional overrides, so a valid name is also safe to print.
    """
    if not isinstance(name, str) or not name.isidentifier():
        return "not a valid identifier"
    if keyword.iskeyword(name):
        return "a Python keyword"
    norm = unicodedata.normalize("NFKC", name)
    if norm != name:
        return f"not in Unicode NFKC normal form: expressions read it as {norm!r}"
    return None


def check_names(kind: str, names: Sequence[str]) -> tuple[str, ...]:
    """Check names are unique identifiers (see :func:`name_problem`) and return them as a tuple."""
    out = tuple(names)
    for nm in out:
        why = name_problem(nm)
        if why is not None:
            raise ModelError(f"{kind} name {nm!r} is {why}")
    dup = sorted(nm for nm, c in Counter(out).items() if c > 1)
    if dup:
        raise ModelError(f"duplicate {kind} names: {', '.join(dup)}")
    return out


def default_names(kind: str, prefix: str, names: Sequence[str] | None, count: int) -> tuple[str, ...]:
    """``names`` checked (unique identifiers, ``count`` of them), or ``prefix1..prefixN`` when ``None``."""
    if names is None:
        return tuple(f"{prefix}{i + 1}" for i in range(count))
    out = check_names(kind, names)
    if len(out) != count:
        raise DimensionError(f"{len(out)} {kind} names given for {count} {kind}s")
    return out


def _fmt_shape(shape: tuple[int | None, int | None]) -> str:
    return "(" + ", ".join("?" if s is None else str(s) for s in shape) + ")"
