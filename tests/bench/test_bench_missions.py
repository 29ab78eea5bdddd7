"""bench missions: the planning-speed figure on a small generated grid (the mission rows run in the bench itself)."""

from __future__ import annotations

import math

import pytest

from agvnav.bench.missions import CASES, TITLE, guidance_joints, planning_ms
from agvnav.world.scenario import load_scenario


def test_planning_speed_is_timed_on_the_generated_grid() -> None:
    ms, n = planning_ms(10, 5, seed=1)
    assert n == 100 and math.isfinite(ms) and 0.0 < ms < 1000.0
    assert TITLE and {name for name, _ in CASES} == {
        "warehouse_mission", "warehouse_mission_differential", "mission_hall", "mission_hall_differential"}
    assert ("mission_hall", "hall_loop_arcs") in CASES and ("warehouse_mission", "warehouse_arcs") in CASES


@pytest.mark.slow
def test_clothoid_corners_lower_the_guidance_error_at_the_hall_joints() -> None:
    # guided at O (mission_hall) the body must turn into a plain arc: ~24 mm, ~9 mm with clothoid corners
    hall = load_scenario("mission_hall")
    assert hall.mission is not None
    arcs = hall.copy_attached({"mission": hall.mission.model_copy(update={"network": "hall_loop_arcs"})})
    clothoid, plain = guidance_joints(hall), guidance_joints(arcs)
    assert 0.015 < plain < 0.04 and clothoid < 0.5 * plain
