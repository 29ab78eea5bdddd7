"""A fleet in one world (issue 28): every vehicle's closed loop, stepped in lockstep.

:func:`build_fleet` builds each vehicle of a :class:`~agvnav.world.fleet.FleetScenario` exactly
as a single run builds it (:func:`agvnav.sim.build.build` of the vehicle's own scenario), then
makes the vehicles physical to one another: each vehicle's body is a moving obstacle
(:class:`VehicleBody`) in every other vehicle's obstacle set, so it cuts their goniometer's line
of sight (:class:`~agvnav.sim.reactive.OccludedReflections`), shows on their safety scanner and
ultrasonic rangers (:class:`~agvnav.sim.reactive.ScannerRole`, :class:`~agvnav.sim.reactive.ObstacleRangers`).
The cross-vehicle checks happen here, as :class:`~agvnav.world.scenario.ScenarioError` naming file,
line and key: two start footprints overlapping, a start pose off every node of the mission's
network, more mission vehicles on a network than it has stations.

:func:`run_fleet` steps the loops in lockstep with the engine's step-wise API: every plant
advances over ``(t, t + dt]`` first (:meth:`~agvnav.sim.engine.ClosedLoop.advance`), then every
vehicle's sensors, estimator and autopilot run (:meth:`~agvnav.sim.engine.ClosedLoop.sense`), so a
sensor sees the other vehicles where they truly are at each instant of the window. After the
step the footprints are compared on the true poses: a contact is a collision that ends the fleet
run as ``failed: collision`` naming both vehicles and the time. A vehicle whose own run ends (its
mission done, or failed: lost positioning, a wall) stops and stays where it stands as an obstacle;
the others go on. The per-vehicle results are those of a single run (:func:`agvnav.sim.run.result_of`);
the fleet's figures (:func:`fleet_figures`) summarise them: jobs completed, deliveries per hour,
time each vehicle spent slowed or stopped and why, minimum separation (footprint to footprint),
collisions. A fleet of one is the single-vehicle run, bit for bit.

This is the per-vehicle engine stepped in lockstep; the batch-kernel engine of issue 28 replaces
the stepping, not the scenario format, the results or their tests.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import Polygon

from agvnav.geometry import wrap_angle_scalar
from agvnav.sim.build import Built, build
from agvnav.sim.mission import load_mission_network
from agvnav.sim.rangers import UltrasonicSensorRole
from agvnav.sim.reactive import ObstacleRangers, OccludedReflections, ReactiveInputs, ScannerRole
from agvnav.sim.roles import GoniometerSensor
from agvnav.sim.run import SimResult, result_of
from agvnav.world.fleet import FleetScenario
from agvnav.world.obstacles import Obstacle, ObstacleSet, obstacle_from_spec
from agvnav.world.scenario import Scenario, ScenarioError

__all__ = [
    "EXACT_WITHIN_M",
    "BuiltFleet",
    "FleetResult",
    "VehicleBody",
    "build_fleet",
    "fleet_figures",
    "run_fleet",
    "simulate_fleet",
]

#: Separations are computed exactly (polygons) when the bounding circles come within this (m).
EXACT_WITHIN_M = 2.0
#: A start pose lies on a node when within this distance (m) and the node's heading tolerance.
START_ON_NODE_M = 0.1


@dataclass
class _Track:
    """Where a body is over the current step: base_link at the step's start and end (m)."""

    t0: float = 0.0
    t1: float = 0.0
    p0: tuple[float, float] = (0.0, 0.0)
    p1: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class VehicleBody(Obstacle):
    """Another vehicle as a moving obstacle: its footprint at its true pose (the plant's ``pose_at``).

    ``centre_at`` (the bounding-circle test of the sensors) interpolates base_link over the current
    step (:class:`_Track`, kept by the fleet loop); the exact geometry (``corners_at``) places the
    footprint's bounding box (the footprint itself for a box body) at the plant's true pose.
    """

    plant: Any = field(default=None, compare=False, repr=False)
    box: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    """x_min, x_max, y_min, y_max of the footprint in base_link (m)."""
    track: _Track = field(default_factory=_Track, compare=False, repr=False)

    @property
    def static(self) -> bool:
        """A vehicle moves."""
        return False

    @property
    def radius(self) -> float:
        """Bounding radius about base_link (m), with 1 cm for the interpolation of :meth:`centre_at`."""
        x0, x1, y0, y1 = self.box
        return max(math.hypot(x, y) for x in (x0, x1) for y in (y0, y1)) + 0.01

    def present(self, t: float) -> bool:
        """Always there."""
        return True

    def pose_at(self, t: ArrayLike) -> NDArray[np.float64]:
        """True base_link pose ``(..., 3)`` at ``t`` (inside the current step; clipped to it)."""
        tt = np.asarray(t, dtype=np.float64)
        return np.asarray(self.plant.pose_at(tt.reshape(-1)), dtype=np.float64).reshape(*tt.shape, 3)

    def centre_at(self, t: float) -> tuple[float, float]:
        """base_link ``(x, y)`` (m) at ``t``, linear over the current step."""
        tr = self.track
        span = tr.t1 - tr.t0
        u = 1.0 if span <= 0.0 else min(max((t - tr.t0) / span, 0.0), 1.0)
        return (tr.p0[0] + u * (tr.p1[0] - tr.p0[0]), tr.p0[1] + u * (tr.p1[1] - tr.p0[1]))

    def corners_at(self, t: float) -> NDArray[np.float64]:
        """The body's box corners ``(4, 2)`` (m) at the true pose at ``t``, counter-clockwise."""
        x, y, h = (float(v) for v in self.plant.pose_at(np.array([t], dtype=np.float64))[0])
        x0, x1, y0, y1 = self.box
        local = np.array([[x1, y1], [x0, y1], [x0, y0], [x1, y0]])
        c, s = math.cos(h), math.sin(h)
        return np.column_stack([x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]])


