import numpy as np

from agvnav.sim.build import surveyed_truth
from agvnav.world import load_builtin_map
from agvnav.world.scenario import parse_scenario


def test_zero_survey_error_is_the_map_itself():
    world = load_builtin_map("lab")
    assert surveyed_truth(world, 0.0, seed=3) is world


def test_survey_error_moves_reflectors_deterministically_with_the_given_std():
    world = load_builtin_map("lab")
    a = surveyed_truth(world, 0.01, seed=3)
    b = surveyed_truth(world, 0.01, seed=3)
    c = surveyed_truth(world, 0.01, seed=4)
    np.testing.assert_array_equal(a.reflector_xy, b.reflector_xy)
    assert not np.array_equal(a.reflector_xy, c.reflector_xy)
    d = a.reflector_xy - world.reflector_xy
    assert 0.0 < np.abs(d).max() < 0.05  # 5 sigma
    assert a.reflector_ids == world.reflector_ids
    np.testing.assert_array_equal(a.wall_segments, world.wall_segments)


def test_survey_std_is_validated_by_the_scenario_schema():
    import pytest

    text = "name: t\nworld_truth:\n  reflector_survey_std_m: -0.1\n"
    with pytest.raises(ValueError, match="reflector_survey_std_m"):
        parse_scenario(text)
