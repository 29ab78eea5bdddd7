"""The baseline: exclusive resources allocated step by step, the way openTCS allocates (issue 30).

Each vehicle drives the static fastest route of every leg (:class:`agvnav.routes.planning.Planner`; it
never routes around another vehicle). Before it starts a step it must claim, all at once, the
resources of that step and the next ``lookahead - 1`` ones (their nodes and edges, as openTCS
reserves the next points and paths; one step by default, and on while the next step enters a block),
and every resource of a *block* any of them lies in: each dead-end spur (a station or parking place
and its edge, :func:`spur_blocks`; one vehicle in it at a time), and optionally each crossing with
its lanes (:func:`crossing_blocks`; on an 8 m grid they lock the neighbouring crossings too and
deadlock at once). Areas where paths come close
without sharing a point, which openTCS users draw as blocks by hand, come from the conflict zones: a
claim succeeds only when no resource claimed conflicts (the zones' relation) with one another vehicle
holds. On arriving at a node the vehicle frees what lies behind it. Nothing avoids a cycle of claims:
two vehicles meeting head-on on a two-way lane, or a loop of one-way lanes full of vehicles, wait for
each other for ever, which the executor reports as a deadlock (openTCS says as much of its
allocator); users draw one-way lanes (``warehouse_oneway``) to make that rare.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from agvnav.routes.network import RouteNetwork
from agvnav.routes.planning import NoRouteError, Planner, Traversal, VehicleLimits
from agvnav.traffic.execute import RouteStep, VehicleRoute
from agvnav.traffic.plan import Conflicts, Resource, VehicleTask

__all__ = ["BaselineAllocator", "baseline_routes", "crossing_blocks", "spur_blocks"]


def crossing_blocks(network: RouteNetwork) -> dict[Resource, frozenset[Resource]]:
    """Resource -> the block it belongs to: each node with three or more neighbours (a crossing) and its edges
    to the other crossings and lanes (not those to dead ends: a vehicle standing at a station or a parking
    place must not lock the crossing in front of it)."""
    out: dict[Resource, frozenset[Resource]] = {}
    g = network.graph

    def degree(n: str) -> int:
        return len(set(g.successors(n)) | set(g.predecessors(n)))

    for n in network.nodes:
        if degree(n) < 3:
            continue
        block = {("node", n)} | {("edge", k) for u, v, k in g.in_edges(n, keys=True) if degree(u) > 1} | {
            ("edge", k) for u, v, k in g.out_edges(n, keys=True) if degree(v) > 1}
        fb = frozenset(block)
        for r in block:
            out[r] = out.get(r, frozenset()) | fb
    return out


def spur_blocks(network: RouteNetwork) -> dict[Resource, frozenset[Resource]]:
    """Resource -> its block: each dead end (a node with one neighbour: a station or parking spur) with the
    edges to it, both ways. One vehicle in a spur at a time, claimed together with the crossing before it
    (:class:`BaselineAllocator` claims on into a block), so a vehicle waiting to enter never stands in the
    way of one coming out."""
    out: dict[Resource, frozenset[Resource]] = {}
    g = network.graph
    for n in network.nodes:
        if len(set(g.successors(n)) | set(g.predecessors(n))) != 1:
            continue
        block = frozenset({("node", n)} | {("edge", k) for _, _, k in g.in_edges(n, keys=True)}
                          | {("edge", k) for _, _, k in g.out_edges(n, keys=True)})
        for r in block:
            out[r] = out.get(r, frozenset()) | block
    return out


def baseline_routes(network: RouteNetwork, tasks: Sequence[VehicleTask],
                    footprints: Mapping[str, NDArray[np.float64]]) -> tuple[list[VehicleRoute], dict[str, str]]:
    """Each task's legs on their static fastest routes; tasks with a leg no route reaches are left out."""
    planners: dict[VehicleLimits, Planner] = {}
    routes, unserved = [], {}
    for t in tasks:
        p = planners.get(t.limits) or planners.setdefault(t.limits, Planner(network, t.limits))
        steps: list[RouteStep] = []
        node, heading = t.start, t.start_heading
        dwell, nb = 0.0, 0.0
        try:
            for g in t.goals:
                route = p.plan(node, g.station, heading, g.arrive_mode)
                for i, tr in enumerate(route.traversals):
                    last = i + 1 == len(route.traversals)
                    steps.append(RouteStep(tr, dwell, nb, int(last and g.action == "drop"), g.dwell_s if last else 0.0))
                    dwell, nb = 0.0, 0.0
                if route.traversals:
                    node, heading = g.station, route.traversals[-1].end_heading
                dwell, nb = dwell + g.dwell_s, g.not_before_s + g.dwell_s
        except NoRouteError as exc:
            unserved[t.vehicle] = str(exc)
            steps = []
        n = network.nodes[t.start]
        h0 = n.heading if n.heading is not None else (steps[0].traversal.start_heading if steps else 0.0)
        routes.append(VehicleRoute(t.vehicle, t.limits, footprints[t.vehicle], t.start, h0, tuple(steps)))
    return routes, unserved


def _step_resources(tr: Traversal) -> tuple[Resource, ...]:
    return (("node", tr.edge.source), ("edge", tr.edge.id), ("node", tr.edge.target))


