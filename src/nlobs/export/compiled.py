"""The compiled fast path: an observer whose step runs in its generated C, on the one protocol.

:func:`compile_observer` generates the observer's C (:mod:`nlobs.export.generate`), compiles it
(:mod:`nlobs.export.compiler`, cached) and loads it with :mod:`ctypes`. The result is an observer
like any other: :func:`nlobs.simulate.simulate` and :func:`nlobs.simulate.run_observer` take it
unchanged. It is *self-stepping* (:class:`~nlobs.observers.base.SelfStepping`): one call of
``P_step_batch`` advances every run of the batch over ``[t, t + h]`` with ``u`` and ``y`` held (RK4
for a continuous observer, stage for stage as the loops' own RK4 on recorded data), so a
simulation of a compiled observer equals :func:`~nlobs.simulate.run_observer` of the Python one on
the same measurements to rounding. In :func:`~nlobs.simulate.simulate` with exact (unsampled)
outputs the Python observer sees the plant's output at every RK4 stage, the compiled one holds it
over the step, as a flight computer does.

:meth:`CompiledObserver.run_record` runs one recorded run entirely in C (``P_run``): no Python per
step (the benchmark's and a deployment's loop).

Errors. A run whose new state is not finite keeps it (the loops report the divergence with its time
and component). Where the C reports a singular gain matrix (``Q_s`` of (3.1)), the Python observer
makes that step of that run again and raises its own error (:class:`~nlobs.observers.drift.
SingularObservabilityError` with the point and time), or, with ``on_singular="nan"``, that run's
state becomes NaN and the others go on.
"""

from __future__ import annotations

import ctypes
import threading
from pathlib import Path
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._typing import Array, BoolArray
from nlobs.errors import CompilerError, DimensionError, NumericalError
from nlobs.export.compiler import Compiler, build_shared
from nlobs.export.generate import default_prefix, generate
from nlobs.export.program import CProgram, nlobs_version, render
from nlobs.observers.base import DeferredEstimate, Diagnosing
from nlobs.systems.timebase import TimeBase

__all__ = ["CompiledCorrectingObserver", "CompiledObserver", "compile_gnss_ins", "compile_observer", "load_library"]

# pointers travel as plain addresses (``ndarray.ctypes.data``): ctypes' typed-pointer casts cost microseconds
_D = _B = _I = ctypes.c_void_p
_LOADED: dict[str, Any] = {}
_LOCK = threading.Lock()

OK, SINGULAR, NONFINITE = 0, 1, 2




def load_library(program: CProgram, *, compiler: Compiler | None = None, strict: bool = False) -> Any:
    """Compile (or take from the cache) and load ``program``; the library with its argument types set.

    Parameters
    ----------
    program : CProgram
        The generated module.
    compiler : Compiler, optional
        Default :func:`nlobs.export.compiler.find_compiler`.
    strict : bool
        Compile with every warning an error.

    Raises
    ------
    CompilerError
        No compiler, or it failed.
    """
    header, source = render(program, nlobs_version())
    path = build_shared(source, headers={program.header_name: header}, strict=strict, compiler=compiler)
    key = str(path)
    with _LOCK:
        lib = _LOADED.get(key)
        if lib is None:
            try:
                lib = ctypes.CDLL(key)
            except OSError:  # a damaged file in the cache (a full disk, another tool): build it once more
                Path(key).unlink(missing_ok=True)
                path = build_shared(source, headers={program.header_name: header}, strict=strict, compiler=compiler)
                try:
                    lib = ctypes.CDLL(str(path))
                except OSError as exc:
                    raise CompilerError(f"{path}: the compiled module cannot be loaded ({exc})") from None
            P = program.prefix
            c_long, c_int, c_d = ctypes.c_long, ctypes.c_int, ctypes.c_double
            sigs: dict[str, tuple[Any, list[Any]]] = {
                "init": (c_int, [_D, _D]),
                "rhs": (c_int, [c_d, _D, _D, _D, _D]),
                "step": (c_int, [c_d, _D, _D, _D, c_d]),
                "estimate": (None, [_D, _D]),
                "estimate_batch": (None, [c_long, _D, _D]),
                "rhs_batch": (c_long, [c_long, c_d, _D, _D, _D, _D, _I]),
                "step_batch": (c_long, [c_long, c_d, _D, _D, _D, c_d, _I]),
                "run": (c_long, [c_long, _D, _D, _D, _D, _B, _D]),
                "run_batch": (c_long, [c_long, c_long, _D, _D, _D, _D, _B, _D, _I]),
            }
            if program.correcting:
                sigs["correct"] = (c_int, [c_d, _D, _D, _D, _B])
                sigs["correct_batch"] = (c_long, [c_long, c_d, _D, _D, _D, _B, _I])
            if program.staged:
                sigs["step_stages"] = (c_int, [c_d, _D, _D, _D, _D, _D, c_d])
                sigs["step_stages_batch"] = (c_long, [c_long, c_d, _D, _D, _D, _D, _D, c_d, _I])
            for name, (res, args) in sigs.items():
                fn = getattr(lib, f"{P}_{name}")
                fn.restype = res
                fn.argtypes = args
            _LOADED[key] = lib
    return lib