def _body(vid: str, plant: Any) -> VehicleBody:
    fp = np.asarray(plant.footprint, dtype=np.float64)
    box = (float(fp[:, 0].min()), float(fp[:, 0].max()), float(fp[:, 1].min()), float(fp[:, 1].max()))
    pose = np.asarray(plant.pose, dtype=np.float64)
    body = VehicleBody(vid, "box", (box[1] - box[0], box[3] - box[2]), pose[None, :2].copy(), plant=plant, box=box)
    body.track.p0 = body.track.p1 = (float(pose[0]), float(pose[1]))
    return body


def _placed(plant: Any) -> Polygon:
    """The footprint at the plant's true pose now."""
    fp = np.asarray(plant.footprint, dtype=np.float64)
    x, y, h = (float(v) for v in np.asarray(plant.pose, dtype=np.float64)[:3])
    c, s = math.cos(h), math.sin(h)
    return Polygon(np.column_stack([x + c * fp[:, 0] - s * fp[:, 1], y + s * fp[:, 0] + c * fp[:, 1]]))


@dataclass
class BuiltFleet:
    """The wired vehicles of a fleet run, in the order of ``fleet.vehicles``."""

    fleet: FleetScenario
    ids: list[str]
    scenarios: list[Scenario]
    built: list[Built]
    bodies: list[VehicleBody]
    duration: float
    n_obstacles: int
    """obstacles of the scenario itself in each vehicle's set (the other vehicles' bodies come after them)."""
    seen: list[_Seen]
    """per vehicle, its sensors holding obstacle sets and their reach."""


