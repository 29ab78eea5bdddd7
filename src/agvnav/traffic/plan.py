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
arrives (it parks there), so a valid plan stays valid after its end. Before a vehicle is planned its
last goal is also reserved from the earliest time it could get there (static lower bound), so the
vehicles planned before it do not cross it later (prioritised planning with reserved end points:
fewer vehicles sent to wait for a goal that others keep crossing, and far fewer search expansions).

Speed: the search runs on integers (:class:`TrafficIndex`, kernels in :mod:`agvnav.traffic._sipp`,
compiled by numba): the conflict relation, each model's traversals and the reverse-Dijkstra lower
bound of each goal are computed once per network and kept; replanning costs the searches only. A
search's best times live in a dense scratch table kept per model graph (each search cleans the entries
it touched), not a hash map; a vehicle's touching busy intervals on a resource are merged into one;
the occupations reserved for a planned vehicle come from the search's chain of states (the same as
:func:`occupation_arrays` of its plan, ``tests/traffic/test_plan_tables.py``). ``agvnav bench traffic``:
100 vehicles on a 2,025-node grid, fresh goals each time (their Dijkstras included), about 70-90 ms.

Each vehicle's work is a list of :class:`Goal` (a station, the dwell there, the earliest time the
dwell may start: a job's release). All goals of a vehicle are searched in one SIPP (the goal index
is part of the state), so a later goal never fails because of how an earlier one was reached
when another way would do. A vehicle whose goals cannot all be reached (a station no route
leads to, or reservations that never clear) is reported in :attr:`FleetPlan.unserved`, never
left planned half-way.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry.angles import wrap_angle_scalar
from agvnav.routes.network import RouteNetwork
from agvnav.routes.planning import HEADING_CLASS_TOL_RAD, Traversal, VehicleLimits, edge_time
from agvnav.traffic._sipp import (
    chain_occupations,
    dijkstra_to,
    release,
    release_held,
    reserve,
    safe_intervals,
    scratch_size,
    sipp,
)

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
    "TrafficIndex",
    "VehiclePlan",
    "VehicleTask",
    "arrive_event",
    "occupation_arrays",
    "plan_fleet",
    "plan_vehicle",
    "start_event",
    "traffic_index",
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


class Step(NamedTuple):
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
    reached: int = 0
    """how many goals in a row (from ``arrives`` on) are reached at ``target`` (a drop, then the next pick)."""

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


class TrafficIndex:
    """Compact integer indexing of a network and its conflict relation, built once and reused.

    Node ``i`` of ``network.nodes`` is resource ``i``, edge ``j`` of ``network.edges`` is resource
    ``n_nodes + j`` (:mod:`agvnav.traffic._sipp`). The conflict relation of each pair of models is
    asked of ``zones`` once per resource and kept as a CSR; each vehicle model's traversals, heading
    classes and static lower bounds (one reverse Dijkstra per goal) are kept too, so replanning a
    fleet costs the searches only.
    """

    def __init__(self, network: RouteNetwork, zones: Conflicts) -> None:
        self.network = network
        self.zones = zones
        self.node_ids = list(network.nodes)
        self.node_index = {n: i for i, n in enumerate(self.node_ids)}
        self.n_nodes = len(self.node_ids)
        self.edge_index = {e: self.n_nodes + j for j, e in enumerate(network.edges)}
        self.n_res = self.n_nodes + len(self.edge_index)
        self._conf: dict[tuple[str, str], tuple[NDArray[np.int64], NDArray[np.int64]]] = {}
        self._graphs: dict[VehicleLimits, _Graph] = {}

    def resource(self, r: Resource) -> int:
        """The integer of resource ``r``."""
        return self.node_index[r[1]] if r[0] == "node" else self.edge_index[r[1]]

    def conf(self, model_a: str, model_b: str) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """CSR ``(ptr, idx)``: the resources of ``model_b`` that ``model_a`` holding resource ``q`` makes busy."""
        key = (model_a, model_b)
        c = self._conf.get(key)
        if c is None:
            ptr = np.zeros(self.n_res + 1, dtype=np.int64)
            idx: list[int] = []
            res = [("node", n) for n in self.node_ids] + [("edge", e) for e in self.network.edges]
            for q, r in enumerate(res):
                idx += sorted(self.resource(x) for x in self.zones.conflicts(model_a, r, model_b))
                ptr[q + 1] = len(idx)
            c = self._conf[key] = (ptr, np.asarray(idx, dtype=np.int64))
        return c

    def graph(self, limits: VehicleLimits) -> _Graph:
        """The planning graph of a vehicle model (built once)."""
        g = self._graphs.get(limits)
        if g is None:
            g = self._graphs[limits] = _Graph.build(self, limits)
        return g


