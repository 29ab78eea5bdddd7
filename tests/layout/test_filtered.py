"""The EKF covariance recursion of layout.filtered against closed forms; base_link information with a mount."""

from __future__ import annotations

import math

import numpy as np

from agvnav.layout.filtered import base_link_information, filtered_prediction, single_fix_rms
from agvnav.layout.prediction import information, sigmas_rms
from agvnav.layout.verify import odometry_model
from agvnav.odometry import OdometryNoise

REFL = np.array([[10.0, 1.0], [0.0, 10.0], [-10.0, 2.0], [3.0, -9.0]])  # no bearing on a revolution boundary
SIGMA = 1e-3


def _bearing(pose: np.ndarray, mount: tuple[float, float, float], r: np.ndarray) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    px, py = pose[0] + c * mount[0] - s * mount[1], pose[1] + s * mount[0] + c * mount[1]
    return np.arctan2(r[:, 1] - py, r[:, 0] - px) - pose[2] - mount[2]


def test_base_link_information_is_the_numerical_jacobian_with_a_mount() -> None:
    pose = np.array([[1.0, -0.5, 0.7]])
    mount = (0.4, 0.1, 0.2)
    c, s = math.cos(0.7), math.sin(0.7)
    head = np.array([[1.0 + c * 0.4 - s * 0.1, -0.5 + s * 0.4 + c * 0.1]])
    info = base_link_information(pose, head, REFL, np.ones((1, 4), dtype=bool), mount, SIGMA)[0]
    J = np.empty((4, 3))
    for i in range(3):
        d = np.zeros(3)
        d[i] = 1e-6
        J[:, i] = (_bearing(pose[0] + d, mount, REFL) - _bearing(pose[0] - d, mount, REFL)) / 2e-6
    np.testing.assert_allclose(info, J.T @ J / SIGMA**2, rtol=1e-6)


def test_single_fix_without_mount_is_the_head_crlb() -> None:
    pose = np.array([[0.5, 0.5, 0.3], [2.0, 1.0, -1.0]])
    vis = np.ones((2, 4), dtype=bool)
    _, _, rms = sigmas_rms(information(pose[:, :2], REFL, vis, SIGMA))
    got = single_fix_rms(base_link_information(pose, pose[:, :2], REFL, vis, (0.0, 0.0, 0.0), SIGMA))
    np.testing.assert_allclose(got, rms, rtol=1e-9)


def test_without_odometry_noise_each_revolution_adds_one_fix_of_information() -> None:
    # Q = 0 and (almost) standing still: after n revolutions P = (P0^-1 + n I)^-1 [seed000 §2.2]
    n, step = 40, 1e-6
    pose = np.zeros((n + 1, 3))
    pose[:, 0] = np.arange(n + 1) * step
    vis = np.ones((n + 1, 4), dtype=bool)
    p0 = np.diag([1e-4, 1e-4, 1e-4])
    out = filtered_prediction(pose, vis, REFL, (0.0, 0.0, 0.0), SIGMA, 1.0 / step, OdometryNoise(0, 0, 0), p0)
    info = base_link_information(pose[:1], pose[:1, :2], REFL, vis[:1], (0.0, 0.0, 0.0), SIGMA)[0]
    want = np.linalg.inv(np.linalg.inv(p0) + n * info)
    assert math.isclose(out.post_rms[-1], math.sqrt(want[0, 0] + want[1, 1]), rel_tol=1e-4)


def test_error_started_on_the_truth_meets_the_filter_covariance() -> None:
    # an actual initial error of zero stays below P, and both converge to the same steady state
    pose = np.zeros((401, 3))
    pose[:, 0] = np.linspace(-20.0, 20.0, 401)
    pose[:, 1] = -4.0
    refl = np.array([[-15.0, 5.0], [-5.0, 5.0], [5.0, 5.0], [15.0, 5.0], [0.0, -10.0]])
    vis = np.ones((401, 5), dtype=bool)
    p0 = np.diag([4e-4, 4e-4, math.radians(1.0) ** 2])
    noise = odometry_model(1e-6, 0.5)
    same = filtered_prediction(pose, vis, refl, (0.3, 0.0, 0.0), 1e-4, 8.0, noise, p0)
    zero = filtered_prediction(pose, vis, refl, (0.3, 0.0, 0.0), 1e-4, 8.0, noise, p0, np.zeros((3, 3)))
    assert zero.mean_square[1] < same.mean_square[1]
    assert np.all(zero.mean_square <= same.mean_square * (1 + 1e-9))
    assert math.isclose(zero.post_rms[-1], same.post_rms[-1], rel_tol=1e-3)
    # odometry noise makes the steady state worse than without it
    none = filtered_prediction(pose, vis, refl, (0.3, 0.0, 0.0), 1e-4, 8.0, OdometryNoise(0, 0, 0), p0)
    assert none.post_rms[-1] < same.post_rms[-1]


def test_odometry_model_of_wheel_slip() -> None:
    m = odometry_model(2e-6, 0.5)
    assert (m.k_d, m.k_dtheta, m.k_theta) == (1e-6, 1.6e-5, 0.0)
