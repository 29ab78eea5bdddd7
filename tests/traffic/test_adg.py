"""The ADG executes prioritised plans safely under delays: acyclic, no collision, no deadlock (issue 30).

Ground truth is brute force: the executor places the true footprints at the sampled poses every 0.2 s
and intersects them, and compares every resource taken with those the others hold; the zones here are
the conservative bounding-disc relation of ``texec_support`` (a superset of the swept footprints).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from texec_support import DiscZones

from agvnav.routes.layouts import grid_network
from agvnav.routes.network import load_network, network_from_dict
from agvnav.routes.planning import VehicleLimits
from agvnav.traffic.adg import PlanConflictError, build_adg
from agvnav.traffic.execute import AdgController, Delays, execute, random_delays, routes_from_plan
from agvnav.traffic.plan import Goal, VehicleTask, plan_fleet
from agvnav.vehicles import box_footprint

FOOT = box_footprint(0.45, 0.45, 0.3)
LIM = VehicleLimits("differential", 1.0)
SWAP = [("WA", "EC"), ("WB", "ED"), ("EA", "WC"), ("EB", "WD")]


def _swap(pairs: list[tuple[str, str]] = SWAP):  # type: ignore[no-untyped-def]
    net = load_network("lane_swap")
    zones = DiscZones(net, {"differential": 0.55})
    tasks = [VehicleTask(f"V{i}", LIM, a, (Goal(b, 3.0, action="drop"),)) for i, (a, b) in enumerate(pairs)]
    return net, zones, plan_fleet(net, tasks, zones)


def _run(net, zones, plan, delays, horizon=3000.0):  # type: ignore[no-untyped-def]
    routes = routes_from_plan(plan, net, dict.fromkeys(plan.plans, LIM), dict.fromkeys(plan.plans, FOOT))
    return execute(net, routes, AdgController(build_adg(plan, zones)), zones, delays, horizon)


def test_four_vehicles_swap_ends_on_one_lane_with_one_bay() -> None:
    net, zones, plan = _swap()
    assert plan.unserved == {}
    adg = build_adg(plan, zones)
    assert adg.is_acyclic()
    used = {st.edge for p in plan.plans.values() for st in p.steps}
    assert used & {"BW-BE", "BW-BE~r"}, "someone waits in the bay while the others pass"
    for p in plan.plans.values():
        assert p.end_node == p.goals[-1].station
    r = _run(net, zones, plan, Delays({}, {}))
    assert r.collisions == [] and r.violations == [] and r.deadlock is None
    assert all(r.finished.values()) and r.n_deliveries == 4


@pytest.mark.parametrize("seed", range(6))
def test_random_delays_never_collide_or_deadlock_in_the_swap(seed: int) -> None:
    net, zones, plan = _swap()
    rng = np.random.default_rng(seed)
    r = _run(net, zones, plan, random_delays(list(plan.plans), rng, 200.0, stops_per_vehicle=3.0))
    assert r.collisions == [] and r.violations == [] and r.deadlock is None
    assert all(r.finished.values())


def _grid_plan(seed: int, n: int = 8):  # type: ignore[no-untyped-def]
    net = network_from_dict(grid_network(4, 5.0))
    zones = DiscZones(net, {"differential": 0.55})
    rng = np.random.default_rng(seed)
    nodes = list(net.nodes)
    starts = rng.choice(len(nodes), n, replace=False)
    free = [i for i in range(len(nodes)) if i not in set(starts.tolist())]
    ends = rng.choice(free, n, replace=False)
    tasks = [VehicleTask(f"V{i}", LIM, nodes[s], (Goal(nodes[int(rng.integers(len(nodes)))], 2.0, action="pick"),
                                                   Goal(nodes[e], 2.0, action="drop")))
             for i, (s, e) in enumerate(zip(starts.tolist(), ends.tolist(), strict=True))]
    return net, zones, plan_fleet(net, tasks, zones)


@pytest.mark.parametrize("seed", range(6))
def test_adg_of_random_grid_plans_is_acyclic_and_safe_under_delays(seed: int) -> None:
    net, zones, plan = _grid_plan(seed)
    adg = build_adg(plan, zones)
    assert adg.is_acyclic()
    r = _run(net, zones, plan, random_delays(list(plan.plans), np.random.default_rng(100 + seed), 150.0))
    assert r.collisions == [] and r.violations == [] and r.deadlock is None
    served = [v for v in plan.plans if v not in plan.unserved]
    assert all(r.finished[v] for v in served)


def test_without_the_adg_the_same_delays_collide_or_conflict() -> None:
    """The check has teeth: the swap run with a controller that lets everyone go at once fails."""

    class Free:
        def may_start(self, vehicle: str, k: int, t: float) -> str | None:
            return None

        def started(self, vehicle: str, k: int, t: float) -> None: ...

        def arrived(self, vehicle: str, k: int, t: float) -> None: ...

        def waiting_for(self, vehicle: str, k: int) -> set[str]:
            return set()

    net, zones, plan = _swap()
    routes = routes_from_plan(plan, net, dict.fromkeys(plan.plans, LIM), dict.fromkeys(plan.plans, FOOT))
    r = execute(net, routes, Free(), zones, Delays({}, {}), 3000.0)
    assert r.collisions or r.violations


def test_an_overlapping_plan_is_refused() -> None:
    _net, zones, plan = _swap()
    v0, v2 = plan.plans["V0"], plan.plans["V2"]
    shift = v2.steps[0].t_start - v0.steps[0].t_start
    moved = tuple(s._replace(t_start=s.t_start - shift, t_end=s.t_end - shift) for s in v2.steps)
    plan.plans["V2"] = dataclasses.replace(v2, steps=moved)
    with pytest.raises(PlanConflictError, match="overlapping"):
        build_adg(plan, zones)


def test_events_happen_in_order_and_after_their_dependencies() -> None:
    _net, zones, plan = _swap()
    adg = build_adg(plan, zones)
    waiting = next((v, e) for v, by in adg.deps.items() for e in by if e == 0)
    with pytest.raises(ValueError, match="before its dependencies"):
        adg.mark(*waiting)
    with pytest.raises(ValueError, match="out of order"):
        adg.mark("V0", 1)


def test_a_station_no_route_reaches_is_reported_unserved() -> None:
    net = load_network("lane_swap")
    zones = DiscZones(net, {"differential": 0.55, "tractor_trailer": 0.8})
    lim = VehicleLimits("tractor_trailer", 1.0)  # cannot back up or turn on the spot: never leaves its spur
    plan = plan_fleet(net, [VehicleTask("T", lim, "WA", (Goal("EC"),))], zones)
    assert "T" in plan.unserved and plan.plans["T"].steps == ()
    with pytest.raises(ValueError, match="unknown station"):
        plan_fleet(net, [VehicleTask("T", LIM, "WA", (Goal("nowhere"),))], zones)
