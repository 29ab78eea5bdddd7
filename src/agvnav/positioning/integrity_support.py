"""Integrity checks on what supports the estimate: innovations, rejections, reflectors explained, timing, geometry.

:func:`support_failures` runs them in one pass over the window's sums
(:mod:`agvnav.positioning.integrity_window`), in this order:

* consistency of the recent innovations: the windowed NIS ``sum y_i^2 / S_i`` of the
  accepted bearings of the last ``window_s`` seconds against the upper
  ``nis_confidence`` quantile of a chi-square with as many degrees of freedom (a
  consistent filter's innovations are white with variance ``S`` [seed002 eq14]): ``"nis"``;
* the drift of the Kalman corrections (:func:`~agvnav.positioning.integrity_nis.corrections_drift`):
  the updates of the window move the estimate by ``sum K y``, whose covariance for a
  consistent filter is the sum of the covariance decreases ``P- - P+``; a sum beyond that
  chi-square bound (and ``max_correction_m``) is odometry carrying the estimate off the
  bearings faster than its noise model allows (wheel slip): ``"corrections"``;
* the timing of the reflections: the goniometer reports the head angle at the instant
  of the reflection, ``z = phase + omega t`` up to a constant, so a stamp that lags the
  measurement shows as a phase jump of ``omega * latency``
  (:class:`~agvnav.positioning.integrity_sight.HeadClock` learns the phase from the first
  reflections and follows slow drift). When most of the window's reflections are off the
  head's phase by more than ``omega * max_latency_s``, the estimate is built on late
  bearings (an uncompensated latency leaves it lagging ``v * latency`` behind with
  consistent innovations): ``"timing"``. A latency of a whole number of revolutions is
  invisible to this check;
* the fraction of reflections the gate rejected in the window: above
  ``max_reject_fraction`` (and at least ``min_rejections``) the true reflectors no longer
  fall into their gates -- the estimate has moved off (a lost odometry stretch) -- while
  clutter alone, spurious reflections at random bearings, stays below it: ``"rejections"``;
* the fraction of the reflectors in sight that the window's accepted reflections
  explain (:func:`explained_fraction`): below ``min_explained_fraction`` the estimate explains
  only a few of them, the signature of a pose that has locked onto a wrong but self-consistent
  subset (an odometry dropout leaves one "tracking" 0.2-0.7 m off on 3 of 9 reflectors):
  ``"unexplained"``. In sight means within ``max_range`` and, when the monitor has the map's
  ``walls``, not hidden behind one
  (:func:`~agvnav.positioning.integrity_sight.reflectors_in_sight`, the goniometer's own
  line-of-sight test), so a racked hall does not count the reflectors behind the racks as missing;
* the number and geometry of the reflectors that supported the recent fixes: at least
  ``min_reflectors`` distinct ones in the window (``"few_reflectors"``), and a best achievable
  position error ``PDOP * bearing_std`` (:func:`~agvnav.positioning.bounds.pdop`, the CRLB of
  seed 000 §2.3) below ``max_fix_std_m`` (``"geometry"``);
* the cross-check against an independent triangulation
  (:mod:`agvnav.positioning.integrity_crosscheck`): ``"crosscheck"``.

The survey error of the reflectors is constant in time, so a filter that takes it as
white bearing noise averages it away and ends overconfident (issue 12: NEES 13 with a
5 mm survey error). The *survey floor* (:func:`survey_information`) is the covariance of a
static fix from the reflectors used when each bearing errs only by its reflector's survey
error, ``(map_std / d)^2`` (the CRLB of seed 000 §2.3 with that std, carried from the
head to base_link): the part of the error no averaging removes, which the estimator
adds to the covariance it reports
(:attr:`~agvnav.positioning.integrity.IntegrityMonitor.survey_floor`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from agvnav.positioning._integrity_fast import _head, in_range, information, nis_per_reflector
from agvnav.positioning.integrity_crosscheck import crosscheck_distance
from agvnav.positioning.integrity_limits import IntegrityLimits
from agvnav.positioning.integrity_nis import chi2_upper, corrections_drift
from agvnav.positioning.integrity_sight import reflectors_in_sight
from agvnav.positioning.integrity_window import _Tally, _Window

__all__ = ["MonitorMap", "Support", "explained_fraction", "in_sight", "support_failures", "survey_information"]


@dataclass(frozen=True, eq=False)
class MonitorMap:
    """The map and sensor the checks read, fixed at the monitor's construction.

    ``xy (N, 2)``, ``radius (N,)`` the reflectors (m); ``walls (M, 2, 2)`` (m) or None;
    ``max_range`` (m); ``tables`` the map for the kernels, ``x, y, radius, map_std`` (m) as
    contiguous arrays; ``mount`` the head pose in base_link (m, m, rad); ``bearing_std``
    (rad); ``odometry_noise`` seed 002's ``(k_d, k_dtheta, k_theta)``.
    """

    xy: np.ndarray
    radius: np.ndarray
    walls: np.ndarray | None
    max_range: float
    tables: tuple[np.ndarray, ...]
    mount: tuple[float, float, float]
    bearing_std: float
    odometry_noise: tuple[float, float, float]


class Support(NamedTuple):
    """The outcome of :func:`support_failures`: the failed checks and the figures they computed.

    ``nis_ratio`` None and ``correction_d2`` NaN when not computed at this check (the
    monitor keeps its previous figure).
    """

    reasons: list[str]
    reflectors_used: int
    survey_floor: np.ndarray
    nis_ratio: float | None
    correction_d2: float
    crosscheck: float


def support_failures(
    m: MonitorMap, lim: IntegrityLimits, window: _Window, tally: _Tally, rejects: deque[float], t: float,
    x: np.ndarray, P: np.ndarray, odom: tuple[float, ...], young: bool, timing_known: bool,
    excluded: tuple[int, ...], excluded_flags: np.ndarray,
) -> Support:
    """The support checks of the module docstring at ``t`` (s) on the estimate ``x (3,)``, ``P (3, 3)``.

    ``window`` and its sums ``tally`` at ``t``; ``rejects`` the stamps (s) of the window's
    rejected reflections (the expired ones are dropped); ``odom`` the odometric pose now;
    ``young`` no full window of support yet; ``timing_known`` the head clock knows the phase;
    ``excluded`` the excluded map rows, ``excluded_flags (N,)`` the same as flags.
    """
    n_entries = len(window)
    n_used = int(np.count_nonzero(tally.sightings))
    head = _head(float(x[0]), float(x[1]), float(x[2]), *m.mount)
    unit, floor = survey_information(head, tally.sightings, m.tables, m.mount)
    out: list[str] = []
    nis_ratio: float | None = None
    d2 = math.nan
    if n_entries:
        buf, start = window.buffer()
        nis = nis_per_reflector(buf, start, n_entries, tally.sightings, tally.first, tally.nis)
        nis_ratio = nis / chi2_upper(n_used, lim.nis_confidence)
        if nis_ratio > 1.0:
            out.append("nis")
        if not young:
            drift, d2 = corrections_drift(tally.corrections, lim.max_correction_m)
            if drift:
                out.append("corrections")
        if timing_known and 2 * tally.late > n_entries >= 4:
            out.append("timing")
    while rejects and t - rejects[0] > lim.window_s:
        rejects.popleft()
    n_rej = len(rejects)
    if n_rej >= lim.min_rejections and n_rej > lim.max_reject_fraction * (n_rej + n_entries):
        out.append("rejections")
    if not young and explained_fraction(m, head, n_used, lim.min_explained_fraction, excluded,
                                        excluded_flags) < lim.min_explained_fraction:
        out.append("unexplained")
    if n_used < lim.min_reflectors:
        if not young and m.xy.shape[0] >= lim.min_reflectors:  # a map without reflectors: other sensors
            out.append("few_reflectors")
    else:
        fix_std = math.sqrt(unit) * m.bearing_std if math.isfinite(unit) else math.inf
        if not fix_std <= lim.max_fix_std_m:
            out.append("geometry")
    crosscheck = crosscheck_distance(
        window.buffer(), tally.newest, x, P, odom, m.mount, m.tables, m.odometry_noise,
        m.bearing_std**2, lim.max_fix_std_m, lim.crosscheck_min_m,
    )
    if crosscheck > lim.crosscheck_bound:
        out.append("crosscheck")
    return Support(out, n_used, floor, nis_ratio, d2, crosscheck)


def survey_information(
    head: tuple[float, float, float], sightings: np.ndarray, tables: tuple[np.ndarray, ...],
    mount: tuple[float, float, float],
) -> tuple[float, np.ndarray]:
    """PDOP² of the sighted reflectors from the head (m²/rad², inf if unobservable) and the survey floor ``(3, 3)``.

    One pass over the bearing Jacobian rows ``[dy/d², -dx/d², -1]`` of the map rows with
    ``sightings (N,)`` non-zero (seed 000 §2.3, :func:`~agvnav.positioning.bounds.crlb`;
    :func:`~agvnav.positioning._integrity_fast.information`): the unit-noise
    information gives the PDOP, the information weighted by ``(d / map_std)^2`` the
    covariance of a static fix of the head whose bearings err only by the survey
    error, carried to base_link through ``base = head - R(psi) mount`` (zero without
    ``map_std`` or with fewer than three reflectors). ``tables``: :attr:`MonitorMap.tables`.
    """
    rx, ry, _, map_std = tables
    pdop2, has_floor, b00, b01, b02, b11, b12, b22 = information(
        head[0], head[1], head[2], sightings, rx, ry, map_std, mount)
    if not has_floor:
        return pdop2, np.zeros((3, 3))
    return pdop2, np.array([[b00, b01, b02], [b01, b11, b12], [b02, b12, b22]])


def in_sight(m: MonitorMap, head: tuple[float, float, float], excluded: tuple[int, ...]) -> int:
    """How many reflectors (not ``excluded``) the head can see (:func:`reflectors_in_sight`)."""
    hx, hy = head[0], head[1]
    d = np.hypot(m.xy[:, 0] - hx, m.xy[:, 1] - hy)
    near = d <= m.max_range
    if m.walls is not None and m.walls.shape[0] and np.any(near):
        rows = np.flatnonzero(near)
        seen = reflectors_in_sight(m.xy[rows], m.radius[rows], (hx, hy), m.walls, m.max_range)
        near = np.zeros_like(near)
        near[rows[seen]] = True
    if excluded:
        near[list(excluded)] = False
    return int(np.count_nonzero(near))


def explained_fraction(
    m: MonitorMap, head: tuple[float, float, float], n_used: int, min_fraction: float,
    excluded: tuple[int, ...], excluded_flags: np.ndarray,
) -> float:
    """Distinct reflectors used (``n_used``) over those in sight of the head (1 when none is).

    The line-of-sight test runs only when it can change the verdict: the reflectors in
    range (``math.hypot(dx, dy) <= max_range``, one compiled pass over the map,
    :func:`~agvnav.positioning._integrity_fast.in_range`; issue 11: 256 reflectors) bound
    those in sight from above, so a fraction already above ``min_fraction`` over those in
    range stands.
    """
    rx, ry, _, _ = m.tables
    n_range = int(in_range(head[0], head[1], rx, ry, m.max_range, excluded_flags))
    if n_range == 0:
        return 1.0
    if n_used >= min_fraction * n_range:
        return n_used / n_range
    n_sight = in_sight(m, head, excluded)
    return 1.0 if n_sight == 0 else n_used / n_sight
