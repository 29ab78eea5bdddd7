"""The VDA 5050 vehicle's order/state machine on the hall route network (in process, simulated clock)."""

from __future__ import annotations

import dataclasses
import json

import pytest

from agvnav.vda5050.bus import InProcessBus
from agvnav.vda5050.master import MasterMessages
from agvnav.vda5050.schemas import JsonObject
from agvnav.vda5050.vehicle import VdaVehicle, VehicleConfig
from agvnav.world.scenario import builtin_scenario, load_scenario


def make(version: str) -> tuple[VdaVehicle, MasterMessages, InProcessBus, list[JsonObject]]:
    v = VdaVehicle(load_scenario(builtin_scenario("mission_hall_differential")),
                   VehicleConfig("M", "S", version, visualization_period_s=1.0, state_period_s=5.0))
    states: list[JsonObject] = []
    bus = InProcessBus({"S": v}, version, lambda _s, name, m: states.append(m) if name == "state" else None)
    m = MasterMessages(v.network, v.map_id, version, "M", "S")
    return v, m, bus, states


def run(bus: InProcessBus, v: VdaVehicle, seconds: float) -> None:
    end = v.t + seconds
    while v.t < end - 1e-9:
        bus.step()


def errors(v: VdaVehicle) -> list[str]:
    return [e["errorType"] for e in v.state()["errors"]]  # type: ignore[index, union-attr]


@pytest.mark.parametrize("version", ["2.1.0", "3.0.0"])
def test_bad_orders_are_rejected_and_the_vehicle_stays_idle(version: str) -> None:
    v, m, bus, _ = make(version)
    run(bus, v, 1.0)
    v3 = version == "3.0.0"
    v.receive("order", b"{not json")
    assert errors(v) == ["VALIDATION_FAILURE" if v3 else "validationError"]
    bad = m.order("o", 0, ["S1", "P"], 2)
    del bad["nodes"][0]["released"]  # type: ignore[index, union-attr]
    v.receive("order", json.dumps(bad))
    assert errors(v) == ["VALIDATION_FAILURE" if v3 else "validationError"]
    unknown = m.order("o", 0, ["S1", "P"], 2)
    unknown["nodes"][1]["nodeId"] = "NOPE"  # type: ignore[index]
    if not v3:
        unknown["edges"][0]["endNodeId"] = "NOPE"  # type: ignore[index]
    v.receive("order", json.dumps(unknown))
    assert errors(v) == ["NO_ROUTE_TO_TARGET" if v3 else "noRouteError"]
    st = v.state()
    refs = {r["referenceKey"]: r["referenceValue"] for r in st["errors"][0]["errorReferences"]}  # type: ignore[index]
    assert refs["nodeId"] == "NOPE" and refs["orderId"] == "o"
    assert refs["orderUpdateId"] == "0" and refs["topic"] == "order"  # a master attributes it by these
    no_edge = m.order("o", 0, ["S1", "Q"], 2)  # no edge S1 -> Q
    v.receive("order", json.dumps(no_edge))
    assert errors(v) == ["NO_ROUTE_TO_TARGET" if v3 else "noRouteError"]
    far = m.order("o", 0, ["P", "Q"], 2)  # the vehicle stands at S1
    v.receive("order", json.dumps(far))
    assert errors(v) == ["START_NODE_OUT_OF_RANGE" if v3 else "noRouteError"]
    act = m.order("o", 0, ["S1", "P"], 2, actions={1: [m.action("jump", "j1")]})
    v.receive("order", json.dumps(act))
    assert errors(v) == ["INVALID_ORDER_ACTION" if v3 else "orderError"]
    if not v3:
        joined = m.order("o", 0, ["S1", "P"], 2)
        joined["edges"][0]["endNodeId"] = "Q"  # type: ignore[index]
        v.receive("order", json.dumps(joined))
        assert errors(v) == ["validationError"]
    v.receive("instantActions", json.dumps(m.instant(m.action("cancelOrder", "c1"))))
    assert ("NO_ORDER_TO_CANCEL" if v3 else "noOrderToCancel") in errors(v)
    run(bus, v, 1.0)
    st = v.state()
    assert st["orderId"] == "" and not st["driving"] and st["nodeStates"] == []
    assert bus.checked.failures == [m for m in bus.checked.failures if m.startswith("order")]  # vehicle: clean