class BaselineAllocator:
    """The allocator of the module doc as an executor :class:`~agvnav.traffic.execute.Controller`."""

    def __init__(self, network: RouteNetwork, routes: Sequence[VehicleRoute], zones: Conflicts,
                 lookahead: int = 1, crossings: bool = False) -> None:
        self.routes = {r.vehicle: r for r in routes}
        self.zones = zones
        self.lookahead = lookahead
        self.blocks = spur_blocks(network)
        if crossings:
            for r, b in crossing_blocks(network).items():
                self.blocks[r] = self.blocks.get(r, frozenset()) | b
        self.held: dict[str, set[Resource]] = {r.vehicle: {("node", r.start)} for r in routes}
        self.version = 0
        """counts the claims and releases: a decision on an unchanged holding is the one made before."""
        self._wants: dict[tuple[str, int], frozenset[Resource]] = {}
        self._reach: dict[tuple[str, int, str], frozenset[Resource]] = {}
        self._conf: dict[tuple[str, Resource, str], frozenset[Resource]] = {}
        self._decided: dict[tuple[str, int], tuple[int, tuple[str, Resource] | None]] = {}

    def _span(self, vehicle: str, k: int) -> int:
        """How many steps from ``k`` on a claim covers: ``lookahead``, and on while the next one enters a block."""
        steps = self.routes[vehicle].steps
        n = min(self.lookahead, len(steps) - k)
        while k + n < len(steps) and ("edge", steps[k + n].traversal.edge.id) in self.blocks:
            n += 1
        return n

    def _wanted(self, vehicle: str, k: int) -> frozenset[Resource]:
        """The claim of step ``k``: its resources, the next ones the span covers and their blocks (kept)."""
        got = self._wants.get((vehicle, k))
        if got is None:
            steps = self.routes[vehicle].steps
            want: set[Resource] = set()
            for st in steps[k:k + self._span(vehicle, k)]:
                want.update(_step_resources(st.traversal))
            for r in list(want):
                want |= self.blocks.get(r, frozenset())
            got = self._wants[(vehicle, k)] = frozenset(want)
        return got

    def _conflicts(self, model: str, r: Resource, other: str) -> frozenset[Resource]:
        """The zones' relation, kept per model pair and resource."""
        key = (model, r, other)
        got = self._conf.get(key)
        if got is None:
            got = self._conf[key] = self.zones.conflicts(model, r, other)
        return got

    def _reached(self, vehicle: str, k: int, other: str) -> frozenset[Resource]:
        """Every resource a vehicle of model ``other`` must not hold for ``vehicle``'s claim of step ``k``."""
        key = (vehicle, k, other)
        got = self._reach.get(key)
        if got is None:
            model = self.routes[vehicle].limits.model
            out: set[Resource] = set()
            for r in self._wanted(vehicle, k):
                out |= self._conflicts(model, r, other)
            got = self._reach[key] = frozenset(out)
        return got

    def _clash(self, vehicle: str, k: int) -> tuple[str, Resource] | None:
        """The first other vehicle (route order) holding something the claim of step ``k`` conflicts with, and the
        first resource of the claim that clashes; decided again only after a claim or a release."""
        got = self._decided.get((vehicle, k))
        if got is not None and got[0] == self.version:
            return got[1]
        model = self.routes[vehicle].limits.model
        found: tuple[str, Resource] | None = None
        for u, held in self.held.items():
            mu = self.routes[u].limits.model
            if u == vehicle or held.isdisjoint(self._reached(vehicle, k, mu)):
                continue
            r = next(r for r in self._wanted(vehicle, k) if not held.isdisjoint(self._conflicts(model, r, mu)))
            found = (u, r)
            break
        self._decided[(vehicle, k)] = (self.version, found)
        return found

    def may_start(self, vehicle: str, k: int, t: float) -> str | None:
        """None when the step's claim succeeds now, else the first resource that clashes."""
        c = self._clash(vehicle, k)
        return None if c is None else f"{c[1][0]}:{c[1][1]}"

    def started(self, vehicle: str, k: int, t: float) -> None:
        """Claim the step's resources."""
        self.held[vehicle] |= self._wanted(vehicle, k)
        self.version += 1

    def arrived(self, vehicle: str, k: int, t: float) -> None:
        """Free what lies behind: keep the node reached (not its block: standing at a dead end holds the dead
        end only) and the claims of the steps ahead already made."""
        steps = self.routes[vehicle].steps
        ahead: set[Resource] = set()
        for st in steps[k + 1:k + self._span(vehicle, k)]:
            ahead.update(_step_resources(st.traversal))
        for r in list(ahead):
            ahead |= self.blocks.get(r, frozenset())
        self.held[vehicle] &= ahead
        self.held[vehicle].add(("node", steps[k].traversal.edge.target))
        self.version += 1

    def waiting_for(self, vehicle: str, k: int) -> set[str]:
        """The vehicles holding something the step's claim clashes with."""
        return {u for u, held in self.held.items()
                if u != vehicle and not held.isdisjoint(self._reached(vehicle, k, self.routes[u].limits.model))}
