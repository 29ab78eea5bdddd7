"""Ultrasonic cone-beam sensor against hand-computed geometry (seed 004 sensors)."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.sensors import UltrasonicArray, UltrasonicSensor, check_wall_segments, cone_echo, seed_004_layout

DEG = math.pi / 180.0


def _wall_through(point, normal_angle, half_length=2.0):
    """Segment through ``point`` whose normal makes ``normal_angle`` with the x-axis."""
    p = np.asarray(point, float)
    u = np.array([-math.sin(normal_angle), math.cos(normal_angle)])
    return np.array([[p - half_length * u, p + half_length * u]])


def test_perpendicular_wall():
    e = cone_echo([0.0, 0.0, 0.0], _wall_through([0.5, 0.0], 0.0))
    assert e.range == pytest.approx(0.5) and e.incidence == pytest.approx(0.0) and e.valid and e.segment == 0


def test_wall_at_angle_foot_inside_cone():
    # normal 10 deg off the axis: the perpendicular foot is inside the 15 deg cone
    e = cone_echo([0.0, 0.0, 0.0], _wall_through([0.5, 0.0], 10 * DEG))
    assert e.range == pytest.approx(0.5 * math.cos(10 * DEG), rel=1e-12)
    assert e.incidence == pytest.approx(0.0, abs=1e-7)


def test_wall_at_angle_foot_outside_cone():
    # normal 25 deg off: nearest point is on the 15 deg cone edge, incidence 10 deg
    e = cone_echo([0.0, 0.0, 0.0], _wall_through([0.5, 0.0], 25 * DEG))
    assert e.range == pytest.approx(0.5 * math.cos(25 * DEG) / math.cos(10 * DEG), rel=1e-12)
    assert e.incidence == pytest.approx(10 * DEG, rel=1e-9)


def test_beyond_incidence_limit_is_a_miss():
    # normal 40 deg off: edge ray meets the wall 25 deg from its normal > 20 deg limit
    e = cone_echo([0.0, 0.0, 0.0], _wall_through([0.5, 0.0], 40 * DEG))
    assert not e.valid and e.segment == -1 and np.isinf(e.range)
    e = cone_echo([0.0, 0.0, 0.0], _wall_through([0.5, 0.0], 34 * DEG))  # 19 deg: still echoes
    assert e.valid


def test_steep_wall_is_silent_and_farther_wall_echoes():
    walls = np.concatenate([_wall_through([0.3, 0.0], 60 * DEG, 0.2), _wall_through([1.2, 0.0], 0.0)])
    e = cone_echo([0.0, 0.0, 0.0], walls)
    assert e.segment == 1 and e.range == pytest.approx(1.2)


def test_out_of_range_and_blind_zone():
    far = cone_echo([0.0, 0.0, 0.0], _wall_through([4.5, 0.0], 0.0))
    assert not far.valid and far.range == pytest.approx(4.5)
    near = cone_echo([0.0, 0.0, 0.0], _wall_through([0.01, 0.0], 0.0))
    assert not near.valid


def test_segment_partly_inside_cone_and_outside_cone():
    seg = np.array([[[1.0, 0.2], [1.0, 1.0]]])
    e = cone_echo([0.0, 0.0, 0.0], seg, max_incidence=math.pi / 2)
    assert e.range == pytest.approx(math.hypot(1.0, 0.2)) and e.incidence == pytest.approx(math.atan(0.2))
    side = np.array([[[1.0, 0.3], [1.0, 1.0]]])  # tan(15 deg) = 0.268 < 0.3: outside the cone
    assert cone_echo([0.0, 0.0, 0.0], side).segment == -1
    behind = cone_echo([0.0, 0.0, math.pi], _wall_through([0.5, 0.0], 0.0))
    assert behind.segment == -1


def test_batch_and_zero_length_flagged():
    walls = np.concatenate([np.array([[[0.4, 0.0], [0.4, 0.0]]]), _wall_through([0.8, 0.0], 0.0)])
    poses = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.0, math.pi]]).reshape(3, 1, 3)
    e = cone_echo(poses, walls)
    assert e.range.shape == (3, 1)
    assert e.range[:2, 0] == pytest.approx([0.8, 0.7]) and not e.valid[2, 0]
    with pytest.raises(ValueError, match="segment 0 has zero length"):
        check_wall_segments(walls)


def _sampled_range(pose, seg, half_angle, n=40001):
    """Brute force: dense points along the segment, kept if inside the cone."""
    pts = seg[0] + np.linspace(0.0, 1.0, n)[:, None] * (seg[1] - seg[0]) - pose[:2]
    bearing = np.arctan2(pts[:, 1], pts[:, 0]) - pose[2]
    inside = np.abs((bearing + np.pi) % (2 * np.pi) - np.pi) <= half_angle
    return np.min(np.hypot(pts[inside, 0], pts[inside, 1])) if inside.any() else np.inf


def _distance_to_segment(seg):
    d = seg[1] - seg[0]
    t = np.clip(-np.dot(seg[0], d) / np.dot(d, d), 0.0, 1.0)
    return np.linalg.norm(seg[0] + t * d)


coord = st.floats(-2.0, 2.0)


@given(coord, coord, coord, coord, st.floats(-math.pi, math.pi), st.floats(5 * DEG, 40 * DEG))
def test_exact_cone_range_matches_dense_rays(x0, y0, x1, y1, heading, half_angle):
    seg = np.array([[x0, y0], [x1, y1]])
    if np.linalg.norm(seg[1] - seg[0]) < 1e-3 or _distance_to_segment(seg) < 0.05:
        return  # degenerate, or touching the transducer
    pose = np.array([0.0, 0.0, heading])
    exact = cone_echo(pose, seg[None], half_angle, max_incidence=math.pi / 2, min_range=0.0, max_range=10.0)
    sampled = _sampled_range(pose, seg, half_angle)
    spacing = np.linalg.norm(seg[1] - seg[0]) / 40000
    if np.isinf(sampled):
        # only a sliver shorter than the sample spacing can hide at the cone edge
        assert exact.segment == -1 or np.isfinite(_sampled_range(pose, seg, half_angle + 1e-3))
        return
    assert exact.range <= sampled + 1e-9
    assert exact.range >= sampled - spacing - 1e-9


def test_sensor_noise_statistics_and_determinism():
    s = UltrasonicSensor(noise_std=0.004)
    poses = np.zeros((4000, 3))
    wall = _wall_through([0.5, 0.0], 0.0)
    r1, v1, _ = s.measure(poses, wall, np.random.default_rng(7))
    r2, _, _ = s.measure(poses, wall, np.random.default_rng(7))
    assert np.array_equal(r1, r2) and v1.all()
    assert np.mean(r1) == pytest.approx(0.5, abs=3 * 0.004 / math.sqrt(4000))
    assert np.std(r1) == pytest.approx(0.004, rel=0.06)
    assert s.noise_std_at(2.6) == pytest.approx(0.004 + 0.01 * 2.0)
    dropped = UltrasonicSensor(p_miss=0.3).measure(poses, wall, np.random.default_rng(1))[1]
    assert np.mean(~dropped) == pytest.approx(0.3, abs=0.03)


def test_ping_times_follow_rate_and_phase():
    s = UltrasonicSensor(rate_hz=20.0, phase=0.01)
    assert s.ping_times(0.0, 0.2) == pytest.approx([0.01, 0.06, 0.11, 0.16])
    assert s.ping_times(0.06, 0.11) == pytest.approx([0.11])  # window (t0, t1]
    tiles = np.concatenate([s.ping_times(0.05 * k, 0.05 * (k + 1)) for k in range(40)])
    assert tiles == pytest.approx(s.ping_times(0.0, 2.0)) and tiles.size == 40


def test_seed_layout_reads_side_walls_and_scan():
    layout = seed_004_layout()
    walls = np.array([[[-5.0, -0.5], [5.0, -0.5]], [[-5.0, 0.6], [5.0, 0.6]], [[0.8, -2.0], [0.8, 2.0]]])
    clean = {n: float(layout[n].echo(np.zeros(3), walls).range) for n in layout.names}
    assert clean["right_front"] == pytest.approx(0.3) and clean["right_rear"] == pytest.approx(0.3)
    assert clean["left_front"] == pytest.approx(0.4) and clean["front"] == pytest.approx(0.575)
    readings = layout.measure([0.0, 0.0, 0.0], walls, np.random.default_rng(3))
    assert readings["right_front"] == pytest.approx(0.3, abs=0.015)
    # moving along +x at 0.1 m/s: the front sensor sees the end wall approaching
    def pose_at(t):
        return np.stack([0.1 * t, 0 * t, 0 * t], -1)

    scan = layout["front"].scan(walls, pose_at, 0.0, 1.0, np.random.default_rng(0))
    assert scan.t.size == 20 and np.all(np.diff(scan.range) < 0.02)


def test_mount_inside_body_is_refused():
    with pytest.raises(ValueError, match=r"'bad' mount .* inside the vehicle body"):
        UltrasonicArray({"bad": UltrasonicSensor(mount=(0.1, 0.0, 0.0))}, 0.45, 0.40)
    with pytest.raises(ValueError, match="points into the vehicle body"):
        UltrasonicArray({"inward": UltrasonicSensor(mount=(0.225, 0.0, math.pi))}, 0.45, 0.40)
    with pytest.raises(ValueError, match="half_angle"):
        UltrasonicSensor(half_angle=2.0)


def test_array_echo_batches_all_sensors():
    layout = seed_004_layout()
    walls = np.array([[[-5.0, -0.5], [5.0, -0.5]], [[0.8, -2.0], [0.8, 2.0]]])
    poses = np.array([[0.0, 0.0, 0.05], [0.1, 0.02, -0.03]])
    batch = layout.echo(poses, walls)
    assert batch.range.shape == (2, 5)
    for i, name in enumerate(layout.names):
        single = layout[name].echo(poses, walls)
        assert np.array_equal(batch.range[:, i], single.range) and np.array_equal(batch.segment[:, i], single.segment)
