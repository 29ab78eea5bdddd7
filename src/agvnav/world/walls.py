"""Landmark walls of a route: the world the seed-004 tracked robot recalibrates against."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["square_landmarks"]


def square_landmarks(
    route: Any,
    side: str = "outside",
    offset: float = 0.5,
    margin: float = 0.5,
    ahead: float = 0.62,
    corner_half_width: float = 0.18,
) -> NDArray[np.float64]:
    """Landmark walls ``(2K, 2, 2)`` for a polygon route: one alongside every leg, one across every corner.

    Seed 004 §II-B/Fig. 5-6 places walls parallel to the legs (heading, eqs 6-7)
    and a wall ahead at each corner (position, eq 8); it gives no dimensions.
    Assumed here: the leg wall ``offset`` m from the route on the outside of the
    turns, from ``margin`` m after the corner to ``margin`` m before the next
    (0.5 m - 0.2 m half-width = 0.3 m ranges, inside the 3-60 cm optimum), and
    the corner wall ``ahead`` m beyond the corner, ``2 corner_half_width`` m long.
    """
    walls = []
    turn_left = _turns_left(route)
    for k in range(route.n_legs):
        start, heading, length = route.leg(k)
        u = np.array([math.cos(heading), math.sin(heading)])
        left = np.array([-u[1], u[0]])
        outward = -left if (turn_left == (side == "outside")) else left
        walls.append([start + margin * u + offset * outward, start + (length - margin) * u + offset * outward])
        corner = start + (length + ahead) * u
        walls.append([corner - corner_half_width * left, corner + corner_half_width * left])
    return np.array(walls)


def _turns_left(route: Any) -> bool:
    c = route.corners
    area = 0.5 * float(np.sum(c[:, 0] * np.roll(c[:, 1], -1) - np.roll(c[:, 0], -1) * c[:, 1]))
    return area > 0.0
