"""Integrity check: RAIM-style leave-one-out fault detection and exclusion (innovation-based FDE).

Residual-based RAIM (Parkinson & Axelrad 1988, Brown 1992) applied to the Kalman innovations
as innovation-based FDE (:func:`leave_one_out_fde`, :func:`window_raim`): the window's mean
innovation of each reflector is fitted to a common pose offset (the pull of a faulty
reflector on the estimate) and the weighted residual sum tested against the chi-square
with ``reflectors - 3`` dof at the false-alarm probability ``raim_false_alarm`` per
check (``"raim"``); leaving each reflector out in turn, the one whose removal makes the
others consistent (``reflectors - 4`` dof, same probability) is excluded once
``raim_confirm`` failing checks have named it, more often than any other
(:class:`RaimEpisode`). The per-reflector NIS test
(:class:`~agvnav.positioning.integrity_nis.ReflectorNis`) misses a moved reflector whose pull
spreads its error over its neighbours (the differential AGV's nearest side reflector moved
0.1 m: the estimate 60-90 mm off with sigma 11 mm, the offender's NIS only ~3x its
neighbours'), and its ratio rule, blind to the pull, excluded sound neighbours of the moved
one: where the RAIM can run (four reflectors or more with EKF innovations) it owns the exclusion.

The RAIM's chi-square holds for untruncated innovations, while the identification gate
keeps only those within 3.3 sigma: a reflector moved by a few sigmas (the differential's
side reflector moved 0.1 m, 10-20 mrad at 4-6 m against ``sqrt(S)`` 3.4-5 mrad) had one
sighting in four accepted -- each a 2-3 sigma innovation that pulled the estimate -- and
the test of those passed while the AGV stayed ``tracking`` 20-26 mm (5 sigma) off for
1-3 s: a reflector moved by a few of its innovation sigmas lands outside its gate on most
revolutions and inside on the others, so the filter and the RAIM saw only the sightings of the
least bias (the gate's truncated tail) -- they still pulled the estimate, while each looked
like a 2-3 sigma innovation. So the estimator also hands the monitor each gated-out reflection that one
reflector not yet seen in the sweep explains within the attribution gate
(:meth:`~agvnav.positioning.integrity.IntegrityMonitor.attribution_gate`, the chi-square
quantile at ``raim_false_alarm``: a sound reflection lies beyond it as rarely as the RAIM may
fail; :meth:`~agvnav.positioning.integrity.IntegrityMonitor.attributed`): one more sighting
for the RAIM, never support of the estimate. A failure that names a reflector is a
measurement fault: it leaves the covariance alone (an inflation widens that reflector's gate
and lets its pull in: a synthetic drive past it ended 120 mm off while degraded); the check
that excludes a reflector inflates it, since the estimate still holds the excluded one's
past pull (:func:`~agvnav.positioning.integrity_verdict.inflates`).
"""
from __future__ import annotations

import functools
import math
from collections import deque
from collections.abc import Collection
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from agvnav.positioning._chi2_table import FALSE_ALARM, QUANTILES_1E5
from agvnav.positioning._integrity_fast import _fde_statistics, mean_innovations, window_fde

__all__ = ["Attributions", "FdeResult", "RaimEpisode", "chi2_threshold", "leave_one_out_fde", "window_raim"]


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


def window_raim(
    innovations: np.ndarray, attributed: Collection[tuple[float, ...]], t: float, window_s: float,
    excluded: tuple[int, ...], map_std: np.ndarray, bearing_var: float, false_alarm: float,
) -> tuple[tuple[int, ...], FdeResult] | None:
    """Innovation-based leave-one-out fault detection and exclusion over the window (:func:`leave_one_out_fde`).

    Each reflector ``k`` accepted in the window contributes the mean ``ybar_k`` of its
    EKF innovations and the mean ``Hbar_k`` of their Jacobian rows (``innovations (N, 6)``:
    ``y, S, H0, H1, H2`` summed per map row and their count, the window's tally). A reflector
    moved from its surveyed place biases its own innovations and, through the estimate it
    pulls, its neighbours' by ``Hbar_k dx``: the means are fitted as ``ybar = Hbar dx``
    (the pull ``dx`` common to the window) and tested with :func:`leave_one_out_fde`.
    Under no fault the innovations are white with variance ``S`` except their survey
    part ``(map_std / d)^2``, constant in time, so ``var(ybar_k) = (map_std / d)^2 +
    (Sbar_k - (map_std / d)^2) / n_k`` over ``n_k`` sightings (``map_std (N,)`` m,
    ``bearing_var`` rad²). The gated-out sightings ``attributed`` to a reflector, rows
    ``(t, map row, y, S, H0, H1, H2)``, count as sightings while within ``window_s`` (s) of
    ``t`` (s) and not ``excluded``. Returns the map rows (in the order of the result's rows)
    and the result, or None with fewer than 4 reflectors (no redundancy) or without
    innovations (not a Kalman filter).
    """
    if attributed:
        innovations = innovations.copy()
        for ta, j, y, s, h0, h1, h2 in attributed:
            if not t - ta > window_s and j not in excluded:
                innovations[int(j)] += (y, s, h0, h1, h2, 1.0)
    found, stats, positive = window_fde(innovations, map_std, bearing_var)
    if len(found) < 4:
        return None
    if not positive:  # leave_one_out_fde names the bad variance (ValueError), as it did
        r, H, var, _ = mean_innovations(innovations, found, map_std, bearing_var)
        return tuple(found.tolist()), leave_one_out_fde(r, H, var, false_alarm)
    return tuple(found.tolist()), _fde_result(stats.tolist(), len(found), 3, false_alarm)


