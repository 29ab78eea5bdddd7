"""Integrity of a streaming estimate: is the reported pose trustworthy? (issue 12 §1)

:class:`IntegrityMonitor` watches what supports the estimate and turns it into a verdict
(``"ok"``, ``"degraded"``, ``"lost"``) and a 0-1 quality figure, as commercial reflector
navigators report one:

* consistency of the recent innovations: the windowed NIS ``sum y_i^2 / S_i`` of the
  accepted bearings of the last ``window_s`` seconds against the upper
  ``nis_confidence`` quantile of a chi-square with as many degrees of freedom (a
  consistent filter's innovations are white with variance ``S`` [seed002 eq14]);
* the fraction of reflections the gate rejected in the window: above
  ``max_reject_fraction`` (and at least ``min_rejections``) the true reflectors no longer
  fall into their gates -- the estimate has moved off (a lost odometry stretch) -- while
  clutter alone, spurious reflections at random bearings, stays below it;
* the fraction of the reflectors in range (by the map) that the window's accepted
  reflections explain: below ``min_explained_fraction`` the estimate explains only a
  few of them, the signature of a pose that has locked onto a wrong but self-consistent
  subset (an odometry dropout leaves one "tracking" 0.2-0.7 m off on 3 of 9 reflectors);
* the number and geometry of the reflectors that supported the recent fixes: at least
  ``min_reflectors`` distinct ones in the window, and a best achievable position error
  ``PDOP * bearing_std`` (:func:`~agvnav.positioning.bounds.pdop`, the CRLB of seed 000
  §2.3) below ``max_fix_std_m``;
* a cross-check against an independent triangulation when three distinct reflectors
  were seen in the last revolution: their bearings are brought to one instant through
  the odometry (the angle propagation of seed 000 §2.2) and triangulated with ToTal
  (:func:`~agvnav.positioning.triangulate`, ``valid=False`` near the critical circle);
  the fix and the estimate must agree within the chi-square bound of their summed
  covariances, or within ``crosscheck_min_m`` (the check looks for gross errors such as
  a wrong association; a fixed survey error of the three reflectors can bias one triple's
  fix by a few sigma while the filter, averaging every reflector, stays consistent).

The survey error of the reflectors is constant in time, so a filter that takes it as
white bearing noise averages it away and ends overconfident (issue 12: NEES 13 with a
5 mm survey error). :attr:`IntegrityMonitor.survey_floor` is the covariance of a static
fix from the reflectors used when each bearing errs only by its reflector's survey
error, ``(map_std / d)^2`` (the CRLB of seed 000 §2.3 with that std): the part of the
error no averaging removes, which the estimator adds to the covariance it reports.

A failed check makes the verdict ``degraded`` and asks the estimator to inflate its
covariance (the estimate says it is less sure); a verdict ``degraded`` for longer than
``lost_after_s``, or a position or heading uncertainty beyond what the bearing gate
can identify reflectors with (``lost_position_std_m``, ``lost_heading_std_rad``), makes
it ``lost``: the estimator then stops correcting and relocalises.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from agvnav.geometry.se2 import between, compose
from agvnav.positioning.bounds import crlb, pdop
from agvnav.positioning.identification import bearing_model
from agvnav.positioning.triangulation import triangulate

__all__ = ["CHI2_2DOF_999", "IntegrityLimits", "IntegrityMonitor", "chi2_upper"]

#: Chi-square quantile, 2 dof, 0.999: agreement bound of the triangulation cross-check.
CHI2_2DOF_999 = 13.815510557964274

#: Normal quantiles of the supported confidences, for :func:`chi2_upper`.
_Z = {0.95: 1.6448536269514722, 0.99: 2.3263478740408408, 0.999: 3.090232306167813}


#: Exact 1-dof quantiles (the square of the two-sided normal quantile).
_CHI2_1DOF = {0.95: 3.841458820694124, 0.99: 6.634896601021214, 0.999: 10.827566170662733}


def chi2_upper(dof: int, confidence: float = 0.999) -> float:
    """Upper ``confidence`` quantile of a chi-square with ``dof`` degrees of freedom.

    Wilson-Hilferty cube-root approximation, ``dof (1 - a + z sqrt(a))^3`` with
    ``a = 2 / (9 dof)`` and ``z`` the normal quantile (within 2 % of the exact value
    from 3 dof on; the 1- and 2-dof values are exact). ``confidence`` is 0.95, 0.99 or 0.999.
    """
    if dof < 1:
        raise ValueError(f"dof must be >= 1, got {dof!r}")
    if confidence not in _Z:
        raise ValueError(f"confidence must be one of {sorted(_Z)}, got {confidence!r}")
    z = _Z[confidence]
    if dof == 1:
        return _CHI2_1DOF[confidence]
    if dof == 2:
        return -2.0 * math.log(1.0 - confidence)
    a = 2.0 / (9.0 * dof)
    return dof * (1.0 - a + z * math.sqrt(a)) ** 3


@dataclass(frozen=True)
class IntegrityLimits:
    """Thresholds of :class:`IntegrityMonitor` (lengths m, angles rad, times s).

    ``enabled=False`` keeps the figures (quality, NIS ratio...) but never leaves ``"ok"``.
    """

    window_s: float = 1.0
    nis_confidence: float = 0.999
    min_reflectors: int = 3
    max_fix_std_m: float = 0.05
    crosscheck_bound: float = CHI2_2DOF_999
    crosscheck_min_m: float = 0.05
    max_reject_fraction: float = 0.75
    min_rejections: int = 8
    min_explained_fraction: float = 0.5
    lost_after_s: float = 5.0
    lost_position_std_m: float = 0.3
    lost_heading_std_rad: float = 0.1
    inflation: float = 4.0
    enabled: bool = True

    def __post_init__(self) -> None:
        if not 0.0 <= self.min_explained_fraction <= 1.0:
            raise ValueError(f"min_explained_fraction must be in [0, 1], got {self.min_explained_fraction!r}")
        if not 0.0 < self.max_reject_fraction <= 1.0:
            raise ValueError(f"max_reject_fraction must be in (0, 1], got {self.max_reject_fraction!r}")
        for name in ("window_s", "max_fix_std_m", "crosscheck_bound", "crosscheck_min_m", "lost_after_s",
                     "lost_position_std_m",
                     "lost_heading_std_rad"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        if not self.inflation >= 1.0:
            raise ValueError(f"inflation must be >= 1, got {self.inflation!r}")
        if self.min_reflectors < 1:
            raise ValueError(f"min_reflectors must be >= 1, got {self.min_reflectors!r}")
        chi2_upper(1, self.nis_confidence)


@dataclass(frozen=True)
class _Entry:
    t: float
    nis: float
    index: int
    bearing: float  # edge bearing in the head frame (rad)
    odom: tuple[float, float, float]  # odometric base_link pose at t


class IntegrityMonitor:
    """Verdict and quality of a streaming estimate from its recent support (module docstring).

    Parameters
    ----------
    reflector_xy, reflector_radius:
        ``(N, 2)`` map centres (m) and ``(N,)`` radii (m).
    mount:
        ``(3,)`` head pose in base_link (m, m, rad).
    bearing_std:
        Std (rad) of one bearing.
    map_std:
        Survey std (m) of a reflector position, one for all or ``(N,)`` one per reflector:
        a bearing at distance d gets the variance ``bearing_std^2 + (map_std / d)^2``.
    revolution_s:
        Duration (s) of one head revolution.
    max_range:
        Reflectors farther than this (m) are not expected to be seen.
    limits:
        The thresholds.

    Attributes
    ----------
    verdict : ``"ok"``, ``"degraded"`` or ``"lost"``.
    quality : 0-1 figure (0 when lost).
    reflectors_used : distinct reflectors accepted in the window.
    nis_ratio : windowed NIS over its chi-square bound (< 1 consistent; NaN without data).
    crosscheck : Mahalanobis distance² of the latest triangulation cross-check (NaN if none).
    survey_floor : ``(3, 3)`` covariance (m², m·rad, rad²) of the survey error of the
        reflectors used (zero without ``map_std`` or support).
    reasons : why the last check failed (empty when it passed).
    """

    def __init__(
        self,
        reflector_xy: ArrayLike,
        reflector_radius: ArrayLike,
        mount: ArrayLike,
        bearing_std: float,
        revolution_s: float,
        limits: IntegrityLimits | None = None,
        map_std: ArrayLike = 0.0,
        max_range: float = math.inf,
    ) -> None:
        self.xy = np.asarray(reflector_xy, dtype=np.float64).reshape(-1, 2)
        self.radius = np.asarray(reflector_radius, dtype=np.float64).reshape(-1)
        self.mount = np.asarray(mount, dtype=np.float64).reshape(3)
        self.bearing_std = float(bearing_std)
        self.map_std = np.broadcast_to(np.asarray(map_std, dtype=np.float64), self.radius.shape)
        self.max_range = float(max_range)
        self.revolution_s = float(revolution_s)
        self.limits = IntegrityLimits() if limits is None else limits
        self._entries: deque[_Entry] = deque()
        self._rejects: deque[float] = deque()
        self.reset()

    def reset(self) -> None:
        """Forget the support (after a relocalisation or a fresh start)."""
        self._entries.clear()
        self._rejects.clear()
        self.verdict = "ok"
        self.quality = 0.0
        self.reflectors_used = 0
        self.nis_ratio = math.nan
        self.crosscheck = math.nan
        self.reasons: tuple[str, ...] = ()
        self.survey_floor = np.zeros((3, 3))
        self._degraded_since: float | None = None
        self._last_check = -math.inf
        self._since: float | None = None  # first check after the reset

    def accepted(self, t: float, nis: float, index: int, bearing: float, odom: tuple[float, ...]) -> None:
        """One accepted reflection at ``t`` (s): its NIS, reflector row, edge bearing (rad), odometric pose."""
        self._entries.append(_Entry(t, float(nis), int(index), float(bearing), (odom[0], odom[1], odom[2])))
        while self._entries and t - self._entries[0].t > self.limits.window_s:
            self._entries.popleft()

    @property
    def used(self) -> tuple[int, ...]:
        """Map rows of the distinct reflectors accepted in the window, ascending."""
        return tuple(sorted({e.index for e in self._entries}))

    def rejected(self, t: float) -> None:
        """One reflection at ``t`` (s) that the gate rejected (spurious, ambiguous or off its prediction)."""
        self._rejects.append(t)
        while self._rejects and t - self._rejects[0] > self.limits.window_s:
            self._rejects.popleft()

    def due(self, t: float) -> bool:
        """True once per head revolution: time for :meth:`check`."""
        return t - self._last_check >= self.revolution_s

    def check(
        self, t: float, pose: ArrayLike, P: ArrayLike, odom: tuple[float, ...], dead_reckoning: bool
    ) -> bool:
        """Judge the estimate ``pose (3,)``, ``P (3, 3)`` at ``t`` (s); True when ``P`` should be inflated.

        ``odom`` is the odometric pose now; ``dead_reckoning`` that the estimator has
        had no accepted reflection for a while (the support checks are then moot and
        only the uncertainty can make the verdict ``lost``).
        """
        self._last_check = t
        x = np.asarray(pose, dtype=np.float64)
        cov = np.asarray(P, dtype=np.float64)
        while self._entries and t - self._entries[0].t > self.limits.window_s:
            self._entries.popleft()
        if self._since is None:
            self._since = t
        young = t - self._since < self.limits.window_s  # no full window of support yet
        reasons = [] if dead_reckoning else self._support_failures(t, x, cov, odom, young)
        reasons += self._uncertainty_failures(cov)
        self.reasons = tuple(reasons) if self.limits.enabled else ()
        reasons = list(self.reasons)
        return self._judge(t, reasons)

    # ------------------------------------------------------------------ checks
    def _support_failures(
        self, t: float, x: np.ndarray, P: np.ndarray, odom: tuple[float, ...], young: bool
    ) -> list[str]:
        lim = self.limits
        entries = list(self._entries)
        used = sorted({e.index for e in entries})
        self.reflectors_used = len(used)
        self.survey_floor = self._survey_floor(x, used)
        out: list[str] = []
        if entries:
            total = sum(e.nis for e in entries)
            self.nis_ratio = total / chi2_upper(len(entries), lim.nis_confidence)
            if self.nis_ratio > 1.0:
                out.append("nis")
        while self._rejects and t - self._rejects[0] > lim.window_s:
            self._rejects.popleft()
        n_rej = len(self._rejects)
        if n_rej >= lim.min_rejections and n_rej > lim.max_reject_fraction * (n_rej + len(entries)):
            out.append("rejections")
        if not young and self._explained(x, len(used)) < lim.min_explained_fraction:
            out.append("unexplained")
        if len(used) < lim.min_reflectors:
            if not young and self.xy.shape[0] >= lim.min_reflectors:  # a map without reflectors: other sensors
                out.append("few_reflectors")
        else:
            head = compose(x, self.mount)
            try:
                fix_std = float(pdop(self.xy[used], head)) * self.bearing_std
            except ValueError:  # a degenerate layout (e.g. the head on a reflector): no geometry
                fix_std = math.inf
            if not fix_std <= lim.max_fix_std_m:
                out.append("geometry")
        self.crosscheck = self._crosscheck(t, x, P, odom)
        if self.crosscheck > lim.crosscheck_bound:
            out.append("crosscheck")
        return out

    def _survey_floor(self, x: np.ndarray, used: list[int]) -> np.ndarray:
        """Covariance of a static fix from ``used`` with bearing errors ``map_std / d`` only (zero if none)."""
        std = self.map_std[used]
        if len(used) < 3 or not np.all(std > 0.0):
            return np.zeros((3, 3))
        head = compose(x, self.mount)
        d = np.maximum(np.hypot(*(self.xy[used] - head[:2]).T), 1e-6)
        try:
            cov = crlb(self.xy[used], head, std / d)
        except ValueError:
            return np.zeros((3, 3))
        return cov if np.all(np.isfinite(cov)) else np.zeros((3, 3))

    def _explained(self, x: np.ndarray, n_used: int) -> float:
        """Distinct reflectors used over those in range of the head at ``x`` (1 when none is in range)."""
        head = compose(x, self.mount)
        n_range = int(np.count_nonzero(np.hypot(*(self.xy - head[:2]).T) <= self.max_range))
        return 1.0 if n_range == 0 else n_used / n_range

    def _uncertainty_failures(self, P: np.ndarray) -> list[str]:
        lim = self.limits
        pos_var = float(np.max(np.linalg.eigvalsh(0.5 * (P[:2, :2] + P[:2, :2].T))))
        if not (pos_var <= lim.lost_position_std_m**2 and P[2, 2] <= lim.lost_heading_std_rad**2):
            return ["uncertainty"]
        return []

    def _crosscheck(self, t: float, x: np.ndarray, P: np.ndarray, odom: tuple[float, ...]) -> float:
        """Mahalanobis distance² between the head position of the estimate and a ToTal fix (NaN if none)."""
        latest: dict[int, _Entry] = {}
        for e in reversed(self._entries):
            if t - e.t <= self.revolution_s and e.index not in latest:
                latest[e.index] = e
        idx = self._best_triple(x, list(latest))
        if idx is None:
            return math.nan
        xy, rad = self.xy[idx], self.radius[idx]
        then = compose(x, between(np.asarray(odom), np.array([latest[i].odom for i in idx])))
        h_then, _, d = bearing_model(then, self.mount, xy, rad)
        h_now, _, _ = bearing_model(x, self.mount, xy, rad)
        z = np.array([latest[i].bearing for i in idx])
        centre = z + np.arcsin(np.clip(rad / np.maximum(d, 1e-12), 0.0, 1.0))  # edge -> centre (seed 000 §2.1)
        z_now = centre + (h_now - h_then)
        std = np.sqrt(self.bearing_std**2 + (self.map_std[idx] / np.maximum(d, 1e-12)) ** 2)
        try:
            fix = triangulate(xy, z_now, method="total", bearing_std=std)
        except ValueError:  # e.g. collinear reflectors: no fix to compare with
            return math.nan
        if not bool(fix.valid) or fix.covariance is None or not np.all(np.isfinite(fix.covariance)):
            return math.nan
        head = compose(x, self.mount)
        diff = np.array([float(fix.x) - head[0], float(fix.y) - head[1]])
        S = fix.covariance[:2, :2] + P[:2, :2]
        if math.hypot(diff[0], diff[1]) <= self.limits.crosscheck_min_m:
            return 0.0  # agreement within the gross-error floor
        try:
            return float(diff @ np.linalg.solve(S, diff))
        except np.linalg.LinAlgError:
            return math.nan

    def _best_triple(self, x: np.ndarray, rows: list[int]) -> list[int] | None:
        """The three of ``rows`` with the smallest position CRLB at ``x`` (seed 000 §2.3), None if none is good.

        Near the critical circle of a triple its linearised covariance is not honest
        (issue 12), so a triple whose bound exceeds ``max_fix_std_m`` is not used.
        """
        if len(rows) < 3:
            return None
        triples = np.array(list(itertools.combinations(rows[:8], 3)))
        try:
            cov = crlb(self.xy[triples], compose(x, self.mount), self.bearing_std)
        except ValueError:
            return None
        score = cov[:, 0, 0] + cov[:, 1, 1]
        score = np.where(np.isfinite(score), score, np.inf)
        k = int(np.argmin(score))
        if not math.sqrt(score[k]) <= self.limits.max_fix_std_m:
            return None
        return [int(i) for i in triples[k]]

    # ------------------------------------------------------------------ verdict
    def _judge(self, t: float, reasons: list[str]) -> bool:
        lim = self.limits
        if "uncertainty" in reasons:
            self.verdict = "lost"
        elif reasons:
            if self._degraded_since is None:
                self._degraded_since = t
            self.verdict = "lost" if t - self._degraded_since > lim.lost_after_s else "degraded"
        else:
            self._degraded_since = None
            self.verdict = "ok"
        self.quality = self._score()
        suspect = {"nis", "crosscheck", "rejections", "unexplained"}
        inflate = bool(suspect.intersection(reasons)) and self.verdict != "lost"
        if inflate:  # judge the inflated estimate on fresh innovations
            self._entries.clear()
            self._rejects.clear()
        return inflate

    def _score(self) -> float:
        """0-1: reflectors (4 or more count fully) x innovation consistency x geometry and cross-check."""
        if self.verdict == "lost":
            return 0.0
        q_count = min(self.reflectors_used, 4) / 4.0
        ratio = self.nis_ratio if math.isfinite(self.nis_ratio) else 1.0
        q_nis = 1.0 / (1.0 + max(0.0, 2.0 * ratio - 1.0) ** 2) if ratio > 0.5 else 1.0
        q_check = 0.5 if {"geometry", "crosscheck", "rejections", "unexplained"} & set(self.reasons) else 1.0
        return q_count * q_nis * q_check
