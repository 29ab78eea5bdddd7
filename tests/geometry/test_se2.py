import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.geometry import (
    angle_diff,
    bearing_to,
    between,
    circumcentre,
    compose,
    intersect_lines,
    inverse,
    lateral_position_error,
    to_body,
    transform_points,
    wrap_angle,
)

coord = st.floats(-50, 50)
ang = st.floats(-10, 10)
pose_st = st.tuples(coord, coord, ang).map(np.array)


def test_wrap_angle_range_and_values():
    a = np.linspace(-20, 20, 1001)
    w = wrap_angle(a)
    assert np.all(w >= -np.pi) and np.all(w < np.pi)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    assert float(wrap_angle(np.pi)) == -np.pi


def test_angle_diff_short_way():
    assert np.isclose(angle_diff(np.pi - 0.1, -np.pi + 0.1), -0.2)


@given(pose_st, pose_st)
def test_compose_inverse_roundtrip(a, b):
    np.testing.assert_allclose(compose(a, inverse(a))[:2], 0.0, atol=1e-9)
    back = compose(a, between(a, b))
    np.testing.assert_allclose(back[:2], b[:2], atol=1e-9)
    assert abs(angle_diff(back[2], b[2])) < 1e-9


@given(pose_st, st.tuples(coord, coord).map(np.array))
def test_points_roundtrip_and_bearing(pose, point):
    body = to_body(pose, point)
    np.testing.assert_allclose(transform_points(pose, body), point, atol=1e-9)
    if np.hypot(*body) > 1e-6:
        assert abs(angle_diff(bearing_to(pose, point), np.arctan2(body[1], body[0]))) < 1e-9


def test_batch_shapes_broadcast():
    poses = np.zeros((4, 5, 3))
    pts = np.ones((4, 5, 2))
    assert transform_points(poses, pts).shape == (4, 5, 2)
    assert compose(poses, np.array([1.0, 0.0, 0.0])).shape == (4, 5, 3)


def test_intersect_lines_known_and_parallel():
    p, ok = intersect_lines([0, 0], 0.0, [1, -1], np.pi / 2)
    assert ok and np.allclose(p, [1, 0])
    p, ok = intersect_lines([0, 0], 0.0, [0, 1], 0.0)
    assert not ok and np.all(np.isnan(p))


def test_circumcentre_known_and_collinear():
    c, ok = circumcentre([1, 0], [0, 1], [-1, 0])
    assert ok and np.allclose(c, [0, 0])
    _, ok = circumcentre([0, 0], [1, 1], [2, 2])
    assert not ok


def test_lateral_position_error_sign_and_rotation():
    true = np.array([[1.0, 2.0, math.pi / 2]])
    est = np.array([[0.99, 2.5, 0.0]])  # 1 cm to the left of a vehicle heading +y is -x
    assert lateral_position_error(true, est)[0] == pytest.approx(0.01)


def test_lateral_position_error_is_body_y_of_the_estimate():
    rng = np.random.default_rng(3)
    true = rng.uniform(-5, 5, (50, 3))
    est = rng.uniform(-5, 5, (50, 3))
    np.testing.assert_allclose(lateral_position_error(true, est), to_body(true, est[:, :2])[:, 1], atol=1e-12)
