"""A kinematic-time executor of fleet routes under delays, with brute-force safety checks (Monte Carlo).

Each vehicle drives its steps (edges) along the exact edge geometry at the edge's mean planned speed
times its own speed factor, turns on the spot at a node (``|dpsi| / turn_rate``) before an edge that
leaves in another heading, dwells at its stations, and stops where it is during its random stops
(:class:`Delays`). Before each step it asks the traffic :class:`Controller` (the ADG,
:class:`AdgController`, or the baseline allocator, :mod:`agvnav.traffic.baseline`) whether it may start;
until then it holds at the node (the time and the zone it waits for are recorded).

Checks, independent of the controller:

* **collisions**: every ``dt`` in which a vehicle moved, the true footprints (placed at the sampled poses)
  of every pair of vehicles whose bounding circles meet are intersected: the separating-axis test of
  convex polygons compiled (:mod:`agvnav.traffic._collide`, checked against shapely in the tests), shapely
  for a footprint that is not convex; the first pair in route order is reported;
* **conflict violations**: whenever a vehicle takes a step's resources they are compared with every
  resource the others hold (the zones' relation);
* **deadlocks**: the vehicles waiting on the controller form a cycle of waits (the controller's
  ``waiting_for``), or no vehicle has moved for ``stall_s`` while some have work left and none is in a
  random stop.

Replanning (:mod:`agvnav.traffic.replan`): with a ``replan`` given, once a vehicle has waited on the
controller for more than ``replan_after_s`` the executor hands every vehicle's :class:`Progress` to it;
a new set of routes and controller it returns takes over from the next tick (the steps under way are
kept as the first steps of the new routes). The checks above run unchanged across it.

This executor replaces the closed loop (sensors, estimator, follower) by the kinematics the plan
assumes; ``agvnav.sim.fleet`` runs the same controller in the closed loop. Its cost is the tick loop in
Python (poses from plain lists, controller decisions kept until an event or a claim changes them, the
wait-for search only when the waits change) and, with ``replan``, the replanning itself (30 vehicles:
20-25 s of CPU for the three executions of ``agvnav bench traffic``'s run, about half of it replanning).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Polygon

from agvnav.geometry.angles import wrap_angle_scalar
from agvnav.routes.network import RouteNetwork
from agvnav.routes.planning import Traversal, VehicleLimits, edge_time
from agvnav.traffic._collide import first_overlap, is_convex, pad_footprints
from agvnav.traffic.adg import Adg, Dependency
from agvnav.traffic.plan import Conflicts, FleetPlan, Resource

__all__ = [
    "AdgController",
    "Controller",
    "Delays",
    "ExecResult",
    "Progress",
    "Replan",
    "RouteStep",
    "VehicleRoute",
    "execute",
    "random_delays",
    "routes_from_plan",
]


class Controller(Protocol):
    """The traffic controller the executor asks before each step."""

    def may_start(self, vehicle: str, k: int, t: float) -> str | None:
        """None when ``vehicle`` may start its step ``k`` now, else the zone (resource) it waits for."""

    def started(self, vehicle: str, k: int, t: float) -> None:
        """``vehicle`` started step ``k`` at ``t`` (s)."""

    def arrived(self, vehicle: str, k: int, t: float) -> None:
        """``vehicle`` arrived at the end of step ``k`` at ``t`` (s)."""

    def waiting_for(self, vehicle: str, k: int) -> set[str]:
        """The vehicles ``vehicle``'s step ``k`` waits for (empty when it may start)."""


