"""Traction speed profile: acceleration limits and a stop at the path end.

The guidance of seed 000 (Fig. 9) commands the steering only; the traction
speed ``v`` of the drive wheel follows a profile. This one is trapezoidal:
it accelerates at most ``max_accel`` towards the cruise speed, and brakes at
``max_decel`` so that it stops where the remaining distance runs out:
``|v| <= sqrt(2 * max_decel * remaining)`` in continuous time. In discrete
time the cap is the speed ``v`` whose step ``v dt`` plus the discrete braking
distance after it (``v^2 / (2 a) + v dt / 2``) fits in the remaining distance,
so the vehicle never passes the end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_nonnegative, require_positive


def profile_speed(
    v: ArrayLike,
    v_target: ArrayLike,
    remaining: ArrayLike,
    dt: float,
    max_accel: float,
    max_decel: float,
) -> NDArray[np.float64]:
    """Next speed set-point (m/s) of the trapezoidal profile; broadcast over ``(...)``.

    Parameters
    ----------
    v : current speed (m/s), signed (negative when reversing).
    v_target : cruise speed (m/s); its sign gives the direction of travel.
    remaining : distance left to the stop point (m, >= 0; negative counts as 0).
    dt : step (s). max_accel, max_decel : |dv/dt| limits (m/s^2) when
        speeding up and slowing down.

    Returns
    -------
    Speed to hold over the next step (m/s): within ``±max_accel*dt`` (speeding
    up) or ``±max_decel*dt`` (slowing down) of ``v``, never beyond the
    discrete braking cap in magnitude (so it stops at the end), except
    when the braking limit itself cannot be met (then it brakes at ``max_decel``).
    """
    v = np.asarray(v, dtype=np.float64)
    vt = np.asarray(v_target, dtype=np.float64)
    rem = np.maximum(np.asarray(remaining, dtype=np.float64), 0.0)
    direction = np.where(vt != 0.0, np.sign(vt), np.sign(v))
    cap = max_decel * (np.sqrt(2.25 * dt * dt + 2.0 * rem / max_decel) - 1.5 * dt)
    goal = direction * np.minimum(np.abs(vt), cap)
    speed_along = v * direction
    up = np.minimum(goal * direction, speed_along + max_accel * dt)
    down = np.maximum(goal * direction, speed_along - max_decel * dt)
    along = np.where(goal * direction >= speed_along, up, down)
    return direction * along


def _sign(a: float) -> float:
    return 1.0 if a > 0.0 else (-1.0 if a < 0.0 else 0.0)


def _profile_speed_scalar(
    v: float, v_target: float, remaining: float, dt: float, max_accel: float, max_decel: float
) -> float:
    """Scalar fast path of :func:`profile_speed` (same arithmetic, no NumPy call overhead)."""
    rem = max(remaining, 0.0)
    direction = _sign(v_target) if v_target != 0.0 else _sign(v)
    cap = max_decel * (math.sqrt(2.25 * dt * dt + 2.0 * rem / max_decel) - 1.5 * dt)
    goal = direction * min(abs(v_target), cap)
    speed_along = v * direction
    if goal * direction >= speed_along:
        along = min(goal * direction, speed_along + max_accel * dt)
    else:
        along = max(goal * direction, speed_along - max_decel * dt)
    return direction * along


@dataclass
class SpeedProfile:
    """Stateful traction speed profile (seed 000 §4 loop, issue 5 §3).

    Defaults are those of a slow indoor AGV: cruise 0.2 m/s (seed 000 guidance
    test), ``max_accel = max_decel = 0.3`` m/s² (assumed).
    """

    cruise_speed: float = 0.2
    max_accel: float = 0.3
    max_decel: float = 0.3
    stop_tolerance: float = 1e-4
    v: float = 0.0

    def __post_init__(self) -> None:
        if not math.isfinite(self.cruise_speed):
            raise ValueError("cruise_speed must be finite")
        require_positive("max_accel", self.max_accel)
        require_positive("max_decel", self.max_decel)
        require_nonnegative("stop_tolerance", self.stop_tolerance)

    def reset(self, v: float = 0.0) -> None:
        """Set the current speed (m/s)."""
        self.v = float(v)

    def command(self, remaining: float, dt: float, v_target: float | None = None) -> float:
        """Speed (m/s) to hold for the next ``dt`` s with ``remaining`` m to the end.

        ``v_target`` overrides the cruise speed (its sign is the direction of
        travel). Returns exactly 0 once ``remaining <= stop_tolerance``.
        """
        require_positive("dt", dt)
        if not math.isfinite(remaining):
            raise ValueError("remaining must be finite")
        target = self.cruise_speed if v_target is None else float(v_target)
        if remaining <= self.stop_tolerance:
            self.v = 0.0
            return 0.0
        self.v = _profile_speed_scalar(self.v, target, remaining, dt, self.max_accel, self.max_decel)
        return self.v
