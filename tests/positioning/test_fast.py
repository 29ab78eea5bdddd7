"""The scalar fast paths of the estimators' inner loop equal the vectorised kernels to 1e-12."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.odometry import OdometryNoise, integrate_pose, motion_covariance, pose_jacobian
from agvnav.positioning import _fast, make_estimator
from agvnav.positioning.bearing_gate import gate_reflection
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.ekf import ekf_predict, ekf_update
from agvnav.positioning.gating import GateSpec
from agvnav.world import load_builtin_map

TOL = 1e-12


def _spd(rng: np.random.Generator, scale: float = 0.05) -> np.ndarray:
    A = rng.normal(0.0, scale, (3, 3))
    return A @ A.T + 1e-6 * np.eye(3)


def _flat(P: np.ndarray) -> tuple[float, ...]:
    return tuple(P.reshape(9).tolist())


@pytest.mark.parametrize("seed", range(20))
def test_twist_step_without_lateral_and_covariance_match_odometry_kernels(seed: int) -> None:
    rng = np.random.default_rng(seed)
    pose = rng.uniform([-10, -10, -math.pi], [10, 10, math.pi])
    dd = rng.normal(0.0, 0.05)
    dth = rng.normal(0.0, 0.05) if seed % 3 else rng.normal(0.0, 1e-6)  # both sinc branches
    noise = OdometryNoise(0.002, 0.004, 0.003)
    P = _spd(rng)
    x, y, psi, f02, f12 = _fast.twist_step(*pose.tolist(), dd, dth)
    np.testing.assert_allclose([x, y, psi], integrate_pose(pose, dd, dth, rule="arc"), rtol=0, atol=TOL)
    F = pose_jacobian(pose, dd, dth)
    np.testing.assert_allclose([f02, f12], [F[0, 2], F[1, 2]], rtol=0, atol=TOL)
    Q = _fast.process_noise(pose[2], dd, dth, noise.k_d, noise.k_dtheta, noise.k_theta)
    Q_ref = motion_covariance(pose, dd, dth, noise)
    np.testing.assert_allclose(np.reshape(Q, (3, 3)), Q_ref, rtol=0, atol=TOL)
    P_new = _fast.predict_covariance(_flat(P), f02, f12, Q)
    _, P_ref = ekf_predict(pose, P, F, Q_ref)
    np.testing.assert_allclose(np.reshape(P_new, (3, 3)), P_ref, rtol=0, atol=TOL)


@pytest.mark.parametrize("seed", range(20))
def test_joseph_update_matches_ekf_update(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    x = rng.uniform([-10, -10, -math.pi], [10, 10, math.pi])
    P = _spd(rng)
    H = rng.normal(0.0, 1.0, 3)
    R = 10.0 ** rng.uniform(-8, -4)
    innovation = rng.normal(0.0, 0.01)
    xn, Pn = _fast.joseph_update(tuple(x.tolist()), _flat(P), innovation, tuple(H.tolist()), R)
    x_ref, P_ref = ekf_update(x, P, innovation, H, R)
    np.testing.assert_allclose(xn, x_ref, rtol=0, atol=TOL)
    np.testing.assert_allclose(np.reshape(Pn, (3, 3)), P_ref, rtol=0, atol=TOL)


@pytest.mark.parametrize("seed", range(20))
def test_bearing_row_matches_bearing_model(seed: int) -> None:
    rng = np.random.default_rng(200 + seed)
    pose = rng.uniform([0, 0, -math.pi], [20, 12, math.pi])
    mount = rng.uniform([-0.5, -0.3, -0.2], [0.5, 0.3, 0.2])
    xy = rng.uniform([0, 0], [20, 12], (6, 2))
    radius = rng.uniform(0.0, 0.05, 6)
    h, H, d = bearing_model(pose, mount, xy, radius)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    px = pose[0] + c * mount[0] - s * mount[1]
    py = pose[1] + s * mount[0] + c * mount[1]
    dpx, dpy = -s * mount[0] - c * mount[1], c * mount[0] - s * mount[1]
    for j in range(6):
        row = _fast.bearing_row(px, py, pose[2], mount[2], dpx, dpy, xy[j, 0], xy[j, 1], radius[j])
        assert abs(_fast.wrap(row[0] - h[j])) <= TOL
        np.testing.assert_allclose(row[1:4], H[j], rtol=1e-12, atol=TOL)
        assert row[4] == pytest.approx(d[j], abs=TOL)


def test_bearing_row_on_the_reflector_centre_is_finite() -> None:
    h, H, d = bearing_model([1.0, 2.0, 0.3], [0.0, 0.0, 0.0], [1.0, 2.0], 0.04)
    row = _fast.bearing_row(1.0, 2.0, 0.3, 0.0, 0.0, 0.0, 1.0, 2.0, 0.04)
    assert d == row[4] == 0.0
    assert abs(_fast.wrap(row[0] - float(h))) <= TOL
    np.testing.assert_array_equal(row[1:4], H)


@pytest.mark.parametrize("seed", range(30))
def test_gate_one_matches_gate_reflection(seed: int) -> None:
    """Same decision, innovation, NIS, Jacobian and variances, with exclusions and range limits."""
    rng = np.random.default_rng(300 + seed)
    world = load_builtin_map("lab")
    xy, radius = world.reflector_xy, world.reflector_radius
    pose = rng.uniform([2, 2, -math.pi], [18, 10, math.pi])
    mount = (0.3, 0.05, 0.01)
    P = _spd(rng, scale=[0.002, 0.01, 0.05][seed % 3])
    h, _, _ = bearing_model(pose, mount, xy, radius)
    j_true = int(rng.integers(xy.shape[0]))
    z = float(_fast.wrap(h[j_true] + rng.normal(0.0, 3e-3)))
    excluded = rng.random(xy.shape[0]) < 0.2
    max_range = float(rng.choice([np.inf, 8.0]))
    kwargs = {"max_range": max_range, "excluded": excluded, "gate": 10.8, "map_std": 0.002}
    ref = gate_reflection(z, pose, P, mount, xy, radius, 1e-7, **kwargs)
    spec = GateSpec(bearing_var=1e-7, max_range=max_range, gate=10.8, map_std=0.002, sweep=0.1)
    claimed = [1.0 if e else -math.inf for e in excluded]  # claimed 0.05 s before t = 1.05: excluded
    rows = _fast.reflector_rows(xy, radius)
    got = _fast.gate_one(z, tuple(pose.tolist()), _flat(P), mount, rows, spec, claimed, 1.05)
    assert got[0] == ref.index and got[3] == ref.n_in_gate
    if ref.index >= 0:
        np.testing.assert_allclose(got[1:3], [ref.innovation, ref.nis], rtol=1e-10, atol=TOL)
        np.testing.assert_allclose(got[4], ref.H, rtol=1e-12, atol=TOL)
        np.testing.assert_allclose(got[5:], [ref.S, ref.R], rtol=1e-12, atol=0)


def test_estimator_fast_path_matches_the_kernels_over_a_drive() -> None:
    """The EKF driven by the fast paths equals a replay with the vectorised kernels.

    Without a survey error (``map_std=0``) the EKF's Schmidt-Kalman update is the plain
    Joseph update of :func:`ekf_update`; with one, ``tests/positioning/test_consider.py``
    checks it against the augmented-state form.
    """
    world = load_builtin_map("lab")
    mount = np.array([0.3, 0.0, 0.0])
    x0 = np.array([6.0, 3.0, 0.4])
    P0 = np.diag([0.01, 0.01, 0.003]) ** 2
    est = make_estimator("ekf", world, mount, initial_pose=x0, initial_covariance=P0, map_std=0.0)
    noise = est.odometry_noise
    x, P = x0.copy(), P0.copy()
    t = 0.0
    rng = np.random.default_rng(7)
    for k in range(200):
        t += 0.01
        dd, dth = 0.004, 0.002 * math.sin(0.05 * k)
        F, Q = pose_jacobian(x, dd, dth), motion_covariance(x, dd, dth, noise)
        x, P = ekf_predict(integrate_pose(x, dd, dth), P, F, Q)
        est.predict(t, dd, dth)
        if k % 4 == 3:
            j = k // 4 % world.reflector_xy.shape[0]
            h, _, _ = bearing_model(x, mount, world.reflector_xy[j], world.reflector_radius[j])
            z = float(h) + rng.normal(0.0, 1e-4) - est.bearing_offset
            accepted = est.update(t, z)
            ref = gate_reflection(
                float(_fast.wrap(z + est.bearing_offset)), x, P, mount, world.reflector_xy,
                world.reflector_radius, est.bearing_std**2, max_range=est.max_range, map_std=est.map_std,
            )
            assert accepted == (ref.index >= 0)
            if accepted:
                x, P = ekf_update(x, P, ref.innovation, ref.H, ref.R)
        np.testing.assert_allclose(est.pose, x, rtol=0, atol=1e-11)
        np.testing.assert_allclose(est.filter_covariance, P, rtol=0, atol=1e-14)
    assert est.n_accepted >= 40  # the update path was exercised


@pytest.mark.parametrize("seed", range(10))
def test_surely_outside_never_rejects_a_reflector_inside_the_gate(seed: int) -> None:
    """The cheap pre-test is a sound bound: when it says outside, the exact NIS is >= gate."""
    rng = np.random.default_rng(400 + seed)
    gate, var, map_std = 10.8, 1e-7, 0.002
    mount = rng.uniform([-0.6, -0.3, -0.2], [0.6, 0.3, 0.2])
    checked = 0
    for _ in range(200):
        pose = rng.uniform([0, 0, -math.pi], [20, 12, math.pi])
        xy = rng.uniform([0, 0], [20, 12], 2)
        radius = rng.choice([0.0, 0.04, 0.3])
        P = _spd(rng, scale=10.0 ** rng.uniform(-3, 0))
        _, H, d = bearing_model(pose, mount, xy, radius)
        if d <= radius:
            continue
        R = var + (map_std / d) ** 2
        S = float(H @ P @ H) + R
        y = rng.normal(0.0, math.sqrt(S) * rng.uniform(0.5, 20.0))  # around and beyond the gate threshold
        if _fast.surely_outside(y, float(d) ** 2, radius, R, float(np.trace(P)), math.hypot(*mount[:2]), gate):
            checked += 1
            assert y * y / S >= gate
    assert checked > 40