class AdgController:
    """The ADG as a :class:`Controller`: step ``k`` is event ``2 k``, its arrival ``2 k + 1``.

    ``version`` counts the events marked: the blockers of a step are looked up again only after one.
    """

    def __init__(self, adg: Adg) -> None:
        self.adg = adg
        self.version = 0
        self._blockers: dict[tuple[str, int], tuple[int, list[Dependency]]] = {}

    def _blocking(self, vehicle: str, k: int) -> list[Dependency]:
        got = self._blockers.get((vehicle, k))
        if got is None or got[0] != self.version:
            got = self._blockers[(vehicle, k)] = (self.version, self.adg.blockers(vehicle, 2 * k))
        return got[1]

    def may_start(self, vehicle: str, k: int, t: float) -> str | None:
        """None when every dependency of the step's start is met, else the resource it waits for."""
        b = self._blocking(vehicle, k)
        return None if not b else f"{b[0].resource[0]}:{b[0].resource[1]}"

    def started(self, vehicle: str, k: int, t: float) -> None:
        """Mark the start event."""
        self.adg.mark(vehicle, 2 * k)
        self.version += 1

    def arrived(self, vehicle: str, k: int, t: float) -> None:
        """Mark the arrival event."""
        self.adg.mark(vehicle, 2 * k + 1)
        self.version += 1

    def waiting_for(self, vehicle: str, k: int) -> set[str]:
        """The vehicles whose events the start waits for."""
        return {d.after for d in self._blocking(vehicle, k)}


@dataclass(frozen=True)
class RouteStep:
    """One edge to drive: the traversal, the dwell (s) at its source first, the earliest start (s), the delivery."""

    traversal: Traversal
    dwell_s: float = 0.0
    not_before_s: float = 0.0
    delivers: int = 0
    """deliveries at the step's end (drops there; each counts once its dwell is over)."""
    drop_dwell_s: float = 0.0
    reached: int = 0
    """goals of the plan reached at the step's end."""


@dataclass(frozen=True)
class VehicleRoute:
    """A vehicle's route: model limits, footprint (k, 2) m in base_link, start node and heading (rad), steps."""

    vehicle: str
    limits: VehicleLimits
    footprint: NDArray[np.float64]
    start: str
    start_heading: float
    steps: tuple[RouteStep, ...]


@dataclass(frozen=True)
class Delays:
    """Per vehicle: speed factor (1 = planned speed) and stops ``(t, duration)`` in s."""

    speed: Mapping[str, float]
    stops: Mapping[str, tuple[tuple[float, float], ...]]


def random_delays(vehicles: Sequence[str], rng: np.random.Generator, horizon_s: float, speed_spread: float = 0.3,
                  stops_per_vehicle: float = 2.0, max_stop_s: float = 60.0) -> Delays:
    """Speed factors uniform in ``1 +- speed_spread``; a Poisson number of stops per vehicle (mean
    ``stops_per_vehicle``) at uniform times in ``[0, horizon_s]``, each of uniform length in ``[0, max_stop_s]``."""
    speed = {v: float(rng.uniform(1.0 - speed_spread, 1.0 + speed_spread)) for v in vehicles}
    stops: dict[str, tuple[tuple[float, float], ...]] = {}
    for v in vehicles:
        n = int(rng.poisson(stops_per_vehicle))
        ts = np.sort(rng.uniform(0.0, horizon_s, n))
        stops[v] = tuple((float(t), float(rng.uniform(0.0, max_stop_s))) for t in ts)
    return Delays(speed, stops)


@dataclass
class ExecResult:
    """What an execution gave: per vehicle deliveries, traffic waits (s, by zone), and the safety counts."""

    t_end: float
    deliveries: dict[str, int]
    delivery_times: list[float]
    wait_s: dict[str, float]
    wait_zones: dict[str, dict[str, float]]
    collisions: list[tuple[str, str, float]]
    violations: list[tuple[str, str, float]]
    deadlock: str | None
    finished: dict[str, bool]
    steps_done: dict[str, int] = field(default_factory=dict)
    replans: int = 0
    """how many times the routes were replanned (a vehicle blocked long)."""

    @property
    def n_deliveries(self) -> int:
        """Deliveries over the run."""
        return sum(self.deliveries.values())


@dataclass
class _State:
    k: int = 0
    phase: str = "wait"  # wait, turn, drive, done
    s: float = 0.0
    turn_left: float = 0.0
    ready_at: float = 0.0
    heading: float = 0.0
    xy: tuple[float, float] = (0.0, 0.0)
    held: tuple[Resource, ...] = ()
    model: str = ""


@dataclass(frozen=True)
class Progress:
    """Where a vehicle is in its route: step ``k`` is next (``moving``: under way, its start done).

    ``eta_s``: when a moving vehicle should arrive at the step's end at planned speed (s); ``stopped``: in a
    stop (a person, a fault); ``done``: every step driven.
    """

    k: int
    moving: bool
    eta_s: float
    stopped: bool
    done: bool


