"""Conflict zones on random small networks (hypothesis): the brute-force check never finds a missed pair."""

from __future__ import annotations

import math
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agvnav.guidance.clothoid import Clothoid
from agvnav.routes.network import network_from_dict
from agvnav.traffic.zones import conflict_zones, find_missed_conflicts

MODELS = ("tricycle", "quad_steer", "differential", "tractor_trailer")

piece = st.one_of(
    st.tuples(st.just("line"), st.floats(0.5, 4.0), st.just(0.0), st.just(0.0)),
    st.tuples(st.just("arc"), st.floats(1.0, 4.0), st.floats(-120.0, 120.0).filter(lambda s: abs(s) > 5.0),
              st.just(0.0)),
    st.tuples(st.just("clothoid"), st.floats(0.5, 3.0), st.floats(-0.6, 0.6), st.floats(-0.6, 0.6)),
)
chain = st.tuples(st.floats(0.0, 8.0), st.floats(0.0, 8.0), st.floats(-180.0, 180.0),
                  st.lists(piece, min_size=1, max_size=3), st.booleans(), st.sampled_from(["forward", "both"]))


def _network(chains: list[tuple[Any, ...]]) -> dict[str, Any]:
    """Chains of line/arc/clothoid edges, each edge starting where and as the previous one ended."""
    nodes: list[dict[str, Any]] = []
    edges: list[dict[str, Any]] = []
    for c, (x, y, h_deg, pieces, two_way, direction) in enumerate(chains):
        nodes.append({"id": f"c{c}n0", "x": x, "y": y, "heading_deg": h_deg})
        for k, (kind, a, b, d) in enumerate(pieces):
            h = math.radians(h_deg)
            if kind == "line":
                x, y = x + a * math.cos(h), y + a * math.sin(h)
                geometry: dict[str, Any] = {"type": "line"}
            elif kind == "arc":
                r, sweep = a, math.radians(b)
                cx, cy = x - r * math.sin(h) * math.copysign(1, sweep), y + r * math.cos(h) * math.copysign(1, sweep)
                h_end = h + sweep
                x = cx + r * math.sin(h_end) * math.copysign(1, sweep)
                y = cy - r * math.cos(h_end) * math.copysign(1, sweep)
                geometry = {"type": "arc", "radius_m": r, "sweep_deg": b, "heading_deg": h_deg}
                h_deg += b
            else:
                cl = Clothoid.from_curvatures(x, y, h, b, d, a)
                x, y = (float(v) for v in cl.point_at(a))
                geometry = {"type": "clothoid", "length_m": a, "curvature_start_per_m": b,
                            "curvature_end_per_m": d, "heading_deg": h_deg}
                h_deg = math.degrees(float(cl.heading_at(a)))
            nodes.append({"id": f"c{c}n{k + 1}", "x": x, "y": y, "heading_deg": h_deg})
            edges.append({"id": f"c{c}e{k}", "from": f"c{c}n{k}", "to": f"c{c}n{k + 1}", "geometry": geometry,
                          "two_way": two_way, "direction": direction})
    return {"name": "random", "tolerances": {"joint_deg": 1.0}, "nodes": nodes, "edges": edges}


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(chain, min_size=2, max_size=3))
def test_random_networks_have_no_missed_conflict(chains: list[tuple[Any, ...]]) -> None:
    net = network_from_dict(_network(chains))
    zones = conflict_zones(net, MODELS)
    assert find_missed_conflicts(net, MODELS, zones, step_m=0.05) == []
