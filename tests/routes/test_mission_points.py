"""Point switching within a mission (C cruising, O in manoeuvres, seed 000 §3.1) and the final heading
alignment of spot-turning vehicles."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from routes_tiny_mission import SCENARIO, run_tiny

from agvnav.navigation.mission import stints
from agvnav.sim import simulate
from agvnav.sim.mission import plan_mission

NET = """\
nodes:
  - {id: A, x: 0, y: 0, heading_deg: 0, kind: station}
  - {id: B, x: 4, y: 0, heading_deg: 0}
  - {id: C, x: 6, y: 2, heading_deg: 90}
  - {id: E, x: 6, y: 6, heading_deg: 90, kind: station}
  - {id: F, x: 6, y: 8, kind: station}
edges:
  - {id: ab, from: A, to: B}
  - {id: bc, from: B, to: C, speed_m_s: 0.3, geometry: {type: arc, radius_m: 2, sweep_deg: 90}}
  - {id: ce, from: C, to: E}
  - {id: ef, from: E, to: F, two_way: true, direction: both}
"""

TRICYCLE = SCENARIO.replace(
    "vehicle: {model: differential, track_m: 0.5, wheel_radius_m: 0.08, encoder_counts_per_rev: 4096}",
    "vehicle: {model: tricycle, wheelbase_m: 1.0}",
).replace(
    "controller: {name: kanayama, params: {convergence_distance: 1.0}}",
    "controller: {name: seed_general, point: O, params: {convergence_distance: 1.0}}",
).replace("  start: A\n", "  start: A\n  point_switching: true\n").replace(
    "station: C, duration_s: 2.0", "station: E, duration_s: 2.0").replace(
    "station: D}", "station: F}").replace("reverse_into, station: C", "reverse_into, station: E")


def tiny(tmp_path: Path) -> object:
    sc = run_tiny(tmp_path, TRICYCLE)
    (tmp_path / "tiny.yaml").write_text(NET)
    return sc


def test_stints_switch_c_forward_and_o_backing_up(tmp_path: Path) -> None:
    plan = plan_mission(tiny(tmp_path))  # type: ignore[arg-type]
    got = stints(plan, True, 1.0)
    # leg 0 A->E: cruising at C along ab, the arc and 3 m of the 4 m straight, the last metre to E
    # at O (handed over on the move);
    # leg 1 E->F: only a straight, at O; leg 2 F->E backing up, at O
    assert [(s.leg, s.point, s.extend, s.last, s.handover) for s in got] == [
        (0, "C", 1.0, False, True), (0, "O", 0.0, True, False), (1, "O", 0.0, True, False),
        (2, "O", 0.0, True, False)]
    assert got[0].s1 == pytest.approx(4.0 + math.pi + 3.0) and got[1].s0 == got[0].s1  # C 3 L into the straight
    assert [s.leg for s in stints(plan, False)] == [0, 1, 2]
    assert all(s.point is None and s.extend == 0.0 for s in stints(plan, False))


def test_tricycle_switches_points_and_stops_on_the_stations(tmp_path: Path) -> None:
    r = simulate(tiny(tmp_path))  # type: ignore[arg-type]
    assert r.outcome == "completed", r.reason
    s = r.series
    leg, off, v, s_est = s["leg"], s["point_offset"], s["v_cmd"], s["s_est"]
    assert np.all(off[(leg == 0) & (s_est < 7.0 + math.pi - 0.01)] == 1.0)  # C cruising
    assert np.all(off[(leg == 0) & (s_est > 7.0 + math.pi + 0.01)] == 0.0)  # O on the approach
    assert np.all(off[leg >= 1] == 0.0)
    k = np.flatnonzero(np.diff(off) != 0.0)[0]
    assert abs(v[k + 1]) > 0.1  # handed over on the move
    # exact dead reckoning, no truth errors: each guided point stops on its station
    assert r.extra["stations"] == 3 and r.extra["max_stop_error_m"] < 0.02  # the truth wheel radius error
    assert r.extra["max_lateral_m.line"] < 0.02
