"""A fleet in one world (issue 28): every vehicle's closed loop, stepped in lockstep.

:func:`build_fleet` builds each vehicle of a :class:`~agvnav.world.fleet.FleetScenario` exactly
as a single run builds it (:func:`agvnav.sim.build.build` of the vehicle's own scenario), then
makes the vehicles physical to one another: each vehicle's body is a moving obstacle
(:class:`~agvnav.sim.bodies.FleetBodies`, in arrays) in every other vehicle's obstacle set
(:class:`~agvnav.sim.bodies.BodiesInView`, those within each sensor's reach), so it cuts their goniometer's line
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

A fleet with transport jobs or a ``fleet.traffic`` section runs under traffic control
(:mod:`agvnav.sim.traffic`): the jobs are dispatched and every route planned together before the
vehicles are built, each vehicle is built with its planned mission and stands at the hold points of
the plan's ADG; after every step each vehicle reports its estimated progress. The rows and figures
then add the jobs dispatched and the time each vehicle waited for traffic, per zone and per node.

The world's step is batch-first: after the plants advance, every vehicle's true motion over the step
is held in arrays (:class:`~agvnav.sim.bodies.FleetBodies`' motion tables, one ``pose_at`` call per
vehicle), and the work against the other bodies runs in kernels once per step or instant for all
vehicles (box edges, lines of sight, footprint gaps). Each vehicle's sensors, estimator and autopilot
are still its own loop's, stepped in lockstep; the batch-kernel engine of issue 28 replaces that
stepping, not the scenario format, the results or their tests.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Polygon

from agvnav.geometry import wrap_angle_scalar
from agvnav.sim.bodies import BodiesInView, FleetBodies, footprint_gaps, placed_footprints
from agvnav.sim.build import Built, build
from agvnav.sim.engine import record_stride
from agvnav.sim.mission import load_mission_network
from agvnav.sim.rangers import UltrasonicSensorRole
from agvnav.sim.reactive import ObstacleRangers, OccludedReflections, ReactiveInputs, ScannerRole
from agvnav.sim.roles import GoniometerSensor
from agvnav.sim.run import SimResult, result_of
from agvnav.sim.traffic import (
    FleetTraffic,
    check_conflicts,
    plan_traffic,
    report_progress,
    standing_mission,
    traffic_figures,
    under_traffic_control,
    wire_holds,
)
from agvnav.world.fleet import FleetScenario
from agvnav.world.obstacles import obstacle_from_spec
from agvnav.world.scenario import Scenario, ScenarioError

__all__ = [
    "EXACT_WITHIN_M",
    "FLEET_MAX_ROWS",
    "TALLY_NAMES",
    "BuiltFleet",
    "FleetResult",
    "build_fleet",
    "fleet_figures",
    "fleet_stride",
    "run_fleet",
    "simulate_fleet",
]

#: Separations are computed exactly (polygons) when the bounding circles come within this (m).
EXACT_WITHIN_M = 2.0
#: A start pose lies on a node when within this distance (m) and the node's heading tolerance.
START_ON_NODE_M = 0.1


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
    bodies: FleetBodies
    """every vehicle's body and true poses over the current step (:mod:`agvnav.sim.bodies`)."""
    duration: float
    n_obstacles: int
    """obstacles of the scenario itself in each vehicle's set (vehicle ``j``'s body is obstacle ``n_obstacles + j``)."""
    traffic: FleetTraffic | None = None
    """the traffic control (jobs dispatched, routes planned together, the ADG's hold points), when under it."""


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
    traffic = plan_traffic(fleet, own) if under_traffic_control(fleet) else None
    for i, sc in enumerate(own):
        try:
            if traffic is None:
                b = build(sc)
            else:
                planned = traffic.missions[ids[i]]
                b = build(sc, planned if planned is not None else standing_mission(traffic, sc))
                wire_holds(traffic, ids[i], b.autopilot)
        except ScenarioError as exc:
            if exc.key and exc.key[:2] == ("mission", "start") and fleet.fleet.vehicles[i].at is not None:
                raise fleet.error(("fleet", "vehicles", i, "at"), f"vehicle {ids[i]!r}: {exc.detail}") from None
            raise fleet.relocate(i, exc) from None
        scenarios.append(sc)
        built.append(b)
    _check_overlaps(fleet, built)
    bodies = FleetBodies([np.asarray(b.plant.footprint, dtype=np.float64) for b in built],
                         np.array([np.asarray(b.plant.pose, dtype=np.float64)[:3] for b in built]))
    n_obs = len(fleet.obstacles or [])
    for i, b in enumerate(built):
        _wire_others(b, scenarios[i], bodies, i)
    duration = float(fleet.duration_s) if fleet.duration_s is not None else max(b.duration for b in built)
    if traffic is not None and fleet.duration_s is None:  # the planned waits for traffic on top
        duration += max((p.end_s for p in traffic.plan.plans.values()), default=0.0)
    stride = fleet_stride(fleet, len(built), float(built[0].loop.dt), duration)
    for b in built:
        b.loop.record_every = stride
    return BuiltFleet(fleet, ids, scenarios, built, bodies, duration, n_obs, traffic)