class Replan(Protocol):
    """Replans the routes from the vehicles' progress at ``t`` (s): new routes and controller, or None."""

    def __call__(self, t: float, progress: Mapping[str, Progress], routes: Mapping[str, VehicleRoute]
                 ) -> tuple[dict[str, VehicleRoute], Controller] | None:
        """New routes (their first step is the one under way for a moving vehicle) and their controller."""


class _EdgeGeom:
    """An edge's sampled centre line as plain lists: arc length (m), x, y (m) and heading (rad) per sample."""

    def __init__(self, tr: Traversal) -> None:
        pts = tr.edge.curve.points
        seg = np.hypot(*np.diff(pts, axis=0).T)
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        head = np.unwrap(tr.edge.curve.headings) + (math.pi if tr.mode < 0 else 0.0)
        self.cum: list[float] = cum.tolist()
        self.xs: list[float] = pts[:, 0].tolist()
        self.ys: list[float] = pts[:, 1].tolist()
        self.head: list[float] = head.tolist()
        self.length = self.cum[-1]

    def pose(self, s: float) -> tuple[float, float, float]:
        """The pose at arc length ``s`` (m, clipped to the edge): linear between samples, as ``np.interp``."""
        s = min(max(s, 0.0), self.length)
        cum = self.cum
        j = bisect_right(cum, s) - 1
        if j >= len(cum) - 1 or cum[j] == s:
            j = min(j, len(cum) - 1)
            return self.xs[j], self.ys[j], self.head[j]
        return _lerp(cum, self.xs, j, s), _lerp(cum, self.ys, j, s), _lerp(cum, self.head, j, s)


def _lerp(xp: list[float], fp: list[float], j: int, x: float) -> float:
    """``np.interp`` between samples ``j`` and ``j + 1`` (its slope-times-offset form, for the same rounding)."""
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[j]


def execute(network: RouteNetwork, routes: Sequence[VehicleRoute], controller: Controller, zones: Conflicts,
            delays: Delays, horizon_s: float, dt: float = 0.2, stall_s: float = 300.0, replan: Replan | None = None,
            replan_after_s: float = 60.0) -> ExecResult:
    """Run the routes under ``delays`` until all are done, a collision, a deadlock or ``horizon_s`` (module doc)."""
    routes = list(routes)
    ids = [r.vehicle for r in routes]
    geoms: dict[tuple[str, int], _EdgeGeom] = {}
    speed: dict[tuple[str, int], float] = {}
    shapes = _Shapes()
    for r in routes:
        _index_route(r, geoms, speed, shapes)
    collider = _Collider(routes)
    zones = _KeptConflicts(zones)
    states: dict[str, _State] = {}
    for r in routes:
        n = network.nodes[r.start]
        states[r.vehicle] = _State(heading=r.start_heading, xy=(n.x, n.y), held=(("node", r.start),),
                                   phase="wait" if r.steps else "done", model=r.limits.model)
    res = ExecResult(0.0, dict.fromkeys(ids, 0), [], dict.fromkeys(ids, 0.0), {v: {} for v in ids}, [], [], None,
                     {})
    by_id = {r.vehicle: r for r in routes}
    t, last_move, last_replan = 0.0, 0.0, -math.inf
    blocked: dict[str, float] = {}
    stops = {v: tuple((a, a + d) for a, d in delays.stops.get(v, ())) for v in ids}
    waits_seen: tuple[object, ...] = ()
    posed = True  # poses changed since the last collision check (the first tick checks the start poses)
    while t < horizon_s:
        moved = False
        waiting: dict[str, int] = {}
        for v in ids:
            st, r = states[v], by_id[v]
            if st.phase == "done" or _in_stop(stops[v], t):
                continue
            moved |= _advance(v, st, r, t, dt, controller, zones, states, geoms, speed, delays, res, waiting)
            if v in waiting:
                blocked.setdefault(v, t)
            else:
                blocked.pop(v, None)
        t += dt
        if (replan is not None and blocked and t - min(blocked.values()) > replan_after_s
                and t - last_replan > replan_after_s):
            last_replan = t
            new = replan(t, _progress(states, by_id, speed, delays, t), by_id)
            if new is not None:
                by_id, controller = new
                routes = [by_id[v] for v in ids]
                collider = _Collider(routes)
                _restart(states, by_id, geoms, speed, shapes)
                blocked.clear()
                waiting = {}  # the steps waited for were the old routes'; the new controller is asked next tick
                res.replans += 1
                posed = True  # the footprints are checked again after a switch
        if moved:
            last_move = t
        if moved or posed:  # no move, no new pose: the last tick's check holds
            posed = False
            hit = collider.first(states)
            if hit is not None:
                res.collisions.append((hit[0], hit[1], t))
                break
        # the waits of an unchanged controller (same events marked) on the same steps form no new cycle
        seen = (controller, getattr(controller, "version", None), tuple(waiting.items()))
        cycle = None if seen[1] is not None and seen == waits_seen else _wait_cycle(controller, waiting)
        waits_seen = seen
        if cycle is not None:
            res.deadlock = f"cycle of waits at {t:.1f} s: {' -> '.join(cycle)}"
            break
        if all(s.phase == "done" for s in states.values()):
            break
        if t - last_move > stall_s and not any(_stopped(delays, v, t) for v in ids):
            res.deadlock = f"no vehicle moved for {stall_s:.0f} s (at {t:.1f} s)"
            break
    res.t_end = t
    res.finished = {v: states[v].phase == "done" for v in ids}
    res.steps_done = {v: states[v].k for v in ids}
    return res


