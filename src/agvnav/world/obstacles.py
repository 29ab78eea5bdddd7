"""Obstacles in the world (issue 18): static boxes and cylinders, and moving ones.

A scenario's ``obstacles:`` list places objects the route planner did not know
about: a pallet left in an aisle (a static box), a pillar guard (a static
cylinder), a person or another vehicle crossing the path (a cylinder or box moving
along a straight or piecewise-linear path at a constant speed from a start time).
This module holds both the schema of that list (:class:`ObstacleSpec`, and the
``scanner:``/``reactive:`` sections that react to obstacles, :class:`ScannerSpec`,
:class:`ReactiveSpec`, kept here so :mod:`agvnav.world.scenario` needs no other
package) and the geometry of an obstacle at time ``t`` (:class:`Obstacle`):
its pose, its shapely shape, its edges (boxes) or circle (cylinders) for exact
ray casting, and whether it blocks a line of sight.

Motion of a moving obstacle (waypoints ``p_0 .. p_k``, speed ``u``, start time
``t_s``): before ``t_s`` it stands at ``p_0`` (or, with ``appears_at_start``, is not
there at all: a person stepping out of a doorway or from behind something the map does
not hold); then it walks the polyline at ``u``; after the last waypoint it stands there.
A moving box faces its direction of travel; a static box faces ``heading``. Units: m, s, rad (degrees only in the
YAML keys ending ``_deg``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Annotated, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field, model_validator
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry

from agvnav.world.strict import Finite, NonNegFloat, PosFloat, StrictModel

__all__ = [
    "Obstacle",
    "ObstacleSet",
    "ObstacleSpec",
    "ReactiveSpec",
    "ScannerSpec",
    "obstacle_from_spec",
]


class ObstacleSpec(StrictModel):
    """One obstacle: a box or a cylinder, standing (``position``) or moving (``path``)."""

    id: str
    """name of the obstacle (used in the metrics: clearance and encounter per obstacle)."""
    shape: Literal["box", "cylinder"]
    """box (length along its heading x width) or cylinder (radius)."""
    radius_m: PosFloat | None = None
    """radius of a cylinder (a person: about 0.25)."""
    length_m: PosFloat | None = None
    """length of a box along its heading."""
    width_m: PosFloat | None = None
    """width of a box across its heading."""
    heading_deg: Finite = 0.0
    """heading of a static box (a moving box faces its direction of travel)."""
    position: tuple[Finite, Finite] | None = None
    """x, y (m) of a static obstacle's centre."""
    path: Annotated[list[tuple[Finite, Finite]], Field(min_length=2)] | None = None
    """waypoints x, y (m) of a moving obstacle's centre: it stands at the first until start_s, then walks."""
    speed_m_s: PosFloat = 1.0
    """speed of a moving obstacle along its path."""
    start_s: NonNegFloat = 0.0
    """time a moving obstacle starts moving."""
    appears_at_start: bool = False
    """true: the obstacle is not there before start_s (it steps out then; false: it stands at its first waypoint)."""

    @model_validator(mode="after")
    def _consistent(self) -> ObstacleSpec:
        if (self.position is None) == (self.path is None):
            raise ValueError("give either position (a static obstacle) or path (a moving one)")
        if self.shape == "cylinder" and self.radius_m is None:
            raise ValueError("a cylinder needs radius_m")
        if self.shape == "box" and (self.length_m is None or self.width_m is None):
            raise ValueError("a box needs length_m and width_m")
        if self.shape == "cylinder" and (self.length_m is not None or self.width_m is not None):
            raise ValueError("a cylinder takes radius_m, not length_m/width_m")
        if self.shape == "box" and self.radius_m is not None:
            raise ValueError("a box takes length_m and width_m, not radius_m")
        return self


class ScannerSpec(StrictModel):
    """A planar safety laser scanner on the vehicle (issue 18): exact ranges to walls and obstacles."""

    mount: tuple[Finite, Finite, Finite] | None = Field(
        None, description="x (m), y (m), theta (deg) in base_link; null: the middle of the body's front edge"
    )
    fov_deg: Annotated[float, Field(gt=0.0, le=360.0)] = 270.0
    """field of view, centred on the scanner's x axis."""
    step_deg: Annotated[float, Field(gt=0.0, le=10.0)] = 0.5
    """angle between beams."""
    max_range_m: PosFloat = 10.0
    """farthest range reported (beyond: no echo)."""
    noise_std_m: NonNegFloat = 0.01
    """standard deviation of the range noise."""
    rate_hz: PosFloat = 25.0
    """scans per second (each scan is taken as instantaneous)."""


