"""Every function of a system's matrices takes the system too: a python-control ``StateSpace`` or a ``LinearSystem``.

The same call with the matrices written out is the reference (bit for bit); python-control's own observability
matrix and poles are a second; a discrete system sets ``discrete``; a system of the wrong time base, or a system with
its matrices given again, is refused with one line.
"""

from __future__ import annotations

import numpy as np
import pytest

import nlobs.linear as L
import nlobs.synthesis as S
from nlobs import Discrete, LinearSystem
from nlobs.errors import InvalidArgumentError

control = pytest.importorskip("control")

A = np.array([[0.0, 1.0, 0.0], [-2.0, -0.5, 1.0], [0.0, 0.0, -3.0]])
B = np.array([[0.0], [1.0], [0.5]])
C = np.array([[1.0, 0.0, 0.0]])
D = np.zeros((1, 1))
AD = np.array([[1.0, 0.1], [-0.2, 0.95]])
BD, CD, DD = np.array([[0.0], [0.1]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))


def _same(a, b) -> bool:  # type: ignore[no-untyped-def]
    """Equal, bit for bit, but for the clock's readings (a solver's seconds)."""
    import dataclasses

    if dataclasses.is_dataclass(a):
        return type(a) is type(b) and all(_same(getattr(a, f.name), getattr(b, f.name))
                                          for f in dataclasses.fields(a) if not f.name.endswith("seconds"))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a if not str(k).endswith("seconds"))
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=np.asarray(a).dtype.kind in "fc"))
    return bool(a == b) or (a != a and b != b)


CASES = [
    (L.hinf_grid_peak, (A, B, C, D), {}),
    (L.invariant_zeros, (A, B, C, D), {}),
    (L.is_left_invertible, (A, B, C, D), {}),
    (L.is_minimum_phase, (A, B, C, D), {}),
    (L.minimum_phase, (A, B, C, D), {}),
    (L.is_strongly_detectable, (A, B, C, D), {}),
    (L.is_detectable, (A, C), {}),
    (L.is_observable, (A, C), {}),
    (L.observability_matrix, (A, C), {}),
    (L.unobservable_modes, (A, C), {}),
    (L.eigenvalues, (A,), {}),
    (L.is_stable, (A,), {}),
    (L.stability_margin, (A,), {}),
    (L.spectral_abscissa, (A,), {}),
    (L.spectral_radius, (A,), {}),
    (L.extended_system, (A, B, C, D), {}),
    (L.check_assumption4, (A, B, C, D), {}),
    (S.design_observer_gain, (A, C, B), {"gamma": 10.0, "gamma_n": 10.0}),
    (S.kalman_bucy_gain, (A, C), {"noise": None}),
]


@pytest.mark.parametrize(("fn", "matrices", "kw"), CASES, ids=[c[0].__name__ for c in CASES])
def test_the_system_gives_the_numbers_of_its_matrices(fn, matrices, kw) -> None:  # type: ignore[no-untyped-def]
    if fn is S.kalman_bucy_gain:
        from nlobs.synthesis.mixed_h2 import NoiseModel

        kw = {"noise": NoiseModel(np.eye(1) * 0.1, np.eye(3), np.eye(3) * 0.01)}
    ref = fn(*matrices, **kw)
    for sys in (control.ss(A, B, C, D), LinearSystem(A, B, C, D)):
        assert _same(fn(sys, **kw), ref), fn.__name__


def test_python_control_agrees() -> None:
    sys = control.ss(A, B, C, D)
    assert np.allclose(L.observability_matrix(sys), control.obsv(A, C))
    assert np.allclose(np.sort_complex(L.eigenvalues(sys)), np.sort_complex(control.poles(sys)))


def test_a_discrete_system_sets_discrete() -> None:
    dsys = control.ss(AD, BD, CD, DD, 0.1)
    assert L.is_stable(dsys) == L.is_stable(AD, discrete=True) is True
    assert L.is_stable(AD) is False  # the same matrix read in continuous time is unstable: the flag mattered
    assert np.array_equal(L.unobservable_modes(dsys), L.unobservable_modes(AD, CD, discrete=True))
    assert L.is_stable(LinearSystem(AD, BD, CD, DD, time=Discrete(0.1)), discrete=True)
    with pytest.raises(InvalidArgumentError, match="discrete=False for a discrete-time system"):
        L.is_stable(dsys, discrete=False)
    cert = S.design_discrete_lipschitz_gain(dsys, lipschitz=0.01)
    assert _same(cert, S.design_discrete_lipschitz_gain(AD, CD, lipschitz=0.01))


def test_the_wrong_time_base_or_matrices_given_twice_are_refused() -> None:
    with pytest.raises(InvalidArgumentError, match="continuous-time system; this function is for discrete"):
        S.design_discrete_lipschitz_gain(control.ss(A, B, C, D), lipschitz=0.01)
    with pytest.raises(InvalidArgumentError, match="discrete-time system; this function is for continuous"):
        S.design_observer_gain(control.ss(AD, BD, CD, DD, 0.1), gamma=10.0, gamma_n=10.0)
    with pytest.raises(InvalidArgumentError, match="A is a system, and C given as well"):
        S.design_observer_gain(control.ss(A, B, C, D), C=C, gamma=10.0)
    with pytest.raises(InvalidArgumentError, match="positional arguments with a system"):
        L.is_stable(control.ss(A, B, C, D), False, 1e-9, "extra")
