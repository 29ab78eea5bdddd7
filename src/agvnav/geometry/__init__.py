"""Plane geometry: angles, SE(2) poses, intersections."""

from agvnav.geometry.angles import PI, TWO_PI, angle_diff, deg2rad, rad2deg, wrap_angle, wrap_angle_scalar
from agvnav.geometry.intersect import (
    circumcentre,
    cross2,
    intersect_lines,
    segment_distances,
    triangle_signed_area,
)
from agvnav.geometry.se2 import (
    bearing_to,
    between,
    compose,
    inverse,
    lateral_position_error,
    to_body,
    transform_points,
)

__all__ = [
    "PI",
    "TWO_PI",
    "angle_diff",
    "bearing_to",
    "between",
    "circumcentre",
    "compose",
    "cross2",
    "deg2rad",
    "intersect_lines",
    "inverse",
    "lateral_position_error",
    "rad2deg",
    "segment_distances",
    "to_body",
    "transform_points",
    "triangle_signed_area",
    "wrap_angle",
    "wrap_angle_scalar",
]
