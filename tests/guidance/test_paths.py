"""Paths: geometry, projection (analytic cases and hypothesis properties), YAML, validation."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.guidance import ArcSegment, LineSegment, Path, load_path, path_from_moves, save_path, seed_test_path


def test_seed_test_path_geometry():
    p = seed_test_path()
    assert p.length == pytest.approx(1.24 * math.pi / 2 + 3.0)
    np.testing.assert_allclose(p.end_pose, [1.24, -1.24 - 3.0, -math.pi / 2], atol=1e-12)
    assert p.is_g1()
    assert p.curvature_at(0.5) == pytest.approx(-1 / 1.24)
    assert p.curvature_at(p.length - 0.1) == 0.0
    # arc midpoint: 45 deg round a right turn centred at (0, -1.24)
    s_mid = 1.24 * math.pi / 4
    np.testing.assert_allclose(p.point_at(s_mid), [1.24 * math.sin(math.pi / 4), -1.24 + 1.24 * math.cos(math.pi / 4)])
    assert p.heading_at(s_mid) == pytest.approx(-math.pi / 4)


def test_projection_analytic_on_arc_and_line():
    p = seed_test_path()
    c = np.array([0.0, -1.24])
    rho, ang = np.array([1.0, 1.5, 1.24]), np.array([80.0, 30.0, 10.0]) * math.pi / 180
    pts = c + rho[:, None] * np.stack([np.sin(ang), np.cos(ang)], axis=-1)
    pr = p.project(pts)
    np.testing.assert_allclose(pr.s, 1.24 * ang, atol=1e-12)
    # right turn: inside the circle is the right side (negative lateral)
    np.testing.assert_allclose(pr.lateral, -(1.24 - rho), atol=1e-12)
    np.testing.assert_allclose(pr.heading, -ang, atol=1e-12)
    np.testing.assert_allclose(pr.curvature, -1 / 1.24)
    # on the final straight (heading -pi/2, x = 1.24): left of it is +x
    q = p.project(np.array([1.34, -3.0]))
    assert q.s == pytest.approx(1.24 * math.pi / 2 + 3.0 - 1.24)
    assert q.lateral == pytest.approx(0.1)
    assert q.segment == 1


def test_projection_beyond_end_uses_end_tangent():
    p = path_from_moves([0, 0, 0], [("line", 2.0)])
    q = p.project(np.array([[3.0, 0.5], [-1.0, -0.25]]))
    np.testing.assert_allclose(q.s, [2.0, 0.0])
    np.testing.assert_allclose(q.lateral, [0.5, -0.25])
    np.testing.assert_allclose(p.extrapolate(np.array([3.0, -1.0])), [[3.0, 0.0], [-1.0, 0.0]])


def test_gap_is_an_error_naming_the_segment():
    a = LineSegment(np.array([0.0, 0.0]), 0.0, 1.0)
    b = LineSegment(np.array([1.0, 0.01]), 0.0, 1.0)
    with pytest.raises(ValueError, match=r"segment 1.*gap"):
        Path([a, b])


def test_corner_is_allowed_but_not_g1():
    a = LineSegment(np.array([0.0, 0.0]), 0.0, 1.0)
    b = LineSegment(np.array([1.0, 0.0]), math.pi / 2, 1.0, direction=-1)
    p = Path([a, b])
    assert not p.is_g1()
    assert p.direction_at(1.5) == -1 and p.direction_at(0.5) == 1
    np.testing.assert_allclose(p.end_pose, [1.0, 1.0, math.pi / 2], atol=1e-12)


@pytest.mark.parametrize(
    "bad, match",
    [
        (lambda: LineSegment(np.zeros(2), 0.0, 0.0), "length"),
        (lambda: ArcSegment(np.zeros(2), 0.0, -1.0, 1.0), "radius"),
        (lambda: ArcSegment(np.zeros(2), 0.0, 1.0, 7.0), "sweep"),
        (lambda: LineSegment(np.zeros(2), 0.0, 1.0, direction=0), "direction"),
        (lambda: path_from_moves([0, 0, 0], [("line", 1.0), ("spiral", 2.0)]), "move 1"),
        (lambda: Path([]), "at least one"),
    ],
)
def test_bad_segments(bad, match):
    with pytest.raises(ValueError, match=match):
        bad()


def test_window_keeps_projection_on_the_right_branch_of_a_self_crossing_path():
    # straight east, 3/4 circle left (centre (4, 1)), then south through (3, 0) across the first straight
    p = path_from_moves([0, 0, 0], [("line", 4.0), ("arc", 1.0, 1.5 * math.pi), ("line", 3.0)])
    crossing = np.array([3.0, 0.02])
    first = p.project(crossing, s_hint=3.0, window=0.5)
    last_s = 4.0 + 1.5 * math.pi + 1.0
    second = p.project(crossing, s_hint=last_s, window=0.5)
    assert first.s == pytest.approx(3.0)
    assert first.lateral == pytest.approx(0.02)
    assert first.heading == pytest.approx(0.0)
    assert second.s == pytest.approx(last_s - 0.02)
    assert second.lateral == pytest.approx(0.0, abs=1e-12)
    assert second.heading == pytest.approx(-math.pi / 2)
    with pytest.raises(ValueError, match="window"):
        p.project(crossing, s_hint=100.0, window=1.0)


def test_yaml_round_trip_with_degrees_labelled(tmp_path):
    p = path_from_moves([1.0, 2.0, 0.3], [("arc", 1.24, -1.2), ("line", 3.0), ("arc", 2.0, 0.7, -1)])
    f = tmp_path / "p.yaml"
    save_path(p, f)
    text = f.read_text()
    assert "heading_deg" in text and "sweep_deg" in text and "reverse" in text
    q = load_path(f)
    s = np.linspace(0, p.length, 37)
    np.testing.assert_allclose(q.point_at(s), p.point_at(s), atol=1e-9)
    np.testing.assert_array_equal(q.direction_at(s), p.direction_at(s))


def test_yaml_corner_round_trip():
    a = LineSegment(np.array([0.0, 0.0]), 0.0, 1.0)
    b = ArcSegment(np.array([1.0, 0.0]), math.pi / 2, 1.0, math.pi / 2)
    p = Path([a, b])
    q = Path.from_dict(p.to_dict())
    np.testing.assert_allclose(q.end_pose, p.end_pose, atol=1e-12)


@pytest.mark.parametrize(
    "data, match",
    [
        ({"start": {"x": 0, "y": 0, "heading_deg": 0}}, "missing key 'segments'"),
        ({"start": {"x": 0, "y": 0, "heading": 0}, "segments": [{"type": "line", "length": 1}]}, r"path\.start"),
        ({"start": {"x": 0, "y": 0, "heading_deg": 0}, "segments": [{"type": "line", "length": -1}]},
         r"segments\[0\].*length"),
        ({"start": {"x": 0, "y": 0, "heading_deg": 0}, "segments": [{"type": "line", "length": 1},
                                                                     {"type": "arc", "radius": 1, "sweep": 90}]},
         r"segments\[1\].*unknown"),
        ({"start": {"x": 0, "y": 0, "heading_deg": 0}, "segments": [{"type": "line", "length": 1},
                                                                     {"type": "line", "length": 1, "x": 1.5, "y": 0}]},
         r"segments\[1\].*gap"),
        ({"start": {"x": 0, "y": 0, "heading_deg": 0}, "segments": [{"type": "line", "length": "a"}]},
         r"segments\[0\]\.length"),
        ({"start": {"x": 0, "y": 0, "heading_deg": 0}, "segments": [{"type": "line", "length": 1,
                                                                      "direction": "sideways"}]},
         r"segments\[0\]\.direction"),
    ],
)
def test_yaml_validation_names_the_problem(data, match):
    with pytest.raises(ValueError, match=match):
        Path.from_dict(data)


# ---------------------------------------------------------------- hypothesis
moves = st.lists(
    st.one_of(
        st.tuples(st.just("line"), st.floats(0.3, 5.0)),
        st.tuples(st.just("arc"), st.floats(0.5, 4.0), st.floats(0.2, 3.0).flatmap(lambda a: st.sampled_from([a, -a]))),
    ),
    min_size=1,
    max_size=5,
)


@given(moves=moves, frac=st.floats(0.0, 1.0), offset=st.floats(-0.2, 0.2), heading=st.floats(-3.1, 3.1))
def test_projection_properties(moves, frac, offset, heading):
    p = path_from_moves([0.5, -1.0, heading], moves)
    s_true = frac * p.length
    n = p.heading_at(s_true)
    pt = p.point_at(s_true) + offset * np.array([-np.sin(n), np.cos(n)])
    g = p.project(pt)
    # optimality: the true foot is a candidate, so the closest is no further
    assert g.distance <= abs(offset) + 1e-9
    np.testing.assert_allclose(p.point_at(g.s), g.point, atol=1e-9)
    assert g.distance == pytest.approx(float(np.hypot(*(pt - g.point))), abs=1e-12)
    # locally (|offset| < radius/2, inside the window) the foot is the true one
    local = p.project(pt, s_hint=s_true, window=0.05)
    joint_near = np.min(np.abs(p.segment_starts - s_true)) < 0.25
    if not joint_near:
        assert local.s == pytest.approx(s_true, abs=1e-9)
        assert local.lateral == pytest.approx(offset, abs=1e-9)
    # vectorised equals per-point
    pts = np.stack([pt, pt + 0.1, pt - 0.3])
    batch = p.project(pts)
    for i in range(3):
        one = p.project(pts[i])
        assert batch.s[i] == pytest.approx(float(one.s), abs=1e-12)
        assert batch.lateral[i] == pytest.approx(float(one.lateral), abs=1e-12)


@given(moves=moves, fracs=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=8))
def test_points_on_the_path_project_onto_themselves(moves, fracs):
    p = path_from_moves([0.0, 0.0, 0.0], moves)
    s = np.array(fracs) * p.length
    pts = p.point_at(s)
    pr = p.project(pts)
    np.testing.assert_allclose(pr.distance, 0.0, atol=1e-9)
    np.testing.assert_allclose(pr.lateral, 0.0, atol=1e-9)


def test_load_path_refuses_duplicate_keys(tmp_path):
    import pytest

    from agvnav.guidance.paths import load_path

    f = tmp_path / "p.yaml"
    f.write_text("path:\n  start: [0, 0, 0]\n  start: [1, 0, 0]\n  segments: []\n")
    with pytest.raises(ValueError, match="duplicate key 'start'"):
        load_path(f)
