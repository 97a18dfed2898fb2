"""Linear state-space models ``(A, B, C, D)``, continuous or discrete time.

``ẋ = A x + B u``, ``y = C x + D u`` (continuous) or ``x⁺ = A x + B u`` (discrete).
Shapes and finiteness are checked at construction; the matrices are stored as
read-only float arrays.
"""

from __future__ import annotations

import functools
import inspect
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlobs._validate import as_matrix, as_square, default_names, readonly
from nlobs.errors import InvalidArgumentError
from nlobs.systems.timebase import CONTINUOUS, Discrete, TimeBase

_CONTROL_DEFAULT_LABEL = re.compile(r"[xuy]\[\d+\]")
F = TypeVar("F", bound=Callable[..., Any])


def is_control_system(obj: Any) -> bool:
    """Whether ``obj`` is a python-control ``StateSpace`` or ``TransferFunction`` (python-control is not imported)."""
    mod = type(obj).__module__ or ""
    return (mod == "control" or mod.startswith("control.")) and hasattr(obj, "dt") and (
        hasattr(obj, "A") or hasattr(obj, "num"))


def _import_control() -> Any:
    try:
        import control
    except ImportError:
        raise InvalidArgumentError("python-control is not installed: pip install 'nlobs[control]'") from None
    return control


def _control_parts(sys: Any) -> dict[str, Any]:
    """Matrices, time base and names of a python-control system (a transfer function is realised first)."""
    if not hasattr(sys, "A"):
        sys = _import_control().ss(sys)
    dt = sys.dt
    if dt is True:
        raise InvalidArgumentError("sys: a discrete-time python-control system with an unspecified sample time "
                                   "(dt=True); give its sample time")
    time: TimeBase = CONTINUOUS if (dt is None or dt == 0) else Discrete(float(dt))

    def names(labels: Any) -> list[str] | None:
        labels = list(labels or [])
        return None if not labels or all(_CONTROL_DEFAULT_LABEL.fullmatch(str(x)) for x in labels) \
            else [str(x) for x in labels]

    raw_name = str(getattr(sys, "name", "") or "")
    return {"A": np.asarray(sys.A, dtype=float), "B": np.asarray(sys.B, dtype=float),
            "C": np.asarray(sys.C, dtype=float), "D": np.asarray(sys.D, dtype=float), "time": time,
            "states": names(getattr(sys, "state_labels", None)), "inputs": names(getattr(sys, "input_labels", None)),
            "outputs": names(getattr(sys, "output_labels", None)),
            "name": raw_name if raw_name and not raw_name.startswith("sys[") else "linear"}


def as_linear_system(obj: Any, what: str = "sys") -> LinearSystem:
    """``obj`` as a :class:`LinearSystem`: itself, or a python-control system converted.

    Raises
    ------
    InvalidArgumentError
        Neither.
    """
    if isinstance(obj, LinearSystem):
        return obj
    if is_control_system(obj):
        return LinearSystem.from_control(obj)
    raise InvalidArgumentError(f"{what}: expected a LinearSystem or a python-control StateSpace/TransferFunction, "
                               f"got {type(obj).__name__}")


_ROLE_LETTERS = frozenset("ABCD")


