"""Traffic control wired into a fleet run (issues 28, 30): jobs dispatched, routes planned together, the ADG kept.

A fleet scenario is under traffic control when it has transport jobs (``fleet.jobs``, ``fleet.job_stream``,
``fleet.jobs_file``) or a ``fleet.traffic`` section. Then, before the vehicles are built
(:func:`plan_traffic`):

1. every vehicle must be a mission vehicle on one route network; its own mission's jobs come first;
2. the transport jobs go to the vehicles (:func:`agvnav.traffic.dispatch.dispatch`, nearest idle), each
   vehicle is sent home (its start) after its work unless ``traffic.home`` is false;
3. the conflict zones of the vehicles' models are computed (:func:`agvnav.traffic.zones.conflict_zones`)
   with ``traffic.margin_m`` widened by each vehicle's guided point offset and by how far its body
   reaches beyond its model's default footprint (the zones sweep the default one about base_link);
4. the routes are planned together (:func:`agvnav.traffic.plan.plan_fleet`) and their ADG built
   (:func:`agvnav.traffic.adg.build_adg`);
5. each vehicle's plan becomes its mission (:func:`agvnav.traffic.hold.mission_legs`, chained as a
   single run chains its own) and its mission autopilot stands at the hold points of
   :class:`agvnav.traffic.hold.HoldControl` (:meth:`agvnav.navigation.mission.MissionAutopilot.hold_at`).

During the run (:func:`report_progress`, called by :func:`agvnav.sim.fleet.run_fleet` after every step)
each vehicle reports its *estimated* progress along its mission path (the autopilot's ``s_est``: what a
real vehicle reports), which marks the ADG's events and counts the time waiting for traffic, per zone
and per node. The policy is the traffic package's and the navigation's; this module only wires it.
A job no vehicle can serve, or a vehicle the planner cannot serve, is reported (``unserved``) and fails
the fleet run; a vehicle left without work stands at its start; a vehicle that waits for traffic behind
vehicles whose runs have ended (a collision, lost positioning) is stopped, failed, naming them (never a
silent stall to the time limit).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely

from agvnav.navigation.mission import MissionAutopilot
from agvnav.routes.mission import Leg, MissionError, MissionPlan, chain_mission
from agvnav.routes.network import RouteNetwork
from agvnav.routes.planning import Route, Traversal, VehicleLimits
from agvnav.sim.mission import load_mission_network
from agvnav.traffic.adg import Adg, build_adg
from agvnav.traffic.dispatch import Assignment, DriveTimes, FleetVehicle, dispatch, tasks_of
from agvnav.traffic.hold import HoldControl, Waits, mission_legs, step_bounds
from agvnav.traffic.jobs import TransportJob, fleet_jobs
from agvnav.traffic.plan import INF, NEVER, FleetPlan, Goal, Occupation, VehiclePlan, plan_fleet
from agvnav.traffic.zones import ConflictZones, conflict_zones, model_footprint
from agvnav.vehicles.builders import build_plant
from agvnav.world.fleet import FleetScenario, TrafficSpec
from agvnav.world.scenario import Scenario

__all__ = [
    "FleetTraffic",
    "check_conflicts",
    "plan_traffic",
    "report_progress",
    "standing_mission",
    "traffic_figures",
    "under_traffic_control",
    "wire_holds",
]


@dataclass
class FleetTraffic:
    """A fleet's traffic plan: network, jobs and their assignment, zones, plan, ADG, the hold control, and each
    vehicle's mission (None: the vehicle has no work and stands at its start)."""

    network: RouteNetwork
    jobs: list[TransportJob]
    assignment: Assignment
    zones: ConflictZones
    margin_m: float
    plan: FleetPlan
    adg: Adg
    control: HoldControl
    missions: dict[str, MissionPlan | None]
    conflict_s: dict[str, float] = field(default_factory=dict)
    """per vehicle, time (s) it held resources conflicting with another's (by the reported progress)."""
    blocked: dict[str, list[str]] = field(default_factory=dict)
    """vehicles stopped because they waited for traffic behind vehicles whose runs had ended, and those vehicles."""
    conflict_time_s: float = 0.0
    """time (s) some two vehicles held conflicting resources (by the reported progress)."""
    conflicts: list[tuple[str, str, float]] = field(default_factory=list)
    """each pair of vehicles that held conflicting resources and the first time (s) it did."""


