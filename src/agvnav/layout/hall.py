"""Geometry set-up of a layout problem: hall polygons, candidate sites, route poses.

Shapely does the polygon work once (validity, containment, face offsets); the
per-pose kernels in :mod:`agvnav.layout.visibility` and
:mod:`agvnav.layout.prediction` only see NumPy arrays. Every geometric check of
the input file (a polygon that does not close or self-intersects, a route
leaving the hall, a reflector inside a rack) raises a located
:class:`~agvnav.world.strict.ScenarioError` naming the key and line.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely import Point, Polygon, validation
from shapely.geometry import LinearRing

from agvnav.guidance import Path
from agvnav.layout.schema import LayoutSpec
from agvnav.sim.build import build_path
from agvnav.world import Reflector, Wall, WorldMap
from agvnav.world.scenario import Scenario, ScenarioError
from agvnav.world.strict import KeyPath, attach_source

__all__ = ["Candidates", "Hall", "RoutePoses", "build_candidates", "build_hall", "route_poses", "routes_as_paths"]

CLOSE_TOL_M = 1e-6


@dataclass(frozen=True)
class Hall:
    """Hall polygons and the wall segments that block the beam.

    ``outer`` is the hall polygon, ``occluders`` ``{id: polygon}`` (racks, pillars),
    ``segments`` ``(M, 2, 2)`` the occluding segments tested for line of sight (m).
    """

    outer: Polygon
    occluders: dict[str, Polygon]
    segments: NDArray[np.float64]

    def world(self, reflectors: list[Reflector]) -> WorldMap:
        """A :class:`WorldMap` with the hall's walls and ``reflectors`` (what ``agvnav simulate`` loads)."""
        walls = [Wall("outer", np.asarray(self.outer.exterior.coords)[:-1], closed=True)]
        walls += [Wall(k, np.asarray(p.exterior.coords)[:-1], closed=True) for k, p in self.occluders.items()]
        return WorldMap(tuple(reflectors), tuple(walls))


@dataclass(frozen=True)
class Candidates:
    """Candidate reflector sites: ``xy`` ``(C, 2)`` (m), ``site`` (index of the site entry, -1 explicit),
    ``along`` (m along that site's faces, for the regular-spacing baseline)."""

    xy: NDArray[np.float64]
    site: NDArray[np.int64]
    along: NDArray[np.float64]


@dataclass(frozen=True)
class RoutePoses:
    """Evaluated route poses: ``pose`` ``(K, 3)`` base_link x, y, psi; ``head`` ``(K, 2)`` goniometer centre;
    ``route`` ``(K,)`` route index; ``s`` ``(K,)`` arclength along the route (m)."""

    pose: NDArray[np.float64]
    head: NDArray[np.float64]
    route: NDArray[np.int64]
    s: NDArray[np.float64]


def _polygon(spec: LayoutSpec, key: KeyPath, pts: list[tuple[float, float]]) -> Polygon:
    """A closed simple polygon from ``pts`` (last point = first), else a located error."""
    arr = np.asarray(pts, dtype=np.float64)
    gap = float(np.hypot(*(arr[-1] - arr[0])))
    if gap > CLOSE_TOL_M:
        raise spec.error(key, f"the polygon does not close: its last point {arr[-1].tolist()} is {gap:.3g} m "
                         f"from the first {arr[0].tolist()} (repeat the first point at the end)")
    ring = LinearRing(arr[:-1])
    poly = Polygon(ring)
    if not ring.is_simple or not poly.is_valid or poly.area <= 0.0:
        raise spec.error(key, f"the polygon is not simple: {validation.explain_validity(poly)}")
    return poly


def build_hall(spec: LayoutSpec) -> Hall:
    """Validated hall polygons: each closes and is simple; occluders lie inside the hall (located errors)."""
    outer = _polygon(spec, ("hall", "outer"), spec.hall.outer)
    occ: dict[str, Polygon] = {}
    for i, o in enumerate(spec.hall.occluders):
        key: KeyPath = ("hall", "occluders", i)
        if o.id in occ or o.id == "outer":
            raise spec.error((*key, "id"), f"duplicate occluder id {o.id!r}")
        poly = _polygon(spec, (*key, "points"), o.points)
        if not outer.contains(poly):
            raise spec.error((*key, "points"), f"occluder {o.id!r} is not inside the hall")
        occ[o.id] = poly
    segs = [_occluding_segments(p) for p in occ.values()]
    if not _is_convex(outer):
        segs.append(_ring_segments(outer))
    segments = np.concatenate(segs) if segs else np.zeros((0, 2, 2))
    return Hall(outer, occ, segments)


