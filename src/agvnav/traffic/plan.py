"""Multi-vehicle planning: prioritised planning with reservations over conflict resources.

Every vehicle plans in turn (priority order) against the reservations of the vehicles planned
before it, with Safe Interval Path Planning (SIPP: Phillips & Likhachev 2011) on the same
``(node, heading class, direction of travel)`` states as :class:`agvnav.routes.planning.Planner`
(drive times :func:`~agvnav.routes.planning.edge_time`, turns on the spot ``|dpsi| / turn_rate``,
a cusp ``cusp_s``), so a vehicle may wait at a node or take a detour (a passing bay) to let
another pass.

Occupancy model (what the ADG executes, :mod:`agvnav.traffic.adg`): driving edge ``e`` from
node ``u`` to ``v`` the vehicle holds the resources ``("node", u)``, ``("edge", e)`` and
``("node", v)``; standing at a node (waiting, turning, dwelling at a station, parked at the end)
it holds ``("node", n)``. A resource ``r`` of model ``b`` is busy while some vehicle of model
``a`` holds a resource ``q`` with ``r in zones.conflicts(a, q, b)`` (:class:`Conflicts`). A plan is
*valid* when no two vehicles hold conflicting resources at overlapping times; the planner keeps
every vehicle's start node reserved until it leaves and its last goal reserved for ever after it
arrives (it parks there), so a valid plan stays valid after its end.

Each vehicle's work is a list of :class:`Goal` (a station, the dwell there, the earliest time the
dwell may start: a job's release). All goals of a vehicle are searched in one SIPP (the goal index
is part of the state), so a later goal never fails because of how an earlier one was reached
when another way would do. A vehicle whose goals cannot all be reached (a station no route
leads to, or reservations that never clear) is reported in :attr:`FleetPlan.unserved`, never
left planned half-way.
"""

from __future__ import annotations

import bisect
import heapq
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from agvnav.geometry.angles import wrap_angle_scalar
from agvnav.routes.network import RouteNetwork
from agvnav.routes.planning import HEADING_CLASS_TOL_RAD, Traversal, VehicleLimits, edge_time

__all__ = [
    "INF",
    "MAX_EXPANSIONS",
    "NEVER",
    "Conflicts",
    "FleetPlan",
    "Goal",
    "Occupation",
    "Reservations",
    "Resource",
    "Step",
    "VehiclePlan",
    "VehicleTask",
    "arrive_event",
    "plan_fleet",
    "plan_vehicle",
    "start_event",
]

#: A node ``("node", node_id)`` or an edge ``("edge", edge_id)`` of the network.
Resource = tuple[str, str]

INF = math.inf

#: SIPP expansions per vehicle before it is reported unserved (the reservations never clear).
MAX_EXPANSIONS = 200_000


class Conflicts(Protocol):
    """The conflict relation of :class:`agvnav.traffic.zones.ConflictZones`."""

    def conflicts(self, model_a: str, res_a: Resource, model_b: str) -> frozenset[Resource]:
        """The resources a vehicle of ``model_b`` must not hold while one of ``model_a`` holds ``res_a``."""


@dataclass(frozen=True)
class Goal:
    """A station to reach, the dwell there (s) and the earliest time (s) the dwell may start (a release)."""

    station: str
    dwell_s: float = 0.0
    not_before_s: float = 0.0
    arrive_mode: int | None = None
    job: str | None = None
    """the transport job it serves (None: the vehicle's own mission)."""
    action: str = "goto"
    """``pick``, ``drop``, ``goto`` or ``reverse_into``."""


@dataclass(frozen=True)
class VehicleTask:
    """What one vehicle must do: its model limits, start node (heading), ready time (s) and goals in order."""

    vehicle: str
    limits: VehicleLimits
    start: str
    goals: tuple[Goal, ...]
    start_heading: float | None = None
    ready_s: float = 0.0


@dataclass(frozen=True)
class Step:
    """One planned action: drive ``traversal`` from ``source`` to ``target`` over ``[t_start, t_end]`` (s).

    ``goal``: index of the goal it drives to; ``dwell_s`` and ``not_before_s``: the vehicle dwells that
    long at ``source`` (a station stop) and starts no earlier than ``not_before_s``; ``arrives``: the goal
    reached at ``target`` (None when ``target`` is a pass-through node).
    """

    traversal: Traversal
    source: str
    target: str
    t_start: float
    t_end: float
    goal: int
    dwell_s: float = 0.0
    not_before_s: float = 0.0
    arrives: int | None = None

    @property
    def edge(self) -> str:
        """The edge id."""
        return self.traversal.edge.id

    def resources(self) -> tuple[Resource, ...]:
        """What the vehicle holds while driving the step (module doc)."""
        return (("node", self.source), ("edge", self.edge), ("node", self.target))


