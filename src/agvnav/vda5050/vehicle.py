"""A VDA 5050 vehicle: the order/state machine driving a simulated agvnav vehicle, with no transport.

:class:`VdaVehicle` wraps the closed loop of a scenario with a route network (``mission.network``;
the scenario's jobs are not driven: the vehicle starts idle at the mission's start pose) and takes
the master's messages through :meth:`VdaVehicle.receive`; what it publishes collects in
:meth:`VdaVehicle.drain` as ``(topic, message)``. :meth:`VdaVehicle.step` advances the simulated
clock one loop step. The transport (:mod:`agvnav.vda5050.bus`) only moves bytes.

Orders (VDA 5050 2.1 §6.6, 3.0 §6.1; the acceptance flow of their Figure 8):

* checked first for form (schema, then alternating sequence ids, base before horizon, 2.x edges
  naming the nodes either side): ``validationError`` / ``VALIDATION_FAILURE``;
* a new ``orderId`` while the vehicle still has node states or unfinished actions is refused
  (``orderError`` / ``OTHER_ORDER_ACTIVE``); its first node must lie within its
  ``allowedDeviationXY`` (default :attr:`VehicleConfig.start_tolerance_m`) of the estimated
  position (``noRouteError`` / ``START_NODE_OUT_OF_RANGE``);
* the same ``orderId``: a lower ``orderUpdateId`` is refused (``orderUpdateError`` /
  ``OUTDATED_ORDER_UPDATE``), the same one ignored (3.0: ``SAME_ORDER_UPDATE_ID`` when the content
  differs), a higher one stitched at the decision point, the last *released* base node (not the
  last node sent), or, when the order had been completed, at ``lastNodeId``/``lastNodeSequenceId``;
  anything else is refused (``orderUpdateError``; 3.0 after a cancel
  ``ORDER_UPDATE_FOLLOWING_CANCEL``) and the running order goes on untouched;
* every node must be a node of the network on the scenario's map (``noRouteError`` /
  ``NO_ROUTE_TO_TARGET``, 3.0 ``UNKNOWN_MAP_ID``), every edge an edge of the network from its
  start to its end node or a NURBS ``trajectory`` joining them, every action one the vehicle
  performs (``orderError`` / ``INVALID_ORDER_ACTION``).

A rejection's error stays in ``state.errors`` until an order is accepted. The vehicle drives the
released base from node to node: one :class:`~agvnav.navigation.mission.MissionAutopilot` leg
up to the next node with a SOFT, SINGLE or HARD action or the decision point, where it stops if
no update extended the base. An update that extends the base while a leg drives is driven on
without a stop at the old decision point: once the vehicle is on the leg's last edge, a new leg
from the last node passed takes over at the speed it has (``_extend_leg``). Actions (§6.12 /
3.0 §6.2.2): a node's actions are queued on arrival in order; NONE and SOFT run in parallel,
SINGLE and HARD alone; SOFT and HARD forbid driving until they end. ``pick``/``drop`` (a load
on/off), ``finePositioning`` take
:attr:`VehicleConfig.action_s` seconds (a ``duration`` parameter overrides); ``finePositioning``
then ends FAILED, with the reason, unless the estimate and its ``deviationRange`` put the vehicle
within the tolerance of its node (``_fine_positioning_failure``), except at a docking node.

Docking (issue 32; docs/docking.md): a scenario with a ``mission`` and a ``docking`` section has a
docking node, the network node named as the docking target, at the docking pose as the map places
the station and reached by one straight approach edge from its approach node
(:func:`agvnav.sim.docking.docking_node`, located errors). A ``finePositioning`` there runs the
station-relative docking: the leg ends at the approach node, the action turns RUNNING and the
docking (:func:`agvnav.sim.build.docking_autopilot`, the autopilot and station estimator of
``agvnav simulate``; the loop feeds the global and the station estimator) drives the approach
edge. It ends FINISHED, the docking node reached, only when the docking finished trusted; else
FAILED with the docking's reason (a reflector not seen, a pattern mismatch, 3 sigma over the
tolerance, ...), a ``nodeUnreachable`` error, and the vehicle holds on the approach until the
order is cancelled. A finePositioning at the docking node reached another way is refused
(``orderError`` / ``INVALID_ORDER_ACTION``). ``agvPosition`` stays the global estimate. A pause
holds the docking still; its own timers (recognition, settling) run on meanwhile.

Instant actions:
``startPause``/``stopPause``, ``cancelOrder`` (waiting and running actions FAILED, the vehicle
stops, the cancel FINISHED once it stands, and only then the node and edge states cleared, so a
master sees the order end by the cancel; without an order ``noOrderToCancel`` /
``NO_ORDER_TO_CANCEL``), ``initPosition`` (2.x) / ``initializePosition`` (3.0), ``stateRequest``,
``factsheetRequest``.

Positioning in the state, honestly: ``positionInitialized``/``localized`` is false while the
estimator is initialising or lost (the integrity monitor's verdict), and then the vehicle does
not start driving and reports ``localizationError`` / ``LOCALIZATION_ERROR`` (FATAL);
``localizationScore`` is the integrity monitor's 0-1 quality; ``deviationRange`` is the bound of
:class:`agvnav.positioning.deviation.DeviationWatch`, fed every loop step, stated from what the
vehicle knows: the larger of ``k sqrt(lambda_max(P_xy))`` of the position covariance
(``k = VehicleConfig.deviation_k``, 4.5: a consistent error exceeds it with probability 4e-5) and,
while the odometry moves, the last head revolution's bearings alone (their common offset plus
3 sigma of that fix: wheel slip carries the filter off its bearings before any check can tell);
while the estimate is in doubt (most reflectors in sight missing with reflections arriving --
an encoder dropout, a false lock --, late reflections, or the revolution's offset beyond
chance) the reach from the last trusted fix: its bound, plus how far the estimate moved since,
plus how far the vehicle could drive since at ``VehicleConfig.deviation_max_speed_m_s`` (the
factsheet's ``speedMax`` by default). ``agvnav bench vda5050`` measures the miss rate on the
true pose and says where the bound is too wide to be useful.
``safetyState.fieldViolation`` is true while the reaction to the safety fields slows or stops the
vehicle (mission scenarios have no reaction wired yet, so false).

``initPosition`` cannot seed agvnav's reflector estimators (they localise themselves from the
reflectors): it runs until the estimator has a fix, then FINISHES when the fix lies within
0.5 m and 10 deg of the given pose and FAILS otherwise, saying so.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime

import numpy as np
from pydantic import ValidationError

from agvnav.geometry import wrap_angle_scalar
from agvnav.guidance import HeadingHoldApproach
from agvnav.guidance.follower import PathFollower
from agvnav.navigation.docking import DockingAutopilot, DockingEstimate
from agvnav.navigation.guard import EstimatorWatch, GuardLimits, PositioningGuard
from agvnav.navigation.mission import MissionAutopilot
from agvnav.positioning.deviation import DeviationWatch, covariance_radius
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.positioning.station import to_station
from agvnav.roles import Estimator, Plant
from agvnav.routes.mission import Leg, chain_mission
from agvnav.routes.network import Edge as NetEdge
from agvnav.routes.network import EdgeCurve, RouteNetwork
from agvnav.routes.nurbs import Nurbs
from agvnav.routes.planning import Route, Traversal
from agvnav.sim.build import build, docking_autopilot, station_estimator
from agvnav.sim.docking import DockingNode, docking_node, true_station
from agvnav.sim.engine import ClosedLoop
from agvnav.sim.mission import load_mission_network, mission_autopilot
from agvnav.vda5050.messages import (
    Action,
    ActionSnap,
    ErrorSnap,
    FactsheetData,
    Node,
    Order,
    Snapshot,
    connection_message,
    factsheet_message,
    parse_instant_actions,
    parse_order,
    state_message,
    visualization_message,
    wall_time,
)
from agvnav.vda5050.messages import (
    Edge as OrderEdge,
)
from agvnav.vda5050.schemas import JsonObject, major, problems
from agvnav.world.scenario import Scenario

__all__ = ["INSTANT_ACTIONS", "ORDER_ACTIONS", "VdaVehicle", "VehicleConfig", "error_name"]

#: Actions an order's nodes may carry (edges: NONE ones only).
ORDER_ACTIONS = ("pick", "drop", "finePositioning")
#: Instant actions per major version (2.x ``initPosition``, 3.0 ``initializePosition``).
INSTANT_ACTIONS = {
    "v2": ("startPause", "stopPause", "cancelOrder", "initPosition", "stateRequest", "factsheetRequest"),
    "v3": ("startPause", "stopPause", "cancelOrder", "initializePosition", "stateRequest", "factsheetRequest"),
}

#: The error types: neutral name -> (2.x name, 3.0 name). 2.1 §6.6.4 and 3.0 Table 9.
_ERRORS = {
    "validation": ("validationError", "VALIDATION_FAILURE"),
    "order": ("orderError", "INVALID_ORDER_ACTION"),
    "other_active": ("orderError", "OTHER_ORDER_ACTIVE"),
    "outdated": ("orderUpdateError", "OUTDATED_ORDER_UPDATE"),
    "same_update": ("orderUpdateError", "SAME_ORDER_UPDATE_ID"),
    "after_cancel": ("orderUpdateError", "ORDER_UPDATE_FOLLOWING_CANCEL"),
    "stitch": ("orderUpdateError", "NO_ROUTE_TO_TARGET"),
    "no_route": ("noRouteError", "NO_ROUTE_TO_TARGET"),
    "start_range": ("noRouteError", "START_NODE_OUT_OF_RANGE"),
    "map": ("orderError", "UNKNOWN_MAP_ID"),
    "no_order_to_cancel": ("noOrderToCancel", "NO_ORDER_TO_CANCEL"),
    "instant": ("instantActionError", "INVALID_INSTANT_ACTION"),
    "localization": ("localizationError", "LOCALIZATION_ERROR"),
    "drive": ("nodeUnreachable", "NODE_UNREACHABLE"),
}

DONE = ("FINISHED", "FAILED")


def error_name(kind: str, version: str) -> str:
    """The error type of ``kind`` (a key of the table above) in ``version``."""
    v2, v3 = _ERRORS[kind]
    return v3 if major(version) == "v3" else v2


@dataclass(frozen=True)
class VehicleConfig:
    """How the vehicle speaks: identity, version, periods (s), tolerances (m), action times (s)."""

    manufacturer: str
    serial: str
    version: str = "2.1.0"
    interface: str = "uagv"
    state_period_s: float = 30.0
    """state published at least this often (the specification's maximum, 30 s)."""
    visualization_period_s: float = 1.0
    """visualization period (0: none)."""
    deviation_k: float = 4.5
    """deviationRange's ``k`` (sigmas of the position covariance's major axis; module doc)."""
    deviation_max_speed_m_s: float | None = None
    """the speed (m/s) the vehicle cannot exceed, for deviationRange's reach while the estimate is in
    doubt (module doc); None: the scenario's ``traction.speed_m_s`` (the factsheet's ``speedMax``)."""
    start_tolerance_m: float = 0.5
    """how far from a new order's first node counts as on it when the node gives no allowedDeviationXY."""
    node_tolerance_m: float = 0.1
    fine_tolerance_m: float = 0.01
    """how far from its node's network position ``finePositioning`` may end, estimate and its
    ``deviationRange`` included, unless the node's ``allowedDeviationXY`` says more (m)."""
    """how far an order's nodePosition may lie from the network's node."""
    action_s: dict[str, float] = field(default_factory=lambda: {"pick": 3.0, "drop": 3.0, "finePositioning": 1.0})
    epoch: datetime = field(default_factory=lambda: datetime.now(UTC))
    """the wall-clock instant of simulated time 0 (message timestamps follow the simulated clock)."""

    def __post_init__(self) -> None:
        major(self.version)
        if not (0.0 < self.state_period_s <= 30.0):
            raise ValueError(f"state_period_s must be in (0, 30] s (VDA 5050: at least every 30 s), "
                             f"got {self.state_period_s!r}")
        v_max = self.deviation_max_speed_m_s
        if not (self.deviation_k > 0.0 and (v_max is None or v_max > 0.0)):
            raise ValueError(f"deviation_k and deviation_max_speed_m_s must be > 0, got {self.deviation_k!r}, "
                             f"{v_max!r}")
        if self.visualization_period_s < 0.0:
            raise ValueError(f"visualization_period_s must be >= 0, got {self.visualization_period_s!r}")
        for name in (self.manufacturer, self.serial, self.interface):
            if not name or any(c in name for c in "/#+$"):
                raise ValueError(f"manufacturer, serial and interface are topic levels: no '/', '#', '+', '$' "
                                 f"or empty, got {name!r}")


class _Rejected(Exception):
    """An order refused: error kind, references, description."""

    def __init__(self, kind: str, refs: tuple[tuple[str, str], ...], text: str) -> None:
        super().__init__(text)
        self.kind, self.refs, self.text = kind, refs, text


@dataclass
class _ActionRun:
    """An action of the order or an instant one, and its run."""

    action: Action
    status: str = "WAITING"
    node_seq: int | None = None
    """sequence id of the node (or edge) that carries it (None: instant)."""
    ends: float = math.inf
    result: str | None = None


@dataclass
class _Item:
    """A node or edge of the held order (``edge`` with its traversal once checked)."""

    node: Node | None = None
    edge_id: str = ""
    seq: int = 0
    released: bool = False
    traversal: Traversal | None = None


class _Pilot:
    """The loop's autopilot: the current leg's MissionAutopilot, or standstill (idle, paused, stopping)."""

    signal_names = ("v_cmd", "driving")

    def __init__(self, family: str) -> None:
        self.family = family
        self.leg: MissionAutopilot | None = None
        self.dock: DockingAutopilot | None = None
        """the docking driving the approach edge into the docking node (finePositioning), or None."""
        self.hold = False
        self.finished = False
        self.v = 0.0

    def command(self, t: float, estimator: Estimator, plant: Plant, dt: float) -> tuple[float, ...]:
        """The docking's or the leg's command, or the family's standstill."""
        if self.dock is not None and not self.hold and not self.dock.finished:
            cmd = self.dock.command(t, estimator, plant, dt)
            self._driving(float(cmd[0]), cmd)
            return cmd
        if self.leg is None or self.hold or self.leg.finished:
            self.v = 0.0
            return (0.0, 0.0, 0.0) if self.family == "holonomic" else (0.0, 0.0)
        cmd = self.leg.command(t, estimator, plant, dt)
        self._driving(float(self.leg.pilot.signals()[0]), cmd)
        return cmd

    def _driving(self, v: float, cmd: tuple[float, ...]) -> None:
        """The commanded speed ``v`` (m/s); turning on the spot (a turn inside a leg, fine positioning) counts as
        driving (VDA 5050 ``driving``: moving and/or rotating), at no speed along x."""
        self.v = v
        if v == 0.0 and self.family != "steered" and any(c != 0.0 for c in cmd[1:]):
            self.v = 1e-5

    def reset_profile(self) -> None:
        """Restart the speed profile from standstill (after a pause or a lost link)."""
        if self.leg is not None:
            self.leg.profile.reset(0.0)
        if self.dock is not None:
            self.dock.approach.profile.reset(0.0)

    def signals(self) -> tuple[float, ...]:
        """``v_cmd`` (m/s), ``driving`` (0/1)."""
        return (self.v, float(abs(self.v) > 1e-6))


class VdaVehicle:
    """The VDA 5050 vehicle of scenario ``sc`` (module doc); messages in by :meth:`receive`, out by :meth:`drain`."""

    def __init__(self, sc: Scenario, config: VehicleConfig) -> None:
        if sc.mission is None:
            raise ValueError(f"scenario {sc.name!r} has no route network (mission.network): a VDA 5050 vehicle "
                             "drives the nodes and edges of one")
        self.sc, self.cfg = sc, config
        self.v3 = major(config.version) == "v3"
        built = build(sc)
        self.network: RouteNetwork = load_mission_network(sc)
        self.map_id = sc.map if isinstance(sc.map, str) else str(sc.map.get("name", "map"))
        pilot = built.autopilot
        if not isinstance(pilot, MissionAutopilot):
            raise ValueError("a VDA 5050 vehicle drives a mission scenario without reactive wiring (not supported yet)")
        follower = pilot.pilot.follower
        self._follower: PathFollower = follower.follower if isinstance(follower, HeadingHoldApproach) else follower
        self._plant = built.plant
        self._offset = built.point_offset
        s = sc.safety
        self._watch = EstimatorWatch(PositioningGuard(
            GuardLimits(s.lateral_3sigma_slow_m, s.lateral_3sigma_stop_m, s.slow_speed_fraction, s.resume_after_s),
            enabled=s.enabled and sc.goniometer is not None))
        self.estimator = built.estimator
        v_max = config.deviation_max_speed_m_s
        #: deviationRange's evidence and trusted fix (:class:`~agvnav.positioning.deviation.DeviationWatch`),
        #: fed every loop step; None for an estimator that is no streaming one
        speed = float(sc.traction.speed_m_s) if v_max is None else v_max
        streaming = isinstance(self.estimator, StreamingEstimator)
        self._deviation = DeviationWatch(speed, k=config.deviation_k) if streaming else None
        self._range: float | None = None
        self._range_t = math.nan
        self._docking: DockingEstimate | None = built.docking
        self.dock_node: DockingNode | None = None
        """the network's docking node of the scenario's docking target (None: no docking section)."""
        if built.docking is not None:
            if sc.docking is not None and sc.docking.guide_on != "station":
                raise sc.error(("docking", "guide_on"), "a VDA 5050 vehicle docks relative to the station "
                               "(guide_on: station): a stop on the map's station is never judged")
            self.dock_node = docking_node(sc, self.network, built.docking.station.target)
        self._dock_failed: str | None = None
        # a leg ends on arriving at its node: no fine positioning at standstill (that is the finePositioning action)
        self._leg_sc = sc.model_copy(update={"mission": sc.mission.model_copy(update={"align_heading": False})})
        self.pilot = _Pilot(str(built.plant.family))
        fed = built.docking if built.docking is not None else built.estimator  # a docking feeds both estimators
        self.loop = ClosedLoop(built.loop.plant, built.loop.sensors, fed, self.pilot, sc.step_s, sc.seed,
                               record_every=1_000_000)
        self.loop.start(1e9)
        self._t_after_end = 0.0
        """simulated time (s) once the loop's run has ended (:attr:`t`)."""
        self.truth_plant = built.loop.plant
        # order
        self.order_id, self.update_id = "", 0
        self.items: list[_Item] = []  # nodes and edges still ahead, the last traversed node first
        self.last_node, self.last_seq = "", 0
        self.actions: list[_ActionRun] = []
        self.instant: list[_ActionRun] = []
        self.cancelled = False
        self.cancel_run: _ActionRun | None = None
        self.paused = False
        self.loads: list[str] = []
        self.leg_nodes: list[tuple[str, int]] = []
        self.leg_passed = 0
        self.errors: dict[str, ErrorSnap] = {}
        self.information: dict[str, ErrorSnap] = {}
        self.failure: str | None = None
        self.link_lost_at: float | None = None
        """simulated time the broker connection was lost (None: connected); the vehicle holds meanwhile."""
        self._link_lost_pose = np.zeros(3)
        # publishing
        self.outbox: list[tuple[str, JsonObject]] = []
        self.header: dict[str, int] = {}
        self._state_due = True
        self._last_state_t = -math.inf
        self._last_vis_t = -math.inf
        self._last_pose = np.asarray(self.estimator.pose, dtype=np.float64).copy()
        self.velocity = (0.0, 0.0, 0.0)
        self.last_order_s: float | None = None
        """simulated time an order was last accepted (the latency bench reads it)."""
        self._update_localization()

    # ------------------------------------------------------------------------------ clock, time
    @property
    def t(self) -> float:
        """Simulated time (s); it runs on after the loop's run ended (a collision, lost positioning)."""
        return self.loop.t if self.loop.running else self._t_after_end

    @property
    def dt(self) -> float:
        """Loop step (s)."""
        return float(self.sc.step_s)

    def _now(self) -> datetime:
        return wall_time(self.cfg.epoch, self.t)

    def _next_header(self, topic: str) -> int:
        self.header[topic] = self.header.get(topic, -1) + 1
        return self.header[topic]

    def _publish(self, topic: str, message: JsonObject) -> None:
        self.outbox.append((topic, message))

    def drain(self) -> list[tuple[str, JsonObject]]:
        """The messages published since the last call, in order, as ``(topic, message)``."""
        out, self.outbox = self.outbox, []
        return out

    def connection(self, state: str) -> JsonObject:
        """A ``connection`` message (``state`` ONLINE, OFFLINE or BROKEN), not queued: the transport sends it."""
        c = self.cfg
        return connection_message(state, self._next_header("connection"), self._now(), c.version, c.manufacturer,
                                  c.serial)

    # ------------------------------------------------------------------------------ link to the master
    def link_lost(self) -> None:
        """The broker connection is lost: the vehicle stands still (an immediate zero command, as a pause)."""
        if self.link_lost_at is None:
            self.link_lost_at = self.t
            self._link_lost_pose = np.asarray(self.truth_plant.pose, dtype=np.float64).copy()
            self._decide()

    def link_restored(self) -> None:
        """The broker connection is back: an information entry says what happened; the order goes on."""
        if self.link_lost_at is None:
            return
        lost = self.link_lost_at
        self.link_lost_at = None
        moved = float(np.hypot(*(np.asarray(self.truth_plant.pose, dtype=np.float64)[:2] - self._link_lost_pose[:2])))
        self.information["link"] = ErrorSnap(
            "brokerConnectionLost", "INFO", (("lostAt", wall_time(self.cfg.epoch, lost).isoformat()),),
            f"broker connection lost for {self.t - lost:.1f} s; "
            f"the vehicle held still meanwhile ({moved:.2f} m while stopping) and resumed its order on reconnection")
        self.pilot.reset_profile()
        self._state_due = True

    # ------------------------------------------------------------------------------ inputs
    def receive(self, topic: str, payload: bytes | str | JsonObject) -> None:
        """A master's message on ``topic`` (``order`` or ``instantActions``); never raises on bad input."""
        try:
            msg = payload if isinstance(payload, dict) else json.loads(payload)
        except (ValueError, UnicodeDecodeError) as exc:
            self._error("validation", (("topic", topic),), f"malformed JSON: {exc}")
            return
        if not isinstance(msg, dict):
            self._error("validation", (("topic", topic),), "a message is a JSON object")
            return
        if topic == "order":
            self._receive_order(msg)
        elif topic == "instantActions":
            self._receive_instant(msg)
        self._state_due = True
        self._decide()  # an accepted order starts the drive in this step's command (order-to-motion latency)

    def _error(self, kind: str, refs: tuple[tuple[str, str], ...], text: str, level: str = "WARNING",
               slot: str = "order") -> None:
        self.errors[slot] = ErrorSnap(error_name(kind, self.cfg.version), level, refs, text[:500])
        self._state_due = True

    # ------------------------------------------------------------------------------ orders
    def _receive_order(self, msg: JsonObject) -> None:
        refs = tuple((k, str(msg[k])) for k in ("headerId", "orderId", "orderUpdateId") if k in msg)
        bad = problems(msg, self.cfg.version, "order", strict=False)
        try:
            if bad:
                raise _Rejected("validation", (("topic", "order"), *refs), "; ".join(bad[:3]))
            order = parse_order(msg)
            self._check_form(order, refs)
            self._accept(order, refs)
        except _Rejected as rej:
            # every rejection names the order (topic, headerId, orderId, orderUpdateId) and then what was wrong:
            # masters attribute a rejection to the order they sent by these references (2.1 §6.6.4)
            named = (("topic", "order"), *refs)
            self._error(rej.kind, (*named, *(r for r in rej.refs if r[0] not in dict(named))), rej.text)
        except ValidationError as exc:
            self._error("validation", (("topic", "order"), *refs), str(exc).splitlines()[0])

    def _check_form(self, o: Order, refs: tuple[tuple[str, str], ...]) -> None:
        def bad(text: str) -> _Rejected:
            return _Rejected("validation", (("topic", "order"), *refs), text)

        if not o.nodes or len(o.edges) != len(o.nodes) - 1:
            raise bad("an order has n nodes and n-1 edges between them")
        seqs = [o.nodes[0].sequence_id]
        for e, n in zip(o.edges, o.nodes[1:], strict=True):
            seqs += [e.sequence_id, n.sequence_id]
        if any(b <= a for a, b in itertools.pairwise(seqs)):
            raise bad("sequenceIds must increase along the order, node, edge, node, ...")
        released = [o.nodes[0].released] + [x.released for e, n in zip(o.edges, o.nodes[1:], strict=True)
                                            for x in (e, n)]
        if not released[0] or any(b and not a for a, b in itertools.pairwise(released)):
            raise bad("the base (released nodes and edges) must come first and start with the first node")
        for i, e in enumerate(o.edges):
            a, b = o.nodes[i].node_id, o.nodes[i + 1].node_id
            if (e.start_node_id not in (None, a)) or (e.end_node_id not in (None, b)):
                raise bad(f"edge {e.edge_id!r} does not join its nodes {a!r} and {b!r}")

    def _active(self) -> bool:
        return len(self.items) > 1 or any(r.status not in DONE for r in self.actions)

    def _base_end(self) -> _Item:
        """The decision point: the last released node held."""
        return [it for it in self.items if it.node is not None and it.released][-1]

    def _accept(self, o: Order, refs: tuple[tuple[str, str], ...]) -> None:
        if o.order_id != self.order_id:
            if self._active():
                raise _Rejected("other_active", (("orderId", o.order_id),),
                                f"order {self.order_id!r} is still active")
            items = self._check_feasible(o, 0)
            self._check_start(o.nodes[0])
            self._replace(o, items)
        else:
            if o.order_update_id < self.update_id:
                raise _Rejected("outdated", refs, f"orderUpdateId {o.order_update_id} < {self.update_id}")
            if o.order_update_id == self.update_id:
                if self.v3 and o != getattr(self, "_held", o):
                    raise _Rejected("same_update", refs, "same orderUpdateId, different content")
                return  # a resend: ignored
            if self.cancelled:
                raise _Rejected("after_cancel", refs, f"order {o.order_id!r} was cancelled")
            first = o.nodes[0]
            if self._active():
                end = self._base_end()
                at = (end.node.node_id, end.seq) if end.node is not None else ("", -1)
            else:
                at = (self.last_node, self.last_seq)
            if (first.node_id, first.sequence_id) != at:
                raise _Rejected("stitch", refs, f"the update starts at {first.node_id!r}/{first.sequence_id}, "
                                f"not at the decision point {at[0]!r}/{at[1]}")
            items = self._check_feasible(o, 1)
            self._stitch(o, items)
        self._held = o
        self.order_id, self.update_id = o.order_id, o.order_update_id
        self.cancelled = False
        self.errors.pop("order", None)
        self.information.pop("link", None)
        self.last_order_s = self.t
        self._state_due = True

    def _check_feasible(self, o: Order, start: int) -> list[_Item]:
        """The order's items from node ``start`` on, edges resolved to traversals; rejects what cannot be driven."""
        oid = (("orderId", o.order_id),)
        out: list[_Item] = []
        for i, n in enumerate(o.nodes):
            if n.node_id not in self.network.nodes:
                raise _Rejected("no_route", (*oid, ("nodeId", n.node_id)), f"no node {n.node_id!r} in the network")
            p = n.node_position
            net = self.network.nodes[n.node_id]
            if p is not None:
                if p.map_id != self.map_id:
                    raise _Rejected("map", (*oid, ("mapId", p.map_id)), f"unknown map {p.map_id!r}")
                if math.hypot(p.x - net.x, p.y - net.y) > self.cfg.node_tolerance_m:
                    raise _Rejected("no_route", (*oid, ("nodeId", n.node_id)),
                                    f"node {n.node_id!r} is at ({net.x:g}, {net.y:g}) m, not ({p.x:g}, {p.y:g})")
            for a in n.actions:
                if a.action_type not in ORDER_ACTIONS:
                    raise _Rejected("order", (*oid, ("actionId", a.action_id), ("actionType", a.action_type)),
                                    f"unsupported action {a.action_type!r}")
                if a.action_type == "finePositioning" and i >= start:
                    self._check_docking(o, i, a, oid)
            if i > 0:
                e = o.edges[i - 1]
                for a in e.actions:
                    if a.action_type not in ORDER_ACTIONS or a.blocking_type != "NONE":
                        raise _Rejected("order", (*oid, ("actionId", a.action_id)),
                                        "edge actions: only NONE pick/drop/finePositioning")
                trav = self._traversal(o.nodes[i - 1].node_id, n.node_id, e, oid)
                if i >= start:
                    out.append(_Item(None, e.edge_id, e.sequence_id, e.released, trav))
            if i >= start:
                out.append(_Item(n, n.node_id, n.sequence_id, n.released))
        return out

    def _check_docking(self, o: Order, i: int, a: Action, oid: tuple[tuple[str, str], ...]) -> None:
        """A finePositioning at the docking node must be reached over the approach edge (it docks on that edge)."""
        dn = self.dock_node
        if dn is None or o.nodes[i].node_id != dn.node:
            return
        if i == 0 or o.nodes[i - 1].node_id != dn.approach or o.edges[i - 1].trajectory is not None:
            raise _Rejected("order", (*oid, ("nodeId", dn.node), ("actionId", a.action_id)),
                            f"finePositioning at docking node {dn.node!r} docks over the approach edge {dn.edge!r}: "
                            f"the order must reach {dn.node!r} from {dn.approach!r}")

    def _traversal(self, a: str, b: str, from_order: OrderEdge, oid: tuple[tuple[str, str], ...]) -> Traversal:
        edge_id = from_order.edge_id
        refs = (*oid, ("edgeId", edge_id))
        cap = from_order.max_speed
        if from_order.trajectory is not None:
            tr = from_order.trajectory
            n = len(tr.control_points)
            p = tr.degree
            knots = tr.knot_vector or tuple([0.0] * (p + 1) + [k / (n - p) for k in range(1, n - p)] + [1.0] * (p + 1))
            try:
                nurbs = Nurbs(p, tuple(knots), np.array([[c.x, c.y] for c in tr.control_points]),
                              np.array([c.weight for c in tr.control_points]))
                pts, hd, length = nurbs.sample(0.05)
            except ValueError as exc:
                raise _Rejected("validation", refs, f"trajectory of {edge_id!r}: {exc}") from None
            gap = self.network.spec.tolerances.gap_m
            na, nb = self.network.nodes[a], self.network.nodes[b]
            if math.hypot(*(pts[0] - (na.x, na.y))) > gap or math.hypot(*(pts[-1] - (nb.x, nb.y))) > gap:
                raise _Rejected("no_route", refs, f"trajectory of {edge_id!r} does not join {a!r} and {b!r}")
            curv = np.gradient(np.unwrap(hd), length / (len(pts) - 1))
            speed = cap if cap is not None else self.sc.traction.speed_m_s
            edge = NetEdge(edge_id, a, b, EdgeCurve("nurbs", pts, hd, curv, length), speed, (1,), None, ())
            return Traversal(edge, 1)
        model = self.sc.vehicle.model
        for net in self.network.edges.values():
            if net.source == a and net.target == b and net.allows(model):
                if cap is not None:
                    net = replace(net, speed=min(net.speed, cap))
                return Traversal(net, 1 if 1 in net.modes else -1)
        raise _Rejected("no_route", refs, f"no edge from {a!r} to {b!r} in the network for a {model} vehicle")

    def _check_start(self, first: Node) -> None:
        if not self._localized:
            raise _Rejected("start_range", (("nodeId", first.node_id),), "the vehicle is not localized")
        net = self.network.nodes[first.node_id]
        tol = self.cfg.start_tolerance_m
        if first.node_position is not None and first.node_position.allowed_deviation_xy is not None:
            tol = max(tol, first.node_position.allowed_deviation_xy)
        x, y = (float(c) for c in self.estimator.pose[:2])
        if math.hypot(x - net.x, y - net.y) > tol:
            raise _Rejected("start_range", (("nodeId", first.node_id),),
                            f"first node {first.node_id!r} is {math.hypot(x - net.x, y - net.y):.2f} m away "
                            f"(allowed {tol:g} m)")

    def _replace(self, o: Order, items: list[_Item]) -> None:
        self.actions = [r for r in self.actions if r.status not in DONE]  # none: the vehicle was idle
        self._dock_failed = None
        self.errors.pop("dock", None)
        self.items = items
        self.loads = self.loads
        for it in items:
            self._queue_actions(it, o)
        self._traverse(items[0])

    def _stitch(self, o: Order, items: list[_Item]) -> None:
        end = self._base_end()
        keep = self.items[: self.items.index(end) + 1]
        # the horizon held is dropped with its (waiting) actions; the stitching node keeps its own
        dropped = {it.seq for it in self.items[len(keep):]}
        self.actions = [r for r in self.actions if r.node_seq not in dropped]
        keep[-1] = replace(end, released=True)
        self.items = keep + items
        for it in items:
            self._queue_actions(it, o)

    def _queue_actions(self, it: _Item, o: Order) -> None:
        acts = it.node.actions if it.node is not None else next(
            (e.actions for e in o.edges if e.sequence_id == it.seq), ())
        self.actions += [_ActionRun(a, node_seq=it.seq) for a in acts]

    # ------------------------------------------------------------------------------ progress
    def _traverse(self, node: _Item) -> None:
        """The vehicle reached ``node`` (the first item): last node, states, its actions become due."""
        assert node.node is not None
        self.last_node, self.last_seq = node.node.node_id, node.seq
        i = self.items.index(node)
        self.items = self.items[i:]
        self._state_due = True

    def _leg_route(self) -> tuple[list[Traversal], list[tuple[str, int]]]:
        """The released edges ahead and their nodes, up to the next node with blocking actions, the decision point
        or the approach edge of a docking (its approach node ends the leg)."""
        travs: list[Traversal] = []
        nodes: list[tuple[str, int]] = []
        for it in self.items[1:]:
            if not it.released:
                break
            if it.traversal is not None:
                if self._docks_over(it):  # the leg ends at the approach node; the docking drives this edge
                    break
                travs.append(it.traversal)
                continue
            assert it.node is not None
            nodes.append((it.node.node_id, it.seq))
            if any(a.blocking_type != "NONE" for a in it.node.actions):
                break
        return travs[:len(nodes)], nodes

    def _start_leg(self) -> None:
        """Drive the released edges ahead up to the next node with blocking actions or the decision point."""
        travs, nodes = self._leg_route()
        if not travs:
            if len(self.items) > 1 and self.items[1].released and self._docks_over(self.items[1]):
                self._start_docking(self.items[2])
            return
        self._drive(travs, nodes, 0.0)

    def _drive(self, travs: list[Traversal], nodes: list[tuple[str, int]], v0: float) -> None:
        """One leg from the last node passed over ``travs`` to ``nodes``, its speed profile starting at ``v0`` (m/s)."""
        net = self.network
        start = net.nodes[self.last_node]
        route = Route(tuple(travs), (self.last_node, *(n for n, _ in nodes)), 0.0)
        leg = Leg(0, "goto", nodes[-1][0], route, 0.0)
        try:
            plan = chain_mission([leg], np.array([start.x, start.y]), math.radians(net.spec.tolerances.heading_deg))
            pilot = mission_autopilot(self._leg_sc, plan, self._follower, self._plant, self._offset, self._watch)
        except ValueError as exc:
            self._fail_drive(nodes[0][0], str(exc))
            return
        if v0 != 0.0:
            pilot.profile.reset(v0)
        self.pilot.leg = pilot
        self.leg_nodes, self.leg_passed = nodes, 0
        self._state_due = True

    def _extend_leg(self) -> None:
        """An update released more of the route while a leg drives to the old decision point: once on the leg's
        last edge, drive on (a new leg from the last node passed over the released edges ahead, at the speed the
        vehicle has; its progress catches up within a step per metre) instead of stopping at the old end.

        Not while the leg holds (paused, blocked, not localized), nor with point switching (a steered vehicle's
        stints hand over between points C and O on the move).
        """
        leg = self.pilot.leg
        if (leg is None or leg.finished or self.pilot.hold or self.leg_passed != len(self.leg_nodes) - 1
                or (self.sc.mission is not None and self.sc.mission.point_switching)):
            return
        travs, nodes = self._leg_route()
        if len(nodes) <= 1 or nodes[0] != self.leg_nodes[-1]:
            return
        self._drive(travs, nodes, float(leg.profile.v))

    def _fine_runs(self, seq: int) -> list[_ActionRun]:
        return [r for r in self.actions if r.node_seq == seq and r.action.action_type == "finePositioning"]

    def _docks_over(self, edge: _Item) -> bool:
        """True when ``edge`` is the approach edge into the docking node and a finePositioning waits there."""
        dn = self.dock_node
        if dn is None or edge.traversal is None or edge.traversal.edge.id != dn.edge:
            return False
        i = self.items.index(edge)
        node = self.items[i + 1] if i + 1 < len(self.items) else None
        return (node is not None and node.released and node.node is not None and node.node.node_id == dn.node
                and any(r.status == "WAITING" for r in self._fine_runs(node.seq)))

    def _start_docking(self, node: _Item) -> None:
        """Standing at the approach node: the docking (a fresh station estimator) drives the approach edge; the
        node's finePositioning RUNS meanwhile (module doc)."""
        est = self._docking
        assert est is not None and node.node is not None
        est.station = station_estimator(self.sc, est.station.target)
        self.pilot.dock = docking_autopilot(self.sc, est.station.target, self._plant, est)
        for r in self._fine_runs(node.seq):
            if r.status == "WAITING":
                r.status, r.ends = "RUNNING", math.inf
        self.leg_nodes, self.leg_passed = [(node.node.node_id, node.seq)], 0
        self._state_due = True

    def _end_docking(self, dock: DockingAutopilot) -> None:
        """The docking judged: FINISHED and the docking node reached only when it finished trusted; else the
        finePositioning FAILED with the docking's reason and the vehicle holds on the approach (module doc)."""
        self.pilot.dock = None
        node_id, seq = self.leg_nodes[0]
        runs = [r for r in self._fine_runs(seq) if r.status == "RUNNING"]
        if dock.phase == "finished" and dock.failure is None:
            pos, head, sig, _ = dock.errors()
            off = math.hypot(float(dock.offset[0]), float(dock.offset[1]))
            for r in runs:
                r.status = "FINISHED"
                r.result = (f"docked at {node_id!r} relative to its target: estimated error {pos * 1e3:.2f} mm, "
                            f"{math.degrees(head):.3f} deg, 3 sigma {sig * 1e3:.2f} mm; station measured "
                            f"{off * 1e3:.1f} mm off the map")
            self.leg_passed = 1
            self._traverse(next(it for it in self.items if it.node is not None and it.seq == seq))
        else:
            reason = dock.failure or "docking ended unjudged"
            for r in runs:
                r.status, r.result = "FAILED", reason
            self._dock_failed = reason
            self._error("drive", (("nodeId", node_id),), f"docking at {node_id!r} failed, the vehicle holds on the "
                        f"approach (cancel the order): {reason}", slot="dock")
        self._idle_station()
        self._state_due = True

    def _idle_station(self) -> None:
        """A fresh, idle station estimator once a docking is over (it served that docking only)."""
        if self._docking is not None:
            self._docking.station = station_estimator(self.sc, self._docking.station.target)

    def docking_true_error(self) -> tuple[float, float] | None:
        """The true error (m, rad) of base_link against the docking pose on the true station, or None without a
        docking node (the simulator's instrument: the scenario's ``docking.truth``)."""
        if self._docking is None:
            return None
        target = self._docking.station.target
        rel = to_station(true_station(self.sc, target), np.asarray(self.truth_plant.pose, dtype=np.float64)[:3])
        d = target.docking_pose
        return float(math.hypot(rel[0] - d[0], rel[1] - d[1])), abs(wrap_angle_scalar(float(rel[2] - d[2])))

    def _fail_drive(self, node_id: str, text: str) -> None:
        self._error("drive", (("nodeId", node_id),), text, level="FATAL", slot="drive")
        self.pilot.leg = None
        self.failure = text

    def _progress(self) -> None:
        if self.pilot.dock is not None:
            if self.pilot.dock.finished:
                self._end_docking(self.pilot.dock)
            return
        leg = self.pilot.leg
        if leg is None:
            return
        sig = leg.signals()
        # the leg's last node is reached when the leg has stopped there (not on creeping within 5 cm of it)
        passed = min(int(sig[leg.signal_names.index("nodes_passed")]), len(self.leg_nodes) - 1)
        if leg.finished:
            passed = len(self.leg_nodes) if leg.failure is None else passed
        while self.leg_passed < min(passed, len(self.leg_nodes)):
            _, seq = self.leg_nodes[self.leg_passed]
            self.leg_passed += 1
            item = next(it for it in self.items if it.node is not None and it.seq == seq)
            self._traverse(item)
        if leg.finished:
            if leg.failure is not None:
                self._fail_drive(self.leg_nodes[min(self.leg_passed, len(self.leg_nodes) - 1)][0], leg.failure)
            self.pilot.leg = None

    # ------------------------------------------------------------------------------ actions
    def _run_actions(self) -> None:
        """Start and finish the due actions by their blocking types (3.0 §6.2.2 Figure 11)."""
        t = self.t
        for r in [*self.actions, *self.instant]:
            if r.status == "RUNNING" and t >= r.ends:
                self._finish(r)
        due = [r for r in self.actions if r.status not in DONE and r.node_seq is not None
               and r.node_seq <= self.last_seq]
        running = [r for r in due if r.status == "RUNNING"]
        for r in due:
            if r.status != "WAITING":
                continue
            alone = r.action.blocking_type in ("HARD", "SINGLE")
            if r.action.blocking_type in ("SOFT", "HARD") and abs(self.pilot.v) > 1e-6:
                break  # no automatic driving with it: it starts once the vehicle stands
            if alone and running:
                break
            if any(x.action.blocking_type in ("HARD", "SINGLE") for x in running):
                break
            self._start(r)
            running.append(r)
            if alone:
                break

    def _blocking(self) -> bool:
        """True while a SOFT or HARD action of a node reached is not done (no automatic driving)."""
        return any(r.status not in DONE and r.action.blocking_type in ("SOFT", "HARD") and r.node_seq is not None
                   and r.node_seq <= self.last_seq for r in self.actions)

    def _start(self, r: _ActionRun) -> None:
        d = r.action.parameter("duration")
        dur = float(d) if isinstance(d, int | float) else self.cfg.action_s.get(r.action.action_type, 0.0)
        r.status, r.ends = "RUNNING", self.t + dur
        self._state_due = True

    def _finish(self, r: _ActionRun) -> None:
        kind = r.action.action_type
        load = r.action.parameter("loadId")
        if kind == "pick":
            self.loads.append(str(load) if load is not None else r.action.action_id)
        elif kind == "drop" and self.loads:
            self.loads.remove(str(load)) if load is not None and str(load) in self.loads else self.loads.pop()
        elif kind == "finePositioning":
            r.result = self._fine_positioning_failure(r)
        r.status = "FINISHED" if r.result is None else "FAILED"
        self._state_due = True

    def _fine_positioning_failure(self, r: _ActionRun) -> str | None:
        """Why the vehicle's stop at ``r``'s node cannot be trusted as fine positioning, or None.

        Judged on the global estimate: not localized, or the estimated distance to the node's
        network position plus the stated ``deviationRange`` beyond the tolerance
        (:attr:`VehicleConfig.fine_tolerance_m` or the node's ``allowedDeviationXY``). At the docking
        node the docking judges instead (:meth:`_end_docking`).
        """
        item = next((it for it in self.items if it.seq == r.node_seq and it.node is not None), None)
        bound = self.deviation_range()
        if item is None or item.node is None or bound is None or not self._localized:
            return "not localized: fine positioning cannot be judged"
        net = self.network.nodes[item.node.node_id]
        tol = self.cfg.fine_tolerance_m
        p = item.node.node_position
        if p is not None and p.allowed_deviation_xy is not None:
            tol = max(tol, float(p.allowed_deviation_xy))
        x, y = (float(c) for c in self.estimator.pose[:2])
        off = math.hypot(x - net.x, y - net.y)
        if off + bound > tol:
            return (f"stopped {off * 1e3:.1f} mm from node {item.node.node_id!r} with a deviationRange of "
                    f"{bound * 1e3:.1f} mm: beyond the {tol * 1e3:.1f} mm tolerance")
        return None

    # ------------------------------------------------------------------------------ instant actions
    def _receive_instant(self, msg: JsonObject) -> None:
        refs = (("topic", "instantActions"), *((k, str(msg[k])) for k in ("headerId",) if k in msg))
        m = dict(msg)
        if "actions" not in m and "instantActions" in m:  # 1.1's key, still sent by some 2.0 masters
            m["actions"] = m.pop("instantActions")
        bad = problems(m, self.cfg.version, "instantActions", strict=False)
        if bad:
            self._error("validation", refs, "; ".join(bad[:3]), slot="instant")
            return
        try:
            ia = parse_instant_actions(msg)
        except ValidationError as exc:
            self._error("validation", refs, str(exc).splitlines()[0], slot="instant")
            return
        known = INSTANT_ACTIONS[major(self.cfg.version)]
        for a in ia.actions:
            if a.action_type not in known:
                self._error("instant", (("actionId", a.action_id), ("actionType", a.action_type)),
                            f"unsupported instant action {a.action_type!r}", slot="instant")
                self.instant.append(_ActionRun(a, "FAILED", result="unsupported"))
                continue
            self.errors.pop("instant", None)
            r = _ActionRun(a, "RUNNING")
            self.instant.append(r)
            self._instant(r)
        self.instant = self.instant[-20:]

    def _instant(self, r: _ActionRun) -> None:
        kind = r.action.action_type
        if kind == "startPause":
            self.paused = True
            r.status = "FINISHED"
        elif kind == "stopPause":
            self.paused = False
            self.pilot.reset_profile()
            r.status = "FINISHED"
        elif kind == "cancelOrder":
            self._cancel(r)
        elif kind in ("initPosition", "initializePosition"):
            r.status = "RUNNING"  # judged in _check_init once the estimator has a fix
        elif kind == "stateRequest":
            r.status = "FINISHED"
        elif kind == "factsheetRequest":
            self._publish("factsheet", self.factsheet())
            r.status = "FINISHED"
        self._state_due = True

    def _cancel(self, r: _ActionRun) -> None:
        if not self._active() or self.cancelled:
            r.status, r.result = "FAILED", "no order to cancel"
            self._error("no_order_to_cancel", (("actionId", r.action.action_id),), "no order to cancel")
            return
        for a in self.actions:
            if a.status not in DONE:
                a.status, a.result = "FAILED", "cancelled"
        if self.pilot.dock is not None:
            self._idle_station()
        self.pilot.leg = self.pilot.dock = None  # no new leg while cancelling (_decide)
        self.cancelled = True
        self.cancel_run = r  # FINISHED once the vehicle stands; the node and edge states are cleared then

    def _check_instant(self) -> None:
        if self.cancel_run is not None and abs(self.pilot.v) < 1e-6 and self._speed() < 0.01:
            self.cancel_run.status = "FINISHED"
            self.cancel_run = None
            self.items = self.items[:1]
            self._state_due = True
        for r in self.instant:
            if r.status == "RUNNING" and r.action.action_type in ("initPosition", "initializePosition"):
                self._check_init(r)

    def _check_init(self, r: _ActionRun) -> None:
        if not self._localized:
            return
        p = {k: r.action.parameter(k) for k in ("x", "y", "theta")}
        if not all(isinstance(v, int | float) for v in p.values()):
            r.status, r.result = "FAILED", "x, y and theta parameters are required"
        else:
            x, y, th = (float(self.estimator.pose[i]) for i in range(3))
            d = math.hypot(x - float(p["x"]), y - float(p["y"]))  # type: ignore[arg-type]
            dth = abs(wrap_angle_scalar(th - float(p["theta"])))  # type: ignore[arg-type]
            ok = d <= 0.5 and dth <= math.radians(10.0)
            r.status = "FINISHED" if ok else "FAILED"
            r.result = f"reflector fix {d:.3f} m, {math.degrees(dth):.1f} deg from the given pose"
        self._state_due = True

    # ------------------------------------------------------------------------------ positioning
    @property
    def _localized(self) -> bool:
        return bool(self.estimator.status not in ("initialising", "lost") and np.all(np.isfinite(self.estimator.pose)))

    def _update_localization(self) -> None:
        was = "localization" in self.errors
        if self._localized:
            self.errors.pop("localization", None)
        else:
            self.errors["localization"] = ErrorSnap(error_name("localization", self.cfg.version), "FATAL", (),
                                                    f"positioning {self.estimator.status}: not localized")
        if was != ("localization" in self.errors):
            self._state_due = True

    def deviation_range(self) -> float | None:
        """The stated bound (m) of the position error (module doc), None while not localized."""
        if not self._localized:
            return None
        if self._range_t != self.t:
            self._update_range()
        return self._range

    def _update_range(self) -> None:
        """Feed the deviation watch the estimate of this step (every step: it keeps the last trusted fix)."""
        self._range_t = self.t
        est = self.estimator
        if self._deviation is not None and isinstance(est, StreamingEstimator):
            self._range = self._deviation.update(est)
        elif self._localized and est.status == "tracking":  # no evidence to judge with: the covariance alone
            self._range = covariance_radius(np.asarray(est.covariance, dtype=np.float64)[:2, :2], self.cfg.deviation_k)
        else:
            self._range = None
        if self._range is not None and not math.isfinite(self._range):
            self._range = None

    def _speed(self) -> float:
        return math.hypot(self.velocity[0], self.velocity[1])

    # ------------------------------------------------------------------------------ step
    def step(self) -> None:
        """One loop step of the simulated vehicle, its order and actions; queues what it publishes."""
        if self.loop.running:
            t = self.loop.t + self.dt
            self.loop.step()
            if not self.loop.running:
                self._t_after_end = t
                self.pilot.v = 0.0  # the vehicle stands, dead
                failure = self.loop.finish().failure or "stopped"
                if self.failure is None:
                    self.failure = failure
                    self._fail_drive(self.last_node, f"the vehicle stopped: {self.failure}")
        else:
            self._t_after_end += self.dt
        pose = np.asarray(self.estimator.pose, dtype=np.float64)
        d = pose - self._last_pose
        c, s = math.cos(pose[2]), math.sin(pose[2])
        if np.all(np.isfinite(d)):
            self.velocity = ((c * d[0] + s * d[1]) / self.dt, (-s * d[0] + c * d[1]) / self.dt,
                             wrap_angle_scalar(float(d[2])) / self.dt)
        self._last_pose = pose.copy()
        self._update_range()
        was_driving = self.pilot.v != 0.0
        self._update_localization()
        self._progress()
        self._run_actions()
        self._check_instant()
        self._decide()
        if was_driving != (self.pilot.v != 0.0):
            self._state_due = True
        self._emit()

    def _decide(self) -> None:
        """Hold while paused, blocked or not localized; start the next leg when there is one to drive."""
        self.pilot.hold = self.paused or self._blocking() or not self._localized or self.link_lost_at is not None
        if self.cancel_run is None and self.failure is None:
            self._extend_leg()
        if (self.pilot.leg is None and self.pilot.dock is None and not self.pilot.hold and self.failure is None
                and self.cancel_run is None and self._dock_failed is None and len(self.items) > 1):
            self._start_leg()

    def run_until(self, t: float, on_step: Callable[[], None] | None = None) -> None:
        """Step until simulated time ``t`` (s); ``on_step`` after each step."""
        while self.t < t - 1e-9:
            self.step()
            if on_step is not None:
                on_step()

    def _emit(self) -> None:
        t = self.t
        if self._state_due or t - self._last_state_t >= self.cfg.state_period_s - 1e-9:
            self._publish("state", self.state())
            self._last_state_t, self._state_due = t, False
        vp = self.cfg.visualization_period_s
        if vp > 0.0 and t - self._last_vis_t >= vp - 1e-9:
            c = self.cfg
            self._publish("visualization", visualization_message(
                self.snapshot(), self._next_header("visualization"), c.version, c.manufacturer, c.serial,
                self.header.get("state", 0)))
            self._last_vis_t = t

    # ------------------------------------------------------------------------------ messages
    def snapshot(self) -> Snapshot:
        """What the vehicle reports now (version-neutral)."""
        pose = tuple(float(v) for v in self.estimator.pose)
        nodes = tuple((it.node.node_id, it.seq, it.released, self.network.nodes[it.node.node_id].x,
                       self.network.nodes[it.node.node_id].y, self.network.nodes[it.node.node_id].heading)
                      for it in self.items[1:] if it.node is not None)
        edges = tuple((it.edge_id, it.seq, it.released) for it in self.items if it.node is None)
        acts = tuple(ActionSnap(r.action.action_id, r.action.action_type, r.status, r.result, r.node_seq is None)
                     for r in [*self.actions, *self.instant])
        quality = getattr(self.estimator, "quality", None)
        last = self.items[0] if self.items else None
        dist = 0.0
        if last is not None and last.node is not None and self._localized:
            n = self.network.nodes[last.node.node_id]
            dist = math.hypot(pose[0] - n.x, pose[1] - n.y)
        return Snapshot(
            t_wall=self._now(), order_id=self.order_id, order_update_id=self.update_id, last_node_id=self.last_node,
            last_node_sequence_id=self.last_seq, nodes=nodes, edges=edges, driving=abs(self.pilot.v) > 1e-6,
            paused=self.paused, new_base_request=False, distance_since_last_node=dist,
            pose=(pose[0], pose[1], pose[2]), map_id=self.map_id, localized=self._localized,
            localization_score=float(quality) if isinstance(quality, float) and self._localized else None,
            deviation_range=self.deviation_range(), velocity=self.velocity, actions=acts,
            errors=tuple(self.errors.values()), loads=tuple(self.loads),
            information=tuple(self.information.values()),
        )

    def state(self) -> JsonObject:
        """A ``state`` message now (takes the next header id)."""
        c = self.cfg
        return state_message(self.snapshot(), self._next_header("state"), c.version, c.manufacturer, c.serial)

    def factsheet(self) -> JsonObject:
        """The ``factsheet`` message from the vehicle spec (kinematics, REFLECTOR, physical limits)."""
        v, tc, c = self.sc.vehicle, self.sc.traction, self.cfg
        kin = {"holonomic": "OMNI", "unicycle": "DIFF", "steered": "THREEWHEEL"}[str(self._plant.family)]
        scopes: list[tuple[str, tuple[str, ...]]] = [(a, ("NODE", "EDGE")) for a in ORDER_ACTIONS]
        scopes += [(a, ("INSTANT",)) for a in INSTANT_ACTIONS[major(c.version)]]
        data = FactsheetData(
            series=f"agvnav {v.model}", kinematic=kin, speed_max=tc.speed_m_s, accel_max=tc.max_accel_m_s2,
            decel_max=tc.max_decel_m_s2, length=float(v.body_length_m), width=float(getattr(v, "body_width_m", 0.0)),
            height_max=2.0, actions=tuple(scopes), min_state_interval=self.dt)
        return factsheet_message(data, self._next_header("factsheet"), self._now(), c.version, c.manufacturer,
                                 c.serial)

    def true_position_error(self) -> float:
        """Distance (m) between the estimated and the true base_link position (the simulator's instrument)."""
        truth = np.asarray(self.truth_plant.pose, dtype=np.float64)
        est = np.asarray(self.estimator.pose, dtype=np.float64)
        return float(math.hypot(est[0] - truth[0], est[1] - truth[1]))
