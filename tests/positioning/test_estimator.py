"""Streaming interface: time order, start-up search, ambiguity, dead reckoning, factory, odometry bookkeeping."""

from __future__ import annotations

import numpy as np
import pytest
from _drive import arc_pose_at, feed

from agvnav.geometry import angle_diff
from agvnav.odometry import OdometryNoise, integrate_pose
from agvnav.positioning.estimator import METHODS, StreamingEstimator, make_estimator
from agvnav.positioning.integrity import IntegrityLimits
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import Reflector, WorldMap, load_builtin_map

MOUNT = np.array([0.6, 0.0, 0.0])


@pytest.fixture(scope="module")
def lab() -> WorldMap:
    return load_builtin_map("lab")


@pytest.mark.parametrize("method", METHODS)
def test_out_of_order_input_raises_naming_times(lab: WorldMap, method: str) -> None:
    est = make_estimator(method, lab, MOUNT, initial_pose=[4.0, 3.0, 0.0])
    est.predict(1.0, 0.0, 0.0)
    with pytest.raises(ValueError, match=r"t=0\.5.*t=1\.0"):
        est.update(0.5, 0.1)
    with pytest.raises(ValueError, match="time order"):
        est.predict(0.9, 0.0, 0.0)


def test_factory_names_and_errors(lab: WorldMap) -> None:
    for method in METHODS:
        est = make_estimator(method, lab, MOUNT)
        assert est.method == method and isinstance(est, StreamingEstimator)
    with pytest.raises(ValueError, match="unknown positioning method 'kalman'"):
        make_estimator("kalman", lab, MOUNT)
    with pytest.raises(ValueError, match="world"):
        make_estimator("ekf")
    with pytest.raises(ValueError, match="mount"):
        make_estimator("ekf", lab, [0.0, 0.0])
    with pytest.raises(ValueError, match="bearing"):
        make_estimator("ekf", lab, MOUNT, initial_pose=[1.0, 1.0, 0.0]).update(0.0, float("nan"))


@pytest.mark.parametrize("method", METHODS)
def test_startup_search_at_standstill_then_tracking(lab: WorldMap, method: str) -> None:
    truth = np.array([12.0, 4.0, 2.5])
    gon = Goniometer(mount=tuple(MOUNT), spurious_rate=1.0, p_miss=0.05)
    est = make_estimator(method, lab, MOUNT)
    assert est.status == "initialising" and np.all(np.isnan(est.pose))
    feed(est, lab, gon, arc_pose_at(truth, 0.0, 0.0), 0.0, 0.0, 1.0, rng=np.random.default_rng(5))
    assert est.status == "tracking"
    assert est.last_search is not None and est.last_search.found
    assert np.hypot(*(est.pose[:2] - truth[:2])) < 3e-3
    assert abs(angle_diff(est.pose[2], truth[2])) < 1e-3
    assert est.n_accepted > 10
    assert np.all(np.linalg.eigvalsh(est.covariance) > 0)


def test_startup_reports_ambiguity_on_symmetric_layout() -> None:
    square = WorldMap(
        tuple(
            Reflector(f"S{i}", 5 + 5 * np.cos(a), 5 + 5 * np.sin(a), 0.04)
            for i, a in enumerate(np.arange(4) * np.pi / 2)
        )
    )
    gon = Goniometer(mount=tuple(MOUNT))
    est = make_estimator("ekf", square, MOUNT)
    feed(est, square, gon, arc_pose_at(np.array([6.0, 5.5, 0.3]), 0.0, 0.0), 0.0, 0.0, 0.6)
    assert est.status == "initialising"  # never guesses
    assert est.last_search.ambiguous and len(est.last_search.alternatives) == 4
    assert np.all(np.isnan(est.pose))


def test_startup_waits_for_standstill(lab: WorldMap) -> None:
    gon = Goniometer(mount=tuple(MOUNT))
    est = make_estimator("ekf", lab, MOUNT)
    feed(est, lab, gon, arc_pose_at(np.array([4.0, 3.0, 0.0]), 1.0, 0.0), 1.0, 0.0, 0.5)
    assert est.status == "initialising" and est.last_search is None


def test_dead_reckoning_when_no_reflector_in_view(lab: WorldMap) -> None:
    start = np.array([4.0, 3.0, 0.1])
    est = make_estimator("ekf", lab, MOUNT, initial_pose=start, dead_reckoning_after=0.5)
    gon = Goniometer(mount=tuple(MOUNT), max_range=0.5)  # blind: nothing within range
    t, x, P = feed(est, lab, gon, arc_pose_at(start, 1.0, 0.2), 1.0, 0.2, 2.0)
    assert est.status == "dead_reckoning" and est.n_accepted == 0
    trace = np.trace(P, axis1=1, axis2=2)
    assert np.all(np.diff(trace) > 0)  # the covariance keeps growing
    steps = np.hypot(*np.diff(x[:, :2], axis=0).T)
    np.testing.assert_allclose(steps, 0.02, rtol=1e-6)  # no jump: the pose follows the odometry
    assert t[0] < 0.5 and est.status == "dead_reckoning"


