"""Integrity check: RAIM-style leave-one-out fault detection and exclusion (innovation-based FDE).

:func:`leave_one_out_fde` fits the window's mean innovations per reflector and tests the fit
and each leave-one-out fit against chi-square quantiles (:func:`chi2_threshold`);
:meth:`agvnav.positioning.integrity.IntegrityMonitor.raim` feeds it (module docstring of
:mod:`agvnav.positioning.integrity`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from agvnav.positioning._chi2_table import FALSE_ALARM, QUANTILES_1E5
from agvnav.positioning._integrity_fast import _fde_statistics

__all__ = ["FdeResult", "chi2_threshold", "leave_one_out_fde"]


@dataclass(frozen=True)
class FdeResult:
    """Outcome of :func:`leave_one_out_fde` (statistics are chi-square distributed under no fault).

    ``statistic``: weighted sum of squared residuals of the fit of all the rows, ``dof``
    its degrees of freedom (rows - states), ``threshold`` its upper ``1 - false_alarm``
    quantile; ``detected``: ``statistic > threshold``. ``without[k]``: the statistic of
    the fit without row ``k`` (``dof - 1`` degrees of freedom, NaN when that leaves no
    redundancy), ``exclusion_threshold`` its bound; ``faulty``: the row whose removal
    leaves the others consistent (the smallest ``without`` below its bound), -1 if none
    or nothing was detected.
    """

    statistic: float
    dof: int
    threshold: float
    detected: bool
    without: tuple[float, ...]
    exclusion_threshold: float
    faulty: int


def chi2_threshold(dof: int, false_alarm: float) -> float:
    """Upper quantile of a chi-square with ``dof`` degrees of freedom exceeded with probability ``false_alarm``.

    scipy's ``chi2.isf``: from a table for the RAIM's default 1e-5
    (:mod:`agvnav.positioning._chi2_table`, the same bits), else computed once per
    ``(dof, false_alarm)`` and kept: the RAIM asks for the same few quantiles at every check (issue 11).
    """
    if dof < 1:
        raise ValueError(f"dof must be >= 1, got {dof!r}")
    if not 0.0 < false_alarm < 1.0:
        raise ValueError(f"false_alarm must be in (0, 1), got {false_alarm!r}")
    if false_alarm == FALSE_ALARM and dof <= len(QUANTILES_1E5):
        return QUANTILES_1E5[dof - 1]  # the RAIM's default: no scipy.stats import (half a second)
    key = (int(dof), float(false_alarm))
    value = _CHI2_QUANTILES.get(key)
    if value is None:
        from scipy.stats import chi2  # noqa: PLC0415 - heavy third-party import, deferred (issue 11)

        value = _CHI2_QUANTILES[key] = float(chi2.isf(key[1], key[0]))
    return value


_CHI2_QUANTILES: dict[tuple[int, float], float] = {}


def _chi2_3dof_sf(x: float) -> float:
    """Survival function of the chi-square with 3 dof: ``erfc(sqrt(x/2)) + sqrt(2x/pi) exp(-x/2)``."""
    return math.erfc(math.sqrt(0.5 * x)) + math.sqrt(2.0 * x / math.pi) * math.exp(-0.5 * x)


@functools.lru_cache(maxsize=8)
def _chi2_3dof_isf(p: float) -> float:
    """Upper ``p`` quantile of the chi-square with 3 dof (bisection on the closed form; no scipy import)."""
    lo, hi = 0.0, 1.0
    while _chi2_3dof_sf(hi) > p:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _chi2_3dof_sf(mid) > p:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-12 * hi:
            break
    return 0.5 * (lo + hi)


def leave_one_out_fde(
    residuals: ArrayLike, jacobian: ArrayLike, variances: ArrayLike, false_alarm: float
) -> FdeResult:
    """Fault detection and exclusion over one set of independent measurements (RAIM).

    Residual-based RAIM (Parkinson & Axelrad 1988; Brown 1992, "A baseline GPS RAIM
    scheme", with the leave-one-out / solution-separation exclusion of Brown & McBurney
    1988; applied to Kalman innovations as innovation-based FDE, Joerger & Pervan 2013):
    the residuals ``r (n,)`` of the measurements about a linearisation point, their
    Jacobian ``H (n, m)`` with respect to the ``m`` states and their independent
    ``variances (n,)`` are fitted by weighted least squares; the weighted sum of the
    squared fit residuals is chi-square with ``n - m`` degrees of freedom when every
    measurement is sound. Above its ``1 - false_alarm`` quantile a fault is *detected*;
    each row is then left out in turn, and the row whose removal leaves the others
    consistent (their statistic, ``n - m - 1`` dof, below the same-probability bound;
    the smallest when several do) is the faulty one. A probability of a false exclusion
    given a detection is not bounded here: the caller confirms it over several checks.

    Units are the caller's (here rad and rad²). Raises ValueError on mismatched shapes,
    non-positive variances, or fewer rows than ``m + 1``.
    """
    r = np.asarray(residuals, dtype=np.float64).reshape(-1)
    H = np.asarray(jacobian, dtype=np.float64)
    v = np.asarray(variances, dtype=np.float64).reshape(-1)
    n = r.shape[0]
    if H.ndim != 2 or H.shape[0] != n or v.shape != (n,):
        raise ValueError(f"jacobian must be ({n}, m) and variances ({n},), got {H.shape} and {v.shape}")
    m = H.shape[1]
    if n <= m:
        raise ValueError(f"leave_one_out_fde needs more rows than states ({m}), got {n}")
    if not (np.all(np.isfinite(v)) and np.all(v > 0.0)):
        raise ValueError("variances must be positive and finite")
    w = 1.0 / v
    h = np.ascontiguousarray(H).reshape(-1)
    return _fde_result(_fde_statistics(r, h, w, m).tolist(), n, m, false_alarm)


def _fde_result(stats: list[float], n: int, m: int, false_alarm: float) -> FdeResult:
    """:class:`FdeResult` of ``n`` rows and ``m`` states from their fits' statistics (:func:`_fde_statistics`)."""
    dof = n - m
    stat = stats[0]
    thr = chi2_threshold(dof, false_alarm)
    detected = bool(stat > thr)
    without = [math.nan] * n
    thr_x = chi2_threshold(dof - 1, false_alarm) if dof >= 2 else math.nan
    faulty = -1
    if dof >= 2:
        without = stats[1:]
        if detected:
            ok = [(without[k], k) for k in range(n) if without[k] <= thr_x]
            if ok:
                faulty = min(ok)[1]
    return FdeResult(float(stat), dof, thr, detected, tuple(without), thr_x, faulty)
