"""The block-diagonal Brunovsky triple of a multi-index (Dalla Mora, Germani & Manes (2.16)).

Used by the symbolic layer (``geometry``: the form (2.15) of a drift-observable model)
and by gain synthesis (``synthesis.drift_gain``: inequality (2.17)), so it lives here,
below both.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from nlobs._typing import Array
from nlobs.errors import InvalidArgumentError


def positive_multi_index(s: Sequence[int], name: str = "s") -> tuple[int, ...]:
    """``s`` as a non-empty tuple of positive integers (``InvalidArgumentError`` otherwise)."""
    try:
        out = tuple(int(v) for v in s)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"{name}: expected a sequence of positive integers, got {s!r}") from None
    if not out or any(v < 1 for v in out) or any(float(a) != b for a, b in zip(s, out)):
        raise InvalidArgumentError(f"{name}: every entry must be a positive integer (at least 1), got {list(s)}")
    return out


def brunovsky(s: Sequence[int]) -> tuple[Array, Array, Array]:
    """``(A_s, B_s, C_s)`` of Dalla Mora, Germani & Manes (2.16): ``n × n``, ``n × q``, ``q × n`` with ``n = Σ s_j``.

    Block ``j``: ``A_j`` the ``s_j × s_j`` upper shift, ``B_j = e_{s_j}``, ``C_j = e_1ᵀ``.

    Examples
    --------
    The multi-index ``s = (2, 1)``: a chain of two integrators and a single one, each measured at its
    top; the pair ``(A_s, C_s)`` is observable:

    >>> import numpy as np
    >>> A, B, C = brunovsky([2, 1])
    >>> A.tolist()
    [[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    >>> B.tolist(), C.tolist()
    ([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    >>> int(np.linalg.matrix_rank(np.vstack([C, C @ A, C @ A @ A])))
    3
    >>> try:
    ...     brunovsky([2, 0])
    ... except Exception as exc:
    ...     print(type(exc).__name__, "-", exc)
    InvalidArgumentError - s: every entry must be a positive integer (at least 1), got [2, 0]
    """
    s_ = positive_multi_index(s)
    n, q = sum(s_), len(s_)
    A, B, C = np.zeros((n, n)), np.zeros((n, q)), np.zeros((q, n))
    i = 0
    for j, sj in enumerate(s_):
        A[i : i + sj - 1, i + 1 : i + sj] = np.eye(sj - 1)
        B[i + sj - 1, j] = 1.0
        C[j, i] = 1.0
        i += sj
    return A, B, C
