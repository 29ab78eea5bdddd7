"""Rear-drive steered plants (seed 003 model A, Ackermann): analytic motion, odometry, pose_at, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _plants import drive, integrate_odometry, steered
from hypothesis import given
from hypothesis import strategies as st

from agvnav.actuators import SteeringActuator
from agvnav.kinematics import TricycleRearDrive, ackermann_wheel_angles
from agvnav.odometry import NonSystematicErrors, TricycleErrors
from agvnav.vehicles import SteeredGeometry, SteeredPlant
from agvnav.vehicles.steered import rear_drive_rate, rear_drive_rk4

L = 1.5


@given(st.floats(-3, 3), st.floats(-1.0, 1.0), st.floats(-2, 2), st.floats(-1, 1))
def test_rate_is_the_kinematic_model_a(theta: float, phi: float, v: float, phi_dot: float) -> None:
    ref = TricycleRearDrive(L).derivative([0.0, 0.0, theta, phi], [v, phi_dot])
    np.testing.assert_allclose(rear_drive_rate(theta, phi, v, phi_dot, L), ref, atol=1e-12)


@pytest.mark.parametrize("model", ["tricycle_rear", "ackermann"])
def test_straight_line(model: str) -> None:
    plant = steered(model, state=(1.0, 2.0, 0.3, 0.0), cpr=4096)
    inc = drive(plant, (0.5, 0.0), 100)
    np.testing.assert_allclose(plant.pose, [1.0 + 2.5 * math.cos(0.3), 2.0 + 2.5 * math.sin(0.3), 0.3], atol=1e-12)
    assert sum(d[0] for d in inc) == pytest.approx(2.5, abs=2 * math.pi / 4096 * 0.15)
    assert plant.geometry == SteeredGeometry(L, "O", math.radians(60.0))


@pytest.mark.parametrize("model", ["tricycle_rear", "ackermann"])
def test_constant_steering_circle_and_odometry(model: str) -> None:
    """phi held: O on the circle of radius L / tan(phi), theta' = V tan(phi) / L [seed003 §3.2.5]."""
    phi, v = 0.35, 0.6
    plant = steered(model, state=(0.0, 0.0, 0.0, phi))
    inc = drive(plant, (v, 0.0), 80)
    th = v * 4.0 * math.tan(phi) / L
    radius = L / math.tan(phi)
    expected = [radius * math.sin(th), radius * (1 - math.cos(th)), th]
    np.testing.assert_allclose(plant.pose, expected, atol=1e-10)
    np.testing.assert_allclose(integrate_odometry((0, 0, 0), inc), expected, atol=2e-5)
    assert all(d[2] == 0.0 for d in inc)


def test_ackermann_reports_both_front_wheels() -> None:
    plant = steered("ackermann", state=(0.0, 0.0, 0.0, 0.3))
    drive(plant, (0.5, 0.1), 5)
    sig = dict(zip(plant.signal_names, plant.signals(), strict=True))
    left, right = ackermann_wheel_angles(sig["phi"], L, 1.0)
    assert sig["phi_left"] == pytest.approx(float(left)) and sig["phi_right"] == pytest.approx(float(right))
    # Ackermann condition: both axes through one centre on the rear axle line
    assert 1 / math.tan(sig["phi_right"]) - 1 / math.tan(sig["phi_left"]) == pytest.approx(1.0 / L)
    assert "phi_left" not in steered("tricycle_rear").signal_names


def test_radius_and_offset_errors_drift_as_predicted() -> None:
    plant = steered(systematic=TricycleErrors(radius_scale=1.02, steering_offset=math.radians(1.0)))
    inc = drive(plant, (0.5, 0.0), 100)
    odo = sum(d[0] for d in inc)
    true_distance = 1.02 * odo
    assert abs(sum(d[1] for d in inc)) < 1e-6  # the encoder reads straight
    assert plant.pose[2] == pytest.approx(true_distance * math.tan(math.radians(1.0)) / L, rel=1e-4)


def test_pose_at_matches_fine_integration() -> None:
    """Piecewise Hermite in a 0.05 s step at 1 m/s with 60 deg/s steering vs the kinematic model, 50 sub-steps.

    Within 1e-9 m / rad: a hundredth of the goniometer resolution (1e-7 rad).
    """
    plant = steered(state=(0.0, 0.0, 0.2, 0.4))
    plant.advance((1.0, math.radians(60.0)), 0.0, 0.05, np.random.default_rng(0))
    t = np.linspace(0.0, 0.05, 11)
    got = plant.pose_at(t)
    model = TricycleRearDrive(L, max_steer=1.5)
    u = np.array([1.0, math.radians(60.0)])
    for i, ti in enumerate(t):
        x = np.array([0.0, 0.0, 0.2, 0.4])
        for _ in range(50):
            x = model.step_unchecked(x, u, ti / 50) if ti > 0 else x
        np.testing.assert_allclose(got[i], x[:3], rtol=0, atol=1e-9)
    end = [0.0, 0.0, 0.2, 0.4]
    for _ in range(5):
        end = rear_drive_rk4(end, 1.0, math.radians(60.0), L, 0.01)[0]
    np.testing.assert_array_equal(plant.state, end)


def test_reverse_and_random_errors_are_seeded() -> None:
    noise = NonSystematicErrors(slip_k=1e-4, steering_std=0.01)
    a, b = steered(nonsystematic=noise), steered(nonsystematic=noise)
    drive(a, (-0.5, 0.3), 20, seed=9)
    drive(b, (-0.5, 0.3), 20, seed=9)
    assert a.signals() == b.signals() and a.pose[0] < 0.0


@pytest.mark.parametrize(
    ("model", "kwargs", "word"),
    [
        ("bicycle", {}, "model"),
        ("ackermann", {}, "track"),
        ("ackermann", {"track": 0.0}, "track"),
        ("tricycle_rear", {"wheelbase": 0.0}, "wheelbase"),
        ("tricycle_rear", {"steering": SteeringActuator(max_angle=math.pi / 2)}, "pi/2"),
    ],
)
def test_bad_input(model: str, kwargs: dict, word: str) -> None:
    args = {"wheelbase": L, "wheel_radius": 0.15, "traction_cpr": 100, "steering_cpr": 100,
            "steering": SteeringActuator(max_angle=1.0)} | kwargs
    with pytest.raises(ValueError, match=word):
        SteeredPlant(model, **args)
