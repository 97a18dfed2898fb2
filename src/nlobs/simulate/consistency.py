"""Filter consistency over Monte Carlo runs: NEES and NIS against their χ² bands.

A Kalman filter is consistent when its covariance describes its error: the normalised estimation error squared
``NEES = eᵀ P⁻¹ e`` of ``n`` states is χ²(n), the normalised innovation squared ``NIS = νᵀ S⁻¹ ν`` of ``d``
measured outputs is χ²(d). Over ``N`` independent runs the sums are χ²(N n) and χ²(Σ d); divided by their degrees
of freedom they scatter about 1 inside the two-sided band of the level asked (Bar-Shalom, Li & Kirubarajan,
*Estimation with Applications to Tracking and Navigation*, Sec. 5.4.2). :func:`filter_consistency` reads them from
a filter's :class:`~nlobs.simulate.result.SimulationResult`: ``P`` (or, without it, no NEES) and ``nis`` among the
extras that :class:`~nlobs.observers.gaussian.GaussianFilter` records, the NIS at the saved instants where a sample
arrived, each run with the number of its outputs sampled there and finite.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from nlobs._schema import INTEGER, NUMBER, Record, array, nullable
from nlobs._typing import Array
from nlobs._validate import in_range

__all__ = ["Consistency", "chi2_band", "error_consistency", "filter_consistency"]


def chi2_band(dof: Any, level: float = 0.95) -> tuple[Array, Array]:
    """The two-sided band of a χ²(dof) variable divided by ``dof``, with probability ``level`` inside.

    Parameters
    ----------
    dof : array_like of int
        Degrees of freedom (positive).
    level : float
        In (0, 1).

    Returns
    -------
    (ndarray, ndarray)
        Lower and upper ends, shaped like ``dof``.

    Examples
    --------
    >>> lo, hi = chi2_band(100)
    >>> round(float(lo), 3), round(float(hi), 3)
    (0.742, 1.296)
    """
    from scipy.stats import chi2

    d = np.asarray(dof, dtype=float)
    a = 0.5 * (1.0 - in_range("level", level, 0.0, 1.0, lo_open=True, hi_open=True))
    return chi2.ppf(a, d) / d, chi2.ppf(1.0 - a, d) / d


@dataclass(frozen=True)
class Consistency:
    """NEES and NIS of a filter over its runs, each divided by its degrees of freedom, with the χ² band.

    Attributes
    ----------
    runs : int
        Runs that count (every estimate finite).
    level : float
        Probability inside the band (0.95).
    t : ndarray, shape (K,)
        The saved instants (NEES).
    nees : ndarray, shape (K,) or None
        ``Σ_r NEES_r / (N n)`` (``None``: no covariance recorded).
    nees_band : (float, float)
        Its band (the same at every instant).
    t_nis : ndarray, shape (M,)
        The saved instants where samples arrived.
    nis, nis_lo, nis_hi : ndarray, shape (M,)
        ``Σ_r NIS_r / Σ_r d_r`` and its band (``d_r``: outputs sampled and finite in run ``r``).
    nees_inside, nis_inside : float
        Fraction of the instants whose average lies inside its band (about ``level`` when consistent; NaN when
        there is none).
    """

    runs: int
    level: float
    t: Array
    nees: Array | None
    nees_band: tuple[float, float]
    t_nis: Array
    nis: Array
    nis_lo: Array
    nis_hi: Array
    nees_inside: float
    nis_inside: float

    def to_dict(self) -> dict[str, Any]:
        """The fractions inside the band and the averages (the JSON's ``consistency``)."""
        return CONSISTENCY_JSON.emit({"runs": self.runs, "level": self.level,
                "nees_inside": None if self.nees is None else self.nees_inside,
                "nees_mean": None if self.nees is None else float(np.mean(self.nees)),
                "nees_band": None if self.nees is None else list(self.nees_band),
                "nis_inside": self.nis_inside if self.nis.size else None,
                "nis_mean": float(np.mean(self.nis)) if self.nis.size else None,
                "nis_instants": int(self.nis.size)})


#: The JSON of a :class:`Consistency` (``consistency`` of ``nlobs simulate MODEL``).
CONSISTENCY_JSON = Record("Consistency", {
    "runs": INTEGER.about("the runs that did not diverge"),
    "level": NUMBER.about("probability inside the band"),
    "nees_inside": NUMBER.about("fraction of instants with the mean NEES inside the band (null: not recorded)"),
    "nees_mean": NUMBER.about("mean NEES divided by the degrees of freedom (about 1)"),
    "nees_band": nullable(array(NUMBER), "the band of the mean NEES divided by the degrees of freedom"),
    "nis_inside": NUMBER,
    "nis_mean": NUMBER,
    "nis_instants": INTEGER,
}, description="NEES and NIS of a filter against the two-sided chi-square band (Bar-Shalom, Li & Kirubarajan, "
               "Sec. 5.4.2).")


def filter_consistency(result: Any, *, level: float = 0.95) -> Consistency | None:
    """NEES and NIS of a filter's Monte Carlo runs (module docstring); ``None`` for a result without ``nis``.

    Parameters
    ----------
    result : SimulationResult
        A batch of runs of a filter that records ``nis`` (and ``P`` for the NEES), with the truth.
    level : float
        Probability inside the band.

    Returns
    -------
    Consistency or None

    Examples
    --------
    Runs of a perfectly consistent "filter": the error drawn from its covariance.

    >>> import numpy as np
    >>> from nlobs.simulate.result import SimulationResult
    >>> rng = np.random.default_rng(0)
    >>> N, K = 200, 50
    >>> P = np.broadcast_to(np.diag([1.0, 4.0]), (N, K, 2, 2))
    >>> x = np.zeros((N, K, 2)); xh = rng.normal(0.0, [1.0, 2.0], (N, K, 2))
    >>> res = SimulationResult(t=np.arange(K) * 0.1, x=x, x_hat=xh, y=None, sampled=None, states=("a", "b"),
    ...                        outputs=(), estimates=("a", "b"), dt=0.1, method="rk4",
    ...                        extras={"P": P, "nis": np.zeros((N, K))})
    >>> c = filter_consistency(res)
    >>> bool(0.85 < c.nees_inside <= 1.0), bool(abs(float(np.mean(c.nees)) - 1.0) < 0.05)
    (True, True)
    """
    extras = result.extras
    if "nis" not in extras or result.x is None:
        return None
    e = np.asarray(result.x_hat, dtype=float) - np.asarray(result.x, dtype=float)
    return error_consistency(result.t, e, extras.get("P"), extras["nis"], result.sampled, result.y, level=level)


def error_consistency(t: Array, e: Array, P: Array | None, nis: Array, sampled: Array | None, y: Array | None, *,
                      level: float = 0.95) -> Consistency:
    """NEES and NIS of a filter's runs from its errors, covariances and innovations (what
    :func:`filter_consistency` computes from a result; a filter whose error lives in another space than its
    estimate, the navigation EKF's error state, calls it with that error).

    Parameters
    ----------
    t : ndarray, shape (K,)
        The saved instants.
    e : ndarray, shape (..., K, n)
        The estimation error at them, in the coordinates of ``P``.
    P : ndarray, shape (..., K, n, n), or None
        The filter's covariance at the same instants (``None``: no NEES).
    nis : ndarray, shape (..., K)
        The normalised innovation squared of the last correction at each instant.
    sampled : ndarray of bool, shape (K, q), or None
        The outputs sampled at each instant.
    y : ndarray, shape (..., K, q), or None
        The samples (NaN: missing, not counted).
    level : float
        Probability inside the band.

    Returns
    -------
    Consistency
    """
    e = np.asarray(e, dtype=float)
    batch = e.shape[:-2]
    K, n = e.shape[-2:]
    e = e.reshape(-1, K, n)
    ok = np.isfinite(e).all(axis=(1, 2))
    runs = int(ok.sum())
    nan_ = float("nan")
    if runs == 0:
        return Consistency(0, level, t, None, (nan_, nan_), np.zeros(0), np.zeros(0), np.zeros(0),
                           np.zeros(0), nan_, nan_)
    e = e[ok]
    nees = None
    band = (nan_, nan_)
    inside_nees = nan_
    if P is not None:
        P = np.broadcast_to(np.asarray(P, dtype=float), (*batch, K, n, n)).reshape(-1, K, n, n)[ok]
        with np.errstate(all="ignore"):
            try:
                q = np.einsum("rki,rki->rk", e, np.linalg.solve(P, e[..., None])[..., 0])
            except np.linalg.LinAlgError:  # a singular covariance somewhere: those instants are not counted
                q = np.full(e.shape[:2], np.nan)
        nees = np.sum(q, axis=0) / (runs * n)
        lo, hi = chi2_band(runs * n, level)
        band = (float(lo), float(hi))
        good = np.isfinite(nees)
        inside_nees = float(np.mean((nees[good] >= lo) & (nees[good] <= hi))) if good.any() else nan_
    nis = np.broadcast_to(np.asarray(nis, dtype=float), (*batch, K)).reshape(-1, K)[ok]
    t_nis, m_nis, lo_nis, hi_nis = np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0)
    inside_nis = nan_
    if sampled is not None and y is not None and np.any(sampled):
        sampled = np.asarray(sampled, dtype=bool)
        y = np.broadcast_to(np.asarray(y, dtype=float), (*batch, K, sampled.shape[-1])).reshape(
            -1, K, sampled.shape[-1])[ok]
        dof = np.sum(sampled[None] & np.isfinite(y), axis=-1)  # (runs, K): outputs each run used at each instant
        rows = np.flatnonzero(sampled.any(axis=-1) & (dof.sum(axis=0) > 0))
        d = dof[:, rows]
        total = d.sum(axis=0)
        m_nis = np.sum(np.where(d > 0, nis[:, rows], 0.0), axis=0) / total
        lo_nis, hi_nis = chi2_band(total, level)
        t_nis = np.asarray(t)[rows]
        fin = np.isfinite(m_nis)
        inside_nis = float(np.mean((m_nis[fin] >= lo_nis[fin]) & (m_nis[fin] <= hi_nis[fin]))) if fin.any() else nan_
    return Consistency(runs, float(level), np.asarray(t), nees, band, t_nis, m_nis, lo_nis, hi_nis, inside_nees,
                       inside_nis)