class ReactiveSpec(StrictModel):
    """Protective/warning fields, the reaction to them, and local avoidance (issue 18).

    The fields are generated from the stopping distance
    ``v t_react + v^2 / (2 a) + margin`` of each speed band's top speed, with ``a``
    the emergency deceleration, widened all round by the approach ``K T`` (ISO 13855,
    :mod:`agvnav.reactive.fields`), unless ``protective_length_m`` fixes them.
    Warning field: the protective one swept ``warning_time_s`` of travel further ahead.
    """

    enabled: bool = True
    """false: the scanner records, the vehicle does not react (to show the metrics can fail)."""
    reaction_time_s: NonNegFloat = 0.3
    """scanner response, control step and drive lag before braking starts."""
    emergency_decel_m_s2: PosFloat | None = None
    """deceleration of an emergency stop (null: the traction's max_decel_m_s2)."""
    margin_m: NonNegFloat = 0.2
    """distance the protective field adds to the stopping distance."""
    lateral_margin_m: NonNegFloat = 0.1
    """fields reach this far beyond the body's sides."""
    approach_speed_m_s: NonNegFloat = 1.6
    """K: a person may walk this fast from any direction towards the vehicle's swept path while it
    stops, so the protective field reaches K (reaction + braking time) beyond the swept strip, sideways as
    well as ahead (ISO 13855's S = K T + C, K = 1.6 m/s; 0: obstacles that stand or cross without approaching)."""
    warning_time_s: NonNegFloat = 1.5
    """the warning field is longer than the protective one by this much travel at the band's top speed."""
    speed_bands: Annotated[int, Field(ge=1, le=16)] = 4
    """field sets per direction, switched by speed (equal bands up to the cruise speed)."""
    protective_length_m: PosFloat | None = None
    """fixed protective field length ahead of the body (null: from the stopping distance)."""
    warning_length_m: PosFloat | None = None
    """fixed warning field length ahead of the body (with protective_length_m)."""
    slow_speed_fraction: Annotated[float, Field(gt=0.0, le=1.0)] = 0.3
    """fraction of the planned speed while the warning field is intruded."""
    resume_after_s: NonNegFloat = 1.0
    """a field must stay clear this long before the vehicle speeds up again."""
    ultrasonic_stop_m: PosFloat | None = None
    """stop when the front ultrasonic ranger reads below this (the seed-004 rangers as a reactive sensor)."""
    ultrasonic_sensor: str = "front"
    """name of the ranger that stops the vehicle."""
    avoid_segments: list[Annotated[int, Field(ge=0)]] | Literal["all"] = Field(default_factory=list)
    """path segments (indices) on which local avoidance is allowed (a flag per edge); "all": every straight one."""
    corridor_left_m: NonNegFloat = 0.0
    """the corridor reaches this far left of the path (avoidance never leaves it)."""
    corridor_right_m: NonNegFloat = 0.0
    """the corridor reaches this far right of the path."""
    avoid_clearance_m: NonNegFloat = 0.3
    """clearance the detour keeps between the body and the obstacle."""
    avoid_after_s: NonNegFloat = 1.0
    """an obstacle in a field must stay put this long before a detour round it is planned."""
    detour_fields: Literal["creep", "approach"] = "creep"
    """fields on a detour, driven at the slow fraction: "creep", the stopping-distance rectangle without the
    approach term (passes a static obstacle at avoid_clearance_m; a person stepping in from the side then is
    not covered by K T); "approach": the speed band's approach fields (the detour stops beside the obstacle)."""

    @model_validator(mode="after")
    def _fixed_fields(self) -> ReactiveSpec:
        if (self.warning_length_m is None) != (self.protective_length_m is None):
            raise ValueError("give protective_length_m and warning_length_m together (or neither)")
        if (self.warning_length_m is not None and self.protective_length_m is not None
                and self.warning_length_m < self.protective_length_m):
            raise ValueError("warning_length_m must be at least protective_length_m")
        return self


