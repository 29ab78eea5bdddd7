"""bench missions: the planning-speed figure on a small generated grid (the mission rows run in the bench itself)."""

from __future__ import annotations

import math

from agvnav.bench.missions import CASES, TITLE, planning_ms


def test_planning_speed_is_timed_on_the_generated_grid() -> None:
    ms, n = planning_ms(10, 5, seed=1)
    assert n == 100 and math.isfinite(ms) and 0.0 < ms < 1000.0
    assert TITLE and {name for name, _ in CASES} == {
        "warehouse_mission", "warehouse_mission_differential", "mission_hall", "mission_hall_differential"}
    assert ("mission_hall", "hall_loop_arcs") in CASES and ("warehouse_mission", "warehouse_arcs") in CASES