def _apply_at(fleet: FleetScenario, i: int, sc: Scenario) -> Scenario:
    """Vehicle ``i``'s scenario with its ``at`` start: a node id, or a pose that must lie on a node of its network."""
    at = fleet.fleet.vehicles[i].at
    if at is None or sc.mission is None:
        return sc
    key = ("fleet", "vehicles", i, "at")
    if isinstance(at, str):
        node = at
    else:
        net = load_mission_network(sc)
        x, y, h = float(at[0]), float(at[1]), math.radians(float(at[2]))
        tol = math.radians(net.spec.tolerances.heading_deg)
        best, dist = None, math.inf
        for n in net.nodes.values():
            d = math.hypot(n.x - x, n.y - y)
            if d < dist:
                best, dist = n, d
        assert best is not None
        heading_ok = best.heading is None or abs(wrap_angle_scalar(best.heading - h)) <= tol + 1e-9
        if dist > START_ON_NODE_M or not heading_ok:
            raise fleet.error(key, f"vehicle {fleet.ids[i]!r} starts off every route of its mission: the nearest "
                                   f"node of {net.name!r} is {best.id} ({dist:.2f} m away"
                                   f"{'' if heading_ok else ', another heading'}); start on a node")
        node = best.id
    mission = sc.mission.model_copy(update={"start": node})
    return sc.copy_attached({"mission": mission})


def build_fleet(fleet: FleetScenario) -> BuiltFleet:
    """Build every vehicle (errors located in the fleet file) and check the fleet (module docstring)."""
    ids = fleet.ids
    scenarios: list[Scenario] = []
    built: list[Built] = []
    own = [_apply_at(fleet, i, sc) for i, sc in enumerate(fleet.vehicle_scenarios())]
    _check_stations(fleet, own)
    for i, sc in enumerate(own):
        try:
            b = build(sc)
        except ScenarioError as exc:
            if exc.key and exc.key[:2] == ("mission", "start") and fleet.fleet.vehicles[i].at is not None:
                raise fleet.error(("fleet", "vehicles", i, "at"), f"vehicle {ids[i]!r}: {exc.detail}") from None
            raise fleet.relocate(i, exc) from None
        scenarios.append(sc)
        built.append(b)
    _check_overlaps(fleet, built)
    bodies = [_body(vid, b.plant) for vid, b in zip(ids, built, strict=True)]
    n_obs = len(fleet.obstacles or [])
    seen = [_wire_others(b, scenarios[i], [bodies[j] for j in range(len(bodies)) if j != i])
            for i, b in enumerate(built)]
    duration = float(fleet.duration_s) if fleet.duration_s is not None else max(b.duration for b in built)
    return BuiltFleet(fleet, ids, scenarios, built, bodies, duration, n_obs, seen)


def _check_stations(fleet: FleetScenario, scenarios: list[Scenario]) -> None:
    """More mission vehicles on one network than its stations can hold: refused."""
    per_net: dict[str, list[int]] = {}
    for i, sc in enumerate(scenarios):
        if sc.mission is not None:
            per_net.setdefault(sc.mission.network, []).append(i)
    for name, members in per_net.items():
        net = load_mission_network(scenarios[members[0]])
        stations = net.stations
        if len(members) > len(stations):
            raise fleet.error(("fleet", "vehicles"), f"{len(members)} vehicles on network {name!r}, which has only "
                                                     f"{len(stations)} stations to hold them")


def _check_overlaps(fleet: FleetScenario, built: list[Built]) -> None:
    """Two vehicles whose start footprints overlap (or touch): refused, naming both."""
    shapes = [_placed(b.plant) for b in built]
    for j in range(len(shapes)):
        for i in range(j):
            if shapes[i].intersects(shapes[j]):
                raise fleet.error(("fleet", "vehicles", j), f"vehicle {fleet.ids[j]!r} starts overlapping vehicle "
                                                            f"{fleet.ids[i]!r}: their start footprints touch")


@dataclass
class _Seen:
    """What one vehicle's sensors may see of the others: its own scenario's obstacles, then the bodies
    within each sensor's reach (updated every step, :func:`_cull`)."""

    own: tuple[Obstacle, ...]
    roles: list[tuple[Any, float]]
    """(role holding an ``obstacles`` set, its reach in m)."""