_INDEX_CACHE: dict[tuple[int, int], TrafficIndex] = {}


def traffic_index(network: RouteNetwork, zones: Conflicts) -> TrafficIndex:
    """The :class:`TrafficIndex` of ``network`` and ``zones`` (the last few are kept)."""
    key = (id(network), id(zones))
    idx = _INDEX_CACHE.get(key)
    if idx is None or idx.network is not network or idx.zones is not zones:
        if len(_INDEX_CACHE) >= 4:
            _INDEX_CACHE.pop(next(iter(_INDEX_CACHE)))
        idx = _INDEX_CACHE[key] = TrafficIndex(network, zones)
    return idx


class Reservations:
    """Busy intervals (s) of every resource per model of the vehicle that would hold it, with their owner.

    Kept as ``(R, cap)`` arrays sorted by start (:mod:`agvnav.traffic._sipp`); ``cap`` doubles when a
    resource fills up.
    """

    def __init__(self, index: TrafficIndex, models: Sequence[str], cap: int = 32) -> None:
        self.index = index
        self.models = tuple(dict.fromkeys(models))
        r = index.n_res
        self.b0 = {m: np.empty((r, cap)) for m in self.models}
        self.b1 = {m: np.empty((r, cap)) for m in self.models}
        self.bo = {m: np.empty((r, cap), dtype=np.int64) for m in self.models}
        self.bn = {m: np.zeros(r, dtype=np.int64) for m in self.models}
        self._owner: dict[str, int] = {}

    def owner(self, vehicle: str) -> int:
        """The integer of ``vehicle``."""
        return self._owner.setdefault(vehicle, len(self._owner))

    def add_arrays(self, vehicle: str, model: str, qs: NDArray[np.int64], t0s: NDArray[np.float64],
                   t1s: NDArray[np.float64]) -> None:
        """Reserve what ``vehicle`` (``model``) holding resources ``qs`` over ``[t0s, t1s]`` makes busy."""
        o = self.owner(vehicle)
        for mb in self.models:
            ptr, idx = self.index.conf(model, mb)
            i = 0
            while True:
                i += reserve(ptr, idx, qs[i:], t0s[i:], t1s[i:], o, self.b0[mb], self.b1[mb], self.bo[mb],
                             self.bn[mb])
                if i >= len(qs):
                    break
                self._grow(mb)

    def _grow(self, mb: str) -> None:
        cap = self.b0[mb].shape[1]
        for arrs in (self.b0, self.b1, self.bo):
            a = arrs[mb]
            arrs[mb] = np.empty((a.shape[0], 2 * cap), dtype=a.dtype)
            arrs[mb][:, :cap] = a

    def add(self, occ: Occupation) -> None:
        """Reserve what ``occ`` makes busy for every model."""
        self.add_arrays(occ.vehicle, occ.model, np.array([self.index.resource(occ.resource)], dtype=np.int64),
                        np.array([occ.t0]), np.array([occ.t1]))

    def release(self, vehicle: str, model: str, held: Sequence[Resource]) -> None:
        """Forget what ``vehicle`` holding ``held`` made busy."""
        qs = np.array([self.index.resource(r) for r in held], dtype=np.int64)
        self.release_arrays(vehicle, model, qs)

    def release_arrays(self, vehicle: str, model: str, qs: NDArray[np.int64]) -> None:
        """Forget what ``vehicle`` holding the resources ``qs`` (integers of the index) made busy."""
        o = self.owner(vehicle)
        for mb in self.models:
            ptr, idx = self.index.conf(model, mb)
            release_held(ptr, idx, qs, o, self.b0[mb], self.b1[mb], self.bo[mb], self.bn[mb])

    def remove_vehicle(self, vehicle: str) -> None:
        """Forget every reservation of ``vehicle``."""
        o = self.owner(vehicle)
        rows = np.arange(self.index.n_res, dtype=np.int64)
        for mb in self.models:
            release(rows, o, self.b0[mb], self.b1[mb], self.bo[mb], self.bn[mb])

    def busy(self, model: str, res: Resource) -> list[tuple[float, float]]:
        """The intervals ``(t0, t1)`` (s) in which a ``model`` vehicle may not hold ``res``, sorted by start."""
        q = self.index.resource(res)
        n = int(self.bn[model][q])
        return [(float(a), float(b)) for a, b in zip(self.b0[model][q, :n], self.b1[model][q, :n], strict=True)]

    def safe_intervals(self, model: str, res: Resource) -> list[tuple[float, float]]:
        """The complement of :meth:`busy` on ``[0, inf)``: when ``res`` is free for ``model``."""
        q = self.index.resource(res)
        cap = self.b0[model].shape[1] + 1
        a, b = np.empty(cap), np.empty(cap)
        m = safe_intervals(self.b0[model][q], self.b1[model][q], int(self.bn[model][q]), a, b)
        return [(float(a[i]), float(b[i])) for i in range(m)]