def under_traffic_control(fleet: FleetScenario) -> bool:
    """True when the fleet has transport jobs or a ``traffic`` section."""
    f = fleet.fleet
    return f.traffic is not None or bool(f.jobs) or f.job_stream is not None or f.jobs_file is not None


def _limits(sc: Scenario) -> VehicleLimits:
    m = sc.mission
    assert m is not None
    return VehicleLimits(sc.vehicle.model, sc.traction.speed_m_s, m.lateral_accel_m_s2, math.radians(m.turn_rate_deg_s))


def _own_goals(sc: Scenario) -> tuple[Goal, ...]:
    """The vehicle's own mission jobs as planning goals (a wait job: a dwell where it stands)."""
    m = sc.mission
    assert m is not None
    out: list[Goal] = []
    where = m.start
    for j in m.jobs:
        station = j.station if j.station is not None else where
        out.append(Goal(station, j.duration_s, arrive_mode=-1 if j.action == "reverse_into" else None,
                        action="goto" if j.action == "wait" else j.action))
        where = station
    return tuple(out)


def _reach_margin(sc: Scenario) -> float:
    """How far (m) the vehicle's guided point and body may lie beyond what the zones sweep: the guided point's
    offset ahead of base_link (the network carries the guided point) plus the largest distance of the body's
    corners outside its model's default footprint."""
    v = sc.vehicle
    steered = v.family == "steered"
    wheelbase = float(getattr(v, "wheelbase_m", 0.0))
    m = sc.mission
    guided_c = steered and (sc.controller.point in (None, "C") or (m is not None and m.point_switching))
    offset = wheelbase if guided_c else 0.0
    body = np.asarray(build_plant(v, [0.0] * (4 if steered else 3)).footprint, dtype=np.float64)
    default = shapely.Polygon(model_footprint(v.model))
    beyond = float(np.max(shapely.distance(default, shapely.points(body)))) if body.size else 0.0
    return offset + beyond


def plan_traffic(fleet: FleetScenario, scenarios: Sequence[Scenario]) -> FleetTraffic:
    """Dispatch, zones, plan, ADG and each vehicle's mission (module doc); errors name the fleet file's key."""
    spec = fleet.fleet.traffic or TrafficSpec()
    ids = fleet.ids
    for i, sc in enumerate(scenarios):
        if sc.mission is None:
            raise fleet.error(("fleet", "vehicles", i), f"vehicle {ids[i]!r} drives a path: under traffic control "
                                                        "every vehicle drives a mission on the route network")
    nets = {sc.mission.network for sc in scenarios if sc.mission is not None}
    if len(nets) > 1:
        raise fleet.error(("fleet", "vehicles"), f"under traffic control the vehicles share one route network, "
                                                 f"got {sorted(nets)}")
    net = load_mission_network(scenarios[0])
    vehicles = []
    for i, sc in enumerate(scenarios):
        assert sc.mission is not None
        try:
            limits = _limits(sc)
        except ValueError as exc:
            raise fleet.error(("fleet", "vehicles", i), f"vehicle {ids[i]!r}: {exc}") from None
        vehicles.append(FleetVehicle(ids[i], limits, sc.mission.start, _own_goals(sc)))
    starts = {v.start for v in vehicles}
    jobs = fleet_jobs(fleet, net, [s for s in net.stations if s not in starts])
    assignment = dispatch(jobs, vehicles, DriveTimes(net))
    tasks = tasks_of(assignment, vehicles, home=spec.home)
    margin = float(spec.margin_m) + max(_reach_margin(sc) for sc in scenarios)
    zones = conflict_zones(net, sorted({v.limits.model for v in vehicles}), margin_m=margin)
    busy = [t for t in tasks if t.goals]
    parked = [Occupation(t.vehicle, t.limits.model, ("node", t.start), 0.0, INF, -1, NEVER)
              for t in tasks if not t.goals]  # a vehicle without work stands at its start for ever
    plan = plan_fleet(net, busy, zones, committed=parked)
    adg = build_adg(plan, zones)
    missions: dict[str, MissionPlan | None] = {}
    bounds: dict[str, list[tuple[float, float]]] = {}
    tol = math.radians(net.spec.tolerances.heading_deg)
    for v in vehicles:
        vp = plan.plans.get(v.id)
        if vp is None or not vp.steps:
            missions[v.id] = None
            bounds[v.id] = []
            continue
        start = net.nodes[v.start]
        try:
            mp = chain_mission(mission_legs(vp), np.array([start.x, start.y]), tol)
        except MissionError as exc:  # pragma: no cover - a plan always moves the vehicle when it has steps
            raise fleet.error(("fleet", "vehicles", ids.index(v.id)), f"vehicle {v.id!r}: {exc}") from None
        missions[v.id] = mp
        bounds[v.id] = step_bounds(mp.node_s, vp)
    standing = {t.vehicle: VehiclePlan(t.vehicle, t.limits.model, t.start, (), (), ()) for t in tasks if not t.goals}
    control = HoldControl(adg, {**plan.plans, **standing}, bounds, zones, follow_adg=spec.follow_adg)
    return FleetTraffic(net, jobs, assignment, zones, margin, plan, adg, control, missions,
                        dict.fromkeys(ids, 0.0))


