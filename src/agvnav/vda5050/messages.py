"""VDA 5050 messages as pydantic models: the master's order and instant actions read, the vehicle's messages built.

Reading (:func:`parse_order`, :func:`parse_instant_actions`): one model serves every version; the
names that differ between versions are alias choices (2.0's ``allowedDeviationXy`` and 2.1's
``allowedDeviationXY``, 2.x ``maxSpeed`` and 3.0 ``maximumSpeed``; 3.0's ``allowedDeviationXY``
ellipse is read as its larger half axis). A 2.0 instant-action message whose array sits under the
1.1 key ``instantActions`` is accepted (:attr:`InstantActions.legacy_key` says so); what the vehicle
publishes is only what its version's schema defines.

Building (:func:`state_message`, :func:`visualization_message`, :func:`connection_message`,
:func:`factsheet_message`): the vehicle's neutral :class:`Snapshot` rendered through the version's
models (:class:`StateV2`, :class:`StateV3`, ...), whose field names are the schema's keys
(camelCase on purpose: the model *is* the wire format). Every built message is checked against
the official schema and for unknown keys (:func:`agvnav.vda5050.schemas.problems`) in the tests,
for every version.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Literal

from pydantic import AliasChoices, BaseModel, ConfigDict, Field, field_validator

from agvnav.geometry import wrap_angle_scalar
from agvnav.vda5050.schemas import JsonObject, major

__all__ = [
    "Action",
    "ActionParameter",
    "ActionSnap",
    "ControlPoint",
    "Edge",
    "ErrorSnap",
    "FactsheetData",
    "InstantActions",
    "Node",
    "NodePosition",
    "Order",
    "Snapshot",
    "StateV2",
    "StateV3",
    "Trajectory",
    "connection_message",
    "factsheet_message",
    "iso_timestamp",
    "parse_instant_actions",
    "parse_order",
    "state_message",
    "visualization_message",
]

# ---------------------------------------------------------------------------------------------- read


class _In(BaseModel):
    """A master's message part: unknown keys ignored here (the schema check reports them)."""

    model_config = ConfigDict(extra="ignore", populate_by_name=True, frozen=True)


class ActionParameter(_In):
    """One ``{key, value}`` action parameter."""

    key: str
    value: object = None


class Action(_In):
    """An action of a node, an edge or an instant-action message."""

    action_type: str = Field(validation_alias=AliasChoices("actionType", "actionName"))
    action_id: str = Field(validation_alias="actionId")
    blocking_type: Literal["NONE", "SOFT", "SINGLE", "HARD"] = Field(validation_alias="blockingType")
    action_parameters: tuple[ActionParameter, ...] = Field(default=(), validation_alias="actionParameters")

    def parameter(self, key: str) -> object:
        """The value of parameter ``key`` (None when absent)."""
        return next((p.value for p in self.action_parameters if p.key == key), None)


class NodePosition(_In):
    """Where a node is (m, rad) on map ``map_id``, and how far from it counts as there (m, rad)."""

    x: float
    y: float
    theta: float | None = None
    allowed_deviation_xy: float | None = Field(
        default=None, validation_alias=AliasChoices("allowedDeviationXY", "allowedDeviationXy"))
    allowed_deviation_theta: float | None = Field(default=None, validation_alias="allowedDeviationTheta")
    map_id: str = Field(validation_alias="mapId")

    @field_validator("allowed_deviation_xy", mode="before")
    @classmethod
    def _ellipse(cls, value: object) -> object:
        """3.0's ellipse ``{a, b, theta}``: its larger half axis (m)."""
        if isinstance(value, dict):
            return max(float(value.get("a", 0.0)), float(value.get("b", 0.0)))
        return value


class Node(_In):
    """An order node."""

    node_id: str = Field(validation_alias="nodeId")
    sequence_id: int = Field(validation_alias="sequenceId")
    released: bool
    node_position: NodePosition | None = Field(default=None, validation_alias="nodePosition")
    actions: tuple[Action, ...] = ()


class ControlPoint(_In):
    """A NURBS control point (m) and its weight."""

    x: float
    y: float
    weight: float = 1.0


class Trajectory(_In):
    """An edge's NURBS trajectory (the degree defaults to 1 as in 3.0; knots uniform clamped when absent)."""

    degree: int = 1
    knot_vector: tuple[float, ...] | None = Field(default=None, validation_alias="knotVector")
    control_points: tuple[ControlPoint, ...] = Field(validation_alias="controlPoints")


