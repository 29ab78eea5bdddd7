"""Planning on (node, heading, direction) states: known answers on small graphs."""

from __future__ import annotations

import math

import pytest

from agvnav.routes.layouts import grid_network
from agvnav.routes.network import load_network, network_from_dict, parse_network
from agvnav.routes.planning import NoRouteError, Planner, VehicleLimits

# A at the origin facing east; B 10 m east. A one-way ring A -> B -> (arc up) -> T -> (arc) -> A
# lets a tricycle come back; a two-way spur B <-> S goes north from B (a 90 deg corner at B).
RING = """\
nodes:
  - {id: A, x: 0, y: 0, heading_deg: 0, kind: station}
  - {id: B, x: 10, y: 0, heading_deg: 0}
  - {id: T, x: 10, y: 4, heading_deg: 180}
  - {id: U, x: 0, y: 4, heading_deg: 180}
  - {id: S, x: 10, y: -5, kind: station}
edges:
  - {id: ab, from: A, to: B}
  - {id: bt, from: B, to: T, geometry: {type: arc, radius_m: 2, sweep_deg: 180}}
  - {id: tu, from: T, to: U}
  - {id: ua, from: U, to: A, geometry: {type: arc, radius_m: 2, sweep_deg: 180}}
  - {id: bs, from: B, to: S, two_way: true}
  - {id: ab2, from: A, to: B, speed_m_s: 0.5, models: [differential]}
"""


def test_tricycle_cannot_turn_at_a_corner_but_a_differential_can() -> None:
    net = parse_network(RING)
    with pytest.raises(NoRouteError, match="no route to station 'S' from 'A' for a tricycle"):
        Planner(net, VehicleLimits("tricycle")).plan("A", "S")
    route = Planner(net, VehicleLimits("differential", turn_rate=0.5)).plan("A", "S")
    assert [t.edge.id for t in route.traversals] == ["ab", "bs"]
    # 10 m + 5 m at 1 m/s, plus a quarter turn on the spot at 0.5 rad/s
    assert route.time_s == pytest.approx(15.0 + (math.pi / 2) / 0.5, abs=1e-6)


def test_heading_state_sends_the_tricycle_round_the_ring() -> None:
    net = parse_network(RING)
    planner = Planner(net, VehicleLimits("tricycle", max_speed=1.0, lateral_accel=10.0))
    route = planner.plan("B", "A", start_heading=0.0)  # facing east at B: only the ring leads back
    assert route.nodes == ("B", "T", "U", "A")
    assert route.time_s == pytest.approx(2 * 2 * math.pi + 10.0, rel=1e-3)


def test_curvature_caps_the_speed() -> None:
    net = parse_network(RING)
    slow = Planner(net, VehicleLimits("tricycle", max_speed=1.0, lateral_accel=0.125)).plan("B", "A", 0.0)
    # v = sqrt(0.125 * 2) = 0.5 m/s on both arcs
    assert slow.time_s == pytest.approx(2 * 2 * math.pi / 0.5 + 10.0, rel=1e-3)


def test_blocked_edge_replans_and_no_route_names_the_station() -> None:
    net = parse_network(RING)
    planner = Planner(net, VehicleLimits("differential"))
    assert [t.edge.id for t in planner.plan("A", "B").traversals] == ["ab"]
    planner.block(["ab"])
    assert [t.edge.id for t in planner.plan("A", "B").traversals] == ["ab2"]  # the slow lane
    planner.block(["ab", "ab2"])
    with pytest.raises(NoRouteError, match="station 'B'"):
        planner.plan("A", "B")
    with pytest.raises(ValueError, match="blocked edge 'zz'"):
        planner.block(["zz"])


def test_reverse_into_the_dock_needs_a_cusp() -> None:
    net = load_network("hall_loop")
    route = Planner(net, VehicleLimits("tricycle")).plan("S1", "D", arrive_mode=-1)
    ids = [(t.edge.id, t.mode) for t in route.traversals]
    assert ids == [("b2", 1), ("d1", -1), ("d2", -1)]  # forward to P, stop, back up into the spur
    cusp = VehicleLimits("tricycle").cusp_s
    assert route.time_s == pytest.approx(11.0 + (math.pi + 2.0) / 0.3 + cusp, rel=1e-3)
    forward = Planner(net, VehicleLimits("tricycle")).plan("D", "S2", start_heading=-math.pi / 2)
    assert [t.mode for t in forward.traversals][:2] == [1, 1]


def test_planning_on_a_generated_grid_finds_the_manhattan_route() -> None:
    net = network_from_dict(grid_network(6, spacing=5.0))
    planner = Planner(net, VehicleLimits("differential", max_speed=1.0, turn_rate=0.5))
    route = planner.plan("n0_0", "n5_5", start_heading=0.0)
    # 50 m of lines at 1 m/s plus at least one quarter turn on the spot (pi/2 / 0.5 s)
    assert route.time_s == pytest.approx(50.0 + math.pi, abs=1e-6)
    assert route.nodes[0] == "n0_0" and route.nodes[-1] == "n5_5" and len(route.traversals) == 10
