"""The vehicles of a fleet as obstacles to one another, held in arrays (issue 28).

:class:`FleetBodies` keeps every vehicle's body (the bounding box of its footprint in base_link)
and its true pose at the start and the end of the current step, ``(n, 3)`` each. The fleet loop
(:mod:`agvnav.sim.fleet`) hands it the true poses once per step (:meth:`FleetBodies.begin_step`);
the per-step work against the other bodies is done there once for all vehicles, in NumPy:

* which bodies each vehicle's sensor may reach this step: one ``(n, n)`` test of the bounding
  circles, widened by how far each body moves over the step (:meth:`FleetBodies.near`);
* a body's pose at an instant inside the step: linear in ``x, y`` and in the wrapped heading
  between the step's two true poses (:meth:`FleetBodies.poses_at`). Against the true motion
  (a constant twist over the step), the error is at most ``|Δψ| v dt / 8`` (the sagitta of the
  arc): 0.3 mm at 1 m/s, 1 rad/s and 50 ms, far below the scanner's range noise;
* line-of-sight tests of many lines against many boxes at once (:func:`segments_hit_boxes`, the
  slab test of each segment in each box's frame), box edges and shapes.

:class:`BodiesInView` is one vehicle's view of the world's obstacles: its scenario's own
obstacles (an :class:`~agvnav.world.obstacles.ObstacleSet`, indices ``0 .. m-1``) followed by
the other vehicles' bodies within a sensor's reach, body ``j`` of the fleet at obstacle index
``m + j`` (so a recorded field trigger names the vehicle). The sensor roles of
:mod:`agvnav.sim.reactive` use it as they use any obstacle set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import Polygon

from agvnav.geometry import wrap_angle
from agvnav.world.obstacles import ObstacleSet

__all__ = ["CULL_MARGIN_M", "BodiesInView", "FleetBodies", "placed_footprints", "segments_hit_boxes"]

#: Margin (m) added to a sensor's reach when the bodies it may see are chosen for a step.
CULL_MARGIN_M = 2.0

_EMPTY_SEGMENTS = np.zeros((0, 2, 2))
_EMPTY_OWNERS = np.zeros(0, dtype=np.int64)


def _wrap(a: NDArray[np.float64]) -> NDArray[np.float64]:
    return wrap_angle(a)


def placed_footprints(footprints: NDArray[np.float64], poses: NDArray[np.float64]) -> NDArray[np.float64]:
    """Footprints ``(n, k, 2)`` in base_link placed at poses ``(n, 3)``: ``(n, k, 2)`` in the map frame (m)."""
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    x, y = footprints[..., 0], footprints[..., 1]
    return np.stack([poses[:, 0, None] + c * x - s * y, poses[:, 1, None] + s * x + c * y], axis=-1)


def segments_hit_boxes(a: NDArray[np.float64], b: NDArray[np.float64], poses: NDArray[np.float64],
                       boxes: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether segment ``a -> b`` meets (touches or crosses) box ``j``, for broadcast arrays.

    ``a``, ``b`` ``(..., 2)`` (m); ``poses`` ``(..., 3)`` place the boxes ``(..., 4)`` =
    ``x_min, x_max, y_min, y_max`` (base_link, m). The segment is taken into each box's frame and
    clipped against its slabs (Liang-Barsky): it meets the box when the entry parameter does not
    pass the exit parameter inside ``[0, 1]``. Returns the broadcast shape of the leading dimensions.
    """
    c, s = np.cos(poses[..., 2]), np.sin(poses[..., 2])
    ax, ay = a[..., 0] - poses[..., 0], a[..., 1] - poses[..., 1]
    bx, by = b[..., 0] - poses[..., 0], b[..., 1] - poses[..., 1]
    u0, v0 = c * ax + s * ay, -s * ax + c * ay
    u1, v1 = c * bx + s * by, -s * bx + c * by
    lo = np.zeros(np.broadcast_shapes(u0.shape, boxes.shape[:-1]))
    hi = np.ones_like(lo)
    ok = np.ones(lo.shape, dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        for p0, p1, bmin, bmax in ((u0, u1, boxes[..., 0], boxes[..., 1]), (v0, v1, boxes[..., 2], boxes[..., 3])):
            d = p1 - p0
            flat = d == 0.0
            ok &= ~flat | ((p0 >= bmin) & (p0 <= bmax))
            ta, tb = (bmin - p0) / d, (bmax - p0) / d
            lo = np.where(flat, lo, np.maximum(lo, np.minimum(ta, tb)))
            hi = np.where(flat, hi, np.minimum(hi, np.maximum(ta, tb)))
    return np.asarray(ok & (lo <= hi), dtype=np.bool_)


class FleetBodies:
    """Every vehicle's body and its true poses over the current step (see the module docstring).

    Parameters
    ----------
    footprints
        Each vehicle's footprint ``(k_i, 2)`` in base_link (m).
    poses
        The start poses ``(n, 3)`` (m, m, rad).
    """

    def __init__(self, footprints: list[NDArray[np.float64]], poses: ArrayLike) -> None:
        fps = [np.asarray(f, dtype=np.float64).reshape(-1, 2) for f in footprints]
        self.n = len(fps)
        k = max((f.shape[0] for f in fps), default=3)
        #: footprints padded to ``k`` vertices by repeating the last (``(n, k, 2)``, m).
        self.footprints = np.stack([np.vstack([f, np.repeat(f[-1:], k - f.shape[0], axis=0)]) for f in fps]) \
            if fps else np.zeros((0, 3, 2))
        #: bounding boxes of the footprints in base_link, ``x_min, x_max, y_min, y_max`` ``(n, 4)`` (m).
        self.boxes = np.array([[f[:, 0].min(), f[:, 0].max(), f[:, 1].min(), f[:, 1].max()] for f in fps],
                              dtype=np.float64).reshape(-1, 4)
        b = self.boxes
        corner = np.hypot(np.maximum(np.abs(b[:, 0]), np.abs(b[:, 1])), np.maximum(np.abs(b[:, 2]), np.abs(b[:, 3])))
        #: bounding radius of each box about base_link (m).
        self.radius = corner
        p = np.asarray(poses, dtype=np.float64).reshape(self.n, 3)
        self.t0 = 0.0
        self.t1 = 0.0
        self.p0 = p.copy()
        self.p1 = p.copy()
        self._dpsi = np.zeros(self.n)
        self._gap = np.full((self.n, self.n), math.inf)
        self._near: dict[float, NDArray[np.bool_]] = {}
        self._cache: dict[tuple[int, float], NDArray[np.int64]] = {}
        self.begin_step(0.0, 0.0, p)

    def begin_step(self, t0: float, t1: float, p1: ArrayLike) -> None:
        """The step ``(t0, t1]`` begins: the poses reached at ``t1`` (``(n, 3)``) become the end of the step."""
        self.t0, self.t1 = float(t0), float(t1)
        self.p0 = self.p1
        self.p1 = np.asarray(p1, dtype=np.float64).reshape(self.n, 3)
        self._dpsi = _wrap(self.p1[:, 2] - self.p0[:, 2])
        xy = self.p1[:, :2]
        moved = np.hypot(*(self.p1[:, :2] - self.p0[:, :2]).T)
        d = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
        self._gap = d - (self.radius + moved)[:, None] - (self.radius + moved)[None, :]
        np.fill_diagonal(self._gap, math.inf)
        self._near = {}
        self._cache = {}

    def near(self, i: int, reach: float) -> NDArray[np.int64]:
        """Bodies other than ``i`` whose bounding circles come within ``reach`` + :data:`CULL_MARGIN_M` (m) of
        body ``i``'s over the step (every vehicle's at once, the first time a reach is asked for in a step)."""
        key = (i, reach)
        out = self._cache.get(key)
        if out is None:
            mask = self._near.get(reach)
            if mask is None:
                mask = self._near[reach] = self._gap <= reach + CULL_MARGIN_M
            out = self._cache[key] = np.flatnonzero(mask[i])
        return out

    def poses_at(self, t: ArrayLike, idx: NDArray[np.int64]) -> NDArray[np.float64]:
        """Poses ``(*t.shape, m, 3)`` of bodies ``idx (m,)`` at times ``t`` inside the step (clipped to it)."""
        tt = np.asarray(t, dtype=np.float64)[..., None]
        span = self.t1 - self.t0
        u = np.ones_like(tt) if span <= 0.0 else np.clip((tt - self.t0) / span, 0.0, 1.0)
        p0 = self.p0[idx]
        out = p0 + u[..., None] * (self.p1[idx] - p0)
        out[..., 2] = p0[:, 2] + u * self._dpsi[idx]
        return out

    def corners(self, poses: NDArray[np.float64], idx: NDArray[np.int64]) -> NDArray[np.float64]:
        """Box corners ``(m, 4, 2)`` (m) of bodies ``idx`` at ``poses (m, 3)``, counter-clockwise."""
        b = self.boxes[idx]
        local = np.stack([np.stack([b[:, 1], b[:, 3]], -1), np.stack([b[:, 0], b[:, 3]], -1),
                          np.stack([b[:, 0], b[:, 2]], -1), np.stack([b[:, 1], b[:, 2]], -1)], axis=1)
        c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
        x, y = local[..., 0], local[..., 1]
        return np.stack([poses[:, 0, None] + c * x - s * y, poses[:, 1, None] + s * x + c * y], axis=-1)


@dataclass(frozen=True)
class BodiesInView(ObstacleSet):
    """One vehicle's obstacles: its scenario's own (``obstacles``), then the other bodies within ``reach`` (m).

    Body ``j`` of the fleet has obstacle index ``len(obstacles) + j`` (module docstring).
    """

    bodies: FleetBodies = field(default=None, compare=False, repr=False)  # type: ignore[assignment]
    me: int = 0
    reach: float = math.inf

    def _others(self) -> NDArray[np.int64]:
        return self.bodies.near(self.me, self.reach)

    def segments_at(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Own box edges, then the near bodies' four edges each ``(4 B, 2, 2)``, and their obstacle indices."""
        own, owner = super().segments_at(t) if self.obstacles else (_EMPTY_SEGMENTS, _EMPTY_OWNERS)
        idx = self._others()
        if idx.size == 0:
            return own, owner
        c = self.bodies.corners(self.bodies.poses_at(t, idx), idx)
        edges = np.stack([c, np.roll(c, -1, axis=1)], axis=2).reshape(-1, 2, 2)
        ids = np.repeat(idx + len(self.obstacles), 4)
        if own.shape[0] == 0:
            return edges, ids
        return np.concatenate([own, edges]), np.concatenate([owner, ids])

    def shapes_at(self, t: float) -> list[Polygon]:
        """Own obstacles' shapes, then the near bodies' boxes."""
        own = super().shapes_at(t)
        idx = self._others()
        if idx.size == 0:
            return own
        c = self.bodies.corners(self.bodies.poses_at(t, idx), idx)
        return own + [Polygon(k) for k in c]

    def blocks(self, p0: ArrayLike, p1: ArrayLike, t: float) -> bool:
        """True when the line of sight ``p0 -> p1`` (m) crosses an own obstacle or a near body at ``t``."""
        return bool(self.blocked(np.asarray(p0, dtype=np.float64)[None, :2], np.asarray(p1, dtype=np.float64)[None, :2],
                                 np.array([t], dtype=np.float64))[0])

    def blocked(self, p0: NDArray[np.float64], p1: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Lines of sight ``p0 (k, 2) -> p1 (k, 2)`` at times ``t (k,)``: crossed by an obstacle or a near body."""
        own = ObstacleSet(self.obstacles)
        out = own.blocked(p0, p1, t) if self.obstacles else np.zeros(t.shape[0], dtype=bool)
        idx = self._others()
        if idx.size == 0 or t.shape[0] == 0:
            return out
        poses = self.bodies.poses_at(t, idx)  # (k, m, 3)
        hit = segments_hit_boxes(p0[:, None, :], p1[:, None, :], poses, self.bodies.boxes[idx][None, :, :])
        return np.asarray(out | hit.any(axis=1), dtype=np.bool_)