class _Graph:
    """One vehicle model's traversals as arrays (CSR by source node), heading classes, static lower bounds."""

    def __init__(self, index: TrafficIndex, limits: VehicleLimits) -> None:
        self.index, self.limits = index, limits
        self.classes: list[list[float]] = []
        self.travs: list[Traversal] = []
        self.ends: list[tuple[Traversal, str, str]] = []
        """per traversal: itself, its source and target node ids."""
        self._flat: tuple[NDArray[np.int64], NDArray[np.float64]] | None = None
        self._bounds: dict[int, NDArray[np.float64]] = {}
        self._best_at = self._iv_at = np.zeros(0, dtype=np.int64)
        empty_i, empty_f = np.zeros(0, dtype=np.int64), np.zeros(0)
        self.order = self.src = self.dst = self.k0 = self.k1 = self.mode = self.res = empty_i
        self.out_ptr = self.rev_ptr = self.rev_from = empty_i
        self.dur = self.rev_w = empty_f

    @classmethod
    def build(cls, index: TrafficIndex, limits: VehicleLimits) -> _Graph:
        g = cls(index, limits)
        net = index.network
        g.classes = [[] if net.nodes[n].heading is None else [float(net.nodes[n].heading)]  # type: ignore[arg-type]
                     for n in index.node_ids]
        rows: list[tuple[int, int, float, int, int, int, int]] = []
        for e in net.edges.values():
            if not e.allows(limits.model):
                continue
            dur = edge_time(e, limits)
            u, v = index.node_index[e.source], index.node_index[e.target]
            for m in e.modes:
                if m < 0 and not limits.reverses:
                    continue
                tr = Traversal(e, m)
                rows.append((u, v, dur, g.cls(u, tr.start_heading), g.cls(v, tr.end_heading), m, len(g.travs)))
                g.travs.append(tr)
        rows.sort(key=lambda r: r[0])
        n = index.n_nodes
        g.order = np.array([r[6] for r in rows], dtype=np.int64)
        src = np.array([r[0] for r in rows], dtype=np.int64)
        g.travs = [g.travs[i] for i in g.order]
        g.ends = [(t, t.edge.source, t.edge.target) for t in g.travs]
        g.src = src
        g.dst = np.array([r[1] for r in rows], dtype=np.int64)
        g.dur = np.array([r[2] for r in rows], dtype=np.float64)
        g.k0 = np.array([r[3] for r in rows], dtype=np.int64)
        g.k1 = np.array([r[4] for r in rows], dtype=np.int64)
        g.mode = np.array([r[5] for r in rows], dtype=np.int64)
        g.res = np.array([index.edge_index[t.edge.id] for t in g.travs], dtype=np.int64)
        g.out_ptr = np.searchsorted(src, np.arange(n + 1)).astype(np.int64)
        rev = np.argsort(g.dst, kind="stable")
        g.rev_ptr = np.searchsorted(g.dst[rev], np.arange(n + 1)).astype(np.int64)
        g.rev_from = src[rev]
        g.rev_w = g.dur[rev] + 1e-9
        return g

    def scratch(self, cls_ptr: NDArray[np.int64], n_goals: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """The scratch tables of :func:`agvnav.traffic._sipp.sipp` (all -1; each search leaves them so), kept."""
        size = int(scratch_size(cls_ptr, n_goals))
        if len(self._best_at) < size:
            self._best_at = np.full(size, -1, dtype=np.int64)
        if len(self._iv_at) != self.index.n_nodes:
            self._iv_at = np.full(self.index.n_nodes, -1, dtype=np.int64)
        return self._best_at, self._iv_at

    def cls(self, node: int, h: float) -> int:
        """The heading class of ``h`` (rad) at node ``node`` (a new one when none is within the tolerance)."""
        hs = self.classes[node]
        for i, c in enumerate(hs):
            if abs(wrap_angle_scalar(h - c)) <= HEADING_CLASS_TOL_RAD:
                return i
        hs.append(h)
        self._flat = None
        return len(hs) - 1

    def flat_classes(self) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """``(cls_ptr, cls_h)``: the heading classes of every node, flat."""
        if self._flat is None:
            ptr = np.zeros(len(self.classes) + 1, dtype=np.int64)
            ptr[1:] = np.cumsum([len(c) for c in self.classes])
            h = np.array([x for c in self.classes for x in c], dtype=np.float64)
            self._flat = (ptr, h)
        return self._flat

    def lower_bounds(self, goal: int) -> NDArray[np.float64]:
        """Static shortest drive time (s) from every node to node ``goal`` (headings ignored): the A* heuristic."""
        b = self._bounds.get(goal)
        if b is None:
            b = self._bounds[goal] = dijkstra_to(goal, self.rev_ptr, self.rev_from, self.rev_w, self.index.n_nodes)
        return b


def plan_vehicle(task: VehicleTask, graph: _Graph, res: Reservations,
                 bounds: Sequence[NDArray[np.float64]] | None = None) -> VehiclePlan | None:
    """SIPP for one vehicle against ``res`` (module doc); None when its goals cannot all be reached."""
    out = _plan_vehicle(task, graph, res, bounds)
    return None if out is None else out[0]


def _plan_vehicle(task: VehicleTask, graph: _Graph, res: Reservations,
                  bounds: Sequence[NDArray[np.float64]] | None = None
                  ) -> tuple[VehiclePlan, tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]] | None:
    """:func:`plan_vehicle` and its :func:`occupation_arrays` (computed from the search's chain)."""
    ix = graph.index
    goals = task.goals
    gnode = np.array([ix.node_index[g.station] for g in goals], dtype=np.int64)
    if bounds is None:
        bounds = [graph.lower_bounds(int(n)) for n in gnode]
    start = ix.node_index[task.start]
    h0 = task.start_heading if task.start_heading is not None else ix.network.nodes[task.start].heading
    k_start = -1 if h0 is None else graph.cls(start, h0)
    cls_ptr, cls_h = graph.flat_classes()
    h = np.stack(bounds) if goals else np.zeros((0, ix.n_nodes))
    rest = _rest_bounds(goals, h, gnode)
    lim, model = graph.limits, graph.limits.model
    tr, dep, t, _ = sipp(graph.out_ptr, graph.dst, graph.dur, graph.k0, graph.k1, graph.mode, graph.res, cls_ptr, cls_h,
                      lim.turn_rate, lim.turns_on_spot, lim.cusp_s, gnode,
                      np.array([g.dwell_s for g in goals]), np.array([g.not_before_s for g in goals]),
                      np.array([2 if g.arrive_mode is None else g.arrive_mode for g in goals], dtype=np.int64),
                      h, rest, res.b0[model], res.b1[model], res.bn[model], start, k_start, task.ready_s,
                      MAX_EXPANSIONS, *graph.scratch(cls_ptr, len(goals)))
    if len(tr) == 0:
        return None
    occ = chain_occupations(tr, dep, t, graph.src, graph.dst, graph.res, start, task.ready_s)
    return _unwind(task, graph, tr.tolist(), dep.tolist(), t.tolist()), occ


