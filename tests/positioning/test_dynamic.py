"""Fixes of a moving vehicle: angle propagation and batch ML are exact at constant velocity; naive is not."""

from __future__ import annotations

import numpy as np
import pytest
from _drive import arc_pose_at, feed
from hypothesis import given
from hypothesis import strategies as st

from agvnav.geometry import angle_diff, between
from agvnav.odometry import OdometryNoise, integrate_pose
from agvnav.positioning.bearing_propagation import batch_ml_fix, centre_bearings, propagate_bearings
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.estimator import make_estimator
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import WorldMap, load_builtin_map

MOUNT = np.array([0.6, 0.05, 0.02])
FINE_PULSES = 2**30  # quantisation far below every tolerance: "without noise"


@pytest.fixture(scope="module")
def lab() -> WorldMap:
    return load_builtin_map("lab")


def _odometry_poses(start_odom: np.ndarray, speed: float, omega: float, times: np.ndarray) -> np.ndarray:
    return integrate_pose(np.broadcast_to(start_odom, times.shape + (3,)), speed * times, omega * times)


@given(st.floats(0.2, 2.0), st.floats(-0.5, 0.5), st.floats(-np.pi, np.pi))
def test_propagated_bearings_equal_bearings_at_fix(speed: float, omega: float, psi0: float) -> None:
    xy = np.array([[15.0, 3.0], [-2.0, 9.0], [4.0, -8.0]])
    pose_at = arc_pose_at(np.array([3.0, 1.0, psi0]), speed, omega)
    t_i = np.array([0.01, 0.05, 0.11])
    t_f = 0.12
    truth_i = pose_at(t_i)
    z_i = bearing_model(truth_i, MOUNT, xy, 0.0)[0]
    odom0 = np.array([-4.0, 2.0, 1.0])  # the odom frame is arbitrary
    odom_i = _odometry_poses(odom0, speed, omega, t_i)
    odom_f = _odometry_poses(odom0, speed, omega, np.array([t_f]))[0]
    x_f = pose_at(np.array([t_f]))[0]
    z_f = propagate_bearings(z_i, odom_i, odom_f, x_f, MOUNT, xy)
    expected = bearing_model(x_f, MOUNT, xy, 0.0)[0]
    np.testing.assert_allclose(angle_diff(z_f, expected), 0.0, atol=1e-11)


def test_centre_bearings_remove_edge_offset() -> None:
    xy = np.array([[5.0, 1.0], [-3.0, 4.0]])
    radius = np.array([0.04, 0.1])
    pose = np.array([0.5, -0.2, 0.3])
    edge = bearing_model(pose, MOUNT, xy, radius)[0]
    centre = bearing_model(pose, MOUNT, xy, 0.0)[0]
    assert np.all(np.abs(angle_diff(edge, centre)) > 5e-3)  # the bias the correction removes
    np.testing.assert_allclose(angle_diff(centre_bearings(edge, pose, MOUNT, xy, radius), centre), 0.0, atol=1e-14)


@given(st.floats(0.2, 2.0), st.floats(-0.5, 0.5))
def test_batch_ml_exact_at_constant_velocity(speed: float, omega: float) -> None:
    xy = np.array([[15.0, 3.0], [-2.0, 9.0], [4.0, -8.0], [10.0, 10.0], [-6.0, -5.0]])
    radius = np.full(5, 0.04)
    pose_at = arc_pose_at(np.array([3.0, 1.0, 0.4]), speed, omega)
    t = np.array([0.0, 0.02, 0.05, 0.08, 0.11])
    t_f = 0.12
    z = bearing_model(pose_at(t), MOUNT, xy, radius)[0]
    odom = _odometry_poses(np.zeros(3), speed, omega, np.append(t, t_f))
    rel = between(odom[-1], odom[:-1])
    truth = pose_at(np.array([t_f]))[0]
    pose, cov, ok = batch_ml_fix(truth + [0.05, -0.04, 0.02], z, xy, radius, rel, MOUNT, 1e-8)
    assert ok
    np.testing.assert_allclose(pose[:2], truth[:2], atol=1e-9)
    assert abs(angle_diff(pose[2], truth[2])) < 1e-10
    assert np.all(np.linalg.eigvalsh(cov) > 0)


