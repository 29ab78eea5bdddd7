"""The streaming estimator's input part: time order, plausibility and the odometry clock.

:class:`InputChecks` owns what the estimator knows of time: the latest input, the first one,
the latest odometry message, the rate of the last increment and the odometry already
extrapolated to a reflection. It judges every input before it reaches the filter
(:mod:`agvnav.positioning.plausibility`): strict (the API) raises ValueError, else the
reading is dropped and counted per reason (a running vehicle never aborts on one bad
reading).

Reflections usually fall between two odometry samples. The estimator then extrapolates
the odometry to the reflection instant at the rate of the last increment
(:meth:`InputChecks.extrapolate`), and deducts that advance from the next increment
(:meth:`InputChecks.take_odometry`), so the odometric path is never counted twice and
never jumps.
"""

from __future__ import annotations

import math
from typing import Any

from agvnav.positioning import _fast
from agvnav.positioning.plausibility import MAX_DEPARTURE, DropCounter, PlausibilityLimits, implausible_increment

__all__ = ["InputChecks", "finite_float"]

_INF = math.inf
Triple = tuple[float, float, float]


def finite_float(name: str, value: Any) -> float:
    """``value`` as a finite float, else ValueError naming ``name`` (scalar fast path of ``require_finite``)."""
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric: {exc}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} contains NaN or inf")
    return v