def _wire_others(b: Built, sc: Scenario, others: list[VehicleBody]) -> _Seen:
    """Make the other vehicles' bodies obstacles to this vehicle's goniometer, scanner and rangers."""
    own = tuple(obstacle_from_spec(o) for o in (sc.obstacles or []))
    obstacles = ObstacleSet((*own, *others))
    sensors = list(b.loop.sensors)
    g = sc.goniometer
    reach = {"reflections": g.max_range_m if g is not None else math.inf,
             "scanner": sc.scanner.max_range_m if sc.scanner is not None else math.inf,
             "ultrasonic": sc.ultrasonic.max_range_m if sc.ultrasonic is not None else math.inf}
    for k, s in enumerate(sensors):
        if isinstance(s, (OccludedReflections, ScannerRole, ObstacleRangers)):
            s.obstacles = obstacles
        elif isinstance(s, GoniometerSensor) and g is not None:
            sensors[k] = OccludedReflections(s, obstacles, b.world.reflector_xy,
                                             (g.mount[0], g.mount[1], math.radians(g.mount[2])))
        elif isinstance(s, UltrasonicSensorRole):
            sensors[k] = ObstacleRangers(s, obstacles, ReactiveInputs(), None)
    b.loop.sensors = sensors
    roles = [(s, reach.get(getattr(s, "name", ""), math.inf)) for s in sensors if hasattr(s, "obstacles")]
    return _Seen(own, roles)


#: Margin (m) added to a sensor's reach when the bodies it may see are chosen for a step.
CULL_MARGIN_M = 2.0


def _cull(bf: BuiltFleet, active: list[int]) -> None:
    """Give each active vehicle's sensors only the bodies within their reach (plus margins) this step."""
    xy = np.array([body.track.p1 for body in bf.bodies], dtype=np.float64)
    r = np.array([body.radius for body in bf.bodies])
    d = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1]) - r[:, None] - r[None, :]
    for i in active:
        seen = bf.seen[i]
        for role, reach in seen.roles:
            near = np.flatnonzero(d[i] <= reach + CULL_MARGIN_M)
            role.obstacles = ObstacleSet((*seen.own, *(bf.bodies[j] for j in near.tolist() if j != i)))


@dataclass
class FleetResult:
    """A fleet run: each vehicle's result (as a single run's), the fleet's figures, outcome."""

    fleet: FleetScenario
    ids: list[str]
    results: list[SimResult]
    figures: dict[str, Any]
    vehicles: list[dict[str, Any]]
    outcome: str
    reason: str | None
    collisions: list[dict[str, Any]] = field(default_factory=list)

    @property
    def completed(self) -> bool:
        """True when every vehicle completed and nothing collided."""
        return self.outcome == "completed"


@dataclass
class _Separation:
    """Smallest footprint-to-footprint distance seen, per vehicle and for the fleet."""

    per_vehicle: NDArray[np.float64]
    nearest: list[str]
    fleet: float = math.inf
    pair: tuple[str, str] | None = None
    t: float = math.nan