def _occluding_segments(poly: Polygon) -> NDArray[np.float64]:
    """Segments that block every line of sight through ``poly`` (both ends outside it).

    A convex quadrilateral (a rack) needs only its two diagonals: a chord through its
    interior separates its corners into two non-empty groups, and so crosses the
    diagonal joining them. Any other polygon uses its edges.
    """
    c = np.asarray(poly.exterior.coords)[:-1]
    if c.shape[0] == 4 and _is_convex(poly):
        return np.stack([np.stack([c[0], c[2]]), np.stack([c[1], c[3]])])
    return _ring_segments(poly)


def _ring_segments(poly: Polygon) -> NDArray[np.float64]:
    c = np.asarray(poly.exterior.coords)
    return np.stack([c[:-1], c[1:]], axis=1)


def _is_convex(poly: Polygon) -> bool:
    return bool(abs(poly.convex_hull.area - poly.area) <= 1e-9 * max(poly.area, 1.0))


def build_candidates(spec: LayoutSpec, hall: Hall) -> Candidates:
    """Candidate sites every ``spacing_m`` along the faces named by ``candidates.sites``, plus the explicit ones.

    A site on ``outer`` sits ``offset_m`` inside the hall; a site on an occluder
    ``offset_m`` outside it. Sites that fall inside another occluder or outside the
    hall are dropped; an explicit candidate there is an error.
    """
    xy: list[NDArray[np.float64]] = []
    site: list[NDArray[np.int64]] = []
    along: list[NDArray[np.float64]] = []
    radius = spec.goniometer.reflector_radius_m
    for i, s in enumerate(spec.candidates.sites):
        if s.face != "outer" and s.face not in hall.occluders:
            key: KeyPath = ("candidates", "sites", i, "face")
            raise spec.error(key, f"unknown face {s.face!r}: use outer or an occluder id")
        offset = radius + 0.01 if s.offset_m is None else s.offset_m
        poly = hall.outer if s.face == "outer" else hall.occluders[s.face]
        pts, a = _face_sites(poly, s.spacing_m, -offset if s.face == "outer" else offset)
        keep = _free(hall, pts, radius)
        xy.append(pts[keep])
        site.append(np.full(int(keep.sum()), i, dtype=np.int64))
        along.append(a[keep])
    for j, p in enumerate(spec.candidates.explicit):
        check_site(spec, hall, ("candidates", "explicit", j), p, radius)
    if spec.candidates.explicit:
        xy.append(np.asarray(spec.candidates.explicit, dtype=np.float64).reshape(-1, 2))
        site.append(np.full(len(spec.candidates.explicit), -1, dtype=np.int64))
        along.append(np.zeros(len(spec.candidates.explicit)))
    if not xy or sum(len(x) for x in xy) == 0:
        raise spec.error(("candidates",), "no candidate site: give sites or explicit positions")
    return Candidates(np.concatenate(xy), np.concatenate(site), np.concatenate(along))


