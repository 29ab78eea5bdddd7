"""The differential AGV with base_link off the axle (kind ``differential_offset``): analytic motion and odometry."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _plants import drive, integrate_odometry

from agvnav.actuators import WheelSpeedLoop
from agvnav.vehicles import DifferentialPlant, build_plant
from agvnav.world.scenario import ScenarioError, builtin_scenario, load_scenario, parse_scenario
from agvnav.world.vehicle_specs import DifferentialOffsetSpec, vehicle_kind

R, B, A = 0.1, 0.5, 0.3
QUANTUM = 2 * math.pi / 100000 * R  # one encoder count of wheel travel (m)


def offset_plant(a: float = A, pose: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> DifferentialPlant:
    """Wheel radius 0.1 m, track 0.5 m, base_link ``a`` m ahead of the axle, seed-004 speed loop."""
    return DifferentialPlant(R, B, 100000, pose, WheelSpeedLoop(), axle_offset=a)


def axle(pose: np.ndarray, a: float = A) -> np.ndarray:
    """The axle midpoint of base_link poses ``(..., 3)``: ``a`` m behind along the heading."""
    return pose[..., :2] - a * np.stack([np.cos(pose[..., 2]), np.sin(pose[..., 2])], axis=-1)


def test_a_turn_on_the_spot_swings_base_link_about_the_fixed_axle() -> None:
    """Opposite wheel rates: the axle midpoint stands, base_link runs on the circle of radius a about it."""
    plant = offset_plant(pose=(1.0, 2.0, 0.3))
    start = axle(plant.pose.copy())
    drive(plant, (2.0, -2.0), 40)
    t = np.linspace(1.95, 2.0, 11)
    poses = plant.pose_at(t)
    np.testing.assert_allclose(axle(poses), np.broadcast_to(start, (11, 2)), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(poses[:, :2] - start, axis=1), A, atol=1e-12)
    assert abs(plant.pose[2] - 0.3) > 1.0  # it did turn


def test_a_steady_turn_puts_base_link_on_the_icr_circle_of_radius_hypot_r_a() -> None:
    """Wheel rates w_R, w_L: the axle runs at radius R = (B/2)(w_R + w_L)/(w_R - w_L) about the ICR on the
    axle line [seed002 eq16]; the rigid body's point a ahead runs at sqrt(R² + a²) about the same ICR."""
    plant = offset_plant()
    drive(plant, (3.0, 2.0), 100)  # settle the speed loops
    radius = 0.5 * B * (3.0 + 2.0) / (3.0 - 2.0)
    psi = plant.pose[2]
    centre = axle(plant.pose) + radius * np.array([-math.sin(psi), math.cos(psi)])
    pts = []
    for k in range(40):
        drive(plant, (3.0, 2.0), 1, t0=5.0 + 0.05 * k)
        pts.append(plant.pose[:2].copy())
    np.testing.assert_allclose(np.linalg.norm(np.array(pts) - centre, axis=1), math.hypot(radius, A), atol=1e-4)


def test_the_odometry_reports_the_sideways_motion_and_integrates_to_the_truth() -> None:
    """Nominal twist: delta_lateral = a delta_theta per step; the dead reckoning follows the truth."""
    plant = offset_plant(pose=(1.0, 2.0, 0.5))
    inc = drive(plant, (3.0, 1.0), 60) + drive(plant, (-1.0, 2.5), 60, t0=3.0)
    for _dd, dth, dlat in inc:
        assert dlat == pytest.approx(A * dth, abs=1e-15)
    assert max(abs(d[2]) for d in inc) > 1e-3  # it really moved sideways
    dead = integrate_odometry((1.0, 2.0, 0.5), inc)
    np.testing.assert_allclose(dead, plant.pose, atol=5e-4)


def test_no_offset_is_the_plain_differential_bit_for_bit() -> None:
    plain, zero = DifferentialPlant(R, B, 100000, (0.0, 0.0, 0.0)), offset_plant(0.0)
    assert drive(plain, (3.0, 1.0), 30) == drive(zero, (3.0, 1.0), 30)
    np.testing.assert_array_equal(plain.pose, zero.pose)


def test_the_kind_builds_its_offset_plant_and_refuses_an_axle_outside_the_body() -> None:
    kind = vehicle_kind("differential_offset")
    assert kind is DifferentialOffsetSpec and kind.family == "unicycle"
    assert kind.reverses and not kind.turns_on_spot
    spec = DifferentialOffsetSpec.model_validate({"model": "differential_offset", "axle_offset_m": 0.25})
    plant = build_plant(spec, [0.0, 0.0, 0.0])
    assert isinstance(plant, DifferentialPlant) and plant.axle_offset == 0.25
    with pytest.raises(ValueError, match="axle_offset"):
        DifferentialOffsetSpec.model_validate({"model": "differential_offset", "axle_offset_m": 0.5})
    with pytest.raises(ValueError, match="axle_offset"):
        DifferentialPlant(R, B, 100, (0.0, 0.0, 0.0), axle_offset=math.nan)


def test_the_shipped_scenario_refuses_an_axle_outside_the_body_naming_key_and_line() -> None:
    text = builtin_scenario("differential_offset_loop").read_text(encoding="utf-8")
    assert load_scenario("differential_offset_loop").vehicle.model == "differential_offset"
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text.replace("axle_offset_m: 0.2 ", "axle_offset_m: 0.6 ", 1), "t.yaml")
    assert "vehicle" in str(info.value) and info.value.line is not None
