"""finePositioning at a docking node runs the station-relative docking (issues 31 and 32), judged on the truth.

``docking_charger_vda``: the differential AGV on the docking bay's route network, the charger CH standing
20 mm / 0.5 deg off its map position. In process, simulated clock.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from agvnav.sim.docking import docking_node, load_target
from agvnav.sim.mission import load_mission_network
from agvnav.vda5050.bus import InProcessBus
from agvnav.vda5050.master import MasterMessages
from agvnav.vda5050.schemas import JsonObject
from agvnav.vda5050.vehicle import VdaVehicle, VehicleConfig
from agvnav.world.scenario import Scenario, ScenarioError, builtin_scenario, load_scenario


def scenario(start: str = "CH_wait", missing: tuple[str, ...] = ()) -> Scenario:
    sc = load_scenario(builtin_scenario("docking_charger_vda"))
    assert sc.mission is not None and sc.docking is not None
    truth = sc.docking.truth.model_copy(update={"missing": list(missing)})
    jobs = [sc.mission.jobs[0].model_copy(update={"station": "CH_wait" if start != "CH_wait" else "CH_approach"})]
    return sc.model_copy(update={"mission": sc.mission.model_copy(update={"start": start, "jobs": jobs}),
                                 "docking": sc.docking.model_copy(update={"truth": truth})})


def make(sc: Scenario) -> tuple[VdaVehicle, MasterMessages, InProcessBus, list[JsonObject]]:
    v = VdaVehicle(sc, VehicleConfig("M", "S", "2.1.0", state_period_s=5.0, visualization_period_s=0.0))
    states: list[JsonObject] = []
    bus = InProcessBus({"S": v}, "2.1.0", lambda _s, name, m: states.append(m) if name == "state" else None)
    return v, MasterMessages(v.network, v.map_id, "2.1.0", "M", "S"), bus, states


def fine_state(st: JsonObject) -> dict[str, object]:
    return next(a for a in st["actionStates"] if a["actionId"] == "fp")  # type: ignore[union-attr, index]


def run_until_done(v: VdaVehicle, bus: InProcessBus, limit_s: float) -> dict[str, object]:
    while v.t < limit_s:
        bus.step()
        fp = fine_state(v.state())
        if fp["actionStatus"] in ("FINISHED", "FAILED"):
            return fp
    raise AssertionError(f"finePositioning not done after {limit_s} s")


@pytest.mark.parametrize(("name", "station"), [
    ("docking_charger_vda", "CH"),
    pytest.param("docking_pallet_stacker_vda", "PAL", marks=pytest.mark.slow),  # the stacker backs in: point O
])
def test_fine_positioning_at_a_docking_node_docks_relative_to_the_true_station(name: str, station: str) -> None:
    v, m, bus, states = make(load_scenario(builtin_scenario(name)))
    fp = m.action("finePositioning", "fp", "HARD")
    nodes = [f"{station}_wait", f"{station}_approach", station]
    bus.publish_master("S", "order", m.order("o", 0, nodes, 3, actions={2: [fp]}))
    while v.pilot.dock is None or v.pilot.dock.phase != "approach" or v.t < 20.0:
        bus.step()
    bus.publish_master("S", "instantActions", m.instant(m.action("startPause", "sp")))  # a pause mid-approach
    for _ in range(40):
        bus.step()
    assert not v.state()["driving"] and math.hypot(*v.velocity[:2]) < 0.01
    bus.publish_master("S", "instantActions", m.instant(m.action("stopPause", "rp")))
    done = run_until_done(v, bus, 90.0)
    st = v.state()
    assert done["actionStatus"] == "FINISHED", done
    assert f"docked at {station!r}" in str(done["resultDescription"])
    assert st["lastNodeId"] == station and st["nodeStates"] == [] and st["errors"] == []
    err, err_h = v.docking_true_error() or (math.inf, math.inf)
    assert err <= 3e-3 and err_h <= math.radians(0.1)  # the docking tolerance, on the true station
    # the state's position stays the global estimate: near the true pose, ~20 mm off the map's station node
    pos = st["agvPosition"]
    assert (pos["x"], pos["y"]) == pytest.approx(tuple(float(c) for c in v.estimator.pose[:2]), abs=1e-9)  # type: ignore[index]
    node = v.network.nodes[station]
    assert 0.012 < math.hypot(pos["x"] - node.x, pos["y"] - node.y) < 0.03  # type: ignore[index, operator]
    # it ran while the vehicle docked: RUNNING (and driving) after the approach node, never FINISHED before
    running = [s for s in states if fine_state(s)["actionStatus"] == "RUNNING"]
    assert running and any(s["driving"] for s in running)
    assert all(s["lastNodeId"] == f"{station}_approach" for s in running)
    assert bus.checked.failures == []


def test_a_missing_target_reflector_fails_fine_positioning_with_the_reason() -> None:
    v, m, bus, states = make(scenario("CH_approach", missing=("CH_a",)))
    fp = m.action("finePositioning", "fp", "HARD")
    bus.publish_master("S", "order", m.order("o", 0, ["CH_approach", "CH"], 2, actions={1: [fp]}))
    done = run_until_done(v, bus, 20.0)
    assert done["actionStatus"] == "FAILED"
    assert "'CH_a' not seen" in str(done["resultDescription"])
    assert all(fine_state(s)["actionStatus"] != "FINISHED" for s in states)
    for _ in range(20):
        bus.step()
    st = v.state()
    assert st["lastNodeId"] == "CH_approach" and not st["driving"]  # holds: the station node was not reached
    errs = st["errors"]
    assert any("'CH_a' not seen" in str(e["errorDescription"]) for e in errs)  # type: ignore[union-attr]
    bus.publish_master("S", "instantActions", m.instant(m.action("cancelOrder", "cx")))
    for _ in range(20):
        bus.step()
    st = v.state()
    assert st["nodeStates"] == [] and fine_state(st)["actionStatus"] == "FAILED"
    assert bus.checked.failures == []


def test_fine_positioning_at_the_docking_node_needs_the_approach_edge() -> None:
    v, m, bus, _ = make(scenario("CH_approach"))
    fp = m.action("finePositioning", "fp", "HARD")
    bus.publish_master("S", "order", m.order("o", 0, ["CH"], 1, actions={0: [fp]}))
    st = v.state()
    assert [e["errorType"] for e in st["errors"]] == ["orderError"]  # type: ignore[union-attr]
    assert "approach edge 'CH_in'" in str(st["errors"][0]["errorDescription"])  # type: ignore[index]
    assert st["orderId"] == ""
    # a finePositioning at a node without a docking target keeps the global judgement
    bus.publish_master("S", "order", m.order("o", 0, ["CH_approach"], 1, actions={0: [fp]}))
    assert fine_state(v.state())["actionStatus"] in ("WAITING", "RUNNING")
    assert v.pilot.dock is None


def test_a_docking_node_off_the_docking_pose_is_refused_with_file_and_line(tmp_path: Path) -> None:
    sc = scenario()
    net = load_mission_network(sc)
    text = Path(net.spec.source).read_text(encoding="utf-8").replace(
        "{id: CH, x: 12.0, y: 9.1,", "{id: CH, x: 12.0, y: 9.13,")
    bad = tmp_path / "bay.yaml"
    bad.write_text(text, encoding="utf-8")
    assert sc.mission is not None
    moved = sc.model_copy(update={"mission": sc.mission.model_copy(update={"network": str(bad)})})
    with pytest.raises(ScenarioError) as exc:
        docking_node(moved, load_mission_network(moved), load_target(moved))
    line = next(i for i, t in enumerate(text.splitlines(), 1) if "{id: CH, x:" in t)
    assert "bay.yaml" in str(exc.value) and f":{line}" in str(exc.value) and "30.0 mm" in str(exc.value)


def test_a_cancel_mid_docking_fails_fine_positioning_and_stops() -> None:
    v, m, bus, _ = make(scenario("CH_approach"))
    fp = m.action("finePositioning", "fp", "HARD")
    bus.publish_master("S", "order", m.order("o", 0, ["CH_approach", "CH"], 2, actions={1: [fp]}))
    while v.pilot.dock is None or v.pilot.dock.phase != "approach" or v.t < 3.0:
        bus.step()
    assert v.state()["driving"]
    bus.publish_master("S", "instantActions", m.instant(m.action("cancelOrder", "cx")))
    for _ in range(60):
        bus.step()
    st = v.state()
    assert fine_state(st)["actionStatus"] == "FAILED" and fine_state(st)["resultDescription"] == "cancelled"
    assert st["nodeStates"] == [] and st["edgeStates"] == [] and not st["driving"]
    assert st["lastNodeId"] == "CH_approach" and v.pilot.dock is None
    assert bus.checked.failures == []