class _KeptConflicts:
    """The zones' relation, each answer kept (the executor asks the same few resources again and again)."""

    def __init__(self, zones: Conflicts) -> None:
        self.zones = zones
        self.kept: dict[tuple[str, Resource, str], frozenset[Resource]] = {}

    def conflicts(self, model_a: str, res_a: Resource, model_b: str) -> frozenset[Resource]:
        """:meth:`Conflicts.conflicts`, asked once per model pair and resource."""
        key = (model_a, res_a, model_b)
        got = self.kept.get(key)
        if got is None:
            got = self.kept[key] = self.zones.conflicts(model_a, res_a, model_b)
        return got


class _Shapes:
    """Each edge's geometry per direction and planned speed per vehicle model, computed once per execution (the
    routes of a replan drive the same edges)."""

    def __init__(self) -> None:
        self.geoms: dict[tuple[str, int], _EdgeGeom] = {}
        self.speeds: dict[tuple[str, VehicleLimits], float] = {}

    def geom(self, tr: Traversal) -> _EdgeGeom:
        """The sampled centre line of ``tr`` (its direction of travel)."""
        key = (tr.edge.id, tr.mode)
        g = self.geoms.get(key)
        if g is None:
            g = self.geoms[key] = _EdgeGeom(tr)
        return g

    def speed(self, tr: Traversal, limits: VehicleLimits) -> float:
        """The mean planned speed (m/s) over ``tr``'s edge: its length over its planned time."""
        key = (tr.edge.id, limits)
        v = self.speeds.get(key)
        if v is None:
            v = self.speeds[key] = tr.edge.curve.length / edge_time(tr.edge, limits)
        return v


def _index_route(r: VehicleRoute, geoms: dict[tuple[str, int], _EdgeGeom], speed: dict[tuple[str, int], float],
                 shapes: _Shapes) -> None:
    """The edge geometry and planned speed (m/s) of each step of ``r``."""
    for k, st in enumerate(r.steps):
        geoms[(r.vehicle, k)] = shapes.geom(st.traversal)
        speed[(r.vehicle, k)] = shapes.speed(st.traversal, r.limits)


def _progress(states: dict[str, _State], by_id: dict[str, VehicleRoute], speed: dict[tuple[str, int], float],
              delays: Delays, t: float) -> dict[str, Progress]:
    """Each vehicle's :class:`Progress` at ``t`` (planned speed for the arrival estimate)."""
    out = {}
    for v, st in states.items():
        moving = st.phase in ("turn", "drive")
        eta = t
        if moving:
            g_len = by_id[v].steps[st.k].traversal.edge.curve.length
            eta = t + max(st.turn_left, 0.0) + max(g_len - st.s, 0.0) / speed[(v, st.k)]
        out[v] = Progress(st.k, moving, eta, _stopped(delays, v, t), st.phase == "done")
    return out