@dataclass(frozen=True)
class Obstacle:
    """Geometry of one obstacle over time (see the module docstring).

    Parameters
    ----------
    id : name.
    shape : ``"box"`` or ``"cylinder"``.
    size : ``(radius,)`` of a cylinder or ``(length, width)`` of a box (m).
    waypoints : ``(k, 2)`` centre positions (m); one row for a static obstacle.
    speed : speed along the waypoints (m/s; ignored when static).
    start : time it starts moving (s).
    heading : heading of a static box (rad).
    appears : not there before ``start`` (:meth:`present`).
    """

    id: str
    shape: str
    size: tuple[float, ...]
    waypoints: NDArray[np.float64]
    speed: float = 1.0
    start: float = 0.0
    heading: float = 0.0
    appears: bool = False
    _cum: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        wp = np.asarray(self.waypoints, dtype=np.float64).reshape(-1, 2)
        if wp.shape[0] < 1 or not np.all(np.isfinite(wp)):
            raise ValueError(f"obstacle {self.id!r}: waypoints must be finite (k >= 1, 2), got shape {wp.shape}")
        if self.shape not in ("box", "cylinder"):
            raise ValueError(f"obstacle {self.id!r}: shape must be 'box' or 'cylinder', got {self.shape!r}")
        n_size = 1 if self.shape == "cylinder" else 2
        if len(self.size) != n_size or not all(math.isfinite(s) and s > 0.0 for s in self.size):
            raise ValueError(f"obstacle {self.id!r}: size must be {n_size} positive finite number(s), got {self.size}")
        if wp.shape[0] > 1 and not (math.isfinite(self.speed) and self.speed > 0.0):
            raise ValueError(f"obstacle {self.id!r}: speed must be positive and finite, got {self.speed!r}")
        object.__setattr__(self, "waypoints", wp)
        legs = np.hypot(*np.diff(wp, axis=0).T) if wp.shape[0] > 1 else np.zeros(0)
        object.__setattr__(self, "_cum", np.concatenate([[0.0], np.cumsum(legs)]))

    def present(self, t: float) -> bool:
        """False before ``start`` (s) for an obstacle that appears then; True otherwise."""
        return not self.appears or t >= self.start

    @property
    def static(self) -> bool:
        """True for an obstacle that never moves."""
        return self.waypoints.shape[0] == 1 or float(self._cum[-1]) == 0.0

    @property
    def radius(self) -> float:
        """Bounding radius about the centre (m): the cylinder's radius or the box's half-diagonal."""
        if self.shape == "cylinder":
            return float(self.size[0])
        return 0.5 * math.hypot(*self.size)

    def pose_at(self, t: ArrayLike) -> NDArray[np.float64]:
        """Centre and heading ``(..., 3)`` (m, m, rad) at times ``t (...)`` (s)."""
        t = np.asarray(t, dtype=np.float64)
        out = np.empty((*t.shape, 3))
        wp = self.waypoints
        if self.static:
            out[..., 0], out[..., 1], out[..., 2] = wp[0, 0], wp[0, 1], self.heading
            return out
        d = np.clip((t - self.start) * self.speed, 0.0, float(self._cum[-1]))
        i = np.clip(np.searchsorted(self._cum, d, side="right") - 1, 0, wp.shape[0] - 2)
        leg = wp[i + 1] - wp[i]
        length = np.maximum(self._cum[i + 1] - self._cum[i], 1e-300)
        u = ((d - self._cum[i]) / length)[..., None]
        xy = wp[i] + u * leg
        out[..., :2] = xy
        out[..., 2] = np.arctan2(leg[..., 1], leg[..., 0]) if self.shape == "box" else 0.0
        return out

    def centre_at(self, t: float) -> tuple[float, float]:
        """Centre ``(x, y)`` (m) at one instant ``t`` (s): the scalar fast path of :meth:`pose_at`."""
        wp = self.waypoints
        if self.static:
            return float(wp[0, 0]), float(wp[0, 1])
        cum = self._cum
        d = min(max((t - self.start) * self.speed, 0.0), float(cum[-1]))
        i = min(max(int(np.searchsorted(cum, d, side="right")) - 1, 0), wp.shape[0] - 2)
        u = (d - float(cum[i])) / max(float(cum[i + 1] - cum[i]), 1e-300)
        return (float(wp[i, 0] + u * (wp[i + 1, 0] - wp[i, 0])), float(wp[i, 1] + u * (wp[i + 1, 1] - wp[i, 1])))

    def corners_at(self, t: float) -> NDArray[np.float64]:
        """The box's corners ``(4, 2)`` (m) at ``t``, counter-clockwise (ValueError for a cylinder)."""
        if self.shape != "box":
            raise ValueError(f"obstacle {self.id!r} is a cylinder: it has no corners")
        x, y, h = (float(v) for v in self.pose_at(t))
        hl, hw = 0.5 * self.size[0], 0.5 * self.size[1]
        local = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
        c, s = math.cos(h), math.sin(h)
        return np.column_stack([x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]])

    def edges_at(self, t: float) -> NDArray[np.float64]:
        """The box's four edges ``(4, 2, 2)`` (m) at ``t``."""
        c = self.corners_at(t)
        return np.stack([c, np.roll(c, -1, axis=0)], axis=1)

    def shape_at(self, t: float, quad_segs: int = 16) -> Polygon:
        """The obstacle as a shapely polygon at ``t`` (a cylinder as a ``4 quad_segs``-gon inscribed in it)."""
        if self.shape == "box":
            return Polygon(self.corners_at(t))
        x, y, _ = (float(v) for v in self.pose_at(t))
        return Point(x, y).buffer(self.size[0], quad_segs=quad_segs)

    def distance(self, geometry: BaseGeometry, t: float) -> float:
        """Exact distance (m) from ``geometry`` to the obstacle at ``t``; 0 when they touch or overlap.

        A cylinder's distance is that from its centre minus its radius (exact, no polygon).
        """
        if self.shape == "box":
            return float(geometry.distance(Polygon(self.corners_at(t))))
        x, y = self.centre_at(t)
        return max(float(geometry.distance(Point(x, y))) - self.size[0], 0.0)


