"""The seed-000 stacker plant (moved from sim): analytic motion, odometry vs truth, pose_at, errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _plants import drive, integrate_odometry, tricycle

from agvnav.actuators import SteeringActuator
from agvnav.kinematics import TricycleStacker
from agvnav.odometry import TricycleErrors


def test_straight_line_and_odometry_equal_truth_up_to_quantisation() -> None:
    plant = tricycle(cpr=4096)
    inc = drive(plant, (0.8, 0.0), 100)
    np.testing.assert_allclose(plant.pose, [4.0, 0.0, 0.0], atol=1e-12)
    quantum = 2 * math.pi / 4096 * 0.125
    assert abs(sum(d for d, _, _ in inc) - 4.0) <= quantum
    assert all(lat == 0.0 and dth == 0.0 for _, dth, lat in inc)


def test_constant_steering_turns_on_the_seed_circle() -> None:
    """gamma held: O turns about the ICR at L / tan(gamma), psi' = v sin(gamma) / L [seed000 eq8]."""
    gamma, v, L = 0.4, 0.5, 1.24
    plant = tricycle(state=(0.0, 0.0, 0.0, gamma))
    inc = drive(plant, (v, 0.0), 80)
    T = 80 * 0.05
    psi = v * math.sin(gamma) / L * T
    radius = L / math.tan(gamma)
    expected = [radius * math.sin(psi), radius * (1.0 - math.cos(psi)), psi]
    np.testing.assert_allclose(plant.pose, expected, atol=1e-9)
    dead = integrate_odometry((0.0, 0.0, 0.0), inc)
    np.testing.assert_allclose(dead, expected, atol=2e-5)  # steering and traction quantisation


@pytest.mark.parametrize("scale", [0.98, 1.03])
def test_radius_error_scales_true_distance_against_odometry(scale: float) -> None:
    plant = tricycle(TricycleErrors(radius_scale=scale))
    inc = drive(plant, (0.8, 0.0), 100)
    odo = sum(d for d, _, _ in inc)
    assert plant.pose[0] == pytest.approx(scale * odo, abs=1e-4)


def test_steering_offset_turns_a_straight_odometry_into_a_truth_arc() -> None:
    offset = math.radians(1.0)
    plant = tricycle(TricycleErrors(steering_offset=offset))
    inc = drive(plant, (0.8, 0.0), 100)
    assert abs(sum(dth for _, dth, _ in inc)) < 1e-5  # the encoder reads straight
    assert plant.pose[2] == pytest.approx(4.0 * math.sin(offset) / 1.24, rel=1e-9)


@pytest.mark.parametrize("gamma0", [0.0, 0.3])
def test_pose_at_matches_fine_integration(gamma0: float) -> None:
    """Hermite cubic (and one RK4 step) inside a 0.05 s step at 0.8 m/s and 60 deg/s steering.

    Within 2e-8 m / rad of a 40-sub-step integration: a fifth of the goniometer resolution
    (1e-7 rad) at this extreme steering rate, far below it at usual rates.
    """
    plant = tricycle(state=(0.0, 0.0, 0.2, gamma0))
    plant.advance((0.8, math.radians(60.0)), 0.0, 0.05, np.random.default_rng(0))
    t = np.linspace(0.0, 0.05, 11)
    got = plant.pose_at(t)
    model = TricycleStacker(plant.L_true)
    u = np.array([0.8, math.radians(60.0)])
    for i, ti in enumerate(t):
        x = np.array([0.0, 0.0, 0.2, gamma0])
        for _ in range(40):
            x = model.step(x, u, ti / 40) if ti > 0 else x
        np.testing.assert_allclose(got[i], x[:3], rtol=0, atol=2e-8)


def test_scalar_pose_at_is_bit_identical_to_the_vectorised_branch() -> None:
    plant = tricycle(state=(0.0, 0.0, 0.2, 0.3))
    drive(plant, (0.8, 0.5), 7)
    t = 0.3 + 0.05 * np.array([-0.1, 0.0, 0.37, 0.5, 0.91, 1.0, 1.2])
    ref = plant.pose_at(np.concatenate([t, t]))  # > 4 instants: the vectorised branch
    for k in range(1, 5):
        np.testing.assert_array_equal(plant.pose_at(t[:k]), ref[:k])


def test_geometry_and_bad_input() -> None:
    plant = tricycle()
    assert plant.geometry.drive_point == "C" and plant.geometry.wheelbase == 1.24
    with pytest.raises(ValueError, match="wheel_radius"):
        type(plant)(1.24, 0.0, 100, 100, SteeringActuator(), TricycleErrors(), None, (0, 0, 0, 0))
    with pytest.raises(ValueError, match="counts_per_rev"):
        type(plant)(1.24, 0.1, 0, 100, SteeringActuator(), TricycleErrors(), None, (0, 0, 0, 0))
    with pytest.raises(ValueError, match="footprint"):
        type(plant)(1.24, 0.1, 100, 100, SteeringActuator(), TricycleErrors(), None, (0, 0, 0, 0),
                    footprint=[[0, 0], [1, 1]])
