"""Fields generated from the stopping distance, selected by speed and direction (issue 18)."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.reactive import field_rectangle, generate_fields, intrusions, stopping_distance

BODY = np.array([[0.5, -0.3], [0.5, 0.3], [-0.5, 0.3], [-0.5, -0.3]])


def test_stopping_distance_known_values():
    # 1 m/s, 0.3 s reaction, 0.5 m/s^2: 0.3 + 1.0 + margin 0.2 = 1.5 m
    assert float(stopping_distance(1.0, 0.3, 0.5, 0.2)) == pytest.approx(1.5, abs=1e-12)
    # 2 m/s, 0.5 s, 1 m/s^2, no margin: 1 + 2 = 3 m; the sign of v is ignored
    assert stopping_distance([2.0, -2.0, 0.0], 0.5, 1.0) == pytest.approx([3.0, 3.0, 0.0], abs=1e-12)
    with pytest.raises(ValueError, match="decel"):
        stopping_distance(1.0, 0.3, 0.0)


def test_generated_sets_are_the_stopping_distance_of_each_band_top_speed():
    cfg = generate_fields(BODY, v_max=1.2, decel=0.6, reaction_time=0.25, margin=0.2, lateral_margin=0.1,
                          warning_time=1.0, bands=3)
    lengths = [s.protective_length for s in cfg.sets]
    expected = [v * 0.25 + v * v / 1.2 + 0.2 for v in (0.4, 0.8, 1.2)]
    assert lengths == pytest.approx(expected, abs=1e-12)
    top = cfg.sets[-1]
    assert top.warning_length == pytest.approx(expected[-1] + 1.2, abs=1e-12)
    # the protective rectangle starts at the body front and is 0.1 m wider each side
    assert top.protective[:, 0].min() == pytest.approx(0.5) and top.protective[:, 0].max() == pytest.approx(
        0.5 + expected[-1])
    assert top.protective[:, 1].min() == pytest.approx(-0.4) and top.protective[:, 1].max() == pytest.approx(0.4)


def test_approach_speed_lengthens_the_protective_field_by_its_walk_during_the_stop():
    still = generate_fields(BODY, 1.0, 0.5, 0.3, margin=0.3, bands=2)
    walking = generate_fields(BODY, 1.0, 0.5, 0.3, margin=0.3, bands=2, approach_speed=1.6)
    # top band: 1.6 m, plus 1.6 m/s over 0.3 s + 1.0 / 0.5 s = 3.68 m
    assert walking.sets[-1].protective_length == pytest.approx(1.6 + 1.6 * 2.3, abs=1e-12)
    assert walking.sets[0].protective_length - still.sets[0].protective_length == pytest.approx(1.6 * 1.3)
    with pytest.raises(ValueError, match="approach_speed"):
        generate_fields(BODY, 1.0, 0.5, 0.3, approach_speed=-1.0)


def test_selection_by_speed_and_direction():
    cfg = generate_fields(BODY, 1.0, 0.5, 0.3, bands=4, reverse=True)
    assert cfg.select(0.0).v_max == pytest.approx(0.25) and cfg.select(0.0).direction == 1
    assert cfg.select(0.3).v_max == pytest.approx(0.5)
    assert cfg.select(1.0).v_max == pytest.approx(1.0)
    assert cfg.select(1.5).v_max == pytest.approx(1.0)  # beyond every band: the fastest
    rev = cfg.select(-0.6)
    assert rev.direction == -1 and rev.v_max == pytest.approx(0.75)
    assert rev.protective[:, 0].max() == pytest.approx(-0.5)  # behind the body


def test_fixed_fields_and_intrusions():
    cfg = generate_fields(BODY, 1.0, 0.5, 0.3, protective_length=1.0, warning_length=2.0)
    fs = cfg.select(0.7)
    pts = np.array([[1.2, 0.0], [2.0, 0.2], [3.0, 0.0], [1.2, 0.5], [np.nan, np.nan]])
    assert list(intrusions(pts, fs.protective)) == [True, False, False, False, False]
    assert list(intrusions(pts, fs.warning)) == [True, True, False, False, False]
    with pytest.raises(ValueError, match="direction"):
        field_rectangle(BODY, 1.0, 0.1, 0)
