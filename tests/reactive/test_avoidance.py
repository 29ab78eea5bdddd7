"""Local avoidance: the detour leaves and rejoins the route and never leaves the corridor (issue 18)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Polygon, box

from agvnav.guidance.paths import ArcSegment, LineSegment, Path
from agvnav.reactive import path_tail, plan_detour, scanned_obstacle, shift_arcs

BODY = np.array([[0.45, -0.3], [0.45, 0.3], [-0.3, 0.3], [-0.3, -0.3]])


def _route() -> Path:
    line = LineSegment(np.array([0.0, 0.0]), 0.0, 20.0)
    return Path([line, ArcSegment(line.end, 0.0, 3.0, math.pi / 2)])


def _bodies(path: Path, upto: float, step: float = 0.05) -> list[Polygon]:
    s = np.arange(0.0, upto, step)
    pts, h = path.point_at(s), path.heading_at(s)
    out = []
    for (x, y), a in zip(pts, h, strict=True):
        c, si = math.cos(a), math.sin(a)
        xy = np.column_stack([x + c * BODY[:, 0] - si * BODY[:, 1], y + si * BODY[:, 0] + c * BODY[:, 1]])
        out.append(Polygon(xy))
    return out


def test_shift_arcs_known_values():
    r, lx = shift_arcs(1.0, math.radians(60.0), 0.1)
    assert r == pytest.approx(1.0) and lx == pytest.approx(2.0 * math.sin(math.radians(60.0)))
    r, lx = shift_arcs(0.2, math.radians(30.0), 2.0)  # radius-limited: a flatter S-curve
    assert r == 2.0 and lx == pytest.approx(2 * 2.0 * math.sin(math.acos(1 - 0.2 / 4.0)))


def test_detour_stays_in_the_corridor_clears_the_obstacle_and_rejoins():
    route = _route()
    pallet = box(9.4, -0.4, 10.6, 0.4)
    d = plan_detour(route, 5.0, [pallet], BODY, corridor_left=2.0, corridor_right=0.6, clearance=0.3,
                    allowed=[0])
    assert d is not None
    assert d.offset == pytest.approx(0.4 + 0.3 + 0.3)  # beside the pallet's left face, left: the right has no room
    corridor = box(-1.0, -0.6, 21.0, 2.0)
    bodies = _bodies(d.path, d.length)
    assert all(corridor.covers(b) for b in bodies)
    assert min(pallet.distance(b) for b in bodies) >= 0.3 - 1e-6
    # the detour's path starts where the vehicle is and ends at the route's end, on the route after the rejoin
    assert d.path.point_at(0.0) == pytest.approx(route.point_at(5.0))
    assert d.path.point_at(d.path.length) == pytest.approx(route.point_at(route.length), abs=1e-9)
    assert d.path.point_at(d.length + 0.5)[1] == pytest.approx(0.0, abs=1e-9)
    assert d.route_s(d.length + 1.0) == pytest.approx(d.s_rejoin + 1.0)


def test_no_detour_when_the_corridor_is_too_narrow_or_avoidance_not_allowed():
    route = _route()
    pallet = box(9.4, -0.4, 10.6, 0.4)
    assert plan_detour(route, 5.0, [pallet], BODY, corridor_left=1.0, corridor_right=0.6) is None
    assert plan_detour(route, 5.0, [pallet], BODY, 2.0, 0.6, allowed=[1]) is None
    # an obstacle too close to the segment's end: no room to rejoin on the straight
    assert plan_detour(route, 5.0, [box(18.5, -0.4, 19.7, 0.4)], BODY, 2.0, 0.6) is None


def test_path_tail_and_scanned_obstacle():
    route = _route()
    tail = path_tail(route, 15.0)
    assert len(tail) == 2 and tail[0].length == pytest.approx(5.0)
    assert tail[0].start == pytest.approx([15.0, 0.0])
    arc_tail = path_tail(route, 20.0 + 3.0 * math.pi / 4)
    assert len(arc_tail) == 1 and arc_tail[0].length == pytest.approx(3.0 * math.pi / 4)
    shape = scanned_obstacle(np.array([[9.4, -0.3], [9.4, 0.3], [np.nan, np.nan]]), 0.0, 1.0)
    assert shape is not None and shape.bounds == pytest.approx((9.4, -0.3, 10.4, 0.3))
    assert scanned_obstacle(np.zeros((0, 2)), 0.0, 1.0) is None