def _restart(states: dict[str, _State], by_id: dict[str, VehicleRoute], geoms: dict[tuple[str, int], _EdgeGeom],
             speed: dict[tuple[str, int], float], shapes: _Shapes) -> None:
    """Every vehicle at the first step of its new route (the one under way when it moves)."""
    geoms.clear()
    speed.clear()
    for v, st in states.items():
        r = by_id[v]
        _index_route(r, geoms, speed, shapes)
        if st.phase != "done":
            st.k = 0
            if not r.steps:
                st.phase = "done"


def _stopped(delays: Delays, v: str, t: float) -> bool:
    return any(a <= t < a + d for a, d in delays.stops.get(v, ()))


def _in_stop(stops: tuple[tuple[float, float], ...], t: float) -> bool:
    """True when ``t`` (s) lies in one of the stops ``(start, end)`` (s), ``start <= t < end``."""
    for a, b in stops:  # noqa: SIM110 - a loop, not a generator: asked for every vehicle at every tick
        if a <= t < b:
            return True
    return False


def _advance(v: str, st: _State, r: VehicleRoute, t: float, dt: float, controller: Controller, zones: Conflicts,
             states: dict[str, _State], geoms: dict[tuple[str, int], _EdgeGeom], speed: dict[tuple[str, int], float],
             delays: Delays, res: ExecResult, waiting: dict[str, int]) -> bool:
    """One ``dt`` of one vehicle; True when it moved (or turned)."""
    if st.phase == "wait":
        step = r.steps[st.k]
        if t < st.ready_at or t < step.not_before_s:
            return False
        zone = controller.may_start(v, st.k, t)
        if zone is not None:
            res.wait_s[v] += dt
            res.wait_zones[v][zone] = res.wait_zones[v].get(zone, 0.0) + dt
            waiting[v] = st.k
            return False
        controller.started(v, st.k, t)
        held = (("node", step.traversal.edge.source), ("edge", step.traversal.edge.id),
                ("node", step.traversal.edge.target))
        _check_taken(v, r.limits.model, held, states, zones, res, t)
        st.held = held
        dpsi = abs(wrap_angle_scalar(step.traversal.start_heading - st.heading))
        st.turn_left = dpsi / r.limits.turn_rate if dpsi > 1e-6 else 0.0
        st.phase, st.s = "turn", 0.0
    if st.phase == "turn":
        if st.turn_left > 0.0:
            target = r.steps[st.k].traversal.start_heading
            frac = min(1.0, dt / st.turn_left)
            st.heading += frac * wrap_angle_scalar(target - st.heading)
            st.turn_left -= dt
            return True
        st.phase = "drive"
    g = geoms[(v, st.k)]
    st.s += speed[(v, st.k)] * delays.speed.get(v, 1.0) * dt
    x, y, h = g.pose(st.s)
    st.xy, st.heading = (x, y), h
    if st.s >= g.length:
        step = r.steps[st.k]
        controller.arrived(v, st.k, t + dt)
        st.held = (("node", step.traversal.edge.target),)
        st.heading = step.traversal.end_heading
        for _ in range(step.delivers):
            res.deliveries[v] += 1
            res.delivery_times.append(t + dt + step.drop_dwell_s)
        st.k += 1
        if st.k >= len(r.steps):
            st.phase = "done"
        else:
            st.phase = "wait"
            st.ready_at = t + dt + r.steps[st.k].dwell_s
    return True


def _check_taken(v: str, model: str, held: tuple[Resource, ...], states: dict[str, _State], zones: Conflicts,
                 res: ExecResult, t: float) -> None:
    """A conflict violation when a resource taken conflicts with one another vehicle holds."""
    for u, other in states.items():
        if u == v:
            continue
        ho = set(other.held)
        for rr in held:
            if ho & zones.conflicts(model, rr, other.model):
                res.violations.append((v, u, t))
                return