def test_order_update_pause_pick_and_cancel() -> None:
    v, m, bus, states = make("2.1.0")
    run(bus, v, 1.0)
    pick = m.action("pick", "pk", "HARD", duration=1.0)
    o = m.order("o1", 0, ["S1", "P", "Q"], 2, actions={1: [pick]})  # base S1-P, horizon Q
    bus.publish_master("S", "order", o)
    st = v.state()
    assert st["lastNodeId"] == "S1" and [n["nodeId"] for n in st["nodeStates"]] == ["P", "Q"]  # type: ignore[index]
    assert [n["released"] for n in st["nodeStates"]] == [True, False]  # type: ignore[index]
    run(bus, v, 2.0)
    assert v.state()["driving"]
    # an update that does not start at the decision point P is refused; the order goes on
    bus.publish_master("S", "order", m.order("o1", 1, ["S1", "P", "Q"], 3))
    assert errors(v) == ["orderUpdateError"] and v.state()["orderUpdateId"] == 0
    upd = m.order("o1", 1, ["P", "Q"], 2, first_seq=2)
    bus.publish_master("S", "order", upd)
    st = v.state()
    assert errors(v) == [] and st["orderUpdateId"] == 1
    assert [(n["nodeId"], n["released"]) for n in st["nodeStates"]] == [("P", True), ("Q", True)]  # type: ignore[index]
    bus.publish_master("S", "order", m.order("o1", 0, ["S1", "P"], 2))  # outdated
    assert errors(v) == ["orderUpdateError"]
    bus.publish_master("S", "instantActions", m.instant(m.action("startPause", "sp")))
    run(bus, v, 3.0)
    st = v.state()
    assert st["paused"] and not st["driving"] and abs(st["velocity"]["vx"]) < 0.05  # type: ignore[index]
    bus.publish_master("S", "instantActions", m.instant(m.action("stopPause", "rp")))
    for _ in range(800):
        bus.step()
        if v.state()["lastNodeId"] == "P":
            break
    bus.step()
    bus.step()
    st = v.state()
    assert st["lastNodeId"] == "P" and st["lastNodeSequenceId"] == 2
    pk = next(a for a in st["actionStates"] if a["actionId"] == "pk")  # type: ignore[union-attr]
    assert pk["actionStatus"] in ("RUNNING", "WAITING") and not st["driving"]  # HARD: no driving while it runs
    run(bus, v, 3.0)
    st = v.state()
    assert next(a for a in st["actionStates"] if a["actionId"] == "pk")["actionStatus"] == "FINISHED"  # type: ignore[union-attr]
    assert st["loads"] and st["driving"]
    bus.publish_master("S", "instantActions", m.instant(m.action("cancelOrder", "cx")))
    bus.step()
    st = v.state()  # stopping: the cancel runs, the order's states stay until it stands (a master sees why it ends)
    cx = next(a for a in st["actionStates"] if a["actionId"] == "cx")  # type: ignore[union-attr]
    assert cx["actionStatus"] == "RUNNING" and st["nodeStates"] != []
    run(bus, v, 3.0)
    st = v.state()
    cx = next(a for a in st["actionStates"] if a["actionId"] == "cx")  # type: ignore[union-attr]
    assert cx["actionStatus"] == "FINISHED" and not st["driving"] and st["nodeStates"] == []
    assert st["orderId"] == "o1" and st["orderUpdateId"] == 1  # kept after a cancel
    assert bus.checked.failures == []
    assert sum(1 for s in states if s["headerId"] >= 0) == len(states)
    assert [s["headerId"] for s in states] == sorted(s["headerId"] for s in states)