class Edge(_In):
    """An order edge (2.x names its nodes; in 3.0 it joins the nodes either side of it in the order)."""

    edge_id: str = Field(validation_alias="edgeId")
    sequence_id: int = Field(validation_alias="sequenceId")
    released: bool
    start_node_id: str | None = Field(default=None, validation_alias="startNodeId")
    end_node_id: str | None = Field(default=None, validation_alias="endNodeId")
    max_speed: float | None = Field(default=None, validation_alias=AliasChoices("maxSpeed", "maximumSpeed"))
    trajectory: Trajectory | None = None
    actions: tuple[Action, ...] = ()


class Order(_In):
    """An order message."""

    header_id: int = Field(validation_alias="headerId")
    order_id: str = Field(validation_alias="orderId")
    order_update_id: int = Field(validation_alias="orderUpdateId")
    nodes: tuple[Node, ...]
    edges: tuple[Edge, ...]


class InstantActions(_In):
    """An instantActions message (``legacy_key``: the array came under 1.1's ``instantActions``)."""

    header_id: int = Field(validation_alias="headerId")
    actions: tuple[Action, ...] = Field(validation_alias=AliasChoices("actions", "instantActions"))
    legacy_key: bool = False


def parse_order(message: JsonObject) -> Order:
    """The order in ``message`` (a pydantic ValidationError, a ValueError, when it does not hold one)."""
    return Order.model_validate(message)


def parse_instant_actions(message: JsonObject) -> InstantActions:
    """The instant actions in ``message`` (``legacy_key`` set when they came under ``instantActions``)."""
    out = InstantActions.model_validate(message)
    if "actions" not in message and "instantActions" in message:
        out = out.model_copy(update={"legacy_key": True})
    return out


# --------------------------------------------------------------------------------------------- build


@dataclass(frozen=True)
class ActionSnap:
    """An action's state: id, type, status (WAITING .. FINISHED/FAILED), result text, instant or not."""

    action_id: str
    action_type: str
    status: str
    result: str | None = None
    instant: bool = False


@dataclass(frozen=True)
class ErrorSnap:
    """An error: type (the version's name), level, references ``(key, value)``, description."""

    error_type: str
    level: str
    references: tuple[tuple[str, str], ...] = ()
    description: str | None = None


@dataclass(frozen=True)
class Snapshot:
    """What the vehicle reports, independent of the version (SI units, radians, map frame)."""

    t_wall: datetime
    order_id: str
    order_update_id: int
    last_node_id: str
    last_node_sequence_id: int
    nodes: tuple[tuple[str, int, bool, float, float, float | None], ...]
    """(nodeId, sequenceId, released, x, y, theta or None) of every node still to be traversed."""
    edges: tuple[tuple[str, int, bool], ...]
    """(edgeId, sequenceId, released) of every edge still to be traversed."""
    driving: bool
    paused: bool
    new_base_request: bool
    distance_since_last_node: float
    pose: tuple[float, float, float]
    map_id: str
    localized: bool
    localization_score: float | None
    deviation_range: float | None
    velocity: tuple[float, float, float]
    actions: tuple[ActionSnap, ...]
    errors: tuple[ErrorSnap, ...]
    battery_charge: float = 100.0
    field_violation: bool = False
    loads: tuple[str, ...] = ()
    operating_mode: str = "AUTOMATIC"
    information: tuple[ErrorSnap, ...] = ()
    """information entries (level INFO or DEBUG): for people and logs, not for a master's logic."""
    extra: dict[str, object] = field(default_factory=dict)