def takes_system(*, time: str = "either", **roles: str) -> Callable[[F], F]:
    """Let a function of a system's matrices also take the system: a :class:`LinearSystem` or a python-control
    ``StateSpace``/``TransferFunction`` in place of its first matrix.

    ``roles`` maps each matrix parameter to the system's matrix it is (``A="A", C="C", Bd="B"``), the first one being
    where the system goes; the other matrices must then not be given. Positional arguments after the system go to
    the function's other parameters in order. A ``discrete`` parameter is taken from the system's time base (given as
    well, it must agree).

    Parameters
    ----------
    time : {"either", "continuous", "discrete"}
        The time bases the function is for: a system of another is refused with the function's name.
    **roles : str
        Parameter name → ``"A"``, ``"B"``, ``"C"`` or ``"D"``.

    Returns
    -------
    callable
        The decorator.
    """
    if not roles or any(v not in _ROLE_LETTERS for v in roles.values()) or time not in ("either", "continuous",
                                                                                          "discrete"):
        raise InvalidArgumentError(f"takes_system: roles {roles!r}, time {time!r}")
    names = tuple(roles)

    def decorate(fn: F) -> F:
        params = [p for p in inspect.signature(fn).parameters.values()
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
        if not params or params[0].name != names[0]:
            raise InvalidArgumentError(f"takes_system: {fn.__name__}'s first parameter is not {names[0]}")
        others = [p.name for p in params if p.name not in roles]
        has_discrete = "discrete" in inspect.signature(fn).parameters

        @functools.wraps(fn)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            first = args[0] if args else kwargs.get(names[0])
            if not (isinstance(first, LinearSystem) or is_control_system(first)):
                return fn(*args, **kwargs)
            sys = as_linear_system(first, names[0])
            rest = list(args[1:])
            if len(rest) > len(others):
                raise InvalidArgumentError(f"{fn.__name__}: {len(args)} positional arguments with a system")
            given = [n for n in names[1:] if n in kwargs]
            if given:
                raise InvalidArgumentError(f"{fn.__name__}: {names[0]} is a system, and {', '.join(given)} "
                                           "given as well: give the system or its matrices")
            call = {k: v for k, v in kwargs.items() if k != names[0]}
            for name, value in zip(others, rest):
                if name in call:
                    raise InvalidArgumentError(f"{fn.__name__}: {name} given twice")
                call[name] = value
            matrices = {"A": sys.A, "B": sys.B, "C": sys.C, "D": sys.D}
            for name, role in roles.items():
                call[name] = matrices[role]
            discrete = sys.time.is_discrete
            if time != "either" and discrete != (time == "discrete"):
                raise InvalidArgumentError(f"{fn.__name__}: a {'discrete' if discrete else 'continuous'}-time system; "
                                           f"this function is for {time} time")
            if has_discrete:
                if "discrete" in call and bool(call["discrete"]) != discrete:
                    raise InvalidArgumentError(f"{fn.__name__}: discrete={call['discrete']!r} for a "
                                               f"{'discrete' if discrete else 'continuous'}-time system")
                call["discrete"] = discrete
            return fn(**call)

        return wrapper  # type: ignore[return-value]

    return decorate


@dataclass(frozen=True)
class LinearSystem:
    """A linear time-invariant system.

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices of shapes ``(n, n)``, ``(n, m)``, ``(p, n)``, ``(p, m)``.
        ``B`` and ``D`` may have zero columns (``m = 0``). Or ``A`` alone, a python-control
        ``StateSpace`` or ``TransferFunction`` (:meth:`from_control`: its matrices, time base and
        signal names).
    time : Continuous or Discrete
        Time base; :data:`~nlobs.systems.timebase.CONTINUOUS` by default.
    states, inputs, outputs : sequence of str, optional
        Names; default ``x1..xn``, ``u1..um``, ``y1..yp``.
    name : str
        A label used in reports.

    Examples
    --------
    A damped oscillator, continuous by default, with nlobs's default names and ``D = 0``:

    >>> import numpy as np
    >>> system = LinearSystem([[0.0, 1.0], [-2.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]])
    >>> (system.n, system.m, system.p), system.states, system.outputs, system.D.tolist(), str(system.time)
    ((2, 1, 1), ('x1', 'x2'), ('y1',), [[0.0]], 'continuous')
    >>> system.rhs(0.0, np.array([1.0, 0.0]), np.array([0.5])).tolist()  # A x + B u
    [0.0, -1.5]
    >>> system.output(0.0, np.zeros((4, 2)), np.zeros((4, 1))).shape  # a batch of four runs
    (4, 1)

    A discrete-time system carries its sampling period:

    >>> from nlobs.systems.timebase import Discrete
    >>> sampled = LinearSystem([[1.0, 0.1], [0.0, 1.0]], [[0.0], [0.1]], [[1.0, 0.0]], time=Discrete(0.1),
    ...                        states=["pos", "vel"])
    >>> sampled.is_discrete, sampled.time.dt, sampled.states
    (True, 0.1, ('pos', 'vel'))
    """

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    C: NDArray[np.float64]
    D: NDArray[np.float64]
    time: TimeBase = CONTINUOUS
    states: tuple[str, ...] = field(default=())
    inputs: tuple[str, ...] = field(default=())
    outputs: tuple[str, ...] = field(default=())
    name: str = "linear"

    def __init__(
        self,
        A: ArrayLike | Any,
        B: ArrayLike | None = None,
        C: ArrayLike | None = None,
        D: ArrayLike | None = None,
        *,
        time: TimeBase = CONTINUOUS,
        states: Sequence[str] | None = None,
        inputs: Sequence[str] | None = None,
        outputs: Sequence[str] | None = None,
        name: str = "linear",
    ) -> None:
        if B is None and C is None and D is None and is_control_system(A):
            parts = _control_parts(A)
            A, B, C, D = parts["A"], parts["B"], parts["C"], parts["D"]
            time = parts["time"]
            states = states if states is not None else parts["states"]
            inputs = inputs if inputs is not None else parts["inputs"]
            outputs = outputs if outputs is not None else parts["outputs"]
            name = parts["name"] if name == "linear" else name
        if B is None or C is None:
            raise InvalidArgumentError("LinearSystem: give A, B, C (and D), or one python-control StateSpace or "
                                       "TransferFunction")
        A_ = as_square("A", A)
        n = A_.shape[0]
        B_ = as_matrix("B", B, (n, None))
        C_ = as_matrix("C", C, (None, n))
        m, p = B_.shape[1], C_.shape[0]
        D_ = np.zeros((p, m)) if D is None else as_matrix("D", D, (p, m))
        object.__setattr__(self, "A", readonly(A_))
        object.__setattr__(self, "B", readonly(B_))
        object.__setattr__(self, "C", readonly(C_))
        object.__setattr__(self, "D", readonly(D_))
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "states", default_names("state", "x", states, n))
        object.__setattr__(self, "inputs", default_names("input", "u", inputs, m))
        object.__setattr__(self, "outputs", default_names("output", "y", outputs, p))
        object.__setattr__(self, "name", str(name))

    @classmethod
    def from_control(cls, sys: Any, *, name: str | None = None) -> LinearSystem:
        """The system of a python-control ``StateSpace`` or ``TransferFunction``.

        A transfer function is realised by ``control.ss``. The time base is continuous for
        ``dt = 0``, :class:`~nlobs.systems.timebase.Discrete` ``(dt)`` for ``dt > 0``. Signal names
        are kept unless they are python-control's defaults (``x[0]``, ``u[0]``, ``y[0]``, ...),
        which become nlobs's (``x1``, ``u1``, ``y1``, ...).

        Raises
        ------
        InvalidArgumentError
            ``sys`` is not a python-control linear system, or a discrete one with an unspecified
            sample time (``dt = True``).
        """
        if not is_control_system(sys):
            raise InvalidArgumentError(f"sys: expected a python-control StateSpace or TransferFunction, got "
                                       f"{type(sys).__name__}")
        p = _control_parts(sys)
        return cls(p["A"], p["B"], p["C"], p["D"], time=p["time"], states=p["states"], inputs=p["inputs"],
                   outputs=p["outputs"], name=p["name"] if name is None else name)

    def to_control(self) -> Any:
        """This system as a python-control ``StateSpace`` (names and sample time kept; needs python-control)."""
        control = _import_control()
        dt = self.time.dt if self.time.is_discrete else 0
        return control.ss(self.A, self.B, self.C, self.D, dt, states=list(self.states), inputs=list(self.inputs),
                          outputs=list(self.outputs), name=self.name)

    @property
    def n(self) -> int:
        """Number of states."""
        return self.A.shape[0]

    @property
    def m(self) -> int:
        """Number of inputs."""
        return self.B.shape[1]

    @property
    def p(self) -> int:
        """Number of outputs."""
        return self.C.shape[0]

    @property
    def is_discrete(self) -> bool:
        return self.time.is_discrete

    def rhs(self, t: float, x: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``A x + B u`` for a batch ``x`` of shape ``(..., n)`` and ``u`` of shape ``(..., m)``."""
        if x.ndim == 1 and u.ndim == 1:  # one run: ndarray.dot costs a third of @ on small matrices
            return self.A.dot(x) + self.B.dot(u)
        return x @ self.A.T + u @ self.B.T

    def output(self, t: float, x: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``C x + D u`` for batches, shape ``(..., p)``."""
        if x.ndim == 1 and u.ndim == 1:
            return self.C.dot(x) + self.D.dot(u)
        return x @ self.C.T + u @ self.D.T

    def rhs_jacobian_x(self, t: float, x: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``∂(A x + B u)/∂x = A``, broadcast to the batch, shape ``(..., n, n)`` (read-only)."""
        if x.ndim == 1 and np.ndim(u) <= 1:
            return self.A
        return np.broadcast_to(self.A, (*np.broadcast_shapes(x.shape[:-1], np.shape(u)[:-1]), *self.A.shape))

    def output_jacobian_x(self, t: float, x: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``∂(C x + D u)/∂x = C``, broadcast to the batch, shape ``(..., p, n)`` (read-only)."""
        if x.ndim == 1 and np.ndim(u) <= 1:
            return self.C
        return np.broadcast_to(self.C, (*np.broadcast_shapes(x.shape[:-1], np.shape(u)[:-1]), *self.C.shape))
