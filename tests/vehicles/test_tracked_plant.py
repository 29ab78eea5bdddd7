"""The seed-004 tracked plant (moved from sim): speed loops, ICR truth, nominal odometry, pose_at."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _plants import drive, integrate_odometry

from agvnav.actuators import WheelSpeedLoop
from agvnav.kinematics.tracked import TrackedVehicle, TrackTerrain, terrain_preset
from agvnav.vehicles import TrackedPlant, UnicycleGeometry

ODO_CONCRETE = TrackTerrain(slip_left=0.016, slip_right=0.016, icr_left=1.12, icr_right=1.12)


def test_plant_motion_matches_tracked_vehicle_and_pose_at_is_continuous():
    veh = TrackedVehicle(0.33, 0.05, "concrete")
    plant = TrackedPlant(veh, WheelSpeedLoop(), veh.terrain, 1440, (1.0, 2.0, 0.3))
    rng = np.random.default_rng(1)
    for _ in range(100):
        plant.advance((3.0, 2.0), 0.0, 0.1, rng)
    # at steady state the sprocket speeds reach the set-point (PID integral), and the
    # truth moves as TrackedVehicle.step with the mean sprocket speeds of each sub-step
    np.testing.assert_allclose(plant.signals()[3:5], (3.0, 2.0), atol=1e-3)
    start = plant.pose.copy()
    plant.advance((3.0, 2.0), 10.0, 0.1, rng)
    w = np.array(plant.speed_loop.omega)
    expected = veh.step(start, w * 0.05, 0.1)
    np.testing.assert_allclose(plant.pose, expected, atol=1e-6)
    ends = plant.pose_at(np.array([10.0, 10.1]))
    np.testing.assert_allclose(ends[0], start, atol=1e-12)
    np.testing.assert_allclose(ends[1], plant.pose, atol=1e-12)
    mid = plant.pose_at(np.array([10.05]))[0]
    np.testing.assert_allclose(mid, veh.step(start, w * 0.05, 0.05), atol=1e-6)


def test_odometry_with_true_terrain_follows_truth_and_with_wrong_terrain_drifts():
    for odo, small in ((terrain_preset("concrete"), True), (ODO_CONCRETE, False)):
        veh = TrackedVehicle(0.33, 0.05, "concrete")
        plant = TrackedPlant(veh, WheelSpeedLoop(), odo, 100000, (0.0, 0.0, 0.0))
        rng = np.random.default_rng(2)
        heading = 0.0
        for _ in range(200):  # an in-place turn
            plant.advance((2.0, -2.0), 0.0, 0.1, rng)
            heading += plant.odometry()[1]
        err = abs(heading - plant.pose[2])
        assert (err < 1e-3) if small else (err > 0.02 * abs(plant.pose[2]))


def test_odometry_lateral_is_the_odometry_terrain_skid() -> None:
    """With ``x_icr`` the odometry model predicts a lateral skid ``v_y = -x_icr omega`` (Martinez et al.)."""
    veh = TrackedVehicle(0.33, 0.05, TrackTerrain(x_icr=0.05))
    plant = TrackedPlant(veh, WheelSpeedLoop(), veh.terrain, 100000, (0.0, 0.0, 0.0))
    inc = drive(plant, (2.0, -2.0), 60, dt=0.1)
    dth = sum(d[1] for d in inc)
    dlat = sum(d[2] for d in inc)
    assert dlat == pytest.approx(-0.05 * dth, rel=1e-9)
    dead = integrate_odometry((0.0, 0.0, 0.0), inc)
    np.testing.assert_allclose(dead, plant.pose, atol=2e-3)


def test_ideal_terrain_straight_line_and_role_members() -> None:
    veh = TrackedVehicle(0.33, 0.05, "ideal")
    plant = TrackedPlant(veh, WheelSpeedLoop(), "ideal", 100000, (0.0, 0.0, 0.0))
    assert plant.geometry == UnicycleGeometry(0.33, 0.05) and plant.family == "unicycle"
    inc = drive(plant, (3.0, 3.0), 100, dt=0.1)
    assert plant.pose[1] == 0.0 and plant.pose[2] == 0.0
    assert sum(d[0] for d in inc) == pytest.approx(plant.pose[0], abs=2 * math.pi / 100000 * 0.05)


def test_bad_input() -> None:
    veh = TrackedVehicle(0.33, 0.05, "ideal")
    with pytest.raises(ValueError, match="counts_per_rev"):
        TrackedPlant(veh, WheelSpeedLoop(), "ideal", 0, (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="substep"):
        TrackedPlant(veh, WheelSpeedLoop(), "ideal", 100, (0.0, 0.0, 0.0), substep=0.0)
    with pytest.raises(ValueError, match="terrain"):
        TrackedPlant(veh, WheelSpeedLoop(), "ice", 100, (0.0, 0.0, 0.0))
