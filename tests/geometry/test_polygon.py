"""The compiled points-in-polygon test (geometry.polygon) against shapely's, the oracle."""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry import Polygon

from agvnav.geometry.polygon import points_inside


def test_points_inside_equal_shapely_on_random_star_polygons() -> None:
    rng = np.random.default_rng(21)
    for _ in range(40):
        k = int(rng.integers(3, 12))
        angles = np.sort(rng.uniform(0.0, 2 * math.pi, k))
        radii = rng.uniform(0.5, 2.0, k)
        polygon = np.column_stack([radii * np.cos(angles), radii * np.sin(angles)]) + rng.uniform(-1, 1, 2)
        points = rng.uniform(-3, 3, (400, 2))
        points[:10] = np.nan
        got = points_inside(points, polygon)
        want = shapely.contains_xy(Polygon(polygon), points[:, 0], points[:, 1])
        np.testing.assert_array_equal(got, want & np.isfinite(points[:, 0]))
    grid = points_inside(np.zeros((2, 3, 2)), np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]))
    assert grid.shape == (2, 3) and grid.all()
