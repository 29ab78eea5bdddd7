"""Missions: speed limits against their definitions, and a closed-loop mission on a tiny network."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from routes_tiny_mission import SCENARIO, run_tiny

from agvnav.guidance.paths import path_from_moves
from agvnav.routes.mission import speed_limits
from agvnav.sim import simulate
from agvnav.world.scenario import ScenarioError, parse_scenario


def test_speed_limit_follows_its_definition() -> None:
    path = path_from_moves([0.0, 0.0, 0.0], [("line", 5.0), ("arc", 1.0, math.pi / 2), ("line", 5.0)])
    seg_speed = np.array([1.0, 1.0, 0.8])
    s, v = speed_limits(path, seg_speed, v_max=0.9, lateral_accel=0.25, max_decel=0.5, creep_distance=0.3,
                        creep_speed=0.05)
    arc = (s > 5.0 + 1e-9) & (s < 5.0 + math.pi / 2 - 1e-9)
    assert v[arc] == pytest.approx(np.full(arc.sum(), 0.5))  # sqrt(a_lat R)
    assert v[s < 1.0] == pytest.approx(np.full((s < 1.0).sum(), 0.9))  # cruise, below the edge limit
    assert np.all(v[s >= path.length - 0.3] <= 0.05 + 1e-12)  # creep-in
    # braking ahead of the arc at the deceleration limit: v^2 = 0.5^2 + 2 a (5 - s)
    before = (s > 4.8) & (s < 5.0)
    assert v[before] == pytest.approx(np.sqrt(0.25 + 2 * 0.5 * (5.0 - s[before])), abs=0.02)
    assert np.all(np.diff(v[s > 5.0 + math.pi / 2 + 0.5]) <= 1e-12)  # only slows towards the station


def test_tiny_mission_closed_loop(tmp_path: Path) -> None:
    r = simulate(run_tiny(tmp_path))
    assert r.outcome == "completed", r.reason
    x = r.extra
    assert x["stations"] == 3
    # no truth errors, exact dead reckoning: the vehicle stops where it was told to (measured at rest, after
    # the heading alignment: it coasts about 5 mm past the point where the profile commanded zero speed)
    assert x["max_stop_error_m"] < 0.015
    assert x["max_stop_heading_error_rad"] < math.radians(1.0)
    assert x["max_lateral_m.arc"] < 0.02 and x["max_lateral_m.line"] < 0.02
    s = r.series
    assert np.any(s["dwelling"] == 1.0) and s["leg"][-1] == 2.0
    assert s["nodes_passed"][-1] == 4.0  # B, C, D, C
    # the dwell at C lasts its 2 s (in steps of 0.05 s)
    assert np.sum(s["dwelling"] == 1.0) * 0.05 == pytest.approx(2.0, abs=0.11)
    # reversed into C: the last leg drives backwards
    assert np.min(s["v_cmd"][s["leg"] == 2.0]) < 0.0 and np.max(s["v_cmd"][s["leg"] == 2.0]) <= 0.0


def test_mission_errors_name_key_and_line(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError) as info:
        simulate(run_tiny(tmp_path, SCENARIO.replace("station: D}", "station: Z}")))
    assert "tiny_mission.yaml:14: mission.jobs[1].station: unknown station 'Z'" in str(info.value)
    with pytest.raises(ScenarioError) as info:
        simulate(run_tiny(tmp_path, SCENARIO.replace("- {action: goto, station: D}", "- {action: goto, station: A}")))
    assert "mission.jobs[1].station: no route to station 'A'" in str(info.value) and info.value.line == 14
    with pytest.raises(ScenarioError, match="mission replaces the path"):
        parse_scenario(SCENARIO + "path: {start: [0, 0, 0], segments: [{type: line, length_m: 1}]}\n")
