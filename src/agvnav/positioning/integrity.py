"""Integrity of a streaming estimate: is the reported pose trustworthy? (issue 12 §1)

:class:`IntegrityMonitor` watches what supports the estimate and turns it into a verdict
(``"ok"``, ``"degraded"``, ``"lost"``) and a 0-1 quality figure, as commercial reflector
navigators report one. This module is the monitor (its state, the verdict and the
drift episode); each check lives in its own module, over the typed window record of
:mod:`agvnav.positioning.integrity_window` (one row per accepted reflection, named fields):
:mod:`~agvnav.positioning.integrity_nis` (innovation chi-square, corrections, uncertainty),
:mod:`~agvnav.positioning.integrity_raim` (leave-one-out FDE),
:mod:`~agvnav.positioning.integrity_crosscheck` (ToTal cross-check) and
:mod:`~agvnav.positioning.integrity_sight` (visibility, head clock). The checks:

* consistency of the recent innovations: the windowed NIS ``sum y_i^2 / S_i`` of the
  accepted bearings of the last ``window_s`` seconds against the upper
  ``nis_confidence`` quantile of a chi-square with as many degrees of freedom (a
  consistent filter's innovations are white with variance ``S`` [seed002 eq14]);
* the fraction of reflections the gate rejected in the window: above
  ``max_reject_fraction`` (and at least ``min_rejections``) the true reflectors no longer
  fall into their gates -- the estimate has moved off (a lost odometry stretch) -- while
  clutter alone, spurious reflections at random bearings, stays below it;
* the fraction of the reflectors in sight that the window's accepted reflections
  explain: below ``min_explained_fraction`` the estimate explains only a few of them,
  the signature of a pose that has locked onto a wrong but self-consistent subset (an
  odometry dropout leaves one "tracking" 0.2-0.7 m off on 3 of 9 reflectors). In sight
  means within ``max_range`` and, when the monitor has the map's ``walls``, not hidden
  behind one (:func:`reflectors_in_sight`, the goniometer's own line-of-sight test), so
  a racked hall does not count the reflectors behind the racks as missing;
* the timing of the reflections: the goniometer reports the head angle at the instant
  of the reflection, ``z = phase + omega t`` up to a constant, so a stamp that lags the
  measurement shows as a phase jump of ``omega * latency`` (:class:`_HeadClock` learns
  the phase from the first reflections and follows slow drift). When most of the
  window's reflections are off the head's phase by more than ``omega * max_latency_s``,
  the estimate is built on late bearings (an uncompensated latency leaves it lagging
  ``v * latency`` behind with consistent innovations): ``"timing"``. A latency of a
  whole number of revolutions is invisible to this check;
* the drift of the Kalman corrections: the updates of the window move the estimate
  by ``sum K y``, whose covariance for a consistent filter is the sum of the covariance
  decreases ``P- - P+``; a sum beyond that chi-square bound (and ``max_correction_m``)
  is odometry carrying the estimate off the bearings faster than its noise model allows
  (wheel slip): ``"corrections"`` (:meth:`IntegrityMonitor._corrections_drift`);
* per reflector, the exponentially weighted mean of its NIS ``y^2 / S`` (weight 1/8,
  about 8 sightings; squared, so a bias that changes sign as the vehicle moves still
  counts): a reflector whose mean exceeds ``exclude_sigmas^2`` and ``exclude_ratio^2``
  times the mean of the other reflectors' is inconsistent with the rest of the map
  (moved, or a reflection off a shiny surface beside it) and is *excluded*:
  :attr:`IntegrityMonitor.excluded`, which the
  estimator never associates again (at most ``max_excluded``, and never below
  ``min_reflectors + 1`` others in view; fault detection and exclusion as RAIM does
  for satellites);
* leave-one-out fault detection and exclusion (residual-based RAIM, Parkinson &
  Axelrad 1988, Brown 1992, applied to the Kalman innovations as innovation-based FDE;
  :func:`leave_one_out_fde`, :meth:`IntegrityMonitor.raim`): the window's mean
  innovation of each reflector is fitted to a common pose offset (the pull of a faulty
  reflector on the estimate) and the weighted residual sum tested against the chi-square
  with ``reflectors - 3`` dof at the false-alarm probability ``raim_false_alarm`` per
  check (``"raim"``); leaving each reflector out in turn, the one whose removal makes the
  others consistent (``reflectors - 4`` dof, same probability) is excluded once
  ``raim_confirm`` failing checks have named it, more often than any other. The
  per-reflector NIS test above misses a moved reflector whose pull spreads its error over
  its neighbours (the differential AGV's nearest side reflector moved 0.1 m: the estimate
  60-90 mm off with sigma 11 mm, the offender's NIS only ~3x its neighbours'), and its
  ratio rule, blind to the pull, excluded sound neighbours of the moved one: where the
  RAIM can run (four reflectors or more with EKF innovations) it owns the exclusion.
  The RAIM's chi-square holds for untruncated innovations, while the identification gate
  keeps only those within 3.3 sigma: a reflector moved by a few sigmas (the differential's
  side reflector moved 0.1 m, 10-20 mrad at 4-6 m against ``sqrt(S)`` 3.4-5 mrad) had one
  sighting in four accepted -- each a 2-3 sigma innovation that pulled the estimate -- and
  the test of those passed while the AGV stayed ``tracking`` 20-26 mm (5 sigma) off for
  1-3 s. So the estimator also hands the monitor each gated-out reflection that one
  reflector not yet seen in the sweep explains within the attribution gate
  (:meth:`IntegrityMonitor.attribution_gate`, the chi-square quantile at
  ``raim_false_alarm``: a sound reflection lies beyond it as rarely as the RAIM may fail;
  :meth:`IntegrityMonitor.attributed`): one more sighting for the RAIM, never support of
  the estimate. A failure that names a reflector is a measurement fault: it leaves the
  covariance alone (an inflation widens that reflector's gate and lets its pull in:
  a synthetic drive past it ended 120 mm off while degraded); the check that excludes a
  reflector inflates it, since the estimate still holds the excluded one's past pull;
* the number and geometry of the reflectors that supported the recent fixes: at least
  ``min_reflectors`` distinct ones in the window, and a best achievable position error
  ``PDOP * bearing_std`` (:func:`~agvnav.positioning.bounds.pdop`, the CRLB of seed 000
  §2.3) below ``max_fix_std_m``;
* a cross-check against an independent triangulation when three distinct reflectors
  were seen in the last revolution: their bearings are brought to one instant through
  the odometry (the angle propagation of seed 000 §2.2) and triangulated with ToTal
  (:func:`~agvnav.positioning.triangulate`, ``valid=False`` near the critical circle),
  each bearing's variance counting the odometry error of its propagation (the
  monitor's ``odometry_noise``, the filter's seed-002 coefficients);
  the fix and the estimate must agree within the chi-square bound of their summed
  covariances, or within ``crosscheck_min_m`` (the check looks for gross errors such as
  a wrong association; a fixed survey error of the three reflectors can bias one triple's
  fix by a few sigma while the filter, averaging every reflector, stays consistent).

The survey error of the reflectors is constant in time, so a filter that takes it as
white bearing noise averages it away and ends overconfident (issue 12: NEES 13 with a
5 mm survey error). :attr:`IntegrityMonitor.survey_floor` is the covariance of a static
fix from the reflectors used when each bearing errs only by its reflector's survey
error, ``(map_std / d)^2`` (the CRLB of seed 000 §2.3 with that std, carried from the
head to base_link): the part of the error no averaging removes, which the estimator
adds to the covariance it reports.

A failed check makes the verdict ``degraded`` and asks the estimator to inflate its
covariance (the estimate says it is less sure; not for a RAIM failure that names a reflector,
and always on an exclusion: see above); the verdict returns to ``ok`` only
after ``recover_s`` seconds of passing checks (a full window of fresh innovations
after an inflation: without it a persistent fault that each inflation hides for one
revolution flips the status between ``tracking`` and ``degraded``). A failure of the
cross-check alone is not held: one triple of one revolution is a thin basis (before its
bearings carried the odometry error of their propagation it failed on about 6 % of the
checks of the sound differential_loop run, fix and estimate 5-14 cm apart, and holding
each for ``recover_s`` kept that vehicle slow until its time ran out); a verdict
``degraded`` by failing checks for longer than
``lost_after_s``, or a position or heading uncertainty beyond what the bearing gate
can identify reflectors with (``lost_position_std_m``, ``lost_heading_std_rad``), makes
it ``lost``: the estimator then stops correcting and relocalises.

The common offset of the last revolution's innovations (:meth:`IntegrityMonitor.offset`):
the fit of the RAIM, whose residual tests reflectors that disagree, has a common part --
the pose offset all the bearings share -- chi-square with 3 dof for a consistent filter;
beyond its upper ``sqrt(raim_false_alarm)`` quantile in two revolutions in a row (disjoint
sightings: together at ``raim_false_alarm``) the prior estimate is off all its bearings at
once, odometry having carried it there: ``"offset"``. It sees the onset of wheel slip a
revolution or two after the lag passes a few sigma, where the window's NIS, averaging a
second, took a second.

A failure that says the estimate moved off its bearings (NIS, corrections, common offset,
rejections, unexplained reflectors; not when the RAIM names a reflector) opens a *drift
episode*: the odometry errs beyond its noise model, and a one-off inflation is not enough
while it goes on (wheel slip: the filter lags the continuing slip and the checks pass on
the lagging estimate). While the episode lasts, the monitor measures the drift from the
window's Kalman corrections and asks the estimator to grow ``P`` at that rate
(:attr:`IntegrityMonitor.drift_noise`, :meth:`IntegrityMonitor._measure_drift`), and the
verdict stays ``degraded`` until ``recover_s`` after the last window whose corrections
summed beyond ``max_correction_m``; the hold, its checks passing, does not count towards
``lost_after_s``.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.typing import ArrayLike

from agvnav.positioning._integrity_fast import (
    _fde_statistics,  # noqa: F401 - re-exported (the checks' kernels, tests/test_jit.py)
    _head,
    in_range,
    information,
    mean_innovations,
    nis_per_reflector,
    revolution_offset,
    window_fde,
)
from agvnav.positioning.integrity_crosscheck import crosscheck_distance
from agvnav.positioning.integrity_limits import IntegrityLimits
from agvnav.positioning.integrity_nis import CHI2_2DOF_999, chi2_upper, corrections_drift, uncertainty_failures
from agvnav.positioning.integrity_raim import (
    FdeResult,
    _chi2_3dof_isf,
    _fde_result,
    chi2_threshold,
    leave_one_out_fde,
)
from agvnav.positioning.integrity_sight import HeadClock, reflectors_in_sight
from agvnav.positioning.integrity_window import (  # noqa: F401 - _WIDTH re-exported
    _OX,
    _OY,
    _WIDTH,
    _Tally,
    _Window,
    _window_tally,
    window_row,
)

__all__ = [
    "CHI2_2DOF_999", "FdeResult", "IntegrityLimits", "IntegrityMonitor", "chi2_threshold", "chi2_upper",
    "leave_one_out_fde", "reflectors_in_sight",
]

_INF = math.inf

_NO_ATTRIBUTED = np.zeros((0, 7))
#: Fraction of a revolution in which a reflector reflects once (the estimator's claim window).
_SWEEP = 0.75
#: Failed checks that say the estimate moved off its bearings (not a named measurement fault): they open
#: a drift episode (:meth:`IntegrityMonitor._measure_drift`).
_ODOMETRY_REASONS = frozenset({"nis", "corrections", "rejections", "unexplained", "offset"})


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
    walls:
        ``(M, 2, 2)`` wall segments of the map (m) that hide reflectors from the head
        (:func:`reflectors_in_sight`); None counts every reflector in range.
    odometry_noise:
        ``(k_d, k_dtheta, k_theta)`` (m²/m, rad²/m, rad²/rad) of the odometry the
        cross-check brings its bearings to one instant with (seed 002's model, as the
        filter's :class:`~agvnav.odometry.OdometryNoise`): the error of that propagation
        is part of each propagated bearing's variance.
    limits:
        The thresholds.

    Attributes
    ----------
    verdict : ``"ok"``, ``"degraded"`` or ``"lost"``.
    quality : 0-1 figure (0 when lost).
    reflectors_used : distinct reflectors accepted in the window.
    nis_ratio : windowed NIS over its chi-square bound (< 1 consistent; NaN without data).
    crosscheck : Mahalanobis distance² of the latest triangulation cross-check (NaN if none).
    survey_floor : ``(3, 3)`` covariance (m², m·rad, rad²) of the base_link pose error that
        the survey error of the reflectors used causes (zero without ``map_std`` or support).
    reasons : why the last check failed (empty when it passed).
    drifting : a drift episode is open (module docstring).
    drift_noise : ``(00, 01, 11)`` position noise (m²) to add to ``P`` after the latest check
        (zeros outside a drift episode; :meth:`_measure_drift`).
    excluded : map rows of the reflectors excluded as inconsistent (kept across :meth:`reset`).
    xy, radius, mount, map_std : the map and mount as given (:attr:`xy` and co), fixed after construction.
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
        walls: ArrayLike | None = None,
        odometry_noise: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        self._xy = _frozen(np.array(reflector_xy, dtype=np.float64).reshape(-1, 2))
        k_d, k_dtheta, k_theta = (float(v) for v in odometry_noise)
        if not all(math.isfinite(v) and v >= 0.0 for v in (k_d, k_dtheta, k_theta)):
            raise ValueError(f"odometry_noise must be three non-negative finite numbers, got {odometry_noise!r}")
        self.odometry_noise = (k_d, k_dtheta, k_theta)
        self._radius = _frozen(np.array(reflector_radius, dtype=np.float64).reshape(-1))
        self._mount = _frozen(np.array(mount, dtype=np.float64).reshape(3))
        self.bearing_std = float(bearing_std)
        self._map_std = _frozen(np.array(np.broadcast_to(np.asarray(map_std, dtype=np.float64), self.radius.shape)))
        self.max_range = float(max_range)
        self.revolution_s = float(revolution_s)
        self.limits = IntegrityLimits() if limits is None else limits
        self.walls = None if walls is None else np.asarray(walls, dtype=np.float64).reshape(-1, 2, 2)
        self._entries = _Window()
        self._rejects: deque[float] = deque()
        #: gated-out reflections attributed to one reflector: (t, map row, y, S, H0, H1, H2) (:meth:`attributed`)
        self._attributed: deque[tuple[float, int, float, float, float, float, float]] = deque()
        #: the map for the kernels (:mod:`agvnav.positioning._integrity_fast`): x, y, radius, map_std (m), as
        #: contiguous arrays; copies, so the map and mount are read-only properties (:attr:`xy` and co)
        self._tables = tuple(np.array(a, dtype=np.float64)  # contiguous, writeable copies (numba's array type)
                             for a in (self.xy[:, 0], self.xy[:, 1], self.radius, self.map_std))
        self._mount_t = (float(self.mount[0]), float(self.mount[1]), float(self.mount[2]))
        self._flags_of: tuple[int, ...] | None = None  # the exclusions self._flags holds (:meth:`_excluded_flags`)
        self._flags = np.zeros(0, dtype=np.int64)
        self._clock = HeadClock(self.revolution_s, self.limits.max_latency_s * 2.0 * math.pi / self.revolution_s)
        self._mean_nu = [0.0] * self.xy.shape[0]  # EWMA of the NIS y^2 / S per reflector
        self._n_nu = [0] * self.xy.shape[0]
        self.excluded: tuple[int, ...] = ()
        self.reset()

    @property
    def xy(self) -> np.ndarray:
        """``(N, 2)`` map centres (m), read-only: fixed at construction (the kernels' tables are copies)."""
        return self._xy

    @property
    def radius(self) -> np.ndarray:
        """``(N,)`` reflector radii (m), read-only (:attr:`xy`)."""
        return self._radius

    @property
    def mount(self) -> np.ndarray:
        """``(3,)`` head pose in base_link (m, m, rad), read-only (:attr:`xy`)."""
        return self._mount

    @property
    def map_std(self) -> np.ndarray:
        """``(N,)`` survey std (m) per reflector, read-only (:attr:`xy`)."""
        return self._map_std

    def reset(self) -> None:
        """Forget the support (after a relocalisation or a fresh start); exclusions and the head clock stay."""
        self._entries.clear()
        self._rejects.clear()
        self._attributed.clear()
        self.verdict = "ok"
        self.quality = 0.0
        self.reflectors_used = 0
        self.nis_ratio = math.nan
        self.crosscheck = math.nan
        self.correction_d2 = math.nan
        self.reasons: tuple[str, ...] = ()
        self.survey_floor = np.zeros((3, 3))
        self._degraded_since: float | None = None
        self._failed_at = -math.inf
        self._last_check = -math.inf
        self._since: float | None = None  # first check after the reset
        self._mean_nu = [0.0] * self.xy.shape[0]
        self._n_nu = [0] * self.xy.shape[0]
        self.raim_statistic = math.nan
        self._raim_tally: dict[int, int] = {}  # map row -> failing RAIM checks that named it (this episode)
        self._raim_ran = False  # the last check could run the RAIM (it then owns the exclusion)
        self._raim_named = False  # the last check's RAIM failure named one reflector (a measurement fault)
        #: the drift model (:meth:`_measure_drift`): an episode is open, the position noise (00, 01, 11) (m²)
        #: the estimator adds at this check; the latest window drift D (m) and the odometric distance it was
        #: measured over (m), the odometric position of the previous check, the last check with evidence (s)
        self.drifting = False
        self.drift_noise = (0.0, 0.0, 0.0)
        self._drift_d = (0.0, 0.0)
        self._drift_s = 0.0
        self._drift_odom: tuple[float, float] | None = None
        self._drift_seen = -math.inf
        self._offset_since: float | None = None  # first of the checks in a row whose offset was beyond chance

    def accepted(
        self, t: float, nis: float, index: int, bearing: float, odom: tuple[float, ...],
        correction: tuple[float, float, float, float, float] | None = None,
        innovation: tuple[float, float, float, float, float] | None = None,
    ) -> None:
        """One accepted reflection at ``t`` (s): its NIS, reflector row, edge bearing (rad), odometric pose.

        ``correction``: a Kalman update's position correction ``(dx, dy)`` (m) and the
        decrease of the position covariance it made, ``P- - P+`` as ``(00, 01, 11)`` (m²),
        for the correction check (module docstring); None for estimators that are no
        Kalman filter. ``innovation``: the update's ``(y, S, H0, H1, H2)`` (rad, rad², the
        bearing Jacobian row) for the leave-one-out test (:meth:`raim`); None without one.
        """
        j = int(index)
        row = window_row(t, nis, j, bearing, odom, self._clock.on_time(t, bearing), correction, innovation)
        self._entries.push(row, t, self.limits.window_s)  # stored as doubles
        if self._attributed:
            self._void_attributions(t, j)
        if -_INF < nis < _INF:
            n = self._n_nu[j] + 1
            self._n_nu[j] = n
            self._mean_nu[j] += (nis - self._mean_nu[j]) / min(n, 8)

    def attribution_gate(self) -> float:
        """Chi-square bound (1 dof) on ``y^2 / S`` of the attribution gate (:meth:`attributed`).

        The upper ``raim_false_alarm`` quantile: a sound reflector's reflection falls beyond
        it no more often than the RAIM may fail on a sound window, so the innovations the
        RAIM sees through this gate are those of a consistent filter, untruncated at the
        level of its own false-alarm probability (the identification gate, 0.999, cuts
        the tail a thousand times more often).
        """
        return chi2_threshold(1, self.limits.raim_false_alarm)

    def attributed(self, t: float, index: int, innovation: tuple[float, float, float, float, float]) -> None:
        """A reflection at ``t`` (s) the gate rejected that only reflector ``index`` explains (the attribution gate).

        ``innovation``: its ``(y, S, H0, H1, H2)`` about the current estimate (rad, rad²,
        the bearing Jacobian row), as :meth:`accepted` takes them. The estimator calls
        this for a reflection outside every identification gate when exactly one
        reflector lies inside :meth:`attribution_gate` and that one was not yet seen in
        the sweep; an acceptance of the same reflector within the sweep (``0.75``
        revolution) voids it afterwards (it was a spurious reflection next to a sound
        reflector). Only the RAIM (:meth:`raim`) counts it: as one more sighting of that
        reflector, never as support of the estimate.

        Why: a reflector moved by a few of its innovation sigmas lands outside its gate on
        most revolutions and inside on the others, so the filter and the RAIM saw only the
        sightings of the least bias (the gate's truncated tail) -- they still pulled the
        estimate, while each looked like a 2-3 sigma innovation. The differential AGV with
        its nearest side reflector moved 0.1 m (10-20 mrad at 4-6 m, ``sqrt(S)`` 3.4-5
        mrad from its 7 mrad of heading noise per revolution) had one sighting in four
        accepted, ended 20-26 mm off with sigma 5 mm and stayed ``tracking`` for 1-3 s.
        """
        if not self.limits.attribute:
            return
        y, s, h0, h1, h2 = (float(v) for v in innovation)
        self._attributed.append((float(t), int(index), y, s, h0, h1, h2))
        while self._attributed and t - self._attributed[0][0] > self.limits.window_s:
            self._attributed.popleft()

    def _void_attributions(self, t: float, j: int) -> None:
        """Forget the attributions to reflector ``j`` within the sweep (0.75 revolution) before ``t`` (s)."""
        sweep = _SWEEP * self.revolution_s
        if any(a[1] == j and t - a[0] < sweep for a in self._attributed):
            self._attributed = deque(a for a in self._attributed if not (a[1] == j and t - a[0] < sweep))

    @property
    def used(self) -> tuple[int, ...]:
        """Map rows of the distinct reflectors accepted in the window, ascending."""
        return tuple(sorted(set(self._entries.indices())))

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
        n_excluded = len(self.excluded)
        x = np.asarray(pose, dtype=np.float64)
        cov = np.asarray(P, dtype=np.float64)
        self._entries.drop_older(t, self.limits.window_s)
        if self._since is None:
            self._since = t
        young = t - self._since < self.limits.window_s  # no full window of support yet
        tally = self._tally(t)
        reasons = [] if dead_reckoning else self._support_failures(t, x, cov, odom, young, tally)
        self._raim_ran = self._raim_named = False
        if self.limits.enabled and not dead_reckoning and not young:
            reasons += self._raim_failures(t, tally)
            reasons += self._offset_failures(t)
        reasons += uncertainty_failures(cov, self.limits.lost_position_std_m, self.limits.lost_heading_std_rad)
        self.reasons = tuple(reasons) if self.limits.enabled else ()
        reasons = list(self.reasons)
        if self.limits.enabled and not dead_reckoning and not young and not self._raim_ran:
            self._exclude()  # the NIS-ratio exclusion only where the RAIM has no redundancy to judge with
        self._measure_drift(t, odom, tally, dead_reckoning)
        return self._judge(t, reasons, len(self.excluded) > n_excluded)

    # ------------------------------------------------------------------ checks
    def _tally(self, t: float) -> _Tally:
        """The window's sums per reflector at ``t`` (s), in one pass (:func:`_window_tally`)."""
        buf, start = self._entries.buffer()
        return _Tally(*_window_tally(buf, start, len(self._entries), t, self.limits.window_s, self.revolution_s,
                                     self._excluded_flags()))

    def _excluded_flags(self) -> np.ndarray:
        """``(N,)`` int64: 1 at the excluded map rows (:attr:`excluded`), kept until they change."""
        if self._flags_of is not self.excluded:
            flags = np.zeros(self.xy.shape[0], dtype=np.int64)
            flags[list(self.excluded)] = 1
            self._flags, self._flags_of = flags, self.excluded
        return self._flags

    def _support_failures(
        self, t: float, x: np.ndarray, P: np.ndarray, odom: tuple[float, ...], young: bool, tally: _Tally
    ) -> list[str]:
        lim = self.limits
        n_entries = len(self._entries)
        n_used = int(np.count_nonzero(tally.sightings))
        self.reflectors_used = n_used
        head = _head(float(x[0]), float(x[1]), float(x[2]), *self._mount_t)
        unit, floor = self._information(head, tally.sightings)
        self.survey_floor = floor
        out: list[str] = []
        if n_entries:
            buf, start = self._entries.buffer()
            nis = nis_per_reflector(buf, start, n_entries, tally.sightings, tally.first, tally.nis)
            self.nis_ratio = nis / chi2_upper(n_used, lim.nis_confidence)
            if self.nis_ratio > 1.0:
                out.append("nis")
            if not young and self._corrections_drift(tally.corrections):
                out.append("corrections")
            if self._clock.sense and 2 * tally.late > n_entries >= 4:
                out.append("timing")
        while self._rejects and t - self._rejects[0] > lim.window_s:
            self._rejects.popleft()
        n_rej = len(self._rejects)
        if n_rej >= lim.min_rejections and n_rej > lim.max_reject_fraction * (n_rej + n_entries):
            out.append("rejections")
        if not young and self._explained(head, n_used) < lim.min_explained_fraction:
            out.append("unexplained")
        if n_used < lim.min_reflectors:
            if not young and self.xy.shape[0] >= lim.min_reflectors:  # a map without reflectors: other sensors
                out.append("few_reflectors")
        else:
            fix_std = math.sqrt(unit) * self.bearing_std if math.isfinite(unit) else math.inf
            if not fix_std <= lim.max_fix_std_m:
                out.append("geometry")
        self.crosscheck = self._crosscheck(t, x, P, odom, tally)
        if self.crosscheck > lim.crosscheck_bound:
            out.append("crosscheck")
        return out

    def _corrections_drift(self, sums: tuple[float, ...]) -> bool:
        """The corrections check (:func:`~agvnav.positioning.integrity_nis.corrections_drift`)."""
        drift, d2 = corrections_drift(sums, self.limits.max_correction_m)
        if not math.isnan(d2):
            self.correction_d2 = d2
        return drift

    def _information(self, head: tuple[float, float, float], sightings: np.ndarray) -> tuple[float, np.ndarray]:
        """PDOP² of the sighted reflectors from the head (m²/rad², inf if unobservable) and the survey floor ``(3, 3)``.

        One pass over the bearing Jacobian rows ``[dy/d², -dx/d², -1]`` of the map rows with
        ``sightings (N,)`` non-zero (seed 000 §2.3, :func:`~agvnav.positioning.bounds.crlb`;
        :func:`~agvnav.positioning._integrity_fast.information`): the unit-noise
        information gives the PDOP, the information weighted by ``(d / map_std)^2`` the
        covariance of a static fix of the head whose bearings err only by the survey
        error, carried to base_link through ``base = head - R(psi) mount`` (zero without
        ``map_std`` or with fewer than three reflectors).
        """
        rx, ry, _, map_std = self._tables
        pdop2, has_floor, b00, b01, b02, b11, b12, b22 = information(
            head[0], head[1], head[2], sightings, rx, ry, map_std, self._mount_t)
        if not has_floor:
            return pdop2, np.zeros((3, 3))
        return pdop2, np.array([[b00, b01, b02], [b01, b11, b12], [b02, b12, b22]])

    def _in_sight(self, head: tuple[float, float, float]) -> int:
        """How many reflectors (not excluded) the head can see (:func:`reflectors_in_sight`)."""
        hx, hy = head[0], head[1]
        d = np.hypot(self.xy[:, 0] - hx, self.xy[:, 1] - hy)
        near = d <= self.max_range
        if self.walls is not None and self.walls.shape[0] and np.any(near):
            rows = np.flatnonzero(near)
            seen = reflectors_in_sight(self.xy[rows], self.radius[rows], (hx, hy), self.walls, self.max_range)
            near = np.zeros_like(near)
            near[rows[seen]] = True
        if self.excluded:
            near[list(self.excluded)] = False
        return int(np.count_nonzero(near))

    def _explained(self, head: tuple[float, float, float], n_used: int) -> float:
        """Distinct reflectors used over those in sight of the head (1 when none is).

        The line-of-sight test runs only when it can change the verdict: the reflectors
        in range bound those in sight from above, so a fraction already above
        ``min_explained_fraction`` over those in range stands.
        """
        n_range = self._in_range(head[0], head[1])
        if n_range == 0:
            return 1.0
        if n_used >= self.limits.min_explained_fraction * n_range:
            return n_used / n_range
        n_sight = self._in_sight(head)
        return 1.0 if n_sight == 0 else n_used / n_sight

    def _in_range(self, hx: float, hy: float) -> int:
        """How many reflectors (not excluded) are within ``max_range`` (m) of ``(hx, hy)`` (m).

        ``math.hypot(dx, dy) <= max_range``, in one compiled pass over the map
        (:func:`~agvnav.positioning._integrity_fast.in_range`; issue 11: 256 reflectors).
        """
        rx, ry, _, _ = self._tables
        return int(in_range(hx, hy, rx, ry, self.max_range, self._excluded_flags()))

    def _crosscheck(
        self, t: float, x: np.ndarray, P: np.ndarray, odom: tuple[float, ...], tally: _Tally
    ) -> float:
        """The ToTal cross-check (:func:`~agvnav.positioning.integrity_crosscheck.crosscheck_distance`)."""
        return crosscheck_distance(
            self._entries.buffer(), tally.newest, x, P, odom, self._mount_t, self._tables, self.odometry_noise,
            self.bearing_std**2, self.limits.max_fix_std_m, self.limits.crosscheck_min_m,
        )

    # ------------------------------------------------------------------ RAIM
    def raim(self, t: float, tally: _Tally | None = None) -> tuple[tuple[int, ...], FdeResult] | None:
        """Innovation-based leave-one-out fault detection and exclusion over the window (:func:`leave_one_out_fde`).

        Each reflector ``k`` accepted in the window contributes the mean ``ybar_k`` of its
        EKF innovations and the mean ``Hbar_k`` of their Jacobian rows. A reflector moved
        from its surveyed place biases its own innovations and, through the estimate it
        pulls, its neighbours' by ``Hbar_k dx``: the means are fitted as ``ybar = Hbar dx``
        (the pull ``dx`` common to the window) and tested with :func:`leave_one_out_fde`.
        Under no fault the innovations are white with variance ``S`` except their survey
        part ``(map_std / d)^2``, constant in time, so ``var(ybar_k) = (map_std / d)^2 +
        (Sbar_k - (map_std / d)^2) / n_k`` over ``n_k`` sightings. Returns the map rows
        (in the order of the result's rows) and the result, or None with fewer than 4
        reflectors (no redundancy) or without innovations (not a Kalman filter). ``tally``: the
        window's sums at ``t`` when the caller has them (:meth:`_tally`).
        """
        tally = self._tally(t) if tally is None else tally
        innovations = tally.innovations
        if self._attributed:  # the gated-out sightings attributed to a reflector (:meth:`attributed`)
            innovations = innovations.copy()
            for ta, j, y, s, h0, h1, h2 in self._attributed:
                if not t - ta > self.limits.window_s and j not in self.excluded:
                    innovations[j] += (y, s, h0, h1, h2, 1.0)
        found, stats, positive = window_fde(innovations, self._tables[3], self.bearing_std**2)
        if len(found) < 4:
            return None
        if not positive:  # leave_one_out_fde names the bad variance (ValueError), as it did
            r, H, var, _ = mean_innovations(innovations, found, self._tables[3], self.bearing_std**2)
            return tuple(found.tolist()), leave_one_out_fde(r, H, var, self.limits.raim_false_alarm)
        return tuple(found.tolist()), _fde_result(stats.tolist(), len(found), 3, self.limits.raim_false_alarm)

    def _raim_failures(self, t: float, sums: _Tally | None = None) -> list[str]:
        """``["raim"]`` when the window fails :meth:`raim`; may exclude the reflector it keeps naming.

        One failure episode (until the verdict could recover) tallies the reflector each
        failing check names; the first to be named ``raim_confirm`` times, and more often
        than any other, is excluded (reflectors along one wall are confused with each other
        on some checks: a moved one is named most often, not every time).
        """
        out = self.raim(t, sums)
        self._raim_ran = out is not None
        if out is None or not out[1].detected:
            # a passing check right after an inflation sees few sightings: the tally is
            # forgotten only once the verdict could recover
            if t - self._failed_at >= self.limits.recover_s:
                self._raim_tally.clear()
            if out is not None:
                self.raim_statistic = out[1].statistic / out[1].threshold
            return []
        rows, res = out
        self.raim_statistic = res.statistic / res.threshold
        if res.faulty < 0:
            return ["raim"]
        self._raim_named = True
        j = rows[res.faulty]
        tally = self._raim_tally
        tally[j] = tally.get(j, 0) + 1
        lim = self.limits
        if (tally[j] >= lim.raim_confirm and all(n < tally[j] for k, n in tally.items() if k != j)
                and len(self.excluded) < lim.max_excluded and len(rows) - 1 >= lim.min_reflectors + 1):
            self._drop(j)
            tally.clear()
        return ["raim"]

    def _drop(self, j: int) -> None:
        """Exclude reflector ``j`` from now on (:attr:`excluded`) and judge the others afresh."""
        if j in self.excluded:
            return
        self.excluded = (*self.excluded, j)
        self._entries.keep(self._entries.records()["reflector"] != j)
        self._n_nu = [0] * len(self._n_nu)
        self._mean_nu = [0.0] * len(self._mean_nu)

    # ------------------------------------------------------------------ exclusion
    def _exclude(self) -> None:
        """Exclude the one reflector whose innovations disagree with the others' (module docstring)."""
        lim = self.limits
        if len(self.excluded) >= lim.max_excluded:
            return
        seen = [j for j in set(self._entries.indices()) if self._n_nu[j] >= 8]  # the set's order, as before
        if len(seen) < lim.min_reflectors + 2:
            return
        worst = max(seen, key=lambda j: self._mean_nu[j])
        others = sum(self._mean_nu[j] for j in seen if j != worst) / (len(seen) - 1)
        m = self._mean_nu[worst]
        if m > lim.exclude_sigmas**2 and m > lim.exclude_ratio**2 * others:
            self._drop(worst)

    # ------------------------------------------------------------------ common offset
    def offset(self, t: float) -> tuple[np.ndarray, float] | None:
        """The pose offset the last revolution's innovations share, and its chi-square (3 dof) statistic.

        The EKF innovations of the sightings within one revolution before ``t`` (s) and the
        gated-out ones attributed to a reflector (:meth:`attributed`), as the RAIM takes
        them (:meth:`raim`): per reflector the mean innovation ``ybar_k``, its Jacobian row
        ``Hbar_k`` and the variance ``(map_std / d)^2 + (Sbar_k - (map_std / d)^2) / n_k``,
        fitted by weighted least squares as ``ybar = Hbar dx``. A consistent filter's
        innovations are white with variance ``S`` [seed002 eq14], so ``dx^T (Hbar^T W Hbar) dx``
        is chi-square with 3 dof; the RAIM tests the residual of the same fit (reflectors that
        disagree), this its common part: the prior estimate off all its bearings at once
        (odometry that carried it off: wheel slip). Returns ``(dx (3,), statistic)`` (m, m,
        rad), or None with fewer than 4 reflectors or a singular fit.

        One compiled pass (:func:`~agvnav.positioning._integrity_fast.revolution_offset`) with the
        RAIM's normal equations and elimination (the same fit, one formulation). It replaced
        NumPy's ``H.T @ (W H)``, ``np.linalg.solve`` and ``dx @ A @ dx``, which OpenBLAS sums in its
        own order with fused multiply-adds (its kernel chosen by the CPU): the statistic moved by
        at most 5e-15 relative, ``dx`` by 7e-13, over the 1,900 checks of 30 s of guidance_test,
        differential_loop and tricycle_rear_loop; no decision changed and the seeded runs kept their bits.
        """
        buf, start = self._entries.buffer()
        att = np.array(self._attributed, dtype=np.float64) if self._attributed else _NO_ATTRIBUTED
        ok, dx0, dx1, dx2, stat = revolution_offset(buf, start, len(self._entries), t, self.revolution_s,
                                                    self._excluded_flags(), att, len(att), self._tables[3],
                                                    self.bearing_std**2)
        return (np.array([dx0, dx1, dx2]), stat) if ok else None

    def _offset_failures(self, t: float) -> list[str]:
        """``["offset"]`` when two revolutions in a row share a pose offset beyond chance (:meth:`offset`).

        Each revolution's statistic against the upper ``sqrt(raim_false_alarm)`` quantile of
        the chi-square with 3 dof; two revolutions at least one revolution apart (disjoint
        sightings, independent for a consistent filter) both beyond it fail together with
        probability ``raim_false_alarm`` per check. Not when the RAIM named a reflector (its
        pull is the offset: a measurement fault). Why: 30 % wheel slip on the seed-000
        tricycle carried the estimate 45-57 mm along its path in the first second while the
        nearest reflector fell out of its gate and the window's NIS stayed below its bound:
        ``tracking`` 5-14 sigma off for 1.15 s (integrity bench, seed 4); this check fails
        0.45 s into that stretch. On the bench's sound runs (10 seeds of each vehicle, about
        4,000 checks) the statistic's 99.9 % point was 9.4 on the tricycle and 19.3 on the
        differential AGV (the chi-square's 16.3: a heavier tail than the model's, which the
        second revolution covers), and no two revolutions in a row passed the bound (13.8).
        """
        out = self.offset(t)
        if out is None or not out[1] > _chi2_3dof_isf(math.sqrt(self.limits.raim_false_alarm)):
            self._offset_since = None
            return []
        if self._offset_since is None or t - self._offset_since < 0.999 * self.revolution_s:
            if self._offset_since is None:
                self._offset_since = t
            return []
        return [] if self._raim_named else ["offset"]

    # ------------------------------------------------------------------ drift model
    def _measure_drift(self, t: float, odom: tuple[float, ...], tally: _Tally, dead_reckoning: bool) -> None:
        """The window's Kalman corrections as a drift measurement, and the drift noise of this check.

        The corrections of the window sum to ``D = sum K y`` (m), over the odometric distance
        ``s_w`` (m) the vehicle covered in it. Once the estimate has moved off its bearings
        (a failed check in :data:`_ODOMETRY_REASONS`: the drift *episode*), the odometry is
        known to err beyond its noise model, and ``D`` is what the bearings say it erred by
        over the window. While the episode lasts, every check adds to the position block of
        ``P`` the drift noise ``D D^T s / s_w``, ``s`` the odometric distance since the
        previous check: a random walk whose variance over the window's distance matches the
        drift the window measured (covariance matching of the process noise to the
        corrections: Mehra 1972, Mohamed & Schwarz 1999). Spread over distance, not time,
        since slip needs motion: a standing vehicle's ``P`` does not grow; and ``|D|`` at most
        ``s_w`` (a wheel errs by at most what it measured: 100 % slip), since corrections
        beyond that are no slip but odometry that reads nothing (an encoder dropout, the
        lost-message checks' business): uncapped, the drift noise of a dropout grew the
        tricycle's sigma to 0.1 m in half a second and a gate that wide locked onto a wrong
        pose 2.7 m off (bench seed 9). Refreshed at every
        check with eight corrections or more (one revolution), it follows the drift: the
        filter, its gain raised, takes the bearings' corrections instead of lagging behind
        the continuing slip with a covariance that no longer covered the lag. A one-off
        inflation did not: 30 % slip on the seed-000 tricycle (issue 12 bench, seeds 1, 3,
        4, 16) left the estimate 16-26 mm (5-8 sigma) behind for 1.1-1.75 s after each x4,
        status back to ``tracking`` while the slip went on, the reflector that saw the lag
        gated out.

        Evidence of the drift: a window whose corrections sum beyond ``max_correction_m``,
        the correction check's floor (its chi-square part cannot judge here: the drift noise
        makes the filter expect the corrections it measures). The episode ends (and the
        verdict may return to ``ok``) once ``recover_s`` has passed since the last such
        window and the last failed check. A slower drift left after it is the common-offset
        check's (:meth:`_offset_failures`). (Against the estimate's own sigma,
        ``|D|^2 > tr P_pos``, a false alarm of the correction check on the sound differential
        AGV held ``degraded`` 3 s on correction noise.) ``P (3, 3)`` is the filter's
        covariance (m², rad²), ``odom`` the odometric pose now, ``tally`` the window's sums
        at ``t`` (s).
        """
        ox, oy = float(odom[0]), float(odom[1])
        step = 0.0 if self._drift_odom is None else math.hypot(ox - self._drift_odom[0], oy - self._drift_odom[1])
        self._drift_odom = (ox, oy)
        dx, dy, _, _, _, n = tally.corrections
        if n >= 8 and not dead_reckoning:
            first = self._entries.row(0)
            self._drift_d = (dx, dy)
            self._drift_s = math.hypot(ox - first[_OX], oy - first[_OY])  # the oldest row's odom_x, odom_y
            if math.hypot(dx, dy) > self.limits.max_correction_m:
                self._drift_seen = t
        self.drift_noise = (0.0, 0.0, 0.0)
        if self.drifting and self._drift_s > 0.0:
            dx, dy = self._drift_d
            cap = min(1.0, self._drift_s / max(math.hypot(dx, dy), 1e-300))  # slip of at most 100 %
            k = step / self._drift_s * cap * cap
            self.drift_noise = (k * dx * dx, k * dx * dy, k * dy * dy)

    # ------------------------------------------------------------------ verdict
    def _judge(self, t: float, reasons: list[str], excluded_now: bool = False) -> bool:
        lim = self.limits
        if set(reasons) - {"crosscheck"}:
            self._failed_at = t  # a lone cross-check failure is not held (see the module docstring)
        if lim.enabled and not self._raim_named and _ODOMETRY_REASONS.intersection(reasons):
            self.drifting = True  # the estimate moved off its bearings: the drift model (:meth:`_measure_drift`)
        elif self.drifting and t - max(self._drift_seen, self._failed_at) >= lim.recover_s:
            self.drifting = False  # a window of corrections within the estimate's sigma since the evidence
        if "uncertainty" in reasons:
            self.verdict = "lost"
        elif reasons or t - self._failed_at < lim.recover_s:
            if self._degraded_since is None:
                self._degraded_since = t
            self.verdict = "lost" if t - self._degraded_since > lim.lost_after_s else "degraded"
        elif self.drifting:  # held by the drift model: consistent checks, so not counted towards lost_after_s
            self._degraded_since = None
            self.verdict = "degraded"
        else:
            self._degraded_since = None
            self.verdict = "ok"
        self.quality = self._score()
        suspect = {"nis", "crosscheck", "rejections", "unexplained", "corrections", "raim", "offset"}
        if self._raim_named:  # a measurement fault: exclude the reflector, do not widen the gates for it
            suspect.discard("raim")
        # an exclusion leaves the estimate with the pull of the excluded reflector's past updates,
        # which P does not hold: inflated, the sound reflectors take it back (its gates no longer admit it)
        inflate = (excluded_now or bool(suspect.intersection(reasons))) and self.verdict != "lost"
        if inflate:  # judge the inflated estimate on fresh innovations
            self._entries.clear()
            self._rejects.clear()
            self._attributed.clear()
        return inflate

    def _score(self) -> float:
        """0-1: reflectors (4 or more count fully) x innovation consistency x geometry and cross-check."""
        if self.verdict == "lost":
            return 0.0
        q_count = min(self.reflectors_used, 4) / 4.0
        ratio = self.nis_ratio if math.isfinite(self.nis_ratio) else 1.0
        q_nis = 1.0 / (1.0 + max(0.0, 2.0 * ratio - 1.0) ** 2) if ratio > 0.5 else 1.0
        bad = {"geometry", "crosscheck", "rejections", "unexplained", "timing", "corrections", "raim", "offset"}
        q_check = 0.5 if bad & set(self.reasons) or self.verdict == "degraded" else 1.0
        return q_count * q_nis * q_check


def _frozen(a: np.ndarray) -> np.ndarray:
    """``a`` made read-only (its own copy: the caller's array is not touched)."""
    a.flags.writeable = False
    return a
