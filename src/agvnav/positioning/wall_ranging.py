"""Seed 004's wall-landmark relations: dead reckoning, heading from a side pair, distance from a wall.

Seed 004 positions a tracked robot on a fixed route by dead reckoning
([seed004 eq3] [seed004 eq4] [seed004 eq5]) and recalibrates it with walls placed along the route as
landmarks, measured by HY-SRF05 rangers (agvnav.sensors.ultrasonic):

* **Orientation** ([seed004 eq6] [seed004 eq7]): two side sensors ``dist`` apart along the body,
  both beaming perpendicular to it, see a wall alongside at ranges US1
  (front) and US2 (rear). With the wall on the *right*, a CCW heading offset
  theta relative to the wall direction moves the front sensor away:
  ``theta = arctan((US1 - US2) / dist)`` ([seed004 eq7]; [seed004 eq6] is the same
  expression written for theta < 0). With the wall on the left the sign flips. The
  seed's arctan assumes each range is measured *along the sensor axis*
  (the perpendicular distance divided by cos(theta), so the difference is
  ``dist * tan(theta)``): that is ``beam="ray"``. A cone-beam ultrasonic
  ranger (agvnav.sensors.ultrasonic) returns the *nearest* echo, which is the
  perpendicular distance itself whenever |theta| is within the beam
  half-angle; the difference is then ``dist * sin(theta)`` and the exact
  inverse is arcsin: ``beam="cone"``, our default. The two agree to
  O(theta^3) (1e-4 rad at 3.6 deg), so this deviation only removes a bias.
* **Position at a corner** [seed004 eq8]: the front sensor measures the wall ahead,
  ``x = x_lan - US``. Here generalised to any wall line, heading and mount:
  a range ``r`` from a sensor mounted at ``m = (x_s, y_s, phi)`` on a robot at
  ``p, theta`` gives the sensor's distance to the wall line ``n . q = c``
  (unit normal ``n`` towards the robot): ``r`` for the cone beam (nearest
  echo), ``-r n . b`` with ``b`` the beam direction for the ray model; then
  ``n . p = c + distance - n . R(theta) [x_s, y_s]``. This fixes the position
  component along ``n`` only; the tangential component is kept from dead
  reckoning. [seed004 eq8] is the case theta = 0, sensor at base_link (both models).
* **Lateral offset from the side pair** (an extension, not in the seed: the
  same relation with the side sensors fixes the distance to a side wall).

Dead reckoning uses the Euler rule of [seed004 eq3] [seed004 eq4] [seed004 eq5], as the seed does, through
agvnav.odometry.integrate_pose (:func:`dead_reckoning_step`).
:class:`agvnav.positioning.wall_landmarks.WallLandmarkLocalizer` applies these relations.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_positive
from agvnav.geometry import wrap_angle
from agvnav.odometry import integrate_pose

__all__ = ["SIDES", "check_beam", "dead_reckoning_step", "distance_from_wall", "heading_from_side_pair", "wall_line"]

SIDES = ("right", "left")


def dead_reckoning_step(
    pose: ArrayLike, omega_right: ArrayLike, omega_left: ArrayLike, wheel_radius: float, track_width: float, dt: float
) -> NDArray[np.float64]:
    """Pose ``(..., 3)`` after ``dt`` s of wheel speeds (rad/s) [seed004 eq3] [seed004 eq4] [seed004 eq5].

    ``x += r/2 (wR + wL) cos(theta) dt``, ``y += r/2 (wR + wL) sin(theta) dt``,
    ``theta += r/L (wR - wL) dt`` (Euler rule, evaluated at the old heading).
    """
    p = np.asarray(pose, dtype=np.float64)
    wr, wl = np.asarray(omega_right, dtype=np.float64), np.asarray(omega_left, dtype=np.float64)
    delta_d = wheel_radius / 2.0 * (wr + wl) * dt
    delta_theta = wheel_radius / track_width * (wr - wl) * dt
    return integrate_pose(p, delta_d, delta_theta, rule="euler")


def heading_from_side_pair(
    us_front: ArrayLike,
    us_rear: ArrayLike,
    spacing: float,
    side: str,
    wall_heading: ArrayLike = 0.0,
    beam: str = "cone",
) -> NDArray[np.float64]:
    """Robot heading (rad) from a side sensor pair beside a wall [seed004 eq6] [seed004 eq7].

    Parameters
    ----------
    us_front, us_rear : ranges (m) of the front (US1) and rear (US2) sensor,
        ``(...)``; both beams perpendicular to the body, towards the wall.
    spacing : distance between the two sensors along the body (m), ``dist``.
    side : ``"right"`` or ``"left"``, the side the wall is on.
    wall_heading : direction (rad) of the wall taken along the travel direction.
    beam : ``"ray"`` for the seed's ``theta = ±arctan((US1 - US2) / dist)``,
        ``"cone"`` (default) for ``±arcsin`` (nearest-echo ranges, see module doc).

    Returns ``wall_heading + theta``.
    """
    if side not in SIDES:
        raise ValueError(f"side must be 'right' or 'left', got {side!r}")
    check_beam(beam)
    require_positive("spacing", spacing)
    ratio = (np.asarray(us_front, dtype=np.float64) - np.asarray(us_rear, dtype=np.float64)) / spacing
    theta = np.arctan(ratio) if beam == "ray" else np.arcsin(np.clip(ratio, -1.0, 1.0))
    return wrap_angle(np.asarray(wall_heading) + (theta if side == "right" else -theta))


def wall_line(segment: ArrayLike, toward: ArrayLike) -> tuple[NDArray[np.float64], float]:
    """Unit normal ``n (2,)`` of a wall segment ``(2, 2)`` pointing to ``toward (2,)``, and ``c = n . a``.

    The wall's line is ``{q : n . q = c}``; ``n . p - c`` is the signed distance of ``p``.
    """
    seg = require_finite("wall segment", segment).reshape(2, 2)
    d = seg[1] - seg[0]
    length = float(np.hypot(*d))
    if length <= 0.0:
        raise ValueError(f"wall segment has zero length: {seg.tolist()}")
    n = np.array([-d[1], d[0]]) / length
    if np.dot(n, np.asarray(toward, dtype=np.float64) - seg[0]) < 0.0:
        n = -n
    return n, float(np.dot(n, seg[0]))


def distance_from_wall(
    ranges: ArrayLike, mounts: ArrayLike, heading: float, normal: ArrayLike, beam: str = "cone"
) -> NDArray[np.float64]:
    """Signed distance (m) of base_link from a wall line, one value per reading ([seed004 eq8] generalised).

    Parameters
    ----------
    ranges : ``(k,)`` measured ranges (m). mounts : ``(k, 3)`` sensor mounts
        ``(x, y, phi)`` in base_link. heading : robot heading (rad).
    normal : unit normal ``(2,)`` of the wall, pointing to the robot.
    beam : ``"cone"`` (range = perpendicular distance) or ``"ray"`` (range along the axis).

    Returns ``n . p - c`` implied by each reading: ``d_sensor - n . R m_xy``
    with ``d_sensor = r`` (cone) or ``-r n . b`` (ray).
    """
    check_beam(beam)
    r = np.asarray(ranges, dtype=np.float64)
    m = np.asarray(mounts, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normal, dtype=np.float64)
    c, s = math.cos(heading), math.sin(heading)
    offset = np.stack([c * m[:, 0] - s * m[:, 1], s * m[:, 0] + c * m[:, 1]], axis=-1)
    axis = np.stack([np.cos(heading + m[:, 2]), np.sin(heading + m[:, 2])], axis=-1)
    sensor_distance = r if beam == "cone" else -r * (axis @ n)
    return sensor_distance - offset @ n


def check_beam(beam: str) -> None:
    """ValueError unless ``beam`` is a range geometry of this module: ``"cone"`` or ``"ray"``."""
    if beam not in ("cone", "ray"):
        raise ValueError(f"beam must be 'cone' or 'ray', got {beam!r}")