def iso_timestamp(t: datetime) -> str:
    """``t`` as ISO 8601 UTC with milliseconds and ``Z`` (the header's timestamp)."""
    return t.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%S.") + f"{t.microsecond // 1000:03d}Z"


def wall_time(epoch: datetime, t: float) -> datetime:
    """The wall-clock instant ``t`` s of simulated time after ``epoch``."""
    return epoch + timedelta(seconds=t)


class _Out(BaseModel):
    """A part of a message the vehicle publishes: the field names are the schema's keys."""

    model_config = ConfigDict(extra="forbid")


class Header(_Out):
    """The protocol header (not an object on the wire: its fields open every message)."""

    headerId: int
    timestamp: str
    version: str
    manufacturer: str
    serialNumber: str


class NodeState(_Out):
    """A node still to be traversed."""

    nodeId: str
    sequenceId: int
    released: bool
    nodePosition: dict[str, float | str] | None = None


class EdgeState(_Out):
    """An edge still to be traversed."""

    edgeId: str
    sequenceId: int
    released: bool


class Velocity(_Out):
    """Body velocity (m/s, m/s, rad/s)."""

    vx: float
    vy: float
    omega: float


class ErrorReference(_Out):
    """One reference of an error."""

    referenceKey: str
    referenceValue: str


class Error(_Out):
    """An error of the state."""

    errorType: str
    errorReferences: list[ErrorReference] | None = None
    errorDescription: str | None = None
    errorLevel: str


class Info(_Out):
    """An information entry of the state (2.x ``infoDescription``, 3.0 ``infoDescriptor``)."""

    infoType: str
    infoReferences: list[ErrorReference] | None = None
    infoDescription: str | None = None
    infoDescriptor: str | None = None
    infoLevel: Literal["INFO", "DEBUG"]


class Load(_Out):
    """A load on the vehicle."""

    loadId: str


class AgvPosition(_Out):
    """2.x ``agvPosition``."""

    x: float
    y: float
    theta: float
    mapId: str
    positionInitialized: bool
    localizationScore: float | None = None
    deviationRange: float | None = None


class MobileRobotPosition(_Out):
    """3.0 ``mobileRobotPosition``."""

    x: float
    y: float
    theta: float
    mapId: str
    localized: bool
    localizationScore: float | None = None
    deviationRange: float | None = None


class ActionStateV2(_Out):
    """2.x action state."""

    actionId: str
    actionType: str | None = None
    actionStatus: Literal["WAITING", "INITIALIZING", "RUNNING", "FINISHED", "FAILED"]
    resultDescription: str | None = None


class ActionStateV3(_Out):
    """3.0 action state."""

    actionId: str
    actionType: str | None = None
    actionStatus: Literal["WAITING", "INITIALIZING", "RUNNING", "PAUSED", "RETRIABLE", "FINISHED", "FAILED"]
    actionResult: str | None = None


class BatteryState(_Out):
    """2.x ``batteryState`` (charge in %)."""

    batteryCharge: float
    charging: bool


class PowerSupply(_Out):
    """3.0 ``powerSupply`` (state of charge in %)."""

    stateOfCharge: float
    charging: bool


class SafetyStateV2(_Out):
    """2.x ``safetyState``."""

    eStop: Literal["AUTOACK", "MANUAL", "REMOTE", "NONE"]
    fieldViolation: bool


class SafetyStateV3(_Out):
    """3.0 ``safetyState``."""

    activeEmergencyStop: Literal["MANUAL", "REMOTE", "NONE"]
    fieldViolation: bool


class _StateCommon(Header):
    orderId: str
    orderUpdateId: int
    lastNodeId: str
    lastNodeSequenceId: int
    nodeStates: list[NodeState]
    edgeStates: list[EdgeState]
    driving: bool
    paused: bool
    newBaseRequest: bool
    distanceSinceLastNode: float
    velocity: Velocity
    loads: list[Load]
    errors: list[Error]
    information: list[Info]


class StateV2(_StateCommon):
    """The 2.0.0/2.1.0 ``state`` message."""

    operatingMode: Literal["AUTOMATIC", "SEMIAUTOMATIC", "MANUAL", "SERVICE", "TEACHIN"]
    agvPosition: AgvPosition
    actionStates: list[ActionStateV2]
    batteryState: BatteryState
    safetyState: SafetyStateV2


class StateV3(_StateCommon):
    """The 3.0.0 ``state`` message (instant actions reported apart from the order's)."""

    operatingMode: Literal["STARTUP", "AUTOMATIC", "SEMIAUTOMATIC", "INTERVENED", "MANUAL", "SERVICE", "TEACH_IN"]
    mobileRobotPosition: MobileRobotPosition
    actionStates: list[ActionStateV3]
    instantActionStates: list[ActionStateV3]
    powerSupply: PowerSupply
    safetyState: SafetyStateV3


class VisualizationV2(Header):
    """The 2.x ``visualization`` message."""

    agvPosition: AgvPosition
    velocity: Velocity


class VisualizationV3(Header):
    """The 3.0 ``visualization`` message (it names the state it follows)."""

    referenceStateHeaderId: int
    mobileRobotPosition: MobileRobotPosition
    velocity: Velocity


class Connection(Header):
    """The ``connection`` message."""

    connectionState: Literal["ONLINE", "OFFLINE", "CONNECTIONBROKEN", "CONNECTION_BROKEN"]


def _header(header_id: int, t: datetime, version: str, manufacturer: str, serial: str) -> dict[str, object]:
    return {"headerId": header_id, "timestamp": iso_timestamp(t), "version": version,
            "manufacturer": manufacturer, "serialNumber": serial}


def _finite(v: float | None) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


def _position(s: Snapshot, v3: bool) -> AgvPosition | MobileRobotPosition:
    x, y, th = (c if math.isfinite(c) else 0.0 for c in s.pose)
    th = wrap_angle_scalar(th)  # the schemas bound theta to [-pi, pi]
    kw: dict[str, object] = {"x": x, "y": y, "theta": th, "mapId": s.map_id,
                             "localizationScore": _finite(s.localization_score),
                             "deviationRange": _finite(s.deviation_range)}
    if v3:
        return MobileRobotPosition.model_validate(kw | {"localized": s.localized})
    return AgvPosition.model_validate(kw | {"positionInitialized": s.localized})


def _errors(s: Snapshot) -> list[Error]:
    return [Error(errorType=e.error_type, errorLevel=e.level, errorDescription=e.description,
                  errorReferences=[ErrorReference(referenceKey=k, referenceValue=v) for k, v in e.references] or None)
            for e in s.errors]


def _information(s: Snapshot, v3: bool) -> list[Info]:
    out = []
    for i in s.information:
        refs = [ErrorReference(referenceKey=k, referenceValue=v) for k, v in i.references] or None
        text = {"infoDescriptor" if v3 else "infoDescription": i.description}
        out.append(Info.model_validate({"infoType": i.error_type, "infoLevel": i.level, "infoReferences": refs} | text))
    return out


def _node_position(s: Snapshot, x: float, y: float, theta: float | None,
                   version: str) -> dict[str, float | str] | None:
    """A node state's position (2.0.0 requires its theta: left out for a node without one)."""
    if theta is None:
        return None if version == "2.0.0" else {"x": x, "y": y, "mapId": s.map_id}
    return {"x": x, "y": y, "theta": wrap_angle_scalar(theta), "mapId": s.map_id}  # schema: [-pi, pi]


def state_message(s: Snapshot, header_id: int, version: str, manufacturer: str, serial: str) -> JsonObject:
    """The ``state`` message of ``version`` for snapshot ``s`` (None fields left out)."""
    v3 = major(version) == "v3"
    common: dict[str, object] = _header(header_id, s.t_wall, version, manufacturer, serial) | {
        "orderId": s.order_id, "orderUpdateId": s.order_update_id, "lastNodeId": s.last_node_id,
        "lastNodeSequenceId": s.last_node_sequence_id,
        "nodeStates": [NodeState(nodeId=n, sequenceId=q, released=r, nodePosition=_node_position(s, x, y, th, version))
                       for n, q, r, x, y, th in s.nodes],
        "edgeStates": [EdgeState(edgeId=e, sequenceId=q, released=r) for e, q, r in s.edges],
        "driving": s.driving, "paused": s.paused, "newBaseRequest": s.new_base_request,
        "distanceSinceLastNode": s.distance_since_last_node,
        "velocity": Velocity(vx=s.velocity[0], vy=s.velocity[1], omega=s.velocity[2]),
        "loads": [Load(loadId=i) for i in s.loads], "errors": _errors(s), "operatingMode": s.operating_mode,
        "information": _information(s, v3),
    }
    if v3:
        def a3(a: ActionSnap) -> ActionStateV3:
            return ActionStateV3(actionId=a.action_id, actionType=a.action_type,
                                 actionStatus=a.status, actionResult=a.result)  # type: ignore[arg-type]
        msg: BaseModel = StateV3.model_validate(common | {
            "mobileRobotPosition": _position(s, True),
            "actionStates": [a3(a) for a in s.actions if not a.instant],
            "instantActionStates": [a3(a) for a in s.actions if a.instant],
            "powerSupply": PowerSupply(stateOfCharge=s.battery_charge, charging=False),
            "safetyState": SafetyStateV3(activeEmergencyStop="NONE", fieldViolation=s.field_violation),
        })
    else:
        msg = StateV2.model_validate(common | {
            "agvPosition": _position(s, False),
            "actionStates": [ActionStateV2(actionId=a.action_id, actionType=a.action_type, actionStatus=a.status,  # type: ignore[arg-type]
                                           resultDescription=a.result) for a in s.actions],
            "batteryState": BatteryState(batteryCharge=s.battery_charge, charging=False),
            "safetyState": SafetyStateV2(eStop="NONE", fieldViolation=s.field_violation),
        })
    return msg.model_dump(exclude_none=True)


def visualization_message(s: Snapshot, header_id: int, version: str, manufacturer: str, serial: str,
                          state_header_id: int) -> JsonObject:
    """The ``visualization`` message (3.0 names ``state_header_id``, the last state published)."""
    head = _header(header_id, s.t_wall, version, manufacturer, serial)
    vel = Velocity(vx=s.velocity[0], vy=s.velocity[1], omega=s.velocity[2])
    msg: BaseModel
    if major(version) == "v3":
        msg = VisualizationV3.model_validate(head | {"referenceStateHeaderId": state_header_id,
                                                     "mobileRobotPosition": _position(s, True), "velocity": vel})
    else:
        msg = VisualizationV2.model_validate(head | {"agvPosition": _position(s, False), "velocity": vel})
    return msg.model_dump(exclude_none=True)


def connection_message(state: str, header_id: int, t: datetime, version: str, manufacturer: str,
                       serial: str) -> JsonObject:
    """The ``connection`` message: ``state`` ONLINE, OFFLINE or BROKEN (the version's spelling of it)."""
    if state == "BROKEN":
        state = "CONNECTION_BROKEN" if major(version) == "v3" else "CONNECTIONBROKEN"
    msg = Connection.model_validate(_header(header_id, t, version, manufacturer, serial) | {"connectionState": state})
    return msg.model_dump(exclude_none=True)


@dataclass(frozen=True)
class FactsheetData:
    """What the factsheet says of the vehicle (SI units): series, kinematics, limits, body, actions."""

    series: str
    kinematic: str
    """DIFF, OMNI or THREEWHEEL (2.x names; 3.0 takes the same strings)."""
    speed_max: float
    accel_max: float
    decel_max: float
    length: float
    width: float
    height_max: float
    actions: tuple[tuple[str, tuple[str, ...]], ...]
    """(actionType, scopes) of every action the vehicle performs."""
    min_state_interval: float


def factsheet_message(f: FactsheetData, header_id: int, t: datetime, version: str, manufacturer: str,
                      serial: str) -> JsonObject:
    """The ``factsheet`` message of ``version``: localization REFLECTOR, navigation AUTONOMOUS, the limits."""
    head = _header(header_id, t, version, manufacturer, serial)
    if major(version) == "v3":
        return head | {
            "typeSpecification": {"seriesName": f.series, "mobileRobotKinematics": f.kinematic,
                                  "mobileRobotClass": "CARRIER", "maximumLoadMass": 0.0,
                                  "localizationTypes": ["REFLECTOR"], "navigationTypes": ["AUTONOMOUS"]},
            "physicalParameters": {"minimumSpeed": 0.0, "maximumSpeed": f.speed_max,
                                   "maximumAcceleration": f.accel_max, "maximumDeceleration": f.decel_max,
                                   "minimumHeight": 0.0, "maximumHeight": f.height_max, "width": f.width,
                                   "length": f.length},
            "protocolLimits": {"maximumStringLengths": {}, "maximumArrayLengths": {},
                               "timing": {"minimumOrderInterval": 0.1, "minimumStateInterval": f.min_state_interval}},
            "protocolFeatures": {"optionalParameters": [], "mobileRobotActions": [
                {"actionType": a, "actionScopes": list(sc), "pauseAllowed": False, "cancelAllowed": True}
                for a, sc in f.actions]},
            "mobileRobotGeometry": {}, "loadSpecification": {},
        }
    return head | {
        "typeSpecification": {"seriesName": f.series, "agvKinematic": f.kinematic, "agvClass": "CARRIER",
                              "maxLoadMass": 0.0, "localizationTypes": ["REFLECTOR"],
                              "navigationTypes": ["AUTONOMOUS"]},
        "physicalParameters": {"speedMin": 0.0, "speedMax": f.speed_max, "accelerationMax": f.accel_max,
                               "decelerationMax": f.decel_max, "heightMax": f.height_max, "width": f.width,
                               "length": f.length},
        "protocolLimits": {"maxStringLens": {}, "maxArrayLens": {},
                           "timing": {"minOrderInterval": 0.1, "minStateInterval": f.min_state_interval}},
        "protocolFeatures": {"optionalParameters": [], "agvActions": [
            {"actionType": a, "actionScopes": list(sc)} for a, sc in f.actions]},
        "agvGeometry": {}, "loadSpecification": {},
    }
