"""The compiled A* route search gives the fastest routes the interpreted Dijkstra gives."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav import jit
from agvnav.bench.traffic_planning import bench_planning
from agvnav.routes.layouts import grid_network
from agvnav.routes.network import load_network, network_from_dict
from agvnav.routes.planning import NoRouteError, Planner, Route, VehicleLimits

pytestmark = pytest.mark.usefixtures("restore_jit_mode")


def _plan_both(planner: Planner, start: str, goal: str, mode: int | None = None) -> tuple[Route | None, Route | None]:
    out: list[Route | None] = []
    for on in (True, False):
        jit.set_compiled(on)
        try:
            out.append(planner.plan(start, goal, None, mode))
        except NoRouteError:
            out.append(None)
    return out[0], out[1]


@pytest.mark.parametrize("model", ["tricycle", "differential", "tractor_trailer"])
def test_astar_routes_equal_dijkstra_routes_on_the_warehouse(model: str) -> None:
    net = load_network("warehouse")
    planner = Planner(net, VehicleLimits(model, max_speed=1.2))
    rng = np.random.default_rng(3)
    ids = list(net.nodes)
    for a, b in rng.integers(0, len(ids), (40, 2)):
        fast, ref = _plan_both(planner, ids[a], ids[b], -1 if a % 5 == 0 else None)
        if ref is None:
            assert fast is None
            continue
        assert fast is not None and fast.time_s == pytest.approx(ref.time_s, abs=1e-6)  # QUEUE_RESOLUTION_S
        assert fast.nodes == ref.nodes  # the warehouse has no ties between fastest routes


def test_astar_times_equal_dijkstra_times_on_a_grid_with_blocked_edges() -> None:
    net = network_from_dict(grid_network(12, spacing=4.0))
    planner = Planner(net, VehicleLimits("differential"), blocked=("h3_3", "v5_5", "h6_0"))
    rng = np.random.default_rng(5)
    ids = list(net.nodes)
    for a, b in rng.integers(0, len(ids), (60, 2)):
        fast, ref = _plan_both(planner, ids[a], ids[b])
        assert fast is not None and ref is not None
        assert fast.time_s == pytest.approx(ref.time_s, abs=1e-6)
        assert all(t.edge.id.removesuffix("~r") not in planner.blocked for t in fast.traversals)
        nodes = [fast.nodes[0]] + [t.edge.target for t in fast.traversals]
        assert nodes == list(fast.nodes) and all(
            t.edge.source == n for t, n in zip(fast.traversals, fast.nodes, strict=False))


@pytest.mark.slow
def test_bench_planning_reports_checked_figures() -> None:
    out = bench_planning(quick=True)
    assert out["plan_ok"] and out["plan_nodes"] == 2500 and out["plan_queries"] == 20
    assert 0.0 < out["plan_ms"] <= out["plan_p95_ms"] and out["plan_states"] > out["plan_nodes"]
