"""The settings document of a log: every key known, angles in radians (issue 29)."""

import math

import pytest

from agvnav.logs import check_settings, estimator_from_settings, positioning_settings
from agvnav.world import load_map


def test_a_run_s_settings_are_accepted_unchanged(short_run):
    doc = positioning_settings(short_run.scenario, short_run.series)
    assert check_settings(doc) == doc


@pytest.mark.parametrize(("doc", "match"), [
    ({"initial_pos": [1.0, 2.0, 0.0]}, r"initial_pos: unknown key"),
    ({"mount": [0.3, 0.0, 90.0]}, r"mount\[2\]: 90.0 is beyond 2π .*degrees"),
    ({"initial_pose": [1.0, 2.0, -180.0]}, r"initial_pose\[2\]: .*beyond 2π"),
    ({"wheel_odometry": {"model": "tricycle", "wheelbase_m": 1.0, "slip_k": 1e-4, "steer_std": 0.001}},
     r"wheel_odometry\.steer_std: unknown key"),
    ({"encoders": {"metres_per_count_right": 1e-4, "metres_per_count_left": 1e-4, "track": 0.5}},
     r"encoders\.track"),
    ({"rate_hz": -8.0}, r"rate_hz"),
])
def test_a_bad_key_or_a_degree_angle_is_refused_by_name(doc, match):
    with pytest.raises(ValueError, match=match):
        check_settings(doc, "s.json")
    with pytest.raises(ValueError, match=match):  # the API refuses them as the reader does
        estimator_from_settings(doc, load_map("lab"))


def test_a_full_turn_in_radians_is_still_radians():
    assert check_settings({"mount": [0.0, 0.0, 2 * math.pi], "initial_pose": [0.0, 0.0, -math.pi]})


def test_an_unknown_estimator_parameter_is_a_value_error():
    with pytest.raises(ValueError, match="params"):
        estimator_from_settings({"params": {"gatee": 3.0}}, load_map("lab"))


def test_the_bearing_offset_reaches_the_estimator():
    assert estimator_from_settings({"bearing_offset": 0.0}, load_map("lab")).bearing_offset == 0.0
    assert estimator_from_settings({"bearing_offset": 0.002}, load_map("lab")).bearing_offset == 0.002