def _rest_bounds(goals: Sequence[Goal], h: NDArray[np.float64], gnode: NDArray[np.int64]) -> NDArray[np.float64]:
    """Lower bound (s) of the work after reaching goal ``i``: dwells and the static times between goals."""
    rest = np.zeros(len(goals) + 1)
    for i in range(len(goals) - 1, -1, -1):
        hop = float(h[i + 1, gnode[i]]) if i + 1 < len(goals) else 0.0
        rest[i] = goals[i].dwell_s + (hop if math.isfinite(hop) else 0.0) + rest[i + 1]
    return rest


def _unwind(task: VehicleTask, graph: _Graph, tr: list[int], dep: list[float], t: list[float]) -> VehiclePlan:
    """The plan of the chain of states the search returned (:func:`agvnav.traffic._sipp.sipp`)."""
    goals = task.goals
    steps: list[Step] = []
    arrivals = [INF] * len(goals)
    pending_dwell, pending_nb = 0.0, 0.0
    gi = 0
    for i in range(1, len(tr)):
        if tr[i] == -1:  # a goal reached: the stop (several goals at one node: their dwells add up)
            g = goals[gi]
            arrivals[gi] = t[i - 1] if tr[i - 1] != -1 else arrivals[gi - 1]
            pending_nb = max(pending_nb + g.dwell_s, g.not_before_s + g.dwell_s)
            pending_dwell += g.dwell_s
            if steps:
                steps[-1] = _with_arrival(steps[-1], gi)
            gi += 1
            continue
        trav, source, target = graph.ends[tr[i]]
        # tuple.__new__ with every field: a Step without the NamedTuple's Python-level constructor (hot: a fleet
        # replan makes thousands)
        steps.append(_new_step(Step, (trav, source, target, dep[i], t[i], gi, pending_dwell, pending_nb, None, 0)))
        pending_dwell, pending_nb = 0.0, 0.0
    return VehiclePlan(task.vehicle, task.limits.model, task.start, tuple(steps), tuple(goals), tuple(arrivals),
                       task.ready_s)


