"""The wall-landmark localizer's parameters, its calibration record, and the check that a route meets landmarks.

:class:`LandmarkParams` (seed 004 §II-B: the HY-SRF05's 0.60 m optimal range, the side
pairs) configures :class:`agvnav.positioning.wall_landmarks.WallLandmarkLocalizer`; each
correction it applies is a :class:`Calibration` in its ``history``;
:func:`check_route_passes_landmarks` refuses a route along which no wall is in the side
rangers' reach.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_nonnegative, require_positive
from agvnav.positioning.wall_ranging import SIDES
from agvnav.sensors.ultrasonic import check_wall_segments

__all__ = ["SEED_004_PAIRS", "Calibration", "LandmarkParams", "check_route_passes_landmarks"]


@dataclass(frozen=True)
class Calibration:
    """One applied correction: time (s), kind (``"heading"``, ``"side_offset"``,
    ``"front_offset"``), wall index, pose before and after (``(3,)``), the ``side``
    whose sensors made it (``"right"``, ``"left"``, ``"front"``; ``""`` for a direct
    call) and the wall's name ``wall_id``."""

    t: float
    kind: str
    wall: int
    before: NDArray[np.float64]
    after: NDArray[np.float64]
    side: str = ""
    wall_id: str = ""


SEED_004_PAIRS = (("right", "right_front", "right_rear"), ("left", "left_front", "left_rear"))

@dataclass(frozen=True)
class LandmarkParams:
    """Association and calibration parameters of :class:`WallLandmarkLocalizer` (SI units).

    detect_range : a reading counts only up to this range (m); 0.60 m is the seed's
        optimal range of the HY-SRF05.
    gate, front_gate : largest |measured - predicted| range (m) for a side sensor / the
        front sensor to be associated with a wall (the front gate is wider: the
        along-track error grows with the distance driven since the last corner).
    end_margin : both sensors of a side pair must project onto the wall at least this
        far (m) inside its ends (near an end the cone sees the corner, not the face).
    calibration_gain : blend of each correction in (0, 1] (1 replaces, as the seed).
    pair_max_age : the two readings of a pair must be at most this old (s).
    lateral_calibration : also fix the distance to a side wall (an extension).
    parallel_tolerance : a wall is "alongside" when its direction is within this
        angle (rad) of the estimated heading, and "across" (the front-wall correction) otherwise.
    side_pairs : ``(side, front sensor, rear sensor)`` names of the side pairs.
    front_sensor : name of the forward sensor (the front-wall correction).
    """

    detect_range: float = 0.60
    gate: float = 0.15
    front_gate: float = 0.30
    end_margin: float = 0.05
    calibration_gain: float = 0.25
    pair_max_age: float = 0.12
    lateral_calibration: bool = True
    parallel_tolerance: float = math.radians(10.0)
    side_pairs: tuple[tuple[str, str, str], ...] = SEED_004_PAIRS
    front_sensor: str = "front"

    def __post_init__(self) -> None:
        for name in ("detect_range", "gate", "front_gate", "pair_max_age", "parallel_tolerance"):
            require_positive(name, getattr(self, name))
        require_nonnegative("end_margin", self.end_margin)
        if not 0.0 < self.calibration_gain <= 1.0:
            raise ValueError(f"calibration_gain must be in (0, 1], got {self.calibration_gain!r}")
        for side, *_ in self.side_pairs:
            if side not in SIDES:
                raise ValueError(f"side_pairs: side must be 'right' or 'left', got {side!r}")

    @property
    def sensor_names(self) -> set[str]:
        """Every ranger name the parameters refer to."""
        return {self.front_sensor, *(n for _, front, rear in self.side_pairs for n in (front, rear))}


def check_route_passes_landmarks(
    legs: Iterable[tuple[ArrayLike, float, float]],
    walls: ArrayLike,
    body_width: float,
    detect_range: float = 0.60,
    parallel_tolerance: float = math.radians(10.0),
) -> None:
    """ValueError unless some wall runs alongside some leg within the side rangers' reach.

    ``legs`` yields ``(start (2,), heading (rad), length (m))``; ``walls (M, 2, 2)`` (m);
    a wall is within reach when its mean lateral offset from the leg line lies in
    ``(body_width / 2, body_width / 2 + detect_range]`` and it overlaps the leg.
    """
    segs = check_wall_segments(walls) if np.size(walls) else np.zeros((0, 2, 2))
    half_width = body_width / 2.0
    for start, heading, length in legs:
        u = np.array([math.cos(heading), math.sin(heading)])
        for seg in segs:
            d = seg[1] - seg[0]
            if abs(math.sin(math.atan2(d[1], d[0]) - heading)) > math.sin(parallel_tolerance):
                continue
            along = (seg - np.asarray(start)) @ u
            lateral = abs(float(np.mean((seg - np.asarray(start)) @ np.array([-u[1], u[0]]))))
            overlap = min(along.max(), length) - max(along.min(), 0.0)
            if overlap > 0.0 and half_width < lateral <= half_width + detect_range:
                return
    raise ValueError(
        "the route never passes a landmark: no landmark wall runs alongside a leg within "
        f"{detect_range:.2f} m of the side sensors"
    )
