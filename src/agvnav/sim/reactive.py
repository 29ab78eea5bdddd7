"""Wiring of the reactive control (issue 18): obstacles, the safety scanner, the reaction, avoidance.

Roles only; the parts live in :mod:`agvnav.world.obstacles`, :mod:`agvnav.sensors.scanner`
and :mod:`agvnav.reactive`:

* :class:`ScannerRole`: the safety scanner as a closed-loop sensor, scanning the walls and
  the obstacles (at each scan's instant) along the true motion; the latest scan is kept in a
  :class:`ReactiveInputs` for the autopilot (positioning never reads it);
* :class:`OccludedReflections`: the goniometer role with reflections whose line of sight an
  obstacle cuts at that instant removed (obstacles occlude the beam like walls);
* :class:`ObstacleRangers`: the ultrasonic role echoing off obstacle faces as well as walls,
  keeping the reading of the stopping ranger for the reaction (the seed-004 rangers as a
  simple reactive sensor; the robot's HY-SRF05 rangers serve "to avoid obstacles" [seed004 §II]);
* :class:`ObstacleCollisionWatch`: the plant's failure is also ``collision`` when the footprint
  at the true pose touches an obstacle at that instant;
* :class:`ReactiveAutopilot`: the :class:`~agvnav.sim.roles.PathAutopilot` of the route whose
  speed scale is the smaller of the positioning guard's and the reaction's (:class:`ReactiveWatch`);
  field sets are chosen by ``max(|v|, v_intended)`` (the speed it would drive at, so a stop is
  not released by the field shrinking at standstill), on a detour at the slow fraction the
  configuration's creep set (``detour_fields``); an emergency stop brakes at the
  emergency deceleration; on a segment that allows it, a stop for a static obstacle that lasts
  ``avoid_after_s`` plans a detour (:func:`agvnav.reactive.plan_detour`) driven at the slow
  fraction, then the route resumes. A detour is planned for a *static* obstacle: one in a field
  whose echoes (off the map's walls) have not moved over ``avoid_after_s``, so a person
  crossing is waited for and a pallet is driven round, planned while the vehicle slows down
  (a long warning field leaves room for the S-curve) or once it stands.

:func:`reactive_figures` turns the recorded signals into the run's figures: stops, time stopped,
minimum clearance and encounter result (``collision``, ``avoid``, ``stop``, ``slow``, ``none``)
per obstacle, the largest excursion of the body beyond the corridor.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Polygon

from agvnav.geometry import compose
from agvnav.reactive import (
    FieldConfig,
    FieldSet,
    Reaction,
    ReactionLimits,
    field_demand,
    generate_fields,
    intrusions,
    plan_detour,
    scanned_obstacle,
)
from agvnav.sensors.scanner import SafetyScanner
from agvnav.sim.collision import segment_distances
from agvnav.sim.roles import PathAutopilot
from agvnav.world import WorldMap
from agvnav.world.obstacles import ObstacleSet, obstacle_from_spec

__all__ = [
    "REACTIVE_SIGNALS",
    "ObstacleCollisionWatch",
    "ObstacleRangers",
    "OccludedReflections",
    "ReactiveAutopilot",
    "ReactiveInputs",
    "ReactiveWatch",
    "ScannerRole",
    "reactive_figures",
    "wire_reactive",
]

#: Signals the reaction adds to the recorded series (then one ``clearance__<id>`` per obstacle, m).
REACTIVE_SIGNALS = (
    "reaction_level",      # 0 clear, 1 slow, 2 stop
    "field_v_max",         # top speed of the selected field set (m/s)
    "protective_length",   # its protective field's reach beyond the body (m)
    "field_trigger",       # obstacle index in the most severe intruded field; -2 a wall; -1 none
    "ranger_stop_range",   # reading of the stopping ultrasonic ranger (m; NaN none)
    "avoiding",            # 1 on a detour
    "detour_target",       # obstacle index the detour passes (-1 none / unknown)
    "corridor_excess",     # how far the body reaches beyond the corridor (m; 0 inside; NaN no corridor)
)

#: Depth (m) an obstacle is assumed to have beyond the faces the scanner sees, when planning a detour.
ASSUMED_DEPTH_M = 1.5
#: An obstacle whose echoes' centroid moved less than this (m) over ``avoid_after_s`` is static.
STATIC_TOLERANCE_M = 0.15
#: Echoes closer than this (m) to a map wall are the wall (the vehicle knows its map).
WALL_TOLERANCE_M = 0.1


@dataclass
class ReactiveInputs:
    """What the sensors last saw, for the autopilot: scan echoes in base_link and their owner, ranger reading."""

    t: float = -math.inf
    points: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    owner: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    ranger: float = math.nan


class ScannerRole:
    """The safety scanner as a closed-loop sensor (see the module docstring).

    Event rows ``(t, min_range, owner of the nearest echo)``: owner an obstacle index, -2 a wall,
    -1 no echo.
    """

    name = "scanner"
    event_names: tuple[str, ...] = ("t", "min_range", "nearest_owner")

    def __init__(self, scanner: SafetyScanner, walls: NDArray[np.float64], obstacles: ObstacleSet,
                 inputs: ReactiveInputs) -> None:
        self.scanner = scanner
        self.walls = np.asarray(walls, dtype=np.float64).reshape(-1, 2, 2)
        self.obstacles = obstacles
        self.inputs = inputs

    def observe(self, pose_at: Any, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """One row per scan instant in ``(t0, t1]``; the last scan is kept in the inputs."""
        times = self.scanner.scan_times(t0, t1)
        if times.size == 0:
            return np.zeros((0, 3))
        poses = np.asarray(pose_at(times), dtype=np.float64).reshape(-1, 3)
        rows = []
        n_walls = self.walls.shape[0]
        for k, t in enumerate(times.tolist()):
            box_edges, box_owner = self.obstacles.segments_at(t)
            circles, circle_owner = self.obstacles.circles_at(t)
            segs = np.concatenate([self.walls, box_edges]) if box_edges.shape[0] else self.walls
            ranges, hit, points = self.scanner.measure(poses[k], segs, circles, rng)
            owners = np.concatenate([np.full(n_walls, -2), box_owner, circle_owner]).astype(np.int64)
            h = hit[0]
            owner = np.where(h >= 0, owners[np.maximum(h, 0)], -1)
            j = int(np.argmin(ranges[0]))
            rows.append((t, float(ranges[0, j]), float(owner[j])))
            echo = owner >= -2
            echo &= h >= 0
            self.inputs.t, self.inputs.points, self.inputs.owner = t, points[0][echo], owner[echo]
        return np.asarray(rows, dtype=np.float64)

    def deliver(self, estimator: Any, event: NDArray[np.float64]) -> None:
        """Nothing: positioning does not use the safety scanner."""


class OccludedReflections:
    """A goniometer role whose reflections are dropped when an obstacle cuts the line of sight then."""

    def __init__(self, inner: Any, obstacles: ObstacleSet, reflector_xy: NDArray[np.float64],
                 mount: tuple[float, float, float]) -> None:
        self.inner = inner
        self.name = getattr(inner, "name", "reflections")
        self.event_names = inner.event_names
        self.obstacles = obstacles
        self.reflector_xy = np.asarray(reflector_xy, dtype=np.float64)
        self.mount = np.asarray(mount, dtype=np.float64)
        self.deliver = inner.deliver
        self.n_occluded = 0

    def observe(self, pose_at: Any, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """The inner role's rows without those an obstacle hides (column 2: the true reflector index)."""
        ev = self.inner.observe(pose_at, t0, t1, rng)
        if ev.shape[0] == 0:
            return ev
        heads = compose(np.asarray(pose_at(ev[:, 0]), dtype=np.float64).reshape(-1, 3), self.mount)
        keep = np.ones(ev.shape[0], dtype=bool)
        for k in range(ev.shape[0]):
            i = int(ev[k, 2])
            if i < 0:
                continue
            if self.obstacles.blocks(heads[k, :2], self.reflector_xy[i], float(ev[k, 0])):
                keep[k] = False
        self.n_occluded += int((~keep).sum())
        return ev[keep]