@dataclass(frozen=True)
class VehiclePlan:
    """A vehicle's plan: its steps in order (empty: it stays at ``start``), the goal arrivals (s)."""

    vehicle: str
    model: str
    start: str
    steps: tuple[Step, ...]
    goals: tuple[Goal, ...]
    arrivals: tuple[float, ...]
    ready_s: float = 0.0

    @property
    def end_node(self) -> str:
        """Where the vehicle parks after its last step."""
        return self.steps[-1].target if self.steps else self.start

    @property
    def end_s(self) -> float:
        """When its work is over (s): the last arrival plus the last dwell."""
        if not self.goals:
            return self.ready_s
        g = self.goals[-1]
        return max(self.arrivals[-1], g.not_before_s) + g.dwell_s

    def occupations(self) -> list[Occupation]:
        """The resources held and when (planned times, s): start node, each step, each stop, the park.

        Events are numbered per vehicle: step ``k`` starts at event ``2 k`` and arrives at ``2 k + 1``
        (:func:`start_event`, :func:`arrive_event`); stops of zero length are left out (the steps around
        them hold the node).
        """
        out: list[Occupation] = []
        first = self.steps[0].t_start if self.steps else INF
        out.append(Occupation(self.vehicle, self.model, ("node", self.start), self.ready_s, first, -1,
                              start_event(0) if self.steps else NEVER))
        for k, st in enumerate(self.steps):
            for r in st.resources():
                out.append(Occupation(self.vehicle, self.model, r, st.t_start, st.t_end, start_event(k),
                                      arrive_event(k)))
            nxt = self.steps[k + 1].t_start if k + 1 < len(self.steps) else INF
            if nxt > st.t_end:
                out.append(Occupation(self.vehicle, self.model, ("node", st.target), st.t_end, nxt, arrive_event(k),
                                      start_event(k + 1) if k + 1 < len(self.steps) else NEVER))
        return out


#: The release event of an occupation that lasts for ever (the vehicle parks).
NEVER = 1 << 60


def start_event(k: int) -> int:
    """Event number of step ``k``'s start (the vehicle enters its edge)."""
    return 2 * k


def arrive_event(k: int) -> int:
    """Event number of step ``k``'s arrival (the vehicle stands at its target node)."""
    return 2 * k + 1


@dataclass(frozen=True)
class Occupation:
    """``vehicle`` (``model``) holds ``resource`` over planned ``[t0, t1]`` (s).

    ``acquire``: the event at which it is taken (-1: held from the start); ``release``: the event at which
    it is given up (:data:`NEVER`: the vehicle parks). Events: :meth:`VehiclePlan.occupations`.
    """

    vehicle: str
    model: str
    resource: Resource
    t0: float
    t1: float
    acquire: int
    release: int


class Reservations:
    """Busy intervals (s) of every resource, per model of the vehicle that would hold it, by owner."""

    def __init__(self, zones: Conflicts, models: Sequence[str]) -> None:
        self.zones = zones
        self.models = tuple(dict.fromkeys(models))
        self._busy: dict[tuple[str, Resource], list[tuple[float, float, str]]] = {}
        self._cache: dict[tuple[str, Resource, str], frozenset[Resource]] = {}

    def _conflicts(self, model_a: str, res: Resource, model_b: str) -> frozenset[Resource]:
        key = (model_a, res, model_b)
        c = self._cache.get(key)
        if c is None:
            c = self._cache[key] = self.zones.conflicts(model_a, res, model_b)
        return c

    def add(self, occ: Occupation) -> None:
        """Reserve what ``occ`` makes busy for every model."""
        for mb in self.models:
            for r in self._conflicts(occ.model, occ.resource, mb):
                bisect.insort(self._busy.setdefault((mb, r), []), (occ.t0, occ.t1, occ.vehicle))

    def remove_vehicle(self, vehicle: str) -> None:
        """Forget every reservation of ``vehicle``."""
        for key, lst in self._busy.items():
            if any(v == vehicle for _, _, v in lst):
                self._busy[key] = [b for b in lst if b[2] != vehicle]

    def busy(self, model: str, res: Resource) -> list[tuple[float, float, str]]:
        """The intervals ``(t0, t1, owner)`` in which a ``model`` vehicle may not hold ``res``, sorted."""
        return self._busy.get((model, res), [])

    def safe_intervals(self, model: str, res: Resource) -> list[tuple[float, float]]:
        """The complement of :meth:`busy` on ``[0, inf)``: when ``res`` is free for ``model``."""
        out: list[tuple[float, float]] = []
        t = 0.0
        for a, b in _merged(self.busy(model, res)):
            if a > t:
                out.append((t, a))
            t = max(t, b)
        if t < INF:
            out.append((t, INF))
        return out

    def first_clash(self, model: str, res: Resource, t0: float, t1: float) -> float | None:
        """End (s) of the latest busy interval of ``res`` overlapping ``[t0, t1]``; None when it is free."""
        end: float | None = None
        for a, b, _ in self.busy(model, res):
            if a >= t1:
                break
            if b > t0 and (end is None or b > end):
                end = b
        return end


