"""``wheel_odometry`` with a method that keeps no consider parameters (issue 12 review).

The exact steered-wheel model's random part alone would leave out the calibration errors
the EKF keeps as consider parameters; naive, angle_propagation and batch_ml take the model's
Crowley bound instead (its inherited ``k_d, k_dtheta, k_theta``, as before the key), and
``agvnav localize --method X`` on a log with ``wheel_odometry`` settings keeps working.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from agvnav.logs.localize import estimator_from_settings
from agvnav.odometry import WHEEL_ODOMETRY_KEYS, OdometryNoise, steered_noise
from agvnav.positioning import make_estimator
from agvnav.positioning.integrity import IntegrityLimits
from agvnav.sim import simulate
from agvnav.world import load_builtin_map
from agvnav.world.scenario import builtin_scenario, parse_scenario

NOISE = steered_noise("tricycle", 1e-4, 1.0, math.radians(0.05), 0.01, 0.003, math.radians(0.2), math.radians(90.0))
P0 = np.diag([0.01, 0.01, 0.01]) ** 2


def _covariance(method: str, noise: OdometryNoise) -> np.ndarray:
    est = make_estimator(method, load_builtin_map("lab"), (0.3, 0.0, 0.0), odometry_noise=noise,
                         initial_pose=(3.0, 2.0, 0.2), initial_covariance=P0,
                         integrity=IntegrityLimits(enabled=False))
    est.predict(0.0, 0.0, 0.0)
    for k in range(1, 41):  # an arc: 0.4 m/s at 20 Hz, 20 deg of steering
        est.predict(0.05 * k, 0.02 * math.cos(0.35), 0.02 * math.sin(0.35))
    return np.asarray(est.covariance)


@pytest.mark.parametrize("method", ["naive", "angle_propagation", "batch_ml"])
def test_methods_without_consider_parameters_take_the_crowley_bound(method: str) -> None:
    crowley = OdometryNoise(NOISE.k_d, NOISE.k_dtheta, NOISE.k_theta)
    np.testing.assert_array_equal(_covariance(method, NOISE), _covariance(method, crowley))


def test_the_ekf_keeps_the_exact_model() -> None:
    crowley = OdometryNoise(NOISE.k_d, NOISE.k_dtheta, NOISE.k_theta)
    assert not np.allclose(_covariance("ekf", NOISE), _covariance("ekf", crowley), rtol=1e-3)


@pytest.mark.parametrize("method", ["naive", "angle_propagation", "batch_ml", "ekf"])
def test_localize_settings_with_wheel_odometry_build_every_method(method: str) -> None:
    settings = {"wheel_odometry": {k: getattr(NOISE, k) for k in WHEEL_ODOMETRY_KEYS},
                "initial_pose": [3.0, 2.0, 0.2], "initial_covariance": P0.tolist()}
    est = estimator_from_settings(settings, load_builtin_map("lab"), method)
    est.predict(0.0, 0.0, 0.0)
    est.predict(0.05, 0.02, 0.001)
    assert np.all(np.isfinite(est.covariance)) and est.covariance[2, 2] > P0[2, 2]


def test_a_naive_scenario_with_wheel_odometry_runs() -> None:
    doc = yaml.safe_load(builtin_scenario("guidance_test").read_text(encoding="utf-8"))
    doc["positioning"]["method"] = "naive"
    result = simulate(parse_scenario(yaml.safe_dump(doc), source="guidance_test naive"))
    assert result.outcome == "completed"
    assert np.all(np.isfinite(result.series["est_cov_psipsi"][-10:]))
