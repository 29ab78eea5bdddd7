"""``positioning.wheel_odometry``: the steered vehicles' exact odometry model and calibration tolerance (issue 12)."""

from __future__ import annotations

import math

import pytest
import yaml

from agvnav.odometry import SteeredOdometryNoise
from agvnav.sim.build import build
from agvnav.world.scenario import ScenarioError, builtin_scenario, load_scenario, parse_scenario


def _doc(name: str) -> dict:
    return yaml.safe_load(builtin_scenario(name).read_text(encoding="utf-8"))


def test_guidance_test_builds_the_exact_model_with_its_calibration_tolerance() -> None:
    est = build(load_scenario("guidance_test")).estimator
    noise = est.odometry_noise
    assert isinstance(noise, SteeredOdometryNoise)
    assert noise.model == "tricycle" and noise.wheelbase_m == 1.0
    assert noise.slip_k == pytest.approx(1e-4) and noise.step_m == pytest.approx(0.2 * 0.05)
    assert noise.radius_scale_std == 0.003 and noise.steering_offset_std == pytest.approx(math.radians(0.2))
    assert noise.k_theta == pytest.approx(1e-4)  # Crowley's bound for three-coefficient consumers


def test_wheel_odometry_and_odometry_noise_are_exclusive() -> None:
    doc = _doc("guidance_test")
    doc["positioning"]["odometry_noise"] = [1e-4, 1e-8, 1e-4]
    with pytest.raises(ScenarioError, match="either odometry_noise"):
        parse_scenario(yaml.safe_dump(doc), "both.yaml")


def test_wheel_odometry_is_for_steered_vehicles() -> None:
    doc = _doc("differential_loop")
    doc["positioning"].pop("odometry_noise")
    doc["positioning"]["wheel_odometry"] = {"slip_std": 0.01}
    with pytest.raises(ScenarioError, match="steered drive wheel"):
        parse_scenario(yaml.safe_dump(doc), "diff.yaml")


def test_negative_tolerance_is_refused() -> None:
    doc = _doc("guidance_test")
    doc["positioning"]["wheel_odometry"]["wheel_radius_std"] = -0.01
    with pytest.raises(ScenarioError, match="wheel_radius_std"):
        parse_scenario(yaml.safe_dump(doc), "neg.yaml")
