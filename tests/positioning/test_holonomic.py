"""Holonomic odometry: the body-twist increment (dd, dtheta, dlateral) moves the pose by the SE(2) exponential."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chi2

from agvnav.kinematics.base import twist_step
from agvnav.odometry import OdometryNoise, motion_covariance
from agvnav.positioning import _fast, make_estimator
from agvnav.positioning.estimator import METHODS
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import load_builtin_map

finite = st.floats(-1.0, 1.0, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(
    pose=st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-math.pi, math.pi)),
    twist=st.tuples(finite, finite, st.floats(-3.0, 3.0)),
    dt=st.floats(1e-3, 0.5),
)
def test_twist_step_is_the_exact_exponential_of_a_constant_twist(pose: tuple, twist: tuple, dt: float) -> None:
    """Against agvnav.kinematics' exponential, and k sub-steps of the same twist equal one step."""
    vx, vy, w = twist
    got = _fast.twist_step(*pose, vx * dt, w * dt, vy * dt)
    ref = twist_step(np.array(pose), vx, vy, w, dt)
    np.testing.assert_allclose(got[:2], ref[:2], rtol=0, atol=1e-12)
    assert abs(_fast.wrap(got[2] - ref[2])) < 1e-12
    x, y, psi = pose
    for _ in range(7):
        x, y, psi = _fast.twist_step(x, y, psi, vx * dt / 7, w * dt / 7, vy * dt / 7)[:3]
    np.testing.assert_allclose([x, y], got[:2], rtol=0, atol=1e-11)
    assert abs(_fast.wrap(psi - got[2])) < 1e-11


