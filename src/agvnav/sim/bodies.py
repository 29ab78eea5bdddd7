"""The vehicles of a fleet as obstacles to one another, held in arrays (issue 28).

:class:`FleetBodies` keeps every vehicle's body (the bounding box of its footprint in base_link)
and its true motion over the current step as a motion table in arrays
(:mod:`agvnav.kinematics.twist`): the true poses at :data:`SAMPLES_PER_STEP` + 1 instants of the
step ``(n, G + 1, 3)`` and the constant twist that joins each two (:func:`~agvnav.kinematics.twist.twist_log`),
so a body's pose at any instant of the step is the SE(2) exponential [seed002 eq25] of its
sub-step's twist, one compiled call for any vehicles at any instants
(:func:`~agvnav.kinematics.twist.fleet_twist_poses`). For a plant whose twist is constant on each
sampled sub-step (the wheel-pair plants at their speed-loop period) this is its true motion;
otherwise the error is that of a constant twist over a sub-step (below 0.1 mm at 1 m/s² and 10 ms).
The fleet loop (:mod:`agvnav.sim.fleet`) hands it the sampled poses once per step
(:meth:`FleetBodies.begin_step`); the per-step work against the other bodies is then done once
for all vehicles, compiled:

* which bodies each vehicle's sensor may reach this step: one ``(n, n)`` test of the bounding
  circles, widened by how far each body moves over the step (:meth:`FleetBodies.near`);
* every body's box edges at an instant (:meth:`FleetBodies.edges_at`, one kernel for all bodies,
  kept for the step: every vehicle's scanner scans at the same instants and reuses them);
* lines of sight against the near bodies at their instants (:func:`bodies_block_sight`: a
  bounding-circle test, then the slab test of the segment in the box's frame, :func:`segment_hits_box`).

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

from agvnav._jit import jit
from agvnav.geometry.polygon import point_in_polygon
from agvnav.kinematics.twist import fleet_twist_poses, fleet_twist_tables, twist_table_pose
from agvnav.world.obstacles import ObstacleSet

__all__ = ["CULL_MARGIN_M", "SAMPLES_PER_STEP", "BodiesInView", "FleetBodies", "bodies_block_sight", "bodies_edges",
           "footprint_gaps", "placed_footprints", "segment_hits_box"]

#: Margin (m) added to a sensor's reach when the bodies it may see are chosen for a step.
CULL_MARGIN_M = 2.0
#: Sub-steps of a step in a body's motion table (the wheel-pair plants' 10 ms speed loop in a 50 ms step).
SAMPLES_PER_STEP = 5

_EMPTY_SEGMENTS = np.zeros((0, 2, 2))
_EMPTY_OWNERS = np.zeros(0, dtype=np.int64)


def placed_footprints(footprints: NDArray[np.float64], poses: NDArray[np.float64]) -> NDArray[np.float64]:
    """Footprints ``(n, k, 2)`` in base_link placed at poses ``(n, 3)``: ``(n, k, 2)`` in the map frame (m)."""
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    x, y = footprints[..., 0], footprints[..., 1]
    return np.stack([poses[:, 0, None] + c * x - s * y, poses[:, 1, None] + s * x + c * y], axis=-1)


@jit
def segment_hits_box(ax: float, ay: float, bx: float, by: float, px: float, py: float, ph: float,
                     xmin: float, xmax: float, ymin: float, ymax: float) -> bool:
    """Whether the segment ``a -> b`` (m) meets (touches or crosses) the box ``[xmin, xmax] x [ymin, ymax]``
    (its base_link, m) placed at the pose ``(px, py, ph)`` (m, rad).

    The segment is taken into the box's frame and clipped against its two slabs (Liang-Barsky): it
    meets the box when the entry parameter does not pass the exit parameter inside ``[0, 1]``.
    """
    c, s = math.cos(ph), math.sin(ph)
    ax, ay, bx, by = ax - px, ay - py, bx - px, by - py
    u0, v0 = c * ax + s * ay, -s * ax + c * ay
    u1, v1 = c * bx + s * by, -s * bx + c * by
    lo, hi = 0.0, 1.0
    for axis in range(2):
        p0, p1 = (u0, u1) if axis == 0 else (v0, v1)
        bmin, bmax = (xmin, xmax) if axis == 0 else (ymin, ymax)
        d = p1 - p0
        if d == 0.0:
            if p0 < bmin or p0 > bmax:
                return False
        else:
            ta, tb = (bmin - p0) / d, (bmax - p0) / d
            lo, hi = max(lo, min(ta, tb)), min(hi, max(ta, tb))
    return lo <= hi


@jit
def bodies_block_sight(p0: NDArray[np.float64], p1: NDArray[np.float64], t: NDArray[np.float64],
                       idx: NDArray[np.int64], states: NDArray[np.float64], twists: NDArray[np.float64],
                       n_sub: NDArray[np.int64], t0: NDArray[np.float64], h: NDArray[np.float64],
                       boxes: NDArray[np.float64], radius: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which lines of sight ``p0 (k, 2) -> p1 (k, 2)`` at instants ``t (k,)`` (s) a body ``idx (m,)`` cuts, ``(k,)``.

    Each body at the line's instant from its motion table (:func:`~agvnav.kinematics.twist.twist_table_pose`);
    a body whose bounding circle (``radius``, m, about base_link) stays off the segment is passed over, the
    others take the slab test (:func:`segment_hits_box`).
    """
    out = np.zeros(t.shape[0], dtype=np.bool_)
    for k in range(t.shape[0]):
        ax, ay, bx, by = p0[k, 0], p0[k, 1], p1[k, 0], p1[k, 1]
        ex, ey = bx - ax, by - ay
        ee = ex * ex + ey * ey
        for j in idx:
            x, y, ph = twist_table_pose(states[j], twists[j], n_sub[j], t0[j], h[j], t[k])
            u = 0.0 if ee == 0.0 else min(max(((x - ax) * ex + (y - ay) * ey) / ee, 0.0), 1.0)
            qx, qy = ax + u * ex - x, ay + u * ey - y
            if qx * qx + qy * qy > radius[j] * radius[j]:
                continue
            b = boxes[j]
            if segment_hits_box(ax, ay, bx, by, x, y, ph, b[0], b[1], b[2], b[3]):
                out[k] = True
                break
    return out


