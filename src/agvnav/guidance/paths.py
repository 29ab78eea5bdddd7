"""Paths as AGV layouts are drawn: straight and circular-arc segments.

A :class:`Path` is the planned path of the *tracked point* of the vehicle (C
when cruising, O when manoeuvring; seed 000 §3.2, Fig. 5). It is parametrised
by arclength ``s`` (m) in the direction the tracked point moves. Each segment
carries a ``direction``: +1 when the vehicle drives forward along it (body
x-axis along the path tangent, v > 0) and -1 when it drives in reverse (forks
first, body x-axis opposite the tangent, v < 0). The path is generic: any
vehicle whose point moves along it can use it (tricycle, tracked robot).
Each segment also carries an optional ``yaw_offset`` (rad, default 0): the
vehicle heading minus the path tangent wanted on that segment, for holonomic
vehicles whose heading is independent of the tangent (e.g. pi/2 for sideways
travel to the left). Non-holonomic followers ignore it.

Conventions (docs/ARCHITECTURE.md): SI units and radians, REP-103 (x forward,
y left, CCW positive). The signed lateral distance is positive to the *left*
of the tangent (direction of increasing s). Curvature is ``d(heading)/ds``,
positive for a left (CCW) turn. Degrees appear only in YAML keys named
``*_deg``.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path as FsPath
from typing import Any, NamedTuple

import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_last_dim
from agvnav.geometry.angles import wrap_angle, wrap_angle_scalar
from agvnav.world.strict import read_document_text
from agvnav.world.yaml_strict import safe_load_unique

__all__ = [
    "GAP_TOLERANCE_M",
    "ArcSegment",
    "LineSegment",
    "Path",
    "PathProjection",
    "PointProjection",
    "Segment",
    "load_path",
    "path_from_moves",
    "save_path",
    "seed_test_path",
]

GAP_TOLERANCE_M = 1e-6
"""Largest distance (m) between one segment's end and the next one's start."""


def _check_yaw_offset(yaw_offset: float) -> float:
    y = float(yaw_offset)
    if not math.isfinite(y):
        raise ValueError(f"yaw_offset must be a finite angle (rad), got {yaw_offset!r}")
    return float(wrap_angle(y))


def _check_direction(direction: int) -> int:
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 (forward) or -1 (reverse), got {direction!r}")
    return int(direction)


def _check_start(start: ArrayLike, heading: float) -> tuple[NDArray[np.float64], float]:
    p = require_finite("start", start)
    if p.shape != (2,):
        raise ValueError(f"start must have shape (2,), got {p.shape}")
    h = float(heading)
    if not math.isfinite(h):
        raise ValueError("heading must be finite")
    return p, float(wrap_angle(h))


def _cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@dataclass(frozen=True, eq=False)
class LineSegment:
    """Straight segment from ``start`` (m, shape (2,)) with tangent ``heading`` (rad).

    ``length`` (m, > 0); ``direction`` +1 forward / -1 reverse; ``yaw_offset``
    (rad, wrapped to [-pi, pi)): heading minus tangent for holonomic vehicles
    (see module doc).
    """

    start: NDArray[np.float64]
    heading: float
    length: float
    direction: int = 1
    yaw_offset: float = 0.0
    _fast: tuple[float, float, float, float] = field(init=False, repr=False)  # start x, y, cos, sin (floats)

    def __post_init__(self) -> None:
        p, h = _check_start(self.start, self.heading)
        if not (math.isfinite(self.length) and self.length > 0.0):
            raise ValueError(f"line length must be a positive finite number, got {self.length!r}")
        object.__setattr__(self, "start", p)
        object.__setattr__(self, "heading", h)
        object.__setattr__(self, "length", float(self.length))
        object.__setattr__(self, "direction", _check_direction(self.direction))
        object.__setattr__(self, "yaw_offset", _check_yaw_offset(self.yaw_offset))
        object.__setattr__(self, "_fast", (float(p[0]), float(p[1]), math.cos(h), math.sin(h)))

    @property
    def curvature(self) -> float:
        """Curvature (1/m): 0 for a line."""
        return 0.0

    def point_at(self, u: ArrayLike) -> NDArray[np.float64]:
        """Point (..., 2) at local arclength ``u`` (m, clipped to [0, length])."""
        u = np.clip(np.asarray(u, dtype=np.float64), 0.0, self.length)
        t = np.array([math.cos(self.heading), math.sin(self.heading)])
        return self.start + u[..., None] * t

    def heading_at(self, u: ArrayLike) -> NDArray[np.float64]:
        """Tangent heading (rad) at local arclength ``u``: constant."""
        return np.full(np.shape(u), self.heading)

    @property
    def end(self) -> NDArray[np.float64]:
        """End point (2,)."""
        return self.point_at(self.length)

    @property
    def end_heading(self) -> float:
        """Tangent heading at the end (rad)."""
        return self.heading

    def local_projection(self, points: NDArray[np.float64], u_lo: ArrayLike, u_hi: ArrayLike) -> NDArray[np.float64]:
        """Local arclength (...,) of the closest point of the segment restricted to [u_lo, u_hi].

        ``points`` (..., 2) in m; the bounds (m) broadcast against the batch shape.
        """
        t = np.array([math.cos(self.heading), math.sin(self.heading)])
        u = (points - self.start) @ t
        return np.clip(u, u_lo, u_hi)

    def point_scalar(self, u: float) -> tuple[float, float]:
        """Scalar fast path of :meth:`point_at` (u clipped to the segment)."""
        u = min(max(u, 0.0), self.length)
        return self.start[0] + u * math.cos(self.heading), self.start[1] + u * math.sin(self.heading)

    def project_scalar(self, x: float, y: float, u_lo: float, u_hi: float) -> tuple[float, float, float, float]:
        """Scalar fast path of :meth:`local_projection`: ``(u, foot_x, foot_y, heading)`` (plain floats)."""
        sx, sy, c, sn = self._fast
        u = min(max((x - sx) * c + (y - sy) * sn, u_lo), u_hi)
        return u, sx + u * c, sy + u * sn, self.heading


@dataclass(frozen=True, eq=False)
class ArcSegment:
    """Circular arc from ``start`` (m, (2,)) with initial tangent ``heading`` (rad).

    ``radius`` (m, > 0) and signed ``sweep`` (rad, 0 < |sweep| <= 2 pi; > 0
    turns left/CCW). Curvature is ``sign(sweep) / radius``. ``direction`` and
    ``yaw_offset`` as for :class:`LineSegment`.
    """

    start: NDArray[np.float64]
    heading: float
    radius: float
    sweep: float
    direction: int = 1
    yaw_offset: float = 0.0
    _centre: tuple[float, float] = field(init=False, repr=False)  # cached for the scalar fast paths
    _phi0: float = field(init=False, repr=False)
    _sg: float = field(init=False, repr=False)  # sign, as a float

    def __post_init__(self) -> None:
        p, h = _check_start(self.start, self.heading)
        if not (math.isfinite(self.radius) and self.radius > 0.0):
            raise ValueError(f"arc radius must be a positive finite number, got {self.radius!r}")
        sw = float(self.sweep)
        if not (math.isfinite(sw) and 0.0 < abs(sw) <= 2.0 * math.pi + 1e-12):
            raise ValueError(f"arc sweep must satisfy 0 < |sweep| <= 2 pi rad, got {self.sweep!r}")
        object.__setattr__(self, "start", p)
        object.__setattr__(self, "heading", h)
        object.__setattr__(self, "radius", float(self.radius))
        object.__setattr__(self, "sweep", sw)
        object.__setattr__(self, "direction", _check_direction(self.direction))
        object.__setattr__(self, "yaw_offset", _check_yaw_offset(self.yaw_offset))
        c = self.centre
        object.__setattr__(self, "_centre", (float(c[0]), float(c[1])))
        object.__setattr__(self, "_phi0", math.atan2(p[1] - c[1], p[0] - c[0]))
        object.__setattr__(self, "_sg", self.sign)

    @property
    def sign(self) -> float:
        """+1 for a left (CCW) turn, -1 for a right turn."""
        return 1.0 if self.sweep > 0 else -1.0

    @property
    def length(self) -> float:
        """Arclength (m) = radius |sweep|."""
        return self.radius * abs(self.sweep)

    @property
    def curvature(self) -> float:
        """Signed curvature (1/m), positive for a left turn."""
        return self.sign / self.radius

    @property
    def centre(self) -> NDArray[np.float64]:
        """Centre of the circle (2,): on the left of the tangent for a left turn."""
        n = np.array([-math.sin(self.heading), math.cos(self.heading)])
        return self.start + self.sign * self.radius * n

    def heading_at(self, u: ArrayLike) -> NDArray[np.float64]:
        """Tangent heading (rad) at local arclength ``u`` (m)."""
        u = np.clip(np.asarray(u, dtype=np.float64), 0.0, self.length)
        return wrap_angle(self.heading + self.curvature * u)

    def point_at(self, u: ArrayLike) -> NDArray[np.float64]:
        """Point (..., 2) at local arclength ``u`` (m, clipped to [0, length])."""
        h = self.heading_at(u)
        # radial unit vector from the centre to the point is the tangent rotated by -sign*90 deg
        r = self.sign * np.stack([np.sin(h), -np.cos(h)], axis=-1)
        return self.centre + self.radius * r

    @property
    def end(self) -> NDArray[np.float64]:
        """End point (2,)."""
        return self.point_at(self.length)

    @property
    def end_heading(self) -> float:
        """Tangent heading at the end (rad)."""
        return float(wrap_angle(self.heading + self.sweep))

    def local_projection(self, points: NDArray[np.float64], u_lo: ArrayLike, u_hi: ArrayLike) -> NDArray[np.float64]:
        """Local arclength (...,) of the closest point of the arc restricted to [u_lo, u_hi].

        The polar angle of the point about the centre, measured from the start
        in the sense of the sweep, gives the unrestricted arclength; outside the
        allowed interval the nearer end along the circle (hence by distance) is
        taken. Bounds (m) broadcast against the batch shape.
        """
        c = self.centre
        d = points - c
        phi = np.arctan2(d[..., 1], d[..., 0])
        phi0 = math.atan2(self.start[1] - c[1], self.start[0] - c[0])
        u = np.mod(self.sign * (phi - phi0), 2.0 * math.pi) * self.radius  # [0, circumference)
        lo, hi = np.asarray(u_lo, dtype=np.float64), np.asarray(u_hi, dtype=np.float64)
        circ = 2.0 * math.pi * self.radius
        d_lo = np.minimum(np.abs(u - lo), circ - np.abs(u - lo))
        d_hi = np.minimum(np.abs(u - hi), circ - np.abs(u - hi))
        inside = (u >= lo) & (u <= hi)
        return np.where(inside, u, np.where(d_lo <= d_hi, lo, hi))

    def point_scalar(self, u: float) -> tuple[float, float]:
        """Scalar fast path of :meth:`point_at` (u clipped to the arc)."""
        u = min(max(u, 0.0), self.length)
        h = self.heading + self.sign * u / self.radius
        cx, cy = self._centre
        return cx + self.sign * self.radius * math.sin(h), cy - self.sign * self.radius * math.cos(h)

    def project_scalar(self, x: float, y: float, u_lo: float, u_hi: float) -> tuple[float, float, float, float]:
        """Scalar fast path of :meth:`local_projection`: ``(u, foot_x, foot_y, heading)`` (plain floats)."""
        cx, cy = self._centre
        r, sg = self.radius, self._sg
        u = ((sg * (math.atan2(y - cy, x - cx) - self._phi0)) % (2.0 * math.pi)) * r
        if not (u_lo <= u <= u_hi):
            circ = 2.0 * math.pi * r
            d_lo = min(abs(u - u_lo), circ - abs(u - u_lo))
            d_hi = min(abs(u - u_hi), circ - abs(u - u_hi))
            u = u_lo if d_lo <= d_hi else u_hi
        h = self.heading + sg * u / r
        return u, cx + sg * r * math.sin(h), cy - sg * r * math.cos(h), wrap_angle_scalar(h)


Segment = LineSegment | ArcSegment


class PointProjection(NamedTuple):
    """Projection of one point (plain floats/ints), as :class:`PathProjection` for a batch."""

    s: float
    lateral: float
    heading: float
    curvature: float
    direction: int
    segment: int
    x: float
    y: float
    distance: float


@dataclass(frozen=True)
class PathProjection:
    """Closest-point projection of points onto a :class:`Path` (all shape ``(...)``).

    Attributes
    ----------
    s : arclength (m) of the closest point, in [0, length].
    lateral : signed lateral distance (m), left of the tangent positive (REP-103).
        Beyond the path ends it is measured from the end tangent line.
    heading : tangent heading (rad) of the path at ``s`` (direction of increasing s).
    curvature : curvature (1/m) at ``s``, positive turning left.
    direction : +1/-1 direction of travel of the segment at ``s``.
    segment : index of that segment.
    point : closest point (..., 2) (m).
    distance : Euclidean distance (m) from the point to ``point``.
    """

    s: NDArray[np.float64]
    lateral: NDArray[np.float64]
    heading: NDArray[np.float64]
    curvature: NDArray[np.float64]
    direction: NDArray[np.int64]
    segment: NDArray[np.int64]
    point: NDArray[np.float64]
    distance: NDArray[np.float64]


class Path:
    """A sequence of line and arc segments, each starting where the previous one ends.

    G1 continuity (equal headings at joints) is not required: a corner is
    allowed, a gap (> :data:`GAP_TOLERANCE_M`) is a ValueError naming the
    segment. Arclength ``s`` runs from 0 to :attr:`length`.
    """

    def __init__(self, segments: Sequence[Segment]):
        segs = list(segments)
        if not segs:
            raise ValueError("a path needs at least one segment")
        for i, seg in enumerate(segs):
            if not isinstance(seg, (LineSegment, ArcSegment)):
                raise ValueError(f"segment {i}: expected LineSegment or ArcSegment, got {type(seg).__name__}")
            if i > 0:
                gap = float(np.hypot(*(seg.start - segs[i - 1].end)))
                if gap > GAP_TOLERANCE_M:
                    raise ValueError(
                        f"segment {i}: starts {gap:.6g} m from the end of segment {i - 1} (gap in the path)"
                    )
        self._segments = tuple(segs)
        lengths = np.array([s.length for s in segs])
        self._s0 = np.concatenate([[0.0], np.cumsum(lengths)])
        # the same abscissae as floats, and each segment's end, for project_point's search (issue 11)
        self._starts = self._s0[:-1].tolist()
        self._ends = [s0 + seg.length for s0, seg in zip(self._starts, segs, strict=True)]
        self._curv = np.array([s.curvature for s in segs])
        self._dir = np.array([s.direction for s in segs], dtype=np.int64)
        # length, curvature and direction of each segment as Python values, for project_point
        self._fast = [(float(seg.length), float(seg.curvature), int(seg.direction)) for seg in segs]
        self._yaw = np.array([s.yaw_offset for s in segs])

    # ---------------------------------------------------------------- access
    @property
    def segments(self) -> tuple[Segment, ...]:
        """The segments, in order."""
        return self._segments

    @property
    def length(self) -> float:
        """Total arclength (m)."""
        return float(self._s0[-1])

    @property
    def segment_starts(self) -> NDArray[np.float64]:
        """Arclength (m) at the start of each segment, plus the total length, shape (n+1,)."""
        return self._s0.copy()

    @property
    def start_pose(self) -> NDArray[np.float64]:
        """``[x, y, tangent heading]`` at s = 0."""
        s0 = self._segments[0]
        return np.array([s0.start[0], s0.start[1], s0.heading])

    @property
    def end_pose(self) -> NDArray[np.float64]:
        """``[x, y, tangent heading]`` at s = length."""
        s1 = self._segments[-1]
        return np.array([s1.end[0], s1.end[1], s1.end_heading])

    def is_g1(self, tol: float = 1e-6) -> bool:
        """True if the tangent heading is continuous (within ``tol`` rad) at every joint."""
        return all(
            abs(float(wrap_angle(b.heading - a.end_heading))) <= tol
            for a, b in zip(self._segments[:-1], self._segments[1:], strict=True)
        )

    def segment_index(self, s: ArrayLike) -> NDArray[np.int64]:
        """Index of the segment holding arclength ``s`` (m); a joint belongs to the next segment."""
        s = np.asarray(s, dtype=np.float64)
        idx = np.searchsorted(self._s0, s, side="right") - 1
        return np.clip(idx, 0, len(self._segments) - 1).astype(np.int64)

    def _per_segment(self, s: ArrayLike, attr: str) -> NDArray[np.float64]:
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, self.length)
        idx = self.segment_index(s)
        out = np.empty(s.shape + ((2,) if attr == "point_at" else ()))
        for i in np.unique(idx):
            m = idx == i
            out[m] = getattr(self._segments[i], attr)(s[m] - self._s0[i])
        return out

    def point_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Point (..., 2) (m) at arclength ``s`` (m, clipped to [0, length])."""
        return self._per_segment(s, "point_at")

    def heading_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Tangent heading (rad) at arclength ``s``."""
        return self._per_segment(s, "heading_at")

    def curvature_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Curvature (1/m) at arclength ``s``."""
        return self._curv[self.segment_index(np.clip(s, 0.0, self.length))]

    def direction_at(self, s: ArrayLike) -> NDArray[np.int64]:
        """Direction of travel (+1/-1) at arclength ``s``."""
        return self._dir[self.segment_index(np.clip(s, 0.0, self.length))]

    def yaw_offset_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Wanted heading minus tangent (rad) at arclength ``s`` (m): the segment's ``yaw_offset``."""
        return self._yaw[self.segment_index(np.clip(s, 0.0, self.length))]

    def extrapolate(self, s: ArrayLike) -> NDArray[np.float64]:
        """Point (..., 2) at arclength ``s``, continuing along the end tangents beyond [0, length]."""
        s = np.asarray(s, dtype=np.float64)
        p = self.point_at(s)
        before, after = np.minimum(s, 0.0), np.maximum(s - self.length, 0.0)
        h0, h1 = self._segments[0].heading, self._segments[-1].end_heading
        p = p + before[..., None] * np.array([math.cos(h0), math.sin(h0)])
        return p + after[..., None] * np.array([math.cos(h1), math.sin(h1)])

    def extrapolate_point(self, s: float) -> tuple[float, float]:
        """Scalar fast path of :meth:`extrapolate` for one arclength ``s`` (m)."""
        if s <= 0.0:
            seg = self._segments[0]
            return seg.start[0] + s * math.cos(seg.heading), seg.start[1] + s * math.sin(seg.heading)
        if s >= self.length:
            seg = self._segments[-1]
            ex, ey = seg.point_scalar(seg.length)
            h, extra = seg.end_heading, s - self.length
            return ex + extra * math.cos(h), ey + extra * math.sin(h)
        i = int(np.searchsorted(self._s0, s, side="right")) - 1
        i = min(max(i, 0), len(self._segments) - 1)
        return self._segments[i].point_scalar(s - float(self._s0[i]))

    # ------------------------------------------------------------ projection
    def project(
        self, points: ArrayLike, s_hint: ArrayLike | None = None, window: float | None = None
    ) -> PathProjection:
        """Closest point on the path for each of ``points`` (..., 2) (m).

        With ``s_hint`` (m, broadcastable to the batch shape) and ``window`` (m),
        only the part of the path with ``|s - s_hint| <= window`` is searched, so a
        controller does not jump to another part of a self-crossing path. Ties go
        to the earlier segment.
        """
        pts = require_last_dim("points", require_finite("points", points), 2)
        batch = pts.shape[:-1]
        if (s_hint is None) != (window is None):
            raise ValueError("give both s_hint and window, or neither")
        if window is not None:
            if not (math.isfinite(window) and window > 0.0):
                raise ValueError(f"window must be a positive finite number, got {window!r}")
            hint = np.broadcast_to(np.asarray(s_hint, dtype=np.float64), batch)
            lo, hi = hint - window, hint + window
        else:
            lo, hi = np.full(batch, -np.inf), np.full(batch, np.inf)
        best_d = np.full(batch, np.inf)
        best_s = np.zeros(batch)
        best_i = np.zeros(batch, dtype=np.int64)
        for i, seg in enumerate(self._segments):
            s0 = self._s0[i]
            u_lo = np.clip(lo - s0, 0.0, seg.length)
            u_hi = np.clip(hi - s0, 0.0, seg.length)
            empty = (hi < s0) | (lo > s0 + seg.length)
            u = seg.local_projection(pts, u_lo, u_hi)
            d = np.hypot(*np.moveaxis(pts - seg.point_at(u), -1, 0))
            d = np.where(empty, np.inf, d)
            better = d < best_d
            best_d = np.where(better, d, best_d)
            best_s = np.where(better, s0 + u, best_s)
            best_i = np.where(better, i, best_i)
        if np.any(~np.isfinite(best_d)):
            raise ValueError("s_hint +/- window does not overlap the path")
        return self._projection_at(pts, best_s, best_i, best_d)

    def project_point(
        self, x: float, y: float, s_hint: float | None = None, window: float | None = None
    ) -> PointProjection:
        """Scalar fast path of :meth:`project` for one point ``(x, y)`` (m): plain floats, same result.

        Meant for controllers called at every time step; only segments that
        overlap ``s_hint +/- window`` are visited.
        """
        if s_hint is None:
            lo, hi = -math.inf, math.inf
        else:
            if window is None or not window > 0.0:
                raise ValueError(f"window must be a positive finite number, got {window!r}")
            lo, hi = s_hint - window, s_hint + window
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError("point contains NaN or inf")
        best = None
        best_d2 = math.inf
        starts, ends, fast = self._starts, self._ends, self._fast
        # the segments overlapping [lo, hi], in order: the first whose end reaches lo (ends ascend), up to hi
        for i in range(bisect.bisect_left(ends, lo), len(starts)):
            s0 = starts[i]
            if s0 > hi:
                break
            if lo > ends[i]:
                continue
            length = fast[i][0]
            u_lo, u_hi = min(max(lo - s0, 0.0), length), min(max(hi - s0, 0.0), length)
            u, fx, fy, h = self._segments[i].project_scalar(x, y, u_lo, u_hi)
            d2 = (x - fx) ** 2 + (y - fy) ** 2
            if d2 < best_d2:
                best_d2, best = d2, (s0 + u, fx, fy, h, i)
        if best is None:
            raise ValueError("s_hint +/- window does not overlap the path")
        s_b, fx, fy, h, i = best
        lateral = math.cos(h) * (y - fy) - math.sin(h) * (x - fx)
        _, curvature, direction = fast[i]
        return PointProjection(s_b, lateral, h, curvature, direction, i, fx, fy, math.sqrt(best_d2))

    def _projection_at(
        self,
        pts: NDArray[np.float64],
        s: NDArray[np.float64],
        idx: NDArray[np.int64],
        dist: NDArray[np.float64],
    ) -> PathProjection:
        heading = np.empty(s.shape)
        foot = np.empty(s.shape + (2,))
        for i in np.unique(idx):
            m = idx == i
            seg = self._segments[i]
            heading[m] = seg.heading_at(s[m] - self._s0[i])
            foot[m] = seg.point_at(s[m] - self._s0[i])
        t = np.stack([np.cos(heading), np.sin(heading)], axis=-1)
        lateral = _cross(t, pts - foot)
        return PathProjection(
            s=s,
            lateral=lateral,
            heading=heading,
            curvature=self._curv[idx],
            direction=self._dir[idx],
            segment=idx,
            point=foot,
            distance=dist,
        )

    # ------------------------------------------------------------------ YAML
    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (degrees labelled ``*_deg``), inverse of :meth:`from_dict`."""
        first = self._segments[0]
        out: dict[str, Any] = {
            "start": {
                "x": float(first.start[0]),
                "y": float(first.start[1]),
                "heading_deg": math.degrees(first.heading),
            },
            "segments": [],
        }
        prev_heading = first.heading
        for seg in self._segments:
            d: dict[str, Any]
            if isinstance(seg, LineSegment):
                d = {"type": "line", "length": seg.length}
            else:
                d = {"type": "arc", "radius": seg.radius, "sweep_deg": math.degrees(seg.sweep)}
            if abs(float(wrap_angle(seg.heading - prev_heading))) > 1e-12:
                d["heading_deg"] = math.degrees(seg.heading)  # a corner (G1 break)
            d["direction"] = "forward" if seg.direction > 0 else "reverse"
            if seg.yaw_offset != 0.0:
                d["yaw_offset_deg"] = math.degrees(seg.yaw_offset)
            out["segments"].append(d)
            prev_heading = seg.end_heading
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Path:
        """Build from the :meth:`to_dict` form; errors name the offending key or segment.

        ``start: {x, y, heading_deg}`` then ``segments``: each ``{type: line, length}``
        or ``{type: arc, radius, sweep_deg}`` with optional ``direction``
        (forward/reverse or +1/-1, default forward), optional ``heading_deg`` (a
        corner: the segment's own initial heading), optional ``yaw_offset_deg``
        (heading minus tangent for holonomic vehicles, default 0) and optional
        ``x``/``y`` (its start, which must coincide with the previous end: a gap
        is an error).
        """
        if not isinstance(data, Mapping):
            raise ValueError("path: expected a mapping with keys 'start' and 'segments'")
        unknown = set(data) - {"start", "segments"}
        if unknown:
            raise ValueError(f"path: unknown key(s) {sorted(unknown)}")
        for key in ("start", "segments"):
            if key not in data:
                raise ValueError(f"path: missing key '{key}'")
        start = data["start"]
        if not isinstance(start, Mapping):
            raise ValueError("path.start: expected a mapping {x, y, heading_deg}")
        _check_keys("path.start", start, required={"x", "y", "heading_deg"}, optional=set())
        pos = np.array([_num("path.start.x", start["x"]), _num("path.start.y", start["y"])])
        heading = math.radians(_num("path.start.heading_deg", start["heading_deg"]))
        items = data["segments"]
        if not isinstance(items, list) or not items:
            raise ValueError("path.segments: expected a non-empty list")
        segs: list[Segment] = []
        for i, item in enumerate(items):
            seg = _segment_from_dict(i, item, pos, heading)
            segs.append(seg)
            pos, heading = seg.end, seg.end_heading
        return cls(segs)

    def __repr__(self) -> str:
        return f"Path({len(self._segments)} segments, length={self.length:.3f} m)"


def _num(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name}: expected a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name}: must be finite, got {value!r}")
    return v


def _check_keys(where: str, d: Mapping[str, Any], required: set[str], optional: set[str]) -> None:
    unknown = set(d) - required - optional
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {sorted(unknown)}")
    missing = required - set(d)
    if missing:
        raise ValueError(f"{where}: missing key(s) {sorted(missing)}")


def _direction_from(where: str, value: Any) -> int:
    table = {"forward": 1, "reverse": -1, 1: 1, -1: -1}
    if isinstance(value, bool) or value not in table:
        raise ValueError(f"{where}: expected 'forward', 'reverse', 1 or -1, got {value!r}")
    return table[value]


def _segment_from_dict(i: int, item: Any, pos: NDArray[np.float64], heading: float) -> Segment:
    where = f"path.segments[{i}]"
    if not isinstance(item, Mapping):
        raise ValueError(f"{where}: expected a mapping")
    kind = item.get("type")
    common = {"type", "direction", "heading_deg", "yaw_offset_deg", "x", "y"}
    if kind == "line":
        _check_keys(where, item, required={"type", "length"}, optional=common)
    elif kind == "arc":
        _check_keys(where, item, required={"type", "radius", "sweep_deg"}, optional=common)
    else:
        raise ValueError(f"{where}.type: expected 'line' or 'arc', got {kind!r}")
    direction = _direction_from(f"{where}.direction", item.get("direction", "forward"))
    yaw = math.radians(_num(f"{where}.yaw_offset_deg", item["yaw_offset_deg"])) if "yaw_offset_deg" in item else 0.0
    if "heading_deg" in item:
        heading = math.radians(_num(f"{where}.heading_deg", item["heading_deg"]))
    if ("x" in item) != ("y" in item):
        raise ValueError(f"{where}: give both x and y, or neither")
    if "x" in item:
        start = np.array([_num(f"{where}.x", item["x"]), _num(f"{where}.y", item["y"])])
        gap = float(np.hypot(*(start - pos)))
        if gap > GAP_TOLERANCE_M:
            raise ValueError(f"{where}: starts {gap:.6g} m from the end of the previous segment (gap in the path)")
    try:
        if kind == "line":
            return LineSegment(pos, heading, _num(f"{where}.length", item["length"]), direction, yaw)
        sweep = math.radians(_num(f"{where}.sweep_deg", item["sweep_deg"]))
        return ArcSegment(pos, heading, _num(f"{where}.radius", item["radius"]), sweep, direction, yaw)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def path_from_moves(
    start_pose: ArrayLike, moves: Iterable[tuple[str, float] | tuple[str, float, float] | Sequence[Any]]
) -> Path:
    """Build a G1 path from a start pose ``[x, y, heading]`` (m, m, rad) and a list of moves.

    Each move is ``("line", length[, direction[, yaw_offset]])`` or
    ``("arc", radius, sweep[, direction[, yaw_offset]])`` with length/radius in
    m, sweep and yaw_offset in rad (sweep > 0 turns left); direction +1/-1.
    """
    p = require_finite("start_pose", start_pose)
    if p.shape != (3,):
        raise ValueError(f"start_pose must have shape (3,), got {p.shape}")
    pos, heading = p[:2], float(p[2])
    segs: list[Segment] = []
    for i, mv in enumerate(moves):
        try:
            kind, *args = mv
            if kind not in ("line", "arc"):
                raise ValueError(f"unknown move kind {kind!r} (expected 'line' or 'arc')")
            n = 1 if kind == "line" else 2  # leading geometric arguments
            if len(args) > n + 2:
                raise ValueError(f"too many values in move {mv!r}")
            extra = (int(args[n]) if len(args) > n else 1, float(args[n + 1]) if len(args) > n + 1 else 0.0)
            if kind == "line":
                seg: Segment = LineSegment(pos, heading, float(args[0]), *extra)
            else:
                seg = ArcSegment(pos, heading, float(args[0]), float(args[1]), *extra)
        except (TypeError, IndexError) as exc:
            raise ValueError(f"move {i}: malformed {mv!r}: {exc}") from None
        except ValueError as exc:
            raise ValueError(f"move {i}: {exc}") from None
        segs.append(seg)
        pos, heading = seg.end, seg.end_heading
    if not segs:
        raise ValueError("moves must not be empty")
    return Path(segs)


def seed_test_path(
    start_pose: ArrayLike = (0.0, 0.0, 0.0), radius: float = 1.24, sweep: float = -math.pi / 2, straight: float = 3.0
) -> Path:
    """The seed-000 guidance test path for point C (seed 000 §4.3, Fig. 10).

    An arc of radius 1.24 m followed by a 3 m straight, driven forward. The
    sweep is not given in the text; a quarter turn (to the right by default)
    matches the drawing of Fig. 10.
    """
    return path_from_moves(start_pose, [("arc", radius, sweep), ("line", straight)])


def load_path(path: str | FsPath) -> Path:
    """Read a path from a YAML file (see :meth:`Path.from_dict`; top-level key ``path`` optional)."""
    text = read_document_text(path, "path")
    try:
        data = safe_load_unique(text)
    except yaml.YAMLError as exc:
        raise ValueError(" ".join(f"{path}: invalid YAML: {exc}".split())) from None
    if isinstance(data, Mapping) and set(data) == {"path"}:
        data = data["path"]
    try:
        return Path.from_dict(data)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def save_path(p: Path, path: str | FsPath) -> None:
    """Write ``p`` to a YAML file under the top-level key ``path``."""
    with open(path, "w", encoding="utf-8") as fh:
        yaml.safe_dump({"path": p.to_dict()}, fh, sort_keys=False)
