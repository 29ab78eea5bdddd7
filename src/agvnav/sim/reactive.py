"""Wiring of the reactive control (issue 18): obstacles, the safety scanner, the reaction, avoidance.

Roles only; the parts live in :mod:`agvnav.world.obstacles`, :mod:`agvnav.sensors.scanner`
and :mod:`agvnav.reactive`, and what the vehicle runs (the reactive autopilot and its watch)
in :mod:`agvnav.navigation.reactive`:

* :class:`ScannerRole`: the safety scanner as a closed-loop sensor, scanning the walls and
  the obstacles (at each scan's instant) along the true motion; the latest scan is kept in a
  :class:`~agvnav.navigation.reactive.ReactiveInputs` for the autopilot (positioning never reads it);
* :class:`OccludedReflections`: the goniometer role with reflections whose line of sight an
  obstacle cuts at that instant removed (obstacles occlude the beam like walls);
* :class:`ObstacleRangers`: the ultrasonic role echoing off obstacle faces as well as walls,
  keeping the reading of the stopping ranger for the reaction (the seed-004 rangers as a
  simple reactive sensor; the robot's HY-SRF05 rangers serve "to avoid obstacles" [seed004 §II]);
* :class:`ObstacleCollisionWatch`: the plant's failure is also ``collision`` when the footprint
  at the true pose touches an obstacle at that instant;
* :func:`wire_reactive`: the route's :class:`~agvnav.navigation.path.PathAutopilot` becomes a
  :class:`~agvnav.navigation.reactive.ReactiveAutopilot`.

:func:`reactive_figures` turns the recorded signals into the run's figures: stops, time stopped,
minimum clearance and encounter result (``collision``, ``avoid``, ``stop``, ``slow``, ``none``)
per obstacle, the largest excursion of the body beyond the corridor.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Polygon

from agvnav.navigation.path import PathAutopilot
from agvnav.navigation.reactive import AvoidParams, ReactiveAutopilot, ReactiveInputs, ReactiveWatch
from agvnav.reactive import FieldConfig, Reaction, ReactionLimits, generate_fields
from agvnav.roles import Plant, PoseFunction, Sensor
from agvnav.sensors.scanner import SafetyScanner
from agvnav.sim.rangers import UltrasonicSensorRole
from agvnav.sim.wrapped import WrappedPlant
from agvnav.vehicles import SteeredGeometry
from agvnav.world import WorldMap
from agvnav.world.obstacles import ObstacleSet, obstacle_from_spec
from agvnav.world.scenario import Scenario

if TYPE_CHECKING:  # a mission autopilot is refused here; its module is imported for mission scenarios only
    from agvnav.navigation.mission import MissionAutopilot

__all__ = [
    "ObstacleCollisionWatch",
    "ObstacleRangers",
    "OccludedReflections",
    "ScannerRole",
    "interpreted_scans_s",
    "reactive_figures",
    "wire_reactive",
]

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

    def observe(self, pose_at: PoseFunction, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
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

    def deliver(self, event: NDArray[np.float64]) -> None:
        """Nothing: positioning does not use the safety scanner."""


class OccludedReflections:
    """A goniometer role whose reflections are dropped when an obstacle cuts the line of sight then."""

    def __init__(self, inner: Sensor, obstacles: ObstacleSet, reflector_xy: NDArray[np.float64],
                 mount: tuple[float, float, float]) -> None:
        self.inner = inner
        self.name = inner.name
        self.event_names = inner.event_names
        self.obstacles = obstacles
        self.reflector_xy = np.asarray(reflector_xy, dtype=np.float64)
        self.mount = np.asarray(mount, dtype=np.float64)
        self.deliver = inner.deliver
        self.n_occluded = 0

    def observe(self, pose_at: PoseFunction, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """The inner role's rows without those an obstacle hides (column 2: the true reflector index)."""
        ev = self.inner.observe(pose_at, t0, t1, rng)
        if ev.shape[0] == 0:
            return ev
        keep = np.ones(ev.shape[0], dtype=bool)
        real = np.flatnonzero(ev[:, 2] >= 0)  # spurious reflections (index -1) have no line of sight
        if real.size:
            t = np.ascontiguousarray(ev[real, 0])
            pose = np.asarray(pose_at(t), dtype=np.float64).reshape(-1, 3)
            c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
            mx, my = float(self.mount[0]), float(self.mount[1])  # the head in the map frame (compose, x and y)
            heads = np.column_stack([pose[:, 0] + c * mx - s * my, pose[:, 1] + s * mx + c * my])
            target = self.reflector_xy[ev[real, 2].astype(np.int64)]
            keep[real] = ~self.obstacles.blocked(heads, target, t)
        self.n_occluded += int((~keep).sum())
        return ev[keep]