def test_batch_ml_flags_unobservable() -> None:
    xy = np.array([[5.0, 0.0], [5.0, 0.0]])
    _, _, ok = batch_ml_fix(np.zeros(3), np.zeros(2), xy, np.zeros(2), np.zeros((2, 3)), np.zeros(3), 1e-8)
    assert not ok


def _moving_errors(lab: WorldMap, method: str, speed: float, omega: float, **kwargs) -> np.ndarray:
    gon = Goniometer(pulses_per_rev=FINE_PULSES, mount=tuple(MOUNT))
    start = np.array([4.0, 3.0, 0.2])
    pose_at = arc_pose_at(start, speed, omega)
    est = make_estimator(
        method,
        lab,
        MOUNT,
        pulses_per_rev=FINE_PULSES,
        map_std=0.0,
        odometry_noise=OdometryNoise(0.0, 0.0, 0.0),
        initial_pose=start + [0.004, -0.003, 0.002],
        initial_covariance=np.diag([0.01, 0.01, 0.005]) ** 2,
        **kwargs,
    )
    t, x, _ = feed(est, lab, gon, pose_at, speed, omega, 2.0)
    late = t > 1.0
    truth = pose_at(t[late])
    return np.column_stack([np.hypot(*(x[late, :2] - truth[:, :2]).T), np.abs(angle_diff(x[late, 2], truth[:, 2]))])


@pytest.mark.parametrize("method", ["angle_propagation", "batch_ml"])
@pytest.mark.parametrize(("speed", "omega"), [(1.0, 0.0), (2.0, 0.25)])
def test_exact_recovery_without_noise_at_constant_velocity(
    lab: WorldMap, method: str, speed: float, omega: float
) -> None:
    err = _moving_errors(lab, method, speed, omega)
    assert err[:, 0].max() < 1e-6
    assert err[:, 1].max() < 1e-7


def test_angle_propagation_with_relative_angles_is_exact_too(lab: WorldMap) -> None:
    err = _moving_errors(lab, "angle_propagation", 1.0, 0.2, triangulation_method="relative_angles")
    assert err[:, 0].max() < 1e-6


def test_naive_fix_degrades_with_speed(lab: WorldMap) -> None:
    slow = _moving_errors(lab, "naive", 0.2, 0.0)[:, 0].max()
    fast = _moving_errors(lab, "naive", 2.0, 0.0)[:, 0].max()
    assert fast > 1e-2  # centimetres at 2 m/s: the bearings are 1/8 s apart
    assert fast > 5.0 * slow


def test_naive_is_exact_at_standstill(lab: WorldMap) -> None:
    err = _moving_errors(lab, "naive", 0.0, 0.0)
    assert err[:, 0].max() < 1e-6


def test_bad_triangulation_method_rejected(lab: WorldMap) -> None:
    with pytest.raises(ValueError, match="triangulation_method"):
        make_estimator("angle_propagation", lab, MOUNT, triangulation_method="total")


def test_near_critical_circle() -> None:
    from agvnav.positioning.fix_switch import near_critical_circle

    R = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    assert near_critical_circle(R, [0.0, -1.0], 0.1)
    assert near_critical_circle(R, [0.0, -0.95], 0.1)
    assert not near_critical_circle(R, [0.0, 0.0], 0.1)
    assert not near_critical_circle(np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]), [0.0, 1.0], 0.1)


def test_relative_angles_near_critical_circle_falls_back_to_absolute(
    lab: WorldMap, monkeypatch: pytest.MonkeyPatch
) -> None:
    from agvnav.positioning import dynamic

    used: list[str] = []
    real = dynamic._triangulate_head

    def spy(xy, z, heading, method):  # type: ignore[no-untyped-def]
        used.append(method)
        return real(xy, z, heading, method)

    monkeypatch.setattr(dynamic, "_triangulate_head", spy)
    err = _moving_errors(
        lab, "angle_propagation", 0.5, 0.05, triangulation_method="relative_angles", critical_margin=0.5
    )
    assert {"relative_angles", "absolute_angles"} <= set(used)  # both, depending on the triple's circle
    assert err[:, 0].max() < 1e-6