def _merged(lst: list[tuple[float, float, str]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for a, b, _ in lst:
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


@dataclass
class _Graph:
    """The traversals of one vehicle model, by source node, with drive times; heading classes per node."""

    network: RouteNetwork
    limits: VehicleLimits
    out: dict[str, list[tuple[Traversal, float, int, int]]] = field(default_factory=dict)
    classes: dict[str, list[float]] = field(default_factory=dict)

    @classmethod
    def build(cls, network: RouteNetwork, limits: VehicleLimits) -> _Graph:
        g = cls(network, limits)
        for n in network.nodes.values():
            g.classes[n.id] = [] if n.heading is None else [n.heading]
            g.out[n.id] = []
        for e in network.edges.values():
            if not e.allows(limits.model):
                continue
            dur = edge_time(e, limits)
            for m in e.modes:
                if m < 0 and not limits.reverses:
                    continue
                tr = Traversal(e, m)
                k0 = g.cls(e.source, tr.start_heading)
                k1 = g.cls(e.target, tr.end_heading)
                g.out[e.source].append((tr, dur, k0, k1))
        return g

    def cls(self, node: str, h: float) -> int:
        hs = self.classes[node]
        for i, c in enumerate(hs):
            if abs(wrap_angle_scalar(h - c)) <= HEADING_CLASS_TOL_RAD:
                return i
        hs.append(h)
        return len(hs) - 1

    def lower_bounds(self, goal: str) -> dict[str, float]:
        """Static shortest drive time (s) from every node to ``goal`` (headings ignored): the A* heuristic."""
        ids = list(self.network.nodes)
        index = {n: i for i, n in enumerate(ids)}
        rows, cols, w = [], [], []
        for u, lst in self.out.items():
            for tr, dur, _, _ in lst:
                rows.append(index[tr.edge.target])
                cols.append(index[u])
                w.append(dur + 1e-9)
        m = csr_matrix((w, (rows, cols)), shape=(len(ids), len(ids)))
        d = dijkstra(m, indices=[index[goal]], min_only=True)
        return {n: float(d[i]) for n, i in index.items()}


def _prep_time(g: _Graph, node: str, k: int, mode: int, k0: int, m: int) -> float | None:
    """Time (s) to get from heading class ``k``, direction ``mode`` to ``k0``, ``m`` at ``node`` (None: cannot)."""
    t = 0.0
    if k != k0 and k >= 0:
        if not g.limits.turns_on_spot:
            return None
        hs = g.classes[node]
        t += abs(wrap_angle_scalar(hs[k0] - hs[k])) / g.limits.turn_rate
    if mode != 0 and m != mode:
        t += g.limits.cusp_s
    return t


@dataclass(order=True)
class _Node:
    f: float
    tie: int
    t: float = field(compare=False)
    key: tuple[int, str, int, int, int] = field(compare=False)
    parent: _Node | None = field(compare=False, default=None)
    step: tuple[Traversal, float, float] | None = field(compare=False, default=None)


def plan_vehicle(task: VehicleTask, graph: _Graph, res: Reservations,
                 bounds: list[dict[str, float]] | None = None) -> VehiclePlan | None:
    """SIPP for one vehicle against ``res`` (module doc); None when its goals cannot all be reached."""
    model = task.limits.model
    goals = task.goals
    if bounds is None:
        bounds = [graph.lower_bounds(g.station) for g in goals]
    rest = _rest_bounds(goals, bounds)
    node_iv = _interval_cache(res, model)
    k_start = -1
    if task.start_heading is not None or graph.network.nodes[task.start].heading is not None:
        h0 = task.start_heading if task.start_heading is not None else graph.network.nodes[task.start].heading
        assert h0 is not None
        k_start = graph.cls(task.start, h0)
    ivs = node_iv(task.start)
    iv0 = _containing(ivs, task.ready_s)
    if iv0 is None:
        return None
    tie = 0
    start = _Node(0.0, 0, task.ready_s, (0, task.start, k_start, 0, iv0))
    start.f = task.ready_s + _h(start.key, bounds, rest)
    heap = [start]
    best: dict[tuple[int, str, int, int, int], float] = {start.key: task.ready_s}
    expansions = 0
    while heap and expansions < MAX_EXPANSIONS:
        cur = heapq.heappop(heap)
        if best.get(cur.key, INF) < cur.t:
            continue
        expansions += 1
        gi, node, k, mode, iv = cur.key
        iv_end = node_iv(node)[iv][1]
        if gi < len(goals) and node == goals[gi].station and _mode_ok(goals[gi], mode):
            g = goals[gi]
            leave = max(cur.t, g.not_before_s) + g.dwell_s
            last = gi + 1 == len(goals)
            if (last and iv_end == INF) or (not last and leave <= iv_end):
                nxt = _Node(0.0, tie, leave, (gi + 1, node, k, mode, iv), cur, None)
                if last:
                    return _unwind(task, nxt, goals)
                if leave < best.get(nxt.key, INF):
                    best[nxt.key] = leave
                    nxt.f = leave + _h(nxt.key, bounds, rest)
                    tie += 1
                    nxt.tie = tie
                    heapq.heappush(heap, nxt)
        if gi >= len(goals):
            continue
        for tr, dur, k0, k1 in graph.out[node]:
            prep = _prep_time(graph, node, k, mode, k0, tr.mode)
            if prep is None:
                continue
            for t_dep, iv1 in _departures(res, model, tr, dur, node_iv(tr.edge.target), cur.t + prep, iv_end):
                t_arr = t_dep + dur
                key = (gi, tr.edge.target, k1, tr.mode, iv1)
                if t_arr >= best.get(key, INF):
                    continue
                best[key] = t_arr
                tie += 1
                child = _Node(t_arr + _h(key, bounds, rest), tie, t_arr, key, cur, (tr, t_dep, t_arr))
                heapq.heappush(heap, child)
    return None


def _mode_ok(goal: Goal, mode: int) -> bool:
    return goal.arrive_mode is None or goal.arrive_mode == mode


def _rest_bounds(goals: Sequence[Goal], bounds: list[dict[str, float]]) -> list[float]:
    """Lower bound (s) of the work after reaching goal ``i``: dwells and the static times between goals."""
    rest = [0.0] * (len(goals) + 1)
    for i in range(len(goals) - 1, -1, -1):
        hop = bounds[i + 1][goals[i].station] if i + 1 < len(goals) else 0.0
        rest[i] = goals[i].dwell_s + (hop if math.isfinite(hop) else 0.0) + rest[i + 1]
    return rest


def _h(key: tuple[int, str, int, int, int], bounds: list[dict[str, float]], rest: list[float]) -> float:
    gi, node = key[0], key[1]
    if gi >= len(bounds):
        return 0.0
    return bounds[gi].get(node, INF) + rest[gi]


def _interval_cache(res: Reservations, model: str) -> _IntervalCache:
    return _IntervalCache(res, model)


class _IntervalCache:
    def __init__(self, res: Reservations, model: str) -> None:
        self.res, self.model = res, model
        self.memo: dict[str, list[tuple[float, float]]] = {}

    def __call__(self, node: str) -> list[tuple[float, float]]:
        v = self.memo.get(node)
        if v is None:
            v = self.memo[node] = self.res.safe_intervals(self.model, ("node", node))
        return v


def _containing(ivs: list[tuple[float, float]], t: float) -> int | None:
    for i, (a, b) in enumerate(ivs):
        if a <= t < b or (a <= t and b == INF):
            return i
    return None


def _departures(res: Reservations, model: str, tr: Traversal, dur: float, v_ivs: list[tuple[float, float]],
                t_ready: float, iv_end: float) -> list[tuple[float, int]]:
    """Earliest departure (s) into each safe interval of the target node (SIPP successors).

    The vehicle waits at the source node (free until ``iv_end``), then holds source, edge and target
    for ``dur`` s; the target must be free from the departure on.
    """
    out: list[tuple[float, int]] = []
    edge = ("edge", tr.edge.id)
    src = ("node", tr.edge.source)
    for j, (a, b) in enumerate(v_ivs):
        if b <= t_ready:
            continue
        t = max(t_ready, a)
        while t + dur <= iv_end and t < b:
            clash = None
            for r in (edge, src):
                c = res.first_clash(model, r, t, t + dur)
                if c is not None and (clash is None or c > clash):
                    clash = c
            if clash is None:
                break
            t = clash
        if t + dur > iv_end:
            break
        if t < b and t + dur < b:
            out.append((t, j))
    return out


def _unwind(task: VehicleTask, end: _Node, goals: Sequence[Goal]) -> VehiclePlan:
    chain: list[_Node] = []
    n: _Node | None = end
    while n is not None:
        chain.append(n)
        n = n.parent
    chain.reverse()
    steps: list[Step] = []
    arrivals = [INF] * len(goals)
    pending_dwell, pending_nb = 0.0, 0.0
    for node in chain:
        gi = node.key[0]
        if node.step is None:
            if node.parent is not None and gi > node.parent.key[0]:  # a goal reached: the stop
                g = goals[gi - 1]
                arrivals[gi - 1] = node.parent.t
                pending_dwell, pending_nb = g.dwell_s, g.not_before_s + g.dwell_s
                if steps:
                    steps[-1] = _with_arrival(steps[-1], gi - 1)
            continue
        tr, t0, t1 = node.step
        steps.append(Step(tr, tr.edge.source, tr.edge.target, t0, t1, gi, pending_dwell, pending_nb))
        pending_dwell, pending_nb = 0.0, 0.0
    for i, g in enumerate(goals):  # a goal at the start node is reached at once
        if not math.isfinite(arrivals[i]) and g.station == task.start and not steps:
            arrivals[i] = task.ready_s
    return VehiclePlan(task.vehicle, task.limits.model, task.start, tuple(steps), tuple(goals), tuple(arrivals),
                       task.ready_s)


def _with_arrival(st: Step, goal: int) -> Step:
    return Step(st.traversal, st.source, st.target, st.t_start, st.t_end, st.goal, st.dwell_s, st.not_before_s, goal)


@dataclass
class FleetPlan:
    """The plans of a fleet, in priority order; ``unserved``: vehicle -> why its goals were not planned."""

    plans: dict[str, VehiclePlan]
    unserved: dict[str, str]
    order: tuple[str, ...]
    plan_s: float = 0.0
    """wall time (s) the planning took."""


def plan_fleet(network: RouteNetwork, tasks: Sequence[VehicleTask], zones: Conflicts,
               graphs: Mapping[str, _Graph] | None = None) -> FleetPlan:
    """Prioritised planning (module doc): tasks in the order given; every start reserved until it is left.

    A vehicle whose goals cannot be reached stays at its start (reserved for ever) and is listed in
    ``unserved`` with the reason.
    """
    t_wall = time.perf_counter()
    res = Reservations(zones, [t.limits.model for t in tasks])
    g_by: dict[tuple[str, VehicleLimits], _Graph] = {}
    for t in tasks:
        if t.start not in network.nodes:
            raise ValueError(f"vehicle {t.vehicle!r}: unknown start node {t.start!r}")
        for g in t.goals:
            if g.station not in network.nodes:
                raise ValueError(f"vehicle {t.vehicle!r}: unknown station {g.station!r}")
        res.add(Occupation(t.vehicle, t.limits.model, ("node", t.start), t.ready_s, INF, -1, 0))
    plans: dict[str, VehiclePlan] = {}
    unserved: dict[str, str] = {}
    bound_cache: dict[tuple[str, VehicleLimits, str], dict[str, float]] = {}
    for t in tasks:
        key = (t.limits.model, t.limits)
        graph = (graphs or {}).get(t.limits.model) or g_by.get(key)
        if graph is None:
            graph = g_by[key] = _Graph.build(network, t.limits)
        bounds = []
        for g in t.goals:
            bk = (t.limits.model, t.limits, g.station)
            if bk not in bound_cache:
                bound_cache[bk] = graph.lower_bounds(g.station)
            bounds.append(bound_cache[bk])
        unreachable = _unreachable(t, bounds)
        res.remove_vehicle(t.vehicle)
        plan = None if unreachable else plan_vehicle(t, graph, res, bounds)
        if plan is None:
            unserved[t.vehicle] = unreachable or "the reservations of the vehicles planned before it never clear"
            plan = VehiclePlan(t.vehicle, t.limits.model, t.start, (), (), (), t.ready_s)
        plans[t.vehicle] = plan
        for occ in plan.occupations():
            res.add(occ)
    return FleetPlan(plans, unserved, tuple(t.vehicle for t in tasks), time.perf_counter() - t_wall)


def _unreachable(task: VehicleTask, bounds: list[dict[str, float]]) -> str | None:
    node = task.start
    for g, b in zip(task.goals, bounds, strict=True):
        if not np.isfinite(b.get(node, INF)):
            return f"no route from {node!r} to station {g.station!r} for a {task.limits.model}"
        node = g.station
    return None
