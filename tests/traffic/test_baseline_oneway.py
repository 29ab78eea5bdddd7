"""The openTCS-like baseline on the one-way warehouse layout, and the planner's goal bookkeeping (issue 30).

Ground truth is the kinematic executor's brute-force checks (true footprints intersected every 0.2 s,
resources taken against those held) with the conservative bounding-disc relation of ``texec_support``.
"""

from __future__ import annotations

import networkx as nx
import numpy as np
from texec_support import DiscZones

from agvnav.routes.layouts import warehouse_grid
from agvnav.routes.network import load_network, network_from_dict
from agvnav.routes.planning import VehicleLimits
from agvnav.traffic.adg import build_adg
from agvnav.traffic.baseline import BaselineAllocator, baseline_routes, spur_blocks
from agvnav.traffic.execute import AdgController, Delays, execute, routes_from_plan
from agvnav.traffic.plan import Goal, VehicleTask, plan_fleet
from agvnav.vehicles import box_footprint

FOOT = box_footprint(0.45, 0.45, 0.3)
LIM = VehicleLimits("differential", 1.0)


def test_the_shipped_one_way_layout_is_its_generator_s_and_strongly_connected() -> None:
    net = load_network("warehouse_oneway")
    gen = network_from_dict(warehouse_grid(one_way=True))
    assert set(net.edges) == set(gen.edges) and set(net.nodes) == set(gen.nodes)
    assert nx.is_strongly_connected(net.graph)
    lanes = [e.id for e in net.edges.values() if e.source.startswith("J") and e.target.startswith("J")]
    assert lanes and not any(e.endswith("~r") for e in lanes)


def test_a_vehicle_waiting_to_enter_a_spur_leaves_the_way_out_free() -> None:
    """One vehicle dwells in station spur S2_0 and leaves it while another comes to it: no deadlock."""
    net = load_network("warehouse_oneway")
    zones = DiscZones(net, {"differential": 0.55})
    assert ("edge", "J2_0-S") in spur_blocks(net)
    tasks = [VehicleTask("V0", LIM, "S2_0", (Goal("P4_0", 0.0, action="goto"),)),
             VehicleTask("V1", LIM, "P1_0", (Goal("S2_0", 3.0, action="drop"), Goal("P1_0")))]
    feet = {"V0": FOOT, "V1": FOOT}
    routes, unserved = baseline_routes(net, tasks, feet)
    assert unserved == {}
    r = execute(net, routes, BaselineAllocator(net, routes, zones), zones, Delays({}, {"V0": ((0.0, 20.0),)}), 2000.0)
    assert r.deadlock is None and r.collisions == [] and r.violations == []
    assert all(r.finished.values()) and r.n_deliveries == 1


def test_a_drop_then_a_pick_at_one_station_are_both_kept() -> None:
    """Two goals reached at one node: both arrivals set, the dwells add up, the delivery counted."""
    net = load_network("warehouse_oneway")
    zones = DiscZones(net, {"differential": 0.55})
    goals = (Goal("S1_1", 3.0, action="pick", job="A"), Goal("S3_1", 4.0, action="drop", job="A"),
             Goal("S3_1", 5.0, action="pick", job="B"), Goal("S5_1", 3.0, action="drop", job="B"), Goal("P0_0"))
    plan = plan_fleet(net, [VehicleTask("V0", LIM, "P0_0", goals)], zones)
    p = plan.plans["V0"]
    assert plan.unserved == {} and p.arrivals[1] == p.arrivals[2] and np.all(np.isfinite(p.arrivals))
    at = next(k for k, s in enumerate(p.steps) if s.arrives == 1)
    assert p.steps[at].reached == 2 and p.steps[at + 1].dwell_s == 9.0
    assert p.steps[at + 1].t_start >= p.arrivals[1] + 9.0 - 1e-9
    routes = routes_from_plan(plan, net, {"V0": LIM}, {"V0": FOOT})
    r = execute(net, routes, AdgController(build_adg(plan, zones)), zones, Delays({}, {}), 2000.0)
    assert r.n_deliveries == 2 and all(r.finished.values())


def test_twenty_vehicles_plan_validly_on_the_two_way_grid() -> None:
    """The integer SIPP's plans hold no conflicting resources at overlapping times (the ADG checks every pair),
    every vehicle reaches its goals in order and parks at the last."""
    net = load_network("warehouse_grid")
    zones = DiscZones(net, {"differential": 0.55})
    rng = np.random.default_rng(3)
    parks = [n for n in net.nodes if n.startswith("P")]
    stations = [n for n in net.nodes if n.startswith("S")]
    homes = rng.choice(len(parks), 20, replace=False)
    tasks = [VehicleTask(f"V{i}", LIM, parks[h], (Goal(stations[int(rng.integers(len(stations)))], 3.0),
                                                    Goal(parks[h])))
             for i, h in enumerate(homes)]
    plan = plan_fleet(net, tasks, zones)
    assert plan.unserved == {}
    adg = build_adg(plan, zones)
    assert adg.is_acyclic()
    for t in tasks:
        p = plan.plans[t.vehicle]
        assert p.end_node == t.start
        pairs = zip(p.steps, p.steps[1:], strict=False)
        assert all(a.target == b.source and a.t_end <= b.t_start + 1e-9 for a, b in pairs)
