"""Ackermann car (seed 003 §3.2.6): kinematically the rear-traction tricycle (model A).

The two front wheels are steered by a linkage that meets the Ackermann
condition: all four wheel axes pass through one instantaneous centre on the
rear-axle line. The model uses the bicycle-equivalent ("virtual middle wheel")
angle ``φ``; ``wheel_angles`` gives the real inner and outer angles.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from agvnav._validate import require_positive
from agvnav.kinematics.base import FloatArray, scalar_inputs_or_flag
from agvnav.kinematics.tricycle import TricycleRearDrive, TricycleRearDriveSimple


def ackermann_wheel_angles(phi: ArrayLike, wheelbase: float, track: float) -> tuple[FloatArray, FloatArray]:
    """Left and right front wheel angles (rad) for bicycle angle ``φ`` (rad).

    Source: [seed003 §3.2.6] (Ackermann configuration: the two front-wheel angles φ₁, φ₂ are
    mechanically linked and the model is that of the tricycle with one virtual middle wheel);
    the seed gives no formula for the link, so it is derived here from the Ackermann condition
    (every wheel axis through the instantaneous centre on the rear-axle line). The virtual
    middle wheel turns about ``R = l / tan φ``; the left wheel is ``t/2`` closer to that centre
    for ``φ > 0``: ``tan φ_L = l tan φ / (l − (t/2) tan φ)``, ``tan φ_R = l tan φ / (l + (t/2) tan φ)``.
    Written with ``atan2`` so an inner wheel past 90° (centre between the front wheels) keeps
    a continuous angle instead of flipping sign.

    ``wheelbase`` l and ``track`` t (m) must be positive (ValueError). ``|φ| < π/2``: a scalar φ
    at/beyond ±90° or NaN raises a ValueError naming ``phi``; in a batch those elements come
    out NaN (the flag), neighbours untouched.
    """
    wheelbase = require_positive("wheelbase", wheelbase)
    track = require_positive("track", track)
    (phi_arr,), ok = scalar_inputs_or_flag(angles={"phi": phi})
    t = np.tan(np.where(ok, phi_arr, np.nan))
    num = wheelbase * t
    left = np.arctan2(num, wheelbase - 0.5 * track * t)
    right = np.arctan2(num, wheelbase + 0.5 * track * t)
    return left, right


class _AckermannMixin:
    wheelbase: float
    track: float

    def wheel_angles(self, phi: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """``(φ_left, φ_right)`` (rad) for bicycle angle φ (Ackermann condition) [seed003 §3.2.6]."""
        return ackermann_wheel_angles(phi, self.wheelbase, self.track)

    def wheel_positions(self) -> FloatArray:
        """Body positions ``(4, 2)`` of the contacts: front-left, front-right, rear-left, rear-right (m)."""
        L, h = self.wheelbase, 0.5 * self.track
        return np.array([[L, h], [L, -h], [0.0, h], [0.0, -h]])


class Ackermann(_AckermannMixin, TricycleRearDrive):
    """Ackermann car, state ``[x, y, theta, phi]`` (rear-axle midpoint), input ``[V, phi_dot]``.

    [seed003 §3.2.6]: the kinematics of the rear-traction tricycle on the bicycle angle.

    Parameters
    ----------
    wheelbase : l, rear axle to front axle (m), > 0.
    track : t, distance between the front wheels (m), > 0.
    max_steer : limit of the bicycle angle |φ| (rad), < π/2.
    max_steer_rate : |φ̇| limit (rad/s).
    """

    def __init__(self, wheelbase: float, track: float, max_steer: float = np.deg2rad(40.0),
                 max_steer_rate: float = np.inf) -> None:
        super().__init__(wheelbase, max_steer, max_steer_rate)
        self.track = require_positive("track", track)


class AckermannSimple(_AckermannMixin, TricycleRearDriveSimple):
    """Ackermann car with the bicycle angle commanded directly: state ``[x, y, theta]``, input ``[V, phi]``.

    [seed003 §3.2.6], simplified like the tricycle's model A.
    """

    def __init__(self, wheelbase: float, track: float, max_steer: float = np.deg2rad(40.0)) -> None:
        super().__init__(wheelbase, max_steer)
        self.track = require_positive("track", track)