class ObstacleRangers:
    """An ultrasonic role echoing off obstacles too; keeps the stopping ranger's last reading in the inputs.

    The obstacle faces of the window's mid-instant join the wall segments (a cylinder as a
    32-gon inscribed in it) before the inner role casts its cones.
    """

    def __init__(self, inner: UltrasonicSensorRole, obstacles: ObstacleSet, inputs: ReactiveInputs,
                 stop_sensor: str | None) -> None:
        self.inner = inner
        self.name = inner.name
        self.event_names = inner.event_names
        self.walls = np.asarray(inner.segments, dtype=np.float64)
        self.obstacles = obstacles
        self.inputs = inputs
        self.column = None if stop_sensor is None else 1 + list(inner.names).index(stop_sensor)
        self.deliver = inner.deliver

    def observe(self, pose_at: PoseFunction, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
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


class ObstacleCollisionWatch(WrappedPlant):
    """The plant's failure, else ``collision`` when its footprint at the true pose touches an obstacle now.

    ``hit`` names the obstacle index of a collision. Other role methods are the plant's
    (:class:`~agvnav.sim.wrapped.WrappedPlant`).
    """

    def __init__(self, plant: Plant, obstacles: ObstacleSet) -> None:
        super().__init__(plant)
        self.obstacles = obstacles
        self._body = np.asarray(plant.footprint, dtype=np.float64)
        self.radius = float(np.max(np.hypot(self._body[:, 0], self._body[:, 1])))
        self.odometry = plant.odometry
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
            body = body or _placed(self._body, pose)
            if ob.distance(body, self.t) <= 0.0:
                self.hit = i
                return "collision"
        return None


def interpreted_scans_s(sensors: Sequence[Sensor], sim_seconds: float) -> float:
    """Extra CPU (s) the safety scanners among ``sensors`` cost over ``sim_seconds`` (s) with the kernels run as
    plain Python (:meth:`~agvnav.sensors.scanner.SafetyScanner.interpreted_cost_s`, against the walls and the
    obstacles' edges), for :func:`agvnav.jit.set_compiled_for_run`."""
    return sum(s.scanner.interpreted_cost_s(sim_seconds, s.walls.shape[0] + 4 * len(s.obstacles))
               for s in sensors if isinstance(s, ScannerRole))


def _placed(footprint: NDArray[np.float64], pose: NDArray[np.float64]) -> Polygon:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return Polygon(np.column_stack([pose[0] + c * footprint[:, 0] - s * footprint[:, 1],
                                    pose[1] + s * footprint[:, 0] + c * footprint[:, 1]]))


def _min_radius(plant: Plant) -> float:
    """Smallest arc radius the detour may use (m): 0.5 m, or the steered vehicle's at 80 % of its lock."""
    g = plant.geometry
    if isinstance(g, SteeredGeometry):
        return max(0.5, float(g.wheelbase) / math.tan(0.8 * float(g.max_steer)))
    return 0.5


def wire_reactive(
    sc: Scenario, world: WorldMap, plant: Plant, sensors: list[Sensor], pilot: PathAutopilot | MissionAutopilot
) -> tuple[Plant, list[Sensor], PathAutopilot | MissionAutopilot]:
    """The loop's plant, sensors and autopilot with the scenario's obstacles, scanner and reaction.

    ``plant`` is the loop's plant (collision with walls already watched); ``pilot`` the route's
    :class:`PathAutopilot`, or a mission's autopilot, each of whose stints then reacts to the fields
    (:func:`_wire_mission`; no avoidance on a mission). Returns them wrapped (see the module docstring).
    """
    if not isinstance(pilot, PathAutopilot):
        return _wire_mission(sc, world, plant, sensors, pilot)
    if pilot.watch is None:
        raise ValueError("the reactive autopilot composes the reaction with the positioning guard: wire a watch")
    obstacles = ObstacleSet(tuple(obstacle_from_spec(o) for o in (sc.obstacles or [])))
    inputs = ReactiveInputs()
    out_sensors = _reactive_sensors(sc, world, plant, sensors, obstacles, inputs)
    r = sc.reactive
    decel = _emergency_decel(sc)
    fields = _fields(sc, plant, any(seg.direction < 0 for seg in pilot.path.segments))
    reaction = _reaction(sc)
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
        avoid = AvoidParams(
            segments=allowed if allowed else None, left=r.corridor_left_m, right=r.corridor_right_m,
            clearance=r.avoid_clearance_m, min_radius=_min_radius(plant), after_s=r.avoid_after_s,
            ranger_stop=r.ultrasonic_stop_m,
        )
        if allowed and r.corridor_left_m <= 0.0 and r.corridor_right_m <= 0.0:
            raise sc.error(("reactive", "corridor_left_m"), "avoidance needs a corridor: give corridor_left_m/right_m")
    watch = ReactiveWatch(pilot.watch, obstacles.ids)
    new_pilot = ReactiveAutopilot(pilot, watch, fields, reaction, inputs, obstacles, world.wall_segments,
                                  decel, avoid)
    loop_plant: Plant = ObstacleCollisionWatch(plant, obstacles) if len(obstacles) else plant
    return loop_plant, out_sensors, new_pilot


def _reactive_sensors(sc: Scenario, world: WorldMap, plant: Plant, sensors: list[Sensor], obstacles: ObstacleSet,
                      inputs: ReactiveInputs) -> list[Sensor]:
    """The loop's sensors seeing the obstacles (goniometer occluded, rangers echoing), and the safety scanner."""
    out_sensors: list[Sensor] = []
    for s in sensors:
        if s.name == "reflections" and len(obstacles) and sc.goniometer is not None:
            g = sc.goniometer
            head = (g.mount[0], g.mount[1], math.radians(g.mount[2]))
            s = OccludedReflections(s, obstacles, world.reflector_xy, head)
        elif isinstance(s, UltrasonicSensorRole):
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
    return out_sensors


def _emergency_decel(sc: Scenario) -> float:
    r = sc.reactive
    return float(sc.traction.max_decel_m_s2 if r is None or r.emergency_decel_m_s2 is None
                 else r.emergency_decel_m_s2)


def _fields(sc: Scenario, plant: Plant, reverse: bool) -> FieldConfig | None:
    """The protective and warning fields of the scenario's reaction (None without a scanner or a reaction)."""
    r, tc = sc.reactive, sc.traction
    if sc.scanner is None or r is None:
        return None
    footprint = np.asarray(plant.footprint, dtype=np.float64)
    creep = r.slow_speed_fraction * tc.speed_m_s if r.detour_fields == "creep" else None
    return generate_fields(footprint, tc.speed_m_s, _emergency_decel(sc), r.reaction_time_s, r.margin_m,
                           r.lateral_margin_m, r.warning_time_s, r.speed_bands, reverse, r.protective_length_m,
                           r.warning_length_m, r.approach_speed_m_s, creep)


def _reaction(sc: Scenario) -> Reaction:
    r = sc.reactive
    limits = ReactionLimits(r.slow_speed_fraction, r.resume_after_s) if r is not None else ReactionLimits()
    return Reaction(limits, enabled=r is not None and r.enabled)


def _wire_mission(sc: Scenario, world: WorldMap, plant: Plant, sensors: list[Sensor], pilot: MissionAutopilot
                  ) -> tuple[Plant, list[Sensor], MissionAutopilot]:
    """A mission vehicle with its obstacles, scanner and fields: every stint's PathAutopilot becomes a
    :class:`ReactiveAutopilot` sharing one reaction, one watch and the scanner's inputs (so a stop or a slow-down
    carries over a stint's end); no local avoidance (a detour plans on one path, a mission drives many)."""
    r = sc.reactive
    if r is not None and (r.avoid_segments == "all" or len(r.avoid_segments)):
        raise sc.error(("reactive", "avoid_segments"), "local avoidance drives a path; a mission vehicle stops or "
                                                       "slows for an obstacle (give no avoid_segments)")
    obstacles = ObstacleSet(tuple(obstacle_from_spec(o) for o in (sc.obstacles or [])))
    inputs = ReactiveInputs()
    out_sensors = _reactive_sensors(sc, world, plant, sensors, obstacles, inputs)
    decel = _emergency_decel(sc)
    fields = _fields(sc, plant, any(seg.direction < 0 for seg in pilot.plan.path.segments))
    reaction = _reaction(sc)
    normal_decel = float(sc.traction.max_decel_m_s2)
    shared: list[ReactiveWatch] = []

    def react(stint: PathAutopilot) -> PathAutopilot:
        if stint.watch is None:
            raise ValueError("the reactive autopilot composes the reaction with the positioning guard: wire a watch")
        if not shared:
            shared.append(ReactiveWatch(stint.watch, obstacles.ids))
        stint.profile.max_decel = normal_decel  # a stint may begin during an emergency stop
        return ReactiveAutopilot(stint, shared[0], fields, reaction, inputs, obstacles, world.wall_segments, decel,
                                 None)

    pilot.wrap_stints(react)
    loop_plant: Plant = ObstacleCollisionWatch(plant, obstacles) if len(obstacles) else plant
    return loop_plant, out_sensors, pilot


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