#: Recorded rows of all the vehicles together a fleet keeps at most when its rate is automatic
#: (about 0.8 GB of series at 50 columns; an 8-hour shift of 50 vehicles records every 15th step).
FLEET_MAX_ROWS = 2_000_000


def fleet_stride(fleet: FleetScenario, n_vehicles: int, dt: float, duration: float) -> int:
    """Steps between two recorded rows of each vehicle: ``record_step_s`` in whole steps, or automatic (every
    step, unless a vehicle would pass :data:`~agvnav.sim.engine.MAX_RECORDED_ROWS` or the fleet
    :data:`FLEET_MAX_ROWS`)."""
    if fleet.record_step_s is not None:
        return max(1, round(float(fleet.record_step_s) / dt))
    n_steps = math.ceil(duration / dt - 1e-9)
    return max(record_stride(n_steps, None), math.ceil(n_vehicles * n_steps / FLEET_MAX_ROWS))


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


def _wire_others(b: Built, sc: Scenario, bodies: FleetBodies, me: int) -> None:
    """Make the other vehicles' bodies obstacles to vehicle ``me``'s goniometer, scanner and rangers, each
    sensor seeing those within its reach (:class:`~agvnav.sim.bodies.BodiesInView`)."""
    own = tuple(obstacle_from_spec(o) for o in (sc.obstacles or []))
    g = sc.goniometer
    reach = {"reflections": g.max_range_m if g is not None else math.inf,
             "scanner": sc.scanner.max_range_m if sc.scanner is not None else math.inf,
             "ultrasonic": sc.ultrasonic.max_range_m if sc.ultrasonic is not None else math.inf}

    def view(name: str) -> BodiesInView:
        return BodiesInView(own, bodies=bodies, me=me, reach=float(reach.get(name, math.inf)))

    sensors = list(b.loop.sensors)
    for k, s in enumerate(sensors):
        if isinstance(s, (OccludedReflections, ScannerRole, ObstacleRangers)):
            s.obstacles = view(s.name)
        elif isinstance(s, GoniometerSensor) and g is not None:
            sensors[k] = OccludedReflections(s, view(s.name), b.world.reflector_xy,
                                             (g.mount[0], g.mount[1], math.radians(g.mount[2])))
        elif isinstance(s, UltrasonicSensorRole):
            sensors[k] = ObstacleRangers(s, view(s.name), ReactiveInputs(), None)
    b.loop.sensors = sensors


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


#: Time (s) each vehicle spent in each state, counted every step (:class:`_Tally`).
TALLY_NAMES = ("time_slowed_positioning_s", "time_stopped_positioning_s", "time_slowed_fields_s",
               "time_stopped_fields_s", "time_stopped_by_vehicle_s")


_TALLIED = ("guard_level", "reaction_level", "field_trigger")


