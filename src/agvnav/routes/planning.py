"""Shortest-time routes on a route network, with the vehicle's heading in the state [seed003 §3.5].

A tricycle cannot turn on the spot: at a node it can only leave along an edge
whose departure heading equals its arrival heading. The planning state is
therefore ``(node, heading, direction of travel)``, not the node alone:

* the vehicle heading when it drives an edge is the tangent (facing forward, +1)
  or the tangent + pi (backing up, -1); headings at a node are grouped into
  classes within :data:`HEADING_CLASS_TOL_RAD`;
* an edge driven in mode ``m`` links ``(u, heading at the start, any)`` to
  ``(v, heading at the end, m)`` at the cost of its drive time; changing the
  direction of travel at a node (a cusp: stop and reverse) costs ``cusp_s``;
* vehicles that turn on the spot (differential, tracked, mecanum) may change
  heading class at a node at the cost ``|dpsi| / turn_rate``;
* an edge's drive time is ``integral ds / v(s)`` with ``v`` the smallest of the
  edge's speed limit, the vehicle's speed and ``sqrt(a_lat / |kappa|)`` (lateral
  acceleration limit).

The state graph is a sparse matrix (CSR), rebuilt only when the blocked edges change.
With the kernels compiled (:mod:`agvnav._jit`) it is searched by A* (:func:`astar_kernel`,
a binary heap over the CSR arrays). Its heuristic is the largest of two lower bounds of the
time left: ``|p - p_goal| / v_max`` (every edge's drive time is at least its length over
``v_max``, a path is at least as long as the straight line, a spot turn or cusp costs time and
no distance) and ALT's landmark bounds (:data:`LANDMARKS` far-apart nodes; their times to and
from every state are computed once per state graph; by the triangle inequality
``d(v, T) >= d(L, T) - d(L, v)`` and ``d(v, T) >= d(v, L) - d(T, L)``). Both are consistent, so
A* returns a fastest route (within :data:`QUEUE_RESOLUTION_S`) while settling only states near
it; per-query work is proportional to what it settles (visited states are marked by a query
stamp, so no array of the graph's size is cleared per query). Interpreted, the same
graph is searched by Dijkstra (``scipy.sparse.csgraph.dijkstra``), first limited to
``3 d / v_max + 60 s`` (``d`` the straight-line distance) and repeated without limit only
if the goal lies beyond. Both give the fastest time; where several routes tie, they may
pick different ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from agvnav._jit import by_mode, jit
from agvnav.geometry.angles import wrap_angle
from agvnav.routes.network import Edge, Node, RouteNetwork
from agvnav.world.vehicle_specs import vehicle_kind

__all__ = [
    "HEADING_CLASS_TOL_RAD",
    "NoRouteError",
    "Planner",
    "Route",
    "Traversal",
    "VehicleLimits",
    "astar_kernel",
    "edge_time",
]

#: Headings at a node closer than this (rad) are one heading class.
HEADING_CLASS_TOL_RAD = math.radians(2.0)


class NoRouteError(ValueError):
    """No route exists; the message names the station that cannot be reached."""


@dataclass(frozen=True)
class VehicleLimits:
    """What the planner needs to know of a vehicle.

    ``model`` (a vehicle kind's name, :data:`agvnav.world.vehicle_specs.VEHICLE_KINDS`),
    ``max_speed`` (m/s), ``lateral_accel`` (m/s^2),
    ``turn_rate`` (rad/s, turning on the spot), ``cusp_s`` (s lost stopping to reverse).
    """

    model: str
    max_speed: float = 1.0
    lateral_accel: float = 0.5
    turn_rate: float = 0.5
    cusp_s: float = 4.0

    def __post_init__(self) -> None:
        vehicle_kind(self.model)  # ValueError naming the valid models
        for name in ("max_speed", "lateral_accel", "turn_rate"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        if not (math.isfinite(self.cusp_s) and self.cusp_s >= 0.0):
            raise ValueError(f"cusp_s must be >= 0, got {self.cusp_s!r}")

    @property
    def turns_on_spot(self) -> bool:
        """True for the kinds that turn at standstill (differential, tracked, mecanum)."""
        return vehicle_kind(self.model).turns_on_spot

    @property
    def reverses(self) -> bool:
        """False for the kinds that may not back up (the tractor-trailer)."""
        return vehicle_kind(self.model).reverses


@dataclass(frozen=True)
class Traversal:
    """One edge driven in ``mode`` (+1 facing forward, -1 backing up)."""

    edge: Edge
    mode: int

    @property
    def start_heading(self) -> float:
        """Vehicle heading (rad) when it enters the edge."""
        return float(wrap_angle(self.edge.curve.start_heading + (math.pi if self.mode < 0 else 0.0)))

    @property
    def end_heading(self) -> float:
        """Vehicle heading (rad) when it leaves the edge."""
        return float(wrap_angle(self.edge.curve.end_heading + (math.pi if self.mode < 0 else 0.0)))


@dataclass(frozen=True)
class Route:
    """A planned route: the traversals in order, the nodes passed and the planned time (s)."""

    traversals: tuple[Traversal, ...]
    nodes: tuple[str, ...]
    time_s: float


def edge_time(edge: Edge, vehicle: VehicleLimits) -> float:
    """Drive time (s) of ``edge`` at the capped speed ``min(limit, v_max, sqrt(a_lat/|kappa|))`` (module doc)."""
    k = np.abs(edge.curve.curvatures)
    with np.errstate(divide="ignore"):
        v_curv = np.sqrt(vehicle.lateral_accel / np.maximum(k, 1e-12))
    v = np.minimum(min(edge.speed, vehicle.max_speed), v_curv)
    v_mid = np.minimum(v[:-1], v[1:])
    ds = edge.curve.length / (len(v) - 1)
    return float(np.sum(ds / v_mid))


class _Classes:
    """Heading classes of one node (representative headings, rad)."""

    def __init__(self) -> None:
        self.headings: list[float] = []

    def index(self, h: float) -> int:
        for i, c in enumerate(self.headings):
            if abs(float(wrap_angle(h - c))) <= HEADING_CLASS_TOL_RAD:
                return i
        self.headings.append(h)
        return len(self.headings) - 1


class Planner:
    """Shortest-time planner on a :class:`RouteNetwork` for one vehicle (see the module doc).

    ``blocked``: edge ids that may not be used (a reverse twin ``id~r`` is blocked with ``id``);
    :meth:`block` replaces them and rebuilds the state graph.
    """

    def __init__(self, network: RouteNetwork, vehicle: VehicleLimits, blocked: tuple[str, ...] = ()) -> None:
        self.network = network
        self.vehicle = vehicle
        self._times = {e.id: edge_time(e, vehicle) for e in network.edges.values() if e.allows(vehicle.model)}
        self.block(blocked)

    @property
    def states(self) -> int:
        """How many (node, heading class, direction) states the search graph has."""
        return int(self._n)

    def block(self, blocked: tuple[str, ...] | list[str]) -> None:
        """Block these edges (ValueError for an unknown id) and rebuild the state graph."""
        for b in blocked:
            if b not in self.network.edges:
                raise ValueError(f"blocked edge {b!r} is not in the network")
        self.blocked = frozenset(blocked) | frozenset(b + "~r" for b in blocked)
        self._build()

    def _usable(self) -> list[Traversal]:
        out = []
        for e in self.network.edges.values():
            if e.id in self.blocked or e.id not in self._times:
                continue
            out += [Traversal(e, m) for m in e.modes if m > 0 or self.vehicle.reverses]
        return out

    def _build(self) -> None:
        classes: dict[str, _Classes] = {n: _Classes() for n in self.network.nodes}
        for node in self.network.nodes.values():
            if node.heading is not None:
                classes[node.id].index(node.heading)
        travs = self._usable()
        ends = [(classes[t.edge.source].index(t.start_heading), classes[t.edge.target].index(t.end_heading))
                for t in travs]
        offset, base = {}, 0
        for n, c in classes.items():
            offset[n] = base
            base += 2 * len(c.headings)
        rows: list[int] = []
        cols: list[int] = []
        cost: list[float] = []
        for t, (k0, k1) in zip(travs, ends, strict=True):
            u, v = offset[t.edge.source] + 2 * k0, offset[t.edge.target] + 2 * k1 + (0 if t.mode > 0 else 1)
            same = 0 if t.mode > 0 else 1
            rows += [u + same, u + 1 - same]
            cols += [v, v]
            cost += [self._times[t.edge.id], self._times[t.edge.id] + self.vehicle.cusp_s]
        if self.vehicle.turns_on_spot:
            self._spot_turns(classes, offset, rows, cols, cost)
        self._classes, self._offset, self._n = classes, offset, base
        self._edge_of: dict[tuple[int, int], Traversal] = {}
        for t, (k0, k1) in zip(travs, ends, strict=True):
            v = offset[t.edge.target] + 2 * k1 + (0 if t.mode > 0 else 1)
            for m in (0, 1):
                key = (offset[t.edge.source] + 2 * k0 + m, v)
                if key not in self._edge_of or self._times[t.edge.id] < self._times[self._edge_of[key].edge.id]:
                    self._edge_of[key] = t
        self._graph = _min_duplicates(rows, cols, cost, base)
        self._search = _Search(self._graph, *self._state_nodes(classes, offset, base))
        self._travs = list(dict.fromkeys(self._edge_of.values()))
        index = {id(t): k for k, t in enumerate(self._travs)}
        tails = np.repeat(np.arange(base), np.diff(self._graph.indptr)).tolist()
        heads = self._graph.indices.tolist()
        self._trav_of_arc = np.array([index[id(self._edge_of[(u, v)])] if (u, v) in self._edge_of else -1
                                      for u, v in zip(tails, heads, strict=True)], dtype=np.int64)

    def _state_nodes(self, classes: dict[str, _Classes], offset: dict[str, int], n: int
                     ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Position (m) of each state's node, (n, 2), and the node's index, (n,)."""
        xy = np.zeros((n, 2))
        node_of = np.zeros(n, dtype=np.int64)
        for k, (node, c) in enumerate(classes.items()):
            nd = self.network.nodes[node]
            xy[offset[node]:offset[node] + 2 * len(c.headings)] = (nd.x, nd.y)
            node_of[offset[node]:offset[node] + 2 * len(c.headings)] = k
        return xy, node_of

    def _spot_turns(
        self, classes: dict[str, _Classes], offset: dict[str, int], rows: list[int], cols: list[int], cost: list[float]
    ) -> None:
        for n, c in classes.items():
            hs = c.headings
            for i, hi in enumerate(hs):
                for j, hj in enumerate(hs):
                    if i == j:
                        continue
                    dt = abs(float(wrap_angle(hj - hi))) / self.vehicle.turn_rate
                    for m in (0, 1):
                        rows.append(offset[n] + 2 * i + m)
                        cols.append(offset[n] + 2 * j + m)
                        cost.append(dt)

    def _states(self, node: str, heading: float | None, mode: int | None) -> list[int]:
        c = self._classes[node]
        ks: list[int] = list(range(len(c.headings)))
        if heading is not None:
            ks = [k for k in ks if abs(float(wrap_angle(c.headings[k] - heading))) <= HEADING_CLASS_TOL_RAD]
        ms = (0, 1) if mode is None else ((0,) if mode > 0 else (1,))
        return [self._offset[node] + 2 * k + m for k in ks for m in ms]

    def plan(
        self, start: str, goal: str, start_heading: float | None = None, arrive_mode: int | None = None
    ) -> Route:
        """Fastest route from node ``start`` to node ``goal``.

        ``start_heading`` (rad): the vehicle's heading at the start (default the node's
        heading, or any); ``arrive_mode`` -1 requires backing into ``goal`` (+1: facing
        forward). Raises :class:`NoRouteError` naming the station that cannot be reached.
        """
        for name in (start, goal):
            if name not in self.network.nodes:
                raise NoRouteError(f"unknown station {name!r}")
        h0 = start_heading if start_heading is not None else self.network.nodes[start].heading
        src = self._states(start, h0, None)
        if not src and self.vehicle.turns_on_spot:
            src = self._states(start, None, None)
        dst = self._states(goal, None, arrive_mode)
        if start == goal and arrive_mode is None:
            return Route((), (start,), 0.0)
        if not src or not dst:
            raise NoRouteError(f"no route to station {goal!r} from {start!r} for a {self.vehicle.model}")
        a, b = self.network.nodes[start], self.network.nodes[goal]
        # A* compiled, Dijkstra interpreted (module docstring)
        route = by_mode(self._astar_route, self._dijkstra_route)(src, dst, a, b, start)
        if route is None:
            raise NoRouteError(f"no route to station {goal!r} from {start!r} for a {self.vehicle.model}")
        return route

    def _astar_route(self, src: list[int], dst: list[int], a: Node, b: Node, start: str) -> Route | None:
        """The compiled search: A* from the states ``src`` to any of ``dst`` (nodes ``a`` to ``b``), None if none.

        Dijkstra (:meth:`_dijkstra_route`) when the heap overflowed (rounding re-opened states).
        """
        best, time_s, _ = self._search.run(src, dst, b.x, b.y, 1.0 / self.vehicle.max_speed)
        if best >= 0:
            return self._unwind_arcs(best, start, time_s)
        return self._dijkstra_route(src, dst, a, b, start) if best == -2 else None

    def _dijkstra_route(self, src: list[int], dst: list[int], a: Node, b: Node, start: str) -> Route | None:
        """The interpreted search (:meth:`_dijkstra`) as a route from node ``start``, None if none."""
        best, time_s, pred = self._dijkstra(src, dst, math.hypot(b.x - a.x, b.y - a.y))
        return None if best < 0 else self._unwind(pred, best, start, time_s)

    def _dijkstra(self, src: list[int], dst: list[int], d: float) -> tuple[int, float, NDArray[np.int32]]:
        """The interpreted search (module doc): the goal state reached (-1: none), its time (s), predecessors."""
        bound = 3.0 * d / self.vehicle.max_speed + 60.0
        for limit in (bound, np.inf):  # search a disc first; the whole graph only when the goal lies beyond
            dist, pred, _ = dijkstra(self._graph, indices=src, return_predecessors=True, min_only=True, limit=limit)
            best = min(dst, key=lambda s: dist[s])
            if math.isfinite(dist[best]):
                return best, float(dist[best]), pred
        return -1, math.inf, pred

    def _unwind_arcs(self, state: int, start: str, time_s: float) -> Route:
        """The route the A* search reached ``state`` by, from the arcs in (:attr:`_Search.pred_arc`)."""
        pred, arc, trav_of_arc = self._search.pred, self._search.pred_arc, self._trav_of_arc
        travs: list[Traversal] = []
        while pred[state] >= 0:
            k = trav_of_arc[arc[state]]
            if k >= 0:
                travs.append(self._travs[k])
            state = pred[state]
        travs.reverse()
        return Route(tuple(travs), (start, *(t.edge.target for t in travs)), time_s)

    def _unwind(self, pred: NDArray[np.int32] | NDArray[np.int64], state: int, start: str, time_s: float) -> Route:
        travs: list[Traversal] = []
        while pred[state] >= 0:
            p = int(pred[state])
            t = self._edge_of.get((p, state))
            if t is not None:
                travs.append(t)
            state = p
        travs.reverse()
        nodes = (start, *(t.edge.target for t in travs))
        return Route(tuple(travs), nodes, time_s)


def _min_duplicates(rows: list[int], cols: list[int], cost: list[float], n: int) -> Any:
    """CSR state graph keeping the cheapest of parallel arcs (scipy would add them)."""
    if not rows:
        return csr_matrix((n, n))
    r, c, w = np.asarray(rows), np.asarray(cols), np.asarray(cost) + 1e-9  # zero cost would drop the arc
    order = np.lexsort((w, c, r))
    r, c, w = r[order], c[order], w[order]
    first = np.ones(r.shape, dtype=bool)
    first[1:] = (r[1:] != r[:-1]) | (c[1:] != c[:-1])
    return csr_matrix((w[first], (r[first], c[first])), shape=(n, n))


#: Landmarks of the A* heuristic (ALT: distances to and from a few far-apart nodes, module doc).
LANDMARKS = 8


class _Search:
    """The A* search's arrays: the CSR graph, each state's position, the landmark distances, and the
    per-query scratch kept between queries (distances, predecessors, the query stamp that says which
    entries are this query's, the heap)."""

    def __init__(self, graph: Any, xy: NDArray[np.float64], node_of: NDArray[np.int64]) -> None:
        self.indptr = np.asarray(graph.indptr, dtype=np.int64)
        self.indices = np.asarray(graph.indices, dtype=np.int64)
        self.weights = np.asarray(graph.data, dtype=np.float64)
        n = len(self.indptr) - 1
        self.x, self.y = np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])
        self.lm_from, self.lm_to = _landmarks(graph, xy, node_of)
        self.dist = np.zeros(n)
        self.pred = np.full(n, -1, dtype=np.int64)
        self.pred_arc = np.full(n, -1, dtype=np.int64)
        self.stamp = np.zeros(n, dtype=np.int64)
        self.goal = np.zeros(n, dtype=np.int64)
        size = len(self.indices) + n + 1  # every relaxation pushes once at most, every source once
        self.heap_cost = np.zeros(size)
        self.heap_g = np.zeros(size)
        self.heap_state = np.zeros(size, dtype=np.int64)
        self.query = 0

    def run(self, src: list[int], dst: list[int], gx: float, gy: float, inv_speed: float
            ) -> tuple[int, float, NDArray[np.int64]]:
        """A* from states ``src`` to any of ``dst`` (goal node at ``gx``, ``gy`` m): goal state (-1: none, -2: the
        heap overflowed), its time (s), the predecessors (and :attr:`pred_arc`, the arcs in)."""
        self.query += 1
        d = np.asarray(dst, dtype=np.int64)
        self.goal[d] = self.query
        with np.errstate(invalid="ignore"):
            to_goal = self.lm_from[d].min(axis=0)  # d(L, T) <= d(L, v) + d(v, T)
            from_goal = self.lm_to[d].max(axis=0)  # d(v, L) <= d(v, T) + max_t d(t, L)
        best = int(astar_kernel(self.indptr, self.indices, self.weights, self.x, self.y,
                                np.asarray(src, dtype=np.int64), self.goal, gx, gy, inv_speed * (1.0 - 1e-9),
                                self.lm_from, self.lm_to, to_goal, from_goal,
                                self.dist, self.pred, self.pred_arc, self.stamp, self.query, self.heap_cost,
                                self.heap_g,
                                self.heap_state))
        return best, (float(self.dist[best]) if best >= 0 else math.inf), self.pred


