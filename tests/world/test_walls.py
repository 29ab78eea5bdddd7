"""Landmark walls of a polygon route (seed 004 §II-B)."""

import math

import numpy as np

from agvnav.guidance.hybrid import PolygonRoute
from agvnav.world.walls import square_landmarks

ROUTE = PolygonRoute.square(3.5)


def test_square_landmarks_geometry():
    w = square_landmarks(ROUTE)
    assert w.shape == (8, 2, 2)
    np.testing.assert_allclose(w[0], [[0.5, -0.5], [3.0, -0.5]])  # leg 0 wall on the right (outside)
    assert math.isclose(float(np.hypot(*(w[1, 1] - w[1, 0]))), 0.36)