def test_not_localized_refuses_to_drive(monkeypatch: pytest.MonkeyPatch) -> None:
    v, m, bus, _ = make("3.0.0")
    run(bus, v, 1.0)
    st = v.state()
    assert st["mobileRobotPosition"]["localized"] and "LOCALIZATION_ERROR" not in errors(v)  # type: ignore[index]
    assert 0.0 < st["mobileRobotPosition"]["deviationRange"] < 0.2  # type: ignore[index]
    bus.publish_master("S", "order", m.order("o1", 0, ["S1", "P"], 2))
    run(bus, v, 1.0)
    assert v.state()["driving"]
    monkeypatch.setattr(type(v.estimator), "status", property(lambda self: "lost"))  # the integrity monitor's verdict
    run(bus, v, 2.0)
    st = v.state()
    assert not st["mobileRobotPosition"]["localized"] and not st["driving"]  # type: ignore[index]
    assert "deviationRange" not in st["mobileRobotPosition"]  # type: ignore[operator]
    err = next(e for e in st["errors"] if e["errorType"] == "LOCALIZATION_ERROR")  # type: ignore[union-attr]
    assert err["errorLevel"] == "FATAL"
    monkeypatch.undo()
    run(bus, v, 3.0)  # the positioning guard resumes after its delay
    assert v.state()["driving"] and "LOCALIZATION_ERROR" not in errors(v)
    assert bus.checked.failures == []


@pytest.mark.parametrize("version", ["2.0.0", "3.0.0"])
def test_link_lost_stands_still_then_reports_and_resumes(version: str) -> None:
    v, m, bus, states = make(version)
    run(bus, v, 0.5)
    v.receive("order", json.dumps(m.order("o1", 0, ["S1", "P"], 2)))
    run(bus, v, 4.0)
    assert v.pilot.v > 0.0
    v.link_lost()
    bus.step()
    assert v.pilot.hold and v.pilot.v == 0.0  # an immediate zero command, as a pause
    run(bus, v, 3.0)
    assert v._speed() < 0.01
    v.link_restored()
    run(bus, v, 0.1)
    info = states[-1]["information"]
    assert [i["infoType"] for i in info] == ["brokerConnectionLost"]  # type: ignore[union-attr, index]
    text = info[0]["infoDescriptor" if version == "3.0.0" else "infoDescription"]  # type: ignore[index]
    assert "lost for 3.1 s" in text  # 3 s and the step of the loss
    run(bus, v, 2.0)
    assert v.pilot.v > 0.0 and bus.checked.failures == []


def test_fine_positioning_is_judged_on_the_estimate_and_its_bound() -> None:
    v, m, bus, _ = make("2.1.0")
    v.cfg = dataclasses.replace(v.cfg, fine_tolerance_m=0.5)
    run(bus, v, 1.0)
    fine = m.action("finePositioning", "fp", "HARD", duration=0.5)
    bus.publish_master("S", "order", m.order("o1", 0, ["S1", "P"], 2, actions={1: [fine]}))
    for _ in range(2000):
        bus.step()
        fp = next(a for a in v.state()["actionStates"] if a["actionId"] == "fp")  # type: ignore[union-attr]
        if fp["actionStatus"] in ("FINISHED", "FAILED"):
            break
    assert fp["actionStatus"] == "FINISHED" and fp.get("resultDescription") is None
    run_ = next(r for r in v.actions if r.action.action_id == "fp")
    v.cfg = dataclasses.replace(v.cfg, fine_tolerance_m=1e-4)  # the same stop, a tolerance below its bound
    reason = v._fine_positioning_failure(run_)
    assert reason is not None and "deviationRange" in reason and "0.1 mm tolerance" in reason
