"""The mission autopilot for a fleet's traffic control: the hold point in the speed profile, turns on the spot."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.navigation.mission import LimitedSpeedProfile, SpotTurn, stints, turn_points
from agvnav.routes.mission import Job, chain_mission, plan_legs
from agvnav.routes.network import load_network
from agvnav.routes.planning import Planner, VehicleLimits


def test_the_profile_stops_at_the_hold_point_smoothly_and_goes_on_when_it_moves() -> None:
    prof = LimitedSpeedProfile(cruise_speed=1.0, max_accel=0.3, max_decel=0.3)
    hold_at, s, dt = 6.0, 0.0, 0.05
    prof.hold = lambda: hold_at - s
    speeds = []
    for _ in range(1200):
        v = prof.command(50.0 - s, dt)
        speeds.append(v)
        s += v * dt
    assert s == pytest.approx(hold_at, abs=0.02) and speeds[-1] == 0.0  # stands at the hold point
    assert max(abs(a - b) for a, b in zip(speeds[1:], speeds[:-1], strict=False)) <= 0.3 * dt + 1e-9  # smoothly
    hold_at = math.inf  # the hold point moves on: it drives again
    for _ in range(100):
        s += prof.command(50.0 - s, dt) * dt
    assert s > 6.5


def test_a_spot_turn_reaches_its_heading_within_its_rate_and_acceleration() -> None:
    spot = SpotTurn(lambda v, w: (v, w), turn_rate=0.5, turn_accel=1.0)
    heading, omega, dt = 0.0, 0.0, 0.05
    target = 2.0
    for _ in range(400):
        new = spot.omega(target - heading, omega, dt)
        assert abs(new) <= 0.5 + 1e-12 and abs(new - omega) <= 1.0 * dt + 1e-12
        omega = new
        heading += omega * dt
    assert heading == pytest.approx(target, abs=0.01)


def test_the_turns_on_the_spot_inside_a_leg_cut_its_stints() -> None:
    net = load_network("lane_swap")
    planner = Planner(net, VehicleLimits("differential", 1.0))
    legs = plan_legs(planner, "WA", [Job("goto", "EC")])
    start = net.nodes["WA"]
    plan = chain_mission(legs, np.array([start.x, start.y]), math.radians(5.0))
    cuts = turn_points(plan)
    assert cuts  # WA -> WH turns onto the lane, the lane end turns onto the spur
    assert len(stints(plan, False)) == 1
    turning = stints(plan, False, turns=True)
    assert len(turning) == len(cuts) + 1 and turning[-1].last and not turning[0].last
    assert [st.s0 for st in turning[1:]] == pytest.approx(cuts)