class _Tally:
    """The fleet's per-vehicle times slowed and stopped and why, counted every step from the autopilots'
    signals (whatever the recording rate): the guard's level (1 slowed, 2 stopped), the reaction's level and
    the obstacle index that triggered it (a vehicle's body: at least ``n_obstacles``)."""

    def __init__(self, bf: BuiltFleet) -> None:
        n = len(bf.built)
        self.n_obstacles = bf.n_obstacles
        self.times = np.zeros((n, len(TALLY_NAMES)))
        self.by = [dict[str, float]() for _ in range(n)]
        """per vehicle, time stopped by each other vehicle's body (s), by id."""
        self.ids = bf.ids
        self.index: list[tuple[int, int, int]] = []
        for b in bf.built:
            names = list(b.loop.autopilot.signal_names)
            ig, ir, it = (names.index(c) if c in names else -1 for c in _TALLIED)
            self.index.append((ig, ir, it))

    def count(self, i: int, pilot_signals: tuple[float, ...], dt: float) -> None:
        """Add a step of ``dt`` (s) of vehicle ``i`` in the state its autopilot's signals give."""
        ig, ir, it = self.index[i]
        guard = pilot_signals[ig] if ig >= 0 else 0.0
        react = pilot_signals[ir] if ir >= 0 else 0.0
        row = self.times[i]
        if guard == 1.0:
            row[0] += dt
        elif guard >= 2.0:
            row[1] += dt
        if react == 1.0:
            row[2] += dt
        elif react >= 2.0:
            row[3] += dt
            trig = int(pilot_signals[it]) if it >= 0 else -1
            if trig >= self.n_obstacles:
                row[4] += dt
                other = self.ids[trig - self.n_obstacles]
                self.by[i][other] = self.by[i].get(other, 0.0) + dt


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
    tally = _Tally(bf)
    collisions: list[dict[str, Any]] = []
    ended_at = [math.nan] * n
    traffic = bf.traffic
    idle = [i for i in range(n) if traffic is not None and traffic.missions[bf.ids[i]] is None]
    cpu0, wall0 = time.process_time(), time.perf_counter()
    steps = 0
    vehicle_steps = 0
    t = 0.0
    while any(loop.running for loop in loops):
        active = [i for i in range(n) if loops[i].running]
        t1 = (steps + 1) * dt
        for i in active:
            loops[i].advance()
        _move_bodies(bf, active, t, t1)
        for i in active:
            if not loops[i].sense():
                ended_at[i] = t1
            tally.count(i, loops[i].autopilot.signals(), dt)
            if traffic is not None:
                report_progress(traffic, bf.ids[i], loops[i].autopilot, t1, dt)
        if traffic is not None:
            check_conflicts(traffic, t1, dt)
            _stop_blocked(bf, traffic, t1, ended_at)
        vehicle_steps += len(active)
        steps += 1
        t = t1
        if idle and all(i in idle or not loops[i].running for i in range(n)):
            for i in idle:  # a vehicle without work stands at its start until the others are done
                if loops[i].running:
                    loops[i].stop(IDLE)
                    ended_at[i] = t
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
    vehicles = [_vehicle_figures(bf, i, results[i], sep, collisions, tally) for i in range(n)]
    figures = fleet_figures(vehicles, collisions, sep, t)
    if traffic is not None:
        figures.update(_traffic_totals(traffic))
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
        unserved = _unserved(traffic)
        if unserved:
            outcome, reason = "failed", "; ".join([*([reason] if reason else []), unserved])
    if progress is not None:
        progress(t)
    return FleetResult(bf.fleet, bf.ids, results, figures, vehicles, outcome, reason, collisions)


#: The stop reason of a vehicle that waits for traffic behind vehicles whose runs have ended (it never could go on).
BLOCKED = "blocked"


def _stop_blocked(bf: BuiltFleet, traffic: FleetTraffic, t: float, ended_at: list[float]) -> None:
    """Stop every vehicle standing at a hold point that waits only for vehicles whose runs have ended (failed before
    passing the events it waits for): it would wait for ever; the reason names them."""
    loops = [b.loop for b in bf.built]
    ended = {bf.ids[j] for j, loop in enumerate(loops) if not loop.running}
    if not ended:
        return
    for i, loop in enumerate(loops):
        if not loop.running:
            continue
        on = traffic.control.waiting_on(bf.ids[i])
        if on and on <= ended:
            traffic.blocked[bf.ids[i]] = sorted(on)
            loop.stop(BLOCKED)
            ended_at[i] = t
            ended.add(bf.ids[i])


def _move_bodies(bf: BuiltFleet, active: list[int], t0: float, t1: float) -> None:
    """The step ``(t0, t1]`` begins for the bodies: the active vehicles' true poses at the bodies' sample instants of
    the step (one ``pose_at`` call each; the others stand where they stopped)."""
    bodies = bf.bodies
    grid = bodies.sample_times(t0, t1)
    poses = np.repeat(bodies.p1[:, None, :], grid.size, axis=1)
    for i in active:
        poses[i] = bf.built[i].plant.pose_at(grid)
    bodies.begin_step(t0, t1, poses)