def _face_sites(poly: Polygon, spacing: float, offset: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points every ``spacing`` along the faces of ``poly`` (half a spacing from the corners), pushed ``offset``
    along the outward normal (negative: inward), with their distance along the boundary."""
    ring = poly.exterior if poly.exterior.is_ccw else LinearRing(np.asarray(poly.exterior.coords)[::-1])
    c = np.asarray(ring.coords)
    out, along, s0 = [], [], 0.0
    for a, b in itertools.pairwise(c):
        length = float(np.hypot(*(b - a)))
        n = math.floor(length / spacing)
        if n >= 1:
            u = (np.arange(n) + 0.5) * (length / n)
            t = (b - a) / length
            normal = np.array([t[1], -t[0]])  # outward for a CCW ring
            out.append(a + u[:, None] * t + offset * normal)
            along.append(s0 + u)
        s0 += length
    if not out:
        return np.zeros((0, 2)), np.zeros(0)
    return np.concatenate(out), np.concatenate(along)


def _free(hall: Hall, pts: NDArray[np.float64], radius: float) -> NDArray[np.bool_]:
    """Which discs of ``radius`` around ``pts`` ``(n, 2)`` lie inside the hall and clear of every occluder."""
    discs = shapely.buffer(shapely.points(pts.reshape(-1, 2)), max(radius, 1e-6), quad_segs=8)
    ok = np.asarray(shapely.contains(hall.outer, discs), dtype=bool)
    for o in hall.occluders.values():
        ok &= ~np.asarray(shapely.intersects(o, discs), dtype=bool)
    return ok


def check_site(spec: LayoutSpec, hall: Hall, key: KeyPath, p: tuple[float, float], radius: float) -> None:
    """A reflector at ``p`` must lie inside the hall and outside every occluder (located error)."""
    pt = Point(float(p[0]), float(p[1]))
    if not hall.outer.contains(pt):
        raise spec.error(key, f"reflector at {list(p)} is outside the hall")
    for name, o in hall.occluders.items():
        if o.intersects(pt.buffer(max(radius, 1e-6), 8)):
            raise spec.error(key, f"reflector at {list(p)} is inside occluder {name!r}")


def routes_as_paths(spec: LayoutSpec) -> list[Path]:
    """The routes as guidance paths (the scenario path builder; gaps are located errors)."""
    out = []
    for i, r in enumerate(spec.routes):
        sc = Scenario.model_validate({"vehicle": {"model": "differential"}, "path": r.path.model_dump()})
        attach_source(sc, "", None, None)
        try:
            out.append(build_path(sc))
        except ScenarioError as exc:
            raise spec.error(("routes", i, *exc.key), exc.detail) from None
    return out


def route_poses(spec: LayoutSpec, hall: Hall, paths: list[Path], spacing: float | None = None) -> RoutePoses:
    """Poses every ``spacing`` m (default ``target.route_spacing_m``) along each route; a pose outside the hall or
    in a rack is an error."""
    mx, my, _theta = spec.goniometer.mount  # the head angle does not change the CRLB (heading is estimated)
    poses, heads, rid, ss = [], [], [], []
    for i, path in enumerate(paths):
        n = max(2, math.ceil(path.length / (spacing or spec.target.route_spacing_m)) + 1)
        s = np.linspace(0.0, path.length, n)
        xy = path.point_at(s)
        psi = path.heading_at(s) + path.yaw_offset_at(s) + np.where(path.direction_at(s) < 0, math.pi, 0.0)
        c, sn = np.cos(psi), np.sin(psi)
        head = xy + np.column_stack([c * mx - sn * my, sn * mx + c * my])
        _check_inside(spec, hall, i, xy, s)
        poses.append(np.column_stack([xy, psi]))
        heads.append(head)
        rid.append(np.full(n, i, dtype=np.int64))
        ss.append(s)
    return RoutePoses(np.concatenate(poses), np.concatenate(heads), np.concatenate(rid), np.concatenate(ss))


def _check_inside(spec: LayoutSpec, hall: Hall, i: int, xy: NDArray[np.float64], s: NDArray[np.float64]) -> None:
    pts = shapely.points(xy)
    outside = ~shapely.contains(hall.outer, pts)
    if outside.any():
        k = int(np.argmax(outside))
        raise spec.error(("routes", i, "path"), f"route {spec.routes[i].name!r} leaves the hall at s = {s[k]:.2f} m "
                         f"({xy[k, 0]:.2f}, {xy[k, 1]:.2f})")
    for name, o in hall.occluders.items():
        inside = shapely.intersects(o, pts)
        if inside.any():
            k = int(np.argmax(inside))
            raise spec.error(("routes", i, "path"), f"route {spec.routes[i].name!r} runs into occluder {name!r} at "
                             f"s = {s[k]:.2f} m ({xy[k, 0]:.2f}, {xy[k, 1]:.2f})")
