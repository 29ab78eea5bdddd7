"""A master control's side: the messages (:class:`MasterMessages`) and a small job dispatcher (:class:`JobMaster`).

:class:`MasterMessages` writes the messages a master sends, in the form of the version spoken
(2.x edges name their nodes, 3.0 edges do not), with its own header ids per topic.
:class:`JobMaster` dispatches pick-and-drop jobs over routes it plans, with order updates and
instant actions, through any transport (the in-process bus of the bench, MQTT).

Without traffic control (the default) each vehicle's route is planned alone, its first half released
and the rest released by an update once the vehicle nears the decision point: the vehicles must not
share the floor (each in its own simulated world, or on separate networks).

With traffic control (``traffic=True``, issue 30) the vehicles share the floor. Jobs go out in
rounds: once every vehicle is idle, each is given a station (distinct, reachable, not where another
stands) and all routes are planned together (:func:`agvnav.traffic.plan.plan_fleet` over the conflict
zones of the vehicles' model, :func:`agvnav.traffic.zones.conflict_zones`), and the plan's order of
passage through every zone is kept by its action dependency graph (:mod:`agvnav.traffic.adg`):

* each order carries the whole route; its **base** (released nodes and edges) ends at the last node
  up to which every step's start is allowed by the ADG (the dependencies on the other vehicles'
  events are met), the rest is **horizon**; the vehicle stops at the end of the base (the decision
  point) unless an update extended it;
* the vehicles' states report progress: ``lastNodeId``/``lastNodeSequenceId`` (node ``i`` of the
  route has sequence id ``2 i``) marks the ADG's events of the steps up to that node (the step's
  start and arrival: the resources it held behind the vehicle are given up);
* after every report the master extends, by an order update stitched at the decision point, the base
  of each vehicle whose next steps the ADG now allows (:attr:`JobMaster.releases` logs each release).

A step is released only when the vehicles planned through its zone before it have reported leaving
it, so a late vehicle delays the others and never meets them (the ADG's safety and deadlock freedom,
:mod:`agvnav.traffic.adg`); the zones' margin (``margin_m``) covers the vehicles' positioning and
tracking errors and the reach of ``lastNodeId`` (a node counts as passed within the vehicle's
deviation of it).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from agvnav.geometry import wrap_angle_scalar
from agvnav.routes.network import RouteNetwork
from agvnav.routes.planning import NoRouteError, Planner, VehicleLimits
from agvnav.traffic.adg import Adg, build_adg
from agvnav.traffic.plan import Goal, VehicleTask, plan_fleet
from agvnav.traffic.zones import DEFAULT_MARGIN_M, ConflictZones, conflict_zones
from agvnav.vda5050.messages import iso_timestamp
from agvnav.vda5050.schemas import JsonObject, major
from agvnav.world.strict import (
    SourcedModel,
    StrictModel,
    load_yaml_document,
    read_document_text,
    validate_document,
)

__all__ = ["FleetSpec", "FleetVehicle", "JobMaster", "MasterMessages", "job_master", "load_fleet_spec"]


@dataclass
class MasterMessages:
    """Messages to vehicle ``serial`` of ``manufacturer`` in ``version`` over ``network`` on map ``map_id``."""

    network: RouteNetwork
    map_id: str
    version: str
    manufacturer: str
    serial: str
    headers: dict[str, int] = field(default_factory=dict)

    def _header(self, topic: str) -> JsonObject:
        self.headers[topic] = self.headers.get(topic, -1) + 1
        return {"headerId": self.headers[topic], "timestamp": iso_timestamp(datetime.now(UTC)),
                "version": self.version, "manufacturer": self.manufacturer, "serialNumber": self.serial}

    @staticmethod
    def action(action_type: str, action_id: str, blocking: str = "HARD", **params: object) -> JsonObject:
        """An action with ``params`` as its actionParameters."""
        return {"actionType": action_type, "actionId": action_id, "blockingType": blocking,
                "actionParameters": [{"key": k, "value": v} for k, v in params.items()]}

    def order(self, order_id: str, update_id: int, nodes: Sequence[str], released: int, first_seq: int = 0,
              actions: dict[int, list[JsonObject]] | None = None) -> JsonObject:
        """An order through ``nodes`` (network ids); the first ``released`` nodes (and edges between) are the base.

        ``actions[i]``: the actions of node ``i``. Sequence ids start at ``first_seq`` (an update
        repeats the decision point's).
        """
        acts = actions or {}
        out_nodes: list[JsonObject] = []
        out_edges: list[JsonObject] = []
        for i, nid in enumerate(nodes):
            n = self.network.nodes[nid]
            theta = wrap_angle_scalar(n.heading or 0.0)
            out_nodes.append({"nodeId": nid, "sequenceId": first_seq + 2 * i, "released": i < released,
                              "nodePosition": {"x": n.x, "y": n.y, "theta": theta, "mapId": self.map_id},
                              "actions": acts.get(i, [])})
            if i:
                e: JsonObject = {"edgeId": f"{nodes[i - 1]}-{nid}", "sequenceId": first_seq + 2 * i - 1,
                                 "released": i < released, "actions": []}
                if major(self.version) == "v2":
                    e |= {"startNodeId": nodes[i - 1], "endNodeId": nid}
                out_edges.append(e)
        return self._header("order") | {"orderId": order_id, "orderUpdateId": update_id, "nodes": out_nodes,
                                        "edges": out_edges}

    def instant(self, *actions: JsonObject) -> JsonObject:
        """An instantActions message (3.0 instant actions are NONE-blocking)."""
        acts = [a | {"blockingType": "NONE"} for a in actions] if major(self.version) == "v3" else list(actions)
        return self._header("instantActions") | {"actions": acts}


@dataclass
class _Dispatch:
    """What the job master knows of one vehicle."""

    messages: MasterMessages
    node: str
    """the node the vehicle stands at or last passed."""
    order: int = 0
    busy: bool = False
    horizon: tuple[str, ...] = ()
    """nodes of the running order still held back (sent unreleased), released by an update."""
    decision_seq: int = 0
    update_id: int = 0
    goal_actions: list[JsonObject] = field(default_factory=list)
    carrying: bool = False
    failed: str | None = None
    paused_until: float | None = None
    next_instant: float = 0.0
    done: int = 0
    rejected: int = 0
    route: tuple[str, ...] = ()
    """traffic control: the nodes of the running order's whole route."""
    granted: int = 0
    """traffic control: steps of the route released so far (the base ends at ``route[granted]``)."""


class JobMaster:
    """A small master control: pick-and-drop jobs between random stations, over any transport.

    For every vehicle (``serials``, starting at ``start``: one node for all, or per serial) it plans the fastest route
    (:class:`~agvnav.routes.planning.Planner`) from where the vehicle stands to the next station
    and sends it as an order with a ``pick`` (then a ``drop``) at its last node: the first half
    of the route released, the rest as horizon, released by an order update stitched at the
    decision point once the vehicle has passed the node before it. Between jobs, now and then,
    instant actions: ``stateRequest``, ``factsheetRequest``, ``startPause`` followed ``pause_s``
    later by ``stopPause`` (``instant_period_s``: their mean interval; 0 for none). Messages go out
    through ``send(serial, topic, message)``; the vehicles' answers come in through
    :meth:`on_message`; :meth:`tick` at the caller's clock ``t`` (s) sends what is due.
    """

    def __init__(self, network: RouteNetwork, map_id: str, version: str, manufacturer: str, serials: Sequence[str],
                 start: str | dict[str, str], send: Callable[[str, str, JsonObject], None],
                 model: str = "differential", seed: int = 0, instant_period_s: float = 60.0, pause_s: float = 2.0,
                 action_s: float = 3.0, traffic: bool = False, margin_m: float = 2 * DEFAULT_MARGIN_M) -> None:
        self.network, self.send = network, send
        self.limits = VehicleLimits(model)
        self.planner = Planner(network, self.limits)
        self.traffic = traffic
        """traffic control (module doc): routes planned together, bases released as the ADG allows."""
        self.zones: ConflictZones | None = conflict_zones(network, [model], margin_m=margin_m) if traffic else None
        self.adg: Adg | None = None
        """traffic control: the ADG of the round under way."""
        self.t = 0.0
        """the caller's clock at the last :meth:`tick` (s)."""
        self.releases: list[tuple[float, str, int, int]] = []
        """traffic control: every base release ``(t, serial, first step, steps released)``, in order."""
        self.marks: list[tuple[float, str, int]] = []
        """traffic control: every ADG event marked from the vehicles' reports ``(t, serial, event)``, in order."""
        starts = start if isinstance(start, dict) else dict.fromkeys(serials, start)
        self.stations = [s for s in network.stations if s not in starts.values()] or list(network.stations)
        self.rng = np.random.default_rng(seed)
        self.max_jobs: float = math.inf
        """jobs per vehicle after which no new order is sent."""
        self.instant_period_s, self.pause_s, self.action_s = instant_period_s, pause_s, action_s
        self.vehicles = {s: _Dispatch(MasterMessages(network, map_id, version, manufacturer, s), starts[s])
                         for s in serials}
        for d in self.vehicles.values():
            d.next_instant = self._gap()

    def _gap(self) -> float:
        return float(self.rng.exponential(self.instant_period_s)) if self.instant_period_s > 0 else math.inf

    @property
    def jobs_done(self) -> int:
        """Orders completed, over all vehicles."""
        return sum(d.done for d in self.vehicles.values())

    def tick(self, t: float) -> None:
        """Send what is due at time ``t`` (s): new orders to idle vehicles, instant actions."""
        self.t = t
        if self.traffic and not any(d.busy for d in self.vehicles.values()):
            self._round()
        for serial, d in self.vehicles.items():
            if d.failed is not None:
                continue
            if d.paused_until is not None and t >= d.paused_until:
                self.send(serial, "instantActions", d.messages.instant(d.messages.action("stopPause", f"sp{t:.2f}")))
                d.paused_until = None
            if not self.traffic and not d.busy and d.done < self.max_jobs:
                self._dispatch(serial, d)
            if t >= d.next_instant and d.paused_until is None:
                kind = str(self.rng.choice(["stateRequest", "factsheetRequest", "startPause"]))
                self.send(serial, "instantActions", d.messages.instant(d.messages.action(kind, f"i{t:.2f}", "NONE")))
                if kind == "startPause":
                    d.paused_until = t + self.pause_s
                d.next_instant = t + self._gap()

    def _round(self) -> None:
        """Traffic control: a station for every vehicle that has jobs left, all routes planned together, their ADG,
        an order each with the base the ADG allows (module doc)."""
        assert self.zones is not None
        taken = {d.node for d in self.vehicles.values()}
        tasks = []
        for serial, d in self.vehicles.items():
            if d.failed is not None or d.done >= self.max_jobs:
                continue
            options = [s for s in self.stations if s not in taken and self._reachable(d.node, s)]
            if not options:
                continue
            goal = str(self.rng.choice(options))
            taken.add(goal)
            act = "drop" if d.carrying else "pick"
            tasks.append(VehicleTask(serial, self.limits, d.node, (Goal(goal, self.action_s, action=act),)))
        if not tasks:
            return
        plan = plan_fleet(self.network, tasks, self.zones)
        self.adg = build_adg(plan, self.zones)
        for task in tasks:
            steps = plan.plans[task.vehicle].steps
            if not steps:
                continue  # unserved this round: planned again in the next
            d = self.vehicles[task.vehicle]
            d.route = (task.start, *(st.target for st in steps))
            d.order += 1
            act = task.goals[0].action
            d.goal_actions = [MasterMessages.action(act, f"{task.vehicle}-{d.order}-{act}", "HARD", stationType="floor",
                                                    loadType="EPAL",
                                                    loadId=f"load-{task.vehicle}-{d.order - int(d.carrying)}",
                                                    duration=self.action_s)]
            d.busy, d.update_id, d.granted = True, 0, 0
            self._grant(task.vehicle, d, first=True)

    def _reachable(self, a: str, b: str) -> bool:
        try:
            self.planner.plan(a, b)
        except NoRouteError:
            return False
        return True

    def _grantable(self, serial: str, d: _Dispatch) -> int:
        """Steps of the route the ADG lets the vehicle take: up to the first whose start waits for another vehicle."""
        assert self.adg is not None
        k, n = d.granted, len(d.route) - 1
        while k < n and not self.adg.blockers(serial, 2 * k):
            k += 1
        return k

    def _grant(self, serial: str, d: _Dispatch, first: bool = False) -> None:
        """Send the order (``first``) or an update stitched at the decision point, when the base grows."""
        k = self._grantable(serial, d)
        if not first and k == d.granted:
            return
        start = d.granted
        nodes = list(d.route[start:])
        if not first:
            d.update_id += 1
        self.send(serial, "order", d.messages.order(f"{serial}-job{d.order}", d.update_id, nodes, k - start + 1,
                                                    2 * start, {len(nodes) - 1: d.goal_actions}))
        self.releases.append((self.t, serial, start, k - start))
        d.granted = k
        d.horizon = tuple(d.route[k:]) if k < len(d.route) - 1 else ()
        d.decision_seq = 2 * k

    def _progress(self, serial: str, d: _Dispatch, msg: JsonObject) -> None:
        """Traffic control: mark the ADG's events of the steps up to the node the vehicle reports, then extend the
        bases the ADG now allows."""
        adg = self.adg
        last, seq = msg.get("lastNodeId"), msg.get("lastNodeSequenceId")
        if adg is None or not d.route or not isinstance(seq, int) or seq % 2 or not isinstance(last, str):
            return
        i = seq // 2
        if not 0 < i < len(d.route) or d.route[i] != last:
            return
        marked = False
        while adg.done[serial] < 2 * i and adg.done[serial] < 2 * d.granted:
            e = adg.done[serial]
            adg.mark(serial, e)
            self.marks.append((self.t, serial, e))
            marked = True
        if marked:
            for other, od in self.vehicles.items():
                if od.busy and od.route and od.granted < len(od.route) - 1:
                    self._grant(other, od)

    def _dispatch(self, serial: str, d: _Dispatch) -> None:
        goal = str(self.rng.choice([s for s in self.stations if s != d.node] or self.stations))
        route = self.planner.plan(d.node, goal)
        nodes = list(route.nodes)
        if any(t.mode < 0 for t in route.traversals) or len(nodes) < 2:
            return  # this vehicle drives forward only: another goal next tick
        d.order += 1
        released = max(2, (len(nodes) + 1) // 2)
        act = "drop" if d.carrying else "pick"
        # the predefined parameters of pick/drop (2.1 §6.8.1): the station and load types, the load's id
        d.goal_actions = [MasterMessages.action(act, f"{serial}-{d.order}-{act}", "HARD", stationType="floor",
                                                loadType="EPAL", loadId=f"load-{serial}-{d.order - int(d.carrying)}",
                                                duration=self.action_s)]
        self.send(serial, "order", d.messages.order(f"{serial}-job{d.order}", 0, nodes, released, 0,
                                                    {len(nodes) - 1: d.goal_actions}))
        d.busy, d.update_id = True, 0
        d.horizon = tuple(nodes[released - 1:]) if released < len(nodes) else ()
        d.decision_seq = 2 * (released - 1)

    def on_message(self, serial: str, topic: str, msg: JsonObject) -> None:
        """A vehicle's message (its state drives the dispatch)."""
        d = self.vehicles.get(serial)
        if d is None or topic != "state":
            return
        errors = msg.get("errors", [])
        if isinstance(errors, list) and any(isinstance(e, dict) and e.get("errorLevel") == "FATAL"
                                            and e.get("errorType") not in ("localizationError", "LOCALIZATION_ERROR")
                                            for e in errors):
            d.failed = str(errors)
        if d.busy and isinstance(errors, list) and any(
                isinstance(e, dict) and {"referenceKey": "orderId", "referenceValue": f"{serial}-job{d.order}"}
                in (e.get("errorReferences") or []) for e in errors):
            d.busy, d.horizon = False, ()  # refused: plan again from where it stands
            d.rejected += 1
        last = msg.get("lastNodeId")
        if isinstance(last, str) and last:
            d.node = last
        if self.traffic:
            self._progress(serial, d, msg)
        nodes = msg.get("nodeStates", [])
        acts = [*msg.get("actionStates", []), *msg.get("instantActionStates", [])]  # type: ignore[misc]
        order_acts = [a for a in acts if isinstance(a, dict)
                      and str(a.get("actionId", "")).startswith(f"{serial}-{d.order}-")]
        if not self.traffic and d.horizon and isinstance(nodes, list):
            released = [n for n in nodes if isinstance(n, dict) and n.get("released")]
            if len(released) <= 1:  # the vehicle is on its way to the decision point: release the rest
                self._release(serial, d)
        if d.busy and not d.horizon and nodes == [] and order_acts and all(
                a.get("actionStatus") in ("FINISHED", "FAILED") for a in order_acts):
            d.busy = False
            d.done += 1
            d.carrying = not d.carrying

    def _release(self, serial: str, d: _Dispatch) -> None:
        d.update_id += 1
        m = d.messages.order(f"{serial}-job{d.order}", d.update_id, list(d.horizon), len(d.horizon),
                             d.decision_seq, {len(d.horizon) - 1: d.goal_actions})
        self.send(serial, "order", m)
        d.horizon = ()


class FleetVehicle(StrictModel):
    """One vehicle the master dispatches to."""

    serial: str
    """its serialNumber (a topic level)."""
    start: str
    """the network node it stands at when the master starts."""


class FleetSpec(SourcedModel):
    """What ``agvnav fleet SPEC`` dispatches: the route network (a scenario's), the vehicles, the jobs."""

    scenario: str
    """scenario file or shipped name whose ``mission.network`` and ``map`` the orders use."""
    version: Literal["2.0.0", "2.1.0", "3.0.0"] = "2.1.0"
    """VDA 5050 version spoken."""
    interface: str = "uagv"
    """interface name, the first topic level."""
    manufacturer: str
    """the vehicles' manufacturer (a topic level)."""
    vehicles: list[FleetVehicle] = Field(min_length=1)
    """the vehicles, with distinct serials."""
    jobs: int = Field(default=2, ge=1)
    """pick-or-drop jobs per vehicle before the master ends."""
    timeout_s: float = Field(default=600.0, gt=0.0)
    """wall-clock limit (s): the run fails when the jobs are not done by then."""
    action_s: float = Field(default=3.0, ge=0.0)
    """``duration`` parameter of every pick and drop (s)."""
    instant_period_s: float = Field(default=0.0, ge=0.0)
    """mean interval (s) of the stateRequest/factsheetRequest/pause instant actions (0: none)."""
    seed: int = Field(default=0, ge=0)
    """seed of the choice of stations."""
    traffic: bool = False
    """traffic control (issue 30): the vehicles share the floor; jobs go out in rounds, routes planned together,
    each order's base released as far as the action dependency graph allows (:class:`JobMaster`)."""
    margin_m: float = Field(default=2 * DEFAULT_MARGIN_M, ge=0.0)
    """traffic control: safety margin (m) between two vehicles' swept footprints (positioning, tracking errors)."""

    @model_validator(mode="after")
    def _distinct(self) -> FleetSpec:
        serials = [v.serial for v in self.vehicles]
        if len(set(serials)) != len(serials):
            raise ValueError(f"vehicles: serials must be distinct, got {serials}")
        for name in (self.interface, self.manufacturer, *serials):
            if not name or any(c in name for c in "/#+$"):
                raise ValueError(f"interface, manufacturer and serials are topic levels: no '/', '#', '+', '$' or "
                                 f"empty, got {name!r}")
        return self


def load_fleet_spec(path: str | Path) -> FleetSpec:
    """Read a fleet spec YAML file; a ScenarioError names file, line and key."""
    text = read_document_text(path, "fleet spec")
    data, nodes = load_yaml_document(text, str(path), "fleet spec")
    return validate_document(FleetSpec, data, nodes, str(path), Path(path).parent)


def job_master(fs: FleetSpec) -> JobMaster:
    """The :class:`JobMaster` of spec ``fs`` (its messages go nowhere until a transport sets ``send``).

    ValueError when the scenario has no route network or a vehicle starts off its nodes.
    """
    from agvnav.sim.mission import load_mission_network  # noqa: PLC0415 - a spec's scenario, read when used
    from agvnav.world.scenario import load_scenario  # noqa: PLC0415

    sc = load_scenario(fs.scenario)
    if sc.mission is None:
        raise ValueError(f"scenario {fs.scenario!r} has no route network (mission.network)")
    net = load_mission_network(sc)
    for v in fs.vehicles:
        if v.start not in net.nodes:
            raise ValueError(f"vehicle {v.serial!r} starts at {v.start!r}, not a node of {sc.mission.network!r}")
    map_id = sc.map if isinstance(sc.map, str) else str(sc.map.get("name", "map"))
    return JobMaster(net, map_id, fs.version, fs.manufacturer, [v.serial for v in fs.vehicles],
                     {v.serial: v.start for v in fs.vehicles}, lambda _s, _n, _m: None, sc.vehicle.model, fs.seed,
                     fs.instant_period_s, action_s=fs.action_s, traffic=fs.traffic, margin_m=fs.margin_m)
