"""The frequency response of a linear observer's error dynamics: what LMIs (14) and (15) bound, drawn.

Grip, Saberi & Johansen design the gain ``K`` of the linear part so that ``H(s) = (sI − 𝔄 + Kℭ)⁻¹ 𝔅_d`` (13), from
the interconnection's disturbance to the error, has ``‖H‖∞ < γ`` (LMI (14)), and, with noise, ``G(s) = −(sI − 𝔄 +
Kℭ)⁻¹ K N`` from the measurement noise to the error ``‖G‖∞ ≤ γn`` (LMI (15)). :func:`error_response` evaluates their
largest singular values on a frequency grid; :func:`bode_figure` draws them with ``γ``, ``γn`` and each peak (the
cascade design writes it as ``bode.png`` beside its simulation). Matplotlib is imported by the figure only.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from nlobs._io import save_figure
from nlobs._typing import Array
from nlobs.errors import DimensionError, InvalidArgumentError

__all__ = ["bode_figure", "error_response", "frequency_grid"]


def frequency_grid(F: ArrayLike, points: int = 400) -> Array:
    """Frequencies [rad per time unit] two decades either side of the moduli of ``F``'s eigenvalues.

    Parameters
    ----------
    F : array_like, shape (n, n)
        The error dynamics' matrix ``𝔄 − Kℭ``.
    points : int
        Grid size.

    Returns
    -------
    ndarray, shape (points,)
        Logarithmically spaced.
    """
    lam = np.abs(np.linalg.eigvals(np.asarray(F, dtype=float)))
    lam = lam[lam > 0]
    lo, hi = (float(lam.min()), float(lam.max())) if lam.size else (1.0, 1.0)
    return np.logspace(np.log10(lo) - 2.0, np.log10(hi) + 2.0, int(points))


def error_response(F: ArrayLike, B: ArrayLike, omega: ArrayLike) -> Array:
    """``σ_max((jωI − F)⁻¹ B)`` at each frequency: the gain from ``B``'s input to the error ``e`` of ``ė = F e + B w``.

    Parameters
    ----------
    F : array_like, shape (n, n)
        ``𝔄 − Kℭ``.
    B : array_like, shape (n, q)
        ``𝔅_d`` (for ``H`` (13)) or ``−K N`` (for ``G``).
    omega : array_like, shape (W,)
        Frequencies.

    Returns
    -------
    ndarray, shape (W,)

    Raises
    ------
    DimensionError
        ``F`` not square or ``B`` of other rows.

    Examples
    --------
    A first-order error ``ė = −a e + w``: ``|H(jω)| = 1/√(ω² + a²)``.

    >>> import numpy as np
    >>> g = error_response([[-2.0]], [[1.0]], [0.0, 2.0])
    >>> np.allclose(g, [0.5, 1 / np.sqrt(8.0)])
    True
    """
    Fm, Bm = np.asarray(F, dtype=float), np.asarray(B, dtype=float)
    if Fm.ndim != 2 or Fm.shape[0] != Fm.shape[1] or Bm.ndim != 2 or Bm.shape[0] != Fm.shape[0]:
        raise DimensionError(f"F of shape {Fm.shape} and B of shape {Bm.shape}: expected (n, n) and (n, q)")
    w = np.asarray(omega, dtype=float).reshape(-1)
    n = Fm.shape[0]
    M = 1j * w[:, None, None] * np.eye(n) - Fm  # (W, n, n)
    T = np.linalg.solve(M, np.broadcast_to(Bm.astype(complex), (w.size, *Bm.shape)))
    return np.linalg.svd(T, compute_uv=False)[:, 0] if Bm.shape[1] else np.zeros(w.size)


def bode_figure(F: ArrayLike, Bd: ArrayLike, *, gamma: float | None = None, KN: ArrayLike | None = None,
                gamma_n: float | None = None, time_unit: str = "s", title: str = "",
                path: str | Path | None = None) -> Any:
    """The largest singular value of ``H(jω)`` (13) and, with ``KN``, of ``G(jω)``, against ω (log-log), with the
    bounds ``γ``, ``γn`` of LMIs (14), (15) and each curve's peak marked.

    Parameters
    ----------
    F : array_like, shape (n, n)
        ``𝔄 − Kℭ`` (Hurwitz).
    Bd : array_like, shape (n, q)
        ``𝔅_d``.
    gamma : float, optional
        The bound of ``‖H‖∞``.
    KN : array_like, shape (n, r), optional
        ``K N`` (``G = −(sI − F)⁻¹ K N``).
    gamma_n : float, optional
        The bound of ``‖G‖∞``.
    time_unit : str
        The model's time unit (ω in rad per it).
    title : str
        The figure's title.
    path : str or Path, optional
        Write the figure there (PNG, atomically).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    InvalidArgumentError
        ``F`` is not Hurwitz (no frequency response bounds an unstable error).
    """
    from matplotlib.figure import Figure

    Fm = np.asarray(F, dtype=float)
    if not np.all(np.isfinite(Fm)) or float(np.max(np.linalg.eigvals(Fm).real)) >= 0.0:
        raise InvalidArgumentError("F: 𝔄 − Kℭ is not Hurwitz, so the error has no frequency response to bound")
    w = frequency_grid(Fm)
    fig = Figure(figsize=(8.0, 4.2), layout="constrained")
    ax = fig.subplots()
    curves = [("H", "‖H(jω)‖ (13): disturbance → error", Bd, gamma, "C0")]
    if KN is not None:
        curves.append(("G", "‖G(jω)‖: measurement noise → error", -np.asarray(KN, dtype=float), gamma_n, "C1"))
    for key, label, B, bound, colour in curves:
        g = error_response(Fm, B, w)
        k = int(np.argmax(g))
        ax.loglog(w, g, color=colour, lw=1.6, label=f"{label}; peak {g[k]:.3g} at ω = {w[k]:.3g}")
        ax.plot([w[k]], [g[k]], "o", color=colour, ms=5)
        if bound is not None and np.isfinite(bound):
            ax.axhline(bound, color=colour, ls="--", lw=1.0,
                       label=f"{'γ' if key == 'H' else 'γn'} = {bound:.3g} (LMI {'(14)' if key == 'H' else '(15)'})")
    ax.set_xlabel(f"ω [rad/{time_unit}]")
    ax.set_ylabel("largest singular value")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(title or "Error dynamics of the linear part (Grip, Saberi & Johansen)", fontsize="medium")
    if path is not None:
        save_figure(fig, Path(path))
    return fig