def _numeric_jacobians(pose: np.ndarray, u: np.ndarray, eps: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Central differences of twist_step w.r.t. the pose (3x3) and the increment (dd, dtheta, dlateral) (3x3)."""

    def f(p: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.array(_fast.twist_step(p[0], p[1], p[2], v[0], v[1], v[2])[:3])

    F, G = np.zeros((3, 3)), np.zeros((3, 3))
    for i in range(3):
        e = np.zeros(3)
        e[i] = eps
        dF = f(pose + e, u) - f(pose - e, u)
        dG = f(pose, u + e) - f(pose, u - e)
        dF[2], dG[2] = _fast.wrap(dF[2]), _fast.wrap(dG[2])
        F[:, i], G[:, i] = dF / (2 * eps), dG / (2 * eps)
    return F, G


@pytest.mark.parametrize("seed", range(25))
def test_pose_jacobian_of_the_exponential_matches_numerical(seed: int) -> None:
    rng = np.random.default_rng(seed)
    pose = rng.uniform([-10, -10, -math.pi], [10, 10, math.pi])
    u = rng.normal(0.0, [0.3, 0.5, 0.3])  # dd, dtheta, dlateral
    _, _, _, f02, f12 = _fast.twist_step(*pose, *u)
    F_num, _ = _numeric_jacobians(pose, u)
    F = np.eye(3)
    F[0, 2], F[1, 2] = f02, f12
    np.testing.assert_allclose(F, F_num, rtol=0, atol=1e-8)


@pytest.mark.parametrize("seed", range(25))
def test_process_noise_is_the_increment_jacobian_to_leading_order(seed: int) -> None:
    """Q against G diag(var) G^T with the exponential's numerical increment Jacobian G.

    Q uses G at zero increment size (mid heading, sinc -> 1): the difference is of the
    order of the increment (|u| ~ 1e-2 here) relative to Q.
    """
    rng = np.random.default_rng(100 + seed)
    pose = rng.uniform([-10, -10, -math.pi], [10, 10, math.pi])
    dd, dth, dl = rng.normal(0.0, [0.01, 0.01, 0.01])
    k = OdometryNoise(2e-3, 4e-3, 3e-3)
    k_lat = 5e-3
    Q = np.reshape(_fast.process_noise(pose[2], dd, dth, k.k_d, k.k_dtheta, k.k_theta, dl, k_lat), (3, 3))
    _, G = _numeric_jacobians(pose, np.array([dd, dth, dl]))
    var = np.diag([k.k_d * abs(dd), k.k_dtheta * math.hypot(dd, dl) + k.k_theta * abs(dth), k_lat * abs(dl)])
    ref = G @ var @ G.T
    scale = np.sqrt(np.outer(np.diag(ref), np.diag(ref))) + 1e-300
    assert np.max(np.abs(Q - ref) / scale) < 0.05
    assert np.all(np.linalg.eigvalsh(Q) >= -1e-18)


@pytest.mark.parametrize("seed", range(10))
def test_without_lateral_the_prediction_is_seed_002s_and_continuous(seed: int) -> None:
    rng = np.random.default_rng(200 + seed)
    pose = rng.uniform([-10, -10, -math.pi], [10, 10, math.pi])
    dd, dth = rng.normal(0.0, 0.05, 2)
    k = OdometryNoise(2e-3, 4e-3, 3e-3)
    Q0 = _fast.process_noise(pose[2], dd, dth, k.k_d, k.k_dtheta, k.k_theta, 0.0, 5e-3)
    np.testing.assert_allclose(np.reshape(Q0, (3, 3)), motion_covariance(pose, dd, dth, k), rtol=0, atol=1e-15)
    Q_eps = _fast.process_noise(pose[2], dd, dth, k.k_d, k.k_dtheta, k.k_theta, 1e-12, 5e-3)
    np.testing.assert_allclose(Q_eps, Q0, rtol=0, atol=1e-13)
    step0 = _fast.twist_step(*pose, dd, dth, 0.0)
    step_eps = _fast.twist_step(*pose, dd, dth, 1e-15)
    np.testing.assert_allclose(step_eps, step0, rtol=0, atol=1e-14)


@pytest.mark.parametrize("method", METHODS)
def test_every_estimator_dead_reckons_a_sideways_drive(method: str) -> None:
    """predict(t, dd, dtheta, dlateral) of each method follows a constant twist exactly."""
    world = load_builtin_map("lab")
    x0 = np.array([5.0, 4.0, 0.7])
    est = make_estimator(method, world, (0.3, 0.0, 0.0), initial_pose=x0)
    vx, vy, w, dt = 0.1, -0.4, 0.15, 0.01
    for k in range(1, 301):
        est.predict(k * dt, vx * dt, w * dt, vy * dt)
    ref = twist_step(x0, vx, vy, w, 3.0)
    np.testing.assert_allclose(est.pose[:2], ref[:2], rtol=0, atol=1e-10)
    assert abs(_fast.wrap(est.pose[2] - ref[2])) < 1e-12


def test_lateral_increment_needs_a_finite_number() -> None:
    est = make_estimator("ekf", load_builtin_map("lab"), (0.0, 0.0, 0.0), initial_pose=[1.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="odometry increment"):
        est.predict(0.1, 0.0, 0.0, float("nan"))
    with pytest.raises(ValueError, match="k_lateral"):
        make_estimator("ekf", load_builtin_map("lab"), (0.0, 0.0, 0.0), k_lateral=-1.0)


def _mecanum_runs(k_lateral: float, runs: int = 300, steps: int = 100) -> np.ndarray:
    """NEES at the end of seeded dead-reckoning runs of a mecanum-like sideways drive.

    Truth: the exact exponential of the true constant twist. Odometry: the true increments
    plus the errors of the model the filter declares (K_D, K_Dtheta, K_theta and a lateral
    error of 4e-4 m^2/m); the filter is told ``k_lateral``.
    """
    world = load_builtin_map("lab")
    noise = OdometryNoise(1e-4, 2e-4, 1e-4)
    vx, vy, w, dt = 0.1, 0.5, 0.2, 0.02
    u = np.array([vx * dt, w * dt, vy * dt])
    std = np.sqrt([noise.k_d * u[0], noise.k_dtheta * math.hypot(u[0], u[2]) + noise.k_theta * u[1], 4e-4 * u[2]])
    x0 = np.array([5.0, 4.0, 0.3])
    P0 = np.diag([1e-6, 1e-6, 1e-7]) ** 2
    rng = np.random.default_rng(11)
    nees = np.empty(runs)
    truth_end = twist_step(x0, vx, vy, w, steps * dt)
    for i in range(runs):
        start = x0 + rng.normal(0.0, np.sqrt(np.diag(P0)))
        est = make_estimator("ekf", world, (0.0, 0.0, 0.0), initial_pose=start, initial_covariance=P0,
                             odometry_noise=noise, k_lateral=k_lateral)
        for k in range(1, steps + 1):
            dd, dth, dl = u + rng.normal(0.0, std)
            est.predict(k * dt, dd, dth, dl)
        e = est.pose - truth_end
        e[2] = _fast.wrap(e[2])
        nees[i] = e @ np.linalg.solve(est.covariance, e)
    return nees


def test_nees_of_a_sideways_drive_is_consistent() -> None:
    """Mean NEES within the 99.9 % chi-square band of 3 dof; a filter without the lateral term fails it."""
    runs = 300
    lo, hi = chi2.ppf([0.0005, 0.9995], 3 * runs) / runs
    consistent = _mecanum_runs(4e-4, runs)
    assert lo < consistent.mean() < hi
    overconfident = _mecanum_runs(0.0, runs)
    assert overconfident.mean() > 2 * hi


def test_ekf_tracks_a_sideways_drive_with_the_goniometer() -> None:
    """Closed-form truth, real reflections: the lateral odometry keeps the EKF on the truth."""
    world = load_builtin_map("lab")
    mount = (0.3, 0.0, 0.0)
    x0 = np.array([8.0, 4.0, 0.5])
    vx, vy, w = 0.05, 0.4, 0.05

    def pose_at(t: np.ndarray) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        return twist_step(np.broadcast_to(x0, t.shape + (3,)), vx, vy, w, t)

    gon = Goniometer(mount=mount)
    refl = gon.scan(world, pose_at, 0.0, 6.0)
    errors = {}
    for use_lateral in (True, False):
        est = make_estimator("ekf", world, mount, initial_pose=x0, initial_covariance=np.diag([0.01, 0.01, 0.003]) ** 2)
        est.predict(0.0, 0.0, 0.0)
        j, dt = 0, 0.02
        for k in range(1, 301):
            t = k * dt
            while j < len(refl) and refl.t[j] <= t:
                est.update(float(refl.t[j]), float(refl.bearing[j]))
                j += 1
            est.predict(t, vx * dt, w * dt, vy * dt if use_lateral else 0.0)
        errors[use_lateral] = float(np.hypot(*(est.pose[:2] - pose_at(6.0)[0, :2])))
    assert errors[True] < 3e-3
    assert errors[False] > 10 * errors[True]
