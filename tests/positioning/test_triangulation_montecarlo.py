"""Monte Carlo: least squares attains the CRLB; reported covariances match the scatter."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.geometry import angle_diff, bearing_to
from agvnav.positioning import crlb, encoder_bearing_std, triangulate

R5 = np.array([[0.0, 12.0], [-10.0, 4.0], [-7.0, -8.0], [8.0, -9.0], [11.0, 5.0]])
R3 = R5[[0, 2, 3]]


def _errors(method, reflectors, pose, sigma, trials, seed):
    rng = np.random.default_rng(seed)
    bearings = bearing_to(pose, reflectors) + rng.normal(0.0, sigma, (trials, len(reflectors)))
    fix = triangulate(reflectors, bearings, method, heading_estimate=pose[2] + 0.1, bearing_std=sigma)
    assert np.all(fix.valid)
    err = np.stack([fix.x - pose[0], fix.y - pose[1], angle_diff(fix.heading, pose[2])], axis=-1)
    return err, fix.covariance


def _check(err, cov, bound, rms_tol, cov_tol):
    rms_pos = np.sqrt(np.mean(err[:, 0] ** 2 + err[:, 1] ** 2))
    crlb_pos = np.sqrt(bound[0, 0] + bound[1, 1])
    assert rms_pos == pytest.approx(crlb_pos, rel=rms_tol)
    assert np.sqrt(np.mean(err[:, 2] ** 2)) == pytest.approx(np.sqrt(bound[2, 2]), rel=rms_tol)
    scatter = np.cov(err.T)
    mean_cov = np.mean(cov, axis=0)
    sd = np.sqrt(np.diag(mean_cov))
    # compare as normalised matrices: diagonal ratios and correlation differences
    np.testing.assert_allclose(np.diag(scatter) / np.diag(mean_cov), 1.0, atol=cov_tol)
    np.testing.assert_allclose(scatter / np.outer(sd, sd), mean_cov / np.outer(sd, sd), atol=cov_tol)


@pytest.mark.parametrize(("sigma", "pose"), [(1e-3, np.array([1.0, -2.0, 0.7])), (2e-3, np.array([-3.0, 3.0, -2.0]))])
def test_least_squares_rms_within_10_percent_of_crlb(sigma, pose):
    err, cov = _errors("least_squares", R5, pose, sigma, 3000, seed=11)
    _check(err, cov, crlb(R5, pose, sigma), rms_tol=0.1, cov_tol=0.1)


@pytest.mark.parametrize("method", ["absolute_angles", "relative_angles", "total"])
def test_three_reflector_methods_reach_the_crlb_at_encoder_noise(method):
    """With three bearings every exact method is first-order efficient (the issue asks <= 1.5x)."""
    sigma = encoder_bearing_std(65535)
    pose = np.array([0.5, 1.0, 2.0])
    err, cov = _errors(method, R3, pose, sigma, 3000, seed=12)
    _check(err, cov, crlb(R3, pose, sigma), rms_tol=0.1, cov_tol=0.1)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["least_squares", "absolute_angles", "total"])
def test_monte_carlo_over_many_poses(method):
    rng = np.random.default_rng(21)
    refl = R5 if method == "least_squares" else R3
    for pose in np.concatenate([rng.uniform(-5, 5, (8, 2)), rng.uniform(-3, 3, (8, 1))], axis=-1):
        err, cov = _errors(method, refl, pose, 1e-3, 40_000, seed=int(rng.integers(1 << 30)))
        _check(err, cov, crlb(refl, pose, 1e-3), rms_tol=0.03, cov_tol=0.05)