def _ptr(a: Array) -> int:
    return a.ctypes.data  # type: ignore[no-any-return]


def _width(name: str, what: str, a: Any, n: int) -> None:
    """``a`` has ``n`` entries along its last axis (broadcasting must never stretch a measurement or an input)."""
    shape = np.shape(a)
    if n and (not shape or shape[-1] != n):
        raise DimensionError(f"{name}: {what} of shape {shape}, expected (..., {n})")


def _contig(a: Any, shape: tuple[int, ...]) -> Array:
    """``a`` as a C-contiguous float64 array of ``shape`` (no copy when it already is one)."""
    if type(a) is np.ndarray and a.shape == shape and a.dtype == np.float64 and a.flags.c_contiguous:
        return a
    out = np.empty(shape)
    out[...] = a  # broadcast on assignment (a ValueError where it does not broadcast, as np.broadcast_to)
    return out


@dataclass(frozen=True, eq=False)
class CompiledObserver:
    """An observer advanced by its generated C (module docstring); satisfies the observer protocol.

    Build it with :func:`compile_observer`.

    Attributes
    ----------
    observer : Observer
        The Python observer it was generated from (names, initial checks, the errors it raises).
    program : CProgram
        The generated module.
    library : ctypes.CDLL
        The loaded shared library.
    made_with : tuple or None
        How :func:`compile_observer` made it (prefix, notes, options): a pickle compiles it again from these
        (``None``: built otherwise, not picklable).
    time : Continuous or Discrete
        The observer's time base.
    name : str
        ``"<observer> [C]"``.

    Examples
    --------
    A Luenberger observer compiled by :func:`compile_observer`: its C right-hand side is
    ``ż = (A − L C) z + B u + L y`` for a batch of two runs, and its step is the RK4 step of the
    Python observer, to rounding:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate.integrators import rk4_step
    >>> A, B, C = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]])
    >>> L = np.array([[4.5], [1.75]])  # eigenvalues of A − L C at −2, −3
    >>> observer = nlobs.LuenbergerObserver(nlobs.LinearSystem(A, B, C), L)
    >>> compiled = compile_observer(observer)
    >>> compiled.name, compiled.n_x, compiled.n_z, compiled.program.discrete
    ('LuenbergerObserver [C]', 2, 2, False)
    >>> z, u, y = np.array([[1.0, 0.0], [0.0, 2.0]]), np.array([[0.5], [0.0]]), np.array([[0.2], [-1.0]])
    >>> dz = compiled.rhs(0.0, z, u, y)
    >>> np.round(dz, 3).tolist(), bool(np.allclose(dz, z @ (A - L @ C).T + u @ B.T + y @ L.T))
    ([[-3.6, -2.9], [-2.5, -2.75]], True)
    >>> python = rk4_step(lambda t, zz: observer.rhs(t, zz, u, y), 0.0, z, 0.01)
    >>> bool(np.allclose(compiled.step(0.0, z, u, y, 0.01), python, rtol=0.0, atol=1e-14))
    True
    """

    observer: Any
    program: CProgram
    library: Any = field(repr=False)
    made_with: tuple[Any, ...] | None = field(default=None, repr=False, compare=False)
    time: TimeBase = field(init=False)
    name: str = field(init=False)
    state_names: tuple[str, ...] | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "time", self.observer.time)
        label = getattr(self.observer, "name", None) or type(self.observer).__name__
        object.__setattr__(self, "name", f"{label} [C]")
        names = getattr(self.observer, "state_names", None)
        object.__setattr__(self, "state_names", tuple(names) if names and len(names) == self.program.n_z else None)
        P = self.program.prefix
        object.__setattr__(self, "_fn", {k: getattr(self.library, f"{P}_{k}") for k in (
            "step_batch", "rhs_batch", "run", "run_batch", "init", "estimate", "estimate_batch",
            *(("correct_batch",) if self.program.correcting else ()),
            *(("step_stages_batch",) if self.program.staged else ()))})

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        """Pickled as the Python observer and how it was compiled; compiled (or taken from the library cache) again
        where it is unpickled (a loaded library cannot be pickled)."""
        if self.made_with is None:
            raise TypeError(f"{self.name}: built without compile_observer, so it cannot be pickled; pickle its "
                            "observer and compile it where it is needed")
        return (_recompile_observer, (self.observer, *self.made_with))

    # ------------------------------------------------------------------ sizes
    @property
    def n_x(self) -> int:
        """Estimate dimension."""
        return self.program.n_x

    @property
    def n_z(self) -> int:
        """Flat state dimension of one run."""
        return self.program.n_z

    # ------------------------------------------------------------------ state conversion
    def _pack(self, z: Any) -> Array:
        codec = self.program.codec
        flat = codec.pack(z) if codec is not None else z
        return np.ascontiguousarray(flat, dtype=np.float64)

    def _unpack(self, flat: Array) -> Any:
        codec = self.program.codec
        return codec.unpack(flat) if codec is not None else flat

    def _io(self, z: Array, u: Array, y: Array) -> tuple[Array, Array, Array, int, tuple[int, ...]]:
        zc = np.array(z, dtype=np.float64, order="C", copy=True)
        if zc.ndim < 1 or zc.shape[-1] != self.n_z:
            raise DimensionError(f"{self.name}: state of shape {zc.shape}, expected (..., {self.n_z})")
        batch = zc.shape[:-1]
        n = zc.size // self.n_z
        uc = self._input(u, batch, n)
        _width(self.name, "y", y, self.program.n_y)
        yc = _contig(y, (*batch, self.program.n_y)) if self.program.n_y else np.zeros(max(n, 1))
        return zc, uc, yc, n, batch

    def _input(self, u: Array, batch: tuple[int, ...], n: int) -> Array:
        """An input of the batch as the C reads it: ``(*batch, n_u)`` contiguous (a stage's too)."""
        _width(self.name, "u", u, self.program.n_u)
        return _contig(u, (*batch, self.program.n_u)) if self.program.n_u else np.zeros(max(n, 1))

    # ------------------------------------------------------------------ protocol
    def init(self, x_hat0: ArrayLike) -> Array:
        """The Python observer's ``init`` (its checks included), as the flat C state ``(..., n_z)``."""
        return self._pack(self.observer.init(x_hat0))

    def estimate(self, z: Array) -> Array:
        """``x̂`` of the flat state (the Python observer's ``estimate`` of the unpacked state)."""
        if self.program.codec is None and self.n_z == self.n_x:
            est = self.observer.estimate
            return est(z)  # type: ignore[no-any-return]
        return self.observer.estimate(self._unpack(z))  # type: ignore[no-any-return]

    def _c_estimate(self, z: Array) -> Array:
        zc = _contig(z, np.shape(z))
        out = np.empty((*zc.shape[:-1], self.n_x))
        self._fn["estimate_batch"](zc.size // self.n_z, _ptr(zc), _ptr(out))
        return out

    def rhs(self, t: float, z: Array, u: Array, y: Array) -> Array:
        """``ż`` or ``z⁺`` of every run, computed in C (``P_rhs_batch``, or ``P_step_batch`` in discrete time)."""
        if self.program.discrete:
            return self.step(t, z, u, y, 0.0)
        zc, uc, yc, n, batch = self._io(z, u, y)
        dz = np.empty_like(zc)
        if self._fn["rhs_batch"](n, float(t), _ptr(zc), _ptr(uc), _ptr(yc), _ptr(dz), None):
            status = np.zeros(max(n, 1), dtype=np.intc)
            self._fn["rhs_batch"](n, float(t), _ptr(zc), _ptr(uc), _ptr(yc), _ptr(dz), _ptr(status))
            self._failed(status[:n], t, z, u, y, dz, lambda zz, uu, yy: self.observer.rhs(t, zz, uu, yy))
        return dz

    def step(self, t: float, z: Array, u: Array, y: Array, h: float) -> Array:
        """The state of every run at ``t + h`` (``u``, ``y`` held), one ``P_step_batch`` call."""
        zc, uc, yc, n, batch = self._io(z, u, y)
        if self._fn["step_batch"](n, float(t), _ptr(zc), _ptr(uc), _ptr(yc), float(h), None):
            zc, uc, yc, n, batch = self._io(z, u, y)  # once more from the start, with the status of every run
            status = np.zeros(max(n, 1), dtype=np.intc)
            self._fn["step_batch"](n, float(t), _ptr(zc), _ptr(uc), _ptr(yc), float(h), _ptr(status))
            self._failed(status[:n], t, z, u, y, zc, lambda zz, uu, yy: self._python_step(t, zz, uu, yy, h))
        return zc

    def step_stages(self, t: float, z: Array, u0: Array, uh: Array, u1: Array, y: Array, h: float) -> Array:
        """The state of every run at ``t + h``, ``y`` held, the input at RK4's stages: ``u0`` at ``t``, ``uh`` at
        ``t + h/2``, ``u1`` at ``t + h`` (one ``P_step_stages_batch`` call; :meth:`step` where the module steps
        itself, holding ``u0``).

        Raises
        ------
        DimensionError
            A state, input or measurement of the wrong width.
        """
        if not self.program.staged:
            return self.step(t, z, u0, y, h)
        zc, uc0, yc, n, batch = self._io(z, u0, y)
        uch, uc1 = self._input(uh, batch, n), self._input(u1, batch, n)
        fn = self._fn["step_stages_batch"]
        if fn(n, float(t), _ptr(zc), _ptr(uc0), _ptr(uch), _ptr(uc1), _ptr(yc), float(h), None):
            zc = np.array(z, dtype=np.float64, order="C", copy=True)
            status = np.zeros(max(n, 1), dtype=np.intc)
            fn(n, float(t), _ptr(zc), _ptr(uc0), _ptr(uch), _ptr(uc1), _ptr(yc), float(h), _ptr(status))
            # the Python step of the failing run with u0 held raises the observer's own error (the same matrix)
            self._failed(status[:n], t, z, u0, y, zc, lambda zz, uu, yy: self._python_step(t, zz, uu, yy, h))
        return zc

    def _python_step(self, t: float, z: Array, u: Array, y: Array, h: float) -> Any:
        from nlobs.simulate.integrators import rk4_step

        obs = self.observer
        if self.program.discrete:
            return obs.rhs(t, z, u, y)
        step = getattr(obs, "step", None)
        if step is not None:
            return step(t, z, u, y, h)
        return rk4_step(lambda tt, zz: obs.rhs(tt, zz, u, y), t, z, h)

    def _failed(self, status: Array, t: float, z: Array, u: Array, y: Array, out: Array, redo: Any) -> None:
        """Runs whose C step reported a singular matrix: the Python observer's error, or NaN (module docstring)."""
        flat = out.reshape(-1, self.n_z)
        singular = np.flatnonzero(status == SINGULAR)
        if singular.size == 0:
            return  # non-finite states are kept: the loops report the divergence
        if getattr(self.observer, "on_singular", "raise") == "nan":
            flat[singular] = np.nan
            return
        r = int(singular[0])
        zb = np.asarray(z, dtype=float).reshape(-1, self.n_z)[r]
        ub = np.broadcast_to(np.asarray(u, dtype=float), (*np.shape(z)[:-1], self.program.n_u)).reshape(-1, self.program.n_u)[r]
        yb = np.broadcast_to(np.asarray(y, dtype=float), (*np.shape(z)[:-1], self.program.n_y)).reshape(-1, self.program.n_y)[r]
        with np.errstate(all="ignore"):
            redo(self._unpack(zb), ub, yb)  # raises the Python observer's own error (point, time)
        raise NumericalError(f"{self.name}: at t = {t:g} the generated C refused the step of run {r} "
                             f"({self.program.status1}) where the Python observer does not")

    def run_records(self, t: Array, z0: Array, u: Array, y: Array, sampled: BoolArray) -> Array | None:
        """Every run over the record in one C call (``P_run_batch``): raw estimates ``(*batch, K, n_x)``.

        The capability :class:`~nlobs.observers.base.RecordRunning` that :func:`nlobs.simulate.run_observer`
        uses: no Python per step. A run whose state becomes non-finite goes on with NaN (the loop
        reports the divergence); where the C finds a singular matrix this returns ``None`` and the loop
        steps the record instead, so that the Python observer reports it as it always does.

        Parameters
        ----------
        t : ndarray, shape (K,)
            The time grid.
        z0 : ndarray, shape (*batch, n_z)
            The initial flat states.
        u : ndarray, shape (*batch, K, m)
            Known input at each instant.
        y : ndarray, shape (*batch, K, p)
            Measurement at each instant (read where ``sampled``).
        sampled : ndarray of bool, shape (K, p)
            Fresh samples.
        """
        p = self.program
        zc = np.array(z0, dtype=np.float64, order="C", copy=True)
        batch = zc.shape[:-1]
        n = zc.size // p.n_z
        grid = np.ascontiguousarray(t, dtype=np.float64)
        K = grid.size
        _width(self.name, "u", u, p.n_u)
        _width(self.name, "y", y, p.n_y)
        uc = _contig(u, (*batch, K, p.n_u)) if p.n_u else np.zeros(1)
        yc = _contig(y, (*batch, K, p.n_y)) if p.n_y else np.zeros(1)
        sm = np.ascontiguousarray(np.broadcast_to(np.asarray(sampled, dtype=bool), (K, p.n_y)), dtype=np.uint8) \
            if p.n_y else np.zeros(1, dtype=np.uint8)
        out = np.empty((*batch, K, p.n_x))
        status = np.zeros(max(n, 1), dtype=np.intc)
        if self._fn["run_batch"](n, K, _ptr(grid), _ptr(zc), _ptr(uc), _ptr(yc), _ptr(sm), _ptr(out), _ptr(status)):
            if np.any(status[:n] == SINGULAR):
                return None
        return out

    def run_record(self, t: ArrayLike, x_hat0: ArrayLike, *, u: ArrayLike | None = None,
                   y: ArrayLike | None = None, sampled: ArrayLike | None = None) -> Array:
        """One run over a recorded grid, entirely in C (``P_run``); the estimates ``(K, n_x)``.

        Parameters
        ----------
        t : array_like, shape (K,)
            Increasing times.
        x_hat0 : array_like, shape (n_x,)
            Initial estimate.
        u : array_like, shape (K, m), optional
            Known input at each instant (held over the step).
        y : array_like, shape (K, p), optional
            Measurement at each instant (taken where ``sampled``).
        sampled : array_like of bool, shape (K, p), optional
            Where ``y`` holds a fresh sample (default: everywhere).

        Raises
        ------
        NumericalError
            A step or correction failed in C (the instant is named).
        """
        grid = np.ascontiguousarray(t, dtype=np.float64)
        if grid.ndim != 1 or grid.size < 1 or np.any(np.diff(grid) <= 0):
            raise DimensionError("t: expected an increasing one-dimensional grid")
        K, p = grid.size, self.program
        z = self.init(np.asarray(x_hat0, dtype=float)).reshape(-1)
        if z.size != p.n_z:
            raise DimensionError(f"x_hat0: one run only (a state of {p.n_z} values), got {z.size}")
        z = np.ascontiguousarray(z)
        _width(self.name, "u", np.zeros((K, 0)) if u is None else u, p.n_u)
        _width(self.name, "y", np.zeros((K, 0)) if y is None else y, p.n_y)
        uc = _contig(u if u is not None else np.zeros((K, 0)), (K, p.n_u)) if p.n_u else np.zeros(1)
        yc = _contig(y if y is not None else np.zeros((K, 0)), (K, p.n_y)) if p.n_y else np.zeros(1)
        sm = None if sampled is None else np.ascontiguousarray(np.broadcast_to(np.asarray(sampled, dtype=bool),
                                                                             (K, p.n_y)), dtype=np.uint8)
        out = np.empty((K, p.n_x))
        rc = self._fn["run"](K, _ptr(grid), _ptr(z), _ptr(uc), _ptr(yc),
                             None if sm is None else _ptr(sm), _ptr(out))
        if rc:
            raise NumericalError(f"{self.name}: the step at t = {grid[int(rc) - 1]:g} failed in C")
        return out


@dataclass(frozen=True, eq=False)
class CompiledCorrectingObserver(CompiledObserver):
    """A :class:`CompiledObserver` that also corrects at samples (``P_correct_batch``).

    Attributes
    ----------
    observer : CorrectingObserver
        The Python observer it was generated from.
    program : CProgram
        The generated module (``correcting`` is true).
    library : ctypes.CDLL
        The loaded shared library.
    made_with : tuple or None
        How :func:`compile_observer` made it (a pickle compiles it again from these).

    Examples
    --------
    Raff & Allgöwer's impulsive observer of a 2-state plant corrects at samples, so it compiles to this
    class. The C jump is ``x̂ ← x̂ + L_J (y − C x̂)`` where the sample is fresh, and nothing where it is not:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.observers.impulsive import ImpulsiveObserver
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> L_J = np.array([[0.5], [0.3]])
    >>> observer = ImpulsiveObserver(system, L_J)
    >>> compiled = compile_observer(observer)
    >>> type(compiled).__name__, compiled.program.correcting
    ('CompiledCorrectingObserver', True)
    >>> z, u, y = np.array([[1.0, 0.0], [0.0, 2.0]]), np.zeros((2, 1)), np.array([[0.5], [1.0]])
    >>> jumped = compiled.correct(0.0, z, u, y, [True])
    >>> np.round(jumped, 3).tolist(), bool(np.allclose(jumped, z + (y - z[:, :1]) @ L_J.T))
    ([[0.75, -0.15], [0.5, 2.3]], True)
    >>> bool(np.array_equal(jumped, observer.correct(0.0, z, u, y, [True])))  # the Python observer's numbers
    True
    >>> bool(np.array_equal(compiled.correct(0.0, z, u, y, [False]), z))  # no fresh sample: no jump
    True
    """

    def correct(self, t: float, z: Array, u: Array, y: Array, fresh: BoolArray) -> Array:
        """The corrected state of every run (a non-finite sampled value is skipped by the C, as in Python)."""
        zc, uc, yc, n, batch = self._io(z, u, y)
        try:  # as the Python observers: a scalar or one flag per output, never fewer bytes than C reads
            fr = np.array(np.broadcast_to(np.asarray(fresh, dtype=bool), (self.program.n_y,)), dtype=np.uint8)
        except ValueError:
            raise DimensionError(f"{self.name}: fresh of shape {np.shape(fresh)}, expected "
                                 f"({self.program.n_y},)") from None
        self._fn["correct_batch"](n, float(t), _ptr(zc), _ptr(uc), _ptr(yc), _ptr(fr), None)
        return zc


class _CompiledDeferred(CompiledCorrectingObserver):
    """A compiled observer whose Python original defers its estimates (one projection per run)."""

    def raw_estimate(self, z: Array) -> Array:
        """The raw estimate (the Python observer's ``raw_estimate`` layout), computed in C (``P_estimate_batch``)."""
        return self._c_estimate(z)

    def finish_estimates(self, raw: Array) -> Any:
        """The Python observer's ``finish_estimates``."""
        return self.observer.finish_estimates(raw)


def compile_observer(observer: Any, *, prefix: str | None = None, compiler: Compiler | None = None,
                     notes: tuple[tuple[str, str], ...] = (), options: dict[str, Any] | None = None) -> CompiledObserver:
    """``observer`` with its step in generated, compiled C (module docstring).

    Parameters
    ----------
    observer : Observer
        One of :func:`nlobs.export.generate.supported`.
    prefix : str, optional
        C prefix (default from the observer's class).
    compiler : Compiler, optional
        Default :func:`nlobs.export.compiler.find_compiler`.
    notes : tuple of (str, str)
        Lines for the generated header.
    options : dict, optional
        Keyword arguments of the observer's generator (the GNSS/INS observer: ``imu_period``).

    Returns
    -------
    CompiledObserver
        Or its correcting form (the observer corrects at samples).

    Raises
    ------
    InvalidArgumentError
        The observer has no C generator.
    CompilerError
        No C compiler, or it failed.

    Examples
    --------
    A Luenberger observer (eigenvalues of ``A − L C`` at ``−2, −3``) compiled once (the library is
    cached), then run on a recorded measurement beside the Python observer: the same estimates:

    >>> import numpy as np
    >>> import nlobs
    >>> from nlobs.simulate import run_observer
    >>> system = nlobs.LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> observer = nlobs.LuenbergerObserver(system, [[4.5], [1.75]])
    >>> compiled = compile_observer(observer)
    >>> type(compiled).__name__, compiled.program.prefix
    ('CompiledObserver', 'nlobs_luenbergerobserver')
    >>> t = np.linspace(0.0, 2.0, 201)
    >>> rec = dict(x_hat0=[0.0, 0.0], u=np.zeros((201, 1)), y=np.cos(t)[:, None])
    >>> a, b = run_observer(observer, t, **rec), run_observer(compiled, t, **rec)
    >>> b.method, bool(np.allclose(a.x_hat, b.x_hat, rtol=0.0, atol=1e-12))
    ('observer step, whole record in one call', True)
    """
    program = generate(observer, default_prefix(observer, prefix), notes=notes,
                       options=options)
    lib = load_library(program, compiler=compiler)
    cls: type[CompiledObserver] = CompiledObserver
    if program.correcting:
        cls = _CompiledDeferred if isinstance(observer, DeferredEstimate) else CompiledCorrectingObserver
    if isinstance(observer, Diagnosing) and getattr(observer, "compiled_diagnostics", True):
        cls = _with_diagnostics(cls)
    return cls(observer, program, lib, (prefix, notes, options))


def _recompile_observer(observer: Any, prefix: str | None, notes: tuple[tuple[str, str], ...],
                        options: dict[str, Any] | None) -> CompiledObserver:
    """Unpickle a :class:`CompiledObserver`: :func:`compile_observer` once more (the library cache answers)."""
    return compile_observer(observer, prefix=prefix, notes=notes, options=options)


_DIAGNOSING: dict[type, type] = {}


def _with_diagnostics(base: type[CompiledObserver]) -> type[CompiledObserver]:
    """``base`` with ``diagnostics``: the Python observer's, of the unpacked state (the loops record them)."""
    cls = _DIAGNOSING.get(base)
    if cls is None:
        def diagnostics(self: CompiledObserver, z: Array, u: Array) -> Any:
            """The Python observer's diagnostics of the unpacked state."""
            return self.observer.diagnostics(self._unpack(z), u)

        cls = _DIAGNOSING[base] = type(f"{base.__name__.lstrip('_')}Diagnosing", (base,),
                                       {"diagnostics": diagnostics, "__module__": __name__,
                                        "__doc__": f"A {base.__name__.lstrip('_')} that records the Python "
                                                   "observer's diagnostics."})
    return cls


def compile_gnss_ins(observer: Any, *, imu_period: float, prefix: str | None = None, compiler: Any = None,
                     notes: tuple[tuple[str, str], ...] = ()) -> Any:
    """:func:`~nlobs.export.compiled.compile_observer` of observer (24) for a given nominal IMU period.

    Parameters
    ----------
    observer : GnssInsObserver or ScheduledGnssInsObserver
    imu_period : float
        ``h₀`` [s] (see :func:`nlobs.export.gnss_ins.generate_gnss_ins`).
    prefix, compiler, notes
        As :func:`~nlobs.export.compiled.compile_observer`.
    """
    return compile_observer(observer, prefix=prefix, compiler=compiler, notes=notes,
                            options={"imu_period": imu_period})
