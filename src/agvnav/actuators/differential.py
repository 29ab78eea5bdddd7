"""Differential (tracked) drive: unicycle <-> wheel speeds, and the wheel speed loop.

[seed004 eq1], [seed004 eq2]: ``omega_R = (2 V + omega L) / (2 r)``,
``omega_L = (2 V - omega L) / (2 r)`` with V the linear speed, omega the yaw
rate, r the sprocket (wheel) radius and L the track (distance between the
tracks). They are the differential-drive equations of
:func:`agvnav.kinematics.wheel_speeds_unchecked` divided by r, and are computed
through it. The seed writes V in cm/s; here everything is SI. Arrays of wheel
speeds are ordered ``[..., right, left]`` everywhere in agvnav.actuators.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_positive
from agvnav.actuators.motor import MotorPair
from agvnav.actuators.pid import PID
from agvnav.kinematics.differential import body_speeds_unchecked, wheel_speeds_unchecked


def unicycle_to_wheels(v: ArrayLike, omega: ArrayLike, wheel_radius: float, track: float) -> NDArray[np.float64]:
    """Wheel angular speeds ``(..., 2)`` = [right, left] (rad/s) [seed004 eq1] [seed004 eq2].

    ``v`` in m/s, ``omega`` in rad/s (CCW positive, REP-103), ``wheel_radius``
    and ``track`` (distance between the wheels/tracks) in m. The wheel ground speeds
    come from :func:`agvnav.kinematics.wheel_speeds_unchecked`.
    """
    right, left = wheel_speeds_unchecked(np.asarray(v, dtype=np.float64), np.asarray(omega, dtype=np.float64), track)
    return np.stack(np.broadcast_arrays(right / wheel_radius, left / wheel_radius), axis=-1)


def wheels_to_unicycle(
    wheel_speeds: ArrayLike, wheel_radius: float, track: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(v, omega) (m/s, rad/s) from wheel speeds ``(..., 2)`` = [right, left] (rad/s).

    Inverse of [seed004 eq1] [seed004 eq2]; the same combination appears in
    [seed004 eq3], [seed004 eq4], [seed004 eq5]. Computed by
    :func:`agvnav.kinematics.body_speeds_unchecked` on the wheel ground speeds ``r ω``.
    """
    w = np.asarray(wheel_speeds, dtype=np.float64)
    return body_speeds_unchecked(wheel_radius * w[..., 0], wheel_radius * w[..., 1], track)


@dataclass(frozen=True)
class DriveGeometry:
    """Sprocket radius and track of a differential/tracked robot (m).

    Defaults: the seed-004 robot is 0.40 m wide; tracks 0.33 m apart centre to
    centre and a 0.05 m sprocket radius are assumptions (not in the seed) that
    give 0.24 m/s at the motors' 45 rpm, above the 0.15 m/s of the tests.
    ``track_width`` is the former name of ``track`` (read-only alias).
    """

    wheel_radius: float = 0.05
    track: float = 0.33

    def __post_init__(self) -> None:
        require_positive("wheel_radius", self.wheel_radius)
        require_positive("track", self.track)

    @property
    def track_width(self) -> float:
        """Former name of :attr:`track` (m), kept for callers not yet renamed."""
        return self.track

    def to_wheels(self, v: ArrayLike, omega: ArrayLike) -> NDArray[np.float64]:
        """[seed004 eq1] [seed004 eq2], see :func:`unicycle_to_wheels`."""
        return unicycle_to_wheels(v, omega, self.wheel_radius, self.track)

    def to_unicycle(self, wheel_speeds: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Inverse of [seed004 eq1] [seed004 eq2], see :func:`wheels_to_unicycle`."""
        return wheels_to_unicycle(wheel_speeds, self.wheel_radius, self.track)


@dataclass
class WheelSpeedLoop:
    """Seed 004's speed loop: one PID per motor driving the [right, left] motor pair.

    ``step(setpoint, dt)`` runs one control period: PID on the measured shaft
    speeds (from the previous step, as a real encoder would report), then the
    motors for ``dt`` s. Returns the shaft speeds (rad/s); multiply by the
    sprocket radius for track speeds.
    """

    motors: MotorPair = field(default_factory=MotorPair)
    pid: PID = field(default_factory=PID)

    def __post_init__(self) -> None:
        if self.pid.size != 2:
            raise ValueError(f"pid.size must be 2 (right, left), got {self.pid.size}")

    def reset(self) -> None:
        """Stop both motors and clear the controllers."""
        self.motors.reset()
        self.pid.reset()

    def step(self, setpoint: ArrayLike, dt: float, measured: ArrayLike | None = None) -> NDArray[np.float64]:
        """Advance ``dt`` s towards wheel speeds ``setpoint = [right, left]`` (rad/s).

        ``measured`` replaces the true shaft speeds as the PID's feedback (e.g.
        an encoder estimate with quantisation); by default the truth is used.
        """
        r = require_finite("setpoint", setpoint).reshape(2)
        y = self.motors.omega if measured is None else require_finite("measured", measured).reshape(2)
        u = self.pid.update(r, y, dt)
        return self.motors.step(u, dt)
