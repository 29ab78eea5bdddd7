"""Seed 004 eqs 3-8: dead reckoning and wall-landmark calibration recover known poses."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.actuators import unicycle_to_wheels
from agvnav.positioning.wall_landmarks import (
    WallLandmarkLocalizer,
    dead_reckoning_step,
    distance_from_wall,
    heading_from_side_pair,
    wall_line,
)
from agvnav.sensors import seed_004_layout

LAYOUT = seed_004_layout()
SPACING = 0.30
RIGHT_WALL = np.array([[-3.0, -0.55], [6.0, -0.55]])  # along +x, right of a robot at y = 0
LEFT_WALL = np.array([[6.0, 0.5], [-3.0, 0.5]])  # drawn the other way on purpose
FRONT_WALL = np.array([[1.0, -2.0], [1.0, 2.0]])


def _ranges(pose, wall, names):
    out = []
    for n in names:
        e = LAYOUT[n].echo(pose, wall[None])
        assert e.valid, n
        out.append(float(e.range))
    return out


def test_heading_formula_signs_match_seed_eqs_6_7():
    # right wall, front sensor farther: positive (CCW) relative heading, eq 7
    assert heading_from_side_pair(0.35, 0.30, 0.30, "right", beam="ray") == pytest.approx(math.atan(0.05 / 0.30))
    # eq 6 form for the opposite case: -arctan((US2 - US1)/dist)
    assert heading_from_side_pair(0.30, 0.35, 0.30, "right", beam="ray") == pytest.approx(-math.atan(0.05 / 0.30))
    assert heading_from_side_pair(0.35, 0.30, 0.30, "left", beam="ray") == pytest.approx(-math.atan(0.05 / 0.30))
    assert heading_from_side_pair(0.35, 0.30, 0.30, "left") == pytest.approx(-math.asin(0.05 / 0.30))


def test_ray_model_is_exact_for_ranges_along_the_axis():
    """The seed's arctan form recovers theta from axis-aligned ranges D_i / cos(theta)."""
    theta, d0, x = 0.2, 0.4, np.array([0.15, -0.15])
    ranges = (d0 + x * math.sin(theta)) / math.cos(theta)
    assert heading_from_side_pair(*ranges, 0.30, "right", beam="ray") == pytest.approx(theta, abs=1e-12)
    assert heading_from_side_pair(*ranges, 0.30, "right", beam="cone") != pytest.approx(theta, abs=1e-3)
    n = np.array([0.0, 1.0])  # wall y = -0.2 - d0 + ..., normal towards the robot
    mounts = np.array([[0.15, -0.2, -math.pi / 2], [-0.15, -0.2, -math.pi / 2]])
    dist = distance_from_wall(ranges, mounts, theta, n, beam="ray")
    assert dist == pytest.approx(np.full(2, d0 + 0.2 * math.cos(theta)), abs=1e-12)
    with pytest.raises(ValueError, match="side"):
        heading_from_side_pair(0.3, 0.3, 0.3, "up")


@given(
    st.floats(-0.12, 0.12),  # true heading offset (rad), inside the beam half-angle
    st.floats(-0.1, 0.1),  # true lateral position (m)
    st.floats(-0.05, 0.05),  # heading error of the estimate (rad)
    st.floats(-0.08, 0.08),  # lateral error of the estimate (m)
    st.sampled_from(["right", "left"]),
)
def test_side_pair_recovers_heading_and_lateral_offset(theta, y, dtheta, dy, side):
    truth = np.array([0.7, y, theta])
    wall = RIGHT_WALL if side == "right" else LEFT_WALL
    names = [f"{side}_front", f"{side}_rear"]
    us1, us2 = _ranges(truth, wall, names)
    loc = WallLandmarkLocalizer(pose=truth + [0.03, dy, dtheta])
    measured = loc.calibrate_heading(1.0, us1, us2, SPACING, side, wall)
    assert measured == pytest.approx(theta, abs=1e-12)
    assert loc.pose[2] == pytest.approx(theta, abs=1e-12)
    mounts = np.array([LAYOUT[n].mount for n in names])
    loc.calibrate_offset(1.0, [us1, us2], mounts, wall, kind="side_offset")
    assert loc.pose[1] == pytest.approx(y, abs=1e-12)
    assert loc.pose[0] == pytest.approx(0.73)  # along-wall component untouched
    assert [c.kind for c in loc.history] == ["heading", "side_offset"]


@given(st.floats(-0.1, 0.1), st.floats(0.0, 0.3), st.floats(-0.1, 0.1))
def test_front_wall_recovers_along_track_position_eq_8(theta, x, dx):
    truth = np.array([x, 0.05, theta])
    (r,) = _ranges(truth, FRONT_WALL, ["front"])
    loc = WallLandmarkLocalizer(pose=truth + [dx, 0.0, 0.0])
    loc.calibrate_offset(2.0, [r], [LAYOUT["front"].mount], FRONT_WALL)
    assert loc.pose[0] == pytest.approx(x, abs=1e-12)
    assert loc.pose[1] == pytest.approx(0.05, abs=1e-12)


def test_eq_8_literal_form():
    # theta = 0 and the sensor at base_link: x = x_lan - US
    n, c = wall_line(FRONT_WALL, [0.0, 0.0])
    d = distance_from_wall([0.4], [[0.0, 0.0, 0.0]], 0.0, n)
    assert n @ np.array([1.0, 0.0]) == pytest.approx(-1.0)
    x = -(c + d[0])  # n . p = c + d with n = (-1, 0)
    assert x == pytest.approx(1.0 - 0.4)


def test_gain_blends_correction():
    loc = WallLandmarkLocalizer(pose=[0.0, 0.0, 0.1], gain=0.25)
    loc.calibrate_heading(0.0, 0.3, 0.3, SPACING, "right", RIGHT_WALL)
    assert loc.pose[2] == pytest.approx(0.075)
    with pytest.raises(ValueError, match="gain"):
        WallLandmarkLocalizer(gain=0.0)


def test_dead_reckoning_eqs_3_5_match_exact_arc_for_small_steps():
    r, track, v, omega, T = 0.05, 0.33, 0.15, 0.1, 5.0
    w = unicycle_to_wheels(v, omega, r, track)
    pose = np.zeros(3)
    n = 20000
    for _ in range(n):
        pose = dead_reckoning_step(pose, w[0], w[1], r, track, T / n)
    exact = [v / omega * math.sin(omega * T), v / omega * (1 - math.cos(omega * T)), omega * T]
    assert pose == pytest.approx(exact, abs=1e-4)
    # one Euler step is exactly eqs 3-5
    one = dead_reckoning_step([1.0, 2.0, 0.3], 3.0, 2.0, r, track, 0.1)
    assert one == pytest.approx([1 + r / 2 * 5 * math.cos(0.3) * 0.1, 2 + r / 2 * 5 * math.sin(0.3) * 0.1, 0.3 + r / track * 0.1])


def test_localizer_predict_and_zero_length_wall():
    loc = WallLandmarkLocalizer()
    loc.predict(0.1, 0.5, 0.2)
    assert loc.pose == pytest.approx([0.5, 0.0, 0.2]) and loc.status == "dead_reckoning"
    with pytest.raises(ValueError, match="zero length"):
        loc.calibrate_offset(0.2, [0.3], [[0.0, 0.0, 0.0]], [[1.0, 1.0], [1.0, 1.0]])
