"""Plausibility limits on the estimator's inputs (issue 12 §1).

A reading a vehicle cannot have produced must not move the estimate: an odometry
increment faster than the vehicle can drive or turn in the elapsed time (a 32-bit
counter wrap, a spike), a time gap between odometry messages beyond a limit, a
non-finite value, a non-positive-definite covariance. In the API (``strict=True``)
each raises ValueError naming the problem; a running vehicle (``strict=False``, the
simulator's mode) drops the reading and counts it per reason (:class:`DropCounter`),
so one bad reading never aborts a run.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MAX_DEPARTURE",
    "DropCounter",
    "PlausibilityLimits",
    "check_covariance",
    "implausible_increment",
    "sound_state",
]

#: Largest departure (m, rad) a refused span may add to the pose's std: the growth of ``P`` for a
#: time gap of ``1e300`` s would overflow to inf (a 1,000 km std already says "position unknown",
#: and the integrity monitor's ``uncertainty`` check makes the verdict ``lost`` long before).
MAX_DEPARTURE = 1e6


@dataclass(frozen=True)
class PlausibilityLimits:
    """What the vehicle can physically do, and how late a reflection may arrive.

    Attributes
    ----------
    max_speed_m_s:
        Largest speed of base_link (m/s): ``hypot(dd, dl) <= max_speed_m_s * dt + slack_m``.
    max_yaw_rate_rad_s:
        Largest yaw rate (rad/s): ``|dtheta| <= max_yaw_rate_rad_s * dt + slack_rad``.
    max_gap_s:
        Largest time (s) between two odometry messages.
    late_window_s:
        Reflections up to this much older (s) than the latest input are put in time
        order (applied at their own instant through the odometry) rather than rejected.
    slack_m, slack_rad:
        Allowance for encoder quantisation and time-stamp jitter (m, rad).
    """

    max_speed_m_s: float = 3.0
    max_yaw_rate_rad_s: float = 3.0
    max_gap_s: float = 10.0
    late_window_s: float = 0.2
    slack_m: float = 0.01
    slack_rad: float = 0.01

    def __post_init__(self) -> None:
        for name in ("max_speed_m_s", "max_yaw_rate_rad_s", "max_gap_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        for name in ("late_window_s", "slack_m", "slack_rad"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"{name} must be a non-negative finite number, got {v!r}")


def implausible_increment(
    limits: PlausibilityLimits, span: float | None, delta_d: float, delta_theta: float, delta_lateral: float = 0.0
) -> str | None:
    """Why the odometry increment over ``span`` (s) is impossible, or None when it is plausible.

    Reasons: ``"time_gap"`` (``span > max_gap_s``), ``"too_fast"`` (distance beyond
    ``max_speed_m_s * span + slack_m``), ``"turns_too_fast"`` (heading change beyond
    ``max_yaw_rate_rad_s * span + slack_rad``). Increments in m and rad.

    ``span=None``: the first message, whose span is unknown (there is no earlier odometry):
    it is judged as if it spanned the largest gap allowed, ``max_gap_s`` (with the defaults
    30 m and 30 rad), so a spike or a counter wrap in the very first message is caught too.
    """
    if span is None:
        span = limits.max_gap_s
    if span > limits.max_gap_s:
        return "time_gap"
    if math.hypot(delta_d, delta_lateral) > limits.max_speed_m_s * span + limits.slack_m:
        return "too_fast"
    if abs(delta_theta) > limits.max_yaw_rate_rad_s * span + limits.slack_rad:
        return "turns_too_fast"
    return None


def check_covariance(name: str, value: ArrayLike) -> NDArray[np.float64]:
    """``value`` as a finite, symmetric, positive-definite ``(3, 3)`` covariance, else ValueError naming ``name``."""
    P = np.asarray(value, dtype=np.float64)
    if P.shape != (3, 3):
        raise ValueError(f"{name} must have shape (3, 3), got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ValueError(f"{name} contains NaN or inf")
    if not np.allclose(P, P.T, rtol=1e-9, atol=1e-15):
        raise ValueError(f"{name} must be symmetric")
    eig = np.linalg.eigvalsh(0.5 * (P + P.T))
    if not eig[0] > 0.0:
        raise ValueError(f"{name} must be positive definite, smallest eigenvalue {eig[0]!r}")
    return 0.5 * (P + P.T)


def sound_state(x: tuple[float, ...], P: tuple[float, ...]) -> bool:
    """Whether pose ``x`` (3 floats, m, rad) is finite and ``P`` (9 floats row-major, m², rad²) a
    finite, symmetric, positive-definite covariance.

    Positive definite by Sylvester's criterion (the leading minors, which is what a Cholesky
    factorisation succeeds on up to rounding); symmetric within 1e-9 relative. Plain float
    arithmetic: it runs after every call of a streaming estimator.
    """
    x0, x1, x2 = x
    p0, p1, p2, p3, p4, p5, p6, p7, p8 = P
    if not (-math.inf < x0 < math.inf and -math.inf < x1 < math.inf and -math.inf < x2 < math.inf):
        return False
    if not (0.0 < p0 < math.inf and 0.0 < p4 < math.inf and 0.0 < p8 < math.inf):
        return False
    tol = 1e-9 * (p0 + p4 + p8)
    if not (abs(p1 - p3) <= tol and abs(p2 - p6) <= tol and abs(p5 - p7) <= tol):  # NaN compares False too
        return False
    minor = p0 * p4 - p1 * p3
    det = p0 * (p4 * p8 - p5 * p7) - p1 * (p3 * p8 - p5 * p6) + p2 * (p3 * p7 - p4 * p6)
    return minor > 0.0 and math.inf > det > 0.0


class DropCounter:
    """Readings dropped by a running estimator, per reason (``n_dropped``), and the latest one."""

    def __init__(self) -> None:
        self.by_reason: Counter[str] = Counter()
        self.last: tuple[float, str] | None = None

    def drop(self, t: float, reason: str) -> None:
        """Count one reading at ``t`` (s) dropped for ``reason``."""
        self.by_reason[reason] += 1
        self.last = (t, reason)

    @property
    def total(self) -> int:
        """Readings dropped so far."""
        return sum(self.by_reason.values())
