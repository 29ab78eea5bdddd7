"""Fields generated from the stopping distance and a person's approach (ISO 13855 S = K T + C), selected by
speed and direction (issue 18)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from agvnav.reactive import (
    FieldConfig,
    approach_clearance,
    approach_field,
    approach_reach,
    field_rectangle,
    generate_fields,
    intrusions,
    stopping_distance,
    swept_strip,
)

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
                          warning_time=1.0, bands=3, approach_speed=0.0)
    lengths = [s.protective_length for s in cfg.sets]
    expected = [v * 0.25 + v * v / 1.2 + 0.2 for v in (0.4, 0.8, 1.2)]
    assert lengths == pytest.approx(expected, abs=1e-12)
    top = cfg.sets[-1]
    assert top.warning_length == pytest.approx(expected[-1] + 1.2, abs=1e-12)
    # the protective rectangle starts at the body front and is 0.1 m wider each side
    assert top.protective[:, 0].min() == pytest.approx(0.5) and top.protective[:, 0].max() == pytest.approx(
        0.5 + expected[-1])
    assert top.protective[:, 1].min() == pytest.approx(-0.4) and top.protective[:, 1].max() == pytest.approx(0.4)


def test_the_protective_field_contains_the_reach_set_of_a_person_at_K():
    """Known geometry: 1 m/s, t_r 0.3 s, a 0.5 m/s^2, C 0.3 m, body front 0.5 m, half-width 0.3 m + 0.1 m.

    The swept strip H = [0.5, 2.1] x [-0.4, 0.4]; T = 0.3 + 2 = 2.3 s, K T = 1.6 x 2.3 = 3.68 m. The field is
    H + disc(3.68) cut at the front face: reaches x = 5.78 ahead and |y| = 4.08 sideways."""
    cfg = generate_fields(BODY, 1.0, 0.5, 0.3, margin=0.3, lateral_margin=0.1, bands=2)  # K defaults to 1.6
    top = cfg.sets[-1]
    assert approach_reach(1.0, 0.3, 0.5) == pytest.approx(3.68, abs=1e-12)
    assert top.reach == pytest.approx(3.68) and top.protective_length == pytest.approx(1.6 + 3.68)
    field = Polygon(top.protective)
    assert field.bounds == pytest.approx((0.5, -4.08, 5.78, 4.08), abs=1e-12)
    # every point a person at K could walk from onto H within T (x >= the front face) is in the field
    rng = np.random.default_rng(3)
    p = rng.uniform([0.5, -4.2], [6.0, 4.2], size=(4000, 2))
    reach = shapely.distance(swept_strip(BODY, 1.6, 0.1), shapely.points(p[:, 0], p[:, 1])) <= 3.68
    assert reach.sum() > 1500 and np.all(intrusions(p[reach], top.protective))
    # ... and little else: the circumscribed arcs add at most 3.68 (1/cos(pi/32) - 1) = 1.8 cm
    outside = approach_clearance(p[~reach], BODY, 1.0, 0.3, 0.5, 0.3, 0.1)
    assert np.all(outside[intrusions(p[~reach], top.protective)] < 0.018)
    exact = 1.6 * 0.8 + 2 * 3.68 * (1.6 + 0.8 / 2) + 0.5 * np.pi * 3.68**2  # strip, sides and ahead, two quarters
    assert exact < field.area < exact * 1.003
    # sideways as well as ahead: a person 4 m beside the front is in it, one 4.2 m beside is not
    assert list(intrusions([[0.6, 4.0], [0.6, -4.2], [5.7, 0.0], [5.8, 0.0]], top.protective)) == [
        True, False, True, False]


def test_the_old_fields_miss_a_person_stepping_in_from_the_side():
    """K = 0 gives the stopping-distance rectangle, which a person 3 m beside the swept strip is outside of
    although it reaches the strip in 3 / 1.6 = 1.9 s < T = 2.3 s."""
    old = generate_fields(BODY, 1.0, 0.5, 0.3, margin=0.3, bands=1, approach_speed=0.0).sets[0]
    new = generate_fields(BODY, 1.0, 0.5, 0.3, margin=0.3, bands=1).sets[0]
    side = np.array([[1.5, 3.4]])
    assert approach_clearance(side, BODY, 1.0, 0.3, 0.5, 0.3, 0.1)[0] == pytest.approx(3.0 - 3.68)
    assert not intrusions(side, old.protective)[0] and intrusions(side, new.protective)[0]
    np.testing.assert_array_equal(old.protective, field_rectangle(BODY, 1.6, 0.1))
    with pytest.raises(ValueError, match="approach_speed"):
        generate_fields(BODY, 1.0, 0.5, 0.3, approach_speed=-1.0)
    with pytest.raises(ValueError, match="reach"):
        approach_field(BODY, 1.0, 0.1, -0.5)


def test_warning_field_is_the_protective_one_swept_ahead_and_the_creep_set_is_the_rectangle():
    cfg = generate_fields(BODY, 1.0, 0.5, 0.3, margin=0.3, warning_time=1.5, bands=1, creep_speed=0.3)
    top = cfg.sets[0]
    assert Polygon(top.warning).bounds == pytest.approx((0.5, -4.08, 5.78 + 1.5, 4.08), abs=1e-12)
    assert Polygon(top.warning).contains(Polygon(top.protective).buffer(-1e-9))
    assert cfg.select(0.3, 1, creep=True) is cfg.creep and cfg.select(0.3, 1) is top
    assert cfg.select(0.5, 1, creep=True) is top  # faster than the creep set: the band's
    creep_len = 0.3 * 0.3 + 0.09 / 1.0 + 0.3
    np.testing.assert_allclose(cfg.creep.protective, field_rectangle(BODY, creep_len, 0.1), atol=1e-12)



def test_a_reversing_detour_never_gets_the_forward_creep_set():
    """The creep set lies ahead of the body: reversing selects the reverse creep set, or the reverse bands."""
    cfg = generate_fields(BODY, 1.0, 0.5, 0.3, margin=0.3, bands=1, reverse=True, creep_speed=0.3)
    assert cfg.select(0.3, 1, creep=True) is cfg.creep and cfg.creep.direction == 1
    back = cfg.select(-0.3, -1, creep=True)
    assert back is cfg.creep_reverse and back.direction == -1
    assert cfg.select(-0.3, creep=True) is back  # direction from the sign of v
    np.testing.assert_allclose(back.protective, field_rectangle(BODY, 0.3 * 0.3 + 0.09 + 0.3, 0.1, -1), atol=1e-12)
    assert Polygon(back.protective).bounds[2] < 0.0  # wholly behind base_link
    # a configuration without a reverse creep set: the reverse band, not the forward creep set
    fwd_creep = generate_fields(BODY, 1.0, 0.5, 0.3, margin=0.3, bands=1, creep_speed=0.3).creep
    no_rev = FieldConfig(cfg.sets, fwd_creep)
    assert no_rev.select(-0.3, -1, creep=True) is next(s for s in cfg.sets if s.direction == -1)
    with pytest.raises(ValueError, match="direction"):
        cfg.select(0.3, 0, creep=True)
    with pytest.raises(ValueError, match="creep set must be a forward"):
        FieldConfig(cfg.sets, back)

def test_reverse_fields_mirror_the_forward_ones():
    cfg = generate_fields(BODY, 1.0, 0.5, 0.3, margin=0.3, bands=1, reverse=True)
    fwd, rev = cfg.sets
    np.testing.assert_allclose(np.sort(rev.protective * [-1, 1], axis=0), np.sort(fwd.protective, axis=0), atol=1e-12)
    assert Polygon(rev.protective).is_valid and Polygon(rev.protective).bounds[2] == pytest.approx(-0.5)


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