class ObstacleRangers:
    """An ultrasonic role echoing off obstacles too; keeps the stopping ranger's last reading in the inputs.

    The obstacle faces of the window's mid-instant join the wall segments (a cylinder as a
    32-gon inscribed in it) before the inner role casts its cones.
    """

    def __init__(self, inner: Any, obstacles: ObstacleSet, inputs: ReactiveInputs, stop_sensor: str | None) -> None:
        self.inner = inner
        self.name = inner.name
        self.event_names = inner.event_names
        self.walls = np.asarray(inner.segments, dtype=np.float64)
        self.obstacles = obstacles
        self.inputs = inputs
        self.column = None if stop_sensor is None else 1 + list(inner.names).index(stop_sensor)
        self.deliver = inner.deliver

    def observe(self, pose_at: Any, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """The inner role's rows with the obstacles in the scene."""
        tm = 0.5 * (t0 + t1)
        faces = [np.stack([c[:-1], c[1:]], axis=1) for c in
                 (np.asarray(s.exterior.coords) for s in self.obstacles.shapes_at(tm))]
        self.inner.segments = np.concatenate([self.walls, *faces]) if faces else self.walls
        ev = self.inner.observe(pose_at, t0, t1, rng)
        if self.column is not None:
            for row in ev:
                r = float(row[self.column])
                if r != math.inf:  # the sensor pinged at this instant (NaN: no echo)
                    self.inputs.ranger = r
        return ev


class ObstacleCollisionWatch:
    """The plant's failure, else ``collision`` when its footprint at the true pose touches an obstacle now.

    ``hit`` names the obstacle index of a collision. Other role methods are the plant's.
    """

    def __init__(self, plant: Any, obstacles: ObstacleSet) -> None:
        self.plant = plant
        self.obstacles = obstacles
        self.footprint = np.asarray(plant.footprint, dtype=np.float64)
        self.radius = float(np.max(np.hypot(self.footprint[:, 0], self.footprint[:, 1])))
        self.pose_at = plant.pose_at
        self.odometry = plant.odometry
        self.signals = plant.signals
        self.signal_names = plant.signal_names
        self.t = 0.0
        self.hit = -1

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """The plant's step; remembers the time reached."""
        self.plant.advance(command, t0, dt, rng)
        self.t = t0 + dt

    def failure(self) -> str | None:
        """The plant's own failure, else ``"collision"`` with an obstacle."""
        own = self.plant.failure()
        if own is not None:
            return str(own)
        pose = np.asarray(self.plant.pose, dtype=np.float64)
        body: Polygon | None = None
        for i, ob in enumerate(self.obstacles.obstacles):
            if not ob.present(self.t):
                continue
            c = ob.centre_at(self.t)
            if math.hypot(c[0] - pose[0], c[1] - pose[1]) > self.radius + ob.radius:
                continue
            body = body or _placed(self.footprint, pose)
            if ob.distance(body, self.t) <= 0.0:
                self.hit = i
                return "collision"
        return None

    def __getattr__(self, name: str) -> Any:
        return getattr(self.plant, name)


def _placed(footprint: NDArray[np.float64], pose: NDArray[np.float64]) -> Polygon:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return Polygon(np.column_stack([pose[0] + c * footprint[:, 0] - s * footprint[:, 1],
                                    pose[1] + s * footprint[:, 0] + c * footprint[:, 1]]))


class ReactiveWatch:
    """The positioning guard's watch with the reaction's scale composed in: ``min`` of the scales.

    Its signals are the guard's followed by :data:`REACTIVE_SIGNALS` and the clearances, which
    the :class:`ReactiveAutopilot` fills in.
    """

    def __init__(self, inner: Any, obstacle_ids: Sequence[str]) -> None:
        self.inner = inner
        self.signal_names = (*inner.signal_names, *REACTIVE_SIGNALS, *(f"clearance__{i}" for i in obstacle_ids))
        self.reactive_scale = 1.0
        self.last_guard_scale = 1.0
        nan = math.nan
        self.reactive_sig: tuple[float, ...] = (0.0, nan, nan, -1.0, nan, 0.0, -1.0, nan,
                                                *([nan] * len(obstacle_ids)))

    def scale(self, t: float, estimator: Any) -> float:
        """``min(guard scale, reaction scale)``."""
        self.last_guard_scale = float(self.inner.scale(t, estimator))
        return min(self.last_guard_scale, self.reactive_scale)

    def signals(self) -> tuple[float, ...]:
        """The guard's signals then the reaction's."""
        return (*self.inner.signals(), *self.reactive_sig)


class ReactiveAutopilot(PathAutopilot):
    """The route's :class:`PathAutopilot` with the reaction and avoidance (see the module docstring)."""

    def __init__(
        self,
        base: PathAutopilot,
        plant: Any,
        watch: ReactiveWatch,
        fields: FieldConfig | None,
        reaction: Reaction,
        inputs: ReactiveInputs,
        obstacles: ObstacleSet,
        walls: NDArray[np.float64],
        emergency_decel: float,
        avoid: dict[str, Any] | None,
    ) -> None:
        super().__init__(base.follower, base.path, base.profile, plant, base.offset, base.progress_window,
                         base.end_tolerance, watch)
        self.rwatch = watch
        self.fields = fields
        self.reaction = reaction
        self.inputs = inputs
        self.obstacles = obstacles
        self.walls = np.asarray(walls, dtype=np.float64).reshape(-1, 2, 2)
        self.emergency_decel = float(emergency_decel)
        self.normal_decel = float(base.profile.max_decel)
        self.avoid = avoid
        self.detour: Any = None
        self.detour_pilot: PathAutopilot | None = None
        self.detours = 0
        self.plant_ref = plant
        self._stopped_since: float | None = None
        self._seen: NDArray[np.float64] | None = None
        self._last_try = -math.inf
        self._footprint = np.asarray(plant.footprint, dtype=np.float64)
        self._trigger = -1
        self._field: FieldSet | None = None

    # ------------------------------------------------------------------ reaction
    def _demand(self, speed: float, direction: int, creep: bool = False) -> tuple[int, float, float]:
        """Demanded level from the latest scan and ranger reading; the selected set's v_max and length.

        ``creep``: on a detour at the slow fraction (the field configuration's creep set, if it has one)."""
        demand, v_max, p_len = 0, math.nan, math.nan
        self._trigger = -1
        self._field = None
        if self.fields is not None and self.inputs.points.shape[0]:
            fs = self.fields.select(speed, direction, creep)
            self._field = fs
            v_max, p_len = fs.v_max, fs.protective_length
            prot = self._inside(self.inputs.points, fs.protective)
            warn = self._inside(self.inputs.points, fs.warning)
            demand = field_demand(bool(prot.any()), bool(warn.any()))
            if demand:
                sel = prot if demand == 2 else warn
                owners = self.inputs.owner[sel]
                obs = owners[owners >= 0]
                self._trigger = int(obs[0]) if obs.size else -2
        elif self.fields is not None:
            fs = self.fields.select(speed, direction, creep)
            v_max, p_len = fs.v_max, fs.protective_length
        stop_at = None if self.avoid is None else self.avoid.get("ranger_stop")
        if stop_at is not None and math.isfinite(self.inputs.ranger) and self.inputs.ranger < stop_at:
            demand = 2
            self._trigger = self._trigger if self._trigger != -1 else -3
        return demand, v_max, p_len

    def _inside(self, points: NDArray[np.float64], polygon: NDArray[np.float64]) -> NDArray[np.bool_]:
        """:func:`agvnav.reactive.intrusions`, testing only the points in the polygon's bounding box."""
        lo, hi = polygon.min(axis=0), polygon.max(axis=0)
        box = (points[:, 0] >= lo[0]) & (points[:, 0] <= hi[0]) & (points[:, 1] >= lo[1]) & (points[:, 1] <= hi[1])
        out = np.zeros(points.shape[0], dtype=bool)
        if box.any():
            out[box] = intrusions(points[box], polygon)
        return out

    def command(self, t: float, estimator: Any, plant: Any, dt: float) -> tuple[float, ...]:
        """Reaction, then avoidance, then the route's (or the detour's) autopilot; records the signals."""
        pilot: PathAutopilot = self.detour_pilot if self.detour_pilot is not None else self
        s_est = self._route_s()
        pose = estimator.pose
        direction = int(self.path.direction_at(min(max(s_est, 0.0), self.path.length)))
        cap = self._detour_cap()
        remaining = max(float(pilot.signals()[6]), 0.0)
        intended = abs(self.profile.cruise_speed) * min(self.rwatch.last_guard_scale, cap)
        intended = min(intended, math.sqrt(2.0 * self.normal_decel * remaining))
        speed = max(abs(self.profile.v), intended)
        demand, v_max, p_len = self._demand(speed, direction, creep=cap < 1.0)
        scale = self.reaction.update(t, demand)
        self.rwatch.reactive_scale = min(scale, cap)
        self.profile.max_decel = self.emergency_decel if self.reaction.level == 2 else self.normal_decel
        self._maybe_avoid(t, pose, s_est)
        pilot = self.detour_pilot if self.detour_pilot is not None else self
        out = PathAutopilot.command(self, t, estimator, plant, dt) if pilot is self else pilot.command(
            t, estimator, plant, dt)
        if pilot is not self:
            self.finished = pilot.finished
            self.failure = pilot.failure
        self._record(t, plant, v_max, p_len)
        return out

    def _detour_cap(self) -> float:
        """Speed fraction on a detour (the slow fraction until it rejoins the route), else 1."""
        if self.detour_pilot is None or self.detour is None:
            return 1.0
        if float(self.detour_pilot.signals()[3]) >= self.detour.length:
            return 1.0
        return float(self.reaction.limits.slow_speed_fraction)

    def _route_s(self) -> float:
        if self.detour_pilot is None:
            return float(self._sig[3])
        return float(self.detour.route_s(float(self.detour_pilot.signals()[3])))

    def _maybe_avoid(self, t: float, pose: Any, s_est: float) -> None:
        """Plan a detour around a *static* obstacle in a field (see the module docstring).

        Static: the centroid of the echoes off the map's walls (map frame, via the estimated pose)
        moved less than :data:`STATIC_TOLERANCE_M` over ``avoid_after_s`` while a field stayed intruded.
        """
        if self.avoid is None or self.avoid.get("segments") is None or self.detour_pilot is not None:
            return
        if self.reaction.level == 0 or self._trigger == -2 or not all(math.isfinite(float(v)) for v in pose[:3]):
            self._stopped_since, self._seen = None, None
            return
        pts = self._obstacle_points(pose)
        if pts.shape[0] == 0:
            return
        centroid = pts.mean(axis=0)
        if self._stopped_since is None or self._seen is None:
            self._stopped_since, self._seen = t, centroid
            return
        wait = float(self.avoid["after_s"])
        if t - self._stopped_since < wait - 1e-9 or t - self._last_try < wait - 1e-9:
            return
        moved = float(np.hypot(*(centroid - self._seen)))
        self._stopped_since, self._seen = t, centroid  # the next check compares with now
        if moved > STATIC_TOLERANCE_M:
            return
        self._last_try = t
        shape = scanned_obstacle(pts, float(pose[2]), ASSUMED_DEPTH_M)
        if shape is None:
            return
        a = self.avoid
        detour = plan_detour(
            self.path, s_est, [shape], self._footprint, a["left"], a["right"], a["clearance"], a["min_radius"],
            self.offset, allowed=a["segments"],
        )
        if detour is None:
            return
        self.detour = detour
        self.detours += 1
        self.follower.set_path(detour.path)
        self.follower.reset()
        self.detour_pilot = PathAutopilot(self.follower, detour.path, self.profile, self.plant_ref, self.offset,
                                          self.progress_window, self.end_tolerance, self.rwatch)
        self._detour_target = self._nearest_obstacle(shape)

    def _obstacle_points(self, pose: Any) -> NDArray[np.float64]:
        """Latest echoes (map frame, via the estimated pose) away from the map's walls, ahead of base_link and
        inside the selected warning field (the field that was intruded)."""
        pts = self.inputs.points
        if pts.shape[0] == 0:
            return pts
        ahead = pts[:, 0] > 0.0
        if self._field is not None:
            ahead &= self._inside(pts, self._field.warning)
        pts = pts[ahead]
        c, s = math.cos(float(pose[2])), math.sin(float(pose[2]))
        world = np.column_stack([pose[0] + c * pts[:, 0] - s * pts[:, 1], pose[1] + s * pts[:, 0] + c * pts[:, 1]])
        if self.walls.shape[0] and world.shape[0]:
            near_wall = np.array([segment_distances(p, self.walls).min() < WALL_TOLERANCE_M for p in world])
            world = world[~near_wall]
        return world

    def _nearest_obstacle(self, shape: Any) -> int:
        """Index of the true obstacle nearest the planned shape (for the metrics only), -1 none."""
        if not len(self.obstacles):
            return -1
        d = self.obstacles.distances(shape, self.rwatch_time)
        return int(np.argmin(d)) if d.min() < 0.5 else -1

    @property
    def rwatch_time(self) -> float:
        """Time of the latest scan (s)."""
        return self.inputs.t

    def _record(self, t: float, plant: Any, v_max: float, p_len: float) -> None:
        pose = np.asarray(plant.pose, dtype=np.float64)
        clear = self.obstacles.clearances(pose, self._footprint, t) if len(self.obstacles) else np.zeros(0)
        excess = self._corridor_excess(pose)
        target = float(getattr(self, "_detour_target", -1)) if self.detour_pilot is not None else -1.0
        self.rwatch.reactive_sig = (
            float(self.reaction.level), v_max, p_len, float(self._trigger), self.inputs.ranger,
            1.0 if self.detour_pilot is not None else 0.0, target, excess, *clear.tolist(),
        )
        if self.detour_pilot is not None:  # the series' s_est stays a route abscissa
            sig = list(self.detour_pilot.signals()[:7])
            sig[3] = self._route_s()
            self._sig = tuple(sig)

    def _corridor_excess(self, pose: NDArray[np.float64]) -> float:
        """How far (m) the body's corners reach beyond the corridor about the route (NaN without one)."""
        if self.avoid is None or (self.avoid["left"] <= 0.0 and self.avoid["right"] <= 0.0):
            return math.nan
        c, s = math.cos(pose[2]), math.sin(pose[2])
        fp = self._footprint
        corners = np.column_stack([pose[0] + c * fp[:, 0] - s * fp[:, 1], pose[1] + s * fp[:, 0] + c * fp[:, 1]])
        pr = self.path.project(corners, s_hint=np.full(len(corners), self._route_s()), window=3.0)
        lat = np.asarray(pr.lateral, dtype=np.float64)
        return float(max(0.0, float(lat.max()) - self.avoid["left"], -float(lat.min()) - self.avoid["right"]))

    def signals(self) -> tuple[float, ...]:
        """The route autopilot's signals (``s_est`` a route abscissa on a detour), the guard's, the reaction's."""
        return (*self._sig, *self.rwatch.signals())


def _min_radius(plant: Any) -> float:
    """Smallest arc radius the detour may use (m): 0.5 m, or the steered vehicle's at 80 % of its lock."""
    g = plant.geometry
    if hasattr(g, "max_steer"):
        return max(0.5, float(g.wheelbase) / math.tan(0.8 * float(g.max_steer)))
    return 0.5


def wire_reactive(sc: Any, world: WorldMap, plant: Any, sensors: list[Any], pilot: Any) -> tuple[Any, list[Any], Any]:
    """The loop's plant, sensors and autopilot with the scenario's obstacles, scanner and reaction.

    ``plant`` is the loop's plant (collision with walls already watched); ``pilot`` the route's
    :class:`PathAutopilot`. Returns them wrapped (see the module docstring).
    """
    if not isinstance(pilot, PathAutopilot):
        raise sc.error(("reactive",), "reactive control drives a path; missions are not supported yet")
    obstacles = ObstacleSet(tuple(obstacle_from_spec(o) for o in (sc.obstacles or [])))
    inputs = ReactiveInputs()
    out_sensors: list[Any] = []
    for s in sensors:
        if getattr(s, "name", "") == "reflections" and len(obstacles) and sc.goniometer is not None:
            g = sc.goniometer
            head = (g.mount[0], g.mount[1], math.radians(g.mount[2]))
            s = OccludedReflections(s, obstacles, world.reflector_xy, head)
        elif getattr(s, "name", "") == "ultrasonic":
            r = sc.reactive
            stop_sensor = r.ultrasonic_sensor if (r is not None and r.ultrasonic_stop_m is not None) else None
            if stop_sensor is not None and stop_sensor not in s.names:
                names = ", ".join(s.names)
                raise sc.error(("reactive", "ultrasonic_sensor"), f"no ranger {stop_sensor!r} (have {names})")
            s = ObstacleRangers(s, obstacles, inputs, stop_sensor)
        out_sensors.append(s)
    footprint = np.asarray(plant.footprint, dtype=np.float64)
    if sc.scanner is not None:
        sp = sc.scanner
        mount = (float(footprint[:, 0].max()), 0.0, 0.0) if sp.mount is None else (
            sp.mount[0], sp.mount[1], math.radians(sp.mount[2]))
        scanner = SafetyScanner(mount, math.radians(sp.fov_deg), math.radians(sp.step_deg), sp.max_range_m,
                                sp.noise_std_m, sp.rate_hz)
        out_sensors.append(ScannerRole(scanner, world.wall_segments, obstacles, inputs))
    r = sc.reactive
    tc = sc.traction
    decel = tc.max_decel_m_s2 if r is None or r.emergency_decel_m_s2 is None else r.emergency_decel_m_s2
    fields = None
    if sc.scanner is not None and r is not None:
        reverse = any(seg.direction < 0 for seg in pilot.path.segments)
        creep = r.slow_speed_fraction * tc.speed_m_s if r.detour_fields == "creep" else None
        fields = generate_fields(footprint, tc.speed_m_s, decel, r.reaction_time_s, r.margin_m, r.lateral_margin_m,
                                 r.warning_time_s, r.speed_bands, reverse, r.protective_length_m, r.warning_length_m,
                                 r.approach_speed_m_s, creep)
    limits = ReactionLimits(r.slow_speed_fraction, r.resume_after_s) if r is not None else ReactionLimits()
    reaction = Reaction(limits, enabled=r is not None and r.enabled)
    avoid = None
    if r is not None:
        segments = r.avoid_segments
        allowed: list[int] | None
        if segments == "all":
            allowed = list(range(len(pilot.path.segments)))
        else:
            allowed = list(segments)
            n = len(pilot.path.segments)
            bad = [i for i in allowed if i >= n]
            if bad:
                raise sc.error(("reactive", "avoid_segments"), f"the path has {n} segments; no segment {bad[0]}")
        avoid = {
            "segments": allowed if allowed else None, "left": r.corridor_left_m, "right": r.corridor_right_m,
            "clearance": r.avoid_clearance_m, "min_radius": _min_radius(plant), "after_s": r.avoid_after_s,
            "ranger_stop": r.ultrasonic_stop_m,
        }
        if allowed and r.corridor_left_m <= 0.0 and r.corridor_right_m <= 0.0:
            raise sc.error(("reactive", "corridor_left_m"), "avoidance needs a corridor: give corridor_left_m/right_m")
    watch = ReactiveWatch(pilot.watch, obstacles.ids)
    new_pilot = ReactiveAutopilot(pilot, plant, watch, fields, reaction, inputs, obstacles, world.wall_segments,
                                  decel, avoid)
    loop_plant = ObstacleCollisionWatch(plant, obstacles) if len(obstacles) else plant
    return loop_plant, out_sensors, new_pilot


def reactive_figures(series: dict[str, NDArray[np.float64]], obstacle_ids: Sequence[str],
                     failure: str | None, collided: int = -1) -> dict[str, Any]:
    """Figures of a run from its recorded signals (see the module docstring).

    ``collided``: index of the obstacle a collision was with (-1 none or a wall).
    """
    t = series["t"]
    level = series["reaction_level"]
    dt = np.diff(t, prepend=t[0])
    stops = int(np.sum((level[1:] >= 2.0) & (level[:-1] < 2.0)) + (1 if level.size and level[0] >= 2.0 else 0))
    time_stopped = float(np.sum(dt[level >= 2.0]))
    trig = series["field_trigger"]
    avoiding = series["avoiding"] > 0.5
    target = series["detour_target"]
    per: dict[str, dict[str, Any]] = {}
    for i, oid in enumerate(obstacle_ids):
        clearance = series[f"clearance__{oid}"]
        finite = clearance[np.isfinite(clearance)]
        min_c = float(finite.min()) if finite.size else math.nan
        if failure == "collision" and collided == i:
            result = "collision"
        elif np.any(avoiding & (target == i)):
            result = "avoid"
        elif np.any((level >= 2.0) & (trig == i)):
            result = "stop"
        elif np.any((level >= 1.0) & (trig == i)):
            result = "slow"
        else:
            result = "none"
        per[oid] = {"min_clearance_m": min_c, "result": result}
    excess = series["corridor_excess"]
    fin = excess[np.isfinite(excess)]
    return {
        "stops": stops,
        "time_stopped_s": time_stopped,
        "detours": int(np.sum(np.diff(avoiding.astype(np.int64), prepend=0) > 0)),
        "max_corridor_excess_m": float(fin.max()) if fin.size else math.nan,
        "obstacles": per,
    }
