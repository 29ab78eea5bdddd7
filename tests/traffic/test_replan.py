"""The lane swap on the real conflict zones, and replanning when a vehicle is blocked long (issue 30).

Ground truth is the executor's brute force: the true footprints intersected every 0.2 s, every resource
taken compared with those the others hold, cycles of waits and stalls detected; the zones are the real
swept-footprint zones (:func:`agvnav.traffic.zones.conflict_zones`).
"""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.routes.network import load_network
from agvnav.routes.planning import VehicleLimits
from agvnav.traffic.adg import build_adg
from agvnav.traffic.execute import AdgController, Delays, ExecResult, execute, random_delays, routes_from_plan
from agvnav.traffic.plan import FleetPlan, Goal, VehicleTask, plan_fleet
from agvnav.traffic.replan import Replanner
from agvnav.traffic.zones import ConflictZones, conflict_zones, model_footprint

MODEL = "differential"
LIM = VehicleLimits(MODEL, 1.0)
SWAP = [("WA", "EC"), ("WB", "ED"), ("EA", "WC"), ("EB", "WD")]


@pytest.fixture(scope="module")
def swap() -> tuple[object, ConflictZones, list[VehicleTask], FleetPlan]:
    net = load_network("lane_swap")
    zones = conflict_zones(net, [MODEL])
    tasks = [VehicleTask(f"V{i}", LIM, a, (Goal(b, 3.0, action="drop"),)) for i, (a, b) in enumerate(SWAP)]
    return net, zones, tasks, plan_fleet(net, tasks, zones)


def _run(swap, delays: Delays, replan: bool) -> tuple[ExecResult, Replanner]:  # type: ignore[no-untyped-def]
    net, zones, tasks, plan = swap
    feet = {t.vehicle: model_footprint(MODEL) for t in tasks}
    rp = Replanner(net, zones, tasks, feet, plan)
    routes = routes_from_plan(plan, net, {t.vehicle: LIM for t in tasks}, feet)
    r = execute(net, routes, AdgController(build_adg(plan, zones)), zones, delays, 3000.0,
                replan=rp if replan else None, replan_after_s=20.0)
    return r, rp


def _safe(r: ExecResult) -> bool:
    return r.collisions == [] and r.violations == [] and r.deadlock is None


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_four_vehicles_swap_ends_on_the_real_zones_under_delays(swap, seed: int) -> None:  # type: ignore[no-untyped-def]
    _, _, tasks, plan = swap
    assert plan.unserved == {}
    delays = random_delays([t.vehicle for t in tasks], np.random.default_rng(seed), 300.0)
    for replan in (False, True):
        r, _ = _run(swap, delays, replan)
        assert _safe(r) and all(r.finished.values()) and r.n_deliveries == 4


def test_replanning_lets_the_others_pass_a_vehicle_stopped_long(swap) -> None:  # type: ignore[no-untyped-def]
    """V1 stops 5 s in for 300 s: through the first plan's ADG the others wait for it; replanned, all three
    deliver before its stop ends, and nothing collides or deadlocks across the switch."""
    delays = Delays({}, {"V1": ((5.0, 300.0),)})
    plain, _ = _run(swap, delays, False)
    replanned, rp = _run(swap, delays, True)
    assert _safe(plain) and _safe(replanned) and rp.kept == replanned.replans >= 1
    assert plain.n_deliveries == replanned.n_deliveries == 4
    assert sum(t < 305.0 for t in plain.delivery_times) <= 1
    assert sum(t < 305.0 for t in replanned.delivery_times) == 3


@pytest.mark.parametrize("who", ["V0", "V2", "V3"])
def test_replanning_stays_safe_whoever_stops(swap, who: str) -> None:  # type: ignore[no-untyped-def]
    r, _ = _run(swap, Delays({"V0": 0.7, "V3": 1.3}, {who: ((10.0, 120.0),)}), True)
    assert _safe(r) and all(r.finished.values()) and r.n_deliveries == 4