_new_step = tuple.__new__


def _with_arrival(st: Step, goal: int) -> Step:
    if st.arrives is None:
        return st._replace(arrives=goal, reached=1)
    return st._replace(reached=st.reached + 1)


def occupation_arrays(plan: VehiclePlan, index: TrafficIndex
                      ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """:meth:`VehiclePlan.occupations` as arrays ``(resource, t0, t1)`` (resources of ``index``)."""
    ni, ei = index.node_index, index.edge_index
    q: list[int] = [ni[plan.start]]
    t0: list[float] = [plan.ready_s]
    t1: list[float] = [plan.steps[0].t_start if plan.steps else INF]
    n = len(plan.steps)
    for k, st in enumerate(plan.steps):
        u, v = ni[st.source], ni[st.target]
        q += (u, ei[st.edge], v)
        t0 += (st.t_start, st.t_start, st.t_start)
        t1 += (st.t_end, st.t_end, st.t_end)
        nxt = plan.steps[k + 1].t_start if k + 1 < n else INF
        if nxt > st.t_end:
            q.append(v)
            t0.append(st.t_end)
            t1.append(nxt)
    return np.array(q, dtype=np.int64), np.array(t0), np.array(t1)


@dataclass
class FleetPlan:
    """The plans of a fleet, in priority order; ``unserved``: vehicle -> why its goals were not planned."""

    plans: dict[str, VehiclePlan]
    unserved: dict[str, str]
    order: tuple[str, ...]
    plan_s: float = 0.0
    """wall time (s) the planning took."""


def plan_fleet(network: RouteNetwork, tasks: Sequence[VehicleTask], zones: Conflicts,
               index: TrafficIndex | None = None, committed: Sequence[Occupation] = (),
               start_hold_s: float = INF) -> FleetPlan:
    """Prioritised planning (module doc): tasks in the order given; every start reserved until it is left.

    A vehicle whose goals cannot be reached stays at its start (reserved for ever) and is listed in
    ``unserved`` with the reason. ``index``: the network's :class:`TrafficIndex` (default: kept per
    network and zones, :func:`traffic_index`). ``committed``: occupations already decided (a step under
    way, a vehicle parked, when replanning): reserved for every task and never released. ``start_hold_s``:
    how long (s) after its ready time the start of a vehicle not yet planned stays reserved (default for
    ever; when replanning vehicles that stand on the lanes, some tens of seconds: a vehicle planned before it may
    then pass its start later, and it must leave before, or it is unserved).
    """
    t_wall = time.perf_counter()
    ix = index if index is not None else traffic_index(network, zones)
    res = Reservations(ix, [t.limits.model for t in tasks] + [o.model for o in committed])
    for o in committed:
        res.add(dataclasses.replace(o, vehicle=f"{o.vehicle}@committed"))
    for t in tasks:
        if t.start not in network.nodes:
            raise ValueError(f"vehicle {t.vehicle!r}: unknown start node {t.start!r}")
        for g in t.goals:
            if g.station not in network.nodes:
                raise ValueError(f"vehicle {t.vehicle!r}: unknown station {g.station!r}")
    bounds_of = {t.vehicle: [ix.graph(t.limits).lower_bounds(ix.node_index[g.station]) for g in t.goals]
                 for t in tasks}
    held: dict[str, tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]] = {}
    why: dict[str, str | None] = {}
    for t in tasks:
        why[t.vehicle] = _unreachable(t, bounds_of[t.vehicle], ix)
        held[t.vehicle] = ends = _endpoints(t, bounds_of[t.vehicle], ix, start_hold_s, why[t.vehicle] is None)
        res.add_arrays(t.vehicle, t.limits.model, *ends)
    plans: dict[str, VehiclePlan] = {}
    unserved: dict[str, str] = {}
    for t in tasks:
        graph = ix.graph(t.limits)
        bounds = bounds_of[t.vehicle]
        unreachable = why[t.vehicle]
        held_q = held[t.vehicle][0]
        res.release_arrays(t.vehicle, t.limits.model, held_q)
        out = None if unreachable else _plan_vehicle(t, graph, res, bounds)
        if out is None:
            unserved[t.vehicle] = unreachable or "the reservations of the vehicles planned before it never clear"
            plan = VehiclePlan(t.vehicle, t.limits.model, t.start, (), (), (), t.ready_s)
            occ = occupation_arrays(plan, ix)
        else:
            plan, occ = out
        plans[t.vehicle] = plan
        res.add_arrays(t.vehicle, t.limits.model, *occ)
    return FleetPlan(plans, unserved, tuple(t.vehicle for t in tasks), time.perf_counter() - t_wall)


