"""Collision of the vehicle's footprint with the map's walls and pillars, checked every step (issue 12 §2).

The walls of a :class:`agvnav.world.WorldMap` are line segments (a closed wall
such as a pillar or the outer wall is the ring of its segments). The vehicle
collides when its footprint polygon, placed at the *true* pose, touches any
segment. The exact test is shapely's on a prepared ``MultiLineString`` of the
walls; it runs only when a wall segment lies within the footprint's bounding
circle (radius ``R``, the farthest footprint vertex from base_link). After a
test, the vehicle is known to be clear for ``clearance = d_min − R`` (``d_min``
the distance from base_link to the nearest segment): until base_link has moved
that far from where it was checked, no test is needed. A vehicle that
turns on the spot keeps its bounding circle, so translation alone bounds the
motion of every footprint point towards the walls.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from numpy.typing import ArrayLike
from shapely.geometry import MultiLineString, Polygon

from agvnav.geometry import segment_distances
from agvnav.roles import Plant
from agvnav.sim.wrapped import WrappedPlant

__all__ = ["CollisionWatch", "WallCollider"]


class WallCollider:
    """Footprint-against-walls test with a bounding-circle prefilter (see the module docstring).

    Parameters
    ----------
    footprint : (k, 2) vehicle outline in base_link (m), k >= 3.
    wall_segments : (m, 2, 2) wall segments in ``map`` (m); may be empty.
    """

    def __init__(self, footprint: ArrayLike, wall_segments: ArrayLike) -> None:
        fp = np.asarray(footprint, dtype=np.float64)
        if fp.ndim != 2 or fp.shape[1] != 2 or fp.shape[0] < 3 or not np.all(np.isfinite(fp)):
            raise ValueError(f"footprint must be a finite (k >= 3, 2) polygon, got shape {fp.shape}")
        self.footprint = fp
        self.radius = float(np.max(np.hypot(fp[:, 0], fp[:, 1])))
        self.segments = np.asarray(wall_segments, dtype=np.float64).reshape(-1, 2, 2)
        self._walls = MultiLineString(list(self.segments)) if len(self.segments) else None
        if self._walls is not None:
            shapely.prepare(self._walls)
        self._checked_at = (math.nan, math.nan)
        self._clearance = -1.0

    def polygon(self, pose: ArrayLike) -> Polygon:
        """The footprint placed at ``pose`` ``(x, y, psi)`` (m, m, rad) in ``map``."""
        x, y, psi = (float(v) for v in np.asarray(pose, dtype=np.float64)[:3])
        c, s = math.cos(psi), math.sin(psi)
        fp = self.footprint
        return Polygon(np.column_stack([x + c * fp[:, 0] - s * fp[:, 1], y + s * fp[:, 0] + c * fp[:, 1]]))

    def hits(self, pose: ArrayLike) -> bool:
        """True when the footprint at ``pose`` touches a wall (exact shapely test, no prefilter)."""
        if self._walls is None:
            return False
        return bool(self._walls.intersects(self.polygon(pose)))

    def check(self, x: float, y: float, psi: float) -> bool:
        """:meth:`hits` with the prefilter: cheap while the vehicle is known to be clear."""
        if self._walls is None:
            return False
        x0, y0 = self._checked_at
        if math.hypot(x - x0, y - y0) < self._clearance:
            return False
        d_min = float(np.min(segment_distances((x, y), self.segments)))
        self._checked_at, self._clearance = (x, y), d_min - self.radius
        if self._clearance > 0.0:
            return False
        return self.hits((x, y, psi))


class CollisionWatch(WrappedPlant):
    """A plant wrapper whose :meth:`failure` also reports ``"collision"`` (the engine then ends the run).

    Every other role method is the wrapped plant's own bound method (no per-step
    indirection, :class:`~agvnav.sim.wrapped.WrappedPlant`).
    """

    def __init__(self, plant: Plant, collider: WallCollider) -> None:
        super().__init__(plant)
        self.collider = collider
        self.advance = plant.advance
        self.odometry = plant.odometry

    def failure(self) -> str | None:
        """The plant's own failure, else ``"collision"`` when the footprint touches a wall."""
        own = self.plant.failure()
        if own is not None:
            return str(own)
        x, y, psi = (float(v) for v in self.plant.pose)
        return "collision" if self.collider.check(x, y, psi) else None
