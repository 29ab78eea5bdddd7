"""A VDA 5050 vehicle turns on the spot where its order's route turns at a node, and a vehicle whose run ended
(a collision) keeps its clock and its state instead of crashing (issue 31). Hall network, in process."""

from __future__ import annotations

import math

import pytest

from agvnav.geometry import wrap_angle_scalar
from agvnav.vda5050.bus import InProcessBus
from agvnav.vda5050.master import MasterMessages
from agvnav.vda5050.vehicle import VdaVehicle, VehicleConfig
from agvnav.world.scenario import builtin_scenario, load_scenario


def vehicle_at(start: str) -> tuple[VdaVehicle, InProcessBus, MasterMessages]:
    sc = load_scenario(builtin_scenario("mission_hall_differential"))
    assert sc.mission is not None
    sc = sc.model_copy(update={"mission": sc.mission.model_copy(update={"start": start})})
    v = VdaVehicle(sc, VehicleConfig("M", "S", "2.1.0", state_period_s=5.0, visualization_period_s=0.0))
    return v, InProcessBus({"S": v}, "2.1.0"), MasterMessages(v.network, v.map_id, "2.1.0", "M", "S")


def test_a_route_turning_at_a_node_is_driven_with_a_turn_on_the_spot() -> None:
    # S1 -> P heading east; the arc P -> D1 driven forward leaves P heading west: a half turn at P, which a
    # differential AGV makes on the spot (before, it swung round on the move into the wall: a collision).
    v, bus, m = vehicle_at("S1")
    bus.publish_master("S", "order", m.order("o1", 0, ["S1", "P", "D1"], 3))
    p, d = v.network.nodes["P"], v.network.nodes["D1"]
    closest, seen, turning_reported, heading = math.inf, ["S1"], [], 0.0
    while v.t < 90.0 and not (seen[-1] == "D1" and not v.state()["driving"]):
        bus.step()
        x, y, h = v.truth_plant.pose[:3]
        closest = min(closest, math.hypot(x - p.x, y - p.y))
        if math.hypot(x - p.x, y - p.y) < 0.02 and abs(wrap_angle_scalar(h - heading)) > 0.1 * v.dt:
            turning_reported.append(v.state()["driving"])  # turning at more than 0.1 rad/s
        heading = h
        if v.last_node != seen[-1]:
            seen.append(v.last_node)
    assert bus.checked.failures == []
    assert v.failure is None and seen == ["S1", "P", "D1"]
    assert closest < 0.02  # it stood at P to turn
    assert turning_reported and all(turning_reported)  # rotating counts as driving (VDA 5050)
    x, y, _ = v.truth_plant.pose[:3]
    assert math.hypot(x - d.x, y - d.y) < 0.05 and v.state()["errors"] == []


def test_a_vehicle_whose_run_ended_keeps_its_clock_and_reports(monkeypatch: pytest.MonkeyPatch) -> None:
    v, bus, m = vehicle_at("S1")
    bus.publish_master("S", "order", m.order("o1", 0, ["S1", "P"], 2))
    while v.t < 2.0:
        bus.step()
    monkeypatch.setattr(v.truth_plant, "failure", lambda: "collision")
    t_end = v.t
    for _ in range(40):
        bus.step()
    assert v.failure is not None and "collision" in v.failure
    assert v.t == pytest.approx(t_end + 40 * v.dt)
    state = v.state()
    assert not state["driving"] and state["errors"]
    assert "collision" in str(state["errors"])
    assert bus.checked.failures == []
