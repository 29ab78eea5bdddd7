"""Topological navigation: a pose is located on the graph, and planning starts from there."""

from __future__ import annotations

import math

import pytest

from agvnav.routes.network import load_network
from agvnav.routes.planning import Planner, VehicleLimits
from agvnav.routes.topology import GraphLocator, plan_from_pose


def test_pose_on_the_bottom_lane_is_located_with_its_direction() -> None:
    net = load_network("hall_loop")
    loc = GraphLocator(net, "tricycle")
    east = loc.locate([12.0, 3.02, 0.01])  # on b2 (S1 -> P, x 8..19), facing east
    assert (east.edge, east.mode, east.next_node) == ("b2", 1, "P")
    assert east.s == pytest.approx(4.0, abs=0.06) and east.fraction == pytest.approx(4.0 / 11.0, abs=0.01)
    west = loc.locate([12.0, 3.0, math.pi])  # same place facing west: the two-way lane's twin
    assert (west.edge, west.next_node) == ("b2~r", "S1")
    assert loc.locate([8.05, 3.0, 0.0]).at_node == "S1"
    with pytest.raises(ValueError, match="not on the route network"):
        loc.locate([15.0, 7.0, 0.0])  # at the pillar, 4 m from any edge


def test_plan_from_a_pose_continues_along_the_current_edge() -> None:
    net = load_network("hall_loop")
    planner = Planner(net, VehicleLimits("tricycle"))
    _, route = plan_from_pose(planner, GraphLocator(net, "tricycle"), [12.0, 3.0, 0.0], "S2")
    assert route.traversals[0].edge.id == "b2" and route.nodes[-1] == "S2"
    full = planner.plan("S1", "S2")
    assert route.time_s < full.time_s  # 4 m of b2 are already behind
