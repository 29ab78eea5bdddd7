"""Fine positioning at a station, wired for the vehicle: the spot-turn lever and the plant's twist command.

The law is :class:`agvnav.guidance.FinePositioner` (the estimate settles, a short
turn-drive-turn correction, the station heading); :func:`fine_positioner` gives it what a
spot-turning vehicle is: the wheel or body command of a twist (:func:`twist_command`) and the
spot-turn acceleration its traction limit allows (:func:`spot_turn_lever`).
"""

from __future__ import annotations

from collections.abc import Callable

from agvnav.guidance import FinePositioner
from agvnav.kinematics.differential import wheel_speeds_unchecked
from agvnav.roles import Plant
from agvnav.vehicles import HolonomicGeometry, UnicycleGeometry

__all__ = ["fine_positioner", "spot_turn_lever", "twist_command"]

def spot_turn_lever(geometry: object, layout: str = "X") -> float:
    """A wheel's ground speed per unit yaw rate in a spot turn (m per rad): the traction limit
    ``max_accel`` (m/s^2) over it is the spot-turn acceleration (rad/s^2).

    * differential or tracked base (:class:`~agvnav.vehicles.UnicycleGeometry`): each wheel at half
      the track, ``v_wheel = v +- (track / 2) omega`` (:func:`agvnav.kinematics.differential.wheel_speeds`);
    * mecanum base (:class:`~agvnav.vehicles.HolonomicGeometry`, :mod:`agvnav.kinematics.omnidirectional`):
      ``r omega_i = (v_x - omega y_i) + s_i (v_y + omega x_i)``, so a pure yaw turns each wheel at
      ``|s_i x_i - y_i| omega``: ``a + b`` (half length plus half width) in the ``"X"`` layout,
      ``|a - b|`` in ``"O"`` (``layout``).

    Any other geometry (a steered vehicle cannot turn on the spot) or layout raises ValueError.
    """
    if isinstance(geometry, UnicycleGeometry):
        return 0.5 * geometry.track
    if isinstance(geometry, HolonomicGeometry):
        a, b = geometry.half_length, geometry.half_width
        if layout == "X":
            return a + b
        if layout == "O" and a != b:
            return abs(a - b)
        raise ValueError(f"mecanum layout {layout!r} with half_length {a!r}, half_width {b!r} cannot turn on the spot")
    raise ValueError(f"no spot-turn lever for geometry {type(geometry).__name__}: a differential, tracked or "
                     "mecanum base turns on the spot")


def twist_command(plant: Plant) -> Callable[[float, float], tuple[float, ...]]:
    """Plant command of a body twist ``(v, omega)`` (m/s, rad/s): wheel rates (unicycle) or the twist (holonomic).

    A unicycle base turns the twist into wheel set-points with its nominal track and wheel radius
    [seed004 eq1] [seed004 eq2]; any other vehicle raises ValueError (a steered one cannot turn on the spot).
    """
    if plant.family == "holonomic":
        return lambda v, omega: (v, 0.0, omega)
    g = plant.geometry
    if plant.family != "unicycle" or not isinstance(g, UnicycleGeometry):
        raise ValueError(f"no twist command for a {plant.family} vehicle: a differential, tracked or mecanum base "
                         "turns on the spot")

    def wheels(v: float, omega: float) -> tuple[float, ...]:
        v_right, v_left = wheel_speeds_unchecked(v, omega, g.track)
        return v_right / g.wheel_radius, v_left / g.wheel_radius

    return wheels


def fine_positioner(
    plant: Plant, layout: str, revolution_s: float, max_accel: float, turn_rate: float
) -> FinePositioner:
    """The fine positioning of a spot-turning ``plant`` (module doc).

    ``layout`` the mecanum roller layout (``"X"`` otherwise), ``revolution_s`` (s) one goniometer revolution, the
    estimate's settling unit, ``max_accel`` (m/s^2) the traction limit, which over
    :func:`spot_turn_lever` is the spot-turn acceleration (rad/s^2), ``turn_rate`` (rad/s) the spot-turn
    rate. ValueError for a vehicle that cannot turn on the spot.
    """
    twist = twist_command(plant)
    lever = spot_turn_lever(plant.geometry, layout)
    return FinePositioner(twist, revolution_s, max_accel, max_accel / lever, turn_rate)
