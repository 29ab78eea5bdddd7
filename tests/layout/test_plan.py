"""The planner end to end on the small hall; bad input is one located line."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.layout import TargetUnreachable, parse_layout, plan_layout
from agvnav.layout.hall import routes_as_paths
from agvnav.layout.plan import build_problem
from agvnav.sim.build import reflectors_in_view
from agvnav.world.strict import ScenarioError


def test_small_plan_meets_target_and_beats_or_ties_baseline(small_text: str) -> None:
    plan = plan_layout(parse_layout(small_text))
    assert plan.prediction.meets(plan.problem)
    assert plan.prediction.count.min() >= 3
    assert plan.result.chosen.size <= plan.baseline.size
    assert plan.result.lower_bound <= plan.result.chosen.size
    world = plan.world
    assert len(world.reflectors) == plan.result.chosen.size
    assert {w.id for w in world.walls} == {"outer", "rack"}


def test_plan_is_deterministic_for_a_seed(small_text: str) -> None:
    a = plan_layout(parse_layout(small_text))
    b = plan_layout(parse_layout(small_text))
    assert np.array_equal(a.result.chosen, b.result.chosen)


def test_poses_carry_heading_and_mount(small_text: str) -> None:
    text = small_text.replace("goniometer: {", "goniometer: {mount: [0.5, 0, 0], ")
    _, _, poses, _ = build_problem(parse_layout(text))
    north = poses.route == 1  # drives west: heading pi, head 0.5 m west of base_link
    np.testing.assert_allclose(np.cos(poses.pose[north, 2]), -1.0)
    np.testing.assert_allclose(poses.head[north, 0], poses.pose[north, 0] - 0.5, atol=1e-12)


BAD = [
    ("  outer: [[0, 0], [20, 0], [20, 12], [0, 12], [0, 0]]", "  outer: [[0, 0], [20, 0], [20, 12], [0, 12]]",
     ":4: hall.outer: the polygon does not close"),
    ("  outer: [[0, 0], [20, 0], [20, 12], [0, 12], [0, 0]]", "  outer: [[0, 0], [20, 12], [20, 0], [0, 12], [0, 0]]",
     ":4: hall.outer: the polygon is not simple"),
    ("start: [2, 2.5, 0]", "start: [2, 2.5, 90]", ":9: routes[0].path: route 'south' leaves the hall"),
    ("start: [18, 9.5, 180]", "start: [18, 6, 180]", ":11: routes[1].path: route 'north' runs into occluder 'rack'"),
    ("  sites: [{face: outer", "  explicit: [[10, 6]]\n  sites: [{face: outer",
     ":14: candidates.explicit[0]: reflector at [10.0, 6.0] is inside occluder 'rack'"),
    ("goniometer: {", "goniometer: {colour: red, ", ":12: goniometer.colour: unknown key"),
]


@pytest.mark.parametrize(("old", "new", "message"), BAD)
def test_bad_input_is_one_located_line(small_text: str, old: str, new: str, message: str) -> None:
    assert old in small_text
    with pytest.raises(ScenarioError) as exc:
        plan_layout(parse_layout(small_text.replace(old, new), "small.yaml"))
    text = str(exc.value)
    assert text.startswith("small.yaml" + message), text
    assert "\n" not in text


def test_unreachable_target_names_points_and_reasons(small_text: str) -> None:
    text = small_text.replace("max_range_m: 15", "max_range_m: 1.5")
    with pytest.raises(TargetUnreachable) as exc:
        plan_layout(parse_layout(text))
    assert "target cannot be met" in str(exc.value) and "out of range" in str(exc.value)
    assert {p["reason"] for p in exc.value.points} <= {"out of range", "occluded", "degenerate"}
    assert exc.value.points[0]["route"] in ("south", "north")


def test_planned_map_passes_the_simulators_in_view_check(small_text: str) -> None:
    spec = parse_layout(small_text)
    plan = plan_layout(spec)
    for path in routes_as_paths(spec):
        pts = path.point_at(np.arange(0.0, path.length, 0.05))
        assert reflectors_in_view(plan.world, pts, 0.3, 15.0).min() >= 3
