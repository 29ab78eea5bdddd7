"""The EKF's odometry calibration errors as consider parameters (issue 12).

* the scalar kernels (:func:`agvnav.positioning._fast.steered_noise`,
  ``calibration_predict``, ``calibration_update``) against the vectorised model
  (:class:`agvnav.odometry.SteeredOdometryNoise` through ``motion_covariance`` and
  ``calibration_jacobian``) and against the augmented transition ``[[F, W], [0, I]]``;
* the estimator over a drive against an augmented-state Schmidt filter (state
  ``[pose, survey errors, radius scale, steering offset]``, gain zero on everything but
  the pose, Joseph form on the whole covariance): same pose, ``P`` and ``P_xc`` to 1e-9;
* NEES by Monte Carlo on a synthetic tricycle drive whose radius scale error and steering
  offset are drawn per run from the prior: consistent with the consider parameters, far
  above the band without them (the band can be left).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _drive import arc_pose_at
from scipy.stats import chi2

from agvnav.geometry import angle_diff, wrap_angle
from agvnav.odometry import calibration_jacobian, integrate_pose, motion_covariance, pose_jacobian, steered_noise
from agvnav.positioning import _fast
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.ekf import EkfEstimator
from agvnav.positioning.integrity import IntegrityLimits
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import load_builtin_map

MOUNT = np.array([0.3, 0.0, 0.0])
L = 1.0


@pytest.mark.parametrize("model", ["tricycle", "tricycle_rear"])
@pytest.mark.parametrize("seed", range(4))
def test_steered_noise_kernel_matches_the_model(model: str, seed: int) -> None:
    rng = np.random.default_rng(seed)
    noise = steered_noise(model, 1e-4, L, 1e-3, 0.02, 0.003, 0.004)
    pose = np.array([*rng.normal(size=2), rng.uniform(-math.pi, math.pi)])
    s, g = rng.uniform(-0.3, 0.3), rng.uniform(-1.2, 1.2)
    dd, dth = (s * math.cos(g), s * math.sin(g) / L) if model == "tricycle" else (s, s * math.tan(g) / L)
    Q, W = _fast.steered_noise(float(pose[2]), dd, dth, model == "tricycle", L, noise.slip_k,
                               noise.steering_std**2 * noise.step_m)
    np.testing.assert_allclose(np.reshape(Q, (3, 3)), motion_covariance(pose, dd, dth, noise), rtol=1e-12,
                               atol=1e-20)
    np.testing.assert_allclose(np.reshape(W, (3, 2)), calibration_jacobian(pose, dd, dth, noise), rtol=1e-12,
                               atol=1e-18)


@pytest.mark.parametrize("seed", range(4))
def test_calibration_predict_and_update_match_the_augmented_form(seed: int) -> None:
    rng = np.random.default_rng(10 + seed)
    A = rng.normal(size=(5, 5)) * 0.01
    Pa = A @ A.T
    cvar = (rng.uniform(1e-6, 1e-5), rng.uniform(1e-6, 1e-5))
    Pa[3:, 3:] = np.diag(cvar)
    Pa += 1e-6 * np.eye(5)
    Pa[3:, 3:] = np.diag(cvar)
    f02, f12 = rng.normal(size=2) * 0.1
    F = np.eye(3)
    F[0, 2], F[1, 2] = f02, f12
    W = rng.normal(size=(3, 2)) * 0.1
    Q = np.diag([1e-6, 2e-6, 3e-7])
    Phi = np.eye(5)
    Phi[:3, :3], Phi[:3, 3:] = F, W
    ref = Phi @ Pa @ Phi.T
    ref[:3, :3] += Q
    P1 = _fast.predict_covariance(tuple(Pa[:3, :3].ravel()), f02, f12, tuple(Q.ravel()))
    P2, X2 = _fast.calibration_predict(P1, tuple(Pa[:3, 3:].ravel()), f02, f12, tuple(W.ravel()), cvar)
    np.testing.assert_allclose(np.reshape(P2, (3, 3)), ref[:3, :3], rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(np.reshape(X2, (3, 2)), ref[:3, 3:], rtol=1e-12, atol=1e-18)
    K, H = rng.normal(size=3), rng.normal(size=3)
    X3 = _fast.calibration_update(X2, tuple(K), tuple(H))
    np.testing.assert_allclose(np.reshape(X3, (3, 2)), (np.eye(3) - np.outer(K, H)) @ ref[:3, 3:], rtol=1e-12,
                               atol=1e-18)


def _true_drive(eps: float, beta: float, g_meas: float, s_meas: float) -> tuple[float, float]:
    """True body twist increment of a front-drive tricycle: wheel ``(1 + eps) s``, angle ``g + beta``."""
    s, g = (1.0 + eps) * s_meas, g_meas + beta
    return s * math.cos(g), s * math.sin(g) / L


def _augmented_reference(seed: int, seconds: float):  # type: ignore[no-untyped-def]
    """The estimator and an augmented-state Schmidt filter driven side by side; their final states."""
    world = load_builtin_map("lab")
    n = world.reflector_xy.shape[0]
    std, sigma = 0.003, 2e-4
    noise = steered_noise("tricycle", 1e-4, L, math.radians(0.05), 0.01, 0.003, math.radians(0.2))
    rng = np.random.default_rng(seed)
    start = np.array([6.0, 3.0, 0.3])
    P0 = np.diag([0.01, 0.01, 0.005]) ** 2
    x0 = start + rng.multivariate_normal(np.zeros(3), P0)
    est = EkfEstimator(world, MOUNT, bearing_std=sigma, bearing_offset=0.0, map_std=std, odometry_noise=noise,
                       initial_pose=x0, initial_covariance=P0, integrity=IntegrityLimits(enabled=False))
    m = 3 + 2 * n + 2
    Pa = np.zeros((m, m))
    Pa[:3, :3] = P0
    Pa[3:-2, 3:-2] = std**2 * np.eye(2 * n)
    Pa[-2:, -2:] = noise.calibration_covariance()
    x = x0.copy()
    gon = Goniometer(pulses_per_rev=2**30, mount=tuple(MOUNT))
    s_rate, g = 0.4, 0.3
    speed, omega = _true_drive(0.003, math.radians(0.2), g, s_rate)
    refl = gon.scan(world, arc_pose_at(start, speed, omega), 0.0, seconds, None)
    z = refl.bearing + rng.normal(0.0, sigma, refl.bearing.shape)
    est.predict(0.0, 0.0, 0.0)
    last, used = 0.0, 0
    for t, zk in zip(refl.t.tolist(), z.tolist(), strict=True):
        s = s_rate * (t - last)
        dd, dth = s * math.cos(g), s * math.sin(g) / L
        est.predict(t, dd, dth)
        Phi = np.eye(m)
        Phi[:3, :3] = pose_jacobian(x, dd, dth)
        Phi[:3, -2:] = calibration_jacobian(x, dd, dth, noise)
        Pa = Phi @ Pa @ Phi.T
        Pa[:3, :3] += motion_covariance(x, dd, dth, noise)
        x = integrate_pose(x, dd, dth)
        x[2] = wrap_angle(x[2])
        last = t
        if est.update(t, zk):
            j = est.last_reflector
            h, H, _ = bearing_model(x, MOUNT, world.reflector_xy[j], world.reflector_radius[j])
            Ha = np.zeros(m)
            Ha[:3] = H
            Ha[3 + 2 * j: 5 + 2 * j] = -H[:2]
            S = Ha @ Pa @ Ha + sigma**2
            K = Pa @ Ha / S
            K[3:] = 0.0  # consider: no gain on the survey or calibration errors
            A = np.eye(m) - np.outer(K, Ha)
            Pa = A @ Pa @ A.T + sigma**2 * np.outer(K, K)
            Pa = 0.5 * (Pa + Pa.T)
            x = x + K[:3] * float(wrap_angle(zk - h))
            x[2] = wrap_angle(x[2])
            used += 1
    return est, x, Pa, used


def test_estimator_matches_the_augmented_state_reference() -> None:
    """A 6 s curve past the lab's reflectors (~300 bearings): pose, ``P``, ``P_xp`` and ``P_xc`` to 1e-9."""
    est, x, Pa, used = _augmented_reference(4, 6.0)
    assert used > 200
    np.testing.assert_allclose(est.pose, x, rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(est.covariance, Pa[:3, :3], rtol=1e-9, atol=1e-16)
    np.testing.assert_allclose(est.calibration_cross_covariance, Pa[:3, -2:], rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(est.cross_covariance, Pa[:3, 3:-2], rtol=1e-6, atol=1e-14)
    assert np.abs(est.calibration_cross_covariance).max() > 1e-7  # the calibration is really carried


def _odometry(est: EkfEstimator, rng: np.random.Generator, t: float, last: float,
              read: tuple[float, float, float, float, float, float]) -> float:
    """One odometry reading from ``last`` to ``t`` (s) with the truth's errors drawn; returns ``t``."""
    eps, s_rate, g, slip_k, steer, step_m = read
    s_true = (1.0 + eps) * s_rate * (t - last)
    s_m = (s_true - math.sqrt(slip_k * s_true) * rng.standard_normal()) / (1.0 + eps)
    g_m = g - steer * math.sqrt(step_m / s_true) * rng.standard_normal()
    est.predict(t, s_m * math.cos(g_m), s_m * math.sin(g_m) / L)
    return t


def _nees_runs(n_runs: int, seconds: float, seed: int, consider: bool, at_reflections: bool = True) -> np.ndarray:
    """NEES ``(n_runs, samples)`` on a front tricycle's curve, radius scale and steering offset drawn per run.

    The truth drives a constant arc (wheel ``(1 + eps) s``, angle ``g + beta``); the filter
    reads ``s`` and ``g`` with random slip (variance ``slip_k |s|``) and steering errors
    (variance ``steering_std^2 step_m / |s|``, white in the distance) drawn per increment.
    Odometry is read every ``dt`` and, with ``at_reflections``, at every reflection (else the
    estimator extrapolates the last increment's rate to the reflection).
    """
    world = load_builtin_map("lab")
    gon = Goniometer(pulses_per_rev=2**30, mount=tuple(MOUNT))
    sigma, dt, s_rate, g = 2e-4, 0.05, 0.3, 0.15
    eps_std, beta_std, slip_k, steer = 0.003, math.radians(0.2), 1e-4, math.radians(0.05)
    step_m = s_rate * dt
    noise = steered_noise("tricycle", slip_k, L, steer, step_m, eps_std if consider else 0.0,
                          beta_std if consider else 0.0)
    out = []
    for k in range(n_runs):
        rng = np.random.default_rng([seed, k])
        eps, beta = rng.normal(0.0, eps_std), rng.normal(0.0, beta_std)
        start = np.array([3.0, 2.0, 0.1])
        P0 = np.diag([0.01, 0.01, 0.003]) ** 2
        est = EkfEstimator(world, MOUNT, bearing_std=sigma, bearing_offset=0.0, map_std=0.0, odometry_noise=noise,
                           initial_pose=start + rng.multivariate_normal(np.zeros(3), P0), initial_covariance=P0,
                           integrity=IntegrityLimits(enabled=False))
        speed, omega = _true_drive(eps, beta, g, s_rate)
        pose_at = arc_pose_at(start, speed, omega)
        refl = gon.scan(world, pose_at, 0.0, seconds, None)
        z = refl.bearing + rng.normal(0.0, sigma, refl.bearing.shape)
        est.predict(0.0, 0.0, 0.0)
        read = (eps, s_rate, g, slip_k, steer, step_m)
        j, nees, last = 0, [], 0.0
        for i, t in enumerate(np.arange(dt, seconds + 1e-9, dt)):
            while j < len(refl) and refl.t[j] <= t:
                if at_reflections and refl.t[j] > last:
                    last = _odometry(est, rng, float(refl.t[j]), last, read)
                est.update(float(refl.t[j]), float(z[j]))
                j += 1
            last = _odometry(est, rng, float(t), last, read)
            if i % 10 == 9:
                truth = pose_at(np.array([t]))[0]
                e = est.pose - truth
                e[2] = angle_diff(est.pose[2], truth[2])
                nees.append(float(e @ np.linalg.solve(est.covariance, e)))
        out.append(nees)
    return np.array(out)


def _band(n: int) -> tuple[float, float]:
    return float(chi2.ppf(0.025, 3 * n) / n), float(chi2.ppf(0.975, 3 * n) / n)


def test_nees_with_drawn_calibration_errors_small() -> None:
    """24 runs of 8 s: the run-averaged NEES inside the band; without the consider parameters far above it."""
    nees = _nees_runs(24, 8.0, 31, consider=True).mean(axis=1)
    lo, hi = _band(nees.size)
    assert lo < nees.mean() < hi
    blind = _nees_runs(24, 8.0, 31, consider=False).mean(axis=1)
    assert blind.mean() > 2.0 * hi


@pytest.mark.slow
def test_nees_with_drawn_calibration_errors_large() -> None:
    nees = _nees_runs(200, 12.0, 32, consider=True).mean(axis=1)
    lo, hi = _band(nees.size)
    assert lo < nees.mean() < hi