class InputChecks:
    """Time order, plausibility and the odometry clock of one streaming estimator.

    ``strict`` raises on a bad input, else drops and counts it (:attr:`drops`);
    ``plausibility`` are the limits (max speed and yaw rate, max gap, late window).
    """

    def __init__(self, strict: bool, plausibility: PlausibilityLimits) -> None:
        self.strict = bool(strict)
        self.plausibility = plausibility
        self.drops = DropCounter()
        self.t: float | None = None  # latest input (s)
        self.t_first: float | None = None
        self.t_odometry: float | None = None
        self.rate: Triple = (0.0, 0.0, 0.0)  # odometry rate (m/s, rad/s, lateral m/s) of the last increment
        self.advance: Triple = (0.0, 0.0, 0.0)  # extrapolated odometry not yet covered by an increment

    @property
    def now(self) -> float:
        """The latest input's time (s), NaN before the first."""
        return math.nan if self.t is None else self.t

    def refuse(self, t: float, reason: str, message: str) -> None:
        """ValueError with ``message`` (strict), else count the dropped reading under ``reason``."""
        if self.strict:
            raise ValueError(message)
        self.drops.drop(t, reason)

    def check_time(self, t: float, what: str) -> float:
        """``t`` (s) as a float no earlier than the latest input, else ValueError."""
        t = finite_float("t", t)
        if self.t is not None and t < self.t:
            raise ValueError(
                f"{what} at t={t!r} s is earlier than the previous input at t={self.t!r} s; "
                "feed odometry and reflections in time order"
            )
        if self.t_first is None:
            self.t_first = t
        return t

    # ------------------------------------------------------------------ odometry
    def odometry(
        self, t: float, delta_d: float, delta_theta: float, delta_lateral: float
    ) -> tuple[float, float, float, float, tuple[float, Triple] | None] | None:
        """``(t, dd, dth, dl, blow_up)`` to integrate, or None when the message is dropped.

        A non-finite or impossible increment is replaced by the motion at the last rate over
        its span (the vehicle most likely went on; the rate capped at the limits,
        :meth:`plausible_rate`); a time gap beyond ``max_gap_s`` is not integrated. Either way
        the motion of the span is unknown: ``blow_up = (span, rate)`` asks the caller to grow
        the variances (:meth:`blow_up_variances`). The first message is judged as if it
        spanned ``max_gap_s`` (an increment of -1e6 m once moved the pose 1,000 km); refused,
        it is replaced by no motion. The closed loop's every call (finite Python floats, in
        time order, plausible) takes a fast path that skips the conversions.
        """
        t_prev, t_odo = self.t, self.t_odometry
        if (
            type(t) is float and type(delta_d) is float and type(delta_theta) is float
            and type(delta_lateral) is float and t_prev is not None and t_odo is not None
            and self.t_first is not None and _INF > t >= t_prev and -_INF < delta_d < _INF
            and -_INF < delta_theta < _INF and -_INF < delta_lateral < _INF
            and implausible_increment(self.plausibility, t - t_odo, delta_d, delta_theta, delta_lateral) is None
        ):
            return t, delta_d, delta_theta, delta_lateral, None
        try:
            t = finite_float("t", t)
        except ValueError:
            self.refuse(self.now, "non_finite", "t contains NaN or inf")
            return None
        if self.t is not None and t < self.t:
            self.refuse(t, "out_of_order", f"odometry at t={t!r} s is earlier than the previous input at "
                        f"t={self.t!r} s; feed odometry and reflections in time order")
            return None
        self.check_time(t, "odometry")
        first = self.t_odometry is None
        span = t - (self.t_first if first else self.t_odometry)  # type: ignore[operator]
        try:
            inc = (
                finite_float("odometry increment", delta_d),
                finite_float("odometry increment", delta_theta),
                finite_float("odometry increment", delta_lateral),
            )
            reason = implausible_increment(self.plausibility, None if first else span, *inc)
        except ValueError as exc:
            inc, reason, message = (math.nan,) * 3, "non_finite", f"{exc} (t={t!r} s)"
        if reason is None:  # the message is formatted only for a dropped increment (issue 11: 16 us a call)
            return t, inc[0], inc[1], inc[2], None
        if reason != "non_finite":
            message = (
                f"odometry increment {inc} over {span!r} s at t={t!r} s is implausible ({reason}); "
                f"limits {self.plausibility}"
            )
        self.refuse(t, reason, message)
        rate = (0.0, 0.0, 0.0) if reason == "time_gap" or first else self.rate
        return t, rate[0] * span, rate[1] * span, rate[2] * span, (span, rate)

    def take_odometry(self, t: float, dd: float, dth: float, dl: float) -> Triple:
        """Book an accepted increment up to ``t`` (s); returns the part not yet extrapolated (m, rad, m)."""
        if self.t_odometry is not None and t > self.t_odometry:
            self.rate = self.plausible_rate(t - self.t_odometry, dd, dth, dl)
        ahead = self.advance
        self.advance = (0.0, 0.0, 0.0)
        self.t_odometry = t
        self.t = t
        return dd - ahead[0], dth - ahead[1], dl - ahead[2]

    def extrapolate(self, t: float) -> Triple | None:
        """The odometry at the last rate from the latest input to ``t`` (s), booked as advance; None if none.

        No farther than ``max_gap_s`` past the latest odometry: beyond, the motion is unknown
        (the next odometry message is a time gap), and a reflection 1e300 s ahead once moved
        the pose 3e300 m with an inf covariance.
        """
        if self.t_odometry is None or self.t is None:
            return None
        end = min(t, self.t_odometry + self.plausibility.max_gap_s)
        if not end > self.t:
            return None
        span = end - self.t
        ahead = (self.rate[0] * span, self.rate[1] * span, self.rate[2] * span)
        done = self.advance
        self.advance = (done[0] + ahead[0], done[1] + ahead[1], done[2] + ahead[2])
        return ahead

    def plausible_rate(self, span: float, dd: float, dth: float, dl: float) -> Triple:
        """The rate (m/s, rad/s, m/s) of an accepted increment over ``span`` (s), capped at the limits.

        An increment over a short span passes the check on its slack (``slack_m``), not on
        the speed limit: the first piece of a burst that carries seconds of missed motion
        (``odometry_lost``: 4 mm in 0.8 ms, 5 m/s) passed, and the pieces after it, refused
        as too fast, were replaced by the motion at that rate -- the estimate ran 0.25 m
        ahead in 50 ms while its sigma stayed at 5 mm. The rate that stands in for a
        refused increment (and extrapolates to a reflection) is one the vehicle can have.
        """
        lim = self.plausibility
        v_d, w, v_l = dd / span, dth / span, dl / span
        speed = math.hypot(v_d, v_l)
        if speed > lim.max_speed_m_s:
            v_d, v_l = v_d * lim.max_speed_m_s / speed, v_l * lim.max_speed_m_s / speed
        return v_d, max(-lim.max_yaw_rate_rad_s, min(lim.max_yaw_rate_rad_s, w)), v_l

    def blow_up_variances(self, span: float, rate: Triple) -> tuple[float, float]:
        """Position and heading variance growth (m², rad²) for ``span`` s of unknown motion beyond ``rate``.

        The square of the largest departure from ``rate`` the limits allow,
        ``(max_speed_m_s + |v|) span`` and ``(max_yaw_rate_rad_s + |omega|) span`` (a time gap:
        the rate is 0), capped so that a gap of 1e300 s cannot overflow.
        """
        lim = self.plausibility
        d = min((lim.max_speed_m_s + math.hypot(rate[0], rate[2])) * span, MAX_DEPARTURE)
        a = min((lim.max_yaw_rate_rad_s + abs(rate[1])) * span, MAX_DEPARTURE)
        return d * d, a * a

    # ------------------------------------------------------------------ reflections
    def reflection(self, t: float, bearing: float, offset: float) -> tuple[float, float] | None:
        """``(t, wrap(bearing + offset))``, or None when dropped (non-finite, or older than the late window)."""
        try:
            t, b = finite_float("t", t), finite_float("bearing", bearing)
        except ValueError as exc:
            self.refuse(self.now, "non_finite", str(exc))
            return None
        if self.t is not None and t < self.t - self.plausibility.late_window_s:
            self.refuse(t, "late", f"reflection at t={t!r} s is earlier than the previous input at t={self.t!r} s "
                        f"by more than late_window_s={self.plausibility.late_window_s!r} s")
            return None
        if self.t_first is None:
            self.t_first = t
        return t, _fast.wrap(b + offset)

    def late_span(self, t: float) -> float:
        """How far (s) a late reflection at ``t`` lies behind the extrapolated present."""
        t_now = self.t if self.t is not None else t
        if self.t_odometry is not None:
            t_now = min(t_now, self.t_odometry + self.plausibility.max_gap_s)
        return max(t_now - t, 0.0)
