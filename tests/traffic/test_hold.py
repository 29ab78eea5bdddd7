"""Hold points from the ADG on vehicles that report their progress (agvnav.traffic.hold), without the closed loop.

Each vehicle here "drives" its chained mission path at 1 m/s, never past its hold point, and reports its
progress every 0.1 s: the resources it holds by that progress never conflict with another's, it waits
where the ADG says, and without the holds the same plans conflict.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.routes.mission import chain_mission
from agvnav.routes.network import load_network
from agvnav.routes.planning import VehicleLimits
from agvnav.traffic.adg import build_adg
from agvnav.traffic.hold import HoldControl, mission_legs, step_bounds
from agvnav.traffic.plan import Goal, VehicleTask, plan_fleet
from agvnav.traffic.zones import conflict_zones

LIMITS = VehicleLimits("differential", 1.0)


def _control(swaps: list[tuple[str, str]], follow_adg: bool = True) -> HoldControl:
    net = load_network("lane_swap")
    zones = conflict_zones(net, ["differential"])
    tasks = [VehicleTask(f"V{i}", LIMITS, a, (Goal(b, 2.0, action="drop"),)) for i, (a, b) in enumerate(swaps)]
    plan = plan_fleet(net, tasks, zones)
    assert not plan.unserved
    bounds = {}
    for v, p in plan.plans.items():
        start = net.nodes[p.start]
        mp = chain_mission(mission_legs(p), np.array([start.x, start.y]), math.radians(5.0))
        bounds[v] = step_bounds(mp.node_s, p)
        assert bounds[v][-1][1] == pytest.approx(mp.path.length)
    return HoldControl(build_adg(plan, zones), plan.plans, bounds, zones, follow_adg)


def _drive(control: HoldControl, seconds: float = 200.0, dt: float = 0.1) -> int:
    """Every vehicle at 1 m/s up to its hold point; returns the steps at which two held conflicting resources."""
    ends = {v: b[-1][1] if b else 0.0 for v, b in control.bounds.items()}
    s = dict.fromkeys(control.plans, 0.0)
    conflicting = 0
    t = 0.0
    while t < seconds and any(s[v] < ends[v] for v in s):
        t += dt
        for v in s:
            s[v] = min(s[v] + dt, control.hold_point(v), ends[v])
            control.report(v, s[v], t, dt)
        conflicting += bool(control.conflicting())
    assert all(s[v] >= ends[v] for v in s), "a vehicle never got to its goal"
    return conflicting


def test_two_vehicles_swapping_ends_of_the_lane_wait_at_their_hold_points_and_never_conflict() -> None:
    control = _control([("WA", "EC"), ("EA", "WC")])
    assert _drive(control) == 0
    assert all(control.adg.done[v] == 2 * len(p.steps) for v, p in control.plans.items())  # every event marked
    waits = {v: w.total_s for v, w in control.waits.items()}
    assert max(waits.values()) > 1.0
    for w in control.waits.values():
        assert sum(w.by_zone.values()) == pytest.approx(w.total_s)
        assert sum(w.by_node.values()) == pytest.approx(w.total_s)
        assert all(z.startswith(("edge:", "node:")) for z in w.by_zone)


def test_without_the_holds_the_same_plans_conflict() -> None:
    control = _control([("WA", "EC"), ("EA", "WC")], follow_adg=False)
    assert _drive(control) > 0
    assert all(w.total_s == 0.0 for w in control.waits.values())


def test_the_hold_point_is_the_source_of_the_first_step_not_allowed() -> None:
    control = _control([("WA", "EC"), ("EA", "WC")])
    held = [v for v in control.plans if math.isfinite(control.hold_point(v))]
    assert held  # someone waits for the other at first
    v = held[0]
    k = next(k for k in range(len(control.plans[v].steps)) if control.adg.blockers(v, 2 * k))
    assert control.hold_point(v) == control.bounds[v][k][0]


def test_a_vehicle_at_its_hold_point_waits_on_the_other() -> None:
    control = _control([("WA", "EC"), ("EA", "WC")])
    assert not any(control.waiting_on(v) for v in control.plans)  # nobody stands at a hold point yet
    s = dict.fromkeys(control.plans, 0.0)
    t, seen = 0.0, {}
    while t < 100.0 and not seen:
        t += 0.1
        for v in s:
            s[v] = min(s[v] + 0.1, control.hold_point(v), control.bounds[v][-1][1])
            control.report(v, s[v], t, 0.1)
        seen = {v: control.waiting_on(v) for v in s if control.waiting_on(v)}
    (v, on), = seen.items()
    assert on == set(control.plans) - {v}
    assert s[v] == pytest.approx(control.hold_point(v))  # it stands at its hold point
