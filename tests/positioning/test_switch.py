"""Seed 000 §5 switch between the relative and the absolute method on the predicted error (issue 13)."""

import math

import numpy as np
import pytest
from tests.positioning._drive import arc_pose_at, feed

from agvnav.geometry import bearing_to
from agvnav.odometry import OdometryNoise
from agvnav.positioning.bounds import fisher_information
from agvnav.positioning.estimator import make_estimator
from agvnav.positioning.fix_switch import fix_given_heading, predicted_position_variances
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import Reflector, WorldMap

R = np.array([[0.0, 10.0], [-8.0, -6.0], [9.0, -5.0]])


def test_held_heading_with_the_bearings_own_heading_std_predicts_the_relative_error():
    """Schur complement: the three-bearing xy covariance is A^-1 + g g^T var(psi | bearings)."""
    head = np.array([2.0, 1.0, 0.4])
    sigma = 1e-4
    cov = np.linalg.inv(fisher_information(R, head, sigma))
    relative, held = predicted_position_variances(R, head, sigma, math.sqrt(cov[2, 2]))
    assert relative == pytest.approx(np.trace(cov[:2, :2]), rel=1e-9)
    assert held == pytest.approx(relative, rel=1e-6)
    # a better odometric heading makes the held-heading fix the better one, a worse one the relative
    assert predicted_position_variances(R, head, sigma, 0.1 * math.sqrt(cov[2, 2]))[1] < relative
    assert predicted_position_variances(R, head, sigma, 10 * math.sqrt(cov[2, 2]))[1] > relative


def test_on_the_critical_circle_only_the_held_heading_is_bounded():
    centre = np.array([0.0, 0.0])
    r = np.array([[10 * math.cos(a), 10 * math.sin(a)] for a in (0.3, 2.2, 4.1)]) + centre
    head = np.array([10 * math.cos(1.0), 10 * math.sin(1.0), 0.2])
    relative, held = predicted_position_variances(r, head, 1e-4, 1e-3)
    assert relative == math.inf or relative > 1e6 * held
    assert math.isfinite(held)


def test_fix_given_heading_is_exact_with_the_true_heading_and_flags_parallel_lines():
    pose = np.array([2.0, -1.0, 0.7])
    b = bearing_to(pose, R)
    np.testing.assert_allclose(fix_given_heading(R, b, 0.7), pose[:2], atol=1e-10)
    assert fix_given_heading(np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([0.0, 0.0]), 0.0) is None


def test_predicted_switch_in_the_estimator_is_exact_and_counts_its_choices():
    world = WorldMap(tuple(Reflector(f"S{i}", x, y, 0.0) for i, (x, y) in enumerate(R)), ())
    mount = np.array([0.3, 0.0, 0.0])
    gon = Goniometer(pulses_per_rev=2**24, mount=tuple(mount))
    start = np.array([-2.0, 1.0, 0.0])
    est = make_estimator("angle_propagation", world, mount, pulses_per_rev=2**24, map_std=0.0,
                         odometry_noise=OdometryNoise(1e-8, 1e-8, 1e-8), initial_pose=start,
                         initial_covariance=np.diag([0.01, 0.01, 0.005]) ** 2, triangulation_method="predicted")
    pose_at = arc_pose_at(start, 1.0, 0.0)
    t, x, _ = feed(est, world, gon, pose_at, 1.0, 0.0, 12.0)
    assert est.n_relative > 0 and est.n_held > 0 and est.n_relative + est.n_held >= est.n_fixes
    truth = pose_at(t)
    assert np.max(np.hypot(*(x[:, :2] - truth[:, :2]).T)) < 1e-3
    with pytest.raises(ValueError, match="predicted"):
        make_estimator("angle_propagation", world, mount, triangulation_method="nope")
