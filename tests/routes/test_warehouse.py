"""The shipped warehouse example: its route network is the generated layout, its map holds it, its missions plan."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.navigation.mission import stints
from agvnav.routes.layouts import warehouse_network
from agvnav.routes.network import load_network, network_from_dict
from agvnav.sim.mission import plan_mission
from agvnav.world.map import load_map
from agvnav.world.scenario import load_scenario


@pytest.mark.parametrize("clothoids", [True, False])
def test_shipped_warehouse_network_is_the_generated_layout(clothoids: bool) -> None:
    generated = network_from_dict(warehouse_network(clothoids))
    shipped = load_network(generated.name)
    assert set(shipped.edges) == set(generated.edges)
    for nid, node in generated.nodes.items():
        assert (shipped.nodes[nid].x, shipped.nodes[nid].y) == pytest.approx((node.x, node.y), abs=1e-6)
    kinds = {n.kind for n in shipped.nodes.values()}
    stations = [n for n in shipped.nodes.values() if n.kind != "decision"]
    assert 10 <= len(stations) <= 20 and "charger" in kinds
    joints = shipped.joints()
    assert joints and all(j.g1 for j in joints)
    assert all(j.g2 for j in joints if j.g2_required)


def test_warehouse_network_stays_clear_of_the_racks_and_pillars() -> None:
    world = load_map("warehouse")
    net = load_network("warehouse")
    pts = np.concatenate([e.curve.points for e in net.edges.values()])
    assert pts[:, 0].min() > 0.0 and pts[:, 0].max() < 60.0 and pts[:, 1].min() > 0.0 and pts[:, 1].max() < 40.0
    walls = world.wall_segments  # (M, 2, 2): the distance of every route point to every wall segment
    a, b = walls[:, 0], walls[:, 1]
    d = b - a
    t = np.clip(np.einsum("pmk,mk->pm", pts[:, None, :] - a[None], d) / np.einsum("mk,mk->m", d, d), 0.0, 1.0)
    gap = np.linalg.norm(pts[:, None, :] - (a[None] + t[..., None] * d[None]), axis=-1)
    assert gap.min() > 1.2  # the tricycle's half width (0.45 m) and more


@pytest.mark.parametrize("name", ["warehouse_mission", "warehouse_mission_differential"])
def test_warehouse_missions_plan_every_job(name: str) -> None:
    sc = load_scenario(name)
    plan = plan_mission(sc)
    assert [leg.station for leg in plan.legs] == ["B1", "B2", "A2", "N1", "N2", "CH", "D"]
    assert plan.path.length > 200.0
    last = plan.legs[-1].route
    assert last is not None and last.traversals[-1].mode < 0  # backed into the dock


def test_tricycle_warehouse_mission_switches_points() -> None:
    sc = load_scenario("warehouse_mission")
    assert sc.mission is not None and sc.mission.point_switching
    got = stints(plan_mission(sc), True, 1.0)
    assert {s.point for s in got} == {"C", "O"}
    assert all(s.point == "O" for s in got if s.last)  # every station approached at O
