"""Route network files: geometry, continuity report, and bad input named with key and line."""

from __future__ import annotations

import math

import pytest

from agvnav.routes.layouts import hall_loop
from agvnav.routes.network import load_network, network_from_dict, parse_network
from agvnav.world.strict import ScenarioError

SMALL = """\
name: small
nodes:
  - {id: A, x: 0, y: 0, heading_deg: 0, kind: station}
  - {id: B, x: 5, y: 0}
  - {id: C, x: 7, y: 2, kind: station}
edges:
  - {id: ab, from: A, to: B, two_way: true}
  - {id: bc, from: B, to: C, geometry: {type: arc, radius_m: 2, sweep_deg: 90, heading_deg: 0}}
"""


def test_small_network_graph_and_joints() -> None:
    net = parse_network(SMALL, "small.yaml")
    assert set(net.edges) == {"ab", "ab~r", "bc"}
    assert net.graph.has_edge("B", "A")
    assert net.stations == ["A", "C"]
    (joint,) = net.joints()  # ab -> bc at B: G1, curvature jumps 0 -> 1/2 (no clothoid: G2 not required)
    assert (joint.incoming, joint.outgoing, joint.g1, joint.g2_required) == ("ab", "bc", True, False)
    assert joint.curvature_jump == pytest.approx(0.5)
    assert net.edges["bc"].curve.points[-1] == pytest.approx([7.0, 2.0])


def test_shipped_network_is_g1_and_g2_at_every_clothoid_joint() -> None:
    net = load_network("hall_loop")
    kinds = {e.curve.kind for e in net.edges.values()}
    assert kinds == {"line", "arc", "clothoid", "nurbs"}
    joints = net.joints()
    assert all(j.g1 for j in joints)
    assert all(j.g2 for j in joints if j.g2_required)
    assert max(e.curve.approx_error_m for e in net.edges.values()) < 5e-4
    plain = network_from_dict(hall_loop(clothoids=False))
    assert any(j.curvature_jump > 0.4 for j in plain.joints())  # line-arc joints jump by 1/R


def error_of(text: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        parse_network(text, "net.yaml")
    return info.value


def test_unknown_node_is_named_with_key_and_line() -> None:
    err = error_of(SMALL.replace("to: C, geometry", "to: X, geometry"))
    assert "net.yaml:8: edges[1].to: unknown node 'X'" in str(err)


def test_gap_at_a_joint_is_refused() -> None:
    err = error_of(SMALL.replace("sweep_deg: 90", "sweep_deg: 80"))
    assert err.line == 8 and "edges[1].geometry" in str(err) and "from node 'C'" in str(err)


def test_heading_jump_at_a_joint_is_refused() -> None:
    # the arc starts 2 deg off the line's heading; C moved to where that arc ends (no gap)
    h0, h1 = math.radians(2.0), math.radians(92.0)
    cx, cy = 5 + 2 * (math.sin(h1) - math.sin(h0)), 2 * (math.cos(h0) - math.cos(h1))
    text = SMALL.replace("heading_deg: 0}}", "heading_deg: 2}}")
    text = text.replace("{id: C, x: 7, y: 2", f"{{id: C, x: {cx:.6f}, y: {cy:.6f}")
    err = error_of(text)
    assert "heading jump of 2 deg at node 'B'" in str(err) and err.line == 8


def test_bad_nurbs_weight_names_the_control_points() -> None:
    text = SMALL + """\
  - {id: cn, from: C, to: A, geometry: {type: nurbs, degree: 1, knot_vector: [0, 0, 1, 1],
     control_points: [{x: 7, y: 2}, {x: 0, y: 0, weight: -1}]}}
"""
    err = error_of(text)
    assert "edges[2].geometry.control_points" in str(err) and "weight must be positive" in str(err)


def test_unknown_key_and_model() -> None:
    assert "unknown key" in str(error_of(SMALL.replace("two_way: true", "two_wya: true")))
    err = error_of(SMALL.replace("two_way: true", "models: [forklift]"))
    assert "unknown vehicle model 'forklift'" in str(err) and err.line == 7


def test_shipped_network_is_the_generated_layout() -> None:
    shipped = load_network("hall_loop")
    generated = network_from_dict(hall_loop(clothoids=True))
    assert set(shipped.edges) == set(generated.edges)
    for nid, node in generated.nodes.items():
        assert (shipped.nodes[nid].x, shipped.nodes[nid].y) == pytest.approx((node.x, node.y), abs=1e-6)