def _placed(fp: NDArray[np.float64], x: float, y: float, h: float) -> Polygon:
    c, s = math.cos(h), math.sin(h)
    return Polygon(np.column_stack([x + c * fp[:, 0] - s * fp[:, 1], y + s * fp[:, 0] + c * fp[:, 1]]))


class _Collider:
    """The collision check of the module doc: the compiled separating-axis kernel (:mod:`agvnav.traffic._collide`)
    when every footprint is convex, else shapely on the pairs whose bounding circles meet (the same first pair)."""

    def __init__(self, routes: Sequence[VehicleRoute]) -> None:
        self.ids = [r.vehicle for r in routes]
        self.feet = [r.footprint for r in routes]
        self.radius = np.array([float(np.max(np.hypot(f[:, 0], f[:, 1]))) for f in self.feet])
        self.convex = all(is_convex(f) for f in self.feet)
        self.fps, self.counts = pad_footprints(self.feet)
        k = self.fps.shape[1]
        self.scratch = (np.zeros((k, 2)), np.zeros((k, 2)))

    def first(self, states: dict[str, _State]) -> tuple[str, str] | None:
        """The first pair of vehicles (route order) whose true footprints intersect, or None."""
        sts = [states[v] for v in self.ids]
        xs = np.array([st.xy[0] for st in sts])
        ys = np.array([st.xy[1] for st in sts])
        hs = np.array([st.heading for st in sts])
        if self.convex:
            ab = int(first_overlap(xs, ys, hs, self.radius, self.fps, self.counts, *self.scratch))
            return None if ab < 0 else (self.ids[ab // len(sts)], self.ids[ab % len(sts)])
        return self._shapely(xs, ys, hs)

    def _shapely(self, xs: NDArray[np.float64], ys: NDArray[np.float64], hs: NDArray[np.float64]
                 ) -> tuple[str, str] | None:
        rad = self.radius
        d = np.hypot(xs[:, None] - xs[None, :], ys[:, None] - ys[None, :])
        near = np.argwhere(np.triu(d < rad[:, None] + rad[None, :], 1))
        for a, b in near.tolist():
            pa = _placed(self.feet[a], float(xs[a]), float(ys[a]), float(hs[a]))
            pb = _placed(self.feet[b], float(xs[b]), float(ys[b]), float(hs[b]))
            if pa.intersects(pb):
                return self.ids[a], self.ids[b]
        return None


def _wait_cycle(controller: Controller, waiting: dict[str, int]) -> list[str] | None:
    """A cycle in the wait-for graph of the vehicles waiting on the controller this step."""
    graph = {v: controller.waiting_for(v, k) & set(waiting) for v, k in waiting.items()}
    color: dict[str, int] = {}
    for root in graph:
        if color.get(root):
            continue
        stack = [(root, iter(sorted(graph[root])))]
        path = [root]
        color[root] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                color[node] = 2
                stack.pop()
                path.pop()
                continue
            if color.get(nxt) == 1:
                return [*path[path.index(nxt):], nxt]
            if not color.get(nxt):
                color[nxt] = 1
                stack.append((nxt, iter(sorted(graph[nxt]))))
                path.append(nxt)
    return None


def routes_from_plan(plan: FleetPlan, network: RouteNetwork, limits: Mapping[str, VehicleLimits],
                     footprints: Mapping[str, NDArray[np.float64]]) -> list[VehicleRoute]:
    """The executor's routes of a fleet plan (``limits`` and ``footprints`` by vehicle)."""
    out = []
    for v in plan.order:
        p = plan.plans[v]
        steps = []
        for st in p.steps:
            reached = p.goals[st.arrives:st.arrives + st.reached] if st.arrives is not None else ()
            drops = [g for g in reached if g.action == "drop"]
            steps.append(RouteStep(st.traversal, st.dwell_s, st.not_before_s, len(drops),
                                   drops[0].dwell_s if drops else 0.0, st.reached))
        node = network.nodes[p.start]
        h0 = p.steps[0].traversal.start_heading if p.steps else 0.0
        out.append(VehicleRoute(v, limits[v], footprints[v], p.start, node.heading if node.heading is not None else h0,
                                tuple(steps)))
    return out
