"""The schema checks and the message models against the official VDA 5050 schemas, every version."""

from __future__ import annotations

import math
from datetime import UTC, datetime

import pytest

from agvnav.vda5050.messages import (
    ActionSnap,
    ErrorSnap,
    FactsheetData,
    Snapshot,
    connection_message,
    factsheet_message,
    parse_instant_actions,
    parse_order,
    state_message,
    visualization_message,
)
from agvnav.vda5050.schemas import VERSIONS, problems, schema, unknown_keys

T = datetime(2026, 1, 2, 3, 4, 5, 678000, tzinfo=UTC)


def snap(localized: bool = True) -> Snapshot:
    # a node heading 270 deg and a pose heading 3.5 rad: the schemas bound theta to [-pi, pi]
    return Snapshot(T, "o1", 2, "A", 4, (("B", 6, True, 1.0, 2.0, 0.5), ("C", 8, False, 3.0, 2.0, None),
                                         ("D", 10, False, 3.0, 4.0, 1.5 * math.pi)),
                    (("e7", 7, True),), True, False, False, 0.3, (1.0, 2.0, 3.5), "hall", localized, 0.9, 0.02,
                    (0.5, 0.0, 0.1), (ActionSnap("a1", "pick", "RUNNING"), ActionSnap("i1", "startPause", "FINISHED",
                                                                                      instant=True)),
                    (ErrorSnap("orderError", "WARNING", (("orderId", "x"),), "bad"),), loads=("l1",),
                    information=(ErrorSnap("brokerConnectionLost", "INFO", (("lostAt", "t"),), "lost 3 s"),))


@pytest.mark.parametrize("version", VERSIONS)
def test_built_messages_conform(version: str) -> None:
    s = snap()
    f = FactsheetData("s", "DIFF", 1.0, 0.3, 0.3, 0.9, 0.6, 2.0, (("pick", ("NODE",)), ("startPause", ("INSTANT",))),
                      0.05)
    msgs = {
        "state": state_message(s, 3, version, "M", "S"),
        "visualization": visualization_message(s, 4, version, "M", "S", 3),
        "connection": connection_message("BROKEN", 0, T, version, "M", "S"),
        "factsheet": factsheet_message(f, 0, T, version, "M", "S"),
    }
    for topic, m in msgs.items():
        assert problems(m, version, topic) == [], topic
    assert msgs["state"]["timestamp"] == "2026-01-02T03:04:05.678Z"
    broken = msgs["connection"]["connectionState"]
    assert broken == ("CONNECTION_BROKEN" if version == "3.0.0" else "CONNECTIONBROKEN")


def test_v3_state_with_v2_names_fails_only_the_unknown_key_check() -> None:
    m = state_message(snap(), 1, "3.0.0", "M", "S")
    m["agvPosition"] = {"x": 0.0, "y": 0.0, "theta": 0.0, "mapId": "hall", "positionInitialized": True}
    m["batteryStat"] = {"batteryCharge": 1.0}
    assert problems(m, "3.0.0", "state", strict=False) == []  # the schema alone lets it pass
    assert unknown_keys(m, "3.0.0", "state") == ["agvPosition", "batteryStat"]
    m2 = state_message(snap(), 1, "3.0.0", "M", "S")
    m2["actionStates"][0]["resultDescription"] = "2.x name"  # nested, inside an array
    assert unknown_keys(m2, "3.0.0", "state") == ["actionStates[0].resultDescription"]


def test_v2_state_is_not_a_v3_state() -> None:
    m = state_message(snap(), 1, "2.1.0", "M", "S")
    bad = problems(m, "3.0.0", "state")
    assert any("powerSupply" in b for b in bad) and any("agvPosition" in b for b in bad)


def test_free_values_and_errata() -> None:
    order = {"headerId": 0, "timestamp": "2026-01-01T00:00:00.00Z", "version": "2.0.0", "manufacturer": "M",
             "serialNumber": "S", "orderId": "o", "orderUpdateId": 0,
             "nodes": [{"nodeId": "A", "sequenceId": 0, "released": True, "actions": [
                 {"actionType": "pick", "actionId": "a", "blockingType": "HARD",
                  "actionParameters": [{"key": "k", "value": [{"any": 1}, 2]}]}],
                 "nodePosition": {"x": 1, "y": 2, "theta": 0, "mapId": "m", "allowedDeviationXy": 0.3}}],
             "edges": []}
    assert problems(order, "2.0.0", "order") == []  # an action parameter's value is free
    assert parse_order(order).nodes[0].node_position.allowed_deviation_xy == 0.3  # type: ignore[union-attr]
    ia = {k: order[k] for k in ("headerId", "timestamp", "version", "manufacturer", "serialNumber")}
    ia["actions"] = [{"actionType": "startPause", "actionId": "p", "blockingType": "HARD"}]
    assert problems(ia, "2.0.0", "instantActions") == []  # the 2.0.0 schema's actionName read as actionType
    legacy = parse_instant_actions({"headerId": 1, "instantActions": ia["actions"]})
    assert legacy.legacy_key and legacy.actions[0].action_type == "startPause"
    assert "typeSpecification" in schema("2.0.0", "factsheet")["properties"]  # type: ignore[operator]


def test_v3_ellipse_deviation_reads_its_larger_axis() -> None:
    o = parse_order({"headerId": 0, "orderId": "o", "orderUpdateId": 0, "edges": [], "nodes": [
        {"nodeId": "A", "sequenceId": 0, "released": True, "actions": [],
         "nodePosition": {"x": 0, "y": 0, "mapId": "m", "allowedDeviationXY": {"a": 0.2, "b": 0.4, "theta": 0}}}]})
    assert o.nodes[0].node_position.allowed_deviation_xy == 0.4  # type: ignore[union-attr]
