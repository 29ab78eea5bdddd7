"""An order update that extends the base while the vehicle drives: it drives on, no stop at the old base end
(issue 31). Hall route network, in process, simulated clock."""

from __future__ import annotations

import math

from agvnav.vda5050.bus import InProcessBus
from agvnav.vda5050.master import MasterMessages
from agvnav.vda5050.vehicle import VdaVehicle, VehicleConfig
from agvnav.world.scenario import builtin_scenario, load_scenario


def drive(extend_at_s: float | None) -> tuple[float, list[str], VdaVehicle]:
    """From P: order P -> Q (base) -> SE (horizon); the update releasing Q -> SE at ``extend_at_s`` (None: once
    stopped at Q). Returns the smallest speed (m/s) within 0.5 m of Q, and the last nodes in turn."""
    sc = load_scenario(builtin_scenario("mission_hall_differential"))
    assert sc.mission is not None
    sc = sc.model_copy(update={"mission": sc.mission.model_copy(update={"start": "P"})})
    v = VdaVehicle(sc, VehicleConfig("M", "S", "2.1.0", state_period_s=5.0, visualization_period_s=0.0))
    bus = InProcessBus({"S": v}, "2.1.0")
    m = MasterMessages(v.network, v.map_id, "2.1.0", "M", "S")
    bus.publish_master("S", "order", m.order("o1", 0, ["P", "Q", "SE"], 2))
    update = m.order("o1", 1, ["Q", "SE"], 2, first_seq=2)
    p = v.network.nodes["Q"]
    slowest, seen, sent = math.inf, ["P"], False
    while v.t < 30.0 and not (seen[-1] == "SE" and not v.state()["driving"]):
        bus.step()
        if not sent and (v.t >= extend_at_s if extend_at_s is not None else
                         seen[-1] == "Q" and not v.state()["driving"]):
            bus.publish_master("S", "order", update)
            sent = True
        truth = v.truth_plant.pose
        if math.hypot(truth[0] - p.x, truth[1] - p.y) < 0.5:
            slowest = min(slowest, math.hypot(*v.velocity[:2]))
        if v.last_node != seen[-1]:
            seen.append(v.last_node)
    assert bus.checked.failures == []
    return slowest, seen, v


def test_a_base_extended_mid_leg_is_driven_on_without_a_stop() -> None:
    slowest, seen, v = drive(extend_at_s=3.0)  # on the edge P -> Q (3 m at 0.5 m/s)
    assert seen == ["P", "Q", "SE"]
    assert slowest > 0.35  # through Q at cruise (0.5 m/s; the state's speed jitters by 0.07): no stop at Q
    st = v.state()
    assert st["nodeStates"] == [] and not st["driving"] and st["errors"] == []
    node = v.network.nodes["SE"]
    assert math.hypot(v.estimator.pose[0] - node.x, v.estimator.pose[1] - node.y) < 0.05


def test_without_the_update_in_time_the_vehicle_stops_at_the_base_end() -> None:
    slowest, seen, _ = drive(extend_at_s=None)  # the same update once it stands at Q
    assert seen == ["P", "Q", "SE"] and slowest < 0.01