def _endpoints(task: VehicleTask, bounds: list[NDArray[np.float64]], ix: TrafficIndex, start_hold_s: float = INF,
               reachable: bool | None = None
               ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """The reservations a vehicle holds before it is planned: its start from its ready time on, and its
    last goal from the earliest time it could get there on (module doc)."""
    q, t0 = [ix.node_index[task.start]], [task.ready_s]
    if reachable is None:
        reachable = _unreachable(task, bounds, ix) is None
    if task.goals and reachable:
        g = task.goals[-1]
        h = np.stack(bounds)
        gnode = np.array([ix.node_index[x.station] for x in task.goals], dtype=np.int64)
        earliest = task.ready_s + float(h[0, q[0]]) + float(_rest_bounds(task.goals, h, gnode)[0]) - g.dwell_s
        q.append(ix.node_index[g.station])
        t0.append(earliest)
    t1 = np.full(len(q), INF)
    t1[0] = task.ready_s + start_hold_s
    return np.array(q, dtype=np.int64), np.array(t0), t1


def _unreachable(task: VehicleTask, bounds: list[NDArray[np.float64]], ix: TrafficIndex) -> str | None:
    node = task.start
    for g, b in zip(task.goals, bounds, strict=True):
        if not np.isfinite(b[ix.node_index[node]]):
            return f"no route from {node!r} to station {g.station!r} for a {task.limits.model}"
        node = g.station
    return None
