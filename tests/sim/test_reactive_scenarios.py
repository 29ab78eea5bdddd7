"""The shipped safety scenarios build; reactive sections are checked against the path (issue 18)."""

from __future__ import annotations

import pytest

from agvnav.navigation.reactive import ReactiveAutopilot
from agvnav.sim.build import build
from agvnav.world.scenario import ScenarioError, builtin_scenario, load_scenario, parse_scenario


@pytest.mark.parametrize("name", ["safety_person_crossing", "safety_person_stepping_out", "safety_lane_obstacle"])
def test_shipped_safety_scenarios_build_with_the_reactive_autopilot(name):
    sc = load_scenario(name)
    assert sc.obstacles and sc.scanner is not None and sc.reactive is not None
    built = build(sc)
    assert isinstance(built.autopilot, ReactiveAutopilot)
    assert "reaction_level" in built.autopilot.signal_names
    assert f"clearance__{sc.obstacles[0].id}" in built.autopilot.signal_names


def test_scenarios_without_the_sections_are_untouched():
    sc = load_scenario("differential_loop")
    assert sc.obstacles is None and sc.scanner is None and sc.reactive is None
    assert not isinstance(build(sc).autopilot, ReactiveAutopilot)


def _lane(**replace: str):
    text = builtin_scenario("safety_lane_obstacle").read_text(encoding="utf-8")
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    return parse_scenario(text, "lane.yaml")


def test_avoidance_on_a_missing_segment_is_named():
    with pytest.raises(ScenarioError, match=r"avoid_segments.*no segment 3"):
        build(_lane(**{"avoid_segments: [0]": "avoid_segments: [3]"}))


def test_avoidance_needs_a_corridor():
    sc = _lane(**{"corridor_left_m: 2.0": "corridor_left_m: 0.0", "corridor_right_m: 0.6": "corridor_right_m: 0.0"})
    with pytest.raises(ScenarioError, match="corridor"):
        build(sc)


def test_a_bad_obstacle_entry_names_its_key_and_line():
    text = builtin_scenario("safety_lane_obstacle").read_text(encoding="utf-8")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if "id: pallet" in s)  # the entry's line
    with pytest.raises(ScenarioError, match=rf"lane.yaml:{line}: obstacles\[0\]: give either position"):
        _lane(**{"position: [13.0, 8.0]}": "}"})