@jit
def bodies_edges(states: NDArray[np.float64], twists: NDArray[np.float64], n_sub: NDArray[np.int64],
                 t0: NDArray[np.float64], h: NDArray[np.float64], boxes: NDArray[np.float64],
                 t: float) -> NDArray[np.float64]:
    """Every body's four box edges ``(n, 4, 2, 2)`` (m) at instant ``t`` (s), counter-clockwise from the
    front-left corner, each body where its motion table puts it then."""
    n = boxes.shape[0]
    out = np.empty((n, 4, 2, 2))
    for j in range(n):
        x, y, ph = twist_table_pose(states[j], twists[j], n_sub[j], t0[j], h[j], t)
        c, s = math.cos(ph), math.sin(ph)
        b = boxes[j]
        for e in range(4):
            lx = b[1] if e == 0 or e == 3 else b[0]
            ly = b[3] if e < 2 else b[2]
            out[j, e, 0, 0] = x + c * lx - s * ly
            out[j, e, 0, 1] = y + s * lx + c * ly
        for e in range(4):
            out[j, e, 1, 0] = out[j, (e + 1) % 4, 0, 0]
            out[j, e, 1, 1] = out[j, (e + 1) % 4, 0, 1]
    return out


@jit
def _segments_gap(ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float) -> float:
    """Distance (m) between the segments ``a b`` and ``c d``: 0 when they meet, else the least of the four
    endpoint-to-segment distances."""
    ex, ey, fx, fy = bx - ax, by - ay, dx - cx, dy - cy
    den = ex * fy - ey * fx
    if den != 0.0:
        u = ((cx - ax) * fy - (cy - ay) * fx) / den
        v = ((cx - ax) * ey - (cy - ay) * ex) / den
        if 0.0 <= u <= 1.0 and 0.0 <= v <= 1.0:
            return 0.0
    best = math.inf
    for k in range(4):
        px, py = (cx, cy) if k == 0 else (dx, dy) if k == 1 else (ax, ay) if k == 2 else (bx, by)
        sx, sy, gx, gy = (ax, ay, ex, ey) if k < 2 else (cx, cy, fx, fy)
        gg = gx * gx + gy * gy
        w = 0.0 if gg == 0.0 else min(max(((px - sx) * gx + (py - sy) * gy) / gg, 0.0), 1.0)
        best = min(best, math.hypot(sx + w * gx - px, sy + w * gy - py))
    return best


