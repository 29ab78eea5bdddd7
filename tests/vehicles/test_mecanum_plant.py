"""The mecanum plant: sideways travel, twist tracking, odometry vs truth, radius and roller errors, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _plants import drive, integrate_odometry, mecanum

from agvnav.actuators import WheelSpeedLoop
from agvnav.kinematics import MecanumBase, twist_step
from agvnav.odometry import NonSystematicErrors
from agvnav.vehicles import HolonomicGeometry, MecanumPlant

QUANTUM = 2 * math.pi / 100000 * 0.05


def test_sideways_travel() -> None:
    plant = mecanum()
    inc = drive(plant, (0.0, 0.1, 0.0), 100)
    x, y, th = plant.pose
    assert abs(x) < 1e-12 and abs(th) < 1e-12
    assert y == pytest.approx(0.5 - 0.1 * 0.1, abs=5e-3)  # minus the speed loops' lag (about 0.1 s)
    assert sum(d[2] for d in inc) == pytest.approx(y, abs=2 * QUANTUM)
    assert abs(sum(d[0] for d in inc)) <= 2 * QUANTUM and abs(sum(d[1] for d in inc)) < 1e-6


def test_steady_state_twist_is_the_command() -> None:
    plant = mecanum()
    drive(plant, (0.08, -0.04, 0.1), 100)  # wheel rates within the motors' 4.7 rad/s
    sig = dict(zip(plant.signal_names, plant.signals(), strict=True))
    np.testing.assert_allclose([sig["v_x"], sig["v_y"], sig["yaw_rate"]], [0.08, -0.04, 0.1], atol=1e-4)
    rates = plant.base.wheel_rates([0.08, -0.04, 0.1])
    np.testing.assert_allclose([sig[f"omega_{w}"] for w in ("fl", "fr", "rl", "rr")], rates, atol=2e-3)


def test_odometry_integrates_to_the_truth_without_errors() -> None:
    plant = mecanum()
    inc = drive(plant, (0.1, 0.05, 0.3), 60) + drive(plant, (-0.05, 0.1, -0.2), 60, t0=3.0)
    np.testing.assert_allclose(integrate_odometry((0, 0, 0), inc), plant.pose, atol=1e-4)


def test_radius_error_scales_true_travel() -> None:
    plant = mecanum(radius_scales=(1.02, 1.02, 1.02, 1.02))
    inc = drive(plant, (0.1, 0.0, 0.0), 100)
    assert plant.pose[0] == pytest.approx(1.02 * sum(d[0] for d in inc), abs=2 * QUANTUM)


def test_unequal_radii_turn_the_base_as_the_least_squares_predicts() -> None:
    """Larger right wheels on a forward run: the base yaws by the least-squares twist of the true ground speeds."""
    scales = (1.0, 1.01, 1.0, 1.01)
    plant = mecanum(radius_scales=scales)
    inc = drive(plant, (0.1, 0.0, 0.0), 100)
    base = plant.base
    phi = sum(d[0] for d in inc) / base.wheel_radius  # every wheel turned this much (rad), nominal odometry
    ground = np.array(scales) * base.wheel_radius * phi
    expected = np.linalg.pinv(base.inverse_matrix * base.wheel_radius) @ ground
    assert plant.pose[2] == pytest.approx(expected[2], rel=1e-3)
    assert abs(sum(d[1] for d in inc)) < 1e-6  # the odometry believes equal radii


def test_roller_slip_shortens_sideways_travel_only() -> None:
    plant = mecanum(roller_slip=0.1)
    inc = drive(plant, (0.0, 0.1, 0.0), 100)
    assert plant.pose[1] == pytest.approx(0.9 * sum(d[2] for d in inc), abs=2 * QUANTUM)
    forward = mecanum(roller_slip=0.1)
    inc = drive(forward, (0.1, 0.0, 0.0), 100)
    assert forward.pose[0] == pytest.approx(sum(d[0] for d in inc), abs=2 * QUANTUM)


def test_pose_at_is_the_sub_step_exponential() -> None:
    plant = mecanum()
    drive(plant, (0.1, 0.05, 0.3), 4)
    start = plant.pose.copy()
    drive(plant, (0.1, 0.05, 0.3), 1, t0=0.2)
    pts = plant.pose_at(np.array([0.2, 0.2137, 0.25]))
    np.testing.assert_allclose(pts[0], start, atol=1e-15)
    np.testing.assert_allclose(pts[2], plant.pose, atol=1e-12)
    knot = plant.pose_at(np.array([0.21]))[0]
    tw = plant.substep_twists[1]
    np.testing.assert_allclose(pts[1], twist_step(knot, *tw, 0.0037), atol=1e-12)


def test_random_slip_is_seeded() -> None:
    noise = NonSystematicErrors(slip_k=1e-4)
    a, b = mecanum(nonsystematic=noise), mecanum(nonsystematic=noise)
    drive(a, (0.1, 0.1, 0.1), 20, seed=2)
    drive(b, (0.1, 0.1, 0.1), 20, seed=2)
    assert a.signals() == b.signals()
    assert a.geometry == HolonomicGeometry(0.05, 0.3, 0.25)


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"base": MecanumBase(0.05, 0.3, 0.3, "O")}, "yaw rate"),
        ({"radius_scales": (1.0, 1.0, 1.0)}, "radius_scales"),
        ({"radius_scales": (1.0, 1.0, 0.0, 1.0)}, "radius_scales"),
        ({"roller_slip": 1.0}, "roller_slip"),
        ({"counts_per_rev": 0}, "counts_per_rev"),
        ({"substep": -0.01}, "substep"),
    ],
)
def test_bad_input(kwargs: dict, word: str) -> None:
    args = {"base": MecanumBase(0.05, 0.3, 0.25), "counts_per_rev": 100, "initial_pose": (0.0, 0.0, 0.0),
            "loop": WheelSpeedLoop()} | kwargs
    with pytest.raises(ValueError, match=word):
        MecanumPlant(**args)