def obstacle_from_spec(spec: ObstacleSpec) -> Obstacle:
    """The :class:`Obstacle` of a scenario entry (degrees become radians)."""
    size = (spec.radius_m,) if spec.shape == "cylinder" else (spec.length_m, spec.width_m)
    points = [spec.position] if spec.path is None else spec.path
    return Obstacle(
        spec.id, spec.shape, tuple(float(s) for s in size if s is not None), np.asarray(points, dtype=np.float64),
        float(spec.speed_m_s), float(spec.start_s), math.radians(spec.heading_deg), bool(spec.appears_at_start),
    )


@dataclass(frozen=True)
class ObstacleSet:
    """All obstacles of a scenario, with the batch geometry the sensors need at an instant.

    ``segments_at(t)`` stacks the box edges, ``circles_at(t)`` the cylinders; ``owner``
    arrays map each edge/circle back to the obstacle index (for the encounter metrics).
    """

    obstacles: tuple[Obstacle, ...]

    def __post_init__(self) -> None:
        ids = [o.id for o in self.obstacles]
        if len(set(ids)) != len(ids):
            raise ValueError(f"obstacle ids must be unique, got {ids}")

    def __len__(self) -> int:
        return len(self.obstacles)

    @property
    def ids(self) -> tuple[str, ...]:
        """Obstacle names, in order."""
        return tuple(o.id for o in self.obstacles)

    @property
    def boxes(self) -> tuple[int, ...]:
        """Indices of the boxes."""
        return tuple(i for i, o in enumerate(self.obstacles) if o.shape == "box")

    @property
    def cylinders(self) -> tuple[int, ...]:
        """Indices of the cylinders."""
        return tuple(i for i, o in enumerate(self.obstacles) if o.shape == "cylinder")

    def segments_at(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Box edges ``(4 B, 2, 2)`` (m) at ``t`` and the obstacle index of each ``(4 B,)``."""
        idx = tuple(i for i in self.boxes if self.obstacles[i].present(t))
        if not idx:
            return np.zeros((0, 2, 2)), np.zeros(0, dtype=np.int64)
        return (np.concatenate([self.obstacles[i].edges_at(t) for i in idx]),
                np.repeat(np.asarray(idx, dtype=np.int64), 4))

    def circles_at(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Cylinders ``(C, 3)`` as ``(x, y, r)`` (m) at ``t`` and the obstacle index of each ``(C,)``."""
        idx = tuple(i for i in self.cylinders if self.obstacles[i].present(t))
        if not idx:
            return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
        rows = [(*self.obstacles[i].centre_at(t), self.obstacles[i].size[0]) for i in idx]
        return np.asarray(rows, dtype=np.float64), np.asarray(idx, dtype=np.int64)

    def shapes_at(self, t: float) -> list[Polygon]:
        """Every obstacle there at ``t`` as a shapely polygon (cylinders inscribed polygons)."""
        return [o.shape_at(t) for o in self.obstacles if o.present(t)]

    def distances(self, geometry: BaseGeometry, t: float) -> NDArray[np.float64]:
        """Exact distance (m) from ``geometry`` to every obstacle at ``t``, ``(n,)`` (inf: not there yet)."""
        return np.array([o.distance(geometry, t) if o.present(t) else math.inf for o in self.obstacles],
                        dtype=np.float64)

    def clearances(self, pose: ArrayLike, footprint: ArrayLike, t: float, exact_within: float = 2.0
                   ) -> NDArray[np.float64]:
        """Distance (m) from the footprint ``(k, 2)`` placed at ``pose`` to every obstacle at ``t``, ``(n,)``
        (NaN for one not there yet).

        Exact (shapely) when the bounding circles come within ``exact_within`` m; beyond, the
        lower bound ``|centre - base_link| - R_body - R_obstacle`` (cheap, and never the minimum
        of a run that came close).
        """
        p = np.asarray(pose, dtype=np.float64)
        fp = np.asarray(footprint, dtype=np.float64)
        r_body = float(np.max(np.hypot(fp[:, 0], fp[:, 1])))
        x, y = float(p[0]), float(p[1])
        out = np.empty(len(self.obstacles))
        body = None
        for i, o in enumerate(self.obstacles):
            if not o.present(t):
                out[i] = math.nan
                continue
            cx, cy = o.centre_at(t)
            bound = math.hypot(cx - x, cy - y) - r_body - o.radius
            if bound > exact_within:
                out[i] = bound
                continue
            if body is None:
                c, s = math.cos(float(p[2])), math.sin(float(p[2]))
                body = Polygon(np.column_stack([x + c * fp[:, 0] - s * fp[:, 1], y + s * fp[:, 0] + c * fp[:, 1]]))
            out[i] = o.distance(body, t)
        return out

    def blocks(self, p0: ArrayLike, p1: ArrayLike, t: float) -> bool:
        """True when the straight line of sight from ``p0`` to ``p1`` (m) crosses an obstacle at ``t``."""
        if not self.obstacles:
            return False
        a = np.asarray(p0, dtype=np.float64)
        b = np.asarray(p1, dtype=np.float64)
        ax, ay, bx, by = float(a[0]), float(a[1]), float(b[0]), float(b[1])
        ex, ey = bx - ax, by - ay
        ee = ex * ex + ey * ey
        line = None
        for o in self.obstacles:
            if not o.present(t):
                continue
            cx, cy = o.centre_at(t)
            u = min(max(((cx - ax) * ex + (cy - ay) * ey) / ee, 0.0), 1.0) if ee > 0.0 else 0.0
            if math.hypot(ax + u * ex - cx, ay + u * ey - cy) > o.radius:  # the bounding circle misses the line
                continue
            line = line or LineString([(ax, ay), (bx, by)])
            if o.distance(line, t) <= 0.0:
                return True
        return False

    def blocked(self, p0: NDArray[np.float64], p1: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.bool_]:
        """:meth:`blocks` for many lines of sight: ``p0 (k, 2) -> p1 (k, 2)`` at times ``t (k,)``; ``(k,)``."""
        return np.array([self.blocks(a, b, float(tk)) for a, b, tk in zip(p0, p1, t, strict=True)], dtype=bool)

    def any_within(self, geometry: BaseGeometry, t: float, distance: float) -> NDArray[np.bool_]:
        """Which obstacles lie within ``distance`` (m) of ``geometry`` at ``t``, ``(n,)``."""
        return self.distances(geometry, t) <= distance

