"""Nominal geometry records the autopilot reads from a plant, and body footprints.

Each plant family publishes one small frozen dataclass (docs/ARCHITECTURE.md,
"One closed loop for every vehicle"): the nominal figures a path follower needs,
never the truth. Lengths in metres, angles in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_positive

__all__ = [
    "DRIVE_POINTS",
    "HolonomicGeometry",
    "SteeredGeometry",
    "UnicycleGeometry",
    "box_footprint",
    "check_footprint",
]

#: Where a steered vehicle's traction acts: ``"C"`` the steered wheel centre (front
#: drive, seed 000 / seed 003 model B), ``"O"`` the rear-axle midpoint (seed 003 model A, Ackermann).
DRIVE_POINTS = ("C", "O")


@dataclass(frozen=True)
class SteeredGeometry:
    """Nominal geometry of a steered vehicle (tricycle, tricycle_rear, ackermann).

    Attributes
    ----------
    wheelbase : L, rear-axle midpoint O to the steered wheel centre C (m), > 0.
    drive_point : ``"C"`` (front drive) or ``"O"`` (rear drive): the point whose
        speed the plant command ``v`` sets.
    max_steer : steering angle limit (rad), in (0, pi/2].
    """

    wheelbase: float
    drive_point: str
    max_steer: float

    def __post_init__(self) -> None:
        require_positive("wheelbase", self.wheelbase)
        if self.drive_point not in DRIVE_POINTS:
            raise ValueError(f"drive_point must be one of {DRIVE_POINTS}, got {self.drive_point!r}")
        if not (math.isfinite(self.max_steer) and 0.0 < self.max_steer <= 0.5 * math.pi):
            raise ValueError(f"max_steer must be in (0, pi/2] rad, got {self.max_steer!r}")


@dataclass(frozen=True)
class UnicycleGeometry:
    """Nominal geometry of a differential/tracked base: ``track`` (wheel or track centre
    lines apart, the seed-004 gauge) and driven ``wheel_radius`` (sprocket radius), m."""

    track: float
    wheel_radius: float

    def __post_init__(self) -> None:
        require_positive("track", self.track)
        require_positive("wheel_radius", self.wheel_radius)


@dataclass(frozen=True)
class HolonomicGeometry:
    """Nominal geometry of a four-wheel mecanum base (m): wheel radius, half wheelbase a, half track b."""

    wheel_radius: float
    half_length: float
    half_width: float

    def __post_init__(self) -> None:
        require_positive("wheel_radius", self.wheel_radius)
        require_positive("half_length", self.half_length)
        require_positive("half_width", self.half_width)


def box_footprint(front: float, rear: float, half_width: float) -> NDArray[np.float64]:
    """Rectangle ``(4, 2)`` in base_link (m), counter-clockwise: x in ``[-rear, front]``, y in ``±half_width``.

    ``front + rear`` and ``half_width`` must be positive (ValueError).
    """
    if not (math.isfinite(front) and math.isfinite(rear) and front + rear > 0.0):
        raise ValueError(f"footprint needs finite front/rear with front + rear > 0, got {front!r}, {rear!r}")
    require_positive("half_width", half_width)
    return np.array([[front, -half_width], [front, half_width], [-rear, half_width], [-rear, -half_width]])


def check_footprint(footprint: ArrayLike) -> NDArray[np.float64]:
    """A body polygon ``(k, 2)`` (m, base_link) with k >= 3 finite vertices and a non-zero area, as a copy."""
    poly = require_finite("footprint", footprint)
    if poly.ndim != 2 or poly.shape[1] != 2 or poly.shape[0] < 3:
        raise ValueError(f"footprint must be a (k >= 3, 2) polygon, got shape {poly.shape}")
    x, y = poly[:, 0], poly[:, 1]
    area = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    if area == 0.0:
        raise ValueError("footprint polygon has zero area")
    return poly.copy()
