"""Local avoidance: a lateral-offset detour that leaves the path and rejoins it inside a corridor (issue 18).

On a straight stretch of the route where avoidance is allowed (a flag per path
segment), an obstacle blocking the path is passed by a lateral shift:
an S-curve of two arcs of radius ``R`` and sweep ``±theta`` moves the tracked point
sideways by ``D = 2 R (1 - cos theta)`` over ``2 R sin theta`` along the route; it
holds the offset past the obstacle, then an opposite S-curve brings it back onto
the route, which it then follows to its end. The offset ``D`` is the smallest that
keeps ``clearance`` between the body (its half-width beside the tracked point) and
the obstacle, on the side with room (up to 0.3 m more when the body's swing on the
S-curves needs it); the S-curves are as gentle as the room before
the obstacle allows (``theta`` from 30 to 75 degrees, ``R >= min_radius``).

Every candidate is checked against the corridor and the obstacles by sweeping the
footprint along it (poses every ``check_step`` m, shapely): each placed footprint
must lie inside the corridor (``corridor_left``/``corridor_right`` of the route,
lengthened by the vehicle's reach at the segment ends) and at least ``clearance``
from every obstacle shape given. None is returned when no candidate passes: the
vehicle then stays stopped, as it would without avoidance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import MultiPoint, Polygon
from shapely.geometry.base import BaseGeometry

from agvnav.guidance.paths import ArcSegment, LineSegment, Path

__all__ = ["Detour", "path_tail", "plan_detour", "scanned_obstacle", "shift_arcs"]

_THETAS_DEG = (30.0, 45.0, 60.0, 75.0)
_EXTRA_OFFSETS = (0.0, 0.1, 0.2, 0.3)


@dataclass(frozen=True)
class Detour:
    """A planned detour: the path to follow from the vehicle's position to the route's end.

    ``s_leave``/``s_rejoin`` (m): route abscissae where the detour leaves and rejoins;
    ``offset`` (m, + left) the lateral shift; ``length`` (m) the detour's own length from
    ``s_start`` to the rejoin point; ``s_start`` the route abscissa the path starts at.
    """

    path: Path
    s_start: float
    s_leave: float
    s_rejoin: float
    offset: float
    length: float
    max_lateral: float

    def route_s(self, s: float) -> float:
        """Route abscissa (m) matching abscissa ``s`` of :attr:`path` (proportional on the detour)."""
        if s <= self.length:
            return self.s_start + s * (self.s_rejoin - self.s_start) / max(self.length, 1e-12)
        return self.s_rejoin + (s - self.length)


def shift_arcs(offset: float, theta: float, min_radius: float) -> tuple[float, float]:
    """Radius (m) and along-route length (m) of an S-curve shifting ``|offset|`` m with arcs of sweep ``theta`` (rad).

    ``R = max(min_radius, |D| / (2 (1 - cos theta)))``; with a larger ``R`` the sweep shrinks
    to keep the shift: the returned length is ``2 R sin theta'`` with ``cos theta' = 1 - |D| / (2 R)``.
    """
    d = abs(offset)
    if not (0.0 < theta < 0.5 * math.pi):
        raise ValueError(f"theta must be in (0, pi/2) rad, got {theta!r}")
    r = max(min_radius, d / (2.0 * (1.0 - math.cos(theta))))
    th = math.acos(max(-1.0, 1.0 - d / (2.0 * r)))
    return r, 2.0 * r * math.sin(th)


def path_tail(path: Path, s: float) -> list[LineSegment | ArcSegment]:
    """The segments of ``path`` from abscissa ``s`` (m) to its end (the first one cut at ``s``)."""
    starts = path.segment_starts
    out: list[LineSegment | ArcSegment] = []
    for i, seg in enumerate(path.segments):
        s0, s1 = float(starts[i]), float(starts[i + 1])
        if s1 <= s + 1e-9:
            continue
        if s0 >= s - 1e-9:
            out.append(seg)
            continue
        u = s - s0
        p = np.asarray(seg.point_at(u), dtype=np.float64)
        h = float(seg.heading_at(u))
        if isinstance(seg, LineSegment):
            out.append(LineSegment(p, h, s1 - s, seg.direction, seg.yaw_offset))
        else:
            sweep = math.copysign((s1 - s) / seg.radius, seg.sweep)
            out.append(ArcSegment(p, h, seg.radius, sweep, seg.direction, seg.yaw_offset))
    return out


def _body_poses(path: Path, length: float, offset: float, step: float) -> NDArray[np.float64]:
    """base_link poses ``(k, 3)`` while the tracked point runs ``[0, length]`` of ``path`` every ``step`` m.

    With the tracked point ``offset`` m ahead of base_link (C of a front-steered vehicle),
    base_link is placed on the path ``offset`` m behind it (the trailing axle follows the
    leader's track: exact on lines, slightly outside the true off-tracking on arcs, so the
    check is conservative for the swing of the rear) and the heading points from base_link
    to the tracked point; before the path's start, the start's tangent is extended backwards.
    """
    s = np.linspace(0.0, length, max(2, math.ceil(length / step) + 1))
    lead = np.asarray(path.point_at(s), dtype=np.float64)
    if offset == 0.0:
        return np.column_stack([lead, np.asarray(path.heading_at(s), dtype=np.float64)])
    back = s - offset
    trail = np.asarray(path.point_at(np.clip(back, 0.0, None)), dtype=np.float64)
    h0 = float(path.heading_at(0.0))
    before = back < 0.0
    trail[before] = lead[0] + back[before, None] * np.array([math.cos(h0), math.sin(h0)])
    d = lead - trail
    return np.column_stack([trail, np.arctan2(d[:, 1], d[:, 0])])


def _placed(footprint: NDArray[np.float64], pose: NDArray[np.float64]) -> Polygon:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return Polygon(np.column_stack([pose[0] + c * footprint[:, 0] - s * footprint[:, 1],
                                    pose[1] + s * footprint[:, 0] + c * footprint[:, 1]]))


def plan_detour(
    path: Path,
    s_now: float,
    obstacles: Sequence[BaseGeometry],
    footprint: ArrayLike,
    corridor_left: float,
    corridor_right: float,
    clearance: float = 0.3,
    min_radius: float = 0.5,
    point_offset: float = 0.0,
    check_step: float = 0.05,
    allowed: Sequence[int] | None = None,
) -> Detour | None:
    """A detour around ``obstacles`` starting at route abscissa ``s_now`` (see the module docstring).

    Parameters
    ----------
    path : the route (of the tracked point).
    s_now : the vehicle's progress along it (m).
    obstacles : obstacle shapes in ``map`` (shapely; e.g. scanned points' hull).
    footprint : ``(k, 2)`` body polygon in base_link (m).
    corridor_left, corridor_right : the corridor's reach either side of the route (m, >= 0).
    clearance : distance kept from every obstacle (m).
    min_radius : smallest arc radius the vehicle can follow (m).
    point_offset : tracked point ahead of base_link (m; the wheelbase for C).
    allowed : indices of the path segments where avoidance is allowed (None: every line).

    Returns
    -------
    The :class:`Detour`, or None when the obstacles are not on an allowed straight stretch or no
    candidate stays in the corridor and clear of them.
    """
    body = np.asarray(footprint, dtype=np.float64)
    fp = body - np.array([point_offset, 0.0])  # the body about the tracked point
    i = int(path.segment_index(s_now))
    seg = path.segments[i]
    if not isinstance(seg, LineSegment) or seg.direction != 1 or (allowed is not None and i not in allowed):
        return None
    if not obstacles:
        return None
    s0, s1 = float(path.segment_starts[i]), float(path.segment_starts[i + 1])
    p0, h = np.asarray(seg.start, dtype=np.float64), float(seg.heading)
    c, s = math.cos(h), math.sin(h)
    # obstacles in the segment frame: x along the route (as route abscissa), y left of it
    xs, ys = [], []
    for g in obstacles:
        pts = shapely.get_coordinates(g.convex_hull)
        rel = pts - p0
        xs.append(s0 + rel[:, 0] * c + rel[:, 1] * s)
        ys.append(-rel[:, 0] * s + rel[:, 1] * c)
    x_all, y_all = np.concatenate(xs), np.concatenate(ys)
    x_lo, x_hi, y_lo, y_hi = float(x_all.min()), float(x_all.max()), float(y_all.min()), float(y_all.max())
    front, rear = float(fp[:, 0].max()), float(-fp[:, 0].min())
    w_left, w_right = float(fp[:, 1].max()), float(-fp[:, 1].min())
    corridor = Polygon([
        p0 + (x - s0) * np.array([c, s]) + y * np.array([-s, c])
        for x, y in ((s0 - rear - front, -corridor_right), (s1 + rear + front, -corridor_right),
                     (s1 + rear + front, corridor_left), (s0 - rear - front, corridor_left))
    ])
    candidates = []
    for extra in _EXTRA_OFFSETS:  # the smallest shift first, then a little more room for the body's swing
        d_left = y_hi + clearance + w_right + extra
        if d_left + w_left <= corridor_left + 1e-9:
            candidates.append(d_left)
        d_right = y_lo - clearance - w_left - extra
        if -d_right + w_right <= corridor_right + 1e-9:
            candidates.append(d_right)
    candidates.sort(key=abs)
    for d in candidates:
        for theta in _THETAS_DEG:
            r, lx = shift_arcs(d, math.radians(theta), min_radius)
            leave = max(s_now, x_lo - clearance - front - lx)
            hold_end = x_hi + clearance + rear
            rejoin = hold_end + lx
            if rejoin > s1 - 1e-9:
                continue
            detour = _build(path, s_now, leave, hold_end, rejoin, d, r, lx)
            if detour is None:
                continue
            poses = _body_poses(detour.path, detour.length, point_offset, check_step)
            bodies = [_placed(body, p) for p in poses]
            if not all(corridor.covers(b) for b in bodies):
                continue
            if any(min(g.distance(b) for g in obstacles) < clearance - 1e-6 for b in bodies):
                continue
            return detour
    return None


def _build(path: Path, s_now: float, leave: float, hold_end: float, rejoin: float, d: float, r: float,
           lx: float) -> Detour | None:
    """The detour path: straight to ``leave``, S-curve out, hold, S-curve back, then the route's tail."""
    theta = math.acos(max(-1.0, 1.0 - abs(d) / (2.0 * r)))
    side = 1.0 if d > 0 else -1.0
    segs: list[LineSegment | ArcSegment] = []
    pos = np.asarray(path.point_at(s_now), dtype=np.float64)
    h = float(path.heading_at(s_now))
    if leave - s_now > 1e-6:
        segs.append(LineSegment(pos, h, leave - s_now))
    for sweep in (side * theta, -side * theta):
        start = segs[-1].end if segs else pos
        head = float(segs[-1].end_heading) if segs else h
        segs.append(ArcSegment(np.asarray(start), head, r, sweep))
    hold = hold_end - (leave + lx)
    if hold > 1e-6:
        segs.append(LineSegment(np.asarray(segs[-1].end), float(segs[-1].end_heading), hold))
    for sweep in (-side * theta, side * theta):
        segs.append(ArcSegment(np.asarray(segs[-1].end), float(segs[-1].end_heading), r, sweep))
    length = sum(seg.length for seg in segs)
    tail = path_tail(path, rejoin)
    if tail:
        gap = float(np.hypot(*(np.asarray(tail[0].start) - np.asarray(segs[-1].end))))
        if gap > 1e-3:
            return None
        tail[0] = _anchored(tail[0], np.asarray(segs[-1].end, dtype=np.float64))
    try:
        full = Path([*segs, *tail])
    except ValueError:
        return None
    return Detour(full, s_now, leave, rejoin, d, length, abs(d))


def _anchored(seg: LineSegment | ArcSegment, start: NDArray[np.float64]) -> LineSegment | ArcSegment:
    """The segment re-anchored exactly at ``start`` (m)."""
    if isinstance(seg, LineSegment):
        return LineSegment(start, seg.heading, seg.length, seg.direction, seg.yaw_offset)
    return ArcSegment(start, seg.heading, seg.radius, seg.sweep, seg.direction, seg.yaw_offset)


def scanned_obstacle(points: ArrayLike, heading: float, depth: float) -> BaseGeometry | None:
    """Shape (map, m) of an obstacle seen as echo ``points (k, 2)``: their hull stretched ``depth`` m along ``heading``.

    A scanner sees only the near faces; the obstacle is assumed to reach ``depth`` beyond
    them in the direction of travel. None when there are no finite points.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    p = p[np.all(np.isfinite(p), axis=1)]
    if p.shape[0] == 0:
        return None
    far = p + depth * np.array([math.cos(heading), math.sin(heading)])
    return MultiPoint(np.concatenate([p, far])).convex_hull
