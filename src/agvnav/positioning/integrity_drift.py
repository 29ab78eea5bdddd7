"""Integrity: the drift episode and its model -- the odometry erring beyond its noise model, measured.

A failure that says the estimate moved off its bearings (:data:`ODOMETRY_REASONS`: NIS,
corrections, common offset, rejections, unexplained reflectors; not when the RAIM names a
reflector) opens a *drift episode*: the odometry errs beyond its noise model, and a one-off
inflation is not enough while it goes on (wheel slip: the filter lags the continuing slip and
the checks pass on the lagging estimate). While the episode lasts, :class:`DriftModel` measures
the drift from the window's Kalman corrections and asks the estimator to grow ``P`` at that
rate (:attr:`DriftModel.noise`, :meth:`DriftModel.measure`), and the verdict stays ``degraded``
until ``recover_s`` after the last window whose corrections summed beyond
``max_correction_m``; the hold, its checks passing, does not count towards ``lost_after_s``
(:mod:`agvnav.positioning.integrity_verdict`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from agvnav.positioning.integrity_limits import IntegrityLimits
from agvnav.positioning.integrity_window import _OX, _OY, _Window

__all__ = ["ODOMETRY_REASONS", "DriftModel"]

#: Failed checks that say the estimate moved off its bearings (not a named measurement fault): they open
#: a drift episode (:meth:`DriftModel.episode`).
ODOMETRY_REASONS = frozenset({"nis", "corrections", "rejections", "unexplained", "offset"})


class DriftModel:
    """The drift episode (:attr:`drifting`) and the position noise it asks for (:attr:`noise`, module docstring).

    ``noise``: ``(00, 01, 11)`` position noise (m²) the estimator adds to ``P`` after the
    latest check (zeros outside an episode). Kept: the latest window drift ``D`` (m), the
    odometric distance it was measured over (m), the odometric position of the previous
    check and the last check with evidence of drift (s).
    """

    def __init__(self) -> None:
        self.drifting = False
        self.noise = (0.0, 0.0, 0.0)
        self._d = (0.0, 0.0)
        self._s = 0.0
        self._odom: tuple[float, float] | None = None
        self._seen = -math.inf

    def measure(
        self, t: float, odom: tuple[float, ...], corrections: tuple[float, ...], window: _Window,
        dead_reckoning: bool, max_correction_m: float,
    ) -> None:
        """The window's Kalman corrections as a drift measurement, and the drift noise of this check.

        The corrections of the window sum to ``D = sum K y`` (m), over the odometric distance
        ``s_w`` (m) the vehicle covered in it. Once the estimate has moved off its bearings
        (a failed check in :data:`ODOMETRY_REASONS`: the drift *episode*), the odometry is
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
        check's (:mod:`agvnav.positioning.integrity_offset`). (Against the estimate's own sigma,
        ``|D|^2 > tr P_pos``, a false alarm of the correction check on the sound differential
        AGV held ``degraded`` 3 s on correction noise.) ``odom`` is the odometric pose now,
        ``corrections`` the window's sums at ``t`` (s) (``_Tally.corrections`` of
        :mod:`~agvnav.positioning.integrity_window`), ``window`` the window whose oldest row's
        odometric position starts the distance.
        """
        ox, oy = float(odom[0]), float(odom[1])
        step = 0.0 if self._odom is None else math.hypot(ox - self._odom[0], oy - self._odom[1])
        self._odom = (ox, oy)
        dx, dy, _, _, _, n = corrections
        if n >= 8 and not dead_reckoning:
            first = window.row(0)
            self._d = (dx, dy)
            self._s = math.hypot(ox - first[_OX], oy - first[_OY])  # the oldest row's odom_x, odom_y
            if math.hypot(dx, dy) > max_correction_m:
                self._seen = t
        self.noise = (0.0, 0.0, 0.0)
        if self.drifting and self._s > 0.0:
            dx, dy = self._d
            cap = min(1.0, self._s / max(math.hypot(dx, dy), 1e-300))  # slip of at most 100 %
            k = step / self._s * cap * cap
            self.noise = (k * dx * dx, k * dx * dy, k * dy * dy)

    def episode(
        self, t: float, reasons: Iterable[str], raim_named: bool, failed_at: float, limits: IntegrityLimits
    ) -> None:
        """Open the episode on a failure in :data:`ODOMETRY_REASONS` (unless the RAIM named a reflector), or
        close it once ``recover_s`` passed since the last evidence of drift and the last failure ``failed_at`` (s)."""
        if limits.enabled and not raim_named and ODOMETRY_REASONS.intersection(reasons):
            self.drifting = True  # the estimate moved off its bearings: the drift model (:meth:`measure`)
        elif self.drifting and t - max(self._seen, failed_at) >= limits.recover_s:
            self.drifting = False  # a window of corrections within the estimate's sigma since the evidence
