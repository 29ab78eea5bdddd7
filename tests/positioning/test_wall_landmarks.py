"""Seed 004 eqs 3-8: dead reckoning and wall-landmark calibration recover known poses; the localizer as an estimator."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.actuators import unicycle_to_wheels
from agvnav.odometry import OdometryNoise, motion_covariance, pose_jacobian
from agvnav.positioning.landmark_params import LandmarkParams, check_route_passes_landmarks
from agvnav.positioning.wall_landmarks import WallLandmarkLocalizer
from agvnav.positioning.wall_ranging import dead_reckoning_step, distance_from_wall, heading_from_side_pair, wall_line
from agvnav.sensors import seed_004_layout

LAYOUT = seed_004_layout()
SPACING = 0.30
RIGHT_WALL = np.array([[-3.0, -0.55], [6.0, -0.55]])  # along +x, right of a robot at y = 0
LEFT_WALL = np.array([[6.0, 0.5], [-3.0, 0.5]])  # drawn the other way on purpose
FRONT_WALL = np.array([[1.0, -2.0], [1.0, 2.0]])
FULL = LandmarkParams(calibration_gain=1.0)  # replace, as the seed does


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
    loc = WallLandmarkLocalizer(params=FULL, pose=truth + [0.03, dy, dtheta])
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
    loc = WallLandmarkLocalizer(params=FULL, pose=truth + [dx, 0.0, 0.0])
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
    loc = WallLandmarkLocalizer(params=LandmarkParams(calibration_gain=0.25), pose=[0.0, 0.0, 0.1])
    loc.calibrate_heading(0.0, 0.3, 0.3, SPACING, "right", RIGHT_WALL)
    assert loc.pose[2] == pytest.approx(0.075)
    with pytest.raises(ValueError, match="gain"):
        LandmarkParams(calibration_gain=0.0)


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
    expected = [1 + r / 2 * 5 * math.cos(0.3) * 0.1, 2 + r / 2 * 5 * math.sin(0.3) * 0.1, 0.3 + r / track * 0.1]
    assert one == pytest.approx(expected)


def test_localizer_predict_and_zero_length_wall():
    loc = WallLandmarkLocalizer()
    loc.predict(0.1, 0.5, 0.2)
    assert loc.pose == pytest.approx([0.5, 0.0, 0.2]) and loc.status == "dead_reckoning"
    with pytest.raises(ValueError, match="zero length"):
        loc.calibrate_offset(0.2, [0.3], [[0.0, 0.0, 0.0]], [[1.0, 1.0], [1.0, 1.0]])


# ---------------------------------------------------------------- the localizer as a streaming estimator
def _readings(truth, walls, names=None):
    """Exact (noise-free) ranges of every sensor at ``truth``; nan where nothing echoes."""
    e = LAYOUT.echo(truth, walls)
    ranges = dict(zip(LAYOUT.names, np.where(e.valid, e.range, np.nan).tolist(), strict=True))
    return {n: ranges[n] for n in (names or LAYOUT.names)}


def test_update_ranges_side_pair_recovers_heading_and_offset_from_the_readings():
    """Eqs 6-7 and the lateral offset through update_ranges: both side readings of one instant."""
    walls = np.array([RIGHT_WALL, FRONT_WALL + [4.0, 0.0]])  # the front wall is out of range
    truth = np.array([0.7, 0.02, 0.04])
    loc = WallLandmarkLocalizer(walls, LAYOUT, FULL, pose=truth + [0.03, -0.05, -0.03], wall_ids=["right", "front"])
    assert loc.update_ranges(0.0, _readings(truth, walls)) == 2
    assert loc.pose == pytest.approx([0.73, 0.02, 0.04], abs=1e-12)  # along-wall x kept from dead reckoning
    assert [(c.kind, c.side, c.wall, c.wall_id) for c in loc.history] == [
        ("heading", "right", 0, "right"), ("side_offset", "right", 0, "right")]
    assert loc.status == "tracking" and loc.t == 0.0


def test_update_ranges_front_wall_eq_8():
    walls = np.array([FRONT_WALL])
    truth = np.array([0.5, 0.1, 0.05])
    loc = WallLandmarkLocalizer(walls, LAYOUT, FULL, pose=truth + [0.12, 0.0, 0.0])
    assert loc.update_ranges(1.0, _readings(truth, walls, ["front"])) == 1
    assert loc.pose == pytest.approx(truth, abs=1e-12)
    assert loc.history[-1].kind == "front_offset" and loc.history[-1].side == "front"


def test_pairing_uses_the_partner_latest_reading_within_pair_max_age():
    walls = np.array([RIGHT_WALL])
    truth = np.array([0.7, 0.0, 0.02])
    r = _readings(truth, walls)
    loc = WallLandmarkLocalizer(walls, LAYOUT, FULL, pose=truth + [0.0, 0.0, 0.02])
    assert loc.update_ranges(0.0, {"right_front": r["right_front"]}) == 0  # partner never read
    assert loc.update_ranges(0.0125, {"right_rear": r["right_rear"]}) == 2  # staggered ping pairs up
    assert loc.pose[2] == pytest.approx(0.02, abs=1e-12)
    assert loc.update_ranges(0.5, {"right_front": r["right_front"]}) == 0  # partner too old (> 0.12 s)


@pytest.mark.parametrize(
    "case, change",
    [
        ("outside the gate", {"right_front": 0.3 + 0.2}),
        ("beyond the detection range", {"right_front": 0.7, "right_rear": 0.7}),
        ("no echo", {"right_front": math.nan}),
    ],
)
def test_readings_that_do_not_match_a_wall_are_not_used(case, change):
    walls = np.array([RIGHT_WALL])
    truth = np.array([0.7, -0.05, 0.0])
    loc = WallLandmarkLocalizer(walls, LAYOUT, FULL, pose=truth)
    assert loc.update_ranges(0.0, {**_readings(truth, walls), **change}) == 0, case
    assert loc.history == [] and loc.status == "dead_reckoning"


def test_no_calibration_near_a_wall_end_or_for_a_wall_across():
    short = np.array([[[0.6, -0.55], [1.0, -0.55]]])  # 0.4 m: the rear sensor is not abreast of it
    truth = np.array([0.7, 0.0, 0.0])
    loc = WallLandmarkLocalizer(short, LAYOUT, FULL, pose=truth)
    assert loc.update_ranges(0.0, _readings(truth, short)) == 0
    turned = np.array([0.7, 0.0, -0.5])  # heading 29 deg off the wall: not parallel for eqs 6-7
    loc = WallLandmarkLocalizer(np.array([RIGHT_WALL]), LAYOUT, FULL, pose=turned)
    ranges = {"right_front": 0.35, "right_rear": 0.35}
    assert loc.update_ranges(0.0, ranges) == 0


def test_estimator_interface_errors():
    loc = WallLandmarkLocalizer(np.array([RIGHT_WALL]), LAYOUT)
    with pytest.raises(ValueError, match="unknown rangers"):
        loc.update_ranges(0.0, {"rear": 0.3})
    loc.predict(1.0, 0.1, 0.0)
    with pytest.raises(ValueError, match="before the latest input"):
        loc.update_ranges(0.5, {"front": 0.3})
    with pytest.raises(ValueError, match="without rangers"):
        WallLandmarkLocalizer().update_ranges(0.0, {"front": 0.3})
    with pytest.raises(ValueError, match="lacks"):
        WallLandmarkLocalizer(np.array([RIGHT_WALL]), LAYOUT, LandmarkParams(front_sensor="nose"))
    with pytest.raises(ValueError, match="finite"):
        loc.predict(2.0, math.nan, 0.0)
    with pytest.raises(ValueError, match="wall_ids"):
        WallLandmarkLocalizer(np.array([RIGHT_WALL]), LAYOUT, wall_ids=["a", "b"])


def test_covariance_grows_as_the_odometry_model_and_shrinks_at_a_calibration():
    noise = OdometryNoise(k_d=0.002, k_dtheta=0.004, k_theta=0.003)
    P0 = np.diag([1e-4, 2e-4, 3e-4])
    loc = WallLandmarkLocalizer(pose=[1.0, 2.0, 0.3], odometry_noise=noise, initial_covariance=P0)
    loc.predict(0.1, 0.05, 0.02)
    F = pose_jacobian([1.0, 2.0, 0.3], 0.05, 0.02, rule="euler")
    Q = motion_covariance([1.0, 2.0, 0.3], 0.05, 0.02, noise)
    np.testing.assert_allclose(loc.covariance, F @ P0 @ F.T + Q, rtol=1e-12, atol=1e-18)
    # gain 1 replaces the heading: its variance becomes the measurement's, 2 std^2 / dist^2
    loc = WallLandmarkLocalizer(params=FULL, pose=[0.0, 0.0, 0.1], initial_covariance=P0, range_std=0.003)
    loc.calibrate_heading(0.0, 0.3, 0.3, SPACING, "right", RIGHT_WALL)
    assert loc.covariance[2, 2] == pytest.approx(2 * 0.003**2 / SPACING**2, rel=1e-12)
    assert loc.covariance[0, 2] == 0.0 and loc.covariance[0, 0] == P0[0, 0]
    # a partial blend shrinks the variance along the corrected direction only
    loc = WallLandmarkLocalizer(pose=[0.0, 0.0, 0.0], initial_covariance=P0, range_std=0.003)
    loc.calibrate_offset(0.0, [0.3], [LAYOUT["front"].mount], FRONT_WALL)
    assert loc.covariance[0, 0] < P0[0, 0] and loc.covariance[1, 1] == P0[1, 1]


def test_lateral_odometry_moves_sideways_at_the_old_heading():
    loc = WallLandmarkLocalizer(pose=[0.0, 0.0, math.pi / 2])
    loc.predict(0.1, 0.0, 0.0, 0.2)
    assert loc.pose == pytest.approx([-0.2, 0.0, math.pi / 2])
    assert loc.covariance[0, 0] > loc.covariance[1, 1]  # lateral noise along map x


def test_route_that_never_passes_a_landmark_is_refused():
    legs = [(np.array([0.0, 0.0]), 0.0, 3.5)]
    check_route_passes_landmarks(legs, np.array([RIGHT_WALL]), LAYOUT.body_width)
    far = np.array([[[10.0, 10.0], [12.0, 10.0]]])
    with pytest.raises(ValueError, match="never passes a landmark"):
        check_route_passes_landmarks(legs, far, LAYOUT.body_width)
    with pytest.raises(ValueError, match="zero length"):
        check_route_passes_landmarks(legs, np.array([[[1.0, -0.5], [1.0, -0.5]]]), LAYOUT.body_width)