def _landmarks(graph: Any, xy: NDArray[np.float64], node_of: NDArray[np.int64]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Times (s) from and to :data:`LANDMARKS` far-apart nodes (all their states), each (n, k).

    The nodes are picked farthest-first in the plane, starting from the one farthest from the
    centroid; the times are Dijkstra's over the state graph and its transpose.
    """
    n = xy.shape[0]
    if n == 0:
        return np.zeros((0, 0)), np.zeros((0, 0))
    picked = [int(np.argmax(np.hypot(*(xy - xy.mean(axis=0)).T)))]
    near = np.hypot(*(xy - xy[picked[0]]).T)
    while len(picked) < min(LANDMARKS, n):
        nxt = int(np.argmax(near))
        if near[nxt] <= 0.0:
            break
        picked.append(nxt)
        near = np.minimum(near, np.hypot(*(xy - xy[nxt]).T))
    lm_from, lm_to = np.empty((len(picked), n)), np.empty((len(picked), n))
    transpose = graph.T.tocsr()
    for k, state in enumerate(picked):
        sources = np.flatnonzero(node_of == node_of[state])
        lm_from[k] = dijkstra(graph, indices=sources, min_only=True)
        lm_to[k] = dijkstra(transpose, indices=sources, min_only=True)
    return np.ascontiguousarray(lm_from.T), np.ascontiguousarray(lm_to.T)  # (n, k): a state's times together


#: Resolution (s) of the A* queue's order: within it the deeper state (larger time so far) goes first.
QUEUE_RESOLUTION_S = 1e-6


@jit
def astar_kernel(indptr: Any, indices: Any, weights: Any, x: Any, y: Any, sources: Any, goal: Any, gx: float,
                 gy: float, inv_speed: float, lm_from: Any, lm_to: Any, to_goal: Any, from_goal: Any, dist: Any,
                 pred: Any, pred_arc: Any, stamp: Any, query: int, heap_cost: Any, heap_g: Any, heap_state: Any
                 ) -> int:
    """A* on a CSR graph (module doc): the first goal state settled (``goal[s] == query``), -1 for none,
    -2 when the heap scratch is full (then nothing is known).

    ``indptr``, ``indices``, ``weights``: the CSR arcs (s); the heuristic (s) of a state ``v`` is the
    largest of ``hypot(x[v] - gx, y[v] - gy) * inv_speed`` and, for each landmark ``k``,
    ``to_goal[k] - lm_from[v, k]`` and ``lm_to[v, k] - from_goal[k]`` (ALT; a NaN term is skipped, an
    infinite one means the goal cannot be reached from ``v``, which is then not pushed). On return
    ``dist`` (s), ``pred`` and ``pred_arc`` (the CSR index of the arc in) hold the search's values for
    the states with ``stamp == query`` (``pred`` -1 at a source); ``heap_*`` are scratch of at least
    ``len(indices) + len(sources)`` entries.
    A binary min-heap with lazy deletion (an entry whose ``g`` is stale is skipped), ordered by
    ``g + h`` in steps of :data:`QUEUE_RESOLUTION_S` and, within one step, by the larger ``g``: on a
    grid, where turning costs time the heuristic cannot see, many states tie with the fastest
    route's ``g + h``, and the deeper one first reaches the goal without settling them all. The
    route found is within ``QUEUE_RESOLUTION_S`` of the fastest.
    """
    size = 0
    n_lm = lm_from.shape[1]
    u = -1
    g = 0.0
    n_src = len(sources)
    for s in sources:
        stamp[s] = query
        dist[s] = 0.0
        pred[s] = -1
    while True:
        # the arcs to relax: the sources (once, from no state), then those of the state popped
        if u < 0:
            lo, hi = 0, n_src
        else:
            lo, hi = indptr[u], indptr[u + 1]
        for e in range(lo, hi):
            if u < 0:
                v = sources[e]
                nd = 0.0
            else:
                v = indices[e]
                nd = g + weights[e]
                if stamp[v] == query and nd >= dist[v]:
                    continue
                stamp[v] = query
                dist[v] = nd
                pred[v] = u
                pred_arc[v] = e
            h = math.hypot(x[v] - gx, y[v] - gy) * inv_speed
            for k in range(n_lm):
                t1 = (to_goal[k] - lm_from[v, k]) * (1.0 - 1e-9)
                if t1 > h:
                    h = t1
                t2 = (lm_to[v, k] - from_goal[k]) * (1.0 - 1e-9)
                if t2 > h:
                    h = t2
            if h == math.inf:
                continue  # the goal cannot be reached from v
            if size >= len(heap_cost):
                return -2
            f = math.floor((nd + h) / QUEUE_RESOLUTION_S)
            i = size
            size += 1
            while i > 0:  # push: sift up
                parent = (i - 1) // 2
                pc = heap_cost[parent]
                if pc < f or (pc == f and heap_g[parent] >= nd):
                    break
                heap_cost[i] = pc
                heap_g[i] = heap_g[parent]
                heap_state[i] = heap_state[parent]
                i = parent
            heap_cost[i] = f
            heap_g[i] = nd
            heap_state[i] = v
        while True:  # pop the next state that is not stale
            if size == 0:
                return -1
            u = heap_state[0]
            g = heap_g[0]
            size -= 1  # move the last entry to the root and sift it down
            last_f = heap_cost[size]
            last_g = heap_g[size]
            last_s = heap_state[size]
            i = 0
            while True:
                child = 2 * i + 1
                if child >= size:
                    break
                if child + 1 < size and (heap_cost[child + 1] < heap_cost[child] or (
                        heap_cost[child + 1] == heap_cost[child] and heap_g[child + 1] > heap_g[child])):
                    child += 1
                if heap_cost[child] > last_f or (heap_cost[child] == last_f and heap_g[child] <= last_g):
                    break
                heap_cost[i] = heap_cost[child]
                heap_g[i] = heap_g[child]
                heap_state[i] = heap_state[child]
                i = child
            if size > 0:
                heap_cost[i] = last_f
                heap_g[i] = last_g
                heap_state[i] = last_s
            if g <= dist[u]:
                break  # else a stale entry: u was reached cheaper since
        if goal[u] == query:
            return u
