"""Bounds: bearing Jacobian vs numerical, CRLB, PDOP, encoder quantisation std."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.geometry import angle_diff, bearing_to
from agvnav.positioning import bearing_jacobian, crlb, encoder_bearing_std, fisher_information, pdop

R = np.array([[0.0, 10.0], [-8.0, -5.0], [9.0, -6.0], [6.0, 7.0]])


def test_jacobian_matches_central_differences():
    rng = np.random.default_rng(1)
    for pose in np.concatenate([rng.uniform(-4, 4, (5, 2)), rng.uniform(-3, 3, (5, 1))], axis=-1):
        jac = bearing_jacobian(R, pose)
        num = np.empty_like(jac)
        for k in range(3):
            dp = np.zeros(3)
            dp[k] = 1e-6
            num[:, k] = angle_diff(bearing_to(pose + dp, R), bearing_to(pose - dp, R)) / 2e-6
        np.testing.assert_allclose(jac, num, rtol=1e-7, atol=1e-9)


def test_encoder_std_is_step_over_root_12():
    assert encoder_bearing_std(65535) == pytest.approx(2 * math.pi / 65535 / math.sqrt(12), rel=1e-15)
    # seed 000 §4.1: 65535 pulses/rev, "0,095 mrad" resolution (2 pi / 65535 = 0.0959 mrad)
    assert 2 * math.pi / 65535 == pytest.approx(0.095e-3, rel=0.01)
    assert encoder_bearing_std(65535) == pytest.approx(2.7677e-5, rel=1e-4)
    rng = np.random.default_rng(0)
    step = 2 * math.pi / 1000
    angles = rng.uniform(-math.pi, math.pi, 200_000)
    error = np.round(angles / step) * step - angles
    assert np.std(error) == pytest.approx(encoder_bearing_std(1000), rel=0.01)
    with pytest.raises(ValueError, match="pulses_per_rev"):
        encoder_bearing_std(0)


def test_crlb_is_inverse_fisher_and_scales_with_variance():
    pose = np.array([1.0, 2.0, 0.3])
    c1 = crlb(R, pose, 1e-3)
    np.testing.assert_allclose(c1 @ fisher_information(R, pose, 1e-3), np.eye(3), atol=1e-9)
    np.testing.assert_allclose(crlb(R, pose, 2e-3), 4.0 * c1, rtol=1e-12)
    np.testing.assert_allclose(c1, c1.T, rtol=1e-12)
    assert np.all(np.linalg.eigvalsh(c1) > 0)
    assert pdop(R, pose) * 1e-3 == pytest.approx(math.sqrt(c1[0, 0] + c1[1, 1]), rel=1e-12)


def test_crlb_batches_and_per_reflector_std():
    poses = np.array([[1.0, 2.0, 0.3], [-2.0, 0.5, -1.0]])
    batch = crlb(R, poses, np.array([1e-3, 1e-3, 2e-3, 1e-3]))
    assert batch.shape == (2, 3, 3)
    one = crlb(R, poses[1], [1e-3, 1e-3, 2e-3, 1e-3])
    np.testing.assert_allclose(batch[1], one, rtol=1e-12)


def test_crlb_is_nan_when_unobservable():
    assert np.all(np.isnan(crlb(R[:2], np.array([1.0, 2.0, 0.3]), 1e-3)))
    # on the critical circle of three reflectors
    r = np.array([[0.0, 1.0], [-math.sqrt(3) / 2, -0.5], [math.sqrt(3) / 2, -0.5]])
    pose = np.array([math.cos(2.0), math.sin(2.0), 0.0])
    assert np.all(np.isnan(crlb(r, pose, 1e-3)))
