"""EKF: update formulae against the information form, Joseph symmetry, NEES consistency by Monte Carlo."""

from __future__ import annotations

import numpy as np
import pytest
from _drive import arc_pose_at, drive_nees, feed
from hypothesis import given
from hypothesis import strategies as st
from scipy.stats import chi2

from agvnav.geometry import angle_diff
from agvnav.odometry import OdometryNoise
from agvnav.positioning.ekf import EkfEstimator, ekf_predict, ekf_update
from agvnav.positioning.estimator import make_estimator
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import load_builtin_map

MOUNT = np.array([0.6, 0.0, 0.0])


def _spd(seed: int) -> np.ndarray:
    a = np.random.default_rng(seed).normal(size=(3, 3))
    return a @ a.T + 0.1 * np.eye(3)


@given(st.integers(0, 10_000))
def test_joseph_update_matches_information_form(seed: int) -> None:
    rng = np.random.default_rng(seed)
    P = _spd(seed)
    H = rng.normal(size=3)
    R = float(rng.uniform(0.01, 1.0))
    x = rng.normal(size=3)
    y = float(rng.normal())
    x_new, P_new = ekf_update(x, P, y, H, R)
    info = np.linalg.inv(P) + np.outer(H, H) / R
    np.testing.assert_allclose(P_new, np.linalg.inv(info), rtol=1e-9, atol=1e-12)
    expected = x + np.linalg.inv(info) @ H * y / R
    expected[2] = np.angle(np.exp(1j * expected[2]))
    np.testing.assert_allclose(x_new[:2], expected[:2], rtol=1e-9, atol=1e-12)
    assert abs(angle_diff(x_new[2], expected[2])) < 1e-9
    np.testing.assert_array_equal(P_new, P_new.T)


def test_update_vectorised_over_batch() -> None:
    P = np.stack([_spd(i) for i in range(4)])
    H = np.random.default_rng(1).normal(size=(4, 3))
    x = np.zeros((4, 3))
    xb, Pb = ekf_update(x, P, np.ones(4), H, np.full(4, 0.5))
    for i in range(4):
        xi, Pi = ekf_update(x[i], P[i], 1.0, H[i], 0.5)
        np.testing.assert_allclose(xb[i], xi, atol=1e-15)
        np.testing.assert_allclose(Pb[i], Pi, atol=1e-15)


def test_predict_is_f_p_ft_plus_q() -> None:
    P, F, Q = _spd(1), _spd(2), _spd(3)
    x, P_new = ekf_predict([0.0, 0.0, 4.0], P, F, Q)
    np.testing.assert_allclose(P_new, F @ P @ F.T + Q, atol=1e-12)
    assert -np.pi <= x[2] < np.pi


def _nees_runs(n_runs: int, seconds: float, seed: int) -> np.ndarray:
    """NEES of the EKF at sampled instants, ``(n_runs, n_samples)``, under matched Gaussian noise."""
    world = load_builtin_map("lab")
    gon = Goniometer(pulses_per_rev=2**30, mount=tuple(MOUNT))
    noise = OdometryNoise(k_d=1e-4, k_dtheta=1e-5, k_theta=1e-5)
    speed, omega, dt, sigma = 1.0, 0.1, 0.02, 5e-4
    out = []
    for k in range(n_runs):
        rng = np.random.default_rng([seed, k])
        start = np.array([4.0, 3.0, 0.2])
        P0 = np.diag([0.01, 0.01, 0.003]) ** 2
        est = EkfEstimator(
            world,
            MOUNT,
            bearing_std=sigma,
            bearing_offset=0.0,
            map_std=0.0,
            odometry_noise=noise,
            initial_pose=start + rng.multivariate_normal(np.zeros(3), P0),
            initial_covariance=P0,
        )
        # odometry noise matched to the filter's Q on each increment (Crowley, seed 002 §3.2)
        out.append(drive_nees(est, world, gon, start, speed, omega, seconds, dt, rng, noise, sigma, 10))
    return np.array(out)


def _assert_consistent(nees: np.ndarray) -> None:
    n = nees.shape[0]
    mean = nees.mean(axis=0)  # average over runs at each instant: n * mean ~ chi2(3n)
    lo, hi = chi2.ppf([0.001, 0.999], 3 * n) / n
    inside = (mean > lo) & (mean < hi)
    assert inside.mean() > 0.8, f"mean NEES {mean.round(2)} outside [{lo:.2f}, {hi:.2f}] too often"
    assert 2.0 < nees.mean() < 4.0


def test_ekf_nees_consistent_small() -> None:
    _assert_consistent(_nees_runs(12, 2.0, seed=11))


@pytest.mark.slow
def test_ekf_nees_consistent_large() -> None:
    _assert_consistent(_nees_runs(150, 4.0, seed=12))


def test_ekf_default_method_and_inspection() -> None:
    world = load_builtin_map("lab")
    est = make_estimator(world=world, mount=MOUNT, initial_pose=[4.0, 3.0, 0.2])
    assert isinstance(est, EkfEstimator) and est.method == "ekf"
    gon = Goniometer(mount=tuple(MOUNT))
    feed(est, world, gon, arc_pose_at(np.array([4.0, 3.0, 0.2]), 0.0, 0.0), 0.0, 0.0, 0.3)
    assert est.last_reflector >= 0 and np.isfinite(est.last_innovation) and est.last_nis < 10.83