def run_fleet(bf: BuiltFleet, progress: Callable[[float], None] | None = None) -> FleetResult:
    """Step every vehicle's loop in lockstep until all have ended or two collide (module docstring)."""
    loops = [b.loop for b in bf.built]
    n = len(loops)
    for sc, loop in zip(bf.scenarios, loops, strict=True):
        loop.start(bf.duration, sc.end_hold_s)
    dt = float(bf.built[0].loop.dt)
    every = max(1, math.ceil(bf.duration / dt) // 100)
    sep = _Separation(np.full(n, math.inf), [""] * n)
    collisions: list[dict[str, Any]] = []
    ended_at = [math.nan] * n
    cpu0, wall0 = time.process_time(), time.perf_counter()
    steps = 0
    vehicle_steps = 0
    t = 0.0
    while any(loop.running for loop in loops):
        active = [i for i in range(n) if loops[i].running]
        t1 = (steps + 1) * dt
        for i in active:
            loops[i].advance()
        for i, body in enumerate(bf.bodies):
            tr = body.track
            tr.t0, tr.t1, tr.p0 = t, t1, tr.p1
            if i in active:
                p = body.plant.pose
                tr.p1 = (float(p[0]), float(p[1]))
        _cull(bf, active)
        for i in active:
            if not loops[i].sense():
                ended_at[i] = t1
        vehicle_steps += len(active)
        steps += 1
        t = t1
        hit = _separations(bf, sep, t)
        if hit is not None:
            a, b = hit
            collisions.append({"vehicles": [bf.ids[a], bf.ids[b]], "t_s": t})
            for i in range(n):
                if loops[i].running:
                    loops[i].stop("collision" if i in (a, b) else "fleet_stopped")
                    ended_at[i] = t
        if progress is not None and steps % every == 0:
            progress(t)
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    outputs = [loop.finish() for loop in loops]
    results = []
    for sc, vb, out in zip(bf.scenarios, bf.built, outputs, strict=True):
        out.wall_time_s = wall
        results.append(result_of(sc, vb, out))
    vehicles = [_vehicle_figures(bf, i, results[i], sep, collisions) for i in range(n)]
    figures = fleet_figures(vehicles, collisions, sep, t)
    figures.update(steps=steps, vehicle_steps=vehicle_steps, cpu_time_s=cpu, wall_time_s=wall,
                   real_time_factor_cpu=t / cpu if cpu > 0 else math.inf,
                   us_per_vehicle_step=1e6 * cpu / vehicle_steps if vehicle_steps else math.nan)
    reason: str | None
    if collisions:
        c = collisions[0]
        outcome, reason = "failed", f"collision of {c['vehicles'][0]} and {c['vehicles'][1]} at {c['t_s']:.2f} s"
    else:
        failed = [v for v in vehicles if v["outcome"] != "completed"]
        outcome = "failed" if failed else "completed"
        reason = None if not failed else "; ".join(f"{v['id']}: {v['reason']}" for v in failed)
    if progress is not None:
        progress(t)
    return FleetResult(bf.fleet, bf.ids, results, figures, vehicles, outcome, reason, collisions)


def _separations(bf: BuiltFleet, sep: _Separation, t: float) -> tuple[int, int] | None:
    """Update the smallest separations at ``t`` (true poses); the first pair in contact, if any."""
    n = len(bf.bodies)
    if n < 2:
        return None
    plants = [b.plant for b in bf.built]
    xy = np.array([[float(p.pose[0]), float(p.pose[1])] for p in plants])
    r = np.array([body.radius - 0.01 for body in bf.bodies])
    d = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1]) - r[:, None] - r[None, :]
    np.fill_diagonal(d, math.inf)
    near = np.argwhere(np.triu(d <= EXACT_WITHIN_M, 1))
    shapes: dict[int, Polygon] = {}
    hit = None
    for a, b in near.tolist():
        sa = shapes.setdefault(a, _placed(plants[a]))
        sb = shapes.setdefault(b, _placed(plants[b]))
        exact = float(sa.distance(sb))
        d[a, b] = d[b, a] = exact
        if exact <= 0.0 and hit is None:
            hit = (a, b)
    d = np.maximum(d, 0.0)
    j = np.argmin(d, axis=1)
    best = d[np.arange(n), j]
    better = best < sep.per_vehicle
    for i in np.flatnonzero(better).tolist():
        sep.per_vehicle[i] = best[i]
        sep.nearest[i] = bf.ids[int(j[i])]
    k = int(np.argmin(best))
    if best[k] < sep.fleet:
        sep.fleet, sep.pair, sep.t = float(best[k]), (bf.ids[k], bf.ids[int(j[k])]), t
    return hit