@pytest.mark.parametrize("method", METHODS)
def test_recovers_tracking_after_blind_stretch(lab: WorldMap, method: str) -> None:
    start = np.array([4.0, 3.0, 0.1])
    pose_at = arc_pose_at(start, 0.5, 0.0)
    est = make_estimator(method, lab, MOUNT, initial_pose=start, dead_reckoning_after=0.4)
    feed(est, lab, Goniometer(mount=tuple(MOUNT), max_range=0.5), pose_at, 0.5, 0.0, 1.0)
    assert est.status == "dead_reckoning"
    refl = Goniometer(mount=tuple(MOUNT)).scan(lab, pose_at, 1.0, 1.6)
    for k in range(1, 31):
        t = 1.0 + 0.02 * k
        for tr, b in zip(
            refl.t[(refl.t > t - 0.02) & (refl.t <= t)], refl.bearing[(refl.t > t - 0.02) & (refl.t <= t)], strict=False
        ):
            est.update(float(tr), float(b))
        est.predict(t, 0.01, 0.0)
    assert est.status == "tracking"
    tolerance = 3e-2 if method == "naive" else 5e-3  # naive ignores the 0.5 m/s motion within a sweep
    assert np.hypot(*(est.pose[:2] - pose_at(np.array([1.6]))[0, :2])) < tolerance


@pytest.mark.parametrize("constant_rate", [True, False])
def test_reflections_between_odometry_samples_keep_the_odometric_path(lab: WorldMap, constant_rate: bool) -> None:
    # (rejected) reflections between samples extrapolate the odometry; the next sample deducts
    # the advance, so nothing is counted twice: exact at a constant rate, and the heading
    # (a sum of increments) exact always
    est = make_estimator(  # integrity off: the lock-out inflation would make it lost (then nothing is rejected)
        "ekf",
        lab,
        MOUNT,
        initial_pose=[4.0, 3.0, 0.0],
        odometry_noise=OdometryNoise(0, 0, 0),
        max_range=0.5,
        integrity=IntegrityLimits(enabled=False),
    )
    est.predict(0.0, 0.0, 0.0)
    pose = np.array([4.0, 3.0, 0.0])
    rng = np.random.default_rng(0)
    for k in range(1, 20):
        t = 0.1 * k
        est.update(t - 0.03, 3.0)  # every reflector beyond max_range: rejected
        est.update(t - 0.01, 3.0)
        dd, dth = (0.1, 0.05) if constant_rate else (rng.uniform(0.0, 0.2), rng.uniform(-0.1, 0.1))
        est.predict(t, dd, dth)
        pose = integrate_pose(pose, dd, dth)
    assert abs(angle_diff(est.pose[2], pose[2])) < 1e-12
    if constant_rate:
        np.testing.assert_allclose(est.pose[:2], pose[:2], atol=1e-12)
    assert est.n_rejected == 38 and est.n_accepted == 0


def test_update_many_matches_sequential_updates(lab: WorldMap) -> None:
    start = np.array([4.0, 3.0, 0.1])
    refl = Goniometer(mount=tuple(MOUNT)).scan(lab, arc_pose_at(start, 0.0, 0.0), 0.0, 0.25)
    a = make_estimator("ekf", lab, MOUNT, initial_pose=start)
    b = make_estimator("ekf", lab, MOUNT, initial_pose=start)
    accepted = a.update_many(refl.t, refl.bearing)
    for t, z in zip(refl.t, refl.bearing, strict=True):
        b.update(float(t), float(z))
    np.testing.assert_array_equal(a.pose, b.pose)
    assert accepted.sum() == a.n_accepted == b.n_accepted > 0
    with pytest.raises(ValueError, match="same shape"):
        a.update_many([1.0, 2.0], [0.1])


def test_one_sweep_never_claims_a_reflector_twice(lab: WorldMap) -> None:
    start = np.array([4.0, 3.0, 0.1])
    refl = Goniometer(mount=tuple(MOUNT)).scan(lab, arc_pose_at(start, 0.0, 0.0), 0.0, 0.124)
    est = make_estimator("ekf", lab, MOUNT, initial_pose=start)
    for t, z in zip(refl.t, refl.bearing, strict=True):
        assert est.update(float(t), float(z))
        assert not est.update(float(t) + 1e-4, float(z))  # an echo in the same sweep: rejected


def test_overconfident_start_recovers_by_covariance_inflation(lab: WorldMap) -> None:
    truth = np.array([4.0, 3.0, 0.1])
    est = make_estimator(
        "ekf", lab, MOUNT, initial_pose=truth + [0.04, -0.03, 0.01], initial_covariance=np.diag([1e-3, 1e-3, 1e-4]) ** 2
    )
    feed(est, lab, Goniometer(mount=tuple(MOUNT)), arc_pose_at(truth, 0.0, 0.0), 0.0, 0.0, 3.0)
    assert est.n_inflations > 0  # the gates first rejected the true reflectors: lock-out detected
    assert est.status == "tracking"
    assert np.hypot(*(est.pose[:2] - truth[:2])) < 2e-3


def test_inflation_is_bounded_when_everything_is_rejected(lab: WorldMap) -> None:
    est = make_estimator("ekf", lab, MOUNT, initial_pose=[4.0, 3.0, 0.0], max_range=0.5)
    est.predict(0.0, 0.0, 0.0)
    for k in range(1, 2000):
        est.update(0.01 * k, 0.3)
    P = est.covariance
    assert np.all(np.isfinite(P)) and P[0, 0] + P[1, 1] < 1.0
