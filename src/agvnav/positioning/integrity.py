"""Integrity of a streaming estimate: is the reported pose trustworthy? (issue 12 §1)

:class:`IntegrityMonitor` watches what supports the estimate and turns it into a verdict
(``"ok"``, ``"degraded"``, ``"lost"``) and a 0-1 quality figure, as commercial reflector
navigators report one. This module is the monitor: its state, fed reflection by reflection
(:meth:`IntegrityMonitor.accepted`, :meth:`IntegrityMonitor.rejected`,
:meth:`IntegrityMonitor.attributed`) and judged once per head revolution
(:meth:`IntegrityMonitor.check`). Each check lives in its own module, over the typed window
record of :mod:`agvnav.positioning.integrity_window` (one row per accepted reflection, named
fields), and says there what it tests and why:

* :mod:`~agvnav.positioning.integrity_support` -- NIS, corrections, timing, rejections,
  reflectors explained, count and geometry, the survey floor;
* :mod:`~agvnav.positioning.integrity_nis` -- the chi-square figures, the corrections' drift,
  the uncertainty, the per-reflector NIS exclusion;
* :mod:`~agvnav.positioning.integrity_crosscheck` -- the ToTal cross-check;
* :mod:`~agvnav.positioning.integrity_sight` -- line of sight, the head clock;
* :mod:`~agvnav.positioning.integrity_raim` -- leave-one-out FDE, the attribution of gated-out
  reflections, the exclusion it confirms;
* :mod:`~agvnav.positioning.integrity_offset` -- the common offset of a revolution;
* :mod:`~agvnav.positioning.integrity_drift` -- the drift episode and the drift noise;
* :mod:`~agvnav.positioning.integrity_verdict` -- verdict, quality, inflation, recovery, lost;
* :mod:`~agvnav.positioning.integrity_limits` -- the thresholds.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.typing import ArrayLike

from agvnav.positioning._integrity_fast import (
    _fde_statistics,  # noqa: F401 - re-exported (the checks' kernels, tests/test_jit.py)
    in_range,
)
from agvnav.positioning.integrity_drift import DriftModel
from agvnav.positioning.integrity_limits import IntegrityLimits
from agvnav.positioning.integrity_nis import (
    CHI2_2DOF_999,
    ReflectorNis,
    chi2_upper,
    uncertainty_failures,
)
from agvnav.positioning.integrity_offset import OffsetCheck, common_offset, revolution_fix
from agvnav.positioning.integrity_raim import (
    Attributed,
    Attributions,
    FdeResult,
    RaimEpisode,
    _chi2_3dof_isf,  # noqa: F401 - re-exported (tests)
    chi2_threshold,
    leave_one_out_fde,
    window_raim,
)
from agvnav.positioning.integrity_sight import HeadClock, reflectors_in_sight
from agvnav.positioning.integrity_support import MonitorMap, support_failures, survey_information
from agvnav.positioning.integrity_verdict import failed_at, inflates, score, verdict_of
from agvnav.positioning.integrity_window import (  # noqa: F401 - _WIDTH re-exported
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

#: Fraction of a revolution in which a reflector reflects once (the estimator's claim window).
_SWEEP = 0.75


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
    drifting : a drift episode is open (:mod:`~agvnav.positioning.integrity_drift`).
    drift_noise : ``(00, 01, 11)`` position noise (m²) to add to ``P`` after the latest check
        (zeros outside a drift episode).
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
        self._attribution = Attributions()  # gated-out reflections attributed to one reflector (:meth:`attributed`)
        #: the map for the kernels (:mod:`agvnav.positioning._integrity_fast`): x, y, radius, map_std (m), as
        #: contiguous arrays; copies, so the map and mount are read-only properties (:attr:`xy` and co)
        self._tables = tuple(np.array(a, dtype=np.float64)  # contiguous, writeable copies (numba's array type)
                             for a in (self.xy[:, 0], self.xy[:, 1], self.radius, self.map_std))
        self._mount_t = (float(self.mount[0]), float(self.mount[1]), float(self.mount[2]))
        self._flags_of: tuple[int, ...] | None = None  # the exclusions self._flags holds (:meth:`_excluded_flags`)
        self._flags = np.zeros(0, dtype=np.int64)
        self._clock = HeadClock(self.revolution_s, self.limits.max_latency_s * 2.0 * math.pi / self.revolution_s)
        self._nis = ReflectorNis(self.xy.shape[0])  # EWMA of the NIS y^2 / S per reflector
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
        self._nis.forget()
        self._raim = RaimEpisode()  # the RAIM's figures and the reflectors it named (this episode)
        self._drift = DriftModel()  # the drift episode and its noise
        self._offset = OffsetCheck()

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
        if self._attribution.rows:
            self._attribution.void(t, j, _SWEEP * self.revolution_s)
        self._nis.add(j, nis)

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
        reflector, never as support of the estimate (why: :mod:`agvnav.positioning.integrity_raim`).
        """
        if not self.limits.attribute:
            return
        self._attribution.add(t, index, innovation, self.limits.window_s)

    @property
    def _attributed(self) -> deque[Attributed]:
        """The attributed reflections, rows ``(t, map row, y, S, H0, H1, H2)`` (:class:`Attributions`)."""
        return self._attribution.rows

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
        self._raim.ran = self._raim.named = False
        if self.limits.enabled and not dead_reckoning and not young:
            reasons += self._raim_failures(t, tally)
            reasons += self._offset_failures(t)
        reasons += uncertainty_failures(cov, self.limits.lost_position_std_m, self.limits.lost_heading_std_rad)
        self.reasons = tuple(reasons) if self.limits.enabled else ()
        reasons = list(self.reasons)
        if self.limits.enabled and not dead_reckoning and not young and not self._raim.ran:
            self._exclude()  # the NIS-ratio exclusion only where the RAIM has no redundancy to judge with
        self._drift.measure(t, odom, tally.corrections, self._entries, dead_reckoning, self.limits.max_correction_m)
        return self._judge(t, reasons, len(self.excluded) > n_excluded)

    # ------------------------------------------------------------------ checks
    @property
    def _map(self) -> MonitorMap:
        """The map and sensor as the checks read them (:class:`~agvnav.positioning.integrity_support.MonitorMap`)."""
        return MonitorMap(self.xy, self.radius, self.walls, self.max_range, self._tables, self._mount_t,
                          self.bearing_std, self.odometry_noise)

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
        """The support checks (:func:`~agvnav.positioning.integrity_support.support_failures`); keeps their figures."""
        out = support_failures(self._map, self.limits, self._entries, tally, self._rejects, t, x, P, odom, young,
                               bool(self._clock.sense), self.excluded, self._excluded_flags())
        self.reflectors_used, self.survey_floor, self.crosscheck = out.reflectors_used, out.survey_floor, out.crosscheck
        if out.nis_ratio is not None:
            self.nis_ratio = out.nis_ratio
        if not math.isnan(out.correction_d2):
            self.correction_d2 = out.correction_d2
        return out.reasons

    def _information(self, head: tuple[float, float, float], sightings: np.ndarray) -> tuple[float, np.ndarray]:
        """PDOP² and survey floor (:func:`~agvnav.positioning.integrity_support.survey_information`)."""
        return survey_information(head, sightings, self._tables, self._mount_t)

    def _in_range(self, hx: float, hy: float) -> int:
        """How many reflectors (not excluded) are within ``max_range`` (m) of ``(hx, hy)`` (m), compiled."""
        rx, ry, _, _ = self._tables
        return int(in_range(hx, hy, rx, ry, self.max_range, self._excluded_flags()))

    # ------------------------------------------------------------------ RAIM
    def raim(self, t: float, tally: _Tally | None = None) -> tuple[tuple[int, ...], FdeResult] | None:
        """Leave-one-out FDE over the window (:func:`~agvnav.positioning.integrity_raim.window_raim`).

        Returns the map rows (in the order of the result's rows) and the result, or None with
        fewer than 4 reflectors or without innovations. ``tally``: the window's sums at ``t``
        (s) when the caller has them (:meth:`_tally`).
        """
        tally = self._tally(t) if tally is None else tally
        return window_raim(tally.innovations, self._attributed, t, self.limits.window_s, self.excluded,
                           self._tables[3], self.bearing_std**2, self.limits.raim_false_alarm)

    def _raim_failures(self, t: float, sums: _Tally | None = None) -> list[str]:
        """``["raim"]`` when the window fails :meth:`raim`; may exclude the reflector it keeps naming
        (:meth:`~agvnav.positioning.integrity_raim.RaimEpisode.judge`)."""
        lim = self.limits
        reasons, drop = self._raim.judge(t, self.raim(t, sums), self._failed_at, lim.recover_s, lim.raim_confirm,
                                         len(self.excluded) < lim.max_excluded, lim.min_reflectors + 1)
        if drop is not None:
            self._drop(drop)
        return reasons

    @property
    def raim_statistic(self) -> float:
        """The latest RAIM statistic over its threshold (NaN before one ran)."""
        return self._raim.statistic

    def _drop(self, j: int) -> None:
        """Exclude reflector ``j`` from now on (:attr:`excluded`) and judge the others afresh."""
        if j in self.excluded:
            return
        self.excluded = (*self.excluded, j)
        self._entries.keep(self._entries.records()["reflector"] != j)
        self._nis.forget()

    def _exclude(self) -> None:
        """Exclude the one reflector whose NIS disagrees with the others'
        (:meth:`~agvnav.positioning.integrity_nis.ReflectorNis.outlier`)."""
        lim = self.limits
        worst = self._nis.outlier(self._entries.indices(), len(self.excluded), lim.max_excluded, lim.min_reflectors,
                                  lim.exclude_sigmas, lim.exclude_ratio)
        if worst is not None:
            self._drop(worst)

    # ------------------------------------------------------------------ common offset
    def offset(self, t: float) -> tuple[np.ndarray, float] | None:
        """The pose offset the last revolution's innovations share, and its chi-square (3 dof) statistic
        (:func:`~agvnav.positioning.integrity_offset.common_offset`); None with fewer than 4 reflectors."""
        return common_offset(self._entries, self._attributed, t, self.revolution_s, self._excluded_flags(),
                             self._tables[3], self.bearing_std**2)

    def explained(self, t: float, pose: ArrayLike) -> tuple[int, int, int]:
        """``(seen, expected, rejected)`` at ``t`` (s): distinct reflectors accepted in the last revolution,
        reflectors in sight (not excluded) from the head at base_link ``pose (3,)`` (m, m, rad)
        (:func:`~agvnav.positioning.integrity_sight.reflectors_in_sight`), and reflections the gate
        rejected in the last revolution. What a fix is trusted on
        (:class:`~agvnav.positioning.deviation.DeviationWatch`): a false lock accepts a few
        bearings self-consistent about a wrong pose and misses the reflectors in sight;
        clutter adds rejections and misses none.
        """
        x = np.asarray(pose, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(x)):
            return 0, 0, 0
        rev = self.revolution_s
        rec = self._entries.records()
        seen = len({int(j) for j, tr in zip(rec["reflector"], rec["t"], strict=True) if not t - tr > rev})
        c, s = math.cos(float(x[2])), math.sin(float(x[2]))
        mx, my, _ = self._mount_t
        head = (float(x[0]) + c * mx - s * my, float(x[1]) + s * mx + c * my)
        sight = reflectors_in_sight(self.xy, self.radius, head, self.walls, self.max_range)
        sight[list(self.excluded)] = False
        rejected = sum(1 for tr in self._rejects if not t - tr > rev)
        return seen, int(sight.sum()), rejected

    def fix(self, t: float) -> tuple[np.ndarray, np.ndarray, int] | None:
        """The last revolution's bearings alone: the truth minus the estimate, its covariance and the reflectors
        (:func:`~agvnav.positioning.integrity_offset.revolution_fix`); None with fewer than 4 reflectors."""
        return revolution_fix(self._entries, self._attributed, t, self.revolution_s, self._excluded_flags(),
                              self._tables[3], self.bearing_std**2)

    def _offset_failures(self, t: float) -> list[str]:
        """``["offset"]`` (:class:`~agvnav.positioning.integrity_offset.OffsetCheck`)."""
        return self._offset.failures(t, self.offset(t), self.revolution_s, self.limits.raim_false_alarm,
                                     self._raim.named)

    # ------------------------------------------------------------------ drift model and verdict
    @property
    def drifting(self) -> bool:
        """A drift episode is open (:mod:`agvnav.positioning.integrity_drift`)."""
        return self._drift.drifting

    @property
    def drift_noise(self) -> tuple[float, float, float]:
        """``(00, 01, 11)`` position noise (m²) to add to ``P`` after the latest check (zeros outside a drift
        episode; :meth:`~agvnav.positioning.integrity_drift.DriftModel.measure`)."""
        return self._drift.noise

    def _judge(self, t: float, reasons: list[str], excluded_now: bool = False) -> bool:
        """The verdict, quality and inflation (:mod:`agvnav.positioning.integrity_verdict`); True: inflate ``P``."""
        lim = self.limits
        self._failed_at = failed_at(t, reasons, self._failed_at)  # a lone cross-check failure is not held
        self._drift.episode(t, reasons, self._raim.named, self._failed_at, lim)
        self.verdict, self._degraded_since = verdict_of(t, reasons, self._failed_at, self._degraded_since,
                                                        self.drifting, lim)
        self.quality = score(self.verdict, self.reflectors_used, self.nis_ratio, self.reasons)
        inflate = inflates(reasons, self._raim.named, excluded_now, self.verdict)
        if inflate:  # judge the inflated estimate on fresh innovations
            self._entries.clear()
            self._rejects.clear()
            self._attributed.clear()
        return inflate


def _frozen(a: np.ndarray) -> np.ndarray:
    """``a`` made read-only (its own copy: the caller's array is not touched)."""
    a.flags.writeable = False
    return a