def _vehicle_figures(bf: BuiltFleet, i: int, result: SimResult, sep: _Separation,
                     collisions: list[dict[str, Any]]) -> dict[str, Any]:
    """One vehicle's row: outcome, jobs, slowed/stopped and why, separation."""
    s = result.series
    t = s["t"]
    dt = np.diff(t, prepend=t[0])
    built = bf.built[i]
    jobs, done, deliveries = _job_counts(built, result)
    guard = s["guard_level"] if "guard_level" in s else np.zeros_like(t)
    react = s["reaction_level"] if "reaction_level" in s else np.zeros_like(t)
    trig = s["field_trigger"] if "field_trigger" in s else np.full_like(t, -1.0)
    by_vehicle = (react >= 2.0) & (trig >= bf.n_obstacles)
    reason = result.reason
    if reason == "fleet_stopped" and collisions:
        c = collisions[0]
        reason = f"stopped: collision of {c['vehicles'][0]} and {c['vehicles'][1]} at {c['t_s']:.2f} s"
    elif reason == "collision":
        other = [v for c in collisions for v in c["vehicles"] if bf.ids[i] in c["vehicles"] and v != bf.ids[i]]
        reason = f"collision with {other[0]}" if other else "collision"
    return {
        "id": bf.ids[i],
        "model": result.scenario.vehicle.model,
        "outcome": result.outcome,
        "reason": reason,
        "jobs": jobs,
        "jobs_completed": done,
        "deliveries": deliveries,
        "distance_m": float(np.nanmax(np.abs(_distance(s)))) if t.size else 0.0,
        "time_slowed_positioning_s": float(np.sum(dt[guard == 1.0])),
        "time_stopped_positioning_s": float(np.sum(dt[guard >= 2.0])),
        "time_slowed_fields_s": float(np.sum(dt[react == 1.0])),
        "time_stopped_fields_s": float(np.sum(dt[react >= 2.0])),
        "time_stopped_by_vehicle_s": float(np.sum(dt[by_vehicle])),
        "min_separation_m": float(sep.per_vehicle[i]),
        "nearest_vehicle": sep.nearest[i] or None,
        "end_s": float(t[-1]) if t.size else 0.0,
    }


def _distance(series: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    for name in ("distance_C", "distance_O", "distance"):
        if name in series:
            return series[name]
    return np.zeros(1)


def _job_counts(built: Built, result: SimResult) -> tuple[int, int, int]:
    """``(jobs, completed, deliveries)``: a mission job is done once its station stop and its dwell are over
    (a wait job once its wait is); a path vehicle has one job, done when its run completed."""
    sc = result.scenario
    if sc.mission is None or built.mission is None:
        return 1, int(result.completed), 0
    legs = built.mission.legs
    stops = list(getattr(built.autopilot, "stops", []))
    t_end = float(result.series["t"][-1])
    done_at: dict[int, float] = {}
    clock = math.nan
    by_leg = {st.leg: st.t for st in stops}
    for k, leg in enumerate(legs):
        if leg.route is not None:
            clock = by_leg.get(k, math.nan)
        clock = clock + leg.dwell_s
        done_at[k] = clock
    finished = result.completed
    done = [k for k, tk in done_at.items() if finished or (math.isfinite(tk) and tk <= t_end + 1e-9)]
    deliveries = sum(1 for k in done if legs[k].action == "drop")
    return len(legs), len(done), deliveries


def fleet_figures(vehicles: list[dict[str, Any]], collisions: list[dict[str, Any]], sep: Any,
                  t_end: float) -> dict[str, Any]:
    """The fleet's headline figures from its vehicles' rows (sums and minima of them)."""
    deliveries = sum(v["deliveries"] for v in vehicles)
    return {
        "vehicles": len(vehicles),
        "completed": sum(v["outcome"] == "completed" for v in vehicles),
        "failed": sum(v["outcome"] != "completed" for v in vehicles),
        "jobs": sum(v["jobs"] for v in vehicles),
        "jobs_completed": sum(v["jobs_completed"] for v in vehicles),
        "deliveries": deliveries,
        "deliveries_per_hour": 3600.0 * deliveries / t_end if t_end > 0 else math.nan,
        "collisions": len(collisions),
        "min_separation_m": min((v["min_separation_m"] for v in vehicles), default=math.inf),
        "min_separation_pair": None if getattr(sep, "pair", None) is None else list(sep.pair),
        "min_separation_t_s": getattr(sep, "t", math.nan),
        "time_stopped_positioning_s": sum(v["time_stopped_positioning_s"] for v in vehicles),
        "time_stopped_fields_s": sum(v["time_stopped_fields_s"] for v in vehicles),
        "sim_time_s": t_end,
    }


def simulate_fleet(fleet: FleetScenario, progress: Callable[[float], None] | None = None,
                   built: BuiltFleet | None = None) -> FleetResult:
    """Build (unless ``built``) and run a fleet scenario; deterministic for its seed."""
    return run_fleet(build_fleet(fleet) if built is None else built, progress)
