"""Points in a polygon, compiled (issue 28): the one form of the test a safety field and a body use.

A point lies inside a simple polygon when a ray from it crosses the polygon's edges an odd number
of times (the crossing number, Jordan curve theorem); the ray here runs towards ``+x``, an edge
``(x0, y0) -> (x1, y1)`` is crossed when ``y`` lies in the half-open span between ``y0`` and ``y1``
and the point is left of the edge there. A point exactly on an edge may fall either way (a safety
field's echoes carry range noise, so that has probability zero); a NaN point is outside.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._jit import jit

__all__ = ["point_in_polygon", "points_in_polygon", "points_inside"]


@jit
def point_in_polygon(px: float, py: float, polygon: NDArray[np.float64]) -> bool:
    """Whether the point ``(px, py)`` (m) lies inside the closed polygon ``polygon (k, 2)`` (crossing number)."""
    inside = False
    k = polygon.shape[0]
    for i in range(k):
        x0, y0 = polygon[i, 0], polygon[i, 1]
        x1, y1 = polygon[(i + 1) % k, 0], polygon[(i + 1) % k, 1]
        if (y0 > py) != (y1 > py) and px < x0 + (py - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
    return inside


@jit
def points_in_polygon(points: NDArray[np.float64], polygon: NDArray[np.float64]) -> NDArray[np.bool_]:
    """:func:`point_in_polygon` for every row of ``points (n, 2)`` (m), ``(n,)``."""
    out = np.zeros(points.shape[0], dtype=np.bool_)
    for i in range(points.shape[0]):
        out[i] = point_in_polygon(points[i, 0], points[i, 1], polygon)
    return out


def points_inside(points: ArrayLike, polygon: ArrayLike) -> NDArray[np.bool_]:
    """Which points ``(..., 2)`` (m; NaN rows are outside) lie inside ``polygon (k, 2)``, ``(...)``."""
    p = np.asarray(points, dtype=np.float64)
    flat = np.ascontiguousarray(p.reshape(-1, 2))
    poly = np.ascontiguousarray(polygon, dtype=np.float64).reshape(-1, 2)
    return np.asarray(points_in_polygon(flat, poly), dtype=np.bool_).reshape(p.shape[:-1])
