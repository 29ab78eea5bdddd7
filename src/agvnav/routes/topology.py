"""Topological navigation [seed003 §3.9]: where on the route graph the vehicle is, and planning from there.

Seed 003 §3.9 names topological navigation: the vehicle reasons about *places*
and the *connections* between them rather than only coordinates. Here the
places are the network's nodes and the connections its edges; the vehicle's
metric pose estimate (from the goniometer and the EKF, or any estimator) is
turned into a topological state by :meth:`GraphLocator.locate`:

* every edge is sampled (its :class:`~agvnav.routes.network.EdgeCurve`
  points); the samples nearest the estimated position (a KD-tree) are
  candidates; a candidate counts only when the vehicle heading agrees, within
  ``heading_tol``, with a heading the edge may be driven with (tangent facing
  forward, tangent + pi backing up);
* the nearest candidate (driving forward preferred over backing up when both
  fit equally well) gives the current edge, the progress along it (m and
  fraction) and the next node; within ``node_radius`` of a node the vehicle
  is *at* that node.

:func:`plan_from_pose` plans from such a state: the rest of the current
edge, then the planner's fastest route from its end node with the heading the
vehicle will have there. This is honest but limited: the pose must be within
``max_distance`` of the network (no off-network recovery path is planned),
and progress along the current edge is driven to its end before any turn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial import cKDTree

from agvnav.geometry.angles import wrap_angle
from agvnav.routes.network import RouteNetwork
from agvnav.routes.planning import NoRouteError, Planner, Route, Traversal

__all__ = ["GraphLocation", "GraphLocator", "plan_from_pose"]


@dataclass(frozen=True)
class GraphLocation:
    """Where the vehicle is on the graph.

    ``edge`` id, ``mode`` (+1 facing forward along it, -1 backing up), ``s`` (m along
    the edge), ``fraction`` (0..1), ``next_node``, ``at_node`` (id when within the
    node radius, else None), ``distance`` (m from the edge).
    """

    edge: str
    mode: int
    s: float
    fraction: float
    next_node: str
    at_node: str | None
    distance: float


class GraphLocator:
    """Locates poses on a :class:`RouteNetwork` (module doc); ``model`` limits the usable edges."""

    def __init__(
        self,
        network: RouteNetwork,
        model: str | None = None,
        heading_tol: float = math.radians(30.0),
        node_radius: float = 0.2,
        max_distance: float = 1.0,
    ) -> None:
        self.network = network
        self.heading_tol, self.node_radius, self.max_distance = heading_tol, node_radius, max_distance
        pts, owner, idx = [], [], []
        self._edges = [e for e in network.edges.values() if model is None or e.allows(model)]
        for k, e in enumerate(self._edges):
            pts.append(e.curve.points)
            owner.append(np.full(len(e.curve.points), k))
            idx.append(np.arange(len(e.curve.points)))
        if not pts:
            raise ValueError("no edge of the network is usable by this vehicle")
        self._pts = np.concatenate(pts)
        self._owner, self._idx = np.concatenate(owner), np.concatenate(idx)
        self._tree = cKDTree(self._pts)

    def locate(self, pose: ArrayLike) -> GraphLocation:
        """The graph location of ``pose`` = (x, y, heading) (m, m, rad); ValueError when off the network."""
        x, y, psi = (float(v) for v in np.asarray(pose, dtype=np.float64).reshape(3))
        k = min(16, len(self._pts))
        dist, cand = self._tree.query([x, y], k=k)
        matches: list[tuple[float, int, str, int]] = []
        for d, c in zip(np.atleast_1d(dist), np.atleast_1d(cand), strict=True):
            if d > self.max_distance:
                break
            edge = self._edges[int(self._owner[c])]
            i = int(self._idx[c])
            for mode in edge.modes:
                h = float(edge.curve.headings[i]) + (math.pi if mode < 0 else 0.0)
                if abs(float(wrap_angle(psi - h))) <= self.heading_tol:
                    matches.append((float(d), mode, edge.id, i))
        if matches:  # nearest; among equally near ones (to 1 mm), driving forward rather than backing up
            d, mode, edge_id, i = min(matches, key=lambda m: (round(m[0], 3), -m[1]))
            return self._location(edge_id, mode, i, d, x, y)
        raise ValueError(f"pose ({x:.3f}, {y:.3f}) is not on the route network (within {self.max_distance:g} m "
                         "and with an allowed heading)")

    def _location(self, edge_id: str, mode: int, i: int, d: float, x: float, y: float) -> GraphLocation:
        e = self.network.edges[edge_id]
        n = len(e.curve.points) - 1
        s = e.curve.length * i / n
        at = None
        for node_id in (e.source, e.target):
            node = self.network.nodes[node_id]
            if math.hypot(x - node.x, y - node.y) <= self.node_radius:
                at = node_id
        return GraphLocation(edge_id, mode, s, s / e.curve.length, e.target, at, d)


def plan_from_pose(planner: Planner, locator: GraphLocator, pose: ArrayLike, goal: str) -> tuple[GraphLocation, Route]:
    """Locate ``pose`` on the graph and plan to ``goal``: the rest of the current edge, then the fastest route.

    Returns the location and the route whose first traversal is the current edge
    (its time counts only the remaining fraction). :class:`NoRouteError` names the station.
    """
    loc = locator.locate(pose)
    edge = planner.network.edges[loc.edge]
    first = Traversal(edge, loc.mode)
    rest = planner.plan(edge.target, goal, first.end_heading) if edge.target != goal else Route((), (goal,), 0.0)
    if not math.isfinite(rest.time_s):
        raise NoRouteError(f"no route to station {goal!r}")
    t_edge = (1.0 - loc.fraction) * edge.curve.length / min(edge.speed, planner.vehicle.max_speed)
    return loc, Route((first, *rest.traversals), (edge.source, *rest.nodes), t_edge + rest.time_s)