def _separations(bf: BuiltFleet, sep: _Separation, t: float) -> tuple[int, int] | None:
    """Update the smallest separations at ``t`` (true poses); the first pair in contact, if any.

    Every pair's lower bound ``|c_a - c_b| - R_a - R_b`` (bounding circles of the footprints about
    base_link) at once; the exact footprint-to-footprint distance (:func:`~agvnav.sim.bodies.footprint_gaps`,
    compiled over the pairs) for the pairs whose bound is within :data:`EXACT_WITHIN_M`.
    """
    n = bf.bodies.n
    if n < 2:
        return None
    bodies = bf.bodies
    poses = bodies.p1  # the true poses now (:func:`_move_bodies`)
    xy = poses[:, :2]
    r = bodies.radius
    d = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1]) - r[:, None] - r[None, :]
    np.fill_diagonal(d, math.inf)
    near = np.argwhere(np.triu(d <= EXACT_WITHIN_M, 1))
    hit = None
    if near.shape[0]:
        a, b = np.ascontiguousarray(near[:, 0]), np.ascontiguousarray(near[:, 1])
        exact = footprint_gaps(placed_footprints(bodies.footprints, poses), a, b)
        d[a, b] = d[b, a] = exact
        touching = np.flatnonzero(exact <= 0.0)
        if touching.size:
            hit = (int(a[touching[0]]), int(b[touching[0]]))
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
                     collisions: list[dict[str, Any]], tally: _Tally) -> dict[str, Any]:
    """One vehicle's row: outcome, jobs, slowed/stopped and why (counted every step), separation."""
    s = result.series
    t = s["t"]
    built = bf.built[i]
    jobs, done, deliveries = _job_counts(built, result)
    reason = result.reason
    if reason == "fleet_stopped" and collisions:
        c = collisions[0]
        reason = f"stopped: collision of {c['vehicles'][0]} and {c['vehicles'][1]} at {c['t_s']:.2f} s"
    elif reason == "collision":
        other = [v for c in collisions for v in c["vehicles"] if bf.ids[i] in c["vehicles"] and v != bf.ids[i]]
        reason = f"collision with {other[0]}" if other else "collision"
    by = tally.by[i]
    outcome = result.outcome
    if reason == BLOCKED and bf.traffic is not None:
        reason = (f"blocked: waits for traffic behind {', '.join(bf.traffic.blocked.get(bf.ids[i], []))}, whose run "
                  "ended first")
    if reason == IDLE:
        outcome, reason = "completed", "idle: no job dispatched to it, it stood at its start"
        jobs = done = deliveries = 0
    row = {
        "id": bf.ids[i],
        "model": result.scenario.vehicle.model,
        "outcome": outcome,
        "reason": reason,
        "jobs": jobs,
        "jobs_completed": done,
        "deliveries": deliveries,
        "distance_m": float(np.nanmax(np.abs(_distance(s)))) if t.size else 0.0,
        **{name: float(v) for name, v in zip(TALLY_NAMES, tally.times[i], strict=True)},
        "stopped_most_by": max(by, key=lambda k: by[k]) if by else None,
        "min_separation_m": float(sep.per_vehicle[i]),
        "nearest_vehicle": sep.nearest[i] or None,
        "end_s": float(t[-1]) if t.size else 0.0,
    }
    if bf.traffic is not None:
        row.update(traffic_figures(bf.traffic, bf.ids[i]))
    return row


#: The stop reason of a vehicle without work, ended once the others are done (reported completed, idle).
IDLE = "idle"


def _traffic_totals(traffic: FleetTraffic) -> dict[str, Any]:
    """The fleet's traffic figures: jobs dispatched and unserved, conflicts (the time waiting for traffic is
    :func:`fleet_figures`' sum of the vehicles')."""
    return {
        "transport_jobs": len(traffic.jobs),
        "unserved_jobs": [j.id for j, _ in traffic.assignment.unserved],
        "unserved_vehicles": sorted(traffic.plan.unserved),
        "traffic_conflicts": len(traffic.conflicts),
        "traffic_conflict_s": traffic.conflict_time_s,
        "traffic_margin_m": traffic.margin_m,
        "adg_dependencies": traffic.adg.n_dependencies,
        "follow_adg": traffic.control.follow_adg,
    }


def _unserved(traffic: FleetTraffic | None) -> str:
    """Why some work was not served (empty when all was)."""
    if traffic is None:
        return ""
    parts = [f"job {j.id} unserved: {why}" for j, why in traffic.assignment.unserved]
    parts += [f"vehicle {v} unserved: {why}" for v, why in traffic.plan.unserved.items()]
    return "; ".join(parts)


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
    """The fleet's headline figures from its vehicles' rows (sums and minima of them; ``traffic_wait_s`` under traffic
    control)."""
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
        **({"traffic_wait_s": sum(v["traffic_wait_s"] for v in vehicles)}
           if any("traffic_wait_s" in v for v in vehicles) else {}),
    }


def simulate_fleet(fleet: FleetScenario, progress: Callable[[float], None] | None = None,
                   built: BuiltFleet | None = None) -> FleetResult:
    """Build (unless ``built``) and run a fleet scenario; deterministic for its seed."""
    return run_fleet(build_fleet(fleet) if built is None else built, progress)