@jit
def footprint_gaps(placed: NDArray[np.float64], a: NDArray[np.int64], b: NDArray[np.int64]) -> NDArray[np.float64]:
    """Distance (m) between the placed footprints ``placed[a[p]]`` and ``placed[b[p]]`` (``(n, k, 2)``, map frame)
    for every pair ``p``: 0 when their edges meet or one holds a vertex of the other, else the least distance
    between their edges (the exact distance of two simple polygons)."""
    out = np.empty(a.shape[0])
    k = placed.shape[1]
    for p in range(a.shape[0]):
        pa, pb = placed[a[p]], placed[b[p]]
        gap = math.inf
        for i in range(k):
            for j in range(k):
                gap = min(gap, _segments_gap(pa[i, 0], pa[i, 1], pa[(i + 1) % k, 0], pa[(i + 1) % k, 1],
                                             pb[j, 0], pb[j, 1], pb[(j + 1) % k, 0], pb[(j + 1) % k, 1]))
        if gap > 0.0 and (point_in_polygon(pa[0, 0], pa[0, 1], pb) or point_in_polygon(pb[0, 0], pb[0, 1], pa)):
            gap = 0.0
        out[p] = gap
    return out


class FleetBodies:
    """Every vehicle's body and its true motion over the current step (see the module docstring).

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
        #: the motion tables: poses at the sub-step boundaries ``(n, S + 1, 3)``, twists ``(n, S, 3)``, sub-steps
        #: used ``(n,)``, start ``(n,)`` and sub-step length ``(n,)`` (s) (:mod:`agvnav.kinematics.twist`).
        self.states = np.repeat(p[:, None, :], 2, axis=1)
        self.twists = np.zeros((self.n, 1, 3))
        self.n_sub = np.ones(self.n, dtype=np.int64)
        self.t_start = np.zeros(self.n)
        self.h = np.ones(self.n)
        self._gap = np.full((self.n, self.n), math.inf)
        self._near: dict[float, NDArray[np.bool_]] = {}
        self._cache: dict[tuple[int, float], NDArray[np.int64]] = {}
        self._edges: dict[float, NDArray[np.float64]] = {}
        self.begin_step(0.0, 0.0, p)

    @staticmethod
    def sample_times(t0: float, t1: float) -> NDArray[np.float64]:
        """The :data:`SAMPLES_PER_STEP` + 1 instants (s) of the step ``[t0, t1]`` at which :meth:`begin_step` takes
        the true poses."""
        return np.asarray(t0 + (t1 - t0) * np.arange(SAMPLES_PER_STEP + 1) / SAMPLES_PER_STEP, dtype=np.float64)

    def begin_step(self, t0: float, t1: float, poses: ArrayLike) -> None:
        """The step ``(t0, t1]`` begins with the bodies' true motion over it.

        ``poses`` is ``(n, G + 1, 3)``, the true poses at ``G + 1`` equally spaced instants from ``t0`` to
        ``t1`` (:meth:`sample_times`), or ``(n, 3)``, the poses reached at ``t1`` (each body then moves with one
        constant twist from where it stood).
        """
        self.t0, self.t1 = float(t0), float(t1)
        p = np.asarray(poses, dtype=np.float64)
        if p.ndim == 2:
            p = np.stack([self.p1, p.reshape(self.n, 3)], axis=1)
        states = np.ascontiguousarray(p.reshape(self.n, -1, 3))
        g = states.shape[1] - 1
        span = self.t1 - self.t0
        h = span / g if span > 0.0 else 1.0
        twists = np.zeros((self.n, g, 3))
        if span > 0.0:
            fleet_twist_tables(states, h, twists)
        self.states, self.twists = states, twists
        self.n_sub = np.full(self.n, g, dtype=np.int64)
        self.t_start = np.full(self.n, self.t0)
        self.h = np.full(self.n, h)
        self.p0 = states[:, 0, :]
        self.p1 = states[:, -1, :]
        xy = self.p1[:, :2]
        moved = np.sqrt(np.max(np.sum((states[:, :, :2] - xy[:, None, :]) ** 2, axis=2), axis=1))
        d = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
        self._gap = d - (self.radius + moved)[:, None] - (self.radius + moved)[None, :]
        np.fill_diagonal(self._gap, math.inf)
        self._near = {}
        self._cache = {}
        self._edges = {}

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

    def _tables(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], NDArray[np.float64],
                               NDArray[np.float64]]:
        return self.states, self.twists, self.n_sub, self.t_start, self.h

    def poses_at(self, t: ArrayLike, idx: NDArray[np.int64]) -> NDArray[np.float64]:
        """Poses ``(*t.shape, m, 3)`` of bodies ``idx (m,)`` at times ``t`` inside the step (clipped to it)."""
        tt = np.asarray(t, dtype=np.float64)
        idx = np.asarray(idx, dtype=np.int64).reshape(-1)
        rows = np.broadcast_to(idx, (*tt.shape, idx.size)).reshape(-1)
        times = np.broadcast_to(tt[..., None], (*tt.shape, idx.size)).reshape(-1)
        out = fleet_twist_poses(*self._tables(), np.ascontiguousarray(rows), np.ascontiguousarray(times))
        return np.asarray(out, dtype=np.float64).reshape(*tt.shape, idx.size, 3)

    def edges_at(self, t: float) -> NDArray[np.float64]:
        """Every body's box edges ``(n, 4, 2, 2)`` (m) at ``t`` (s) (:func:`bodies_edges`), kept for the step."""
        out = self._edges.get(t)
        if out is None:
            out = self._edges[t] = bodies_edges(*self._tables(), self.boxes, float(t))
        return out

    def corners(self, poses: NDArray[np.float64], idx: NDArray[np.int64]) -> NDArray[np.float64]:
        """Box corners ``(m, 4, 2)`` (m) of bodies ``idx`` at ``poses (m, 3)``, counter-clockwise."""
        b = self.boxes[idx]
        local = np.stack([np.stack([b[:, 1], b[:, 3]], -1), np.stack([b[:, 0], b[:, 3]], -1),
                          np.stack([b[:, 0], b[:, 2]], -1), np.stack([b[:, 1], b[:, 2]], -1)], axis=1)
        c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
        x, y = local[..., 0], local[..., 1]
        return np.stack([poses[:, 0, None] + c * x - s * y, poses[:, 1, None] + s * x + c * y], axis=-1)

    def block_sight(self, p0: NDArray[np.float64], p1: NDArray[np.float64], t: NDArray[np.float64],
                    idx: NDArray[np.int64]) -> NDArray[np.bool_]:
        """Lines of sight ``p0 (k, 2) -> p1 (k, 2)`` at ``t (k,)`` cut by one of the bodies ``idx``
        (:func:`bodies_block_sight`)."""
        return np.asarray(bodies_block_sight(np.ascontiguousarray(p0, dtype=np.float64),
                                             np.ascontiguousarray(p1, dtype=np.float64),
                                             np.ascontiguousarray(t, dtype=np.float64), idx, *self._tables(),
                                             self.boxes, self.radius), dtype=np.bool_)


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
        edges = self.bodies.edges_at(t)[idx].reshape(-1, 2, 2)
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
        return np.asarray(out | self.bodies.block_sight(p0, p1, t, idx), dtype=np.bool_)