class RaimEpisode:
    """The RAIM's judgement over one failure episode: which reflector it keeps naming.

    ``statistic``: the latest check's statistic over its threshold (NaN before one ran);
    ``ran``: the latest check could run the RAIM (it then owns the exclusion); ``named``:
    the latest check's failure named one reflector (a measurement fault); ``tally``: map row
    -> failing checks of this episode that named it.
    """

    def __init__(self) -> None:
        self.statistic = math.nan
        self.ran = False
        self.named = False
        self.tally: dict[int, int] = {}

    def judge(
        self, t: float, out: tuple[tuple[int, ...], FdeResult] | None, last_failed: float, recover_s: float,
        confirm: int, may_exclude: bool, min_others: int,
    ) -> tuple[list[str], int | None]:
        """``(["raim"] or [], the map row to exclude or None)`` at ``t`` (s) for ``out`` (:func:`window_raim`).

        One failure episode (until the verdict could recover: ``recover_s`` (s) after the
        last held failure ``last_failed``) tallies the reflector each failing check names; the
        first to be named ``confirm`` times, and more often than any other, is excluded when
        ``may_exclude`` (fewer than ``max_excluded`` so far) and at least ``min_others``
        reflectors of the check remain (reflectors along one wall are confused with each other
        on some checks: a moved one is named most often, not every time).
        """
        self.ran = out is not None
        if out is None or not out[1].detected:
            # a passing check right after an inflation sees few sightings: the tally is
            # forgotten only once the verdict could recover
            if t - last_failed >= recover_s:
                self.tally.clear()
            if out is not None:
                self.statistic = out[1].statistic / out[1].threshold
            return [], None
        rows, res = out
        self.statistic = res.statistic / res.threshold
        if res.faulty < 0:
            return ["raim"], None
        self.named = True
        j = rows[res.faulty]
        tally = self.tally
        tally[j] = tally.get(j, 0) + 1
        if (tally[j] >= confirm and all(n < tally[j] for k, n in tally.items() if k != j)
                and may_exclude and len(rows) - 1 >= min_others):
            tally.clear()
            return ["raim"], j
        return ["raim"], None


#: One attributed reflection: ``(t, map row, y, S, H0, H1, H2)`` (s, -, rad, rad², the bearing Jacobian row).
Attributed = tuple[float, int, float, float, float, float, float]


class Attributions:
    """The gated-out reflections attributed to one reflector, oldest first (:attr:`rows`), for the RAIM only.

    A reflection the identification gate rejected that exactly one reflector, not yet seen in
    the sweep, explains within the attribution gate (module docstring): one more sighting of
    that reflector for :func:`window_raim` and the common offset, never support of the estimate.
    """

    def __init__(self) -> None:
        self.rows: deque[Attributed] = deque()

    def add(self, t: float, index: int, innovation: tuple[float, float, float, float, float], window_s: float) -> None:
        """One attribution at ``t`` (s) to map row ``index`` with its ``(y, S, H0, H1, H2)``; those older than
        ``window_s`` (s) are dropped."""
        y, s, h0, h1, h2 = (float(v) for v in innovation)
        self.rows.append((float(t), int(index), y, s, h0, h1, h2))
        while self.rows and t - self.rows[0][0] > window_s:
            self.rows.popleft()

    def void(self, t: float, j: int, sweep_s: float) -> None:
        """Forget the attributions to map row ``j`` within ``sweep_s`` (s) before ``t`` (s): an acceptance of
        the same reflector in the sweep makes them spurious reflections next to a sound reflector."""
        if any(a[1] == j and t - a[0] < sweep_s for a in self.rows):
            self.rows = deque(a for a in self.rows if not (a[1] == j and t - a[0] < sweep_s))