class _Stand:
    """The hold point of a vehicle without work: where it stands (its start)."""

    def hold_point(self, s: float) -> float:
        """Always the start of its path (m)."""
        return 0.0


def standing_mission(traffic: FleetTraffic, sc: Scenario) -> MissionPlan:
    """The mission a vehicle without work is built with: the first edge out of its start, never driven (it holds
    at its start, :func:`wire_holds`); the fleet run stops it once the others are done."""
    m = sc.mission
    assert m is not None
    net = traffic.network
    model = sc.vehicle.model
    edge = next((e for e in net.edges.values() if e.source == m.start and e.allows(model)), None)
    if edge is None:
        raise sc.error(("mission", "start"), f"no edge of network {net.name!r} leaves {m.start!r} for a {model}")
    route = Route((Traversal(edge, 1),), (edge.source, edge.target), 0.0)
    start = net.nodes[m.start]
    return chain_mission([Leg(0, "goto", edge.target, route, 0.0)], np.array([start.x, start.y]),
                         math.radians(net.spec.tolerances.heading_deg))


def wire_holds(traffic: FleetTraffic, vehicle: str, autopilot: object) -> None:
    """Make the vehicle's mission autopilot stand at the traffic control's hold points (at its start for ever
    when it has no work); a spot-turning vehicle turns on the spot where its plan turns at a node, as every
    mission autopilot does (:func:`agvnav.sim.mission.mission_autopilot`)."""
    if not isinstance(autopilot, MissionAutopilot):
        raise TypeError(f"vehicle {vehicle!r}: traffic control needs a mission autopilot, got {type(autopilot)}")
    if traffic.missions[vehicle] is None:
        autopilot.hold_at(_Stand())
    else:
        autopilot.hold_at(traffic.control.agent(vehicle))


def report_progress(traffic: FleetTraffic, vehicle: str, autopilot: object, t: float, dt: float) -> None:
    """The vehicle reports its estimated progress along its mission path at ``t`` (s) after a step of ``dt`` (s)."""
    if not isinstance(autopilot, MissionAutopilot) or traffic.missions.get(vehicle) is None:
        return
    i_dw = autopilot.signal_names.index("dwelling")
    dwelling = bool(autopilot.signals()[i_dw])
    traffic.control.report(vehicle, autopilot.progress, t, dt, dwelling)


def check_conflicts(traffic: FleetTraffic, t: float, dt: float) -> None:
    """Count the time vehicles hold conflicting resources (by their reported progress; the independent check)."""
    pairs = traffic.control.conflicting()
    if pairs:
        traffic.conflict_time_s += dt
    for a, b in pairs:
        traffic.conflict_s[a] += dt
        traffic.conflict_s[b] += dt
        if not any(c[:2] == (a, b) for c in traffic.conflicts):
            traffic.conflicts.append((a, b, t))


def traffic_figures(traffic: FleetTraffic, vehicle: str) -> dict[str, Any]:
    """One vehicle's traffic figures: jobs dispatched, time waiting for traffic (s), where and for which zone."""
    w = traffic.control.waits.get(vehicle, Waits())
    return {
        "dispatched_jobs": [j.id for j in traffic.assignment.jobs.get(vehicle, [])],
        "traffic_wait_s": w.total_s,
        "traffic_wait_by_zone_s": dict(sorted(w.by_zone.items(), key=lambda kv: -kv[1])),
        "traffic_wait_by_node_s": dict(sorted(w.by_node.items(), key=lambda kv: -kv[1])),
        "traffic_wait_most_at": max(w.by_node, key=lambda k: w.by_node[k]) if w.by_node else None,
        "traffic_conflict_s": traffic.conflict_s.get(vehicle, 0.0),
    }
