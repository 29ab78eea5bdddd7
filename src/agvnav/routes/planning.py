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

The state graph is a sparse matrix searched by Dijkstra
(``scipy.sparse.csgraph.dijkstra``), rebuilt only when the blocked edges change;
the search is first limited to ``3 d / v_max + 60 s`` (``d`` the straight-line
distance), and repeated without limit only if the goal lies beyond (the result
is the same shortest route: Dijkstra settles states in cost order).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from agvnav.geometry.angles import wrap_angle
from agvnav.routes.network import Edge, RouteNetwork
from agvnav.world.vehicle_specs import vehicle_kind

__all__ = [
    "HEADING_CLASS_TOL_RAD",
    "NoRouteError",
    "Planner",
    "Route",
    "Traversal",
    "VehicleLimits",
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
        bound = 3.0 * math.hypot(b.x - a.x, b.y - a.y) / self.vehicle.max_speed + 60.0
        for limit in (bound, np.inf):  # search a disc first; the whole graph only when the goal lies beyond
            dist, pred, _ = dijkstra(self._graph, indices=src, return_predecessors=True, min_only=True, limit=limit)
            best = min(dst, key=lambda s: dist[s])
            if math.isfinite(dist[best]):
                break
        if not math.isfinite(dist[best]):
            raise NoRouteError(f"no route to station {goal!r} from {start!r} for a {self.vehicle.model}")
        return self._unwind(pred, best, start, float(dist[best]))

    def _unwind(self, pred: NDArray[np.int32], state: int, start: str, time_s: float) -> Route:
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
