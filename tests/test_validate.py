"""Shared argument validation: shapes, finiteness, symmetry, ranges, names; and atomic writes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nlobs._io import atomic_write, atomic_write_text
from nlobs._validate import as_batch, as_matrix, as_square, as_symmetric, as_vector, check_names, in_range, positive
from nlobs.errors import DimensionError, InvalidArgumentError, ModelError, NonFiniteError, NotSymmetricError


def test_matrix_shapes_are_never_silently_reshaped() -> None:
    with pytest.raises(DimensionError, match=r"B: expected a 2-d matrix, got shape \(3,\)"):
        as_matrix("B", [1.0, 2.0, 3.0])
    with pytest.raises(DimensionError, match=r"C: expected shape \(\?, 4\), got \(2, 3\)"):
        as_matrix("C", np.ones((2, 3)), (None, 4))
    with pytest.raises(DimensionError, match="A: expected a square matrix"):
        as_square("A", np.ones((2, 3)))
    with pytest.raises(DimensionError, match="cannot be read as a numeric array"):
        as_matrix("A", [[1, "x"]])
    with pytest.raises(DimensionError, match=r"x0: expected length 3, got 2"):
        as_vector("x0", [1, 2], 3)
    with pytest.raises(DimensionError, match=r"x: expected shape \(\.\.\., 2\)"):
        as_batch("x", np.ones((4, 3)), 2)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_entries_are_located(bad: float) -> None:
    a = np.eye(3)
    a[1, 2] = bad
    with pytest.raises(NonFiniteError, match=r"A: entry \(1, 2\) is"):
        as_square("A", a)


def test_symmetry_is_checked_relative_to_scale_and_result_is_exactly_symmetric() -> None:
    with pytest.raises(NotSymmetricError, match=r"P: not symmetric \(max \|M - M\^T\| = 0\.1\)"):
        as_symmetric("P", [[1.0, 0.1], [0.0, 1.0]])
    m = np.array([[1e6, 1.0], [1.0 + 1e-5, 2e6]])  # asymmetry 1e-5 relative to 2e6: accepted
    s = as_symmetric("P", m)
    np.testing.assert_array_equal(s, s.T)


def test_ranges_and_positivity() -> None:
    assert in_range("rtol", 1e-3, 0.0, 1.0) == 1e-3
    with pytest.raises(InvalidArgumentError, match=r"rtol: must lie in \(0, 0\.5\), got 0\.0"):
        in_range("rtol", 0.0, 0.0, 0.5, lo_open=True)
    with pytest.raises(NonFiniteError, match="tol: must be finite"):
        in_range("tol", float("nan"), 0.0, 1.0)
    with pytest.raises(InvalidArgumentError, match="expected a number"):
        in_range("tol", "abc", 0.0, 1.0)  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="gamma: must be positive, got -1.0"):
        positive("gamma", -1.0)
    assert positive("eta", 0.0, allow_zero=True) == 0.0


def test_names() -> None:
    assert check_names("state", ["a", "b"]) == ("a", "b")
    with pytest.raises(ModelError, match="duplicate state names: a"):
        check_names("state", ["a", "a"])
    with pytest.raises(ModelError, match="'1x' is not a valid identifier"):
        check_names("state", ["1x"])


def test_atomic_write_replaces_or_leaves_untouched(tmp_path: Path) -> None:
    target = tmp_path / "out" / "report.txt"
    atomic_write_text(target, "first")
    assert target.read_text() == "first"

    def failing(fh) -> None:  # type: ignore[no-untyped-def]
        fh.write(b"partial")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        atomic_write(target, failing)
    assert target.read_text() == "first"
    assert sorted(p.name for p in target.parent.iterdir()) == ["report.txt"]


def test_atomic_write_gives_the_mode_a_plain_open_would(tmp_path: Path) -> None:
    import os

    old = os.umask(0o022)
    try:
        plain, atomic = tmp_path / "plain.txt", tmp_path / "atomic.txt"
        plain.write_text("x")
        atomic_write_text(atomic, "x")
        assert atomic.stat().st_mode & 0o777 == plain.stat().st_mode & 0o777 == 0o644
        atomic.chmod(0o600)  # an existing file keeps its mode
        atomic_write_text(atomic, "y")
        assert atomic.stat().st_mode & 0o777 == 0o600
    finally:
        os.umask(old)


def test_one_of_normalises_defaults_and_names_every_choice() -> None:
    from nlobs._validate import one_of

    assert one_of("`sampling`", " Hold ", ("predictor", "hold")) == "hold"
    assert one_of("`sampling`", None, ("predictor", "hold"), "predictor") == "predictor"
    with pytest.raises(InvalidArgumentError, match=r"`sampling`: expected one of predictor, hold, got 'sideways'"):
        one_of("`sampling`", "sideways", ("predictor", "hold"))
    with pytest.raises(InvalidArgumentError):
        one_of("`sampling`", None, ("predictor", "hold"))  # no default: None is not a choice
